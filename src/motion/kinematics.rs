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
        AgentState {
            position: self.position,
            heading_rad: self.heading_rad,
            velocity_mps: Vector2::new(self.heading_rad.cos(), self.heading_rad.sin()) * self.speed_mps,
        }
    }
}

/// Advances `state` by one step of `dt_s` seconds under `action`.
#[inline]
pub fn step(state: &KinematicState, action: Action, dt_s: f64) -> KinematicState {
    let speed_mps = (state.speed_mps + action.accel_mps2 * dt_s).max(0.0);
    let heading_rad = wrap_angle(state.heading_rad + action.yaw_rate_radps * dt_s);
    let position = state.position + Vector2::new(heading_rad.cos(), heading_rad.sin()) * (speed_mps * dt_s);
    KinematicState { position, heading_rad, speed_mps }
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn speed_never_negative() {
        let s = KinematicState { position: Point2::origin(), heading_rad: 1.0, speed_mps: 0.2 };
        let s = step(&s, Action { accel_mps2: -5.0, yaw_rate_radps: 0.0 }, 0.1);
        assert_eq!(s.speed_mps, 0.0);
        assert_eq!(s.position, Point2::origin());
    }
}
