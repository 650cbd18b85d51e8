//! The choices the search tries each token period (accelerations from
//! full braking to full acceleration, and a set of yaw rates); the car's
//! turning limit is [`turn_bounded_yaw_rate`](crate::motion::kinematics::turn_bounded_yaw_rate).

use crate::motion::kinematics::stepped_speed_mps;
use crate::motion::tokens::{MAX_ACCEL_MPS2, SIM_DT_S, TOKEN_PERIOD_STEPS};

/// The speeds over one period of `steps` steps from `speed_mps` at
/// `accel_mps2`, as [`step_to_heading`](crate::motion::kinematics::step_to_heading) computes them (`speeds[k]` after
/// k + 1 steps; the rest unused).
pub(super) fn period_speeds(speed_mps: f64, accel_mps2: f64, steps: usize) -> [f64; TOKEN_PERIOD_STEPS] {
    let mut v = speed_mps;
    let mut speeds = [0.0; TOKEN_PERIOD_STEPS];
    for s in speeds.iter_mut().take(steps) {
        v = stepped_speed_mps(v, accel_mps2, SIM_DT_S);
        *s = v;
    }
    speeds
}

/// Accelerations tried per period, m/s²: full braking to full acceleration
/// (the token grid's range; an escape from a car closing from behind may
/// need all of it).
pub(super) const ACCELS_MPS2: [f64; 8] = [-MAX_ACCEL_MPS2, -3.5, -2.0, -0.8, 0.0, 1.0, 2.5, MAX_ACCEL_MPS2];
/// Yaw rates tried per period, rad/s (the grid allows ±1.5; ±1 rad/s is a
/// 10 m radius at 10 m/s, the sharpest swerve most escapes need; more
/// choices per period would outgrow the expansion budget of an 8 s
/// search: 48 candidates × 72 actions × 16 periods = 55 296 of 60 000).
pub(super) const YAW_RATES_RADPS: [f64; 9] = [-1.0, -0.6, -0.3, -0.1, 0.0, 0.1, 0.3, 0.6, 1.0];

/// Choices tried per candidate and period.
pub(super) const ACTIONS: usize = ACCELS_MPS2.len() * YAW_RATES_RADPS.len();

#[cfg(test)]
mod tests {
    use crate::eval::witness::test_support::{
        assert_touches_no_car, assert_turns_like_a_car, at, car, oncoming_car, search_among_cars, states_over,
    };
    use crate::eval::witness::{FixedTraffic, Witness, WitnessBudget, search_witness};
    use crate::scenario::{AgentBody, AgentKind};

    #[test]
    fn a_wall_closing_from_behind_is_escaped_at_full_acceleration() {
        // Ego at 10 m/s, a wall 40 m wide 4 m behind it at 15 m/s: no swerve
        // clears it, braking or holding speed is hit within a second, and
        // 2.5 m/s² is caught after 1.1 s; 5 m/s² keeps 1.5 m clear.
        let horizon = 20;
        let wall = AgentBody { kind: AgentKind::Vehicle, length_m: 4.0, width_m: 40.0 };
        let states = states_over(horizon, |t| vec![None, Some(at(-8.25 + 15.0 * t, 0.0, 15.0))]);
        let traffic = FixedTraffic { states: &states, bodies: &[car(), wall], ego: 0, road: None };
        let w = search_witness(&at(0.0, 0.0, 10.0), car(), &traffic, horizon, WitnessBudget::default());
        let Witness::Found { trajectory, min_clearance_m, .. } = w else { panic!("{w:?}") };
        assert!(min_clearance_m > WitnessBudget::default().margin_m);
        // Faster than 2.5 m/s² could make it over the first second.
        assert!(trajectory[10].speed_mps() > 10.0 + 2.5 + 1.0, "{:?}", trajectory[10]);
    }

    #[test]
    fn a_standing_car_moves_off_before_it_turns() {
        // Ego standing, the car head-on: it must pull away and steer out of
        // the lane; it may not turn in place.
        let horizon = 60;
        let states = oncoming_car(horizon);
        let w = search_among_cars(search_witness, &at(0.0, 0.0, 0.0), &states, horizon);
        let Witness::Found { trajectory, .. } = w else { panic!("{w:?}") };
        assert_touches_no_car(&trajectory, &states);
        assert_turns_like_a_car(&trajectory);
    }
}
