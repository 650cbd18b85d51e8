//! Oriented bounding boxes of agents and the box–box queries the simulator
//! and the feasibility labels need (intersection, separation distance).
//!
//! This is the one place that talks to parry2d. The relative pose of the two
//! boxes is computed in `f64` first and only then narrowed to parry's `f32`,
//! so precision does not depend on how far the scene is from the origin.

use parry2d::math::{Pose, Vec2};
use parry2d::query::details::{distance_cuboid_cuboid, intersection_test_cuboid_cuboid};
use parry2d::shape::Cuboid;

use super::{Point2, Pose2, Vector2};

/// An agent's footprint: a rectangle centred on its position, long side
/// along its heading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientedBox {
    /// Centre and heading in the scenario frame.
    pub pose: Pose2,
    /// Extent along the heading, metres.
    pub length_m: f64,
    /// Extent across the heading, metres.
    pub width_m: f64,
}

impl OrientedBox {
    /// A box at `pose` with the given length and width (metres).
    pub fn new(pose: Pose2, length_m: f64, width_m: f64) -> Self {
        Self { pose, length_m, width_m }
    }

    /// Half the diagonal, m: the radius of the box's bounding circle. A
    /// plain square root, several times cheaper than `hypot` and within an
    /// ulp of it (callers that reject on it keep a margin far above that).
    pub fn half_diagonal_m(&self) -> f64 {
        0.5 * (self.length_m * self.length_m + self.width_m * self.width_m).sqrt()
    }

    fn cuboid(&self) -> Cuboid {
        Cuboid::new(Vec2::new((self.length_m * 0.5) as f32, (self.width_m * 0.5) as f32))
    }

    /// Pose of `other` in this box's body frame, narrowed to `f32`.
    fn relative_pose(&self, other: &OrientedBox) -> Pose {
        self.relative_pose_with_sin_cos(other, self.pose.heading_rad.sin_cos())
    }

    /// [`Self::relative_pose`] with this box's heading's `sin_cos()` at hand
    /// (the same bits as [`Pose2::to_body`] works out).
    fn relative_pose_with_sin_cos(&self, other: &OrientedBox, (s, c): (f64, f64)) -> Pose {
        let d = other.pose.position - self.pose.position;
        let t = Vector2::new(c * d.x + s * d.y, -s * d.x + c * d.y);
        let yaw = other.pose.heading_rad - self.pose.heading_rad;
        Pose::new(Vec2::new(t.x as f32, t.y as f32), yaw as f32)
    }

    /// Whether the two boxes overlap (touching counts).
    pub fn intersects(&self, other: &OrientedBox) -> bool {
        // The heading's sine and cosine only once the cheap reject has
        // passed: most pairs a caller tests are far apart.
        self.within_reach(other) && self.intersects_exact_with_sin_cos(other, self.pose.heading_rad.sin_cos())
    }

    /// [`Self::intersects`] with this box's heading's `sin_cos()` at hand
    /// (see [`Self::intersects_exact_with_sin_cos`]).
    pub(crate) fn intersects_with_sin_cos(&self, other: &OrientedBox, sin_cos: (f64, f64)) -> bool {
        self.within_reach(other) && self.intersects_exact_with_sin_cos(other, sin_cos)
    }

    /// The cheap reject before the exact SAT test: whether the boxes'
    /// bounding circles meet, with a micrometre to spare (a reject only
    /// ever skips a test that would have said no; a NaN distance is left
    /// to the exact test).
    fn within_reach(&self, other: &OrientedBox) -> bool {
        self.within(other, self.reach_to(other))
    }

    /// The reach of [`Self::intersects`]'s cheap reject for this box and
    /// `other`: their bounding circles' radii and a micrometre. It depends
    /// on the two boxes' sizes only, so a caller testing many pairs of the
    /// same two sizes works it out once (see [`Self::intersects_within`]).
    pub fn reach_to(&self, other: &OrientedBox) -> f64 {
        self.half_diagonal_m() + other.half_diagonal_m() + 1e-6
    }

    /// Whether the centres are within `reach_m` (or NaN apart).
    fn within(&self, other: &OrientedBox, reach_m: f64) -> bool {
        let d2 = (self.pose.position - other.pose.position).norm_squared();
        d2.partial_cmp(&(reach_m * reach_m)) != Some(std::cmp::Ordering::Greater)
    }

    /// [`Self::intersects`], with `reach_m` the [`Self::reach_to`] of this
    /// box and `other` (or of any two boxes of their sizes): the same
    /// answer, without the bounding circles' square roots.
    pub fn intersects_within(&self, other: &OrientedBox, reach_m: f64) -> bool {
        self.within(other, reach_m) && self.intersects_exact_with_sin_cos(other, self.pose.heading_rad.sin_cos())
    }

    /// The separating-axis test of [`Self::intersects`] without its
    /// bounding-circle reject, for callers whose own broad phase has already
    /// shown that reject would not fire (see [`super::BoxSet`]).
    pub(crate) fn intersects_exact(&self, other: &OrientedBox) -> bool {
        intersection_test_cuboid_cuboid(&self.relative_pose(other), &self.cuboid(), &other.cuboid())
    }

    /// Separation distance between the boxes in metres; 0 when they overlap.
    pub fn distance(&self, other: &OrientedBox) -> f64 {
        distance_cuboid_cuboid(&self.relative_pose(other), &self.cuboid(), &other.cuboid()) as f64
    }

    /// [`Self::intersects_exact`] and [`Self::distance`] with this box's
    /// heading's `sin_cos()` at hand, for a caller that queries one box
    /// against many: the same answers, bit for bit.
    pub(crate) fn intersects_exact_with_sin_cos(&self, other: &OrientedBox, sin_cos: (f64, f64)) -> bool {
        intersection_test_cuboid_cuboid(
            &self.relative_pose_with_sin_cos(other, sin_cos),
            &self.cuboid(),
            &other.cuboid(),
        )
    }

    /// See [`Self::intersects_exact_with_sin_cos`].
    pub(crate) fn distance_with_sin_cos(&self, other: &OrientedBox, sin_cos: (f64, f64)) -> f64 {
        distance_cuboid_cuboid(&self.relative_pose_with_sin_cos(other, sin_cos), &self.cuboid(), &other.cuboid()) as f64
    }

    /// Distance from `point` to the box in metres; 0 inside it. For a
    /// bound on many boxes at once: every box whose centre lies within `r`
    /// of `point` is at least this less `r` and its half diagonal away.
    pub fn distance_to_point(&self, point: &Point2) -> f64 {
        let offset = self.pose.to_body(point);
        let outside_m = |along_m: f64, half_m: f64| (along_m.abs() - half_m).max(0.0);
        outside_m(offset.x, 0.5 * self.length_m).hypot(outside_m(offset.y, 0.5 * self.width_m))
    }

    /// The four corners, counter-clockwise starting front-left.
    pub fn corners(&self) -> [Point2; 4] {
        let (hl, hw) = (self.length_m * 0.5, self.width_m * 0.5);
        [
            self.pose.from_body(&Vector2::new(hl, hw)),
            self.pose.from_body(&Vector2::new(-hl, hw)),
            self.pose.from_body(&Vector2::new(-hl, -hw)),
            self.pose.from_body(&Vector2::new(hl, -hw)),
        ]
    }
}

/// Lower bounds of [`OrientedBox::distance`] between a box moving at a
/// constant velocity (without turning) and a box standing still, at any
/// lead time up to a limit, from the separating axes alone: the widest
/// gap between the boxes' shadows on the four edge normals, less a margin
/// for the `f32` rounding of the exact query. A bound is the exact
/// distance whenever the nearest features are an edge and what faces it,
/// and never above it; at most 0 (no bound) where the shadows overlap on
/// every axis; NaN where an input is, so that a caller comparing it skips
/// nothing.
///
/// Its use is pruning: a caller that needs the least of many distances
/// along the motion asks the exact query only where a bound could still
/// beat the least so far, and gets the same least, bit for bit. A shadow
/// moves linearly with the lead, so each bound costs a few operations.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SweptSeparation {
    /// Per edge normal: the offset's shadow at lead 0, its rate of change
    /// (m/s), and the two boxes' half-widths on it together.
    axes: [(f64, f64, f64); 4],
    margin_m: f64,
}

impl SweptSeparation {
    /// `moving` (its heading's `sin_cos()` at hand) moving at
    /// `velocity_mps` for up to `max_lead_s`, against `still` (likewise).
    pub(crate) fn new(
        moving: &OrientedBox,
        (s1, c1): (f64, f64),
        velocity_mps: Vector2,
        still: &OrientedBox,
        (s2, c2): (f64, f64),
        max_lead_s: f64,
    ) -> Self {
        let d = still.pose.position - moving.pose.position;
        let (a1, b1) = (0.5 * moving.length_m, 0.5 * moving.width_m);
        let (a2, b2) = (0.5 * still.length_m, 0.5 * still.width_m);
        // |cos| and |sin| of the heading difference.
        let (cos_d, sin_d) = ((c1 * c2 + s1 * s2).abs(), (s1 * c2 - c1 * s2).abs());
        let axis = |(x, y): (f64, f64), reach: f64| (d.x * x + d.y * y, velocity_mps.x * x + velocity_mps.y * y, reach);
        let axes = [
            axis((c1, s1), a1 + a2 * cos_d + b2 * sin_d),
            axis((-s1, c1), b1 + a2 * sin_d + b2 * cos_d),
            axis((c2, s2), a2 + a1 * cos_d + b1 * sin_d),
            axis((-s2, c2), b2 + a1 * sin_d + b1 * cos_d),
        ];
        // The exact query works in `f32` in the moving box's frame: a
        // relative error of about 1e-7 of the offset and the sizes. A
        // millimetre and 1e-5 of them is far above it and far below any
        // gap that matters. (The farthest offset by its 1-norm, no less
        // than its length: no square roots.)
        let l1 = |v: Vector2| v.x.abs() + v.y.abs();
        let farthest_m = l1(d) + l1(velocity_mps) * max_lead_s.abs();
        Self { axes, margin_m: 1e-3 + 1e-5 * (farthest_m + a1 + b1 + a2 + b2) }
    }

    /// A lower bound of the distance `lead_s` seconds on (within the limit).
    pub(crate) fn lower_bound_m(&self, lead_s: f64) -> f64 {
        let gap = |&(shadow, rate, reach): &(f64, f64, f64)| (shadow - rate * lead_s).abs() - reach;
        let [x, y, z, w] = &self.axes;
        gap(x).max(gap(y)).max(gap(z)).max(gap(w)) - self.margin_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn car(x: f64, y: f64, h: f64) -> OrientedBox {
        OrientedBox::new(Pose2::new(x, y, h), 4.5, 2.0)
    }

    #[test]
    fn a_reach_worked_out_once_gives_every_pair_of_those_sizes_the_same_answer() {
        // A car against a person on foot on a grid of offsets and headings
        // that crosses touching, grazing (the bounding circles' rim) and
        // apart; one reach for all the pairs.
        let person = |x: f64, y: f64, h: f64| OrientedBox::new(Pose2::new(x, y, h), 0.6, 0.6);
        let reach_m = car(0.0, 0.0, 0.0).reach_to(&person(0.0, 0.0, 0.0));
        let (mut touching, mut apart) = (0, 0);
        for i in -40..=40 {
            for j in -20..=20 {
                for h in [0.0, 0.4, 1.3, -2.9] {
                    let (a, b) = (car(0.0, 0.0, h), person(i as f64 * 0.07, j as f64 * 0.09, -h));
                    assert_eq!(a.intersects_within(&b, reach_m), a.intersects(&b), "{a:?} {b:?}");
                    if a.intersects(&b) { touching += 1 } else { apart += 1 }
                }
            }
        }
        assert!(touching > 1000 && apart > 1000, "{touching} {apart}");
    }

    #[test]
    fn a_point_is_as_far_from_a_box_as_a_tiny_box_there_is() {
        // Inside, beside a side, off a corner; against parry's box distance
        // to a 2 mm box at the point (its f32 arithmetic within 1e-5 m).
        let a = car(3.0, -1.0, 0.7);
        for (x, y) in [(3.0, -1.0), (3.5, -0.4), (8.0, 2.0), (-4.0, -6.0), (3.0, 4.0), (0.2, -2.9)] {
            let point = Point2::new(x, y);
            let tiny = OrientedBox::new(Pose2::new(x, y, 0.0), 0.002, 0.002);
            let d = a.distance_to_point(&point);
            assert!((d - a.distance(&tiny)).abs() < 2e-3, "({x}, {y}): {d} against {}", a.distance(&tiny));
        }
        assert_eq!(a.distance_to_point(&Point2::new(3.0, -1.0)), 0.0);
        // 1 m straight ahead of the front bumper.
        let ahead = a.pose.from_body(&Vector2::new(3.25, 0.0));
        assert!((a.distance_to_point(&ahead) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn distance_is_symmetric() {
        // parry once had an argument-order bug in cuboid–cuboid distance.
        let cases = [
            (car(0.0, 0.0, 0.0), car(7.0, 1.0, 0.4)),
            (car(1.0, -3.0, 1.2), car(-4.0, 2.0, -2.0)),
            (car(0.0, 0.0, 0.3), car(0.0, 5.0, 1.57)),
        ];
        for (a, b) in cases {
            let (dab, dba) = (a.distance(&b), b.distance(&a));
            assert!((dab - dba).abs() < 1e-4, "d(a,b)={dab} d(b,a)={dba}");
        }
    }

    #[test]
    fn axis_aligned_gap_matches_hand_computation() {
        // Front of a at x=2.25, back of b at x=10-2.25=7.75: gap 5.5 m.
        let d = car(0.0, 0.0, 0.0).distance(&car(10.0, 0.0, 0.0));
        assert!((d - 5.5).abs() < 1e-4, "{d}");
    }

    #[test]
    fn overlap_detected_and_distance_zero() {
        let a = car(0.0, 0.0, 0.0);
        let b = car(3.0, 1.0, 0.5);
        assert!(a.intersects(&b) && b.intersects(&a));
        assert_eq!(a.distance(&b), 0.0);
        assert!(!a.intersects(&car(0.0, 2.5, 0.0)));
    }

    #[test]
    fn the_separating_axis_bound_never_exceeds_the_distance_and_is_tight_face_to_face() {
        let sin_cos = |b: &OrientedBox| b.pose.heading_rad.sin_cos();
        let swept =
            |a: &OrientedBox, v: Vector2, b: &OrientedBox| SweptSeparation::new(a, sin_cos(a), v, b, sin_cos(b), 1.5);
        let bound = |a: &OrientedBox, b: &OrientedBox| swept(a, Vector2::zeros(), b).lower_bound_m(0.0);
        let truck = |x: f64, y: f64, h: f64| OrientedBox::new(Pose2::new(x, y, h), 12.0, 2.5);
        let (mut tight, mut pairs) = (0, 0);
        for i in -30..=30 {
            for j in -20..=20 {
                for (h1, h2) in [(0.0, 0.0), (0.3, -0.1), (1.2, 2.9), (-2.0, 0.7), (0.05, 0.05)] {
                    let (a, b) = (car(1e4, -2e3, h1), truck(1e4 + i as f64 * 0.61, -2e3 + j as f64 * 0.47, h2));
                    let (lb, d) = (bound(&a, &b), a.distance(&b));
                    assert!(lb <= d, "{a:?} {b:?}: bound {lb} > distance {d}");
                    pairs += 1;
                    tight += usize::from(d - lb < 0.01);
                }
            }
        }
        // Most pairs of the grid are an edge facing a side: tight there.
        assert!(tight * 2 > pairs, "{tight} of {pairs}");
        // Moving: the bound at a lead is the bound of the box moved there.
        let v = Vector2::new(14.0, -3.0);
        for lead_s in [0.0, 0.3, 0.7, 1.5] {
            for (h, y) in [(0.0, 3.0), (0.4, -4.0), (2.0, 0.0)] {
                let (a, b) = (car(0.0, 0.0, h), truck(12.0, y, -h));
                let moved = OrientedBox { pose: Pose2 { position: a.pose.position + v * lead_s, ..a.pose }, ..a };
                let lb = swept(&a, v, &b).lower_bound_m(lead_s);
                assert!(lb <= moved.distance(&b), "{lead_s} {h} {y}");
                assert!((lb - bound(&moved, &b)).abs() < 1e-3, "{lead_s} {h} {y}");
            }
        }
        // Nose to tail 5.5 m apart: the bound is the gap, less its margin.
        let (a, b) = (car(0.0, 0.0, 0.0), car(10.0, 0.0, 0.0));
        assert!((bound(&a, &b) - 5.5).abs() < 2e-3, "{}", bound(&a, &b));
        let nan = car(f64::NAN, 0.0, 0.0);
        assert!(bound(&a, &nan).is_nan());
    }

    #[test]
    fn far_from_origin_keeps_precision() {
        // Same configuration shifted by 10 km: the relative pose is computed in f64.
        let off = 10_000.0;
        let d = car(off, off, 0.0).distance(&car(off + 10.0, off, 0.0));
        assert!((d - 5.5).abs() < 1e-4, "{d}");
    }
}
