//! `safer bench`: import time per scene per format (against the time to
//! read the same bytes from disk, as the reference), and simulator steps per
//! second with every agent on log replay (against a bare replay loop that
//! only copies the recorded states, as the reference).

use std::collections::BTreeMap;
use std::path::Path;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use super::{CliError, scene_paths};
use crate::planners::BuiltinPlanner;
use crate::scenario::{SourceFormat, import};
use crate::sim::{SimConfig, Simulation};

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn time<T>(repeat: usize, mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut out = None;
    let times = (0..repeat)
        .map(|_| {
            let t = Instant::now();
            out = Some(f());
            t.elapsed()
        })
        .collect();
    (median(times), out.expect("repeat >= 1"))
}

pub(super) fn run(scenes: &Path, repeat: usize) -> Result<ExitCode, CliError> {
    let profile = if cfg!(debug_assertions) { "debug" } else { "release" };
    println!(
        "safer bench: {profile} build, {} CPUs, median of {repeat} runs, single-threaded\n",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );

    // Import: per format, the mean and max of per-scene medians.
    let paths = scene_paths(scenes)?;
    let mut per_format: BTreeMap<SourceFormat, (Vec<Duration>, Vec<Duration>, usize)> = BTreeMap::new();
    let mut sim_candidates = Vec::new();
    for p in &paths {
        let format = import::detect_format(p)?;
        let (read_t, _) = time(repeat, || {
            let files = match format {
                SourceFormat::Argoverse2 => {
                    import::argoverse2::find_scenario_files(p).map(|f| vec![f.scenario, f.map]).unwrap_or_default()
                }
                _ => vec![p.clone()],
            };
            files.iter().map(|f| std::fs::read(f).map(|b| b.len()).unwrap_or(0)).sum::<usize>()
        });
        let (import_t, scenarios) = time(repeat, || import::load(p));
        let scenarios = scenarios?;
        let e = per_format.entry(format).or_default();
        e.0.push(import_t / scenarios.len().max(1) as u32);
        e.1.push(read_t / scenarios.len().max(1) as u32);
        e.2 += scenarios.len();
        if format == SourceFormat::WomdProto {
            sim_candidates.extend(scenarios);
        }
    }
    println!("{:<12} {:>7} {:>14} {:>13} {:>15}", "format", "scenes", "import ms/scene", "max ms/scene", "× file read");
    for (format, (imports, reads, n)) in &per_format {
        let mean = |v: &Vec<Duration>| v.iter().sum::<Duration>().as_secs_f64() * 1e3 / v.len() as f64;
        let max = imports.iter().max().copied().unwrap_or_default().as_secs_f64() * 1e3;
        let name = serde_json::to_value(format)?;
        println!(
            "{:<12} {:>7} {:>14.1} {:>13.1} {:>15.0}",
            name.as_str().unwrap_or_default(),
            n,
            mean(imports),
            max,
            mean(imports) / mean(reads).max(1e-9)
        );
    }

    // Simulator: 9 s WOMD scenes, every agent and the ego on log replay.
    println!(
        "\n{:<40} {:>7} {:>7} {:>10} {:>14} {:>16}",
        "simulator (all log replay)", "agents", "steps", "steps/s", "agent-steps/s", "× bare replay"
    );
    for s in &sim_candidates {
        let Some(ego) = s.ego else { continue };
        let (sim_t, steps) = time(repeat, || {
            let mut planner = BuiltinPlanner::LogReplay.instantiate(s, ego);
            Simulation::new(s, SimConfig::default()).map(|sim| sim.run(planner.as_mut()).steps())
        });
        let steps = steps?;
        // Reference: copy each step's recorded states, nothing else.
        let (bare_t, _) = time(repeat, || {
            let mut acc = 0usize;
            for k in s.current_step..s.num_steps() {
                let row: Vec<_> = s.tracks.iter().map(|t| t.state(k).copied()).collect();
                acc += row.iter().flatten().count();
            }
            acc
        });
        let sps = steps as f64 / sim_t.as_secs_f64();
        println!(
            "{:<40} {:>7} {:>7} {:>10.0} {:>14.0} {:>16.1}",
            s.id.chars().take(40).collect::<String>(),
            s.tracks.len(),
            steps,
            sps,
            sps * s.tracks.len() as f64,
            sim_t.as_secs_f64() / bare_t.as_secs_f64().max(1e-9)
        );
    }
    Ok(ExitCode::SUCCESS)
}
