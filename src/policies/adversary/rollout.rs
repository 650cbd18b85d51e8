//! The CBV's states under a token: one token period from a state, and
//! continued after it at an acceleration, holding the curvature the
//! token ends with.

use crate::geometry::wrap_angle;
use crate::motion::tokens::{MAX_YAW_RATE_RADPS, SIM_DT_S, Token, TokenGrid};
use crate::motion::{Action, KinematicState, kinematic_step_with_sin_cos};
use crate::scenario::AgentState;

/// The CBV's states over one token period from `now` under each token.
pub(super) fn token_rollouts(now: &AgentState, tokens: &[Token]) -> Vec<Vec<AgentState>> {
    let from = KinematicState::from_agent_state(now);
    tokens.iter().map(|t| token_rollout(&from, *t)).collect()
}

/// The CBV's states over one token period from `from` under `token`.
pub(super) fn token_rollout(from: &KinematicState, token: Token) -> Vec<AgentState> {
    TokenGrid::rollout_with_sin_cos(from, token)
        .iter()
        .map(|(s, sin_cos)| s.to_agent_state_with_sin_cos(*sin_cos))
        .collect()
}

/// `steps` states after `rollout` at `accel_mps2`, holding the curvature
/// the rollout ends with.
pub(super) fn continued_after(
    rollout: &[AgentState],
    accel_mps2: f64,
    steps: usize,
) -> impl Iterator<Item = AgentState> + use<> {
    let curvature_per_m = match rollout {
        [.., before, end] => {
            let travelled_m = (end.position - before.position).norm();
            if travelled_m > 1e-3 { wrap_angle(end.heading_rad - before.heading_rad) / travelled_m } else { 0.0 }
        }
        _ => 0.0,
    };
    let mut state = rollout.last().map(KinematicState::from_agent_state);
    (0..steps).map_while(move |_| {
        let now = state.as_mut()?;
        let speed_mps = (now.speed_mps + accel_mps2 * SIM_DT_S).max(0.0);
        let yaw_rate_radps = (curvature_per_m * speed_mps).clamp(-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS);
        let (next, sin_cos) = kinematic_step_with_sin_cos(now, Action { accel_mps2, yaw_rate_radps }, SIM_DT_S);
        *now = next;
        Some(next.to_agent_state_with_sin_cos(sin_cos))
    })
}
