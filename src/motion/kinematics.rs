//! The kinematic model `K` of the token contract: a unicycle stepped at the
//! simulator's 0.1 s with semi-implicit Euler.
//!
//! One step with action (a, ψ̇) and step length `dt`:
//! 1. `v ← max(0, v + a·dt)` (no reversing),
//! 2. `θ ← wrap(θ + ψ̇·dt)`,
//! 3. `p ← p + v·dt·(cos θ, sin θ)` with the *updated* `v` and `θ`.
//!
//! The order is part of the contract: the token inversion, the adversary's
//! next-state prediction and the simulator all call this one function.

use crate::geometry::{Point2, Vector2, wrap_angle};
use crate::scenario::AgentState;

use super::Action;

/// The wheelbase of the car the unicycle stands for, m: the model itself
/// has none, but a steering angle (a planner's view of the ego) and the
/// sideslip a turn allows (the vehicle limits) are worked out for a
/// kinematic bicycle with this wheelbase.
pub const WHEELBASE_M: f64 = 3.0;

/// Below this speed along the heading, m/s, a path has no curvature to
/// speak of and [`steering_angle_rad`] is 0.
pub const STEERING_MIN_SPEED_MPS: f64 = 0.1;

/// The front-wheel steering angle, rad (positive steers left), of a
/// kinematic bicycle with a [`WHEELBASE_M`] wheelbase driving the path a
/// unicycle drives at this yaw rate and speed: atan(wheelbase ×
/// yaw rate / speed), in (-π/2, π/2); 0 below [`STEERING_MIN_SPEED_MPS`].
pub fn steering_angle_rad(yaw_rate_radps: f64, speed_mps: f64) -> f64 {
    if speed_mps.abs() < STEERING_MIN_SPEED_MPS || !yaw_rate_radps.is_finite() {
        return 0.0;
    }
    (WHEELBASE_M * yaw_rate_radps / speed_mps).atan()
}

/// The state the kinematic model evolves: pose and scalar speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KinematicState {
    /// Position, metres.
    pub position: Point2,
    /// Heading, radians in `(-π, π]`.
    pub heading_rad: f64,
    /// Speed along the heading, m/s (never negative).
    pub speed_mps: f64,
}

impl KinematicState {
    /// From a recorded state: speed is the velocity's component along the
    /// heading, clamped at 0 (the model cannot reverse).
    pub fn from_agent_state(s: &AgentState) -> Self {
        let forward = Vector2::new(s.heading_rad.cos(), s.heading_rad.sin());
        Self { position: s.position, heading_rad: s.heading_rad, speed_mps: s.velocity_mps.dot(&forward).max(0.0) }
    }

    /// Back to an agent state, velocity along the heading.
    pub fn to_agent_state(&self) -> AgentState {
        self.to_agent_state_with_sin_cos(self.heading_rad.sin_cos())
    }

    /// [`Self::to_agent_state`] with the heading's `sin_cos()` at hand (as
    /// [`step_with_sin_cos`] gives it): the same state, without the
    /// trigonometry again.
    pub fn to_agent_state_with_sin_cos(&self, (sin, cos): (f64, f64)) -> AgentState {
        AgentState {
            position: self.position,
            heading_rad: self.heading_rad,
            velocity_mps: Vector2::new(cos, sin) * self.speed_mps,
        }
    }
}

/// Advances `state` by one step of `dt_s` seconds under `action`.
#[inline]
pub fn step(state: &KinematicState, action: Action, dt_s: f64) -> KinematicState {
    step_with_sin_cos(state, action, dt_s).0
}

/// [`step`], also giving the new heading's `sin_cos()`: a caller that
/// puts a box at the new state (a collision or clearance query) needs them
/// again, and sine and cosine are the costliest part of a step.
#[inline]
pub fn step_with_sin_cos(state: &KinematicState, action: Action, dt_s: f64) -> (KinematicState, (f64, f64)) {
    let heading_rad = turned_heading_rad(state.heading_rad, action.yaw_rate_radps, dt_s);
    let sin_cos = heading_rad.sin_cos();
    (step_to_heading(state, action.accel_mps2, heading_rad, sin_cos, dt_s), sin_cos)
}

/// [`step_with_sin_cos`] for a rollout whose heading often holds from one
/// step to the next (a straight prediction, a stopped agent, a turn that
/// has ended): the heading's `sin_cos()` is worked out again only when the
/// heading changes, so every step is the same to the bit.
#[derive(Debug, Clone, Copy, Default)]
pub struct HeldHeadingStepper {
    /// The last heading's bits and its `sin_cos()`.
    last: Option<(u64, (f64, f64))>,
}

impl HeldHeadingStepper {
    /// [`step_with_sin_cos`]`(state, action, dt_s)`.
    #[inline]
    pub fn step(&mut self, state: &KinematicState, action: Action, dt_s: f64) -> (KinematicState, (f64, f64)) {
        let heading_rad = turned_heading_rad(state.heading_rad, action.yaw_rate_radps, dt_s);
        let sin_cos = match self.last {
            Some((bits, sin_cos)) if bits == heading_rad.to_bits() => sin_cos,
            _ => self.last.insert((heading_rad.to_bits(), heading_rad.sin_cos())).1,
        };
        (step_to_heading(state, action.accel_mps2, heading_rad, sin_cos, dt_s), sin_cos)
    }
}

/// The headings (each with its `sin_cos()`) of `STEPS` [`step`]s of `dt_s`
/// from `heading_rad` under `yaw_rate_radps`: they depend on nothing else,
/// so rollouts that share a heading and a yaw rate can share them (with
/// [`step_to_heading`], the same states to the bit).
pub fn turned_headings<const STEPS: usize>(
    heading_rad: f64,
    yaw_rate_radps: f64,
    dt_s: f64,
) -> [(f64, (f64, f64)); STEPS] {
    let mut heading_rad = heading_rad;
    std::array::from_fn(|_| {
        heading_rad = turned_heading_rad(heading_rad, yaw_rate_radps, dt_s);
        (heading_rad, heading_rad.sin_cos())
    })
}

/// The heading [`step`] turns `heading_rad` to under `yaw_rate_radps`: it
/// does not depend on the speed or acceleration.
#[inline]
pub fn turned_heading_rad(heading_rad: f64, yaw_rate_radps: f64, dt_s: f64) -> f64 {
    wrap_angle(heading_rad + yaw_rate_radps * dt_s)
}

/// [`step`] with its new heading (see [`turned_heading_rad`]) and that
/// heading's `sin_cos()` worked out already: for a caller that rolls out
/// many accelerations under one sequence of yaw rates, whose headings are
/// all the same.
#[inline]
pub fn step_to_heading(
    state: &KinematicState,
    accel_mps2: f64,
    heading_rad: f64,
    (sin, cos): (f64, f64),
    dt_s: f64,
) -> KinematicState {
    let speed_mps = stepped_speed_mps(state.speed_mps, accel_mps2, dt_s);
    let position = state.position + Vector2::new(cos, sin) * (speed_mps * dt_s);
    KinematicState { position, heading_rad, speed_mps }
}

/// The speed [`step`] ends at from `speed_mps` under `accel_mps2`: the
/// model brakes to a standstill and never reverses. Code that needs the
/// step's new speed before stepping (a yaw rate bounded by it, a speed
/// profile without positions) asks here, so it cannot drift from the step.
#[inline]
pub fn stepped_speed_mps(speed_mps: f64, accel_mps2: f64, dt_s: f64) -> f64 {
    (speed_mps + accel_mps2 * dt_s).max(0.0)
}

/// Tightest turning radius of an ego that escapes or is searched for an
/// escape, m: a passenger car's (about 5 m kerb to kerb for a small car,
/// more for most). Its yaw rate at a step is at most the speed over it, so
/// that a standing car cannot turn in place.
pub const MIN_TURN_RADIUS_M: f64 = 5.0;

/// `yaw_rate_radps` bounded by what a car at `speed_mps` can turn (see
/// [`MIN_TURN_RADIUS_M`]); the unbounded rate, bit for bit, where it is
/// within reach.
#[inline]
pub fn turn_bounded_yaw_rate(yaw_rate_radps: f64, speed_mps: f64) -> f64 {
    let most = speed_mps / MIN_TURN_RADIUS_M;
    // Not `clamp`: a NaN speed leaves the rate as it is instead of panicking.
    yaw_rate_radps.max(-most).min(most)
}

/// An upper bound on how far [`step`] can carry a state of speed
/// `speed_mps` in `steps` steps of `dt_s` with accelerations of at most
/// `max_accel_mps2` and any yaw rates, metres: the speed grows by at most
/// `max_accel_mps2·dt_s` a step and each step moves the position by the
/// new speed times `dt_s`. A negative or NaN speed or acceleration counts
/// as 0, as in [`step`], where the speed is clamped the same way. Exact in
/// real arithmetic; callers that compare it with rounded positions add a
/// little.
pub fn max_travel_m(speed_mps: f64, max_accel_mps2: f64, dt_s: f64, steps: usize) -> f64 {
    let k = steps as f64;
    dt_s * (k * speed_mps.max(0.0) + max_accel_mps2.max(0.0) * dt_s * k * (k + 1.0) / 2.0)
}

/// An upper bound on how far [`step`] can carry a state of speed
/// `speed_mps` in `steps` steps of `dt_s`, with accelerations of at most
/// `max_accel_mps2` and yaw rates of at most `max_yaw_rate_radps` either
/// way, from where holding on (no acceleration, no turn) carries it,
/// metres: step `k` moves the position by the new speed along the new
/// heading times `dt_s`, and these differ from holding on by at most
/// `k·dt_s·max_accel_mps2` (braking stops at a standstill) and
/// `k·dt_s·max_yaw_rate_radps` (a chord is no longer than its arc). Exact
/// in real arithmetic; callers that compare it with rounded positions add
/// a little.
pub fn max_deviation_from_holding_m(
    speed_mps: f64,
    (max_accel_mps2, max_yaw_rate_radps): (f64, f64),
    dt_s: f64,
    steps: usize,
) -> f64 {
    let k = steps as f64;
    dt_s * dt_s * k * (k + 1.0) / 2.0 * (max_accel_mps2.abs() + speed_mps.max(0.0) * max_yaw_rate_radps.abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steering_is_the_bicycle_angle_for_the_unicycle_path_left_positive() {
        // 0.1 rad/s at 10 m/s: a 100 m radius, atan(3 / 100).
        assert!((steering_angle_rad(0.1, 10.0) - 0.03f64.atan()).abs() < 1e-15);
        assert!(steering_angle_rad(-0.1, 10.0) < 0.0);
        assert_eq!(steering_angle_rad(0.5, 0.05), 0.0, "no path to speak of at a crawl");
        assert_eq!(steering_angle_rad(f64::NAN, 5.0), 0.0);
        assert!(steering_angle_rad(1.5, 0.1) < std::f64::consts::FRAC_PI_2);
    }

    #[test]
    fn a_held_heading_stepper_steps_as_the_plain_step_to_the_bit() {
        // Straight on, a turn, the turn ended, braking to a standstill.
        let mut plain = KinematicState { position: Point2::new(1.0, 2.0), heading_rad: 0.3, speed_mps: 6.0 };
        let mut held = plain;
        let mut stepper = HeldHeadingStepper::default();
        let actions = [(0.5, 0.0), (0.0, 0.4), (-1.0, -0.2), (-5.0, 0.0), (-5.0, 0.3)];
        for (accel_mps2, yaw_rate_radps) in actions.iter().flat_map(|&a| std::iter::repeat_n(a, 8)) {
            let action = Action { accel_mps2, yaw_rate_radps };
            let (next_plain, trig_plain) = step_with_sin_cos(&plain, action, 0.1);
            let (next_held, trig_held) = stepper.step(&held, action, 0.1);
            assert_eq!((next_held, trig_held), (next_plain, trig_plain), "{action:?}");
            (plain, held) = (next_plain, next_held);
        }
    }

    #[test]
    fn straight_acceleration_matches_semi_implicit_euler() {
        let s0 = KinematicState { position: Point2::origin(), heading_rad: 0.0, speed_mps: 10.0 };
        let mut s = s0;
        for _ in 0..5 {
            s = step(&s, Action { accel_mps2: 2.0, yaw_rate_radps: 0.0 }, 0.1);
        }
        // v: 10.2, 10.4, ..., 11.0; x = 0.1 * (10.2+10.4+10.6+10.8+11.0) = 5.3
        assert!((s.speed_mps - 11.0).abs() < 1e-12);
        assert!((s.position.x - 5.3).abs() < 1e-12);
        assert!(s.position.y.abs() < 1e-12);
    }

    #[test]
    fn a_step_with_its_trigonometry_at_hand_is_the_plain_step_to_the_bit() {
        // The planners and the witness search step with sines and cosines
        // worked out once (`step_with_sin_cos`, `step_to_heading`); every
        // verdict they reach assumes these are the plain step's numbers.
        let mut s = KinematicState { position: Point2::new(-3.2e3, 7.5e2), heading_rad: 3.0, speed_mps: 12.3 };
        for k in 0..200 {
            let action = Action { accel_mps2: [-6.0, 2.5, 0.0][k % 3], yaw_rate_radps: [0.9, -0.3, 0.0, 1.5][k % 4] };
            // The step as written out before the trigonometry was shared,
            // with separate calls to `cos` and `sin`.
            let speed_mps = (s.speed_mps + action.accel_mps2 * 0.1).max(0.0);
            let heading_rad = wrap_angle(s.heading_rad + action.yaw_rate_radps * 0.1);
            let position = s.position + Vector2::new(heading_rad.cos(), heading_rad.sin()) * (speed_mps * 0.1);
            let plain = KinematicState { position, heading_rad, speed_mps };
            assert_eq!(step(&s, action, 0.1), plain);
            let (with_trig, (sin, cos)) = step_with_sin_cos(&s, action, 0.1);
            assert_eq!(with_trig, plain);
            assert_eq!(
                (sin.to_bits(), cos.to_bits()),
                (plain.heading_rad.sin().to_bits(), plain.heading_rad.cos().to_bits())
            );
            let heading_rad = turned_heading_rad(s.heading_rad, action.yaw_rate_radps, 0.1);
            assert_eq!(step_to_heading(&s, action.accel_mps2, heading_rad, (sin, cos), 0.1), plain);
            s = plain;
        }
    }

    #[test]
    fn max_travel_bounds_every_rollout_and_is_reached_at_full_throttle() {
        let s0 = KinematicState { position: Point2::new(3.0, -1.0), heading_rad: 0.4, speed_mps: 7.0 };
        let actions = [(2.5, 0.0), (2.5, 0.6), (-4.0, 0.3), (0.0, -0.6), (1.0, 0.1)];
        for (i, &(a, w)) in actions.iter().enumerate() {
            let mut s = s0;
            for k in 1..=60 {
                // Alternate with braking so speeds are not monotone.
                let accel = if k % 7 == 0 { -5.0 } else { a };
                s = step(&s, Action { accel_mps2: accel, yaw_rate_radps: w }, 0.1);
                let bound = max_travel_m(s0.speed_mps, 2.5, 0.1, k);
                assert!((s.position - s0.position).norm() <= bound + 1e-9, "action {i} step {k}");
            }
        }
        let mut s = s0;
        for _ in 0..20 {
            s = step(&s, Action { accel_mps2: 2.5, yaw_rate_radps: 0.0 }, 0.1);
        }
        assert!(((s.position - s0.position).norm() - max_travel_m(7.0, 2.5, 0.1, 20)).abs() < 1e-9);
        assert_eq!(max_travel_m(0.0, -1.0, 0.1, 10), 0.0);
        assert_eq!(max_travel_m(f64::NAN, 1.0, 0.1, 3), max_travel_m(0.0, 1.0, 0.1, 3));
    }

    #[test]
    fn speed_never_negative() {
        let s = KinematicState { position: Point2::origin(), heading_rad: 1.0, speed_mps: 0.2 };
        let s = step(&s, Action { accel_mps2: -5.0, yaw_rate_radps: 0.0 }, 0.1);
        assert_eq!(s.speed_mps, 0.0);
        assert_eq!(s.position, Point2::origin());
    }
}
