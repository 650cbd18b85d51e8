//! The wire format of planner protocol version 1 (minor revisions 0 to 3):
//! every message the harness writes (`hello`, `prepare`, `observation`,
//! `bye`) and every message a planner may answer (`ready`, `prepared`,
//! `control`, `trajectory`, `error`), as serde types, and
//! [`protocol_schema`], the JSON Schema generated from them. Their doc
//! comments become the descriptions in the committed schema
//! (`docs/planner-protocol.schema.json`), so they are written for planner
//! authors. Turning simulator types into these messages and back is
//! [`super::encoding`]'s job.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::map::SignalState;
use crate::scenario::AgentKind;

/// The protocol version this harness speaks (`protocol` in `hello` and `ready`).
pub const PROTOCOL_VERSION: u32 = 1;

/// The highest minor revision of [`PROTOCOL_VERSION`] this harness speaks
/// (`protocol_minor` in `hello`); a planner opts in with `protocol_minor`
/// in `ready`, and one that leaves it out gets revision 0 (version 1 as
/// first published).
pub const PROTOCOL_MINOR: u32 = 3;

/// The most bytes of JSON a reply's `debug` object may take (serialised
/// compactly): enough for a planner's per-step diagnostics, not a log. A
/// larger one is a protocol error.
pub const MAX_DEBUG_BYTES: usize = 64 * 1024;

/// A message from the harness to the planner (one line on its stdin).
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub(super) enum HarnessMessage {
    /// First message after the start. Answer with `ready` within the startup timeout.
    Hello {
        /// Protocol version the harness speaks (1).
        protocol: u32,
        /// Highest minor revision the harness speaks (3). Answer `ready` with
        /// `protocol_minor: 3` (or 2: the same messages) to get the 1.1
        /// messages (`prepare`, the stable route) and have every reply
        /// checked against the step it names (1.2); `protocol_minor: 1` for
        /// 1.1; leave it out to be spoken to in 1.0.
        protocol_minor: u32,
        /// Simulation step: time between two observations, s.
        dt_s: f64,
        /// The ego's box.
        ego: EgoSize,
        /// Since 1.3 (sent to every planner): the time allowed to answer one
        /// observation, s, from the observation being written to the reply
        /// line arriving (the spec's `step_timeout_ms`).
        step_timeout_s: f64,
        /// Since 1.3: the time allowed to answer the first observation, s
        /// (`first_step_timeout_ms`, else the step timeout).
        first_step_timeout_s: f64,
        /// Since 1.3: the time allowed from the process's start to its
        /// `ready` and, from 1.1 on, on to its `prepared`, s (one allowance
        /// for both; `startup_timeout_ms`).
        startup_timeout_s: f64,
        /// Since 1.1 (sent to every planner; 1.0 planners ignore it): which
        /// scene and variant runs. Absent when the harness has no scenario
        /// context (a planner driven outside the pipeline).
        #[serde(skip_serializing_if = "Option::is_none")]
        scenario: Option<WireScenario>,
        /// Since 1.1: world coordinates of the scenario frame's origin, [x, y]
        /// in m (the source's frame, e.g. UTM for NGSIM); a point's world
        /// position is its scenario-frame position plus this.
        #[serde(skip_serializing_if = "Option::is_none")]
        origin_world: Option<[f64; 2]>,
        /// Since 1.1: how long the rollout runs.
        #[serde(skip_serializing_if = "Option::is_none")]
        horizon: Option<WireHorizon>,
        /// Since 1.1: where the ego's recording ends (its last valid recorded
        /// state, scenario frame), as a goal; absent for scenes without one.
        #[serde(skip_serializing_if = "Option::is_none")]
        goal: Option<WireGoal>,
    },
    /// Since 1.1, only to planners that answered `ready` with
    /// `protocol_minor` ≥ 1: the whole road map, once, before the first
    /// observation. Answer with `prepared` (or `error`) within the startup
    /// timeout, which counts from the start of the process: load models and
    /// precompute here.
    Prepare {
        /// The whole map of the scenario (not clipped).
        map: WireFullMap,
    },
    /// The world at one simulation step. Answer with exactly one `control`,
    /// `trajectory` or `error` line within the step timeout.
    Observation {
        /// Step index in the scenario's numbering. Since 1.2 the reply names
        /// it back (`step`): a reply for another step is a protocol error.
        step: usize,
        /// Time since the rollout started, s.
        time_s: f64,
        /// The ego's state and size.
        ego: WireEgo,
        /// Other road users within the ego's perception range, in track order.
        agents: Vec<WireAgent>,
        /// Map elements within 60 m of the ego. Protocol 1.0 only: a 1.1
        /// planner has the whole map from `prepare`.
        #[serde(skip_serializing_if = "Option::is_none")]
        map: Option<WireMap>,
        /// Traffic-signal states now, per controlled lane.
        signals: Vec<WireSignal>,
        /// 1.0: a hint, the centreline of the ego's current lane from the
        /// ego's projection onto it forward, following each lane's first
        /// successor, up to 100 m, sampled every 2 m or less ([x, y] in m);
        /// empty when no lane within 10 m runs in the ego's direction.
        /// 1.1: the stable route: lane centrelines from 20 m behind the ego
        /// (where it was planned) through `route_lanes`, at least 200 m ahead
        /// of the ego where the map has that much, sampled every 2 m or less;
        /// the same points at every step until `route_revision` changes.
        route: Vec<[f64; 2]>,
        /// Since 1.1: the lanes `route` runs along, in order (ids as in
        /// `prepare`'s map).
        #[serde(skip_serializing_if = "Option::is_none")]
        route_lanes: Option<Vec<i64>>,
        /// Since 1.1: increases by one whenever the route is planned anew
        /// (the ego left it, or it ran short and was extended); 0 at first.
        #[serde(skip_serializing_if = "Option::is_none")]
        route_revision: Option<u32>,
        /// Since 1.1: the ego's arc length along `route`, m, from its first point.
        #[serde(skip_serializing_if = "Option::is_none")]
        route_s_m: Option<f64>,
    },
    /// The rollout is over: exit (status 0). Stdin is closed right after;
    /// a process still alive 1 s later is killed.
    Bye,
}

/// A box size.
#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
pub(super) struct EgoSize {
    /// Length, m.
    pub(super) length_m: f64,
    /// Width, m.
    pub(super) width_m: f64,
}

/// Which scene and variant runs (since 1.1).
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "Scenario")]
pub(super) struct WireScenario {
    /// Scenario id (from the source, else the file stem).
    pub(super) id: String,
    /// Source format: `womd-proto`, `womd-json`, `common-road`, `argoverse2`
    /// or `authored`.
    pub(super) format: String,
    /// File the scenario was read from, as an absolute path.
    pub(super) source_file: String,
    /// The variant's name (`suite::scenario::seed-k` for suites), when the
    /// harness runs one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) variant: Option<String>,
    /// The variant's seed, when the harness runs one: an integer below
    /// 2^53, so every JSON reader holds it exactly (one per variant; the
    /// top 53 bits of the harness's 64-bit variant seed).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(range(max = 9_007_199_254_740_991u64))]
    pub(super) seed: Option<u64>,
}

/// How long the rollout runs (since 1.1).
#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
#[schemars(rename = "Horizon")]
pub(super) struct WireHorizon {
    /// `step` of the first observation (scenario numbering).
    pub(super) start_step: usize,
    /// Observations the planner will get at most (the rollout may end
    /// earlier: a collision, a failure, the ego leaving the mapped area).
    pub(super) steps: usize,
    /// Time between two observations, s.
    pub(super) dt_s: f64,
    /// `steps` × `dt_s`, s.
    pub(super) duration_s: f64,
}

/// Where the ego's recording ends (since 1.1).
#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
#[schemars(rename = "Goal")]
pub(super) struct WireGoal {
    /// Box centre x, m (scenario frame).
    pub(super) x: f64,
    /// Box centre y, m (scenario frame).
    pub(super) y: f64,
    /// Heading there, rad.
    pub(super) heading_rad: f64,
    /// `step` at which the recording reaches it (may be after the rollout's end).
    pub(super) step: usize,
}

/// The whole map (since 1.1, in `prepare`).
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "FullMap")]
pub(super) struct WireFullMap {
    /// Every lane, in id order.
    pub(super) lanes: Vec<WireFullLane>,
    /// Road edges (kerbs, boundaries), each a polyline of [x, y] points in
    /// m, the road on its left side.
    pub(super) road_edges: Vec<Vec<[f64; 2]>>,
    /// Stop signs.
    pub(super) stop_signs: Vec<WireStopSign>,
    /// Signal-controlled lanes and where their traffic stops (`signals` in
    /// observations give the states).
    pub(super) signal_stops: Vec<WireSignalStop>,
}

/// A lane of the whole map.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "FullLane")]
pub(super) struct WireFullLane {
    /// Lane id: the source's own (CommonRoad lanelet id, WOMD map feature
    /// id, Argoverse 2 lane segment id; authored maps number from 0).
    pub(super) id: i64,
    /// Centreline in the direction of travel, [x, y] in m, every 2 m or less.
    pub(super) centreline: Vec<[f64; 2]>,
    /// Left boundary (in the direction of travel), where the source has one.
    pub(super) left_boundary: Option<Vec<[f64; 2]>>,
    /// Right boundary, where the source has one.
    pub(super) right_boundary: Option<Vec<[f64; 2]>>,
    /// Mean width, m, from the boundaries; null when the source has none.
    pub(super) width_m: Option<f64>,
    /// Speed limit, m/s; null when the source gives none (WOMD never does).
    pub(super) speed_limit_mps: Option<f64>,
    /// Lanes whose end joins this lane's start.
    pub(super) predecessors: Vec<i64>,
    /// Lanes this lane's end joins.
    pub(super) successors: Vec<i64>,
    /// Adjacent lanes on the left.
    pub(super) left_neighbours: Vec<i64>,
    /// Adjacent lanes on the right.
    pub(super) right_neighbours: Vec<i64>,
    /// Whether it lies inside an intersection.
    pub(super) in_intersection: bool,
    /// Midpoint of the lane's stop line, [x, y] in m, where the source has
    /// one (CommonRoad `stopLine`); null otherwise.
    pub(super) stop_line: Option<[f64; 2]>,
}

/// A stop sign.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "StopSign")]
pub(super) struct WireStopSign {
    /// Position of the sign, [x, y] in m.
    pub(super) position: [f64; 2],
    /// The lanes it controls.
    pub(super) lanes: Vec<i64>,
}

/// Where traffic on a signal-controlled lane stops.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "SignalStop")]
pub(super) struct WireSignalStop {
    /// The controlled lane.
    pub(super) lane: i64,
    /// The stop line's point, [x, y] in m: the source's stop line, else the
    /// lane's end.
    pub(super) stop_point: [f64; 2],
}

/// The ego at one step.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "EgoState")]
pub(super) struct WireEgo {
    /// Box centre x, m (scenario frame).
    pub(super) x: f64,
    /// Box centre y, m (scenario frame).
    pub(super) y: f64,
    /// Heading, rad, counter-clockwise from +x, in (-π, π].
    pub(super) heading_rad: f64,
    /// Speed (norm of the velocity), m/s.
    pub(super) speed_mps: f64,
    /// Velocity x, m/s.
    pub(super) vx: f64,
    /// Velocity y, m/s.
    pub(super) vy: f64,
    /// Since 1.3: the ego's longitudinal acceleration over the last step,
    /// m/s² (negative: slowing): the change of its speed along the heading
    /// (never negative, as the kinematic model holds it) from the previous
    /// step to this one, divided by the step. Under a `control` it is the
    /// `accel_mps2` applied, unless the speed stopped at 0. 0 at the first
    /// step when the ego has no earlier state.
    pub(super) accel_mps2: f64,
    /// Since 1.3: the ego's yaw rate over the last step, rad/s
    /// (counter-clockwise positive: positive turns left): the heading's
    /// change from the previous step (wrapped to (-π, π]) divided by the
    /// step. Under a `control` it is the `yaw_rate_radps` applied. 0 at the
    /// first step when the ego has no earlier state.
    pub(super) yaw_rate_radps: f64,
    /// Since 1.3: the front-wheel steering angle of a kinematic bicycle
    /// with a 3.0 m wheelbase driving the path of the last step, rad
    /// (positive steers left): atan(3.0 m × yaw_rate_radps / speed along
    /// the heading), in (-π/2, π/2). The simulator moves the ego as a
    /// unicycle and has no steering of its own; this is the angle that
    /// curvature stands for (recover the curvature as tan(angle) / 3.0 m).
    /// 0 below 0.1 m/s, where the path has no curvature to speak of.
    pub(super) steering_angle_rad: f64,
    /// Length, m.
    pub(super) length_m: f64,
    /// Width, m.
    pub(super) width_m: f64,
}

/// Another road user as the ego perceives it.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "Agent")]
pub(super) struct WireAgent {
    /// Id from the scenario's source (stable within a rollout).
    pub(super) id: String,
    /// Road-user type.
    pub(super) kind: WireAgentKind,
    /// Box centre x, m.
    pub(super) x: f64,
    /// Box centre y, m.
    pub(super) y: f64,
    /// Heading, rad, counter-clockwise from +x.
    pub(super) heading_rad: f64,
    /// Velocity x, m/s.
    pub(super) vx: f64,
    /// Velocity y, m/s.
    pub(super) vy: f64,
    /// Length, m.
    pub(super) length_m: f64,
    /// Width, m.
    pub(super) width_m: f64,
}

/// Road-user type.
#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
#[schemars(rename = "AgentKind")]
pub(super) enum WireAgentKind {
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
pub(super) struct WireMap {
    /// Lanes with some part within 60 m of the ego, in id order.
    pub(super) lanes: Vec<WireLane>,
    /// Road edges (kerbs, boundaries) with some part within 60 m of the ego,
    /// each a polyline of [x, y] points in m, the road on its left side.
    pub(super) road_edges: Vec<Vec<[f64; 2]>>,
}

/// One lane near the ego.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "Lane")]
pub(super) struct WireLane {
    /// Lane id (as in `signals[].lane`).
    pub(super) id: i64,
    /// Centreline in the direction of travel, [x, y] in m, sampled every 2 m
    /// or less, clipped to the stretch within 60 m of the ego.
    pub(super) centreline: Vec<[f64; 2]>,
    /// Speed limit, m/s, when the map gives one.
    pub(super) speed_limit_mps: Option<f64>,
}

/// The state of the signal controlling one lane.
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[schemars(rename = "Signal")]
pub(super) struct WireSignal {
    /// Controlled lane id.
    pub(super) lane: i64,
    /// Signal state.
    pub(super) state: WireSignalState,
}

/// A traffic-signal state (stop = red, caution = yellow, go = green).
#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
#[schemars(rename = "SignalState")]
pub(super) enum WireSignalState {
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
pub(super) enum PlannerMessage {
    /// Answer to `hello`: the planner is ready for observations.
    Ready {
        /// Protocol version the planner speaks; must be 1.
        protocol: u32,
        /// Minor revision the planner speaks: 2 for 1.2 (the 1.1 messages and
        /// step-tagged replies), 1 for the 1.1 messages, absent or 0 for 1.0.
        /// A revision above the harness's is spoken to as the harness's.
        #[serde(default)]
        protocol_minor: u32,
        /// The planner's own name, for logs.
        #[serde(default)]
        name: Option<String>,
    },
    /// Since 1.1: answer to `prepare`, the planner is ready for the first observation.
    Prepared {},
    /// Answer to an observation: a control applied for one step through the
    /// kinematic unicycle model (speed += accel·dt, clamped at 0; heading +=
    /// yaw_rate·dt; then move along the new heading). Not clipped.
    Control {
        /// Since 1.2 (required from planners that speak it): the `step` of
        /// the observation this answers. Checked whenever given.
        #[serde(default)]
        step: Option<usize>,
        /// Longitudinal acceleration, m/s² (negative brakes).
        accel_mps2: f64,
        /// Yaw rate, rad/s (positive turns left).
        yaw_rate_radps: f64,
        /// Since 1.3: any JSON the planner wants kept with this step (its
        /// cost terms, the candidate it chose, why it braked), at most 64 KiB
        /// as compact JSON. The harness stores it with the step in the
        /// rollout's recording (`/planner/debug`) and ignores it otherwise.
        #[serde(default)]
        debug: Option<serde_json::Value>,
    },
    /// Answer to an observation: planned states; the ego follows it exactly,
    /// taking the state interpolated at t = dt_s.
    Trajectory {
        /// Since 1.2 (required from planners that speak it): the `step` of
        /// the observation this answers. Checked whenever given.
        #[serde(default)]
        step: Option<usize>,
        /// Planned states, times positive and increasing, the last at t ≥ dt_s.
        points: Vec<WirePoint>,
        /// Since 1.3: any JSON the planner wants kept with this step, at most
        /// 64 KiB as compact JSON; as `control`'s `debug`.
        #[serde(default)]
        debug: Option<serde_json::Value>,
    },
    /// The planner gives up: the rollout fails with this message.
    Error {
        /// The step it gives up at (optional in every revision: giving up
        /// fails the rollout whatever the step).
        #[serde(default)]
        step: Option<usize>,
        /// Why.
        #[serde(default)]
        message: Option<String>,
    },
}

impl PlannerMessage {
    /// The step a reply to an observation names (1.2), if any.
    pub(super) fn step(&self) -> Option<usize> {
        match self {
            Self::Control { step, .. } | Self::Trajectory { step, .. } | Self::Error { step, .. } => *step,
            Self::Ready { .. } | Self::Prepared {} => None,
        }
    }

    /// The `debug` object a `control` or `trajectory` carries (1.3), if any.
    pub(super) fn debug(&self) -> Option<&serde_json::Value> {
        match self {
            Self::Control { debug, .. } | Self::Trajectory { debug, .. } => debug.as_ref(),
            Self::Ready { .. } | Self::Prepared {} | Self::Error { .. } => None,
        }
    }

    /// The `type` tag, for error messages.
    pub(super) fn kind(&self) -> &'static str {
        match self {
            Self::Ready { .. } => "ready",
            Self::Prepared {} => "prepared",
            Self::Control { .. } => "control",
            Self::Trajectory { .. } => "trajectory",
            Self::Error { .. } => "error",
        }
    }
}

/// A planned state.
#[derive(Debug, Clone, Copy, Deserialize, JsonSchema)]
#[schemars(rename = "TrajectoryPoint")]
pub(super) struct WirePoint {
    /// Time after the observation, s (> 0).
    pub(super) t: f64,
    /// Box centre x, m.
    pub(super) x: f64,
    /// Box centre y, m.
    pub(super) y: f64,
    /// Heading, rad, counter-clockwise from +x.
    pub(super) heading_rad: f64,
    /// Speed along the heading, m/s (≥ 0).
    pub(super) speed_mps: f64,
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
        "title": format!("SaFeR planner protocol, version {PROTOCOL_VERSION}.{PROTOCOL_MINOR}"),
        "description": "One JSON object per line. HarnessMessage: harness to planner (stdin). PlannerMessage: planner to harness (stdout). See docs/planner-protocol.md.",
        "oneOf": [to_planner, to_harness],
        "$defs": defs,
    })
}
#[cfg(test)]
mod tests {
    use super::*;

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
             `SAFER_BLESS=1 cargo test --lib planners::external::wire::tests::committed_schema_is_current`"
        );
    }
}
