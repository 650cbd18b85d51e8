//! The per-object, per-step features of one joint scene (the log, or one
//! rollout), as `metric_features.py`, `trajectory_features.py`,
//! `interaction_features.py`, `map_metric_features.py` and
//! `traffic_light_features.py` compute them:
//!
//! - kinematics by central differences at the configured step (10 Hz):
//!   speed `|p[t+1] − p[t−1]| / 2Δt`, acceleration the central difference of
//!   speed, yaw rate `wrap(h[t+1] − h[t−1]) / 2Δt`, yaw acceleration the
//!   wrapped central difference of the per-step yaw change over `Δt²`; NaN
//!   where a neighbour is missing or at the ends of the window (2-D: the
//!   scenes carry no height);
//! - distance to the nearest object: signed distance between oriented boxes
//!   (negative = penetration depth), minimum over the other simulated
//!   objects present at that step; 10¹⁰ when there is none;
//! - collision: that distance below 0 (touching is not a collision);
//! - time to collision: the object ahead that the evaluated object follows
//!   (ahead of its front, laterally overlapping its straight trail, heading
//!   difference ≤ 75°, and ≤ 10° when the lateral overlap is under 0.5 m),
//!   nearest along the heading; gap over closing speed (central-difference
//!   speeds), capped at 5 s, and 5 s when nothing is followed or not
//!   closing. As in Waymo's code the heading difference is the raw
//!   `|h_other − h_ego|`, not wrapped;
//! - distance to the road edge: the largest signed distance of the four box
//!   corners (positive off road, `RoadMap::signed_distance_to_road_edge`);
//!   −10¹⁰ for an absent object; off-road when above 0;
//! - traffic-light violation: between two steps the centre crosses a
//!   signal's stop point (projected on the stop-point segment of the
//!   controlled lane) while the signal is `Stop` or `ArrowStop`, and the
//!   lane nearest the centre is that controlled lane. "Nearest" uses
//!   Waymo's segment distance `|p − a + t·(b − a)|` (a `+` where a point-
//!   to-segment distance has a `−`): the published metric picks lanes that
//!   way, so this does too. Lanes are the surface-street lanes where the
//!   map types its lanes, else all lanes. Waymo pads lanes to a common
//!   length and its padding adds a segment from each lane's end to the
//!   world origin; that artefact depends on the world frame and is not
//!   reproduced. A signal without a stop point stops at its lane's end.

use std::cell::RefCell;
use std::collections::HashMap;

use crate::geometry::{OrientedBox, Point2, Polyline, Vector2};
use crate::map::{LaneKind, MapElementId, RoadMap, SegmentIndex, SignalState};
use crate::scenario::{AgentBody, AgentKind, AgentState};

/// Distance used where no other object (or no state) exists, as Waymo's
/// `EXTREMELY_LARGE_DISTANCE`.
pub const EXTREMELY_LARGE_DISTANCE: f64 = 1e10;
/// Time to collision used when no object is followed, and the cap, s.
pub const MAXIMUM_TIME_TO_COLLISION_S: f64 = 5.0;
/// Largest heading difference for following, rad (75°).
const MAX_HEADING_DIFF_RAD: f64 = 75.0 * std::f64::consts::PI / 180.0;
/// Largest heading difference when the lateral overlap is small, rad (10°).
const MAX_HEADING_DIFF_FOR_SMALL_OVERLAP_RAD: f64 = 10.0 * std::f64::consts::PI / 180.0;
/// Lateral overlap under which the tighter heading condition applies, m.
const SMALL_OVERLAP_THRESHOLD_M: f64 = 0.5;

/// Wraps to `[−π, π)` as Waymo's `_wrap_angle` (floor modulo).
fn wrap(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

/// Central difference `(x[t+1] − x[t−1]) / 2`, NaN at both ends.
fn central_diff(xs: &[f64]) -> Vec<f64> {
    let mut out = vec![f64::NAN; xs.len()];
    for t in 1..xs.len().saturating_sub(1) {
        out[t] = (xs[t + 1] - xs[t - 1]) / 2.0;
    }
    out
}

/// Kinematic features of one trajectory (NaN where a state is missing):
/// linear speed, linear acceleration, angular speed, angular acceleration.
pub fn kinematics(states: &[Option<AgentState>], step_s: f64) -> [Vec<f64>; 4] {
    let x: Vec<f64> = states.iter().map(|s| s.map_or(f64::NAN, |s| s.position.x)).collect();
    let y: Vec<f64> = states.iter().map(|s| s.map_or(f64::NAN, |s| s.position.y)).collect();
    let h: Vec<f64> = states.iter().map(|s| s.map_or(f64::NAN, |s| s.heading_rad)).collect();
    let (dx, dy) = (central_diff(&x), central_diff(&y));
    let speed: Vec<f64> = dx.iter().zip(&dy).map(|(a, b)| a.hypot(*b) / step_s).collect();
    let accel: Vec<f64> = central_diff(&speed).into_iter().map(|v| v / step_s).collect();
    let dh_step: Vec<f64> = central_diff(&h).into_iter().map(|d| wrap(d * 2.0) / 2.0).collect();
    let d2h_step: Vec<f64> = central_diff(&dh_step).into_iter().map(|d| wrap(d * 2.0) / 2.0).collect();
    let yaw_rate = dh_step.iter().map(|d| d / step_s).collect();
    let yaw_accel = d2h_step.iter().map(|d| d / (step_s * step_s)).collect();
    [speed, accel, yaw_rate, yaw_accel]
}

/// `valid[t−1] && valid[t+1]`, false at both ends (`central_logical_and`).
pub fn central_and(valid: &[bool]) -> Vec<bool> {
    let mut out = vec![false; valid.len()];
    for t in 1..valid.len().saturating_sub(1) {
        out[t] = valid[t - 1] && valid[t + 1];
    }
    out
}

/// Signed distance between two oriented boxes, m: the Euclidean gap when
/// apart, minus the penetration depth (smallest separating translation)
/// when they overlap. Computed in `f64` on the corners.
pub fn signed_box_distance(a: &[Point2; 4], b: &[Point2; 4]) -> f64 {
    // Separating-axis test over both boxes' edge normals.
    let mut min_overlap = f64::INFINITY;
    for poly in [a, b] {
        for k in 0..2 {
            let e = poly[k + 1] - poly[k];
            let n = Vector2::new(-e.y, e.x) / e.norm();
            let project = |q: &[Point2; 4]| {
                q.iter()
                    .map(|p| n.dot(&p.coords))
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)))
            };
            let ((alo, ahi), (blo, bhi)) = (project(a), project(b));
            min_overlap = min_overlap.min((ahi - blo).min(bhi - alo));
        }
    }
    if min_overlap >= 0.0 {
        return -min_overlap;
    }
    // Apart: the closest pair is a corner of one against an edge of the other.
    let mut best = f64::INFINITY;
    for (p, q) in [(a, b), (b, a)] {
        for c in p {
            for k in 0..4 {
                let (s, e) = (q[k], q[(k + 1) % 4]);
                let d = e - s;
                let t = ((c - s).dot(&d) / d.norm_squared()).clamp(0.0, 1.0);
                best = best.min((c - (s + d * t)).norm());
            }
        }
    }
    best
}

/// Features of the evaluated objects over the future steps of one joint scene:
/// `[object][future step]`.
#[derive(Debug, Clone, PartialEq)]
pub struct MetricFeatures {
    /// Whether the object has a state at that step.
    pub valid: Vec<Vec<bool>>,
    /// Speed, m/s.
    pub linear_speed: Vec<Vec<f64>>,
    /// Acceleration, m/s².
    pub linear_acceleration: Vec<Vec<f64>>,
    /// Yaw rate, rad/s.
    pub angular_speed: Vec<Vec<f64>>,
    /// Yaw acceleration, rad/s².
    pub angular_acceleration: Vec<Vec<f64>>,
    /// Signed box distance to the nearest other object, m.
    pub distance_to_nearest_object: Vec<Vec<f64>>,
    /// Box overlap with another object.
    pub collision: Vec<Vec<bool>>,
    /// Time to collision with the object followed, s.
    pub time_to_collision: Vec<Vec<f64>>,
    /// Signed distance of the most off-road corner to the road edge, m;
    /// `None` when the map has no road edges.
    pub distance_to_road_edge: Option<Vec<Vec<f64>>>,
    /// Most off-road corner beyond the edge.
    pub offroad: Option<Vec<Vec<bool>>>,
    /// Crossing a stop line on red.
    pub traffic_light_violation: Vec<Vec<bool>>,
}

/// Lanes and signals for the traffic-light feature.
#[derive(Debug, Clone)]
struct SignalContext {
    /// Lanes searched for "the lane the object is on".
    lanes: Vec<(MapElementId, Polyline)>,
    index: SegmentIndex,
    /// Longest lane segment, m (bounds the search).
    max_segment_m: f64,
    fences: Vec<Fence>,
}

/// A signal's stop point on the segment of its lane nearest to it.
#[derive(Debug, Clone)]
struct Fence {
    lane: MapElementId,
    states: Vec<SignalState>,
    start: Point2,
    along: Vector2,
    stop_rel: f64,
}

impl Fence {
    /// Coordinate of `p`'s projection along the fence segment (0 at its start, 1 at its end).
    fn rel(&self, p: &Point2) -> f64 {
        let l2 = self.along.norm_squared();
        if l2 > 0.0 { (p - self.start).dot(&self.along) / l2 } else { 0.0 }
    }
}

/// Waymo's lane-segment distance `|p − a + t(b − a)|` with `t` the clipped
/// projection parameter (`_get_nearest_lane_segment_index`).
fn waymo_segment_distance(p: &Point2, a: &Point2, b: &Point2) -> f64 {
    let d = b - a;
    let ap = p - a;
    let l2 = d.norm_squared();
    let t = if l2 > 0.0 { (ap.dot(&d) / l2).clamp(0.0, 1.0) } else { 0.0 };
    (ap + d * t).norm()
}

impl SignalContext {
    fn new(map: &RoadMap) -> Self {
        let typed = map.lanes.iter().any(|l| l.kind != LaneKind::Undefined);
        let lanes: Vec<(MapElementId, Polyline)> = map
            .lanes
            .iter()
            .filter(|l| !typed || l.kind == LaneKind::SurfaceStreet)
            .filter(|l| l.centreline.len() >= 2)
            .map(|l| (l.id, l.centreline.clone()))
            .collect();
        let index = SegmentIndex::build(lanes.iter().map(|(_, l)| l));
        let max_segment_m =
            lanes.iter().flat_map(|(_, l)| l.points().windows(2).map(|w| (w[1] - w[0]).norm())).fold(0.0, f64::max);
        let fences = map
            .traffic_signals
            .iter()
            .filter_map(|s| {
                let (_, line) = lanes.iter().find(|(id, _)| *id == s.lane)?;
                let pts = line.points();
                let stop = s.stop_point.unwrap_or(*pts.last()?);
                let (mut best, mut best_i) = (f64::INFINITY, 0);
                for (i, w) in pts.windows(2).enumerate() {
                    let d = waymo_segment_distance(&stop, &w[0], &w[1]);
                    if d < best {
                        (best, best_i) = (d, i);
                    }
                }
                let (start, along) = (pts[best_i], pts[best_i + 1] - pts[best_i]);
                let mut f = Fence { lane: s.lane, states: s.states.clone(), start, along, stop_rel: 0.0 };
                f.stop_rel = f.rel(&stop);
                Some(f)
            })
            .collect();
        Self { lanes, index, max_segment_m, fences }
    }

    /// The lane Waymo's metric puts `p` on.
    fn nearest_lane(&self, p: &Point2) -> Option<MapElementId> {
        // Waymo's distance d' and the point–segment distance d of the same
        // segment satisfy d' >= d - 2·len, so segments outside the searched
        // square (d > r) cannot beat a candidate with d' <= r - 2·max_len.
        if !(p.x.is_finite() && p.y.is_finite()) {
            return None;
        }
        let mut radius = 8.0 + 2.0 * self.max_segment_m;
        loop {
            let mut best: Option<(f64, usize)> = None;
            for (lane, segs) in self.index.candidates(p, radius) {
                let pts = self.lanes[lane].1.points();
                for s in segs {
                    let d = waymo_segment_distance(p, &pts[s], &pts[s + 1]);
                    if best.is_none_or(|(b, _)| d < b) {
                        best = Some((d, lane));
                    }
                }
            }
            let everything = radius >= self.index.max_distance_from(p);
            match best {
                Some((d, lane)) if everything || d <= radius - 2.0 * self.max_segment_m => {
                    return Some(self.lanes[lane].0);
                }
                None if everything => return None,
                _ => radius *= 2.0,
            }
        }
    }
}

/// What stays the same for every joint scene of one scenario window: the
/// simulated objects, who is evaluated, the map queries.
#[derive(Debug, Clone)]
pub struct SceneContext<'a> {
    map: &'a RoadMap,
    bodies: Vec<AgentBody>,
    evaluated: Vec<usize>,
    /// Index of the window's current step in a joint scene's trajectories.
    current_index: usize,
    future_steps: usize,
    /// Scenario step of trajectory index 0.
    first_step: usize,
    step_s: f64,
    signals: SignalContext,
    /// Road-edge distance of an object's box by its exact pose: stationary
    /// agents repeat the same pose over steps and rollouts, and the map
    /// query is the costliest part of the features.
    road_edge_cache: RefCell<HashMap<(usize, [u64; 3]), f64>>,
}

/// One simulated object's box at one step.
#[derive(Debug, Clone, Copy)]
struct Placed {
    state: AgentState,
    corners: [Point2; 4],
    radius_m: f64,
}

impl<'a> SceneContext<'a> {
    /// `bodies` of the simulated objects; `evaluated` indexes into them;
    /// trajectories start at scenario step `first_step` and the window's
    /// current step is trajectory index `current_index`.
    pub fn new(
        map: &'a RoadMap,
        bodies: Vec<AgentBody>,
        evaluated: Vec<usize>,
        first_step: usize,
        current_index: usize,
        future_steps: usize,
        step_s: f64,
    ) -> Self {
        let signals = SignalContext::new(map);
        Self {
            map,
            bodies,
            evaluated,
            current_index,
            future_steps,
            first_step,
            step_s,
            signals,
            road_edge_cache: RefCell::new(HashMap::new()),
        }
    }

    /// Indices (into the simulated objects) of the evaluated objects.
    pub fn evaluated(&self) -> &[usize] {
        &self.evaluated
    }

    /// Whether evaluated object `e` (position in [`SceneContext::evaluated`]) is a vehicle.
    pub fn is_vehicle(&self, e: usize) -> bool {
        self.bodies[self.evaluated[e]].kind == AgentKind::Vehicle
    }

    fn place(&self, object: usize, s: &AgentState) -> Placed {
        let b = &self.bodies[object];
        let corners = OrientedBox::new(s.pose(), b.length_m, b.width_m).corners();
        Placed { state: *s, corners, radius_m: 0.5 * b.length_m.hypot(b.width_m) }
    }

    /// The features of one joint scene: `trajectories[object][index]`, all
    /// of length `current_index + 1 + future_steps`.
    pub fn features(&self, trajectories: &[Vec<Option<AgentState>>]) -> MetricFeatures {
        let f = self.future_steps;
        let future = |t: usize| self.current_index + 1 + t;
        let kin: Vec<[Vec<f64>; 4]> = trajectories.iter().map(|tr| kinematics(tr, self.step_s)).collect();
        let slice = |k: usize| -> Vec<Vec<f64>> {
            self.evaluated.iter().map(|&e| (0..f).map(|t| kin[e][k][future(t)]).collect()).collect()
        };
        let ne = self.evaluated.len();
        let mut out = MetricFeatures {
            valid: self
                .evaluated
                .iter()
                .map(|&e| (0..f).map(|t| trajectories[e][future(t)].is_some()).collect())
                .collect(),
            linear_speed: slice(0),
            linear_acceleration: slice(1),
            angular_speed: slice(2),
            angular_acceleration: slice(3),
            distance_to_nearest_object: vec![vec![EXTREMELY_LARGE_DISTANCE; f]; ne],
            collision: vec![vec![false; f]; ne],
            time_to_collision: vec![vec![MAXIMUM_TIME_TO_COLLISION_S; f]; ne],
            distance_to_road_edge: (!self.map.road_edges.is_empty())
                .then(|| vec![vec![-EXTREMELY_LARGE_DISTANCE; f]; ne]),
            offroad: (!self.map.road_edges.is_empty()).then(|| vec![vec![false; f]; ne]),
            traffic_light_violation: vec![vec![false; f]; ne],
        };
        for t in 0..f {
            let index = future(t);
            let placed: Vec<Option<Placed>> =
                trajectories.iter().enumerate().map(|(o, tr)| tr[index].map(|s| self.place(o, &s))).collect();
            for (ei, &e) in self.evaluated.iter().enumerate() {
                let Some(me) = placed[e] else { continue };
                let d = self.nearest_object_distance(e, &me, &placed);
                out.distance_to_nearest_object[ei][t] = d;
                out.collision[ei][t] = d < 0.0;
                out.time_to_collision[ei][t] = self.time_to_collision(e, &me, &placed, &kin, index);
                if let (Some(dist), Some(off)) = (out.distance_to_road_edge.as_mut(), out.offroad.as_mut()) {
                    let worst = self.road_edge_distance(e, &me);
                    dist[ei][t] = worst;
                    off[ei][t] = worst > 0.0;
                }
                let before = trajectories[e][index - 1];
                out.traffic_light_violation[ei][t] =
                    before.is_some_and(|b| self.violates_red_light(&b.position, &me.state.position, index));
            }
        }
        out
    }

    /// Largest signed road-edge distance of the box's corners, m.
    fn road_edge_distance(&self, object: usize, me: &Placed) -> f64 {
        let p = &me.state;
        let key = (object, [p.position.x.to_bits(), p.position.y.to_bits(), p.heading_rad.to_bits()]);
        if let Some(d) = self.road_edge_cache.borrow().get(&key) {
            return *d;
        }
        let worst = me
            .corners
            .iter()
            .filter_map(|c| self.map.signed_distance_to_road_edge(c))
            .fold(f64::NEG_INFINITY, f64::max);
        self.road_edge_cache.borrow_mut().insert(key, worst);
        worst
    }

    fn nearest_object_distance(&self, me_index: usize, me: &Placed, placed: &[Option<Placed>]) -> f64 {
        // Centre distance minus both bounding radii: a lower bound on the
        // box distance.
        let lower_bound =
            |other: &Placed| (other.state.position - me.state.position).norm() - me.radius_m - other.radius_m;
        let others =
            || placed.iter().enumerate().filter(|&(o, _)| o != me_index).filter_map(|(o, p)| Some((o, p.as_ref()?)));
        // The object with the least bound first: its exact distance is
        // usually the answer, and the bound then turns away the rest.
        let Some((first, nearest, _)) =
            others().map(|(o, p)| (o, p, lower_bound(p))).min_by(|a, b| a.2.total_cmp(&b.2))
        else {
            return EXTREMELY_LARGE_DISTANCE;
        };
        let mut best = EXTREMELY_LARGE_DISTANCE.min(signed_box_distance(&me.corners, &nearest.corners));
        for (_, other) in others().filter(|&(o, _)| o != first) {
            // (A NaN bound proves nothing: the exact distance is taken.)
            let bound = lower_bound(other);
            if bound < best || bound.is_nan() {
                best = best.min(signed_box_distance(&me.corners, &other.corners));
            }
        }
        best
    }

    fn time_to_collision(
        &self,
        me_index: usize,
        me: &Placed,
        placed: &[Option<Placed>],
        kin: &[[Vec<f64>; 4]],
        index: usize,
    ) -> f64 {
        let my_body = &self.bodies[me_index];
        let (sin_h, cos_h) = me.state.heading_rad.sin_cos();
        let mut ahead: Option<(f64, usize)> = None;
        for (o, other) in placed.iter().enumerate() {
            let Some(other) = other else { continue };
            if o == me_index {
                continue;
            }
            let body = &self.bodies[o];
            let yaw_diff = (other.state.heading_rad - me.state.heading_rad).abs();
            let d = other.state.position - me.state.position;
            let rel_x = cos_h * d.x + sin_h * d.y;
            // Exact early outs before the trigonometry (most pairs fail
            // one): the heading rule, and an object not ahead of the front
            // bumper (`long_offset` is never negative). Written so that a
            // NaN is turned away, as the full test turns it away.
            if !(yaw_diff <= MAX_HEADING_DIFF_RAD && rel_x - 0.5 * my_body.length_m > 0.0) {
                continue;
            }
            let (c, s) = (yaw_diff.cos().abs(), yaw_diff.sin().abs());
            let long_offset = 0.5 * body.length_m * c + 0.5 * body.width_m * s;
            let lat_offset = 0.5 * body.length_m * s + 0.5 * body.width_m * c;
            let rel_y = -sin_h * d.x + cos_h * d.y;
            let long_distance = rel_x - 0.5 * my_body.length_m - long_offset;
            let lat_overlap = rel_y.abs() - 0.5 * my_body.width_m - lat_offset;
            let following = long_distance > 0.0
                && yaw_diff <= MAX_HEADING_DIFF_RAD
                && lat_overlap < 0.0
                && (lat_overlap < -SMALL_OVERLAP_THRESHOLD_M || yaw_diff <= MAX_HEADING_DIFF_FOR_SMALL_OVERLAP_RAD);
            if following && ahead.is_none_or(|(best, _)| long_distance < best) {
                ahead = Some((long_distance, o));
            }
        }
        let Some((gap, o)) = ahead else { return MAXIMUM_TIME_TO_COLLISION_S };
        let rel_speed = kin[me_index][0][index] - kin[o][0][index];
        if rel_speed > 0.0 { (gap / rel_speed).min(MAXIMUM_TIME_TO_COLLISION_S) } else { MAXIMUM_TIME_TO_COLLISION_S }
    }

    fn violates_red_light(&self, before: &Point2, now: &Point2, index: usize) -> bool {
        let step = self.first_step + index;
        let crossed = self.signals.fences.iter().filter(|f| {
            f.states.get(step).is_some_and(|s| matches!(s, SignalState::Stop | SignalState::ArrowStop))
                && f.rel(before) < f.stop_rel
                && f.rel(now) > f.stop_rel
        });
        let mut lane: Option<Option<MapElementId>> = None;
        for f in crossed {
            let on = *lane.get_or_insert_with(|| self.signals.nearest_lane(now));
            if on == Some(f.lane) {
                return true;
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose2;

    fn corners(x: f64, y: f64, h: f64, l: f64, w: f64) -> [Point2; 4] {
        OrientedBox::new(Pose2::new(x, y, h), l, w).corners()
    }

    #[test]
    fn signed_box_distance_gap_and_penetration() {
        // Gap of 5.5 m between two 4.5 m cars 10 m apart.
        let d = signed_box_distance(&corners(0.0, 0.0, 0.0, 4.5, 2.0), &corners(10.0, 0.0, 0.0, 4.5, 2.0));
        assert!((d - 5.5).abs() < 1e-12, "{d}");
        // Overlap of 1 m along x: penetration depth 1.
        let d = signed_box_distance(&corners(0.0, 0.0, 0.0, 4.5, 2.0), &corners(3.5, 0.0, 0.0, 4.5, 2.0));
        assert!((d + 1.0).abs() < 1e-12, "{d}");
        // Side by side with 0.5 m lateral overlap: the smaller axis wins.
        let d = signed_box_distance(&corners(0.0, 0.0, 0.0, 4.5, 2.0), &corners(1.0, 1.5, 0.0, 4.5, 2.0));
        assert!((d + 0.5).abs() < 1e-12, "{d}");
        // Corner to corner diagonal gap: 3-4-5.
        let d = signed_box_distance(&corners(0.0, 0.0, 0.0, 2.0, 2.0), &corners(5.0, 6.0, 0.0, 2.0, 2.0));
        assert!((d - 5.0).abs() < 1e-12, "{d}");
        // Symmetric.
        let (a, b) = (corners(1.0, -3.0, 1.2, 4.5, 2.0), corners(-4.0, 2.0, -2.0, 4.0, 1.8));
        assert!((signed_box_distance(&a, &b) - signed_box_distance(&b, &a)).abs() < 1e-12);
        // Agrees with parry (via OrientedBox::distance) when apart.
        let (oa, ob) = (
            OrientedBox::new(Pose2::new(1.0, -3.0, 1.2), 4.5, 2.0),
            OrientedBox::new(Pose2::new(-4.0, 2.0, -2.0), 4.0, 1.8),
        );
        assert!((signed_box_distance(&a, &b) - oa.distance(&ob)).abs() < 1e-4);
    }

    #[test]
    fn kinematics_of_uniform_turning_motion() {
        // 10 m/s along x with heading increasing 0.02 rad per step.
        let states: Vec<Option<AgentState>> = (0..6)
            .map(|k| {
                Some(AgentState {
                    position: Point2::new(k as f64, 0.0),
                    heading_rad: 0.02 * k as f64,
                    velocity_mps: Vector2::new(10.0, 0.0),
                })
            })
            .collect();
        let [v, a, w, dw] = kinematics(&states, 0.1);
        assert!(v[0].is_nan() && v[5].is_nan());
        assert!((v[2] - 10.0).abs() < 1e-9);
        assert!(a[1].is_nan() && a[4].is_nan() && a[2].abs() < 1e-9);
        assert!((w[3] - 0.2).abs() < 1e-9);
        assert!(dw[2].abs() < 1e-6);
        // Across ±π the yaw rate is the short way round.
        let wrapped: Vec<Option<AgentState>> = [3.1, -3.1, -3.0]
            .iter()
            .map(|&h| Some(AgentState { position: Point2::origin(), heading_rad: h, velocity_mps: Vector2::zeros() }))
            .collect();
        let [_, _, w, _] = kinematics(&wrapped, 0.1);
        let expected = wrap(-3.0 - 3.1) / 2.0 / 0.1;
        assert!((w[1] - expected).abs() < 1e-9 && w[1] > 0.0, "{}", w[1]);
        assert_eq!(central_and(&[true, true, false, true]), vec![false, false, true, false]);
    }
}
