//! Argoverse 2 import: the shared scenario goes through
//! [`safer_scenarios::scenario::import::load`] (as a folder and as its parquet) and
//! must keep the invariants (58 tracks over 110 steps, the AV as ego, the
//! focal track as object of interest, headings that agree with velocity and
//! motion, a map with lanes, drivable areas and crosswalks). Broken input
//! built here (garbage bytes, small parquet files written with the
//! `parquet` crate, a broken map JSON, a folder without its map) must fail
//! naming the file and the row/column or line/column, never a panic.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use parquet::data_type::ByteArray;
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::parser::parse_message_type;
use safer_scenarios::geometry::Point2;
use safer_scenarios::map::{AreaKind, LaneKind};
use safer_scenarios::scenario::import::{ImportError, Location, argoverse2, detect_format, discover, load};
use safer_scenarios::scenario::{AgentKind, DataLicence, RoleOrigin, Scenario, SourceFormat};

use crate::import_commonroad::heading_follows_motion;
use crate::import_womd_proto::heading_agreement;
use crate::shared_data::data_dir;

const SCENARIO_ID: &str = "0a1e6f0a-1817-4a98-b02e-db8c9327d151";

fn av2_dir() -> PathBuf {
    data_dir().join("av2")
}

fn parquet_path() -> PathBuf {
    av2_dir().join(format!("scenario_{SCENARIO_ID}.parquet"))
}

fn map_path() -> PathBuf {
    av2_dir().join(format!("log_map_archive_{SCENARIO_ID}.json"))
}

fn check(s: &Scenario) {
    s.validate().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.id, SCENARIO_ID);
    assert_eq!(s.source.format, SourceFormat::Argoverse2);
    assert_eq!(s.source.licence, DataLicence::CcByNcSa4);
    assert_eq!(s.tracks.len(), 58, "tracks");
    assert_eq!(s.num_steps(), 110, "steps");
    assert_eq!(s.current_step, argoverse2::CURRENT_STEP);
    assert!((s.dt_s - 0.1).abs() < 1e-12);

    let ego = s.ego.expect("the AV is the ego");
    assert_eq!(s.track(ego).id.0, "AV");
    assert_eq!(s.ego_origin, RoleOrigin::Source);
    assert_eq!(s.objects_of_interest.len(), 1, "the focal track");
    let focal = s.objects_of_interest[0];
    assert_eq!(s.track(focal).id.0, "138951", "focal_track_id column");
    if s.track(focal).kind == AgentKind::Vehicle {
        assert_eq!(s.cbv, Some(focal));
        assert_eq!(s.cbv_origin, RoleOrigin::Source);
    }
    assert!(s.track(ego).state(s.current_step).is_some(), "AV valid now");
    assert!(s.track(focal).state(s.current_step).is_some(), "focal track valid now");
    // AV and focal track are observed over the whole scenario.
    assert_eq!(s.track(ego).valid_steps(), 110);
    assert_eq!(s.track(focal).valid_steps(), 110);
    let valid_now = s.tracks.iter().filter(|t| t.state(s.current_step).is_some()).count();
    assert!(valid_now >= 10, "{valid_now} agents valid now");
    let rows: usize = s.tracks.iter().map(|t| t.valid_steps()).sum();
    assert_eq!(rows, 2434, "one state per parquet row");

    for t in &s.tracks {
        assert!(t.length_m > 0.0 && t.width_m > 0.0);
        for st in t.states.iter().flatten() {
            assert!(st.position.x.is_finite() && st.position.y.is_finite() && st.velocity_mps.norm().is_finite());
            assert!(st.position.coords.norm() < 1_000.0, "track {} far from the origin: {st:?}", t.id);
            assert!(st.heading_rad > -std::f64::consts::PI && st.heading_rad <= std::f64::consts::PI);
            assert!(st.speed_mps() < 60.0, "track {} speed {}", t.id, st.speed_mps());
        }
    }
    let (agreement, samples) = heading_agreement(s);
    assert!(samples >= 100 && agreement > 0.9, "heading vs velocity {:.1}% of {samples}", agreement * 100.0);
    let (follows, moves) = heading_follows_motion(s);
    assert!(moves >= 100 && follows > 0.9, "heading vs motion {:.1}% of {moves}", follows * 100.0);

    let counts = s.map.counts();
    assert_eq!(counts.lanes, 71);
    assert_eq!(counts.drivable_areas, 2);
    // Each of the two outlines loses the two stretches it shares with the
    // other and falls apart into two runs.
    assert_eq!(counts.road_edges, 4, "drivable-area outlines without their seams");
    assert_eq!(counts.crosswalks, 6);
    assert!(s.map.lanes.iter().any(|l| l.kind == LaneKind::BikeLane));
    assert!(s.map.lanes.iter().any(|l| l.kind == LaneKind::SurfaceStreet));
    assert!(s.map.lanes.iter().any(|l| !l.successors.is_empty() && !l.predecessors.is_empty()));
    assert!(s.map.areas.iter().all(|a| a.kind == AreaKind::Crosswalk && a.polygon.vertices.len() >= 4));
    // Vehicles at "now" inside the map's extent are on the drivable area,
    // or within a metre of it. (The map is a crop: a few vehicles are
    // beyond it.)
    let (lo, hi) = s
        .map
        .drivable_areas
        .iter()
        .filter_map(|a| a.bounds())
        .fold((Point2::new(f64::MAX, f64::MAX), Point2::new(f64::MIN, f64::MIN)), |(lo, hi), (a, b)| {
            (Point2::new(lo.x.min(a.x), lo.y.min(a.y)), Point2::new(hi.x.max(b.x), hi.y.max(b.y)))
        });
    let vehicles_now: Vec<_> = s
        .tracks
        .iter()
        .filter(|t| t.kind == AgentKind::Vehicle)
        .filter_map(|t| t.state(s.current_step))
        .filter(|st| (lo.x..=hi.x).contains(&st.position.x) && (lo.y..=hi.y).contains(&st.position.y))
        .collect();
    let near_road = vehicles_now
        .iter()
        .filter(|st| s.map.signed_distance_to_road_edge(&st.position).is_some_and(|d| d < 1.0))
        .count();
    assert!(
        vehicles_now.len() >= 10 && near_road == vehicles_now.len(),
        "{near_road} of {} vehicles on the road",
        vehicles_now.len()
    );
    // Edges are kerbs: the seam where the map was cut into two drivable
    // areas is not one, so a point on the seam 3 m from the
    // kerbs either side is 3 m inside the road.
    let seam = Point2::new(-430.5, 1350.0) - s.origin_world;
    let d = s.map.signed_distance_to_road_edge(&seam).unwrap();
    assert!(d < -2.5, "{d}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn argoverse2_scenario_imports_with_invariants() {
    let folder = av2_dir();
    let found = discover(&folder).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(found, vec![folder.clone()], "the folder is one scenario");
    assert_eq!(detect_format(&folder).unwrap_or_else(|e| panic!("{e}")), SourceFormat::Argoverse2);

    let scenario_bytes = std::fs::read(parquet_path()).unwrap();
    let map_bytes = std::fs::read(map_path()).unwrap();
    let started = Instant::now();
    argoverse2::parse(&scenario_bytes, &map_bytes, &parquet_path()).unwrap_or_else(|e| panic!("{e}"));
    let parse_s = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let from_folder = load(&folder).unwrap_or_else(|e| panic!("{e}"));
    let load_s = started.elapsed().as_secs_f64();
    let from_file = load(&parquet_path()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(from_folder.len(), 1);
    assert_eq!(from_file.len(), 1);
    for s in from_folder.iter().chain(&from_file) {
        check(s);
    }
    assert_eq!(from_folder[0].tracks, from_file[0].tracks);
    let s = &from_folder[0];
    let (agreement, samples) = heading_agreement(s);
    let (follows, moves) = heading_follows_motion(s);
    println!(
        "av2 {}: {} tracks x {} steps, {:?}; heading vs velocity {:.1}% of {samples}, vs motion {:.1}% of {moves}; parse {:.0} ms, load {:.0} ms; notes {:?}",
        s.id,
        s.tracks.len(),
        s.num_steps(),
        s.map.counts(),
        agreement * 100.0,
        follows * 100.0,
        parse_s * 1e3,
        load_s * 1e3,
        s.source.notes
    );
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn argoverse2_finds_its_files_from_folder_or_parquet() {
    let from_folder = argoverse2::find_scenario_files(&av2_dir()).unwrap_or_else(|e| panic!("{e}"));
    let from_file = argoverse2::find_scenario_files(&parquet_path()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(from_folder, from_file);
    assert_eq!(from_folder.scenario, parquet_path());
    assert_eq!(from_folder.map, map_path());
}

fn malformed_at(err: &ImportError, path: &Path) -> Location {
    assert!(err.to_string().contains(&path.display().to_string()), "file not named: {err}");
    match err {
        ImportError::Malformed { location, .. } => location.clone(),
        other => panic!("expected Malformed: {other}"),
    }
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn argoverse2_folder_without_map_is_an_error_naming_it() {
    let scratch = crate::scratch::Scratch::new("av2-no-map");
    let parquet = scratch.join(format!("scenario_{SCENARIO_ID}.parquet"));
    std::fs::copy(parquet_path(), &parquet).unwrap();

    let err = argoverse2::find_scenario_files(&scratch).expect_err("no map");
    assert_eq!(malformed_at(&err, &parquet), Location::File);
    assert!(err.to_string().contains(&format!("log_map_archive_{SCENARIO_ID}.json")), "{err}");
    let err = load(&parquet).expect_err("no map");
    assert!(err.to_string().contains("map is missing"), "{err}");
    // Through the folder, `load` refuses it as a scenario folder, naming it.
    let err = load(&scratch).expect_err("no map");
    assert!(err.to_string().contains(&scratch.display().to_string()), "{err}");

    // A map under another id is taken when it is the only one.
    std::fs::copy(map_path(), scratch.join("log_map_archive_other.json")).unwrap();
    let files = argoverse2::find_scenario_files(&scratch).unwrap_or_else(|e| panic!("{e}"));
    assert!(files.map.ends_with("log_map_archive_other.json"));
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn argoverse2_garbage_and_broken_map_are_errors() {
    let path = parquet_path();
    let map = std::fs::read(map_path()).unwrap();
    let scenario = std::fs::read(&path).unwrap();
    for garbage in [&b""[..], b"PAR1", b"PAR1garbagegarbagePAR1", &[0u8; 64], &scenario[..scenario.len() / 2]] {
        let err = argoverse2::parse(garbage, &map, &path).expect_err("garbage parquet");
        malformed_at(&err, &path);
    }
    // Corrupt bytes inside the column chunks: an error or (for a flip in a
    // value) a scenario, never a panic out of the importer.
    for at in (8..scenario.len() - 8).step_by(997) {
        let mut broken = scenario.clone();
        broken[at] ^= 0x5a;
        let _ = argoverse2::parse(&broken, &map, &path);
    }

    let text = String::from_utf8(map.clone()).unwrap();
    let broken = text.replacen("\"centerline\"", "\"centerline\" ]", 1);
    let err = argoverse2::parse(&scenario, broken.as_bytes(), &path).expect_err("broken JSON");
    match malformed_at(&err, &path) {
        Location::LineColumn { line, column } => assert!(line >= 1 && column > 1, "{err}"),
        other => panic!("expected line/column, got {other:?}: {err}"),
    }
    assert!(err.to_string().contains("map JSON"), "{err}");
    let files = argoverse2::ScenarioFiles { scenario: path.clone(), map: map_path() };
    let err = argoverse2::parse_files(&scenario, broken.as_bytes(), &files).expect_err("broken JSON");
    malformed_at(&err, &map_path());
    let far = SMALL_MAP.replacen("\"x\": 10, \"y\": 0", "\"x\": 1e12, \"y\": 0", 1);
    let err = argoverse2::parse(&scenario, far.as_bytes(), &path).expect_err("far coordinate");
    assert_eq!(malformed_at(&err, &path), Location::Element("lane_segments[1].centerline[1]".to_string()), "{err}");
    let err = argoverse2::parse(&scenario, b"{\"lane_segments\": {}}", &path).expect_err("no drivable_areas");
    assert!(err.to_string().contains("drivable_areas"), "{err}");
}

/// One column of a hand-made scenario parquet.
enum Column {
    Text(&'static str, Vec<&'static str>),
    Int(&'static str, Vec<i64>),
    Float(&'static str, Vec<f64>),
}

/// Writes a flat parquet (uncompressed, one row group) from columns.
fn write_parquet(columns: &[Column]) -> Vec<u8> {
    use parquet::column::writer::ColumnWriter;
    let fields: Vec<String> = columns
        .iter()
        .map(|c| match c {
            Column::Text(n, _) => format!("REQUIRED BYTE_ARRAY {n} (UTF8);"),
            Column::Int(n, _) => format!("REQUIRED INT64 {n};"),
            Column::Float(n, _) => format!("REQUIRED DOUBLE {n};"),
        })
        .collect();
    let schema = Arc::new(parse_message_type(&format!("message schema {{ {} }}", fields.join(" "))).unwrap());
    let mut out = Vec::new();
    let mut writer =
        SerializedFileWriter::new(&mut out, schema, Arc::new(WriterProperties::builder().build())).unwrap();
    let mut group = writer.next_row_group().unwrap();
    let mut i = 0;
    while let Some(mut col) = group.next_column().unwrap() {
        match (&columns[i], col.untyped()) {
            (Column::Text(_, v), ColumnWriter::ByteArrayColumnWriter(w)) => {
                let values: Vec<ByteArray> = v.iter().map(|s| ByteArray::from(*s)).collect();
                w.write_batch(&values, None, None).unwrap();
            }
            (Column::Int(_, v), ColumnWriter::Int64ColumnWriter(w)) => {
                w.write_batch(v, None, None).unwrap();
            }
            (Column::Float(_, v), ColumnWriter::DoubleColumnWriter(w)) => {
                w.write_batch(v, None, None).unwrap();
            }
            _ => unreachable!("schema and columns agree"),
        }
        col.close().unwrap();
        i += 1;
    }
    group.close().unwrap();
    writer.close().unwrap();
    out
}

/// Two tracks ("AV" and "7"), three rows each, with `change` applied.
fn small_parquet(change: impl FnOnce(&mut Vec<Column>)) -> Vec<u8> {
    let mut columns = vec![
        Column::Text("track_id", vec!["AV", "AV", "AV", "7", "7", "7"]),
        Column::Text("object_type", vec!["vehicle", "vehicle", "vehicle", "pedestrian", "pedestrian", "pedestrian"]),
        Column::Int("timestep", vec![48, 49, 50, 48, 49, 50]),
        Column::Float("position_x", vec![0.0, 1.0, 2.0, 5.0, 5.0, 5.0]),
        Column::Float("position_y", vec![0.0, 0.0, 0.0, 3.0, 3.1, 3.2]),
        Column::Float("heading", vec![0.0, 0.0, 0.0, 1.57, 1.57, 1.57]),
        Column::Float("velocity_x", vec![10.0, 10.0, 10.0, 0.0, 0.0, 0.0]),
        Column::Float("velocity_y", vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]),
        Column::Text("scenario_id", vec!["s1"; 6]),
        Column::Text("focal_track_id", vec!["7"; 6]),
        Column::Int("num_timestamps", vec![110; 6]),
    ];
    change(&mut columns);
    write_parquet(&columns)
}

const SMALL_MAP: &str = r#"{"lane_segments": {"1": {"id": 1, "centerline": [{"x": -10, "y": 0}, {"x": 10, "y": 0}],
  "left_lane_boundary": [{"x": -10, "y": 2}, {"x": 10, "y": 2}], "right_lane_boundary": [{"x": -10, "y": -2}, {"x": 10, "y": -2}],
  "lane_type": "VEHICLE", "is_intersection": false, "predecessors": [], "successors": [], "left_neighbor_id": null,
  "right_neighbor_id": null}},
 "drivable_areas": {"2": {"id": 2, "area_boundary": [{"x": -10, "y": -2}, {"x": 10, "y": -2}, {"x": 10, "y": 2}, {"x": -10, "y": 2}]}},
 "pedestrian_crossings": {}}"#;

/// An edit to the columns of [`small_parquet`].
type ColumnChange = Box<dyn FnOnce(&mut Vec<Column>)>;

fn set(columns: &mut [Column], name: &str, to: Column) {
    let at = columns
        .iter()
        .position(|c| matches!(c, Column::Text(n, _) | Column::Int(n, _) | Column::Float(n, _) if *n == name))
        .unwrap();
    columns[at] = to;
}

#[test]
fn argoverse2_small_parquet_reads_and_errors_name_row_and_column() {
    let path = Path::new("scenario_s1.parquet");
    let s = argoverse2::parse(&small_parquet(|_| {}), SMALL_MAP.as_bytes(), path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.id, "s1");
    assert_eq!(s.num_steps(), 110);
    assert_eq!(s.tracks.len(), 2);
    assert_eq!(s.ego.map(|e| s.track(e).id.0.as_str()), Some("AV"));
    // The focal track is a pedestrian: of interest, but not the CBV.
    assert_eq!(s.objects_of_interest.len(), 1);
    assert_eq!(s.cbv, None);
    assert_eq!(s.tracks[1].kind, AgentKind::Pedestrian);
    assert_eq!((s.tracks[0].length_m, s.tracks[0].width_m), argoverse2::VEHICLE_SIZE_M);
    assert!(s.tracks[0].state(47).is_none() && s.tracks[0].state(49).is_some());

    let cases: Vec<(ColumnChange, &str)> = vec![
        (
            Box::new(|c: &mut Vec<Column>| c.retain(|c| !matches!(c, Column::Float("position_y", _)))),
            "column position_y",
        ),
        (
            Box::new(|c: &mut Vec<Column>| set(c, "heading", Column::Text("heading", vec!["north"; 6]))),
            "row 0, column heading",
        ),
        (
            Box::new(|c: &mut Vec<Column>| set(c, "timestep", Column::Int("timestep", vec![48, 49, 110, 48, 49, 50]))),
            "row 2, column timestep",
        ),
        (
            Box::new(|c: &mut Vec<Column>| {
                set(c, "velocity_x", Column::Float("velocity_x", vec![10.0, f64::NAN, 10.0, 0.0, 0.0, 0.0]))
            }),
            "row 1, column velocity_x",
        ),
        (
            Box::new(|c: &mut Vec<Column>| set(c, "timestep", Column::Int("timestep", vec![48, 49, 49, 48, 49, 50]))),
            "row 2, column timestep",
        ),
        (
            Box::new(|c: &mut Vec<Column>| set(c, "num_timestamps", Column::Int("num_timestamps", vec![i64::MAX; 6]))),
            "row 0, column num_timestamps",
        ),
        (
            Box::new(|c: &mut Vec<Column>| {
                set(c, "position_x", Column::Float("position_x", vec![0.0, 1.0, 2.0, 5.0, 1e12, 5.0]))
            }),
            "row 4, column position_x",
        ),
    ];
    for (change, at) in cases {
        let bytes = small_parquet(change);
        let err = argoverse2::parse(&bytes, SMALL_MAP.as_bytes(), path).expect_err(at);
        assert_eq!(malformed_at(&err, path), Location::Element(at.to_string()), "{err}");
    }
}
