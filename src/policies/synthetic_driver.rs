//! A synthetic road user that makes the lateral choices recorded urban
//! traffic makes: it turns left or right at junctions instead of always
//! going straight, changes lanes at will when the neighbour lane has room,
//! and accepts or refuses gaps in crossing traffic (an unprotected left
//! turn waits for the oncoming car, or does not). Speed control is IDM with
//! the [`AccelDisturbance`] of the noisy IDM driver.
//!
//! It makes the realism prior's training traffic: a next-token prior only
//! offers the steering its data shows, and lane-keeping drivers that go
//! straight through every junction teach it none.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::lane_follower::{build_route_choosing, idm_accel_mps2, pursuit_yaw_rate, route_along_lanes, route_leader};
use super::noisy_idm::{AccelDisturbance, DriverNoise};
use super::{AgentAction, AgentPolicy, IdmParams, Route, WorldView};
use crate::geometry::{Point2, Polyline, Vector2, wrap_angle};
use crate::map::Lane;
use crate::motion::Action;
use crate::motion::tokens::{MAX_ACCEL_MPS2, SIM_DT_S};
use crate::scenario::{AgentKind, AgentState, TrackIndex};

/// How far ahead on its route a driver looks for crossing conflicts, m.
const CONFLICT_LOOKAHEAD_M: f64 = 45.0;
/// Prediction horizon of crossing traffic (constant velocity), s.
const CONFLICT_HORIZON_S: f64 = 5.0;
/// Lateral distance from the route under which a predicted position is in conflict, m.
const CONFLICT_LATERAL_M: f64 = 2.5;
/// Least angle between the route and another agent's motion for a crossing (not following) conflict.
const CROSSING_MIN_ANGLE_RAD: f64 = 35.0 * std::f64::consts::PI / 180.0;
/// A route that turns by more than this within the look-ahead is a turning manoeuvre.
const TURN_MIN_ANGLE_RAD: f64 = 30.0 * std::f64::consts::PI / 180.0;
/// Time a driver leaves between itself and a pedestrian or cyclist crossing
/// its route: it goes first only when it clears the crossing this much
/// sooner, s (a bold turner that accepts no gap from cars still yields).
const PEDESTRIAN_MARGIN_S: f64 = 2.0;
/// Slowest speed at which another agent is still predicted to reach a conflict, m/s.
const MOVING_MIN_MPS: f64 = 1.0;
/// Slowest speed at which a lane change starts, m/s.
const LANE_CHANGE_MIN_SPEED_MPS: f64 = 3.0;
/// Shortest lane change, m.
const LANE_CHANGE_MIN_LENGTH_M: f64 = 15.0;
/// Least time between two lane changes of one driver, s.
const LANE_CHANGE_COOLDOWN_S: f64 = 4.0;

/// The choices one synthetic driver makes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriverChoices {
    /// Chance of leaving the straightest successor at a junction for one of
    /// the others (drawn uniformly), per junction.
    pub turn_probability: f64,
    /// Rate of starting a discretionary lane change while a neighbour lane
    /// going the same way has room, 1/s (tripled behind a slower leader).
    pub lane_change_rate_per_s: f64,
    /// Duration of a lane change, s.
    pub lane_change_duration_s: f64,
    /// Gap accepted in crossing traffic when turning, s: the driver yields
    /// to a crossing vehicle that reaches the conflict before it or less
    /// than this after it. Zero: it never yields when turning. Going
    /// straight, a driver yields only to one that gets there first.
    pub accepted_gap_s: f64,
    /// Seed of the junction and lane-change draws.
    pub seed: u64,
}

impl DriverChoices {
    /// The straightest successor (index 0) or, with the turn probability, one
    /// of the others: a fixed draw per (driver, lane), so rebuilding the
    /// route never changes a choice already made.
    fn successor(&self, from: &Lane, successors: &[&Lane]) -> usize {
        if successors.len() < 2 {
            return 0;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed ^ (from.id.0 as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        if rng.random::<f64>() < self.turn_probability { rng.random_range(1..successors.len()) } else { 0 }
    }
}

/// A lane change under way.
#[derive(Debug, Clone, Copy)]
struct LaneChange {
    /// Step at which it ends.
    until_step: usize,
}

/// IDM speed control with junction choices, lane changes and gap acceptance.
#[derive(Debug)]
pub struct SyntheticDriver {
    params: IdmParams,
    choices: DriverChoices,
    disturbance: AccelDisturbance,
    rng: ChaCha8Rng,
    route: Option<Route>,
    desired_speed_mps: Option<f64>,
    lane_change: Option<LaneChange>,
    next_lane_change_step: usize,
}

impl SyntheticDriver {
    /// A driver with IDM `params`, disturbance `noise` and `choices`.
    pub fn new(params: IdmParams, noise: DriverNoise, choices: DriverChoices) -> Self {
        Self {
            params,
            choices,
            disturbance: AccelDisturbance::new(noise),
            rng: ChaCha8Rng::seed_from_u64(choices.seed.wrapping_add(1)),
            route: None,
            desired_speed_mps: None,
            lane_change: None,
            next_lane_change_step: 0,
        }
    }

    /// The control for `agent`, or `None` when it is absent.
    fn control(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> Option<Action> {
        let state = *world.state(agent)?;
        if self.lane_change.is_some_and(|c| world.step >= c.until_step) {
            self.lane_change = None;
        }
        if self.lane_change.is_none() && Route::needs_rebuild(self.route.as_ref(), &state.position) {
            let choices = self.choices;
            let kind = world.body(agent).kind;
            self.route =
                Some(build_route_choosing(world.map, &state, kind, &mut |from, next| choices.successor(from, next)));
        }
        let speed = state.speed_mps();
        let mut here_s = self.route.as_ref()?.path.project(&state.position)?.arc_length_m;
        let mut leader = route_leader(world, agent, self.route.as_ref()?, here_s, &self.params);
        if self.maybe_change_lane(world, agent, &state, leader) {
            // A new path: where the driver is on it and what it brakes for there.
            here_s = self.route.as_ref()?.path.project(&state.position)?.arc_length_m;
            leader = route_leader(world, agent, self.route.as_ref()?, here_s, &self.params);
        }
        let route = self.route.as_ref()?;
        let v0 = *self.desired_speed_mps.get_or_insert_with(|| {
            route.desired_speed_mps(world.map, self.params.desired_speed_mps, speed, self.params.fallback_speed_mps)
        });
        let yaw_rate = pursuit_yaw_rate(route, here_s, &state, &self.params)?;
        if let Some(stop_gap) = self.yield_gap_m(world, agent, route, here_s)
            && leader.is_none_or(|(g, _)| stop_gap < g)
        {
            leader = Some((stop_gap, 0.0));
        }
        let accel = idm_accel_mps2(&self.params, speed, v0, leader) + self.disturbance.step();
        Some(Action { accel_mps2: accel.clamp(-MAX_ACCEL_MPS2, MAX_ACCEL_MPS2), yaw_rate_radps: yaw_rate })
    }

    /// Starts a lane change with the driver's rate when a neighbour lane
    /// going the same way has room beside and ahead; whether it did (the
    /// route is then the lane change's path).
    fn maybe_change_lane(
        &mut self,
        world: &WorldView<'_>,
        agent: TrackIndex,
        state: &AgentState,
        leader: Option<(f64, f64)>,
    ) -> bool {
        let speed = state.speed_mps();
        if self.lane_change.is_some() || world.step < self.next_lane_change_step || speed < LANE_CHANGE_MIN_SPEED_MPS {
            return false;
        }
        let slow_leader = leader.is_some_and(|(gap, v)| gap < 40.0 && v < 0.85 * speed.max(1.0));
        let rate = self.choices.lane_change_rate_per_s * if slow_leader { 3.0 } else { 1.0 };
        if self.rng.random::<f64>() >= rate * SIM_DT_S {
            return false;
        }
        let map = world.map;
        let Some(m) = map.nearest_lane(&state.position, Some(state.heading_rad), 2.5) else { return false };
        let lane = &map.lanes[m.lane_index];
        if lane.in_intersection {
            return false;
        }
        let mut sides: Vec<&Lane> = lane
            .left_neighbours
            .iter()
            .chain(&lane.right_neighbours)
            .filter_map(|id| map.lane(*id))
            .filter(|l| !l.in_intersection)
            .collect();
        if sides.is_empty() {
            return false;
        }
        let target = sides.swap_remove(self.rng.random_range(0..sides.len()));
        let Some(on_target) = target.centreline.project(&state.position) else { return false };
        // Same direction, beside the driver (not past the neighbour's end).
        if target.centreline.tangent_dot(&on_target, state.heading_rad) < 0.9 || on_target.distance_m > 6.0 {
            return false;
        }
        let length = (speed * self.choices.lane_change_duration_s).max(LANE_CHANGE_MIN_LENGTH_M);
        if !target_lane_has_room(world, agent, target, on_target.arc_length_m, speed) {
            return false;
        }
        let choices = self.choices;
        let Some(after) =
            route_along_lanes(map, target, on_target.arc_length_m, &mut |from, next| choices.successor(from, next))
        else {
            return false;
        };
        if after.path.length_m() < length + 20.0 {
            return false;
        }
        let Some(current) = self.route.as_ref() else { return false };
        let Some(here) = current.path.project(&state.position) else { return false };
        self.route = Some(blended_route(current, here.arc_length_m, &after, state, length));
        let duration_steps = (length / speed / SIM_DT_S).ceil() as usize;
        self.lane_change = Some(LaneChange { until_step: world.step + duration_steps });
        self.next_lane_change_step = world.step + duration_steps + (LANE_CHANGE_COOLDOWN_S / SIM_DT_S) as usize;
        true
    }

    /// Gap to the point where the driver stops to yield to crossing
    /// traffic, m, or `None` when it goes.
    fn yield_gap_m(&self, world: &WorldView<'_>, agent: TrackIndex, route: &Route, here_s: f64) -> Option<f64> {
        let state = world.state(agent)?;
        let body = world.body(agent);
        let map = world.map;
        let ahead_end = here_s + CONFLICT_LOOKAHEAD_M;
        // Where the junction on the route ahead begins (its stop line). Away
        // from junctions only people on foot or on a bicycle cross the route.
        let junction_start = route
            .lanes
            .iter()
            .find(|&&(id, start, end)| {
                end > here_s && start < ahead_end && map.lane(id).is_some_and(|l| l.in_intersection)
            })
            .map(|&(_, start, _)| start);
        let turning = {
            let (_, d0) = route.path.sample(here_s)?;
            let (_, d1) = route.path.sample(ahead_end)?;
            wrap_angle(d1.y.atan2(d1.x) - d0.y.atan2(d0.x)).abs() > TURN_MIN_ANGLE_RAD
        };
        let refuses_gaps = turning && self.choices.accepted_gap_s <= 0.0;
        let my_speed = state.speed_mps().max(2.0);
        let mut stop: Option<f64> = None;
        for (j, other) in world.states.iter().enumerate() {
            let Some(other) = other else { continue };
            let v = other.velocity_mps;
            if j == agent.0 || v.norm() < MOVING_MIN_MPS || (other.position - state.position).norm() > 80.0 {
                continue;
            }
            let vulnerable = world.bodies[j].kind != AgentKind::Vehicle;
            if !vulnerable && (junction_start.is_none() || refuses_gaps) {
                continue;
            }
            // The other's first predicted position on the route ahead, crossing it.
            let hit = (1..=(CONFLICT_HORIZON_S / 0.5) as usize).find_map(|k| {
                let t = k as f64 * 0.5;
                let p = route.path.project(&(other.position + v * t))?;
                let ahead = p.arc_length_m - here_s;
                let crossing = v.normalize().dot(&p.tangent) < CROSSING_MIN_ANGLE_RAD.cos();
                (p.distance_m < CONFLICT_LATERAL_M && ahead > 0.0 && ahead < CONFLICT_LOOKAHEAD_M && crossing)
                    .then_some((ahead, t))
            });
            let Some((ahead, t_other)) = hit else { continue };
            // Already in the conflict area: clear it rather than stop in it.
            if ahead < 0.5 * body.length_m + 2.0 {
                continue;
            }
            let t_me = ahead / my_speed;
            let margin = if vulnerable {
                PEDESTRIAN_MARGIN_S
            } else if turning {
                self.choices.accepted_gap_s
            } else {
                0.0
            };
            if t_other < t_me + margin {
                // Wait at the stop line while still before it, else short of the conflict.
                let to_line = junction_start.map_or(f64::NEG_INFINITY, |start| start - here_s - 0.5 * body.length_m);
                let short_of_conflict = ahead - 0.5 * body.length_m - CONFLICT_LATERAL_M;
                // A person may cross before the stop line (a crosswalk on the way in).
                let gap = match (to_line > 0.0, vulnerable) {
                    (true, false) => to_line,
                    (true, true) => to_line.min(short_of_conflict),
                    (false, _) => short_of_conflict,
                };
                stop = Some(stop.map_or(gap, |g: f64| g.min(gap)));
            }
        }
        stop.map(|g| g.max(0.1))
    }
}

/// Whether the neighbour `lane` has room for the driver beside it: no
/// other agent on it within a speed-dependent window behind and ahead of
/// arc length `beside_s`.
fn target_lane_has_room(world: &WorldView<'_>, agent: TrackIndex, lane: &Lane, beside_s: f64, speed_mps: f64) -> bool {
    let behind = 8.0 + 1.2 * speed_mps;
    let ahead = 8.0 + 0.8 * speed_mps;
    world.states.iter().enumerate().all(|(j, other)| {
        let Some(other) = other else { return true };
        if j == agent.0 {
            return true;
        }
        let Some(p) = lane.centreline.project(&other.position) else { return true };
        let ds = p.arc_length_m - beside_s;
        p.distance_m > 2.0 || ds < -behind || ds > ahead
    })
}

/// The path of a lane change: from arc `here_s` of `current`, a smoothstep
/// blend into `after` (which starts beside the driver) over `length_m`,
/// then `after`; a point behind the driver keeps projections off the start.
fn blended_route(current: &Route, here_s: f64, after: &Route, state: &AgentState, length_m: f64) -> Route {
    const BLEND_POINTS: usize = 20;
    let back = Vector2::new(state.heading_rad.cos(), state.heading_rad.sin()) * -5.0;
    let mut points: Vec<Point2> = vec![state.position + back];
    for k in 0..=BLEND_POINTS {
        let u = k as f64 / BLEND_POINTS as f64;
        let w = u * u * (3.0 - 2.0 * u);
        let (Some((a, _)), Some((b, _))) =
            (current.path.sample(here_s + u * length_m), after.path.sample(u * length_m))
        else {
            continue;
        };
        points.push(Point2::from(a.coords * (1.0 - w) + b.coords * w));
    }
    let mut acc = 0.0;
    for w in after.path.points().windows(2) {
        acc += (w[1] - w[0]).norm();
        if acc > length_m + 0.5 {
            points.push(w[1]);
        }
    }
    // The blend is about as long as the stretch of `after` it replaces, and
    // the point behind adds 5 m: lane arcs shift by that much.
    let lanes = after.lanes.iter().map(|&(id, s0, s1)| (id, s0 + 5.0, s1 + 5.0)).collect();
    Route { path: Polyline::new(points), lanes }
}

impl AgentPolicy for SyntheticDriver {
    fn name(&self) -> &'static str {
        "synthetic-driver"
    }

    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
        AgentAction::from_control(world, agent, self.control(world, agent))
    }
}
