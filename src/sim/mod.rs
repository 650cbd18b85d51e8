//! The closed-loop engine: steps a scenario at 0.1 s with every background
//! agent driven by its policy and the ego by a planner, detects collisions
//! (oriented boxes) and off-road events, and records the rollout.
//!
//! A rollout is a pure function of the scenario, the planner, the policies
//! and the configuration: agents are updated in track order, every query
//! iterates in index order, and nothing reads a clock or a global RNG.

pub mod authoring;
mod events;
mod rollout;
pub mod synthetic;
pub mod traffic;

pub use crate::motion::vehicle_limits::{LimitMonitor, LimitViolation, VehicleLimits};
pub use events::{CollisionEvent, EgoCollisionKind, EgoContact, LaneOccupancy, OffRoadEvent};
pub use rollout::{PlannerDebug, Rollout, RolloutSummary, Termination};

use crate::motion::{KinematicState, kinematic_step, tokens::SIM_DT_S};
use crate::planners::{EgoMotion, Goal, Horizon, Observation, PerceivedAgent, Planner, Route};
use crate::policies::{AgentAction, AgentPolicy, BackgroundPolicy, WorldView};
use crate::scenario::{AgentBody, AgentState, Scenario, TrackIndex};

/// Largest length or width of a simulated agent's box, m (the scenario
/// layer's bound, which importers already hold recorded boxes to).
pub use crate::scenario::bounds::MAX_BODY_M;

/// Relative difference between a scenario's step and the simulator's that is accepted.
pub const DT_TOLERANCE: f64 = 0.025;

/// How a rollout is set up.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// First step; `None` = the scenario's current step.
    pub start_step: Option<usize>,
    /// Last step (inclusive); `None` = the scenario's last step.
    pub end_step: Option<usize>,
    /// Policy for background agents present at the start. Agents that
    /// appear later in the log are always replayed.
    pub background: BackgroundPolicy,
    /// Perception range of the ego: agents farther than this are not in
    /// its observation, m.
    pub perception_range_m: f64,
    /// Stop at the ego's first collision (stage-1/2 evaluation needs only
    /// the first one).
    pub stop_on_ego_collision: bool,
    /// The limits the ego's motion is held to at every step (the planner
    /// under test); `None`: unchecked (a replayed log is what it is).
    pub ego_limits: Option<VehicleLimits>,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            start_step: None,
            end_step: None,
            background: BackgroundPolicy::LogReplay,
            perception_range_m: 120.0,
            stop_on_ego_collision: false,
            ego_limits: None,
        }
    }
}

/// Why a rollout could not be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The scenario has no ego.
    #[error("scenario {0} has no ego: the source names none and conflict mining found no pair of moving vehicles")]
    NoEgo(String),
    /// The ego is not valid at the start step.
    #[error("scenario {scenario}: the ego ({ego}) has no valid state at start step {step}")]
    EgoAbsentAtStart {
        /// Scenario id.
        scenario: String,
        /// Ego id.
        ego: String,
        /// Start step.
        step: usize,
    },
    /// The scenario's step is not the simulator's.
    #[error("scenario {scenario} has steps of {dt_s} s; the simulator steps at {SIM_DT_S} s (±2.5%)")]
    StepMismatch {
        /// Scenario id.
        scenario: String,
        /// Its step, s.
        dt_s: f64,
    },
    /// Start/end steps outside the scenario.
    #[error("scenario {scenario}: steps {start}..={end} are outside its {steps} steps")]
    BadRange {
        /// Scenario id.
        scenario: String,
        /// Start.
        start: usize,
        /// End.
        end: usize,
        /// Steps in the scenario.
        steps: usize,
    },
}

/// One closed-loop run of a scenario.
pub struct Simulation<'a> {
    scenario: &'a Scenario,
    config: SimConfig,
    ego: TrackIndex,
    policies: Vec<Option<Box<dyn AgentPolicy>>>,
}

impl<'a> Simulation<'a> {
    /// Sets up a run with the configured background policy for every
    /// non-ego agent present at the start.
    pub fn new(scenario: &'a Scenario, config: SimConfig) -> Result<Self, SimError> {
        let ego = scenario.ego.ok_or_else(|| SimError::NoEgo(scenario.id.clone()))?;
        // Recorded timestamps jitter (WOMD: 0.1000004 s, 0.10024 s); log
        // replay is by step index, so a small mismatch is harmless.
        if (scenario.dt_s - SIM_DT_S).abs() > DT_TOLERANCE * SIM_DT_S {
            return Err(SimError::StepMismatch { scenario: scenario.id.clone(), dt_s: scenario.dt_s });
        }
        let start = config.start_step.unwrap_or(scenario.current_step);
        let end = config.end_step.unwrap_or(scenario.num_steps().saturating_sub(1));
        if start >= end || end >= scenario.num_steps() {
            return Err(SimError::BadRange { scenario: scenario.id.clone(), start, end, steps: scenario.num_steps() });
        }
        if scenario.track(ego).state(start).is_none() {
            return Err(SimError::EgoAbsentAtStart {
                scenario: scenario.id.clone(),
                ego: scenario.track(ego).id.to_string(),
                step: start,
            });
        }
        let policies = (0..scenario.tracks.len())
            .map(|i| {
                let agent = TrackIndex(i);
                (agent != ego).then(|| {
                    let present = scenario.track(agent).state(start).is_some();
                    let policy = if present { config.background } else { config.background.for_late_entrant() };
                    policy.instantiate(scenario, agent)
                })
            })
            .collect();
        Ok(Self { scenario, config, ego, policies })
    }

    /// Replaces the policy of one background agent (e.g. the CBV's adversary).
    pub fn set_policy(&mut self, agent: TrackIndex, policy: Box<dyn AgentPolicy>) {
        if agent != self.ego {
            self.policies[agent.0] = Some(policy);
        }
    }

    /// Runs to the end step (or the ego's first collision, if configured).
    pub fn run(mut self, planner: &mut dyn Planner) -> Rollout {
        let scenario = self.scenario;
        let start = self.config.start_step.unwrap_or(scenario.current_step);
        let end = self.config.end_step.unwrap_or(scenario.num_steps() - 1);
        let bodies: Vec<AgentBody> = scenario.tracks.iter().map(|t| t.body()).collect();
        let mut states: Vec<Option<AgentState>> = scenario.tracks.iter().map(|t| t.state(start).copied()).collect();
        // Recorded starts are validated at import; this keeps hand-built
        // scenarios from feeding nonsense to the event detector as well.
        if let Some((agent, reason)) = self.first_invalid(&states) {
            // Nothing is simulated; the record keeps only the valid agents.
            let valid =
                states.iter().map(|s| s.filter(|s| crate::scenario::bounds::implausibility(s).is_none())).collect();
            return Rollout {
                scenario_id: scenario.id.clone(),
                dt_s: SIM_DT_S,
                start_step: start,
                ego: self.ego,
                cbv: scenario.cbv,
                agent_ids: scenario.tracks.iter().map(|t| t.id.clone()).collect(),
                bodies,
                states: vec![valid],
                collisions: Vec::new(),
                off_road: Vec::new(),
                min_distance_to_ego: None,
                termination: Termination::InvalidAgentState { step: start, agent, reason },
                planner: planner.name().to_string(),
                planner_debug: Vec::new(),
            };
        }
        let mut detector = events::EventDetector::new(scenario, self.ego, &bodies, &states, start);
        let mut record = vec![states.clone()];
        let mut termination = Termination::Completed;

        let mut limits = self.config.ego_limits.map(|l| (l, LimitMonitor::new(l)));
        // The ego's route, as external planners are sent it (the recording guides it at forks).
        let mut route = RouteState {
            route: std::sync::Arc::new(Route::default()),
            recorded: crate::planners::route::recorded_path(scenario, self.ego, start),
            horizon: Horizon::new(start, end, SIM_DT_S),
            goal: Goal::recorded(scenario, self.ego),
        };
        // The ego's state a step earlier, for its acceleration and yaw rate:
        // the recording's before the start, the simulated one after.
        let mut previous_ego = start.checked_sub(1).and_then(|k| scenario.track(self.ego).state(k).copied());
        let mut planner_debug = Vec::new();
        for step in start..end {
            let world = WorldView { map: &scenario.map, step, bodies: &bodies, states: &states };
            let actions: Vec<AgentAction> = self
                .policies
                .iter_mut()
                .enumerate()
                .map(|(i, p)| match p {
                    Some(p) => p.act(&world, TrackIndex(i)),
                    None => AgentAction::Absent,
                })
                .collect();
            let observation = self.observe(step, start, &bodies, &states, previous_ego.as_ref(), &mut route);
            let mut sent_control = None;
            let planned = planner.plan(&observation);
            if let Some(debug) = planner.take_debug() {
                planner_debug.push(PlannerDebug { step, debug });
            }
            let ego_next = planned.map_err(|e| e.to_string()).and_then(|out| {
                let ego_now = states[self.ego.0].expect("ego present while running");
                if let crate::planners::PlannerOutput::Control(action) = &out {
                    sent_control = Some(*action);
                }
                out.next_state(&ego_now, SIM_DT_S)
            });
            let mut next = advance(&states, &actions);
            let ego_next = ego_next.and_then(|s| match crate::scenario::bounds::implausibility(&s) {
                None => Ok(s),
                Some(why) => Err(format!("the planner's output puts the ego at an invalid state: {why}")),
            });
            match ego_next {
                Ok(s) => {
                    let ego_now = states[self.ego.0].expect("ego present while running");
                    let violation = limits.as_mut().and_then(|(l, monitor)| {
                        sent_control.and_then(|a| l.check_control(&a)).or_else(|| monitor.step(&ego_now, &s, SIM_DT_S))
                    });
                    if let Some(violation) = violation {
                        termination = Termination::VehicleLimitExceeded { step, reason: violation.to_string() };
                        break;
                    }
                    next[self.ego.0] = Some(s)
                }
                Err(reason) => {
                    termination = Termination::PlannerFailed { step, reason };
                    break;
                }
            }
            if let Some((agent, reason)) = self.first_invalid(&next) {
                termination = Termination::InvalidAgentState { step: step + 1, agent, reason };
                break;
            }
            previous_ego = states[self.ego.0];
            states = next;
            record.push(states.clone());
            let collided = detector.observe(step + 1, &states);
            if collided && self.config.stop_on_ego_collision {
                termination = Termination::EgoCollision { step: step + 1 };
                break;
            }
            if let Some(left) = detector.left_mapped_area() {
                termination = Termination::LeftMappedArea { step: left };
                break;
            }
        }
        let (collisions, off_road, min_distance) = detector.finish();
        Rollout {
            scenario_id: scenario.id.clone(),
            dt_s: SIM_DT_S,
            start_step: start,
            ego: self.ego,
            cbv: scenario.cbv,
            agent_ids: scenario.tracks.iter().map(|t| t.id.clone()).collect(),
            bodies,
            states: record,
            collisions,
            off_road,
            min_distance_to_ego: min_distance,
            termination,
            planner: planner.name().to_string(),
            planner_debug,
        }
    }

    /// The first agent (in track order) whose state is implausible, with why.
    /// A present agent's box must be finite, positive and at most
    /// [`MAX_BODY_M`] on each side too: the box–box queries assume it.
    fn first_invalid(&self, states: &[Option<AgentState>]) -> Option<(crate::scenario::AgentId, String)> {
        states.iter().enumerate().find_map(|(i, s)| {
            let track = &self.scenario.tracks[i];
            let why = crate::scenario::bounds::implausibility(s.as_ref()?).or_else(|| {
                let sides = [("length", track.length_m), ("width", track.width_m)];
                sides.into_iter().find(|(_, v)| !(*v > 0.0 && *v <= MAX_BODY_M)).map(|(name, v)| {
                    format!(
                        "{name} = {} m is outside the simulation bounds (0, {} m]",
                        crate::number::shown(v),
                        crate::number::shown(MAX_BODY_M)
                    )
                })
            })?;
            Some((track.id.clone(), why))
        })
    }

    fn observe<'m>(
        &self,
        step: usize,
        start: usize,
        bodies: &[AgentBody],
        states: &[Option<AgentState>],
        previous_ego: Option<&AgentState>,
        route: &mut RouteState,
    ) -> Observation<'m>
    where
        'a: 'm,
    {
        let ego = states[self.ego.0].expect("ego present while running");
        let range2 = self.config.perception_range_m.powi(2);
        let agents = states
            .iter()
            .enumerate()
            .filter(|&(i, _)| i != self.ego.0)
            .filter_map(|(i, s)| s.map(|s| (i, s)))
            .filter(|(_, s)| (s.position - ego.position).norm_squared() <= range2)
            .map(|(i, state)| PerceivedAgent {
                id: self.scenario.tracks[i].id.clone(),
                kind: bodies[i].kind,
                length_m: bodies[i].length_m,
                width_m: bodies[i].width_m,
                state,
            })
            .collect();
        let signals = self
            .scenario
            .map
            .traffic_signals
            .iter()
            .filter_map(|s| s.states.get(step).map(|st| (s.lane, *st)))
            .collect();
        let ego_body = bodies[self.ego.0];
        // The previous step's observation is gone: no copy of the route is made.
        let s = std::sync::Arc::make_mut(&mut route.route).update(&self.scenario.map, &ego, &route.recorded);
        let route_s_m = (!route.route.is_empty()).then_some(s);
        let motion = EgoMotion::between(previous_ego, &ego, SIM_DT_S);
        Observation {
            route: route.route.clone(),
            route_s_m,
            horizon: Some(route.horizon),
            goal: route.goal,
            step,
            time_s: (step - start) as f64 * SIM_DT_S,
            dt_s: SIM_DT_S,
            ego,
            ego_accel_mps2: motion.accel_mps2,
            ego_yaw_rate_radps: motion.yaw_rate_radps,
            ego_length_m: ego_body.length_m,
            ego_width_m: ego_body.width_m,
            agents,
            map: &self.scenario.map,
            signals,
        }
    }
}

/// What a rollout's observations tell of the ego's route and task.
struct RouteState {
    route: std::sync::Arc<Route>,
    /// The ego's recorded positions from the start (the route's guide at forks).
    recorded: Vec<crate::geometry::Point2>,
    horizon: Horizon,
    goal: Option<Goal>,
}

/// Every agent's state one step later under its action.
pub fn advance(states: &[Option<AgentState>], actions: &[AgentAction]) -> Vec<Option<AgentState>> {
    states
        .iter()
        .zip(actions)
        .map(|(now, action)| match (action, now) {
            (AgentAction::Teleport(s), _) => Some(*s),
            (AgentAction::Control(a), Some(now)) => {
                Some(kinematic_step(&KinematicState::from_agent_state(now), *a, SIM_DT_S).to_agent_state())
            }
            (AgentAction::Control(_), None) | (AgentAction::Absent, _) => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Polyline, Vector2};
    use crate::map::{Lane, MapElementId, RoadEdge, RoadEdgeKind, RoadMap};
    use crate::planners::{BuiltinPlanner, PlannerOutput};
    use crate::scenario::{AgentId, AgentKind, ScenarioSource, Track};

    /// A 300 m straight road; the ego at x=0 doing 12 m/s, a car stopped at
    /// x=60 in the same lane (recorded as stopped throughout), 121 steps.
    fn stopped_car_ahead() -> Scenario {
        let straight = |y0: f64, x0: f64, x1: f64| Polyline::new(vec![Point2::new(x0, y0), Point2::new(x1, y0)]);
        let lane = Lane::new(MapElementId(1), straight(0.0, -50.0, 300.0));
        let edges = vec![
            RoadEdge { id: MapElementId(2), polyline: straight(-2.0, -50.0, 300.0), kind: RoadEdgeKind::Boundary },
            RoadEdge { id: MapElementId(3), polyline: straight(2.0, 300.0, -50.0), kind: RoadEdgeKind::Boundary },
        ];
        let map = RoadMap::new(vec![lane], edges, vec![], vec![], vec![], vec![], vec![]);
        let track = |id: &str, x0: f64, v: f64| Track {
            id: AgentId(id.into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            states: (0..121)
                .map(|k| {
                    Some(AgentState {
                        position: Point2::new(x0 + v * 0.1 * k as f64, 0.0),
                        heading_rad: 0.0,
                        velocity_mps: Vector2::new(v, 0.0),
                    })
                })
                .collect(),
        };
        Scenario::new(
            "stopped-car-ahead",
            ScenarioSource::authored("test"),
            0.1,
            map,
            vec![track("ego", 0.0, 12.0), track("stopped", 60.0, 0.0)],
        )
        .with_roles(TrackIndex(0), Some(TrackIndex(1)))
    }

    fn run(planner: BuiltinPlanner) -> Rollout {
        let s = stopped_car_ahead();
        let mut p = planner.instantiate(&s, TrackIndex(0));
        Simulation::new(&s, SimConfig::default()).unwrap().run(p.as_mut())
    }

    /// A 350 m road (lane, edges and drivable area from x = -50 to 300, as a
    /// CommonRoad map cut off at the end of its recording); the ego alone at
    /// x = 250 doing 12 m/s, heading `heading_rad`.
    fn road_that_ends(heading_rad: f64) -> Scenario {
        let straight = |y0: f64, x0: f64, x1: f64| Polyline::new(vec![Point2::new(x0, y0), Point2::new(x1, y0)]);
        let lane = Lane::new(MapElementId(1), straight(0.0, -50.0, 300.0));
        let edges = vec![
            RoadEdge { id: MapElementId(2), polyline: straight(-2.0, -50.0, 300.0), kind: RoadEdgeKind::Boundary },
            RoadEdge { id: MapElementId(3), polyline: straight(2.0, 300.0, -50.0), kind: RoadEdgeKind::Boundary },
        ];
        let area = crate::geometry::Polygon::new(vec![
            Point2::new(-50.0, -2.0),
            Point2::new(300.0, -2.0),
            Point2::new(300.0, 2.0),
            Point2::new(-50.0, 2.0),
        ]);
        let map = RoadMap::new(vec![lane], edges, vec![], vec![], vec![area], vec![], vec![]);
        let v = Vector2::new(heading_rad.cos(), heading_rad.sin()) * 12.0;
        let ego = Track {
            id: AgentId("ego".into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            states: (0..81)
                .map(|k| {
                    Some(AgentState {
                        position: Point2::new(250.0, 0.0) + v * 0.1 * k as f64,
                        heading_rad,
                        velocity_mps: v,
                    })
                })
                .collect(),
        };
        Scenario::new("road-that-ends", ScenarioSource::authored("test"), 0.1, map, vec![ego])
            .with_roles(TrackIndex(0), None)
    }

    /// Drives on at constant speed and notes what each observation says
    /// of the route, the leader, the horizon and the goal.
    #[derive(Default)]
    struct RouteWatcher {
        seen: Vec<Seen>,
    }

    /// The ego's place on the route, its revision, the leader's gap, the horizon and the goal.
    type Seen = (Option<f64>, u32, Option<f64>, Option<crate::planners::Horizon>, Option<crate::planners::Goal>);

    impl Planner for RouteWatcher {
        fn name(&self) -> &str {
            "route-watcher"
        }
        fn plan(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, crate::planners::PlannerError> {
            let gap = obs.leader().map(|l| l.gap_m);
            self.seen.push((obs.route_s_m, obs.route.revision(), gap, obs.horizon, obs.goal));
            Ok(PlannerOutput::Control(crate::motion::Action::default()))
        }
    }

    #[test]
    fn observations_carry_the_route_with_the_ego_advancing_on_it_the_leader_horizon_and_goal() {
        let s = stopped_car_ahead();
        let mut watcher = RouteWatcher::default();
        let config = SimConfig { end_step: Some(20), ..SimConfig::default() };
        Simulation::new(&s, config).unwrap().run(&mut watcher);
        assert_eq!(watcher.seen.len(), 20);
        for (k, (s_m, revision, gap, horizon, goal)) in watcher.seen.iter().enumerate() {
            // 12 m/s: 1.2 m a step along the route planned at the start.
            let expected = ROUTE_BEHIND + 1.2 * k as f64;
            assert!((s_m.unwrap() - expected).abs() < 1e-6, "step {k}: {s_m:?}, not {expected}");
            assert_eq!(*revision, 0, "step {k}");
            // The stopped car 60 m ahead of the start; 4.5 m cars.
            let expected_gap = 60.0 - 1.2 * k as f64 - 4.5;
            assert!((gap.unwrap() - expected_gap).abs() < 1e-6, "step {k}: {gap:?}");
            let horizon = horizon.unwrap();
            assert_eq!((horizon.start_step, horizon.end_step, horizon.steps()), (0, 20, 20));
            let goal = goal.unwrap();
            assert_eq!(goal.step, 120);
            assert!((goal.state.position.x - 144.0).abs() < 1e-9);
        }
    }

    const ROUTE_BEHIND: f64 = crate::planners::route::ROUTE_BEHIND_M;

    /// Records the ego's acceleration and yaw rate it is shown; turns left
    /// while braking.
    #[derive(Default)]
    struct MotionWatcher {
        seen: Vec<(f64, f64)>,
    }

    impl Planner for MotionWatcher {
        fn name(&self) -> &str {
            "motion-watcher"
        }
        fn plan(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, crate::planners::PlannerError> {
            self.seen.push((obs.ego_accel_mps2, obs.ego_yaw_rate_radps));
            Ok(PlannerOutput::Control(crate::motion::Action { accel_mps2: -2.0, yaw_rate_radps: 0.1 }))
        }
    }

    #[test]
    fn the_ego_motion_is_the_recordings_at_the_start_then_the_controls_applied() {
        let mut s = stopped_car_ahead();
        // Recorded: 11 m/s heading -0.01 rad at step 4, 12 m/s heading 0 at step 5.
        let before = s.tracks[0].states[4].as_mut().unwrap();
        before.heading_rad = -0.01;
        before.velocity_mps = Vector2::new(11.0 * 0.01f64.cos(), -11.0 * 0.01f64.sin());
        let mut watcher = MotionWatcher::default();
        let config = SimConfig { start_step: Some(5), end_step: Some(15), ..SimConfig::default() };
        Simulation::new(&s, config).unwrap().run(&mut watcher);
        assert_eq!(watcher.seen.len(), 10);
        let (accel, yaw_rate) = watcher.seen[0];
        assert!((accel - 10.0).abs() < 1e-9 && (yaw_rate - 0.1).abs() < 1e-9, "{:?}", watcher.seen[0]);
        for (k, &(accel, yaw_rate)) in watcher.seen.iter().enumerate().skip(1) {
            assert!((accel + 2.0).abs() < 1e-9 && (yaw_rate - 0.1).abs() < 1e-9, "step {k}: {accel}, {yaw_rate}");
        }
        // From step 0 there is no state before: nothing is made up.
        let mut watcher = MotionWatcher::default();
        Simulation::new(&s, SimConfig { end_step: Some(3), ..SimConfig::default() }).unwrap().run(&mut watcher);
        assert_eq!(watcher.seen[0], (0.0, 0.0));
    }

    fn run_constant_velocity(s: &Scenario) -> Rollout {
        let mut p = BuiltinPlanner::ConstantVelocity.instantiate(s, TrackIndex(0));
        Simulation::new(s, SimConfig::default()).unwrap().run(p.as_mut())
    }

    #[test]
    fn driving_past_the_end_of_the_map_ends_the_rollout_and_is_not_off_road() {
        let r = run_constant_velocity(&road_that_ends(0.0));
        // The front corners pass x = 300 at step 40 (250 + 1.2 k + 2.25 > 300).
        assert_eq!(r.termination, Termination::LeftMappedArea { step: 40 });
        assert!(r.off_road.is_empty(), "{:?}", r.off_road);
        assert_eq!(r.summary().ego_off_road_s, None);
        assert_eq!(r.states.len(), 41, "nothing is simulated past the map");
    }

    /// [`road_that_ends`] with the ego moved `dy` sideways (towards +y).
    /// A lane (y in 0..4) that ends where the map does, at x = 300, its
    /// upper kerb stopping 10 m short; beside it, 0.3 m away, a ramp
    /// (y in 4.3..8) whose kerb goes on to x = 400. The ego drives along the
    /// lane's upper half at 12 m/s, straight off its end: the road edge
    /// nearest to its corner past the end is the ramp's, which does not end
    /// there.
    fn lane_that_ends_beside_a_ramp() -> Scenario {
        let straight = |y0: f64, x0: f64, x1: f64| Polyline::new(vec![Point2::new(x0, y0), Point2::new(x1, y0)]);
        let lane = Lane {
            left_boundary: Some(straight(4.0, -50.0, 300.0)),
            right_boundary: Some(straight(0.0, -50.0, 300.0)),
            ..Lane::new(MapElementId(1), straight(2.0, -50.0, 300.0))
        };
        let ramp = Lane {
            left_boundary: Some(straight(8.0, -50.0, 400.0)),
            right_boundary: Some(straight(4.3, -50.0, 400.0)),
            ..Lane::new(MapElementId(2), straight(6.15, -50.0, 400.0))
        };
        let edges = vec![
            RoadEdge { id: MapElementId(3), polyline: straight(0.0, -50.0, 300.0), kind: RoadEdgeKind::Boundary },
            RoadEdge { id: MapElementId(4), polyline: straight(4.0, 290.0, -50.0), kind: RoadEdgeKind::Boundary },
            RoadEdge { id: MapElementId(5), polyline: straight(4.3, -50.0, 400.0), kind: RoadEdgeKind::Boundary },
            RoadEdge { id: MapElementId(6), polyline: straight(8.0, 400.0, -50.0), kind: RoadEdgeKind::Boundary },
        ];
        let rect = |x0: f64, x1: f64, y0: f64, y1: f64| {
            crate::geometry::Polygon::new(vec![
                Point2::new(x0, y0),
                Point2::new(x1, y0),
                Point2::new(x1, y1),
                Point2::new(x0, y1),
            ])
        };
        let areas = vec![rect(-50.0, 300.0, 0.0, 4.0), rect(-50.0, 400.0, 4.3, 8.0)];
        let map = RoadMap::new(vec![lane, ramp], edges, vec![], vec![], areas, vec![], vec![]);
        let ego = Track {
            id: AgentId("ego".into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            states: (0..101)
                .map(|k| {
                    Some(AgentState {
                        position: Point2::new(250.0 + 1.2 * k as f64, 2.9),
                        heading_rad: 0.0,
                        velocity_mps: Vector2::new(12.0, 0.0),
                    })
                })
                .collect(),
        };
        Scenario::new("lane-that-ends-beside-a-ramp", ScenarioSource::authored("test"), 0.1, map, vec![ego])
            .with_roles(TrackIndex(0), None)
    }

    #[test]
    fn driving_off_the_end_of_a_lane_beside_a_ramp_leaves_the_map_in_every_mode() {
        let s = lane_that_ends_beside_a_ramp();
        // The ego's front corner past the end: the nearest edge is the ramp's.
        let corner = Point2::new(301.0, 3.9);
        assert!(s.map.is_past_mapped_end(&corner), "past the lane's end, in its corridor");
        // A kerb still counts: beside the lane, before its end, or across the ramp's kerb.
        assert!(!s.map.is_past_mapped_end(&Point2::new(250.0, -0.5)));
        assert!(!s.map.is_past_mapped_end(&Point2::new(301.0, 4.6)), "on the ramp, not past the map");
        // Log replay, a closed-loop planner, and the rollouts stage 1 and
        // stage 2 play (the same simulator): all end where the ego leaves.
        let mut ends = Vec::new();
        for planner in [BuiltinPlanner::LogReplay, BuiltinPlanner::ConstantVelocity, BuiltinPlanner::Idm] {
            let mut p = planner.instantiate(&s, TrackIndex(0));
            let r = Simulation::new(&s, SimConfig::default()).unwrap().run(p.as_mut());
            assert!(r.off_road.is_empty(), "{planner:?}: {:?}", r.off_road);
            assert!(matches!(r.termination, Termination::LeftMappedArea { .. }), "{planner:?}: {:?}", r.termination);
            ends.push(r.termination);
        }
        assert_eq!(ends[0], ends[1], "log replay and constant velocity drive the same path");
        assert_eq!(ends[0], Termination::LeftMappedArea { step: 40 });
    }

    fn shifted(mut s: Scenario, dy: f64) -> Scenario {
        for state in s.tracks[0].states.iter_mut().flatten() {
            state.position.y += dy;
        }
        s
    }

    #[test]
    fn an_ego_starting_over_the_edge_is_excused_only_while_it_gets_no_farther_off() {
        // The ego's box reaches y = dy + 1 and the road's edge is y = 2: a
        // corner 0.1 m over at the start.
        let along = run_constant_velocity(&shifted(road_that_ends(0.0), 1.1));
        assert!(along.off_road.is_empty(), "keeping its start's offset is excused: {:?}", along.off_road);
        // The same start heading 0.2 rad off the road: the start must not
        // excuse the whole departure (16 m off and more).
        let away = run_constant_velocity(&shifted(road_that_ends(0.2), 1.1));
        assert_eq!(away.off_road.len(), 1, "{:?}", away.off_road);
        let first = away.off_road[0];
        assert!(first.distance_m > 0.1 + crate::sim::events::OFF_ROAD_START_TOLERANCE_M, "{first:?}");
        assert!(away.summary().ego_off_road_s.is_some());
    }

    #[test]
    fn leaving_the_road_sideways_is_still_off_road() {
        let r = run_constant_velocity(&road_that_ends(0.2));
        assert_eq!(r.termination, Termination::Completed);
        assert_eq!(r.off_road.len(), 1, "{:?}", r.off_road);
        assert!(r.off_road[0].step < 10, "{:?}", r.off_road);
    }

    /// Two 3.5 m lanes eastbound (lane 0 centred on y = 1.75, lane 1 on
    /// y = 5.25); the ego in lane 0 and a neighbour level with it in lane
    /// 1, both at 12 m/s, each drifting sideways towards the other at the
    /// given speed, m/s.
    fn side_by_side(ego_drift_mps: f64, neighbour_drift_mps: f64) -> Scenario {
        let map = crate::map::templates::StraightRoad {
            lanes: 2,
            oncoming_lanes: 0,
            lane_width_m: 3.5,
            length_m: 300.0,
            speed_limit_mps: None,
        }
        .build();
        let track = |id: &str, y0: f64, drift: f64| {
            let v = Vector2::new(12.0, drift);
            Track {
                id: AgentId(id.into()),
                kind: AgentKind::Vehicle,
                length_m: 4.5,
                width_m: 1.9,
                states: (0..81)
                    .map(|k| {
                        Some(AgentState {
                            position: Point2::new(20.0, y0) + v * 0.1 * k as f64,
                            heading_rad: drift.atan2(12.0),
                            velocity_mps: v,
                        })
                    })
                    .collect(),
            }
        };
        let tracks = vec![track("ego", 1.75, ego_drift_mps), track("neighbour", 5.25, -neighbour_drift_mps)];
        Scenario::new("side-by-side", ScenarioSource::authored("test"), 0.1, map, tracks)
            .with_roles(TrackIndex(0), Some(TrackIndex(1)))
    }

    #[test]
    fn sideswiped_in_its_own_lane_the_ego_is_not_at_fault_drifting_across_the_line_it_is() {
        // The neighbour cuts into the ego's lane; the ego holds it.
        let c = run_constant_velocity(&side_by_side(0.0, 1.0)).summary().ego_collision.expect("contact");
        assert_eq!((c.kind, c.lanes), (EgoCollisionKind::ActiveLateral, LaneOccupancy::OneLane));
        assert!(!c.at_fault);
        // The ego drifts over the line into the neighbour, who holds its lane.
        let c = run_constant_velocity(&side_by_side(1.0, 0.0)).summary().ego_collision.expect("contact");
        assert_eq!((c.kind, c.lanes), (EgoCollisionKind::ActiveLateral, LaneOccupancy::SeveralLanes));
        assert!(c.at_fault);
    }

    #[test]
    fn constant_velocity_ego_hits_the_stopped_car() {
        let r = run(BuiltinPlanner::ConstantVelocity);
        let c = r.ego_collision().expect("collision");
        // Gap 60 - 4.5 = 55.5 m at 12 m/s: contact after 4.625 s, i.e. at step 47.
        assert_eq!(c.step, 47);
        assert_eq!((c.a, c.b), (TrackIndex(0), TrackIndex(1)));
        let summary = r.summary().ego_collision.unwrap();
        assert!(summary.with_cbv);
        // Driving into a stopped car is the ego's fault.
        assert_eq!(summary.kind, EgoCollisionKind::StoppedOther);
        assert!(summary.at_fault);
        assert!(r.off_road.is_empty());
    }

    #[test]
    fn idm_ego_stops_behind_it() {
        let r = run(BuiltinPlanner::Idm);
        assert!(r.ego_collision().is_none(), "{:?}", r.collisions);
        let closest = r.min_distance_to_ego.unwrap();
        assert!(closest.distance_m > 0.5 && closest.distance_m < 6.0, "{closest:?}");
        let last = r.states.last().unwrap()[0].unwrap();
        assert!(last.speed_mps() < 1.0, "ego still at {} m/s", last.speed_mps());
        assert_eq!(r.termination, Termination::Completed);
    }

    #[test]
    fn a_reactive_follower_stops_behind_an_ego_that_brakes_a_replayed_one_runs_into_it() {
        // The IDM ego stops behind the stopped car; a follower recorded 20 m
        // behind at the ego's recorded 12 m/s drives on.
        let base = stopped_car_ahead();
        let mut follower = base.tracks[0].clone();
        follower.id = AgentId("follower".into());
        for s in follower.states.iter_mut().flatten() {
            s.position.x -= 20.0;
        }
        let mut tracks = base.tracks.clone();
        tracks.push(follower);
        let s = Scenario::new(
            "stopped-car-ahead-with-follower",
            ScenarioSource::authored("test"),
            0.1,
            base.map.clone(),
            tracks,
        )
        .with_roles(TrackIndex(0), Some(TrackIndex(1)));
        let run_with = |background| {
            let mut p = BuiltinPlanner::Idm.instantiate(&s, TrackIndex(0));
            Simulation::new(&s, SimConfig { background, ..SimConfig::default() }).unwrap().run(p.as_mut())
        };
        let replayed = run_with(BackgroundPolicy::LogReplay).summary().ego_collision.expect("rear-ended");
        assert_eq!((replayed.other.0.as_str(), replayed.kind), ("follower", EgoCollisionKind::ActiveRear));
        assert!(!replayed.at_fault);
        let reactive = run_with(BackgroundPolicy::ReactiveLogReplay);
        assert!(reactive.collisions.is_empty(), "{:?}", reactive.collisions);
        // The stopped car is recorded stopped: the reactive replay leaves it there.
        let last = reactive.states.last().unwrap();
        assert_eq!(last[1].unwrap().position.x, 60.0);
        assert!(last[2].unwrap().speed_mps() < 0.5, "{:?}", last[2]);
    }

    #[test]
    fn evasive_ego_avoids_the_stopped_car() {
        let r = run(BuiltinPlanner::Evasive);
        assert!(r.ego_collision().is_none(), "{:?}", r.collisions);
        assert!(r.off_road.is_empty(), "{:?}", r.off_road);
        // It either stopped behind the car or went round it: either way it kept a gap.
        assert!(r.min_distance_to_ego.unwrap().distance_m > 0.3, "{:?}", r.min_distance_to_ego);
    }

    #[test]
    fn log_replay_rollout_reproduces_the_log_and_is_deterministic() {
        let s = stopped_car_ahead();
        let run = || {
            let mut p = BuiltinPlanner::LogReplay.instantiate(&s, TrackIndex(0));
            Simulation::new(&s, SimConfig::default()).unwrap().run(p.as_mut())
        };
        let (a, b) = (run(), run());
        assert_eq!(a.states, b.states);
        assert_eq!(a.states.len(), 121);
        for (k, step) in a.states.iter().enumerate() {
            assert_eq!(step[0], s.tracks[0].states[k]);
        }
    }

    #[test]
    fn bad_planner_output_ends_the_rollout_with_a_reason() {
        struct NanPlanner;
        impl Planner for NanPlanner {
            fn name(&self) -> &str {
                "nan"
            }
            fn plan(&mut self, _: &Observation<'_>) -> Result<PlannerOutput, crate::planners::PlannerError> {
                Ok(PlannerOutput::Control(crate::motion::Action { accel_mps2: f64::NAN, yaw_rate_radps: 0.0 }))
            }
        }
        let s = stopped_car_ahead();
        let r = Simulation::new(&s, SimConfig::default()).unwrap().run(&mut NanPlanner);
        match &r.termination {
            Termination::PlannerFailed { step: 0, reason } => assert!(reason.contains("non-finite"), "{reason}"),
            other => panic!("{other:?}"),
        }
    }

    /// A planner that always gives the same output.
    struct Fixed(PlannerOutput);

    impl Planner for Fixed {
        fn name(&self) -> &str {
            "fixed"
        }
        fn plan(&mut self, _: &Observation<'_>) -> Result<PlannerOutput, crate::planners::PlannerError> {
            Ok(self.0.clone())
        }
    }

    fn planner_failure(output: PlannerOutput) -> (usize, String) {
        let s = stopped_car_ahead();
        let r = Simulation::new(&s, SimConfig::default()).unwrap().run(&mut Fixed(output));
        match r.termination {
            Termination::PlannerFailed { step, reason } => (step, reason),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_huge_acceleration_is_a_planner_failure_not_a_hang() {
        let control = crate::motion::Action { accel_mps2: 1e100, yaw_rate_radps: 0.0 };
        let (step, reason) = planner_failure(PlannerOutput::Control(control));
        assert_eq!(step, 0);
        assert!(reason.contains("outside the simulation bounds"), "{reason}");
    }

    #[test]
    fn a_trajectory_point_at_1e20_is_a_planner_failure_not_a_hang() {
        let far =
            AgentState { position: Point2::new(1e20, 0.0), heading_rad: 0.0, velocity_mps: Vector2::new(12.0, 0.0) };
        let point = crate::planners::TrajectoryPoint { time_s: 0.1, state: far };
        let (_, reason) = planner_failure(PlannerOutput::Trajectory(vec![point]));
        assert!(reason.contains("x = 1e20 m"), "{reason}");
    }

    #[test]
    fn a_background_policy_producing_nan_aborts_the_rollout_naming_the_agent() {
        struct Nonsense;
        impl AgentPolicy for Nonsense {
            fn name(&self) -> &'static str {
                "nonsense"
            }
            fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
                let mut s = world.states[agent.0].unwrap();
                s.position.x = f64::NAN;
                AgentAction::Teleport(s)
            }
        }
        let s = stopped_car_ahead();
        let mut sim = Simulation::new(&s, SimConfig::default()).unwrap();
        sim.set_policy(TrackIndex(1), Box::new(Nonsense));
        let mut p = BuiltinPlanner::ConstantVelocity.instantiate(&s, TrackIndex(0));
        let r = sim.run(p.as_mut());
        match &r.termination {
            Termination::InvalidAgentState { step: 1, agent, reason } => {
                assert_eq!(agent.0, "stopped");
                assert!(reason.contains("x = NaN"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
        // The invalid state is not in the record.
        assert_eq!(r.states.len(), 1);
    }

    #[test]
    fn a_recorded_start_state_out_of_bounds_aborts_before_the_first_step() {
        let mut s = stopped_car_ahead();
        s.tracks[1].states[0].as_mut().unwrap().position.x = 1e20;
        let mut p = BuiltinPlanner::ConstantVelocity.instantiate(&s, TrackIndex(0));
        let r = Simulation::new(&s, SimConfig::default()).unwrap().run(p.as_mut());
        assert!(matches!(r.termination, Termination::InvalidAgentState { step: 0, .. }), "{:?}", r.termination);
        assert_eq!(r.states[0][1], None);
    }

    /// IDM parameters a spec could once carry: a driver accelerating to 1e300 m/s.
    fn absurd_idm() -> crate::policies::IdmParams {
        crate::policies::IdmParams { desired_speed_mps: Some(1e300), max_accel_mps2: 1e300, ..Default::default() }
    }

    #[test]
    fn an_idm_planner_with_absurd_parameters_fails_instead_of_hanging() {
        let s = stopped_car_ahead();
        let mut p = crate::planners::IdmPlanner::new(absurd_idm());
        let r = Simulation::new(&s, SimConfig::default()).unwrap().run(&mut p);
        match &r.termination {
            Termination::PlannerFailed { step: 0, reason } => {
                assert!(reason.contains("outside the simulation bounds"), "{reason}")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_background_idm_with_absurd_parameters_aborts_naming_the_agent() {
        let mut s = stopped_car_ahead();
        // The stopped car wants to go: with IDM it accelerates at 1e300 m/s².
        s.tracks[1].states[0].as_mut().unwrap().velocity_mps = Vector2::new(1.0, 0.0);
        let mut sim = Simulation::new(&s, SimConfig::default()).unwrap();
        sim.set_policy(TrackIndex(1), Box::new(crate::policies::IdmLaneFollower::new(absurd_idm())));
        let mut p = BuiltinPlanner::Idm.instantiate(&s, TrackIndex(0));
        let r = sim.run(p.as_mut());
        match &r.termination {
            Termination::InvalidAgentState { step: 1, agent, reason } => {
                assert_eq!(agent.0, "stopped");
                assert!(reason.contains("outside the simulation bounds"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn an_absurd_box_aborts_before_the_first_step() {
        // A NaN-wide box once reached parry's box–box distance and panicked there.
        let mut s = stopped_car_ahead();
        s.tracks[1].width_m = f64::NAN;
        let mut p = BuiltinPlanner::ConstantVelocity.instantiate(&s, TrackIndex(0));
        let r = Simulation::new(&s, SimConfig::default()).unwrap().run(p.as_mut());
        match &r.termination {
            Termination::InvalidAgentState { step: 0, agent, reason } => {
                assert_eq!(agent.0, "stopped");
                assert!(reason.starts_with("width = NaN m is outside"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
    }
}
