//! One MCAP recording per rollout, in Foxglove's well-known protobuf
//! schemas so it opens in Foxglove's 3D panel without configuration.
//!
//! Topics (all in the fixed frame [`FRAME_MAP`], the scenario's local,
//! re-centred frame; the world offset is in the file's metadata):
//!
//! | topic | schema | when |
//! | --- | --- | --- |
//! | [`TOPIC_MAP`] | `foxglove.SceneUpdate` | once at t = 0: road edges, lane centrelines, road lines, crosswalks and other areas, drivable-area outlines, stop signs |
//! | [`TOPIC_PATHS`] | `foxglove.SceneUpdate` | once at t = 0: the ego's and the CBV's whole paths |
//! | [`TOPIC_WITNESS`] | `foxglove.SceneUpdate` | t = 0: each extra trajectory as a line; then per step its footprint |
//! | [`TOPIC_AGENTS`] | `foxglove.SceneUpdate` | every step: one cube per agent (ego blue, CBV orange, others by kind, collided red), replacing the previous step's |
//! | [`TOPIC_COLLISIONS`] | `foxglove.SceneUpdate` | at each collision: a marker at the contact point |
//! | [`TOPIC_TF`] | `foxglove.FrameTransform` | every step: `map` → `ego`, so the view can follow the ego |
//! | [`TOPIC_EVENTS`] | `foxglove.Log` | t = 0 (what ran), collisions, off-road, planner failure |
//! | [`TOPIC_PLANNER_DEBUG`] | `safer.PlannerDebug` (JSON) | at each step the planner gave a `debug` object: `{"step": k, "debug": ...}`; only in recordings of such planners |
//!
//! Log time = publish time = step time in nanoseconds from 0, never the
//! wall clock; messages are written in time order (ties in topic order),
//! with a plain `mcap::Writer` and no global logging context, so parallel
//! trials can record side by side and the same rollout gives the same
//! bytes. Chunks are uncompressed: the crate is built without the C
//! compressors, and a rollout recording is a few megabytes.

use std::collections::BTreeMap;
use std::io::Cursor;

use foxglove::Encode;
use foxglove::messages::{
    ArrowPrimitive, Color, CubePrimitive, CylinderPrimitive, Duration, FrameTransform, KeyValuePair, LinePrimitive,
    Log, Point3, Pose, Quaternion, SceneEntity, SceneEntityDeletion, SceneUpdate, SpherePrimitive, TextPrimitive,
    Timestamp, Vector3, line_primitive, log, scene_entity_deletion,
};
use prost::Message as _;

use super::{NamedTrajectory, RecordError, TrajectoryRole};
use crate::geometry::{OrientedBox, Point2, Pose2};
use crate::map::{AreaKind, RoadLineKind, RoadMap};
use crate::scenario::{AgentKind, AgentState, Scenario, TrackIndex};
use crate::sim::{Rollout, Termination};

/// The map, once.
pub const TOPIC_MAP: &str = "/scene/map";
/// The ego's and CBV's whole paths, once.
pub const TOPIC_PATHS: &str = "/scene/paths";
/// Extra trajectories (feasibility witness, plans).
pub const TOPIC_WITNESS: &str = "/scene/witness";
/// Agent footprints, every step.
pub const TOPIC_AGENTS: &str = "/scene/agents";
/// Collision markers.
pub const TOPIC_COLLISIONS: &str = "/scene/collisions";
/// The ego's frame, every step.
pub const TOPIC_TF: &str = "/tf";
/// Human-readable events.
pub const TOPIC_EVENTS: &str = "/events";
/// The planner's own per-step data (an external planner's `debug`), JSON.
pub const TOPIC_PLANNER_DEBUG: &str = "/planner/debug";
/// The JSON Schema of a [`TOPIC_PLANNER_DEBUG`] message.
const PLANNER_DEBUG_SCHEMA: &str = r#"{"type":"object","properties":{"step":{"type":"integer","description":"scenario step of the observation answered"},"debug":{"description":"the planner's JSON, as it sent it"}},"required":["step","debug"]}"#;
/// The fixed frame everything is drawn in.
pub const FRAME_MAP: &str = "map";
/// The frame that follows the ego.
pub const FRAME_EGO: &str = "ego";
/// Name of the MCAP metadata record that describes the rollout.
pub const METADATA_NAME: &str = "safer.rollout";

/// Height of drawn vehicles (and unknown agents), m: the data have no height.
const VEHICLE_HEIGHT_M: f64 = 1.5;
/// Height of drawn pedestrians and cyclists, m.
const PERSON_HEIGHT_M: f64 = 1.7;
/// Height above the ground of drawn lines, m, so they are not hidden by
/// the ground plane.
const LINE_Z_M: f64 = 0.05;

const fn rgba(r: f64, g: f64, b: f64, a: f64) -> Color {
    Color { r, g, b, a }
}

// The same palette as the pictures (see `svg`).
const EGO: Color = rgba(0.122, 0.435, 0.820, 1.0);
const CBV: Color = rgba(0.937, 0.541, 0.0, 1.0);
const COLLIDED: Color = rgba(0.839, 0.153, 0.157, 1.0);
const VEHICLE: Color = rgba(0.66, 0.69, 0.73, 1.0);
const PEDESTRIAN: Color = rgba(0.60, 0.48, 0.80, 1.0);
const CYCLIST: Color = rgba(0.30, 0.68, 0.55, 1.0);
const OTHER: Color = rgba(0.75, 0.73, 0.66, 1.0);
const ROAD_EDGE: Color = rgba(0.85, 0.85, 0.85, 1.0);
const LANE: Color = rgba(0.45, 0.55, 0.68, 0.8);
const WHITE_LINE: Color = rgba(0.95, 0.95, 0.95, 0.9);
const YELLOW_LINE: Color = rgba(0.90, 0.70, 0.0, 0.9);
const CROSSWALK: Color = rgba(0.80, 0.80, 0.80, 0.8);
const AREA: Color = rgba(0.65, 0.55, 0.45, 0.8);
const DRIVABLE: Color = rgba(0.5, 0.5, 0.55, 0.6);
const STOP: Color = rgba(0.75, 0.22, 0.17, 1.0);
const TEXT: Color = rgba(1.0, 1.0, 1.0, 1.0);

fn trajectory_colour(role: TrajectoryRole) -> Color {
    match role {
        TrajectoryRole::FeasibilityWitness => rgba(0.102, 0.596, 0.314, 1.0),
        TrajectoryRole::EgoPlan => rgba(0.482, 0.196, 0.580, 1.0),
        TrajectoryRole::Reference => rgba(0.6, 0.6, 0.6, 1.0),
    }
}

/// The channels, in the order they are registered and in which messages of
/// equal time are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Topic {
    Map,
    Paths,
    Witness,
    Agents,
    Collisions,
    Tf,
    Events,
    PlannerDebug,
}

impl Topic {
    const ALL: [Topic; 8] = [
        Topic::Map,
        Topic::Paths,
        Topic::Witness,
        Topic::Agents,
        Topic::Collisions,
        Topic::Tf,
        Topic::Events,
        Topic::PlannerDebug,
    ];

    fn name(self) -> &'static str {
        match self {
            Self::Map => TOPIC_MAP,
            Self::Paths => TOPIC_PATHS,
            Self::Witness => TOPIC_WITNESS,
            Self::Agents => TOPIC_AGENTS,
            Self::Collisions => TOPIC_COLLISIONS,
            Self::Tf => TOPIC_TF,
            Self::Events => TOPIC_EVENTS,
            Self::PlannerDebug => TOPIC_PLANNER_DEBUG,
        }
    }

    /// How its messages are encoded.
    fn message_encoding(self) -> &'static str {
        match self {
            Self::PlannerDebug => "json",
            _ => "protobuf",
        }
    }

    fn schema(self) -> Option<foxglove::Schema> {
        match self {
            Self::Tf => FrameTransform::get_schema(),
            Self::Events => Log::get_schema(),
            Self::PlannerDebug => Some(foxglove::Schema::new(
                "safer.PlannerDebug",
                "jsonschema",
                PLANNER_DEBUG_SCHEMA.as_bytes().to_vec(),
            )),
            _ => SceneUpdate::get_schema(),
        }
    }
}

/// A message waiting to be written in time order.
struct Pending {
    time_ns: u64,
    topic: Topic,
    data: Vec<u8>,
}

/// Encodes the rollout's recording (see the module doc for its topics).
/// Extra trajectories are drawn on [`TOPIC_WITNESS`]; their names should be
/// unique, since entities with the same name replace each other.
pub fn encode_rollout_mcap(
    scenario: &Scenario,
    rollout: &Rollout,
    extra: &[NamedTrajectory],
) -> Result<Vec<u8>, RecordError> {
    check(rollout)?;
    let rec = Recorder { rollout };
    let mut pending = Vec::new();
    let mut push = |time_ns: u64, topic: Topic, data: Vec<u8>| pending.push(Pending { time_ns, topic, data });

    push(0, Topic::Map, map_update(&scenario.map, ts(0)).encode_to_vec());
    push(0, Topic::Paths, rec.paths().encode_to_vec());
    for (time_ns, update) in rec.witness(extra) {
        push(time_ns, Topic::Witness, update.encode_to_vec());
    }
    for k in 0..rollout.states.len() {
        let time_ns = rec.time_ns(k);
        push(time_ns, Topic::Agents, rec.agents(k).encode_to_vec());
        if let Some(tf) = rec.ego_frame(k) {
            push(time_ns, Topic::Tf, tf.encode_to_vec());
        }
    }
    for (time_ns, update) in rec.collisions() {
        push(time_ns, Topic::Collisions, update.encode_to_vec());
    }
    for (time_ns, log) in rec.events() {
        push(time_ns, Topic::Events, log.encode_to_vec());
    }
    for d in &rollout.planner_debug {
        let time_ns = rec.time_ns(d.step.saturating_sub(rollout.start_step));
        let message = serde_json::to_vec(d).map_err(|e| RecordError::InconsistentRollout {
            scenario: rollout.scenario_id.clone(),
            what: format!("the planner's debug data at step {} is not JSON: {e}", d.step),
        })?;
        push(time_ns, Topic::PlannerDebug, message);
    }
    // Stable: equal times keep topic order, then the order pushed.
    pending.sort_by_key(|p| (p.time_ns, p.topic));

    let options = ::mcap::WriteOptions::new()
        .compression(None)
        .profile("")
        .library(format!("safer {}", env!("CARGO_PKG_VERSION")));
    let mut writer = options.create(Cursor::new(Vec::new()))?;
    let mut channels = BTreeMap::new();
    for topic in Topic::ALL {
        // Only planners that send debug data get its channel: other
        // recordings stay as they were.
        if topic == Topic::PlannerDebug && rollout.planner_debug.is_empty() {
            continue;
        }
        let schema_id = match topic.schema() {
            Some(s) => writer.add_schema(&s.name, &s.encoding, &s.data)?,
            None => 0,
        };
        let id = writer.add_channel(schema_id, topic.name(), topic.message_encoding(), &BTreeMap::new())?;
        channels.insert(topic, id);
    }
    writer
        .write_metadata(&::mcap::records::Metadata { name: METADATA_NAME.into(), metadata: rec.metadata(scenario) })?;
    let mut sequence: BTreeMap<Topic, u32> = BTreeMap::new();
    for p in &pending {
        let seq = sequence.entry(p.topic).or_insert(0);
        let header = ::mcap::records::MessageHeader {
            channel_id: channels[&p.topic],
            sequence: *seq,
            log_time: p.time_ns,
            publish_time: p.time_ns,
        };
        *seq += 1;
        writer.write_to_known_channel(&header, &p.data)?;
    }
    writer.finish()?;
    Ok(writer.into_inner().into_inner())
}

/// Refuses rollouts whose parts disagree, so the recording never indexes
/// outside them.
fn check(rollout: &Rollout) -> Result<(), RecordError> {
    let fail = |what: String| Err(RecordError::InconsistentRollout { scenario: rollout.scenario_id.clone(), what });
    let n = rollout.bodies.len();
    if !(rollout.dt_s.is_finite() && rollout.dt_s > 0.0) {
        return fail(format!("step length {} s is not positive", rollout.dt_s));
    }
    if rollout.agent_ids.len() != n {
        return fail(format!("{} agent ids for {n} agents", rollout.agent_ids.len()));
    }
    if let Some(k) = rollout.states.iter().position(|s| s.len() != n) {
        return fail(format!("step {k} has {} states for {n} agents", rollout.states[k].len()));
    }
    for (name, role) in [("ego", Some(rollout.ego)), ("CBV", rollout.cbv)] {
        if let Some(TrackIndex(i)) = role
            && i >= n
        {
            return fail(format!("{name} index {i} outside {n} agents"));
        }
    }
    let steps = rollout.start_step..rollout.start_step + rollout.states.len();
    for c in &rollout.collisions {
        if c.a.0 >= n || c.b.0 >= n || !steps.contains(&c.step) {
            return fail(format!("collision {c:?} outside the rollout"));
        }
    }
    Ok(())
}

fn ts(time_ns: u64) -> Timestamp {
    let sec = u32::try_from(time_ns / 1_000_000_000).unwrap_or(u32::MAX);
    // Below 10⁹ by construction, so this constructor cannot overflow.
    Timestamp::new(sec, (time_ns % 1_000_000_000) as u32)
}

fn kv(key: &str, value: impl Into<String>) -> KeyValuePair {
    KeyValuePair { key: key.into(), value: value.into() }
}

fn finite(s: &AgentState) -> bool {
    s.position.x.is_finite() && s.position.y.is_finite() && s.heading_rad.is_finite()
}

/// A pose at height `z` with the heading as a rotation about z.
fn pose3(pose: &Pose2, z: f64) -> Pose {
    let half = 0.5 * pose.heading_rad;
    Pose {
        position: Some(Vector3 { x: pose.position.x, y: pose.position.y, z }),
        orientation: Some(Quaternion { x: 0.0, y: 0.0, z: half.sin(), w: half.cos() }),
    }
}

fn entity(id: String, timestamp: Timestamp) -> SceneEntity {
    SceneEntity { timestamp: Some(timestamp), frame_id: FRAME_MAP.into(), id, ..Default::default() }
}

/// One `LINE_LIST` for many polylines: points once, segments by index
/// (half the bytes of repeating inner points). Non-finite points break a
/// polyline. `None` when nothing is left to draw.
fn line_list<'p>(
    polylines: impl IntoIterator<Item = &'p [Point2]>,
    closed: bool,
    colour: Color,
    thickness_px: f64,
) -> Option<LinePrimitive> {
    let mut points = Vec::new();
    let mut indices = Vec::new();
    for line in polylines {
        let mut run_start: Option<u32> = None;
        let first = u32::try_from(points.len()).ok()?;
        let mut all_finite = true;
        for p in line {
            if !(p.x.is_finite() && p.y.is_finite()) {
                run_start = None;
                all_finite = false;
                continue;
            }
            let i = u32::try_from(points.len()).ok()?;
            points.push(Point3 { x: p.x, y: p.y, z: LINE_Z_M });
            if run_start.is_some() {
                indices.extend([i - 1, i]);
            } else {
                run_start = Some(i);
            }
        }
        let last = u32::try_from(points.len()).ok()?;
        if closed && all_finite && last >= first + 3 {
            indices.extend([last - 1, first]);
        }
    }
    (!indices.is_empty()).then(|| LinePrimitive {
        r#type: line_primitive::Type::LineList as i32,
        pose: Some(pose3(&Pose2::new(0.0, 0.0, 0.0), 0.0)),
        thickness: thickness_px,
        scale_invariant: true,
        points,
        color: Some(colour),
        colors: Vec::new(),
        indices,
    })
}

/// The map as one scene update with an entity per element type, so each
/// can be inspected on its own.
fn map_update(map: &RoadMap, t: Timestamp) -> SceneUpdate {
    let mut entities = Vec::new();
    let mut add = |name: &str, lines: Vec<LinePrimitive>| {
        if !lines.is_empty() {
            entities.push(SceneEntity { lines, ..entity(format!("map/{name}"), t) });
        }
    };
    add(
        "drivable_areas",
        line_list(map.drivable_areas.iter().map(|a| a.vertices.as_slice()), true, DRIVABLE, 1.0).into_iter().collect(),
    );
    add(
        "crosswalks",
        line_list(
            map.areas.iter().filter(|a| a.kind == AreaKind::Crosswalk).map(|a| a.polygon.vertices.as_slice()),
            true,
            CROSSWALK,
            1.5,
        )
        .into_iter()
        .collect(),
    );
    add(
        "areas",
        line_list(
            map.areas.iter().filter(|a| a.kind != AreaKind::Crosswalk).map(|a| a.polygon.vertices.as_slice()),
            true,
            AREA,
            1.0,
        )
        .into_iter()
        .collect(),
    );
    add(
        "lane_centrelines",
        line_list(map.lanes.iter().map(|l| l.centreline.points()), false, LANE, 1.0).into_iter().collect(),
    );
    let yellow = |k: RoadLineKind| {
        use RoadLineKind as K;
        matches!(
            k,
            K::BrokenSingleYellow
                | K::BrokenDoubleYellow
                | K::SolidSingleYellow
                | K::SolidDoubleYellow
                | K::PassingDoubleYellow
        )
    };
    add(
        "road_lines",
        [
            line_list(
                map.road_lines.iter().filter(|l| !yellow(l.kind)).map(|l| l.polyline.points()),
                false,
                WHITE_LINE,
                1.5,
            ),
            line_list(
                map.road_lines.iter().filter(|l| yellow(l.kind)).map(|l| l.polyline.points()),
                false,
                YELLOW_LINE,
                1.5,
            ),
        ]
        .into_iter()
        .flatten()
        .collect(),
    );
    add(
        "road_edges",
        line_list(map.road_edges.iter().map(|e| e.polyline.points()), false, ROAD_EDGE, 2.5).into_iter().collect(),
    );
    let stops: Vec<CylinderPrimitive> = map
        .stop_signs
        .iter()
        .filter(|s| s.position.x.is_finite() && s.position.y.is_finite())
        .map(|s| CylinderPrimitive {
            pose: Some(pose3(&Pose2 { position: s.position, heading_rad: 0.0 }, 1.0)),
            size: Some(Vector3 { x: 0.6, y: 0.6, z: 2.0 }),
            bottom_scale: 1.0,
            top_scale: 1.0,
            color: Some(STOP),
        })
        .collect();
    if !stops.is_empty() {
        entities.push(SceneEntity { cylinders: stops, ..entity("map/stop_signs".into(), t) });
    }
    SceneUpdate { deletions: Vec::new(), entities }
}

/// Builds the messages of one (checked) rollout.
struct Recorder<'a> {
    rollout: &'a Rollout,
}

impl Recorder<'_> {
    fn time_ns(&self, k: usize) -> u64 {
        // `check` made dt finite and positive; the cast saturates.
        (k as f64 * self.rollout.dt_s * 1e9).round() as u64
    }

    fn time_text(&self, step: usize) -> String {
        format!("t = {:.2} s", step.saturating_sub(self.rollout.start_step) as f64 * self.rollout.dt_s)
    }

    fn state(&self, k: usize, i: usize) -> Option<&AgentState> {
        self.rollout.states.get(k)?.get(i)?.as_ref().filter(|s| finite(s))
    }

    fn id(&self, i: usize) -> &str {
        self.rollout.agent_ids.get(i).map_or("?", |a| a.0.as_str())
    }

    fn role(&self, i: usize) -> &'static str {
        if self.rollout.ego.0 == i {
            "ego"
        } else if self.rollout.cbv.is_some_and(|c| c.0 == i) {
            "CBV"
        } else {
            "other"
        }
    }

    fn kind_name(&self, i: usize) -> &'static str {
        match self.rollout.bodies.get(i).map(|b| b.kind) {
            Some(AgentKind::Vehicle) => "vehicle",
            Some(AgentKind::Pedestrian) => "pedestrian",
            Some(AgentKind::Cyclist) => "cyclist",
            _ => "other",
        }
    }

    /// "ego 'id' (vehicle)", "CBV 'id' (vehicle)", "pedestrian 'id'".
    fn who(&self, i: usize) -> String {
        match self.role(i) {
            "other" => format!("{} '{}'", self.kind_name(i), self.id(i)),
            role => format!("{role} '{}' ({})", self.id(i), self.kind_name(i)),
        }
    }

    /// The ego's and CBV's whole paths, for orientation while scrubbing.
    fn paths(&self) -> SceneUpdate {
        let mut entities = Vec::new();
        for (name, agent, colour) in [("cbv", self.rollout.cbv, CBV), ("ego", Some(self.rollout.ego), EGO)] {
            let Some(TrackIndex(i)) = agent else { continue };
            let mut runs: Vec<Vec<Point2>> = vec![Vec::new()];
            for k in 0..self.rollout.states.len() {
                match self.state(k, i) {
                    Some(s) => runs.last_mut().expect("never empty").push(s.position),
                    None => runs.push(Vec::new()),
                }
            }
            if let Some(line) = line_list(runs.iter().map(Vec::as_slice), false, colour, 3.0) {
                entities.push(SceneEntity {
                    lines: vec![line],
                    metadata: vec![kv("agent", self.id(i))],
                    ..entity(format!("path/{name}"), ts(0))
                });
            }
        }
        SceneUpdate { deletions: Vec::new(), entities }
    }

    /// Each extra trajectory's line at t = 0, then its footprint at every
    /// step of the rollout's cadence that its time span covers.
    fn witness(&self, extra: &[NamedTrajectory]) -> Vec<(u64, SceneUpdate)> {
        let mut out = Vec::new();
        let lines: Vec<SceneEntity> = extra
            .iter()
            .filter_map(|e| {
                let pts: Vec<Point2> =
                    e.poses.iter().filter(|p| p.time_s.is_finite()).map(|p| p.pose.position).collect();
                let line = line_list([pts.as_slice()], false, trajectory_colour(e.role), 3.0)?;
                Some(SceneEntity {
                    lines: vec![line],
                    metadata: vec![kv("role", e.role.label())],
                    ..entity(format!("witness/{}", e.name), ts(0))
                })
            })
            .collect();
        if !lines.is_empty() {
            out.push((0, SceneUpdate { deletions: Vec::new(), entities: lines }));
        }
        let end_s = extra
            .iter()
            .flat_map(|e| e.poses.iter().map(|p| p.time_s))
            .filter(|t| t.is_finite())
            .fold(f64::NEG_INFINITY, f64::max);
        if !end_s.is_finite() || end_s < 0.0 {
            return out;
        }
        // Bounded, so an absurd time cannot make the file explode.
        let steps = ((end_s / self.rollout.dt_s).floor() as usize).min(100_000);
        let lifetime = Duration::saturating_from_secs_f64(1.5 * self.rollout.dt_s);
        for k in 0..=steps {
            let time_ns = self.time_ns(k);
            let t_s = k as f64 * self.rollout.dt_s;
            let entities: Vec<SceneEntity> = extra
                .iter()
                .filter_map(|e| {
                    let pose = e.pose_at(t_s)?;
                    let (l, w, h) = e.body.map_or((1.0, 1.0, 0.5), |b| (b.length_m, b.width_m, VEHICLE_HEIGHT_M));
                    let mut colour = trajectory_colour(e.role);
                    colour.a = 0.45;
                    Some(SceneEntity {
                        lifetime: Some(lifetime),
                        cubes: vec![CubePrimitive {
                            pose: Some(pose3(&pose, 0.5 * h)),
                            size: Some(Vector3 { x: l, y: w, z: h }),
                            color: Some(colour),
                        }],
                        ..entity(format!("witness/{}/footprint", e.name), ts(time_ns))
                    })
                })
                .collect();
            if !entities.is_empty() {
                out.push((time_ns, SceneUpdate { deletions: Vec::new(), entities }));
            }
        }
        out
    }

    /// Every present agent at step `k` as a cube; the update first deletes
    /// the previous step's entities, so agents that left disappear.
    fn agents(&self, k: usize) -> SceneUpdate {
        let t = ts(self.time_ns(k));
        let step = self.rollout.start_step + k;
        let collided: std::collections::BTreeSet<usize> =
            self.rollout.collisions.iter().filter(|c| c.step <= step).flat_map(|c| [c.a.0, c.b.0]).collect();
        let mut entities = Vec::new();
        for (i, body) in self.rollout.bodies.iter().enumerate() {
            let Some(s) = self.state(k, i) else { continue };
            let (l, w) = (body.length_m, body.width_m);
            if !(l.is_finite() && w.is_finite() && l > 0.0 && w > 0.0) {
                continue;
            }
            let h = match body.kind {
                AgentKind::Pedestrian | AgentKind::Cyclist => PERSON_HEIGHT_M,
                AgentKind::Vehicle | AgentKind::Other => VEHICLE_HEIGHT_M,
            };
            let role = self.role(i);
            let colour = match (collided.contains(&i), role, body.kind) {
                (true, _, _) => COLLIDED,
                (false, "ego", _) => EGO,
                (false, "CBV", _) => CBV,
                (false, _, AgentKind::Vehicle) => VEHICLE,
                (false, _, AgentKind::Pedestrian) => PEDESTRIAN,
                (false, _, AgentKind::Cyclist) => CYCLIST,
                (false, _, AgentKind::Other) => OTHER,
            };
            let pose = s.pose();
            let mut e = SceneEntity {
                metadata: vec![
                    kv("kind", self.kind_name(i)),
                    kv("role", role),
                    kv("speed_mps", format!("{:.2}", s.speed_mps())),
                ],
                cubes: vec![CubePrimitive {
                    pose: Some(pose3(&pose, 0.5 * h)),
                    size: Some(Vector3 { x: l, y: w, z: h }),
                    color: Some(colour),
                }],
                ..entity(format!("agent/{}", self.id(i)), t)
            };
            if role != "other" {
                // Heading arrow and a label: the two agents a reviewer follows.
                let tail = pose.position;
                e.arrows.push(ArrowPrimitive {
                    pose: Some(pose3(&Pose2 { position: tail, heading_rad: pose.heading_rad }, h + 0.1)),
                    shaft_length: 0.5 * l,
                    shaft_diameter: 0.2,
                    head_length: 0.6,
                    head_diameter: 0.6,
                    color: Some(TEXT),
                });
                e.texts.push(TextPrimitive {
                    pose: Some(pose3(&pose, h + 1.5)),
                    billboard: true,
                    font_size: 14.0,
                    scale_invariant: true,
                    color: Some(TEXT),
                    text: role.to_string(),
                });
            }
            entities.push(e);
        }
        SceneUpdate {
            deletions: vec![SceneEntityDeletion {
                timestamp: Some(t),
                r#type: scene_entity_deletion::Type::All as i32,
                id: String::new(),
            }],
            entities,
        }
    }

    /// `map` → `ego` at step `k`, while the ego is present.
    fn ego_frame(&self, k: usize) -> Option<FrameTransform> {
        let s = self.state(k, self.rollout.ego.0)?;
        let pose = pose3(&s.pose(), 0.0);
        Some(FrameTransform {
            timestamp: Some(ts(self.time_ns(k))),
            parent_frame_id: FRAME_MAP.into(),
            child_frame_id: FRAME_EGO.into(),
            translation: pose.position,
            rotation: pose.orientation,
        })
    }

    /// A marker at each collision's contact point, from its step on.
    fn collisions(&self) -> Vec<(u64, SceneUpdate)> {
        let mut out = Vec::new();
        for c in &self.rollout.collisions {
            let k = c.step - self.rollout.start_step;
            let footprint = |i: usize| {
                let s = self.state(k, i)?;
                let b = self.rollout.bodies.get(i)?;
                Some(OrientedBox::new(s.pose(), b.length_m, b.width_m))
            };
            let (Some(a), Some(b)) = (footprint(c.a.0), footprint(c.b.0)) else { continue };
            let p = super::svg::contact_point(&a, &b);
            let time_ns = self.time_ns(k);
            let at = Pose2 { position: p, heading_rad: 0.0 };
            let text = format!("collision: {} and {} at {}", self.who(c.a.0), self.who(c.b.0), self.time_text(c.step));
            let entity = SceneEntity {
                metadata: vec![
                    kv("a", self.id(c.a.0)),
                    kv("b", self.id(c.b.0)),
                    kv("involves_ego", c.involves_ego.to_string()),
                ],
                spheres: vec![SpherePrimitive {
                    pose: Some(pose3(&at, 1.0)),
                    size: Some(Vector3 { x: 2.0, y: 2.0, z: 2.0 }),
                    color: Some(rgba(COLLIDED.r, COLLIDED.g, COLLIDED.b, 0.6)),
                }],
                texts: vec![TextPrimitive {
                    pose: Some(pose3(&at, 3.0)),
                    billboard: true,
                    font_size: 14.0,
                    scale_invariant: true,
                    color: Some(COLLIDED),
                    text,
                }],
                ..entity(format!("collision/{}/{}", self.id(c.a.0), self.id(c.b.0)), ts(time_ns))
            };
            out.push((time_ns, SceneUpdate { deletions: Vec::new(), entities: vec![entity] }));
        }
        out
    }

    /// What a reviewer reads in Foxglove's log panel.
    fn events(&self) -> Vec<(u64, Log)> {
        let r = self.rollout;
        let log = |time_ns: u64, level: log::Level, message: String| {
            (
                time_ns,
                Log {
                    timestamp: Some(ts(time_ns)),
                    level: level as i32,
                    message,
                    name: "safer".into(),
                    ..Default::default()
                },
            )
        };
        let at = |step: usize| self.time_ns(step.saturating_sub(r.start_step));
        let mut out = vec![log(
            0,
            log::Level::Info,
            format!(
                "rollout of scenario {} with planner {}: ego '{}', CBV {}, {} agents, {} steps of {} s from step {}",
                r.scenario_id,
                r.planner,
                self.id(r.ego.0),
                r.cbv.map_or_else(|| "none".to_string(), |c| format!("'{}'", self.id(c.0))),
                r.bodies.len(),
                r.steps(),
                r.dt_s,
                r.start_step
            ),
        )];
        for c in &r.collisions {
            let level = if c.involves_ego { log::Level::Error } else { log::Level::Warning };
            let message =
                format!("collision at {}: {} and {}", self.time_text(c.step), self.who(c.a.0), self.who(c.b.0));
            out.push(log(at(c.step), level, message));
        }
        for o in &r.off_road {
            let message =
                format!("ego off road at {}: {:.2} m past the road edge", self.time_text(o.step), o.distance_m);
            out.push(log(at(o.step), log::Level::Warning, message));
        }
        match &r.termination {
            Termination::Completed => {}
            Termination::EgoCollision { step } => out.push(log(
                at(*step),
                log::Level::Info,
                format!("rollout stopped at the ego's first collision ({})", self.time_text(*step)),
            )),
            Termination::LeftMappedArea { step } => out.push(log(
                at(*step),
                log::Level::Info,
                format!("rollout ended: the ego left the mapped area ({})", self.time_text(*step)),
            )),
            Termination::PlannerFailed { step, reason } => out.push(log(
                at(*step),
                log::Level::Error,
                format!("planner failed at {}: {reason}", self.time_text(*step)),
            )),
            Termination::VehicleLimitExceeded { step, reason } => out.push(log(
                at(*step),
                log::Level::Error,
                format!("the planner drove the ego beyond its vehicle limits at {}: {reason}", self.time_text(*step)),
            )),
            Termination::InvalidAgentState { step, agent, reason } => out.push(log(
                at(*step),
                log::Level::Error,
                format!("rollout aborted at {}: agent {agent} has an invalid state: {reason}", self.time_text(*step)),
            )),
        }
        out
    }

    /// The rollout in a few strings, readable with `mcap info`-style tools.
    fn metadata(&self, scenario: &Scenario) -> BTreeMap<String, String> {
        let r = self.rollout;
        let mut m = BTreeMap::new();
        let mut put = |k: &str, v: String| {
            m.insert(k.to_string(), v);
        };
        put("scenario", r.scenario_id.clone());
        put("planner", r.planner.clone());
        put("ego", self.id(r.ego.0).to_string());
        put("cbv", r.cbv.map_or_else(String::new, |c| self.id(c.0).to_string()));
        put("start_step", r.start_step.to_string());
        put("steps", r.steps().to_string());
        put("dt_s", r.dt_s.to_string());
        put("frame", FRAME_MAP.to_string());
        put("origin_world_x_m", scenario.origin_world.x.to_string());
        put("origin_world_y_m", scenario.origin_world.y.to_string());
        put("termination", serde_json::to_string(&r.termination).unwrap_or_default());
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::test_support::{crossing_rollout, crossing_scenario};
    use crate::record::{TimedPose, write_rollout_mcap};

    fn messages(bytes: &[u8]) -> Vec<::mcap::Message<'static>> {
        ::mcap::MessageStream::new(bytes).expect("MCAP header").collect::<Result<_, _>>().expect("readable MCAP")
    }

    fn on<'m>(msgs: &'m [::mcap::Message<'static>], topic: &str) -> Vec<&'m ::mcap::Message<'static>> {
        msgs.iter().filter(|m| m.channel.topic == topic).collect()
    }

    fn scene(m: &::mcap::Message) -> SceneUpdate {
        SceneUpdate::decode(&m.data[..]).expect("a foxglove.SceneUpdate")
    }

    #[test]
    fn mcap_reads_back_with_foxglove_channels_and_one_agents_update_per_step() {
        let s = crossing_scenario();
        let r = crossing_rollout(&s);
        let bytes = encode_rollout_mcap(&s, &r, &[]).unwrap();
        let msgs = messages(&bytes);

        let summary = ::mcap::Summary::read(&bytes).unwrap().expect("a summary section");
        let mut topics: Vec<(String, String, String)> = summary
            .channels
            .values()
            .map(|c| {
                let schema = c.schema.as_ref().expect("every channel has a schema");
                assert_eq!(schema.encoding, "protobuf");
                (c.topic.clone(), schema.name.clone(), c.message_encoding.clone())
            })
            .collect();
        topics.sort();
        let scene_update = |t: &str| (t.to_string(), "foxglove.SceneUpdate".to_string(), "protobuf".to_string());
        let mut expected = vec![
            scene_update(TOPIC_AGENTS),
            scene_update(TOPIC_COLLISIONS),
            scene_update(TOPIC_MAP),
            scene_update(TOPIC_PATHS),
            scene_update(TOPIC_WITNESS),
            (TOPIC_EVENTS.into(), "foxglove.Log".into(), "protobuf".into()),
            (TOPIC_TF.into(), "foxglove.FrameTransform".into(), "protobuf".into()),
        ];
        expected.sort();
        assert_eq!(topics, expected);
        assert_eq!(summary.metadata_indexes.len(), 1);

        // One agents update per recorded state (steps + the start), the map once.
        let agents = on(&msgs, TOPIC_AGENTS);
        assert_eq!(agents.len(), r.states.len());
        assert_eq!(r.states.len(), r.steps() + 1);
        assert_eq!(on(&msgs, TOPIC_MAP).len(), 1);
        assert_eq!(on(&msgs, TOPIC_TF).len(), r.states.len());
        // Log times: step times from 0, in order over the whole file.
        for (k, m) in agents.iter().enumerate() {
            assert_eq!(m.log_time, k as u64 * 100_000_000, "step {k}");
            assert_eq!(m.publish_time, m.log_time);
        }
        assert!(msgs.windows(2).all(|w| w[0].log_time <= w[1].log_time));

        // Every agents update: delete-all, then one cube per present agent.
        let collision_k = r.ego_collision().unwrap().step - r.start_step;
        for (k, m) in agents.iter().enumerate() {
            let u = scene(m);
            assert_eq!(u.deletions.len(), 1);
            let present = r.states[k].iter().filter(|s| s.is_some()).count();
            assert_eq!(u.entities.len(), present, "step {k}");
            assert!(u.entities.iter().all(|e| e.cubes.len() == 1 && e.frame_id == FRAME_MAP));
            let ego = u.entities.iter().find(|e| e.id == "agent/ego-1").expect("ego present");
            let colour = ego.cubes[0].color.unwrap();
            assert_eq!(colour, if k < collision_k { EGO } else { COLLIDED }, "step {k}");
            let cbv = u.entities.iter().find(|e| e.id == "agent/cbv-2").expect("CBV present");
            assert_eq!(cbv.texts[0].text, "CBV");
            let size = cbv.cubes[0].size.unwrap();
            assert_eq!((size.x, size.y, size.z), (4.5, 2.0, VEHICLE_HEIGHT_M));
        }
        // The CBV heads north: a quarter turn about z.
        let first = scene(agents[0]);
        let cbv = first.entities.iter().find(|e| e.id == "agent/cbv-2").unwrap();
        let q = cbv.cubes[0].pose.unwrap().orientation.unwrap();
        assert!((q.z - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-9 && (q.w - q.z).abs() < 1e-9, "{q:?}");

        let map = scene(on(&msgs, TOPIC_MAP)[0]);
        let ids: Vec<&str> = map.entities.iter().map(|e| e.id.as_str()).collect();
        assert_eq!(
            ids,
            ["map/crosswalks", "map/lane_centrelines", "map/road_lines", "map/road_edges", "map/stop_signs"]
        );
        let edges = &map.entities[3].lines[0];
        // Four edges of three points: eight segments.
        assert_eq!((edges.points.len(), edges.indices.len()), (12, 16));

        let collisions = on(&msgs, TOPIC_COLLISIONS);
        assert_eq!(collisions.len(), 1);
        assert_eq!(collisions[0].log_time, collision_k as u64 * 100_000_000);
        let marker = scene(collisions[0]);
        assert_eq!(marker.entities[0].id, "collision/ego-1/cbv-2");

        let logs: Vec<Log> = on(&msgs, TOPIC_EVENTS).iter().map(|m| Log::decode(&m.data[..]).unwrap()).collect();
        assert!(logs[0].message.starts_with("rollout of scenario crossing with planner constant-velocity"));
        let hit = logs.iter().find(|l| l.message.contains("collision")).expect("a collision event");
        assert_eq!(hit.message, "collision at t = 3.90 s: ego 'ego-1' (vehicle) and CBV 'cbv-2' (vehicle)");
        assert_eq!(hit.level, log::Level::Error as i32);

        let tf = FrameTransform::decode(&on(&msgs, TOPIC_TF)[10].data[..]).unwrap();
        assert_eq!((tf.parent_frame_id.as_str(), tf.child_frame_id.as_str()), (FRAME_MAP, FRAME_EGO));
        assert!((tf.translation.unwrap().x - 10.0).abs() < 1e-9);
    }

    #[test]
    fn mcap_bytes_are_identical_for_the_same_rollout() {
        let s = crossing_scenario();
        let r = crossing_rollout(&s);
        let a = encode_rollout_mcap(&s, &r, &[]).unwrap();
        let b = encode_rollout_mcap(&s, &crossing_rollout(&s), &[]).unwrap();
        assert!(a == b, "two encodings differ");
    }

    #[test]
    fn mcap_write_is_atomic_and_fails_cleanly_into_a_missing_directory() {
        let tmp = tempfile::Builder::new().prefix("safer-record-mcap-").tempdir().unwrap();
        let dir = tmp.path().to_path_buf();
        let s = crossing_scenario();
        let r = crossing_rollout(&s);
        let path = dir.join("crossing.mcap");
        write_rollout_mcap(&path, &s, &r, &[]).unwrap();
        write_rollout_mcap(&path, &s, &r, &[]).unwrap();
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("crossing.mcap")], "no temporary left behind");
        assert_eq!(std::fs::read(&path).unwrap(), encode_rollout_mcap(&s, &r, &[]).unwrap());

        let missing = dir.join("missing").join("crossing.mcap");
        let err = write_rollout_mcap(&missing, &s, &r, &[]).unwrap_err();
        assert!(matches!(err, RecordError::Io { .. }), "{err}");
        assert!(!missing.exists() && !dir.join("missing").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn mcap_refuses_inconsistent_rollouts() {
        let s = crossing_scenario();
        let good = crossing_rollout(&s);
        let mut ragged = good.clone();
        ragged.states[3].pop();
        let mut bad_dt = good.clone();
        bad_dt.dt_s = f64::NAN;
        let mut bad_cbv = good.clone();
        bad_cbv.cbv = Some(TrackIndex(9));
        let mut bad_collision = good.clone();
        bad_collision.collisions[0].step = 10_000;
        for (r, what) in [(ragged, "step 3"), (bad_dt, "step length"), (bad_cbv, "CBV"), (bad_collision, "collision")] {
            let err = encode_rollout_mcap(&s, &r, &[]).unwrap_err();
            assert!(matches!(err, RecordError::InconsistentRollout { .. }) && err.to_string().contains(what), "{err}");
        }
    }

    #[test]
    fn mcap_skips_non_finite_states() {
        let s = crossing_scenario();
        let mut r = crossing_rollout(&s);
        r.states[5][2].as_mut().unwrap().position.y = f64::NAN;
        let bytes = encode_rollout_mcap(&s, &r, &[]).unwrap();
        let msgs = messages(&bytes);
        let u = scene(on(&msgs, TOPIC_AGENTS)[5]);
        assert_eq!(u.entities.len(), 3);
        assert!(u.entities.iter().all(|e| e.id != "agent/parked-3"));
    }

    #[test]
    fn mcap_records_a_witness_line_and_its_footprints() {
        let s = crossing_scenario();
        let r = crossing_rollout(&s);
        let witness = NamedTrajectory {
            name: "brake".into(),
            role: TrajectoryRole::FeasibilityWitness,
            body: Some(r.bodies[0]),
            poses: (0..=30)
                .map(|k| TimedPose { time_s: 0.1 * k as f64, pose: Pose2::new(k as f64, 0.0, 0.0) })
                .collect(),
        };
        let bytes = encode_rollout_mcap(&s, &r, &[witness]).unwrap();
        let msgs = messages(&bytes);
        let w = on(&msgs, TOPIC_WITNESS);
        // The line at t = 0, then a footprint per step of its 3 s.
        assert_eq!(w.len(), 1 + 31);
        let line = scene(w[0]);
        assert_eq!(line.entities[0].id, "witness/brake");
        assert_eq!(line.entities[0].lines[0].points.len(), 31);
        let last = scene(w[31]);
        assert_eq!(last.entities[0].id, "witness/brake/footprint");
        assert!((last.entities[0].cubes[0].pose.unwrap().position.unwrap().x - 30.0).abs() < 1e-9);
        assert_eq!(w[31].log_time, 3_000_000_000);
    }
}
