//! The SaFeR adversary: drives the critical background vehicle (CBV) token
//! by token. Every token period it takes the realism prior's top-n tokens
//! (the trust region, which keeps the behaviour human-like), predicts the
//! CBV's state after each through the kinematic model, and picks the token
//! with the least loss: the box distance to the ego when the feasibility
//! value says the ego can still avoid a collision (V_h ≤ 0), else V_h + Δ
//! (so an unavoidable state is chosen only when nothing else is left). The
//! ablations are the same policy with a part switched off.

use std::sync::{Arc, Mutex};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::prior_sampling::{PriorTraffic, draw_seed, ranked_tokens};
use super::{AgentAction, AgentPolicy, WorldView};
use crate::geometry::OrientedBox;
use crate::models::ModelError;
pub use crate::models::feasibility_oracle::{EgoCbvState, FeasibilityOracle};
use crate::motion::KinematicState;
use crate::motion::tokens::{TOKEN_PERIOD_S, TOKEN_PERIOD_STEPS, Token, TokenGrid};
use crate::scenario::{AgentState, TrackIndex};

/// Penalty added to V_h for candidates outside the feasible region (the paper's Δ).
pub const INFEASIBLE_PENALTY: f64 = 50.0;

/// Candidates whose loss is within this of the best are equally adversarial
/// (m of box distance; V_h differences above it matter).
pub const NEAR_OPTIMAL_LOSS_M: f64 = 0.25;

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
        let seed = shared.seed();
        let Some(logits) = shared.logits_at(cbv.0, world.step).cloned() else { return Ok(None) };
        drop(shared);
        let ranked = ranked_tokens(&logits);
        let (Some(cbv_now), Some(ego_now)) = (world.state(cbv), world.state(self.ego)) else {
            return Ok(ranked.first().copied());
        };
        let candidates = match self.trust_region {
            TrustRegion::TopN(n) => &ranked[..n.max(1).min(ranked.len())],
            TrustRegion::WholeVocabulary => &ranked[..],
        };
        let ego_next = ego_prediction(ego_now);
        let (ego_body, cbv_body) = (world.body(self.ego), world.body(cbv));
        let ego_box = OrientedBox::new(ego_next.pose(), ego_body.length_m, ego_body.width_m);
        let from = KinematicState::from_agent_state(cbv_now);
        let predicted: Vec<AgentState> =
            candidates.iter().map(|t| TokenGrid::rollout(&from, *t)[TOKEN_PERIOD_STEPS - 1].to_agent_state()).collect();
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
        // Among the candidates (nearly) as adversarial as the best, draw one
        // by its prior probability with the variant's seed: seeds then give
        // different, equally adversarial variants, and likelier tokens win.
        // A NaN distance (never expected: states are bounds-checked) ranks last.
        let losses: Vec<f64> = losses.into_iter().map(|l| if l.is_nan() { f64::INFINITY } else { l }).collect();
        let best_loss = losses.iter().copied().fold(f64::INFINITY, f64::min);
        let near: Vec<usize> =
            (0..candidates.len()).filter(|&i| losses[i] <= best_loss + NEAR_OPTIMAL_LOSS_M).collect();
        let Some(&last) = near.last() else {
            // Every loss infinite: no candidate is better than another, so
            // the prior's likeliest token drives the CBV.
            return Ok(candidates.first().copied());
        };
        let weights: Vec<f64> = {
            let top = near.iter().map(|&i| logits[candidates[i].0 as usize]).fold(f32::NEG_INFINITY, f32::max);
            near.iter().map(|&i| ((logits[candidates[i].0 as usize] - top) as f64).exp()).collect()
        };
        let mut rng = ChaCha8Rng::seed_from_u64(draw_seed(seed, cbv.0, world.step));
        let mut u = rng.random::<f64>() * weights.iter().sum::<f64>();
        let mut best = last;
        for (&i, w) in near.iter().zip(&weights) {
            if u < *w {
                best = i;
                break;
            }
            u -= w;
        }
        Ok(Some(candidates[best]))
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
            match self.choose(world, agent) {
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
