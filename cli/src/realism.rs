//! `safer realism --scenes DIR`: the Waymo Sim Agents (WOSAC 2025) realism
//! metrics of a traffic policy on recorded scenes. Each scene is rolled out
//! `--rollouts` times with every agent present at the window's start driven
//! by the policy (no ego planner: WOSAC simulates the ego too), scored with
//! `eval::realism`, and summarised per source format and overall.
//!
//! Scenes run in parallel; each scene's result depends only on the scene,
//! the policy and the seed, and results are sorted by scenario id, so the
//! output does not depend on the thread count.

use super::*;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use super::{CliError, scene_paths};
use safer_scenarios::eval::realism::{RealismAggregate, RealismConfig, RealismWindow, ScenarioRealism, score_scenario};
use safer_scenarios::harness::evaluation::held_out_scenes;
use safer_scenarios::harness::variant::variant_seed;
use safer_scenarios::models::prior::{PriorVariant, RealismPrior};
use safer_scenarios::policies::prior_sampling::{
    PriorAgent, PriorTraffic, ScenarioMapEncoding, TokenSampling, decode_rollouts_together,
};
use safer_scenarios::policies::{AgentPolicy, BackgroundPolicy};
use safer_scenarios::scenario::{Scenario, SourceFormat, import};
use safer_scenarios::sim::traffic::{simulate_all_agents, simulate_rollouts_in_lockstep};
use safer_scenarios::spec::spec_name;

/// The rule that picks each scene's window, for the help text and reports.
pub const WINDOW_RULE: &str = "80 future steps (8 s) from the scene's current step when it has at least \
10 steps of history and 80 of future (WOMD: current step 10 of 91); otherwise the window whose current \
step is step 10 (1.0 s of history, 8 s of future) when the scene has at least 91 steps (NGSIM, \
Argoverse 2); shorter scenes are skipped";

/// The window rule as `safer realism --help` prints it.
pub const WINDOW_RULE_HELP: &str = "Window: 80 future steps (8 s) from the scene's current step when it has at least \
10 steps of history and 80 of future (WOMD: current step 10 of 91); otherwise the window whose current \
step is step 10 (1.0 s of history, 8 s of future) when the scene has at least 91 steps (NGSIM, \
Argoverse 2); shorter scenes are skipped. Every agent valid at the window's current step is simulated \
and evaluated; agents appearing later replay the log and are not scored.";

/// Who drives the agents in the realism rollouts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RealismPolicy {
    /// Keep speed and heading from the start state.
    ConstantVelocity,
    /// Replay the recorded trajectories (an upper reference, not a policy).
    LogReplay,
    /// Follow the lane, brake for leaders and red lights (IDM).
    Idm,
    /// The learned realism prior (differential attention), sampled top-k.
    Prior,
    /// The plain-attention prior (the `no-mda` ablation), sampled top-k.
    PriorPlain,
}

impl RealismPolicy {
    /// The learned prior this policy samples, if it is one.
    fn prior_variant(self) -> Option<PriorVariant> {
        match self {
            Self::Prior => Some(PriorVariant::Differential),
            Self::PriorPlain => Some(PriorVariant::Plain),
            Self::ConstantVelocity | Self::LogReplay | Self::Idm => None,
        }
    }

    /// Loads what the policy needs, failing early with the model's error.
    fn load(self) -> Result<Option<Arc<RealismPrior>>, CliError> {
        self.prior_variant()
            .map(|v| RealismPrior::load(&safer_scenarios::models::ModelSource::shipped(), v).map(Arc::new))
            .transpose()
            .map_err(CliError::from)
    }
}

/// Arguments of `safer realism`.
#[derive(Debug, Clone)]
pub struct RealismRequest {
    /// Folder (searched recursively) or file of scenes.
    pub scenes: PathBuf,
    /// Rollouts per scene.
    pub rollouts: usize,
    /// JSON report path.
    pub json: Option<PathBuf>,
    /// The policy.
    pub policy: RealismPolicy,
    /// Base seed.
    pub seed: u64,
    /// Score at most this many scenes (the first by file path, then id).
    pub max_scenes: Option<usize>,
    /// How the prior policies draw their tokens.
    pub sampling: TokenSampling,
}

/// The token sampling of `policy` from the command line's `--top-k` and
/// `--temperature`: the defaults where they are not given, and an error
/// where they are given to a policy that draws no tokens (they would be
/// silently ignored).
pub fn sampling_for(
    policy: RealismPolicy,
    top_k: Option<usize>,
    temperature: Option<f64>,
) -> Result<TokenSampling, CliError> {
    if policy.prior_variant().is_none() && (top_k.is_some() || temperature.is_some()) {
        return Err(CliError::Usage(format!(
            "--top-k and --temperature apply to the prior policies (prior, prior-plain), not to `{}`",
            spec_name(&policy)
        )));
    }
    let default = TokenSampling::default();
    Ok(TokenSampling { top_k: top_k.unwrap_or(default.top_k), temperature: temperature.unwrap_or(default.temperature) })
}

/// The aggregates a run reports: over all its scenes, per source format,
/// and held out against the rest.
#[derive(Debug, Serialize)]
struct RealismSummary {
    overall: RealismAggregate,
    by_format: BTreeMap<SourceFormat, RealismAggregate>,
    held_out: HeldOutRealism,
}

/// The aggregates of the held-out scenes (every tenth by id) and of the
/// rest.
#[derive(Debug, Serialize)]
struct HeldOutRealism {
    /// How many scenes were held out (scored or not).
    held_out_scenes: usize,
    held_out: RealismAggregate,
    rest: RealismAggregate,
}

/// A scene that was not scored, and why.
#[derive(Debug, Clone, Serialize)]
struct Skipped {
    scenario: String,
    path: PathBuf,
    reason: String,
    /// Whether it is an error (as opposed to a scene too short for the window).
    error: bool,
}

#[derive(Debug, Serialize)]
struct Report<'a> {
    policy: RealismPolicy,
    /// The prior policies' draw: among the `top_k` likeliest tokens at
    /// `temperature` (absent for the other policies).
    top_k: Option<usize>,
    temperature: Option<f64>,
    rollouts: usize,
    seed: u64,
    window_rule: &'static str,
    config: &'a RealismConfig,
    #[serde(flatten)]
    summary: RealismSummary,
    scenes: &'a [ScenarioRealism],
    skipped: &'a [Skipped],
    wall_s: f64,
    /// Mean time of one scene (all rollouts and scoring) on one thread, s.
    mean_scene_s: f64,
    /// Of it, the rollouts (the policy driving every agent), s.
    mean_rollouts_s: f64,
    /// Of it, the scoring (the metrics' features and likelihoods), s.
    mean_scoring_s: f64,
}

/// Where one scene's time went, s.
#[derive(Debug, Clone, Copy, Default)]
struct SceneTimes {
    rollouts_s: f64,
    scoring_s: f64,
}

impl SceneTimes {
    fn total_s(&self) -> f64 {
        self.rollouts_s + self.scoring_s
    }
}

/// Rolls out and scores one scene.
fn score_one(
    scenario: &Scenario,
    args: &RealismRequest,
    config: &RealismConfig,
    prior: Option<&Arc<RealismPrior>>,
) -> Result<Option<(ScenarioRealism, SceneTimes)>, String> {
    let Some(window) = RealismWindow::for_scenario(scenario, config.future_steps) else {
        return Ok(None);
    };
    let started = Instant::now();
    // The prior's per-scene inputs: the map encoded once for all rollouts.
    let prior = match prior {
        Some(p) => {
            let map = ScenarioMapEncoding::new(p, scenario).map_err(|e| e.to_string())?;
            Some((p.clone(), Arc::new(scenario.clone()), map))
        }
        None => None,
    };
    let start = window.start_step;
    let members: Vec<usize> =
        (0..scenario.tracks.len()).filter(|&i| scenario.tracks[i].state(start).is_some()).collect();
    let rollouts = match &prior {
        // The prior's rollouts run side by side, so each token boundary
        // decodes every rollout's agents in one set of full batches.
        Some((p, shared, map)) => {
            let traffics: Vec<_> = (0..args.rollouts)
                .map(|r| {
                    let seed = variant_seed(args.seed, &scenario.id, r as u32);
                    PriorTraffic::new(
                        p.clone(),
                        shared.clone(),
                        map.clone(),
                        start,
                        members.clone(),
                        args.sampling,
                        seed,
                    )
                })
                .collect();
            let rollouts = simulate_rollouts_in_lockstep(
                scenario,
                start,
                window.end_step(),
                args.rollouts,
                |r, _| -> Box<dyn AgentPolicy> { Box::new(PriorAgent::new(traffics[r].clone())) },
                |worlds| decode_rollouts_together(&traffics, worlds),
            )
            .map_err(|e| e.to_string())?;
            for t in &traffics {
                if let Some(e) = t.lock().unwrap_or_else(|p| p.into_inner()).error() {
                    return Err(format!("prior inference failed: {e}"));
                }
            }
            rollouts
        }
        None => {
            let mut rollouts = Vec::with_capacity(args.rollouts);
            for _ in 0..args.rollouts {
                let states = simulate_all_agents(scenario, start, window.end_step(), |agent| match args.policy {
                    RealismPolicy::ConstantVelocity => BackgroundPolicy::ConstantVelocity.instantiate(scenario, agent),
                    RealismPolicy::Idm => BackgroundPolicy::Idm.instantiate(scenario, agent),
                    _ => BackgroundPolicy::LogReplay.instantiate(scenario, agent),
                })
                .map_err(|e| e.to_string())?;
                rollouts.push(states);
            }
            rollouts
        }
    };
    let rolled_out = Instant::now();
    let scored = score_scenario(scenario, window, &rollouts, config).map_err(|e| e.to_string())?;
    let times =
        SceneTimes { rollouts_s: (rolled_out - started).as_secs_f64(), scoring_s: rolled_out.elapsed().as_secs_f64() };
    Ok(Some((scored, times)))
}

pub(super) fn run(args: &RealismRequest) -> Result<ExitCode, CliError> {
    if let Some(out) = &args.json {
        super::check_json_report(out)?;
    }
    let prior = args.policy.load()?;
    if args.rollouts == 0 {
        // The command line refuses 0 already; this guards other callers.
        return Err(CliError::Usage("--rollouts must be at least 1".to_string()));
    }
    let config = RealismConfig::wosac_2025();
    let mut paths = scene_paths(&args.scenes)?;
    if let Some(n) = args.max_scenes {
        paths.truncate(n);
    }
    let started = Instant::now();
    let loaded: Vec<(PathBuf, Result<Vec<Scenario>, String>)> =
        paths.par_iter().map(|p| (p.clone(), import::load(p).map_err(|e| e.to_string()))).collect();
    let mut skipped = Vec::new();
    let mut scenes: Vec<(PathBuf, Scenario)> = Vec::new();
    for (path, r) in loaded {
        match r {
            Ok(list) => scenes.extend(list.into_iter().map(|s| (path.clone(), s))),
            Err(reason) => skipped.push(Skipped { scenario: String::new(), path, reason, error: true }),
        }
    }
    scenes.sort_by(|a, b| a.1.id.cmp(&b.1.id).then_with(|| a.0.cmp(&b.0)));
    if let Some(n) = args.max_scenes {
        scenes.truncate(n);
    }
    let progress = super::progress::Progress::new("realism", "scenes", scenes.len());
    let scored: Vec<Result<Option<(ScenarioRealism, SceneTimes)>, String>> = scenes
        .par_iter()
        .map(|(_, s)| {
            let scored = score_one(s, args, &config, prior.as_ref());
            progress.tick();
            scored
        })
        .collect();
    drop(progress);
    let wall_s = started.elapsed().as_secs_f64();
    let mut results = Vec::new();
    let mut busy = SceneTimes::default();
    for ((path, scenario), r) in scenes.iter().zip(scored) {
        match r {
            Ok(Some((result, times))) => {
                busy.rollouts_s += times.rollouts_s;
                busy.scoring_s += times.scoring_s;
                results.push(result);
            }
            Ok(None) => skipped.push(Skipped {
                scenario: scenario.id.clone(),
                path: path.clone(),
                reason: format!("{} steps: too short for the window", scenario.num_steps()),
                error: false,
            }),
            Err(reason) => {
                skipped.push(Skipped { scenario: scenario.id.clone(), path: path.clone(), reason, error: true })
            }
        }
    }
    let per_scene = |busy_s: f64| if results.is_empty() { 0.0 } else { busy_s / results.len() as f64 };
    let mean = SceneTimes { rollouts_s: per_scene(busy.rollouts_s), scoring_s: per_scene(busy.scoring_s) };
    let mut formats: BTreeMap<SourceFormat, Vec<&ScenarioRealism>> = BTreeMap::new();
    for r in &results {
        formats.entry(r.format).or_default().push(r);
    }
    let by_format: BTreeMap<SourceFormat, RealismAggregate> =
        formats.into_iter().map(|(f, rs)| (f, RealismAggregate::mean(rs, &config))).collect();
    let overall = RealismAggregate::mean(&results, &config);
    // Every tenth scene by id, as `evaluate`, `prior-fit` and
    // `trust-region` hold out of the same folder.
    let held_out_ids = held_out_scenes(scenes.iter().map(|(_, s)| s.id.as_str()));
    let (held, rest): (Vec<&ScenarioRealism>, Vec<&ScenarioRealism>) =
        results.iter().partition(|r| held_out_ids.contains(&r.scenario_id));
    let split = HeldOutRealism {
        held_out_scenes: held_out_ids.len(),
        held_out: RealismAggregate::mean(held, &config),
        rest: RealismAggregate::mean(rest, &config),
    };
    let summary = RealismSummary { by_format, overall, held_out: split };
    let mut table = super::table_writer(args.json.as_deref());
    print_table(&mut table, args, &summary, &skipped, mean, wall_s)?;
    table.flush()?;
    if let Some(out) = &args.json {
        let draws = args.policy.prior_variant().is_some();
        let report = Report {
            policy: args.policy,
            top_k: draws.then_some(args.sampling.top_k),
            temperature: draws.then_some(args.sampling.temperature),
            rollouts: args.rollouts,
            seed: args.seed,
            window_rule: WINDOW_RULE,
            config: &config,
            summary,
            scenes: &results,
            skipped: &skipped,
            wall_s,
            mean_scene_s: mean.total_s(),
            mean_rollouts_s: mean.rollouts_s,
            mean_scoring_s: mean.scoring_s,
        };
        write_json(out, &report)?;
    }
    Ok(if skipped.iter().any(|s| s.error) { ExitCode::from(1) } else { ExitCode::SUCCESS })
}

/// Writes the report by the rules of [`safer_scenarios::record::output`], creating
/// the folder of a file path first.
fn write_json(path: &Path, report: &Report<'_>) -> Result<(), CliError> {
    safer_scenarios::record::create_parent_folder(path)?;
    super::write_json_report(path, report)
}

/// The prior's sampling for the table's title where it is not the default.
fn sampling_note(args: &RealismRequest) -> String {
    if args.policy.prior_variant().is_none() || args.sampling == TokenSampling::default() {
        return String::new();
    }
    format!(" (top-{}, temperature {})", args.sampling.top_k, args.sampling.temperature)
}

/// The human-readable table (on stdout, or stderr when the JSON report
/// takes stdout); scenes that failed go to stderr.
fn print_table(
    out: &mut dyn Write,
    args: &RealismRequest,
    summary: &RealismSummary,
    skipped: &[Skipped],
    mean: SceneTimes,
    wall_s: f64,
) -> std::io::Result<()> {
    writeln!(
        out,
        "WOSAC 2025 realism, policy {}{}, {} rollouts per scene, seed {}",
        spec_name(&args.policy),
        sampling_note(args),
        args.rollouts,
        args.seed
    )?;
    writeln!(
        out,
        "{:<12} {:>6} {:>10} {:>12} {:>10} {:>8} {:>8} {:>10} {:>9}",
        "format", "scenes", "kinematic", "interactive", "map-based", "meta", "minADE", "collision", "off-road"
    )?;
    let cell = |v: Option<f64>, digits: usize| v.map_or("-".to_string(), |x| format!("{x:.digits$}"));
    let row = |out: &mut dyn Write, name: &str, a: &RealismAggregate| {
        writeln!(
            out,
            "{:<12} {:>6} {:>10} {:>12} {:>10} {:>8} {:>8} {:>10} {:>9}",
            name,
            a.scenarios,
            cell(a.buckets.kinematic, 4),
            cell(a.buckets.interactive, 4),
            cell(a.buckets.map_based, 4),
            cell(a.meta_metric, 4),
            cell(a.min_average_displacement_error_m, 2),
            cell(a.simulated_collision_rate, 3),
            cell(a.simulated_offroad_rate, 3),
        )
    };
    for (format, a) in &summary.by_format {
        row(out, &spec_name(format), a)?;
    }
    row(out, "overall", &summary.overall)?;
    row(out, "held out", &summary.held_out.held_out)?;
    row(out, "the rest", &summary.held_out.rest)?;
    writeln!(out, "held out: every tenth scene by id ({} scenes)", summary.held_out.held_out_scenes)?;
    let short = skipped.iter().filter(|s| !s.error).count();
    let failed: Vec<&Skipped> = skipped.iter().filter(|s| s.error).collect();
    if short > 0 {
        writeln!(out, "{short} scenes too short for the window, skipped")?;
    }
    for s in &failed {
        match s.scenario.as_str() {
            // A file that did not load: its import error names it.
            "" => eprintln!("error: {}", s.reason),
            scenario => eprintln!("error: {} {scenario}: {}", s.path.display(), s.reason),
        }
    }
    writeln!(
        out,
        "{:.2} s per scene on one thread ({} rollouts {:.2} s, scoring {:.2} s); {wall_s:.1} s wall",
        mean.total_s(),
        args.rollouts,
        mean.rollouts_s,
        mean.scoring_s,
    )?;
    Ok(())
}

/// The arguments of `safer realism`.
#[derive(Debug, clap::Args)]
pub(crate) struct RealismArgs {
    /// Folder of scenario files (searched recursively), or one file; `data:REL` is in $SAFER_DATA_DIR.
    #[arg(long, value_parser = data_path)]
    pub(crate) scenes: PathBuf,
    /// Rollouts per scene (WOSAC: 32), at least 1.
    #[arg(long, default_value_t = 32, value_parser = at_least_one())]
    pub(crate) rollouts: usize,
    /// Also write a JSON report (per scene and aggregates) to this file (`-`: standard output).
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub(crate) json: Option<PathBuf>,
    /// Policy driving every agent present at the window's start (default: the shipped realism prior).
    #[arg(long, value_enum, default_value_t = realism::RealismPolicy::Prior)]
    pub(crate) policy: realism::RealismPolicy,
    /// Base seed (per-rollout seeds derive from it, the scenario id and the rollout index).
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    /// Score at most this many scenes (at least 1).
    #[arg(long, value_name = "N", value_parser = at_least_one())]
    pub(crate) max_scenes: Option<usize>,
    /// The prior policies draw each token among this many most likely ones (default 10), from 1 to the vocabulary size.
    #[arg(long, value_name = "K", value_parser = RangedU64ValueParser::<usize>::new().range(1..=VOCABULARY_SIZE as u64))]
    pub(crate) top_k: Option<usize>,
    /// Softmax temperature of the prior policies' draw (default 1: the model's distribution; lower is greedier), positive and finite.
    #[arg(long, value_parser = positive_finite)]
    pub(crate) temperature: Option<f64>,
}

/// Runs `safer realism`.
pub(crate) fn command(args: RealismArgs) -> Result<ExitCode, CliError> {
    let RealismArgs { scenes, rollouts, json, policy, seed, max_scenes, top_k, temperature } = args;
    sampling_for(policy, top_k, temperature)
        .and_then(|sampling| run(&RealismRequest { scenes, rollouts, json, policy, seed, max_scenes, sampling }))
}
