//! Distinct behaviours among tokens: each token held for
//! [`BEHAVIOUR_HOLD_S`] from the CBV's state, two tokens being one
//! behaviour when their end positions lie within
//! [`BEHAVIOUR_SEPARATION_M`]. On the fine token grid neighbouring tokens
//! are near-duplicates (0.16 m/s² and 0.05 rad/s apart), so a confident
//! prior's likeliest tokens are often variants of one or two manoeuvres;
//! grouping them says how many different things the CBV could do, and
//! the distinct-behaviour trust region keeps one token of each.

use crate::geometry::Point2;
use crate::motion::tokens::{SIM_DT_S, Token, TokenGrid};
use crate::motion::{KinematicState, kinematic_step};

/// How long each token is held to tell behaviours apart, s.
pub const BEHAVIOUR_HOLD_S: f64 = 2.0;

/// End positions closer than this are one behaviour, m.
pub const BEHAVIOUR_SEPARATION_M: f64 = 1.0;

/// Where the CBV ends after holding `token` for [`BEHAVIOUR_HOLD_S`] from `from`.
fn behaviour_end(from: &KinematicState, token: Token) -> Point2 {
    let action = TokenGrid::action(token);
    let hold_steps = (BEHAVIOUR_HOLD_S / SIM_DT_S).round() as usize;
    (0..hold_steps).fold(*from, |state, _| kinematic_step(&state, action, SIM_DT_S)).position
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
    // The scan stops at the limit without asking `tokens` for another: a
    // lazy tail (the rest of a ranking) is then never computed.
    for token in tokens {
        let end = behaviour_end(from, token);
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
    use crate::motion::tokens::BINS_PER_AXIS;

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
}
