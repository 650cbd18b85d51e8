//! Whether a token turns the adversary's CBV as a car can: within what
//! its tyres hold and no tighter than it steers ([`first_beyond`]). The
//! motion tokens reach a yaw rate of 1.5 rad/s at any speed: at 10 m/s
//! that pulls 15 m/s² sideways, half as much again as a road car's tyres
//! hold on dry asphalt, and at walking pace it swings the car round on the
//! spot. The prior, which learned recorded driving, rarely ranks such a
//! token high, but the adversary's losses pick the trust region's
//! extremes: without the grip bound the in-path CBVs of WOMD interactive
//! turned beyond grip in one variant in 12 (`safer-in-path` over 20
//! behaviours) to one in 6 (its lookahead over 60), at more than 20 m/s²
//! in some, and a CBV moving off from behind a stopped car turned 30° in
//! the metre it drove. A car cannot drive such a token, so it is
//! implausible for the CBV as leaving the road is.
//!
//! The grip bound is the default of the ego's own limits
//! ([`DEFAULT_MAX_LATERAL_ACCEL_MPS2`]), measured as the limits measure
//! it: the mean speed of a step times its yaw rate. Within grip is not yet
//! how people turn: a suite may hold the CBV to a lower bound
//! ([`CbvTurningLimit`]), such as the hardest turns of recorded drivers.
//! The steering bound is a car's tightest turn
//! ([`CAR_MAX_CURVATURE_PER_M`]): a step may turn the heading by at most
//! that much a metre it drives, so a standing CBV keeps its heading.

use crate::geometry::wrap_angle;
use crate::motion::tokens::SIM_DT_S;
use crate::motion::vehicle_limits::{CAR_MAX_CURVATURE_PER_M, DEFAULT_MAX_LATERAL_ACCEL_MPS2, lateral_accel_mps2};
use crate::scenario::{AgentKind, AgentState};

/// Floating-point slack on the grip bound: a token exactly at it is within it.
const SLACK_MPS2: f64 = 1e-6;
/// Floating-point slack on the steering bound, rad.
const SLACK_RAD: f64 = 1e-9;

/// How hard the adversary's CBV may turn: the largest lateral
/// acceleration a token may pull at any step, m/s². At most the tyres'
/// grip ([`CbvTurningLimit::GRIP`], the default), which no car passes; a
/// lower bound holds the CBV to how people turn (beyond the paper). A
/// vehicle CBV is also held to a car's turning circle
/// ([`CAR_MAX_CURVATURE_PER_M`]); a cyclist or a person on foot (a pair
/// as loaded may name one) is not.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
pub struct CbvTurningLimit {
    max_lateral_accel_mps2: f64,
    car_turning_circle: bool,
}

// Never NaN: built only from `GRIP` and by `new`, which refuses it.
impl Eq for CbvTurningLimit {}

impl CbvTurningLimit {
    /// The tyres' grip: the default of the ego's own limit,
    /// [`DEFAULT_MAX_LATERAL_ACCEL_MPS2`].
    pub const GRIP: Self = Self { max_lateral_accel_mps2: DEFAULT_MAX_LATERAL_ACCEL_MPS2, car_turning_circle: true };

    /// A limit of `max_lateral_accel_mps2`: `None` unless it is above 0
    /// and at most the grip (a car cannot turn harder, whatever is asked).
    pub fn new(max_lateral_accel_mps2: f64) -> Option<Self> {
        (max_lateral_accel_mps2 > 0.0 && max_lateral_accel_mps2 <= DEFAULT_MAX_LATERAL_ACCEL_MPS2)
            .then_some(Self { max_lateral_accel_mps2, ..Self::GRIP })
    }

    /// The largest lateral acceleration, m/s².
    pub fn max_lateral_accel_mps2(self) -> f64 {
        self.max_lateral_accel_mps2
    }

    /// The limit for a CBV of `kind`: a car's turning circle holds for a
    /// vehicle alone.
    pub(super) fn for_kind(self, kind: AgentKind) -> Self {
        Self { car_turning_circle: kind == AgentKind::Vehicle, ..self }
    }
}

impl Default for CbvTurningLimit {
    fn default() -> Self {
        Self::GRIP
    }
}

/// The first state of `rollout` (a token's states, one a simulator step,
/// from `now`) reached by a step that pulls more sideways than `limit`
/// allows or turns tighter than a car steers, or `None` where every step
/// stays within both.
pub(super) fn first_beyond(now: &AgentState, rollout: &[AgentState], limit: CbvTurningLimit) -> Option<usize> {
    std::iter::once(now).chain(rollout).zip(rollout).position(|(from, to)| {
        lateral_accel_mps2(from, to, SIM_DT_S) > limit.max_lateral_accel_mps2 + SLACK_MPS2
            || (limit.car_turning_circle && turns_tighter_than_a_car(from, to))
    })
}

/// Whether the step from `from` to `to` turns the heading by more than
/// [`CAR_MAX_CURVATURE_PER_M`] for the distance it drives.
fn turns_tighter_than_a_car(from: &AgentState, to: &AgentState) -> bool {
    let turned_rad = wrap_angle(to.heading_rad - from.heading_rad).abs();
    turned_rad > CAR_MAX_CURVATURE_PER_M * (to.position - from.position).norm() + SLACK_RAD
}

/// The lateral acceleration each step of `rollout` (a token's states, one
/// a simulator step, from `now`) pulls, m/s²: what the turning limit bounds.
pub(super) fn lateral_accels_mps2<'a>(
    now: &'a AgentState,
    rollout: &'a [AgentState],
) -> impl Iterator<Item = f64> + 'a {
    std::iter::once(now).chain(rollout).zip(rollout).map(|(from, to)| lateral_accel_mps2(from, to, SIM_DT_S))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::tokens::TOKEN_PERIOD_STEPS;
    use crate::policies::adversary::test_support::turning;

    #[test]
    fn a_token_beyond_the_tyres_grip_is_caught_at_its_first_step() {
        let grip = CbvTurningLimit::GRIP;
        // 1.5 rad/s at 10 m/s pulls 15 m/s²; at 5 m/s, 7.5 m/s².
        let (now, fast) = turning(10.0, 1.5);
        assert_eq!(fast.len(), TOKEN_PERIOD_STEPS);
        assert_eq!(first_beyond(&now, &fast, grip), Some(0));
        // 1.3 rad/s at 6 m/s pulls 7.8 m/s² on a 4.6 m radius: within both.
        let (now, slow) = turning(6.0, 1.3);
        assert_eq!(first_beyond(&now, &slow, grip), None);
        // 0.8 rad/s at 10 m/s (8 m/s²) is within grip; straight on is too.
        let (now, gentle) = turning(10.0, 0.8);
        assert_eq!(first_beyond(&now, &gentle, grip), None);
        let (now, straight) = turning(30.0, 0.0);
        assert_eq!(first_beyond(&now, &straight, grip), None);
        // A lower limit catches the gentle turn too.
        assert_eq!(first_beyond(&now, &straight, CbvTurningLimit::new(4.0).unwrap()), None);
        let (now, gentle) = turning(10.0, 0.8);
        assert_eq!(first_beyond(&now, &gentle, CbvTurningLimit::new(4.0).unwrap()), Some(0));
    }

    #[test]
    fn a_token_tighter_than_a_car_steers_is_caught_however_gently_it_pulls() {
        let grip = CbvTurningLimit::GRIP;
        // 1.5 rad/s at 5 m/s pulls 7.5 m/s², within grip, on a 3.3 m radius.
        let (now, tight) = turning(5.0, 1.5);
        assert_eq!(first_beyond(&now, &tight, grip), Some(0));
        // At walking pace (1 m/s) a tenth of a radian a second or so is a
        // car's full lock; half a radian a second is a spin.
        let (now, lock) = turning(1.0, 0.19);
        assert_eq!(first_beyond(&now, &lock, grip), None);
        let (now, spin) = turning(1.0, 0.5);
        assert_eq!(first_beyond(&now, &spin, grip), Some(0));
        // A standing car keeps its heading: the gentlest turn is too much,
        // straight on is not.
        let (now, on_the_spot) = turning(0.0, 0.05);
        assert_eq!(first_beyond(&now, &on_the_spot, grip), Some(0));
        let (now, standing) = turning(0.0, 0.0);
        assert_eq!(first_beyond(&now, &standing, grip), None);
        // A person on foot or a cyclist as the CBV turns where it stands.
        for kind in [AgentKind::Pedestrian, AgentKind::Cyclist] {
            assert_eq!(first_beyond(&now, &on_the_spot, grip.for_kind(kind)), None, "{kind:?}");
        }
        assert_eq!(first_beyond(&now, &on_the_spot, grip.for_kind(AgentKind::Vehicle)), Some(0));
    }

    #[test]
    fn a_turning_limit_is_above_zero_and_within_grip() {
        assert_eq!(CbvTurningLimit::new(4.0).map(CbvTurningLimit::max_lateral_accel_mps2), Some(4.0));
        assert_eq!(CbvTurningLimit::new(DEFAULT_MAX_LATERAL_ACCEL_MPS2), Some(CbvTurningLimit::GRIP));
        for refused in [0.0, -1.0, 9.5, f64::NAN, f64::INFINITY] {
            assert_eq!(CbvTurningLimit::new(refused), None, "{refused}");
        }
    }
}
