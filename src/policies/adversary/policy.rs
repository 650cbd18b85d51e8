//! The [`Adversary`] policy of one rollout's CBV: the approach phase's
//! draws from the prior, then SaFeR's choice at every token boundary,
//! each token held for its period.

use std::sync::{Arc, Mutex};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::approach::{ApproachPhase, approach_draw};
use super::background_forecast::BackgroundForecast;
use super::choice::{Feasibility, Search, safer_choice};
use super::contact_witness::EscapeWitness;
use super::escape_room::FeasibilityScope;
use super::reaction::EgoSight;
use crate::models::ModelError;
use crate::models::feasibility_oracle::FeasibilityOracle;
use crate::motion::tokens::{TOKEN_PERIOD_STEPS, Token, TokenGrid};
use crate::policies::prior_sampling::{PriorTraffic, draw_seed};
use crate::policies::{AgentAction, AgentPolicy, WorldView};
use crate::scenario::{AgentState, TrackIndex};

/// The adversary of one rollout's CBV.
pub struct Adversary {
    shared: Arc<Mutex<PriorTraffic>>,
    ego: TrackIndex,
    search: Search,
    feasibility: Option<Arc<dyn FeasibilityOracle>>,
    witness: Option<Arc<dyn EscapeWitness>>,
    approach: ApproachPhase,
    sight: EgoSight,
    current: Option<Token>,
    error: Option<Arc<ModelError>>,
}

impl std::fmt::Debug for Adversary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Adversary")
            .field("ego", &self.ego)
            .field("search", &self.search)
            .field("feasibility", &self.feasibility.is_some())
            .field("witness", &self.witness.is_some())
            .field("approach", &self.approach)
            .field("sight", &self.sight)
            .finish()
    }
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
        Self {
            shared,
            ego,
            search,
            feasibility,
            witness: None,
            approach: ApproachPhase::default(),
            sight: EgoSight::default(),
            current: None,
            error: None,
        }
    }

    /// The same adversary asking `witness` before it takes a candidate near
    /// the ego, when its search's feasibility scope is
    /// [`FeasibilityScope::Witnessed`].
    pub fn with_escape_witness(self, witness: Arc<dyn EscapeWitness>) -> Self {
        Self { witness: Some(witness), ..self }
    }

    /// The same adversary with `approach` as its approach phase (the
    /// default is [`ApproachPhase::Seeded`]).
    pub fn with_approach(self, approach: ApproachPhase) -> Self {
        Self { approach, ..self }
    }

    /// The same adversary seeing the ego as `sight` says (the default is
    /// [`EgoSight::Current`]).
    pub fn with_ego_sight(self, sight: EgoSight) -> Self {
        Self { sight, ..self }
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
        // The rollout so far, only where the witness will search it.
        let witnessed = self.search.feasibility == FeasibilityScope::Witnessed && self.witness.is_some();
        let history = if witnessed { shared.frames().to_vec() } else { Vec::new() };
        let ego_seen = (self.sight != EgoSight::Current).then(|| self.sight.ego_seen(shared.frames(), self.ego));
        drop(shared);
        // The whole choice is made on the ego as the adversary sees it.
        let seen_states;
        let seen_world;
        let world = match ego_seen.flatten() {
            Some(seen) => {
                seen_states = with_state(world.states, self.ego, seen);
                seen_world = WorldView { states: &seen_states, ..*world };
                &seen_world
            }
            None => world,
        };
        let forecast = BackgroundForecast { recording: Some(&scenario), not_replayed: &prior_driven };
        let mut feasibility_s = 0.0;
        let constraint =
            Feasibility { oracle: self.feasibility.as_deref(), witness: self.witness.as_deref(), history: &history };
        let chosen =
            safer_choice(world, (cbv, self.ego), &logits, self.search, &forecast, constraint, &mut feasibility_s);
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
        Some(approach_draw(world, (cbv, self.ego), &logits, sampling, &forecast, &self.search, &mut rng))
    }
}

/// `states` with `agent`'s slot holding `state`.
fn with_state(states: &[Option<AgentState>], agent: TrackIndex, state: AgentState) -> Vec<Option<AgentState>> {
    let mut out = states.to_vec();
    if let Some(slot) = out.get_mut(agent.0) {
        *slot = Some(state);
    }
    out
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
            let chosen = if token_index < self.approach.tokens(seed, agent) {
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
