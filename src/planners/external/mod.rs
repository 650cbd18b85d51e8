//! External planners: a child process that drives the ego by speaking the
//! JSON-lines planner protocol (version 1, revisions 1.0 to 1.3, specified
//! in `docs/planner-protocol.md`, schema in `docs/planner-protocol.schema.json`).
//!
//! One JSON object per line in each direction: the harness writes `hello`,
//! then one `observation` per simulation step, then `bye` on the child's
//! stdin; the planner answers `hello` with `ready` and every observation with
//! a `control`, a `trajectory` or an `error` on its stdout. A planner whose
//! `ready` says `protocol_minor: 1` also gets `prepare` (the whole map, once;
//! answered by `prepared`) and the stable route (`route`) instead of the
//! per-step map; one that does not is spoken to in 1.0. With
//! `protocol_minor: 2` every reply names the step it answers, and a reply
//! for another step fails the rollout (a step it names is checked in every
//! revision). 1.3 adds fields every planner gets (the timeouts in `hello`,
//! the ego's acceleration, yaw rate and steering angle in observations) and
//! the `debug` object a reply may carry, kept with the step in the
//! rollout ([`crate::sim::Rollout::planner_debug`]). A [`RolloutContext`]
//! (the scene and variant, given by the pipeline) fills `hello`'s 1.1 fields,
//! the `args`/`env` placeholders and the `SAFER_*` variables. Its stderr is
//! free-form logging; the harness keeps the last lines to explain failures
//! and the whole of it ([`ExternalPlanner::stderr_log`]) for the artefacts.
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
//! On Unix the process runs in its own process group, and ending it
//! (after `bye`, on a failure, on drop) kills the whole group: a wrapper
//! script need not `exec` the real planner, and helpers a planner starts do
//! not outlive it (unless they leave the group, e.g. with `setsid`). Its
//! own group does not receive the terminal's Ctrl-C, so the harness kills
//! the groups of live planners when SIGINT, SIGTERM or SIGHUP ends it.
//!
//! # Layout
//!
//! This module owns the [`ExternalPlanner`] session: starting and
//! handshaking (and the 1.1 `prepare`), one exchange per step, latching the
//! first failure, a fresh process per rollout. `context` holds what the
//! planner is told of the scene, `route` the 1.1 stable route, `wire` the
//! message types and the schema,
//! `encoding` turns observations into messages and replies into planner
//! outputs ([`decode_reply`]), `process` runs the child process and
//! its I/O, and `interrupt` ends live planners when the harness is
//! interrupted.
//!
//! # Determinism
//!
//! Messages are a pure function of the observation (numbers formatted by
//! `serde_json`, maps in id order). Wall-clock time only decides whether a
//! timeout ran out.

mod context;
mod encoding;
mod interrupt;
mod process;
mod road_edges;
mod wire;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::route::Route as StableRoute;
pub use super::route::{ROUTE_AHEAD_MIN_M, ROUTE_AHEAD_PLANNED_M, ROUTE_BEHIND_M, ROUTE_LEAVE_M};
use super::{Observation, Planner, PlannerError, PlannerOutput};
use crate::map::RoadMap;
use crate::motion::tokens::SIM_DT_S;
use crate::scenario::AgentState;
pub use context::{PLACEHOLDERS, RolloutContext, check_placeholders, expand};
pub use encoding::{MAP_RADIUS_M, MAP_SPACING_M, ROUTE_LENGTH_M, decode_reply};
use encoding::{
    ReplyError, check_debug, check_reply_step, full_map, observation_message, observation_message_v11, reply_output,
    road_edges,
};
use process::Process;
pub(crate) use process::format_stderr_tail;
use wire::{EgoSize, HarnessMessage, PlannerMessage};
pub use wire::{MAX_DEBUG_BYTES, PROTOCOL_MINOR, PROTOCOL_VERSION, protocol_schema};

/// The road edges the protocol sends for `map` (`prepare`'s
/// `map.road_edges`, and what 1.0 observations clip), as `[x, y]`
/// polylines with the road on their left: the map's edges resampled every
/// [`MAP_SPACING_M`] or less, less the stretches that are no outer
/// boundary of the drivable area (bounds with a lane right beyond them, an
/// intersection lane's bounds with the junction's lanes beyond them).
pub fn protocol_road_edges(map: &RoadMap) -> Vec<Vec<[f64; 2]>> {
    road_edges(map).iter().map(|e| e.points().iter().map(|p| [p.x, p.y]).collect()).collect()
}

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
    /// Arguments passed to the program; `{scenario}`, `{variant}`, `{seed}`,
    /// `{format}` and `{source}` are replaced when a rollout context is known.
    #[serde(default)]
    pub args: Vec<String>,
    /// Working directory of the process; the harness's own when absent.
    #[serde(default)]
    pub working_dir: Option<PathBuf>,
    /// Extra environment variables (name → value), set on top of the
    /// harness's environment and its `SAFER_*` variables; a name given here
    /// replaces theirs. Values take the placeholders of `args`.
    #[serde(default)]
    pub env: BTreeMap<String, String>,
    /// Time allowed to answer one observation, ms (from the observation
    /// being handed to the writer to the reply line arriving).
    #[serde(default = "default_step_timeout_ms")]
    pub step_timeout_ms: u64,
    /// Time allowed to answer the first observation, ms; `step_timeout_ms`
    /// when absent (a planner that compiles or warms up on its first plan).
    #[serde(default)]
    pub first_step_timeout_ms: Option<u64>,
    /// Time allowed from starting the process to its `ready` line (and, in
    /// protocol 1.1, from there to its `prepared` line), ms: planners may
    /// import large libraries or load models first.
    #[serde(default = "default_startup_timeout_ms")]
    pub startup_timeout_ms: u64,
}

impl ExternalPlannerConfig {
    /// A config with no arguments, environment or working directory and the
    /// default timeouts (1000 ms per step, the same for the first, 10 000 ms
    /// to start).
    pub fn new(name: impl Into<String>, command: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            command: command.into(),
            args: Vec::new(),
            working_dir: None,
            env: BTreeMap::new(),
            step_timeout_ms: default_step_timeout_ms(),
            first_step_timeout_ms: None,
            startup_timeout_ms: default_startup_timeout_ms(),
        }
    }

    /// The config with placeholders replaced and the context's `SAFER_*`
    /// variables added (under the configured ones).
    fn for_context(&self, context: Option<&RolloutContext>) -> Result<ExternalPlannerConfig, String> {
        let Some(c) = context else { return Ok(self.clone()) };
        let mut config = self.clone();
        config.args = self.args.iter().map(|a| c.expand(a)).collect::<Result<_, _>>()?;
        let mut env: BTreeMap<String, String> = c.env().into_iter().collect();
        for (k, v) in &self.env {
            env.insert(k.clone(), c.expand(v)?);
        }
        config.env = env;
        Ok(config)
    }
}

/// The protocol revision agreed with a running process (later revisions
/// order after earlier ones and keep what they brought).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Revision {
    /// 1.0: the map near the ego and the route hint in every observation.
    V1_0,
    /// 1.1: `prepare` with the whole map once, then the stable route.
    V1_1,
    /// 1.2: as 1.1, and every reply names the step it answers.
    V1_2,
    /// 1.3: as 1.2; the fields 1.3 adds are sent to every planner, so a
    /// planner asking for it learns only that the harness knows them.
    V1_3,
}

impl Revision {
    /// The revision a planner's `ready` asks for (above the harness's: the
    /// harness's).
    fn from_minor(protocol_minor: u32) -> Self {
        match protocol_minor {
            0 => Self::V1_0,
            1 => Self::V1_1,
            2 => Self::V1_2,
            _ => Self::V1_3,
        }
    }
}

/// A planner running in a child process, spoken to in JSON lines.
pub struct ExternalPlanner {
    config: ExternalPlannerConfig,
    /// The scene and variant, for `hello`, placeholders and the route.
    context: Option<RolloutContext>,
    /// The running process, once started and until it fails or is replaced.
    process: Option<Process>,
    /// The protocol revision agreed with the running process.
    revision: Revision,
    /// Whether the 1.1 `prepare` exchange is done for the running process.
    prepared: bool,
    /// The 1.1 route of this rollout.
    route: StableRoute,
    /// The ego's recorded positions (the route's guide at forks).
    recorded_path: Vec<crate::geometry::Point2>,
    /// Observations answered in this rollout (the first gets its own timeout).
    answered: usize,
    /// The name the process announced in `ready`.
    announced_name: Option<String>,
    /// The first failure of this rollout; returned by every later call.
    failure: Option<PlannerError>,
    /// `plan` calls so far, to recognise the start of a new rollout.
    calls: usize,
    /// Stderr of this rollout's processes that are gone.
    stderr_log: String,
    /// How long this rollout's process took to start and to prepare.
    startup: Option<super::PlannerStartup>,
    /// The `debug` object of the last reply, until the simulator takes it.
    debug: Option<serde_json::Value>,
    /// The road edges 1.0 observations clip, as the protocol sends them,
    /// worked out once per map (keyed by its address within a rollout).
    road_edges: Option<(usize, Vec<crate::geometry::Polyline>)>,
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
        Self {
            config,
            context: None,
            process: None,
            revision: Revision::V1_0,
            prepared: false,
            route: StableRoute::default(),
            recorded_path: Vec::new(),
            answered: 0,
            announced_name: None,
            failure: None,
            calls: 0,
            stderr_log: String::new(),
            startup: None,
            debug: None,
            road_edges: None,
        }
    }

    /// A planner that knows the scene and variant it drives: `hello` names
    /// them, placeholders in `args`/`env` are replaced, `SAFER_*` variables
    /// are set, and the 1.1 route follows the ego's recording at forks.
    pub fn with_context(config: ExternalPlannerConfig, context: RolloutContext) -> Self {
        let mut planner = Self::new(config);
        planner.recorded_path = context.recorded_path();
        planner.context = Some(context);
        planner
    }

    /// Starts the process now and completes the `hello`/`ready` handshake
    /// (announcing the simulator's step and this ego size).
    pub fn start(config: ExternalPlannerConfig, ego_length_m: f64, ego_width_m: f64) -> Result<Self, PlannerError> {
        let mut planner = Self::new(config);
        planner.launch(SIM_DT_S, ego_length_m, ego_width_m)?;
        Ok(planner)
    }

    /// Starts the process of a planner made [`Self::with_context`] now,
    /// through `hello` and (in 1.1) `prepare` with the scenario's map and
    /// the ego's start state, so that the first observation finds it ready.
    pub fn start_with_context(config: ExternalPlannerConfig, context: RolloutContext) -> Result<Self, PlannerError> {
        let scenario = context.scenario.clone();
        let track = scenario.track(context.ego);
        let start_state = track.state(context.start_step).copied();
        let mut planner = Self::with_context(config, context);
        let started = Instant::now();
        planner.launch(SIM_DT_S, track.length_m, track.width_m)?;
        if let Some(ego) = start_state {
            planner.prepare(&scenario.map, &ego, started)?;
        }
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

    /// The protocol revision agreed with the running process, as `1.0`,
    /// `1.1`, `1.2` or `1.3` (`None` before the handshake).
    pub fn protocol(&self) -> Option<&'static str> {
        self.process.as_ref().map(|_| match self.revision {
            Revision::V1_0 => "1.0",
            Revision::V1_1 => "1.1",
            Revision::V1_2 => "1.2",
            Revision::V1_3 => "1.3",
        })
    }

    /// The failure that ended this rollout for the planner, if any.
    pub fn failure(&self) -> Option<&PlannerError> {
        self.failure.as_ref()
    }

    /// The last lines the running process wrote to stderr, oldest first.
    pub fn stderr_tail(&self) -> Vec<String> {
        self.process.as_ref().map(|p| p.stderr_tail()).unwrap_or_default()
    }

    /// Everything this rollout's process wrote to stderr so far (up to
    /// 8 MiB), whether it is still running or not.
    pub fn stderr_log(&self) -> String {
        let mut log = self.stderr_log.clone();
        if let Some(p) = &self.process {
            log.push_str(&p.stderr_log());
        }
        log
    }

    /// Starts the process and waits for `ready`; on failure the process is
    /// killed and the error recorded.
    fn launch(&mut self, dt_s: f64, ego_length_m: f64, ego_width_m: f64) -> Result<(), PlannerError> {
        let clock = Instant::now();
        let name = self.config.name.clone();
        let during = "during startup";
        let config = self.config.for_context(self.context.as_ref()).map_err(|message| PlannerError::SpawnFailed {
            planner: name.clone(),
            command: self.config.command.clone(),
            reason: message,
        });
        let result = config.and_then(|config| Process::spawn(&config)).and_then(|mut process| {
            let c = self.context.as_ref();
            let hello = HarnessMessage::Hello {
                protocol: PROTOCOL_VERSION,
                protocol_minor: PROTOCOL_MINOR,
                dt_s,
                ego: EgoSize { length_m: ego_length_m, width_m: ego_width_m },
                step_timeout_s: self.config.step_timeout_ms as f64 / 1e3,
                first_step_timeout_s: self.config.first_step_timeout_ms.unwrap_or(self.config.step_timeout_ms) as f64
                    / 1e3,
                startup_timeout_s: self.config.startup_timeout_ms as f64 / 1e3,
                scenario: c.map(|c| c.wire_scenario()),
                origin_world: c.map(|c| [c.scenario.origin_world.x, c.scenario.origin_world.y]),
                horizon: c.map(|c| c.wire_horizon(dt_s)),
                goal: c.and_then(|c| c.wire_goal()),
            };
            let timeout_ms = self.config.startup_timeout_ms;
            match process.exchange(&name, &hello, during, timeout_ms) {
                Ok(PlannerMessage::Ready { protocol, protocol_minor, name: announced })
                    if protocol == PROTOCOL_VERSION =>
                {
                    let revision = Revision::from_minor(protocol_minor);
                    Ok((process, announced, revision))
                }
                Ok(PlannerMessage::Ready { protocol, .. }) => Err(process.fail(PlannerError::Protocol {
                    planner: name.clone(),
                    during: during.into(),
                    message: format!(
                        "it speaks protocol version {protocol}; this harness speaks version {PROTOCOL_VERSION}"
                    ),
                })),
                Ok(PlannerMessage::Error { message, .. }) => Err(process.fail(PlannerError::Reported {
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
            Ok((process, announced, revision)) => {
                self.process = Some(process);
                self.startup =
                    Some(super::PlannerStartup { launch_ms: clock.elapsed().as_secs_f64() * 1e3, prepare_ms: None });
                self.announced_name = announced;
                self.revision = revision;
                self.prepared = false;
                Ok(())
            }
            Err(e) => {
                self.failure = Some(e.clone());
                Err(e)
            }
        }
    }

    /// Protocol 1.1: sends `prepare` (the whole map) and waits for
    /// `prepared`, within what is left of the startup timeout counted from
    /// `started`. Nothing to do in 1.0 or when already prepared.
    fn prepare(&mut self, map: &RoadMap, ego: &AgentState, started: Instant) -> Result<(), PlannerError> {
        if self.revision < Revision::V1_1 || self.prepared {
            return Ok(());
        }
        let name = self.config.name.clone();
        let during = "during prepare";
        let elapsed_ms = started.elapsed().as_millis() as u64;
        let timeout_ms = self.config.startup_timeout_ms.saturating_sub(elapsed_ms).max(1);
        self.route = StableRoute::default();
        self.route.update(map, ego, &self.recorded_path);
        let message = HarnessMessage::Prepare { map: full_map(map) };
        let Some(process) = self.process.as_mut() else {
            return Ok(());
        };
        let clock = Instant::now();
        let reply = match process.exchange(&name, &message, during, timeout_ms) {
            Ok(PlannerMessage::Prepared {}) => Ok(()),
            Ok(PlannerMessage::Error { message, .. }) => Err(PlannerError::Reported {
                planner: name.clone(),
                during: during.into(),
                message: message.unwrap_or_default(),
            }),
            Ok(other) => Err(PlannerError::Protocol {
                planner: name.clone(),
                during: during.into(),
                message: format!("expected `prepared` in answer to `prepare`, got `{}`", other.kind()),
            }),
            Err(PlannerError::Timeout { planner, during, .. }) => {
                // Name the whole startup allowance: that is what ran out.
                Err(PlannerError::Timeout { planner, during, timeout_ms: self.config.startup_timeout_ms })
            }
            Err(e) => Err(e),
        };
        match reply {
            Ok(()) => {
                self.prepared = true;
                if let Some(startup) = self.startup.as_mut() {
                    startup.prepare_ms = Some(clock.elapsed().as_secs_f64() * 1e3);
                }
                Ok(())
            }
            Err(e) => Err(self.fail(e)),
        }
    }

    /// Kills the process (if any) and records `error` as this rollout's
    /// failure; it is returned by every later call until the next rollout.
    /// The process's stderr is kept for [`Self::stderr_log`].
    fn fail(&mut self, error: PlannerError) -> PlannerError {
        if let Some(mut p) = self.process.take() {
            p.kill();
            self.stderr_log.push_str(&p.stderr_log());
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
        self.answered = 0;
        self.stderr_log.clear();
        self.startup = None;
        self.debug = None;
        self.road_edges = None;
    }

    /// One observation → reply round trip, validated into a planner output.
    fn step(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        let name = self.config.name.clone();
        let during = format!("at step {}", obs.step);
        let timeout_ms = match (self.answered, self.config.first_step_timeout_ms) {
            (0, Some(first)) => first,
            _ => self.config.step_timeout_ms,
        };
        let message = match self.revision {
            Revision::V1_0 => {
                let key = std::ptr::from_ref(obs.map) as usize;
                if self.road_edges.as_ref().is_none_or(|(k, _)| *k != key) {
                    self.road_edges = Some((key, road_edges(obs.map)));
                }
                let edges = self.road_edges.as_ref().map_or(&[][..], |(_, e)| e.as_slice());
                observation_message(obs, edges)
            }
            Revision::V1_1 | Revision::V1_2 | Revision::V1_3 => {
                let s = self.route.update(obs.map, &obs.ego, &self.recorded_path);
                observation_message_v11(obs, &self.route, s)
            }
        };
        let Some(process) = self.process.as_mut() else {
            // Unreachable in practice (plan starts the process first); an
            // error rather than a panic all the same.
            return Err(PlannerError::NoOutput { step: obs.step, reason: format!("planner `{name}` is not running") });
        };
        let reply = process.exchange(&name, &message, &during, timeout_ms)?;
        self.answered += 1;
        let tagged = self.revision >= Revision::V1_2;
        let checked = check_reply_step(&reply, obs.step, tagged).and_then(|()| check_debug(&reply));
        self.debug = checked.is_ok().then(|| reply.debug().cloned()).flatten();
        checked.and_then(|()| reply_output(reply, obs.dt_s)).map_err(|e| match e {
            ReplyError::Protocol(message) => PlannerError::Protocol { planner: name, during, message },
            ReplyError::Reported(message) => PlannerError::Reported { planner: name, during, message },
        })
    }
}

impl Planner for ExternalPlanner {
    fn startup(&self) -> Option<super::PlannerStartup> {
        self.startup
    }

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
        self.debug = None;
        if let Some(e) = &self.failure {
            return Err(e.clone());
        }
        let started = Instant::now();
        if self.process.is_none() {
            self.launch(obs.dt_s, obs.ego_length_m, obs.ego_width_m)?;
        }
        // 1.1: once per process (a no-op in 1.0 and once prepared).
        self.prepare(obs.map, &obs.ego, started)?;
        self.step(obs).map_err(|e| self.fail(e))
    }

    fn take_debug(&mut self) -> Option<serde_json::Value> {
        self.debug.take()
    }

    fn end_rollout(&mut self) -> Option<String> {
        if let Some(mut p) = self.process.take() {
            // `bye`, wait for the exit, join the reader threads: the log is
            // then complete.
            p.shutdown();
            self.stderr_log.push_str(&p.stderr_log());
        }
        Some(self.stderr_log.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point2;
    use crate::geometry::Vector2;
    use crate::map::templates::StraightRoad;
    use crate::map::{MapElementId, SignalState};
    use crate::planners::PerceivedAgent;
    use crate::scenario::{AgentId, Scenario, ScenarioSource, Track, TrackIndex};
    use crate::scenario::{AgentKind, AgentState};
    use crate::sim::{Rollout, SimConfig, Simulation, Termination};
    use process::BYE_GRACE;
    use std::time::{Duration, Instant};

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

    /// The observation the simulator would give at `step` of the recording.
    pub(super) fn observation_at(s: &Scenario, step: usize) -> Observation<'_> {
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
            signals: vec![(MapElementId(0), SignalState::Go)],
            ..Observation::new(&s.map, state(0))
        }
    }

    /// Reaped processes leave no `/proc` entry (zombies do).
    fn process_gone(pid: u32) -> bool {
        !std::path::Path::new(&format!("/proc/{pid}")).exists()
    }

    /// A 300 m straight road (template, lanes 0 and 1 along +x); the ego in
    /// lane 0 at x = 10 doing 10 m/s, a car stopped in lane 0 at x = 70
    /// throughout; 121 steps (12 s).
    pub(super) fn stopped_car_ahead() -> Scenario {
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

    fn probe(args: &[&str]) -> ExternalPlannerConfig {
        let mut c = ExternalPlannerConfig::new("probe", "python3");
        let script = format!("{}/tests/fixtures/planners/probe_planner.py", env!("CARGO_MANIFEST_DIR"));
        c.args = std::iter::once(script).chain(args.iter().map(|a| a.to_string())).collect();
        c
    }

    fn context(s: &Scenario) -> RolloutContext {
        RolloutContext {
            scenario: std::sync::Arc::new(s.clone()),
            ego: TrackIndex(0),
            start_step: 0,
            end_step: s.num_steps() - 1,
            variant: Some("probe-suite::external-stopped-car-ahead::seed-3".into()),
            // A variant seed above 2^53, as most are.
            seed: Some(0xfedc_ba98_7654_3210),
        }
    }

    /// The probe's reports (`probe: {...}` stderr lines), in order.
    /// What the probe planner reported, read after the rollout ended (the
    /// process has exited, so every line it wrote is in).
    fn reports(planner: &mut ExternalPlanner) -> Vec<serde_json::Value> {
        Planner::end_rollout(planner)
            .unwrap_or_default()
            .lines()
            .filter_map(|l| l.strip_prefix("probe: "))
            .map(|l| serde_json::from_str(l).unwrap())
            .collect()
    }

    #[test]
    fn protocol_1_1_names_the_scene_in_hello_and_sends_the_map_once() {
        let s = stopped_car_ahead();
        let mut planner = ExternalPlanner::with_context(probe(&[]), context(&s));
        let r = run(&s, &mut planner);
        assert_eq!(r.termination, Termination::Completed);
        assert_eq!(planner.protocol(), Some("1.1"));
        let reports = reports(&mut planner);
        let hello = &reports[0]["message"];
        assert_eq!(hello["protocol"], 1);
        assert_eq!(hello["protocol_minor"], 3);
        // 1.3: the time budget as the harness enforces it, in seconds.
        assert_eq!(hello["step_timeout_s"], 1.0);
        assert_eq!(hello["first_step_timeout_s"], 1.0);
        assert_eq!(hello["startup_timeout_s"], 10.0);
        assert_eq!(hello["scenario"]["id"], "external-stopped-car-ahead");
        assert_eq!(hello["scenario"]["format"], "authored");
        assert_eq!(hello["scenario"]["variant"], "probe-suite::external-stopped-car-ahead::seed-3");
        // Its top 53 bits: exact in every JSON reader, JavaScript's included.
        assert_eq!(hello["scenario"]["seed"], 0xfedc_ba98_7654_3210_u64 >> 11);
        assert!(hello["scenario"]["seed"].as_u64().unwrap() < 1 << 53);
        assert_eq!(hello["origin_world"], serde_json::json!([0.0, 0.0]));
        assert_eq!(
            hello["horizon"],
            serde_json::json!({"start_step": 0, "steps": 120, "dt_s": 0.1, "duration_s": 12.0})
        );
        assert_eq!(hello["goal"]["x"], 10.0 + 12.0 * 10.0);
        // The map exactly once, before the first observation, with links and ids.
        let kinds: Vec<&str> = reports.iter().map(|r| r["type"].as_str().unwrap()).collect();
        assert_eq!(kinds.iter().filter(|k| **k == "prepare").count(), 1);
        assert_eq!(kinds[1], "prepare");
        assert_eq!(kinds.iter().filter(|k| **k == "observation").count(), 120);
        assert_eq!(reports[1]["lanes"], 2);
        for key in ["successors", "left_neighbours", "right_boundary", "speed_limit_mps", "width_m"] {
            assert!(reports[1]["lane_keys"].as_array().unwrap().iter().any(|k| k == key), "{key}");
        }
        // Observations: no map, a stable route of 20 m behind + the rest of the road ahead.
        let observations: Vec<&serde_json::Value> = reports.iter().filter(|r| r["type"] == "observation").collect();
        for o in &observations {
            assert!(!o["keys"].as_array().unwrap().iter().any(|k| k == "map"), "{o}");
            assert_eq!(o["route_revision"], 0, "{o}");
            assert_eq!(o["route_first"], observations[0]["route_first"], "the route moved: {o}");
        }
        assert_eq!(observations[0]["route_first"], serde_json::json!([[0.0, 1.75]]));
        assert_eq!(observations[0]["route_length_m"], 300.0);
        assert_eq!(observations[0]["route_s_m"], 10.0);
        assert_eq!(observations[10]["route_s_m"], 20.0);
    }

    #[test]
    fn a_1_0_planner_gets_no_prepare_and_the_map_in_every_observation() {
        let s = stopped_car_ahead();
        let mut planner = ExternalPlanner::with_context(probe(&["--minor", "0"]), context(&s));
        let r = run(&s, &mut planner);
        assert_eq!(r.termination, Termination::Completed);
        assert_eq!(planner.protocol(), Some("1.0"));
        let reports = reports(&mut planner);
        assert!(reports.iter().all(|r| r["type"] != "prepare"));
        let first = reports.iter().find(|r| r["type"] == "observation").unwrap();
        assert!(first["keys"].as_array().unwrap().iter().any(|k| k == "map"), "{first}");
        assert!(first["route_revision"].is_null());
        // The 1.0 hint: 100 m from the ego.
        assert_eq!(first["route_length_m"], 100.0);
    }

    #[test]
    fn a_slow_first_answer_passes_with_first_step_timeout_ms_and_fails_without() {
        let s = stopped_car_ahead();
        let r = run(&s, &mut ExternalPlanner::with_context(probe(&["--sleep-first", "2"]), context(&s)));
        assert_eq!(failed(&r), (0, "external planner `probe` did not answer at step 0 within 1000 ms"));
        let mut config = probe(&["--sleep-first", "2"]);
        config.first_step_timeout_ms = Some(4000);
        let r = run(&s, &mut ExternalPlanner::with_context(config, context(&s)));
        assert_eq!(r.termination, Termination::Completed);
    }

    #[test]
    fn a_slow_prepare_counts_against_the_startup_timeout() {
        let s = stopped_car_ahead();
        let mut config = probe(&["--sleep-prepare", "1.5"]);
        config.startup_timeout_ms = 1000;
        let err = ExternalPlanner::start_with_context(config.clone(), context(&s)).unwrap_err();
        assert_eq!(err.to_string(), "external planner `probe` did not answer during prepare within 1000 ms");
        config.startup_timeout_ms = 5000;
        let mut planner = ExternalPlanner::start_with_context(config, context(&s)).unwrap();
        assert_eq!(run(&s, &mut planner).termination, Termination::Completed);
    }

    #[test]
    fn placeholders_env_and_working_dir_reach_the_process() {
        let s = stopped_car_ahead();
        let tmp = tempfile::Builder::new().prefix("safer-probe-cwd-").tempdir().unwrap();
        let dir = tmp.path().to_path_buf();
        let mut config = probe(&["--scene={scenario}", "{seed}", "{{x}}", "{source}"]);
        config.working_dir = Some(dir.clone());
        config.env.insert("PROBE_VARIANT".into(), "v={variant}".into());
        config.env.insert("SAFER_SEED".into(), "overridden".into());
        let mut planner = ExternalPlanner::with_context(config, context(&s));
        run(&s, &mut planner);
        let hello = reports(&mut planner).into_iter().next().unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        // The scene file as an absolute path: the planner runs elsewhere.
        let source = std::path::absolute(&s.source.path).unwrap().display().to_string();
        assert!(!s.source.path.is_absolute(), "the fixture's path is relative: {}", s.source.path.display());
        let seed = (0xfedc_ba98_7654_3210_u64 >> 11).to_string();
        assert_eq!(hello["args"], serde_json::json!(["--scene=external-stopped-car-ahead", seed, "{x}", source]));
        assert_eq!(hello["message"]["scenario"]["source_file"], source);
        assert_eq!(hello["env"]["SAFER_SOURCE"], source);
        assert_eq!(std::path::Path::new(hello["cwd"].as_str().unwrap()), dir.canonicalize().unwrap_or(dir.clone()));
        let env = &hello["env"];
        assert_eq!(env["PROBE_VARIANT"], "v=probe-suite::external-stopped-car-ahead::seed-3");
        assert_eq!(env["SAFER_SCENARIO"], "external-stopped-car-ahead");
        assert_eq!(env["SAFER_VARIANT"], "probe-suite::external-stopped-car-ahead::seed-3");
        assert_eq!(env["SAFER_SEED"], "overridden", "the spec's env wins over the harness's");
        assert_eq!(env["SAFER_FORMAT"], "authored");
        assert_eq!(env["SAFER_PROTOCOL"], "1.3");
    }

    #[test]
    fn hello_gives_the_configured_timeouts_and_1_3_is_negotiated() {
        let s = stopped_car_ahead();
        let mut config = probe(&["--minor", "3"]);
        config.step_timeout_ms = 250;
        config.first_step_timeout_ms = Some(4500);
        config.startup_timeout_ms = 30_000;
        let mut planner = ExternalPlanner::with_context(config, context(&s));
        assert_eq!(run(&s, &mut planner).termination, Termination::Completed);
        assert_eq!(planner.protocol(), Some("1.3"));
        let hello = &reports(&mut planner)[0]["message"];
        assert_eq!(
            (&hello["step_timeout_s"], &hello["first_step_timeout_s"], &hello["startup_timeout_s"]),
            (&serde_json::json!(0.25), &serde_json::json!(4.5), &serde_json::json!(30.0))
        );
        // A later revision than the harness's is spoken to as the harness's;
        // 1.2 stays 1.2.
        for (minor, spoken) in [("9", "1.3"), ("2", "1.2")] {
            let mut planner = ExternalPlanner::with_context(probe(&["--minor", minor]), context(&s));
            assert_eq!(run(&s, &mut planner).termination, Termination::Completed);
            assert_eq!(planner.protocol(), Some(spoken), "ready with protocol_minor {minor}");
        }
    }

    #[test]
    fn the_ego_state_carries_the_applied_acceleration_yaw_rate_and_steering() {
        let s = stopped_car_ahead();
        let config = probe(&["--minor", "3", "--accel", "-1.5", "--yaw-rate", "0.05"]);
        let mut planner = ExternalPlanner::with_context(config, context(&s));
        let sim = SimConfig { end_step: Some(30), ..SimConfig::default() };
        let r = Simulation::new(&s, sim).unwrap().run(&mut planner);
        assert_eq!(r.termination, Termination::Completed);
        let egos: Vec<serde_json::Value> = reports(&mut planner)
            .into_iter()
            .filter(|r| r["type"] == "observation")
            .map(|r| r["ego"].clone())
            .collect();
        assert_eq!(egos.len(), 30);
        // The rollout starts at step 0: nothing before it.
        assert_eq!((&egos[0]["accel_mps2"], &egos[0]["yaw_rate_radps"]), (&0.0.into(), &0.0.into()));
        assert_eq!(egos[0]["steering_angle_rad"], 0.0);
        for (k, ego) in egos.iter().enumerate().skip(1) {
            let number = |key: &str| ego[key].as_f64().unwrap_or_else(|| panic!("step {k}: no {key} in {ego}"));
            assert!((number("accel_mps2") + 1.5).abs() < 1e-9, "step {k}: {ego}");
            assert!((number("yaw_rate_radps") - 0.05).abs() < 1e-9, "step {k}: {ego}");
            // Left turn, positive; the bicycle's angle for that curvature.
            let expected = (3.0 * 0.05 / number("speed_mps")).atan();
            assert!((number("steering_angle_rad") - expected).abs() < 1e-9, "step {k}: {ego}");
            assert!(number("steering_angle_rad") > 0.0);
        }
    }

    #[test]
    fn debug_objects_are_kept_with_their_steps_and_too_big_ones_fail() {
        let s = stopped_car_ahead();
        let mut planner = ExternalPlanner::with_context(probe(&["--minor", "3", "--debug-bytes", "100"]), context(&s));
        let r = run(&s, &mut planner);
        assert_eq!(r.termination, Termination::Completed);
        assert_eq!(r.planner_debug.len(), 120);
        for (k, d) in r.planner_debug.iter().enumerate() {
            assert_eq!(d.step, k);
            assert_eq!(d.debug["step"], k);
            assert_eq!(d.debug["pad"].as_str().map(str::len), Some(100));
        }
        // Kept where a failure is looked at: the recording.
        let bytes = crate::record::encode_rollout_mcap(&s, &r, &[]).unwrap();
        let debug: Vec<(u64, serde_json::Value)> = ::mcap::MessageStream::new(&bytes)
            .unwrap()
            .map(|m| m.unwrap())
            .filter(|m| m.channel.topic == crate::record::mcap::TOPIC_PLANNER_DEBUG)
            .map(|m| {
                assert_eq!(m.channel.message_encoding, "json");
                (m.log_time, serde_json::from_slice(&m.data).unwrap())
            })
            .collect();
        assert_eq!(debug.len(), 120);
        // At the time of the step it answered.
        assert_eq!(debug[7].0, 700_000_000);
        assert_eq!(debug[7].1["step"], 7);
        assert_eq!(debug[7].1["debug"]["step"], 7);

        let too_big = MAX_DEBUG_BYTES.to_string();
        let r = run(&s, &mut ExternalPlanner::with_context(probe(&["--debug-bytes", &too_big]), context(&s)));
        let (step, reason) = failed(&r);
        assert_eq!(step, 0);
        assert!(
            reason.contains("its `control` carries a `debug` object of 65555 bytes (as compact JSON); at most 65536"),
            "{reason}"
        );
        assert!(r.planner_debug.is_empty());
    }

    #[test]
    fn config_deserialises_with_defaults_and_rejects_unknown_fields() {
        let c: ExternalPlannerConfig =
            serde_json::from_str(r#"{"name":"p","command":"python3","env":{"A":"1"}}"#).unwrap();
        assert_eq!((c.step_timeout_ms, c.startup_timeout_ms), (1000, 10_000));
        assert_eq!(c.env, BTreeMap::from([("A".to_string(), "1".to_string())]));
        let e = serde_json::from_str::<ExternalPlannerConfig>(r#"{"name":"p","command":"x","timeout":5}"#);
        assert!(e.unwrap_err().to_string().contains("unknown field `timeout`"));
    }
}
