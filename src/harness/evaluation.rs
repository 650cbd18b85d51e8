//! The dual-stage evaluation of adversary methods over many scenes and
//! seeds (the paper's Table II protocol). For each (scene, method, seed):
//! stage 1 — the ego replays its log while the method drives the CBV; a
//! CBV–ego collision counts toward the collision rate CR. Stage 2 — a
//! reactive planner drives the ego through the same variant with the CBV
//! replaying its stage-1 trajectory (or, optionally, driven by the method
//! again, closed loop; both modes side by side when asked); surviving
//! without an ego collision counts toward the solution rate SR. Each
//! stage-1 collision is checked for a feasibility witness, and each
//! stage-2 collision for a closed-loop one ([`crate::eval::escape`]);
//! stage 2 also says whether the conflict reached the planner's ego. VJ and AJ compare the CBV's stage-1 speed and
//! acceleration with the logged CBV's (see [`crate::eval::Histogram::speed`] and
//! [`crate::eval::Histogram::acceleration`] for the bins).
//!
//! Variants run in parallel with rayon; each is a pure function of its
//! (scene, method, seed), and results are sorted, so the table does not
//! depend on the thread count.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use rayon::prelude::*;

use super::HarnessError;
use super::acceptance;
use super::artefacts;
use super::methods::{BackgroundDriver, MapEncodings, MethodSettings, ModelSet};
use super::metrics::{CbvBackgroundContact, SuiteMetrics, VariantTally, cbv_background_collisions};
use super::mutation::{KillsInput, MethodKills, ReplayCatches, VariantMutation, evaluation_criteria, judge_mutant};
use super::pipeline::{self, PlannerLatency, Stage2Verdict, VariantSetup};
pub use super::pipeline::{Stage2Cbv, VariantProfile};
use super::variant::variant_seed;
use super::variant::{CollisionEscape, VariantOutcome};
use crate::eval::escape::EscapeBudget;
use crate::eval::sideways_speed::{SidewaysSpread, recorded_lane_changes_mps};
use crate::eval::spread::Spread;
use crate::eval::witness::Witness;
use crate::eval::{CbvStart, ConflictReach};
use crate::planners::FaultOperator;
use crate::policies::BackgroundPolicy;
use crate::policies::adversary::{
    ApproachPhase, CbvTurningCost, CbvTurningLimit, EgoContactRule, FeasibilityScope, WrongWayRule,
};
use crate::policies::prior_sampling::TokenSampling;
use crate::scenario::Scenario;
use crate::sim::{EgoCollisionKind, Rollout, SimConfig};
use crate::spec::planner::PlannerAdapter;
use crate::spec::suite::AdversaryMethod;

/// What to evaluate.
#[derive(Debug, Clone)]
pub struct EvaluationRequest {
    /// Methods, one table row each.
    pub methods: Vec<AdversaryMethod>,
    /// Seeds per (scene, method).
    pub seeds: u32,
    /// Base seed.
    pub base_seed: u64,
    /// Reactive planner of stage 2: a built-in or a planner spec.
    pub planner: PlannerAdapter,
    /// Trust-region size n.
    pub trust_region: usize,
    /// Whether the prior drives the CBV for a while before the adversary
    /// engages (seeded, the default) or not at all (the paper's protocol).
    pub approach: ApproachPhase,
    /// What the feasibility constraint of the methods with V_h takes into
    /// account (the pair alone: the paper's).
    pub feasibility: FeasibilityScope,
    /// Which contacts with the ego the SaFeR methods' CBV may make (any:
    /// the paper's).
    pub ego_contact: EgoContactRule,
    /// Whether the SaFeR methods' CBV may drive against a lane's traffic
    /// (allowed: the paper's).
    pub wrong_way: WrongWayRule,
    /// How hard the SaFeR methods' CBV may turn (the tyres' grip unless
    /// lower).
    pub turning: CbvTurningLimit,
    /// What a turn of the SaFeR methods' CBV adds to its loss (none: the
    /// paper's).
    pub turning_cost: CbvTurningCost,
    /// Who drives the background agents.
    pub background: BackgroundDriver,
    /// Stage-2 CBV modes, each a row per method (replay: the paper's
    /// protocol).
    pub stage2_cbv: Vec<Stage2Cbv>,
    /// The closed-loop witness's budget for stage-2 collisions (`None`:
    /// not searched).
    pub escape: Option<EscapeBudget>,
    /// Horizon of both stages from the scene's current step, s.
    pub horizon_s: f64,
    /// Where to write a failing variant's recording, picture and planner
    /// stderr (as `safer run` does), `<dir>/<method>/<scenario>/seed-k.*`;
    /// `None`: nowhere.
    pub artefacts: Option<PathBuf>,
    /// Which variants get artefacts where `artefacts` names a folder.
    pub artefacts_of: ArtefactVariants,
    /// Mutation testing: faults planted in the planner, each judged on
    /// every variant the planner passes
    /// ([`super::mutation::evaluation_criteria`]); empty: none.
    pub mutants: Vec<FaultOperator>,
}

/// Which variants of an evaluation get their recording and picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ArtefactVariants {
    /// The variants the planner did not solve (what a reviewer opens).
    #[default]
    Failing,
    /// Every variant, solved ones too (to see what the adversary or a
    /// prior-driven CBV did where nothing failed).
    All,
}

impl ArtefactVariants {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Failing, Self::All];
}

/// A digest of an evaluation's whole sorted scene list (before any
/// partition), so the reports of its parts can prove they split the same
/// scenes: the same on every machine.
pub fn scene_list_digest<S: AsRef<str>>(sorted_ids: &[S]) -> String {
    let joined: Vec<&str> = sorted_ids.iter().map(AsRef::as_ref).collect();
    format!("{:016x}", super::stable_hash::fnv1a(joined.join("\n").as_bytes()))
}

/// One of `count` parts of an evaluation, for running it on several
/// machines: scene `i` of the sorted scene list belongs to part
/// `i mod count + 1`, so the parts are disjoint, cover every scene, and
/// differ in size by one scene at most. Each variant is a pure function
/// of its (scene, method, seed), so the parts' records merged are the
/// records one run makes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Partition {
    /// Which part, from 1.
    pub index: usize,
    /// How many parts.
    pub count: usize,
}

impl Partition {
    /// The scenes of this part, from the whole sorted list.
    pub fn select<T>(&self, scenes: Vec<T>) -> Vec<T> {
        scenes.into_iter().enumerate().filter(|(i, _)| i % self.count + 1 == self.index).map(|(_, s)| s).collect()
    }
}

impl std::str::FromStr for Partition {
    type Err = String;

    /// `K/N`, 1 ≤ K ≤ N.
    fn from_str(text: &str) -> Result<Self, String> {
        let (k, n) = text.split_once('/').ok_or_else(|| format!("`{text}` is not K/N (e.g. 2/4)"))?;
        let number =
            |t: &str| t.trim().parse::<usize>().map_err(|_| format!("`{t}` in `{text}` is not a whole number"));
        let (index, count) = (number(k)?, number(n)?);
        if count == 0 || index == 0 || index > count {
            return Err(format!("`{text}`: the part must be from 1 to the number of parts, which must be at least 1"));
        }
        Ok(Partition { index, count })
    }
}

/// The planner's ego's first collision in stage 2: with whom, and whose
/// fault.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Stage2Contact {
    /// The other agent's id.
    pub other: String,
    /// Whether it was the CBV.
    pub with_cbv: bool,
    /// Whether the ego was at fault.
    pub at_fault: bool,
}

/// The outcome of one variant.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct VariantRecord {
    /// Scenario id.
    pub scenario: String,
    /// Method.
    pub method: AdversaryMethod,
    /// The CBV in stage 2.
    pub stage2_cbv: Stage2Cbv,
    /// Seed index.
    pub seed: u32,
    /// Stage 1: the CBV hit the ego.
    pub stage1_collision: bool,
    /// Stage 1: how the CBV and the recorded ego touched at their first
    /// contact, in nuPlan's categories seen from the ego (a front contact,
    /// the ego hit from behind, ...); `None` without one. Reports written
    /// before it was recorded read back as `None`.
    #[serde(default)]
    pub stage1_contact: Option<EgoCollisionKind>,
    /// Where the scene's CBV starts relative to its ego, at the step the
    /// variant starts from; `None` where either is missing there. Reports
    /// written before it was recorded read back as `None`.
    #[serde(default)]
    pub cbv_start: Option<CbvStart>,
    /// Stage 2: the ego collided with anything.
    pub stage2_collision: bool,
    /// Stage 2's verdict: solved, collided, or aborted (planner failure);
    /// `None` when the variant could not run.
    pub stage2: Option<Stage2Verdict>,
    /// Stage 2: the ego's first collision, with whom and whose fault.
    pub stage2_contact: Option<Stage2Contact>,
    /// For a stage-1 collision: whether a feasibility witness was found.
    pub witness: Option<bool>,
    /// Stage-1 closest gap between the recorded ego and any agent, m.
    pub stage1_min_gap_m: Option<f64>,
    /// Stage-1 closest gap between the recorded ego and the CBV, m (what
    /// the closest-approach table bands). Reports written before it was
    /// recorded read back as `None`.
    #[serde(default)]
    pub stage1_min_gap_to_cbv_m: Option<f64>,
    /// Stage-2 closest gap to any agent, m.
    pub stage2_min_gap_m: Option<f64>,
    /// Stage-2 closest gap between the planner's ego and the CBV, m.
    pub stage2_min_gap_to_cbv_m: Option<f64>,
    /// Stage 2: the CBV came within 1 m of the planner's ego.
    pub conflict_reached: bool,
    /// For a stage-2 collision: the closed-loop witness's verdict.
    pub stage2_escape: Option<CollisionEscape>,
    /// ... whether its pre-check (an escape from the CBV as it drove)
    /// found one.
    pub stage2_escape_precheck: Option<bool>,
    /// ... and the closed-loop rollouts it played.
    pub stage2_escape_rollouts: Option<usize>,
    /// Stage 1: the CBV collided with a background agent.
    pub cbv_hit_background: bool,
    /// ... and was at fault in at least one such collision.
    pub cbv_at_fault_with_background: bool,
    /// Those collisions: whom the CBV hit, when, and whether at fault.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cbv_background_contacts: Vec<CbvBackgroundContact>,
    /// Stage 1: time the CBV spent off the road, having started on it, s.
    pub cbv_off_road_s: f64,
    /// Wall time of the variant (both stages and the witness), s.
    pub time_s: f64,
    /// Where the time went, s.
    pub profile: VariantProfile,
    /// How long the stage-2 planner took per observation (wall clock).
    pub planner_latency: Option<PlannerLatency>,
    /// Why the variant could not be run, if it could not.
    pub error: Option<String>,
    /// The failing variant's recording, picture and planner stderr, where
    /// the evaluation was asked to write them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub artefacts: Vec<PathBuf>,
    /// What the variant contributes to CR, SR, VJ and AJ (in the report,
    /// so that partitions' reports merge into the same table).
    pub tally: VariantTally,
    /// The held sideways speed of every recorded vehicle of the scene
    /// that changed lanes over both stages' steps, m/s
    /// ([`recorded_lane_changes_mps`]): the same in each of the scene's
    /// variants, the reference for the CBV's lane changes. Reports written
    /// before it was recorded read back as none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub recorded_lane_changes_mps: Vec<f64>,
    /// The mutants' results, when the evaluation planted them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mutation: Option<VariantMutation>,
}

impl VariantRecord {
    /// The record of a variant that could not run, and why.
    pub(crate) fn failed(
        scenario: &str,
        method: AdversaryMethod,
        stage2_cbv: Stage2Cbv,
        seed: u32,
        error: String,
    ) -> Self {
        VariantRecord {
            scenario: scenario.into(),
            method,
            stage2_cbv,
            seed,
            stage1_collision: false,
            stage1_contact: None,
            cbv_start: None,
            stage2_collision: false,
            stage2: None,
            stage2_contact: None,
            witness: None,
            stage1_min_gap_m: None,
            stage1_min_gap_to_cbv_m: None,
            stage2_min_gap_m: None,
            stage2_min_gap_to_cbv_m: None,
            conflict_reached: false,
            stage2_escape: None,
            stage2_escape_precheck: None,
            stage2_escape_rollouts: None,
            cbv_hit_background: false,
            cbv_at_fault_with_background: false,
            cbv_background_contacts: Vec::new(),
            cbv_off_road_s: 0.0,
            time_s: 0.0,
            profile: VariantProfile::default(),
            planner_latency: None,
            error: Some(error),
            artefacts: Vec::new(),
            tally: VariantTally::default(),
            recorded_lane_changes_mps: Vec::new(),
            mutation: None,
        }
    }
}

/// One row of the table.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MethodRow {
    /// Method.
    pub method: AdversaryMethod,
    /// The CBV in stage 2.
    pub stage2_cbv: Stage2Cbv,
    /// Variants run.
    pub variants: usize,
    /// Variants that could not run.
    pub errors: usize,
    /// Collision rate (stage 1); `None` when no variant ran.
    pub cr: Option<f64>,
    /// Solution rate over all variants (stage 2); `None` when no variant ran.
    pub sr: Option<f64>,
    /// Solution rate over the stage-1 critical variants.
    pub sr_critical: Option<f64>,
    /// Share of stage-1 collisions with a feasibility witness.
    pub witness_rate: Option<f64>,
    /// Solution rate over the witnessed stage-1 collisions: how much of
    /// what is provably avoidable the stage-2 planner avoids.
    pub sr_witnessed: Option<f64>,
    /// Share of variants whose CBV hit a background agent in stage 1.
    pub cbv_background_collision_rate: Option<f64>,
    /// Share of variants where the CBV was at fault in such a collision.
    pub cbv_at_fault_background_collision_rate: Option<f64>,
    /// ... in one with a pedestrian or cyclist.
    #[serde(default)]
    pub cbv_at_fault_vulnerable_rate: Option<f64>,
    /// Share of variants whose CBV left the road in stage 1.
    pub cbv_off_road_rate: Option<f64>,
    /// Mean time the CBV spent off the road per variant, s.
    pub cbv_off_road_s: Option<f64>,
    /// Share of variants whose CBV drove against a lane's traffic in
    /// stage 1 (older reports lack it: read as unknown).
    #[serde(default)]
    pub cbv_wrong_way_rate: Option<f64>,
    /// The same in stage 2, against the planner's ego.
    #[serde(default)]
    pub cbv_wrong_way_rate_stage2: Option<f64>,
    /// Share of variants whose CBV drove across the lanes for a second or
    /// more in stage 1 (older reports lack it: read as unknown).
    #[serde(default)]
    pub cbv_across_lanes_rate: Option<f64>,
    /// The same in stage 2, against the planner's ego.
    #[serde(default)]
    pub cbv_across_lanes_rate_stage2: Option<f64>,
    /// Share of variants whose CBV turned harder than a car's tyres hold
    /// in stage 1 ([`SuiteMetrics::cbv_beyond_grip_rate`]; older reports
    /// lack it: read as unknown).
    #[serde(default)]
    pub cbv_beyond_grip_rate: Option<f64>,
    /// Share of variants whose CBV turned tighter than a car steers in
    /// stage 1 ([`SuiteMetrics::cbv_tighter_than_a_car_rate`]; older
    /// reports lack it: read as unknown).
    #[serde(default)]
    pub cbv_tighter_than_a_car_rate: Option<f64>,
    /// Share of variants whose CBV drove on the ego's bumper in stage 1
    /// ([`SuiteMetrics::cbv_tailgating_rate`]; older reports lack it: read
    /// as unknown).
    #[serde(default)]
    pub cbv_tailgating_rate: Option<f64>,
    /// How hard the CBV turned in stage 1
    /// ([`SuiteMetrics::cbv_peak_lateral_accel_mps2`]; older reports lack
    /// it: read as unknown).
    #[serde(default)]
    pub cbv_peak_lateral_accel_mps2: Option<Spread>,
    /// The same for the recorded CBV over the same steps.
    #[serde(default)]
    pub logged_cbv_peak_lateral_accel_mps2: Option<Spread>,
    /// How briskly the CBV moved across its lanes in stage 1
    /// ([`SuiteMetrics::cbv_sideways`]; older reports lack it: read as
    /// unknown).
    #[serde(default)]
    pub cbv_sideways: Option<SidewaysSpread>,
    /// The same for the recorded CBV over the same steps.
    #[serde(default)]
    pub logged_cbv_sideways: Option<SidewaysSpread>,
    /// [`MethodRow::cbv_sideways`] over the variants whose CBV changed
    /// lanes in stage 1 ([`SuiteMetrics::cbv_lane_change_sideways`]).
    pub cbv_lane_change_sideways: Option<SidewaysSpread>,
    /// The reference for it: the held sideways speeds of every recorded
    /// vehicle that changed lanes in the row's scenes over both stages'
    /// steps, each scene once ([`VariantRecord::recorded_lane_changes_mps`]).
    pub recorded_lane_change_sideways: Option<SidewaysSpread>,
    /// The scenes where the CBV left the road in stage 1: how many of
    /// each one's variants did, most first (a rate that one scene makes
    /// reads differently from one spread over many).
    pub off_road_scenes: Vec<SceneCount>,
    /// The same for the CBV at fault in a collision with background
    /// traffic.
    pub at_fault_scenes: Vec<SceneCount>,
    /// The same for the CBV driving against a lane's traffic, in either
    /// stage (older reports lack it: read as none).
    #[serde(default)]
    pub wrong_way_scenes: Vec<SceneCount>,
    /// The same for the CBV driving across the lanes for a second or more
    /// in either stage (older reports lack it: read as none).
    #[serde(default)]
    pub across_lanes_scenes: Vec<SceneCount>,
    /// How close the CBV came to the recorded ego in stage 1; `None` when
    /// no variant ran.
    pub stage1_closest: Option<ClosestApproach>,
    /// How close the CBV came to the planner's ego in stage 2, over the
    /// stage-1-critical variants; `None` when none was critical.
    pub stage2_closest_critical: Option<Stage2Approach>,
    /// Distinct variants per variant: how many different CBV paths the
    /// seeds of each scene made (stage 1, to the centimetre), summed over
    /// the scenes, over the variants that ran. 1 when every seed gives its
    /// own variant; `None` when no variant ran.
    pub distinct_rate: Option<f64>,
    /// Stage 2: share of variants whose CBV came within 1 m of the
    /// planner's ego.
    pub conflict_reach: Option<f64>,
    /// The same over the stage-1-critical variants.
    pub conflict_reach_critical: Option<f64>,
    /// SR over the avoidable conflicts (reached or collided, less the
    /// collisions without an escape).
    pub sr_avoidable: Option<f64>,
    /// The planner's failures on avoidable conflicts.
    pub avoidable_failures: usize,
    /// Stage-2 collisions with no closed-loop escape within budget (the
    /// generator's fault).
    pub no_escape_collisions: usize,
    /// Their share of the variants.
    pub no_escape_collision_rate: Option<f64>,
    /// Stage-2 collisions whose pre-check found an escape from the CBV as
    /// it drove that the reacting CBV then refuted (no closed-loop escape).
    pub precheck_refuted: usize,
    /// Variants the planner did not solve.
    pub failures: usize,
    /// Jensen–Shannon divergence of CBV speed vs the log.
    pub vj: Option<f64>,
    /// Jensen–Shannon divergence of CBV acceleration vs the log.
    pub aj: Option<f64>,
    /// Jensen–Shannon divergence of CBV yaw rate vs the log.
    pub yj: Option<f64>,
    /// Mean wall time per variant, s.
    pub time_per_variant_s: f64,
    /// The kinds of conflict the variants made: per kind, with the
    /// recorded ego (stage 1) and with the planner's (stage 2), and the
    /// planner's failures there.
    pub conflicts: Vec<super::metrics::KindCoverage>,
    /// Mean time per variant by part, s.
    pub profile: VariantProfile,
    /// The mutants the variants killed, when the evaluation planted them.
    pub kills: Option<MethodKills>,
}

/// How many of one scene's variants (of one method) something happened
/// in.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct SceneCount {
    /// Scenario id.
    pub scenario: String,
    /// The variants it happened in.
    pub variants: usize,
    /// The scene's variants that ran.
    pub of: usize,
}

/// The scenes where `happened` holds for at least one of `variants`, with
/// how many: most first, then by id.
fn scenes_where(variants: &[&VariantRecord], happened: impl Fn(&VariantRecord) -> bool) -> Vec<SceneCount> {
    let mut by_scene: std::collections::BTreeMap<&str, (usize, usize)> = Default::default();
    for r in variants {
        let (hits, of) = by_scene.entry(r.scenario.as_str()).or_default();
        *hits += usize::from(happened(r));
        *of += 1;
    }
    let mut scenes: Vec<SceneCount> = by_scene
        .into_iter()
        .filter(|&(_, (hits, _))| hits > 0)
        .map(|(scenario, (variants, of))| SceneCount { scenario: scenario.to_string(), variants, of })
        .collect();
    // Stable: scenes with as many variants stay in id order.
    scenes.sort_by_key(|c| std::cmp::Reverse(c.variants));
    scenes
}

/// Searches a feasibility witness for a finished stage 1: an ego
/// trajectory that avoids everyone as they drove, or none within budget.
pub type WitnessSearch = dyn Fn(&Scenario, &Rollout) -> Witness + Sync;

impl EvaluationRequest {
    /// How `method` drives the CBV in this evaluation's variants.
    pub fn method_settings(&self, method: AdversaryMethod) -> MethodSettings {
        MethodSettings {
            method,
            trust_region: self.trust_region,
            background: self.background,
            sampling: TokenSampling::default(),
            approach: self.approach,
            feasibility: self.feasibility,
            ego_contact: self.ego_contact,
            wrong_way: self.wrong_way,
            turning: self.turning,
            turning_cost: self.turning_cost,
        }
    }
}

/// The simulation settings and the variant seed of `method`'s variant
/// `seed_index` of `scenario` in an evaluation: both stages from the
/// scene's current step over the request's horizon.
pub fn stage1_setup(
    scenario: &Scenario,
    method: AdversaryMethod,
    seed_index: u32,
    request: &EvaluationRequest,
) -> (SimConfig, u64) {
    let (start, end) = stage_steps(scenario, request.horizon_s).into_inner();
    let background = match request.background {
        BackgroundDriver::ReactiveLogReplay => BackgroundPolicy::ReactiveLogReplay,
        BackgroundDriver::Configured | BackgroundDriver::Prior => SimConfig::default().background,
    };
    let sim = SimConfig { start_step: Some(start), end_step: Some(end), background, ..SimConfig::default() };
    (sim, variant_seed(request.base_seed, &format!("{}/{method:?}", scenario.id), seed_index))
}

/// The steps both stages of an evaluation's variants of `scenario` cover:
/// from its current step over `horizon_s`, within the recording.
fn stage_steps(scenario: &Scenario, horizon_s: f64) -> std::ops::RangeInclusive<usize> {
    let start = scenario.current_step;
    // Saturating: a horizon of 1e19 s is the whole recording, not an
    // overflow to an empty range.
    let end = start.saturating_add((horizon_s / scenario.dt_s).round() as usize).min(scenario.num_steps() - 1);
    start..=end
}

/// The spread of the recorded lane changes of `records`' scenes, each
/// scene once ([`VariantRecord::recorded_lane_changes_mps`]).
fn recorded_lane_change_sideways(records: &[&VariantRecord]) -> Option<SidewaysSpread> {
    let mut seen = std::collections::BTreeSet::new();
    SidewaysSpread::of(
        records
            .iter()
            .filter(|r| seen.insert(r.scenario.as_str()))
            .flat_map(|r| r.recorded_lane_changes_mps.iter().copied()),
    )
}

/// Runs one variant.
fn run_one(
    scenario: &Arc<Scenario>,
    (method, stage2_cbv, seed_index): (AdversaryMethod, Stage2Cbv, u32),
    request: &EvaluationRequest,
    models: &ModelSet,
    maps: &MapEncodings,
    witness: Option<&WitnessSearch>,
) -> Result<VariantRecord, HarnessError> {
    let clock = Instant::now();
    let (sim, seed) = stage1_setup(scenario, method, seed_index, request);
    let variant = format!("{}::{}::seed-{seed_index}", scenario.id, crate::spec::spec_name(&method));
    let setup = VariantSetup {
        scenario,
        settings: request.method_settings(method),
        seed,
        sim: &sim,
        stage2_cbv,
        planner: &request.planner,
        models,
        maps,
        variant: Some(&variant),
        escape: request.escape,
        ego_limits: Some(crate::sim::VehicleLimits::default()),
        fault: None,
    };
    let stages = pipeline::run(setup)?;
    let mutation = (!request.mutants.is_empty()).then(|| {
        let criteria = evaluation_criteria();
        let escape = stages.escape.as_ref().map(CollisionEscape::of);
        let base = acceptance::check(&criteria, &stages.stage2, scenario, stages.min_ttc_s, escape);
        VariantMutation::run(&base, &request.mutants, |op| {
            judge_mutant(&setup, &stages.stage1, &stages.stage2, &criteria, op)
        })
    });
    let background_contacts = cbv_background_collisions(scenario, &stages.stage1);
    let tally = VariantTally::with_background(scenario, &stages, &background_contacts);
    let mut profile = stages.profile;
    let witness_clock = Instant::now();
    let stage1_witness = match (tally.critical, witness) {
        (true, Some(search)) => Some(search(scenario, &stages.stage1)),
        _ => None,
    };
    let witness = stage1_witness.as_ref().map(Witness::is_found);
    profile.witness_s = witness_clock.elapsed().as_secs_f64();
    let (stage1_summary, stage2_summary) = (stages.stage1.summary(), stages.stage2.summary());
    let stage2_contact = stage2_summary.ego_collision.as_ref().map(|c| Stage2Contact {
        other: c.other.0.clone(),
        with_cbv: c.with_cbv,
        at_fault: c.at_fault,
    });
    let mut record = VariantRecord {
        scenario: scenario.id.clone(),
        method,
        stage2_cbv,
        seed: seed_index,
        stage1_collision: tally.critical,
        stage1_contact: stage1_summary.ego_collision.as_ref().filter(|c| c.with_cbv).map(|c| c.kind),
        cbv_start: CbvStart::of_scenario(scenario),
        stage2_collision: stages.stage2.ego_collision().is_some(),
        stage2: Some(stages.verdict.clone()),
        stage2_contact,
        witness,
        stage1_min_gap_m: stage1_summary.min_distance_to_ego_m,
        stage1_min_gap_to_cbv_m: ConflictReach::of(&stages.stage1).min_gap_to_cbv_m,
        stage2_min_gap_m: stage2_summary.min_distance_to_ego_m,
        stage2_min_gap_to_cbv_m: stages.reach.min_gap_to_cbv_m,
        conflict_reached: stages.reach.reached,
        stage2_escape: stages.escape.as_ref().map(CollisionEscape::of),
        stage2_escape_precheck: stages.escape.as_ref().map(|e| e.precheck_found),
        stage2_escape_rollouts: stages.escape.as_ref().map(|e| e.rollouts),
        cbv_hit_background: tally.cbv_hit_background,
        cbv_at_fault_with_background: tally.cbv_at_fault_with_background,
        cbv_background_contacts: background_contacts,
        cbv_off_road_s: (tally.cbv_off_road_s * 10.0).round() / 10.0,
        time_s: 0.0,
        profile,
        planner_latency: stages.planner_latency,
        error: None,
        artefacts: Vec::new(),
        tally: tally.clone(),
        // The scene's, filled in by `evaluate` once for all its variants.
        recorded_lane_changes_mps: Vec::new(),
        mutation,
    };
    let wanted = match request.artefacts_of {
        ArtefactVariants::Failing => !tally.solved,
        ArtefactVariants::All => true,
    };
    if let Some(dir) = request.artefacts.as_deref().filter(|_| wanted) {
        let outcome = VariantOutcome {
            name: format!("{}::{}::seed-{seed_index}", row_name(method, stage2_cbv), scenario.id),
            seed,
            scenario: scenario.clone(),
            stage1: stages.stage1,
            stage2: stages.stage2,
            verdict: stages.verdict,
            min_ttc_s: stages.min_ttc_s,
            reach: stages.reach,
            escape: stages.escape,
            tally,
            failures: Vec::new(),
            planner_latency: stages.planner_latency,
            planner_stderr: stages.planner_stderr,
            shrunk: None,
            not_shrunk: None,
        };
        let stage1_escape = stage1_witness.as_ref().and_then(|w| artefacts::stage1_escape(&outcome, w));
        let written = artefacts::write(dir, &outcome, stage1_escape).map_err(HarnessError::Artefacts)?;
        let (stage1_mcap, stage1_svg) = written.stage1;
        record.artefacts = [Some(written.mcap), Some(written.svg), Some(stage1_mcap), Some(stage1_svg), written.stderr]
            .into_iter()
            .flatten()
            .collect();
    }
    record.time_s = clock.elapsed().as_secs_f64();
    Ok(record)
}

/// A method's name in reports, with its stage-2 CBV mode when that is
/// closed loop (`safer`, `safer-closed-loop`).
fn row_name(method: AdversaryMethod, stage2_cbv: Stage2Cbv) -> String {
    let method = crate::spec::spec_name(&method);
    match stage2_cbv {
        Stage2Cbv::Replay => method,
        Stage2Cbv::ClosedLoop => format!("{method}-closed-loop"),
        Stage2Cbv::ClosedLoopDelayed => format!("{method}-closed-loop-delayed"),
    }
}

/// Runs every (scene, method, seed); `tick` is called after each variant.
/// Scenes without an ego or CBV are skipped by the caller.
pub fn evaluate(
    scenes: &[Arc<Scenario>],
    request: &EvaluationRequest,
    models: &ModelSet,
    witness: Option<&WitnessSearch>,
    tick: &(dyn Fn() + Sync),
) -> Vec<VariantRecord> {
    let maps = MapEncodings::default();
    let recorded_lane_changes: Vec<Vec<f64>> = scenes
        .par_iter()
        .map(|scenario| recorded_lane_changes_mps(scenario, stage_steps(scenario, request.horizon_s)))
        .collect();
    let jobs: Vec<(usize, AdversaryMethod, Stage2Cbv, u32)> = scenes
        .iter()
        .enumerate()
        .flat_map(|(i, _)| {
            request.methods.iter().flat_map(move |&m| {
                request.stage2_cbv.iter().flat_map(move |&mode| (0..request.seeds).map(move |s| (i, m, mode, s)))
            })
        })
        .collect();
    let mut records: Vec<VariantRecord> = jobs
        .par_iter()
        .map(|&(i, method, mode, seed)| {
            let scenario = &scenes[i];
            let r = run_one(scenario, (method, mode, seed), request, models, &maps, witness)
                .map(|r| VariantRecord { recorded_lane_changes_mps: recorded_lane_changes[i].clone(), ..r })
                .unwrap_or_else(|e| VariantRecord::failed(&scenario.id, method, mode, seed, e.to_string()));
            tick();
            r
        })
        .collect();
    sort_records(&mut records);
    records
}

/// Puts records in the order an evaluation reports them: by method,
/// stage-2 mode, scenario id and seed (whatever order they ran in, on
/// however many threads or machines).
pub fn sort_records(records: &mut [VariantRecord]) {
    records.sort_by(|a, b| {
        (a.method, a.stage2_cbv, &a.scenario, a.seed).cmp(&(b.method, b.stage2_cbv, &b.scenario, b.seed))
    });
}

/// The held-out part of an evaluation: every tenth scene by sorted id (the
/// 10th, 20th, …), looked at to report, never to tune on; and the table
/// over those scenes and over the rest.
#[derive(Debug, Clone, serde::Serialize)]
pub struct HeldOutSplit {
    /// The held-out scene ids, sorted.
    pub scenes: Vec<String>,
    /// How many scenes the evaluation had in all.
    pub of_scenes: usize,
    /// The table over the held-out scenes' variants.
    pub held_out: Vec<MethodRow>,
    /// The table over the other scenes' variants.
    pub rest: Vec<MethodRow>,
    /// For each row of `held_out`: the range (2.5th to 97.5th percentile)
    /// of the CR that as many scenes drawn at random from all of them
    /// give; `None` where nothing is held out or nothing ran.
    pub cr_by_chance: Vec<Option<[f64; 2]>>,
    /// For each row of `held_out`: the same range of reach-crit (see
    /// [`MethodRow::conflict_reach_critical`]); `None` also where no draw
    /// holds a critical variant.
    pub reach_critical_by_chance: Vec<Option<[f64; 2]>>,
}

/// Random draws behind [`HeldOutSplit::cr_by_chance`] and
/// [`HeldOutSplit::reach_critical_by_chance`].
const CHANCE_DRAWS: usize = 2000;

/// Splits `records` into the held-out scenes and the rest (see
/// [`HeldOutSplit`]), one row per method of `methods` on each side.
pub fn held_out_split(records: &[VariantRecord], methods: &[AdversaryMethod]) -> HeldOutSplit {
    let ids: std::collections::BTreeSet<&str> = records.iter().map(|r| r.scenario.as_str()).collect();
    let of_scenes = ids.len();
    let held = held_out_scenes(ids);
    let held_out = |r: &VariantRecord| held.contains(r.scenario.as_str());
    let held_out_rows = table_of(records, methods, held_out);
    // For each row: its records, and how many scenes it holds out.
    let row_draws: Vec<(Vec<&VariantRecord>, usize)> = held_out_rows
        .iter()
        .map(|row| {
            let of_row = |r: &VariantRecord| r.method == row.method && r.stage2_cbv == row.stage2_cbv;
            let scenes_held = records.iter().filter(|r| of_row(r) && held_out(r) && r.error.is_none());
            let k = scenes_held.map(|r| r.scenario.as_str()).collect::<std::collections::BTreeSet<_>>().len();
            (records.iter().filter(|r| of_row(r)).collect(), k)
        })
        .collect();
    let cr_by_chance = row_draws.iter().map(|(rows, k)| cr_of_random_scenes(rows.iter().copied(), *k)).collect();
    let reach_critical_by_chance =
        row_draws.iter().map(|(rows, k)| reach_critical_of_random_scenes(rows.iter().copied(), *k)).collect();
    HeldOutSplit {
        scenes: held.iter().cloned().collect(),
        of_scenes,
        held_out: held_out_rows,
        rest: table_of(records, methods, |r| !held_out(r)),
        cr_by_chance,
        reach_critical_by_chance,
    }
}

/// The table over the scenes whose CBV starts one way relative to the ego
/// ([`CbvStart`]).
#[derive(Debug, Clone, serde::Serialize)]
pub struct CbvStartRows {
    /// Where the CBV starts.
    pub start: CbvStart,
    /// How many scenes' CBVs start so.
    pub scenes: usize,
    /// The table over those scenes' variants, one row per method.
    pub rows: Vec<MethodRow>,
}

/// The table of `records` split by where each scene's CBV starts, in
/// [`CbvStart::ALL`]'s order, leaving out the starts no scene has: the
/// collision rate a method reaches from each start (a CBV behind the ego
/// going its way has no contact but from behind unless it overtakes).
pub fn by_cbv_start(records: &[VariantRecord], methods: &[AdversaryMethod]) -> Vec<CbvStartRows> {
    CbvStart::ALL
        .into_iter()
        .filter_map(|start| {
            let starts_so = |r: &VariantRecord| r.cbv_start == Some(start);
            let scenes: std::collections::BTreeSet<&str> =
                records.iter().filter(|r| starts_so(r)).map(|r| r.scenario.as_str()).collect();
            (!scenes.is_empty()).then(|| CbvStartRows {
                start,
                scenes: scenes.len(),
                rows: table_of(records, methods, starts_so),
            })
        })
        .collect()
}

/// The 2.5th and 97.5th percentiles of the CR of `k` scenes drawn at
/// random (without replacement) from those of `records` that ran, over
/// [`CHANCE_DRAWS`] draws of a fixed seed: how far a held-out CR over `k`
/// scenes may lie from the rest's by the luck of which scenes it got
/// (variants of one scene are not independent, so scenes are drawn, not
/// variants). `None` for `k` of 0 or more than there are scenes.
fn cr_of_random_scenes<'r>(records: impl Iterator<Item = &'r VariantRecord>, k: usize) -> Option<[f64; 2]> {
    // Per scene: (collisions, variants that ran).
    share_of_random_scenes(records, k, |r| (usize::from(r.tally.critical), 1))
}

/// [`cr_of_random_scenes`] for reach-crit: the share of the drawn scenes'
/// critical variants whose conflict reached the planner. A draw of scenes
/// without a critical variant has no reach-crit and is left out; `None`
/// where every draw is.
fn reach_critical_of_random_scenes<'r>(records: impl Iterator<Item = &'r VariantRecord>, k: usize) -> Option<[f64; 2]> {
    // Per scene: (critical variants reached, critical variants).
    share_of_random_scenes(records, k, |r| {
        let critical = usize::from(r.tally.critical);
        (critical * usize::from(r.tally.reached), critical)
    })
}

/// The 2.5th and 97.5th percentiles, over [`CHANCE_DRAWS`] draws of `k`
/// scenes at random (without replacement, a fixed seed) from those of
/// `records` that ran, of the share the drawn scenes' variants make
/// together: `count` gives a variant's (numerator, denominator), summed
/// over the draw. Draws whose denominator is 0 are left out. `None` for
/// `k` of 0 or more than there are scenes, or where every draw is left
/// out.
fn share_of_random_scenes<'r>(
    records: impl Iterator<Item = &'r VariantRecord>,
    k: usize,
    count: impl Fn(&VariantRecord) -> (usize, usize),
) -> Option<[f64; 2]> {
    use rand::{Rng, SeedableRng};
    // Per scene, in id order.
    let mut per_scene: std::collections::BTreeMap<&str, (usize, usize)> = std::collections::BTreeMap::new();
    for r in records.filter(|r| r.error.is_none()) {
        let e = per_scene.entry(r.scenario.as_str()).or_default();
        let (part, whole) = count(r);
        e.0 += part;
        e.1 += whole;
    }
    let scenes: Vec<(usize, usize)> = per_scene.into_values().collect();
    if k == 0 || k > scenes.len() {
        return None;
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5afe_0001);
    let mut order: Vec<usize> = (0..scenes.len()).collect();
    let mut shares: Vec<f64> = (0..CHANCE_DRAWS)
        .filter_map(|_| {
            // The first k of a partial Fisher–Yates shuffle.
            for i in 0..k {
                let j = rng.random_range(i..order.len());
                order.swap(i, j);
            }
            let (part, whole) = order[..k].iter().fold((0, 0), |(p, w), &i| (p + scenes[i].0, w + scenes[i].1));
            (whole > 0).then(|| part as f64 / whole as f64)
        })
        .collect();
    if shares.is_empty() {
        return None;
    }
    shares.sort_by(f64::total_cmp);
    let last = shares.len() - 1;
    let at = |q: f64| shares[((q * last as f64).round() as usize).min(last)];
    Some([at(0.025), at(0.975)])
}

/// The held-out scenes among `ids`: every tenth by sorted id (the 10th,
/// 20th, …).
pub fn held_out_scenes<'a>(ids: impl IntoIterator<Item = &'a str>) -> std::collections::BTreeSet<String> {
    let sorted: std::collections::BTreeSet<&str> = ids.into_iter().collect();
    sorted.into_iter().skip(9).step_by(10).map(String::from).collect()
}

/// How close the CBV came to the recorded ego in stage 1 (box distance),
/// as shares of the variants that ran; the four add up to one. It tells a
/// CBV that never got near the ego (the trust region offered no way there)
/// from one held off the last half metre (a state within d_th of the ego is
/// infeasible by definition, so a stage-1 contact needs the recorded ego
/// to leave its predicted path).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ClosestApproach {
    /// Contact: a stage-1 collision (the collision rate).
    pub contact: f64,
    /// No contact, closest gap under 0.5 m.
    pub under_half_m: f64,
    /// No contact, closest gap from 0.5 m to under 1 m.
    pub under_1_m: f64,
    /// Never within 1 m (or no gap measured: the two never met on the road).
    pub farther: f64,
}

/// Lower bounds of the [`ClosestApproach`] bands, m.
const CLOSEST_APPROACH_BANDS_M: [f64; 2] = [0.5, 1.0];

impl ClosestApproach {
    /// The shares over `variants` (that ran); `None` for none.
    fn of(variants: &[&VariantRecord]) -> Option<Self> {
        let n = variants.len();
        let share =
            |keep: &dyn Fn(&VariantRecord) -> bool| variants.iter().filter(|r| keep(r)).count() as f64 / n as f64;
        // The gap bands hold the variants without a stage-1 collision.
        let band = |gap: &dyn Fn(Option<f64>) -> bool| share(&|r| !r.tally.critical && gap(r.stage1_min_gap_to_cbv_m));
        let [half, one] = CLOSEST_APPROACH_BANDS_M;
        (n > 0).then(|| Self {
            contact: share(&|r| r.tally.critical),
            under_half_m: band(&|g| g.is_some_and(|g| g < half)),
            under_1_m: band(&|g| g.is_some_and(|g| (half..one).contains(&g))),
            // Counted, not the rest of 1: a difference of shares can round to −0.000.
            farther: band(&|g| g.is_none_or(|g| g >= one)),
        })
    }
}

/// Where the conflicts that hit the recorded ego in stage 1 met the
/// planner's ego in stage 2: counts of the stage-1-critical variants by
/// the CBV's closest approach (box distance), each in one band. The first
/// two add up to conflict reach on the critical variants; the rest tell
/// a conflict the planner passed near (it answered with a margin) from
/// one that never came near it, and from a rollout another collision
/// ended first.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Stage2Approach {
    /// The stage-1-critical variants that ran.
    pub critical: usize,
    /// The planner's ego collided with the CBV.
    pub contact: usize,
    /// The CBV came within 1 m without a collision with it (reached).
    pub under_1_m: usize,
    /// Not reached: the planner's ego hit another agent first, which
    /// ended the rollout.
    pub other_collision_first: usize,
    /// Not reached: the closest gap from 1 m to under 2 m.
    pub under_2_m: usize,
    /// ... from 2 m to under 5 m.
    pub under_5_m: usize,
    /// ... 5 m or more, or no gap measured (the CBV never on the road
    /// beside the planner's ego).
    pub farther: usize,
    /// The planner's CBV-blind twin (the `blind-cbv` mutant, where the
    /// evaluation planted it) on the variants of [`Self::under_2_m`]: a
    /// conflict that hits a planner blind to the CBV is one the planner
    /// had to answer, met even where it kept more than 1 m.
    pub blind_twin_under_2_m: BlindTwinHits,
    /// ... on those of [`Self::under_5_m`].
    pub blind_twin_under_5_m: BlindTwinHits,
    /// ... on those of [`Self::farther`].
    pub blind_twin_farther: BlindTwinHits,
}

/// Of some variants the planner passed, on how many its CBV-blind twin
/// (the `blind-cbv` mutant) ran, and on how many of those its ego
/// collided with the CBV.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct BlindTwinHits {
    /// Variants the twin ran on.
    pub ran: usize,
    /// Of those, the ones where it hit the CBV.
    pub hit: usize,
}

impl BlindTwinHits {
    /// Counts `record`'s `blind-cbv` mutant, if it ran.
    fn add(&mut self, record: &VariantRecord) {
        let twin = record
            .mutation
            .as_ref()
            .and_then(|m| m.mutants.iter().find(|t| t.operator == FaultOperator::BlindCbv && t.error.is_none()));
        if let Some(twin) = twin {
            self.ran += 1;
            self.hit += usize::from(twin.hit_cbv);
        }
    }
}

/// Upper bounds of the [`Stage2Approach`] bands beyond reach, m.
const STAGE2_APPROACH_BANDS_M: [f64; 2] = [2.0, 5.0];

impl Stage2Approach {
    /// The critical variants the CBV did not reach on which the planner's
    /// CBV-blind twin ran, and of those the ones where it hit the CBV.
    pub fn blind_twin(&self) -> BlindTwinHits {
        let bands = [self.blind_twin_under_2_m, self.blind_twin_under_5_m, self.blind_twin_farther];
        bands
            .iter()
            .fold(BlindTwinHits::default(), |sum, t| BlindTwinHits { ran: sum.ran + t.ran, hit: sum.hit + t.hit })
    }

    /// The share of the critical variants whose conflict met the planner:
    /// reached (a contact or under 1 m: reach-crit) or a threat its
    /// CBV-blind twin ran into. Without `blind-cbv` planted it is
    /// reach-crit. `None` for no critical variant.
    pub fn met(&self) -> Option<f64> {
        let met = self.contact + self.under_1_m + self.blind_twin().hit;
        (self.critical > 0).then(|| met as f64 / self.critical as f64)
    }

    /// The counts over the critical ones of `variants` (that ran); `None`
    /// when none was critical.
    fn of(variants: &[&VariantRecord]) -> Option<Self> {
        let [two, five] = STAGE2_APPROACH_BANDS_M;
        let mut counts = Stage2Approach::default();
        for r in variants.iter().filter(|r| r.tally.critical) {
            counts.critical += 1;
            let band = if r.tally.reached {
                if r.stage2_contact.as_ref().is_some_and(|c| c.with_cbv) {
                    &mut counts.contact
                } else {
                    &mut counts.under_1_m
                }
            } else if r.tally.collided_with_other {
                &mut counts.other_collision_first
            } else {
                let (band, twin) = match r.stage2_min_gap_to_cbv_m {
                    Some(g) if g < two => (&mut counts.under_2_m, &mut counts.blind_twin_under_2_m),
                    Some(g) if g < five => (&mut counts.under_5_m, &mut counts.blind_twin_under_5_m),
                    _ => (&mut counts.farther, &mut counts.blind_twin_farther),
                };
                twin.add(r);
                band
            };
            *band += 1;
        }
        (counts.critical > 0).then_some(counts)
    }
}

/// The share of `variants` (of one method) that differ from every other
/// seed's variant of their scene: distinct CBV paths per scene, summed,
/// over the variants; `None` for none.
fn distinct_rate(variants: &[&VariantRecord]) -> Option<f64> {
    let distinct: std::collections::BTreeSet<(&str, Option<u64>)> =
        variants.iter().map(|r| (r.scenario.as_str(), r.tally.cbv_path_digest)).collect();
    (!variants.is_empty()).then(|| distinct.len() as f64 / variants.len() as f64)
}

/// The mutation runs of `variants`, as the kills count them.
pub(crate) fn kills_inputs<'a>(variants: &[&'a VariantRecord]) -> impl Iterator<Item = KillsInput<'a>> {
    variants.iter().filter_map(|r| {
        Some(KillsInput {
            scene: &r.scenario,
            cbv_path_digest: r.tally.cbv_path_digest,
            mutation: r.mutation.as_ref()?,
        })
    })
}

/// One row per method, in the requested order, and within a method one
/// per stage-2 CBV mode the records hold (replay first), side by side. CR,
/// SR, SR-crit, VJ, AJ, reach and SR over avoidable conflicts are the
/// suite metrics ([`SuiteMetrics::aggregate`]) over the variants that ran;
/// variants that could not run are counted in `errors`.
pub fn table(records: &[VariantRecord], methods: &[AdversaryMethod]) -> Vec<MethodRow> {
    table_of(records, methods, |_| true)
}

/// The stage-2 CBV modes `records` hold, replay first; replay alone
/// where they hold none (a table of no records still has its rows).
pub(crate) fn stage2_modes(records: &[VariantRecord]) -> Vec<Stage2Cbv> {
    let mut modes: Vec<Stage2Cbv> = records.iter().map(|r| r.stage2_cbv).collect();
    modes.sort();
    modes.dedup();
    if modes.is_empty() {
        modes.push(Stage2Cbv::Replay);
    }
    modes
}

/// [`table`] over the records that `keep` keeps.
fn table_of(
    records: &[VariantRecord],
    methods: &[AdversaryMethod],
    keep: impl Fn(&VariantRecord) -> bool,
) -> Vec<MethodRow> {
    let modes = stage2_modes(records);
    // What log replay catches, per stage-2 mode, where it ran with mutants.
    let replay_catches: Vec<(Stage2Cbv, ReplayCatches)> = modes
        .iter()
        .filter_map(|&mode| {
            let replay: Vec<&VariantRecord> = records
                .iter()
                .filter(|r| r.method == AdversaryMethod::Log && r.stage2_cbv == mode && r.error.is_none() && keep(r))
                .collect();
            replay.iter().any(|r| r.mutation.is_some()).then(|| (mode, MethodKills::catches(kills_inputs(&replay))))
        })
        .collect();
    methods
        .iter()
        .flat_map(|&method| modes.iter().map(move |&mode| (method, mode)))
        .map(|(method, mode)| {
            let all: Vec<&VariantRecord> =
                records.iter().filter(|r| r.method == method && r.stage2_cbv == mode && keep(r)).collect();
            let ok: Vec<&VariantRecord> = all.iter().copied().filter(|r| r.error.is_none()).collect();
            let metrics = SuiteMetrics::aggregate(ok.iter().map(|r| &r.tally));
            let searched: Vec<&VariantRecord> = ok.iter().copied().filter(|r| r.witness.is_some()).collect();
            let witnessed: Vec<&VariantRecord> = searched.iter().copied().filter(|r| r.witness == Some(true)).collect();
            let witness_rate = (!searched.is_empty()).then(|| witnessed.len() as f64 / searched.len() as f64);
            let sr_witnessed = (!witnessed.is_empty())
                .then(|| witnessed.iter().filter(|r| r.tally.solved).count() as f64 / witnessed.len() as f64);
            let n = ok.len().max(1) as f64;
            let mut profile = VariantProfile::default();
            for r in &ok {
                profile.add(&r.profile);
            }
            MethodRow {
                profile: profile.scaled(1.0 / n),
                method,
                stage2_cbv: mode,
                variants: all.len(),
                errors: all.len() - ok.len(),
                cr: metrics.collision_rate,
                sr: metrics.solution_rate,
                sr_critical: metrics.solution_rate_critical,
                witness_rate,
                sr_witnessed,
                cbv_background_collision_rate: metrics.cbv_background_collision_rate,
                cbv_at_fault_background_collision_rate: metrics.cbv_at_fault_background_collision_rate,
                cbv_at_fault_vulnerable_rate: metrics.cbv_at_fault_vulnerable_rate,
                cbv_off_road_rate: metrics.cbv_off_road_rate,
                cbv_off_road_s: metrics.cbv_off_road_s,
                cbv_wrong_way_rate: metrics.cbv_wrong_way_rate,
                cbv_wrong_way_rate_stage2: metrics.cbv_wrong_way_rate_stage2,
                cbv_across_lanes_rate: metrics.cbv_across_lanes_rate,
                cbv_across_lanes_rate_stage2: metrics.cbv_across_lanes_rate_stage2,
                cbv_beyond_grip_rate: metrics.cbv_beyond_grip_rate,
                cbv_tighter_than_a_car_rate: metrics.cbv_tighter_than_a_car_rate,
                cbv_tailgating_rate: metrics.cbv_tailgating_rate,
                cbv_peak_lateral_accel_mps2: metrics.cbv_peak_lateral_accel_mps2,
                logged_cbv_peak_lateral_accel_mps2: metrics.logged_cbv_peak_lateral_accel_mps2,
                cbv_sideways: metrics.cbv_sideways,
                logged_cbv_sideways: metrics.logged_cbv_sideways,
                cbv_lane_change_sideways: metrics.cbv_lane_change_sideways,
                recorded_lane_change_sideways: recorded_lane_change_sideways(&ok),
                off_road_scenes: scenes_where(&ok, |r| r.tally.cbv_left_road()),
                at_fault_scenes: scenes_where(&ok, |r| r.tally.cbv_at_fault_with_background),
                wrong_way_scenes: scenes_where(&ok, |r| {
                    r.tally.cbv_drove_wrong_way() || r.tally.cbv_drove_wrong_way_in_stage2()
                }),
                across_lanes_scenes: scenes_where(&ok, |r| {
                    r.tally.cbv_drove_across_lanes() || r.tally.cbv_drove_across_lanes_in_stage2()
                }),
                stage1_closest: ClosestApproach::of(&ok),
                stage2_closest_critical: Stage2Approach::of(&ok),
                distinct_rate: distinct_rate(&ok),
                conflict_reach: metrics.conflict_reach,
                conflict_reach_critical: metrics.conflict_reach_critical,
                sr_avoidable: metrics.solution_rate_avoidable,
                avoidable_failures: metrics.avoidable_failures,
                no_escape_collisions: metrics.no_escape_collisions,
                no_escape_collision_rate: metrics.no_escape_collision_rate,
                precheck_refuted: ok
                    .iter()
                    .filter(|r| {
                        r.stage2_escape_precheck == Some(true) && r.stage2_escape.is_some_and(|e| !e.avoidable())
                    })
                    .count(),
                failures: ok.iter().filter(|r| !r.tally.solved).count(),
                vj: metrics.velocity_jsd,
                aj: metrics.acceleration_jsd,
                yj: metrics.yaw_rate_jsd,
                time_per_variant_s: ok.iter().map(|r| r.time_s).sum::<f64>() / n,
                conflicts: metrics.coverage,
                kills: MethodKills::of(
                    kills_inputs(&ok),
                    replay_catches.iter().find(|(m, _)| *m == mode).map(|(_, c)| c),
                ),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::mutation::MutantRecord;

    /// A variant of `scenario` that ran and whose CBV path has `digest`.
    fn record(scenario: &str, seed: u32, digest: u64) -> VariantRecord {
        VariantRecord {
            error: None,
            tally: VariantTally { cbv_path_digest: Some(digest), ..VariantTally::default() },
            ..VariantRecord::failed(scenario, AdversaryMethod::Safer, Stage2Cbv::Replay, seed, String::new())
        }
    }

    #[test]
    fn the_table_by_cbv_start_puts_each_scenes_variants_under_its_start_and_leaves_out_starts_no_scene_has() {
        let variant = |scenario: &str, seed: u32, start: Option<CbvStart>, critical: bool| VariantRecord {
            cbv_start: start,
            stage1_collision: critical,
            tally: VariantTally { critical, ..record(scenario, seed, u64::from(seed)).tally },
            ..record(scenario, seed, u64::from(seed))
        };
        let records = [
            variant("a", 0, Some(CbvStart::Behind), false),
            variant("a", 1, Some(CbvStart::Behind), true),
            variant("b", 0, Some(CbvStart::Behind), false),
            variant("b", 1, Some(CbvStart::Behind), false),
            variant("c", 0, Some(CbvStart::Crossing), true),
            variant("c", 1, Some(CbvStart::Crossing), true),
            // A scene whose start is unknown (a report from before it was
            // recorded) counts under none.
            variant("d", 0, None, true),
        ];
        let split = by_cbv_start(&records, &[AdversaryMethod::Safer]);
        let got: Vec<(CbvStart, usize, Option<f64>)> =
            split.iter().map(|s| (s.start, s.scenes, s.rows[0].cr)).collect();
        assert_eq!(got, [(CbvStart::Behind, 2, Some(0.25)), (CbvStart::Crossing, 1, Some(1.0))]);
        assert_eq!(table(&records, &[AdversaryMethod::Safer])[0].cr, Some(4.0 / 7.0));
    }

    #[test]
    fn the_closest_approach_puts_each_variant_in_one_band_and_contact_before_any_gap() {
        // A contact (whose gap reads 0), gaps of 0.2 and 0.5 m (the band's
        // lower bound belongs to it), 0.99 m, 1.0 m and none measured.
        let gaps = [(true, Some(0.0)), (false, Some(0.2)), (false, Some(0.5)), (false, Some(0.99))];
        let rest = [(false, Some(1.0)), (false, None)];
        let records: Vec<VariantRecord> = gaps
            .iter()
            .chain(&rest)
            .enumerate()
            .map(|(i, &(critical, gap))| VariantRecord {
                // The gap to anyone is not the CBV's: a car beside the ego
                // closer than the CBV must not move a variant's band.
                stage1_min_gap_m: Some(0.1),
                stage1_min_gap_to_cbv_m: gap,
                tally: VariantTally { critical, ..record("a", i as u32, i as u64).tally },
                ..record("a", i as u32, i as u64)
            })
            .collect();
        let c = table(&records, &[AdversaryMethod::Safer])[0].stage1_closest.unwrap();
        assert_eq!((c.contact, c.under_half_m, c.under_1_m), (1.0 / 6.0, 1.0 / 6.0, 2.0 / 6.0));
        assert!((c.farther - 2.0 / 6.0).abs() < 1e-12);
        assert_eq!(table(&[], &[AdversaryMethod::Safer])[0].stage1_closest, None);
    }

    #[test]
    fn the_stage2_approach_counts_each_critical_variant_in_one_band_and_its_first_two_are_reach() {
        // (critical, reached, contact with the CBV, collided with another
        // agent, stage-2 gap to the CBV): a contact; a near approach; a
        // rollout another collision ended; gaps of 1.0, 1.99, 2.0 and 5.0 m
        // (each bound belongs to the band above it) and none measured; and
        // a variant that was not critical, which no band counts.
        let cases = [
            (true, true, true, false, Some(0.0)),
            (true, true, false, false, Some(0.4)),
            (true, false, false, true, Some(0.8)),
            (true, false, false, false, Some(1.0)),
            (true, false, false, false, Some(1.99)),
            (true, false, false, false, Some(2.0)),
            (true, false, false, false, Some(5.0)),
            (true, false, false, false, None),
            (false, true, true, false, Some(0.0)),
        ];
        // The CBV-blind twin: hit the CBV at 1.0 m, missed it at 1.99 m,
        // could not run at 2.0 m, not planted at 5.0 m, hit it where no gap
        // was measured; a hit on a variant reached counts in no band.
        let twin = |hit_cbv: bool, error: bool| {
            Some(VariantMutation {
                base_failure: None,
                mutants: vec![
                    MutantRecord {
                        operator: FaultOperator::NoBrake,
                        killed: true,
                        failure: None,
                        hit_cbv: true,
                        drove_differently: Some(true),
                        path_departure_m: Some(0.0),
                        error: None,
                    },
                    MutantRecord {
                        operator: FaultOperator::BlindCbv,
                        killed: hit_cbv,
                        failure: None,
                        hit_cbv,
                        drove_differently: Some(true),
                        path_departure_m: Some(0.0),
                        error: error.then(|| "gone".to_owned()),
                    },
                ],
            })
        };
        let twins = [
            None,
            twin(true, false),
            None,
            twin(true, false),
            twin(false, false),
            twin(true, true),
            None,
            twin(true, false),
            None,
        ];
        let records: Vec<VariantRecord> = cases
            .iter()
            .zip(twins)
            .enumerate()
            .map(|(i, (&(critical, reached, contact, other, gap), mutation))| {
                let base = record("a", i as u32, i as u64);
                VariantRecord {
                    mutation,
                    stage2_min_gap_to_cbv_m: gap,
                    stage2_contact: (contact || other).then(|| Stage2Contact {
                        other: "7".into(),
                        with_cbv: contact,
                        at_fault: false,
                    }),
                    tally: VariantTally { critical, reached, collided_with_other: other, ..base.tally.clone() },
                    ..base
                }
            })
            .collect();
        let row = &table(&records, &[AdversaryMethod::Safer])[0];
        let c = row.stage2_closest_critical.unwrap();
        assert_eq!(
            c,
            Stage2Approach {
                critical: 8,
                contact: 1,
                under_1_m: 1,
                other_collision_first: 1,
                under_2_m: 2,
                under_5_m: 1,
                farther: 2,
                blind_twin_under_2_m: BlindTwinHits { ran: 2, hit: 1 },
                blind_twin_under_5_m: BlindTwinHits { ran: 0, hit: 0 },
                blind_twin_farther: BlindTwinHits { ran: 1, hit: 1 },
            }
        );
        assert_eq!(
            Some((c.contact + c.under_1_m) as f64 / c.critical as f64),
            row.conflict_reach_critical,
            "the first two bands are reach on the critical variants"
        );
        assert_eq!(c.blind_twin(), BlindTwinHits { ran: 3, hit: 2 });
        assert_eq!(c.met(), Some(4.0 / 8.0), "reached 2, and the twin hit 2 more");
        let without_twin = Stage2Approach { critical: 4, contact: 1, under_1_m: 1, under_2_m: 2, ..Default::default() };
        assert_eq!(without_twin.met(), Some(0.5), "reach-crit where no twin ran");
        assert_eq!(Stage2Approach::default().met(), None, "no critical variant");
        let none_critical = [record("a", 0, 0)];
        assert_eq!(table(&none_critical, &[AdversaryMethod::Safer])[0].stage2_closest_critical, None);
    }

    #[test]
    fn the_scenes_where_the_cbv_broke_a_rule_are_counted_by_scene_most_first() {
        // Scene b: two of three variants off the road, one at fault; a: one
        // of two off the road; c: none; d: one off the road, but it could
        // not run, so it is no variant of the table's.
        let broke = |scenario: &str, seed: u32, off_road_s: f64, at_fault: bool| VariantRecord {
            tally: VariantTally {
                cbv_off_road_s: off_road_s,
                cbv_at_fault_with_background: at_fault,
                ..record(scenario, seed, 0).tally
            },
            ..record(scenario, seed, 0)
        };
        let mut failed = broke("d", 0, 1.0, true);
        failed.error = Some("the planner crashed".into());
        let records = [
            broke("a", 0, 0.5, false),
            broke("a", 1, 0.0, false),
            broke("b", 0, 2.0, false),
            broke("b", 1, 0.1, true),
            broke("b", 2, 0.0, false),
            broke("c", 0, 0.0, false),
            failed,
        ];
        let row = &table(&records, &[AdversaryMethod::Safer])[0];
        let count = |scenario: &str, variants, of| SceneCount { scenario: scenario.into(), variants, of };
        assert_eq!(row.off_road_scenes, [count("b", 2, 3), count("a", 1, 2)]);
        assert_eq!(row.at_fault_scenes, [count("b", 1, 3)]);
        // Scenes with as many variants come in id order.
        let tie = [broke("z", 0, 1.0, false), broke("y", 0, 1.0, false)];
        let row = &table(&tie, &[AdversaryMethod::Safer])[0];
        assert_eq!(row.off_road_scenes, [count("y", 1, 1), count("z", 1, 1)]);
        assert!(row.at_fault_scenes.is_empty());
    }

    #[test]
    fn seeds_that_made_the_same_variant_count_once_and_only_within_their_scene() {
        // Scene a: seeds 0 and 2 made the same path; scene b's path has a's
        // digest but is another scene's variant.
        let records = [record("a", 0, 7), record("a", 1, 8), record("a", 2, 7), record("b", 0, 7)];
        let rows = table(&records, &[AdversaryMethod::Safer]);
        assert_eq!(rows[0].distinct_rate, Some(0.75));
        assert_eq!(table(&[], &[AdversaryMethod::Safer])[0].distinct_rate, None);
    }

    #[test]
    fn every_tenth_scene_by_id_is_held_out_and_each_side_gets_its_own_rows() {
        // 25 scenes, named so that their sorted order is s00 … s24; only
        // the held-out ones (s09, s19) collide.
        let records: Vec<VariantRecord> = (0..25)
            .map(|i| {
                let id = format!("s{i:02}");
                let mut r = record(&id, 0, i);
                r.tally.critical = i % 10 == 9;
                r
            })
            .rev()
            .collect();
        let split = held_out_split(&records, &[AdversaryMethod::Safer]);
        assert_eq!(split.scenes, ["s09", "s19"]);
        assert_eq!(split.of_scenes, 25);
        assert_eq!((split.held_out[0].variants, split.held_out[0].cr), (2, Some(1.0)));
        assert_eq!((split.rest[0].variants, split.rest[0].cr), (23, Some(0.0)));
        // Fewer than ten scenes: nothing is held out.
        let few = held_out_split(&records[..9], &[AdversaryMethod::Safer]);
        assert!(few.scenes.is_empty() && few.held_out[0].variants == 0 && few.rest[0].variants == 9);
        assert_eq!(few.cr_by_chance, [None]);
        assert_eq!(few.reach_critical_by_chance, [None]);
        // Two of 25 scenes collide: two scenes at random make a CR of 0,
        // 0.5 or (rarely: 1 draw in 300) 1.
        let [lo, hi] = split.cr_by_chance[0].expect("two scenes held out");
        assert_eq!((lo, hi), (0.0, 0.5));
        // None of the critical variants reached the planner: every draw
        // with one has a reach-crit of 0.
        assert_eq!(split.reach_critical_by_chance, [Some([0.0, 0.0])]);
    }

    /// `scenes` scenes `s0`, `s1`, … of `seeds` variants each, every
    /// variant set by `mark` with its scene's index.
    fn scenes_of_variants(scenes: usize, seeds: u32, mark: impl Fn(usize, &mut VariantRecord)) -> Vec<VariantRecord> {
        (0..scenes)
            .flat_map(|i| (0..seeds).map(move |seed| (i, seed)))
            .map(|(i, seed)| {
                let mut r = record(&format!("s{i}"), seed, u64::from(seed));
                mark(i, &mut r);
                r
            })
            .collect()
    }

    #[test]
    fn the_cr_by_chance_draws_scenes_not_variants() {
        // Ten scenes of ten variants: one scene always collides, the others
        // never. One scene drawn at random makes a CR of 0 or 1, never
        // between; variants drawn one by one would.
        let records = scenes_of_variants(10, 10, |i, r| r.tally.critical = i == 3);
        let [lo, hi] = cr_of_random_scenes(records.iter(), 1).unwrap();
        assert_eq!((lo, hi), (0.0, 1.0));
        // All ten: the overall CR, every draw.
        assert_eq!(cr_of_random_scenes(records.iter(), 10), Some([0.1, 0.1]));
        assert_eq!(cr_of_random_scenes(records.iter(), 11), None);
        assert_eq!(cr_of_random_scenes(records.iter(), 0), None);
        // The same draws on any machine: a fixed seed.
        assert_eq!(cr_of_random_scenes(records.iter(), 3), cr_of_random_scenes(records.iter(), 3));
    }

    #[test]
    fn the_reach_crit_by_chance_leaves_out_draws_without_a_critical_variant() {
        // Ten scenes of four variants: scene 3's are all critical and reach
        // the planner, scene 5's are all critical and do not, the others
        // have no critical variant.
        let records = scenes_of_variants(10, 4, |i, r| {
            r.tally.critical = i == 3 || i == 5;
            r.tally.reached = i != 5;
        });
        // One scene a draw: only scenes 3 and 5 have a reach-crit, 1 or 0;
        // the eight others are left out, not counted as 0.
        assert_eq!(reach_critical_of_random_scenes(records.iter(), 1), Some([0.0, 1.0]));
        // All ten: 4 of the 8 critical variants, every draw.
        assert_eq!(reach_critical_of_random_scenes(records.iter(), 10), Some([0.5, 0.5]));
        // No critical variant anywhere: no draw has a reach-crit.
        let calm: Vec<VariantRecord> = records.iter().filter(|r| !r.tally.critical).cloned().collect();
        assert_eq!(reach_critical_of_random_scenes(calm.iter(), 2), None);
        // (The reached variants of the calm scenes count for nothing: all
        // ten scenes give 0.5, not 36 of 40.) The CR of the same draws
        // counts every variant.
        assert_eq!(cr_of_random_scenes(records.iter(), 10), Some([0.2, 0.2]));
    }
}
