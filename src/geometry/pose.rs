//! Planar poses (position + heading) and angle arithmetic.

use super::{Point2, Vector2};

/// Wraps an angle in radians to `(-π, π]`.
pub fn wrap_angle(angle_rad: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    let mut a = angle_rad % two_pi;
    if a <= -std::f64::consts::PI {
        a += two_pi;
    } else if a > std::f64::consts::PI {
        a -= two_pi;
    }
    a
}

/// A position and heading in a scenario's local frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose2 {
    /// Position, metres.
    pub position: Point2,
    /// Heading, radians, counter-clockwise from +x.
    pub heading_rad: f64,
}

impl Pose2 {
    /// A pose at `(x, y)` with the given heading.
    pub fn new(x: f64, y: f64, heading_rad: f64) -> Self {
        Self { position: Point2::new(x, y), heading_rad }
    }

    /// Unit vector along the heading.
    pub fn forward(&self) -> Vector2 {
        Vector2::new(self.heading_rad.cos(), self.heading_rad.sin())
    }

    /// Expresses a world (local-frame) point in this pose's body frame
    /// (x forward, y to the left).
    pub fn to_body(&self, p: &Point2) -> Vector2 {
        let d = p - self.position;
        let (s, c) = self.heading_rad.sin_cos();
        Vector2::new(c * d.x + s * d.y, -s * d.x + c * d.y)
    }

    /// Maps a body-frame offset back to the scenario frame.
    pub fn from_body(&self, offset: &Vector2) -> Point2 {
        let (s, c) = self.heading_rad.sin_cos();
        self.position + Vector2::new(c * offset.x - s * offset.y, s * offset.x + c * offset.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_angle_stays_in_half_open_interval() {
        use std::f64::consts::PI;
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(0.5) - 0.5).abs() < 1e-12);
        assert!((wrap_angle(-7.0) - (-7.0 + 2.0 * PI)).abs() < 1e-12);
    }

    #[test]
    fn body_frame_round_trip() {
        let pose = Pose2::new(3.0, -2.0, 0.7);
        let p = Point2::new(10.0, 4.0);
        let back = pose.from_body(&pose.to_body(&p));
        assert!((back - p).norm() < 1e-12);
        // A point straight ahead lies on the body x axis.
        let ahead = pose.position + pose.forward() * 5.0;
        let b = pose.to_body(&ahead);
        assert!((b.x - 5.0).abs() < 1e-12 && b.y.abs() < 1e-12);
    }
}
