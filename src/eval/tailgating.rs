//! How long a road user drove close behind another: the realism check of
//! a CBV that closes on the ego from behind and then hangs on its bumper.
//!
//! A CBV held off contacts from behind the ego (by V_h, or by a rule
//! against the contact alone) can still close to within centimetres of
//! the ego's tail and follow it there at speed: no collision, so neither
//! CR nor the plausibility rules see it, yet no driver follows a car at a
//! few hundredths of a second. (`ego_contact: not-from-behind` keeps the
//! CBV off the bumper too, where a plausible token does.) The measure is the *time gap* of car
//! following (the bumper-to-bumper gap over the follower's speed), held
//! while the follower is behind the leader, within its width and going
//! its way ([`tailgates`], which the adversary's rule against closing on
//! the ego's tail shares).

pub use crate::scenario::following::{TAILGATE_MIN_SPEED_MPS, TAILGATE_TIME_GAP_S, tailgates};
use crate::scenario::{AgentBody, AgentState};

/// How long the follower must hold it to count as tailgating, s (a
/// merge or a pass through the gap takes less).
pub const TAILGATE_HELD_S: f64 = 1.0;

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
    use crate::scenario::following::tests::{CAR, car};

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
