//! WOMD `Scenario` protobuf import: every shared `.tfrecord` file goes
//! through [`safer_scenarios::scenario::import::load`] and must keep the invariants
//! (counts, valid masks, finite values, headings that agree with velocity),
//! and broken TFRecord / protobuf input built here must fail with a message
//! naming the file and the place, never a panic. Also home of the checks
//! shared with the JSON importer's tests ([`check_scenario`],
//! [`on_road_share`]).

use std::path::Path;
use std::time::Instant;

use safer_scenarios::geometry::wrap_angle;
use safer_scenarios::scenario::import::{load, tfrecord, womd_proto};
use safer_scenarios::scenario::{AgentKind, RoleOrigin, Scenario};

use crate::shared_data::files;

/// Vehicles at least this fast have a velocity direction that tells their heading.
const MOVING_SPEED_MPS: f64 = 2.0;
/// Heading within this angle of the velocity direction agrees.
const AGREEMENT_RAD: f64 = 0.5;

/// Share of moving-vehicle samples whose heading agrees with the velocity
/// direction, and the number of samples.
pub fn heading_agreement(s: &Scenario) -> (f64, usize) {
    let (mut n, mut agree) = (0usize, 0usize);
    for t in s.tracks.iter().filter(|t| t.kind == AgentKind::Vehicle) {
        for st in t.states.iter().flatten() {
            if st.speed_mps() > MOVING_SPEED_MPS {
                n += 1;
                let direction = st.velocity_mps.y.atan2(st.velocity_mps.x);
                agree += usize::from(wrap_angle(st.heading_rad - direction).abs() < AGREEMENT_RAD);
            }
        }
    }
    (if n == 0 { 1.0 } else { agree as f64 / n as f64 }, n)
}

/// Share of lane-centreline points the map classifies as on the road
/// (negative signed distance to the nearest road edge), and the number of
/// points checked. Points are sampled evenly, at most [`ON_ROAD_SAMPLES`]
/// per scene: each query costs about a quarter millisecond in a debug build,
/// and all of them (half a million over the JSON scenes) gave the same
/// shares when measured once.
pub fn on_road_share(s: &Scenario) -> (f64, usize) {
    let total: usize = s.map.lanes.iter().map(|l| l.centreline.len()).sum();
    let stride = total.div_ceil(ON_ROAD_SAMPLES).max(1);
    let points = s.map.lanes.iter().flat_map(|l| l.centreline.points()).step_by(stride);
    let (mut n, mut on) = (0usize, 0usize);
    for p in points {
        if let Some(d) = s.map.signed_distance_to_road_edge(p) {
            n += 1;
            on += usize::from(d < 0.0);
        }
    }
    (if n == 0 { 1.0 } else { on as f64 / n as f64 }, n)
}

/// Most lane points [`on_road_share`] checks per scene.
pub const ON_ROAD_SAMPLES: usize = 1000;

/// Invariants every imported WOMD scene must have, whatever its format.
pub fn check_scenario(path: &Path, s: &Scenario) {
    let name = path.display();
    s.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
    assert!(!s.tracks.is_empty(), "{name}: no tracks");
    assert_eq!(s.num_steps(), 91, "{name}: steps");
    assert_eq!(s.current_step, 10, "{name}: current step");
    assert!((s.dt_s - 0.1).abs() < 1e-6, "{name}: dt {}", s.dt_s);
    let valid_now = s.tracks.iter().filter(|t| t.state(s.current_step).is_some()).count();
    assert!(valid_now > 0, "{name}: no agent valid at the current step");
    for t in &s.tracks {
        assert!(t.length_m > 0.0 && t.width_m > 0.0, "{name}: track {} size", t.id);
        for st in t.states.iter().flatten() {
            // Re-centred: a scene spans a few hundred metres, never a city.
            assert!(st.position.coords.norm() < 5_000.0, "{name}: track {} far from the origin: {st:?}", t.id);
            assert!(st.heading_rad > -std::f64::consts::PI && st.heading_rad <= std::f64::consts::PI);
            assert!(st.speed_mps() < 80.0, "{name}: track {} speed {}", t.id, st.speed_mps());
        }
    }
    let (agreement, samples) = heading_agreement(s);
    assert!(
        samples < 10 || agreement > 0.9,
        "{name}: heading agrees with velocity in only {:.1}% of {samples} moving-vehicle samples (wrong unit?)",
        agreement * 100.0
    );
    assert!(!s.map.is_empty(), "{name}: empty map");
    assert!(!s.map.lanes.is_empty(), "{name}: no lanes");
    if let Some(ego) = s.ego {
        assert!(s.track(ego).state(s.current_step).is_some(), "{name}: ego not valid now");
    }
    if let (Some(ego), Some(cbv)) = (s.ego, s.cbv) {
        assert_ne!(ego, cbv, "{name}: ego is the CBV");
    }
    for signal in &s.map.traffic_signals {
        assert_eq!(signal.states.len(), s.num_steps(), "{name}: signal of lane {:?}", signal.lane);
    }
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn womd_proto_every_file_imports_with_invariants() {
    for path in files("womd-tfrecord", "tfrecord") {
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let started = Instant::now();
        womd_proto::parse(&bytes, &path).unwrap_or_else(|e| panic!("{e}"));
        let parse_s = started.elapsed().as_secs_f64();
        let started = Instant::now();
        let scenarios = load(&path).unwrap_or_else(|e| panic!("{e}"));
        let load_s = started.elapsed().as_secs_f64();
        assert_eq!(scenarios.len(), 1, "{}: one scenario per file", path.display());
        for s in &scenarios {
            check_scenario(&path, s);
            // Both files name their ego.
            assert!(s.ego.is_some(), "{}: no ego", path.display());
            assert_eq!(s.ego_origin, RoleOrigin::Source);
            assert!(!s.id.is_empty());
            let (agreement, samples) = heading_agreement(s);
            let (on_road, points) = on_road_share(s);
            println!(
                "{}: {} tracks, {} lanes, {:?}; heading agreement {:.1}% of {samples}; lane points on road {:.1}% of {points}; parse {:.0} ms, load (parse, re-centre, roles, validate) {:.0} ms; notes {:?}",
                path.display(),
                s.tracks.len(),
                s.map.lanes.len(),
                s.map.counts(),
                agreement * 100.0,
                on_road * 100.0,
                parse_s * 1e3,
                load_s * 1e3,
                s.source.notes
            );
        }
    }
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn womd_proto_counts_match_the_files() {
    let dir = crate::shared_data::data_dir().join("womd-tfrecord");
    let one = load(&dir.join("motion_data_one_scenario.tfrecord")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(one[0].tracks.len(), 83);
    assert_eq!(one[0].map.lanes.len(), 199);
    let input = load(&dir.join("womd_scenario_input.tfrecord")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(input[0].tracks.len(), 257);
    for s in one.iter().chain(&input) {
        // WOMD labels lanes with connectivity and speed limits.
        assert!(s.map.lanes.iter().any(|l| !l.successors.is_empty()), "{}: no lane successors", s.id);
        assert!(s.map.lanes.iter().any(|l| !l.predecessors.is_empty()), "{}: no lane predecessors", s.id);
        assert!(s.map.lanes.iter().any(|l| l.speed_limit_mps.is_some()), "{}: no speed limits", s.id);
        assert!(!s.map.road_edges.is_empty(), "{}: no road edges", s.id);
        // Every successor named exists in the map (WOMD maps are cropped, so
        // allow a few dangling ones at the crop border).
        let named: usize = s.map.lanes.iter().map(|l| l.successors.len()).sum();
        let found: usize =
            s.map.lanes.iter().flat_map(|l| &l.successors).filter(|id| s.map.lane(**id).is_some()).count();
        assert!(found as f64 >= 0.8 * named as f64, "{}: {found} of {named} successors exist", s.id);
        // Lane boundaries built from boundary segments lie on their side:
        // port (negative signed distance) for the left, starboard for the right.
        let (mut sided, mut total) = (0usize, 0usize);
        for lane in &s.map.lanes {
            for (boundary, sign) in [(&lane.left_boundary, -1.0), (&lane.right_boundary, 1.0)] {
                for p in boundary.iter().flat_map(|b| b.points()) {
                    if let Some(proj) = lane.centreline.project(p) {
                        total += 1;
                        sided += usize::from(proj.signed_distance_m * sign > 0.0);
                    }
                }
            }
        }
        assert!(total > 100, "{}: {total} boundary points", s.id);
        assert!(sided as f64 > 0.95 * total as f64, "{}: {sided} of {total} boundary points on their side", s.id);
        println!(
            "{}: {sided} of {total} lane-boundary points on their side; ego {:?} ({:?}), CBV {:?} ({:?}), objects of interest {:?}",
            s.id, s.ego, s.ego_origin, s.cbv, s.cbv_origin, s.objects_of_interest
        );
    }
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn womd_proto_on_road_share_of_lane_points() {
    // The map module assumes WOMD road edges have the road on their port
    // side; lane centrelines must then lie on the road almost everywhere.
    for path in files("womd-tfrecord", "tfrecord") {
        for s in load(&path).unwrap_or_else(|e| panic!("{e}")) {
            let (share, points) = on_road_share(&s);
            assert!(points > ON_ROAD_SAMPLES / 2, "{}: {points} lane points", path.display());
            assert!(share > 0.8, "{}: only {:.1}% of lane points on the road", path.display(), share * 100.0);
        }
    }
}

/// A path for messages; the bytes never touch the disk.
fn fake_path() -> &'static Path {
    Path::new("in-memory/broken.tfrecord")
}

fn first_record() -> Vec<u8> {
    let path = crate::shared_data::data_dir().join("womd-tfrecord/motion_data_one_scenario.tfrecord");
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn womd_proto_truncated_file_is_an_error_naming_the_record() {
    let bytes = first_record();
    for cut in [1, 7, 12, 13, 100, bytes.len() / 2, bytes.len() - 1] {
        let e = womd_proto::parse(&bytes[..cut], fake_path()).expect_err("truncated input must fail").to_string();
        assert!(e.contains("in-memory/broken.tfrecord"), "{e}");
        assert!(e.contains("record 0 (byte 0)"), "cut {cut}: {e}");
        assert!(e.contains("truncated"), "cut {cut}: {e}");
    }
    // A second record cut short names record 1 at its own offset.
    let mut two = bytes.clone();
    two.extend_from_slice(&bytes[..bytes.len() - 3]);
    let e = womd_proto::parse(&two, fake_path()).unwrap_err().to_string();
    assert!(e.contains(&format!("record 1 (byte {})", bytes.len())), "{e}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn womd_proto_flipped_crc_byte_is_an_error() {
    let bytes = first_record();
    // Length CRC (bytes 8..12), payload CRC (last 4 bytes), and a payload byte.
    for at in [9, bytes.len() - 2, 5000] {
        let mut bad = bytes.clone();
        bad[at] ^= 0x01;
        let e = womd_proto::parse(&bad, fake_path()).expect_err("corrupt input must fail").to_string();
        assert!(e.contains("in-memory/broken.tfrecord") && e.contains("record 0"), "{e}");
        assert!(e.contains("CRC mismatch"), "byte {at}: {e}");
    }
}

#[test]
fn womd_proto_garbage_payload_with_valid_crcs_is_a_decode_error() {
    // 0xff.. is an invalid varint / wire type: prost must refuse it.
    let mut file = tfrecord::frame_record(b"ok");
    let offset = file.len();
    file.extend(tfrecord::frame_record(&[0xff; 64]));
    let e = womd_proto::parse(&file, fake_path()).expect_err("garbage must fail").to_string();
    assert!(e.contains("in-memory/broken.tfrecord"), "{e}");
    // Record 0 ("ok") is itself not a Scenario and fails first; check that,
    // then the garbage on its own at record 0.
    assert!(e.contains("record 0 (byte 0)"), "{e}");
    let e = womd_proto::parse(&file[offset..], fake_path()).unwrap_err().to_string();
    assert!(e.contains("record 0 (byte 0)") && e.contains("not a WOMD Scenario protobuf"), "{e}");
}

#[test]
fn womd_proto_empty_scenario_record_is_an_error() {
    // An empty payload decodes to a Scenario with every field absent.
    let e = womd_proto::parse(&tfrecord::frame_record(&[]), fake_path()).unwrap_err().to_string();
    assert!(e.contains("record 0 (byte 0)") && e.contains("timestamps_seconds"), "{e}");
    let e = womd_proto::parse(&[], fake_path()).unwrap_err().to_string();
    assert!(e.contains("no records"), "{e}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn womd_proto_nan_in_a_valid_state_names_track_and_step() {
    use prost::Message;
    use womd_proto::proto;
    let bytes = first_record();
    let record = &tfrecord::read_records(&bytes, fake_path()).unwrap()[0];
    let mut message = proto::Scenario::decode(record.payload).unwrap();
    let (track, step) = message
        .tracks
        .iter()
        .enumerate()
        .find_map(|(i, t)| t.states.iter().position(|s| s.valid == Some(true)).map(|k| (i, k)))
        .unwrap();
    message.tracks[track].states[step].center_x = Some(f64::NAN);
    let file = tfrecord::frame_record(&message.encode_to_vec());
    let e = womd_proto::parse(&file, fake_path()).unwrap_err().to_string();
    assert!(e.contains(&format!("tracks[{track}]")) && e.contains(&format!("states[{step}]")), "{e}");
    assert!(e.contains("record 0"), "{e}");
}

/// The geometric join of [`LaneGraph`] (for sources that keep no lane
/// connectivity, such as WOMD JSON) recovers the successors WOMD protobuf
/// records: on the shared protobuf scenes with their connectivity removed,
/// at least 9 of 10 recorded links are found and at least 9 of 10 links
/// found are recorded.
#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn womd_proto_lane_successors_joined_by_geometry_match_the_recorded_ones() {
    use safer_scenarios::map::lane_graph::LaneGraph;
    use safer_scenarios::map::{Lane, RoadMap};
    let (mut recorded, mut found, mut both) = (0usize, 0usize, 0usize);
    let (mut dead_ends, mut dead_ends_joined) = (0usize, 0usize);
    for path in files("womd-tfrecord", "tfrecord") {
        for s in load(&path).unwrap() {
            let m = &s.map;
            let with = LaneGraph::build(m);
            let bare: Vec<Lane> = m
                .lanes
                .iter()
                .map(|l| {
                    let mut l = l.clone();
                    (l.successors, l.predecessors) = (vec![], vec![]);
                    l
                })
                .collect();
            let bare = RoadMap::new(
                bare,
                m.road_edges.clone(),
                m.road_lines.clone(),
                m.areas.clone(),
                m.drivable_areas.clone(),
                m.stop_signs.clone(),
                m.traffic_signals.clone(),
            );
            let joined = LaneGraph::build(&bare);
            for i in 0..m.lanes.len() {
                let truth = if m.lanes[i].successors.is_empty() { &[][..] } else { with.successors(i) };
                let guess = joined.successors(i);
                if truth.is_empty() {
                    dead_ends += 1;
                    dead_ends_joined += usize::from(!guess.is_empty());
                }
                recorded += truth.len();
                found += guess.len();
                both += guess.iter().filter(|j| truth.contains(j)).count();
            }
        }
    }
    let (recall, precision) = (both as f64 / recorded as f64, both as f64 / found as f64);
    eprintln!(
        "{recorded} recorded successor links, {found} joined, {both} in both: recall {recall:.3}, precision {precision:.3}; {dead_ends_joined} of {dead_ends} lanes without a recorded successor joined"
    );
    assert!(recorded > 100, "{recorded} recorded links: too few to judge");
    assert!(recall >= 0.9 && precision >= 0.9, "recall {recall:.3}, precision {precision:.3}");
}
