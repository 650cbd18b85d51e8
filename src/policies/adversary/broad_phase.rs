//! The plausibility check's broad phase ([`Bounds`]): an axis-aligned
//! rectangle around a set of boxes, so that a CBV path and an agent whose
//! rectangles lie apart skip the exact box tests.

use crate::geometry::OrientedBox;

/// An axis-aligned rectangle holding a set of boxes (each box's centre
/// plus its half-diagonal either way), for a broad phase: boxes in two
/// disjoint ones cannot touch.
#[derive(Debug, Clone, Copy)]
pub(super) struct Bounds {
    min: crate::geometry::Point2,
    max: crate::geometry::Point2,
}

impl Bounds {
    /// The bounds of `boxes` (empty, and overlapping nothing, for none; the
    /// whole plane if a box has a NaN centre or size).
    pub(super) fn of<'a>(boxes: impl IntoIterator<Item = &'a OrientedBox>) -> Self {
        let mut bounds = Self {
            min: crate::geometry::Point2::new(f64::INFINITY, f64::INFINITY),
            max: crate::geometry::Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
        };
        // The last box's size and reach: a path's boxes all have one size,
        // so its square root is taken once.
        let mut last: Option<((u64, u64), f64)> = None;
        for b in boxes {
            // A micrometre wider than the half-diagonal: the bounds only
            // ever hold a little more.
            let size = (b.length_m.to_bits(), b.width_m.to_bits());
            let reach_m = match last {
                Some((of, reach_m)) if of == size => reach_m,
                _ => last.insert((size, b.half_diagonal_m() + 1e-6)).1,
            };
            let p = b.pose.position;
            if [p.x, p.y, reach_m].iter().any(|v| v.is_nan()) {
                // Where such a box is is unknown: it may be anywhere.
                return Self {
                    min: crate::geometry::Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
                    max: crate::geometry::Point2::new(f64::INFINITY, f64::INFINITY),
                };
            }
            bounds.min.x = bounds.min.x.min(p.x - reach_m);
            bounds.min.y = bounds.min.y.min(p.y - reach_m);
            bounds.max.x = bounds.max.x.max(p.x + reach_m);
            bounds.max.y = bounds.max.y.max(p.y + reach_m);
        }
        bounds
    }

    /// Whether the two rectangles may share a point: false only where one
    /// lies wholly beside the other (a NaN coordinate proves nothing, and
    /// leaves the exact tests to decide).
    pub(super) fn overlaps(&self, other: &Bounds) -> bool {
        !(self.max.x < other.min.x || other.max.x < self.min.x || self.max.y < other.min.y || other.max.y < self.min.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_hold_their_boxes_and_only_disjoint_ones_are_told_apart() {
        use crate::geometry::{Point2, Pose2};
        let at = |x: f64, y: f64, heading_rad: f64| {
            OrientedBox::new(Pose2 { position: Point2::new(x, y), heading_rad }, 4.0, 2.0)
        };
        let path = Bounds::of(&[at(0.0, 0.0, 0.0), at(10.0, 0.0, 0.7)]);
        // A box touching the path's last box at a corner is inside the bounds.
        let touching = at(12.5, 1.9, 0.0);
        assert!(touching.intersects(&at(10.0, 0.0, 0.7)));
        assert!(path.overlaps(&Bounds::of(&[touching])));
        // One 3 m clear of them is not.
        assert!(!path.overlaps(&Bounds::of(&[at(10.0, 8.0, 0.0)])));
        // No boxes overlap nothing; NaN proves nothing.
        assert!(!path.overlaps(&Bounds::of(&[])));
        assert!(path.overlaps(&Bounds::of(&[at(f64::NAN, 0.0, 0.0)])));
    }
}
