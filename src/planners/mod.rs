//! The ego under test: the [`Planner`] trait every planner implements
//! (built-ins, in-process planners a test target registers by name,
//! external processes speaking the JSON-lines protocol; ONNX policies
//! later), the observation it receives and the output it returns.

pub mod builtin;
pub mod evasive;
pub mod external;
pub mod registry;

pub use builtin::{BuiltinPlanner, ConstantVelocityPlanner, IdmPlanner, LogReplayPlanner};
pub use evasive::{EvasiveParams, EvasivePlanner};
pub use external::{ExternalPlanner, ExternalPlannerConfig};

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
#[non_exhaustive]
pub enum PlannerOutput {
    /// A control applied through the kinematic model for one step.
    Control(Action),
    /// A trajectory; the simulator tracks it perfectly, taking the state
    /// interpolated one step ahead.
    Trajectory(Vec<TrajectoryPoint>),
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
