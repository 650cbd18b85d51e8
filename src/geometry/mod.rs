//! Plane geometry in a scenario's local frame: points, poses, oriented boxes,
//! polylines and polygons.
//!
//! All project code works in `f64` nalgebra types (`Point2`, `Vector2`) in
//! metres and radians. parry2d (glam, `f32`) is used only inside
//! [`oriented_box`] for box–box queries; conversion happens there and nowhere
//! else. Coordinates are re-centred per scenario (see `scenario`), so the
//! `f32` conversion at the parry boundary keeps millimetre precision.

pub mod box_set;
pub mod oriented_box;
pub mod polygon;
pub mod polyline;
pub mod pose;

pub use box_set::BoxSet;
pub use oriented_box::OrientedBox;
pub(crate) use oriented_box::SweptSeparation;
pub use polygon::Polygon;
pub use polyline::{Polyline, PolylineProjection};
pub use pose::{Pose2, wrap_angle};

/// A point in a scenario's local frame, metres.
pub type Point2 = nalgebra::Point2<f64>;
/// A displacement or velocity in a scenario's local frame (metres, or m/s).
pub type Vector2 = nalgebra::Vector2<f64>;

/// Whether a squared distance `d2` is clearly greater than `than_d2`: by a
/// relative margin (1e-9) far above rounding, so that the square roots of
/// the two are sure to differ and the larger one need not be taken. Hot
/// nearest-first searches turn candidates away on this before paying for a
/// square root; `false` for a NaN, which proves nothing.
pub fn clearly_farther_squared(d2: f64, than_d2: f64) -> bool {
    d2 > than_d2 * (1.0 + 1e-9)
}

#[cfg(test)]
mod tests {
    use super::clearly_farther_squared;

    #[test]
    fn clearly_farther_means_a_larger_square_root() {
        for than in [0.0, 1e-300, 1e-6, 1.0, 2500.0, 1e12] {
            assert!(!clearly_farther_squared(than, than));
            assert!(!clearly_farther_squared(f64::NAN, than));
            let beyond = than * (1.0 + 1e-8) + f64::MIN_POSITIVE;
            assert!(clearly_farther_squared(beyond, than), "{than}");
            assert!(beyond.sqrt() > than.sqrt(), "{than}");
        }
    }
}
