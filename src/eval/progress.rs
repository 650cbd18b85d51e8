//! Whether the ego got anywhere: a planner that stops dead in a free lane
//! collides with nothing and breaks no rule, so it passes every other
//! criterion. Progress is measured against the logged ego, the one route
//! every recorded and authored scene has: the distance the ego drove over
//! the rollout, as a share of the distance the logged ego drove over the
//! same steps. An ego that ends stopped behind an agent in its path is
//! blocked, not idle.

use crate::geometry::Vector2;
use crate::scenario::{AgentId, AgentState};
use crate::sim::Rollout;

/// Least distance the logged ego must drive over the rollout's steps for
/// progress to be measured, m: below it the log gives no route to follow
/// (a car waiting at a light), and any share of it is noise.
pub const MIN_LOGGED_ROUTE_M: f64 = 5.0;

/// How far ahead of its front an agent blocks the ego, m.
pub const BLOCKED_AHEAD_M: f64 = 10.0;

/// Speed below which the ego counts as stopped, m/s.
const STOPPED_MPS: f64 = 1.0;

/// Lateral room beyond the two half-widths within which an agent ahead is
/// in the ego's path, m.
const PATH_MARGIN_M: f64 = 0.5;

/// How far the ego got, against the logged ego over the same steps.
#[derive(Debug, Clone, PartialEq)]
pub struct Progress {
    /// Distance the ego drove, m.
    pub driven_m: f64,
    /// Distance the logged ego drove over the same steps, m.
    pub logged_m: f64,
    /// The agent the ego ended stopped behind, if any.
    pub blocked_by: Option<AgentId>,
}

impl Progress {
    /// The ego's distance as a share of the logged ego's.
    pub fn share(&self) -> f64 {
        self.driven_m / self.logged_m
    }
}

/// The ego's progress in `rollout` against `logged_ego` (the logged ego's
/// states, indexed by scene step), or `None` when the logged ego drove
/// under [`MIN_LOGGED_ROUTE_M`] over the rollout's steps.
pub fn progress(rollout: &Rollout, logged_ego: &[Option<AgentState>]) -> Option<Progress> {
    let ego = rollout.ego.0;
    let driven_m = path_length_m(rollout.states.iter().map(|row| row.get(ego).copied().flatten()));
    let steps = rollout.start_step..rollout.start_step + rollout.states.len();
    let logged_m = path_length_m(steps.map(|k| logged_ego.get(k).copied().flatten()));
    (logged_m >= MIN_LOGGED_ROUTE_M).then(|| Progress { driven_m, logged_m, blocked_by: blocked_by(rollout) })
}

/// Sum of the distances between consecutive present states.
fn path_length_m(states: impl Iterator<Item = Option<AgentState>>) -> f64 {
    let mut last: Option<AgentState> = None;
    let mut total = 0.0;
    for s in states.flatten() {
        if let Some(prev) = last {
            total += (s.position - prev.position).norm();
        }
        last = Some(s);
    }
    total
}

/// The agent in the ego's path within [`BLOCKED_AHEAD_M`] of its front
/// when the rollout ends with the ego stopped.
fn blocked_by(rollout: &Rollout) -> Option<AgentId> {
    let last = rollout.states.last()?;
    let ego = last.get(rollout.ego.0).copied().flatten()?;
    if ego.speed_mps() >= STOPPED_MPS {
        return None;
    }
    let body = &rollout.bodies[rollout.ego.0];
    let forward = Vector2::new(ego.heading_rad.cos(), ego.heading_rad.sin());
    let left = Vector2::new(-forward.y, forward.x);
    (0..last.len())
        .filter(|&i| i != rollout.ego.0)
        .filter_map(|i| Some((i, last[i]?)))
        .filter(|(i, other)| {
            let other_body = &rollout.bodies[*i];
            let offset = other.position - ego.position;
            let along = offset.dot(&forward) - 0.5 * (body.length_m + other_body.length_m);
            let across = offset.dot(&left).abs();
            (-0.5 * body.length_m..=BLOCKED_AHEAD_M).contains(&along)
                && across <= 0.5 * (body.width_m + other_body.width_m) + PATH_MARGIN_M
        })
        .min_by(|(_, a), (_, b)| (a.position - ego.position).norm().total_cmp(&(b.position - ego.position).norm()))
        .map(|(i, _)| rollout.agent_ids[i].clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point2;
    use crate::map::templates::StraightRoad;
    use crate::motion::Action;
    use crate::planners::{Observation, Planner, PlannerError, PlannerOutput};
    use crate::scenario::{AgentKind, Scenario, ScenarioSource, Track, TrackIndex};
    use crate::sim::{SimConfig, Simulation};

    /// Brakes at 8 m/s² to a standstill and stays there.
    struct StopDead;

    impl Planner for StopDead {
        fn name(&self) -> &str {
            "stop-dead"
        }
        fn plan(&mut self, o: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
            let accel_mps2 = if o.ego.speed_mps() > 0.0 { -8.0 } else { 0.0 };
            Ok(PlannerOutput::Control(Action { accel_mps2, yaw_rate_radps: 0.0 }))
        }
    }

    fn track(id: &str, states: Vec<Option<AgentState>>) -> Track {
        Track { id: AgentId(id.into()), kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0, states }
    }

    fn at(x: f64, speed: f64) -> Option<AgentState> {
        Some(AgentState { position: Point2::new(x, 1.75), heading_rad: 0.0, velocity_mps: Vector2::new(speed, 0.0) })
    }

    /// A 3 s scene whose logged ego drives 10 m/s from x = 10 (the
    /// rollout starts at step 0), with a car parked at `parked_x` if given.
    fn scene(parked_x: Option<f64>) -> Scenario {
        let map =
            StraightRoad { lanes: 1, oncoming_lanes: 0, lane_width_m: 3.5, length_m: 300.0, speed_limit_mps: None }
                .build();
        let mut tracks = vec![track("ego", (0..31).map(|k| at(10.0 + k as f64, 10.0)).collect())];
        if let Some(x) = parked_x {
            tracks.push(track("parked", vec![at(x, 0.0); 31]));
        }
        Scenario::new("progress", ScenarioSource::authored("test"), 0.1, map, tracks).with_roles(TrackIndex(0), None)
    }

    fn measured(parked_x: Option<f64>) -> Option<Progress> {
        let s = scene(parked_x);
        let rollout = Simulation::new(&s, SimConfig::default()).unwrap().run(&mut StopDead);
        progress(&rollout, &s.tracks[0].states)
    }

    #[test]
    fn an_ego_stopping_dead_in_a_free_lane_makes_little_progress_and_is_not_blocked() {
        let p = measured(None).expect("the logged ego drives 30 m");
        assert!((p.logged_m - 30.0).abs() < 1e-6, "{p:?}");
        // From 10 m/s at 8 m/s²: about 6.25 m.
        assert!(p.driven_m > 5.0 && p.driven_m < 8.0, "{p:?}");
        assert_eq!(p.blocked_by, None);
    }

    #[test]
    fn an_ego_stopped_behind_a_car_in_its_path_is_blocked() {
        // Parked 15 m ahead of the ego's centre: the ego stops about 3.5 m
        // behind its tail.
        let p = measured(Some(25.0)).expect("the logged ego drives 30 m");
        assert_eq!(p.blocked_by, Some(AgentId("parked".into())));
    }

    #[test]
    fn a_logged_ego_standing_still_gives_no_route_to_measure() {
        let mut s = scene(None);
        s.tracks[0].states = vec![at(10.0, 0.0); 31];
        let rollout = Simulation::new(&s, SimConfig::default()).unwrap().run(&mut StopDead);
        assert_eq!(progress(&rollout, &s.tracks[0].states), None);
    }
}
