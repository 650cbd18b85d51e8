//! An IDM-style lane follower: pure-pursuit steering along a route of lane
//! centrelines (going straight through junctions where the lane graph
//! branches), and Intelligent Driver Model speed control that brakes for
//! the nearest agent on the route ahead and for red signals.
//!
//! Used for background traffic and, wrapped as a planner, as the simplest
//! reactive ego. Without a lane (pedestrians, off-map), the route is a
//! straight line along the heading.

use super::{AgentAction, AgentPolicy, WorldView};
use crate::geometry::{Point2, Polyline, Vector2, wrap_angle};
use crate::map::{Lane, MapElementId, RoadMap};
use crate::motion::Action;
use crate::motion::tokens::{MAX_ACCEL_MPS2, MAX_YAW_RATE_RADPS};
use crate::scenario::{AgentKind, AgentState, TrackIndex};

/// Parameters of the lane follower; defaults are textbook IDM values for
/// urban driving (Treiber & Kesting).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdmParams {
    /// Desired speed, m/s; `None` uses the lane's speed limit, else the
    /// larger of the start speed and [`IdmParams::fallback_speed_mps`].
    pub desired_speed_mps: Option<f64>,
    /// Desired speed when the map gives no limit and the agent starts slower, m/s.
    pub fallback_speed_mps: f64,
    /// Maximum acceleration `a`, m/s².
    pub max_accel_mps2: f64,
    /// Comfortable deceleration `b`, m/s².
    pub comfort_decel_mps2: f64,
    /// Hardest braking allowed, m/s² (positive number).
    pub max_decel_mps2: f64,
    /// Time headway `T`, s.
    pub time_headway_s: f64,
    /// Standstill gap `s0`, m.
    pub min_gap_m: f64,
    /// Acceleration exponent `δ`.
    pub exponent: f64,
    /// Pure-pursuit look-ahead per m/s of speed, s.
    pub lookahead_time_s: f64,
    /// Minimum pure-pursuit look-ahead, m.
    pub min_lookahead_m: f64,
    /// How far ahead leaders are searched, m.
    pub sensing_range_m: f64,
}

impl IdmParams {
    /// The first parameter outside its plausible range, with why: IDM with a
    /// desired speed of 1e300 m/s or a negative headway is not a driver.
    pub fn implausible_field(&self) -> Option<(&'static str, String)> {
        let ranges: [(&'static str, Option<f64>, f64, f64); 11] = [
            ("desired_speed_mps", self.desired_speed_mps, 0.0, 70.0),
            ("fallback_speed_mps", Some(self.fallback_speed_mps), 0.0, 70.0),
            ("max_accel_mps2", Some(self.max_accel_mps2), 0.0, 10.0),
            ("comfort_decel_mps2", Some(self.comfort_decel_mps2), 0.0, 10.0),
            ("max_decel_mps2", Some(self.max_decel_mps2), 0.0, 15.0),
            ("time_headway_s", Some(self.time_headway_s), 0.0, 10.0),
            ("min_gap_m", Some(self.min_gap_m), 0.0, 50.0),
            ("exponent", Some(self.exponent), 0.0, 10.0),
            ("lookahead_time_s", Some(self.lookahead_time_s), 0.0, 5.0),
            ("min_lookahead_m", Some(self.min_lookahead_m), 0.0, 100.0),
            ("sensing_range_m", Some(self.sensing_range_m), 0.0, 500.0),
        ];
        ranges.into_iter().find_map(|(name, value, min, max)| {
            let v = value?;
            // Speeds, accelerations, the exponent and ranges must be positive;
            // headway and gaps may be zero.
            let zero_ok = matches!(name, "time_headway_s" | "min_gap_m" | "lookahead_time_s");
            let ok = v.is_finite() && (v > min || (zero_ok && v == min)) && v <= max;
            let open = if zero_ok { "[" } else { "(" };
            let got = if v.is_finite() && v.abs() >= 1e7 { format!("{v:e}") } else { format!("{v}") };
            (!ok).then(|| (name, format!("must be a number in {open}{min}, {max}], got {got}")))
        })
    }
}

impl Default for IdmParams {
    fn default() -> Self {
        Self {
            desired_speed_mps: None,
            fallback_speed_mps: 10.0,
            max_accel_mps2: 1.5,
            comfort_decel_mps2: 2.0,
            max_decel_mps2: MAX_ACCEL_MPS2,
            time_headway_s: 1.5,
            min_gap_m: 2.0,
            exponent: 4.0,
            lookahead_time_s: 0.8,
            min_lookahead_m: 4.0,
            sensing_range_m: 80.0,
        }
    }
}

/// IDM's desired gap s* = s0 + max(0, v·T + v·Δv / (2·√(a·b))), m, for
/// speed v closing on its leader at Δv (positive: faster than it), with
/// standstill gap s0, time headway T, acceleration a and comfortable
/// deceleration b.
pub fn idm_desired_gap_m(
    speed_mps: f64,
    closing_mps: f64,
    min_gap_m: f64,
    time_headway_s: f64,
    max_accel_mps2: f64,
    comfort_decel_mps2: f64,
) -> f64 {
    min_gap_m
        + (speed_mps * time_headway_s + speed_mps * closing_mps / (2.0 * (max_accel_mps2 * comfort_decel_mps2).sqrt()))
            .max(0.0)
}

/// Route length built ahead of the agent, m.
const ROUTE_HORIZON_M: f64 = 200.0;
/// Rebuild the route when less than this remains ahead, m.
const ROUTE_REBUILD_M: f64 = 60.0;
/// Lateral offset from the route under which another agent is "on it", m.
const ON_ROUTE_LATERAL_M: f64 = 1.8;
/// How far from a lane centreline an agent may start and still follow it, m.
const LANE_SEARCH_RADIUS_M: f64 = 4.0;

/// The path an agent drives along, and which lanes make it up.
#[derive(Debug, Clone)]
pub struct Route {
    /// The path, starting a few metres behind the agent.
    pub path: Polyline,
    /// (lane, arc length of its start on the path, arc length of its end).
    pub lanes: Vec<(MapElementId, f64, f64)>,
}

impl Route {
    /// Whether a route (or none yet) must be rebuilt for an agent at
    /// `position`: none, `position` does not project onto it, or less
    /// than 60 m of it remain ahead.
    pub fn needs_rebuild(route: Option<&Route>, position: &Point2) -> bool {
        route.is_none_or(|r| {
            r.path.project(position).is_none_or(|p| r.path.length_m() - p.arc_length_m < ROUTE_REBUILD_M)
        })
    }

    /// The desired speed of an agent starting on this route at
    /// `start_speed_mps`: its `own` when configured, else the first lane's
    /// limit, else the larger of the start speed and `fallback_mps`.
    pub fn desired_speed_mps(&self, map: &RoadMap, own: Option<f64>, start_speed_mps: f64, fallback_mps: f64) -> f64 {
        own.unwrap_or_else(|| {
            let limit = self.lanes.first().and_then(|(id, _, _)| map.lane(*id)).and_then(|l| l.speed_limit_mps);
            limit.unwrap_or(start_speed_mps.max(fallback_mps))
        })
    }
}

/// A route of about 200 m from `state`: the nearest lane going the agent's
/// way, then the straightest successor at each junction (ties to the lower
/// id); a straight line along the heading off the lane graph or for
/// pedestrians.
pub fn build_route(map: &RoadMap, state: &AgentState, kind: AgentKind) -> Route {
    build_route_choosing(map, state, kind, &mut |_, _| 0)
}

/// [`build_route`] with the successor at each junction picked by `choose`:
/// it gets the lane the route leaves and the successors ordered from the
/// straightest (ties to the lower id), and returns an index into them.
pub fn build_route_choosing(
    map: &RoadMap,
    state: &AgentState,
    kind: AgentKind,
    choose: &mut SuccessorChoice<'_>,
) -> Route {
    build_route_along(map, state, kind, &[], choose)
}

/// [`build_route_choosing`] starting on the lane `mission` (the way the
/// agent is to go, such as its recording) keeps to where a junction's
/// lanes overlap at the agent ([`RoadMap::lane_along`]): from the nearest
/// alone the route may start down a turn the mission never takes.
pub fn build_route_along(
    map: &RoadMap,
    state: &AgentState,
    kind: AgentKind,
    mission: &[Point2],
    choose: &mut SuccessorChoice<'_>,
) -> Route {
    let straight = || {
        let f = Vector2::new(state.heading_rad.cos(), state.heading_rad.sin());
        Route { path: Polyline::new(vec![state.position, state.position + f * ROUTE_HORIZON_M]), lanes: vec![] }
    };
    if kind != AgentKind::Vehicle && kind != AgentKind::Cyclist {
        return straight();
    }
    let Some(m) = map.lane_along(&state.position, state.heading_rad, LANE_SEARCH_RADIUS_M, mission) else {
        return straight();
    };
    let lane = &map.lanes[m.lane_index];
    // Only an aligned lane is the agent's (nearest_lane falls back to a
    // misaligned one when it finds nothing else).
    if lane.centreline.tangent_dot(&m.projection, state.heading_rad) < crate::map::ALIGNED_LANE_MAX_ANGLE_RAD.cos() {
        return straight();
    }
    // Start slightly behind the agent so the projection is never clamped to the route start.
    route_along_lanes(map, lane, (m.projection.arc_length_m - 5.0).max(0.0), choose).unwrap_or_else(straight)
}

/// Picks a junction's successor: (the lane left, its successors from the
/// straightest) → index.
pub type SuccessorChoice<'a> = dyn FnMut(&Lane, &[&Lane]) -> usize + 'a;

/// About 200 m of lane centrelines from arc length `s0_m` of `lane` on,
/// with `choose` picking at each junction; `None` when that is under two points.
pub fn route_along_lanes<'m>(
    map: &'m RoadMap,
    mut lane: &'m Lane,
    s0_m: f64,
    choose: &mut SuccessorChoice<'_>,
) -> Option<Route> {
    let mut points: Vec<Point2> = Vec::new();
    let mut lanes = Vec::new();
    let mut covered = 0.0;
    let mut first = true;
    loop {
        let pts = lane.centreline.points();
        let start_s = if first { s0_m } else { 0.0 };
        let lane_start_on_path = covered;
        let mut seg_pts: Vec<Point2> = Vec::new();
        if let Some((p, _)) = lane.centreline.sample(start_s) {
            seg_pts.push(p);
        }
        let mut acc = 0.0;
        for w in pts.windows(2) {
            acc += (w[1] - w[0]).norm();
            if acc > start_s {
                seg_pts.push(w[1]);
            }
        }
        covered += (lane.centreline.length_m() - start_s).max(0.0);
        lanes.push((lane.id, lane_start_on_path, covered));
        points.extend(seg_pts);
        first = false;
        if covered >= ROUTE_HORIZON_M || lanes.len() > 64 {
            break;
        }
        // Successors from the straightest: the least deviation of the
        // direction 10 m in from this lane's end direction; ties to the lower id.
        let Some((_, end_dir)) = lane.centreline.sample(lane.centreline.length_m()) else { break };
        // The map's lane graph: recorded successors, else the lanes that
        // start where this one ends (a source without connectivity).
        let mut next: Vec<(&'m Lane, f64)> = map
            .lanes_after(lane.id)
            .into_iter()
            .filter_map(|l| l.centreline.sample(10.0).map(|(_, d)| (l, -d.dot(&end_dir))))
            .collect();
        if next.is_empty() {
            break;
        }
        next.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.id.cmp(&b.0.id)));
        let ordered: Vec<&'m Lane> = next.into_iter().map(|(l, _)| l).collect();
        lane = ordered[choose(lane, &ordered).min(ordered.len() - 1)];
    }
    let path = Polyline::new(points);
    (path.len() >= 2).then_some(Route { path, lanes })
}

/// Pure-pursuit yaw rate towards the route point a look-ahead past arc
/// length `here_s` (the agent's projection), rad/s.
pub fn pursuit_yaw_rate(route: &Route, here_s: f64, state: &AgentState, params: &IdmParams) -> Option<f64> {
    let speed = state.speed_mps();
    let lookahead = (params.lookahead_time_s * speed).max(params.min_lookahead_m);
    let curvature = pursuit_curvature(&route.path, here_s + lookahead, state)?;
    Some((curvature * speed.max(0.5)).clamp(-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS))
}

/// The pure-pursuit curvature, 1/m, that takes `state` through the point
/// at arc length `target_s` of `path` (`None` off the path's ends).
pub fn pursuit_curvature(path: &Polyline, target_s: f64, state: &AgentState) -> Option<f64> {
    let (target, _) = path.sample(target_s)?;
    let to_target = target - state.position;
    let alpha = wrap_angle(to_target.y.atan2(to_target.x) - state.heading_rad);
    Some(2.0 * alpha.sin() / to_target.norm().max(1e-3))
}

/// What IDM brakes for on the route: (gap, m; its speed along the route,
/// m/s) of the closest agent on the route ahead or a red signal's stop line.
pub fn route_leader(
    world: &WorldView<'_>,
    agent: TrackIndex,
    route: &Route,
    here_s: f64,
    params: &IdmParams,
) -> Option<(f64, f64)> {
    let state = world.state(agent)?;
    let body = world.body(agent);
    let mut leader: Option<(f64, f64)> = None;
    let mut consider = |gap: f64, v: f64| {
        if leader.is_none_or(|(g, _)| gap < g) {
            leader = Some((gap, v));
        }
    };
    let forward = Vector2::new(state.heading_rad.cos(), state.heading_rad.sin());
    for (j, other) in world.states.iter().enumerate() {
        let Some(other) = other else { continue };
        if j == agent.0 {
            continue;
        }
        let d = other.position - state.position;
        if d.norm() > params.sensing_range_m || d.dot(&forward) < 0.0 {
            continue;
        }
        let Some(p) = route.path.project(&other.position) else { continue };
        let ahead = p.arc_length_m - here_s;
        if p.distance_m > ON_ROUTE_LATERAL_M || ahead <= 0.0 {
            continue;
        }
        let gap = ahead - 0.5 * (body.length_m + world.bodies[j].length_m);
        consider(gap, other.velocity_mps.dot(&p.tangent));
    }
    for &(lane, _, end_s) in &route.lanes {
        let red = world.map.signal_state(lane, world.step).is_some_and(|s| s.requires_stop());
        let ahead = end_s - here_s;
        if red && ahead > 0.5 * body.length_m && ahead < params.sensing_range_m {
            consider(ahead - 0.5 * body.length_m, 0.0);
        }
    }
    leader
}

/// IDM's acceleration at `speed_mps` towards desired speed `v0_mps`,
/// braking for `leader` (gap m, speed m/s), within the parameters' limits.
pub fn idm_accel_mps2(params: &IdmParams, speed_mps: f64, v0_mps: f64, leader: Option<(f64, f64)>) -> f64 {
    let p = params;
    let free = 1.0 - (speed_mps / v0_mps.max(0.1)).powf(p.exponent);
    let interaction = leader.map_or(0.0, |(gap, v_lead)| {
        let desired_gap = idm_desired_gap_m(
            speed_mps,
            speed_mps - v_lead,
            p.min_gap_m,
            p.time_headway_s,
            p.max_accel_mps2,
            p.comfort_decel_mps2,
        );
        (desired_gap / gap.max(0.1)).powi(2)
    });
    // max/min, not clamp: clamp panics on NaN or crossed bounds, and
    // parameters reach here unchecked through the library API (a NaN
    // control is refused by the simulator, naming the agent).
    (p.max_accel_mps2 * (free - interaction)).max(-p.max_decel_mps2).min(p.max_accel_mps2)
}

/// The IDM lane follower for one agent.
#[derive(Debug, Clone)]
pub struct IdmLaneFollower {
    params: IdmParams,
    route: Option<Route>,
    desired_speed_mps: Option<f64>,
}

impl IdmLaneFollower {
    /// A follower with these parameters; its route is built on first use.
    pub fn new(params: IdmParams) -> Self {
        Self { params, route: None, desired_speed_mps: None }
    }

    /// The control for `agent` at `world.step`, or `None` when it is absent.
    pub fn control(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> Option<Action> {
        let state = *world.state(agent)?;
        if Route::needs_rebuild(self.route.as_ref(), &state.position) {
            self.route = Some(build_route(world.map, &state, world.body(agent).kind));
        }
        let route = self.route.as_ref()?;
        let here = route.path.project(&state.position)?;
        let speed = state.speed_mps();
        let v0 = *self.desired_speed_mps.get_or_insert_with(|| {
            route.desired_speed_mps(world.map, self.params.desired_speed_mps, speed, self.params.fallback_speed_mps)
        });
        let yaw_rate = pursuit_yaw_rate(route, here.arc_length_m, &state, &self.params)?;
        let leader = route_leader(world, agent, route, here.arc_length_m, &self.params);
        Some(Action { accel_mps2: idm_accel_mps2(&self.params, speed, v0, leader), yaw_rate_radps: yaw_rate })
    }
}

impl AgentPolicy for IdmLaneFollower {
    fn name(&self) -> &'static str {
        "idm"
    }

    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
        AgentAction::from_control(world, agent, self.control(world, agent))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::{Lane, MapElementId};

    #[test]
    fn a_route_along_a_mission_starts_down_the_turn_the_mission_takes_where_turns_overlap() {
        // Lane 1 ends where two turns start, on top of each other for 10 m.
        let lane = |id: i64, pts: &[(f64, f64)], successors: &[i64]| Lane {
            successors: successors.iter().map(|&i| MapElementId(i)).collect(),
            ..Lane::new(MapElementId(id), Polyline::new(pts.iter().map(|&(x, y)| Point2::new(x, y)).collect()))
        };
        let lanes = vec![
            lane(1, &[(0.0, 0.0), (100.0, 0.0)], &[2, 3]),
            lane(2, &[(100.0, 0.0), (110.0, 0.0), (200.0, 100.0)], &[]),
            lane(3, &[(100.0, 0.0), (110.0, 0.0), (200.0, -100.0)], &[]),
        ];
        let map = RoadMap::new(lanes, vec![], vec![], vec![], vec![], vec![], vec![]);
        let ego =
            AgentState { position: Point2::new(105.0, 0.0), heading_rad: 0.0, velocity_mps: Vector2::new(5.0, 0.0) };
        let mission: Vec<Point2> = (0..=200)
            .map(|i| i as f64)
            .map(|x| if x <= 110.0 { Point2::new(x, 0.0) } else { Point2::new(x, -(x - 110.0) * 100.0 / 90.0) })
            .collect();
        let first_lane = |route: Route| route.lanes.first().map(|l| l.0);
        let nearest = build_route_choosing(&map, &ego, AgentKind::Vehicle, &mut |_, _| 0);
        assert_eq!(first_lane(nearest), Some(MapElementId(2)), "the nearest: a tie, to the lower id");
        let along = build_route_along(&map, &ego, AgentKind::Vehicle, &mission, &mut |_, _| 0);
        assert_eq!(first_lane(along), Some(MapElementId(3)));
    }
}
