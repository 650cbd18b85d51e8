//! Whether a token turns the adversary's CBV within what a car's tyres
//! hold ([`first_beyond_grip`]). The motion tokens reach a yaw rate of
//! 1.5 rad/s at any speed: at 10 m/s that pulls 15 m/s² sideways, half as
//! much again as a road car's tyres hold on dry asphalt. The prior, which
//! learned recorded driving, rarely ranks such a token high, but the
//! adversary's losses pick the trust region's extremes, and without this
//! bound the in-path CBVs of WOMD interactive turned beyond grip in one
//! variant in 12 (`safer-in-path` over 20 behaviours) to one in 6 (its
//! lookahead over 60), at more than 20 m/s² in some. A car cannot drive such a token, so it is
//! implausible for the CBV as leaving the road is.
//!
//! The bound is the default of the ego's own limits
//! ([`DEFAULT_MAX_LATERAL_ACCEL_MPS2`]), measured as the limits measure
//! it: the mean speed of a step times its yaw rate.

use crate::geometry::wrap_angle;
use crate::motion::tokens::SIM_DT_S;
use crate::motion::vehicle_limits::DEFAULT_MAX_LATERAL_ACCEL_MPS2;
use crate::scenario::AgentState;

/// Floating-point slack on the bound: a token exactly at it is within it.
const SLACK_MPS2: f64 = 1e-6;

/// The first state of `rollout` (a token's states, one a simulator step,
/// from `now`) reached by a step that pulls more than
/// [`DEFAULT_MAX_LATERAL_ACCEL_MPS2`] sideways, or `None` where every step
/// stays within grip.
pub(super) fn first_beyond_grip(now: &AgentState, rollout: &[AgentState]) -> Option<usize> {
    std::iter::once(now).chain(rollout).zip(rollout).position(|(from, to)| {
        let yaw_rate_radps = wrap_angle(to.heading_rad - from.heading_rad) / SIM_DT_S;
        let mean_speed_mps = 0.5 * (from.speed_mps() + to.speed_mps());
        mean_speed_mps * yaw_rate_radps.abs() > DEFAULT_MAX_LATERAL_ACCEL_MPS2 + SLACK_MPS2
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::tokens::{TOKEN_PERIOD_STEPS, TokenGrid};
    use crate::motion::{Action, KinematicState};

    /// The states of a token of `yaw_rate_radps` at a steady `speed_mps`.
    fn turning(speed_mps: f64, yaw_rate_radps: f64) -> (AgentState, Vec<AgentState>) {
        let now = AgentState {
            position: crate::geometry::Point2::new(0.0, 0.0),
            heading_rad: 0.0,
            velocity_mps: crate::geometry::Vector2::new(speed_mps, 0.0),
        };
        let token = TokenGrid::quantize(Action { accel_mps2: 0.0, yaw_rate_radps });
        let from = KinematicState::from_agent_state(&now);
        let states = TokenGrid::rollout(&from, token).iter().map(KinematicState::to_agent_state).collect();
        (now, states)
    }

    #[test]
    fn a_token_beyond_the_tyres_grip_is_caught_at_its_first_step() {
        // 1.5 rad/s at 10 m/s pulls 15 m/s²; at 5 m/s, 7.5 m/s².
        let (now, fast) = turning(10.0, 1.5);
        assert_eq!(fast.len(), TOKEN_PERIOD_STEPS);
        assert_eq!(first_beyond_grip(&now, &fast), Some(0));
        let (now, slow) = turning(5.0, 1.5);
        assert_eq!(first_beyond_grip(&now, &slow), None);
        // 0.8 rad/s at 10 m/s (8 m/s²) is within grip; straight on is too.
        let (now, gentle) = turning(10.0, 0.8);
        assert_eq!(first_beyond_grip(&now, &gentle), None);
        let (now, straight) = turning(30.0, 0.0);
        assert_eq!(first_beyond_grip(&now, &straight), None);
    }
}
