//! The ego under test: the [`Planner`] trait every planner implements
//! (built-ins, in-process planners a test target registers by name,
//! external processes speaking the JSON-lines protocol; ONNX policies
//! later), the observation it receives and the output it returns.

pub mod builtin;
pub mod evasive;
pub mod external;
pub mod mutant;
pub mod panic_guard;
pub mod registry;

pub use builtin::{BuiltinPlanner, ConstantVelocityPlanner, IdmPlanner, LogReplayPlanner};
pub use evasive::{EvasiveParams, EvasivePlanner};
pub use external::{ExternalPlanner, ExternalPlannerConfig};
pub use mutant::{FaultOperator, MutantPlanner};

use crate::map::{MapElementId, RoadMap, SignalState};
use crate::motion::{Action, KinematicState, kinematic_step};
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

impl<'a> Observation<'a> {
    /// The observation of step 0 on `map` with the ego at `ego`: 0.1 s
    /// steps, a 4.5 m × 2 m ego, nobody else and no signals. Set the other
    /// fields as a test needs (they are public), e.g. to unit-test a
    /// planner's adapter outside the harness.
    pub fn new(map: &'a RoadMap, ego: AgentState) -> Self {
        Observation {
            step: 0,
            time_s: 0.0,
            dt_s: 0.1,
            ego,
            ego_length_m: 4.5,
            ego_width_m: 2.0,
            agents: Vec::new(),
            map,
            signals: Vec::new(),
        }
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
