//! How long a road user drove close behind another: the realism check of
//! a CBV that closes on the ego from behind and then hangs on its bumper.
//!
//! A CBV held off contacts from behind the ego (`ego_contact:
//! not-from-behind`) can still close to within centimetres of the ego's
//! tail and follow it there at speed: no collision, so neither CR nor the
//! plausibility rules see it, yet no driver follows a car at a few
//! hundredths of a second. The measure is the *time gap* of car
//! following (the bumper-to-bumper gap over the follower's speed), held
//! while the follower is behind the leader, within its width and going
//! its way.

use crate::geometry::Vector2;
use crate::scenario::{AgentBody, AgentState};

/// The time gap under which following counts as tailgating, s: half a
/// second, a fraction of the one to two seconds drivers commonly keep,
/// and under what they keep even in dense freeway traffic.
pub const TAILGATE_TIME_GAP_S: f64 = 0.5;

/// How long the follower must hold it to count as tailgating, s (a
/// merge or a pass through the gap takes less).
pub const TAILGATE_HELD_S: f64 = 1.0;

/// The speed below which close following is not tailgating, m/s (a queue
/// creeping at walking pace keeps small gaps).
pub const TAILGATE_MIN_SPEED_MPS: f64 = 5.0;

/// Whether `follower` drives behind `leader` within the time gap: moving
/// at [`TAILGATE_MIN_SPEED_MPS`] or more, within 45° of the leader's
/// heading, its centre behind the leader's tail and within the two
/// bodies' half widths of the leader's heading line, and the gap between
/// the boxes under [`TAILGATE_TIME_GAP_S`] of its speed.
pub fn tailgates(follower: (&AgentState, AgentBody), leader: (&AgentState, AgentBody)) -> bool {
    let ((f, f_body), (l, l_body)) = (follower, leader);
    let speed_mps = f.speed_mps();
    if speed_mps < TAILGATE_MIN_SPEED_MPS {
        return false;
    }
    let (sin, cos) = l.heading_rad.sin_cos();
    // Going the leader's way: within 45° (cos > cos 45°).
    if (f.heading_rad - l.heading_rad).cos() < std::f64::consts::FRAC_1_SQRT_2 {
        return false;
    }
    let offset = f.position - l.position;
    let ahead_m = offset.dot(&Vector2::new(cos, sin));
    let lateral_m = offset.dot(&Vector2::new(-sin, cos)).abs();
    if ahead_m > -0.5 * l_body.length_m || lateral_m > 0.5 * (l_body.width_m + f_body.width_m) {
        return false;
    }
    l_body.footprint(l).distance(&f_body.footprint(f)) < TAILGATE_TIME_GAP_S * speed_mps
}

/// The longest run of consecutive steps at which `follower` tailgated
/// `leader` ([`tailgates`]), s (0 where it never did); `None` where the
/// two were never present at the same step.
pub fn longest_tailgating_s(
    follower: (&[Option<AgentState>], AgentBody),
    leader: (&[Option<AgentState>], AgentBody),
    dt_s: f64,
) -> Option<f64> {
    let ((f_states, f_body), (l_states, l_body)) = (follower, leader);
    let (mut run, mut longest, mut measured) = (0usize, 0usize, false);
    for (f, l) in f_states.iter().zip(l_states) {
        let close = match (f, l) {
            (Some(f), Some(l)) => {
                measured = true;
                tailgates((f, f_body), (l, l_body))
            }
            _ => false,
        };
        run = if close { run + 1 } else { 0 };
        longest = longest.max(run);
    }
    measured.then_some(longest as f64 * dt_s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point2;
    use crate::scenario::AgentKind;

    const CAR: AgentBody = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };

    fn car(x: f64, y: f64, heading_rad: f64, speed_mps: f64) -> AgentState {
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
    fn the_longest_run_counts_consecutive_steps_and_absence_is_unmeasured() {
        let leader: Vec<_> = (0..30).map(|k| Some(car(2.0 * k as f64, 0.0, 0.0, 20.0))).collect();
        // On the bumper for steps 5..20 (15 steps), 30 m back otherwise.
        let follower: Vec<_> = (0..30)
            .map(|k| {
                let gap_m = if (5..20).contains(&k) { 0.5 } else { 30.0 };
                Some(car(2.0 * k as f64 - 4.5 - gap_m, 0.0, 0.0, 20.0))
            })
            .collect();
        let longest = longest_tailgating_s((&follower, CAR), (&leader, CAR), 0.1).unwrap();
        assert!((longest - 1.5).abs() < 1e-12);
        let absent = vec![None; 30];
        assert_eq!(longest_tailgating_s((&absent, CAR), (&leader, CAR), 0.1), None);
        let far: Vec<_> = leader.iter().map(|l| l.map(|l| car(l.position.x - 40.0, 0.0, 0.0, 20.0))).collect();
        assert_eq!(longest_tailgating_s((&far, CAR), (&leader, CAR), 0.1), Some(0.0));
    }
}
