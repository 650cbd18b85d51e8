//! A variant as a CommonRoad 2020a scenario, so a team can run a failing
//! variant in CommonRoad's tools (a CommonRoad planner, the drivability
//! checker, the scenario designer) and see the failure safer saw: every
//! agent but the ego as a dynamic obstacle driving its stage-2 trajectory,
//! the ego as the planning problem, and the road as the source has it.
//!
//! This module owns the export's content. Everything is in the source's
//! own frame (safer's shifted local frame plus [`Scenario::origin_world`]),
//! so an export overlays its source file exactly. Time step 0 is the
//! rollout's first step, as the 2020a schema wants every initial state
//! (the sidecar says which of the source's time steps that is); copied
//! traffic lights have their cycles re-based to it, so they show the
//! colours the source shows at the same moment.
//!
//! - From a CommonRoad source, the road is copied from the source file,
//!   read again at export time: location, tags, lanelets (bounds,
//!   neighbours of either direction, stop lines, sign and light
//!   references), traffic signs, traffic lights and intersections, ids
//!   unchanged. Obstacles keep their source ids. Where the file is gone or
//!   no longer matches the scene, the map is converted as for the other
//!   sources and the header comment says why.
//! - From other sources (WOMD, Argoverse 2, authored scenes), the map is
//!   converted: one lanelet per lane, bounds from the lane's own
//!   boundaries where the source has them (else the centreline offset by
//!   the default half-width), same-direction neighbours and opposite-direction
//!   left neighbours (lanes whose left bounds run together), traffic signals
//!   as traffic lights whose cycle plays the recorded states, stop signs
//!   as signs. Numeric ids are kept where they are positive and unique
//!   across lanelets, signs, lights, obstacles and the planning problem;
//!   the others are renumbered above every kept id, and the header comment
//!   and the sidecar list each renumbering.
//!
//! The planning problem has the ego's start and, as its goal, the lanelets
//! of the ego's route (the route the harness sends a planner) that the
//! variant's horizon can reach, at the rollout's last time step: a
//! CommonRoad planner drives the whole horizon. CommonRoad 2020a has no
//! place for the ego's size, so it is in the header comment and in a JSON
//! sidecar beside the file ([`sidecar_path`]), with the frame, the ids and
//! the limits of the conversion. An agent that leaves and comes back is
//! exported up to its first absence (CommonRoad trajectories have no gaps);
//! one seen at a single step is left out (a dynamic obstacle needs a
//! trajectory). An agent that enters after the first step starts at a time
//! step above 0, which the 2020a schema does not allow (commonroad-io reads
//! it): the sidecar lists these obstacles.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::RecordError;
use crate::geometry::{Point2, Vector2};
use crate::map::{
    DEFAULT_LANE_HALF_WIDTH_M, Lane, LaneKind, MAX_LANE_HALF_WIDTH_M, MIN_LANE_HALF_WIDTH_M, MapElementId,
};
use crate::map::{SignalState, TrafficSignal};
use crate::planners::route::{Route, recorded_path};
use crate::scenario::{AgentKind, AgentState, Scenario, SourceFormat};
use crate::sim::Rollout;

/// The benchmark id of every export whose map is converted: a fictitious
/// country (`ZAM`, as CommonRoad's own made-up scenarios) so that no export
/// passes for a recorded benchmark; the variant is named in `source`. An
/// export whose map is copied from a CommonRoad source keeps the source's
/// country (its traffic-sign ids are that country's), as
/// `USA_Safer-1_1_T-1`.
pub const BENCHMARK_ID: &str = "ZAM_Safer-1_1_T-1";

/// The `format` value that names a sidecar ([`ExportSidecar`]).
pub const SIDECAR_FORMAT: &str = "safer-commonroad-export";

/// What the goal's reach adds to the distance the ego covers at its top
/// speed over the horizon, m: a lane change's length, so a goal lanelet
/// starting just past that distance is still in.
const GOAL_REACH_MARGIN_M: f64 = 20.0;

/// Zamunda's (German) stop sign, for stop signs of converted maps.
const STOP_SIGN_ID: &str = "206";

/// How far the re-read source may be from the scene, m, before it counts
/// as changed (the scene's shift to its local frame rounds below this).
const SOURCE_MATCH_M: f64 = 1e-3;

/// An export: the CommonRoad document, its sidecar, and what a user should
/// know about it.
#[derive(Debug, Clone)]
pub struct CommonRoadExport {
    /// The CommonRoad 2020a document.
    pub xml: String,
    /// What the format has no place for (the ego's size, the frame, ids).
    pub sidecar: ExportSidecar,
    /// Facts worth printing (a source that could not be copied).
    pub notes: Vec<String>,
}

/// The JSON sidecar written beside every export ([`sidecar_path`]): what
/// CommonRoad 2020a has no place for, so a CommonRoad planner can be given
/// the ego's size and a reader can map ids and frames back to safer's.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ExportSidecar {
    /// Always [`SIDECAR_FORMAT`].
    pub format: &'static str,
    /// Layout version of this sidecar (1).
    pub version: u32,
    /// The variant (`suite::scenario::seed-k`).
    pub variant: String,
    /// Whether this is the shrunk variant (the one safer shows first).
    pub shrunk: bool,
    /// The scene's id.
    pub scenario: String,
    /// The scene's source format (`common-road`, `womd-proto`, …).
    pub source_format: &'static str,
    /// The scene's source file.
    pub source_path: String,
    /// `copied` (from the CommonRoad source file) or `converted`.
    pub map: &'static str,
    /// Where safer's local frame lies in the export's (the source's)
    /// frame, m: safer's coordinates plus this are the export's.
    pub origin_world_m: [f64; 2],
    /// Step length, s.
    pub dt_s: f64,
    /// The source's time step at the export's time step 0 (the rollout's
    /// first step): the export's time step `t` is the source's `t` plus this.
    pub source_first_time_step: usize,
    /// The export's last time step (the rollout's last step, the goal's time).
    pub last_time_step: usize,
    /// The ego.
    pub ego: SidecarEgo,
    /// The CBV (the adversary), where the scene has one and it was exported.
    pub cbv: Option<SidecarObstacle>,
    /// The goal's lanelets, in route order.
    pub goal_lanelets: Vec<i64>,
    /// Elements whose source id could not be kept, with the id they got.
    pub renumbered: Vec<Renumbered>,
    /// Obstacles that enter after the first step: their initial time step
    /// is above 0, which the 2020a schema does not allow.
    pub late_obstacles: Vec<i64>,
    /// Source ids of the agents seen at a single step, left out (a 2020a
    /// dynamic obstacle needs a trajectory).
    pub left_out: Vec<String>,
    /// What the export does not carry over from the scene.
    pub limits: Vec<String>,
}

/// The ego in the sidecar.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SidecarEgo {
    /// Its id in the source.
    pub source_id: String,
    /// The planning problem's id.
    pub planning_problem_id: i64,
    /// Box length, m.
    pub length_m: f64,
    /// Box width, m.
    pub width_m: f64,
}

/// An agent exported as an obstacle.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SidecarObstacle {
    /// Its id in the source.
    pub source_id: String,
    /// Its obstacle id in the export.
    pub obstacle_id: i64,
}

/// One element whose source id did not fit CommonRoad's id rules.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Renumbered {
    /// `lanelet`, `obstacle` or `planningProblem`.
    pub element: &'static str,
    /// Its id in the source.
    pub source_id: String,
    /// Its id in the export.
    pub id: i64,
}

/// Where [`write_commonroad`] puts the sidecar of the export at `xml`:
/// `NAME.xml` → `NAME.commonroad.json`.
pub fn sidecar_path(xml: &Path) -> PathBuf {
    xml.with_extension("commonroad.json")
}

/// The stage-2 `rollout` of `variant` (a variant of `scenario`) as a
/// CommonRoad 2020a document. `shrunk`: whether the rollout is the
/// variant's shrunk one (said in the file and the sidecar).
pub fn commonroad_export(
    scenario: &Scenario,
    rollout: &Rollout,
    variant: &str,
    shrunk: bool,
) -> Result<CommonRoadExport, RecordError> {
    let inconsistent = |what: String| RecordError::InconsistentRollout { scenario: scenario.id.clone(), what };
    if rollout.dt_s.is_nan() || rollout.dt_s <= 0.0 {
        return Err(inconsistent(format!("step length {} s is not positive", rollout.dt_s)));
    }
    let agents = rollout.bodies.len();
    if rollout.agent_ids.len() != agents || rollout.states.iter().any(|row| row.len() != agents) {
        return Err(inconsistent(format!("the state table is not {agents} agents wide")));
    }
    let ego = rollout.ego.0;
    if ego >= agents {
        return Err(inconsistent(format!("the ego is agent {ego} of {agents}")));
    }
    let state = |step: usize, agent: usize| rollout.states.get(step).and_then(|row| row.get(agent)).copied().flatten();
    let ego_start = state(0, ego).ok_or_else(|| inconsistent("the ego is absent at the first step".into()))?;
    let origin = scenario.origin_world;
    let first_t = rollout.start_step;
    let last = rollout.states.len().saturating_sub(1);
    // What the simulator knows of the ego's motion at the start, as its
    // planner is told: from the recording's step before, else none.
    let ego_motion = crate::planners::EgoMotion::between(
        first_t.checked_sub(1).and_then(|k| scenario.tracks.get(ego)?.state(k)),
        &ego_start,
        rollout.dt_s,
    );

    let mut ids = Ids::default();
    let mut limits = vec![
        "the obstacles drive the variant's stage-2 trajectories open loop: they do not react to a planner that \
         drives differently from the one under test"
            .to_string(),
        "an agent that leaves and comes back is exported up to its first absence".to_string(),
        "CommonRoad 2020a has no place for the ego's size: it is in this comment and in the sidecar JSON".to_string(),
    ];
    let mut notes = Vec::new();

    // The map: the source's own elements where the source is a CommonRoad
    // file that still matches the scene, else converted from the scene.
    let copied = match scenario.source.format {
        SourceFormat::CommonRoad => match copy_source(scenario, first_t) {
            Ok(source) => Some(source),
            Err(why) => {
                let why = format!("map converted, not copied: {why}");
                notes.push(why.clone());
                limits.push(why);
                None
            }
        },
        _ => None,
    };
    let lanes: Vec<&Lane> = scenario.map.lanes.iter().filter(|l| l.centreline.len() >= 2).collect();
    // Claims before any renumbering, so a renumbered id never takes an id
    // a later element keeps.
    let (lane_claims, sign_claims): (Vec<Option<i64>>, Vec<Option<i64>>) = match &copied {
        Some(source) => {
            ids.used.extend(source.ids.iter().copied());
            (Vec::new(), Vec::new())
        }
        None => (
            lanes.iter().map(|l| ids.claim(Some(l.id.0))).collect(),
            scenario.map.stop_signs.iter().map(|s| ids.claim(Some(s.id.0))).collect(),
        ),
    };
    let runs: Vec<(usize, Vec<(usize, AgentState)>)> = (0..agents)
        .filter(|&a| a != ego)
        .filter_map(|a| {
            let first = (0..rollout.states.len()).find(|&k| state(k, a).is_some())?;
            let run: Vec<(usize, AgentState)> =
                (first..rollout.states.len()).map_while(|k| state(k, a).map(|s| (k, s))).collect();
            Some((a, run))
        })
        .collect();
    let (exported, single): (Vec<_>, Vec<_>) = runs.into_iter().partition(|(_, run)| run.len() >= 2);
    if !single.is_empty() {
        limits.push(format!(
            "{} agent(s) seen at a single step are left out (a 2020a dynamic obstacle needs a trajectory)",
            single.len()
        ));
    }
    let source_id = |a: usize| rollout.agent_ids[a].0.clone();
    let obstacle_claims: Vec<Option<i64>> =
        exported.iter().map(|(a, _)| ids.claim(source_id(*a).trim().parse().ok())).collect();
    let ego_claim = ids.claim(source_id(ego).trim().parse().ok());

    let mut map_xml = String::new();
    let lane_ids: BTreeMap<MapElementId, i64> = match &copied {
        Some(source) => {
            for element in &source.elements {
                let _ = writeln!(map_xml, "  {element}");
            }
            limits.push("static obstacles of the source are exported as dynamic obstacles standing still".to_string());
            lanes.iter().filter(|l| source.lanelets.contains(&l.id.0)).map(|l| (l.id, l.id.0)).collect()
        }
        None => {
            let lane_ids: BTreeMap<MapElementId, i64> = lanes
                .iter()
                .zip(&lane_claims)
                .map(|(l, c)| (l.id, c.unwrap_or_else(|| ids.fresh("lanelet", l.id.0.to_string()))))
                .collect();
            let sign_ids: Vec<i64> = scenario
                .map
                .stop_signs
                .iter()
                .zip(&sign_claims)
                .map(|(s, c)| c.unwrap_or_else(|| ids.fresh("trafficSign", s.id.0.to_string())))
                .collect();
            let light_ids: Vec<i64> = scenario.map.traffic_signals.iter().map(|_| ids.fresh_unnamed()).collect();
            write_converted_map(&mut map_xml, scenario, first_t, &lanes, &lane_ids, &sign_ids, &light_ids);
            limits.extend(CONVERTED_LIMITS.iter().map(|l| l.to_string()));
            lane_ids
        }
    };
    let obstacle_ids: Vec<i64> = exported
        .iter()
        .zip(&obstacle_claims)
        .map(|((a, _), c)| c.unwrap_or_else(|| ids.fresh("obstacle", source_id(*a))))
        .collect();
    let problem_id = ego_claim.unwrap_or_else(|| ids.fresh("planningProblem", source_id(ego)));

    // The goal: the route's lanelets within the horizon's reach.
    let goal_lanelets: Vec<i64> =
        goal_lanes(scenario, rollout, &ego_start).iter().filter_map(|id| lane_ids.get(id).copied()).collect();
    if goal_lanelets.is_empty() {
        limits.push("the ego starts on no lane of the map running its way: the goal is the time alone".into());
    }

    let body = &rollout.bodies[ego];
    let cbv = rollout.cbv.and_then(|c| {
        let at = exported.iter().position(|(a, _)| *a == c.0)?;
        Some(SidecarObstacle { source_id: source_id(c.0), obstacle_id: obstacle_ids[at] })
    });
    let sidecar = ExportSidecar {
        format: SIDECAR_FORMAT,
        version: 1,
        variant: variant.to_string(),
        shrunk,
        scenario: scenario.id.clone(),
        source_format: scenario.source.format.name(),
        source_path: scenario.source.path.display().to_string(),
        map: if copied.is_some() { "copied" } else { "converted" },
        origin_world_m: [origin.x, origin.y],
        dt_s: rollout.dt_s,
        source_first_time_step: first_t,
        last_time_step: last,
        ego: SidecarEgo {
            source_id: source_id(ego),
            planning_problem_id: problem_id,
            length_m: body.length_m,
            width_m: body.width_m,
        },
        cbv,
        goal_lanelets,
        renumbered: std::mem::take(&mut ids.renumbered),
        left_out: single.iter().map(|(a, _)| source_id(*a)).collect(),
        late_obstacles: exported
            .iter()
            .zip(&obstacle_ids)
            .filter(|((_, run), _)| run[0].0 > 0)
            .map(|(_, id)| *id)
            .collect(),
        limits,
    };

    let mut x = String::new();
    let _ = writeln!(x, "<?xml version='1.0' encoding='UTF-8'?>");
    let country = copied.as_ref().map_or("ZAM", |s| s.country.as_str());
    let _ = writeln!(
        x,
        "<commonRoad timeStepSize=\"{}\" commonRoadVersion=\"2020a\" author=\"safer\" affiliation=\"safer\" \
         source=\"{}\" benchmarkID=\"{country}_Safer-1_1_T-1\" date=\"{}\">",
        num(rollout.dt_s),
        attr(&format!("safer variant {variant}{} of scenario {}", if shrunk { " (shrunk)" } else { "" }, scenario.id)),
        today()
    );
    x.push_str(&header_comment(&sidecar));
    match &copied {
        Some(source) => {
            let _ = writeln!(x, "  {}\n  {}", source.location, source.tags);
        }
        None => x.push_str(
            "  <location>\n    <geoNameId>-999</geoNameId>\n    <gpsLatitude>999</gpsLatitude>\n    \
             <gpsLongitude>999</gpsLongitude>\n  </location>\n  <scenarioTags>\n    <critical/>\n  </scenarioTags>\n",
        ),
    }
    x.push_str(&map_xml);

    // Every agent but the ego, from its first appearance to its first
    // absence, in the source's frame and time.
    for ((agent, run), id) in exported.iter().zip(&obstacle_ids) {
        let body = &rollout.bodies[*agent];
        let kind = copied
            .as_ref()
            .and_then(|s| s.obstacle_types.get(&rollout.agent_ids[*agent].0))
            .map_or(obstacle_type(body.kind), String::as_str);
        let _ = writeln!(x, "  <dynamicObstacle id=\"{id}\">");
        let _ = writeln!(x, "    <type>{}</type>", attr(kind));
        let _ = writeln!(
            x,
            "    <shape>\n      <rectangle>\n        <length>{}</length>\n        <width>{}</width>\n      </rectangle>\n    </shape>",
            num(body.length_m),
            num(body.width_m)
        );
        let (k0, s0) = run[0];
        x.push_str(&obstacle_state("initialState", k0, &s0, origin, "    "));
        if run.len() > 1 {
            x.push_str("    <trajectory>\n");
            for (k, s) in &run[1..] {
                x.push_str(&obstacle_state("state", *k, s, origin, "      "));
            }
            x.push_str("    </trajectory>\n");
        }
        x.push_str("  </dynamicObstacle>\n");
    }

    // The ego's planning problem: start as it started; goal the route's
    // lanelets at the rollout's last step.
    let _ = writeln!(x, "  <planningProblem id=\"{problem_id}\">");
    let _ = writeln!(
        x,
        "    <initialState>\n{}      <orientation>\n        <exact>{}</exact>\n      </orientation>\n      \
         <time>\n        <exact>0</exact>\n      </time>\n      <velocity>\n        <exact>{}</exact>\n      </velocity>\n      \
         <acceleration>\n        <exact>{}</exact>\n      </acceleration>\n      \
         <yawRate>\n        <exact>{}</exact>\n      </yawRate>\n      <slipAngle>\n        <exact>0</exact>\n      </slipAngle>\n    \
         </initialState>",
        position(&(ego_start.position + origin), "      "),
        num(ego_start.heading_rad),
        num(ego_start.speed_mps()),
        num(ego_motion.accel_mps2),
        num(ego_motion.yaw_rate_radps)
    );
    x.push_str("    <goalState>\n");
    if !sidecar.goal_lanelets.is_empty() {
        x.push_str("      <position>\n");
        for id in &sidecar.goal_lanelets {
            let _ = writeln!(x, "        <lanelet ref=\"{id}\"/>");
        }
        x.push_str("      </position>\n");
    }
    let _ = writeln!(
        x,
        "      <time>\n        <intervalStart>{last}</intervalStart>\n        <intervalEnd>{last}</intervalEnd>\n      \
         </time>\n    </goalState>\n  </planningProblem>"
    );
    x.push_str("</commonRoad>\n");
    Ok(CommonRoadExport { xml: x, sidecar, notes })
}

/// [`commonroad_export`]'s document alone.
pub fn commonroad_xml(scenario: &Scenario, rollout: &Rollout, variant: &str) -> Result<String, RecordError> {
    Ok(commonroad_export(scenario, rollout, variant, false)?.xml)
}

/// Writes [`commonroad_export`] to `path` and its sidecar to
/// [`sidecar_path`] (each atomically: a reader never sees half a file), and
/// returns its notes.
pub fn write_commonroad(
    path: &Path,
    scenario: &Scenario,
    rollout: &Rollout,
    variant: &str,
    shrunk: bool,
) -> Result<Vec<String>, RecordError> {
    let export = commonroad_export(scenario, rollout, variant, shrunk)?;
    let sidecar = serde_json::to_string_pretty(&export.sidecar).map_err(|e| RecordError::InconsistentRollout {
        scenario: scenario.id.clone(),
        what: format!("sidecar: {e}"),
    })? + "\n";
    super::write_output(path, export.xml.as_bytes())?;
    super::write_output(&sidecar_path(path), sidecar.as_bytes())?;
    Ok(export.notes)
}

/// The limits of a converted map, said in the file and the sidecar.
const CONVERTED_LIMITS: [&str; 4] = [
    "lanelet bounds are the lane's own boundaries where the source has them (projected at the centreline's \
     vertices), else the centreline offset by the default half-width",
    "opposite-direction left neighbours are found from the bounds (the scene's map keeps only same-direction \
     neighbours): where two lanes' left bounds run more than 0.5 m apart, CommonRoad's road boundary may close \
     between them",
    "traffic lights: one per signal-controlled lane, at its stop point, whose cycle plays the recorded states from \
     the rollout's first step to the scene's end (then repeats)",
    "road edges, painted lines, crosswalks, speed limits, intersections, and stop signs that control no lane \
     are not exported",
];

/// CommonRoad's id rule: positive, unique across the document.
#[derive(Default)]
struct Ids {
    used: BTreeSet<i64>,
    renumbered: Vec<Renumbered>,
}

impl Ids {
    /// `preferred` when it fits (positive, not yet taken); `None` means
    /// renumber with [`Self::fresh`] once every claim is made.
    fn claim(&mut self, preferred: Option<i64>) -> Option<i64> {
        preferred.filter(|&id| id > 0 && self.used.insert(id))
    }

    /// A new id above every id taken, recorded as a renumbering.
    fn fresh(&mut self, element: &'static str, source_id: String) -> i64 {
        let id = self.fresh_unnamed();
        self.renumbered.push(Renumbered { element, source_id, id });
        id
    }

    /// A new id for an element the source has no id for.
    fn fresh_unnamed(&mut self) -> i64 {
        let id = self.used.last().map_or(1, |m| m.saturating_add(1));
        self.used.insert(id);
        id
    }
}

/// The source's road, copied.
struct SourceMap {
    /// The benchmark id's country (`USA`), for the sign ids' meaning.
    country: String,
    /// `<location>`, verbatim.
    location: String,
    /// `<scenarioTags>`, verbatim.
    tags: String,
    /// Lanelets, signs, lights and intersections, verbatim, in file order.
    elements: Vec<String>,
    /// Every id those elements hold (incomings' too).
    ids: BTreeSet<i64>,
    /// The lanelets' ids.
    lanelets: BTreeSet<i64>,
    /// Each obstacle's `<type>`, by id.
    obstacle_types: BTreeMap<String, String>,
}

/// Reads the scene's CommonRoad source again and copies its road, after
/// checking that the file still holds the scene (the same lanelets and
/// tracks, shifted by the scene's origin). `Err` says why not. Traffic
/// lights are re-based so that the export's time step 0 is the source's
/// `first_time_step` ([`rebase_light_cycle`]).
fn copy_source(scenario: &Scenario, first_time_step: usize) -> Result<SourceMap, String> {
    let path = &scenario.source.path;
    let shown = path.display();
    let bytes = std::fs::read(path).map_err(|e| format!("the source file {shown} cannot be read ({e})"))?;
    let source = crate::scenario::import::commonroad::parse(&bytes, path)
        .map_err(|e| format!("the source file no longer reads as CommonRoad ({e})"))?;
    let changed = |what: String| format!("the source file {shown} no longer holds the scene ({what})");
    let origin = scenario.origin_world;
    if source.map.lanes.len() != scenario.map.lanes.len() {
        return Err(changed(format!(
            "{} lanelets, the scene has {}",
            source.map.lanes.len(),
            scenario.map.lanes.len()
        )));
    }
    for lane in &scenario.map.lanes {
        let Some(theirs) = source.map.lane(lane.id) else {
            return Err(changed(format!("no lanelet {}", lane.id.0)));
        };
        let (a, b) = (lane.centreline.points(), theirs.centreline.points());
        if a.len() != b.len() || a.iter().zip(b).any(|(p, q)| (p + origin - q).norm() > SOURCE_MATCH_M) {
            return Err(changed(format!("lanelet {} differs", lane.id.0)));
        }
    }
    let tracks: BTreeMap<&str, &crate::scenario::Track> = source.tracks.iter().map(|t| (t.id.0.as_str(), t)).collect();
    for track in &scenario.tracks {
        let Some(theirs) = tracks.get(track.id.0.as_str()) else {
            return Err(changed(format!("no obstacle {}", track.id)));
        };
        let same = track.states.len() == theirs.states.len()
            && track.states.iter().zip(&theirs.states).all(|(a, b)| match (a, b) {
                (Some(a), Some(b)) => (a.position + origin - b.position).norm() <= SOURCE_MATCH_M,
                (None, None) => true,
                _ => false,
            });
        if !same {
            return Err(changed(format!("obstacle {} differs", track.id)));
        }
    }

    // The parse above succeeded, so the text is UTF-8 and well-formed.
    let text = std::str::from_utf8(&bytes).map_err(|e| format!("the source file is not UTF-8 ({e})"))?;
    let options = roxmltree::ParsingOptions { allow_dtd: false, ..roxmltree::ParsingOptions::default() };
    let doc = roxmltree::Document::parse_with_options(text, options)
        .map_err(|e| format!("the source file is not well-formed XML ({e})"))?;
    let root = doc.root_element();
    let verbatim = |n: roxmltree::Node<'_, '_>| text[n.range()].to_string();
    let country = root
        .attribute("benchmarkID")
        .and_then(|b| b.split('_').next())
        .filter(|c| c.len() == 3 && c.bytes().all(|b| b.is_ascii_uppercase()))
        .unwrap_or("ZAM")
        .to_string();
    let find = |name: &str| root.children().find(|n| n.has_tag_name(name)).map(verbatim);
    let location = find("location").ok_or_else(|| "the source file has no <location>".to_string())?;
    let tags = find("scenarioTags").unwrap_or_else(|| "<scenarioTags>\n    <critical/>\n  </scenarioTags>".into());
    let mut elements = Vec::new();
    let mut ids = BTreeSet::new();
    let mut lanelets = BTreeSet::new();
    let mut obstacle_types = BTreeMap::new();
    for node in root.children().filter(roxmltree::Node::is_element) {
        let name = node.tag_name().name();
        match name {
            "lanelet" | "trafficSign" | "trafficLight" | "intersection" => {
                for d in node.descendants().filter(roxmltree::Node::is_element) {
                    if let Some(id) = d.attribute("id") {
                        let id: i64 = id.trim().parse().map_err(|_| format!("<{name}> id {id:?} is not an integer"))?;
                        ids.insert(id);
                        if d.has_tag_name("lanelet") {
                            lanelets.insert(id);
                        }
                    }
                }
                elements.push(if name == "trafficLight" {
                    rebase_light_cycle(node, text, first_time_step)?
                } else {
                    verbatim(node)
                });
            }
            "dynamicObstacle" | "staticObstacle" => {
                let kind = node.children().find(|n| n.has_tag_name("type")).and_then(|n| n.text());
                if let (Some(id), Some(kind)) = (node.attribute("id"), kind) {
                    obstacle_types.insert(id.trim().to_string(), kind.trim().to_string());
                }
            }
            _ => {}
        }
    }
    Ok(SourceMap { country, location, tags, elements, ids, lanelets, obstacle_types })
}

/// A copied `<trafficLight>` (`light`, in the source `text`) with its
/// cycle's `<timeOffset>` moved so the export's time step 0 shows what the
/// source's `first_time_step` shows. CommonRoad plays a cycle of total
/// length L from its offset on and repeats it, so only the offset modulo L
/// matters; 0 is written as no offset (the schema wants a positive one).
fn rebase_light_cycle(light: roxmltree::Node<'_, '_>, text: &str, first_time_step: usize) -> Result<String, String> {
    let range = light.range();
    let id = light.attribute("id").unwrap_or("?");
    let Some(cycle) = light.children().find(|n| n.has_tag_name("cycle")) else {
        return Ok(text[range].to_string());
    };
    let number = |n: roxmltree::Node<'_, '_>, what: &str| -> Result<u64, String> {
        let raw = n.text().unwrap_or("").trim();
        raw.parse().map_err(|_| format!("traffic light {id}: {what} {raw:?} is not a whole number of steps"))
    };
    let mut length = 0u64;
    for element in cycle.children().filter(|n| n.has_tag_name("cycleElement")) {
        if let Some(d) = element.children().find(|n| n.has_tag_name("duration")) {
            length = length.saturating_add(number(d, "a duration")?);
        }
    }
    if length == 0 {
        return Ok(text[range].to_string());
    }
    let offset_node = cycle.children().find(|n| n.has_tag_name("timeOffset"));
    let offset = offset_node.map(|n| number(n, "the time offset")).transpose()?.unwrap_or(0);
    let shift = first_time_step as u64 % length;
    let rebased = (offset % length + length - shift) % length;
    let element = if rebased == 0 { String::new() } else { format!("<timeOffset>{rebased}</timeOffset>") };
    // Replace the old offset element, or put the new one at the cycle's end.
    let (cut, keep) = match offset_node {
        Some(n) => (n.range(), String::new()),
        None => {
            let end = cycle.range().end;
            let close = text[..end].rfind("</").unwrap_or(end);
            (close..close, "\n      ".to_string())
        }
    };
    let inserted = if element.is_empty() { String::new() } else { format!("{element}{keep}") };
    Ok(format!("{}{}{}", &text[range.start..cut.start], inserted, &text[cut.end..range.end]))
}

/// The lanes of the ego's route (the route the harness sends a planner,
/// following the recording at forks) from the ego's lane to as far as the
/// ego could drive over the rollout: its top speed (started, recorded or
/// driven) times the horizon, plus [`GOAL_REACH_MARGIN_M`].
fn goal_lanes(scenario: &Scenario, rollout: &Rollout, ego_start: &AgentState) -> Vec<MapElementId> {
    let ego = rollout.ego;
    let recorded = recorded_path(scenario, ego, rollout.start_step);
    let mut route = Route::default();
    route.update(&scenario.map, ego_start, &recorded);
    if route.is_empty() {
        return Vec::new();
    }
    let steps = rollout.states.len();
    let recorded_top = scenario.tracks.get(ego.0).map_or(0.0, |t| {
        t.states.iter().skip(rollout.start_step).take(steps).flatten().map(AgentState::speed_mps).fold(0.0, f64::max)
    });
    let driven_top = rollout
        .states
        .iter()
        .filter_map(|row| row.get(ego.0).copied().flatten())
        .map(|s| s.speed_mps())
        .fold(0.0, f64::max);
    let top = ego_start.speed_mps().max(recorded_top).max(driven_top);
    let reach = top * steps.saturating_sub(1) as f64 * rollout.dt_s + GOAL_REACH_MARGIN_M;
    let lanes: Vec<&Lane> = route.lanes().iter().filter_map(|id| scenario.map.lane(*id)).collect();
    let nearest = lanes
        .iter()
        .enumerate()
        .filter_map(|(i, l)| l.centreline.project(&ego_start.position).map(|p| (i, p)))
        .min_by(|a, b| a.1.distance_m.total_cmp(&b.1.distance_m));
    let Some((start, at)) = nearest else { return Vec::new() };
    let mut out = Vec::new();
    let mut ahead = -at.arc_length_m;
    for lane in &lanes[start..] {
        out.push(lane.id);
        ahead += lane.centreline.length_m();
        if ahead >= reach {
            break;
        }
    }
    out
}

/// The converted road: one lanelet per lane, stop signs, traffic lights.
fn write_converted_map(
    x: &mut String,
    scenario: &Scenario,
    first_time_step: usize,
    lanes: &[&Lane],
    lane_ids: &BTreeMap<MapElementId, i64>,
    sign_ids: &[i64],
    light_ids: &[i64],
) {
    let origin = scenario.origin_world;
    let map = &scenario.map;
    let all_bounds: Vec<(Vec<Point2>, Vec<Point2>)> = lanes.iter().map(|l| bounds(l)).collect();
    let opposite = opposite_left_neighbours(lanes, &all_bounds, lane_ids);
    for ((lane, (left, right)), opposite) in lanes.iter().zip(&all_bounds).zip(opposite) {
        let _ = writeln!(x, "  <lanelet id=\"{}\">", lane_ids[&lane.id]);
        for (tag, points) in [("leftBound", left), ("rightBound", right)] {
            let _ = writeln!(x, "    <{tag}>");
            for p in points {
                x.push_str(&point(&(p + origin), "      "));
            }
            let _ = writeln!(x, "    </{tag}>");
        }
        for (tag, refs) in [("predecessor", &lane.predecessors), ("successor", &lane.successors)] {
            for id in refs.iter().filter_map(|id| lane_ids.get(id)) {
                let _ = writeln!(x, "    <{tag} ref=\"{id}\"/>");
            }
        }
        for (tag, refs) in [("adjacentLeft", &lane.left_neighbours), ("adjacentRight", &lane.right_neighbours)] {
            if let Some(id) = refs.iter().find_map(|id| lane_ids.get(id)) {
                let _ = writeln!(x, "    <{tag} ref=\"{id}\" drivingDir=\"same\"/>");
            } else if tag == "adjacentLeft"
                && let Some(id) = opposite
            {
                let _ = writeln!(x, "    <{tag} ref=\"{id}\" drivingDir=\"opposite\"/>");
            }
        }
        if let Some(stop) = lane.stop_line {
            // Across the lanelet at the centreline vertex nearest the stop point.
            let points = lane.centreline.points();
            let i = (0..points.len()).min_by(|&a, &b| (points[a] - stop).norm().total_cmp(&(points[b] - stop).norm()));
            if let Some(i) = i {
                let _ = writeln!(
                    x,
                    "    <stopLine>\n{}{}      <lineMarking>solid</lineMarking>\n    </stopLine>",
                    point(&(left[i] + origin), "      "),
                    point(&(right[i] + origin), "      ")
                );
            }
        }
        let _ = writeln!(x, "    <laneletType>{}</laneletType>", lanelet_type(lane.kind));
        for (sign, id) in map.stop_signs.iter().zip(sign_ids) {
            if sign.lanes.contains(&lane.id) {
                let _ = writeln!(x, "    <trafficSignRef ref=\"{id}\"/>");
            }
        }
        for (signal, id) in map.traffic_signals.iter().zip(light_ids) {
            if signal.lane == lane.id {
                let _ = writeln!(x, "    <trafficLightRef ref=\"{id}\"/>");
            }
        }
        x.push_str("  </lanelet>\n");
    }
    // CommonRoad refuses a sign or light no lanelet refers to.
    let controls = |lanes: &[MapElementId]| lanes.iter().any(|id| lane_ids.contains_key(id));
    for (sign, id) in map.stop_signs.iter().zip(sign_ids).filter(|(s, _)| controls(&s.lanes)) {
        let _ = writeln!(
            x,
            "  <trafficSign id=\"{id}\">\n    <trafficSignElement>\n      <trafficSignID>{STOP_SIGN_ID}</trafficSignID>\n    \
             </trafficSignElement>\n    <position>\n{}    </position>\n    <virtual>false</virtual>\n  </trafficSign>",
            point(&(sign.position + origin), "      ")
        );
    }
    for (signal, id) in map.traffic_signals.iter().zip(light_ids).filter(|(s, _)| controls(&[s.lane])) {
        x.push_str(&traffic_light(signal, *id, origin, first_time_step));
    }
}

/// How close two left bounds run for their lanes to be opposite-direction
/// neighbours, m: one painted line, drawn once per lane.
const OPPOSITE_BOUND_M: f64 = 0.5;

/// Each lane's opposite-direction left neighbour, found from the bounds
/// (the scene's map keeps only same-direction neighbours): the lane of the
/// other direction whose left bound runs along this lane's left bound, within
/// [`OPPOSITE_BOUND_M`], for at least half its points. `None` where there
/// is none, or where the lane has a same-direction left neighbour.
fn opposite_left_neighbours(
    lanes: &[&Lane],
    bounds: &[(Vec<Point2>, Vec<Point2>)],
    lane_ids: &BTreeMap<MapElementId, i64>,
) -> Vec<Option<i64>> {
    let boxes: Vec<(Point2, Point2)> = bounds
        .iter()
        .map(|(left, _)| {
            left.iter().fold((left[0], left[0]), |(lo, hi), p| {
                (Point2::new(lo.x.min(p.x), lo.y.min(p.y)), Point2::new(hi.x.max(p.x), hi.y.max(p.y)))
            })
        })
        .collect();
    let lines: Vec<crate::geometry::Polyline> =
        bounds.iter().map(|(left, _)| crate::geometry::Polyline::new(left.clone())).collect();
    let apart = |a: &(Point2, Point2), b: &(Point2, Point2)| {
        a.0.x > b.1.x + OPPOSITE_BOUND_M
            || b.0.x > a.1.x + OPPOSITE_BOUND_M
            || a.0.y > b.1.y + OPPOSITE_BOUND_M
            || b.0.y > a.1.y + OPPOSITE_BOUND_M
    };
    (0..lanes.len())
        .map(|i| {
            if lanes[i].left_neighbours.iter().any(|id| lane_ids.contains_key(id)) {
                return None;
            }
            let left = &bounds[i].0;
            let matches = |j: usize| {
                left.windows(2)
                    .filter(|w| {
                        let along = w[1] - w[0];
                        let mid = w[0] + along * 0.5;
                        lines[j]
                            .project(&mid)
                            .is_some_and(|q| q.distance_m <= OPPOSITE_BOUND_M && q.tangent.dot(&along) < 0.0)
                    })
                    .count()
            };
            (0..lanes.len())
                .filter(|&j| j != i && !apart(&boxes[i], &boxes[j]))
                .map(|j| (j, matches(j)))
                .filter(|&(_, n)| n > 0 && 2 * n >= left.len() - 1)
                .max_by_key(|&(j, n)| (n, std::cmp::Reverse(j)))
                .and_then(|(j, _)| lane_ids.get(&lanes[j].id).copied())
        })
        .collect()
}

/// A signal's recorded states as a CommonRoad light: one cycle element per
/// run of one colour, from the rollout's first step (the export's time
/// step 0; the cycle repeats after the scene's end, which no rollout
/// reaches).
fn traffic_light(signal: &TrafficSignal, id: i64, origin: Vector2, first_time_step: usize) -> String {
    let states = signal.states.get(first_time_step..).unwrap_or_default();
    let mut runs: Vec<(&str, usize)> = Vec::new();
    for state in states {
        let colour = light_colour(*state);
        match runs.last_mut() {
            Some((c, n)) if *c == colour => *n += 1,
            _ => runs.push((colour, 1)),
        }
    }
    if runs.is_empty() {
        runs.push(("inactive", 1));
    }
    let mut x = format!("  <trafficLight id=\"{id}\">\n    <cycle>\n");
    for (colour, duration) in &runs {
        let _ = writeln!(
            x,
            "      <cycleElement>\n        <duration>{duration}</duration>\n        <color>{colour}</color>\n      </cycleElement>"
        );
    }
    x.push_str("    </cycle>\n");
    if let Some(p) = signal.stop_point {
        let _ = write!(x, "    <position>\n{}    </position>\n", point(&(p + origin), "      "));
    }
    let active = states.iter().any(|s| *s != SignalState::Unknown);
    let _ = writeln!(x, "    <direction>all</direction>\n    <active>{active}</active>\n  </trafficLight>");
    x
}

/// CommonRoad's colour for a signal state (arrows and flashing lights as
/// their colour; an unknown state as an inactive light).
fn light_colour(state: SignalState) -> &'static str {
    match state {
        SignalState::Stop | SignalState::ArrowStop | SignalState::FlashingStop => "red",
        SignalState::Caution | SignalState::ArrowCaution | SignalState::FlashingCaution => "yellow",
        SignalState::Go | SignalState::ArrowGo => "green",
        _ => "inactive",
    }
}

/// The export's header comment: what the file is, its frame and time, the
/// ego's size, the goal, the limits and the renumbered ids.
fn header_comment(s: &ExportSidecar) -> String {
    let mut c = String::new();
    let _ = writeln!(
        c,
        "safer export of variant {} ({}) of scene {} ({} source {}).",
        s.variant,
        if s.shrunk { "shrunk, as safer shows it first" } else { "as generated" },
        s.scenario,
        s.source_format,
        s.source_path
    );
    let _ = writeln!(
        c,
        "Frame: the source's (safer's local frame plus ({}, {}) m). Time: the rollout runs from time step 0 to \
         {} ({} s steps); time step 0 is the source's time step {}.",
        num(s.origin_world_m[0]),
        num(s.origin_world_m[1]),
        s.last_time_step,
        num(s.dt_s),
        s.source_first_time_step
    );
    let _ = writeln!(
        c,
        "Map: {}.",
        if s.map == "copied" {
            "copied from the source file (lanelets, signs, lights, intersections and their ids)"
        } else {
            "converted from the scene's map"
        }
    );
    let _ = writeln!(
        c,
        "Ego: planning problem {} (source id {}), length {} m, width {} m.",
        s.ego.planning_problem_id,
        s.ego.source_id,
        num(s.ego.length_m),
        num(s.ego.width_m)
    );
    if let Some(cbv) = &s.cbv {
        let _ = writeln!(c, "CBV (the adversary): obstacle {} (source id {}).", cbv.obstacle_id, cbv.source_id);
    }
    let lanelets: Vec<String> = s.goal_lanelets.iter().map(i64::to_string).collect();
    let _ = writeln!(c, "Goal: lanelets [{}] at time step {}.", lanelets.join(", "), s.last_time_step);
    let _ = writeln!(c, "Sidecar: the JSON file beside this one, named like it with .commonroad.json.");
    for limit in &s.limits {
        let _ = writeln!(c, "Limit: {limit}.");
    }
    for r in &s.renumbered {
        let _ = writeln!(c, "Renumbered: {} {:?} is {}.", r.element, r.source_id, r.id);
    }
    if !s.late_obstacles.is_empty() {
        let late: Vec<String> = s.late_obstacles.iter().map(i64::to_string).collect();
        let _ = writeln!(
            c,
            "Enter after time step 0 (not allowed by the 2020a schema, read by commonroad-io): obstacles [{}].",
            late.join(", ")
        );
    }
    // A comment cannot hold "--".
    let mut text = c.replace("--", "- -");
    while text.contains("--") {
        text = text.replace("--", "- -");
    }
    let body: Vec<String> = text.lines().map(|l| format!("       {l}")).collect();
    format!("  <!--\n{}\n  -->\n", body.join("\n"))
}

/// A lane's bounds, one point per centreline vertex on either side: the
/// lane's own boundary there (its nearest point, when on that side within
/// the plausible half-widths), else the centreline offset by the default
/// half-width along the mean normal of the segments meeting there.
fn bounds(lane: &Lane) -> (Vec<Point2>, Vec<Point2>) {
    let points = lane.centreline.points();
    let mut left = Vec::with_capacity(points.len());
    let mut right = Vec::with_capacity(points.len());
    for (i, p) in points.iter().enumerate() {
        let before = if i > 0 { p - points[i - 1] } else { points[1] - p };
        let after = if i + 1 < points.len() { points[i + 1] - p } else { p - points[i - 1] };
        let along = before.normalize() + after.normalize();
        let along = if along.norm() > 1e-9 { along.normalize() } else { after.normalize() };
        let normal = Vector2::new(-along.y, along.x);
        let side = |boundary: &Option<crate::geometry::Polyline>, sign: f64| {
            boundary
                .as_ref()
                .and_then(|b| b.project(p))
                .filter(|q| {
                    (MIN_LANE_HALF_WIDTH_M..=MAX_LANE_HALF_WIDTH_M).contains(&q.distance_m)
                        && (q.point - p).dot(&normal) * sign > 0.0
                })
                .map_or(p + normal * (sign * DEFAULT_LANE_HALF_WIDTH_M), |q| q.point)
        };
        left.push(side(&lane.left_boundary, 1.0));
        right.push(side(&lane.right_boundary, -1.0));
    }
    (left, right)
}

fn obstacle_state(tag: &str, time_step: usize, s: &AgentState, origin: Vector2, indent: &str) -> String {
    format!(
        "{indent}<{tag}>\n{}{indent}  <orientation>\n{indent}    <exact>{}</exact>\n{indent}  </orientation>\n\
         {indent}  <time>\n{indent}    <exact>{time_step}</exact>\n{indent}  </time>\n\
         {indent}  <velocity>\n{indent}    <exact>{}</exact>\n{indent}  </velocity>\n{indent}</{tag}>\n",
        position(&(s.position + origin), &format!("{indent}  ")),
        num(s.heading_rad),
        num(s.speed_mps()),
    )
}

fn position(p: &Point2, indent: &str) -> String {
    format!("{indent}<position>\n{}{indent}</position>\n", point(p, &format!("{indent}  ")))
}

fn point(p: &Point2, indent: &str) -> String {
    format!("{indent}<point>\n{indent}  <x>{}</x>\n{indent}  <y>{}</y>\n{indent}</point>\n", num(p.x), num(p.y))
}

/// A number as CommonRoad's readers take it: plain decimal, shortest
/// round-trip form.
fn num(v: f64) -> String {
    if v == 0.0 { "0".into() } else { format!("{v}") }
}

fn attr(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

fn obstacle_type(kind: AgentKind) -> &'static str {
    match kind {
        AgentKind::Vehicle => "car",
        AgentKind::Pedestrian => "pedestrian",
        AgentKind::Cyclist => "bicycle",
        AgentKind::Other => "unknown",
    }
}

fn lanelet_type(kind: LaneKind) -> &'static str {
    match kind {
        LaneKind::Freeway => "highway",
        LaneKind::SurfaceStreet => "urban",
        LaneKind::BikeLane => "bicycleLane",
        LaneKind::BusLane => "busLane",
        LaneKind::Undefined => "unknown",
    }
}

/// The export's date, `YYYY-MM-DD` (UTC), as 2020a's `date` attribute wants.
fn today() -> String {
    let days = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs() / 86_400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planners::BuiltinPlanner;
    use crate::scenario::{TrackIndex, import};
    use crate::sim::{SimConfig, Simulation};

    /// IDM driving the ego of `scene` from its current step.
    fn drive(scene: &Scenario) -> Rollout {
        let config = SimConfig { start_step: Some(scene.current_step), ..SimConfig::default() };
        let ego = scene.ego.unwrap();
        let mut planner = BuiltinPlanner::Idm.instantiate(scene, ego);
        Simulation::new(scene, config).unwrap().run(planner.as_mut())
    }

    /// A shipped NGSIM scene and IDM driving its ego.
    fn variant() -> (Scenario, Rollout) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/ngsim/USA_US101-4_3_T-1.xml");
        let scene = import::load(&path).unwrap().remove(0);
        let rollout = drive(&scene);
        (scene, rollout)
    }

    /// A small CommonRoad scene: an eastbound lanelet 11 with a westbound
    /// one (12) on its left, its successor 13 with a traffic light and a
    /// stop line, a speed-limit sign, and three cars, far from the origin
    /// so the import shifts it.
    fn crossing_source(dir: &Path) -> PathBuf {
        let bound = |y: f64, from: f64, to: f64| {
            format!(
                "<point><x>{}</x><y>{}</y></point><point><x>{}</x><y>{}</y></point><point><x>{}</x><y>{}</y></point>",
                5000.0 + from,
                7000.0 + y,
                5000.0 + 0.5 * (from + to),
                7000.0 + y,
                5000.0 + to,
                7000.0 + y
            )
        };
        let lanelet = |id: i64, left: String, right: String, extra: &str| {
            format!(
                "  <lanelet id=\"{id}\">\n    <leftBound>{left}<lineMarking>solid</lineMarking></leftBound>\n    \
                 <rightBound>{right}</rightBound>\n    {extra}\n  </lanelet>\n"
            )
        };
        let car = |id: i64, x: f64, y: f64, heading: f64, speed: f64| {
            let state = |tag: &str, t: usize| {
                let x = 5000.0 + x + heading.cos() * speed * 0.1 * t as f64;
                format!(
                    "<{tag}><position><point><x>{x}</x><y>{}</y></point></position><orientation><exact>{heading}</exact>\
                     </orientation><time><exact>{t}</exact></time><velocity><exact>{speed}</exact></velocity></{tag}>",
                    7000.0 + y
                )
            };
            let trajectory: String = (1..60).map(|t| state("state", t)).collect();
            format!(
                "  <dynamicObstacle id=\"{id}\"><type>truck</type><shape><rectangle><length>4.6</length><width>1.9</width>\
                 </rectangle></shape>{}<trajectory>{trajectory}</trajectory></dynamicObstacle>\n",
                state("initialState", 0)
            )
        };
        let xml = format!(
            "<?xml version=\"1.0\" ?>\n<commonRoad benchmarkID=\"USA_Test-1_1_T-1\" commonRoadVersion=\"2020a\" \
             timeStepSize=\"0.1\" author=\"a\" affiliation=\"b\" source=\"c\" date=\"2020-01-01\">\n  <location>\
             <geoNameId>1</geoNameId><gpsLatitude>2</gpsLatitude><gpsLongitude>3</gpsLongitude></location>\n  \
             <scenarioTags><urban/></scenarioTags>\n{}{}{}  <trafficSign id=\"31\"><trafficSignElement>\
             <trafficSignID>R2-1</trafficSignID><additionalValue>15</additionalValue></trafficSignElement>\
             <virtual>true</virtual></trafficSign>\n  <trafficLight id=\"41\"><cycle><cycleElement><duration>30\
             </duration><color>green</color></cycleElement><cycleElement><duration>40</duration><color>red</color>\
             </cycleElement><timeOffset>7</timeOffset></cycle></trafficLight>\n{}{}{}  <planningProblem id=\"99\">\
             </planningProblem>\n</commonRoad>\n",
            lanelet(
                11,
                bound(3.5, 0.0, 100.0),
                bound(0.0, 0.0, 100.0),
                "<successor ref=\"13\"/><adjacentLeft ref=\"12\" drivingDir=\"opposite\"/><laneletType>urban\
                 </laneletType><trafficSignRef ref=\"31\"/>"
            ),
            lanelet(
                12,
                bound(3.5, 100.0, 0.0),
                bound(7.0, 100.0, 0.0),
                "<adjacentLeft ref=\"11\" drivingDir=\"opposite\"/><laneletType>urban</laneletType>"
            ),
            lanelet(
                13,
                bound(3.5, 100.0, 200.0),
                bound(0.0, 100.0, 200.0),
                "<predecessor ref=\"11\"/><stopLine><point><x>5200</x><y>7003.5</y></point><point><x>5200</x>\
                 <y>7000</y></point><lineMarking>solid</lineMarking></stopLine><laneletType>urban</laneletType>\
                 <trafficLightRef ref=\"41\"/>"
            ),
            car(1, 20.0, 1.75, 0.0, 10.0),
            car(2, 45.0, 1.75, 0.0, 8.0),
            car(3, 90.0, 5.25, std::f64::consts::PI, 9.0),
        );
        let path = dir.join("USA_Test-1_1_T-1.xml");
        std::fs::write(&path, xml).unwrap();
        path
    }

    /// The crossing scene with car 1 as the ego and car 2 as the CBV, and
    /// IDM driving the ego.
    fn crossing(dir: &Path) -> (Scenario, Rollout, PathBuf) {
        let path = crossing_source(dir);
        let scene = import::load(&path).unwrap().remove(0);
        let index = |id: &str| TrackIndex(scene.tracks.iter().position(|t| t.id.0 == id).unwrap());
        let (ego, cbv) = (index("1"), index("2"));
        let scene = scene.with_roles(ego, Some(cbv));
        let rollout = drive(&scene);
        (scene, rollout, path)
    }

    /// A `<trafficLight>`'s colour at `time_step`, as CommonRoad plays a
    /// cycle: from its offset on, repeated.
    fn light_colour_at(light: roxmltree::Node<'_, '_>, time_step: u64) -> String {
        let cycle = light.children().find(|n| n.has_tag_name("cycle")).unwrap();
        let value = |n: roxmltree::Node<'_, '_>, tag: &str| -> String {
            n.children().find(|c| c.has_tag_name(tag)).unwrap().text().unwrap().trim().to_string()
        };
        let elements: Vec<(u64, String)> = cycle
            .children()
            .filter(|n| n.has_tag_name("cycleElement"))
            .map(|e| (value(e, "duration").parse().unwrap(), value(e, "color")))
            .collect();
        let offset: u64 =
            cycle.children().find(|n| n.has_tag_name("timeOffset")).map_or(0, |n| n.text().unwrap().parse().unwrap());
        let length: u64 = elements.iter().map(|(d, _)| d).sum();
        let mut phase = (time_step + length - offset % length) % length;
        for (duration, colour) in elements {
            if phase < duration {
                return colour;
            }
            phase -= duration;
        }
        unreachable!()
    }

    fn doc_ids(root: roxmltree::Node<'_, '_>, tag: &str) -> Vec<i64> {
        root.children().filter(|n| n.has_tag_name(tag)).map(|n| n.attribute("id").unwrap().parse().unwrap()).collect()
    }

    #[test]
    fn a_commonroad_source_is_copied_with_its_ids_lights_and_bounds_in_its_frame() {
        let dir = tempfile::tempdir().unwrap();
        let (scene, rollout, path) = crossing(dir.path());
        assert_ne!(scene.origin_world, Vector2::zeros(), "the import shifts the scene");
        let export = commonroad_export(&scene, &rollout, "s::USA_Test-1_1_T-1::seed-0", true).unwrap();
        assert_eq!(export.sidecar.map, "copied");
        assert!(export.notes.is_empty(), "{:?}", export.notes);
        let source_text = std::fs::read_to_string(&path).unwrap();
        let source = roxmltree::Document::parse(&source_text).unwrap();
        let doc = roxmltree::Document::parse(&export.xml).unwrap();
        let root = doc.root_element();
        assert_eq!(root.attribute("benchmarkID"), Some("USA_Safer-1_1_T-1"), "US sign ids keep their country");
        // Lanelets and the sign: the source's elements, ids and all.
        for tag in ["lanelet", "trafficSign"] {
            let theirs: Vec<String> = source
                .root_element()
                .children()
                .filter(|n| n.has_tag_name(tag))
                .map(|n| source_text[n.range()].to_string())
                .collect();
            let ours: Vec<String> =
                root.children().filter(|n| n.has_tag_name(tag)).map(|n| export.xml[n.range()].to_string()).collect();
            assert_eq!(ours, theirs, "{tag}");
        }
        assert_eq!(doc_ids(root, "trafficLight"), vec![41]);
        // The light: the source's, its cycle re-based so that the export's
        // time step t shows what the source shows at t + first.
        let first = rollout.start_step as u64;
        let is_light = |n: &roxmltree::Node<'_, '_>| n.has_tag_name("trafficLight");
        let theirs = source.root_element().children().find(is_light).unwrap();
        let ours = root.children().find(is_light).unwrap();
        assert!(first > 0 && !first.is_multiple_of(70), "the re-basing is exercised: first time step {first}");
        for t in 0..140 {
            assert_eq!(light_colour_at(ours, t), light_colour_at(theirs, t + first), "time step {t}");
        }
        assert!(export.xml.contains("<adjacentLeft ref=\"12\" drivingDir=\"opposite\"/>"));
        // Obstacles keep their ids and the source's type; the ego is the
        // planning problem, under its own id.
        assert_eq!(doc_ids(root, "dynamicObstacle"), vec![2, 3]);
        assert_eq!(doc_ids(root, "planningProblem"), vec![1]);
        assert!(export.xml.contains("<type>truck</type>"));
        assert_eq!(export.sidecar.cbv, Some(SidecarObstacle { source_id: "2".into(), obstacle_id: 2 }));
        assert!(export.sidecar.renumbered.is_empty());
        // Frame: the source's; time step 0 is the rollout's first step. Car 3
        // at time step 0 is where the source has it at that step.
        let obstacle = root.children().find(|n| n.attribute("id") == Some("3")).unwrap();
        let initial = obstacle.children().find(|n| n.has_tag_name("initialState")).unwrap();
        let text = |tag: &str| -> f64 {
            let node = initial.descendants().find(|n| n.has_tag_name(tag)).unwrap();
            let value = node.descendants().find(|n| n.has_tag_name("exact")).unwrap_or(node);
            value.text().unwrap().trim().parse().unwrap()
        };
        assert_eq!(text("time"), 0.0);
        let (x, y) = (text("x"), text("y"));
        assert!((x - (5090.0 - 0.9 * first as f64)).abs() < 1e-6 && (y - 7005.25).abs() < 1e-9, "({x}, {y})");
        assert_eq!(export.sidecar.origin_world_m, [scene.origin_world.x, scene.origin_world.y]);
        // The import reads it back: the same lights and lanelets.
        let back = import::commonroad::parse(export.xml.as_bytes(), Path::new("export.xml")).unwrap();
        let again = import::commonroad::parse(source_text.as_bytes(), &path).unwrap();
        assert_eq!(back.map.traffic_signals.len(), again.map.traffic_signals.len());
        assert_eq!(back.map.lanes.len(), 3);
    }

    #[test]
    fn a_changed_source_falls_back_to_the_conversion_and_says_why() {
        let dir = tempfile::tempdir().unwrap();
        let (scene, rollout, path) = crossing(dir.path());
        let moved = std::fs::read_to_string(&path).unwrap().replace("<y>7007</y>", "<y>7008</y>");
        std::fs::write(&path, moved).unwrap();
        let export = commonroad_export(&scene, &rollout, "v", false).unwrap();
        assert_eq!(export.sidecar.map, "converted");
        assert!(export.notes[0].contains("no longer holds the scene (lanelet 12 differs)"), "{:?}", export.notes);
        assert!(export.xml.contains("Limit: map converted, not copied"));
        std::fs::remove_file(&path).unwrap();
        let export = commonroad_export(&scene, &rollout, "v", false).unwrap();
        assert!(export.notes[0].contains("cannot be read"), "{:?}", export.notes);
        // Converted: lanelet ids are the lanes' own, the light a new one,
        // bounds the lanes' own boundaries (3.5 m wide, not 2 × default).
        let doc = roxmltree::Document::parse(&export.xml).unwrap();
        let root = doc.root_element();
        assert_eq!(doc_ids(root, "lanelet"), vec![11, 12, 13]);
        assert_eq!(doc_ids(root, "trafficLight").len(), 1);
        let lanelet = root.children().find(|n| n.attribute("id") == Some("11")).unwrap();
        let ys: Vec<f64> = ["leftBound", "rightBound"]
            .iter()
            .map(|b| {
                let bound = lanelet.children().find(|n| n.has_tag_name(*b)).unwrap();
                bound.descendants().find(|n| n.has_tag_name("y")).unwrap().text().unwrap().parse().unwrap()
            })
            .collect();
        assert!((ys[0] - 7003.5).abs() < 1e-6 && (ys[1] - 7000.0).abs() < 1e-6, "{ys:?}");
        // The westbound lane beside it is found again as its opposite-direction neighbour.
        let adjacent = |id: &str| {
            let lanelet = root.children().find(|n| n.attribute("id") == Some(id)).unwrap();
            let a = lanelet.children().find(|n| n.has_tag_name("adjacentLeft")).unwrap();
            (a.attribute("ref").unwrap().to_string(), a.attribute("drivingDir").unwrap().to_string())
        };
        assert_eq!(adjacent("11"), ("12".into(), "opposite".into()));
        assert_eq!(adjacent("12"), ("11".into(), "opposite".into()));
        assert!(
            root.children()
                .find(|n| n.attribute("id") == Some("13"))
                .unwrap()
                .children()
                .all(|n| !n.has_tag_name("adjacentLeft"))
        );
    }

    #[test]
    fn the_goal_is_the_route_over_the_horizon_and_the_size_is_written() {
        let (scene, rollout) = variant();
        let export = commonroad_export(&scene, &rollout, "suite::USA_US101-4_3_T-1::seed-0", false).unwrap();
        let s = &export.sidecar;
        let last = rollout.states.len() - 1;
        assert_eq!((s.source_first_time_step, s.last_time_step), (rollout.start_step, last));
        let body = &rollout.bodies[rollout.ego.0];
        assert_eq!((s.ego.length_m, s.ego.width_m), (body.length_m, body.width_m));
        assert!(export.xml.contains(&format!("length {} m, width {} m", num(body.length_m), num(body.width_m))));
        // The goal holds the lanelets the ego drove through, at the last step.
        let doc = roxmltree::Document::parse(&export.xml).unwrap();
        let goal = doc.descendants().find(|n| n.has_tag_name("goalState")).unwrap();
        let refs: Vec<i64> = goal
            .descendants()
            .filter(|n| n.has_tag_name("lanelet"))
            .map(|n| n.attribute("ref").unwrap().parse().unwrap())
            .collect();
        assert_eq!(refs, s.goal_lanelets);
        let ego_end = rollout.states.last().unwrap()[rollout.ego.0].unwrap().position;
        let end_lane = scene.map.lanes.iter().min_by(|a, b| {
            let d = |l: &Lane| l.centreline.project(&ego_end).unwrap().distance_m;
            d(a).total_cmp(&d(b))
        });
        assert!(refs.contains(&end_lane.unwrap().id.0), "{refs:?} lacks the lane the ego ends on");
        let interval =
            |tag: &str| goal.descendants().find(|n| n.has_tag_name(tag)).unwrap().text().unwrap().to_string();
        assert_eq!((interval("intervalStart"), interval("intervalEnd")), (last.to_string(), last.to_string()));
        // Ids unique across lanelets, obstacles and the planning problem.
        let ids: Vec<&str> = doc.root_element().children().filter_map(|n| n.attribute("id")).collect();
        let unique: BTreeSet<&&str> = ids.iter().collect();
        assert_eq!(unique.len(), ids.len());
    }

    #[test]
    fn clashing_ids_are_renumbered_and_listed() {
        let (mut scene, mut rollout) = variant();
        // Authored-style ids: an obstacle named like a lanelet, one not a number.
        let lane = scene.map.lanes[0].id.0.to_string();
        let present = |a: usize| rollout.states.iter().any(|row| row[a].is_some());
        let others: Vec<usize> =
            (0..rollout.agent_ids.len()).filter(|&a| a != rollout.ego.0 && present(a)).take(2).collect();
        rollout.agent_ids[others[0]].0 = lane.clone();
        rollout.agent_ids[others[1]].0 = "lead car".into();
        scene.source.format = SourceFormat::Authored;
        // A stop sign on the first lane is written and referenced; one that
        // controls no lane is left out (CommonRoad refuses it).
        let p = scene.map.lanes[0].centreline.points()[0];
        scene.map.stop_signs.push(crate::map::StopSign::new(MapElementId(77_777), p, vec![scene.map.lanes[0].id]));
        scene.map.stop_signs.push(crate::map::StopSign::new(MapElementId(88_888), p, vec![]));
        let export = commonroad_export(&scene, &rollout, "v", false).unwrap();
        assert!(export.xml.contains("<trafficSign id=\"77777\">") && !export.xml.contains("88888"));
        assert!(export.xml.contains("<trafficSignRef ref=\"77777\"/>"));
        let renumbered: Vec<(&str, &str)> =
            export.sidecar.renumbered.iter().map(|r| (r.element, r.source_id.as_str())).collect();
        assert_eq!(renumbered, vec![("obstacle", lane.as_str()), ("obstacle", "lead car")]);
        assert!(export.xml.contains(&format!("Renumbered: obstacle \"{lane}\" is")));
        let doc = roxmltree::Document::parse(&export.xml).unwrap();
        let ids: Vec<i64> =
            doc.root_element().children().filter_map(|n| n.attribute("id")).map(|i| i.parse().unwrap()).collect();
        assert!(ids.iter().all(|&i| i > 0));
        assert_eq!(ids.iter().collect::<BTreeSet<_>>().len(), ids.len());
    }

    #[test]
    fn the_start_carries_the_egos_motion_and_late_or_fleeting_agents_are_said() {
        let (mut scene, mut rollout) = variant();
        let ego = rollout.ego.0;
        // The recording's step before the start: slower and turned right.
        let before = scene.tracks[ego].states[rollout.start_step - 1].as_mut().unwrap();
        before.velocity_mps *= 0.9;
        before.heading_rad -= 0.02;
        // One agent enters late, another is there for one step only.
        let present = |r: &Rollout, a: usize| r.states.iter().filter(|row| row[a].is_some()).count();
        let others: Vec<usize> =
            (0..rollout.agent_ids.len()).filter(|&a| a != ego && present(&rollout, a) > 5).collect();
        let (late, fleeting) = (others[0], others[1]);
        rollout.states[0][late] = None;
        for row in rollout.states.iter_mut().skip(1) {
            row[fleeting] = None;
        }
        let export = commonroad_export(&scene, &rollout, "v", false).unwrap();
        let doc = roxmltree::Document::parse(&export.xml).unwrap();
        let root = doc.root_element();
        let late_id: i64 = rollout.agent_ids[late].0.parse().unwrap();
        let fleeting_id = rollout.agent_ids[fleeting].0.clone();
        assert_eq!(export.sidecar.late_obstacles, vec![late_id]);
        assert!(!doc_ids(root, "dynamicObstacle").contains(&fleeting_id.parse().unwrap()), "{fleeting_id} left out");
        assert!(export.sidecar.limits.iter().any(|l| l.starts_with("1 agent(s) seen at a single step")));
        assert_eq!(export.sidecar.left_out, vec![fleeting_id.clone()]);
        // Every other obstacle starts at time step 0, as the planning problem does.
        let start_time = |n: roxmltree::Node<'_, '_>| -> String {
            let initial = n.children().find(|c| c.has_tag_name("initialState")).unwrap();
            let time = initial.children().find(|c| c.has_tag_name("time")).unwrap();
            time.descendants().find(|c| c.has_tag_name("exact")).unwrap().text().unwrap().trim().to_string()
        };
        for n in root.children().filter(|n| n.has_tag_name("dynamicObstacle") || n.has_tag_name("planningProblem")) {
            let id: i64 = n.attribute("id").unwrap().parse().unwrap();
            assert_eq!(start_time(n) == "0", id != late_id, "obstacle {id} starts at {}", start_time(n));
        }
        // The ego's acceleration and yaw rate at the start: what its planner is told.
        let previous = scene.tracks[ego].state(rollout.start_step - 1).copied();
        let start = rollout.states[0][ego].unwrap();
        let motion = crate::planners::EgoMotion::between(previous.as_ref(), &start, rollout.dt_s);
        assert!(motion.accel_mps2 > 0.0 && motion.yaw_rate_radps > 0.0, "{motion:?}");
        let problem = root.children().find(|n| n.has_tag_name("planningProblem")).unwrap();
        let exact = |tag: &str| -> f64 {
            let node = problem.descendants().find(|n| n.has_tag_name(tag)).unwrap();
            node.descendants().find(|n| n.has_tag_name("exact")).unwrap().text().unwrap().trim().parse().unwrap()
        };
        assert_eq!(exact("acceleration"), motion.accel_mps2);
        assert_eq!(exact("yawRate"), motion.yaw_rate_radps);
    }

    #[test]
    fn safers_importer_reads_an_export_back_to_the_same_scene() {
        let (scene, rollout) = variant();
        let export = commonroad_export(&scene, &rollout, "suite::USA_US101-4_3_T-1::seed-0", false).unwrap();
        assert_eq!(export.sidecar.map, "copied");
        let back = import::commonroad::parse(export.xml.as_bytes(), Path::new("export.xml")).unwrap();
        assert_eq!(back.id, "USA_Safer-1_1_T-1");
        assert_eq!(back.dt_s, rollout.dt_s);
        // Every agent but the ego, in order, at every step it was there (from
        // its first appearance to its first absence), within 1 cm, in the
        // source's frame and at the source's time steps.
        let origin = scene.origin_world;
        let others: Vec<usize> = (0..rollout.bodies.len())
            .filter(|&a| a != rollout.ego.0 && rollout.states.iter().any(|row| row[a].is_some()))
            .collect();
        assert_eq!(back.tracks.len(), others.len());
        let mut compared = 0;
        for (track, &agent) in back.tracks.iter().zip(&others) {
            assert_eq!(track.id, rollout.agent_ids[agent]);
            let first = rollout.states.iter().position(|row| row[agent].is_some()).unwrap();
            for (k, row) in rollout.states.iter().enumerate().skip(first) {
                let Some(sent) = row[agent] else { break };
                let t = k;
                let got = track.state(t).unwrap_or_else(|| panic!("{} missing at time step {t}", track.id.0));
                assert!((got.position - (sent.position + origin)).norm() < 0.01, "{} at step {k}", track.id.0);
                assert!((got.heading_rad - sent.heading_rad).abs() < 1e-6);
                assert!((got.speed_mps() - sent.speed_mps()).abs() < 1e-6);
                compared += 1;
            }
            assert_eq!(track.length_m, rollout.bodies[agent].length_m);
        }
        assert!(compared > 500, "{compared} states compared");
        // The lanes: the source's, in the source's frame.
        assert_eq!(back.map.lanes.len(), scene.map.lanes.len());
        for (got, sent) in back.map.lanes.iter().zip(&scene.map.lanes) {
            assert_eq!(got.id, sent.id);
            for (p, q) in got.centreline.points().iter().zip(sent.centreline.points()) {
                assert!((p - (q + origin)).norm() < 1e-3, "lane {:?}", sent.id);
            }
        }
    }

    #[test]
    fn the_export_is_well_formed_and_names_its_variant() {
        let (scene, rollout) = variant();
        let xml = commonroad_export(&scene, &rollout, "a<b>&\"c\"--d", true).unwrap().xml;
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let root = doc.root_element();
        assert_eq!(root.attribute("commonRoadVersion"), Some("2020a"));
        assert!(root.attribute("source").unwrap().contains("a<b>&\"c\"--d (shrunk)"));
        let problem = root.children().find(|n| n.has_tag_name("planningProblem")).unwrap();
        assert!(problem.descendants().any(|n| n.has_tag_name("goalState")));
        assert_eq!(today().len(), 10);
    }
}
