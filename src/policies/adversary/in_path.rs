//! The in-path objectives of `safer-in-path` and `safer-cut-in` (beyond
//! the paper): a candidate scores how close it puts the CBV to the ego's
//! path *ahead* of the ego, not to the ego's body.
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
//!
//! The cut-in loss of `safer-cut-in` (beyond the paper) finishes what the
//! in-path loss starts. The box distance stops falling once a corner of
//! the CBV reaches the ego's path, so the in-path loss can leave a CBV
//! from the next lane with its corner over the lane line and its body
//! beside the ego's lane: a cut-in threatened, not made, which a planner
//! answers by keeping its lane. The cut-in loss adds, for a CBV ahead of the ego,
//! [`CUT_IN_LATERAL_COST`] per metre its centre lies to the side of the
//! ego's heading line, so it keeps coming over until it is in the ego's
//! path; and it grades the not-ahead penalty by how far the CBV's centre
//! is short of the ego's front bumper, [`CUT_IN_NOT_AHEAD_COST`] per
//! metre up to [`NOT_AHEAD_PENALTY_M`], so that a CBV beside the ego
//! gains by drawing ahead of it (where a flat penalty leaves it hugging
//! the ego's side, the one move that lowers the box distance).

use crate::geometry::Vector2;
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

/// What a metre of the CBV's centre to the side of the ego's heading line
/// adds to the cut-in loss when the CBV is ahead of the ego, m per m.
pub const CUT_IN_LATERAL_COST: f64 = 0.5;

/// What a metre of the CBV's centre short of the ego's front bumper adds
/// to the cut-in loss, m per m, up to [`NOT_AHEAD_PENALTY_M`].
pub const CUT_IN_NOT_AHEAD_COST: f64 = 2.0;

/// Where the CBV stands against the ego's path ahead.
struct PathApproach {
    /// The least, over lead times, of the box distance to the ego's
    /// constant-velocity footprint plus the lead cost, m.
    closest_m: f64,
    /// How far the CBV's centre is short of the ego's front bumper along
    /// the ego's heading, m (negative: ahead of it).
    short_of_front_m: f64,
    /// How far the CBV's centre is to the side of the ego's heading line, m.
    lateral_m: f64,
}

impl PathApproach {
    fn of(ego_next: &AgentState, ego_body: AgentBody, cbv: &AgentState, cbv_body: AgentBody) -> Self {
        let cbv_box = cbv_body.footprint(cbv);
        let leads = (IN_PATH_MAX_LEAD_S / TOKEN_PERIOD_S).round() as usize;
        let closest_m = (0..=leads)
            .map(|k| {
                let lead_s = k as f64 * TOKEN_PERIOD_S;
                let ego_then = AgentState { position: ego_next.position + ego_next.velocity_mps * lead_s, ..*ego_next };
                ego_body.footprint(&ego_then).distance(&cbv_box) + IN_PATH_LEAD_COST_M_PER_S * lead_s
            })
            .fold(f64::INFINITY, f64::min);
        let (sin, cos) = ego_next.heading_rad.sin_cos();
        let offset = cbv.position - ego_next.position;
        let ahead_m = offset.dot(&Vector2::new(cos, sin));
        let lateral_m = offset.dot(&Vector2::new(-sin, cos)).abs();
        Self { closest_m, short_of_front_m: 0.5 * ego_body.length_m - ahead_m, lateral_m }
    }

    fn ahead(&self) -> bool {
        self.short_of_front_m < 0.0
    }
}

/// The in-path loss of the CBV at `cbv` (body `cbv_body`) for the ego at
/// `ego_next` (its constant-velocity prediction at the end of the token,
/// body `ego_body`); see the module.
pub(super) fn in_path_loss(ego_next: &AgentState, ego_body: AgentBody, cbv: &AgentState, cbv_body: AgentBody) -> f64 {
    let approach = PathApproach::of(ego_next, ego_body, cbv, cbv_body);
    if approach.ahead() { approach.closest_m } else { approach.closest_m + NOT_AHEAD_PENALTY_M }
}

/// The cut-in loss of `safer-cut-in`, for the same arguments as
/// [`in_path_loss`]; see the module.
pub(super) fn cut_in_loss(ego_next: &AgentState, ego_body: AgentBody, cbv: &AgentState, cbv_body: AgentBody) -> f64 {
    let approach = PathApproach::of(ego_next, ego_body, cbv, cbv_body);
    if approach.ahead() {
        approach.closest_m + CUT_IN_LATERAL_COST * approach.lateral_m
    } else {
        approach.closest_m + (CUT_IN_NOT_AHEAD_COST * approach.short_of_front_m).min(NOT_AHEAD_PENALTY_M)
    }
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

    fn cut_in(cbv: Option<AgentState>) -> f64 {
        cut_in_loss(&car(0.0, 0.0, 10.0).unwrap(), CAR, &cbv.unwrap(), CAR)
    }

    #[test]
    fn ahead_of_the_ego_the_cut_in_loss_draws_the_cbv_all_the_way_into_its_path() {
        // 8 m ahead: with its side 0.5 m into the ego's path the box meets
        // the ego's footprint half a second on, and coming farther over
        // changes nothing for the in-path loss.
        let (corner_in, centred) = (car(8.0, 1.5, 10.0), car(8.0, 0.0, 10.0));
        assert!((loss(corner_in) - 0.5).abs() < 1e-6 && (loss(centred) - 0.5).abs() < 1e-6);
        // The cut-in loss adds half the centre's offset from the ego's heading line.
        assert!((cut_in(corner_in) - 1.25).abs() < 1e-6, "{}", cut_in(corner_in));
        assert!((cut_in(centred) - 0.5).abs() < 1e-6, "{}", cut_in(centred));
        // Still in the next lane, its side 0.5 m off the ego's path: the most.
        let next_lane = cut_in(car(8.0, 2.5, 10.0));
        assert!((next_lane - 2.25).abs() < 1e-6, "{next_lane}");
    }

    #[test]
    fn beside_the_ego_the_cut_in_loss_prefers_drawing_ahead_to_hugging_its_side() {
        let (beside, hugging, drawing_ahead) = (car(0.0, 2.5, 10.0), car(0.0, 2.2, 10.0), car(1.0, 2.5, 10.0));
        // The in-path loss pays the flat penalty for all three and prefers
        // the one nearest the ego's side.
        assert!(loss(hugging) < loss(drawing_ahead));
        assert!((loss(beside) - loss(drawing_ahead)).abs() < 1e-6);
        // The cut-in loss pays 2 m a metre short of the front bumper
        // (2.25 m for a centre level with the ego's, 1.25 m a metre on).
        assert!((cut_in(hugging) - (0.2 + 4.5)).abs() < 1e-6, "{}", cut_in(hugging));
        assert!((cut_in(drawing_ahead) - (0.5 + 2.5)).abs() < 1e-6, "{}", cut_in(drawing_ahead));
        assert!(cut_in(drawing_ahead) < cut_in(hugging) && cut_in(hugging) < cut_in(beside));
        // Far behind, the penalty is the in-path loss's.
        assert!((cut_in(car(-4.5, 0.0, 10.0)) - loss(car(-4.5, 0.0, 10.0))).abs() < 1e-6);
    }
}
