//! Waymo Open Motion Dataset `Scenario` protobuf records, read from TFRecord
//! framing ([`super::tfrecord`]) into [`Scenario`]s.
//!
//! This module owns the hand-written prost message structs for the part of
//! Waymo's proto2 schema a scenario needs ([`proto`]; field numbers from Waymo's
//! `scenario.proto` and `map.proto` in the waymo-open-dataset repository,
//! no build script or protoc) and the mapping from them
//! into the crate model: tracks with valid masks, ego and objects of
//! interest, the lane graph, road edges and lines, areas, stop signs and
//! per-lane traffic-signal states. Coordinates stay in Waymo's world frame;
//! [`super::load`] re-centres. Decoded values are sanity-checked (finite
//! coordinates, positive sizes, indices in range) so a corrupt record is an
//! [`ImportError`] naming the record, track and step, never a panic or a
//! silently wrong scenario.

use std::collections::BTreeMap;
use std::path::Path;

use prost::Message;

use super::tfrecord::{self, Record};
use super::{ImportError, Location};
use crate::geometry::{Point2, Polygon, Polyline, Vector2};
use crate::map::{
    AreaKind, Lane, LaneKind, MapArea, MapElementId, RoadEdge, RoadEdgeKind, RoadLine, RoadLineKind, RoadMap,
    SignalState, StopSign, TrafficSignal,
};
use crate::scenario::{
    AgentId, AgentKind, AgentState, DataLicence, Scenario, ScenarioSource, SourceFormat, Track, TrackIndex,
};

/// Miles per hour to metres per second (exact by definition of the mile).
const MPH_TO_MPS: f64 = 0.44704;
/// WOMD's nominal step length, seconds (10 Hz).
const WOMD_STEP_S: f64 = 0.1;

/// Prost message structs for the subset of Waymo's `scenario.proto` and
/// `map.proto` this importer reads. Waymo's schema is proto2, so singular
/// fields are `Option`s: absence is distinguishable from zero. Enum fields
/// are read as plain `int32` codes (the wire encoding is the same), and
/// mapped to the crate's enums where they are used, so an enum value newer
/// than this table degrades to "unknown" instead of failing the decode.
/// Fields not listed here are skipped by prost.
pub mod proto {
    /// `waymo.open_dataset.Scenario`: one recorded scene.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct Scenario {
        /// Time of each step, seconds.
        #[prost(double, repeated, tag = "1")]
        pub timestamps_seconds: Vec<f64>,
        /// Every agent's track.
        #[prost(message, repeated, tag = "2")]
        pub tracks: Vec<Track>,
        /// Track ids (not indices) of an interacting pair, where labelled.
        #[prost(int32, repeated, tag = "4")]
        pub objects_of_interest: Vec<i32>,
        /// Waymo's scenario id.
        #[prost(string, optional, tag = "5")]
        pub scenario_id: Option<String>,
        /// Index into `tracks` of the self-driving car.
        #[prost(int32, optional, tag = "6")]
        pub sdc_track_index: Option<i32>,
        /// Traffic-signal states, one entry per step.
        #[prost(message, repeated, tag = "7")]
        pub dynamic_map_states: Vec<DynamicMapState>,
        /// The static map.
        #[prost(message, repeated, tag = "8")]
        pub map_features: Vec<MapFeature>,
        /// Index of "now" into `timestamps_seconds`.
        #[prost(int32, optional, tag = "10")]
        pub current_time_index: Option<i32>,
        /// Tracks the motion-prediction challenge asks to predict.
        #[prost(message, repeated, tag = "11")]
        pub tracks_to_predict: Vec<RequiredPrediction>,
    }

    /// `Track`: one agent over all steps.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct Track {
        /// Waymo's object id, unique within the scenario.
        #[prost(int32, optional, tag = "1")]
        pub id: Option<i32>,
        /// `ObjectType` code: 0 unset, 1 vehicle, 2 pedestrian, 3 cyclist, 4 other.
        #[prost(int32, optional, tag = "2")]
        pub object_type: Option<i32>,
        /// One state per step.
        #[prost(message, repeated, tag = "3")]
        pub states: Vec<ObjectState>,
    }

    /// `ObjectState`: an agent's box and velocity at one step.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct ObjectState {
        /// Box centre x, metres.
        #[prost(double, optional, tag = "2")]
        pub center_x: Option<f64>,
        /// Box centre y, metres.
        #[prost(double, optional, tag = "3")]
        pub center_y: Option<f64>,
        /// Box centre z, metres.
        #[prost(double, optional, tag = "4")]
        pub center_z: Option<f64>,
        /// Box length, metres.
        #[prost(float, optional, tag = "5")]
        pub length: Option<f32>,
        /// Box width, metres.
        #[prost(float, optional, tag = "6")]
        pub width: Option<f32>,
        /// Box height, metres.
        #[prost(float, optional, tag = "7")]
        pub height: Option<f32>,
        /// Heading, radians.
        #[prost(float, optional, tag = "8")]
        pub heading: Option<f32>,
        /// Velocity x, m/s.
        #[prost(float, optional, tag = "9")]
        pub velocity_x: Option<f32>,
        /// Velocity y, m/s.
        #[prost(float, optional, tag = "10")]
        pub velocity_y: Option<f32>,
        /// Whether this step was observed.
        #[prost(bool, optional, tag = "11")]
        pub valid: Option<bool>,
    }

    /// `RequiredPrediction`: a track the challenge asks to predict.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct RequiredPrediction {
        /// Index into `Scenario.tracks`.
        #[prost(int32, optional, tag = "1")]
        pub track_index: Option<i32>,
        /// `DifficultyLevel` code.
        #[prost(int32, optional, tag = "2")]
        pub difficulty: Option<i32>,
    }

    /// `DynamicMapState`: every signal's state at one step.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct DynamicMapState {
        /// One entry per signal-controlled lane.
        #[prost(message, repeated, tag = "1")]
        pub lane_states: Vec<TrafficSignalLaneState>,
    }

    /// `TrafficSignalLaneState`: the signal of one lane at one step.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct TrafficSignalLaneState {
        /// Controlled lane's map-feature id.
        #[prost(int64, optional, tag = "1")]
        pub lane: Option<i64>,
        /// `State` code: 0 unknown, 1 arrow stop, 2 arrow caution, 3 arrow go,
        /// 4 stop, 5 caution, 6 go, 7 flashing stop, 8 flashing caution.
        #[prost(int32, optional, tag = "2")]
        pub state: Option<i32>,
        /// Where the lane's stop line is.
        #[prost(message, optional, tag = "3")]
        pub stop_point: Option<MapPoint>,
    }

    /// `MapFeature`: one element of the static map.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct MapFeature {
        /// Map-unique id.
        #[prost(int64, optional, tag = "1")]
        pub id: Option<i64>,
        /// What the feature is.
        #[prost(oneof = "FeatureData", tags = "3, 4, 5, 7, 8, 9, 10")]
        pub feature_data: Option<FeatureData>,
    }

    /// `MapFeature.feature_data`: the kinds of map feature.
    #[derive(Clone, PartialEq, prost::Oneof)]
    pub enum FeatureData {
        /// A lane centreline.
        #[prost(message, tag = "3")]
        Lane(LaneCenter),
        /// A painted line.
        #[prost(message, tag = "4")]
        RoadLine(RoadLine),
        /// A road edge (curb, median).
        #[prost(message, tag = "5")]
        RoadEdge(RoadEdge),
        /// A stop sign.
        #[prost(message, tag = "7")]
        StopSign(StopSign),
        /// A crosswalk polygon.
        #[prost(message, tag = "8")]
        Crosswalk(Crosswalk),
        /// A speed-bump polygon.
        #[prost(message, tag = "9")]
        SpeedBump(SpeedBump),
        /// A driveway polygon.
        #[prost(message, tag = "10")]
        Driveway(Driveway),
    }

    /// `MapPoint`: a point in the world frame, metres.
    #[derive(Clone, Copy, PartialEq, prost::Message)]
    pub struct MapPoint {
        /// x, metres.
        #[prost(double, optional, tag = "1")]
        pub x: Option<f64>,
        /// y, metres.
        #[prost(double, optional, tag = "2")]
        pub y: Option<f64>,
        /// z, metres.
        #[prost(double, optional, tag = "3")]
        pub z: Option<f64>,
    }

    /// `LaneCenter`: a lane's centreline and its connectivity.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct LaneCenter {
        /// Speed limit, miles per hour.
        #[prost(double, optional, tag = "1")]
        pub speed_limit_mph: Option<f64>,
        /// `LaneType` code: 0 undefined, 1 freeway, 2 surface street, 3 bike lane.
        #[prost(int32, optional, tag = "2")]
        pub r#type: Option<i32>,
        /// Whether the lane interpolates between others (e.g. across an intersection).
        #[prost(bool, optional, tag = "3")]
        pub interpolating: Option<bool>,
        /// Centreline in driving direction.
        #[prost(message, repeated, tag = "8")]
        pub polyline: Vec<MapPoint>,
        /// Lanes that lead into this one.
        #[prost(int64, repeated, tag = "9")]
        pub entry_lanes: Vec<i64>,
        /// Lanes this one leads into.
        #[prost(int64, repeated, tag = "10")]
        pub exit_lanes: Vec<i64>,
        /// Neighbours on the left.
        #[prost(message, repeated, tag = "11")]
        pub left_neighbors: Vec<LaneNeighbor>,
        /// Neighbours on the right.
        #[prost(message, repeated, tag = "12")]
        pub right_neighbors: Vec<LaneNeighbor>,
        /// Boundary features on the left, by centreline index range.
        #[prost(message, repeated, tag = "13")]
        pub left_boundaries: Vec<BoundarySegment>,
        /// Boundary features on the right, by centreline index range.
        #[prost(message, repeated, tag = "14")]
        pub right_boundaries: Vec<BoundarySegment>,
    }

    /// `LaneNeighbor`: a lane beside another over an index range.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct LaneNeighbor {
        /// The neighbouring lane's id.
        #[prost(int64, optional, tag = "1")]
        pub feature_id: Option<i64>,
        /// First centreline index of this lane alongside the neighbour.
        #[prost(int32, optional, tag = "2")]
        pub self_start_index: Option<i32>,
        /// Last centreline index of this lane alongside the neighbour.
        #[prost(int32, optional, tag = "3")]
        pub self_end_index: Option<i32>,
        /// First centreline index of the neighbour.
        #[prost(int32, optional, tag = "4")]
        pub neighbor_start_index: Option<i32>,
        /// Last centreline index of the neighbour.
        #[prost(int32, optional, tag = "5")]
        pub neighbor_end_index: Option<i32>,
        /// Boundaries between the two lanes.
        #[prost(message, repeated, tag = "6")]
        pub boundaries: Vec<BoundarySegment>,
    }

    /// `BoundarySegment`: a road line or edge bounding part of a lane.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct BoundarySegment {
        /// First centreline index this boundary covers.
        #[prost(int32, optional, tag = "1")]
        pub lane_start_index: Option<i32>,
        /// Last centreline index this boundary covers (inclusive).
        #[prost(int32, optional, tag = "2")]
        pub lane_end_index: Option<i32>,
        /// Id of the road line or road edge feature.
        #[prost(int64, optional, tag = "3")]
        pub boundary_feature_id: Option<i64>,
        /// `RoadLineType` code of the boundary.
        #[prost(int32, optional, tag = "4")]
        pub boundary_type: Option<i32>,
    }

    /// `RoadLine`: a painted line.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct RoadLine {
        /// `RoadLineType` code: 0 unknown … 8 passing double yellow.
        #[prost(int32, optional, tag = "1")]
        pub r#type: Option<i32>,
        /// The line.
        #[prost(message, repeated, tag = "2")]
        pub polyline: Vec<MapPoint>,
    }

    /// `RoadEdge`: a boundary of the drivable road.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct RoadEdge {
        /// `RoadEdgeType` code: 0 unknown, 1 boundary, 2 median.
        #[prost(int32, optional, tag = "1")]
        pub r#type: Option<i32>,
        /// The edge.
        #[prost(message, repeated, tag = "2")]
        pub polyline: Vec<MapPoint>,
    }

    /// `StopSign`: a sign and the lanes it controls.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct StopSign {
        /// Controlled lanes.
        #[prost(int64, repeated, tag = "1")]
        pub lane: Vec<i64>,
        /// Where the sign is.
        #[prost(message, optional, tag = "2")]
        pub position: Option<MapPoint>,
    }

    /// `Crosswalk`: a pedestrian crossing.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct Crosswalk {
        /// Outline.
        #[prost(message, repeated, tag = "1")]
        pub polygon: Vec<MapPoint>,
    }

    /// `SpeedBump`: a speed bump.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct SpeedBump {
        /// Outline.
        #[prost(message, repeated, tag = "1")]
        pub polygon: Vec<MapPoint>,
    }

    /// `Driveway`: a driveway.
    #[derive(Clone, PartialEq, prost::Message)]
    pub struct Driveway {
        /// Outline.
        #[prost(message, repeated, tag = "1")]
        pub polygon: Vec<MapPoint>,
    }
}

/// Parses every `Scenario` record of a TFRecord file. Framing errors, decode
/// errors and implausible values are reported with the record's index and
/// byte offset; an empty file is an error (it holds no scenario).
pub fn parse(bytes: &[u8], path: &Path) -> Result<Vec<Scenario>, ImportError> {
    scenario_records(bytes, path)?.iter().map(|record| parse_record(record, path)).collect()
}

/// The records of a TFRecord file; an empty file is an error (it holds no
/// scenario).
fn scenario_records<'a>(bytes: &'a [u8], path: &Path) -> Result<Vec<Record<'a>>, ImportError> {
    let records = tfrecord::read_records(bytes, path)?;
    if records.is_empty() {
        return Err(ImportError::malformed(path, SourceFormat::WomdProto, Location::File, "empty file: no records"));
    }
    Ok(records)
}

/// Decodes a record's payload as `M` (the whole `Scenario`, or a part of
/// it), an error naming the record when it is not one.
fn decode<M: Message + Default>(record: &Record<'_>, path: &Path) -> Result<M, ImportError> {
    M::decode(record.payload).map_err(|e| {
        ImportError::malformed(
            path,
            SourceFormat::WomdProto,
            record.location(),
            format!("not a WOMD Scenario protobuf: {e}"),
        )
    })
}

/// The id of a record without a scenario id of its own.
fn fallback_id(path: &Path, index: usize) -> String {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    format!("{stem}#{index}")
}

/// The scenario id of every record of a TFRecord file, in order, without
/// decoding the scenes (only the id field is read; the rest is skipped).
/// A record without an id gets the one [`parse_record`] gives it
/// (`STEM#index`). Framing errors are reported as [`parse`] reports them.
pub fn scenario_ids(bytes: &[u8], path: &Path) -> Result<Vec<String>, ImportError> {
    /// `Scenario` with only its id: prost skips every other field.
    #[derive(Clone, PartialEq, prost::Message)]
    struct IdOnly {
        #[prost(string, optional, tag = "5")]
        scenario_id: Option<String>,
    }
    scenario_records(bytes, path)?
        .iter()
        .map(|record| {
            let message: IdOnly = decode(record, path)?;
            Ok(message.scenario_id.filter(|id| !id.is_empty()).unwrap_or_else(|| fallback_id(path, record.index)))
        })
        .collect()
}

/// Decodes one record and maps it into the crate model.
pub fn parse_record(record: &Record<'_>, path: &Path) -> Result<Scenario, ImportError> {
    let message: proto::Scenario = decode(record, path)?;
    Converter { path, record }.scenario(message)
}

/// Carries the record's whereabouts so every error can name it.
struct Converter<'a> {
    path: &'a Path,
    record: &'a Record<'a>,
}

impl Converter<'_> {
    /// An error at an element inside the record, such as `tracks[3].states[17]`.
    fn at(&self, element: impl std::fmt::Display, message: impl Into<String>) -> ImportError {
        ImportError::malformed(
            self.path,
            SourceFormat::WomdProto,
            Location::Element(format!("record {} (byte {}): {element}", self.record.index, self.record.byte_offset)),
            message,
        )
    }

    fn scenario(&self, message: proto::Scenario) -> Result<Scenario, ImportError> {
        let mut notes = vec![format!("TFRecord record {} at byte {}", self.record.index, self.record.byte_offset)];
        let num_steps = message.timestamps_seconds.len();
        let measured_dt_s = self.step_length(&message.timestamps_seconds)?;
        // WOMD is recorded at a nominal 10 Hz with timestamps that jitter by
        // a few milliseconds (one shared file averages 0.10024 s); the
        // simulator and token grid work on the nominal step.
        let dt_s = if ((measured_dt_s - WOMD_STEP_S) / WOMD_STEP_S).abs() < 0.01 {
            if (measured_dt_s - WOMD_STEP_S).abs() > 1e-6 {
                notes.push(format!("timestamps average {measured_dt_s:.5} s per step; nominal {WOMD_STEP_S} s used"));
            }
            WOMD_STEP_S
        } else {
            notes.push(format!("timestamps average {measured_dt_s:.5} s per step, not WOMD's nominal {WOMD_STEP_S} s"));
            measured_dt_s
        };
        let current_step = match message.current_time_index {
            Some(i) if i >= 0 && (i as usize) < num_steps => i as usize,
            Some(i) => {
                return Err(self.at("current_time_index", format!("{i} is outside the {num_steps} timestamps")));
            }
            None => return Err(self.at("current_time_index", "missing")),
        };
        if message.tracks.is_empty() {
            return Err(self.at("tracks", "the scenario has no tracks"));
        }
        let mut tracks = Vec::with_capacity(message.tracks.len());
        let mut sizeless = 0usize;
        for (i, t) in message.tracks.iter().enumerate() {
            let (track, had_size) = self.track(i, t, num_steps)?;
            sizeless += usize::from(!had_size);
            tracks.push(track);
        }
        if sizeless > 0 {
            notes.push(format!("{sizeless} tracks have no valid state; they got a default size for their type"));
        }

        let ego = match message.sdc_track_index {
            Some(i) if i >= 0 && (i as usize) < tracks.len() => Some(TrackIndex(i as usize)),
            Some(i) => {
                return Err(self.at("sdc_track_index", format!("{i} is outside the {} tracks", tracks.len())));
            }
            None => None,
        };
        let index_by_id: BTreeMap<&str, usize> = tracks.iter().enumerate().map(|(i, t)| (t.id.0.as_str(), i)).collect();
        let mut objects_of_interest = Vec::new();
        for id in &message.objects_of_interest {
            match index_by_id.get(id.to_string().as_str()) {
                Some(&i) => objects_of_interest.push(TrackIndex(i)),
                None => notes.push(format!("object of interest {id} names no track; ignored")),
            }
        }
        let cbv = cbv_from_objects_of_interest(&tracks, ego, &objects_of_interest);

        let map = self.map(&message.map_features, &message.dynamic_map_states, num_steps)?;
        let id = match message.scenario_id {
            Some(id) if !id.is_empty() => id,
            _ => fallback_id(self.path, self.record.index),
        };
        Ok(Scenario {
            current_step,
            objects_of_interest,
            ..Scenario::new(
                id,
                ScenarioSource {
                    format: SourceFormat::WomdProto,
                    path: self.path.to_path_buf(),
                    licence: DataLicence::WaymoNonCommercial,
                    notes,
                },
                dt_s,
                map,
                tracks,
            )
        }
        .with_source_roles(ego, cbv))
    }

    /// The mean step length of the timestamps, which must increase.
    fn step_length(&self, timestamps: &[f64]) -> Result<f64, ImportError> {
        let (Some(first), Some(last)) = (timestamps.first(), timestamps.last()) else {
            return Err(self.at("timestamps_seconds", "missing"));
        };
        if timestamps.len() < 2 {
            return Err(self.at("timestamps_seconds", "a scenario needs at least two steps"));
        }
        for (k, pair) in timestamps.windows(2).enumerate() {
            if let [a, b] = pair
                && !(a.is_finite() && b.is_finite() && b > a)
            {
                return Err(self.at(format!("timestamps_seconds[{}]", k + 1), format!("{b} s does not follow {a} s")));
            }
        }
        Ok((last - first) / (timestamps.len() - 1) as f64)
    }

    /// One track. Returns whether its size came from the data (`false`: no
    /// valid state, default size for its type).
    fn track(&self, i: usize, t: &proto::Track, num_steps: usize) -> Result<(Track, bool), ImportError> {
        let id = match t.id {
            Some(id) => AgentId(id.to_string()),
            None => return Err(self.at(format!("tracks[{i}].id"), "missing")),
        };
        let element = |what: &str| format!("tracks[{i}] (id {id}){what}");
        if t.states.len() != num_steps {
            return Err(self.at(
                element(".states"),
                format!("{} states, but the scenario has {num_steps} timestamps", t.states.len()),
            ));
        }
        let kind = match t.object_type.unwrap_or(0) {
            1 => AgentKind::Vehicle,
            2 => AgentKind::Pedestrian,
            3 => AgentKind::Cyclist,
            _ => AgentKind::Other,
        };
        let mut states = Vec::with_capacity(num_steps);
        let mut size = None;
        for (k, s) in t.states.iter().enumerate() {
            if s.valid != Some(true) {
                states.push(None);
                continue;
            }
            let values = [
                s.center_x.unwrap_or(f64::NAN),
                s.center_y.unwrap_or(f64::NAN),
                f64::from(s.heading.unwrap_or(f32::NAN)),
                f64::from(s.velocity_x.unwrap_or(f32::NAN)),
                f64::from(s.velocity_y.unwrap_or(f32::NAN)),
            ];
            let [x, y, heading, vx, vy] = values;
            if !values.iter().all(|v| v.is_finite()) {
                return Err(self.at(
                    element(&format!(".states[{k}]")),
                    format!(
                        "valid state with missing or non-finite values: centre ({x}, {y}), heading {heading}, velocity ({vx}, {vy})"
                    ),
                ));
            }
            if size.is_none() {
                let (length, width) = (s.length.unwrap_or(f32::NAN), s.width.unwrap_or(f32::NAN));
                if !(length.is_finite() && length > 0.0 && width.is_finite() && width > 0.0) {
                    return Err(self.at(
                        element(&format!(".states[{k}]")),
                        format!("first valid state has size {length} x {width} m; sizes must be positive"),
                    ));
                }
                size = Some((f64::from(length), f64::from(width)));
            }
            let heading_rad = crate::scenario::bounds::recorded_heading(heading)
                .map_err(|e| self.at(element(&format!(".states[{k}]")), e))?;
            states.push(Some(AgentState {
                position: Point2::new(x, y),
                heading_rad,
                velocity_mps: Vector2::new(vx, vy),
            }));
        }
        let had_size = size.is_some();
        let (length_m, width_m) = size.unwrap_or_else(|| default_size(kind));
        Ok((Track { id, kind, length_m, width_m, states }, had_size))
    }

    /// A polyline of map points, each finite.
    fn polyline(&self, element: &str, points: &[proto::MapPoint]) -> Result<Vec<Point2>, ImportError> {
        points.iter().enumerate().map(|(k, p)| self.point(&format!("{element}[{k}]"), p)).collect()
    }

    fn point(&self, element: &str, p: &proto::MapPoint) -> Result<Point2, ImportError> {
        match (p.x, p.y) {
            (Some(x), Some(y)) if x.is_finite() && y.is_finite() => Ok(Point2::new(x, y)),
            (x, y) => Err(self.at(element, format!("point ({x:?}, {y:?}) is missing or not finite"))),
        }
    }

    fn map(
        &self,
        features: &[proto::MapFeature],
        dynamic: &[proto::DynamicMapState],
        num_steps: usize,
    ) -> Result<RoadMap, ImportError> {
        use proto::FeatureData as F;
        // Lane boundaries refer to road lines and edges by id; collect those first.
        // Invalid points are skipped here; they are reported where the
        // feature itself is read.
        let mut boundary_lines: BTreeMap<i64, Polyline> = BTreeMap::new();
        for f in features {
            let points = match &f.feature_data {
                Some(F::RoadLine(l)) => &l.polyline,
                Some(F::RoadEdge(e)) => &e.polyline,
                _ => continue,
            };
            if let Some(id) = f.id {
                let valid = points
                    .iter()
                    .filter_map(|p| Some(Point2::new(p.x?, p.y?)))
                    .filter(|p| p.x.is_finite() && p.y.is_finite());
                boundary_lines.insert(id, Polyline::new(valid.collect()));
            }
        }
        let (mut lanes, mut road_edges, mut road_lines, mut areas, mut stop_signs) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (j, f) in features.iter().enumerate() {
            let Some(raw_id) = f.id else {
                return Err(self.at(format!("map_features[{j}].id"), "missing"));
            };
            let id = MapElementId(raw_id);
            let element = |what: &str| format!("map_features[{j}] (id {raw_id}).{what}");
            match &f.feature_data {
                Some(F::Lane(l)) => {
                    let points = self.polyline(&element("lane.polyline"), &l.polyline)?;
                    let left_boundary = lane_boundary(&points, &l.left_boundaries, &boundary_lines);
                    let right_boundary = lane_boundary(&points, &l.right_boundaries, &boundary_lines);
                    let centreline = Polyline::new(points);
                    let speed_limit_mps =
                        l.speed_limit_mph.filter(|v| v.is_finite() && *v > 0.0).map(|mph| mph * MPH_TO_MPS);
                    lanes.push(Lane {
                        id,
                        centreline,
                        kind: match l.r#type.unwrap_or(0) {
                            1 => LaneKind::Freeway,
                            2 => LaneKind::SurfaceStreet,
                            3 => LaneKind::BikeLane,
                            _ => LaneKind::Undefined,
                        },
                        speed_limit_mps,
                        predecessors: l.entry_lanes.iter().copied().map(MapElementId).collect(),
                        successors: l.exit_lanes.iter().copied().map(MapElementId).collect(),
                        left_neighbours: l
                            .left_neighbors
                            .iter()
                            .filter_map(|n| n.feature_id)
                            .map(MapElementId)
                            .collect(),
                        right_neighbours: l
                            .right_neighbors
                            .iter()
                            .filter_map(|n| n.feature_id)
                            .map(MapElementId)
                            .collect(),
                        left_boundary,
                        right_boundary,
                        // WOMD has no intersection flag; `interpolating` lanes are
                        // often intersection connectors but not only those.
                        in_intersection: false,
                        crosses_lanes: false,
                        stop_line: None,
                    });
                }
                Some(F::RoadLine(l)) => road_lines.push(RoadLine {
                    id,
                    polyline: Polyline::new(self.polyline(&element("road_line.polyline"), &l.polyline)?),
                    kind: RoadLineKind::from_womd(l.r#type.unwrap_or(0)),
                }),
                Some(F::RoadEdge(e)) => road_edges.push(RoadEdge {
                    id,
                    polyline: Polyline::new(self.polyline(&element("road_edge.polyline"), &e.polyline)?),
                    kind: road_edge_kind(e.r#type.unwrap_or(0)),
                }),
                Some(F::StopSign(s)) => {
                    let Some(p) = &s.position else {
                        return Err(self.at(element("stop_sign.position"), "missing"));
                    };
                    stop_signs.push(StopSign {
                        id,
                        position: self.point(&element("stop_sign.position"), p)?,
                        lanes: s.lane.iter().copied().map(MapElementId).collect(),
                    });
                }
                Some(F::Crosswalk(a)) => {
                    let polygon = Polygon::new(self.polyline(&element("crosswalk.polygon"), &a.polygon)?);
                    areas.push(MapArea { id, kind: AreaKind::Crosswalk, polygon });
                }
                Some(F::SpeedBump(a)) => {
                    let polygon = Polygon::new(self.polyline(&element("speed_bump.polygon"), &a.polygon)?);
                    areas.push(MapArea { id, kind: AreaKind::SpeedBump, polygon });
                }
                Some(F::Driveway(a)) => {
                    let polygon = Polygon::new(self.polyline(&element("driveway.polygon"), &a.polygon)?);
                    areas.push(MapArea { id, kind: AreaKind::Driveway, polygon });
                }
                // A feature kind this table does not know (or none): nothing to draw.
                None => {}
            }
        }
        let traffic_signals = self.traffic_signals(dynamic, num_steps)?;
        let mut map = RoadMap::new(lanes, road_edges, road_lines, areas, Vec::new(), stop_signs, traffic_signals);
        // WOMD flags no junction lanes: take them from where lanes cross.
        map.mark_crossing_lanes_as_junctions();
        Ok(map)
    }

    /// Per-lane signal states over the steps, from one `DynamicMapState` per
    /// step. Steps a lane is not listed in are [`SignalState::Unknown`]; the
    /// stop point is the first one given.
    fn traffic_signals(
        &self,
        dynamic: &[proto::DynamicMapState],
        num_steps: usize,
    ) -> Result<Vec<TrafficSignal>, ImportError> {
        if dynamic.len() > num_steps {
            return Err(self
                .at("dynamic_map_states", format!("{} entries, more than the {num_steps} timestamps", dynamic.len())));
        }
        let mut by_lane: BTreeMap<i64, TrafficSignal> = BTreeMap::new();
        for (step, d) in dynamic.iter().enumerate() {
            for (k, s) in d.lane_states.iter().enumerate() {
                let element = format!("dynamic_map_states[{step}].lane_states[{k}]");
                let Some(lane) = s.lane else {
                    return Err(self.at(format!("{element}.lane"), "missing"));
                };
                let stop_point = match &s.stop_point {
                    Some(p) => Some(self.point(&format!("{element}.stop_point"), p)?),
                    None => None,
                };
                let signal = by_lane.entry(lane).or_insert_with(|| TrafficSignal {
                    lane: MapElementId(lane),
                    stop_point: None,
                    states: vec![SignalState::Unknown; num_steps],
                });
                if signal.stop_point.is_none() {
                    signal.stop_point = stop_point;
                }
                if let Some(slot) = signal.states.get_mut(step) {
                    *slot = SignalState::from_womd(s.state.unwrap_or(0));
                }
            }
        }
        Ok(by_lane.into_values().collect())
    }
}

/// A lane boundary pieced together from its boundary segments: for each
/// segment (in centreline order), the stretch of the referenced road line or
/// edge between the projections of the segment's first and last centreline
/// points, oriented along the lane. `centreline` holds the lane's points as
/// the source lists them, since segment indices refer to those. Segments
/// naming a missing feature or indices past the centreline are skipped;
/// `None` when fewer than two points remain.
fn lane_boundary(
    centreline: &[Point2],
    segments: &[proto::BoundarySegment],
    lines: &BTreeMap<i64, Polyline>,
) -> Option<Polyline> {
    let mut sorted: Vec<&proto::BoundarySegment> = segments.iter().collect();
    sorted.sort_by_key(|s| s.lane_start_index.unwrap_or(0));
    let mut out = Vec::new();
    for s in sorted {
        let Some(boundary) = s.boundary_feature_id.and_then(|id| lines.get(&id)) else {
            continue;
        };
        let index = |i: Option<i32>| usize::try_from(i.unwrap_or(0)).ok();
        let (Some(start), Some(end)) = (index(s.lane_start_index), index(s.lane_end_index)) else {
            continue;
        };
        let (Some(first), Some(last)) = (centreline.get(start), centreline.get(end)) else {
            continue;
        };
        let (Some(a), Some(b)) = (boundary.project(first), boundary.project(last)) else {
            continue;
        };
        // One projection per end keeps this linear in the boundary's size;
        // the boundary's own vertices in between carry its shape.
        let (lo, hi) = (a.arc_length_m.min(b.arc_length_m), a.arc_length_m.max(b.arc_length_m));
        let mut arc = 0.0;
        let mut previous: Option<&Point2> = None;
        let mut inner = Vec::new();
        for p in boundary.points() {
            arc += previous.map_or(0.0, |q| (p - q).norm());
            previous = Some(p);
            if arc > lo && arc < hi {
                inner.push(*p);
            }
        }
        if a.arc_length_m > b.arc_length_m {
            inner.reverse();
        }
        out.push(a.point);
        out.extend(inner);
        out.push(b.point);
    }
    let line = Polyline::new(out);
    (line.len() >= 2).then_some(line)
}

/// WOMD `RoadEdgeType` code to the crate's kind.
fn road_edge_kind(code: i32) -> RoadEdgeKind {
    match code {
        1 => RoadEdgeKind::Boundary,
        2 => RoadEdgeKind::Median,
        _ => RoadEdgeKind::Unknown,
    }
}

/// Size for a track the source never observed (so never sized): typical
/// dimensions of its type, metres. Such a track has no valid state, so the
/// size is never used for a footprint; it only keeps the invariants.
pub(crate) fn default_size(kind: AgentKind) -> (f64, f64) {
    match kind {
        AgentKind::Vehicle => (4.5, 2.0),
        AgentKind::Pedestrian => (0.6, 0.6),
        AgentKind::Cyclist => (1.8, 0.7),
        AgentKind::Other => (1.0, 1.0),
    }
}

/// The CBV a WOMD source implies: when the objects of interest are the ego
/// and exactly one other track, and that one is a vehicle, it is the ego's
/// labelled interaction partner.
pub(crate) fn cbv_from_objects_of_interest(
    tracks: &[Track],
    ego: Option<TrackIndex>,
    objects_of_interest: &[TrackIndex],
) -> Option<TrackIndex> {
    let ego = ego?;
    if !objects_of_interest.contains(&ego) {
        return None;
    }
    let mut others = objects_of_interest.iter().copied().filter(|&i| i != ego);
    let (Some(other), None) = (others.next(), others.next()) else {
        return None;
    };
    (tracks.get(other.0)?.kind == AgentKind::Vehicle).then_some(other)
}
