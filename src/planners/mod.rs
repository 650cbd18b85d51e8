//! The ego under test: the [`Planner`] trait every planner implements
//! (built-ins, in-process planners a test target registers by name,
//! external processes speaking the JSON-lines protocol; ONNX policies
//! later), the observation it receives and the output it returns.

pub mod builtin;
pub mod evasive;
pub mod external;
pub(crate) mod lane_walk;
pub mod mutant;
pub mod panic_guard;
pub mod registry;
pub mod route;

pub use builtin::{BuiltinPlanner, ConstantVelocityPlanner, IdmPlanner, LogReplayPlanner};
pub use evasive::{AvoidedContacts, EvasiveParams, EvasivePlanner};
pub use external::{ExternalPlanner, ExternalPlannerConfig};
pub use mutant::{FaultOperator, MutantPlanner};
pub use route::Route;

use std::sync::Arc;

use crate::geometry::Vector2;
use crate::map::{LaneMatch, MapElementId, RoadMap, SignalState};
use crate::motion::{Action, KinematicState, kinematic_step};
use crate::scenario::{AgentId, AgentKind, AgentState, Scenario, TrackIndex};

/// How far from the ego [`Observation::nearest_lane`] searches, m (the
/// route's lane search too).
pub const EGO_LANE_SEARCH_M: f64 = 10.0;
/// [`Observation::leader`]'s margin beside the ego's corridor, m.
pub const LEADER_MARGIN_M: f64 = 0.4;
/// How far along the route [`Observation::leader`] searches, m.
pub const LEADER_RANGE_M: f64 = 120.0;

/// Another road user as the ego perceives it.
#[derive(Debug, Clone, PartialEq)]
pub struct PerceivedAgent {
    /// Source id.
    pub id: AgentId,
    /// Agent type.
    pub kind: AgentKind,
    /// Length, m.
    pub length_m: f64,
    /// Width, m.
    pub width_m: f64,
    /// Current state.
    pub state: AgentState,
}

/// What a planner sees at one step.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct Observation<'a> {
    /// Step index in the scenario's numbering.
    pub step: usize,
    /// Time since the rollout started, s.
    pub time_s: f64,
    /// Step length, s.
    pub dt_s: f64,
    /// The ego's state.
    pub ego: AgentState,
    /// The ego's longitudinal acceleration over the last step, m/s²: the
    /// change of its speed along the heading (as the kinematic model holds
    /// it, never negative) from the previous step, over the step; 0 where
    /// no earlier state is known ([`EgoMotion::between`]).
    pub ego_accel_mps2: f64,
    /// The ego's yaw rate over the last step, rad/s (positive turns left):
    /// the heading's wrapped change from the previous step, over the step;
    /// 0 where no earlier state is known.
    pub ego_yaw_rate_radps: f64,
    /// The ego's length, m.
    pub ego_length_m: f64,
    /// The ego's width, m.
    pub ego_width_m: f64,
    /// Other agents present now.
    pub agents: Vec<PerceivedAgent>,
    /// The HD map.
    pub map: &'a RoadMap,
    /// Signal states now, per controlled lane.
    pub signals: Vec<(MapElementId, SignalState)>,
    /// The route the ego is on (the stable route external planners are
    /// sent): kept while the ego follows it, planned anew (with the next
    /// [`Route::revision`]) when it leaves it. Empty where the ego is on
    /// no lane running its way.
    pub route: Arc<Route>,
    /// The ego's arc length along [`route`](Self::route), m; `None` when
    /// the route is empty.
    pub route_s_m: Option<f64>,
    /// The steps this rollout runs; `None` outside a rollout (e.g. an
    /// observation made by [`Observation::new`]).
    pub horizon: Option<Horizon>,
    /// The ego's last valid recorded state, as a goal: a hint of where the
    /// scene meant it to go, not a task; `None` for scenes without one.
    pub goal: Option<Goal>,
}

/// The steps a rollout runs (the external protocol's `hello.horizon`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct Horizon {
    /// The first step, in the scenario's numbering.
    pub start_step: usize,
    /// The last step (inclusive).
    pub end_step: usize,
    /// Step length, s.
    pub dt_s: f64,
}

impl Horizon {
    /// From `start_step` to `end_step` (inclusive) in steps of `dt_s`.
    pub fn new(start_step: usize, end_step: usize, dt_s: f64) -> Self {
        Horizon { start_step, end_step, dt_s }
    }

    /// Steps simulated: `end_step - start_step`.
    pub fn steps(&self) -> usize {
        self.end_step.saturating_sub(self.start_step)
    }

    /// The rollout's length, s.
    pub fn duration_s(&self) -> f64 {
        self.steps() as f64 * self.dt_s
    }

    /// Time left after `step`, s (0 at or past the end).
    pub fn remaining_s(&self, step: usize) -> f64 {
        self.end_step.saturating_sub(step) as f64 * self.dt_s
    }
}

/// How the ego moved over the last step, from two consecutive states (the
/// simulator keeps poses and velocities, not controls): what
/// [`Observation::ego_accel_mps2`] and [`Observation::ego_yaw_rate_radps`]
/// hold.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[non_exhaustive]
pub struct EgoMotion {
    /// Change of the speed along the heading (never negative, as
    /// [`KinematicState::from_agent_state`] holds it), over the step, m/s².
    pub accel_mps2: f64,
    /// Wrapped change of the heading, over the step, rad/s.
    pub yaw_rate_radps: f64,
}

impl EgoMotion {
    /// The motion from `previous` to `now`, `dt_s` apart; zero without a
    /// previous state. Under a control through the kinematic model this
    /// gives back the control applied (the acceleration unless the speed
    /// stopped at 0).
    pub fn between(previous: Option<&AgentState>, now: &AgentState, dt_s: f64) -> Self {
        let Some(previous) = previous else { return Self::default() };
        if dt_s.is_nan() || dt_s <= 0.0 {
            return Self::default();
        }
        let speed = |s: &AgentState| KinematicState::from_agent_state(s).speed_mps;
        EgoMotion {
            accel_mps2: (speed(now) - speed(previous)) / dt_s,
            yaw_rate_radps: crate::geometry::wrap_angle(now.heading_rad - previous.heading_rad) / dt_s,
        }
    }
}

/// The ego's last valid recorded state (the external protocol's
/// `hello.goal`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct Goal {
    /// Its step, in the scenario's numbering.
    pub step: usize,
    /// The recorded state there.
    pub state: AgentState,
}

impl Goal {
    /// A goal `state` at `step`.
    pub fn new(step: usize, state: AgentState) -> Self {
        Goal { step, state }
    }

    /// The last valid recorded state of track `ego` of `scenario`.
    pub fn recorded(scenario: &Scenario, ego: TrackIndex) -> Option<Goal> {
        let track = scenario.tracks.get(ego.0)?;
        track.states.iter().enumerate().rev().find_map(|(k, s)| s.map(|state| Goal { step: k, state }))
    }
}

/// The nearest road user ahead of the ego in its corridor along the route
/// ([`Observation::leader`]).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Leader {
    /// Who it is.
    pub agent: PerceivedAgent,
    /// Bumper-to-bumper distance along the route, m (negative: overlapping).
    pub gap_m: f64,
    /// Its velocity along the route's direction at the ego, m/s.
    pub speed_mps: f64,
    /// Its centre's arc length along the route, m.
    pub s_m: f64,
    /// Its centre's offset from the route, m (left > 0).
    pub lateral_m: f64,
}

impl<'a> Observation<'a> {
    /// The observation of step 0 on `map` with the ego at `ego`: 0.1 s
    /// steps, a 4.5 m × 2 m ego, nobody else and no signals, the route
    /// planned from the ego's lane ([`Route::plan_from`]: the first
    /// successor at forks), no horizon and no goal. Set the other fields as
    /// a test needs (they are public; [`Observation::with_route_from`]
    /// plans the route anew), e.g. to unit-test a planner's adapter outside
    /// the harness.
    pub fn new(map: &'a RoadMap, ego: AgentState) -> Self {
        let (route, route_s_m) = Route::plan_from(map, &ego);
        Observation {
            route: Arc::new(route),
            route_s_m,
            horizon: None,
            goal: None,
            step: 0,
            time_s: 0.0,
            dt_s: 0.1,
            ego,
            ego_accel_mps2: 0.0,
            ego_yaw_rate_radps: 0.0,
            ego_length_m: 4.5,
            ego_width_m: 2.0,
            agents: Vec::new(),
            map,
            signals: Vec::new(),
        }
    }

    /// This observation with the route planned anew from the ego's place
    /// (after a test moved the ego), as [`Observation::new`] plans it.
    pub fn with_route_from(mut self, ego: AgentState) -> Self {
        self.ego = ego;
        let (route, route_s_m) = Route::plan_from(self.map, &ego);
        self.route = Arc::new(route);
        self.route_s_m = route_s_m;
        self
    }

    /// The ego's lane: the nearest lane within [`EGO_LANE_SEARCH_M`],
    /// preferring lanes running the ego's way ([`RoadMap::nearest_lane`]),
    /// with the ego's projection onto its centreline. The lane is
    /// `self.map.lanes[m.lane_index]`.
    pub fn nearest_lane(&self) -> Option<LaneMatch> {
        self.map.nearest_lane(&self.ego.position, Some(self.ego.heading_rad), EGO_LANE_SEARCH_M)
    }

    /// [`Observation::leader_within`] with a [`LEADER_MARGIN_M`] margin over
    /// [`LEADER_RANGE_M`] of route, as the Python kit's `leader()`.
    pub fn leader(&self) -> Option<Leader> {
        self.leader_within(LEADER_MARGIN_M, LEADER_RANGE_M)
    }

    /// The nearest agent ahead of the ego whose box reaches into the ego's
    /// corridor along the route (the ego's half width, plus the agent's
    /// half extent across the route as it is turned, plus `margin_m`),
    /// searching `range_m` metres of route ahead; `None` when there is none
    /// or the route is empty. The same rule as the Python kit's
    /// `Observation.leader`.
    pub fn leader_within(&self, margin_m: f64, range_m: f64) -> Option<Leader> {
        let s_ego = self.route_s_m?;
        let (_, along) = self.route.at(s_ego)?;
        let mut best: Option<Leader> = None;
        for agent in &self.agents {
            let position = agent.state.position;
            if (position - self.ego.position).norm() > range_m + 10.0 {
                continue;
            }
            let Some(p) = self.route.project_between(&position, s_ego - 5.0, s_ego + range_m) else {
                continue;
            };
            let s = p.arc_length_m;
            if s <= s_ego {
                continue;
            }
            // PolylineProjection's signed distance is negative on the left.
            let lateral = -p.signed_distance_m;
            let rel = agent.state.heading_rad - p.tangent.y.atan2(p.tangent.x);
            let (sin, cos) = (rel.sin().abs(), rel.cos().abs());
            let half_across = 0.5 * (sin * agent.length_m + cos * agent.width_m);
            if lateral.abs() > self.ego_width_m / 2.0 + half_across + margin_m {
                continue;
            }
            let half_along = 0.5 * (cos * agent.length_m + sin * agent.width_m);
            let gap_m = s - s_ego - self.ego_length_m / 2.0 - half_along;
            if best.as_ref().is_none_or(|b| gap_m < b.gap_m) {
                let speed_mps = agent.state.velocity_mps.dot(&Vector2::new(along.x, along.y));
                best = Some(Leader { agent: agent.clone(), gap_m, speed_mps, s_m: s, lateral_m: lateral });
            }
        }
        best
    }
}

/// A planned state, `time_s` after the observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrajectoryPoint {
    /// Time after the observation, s.
    pub time_s: f64,
    /// Planned state.
    pub state: AgentState,
}

/// What a planner returns.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum PlannerOutput {
    /// A control applied through the kinematic model for one step.
    Control(Action),
    /// A trajectory; the simulator tracks it perfectly, taking the state
    /// interpolated one step ahead.
    Trajectory(Vec<TrajectoryPoint>),
}

impl PlannerOutput {
    /// The ego's state `dt_s` after `now` under this output: a control
    /// through the kinematic model, a trajectory tracked perfectly (the
    /// state interpolated at `dt_s`). The error says why the output cannot
    /// be applied (a non-finite number, an empty trajectory, times not
    /// increasing, a trajectory ending before `dt_s`).
    pub fn next_state(&self, now: &AgentState, dt_s: f64) -> Result<AgentState, String> {
        match self {
            PlannerOutput::Control(a) => {
                if !(a.accel_mps2.is_finite() && a.yaw_rate_radps.is_finite()) {
                    return Err(format!(
                        "non-finite control: acceleration {} m/s², yaw rate {} rad/s",
                        a.accel_mps2, a.yaw_rate_radps
                    ));
                }
                Ok(kinematic_step(&KinematicState::from_agent_state(now), *a, dt_s).to_agent_state())
            }
            PlannerOutput::Trajectory(points) => trajectory_state_at(now, points, dt_s),
        }
    }
}

/// The state a perfectly tracked trajectory reaches `t` after `now` (t = 0).
fn trajectory_state_at(now: &AgentState, points: &[TrajectoryPoint], t: f64) -> Result<AgentState, String> {
    let first = points.first().ok_or("empty trajectory")?;
    for p in points {
        let s = &p.state;
        let finite = p.time_s.is_finite()
            && s.position.x.is_finite()
            && s.position.y.is_finite()
            && s.heading_rad.is_finite()
            && s.velocity_mps.x.is_finite()
            && s.velocity_mps.y.is_finite();
        if !finite {
            return Err(format!(
                "non-finite trajectory point at t = {} s: x {} m, y {} m, heading {} rad, velocity ({}, {}) m/s",
                p.time_s, s.position.x, s.position.y, s.heading_rad, s.velocity_mps.x, s.velocity_mps.y
            ));
        }
    }
    if points.windows(2).any(|w| w[1].time_s <= w[0].time_s) || first.time_s <= 0.0 {
        return Err("trajectory times must be positive and increasing".into());
    }
    let mut prev = (0.0, *now);
    for p in points {
        // A point at exactly the next step is taken as is: interpolating
        // with w = 1 would give a + (b - a), off by an ulp from b.
        if (p.time_s - t).abs() <= 1e-9 {
            return Ok(p.state);
        }
        if p.time_s >= t - 1e-9 {
            let w = ((t - prev.0) / (p.time_s - prev.0)).clamp(0.0, 1.0);
            let lerp = |a: f64, b: f64| a + (b - a) * w;
            let dh = crate::geometry::wrap_angle(p.state.heading_rad - prev.1.heading_rad);
            return Ok(AgentState {
                position: prev.1.position + (p.state.position - prev.1.position) * w,
                heading_rad: crate::geometry::wrap_angle(prev.1.heading_rad + dh * w),
                velocity_mps: crate::geometry::Vector2::new(
                    lerp(prev.1.velocity_mps.x, p.state.velocity_mps.x),
                    lerp(prev.1.velocity_mps.y, p.state.velocity_mps.y),
                ),
            });
        }
        prev = (p.time_s, p.state);
    }
    Err(format!("trajectory ends at {} s, before the next step ({t} s)", prev.0))
}

/// Why a planner failed to answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlannerError {
    /// The planner has nothing to say at this step (e.g. a log-replay ego
    /// whose recording ends).
    #[error("planner has no output at step {step}: {reason}")]
    NoOutput {
        /// Step.
        step: usize,
        /// Why.
        reason: String,
    },
    /// The output is unusable (NaN, empty trajectory, times not increasing).
    #[error("planner output is invalid: {0}")]
    InvalidOutput(String),
    /// An external planner's process could not be started (e.g. command not
    /// found, not executable, bad working directory).
    #[error("external planner `{planner}`: could not start `{command}`: {reason}")]
    SpawnFailed {
        /// Planner name.
        planner: String,
        /// The command as configured.
        command: String,
        /// The operating system's reason.
        reason: String,
    },
    /// An external planner's process exited (or closed its stdout) while the
    /// harness waited for an answer.
    #[error("external planner `{planner}` {what} {during}{}", external::format_stderr_tail(.stderr_tail))]
    Crashed {
        /// Planner name.
        planner: String,
        /// What happened, e.g. `exited with exit status: 3`.
        what: String,
        /// When, e.g. `at step 12` or `during startup`.
        during: String,
        /// The last lines it wrote to stderr, oldest first.
        stderr_tail: Vec<String>,
    },
    /// An external planner did not answer within its timeout.
    #[error("external planner `{planner}` did not answer {during} within {timeout_ms} ms")]
    Timeout {
        /// Planner name.
        planner: String,
        /// When, e.g. `at step 12` or `during startup`.
        during: String,
        /// The timeout that ran out, ms.
        timeout_ms: u64,
    },
    /// An external planner broke the protocol: a line that is not JSON, an
    /// unknown or unexpected message, a missing or non-finite number, a wrong
    /// protocol version.
    #[error("external planner `{planner}` broke the protocol {during}: {message}")]
    Protocol {
        /// Planner name.
        planner: String,
        /// When, e.g. `at step 12` or `during startup`.
        during: String,
        /// What was wrong, quoting the offending line.
        message: String,
    },
    /// An external planner answered with an `error` message.
    #[error("external planner `{planner}` reported an error {during}: {message}")]
    Reported {
        /// Planner name.
        planner: String,
        /// When, e.g. `at step 12` or `during startup`.
        during: String,
        /// Its message.
        message: String,
    },
    /// An in-process planner panicked in `plan` ([`panic_guard`]).
    #[error("planner `{planner}` panicked: {message}")]
    Panicked {
        /// Planner name.
        planner: String,
        /// The panic's message (cut to 2 000 characters).
        message: String,
    },
    /// The planner's own error (made with [`PlannerError::other`]); the
    /// message shows it with its whole source chain.
    #[error("planner error: {0}")]
    Other(OtherError),
}

impl PlannerError {
    /// Wraps a planner's own error, e.g.
    /// `my_stack.plan(..).map_err(PlannerError::other)?`, or a message:
    /// `PlannerError::other("no route")`.
    pub fn other(error: impl Into<Box<dyn std::error::Error + Send + Sync>>) -> Self {
        PlannerError::Other(OtherError(Arc::from(error.into())))
    }
}

impl From<Box<dyn std::error::Error + Send + Sync>> for PlannerError {
    fn from(error: Box<dyn std::error::Error + Send + Sync>) -> Self {
        PlannerError::other(error)
    }
}

/// A planner's own error inside [`PlannerError::Other`]. Its `Display`
/// is the error's message followed by those of its sources (`: ` between
/// them), as the harness reports failures as text; the error itself is
/// [`OtherError::error`]. Two are equal when they are the same error.
#[derive(Debug, Clone)]
pub struct OtherError(Arc<dyn std::error::Error + Send + Sync>);

impl OtherError {
    /// The wrapped error.
    pub fn error(&self) -> &(dyn std::error::Error + Send + Sync + 'static) {
        &*self.0
    }
}

impl std::fmt::Display for OtherError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)?;
        let mut source = self.0.source();
        while let Some(s) = source {
            write!(f, ": {s}")?;
            source = s.source();
        }
        Ok(())
    }
}

impl PartialEq for OtherError {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// The ego's driver.
pub trait Planner: Send {
    /// Name for reports.
    fn name(&self) -> &str;
    /// Plans from the observation at one step.
    fn plan(&mut self, observation: &Observation<'_>) -> Result<PlannerOutput, PlannerError>;
    /// Ends the rollout and returns what the planner wrote to its error
    /// stream in it (external processes: told `bye` and waited for, so the
    /// log is complete up to their exit); `None` for planners without one.
    fn end_rollout(&mut self) -> Option<String> {
        None
    }
    /// How long this rollout's start took, for planners that start
    /// something (an external process); `None` for the others.
    fn startup(&self) -> Option<PlannerStartup> {
        None
    }
    /// The planner's own data about its last [`Planner::plan`] call, taken
    /// (the next call gives `None` until it plans again): an external
    /// planner's `debug` object. The simulator keeps it with the step in
    /// the rollout ([`crate::sim::Rollout::planner_debug`]); `None` for
    /// planners without any.
    fn take_debug(&mut self) -> Option<serde_json::Value> {
        None
    }
}

/// How long a planner took to start, before its first observation.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct PlannerStartup {
    /// From starting the process to its `ready`, ms.
    pub launch_ms: f64,
    /// Its answer to the whole map (`prepare` → `prepared`, protocol 1.1
    /// and later), ms; `None` when it was not sent.
    pub prepare_ms: Option<f64>,
}

#[cfg(test)]
mod adapter_tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::map::templates::StraightRoad;

    /// Two 3.5 m lanes along +x (centres at y = 1.75 and 5.25), 300 m long.
    fn two_lanes() -> RoadMap {
        StraightRoad { lanes: 2, oncoming_lanes: 0, lane_width_m: 3.5, length_m: 300.0, speed_limit_mps: None }.build()
    }

    fn state(x: f64, y: f64, speed: f64) -> AgentState {
        AgentState { position: Point2::new(x, y), heading_rad: 0.0, velocity_mps: Vector2::new(speed, 0.0) }
    }

    fn car(id: &str, x: f64, y: f64, speed: f64) -> PerceivedAgent {
        PerceivedAgent {
            id: AgentId(id.into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            state: state(x, y, speed),
        }
    }

    #[test]
    fn the_leader_is_the_car_ahead_in_the_ego_lane_not_a_nearer_one_in_the_next_lane() {
        let map = two_lanes();
        let mut obs = Observation::new(&map, state(20.0, 1.75, 10.0));
        obs.agents = vec![
            car("next-lane", 30.0, 5.25, 5.0),
            car("behind", 10.0, 1.75, 12.0),
            car("ahead", 50.0, 1.75, 8.0),
            car("far-ahead", 80.0, 1.75, 8.0),
        ];
        let leader = obs.leader().expect("a leader");
        assert_eq!(leader.agent.id.0, "ahead");
        // 30 m between centres, less two half lengths.
        assert!((leader.gap_m - 25.5).abs() < 1e-9, "{leader:?}");
        assert!((leader.speed_mps - 8.0).abs() < 1e-9);
        assert!(leader.lateral_m.abs() < 1e-9);
        // A car straddling the lane line reaches into the corridor.
        obs.agents.push(car("straddling", 40.0, 3.6, 8.0));
        assert_eq!(obs.leader().unwrap().agent.id.0, "straddling");
        // Left of the route is positive.
        assert!(obs.leader().unwrap().lateral_m > 1.8);
        // Out of range: none.
        obs.agents = vec![car("ahead", 200.0, 1.75, 8.0)];
        assert!(obs.leader().is_none());
        assert!(obs.leader_within(LEADER_MARGIN_M, 200.0).is_some());
    }

    #[test]
    fn in_the_next_lane_the_leader_is_the_car_ahead_there() {
        let map = two_lanes();
        let mut obs = Observation::new(&map, state(20.0, 5.25, 10.0));
        obs.agents = vec![car("right-lane", 30.0, 1.75, 5.0), car("left-lane", 60.0, 5.25, 5.0)];
        assert_eq!(obs.leader().unwrap().agent.id.0, "left-lane");
    }

    #[test]
    fn the_nearest_lane_and_the_projection_onto_it_are_the_ego_s() {
        let map = two_lanes();
        let obs = Observation::new(&map, state(42.0, 5.0, 10.0));
        let m = obs.nearest_lane().expect("on a lane");
        assert_eq!(map.lanes[m.lane_index].id, MapElementId(1));
        assert!((m.projection.arc_length_m - 42.0).abs() < 1e-9);
        assert!((m.projection.distance_m - 0.25).abs() < 1e-9);
        // Off the road: no lane within 10 m.
        assert!(Observation::new(&map, state(42.0, 30.0, 10.0)).nearest_lane().is_none());
    }

    #[test]
    fn observation_new_plans_the_route_from_the_ego_s_lane() {
        let map = two_lanes();
        let obs = Observation::new(&map, state(50.0, 1.75, 10.0));
        assert_eq!(obs.route.lanes(), &[MapElementId(0)]);
        assert_eq!(obs.route_s_m, Some(route::ROUTE_BEHIND_M));
        assert_eq!(obs.route.revision(), 0);
        assert!((obs.route.at(0.0).unwrap().0 - Point2::new(30.0, 1.75)).norm() < 1e-9);
        // Facing against the lanes: no route, no leader, no place on it.
        let back = AgentState { heading_rad: std::f64::consts::PI, ..state(50.0, 1.75, 10.0) };
        let obs = Observation::new(&map, back);
        assert!(obs.route.is_empty() && obs.route_s_m.is_none() && obs.leader().is_none());
        assert!(obs.horizon.is_none() && obs.goal.is_none());
    }

    #[test]
    fn a_planner_s_error_is_reported_with_its_sources() {
        #[derive(Debug, thiserror::Error)]
        #[error("trajectory optimiser failed")]
        struct Outer(#[source] std::io::Error);
        let e = PlannerError::other(Outer(std::io::Error::other("solver diverged")));
        assert_eq!(e.to_string(), "planner error: trajectory optimiser failed: solver diverged");
        assert_eq!(e.clone(), e);
        assert_ne!(e, PlannerError::other("trajectory optimiser failed"));
        assert_eq!(PlannerError::other("no route").to_string(), "planner error: no route");
    }
}
