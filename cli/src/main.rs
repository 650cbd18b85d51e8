//! The `safer` command line: argument parsing and the commands, each in its
//! own module. Commands print human-readable tables by default and JSON
//! with `--json`; errors go to stderr with the file and place at fault.
//!
//! Arguments are checked by clap before a command starts: counts that must
//! be at least one, the trust region within the token vocabulary, durations
//! positive and finite; a bad number is refused naming the flag and the
//! accepted range, never clamped. Paths written `data:REL` name `REL` in the
//! recorded-data folder `$SAFER_DATA_DIR`, and `safer:REL` a file safer
//! ships, by the rule specs use ([`spec::paths`]); the data defaults are
//! written that way. Every output path goes through
//! [`record::write_output`] (`-` is standard output, symlinks followed,
//! devices written in place, folders refused).
//!
//! [`spec::paths`]: safer_scenarios::spec::paths
//! [`record::write_output`]: safer_scenarios::record::write_output

mod bench;
mod bench_baseline;
mod bench_models;
mod choice;
mod evaluate;
mod feasibility_dataset;
mod feasibility_eval;
mod inspect;
mod prior_dataset;
mod prior_fit;
mod progress;
mod realism;
mod render;
mod run;
mod schema;
mod simulate;
mod token_roundtrip;
mod trust_region;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use choice::choice;
use clap::builder::{RangedU64ValueParser, TypedValueParser};
use clap::{Parser, Subcommand};

use safer_scenarios::harness::HarnessError;
use safer_scenarios::harness::evaluation::ArtefactVariants;
use safer_scenarios::harness::evaluation::Stage2Cbv;
use safer_scenarios::harness::methods::BackgroundDriver;
use safer_scenarios::models::ModelError;
use safer_scenarios::motion::tokens::VOCABULARY_SIZE;
use safer_scenarios::planners::BuiltinPlanner;
use safer_scenarios::record::RecordError;
use safer_scenarios::scenario::import::ImportError;
use safer_scenarios::sim::SimError;
use safer_scenarios::spec::SpecError;
use safer_scenarios::spec::planner::PlannerAdapter;
use safer_scenarios::spec::suite::AdversaryMethod;

/// How `data:` paths and output paths are read, for `safer --help`.
const PATHS_HELP: &str = "Paths: `data:REL` names REL in the recorded-data folder $SAFER_DATA_DIR, and `safer:REL` \
a file safer ships (scenes/, specs/, planners/), as in specs. An output path of `-` is \
standard output; a symlink is followed (the file it names is replaced atomically, the link stays); a FIFO or \
character device is written in place; a folder is refused.";

/// Scenario tests for autonomous-driving planners: safety-critical,
/// realistic and avoidable conflicts (SaFeR).
#[derive(Debug, Parser)]
#[command(name = "safer", version, about, after_help = PATHS_HELP)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

// Parsed once per process: a variant's size costs nothing, and boxing
// the evaluation's options would only complicate clap's derive.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
enum Command {
    /// Run scenario suites: the same variants, metrics and verdicts as a planner crate's `cargo test`.
    Run(run::RunArgs),
    /// Dual-stage evaluation of adversary methods: CR, SR, SR on critical variants, witness rate, VJ, AJ, YJ.
    Evaluate(evaluate::EvaluateArgs),
    /// Merge the JSON reports of `safer evaluate --partition K/N` runs into the table and report one run would give.
    EvaluateMerge(evaluate::EvaluateMergeArgs),
    /// Draw a scenario (a recorded file or a scenario spec YAML) as an SVG picture.
    Render(render::RenderArgs),
    /// Summarise a scenario file: format, id, agents by type, steps, map, ego and CBV.
    Inspect(inspect::InspectArgs),
    /// Run closed-loop rollouts: the ego driven by a planner, the others by a background policy.
    Simulate(simulate::SimulateArgs),
    /// Print the JSON Schema of a spec kind (for editors: yaml-language-server `$schema`).
    Schema(schema::SchemaArgs),
    /// WOSAC 2025 realism metrics of a traffic policy: roll out every agent of each scene N times and score the rollouts against the log.
    #[command(after_help = realism::WINDOW_RULE_HELP)]
    Realism(realism::RealismArgs),
    /// What the realism prior's trust region offers the adversary: per method, the probability mass of the tokens of its region (the top n, or the n likeliest distinct behaviours for `safer-distinct` and `safer-in-path`), their acceleration and yaw-rate range, distinct behaviours and plausible share, at the CBV's token boundaries of stage 1.
    TrustRegion(trust_region::TrustRegionArgs),
    /// Benchmarks: import time per scene per format, simulator steps per second, one SaFeR variant and its witness search; each beside its reference.
    Bench(bench::BenchArgs),
    /// Measure the log → token → log round trip (ADE/FDE) over recorded scenes.
    TokenRoundtrip(token_roundtrip::TokenRoundtripArgs),
    /// [model tools] Write the realism prior's training shards (NGSIM scenes + calibrated synthetic traffic).
    PriorDataset(prior_dataset::PriorDatasetArgs),
    /// [model tools] How well the realism prior predicts recorded driving: NLL, top-1 and how often the recorded token is in the top n, at every token boundary of every moving vehicle, with the history ending at the boundary (as in closed loop) and one step late (a probe of whether the prior reads the start of the token it predicts).
    PriorFit(prior_fit::PriorFitArgs),
    /// [model tools] Write the feasibility value's training transitions (NGSIM + synthetic, several ego and CBV policies).
    FeasibilityDataset(feasibility_dataset::FeasibilityDatasetArgs),
    /// [model tools] Accuracy of the shipped V_h against the witness search on held-out states, V_h latency, and the LFR picture.
    FeasibilityEval(feasibility_eval::FeasibilityEvalArgs),
    /// [model tools] Latency of the learned models in tract (map encoding, CBV query, full-scene step), against onnxruntime/PyTorch.
    BenchModels(bench_models::BenchModelsArgs),
}

/// Errors the commands report.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// A scenario could not be imported.
    #[error(transparent)]
    Import(#[from] ImportError),
    /// A rollout could not be set up.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// Writing output failed.
    #[error("cannot write output: {0}")]
    Output(#[from] std::io::Error),
    /// Serialising JSON failed.
    #[error("cannot serialise JSON: {0}")]
    Json(#[from] serde_json::Error),
    /// A folder held no scenario files.
    #[error("{0}: no scenario files found (looked for .tfrecord, .json, .xml, Argoverse 2 folders)")]
    NoScenes(PathBuf),
    /// A spec file could not be loaded (printed as a report with the YAML snippet).
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// A suite variant could not be run.
    #[error(transparent)]
    Harness(#[from] HarnessError),
    /// An artefact could not be written.
    #[error(transparent)]
    Record(#[from] RecordError),
    /// A learned model could not be loaded or run.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The `--baseline` build of `safer bench` could not be run or read.
    #[error("--baseline {}: {problem}", binary.display())]
    Baseline {
        /// The baseline's binary, as given.
        binary: PathBuf,
        /// What went wrong, in words.
        problem: String,
    },
    /// The arguments ask for something that cannot be done.
    #[error("{0}")]
    Usage(String),
}

/// Runs the command line; returns the process exit code.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(args) => run::command(args),
        Command::Evaluate(args) => evaluate::command(args),
        Command::EvaluateMerge(args) => evaluate::merge_command(args),
        Command::Render(args) => render::command(args),
        Command::Inspect(args) => inspect::command(args),
        Command::Simulate(args) => simulate::command(args),
        Command::Schema(args) => schema::command(args),
        Command::Realism(args) => realism::command(args),
        Command::TrustRegion(args) => trust_region::command(args),
        Command::Bench(args) => bench::command(args),
        Command::TokenRoundtrip(args) => token_roundtrip::command(args),
        Command::PriorDataset(args) => prior_dataset::command(args),
        Command::PriorFit(args) => prior_fit::command(args),
        Command::FeasibilityDataset(args) => feasibility_dataset::command(args),
        Command::FeasibilityEval(args) => feasibility_eval::command(args),
        Command::BenchModels(args) => bench_models::command(args),
    };
    match result {
        Ok(code) => code,
        // A spec error reads best as the report with the offending YAML line.
        Err(CliError::Spec(e)) => {
            eprintln!("{}", e.render(std::io::IsTerminal::is_terminal(&std::io::stderr())));
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("{}", error_report(&e));
            ExitCode::from(2)
        }
    }
}

/// `error: MESSAGE` and, one per line, each cause the message does not
/// already include (the sources carried by the error enums).
fn error_report(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = format!("error: {e}");
    let mut source = e.source();
    while let Some(cause) = source {
        let line = cause.to_string();
        if !text.contains(&line) {
            text.push_str("\n  caused by: ");
            text.push_str(&line);
        }
        source = cause.source();
    }
    text
}

/// A command-line path: `data:REL` is `REL` in the shared recorded-data
/// folder, by the rule of [`safer_scenarios::spec::paths`] for the project this
/// binary was built from; anything else is taken as written.
/// Checks, before a command runs, that `--json PATH` can take its report:
/// a file, `-` or a device ([`safer_scenarios::record::output::check_output`]), and
/// not an existing file of another kind than JSON.
fn check_json_report(path: &Path) -> Result<(), CliError> {
    safer_scenarios::record::output::check_output(path)?;
    safer_scenarios::record::check_replaceable("--json", path, safer_scenarios::record::OutputKind::Json, false)?;
    Ok(())
}

/// Writes `report` as pretty JSON to `path` (`-`: standard output); the
/// command checked the path with [`check_json_report`] before it ran.
fn write_json_report(path: &Path, report: &impl serde::Serialize) -> Result<(), CliError> {
    safer_scenarios::record::write_output(path, (serde_json::to_string_pretty(report)? + "\n").as_bytes())?;
    Ok(())
}

/// Parses a scene path: `data:REL` and `safer:REL` resolved as in specs,
/// anything else as written; a path that does not exist is refused here,
/// naming it, before any command runs.
fn data_path(written: &str) -> Result<PathBuf, String> {
    let path = if written.starts_with("data:") || written.starts_with("safer:") {
        safer_scenarios::spec::paths::resolve_checked(safer_scenarios::spec::paths::shipped_dir(), written)?
    } else {
        PathBuf::from(written)
    };
    if !path.exists() {
        return Err(format!(
            "no such file or folder: {}{}",
            path.display(),
            safer_scenarios::spec::paths::missing_hint(written)
        ));
    }
    Ok(path)
}

/// Parses `--planner`: a built-in's name, else a planner spec file.
fn planner_arg(written: &str) -> Result<PlannerAdapter, String> {
    if let Ok(builtin) =
        BuiltinPlanner::ALL.iter().copied().find(|b| safer_scenarios::spec::spec_name(b) == written).ok_or(())
    {
        return Ok(PlannerAdapter::builtin(builtin));
    }
    let path = Path::new(written);
    if !path.exists() {
        return Err(format!(
            "`{written}` is neither a built-in planner (log-replay, constant-velocity, idm, evasive) nor a planner spec file"
        ));
    }
    PlannerAdapter::load(path).map_err(|e| e.to_string())
}

/// Most worker threads `--jobs` takes: `--jobs 10000` turned a 0.2 s suite
/// into more than a minute at a load of about 1000.
const MAX_JOBS: usize = 256;

/// Sets the number of rayon worker threads (`--jobs`).
fn set_jobs(jobs: Option<usize>) -> Result<(), CliError> {
    let Some(n) = jobs else { return Ok(()) };
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build_global()
        .map_err(|e| CliError::Usage(format!("--jobs {n}: could not set up the worker threads: {e}")))
}

/// A list of fault operators, as `--mutants` takes it.
#[derive(Debug, Clone)]
pub(crate) struct FaultOperators(pub(crate) Vec<safer_scenarios::planners::FaultOperator>);

/// `no-brake,late` or `all`.
fn fault_operators(text: &str) -> Result<FaultOperators, String> {
    safer_scenarios::planners::FaultOperator::parse_list(text).map(FaultOperators)
}

/// Parses a count that must be at least 1 (clap names the flag and the
/// range when it is not).
fn at_least_one() -> impl TypedValueParser<Value = usize> {
    RangedU64ValueParser::<usize>::new().range(1..)
}

/// Parses a number written for a flag that accepts `range` (as in
/// `0 < x < inf`): the value `accept` keeps, or a message naming the range
/// and then `why` (what follows the range in it, such as its unit).
fn number_in(written: &str, range: &str, why: &str, accept: impl FnOnce(f64) -> Option<f64>) -> Result<f64, String> {
    let v: f64 = written.trim().parse().map_err(|_| format!("`{written}` is not a number; expected {range}"))?;
    accept(v).ok_or_else(|| format!("{v} is outside the accepted range {range}{why}"))
}

/// Parses a positive, finite number (durations, distances).
fn positive_finite(written: &str) -> Result<f64, String> {
    number_in(written, "0 < x < inf", " (a positive, finite number)", |v| (v.is_finite() && v > 0.0).then_some(v))
}

/// Parses a non-negative, finite number (speeds, thresholds).
fn non_negative_finite(written: &str) -> Result<f64, String> {
    number_in(written, "0 <= x < inf", " (a non-negative, finite number)", |v| (v.is_finite() && v >= 0.0).then_some(v))
}

/// A mean to `decimals` places for a table, `—` where there is none.
fn figure(value: Option<f64>, decimals: usize) -> String {
    value.map_or("—".into(), |v| format!("{v:.decimals$}"))
}

/// Writes a command's JSON report to `json` (if asked) and its table
/// (`print`) to standard output, or to standard error when the report
/// takes standard output. A report file is written before the table: a
/// reader that closes standard output early (`| head`) must not cost the
/// run its report, and a closed pipe ends the table quietly.
fn write_report_and_table(
    json: Option<&Path>,
    report: &impl serde::Serialize,
    print: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
) -> Result<(), CliError> {
    let report_text = || serde_json::to_string_pretty(report).map(|t| t + "\n");
    if let Some(path) = json.filter(|p| !safer_scenarios::record::is_stdout(p)) {
        safer_scenarios::record::write_output(path, report_text()?.as_bytes())?;
        eprintln!("wrote {}", path.display());
    }
    let mut table = table_writer(json);
    match print(&mut table).and_then(|()| table.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other?,
    }
    if let Some(path) = json.filter(|p| safer_scenarios::record::is_stdout(p)) {
        safer_scenarios::record::write_output(path, report_text()?.as_bytes())?;
    }
    Ok(())
}

/// Where a command's human-readable table goes: standard output, or
/// standard error when the JSON report takes standard output (`--json -`),
/// so the JSON stays parseable.
fn table_writer(json: Option<&Path>) -> Box<dyn std::io::Write> {
    if json.is_some_and(safer_scenarios::record::is_stdout) {
        Box::new(std::io::stderr().lock())
    } else {
        Box::new(std::io::stdout().lock())
    }
}

/// Scenario files under `path` (or `path` itself when it is a file).
fn scene_paths(path: &std::path::Path) -> Result<Vec<PathBuf>, CliError> {
    if let Err(e) = std::fs::metadata(path) {
        return Err(CliError::Usage(format!("{}: no such file or folder ({e})", path.display())));
    }
    let is_av2_folder = safer_scenarios::scenario::import::argoverse2::find_scenario_files(path).is_ok();
    if path.is_dir() && !is_av2_folder {
        let found = safer_scenarios::scenario::import::discover(path)?;
        if found.is_empty() {
            return Err(CliError::NoScenes(path.to_path_buf()));
        }
        Ok(found)
    } else {
        Ok(vec![path.to_path_buf()])
    }
}
