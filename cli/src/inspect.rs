//! `safer inspect FILE`: what is in a scenario file.

use super::*;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::ExitCode;

use serde::Serialize;

use super::CliError;
use safer_scenarios::map::MapCounts;
use safer_scenarios::scenario::{AgentKind, RoleOrigin, Scenario, SourceFormat, import};

/// A role holder in the summary.
#[derive(Debug, Serialize)]
struct RoleSummary {
    id: String,
    kind: AgentKind,
    assigned_by: RoleOrigin,
}

/// What `inspect` prints for one scenario.
#[derive(Debug, Serialize)]
struct ScenarioSummary {
    format: SourceFormat,
    scenario_id: String,
    file: String,
    agents: usize,
    agents_by_kind: BTreeMap<AgentKind, usize>,
    steps: usize,
    dt_s: f64,
    duration_s: f64,
    current_step: usize,
    map: MapCounts,
    ego: Option<RoleSummary>,
    cbv: Option<RoleSummary>,
    origin_world_m: [f64; 2],
    notes: Vec<String>,
}

fn summarise(s: &Scenario) -> ScenarioSummary {
    let mut by_kind = BTreeMap::new();
    for t in &s.tracks {
        *by_kind.entry(t.kind).or_insert(0) += 1;
    }
    let role = |i: Option<safer_scenarios::scenario::TrackIndex>, origin| {
        i.map(|i| RoleSummary { id: s.track(i).id.to_string(), kind: s.track(i).kind, assigned_by: origin })
    };
    ScenarioSummary {
        format: s.source.format,
        scenario_id: s.id.clone(),
        file: s.source.path.display().to_string(),
        agents: s.tracks.len(),
        agents_by_kind: by_kind,
        steps: s.num_steps(),
        dt_s: s.dt_s,
        duration_s: s.duration_s(),
        current_step: s.current_step,
        map: s.map.counts(),
        ego: role(s.ego, s.ego_origin),
        cbv: role(s.cbv, s.cbv_origin),
        origin_world_m: [s.origin_world.x, s.origin_world.y],
        notes: s.source.notes.clone(),
    }
}

pub(super) fn run(file: &Path, json: Option<&Path>) -> Result<ExitCode, CliError> {
    if let Some(path) = json {
        super::check_json_report(path)?;
    }
    let scenarios = import::load(file)?;
    let summaries: Vec<ScenarioSummary> = scenarios.iter().map(summarise).collect();
    if let Some(path) = json {
        super::write_json_report(path, &summaries)?;
        return Ok(ExitCode::SUCCESS);
    }
    for s in &summaries {
        println!("scenario      {}", s.scenario_id);
        println!("file          {}", s.file);
        println!("format        {}", serde_json::to_value(s.format)?.as_str().unwrap_or_default());
        let kinds: Vec<String> =
            s.agents_by_kind.iter().map(|(k, n)| format!("{n} {}", safer_scenarios::spec::spec_name(k))).collect();
        println!("agents        {} ({})", s.agents, kinds.join(", "));
        println!("steps         {} × {:.4} s = {:.1} s, now = step {}", s.steps, s.dt_s, s.duration_s, s.current_step);
        let m = &s.map;
        println!(
            "map           {} lanes ({} in junctions), {} road edges, {} road lines, {} crosswalks, {} speed bumps, {} driveways, {} drivable areas, {} stop signs, {} signal-controlled lanes",
            m.lanes,
            m.junction_lanes,
            m.road_edges,
            m.road_lines,
            m.crosswalks,
            m.speed_bumps,
            m.driveways,
            m.drivable_areas,
            m.stop_signs,
            m.traffic_signals
        );
        let role = |r: &Option<RoleSummary>| match r {
            Some(r) => {
                let (kind, by) =
                    (safer_scenarios::spec::spec_name(&r.kind), safer_scenarios::spec::spec_name(&r.assigned_by));
                format!("{} ({kind}, by {by})", r.id)
            }
            None => "none".to_string(),
        };
        println!("ego           {}", role(&s.ego));
        println!("cbv           {}", role(&s.cbv));
        println!("origin        ({:.0}, {:.0}) m in the source frame", s.origin_world_m[0], s.origin_world_m[1]);
        for n in &s.notes {
            println!("note          {n}");
        }
        println!();
    }
    Ok(ExitCode::SUCCESS)
}

/// The arguments of `safer inspect`.
#[derive(Debug, clap::Args)]
pub(crate) struct InspectArgs {
    /// A WOMD .tfrecord or .json, CommonRoad .xml, or Argoverse 2 .parquet / folder (`data:REL`: in $SAFER_DATA_DIR; `safer:REL`: a file safer ships).
    #[arg(value_parser = data_path)]
    pub(crate) file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub(crate) json: Option<PathBuf>,
}

/// Runs `safer inspect`.
pub(crate) fn command(args: InspectArgs) -> Result<ExitCode, CliError> {
    let InspectArgs { file, json } = args;
    run(&file, json.as_deref())
}
