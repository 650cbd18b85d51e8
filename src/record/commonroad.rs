//! A variant as a CommonRoad 2020a scenario, so a team can open a failing
//! variant in CommonRoad's tools (and, through the CommonRoad scenario
//! designer, in OpenDRIVE and CARLA): the lanelet network from the map,
//! every agent but the ego as a dynamic obstacle driving its stage-2
//! trajectory, and the ego as the planning problem (its initial state, and
//! a goal region where the recording had it at the end, within the
//! rollout's time).
//!
//! Ids are renumbered (CommonRoad wants positive ids, unique across
//! lanelets, obstacles and planning problems): lanelets from 1, then the
//! obstacles, then the planning problem. Each lanelet's bounds are its
//! centreline's vertices offset sideways by the lane's half-width (from the
//! source's boundary where it has one, else the default), so both bounds
//! have the same number of points and their mean is the centreline. Time
//! step 0 is the rollout's first step; an agent that leaves and comes back
//! is exported up to its first absence (CommonRoad trajectories have no
//! gaps).

use std::fmt::Write as _;
use std::path::Path;

use super::RecordError;
use crate::geometry::{Point2, Polyline, Vector2};
use crate::map::{DEFAULT_LANE_HALF_WIDTH_M, Lane, LaneKind, MAX_LANE_HALF_WIDTH_M, MIN_LANE_HALF_WIDTH_M};
use crate::scenario::{AgentKind, AgentState, Scenario};
use crate::sim::Rollout;

/// The benchmark id of every export: a fictitious country (`ZAM`, as
/// CommonRoad's own made-up scenarios) so that no export passes for a
/// recorded benchmark; the variant is named in `source`.
pub const BENCHMARK_ID: &str = "ZAM_Safer-1_1_T-1";

/// Length and width of the goal region around the recorded ego's last
/// position, m.
const GOAL_SIZE_M: (f64, f64) = (10.0, 4.0);

/// The stage-2 `rollout` of `variant` (a variant of `scenario`) as a
/// CommonRoad 2020a document.
pub fn commonroad_xml(scenario: &Scenario, rollout: &Rollout, variant: &str) -> Result<String, RecordError> {
    let inconsistent = |what: String| RecordError::InconsistentRollout { scenario: scenario.id.clone(), what };
    if rollout.dt_s.is_nan() || rollout.dt_s <= 0.0 {
        return Err(inconsistent(format!("step length {} s is not positive", rollout.dt_s)));
    }
    let ego = rollout.ego.0;
    let state = |step: usize, agent: usize| rollout.states.get(step).and_then(|row| row.get(agent)).copied().flatten();
    let ego_start = state(0, ego).ok_or_else(|| inconsistent("the ego is absent at the first step".into()))?;
    let mut x = String::new();
    let _ = writeln!(x, "<?xml version='1.0' encoding='UTF-8'?>");
    let _ = writeln!(
        x,
        "<commonRoad timeStepSize=\"{}\" commonRoadVersion=\"2020a\" author=\"safer\" affiliation=\"safer\" \
         source=\"{}\" benchmarkID=\"{BENCHMARK_ID}\" date=\"{}\">",
        num(rollout.dt_s),
        attr(&format!("safer variant {variant} of scenario {}", scenario.id)),
        today()
    );
    x.push_str(
        "  <location>\n    <geoNameId>-999</geoNameId>\n    <gpsLatitude>999</gpsLatitude>\n    \
         <gpsLongitude>999</gpsLongitude>\n  </location>\n  <scenarioTags>\n    <Critical/>\n  </scenarioTags>\n",
    );

    // Lanelets, renumbered from 1 in the map's order.
    let lanes: Vec<&Lane> = scenario.map.lanes.iter().filter(|l| l.centreline.len() >= 2).collect();
    let lanelet_id = |id| lanes.iter().position(|l| l.id == id).map(|i| i + 1);
    for (i, lane) in lanes.iter().enumerate() {
        let (left, right) = bounds(lane);
        let _ = writeln!(x, "  <lanelet id=\"{}\">", i + 1);
        for (tag, points) in [("leftBound", &left), ("rightBound", &right)] {
            let _ = writeln!(x, "    <{tag}>");
            for p in points {
                let _ = writeln!(
                    x,
                    "      <point>\n        <x>{}</x>\n        <y>{}</y>\n      </point>",
                    num(p.x),
                    num(p.y)
                );
            }
            let _ = writeln!(x, "    </{tag}>");
        }
        for (tag, ids) in [("predecessor", &lane.predecessors), ("successor", &lane.successors)] {
            for id in ids.iter().filter_map(|&id| lanelet_id(id)) {
                let _ = writeln!(x, "    <{tag} ref=\"{id}\"/>");
            }
        }
        for (tag, ids) in [("adjacentLeft", &lane.left_neighbours), ("adjacentRight", &lane.right_neighbours)] {
            if let Some(id) = ids.iter().find_map(|&id| lanelet_id(id)) {
                let _ = writeln!(x, "    <{tag} ref=\"{id}\" drivingDir=\"same\"/>");
            }
        }
        let _ = writeln!(x, "    <laneletType>{}</laneletType>", lanelet_type(lane.kind));
        x.push_str("  </lanelet>\n");
    }

    // Every agent but the ego, from its first appearance to its first absence.
    let mut next_id = lanes.len() + 1;
    for (agent, body) in rollout.bodies.iter().enumerate().filter(|&(a, _)| a != ego) {
        let Some(first) = (0..rollout.states.len()).find(|&k| state(k, agent).is_some()) else { continue };
        let run: Vec<(usize, AgentState)> =
            (first..rollout.states.len()).map_while(|k| state(k, agent).map(|s| (k, s))).collect();
        let _ = writeln!(x, "  <dynamicObstacle id=\"{next_id}\">");
        next_id += 1;
        let _ = writeln!(x, "    <type>{}</type>", obstacle_type(body.kind));
        let _ = writeln!(
            x,
            "    <shape>\n      <rectangle>\n        <length>{}</length>\n        <width>{}</width>\n      </rectangle>\n    </shape>",
            num(body.length_m),
            num(body.width_m)
        );
        let (k0, s0) = run[0];
        x.push_str(&obstacle_state("initialState", k0, &s0, "    "));
        if run.len() > 1 {
            x.push_str("    <trajectory>\n");
            for (k, s) in &run[1..] {
                x.push_str(&obstacle_state("state", *k, s, "      "));
            }
            x.push_str("    </trajectory>\n");
        }
        x.push_str("  </dynamicObstacle>\n");
    }

    // The ego's planning problem: start as it started; goal where the
    // recording had it at the rollout's last step (else its start), any
    // time within the rollout.
    let last = rollout.states.len().saturating_sub(1);
    let goal = scenario.tracks.get(ego).and_then(|t| t.state(rollout.start_step + last)).copied().unwrap_or(ego_start);
    let _ = writeln!(x, "  <planningProblem id=\"{next_id}\">");
    let _ = writeln!(
        x,
        "    <initialState>\n{}      <orientation>\n        <exact>{}</exact>\n      </orientation>\n      \
         <time>\n        <exact>0</exact>\n      </time>\n      <velocity>\n        <exact>{}</exact>\n      </velocity>\n      \
         <yawRate>\n        <exact>0</exact>\n      </yawRate>\n      <slipAngle>\n        <exact>0</exact>\n      </slipAngle>\n    \
         </initialState>",
        position(&ego_start.position, "      "),
        num(ego_start.heading_rad),
        num(ego_start.speed_mps())
    );
    let _ = writeln!(
        x,
        "    <goalState>\n      <position>\n        <rectangle>\n          <length>{}</length>\n          <width>{}</width>\n          \
         <orientation>{}</orientation>\n          <center>\n            <x>{}</x>\n            <y>{}</y>\n          </center>\n        \
         </rectangle>\n      </position>\n      <time>\n        <intervalStart>0</intervalStart>\n        <intervalEnd>{last}</intervalEnd>\n      \
         </time>\n    </goalState>\n  </planningProblem>",
        num(GOAL_SIZE_M.0),
        num(GOAL_SIZE_M.1),
        num(goal.heading_rad),
        num(goal.position.x),
        num(goal.position.y)
    );
    x.push_str("</commonRoad>\n");
    Ok(x)
}

/// Writes [`commonroad_xml`] to `path` (atomically: a reader never sees half a file).
pub fn write_commonroad(path: &Path, scenario: &Scenario, rollout: &Rollout, variant: &str) -> Result<(), RecordError> {
    let text = commonroad_xml(scenario, rollout, variant)?;
    super::write_output(path, text.as_bytes())
}

/// A lane's bounds: its centreline's vertices offset by its half-width to
/// either side (along the mean normal of the segments meeting there).
fn bounds(lane: &Lane) -> (Vec<Point2>, Vec<Point2>) {
    let points = lane.centreline.points();
    let half_width = |boundary: &Option<Polyline>, p: &Point2| {
        boundary
            .as_ref()
            .and_then(|b| b.project(p))
            .map_or(DEFAULT_LANE_HALF_WIDTH_M, |b| b.distance_m.clamp(MIN_LANE_HALF_WIDTH_M, MAX_LANE_HALF_WIDTH_M))
    };
    let mut left = Vec::with_capacity(points.len());
    let mut right = Vec::with_capacity(points.len());
    for (i, p) in points.iter().enumerate() {
        let before = if i > 0 { p - points[i - 1] } else { points[1] - p };
        let after = if i + 1 < points.len() { points[i + 1] - p } else { p - points[i - 1] };
        let along = before.normalize() + after.normalize();
        let along = if along.norm() > 1e-9 { along.normalize() } else { after.normalize() };
        let normal = Vector2::new(-along.y, along.x);
        left.push(p + normal * half_width(&lane.left_boundary, p));
        right.push(p - normal * half_width(&lane.right_boundary, p));
    }
    // The mean of the bounds is the centreline only where both offsets are
    // equal: use the smaller on both sides where they differ.
    for i in 0..points.len() {
        let (l, r) = ((left[i] - points[i]).norm(), (right[i] - points[i]).norm());
        if (l - r).abs() > 1e-9 {
            let w = l.min(r);
            let normal = (left[i] - points[i]) / l;
            left[i] = points[i] + normal * w;
            right[i] = points[i] - normal * w;
        }
    }
    (left, right)
}

fn obstacle_state(tag: &str, step: usize, s: &AgentState, indent: &str) -> String {
    format!(
        "{indent}<{tag}>\n{}{indent}  <orientation>\n{indent}    <exact>{}</exact>\n{indent}  </orientation>\n\
         {indent}  <time>\n{indent}    <exact>{step}</exact>\n{indent}  </time>\n\
         {indent}  <velocity>\n{indent}    <exact>{}</exact>\n{indent}  </velocity>\n{indent}</{tag}>\n",
        position(&s.position, &format!("{indent}  ")),
        num(s.heading_rad),
        num(s.speed_mps()),
    )
}

fn position(p: &Point2, indent: &str) -> String {
    format!(
        "{indent}<position>\n{indent}  <point>\n{indent}    <x>{}</x>\n{indent}    <y>{}</y>\n{indent}  </point>\n{indent}</position>\n",
        num(p.x),
        num(p.y)
    )
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
    use crate::scenario::import;
    use crate::sim::{SimConfig, Simulation};

    /// IDM driving the ego of a shipped NGSIM scene from its current step.
    fn variant() -> (Scenario, Rollout) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/ngsim/USA_US101-4_3_T-1.xml");
        let scene = import::load(&path).unwrap().remove(0);
        let config = SimConfig { start_step: Some(scene.current_step), ..SimConfig::default() };
        let ego = scene.ego.unwrap();
        let mut planner = BuiltinPlanner::Idm.instantiate(&scene, ego);
        let rollout = Simulation::new(&scene, config).unwrap().run(planner.as_mut());
        (scene, rollout)
    }

    #[test]
    fn safers_importer_reads_an_export_back_to_the_same_scene() {
        let (scene, rollout) = variant();
        let xml = commonroad_xml(&scene, &rollout, "suite::USA_US101-4_3_T-1::seed-0").unwrap();
        let back = import::commonroad::parse(xml.as_bytes(), Path::new("export.xml")).unwrap();
        assert_eq!(back.id, BENCHMARK_ID);
        assert_eq!(back.dt_s, rollout.dt_s);
        // Every agent but the ego, in order, at every step it was there (from
        // its first appearance to its first absence), within 1 cm.
        let others: Vec<usize> = (0..rollout.bodies.len())
            .filter(|&a| a != rollout.ego.0 && rollout.states.iter().any(|row| row[a].is_some()))
            .collect();
        assert_eq!(back.tracks.len(), others.len());
        let mut compared = 0;
        for (track, &agent) in back.tracks.iter().zip(&others) {
            let first = rollout.states.iter().position(|row| row[agent].is_some()).unwrap();
            for (k, row) in rollout.states.iter().enumerate().skip(first) {
                let Some(sent) = row[agent] else { break };
                let got = track.state(k).unwrap_or_else(|| panic!("{} missing at step {k}", track.id.0));
                assert!((got.position - sent.position).norm() < 0.01, "{} at step {k}", track.id.0);
                assert!((got.heading_rad - sent.heading_rad).abs() < 1e-6);
                assert!((got.speed_mps() - sent.speed_mps()).abs() < 1e-6);
                compared += 1;
            }
            assert_eq!(track.length_m, rollout.bodies[agent].length_m);
        }
        assert!(compared > 500, "{compared} states compared");
        // The lanes: as many, each centreline within 1 cm of the source's.
        assert_eq!(back.map.lanes.len(), scene.map.lanes.len());
        for (got, sent) in back.map.lanes.iter().zip(&scene.map.lanes) {
            for p in got.centreline.points() {
                let off = sent.centreline.project(p).unwrap().distance_m;
                assert!(off < 0.01, "lane {:?}: {off} m off the source centreline", sent.id);
            }
            assert_eq!(got.successors.len(), sent.successors.len(), "lane {:?}", sent.id);
        }
    }

    #[test]
    fn the_export_is_well_formed_and_names_its_variant() {
        let (scene, rollout) = variant();
        let xml = commonroad_xml(&scene, &rollout, "a<b>&\"c\"").unwrap();
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let root = doc.root_element();
        assert_eq!(root.attribute("commonRoadVersion"), Some("2020a"));
        assert!(root.attribute("source").unwrap().contains("a<b>&\"c\""));
        let problem = root.children().find(|n| n.has_tag_name("planningProblem")).unwrap();
        assert!(problem.descendants().any(|n| n.has_tag_name("goalState")));
        // Ids unique across lanelets, obstacles and the planning problem.
        let ids: Vec<&str> = root.children().filter_map(|n| n.attribute("id")).collect();
        let unique: std::collections::BTreeSet<&&str> = ids.iter().collect();
        assert_eq!(unique.len(), ids.len());
        assert_eq!(today().len(), 10);
    }
}
