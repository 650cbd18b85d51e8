//! The ego under test: the [`Planner`] trait every planner implements
//! (built-ins here; external processes and ONNX policies later), the
//! observation it receives and the output it returns.

pub mod builtin;

pub use builtin::{BuiltinPlanner, ConstantVelocityPlanner, IdmPlanner, LogReplayPlanner};

use crate::map::{MapElementId, RoadMap, SignalState};
use crate::motion::Action;
use crate::scenario::{AgentId, AgentKind, AgentState};

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
pub struct Observation<'a> {
    /// Step index in the scenario's numbering.
    pub step: usize,
    /// Time since the rollout started, s.
    pub time_s: f64,
    /// Step length, s.
    pub dt_s: f64,
    /// The ego's state.
    pub ego: AgentState,
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
pub enum PlannerOutput {
    /// A control applied through the kinematic model for one step.
    Control(Action),
    /// A trajectory; the simulator tracks it perfectly, taking the state
    /// interpolated one step ahead.
    Trajectory(Vec<TrajectoryPoint>),
}

/// Why a planner failed to answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
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
}

/// The ego's driver.
pub trait Planner: Send {
    /// Name for reports.
    fn name(&self) -> &str;
    /// Plans from the observation at one step.
    fn plan(&mut self, observation: &Observation<'_>) -> Result<PlannerOutput, PlannerError>;
}
