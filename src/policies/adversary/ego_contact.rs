//! Which contacts with the ego the adversary may make ([`EgoContactRule`]):
//! any (the paper's), or none from behind the ego.
//!
//! A CBV that runs into the ego from behind, or into an ego standing
//! still, makes a collision no planner answers for: nuPlan's rule does not
//! blame an ego hit from behind, a driver cannot see or outrun a car that
//! chases it, and in stage 2 a CBV closing from behind follows whatever
//! escape the ego tries. Under [`EgoContactRule::NotFromBehind`] a candidate
//! token after which the CBV, braking as hard as it can, would still run
//! into the ego (held on at its velocity) from behind counts as
//! infeasible, and a lookahead continuation that ends in such a contact is
//! not a conflict. Where every plausible token of the trust region would
//! rear-end the ego, the CBV leaves the region for the likeliest plausible
//! token that does not (most often a harder brake than the region holds);
//! only where no plausible token keeps off does it take one that rear-ends
//! the ego. The CBV
//! may still follow the ego closely, cut in ahead of it, brake ahead of
//! it, turn across it or come in from the side: the conflicts a planner
//! must answer.

use super::rollout::braking_after;
use crate::motion::tokens::SIM_DT_S;
use crate::scenario::contact::EgoCollisionKind;
use crate::scenario::{AgentBody, AgentState};

/// Which contacts with the ego the adversary may make.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum EgoContactRule {
    /// Any contact (the paper's: the loss is the distance to the ego).
    #[default]
    Any,
    /// Beyond the paper: none from behind the ego or with the ego standing
    /// still (the contacts nuPlan's rule never blames the ego for).
    NotFromBehind,
}

impl EgoContactRule {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Any, Self::NotFromBehind];
}

/// Whether the CBV at `cbv`, touching the ego at `ego`, touches it from
/// behind or while it stands (as the ego's collision events classify it).
pub(super) fn from_behind(ego: &AgentState, cbv: &AgentState) -> bool {
    matches!(EgoCollisionKind::classify(ego, cbv), EgoCollisionKind::ActiveRear | EgoCollisionKind::StoppedEgo)
}

/// Whether the CBV along `rollout` (a token's states, one per step from
/// the step after now), then braking as hard as it can for
/// [`BRAKING_CHECK_STEPS`](super::rollout::BRAKING_CHECK_STEPS) steps, runs into the ego
/// from behind, the ego held on from `ego_now` at its velocity.
pub(super) fn rear_ends(
    rollout: &[AgentState],
    ego_now: &AgentState,
    (ego_body, cbv_body): (AgentBody, AgentBody),
) -> bool {
    let braking = braking_after(rollout);
    // Judged at the first contact only: held on through the CBV, the ego
    // would later have it behind, whoever ran into whom.
    let first_contact = rollout.iter().copied().chain(braking).enumerate().find_map(|(k, cbv)| {
        let ahead_s = (k + 1) as f64 * SIM_DT_S;
        let ego = AgentState { position: ego_now.position + ego_now.velocity_mps * ahead_s, ..*ego_now };
        ego_body.footprint(&ego).intersects(&cbv_body.footprint(&cbv)).then_some((ego, cbv))
    });
    first_contact.is_some_and(|(ego, cbv)| from_behind(&ego, &cbv))
}

#[cfg(test)]
mod tests {
    use super::super::rollout::token_rollout;
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::motion::KinematicState;
    use crate::motion::tokens::{Token, TokenGrid};
    use crate::scenario::AgentKind;

    const CAR: AgentBody = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };

    fn car(x: f64, y: f64, vx: f64) -> AgentState {
        AgentState { position: Point2::new(x, y), heading_rad: 0.0, velocity_mps: Vector2::new(vx, 0.0) }
    }

    fn held(accel_mps2: f64) -> Token {
        TokenGrid::quantize(crate::motion::Action { accel_mps2, yaw_rate_radps: 0.0 })
    }

    fn rollout(from: AgentState, accel_mps2: f64) -> Vec<AgentState> {
        token_rollout(&KinematicState::from_agent_state(&from), held(accel_mps2))
    }

    #[test]
    fn a_cbv_closing_faster_than_it_can_brake_rear_ends_the_ego_and_one_that_can_stop_does_not() {
        let ego = car(0.0, 0.0, 10.0);
        let bodies = (CAR, CAR);
        // 6 m behind (1.5 m gap), 8 m/s faster: braking at the utmost after
        // the token it still closes 1.5 m and more.
        assert!(rear_ends(&rollout(car(-6.0, 0.0, 18.0), 0.0), &ego, bodies));
        // 30 m behind, the same speeds: it brakes short of the ego.
        assert!(!rear_ends(&rollout(car(-30.0, 0.0, 18.0), 0.0), &ego, bodies));
        // Ahead of the ego and braking hard: the ego runs into the CBV, a
        // conflict the planner must answer, not a rear-ending by the CBV.
        assert!(!rear_ends(&rollout(car(6.0, 0.0, 10.0), -5.0), &ego, bodies));
        // Beside it in the next lane, faster: no contact at all.
        assert!(!rear_ends(&rollout(car(-6.0, 3.5, 18.0), 0.0), &ego, bodies));
    }

    #[test]
    fn contacts_from_behind_and_with_a_standing_ego_are_the_ones_the_rule_excludes() {
        let ego = car(0.0, 0.0, 10.0);
        assert!(from_behind(&ego, &car(-4.4, 0.0, 12.0)));
        assert!(!from_behind(&ego, &car(4.4, 0.0, 8.0)), "ahead of the ego");
        assert!(!from_behind(&ego, &car(0.0, 2.0, 10.0)), "beside it");
        assert!(from_behind(&car(0.0, 0.0, 0.0), &car(4.4, 0.0, 3.0)), "the ego standing still");
    }
}
