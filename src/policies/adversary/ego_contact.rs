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
//! the ego. Nor, under the rule, does the CBV ride the ego's bumper
//! ([`EgoTail`]): held off the contact alone, a CBV closing from behind
//! ends centimetres off the ego's tail at speed. The CBV may still
//! follow the ego, cut in ahead of it, brake ahead of it, turn across it
//! or come in from the side: the conflicts a planner must answer.

use super::rollout::braking_after;
use crate::motion::tokens::SIM_DT_S;
use crate::scenario::contact::EgoCollisionKind;
use crate::scenario::following::{following_gap_m, within_tailgating_gap};
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
    /// still (the contacts nuPlan's rule never blames the ego for), and no
    /// riding the ego's bumper.
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

/// The ego's tail as [`EgoContactRule::NotFromBehind`] keeps the CBV off
/// it. A CBV held off a contact from behind would otherwise close to
/// within centimetres of the ego's tail and ride its bumper at speed: a
/// gap no driver keeps, and a conflict no planner answers for. So a state
/// is ruled out where the CBV follows the ego
/// ([`following_gap_m`](crate::scenario::following::following_gap_m)) and,
/// braking at [`TAIL_BRAKE_MPS2`] until it is no faster than the ego,
/// would keep under half a second's gap at speed (the
/// [tailgating](crate::scenario::following::tailgates) gap), unless it is
/// that close already now, when it may hold that gap but not close it.
/// The braking term makes the rule look ahead: a CBV closing fast starts
/// braking while it can still do so comfortably, rather than a token
/// before the bumper.
#[derive(Debug, Clone, Copy)]
pub(super) struct EgoTail {
    bodies: (AgentBody, AgentBody),
    /// The CBV's gap on the ego's tail now, less what it closes braking
    /// ([`EgoTail::gap_m`]), where that is within the tailgating gap, m.
    close_now_m: Option<f64>,
}

/// The deceleration a CBV closing on the ego's tail is expected to brake
/// at, m/s²: the 3.4 m/s² that AASHTO's stopping sight distance assumes,
/// which most drivers keep within when braking for a car ahead.
pub const TAIL_BRAKE_MPS2: f64 = 3.4;

/// How much closer than its gap now a CBV already on the ego's bumper may
/// come and still hold it, m (rounding, not a margin).
const HELD_GAP_TOLERANCE_M: f64 = 1e-6;

impl EgoTail {
    /// The ego's tail with the CBV at `cbv_now` and the ego at `ego_now`.
    pub(super) fn new(cbv_now: &AgentState, ego_now: &AgentState, bodies: (AgentBody, AgentBody)) -> Self {
        let mut tail = Self { bodies, close_now_m: None };
        tail.close_now_m = tail.too_close_m(cbv_now, ego_now);
        tail
    }

    /// The CBV's gap to the ego's tail, less the distance it closes braking
    /// at [`TAIL_BRAKE_MPS2`] to the ego's speed, m; `None` where it does
    /// not follow the ego.
    fn gap_m(&self, cbv: &AgentState, ego: &AgentState) -> Option<f64> {
        let (ego_body, cbv_body) = self.bodies;
        let gap_m = following_gap_m((cbv, cbv_body), (ego, ego_body))?;
        let closing_mps = (cbv.speed_mps() - ego.speed_mps()).max(0.0);
        Some(gap_m - closing_mps * closing_mps / (2.0 * TAIL_BRAKE_MPS2))
    }

    /// [`EgoTail::gap_m`] where it is within the tailgating gap at the CBV's speed.
    fn too_close_m(&self, cbv: &AgentState, ego: &AgentState) -> Option<f64> {
        self.gap_m(cbv, ego).filter(|&gap_m| within_tailgating_gap(gap_m, cbv.speed_mps()))
    }

    /// Whether the CBV at `cbv` comes closer to the tail of the ego at
    /// `ego` than the rule allows.
    pub(super) fn closed_on(&self, cbv: &AgentState, ego: &AgentState) -> bool {
        self.too_close_m(cbv, ego)
            .is_some_and(|gap_m| self.close_now_m.is_none_or(|now_m| gap_m < now_m - HELD_GAP_TOLERANCE_M))
    }

    /// Whether the CBV at the end of `rollout` (a token's states, one per
    /// step from the step after now) comes closer to the tail of the ego,
    /// held on from `ego_now` at its velocity, than the rule allows.
    pub(super) fn closed_on_after(&self, rollout: &[AgentState], ego_now: &AgentState) -> bool {
        let Some(end) = rollout.last() else { return false };
        let ahead_s = rollout.len() as f64 * SIM_DT_S;
        let ego = AgentState { position: ego_now.position + ego_now.velocity_mps * ahead_s, ..*ego_now };
        self.closed_on(end, &ego)
    }
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

    /// Whether the CBV from `cbv_now`, after a token held at `accel_mps2`,
    /// closes on the tail of the ego at `ego_now` more than the rule allows.
    fn closes_on_tail(cbv_now: AgentState, ego_now: AgentState, accel_mps2: f64) -> bool {
        EgoTail::new(&cbv_now, &ego_now, (CAR, CAR)).closed_on_after(&rollout(cbv_now, accel_mps2), &ego_now)
    }

    #[test]
    fn a_cbv_closing_on_the_egos_tail_brakes_before_its_bumper_not_at_it() {
        let ego = car(0.0, 0.0, 20.0);
        // 20 m behind the ego's tail at 25 m/s: holding its speed for the
        // token it ends 17.5 m back, and braking at 3.4 m/s² from there to
        // the ego's speed takes 3.7 m more, leaving 13.8 m, over half a
        // second at 25 m/s. Speeding up at 4 m/s² it ends 17 m back at
        // 27 m/s, and braking would take 7.2 m: 9.8 m, under half a second.
        let cbv = car(-24.5, 0.0, 25.0);
        assert!(!closes_on_tail(cbv, ego, 0.0));
        assert!(closes_on_tail(cbv, ego, 4.0));
        // Neither is a contact from behind: the rule looks further ahead.
        assert!(!rear_ends(&rollout(cbv, 4.0), &ego, (CAR, CAR)));
        // In the next lane, or in a queue at walking pace, it may close in.
        assert!(!closes_on_tail(car(-24.5, 3.5, 25.0), ego, 4.0));
        let creeping = car(0.0, 0.0, 2.0);
        assert!(!closes_on_tail(car(-6.0, 0.0, 4.0), creeping, 1.0));
    }

    #[test]
    fn a_cbv_already_on_the_egos_bumper_may_hold_its_gap_but_not_close_it() {
        // 5 m behind the ego's tail, both at 20 m/s: a quarter of a second.
        let (ego, cbv) = (car(0.0, 0.0, 20.0), car(-9.5, 0.0, 20.0));
        assert!(!closes_on_tail(cbv, ego, 0.0), "holding the gap");
        assert!(!closes_on_tail(cbv, ego, -2.0), "opening it");
        assert!(closes_on_tail(cbv, ego, 1.0), "closing it");
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
