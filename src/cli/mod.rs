//! The `safer` command line: argument parsing and the commands, each in its
//! own module. Commands print human-readable tables by default and JSON
//! with `--json`; errors go to stderr with the file and place at fault.

mod bench;
mod inspect;
mod simulate;
mod token_roundtrip;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use crate::planners::BuiltinPlanner;
use crate::policies::BackgroundPolicy;
use crate::scenario::import::ImportError;
use crate::sim::SimError;

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
}

/// Runs the command line; returns the process exit code.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Inspect { file, json } => inspect::run(&file, json),
        Command::Simulate { path, planner, background, json } => simulate::run(&path, planner, background, json),
        Command::TokenRoundtrip { scenes, json } => token_roundtrip::run(&scenes, json),
        Command::Bench { scenes, repeat } => bench::run(&scenes, repeat.max(1)),
    };
    match result {
        Ok(code) => code,
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
