//! External planners: a child process that drives the ego by speaking the
//! JSON-lines planner protocol (version 1, specified in
//! `docs/planner-protocol.md`, schema in `docs/planner-protocol.schema.json`).
//!
//! One JSON object per line in each direction: the harness writes `hello`,
//! then one `observation` per simulation step, then `bye` on the child's
//! stdin; the planner answers `hello` with `ready` and every observation with
//! a `control`, a `trajectory` or an `error` on its stdout. Its stderr is
//! free-form logging; the harness keeps the last lines to explain failures.
//!
//! Coordinates are the scenario's local frame: metres, re-centred on the
//! scenario (not UTM/world coordinates), x/y as in the map, headings in
//! radians counter-clockwise from +x.
//!
//! # Failures
//!
//! A planner that cannot be started, exits, stays silent past its timeout,
//! prints something that is not a protocol message, or reports an `error`,
//! fails with a [`PlannerError`] that names it and says which of these
//! happened (exit status and the tail of its stderr for a crash, the timeout
//! in ms for a hang, the first 200 characters of a bad line). The simulator
//! then ends that rollout with `Termination::PlannerFailed`. The process is
//! killed at once, and every later call returns the same error without
//! touching a process, until the next rollout starts (see below).
//!
//! # Lifetime
//!
//! [`ExternalPlanner::new`] starts nothing: the process is started on the
//! first [`Planner::plan`] call, whose observation provides the ego's size
//! and the step length for `hello`, so that a planner that cannot start
//! fails its rollout like any other planner failure. [`ExternalPlanner::start`]
//! starts and handshakes eagerly instead, for callers that want to fail
//! before simulating. A call whose observation has `time_s == 0` after
//! earlier calls is the start of a new rollout: the old process is told
//! `bye` and a fresh one is started, so no planner state (or failure) leaks
//! from one rollout into the next. Dropping the planner sends `bye`, closes
//! stdin, waits up to a second for the process to exit and then kills it;
//! the process is always reaped (no zombies).
//!
//! Only the planner's own process is managed: a wrapper script should `exec`
//! the real planner, or its children may outlive a kill.
//!
//! # Determinism
//!
//! Messages are a pure function of the observation (numbers formatted by
//! `serde_json`, maps in id order). Wall-clock time only decides whether a
//! timeout ran out.

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, SyncSender, TryRecvError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{Observation, Planner, PlannerError, PlannerOutput, TrajectoryPoint};
use crate::geometry::{Point2, Polyline, Vector2};
use crate::map::{RoadMap, SignalState};
use crate::motion::Action;
use crate::motion::tokens::SIM_DT_S;
use crate::scenario::{AgentKind, AgentState};

/// The protocol version this harness speaks (`protocol` in `hello` and `ready`).
pub const PROTOCOL_VERSION: u32 = 1;

/// Map elements (lane centrelines, road edges) are sent only where they lie
/// within this distance of the ego's centre, m.
pub const MAP_RADIUS_M: f64 = 60.0;

/// Polylines in observations are resampled at equal arc-length steps of at
/// most this, m: dense recorded maps are thinned and long straight segments
/// filled in, so messages stay small and planners need not interpolate.
pub const MAP_SPACING_M: f64 = 2.0;

/// Length of the `route` hint ahead of the ego, m.
pub const ROUTE_LENGTH_M: f64 = 100.0;

/// How far from the ego its lane is searched for the route hint, m.
const ROUTE_LANE_SEARCH_M: f64 = 10.0;
/// Lanes followed at most for the route hint (guards against zero-length
/// successor cycles in imported maps).
const ROUTE_MAX_LANES: usize = 64;
/// Characters of an offending line quoted in an error.
const QUOTE_CHARS: usize = 200;
/// Stderr lines kept for error messages.
const STDERR_LINES: usize = 20;
/// Characters kept of each stderr line.
const STDERR_LINE_CHARS: usize = 500;
/// Bytes read of one stdout line before it is refused: a planner that
/// prints without newlines must not exhaust the harness's memory.
const MAX_REPLY_BYTES: usize = 16 << 20;
/// Stdout lines queued between the reader thread and the harness.
const STDOUT_QUEUE_LINES: usize = 64;
/// Bytes read of one stderr line (the rest is skipped).
const MAX_STDERR_LINE_BYTES: usize = 4096;
/// Time a process gets to exit after `bye` before it is killed.
const BYE_GRACE: Duration = Duration::from_millis(1000);
/// Time a process that closed its stdout gets to report an exit status.
const EXIT_STATUS_WAIT: Duration = Duration::from_millis(1000);
/// Time the stderr reader gets to drain the last lines of a dead process.
const STDERR_DRAIN_WAIT: Duration = Duration::from_millis(500);
/// Time the I/O threads get to finish after the process is gone; a
/// grandchild holding the pipes open must not block the harness.
const THREAD_JOIN_WAIT: Duration = Duration::from_millis(200);

fn default_step_timeout_ms() -> u64 {
    1000
}

fn default_startup_timeout_ms() -> u64 {
    10_000
}

/// How to run an external planner.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExternalPlannerConfig {
    /// Name used in reports and error messages.
    pub name: String,
    /// Program to run: looked up on `PATH` unless it contains a slash.
    pub command: String,
    /// Arguments passed to the program.
    #[serde(default)]
    pub args: Vec<String>,
    /// Working directory of the process; the harness's own when absent.
    #[serde(default)]
    pub working_dir: Option<PathBuf>,
    /// Extra environment variables, `[name, value]` pairs set in this order
    /// on top of the harness's environment.
    #[serde(default)]
    pub env: Vec<(String, String)>,
    /// Time allowed to answer one observation, ms (from the observation
    /// being handed to the writer to the reply line arriving).
    #[serde(default = "default_step_timeout_ms")]
    pub step_timeout_ms: u64,
    /// Time allowed from starting the process to its `ready` line, ms
    /// (planners may import large libraries or load models first).
    #[serde(default = "default_startup_timeout_ms")]
    pub startup_timeout_ms: u64,
}

impl ExternalPlannerConfig {
    /// A config with no arguments, environment or working directory and the
    /// default timeouts (1000 ms per step, 10 000 ms to start).
    pub fn new(name: impl Into<String>, command: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            command: command.into(),
            args: Vec::new(),
            working_dir: None,
            env: Vec::new(),
            step_timeout_ms: default_step_timeout_ms(),
            startup_timeout_ms: default_startup_timeout_ms(),
        }
    }
}

/// A planner running in a child process, spoken to in JSON lines.
pub struct ExternalPlanner {
    config: ExternalPlannerConfig,
    /// The running process, once started and until it fails or is replaced.
    process: Option<Process>,
    /// The name the process announced in `ready`.
    announced_name: Option<String>,
    /// The first failure of this rollout; returned by every later call.
    failure: Option<PlannerError>,
    /// `plan` calls so far, to recognise the start of a new rollout.
    calls: usize,
}

impl std::fmt::Debug for ExternalPlanner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ExternalPlanner")
            .field("config", &self.config)
            .field("pid", &self.pid())
            .field("announced_name", &self.announced_name)
            .field("failure", &self.failure)
            .finish()
    }
}

impl ExternalPlanner {
    /// A planner whose process starts on the first [`Planner::plan`] call.
    pub fn new(config: ExternalPlannerConfig) -> Self {
        Self { config, process: None, announced_name: None, failure: None, calls: 0 }
    }

    /// Starts the process now and completes the `hello`/`ready` handshake
    /// (announcing the simulator's step and this ego size).
    pub fn start(config: ExternalPlannerConfig, ego_length_m: f64, ego_width_m: f64) -> Result<Self, PlannerError> {
        let mut planner = Self::new(config);
        planner.launch(SIM_DT_S, ego_length_m, ego_width_m)?;
        Ok(planner)
    }

    /// The configuration it runs with.
    pub fn config(&self) -> &ExternalPlannerConfig {
        &self.config
    }

    /// The process id while a process is running (not before the start, not
    /// after a failure).
    pub fn pid(&self) -> Option<u32> {
        self.process.as_ref().map(|p| p.pid)
    }

    /// The name the process gave in its `ready` message, if any.
    pub fn announced_name(&self) -> Option<&str> {
        self.announced_name.as_deref()
    }

    /// The failure that ended this rollout for the planner, if any.
    pub fn failure(&self) -> Option<&PlannerError> {
        self.failure.as_ref()
    }

    /// The last lines the running process wrote to stderr, oldest first.
    pub fn stderr_tail(&self) -> Vec<String> {
        self.process.as_ref().map(|p| p.stderr_tail()).unwrap_or_default()
    }

    /// Starts the process and waits for `ready`; on failure the process is
    /// killed and the error recorded.
    fn launch(&mut self, dt_s: f64, ego_length_m: f64, ego_width_m: f64) -> Result<(), PlannerError> {
        let name = self.config.name.clone();
        let result = Process::spawn(&self.config).and_then(|mut process| {
            let hello = HarnessMessage::Hello {
                protocol: PROTOCOL_VERSION,
                dt_s,
                ego: EgoSize { length_m: ego_length_m, width_m: ego_width_m },
            };
            let during = "during startup";
            let timeout_ms = self.config.startup_timeout_ms;
            match process.exchange(&name, &hello, during, timeout_ms) {
                Ok(PlannerMessage::Ready { protocol, name: announced }) if protocol == PROTOCOL_VERSION => {
                    Ok((process, announced))
                }
                Ok(PlannerMessage::Ready { protocol, .. }) => Err(process.fail(PlannerError::Protocol {
                    planner: name.clone(),
                    during: during.into(),
                    message: format!(
                        "it speaks protocol version {protocol}; this harness speaks version {PROTOCOL_VERSION}"
                    ),
                })),
                Ok(PlannerMessage::Error { message }) => Err(process.fail(PlannerError::Reported {
                    planner: name.clone(),
                    during: during.into(),
                    message: message.unwrap_or_default(),
                })),
                Ok(other) => Err(process.fail(PlannerError::Protocol {
                    planner: name.clone(),
                    during: during.into(),
                    message: format!("expected `ready` in answer to `hello`, got `{}`", other.kind()),
                })),
                Err(e) => Err(process.fail(e)),
            }
        });
        match result {
            Ok((process, announced)) => {
                self.process = Some(process);
                self.announced_name = announced;
                Ok(())
            }
            Err(e) => {
                self.failure = Some(e.clone());
                Err(e)
            }
        }
    }

    /// Records a failure and kills the process at once: a planner that
    /// misbehaved gets no more observations, and a spinning one must not keep
    /// a core busy until the planner is dropped.
    fn fail(&mut self, error: PlannerError) -> PlannerError {
        if let Some(mut p) = self.process.take() {
            p.kill();
        }
        self.failure = Some(error.clone());
        error
    }

    /// Says `bye` to the current process (if any) and forgets this rollout.
    fn reset(&mut self) {
        if let Some(mut p) = self.process.take() {
            p.shutdown();
        }
        self.announced_name = None;
        self.failure = None;
    }

    /// One observation → reply round trip, validated into a planner output.
    fn step(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        let name = self.config.name.clone();
        let during = format!("at step {}", obs.step);
        let timeout_ms = self.config.step_timeout_ms;
        let Some(process) = self.process.as_mut() else {
            // Unreachable in practice (plan starts the process first); an
            // error rather than a panic all the same.
            return Err(PlannerError::NoOutput { step: obs.step, reason: format!("planner `{name}` is not running") });
        };
        let message = observation_message(obs);
        let reply = process.exchange(&name, &message, &during, timeout_ms)?;
        let protocol =
            |message: String| PlannerError::Protocol { planner: name.clone(), during: during.clone(), message };
        match reply {
            PlannerMessage::Control { accel_mps2, yaw_rate_radps } => {
                Ok(PlannerOutput::Control(Action { accel_mps2, yaw_rate_radps }))
            }
            PlannerMessage::Trajectory { points } => trajectory(&points, obs.dt_s).map_err(protocol),
            PlannerMessage::Error { message } => {
                Err(PlannerError::Reported { planner: name.clone(), during, message: message.unwrap_or_default() })
            }
            PlannerMessage::Ready { .. } => Err(protocol(
                "expected `control`, `trajectory` or `error` in answer to an observation, got `ready`".into(),
            )),
        }
    }
}

impl Planner for ExternalPlanner {
    fn name(&self) -> &str {
        &self.config.name
    }

    fn plan(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        // Rollouts start at time 0: a fresh process for each keeps planner
        // state and failures from leaking between rollouts.
        if obs.time_s == 0.0 && self.calls > 0 {
            self.reset();
        }
        self.calls += 1;
        if let Some(e) = &self.failure {
            return Err(e.clone());
        }
        if self.process.is_none() {
            self.launch(obs.dt_s, obs.ego_length_m, obs.ego_width_m)?;
        }
        self.step(obs).map_err(|e| self.fail(e))
    }
}

/// Trajectory points from the wire, checked: at least one point, times
/// positive, increasing and reaching the next step, speeds not negative.
fn trajectory(points: &[WirePoint], dt_s: f64) -> Result<PlannerOutput, String> {
    let last = points.last().ok_or("the trajectory has no points")?;
    let mut previous_t = 0.0;
    for (i, p) in points.iter().enumerate() {
        if p.t <= previous_t {
            return Err(format!(
                "trajectory point {i} has t = {} s; times must be positive and increasing (relative to the observation)",
                p.t
            ));
        }
        if p.speed_mps < 0.0 {
            return Err(format!("trajectory point {i} has speed_mps = {}; speeds must not be negative", p.speed_mps));
        }
        previous_t = p.t;
    }
    if last.t < dt_s - 1e-9 {
        return Err(format!("the trajectory ends at t = {} s, before the next step (t = {dt_s} s)", last.t));
    }
    Ok(PlannerOutput::Trajectory(
        points
            .iter()
            .map(|p| TrajectoryPoint {
                time_s: p.t,
                state: AgentState {
                    position: Point2::new(p.x, p.y),
                    heading_rad: p.heading_rad,
                    velocity_mps: Vector2::new(p.heading_rad.cos(), p.heading_rad.sin()) * p.speed_mps,
                },
            })
            .collect(),
    ))
}

// ---------------------------------------------------------------------------
// Wire messages. Their doc comments become the descriptions in the committed
// JSON Schema, so they are written for planner authors.

/// A message from the harness to the planner (one line on its stdin).
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
enum HarnessMessage {
    /// First message after the start. Answer with `ready` within the startup timeout.
    Hello {
        /// Protocol version the harness speaks (1).
        protocol: u32,
        /// Simulation step: time between two observations, s.
        dt_s: f64,
        /// The ego's box.
        ego: EgoSize,
    },
    /// The world at one simulation step. Answer with exactly one `control`,
    /// `trajectory` or `error` line within the step timeout.
    Observation {
        /// Step index in the scenario's numbering.
        step: usize,
        /// Time since the rollout started, s.
        time_s: f64,
        /// The ego's state and size.
        ego: WireEgo,
        /// Other road users within the ego's perception range, in track order.
        agents: Vec<WireAgent>,
        /// Map elements within 60 m of the ego.
        map: WireMap,
        /// Traffic-signal states now, per controlled lane.
        signals: Vec<WireSignal>,
        /// Hint: the centreline of the ego's current lane from the ego's
        /// projection onto it forward, following each lane's first successor,
        /// up to 100 m, sampled every 2 m or less ([x, y] in m). Empty when
        /// no lane within 10 m runs in the ego's direction.
        route: Vec<[f64; 2]>,
    },
    /// The rollout is over: exit (status 0). Stdin is closed right after;
    /// a process still alive 1 s later is killed.
    Bye,
}

/// A box size.
#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
struct EgoSize {
    /// Length, m.
    length_m: f64,
    /// Width, m.
    width_m: f64,
}

/// The ego at one step.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "EgoState")]
struct WireEgo {
    /// Box centre x, m (scenario frame).
    x: f64,
    /// Box centre y, m (scenario frame).
    y: f64,
    /// Heading, rad, counter-clockwise from +x, in (-π, π].
    heading_rad: f64,
    /// Speed (norm of the velocity), m/s.
    speed_mps: f64,
    /// Velocity x, m/s.
    vx: f64,
    /// Velocity y, m/s.
    vy: f64,
    /// Length, m.
    length_m: f64,
    /// Width, m.
    width_m: f64,
}

/// Another road user as the ego perceives it.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "Agent")]
struct WireAgent {
    /// Id from the scenario's source (stable within a rollout).
    id: String,
    /// Road-user type.
    kind: WireAgentKind,
    /// Box centre x, m.
    x: f64,
    /// Box centre y, m.
    y: f64,
    /// Heading, rad, counter-clockwise from +x.
    heading_rad: f64,
    /// Velocity x, m/s.
    vx: f64,
    /// Velocity y, m/s.
    vy: f64,
    /// Length, m.
    length_m: f64,
    /// Width, m.
    width_m: f64,
}

/// Road-user type.
#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
#[schemars(rename = "AgentKind")]
enum WireAgentKind {
    /// Car, truck, bus, motorcycle.
    Vehicle,
    /// Pedestrian.
    Pedestrian,
    /// Cyclist.
    Cyclist,
    /// Anything else (static objects, unknown).
    Other,
}

/// Map elements near the ego.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "Map")]
struct WireMap {
    /// Lanes with some part within 60 m of the ego, in id order.
    lanes: Vec<WireLane>,
    /// Road edges (kerbs, boundaries) with some part within 60 m of the ego,
    /// each a polyline of [x, y] points in m, the road on its left side.
    road_edges: Vec<Vec<[f64; 2]>>,
}

/// One lane near the ego.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "Lane")]
struct WireLane {
    /// Lane id (as in `signals[].lane`).
    id: i64,
    /// Centreline in the direction of travel, [x, y] in m, sampled every 2 m
    /// or less, clipped to the stretch within 60 m of the ego.
    centreline: Vec<[f64; 2]>,
    /// Speed limit, m/s, when the map gives one.
    speed_limit_mps: Option<f64>,
}

/// The state of the signal controlling one lane.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "Signal")]
struct WireSignal {
    /// Controlled lane id.
    lane: i64,
    /// Signal state.
    state: WireSignalState,
}

/// A traffic-signal state (stop = red, caution = yellow, go = green).
#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
#[schemars(rename = "SignalState")]
enum WireSignalState {
    /// Unknown or not observed.
    Unknown,
    /// Red arrow.
    ArrowStop,
    /// Yellow arrow.
    ArrowCaution,
    /// Green arrow.
    ArrowGo,
    /// Red.
    Stop,
    /// Yellow.
    Caution,
    /// Green.
    Go,
    /// Flashing red.
    FlashingStop,
    /// Flashing yellow.
    FlashingCaution,
}

impl From<SignalState> for WireSignalState {
    fn from(s: SignalState) -> Self {
        match s {
            SignalState::Unknown => Self::Unknown,
            SignalState::ArrowStop => Self::ArrowStop,
            SignalState::ArrowCaution => Self::ArrowCaution,
            SignalState::ArrowGo => Self::ArrowGo,
            SignalState::Stop => Self::Stop,
            SignalState::Caution => Self::Caution,
            SignalState::Go => Self::Go,
            SignalState::FlashingStop => Self::FlashingStop,
            SignalState::FlashingCaution => Self::FlashingCaution,
        }
    }
}

impl From<AgentKind> for WireAgentKind {
    fn from(k: AgentKind) -> Self {
        match k {
            AgentKind::Vehicle => Self::Vehicle,
            AgentKind::Pedestrian => Self::Pedestrian,
            AgentKind::Cyclist => Self::Cyclist,
            AgentKind::Other => Self::Other,
        }
    }
}

/// A message from the planner to the harness (one line on its stdout).
/// Unknown fields are ignored; every number must be finite (JSON has no
/// NaN or Infinity).
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
enum PlannerMessage {
    /// Answer to `hello`: the planner is ready for observations.
    Ready {
        /// Protocol version the planner speaks; must be 1.
        protocol: u32,
        /// The planner's own name, for logs.
        #[serde(default)]
        name: Option<String>,
    },
    /// Answer to an observation: a control applied for one step through the
    /// kinematic unicycle model (speed += accel·dt, clamped at 0; heading +=
    /// yaw_rate·dt; then move along the new heading). Not clipped.
    Control {
        /// Longitudinal acceleration, m/s² (negative brakes).
        accel_mps2: f64,
        /// Yaw rate, rad/s (positive turns left).
        yaw_rate_radps: f64,
    },
    /// Answer to an observation: planned states; the ego follows it exactly,
    /// taking the state interpolated at t = dt_s.
    Trajectory {
        /// Planned states, times positive and increasing, the last at t ≥ dt_s.
        points: Vec<WirePoint>,
    },
    /// The planner gives up: the rollout fails with this message.
    Error {
        /// Why.
        #[serde(default)]
        message: Option<String>,
    },
}

impl PlannerMessage {
    /// The `type` tag, for error messages.
    fn kind(&self) -> &'static str {
        match self {
            Self::Ready { .. } => "ready",
            Self::Control { .. } => "control",
            Self::Trajectory { .. } => "trajectory",
            Self::Error { .. } => "error",
        }
    }
}

/// A planned state.
#[derive(Debug, Clone, Copy, Deserialize, JsonSchema)]
#[schemars(rename = "TrajectoryPoint")]
struct WirePoint {
    /// Time after the observation, s (> 0).
    t: f64,
    /// Box centre x, m.
    x: f64,
    /// Box centre y, m.
    y: f64,
    /// Heading, rad, counter-clockwise from +x.
    heading_rad: f64,
    /// Speed along the heading, m/s (≥ 0).
    speed_mps: f64,
}

/// The JSON Schema (draft 2020-12) of every protocol message in both
/// directions, as committed in `docs/planner-protocol.schema.json`.
pub fn protocol_schema() -> serde_json::Value {
    let mut generator = schemars::generate::SchemaSettings::draft2020_12().into_generator();
    let to_planner = generator.subschema_for::<HarnessMessage>();
    let to_harness = generator.subschema_for::<PlannerMessage>();
    let defs = generator.take_definitions(true);
    serde_json::json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": format!("SaFeR planner protocol, version {PROTOCOL_VERSION}"),
        "description": "One JSON object per line. HarnessMessage: harness to planner (stdin). PlannerMessage: planner to harness (stdout). See docs/planner-protocol.md.",
        "oneOf": [to_planner, to_harness],
        "$defs": defs,
    })
}

// ---------------------------------------------------------------------------
// Observation encoding.

/// The `observation` message for one step.
fn observation_message(obs: &Observation<'_>) -> HarnessMessage {
    let ego = &obs.ego;
    let centre = ego.position;
    HarnessMessage::Observation {
        step: obs.step,
        time_s: obs.time_s,
        ego: WireEgo {
            x: centre.x,
            y: centre.y,
            heading_rad: ego.heading_rad,
            speed_mps: ego.speed_mps(),
            vx: ego.velocity_mps.x,
            vy: ego.velocity_mps.y,
            length_m: obs.ego_length_m,
            width_m: obs.ego_width_m,
        },
        agents: obs
            .agents
            .iter()
            .map(|a| WireAgent {
                id: a.id.0.clone(),
                kind: a.kind.into(),
                x: a.state.position.x,
                y: a.state.position.y,
                heading_rad: a.state.heading_rad,
                vx: a.state.velocity_mps.x,
                vy: a.state.velocity_mps.y,
                length_m: a.length_m,
                width_m: a.width_m,
            })
            .collect(),
        map: WireMap {
            lanes: obs
                .map
                .lanes
                .iter()
                .filter_map(|l| {
                    clip(&l.centreline, &centre, MAP_RADIUS_M).map(|centreline| WireLane {
                        id: l.id.0,
                        centreline,
                        speed_limit_mps: l.speed_limit_mps,
                    })
                })
                .collect(),
            road_edges: obs.map.road_edges.iter().filter_map(|e| clip(&e.polyline, &centre, MAP_RADIUS_M)).collect(),
        },
        signals: obs.signals.iter().map(|(lane, state)| WireSignal { lane: lane.0, state: (*state).into() }).collect(),
        route: route_ahead(obs.map, ego),
    }
}

/// Points at equal arc-length steps of at most [`MAP_SPACING_M`] over
/// `[s0, s0 + length]`, both ends included.
fn samples(line: &Polyline, s0: f64, length_m: f64) -> impl Iterator<Item = Point2> + '_ {
    let n = (length_m / MAP_SPACING_M).ceil().max(1.0) as usize;
    (0..=n).filter_map(move |k| line.sample(s0 + length_m * k as f64 / n as f64).map(|(p, _)| p))
}

/// The stretch of `line` (resampled) from its first to its last sample
/// within `radius_m` of `centre`; `None` when no part is that close.
fn clip(line: &Polyline, centre: &Point2, radius_m: f64) -> Option<Vec<[f64; 2]>> {
    // The exact distance first: most of a large map is skipped unsampled.
    if line.project(centre)?.distance_m > radius_m {
        return None;
    }
    let points: Vec<Point2> = samples(line, 0.0, line.length_m()).collect();
    let near = |p: &&Point2| (*p - centre).norm() <= radius_m;
    let first = points.iter().position(|p| near(&p))?;
    let last = points.iter().rposition(|p| near(&p))?;
    Some(points[first..=last].iter().map(|p| [p.x, p.y]).collect())
}

/// The route hint: the ego's lane centreline ahead, following first
/// successors, up to [`ROUTE_LENGTH_M`].
fn route_ahead(map: &RoadMap, ego: &AgentState) -> Vec<[f64; 2]> {
    let mut route: Vec<[f64; 2]> = Vec::new();
    let Some(m) = map.nearest_lane(&ego.position, Some(ego.heading_rad), ROUTE_LANE_SEARCH_M) else {
        return route;
    };
    // nearest_lane prefers lanes in the ego's direction but falls back to
    // others; a route against the traffic would mislead.
    let forward = Vector2::new(ego.heading_rad.cos(), ego.heading_rad.sin());
    if m.projection.tangent.dot(&forward) <= 0.0 {
        return route;
    }
    let mut lane = &map.lanes[m.lane_index];
    let mut s0 = m.projection.arc_length_m;
    let mut remaining = ROUTE_LENGTH_M;
    for _ in 0..ROUTE_MAX_LANES {
        let take = (lane.centreline.length_m() - s0).max(0.0).min(remaining);
        for p in samples(&lane.centreline, s0, take) {
            // Consecutive lanes share their joining point: keep it once.
            if route.last().is_none_or(|q| (q[0] - p.x).hypot(q[1] - p.y) > 1e-6) {
                route.push([p.x, p.y]);
            }
        }
        remaining -= take;
        if remaining <= 1e-9 {
            break;
        }
        let Some(next) = lane.successors.first().and_then(|id| map.lane(*id)) else {
            break;
        };
        lane = next;
        s0 = 0.0;
    }
    route
}

// ---------------------------------------------------------------------------
// The process and its I/O threads.

/// What the stdout reader thread saw.
enum StdoutEvent {
    /// A complete line, without its line ending.
    Line(Vec<u8>),
    /// A line longer than [`MAX_REPLY_BYTES`]; its beginning.
    TooLong(Vec<u8>),
    /// Reading failed.
    Failed(String),
}

/// A running child process with its stdin writer and stdout/stderr readers.
/// Stdin is written on a thread so that a planner that stops reading can
/// only make the harness time out, never block it.
struct Process {
    child: Child,
    pid: u32,
    /// Lines for the stdin writer; dropping it closes the child's stdin.
    to_stdin: Option<Sender<String>>,
    /// Lines from stdout; disconnected at end of file.
    from_stdout: Receiver<StdoutEvent>,
    /// The last stderr lines.
    stderr_tail: Arc<Mutex<VecDeque<String>>>,
    /// Disconnects when the stderr reader has read everything.
    stderr_done: Receiver<()>,
    threads: Vec<JoinHandle<()>>,
    /// Exit status once reaped.
    exited: Option<ExitStatus>,
}

impl Process {
    /// Starts the configured command with piped stdin/stdout/stderr.
    fn spawn(config: &ExternalPlannerConfig) -> Result<Self, PlannerError> {
        let spawn_failed = |reason: String| PlannerError::SpawnFailed {
            planner: config.name.clone(),
            command: config.command.clone(),
            reason,
        };
        let mut command = Command::new(&config.command);
        command
            .args(&config.args)
            .envs(config.env.iter().map(|(k, v)| (k, v)))
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        if let Some(dir) = &config.working_dir {
            command.current_dir(dir);
        }
        let mut child = command.spawn().map_err(|e| {
            let place = config.working_dir.as_ref().map(|d| format!(" (working directory {})", d.display()));
            spawn_failed(format!("{e}{}", place.unwrap_or_default()))
        })?;
        let pid = child.id();
        let (Some(stdin), Some(stdout), Some(stderr)) = (child.stdin.take(), child.stdout.take(), child.stderr.take())
        else {
            let _ = child.kill();
            let _ = child.wait();
            return Err(spawn_failed("its standard streams could not be piped".into()));
        };
        let (to_stdin, stdin_rx) = mpsc::channel::<String>();
        // Bounded: a planner flooding stdout is held back by the pipe instead
        // of filling the harness's memory (it fails at its next step anyway).
        let (stdout_tx, from_stdout) = mpsc::sync_channel(STDOUT_QUEUE_LINES);
        let (stderr_done_tx, stderr_done) = mpsc::channel::<()>();
        let stderr_tail = Arc::new(Mutex::new(VecDeque::new()));
        let mut process = Process {
            child,
            pid,
            to_stdin: Some(to_stdin),
            from_stdout,
            stderr_tail: stderr_tail.clone(),
            stderr_done,
            threads: Vec::new(),
            exited: None,
        };
        // Thread names may not contain NUL (spawning would panic).
        let name = config.name.replace('\0', "?");
        let spawned = [
            std::thread::Builder::new()
                .name(format!("planner {name} stdin"))
                .spawn(move || write_lines(stdin, stdin_rx)),
            std::thread::Builder::new()
                .name(format!("planner {name} stdout"))
                .spawn(move || read_stdout(stdout, stdout_tx)),
            std::thread::Builder::new()
                .name(format!("planner {name} stderr"))
                .spawn(move || read_stderr(stderr, stderr_tail, stderr_done_tx)),
        ];
        for thread in spawned {
            match thread {
                Ok(handle) => process.threads.push(handle),
                Err(e) => {
                    process.kill();
                    return Err(spawn_failed(format!("could not start an I/O thread: {e}")));
                }
            }
        }
        Ok(process)
    }

    /// Sends `message` and waits up to `timeout_ms` for one reply line.
    fn exchange(
        &mut self,
        planner: &str,
        message: &HarnessMessage,
        during: &str,
        timeout_ms: u64,
    ) -> Result<PlannerMessage, PlannerError> {
        let protocol =
            |message: String| PlannerError::Protocol { planner: planner.into(), during: during.into(), message };
        // A line waiting before the question is asked is an answer to no
        // question (often debug output printed to stdout): the protocol
        // would be out of step from here on.
        loop {
            match self.from_stdout.try_recv() {
                Ok(StdoutEvent::Line(l)) if is_blank(&l) => continue,
                Ok(StdoutEvent::Line(l) | StdoutEvent::TooLong(l)) => {
                    return Err(protocol(format!(
                        "it printed a line nobody asked for: {} (stdout is for protocol messages only; log to stderr)",
                        quote(&l)
                    )));
                }
                Ok(StdoutEvent::Failed(e)) => return Err(protocol(format!("reading its stdout failed: {e}"))),
                Err(TryRecvError::Disconnected) => return Err(self.crashed(planner, during)),
                Err(TryRecvError::Empty) => break,
            }
        }
        let line = match serde_json::to_string(message) {
            Ok(mut line) => {
                line.push('\n');
                line
            }
            Err(e) => return Err(protocol(format!("the harness could not encode its message: {e}"))),
        };
        let deadline = Instant::now() + Duration::from_millis(timeout_ms);
        let sent = self.to_stdin.as_ref().is_some_and(|tx| tx.send(line).is_ok());
        if !sent {
            // The writer stopped: writing failed because stdin is closed.
            return Err(self.crashed(planner, during));
        }
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.from_stdout.recv_timeout(left) {
                Ok(StdoutEvent::Line(l)) if is_blank(&l) => continue,
                Ok(StdoutEvent::Line(l)) => return parse_reply(&l).map_err(protocol),
                Ok(StdoutEvent::TooLong(l)) => {
                    return Err(protocol(format!(
                        "it printed a line longer than {MAX_REPLY_BYTES} bytes: {}",
                        quote(&l)
                    )));
                }
                Ok(StdoutEvent::Failed(e)) => return Err(protocol(format!("reading its stdout failed: {e}"))),
                Err(RecvTimeoutError::Timeout) => {
                    return Err(PlannerError::Timeout { planner: planner.into(), during: during.into(), timeout_ms });
                }
                Err(RecvTimeoutError::Disconnected) => return Err(self.crashed(planner, during)),
            }
        }
    }

    /// The error for a process whose stdout (or stdin) closed: its exit
    /// status and the tail of its stderr.
    fn crashed(&mut self, planner: &str, during: &str) -> PlannerError {
        let what = match self.wait_exit(EXIT_STATUS_WAIT) {
            Some(status) => format!("exited with {status}"),
            None => {
                self.kill();
                "closed its stdout without exiting (killed)".into()
            }
        };
        // Disconnected = the reader saw end of file: the tail is complete.
        let _ = self.stderr_done.recv_timeout(STDERR_DRAIN_WAIT);
        PlannerError::Crashed { planner: planner.into(), what, during: during.into(), stderr_tail: self.stderr_tail() }
    }

    /// Kills the process (so it stops at once) and passes the error through.
    fn fail(&mut self, error: PlannerError) -> PlannerError {
        self.kill();
        error
    }

    fn stderr_tail(&self) -> Vec<String> {
        self.stderr_tail.lock().unwrap_or_else(|e| e.into_inner()).iter().cloned().collect()
    }

    /// Waits up to `timeout` for the process to exit; its status if it did.
    fn wait_exit(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let deadline = Instant::now() + timeout;
        let mut pause = Duration::from_millis(1);
        while self.exited.is_none() {
            match self.child.try_wait() {
                Ok(Some(status)) => self.exited = Some(status),
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(pause);
                    pause = (pause * 2).min(Duration::from_millis(20));
                }
                Ok(None) | Err(_) => break,
            }
        }
        self.exited
    }

    /// Kills and reaps the process, then lets the I/O threads finish.
    fn kill(&mut self) {
        self.to_stdin = None;
        if self.exited.is_none() {
            let _ = self.child.kill();
            if let Ok(status) = self.child.wait() {
                self.exited = Some(status);
            }
        }
        self.join_threads();
    }

    /// `bye`, close stdin, wait [`BYE_GRACE`], then kill.
    fn shutdown(&mut self) {
        if self.exited.is_none()
            && let Some(tx) = self.to_stdin.take()
            && let Ok(mut line) = serde_json::to_string(&HarnessMessage::Bye)
        {
            line.push('\n');
            // The writer sends it, then sees the channel closed and closes
            // the child's stdin.
            let _ = tx.send(line);
        }
        self.to_stdin = None;
        self.wait_exit(BYE_GRACE);
        self.kill();
    }

    /// Joins the I/O threads; ones still blocked after [`THREAD_JOIN_WAIT`]
    /// (a grandchild holding a pipe) are left to end with the pipe.
    fn join_threads(&mut self) {
        let deadline = Instant::now() + THREAD_JOIN_WAIT;
        while self.threads.iter().any(|t| !t.is_finished()) && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(1));
        }
        for t in std::mem::take(&mut self.threads) {
            if t.is_finished() {
                let _ = t.join();
            }
        }
    }
}

impl Drop for Process {
    fn drop(&mut self) {
        if self.exited.is_none() {
            self.shutdown();
        } else {
            self.join_threads();
        }
    }
}

/// Stdin writer: one line per message until the channel closes (then stdin
/// is closed by dropping it) or writing fails (the child closed its stdin).
fn write_lines(mut stdin: ChildStdin, lines: Receiver<String>) {
    for line in lines {
        if stdin.write_all(line.as_bytes()).and_then(|()| stdin.flush()).is_err() {
            break;
        }
    }
}

/// Stdout reader: forwards lines until end of file (dropping the sender
/// tells the harness) or until nobody listens.
fn read_stdout(stdout: impl Read, events: SyncSender<StdoutEvent>) {
    let mut reader = BufReader::new(stdout);
    loop {
        let mut line = Vec::new();
        let event = match read_line_limited(&mut reader, &mut line, MAX_REPLY_BYTES) {
            Ok(LineRead::Eof) => return,
            Ok(LineRead::Complete) => StdoutEvent::Line(line),
            Ok(LineRead::Truncated) => StdoutEvent::TooLong(line),
            Err(e) => StdoutEvent::Failed(e.to_string()),
        };
        let stop = matches!(event, StdoutEvent::Failed(_));
        if events.send(event).is_err() || stop {
            return;
        }
    }
}

/// Stderr reader: keeps the last [`STDERR_LINES`] lines; `done` is dropped
/// at end of file.
fn read_stderr(stderr: impl Read, tail: Arc<Mutex<VecDeque<String>>>, done: Sender<()>) {
    let mut reader = BufReader::new(stderr);
    loop {
        let mut line = Vec::new();
        match read_line_limited(&mut reader, &mut line, MAX_STDERR_LINE_BYTES) {
            Ok(LineRead::Eof) | Err(_) => break,
            Ok(LineRead::Complete | LineRead::Truncated) => {
                let mut tail = tail.lock().unwrap_or_else(|e| e.into_inner());
                tail.push_back(truncate_chars(&String::from_utf8_lossy(&line), STDERR_LINE_CHARS));
                while tail.len() > STDERR_LINES {
                    tail.pop_front();
                }
            }
        }
    }
    drop(done);
}

/// How a bounded line read ended.
enum LineRead {
    /// End of file before any byte.
    Eof,
    /// A whole line (or the last, unterminated one).
    Complete,
    /// The line was longer than the limit; `buf` holds its beginning and the
    /// rest was skipped.
    Truncated,
}

/// Reads one line into `buf` (without `\n` or `\r\n`), keeping at most
/// `limit` bytes of it.
fn read_line_limited(reader: &mut impl BufRead, buf: &mut Vec<u8>, limit: usize) -> std::io::Result<LineRead> {
    let mut truncated = false;
    let mut any = false;
    loop {
        let available = match reader.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if available.is_empty() {
            break;
        }
        any = true;
        let (chunk, used, end) = match available.iter().position(|&b| b == b'\n') {
            Some(i) => (&available[..i], i + 1, true),
            None => (available, available.len(), false),
        };
        let room = limit.saturating_sub(buf.len());
        truncated |= chunk.len() > room;
        buf.extend_from_slice(&chunk[..chunk.len().min(room)]);
        reader.consume(used);
        if end {
            break;
        }
    }
    if !any {
        return Ok(LineRead::Eof);
    }
    if buf.last() == Some(&b'\r') {
        buf.pop();
    }
    Ok(if truncated { LineRead::Truncated } else { LineRead::Complete })
}

fn is_blank(line: &[u8]) -> bool {
    line.iter().all(u8::is_ascii_whitespace)
}

/// Parses one reply line; the error says what is wrong and quotes it.
fn parse_reply(line: &[u8]) -> Result<PlannerMessage, String> {
    let text = String::from_utf8_lossy(line);
    if let Some(token) = non_finite_token(&text) {
        return Err(format!(
            "non-finite number `{token}` in {}: JSON has no NaN or Infinity, every number must be finite",
            quote(line)
        ));
    }
    serde_json::from_str::<PlannerMessage>(&text).map_err(|e| {
        let reason = e.to_string();
        if reason.contains("number out of range") {
            format!("non-finite number (out of the f64 range) in {}: {reason}", quote(line))
        } else if e.is_syntax() || e.is_eof() {
            format!(
                "a line that is not JSON ({reason}): {} (stdout is for protocol messages only; log to stderr)",
                quote(line)
            )
        } else {
            format!("not a valid protocol message ({reason}): {}", quote(line))
        }
    })
}

/// The first bare `NaN`, `Infinity` or `-Infinity` outside strings, as
/// Python's `json.dumps` writes them by default.
fn non_finite_token(text: &str) -> Option<&'static str> {
    let bytes = text.as_bytes();
    let (mut in_string, mut escaped) = (false, false);
    for (i, &b) in bytes.iter().enumerate() {
        if in_string {
            match (escaped, b) {
                (true, _) => escaped = false,
                (false, b'\\') => escaped = true,
                (false, b'"') => in_string = false,
                _ => {}
            }
            continue;
        }
        match b {
            b'"' => in_string = true,
            b'N' if bytes[i..].starts_with(b"NaN") => return Some("NaN"),
            b'-' if bytes[i..].starts_with(b"-Infinity") => return Some("-Infinity"),
            b'I' if bytes[i..].starts_with(b"Infinity") && (i == 0 || bytes[i - 1] != b'-') => {
                return Some("Infinity");
            }
            _ => {}
        }
    }
    None
}

/// The first [`QUOTE_CHARS`] characters of a line, in backticks.
fn quote(line: &[u8]) -> String {
    format!("`{}`", truncate_chars(&String::from_utf8_lossy(line), QUOTE_CHARS))
}

fn truncate_chars(s: &str, max: usize) -> String {
    match s.char_indices().nth(max) {
        Some((cut, _)) => format!("{}…", &s[..cut]),
        None => s.to_string(),
    }
}

/// The stderr part of a crash message (used by [`PlannerError::Crashed`]).
pub(crate) fn format_stderr_tail(lines: &[String]) -> String {
    if lines.is_empty() {
        "; it wrote nothing to stderr".into()
    } else {
        let mut s = format!("; the last {} lines of its stderr:", lines.len());
        for l in lines {
            s.push_str("\n  | ");
            s.push_str(l);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point2;
    use crate::map::templates::StraightRoad;
    use crate::map::{Lane, LaneKind, MapElementId};
    use crate::planners::PerceivedAgent;
    use crate::scenario::{AgentId, Scenario, ScenarioSource, Track, TrackIndex};
    use crate::sim::{Rollout, SimConfig, Simulation, Termination};

    fn script(file: &str) -> String {
        format!("{}/planners/{file}", env!("CARGO_MANIFEST_DIR"))
    }

    fn python(name: &str, file: &str, args: &[&str]) -> ExternalPlannerConfig {
        let mut c = ExternalPlannerConfig::new(name, "python3");
        c.args = std::iter::once(script(file)).chain(args.iter().map(|a| a.to_string())).collect();
        c
    }

    fn misbehaving(mode: &str, good_steps: usize) -> ExternalPlannerConfig {
        python(mode, "misbehaving_planner.py", &[mode, &good_steps.to_string()])
    }

    /// Reaped processes leave no `/proc` entry (zombies do).
    fn process_gone(pid: u32) -> bool {
        !std::path::Path::new(&format!("/proc/{pid}")).exists()
    }

    /// A 300 m straight road (template, lanes 0 and 1 along +x); the ego in
    /// lane 0 at x = 10 doing 10 m/s, a car stopped in lane 0 at x = 70
    /// throughout; 121 steps (12 s).
    fn stopped_car_ahead() -> Scenario {
        let map = StraightRoad {
            lanes: 2,
            oncoming_lanes: 0,
            lane_width_m: 3.5,
            length_m: 300.0,
            speed_limit_mps: Some(13.9),
        }
        .build();
        let track = |id: &str, x0: f64, v: f64| Track {
            id: AgentId(id.into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            states: (0..121)
                .map(|k| {
                    Some(AgentState {
                        position: Point2::new(x0 + v * 0.1 * k as f64, 1.75),
                        heading_rad: 0.0,
                        velocity_mps: Vector2::new(v, 0.0),
                    })
                })
                .collect(),
        };
        Scenario::new(
            "external-stopped-car-ahead",
            ScenarioSource::authored("test"),
            0.1,
            map,
            vec![track("ego", 10.0, 10.0), track("stopped", 70.0, 0.0)],
        )
        .with_roles(TrackIndex(0), Some(TrackIndex(1)))
    }

    fn run(scenario: &Scenario, planner: &mut ExternalPlanner) -> Rollout {
        Simulation::new(scenario, SimConfig::default()).unwrap().run(planner)
    }

    /// The failure step and reason; panics (test failure) otherwise.
    fn failed(r: &Rollout) -> (usize, &str) {
        match &r.termination {
            Termination::PlannerFailed { step, reason } => (*step, reason.as_str()),
            other => panic!("expected a planner failure, got {other:?}"),
        }
    }

    #[test]
    fn example_planner_stops_behind_the_stopped_car() {
        let s = stopped_car_ahead();
        let mut planner = ExternalPlanner::new(python("example", "example_planner.py", &[]));
        let r = run(&s, &mut planner);
        assert_eq!(r.termination, Termination::Completed);
        assert_eq!(r.planner, "example");
        assert_eq!(planner.announced_name(), Some("example-pure-pursuit-idm"));
        assert!(r.ego_collision().is_none(), "{:?}", r.collisions);
        assert!(r.off_road.is_empty(), "{:?}", r.off_road);
        let closest = r.min_distance_to_ego.unwrap();
        assert!(closest.distance_m > 0.5 && closest.distance_m < 8.0, "{closest:?}");
        let last = r.states.last().unwrap()[0].unwrap();
        assert!(last.speed_mps() < 0.5, "ego still at {} m/s", last.speed_mps());
        assert!((last.position.y - 1.75).abs() < 0.1, "ego left its lane: {last:?}");
        assert!(planner.stderr_tail().iter().any(|l| l.contains("hello")), "{:?}", planner.stderr_tail());
        let pid = planner.pid().expect("running until dropped");
        drop(planner);
        assert!(process_gone(pid), "process {pid} outlived its planner");
    }

    #[test]
    fn rollouts_are_deterministic_and_each_gets_a_fresh_process() {
        let s = stopped_car_ahead();
        let mut planner = ExternalPlanner::new(python("example", "example_planner.py", &[]));
        let a = run(&s, &mut planner);
        let first = planner.pid().unwrap();
        let b = run(&s, &mut planner);
        let second = planner.pid().unwrap();
        assert_ne!(first, second, "the second rollout reused the first one's process");
        assert!(process_gone(first));
        assert_eq!(a.states, b.states);
    }

    #[test]
    fn crash_names_the_exit_status_and_the_stderr_tail() {
        let s = stopped_car_ahead();
        let mut planner = ExternalPlanner::start(misbehaving("crash", 3), 4.5, 2.0).unwrap();
        let pid = planner.pid().unwrap();
        let r = run(&s, &mut planner);
        let (step, reason) = failed(&r);
        assert_eq!(step, 3);
        assert!(reason.contains("external planner `crash`"), "{reason}");
        assert!(reason.contains("exited with exit status: 3 at step 3"), "{reason}");
        assert!(reason.contains("| Traceback (most recent call last):"), "{reason}");
        assert!(reason.contains("| misbehaving_planner: crashing at step 3"), "{reason}");
        assert!(planner.pid().is_none());
        assert!(process_gone(pid));
        assert_eq!(r.states.len(), 4, "steps 0..3 were simulated");
    }

    #[test]
    fn hang_times_out_after_the_step_timeout() {
        let s = stopped_car_ahead();
        let mut config = misbehaving("hang", 2);
        config.step_timeout_ms = 300;
        let mut planner = ExternalPlanner::start(config, 4.5, 2.0).unwrap();
        let pid = planner.pid().unwrap();
        let t0 = Instant::now();
        let r = run(&s, &mut planner);
        let elapsed = t0.elapsed();
        let (step, reason) = failed(&r);
        assert_eq!(step, 2);
        assert_eq!(reason, "external planner `hang` did not answer at step 2 within 300 ms");
        // 300 ms for the timeout, the rest for two good steps and the kill.
        assert!(elapsed >= Duration::from_millis(300) && elapsed < Duration::from_millis(1500), "{elapsed:?}");
        // Killed at the failure, not only when dropped.
        assert!(process_gone(pid), "the hung process {pid} is still there");
        // Dead for the rest of the rollout: the same error, at once.
        let obs_scenario = stopped_car_ahead();
        let obs = observation_at(&obs_scenario, 5);
        let t1 = Instant::now();
        assert_eq!(planner.plan(&obs).unwrap_err(), planner.failure().unwrap().clone());
        assert!(t1.elapsed() < Duration::from_millis(50));
        assert!(planner.failure().unwrap().to_string().contains("within 300 ms"));
    }

    #[test]
    fn garbage_is_quoted() {
        let r = run(&stopped_car_ahead(), &mut ExternalPlanner::new(misbehaving("garbage", 1)));
        let (step, reason) = failed(&r);
        assert_eq!(step, 1);
        assert!(reason.starts_with("external planner `garbage` broke the protocol at step 1: a line that is not JSON"));
        assert!(reason.contains("`this is not JSON, it is a planner talking to itself`"), "{reason}");
    }

    #[test]
    fn nan_is_reported_as_non_finite() {
        let r = run(&stopped_car_ahead(), &mut ExternalPlanner::new(misbehaving("nan", 0)));
        let (step, reason) = failed(&r);
        assert_eq!(step, 0);
        assert!(reason.contains("non-finite number `NaN`"), "{reason}");
        assert!(reason.contains(r#"`{"type": "control", "accel_mps2": NaN, "yaw_rate_radps": 0.0}`"#), "{reason}");
    }

    #[test]
    fn unknown_messages_and_missing_numbers_are_protocol_errors() {
        let s = stopped_car_ahead();
        let r = run(&s, &mut ExternalPlanner::new(misbehaving("unknown", 0)));
        let (_, reason) = failed(&r);
        assert!(reason.contains("not a valid protocol message (unknown variant `steer`"), "{reason}");
        let r = run(&s, &mut ExternalPlanner::new(misbehaving("missing", 0)));
        let (_, reason) = failed(&r);
        assert!(reason.contains("missing field `yaw_rate_radps`"), "{reason}");
        let r = run(&s, &mut ExternalPlanner::new(misbehaving("chatty", 0)));
        let (_, reason) = failed(&r);
        assert!(reason.contains("`debug: thinking...`") && reason.contains("log to stderr"), "{reason}");
    }

    #[test]
    fn reported_error_fails_with_its_message() {
        let r = run(&stopped_car_ahead(), &mut ExternalPlanner::new(misbehaving("error", 2)));
        assert_eq!(
            failed(&r),
            (2, "external planner `error` reported an error at step 2: planner lost its localisation")
        );
    }

    #[test]
    fn startup_failures_fail_the_first_step() {
        let s = stopped_car_ahead();
        let r = run(&s, &mut ExternalPlanner::new(misbehaving("bad-version", 0)));
        assert_eq!(
            failed(&r),
            (
                0,
                "external planner `bad-version` broke the protocol during startup: it speaks protocol version 2; this harness speaks version 1"
            )
        );
        let r = run(&s, &mut ExternalPlanner::new(misbehaving("exit-at-start", 0)));
        let (_, reason) = failed(&r);
        assert!(reason.contains("exited with exit status: 7 during startup"), "{reason}");
        assert!(reason.contains("| misbehaving_planner: giving up before hello"), "{reason}");

        let mut config = misbehaving("slow-start", 0);
        config.startup_timeout_ms = 200;
        let t0 = Instant::now();
        let err = ExternalPlanner::start(config, 4.5, 2.0).unwrap_err();
        assert!(t0.elapsed() < Duration::from_millis(1200), "{:?}", t0.elapsed());
        assert_eq!(err.to_string(), "external planner `slow-start` did not answer during startup within 200 ms");
    }

    #[test]
    fn missing_command_cannot_start() {
        let config = ExternalPlannerConfig::new("ghost", "no-such-planner-binary-3f9c");
        let r = run(&stopped_car_ahead(), &mut ExternalPlanner::new(config));
        let (step, reason) = failed(&r);
        assert_eq!(step, 0);
        assert!(
            reason.starts_with("external planner `ghost`: could not start `no-such-planner-binary-3f9c`: No such file"),
            "{reason}"
        );
    }

    #[test]
    fn drop_kills_a_planner_that_ignores_bye() {
        let planner = ExternalPlanner::start(misbehaving("deaf", 0), 4.5, 2.0).unwrap();
        let pid = planner.pid().unwrap();
        assert!(!process_gone(pid));
        let t0 = Instant::now();
        drop(planner);
        assert!(process_gone(pid), "process {pid} survived the drop");
        // bye, then the grace period, then the kill.
        assert!(t0.elapsed() >= BYE_GRACE && t0.elapsed() < BYE_GRACE * 2, "{:?}", t0.elapsed());
    }

    #[test]
    fn drop_after_bye_is_quick() {
        let planner = ExternalPlanner::start(python("example", "example_planner.py", &[]), 4.5, 2.0).unwrap();
        let pid = planner.pid().unwrap();
        let t0 = Instant::now();
        drop(planner);
        assert!(process_gone(pid));
        // It exited on `bye`: no grace period ran out, no kill was needed.
        assert!(t0.elapsed() < BYE_GRACE, "{:?}", t0.elapsed());
    }

    /// The observation the simulator would give at `step` of the recording.
    fn observation_at(s: &Scenario, step: usize) -> Observation<'_> {
        let state = |i: usize| s.tracks[i].states[step].unwrap();
        Observation {
            step,
            time_s: step as f64 * 0.1,
            dt_s: 0.1,
            ego: state(0),
            ego_length_m: 4.5,
            ego_width_m: 2.0,
            agents: vec![PerceivedAgent {
                id: s.tracks[1].id.clone(),
                kind: AgentKind::Vehicle,
                length_m: 4.5,
                width_m: 2.0,
                state: state(1),
            }],
            map: &s.map,
            signals: vec![(MapElementId(0), SignalState::Go)],
        }
    }

    #[test]
    fn observation_message_has_the_documented_fields() {
        let s = stopped_car_ahead();
        let mut obs = observation_at(&s, 0);
        obs.ego.position = Point2::new(100.0, 1.75);
        let v = serde_json::to_value(observation_message(&obs)).unwrap();
        assert_eq!(v["type"], "observation");
        assert_eq!(v["step"], 0);
        assert_eq!(v["ego"]["x"], 100.0);
        assert_eq!(v["ego"]["speed_mps"], 10.0);
        assert_eq!(v["ego"]["length_m"], 4.5);
        assert_eq!(
            v["agents"][0],
            serde_json::json!({"id": "stopped", "kind": "vehicle", "x": 70.0, "y": 1.75, "heading_rad": 0.0,
                "vx": 0.0, "vy": 0.0, "length_m": 4.5, "width_m": 2.0})
        );
        assert_eq!(v["signals"], serde_json::json!([{"lane": 0, "state": "go"}]));
        // Lanes 0 and 1 run 0..300 m: clipped to x in [40, 160], every 2 m.
        let lanes = v["map"]["lanes"].as_array().unwrap();
        assert_eq!(lanes.len(), 2);
        let centreline = lanes[0]["centreline"].as_array().unwrap();
        assert_eq!(centreline.len(), 61);
        assert_eq!(centreline[0], serde_json::json!([40.0, 1.75]));
        assert_eq!(centreline[60], serde_json::json!([160.0, 1.75]));
        assert_eq!(lanes[0]["speed_limit_mps"], 13.9);
        assert_eq!(v["map"]["road_edges"].as_array().unwrap().len(), 2);
        // Route: 100 m of lane 0 ahead of the ego.
        let route = v["route"].as_array().unwrap();
        assert_eq!(route.len(), 51);
        assert_eq!(route[0], serde_json::json!([100.0, 1.75]));
        assert_eq!(route[50], serde_json::json!([200.0, 1.75]));
        // Far from every lane: no map, no route.
        obs.ego.position = Point2::new(1000.0, 500.0);
        let v = serde_json::to_value(observation_message(&obs)).unwrap();
        assert_eq!(v["map"], serde_json::json!({"lanes": [], "road_edges": []}));
        assert_eq!(v["route"], serde_json::json!([]));
    }

    #[test]
    fn route_follows_the_first_successor_and_not_oncoming_lanes() {
        let lane = |id: i64, pts: &[(f64, f64)], successors: Vec<MapElementId>| Lane {
            kind: LaneKind::SurfaceStreet,
            successors,
            ..Lane::new(MapElementId(id), Polyline::new(pts.iter().map(|&(x, y)| Point2::new(x, y)).collect()))
        };
        let map = RoadMap::new(
            vec![
                lane(1, &[(0.0, 0.0), (50.0, 0.0)], vec![MapElementId(2), MapElementId(3)]),
                lane(2, &[(50.0, 0.0), (50.0, 200.0)], vec![]),
                lane(3, &[(50.0, 0.0), (50.0, -200.0)], vec![]),
            ],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
        );
        let ego = |x: f64, heading_rad: f64| AgentState {
            position: Point2::new(x, 0.0),
            heading_rad,
            velocity_mps: Vector2::zeros(),
        };
        let route = route_ahead(&map, &ego(40.0, 0.0));
        assert_eq!(route.first(), Some(&[40.0, 0.0]));
        assert_eq!(route.last(), Some(&[50.0, 90.0]));
        assert!(route.windows(2).all(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) <= MAP_SPACING_M + 1e-9));
        // Facing against the only lane: no route.
        assert!(route_ahead(&map, &ego(20.0, std::f64::consts::PI)).is_empty());
    }

    #[test]
    fn replies_are_parsed_strictly() {
        let ok = parse_reply(br#"{"type":"control","accel_mps2":-2,"yaw_rate_radps":0.5,"debug":"x"}"#).unwrap();
        assert!(matches!(ok, PlannerMessage::Control { accel_mps2: -2.0, yaw_rate_radps: 0.5 }));
        // NaN inside a string is just text.
        let ok = parse_reply(br#"{"type":"error","message":"got NaN and -Infinity"}"#).unwrap();
        assert!(matches!(ok, PlannerMessage::Error { message: Some(m) } if m == "got NaN and -Infinity"));
        for (line, token) in [
            (r#"{"type":"control","accel_mps2":Infinity,"yaw_rate_radps":0}"#, "`Infinity`"),
            (r#"{"type":"control","accel_mps2":-Infinity,"yaw_rate_radps":0}"#, "`-Infinity`"),
            (r#"{"type":"control","accel_mps2":1e400,"yaw_rate_radps":0}"#, "out of the f64 range"),
        ] {
            let e = parse_reply(line.as_bytes()).unwrap_err();
            assert!(e.starts_with("non-finite number") && e.contains(token), "{e}");
        }
        let e = parse_reply(br#"{"type":"control","accel_mps2":null,"yaw_rate_radps":0}"#).unwrap_err();
        assert!(e.contains("invalid type: null"), "{e}");
        let long = "x".repeat(500);
        let e = parse_reply(long.as_bytes()).unwrap_err();
        assert!(e.contains(&format!("`{}…`", "x".repeat(200))), "{e}");
        assert!(!e.contains(&"x".repeat(201)));
    }

    #[test]
    fn trajectories_are_checked_and_converted() {
        let p = |t: f64, x: f64, speed_mps: f64| WirePoint { t, x, y: 0.0, heading_rad: 0.0, speed_mps };
        match trajectory(&[p(0.1, 1.0, 10.0), p(0.2, 2.0, 10.0)], 0.1).unwrap() {
            PlannerOutput::Trajectory(points) => {
                assert_eq!(points[1].time_s, 0.2);
                assert_eq!(points[1].state.velocity_mps, Vector2::new(10.0, 0.0));
            }
            other => panic!("{other:?}"),
        }
        assert!(trajectory(&[], 0.1).unwrap_err().contains("no points"));
        assert!(trajectory(&[p(0.2, 1.0, 1.0), p(0.1, 2.0, 1.0)], 0.1).unwrap_err().contains("increasing"));
        assert!(trajectory(&[p(0.05, 1.0, 1.0)], 0.1).unwrap_err().contains("before the next step"));
        assert!(trajectory(&[p(0.1, 1.0, -1.0)], 0.1).unwrap_err().contains("must not be negative"));
    }

    #[test]
    fn stderr_keeps_a_bounded_tail_and_long_lines_are_cut() {
        let text: String = (0..100).map(|i| format!("line {i}\n")).collect::<String>() + &"y".repeat(10_000);
        let tail = Arc::new(Mutex::new(VecDeque::new()));
        let (done, done_rx) = mpsc::channel();
        read_stderr(text.as_bytes(), tail.clone(), done);
        assert!(matches!(done_rx.recv(), Err(mpsc::RecvError)));
        let tail = tail.lock().unwrap();
        assert_eq!(tail.len(), STDERR_LINES);
        assert_eq!(tail[0], "line 81");
        assert_eq!(tail[STDERR_LINES - 1].chars().count(), STDERR_LINE_CHARS + 1);

        let mut reader = BufReader::with_capacity(7, "abcdefghij\r\nxy".as_bytes());
        let mut buf = Vec::new();
        assert!(matches!(read_line_limited(&mut reader, &mut buf, 4).unwrap(), LineRead::Truncated));
        assert_eq!(buf, b"abcd");
        buf.clear();
        assert!(matches!(read_line_limited(&mut reader, &mut buf, 4).unwrap(), LineRead::Complete));
        assert_eq!(buf, b"xy");
        buf.clear();
        assert!(matches!(read_line_limited(&mut reader, &mut buf, 4).unwrap(), LineRead::Eof));
    }

    #[test]
    fn config_deserialises_with_defaults_and_rejects_unknown_fields() {
        let c: ExternalPlannerConfig =
            serde_json::from_str(r#"{"name":"p","command":"python3","env":[["A","1"]]}"#).unwrap();
        assert_eq!((c.step_timeout_ms, c.startup_timeout_ms), (1000, 10_000));
        assert_eq!(c.env, vec![("A".to_string(), "1".to_string())]);
        let e = serde_json::from_str::<ExternalPlannerConfig>(r#"{"name":"p","command":"x","timeout":5}"#);
        assert!(e.unwrap_err().to_string().contains("unknown field `timeout`"));
    }

    #[test]
    fn env_and_working_dir_reach_the_process() {
        // A planner that answers `ready` with its working directory and an
        // environment variable as its name.
        let mut c = ExternalPlannerConfig::new("env", "python3");
        c.args = vec![
            "-c".into(),
            "import json,os,sys; sys.stdin.readline(); print(json.dumps({'type':'ready','protocol':1,'name':os.getcwd()+'|'+os.environ['SAFER_TEST']}), flush=True); sys.stdin.readline()".into(),
        ];
        c.working_dir = Some(std::env::temp_dir());
        c.env = vec![("SAFER_TEST".into(), "42".into())];
        let planner = ExternalPlanner::start(c, 4.5, 2.0).unwrap();
        let dir = std::env::temp_dir().canonicalize().unwrap();
        assert_eq!(planner.announced_name(), Some(format!("{}|42", dir.display()).as_str()));
    }

    #[test]
    fn committed_schema_is_current() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/planner-protocol.schema.json");
        let generated = serde_json::to_string_pretty(&protocol_schema()).unwrap() + "\n";
        if std::env::var_os("SAFER_BLESS").is_some() {
            std::fs::write(path, &generated).unwrap();
        }
        let committed = std::fs::read_to_string(path).unwrap_or_default();
        assert!(
            committed == generated,
            "docs/planner-protocol.schema.json is out of date; regenerate it with \
             `SAFER_BLESS=1 cargo test --lib planners::external::tests::committed_schema_is_current`"
        );
    }
}
