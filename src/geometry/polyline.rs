//! Open polylines: lane centrelines, road edges, lane boundaries. Arc-length
//! parametrisation, projection of a point (arc length and signed lateral
//! offset), sampling, and the port-side signed distance that the Waymo Sim
//! Agents map metrics use for road edges.

use super::{Point2, Vector2};

/// An ordered list of points; consecutive points form segments.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Polyline {
    points: Vec<Point2>,
    /// Cumulative arc length at each point, metres (`cumulative_m[0] == 0`).
    cumulative_m: Vec<f64>,
    /// The axis-aligned bounds of each run of [`CHUNK_SEGMENTS`] segments
    /// (empty for a line of fewer than two runs): the broad phase of
    /// [`Polyline::project`], which a planner calls thousands of times a
    /// step on a route of hundreds of points.
    chunks: Vec<ChunkBounds>,
}

/// Segments per run of the projection's broad phase.
const CHUNK_SEGMENTS: usize = 16;

/// A run's bounds are skipped only when this much farther than the best
/// segment found, m: far above the rounding of a closest point's
/// coordinates, so pruning never changes which segment wins.
const CHUNK_PRUNE_SLACK_M: f64 = 1e-6;

/// The axis-aligned bounds of a run of segments.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ChunkBounds {
    min: Point2,
    max: Point2,
}

impl ChunkBounds {
    /// The bounds of `points`.
    fn of(points: &[Point2]) -> Self {
        let mut b = Self { min: points[0], max: points[0] };
        for p in &points[1..] {
            b.min = Point2::new(b.min.x.min(p.x), b.min.y.min(p.y));
            b.max = Point2::new(b.max.x.max(p.x), b.max.y.max(p.y));
        }
        b
    }

    /// The squared distance from `p` to the rectangle (0 inside it): no
    /// segment of the run is nearer.
    fn distance_squared(&self, p: &Point2) -> f64 {
        let dx = (self.min.x - p.x).max(p.x - self.max.x).max(0.0);
        let dy = (self.min.y - p.y).max(p.y - self.max.y).max(0.0);
        dx * dx + dy * dy
    }
}

/// Where a point projects onto a polyline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolylineProjection {
    /// Closest point on the polyline.
    pub point: Point2,
    /// Arc length of the closest point from the start, metres.
    pub arc_length_m: f64,
    /// Distance to the closest point, metres (non-negative).
    pub distance_m: f64,
    /// Distance with a side: negative on the port (left) side of the
    /// direction of travel, positive on the starboard (right) side. At a vertex
    /// the side follows the local convexity, as in the Waymo metrics.
    pub signed_distance_m: f64,
    /// Unit tangent of the segment the closest point lies on.
    pub tangent: Vector2,
    /// Index of that segment.
    pub segment: usize,
}

/// The squared distance from `p` to the segment from `a` to `b` and the
/// parameter of its closest point: [`Polyline::segment_distance_squared`]
/// for a segment whose ends are at hand (the same arithmetic, so the same
/// bits).
pub fn segment_distance_squared([a, b]: &[Point2; 2], p: &Point2) -> (f64, f64) {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
    ((a + ab * t - p).norm_squared(), t)
}

fn cross(a: &Vector2, b: &Vector2) -> f64 {
    a.x * b.y - a.y * b.x
}

impl Polyline {
    /// A polyline through `points`; consecutive duplicates are dropped so
    /// every segment has a direction.
    pub fn new(points: Vec<Point2>) -> Self {
        let mut pts: Vec<Point2> = Vec::with_capacity(points.len());
        for p in points {
            if pts.last().is_none_or(|q: &Point2| (p - q).norm() > 1e-9) {
                pts.push(p);
            }
        }
        let mut cumulative_m = Vec::with_capacity(pts.len());
        let mut s = 0.0;
        for (i, p) in pts.iter().enumerate() {
            if i > 0 {
                s += (p - pts[i - 1]).norm();
            }
            cumulative_m.push(s);
        }
        let n_segments = pts.len().saturating_sub(1);
        // Non-finite points would make the bounds meaningless: such a line
        // is projected by the plain scan.
        let finite = pts.iter().all(|p| p.x.is_finite() && p.y.is_finite());
        let chunks = if finite && n_segments >= 2 * CHUNK_SEGMENTS {
            (0..n_segments)
                .step_by(CHUNK_SEGMENTS)
                .map(|first| ChunkBounds::of(&pts[first..=(first + CHUNK_SEGMENTS).min(n_segments)]))
                .collect()
        } else {
            Vec::new()
        };
        Self { points: pts, cumulative_m, chunks }
    }

    /// The points, in order.
    pub fn points(&self) -> &[Point2] {
        &self.points
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when the polyline has no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Arc length from the start to point `i`, metres (`None` past the
    /// last point).
    pub fn arc_length_at_point_m(&self, i: usize) -> Option<f64> {
        self.cumulative_m.get(i).copied()
    }

    /// Total arc length, metres.
    pub fn length_m(&self) -> f64 {
        self.cumulative_m.last().copied().unwrap_or(0.0)
    }

    /// The same points in reverse order.
    pub fn reversed(&self) -> Polyline {
        Polyline::new(self.points.iter().rev().copied().collect())
    }

    /// The point at arc length `s` (clamped to the ends) and the unit
    /// tangent there.
    pub fn sample(&self, s_m: f64) -> Option<(Point2, Vector2)> {
        match self.points.len() {
            0 => None,
            1 => Some((self.points[0], Vector2::x())),
            n => {
                let s = s_m.clamp(0.0, self.length_m());
                let i = match self.cumulative_m.binary_search_by(|c| c.total_cmp(&s)) {
                    Ok(i) => i.min(n - 2),
                    Err(i) => i.saturating_sub(1).min(n - 2),
                };
                let seg = self.points[i + 1] - self.points[i];
                let len = seg.norm();
                let t = ((s - self.cumulative_m[i]) / len).clamp(0.0, 1.0);
                Some((self.points[i] + seg * t, seg / len))
            }
        }
    }

    /// Indices of the segments that reach arc lengths `from_m..=to_m` (for
    /// [`Polyline::project_segments`] on a stretch of the line).
    pub fn segments_between(&self, from_m: f64, to_m: f64) -> std::ops::Range<usize> {
        let first = self.cumulative_m.partition_point(|&a| a < from_m).saturating_sub(1);
        let end = self.cumulative_m.partition_point(|&a| a <= to_m).min(self.points.len().saturating_sub(1));
        first..end.max(first)
    }

    /// Cosine between the polyline's direction at `projection` and a heading:
    /// positive when travelling along the polyline.
    pub fn tangent_dot(&self, projection: &PolylineProjection, heading_rad: f64) -> f64 {
        projection.tangent.dot(&Vector2::new(heading_rad.cos(), heading_rad.sin()))
    }

    /// Resamples to `n >= 2` points equally spaced in arc length.
    pub fn resample(&self, n: usize) -> Polyline {
        let n = n.max(2);
        let total = self.length_m();
        Polyline::new((0..n).filter_map(|k| self.sample(total * k as f64 / (n - 1) as f64).map(|(p, _)| p)).collect())
    }

    /// Closest point on the polyline to `p`, with arc length and side.
    /// `None` for a polyline with fewer than two points.
    pub fn project(&self, p: &Point2) -> Option<PolylineProjection> {
        let n_segments = self.points.len().saturating_sub(1);
        let finite = p.x.is_finite() && p.y.is_finite();
        if self.chunks.is_empty() || !finite {
            return self.project_segments(p, 0..n_segments);
        }
        // The same answer as scanning every segment (the least distance,
        // ties to the lowest segment), with runs that cannot hold it
        // skipped: the nearest run first, then the others in order.
        let run = |c: usize| c * CHUNK_SEGMENTS..((c + 1) * CHUNK_SEGMENTS).min(n_segments);
        let (_, nearest) = self
            .chunks
            .iter()
            .enumerate()
            .map(|(c, bounds)| (bounds.distance_squared(p), c))
            .min_by(|a, b| a.0.total_cmp(&b.0))?;
        let mut best: Option<(f64, usize, f64)> = None;
        let scan = |segments: std::ops::Range<usize>, best: &mut Option<(f64, usize, f64)>| {
            for i in segments {
                let (d2, t) = self.segment_distance_squared(p, i);
                if best.is_none_or(|(bd, bi, _)| d2 < bd || (d2 == bd && i < bi)) {
                    *best = Some((d2, i, t));
                }
            }
        };
        scan(run(nearest), &mut best);
        for c in (0..self.chunks.len()).filter(|&c| c != nearest) {
            let bound_m = best.map_or(f64::INFINITY, |(bd, _, _)| bd.sqrt() + CHUNK_PRUNE_SLACK_M);
            if self.chunks[c].distance_squared(p) <= bound_m * bound_m {
                scan(run(c), &mut best);
            }
        }
        best.map(|closest| self.projection_at(p, closest))
    }

    /// [`Polyline::project`] for a point near one whose closest segment was
    /// `hint` (a rollout's previous step): the same answer for any hint,
    /// found with fewer distances when the hint is right or close. The
    /// hint's distance bounds the search: a run, or a segment, that lies
    /// farther (a segment's start less its length, a bound without a
    /// division) cannot hold the answer.
    pub fn project_near(&self, p: &Point2, hint: usize) -> Option<PolylineProjection> {
        let n_segments = self.points.len().saturating_sub(1);
        if n_segments == 0 || !(p.x.is_finite() && p.y.is_finite()) {
            return self.project(p);
        }
        // Far above the rounding of the bounds' arithmetic (relative 1e-16,
        // summed over at most millions of segments), small beside anything
        // that matters.
        let slack_m = CHUNK_PRUNE_SLACK_M + 1e-9 * (self.length_m() + p.x.abs() + p.y.abs());
        let hint = hint.min(n_segments - 1);
        let (d2, t) = self.segment_distance_squared(p, hint);
        let mut best = (d2, hint, t);
        let mut reach_m = d2.sqrt() + slack_m;
        let mut nan = d2.is_nan();
        let mut scan = |segments: std::ops::Range<usize>, best: &mut (f64, usize, f64), reach_m: &mut f64| {
            for i in segments {
                let length_m = self.cumulative_m[i + 1] - self.cumulative_m[i];
                let bound_m = *reach_m + length_m;
                if i == hint || (p - self.points[i]).norm_squared() > bound_m * bound_m {
                    continue;
                }
                let (d2, t) = self.segment_distance_squared(p, i);
                nan |= d2.is_nan();
                if d2 < best.0 || (d2 == best.0 && i < best.1) {
                    *best = (d2, i, t);
                    *reach_m = d2.sqrt() + slack_m;
                }
            }
        };
        if self.chunks.is_empty() {
            scan(0..n_segments, &mut best, &mut reach_m);
        } else {
            for (c, bounds) in self.chunks.iter().enumerate() {
                if bounds.distance_squared(p) <= reach_m * reach_m {
                    scan(c * CHUNK_SEGMENTS..((c + 1) * CHUNK_SEGMENTS).min(n_segments), &mut best, &mut reach_m);
                }
            }
        }
        // Absurd points (a NaN distance) order nothing: the plain search decides.
        if nan {
            return self.project(p);
        }
        Some(self.projection_at(p, best))
    }

    /// As [`Polyline::project`], restricted to the given segment indices
    /// (used with a spatial index that pre-selects candidate segments).
    pub fn project_segments(
        &self,
        p: &Point2,
        segments: impl IntoIterator<Item = usize>,
    ) -> Option<PolylineProjection> {
        let mut best: Option<(f64, usize, f64)> = None; // (dist², segment, t)
        for i in segments {
            let (d2, t) = self.segment_distance_squared(p, i);
            if best.is_none_or(|(bd, _, _)| d2 < bd) {
                best = Some((d2, i, t));
            }
        }
        best.map(|closest| self.projection_at(p, closest))
    }

    /// The projection of `p` whose closest point lies on segment `i` at
    /// parameter `t`, `d2` from `p` (squared).
    fn projection_at(&self, p: &Point2, (d2, i, t): (f64, usize, f64)) -> PolylineProjection {
        let (a, b) = (self.points[i], self.points[i + 1]);
        let ab = b - a;
        let len = ab.norm();
        let tangent = ab / len;
        let closest = a + ab * t;
        let distance_m = d2.sqrt();
        let side = self.side_of(p, i, t);
        PolylineProjection {
            point: closest,
            arc_length_m: self.cumulative_m[i] + t * len,
            distance_m,
            signed_distance_m: if side > 0.0 { -distance_m } else { distance_m },
            tangent,
            segment: i,
        }
    }

    /// The squared distance from `p` to segment `i` (`points[i]` to
    /// `points[i + 1]`) and the parameter of its closest point, exactly as
    /// [`Self::project_segments`] computes them.
    pub fn segment_distance_squared(&self, p: &Point2, i: usize) -> (f64, f64) {
        segment_distance_squared(&[self.points[i], self.points[i + 1]], p)
    }

    /// Positive when `p` is on the port side of segment `i` at parameter
    /// `t`. At an interior vertex the two segments meeting there decide: for
    /// a left (convex) turn the point must be left of both, for a right
    /// (concave) turn left of either.
    fn side_of(&self, p: &Point2, i: usize, t: f64) -> f64 {
        let seg = |k: usize| self.points[k + 1] - self.points[k];
        let left_of = |k: usize| cross(&seg(k), &(p - self.points[k]));
        let n_seg = self.points.len() - 1;
        let neighbour = if t <= 0.0 && i > 0 {
            Some(i - 1)
        } else if t >= 1.0 && i + 1 < n_seg {
            Some(i + 1)
        } else {
            None
        };
        match neighbour {
            None => left_of(i),
            Some(j) => {
                let (first, second) = if j < i { (j, i) } else { (i, j) };
                let convex = cross(&seg(first), &seg(second)) >= 0.0;
                let (l1, l2) = (left_of(first), left_of(second));
                let inside = if convex { l1 > 0.0 && l2 > 0.0 } else { l1 > 0.0 || l2 > 0.0 };
                if inside { 1.0 } else { -1.0 }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(pts: &[(f64, f64)]) -> Polyline {
        Polyline::new(pts.iter().map(|&(x, y)| Point2::new(x, y)).collect())
    }

    #[test]
    fn the_pruned_projection_is_the_full_scan() {
        // A long route that winds and doubles back past itself (so a far
        // run of it lies near a point too), queried on a grid that also
        // hits vertices and points equidistant from two segments.
        let points: Vec<(f64, f64)> = (0..400)
            .map(|k| {
                let s = k as f64 * 0.5;
                (30.0 * (s / 40.0).sin() + 0.1 * s, 25.0 * (s / 25.0).sin())
            })
            .collect();
        let l = line(&points);
        assert!(!l.chunks.is_empty(), "the line is long enough to be split into runs");
        let all = 0..l.len() - 1;
        let mut queries: Vec<Point2> = points.iter().map(|&(x, y)| Point2::new(x, y)).collect();
        for i in -40..=80 {
            for j in -40..=40 {
                queries.push(Point2::new(i as f64 * 0.75, j as f64 * 0.75));
            }
        }
        for q in &queries {
            assert_eq!(l.project(q), l.project_segments(q, all.clone()), "at {q:?}");
        }
        // From any hint, the hinted search gives the same answer too.
        for q in queries.iter().step_by(7) {
            let answer = l.project_segments(q, all.clone());
            let right = answer.map_or(0, |a| a.segment);
            for hint in [0, right.saturating_sub(1), right, right + 1, l.len() / 2, l.len() - 2, usize::MAX] {
                assert_eq!(l.project_near(q, hint), answer, "at {q:?} from {hint}");
            }
        }
        // A short line (no runs) and a single segment too.
        for short in [line(&points[..20]), line(&points[..2])] {
            for q in queries.iter().step_by(5) {
                for hint in [0, 3, 18] {
                    assert_eq!(short.project_near(q, hint), short.project(q), "at {q:?} from {hint}");
                }
            }
        }
        // Non-finite queries keep the plain scan's answer.
        let nan = Point2::new(f64::NAN, 1.0);
        assert_eq!(format!("{:?}", l.project_near(&nan, 3)), format!("{:?}", l.project_segments(&nan, all.clone())));
        assert_eq!(format!("{:?}", l.project(&nan)), format!("{:?}", l.project_segments(&nan, all.clone())));
    }

    #[test]
    fn segments_between_cover_the_stretch() {
        // Points at arc lengths 0, 10, 20, 30: segments 0, 1, 2.
        let l = line(&[(0.0, 0.0), (10.0, 0.0), (20.0, 0.0), (30.0, 0.0)]);
        assert_eq!(l.segments_between(5.0, 15.0), 0..2);
        assert_eq!(l.segments_between(10.0, 10.0), 0..2, "a vertex touches both its segments");
        assert_eq!(l.segments_between(25.0, 100.0), 2..3);
        assert!(l.segments_between(40.0, 50.0).is_empty());
    }

    #[test]
    fn projection_gives_arc_length_and_side() {
        let l = line(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)]);
        assert!((l.length_m() - 20.0).abs() < 1e-12);
        let left = l.project(&Point2::new(4.0, 2.0)).unwrap();
        assert!((left.arc_length_m - 4.0).abs() < 1e-12);
        assert!((left.signed_distance_m + 2.0).abs() < 1e-12, "port side is negative");
        let right = l.project(&Point2::new(4.0, -3.0)).unwrap();
        assert!((right.signed_distance_m - 3.0).abs() < 1e-12);
    }

    #[test]
    fn vertex_side_follows_convexity() {
        // Left turn at (10, 0): the region inside the corner is port side.
        let l = line(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)]);
        assert!(l.project(&Point2::new(9.0, 1.0)).unwrap().signed_distance_m < 0.0);
        // Outside the corner (beyond both segments) is starboard.
        assert!(l.project(&Point2::new(11.0, -1.0)).unwrap().signed_distance_m > 0.0);
        // Right turn: the outside of the corner is port side.
        let r = line(&[(0.0, 0.0), (10.0, 0.0), (10.0, -10.0)]);
        assert!(r.project(&Point2::new(11.0, 1.0)).unwrap().signed_distance_m < 0.0);
        assert!(r.project(&Point2::new(9.0, -1.0)).unwrap().signed_distance_m > 0.0);
    }

    #[test]
    fn sample_and_resample() {
        let l = line(&[(0.0, 0.0), (3.0, 0.0), (3.0, 4.0)]);
        let (p, t) = l.sample(5.0).unwrap();
        assert!((p - Point2::new(3.0, 2.0)).norm() < 1e-12);
        assert!((t - Vector2::new(0.0, 1.0)).norm() < 1e-12);
        let r = l.resample(8);
        assert_eq!(r.len(), 8);
        assert!((r.length_m() - 7.0).abs() < 1e-9);
    }

    #[test]
    fn duplicate_points_are_dropped() {
        let l = line(&[(0.0, 0.0), (0.0, 0.0), (1.0, 0.0)]);
        assert_eq!(l.len(), 2);
    }
}
