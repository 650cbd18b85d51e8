//! The shipped feasibility value V_h: loads, matches its card, reproduces
//! its goldens in tract, and separates an obviously safe state from an
//! obviously violating one.

use safer_scenarios::geometry::{Point2, Vector2};
use safer_scenarios::models::ModelSource;
use safer_scenarios::models::feasibility::{FeasibilityValue, pair};
use safer_scenarios::scenario::{AgentBody, AgentKind, AgentState};

fn car() -> AgentBody {
    AgentBody { kind: AgentKind::Vehicle, length_m: 4.6, width_m: 1.9 }
}

fn at(x: f64, y: f64, heading: f64, v: f64) -> AgentState {
    AgentState {
        position: Point2::new(x, y),
        heading_rad: heading,
        velocity_mps: Vector2::new(heading.cos(), heading.sin()) * v,
    }
}

#[test]
fn shipped_feasibility_value_reproduces_its_goldens() {
    let v = FeasibilityValue::load(&ModelSource::Embedded).unwrap();
    let replay = v.model().replay_golden().unwrap();
    assert_eq!(replay.values, 20);
    assert!(replay.max_abs_diff <= replay.tolerance, "{replay:?}");
}

#[test]
fn far_states_are_feasible_and_overlapping_states_are_not() {
    let v = FeasibilityValue::load(&ModelSource::Embedded).unwrap();
    let ego = at(0.0, 0.0, 0.0, 10.0);
    let states = [
        pair(ego, car(), at(40.0, 0.0, 0.0, 10.0), car()), // 40 m ahead, same speed
        pair(ego, car(), at(0.0, 20.0, 0.0, 10.0), car()), // far to the side
        pair(ego, car(), at(3.0, 0.0, 0.0, 0.0), car()),   // overlapping, stopped
        pair(ego, car(), at(1.0, 0.5, 0.3, 12.0), car()),  // overlapping
    ];
    let values = v.evaluate(&states).unwrap();
    assert!(values[0] <= 0.0 && values[1] <= 0.0, "{values:?}");
    assert!(values[2] > 0.0 && values[3] > 0.0, "{values:?}");
    // 25 states: more than one model batch (20), in order.
    let many: Vec<_> = (0..25).map(|i| states[i % 4]).collect();
    let out = v.evaluate(&many).unwrap();
    assert_eq!(out.len(), 25);
    assert_eq!(out[24], values[0]);
}
