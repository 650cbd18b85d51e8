//! A fixed set of oriented boxes (the other agents at one step) with a
//! broad phase for the two queries the planners and the witness search ask
//! many times a step: "does this box touch any of them" and "how close does
//! it come to the nearest one". The boxes are sorted by centre x, so a query
//! only looks at those within reach along x, and then only those whose
//! bounding circles are within reach go to parry's exact tests.
//!
//! The broad phase only skips boxes that the exact answer cannot depend on
//! (with [`SLACK_M`] to spare for rounding), and the exact tests are the
//! same calls in the same argument order as a plain loop over the boxes, so
//! every answer is bit-identical to that loop's.

use super::OrientedBox;

/// Extra reach of the broad phase, m: far above the rounding of the circle
/// test and of parry's `f32` distance, far below anything that matters.
const SLACK_M: f64 = 0.01;

#[derive(Debug, Clone, Copy)]
struct Entry {
    x: f64,
    y: f64,
    radius_m: f64,
    shape: OrientedBox,
}

/// Boxes sorted by centre x, with their bounding-circle radii.
#[derive(Debug, Clone, Default)]
pub struct BoxSet {
    entries: Vec<Entry>,
    max_radius_m: f64,
}

/// Half the diagonal: the radius of a box's bounding circle (a plain
/// square root, cheaper than `hypot`; its rounding is far inside [`SLACK_M`]).
fn radius(b: &OrientedBox) -> f64 {
    0.5 * (b.length_m * b.length_m + b.width_m * b.width_m).sqrt()
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
        let mut entries: Vec<Entry> = boxes
            .into_iter()
            .map(|shape| Entry { x: shape.pose.position.x, y: shape.pose.position.y, radius_m: radius(&shape), shape })
            .collect();
        entries.sort_by(|a, b| a.x.total_cmp(&b.x));
        let max_radius_m = entries.iter().map(|e| e.radius_m).fold(0.0, f64::max);
        Self { entries, max_radius_m }
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
        let lo = self.entries.partition_point(|e| e.x < x - reach);
        let hi = self.entries.partition_point(|e| e.x <= x + reach);
        &self.entries[lo..hi.max(lo)]
    }

    /// Whether any box touches `query`: the same answer as
    /// `boxes.iter().any(|b| b.intersects(query))`.
    pub fn any_intersects(&self, query: &OrientedBox) -> bool {
        let (qx, qy, qr) = (query.pose.position.x, query.pose.position.y, radius(query));
        self.within_x(qx, qr + self.max_radius_m + SLACK_M).iter().any(|e| {
            let reach = qr + e.radius_m;
            let (dx, dy) = (e.x - qx, e.y - qy);
            let d2 = dx * dx + dy * dy;
            if d2 > (reach + SLACK_M) * (reach + SLACK_M) {
                false
            } else if surely_within(d2, reach) {
                e.shape.intersects_exact(query)
            } else {
                e.shape.intersects(query)
            }
        })
    }

    /// The smaller of `bound` and the clearance from `query` to the nearest
    /// box (0 for one it touches): the same answer as folding
    /// `if query.intersects(b) { 0 } else { query.distance(b) }` over the
    /// boxes with `f64::min`, starting from `bound`. Boxes whose bounding
    /// circles are farther than `bound` cannot lower it and are skipped,
    /// so a small bound makes the query cheap.
    pub fn clearance_below(&self, query: &OrientedBox, bound: f64) -> f64 {
        let (qx, qy, qr) = (query.pose.position.x, query.pose.position.y, radius(query));
        let mut nearest = bound;
        for e in self.within_x(qx, bound + qr + self.max_radius_m + SLACK_M) {
            let reach = nearest + qr + e.radius_m + SLACK_M;
            let (dx, dy) = (e.x - qx, e.y - qy);
            if reach.is_finite() && dx * dx + dy * dy > reach * reach {
                continue;
            }
            let touches = if surely_within(dx * dx + dy * dy, qr + e.radius_m) {
                query.intersects_exact(&e.shape)
            } else {
                query.intersects(&e.shape)
            };
            let d = if touches { 0.0 } else { query.distance(&e.shape) };
            nearest = nearest.min(d);
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
    fn an_empty_set_touches_nothing_and_keeps_the_bound() {
        let set = BoxSet::new(Vec::new());
        let q = OrientedBox::new(Pose2::new(0.0, 0.0, 0.0), 4.5, 2.0);
        assert!(set.is_empty());
        assert!(!set.any_intersects(&q));
        assert_eq!(set.clearance_below(&q, 3.0), 3.0);
        assert_eq!(set.clearance_below(&q, f64::INFINITY), f64::INFINITY);
    }
}
