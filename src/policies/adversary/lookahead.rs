//! The receding-horizon search of `safer-lookahead` and
//! `safer-in-path-lookahead` ([`Lookahead`]): a first token scored by the
//! best its continuations reach over [`LOOKAHEAD_TOKENS`] token periods
//! under the search's objective, inside the same constraints as the
//! one-step choice.

use super::continuations::{Child, Continuations};
use super::ego_contact::{EgoContactRule, EgoTail};
use super::escape_room::{EscapeRoom, veto_without_room};
use super::feasibility::feasibility_values;
use super::objective::Objective;
use super::turning_limit::CbvTurningLimit;
use crate::models::ModelError;
use crate::models::feasibility_oracle::FeasibilityOracle;
use crate::motion::KinematicState;
use crate::motion::tokens::{TOKEN_PERIOD_S, TOKEN_PERIOD_STEPS, Token, TokenGrid};
use crate::policies::WorldView;
use crate::scenario::AgentState;

/// How many token periods `safer-lookahead` scores ahead (1.5 s).
pub const LOOKAHEAD_TOKENS: usize = 3;

/// What `safer-lookahead` adds to a continuation's score per token period
/// after the first, m: of two equally close approaches the sooner wins.
pub const LOOKAHEAD_DELAY_PENALTY_M: f64 = 0.5;

/// The receding-horizon search of `safer-lookahead` and
/// `safer-in-path-lookahead` (beyond the paper).
///
/// One-step greed steers the CBV at where the ego will be in 0.5 s and
/// stops it at the edge of the feasible set, where it hovers beside the
/// ego: the conflict is threatened, not made. The lookahead scores a
/// first token by the best its continuations reach over `tokens` token
/// periods, with the ego at constant velocity and inside the same
/// constraints:
/// - every continuation token comes from the same trust region (the
///   prior's current top n stands in for its later ones, which would need
///   the prior run on hypothetical histories);
/// - a continuation ends at its first state where V_h > 0, that leaves
///   the road, or that a token beyond the CBV's turning limit (the tyres'
///   grip unless lower) reaches; only a *contact* with the ego may end it infeasibly, and
///   only straight from a feasible state (V_h ≤ 0: the ego could still
///   have escaped one token earlier, and it is that escape the witness
///   later looks for), and not from behind the ego where the search's
///   [`EgoContactRule`] rules that out (under which a continuation also
///   ends where it comes too close on the ego's tail).
///
/// A continuation scores its objective (the paper's: its distance to the
/// ego) plus [`LOOKAHEAD_DELAY_PENALTY_M`] per token after the first
/// (sooner is better). A contact scores what the objective makes of it: 0
/// for the paper's, and for the in-path ones 0 ahead of the ego and the
/// not-ahead penalty beside or behind it, so that running into the ego's
/// side does not outrank getting into its path. A first token takes the
/// least score of its continuations when below its one-step loss. The
/// search is a beam as wide as the trust region ranked by score, a pure
/// function of the world like the one-step choice.
pub(super) struct Lookahead<'a> {
    pub(super) world: &'a WorldView<'a>,
    pub(super) ego_now: AgentState,
    pub(super) ego_body: crate::scenario::AgentBody,
    pub(super) cbv_body: crate::scenario::AgentBody,
    /// The trust region, most likely first.
    pub(super) candidates: &'a [Token],
    /// How many token periods ahead (at least 1).
    pub(super) tokens: usize,
    /// Whether the CBV is on the road now (then a continuation must stay on it).
    pub(super) on_road_now: bool,
    /// What a continuation's score measures (the one-step loss's objective).
    pub(super) objective: Objective,
    /// The room the traffic leaves the ego (`pair-in-traffic` only).
    pub(super) room: Option<&'a EscapeRoom<'a>>,
    /// Whether a contact from behind the ego is a conflict (see [`EgoContactRule`]).
    pub(super) ego_contact: EgoContactRule,
    /// The ego's tail the CBV keeps off (`None`: the rule allows the bumper).
    pub(super) tail: Option<EgoTail>,
    /// How hard the CBV may turn, for its kind (a continuation beyond it is no plan).
    pub(super) turning: CbvTurningLimit,
}

/// The one-step search's results for each candidate of the trust region.
pub(super) struct FirstTokens<'a> {
    /// Where the CBV ends the token.
    pub(super) states: &'a [AgentState],
    /// Its box distance to the ego's prediction there, m.
    pub(super) distances_m: &'a [f64],
    /// Its objective there (the box distance for the paper's), m.
    pub(super) scores_m: &'a [f64],
    /// V_h there (`None`: no feasibility constraint).
    pub(super) values: Option<&'a [f32]>,
    /// Whether it runs into the ego from behind where the search's
    /// [`EgoContactRule`] rules that out (then it is never lowered).
    pub(super) rear_ends: &'a [bool],
}

/// One continuation of the beam: which first token it extends, where the
/// CBV is at its end and its objective there (the beam keeps the best).
struct Continuation {
    root: usize,
    /// Its tokens after the first token.
    path: Vec<Token>,
    state: KinematicState,
    score_m: f64,
}

/// The tokens after the first token of `child`: its parent's in the
/// beam, then its own.
fn path_of(child: &Child, beam: &[Continuation]) -> Vec<Token> {
    let parent = &beam[child.parent].path;
    let mut path = Vec::with_capacity(parent.len() + 1);
    path.extend_from_slice(parent);
    path.push(child.token);
    path
}

/// The continuation that gave a first token its loss.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Lowering {
    /// Its tokens after the first token (none: a contact in the first token).
    pub(super) path: Vec<Token>,
    /// Its box distance to the ego's prediction at its end, m.
    pub(super) distance_m: f64,
}

/// How many of a first token's lowering continuations [`best_kept`] asks
/// about a round: most first tokens keep their best, and a round asks all
/// the first tokens' together (one V_h batch).
const LOWERING_ASKED_PER_ROUND: usize = 2;

/// Of the `lowering` continuations, each first token's best kept one (by
/// its loss, its score plus `delay_m`; ties to the order they were made
/// in), as `(first token, continuation)`. `judge` answers for a batch
/// whether each is kept; each first token's are asked best first, a few a
/// round, until one is kept or none is left. The same as judging them all
/// and keeping, in the order they were made, each that lowers its first
/// token's loss further, with far fewer questions where many would lower it.
fn best_kept(
    children: &Continuations,
    lowering: &[usize],
    delay_m: f64,
    mut judge: impl FnMut(&[usize]) -> Result<Vec<bool>, ModelError>,
) -> Result<Vec<(usize, usize)>, ModelError> {
    let mut by_root: std::collections::BTreeMap<usize, Vec<(f64, usize)>> = Default::default();
    for &i in lowering {
        let loss_m = children.score_m(i).max(0.0) + delay_m;
        by_root.entry(children.child(i).root).or_default().push((loss_m, i));
    }
    let mut pending: Vec<(usize, std::vec::IntoIter<(f64, usize)>)> = by_root
        .into_iter()
        .map(|(root, mut ranked)| {
            ranked.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            (root, ranked.into_iter())
        })
        .collect();
    let mut best = Vec::new();
    while !pending.is_empty() {
        let round: Vec<(usize, Vec<usize>)> = pending
            .iter_mut()
            .map(|(root, ranked)| (*root, ranked.by_ref().take(LOWERING_ASKED_PER_ROUND).map(|(_, i)| i).collect()))
            .collect();
        let asked: Vec<usize> = round.iter().flat_map(|(_, asked)| asked.iter().copied()).collect();
        // The answers come back in the order asked: each first token's in turn.
        let mut answers = judge(&asked)?.into_iter();
        let mut settled = Vec::with_capacity(round.len());
        for (root, asked) in &round {
            let kept: Vec<bool> = answers.by_ref().take(asked.len()).collect();
            let first_kept = asked.iter().zip(&kept).find(|&(_, &k)| k).map(|(&i, _)| i);
            if let Some(i) = first_kept {
                best.push((*root, i));
            }
            settled.push(first_kept.is_some());
        }
        let mut settled = settled.into_iter();
        pending.retain(|(_, ranked)| !settled.next().unwrap_or(true) && ranked.len() > 0);
    }
    Ok(best)
}

impl Lookahead<'_> {
    /// Lowers each candidate's one-step loss in `losses` to the best score
    /// of its continuations (see [`Lookahead`]); returns, for each, the
    /// continuation that lowered it (`None`: its one-step loss stands).
    pub(super) fn lower_losses(
        &self,
        cbv_now: &AgentState,
        first: FirstTokens<'_>,
        losses: &mut [f64],
        feasibility: Option<&dyn FeasibilityOracle>,
        feasibility_s: &mut f64,
    ) -> Result<Vec<Option<Lowering>>, ModelError> {
        let mut lowered: Vec<Option<Lowering>> = vec![None; losses.len()];
        let feasible = |i: usize| first.values.is_none_or(|v| v[i] <= 0.0);
        self.lower_first_token_contacts(cbv_now, &first, (losses, &mut lowered), feasibility, feasibility_s)?;
        let mut beam: Vec<Continuation> = (0..first.states.len())
            .filter(|&i| feasible(i) && first.distances_m[i] > 0.0 && !first.rear_ends[i])
            .map(|i| Continuation {
                root: i,
                path: Vec::new(),
                state: KinematicState::from_agent_state(&first.states[i]),
                score_m: first.scores_m[i],
            })
            .collect();
        Self::keep_best(&mut beam, self.candidates.len());
        let largest_action = TokenGrid::largest_action(self.candidates);
        for depth in 2..=self.tokens {
            let ahead_s = TOKEN_PERIOD_S * depth as f64;
            let ahead_steps = TOKEN_PERIOD_STEPS * depth;
            let ego =
                AgentState { position: self.ego_now.position + self.ego_now.velocity_mps * ahead_s, ..self.ego_now };
            let delay_m = LOOKAHEAD_DELAY_PENALTY_M * (depth - 1) as f64;
            let lowers = |score_m: f64, root: usize| score_m.max(0.0) + delay_m < losses[root];
            // At the last depth a continuation counts only if it lowers its
            // first token's loss: a member none of whose continuations can,
            // by where its tokens can take the CBV, is not continued (most
            // of them; the same search).
            let last = depth == self.tokens;
            let can_lower = |c: &Continuation| {
                let within = TokenGrid::rollout_end_reach(&c.state, largest_action);
                lowers(self.objective.loss_lower_bound_within(&ego, self.ego_body, within, self.cbv_body), c.root)
            };
            let mut children = Continuations::new(
                beam.iter().enumerate().filter(|(_, c)| !last || can_lower(c)).map(|(p, c)| (p, (c.root, c.state))),
                self.candidates,
                ego,
                (self.ego_body, self.cbv_body),
                self.objective,
            );
            // The ones that would lower their first token's loss: exact
            // scores only where a bound leaves it open.
            let lowering: Vec<usize> = (0..children.len())
                .filter(|&i| {
                    let root = children.child(i).root;
                    lowers(children.score_unless(i, |s| !lowers(s, root)), root)
                })
                .collect();
            // Whether a continuation stays on the road and is feasible (or
            // a contact) is asked only of those whose answer can change the
            // outcome. Of the ones that would lower their first token's
            // loss, only the best kept counts: each first token's are asked
            // best first (ties to the order they were made in, as a pass in
            // that order keeping strict improvements would settle them), a
            // few a round, until one is kept. A contact scores what the
            // objective makes of it: 0 for the paper's, the not-ahead
            // penalty for the in-path ones' CBV running into the ego from
            // behind or the side.
            let mut kept = vec![None; children.len()];
            let best = best_kept(&children, &lowering, delay_m, |batch: &[usize]| {
                self.judge(&children, batch, &mut kept, (ego, ahead_steps), feasibility, feasibility_s)?;
                Ok(batch.iter().map(|&i| kept[i] == Some(true)).collect())
            })?;
            for (root, i) in best {
                let c = children.child(i);
                losses[root] = children.score_m(i).max(0.0) + delay_m;
                lowered[root] = Some(Lowering { path: path_of(c, &beam), distance_m: children.distance_m(i) });
            }
            // Then the best-scored until the next beam is full (none at the
            // last depth). The rest are never kept, whatever the answer: the
            // same search, with a fraction of the V_h queries. The next
            // beam's candidates come in score order (non-contacts only, ties
            // to the likelier first token, then the order they were made in).
            let width = if depth < self.tokens { self.candidates.len() } else { 0 };
            let next_beam =
                self.best_scored_kept(&mut children, &mut kept, width, (ego, ahead_steps), feasibility, feasibility_s)?;
            beam = next_beam
                .into_iter()
                .map(|i| {
                    let c = children.child(i);
                    Continuation { root: c.root, path: path_of(c, &beam), state: c.state, score_m: children.score_m(i) }
                })
                .collect();
        }
        Ok(lowered)
    }

    /// Lowers to its score (0 for the paper's) the loss of each first
    /// token that ends in a contact with the ego (not a rear-end the rule
    /// rules out) although V_h calls its end infeasible, where the CBV's
    /// state now is feasible: a contact straight from a feasible state,
    /// which the ego could have escaped. Nothing without V_h.
    fn lower_first_token_contacts(
        &self,
        cbv_now: &AgentState,
        first: &FirstTokens<'_>,
        (losses, lowered): (&mut [f64], &mut [Option<Lowering>]),
        feasibility: Option<&dyn FeasibilityOracle>,
        feasibility_s: &mut f64,
    ) -> Result<(), ModelError> {
        let (Some(oracle), Some(values)) = (feasibility, first.values) else { return Ok(()) };
        let mut now =
            feasibility_values(oracle, &[*cbv_now], self.ego_now, self.ego_body, self.cbv_body, feasibility_s)?;
        if let Some(room) = self.room {
            veto_without_room(room, &mut now, &[*cbv_now], &self.ego_now, 0);
        }
        if now[0] <= 0.0 {
            for (i, loss) in losses.iter_mut().enumerate() {
                if values[i] > 0.0 && first.distances_m[i] <= 0.0 && !first.rear_ends[i] {
                    *loss = first.scores_m[i].max(0.0);
                    lowered[i] = Some(Lowering { path: Vec::new(), distance_m: first.distances_m[i] });
                }
            }
        }
        Ok(())
    }

    /// The next beam: up to `width` of `children`, best scored first (see
    /// [`Continuations::extend_order`]), that [`Self::judge`] keeps
    /// (answers into `kept`), judged a batch at a time only until the beam
    /// is full. A contact ends its continuation; the beam keeps the best of
    /// the rest.
    fn best_scored_kept(
        &self,
        children: &mut Continuations,
        kept: &mut [Option<bool>],
        width: usize,
        ego_ahead: (AgentState, usize),
        feasibility: Option<&dyn FeasibilityOracle>,
        feasibility_s: &mut f64,
    ) -> Result<Vec<usize>, ModelError> {
        let mut order: Vec<usize> = Vec::with_capacity(width);
        let mut next_beam: Vec<usize> = Vec::with_capacity(width);
        let mut asked = 0;
        loop {
            children.extend_order(&mut order, asked + width - next_beam.len());
            if next_beam.len() >= width || asked >= order.len() {
                return Ok(next_beam);
            }
            let batch: Vec<usize> = order[asked..].iter().take(width - next_beam.len()).copied().collect();
            asked += batch.len();
            self.judge(children, &batch, kept, ego_ahead, feasibility, feasibility_s)?;
            next_beam.extend(batch.into_iter().filter(|&i| kept[i] == Some(true)));
        }
    }

    /// Judges each of `which` not judged yet into `kept`: `false` when it
    /// leaves the road (where the CBV is on it now), turns beyond the
    /// CBV's turning limit, or is a contact from behind the ego or too
    /// close on its tail where the search's [`EgoContactRule`] rules that out, else
    /// `true` for a contact (which may end infeasibly: its parent was feasible, so the
    /// ego could have escaped it) or with V_h ≤ 0 there against the ego at
    /// `ego`, `ahead_steps` steps ahead (and, in the `pair-in-traffic`
    /// scope, room for it to escape).
    fn judge(
        &self,
        children: &Continuations,
        which: &[usize],
        kept: &mut [Option<bool>],
        (ego, ahead_steps): (AgentState, usize),
        feasibility: Option<&dyn FeasibilityOracle>,
        feasibility_s: &mut f64,
    ) -> Result<(), ModelError> {
        let mut ask = Vec::new();
        for &i in which {
            if kept[i].is_some() {
                continue;
            }
            let at = children.child(i).at;
            let leaves_road = || self.on_road_now && self.world.map.is_off_road_within_map(&at.position);
            // A contact from behind, where the rule rules it out, is no
            // conflict, nor a plan through the ego's bumper.
            let on_tail = || {
                self.ego_contact == EgoContactRule::NotFromBehind
                    && children.distance_m(i) <= 0.0
                    && super::ego_contact::from_behind(&ego, &at)
                    || self.tail.is_some_and(|t| t.closed_on(&at, &ego))
            };
            // A token beyond the turning limit is one the CBV will not be
            // allowed to drive: a plan through it is no plan.
            if leaves_road() || children.child(i).beyond(self.turning) || on_tail() {
                kept[i] = Some(false);
            } else if feasibility.is_none() || children.distance_m(i) <= 0.0 {
                kept[i] = Some(true);
            } else {
                kept[i] = Some(false);
                ask.push(i);
            }
        }
        if let Some(oracle) = feasibility
            && !ask.is_empty()
        {
            let states: Vec<AgentState> = ask.iter().map(|&i| children.child(i).at).collect();
            let mut values = feasibility_values(oracle, &states, ego, self.ego_body, self.cbv_body, feasibility_s)?;
            if let Some(room) = self.room {
                veto_without_room(room, &mut values, &states, &ego, ahead_steps);
            }
            for (&i, v) in ask.iter().zip(values) {
                kept[i] = Some(v <= 0.0);
            }
        }
        Ok(())
    }

    /// Keeps the `width` continuations of the best score (ties: the
    /// likelier first token, then the order they were made in).
    fn keep_best(beam: &mut Vec<Continuation>, width: usize) {
        beam.sort_by(|a, b| Self::rank((a.score_m, a.root), (b.score_m, b.root)));
        beam.truncate(width);
    }

    /// The beam's order: the better score first, ties to the likelier
    /// first token (a stable sort then keeps the order they were made in).
    fn rank((score_a, root_a): (f64, usize), (score_b, root_b): (f64, usize)) -> std::cmp::Ordering {
        score_a.total_cmp(&score_b).then(root_a.cmp(&root_b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::policies::adversary::test_support::{LIKED, StubOracle, car, choice_among, choice_in, token};
    use crate::policies::adversary::{EgoCbvState, Search, TrustRegion};

    /// The box gap between the ego and the CBV of a feasibility query, m.
    fn gap_m(p: &EgoCbvState) -> f64 {
        p.ego_body.footprint(&p.ego).distance(&p.cbv_body.footprint(&p.cbv))
    }

    /// The CBV 2.5 m (box gap) behind the ego, closing at 4 m/s: after one
    /// token at +5 m/s² it touches the ego's prediction, at +2 m/s² it is
    /// about 0.25 m from it, holding speed 0.5 m.
    const CLOSING: [Option<AgentState>; 2] = [
        Some(AgentState {
            position: crate::geometry::Point2::new(7.0, 0.0),
            heading_rad: 0.0,
            velocity_mps: crate::geometry::Vector2::new(10.0, 0.0),
        }),
        Some(AgentState {
            position: crate::geometry::Point2::new(0.0, 0.0),
            heading_rad: 0.0,
            velocity_mps: crate::geometry::Vector2::new(14.0, 0.0),
        }),
    ];

    #[test]
    fn the_lookahead_takes_a_contact_the_ego_could_still_have_escaped_and_the_paper_does_not() {
        // V_h > 0 closer than 0.3 m: contacts are infeasible states.
        let close_is_infeasible = StubOracle(|p| if gap_m(p) < 0.3 { 1.0 } else { -1.0 });
        let one_step = Search::one_step(TrustRegion::TopN(5));
        let lookahead = Search { lookahead_tokens: LOOKAHEAD_TOKENS, ..one_step };
        // The paper's arg min stops at the closest feasible state.
        assert_eq!(choice_in(&CLOSING, &LIKED, one_step, Some(&close_is_infeasible)), token(0.0));
        // From a feasible state (2.5 m) the contact is a conflict the ego could escape.
        assert_eq!(choice_in(&CLOSING, &LIKED, lookahead, Some(&close_is_infeasible)), token(5.0));
        // From an infeasible state it is not: the least V_h (the widest gap) wins, as in the paper.
        let near_is_infeasible = StubOracle(|p| 3.0 - gap_m(p) as f32);
        assert_eq!(choice_in(&CLOSING, &LIKED, lookahead, Some(&near_is_infeasible)), token(-5.0));
        assert_eq!(choice_in(&CLOSING, &LIKED, one_step, Some(&near_is_infeasible)), token(-5.0));
    }

    #[test]
    fn in_traffic_the_lookahead_takes_no_contact_the_boxed_in_ego_could_not_escape() {
        use crate::policies::adversary::FeasibilityScope;
        let close_is_infeasible = StubOracle(|p| if gap_m(p) < 0.3 { 1.0 } else { -1.0 });
        let pair = Search { lookahead_tokens: LOOKAHEAD_TOKENS, ..Search::one_step(TrustRegion::TopN(5)) };
        let in_traffic = Search { feasibility: FeasibilityScope::PairInTraffic, ..pair };
        // The ego at 10 m/s, the CBV's box 1 m behind it at 11 m/s.
        let (ego, cbv) = (car(0.0, 0.0, 10.0), car(-5.5, 0.0, 11.0));
        // On an open road V_h's escape is there: both take the contact.
        for search in [pair, in_traffic] {
            assert_eq!(choice_in(&[ego, cbv], &LIKED, search, Some(&close_is_infeasible)), token(5.0));
        }
        // Boxed in by cars at its speed 3 m ahead (too near to speed away
        // from the CBV in) and in the lanes either side, the ego has no
        // escape: in traffic every state near it is infeasible, and the
        // likeliest token wins (the paper's fallback).
        let boxed = [ego, cbv, car(8.5, 0.0, 10.0), car(0.0, 3.5, 10.0), car(0.0, -3.5, 10.0)];
        assert_eq!(choice_in(&boxed, &LIKED, pair, Some(&close_is_infeasible)), token(5.0));
        assert_eq!(choice_in(&boxed, &LIKED, in_traffic, Some(&close_is_infeasible)), token(-5.0));
    }

    #[test]
    fn witnessed_the_lookahead_takes_no_contact_the_witness_finds_no_escape_from() {
        use crate::map::RoadMap;
        use crate::policies::adversary::test_support::choice_under;
        use crate::policies::adversary::{EscapeWitness, Feasibility, FeasibilityScope};
        use crate::scenario::AgentBody;
        /// A witness with one answer, counting the questions.
        struct Answer(bool, std::sync::atomic::AtomicUsize);
        impl EscapeWitness for Answer {
            fn ego_escapes(&self, _: &RoadMap, _: &[Vec<Option<AgentState>>], _: &[AgentBody], _: usize) -> bool {
                self.1.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                self.0
            }
        }
        let close_is_infeasible = StubOracle(|p| if gap_m(p) < 0.3 { 1.0 } else { -1.0 });
        let liked: Vec<(Token, f32)> = LIKED.iter().map(|&(a, logit)| (token(a), logit)).collect();
        let pair = Search { lookahead_tokens: LOOKAHEAD_TOKENS, ..Search::one_step(TrustRegion::TopN(5)) };
        let witnessed = Search { feasibility: FeasibilityScope::Witnessed, ..pair };
        let chosen = |search, witness: &Answer| {
            let constraint = Feasibility { oracle: Some(&close_is_infeasible), witness: Some(witness), history: &[] };
            choice_under(&CLOSING, &liked, search, constraint)
        };
        // The witness finds an escape: the contact V_h alone takes, after one question.
        let escapes = Answer(true, Default::default());
        assert_eq!(chosen(witnessed, &escapes), token(5.0));
        assert_eq!(escapes.1.into_inner(), 1);
        // It finds none: every candidate closes in on the ego, each asked in
        // turn until the boundary's searches are spent; all count as
        // infeasible alike and the likeliest wins (the paper's fallback).
        let none = Answer(false, Default::default());
        assert_eq!(chosen(witnessed, &none), token(-5.0));
        assert_eq!(none.1.into_inner(), crate::policies::adversary::WITNESS_CHECKS_PER_TOKEN);
        // The witness is asked in the `witnessed` scope only.
        let unasked = Answer(false, Default::default());
        assert_eq!(chosen(pair, &unasked), token(5.0));
        assert_eq!(unasked.1.into_inner(), 0);
    }

    #[test]
    fn with_the_in_path_objective_a_contact_beside_the_ego_scores_as_not_ahead() {
        use crate::motion::Action;
        use crate::policies::adversary::Objective;
        // The CBV in the next lane, its centre 1 m behind the ego's, both at
        // 10 m/s. Steering right it touches the ego's side within a second,
        // beside it; at +5 m/s² it draws ahead of the ego's front bumper
        // within 1.5 s, 1.5 m to the side of its path.
        let states = [car(0.0, 0.0, 10.0), car(-1.0, 3.5, 10.0)];
        let steer_in = crate::motion::tokens::TokenGrid::quantize(Action { accel_mps2: 0.0, yaw_rate_radps: -0.3 });
        let liked = [(token(0.0), 3.0), (steer_in, 2.0), (token(5.0), 1.0)];
        let chosen = |objective| {
            let search =
                Search { objective, lookahead_tokens: LOOKAHEAD_TOKENS, ..Search::one_step(TrustRegion::TopN(3)) };
            choice_among(&states, &liked, search, None)
        };
        // The paper's loss takes the contact with the ego's side.
        assert_eq!(chosen(Objective::Contact), steer_in);
        // The in-path loss counts that contact as not ahead of the ego (the
        // penalty, not 0): the CBV draws ahead towards the ego's path instead.
        assert_eq!(chosen(Objective::InPath), token(5.0));
    }

    #[test]
    fn the_lookahead_asks_v_h_only_of_the_continuations_that_can_change_its_choice() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        /// Every state feasible; counts the states asked about.
        struct Counting(AtomicUsize);
        impl FeasibilityOracle for Counting {
            fn values(&self, pairs: &[EgoCbvState]) -> Result<Vec<f32>, ModelError> {
                self.0.fetch_add(pairs.len(), Ordering::Relaxed);
                Ok(vec![-1.0; pairs.len()])
            }
        }
        // 30 m behind the ego at the same speed, as below: the hardest
        // acceleration closes most.
        let states = [car(30.0, 0.0, 10.0), car(0.0, 0.0, 10.0)];
        let lookahead = Search { lookahead_tokens: LOOKAHEAD_TOKENS, ..Search::one_step(TrustRegion::TopN(5)) };
        let oracle = Counting(AtomicUsize::new(0));
        assert_eq!(choice_in(&states, &LIKED, lookahead, Some(&oracle)), token(5.0));
        // Asking of every continuation: the CBV now, the 5 first tokens and
        // 5 × 5 continuations at each of the two later depths.
        let every = 1 + 5 + 25 + 25;
        let asked = oracle.0.load(Ordering::Relaxed);
        assert!(asked < every, "{asked} of {every}");
    }

    #[test]
    fn the_lookahead_scores_what_a_continuation_reaches_inside_the_constraints() {
        // 30 m behind the ego at the same speed: no contact within 1.5 s.
        // Every state feasible: hardest acceleration closes most, as in one step.
        let states = [car(30.0, 0.0, 10.0), car(0.0, 0.0, 10.0)];
        let lookahead = Search { lookahead_tokens: LOOKAHEAD_TOKENS, ..Search::one_step(TrustRegion::TopN(5)) };
        let feasible = StubOracle(|_| -1.0);
        assert_eq!(choice_in(&states, &LIKED, lookahead, Some(&feasible)), token(5.0));
        // Faster than 12 m/s is infeasible: +5 (12.5 m/s after the token)
        // is out; the closest feasible approach starts with +2.
        let fast_is_infeasible = StubOracle(|p| if p.cbv.speed_mps() > 12.01 { 1.0 } else { -1.0 });
        assert_eq!(choice_in(&states, &LIKED, lookahead, Some(&fast_is_infeasible)), token(2.0));
    }
}
