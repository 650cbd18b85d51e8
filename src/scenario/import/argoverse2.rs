//! Argoverse 2 motion-forecasting scenarios: a `scenario_<id>.parquet` of
//! track states and the `log_map_archive_<id>.json` beside it.
//!
//! This module owns finding the two files of a scenario, reading the
//! parquet (one row per track and step, read with the `parquet` crate's
//! row API, no Arrow) into [`Track`]s on the 110-step grid, and the map JSON
//! into lanes, drivable areas (whose outlines are the road edges) and
//! crosswalks. AV2 gives no object sizes, so each type gets a documented
//! default. The AV's track is the ego; the focal track is the only object
//! of interest and, when it is a vehicle other than the AV, the CBV.
//!
//! Errors name the row and column of the parquet, or the line and column of
//! the map JSON. The parquet decoder is a dependency that has been seen to
//! panic on corrupt files; that is caught and reported as an error.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::{ImportError, Location};
use crate::geometry::{Point2, Polygon, Polyline};
use crate::map::{AreaKind, Lane, LaneKind, MapArea, MapElementId, RoadEdge, RoadEdgeKind, RoadMap};
use crate::scenario::{AgentKind, DataLicence, Scenario, ScenarioSource, SourceFormat, Track, TrackIndex};

const FORMAT: SourceFormat = SourceFormat::Argoverse2;

/// Step length: AV2 scenarios are sampled at 10 Hz (`AV2_SCENARIO_STEP_HZ`
/// in the av2-api's `motion_forecasting/constants.py`).
pub const STEP_S: f64 = 0.1;
/// Steps per scenario when the file has no `num_timestamps` column
/// (`AV2_SCENARIO_TOTAL_TIMESTEPS`: 5 s observed + 6 s predicted).
pub const NUM_STEPS: usize = 110;
/// "Now": the last of the 50 observed steps (`AV2_SCENARIO_OBS_TIMESTEPS`).
pub const CURRENT_STEP: usize = 49;
/// Track id of the data-collection vehicle, the ego.
pub const AV_TRACK_ID: &str = "AV";

/// Largest coordinate magnitude accepted, metres: projected (UTM-like)
/// frames stay below 1e7; beyond that a value is corrupt, and absurd
/// extents make the map's spatial grid allocate without bound.
const MAX_COORDINATE_M: f64 = 1e7;

/// Default footprints, length × width in metres, by AV2 `object_type`.
/// AV2 publishes no extents. Vehicles use 4.5 × 2.0: the median WOMD
/// vehicle box in the recorded WOMD JSON set (`data:womd-json`) is 4.6 × 2.06 (3300 boxes), and
/// the av2-api draws vehicles as 4.0 × 2.0, short for US traffic.
pub const VEHICLE_SIZE_M: (f64, f64) = (4.5, 2.0);
/// A 40-foot US transit bus (12.2 × 2.6 m), rounded.
pub const BUS_SIZE_M: (f64, f64) = (12.0, 2.5);
/// The av2-api's own cyclist/motorcyclist box
/// (`_ESTIMATED_CYCLIST_LENGTH_M`/`_WIDTH_M` in `scenario_visualization.py`);
/// also used for riderless bicycles.
pub const CYCLIST_SIZE_M: (f64, f64) = (2.0, 0.7);
/// Median WOMD pedestrian box (0.88 × 0.84 m over 333 boxes), rounded.
pub const PEDESTRIAN_SIZE_M: (f64, f64) = (0.9, 0.85);
/// Static objects, background, construction and unknown types: a small
/// obstacle, so they block without dominating conflict mining.
pub const OTHER_SIZE_M: (f64, f64) = (1.0, 1.0);

/// Kind and default size of an AV2 `object_type` (the av2-api's
/// `ObjectType` values).
pub fn kind_and_size(object_type: &str) -> (AgentKind, (f64, f64)) {
    match object_type {
        "vehicle" => (AgentKind::Vehicle, VEHICLE_SIZE_M),
        "bus" => (AgentKind::Vehicle, BUS_SIZE_M),
        "motorcyclist" => (AgentKind::Vehicle, CYCLIST_SIZE_M),
        "cyclist" => (AgentKind::Cyclist, CYCLIST_SIZE_M),
        "pedestrian" => (AgentKind::Pedestrian, PEDESTRIAN_SIZE_M),
        "riderless_bicycle" => (AgentKind::Other, CYCLIST_SIZE_M),
        // static, background, construction, unknown, and anything newer.
        _ => (AgentKind::Other, OTHER_SIZE_M),
    }
}

/// The two files of one Argoverse 2 scenario.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ScenarioFiles {
    /// `scenario_<id>.parquet`.
    pub scenario: PathBuf,
    /// `log_map_archive_<id>.json`.
    pub map: PathBuf,
}

/// Finds the parquet and map of the scenario at `path`: either the
/// `scenario_<id>.parquet` itself or the folder holding it. The map is
/// `log_map_archive_<id>.json` beside it, else the only
/// `log_map_archive_*.json` there. A folder without exactly one scenario
/// parquet is not an AV2 scenario folder ([`ImportError::UnknownFormat`]);
/// a scenario without its map is [`ImportError::Malformed`], naming the
/// file that is missing.
pub fn find_scenario_files(path: &Path) -> Result<ScenarioFiles, ImportError> {
    let scenario = if path.is_dir() {
        let parquets = list(path, "scenario_", ".parquet")?;
        match parquets.as_slice() {
            [one] => one.clone(),
            [] => {
                return Err(ImportError::UnknownFormat {
                    path: path.to_path_buf(),
                    reason: "a folder without a scenario_<id>.parquet".to_string(),
                });
            }
            many => {
                return Err(ImportError::UnknownFormat {
                    path: path.to_path_buf(),
                    reason: format!("{} scenario_*.parquet files in one folder; pass one of them", many.len()),
                });
            }
        }
    } else {
        path.to_path_buf()
    };
    let folder = scenario.parent().map(Path::to_path_buf).unwrap_or_default();
    let folder = if folder.as_os_str().is_empty() { PathBuf::from(".") } else { folder };
    let id = scenario_id_from_name(&scenario);
    let by_id = folder.join(format!("log_map_archive_{id}.json"));
    if by_id.is_file() {
        return Ok(ScenarioFiles { scenario, map: by_id });
    }
    let maps = list(&folder, "log_map_archive_", ".json")?;
    match maps.as_slice() {
        [one] => Ok(ScenarioFiles { scenario, map: one.clone() }),
        others => {
            let found = if others.is_empty() {
                "there is no log_map_archive_*.json".to_string()
            } else {
                format!("there are {} other log_map_archive_*.json files", others.len())
            };
            Err(ImportError::malformed(
                &scenario,
                FORMAT,
                Location::File,
                format!("its map is missing: expected {} ({found} in that folder)", by_id.display()),
            ))
        }
    }
}

/// `<id>` of `scenario_<id>.parquet` (the whole stem for other names).
fn scenario_id_from_name(path: &Path) -> String {
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
    stem.strip_prefix("scenario_").unwrap_or(stem).to_string()
}

/// Files in `dir` whose names start with `prefix` and end with `suffix`, sorted.
fn list(dir: &Path, prefix: &str, suffix: &str) -> Result<Vec<PathBuf>, ImportError> {
    let entries = std::fs::read_dir(dir).map_err(|source| ImportError::Io { path: dir.to_path_buf(), source })?;
    let mut out = Vec::new();
    for e in entries {
        let p = e.map_err(|source| ImportError::Io { path: dir.to_path_buf(), source })?.path();
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        if name.starts_with(prefix) && name.ends_with(suffix) && p.is_file() {
            out.push(p);
        }
    }
    out.sort();
    Ok(out)
}

/// Parses one scenario from its parquet and map JSON bytes. `path` is the
/// parquet's; errors in the map are reported against it too, with "map
/// JSON" in the message (use [`parse_files`] to name the map file itself).
pub fn parse(scenario: &[u8], map: &[u8], path: &Path) -> Result<Scenario, ImportError> {
    parse_inner(scenario, map, path, None)
}

/// As [`parse`], with errors in the map JSON reported against `files.map`.
pub fn parse_files(scenario: &[u8], map: &[u8], files: &ScenarioFiles) -> Result<Scenario, ImportError> {
    parse_inner(scenario, map, &files.scenario, Some(&files.map))
}

fn parse_inner(
    scenario_bytes: &[u8],
    map_bytes: &[u8],
    path: &Path,
    map_path: Option<&Path>,
) -> Result<Scenario, ImportError> {
    let table = read_parquet_within_deadline(scenario_bytes, path)?;
    let map = read_map(map_bytes, map_path.unwrap_or(path), map_path.is_none())?;

    let Table { scenario_id, focal_track_id, city, num_steps, tracks } = table;
    let find = |id: &str| tracks.iter().position(|t| t.id.0 == id).map(TrackIndex);
    let ego = find(AV_TRACK_ID);
    let focal = focal_track_id.as_deref().and_then(find);
    let cbv = focal.filter(|&f| Some(f) != ego && tracks[f.0].kind == AgentKind::Vehicle);
    let current_step = CURRENT_STEP.min(num_steps.saturating_sub(1));

    let mut notes = vec![
        "object sizes are per-type defaults: Argoverse 2 records none".to_string(),
        format!("current step {current_step} of {num_steps}: the last of the {} observed steps", current_step + 1),
    ];
    if let Some(city) = city {
        notes.push(format!("city: {city}"));
    }
    if ego.is_none() {
        notes.push(format!("no track {AV_TRACK_ID:?}: the ego is left to conflict mining"));
    }
    match (focal_track_id.as_deref(), focal, cbv) {
        (None, _, _) => notes.push("no focal_track_id column: no object of interest".to_string()),
        (Some(id), None, _) => notes.push(format!("focal track {id} has no rows")),
        (Some(id), Some(_), None) => {
            notes.push(format!("focal track {id} is not a vehicle other than the AV, so it is not the CBV"))
        }
        (Some(_), Some(_), Some(_)) => {}
    }

    Ok(Scenario {
        current_step,
        objects_of_interest: focal.into_iter().collect(),
        ..Scenario::new(
            scenario_id,
            ScenarioSource { format: FORMAT, path: path.to_path_buf(), licence: DataLicence::CcByNcSa4, notes },
            STEP_S,
            map,
            tracks,
        )
    }
    .with_source_roles(ego, cbv))
}

// ---------------------------------------------------------------------------
// Scenario parquet

/// What the parquet holds, laid out on the step grid.
struct Table {
    scenario_id: String,
    focal_track_id: Option<String>,
    city: Option<String>,
    num_steps: usize,
    /// In order of first appearance in the file.
    tracks: Vec<Track>,
}

/// Without the `argoverse2` feature, Argoverse 2 files are recognised
/// but not decoded: the parquet reader is left out of the build.
#[cfg(not(feature = "argoverse2"))]
fn read_parquet_within_deadline(_bytes: &[u8], path: &Path) -> Result<Table, ImportError> {
    Err(ImportError::malformed(
        path,
        FORMAT,
        Location::File,
        "this build of safer-scenarios reads Argoverse 2 scenarios only with its `argoverse2` feature \
         (`safer-scenarios = { version = \"0.1\", features = [\"argoverse2\"] }`; the `safer` command line has it)"
            .to_string(),
    ))
}

#[cfg(feature = "argoverse2")]
mod parquet_table;
#[cfg(feature = "argoverse2")]
use parquet_table::read_parquet_within_deadline;

// ---------------------------------------------------------------------------
// Map JSON

/// `log_map_archive_<id>.json`, the parts this importer reads. Unknown
/// fields (lane marks, `z`) are ignored.
#[derive(serde::Deserialize)]
struct RawMap {
    lane_segments: BTreeMap<String, RawLaneSegment>,
    drivable_areas: BTreeMap<String, RawDrivableArea>,
    #[serde(default)]
    pedestrian_crossings: BTreeMap<String, RawCrossing>,
}

#[derive(serde::Deserialize)]
struct RawPoint {
    x: f64,
    y: f64,
}

#[derive(serde::Deserialize)]
struct RawLaneSegment {
    id: i64,
    centerline: Vec<RawPoint>,
    left_lane_boundary: Vec<RawPoint>,
    right_lane_boundary: Vec<RawPoint>,
    lane_type: String,
    #[serde(default)]
    is_intersection: bool,
    #[serde(default)]
    predecessors: Vec<i64>,
    #[serde(default)]
    successors: Vec<i64>,
    #[serde(default)]
    left_neighbor_id: Option<i64>,
    #[serde(default)]
    right_neighbor_id: Option<i64>,
}

#[derive(serde::Deserialize)]
struct RawDrivableArea {
    id: i64,
    area_boundary: Vec<RawPoint>,
}

#[derive(serde::Deserialize)]
struct RawCrossing {
    id: i64,
    edge1: Vec<RawPoint>,
    edge2: Vec<RawPoint>,
}

fn points(raw: &[RawPoint]) -> Vec<Point2> {
    raw.iter().map(|p| Point2::new(p.x, p.y)).collect()
}

/// AV2 `lane_type` to lane kind. AV2 maps are urban, so a vehicle lane is a
/// surface-street lane.
fn lane_kind(lane_type: &str) -> LaneKind {
    match lane_type {
        "VEHICLE" => LaneKind::SurfaceStreet,
        "BIKE" => LaneKind::BikeLane,
        "BUS" => LaneKind::BusLane,
        _ => LaneKind::Undefined,
    }
}

/// Reads the map. `name_map` adds "map JSON" to messages whose `path` is
/// the scenario parquet's rather than the map's.
fn read_map(bytes: &[u8], path: &Path, name_map: bool) -> Result<RoadMap, ImportError> {
    let prefix = if name_map { "map JSON: " } else { "" };
    let err = |location: Location, message: String| {
        ImportError::malformed(path, FORMAT, location, format!("{prefix}{message}"))
    };
    let raw: RawMap = serde_json::from_slice(bytes).map_err(|e| {
        // serde_json's message ends with the position, which the location
        // already carries.
        let message = e.to_string();
        let suffix = format!(" at line {} column {}", e.line(), e.column());
        let message = message.strip_suffix(&suffix).unwrap_or(&message);
        err(Location::LineColumn { line: e.line(), column: e.column() }, format!("not an Argoverse 2 map: {message}"))
    })?;

    let lists = raw
        .lane_segments
        .iter()
        .flat_map(|(key, l)| {
            [("centerline", &l.centerline), ("left_lane_boundary", &l.left_lane_boundary)]
                .into_iter()
                .chain([("right_lane_boundary", &l.right_lane_boundary)])
                .map(move |(field, pts)| (format!("lane_segments[{key}].{field}"), pts))
        })
        .chain(
            raw.drivable_areas
                .iter()
                .map(|(key, a)| (format!("drivable_areas[{key}].area_boundary"), &a.area_boundary)),
        )
        .chain(raw.pedestrian_crossings.iter().flat_map(|(key, c)| {
            [
                (format!("pedestrian_crossings[{key}].edge1"), &c.edge1),
                (format!("pedestrian_crossings[{key}].edge2"), &c.edge2),
            ]
        }));
    for (at, pts) in lists {
        if let Some((i, p)) = pts.iter().enumerate().find(|(_, p)| p.x.abs().max(p.y.abs()) > MAX_COORDINATE_M) {
            return Err(err(
                Location::Element(format!("{at}[{i}]")),
                format!(
                    "({}, {}) is more than {} m from the origin",
                    crate::number::shown(p.x),
                    crate::number::shown(p.y),
                    crate::number::shown(MAX_COORDINATE_M)
                ),
            ));
        }
    }

    let mut lanes = Vec::with_capacity(raw.lane_segments.len());
    for (key, l) in &raw.lane_segments {
        let centreline = Polyline::new(points(&l.centerline));
        if centreline.len() < 2 {
            return Err(err(
                Location::Element(format!("lane_segments[{key}].centerline")),
                "a centreline needs at least two distinct points".to_string(),
            ));
        }
        let boundary = |raw: &[RawPoint]| Some(Polyline::new(points(raw))).filter(|b| b.len() >= 2);
        lanes.push(Lane {
            id: MapElementId(l.id),
            centreline,
            kind: lane_kind(&l.lane_type),
            speed_limit_mps: None,
            predecessors: l.predecessors.iter().copied().map(MapElementId).collect(),
            successors: l.successors.iter().copied().map(MapElementId).collect(),
            left_neighbours: l.left_neighbor_id.map(MapElementId).into_iter().collect(),
            right_neighbours: l.right_neighbor_id.map(MapElementId).into_iter().collect(),
            left_boundary: boundary(&l.left_lane_boundary),
            right_boundary: boundary(&l.right_lane_boundary),
            in_intersection: l.is_intersection,
            crosses_lanes: false,
            stop_line: None,
        });
    }

    let mut drivable_areas = Vec::with_capacity(raw.drivable_areas.len());
    for (key, a) in &raw.drivable_areas {
        let polygon = Polygon::new(points(&a.area_boundary));
        if polygon.vertices.len() < 3 {
            return Err(err(
                Location::Element(format!("drivable_areas[{key}].area_boundary")),
                "a drivable area needs at least three points".to_string(),
            ));
        }
        drivable_areas.push((a.id, polygon));
    }
    // Ids for edges beyond the first of an outline follow every id in the map.
    let max_id = raw
        .lane_segments
        .values()
        .map(|l| l.id)
        .chain(raw.drivable_areas.values().map(|a| a.id))
        .chain(raw.pedestrian_crossings.values().map(|c| c.id))
        .max()
        .unwrap_or(0);
    let road_edges = road_edges_from_areas(&drivable_areas, max_id.saturating_add(1));
    let drivable_areas = drivable_areas.into_iter().map(|(_, p)| p).collect();

    // A crossing is the strip between its two edges, which run the same way.
    let mut areas = Vec::with_capacity(raw.pedestrian_crossings.len());
    for (key, c) in &raw.pedestrian_crossings {
        let outline: Vec<Point2> = points(&c.edge1).into_iter().chain(points(&c.edge2).into_iter().rev()).collect();
        if outline.len() < 3 {
            return Err(err(
                Location::Element(format!("pedestrian_crossings[{key}]")),
                "a crossing needs at least three points over its two edges".to_string(),
            ));
        }
        areas.push(MapArea { id: MapElementId(c.id), kind: AreaKind::Crosswalk, polygon: Polygon::new(outline) });
    }

    Ok(RoadMap::new(lanes, road_edges, Vec::new(), areas, drivable_areas, Vec::new(), Vec::new()))
}

/// Outline points closer than this to another drivable area's outline lie
/// on a seam between the two.
const SEAM_TOLERANCE_M: f64 = 0.01;

/// Road edges from drivable-area outlines: each outline counter-clockwise
/// (the road on its port side), without the stretches it shares with
/// another area. Those are seams where the map was cut into areas, not
/// kerbs; left in, every point near a seam would seem to be at the road's
/// edge. An outline with seams falls apart into several edges: the first
/// keeps the area's id, the others count up from `next_id`.
fn road_edges_from_areas(areas: &[(i64, Polygon)], mut next_id: i64) -> Vec<RoadEdge> {
    let bounds: Vec<Option<(Point2, Point2)>> = areas.iter().map(|(_, p)| p.bounds()).collect();
    let on_other_outline = |me: usize, p: &Point2| {
        areas.iter().enumerate().any(|(k, (_, other))| {
            let near_box = bounds[k].is_some_and(|(lo, hi)| {
                p.x >= lo.x - SEAM_TOLERANCE_M
                    && p.x <= hi.x + SEAM_TOLERANCE_M
                    && p.y >= lo.y - SEAM_TOLERANCE_M
                    && p.y <= hi.y + SEAM_TOLERANCE_M
            });
            k != me
                && near_box
                && other.boundary_ccw().project(p).is_some_and(|proj| proj.distance_m <= SEAM_TOLERANCE_M)
        })
    };
    let mut edges = Vec::new();
    for (me, (id, polygon)) in areas.iter().enumerate() {
        let ring = polygon.boundary_ccw();
        let pts = ring.points();
        let segments = pts.len().saturating_sub(1);
        // A segment is a seam when its midpoint lies on another outline.
        let seam: Vec<bool> = (0..segments)
            .map(|i| on_other_outline(me, &Point2::from((pts[i].coords + pts[i + 1].coords) * 0.5)))
            .collect();
        let mut runs: Vec<Vec<Point2>> = Vec::new();
        match seam.iter().position(|&s| s) {
            None => runs.push(pts.to_vec()),
            Some(first_seam) => {
                // Walk the ring once, starting just after a seam, so no run
                // is cut in two at the ring's arbitrary start.
                let mut run: Vec<Point2> = Vec::new();
                for step in 1..=segments {
                    let i = (first_seam + step) % segments;
                    if seam[i] {
                        if run.len() >= 2 {
                            runs.push(std::mem::take(&mut run));
                        }
                        run.clear();
                    } else {
                        if run.is_empty() {
                            run.push(pts[i]);
                        }
                        run.push(pts[i + 1]);
                    }
                }
                if run.len() >= 2 {
                    runs.push(run);
                }
            }
        }
        for (n, run) in runs.into_iter().enumerate() {
            let edge_id = if n == 0 {
                *id
            } else {
                next_id = next_id.saturating_add(1);
                next_id - 1
            };
            edges.push(RoadEdge {
                id: MapElementId(edge_id),
                polyline: Polyline::new(run),
                kind: RoadEdgeKind::Boundary,
            });
        }
    }
    edges
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAP: &str = r#"{
  "lane_segments": {"1": {"id": 1, "centerline": [{"x": 0, "y": 0, "z": 0}, {"x": 10, "y": 0, "z": 0}],
    "left_lane_boundary": [{"x": 0, "y": 2}, {"x": 10, "y": 2}], "right_lane_boundary": [{"x": 0, "y": -2}, {"x": 10, "y": -2}],
    "lane_type": "VEHICLE", "is_intersection": false, "predecessors": [], "successors": [2],
    "left_neighbor_id": null, "right_neighbor_id": 3}},
  "drivable_areas": {"5": {"id": 5, "area_boundary": [{"x": 0, "y": -2}, {"x": 0, "y": 2}, {"x": 10, "y": 2}, {"x": 10, "y": -2}]}},
  "pedestrian_crossings": {"7": {"id": 7, "edge1": [{"x": 5, "y": -2}, {"x": 5, "y": 2}], "edge2": [{"x": 6, "y": -2}, {"x": 6, "y": 2}]}}
}"#;

    #[test]
    fn map_json_becomes_lanes_edges_and_crosswalks() {
        let m = read_map(MAP.as_bytes(), Path::new("m.json"), false).unwrap();
        assert_eq!(m.lanes.len(), 1);
        assert_eq!(m.lanes[0].successors, vec![MapElementId(2)]);
        assert_eq!(m.lanes[0].right_neighbours, vec![MapElementId(3)]);
        assert!(m.lanes[0].left_neighbours.is_empty());
        assert_eq!(m.lanes[0].kind, LaneKind::SurfaceStreet);
        assert_eq!(m.road_edges.len(), 1);
        assert!(!m.is_off_road(&Point2::new(5.0, 0.0)));
        assert!(m.is_off_road(&Point2::new(5.0, 3.0)));
        let d = m.signed_distance_to_road_edge(&Point2::new(5.0, 1.0)).unwrap();
        assert!((d + 1.0).abs() < 1e-9, "{d}");
        assert!(m.areas[0].polygon.contains(&Point2::new(5.5, 0.0)));
    }

    #[test]
    fn map_errors_are_located() {
        let err = read_map(b"{\n  \"lane_segments\": {,}", Path::new("m.json"), true).unwrap_err().to_string();
        assert!(err.contains("line 2, column 21: map JSON: not an Argoverse 2 map: key must be a string"), "{err}");
        assert!(!err.contains("at line"), "{err}");
        let err = read_map(MAP.replace("\"x\": 10, \"y\": 0", "\"x\": 0, \"y\": 0").as_bytes(), Path::new("m"), false)
            .unwrap_err()
            .to_string();
        assert!(err.contains("lane_segments[1].centerline"), "{err}");
    }

    #[test]
    fn object_types_map_to_kinds() {
        assert_eq!(kind_and_size("vehicle"), (AgentKind::Vehicle, VEHICLE_SIZE_M));
        assert_eq!(kind_and_size("motorcyclist").0, AgentKind::Vehicle);
        assert_eq!(kind_and_size("cyclist").0, AgentKind::Cyclist);
        assert_eq!(kind_and_size("construction").0, AgentKind::Other);
    }
}
