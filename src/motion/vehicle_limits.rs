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
    /// Highest lateral acceleration, m/s² (speed × yaw rate; default 9,
    /// about what a road car's tyres hold on dry asphalt).
    pub max_lateral_accel_mps2: f64,
    /// Most sideways drift a rollout may add up beyond what a car's
    /// sideslip allows, m (default 0.5). A car moves along its heading,
    /// give or take the sideslip of its centre in a turn; a crab of
    /// 0.35 m a step with a constant heading passes the per-step position
    /// check every step, so the excess is summed over the rollout
    /// ([`LimitMonitor`]).
    pub max_lateral_slip_m: f64,
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
            max_lateral_accel_mps2: DEFAULT_MAX_LATERAL_ACCEL_MPS2,
            max_lateral_slip_m: 0.5,
        }
    }
}

/// The default [`VehicleLimits::max_lateral_accel_mps2`], m/s²: about what
/// a road car's tyres hold on dry asphalt. The adversary's CBV is held to
/// it as well.
pub const DEFAULT_MAX_LATERAL_ACCEL_MPS2: f64 = 9.0;

/// The tightest turn a car drives, 1/m (a 4 m radius at its centre): the
/// recorded vehicles of WOMD interactive turn at most about 0.22 over
/// 0.5 s in which they move 0.5 m or more (beyond that the recorded
/// headings jump, a tracking glitch, not a turn). The unicycle of the
/// motion tokens has no such bound: at walking pace a yaw-rate token
/// swings a standing car round on the spot. The adversary's CBV is held to
/// it; the ego's own check ([`VehicleLimits::max_curvature_per_m`]) stays
/// looser, for the built-in planners' path following.
pub const CAR_MAX_CURVATURE_PER_M: f64 = 0.25;

/// The lateral acceleration the built-in planners keep within, m/s²: a
/// margin under the default [`VehicleLimits::max_lateral_accel_mps2`], so
/// that the reference planners drive as a car can.
pub const BUILTIN_MAX_LATERAL_ACCEL_MPS2: f64 = 8.5;

/// `yaw_rate_radps` cut so that a step from `speed_mps` to `next_speed_mps`
/// pulls at most `max_lateral_accel_mps2` (measured as
/// [`VehicleLimits::check`] does: the mean speed times the yaw rate).
pub fn within_grip(yaw_rate_radps: f64, speed_mps: f64, next_speed_mps: f64, max_lateral_accel_mps2: f64) -> f64 {
    let mean_speed = 0.5 * (speed_mps + next_speed_mps).abs();
    if mean_speed * yaw_rate_radps.abs() <= max_lateral_accel_mps2 {
        return yaw_rate_radps;
    }
    let top = max_lateral_accel_mps2 / mean_speed;
    yaw_rate_radps.clamp(-top, top)
}

/// The lateral acceleration of a step from `from` to `to` over `dt_s`,
/// m/s²: the mean of the two speeds times the heading change per second,
/// as [`VehicleLimits::check`] measures it.
pub fn lateral_accel_mps2(from: &AgentState, to: &AgentState, dt_s: f64) -> f64 {
    0.5 * (from.speed_mps() + to.speed_mps()) * wrap_angle(to.heading_rad - from.heading_rad).abs() / dt_s
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
            "{} {} {unit} exceeds the vehicle limit {} = {} {unit}",
            self.quantity,
            crate::number::rounded(self.value, 3),
            self.limit,
            crate::number::shown(self.bound),
            unit = self.unit
        )
    }
}

impl VehicleLimits {
    /// Names and values of the limits, for validation.
    pub fn entries(&self) -> [(&'static str, f64, &'static str); 9] {
        [
            ("max_speed_mps", self.max_speed_mps, "m/s"),
            ("max_accel_mps2", self.max_accel_mps2, "m/s²"),
            ("max_decel_mps2", self.max_decel_mps2, "m/s²"),
            ("max_yaw_rate_radps", self.max_yaw_rate_radps, "rad/s"),
            ("max_curvature_per_m", self.max_curvature_per_m, "1/m"),
            ("max_reverse_speed_mps", self.max_reverse_speed_mps, "m/s"),
            ("max_position_error_m", self.max_position_error_m, "m"),
            ("max_lateral_accel_mps2", self.max_lateral_accel_mps2, "m/s²"),
            ("max_lateral_slip_m", self.max_lateral_slip_m, "m"),
        ]
    }

    /// The yaw rate a control asks for, against the limit: reported as
    /// sent, where the heading change it causes wraps (1e308 rad/s would
    /// read as some 24 rad/s).
    pub fn check_control(&self, action: &crate::motion::Action) -> Option<LimitViolation> {
        let sent = action.yaw_rate_radps.abs();
        (sent.is_nan() || sent > self.max_yaw_rate_radps + SLACK).then_some(LimitViolation {
            limit: "max_yaw_rate_radps",
            quantity: "yaw rate sent",
            value: sent,
            bound: self.max_yaw_rate_radps,
            unit: "rad/s",
        })
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
                let lateral_accel = lateral_accel_mps2(now, next, dt_s);
                broke(
                    "max_lateral_accel_mps2",
                    "lateral acceleration",
                    lateral_accel,
                    self.max_lateral_accel_mps2,
                    "m/s²",
                )
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

/// How far behind the centre a car's rear axle is, m (half the
/// [`WHEELBASE_M`](super::kinematics::WHEELBASE_M)): in a turn of
/// curvature κ the centre slips sideways at an angle of about this × κ.
const CENTRE_TO_REAR_AXLE_M: f64 = 0.5 * super::kinematics::WHEELBASE_M;

/// Sideslip beyond the geometric one a tyre's slip angle allows in
/// ordinary driving, rad (about 3°).
const TYRE_SLIP_RAD: f64 = 0.05;

/// Sideways movement per step put down to rounding and interpolation, m.
const LATERAL_ROUNDING_M: f64 = 0.01;

/// [`VehicleLimits::check`] over a whole rollout, adding what no single
/// step shows: the sideways drift beyond a car's sideslip, summed
/// ([`VehicleLimits::max_lateral_slip_m`]).
#[derive(Debug, Clone)]
pub struct LimitMonitor {
    limits: VehicleLimits,
    slip_m: f64,
}

impl LimitMonitor {
    /// A monitor of a rollout that has not moved yet.
    pub fn new(limits: VehicleLimits) -> Self {
        Self { limits, slip_m: 0.0 }
    }

    /// The first limit the step from `now` to `next` breaks, the summed
    /// sideways drift included, or `None`.
    pub fn step(&mut self, now: &AgentState, next: &AgentState, dt_s: f64) -> Option<LimitViolation> {
        if let Some(v) = self.limits.check(now, next, dt_s) {
            return Some(v);
        }
        self.slip_m += lateral_slip_m(now, next);
        let bound = self.limits.max_lateral_slip_m;
        (self.slip_m.is_nan() || self.slip_m > bound + SLACK).then_some(LimitViolation {
            limit: "max_lateral_slip_m",
            quantity: "sideways drift beyond the car's sideslip, summed",
            value: self.slip_m,
            bound,
            unit: "m",
        })
    }
}

/// The step's sideways movement beyond what the sideslip of a car's
/// centre allows, m: movement across the mean heading, less the along
/// distance times the sideslip of a turn of the step's curvature.
fn lateral_slip_m(now: &AgentState, next: &AgentState) -> f64 {
    let driven = next.position - now.position;
    let turn = wrap_angle(next.heading_rad - now.heading_rad);
    let mean_heading = now.heading_rad + 0.5 * turn;
    let (sin, cos) = mean_heading.sin_cos();
    let along = driven.x * cos + driven.y * sin;
    let lateral = -driven.x * sin + driven.y * cos;
    let distance = driven.norm();
    let curvature = if distance > 0.0 { turn.abs() / distance } else { 0.0 };
    let allowed = along.abs() * (CENTRE_TO_REAR_AXLE_M * curvature + TYRE_SLIP_RAD) + LATERAL_ROUNDING_M;
    (lateral.abs() - allowed).max(0.0)
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
                    // Curvature and lateral acceleration are the limits a
                    // grid token may break: a full-rate turn below 1.5 m/s
                    // is tighter than a 1 m radius, and above 6 m/s it pulls
                    // more than 9 m/s² (the CBV's tokens are not held to the
                    // ego's limits).
                    let (v_next, tight) = (next.speed_mps(), yaw.abs() / next.speed_mps().max(1e-9) > 1.0);
                    let lateral = 0.5 * (speed + v_next) * yaw.abs() > 9.0;
                    let expected = if speed.min(v_next) >= 1.0 && tight {
                        Some("max_curvature_per_m")
                    } else {
                        lateral.then_some("max_lateral_accel_mps2")
                    };
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
    fn a_sideways_crab_adds_up_to_a_violation_that_no_single_step_shows() {
        // 0.35 m sideways a step at 10 m/s, heading held, velocities
        // reporting the crab: every step passes `check` on its own.
        let crab = |k: f64| AgentState {
            position: Point2::new(k, 0.35 * k),
            heading_rad: 0.0,
            velocity_mps: Vector2::new(10.0, 3.5),
        };
        let mut monitor = LimitMonitor::new(VehicleLimits::default());
        let mut broke_at = None;
        for k in 0..10 {
            assert_eq!(VehicleLimits::default().check(&crab(k as f64), &crab(k as f64 + 1.0), 0.1), None);
            if let Some(v) = monitor.step(&crab(k as f64), &crab(k as f64 + 1.0), 0.1) {
                assert_eq!(v.limit, "max_lateral_slip_m");
                broke_at = Some(k);
                break;
            }
        }
        assert_eq!(broke_at, Some(1), "0.29 m of excess a step passes 0.5 m at the second step");
        // A unicycle turning at the full token rate never slips.
        let mut monitor = LimitMonitor::new(VehicleLimits::default());
        let mut now = at(0.0, 0.0, 0.3, 5.0);
        for _ in 0..100 {
            let next = kinematic_step(
                &KinematicState::from_agent_state(&now),
                Action { accel_mps2: 0.0, yaw_rate_radps: 1.5 },
                0.1,
            )
            .to_agent_state();
            assert_eq!(monitor.step(&now, &next, 0.1), None);
            now = next;
        }
    }

    #[test]
    fn a_swerve_of_4_g_breaks_the_lateral_acceleration_limit() {
        // 1.4 rad/s at 30 m/s: 42 m/s², inside the yaw-rate limit.
        let now = at(0.0, 0.0, 0.0, 30.0);
        let next = kinematic_step(
            &KinematicState::from_agent_state(&now),
            Action { accel_mps2: 0.0, yaw_rate_radps: 1.4 },
            0.1,
        )
        .to_agent_state();
        let v = VehicleLimits::default().check(&now, &next, 0.1).unwrap();
        assert_eq!(v.limit, "max_lateral_accel_mps2");
        assert!((v.value - 42.0).abs() < 1e-6, "{v}");
    }

    #[test]
    fn a_yaw_rate_sent_is_reported_as_sent() {
        let v = VehicleLimits::default().check_control(&Action { accel_mps2: 0.0, yaw_rate_radps: -1e308 }).unwrap();
        assert_eq!(v.value, 1e308);
        assert!(v.to_string().starts_with("yaw rate sent 1e308 rad/s exceeds"), "{v}");
        assert_eq!(VehicleLimits::default().check_control(&Action { accel_mps2: -50.0, yaw_rate_radps: 1.5 }), None);
    }

    #[test]
    fn a_heading_across_minus_pi_is_a_small_turn() {
        let (now, next) = (at(0.0, 0.0, 3.13, 10.0), at(-1.0, 0.0, -3.13, 10.0));
        assert_eq!(broken(now, next), None);
    }
}
