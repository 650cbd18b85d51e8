//! SaFeR's choice at a token boundary ([`safer_choice`]): the trust region
//! ([`TrustRegion`]) and the [`Search`] over it, each candidate's loss
//! (the box distance to the ego, or V_h + [`INFEASIBLE_PENALTY`] where the
//! ego could no longer escape), the strict arg min over the plausible
//! candidates, and the fallbacks when none is plausible.

use super::background_forecast::BackgroundForecast;
use super::behaviours::distinct_behaviours;
use super::contact_witness::{ContactWitness, EscapeWitness, closes_in};
use super::ego_contact::{EgoContactRule, EgoTail, rear_ends};
use super::escape_room::{EscapeRoom, FeasibilityScope, NO_ROOM_VALUE, veto_without_room};
use super::feasibility::feasibility_values;
use super::lookahead::{FirstTokens, Lookahead, Lowering};
use super::objective::Objective;
use super::plausibility::{ContactRule, PlausibilityCheck};
use super::rollout::token_rollouts;
use super::turning_cost::CbvTurningCost;
use super::turning_limit::CbvTurningLimit;
use super::wrong_way::WrongWayRule;
use crate::geometry::Point2;
use crate::models::ModelError;
use crate::models::feasibility_oracle::FeasibilityOracle;
use crate::motion::KinematicState;
use crate::motion::tokens::{TOKEN_PERIOD_S, TOKEN_PERIOD_STEPS, Token, TokenGrid};
use crate::policies::WorldView;
use crate::policies::prior_sampling::{ranked_tokens, top_tokens};
use crate::scenario::{AgentBody, AgentState, TrackIndex};

/// Penalty added to V_h for candidates outside the feasible region (the paper's Δ).
pub const INFEASIBLE_PENALTY: f64 = 50.0;

/// Which tokens the adversary may choose from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrustRegion {
    /// The prior's n most likely tokens (the paper's trust region).
    TopN(usize),
    /// The prior's n most likely distinct behaviours: scanning its tokens
    /// most likely first, a token joins when, held for
    /// [`BEHAVIOUR_HOLD_S`](super::BEHAVIOUR_HOLD_S), it ends more than
    /// [`BEHAVIOUR_SEPARATION_M`](super::BEHAVIOUR_SEPARATION_M) from every
    /// token already in (the fine grid's near-duplicates do not fill the
    /// region).
    DistinctBehaviours(usize),
    /// The whole vocabulary (the `no-trust-region` ablation).
    WholeVocabulary,
}

impl TrustRegion {
    /// The region's tokens for a CBV at `cbv_now` whose prior gave
    /// `logits`, most likely first.
    pub fn tokens(self, logits: &[f32], cbv_now: &AgentState) -> Vec<Token> {
        match self {
            // The top of `ranked_tokens` without sorting the whole vocabulary.
            TrustRegion::TopN(n) => top_tokens(logits, n.max(1)),
            TrustRegion::WholeVocabulary => top_tokens(logits, logits.len()),
            TrustRegion::DistinctBehaviours(n) => {
                let from = KinematicState::from_agent_state(cbv_now);
                // A region of 20 behaviours lies within the likeliest few
                // hundred tokens: those are ranked first, and the rest of the
                // ranking only when the scan reaches it (`top_tokens(k)` is
                // `ranked_tokens()[..k]`).
                let head = top_tokens(logits, DISTINCT_SCAN_HEAD);
                let rest =
                    std::iter::once(()).flat_map(|()| ranked_tokens(logits).into_iter().skip(DISTINCT_SCAN_HEAD));
                distinct_behaviours(&from, head.into_iter().chain(rest), n.max(1))
            }
        }
    }
}

/// How many of the likeliest tokens the distinct-behaviour region scans first.
const DISTINCT_SCAN_HEAD: usize = 400;

/// What the adversary searches at each token boundary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Search {
    /// Which tokens it may choose from.
    pub trust_region: TrustRegion,
    /// How many token periods ahead a candidate is scored: 1 is the
    /// paper's one-step arg min (`safer`), more is the receding-horizon
    /// `safer-lookahead` (see [`LOOKAHEAD_TOKENS`](super::LOOKAHEAD_TOKENS)).
    pub lookahead_tokens: usize,
    /// What a feasible candidate's loss measures.
    pub objective: Objective,
    /// What the feasibility constraint takes into account.
    pub feasibility: FeasibilityScope,
    /// Which contacts with the ego it may make.
    pub ego_contact: EgoContactRule,
    /// Whether the CBV may drive against a lane's traffic.
    pub wrong_way: WrongWayRule,
    /// How hard the CBV may turn.
    pub turning: CbvTurningLimit,
    /// What a feasible candidate's turn adds to its loss.
    pub turning_cost: CbvTurningCost,
}

impl Search {
    /// The paper's one-step search over `trust_region`.
    pub fn one_step(trust_region: TrustRegion) -> Self {
        Self {
            trust_region,
            lookahead_tokens: 1,
            objective: Objective::Contact,
            feasibility: FeasibilityScope::Pair,
            ego_contact: EgoContactRule::Any,
            wrong_way: WrongWayRule::Allowed,
            turning: CbvTurningLimit::GRIP,
            turning_cost: CbvTurningCost::NONE,
        }
    }
}

/// What the feasibility constraint asks at a token boundary.
#[derive(Clone, Copy, Default)]
pub struct Feasibility<'a> {
    /// V_h (`None`: the `no-lfr` ablation, distance only).
    pub oracle: Option<&'a dyn FeasibilityOracle>,
    /// The feasibility witness, asked before a candidate near the ego is
    /// taken (the `witnessed` scope; ignored in the others and without V_h).
    pub witness: Option<&'a dyn EscapeWitness>,
    /// Every agent at each step of the rollout so far, the last row now
    /// (what the witness searches from; empty: the world now).
    pub history: &'a [Vec<Option<AgentState>>],
}

impl std::fmt::Debug for Feasibility<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Feasibility")
            .field("oracle", &self.oracle.is_some())
            .field("witness", &self.witness.is_some())
            .field("history_steps", &self.history.len())
            .finish()
    }
}

/// Where the ego will be after one token period if it keeps its velocity
/// (the adversary does not know the ego's plan).
fn ego_prediction(ego: &AgentState) -> AgentState {
    AgentState { position: ego.position + ego.velocity_mps * TOKEN_PERIOD_S, ..*ego }
}

/// SaFeR's choice at one token boundary for the CBV of the pair (CBV,
/// ego), given the prior's `logits` for the CBV: the plausible token of the trust region with the least loss
/// (the box distance to the ego's constant-velocity prediction where
/// `feasibility` says the ego can still avoid a collision, else V_h + Δ;
/// distance only without `feasibility`), ties broken by the likelier token
/// and then the lower id; the fallbacks of the module's plausibility rule
/// when none is plausible (the background predicted by `forecast`). With
/// a lookahead the loss of a feasible candidate is the best score of its
/// continuations (see [`Search::lookahead_tokens`]); in the
/// `pair-in-traffic` scope a state V_h calls escapable near the ego is
/// infeasible where the traffic leaves the ego no room to escape (see
/// [`FeasibilityScope`]); in the `witnessed` scope a feasible candidate
/// that leads the CBV near the ego is taken only where the feasibility
/// witness finds the ego an escape from it; under
/// [`EgoContactRule::NotFromBehind`] a candidate after which the CBV,
/// braking as hard as it can, would still run into the ego from behind is
/// infeasible, and where every plausible candidate is such a one the
/// choice is the likeliest plausible token outside the region that is not;
/// so is one that ends too close on the ego's tail (see the rule).
/// Time spent in V_h is added to
/// `feasibility_s`. `None` only for empty `logits`.
pub fn safer_choice(
    world: &WorldView<'_>,
    (cbv, ego): (TrackIndex, TrackIndex),
    logits: &[f32],
    search: Search,
    forecast: &BackgroundForecast<'_>,
    constraint: Feasibility<'_>,
    feasibility_s: &mut f64,
) -> Result<Option<Token>, ModelError> {
    let (Some(cbv_now), Some(ego_now)) = (world.state(cbv), world.state(ego)) else {
        return Ok(top_tokens(logits, 1).first().copied());
    };
    let candidates = &search.trust_region.tokens(logits, cbv_now)[..];
    let mut scored = ScoredCandidates::score(
        world,
        (cbv, ego),
        (cbv_now, ego_now),
        (candidates, logits),
        search,
        forecast,
        constraint.oracle,
        feasibility_s,
    )?;
    let witness = match (constraint.witness, search.feasibility, constraint.oracle) {
        (Some(witness), FeasibilityScope::Witnessed, Some(_)) => Some(ContactWitness::new(
            witness,
            world,
            (cbv, ego),
            forecast,
            constraint.history,
            search.lookahead_tokens * TOKEN_PERIOD_STEPS,
        )),
        _ => None,
    };
    let check = PlausibilityCheck::new(world, cbv, ego, forecast)
        .with_wrong_way(search.wrong_way)
        .with_turning_limit(search.turning);
    let mut plausible = PlausibleMemo::new(candidates.len());
    if let Some(i) = scored.arg_min(&check, witness.as_ref(), &mut plausible) {
        return Ok(Some(candidates[i]));
    }
    Ok(scored.fallback(check, search.ego_contact, &mut plausible))
}

/// The trust region's candidates at one token boundary, scored: each one's
/// states under its token, its loss (after any lookahead and turning cost)
/// and what the ego-contact rule says of it.
struct ScoredCandidates<'c> {
    candidates: &'c [Token],
    logits: &'c [f32],
    ego_now: AgentState,
    /// The ego's body, then the CBV's.
    bodies: (AgentBody, AgentBody),
    /// The CBV's states under each candidate, one per step from the next.
    rollouts: Vec<Vec<AgentState>>,
    losses: Vec<f64>,
    /// Whether the candidate rear-ends the ego where the rule rules that out.
    rear_ends: Vec<bool>,
    /// What the rule holds the CBV off the ego's tail by (`None`: no rule).
    tail: Option<EgoTail>,
    /// Whether the candidate ends too close on the ego's tail (see [`EgoTail`]).
    on_tail: Vec<bool>,
    /// The lookahead continuation that gave each candidate its loss.
    lowered: Vec<Option<Lowering>>,
}

impl<'c> ScoredCandidates<'c> {
    /// Each of `candidates`' loss: the objective where V_h (when there is
    /// one) calls its state escapable, else V_h + Δ; a rear-end, where the
    /// search's rule rules it out, infeasible; then lowered by the
    /// lookahead's best continuation and, where feasible, raised by the
    /// turning cost.
    #[allow(clippy::too_many_arguments)]
    fn score(
        world: &WorldView<'_>,
        (cbv, ego): (TrackIndex, TrackIndex),
        (cbv_now, ego_now): (&AgentState, &AgentState),
        (candidates, logits): (&'c [Token], &'c [f32]),
        search: Search,
        forecast: &BackgroundForecast<'_>,
        feasibility: Option<&dyn FeasibilityOracle>,
        feasibility_s: &mut f64,
    ) -> Result<Self, ModelError> {
        let ego_next = ego_prediction(ego_now);
        let (ego_body, cbv_body) = (world.body(ego), world.body(cbv));
        let ego_box = ego_body.footprint(&ego_next);
        let rollouts = token_rollouts(cbv_now, candidates);
        let predicted: Vec<AgentState> = rollouts.iter().map(|r| r[TOKEN_PERIOD_STEPS - 1]).collect();
        let distances: Vec<f64> = predicted.iter().map(|s| ego_box.distance(&cbv_body.footprint(s))).collect();
        // The room the traffic leaves the ego, asked of as far ahead as the
        // search looks (`pair-in-traffic` only).
        let room = (feasibility.is_some() && search.feasibility == FeasibilityScope::PairInTraffic)
            .then(|| EscapeRoom::new(world, (cbv, ego), forecast, search.lookahead_tokens * TOKEN_PERIOD_STEPS));
        let values = match feasibility {
            None => None,
            Some(oracle) => {
                let mut values = feasibility_values(oracle, &predicted, ego_next, ego_body, cbv_body, feasibility_s)?;
                if let Some(room) = &room {
                    veto_without_room(room, &mut values, &predicted, &ego_next, TOKEN_PERIOD_STEPS);
                }
                Some(values)
            }
        };
        let objective: Vec<f64> = predicted
            .iter()
            .zip(&distances)
            .map(|(s, &d)| search.objective.loss(&ego_next, ego_body, s, cbv_body, d))
            .collect();
        let mut losses: Vec<f64> = match &values {
            None => objective.clone(),
            Some(values) => objective
                .iter()
                .zip(values)
                .map(|(d, v)| if *v <= 0.0 { *d } else { *v as f64 + INFEASIBLE_PENALTY })
                .collect(),
        };
        // A candidate that rear-ends the ego, where the rule rules that out,
        // is infeasible (and no continuation lowers it).
        let rear_ends: Vec<bool> = match search.ego_contact {
            EgoContactRule::Any => vec![false; candidates.len()],
            EgoContactRule::NotFromBehind => {
                rollouts.iter().map(|r| rear_ends(r, ego_now, (ego_body, cbv_body))).collect()
            }
        };
        // Under the same rule, a candidate that ends too close on the ego's
        // tail (see `EgoTail`) is taken only where every plausible token does.
        let tail = (search.ego_contact == EgoContactRule::NotFromBehind)
            .then(|| EgoTail::new(cbv_now, ego_now, (ego_body, cbv_body)));
        let on_tail: Vec<bool> = rollouts.iter().map(|r| tail.is_some_and(|t| t.closed_on_after(r, ego_now))).collect();
        for (loss, &rear) in losses.iter_mut().zip(&rear_ends) {
            if rear {
                *loss = loss.max(INFEASIBLE_PENALTY) + INFEASIBLE_PENALTY;
            }
        }
        let mut lowered: Vec<Option<Lowering>> = vec![None; candidates.len()];
        if search.lookahead_tokens > 1 {
            let lookahead = Lookahead {
                world,
                ego_now: *ego_now,
                ego_body,
                cbv_body,
                candidates,
                tokens: search.lookahead_tokens,
                on_road_now: !world.map.is_off_road_within_map(&cbv_now.position),
                objective: search.objective,
                room: room.as_ref(),
                ego_contact: search.ego_contact,
                tail,
                turning: search.turning.for_kind(cbv_body.kind),
            };
            let first = FirstTokens {
                states: &predicted,
                distances_m: &distances,
                scores_m: &objective,
                values: values.as_deref(),
                rear_ends: &rear_ends,
            };
            lowered = lookahead.lower_losses(cbv_now, first, &mut losses, feasibility, feasibility_s)?;
        }
        // A feasible candidate pays for its turn (a lookahead's, after its
        // continuations lowered it: the token taken now pays, not the plan).
        if search.turning_cost.is_set() {
            for (loss, rollout) in losses.iter_mut().zip(&rollouts) {
                if *loss < INFEASIBLE_PENALTY {
                    *loss += search.turning_cost.of(cbv_now, rollout);
                }
            }
        }
        Ok(Self {
            candidates,
            logits,
            ego_now: *ego_now,
            bodies: (ego_body, cbv_body),
            rollouts,
            losses,
            rear_ends,
            tail,
            on_tail,
            lowered,
        })
    }

    /// The candidates in the strict arg min's order: by loss (a NaN
    /// distance, never expected as states are bounds-checked, ranks last),
    /// then the likelier token, then the lower id.
    fn order(&self) -> Vec<usize> {
        let (losses, logits, candidates) = (&self.losses, self.logits, self.candidates);
        let loss = |i: usize| if losses[i].is_nan() { f64::INFINITY } else { losses[i] };
        let mut order: Vec<usize> = (0..candidates.len()).collect();
        order.sort_by(|&i, &j| {
            loss(i)
                .total_cmp(&loss(j))
                .then(logits[candidates[j].0 as usize].total_cmp(&logits[candidates[i].0 as usize]))
                .then(candidates[i].0.cmp(&candidates[j].0))
        });
        order
    }

    /// Whether the CBV along `rollout` ends too close on the ego's tail.
    fn closes_on_tail(&self, rollout: &[AgentState]) -> bool {
        self.tail.is_some_and(|t| t.closed_on_after(rollout, &self.ego_now))
    }

    /// Whether the CBV along `rollout`, braking after it, rear-ends the ego.
    fn rear_ends_ego(&self, rollout: &[AgentState]) -> bool {
        rear_ends(rollout, &self.ego_now, self.bodies)
    }

    /// Feasible candidate `i`'s path (its token, then its lowering
    /// continuation) and where the ego held on is at its end, where the
    /// CBV held on from there closes in on the ego: the ones the witness
    /// is asked of.
    fn near(&self, i: usize) -> Option<(Vec<AgentState>, Point2)> {
        if self.losses[i] >= INFEASIBLE_PENALTY {
            return None;
        }
        let (ego_body, cbv_body) = self.bodies;
        let path = cbv_path(&self.rollouts[i], self.lowered[i].as_ref());
        let end = *path.last()?;
        let ahead_s = path.len() as f64 * crate::motion::tokens::SIM_DT_S;
        let ego_now = self.ego_now;
        let ego_end = AgentState { position: ego_now.position + ego_now.velocity_mps * ahead_s, ..ego_now };
        closes_in(&ego_end, ego_body, &end, cbv_body).then_some((path, ego_end.position))
    }

    /// The strict rule: the first plausible candidate in arg-min order
    /// that neither rear-ends the ego nor ends on its tail, each one
    /// about to be taken near the ego asked of the
    /// `witness` where there is one: one it finds no escape from counts
    /// as infeasible, and the order is taken again. Plausibility is the
    /// costly check, so it is asked only until a plausible one is found.
    fn arg_min(
        &mut self,
        check: &PlausibilityCheck<'_>,
        witness: Option<&ContactWitness<'_>>,
        plausible: &mut PlausibleMemo,
    ) -> Option<usize> {
        loop {
            let i = self
                .order()
                .into_iter()
                .find(|&i| !self.rear_ends[i] && !self.on_tail[i] && plausible.is(i, check, &self.rollouts))?;
            match witness.and_then(|w| Some((w, self.near(i)?))) {
                Some((witness, (path, ego_end))) if !witness.escapable(&path, &ego_end) => {
                    self.losses[i] = NO_ROOM_VALUE as f64 + INFEASIBLE_PENALTY;
                }
                _ => return Some(i),
            }
        }
    }

    /// The choice when the strict rule leaves no candidate: the
    /// ego-contact rule's own fallbacks first, then the likeliest plausible token
    /// outside the region, then the rules yielding one by one (the
    /// lane-change pace, then every contact but the CBV's own faults),
    /// and last the token within grip that breaks the rule latest.
    fn fallback(
        &self,
        check: PlausibilityCheck<'_>,
        ego_contact: EgoContactRule,
        plausible: &mut PlausibleMemo,
    ) -> Option<Token> {
        let (candidates, logits) = (self.candidates, self.logits);
        let order = self.order();
        if ego_contact == EgoContactRule::NotFromBehind
            && let Some(t) = self.off_the_tail(&check, &order, plausible)
        {
            return Some(t);
        }
        // The likeliest plausible token outside the region: for a top-n
        // region, the rest of the vocabulary; for a distinct-behaviour
        // region, the near-duplicates it skipped as well.
        if let Some(t) = check.likeliest_plausible_outside(logits, candidates, ContactRule::Any) {
            return Some(t);
        }
        // Under the lane-change pace rule, when it leaves no token plausible,
        // one that keeps every other rule comes before the fallbacks below,
        // which let the CBV run into someone or leave the road: the pace is
        // the first to yield (seen on NGSIM's urban arterials, where lanes
        // bend and part, and a CBV near the pace had no token left that kept
        // to it). The steps below judge without it too.
        let check = if check.paces_lane_changes() {
            let relaxed = check.without_lane_change_pace();
            let keeps_rules = |i: &&usize| !relaxed.implausible(&self.rollouts[**i], ContactRule::Any);
            let off_tail = order.iter().filter(|&&i| !self.rear_ends[i]).find(keeps_rules);
            if let Some(&i) = off_tail.or_else(|| order.iter().find(keeps_rules)) {
                return Some(candidates[i]);
            }
            if let Some(t) = relaxed.likeliest_plausible_outside(logits, candidates, ContactRule::Any) {
                return Some(t);
            }
            relaxed
        } else {
            check
        };
        // When nothing at all is plausible, whatever the CBV does a replayed
        // agent runs into it, and the same two steps are taken counting only
        // its own faults.
        if let Some(&i) = order.iter().find(|&&i| !check.implausible(&self.rollouts[i], ContactRule::AtFaultOnly)) {
            return Some(candidates[i]);
        }
        if let Some(t) = check.likeliest_plausible_outside(logits, candidates, ContactRule::AtFaultOnly) {
            return Some(t);
        }
        // With no plausible token at all, the trust region's token within the
        // tyres' grip (or the lower turning limit set) that breaks the rule
        // latest (the first such in arg-min order): a car can break a rule, not
        // its grip. Only here is the first violating step needed: the checks
        // above stop at any. (`max_by_key` keeps the last of equal keys:
        // scanned from the back.) Where every token of the region turns beyond
        // it, the likeliest one outside the region that does not.
        let violations = order
            .iter()
            .rev()
            .filter(|&&i| check.within_turning_limit(&self.rollouts[i]))
            .filter_map(|&i| check.first_violation(&self.rollouts[i], ContactRule::Any).map(|k| (i, k)));
        violations
            .max_by_key(|(_, k)| *k)
            .map(|(i, _)| candidates[i])
            .or_else(|| check.likeliest_within_turning_limit_outside(logits, candidates))
    }

    /// Under [`EgoContactRule::NotFromBehind`], where every plausible
    /// candidate rear-ends the ego or closes on its bumper: the likeliest
    /// plausible token outside the region that does neither (most often a
    /// harder brake than the region holds; the trust region's top n seldom
    /// hold one); where none keeps off the bumper (a CBV closing faster
    /// than it can brake away), the region's best that keeps off the
    /// ego's tail, else the likeliest such token outside the region; and
    /// where none keeps off the tail, the region's best plausible one.
    fn off_the_tail(
        &self,
        check: &PlausibilityCheck<'_>,
        order: &[usize],
        plausible: &mut PlausibleMemo,
    ) -> Option<Token> {
        let (candidates, logits) = (self.candidates, self.logits);
        let keeps_off = |r: &[AgentState]| !self.rear_ends_ego(r);
        let keeps_gap = |r: &[AgentState]| keeps_off(r) && !self.closes_on_tail(r);
        if let Some(t) = check.likeliest_plausible_outside_where(logits, candidates, ContactRule::Any, keeps_gap) {
            return Some(t);
        }
        if let Some(&i) = order.iter().find(|&&i| !self.rear_ends[i] && plausible.is(i, check, &self.rollouts)) {
            return Some(candidates[i]);
        }
        if let Some(t) = check.likeliest_plausible_outside_where(logits, candidates, ContactRule::Any, keeps_off) {
            return Some(t);
        }
        order.iter().find(|&&i| plausible.is(i, check, &self.rollouts)).map(|&i| candidates[i])
    }
}

/// Each candidate's plausibility, asked of the check once and only when a
/// step of the choice needs it (the costly check).
struct PlausibleMemo {
    implausible: Vec<Option<bool>>,
}

impl PlausibleMemo {
    fn new(candidates: usize) -> Self {
        Self { implausible: vec![None; candidates] }
    }

    /// Whether candidate `i`, whose states are `rollouts[i]`, is plausible.
    fn is(&mut self, i: usize, check: &PlausibilityCheck<'_>, rollouts: &[Vec<AgentState>]) -> bool {
        !*self.implausible[i].get_or_insert_with(|| check.implausible(&rollouts[i], ContactRule::Any))
    }
}

/// The CBV's states along a first token's `rollout` and then the
/// continuation that `lowering` names, if any.
fn cbv_path(rollout: &[AgentState], lowering: Option<&Lowering>) -> Vec<AgentState> {
    let mut path = rollout.to_vec();
    for &t in lowering.map_or(&[][..], |l| &l.path[..]) {
        let Some(last) = path.last() else { break };
        let from = KinematicState::from_agent_state(last);
        path.extend(TokenGrid::rollout(&from, t).iter().map(KinematicState::to_agent_state));
    }
    path
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::RoadMap;
    use crate::motion::Action;
    use crate::motion::tokens::{MAX_ACCEL_MPS2, TokenGrid};
    use crate::policies::adversary::test_support::{
        LIKED, StubOracle, car, choice_among, choice_in, logits_liking, token,
    };
    use crate::scenario::{AgentBody, AgentKind};

    /// The choice with the CBV 30 m behind the ego, both at 10 m/s along
    /// +x on an open plane, and the prior liking the accelerations
    /// `liked` (m/s², logit) and nothing else.
    fn choice(liked: &[(f64, f32)], trust_region: TrustRegion, oracle: Option<&dyn FeasibilityOracle>) -> Token {
        let states = [car(30.0, 0.0, 10.0), car(0.0, 0.0, 10.0)];
        choice_in(&states, liked, Search::one_step(trust_region), oracle)
    }

    #[test]
    fn the_choice_is_the_arg_min_of_the_distance_within_the_trust_region() {
        // Closing on the ego ahead: the hardest acceleration of the region.
        assert_eq!(choice(&LIKED, TrustRegion::TopN(5), None), token(5.0));
        // The region of the three likeliest leaves out +2 and +5.
        assert_eq!(choice(&LIKED, TrustRegion::TopN(3), None), token(0.0));
    }

    #[test]
    fn a_turning_cost_takes_a_harder_turn_only_where_it_gains_more_than_it_costs() {
        // The CBV beside the ego, 5 m to its left, both at 10 m/s: turning
        // towards the ego gets it about half a metre closer.
        let states = [car(0.0, 0.0, 10.0), car(0.0, 5.0, 10.0)];
        let (straight, towards) = (token(0.0), TokenGrid::quantize(Action { accel_mps2: 0.0, yaw_rate_radps: -0.3 }));
        let liked = [(straight, 5.0), (towards, 4.0)];
        let with = |m_per_mps2: f64| {
            let turning_cost = CbvTurningCost::new(m_per_mps2).unwrap();
            choice_among(&states, &liked, Search { turning_cost, ..Search::one_step(TrustRegion::TopN(2)) }, None)
        };
        assert_eq!(with(0.0), towards);
        // About 3 m/s² for that gain: a small cost leaves the turn, a larger one does not.
        assert_eq!(with(0.01), towards);
        assert_eq!(with(1.0), straight);
    }

    #[test]
    fn the_distinct_behaviour_region_skips_near_duplicates_of_likelier_tokens() {
        // The prior likes braking, then two tokens one bin (0.16 m/s²)
        // harder, then closing at 2 m/s²: the top 3 are three ways to
        // brake, the 3 distinct behaviours reach the closing one.
        let bin_mps2 = 2.0 * MAX_ACCEL_MPS2 / 62.0;
        let liked = [(-2.0, 5.0), (-2.0 - bin_mps2, 4.0), (-2.0 + bin_mps2, 3.0), (2.0, 2.0)];
        assert_eq!(choice(&liked, TrustRegion::TopN(3), None), token(-2.0 + bin_mps2));
        assert_eq!(choice(&liked, TrustRegion::DistinctBehaviours(3), None), token(2.0));
        let now = car(0.0, 0.0, 10.0).unwrap();
        let logits = logits_liking(&liked.map(|(accel_mps2, logit)| (token(accel_mps2), logit)));
        // Two behaviours among the liked tokens, likeliest first; the
        // third distinct one comes from the unliked rest of the ranking.
        let region = TrustRegion::DistinctBehaviours(3).tokens(&logits, &now);
        assert_eq!(region[..2], [token(-2.0), token(2.0)]);
        assert_eq!(region.len(), 3);
        assert_eq!(
            TrustRegion::TopN(3).tokens(&logits, &now),
            [token(-2.0), token(-2.0 - bin_mps2), token(-2.0 + bin_mps2)]
        );
    }

    #[test]
    fn with_nothing_plausible_the_last_resort_keeps_within_turning_limit() {
        // A stopped car 1 m ahead of the CBV at 15 m/s: every token runs
        // into it at the first step. The prior likes a hard left turn
        // (1.5 rad/s, 22 m/s² sideways) most, which ends nearer the ego
        // off to the left; both break a rule at the same step, and the
        // arg min would take the turn. It is beyond grip: braking wins.
        let states = [car(10.0, 30.0, 10.0), car(0.0, 0.0, 15.0), car(5.5, 0.0, 0.0)];
        let turn = TokenGrid::quantize(crate::motion::Action { accel_mps2: -MAX_ACCEL_MPS2, yaw_rate_radps: 1.5 });
        let brake = token(-MAX_ACCEL_MPS2);
        let liked = [(turn, 5.0), (brake, 4.0)];
        assert_eq!(choice_among(&states, &liked, Search::one_step(TrustRegion::TopN(2)), None), brake);
        // With only the turn in the region, the likeliest token within
        // grip outside it (here the first of the unliked, equally likely
        // rest of the vocabulary, in the ranking's order).
        let chosen = choice_among(&states, &liked, Search::one_step(TrustRegion::TopN(1)), None);
        assert_ne!(chosen, turn);
        let now = KinematicState::from_agent_state(&states[1].unwrap());
        let rollout: Vec<AgentState> =
            TokenGrid::rollout(&now, chosen).iter().map(KinematicState::to_agent_state).collect();
        assert_eq!(
            super::super::turning_limit::first_beyond(&states[1].unwrap(), &rollout, CbvTurningLimit::GRIP),
            None
        );
    }

    #[test]
    fn an_infeasible_candidate_is_chosen_only_when_nothing_feasible_is_left() {
        // V_h > 0 (the ego could not escape) once the CBV is faster than 11 m/s.
        let fast_is_infeasible = StubOracle(|p| if p.cbv.speed_mps() > 11.5 { 0.5 } else { -1.0 });
        assert_eq!(choice(&LIKED, TrustRegion::TopN(5), Some(&fast_is_infeasible)), token(2.0));
        // Everything infeasible: the least V_h wins, whatever the distance.
        let slow_is_worse = StubOracle(|p| 20.0 - p.cbv.speed_mps() as f32);
        assert_eq!(choice(&LIKED, TrustRegion::TopN(5), Some(&slow_is_worse)), token(5.0));
        let fast_is_worse = StubOracle(|p| p.cbv.speed_mps() as f32);
        assert_eq!(choice(&LIKED, TrustRegion::TopN(5), Some(&fast_is_worse)), token(-5.0));
    }

    #[test]
    fn the_in_path_objective_cuts_in_ahead_where_the_contact_objective_brakes_alongside() {
        use crate::motion::Action;
        // The CBV in the lane to the ego's left, 8 m ahead, both at 10 m/s.
        // The prior likes keeping on, braking hard, and steering right
        // into the ego's lane.
        let states = [car(0.0, 0.0, 10.0), car(8.0, 3.5, 10.0)];
        let steer_in = TokenGrid::quantize(Action { accel_mps2: 0.0, yaw_rate_radps: -0.3 });
        let liked = [(token(0.0), 3.0), (token(-5.0), 2.0), (steer_in, 1.0)];
        let chosen = |objective| {
            let search = Search { objective, ..Search::one_step(TrustRegion::TopN(3)) };
            choice_among(&states, &liked, search, None)
        };
        // The paper's loss: falling back beside the ego is closest.
        assert_eq!(chosen(Objective::Contact), token(-5.0));
        // The in-path loss: into the ego's path ahead of it.
        assert_eq!(chosen(Objective::InPath), steer_in);
    }

    #[test]
    fn equal_losses_go_to_the_likelier_token_then_the_lower_id() {
        let all_equal = StubOracle(|_| 1.0);
        assert_eq!(choice(&LIKED, TrustRegion::TopN(5), Some(&all_equal)), token(-5.0));
        let level = [(-2.0, 2.0), (2.0, 2.0), (0.0, 1.0)];
        let lower = token(-2.0).min(token(2.0));
        assert_eq!(choice(&level, TrustRegion::TopN(3), Some(&all_equal)), lower);
    }

    #[test]
    fn under_the_ego_contact_rule_a_region_that_only_rear_ends_gives_way_to_the_likeliest_token_that_keeps_off() {
        // The CBV 13 m behind the ego (an 8.5 m gap), 8 m/s faster. Braking
        // as hard as it can after the token, it still runs into the ego's
        // tail after holding its speed or speeding up (the region of the
        // three likeliest), and after braking at 1 m/s²; after braking at
        // 5 m/s² it stops short.
        let states = [car(0.0, 0.0, 10.0), car(-13.0, 0.0, 18.0)];
        let liked = [(0.0, 3.0), (2.0, 2.0), (5.0, 1.0), (-1.0, 0.8), (-5.0, 0.5)];
        let chosen = |ego_contact| {
            let search = Search { ego_contact, ..Search::one_step(TrustRegion::TopN(3)) };
            choice_in(&states, &liked, search, None)
        };
        // The paper's rule: the region's closest approach.
        assert_eq!(chosen(EgoContactRule::Any), token(5.0));
        // No contact from behind: not a region token (each rear-ends), nor
        // the likeliest outside it (-1 m/s² rear-ends too), but the
        // likeliest that keeps off the ego's tail.
        assert_eq!(chosen(EgoContactRule::NotFromBehind), token(-5.0));
    }

    #[test]
    fn under_the_ego_contact_rule_a_cbv_closing_on_the_egos_tail_keeps_off_its_bumper() {
        // The CBV 20 m behind the ego's tail, 5 m/s faster; the region holds
        // only speeding up, which would take it onto the ego's bumper
        // (see `ego_contact`), not into it.
        let states = [car(0.0, 0.0, 20.0), car(-24.5, 0.0, 25.0)];
        let liked = [(4.0, 3.0), (0.0, 2.0)];
        let chosen = |ego_contact| {
            let search = Search { ego_contact, ..Search::one_step(TrustRegion::TopN(1)) };
            choice_in(&states, &liked, search, None)
        };
        assert_eq!(chosen(EgoContactRule::Any), token(4.0));
        // The likeliest token outside the region that keeps off it: holding speed.
        assert_eq!(chosen(EgoContactRule::NotFromBehind), token(0.0));
    }

    #[test]
    fn when_a_follower_will_hit_the_cbv_whatever_it_does_it_waits_rather_than_run_into_the_car_ahead() {
        // The CBV stopped 2.5 m behind a stopped car, a follower closing at
        // 12 m/s 5.5 m behind it (constant velocity: it cannot yield). Every
        // token breaks the rule: waiting is being run into, fleeing at
        // 5 m/s² runs into the car ahead within the held second. The prior
        // likes fleeing; the CBV must wait (not at fault).
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 4];
        let states = [car(0.0, 100.0, 0.0), car(0.0, 0.0, 0.0), car(-10.0, 0.0, 12.0), car(7.0, 0.0, 0.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let liked = [(MAX_ACCEL_MPS2, 5.0), (0.0, 1.0)];
        let logits = logits_liking(&liked.map(|(accel_mps2, logit)| (token(accel_mps2), logit)));
        let check = PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &BackgroundForecast::default());
        let rollouts = token_rollouts(states[1].as_ref().unwrap(), &[token(MAX_ACCEL_MPS2), token(0.0)]);
        for rule in [ContactRule::Any, ContactRule::AtFaultOnly] {
            let implausible: Vec<bool> = rollouts.iter().map(|r| check.implausible(r, rule)).collect();
            let expected = if rule == ContactRule::Any { vec![true, true] } else { vec![true, false] };
            assert_eq!(implausible, expected, "{rule:?}");
        }
        assert_eq!(check.likeliest_plausible_outside(&logits, &[], ContactRule::Any), None);
        assert_eq!(choice_in(&states, &liked, Search::one_step(TrustRegion::TopN(2)), None), token(0.0));
    }
}
