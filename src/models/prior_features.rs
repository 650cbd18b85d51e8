//! The realism prior's feature builder (contract version 2, documented in
//! `docs/prior-features.md`): for one query agent at a token boundary, its
//! recent states in its own frame, its nearest neighbours and map tokens
//! with relative pose features d_ij, and padding masks. The same code writes
//! the training shards and feeds inference, so the two cannot disagree.
//!
//! The map is cut into *map tokens* (polyline pieces of at most
//! [`MAP_TOKEN_MAX_LENGTH_M`]) once per scenario ([`MapTokens`]); their
//! pose-free features go through the map encoder once, and each query only
//! gathers its nearest rows and adds the query-relative pose.

use std::collections::HashMap;

use crate::geometry::{Point2, Vector2, clearly_farther_squared, wrap_angle};
use crate::map::{AreaKind, MapElementId, RoadMap, SignalState};
use crate::motion::tokens::{TOKEN_PERIOD_S, TOKEN_PERIOD_STEPS};
use crate::scenario::{AgentBody, AgentKind, AgentState};

/// History points per query: t − 2.5 s … t, 0.5 s apart (last = now).
pub const HISTORY_POINTS: usize = 6;
/// Values per history point.
pub const HISTORY_FEATURES: usize = 8;
/// Values describing the query agent itself.
pub const SELF_FEATURES: usize = 6;
/// Neighbours per query.
pub const NEIGHBOURS: usize = 16;
/// Values per neighbour.
pub const NEIGHBOUR_FEATURES: usize = 12;
/// Radius within which neighbours are taken, m.
pub const NEIGHBOUR_RADIUS_M: f64 = 50.0;
/// Map tokens per query.
pub const MAP_TOKENS: usize = 48;
/// Pose-free values per map token: kind one-hot (4), length, in
/// intersection, speed limit, then the lane's turn ahead (rightmost and
/// leftmost heading change, reach). A map encoder reads the first
/// [`MapTokenWidth`] of them.
pub const MAP_TOKEN_FEATURES: usize = 10;
/// How far ahead along the lane graph a lane token's turn is read, m.
pub const LANE_LOOK_AHEAD_M: f64 = 40.0;
/// Radius within which map tokens are taken, m.
pub const MAP_RADIUS_M: f64 = 60.0;
/// Longest map token, m.
pub const MAP_TOKEN_MAX_LENGTH_M: f64 = 8.0;
/// Values of a relative pose feature d_ij.
pub const POSE_FEATURES: usize = 5;
/// Values of a map token's signal state.
pub const SIGNAL_FEATURES: usize = 4;
/// Rows the map encoder takes per call.
pub const MAP_ENCODER_CHUNK: usize = 256;

const GRID_CELL_M: f64 = 20.0;

/// Which pose-free map-token values a map encoder reads: the width of its
/// `map_tokens` input says it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapTokenWidth {
    /// The first 7 values (feature contract version 1): kind, length, in
    /// intersection, speed limit.
    Base = 7,
    /// All 10 (version 2): also the lane's turn ahead along the lane graph.
    WithTurnAhead = 10,
}

impl MapTokenWidth {
    /// The width with this many values, if a map encoder may read it.
    pub fn from_values(values: usize) -> Option<Self> {
        match values {
            7 => Some(Self::Base),
            10 => Some(Self::WithTurnAhead),
            _ => None,
        }
    }

    /// Values per map token.
    pub fn values(self) -> usize {
        self as usize
    }
}

/// One piece of a map polyline.
#[derive(Debug, Clone, PartialEq)]
pub struct MapToken {
    /// Midpoint, scenario frame.
    pub midpoint: Point2,
    /// Direction of travel along the piece, rad.
    pub direction_rad: f64,
    /// Pose-free features (see the contract).
    pub features: [f32; MAP_TOKEN_FEATURES],
    /// The lane it belongs to, for lane centrelines (signal lookup).
    pub lane: Option<MapElementId>,
}

/// The map of a scenario cut into tokens, with a grid for radius queries.
/// Built once per scenario.
#[derive(Debug, Clone, Default)]
pub struct MapTokens {
    /// All tokens, in map order (lanes, road edges, road lines, areas).
    pub tokens: Vec<MapToken>,
    grid: HashMap<(i32, i32), Vec<u32>>,
}

fn cell(p: &Point2) -> (i32, i32) {
    ((p.x / GRID_CELL_M).floor() as i32, (p.y / GRID_CELL_M).floor() as i32)
}

impl MapTokens {
    /// Cuts every polyline of `map` into tokens.
    pub fn build(map: &RoadMap) -> Self {
        let graph = map.lane_graph();
        let mut tokens = Vec::new();
        let mut add = |points: &[Point2], kind: usize, in_intersection: bool, speed_limit: f64, lane: Option<usize>| {
            let mut arc_m = 0.0;
            for (a, b) in pieces(points) {
                let d = b - a;
                let length = d.norm();
                let mid_arc_m = arc_m + length / 2.0;
                arc_m += length;
                if length < 1e-3 {
                    continue;
                }
                let mut features = [0.0f32; MAP_TOKEN_FEATURES];
                features[kind] = 1.0;
                features[4] = length as f32;
                features[5] = if in_intersection { 1.0 } else { 0.0 };
                features[6] = speed_limit as f32;
                if let Some(turn) = lane.and_then(|i| graph.turn_ahead(map, i, mid_arc_m, LANE_LOOK_AHEAD_M)) {
                    features[7] = turn.rightmost_rad as f32;
                    features[8] = turn.leftmost_rad as f32;
                    features[9] = turn.reach_m as f32;
                }
                let lane = lane.map(|i| map.lanes[i].id);
                tokens.push(MapToken {
                    midpoint: Point2::from((a.coords + b.coords) * 0.5),
                    direction_rad: d.y.atan2(d.x),
                    features,
                    lane,
                });
            }
        };
        for (i, lane) in map.lanes.iter().enumerate() {
            add(lane.centreline.points(), 0, lane.in_intersection, lane.speed_limit_mps.unwrap_or(0.0), Some(i));
        }
        for edge in &map.road_edges {
            add(edge.polyline.points(), 1, false, 0.0, None);
        }
        for line in &map.road_lines {
            add(line.polyline.points(), 2, false, 0.0, None);
        }
        for area in &map.areas {
            if matches!(area.kind, AreaKind::Crosswalk | AreaKind::SpeedBump | AreaKind::Driveway) {
                add(area.polygon.boundary_ccw().points(), 3, false, 0.0, None);
            }
        }
        let mut grid: HashMap<(i32, i32), Vec<u32>> = HashMap::new();
        for (i, t) in tokens.iter().enumerate() {
            grid.entry(cell(&t.midpoint)).or_default().push(i as u32);
        }
        Self { tokens, grid }
    }

    /// Indices of the `k` tokens nearest to `p` within `radius_m`, nearest
    /// first (ties by index, so the order is deterministic).
    pub fn nearest(&self, p: &Point2, k: usize, radius_m: f64) -> Vec<(u32, f64)> {
        let r = (radius_m / GRID_CELL_M).ceil() as i32;
        let (cx, cy) = cell(p);
        let mut found: Vec<(u32, f64)> = Vec::new();
        // Cells wholly beyond the radius are skipped (a 1 µm margin keeps
        // every token that the exact test below would keep).
        let gap = |lo: f64, x: f64| (lo - x).max(x - (lo + GRID_CELL_M)).max(0.0);
        let reach2 = (radius_m + 1e-6).powi(2);
        for dx in -r..=r {
            for dy in -r..=r {
                let (gx, gy) = (gap(f64::from(cx + dx) * GRID_CELL_M, p.x), gap(f64::from(cy + dy) * GRID_CELL_M, p.y));
                if gx * gx + gy * gy > reach2 {
                    continue;
                }
                if let Some(ids) = self.grid.get(&(cx + dx, cy + dy)) {
                    for &i in ids {
                        let d = (self.tokens[i as usize].midpoint - p).norm();
                        if d <= radius_m {
                            found.push((i, d));
                        }
                    }
                }
            }
        }
        // The nearest `k` by selection, then only they sorted: a 60 m
        // circle holds far more tokens than the query keeps.
        let order = |a: &(u32, f64), b: &(u32, f64)| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0));
        if k == 0 {
            return Vec::new();
        }
        if found.len() > k {
            found.select_nth_unstable_by(k - 1, order);
            found.truncate(k);
        }
        found.sort_by(order);
        found
    }

    /// The first `width` pose-free features of every token, row-major,
    /// padded with zero rows to a multiple of [`MAP_ENCODER_CHUNK`].
    pub fn encoder_input(&self, width: MapTokenWidth) -> Vec<f32> {
        let w = width.values();
        let rows = self.tokens.len().div_ceil(MAP_ENCODER_CHUNK).max(1) * MAP_ENCODER_CHUNK;
        let mut out = vec![0.0f32; rows * w];
        for (i, t) in self.tokens.iter().enumerate() {
            out[i * w..(i + 1) * w].copy_from_slice(&t.features[..w]);
        }
        out
    }
}

/// Splits a polyline into consecutive pieces of at most
/// [`MAP_TOKEN_MAX_LENGTH_M`], each given by its start and end point.
fn pieces(points: &[Point2]) -> Vec<(Point2, Point2)> {
    let mut out = Vec::new();
    if points.len() < 2 {
        return out;
    }
    let mut start = points[0];
    let mut acc = 0.0;
    for w in points.windows(2) {
        let (mut a, b) = (w[0], w[1]);
        let mut seg = (b - a).norm();
        while acc + seg > MAP_TOKEN_MAX_LENGTH_M {
            let take = MAP_TOKEN_MAX_LENGTH_M - acc;
            let cut = a + (b - a) * (take / seg);
            out.push((start, cut));
            start = cut;
            a = cut;
            seg -= take;
            acc = 0.0;
        }
        acc += seg;
    }
    if acc > 1e-3 {
        out.push((start, *points.last().expect("two points or more")));
    }
    out
}

/// The states of every agent over time, as the feature builder reads them:
/// `frame(step)[agent]`. Training uses the tokenized tracks; the prior
/// policy keeps the closed-loop states it has seen.
pub trait StateHistory {
    /// Every agent's state at `step`, `None` where absent or unknown.
    fn state(&self, step: usize, agent: usize) -> Option<AgentState>;
    /// Number of agent slots.
    fn agents(&self) -> usize;
}

/// The signal state of a lane at a step, as the map gives it.
pub trait SignalLookup {
    /// State of the signal on `lane` at `step`, if the lane has one.
    fn signal(&self, lane: MapElementId, step: usize) -> Option<SignalState>;
}

impl SignalLookup for RoadMap {
    fn signal(&self, lane: MapElementId, step: usize) -> Option<SignalState> {
        self.signal_state(lane, step)
    }
}

/// One query's features, flattened per tensor (see the contract).
#[derive(Debug, Clone, PartialEq)]
pub struct QueryFeatures {
    /// [HISTORY_POINTS × HISTORY_FEATURES]
    pub history: [f32; HISTORY_POINTS * HISTORY_FEATURES],
    /// [SELF_FEATURES]
    pub agent_self: [f32; SELF_FEATURES],
    /// [NEIGHBOURS × NEIGHBOUR_FEATURES]
    pub neighbours: [f32; NEIGHBOURS * NEIGHBOUR_FEATURES],
    /// [NEIGHBOURS × POSE_FEATURES]
    pub neighbour_pose: [f32; NEIGHBOURS * POSE_FEATURES],
    /// [NEIGHBOURS]
    pub neighbour_mask: [f32; NEIGHBOURS],
    /// Index of each map token in [`MapTokens::tokens`] (`u32::MAX` = padding).
    pub map_index: [u32; MAP_TOKENS],
    /// [MAP_TOKENS × POSE_FEATURES]
    pub map_pose: [f32; MAP_TOKENS * POSE_FEATURES],
    /// [MAP_TOKENS × SIGNAL_FEATURES]
    pub map_signal: [f32; MAP_TOKENS * SIGNAL_FEATURES],
    /// [MAP_TOKENS]
    pub map_mask: [f32; MAP_TOKENS],
}

fn kind_one_hot(kind: AgentKind) -> [f32; 4] {
    let mut v = [0.0; 4];
    v[match kind {
        AgentKind::Vehicle => 0,
        AgentKind::Pedestrian => 1,
        AgentKind::Cyclist => 2,
        AgentKind::Other => 3,
    }] = 1.0;
    v
}

fn signal_one_hot(state: Option<SignalState>) -> [f32; SIGNAL_FEATURES] {
    let i = match state {
        Some(SignalState::Stop | SignalState::ArrowStop | SignalState::FlashingStop) => 0,
        Some(SignalState::Caution | SignalState::ArrowCaution | SignalState::FlashingCaution) => 1,
        Some(SignalState::Go | SignalState::ArrowGo) => 2,
        Some(SignalState::Unknown) | None => 3,
    };
    let mut v = [0.0; SIGNAL_FEATURES];
    v[i] = 1.0;
    v
}

fn speed_of(s: &AgentState) -> f64 {
    s.speed_mps()
}

/// Builds the features of `agent` at `step` (a token boundary). Returns
/// `None` when the agent is absent at `step`.
pub fn build_query(
    history: &dyn StateHistory,
    bodies: &[AgentBody],
    map: &MapTokens,
    signals: &dyn SignalLookup,
    agent: usize,
    step: usize,
) -> Option<QueryFeatures> {
    let now = history.state(step, agent)?;
    // The agent frame's rotation, computed once (`Pose2::to_body` would
    // take the heading's sine and cosine at every call).
    let (sin_h, cos_h) = now.heading_rad.sin_cos();
    let rotate = |v: &Vector2| Vector2::new(cos_h * v.x + sin_h * v.y, -sin_h * v.x + cos_h * v.y);
    let to_body = |p: &Point2| rotate(&(p - now.position));
    let at = |k: usize| -> Option<AgentState> {
        let back = (HISTORY_POINTS - 1 - k) * TOKEN_PERIOD_STEPS;
        step.checked_sub(back).and_then(|s| history.state(s, agent))
    };
    let mut q = QueryFeatures {
        history: [0.0; HISTORY_POINTS * HISTORY_FEATURES],
        agent_self: [0.0; SELF_FEATURES],
        neighbours: [0.0; NEIGHBOURS * NEIGHBOUR_FEATURES],
        neighbour_pose: [0.0; NEIGHBOURS * POSE_FEATURES],
        neighbour_mask: [0.0; NEIGHBOURS],
        map_index: [u32::MAX; MAP_TOKENS],
        map_pose: [0.0; MAP_TOKENS * POSE_FEATURES],
        map_signal: [0.0; MAP_TOKENS * SIGNAL_FEATURES],
        map_mask: [0.0; MAP_TOKENS],
    };
    // The point before the first history point gives its accel / yaw rate.
    let before_first = step.checked_sub(HISTORY_POINTS * TOKEN_PERIOD_STEPS).and_then(|s| history.state(s, agent));
    let mut previous = before_first;
    for k in 0..HISTORY_POINTS {
        let point = at(k);
        if let Some(s) = point {
            let p = to_body(&s.position);
            let dh = wrap_angle(s.heading_rad - now.heading_rad);
            let (accel, yaw_rate) = match previous {
                Some(prev) => (
                    ((speed_of(&s) - speed_of(&prev)) / TOKEN_PERIOD_S).clamp(-10.0, 10.0),
                    (wrap_angle(s.heading_rad - prev.heading_rad) / TOKEN_PERIOD_S).clamp(-3.0, 3.0),
                ),
                None => (0.0, 0.0),
            };
            let row = &mut q.history[k * HISTORY_FEATURES..(k + 1) * HISTORY_FEATURES];
            row.copy_from_slice(&[
                p.x as f32,
                p.y as f32,
                dh.cos() as f32,
                dh.sin() as f32,
                speed_of(&s) as f32,
                accel as f32,
                yaw_rate as f32,
                1.0,
            ]);
        }
        previous = point;
    }
    let body = bodies[agent];
    let kind = kind_one_hot(body.kind);
    q.agent_self = [body.length_m as f32, body.width_m as f32, kind[0], kind[1], kind[2], kind[3]];

    // Agents clearly beyond the radius are turned away on the squared
    // distance; the rest take the exact test on the distance.
    let mut others: Vec<(usize, f64, AgentState)> = (0..history.agents())
        .filter(|&j| j != agent)
        .filter_map(|j| {
            let s = history.state(step, j)?;
            let offset = s.position - now.position;
            let d2 = offset.norm_squared();
            if clearly_farther_squared(d2, NEIGHBOUR_RADIUS_M * NEIGHBOUR_RADIUS_M) || d2.is_nan() {
                return None;
            }
            let d = offset.norm();
            (d <= NEIGHBOUR_RADIUS_M).then_some((j, d, s))
        })
        .collect();
    // The nearest NEIGHBOURS in order (distance, then index: a total
    // order, so selecting them first and sorting only them is the same).
    let order = |a: &(usize, f64, AgentState), b: &(usize, f64, AgentState)| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0));
    if others.len() > NEIGHBOURS {
        others.select_nth_unstable_by(NEIGHBOURS - 1, order);
        others.truncate(NEIGHBOURS);
    }
    others.sort_by(order);
    for (n, (j, distance, s)) in others.into_iter().enumerate() {
        let p = to_body(&s.position);
        let v = rotate(&s.velocity_mps);
        let dh = wrap_angle(s.heading_rad - now.heading_rad);
        let prev = step.checked_sub(TOKEN_PERIOD_STEPS).and_then(|sp| history.state(sp, j));
        let (dx, dy, prev_valid) = match prev {
            Some(ps) => {
                let d = rotate(&(s.position - ps.position));
                (d.x as f32, d.y as f32, 1.0)
            }
            None => (0.0, 0.0, 0.0),
        };
        let b = bodies[j];
        let kind = kind_one_hot(b.kind);
        q.neighbours[n * NEIGHBOUR_FEATURES..(n + 1) * NEIGHBOUR_FEATURES].copy_from_slice(&[
            speed_of(&s) as f32,
            v.x as f32,
            v.y as f32,
            b.length_m as f32,
            b.width_m as f32,
            kind[0],
            kind[1],
            kind[2],
            kind[3],
            dx,
            dy,
            prev_valid,
        ]);
        q.neighbour_pose[n * POSE_FEATURES..(n + 1) * POSE_FEATURES].copy_from_slice(&[
            p.x as f32,
            p.y as f32,
            distance as f32,
            dh.cos() as f32,
            dh.sin() as f32,
        ]);
        q.neighbour_mask[n] = 1.0;
    }

    for (n, (i, distance)) in map.nearest(&now.position, MAP_TOKENS, MAP_RADIUS_M).into_iter().enumerate() {
        let token = &map.tokens[i as usize];
        let p = to_body(&token.midpoint);
        let dh = wrap_angle(token.direction_rad - now.heading_rad);
        q.map_index[n] = i;
        q.map_pose[n * POSE_FEATURES..(n + 1) * POSE_FEATURES].copy_from_slice(&[
            p.x as f32,
            p.y as f32,
            distance as f32,
            dh.cos() as f32,
            dh.sin() as f32,
        ]);
        let signal = token.lane.and_then(|lane| signals.signal(lane, step));
        q.map_signal[n * SIGNAL_FEATURES..(n + 1) * SIGNAL_FEATURES].copy_from_slice(&signal_one_hot(signal));
        q.map_mask[n] = 1.0;
    }
    Some(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Polyline;
    use crate::map::Lane;

    struct Frames(Vec<Vec<Option<AgentState>>>);
    impl StateHistory for Frames {
        fn state(&self, step: usize, agent: usize) -> Option<AgentState> {
            self.0.get(step).and_then(|f| f[agent])
        }
        fn agents(&self) -> usize {
            self.0.first().map_or(0, Vec::len)
        }
    }

    fn car() -> AgentBody {
        AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }
    }

    fn moving(x: f64, y: f64, heading: f64, v: f64) -> AgentState {
        AgentState {
            position: Point2::new(x, y),
            heading_rad: heading,
            velocity_mps: Vector2::new(v * heading.cos(), v * heading.sin()),
        }
    }

    /// Two cars driving north (heading π/2) at 10 m/s, the second 20 m ahead.
    fn northbound() -> (Frames, RoadMap) {
        let h = std::f64::consts::FRAC_PI_2;
        let frames = (0..=30)
            .map(|k| {
                let y = k as f64 * 1.0;
                vec![Some(moving(0.0, y, h, 10.0)), Some(moving(0.0, y + 20.0, h, 10.0))]
            })
            .collect();
        let lane = Lane::new(MapElementId(1), Polyline::new(vec![Point2::new(0.0, -50.0), Point2::new(0.0, 100.0)]));
        (Frames(frames), RoadMap::from_lanes(vec![lane]))
    }

    #[test]
    fn polylines_are_cut_into_pieces_no_longer_than_the_limit() {
        let p = pieces(&[Point2::new(0.0, 0.0), Point2::new(20.0, 0.0), Point2::new(20.0, 3.0)]);
        assert_eq!(p.len(), 3);
        for (a, b) in &p {
            assert!((b - a).norm() <= MAP_TOKEN_MAX_LENGTH_M + 1e-9);
        }
        assert_eq!(p[0].0, Point2::new(0.0, 0.0));
        assert_eq!(p.last().unwrap().1, Point2::new(20.0, 3.0));
    }

    #[test]
    fn the_intersection_feature_is_the_sources_flag_not_a_junction_found_from_crossing_lanes() {
        // The shipped prior was trained and measured with the source's flag
        // (WOMD's maps flag none); lanes marked for crossing leave it as is.
        let lane = |id: i64, from: (f64, f64), to: (f64, f64)| {
            Lane::new(MapElementId(id), Polyline::new(vec![Point2::new(from.0, from.1), Point2::new(to.0, to.1)]))
        };
        let mut map = RoadMap::from_lanes(vec![lane(1, (-20.0, 0.0), (20.0, 0.0)), lane(2, (0.0, -20.0), (0.0, 20.0))]);
        assert_eq!(map.mark_crossing_lanes_as_junctions(), 2);
        let flagged = |map: &RoadMap| MapTokens::build(map).tokens.iter().filter(|t| t.features[5] != 0.0).count();
        assert_eq!(flagged(&map), 0);
        map.lanes[0].in_intersection = true;
        assert!(flagged(&map) > 0);
    }

    #[test]
    fn features_are_in_the_query_agents_frame() {
        let (frames, map) = northbound();
        let tokens = MapTokens::build(&map);
        let q = build_query(&frames, &[car(), car()], &tokens, &map, 0, 30).unwrap();
        // Now: at the origin of its frame, speed 10, valid.
        let now = &q.history[5 * HISTORY_FEATURES..6 * HISTORY_FEATURES];
        assert!(now[0].abs() < 1e-5 && now[1].abs() < 1e-5 && (now[2] - 1.0).abs() < 1e-6 && now[7] == 1.0);
        // 2.5 s (25 steps of 1 m) ago it was 25 m behind: x = -25 in its own frame.
        assert!((q.history[0] + 25.0).abs() < 1e-4, "{}", q.history[0]);
        // The leader is 20 m ahead: +x in the query frame, same heading.
        assert_eq!(q.neighbour_mask[0], 1.0);
        assert!((q.neighbour_pose[0] - 20.0).abs() < 1e-4 && q.neighbour_pose[1].abs() < 1e-4);
        assert!((q.neighbour_pose[3] - 1.0).abs() < 1e-6);
        // Its velocity is along +x; it moved 5 m forward over the last 0.5 s.
        assert!((q.neighbours[1] - 10.0).abs() < 1e-4 && q.neighbours[2].abs() < 1e-4);
        assert!((q.neighbours[9] - 5.0).abs() < 1e-4);
        assert_eq!(q.neighbour_mask[1], 0.0);
        // The lane runs along the query's heading.
        assert_eq!(q.map_mask[0], 1.0);
        assert!((q.map_pose[3] - 1.0).abs() < 1e-6);
        // Unknown signal state.
        assert_eq!(&q.map_signal[0..4], &[0.0, 0.0, 0.0, 1.0]);
    }

    #[test]
    fn lane_tokens_carry_the_turn_ahead_and_other_tokens_none() {
        use crate::map::{RoadEdge, RoadEdgeKind};
        // An approach 0..30 m east whose only way on turns right (a quarter
        // circle of 15 m), and a road edge beside it.
        let approach = Lane::new(MapElementId(1), Polyline::new(vec![Point2::new(0.0, 0.0), Point2::new(30.0, 0.0)]));
        let arc: Vec<Point2> = (0..=18)
            .map(|k| {
                let a = k as f64 / 18.0 * std::f64::consts::FRAC_PI_2;
                Point2::new(30.0 + 15.0 * a.sin(), -15.0 * (1.0 - a.cos()))
            })
            .collect();
        let right = Lane::new(MapElementId(2), Polyline::new(arc));
        let edge = RoadEdge {
            id: MapElementId(3),
            polyline: Polyline::new(vec![Point2::new(0.0, 2.0), Point2::new(30.0, 2.0)]),
            kind: RoadEdgeKind::Boundary,
        };
        let map = RoadMap::new(vec![approach, right], vec![edge], vec![], vec![], vec![], vec![], vec![]);
        let tokens = MapTokens::build(&map);
        let first = &tokens.tokens[0];
        assert_eq!(first.lane, Some(MapElementId(1)));
        // Its midpoint is 4 m in: 26 m of approach, then 14 m of the arc.
        let expected = -14.0 / 15.0;
        assert!((first.features[7] as f64 - expected).abs() < 0.06, "{:?}", first.features);
        assert!((first.features[8] as f64 - expected).abs() < 0.06, "right is the only way: {:?}", first.features);
        assert_eq!(first.features[9], LANE_LOOK_AHEAD_M as f32);
        let edge_token = tokens.tokens.iter().find(|t| t.features[1] == 1.0).unwrap();
        assert_eq!(&edge_token.features[7..], &[0.0, 0.0, 0.0]);
        // A width-7 encoder reads the first seven values only.
        let base = tokens.encoder_input(MapTokenWidth::Base);
        assert_eq!(&base[..7], &first.features[..7]);
        assert_eq!(MapTokenWidth::from_values(7), Some(MapTokenWidth::Base));
        assert_eq!(MapTokenWidth::from_values(8), None);
    }

    #[test]
    fn history_before_the_log_is_masked() {
        let (frames, map) = northbound();
        let tokens = MapTokens::build(&map);
        let q = build_query(&frames, &[car(), car()], &tokens, &map, 0, 10).unwrap();
        // Step 10: points at steps -15, -10, -5 do not exist; 0, 5, 10 do.
        let valid: Vec<f32> = (0..HISTORY_POINTS).map(|k| q.history[k * HISTORY_FEATURES + 7]).collect();
        assert_eq!(valid, vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
    }

    #[test]
    fn nearest_map_tokens_are_sorted_and_within_the_radius() {
        let (_, map) = northbound();
        let tokens = MapTokens::build(&map);
        let near = tokens.nearest(&Point2::new(3.0, 0.0), 5, 20.0);
        assert_eq!(near.len(), 5);
        assert!(near.windows(2).all(|w| w[0].1 <= w[1].1));
        assert!(near.iter().all(|(_, d)| *d <= 20.0));
        for width in [MapTokenWidth::Base, MapTokenWidth::WithTurnAhead] {
            assert!(tokens.encoder_input(width).len().is_multiple_of(MAP_ENCODER_CHUNK * width.values()));
        }
        // The head of the full ranking (by distance, ties by index), for any k.
        for (x, y) in [(3.0, 0.0), (-20.0, 35.0), (0.0, 90.0)] {
            let p = Point2::new(x, y);
            let mut all: Vec<(u32, f64)> = (0..tokens.tokens.len() as u32)
                .map(|i| (i, (tokens.tokens[i as usize].midpoint - p).norm()))
                .filter(|&(_, d)| d <= 60.0)
                .collect();
            all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            for k in [0, 1, 5, 48, all.len(), all.len() + 3] {
                assert_eq!(tokens.nearest(&p, k, 60.0), all[..k.min(all.len())], "k {k} at {p:?}");
            }
        }
    }
}
