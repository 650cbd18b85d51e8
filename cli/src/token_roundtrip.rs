//! `safer token-roundtrip --scenes DIR`: the reconstruction error of the
//! log → token → log round trip, per source format and agent kind.

use super::*;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::ExitCode;

use rayon::prelude::*;
use serde::Serialize;

use super::{CliError, scene_paths};
use safer_scenarios::motion::inversion::{RoundTripError, round_trip_error};
use safer_scenarios::motion::tokenize_track;
use safer_scenarios::scenario::{AgentKind, SourceFormat, import};

#[derive(Debug, Serialize)]
struct Row {
    format: SourceFormat,
    kind: AgentKind,
    scenes: usize,
    tracks: usize,
    compared_steps: usize,
    ade_m: f64,
    fde_m: f64,
    max_m: f64,
}

pub(super) fn run(scenes: &Path, json: Option<&Path>) -> Result<ExitCode, CliError> {
    if let Some(path) = json {
        super::check_json_report(path)?;
    }
    let paths = scene_paths(scenes)?;
    let started = std::time::Instant::now();
    type FileTally = Vec<(SourceFormat, AgentKind, RoundTripError)>;
    let per_file: Vec<Result<FileTally, CliError>> = paths
        .par_iter()
        .map(|p| {
            let mut out = Vec::new();
            for s in import::load(p)? {
                for t in &s.tracks {
                    let e = round_trip_error(t, &tokenize_track(t, s.current_step));
                    if e.steps > 0 {
                        out.push((s.source.format, t.kind, e));
                    }
                }
            }
            Ok(out)
        })
        .collect();
    let mut table: BTreeMap<(SourceFormat, AgentKind), (RoundTripError, usize, usize)> = BTreeMap::new();
    for r in per_file {
        let rows = r?;
        let mut seen = std::collections::BTreeSet::new();
        for (format, kind, e) in rows {
            let entry = table.entry((format, kind)).or_default();
            entry.0.merge(&e);
            entry.1 += 1;
            if seen.insert((format, kind)) {
                entry.2 += 1;
            }
        }
    }
    let rows: Vec<Row> = table
        .into_iter()
        .map(|((format, kind), (e, tracks, scenes))| Row {
            format,
            kind,
            scenes,
            tracks,
            compared_steps: e.steps,
            ade_m: e.ade_m(),
            fde_m: e.fde_m(),
            max_m: e.max_displacement_m,
        })
        .collect();
    if let Some(path) = json {
        super::write_json_report(path, &rows)?;
    } else {
        println!(
            "{:<12} {:<11} {:>6} {:>7} {:>9} {:>8} {:>8} {:>8}",
            "format", "kind", "scenes", "tracks", "steps", "ADE m", "FDE m", "max m"
        );
        for r in &rows {
            let f = serde_json::to_value(r.format)?;
            let k = serde_json::to_value(r.kind)?;
            println!(
                "{:<12} {:<11} {:>6} {:>7} {:>9} {:>8.3} {:>8.3} {:>8.2}",
                f.as_str().unwrap_or_default(),
                k.as_str().unwrap_or_default(),
                r.scenes,
                r.tracks,
                r.compared_steps,
                r.ade_m,
                r.fde_m,
                r.max_m
            );
        }
        println!(
            "\nFDE is the error at the last compared step of each segment (a segment is a run of token periods \
             with valid log at both ends). {} files in {:.1} s.",
            paths.len(),
            started.elapsed().as_secs_f64()
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// The arguments of `safer token-roundtrip`.
#[derive(Debug, clap::Args)]
pub(crate) struct TokenRoundtripArgs {
    /// Folder of scenario files (searched recursively); `data:REL` is in $SAFER_DATA_DIR.
    #[arg(long, value_parser = data_path)]
    pub(crate) scenes: PathBuf,
    /// Print JSON instead of a table.
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub(crate) json: Option<PathBuf>,
}

/// Runs `safer token-roundtrip`.
pub(crate) fn command(args: TokenRoundtripArgs) -> Result<ExitCode, CliError> {
    let TokenRoundtripArgs { scenes, json } = args;
    run(&scenes, json.as_deref())
}
