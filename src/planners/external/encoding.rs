//! Translation between the simulator's types and the wire messages: an
//! [`Observation`] becomes an `observation` message (the map clipped to
//! [`MAP_RADIUS_M`] around the ego and resampled every [`MAP_SPACING_M`],
//! the route hint ahead of the ego), and a reply line becomes a
//! [`PlannerOutput`] ([`decode_reply`]: strict JSON parsing, non-finite
//! numbers named, trajectories checked). Offending lines are quoted in the
//! errors, truncated to 200 characters.

pub(super) use super::road_edges::road_edges;
use super::wire::{
    HarnessMessage, MAX_DEBUG_BYTES, PlannerMessage, WireAgent, WireEgo, WireFullLane, WireFullMap, WireLane, WireMap,
    WirePoint, WireSignal, WireSignalStop, WireStopSign,
};
use crate::geometry::{Point2, Polyline, Vector2};
use crate::map::{Lane, RoadMap};
use crate::motion::Action;
use crate::motion::kinematics::steering_angle_rad;
use crate::planners::lane_walk::{samples, walk_lanes};
use crate::planners::route::Route as StableRoute;
use crate::planners::{Observation, PlannerOutput, TrajectoryPoint};
use crate::scenario::AgentState;

/// Map elements (lane centrelines, road edges) are sent only where they lie
/// within this distance of the ego's centre, m.
pub const MAP_RADIUS_M: f64 = 60.0;

pub use crate::planners::lane_walk::MAP_SPACING_M;

/// Length of the `route` hint ahead of the ego, m.
pub const ROUTE_LENGTH_M: f64 = 100.0;

/// How far from the ego its lane is searched for the route hint, m.
const ROUTE_LANE_SEARCH_M: f64 = 10.0;
/// Lanes followed at most for the route hint (guards against zero-length
/// successor cycles in imported maps).
const ROUTE_MAX_LANES: usize = 64;
/// Characters of an offending line quoted in an error.
const QUOTE_CHARS: usize = 200;

/// The `observation` message of protocol 1.1 for one step: no map (the
/// planner has it from `prepare`) and the stable route.
pub(super) fn observation_message_v11(obs: &Observation<'_>, route: &StableRoute, route_s_m: f64) -> HarnessMessage {
    observation_with(
        obs,
        None,
        route.points.clone(),
        Some(route.lanes.iter().map(|l| l.0).collect()),
        Some(route.revision),
        Some(route_s_m),
    )
}

/// A polyline resampled every [`MAP_SPACING_M`] or less, as [x, y] pairs.
fn resampled(line: &Polyline) -> Vec<[f64; 2]> {
    samples(line, 0.0, line.length_m()).map(|p| [p.x, p.y]).collect()
}

/// The whole map, for `prepare`.
pub(super) fn full_map(map: &RoadMap) -> WireFullMap {
    let ids = |v: &[crate::map::MapElementId]| v.iter().map(|i| i.0).collect::<Vec<_>>();
    // The lane graph's links: recorded, else joined by geometry (a source
    // without connectivity), as safer's own routes follow them.
    let graph = map.lane_graph();
    let linked = |lanes: &[usize]| lanes.iter().map(|&j| map.lanes[j].id.0).collect::<Vec<_>>();
    WireFullMap {
        lanes: map
            .lanes
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let width_m = match (&l.left_boundary, &l.right_boundary) {
                    (Some(left), Some(right)) => mean_distance(left, right),
                    _ => None,
                };
                WireFullLane {
                    id: l.id.0,
                    centreline: resampled(&l.centreline),
                    left_boundary: l.left_boundary.as_ref().map(resampled),
                    right_boundary: l.right_boundary.as_ref().map(resampled),
                    width_m,
                    speed_limit_mps: l.speed_limit_mps,
                    predecessors: linked(graph.predecessors(i)),
                    successors: linked(graph.successors(i)),
                    left_neighbours: ids(&l.left_neighbours),
                    right_neighbours: ids(&l.right_neighbours),
                    in_intersection: l.in_junction(),
                    stop_line: l.stop_line.map(|p| [p.x, p.y]),
                }
            })
            .collect(),
        road_edges: super::protocol_road_edges(map),
        stop_signs: map
            .stop_signs
            .iter()
            .map(|s| WireStopSign { position: [s.position.x, s.position.y], lanes: ids(&s.lanes) })
            .collect(),
        signal_stops: map
            .traffic_signals
            .iter()
            .filter_map(|s| {
                let point =
                    s.stop_point.or_else(|| map.lane(s.lane).and_then(|l| l.centreline.points().last().copied()))?;
                Some(WireSignalStop { lane: s.lane.0, stop_point: [point.x, point.y] })
            })
            .collect(),
    }
}

/// Mean distance from the points of `a` to the polyline `b`, m (rounded
/// to the centimetre: a width, not a measurement).
fn mean_distance(a: &Polyline, b: &Polyline) -> Option<f64> {
    let d: Vec<f64> = a.points().iter().filter_map(|p| b.project(p)).map(|p| p.distance_m).collect();
    (!d.is_empty()).then(|| (d.iter().sum::<f64>() / d.len() as f64 * 100.0).round() / 100.0)
}

/// The `observation` message of protocol 1.0 for one step; `road_edges`
/// are the map's edges as the protocol sends them ([`road_edges`]).
pub(super) fn observation_message(obs: &Observation<'_>, road_edges: &[Polyline]) -> HarnessMessage {
    let centre = obs.ego.position;
    let map = WireMap {
        lanes: obs
            .map
            .lanes
            .iter()
            .filter_map(|l| {
                clip(&l.centreline, &centre, MAP_RADIUS_M).map(|centreline| WireLane {
                    id: l.id.0,
                    centreline,
                    speed_limit_mps: l.speed_limit_mps,
                })
            })
            .collect(),
        road_edges: road_edges.iter().filter_map(|e| clip(e, &centre, MAP_RADIUS_M)).collect(),
    };
    observation_with(obs, Some(map), route_ahead(obs.map, &obs.ego), None, None, None)
}

/// An `observation` message with the given map and route fields.
fn observation_with(
    obs: &Observation<'_>,
    map: Option<WireMap>,
    route: Vec<[f64; 2]>,
    route_lanes: Option<Vec<i64>>,
    route_revision: Option<u32>,
    route_s_m: Option<f64>,
) -> HarnessMessage {
    let ego = &obs.ego;
    HarnessMessage::Observation {
        step: obs.step,
        time_s: obs.time_s,
        ego: WireEgo {
            x: ego.position.x,
            y: ego.position.y,
            heading_rad: ego.heading_rad,
            speed_mps: ego.speed_mps(),
            vx: ego.velocity_mps.x,
            vy: ego.velocity_mps.y,
            accel_mps2: obs.ego_accel_mps2,
            yaw_rate_radps: obs.ego_yaw_rate_radps,
            steering_angle_rad: steering_angle_rad(
                obs.ego_yaw_rate_radps,
                crate::motion::KinematicState::from_agent_state(ego).speed_mps,
            ),
            length_m: obs.ego_length_m,
            width_m: obs.ego_width_m,
        },
        agents: obs
            .agents
            .iter()
            .map(|a| WireAgent {
                id: a.id.0.clone(),
                kind: a.kind.into(),
                x: a.state.position.x,
                y: a.state.position.y,
                heading_rad: a.state.heading_rad,
                vx: a.state.velocity_mps.x,
                vy: a.state.velocity_mps.y,
                length_m: a.length_m,
                width_m: a.width_m,
            })
            .collect(),
        map,
        signals: obs.signals.iter().map(|(lane, state)| WireSignal { lane: lane.0, state: (*state).into() }).collect(),
        route,
        route_lanes,
        route_revision,
        route_s_m,
    }
}

/// The stretch of `line` (resampled) from its first to its last sample
/// within `radius_m` of `centre`; `None` when no part is that close.
fn clip(line: &Polyline, centre: &Point2, radius_m: f64) -> Option<Vec<[f64; 2]>> {
    // The exact distance first: most of a large map is skipped unsampled.
    if line.project(centre)?.distance_m > radius_m {
        return None;
    }
    let points: Vec<Point2> = samples(line, 0.0, line.length_m()).collect();
    let near = |p: &&Point2| (*p - centre).norm() <= radius_m;
    let first = points.iter().position(|p| near(&p))?;
    let last = points.iter().rposition(|p| near(&p))?;
    Some(points[first..=last].iter().map(|p| [p.x, p.y]).collect())
}

/// The route hint: the ego's lane centreline ahead, following first
/// successors on the map's lane graph, up to [`ROUTE_LENGTH_M`].
fn route_ahead(map: &RoadMap, ego: &AgentState) -> Vec<[f64; 2]> {
    let first_successor = |lane: &Lane, _| map.lanes_after(lane.id).first().copied();
    walk_lanes(map, (ego, &[]), ROUTE_LANE_SEARCH_M, 0.0, ROUTE_LENGTH_M, ROUTE_MAX_LANES, first_successor)
        .map(|walk| walk.points)
        .unwrap_or_default()
}

/// Why a reply to an observation gives no [`PlannerOutput`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ReplyError {
    /// The line breaks the protocol: it is not JSON, not a known message, a
    /// `ready`, lacks a field, holds a non-finite number, or is a trajectory
    /// that fails the checks. The message says which and quotes the line.
    #[error("{0}")]
    Protocol(String),
    /// The planner answered with an `error` message; its text (empty when
    /// it gave none).
    #[error("the planner reported an error: {0}")]
    Reported(String),
}

/// The reply decoding entry point: one line a planner wrote in answer to
/// an observation (without its line ending), parsed strictly and converted
/// into the [`PlannerOutput`] the simulator applies. `dt_s` is the step
/// length a trajectory must reach. Total on arbitrary bytes: it never
/// panics, and every number in an `Ok` output is finite.
pub fn decode_reply(line: &[u8], dt_s: f64) -> Result<PlannerOutput, ReplyError> {
    let reply = parse_reply(line).map_err(ReplyError::Protocol)?;
    check_debug(&reply)?;
    reply_output(reply, dt_s)
}

/// A reply's `debug` object, compact JSON, once it is checked to be within
/// [`MAX_DEBUG_BYTES`]: a planner's diagnostics are kept with every step,
/// so one that dumps its whole state each step must hear so at once.
pub(super) fn check_debug(reply: &PlannerMessage) -> Result<(), ReplyError> {
    let Some(debug) = reply.debug() else { return Ok(()) };
    let bytes = serde_json::to_vec(debug).map_or(usize::MAX, |v| v.len());
    if bytes > MAX_DEBUG_BYTES {
        return Err(ReplyError::Protocol(format!(
            "its `{}` carries a `debug` object of {bytes} bytes (as compact JSON); at most {MAX_DEBUG_BYTES} \
             bytes are kept per step (write larger diagnostics to stderr or a file of its own)",
            reply.kind()
        )));
    }
    Ok(())
}

/// Whether `reply` may answer the observation of `step`: a step it names
/// must be that one, and a planner speaking 1.2 (`required`) must name one.
/// An `error` passes either way: giving up fails the rollout regardless.
pub(super) fn check_reply_step(reply: &PlannerMessage, step: usize, required: bool) -> Result<(), ReplyError> {
    if matches!(reply, PlannerMessage::Error { .. }) {
        return Ok(());
    }
    match reply.step() {
        Some(answered) if answered != step => Err(ReplyError::Protocol(format!(
            "its `{}` answers step {answered}, but the observation was step {step} (one reply per observation: \
             a reply too many or too few puts every later one out of step)",
            reply.kind()
        ))),
        None if required => Err(ReplyError::Protocol(format!(
            "its `{}` names no `step`; a planner speaking protocol 1.2 names the step it answers ({step} here)",
            reply.kind()
        ))),
        _ => Ok(()),
    }
}

/// The planner output a parsed reply to an observation stands for.
pub(super) fn reply_output(reply: PlannerMessage, dt_s: f64) -> Result<PlannerOutput, ReplyError> {
    match reply {
        PlannerMessage::Control { accel_mps2, yaw_rate_radps, .. } => {
            Ok(PlannerOutput::Control(Action { accel_mps2, yaw_rate_radps }))
        }
        PlannerMessage::Trajectory { points, .. } => trajectory(&points, dt_s).map_err(ReplyError::Protocol),
        PlannerMessage::Error { message, .. } => Err(ReplyError::Reported(message.unwrap_or_default())),
        other @ (PlannerMessage::Ready { .. } | PlannerMessage::Prepared {}) => Err(ReplyError::Protocol(format!(
            "expected `control`, `trajectory` or `error` in answer to an observation, got `{}`",
            other.kind()
        ))),
    }
}

/// Trajectory points from the wire, checked: at least one point, times
/// positive, increasing and reaching the next step, speeds not negative.
fn trajectory(points: &[WirePoint], dt_s: f64) -> Result<PlannerOutput, String> {
    let last = points.last().ok_or("the trajectory has no points")?;
    let mut previous_t = 0.0;
    for (i, p) in points.iter().enumerate() {
        if p.t <= previous_t {
            return Err(format!(
                "trajectory point {i} has t = {} s; times must be positive and increasing (relative to the observation)",
                p.t
            ));
        }
        if p.speed_mps < 0.0 {
            return Err(format!("trajectory point {i} has speed_mps = {}; speeds must not be negative", p.speed_mps));
        }
        previous_t = p.t;
    }
    if last.t < dt_s - 1e-9 {
        return Err(format!("the trajectory ends at t = {} s, before the next step (t = {dt_s} s)", last.t));
    }
    Ok(PlannerOutput::Trajectory(
        points
            .iter()
            .map(|p| TrajectoryPoint {
                time_s: p.t,
                state: AgentState {
                    position: Point2::new(p.x, p.y),
                    heading_rad: p.heading_rad,
                    velocity_mps: Vector2::new(p.heading_rad.cos(), p.heading_rad.sin()) * p.speed_mps,
                },
            })
            .collect(),
    ))
}

/// Parses one reply line; the error says what is wrong and quotes it.
pub(super) fn parse_reply(line: &[u8]) -> Result<PlannerMessage, String> {
    let text = String::from_utf8_lossy(line);
    if let Some(token) = non_finite_token(&text) {
        return Err(format!(
            "non-finite number `{token}` in {}: JSON has no NaN or Infinity, every number must be finite",
            quote(line)
        ));
    }
    let parsed = serde_json::from_str::<PlannerMessage>(&text).map(|m| match m {
        // A planner's own words travel into every report: cut as a quote is.
        PlannerMessage::Error { step, message: Some(message) } => PlannerMessage::Error {
            step,
            message: Some(crate::message_text::cut_with_length(&message, ERROR_MESSAGE_CHARS)),
        },
        m => m,
    });
    parsed.map_err(|e| {
        let reason = e.to_string();
        if reason.contains("number out of range") {
            format!("non-finite number (out of the f64 range) in {}: {reason}", quote(line))
        } else if e.is_syntax() || e.is_eof() {
            format!(
                "a line that is not JSON ({reason}): {} (stdout is for protocol messages only; log to stderr)",
                quote(line)
            )
        } else {
            format!("not a valid protocol message ({reason}): {}", quote(line))
        }
    })
}

/// The first bare `NaN`, `Infinity` or `-Infinity` outside strings, as
/// Python's `json.dumps` writes them by default.
fn non_finite_token(text: &str) -> Option<&'static str> {
    let bytes = text.as_bytes();
    let (mut in_string, mut escaped) = (false, false);
    for (i, &b) in bytes.iter().enumerate() {
        if in_string {
            match (escaped, b) {
                (true, _) => escaped = false,
                (false, b'\\') => escaped = true,
                (false, b'"') => in_string = false,
                _ => {}
            }
            continue;
        }
        match b {
            b'"' => in_string = true,
            b'N' if bytes[i..].starts_with(b"NaN") => return Some("NaN"),
            b'-' if bytes[i..].starts_with(b"-Infinity") => return Some("-Infinity"),
            b'I' if bytes[i..].starts_with(b"Infinity") && (i == 0 || bytes[i - 1] != b'-') => {
                return Some("Infinity");
            }
            _ => {}
        }
    }
    None
}

/// The most characters of a planner's `error` message kept: enough for a
/// traceback's last lines, not a report per variant the size of a log.
const ERROR_MESSAGE_CHARS: usize = 2000;

/// The first [`QUOTE_CHARS`] characters of a line, in backticks.
pub(super) fn quote(line: &[u8]) -> String {
    format!("`{}`", truncate_chars(&String::from_utf8_lossy(line), QUOTE_CHARS))
}

pub(super) fn truncate_chars(s: &str, max: usize) -> String {
    match s.char_indices().nth(max) {
        Some((cut, _)) => format!("{}…", &s[..cut]),
        None => s.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{observation_at, stopped_car_ahead};
    use super::*;
    use crate::map::{Lane, LaneKind, MapElementId};

    #[test]
    fn observation_message_has_the_documented_fields() {
        let s = stopped_car_ahead();
        let mut obs = observation_at(&s, 0);
        obs.ego.position = Point2::new(100.0, 1.75);
        let edges = road_edges(obs.map);
        let v = serde_json::to_value(observation_message(&obs, &edges)).unwrap();
        assert_eq!(v["type"], "observation");
        assert_eq!(v["step"], 0);
        assert_eq!(v["ego"]["x"], 100.0);
        assert_eq!(v["ego"]["speed_mps"], 10.0);
        assert_eq!(v["ego"]["length_m"], 4.5);
        assert_eq!(
            v["agents"][0],
            serde_json::json!({"id": "stopped", "kind": "vehicle", "x": 70.0, "y": 1.75, "heading_rad": 0.0,
                "vx": 0.0, "vy": 0.0, "length_m": 4.5, "width_m": 2.0})
        );
        assert_eq!(v["signals"], serde_json::json!([{"lane": 0, "state": "go"}]));
        // Lanes 0 and 1 run 0..300 m: clipped to x in [40, 160], every 2 m.
        let lanes = v["map"]["lanes"].as_array().unwrap();
        assert_eq!(lanes.len(), 2);
        let centreline = lanes[0]["centreline"].as_array().unwrap();
        assert_eq!(centreline.len(), 61);
        assert_eq!(centreline[0], serde_json::json!([40.0, 1.75]));
        assert_eq!(centreline[60], serde_json::json!([160.0, 1.75]));
        assert_eq!(lanes[0]["speed_limit_mps"], 13.9);
        assert_eq!(v["map"]["road_edges"].as_array().unwrap().len(), 2);
        // Route: 100 m of lane 0 ahead of the ego.
        let route = v["route"].as_array().unwrap();
        assert_eq!(route.len(), 51);
        assert_eq!(route[0], serde_json::json!([100.0, 1.75]));
        assert_eq!(route[50], serde_json::json!([200.0, 1.75]));
        // Far from every lane: no map, no route.
        obs.ego.position = Point2::new(1000.0, 500.0);
        let v = serde_json::to_value(observation_message(&obs, &edges)).unwrap();
        assert_eq!(v["map"], serde_json::json!({"lanes": [], "road_edges": []}));
        assert_eq!(v["route"], serde_json::json!([]));
    }

    #[test]
    fn route_follows_the_first_successor_and_not_oncoming_lanes() {
        let lane = |id: i64, pts: &[(f64, f64)], successors: Vec<MapElementId>| Lane {
            kind: LaneKind::SurfaceStreet,
            successors,
            ..Lane::new(MapElementId(id), Polyline::new(pts.iter().map(|&(x, y)| Point2::new(x, y)).collect()))
        };
        let map = RoadMap::new(
            vec![
                lane(1, &[(0.0, 0.0), (50.0, 0.0)], vec![MapElementId(2), MapElementId(3)]),
                // Each turning off at 45° first (a join by geometry takes
                // lanes that turn by less than 90° where they meet).
                lane(2, &[(50.0, 0.0), (60.0, 10.0), (60.0, 200.0)], vec![]),
                lane(3, &[(50.0, 0.0), (60.0, -10.0), (60.0, -200.0)], vec![]),
            ],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
        );
        let ego = |x: f64, heading_rad: f64| AgentState {
            position: Point2::new(x, 0.0),
            heading_rad,
            velocity_mps: Vector2::zeros(),
        };
        let route = route_ahead(&map, &ego(40.0, 0.0));
        assert_eq!(route.first(), Some(&[40.0, 0.0]));
        // 100 m: 10 m of lane 1, then lane 2's diagonal and on north.
        let last = route.last().unwrap();
        assert!((last[0] - 60.0).abs() < 1e-9 && (last[1] - (100.0 - 200f64.sqrt())).abs() < 1e-6, "{last:?}");
        assert!(route.windows(2).all(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) <= MAP_SPACING_M + 1e-9));
        // Facing against the only lane: no route.
        assert!(route_ahead(&map, &ego(20.0, std::f64::consts::PI)).is_empty());
        // The same lanes from a source without connectivity: joined where
        // one starts as another ends, in the route and in `prepare`'s map.
        let unconnected = RoadMap::from_lanes(
            map.lanes.iter().cloned().map(|l| Lane { successors: vec![], predecessors: vec![], ..l }).collect(),
        );
        assert_eq!(route_ahead(&unconnected, &ego(40.0, 0.0)), route);
        let links = serde_json::to_value(full_map(&unconnected)).unwrap()["lanes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|l| (l["id"].as_i64().unwrap(), l["predecessors"].clone(), l["successors"].clone()))
            .collect::<Vec<_>>();
        use serde_json::json;
        assert_eq!(links, vec![(1, json!([]), json!([2, 3])), (2, json!([1]), json!([])), (3, json!([1]), json!([]))]);
    }

    #[test]
    fn the_full_map_names_lanes_that_cross_as_intersection_lanes_where_the_map_flags_none() {
        let lane = |id: i64, pts: &[(f64, f64)]| {
            Lane::new(MapElementId(id), Polyline::new(pts.iter().map(|&(x, y)| Point2::new(x, y)).collect()))
        };
        let mut map = RoadMap::from_lanes(vec![
            lane(1, &[(-30.0, 0.0), (30.0, 0.0)]),
            lane(2, &[(0.0, -30.0), (0.0, 30.0)]),
            lane(3, &[(-30.0, 40.0), (30.0, 40.0)]),
        ]);
        let flags = |map: &RoadMap| -> Vec<bool> { full_map(map).lanes.iter().map(|l| l.in_intersection).collect() };
        assert_eq!(flags(&map), [false, false, false]);
        map.mark_crossing_lanes_as_junctions();
        assert_eq!(flags(&map), [true, true, false]);
    }

    #[test]
    fn replies_are_parsed_strictly() {
        let ok = parse_reply(br#"{"type":"control","accel_mps2":-2,"yaw_rate_radps":0.5,"debug":"x"}"#).unwrap();
        assert!(matches!(ok, PlannerMessage::Control { accel_mps2: -2.0, yaw_rate_radps: 0.5, step: None, .. }));
        // NaN inside a string is just text.
        let ok = parse_reply(br#"{"type":"error","message":"got NaN and -Infinity"}"#).unwrap();
        assert!(matches!(ok, PlannerMessage::Error { message: Some(m), .. } if m == "got NaN and -Infinity"));
        for (line, token) in [
            (r#"{"type":"control","accel_mps2":Infinity,"yaw_rate_radps":0}"#, "`Infinity`"),
            (r#"{"type":"control","accel_mps2":-Infinity,"yaw_rate_radps":0}"#, "`-Infinity`"),
            (r#"{"type":"control","accel_mps2":1e400,"yaw_rate_radps":0}"#, "out of the f64 range"),
        ] {
            let e = parse_reply(line.as_bytes()).unwrap_err();
            assert!(e.starts_with("non-finite number") && e.contains(token), "{e}");
        }
        let e = parse_reply(br#"{"type":"control","accel_mps2":null,"yaw_rate_radps":0}"#).unwrap_err();
        assert!(e.contains("invalid type: null"), "{e}");
        let long = "x".repeat(500);
        let e = parse_reply(long.as_bytes()).unwrap_err();
        assert!(e.contains(&format!("`{}…`", "x".repeat(200))), "{e}");
        assert!(!e.contains(&"x".repeat(201)));
    }

    #[test]
    fn trajectories_are_checked_and_converted() {
        let p = |t: f64, x: f64, speed_mps: f64| WirePoint { t, x, y: 0.0, heading_rad: 0.0, speed_mps };
        match trajectory(&[p(0.1, 1.0, 10.0), p(0.2, 2.0, 10.0)], 0.1).unwrap() {
            PlannerOutput::Trajectory(points) => {
                assert_eq!(points[1].time_s, 0.2);
                assert_eq!(points[1].state.velocity_mps, Vector2::new(10.0, 0.0));
            }
            other => panic!("{other:?}"),
        }
        assert!(trajectory(&[], 0.1).unwrap_err().contains("no points"));
        assert!(trajectory(&[p(0.2, 1.0, 1.0), p(0.1, 2.0, 1.0)], 0.1).unwrap_err().contains("increasing"));
        assert!(trajectory(&[p(0.05, 1.0, 1.0)], 0.1).unwrap_err().contains("before the next step"));
        assert!(trajectory(&[p(0.1, 1.0, -1.0)], 0.1).unwrap_err().contains("must not be negative"));
    }
}
