//! A fixed set of oriented boxes (the other agents at one step) with a
//! broad phase for the two queries the planners and the witness search ask
//! many times a step: "does this box touch any of them" and "how close does
//! it come to the nearest one". The boxes are sorted by centre x, so a query
//! only looks at those within reach along x; then only those whose bounding
//! circles are within reach are looked at further, and a separating-axis
//! gap computed in `f64` (a lower bound on the boxes' distance) settles
//! every case that is not within 1 cm (`SLACK_M`) of the answer's edge. Only the
//! rest go to parry's exact tests.
//!
//! The broad phase only skips boxes that the exact answer cannot depend on,
//! and decides a touch by itself only where the gap is more than
//! 1 cm either side of zero (parry's `f32` tests cannot disagree
//! there); the exact tests are the same calls in the same argument order as
//! a plain loop over the boxes, so every answer is bit-identical to that
//! loop's.

use super::OrientedBox;

/// Extra reach of the broad phase, m: far above the rounding of the circle
/// test, of the `f64` gap and of parry's `f32` tests, far below anything
/// that matters.
const SLACK_M: f64 = 0.01;

/// A box's centre, axes and half extents, for the `f64` gap.
#[derive(Debug, Clone, Copy)]
struct Frame {
    x: f64,
    y: f64,
    cos: f64,
    sin: f64,
    half_length_m: f64,
    half_width_m: f64,
}

impl Frame {
    #[cfg(test)]
    fn of(b: &OrientedBox) -> Self {
        Self::with_sin_cos(b, b.pose.heading_rad.sin_cos())
    }

    /// With the heading's `sin_cos()` already at hand.
    fn with_sin_cos(b: &OrientedBox, (sin, cos): (f64, f64)) -> Self {
        Self {
            x: b.pose.position.x,
            y: b.pose.position.y,
            cos,
            sin,
            half_length_m: 0.5 * b.length_m,
            half_width_m: 0.5 * b.width_m,
        }
    }

    /// The largest separation of the two boxes along any of their four
    /// edge normals: positive, a lower bound on their distance; negative
    /// along all four, they overlap by at least its magnitude (the
    /// separating-axis theorem, which is exact for two rectangles). NaN for
    /// NaN input.
    fn gap(&self, other: &Frame) -> f64 {
        let (dx, dy) = (other.x - self.x, other.y - self.y);
        // |cos| and |sin| of the heading difference: the other box's axes on this box's.
        let along = (self.cos * other.cos + self.sin * other.sin).abs();
        let across = (self.sin * other.cos - self.cos * other.sin).abs();
        let (a_l, a_w) = (self.half_length_m, self.half_width_m);
        let (b_l, b_w) = (other.half_length_m, other.half_width_m);
        let on_self_x = (dx * self.cos + dy * self.sin).abs() - a_l - (b_l * along + b_w * across);
        let on_self_y = (dy * self.cos - dx * self.sin).abs() - a_w - (b_l * across + b_w * along);
        let on_other_x = (dx * other.cos + dy * other.sin).abs() - b_l - (a_l * along + a_w * across);
        let on_other_y = (dy * other.cos - dx * other.sin).abs() - b_w - (a_l * across + a_w * along);
        on_self_x.max(on_self_y).max(on_other_x).max(on_other_y)
    }
}

#[derive(Debug, Clone, Copy)]
struct Entry {
    frame: Frame,
    radius_m: f64,
    shape: OrientedBox,
}

/// Boxes sorted by centre x, with their bounding-circle radii and axes.
#[derive(Debug, Clone, Default)]
pub struct BoxSet {
    entries: Vec<Entry>,
    max_radius_m: f64,
    /// Storage kept from one refill to the next: the entries in input
    /// order, and their sort keys (centre x, place in the input).
    unsorted: Vec<Entry>,
    keys: Vec<(f64, u32)>,
}

/// Whether the bounding circles of two boxes `d2` (squared centre distance)
/// apart, with radii summing to `reach`, surely overlap: then the circle
/// reject of [`OrientedBox::intersects`] cannot fire and its exact test
/// alone gives the same answer.
fn surely_within(d2: f64, reach: f64) -> bool {
    reach > SLACK_M && d2 < (reach - SLACK_M) * (reach - SLACK_M)
}

impl BoxSet {
    /// The set of `boxes`.
    pub fn new(boxes: impl IntoIterator<Item = OrientedBox>) -> Self {
        Self::with_sin_cos(boxes.into_iter().map(|b| (b, b.pose.heading_rad.sin_cos())))
    }

    /// The set of `boxes`, each with its heading's `sin_cos()` (worked out
    /// once by a caller whose boxes keep their headings over many sets).
    pub fn with_sin_cos(boxes: impl IntoIterator<Item = (OrientedBox, (f64, f64))>) -> Self {
        let mut set = Self::default();
        set.refill_with_sin_cos(boxes);
        set
    }

    /// Makes this the set [`Self::with_sin_cos`] would make of `boxes`,
    /// keeping its storage: for callers that build many sets a second.
    pub fn refill_with_sin_cos(&mut self, boxes: impl IntoIterator<Item = (OrientedBox, (f64, f64))>) {
        self.unsorted.clear();
        self.unsorted.extend(boxes.into_iter().map(|(shape, sin_cos)| Entry {
            frame: Frame::with_sin_cos(&shape, sin_cos),
            radius_m: shape.half_diagonal_m(),
            shape,
        }));
        // By x, ties in input order (a stable sort's order, without its
        // buffer). The small keys are sorted and the entries (a hundred
        // bytes each) moved once: moving the entries in the sort itself
        // was a sixth of the evasive planner's time.
        self.keys.clear();
        self.keys.extend(self.unsorted.iter().enumerate().map(|(i, e)| (e.frame.x, i as u32)));
        self.keys.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        self.entries.clear();
        self.entries.extend(self.keys.iter().map(|&(_, i)| self.unsorted[i as usize]));
        self.max_radius_m = self.entries.iter().map(|e| e.radius_m).fold(0.0, f64::max);
    }

    /// Number of boxes.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether the set holds no box.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The entries whose centre x lies within `reach` of `x` (all of them
    /// for an infinite or NaN reach).
    fn within_x(&self, x: f64, reach: f64) -> &[Entry] {
        if !reach.is_finite() || !x.is_finite() {
            return &self.entries;
        }
        let lo = self.entries.partition_point(|e| e.frame.x < x - reach);
        let hi = self.entries.partition_point(|e| e.frame.x <= x + reach);
        &self.entries[lo..hi.max(lo)]
    }

    /// Whether any box touches `query`: the same answer as
    /// `boxes.iter().any(|b| b.intersects(query))`.
    pub fn any_intersects(&self, query: &OrientedBox) -> bool {
        self.any_intersects_with_sin_cos(query, query.pose.heading_rad.sin_cos())
    }

    /// [`Self::any_intersects`], with the query's heading's `sin_cos()`
    /// already at hand (the same answer when they are that heading's).
    pub fn any_intersects_with_sin_cos(&self, query: &OrientedBox, sin_cos: (f64, f64)) -> bool {
        let q = Frame::with_sin_cos(query, sin_cos);
        let qr = query.half_diagonal_m();
        self.within_x(q.x, qr + self.max_radius_m + SLACK_M).iter().any(|e| {
            let reach = qr + e.radius_m;
            let (dx, dy) = (e.frame.x - q.x, e.frame.y - q.y);
            let d2 = dx * dx + dy * dy;
            if d2 > (reach + SLACK_M) * (reach + SLACK_M) {
                return false;
            }
            let gap = e.frame.gap(&q);
            if gap > SLACK_M {
                false
            } else if gap < -SLACK_M {
                true
            } else if surely_within(d2, reach) {
                e.shape.intersects_exact_with_sin_cos(query, (e.frame.sin, e.frame.cos))
            } else {
                e.shape.intersects_with_sin_cos(query, (e.frame.sin, e.frame.cos))
            }
        })
    }

    /// The smaller of `bound` and the clearance from `query` to the nearest
    /// box (0 for one it touches): the same answer as folding
    /// `if query.intersects(b) { 0 } else { query.distance(b) }` over the
    /// boxes with `f64::min`, starting from `bound`. Boxes that cannot come
    /// closer than `bound` are skipped, so a small bound makes the query
    /// cheap.
    pub fn clearance_below(&self, query: &OrientedBox, bound: f64) -> f64 {
        self.clearance_below_unless_at_most(query, bound, f64::NEG_INFINITY)
    }

    /// As [`Self::clearance_below`] wherever that answer is above `floor`;
    /// where it is not, some value `<= floor` (the search stops at the first
    /// box that brings the clearance down to `floor`). For callers that
    /// drop a candidate whose clearance falls to `floor`.
    pub fn clearance_below_unless_at_most(&self, query: &OrientedBox, bound: f64, floor: f64) -> f64 {
        self.clearance_below_unless_at_most_with_sin_cos(query, query.pose.heading_rad.sin_cos(), bound, floor)
    }

    /// [`Self::clearance_below_unless_at_most`], with the query's heading's
    /// `sin_cos()` already at hand (the same answer when they are that
    /// heading's).
    pub fn clearance_below_unless_at_most_with_sin_cos(
        &self,
        query: &OrientedBox,
        sin_cos: (f64, f64),
        bound: f64,
        floor: f64,
    ) -> f64 {
        let q = Frame::with_sin_cos(query, sin_cos);
        let qr = query.half_diagonal_m();
        let mut nearest = bound;
        for e in self.within_x(q.x, bound + qr + self.max_radius_m + SLACK_M) {
            let reach = nearest + qr + e.radius_m + SLACK_M;
            let (dx, dy) = (e.frame.x - q.x, e.frame.y - q.y);
            let d2 = dx * dx + dy * dy;
            if reach.is_finite() && d2 > reach * reach {
                continue;
            }
            // The distance is at least the gap (to well within the slack):
            // a box whose gap exceeds `nearest` cannot lower it, and one with
            // a positive gap does not touch.
            let gap = q.gap(&e.frame);
            if gap > nearest + SLACK_M {
                continue;
            }
            let touches = if gap > SLACK_M {
                false
            } else if surely_within(d2, qr + e.radius_m) {
                query.intersects_exact_with_sin_cos(&e.shape, sin_cos)
            } else {
                query.intersects_with_sin_cos(&e.shape, sin_cos)
            };
            let d = if touches { 0.0 } else { query.distance_with_sin_cos(&e.shape, sin_cos) };
            nearest = nearest.min(d);
            if nearest <= floor {
                break;
            }
        }
        nearest
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose2;

    /// A deterministic scatter of boxes of several sizes and headings.
    fn scatter(n: usize, seed: u64) -> Vec<OrientedBox> {
        let mut state = seed;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let pose = Pose2::new(next() * 200.0 - 100.0, next() * 60.0 - 30.0, next() * 6.3 - 3.15);
                OrientedBox::new(pose, 1.0 + next() * 12.0, 0.5 + next() * 2.5)
            })
            .collect()
    }

    #[test]
    fn answers_match_the_plain_loop_bit_for_bit() {
        let boxes = scatter(150, 7);
        let set = BoxSet::new(boxes.clone());
        assert_eq!(set.len(), 150);
        let mut hits = 0;
        for (i, query) in scatter(400, 11).iter().enumerate() {
            let any = boxes.iter().any(|b| b.intersects(query));
            assert_eq!(set.any_intersects(query), any, "query {i}");
            hits += usize::from(any);
            for bound in [f64::INFINITY, 5.0, 1.0, 0.2, 0.0] {
                let plain = boxes
                    .iter()
                    .map(|b| if query.intersects(b) { 0.0 } else { query.distance(b) })
                    .fold(bound, f64::min);
                assert_eq!(set.clearance_below(query, bound).to_bits(), plain.to_bits(), "query {i} bound {bound}");
            }
        }
        // The scatter exercises both answers.
        assert!(hits > 40 && hits < 360, "{hits}");
    }

    #[test]
    fn the_gap_bounds_the_distance_and_settles_touches_away_from_zero() {
        // Pairs close enough for every case: deep overlaps, near touches, small gaps.
        let (a, b) = (scatter(3000, 3), scatter(3000, 5));
        let mut decided = 0;
        for (i, (a, b)) in a.iter().zip(&b).enumerate() {
            let b = OrientedBox::new(
                Pose2 { position: a.pose.position + (b.pose.position - a.pose.position) * 0.08, ..b.pose },
                b.length_m,
                b.width_m,
            );
            let gap = Frame::of(a).gap(&Frame::of(&b));
            assert!(gap <= a.distance(&b) + 1e-4, "pair {i}: gap {gap} > distance {}", a.distance(&b));
            if gap.abs() > SLACK_M {
                assert_eq!(a.intersects(&b), gap < 0.0, "pair {i}: gap {gap}");
                decided += 1;
            }
        }
        assert!(decided > 2000, "{decided}");
    }

    #[test]
    fn dense_near_touching_queries_match_the_plain_loop() {
        // A tight cluster: most queries touch or nearly touch several boxes.
        let boxes: Vec<OrientedBox> = scatter(120, 17)
            .into_iter()
            .map(|b| OrientedBox::new(Pose2 { position: b.pose.position * 0.4, ..b.pose }, b.length_m, b.width_m))
            .collect();
        let set = BoxSet::new(boxes.clone());
        let (mut hits, mut near_edge) = (0, 0);
        for (i, query) in scatter(3000, 19).iter().enumerate() {
            let query = OrientedBox::new(
                Pose2 { position: query.pose.position * 0.4, ..query.pose },
                query.length_m * 0.3,
                query.width_m * 0.3,
            );
            let any = boxes.iter().any(|b| b.intersects(&query));
            assert_eq!(set.any_intersects(&query), any, "query {i}");
            hits += usize::from(any);
            let q = Frame::of(&query);
            near_edge += boxes.iter().filter(|b| Frame::of(b).gap(&q).abs() <= 0.1).count();
            for bound in [f64::INFINITY, 2.0, 0.5, 0.05] {
                let plain = boxes
                    .iter()
                    .map(|b| if query.intersects(b) { 0.0 } else { query.distance(b) })
                    .fold(bound, f64::min);
                assert_eq!(set.clearance_below(&query, bound).to_bits(), plain.to_bits(), "query {i} bound {bound}");
                for floor in [0.0, 0.1, 1.0] {
                    let floored = set.clearance_below_unless_at_most(&query, bound, floor);
                    if plain > floor {
                        assert_eq!(floored.to_bits(), plain.to_bits(), "query {i} bound {bound} floor {floor}");
                    } else {
                        assert!(floored <= floor, "query {i} bound {bound} floor {floor}: {floored}");
                    }
                }
            }
        }
        // Both answers, and many pairs within 10 cm of touching.
        assert!(hits > 300 && hits < 2700 && near_edge > 300, "{hits} {near_edge}");
    }

    #[test]
    fn an_empty_set_touches_nothing_and_keeps_the_bound() {
        let set = BoxSet::new(Vec::new());
        let q = OrientedBox::new(Pose2::new(0.0, 0.0, 0.0), 4.5, 2.0);
        assert!(set.is_empty());
        assert!(!set.any_intersects(&q));
        assert_eq!(set.clearance_below(&q, 3.0), 3.0);
        assert_eq!(set.clearance_below(&q, f64::INFINITY), f64::INFINITY);
    }
}
