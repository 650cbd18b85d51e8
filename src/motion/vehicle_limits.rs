//! The physics the planner under test is held to. A planner's output is
//! applied as it says (a control through the kinematic model, or the
//! planned state one step ahead), so without a check a reply could teleport
//! the ego 70 m over the car in front, stop it from 20 m/s in one step, or
//! reverse it at 15 m/s while reporting a standstill, and pass. Every step
//! of the ego is checked against [`VehicleLimits`]: speed, acceleration and
//! deceleration (from the reported speeds), yaw rate and curvature (from
//! the headings and the distance driven), reversing speed, and the position
//! against the reported velocities. In the simulator a violation ends the
//! rollout (`Termination::VehicleLimitExceeded`) naming the step, the limit
//! and the value; such a variant is never solved. Planted faults keep their
//! changed controls inside the same limits.
//!
//! The defaults are generous bounds on a road car, not comfort limits: a
//! planner inside them can still be a bad driver, but not an impossible
//! one.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::scenario::AgentState;

/// Limits on the ego's motion between two consecutive steps.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct VehicleLimits {
    /// Highest speed, m/s (default 70, about 250 km/h).
    pub max_speed_mps: f64,
    /// Highest acceleration, m/s² (default 8: beyond a sports car's).
    pub max_accel_mps2: f64,
    /// Highest deceleration, m/s², positive (default 12: beyond an
    /// emergency stop on dry asphalt, about 1 g).
    pub max_decel_mps2: f64,
    /// Highest yaw rate, rad/s (default 1.5, the motion tokens' range).
    pub max_yaw_rate_radps: f64,
    /// Highest curvature of the path driven, 1/m, checked while the ego
    /// moves at 1 m/s or more (default 1: a 1 m radius, tighter than any
    /// road vehicle turns; the built-in planners' path following reaches
    /// 0.7 at walking pace on recorded intersections, and a team whose car
    /// turns no tighter than 5 m sets 0.2).
    pub max_curvature_per_m: f64,
    /// Highest reversing speed along the heading, m/s (default 3).
    pub max_reverse_speed_mps: f64,
    /// Largest gap between where the ego is and where its reported
    /// velocities (the mean of the two steps') put it, m per step
    /// (default 0.5: a 5 m/s disagreement).
    pub max_position_error_m: f64,
}

impl Default for VehicleLimits {
    fn default() -> Self {
        Self {
            max_speed_mps: 70.0,
            max_accel_mps2: 8.0,
            max_decel_mps2: 12.0,
            max_yaw_rate_radps: 1.5,
            max_curvature_per_m: 1.0,
            max_reverse_speed_mps: 3.0,
            max_position_error_m: 0.5,
        }
    }
}

/// Floating-point slack on every limit (a planner exactly at a limit,
/// through the kinematic model's rounding, is inside it).
const SLACK: f64 = 1e-6;

/// Speed from which the curvature is checked, m/s: below it a car's
/// heading may still change on the spot in the token model.
const CURVATURE_CHECK_FROM_MPS: f64 = 1.0;

/// A limit the ego's motion broke.
#[derive(Debug, Clone, PartialEq)]
pub struct LimitViolation {
    /// The limit's key in a spec (`max_decel_mps2`).
    pub limit: &'static str,
    /// What was measured, in words.
    pub quantity: &'static str,
    /// The measured value.
    pub value: f64,
    /// The limit's value.
    pub bound: f64,
    /// The unit of both.
    pub unit: &'static str,
}

impl std::fmt::Display for LimitViolation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} {:.3} {unit} exceeds the vehicle limit {} = {} {unit}",
            self.quantity,
            self.value,
            self.limit,
            self.bound,
            unit = self.unit
        )
    }
}

impl VehicleLimits {
    /// Names and values of the limits, for validation.
    pub fn entries(&self) -> [(&'static str, f64, &'static str); 7] {
        [
            ("max_speed_mps", self.max_speed_mps, "m/s"),
            ("max_accel_mps2", self.max_accel_mps2, "m/s²"),
            ("max_decel_mps2", self.max_decel_mps2, "m/s²"),
            ("max_yaw_rate_radps", self.max_yaw_rate_radps, "rad/s"),
            ("max_curvature_per_m", self.max_curvature_per_m, "1/m"),
            ("max_reverse_speed_mps", self.max_reverse_speed_mps, "m/s"),
            ("max_position_error_m", self.max_position_error_m, "m"),
        ]
    }

    /// The first limit the step from `now` to `next` (`dt_s` apart)
    /// breaks, or `None`.
    pub fn check(&self, now: &AgentState, next: &AgentState, dt_s: f64) -> Option<LimitViolation> {
        let broke = |limit, quantity, value: f64, bound: f64, unit| {
            // A NaN quantity (from absurd states) breaks the limit too.
            (value.is_nan() || value > bound + SLACK).then_some(LimitViolation { limit, quantity, value, bound, unit })
        };
        let (v0, v1) = (now.speed_mps(), next.speed_mps());
        let driven = next.position - now.position;
        let expected = (now.velocity_mps + next.velocity_mps) * (0.5 * dt_s);
        let turn = wrap_angle(next.heading_rad - now.heading_rad).abs();
        let along = driven.x * now.heading_rad.cos() + driven.y * now.heading_rad.sin();
        let moving = v0.min(v1) >= CURVATURE_CHECK_FROM_MPS && driven.norm() > 0.0;
        broke("max_speed_mps", "speed", v1, self.max_speed_mps, "m/s")
            .or_else(|| broke("max_accel_mps2", "acceleration", (v1 - v0) / dt_s, self.max_accel_mps2, "m/s²"))
            .or_else(|| broke("max_decel_mps2", "deceleration", (v0 - v1) / dt_s, self.max_decel_mps2, "m/s²"))
            .or_else(|| broke("max_yaw_rate_radps", "yaw rate", turn / dt_s, self.max_yaw_rate_radps, "rad/s"))
            .or_else(|| {
                let curvature = if moving { turn / driven.norm() } else { 0.0 };
                broke("max_curvature_per_m", "curvature", curvature, self.max_curvature_per_m, "1/m")
            })
            .or_else(|| {
                broke("max_reverse_speed_mps", "reversing speed", -along / dt_s, self.max_reverse_speed_mps, "m/s")
            })
            .or_else(|| {
                let error = (driven - expected).norm();
                broke(
                    "max_position_error_m",
                    "distance between the position and where the reported velocities put it",
                    error,
                    self.max_position_error_m,
                    "m",
                )
            })
    }
}

/// An angle in (−π, π].
fn wrap_angle(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    let w = a.rem_euclid(two_pi);
    if w > std::f64::consts::PI { w - two_pi } else { w }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::motion::kinematic_step;
    use crate::motion::{Action, KinematicState};

    fn at(x: f64, y: f64, heading: f64, speed: f64) -> AgentState {
        AgentState {
            position: Point2::new(x, y),
            heading_rad: heading,
            velocity_mps: Vector2::new(heading.cos(), heading.sin()) * speed,
        }
    }

    fn broken(now: AgentState, next: AgentState) -> Option<&'static str> {
        VehicleLimits::default().check(&now, &next, 0.1).map(|v| v.limit)
    }

    #[test]
    fn every_token_of_the_grid_is_inside_the_limits() {
        // The motion tokens' extremes at speeds from standstill to 40 m/s.
        for speed in [0.0, 0.5, 1.0, 5.0, 20.0, 40.0] {
            for accel in [-5.0, 0.0, 5.0] {
                for yaw in [-1.5, 0.0, 1.5] {
                    let now = at(3.0, -2.0, 0.7, speed);
                    let next = kinematic_step(
                        &KinematicState::from_agent_state(&now),
                        Action { accel_mps2: accel, yaw_rate_radps: yaw },
                        0.1,
                    )
                    .to_agent_state();
                    let v = VehicleLimits::default().check(&now, &next, 0.1);
                    // Curvature is the one limit a grid token may break: a
                    // full-rate turn below 1.5 m/s is tighter than a 1 m radius.
                    let (v_next, tight) = (next.speed_mps(), yaw.abs() / next.speed_mps().max(1e-9) > 1.0);
                    let expected = (speed.min(v_next) >= 1.0 && tight).then_some("max_curvature_per_m");
                    assert_eq!(v.map(|v| v.limit), expected, "{speed} {accel} {yaw}");
                }
            }
        }
    }

    #[test]
    fn a_teleport_an_instant_stop_and_a_reverse_reported_as_standing_are_caught() {
        // 70 m ahead in one step at a reported 20 m/s.
        assert_eq!(broken(at(0.0, 0.0, 0.0, 20.0), at(70.0, 0.0, 0.0, 20.0)), Some("max_position_error_m"));
        // From 20 m/s to a standstill in 0.1 s: 200 m/s².
        let stop = VehicleLimits::default().check(&at(0.0, 0.0, 0.0, 20.0), &at(1.0, 0.0, 0.0, 0.0), 0.1).unwrap();
        assert_eq!(stop.limit, "max_decel_mps2");
        assert!((stop.value - 200.0).abs() < 1e-9, "{stop}");
        assert!(stop.to_string().contains("deceleration 200.000 m/s² exceeds the vehicle limit max_decel_mps2 = 12"));
        // Backwards 1.5 m in a step (15 m/s) while reporting 0 m/s.
        assert_eq!(broken(at(0.0, 0.0, 0.0, 0.0), at(-1.5, 0.0, 0.0, 0.0)), Some("max_reverse_speed_mps"));
        // Sideways 1 m in a step, heading and speed unchanged.
        assert_eq!(broken(at(0.0, 0.0, 0.0, 10.0), at(1.0, 1.0, 0.0, 10.0)), Some("max_position_error_m"));
        // A turn on the spot at speed: 90° in one step.
        assert_eq!(broken(at(0.0, 0.0, 0.0, 10.0), at(1.0, 0.0, 1.57, 10.0)), Some("max_yaw_rate_radps"));
        // Too fast.
        assert_eq!(broken(at(0.0, 0.0, 0.0, 75.0), at(7.5, 0.0, 0.0, 75.0)), Some("max_speed_mps"));
    }

    #[test]
    fn a_heading_across_minus_pi_is_a_small_turn() {
        let (now, next) = (at(0.0, 0.0, 3.13, 10.0), at(-1.0, 0.0, -3.13, 10.0));
        assert_eq!(broken(now, next), None);
    }
}
