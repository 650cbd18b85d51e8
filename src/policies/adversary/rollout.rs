//! The CBV's states under a token: one token period from a state, and
//! continued after it at an acceleration (braking as hard as it can, for
//! the braking checks), holding the curvature the token ends with.

use crate::geometry::wrap_angle;
use crate::motion::kinematics::{HeldHeadingStepper, stepped_speed_mps};
use crate::motion::tokens::{MAX_ACCEL_MPS2, MAX_YAW_RATE_RADPS, SIM_DT_S, Token, TokenGrid, TurnedHeadings};
use crate::motion::{Action, KinematicState};
use crate::scenario::AgentState;

/// The CBV's states over one token period from `now` under each token.
pub(super) fn token_rollouts(now: &AgentState, tokens: &[Token]) -> Vec<Vec<AgentState>> {
    let from = KinematicState::from_agent_state(now);
    let mut turned = TurnedHeadings::default();
    tokens.iter().map(|&t| token_rollout_turning(&from, t, &mut turned)).collect()
}

/// The CBV's states over one token period from `from` under `token`.
#[cfg(test)]
pub(super) fn token_rollout(from: &KinematicState, token: Token) -> Vec<AgentState> {
    as_agent_states(&TokenGrid::rollout_with_sin_cos(from, token))
}

/// [`token_rollout`], the heading sequence taken from `turned` where an
/// earlier token of the same yaw rate worked it out from `from`: the same
/// states, for a scan of many tokens from one state.
pub(super) fn token_rollout_turning(
    from: &KinematicState,
    token: Token,
    turned: &mut TurnedHeadings,
) -> Vec<AgentState> {
    as_agent_states(&TokenGrid::rollout_turning(from, token, turned))
}

fn as_agent_states(rollout: &[(KinematicState, (f64, f64))]) -> Vec<AgentState> {
    rollout.iter().map(|(s, sin_cos)| s.to_agent_state_with_sin_cos(*sin_cos)).collect()
}

/// After a candidate token the braking checks (the plausibility check's,
/// and the ego-contact rule's) brake the CBV this many simulator steps
/// (2 s) to see whether it could still stop short of what is ahead.
pub(super) const BRAKING_CHECK_STEPS: usize = 20;

/// The CBV's states over [`BRAKING_CHECK_STEPS`] steps after `rollout`
/// (a token's states), braking as hard as it can while holding the
/// curvature it ends the token with: a driver braking in a bend keeps
/// steering along it.
pub(super) fn braking_after(rollout: &[AgentState]) -> impl Iterator<Item = AgentState> + use<> {
    continued_after(rollout, -MAX_ACCEL_MPS2, BRAKING_CHECK_STEPS)
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
    // A straight token's continuations (most of the plausibility
    // fallback's) and a stopped CBV's hold their heading: its sine and
    // cosine, most of the fallback's trigonometry, are worked out once.
    let mut stepper = HeldHeadingStepper::default();
    (0..steps).map_while(move |_| {
        let now = state.as_mut()?;
        let speed_mps = stepped_speed_mps(now.speed_mps, accel_mps2, SIM_DT_S);
        let yaw_rate_radps = (curvature_per_m * speed_mps).clamp(-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS);
        let (next, sin_cos) = stepper.step(now, Action { accel_mps2, yaw_rate_radps }, SIM_DT_S);
        *now = next;
        Some(next.to_agent_state_with_sin_cos(sin_cos))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::kinematic_step_with_sin_cos;

    #[test]
    fn a_continuation_steps_exactly_as_the_kinematic_model_with_its_trigonometry_reused() {
        // Straight, curving, braking to a standstill in a bend: each state
        // is, to the bit, the plain kinematic step's from the last one.
        let from =
            KinematicState { position: crate::geometry::Point2::new(3.0, -1.0), heading_rad: 0.4, speed_mps: 9.0 };
        for (token_action, accel_mps2) in
            [((0.0, 0.0), 0.0), ((1.0, 0.3), 1.0), ((-2.0, -0.2), -MAX_ACCEL), ((0.0, 0.0), -MAX_ACCEL)]
        {
            let token = TokenGrid::quantize(Action { accel_mps2: token_action.0, yaw_rate_radps: token_action.1 });
            let rollout = token_rollout(&from, token);
            let curvature_per_m = {
                let (before, end) = (&rollout[rollout.len() - 2], &rollout[rollout.len() - 1]);
                wrap_angle(end.heading_rad - before.heading_rad) / (end.position - before.position).norm()
            };
            let mut plain = KinematicState::from_agent_state(rollout.last().unwrap());
            let continued: Vec<AgentState> = continued_after(&rollout, accel_mps2, 60).collect();
            assert_eq!(continued.len(), 60);
            for s in &continued {
                let speed_mps = stepped_speed_mps(plain.speed_mps, accel_mps2, SIM_DT_S);
                let yaw_rate_radps = (curvature_per_m * speed_mps).clamp(-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS);
                let (next, sin_cos) =
                    kinematic_step_with_sin_cos(&plain, Action { accel_mps2, yaw_rate_radps }, SIM_DT_S);
                plain = next;
                assert_eq!(*s, next.to_agent_state_with_sin_cos(sin_cos), "{token_action:?} at {accel_mps2}");
            }
        }
    }

    const MAX_ACCEL: f64 = crate::motion::tokens::MAX_ACCEL_MPS2;
}
