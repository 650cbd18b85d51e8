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
pub use polygon::Polygon;
pub use polyline::{Polyline, PolylineProjection};
pub use pose::{Pose2, wrap_angle};

/// A point in a scenario's local frame, metres.
pub type Point2 = nalgebra::Point2<f64>;
/// A displacement or velocity in a scenario's local frame (metres, or m/s).
pub type Vector2 = nalgebra::Vector2<f64>;
