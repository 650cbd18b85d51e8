//! What a token's turn adds to the adversary's loss ([`CbvTurningCost`],
//! beyond the paper).
//!
//! The losses rank a candidate only by where it puts the CBV, so of two
//! that get it about as close the one turning harder wins whenever it gets
//! there a little sooner: held within grip, the in-path CBVs peak at three
//! to four times the lateral acceleration of the recorded CBVs at the
//! median. A turning limit caps the peak but not the habit: the losses take
//! the limit's edge, wherever it is. A turning cost weighs the turn in the
//! loss itself, so a harder turn is taken only where it gets the CBV
//! closer by more than it costs. The token about to be taken pays for its
//! own turn; a lookahead's later tokens do not, as each is taken, or not,
//! at its own boundary, where it pays then.

use super::turning_limit::lateral_accels_mps2;
use crate::scenario::AgentState;

/// The largest turning cost a suite or the command line may set, m per
/// m/s²: well past the costs worth setting (at 1 the in-path CBV already
/// turns less than recorded drivers), and a bound that refuses a slip such
/// as 50 for 0.50.
pub const MAX_TURNING_COST_M_PER_MPS2: f64 = 5.0;

/// What a m/s² of the CBV's lateral acceleration adds to a feasible
/// candidate's loss, m (beyond the paper): the peak over the token's steps,
/// measured as the turning limit measures it (a step's mean speed times its
/// yaw rate). 0, the default, is the paper's loss.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct CbvTurningCost(f64);

// Never NaN: built only from `NONE` and by `new`, which refuses it.
impl Eq for CbvTurningCost {}

impl CbvTurningCost {
    /// No cost: the losses as they are.
    pub const NONE: Self = Self(0.0);

    /// A cost of `m_per_mps2`: `None` unless it is finite, at least 0 and
    /// at most [`MAX_TURNING_COST_M_PER_MPS2`].
    pub fn new(m_per_mps2: f64) -> Option<Self> {
        (0.0..=MAX_TURNING_COST_M_PER_MPS2).contains(&m_per_mps2).then_some(Self(m_per_mps2))
    }

    /// The cost, m per m/s².
    pub fn m_per_mps2(self) -> f64 {
        self.0
    }

    /// Whether a turn costs anything.
    pub fn is_set(self) -> bool {
        self.0 > 0.0
    }

    /// What the token whose states are `rollout` (one a simulator step,
    /// from `now`) adds to its loss, m.
    pub(super) fn of(self, now: &AgentState, rollout: &[AgentState]) -> f64 {
        if !self.is_set() {
            return 0.0;
        }
        self.0 * lateral_accels_mps2(now, rollout).fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Action;
    use crate::motion::tokens::TokenGrid;
    use crate::policies::adversary::test_support::turning;

    #[test]
    fn a_turn_costs_its_peak_lateral_acceleration_times_the_cost() {
        let cost = CbvTurningCost::new(0.5).unwrap();
        // Straight on costs nothing; 0.4 rad/s at 10 m/s pulls about 4 m/s².
        let (now, straight) = turning(10.0, 0.0);
        assert_eq!(cost.of(&now, &straight), 0.0);
        let (now, turn) = turning(10.0, 0.4);
        let paid = cost.of(&now, &turn);
        let yaw_rate =
            TokenGrid::action(TokenGrid::quantize(Action { accel_mps2: 0.0, yaw_rate_radps: 0.4 })).yaw_rate_radps;
        assert!((paid - 0.5 * 10.0 * yaw_rate).abs() < 0.05, "{paid}");
        // The same turn at half the speed pulls half as much; none is free.
        let (now, slow) = turning(5.0, 0.4);
        assert!((cost.of(&now, &slow) - paid / 2.0).abs() < 0.05);
        assert_eq!(CbvTurningCost::NONE.of(&now, &slow), 0.0);
    }

    #[test]
    fn a_turning_cost_is_finite_and_within_its_range() {
        assert_eq!(CbvTurningCost::new(0.1).map(CbvTurningCost::m_per_mps2), Some(0.1));
        assert_eq!(CbvTurningCost::new(0.0), Some(CbvTurningCost::NONE));
        assert!(!CbvTurningCost::NONE.is_set());
        assert!(CbvTurningCost::new(MAX_TURNING_COST_M_PER_MPS2).is_some());
        for refused in [-0.1, 5.5, f64::NAN, f64::INFINITY] {
            assert_eq!(CbvTurningCost::new(refused), None, "{refused}");
        }
    }
}
