//! The SaFeR adversary: drives the critical background vehicle (CBV) token
//! by token. Every token period it takes the realism prior's top-n tokens
//! (the trust region, which keeps the behaviour human-like), predicts the
//! CBV's state after each through the kinematic model, and picks the token
//! with the least loss: the box distance to the ego when the feasibility
//! value says the ego can still avoid a collision (V_h ≤ 0), else V_h + Δ
//! (so an unavoidable state is chosen only when nothing else is left). The
//! choice is the paper's strict arg min, ties broken by the prior's logit
//! and then the token id, so it is a pure function of the world.
//!
//! Two things the paper leaves open are fixed here:
//! - **Seeds.** With the background on log replay an arg min gives every
//!   seed the same variant. The seed instead sets an *approach phase*: the
//!   prior samples the CBV's first 1–4 tokens (0.5–2 s, drawn from the
//!   seed) before the adversary engages, so each seed starts the attack
//!   from a different, realistic state.
//! - **Plausibility.** The CBV must stay a plausible road user. A
//!   candidate is implausible when its 0.5 s rollout takes the CBV from the
//!   road onto the off-road area (or, off the road already, farther from
//!   it; driving on past the mapped end of the road, where the recording's
//!   map was cut off, is not leaving it), when a background agent
//!   (replayed agents where their recording puts them, the others at
//!   constant velocity: [`BackgroundForecast`]) and the CBV touch during
//!   the token or the second after it with the token held (no brake checks
//!   on followers, no stopping in the way of crossing traffic), when a
//!   replayed agent would run into the CBV in the 2 s after that with the
//!   CBV keeping its speed (replay cannot yield: no slowing down in front
//!   of traffic closing fast), or when the
//!   CBV, braking as hard as it can after the token (holding its
//!   curvature, as a driver braking in a bend does), would leave the road
//!   before it stands, or run into one within 2 s (at fault as the
//!   metrics judge it: a follower running into a braking CBV is not the
//!   CBV's doing). A plausible token leaves the CBV room to stop on the
//!   road. The arg min
//!   is taken over the plausible candidates of the trust region; when none
//!   is plausible the CBV takes the likeliest plausible token of the whole
//!   vocabulary (what a careful driver would do: the trust region is for
//!   realism, and leaving the road or hitting traffic is not realistic).
//!   When no token at all is plausible, a replayed agent is about to run
//!   into the CBV whatever it does (replay cannot yield); then the same
//!   two steps are taken with only the contacts the CBV would be at fault
//!   for counted (and cut-ins: hit from behind in a lane it moved into,
//!   which nuPlan's rule does not blame): waiting to be hit is better than
//!   fleeing into someone else. Only when even that leaves nothing, the
//!   trust region's token that breaks the rule latest. The same rule
//!   restricts the prior's draws in the approach phase.
//!
//! The ablations are the same policy with a part switched off;
//! `safer-lookahead` (beyond the paper) is the same policy scoring tokens
//! over a receding horizon ([`Lookahead`]).

use std::sync::{Arc, Mutex};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::prior_sampling::{PriorTraffic, TokenSampling, draw_seed, ranked_tokens, sample_token, top_tokens};
use super::{AgentAction, AgentPolicy, WorldView};
use crate::geometry::{OrientedBox, wrap_angle};
use crate::models::ModelError;
pub use crate::models::feasibility_oracle::{EgoCbvState, FeasibilityOracle};
use crate::motion::tokens::{
    MAX_ACCEL_MPS2, MAX_YAW_RATE_RADPS, SIM_DT_S, TOKEN_PERIOD_S, TOKEN_PERIOD_STEPS, Token, TokenGrid,
};
use crate::motion::{Action, KinematicState, kinematic_step};
use crate::scenario::contact::{EgoCollisionKind, EgoContact};
use crate::scenario::{AgentState, TrackIndex};

/// Penalty added to V_h for candidates outside the feasible region (the paper's Δ).
pub const INFEASIBLE_PENALTY: f64 = 50.0;

/// The approach phase: the prior drives the CBV for this many token
/// periods (drawn per seed, uniformly) before the adversary engages.
pub const APPROACH_TOKENS: std::ops::RangeInclusive<usize> = 1..=4;

/// Background agents farther than this from the CBV cannot be reached
/// within the plausibility check's horizon (3.5 s at a closing speed of
/// up to about 34 m/s) and are not checked, m.
const BACKGROUND_CHECK_RANGE_M: f64 = 120.0;

/// After a candidate token the plausibility check brakes the CBV this many
/// simulator steps (2 s) to see whether it could still stop short of the
/// background traffic.
const BRAKING_CHECK_STEPS: usize = 20;

/// The road check of the braking path goes on past
/// [`BRAKING_CHECK_STEPS`] until the CBV stands, for at most this many
/// steps more (8 s in all: enough to stop from 40 m/s at the hardest
/// braking). Only the road is checked that far: the background forecast
/// is not.
const STANDSTILL_CHECK_MAX_STEPS: usize = 60;

/// A token held this many steps (1 s) more must not bring the CBV and a
/// background agent (predicted at constant velocity) into contact: no
/// brake checks on followers, no stopping in the way of crossing traffic.
const HOLDING_CHECK_STEPS: usize = 10;

/// After the held token the CBV keeps its speed (and curvature) this many
/// steps (2 s) more, and a replayed agent that would run into it within
/// them makes the token implausible: a replayed car cannot yield (agents
/// the prior or a rule drives can, and are not checked here), and a
/// driver does not slow down or stop in front of traffic closing on it
/// faster than it could get out of the way (seen on WOMD interactive: a
/// CBV slowing in a lane where a car came up at 25 m/s, a CBV stopped in
/// the path of crossing traffic 2 s away; 1 s of holding saw both only
/// when no token could avoid them any more). Contacts the CBV would be at
/// fault for are not counted here: running into someone at constant speed
/// seconds ahead is what the braking check is for.
const CLOSING_CHECK_STEPS: usize = 20;

/// Which tokens the adversary may choose from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrustRegion {
    /// The prior's n most likely tokens.
    TopN(usize),
    /// The whole vocabulary (the `no-trust-region` ablation).
    WholeVocabulary,
}

/// What the adversary searches at each token boundary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Search {
    /// Which tokens it may choose from.
    pub trust_region: TrustRegion,
    /// How many token periods ahead a candidate is scored: 1 is the
    /// paper's one-step arg min (`safer`), more is the receding-horizon
    /// `safer-lookahead` (see [`LOOKAHEAD_TOKENS`]).
    pub lookahead_tokens: usize,
}

impl Search {
    /// The paper's one-step search over `trust_region`.
    pub fn one_step(trust_region: TrustRegion) -> Self {
        Self { trust_region, lookahead_tokens: 1 }
    }
}

/// How many token periods `safer-lookahead` scores ahead (1.5 s).
pub const LOOKAHEAD_TOKENS: usize = 3;

/// What `safer-lookahead` adds to a continuation's score per token period
/// after the first, m: of two equally close approaches the sooner wins.
pub const LOOKAHEAD_DELAY_PENALTY_M: f64 = 0.5;

/// The adversary of one rollout's CBV.
pub struct Adversary {
    shared: Arc<Mutex<PriorTraffic>>,
    ego: TrackIndex,
    search: Search,
    feasibility: Option<Arc<dyn FeasibilityOracle>>,
    current: Option<Token>,
    error: Option<Arc<ModelError>>,
}

impl std::fmt::Debug for Adversary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Adversary")
            .field("ego", &self.ego)
            .field("search", &self.search)
            .field("feasibility", &self.feasibility.is_some())
            .finish()
    }
}

/// Where the ego will be after one token period if it keeps its velocity
/// (the adversary does not know the ego's plan).
fn ego_prediction(ego: &AgentState) -> AgentState {
    AgentState { position: ego.position + ego.velocity_mps * TOKEN_PERIOD_S, ..*ego }
}

impl Adversary {
    /// The adversary; `feasibility: None` is the `no-lfr` ablation
    /// (distance only). `shared` must have the CBV as a member.
    pub fn new(
        shared: Arc<Mutex<PriorTraffic>>,
        ego: TrackIndex,
        search: Search,
        feasibility: Option<Arc<dyn FeasibilityOracle>>,
    ) -> Self {
        Self { shared, ego, search, feasibility, current: None, error: None }
    }

    /// The first error met (inference), if any.
    pub fn error(&self) -> Option<&Arc<ModelError>> {
        self.error.as_ref()
    }

    /// The token minimising the SaFeR loss among the trust region, or `None`
    /// when the prior has no opinion (the CBV is absent).
    fn choose(&mut self, world: &WorldView<'_>, cbv: TrackIndex) -> Result<Option<Token>, ModelError> {
        let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
        let Some(logits) = shared.logits_at(cbv.0, world.step).cloned() else { return Ok(None) };
        let (scenario, prior_driven) = (shared.scenario().clone(), shared.members().to_vec());
        drop(shared);
        let forecast = BackgroundForecast { recording: Some(&scenario), not_replayed: &prior_driven };
        let mut feasibility_s = 0.0;
        let chosen = safer_choice(
            world,
            (cbv, self.ego),
            &logits,
            self.search,
            &forecast,
            self.feasibility.as_deref(),
            &mut feasibility_s,
        );
        self.shared.lock().unwrap_or_else(|p| p.into_inner()).add_feasibility_time(feasibility_s);
        chosen
    }

    /// The approach phase's token: [`approach_draw`] with the rollout's
    /// seed and sampling.
    fn approach_token(&self, world: &WorldView<'_>, cbv: TrackIndex) -> Option<Token> {
        let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
        let (seed, sampling) = (shared.seed(), shared.sampling());
        let logits = shared.logits_at(cbv.0, world.step)?.clone();
        let (scenario, prior_driven) = (shared.scenario().clone(), shared.members().to_vec());
        drop(shared);
        let forecast = BackgroundForecast { recording: Some(&scenario), not_replayed: &prior_driven };
        let mut rng = ChaCha8Rng::seed_from_u64(draw_seed(seed, cbv.0, world.step));
        Some(approach_draw(world, (cbv, self.ego), &logits, sampling, &forecast, &mut rng))
    }

    /// How many token periods of the approach phase this rollout's seed gives.
    fn approach_tokens(seed: u64, cbv: TrackIndex) -> usize {
        let mut rng = ChaCha8Rng::seed_from_u64(draw_seed(seed, cbv.0, usize::MAX));
        rng.random_range(APPROACH_TOKENS)
    }
}

/// The approach phase's token for the CBV of the pair (CBV, ego): a draw
/// from the prior (`sampling`, with `rng`) among the plausible tokens of
/// its top k; when none is, the fallbacks of the module's plausibility
/// rule; a draw among the top k as they are when nothing is plausible at
/// all (or the CBV is absent).
fn approach_draw(
    world: &WorldView<'_>,
    (cbv, ego): (TrackIndex, TrackIndex),
    logits: &[f32],
    sampling: TokenSampling,
    forecast: &BackgroundForecast<'_>,
    rng: &mut impl Rng,
) -> Token {
    let top = &top_tokens(logits, sampling.top_k.clamp(1, logits.len()))[..];
    let Some(cbv_now) = world.state(cbv) else { return sample_token(logits, sampling, rng) };
    let check = PlausibilityCheck::new(world, cbv, ego, forecast);
    let rollouts = token_rollouts(cbv_now, top);
    // As in the adversary's choice: the plausible tokens of the top k,
    // else the likeliest plausible one of the vocabulary; under the strict
    // rule first, then counting only the CBV's own faults.
    for rule in [ContactRule::Any, ContactRule::AtFaultOnly] {
        let plausible: Vec<Token> =
            top.iter().zip(&rollouts).filter(|(_, r)| !check.implausible(r, rule)).map(|(t, _)| *t).collect();
        if !plausible.is_empty() {
            // Only the checked, plausible tokens keep their logits: a draw
            // from the top k of logits merely masked where implausible
            // would reach past the top k to tokens never checked.
            let mut masked = vec![f32::NEG_INFINITY; logits.len()];
            for t in &plausible {
                masked[t.0 as usize] = logits[t.0 as usize];
            }
            return sample_token(&masked, TokenSampling { top_k: plausible.len(), ..sampling }, rng);
        }
        if let Some(t) = check.likeliest_plausible(logits, top.len()..logits.len(), rule) {
            return t;
        }
    }
    sample_token(logits, sampling, rng)
}

/// SaFeR's choice at one token boundary for the CBV of the pair (CBV,
/// ego), given the prior's `logits` for the CBV: the plausible token of the trust region with the least loss
/// (the box distance to the ego's constant-velocity prediction where
/// `feasibility` says the ego can still avoid a collision, else V_h + Δ;
/// distance only without `feasibility`), ties broken by the likelier token
/// and then the lower id; the fallbacks of the module's plausibility rule
/// when none is plausible (the background predicted by `forecast`). With
/// a lookahead the loss of a feasible candidate is the best score of its
/// continuations (see [`Lookahead`]). Time spent in `feasibility` is added to
/// `feasibility_s`. `None` only for empty `logits`.
pub fn safer_choice(
    world: &WorldView<'_>,
    (cbv, ego): (TrackIndex, TrackIndex),
    logits: &[f32],
    search: Search,
    forecast: &BackgroundForecast<'_>,
    feasibility: Option<&dyn FeasibilityOracle>,
    feasibility_s: &mut f64,
) -> Result<Option<Token>, ModelError> {
    // The trust region, most likely first: the top of `ranked_tokens`
    // without sorting the whole vocabulary.
    let k = match search.trust_region {
        TrustRegion::TopN(n) => n.max(1).min(logits.len()),
        TrustRegion::WholeVocabulary => logits.len(),
    };
    let candidates = &top_tokens(logits, k)[..];
    let (Some(cbv_now), Some(ego_now)) = (world.state(cbv), world.state(ego)) else {
        return Ok(candidates.first().copied());
    };
    let ego_next = ego_prediction(ego_now);
    let (ego_body, cbv_body) = (world.body(ego), world.body(cbv));
    let ego_box = ego_body.footprint(&ego_next);
    let rollouts = token_rollouts(cbv_now, candidates);
    let predicted: Vec<AgentState> = rollouts.iter().map(|r| r[TOKEN_PERIOD_STEPS - 1]).collect();
    let distances: Vec<f64> = predicted.iter().map(|s| ego_box.distance(&cbv_body.footprint(s))).collect();
    let values = match feasibility {
        None => None,
        Some(oracle) => Some(feasibility_values(oracle, &predicted, ego_next, ego_body, cbv_body, feasibility_s)?),
    };
    let mut losses: Vec<f64> = match &values {
        None => distances.clone(),
        Some(values) => distances
            .iter()
            .zip(values)
            .map(|(d, v)| if *v <= 0.0 { *d } else { *v as f64 + INFEASIBLE_PENALTY })
            .collect(),
    };
    if search.lookahead_tokens > 1 {
        let lookahead = Lookahead {
            world,
            ego_now: *ego_now,
            ego_body,
            cbv_body,
            candidates,
            tokens: search.lookahead_tokens,
            on_road_now: !world.map.is_off_road_within_map(&cbv_now.position),
        };
        let first = FirstTokens { states: &predicted, distances_m: &distances, values: values.as_deref() };
        lookahead.lower_losses(cbv_now, first, &mut losses, feasibility, feasibility_s)?;
    }
    // The strict arg min: by loss (a NaN distance, never expected as
    // states are bounds-checked, ranks last), then the likelier token,
    // then the lower id; the first plausible candidate in that order,
    // or the first of all when none is. Plausibility is the costly
    // check, so it is asked only until a plausible one is found.
    let loss = |i: usize| if losses[i].is_nan() { f64::INFINITY } else { losses[i] };
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by(|&i, &j| {
        loss(i)
            .total_cmp(&loss(j))
            .then(logits[candidates[j].0 as usize].total_cmp(&logits[candidates[i].0 as usize]))
            .then(candidates[i].0.cmp(&candidates[j].0))
    });
    let check = PlausibilityCheck::new(world, cbv, ego, forecast);
    // The strict rule first; when nothing at all is plausible, whatever the
    // CBV does a replayed agent runs into it, and the same two steps are
    // taken counting only its own faults.
    let mut violations = Vec::with_capacity(order.len());
    for rule in [ContactRule::Any, ContactRule::AtFaultOnly] {
        for &i in &order {
            match check.first_violation(&rollouts[i], rule) {
                None => return Ok(Some(candidates[i])),
                Some(k) if rule == ContactRule::Any => violations.push((i, k)),
                Some(_) => {}
            }
        }
        if let Some(t) = check.likeliest_plausible(logits, candidates.len()..logits.len(), rule) {
            return Ok(Some(t));
        }
    }
    // With no plausible token at all, the trust region's token that
    // breaks the rule latest (the first such in arg-min order).
    Ok(violations.iter().rev().max_by_key(|(_, k)| *k).map(|(i, _)| candidates[*i]))
}

/// V_h of the CBV in each of `predicted` against the ego in `ego`, timed
/// into `feasibility_s`; a NaN is a broken model and an error.
fn feasibility_values(
    oracle: &dyn FeasibilityOracle,
    predicted: &[AgentState],
    ego: AgentState,
    ego_body: crate::scenario::AgentBody,
    cbv_body: crate::scenario::AgentBody,
    feasibility_s: &mut f64,
) -> Result<Vec<f32>, ModelError> {
    let pairs: Vec<EgoCbvState> = predicted.iter().map(|s| EgoCbvState { ego, ego_body, cbv: *s, cbv_body }).collect();
    let clock = std::time::Instant::now();
    let values = oracle.values(&pairs);
    *feasibility_s += clock.elapsed().as_secs_f64();
    let values = values?;
    // A NaN value is a broken model, not a feasible state: fail the
    // variant with the model named rather than guess.
    if let Some(i) = values.iter().position(|v| v.is_nan()) {
        return Err(ModelError::Inference {
            model: "feasibility value V_h".into(),
            message: format!("returned NaN for candidate token {} of {}", i, values.len()),
        });
    }
    Ok(values)
}

/// The receding-horizon search of `safer-lookahead` (beyond the paper).
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
/// - a continuation ends at its first state where V_h > 0 or that leaves
///   the road; only a *contact* with the ego may end it infeasibly, and
///   only straight from a feasible state (V_h ≤ 0: the ego could still
///   have escaped one token earlier, and it is that escape the witness
///   later looks for).
///
/// A continuation scores its distance to the ego plus
/// [`LOOKAHEAD_DELAY_PENALTY_M`] per token after the first (sooner is
/// better; a contact scores 0 plus that delay), and a first token takes
/// the least score of its continuations when below its one-step loss. The
/// search is a beam as wide as the trust region ranked by distance, a pure
/// function of the world like the one-step choice.
struct Lookahead<'a> {
    world: &'a WorldView<'a>,
    ego_now: AgentState,
    ego_body: crate::scenario::AgentBody,
    cbv_body: crate::scenario::AgentBody,
    /// The trust region, most likely first.
    candidates: &'a [Token],
    /// How many token periods ahead (at least 1).
    tokens: usize,
    /// Whether the CBV is on the road now (then a continuation must stay on it).
    on_road_now: bool,
}

/// The one-step search's results for each candidate of the trust region.
struct FirstTokens<'a> {
    /// Where the CBV ends the token.
    states: &'a [AgentState],
    /// Its box distance to the ego's prediction there, m.
    distances_m: &'a [f64],
    /// V_h there (`None`: no feasibility constraint).
    values: Option<&'a [f32]>,
}

/// One continuation of the beam: which first token it extends, where the
/// CBV is at its end, and its distance to the ego there.
struct Continuation {
    root: usize,
    state: KinematicState,
    distance_m: f64,
}

impl Lookahead<'_> {
    /// Lowers each candidate's one-step loss in `losses` to the best score
    /// of its continuations (see [`Lookahead`]).
    fn lower_losses(
        &self,
        cbv_now: &AgentState,
        first: FirstTokens<'_>,
        losses: &mut [f64],
        feasibility: Option<&dyn FeasibilityOracle>,
        feasibility_s: &mut f64,
    ) -> Result<(), ModelError> {
        let feasible = |i: usize| first.values.is_none_or(|v| v[i] <= 0.0);
        // A contact in the first token, straight from a feasible state now.
        if let (Some(oracle), Some(values)) = (feasibility, first.values) {
            let now =
                feasibility_values(oracle, &[*cbv_now], self.ego_now, self.ego_body, self.cbv_body, feasibility_s)?;
            if now[0] <= 0.0 {
                for (i, loss) in losses.iter_mut().enumerate() {
                    if values[i] > 0.0 && first.distances_m[i] <= 0.0 {
                        *loss = 0.0;
                    }
                }
            }
        }
        let mut beam: Vec<Continuation> = (0..first.states.len())
            .filter(|&i| feasible(i) && first.distances_m[i] > 0.0)
            .map(|i| Continuation {
                root: i,
                state: KinematicState::from_agent_state(&first.states[i]),
                distance_m: first.distances_m[i],
            })
            .collect();
        Self::keep_best(&mut beam, self.candidates.len());
        for depth in 2..=self.tokens {
            let ahead_s = TOKEN_PERIOD_S * depth as f64;
            let ego =
                AgentState { position: self.ego_now.position + self.ego_now.velocity_mps * ahead_s, ..self.ego_now };
            let ego_box = self.ego_body.footprint(&ego);
            let mut children: Vec<Continuation> = Vec::with_capacity(beam.len() * self.candidates.len());
            for parent in &beam {
                for &t in self.candidates {
                    let end = TokenGrid::rollout(&parent.state, t)[TOKEN_PERIOD_STEPS - 1];
                    let at = end.to_agent_state();
                    if self.on_road_now && self.world.map.is_off_road_within_map(&at.position) {
                        continue;
                    }
                    let distance_m = ego_box.distance(&self.cbv_body.footprint(&at));
                    children.push(Continuation { root: parent.root, state: end, distance_m });
                }
            }
            if let Some(oracle) = feasibility {
                let states: Vec<AgentState> = children.iter().map(|c| c.state.to_agent_state()).collect();
                let values = feasibility_values(oracle, &states, ego, self.ego_body, self.cbv_body, feasibility_s)?;
                // Parents are feasible: an infeasible contact is one the ego could have escaped.
                let mut values = values.into_iter();
                children.retain(|c| values.next().is_some_and(|v| v <= 0.0) || c.distance_m <= 0.0);
            }
            let delay_m = LOOKAHEAD_DELAY_PENALTY_M * (depth - 1) as f64;
            for c in &children {
                losses[c.root] = losses[c.root].min(c.distance_m.max(0.0) + delay_m);
            }
            // A contact ends its continuation.
            children.retain(|c| c.distance_m > 0.0);
            Self::keep_best(&mut children, self.candidates.len());
            beam = children;
        }
        Ok(())
    }

    /// Keeps the `width` continuations closest to the ego (ties: the
    /// likelier first token, then the order they were made in).
    fn keep_best(beam: &mut Vec<Continuation>, width: usize) {
        beam.sort_by(|a, b| a.distance_m.total_cmp(&b.distance_m).then(a.root.cmp(&b.root)));
        beam.truncate(width);
    }
}

/// The CBV's states over one token period from `now` under each token.
fn token_rollouts(now: &AgentState, tokens: &[Token]) -> Vec<Vec<AgentState>> {
    let from = KinematicState::from_agent_state(now);
    tokens.iter().map(|t| token_rollout(&from, *t)).collect()
}

/// The CBV's states over one token period from `from` under `token`.
fn token_rollout(from: &KinematicState, token: Token) -> Vec<AgentState> {
    TokenGrid::rollout(from, token).iter().map(KinematicState::to_agent_state).collect()
}

/// The CBV's states over [`BRAKING_CHECK_STEPS`] steps after `rollout`
/// (a token's states), braking as hard as it can while holding the
/// curvature it ends the token with: a driver braking in a bend keeps
/// steering along it.
fn braking_after(rollout: &[AgentState]) -> impl Iterator<Item = AgentState> + use<> {
    continued_after(rollout, -MAX_ACCEL_MPS2, BRAKING_CHECK_STEPS)
}

/// The CBV's path while it holds the token: `rollout` (the token's states),
/// then [`HOLDING_CHECK_STEPS`] steps holding the token's acceleration and
/// curvature, then [`CLOSING_CHECK_STEPS`] more at the speed reached,
/// still holding the curvature.
fn held_path(rollout: &[AgentState]) -> Vec<AgentState> {
    let accel_mps2 = match rollout {
        [.., before, end] => (end.speed_mps() - before.speed_mps()) / SIM_DT_S,
        _ => 0.0,
    };
    let mut held: Vec<AgentState> = rollout.to_vec();
    held.extend(continued_after(rollout, accel_mps2.clamp(-MAX_ACCEL_MPS2, MAX_ACCEL_MPS2), HOLDING_CHECK_STEPS));
    held.extend(continued_after(&held, 0.0, CLOSING_CHECK_STEPS));
    held
}

/// `steps` states after `rollout` at `accel_mps2`, holding the curvature
/// the rollout ends with.
fn continued_after(rollout: &[AgentState], accel_mps2: f64, steps: usize) -> impl Iterator<Item = AgentState> + use<> {
    let curvature_per_m = match rollout {
        [.., before, end] => {
            let travelled_m = (end.position - before.position).norm();
            if travelled_m > 1e-3 { wrap_angle(end.heading_rad - before.heading_rad) / travelled_m } else { 0.0 }
        }
        _ => 0.0,
    };
    let mut state = rollout.last().map(KinematicState::from_agent_state);
    (0..steps).map_while(move |_| {
        let now = state.as_mut()?;
        let speed_mps = (now.speed_mps + accel_mps2 * SIM_DT_S).max(0.0);
        let yaw_rate_radps = (curvature_per_m * speed_mps).clamp(-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS);
        *now = kinematic_step(now, Action { accel_mps2, yaw_rate_radps }, SIM_DT_S);
        Some(now.to_agent_state())
    })
}

/// What the adversary knows of the background's next seconds. An agent the
/// rollout replays from its recording (log replay, and reactive replay
/// while it keeps to the recording) will be where its recording says: the
/// scenario generator replays it, so it knows. Any other agent (driven by
/// the prior or a rule, or off its recording) is predicted at constant
/// velocity. Without a recording every agent is.
#[derive(Debug, Clone, Copy, Default)]
pub struct BackgroundForecast<'a> {
    /// The scenario whose recordings replayed agents follow.
    pub recording: Option<&'a crate::scenario::Scenario>,
    /// Agents that are not replayed (the prior drives them), sorted.
    pub not_replayed: &'a [usize],
}

/// How far an agent may be from its recorded position and still be taken
/// to follow its recording, m (reactive replay falls behind it when it
/// brakes; then it is predicted at constant velocity).
const ON_RECORDING_TOLERANCE_M: f64 = 0.5;

impl BackgroundForecast<'_> {
    /// The recorded track `agent` follows now, if it is replayed from it
    /// (not driven by the prior, and where its recording puts it).
    fn replayed_track(&self, world: &WorldView<'_>, agent: TrackIndex) -> Option<&crate::scenario::Track> {
        let now = world.state(agent);
        self.recording
            .filter(|_| self.not_replayed.binary_search(&agent.0).is_err())
            .and_then(|r| r.tracks.get(agent.0))
            .filter(|track| match (now, track.state(world.step)) {
                (Some(now), Some(then)) => (now.position - then.position).norm() <= ON_RECORDING_TOLERANCE_M,
                // A replayed agent enters (or leaves) as recorded.
                (None, _) => true,
                (Some(_), None) => false,
            })
    }

    /// `agent`'s predicted states over the `steps` simulator steps after
    /// `world.step` (`None`: absent at that step), and whether they come
    /// from its recording (a replayed agent, which cannot yield).
    fn states(&self, world: &WorldView<'_>, agent: TrackIndex, steps: usize) -> (Vec<Option<AgentState>>, bool) {
        match (self.replayed_track(world, agent), world.state(agent)) {
            (Some(track), _) => ((1..=steps).map(|k| track.state(world.step + k).copied()).collect(), true),
            (None, Some(s)) => (
                (1..=steps)
                    .map(|k| Some(AgentState { position: s.position + s.velocity_mps * (k as f64 * SIM_DT_S), ..*s }))
                    .collect(),
                false,
            ),
            (None, None) => (Vec::new(), false),
        }
    }
}

/// Whether a candidate rollout of the CBV (one state per simulator step of
/// the token) is implausible for a road user (the module's rule: leaving
/// the road, touching background traffic during the token, or no room to
/// brake short of it). The background's predicted states and boxes are
/// built once per decision.
/// An axis-aligned rectangle holding a set of boxes (each box's centre
/// plus its half-diagonal either way), for a broad phase: boxes in two
/// disjoint ones cannot touch.
#[derive(Debug, Clone, Copy)]
struct Bounds {
    min: crate::geometry::Point2,
    max: crate::geometry::Point2,
}

impl Bounds {
    /// The bounds of `boxes` (empty, and overlapping nothing, for none; the
    /// whole plane if a box has a NaN centre or size).
    fn of<'a>(boxes: impl IntoIterator<Item = &'a OrientedBox>) -> Self {
        let mut bounds = Self {
            min: crate::geometry::Point2::new(f64::INFINITY, f64::INFINITY),
            max: crate::geometry::Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
        };
        for b in boxes {
            let reach_m = 0.5 * b.length_m.hypot(b.width_m);
            let p = b.pose.position;
            if [p.x, p.y, reach_m].iter().any(|v| v.is_nan()) {
                // Where such a box is is unknown: it may be anywhere.
                return Self {
                    min: crate::geometry::Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
                    max: crate::geometry::Point2::new(f64::INFINITY, f64::INFINITY),
                };
            }
            bounds.min.x = bounds.min.x.min(p.x - reach_m);
            bounds.min.y = bounds.min.y.min(p.y - reach_m);
            bounds.max.x = bounds.max.x.max(p.x + reach_m);
            bounds.max.y = bounds.max.y.max(p.y + reach_m);
        }
        bounds
    }

    /// Whether the two rectangles may share a point: false only where one
    /// lies wholly beside the other (a NaN coordinate proves nothing, and
    /// leaves the exact tests to decide).
    fn overlaps(&self, other: &Bounds) -> bool {
        !(self.max.x < other.min.x || other.max.x < self.min.x || self.max.y < other.min.y || other.max.y < self.min.y)
    }
}

/// Which contacts with background traffic break the plausibility rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ContactRule {
    /// Any contact while the CBV holds its token (being run into included:
    /// no brake checks, no stopping in the way), and running into someone
    /// while it brakes after the token: the rule.
    Any,
    /// Only contacts the CBV is at fault for, as the metrics judge them,
    /// and cut-ins ([`PlausibilityCheck::cut_in`]): the fallback when a
    /// replayed agent will run into the CBV whatever it does.
    AtFaultOnly,
}

/// Which violation of the plausibility rule a check looks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Violation {
    /// The first step at which the rule is broken.
    First,
    /// Any step at which it is: whether it is broken at all.
    Any,
}

struct PlausibilityCheck<'w> {
    world: &'w WorldView<'w>,
    cbv_body: crate::scenario::AgentBody,
    /// The CBV now (`None`: absent, nothing is implausible).
    cbv_now: Option<AgentState>,
    /// Each nearby background agent's predicted state and box, one per
    /// step of the check (`None`: absent at that step).
    background: Vec<Vec<Option<(AgentState, OrientedBox)>>>,
    /// Whether each of those agents is replayed from its recording.
    replayed: Vec<bool>,
    /// The bounds of each of those agents' predicted boxes over all the
    /// steps: a CBV path whose boxes lie outside them touches none of
    /// that agent's, and its box tests are skipped.
    background_bounds: Vec<Bounds>,
    /// The CBV's signed distance to the road edge now, m (positive: off
    /// the road; `None` where the map has no road edges near it).
    edge_distance_now: Option<f64>,
    on_road_now: bool,
    /// The lanes holding the CBV's centre now, driven its way (empty off
    /// the lanes or on a map without them): what it cuts in from.
    lanes_now: Vec<crate::map::MapElementId>,
}

impl<'w> PlausibilityCheck<'w> {
    fn new(world: &'w WorldView<'w>, cbv: TrackIndex, ego: TrackIndex, forecast: &BackgroundForecast<'_>) -> Self {
        let cbv_body = world.body(cbv);
        let cbv_now = world.state(cbv).copied();
        let Some(now) = cbv_now else {
            return Self {
                world,
                cbv_body,
                cbv_now,
                background: Vec::new(),
                replayed: Vec::new(),
                background_bounds: Vec::new(),
                edge_distance_now: None,
                on_road_now: false,
                lanes_now: Vec::new(),
            };
        };
        let horizon = TOKEN_PERIOD_STEPS + BRAKING_CHECK_STEPS.max(HOLDING_CHECK_STEPS + CLOSING_CHECK_STEPS);
        let in_range = |s: &AgentState| (s.position - now.position).norm() < BACKGROUND_CHECK_RANGE_M;
        let (background, replayed): (Vec<Vec<_>>, Vec<bool>) = (0..world.states.len())
            .filter(|&i| i != cbv.0 && i != ego.0)
            .filter_map(|i| {
                let (states, replayed) = forecast.states(world, TrackIndex(i), horizon);
                states.iter().flatten().next().is_some_and(in_range).then_some((i, states, replayed))
            })
            .map(|(i, states, replayed)| {
                let b = world.bodies[i];
                (states.into_iter().map(|s| s.map(|at| (at, b.footprint(&at)))).collect(), replayed)
            })
            .unzip();
        let background_bounds =
            background.iter().map(|predicted| Bounds::of(predicted.iter().flatten().map(|(_, b)| b))).collect();
        Self {
            world,
            cbv_body,
            cbv_now,
            background,
            replayed,
            background_bounds,
            edge_distance_now: world.map.signed_distance_to_road_edge(&now.position),
            on_road_now: !world.map.is_off_road_within_map(&now.position),
            lanes_now: world.map.lanes_containing(&now.position, now.heading_rad),
        }
    }

    /// Whether the CBV, hit by `theirs` at `at`, cut in: it was hit from
    /// behind (or standing) in a lane that neither holds nor continues
    /// any of its lanes now. nuPlan does not blame a car hit from behind,
    /// but a driver moving into a lane must leave the traffic in it room:
    /// in the fallbacks, where only the CBV's own faults count, a cut-in
    /// in front of a replayed car (which cannot yield) counts as one.
    /// Undecided (false) where the CBV is in no lane now or then.
    fn cut_in(&self, at: &AgentState, theirs: &AgentState) -> bool {
        let hit_from_behind = matches!(
            EgoCollisionKind::classify(at, theirs),
            EgoCollisionKind::ActiveRear | EgoCollisionKind::StoppedEgo
        );
        if !hit_from_behind || self.lanes_now.is_empty() {
            return false;
        }
        let map = self.world.map;
        let lanes_then = map.lanes_containing(&at.position, at.heading_rad);
        !lanes_then.is_empty()
            && !lanes_then.iter().any(|&then| self.lanes_now.iter().any(|&now| map.lanes_connected(now, then)))
    }

    /// Whether `rollout` breaks the rule: the checks stop at the first
    /// violation found (the plausibility fallback ranks the whole
    /// vocabulary, where most tokens break it).
    fn implausible(&self, rollout: &[AgentState], rule: ContactRule) -> bool {
        self.violation(rollout, Violation::Any, rule).is_some()
    }

    /// The first step (counted from the token's first state) at which
    /// `rollout` breaks the rule, or `None` for a plausible token.
    fn first_violation(&self, rollout: &[AgentState], rule: ContactRule) -> Option<usize> {
        self.violation(rollout, Violation::First, rule)
    }

    /// A step at which `rollout` breaks the rule: the first one, or (for
    /// [`Violation::Any`]) the first one the checks come to.
    fn violation(&self, rollout: &[AgentState], wanted: Violation, rule: ContactRule) -> Option<usize> {
        let end = rollout.last()?;
        let map = self.world.map;
        let braking: Vec<AgentState> = rollout.iter().copied().chain(braking_after(rollout)).collect();
        let mut first: Option<usize> = None;
        let note = |first: &mut Option<usize>, k: usize| *first = Some(first.map_or(k, |f| f.min(k)));
        if self.on_road_now {
            // Moving states only: a stopped CBV stays where it stopped.
            // On to a standstill: 2 s of braking from motorway speed
            // still leaves a bend to run out of (seen on WOMD
            // interactive: a CBV at 21 m/s judged able to stop on the road
            // that, a token later, had no token left that stayed on it).
            let to_standstill = continued_after(&braking, -MAX_ACCEL_MPS2, STANDSTILL_CHECK_MAX_STEPS);
            if let Some(k) = braking
                .iter()
                .copied()
                .chain(to_standstill)
                .take_while(|s| s.speed_mps() > 0.0)
                .position(|s| map.is_off_road_within_map(&s.position))
            {
                note(&mut first, k);
            }
        } else if let (Some(now), Some(then)) =
            (self.edge_distance_now, map.signed_distance_to_road_edge(&end.position))
            && then > now
        {
            // Off the road already: head back to it, not farther away.
            note(&mut first, rollout.len() - 1);
        }
        if wanted == Violation::Any && first.is_some() {
            return first;
        }
        // Each background agent's first contact is judged, as the metrics
        // judge a collision by its onset (a follower at constant velocity
        // would otherwise drive through the stopped CBV and seem to be hit
        // from the front). Holding the token, any contact counts: stopping
        // in the way of traffic is the CBV's doing too.
        // Both paths start with the token's own states: their boxes are built once.
        let body = |s: &AgentState| self.cbv_body.footprint(s);
        let token_boxes: Vec<OrientedBox> = rollout.iter().map(body).collect();
        let held = held_path(rollout);
        let held_boxes: Vec<OrientedBox> =
            token_boxes.iter().copied().chain(held[rollout.len()..].iter().map(body)).collect();
        let braking_boxes: Vec<OrientedBox> =
            token_boxes.into_iter().chain(braking[rollout.len()..].iter().map(body)).collect();
        let first_contact = |predicted: &[Option<(AgentState, OrientedBox)>], own: &[OrientedBox]| {
            predicted.iter().zip(own).position(|(theirs, own)| theirs.is_some_and(|(_, b)| b.intersects(own)))
        };
        let own_bounds = Bounds::of(held_boxes.iter().chain(&braking_boxes));
        for ((predicted, bounds), &replayed) in self.background.iter().zip(&self.background_bounds).zip(&self.replayed)
        {
            if wanted == Violation::Any && first.is_some() {
                break;
            }
            if !bounds.overlaps(&own_bounds) {
                continue;
            }
            if let Some(k) = first_contact(predicted, &held_boxes)
                && let Some((theirs, _)) = predicted[k]
            {
                let at_fault = || EgoContact::judge(map, &held[k], &held_boxes[k], &theirs).at_fault();
                let breaks_rule = match rule {
                    ContactRule::Any if k < rollout.len() + HOLDING_CHECK_STEPS => true,
                    // Keeping its speed: only replayed traffic closing on
                    // the CBV (the others react).
                    ContactRule::Any => replayed && !at_fault(),
                    ContactRule::AtFaultOnly if k < rollout.len() + HOLDING_CHECK_STEPS => {
                        at_fault() || self.cut_in(&held[k], &theirs)
                    }
                    ContactRule::AtFaultOnly => replayed && self.cut_in(&held[k], &theirs),
                };
                if breaks_rule {
                    note(&mut first, k);
                }
            }
            // Braking after the token: only what the CBV runs into.
            if let Some(k) = first_contact(predicted, &braking_boxes)
                && let Some((theirs, _)) = predicted[k]
                && EgoContact::judge(map, &braking[k], &braking_boxes[k], &theirs).at_fault()
            {
                note(&mut first, k);
            }
        }
        first
    }

    /// The likeliest plausible token among the ranks `ranks` of the prior's
    /// ranking of `logits` (most likely first), if any.
    fn likeliest_plausible(&self, logits: &[f32], ranks: std::ops::Range<usize>, rule: ContactRule) -> Option<Token> {
        let now = self.cbv_now.as_ref()?;
        let ranked = ranked_tokens(logits);
        let from = KinematicState::from_agent_state(now);
        ranked.get(ranks)?.iter().copied().find(|t| !self.implausible(&token_rollout(&from, *t), rule))
    }
}

impl AgentPolicy for Adversary {
    fn name(&self) -> &'static str {
        "safer-adversary"
    }

    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
        let start = {
            let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
            shared.observe(world);
            shared.start()
        };
        if world.state(agent).is_none() {
            return AgentAction::Absent;
        }
        let boundary = world.step.saturating_sub(start) % TOKEN_PERIOD_STEPS == 0;
        if boundary || self.current.is_none() {
            let seed = self.shared.lock().unwrap_or_else(|p| p.into_inner()).seed();
            let token_index = world.step.saturating_sub(start) / TOKEN_PERIOD_STEPS;
            let chosen = if token_index < Self::approach_tokens(seed, agent) {
                // The approach phase: the prior drives the CBV.
                Ok(self.approach_token(world, agent))
            } else {
                self.choose(world, agent)
            };
            match chosen {
                Ok(Some(t)) => self.current = Some(t),
                Ok(None) => {}
                Err(e) => {
                    let error = Arc::new(e);
                    self.shared.lock().unwrap_or_else(|p| p.into_inner()).record_error(error.clone());
                    self.error.get_or_insert(error);
                }
            }
        }
        AgentAction::Control(self.current.map(TokenGrid::action).unwrap_or_default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::map::RoadMap;
    use crate::motion::Action;
    use crate::scenario::{AgentBody, AgentKind};

    fn car(x: f64, y: f64, speed_mps: f64) -> Option<AgentState> {
        Some(AgentState { position: Point2::new(x, y), heading_rad: 0.0, velocity_mps: Vector2::new(speed_mps, 0.0) })
    }

    fn token(accel_mps2: f64) -> Token {
        TokenGrid::quantize(Action { accel_mps2, yaw_rate_radps: 0.0 })
    }

    #[test]
    fn a_token_the_cbv_cannot_brake_out_of_is_implausible() {
        // Ego far away; the CBV at 15 m/s, 25 m behind a stopped car. Full
        // acceleration for 0.5 s leaves it no room to stop (about 8 m at
        // 19 m/s / 5 m/s² needs 36 m); full braking does.
        let map = RoadMap::default();
        let body = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };
        let bodies = [body; 3];
        let states = [car(0.0, 100.0, 10.0), car(0.0, 0.0, 15.0), car(30.0, 0.0, 0.0)];
        let world = WorldView { map: &map, step: 10, bodies: &bodies, states: &states };
        let (ego, cbv) = (TrackIndex(0), TrackIndex(1));
        let tokens = [token(MAX_ACCEL_MPS2), token(0.0), token(-MAX_ACCEL_MPS2)];
        let rollouts = token_rollouts(states[1].as_ref().unwrap(), &tokens);
        let implausible = |world: &WorldView<'_>| {
            let check = PlausibilityCheck::new(world, cbv, ego, &BackgroundForecast::default());
            rollouts.iter().map(|r| check.implausible(r, ContactRule::Any)).collect::<Vec<bool>>()
        };
        assert_eq!(implausible(&world), vec![true, true, false]);
        // The same tokens with the stopped car in the next lane are all plausible.
        let beside = [states[0], states[1], car(30.0, 4.0, 0.0)];
        let world = WorldView { states: &beside, ..world };
        assert_eq!(implausible(&world), vec![false; 3]);
    }

    /// Ego far away, the CBV at 10 m/s, and a car 12 m ahead of it at
    /// 10 m/s whose recording brakes at 8 m/s² to a stop (6.25 m on).
    fn behind_a_recorded_braking_car() -> (crate::scenario::Scenario, [Option<AgentState>; 3]) {
        use crate::scenario::{AgentId, ScenarioSource, Track};
        let states = [car(0.0, 100.0, 0.0), car(0.0, 0.0, 10.0), car(12.0, 0.0, 10.0)];
        let braking = (0..40)
            .map(|k| {
                let t = (k as f64 * SIM_DT_S).min(1.25);
                car(12.0 + 10.0 * t - 4.0 * t * t, 0.0, 10.0 - 8.0 * t)
            })
            .collect();
        let held = |s: Option<AgentState>| (0..40).map(|_| s).collect();
        let track = |id: &str, states| Track {
            id: AgentId(id.into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            states,
        };
        let tracks = vec![track("ego", held(states[0])), track("cbv", held(states[1])), track("lead", braking)];
        let scenario = crate::scenario::Scenario::new(
            "braking-lead",
            ScenarioSource::authored("test"),
            SIM_DT_S,
            RoadMap::default(),
            tracks,
        )
        .with_roles(TrackIndex(0), Some(TrackIndex(1)));
        (scenario, states)
    }

    #[test]
    fn a_replayed_car_is_forecast_by_its_recording_and_others_at_constant_velocity() {
        let (scenario, states) = behind_a_recorded_braking_car();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let world = WorldView { map: &scenario.map, step: 0, bodies: &bodies, states: &states };
        let tokens = [token(0.0), token(-MAX_ACCEL_MPS2)];
        let rollouts = token_rollouts(states[1].as_ref().unwrap(), &tokens);
        let implausible = |world: &WorldView<'_>, forecast: BackgroundForecast<'_>| {
            let check = PlausibilityCheck::new(world, TrackIndex(1), TrackIndex(0), &forecast);
            rollouts.iter().map(|r| check.implausible(r, ContactRule::Any)).collect::<Vec<bool>>()
        };
        // Replayed: holding speed runs into the car as it brakes; braking does not.
        let replayed = BackgroundForecast { recording: Some(&scenario), not_replayed: &[] };
        assert_eq!(implausible(&world, replayed), vec![true, false]);
        // At constant velocity the car keeps its 10 m/s: both are plausible.
        assert_eq!(implausible(&world, BackgroundForecast::default()), vec![false, false]);
        // Driven by the prior, or 1 m off its recording: constant velocity too.
        assert_eq!(implausible(&world, BackgroundForecast { not_replayed: &[2], ..replayed }), vec![false, false]);
        let off = [states[0], states[1], car(13.0, 0.0, 10.0)];
        let world = WorldView { states: &off, ..world };
        assert_eq!(implausible(&world, replayed), vec![false, false]);
    }

    /// A recording in which every agent of `states` keeps its velocity for 4 s.
    fn recorded_at_constant_velocity(states: &[Option<AgentState>]) -> crate::scenario::Scenario {
        use crate::scenario::{AgentId, ScenarioSource, Track};
        let tracks = states
            .iter()
            .enumerate()
            .map(|(i, s)| Track {
                id: AgentId(format!("agent-{i}")),
                kind: AgentKind::Vehicle,
                length_m: 4.5,
                width_m: 2.0,
                states: (0..40)
                    .map(|k| {
                        s.map(|s| AgentState { position: s.position + s.velocity_mps * (k as f64 * SIM_DT_S), ..s })
                    })
                    .collect(),
            })
            .collect();
        crate::scenario::Scenario::new(
            "constant-velocity",
            ScenarioSource::authored("test"),
            SIM_DT_S,
            RoadMap::default(),
            tracks,
        )
        .with_roles(TrackIndex(0), Some(TrackIndex(1)))
    }

    #[test]
    fn slowing_in_front_of_replayed_traffic_closing_fast_is_implausible_seconds_before_contact() {
        // Ego far away; the CBV at 10 m/s and a replayed car 40 m behind it
        // at 25 m/s (35.5 m between the boxes, 15 m/s faster: contact in
        // 2.4 s at constant speeds, after the token and its 1 s hold).
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let tokens = [token(MAX_ACCEL_MPS2), token(0.0), token(-2.0)];
        let implausible = |states: &[Option<AgentState>; 3], not_replayed: &[usize]| {
            let scenario = recorded_at_constant_velocity(states);
            let world = WorldView { map: &scenario.map, step: 0, bodies: &bodies, states };
            let forecast = BackgroundForecast { recording: Some(&scenario), not_replayed };
            let check = PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &forecast);
            token_rollouts(states[1].as_ref().unwrap(), &tokens)
                .iter()
                .map(|r| check.implausible(r, ContactRule::Any))
                .collect::<Vec<bool>>()
        };
        let closing = [car(0.0, 100.0, 10.0), car(0.0, 0.0, 10.0), car(-40.0, 0.0, 25.0)];
        // Speeding up keeps ahead of it; keeping the speed or slowing down
        // is to be run into.
        assert_eq!(implausible(&closing, &[]), vec![false, true, true]);
        // A car the prior drives can brake: only the 1 s hold is checked.
        assert_eq!(implausible(&closing, &[2]), vec![false; 3]);
        // 80 m behind, it reaches the CBV in none of the three within 3.5 s.
        let far = [closing[0], closing[1], car(-80.0, 0.0, 25.0)];
        assert_eq!(implausible(&far, &[]), vec![false; 3]);
        // What the CBV would run into seconds ahead at its speed is left to
        // the braking check: a stopped car 25.5 m ahead is reached in
        // 2.55 s, and the CBV can still stop short of it.
        let ahead = [closing[0], closing[1], car(30.0, 0.0, 0.0)];
        assert_eq!(implausible(&ahead, &[]), vec![false; 3]);
    }

    #[test]
    fn the_ego_is_never_an_obstacle_of_the_plausibility_check() {
        // The adversary exists to reach the ego: closing on it is not implausible.
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(20.0, 0.0, 0.0), car(0.0, 0.0, 15.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let rollouts = token_rollouts(states[1].as_ref().unwrap(), &[token(MAX_ACCEL_MPS2)]);
        assert!(
            !PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &BackgroundForecast::default())
                .implausible(&rollouts[0], ContactRule::Any)
        );
    }

    /// A road 8 m wide along +x (y from -2 to 6) that ends at x = 40: one
    /// road edge with the road on its left.
    fn dead_end_road() -> RoadMap {
        use crate::geometry::Polyline;
        use crate::map::{MapElementId, RoadEdge, RoadEdgeKind};
        let points = [(-50.0, -2.0), (40.0, -2.0), (40.0, 6.0), (-50.0, 6.0)];
        let polyline = Polyline::new(points.iter().map(|&(x, y)| Point2::new(x, y)).collect());
        let edge = RoadEdge { id: MapElementId(1), polyline, kind: RoadEdgeKind::Boundary };
        RoadMap::new(vec![], vec![edge], vec![], vec![], vec![], vec![], vec![])
    }

    #[test]
    fn bounds_hold_their_boxes_and_only_disjoint_ones_are_told_apart() {
        use crate::geometry::{Point2, Pose2};
        let at = |x: f64, y: f64, heading_rad: f64| {
            OrientedBox::new(Pose2 { position: Point2::new(x, y), heading_rad }, 4.0, 2.0)
        };
        let path = Bounds::of(&[at(0.0, 0.0, 0.0), at(10.0, 0.0, 0.7)]);
        // A box touching the path's last box at a corner is inside the bounds.
        let touching = at(12.5, 1.9, 0.0);
        assert!(touching.intersects(&at(10.0, 0.0, 0.7)));
        assert!(path.overlaps(&Bounds::of(&[touching])));
        // One 3 m clear of them is not.
        assert!(!path.overlaps(&Bounds::of(&[at(10.0, 8.0, 0.0)])));
        // No boxes overlap nothing; NaN proves nothing.
        assert!(!path.overlaps(&Bounds::of(&[])));
        assert!(path.overlaps(&Bounds::of(&[at(f64::NAN, 0.0, 0.0)])));
    }

    fn implausible_tokens(world: &WorldView<'_>, cbv: TrackIndex, tokens: &[Token]) -> Vec<bool> {
        let check = PlausibilityCheck::new(world, cbv, TrackIndex(0), &BackgroundForecast::default());
        token_rollouts(world.states[cbv.0].as_ref().unwrap(), tokens)
            .iter()
            .map(|r| check.implausible(r, ContactRule::Any))
            .collect()
    }

    #[test]
    fn a_token_after_which_the_cbv_cannot_stop_on_the_road_is_implausible() {
        // 30 m before the dead end at 15 m/s: full braking stops it on the
        // road (about 23 m); full acceleration for 0.5 s leaves it no room,
        // though the token itself stays on the road.
        let map = dead_end_road();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(-40.0, 0.0, 0.0), car(10.0, 2.0, 15.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        assert_eq!(
            implausible_tokens(&world, TrackIndex(1), &[token(MAX_ACCEL_MPS2), token(-MAX_ACCEL_MPS2)]),
            vec![true, false]
        );
    }

    #[test]
    fn room_to_stop_is_judged_to_a_standstill_not_over_the_first_two_seconds() {
        // 67 m before the dead end at 25 m/s. Holding speed for the token,
        // 2 s of full braking end 14.5 m short of the end, still at
        // 15 m/s: the standstill lies 8 m past it. Braking as the token
        // stops it 4.5 m short.
        let map = dead_end_road();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(-45.0, 0.0, 0.0), car(-27.0, 2.0, 25.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        assert_eq!(implausible_tokens(&world, TrackIndex(1), &[token(0.0), token(-MAX_ACCEL_MPS2)]), vec![true, false]);
    }

    #[test]
    fn off_the_road_the_cbv_must_head_back_to_it() {
        // 2 m beside the road's left edge (y = 6), heading along it.
        let map = dead_end_road();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(-40.0, 0.0, 0.0), car(0.0, 8.0, 5.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let turn = |yaw_rate_radps| TokenGrid::quantize(Action { accel_mps2: 0.0, yaw_rate_radps });
        assert_eq!(implausible_tokens(&world, TrackIndex(1), &[turn(0.5), turn(-0.5)]), vec![true, false]);
    }

    #[test]
    fn no_brake_checks_on_a_follower_but_stopping_room_is_judged_on_what_the_cbv_hits() {
        // A follower 3.5 m behind at the same 10 m/s (constant velocity).
        // Keeping speed is plausible, though braking hard after the token
        // would get the CBV hit from behind (the follower's doing, not the
        // CBV's); braking hard as the token, held for a second, is a brake
        // check and implausible.
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let states = [car(0.0, 100.0, 0.0), car(0.0, 0.0, 10.0), car(-8.0, 0.0, 10.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        assert_eq!(implausible_tokens(&world, TrackIndex(1), &[token(0.0), token(-MAX_ACCEL_MPS2)]), vec![false, true]);
        // The follower 20 m behind: braking hard is no brake check.
        let far = [states[0], states[1], car(-20.0, 0.0, 10.0)];
        let world = WorldView { states: &far, ..world };
        assert_eq!(
            implausible_tokens(&world, TrackIndex(1), &[token(0.0), token(-MAX_ACCEL_MPS2)]),
            vec![false, false]
        );
    }

    #[test]
    fn stopping_in_the_way_of_crossing_traffic_is_implausible() {
        // The CBV at 2 m/s stands in the path of a car crossing at 10 m/s,
        // 1 s away. Stopping there gets it hit (a stopped CBV is not at
        // fault by the metrics' rule, but it chose to stop there);
        // accelerating clears the path in time.
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let crossing = AgentState {
            position: Point2::new(8.0, -12.0),
            heading_rad: std::f64::consts::FRAC_PI_2,
            velocity_mps: Vector2::new(0.0, 10.0),
        };
        let states = [car(0.0, 100.0, 0.0), car(8.0, 0.0, 2.0), Some(crossing)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        assert_eq!(
            implausible_tokens(&world, TrackIndex(1), &[token(-MAX_ACCEL_MPS2), token(MAX_ACCEL_MPS2)]),
            vec![true, false]
        );
    }

    #[test]
    fn with_no_plausible_token_in_the_trust_region_the_likeliest_plausible_one_is_taken() {
        // Before the dead end: the prior likes accelerating (implausible);
        // among the rest it prefers -4 m/s² to -5 m/s².
        let map = dead_end_road();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(-40.0, 0.0, 0.0), car(10.0, 2.0, 15.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let mut logits = vec![-10.0f32; crate::motion::tokens::VOCABULARY_SIZE];
        logits[token(MAX_ACCEL_MPS2).0 as usize] = 5.0;
        logits[token(3.0).0 as usize] = 4.0;
        logits[token(-4.0).0 as usize] = 2.0;
        logits[token(-MAX_ACCEL_MPS2).0 as usize] = 1.0;
        let check = PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &BackgroundForecast::default());
        assert_eq!(
            check.likeliest_plausible(&logits, 0..2, ContactRule::Any),
            None,
            "the trust region of two holds none"
        );
        assert_eq!(check.likeliest_plausible(&logits, 2..logits.len(), ContactRule::Any), Some(token(-4.0)));
    }

    /// A feasibility value from a rule on the candidate state.
    struct StubOracle(fn(&EgoCbvState) -> f32);
    impl FeasibilityOracle for StubOracle {
        fn values(&self, pairs: &[EgoCbvState]) -> Result<Vec<f32>, ModelError> {
            Ok(pairs.iter().map(self.0).collect())
        }
    }

    /// The choice with the CBV 30 m behind the ego, both at 10 m/s along
    /// +x on an open plane, and the prior liking the accelerations
    /// `liked` (m/s², logit) and nothing else.
    fn choice(liked: &[(f64, f32)], trust_region: TrustRegion, oracle: Option<&dyn FeasibilityOracle>) -> Token {
        let states = [car(30.0, 0.0, 10.0), car(0.0, 0.0, 10.0)];
        choice_in(&states, liked, Search::one_step(trust_region), oracle)
    }

    /// The choice with the ego (index 0), the CBV (index 1) and any other
    /// cars (background at constant velocity) in `states` on an open plane.
    fn choice_in(
        states: &[Option<AgentState>],
        liked: &[(f64, f32)],
        search: Search,
        oracle: Option<&dyn FeasibilityOracle>,
    ) -> Token {
        let map = RoadMap::default();
        let bodies = vec![AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; states.len()];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states };
        let mut logits = vec![-30.0f32; crate::motion::tokens::VOCABULARY_SIZE];
        for &(accel_mps2, logit) in liked {
            logits[token(accel_mps2).0 as usize] = logit;
        }
        let mut feasibility_s = 0.0;
        safer_choice(
            &world,
            (TrackIndex(1), TrackIndex(0)),
            &logits,
            search,
            &BackgroundForecast::default(),
            oracle,
            &mut feasibility_s,
        )
        .unwrap()
        .unwrap()
    }

    #[test]
    fn the_approach_draws_only_among_the_checked_plausible_tokens_of_the_top_k() {
        // 25 m behind a stopped car at 15 m/s: of the top two, full
        // acceleration is implausible and full braking plausible; holding
        // speed (implausible too, ranked third and as likely as braking)
        // lies outside the top two and is never checked, so never drawn.
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let states = [car(0.0, 100.0, 10.0), car(0.0, 0.0, 15.0), car(30.0, 0.0, 0.0)];
        let world = WorldView { map: &map, step: 10, bodies: &bodies, states: &states };
        let mut logits = vec![-30.0f32; crate::motion::tokens::VOCABULARY_SIZE];
        logits[token(MAX_ACCEL_MPS2).0 as usize] = 5.0;
        logits[token(-MAX_ACCEL_MPS2).0 as usize] = 4.0;
        logits[token(0.0).0 as usize] = 4.0 - 1e-6;
        let sampling = TokenSampling { top_k: 2, temperature: 1.0 };
        for seed in 0..32 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let drawn = approach_draw(
                &world,
                (TrackIndex(1), TrackIndex(0)),
                &logits,
                sampling,
                &BackgroundForecast::default(),
                &mut rng,
            );
            assert_eq!(drawn, token(-MAX_ACCEL_MPS2), "seed {seed}");
        }
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
        let mut logits = vec![-30.0f32; crate::motion::tokens::VOCABULARY_SIZE];
        for (accel_mps2, logit) in liked {
            logits[token(accel_mps2).0 as usize] = logit;
        }
        let check = PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &BackgroundForecast::default());
        let rollouts = token_rollouts(states[1].as_ref().unwrap(), &[token(MAX_ACCEL_MPS2), token(0.0)]);
        for rule in [ContactRule::Any, ContactRule::AtFaultOnly] {
            let implausible: Vec<bool> = rollouts.iter().map(|r| check.implausible(r, rule)).collect();
            let expected = if rule == ContactRule::Any { vec![true, true] } else { vec![true, false] };
            assert_eq!(implausible, expected, "{rule:?}");
        }
        assert_eq!(check.likeliest_plausible(&logits, 0..logits.len(), ContactRule::Any), None);
        assert_eq!(choice_in(&states, &liked, Search::one_step(TrustRegion::TopN(2)), None), token(0.0));
    }

    #[test]
    fn in_the_fallback_a_cut_in_hit_from_behind_is_the_cbvs_fault_and_keeping_its_lane_is_not() {
        // Two eastbound lanes (y 0–3.5 and 3.5–7). The CBV at 10 m/s with
        // its centre just inside the left lane (y = 3.6); a follower in the
        // right lane 8 m behind at 20 m/s. Keeping its lane, the follower
        // clips the CBV's rear corner: hit from behind in its own lane, not
        // its fault (nuPlan). Moving over into the right lane in front of
        // the follower (a crabbing path, to keep the geometry plain), the
        // same hit from behind is a cut-in: its fault in the fallback.
        let map = crate::map::templates::StraightRoad {
            lanes: 2,
            oncoming_lanes: 0,
            lane_width_m: 3.5,
            length_m: 200.0,
            speed_limit_mps: None,
        }
        .build();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let states = [car(150.0, 5.25, 10.0), car(100.0, 3.6, 10.0), car(92.0, 1.75, 20.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let check = PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &BackgroundForecast::default());
        let path = |lateral_m: fn(usize) -> f64| -> Vec<AgentState> {
            (1..=TOKEN_PERIOD_STEPS)
                .map(|k| car(100.0 + k as f64 * 10.0 * SIM_DT_S, lateral_m(k), 10.0).unwrap())
                .collect()
        };
        let keeping_its_lane = path(|_| 3.6);
        let cutting_in = path(|k| 3.6 - 0.2 * k as f64);
        assert!(check.implausible(&keeping_its_lane, ContactRule::Any), "the follower hits it");
        assert!(!check.implausible(&keeping_its_lane, ContactRule::AtFaultOnly));
        assert!(check.implausible(&cutting_in, ContactRule::AtFaultOnly));
    }

    const LIKED: [(f64, f32); 5] = [(-5.0, 5.0), (-2.0, 4.0), (0.0, 3.0), (2.0, 2.0), (5.0, 1.0)];

    #[test]
    fn the_choice_is_the_arg_min_of_the_distance_within_the_trust_region() {
        // Closing on the ego ahead: the hardest acceleration of the region.
        assert_eq!(choice(&LIKED, TrustRegion::TopN(5), None), token(5.0));
        // The region of the three likeliest leaves out +2 and +5.
        assert_eq!(choice(&LIKED, TrustRegion::TopN(3), None), token(0.0));
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
    fn equal_losses_go_to_the_likelier_token_then_the_lower_id() {
        let all_equal = StubOracle(|_| 1.0);
        assert_eq!(choice(&LIKED, TrustRegion::TopN(5), Some(&all_equal)), token(-5.0));
        let level = [(-2.0, 2.0), (2.0, 2.0), (0.0, 1.0)];
        let lower = token(-2.0).min(token(2.0));
        assert_eq!(choice(&level, TrustRegion::TopN(3), Some(&all_equal)), lower);
    }

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

    #[test]
    fn approach_phases_cover_the_range_and_depend_on_the_seed() {
        let lengths: Vec<usize> = (0..64).map(|seed| Adversary::approach_tokens(seed, TrackIndex(3))).collect();
        assert!(lengths.iter().all(|n| APPROACH_TOKENS.contains(n)), "{lengths:?}");
        for n in APPROACH_TOKENS {
            assert!(lengths.contains(&n), "{n} never drawn in {lengths:?}");
        }
        // A pure function of the seed.
        assert_eq!(Adversary::approach_tokens(5, TrackIndex(3)), Adversary::approach_tokens(5, TrackIndex(3)));
    }
}
