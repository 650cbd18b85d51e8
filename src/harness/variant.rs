//! One variant, end to end: the dual-stage pipeline, the acceptance check
//! and a stable summary for snapshots.

use std::sync::Arc;

use super::acceptance::{self, AcceptanceFailure};
use super::{HarnessError, Suite, SuiteScenario};
use crate::eval::min_time_to_collision;
use crate::planners::external::{ExternalPlanner, ExternalPlannerConfig};
use crate::planners::{BuiltinPlanner, IdmPlanner, Planner};
use crate::policies::LogReplay;
use crate::policies::prior_sampling::TokenSampling;
use super::methods::{self, BackgroundDriver, MapEncodings, MethodSettings, ModelSet};
use crate::scenario::{Scenario, Track, TrackIndex};
use crate::sim::{Rollout, SimConfig, Simulation};
use crate::spec::planner::PlannerAdapter;

/// Everything a variant produced.
#[derive(Debug, Clone)]
pub struct VariantOutcome {
    /// `suite::scenario::seed-k`.
    pub name: String,
    /// The variant's seed.
    pub seed: u64,
    /// The base scenario.
    pub scenario: Arc<Scenario>,
    /// Stage 1: ego on log replay, CBV by the method.
    pub stage1: Rollout,
    /// Stage 2: the planner under test, CBV replaying its stage-1 trajectory.
    pub stage2: Rollout,
    /// Minimum time to collision in stage 2, s.
    pub min_ttc_s: Option<f64>,
    /// Failed acceptance criteria (empty: the variant passes).
    pub failures: Vec<AcceptanceFailure>,
}

impl VariantOutcome {
    /// Whether the CBV hit the ego in stage 1 (counts toward CR).
    pub fn stage1_cbv_hit_ego(&self) -> bool {
        self.stage1.summary().ego_collision.is_some_and(|c| c.with_cbv)
    }

    /// Whether the planner under test survived stage 2 without a collision (counts toward SR).
    pub fn solved(&self) -> bool {
        self.stage2.ego_collision().is_none()
    }

    /// The stable, rounded summary that snapshots record.
    pub fn summary(&self) -> VariantSummary {
        let s1 = self.stage1.summary();
        let s2 = self.stage2.summary();
        let round = |x: f64| (x * 100.0).round() / 100.0;
        VariantSummary {
            variant: self.name.clone(),
            seed: self.seed,
            planner: s2.planner.clone(),
            ego: s2.ego.0.clone(),
            cbv: s2.cbv.as_ref().map(|c| c.0.clone()),
            stage1_cbv_hit_ego: self.stage1_cbv_hit_ego(),
            stage1_min_gap_m: s1.min_distance_to_ego_m.map(round),
            stage2_collision: s2.ego_collision.as_ref().map(|c| format!("{} at {:.1} s", c.other, c.time_s)),
            stage2_off_road_s: s2.ego_off_road_s.map(|t| (t * 10.0).round() / 10.0),
            stage2_min_gap_m: s2.min_distance_to_ego_m.map(round),
            stage2_min_ttc_s: self.min_ttc_s.map(|t| (t * 10.0).round() / 10.0),
            stage2_termination: serde_json::to_value(&s2.termination)
                .ok()
                .and_then(|v| v.get("kind").and_then(|k| k.as_str()).map(String::from))
                .unwrap_or_default(),
            passed: self.failures.is_empty(),
            failures: self.failures.iter().map(|f| format!("{}: {}", f.criterion, f.what)).collect(),
        }
    }
}

/// What snapshots record of a variant: stable fields, rounded.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct VariantSummary {
    /// Test name.
    pub variant: String,
    /// Seed.
    pub seed: u64,
    /// Planner under test.
    pub planner: String,
    /// Ego id.
    pub ego: String,
    /// CBV id.
    pub cbv: Option<String>,
    /// Stage 1: the CBV hit the ego.
    pub stage1_cbv_hit_ego: bool,
    /// Stage 1: closest gap to the ego, m (2 decimals).
    pub stage1_min_gap_m: Option<f64>,
    /// Stage 2: the ego's first collision.
    pub stage2_collision: Option<String>,
    /// Stage 2: when the ego left the road, s.
    pub stage2_off_road_s: Option<f64>,
    /// Stage 2: closest gap, m (2 decimals).
    pub stage2_min_gap_m: Option<f64>,
    /// Stage 2: minimum TTC, s (1 decimal).
    pub stage2_min_ttc_s: Option<f64>,
    /// Stage 2: how the rollout ended.
    pub stage2_termination: String,
    /// Whether every criterion held.
    pub passed: bool,
    /// The failed criteria.
    pub failures: Vec<String>,
}

/// Map encodings shared by every variant of the process.
static MAP_ENCODINGS: std::sync::LazyLock<MapEncodings> = std::sync::LazyLock::new(MapEncodings::default);

/// FNV-1a, 64 bit: a stable hash for seeds (std's hasher is not stable across releases).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ *b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

/// The seed of variant `index` of `scenario` in a suite seeded `base`: a pure
/// function of the variant's identity.
pub fn variant_seed(base: u64, scenario: &str, index: u32) -> u64 {
    fnv1a(format!("{base}/{scenario}/{index}").as_bytes())
}

/// A fresh planner for the ego of `scenario`.
pub fn make_planner(
    adapter: &PlannerAdapter,
    scenario: &Scenario,
    ego: TrackIndex,
) -> Result<Box<dyn Planner>, HarnessError> {
    match adapter {
        PlannerAdapter::Builtin { planner: BuiltinPlanner::Idm, idm, .. } => Ok(Box::new(IdmPlanner::new(*idm))),
        PlannerAdapter::Builtin { planner, .. } => Ok(planner.instantiate(scenario, ego)),
        PlannerAdapter::External { name, spec, working_dir } => {
            let mut config = ExternalPlannerConfig::new(name.clone(), spec.command.clone());
            config.args = spec.args.clone();
            config.working_dir = Some(working_dir.clone());
            config.step_timeout_ms = spec.step_timeout_ms;
            config.startup_timeout_ms = spec.startup_timeout_ms;
            let body = scenario.track(ego).body();
            ExternalPlanner::start(config, body.length_m, body.width_m)
                .map(|p| Box::new(p) as Box<dyn Planner>)
                .map_err(|e| HarnessError::PlannerStart { planner: name.clone(), reason: e.to_string() })
        }
    }
}

/// The CBV's stage-1 trajectory as a track (`None` before the start step).
pub(crate) fn track_from_rollout(scenario: &Scenario, rollout: &Rollout, agent: TrackIndex) -> Track {
    let mut t = scenario.track(agent).clone();
    t.states = (0..scenario.num_steps())
        .map(|k| k.checked_sub(rollout.start_step).and_then(|i| rollout.states.get(i)).and_then(|row| row[agent.0]))
        .collect();
    t
}

/// Runs variant `index` of `scenario` in `suite`.
pub fn run_variant(suite: &Suite, scenario: &SuiteScenario, index: u32) -> Result<VariantOutcome, HarnessError> {
    let spec = &suite.spec.value;
    let base = scenario.load()?;
    let ego = base.ego.ok_or_else(|| crate::sim::SimError::NoEgo(base.id.clone()))?;
    let cbv = base.cbv.ok_or_else(|| HarnessError::NoCbv(base.id.clone()))?;
    let seed = variant_seed(spec.seed, &scenario.name, index);
    let config = SimConfig { background: spec.adversary.background, ..SimConfig::default() };

    // Stage 1: the ego replays its log; the CBV is driven by the method.
    let mut stage1 = Simulation::new(&base, config.clone())?;
    let settings = MethodSettings {
        method: spec.adversary.method,
        trust_region: spec.adversary.trust_region,
        background: BackgroundDriver::Configured,
        sampling: TokenSampling::default(),
    };
    let models = ModelSet::shipped();
    let start = config.start_step.unwrap_or(base.current_step);
    let installed = methods::install(&mut stage1, &base, cbv, start, settings, &models, &MAP_ENCODINGS, seed)?;
    let mut replay_ego = BuiltinPlanner::LogReplay.instantiate(&base, ego);
    let stage1 = stage1.run(replay_ego.as_mut());
    if let Some(reason) = installed.error() {
        return Err(HarnessError::Model { method: spec.adversary.method, reason });
    }

    // Stage 2: the planner under test; the CBV replays what it did in stage 1.
    let mut stage2 = Simulation::new(&base, config)?;
    stage2.set_policy(cbv, Box::new(LogReplay::new(track_from_rollout(&base, &stage1, cbv))));
    let mut planner = make_planner(&suite.planner, &base, ego)?;
    let stage2 = stage2.run(planner.as_mut());
    drop(planner);

    let min_ttc_s = min_time_to_collision(&stage2);
    let failures = acceptance::check(&spec.acceptance.variant, &stage2, min_ttc_s);
    Ok(VariantOutcome {
        name: suite.variant_name(scenario, index),
        seed,
        scenario: base,
        stage1,
        stage2,
        min_ttc_s,
        failures,
    })
}
