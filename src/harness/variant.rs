//! One suite variant, end to end: the dual-stage pipeline
//! ([`super::pipeline`]) on the suite's scenario, planner and adversary
//! settings, the acceptance check, and a stable summary for snapshots.

use std::sync::Arc;

use super::acceptance::{self, AcceptanceFailure};
use super::methods::{BackgroundDriver, MapEncodings, MethodSettings, ModelSet};
use super::metrics::VariantTally;
use super::pipeline::{self, PlannerLatency, Stage2Verdict, VariantSetup};
use super::shrink::{FailingVariant, ShrinkStop, shrink};
use super::stable_hash::fnv1a;
use super::{HarnessError, Suite, SuiteScenario};
use crate::eval::ConflictReach;
use crate::eval::escape::{EscapeBudget, EscapeSearch};
use crate::policies::prior_sampling::TokenSampling;
use crate::scenario::Scenario;
use crate::sim::{Rollout, SimConfig};

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
    /// Stage 2: the planner under test, the CBV closed loop or replaying
    /// its stage-1 trajectory (the suite's `adversary.stage2_cbv`).
    pub stage2: Rollout,
    /// Stage 2's verdict (solved, collided, aborted).
    pub verdict: Stage2Verdict,
    /// Minimum time to collision in stage 2, s.
    pub min_ttc_s: Option<f64>,
    /// How close the CBV came to the planner's ego in stage 2.
    pub reach: ConflictReach,
    /// The closed-loop witness of an ego collision in stage 2.
    pub escape: Option<EscapeSearch>,
    /// What the variant contributes to the suite metrics.
    pub tally: VariantTally,
    /// Failed acceptance criteria (empty: the variant passes).
    pub failures: Vec<AcceptanceFailure>,
    /// How long the planner took per observation in stage 2 (not in the
    /// snapshot summary: wall-clock times are not stable).
    pub planner_latency: Option<PlannerLatency>,
    /// What an external planner wrote to stderr in stage 2.
    pub planner_stderr: Option<String>,
    /// The failing variant shrunk (see [`super::shrink`]): the smallest
    /// deviation from the log that fails the planner the same way.
    pub shrunk: Option<super::shrink::Shrunk>,
    /// Why a failing variant was not shrunk, when shrinking was on.
    pub not_shrunk: Option<super::shrink::NotShrunk>,
}

impl VariantOutcome {
    /// Whether the CBV hit the ego in stage 1 (counts toward CR).
    pub fn stage1_cbv_hit_ego(&self) -> bool {
        self.tally.critical
    }

    /// Whether the planner under test solved stage 2 (counts toward SR): it
    /// ran to the end without an ego collision. A planner that crashed,
    /// hung or answered garbage has not.
    pub fn solved(&self) -> bool {
        self.verdict.solved()
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
            stage2_min_gap_to_cbv_m: self.reach.min_gap_to_cbv_m.map(round),
            conflict_reached: self.reach.reached,
            stage1_conflict: self.tally.stage1_conflict,
            conflict: self.tally.conflict,
            stage2_escape: self.escape.as_ref().map(CollisionEscape::of),
            stage2_min_ttc_s: self.min_ttc_s.map(|t| (t * 10.0).round() / 10.0),
            stage2_termination: serde_json::to_value(&s2.termination)
                .ok()
                .and_then(|v| v.get("kind").and_then(|k| k.as_str()).map(String::from))
                .unwrap_or_default(),
            passed: self.failures.is_empty(),
            failures: self.failures.iter().map(|f| format!("{}: {}", f.criterion, f.what)).collect(),
            shrunk: self.shrunk.as_ref().map(|s| ShrunkSummary {
                adversarial_tokens: [s.before.adversarial_tokens, s.after.adversarial_tokens],
                max_distance_from_log_m: [round(s.before.max_distance_m), round(s.after.max_distance_m)],
                tokens_changed: s.tokens_changed,
                candidates: s.candidates,
                stopped: s.stopped,
                failure: s.failures.first().map(|f| format!("{}: {}", f.criterion, f.what)).unwrap_or_default(),
            }),
            not_shrunk: self.not_shrunk.as_ref().map(ToString::to_string),
        }
    }
}

/// What a failing variant's shrink found, as reports and snapshots carry it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ShrunkSummary {
    /// Adversarial tokens (periods whose token is not the log's), before
    /// and after.
    pub adversarial_tokens: [usize; 2],
    /// The CBV's largest distance from its recorded path, before and after,
    /// m (2 decimals).
    pub max_distance_from_log_m: [f64; 2],
    /// Periods given back to the log.
    pub tokens_changed: usize,
    /// Candidate rollouts played.
    pub candidates: usize,
    /// Why the search ended (`time_limit`: another machine may shrink
    /// further).
    pub stopped: ShrinkStop,
    /// The shrunk variant's first failure (the same criterion as the
    /// variant's).
    pub failure: String,
}

impl ShrunkSummary {
    /// "9 → 3 adversarial tokens, 4.12 → 1.20 m from the logged CBV path
    /// (12 candidate rollouts, the whole budget)", saying when the search
    /// stopped at its time limit.
    pub fn describe(&self) -> String {
        let stopped = match self.stopped {
            ShrinkStop::Searched => String::new(),
            ShrinkStop::RolloutBudget => ", the whole budget".to_string(),
            ShrinkStop::TimeLimit => format!(
                "; stopped at its time limit after {}: another machine may shrink further",
                plural(self.candidates, "candidate")
            ),
            ShrinkStop::CandidateFailed => "; stopped where a candidate could not be played".to_string(),
        };
        format!(
            "{} → {} adversarial tokens, {:.2} → {:.2} m from the logged CBV path ({}{stopped})",
            self.adversarial_tokens[0],
            self.adversarial_tokens[1],
            self.max_distance_from_log_m[0],
            self.max_distance_from_log_m[1],
            plural(self.candidates, "candidate rollout"),
        )
    }
}

/// `1 candidate`, `2 candidates`.
fn plural(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
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
    /// Stage 2: closest gap to any agent, m (2 decimals).
    pub stage2_min_gap_m: Option<f64>,
    /// Stage 2: closest gap to the CBV, m (2 decimals).
    pub stage2_min_gap_to_cbv_m: Option<f64>,
    /// Stage 2: the CBV came within 1 m of the planner's ego.
    pub conflict_reached: bool,
    /// Stage 1: the kind of conflict the CBV made with the recorded ego
    /// (`None`: it never came within 1 m).
    pub stage1_conflict: Option<crate::eval::ConflictKind>,
    /// Stage 2: the kind of conflict the CBV made with the planner's ego.
    pub conflict: Option<crate::eval::ConflictKind>,
    /// Stage 2: for an ego collision, the closed-loop witness's verdict.
    pub stage2_escape: Option<CollisionEscape>,
    /// Stage 2: minimum TTC, s (1 decimal).
    pub stage2_min_ttc_s: Option<f64>,
    /// Stage 2: how the rollout ended.
    pub stage2_termination: String,
    /// Whether every criterion held.
    pub passed: bool,
    /// The failed criteria.
    pub failures: Vec<String>,
    /// A failing variant shrunk: the smallest deviation from the log that
    /// fails the same way (`None`: passed, not shrunk, or nothing kept).
    pub shrunk: Option<ShrunkSummary>,
    /// Why a failing variant was not shrunk, when shrinking was on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub not_shrunk: Option<String>,
}

pub use crate::eval::escape::CollisionEscape;

/// Map encodings shared by every variant of the process.
static MAP_ENCODINGS: std::sync::LazyLock<MapEncodings> = std::sync::LazyLock::new(MapEncodings::default);

/// The seed of variant `index` of `scenario` in a suite seeded `base`: a pure
/// function of the variant's identity.
pub fn variant_seed(base: u64, scenario: &str, index: u32) -> u64 {
    fnv1a(format!("{base}/{scenario}/{index}").as_bytes())
}

/// What a variant of a suite is made from: the imported scene, its seed,
/// its simulation settings and its name (a [`VariantSetup`] borrows them).
pub(crate) struct VariantInputs {
    pub(crate) base: Arc<Scenario>,
    pub(crate) seed: u64,
    pub(crate) sim: SimConfig,
    pub(crate) models: Arc<ModelSet>,
    pub(crate) name: String,
}

impl VariantInputs {
    /// The inputs of variant `index` of `scenario` in `suite`.
    pub(crate) fn of(suite: &Suite, scenario: &SuiteScenario, index: u32) -> Result<Self, HarnessError> {
        let spec = &suite.spec.value;
        Ok(Self {
            base: scenario.load()?,
            seed: variant_seed(spec.seed, &scenario.name, index),
            sim: SimConfig { background: spec.adversary.background, ..SimConfig::default() },
            models: ModelSet::shipped(),
            name: suite.variant_name(scenario, index),
        })
    }

    /// The variant's setup under `suite`'s adversary, planner and criteria.
    pub(crate) fn setup<'a>(&'a self, suite: &'a Suite) -> VariantSetup<'a> {
        let spec = &suite.spec.value;
        VariantSetup {
            scenario: &self.base,
            settings: MethodSettings {
                method: spec.adversary.method,
                trust_region: spec.adversary.trust_region,
                background: BackgroundDriver::Configured,
                sampling: TokenSampling::default(),
                approach: spec.adversary.approach_phase,
                feasibility: spec.adversary.feasibility,
                ego_contact: spec.adversary.ego_contact,
                wrong_way: spec.adversary.wrong_way,
                turning: spec.adversary.turning_limit(),
                turning_cost: spec.adversary.turning_cost(),
            },
            seed: self.seed,
            sim: &self.sim,
            stage2_cbv: spec.adversary.stage2_cbv,
            planner: &suite.planner,
            models: &self.models,
            maps: &MAP_ENCODINGS,
            variant: Some(&self.name),
            escape: Some(EscapeBudget::default()),
            ego_limits: Some(spec.acceptance.variant.vehicle_limits),
            fault: None,
        }
    }
}

/// Runs variant `index` of `scenario` in `suite`.
pub fn run_variant(suite: &Suite, scenario: &SuiteScenario, index: u32) -> Result<VariantOutcome, HarnessError> {
    let spec = &suite.spec.value;
    let inputs = VariantInputs::of(suite, scenario, index)?;
    let (base, seed) = (&inputs.base, inputs.seed);
    let name = inputs.name.clone();
    let setup = inputs.setup(suite);
    // A collision the ego was not at fault for, under
    // `no_at_fault_collision`, is nobody's failure: its witness would count
    // it against the generator where no escape was found.
    let criteria = &spec.acceptance.variant;
    let stages = pipeline::run_witnessing(setup, |stage2| acceptance::asks_witness(criteria, stage2))?;
    let escape = stages.escape.as_ref().map(CollisionEscape::of);
    let failures = acceptance::check(criteria, &stages.stage2, base, stages.min_ttc_s, escape);
    // The verdict is the variant's failures alone: the shrink only
    // explains them, and what it cannot shrink it says why.
    let (shrunk, not_shrunk) = if failures.is_empty() || !suite.shrink.enabled() {
        (None, None)
    } else {
        let failing = FailingVariant {
            setup,
            stage1: &stages.stage1,
            stage2: &stages.stage2,
            failures: &failures,
            criteria: &spec.acceptance.variant,
            escape,
        };
        match shrink(&failing, suite.shrink) {
            Ok(s) => (Some(s), None),
            Err(why) => (None, Some(why)),
        }
    };
    Ok(VariantOutcome {
        name,
        seed,
        tally: VariantTally::of(base, &stages),
        scenario: base.clone(),
        verdict: stages.verdict,
        min_ttc_s: stages.min_ttc_s,
        reach: stages.reach,
        escape: stages.escape,
        stage1: stages.stage1,
        stage2: stages.stage2,
        failures,
        planner_latency: stages.planner_latency,
        planner_stderr: stages.planner_stderr,
        shrunk,
        not_shrunk,
    })
}
