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
//! - **Plausibility.** A candidate is kept out of the choice, while any
//!   other remains, when its 0.5 s rollout takes the CBV from the road onto
//!   the off-road area, or when the CBV, braking as hard as it can after
//!   it, would still run into a background vehicle (predicted at constant
//!   velocity over 2 s): the CBV must stay a plausible road user. The same
//!   rule restricts the prior's draws in the approach phase.
//!
//! The ablations are the same policy with a part switched off.

use std::sync::{Arc, Mutex};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::prior_sampling::{PriorTraffic, draw_seed, sample_token, top_tokens};
use super::{AgentAction, AgentPolicy, WorldView};
use crate::geometry::OrientedBox;
use crate::models::ModelError;
pub use crate::models::feasibility_oracle::{EgoCbvState, FeasibilityOracle};
use crate::motion::tokens::{MAX_ACCEL_MPS2, SIM_DT_S, TOKEN_PERIOD_S, TOKEN_PERIOD_STEPS, Token, TokenGrid};
use crate::motion::{Action, KinematicState, kinematic_step};
use crate::scenario::{AgentState, TrackIndex};

/// Penalty added to V_h for candidates outside the feasible region (the paper's Δ).
pub const INFEASIBLE_PENALTY: f64 = 50.0;

/// The approach phase: the prior drives the CBV for this many token
/// periods (drawn per seed, uniformly) before the adversary engages.
pub const APPROACH_TOKENS: std::ops::RangeInclusive<usize> = 1..=4;

/// Background agents farther than this from the CBV cannot be reached
/// within the plausibility check's horizon and are not checked, m.
const BACKGROUND_CHECK_RANGE_M: f64 = 80.0;

/// After a candidate token the plausibility check brakes the CBV this many
/// simulator steps (2 s) to see whether it could still stop short of the
/// background traffic.
const BRAKING_CHECK_STEPS: usize = 20;

/// Which tokens the adversary may choose from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrustRegion {
    /// The prior's n most likely tokens.
    TopN(usize),
    /// The whole vocabulary (the `no-trust-region` ablation).
    WholeVocabulary,
}

/// The adversary of one rollout's CBV.
pub struct Adversary {
    shared: Arc<Mutex<PriorTraffic>>,
    ego: TrackIndex,
    trust_region: TrustRegion,
    feasibility: Option<Arc<dyn FeasibilityOracle>>,
    current: Option<Token>,
    error: Option<Arc<ModelError>>,
}

impl std::fmt::Debug for Adversary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Adversary")
            .field("ego", &self.ego)
            .field("trust_region", &self.trust_region)
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
        trust_region: TrustRegion,
        feasibility: Option<Arc<dyn FeasibilityOracle>>,
    ) -> Self {
        Self { shared, ego, trust_region, feasibility, current: None, error: None }
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
        drop(shared);
        // The trust region, most likely first: the top of `ranked_tokens`
        // without sorting the whole vocabulary.
        let k = match self.trust_region {
            TrustRegion::TopN(n) => n.max(1).min(logits.len()),
            TrustRegion::WholeVocabulary => logits.len(),
        };
        let candidates = &top_tokens(&logits, k)[..];
        let (Some(cbv_now), Some(ego_now)) = (world.state(cbv), world.state(self.ego)) else {
            return Ok(candidates.first().copied());
        };
        let ego_next = ego_prediction(ego_now);
        let (ego_body, cbv_body) = (world.body(self.ego), world.body(cbv));
        let ego_box = OrientedBox::new(ego_next.pose(), ego_body.length_m, ego_body.width_m);
        let rollouts = token_rollouts(cbv_now, candidates);
        let predicted: Vec<AgentState> = rollouts.iter().map(|r| r[TOKEN_PERIOD_STEPS - 1]).collect();
        let distances: Vec<f64> = predicted
            .iter()
            .map(|s| ego_box.distance(&OrientedBox::new(s.pose(), cbv_body.length_m, cbv_body.width_m)))
            .collect();
        let losses: Vec<f64> = match &self.feasibility {
            None => distances,
            Some(oracle) => {
                let pairs: Vec<EgoCbvState> =
                    predicted.iter().map(|s| EgoCbvState { ego: ego_next, ego_body, cbv: *s, cbv_body }).collect();
                let clock = std::time::Instant::now();
                let values = oracle.values(&pairs);
                self.shared
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .add_feasibility_time(clock.elapsed().as_secs_f64());
                let values = values?;
                // A NaN value is a broken model, not a feasible state: fail
                // the variant with the model named rather than guess.
                if let Some(i) = values.iter().position(|v| v.is_nan()) {
                    return Err(ModelError::Inference {
                        model: "feasibility value V_h".into(),
                        message: format!("returned NaN for candidate token {} of {}", i, values.len()),
                    });
                }
                distances
                    .iter()
                    .zip(values)
                    .map(|(d, v)| if v <= 0.0 { *d } else { v as f64 + INFEASIBLE_PENALTY })
                    .collect()
            }
        };
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
        let check = PlausibilityCheck::new(world, cbv, self.ego);
        let best = order.iter().copied().find(|&i| !check.implausible(&rollouts[i])).or(order.first().copied());
        Ok(best.map(|i| candidates[i]))
    }

    /// The approach phase's token: a draw from the prior (with the
    /// rollout's seed and sampling) among the plausible candidates of its
    /// top k, or among all of them when none is plausible.
    fn approach_token(&self, world: &WorldView<'_>, cbv: TrackIndex) -> Option<Token> {
        let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
        let (seed, sampling) = (shared.seed(), shared.sampling());
        let logits = shared.logits_at(cbv.0, world.step)?.clone();
        drop(shared);
        let top = &top_tokens(&logits, sampling.top_k.clamp(1, logits.len()))[..];
        let mut masked = logits.clone();
        if let Some(cbv_now) = world.state(cbv) {
            let check = PlausibilityCheck::new(world, cbv, self.ego);
            let implausible: Vec<bool> = token_rollouts(cbv_now, top).iter().map(|r| check.implausible(r)).collect();
            if implausible.iter().any(|bad| !bad) {
                for (t, bad) in top.iter().zip(implausible) {
                    if bad {
                        masked[t.0 as usize] = f32::NEG_INFINITY;
                    }
                }
            }
        }
        // Masked tokens rank last, so the top k keeps every plausible one.
        let mut rng = ChaCha8Rng::seed_from_u64(draw_seed(seed, cbv.0, world.step));
        Some(sample_token(&masked, sampling, &mut rng))
    }

    /// How many token periods of the approach phase this rollout's seed gives.
    fn approach_tokens(seed: u64, cbv: TrackIndex) -> usize {
        let mut rng = ChaCha8Rng::seed_from_u64(draw_seed(seed, cbv.0, usize::MAX));
        rng.random_range(APPROACH_TOKENS)
    }
}

/// The CBV's states over one token period from `now` under each token.
fn token_rollouts(now: &AgentState, tokens: &[Token]) -> Vec<Vec<AgentState>> {
    let from = KinematicState::from_agent_state(now);
    tokens.iter().map(|t| TokenGrid::rollout(&from, *t).iter().map(KinematicState::to_agent_state).collect()).collect()
}

/// Whether a candidate rollout of the CBV (one state per simulator step of
/// the token) is implausible for a road user: it leaves the road while the
/// CBV is on it now, or the CBV, braking as hard as it can after the token,
/// would still overlap a background agent predicted at constant velocity.
/// The background's predicted boxes are built once per decision.
struct PlausibilityCheck<'w> {
    world: &'w WorldView<'w>,
    cbv_body: crate::scenario::AgentBody,
    /// Each nearby background agent's boxes, one per step of the check.
    background: Vec<Vec<OrientedBox>>,
    on_road_now: bool,
}

impl<'w> PlausibilityCheck<'w> {
    fn new(world: &'w WorldView<'w>, cbv: TrackIndex, ego: TrackIndex) -> Self {
        let cbv_body = world.body(cbv);
        let Some(cbv_now) = world.state(cbv) else {
            return Self { world, cbv_body, background: Vec::new(), on_road_now: false };
        };
        let horizon = TOKEN_PERIOD_STEPS + BRAKING_CHECK_STEPS;
        let background = (0..world.states.len())
            .filter(|&i| i != cbv.0 && i != ego.0)
            .filter_map(|i| world.states[i].map(|s| (i, s)))
            .filter(|(_, s)| (s.position - cbv_now.position).norm() < BACKGROUND_CHECK_RANGE_M)
            .map(|(i, s)| {
                let b = world.bodies[i];
                (1..=horizon)
                    .map(|k| {
                        let at = AgentState { position: s.position + s.velocity_mps * (k as f64 * SIM_DT_S), ..s };
                        OrientedBox::new(at.pose(), b.length_m, b.width_m)
                    })
                    .collect()
            })
            .collect();
        Self { world, cbv_body, background, on_road_now: !world.map.is_off_road(&cbv_now.position) }
    }

    fn implausible(&self, rollout: &[AgentState]) -> bool {
        let Some(end) = rollout.last() else { return false };
        if self.on_road_now && rollout.iter().any(|s| self.world.map.is_off_road(&s.position)) {
            return true;
        }
        let brake = Action { accel_mps2: -MAX_ACCEL_MPS2, yaw_rate_radps: 0.0 };
        let mut braking = KinematicState::from_agent_state(end);
        let path = rollout.iter().copied().chain((0..BRAKING_CHECK_STEPS).map(|_| {
            braking = kinematic_step(&braking, brake, SIM_DT_S);
            braking.to_agent_state()
        }));
        path.enumerate().any(|(k, s)| {
            let own = OrientedBox::new(s.pose(), self.cbv_body.length_m, self.cbv_body.width_m);
            self.background.iter().any(|boxes| boxes.get(k).is_some_and(|b| b.intersects(&own)))
        })
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
            let check = PlausibilityCheck::new(world, cbv, ego);
            rollouts.iter().map(|r| check.implausible(r)).collect::<Vec<bool>>()
        };
        assert_eq!(implausible(&world), vec![true, true, false]);
        // The same tokens with the stopped car in the next lane are all plausible.
        let beside = [states[0], states[1], car(30.0, 4.0, 0.0)];
        let world = WorldView { states: &beside, ..world };
        assert_eq!(implausible(&world), vec![false; 3]);
    }

    #[test]
    fn the_ego_is_never_an_obstacle_of_the_plausibility_check() {
        // The adversary exists to reach the ego: closing on it is not implausible.
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(20.0, 0.0, 0.0), car(0.0, 0.0, 15.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let rollouts = token_rollouts(states[1].as_ref().unwrap(), &[token(MAX_ACCEL_MPS2)]);
        assert!(!PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0)).implausible(&rollouts[0]));
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
