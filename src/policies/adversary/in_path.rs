//! The in-path objective of `safer-in-path` (beyond the paper): a
//! candidate scores how close it puts the CBV to the ego's path *ahead*
//! of the ego, not to the ego's body.
//!
//! The paper's loss, the box distance to where the ego will be one token
//! later, is met as well by a CBV closing from behind or from the side as
//! by one in front, and a planner escapes the first two by speeding up or
//! keeping its lane: a planner that never brakes passes them. The
//! conflicts that test a planner
//! put the CBV in its path: a cut-in, a merge, a turn across, a car ahead
//! braking. So the in-path loss is the least, over lead times of 0 to
//! [`IN_PATH_MAX_LEAD_S`], of the box distance to the ego's
//! constant-velocity footprint that far ahead plus
//! [`IN_PATH_LEAD_COST_M_PER_S`] per second of lead: a CBV reaching the
//! ego's path 1 s ahead of it scores about 1 m, and it lowers its score by
//! letting the ego close in (braking ahead of it). A CBV whose centre is
//! not ahead of the ego's front bumper pays [`NOT_AHEAD_PENALTY_M`], so
//! that beside the ego it prefers getting ahead and in over swiping its
//! side; from behind, with every candidate paying it, the order is the
//! paper's. The feasibility constraint and the plausibility rule are the
//! one-step choice's.

use crate::motion::tokens::TOKEN_PERIOD_S;
use crate::scenario::{AgentBody, AgentState};

/// The farthest lead time the in-path loss looks at, s.
pub const IN_PATH_MAX_LEAD_S: f64 = 1.5;

/// What a second of lead adds to the in-path loss, m: of two equally close
/// approaches to the ego's path, the one it reaches sooner wins.
pub const IN_PATH_LEAD_COST_M_PER_S: f64 = 1.0;

/// What a CBV whose centre is not ahead of the ego's front bumper adds to
/// the in-path loss, m.
pub const NOT_AHEAD_PENALTY_M: f64 = 5.0;

/// The in-path loss of the CBV at `cbv` (body `cbv_body`) for the ego at
/// `ego_next` (its constant-velocity prediction at the end of the token,
/// body `ego_body`); see the module.
pub(super) fn in_path_loss(ego_next: &AgentState, ego_body: AgentBody, cbv: &AgentState, cbv_body: AgentBody) -> f64 {
    let cbv_box = cbv_body.footprint(cbv);
    let leads = (IN_PATH_MAX_LEAD_S / TOKEN_PERIOD_S).round() as usize;
    let best = (0..=leads)
        .map(|k| {
            let lead_s = k as f64 * TOKEN_PERIOD_S;
            let ego_then = AgentState { position: ego_next.position + ego_next.velocity_mps * lead_s, ..*ego_next };
            ego_body.footprint(&ego_then).distance(&cbv_box) + IN_PATH_LEAD_COST_M_PER_S * lead_s
        })
        .fold(f64::INFINITY, f64::min);
    let (sin, cos) = ego_next.heading_rad.sin_cos();
    let ahead_m = (cbv.position - ego_next.position).dot(&crate::geometry::Vector2::new(cos, sin));
    if ahead_m > 0.5 * ego_body.length_m { best } else { best + NOT_AHEAD_PENALTY_M }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::policies::adversary::test_support::car;
    use crate::scenario::AgentKind;

    const CAR: AgentBody = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };

    fn loss(cbv: Option<AgentState>) -> f64 {
        in_path_loss(&car(0.0, 0.0, 10.0).unwrap(), CAR, &cbv.unwrap(), CAR)
    }

    #[test]
    fn the_ego_path_ahead_scores_better_than_its_side_or_its_rear() {
        // In the ego's lane 10 m ahead at its speed (5.5 m between the
        // bumpers): the ego's footprint 0.5 s on is 0.5 m short of it, 1 s
        // on it overlaps; either way 1 m.
        let ahead = loss(car(10.0, 0.0, 10.0));
        assert!((ahead - 1.0).abs() < 1e-9, "{ahead}");
        // Beside it, 0.5 m off its side: close, but not ahead.
        let beside = loss(car(0.0, 2.5, 10.0));
        assert!((beside - (0.5 + NOT_AHEAD_PENALTY_M)).abs() < 1e-9, "{beside}");
        // Right behind it, touching its rear.
        let behind = loss(car(-4.5, 0.0, 10.0));
        assert!((behind - NOT_AHEAD_PENALTY_M).abs() < 1e-9, "{behind}");
        assert!(ahead < beside && ahead < behind);
        // Closer ahead is better: 5 m ahead meets the ego half a second on.
        let closer = loss(car(5.0, 0.0, 10.0));
        assert!((closer - 0.5).abs() < 1e-9, "{closer}");
    }

    #[test]
    fn a_cbv_in_the_next_lane_ahead_scores_better_moving_in() {
        // 1.5 m beside the ego's path, which reaches it 1 s on.
        let staying = loss(car(12.0, 3.5, 10.0));
        assert!((staying - 2.5).abs() < 1e-9, "{staying}");
        let moving_in = loss(car(12.0, 2.0, 10.0));
        assert!((moving_in - 1.0).abs() < 1e-9, "{moving_in}");
    }
}
