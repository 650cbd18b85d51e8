//! Adversary methods by name: what drives the CBV (and, optionally, the
//! background) in a variant — the recorded log, the realism prior, the full
//! SaFeR adversary or one of its ablations. The learned models are loaded
//! once per process ([`ModelSet::shipped`]) and shared by every variant; a
//! scenario's map is encoded once per prior ([`MapEncodings`]).

use std::collections::HashMap;

use std::sync::{Arc, Mutex, OnceLock};

use super::HarnessError;
use crate::eval::witness::{FIRST_WIDENING, FixedTraffic, RoadKeeping, RoadRule, WitnessBudget, search_witness};
use crate::map::RoadMap;
use crate::models::prior::{PriorVariant, RealismPrior};
use crate::models::{ModelError, ModelSource};
use crate::policies::LogReplay;
use crate::policies::adversary::{
    Adversary, ApproachPhase, CbvTurningCost, CbvTurningLimit, EgoContactRule, EgoSight, EscapeWitness,
    FeasibilityOracle, FeasibilityScope, LOOKAHEAD_TOKENS, Objective, Search, TrustRegion, WrongWayRule,
};
use crate::policies::prior_sampling::{PriorAgent, PriorTraffic, ScenarioMapEncoding, TokenSampling, TrafficTimings};
use crate::scenario::{AgentBody, AgentState, Scenario, TrackIndex};
use crate::sim::Simulation;
use crate::spec::suite::AdversaryMethod;

/// The learned models a method may need.
pub struct ModelSet {
    /// Where they were loaded from.
    pub source: ModelSource,
    /// The prior with differential attention.
    pub prior: Result<Arc<RealismPrior>, Arc<ModelError>>,
    /// The prior with plain attention (`no-mda`).
    pub prior_plain: Result<Arc<RealismPrior>, Arc<ModelError>>,
    /// The feasibility value V_h.
    pub feasibility: Result<Arc<dyn FeasibilityOracle>, Arc<ModelError>>,
}

impl std::fmt::Debug for ModelSet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ModelSet").field("source", &self.source).finish()
    }
}

static SHIPPED: OnceLock<Arc<ModelSet>> = OnceLock::new();

impl ModelSet {
    /// Loads what is in `source`; a model that fails to load keeps its error,
    /// reported when a method needs it.
    pub fn load(source: ModelSource) -> Self {
        let prior = |v| RealismPrior::load(&source, v).map(Arc::new).map_err(Arc::new);
        let feasibility = crate::models::feasibility_oracle(&source).map_err(Arc::new);
        Self { prior: prior(PriorVariant::Differential), prior_plain: prior(PriorVariant::Plain), feasibility, source }
    }

    /// The shipped models (embedded, or the folder in `SAFER_MODELS`), loaded once per process.
    pub fn shipped() -> Arc<ModelSet> {
        SHIPPED.get_or_init(|| Arc::new(Self::load(ModelSource::shipped()))).clone()
    }

    /// The prior a method drives the CBV with.
    pub fn prior_for(&self, method: AdversaryMethod) -> Result<Arc<RealismPrior>, HarnessError> {
        let which = if method == AdversaryMethod::NoMda { &self.prior_plain } else { &self.prior };
        which.clone().map_err(|source| HarnessError::Model { method, source })
    }
}

/// Map encodings per (scenario, prior variant), computed once.
#[derive(Debug, Default)]
pub struct MapEncodings {
    cache: Mutex<HashMap<(String, PriorVariant), ScenarioMapEncoding>>,
}

impl MapEncodings {
    /// The encoding of `scenario`'s map for `prior`.
    pub fn get(&self, prior: &RealismPrior, scenario: &Scenario) -> Result<ScenarioMapEncoding, HarnessError> {
        let key = (scenario.id.clone(), prior.variant());
        if let Some(e) = self.cache.lock().unwrap_or_else(|p| p.into_inner()).get(&key) {
            return Ok(e.clone());
        }
        let e = ScenarioMapEncoding::new(prior, scenario)
            .map_err(|e| HarnessError::Model { method: AdversaryMethod::Prior, source: Arc::new(e) })?;
        self.cache.lock().unwrap_or_else(|p| p.into_inner()).insert(key, e.clone());
        Ok(e)
    }
}

/// Who drives the background agents in stage 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BackgroundDriver {
    /// As the simulation configuration says (log replay by default).
    #[default]
    Configured,
    /// The realism prior drives every background agent.
    Prior,
    /// Reactive log replay in both stages: each agent keeps to its recorded
    /// path, braking along it for road users in its way.
    ReactiveLogReplay,
}

impl BackgroundDriver {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Configured, Self::Prior, Self::ReactiveLogReplay];
}

/// What a method installed, to be asked for errors after the run.
#[derive(Debug, Default)]
pub struct InstalledMethod {
    traffic: Option<Arc<Mutex<PriorTraffic>>>,
}

impl InstalledMethod {
    /// Where the rollout's learned-model time went (zero without a model).
    pub fn timings(&self) -> TrafficTimings {
        self.traffic.as_ref().map(|t| t.lock().unwrap_or_else(|p| p.into_inner()).timings()).unwrap_or_default()
    }

    /// The first model error met during the rollout, if any.
    pub fn error(&self) -> Option<Arc<ModelError>> {
        self.traffic.as_ref().and_then(|t| t.lock().unwrap_or_else(|p| p.into_inner()).error().cloned())
    }
}

/// Everything that decides how a method drives the CBV.
#[derive(Debug, Clone, Copy)]
pub struct MethodSettings {
    /// The method.
    pub method: AdversaryMethod,
    /// Trust-region size n.
    pub trust_region: usize,
    /// Who drives the background.
    pub background: BackgroundDriver,
    /// How the prior's tokens are drawn (for `prior` and a prior-driven background).
    pub sampling: TokenSampling,
    /// Whether the prior drives the CBV for a while before the adversary
    /// engages (the SaFeR methods).
    pub approach: ApproachPhase,
    /// What the feasibility constraint takes into account (the methods with V_h).
    pub feasibility: FeasibilityScope,
    /// Which contacts with the ego the SaFeR methods' CBV may make.
    pub ego_contact: EgoContactRule,
    /// Whether the SaFeR methods' CBV may drive against a lane's traffic.
    pub wrong_way: WrongWayRule,
    /// How hard the SaFeR methods' CBV may turn.
    pub turning: CbvTurningLimit,
    /// What a turn of the SaFeR methods' CBV adds to its loss (none: the paper's).
    pub turning_cost: CbvTurningCost,
}

/// The feasibility witness the `witnessed` scope asks before the CBV makes
/// a contact: the fixed-traffic search `safer evaluate` checks stage-1
/// collisions with, its ego's centre kept on the road, its beam widened
/// once (×[`FIRST_WIDENING`]) where the narrow one finds nothing. Where
/// it finds nothing the wider searches of `safer evaluate` might still
/// find an escape: the adversary then turns away a contact that had one,
/// never the other way round.
#[derive(Debug, Clone, Copy, Default)]
pub struct ContactEscapeSearch;

impl EscapeWitness for ContactEscapeSearch {
    fn ego_escapes(&self, map: &RoadMap, states: &[Vec<Option<AgentState>>], bodies: &[AgentBody], ego: usize) -> bool {
        // An ego absent at the start has nothing to escape.
        let Some(start) = states.first().and_then(|row| row.get(ego).copied().flatten()) else { return true };
        let traffic = FixedTraffic { states, bodies, ego, road: Some(RoadRule { map, keeping: RoadKeeping::Centre }) };
        let budget = WitnessBudget::widening_up_to(FIRST_WIDENING);
        search_witness(&start, bodies[ego], &traffic, states.len().saturating_sub(1), budget).is_found()
    }
}

/// The trust region `method` searches, for a region of `n`.
pub fn trust_region_of(method: AdversaryMethod, n: usize) -> TrustRegion {
    match method {
        AdversaryMethod::NoTrustRegion => TrustRegion::WholeVocabulary,
        AdversaryMethod::SaferDistinct
        | AdversaryMethod::SaferInPath
        | AdversaryMethod::SaferCutIn
        | AdversaryMethod::SaferInPathLookahead => TrustRegion::DistinctBehaviours(n),
        _ => TrustRegion::TopN(n),
    }
}

/// Sets up what the prior sees when it predicts the CBV for `method`:
/// for `safer-inattentive`, the CBV's queries leave the ego out.
pub(super) fn set_cbv_view(method: AdversaryMethod, traffic: &mut PriorTraffic, cbv: TrackIndex, ego: TrackIndex) {
    if !method.prior_sees_ego() {
        traffic.hide_from(cbv.0, ego.0);
    }
}

/// Installs the method's CBV policy (and a prior-driven background, if
/// asked) in a stage-1 simulation starting at `start`.
#[allow(clippy::too_many_arguments)]
pub fn install(
    sim: &mut Simulation<'_>,
    scenario: &Arc<Scenario>,
    cbv: TrackIndex,
    start: usize,
    settings: MethodSettings,
    models: &ModelSet,
    maps: &MapEncodings,
    seed: u64,
) -> Result<InstalledMethod, HarnessError> {
    install_seeing_ego(sim, scenario, cbv, start, settings, (models, maps), seed, EgoSight::Current)
}

/// [`install`], the adversary seeing the ego as `sight` says (the SaFeR
/// methods; the others do not aim at the ego).
#[allow(clippy::too_many_arguments)]
pub fn install_seeing_ego(
    sim: &mut Simulation<'_>,
    scenario: &Arc<Scenario>,
    cbv: TrackIndex,
    start: usize,
    settings: MethodSettings,
    (models, maps): (&ModelSet, &MapEncodings),
    seed: u64,
    sight: EgoSight,
) -> Result<InstalledMethod, HarnessError> {
    let ego = scenario.ego.ok_or_else(|| crate::sim::SimError::NoEgo(scenario.id.clone()))?;
    let needs_prior = settings.method != AdversaryMethod::Log || settings.background == BackgroundDriver::Prior;
    if !needs_prior {
        sim.set_policy(cbv, Box::new(LogReplay::new(scenario.track(cbv).clone())));
        return Ok(InstalledMethod::default());
    }
    let prior_method = if settings.method == AdversaryMethod::Log { AdversaryMethod::Prior } else { settings.method };
    let prior = models.prior_for(prior_method)?;
    let map = maps.get(&prior, scenario)?;
    let mut members: Vec<usize> = Vec::new();
    if settings.method != AdversaryMethod::Log {
        members.push(cbv.0);
    }
    if settings.background == BackgroundDriver::Prior {
        members.extend(
            (0..scenario.tracks.len())
                .filter(|&i| i != ego.0 && i != cbv.0 && scenario.tracks[i].state(start).is_some()),
        );
    }
    members.sort_unstable();
    let traffic = PriorTraffic::new(prior, scenario.clone(), map, start, members.clone(), settings.sampling, seed);
    set_cbv_view(settings.method, &mut traffic.lock().unwrap_or_else(|p| p.into_inner()), cbv, ego);
    for &m in &members {
        if m != cbv.0 {
            sim.set_policy(TrackIndex(m), Box::new(PriorAgent::new(traffic.clone())));
        }
    }
    let feasibility =
        || models.feasibility.clone().map_err(|source| HarnessError::Model { method: settings.method, source });
    let search = Search {
        feasibility: settings.feasibility,
        ego_contact: settings.ego_contact,
        wrong_way: settings.wrong_way,
        turning: settings.turning,
        turning_cost: settings.turning_cost,
        ..Search::one_step(trust_region_of(settings.method, settings.trust_region))
    };
    let adversary = |search, feasibility| {
        let adversary = Adversary::new(traffic.clone(), ego, search, feasibility)
            .with_approach(settings.approach)
            .with_ego_sight(sight);
        Box::new(match settings.feasibility {
            FeasibilityScope::Witnessed => adversary.with_escape_witness(Arc::new(ContactEscapeSearch)),
            FeasibilityScope::Pair | FeasibilityScope::PairInTraffic => adversary,
        })
    };
    match settings.method {
        AdversaryMethod::Log => sim.set_policy(cbv, Box::new(LogReplay::new(scenario.track(cbv).clone()))),
        AdversaryMethod::Prior => sim.set_policy(cbv, Box::new(PriorAgent::new(traffic.clone()))),
        AdversaryMethod::Safer
        | AdversaryMethod::NoMda
        | AdversaryMethod::NoTrustRegion
        | AdversaryMethod::SaferDistinct
        | AdversaryMethod::SaferInattentive => sim.set_policy(cbv, adversary(search, Some(feasibility()?))),
        AdversaryMethod::SaferLookahead => {
            let search = Search { lookahead_tokens: LOOKAHEAD_TOKENS, ..search };
            sim.set_policy(cbv, adversary(search, Some(feasibility()?)))
        }
        AdversaryMethod::SaferInPath => {
            let search = Search { objective: Objective::InPath, ..search };
            sim.set_policy(cbv, adversary(search, Some(feasibility()?)))
        }
        AdversaryMethod::SaferCutIn => {
            let search = Search { objective: Objective::CutIn, ..search };
            sim.set_policy(cbv, adversary(search, Some(feasibility()?)))
        }
        AdversaryMethod::SaferInPathLookahead => {
            let search = Search { objective: Objective::InPath, lookahead_tokens: LOOKAHEAD_TOKENS, ..search };
            sim.set_policy(cbv, adversary(search, Some(feasibility()?)))
        }
        AdversaryMethod::NoLfr => sim.set_policy(cbv, adversary(search, None)),
    }
    Ok(InstalledMethod { traffic: Some(traffic) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::AgentKind;

    /// A stopped ego at the origin facing +x, a CBV 1 m behind its box at
    /// 3 m/s, and `others` standing, over 2 s: the witness's rows.
    fn rows(others: &[(f64, f64)]) -> (Vec<Vec<Option<AgentState>>>, Vec<AgentBody>) {
        let at = |x: f64, y: f64, v: f64| {
            Some(AgentState {
                position: crate::geometry::Point2::new(x, y),
                heading_rad: 0.0,
                velocity_mps: crate::geometry::Vector2::new(v, 0.0),
            })
        };
        let rows = (0..=20)
            .map(|k| {
                let mut row = vec![if k == 0 { at(0.0, 0.0, 0.0) } else { None }, at(-5.5 + 0.3 * k as f64, 0.0, 3.0)];
                row.extend(others.iter().map(|&(x, y)| at(x, y, 0.0)));
                row
            })
            .collect();
        (rows, vec![AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2 + others.len()])
    }

    #[test]
    fn the_contact_search_finds_the_open_road_escape_and_none_for_a_boxed_in_ego() {
        let map = RoadMap::default();
        let (open, bodies) = rows(&[]);
        assert!(ContactEscapeSearch.ego_escapes(&map, &open, &bodies, 0));
        // A car 1 m ahead of its box and cars in the lanes either side.
        let (boxed, bodies) = rows(&[(5.5, 0.0), (0.0, 3.5), (0.0, -3.5)]);
        assert!(!ContactEscapeSearch.ego_escapes(&map, &boxed, &bodies, 0));
    }
}
