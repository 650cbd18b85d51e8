//! What the witness's unit tests share: cars, starts, traffic and roads
//! to search among, and the checks of a found trajectory.

use super::{FixedTraffic, MIN_TURN_RADIUS_M, RoadKeeping, RoadRule, Witness, WitnessBudget};
use crate::geometry::{OrientedBox, Point2, Vector2};
use crate::map::RoadMap;
use crate::motion::tokens::SIM_DT_S;
use crate::scenario::{AgentBody, AgentKind, AgentState};

/// A car's body, 4.5 m by 2 m.
pub(super) fn car() -> AgentBody {
    AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }
}

/// An agent at (`x`, `y`) heading along +x at `v` m/s.
pub(super) fn at(x: f64, y: f64, v: f64) -> AgentState {
    AgentState { position: Point2::new(x, y), heading_rad: 0.0, velocity_mps: Vector2::new(v, 0.0) }
}

/// Traffic around a start at the origin: `n` cars on straight lines,
/// some parked, from a fixed seed; some come and go mid-way.
pub(super) fn random_traffic(n: usize, steps: usize, seed: u64) -> (Vec<Vec<Option<AgentState>>>, Vec<AgentBody>) {
    let mut state = seed;
    let mut next = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let agents: Vec<(Point2, f64, f64, AgentBody, usize)> = (0..n)
        .map(|_| {
            // Clear of the start, so most searches get going.
            let mut p = Point2::new(0.0, 0.0);
            while p.coords.norm() < 6.0 {
                p = Point2::new(next() * 60.0 - 20.0, next() * 24.0 - 12.0);
            }
            let heading = next() * 6.3 - 3.15;
            let speed = if next() < 0.4 { 0.0 } else { next() * 12.0 };
            let body = AgentBody { kind: AgentKind::Vehicle, length_m: 3.5 + next() * 5.0, width_m: 1.6 + next() };
            (p, heading, speed, body, (next() * steps as f64 * 1.5) as usize)
        })
        .collect();
    let states = (0..=steps)
        .map(|k| {
            let t = k as f64 * SIM_DT_S;
            let mut row = vec![None];
            row.extend(agents.iter().map(|&(p, h, v, _, gone)| {
                let dir = Vector2::new(h.cos(), h.sin());
                (k < gone).then(|| AgentState { position: p + dir * v * t, heading_rad: h, velocity_mps: dir * v })
            }));
            row
        })
        .collect();
    let mut bodies = vec![car()];
    bodies.extend(agents.iter().map(|a| a.3));
    (states, bodies)
}

/// A straight road 200 m long with `lanes` lanes of 3.5 m, the first
/// lane's centre on the x axis and the origin 100 m from either end.
pub(super) fn straight_road(lanes: usize) -> RoadMap {
    straight_road_of(lanes, 3.5)
}

/// [`straight_road`] with lanes `lane_width_m` wide.
pub(super) fn straight_road_of(lanes: usize, lane_width_m: f64) -> RoadMap {
    let road = crate::map::templates::StraightRoad {
        lanes,
        oncoming_lanes: 0,
        lane_width_m,
        length_m: 200.0,
        speed_limit_mps: None,
    };
    road.build().translated(&Vector2::new(100.0, 0.5 * lane_width_m))
}

/// The rule keeping the ego's centre on `map`.
pub(super) fn centre_on(map: &RoadMap) -> Option<RoadRule<'_>> {
    Some(RoadRule { map, keeping: RoadKeeping::Centre })
}

/// Each step's agents, from steps 0 to `horizon`, by `at_time_s`.
pub(super) fn states_over(
    horizon: usize,
    at_time_s: impl Fn(f64) -> Vec<Option<AgentState>>,
) -> Vec<Vec<Option<AgentState>>> {
    (0..=horizon).map(|k| at_time_s(k as f64 * SIM_DT_S)).collect()
}

/// `search` from `start` (ego index 0) with the default budget, every agent a car.
pub(super) fn search_among_cars(
    search: fn(&AgentState, AgentBody, &FixedTraffic<'_>, usize, WitnessBudget) -> Witness,
    start: &AgentState,
    states: &[Vec<Option<AgentState>>],
    horizon: usize,
) -> Witness {
    let bodies = vec![car(); states[0].len()];
    let traffic = FixedTraffic { states, bodies: &bodies, ego: 0, road: None };
    search(start, car(), &traffic, horizon, WitnessBudget::default())
}

/// Every state of `trajectory` (a car) clear of every car in `states`.
pub(super) fn assert_touches_no_car(trajectory: &[AgentState], states: &[Vec<Option<AgentState>>]) {
    assert_touches_none_of(trajectory, states, &vec![car(); states[0].len()]);
}

/// Every state of `trajectory` (a car) clear of every agent (of
/// `bodies`) in `states`.
pub(super) fn assert_touches_none_of(
    trajectory: &[AgentState],
    states: &[Vec<Option<AgentState>>],
    bodies: &[AgentBody],
) {
    for (k, s) in trajectory.iter().enumerate() {
        let ego = OrientedBox::new(s.pose(), 4.5, 2.0);
        for (other, b) in states[k].iter().zip(bodies).skip(1) {
            let Some(other) = other else { continue };
            assert!(!ego.intersects(&OrientedBox::new(other.pose(), b.length_m, b.width_m)), "step {k}");
        }
    }
}

/// Every step of `trajectory` turns no tighter than [`MIN_TURN_RADIUS_M`]
/// at the step's speed.
pub(super) fn assert_turns_like_a_car(trajectory: &[AgentState]) {
    for (k, pair) in trajectory.windows(2).enumerate() {
        let turned_rad = crate::geometry::wrap_angle(pair[1].heading_rad - pair[0].heading_rad).abs();
        let travelled_m = pair[1].speed_mps() * SIM_DT_S;
        assert!(turned_rad <= travelled_m / MIN_TURN_RADIUS_M + 1e-12, "step {k}: {turned_rad} rad in {travelled_m} m");
    }
}

/// A car head-on from 40 m ahead at 10 m/s, from steps 0 to `horizon`.
pub(super) fn oncoming_car(horizon: usize) -> Vec<Vec<Option<AgentState>>> {
    states_over(horizon, |t| {
        let x = 40.0 - 10.0 * t;
        vec![
            None,
            Some(AgentState {
                position: Point2::new(x, 0.0),
                heading_rad: std::f64::consts::PI,
                velocity_mps: Vector2::new(-10.0, 0.0),
            }),
        ]
    })
}
