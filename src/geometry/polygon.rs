//! Simple polygons: drivable areas, lanelets, crosswalks.

use super::{Point2, Polyline};

/// A simple polygon given by its boundary; the closing edge is implicit.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Polygon {
    /// Boundary vertices, in order, without repeating the first.
    pub vertices: Vec<Point2>,
}

impl Polygon {
    /// A polygon from its boundary; a repeated closing vertex is dropped.
    pub fn new(mut vertices: Vec<Point2>) -> Self {
        if vertices.len() > 1 && (vertices[0] - vertices[vertices.len() - 1]).norm() < 1e-9 {
            vertices.pop();
        }
        Self { vertices }
    }

    /// Signed area, m²: positive for counter-clockwise vertex order.
    pub fn signed_area_m2(&self) -> f64 {
        let n = self.vertices.len();
        (0..n)
            .map(|i| {
                let (a, b) = (self.vertices[i], self.vertices[(i + 1) % n]);
                a.x * b.y - b.x * a.y
            })
            .sum::<f64>()
            * 0.5
    }

    /// Whether `p` is inside (even–odd rule; boundary points may go either way).
    pub fn contains(&self, p: &Point2) -> bool {
        let n = self.vertices.len();
        if n < 3 {
            return false;
        }
        let mut inside = false;
        let mut j = n - 1;
        for i in 0..n {
            let (a, b) = (self.vertices[i], self.vertices[j]);
            if (a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x {
                inside = !inside;
            }
            j = i;
        }
        inside
    }

    /// The closed boundary as a polyline, oriented counter-clockwise so the
    /// interior is on its port side (the road-edge convention).
    pub fn boundary_ccw(&self) -> Polyline {
        let mut pts = self.vertices.clone();
        if self.signed_area_m2() < 0.0 {
            pts.reverse();
        }
        if let Some(first) = pts.first().copied() {
            pts.push(first);
        }
        Polyline::new(pts)
    }

    /// Axis-aligned bounds `(min, max)`.
    pub fn bounds(&self) -> Option<(Point2, Point2)> {
        let first = *self.vertices.first()?;
        Some(self.vertices.iter().fold((first, first), |(lo, hi), p| {
            (Point2::new(lo.x.min(p.x), lo.y.min(p.y)), Point2::new(hi.x.max(p.x), hi.y.max(p.y)))
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contains_and_orientation() {
        let sq = Polygon::new(vec![
            Point2::new(0.0, 0.0),
            Point2::new(0.0, 2.0),
            Point2::new(2.0, 2.0),
            Point2::new(2.0, 0.0),
            Point2::new(0.0, 0.0),
        ]);
        assert_eq!(sq.vertices.len(), 4);
        assert!(sq.signed_area_m2() < 0.0, "clockwise input");
        assert!(sq.contains(&Point2::new(1.0, 1.0)));
        assert!(!sq.contains(&Point2::new(3.0, 1.0)));
        // The CCW boundary has the interior on its port side (negative distance).
        let b = sq.boundary_ccw();
        assert!(b.project(&Point2::new(1.0, 0.5)).unwrap().signed_distance_m < 0.0);
        assert!(b.project(&Point2::new(1.0, -0.5)).unwrap().signed_distance_m > 0.0);
    }
}
