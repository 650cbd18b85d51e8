//! `safer simulate PATH`: one closed-loop rollout per scenario, summarised.

use super::*;
use std::path::Path;
use std::process::ExitCode;

use rayon::prelude::*;

use super::{CliError, scene_paths};
use safer_scenarios::harness::pipeline::make_planner;
use safer_scenarios::planners::BuiltinPlanner;
use safer_scenarios::planners::external::RolloutContext;
use safer_scenarios::policies::BackgroundPolicy;
use safer_scenarios::scenario::{Scenario, import};
use safer_scenarios::sim::{RolloutSummary, SimConfig, Simulation};
use safer_scenarios::spec::planner::PlannerAdapter;

/// Runs one rollout of `scenario` with the planner `planner` describes (a
/// built-in, or an external process started for this scene and told it
/// in `hello`).
pub fn simulate_one(
    scenario: &Scenario,
    planner: &PlannerAdapter,
    background: BackgroundPolicy,
) -> Result<RolloutSummary, String> {
    let ego = scenario.ego.ok_or_else(|| safer_scenarios::sim::SimError::NoEgo(scenario.id.clone()).to_string())?;
    // The ego is held to the default vehicle limits unless it replays its log.
    let replays_log = matches!(planner, PlannerAdapter::Builtin { planner: BuiltinPlanner::LogReplay, .. });
    let ego_limits = (!replays_log).then(safer_scenarios::sim::VehicleLimits::default);
    let sim = Simulation::new(scenario, SimConfig { background, ego_limits, ..SimConfig::default() })
        .map_err(|e| e.to_string())?;
    let context = RolloutContext {
        scenario: std::sync::Arc::new(scenario.clone()),
        ego,
        start_step: scenario.current_step,
        end_step: scenario.num_steps().saturating_sub(1),
        variant: None,
        seed: None,
    };
    let mut p = make_planner(planner, context).map_err(|e| e.to_string())?;
    Ok(sim.run(p.as_mut()).summary())
}

pub(super) fn run(
    path: &Path,
    planner: &PlannerAdapter,
    background: BackgroundPolicy,
    json: Option<&Path>,
) -> Result<ExitCode, CliError> {
    if let Some(path) = json {
        super::check_json_report(path)?;
    }
    let paths = scene_paths(path)?;
    // Files in parallel; results come back in path order, so output is
    // deterministic. An import error names its file already; a simulation
    // error gets the file and scenario here.
    let results: Vec<Result<Vec<RolloutSummary>, String>> = paths
        .par_iter()
        .map(|p| {
            let scenarios = import::load(p).map_err(|e| e.to_string())?;
            scenarios
                .iter()
                .map(|s| {
                    simulate_one(s, planner, background).map_err(|e| format!("{}: scenario {}: {e}", p.display(), s.id))
                })
                .collect()
        })
        .collect();
    let mut failures = 0;
    let mut summaries = Vec::new();
    for r in results {
        match r {
            Ok(s) => summaries.extend(s),
            Err(message) => {
                failures += 1;
                eprintln!("error: {message}");
            }
        }
    }
    if let Some(path) = json {
        super::write_json_report(path, &summaries)?;
    } else if !(summaries.is_empty() && failures > 0) {
        print_table(&summaries);
    }
    Ok(if failures > 0 { ExitCode::from(1) } else { ExitCode::SUCCESS })
}

fn print_table(rows: &[RolloutSummary]) {
    println!(
        "{:<44} {:>8} {:>8} {:>6} {:>22} {:>9} {:>9}",
        "scenario", "ego", "cbv", "time s", "ego collision", "off-road", "min gap m"
    );
    for r in rows {
        let collision = r.ego_collision.as_ref().map_or("-".to_string(), |c| {
            format!("{:.1}s with {}{}", c.time_s, c.other, if c.with_cbv { " (CBV)" } else { "" })
        });
        let off_road = r.ego_off_road_s.map_or("-".to_string(), |t| format!("{t:.1}s"));
        let gap = r.min_distance_to_ego_m.map_or("-".to_string(), |d| format!("{d:.2}"));
        let name: String = r.scenario.chars().take(44).collect();
        println!(
            "{:<44} {:>8} {:>8} {:>6.1} {:>22} {:>9} {:>9}",
            name,
            r.ego.0,
            r.cbv.as_ref().map_or("-", |c| c.0.as_str()),
            r.duration_s,
            collision,
            off_road,
            gap
        );
    }
    let n = rows.len();
    let collided = rows.iter().filter(|r| r.ego_collision.is_some()).count();
    let off = rows.iter().filter(|r| r.ego_off_road_s.is_some()).count();
    println!("\n{n} rollouts: {collided} with an ego collision, {off} with the ego off-road");
}

/// The arguments of `safer simulate`.
#[derive(Debug, clap::Args)]
pub(crate) struct SimulateArgs {
    /// A scenario file, or a folder searched recursively for scenario files (`data:REL`: in $SAFER_DATA_DIR; `safer:REL`: a file safer ships).
    #[arg(value_parser = data_path, required_unless_present = "scenes", conflicts_with = "scenes")]
    pub(crate) path: Option<PathBuf>,
    /// The same as the positional path, named as the other commands name it.
    #[arg(long, value_parser = data_path)]
    pub(crate) scenes: Option<PathBuf>,
    /// Planner driving the ego: a built-in (log-replay, constant-velocity,
    /// idm, evasive) or a planner spec file, as `run` and `evaluate` take.
    #[arg(long, default_value = "idm", value_parser = planner_arg, value_name = "BUILTIN|SPEC.yaml")]
    pub(crate) planner: PlannerAdapter,
    /// Policy driving the other agents.
    #[arg(long, value_parser = choice(BackgroundPolicy::ALL), default_value = "log-replay")]
    pub(crate) background: BackgroundPolicy,
    /// Print JSON instead of a table.
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub(crate) json: Option<PathBuf>,
}

/// Runs `safer simulate`.
pub(crate) fn command(args: SimulateArgs) -> Result<ExitCode, CliError> {
    let SimulateArgs { path, scenes, planner, background, json } = args;
    let path = path.or(scenes).expect("clap requires the path or --scenes");
    run(&path, &planner, background, json.as_deref())
}
