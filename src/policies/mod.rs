//! Who drives a background agent in closed loop: log replay (plain, or
//! reactive: braking along the recorded path for whoever is in the way),
//! constant velocity, an IDM-style lane follower, the learned prior and the
//! SaFeR adversary. A policy sees the world at step `k` and says
//! what the agent does until `k + 1`.

pub mod adversary;
pub mod cbv_rules;
pub mod constant_velocity;
pub mod crossing_pedestrian;
pub mod lane_follower;
pub mod log_replay;
pub mod noisy_idm;
pub mod prior_sampling;
pub mod reactive_log_replay;
pub mod synthetic_driver;

pub use constant_velocity::ConstantVelocity;
pub use lane_follower::{IdmLaneFollower, IdmParams, Route, build_route, build_route_along, build_route_choosing};
pub use log_replay::LogReplay;
pub use reactive_log_replay::ReactiveLogReplay;

use crate::map::RoadMap;
use crate::motion::Action;
use crate::scenario::{AgentBody, AgentState, Scenario, TrackIndex};

/// What an agent does over one simulator step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AgentAction {
    /// Be at exactly this state at the next step (log replay).
    Teleport(AgentState),
    /// Apply this control through the kinematic model.
    Control(Action),
    /// Not present at the next step.
    Absent,
}

impl AgentAction {
    /// A controller's output as an action: its control, or holding still
    /// (zero control) while present without one, or absent.
    pub fn from_control(world: &WorldView<'_>, agent: TrackIndex, control: Option<Action>) -> Self {
        match control {
            Some(a) => Self::Control(a),
            None if world.state(agent).is_some() => Self::Control(Action::default()),
            None => Self::Absent,
        }
    }
}

/// The world as every policy sees it at one step.
#[derive(Debug, Clone, Copy)]
pub struct WorldView<'a> {
    /// The map.
    pub map: &'a RoadMap,
    /// Current step index (in the scenario's step numbering).
    pub step: usize,
    /// Type and size of every agent slot.
    pub bodies: &'a [AgentBody],
    /// Current state of every agent slot (`None`: absent), same indexing.
    pub states: &'a [Option<AgentState>],
}

impl WorldView<'_> {
    /// Type and size of `agent`.
    pub fn body(&self, agent: TrackIndex) -> AgentBody {
        self.bodies[agent.0]
    }

    /// Current state of `agent`.
    pub fn state(&self, agent: TrackIndex) -> Option<&AgentState> {
        self.states.get(agent.0).and_then(Option::as_ref)
    }
}

/// A driver of one background agent.
pub trait AgentPolicy: Send {
    /// Short name for reports.
    fn name(&self) -> &'static str;
    /// The agent's action from `world.step` to the next step.
    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction;
}

/// The built-in background policies, selectable by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum BackgroundPolicy {
    /// Replay the recorded trajectory (non-reactive).
    #[default]
    LogReplay,
    /// Replay the recorded path, braking along it for road users in the way,
    /// then catching up with the recording.
    ReactiveLogReplay,
    /// Keep speed and heading from the start state.
    ConstantVelocity,
    /// Follow the lane, brake for leaders and red lights (IDM).
    Idm,
}

impl BackgroundPolicy {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::LogReplay, Self::ReactiveLogReplay, Self::ConstantVelocity, Self::Idm];
}

impl BackgroundPolicy {
    /// The policy for an agent that enters after the rollout starts: the
    /// replays follow its recorded entry; the others need a start state,
    /// so such an agent replays its log.
    pub fn for_late_entrant(self) -> Self {
        match self {
            Self::LogReplay | Self::ReactiveLogReplay => self,
            Self::ConstantVelocity | Self::Idm => Self::LogReplay,
        }
    }

    /// A fresh policy instance for `agent` of `scenario`.
    pub fn instantiate(self, scenario: &Scenario, agent: TrackIndex) -> Box<dyn AgentPolicy> {
        match self {
            Self::LogReplay => Box::new(LogReplay::new(scenario.track(agent).clone())),
            Self::ReactiveLogReplay => Box::new(ReactiveLogReplay::new(scenario.track(agent).clone())),
            Self::ConstantVelocity => Box::new(ConstantVelocity),
            Self::Idm => Box::new(IdmLaneFollower::new(IdmParams::default())),
        }
    }
}
