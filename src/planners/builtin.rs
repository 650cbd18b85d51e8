//! Built-in planners: log replay (the non-reactive ego of stage 1),
//! constant velocity, and the IDM lane follower as a reactive ego.

use super::{Observation, Planner, PlannerError, PlannerOutput, TrajectoryPoint};
use crate::motion::{Action, within_grip};
use crate::policies::{IdmLaneFollower, IdmParams, WorldView};
use crate::scenario::{AgentBody, AgentKind, Scenario, Track, TrackIndex};

/// The built-in planners, selectable by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum BuiltinPlanner {
    /// Replay the ego's recording (non-reactive).
    LogReplay,
    /// Keep speed and heading.
    ConstantVelocity,
    /// Follow the lane with IDM speed control.
    #[default]
    Idm,
    /// Sample and roll out evasive manoeuvres against predicted traffic.
    Evasive,
}

impl BuiltinPlanner {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::LogReplay, Self::ConstantVelocity, Self::Idm, Self::Evasive];
}

impl BuiltinPlanner {
    /// A planner instance for the ego `ego` of `scenario`.
    pub fn instantiate(self, scenario: &Scenario, ego: TrackIndex) -> Box<dyn Planner> {
        match self {
            Self::LogReplay => Box::new(LogReplayPlanner::new(scenario.track(ego).clone())),
            Self::ConstantVelocity => Box::new(ConstantVelocityPlanner),
            Self::Idm => Box::new(IdmPlanner::new(IdmParams::default())),
            Self::Evasive => Box::new(super::EvasivePlanner::for_recorded_ego(Default::default(), scenario, ego)),
        }
    }
}

/// Replays the ego's recorded track.
#[derive(Debug, Clone)]
pub struct LogReplayPlanner {
    track: Track,
}

impl LogReplayPlanner {
    /// Replays `track`.
    pub fn new(track: Track) -> Self {
        Self { track }
    }
}

impl Planner for LogReplayPlanner {
    fn name(&self) -> &str {
        "log-replay"
    }

    fn plan(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        let next = self.track.state(obs.step + 1).ok_or_else(|| PlannerError::NoOutput {
            step: obs.step,
            reason: "the ego's recording has no valid state at the next step".into(),
        })?;
        Ok(PlannerOutput::Trajectory(vec![TrajectoryPoint { time_s: obs.dt_s, state: *next }]))
    }
}

/// Keeps speed and heading.
#[derive(Debug, Clone, Copy, Default)]
pub struct ConstantVelocityPlanner;

impl Planner for ConstantVelocityPlanner {
    fn name(&self) -> &str {
        "constant-velocity"
    }

    fn plan(&mut self, _: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        Ok(PlannerOutput::Control(Action::default()))
    }
}

/// The IDM lane follower driving the ego. It sees only the observation,
/// exactly what any other planner would.
pub struct IdmPlanner {
    follower: IdmLaneFollower,
}

impl IdmPlanner {
    /// An IDM ego with these parameters.
    pub fn new(params: IdmParams) -> Self {
        Self { follower: IdmLaneFollower::new(params) }
    }
}

impl Planner for IdmPlanner {
    fn name(&self) -> &str {
        "idm"
    }

    fn plan(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        // Slot 0 is the ego, then the perceived agents.
        let ego_body = AgentBody { kind: AgentKind::Vehicle, length_m: obs.ego_length_m, width_m: obs.ego_width_m };
        let bodies: Vec<AgentBody> = std::iter::once(ego_body)
            .chain(obs.agents.iter().map(|a| AgentBody { kind: a.kind, length_m: a.length_m, width_m: a.width_m }))
            .collect();
        let states: Vec<_> = std::iter::once(Some(obs.ego)).chain(obs.agents.iter().map(|a| Some(a.state))).collect();
        let world = WorldView { map: obs.map, step: obs.step, bodies: &bodies, states: &states };
        let action = self.follower.control(&world, TrackIndex(0)).unwrap_or_default();
        let speed = obs.ego.speed_mps();
        let next_speed = (speed + action.accel_mps2 * crate::motion::tokens::SIM_DT_S).max(0.0);
        let yaw_rate_radps =
            within_grip(action.yaw_rate_radps, speed, next_speed, crate::motion::BUILTIN_MAX_LATERAL_ACCEL_MPS2);
        Ok(PlannerOutput::Control(Action { yaw_rate_radps, ..action }))
    }
}
