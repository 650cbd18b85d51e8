//! Distinct behaviours among tokens: each token held for
//! [`BEHAVIOUR_HOLD_S`] from the CBV's state, two tokens being one
//! behaviour when their end positions lie within
//! [`BEHAVIOUR_SEPARATION_M`]. On the fine token grid neighbouring tokens
//! are near-duplicates (0.16 m/s² and 0.05 rad/s apart), so a confident
//! prior's likeliest tokens are often variants of one or two manoeuvres;
//! grouping them says how many different things the CBV could do, and
//! the distinct-behaviour trust region keeps one token of each.

use crate::geometry::Point2;
use crate::motion::KinematicState;
use crate::motion::kinematics::{step_to_heading, turned_headings};
use crate::motion::tokens::{BINS_PER_AXIS, SIM_DT_S, Token, TokenGrid};

/// How long each token is held to tell behaviours apart, s.
pub const BEHAVIOUR_HOLD_S: f64 = 2.0;

/// End positions closer than this are one behaviour, m.
pub const BEHAVIOUR_SEPARATION_M: f64 = 1.0;

/// The steps [`BEHAVIOUR_HOLD_S`] lasts.
const HOLD_STEPS: usize = (BEHAVIOUR_HOLD_S / SIM_DT_S + 0.5) as usize;

/// The headings (each with its `sin_cos()`) of the steps of a hold.
type HoldHeadings = [(f64, (f64, f64)); HOLD_STEPS];

/// The headings the CBV turns through holding `yaw_rate_radps` for
/// [`BEHAVIOUR_HOLD_S`] from `from`: they depend on the yaw rate alone, so
/// the many accelerations of a ranking that share one are stepped with
/// them worked out once.
fn hold_headings(from: &KinematicState, yaw_rate_radps: f64) -> HoldHeadings {
    turned_headings(from.heading_rad, yaw_rate_radps, SIM_DT_S)
}

/// Where the CBV ends after holding `token` for [`BEHAVIOUR_HOLD_S`] from
/// `from`, turning through `headings` (its yaw rate's): the end of
/// [`kinematic_step`]s to the bit.
fn behaviour_end(from: &KinematicState, token: Token, headings: &HoldHeadings) -> Point2 {
    let accel_mps2 = TokenGrid::action(token).accel_mps2;
    headings
        .iter()
        .fold(*from, |state, &(heading_rad, sin_cos)| {
            step_to_heading(&state, accel_mps2, heading_rad, sin_cos, SIM_DT_S)
        })
        .position
}

/// The first token of each behaviour among `tokens`, in their order, at
/// most `limit` of them: a token starts a new behaviour when it ends more
/// than [`BEHAVIOUR_SEPARATION_M`] from every earlier behaviour's first
/// token. Given the tokens most likely first, these are each behaviour's
/// likeliest token.
pub fn distinct_behaviours(from: &KinematicState, tokens: impl IntoIterator<Item = Token>, limit: usize) -> Vec<Token> {
    if limit == 0 {
        return Vec::new();
    }
    let mut leaders: Vec<(Token, Point2)> = Vec::new();
    let mut headings: [Option<HoldHeadings>; BINS_PER_AXIS] = [None; BINS_PER_AXIS];
    // The scan stops at the limit without asking `tokens` for another: a
    // lazy tail (the rest of a ranking) is then never computed.
    for token in tokens {
        let turned = headings[token.yaw_rate_bin()]
            .get_or_insert_with(|| hold_headings(from, TokenGrid::action(token).yaw_rate_radps));
        let end = behaviour_end(from, token, turned);
        if leaders.iter().all(|(_, l)| (l - end).norm() > BEHAVIOUR_SEPARATION_M) {
            leaders.push((token, end));
            if leaders.len() == limit {
                break;
            }
        }
    }
    leaders.into_iter().map(|(t, _)| t).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point2;
    use crate::motion::kinematic_step;

    fn at_10_mps() -> KinematicState {
        KinematicState { position: Point2::origin(), heading_rad: 0.0, speed_mps: 10.0 }
    }

    #[test]
    fn neighbouring_tokens_are_one_behaviour_and_distant_ones_are_not() {
        let mid = BINS_PER_AXIS / 2;
        let t = |a: usize, y: usize| Token::from_bins(a, y).unwrap();
        // One acceleration bin apart: 0.16 m/s² over 2 s is 0.32 m.
        let near = [t(mid, mid), t(mid + 1, mid), t(mid - 1, mid)];
        assert_eq!(distinct_behaviours(&at_10_mps(), near, usize::MAX), vec![t(mid, mid)]);
        // Ten bins apart: 1.6 m/s² is 3.2 m; the leaders keep their order.
        let far = [t(mid + 10, mid), t(mid, mid), t(mid + 9, mid), t(mid, mid + 5)];
        assert_eq!(
            distinct_behaviours(&at_10_mps(), far, usize::MAX),
            vec![t(mid + 10, mid), t(mid, mid), t(mid, mid + 5)]
        );
        // The limit stops the scan.
        assert_eq!(distinct_behaviours(&at_10_mps(), far, 2), vec![t(mid + 10, mid), t(mid, mid)]);
    }

    #[test]
    fn a_behaviours_end_is_the_kinematic_steps_end_to_the_bit() {
        for (heading_rad, speed_mps) in [(0.0, 10.0), (3.1, 0.4), (-1.2, 30.0)] {
            let from = KinematicState { position: Point2::new(-40.0, 2.0), heading_rad, speed_mps };
            for token in TokenGrid::all().step_by(5) {
                let action = TokenGrid::action(token);
                let stepped = (0..20).fold(from, |state, _| kinematic_step(&state, action, SIM_DT_S)).position;
                let end = behaviour_end(&from, token, &hold_headings(&from, action.yaw_rate_radps));
                assert_eq!((end.x.to_bits(), end.y.to_bits()), (stepped.x.to_bits(), stepped.y.to_bits()), "{token:?}");
            }
        }
    }
}
