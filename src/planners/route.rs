//! The stable route (protocol 1.1's, and [`crate::planners::Observation::route`]):
//! a path of lane centrelines planned once
//! from where the ego is and kept unchanged at every step until the ego
//! leaves it (then planned anew from there) or it runs short (then planned
//! anew, so that at least [`ROUTE_AHEAD_MIN_M`] lie ahead where the map has
//! them). A planner can cache it by its revision and never sees it jitter
//! with the ego's position, unlike the 1.0 route hint.
//!
//! At a fork the route takes the successor that the ego's *recording* keeps
//! to (the harness knows where the recorded ego went; that is the scene's
//! intended route), else the first successor. Successors are the map's
//! [lane graph](crate::map::RoadMap::lane_graph)'s: where the source
//! records none, the lanes that start where a lane ends.

use crate::geometry::{Point2, Polyline, PolylineProjection, Vector2};
use crate::map::{MapElementId, RoadMap};
use crate::scenario::AgentState;

use super::lane_walk::{WalkDirection, walk_lanes};
use crate::scenario::{Scenario, TrackIndex};

/// Route length planned behind the ego's projection, m (so a planner can
/// project the ego onto it even after braking back a little).
pub const ROUTE_BEHIND_M: f64 = 20.0;
/// The route is planned anew when less than this lies ahead of the ego, m
/// (unless the map ends sooner).
pub const ROUTE_AHEAD_MIN_M: f64 = 200.0;
/// Route length planned ahead of the ego, m.
pub const ROUTE_AHEAD_PLANNED_M: f64 = 400.0;
/// The ego has left the route when its centre is farther than this from
/// it, m (more than half a lane beyond a lane change's end), beyond the
/// distance it had when the route was planned: an ego that starts off its
/// lane's centreline (a lane the map lacks, a recording between lanes)
/// has not left a route planned from there.
pub const ROUTE_LEAVE_M: f64 = 2.5;
/// Where the ego's lane is searched, m.
const LANE_SEARCH_M: f64 = 10.0;
/// Lanes followed at most (guards against zero-length successor cycles).
const MAX_LANES: usize = 256;

/// The route the ego is on: a path along lane centrelines from
/// [`ROUTE_BEHIND_M`] behind the ego to [`ROUTE_AHEAD_PLANNED_M`] ahead,
/// planned once from the ego's lane and kept while the ego follows it (a
/// new plan, with the next [`revision`](Self::revision), when the ego
/// leaves it or less than [`ROUTE_AHEAD_MIN_M`] lie ahead). At a fork it
/// takes the successor the ego's recording keeps to, else the first. It is
/// the route external planners are sent (protocol 1.1 `route`), so a Rust
/// planner and a Python one see the same path.
///
/// Empty (no points) where the ego is on no lane running its way.
#[derive(Debug, Clone, Default)]
pub struct Route {
    /// The lanes it runs along, in order.
    pub(crate) lanes: Vec<MapElementId>,
    /// Its points, every [`super::lane_walk::MAP_SPACING_M`] or less.
    pub(crate) points: Vec<[f64; 2]>,
    line: Polyline,
    /// 0 for the first plan, +1 for every new one.
    pub(crate) revision: u32,
    planned: bool,
    /// Whether the map ended before [`ROUTE_AHEAD_PLANNED_M`] (no point in
    /// planning anew when it runs short).
    ends_with_map: bool,
    /// How far the ego may be from the route before it has left it, m:
    /// [`ROUTE_LEAVE_M`] beyond its distance when the route was planned.
    leave_m: f64,
}

impl Route {
    /// The route from `ego`'s place on `map` (its lane: the nearest within
    /// 10 m running its way), with no recording to follow at forks
    /// (the first successor is taken), and the ego's arc length along it
    /// (`None` when the route is empty).
    pub fn plan_from(map: &RoadMap, ego: &AgentState) -> (Route, Option<f64>) {
        let mut route = Route::default();
        let s = route.update(map, ego, &[]);
        let s = (!route.is_empty()).then_some(s);
        (route, s)
    }

    /// The route's path along lane centrelines (no points when empty),
    /// points every 2 m or less.
    pub fn path(&self) -> &Polyline {
        &self.line
    }

    /// The lanes it runs along, in order.
    pub fn lanes(&self) -> &[MapElementId] {
        &self.lanes
    }

    /// 0 for the first plan of a rollout, +1 for every new plan: a planner
    /// may cache what it derives from the route until this changes.
    pub fn revision(&self) -> u32 {
        self.revision
    }

    /// Whether there is no route (the ego is on no lane running its way).
    pub fn is_empty(&self) -> bool {
        self.points.len() < 2
    }

    /// Its length, m (0 when empty).
    pub fn length_m(&self) -> f64 {
        self.line.length_m()
    }

    /// Projects `p` onto the route (`None` when empty).
    pub fn project(&self, p: &Point2) -> Option<PolylineProjection> {
        self.line.project(p)
    }

    /// Projects `p` onto the part of the route between arc lengths
    /// `from_m` and `to_m` (the ego's surroundings, where the route passes
    /// a point twice).
    pub fn project_between(&self, p: &Point2, from_m: f64, to_m: f64) -> Option<PolylineProjection> {
        if self.is_empty() {
            return None;
        }
        self.line.project_segments(p, self.line.segments_between(from_m, to_m))
    }

    /// The point and unit direction of the route at arc length `s_m`
    /// (clamped to its ends; `None` when empty).
    pub fn at(&self, s_m: f64) -> Option<(Point2, Vector2)> {
        self.line.sample(s_m.clamp(0.0, self.line.length_m()))
    }

    /// Keeps the route while the ego is on it with enough ahead; otherwise
    /// plans it anew from the ego. `recorded` are the ego's recorded
    /// positions (for the choice at forks). Returns the ego's arc length
    /// along the route (0 when there is none).
    pub(crate) fn update(&mut self, map: &RoadMap, ego: &AgentState, recorded: &[Point2]) -> f64 {
        if self.planned
            && let Some(s) = self.keeps(ego)
        {
            return s;
        }
        let revision = if self.planned { self.revision + 1 } else { 0 };
        *self = plan(map, ego, recorded);
        self.revision = revision;
        self.planned = true;
        let at = self.line.project(&ego.position);
        self.leave_m = ROUTE_LEAVE_M + at.map_or(0.0, |p| p.distance_m);
        at.map_or(0.0, |p| p.arc_length_m)
    }

    /// The route's path (no points before the first plan, or off the map).
    pub(crate) fn line(&self) -> &Polyline {
        &self.line
    }

    /// The ego's arc length when the current route still serves it.
    fn keeps(&self, ego: &AgentState) -> Option<f64> {
        if self.points.len() < 2 {
            // No route (off the map): try again at every step.
            return None;
        }
        let p = self.line.project(&ego.position)?;
        let forward = Vector2::new(ego.heading_rad.cos(), ego.heading_rad.sin());
        let on_it = p.distance_m <= self.leave_m && p.tangent.dot(&forward) > 0.0;
        let long_enough = self.ends_with_map || self.line.length_m() - p.arc_length_m >= ROUTE_AHEAD_MIN_M;
        (on_it && long_enough).then_some(p.arc_length_m)
    }
}

/// Plans a route from the ego's lane (the nearest within 10 m running its
/// way), [`ROUTE_BEHIND_M`] behind it (into the lanes before it where its
/// lane starts closer behind) to [`ROUTE_AHEAD_PLANNED_M`] ahead.
fn plan(map: &RoadMap, ego: &AgentState, recorded: &[Point2]) -> Route {
    let at_fork = |lane: &'_ crate::map::Lane, direction| {
        let choices = match direction {
            WalkDirection::Ahead => map.lanes_after(lane.id),
            WalkDirection::Behind => map.lanes_before(lane.id),
        };
        choose_lane(&choices, recorded)
    };
    let Some(walk) =
        walk_lanes(map, (ego, recorded), LANE_SEARCH_M, ROUTE_BEHIND_M, ROUTE_AHEAD_PLANNED_M, MAX_LANES, at_fork)
    else {
        return Route::default();
    };
    Route {
        line: Polyline::new(walk.points.iter().map(|p| Point2::new(p[0], p[1])).collect()),
        lanes: walk.lanes,
        points: walk.points,
        ends_with_map: !walk.reached_length,
        ..Route::default()
    }
}

/// The ego's recorded positions from `start_step` on: the route's guide
/// at forks (the scene's intended route).
pub(crate) fn recorded_path(scenario: &Scenario, ego: TrackIndex, start_step: usize) -> Vec<Point2> {
    scenario
        .tracks
        .get(ego.0)
        .map(|t| t.states.iter().skip(start_step).flatten().map(|s| s.position).collect())
        .unwrap_or_default()
}

/// The lane of `choices` (successors or predecessors) the recording keeps
/// to the farthest ([`crate::map::lane_followed`]); the first where the
/// recording does not decide.
fn choose_lane<'m>(lanes: &[&'m crate::map::Lane], recorded: &[Point2]) -> Option<&'m crate::map::Lane> {
    let taken = crate::map::lane_followed(lanes, recorded).unwrap_or(0);
    lanes.get(taken).copied()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::{Lane, LaneKind};

    fn lane(id: i64, pts: &[(f64, f64)], successors: &[i64]) -> Lane {
        Lane {
            kind: LaneKind::SurfaceStreet,
            successors: successors.iter().map(|&i| MapElementId(i)).collect(),
            ..Lane::new(MapElementId(id), Polyline::new(pts.iter().map(|&(x, y)| Point2::new(x, y)).collect()))
        }
    }

    fn ego(x: f64, y: f64) -> AgentState {
        AgentState { position: Point2::new(x, y), heading_rad: 0.0, velocity_mps: Vector2::new(10.0, 0.0) }
    }

    /// A 100 m lane forking into one going left (north) and one going right.
    fn fork() -> RoadMap {
        let mut lanes = vec![
            lane(1, &[(0.0, 0.0), (100.0, 0.0)], &[2, 3]),
            lane(2, &[(100.0, 0.0), (200.0, 100.0), (200.0, 1000.0)], &[]),
            lane(3, &[(100.0, 0.0), (200.0, -100.0), (200.0, -1000.0)], &[]),
        ];
        for l in &mut lanes[1..] {
            l.predecessors = vec![MapElementId(1)];
        }
        RoadMap::new(lanes, vec![], vec![], vec![], vec![], vec![], vec![])
    }

    #[test]
    fn the_route_does_not_move_while_the_ego_follows_it_and_is_replanned_when_it_leaves() {
        let map = fork();
        let mut route = Route::default();
        let s = route.update(&map, &ego(30.0, 0.0), &[]);
        assert_eq!((route.revision, s), (0, ROUTE_BEHIND_M));
        assert_eq!(route.points[0], [10.0, 0.0]);
        assert_eq!(route.lanes, vec![MapElementId(1), MapElementId(2)], "first successor without a recording");
        let first = route.points.clone();
        // Drifting within the lane, moving on: the same points.
        for (x, y) in [(31.0, 0.4), (40.0, -1.0), (60.0, 2.0)] {
            let s = route.update(&map, &ego(x, y), &[]);
            assert_eq!(route.points, first);
            assert_eq!(route.revision, 0);
            assert!((s - (x - 10.0)).abs() < 1e-9, "{s}");
        }
        // Beyond 2.5 m from it: planned anew from where the ego is.
        route.update(&map, &ego(70.0, 3.0), &[]);
        assert_eq!(route.revision, 1);
        assert_eq!(route.points[0], [50.0, 0.0]);
        // At least 200 m ahead, every 2 m or less.
        assert!(route.line.length_m() - 20.0 >= ROUTE_AHEAD_MIN_M);
        assert!(route.points.windows(2).all(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) <= 2.0 + 1e-9));
    }

    #[test]
    fn at_a_lane_start_the_route_reaches_back_into_the_lane_before() {
        let map = fork();
        let mut route = Route::default();
        // 5 m into lane 3, heading along it (south-east).
        let heading = (-1.0f64).atan2(1.0);
        let start = Point2::new(100.0, 0.0) + Vector2::new(heading.cos(), heading.sin()) * 5.0;
        let ego = AgentState { position: start, heading_rad: heading, velocity_mps: Vector2::zeros() };
        let s = route.update(&map, &ego, &[start]);
        assert_eq!(route.lanes[..2], [MapElementId(1), MapElementId(3)], "{:?}", route.lanes);
        assert!((s - ROUTE_BEHIND_M).abs() < 1e-6, "the ego is {s} m along the route, not {ROUTE_BEHIND_M}");
        assert_eq!(route.points[0], [85.0, 0.0]);
        // (Sampling every 2 m cuts the corner at (200, -100) a little.)
        assert!(route.line.length_m() - s >= ROUTE_AHEAD_PLANNED_M - 1.0, "{}", route.line.length_m() - s);
    }

    #[test]
    fn an_ego_planned_off_its_lane_keeps_its_route_until_it_moves_further_away() {
        let map = fork();
        let mut route = Route::default();
        // 3.7 m beside the only lane running its way (a lane the map lacks).
        for step in 0..30 {
            route.update(&map, &ego(10.0 + step as f64, 3.7), &[]);
            assert_eq!(route.revision, 0, "step {step}: planned anew with the same lanes");
        }
        // 2.5 m further out it has left the route.
        route.update(&map, &ego(45.0, 6.3), &[]);
        assert_eq!(route.revision, 1);
    }

    #[test]
    fn where_a_junctions_turns_overlap_at_the_ego_the_route_starts_down_the_recorded_one() {
        // Lane 1 ends where two turns start, their first 10 m on top of each
        // other: at (105, 0) the nearest lane is a tie (to the lower id).
        let mut lanes = vec![
            lane(1, &[(0.0, 0.0), (100.0, 0.0)], &[2, 3]),
            lane(2, &[(100.0, 0.0), (110.0, 0.0), (200.0, 100.0), (200.0, 1000.0)], &[]),
            lane(3, &[(100.0, 0.0), (110.0, 0.0), (200.0, -100.0), (200.0, -1000.0)], &[]),
        ];
        for l in &mut lanes[1..] {
            l.predecessors = vec![MapElementId(1)];
        }
        let map = RoadMap::new(lanes, vec![], vec![], vec![], vec![], vec![], vec![]);
        let mut plain = Route::default();
        plain.update(&map, &ego(105.0, 0.0), &[]);
        assert_eq!(plain.lanes, vec![MapElementId(1), MapElementId(2)], "the nearest without a recording");
        // A recording every metre that takes the right turn.
        let recorded: Vec<Point2> = (0..=200)
            .map(|i| i as f64)
            .map(|x| if x <= 110.0 { Point2::new(x, 0.0) } else { Point2::new(x, -(x - 110.0) * 100.0 / 90.0) })
            .collect();
        let mut route = Route::default();
        route.update(&map, &ego(105.0, 0.0), &recorded);
        assert_eq!(route.lanes, vec![MapElementId(1), MapElementId(3)]);
    }

    #[test]
    fn at_a_fork_the_route_follows_the_recording() {
        let map = fork();
        let mut route = Route::default();
        // A recording every metre: it keeps to both successors for their
        // first metres, and to lane 3 beyond.
        let recorded: Vec<Point2> = (0..=170)
            .map(|i| i as f64)
            .map(|d| if d <= 100.0 { Point2::new(d, 0.0) } else { Point2::new(d, 100.0 - d) })
            .collect();
        route.update(&map, &ego(30.0, 0.0), &recorded);
        assert_eq!(route.lanes, vec![MapElementId(1), MapElementId(3)]);
    }

    #[test]
    fn without_recorded_connectivity_the_route_runs_on_through_the_lanes_that_start_where_one_ends() {
        // The fork as GPUDrive's WOMD JSON keeps it: no successors or predecessors.
        let mut lanes = fork().lanes;
        for l in &mut lanes {
            l.successors.clear();
            l.predecessors.clear();
        }
        let map = RoadMap::from_lanes(lanes);
        let recorded: Vec<Point2> = (0..=170)
            .map(|i| i as f64)
            .map(|d| if d <= 100.0 { Point2::new(d, 0.0) } else { Point2::new(d, 100.0 - d) })
            .collect();
        let mut route = Route::default();
        route.update(&map, &ego(30.0, 0.0), &recorded);
        assert_eq!(route.lanes, vec![MapElementId(1), MapElementId(3)]);
        assert!(route.line.length_m() - 20.0 >= ROUTE_AHEAD_MIN_M, "{}", route.line.length_m());
        // Starting 5 m into lane 3, the route reaches back into lane 1.
        let heading = (-1.0f64).atan2(1.0);
        let start = Point2::new(100.0, 0.0) + Vector2::new(heading.cos(), heading.sin()) * 5.0;
        let on_the_turn = AgentState { position: start, heading_rad: heading, velocity_mps: Vector2::zeros() };
        let mut route = Route::default();
        route.update(&map, &on_the_turn, &[start]);
        assert_eq!(route.lanes[..2], [MapElementId(1), MapElementId(3)], "{:?}", route.lanes);
    }
}
