//! WOMD scenes in the nocturne / GPUDrive JSON format, read into a
//! [`Scenario`].
//!
//! This module owns the typed serde structs of that format and the mapping
//! into the crate model. Three generations of the format live side by side
//! (measured on the shared files):
//!
//! | generation | `scenario_id` | `metadata` | heading | invalid steps hold |
//! | --- | --- | --- | --- | --- |
//! | oldest | no | no | degrees | -10000 |
//! | middle | yes | no | degrees (one file: radians) | 0.0001 |
//! | newest | yes | yes | radians | -10000 |
//!
//! The heading unit is therefore decided from the data: for moving vehicles
//! the velocity direction is compared with the heading read as radians and
//! as degrees, and the unit that agrees wins; the presence of `metadata` is
//! only the fallback when too few vehicles move. The decision, and any
//! disagreement with the metadata rule, is recorded in
//! [`ScenarioSource::notes`]. A step is valid only when `valid` is true and
//! none of its values is a sentinel.
//!
//! Syntax errors are reported at their line and column; a document that
//! parses but has the wrong shape (lists of different lengths, indices out
//! of range) at the element path, such as `objects[3].heading`.
//! Coordinates stay in the world frame; [`super::load`] re-centres.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use super::womd_proto::{cbv_from_objects_of_interest, default_size};
use super::{ImportError, Location};
use crate::geometry::{Point2, Polygon, Polyline, Vector2, wrap_angle};
use crate::map::{
    AreaKind, Lane, LaneKind, MapArea, MapElementId, RoadEdge, RoadEdgeKind, RoadLine, RoadLineKind, RoadMap,
    SignalState, StopSign, TrafficSignal,
};
use crate::scenario::{
    AgentId, AgentKind, AgentState, DataLicence, Scenario, ScenarioSource, SourceFormat, Track, TrackIndex,
};

/// Step length of every WOMD scene, seconds (10 Hz).
const WOMD_STEP_S: f64 = 0.1;
/// Index of "now" in WOMD scenes: one second of history.
const WOMD_CURRENT_STEP: usize = 10;
/// Value the converters write into position, heading and velocity of an
/// unobserved step.
const SENTINEL: f64 = -10000.0;
/// Placeholder the middle generation writes into unobserved steps instead.
const PLACEHOLDER: f64 = 0.0001;
/// A vehicle faster than this has a velocity direction that tells its
/// heading; slower ones (parked, creeping) have noisy velocity.
const MOVING_SPEED_MPS: f64 = 2.0;
/// Heading and velocity direction within this angle count as agreeing
/// (generous: the test only has to tell radians from degrees apart).
const AGREEMENT_RAD: f64 = 0.5;
/// Fewer moving samples than this do not decide the heading unit.
const MIN_UNIT_SAMPLES: usize = 10;

/// The top-level document.
#[derive(Debug, Deserialize)]
struct SceneJson {
    /// File name the converter wrote.
    #[serde(default)]
    name: Option<String>,
    /// Waymo scenario id (middle and newest generations).
    #[serde(default)]
    scenario_id: Option<String>,
    /// Agents.
    objects: Vec<ObjectJson>,
    /// Map elements.
    roads: Vec<RoadJson>,
    /// Traffic signals keyed by controlled lane id.
    #[serde(default)]
    tl_states: BTreeMap<String, SignalJson>,
    /// Ego and interaction labels (newest generation only).
    #[serde(default)]
    metadata: Option<MetadataJson>,
}

/// One agent.
#[derive(Debug, Deserialize)]
struct ObjectJson {
    /// `vehicle`, `pedestrian`, `cyclist`.
    #[serde(rename = "type")]
    kind: String,
    /// Box length, metres.
    length: f64,
    /// Box width, metres.
    width: f64,
    /// Box centre per step.
    position: Vec<PointJson>,
    /// Heading per step (unit depends on the generation).
    heading: Vec<f64>,
    /// Velocity per step, m/s.
    velocity: Vec<VelocityJson>,
    /// Whether each step was observed.
    valid: Vec<bool>,
    /// Waymo track id, where the converter kept it.
    #[serde(default)]
    id: Option<i64>,
}

/// A point; `z` is ignored.
#[derive(Debug, Clone, Copy, Deserialize)]
struct PointJson {
    x: f64,
    y: f64,
}

/// A velocity, m/s.
#[derive(Debug, Clone, Copy, Deserialize)]
struct VelocityJson {
    x: f64,
    y: f64,
}

/// One map element.
#[derive(Debug, Deserialize)]
struct RoadJson {
    /// `lane`, `road_edge`, `road_line`, `crosswalk`, `stop_sign`, `driveway`, `speed_bump`.
    #[serde(rename = "type")]
    kind: String,
    /// Points: a centreline, a line, a polygon outline, or one point.
    geometry: Vec<PointJson>,
    /// Waymo map-feature id, where the converter kept it.
    #[serde(default)]
    id: Option<i64>,
    /// GPUDrive's map-element code, which carries the WOMD subtype: lanes
    /// 0–3, road lines 5–13, road edges 14–16.
    #[serde(default)]
    map_element_id: Option<i64>,
}

/// One lane's signal over the steps it was observed in.
#[derive(Debug, Deserialize)]
struct SignalJson {
    /// State names (`unknown`, `stop`, `go`, `caution`, `arrow_stop`, …).
    state: Vec<String>,
    /// Step of each entry; absent means entry `k` is step `k`.
    #[serde(default)]
    time_index: Option<Vec<i64>>,
    /// Stop point x per entry.
    #[serde(default)]
    x: Vec<f64>,
    /// Stop point y per entry.
    #[serde(default)]
    y: Vec<f64>,
}

/// Labels of the newest generation.
#[derive(Debug, Deserialize)]
struct MetadataJson {
    /// Index of the ego in `objects`.
    #[serde(default)]
    sdc_track_index: Option<i64>,
    /// Object ids (not indices) of an interacting pair.
    #[serde(default)]
    objects_of_interest: Vec<i64>,
}

/// Unit of the `heading` lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum HeadingUnit {
    Radians,
    Degrees,
}

impl HeadingUnit {
    fn name(self) -> &'static str {
        match self {
            Self::Radians => "radians",
            Self::Degrees => "degrees",
        }
    }

    fn to_radians(self, heading: f64) -> f64 {
        match self {
            Self::Radians => heading,
            Self::Degrees => heading.to_radians(),
        }
    }
}

/// Parses one JSON scene.
pub fn parse(bytes: &[u8], path: &Path) -> Result<Scenario, ImportError> {
    // A byte-order mark (as Windows editors write) is accepted, as YAML
    // and XML accept it; JSON parsers refuse it at line 1, column 1.
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let scene: SceneJson = serde_json::from_slice(bytes).map_err(|e| syntax_error(&e, path))?;
    Converter { path }.scenario(scene)
}

/// A serde_json error at its line and column, without repeating them in the
/// message.
fn syntax_error(e: &serde_json::Error, path: &Path) -> ImportError {
    let text = e.to_string();
    let suffix = format!(" at line {} column {}", e.line(), e.column());
    let message = text.strip_suffix(&suffix).unwrap_or(&text).to_string();
    // serde_json reports line 0 for errors without a position (I/O); a
    // 1-based location cannot say that, so those point at the file.
    let location =
        if e.line() == 0 { Location::File } else { Location::LineColumn { line: e.line(), column: e.column() } };
    ImportError::malformed(path, SourceFormat::WomdJson, location, message)
}

/// Whether a step's values are a converter's stand-in for "not observed".
fn is_sentinel(p: &PointJson, heading: f64, v: &VelocityJson) -> bool {
    [p.x, p.y, heading, v.x, v.y].contains(&SENTINEL) || (p.x == PLACEHOLDER && p.y == PLACEHOLDER)
}

struct Converter<'a> {
    path: &'a Path,
}

impl Converter<'_> {
    fn at(&self, element: impl Into<String>, message: impl Into<String>) -> ImportError {
        ImportError::malformed(self.path, SourceFormat::WomdJson, Location::Element(element.into()), message)
    }

    fn scenario(&self, scene: SceneJson) -> Result<Scenario, ImportError> {
        let mut notes = Vec::new();
        let Some(first) = scene.objects.first() else {
            return Err(self.at("objects", "the scene has no objects"));
        };
        let num_steps = first.valid.len();
        self.check_shapes(&scene.objects, num_steps)?;
        if num_steps == 0 {
            return Err(self.at("objects[0].valid", "no steps"));
        }

        let unit = self.heading_unit(&scene, &mut notes);
        let mut tracks = Vec::with_capacity(scene.objects.len());
        let mut sentinel_steps = 0usize;
        let mut sizeless = 0usize;
        for (i, o) in scene.objects.iter().enumerate() {
            let kind = match o.kind.as_str() {
                "vehicle" => AgentKind::Vehicle,
                "pedestrian" => AgentKind::Pedestrian,
                "cyclist" => AgentKind::Cyclist,
                _ => AgentKind::Other,
            };
            let mut states = Vec::with_capacity(num_steps);
            for (k, valid) in o.valid.iter().enumerate() {
                let (Some(p), Some(&h), Some(v)) = (o.position.get(k), o.heading.get(k), o.velocity.get(k)) else {
                    return Err(self.at(format!("objects[{i}]"), format!("step {k} missing")));
                };
                if !valid {
                    states.push(None);
                    continue;
                }
                if is_sentinel(p, h, v) {
                    sentinel_steps += 1;
                    states.push(None);
                    continue;
                }
                if ![p.x, p.y, h, v.x, v.y].iter().all(|x| x.is_finite()) {
                    return Err(self.at(format!("objects[{i}].position[{k}]"), "non-finite value in a valid step"));
                }
                let heading_rad = crate::scenario::bounds::recorded_heading(unit.to_radians(h))
                    .map_err(|e| self.at(format!("objects[{i}].heading[{k}]"), e))?;
                states.push(Some(AgentState {
                    position: Point2::new(p.x, p.y),
                    heading_rad,
                    velocity_mps: Vector2::new(v.x, v.y),
                }));
            }
            let any_valid = states.iter().any(Option::is_some);
            let (length_m, width_m) = if any_valid {
                for (name, value) in [("length", o.length), ("width", o.width)] {
                    if !(value.is_finite() && value > 0.0) {
                        return Err(
                            self.at(format!("objects[{i}].{name}"), format!("{value} m is not a positive size"))
                        );
                    }
                }
                (o.length, o.width)
            } else {
                // Never observed: the size is never used for a footprint.
                sizeless += 1;
                let (l, w) = default_size(kind);
                (
                    if o.length.is_finite() && o.length > 0.0 { o.length } else { l },
                    if o.width.is_finite() && o.width > 0.0 { o.width } else { w },
                )
            };
            let id = AgentId(o.id.map_or_else(|| i.to_string(), |id| id.to_string()));
            tracks.push(Track { id, kind, length_m, width_m, states });
        }
        if sentinel_steps > 0 {
            notes.push(format!("{sentinel_steps} steps marked valid but holding sentinel values were made invalid"));
        }
        if sizeless > 0 {
            notes.push(format!("{sizeless} objects have no valid step"));
        }

        let (ego, objects_of_interest) = self.roles(&scene, &tracks, &mut notes)?;
        let cbv = cbv_from_objects_of_interest(&tracks, ego, &objects_of_interest);
        let map = self.map(&scene, num_steps, &mut notes)?;

        let current_step = if num_steps > WOMD_CURRENT_STEP {
            WOMD_CURRENT_STEP
        } else {
            notes.push(format!("only {num_steps} steps: current step set to the last"));
            num_steps - 1
        };
        let id = match (&scene.scenario_id, &scene.name) {
            (Some(id), _) if !id.is_empty() => id.clone(),
            (_, Some(name)) if !name.is_empty() => name.strip_suffix(".json").unwrap_or(name).to_string(),
            _ => self.path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        };
        Ok(Scenario {
            current_step,
            objects_of_interest,
            ..Scenario::new(
                id,
                ScenarioSource {
                    format: SourceFormat::WomdJson,
                    path: self.path.to_path_buf(),
                    licence: DataLicence::WaymoNonCommercial,
                    notes,
                },
                WOMD_STEP_S,
                map,
                tracks,
            )
        }
        .with_source_roles(ego, cbv))
    }

    /// Every per-step list of every object has `num_steps` entries.
    fn check_shapes(&self, objects: &[ObjectJson], num_steps: usize) -> Result<(), ImportError> {
        for (i, o) in objects.iter().enumerate() {
            for (name, len) in [
                ("valid", o.valid.len()),
                ("position", o.position.len()),
                ("heading", o.heading.len()),
                ("velocity", o.velocity.len()),
            ] {
                if len != num_steps {
                    return Err(self.at(
                        format!("objects[{i}].{name}"),
                        format!("{len} entries, but objects[0].valid has {num_steps}"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Decides the heading unit from moving vehicles' velocity directions,
    /// falling back to the metadata rule, and notes the decision.
    fn heading_unit(&self, scene: &SceneJson, notes: &mut Vec<String>) -> HeadingUnit {
        let by_rule = if scene.metadata.is_some() { HeadingUnit::Radians } else { HeadingUnit::Degrees };
        let rule = if scene.metadata.is_some() { "metadata present" } else { "no metadata" };
        let (mut samples, mut as_radians, mut as_degrees) = (0usize, 0usize, 0usize);
        let mut beyond_two_pi = false;
        for o in scene.objects.iter() {
            let vehicle = o.kind == "vehicle";
            let steps = o.valid.iter().zip(&o.position).zip(&o.heading).zip(&o.velocity);
            for (((&valid, p), &h), v) in steps {
                if !valid || is_sentinel(p, h, v) || !h.is_finite() {
                    continue;
                }
                beyond_two_pi |= h.abs() > std::f64::consts::TAU + 1e-6;
                if !vehicle || v.x.hypot(v.y) <= MOVING_SPEED_MPS {
                    continue;
                }
                let direction = v.y.atan2(v.x);
                samples += 1;
                as_radians += usize::from(wrap_angle(h - direction).abs() < AGREEMENT_RAD);
                as_degrees += usize::from(wrap_angle(h.to_radians() - direction).abs() < AGREEMENT_RAD);
            }
        }
        let percent = |n: usize| if samples == 0 { 0.0 } else { 100.0 * n as f64 / samples as f64 };
        let (unit, how) = if samples >= MIN_UNIT_SAMPLES && as_radians != as_degrees {
            let by_data = if as_radians > as_degrees { HeadingUnit::Radians } else { HeadingUnit::Degrees };
            let agree = if by_data == HeadingUnit::Radians { as_radians } else { as_degrees };
            let how = if by_data == by_rule {
                format!("{rule}; {:.0}% of {samples} moving-vehicle samples agree", percent(agree))
            } else {
                format!(
                    "{rule} suggests {}, but {:.0}% of {samples} moving-vehicle samples agree with {} (vs {:.0}%): trusting the data",
                    by_rule.name(),
                    percent(agree),
                    by_data.name(),
                    percent(if by_data == HeadingUnit::Radians { as_degrees } else { as_radians }),
                )
            };
            (by_data, how)
        } else if beyond_two_pi {
            (
                HeadingUnit::Degrees,
                format!("{rule}; too few moving vehicles ({samples}) to compare, but |heading| exceeds 2π"),
            )
        } else {
            (by_rule, format!("{rule}; too few moving vehicles ({samples}) to check against the data"))
        };
        notes.push(format!("heading unit: {} ({how})", unit.name()));
        unit
    }

    /// Ego and objects of interest from `metadata`, where present.
    fn roles(
        &self,
        scene: &SceneJson,
        tracks: &[Track],
        notes: &mut Vec<String>,
    ) -> Result<(Option<TrackIndex>, Vec<TrackIndex>), ImportError> {
        let Some(meta) = &scene.metadata else {
            return Ok((None, Vec::new()));
        };
        let ego = match meta.sdc_track_index {
            Some(i) if i >= 0 && (i as usize) < tracks.len() => Some(TrackIndex(i as usize)),
            Some(i) => {
                return Err(self.at("metadata.sdc_track_index", format!("{i} is outside the {} objects", tracks.len())));
            }
            None => None,
        };
        let index_by_id: BTreeMap<i64, usize> =
            scene.objects.iter().enumerate().filter_map(|(i, o)| Some((o.id?, i))).collect();
        let mut objects_of_interest = Vec::new();
        for id in &meta.objects_of_interest {
            match index_by_id.get(id) {
                Some(&i) => objects_of_interest.push(TrackIndex(i)),
                None => notes.push(format!("object of interest {id} names no object; ignored")),
            }
        }
        Ok((ego, objects_of_interest))
    }

    fn polyline(&self, j: usize, road: &RoadJson) -> Result<Vec<Point2>, ImportError> {
        road.geometry
            .iter()
            .enumerate()
            .map(|(k, p)| {
                if p.x.is_finite() && p.y.is_finite() {
                    Ok(Point2::new(p.x, p.y))
                } else {
                    Err(self.at(format!("roads[{j}].geometry[{k}]"), "non-finite point"))
                }
            })
            .collect()
    }

    fn map(&self, scene: &SceneJson, num_steps: usize, notes: &mut Vec<String>) -> Result<RoadMap, ImportError> {
        let (mut lanes, mut road_edges, mut road_lines, mut areas, mut stop_signs) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut unknown_kinds: BTreeMap<&str, usize> = BTreeMap::new();
        for (j, road) in scene.roads.iter().enumerate() {
            // Older files have no ids: the position in `roads` is unique too.
            let id = MapElementId(road.id.unwrap_or(j as i64));
            let code = road.map_element_id;
            let area = |kind| -> Result<MapArea, ImportError> {
                Ok(MapArea { id, kind, polygon: Polygon::new(self.polyline(j, road)?) })
            };
            match road.kind.as_str() {
                "lane" => lanes.push(Lane {
                    id,
                    centreline: Polyline::new(self.polyline(j, road)?),
                    kind: match code {
                        Some(1) => LaneKind::Freeway,
                        Some(2) => LaneKind::SurfaceStreet,
                        Some(3) => LaneKind::BikeLane,
                        _ => LaneKind::Undefined,
                    },
                    speed_limit_mps: None,
                    // The JSON keeps no lane connectivity.
                    predecessors: Vec::new(),
                    successors: Vec::new(),
                    left_neighbours: Vec::new(),
                    right_neighbours: Vec::new(),
                    left_boundary: None,
                    right_boundary: None,
                    in_intersection: false,
                    crosses_lanes: false,
                    stop_line: None,
                }),
                "road_edge" => road_edges.push(RoadEdge {
                    id,
                    polyline: Polyline::new(self.polyline(j, road)?),
                    kind: match code {
                        Some(15) => RoadEdgeKind::Boundary,
                        Some(16) => RoadEdgeKind::Median,
                        _ => RoadEdgeKind::Unknown,
                    },
                }),
                "road_line" => road_lines.push(RoadLine {
                    id,
                    polyline: Polyline::new(self.polyline(j, road)?),
                    // GPUDrive codes road lines as WOMD's RoadLineType + 5.
                    kind: code
                        .and_then(|c| i32::try_from(c - 5).ok())
                        .map_or(RoadLineKind::Unknown, RoadLineKind::from_womd),
                }),
                "crosswalk" => areas.push(area(AreaKind::Crosswalk)?),
                "speed_bump" => areas.push(area(AreaKind::SpeedBump)?),
                "driveway" => areas.push(area(AreaKind::Driveway)?),
                "stop_sign" => {
                    let Some(position) = self.polyline(j, road)?.first().copied() else {
                        return Err(self.at(format!("roads[{j}].geometry"), "a stop sign needs a point"));
                    };
                    stop_signs.push(StopSign { id, position, lanes: Vec::new() });
                }
                other => *unknown_kinds.entry(other).or_default() += 1,
            }
        }
        for (kind, count) in unknown_kinds {
            notes.push(format!("{count} roads of unknown type {kind:?} ignored"));
        }
        let traffic_signals = self.traffic_signals(&scene.tl_states, num_steps, notes)?;
        let mut map = RoadMap::new(lanes, road_edges, road_lines, areas, Vec::new(), stop_signs, traffic_signals);
        // WOMD flags no junction lanes: take them from where lanes cross.
        map.mark_crossing_lanes_as_junctions();
        Ok(map)
    }

    /// Per-lane signal states over all steps; steps a lane is not listed in
    /// are [`SignalState::Unknown`]. The stop point is the first one given.
    fn traffic_signals(
        &self,
        tl_states: &BTreeMap<String, SignalJson>,
        num_steps: usize,
        notes: &mut Vec<String>,
    ) -> Result<Vec<TrafficSignal>, ImportError> {
        let mut signals = Vec::with_capacity(tl_states.len());
        let mut unknown_names: BTreeMap<&str, usize> = BTreeMap::new();
        for (key, s) in tl_states {
            let element = |what: &str| format!("tl_states[{key:?}]{what}");
            let lane: i64 = key.trim().parse().map_err(|_| self.at(element(""), "key is not a lane id"))?;
            let n = s.state.len();
            if let Some(times) = &s.time_index
                && times.len() != n
            {
                return Err(self.at(element(".time_index"), format!("{} entries, but state has {n}", times.len())));
            }
            for (name, len) in [("x", s.x.len()), ("y", s.y.len())] {
                if len != n && len != 0 {
                    return Err(self.at(element(&format!(".{name}")), format!("{len} entries, but state has {n}")));
                }
            }
            let mut states = vec![SignalState::Unknown; num_steps];
            for (k, name) in s.state.iter().enumerate() {
                let step = match &s.time_index {
                    Some(times) => times.get(k).copied().unwrap_or(-1),
                    None => k as i64,
                };
                let Some(slot) = usize::try_from(step).ok().and_then(|t| states.get_mut(t)) else {
                    return Err(self.at(
                        element(&format!(".time_index[{k}]")),
                        format!("step {step} outside the {num_steps} steps"),
                    ));
                };
                *slot = signal_state(name).unwrap_or_else(|| {
                    *unknown_names.entry(name.as_str()).or_default() += 1;
                    SignalState::Unknown
                });
            }
            let stop_point =
                s.x.iter()
                    .zip(&s.y)
                    .find(|(x, y)| x.is_finite() && y.is_finite() && **x != SENTINEL && **y != SENTINEL)
                    .map(|(&x, &y)| Point2::new(x, y));
            signals.push(TrafficSignal { lane: MapElementId(lane), stop_point, states });
        }
        for (name, count) in unknown_names {
            notes.push(format!("{count} signal states named {name:?} read as unknown"));
        }
        // Keys sort as strings; the map wants lane-id order.
        signals.sort_by_key(|s| s.lane);
        Ok(signals)
    }
}

/// A signal state by its name in the JSON (lower-case WOMD enum names, with
/// or without the `LANE_STATE_` prefix).
fn signal_state(name: &str) -> Option<SignalState> {
    let lower = name.trim().to_ascii_lowercase();
    let bare = lower.strip_prefix("lane_state_").unwrap_or(&lower);
    Some(match bare {
        "unknown" => SignalState::Unknown,
        "arrow_stop" => SignalState::ArrowStop,
        "arrow_caution" => SignalState::ArrowCaution,
        "arrow_go" => SignalState::ArrowGo,
        "stop" => SignalState::Stop,
        "caution" => SignalState::Caution,
        "go" => SignalState::Go,
        "flashing_stop" => SignalState::FlashingStop,
        "flashing_caution" => SignalState::FlashingCaution,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signal_names() {
        assert_eq!(signal_state("arrow_go"), Some(SignalState::ArrowGo));
        assert_eq!(signal_state("LANE_STATE_STOP"), Some(SignalState::Stop));
        assert_eq!(signal_state("purple"), None);
    }

    fn object(heading: f64, vx: f64, vy: f64) -> String {
        let n = 12;
        let list = |item: String| format!("[{}]", vec![item; n].join(","));
        format!(
            r#"{{"type":"vehicle","length":4.5,"width":2.0,"position":{},"heading":{},"velocity":{},"valid":{}}}"#,
            list(r#"{"x":1.0,"y":2.0}"#.into()),
            list(heading.to_string()),
            list(format!(r#"{{"x":{vx},"y":{vy}}}"#)),
            list("true".into())
        )
    }

    #[test]
    fn heading_unit_follows_the_data_not_the_metadata_rule() {
        // No metadata (rule: degrees), but headings are radians matching velocity.
        let json =
            format!(r#"{{"name":"x.json","objects":[{}],"roads":[],"tl_states":{{}}}}"#, object(1.0, 2.7015, 4.2074));
        let s = parse(json.as_bytes(), Path::new("x.json")).unwrap();
        assert!((s.tracks[0].states[0].unwrap().heading_rad - 1.0).abs() < 1e-12);
        assert!(s.source.notes.iter().any(|n| n.contains("heading unit: radians") && n.contains("trusting the data")));
        // Degrees, as the rule says (120 rad would point elsewhere).
        let json =
            format!(r#"{{"name":"x.json","objects":[{}],"roads":[],"tl_states":{{}}}}"#, object(120.0, -2.5, 4.3301));
        let s = parse(json.as_bytes(), Path::new("x.json")).unwrap();
        assert!((s.tracks[0].states[0].unwrap().heading_rad - 120f64.to_radians()).abs() < 1e-12);
        assert!(s.source.notes.iter().any(|n| n.starts_with("heading unit: degrees (no metadata; 100%")));
    }

    #[test]
    fn sentinels_are_invalid_steps() {
        let json = format!(
            r#"{{"name":"x.json","objects":[{}],"roads":[],"tl_states":{{}}}}"#,
            object(-10000.0, -10000.0, -10000.0)
        );
        let s = parse(json.as_bytes(), Path::new("x.json")).unwrap();
        assert_eq!(s.tracks[0].valid_steps(), 0);
    }

    #[test]
    fn signals_fill_the_listed_steps() {
        let json = format!(
            r#"{{"name":"x.json","objects":[{}],"roads":[],"tl_states":{{"7":{{"state":["stop","go"],"x":[1,1],"y":[2,2],"z":[0,0],"time_index":[3,4]}}}}}}"#,
            object(0.0, 5.0, 0.0)
        );
        let s = parse(json.as_bytes(), Path::new("x.json")).unwrap();
        let signal = &s.map.traffic_signals[0];
        assert_eq!(signal.lane, MapElementId(7));
        assert_eq!(signal.states.len(), 12);
        assert_eq!(&signal.states[2..5], &[SignalState::Unknown, SignalState::Stop, SignalState::Go]);
        assert_eq!(signal.stop_point, Some(Point2::new(1.0, 2.0)));
    }
}
