//! The `safer` command line: argument parsing and the commands, each in its
//! own module. Commands print human-readable tables by default and JSON
//! with `--json`; errors go to stderr with the file and place at fault.

mod bench;
mod bench_models;
mod evaluate;
mod feasibility_dataset;
mod feasibility_eval;
mod inspect;
mod prior_dataset;
mod realism;
mod render;
mod run;
mod schema;
mod simulate;
mod token_roundtrip;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use crate::harness::HarnessError;
use crate::harness::evaluation::{EvaluationRequest, Stage2Cbv};
use crate::harness::methods::BackgroundDriver;
use crate::spec::suite::AdversaryMethod;
use crate::planners::BuiltinPlanner;
use crate::policies::BackgroundPolicy;
use crate::record::RecordError;
use crate::scenario::import::ImportError;
use crate::sim::SimError;
use crate::spec::{SpecError, SpecKind};

/// Scenario tests for autonomous-driving planners: safety-critical,
/// realistic and avoidable conflicts (SaFeR).
#[derive(Debug, Parser)]
#[command(name = "safer", version, about)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Summarise a scenario file: format, id, agents by type, steps, map, ego and CBV.
    Inspect {
        /// A WOMD .tfrecord or .json, CommonRoad .xml, or Argoverse 2 .parquet / folder.
        file: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Run closed-loop rollouts: the ego driven by a planner, the others by a background policy.
    Simulate {
        /// A scenario file, or a folder searched recursively for scenario files.
        path: PathBuf,
        /// Planner driving the ego.
        #[arg(long, value_enum, default_value_t = BuiltinPlanner::Idm)]
        planner: BuiltinPlanner,
        /// Policy driving the other agents.
        #[arg(long, value_enum, default_value_t = BackgroundPolicy::LogReplay)]
        background: BackgroundPolicy,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Measure the log → token → log round trip (ADE/FDE) over recorded scenes.
    TokenRoundtrip {
        /// Folder of scenario files (searched recursively).
        #[arg(long)]
        scenes: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Benchmarks: import time per scene per format, simulator steps per second.
    Bench {
        /// Folder of scenario files (searched recursively).
        #[arg(long, default_value = "../shared/data")]
        scenes: PathBuf,
        /// Repetitions of each measurement (the median is reported).
        #[arg(long, default_value_t = 3)]
        repeat: usize,
    },
    /// Run scenario suites (the same variants and metrics as `cargo test --test suites`).
    Run {
        /// Suite spec files (`specs/suites/*.yaml`).
        #[arg(required = true)]
        suites: Vec<PathBuf>,
        /// Also write a JSON report to this file.
        #[arg(long, value_name = "OUT")]
        json: Option<PathBuf>,
        /// Folder for the recordings and pictures of failing variants.
        #[arg(long, value_name = "DIR", default_value = "target/safer-artifacts")]
        artifacts: PathBuf,
        /// Only variants and metrics whose test name contains this.
        #[arg(long, value_name = "SUBSTR")]
        filter: Option<String>,
    },
    /// WOSAC 2025 realism metrics of a traffic policy: roll out every agent of each scene N times and score the rollouts against the log.
    #[command(after_help = realism::WINDOW_RULE_HELP)]
    Realism {
        /// Folder of scenario files (searched recursively), or one file.
        #[arg(long)]
        scenes: PathBuf,
        /// Rollouts per scene (WOSAC: 32).
        #[arg(long, default_value_t = 32)]
        rollouts: usize,
        /// Also write a JSON report (per scene and aggregates) to this file.
        #[arg(long, value_name = "OUT")]
        json: Option<PathBuf>,
        /// Policy driving every agent present at the window's start.
        #[arg(long, value_enum, default_value_t = realism::RealismPolicy::Idm)]
        policy: realism::RealismPolicy,
        /// Base seed (per-rollout seeds derive from it, the scenario id and the rollout index).
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Score at most this many scenes.
        #[arg(long, value_name = "N")]
        max_scenes: Option<usize>,
    },
    /// Print the JSON Schema of a spec kind (for editors: yaml-language-server `$schema`).
    Schema {
        /// Which spec.
        #[arg(value_enum)]
        kind: SpecKind,
        /// Write to this file instead of stdout.
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// Latency of the learned models in tract (map encoding, CBV query, full-scene step), against onnxruntime/PyTorch.
    BenchModels {
        /// Scenes to pick the busiest from.
        #[arg(long, default_value = "../shared/data/womd-tfrecord")]
        scenes: PathBuf,
        /// Folder of the models and their cards.
        #[arg(long, default_value = "models")]
        models: PathBuf,
        /// Repetitions (the median is reported).
        #[arg(long, default_value_t = 200)]
        repeat: usize,
    },
    /// Dual-stage evaluation of adversary methods: CR, SR, SR on critical variants, witness rate, VJ, AJ.
    Evaluate {
        /// Folder of recorded scenes (searched recursively); scenes need an ego and a CBV.
        #[arg(long)]
        scenes: PathBuf,
        /// Methods to compare, one table row each.
        #[arg(long, value_enum, value_delimiter = ',', default_values_t = [AdversaryMethod::Safer, AdversaryMethod::NoLfr, AdversaryMethod::NoTrustRegion, AdversaryMethod::NoMda, AdversaryMethod::Prior, AdversaryMethod::Log])]
        methods: Vec<AdversaryMethod>,
        /// Seeds per scene and method.
        #[arg(long, default_value_t = 10)]
        seeds: u32,
        /// Base seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Reactive planner driving the ego in stage 2.
        #[arg(long, value_enum, default_value_t = BuiltinPlanner::Evasive)]
        planner: BuiltinPlanner,
        /// Trust-region size n (top-n tokens of the prior).
        #[arg(long, default_value_t = 20)]
        trust_region: usize,
        /// Who drives the background agents.
        #[arg(long, value_enum, default_value_t = BackgroundDriver::Configured)]
        background: BackgroundDriver,
        /// The CBV in stage 2: replaying its stage-1 trajectory, or driven by the method again.
        #[arg(long, value_enum, default_value_t = Stage2Cbv::Replay)]
        stage2_cbv: Stage2Cbv,
        /// Horizon of both stages from the scene's current step, s.
        #[arg(long, default_value_t = 8.0)]
        horizon_s: f64,
        /// Evaluate only the first N scenes (by id).
        #[arg(long, value_name = "N")]
        max_scenes: Option<usize>,
        /// Also write every variant and the table as JSON.
        #[arg(long, value_name = "OUT")]
        json: Option<PathBuf>,
    },
    /// Write the feasibility value's training transitions (NGSIM + synthetic, several ego and CBV policies).
    FeasibilityDataset {
        /// Recorded scenes whose licence allows training the shipped models (NGSIM).
        #[arg(long, default_value = "../shared/data/commonroad-ngsim")]
        recorded: PathBuf,
        /// Output folder.
        #[arg(long, default_value = "training/data/feasibility")]
        out: PathBuf,
        /// Synthetic scenes.
        #[arg(long, default_value_t = 300)]
        synthetic_scenes: usize,
        /// Base seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Replace an existing dataset.
        #[arg(long)]
        force: bool,
    },
    /// Accuracy of the shipped V_h against the witness search on held-out states, V_h latency, and the LFR picture.
    FeasibilityEval {
        /// Recorded scenes of the collection (NGSIM).
        #[arg(long, default_value = "../shared/data/commonroad-ngsim")]
        recorded: PathBuf,
        /// Synthetic scenes of the collection (same as for `feasibility-dataset`).
        #[arg(long, default_value_t = 300)]
        synthetic_scenes: usize,
        /// Base seed of the collection.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Most held-out states to label.
        #[arg(long, default_value_t = 3000)]
        states: usize,
        /// Where to draw V_h over relative CBV positions.
        #[arg(long, default_value = "docs/feasibility-lfr.svg")]
        svg: PathBuf,
    },
    /// Write the realism prior's training shards (NGSIM scenes + calibrated synthetic traffic).
    PriorDataset {
        /// Recorded scenes whose licence allows training the shipped models (NGSIM).
        #[arg(long, default_value = "../shared/data/commonroad-ngsim")]
        recorded: PathBuf,
        /// Output folder for the shards.
        #[arg(long, default_value = "training/data/prior")]
        out: PathBuf,
        /// Synthetic scenes on procedural templates (straight roads, merges, signalised crossings).
        #[arg(long, default_value_t = 600)]
        template_scenes: usize,
        /// Synthetic scenes on the recorded maps.
        #[arg(long, default_value_t = 200)]
        recorded_map_scenes: usize,
        /// Base seed of the synthetic traffic.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Samples per shard.
        #[arg(long, default_value_t = 50_000)]
        shard_size: usize,
        /// Replace shards already in the output folder.
        #[arg(long)]
        force: bool,
    },
    /// Draw a scenario (a recorded file or a scenario spec YAML) as an SVG picture.
    Render {
        /// A recorded scenario (.tfrecord, .json, .xml, .parquet / AV2 folder) or a scenario spec (.yaml).
        file: PathBuf,
        /// Step whose footprints are drawn (default: the scenario's current step).
        #[arg(long, value_name = "N")]
        step: Option<usize>,
        /// Output file (default: `<stem>.svg` in the current folder); a folder when FILE holds several scenarios.
        #[arg(long, value_name = "OUT")]
        out: Option<PathBuf>,
        /// Overwrite existing pictures.
        #[arg(long)]
        force: bool,
    },
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
    /// The arguments ask for something that cannot be done.
    #[error("{0}")]
    Usage(String),
}

/// Runs the command line; returns the process exit code.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Inspect { file, json } => inspect::run(&file, json),
        Command::Simulate { path, planner, background, json } => simulate::run(&path, planner, background, json),
        Command::TokenRoundtrip { scenes, json } => token_roundtrip::run(&scenes, json),
        Command::Bench { scenes, repeat } => bench::run(&scenes, repeat.max(1)),
        Command::Run { suites, json, artifacts, filter } => {
            run::run(&suites, json.as_deref(), &artifacts, filter.as_deref())
        }
        Command::Realism { scenes, rollouts, json, policy, seed, max_scenes } => {
            realism::run(&realism::RealismArgs { scenes, rollouts, json, policy, seed, max_scenes })
        }
        Command::Schema { kind, out } => schema::run(kind, out.as_deref()),
        Command::Render { file, step, out, force } => render::run(&file, step, out.as_deref(), force),
        Command::BenchModels { scenes, models, repeat } => bench_models::run(&scenes, &models, repeat.max(1)),
        Command::Evaluate {
            scenes,
            methods,
            seeds,
            seed,
            planner,
            trust_region,
            background,
            stage2_cbv,
            horizon_s,
            max_scenes,
            json,
        } => {
            let request = EvaluationRequest {
                methods,
                seeds: seeds.max(1),
                base_seed: seed,
                planner,
                trust_region: trust_region.clamp(1, crate::motion::tokens::VOCABULARY_SIZE),
                background,
                stage2_cbv,
                horizon_s,
            };
            evaluate::run(&scenes, &request, max_scenes, json.as_ref())
        }
        Command::FeasibilityDataset { recorded, out, synthetic_scenes, seed, force } => {
            feasibility_dataset::run(&feasibility_dataset::FeasibilityDatasetRequest {
                recorded,
                out,
                synthetic_scenes,
                seed,
                force,
            })
        }
        Command::FeasibilityEval { recorded, synthetic_scenes, seed, states, svg } => feasibility_eval::run(
            &feasibility_dataset::FeasibilityDatasetRequest {
                recorded,
                out: PathBuf::new(),
                synthetic_scenes,
                seed,
                force: false,
            },
            states,
            &svg,
        ),
        Command::PriorDataset { recorded, out, template_scenes, recorded_map_scenes, seed, shard_size, force } => {
            prior_dataset::run(&prior_dataset::DatasetRequest {
                recorded,
                out,
                template_scenes,
                recorded_map_scenes,
                seed,
                shard_size: shard_size.max(1),
                force,
            })
        }
    };
    match result {
        Ok(code) => code,
        // A spec error reads best as the report with the offending YAML line.
        Err(CliError::Spec(e)) => {
            eprintln!("{:?}", e.to_report());
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

/// Scenario files under `path` (or `path` itself when it is a file).
fn scene_paths(path: &std::path::Path) -> Result<Vec<PathBuf>, CliError> {
    let is_av2_folder = crate::scenario::import::argoverse2::find_scenario_files(path).is_ok();
    if path.is_dir() && !is_av2_folder {
        let found = crate::scenario::import::discover(path)?;
        if found.is_empty() {
            return Err(CliError::NoScenes(path.to_path_buf()));
        }
        Ok(found)
    } else {
        Ok(vec![path.to_path_buf()])
    }
}
