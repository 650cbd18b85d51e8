//! The dual-stage evaluation of adversary methods over many scenes and
//! seeds (the paper's Table II protocol). For each (scene, method, seed):
//! stage 1 — the ego replays its log while the method drives the CBV; a
//! CBV–ego collision counts toward the collision rate CR. Stage 2 — a
//! reactive planner drives the ego through the same variant with the CBV
//! replaying its stage-1 trajectory (or, optionally, driven by the method
//! again, closed loop); surviving without an ego collision counts toward
//! the solution rate SR. Each stage-1 collision is checked for a
//! feasibility witness. VJ and AJ compare the CBV's stage-1 speed and
//! acceleration with the logged CBV's (see [`Histogram::speed`] and
//! [`Histogram::acceleration`] for the bins).
//!
//! Variants run in parallel with rayon; each is a pure function of its
//! (scene, method, seed), and results are sorted, so the table does not
//! depend on the thread count.

use std::sync::Arc;
use std::time::Instant;

use rayon::prelude::*;

use super::HarnessError;
use super::methods::{self, BackgroundDriver, MapEncodings, MethodSettings, ModelSet};
use super::variant::{track_from_rollout, variant_seed};
use crate::eval::{Histogram, jensen_shannon};
use crate::planners::BuiltinPlanner;
use crate::policies::LogReplay;
use crate::policies::prior_sampling::TokenSampling;
use crate::scenario::Scenario;
use crate::sim::{Rollout, SimConfig, Simulation};
use crate::spec::suite::AdversaryMethod;

/// How the CBV behaves in stage 2.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stage2Cbv {
    /// Replays its stage-1 trajectory (the paper's protocol).
    #[default]
    Replay,
    /// Is driven by the method again, reacting to the planner.
    ClosedLoop,
}

/// What to evaluate.
#[derive(Debug, Clone)]
pub struct EvaluationRequest {
    /// Methods, one table row each.
    pub methods: Vec<AdversaryMethod>,
    /// Seeds per (scene, method).
    pub seeds: u32,
    /// Base seed.
    pub base_seed: u64,
    /// Reactive planner of stage 2.
    pub planner: BuiltinPlanner,
    /// Trust-region size n.
    pub trust_region: usize,
    /// Who drives the background agents.
    pub background: BackgroundDriver,
    /// Stage-2 CBV.
    pub stage2_cbv: Stage2Cbv,
    /// Horizon of both stages from the scene's current step, s.
    pub horizon_s: f64,
}

/// The outcome of one variant.
#[derive(Debug, Clone, serde::Serialize)]
pub struct VariantRecord {
    /// Scenario id.
    pub scenario: String,
    /// Method.
    pub method: AdversaryMethod,
    /// Seed index.
    pub seed: u32,
    /// Stage 1: the CBV hit the ego.
    pub stage1_collision: bool,
    /// Stage 2: the ego collided with anything.
    pub stage2_collision: bool,
    /// For a stage-1 collision: whether a feasibility witness was found.
    pub witness: Option<bool>,
    /// Stage-1 closest ego–CBV gap, m.
    pub stage1_min_gap_m: Option<f64>,
    /// Wall time of the variant (both stages and the witness), s.
    pub time_s: f64,
    /// Where the time went, s.
    pub profile: VariantProfile,
    /// Why the variant could not be run, if it could not.
    pub error: Option<String>,
    #[serde(skip)]
    cbv_speeds_mps: Vec<f64>,
    #[serde(skip)]
    cbv_accels_mps2: Vec<f64>,
    #[serde(skip)]
    logged_speeds_mps: Vec<f64>,
    #[serde(skip)]
    logged_accels_mps2: Vec<f64>,
}

/// Where a variant's time went, s.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct VariantProfile {
    /// Stage 1, whole (simulation, CBV method, models).
    pub stage1_s: f64,
    /// Of which: the prior's query features.
    pub stage1_features_s: f64,
    /// Of which: the prior's decoder.
    pub stage1_decoder_s: f64,
    /// Of which: feasibility value queries.
    pub stage1_feasibility_s: f64,
    /// Stage 2 (the planner under test).
    pub stage2_s: f64,
    /// The witness search.
    pub witness_s: f64,
}

impl VariantProfile {
    fn add(&mut self, o: &VariantProfile) {
        self.stage1_s += o.stage1_s;
        self.stage1_features_s += o.stage1_features_s;
        self.stage1_decoder_s += o.stage1_decoder_s;
        self.stage1_feasibility_s += o.stage1_feasibility_s;
        self.stage2_s += o.stage2_s;
        self.witness_s += o.witness_s;
    }

    fn scaled(&self, k: f64) -> VariantProfile {
        VariantProfile {
            stage1_s: self.stage1_s * k,
            stage1_features_s: self.stage1_features_s * k,
            stage1_decoder_s: self.stage1_decoder_s * k,
            stage1_feasibility_s: self.stage1_feasibility_s * k,
            stage2_s: self.stage2_s * k,
            witness_s: self.witness_s * k,
        }
    }
}

/// One row of the table.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MethodRow {
    /// Method.
    pub method: AdversaryMethod,
    /// Variants run.
    pub variants: usize,
    /// Variants that could not run.
    pub errors: usize,
    /// Collision rate (stage 1).
    pub cr: f64,
    /// Solution rate over all variants (stage 2).
    pub sr: f64,
    /// Solution rate over the stage-1 critical variants.
    pub sr_critical: Option<f64>,
    /// Share of stage-1 collisions with a feasibility witness.
    pub witness_rate: Option<f64>,
    /// Jensen–Shannon divergence of CBV speed vs the log.
    pub vj: Option<f64>,
    /// Jensen–Shannon divergence of CBV acceleration vs the log.
    pub aj: Option<f64>,
    /// Mean wall time per variant, s.
    pub time_per_variant_s: f64,
    /// Mean time per variant by part, s.
    pub profile: VariantProfile,
}

/// Searches a feasibility witness for a finished stage 1: `Some(true)` when
/// an ego trajectory avoiding everyone exists, `Some(false)` when none was
/// found within budget.
pub type WitnessSearch = dyn Fn(&Scenario, &Rollout) -> bool + Sync;

fn speeds_and_accels(states: impl Iterator<Item = Option<f64>>, dt_s: f64) -> (Vec<f64>, Vec<f64>) {
    let v: Vec<Option<f64>> = states.collect();
    let speeds = v.iter().flatten().copied().collect();
    let accels = v.windows(2).filter_map(|w| Some((w[1]? - w[0]?) / dt_s)).collect();
    (speeds, accels)
}

/// Runs one variant.
#[allow(clippy::too_many_arguments)]
fn run_one(
    scenario: &Arc<Scenario>,
    method: AdversaryMethod,
    seed_index: u32,
    request: &EvaluationRequest,
    models: &ModelSet,
    maps: &MapEncodings,
    witness: Option<&WitnessSearch>,
) -> Result<VariantRecord, HarnessError> {
    let clock = Instant::now();
    let ego = scenario.ego.ok_or_else(|| crate::sim::SimError::NoEgo(scenario.id.clone()))?;
    let cbv = scenario.cbv.ok_or_else(|| HarnessError::NoCbv(scenario.id.clone()))?;
    let start = scenario.current_step;
    let end = (start + (request.horizon_s / scenario.dt_s).round() as usize).min(scenario.num_steps() - 1);
    let config = SimConfig { start_step: Some(start), end_step: Some(end), ..SimConfig::default() };
    let seed = variant_seed(request.base_seed, &format!("{}/{method:?}", scenario.id), seed_index);
    let settings = MethodSettings {
        method,
        trust_region: request.trust_region,
        background: request.background,
        sampling: TokenSampling::default(),
    };

    let mut stage1 = Simulation::new(scenario, config.clone())?;
    let installed = methods::install(&mut stage1, scenario, cbv, start, settings, models, maps, seed)?;
    let mut replay_ego = BuiltinPlanner::LogReplay.instantiate(scenario, ego);
    let stage1 = stage1.run(replay_ego.as_mut());
    if let Some(reason) = installed.error() {
        return Err(HarnessError::Model { method, reason });
    }
    let models_time = installed.timings();
    let mut profile = VariantProfile {
        stage1_s: clock.elapsed().as_secs_f64(),
        stage1_features_s: models_time.features_s,
        stage1_decoder_s: models_time.decoder_s,
        stage1_feasibility_s: models_time.feasibility_s,
        ..VariantProfile::default()
    };
    let stage2_clock = Instant::now();
    let s1 = stage1.summary();
    let stage1_collision = s1.ego_collision.as_ref().is_some_and(|c| c.with_cbv);

    let mut stage2 = Simulation::new(scenario, config)?;
    let closed_loop = match request.stage2_cbv {
        Stage2Cbv::Replay => {
            stage2.set_policy(cbv, Box::new(LogReplay::new(track_from_rollout(scenario, &stage1, cbv))));
            None
        }
        Stage2Cbv::ClosedLoop => {
            Some(methods::install(&mut stage2, scenario, cbv, start, settings, models, maps, seed)?)
        }
    };
    let mut planner = request.planner.instantiate(scenario, ego);
    let stage2 = stage2.run(planner.as_mut());
    if let Some(reason) = closed_loop.and_then(|i| i.error()) {
        return Err(HarnessError::Model { method, reason });
    }
    profile.stage2_s = stage2_clock.elapsed().as_secs_f64();
    let witness_clock = Instant::now();
    let witness = match (stage1_collision, witness) {
        (true, Some(search)) => Some(search(scenario, &stage1)),
        _ => None,
    };
    profile.witness_s = witness_clock.elapsed().as_secs_f64();

    let (cbv_speeds_mps, cbv_accels_mps2) =
        speeds_and_accels(stage1.states.iter().map(|row| row[cbv.0].map(|s| s.speed_mps())), stage1.dt_s);
    let logged = scenario.track(cbv);
    let (logged_speeds_mps, logged_accels_mps2) =
        speeds_and_accels((start..=end).map(|k| logged.state(k).map(|s| s.speed_mps())), scenario.dt_s);
    Ok(VariantRecord {
        scenario: scenario.id.clone(),
        method,
        seed: seed_index,
        stage1_collision,
        stage2_collision: stage2.ego_collision().is_some(),
        witness,
        stage1_min_gap_m: s1.min_distance_to_ego_m,
        time_s: clock.elapsed().as_secs_f64(),
        profile,
        error: None,
        cbv_speeds_mps,
        cbv_accels_mps2,
        logged_speeds_mps,
        logged_accels_mps2,
    })
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
    let jobs: Vec<(usize, AdversaryMethod, u32)> = scenes
        .iter()
        .enumerate()
        .flat_map(|(i, _)| request.methods.iter().flat_map(move |&m| (0..request.seeds).map(move |s| (i, m, s))))
        .collect();
    let mut records: Vec<VariantRecord> = jobs
        .par_iter()
        .map(|&(i, method, seed)| {
            let scenario = &scenes[i];
            let r =
                run_one(scenario, method, seed, request, models, &maps, witness).unwrap_or_else(|e| VariantRecord {
                    scenario: scenario.id.clone(),
                    method,
                    seed,
                    stage1_collision: false,
                    stage2_collision: false,
                    witness: None,
                    stage1_min_gap_m: None,
                    time_s: 0.0,
                    profile: VariantProfile::default(),
                    error: Some(e.to_string()),
                    cbv_speeds_mps: vec![],
                    cbv_accels_mps2: vec![],
                    logged_speeds_mps: vec![],
                    logged_accels_mps2: vec![],
                });
            tick();
            r
        })
        .collect();
    records.sort_by(|a, b| (a.method, &a.scenario, a.seed).cmp(&(b.method, &b.scenario, b.seed)));
    records
}

/// One row per method, in the requested order.
pub fn table(records: &[VariantRecord], methods: &[AdversaryMethod]) -> Vec<MethodRow> {
    methods
        .iter()
        .map(|&method| {
            let all: Vec<&VariantRecord> = records.iter().filter(|r| r.method == method).collect();
            let ok: Vec<&VariantRecord> = all.iter().copied().filter(|r| r.error.is_none()).collect();
            let n = ok.len().max(1) as f64;
            let share = |f: &dyn Fn(&VariantRecord) -> bool, of: &[&VariantRecord]| -> Option<f64> {
                (!of.is_empty()).then(|| of.iter().filter(|r| f(r)).count() as f64 / of.len() as f64)
            };
            let critical: Vec<&VariantRecord> = ok.iter().copied().filter(|r| r.stage1_collision).collect();
            let searched: Vec<&VariantRecord> = critical.iter().copied().filter(|r| r.witness.is_some()).collect();
            let mut hist =
                [Histogram::speed(), Histogram::speed(), Histogram::acceleration(), Histogram::acceleration()];
            for r in &ok {
                r.cbv_speeds_mps.iter().for_each(|v| hist[0].add(*v));
                r.logged_speeds_mps.iter().for_each(|v| hist[1].add(*v));
                r.cbv_accels_mps2.iter().for_each(|v| hist[2].add(*v));
                r.logged_accels_mps2.iter().for_each(|v| hist[3].add(*v));
            }
            let mut profile = VariantProfile::default();
            for r in &ok {
                profile.add(&r.profile);
            }
            MethodRow {
                profile: profile.scaled(1.0 / n),
                method,
                variants: all.len(),
                errors: all.len() - ok.len(),
                cr: ok.iter().filter(|r| r.stage1_collision).count() as f64 / n,
                sr: ok.iter().filter(|r| !r.stage2_collision).count() as f64 / n,
                sr_critical: share(&|r| !r.stage2_collision, &critical),
                witness_rate: share(&|r| r.witness == Some(true), &searched),
                vj: jensen_shannon(&hist[0], &hist[1]),
                aj: jensen_shannon(&hist[2], &hist[3]),
                time_per_variant_s: (ok.iter().map(|r| r.time_s).sum::<f64>() + 0.0) / n,
            }
        })
        .collect()
}
