//! The wire format of planner protocol version 1: every message the harness
//! writes (`hello`, `observation`, `bye`) and every message a planner may
//! answer (`ready`, `control`, `trajectory`, `error`), as serde types, and
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

/// A message from the harness to the planner (one line on its stdin).
#[derive(Debug, Clone, Serialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub(super) enum HarnessMessage {
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
pub(super) struct EgoSize {
    /// Length, m.
    pub(super) length_m: f64,
    /// Width, m.
    pub(super) width_m: f64,
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
    pub(super) fn kind(&self) -> &'static str {
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
        "title": format!("SaFeR planner protocol, version {PROTOCOL_VERSION}"),
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
