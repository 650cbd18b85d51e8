//! Car following between two road users: whether one drives on the
//! other's bumper ([`tailgates`]), measured as car following is, by the
//! *time gap* (the bumper-to-bumper gap over the follower's speed) while
//! the follower is behind the leader, within its width and going its way.
//! The adversary keeps its CBV off the ego's bumper by it, and the
//! realism metrics count the CBVs that drove there.

use super::{AgentBody, AgentState};
use crate::geometry::Vector2;

/// The time gap under which following counts as tailgating, s: half a
/// second, a fraction of the one to two seconds drivers commonly keep,
/// and under what they keep even in dense freeway traffic.
pub const TAILGATE_TIME_GAP_S: f64 = 0.5;

/// The speed below which close following is not tailgating, m/s (a queue
/// creeping at walking pace keeps small gaps).
pub const TAILGATE_MIN_SPEED_MPS: f64 = 5.0;

/// The gap between the boxes of `follower` and `leader`, m, where
/// `follower` follows `leader`: within 45° of its heading, its centre
/// behind the leader's tail and within the two bodies' half widths of
/// the leader's heading line; `None` where it does not.
pub fn following_gap_m(follower: (&AgentState, AgentBody), leader: (&AgentState, AgentBody)) -> Option<f64> {
    let ((f, f_body), (l, l_body)) = (follower, leader);
    let (sin, cos) = l.heading_rad.sin_cos();
    // Going the leader's way: within 45° (cos > cos 45°).
    if (f.heading_rad - l.heading_rad).cos() < std::f64::consts::FRAC_1_SQRT_2 {
        return None;
    }
    let offset = f.position - l.position;
    let ahead_m = offset.dot(&Vector2::new(cos, sin));
    let lateral_m = offset.dot(&Vector2::new(-sin, cos)).abs();
    if ahead_m > -0.5 * l_body.length_m || lateral_m > 0.5 * (l_body.width_m + f_body.width_m) {
        return None;
    }
    Some(l_body.footprint(l).distance(&f_body.footprint(f)))
}

/// Whether a follower at `speed_mps` keeps a gap of `gap_m` under the
/// time gap of tailgating ([`TAILGATE_TIME_GAP_S`]), at
/// [`TAILGATE_MIN_SPEED_MPS`] or more.
pub fn within_tailgating_gap(gap_m: f64, speed_mps: f64) -> bool {
    speed_mps >= TAILGATE_MIN_SPEED_MPS && gap_m < TAILGATE_TIME_GAP_S * speed_mps
}

/// Whether `follower` drives behind `leader` within the time gap: it
/// follows it ([`following_gap_m`]) at [`TAILGATE_MIN_SPEED_MPS`] or
/// more, the gap between the boxes under [`TAILGATE_TIME_GAP_S`] of its
/// speed.
pub fn tailgates(follower: (&AgentState, AgentBody), leader: (&AgentState, AgentBody)) -> bool {
    let speed_mps = follower.0.speed_mps();
    speed_mps >= TAILGATE_MIN_SPEED_MPS
        && following_gap_m(follower, leader).is_some_and(|gap_m| within_tailgating_gap(gap_m, speed_mps))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::geometry::Point2;
    use crate::scenario::AgentKind;

    /// A car's body, 4.5 m by 2 m.
    pub(crate) const CAR: AgentBody = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };

    /// A car at (`x`, `y`) heading `heading_rad` at `speed_mps`.
    pub(crate) fn car(x: f64, y: f64, heading_rad: f64, speed_mps: f64) -> AgentState {
        AgentState {
            position: Point2::new(x, y),
            heading_rad,
            velocity_mps: Vector2::new(heading_rad.cos(), heading_rad.sin()) * speed_mps,
        }
    }

    #[test]
    fn a_car_on_the_bumper_at_speed_tailgates_and_one_at_a_two_second_gap_does_not() {
        let leader = car(0.0, 0.0, 0.0, 20.0);
        // Gap = centre distance − 4.5 m (two half lengths).
        let at_gap = |gap_m: f64| car(-4.5 - gap_m, 0.0, 0.0, 20.0);
        assert!(tailgates((&at_gap(0.3), CAR), (&leader, CAR)));
        assert!(tailgates((&at_gap(9.9), CAR), (&leader, CAR)), "0.495 s at 20 m/s");
        assert!(!tailgates((&at_gap(10.1), CAR), (&leader, CAR)), "0.505 s");
        assert!(!tailgates((&at_gap(40.0), CAR), (&leader, CAR)), "two seconds");
    }

    #[test]
    fn beside_ahead_across_or_creeping_is_not_tailgating() {
        let leader = car(0.0, 0.0, 0.0, 20.0);
        assert!(!tailgates((&car(-5.0, 3.5, 0.0, 20.0), CAR), (&leader, CAR)), "the next lane");
        assert!(!tailgates((&car(5.0, 0.0, 0.0, 20.0), CAR), (&leader, CAR)), "ahead");
        assert!(!tailgates((&car(-5.0, 0.0, 1.2, 20.0), CAR), (&leader, CAR)), "crossing behind");
        assert!(!tailgates((&car(-4.8, 0.0, 0.0, 3.0), CAR), (&car(0.0, 0.0, 0.0, 3.0), CAR)), "a queue");
    }

    #[test]
    fn the_following_gap_is_the_box_gap_behind_the_leader_only() {
        let leader = car(0.0, 0.0, 0.0, 20.0);
        let gap = following_gap_m((&car(-4.5 - 2.0, 0.0, 0.0, 20.0), CAR), (&leader, CAR)).unwrap();
        assert!((gap - 2.0).abs() < 1e-9, "{gap}");
        let far = following_gap_m((&car(-4.5 - 60.0, 0.0, 0.0, 20.0), CAR), (&leader, CAR)).unwrap();
        assert!((far - 60.0).abs() < 1e-9, "{far}");
        assert_eq!(following_gap_m((&car(-6.5, 3.5, 0.0, 20.0), CAR), (&leader, CAR)), None, "the next lane");
        assert_eq!(following_gap_m((&car(6.5, 0.0, 0.0, 20.0), CAR), (&leader, CAR)), None, "ahead");
        assert_eq!(following_gap_m((&car(-6.5, 0.0, 1.2, 20.0), CAR), (&leader, CAR)), None, "crossing");
    }
}
