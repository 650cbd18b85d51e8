//! The plausible range of an agent state. Everything downstream (collision
//! sweeps, road-edge ring searches, TTC, pictures) assumes finite positions
//! at map scale; a planner answering `accel_mps2: 1e100`, a trajectory point
//! at x = 1e20 or a recording with one sample at x = 1e20 once drove those
//! loops into hours-long busy work. Importers refuse recorded states outside
//! these bounds (naming the agent and step), and the simulator checks every
//! state it produces, ending the rollout with a reason instead.

use super::AgentState;

/// Largest |x| or |y| of a simulated position in the scene frame, m.
/// Scenes are re-centred near their ego, so 10,000 km is far beyond any
/// road and still small enough for every geometric query to be exact.
pub const MAX_ABS_POSITION_M: f64 = 1e7;

/// Largest |x| or |y| of a recorded position in its source's world frame,
/// before re-centring, m: world frames such as UTM reach 1e7 m.
pub const MAX_ABS_WORLD_POSITION_M: f64 = 1e8;

/// Largest side of an agent's box, m: beyond any road vehicle (a road
/// train is about 50 m), and what the box–box queries assume.
pub const MAX_BODY_M: f64 = 100.0;

/// Largest simulated speed, m/s (about 3,600 km/h): no road user gets
/// close, yet it leaves room for noisy recorded velocities.
pub const MAX_SPEED_MPS: f64 = 1e3;

/// Largest |heading| a recording may give before wrapping, rad: sources
/// write angles within a turn or two of zero; 1e300 rad wraps to an
/// arbitrary angle (its digits below a turn are gone).
pub const MAX_ABS_RECORDED_HEADING_RAD: f64 = 1e3;

/// A recorded heading, wrapped into (−π, π]; an error saying why when it
/// is not finite or beyond [`MAX_ABS_RECORDED_HEADING_RAD`].
pub fn recorded_heading(raw_rad: f64) -> Result<f64, String> {
    if raw_rad.is_finite() && raw_rad.abs() <= MAX_ABS_RECORDED_HEADING_RAD {
        Ok(crate::geometry::wrap_angle(raw_rad))
    } else {
        Err(format!(
            "heading {raw_rad:e} rad is not a plausible angle (at most {MAX_ABS_RECORDED_HEADING_RAD} rad either way)"
        ))
    }
}

/// Why `state` is not a plausible state in a scene frame, or `None` when it is.
pub fn implausibility(state: &AgentState) -> Option<String> {
    implausibility_within(state, MAX_ABS_POSITION_M)
}

/// Why `state` is not plausible with positions bounded by
/// `max_abs_position_m`, or `None` when it is.
pub fn implausibility_within(state: &AgentState, max_abs_position_m: f64) -> Option<String> {
    let values = [
        ("x", state.position.x, max_abs_position_m, "m"),
        ("y", state.position.y, max_abs_position_m, "m"),
        ("heading", state.heading_rad, f64::MAX, "rad"),
        ("velocity x", state.velocity_mps.x, MAX_SPEED_MPS, "m/s"),
        ("velocity y", state.velocity_mps.y, MAX_SPEED_MPS, "m/s"),
    ];
    for (name, value, bound, unit) in values {
        if !value.is_finite() {
            return Some(format!("{name} = {value} is not finite"));
        }
        if value.abs() > bound {
            return Some(format!(
                "{name} = {} {unit} is outside the simulation bounds (±{} {unit})",
                crate::number::shown(value),
                crate::number::shown(bound)
            ));
        }
    }
    let speed = state.speed_mps();
    (speed > MAX_SPEED_MPS).then(|| {
        format!(
            "speed = {} m/s is outside the simulation bounds (≤ {} m/s)",
            crate::number::shown(speed),
            crate::number::shown(MAX_SPEED_MPS)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};

    fn state(x: f64, vx: f64) -> AgentState {
        AgentState { position: Point2::new(x, 0.0), heading_rad: 0.0, velocity_mps: Vector2::new(vx, 0.0) }
    }

    #[test]
    fn map_scale_states_are_plausible() {
        assert_eq!(implausibility(&state(5_000.0, 40.0)), None);
        assert_eq!(implausibility(&state(-9.9e6, -999.0)), None);
    }

    #[test]
    fn huge_and_non_finite_values_are_named() {
        let r = implausibility(&state(1e20, 0.0)).unwrap();
        assert!(r.starts_with("x = 1e20 m is outside"), "{r}");
        let r = implausibility(&state(0.0, f64::NAN)).unwrap();
        assert!(r.starts_with("velocity x = NaN"), "{r}");
        let r = implausibility(&state(0.0, 1e99)).unwrap();
        assert!(r.contains("velocity x"), "{r}");
        let mut diagonal = state(0.0, 800.0);
        diagonal.velocity_mps.y = 800.0;
        assert!(implausibility(&diagonal).unwrap().starts_with("speed"));
    }
}
