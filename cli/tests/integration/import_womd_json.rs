//! WOMD JSON (nocturne / GPUDrive) import: every shared `.json` scene goes
//! through [`safer_scenarios::scenario::import::load`] and must keep the invariants;
//! the heading unit (degrees in older files, radians in newer ones) must be
//! detected so headings agree with velocity; broken JSON built here must
//! fail with the file and the line/column or element, never a panic.

use std::path::Path;

use safer_scenarios::scenario::RoleOrigin;
use safer_scenarios::scenario::import::{load, womd_json};

use crate::import_womd_proto::{check_scenario, heading_agreement, on_road_share};
use crate::shared_data::{ImportTimings, TimedImport, files};

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn womd_json_every_file_imports_with_invariants() {
    let paths = files("womd-json", "json");
    assert_eq!(paths.len(), 67, "shared WOMD JSON scenes");
    let mut timings = ImportTimings::default();
    let (mut degrees, mut radians, mut with_ego) = (0, 0, 0);
    let (mut on_road_points, mut all_points) = (0.0f64, 0usize);
    for path in &paths {
        let TimedImport { bytes, scenarios, parse_s, load_s } = timings.import(path, womd_json::parse);
        assert_eq!(scenarios.len(), 1);
        let s = &scenarios[0];
        check_scenario(path, s);
        let unit = s
            .source
            .notes
            .iter()
            .find(|n| n.starts_with("heading unit: "))
            .unwrap_or_else(|| panic!("{}: no heading-unit note in {:?}", path.display(), s.source.notes));
        if unit.starts_with("heading unit: degrees") {
            degrees += 1;
        } else {
            radians += 1;
        }
        // The source names an ego exactly when it has metadata; a labelled
        // interacting pair without the SDC replaces it.
        let text = String::from_utf8_lossy(&bytes);
        if text.contains("\"metadata\"") && text.contains("\"sdc_track_index\"") {
            with_ego += 1;
            match s.ego_origin {
                RoleOrigin::Source => {}
                RoleOrigin::LabelledPair => {
                    let (ego, cbv) = (s.ego.unwrap(), s.cbv.unwrap());
                    assert!(s.objects_of_interest.contains(&ego) && s.objects_of_interest.contains(&cbv));
                    assert!(s.source.notes.iter().any(|n| n.contains("the SDC")), "{:?}", s.source.notes);
                }
                other => panic!("{}: ego origin {other:?} despite an SDC", path.display()),
            }
        } else {
            assert_ne!(s.ego_origin, RoleOrigin::Source, "{}", path.display());
        }
        let (share, points) = on_road_share(s);
        on_road_points += share * points as f64;
        all_points += points;
        let (agreement, samples) = heading_agreement(s);
        println!(
            "{}: {} tracks, {} lanes, {} edges, heading {:.1}% of {samples}, lane points on road {:.1}% of {points}, parse {:.0} ms, load {:.0} ms; {}",
            path.file_name().unwrap_or_default().to_string_lossy(),
            s.tracks.len(),
            s.map.lanes.len(),
            s.map.road_edges.len(),
            agreement * 100.0,
            share * 100.0,
            parse_s * 1e3,
            load_s * 1e3,
            unit
        );
    }
    println!(
        "womd-json: {} files, {} (load = parse, re-centre, roles, validate); {degrees} in degrees, {radians} in radians; {with_ego} name an ego; lane points on road {:.1}% of {all_points}",
        paths.len(),
        timings.summary(),
        100.0 * on_road_points / all_points.max(1) as f64
    );
    // 42 + 13 files in degrees; 11 with metadata and one middle-generation
    // file in radians.
    assert_eq!((degrees, radians), (55, 12));
    assert_eq!(with_ego, 11);
    assert!(on_road_points / all_points as f64 > 0.8, "lane points mostly on the road");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn womd_json_newest_generation_names_ego_and_cbv() {
    let path = crate::shared_data::data_dir().join("womd-json/tfrecord-00000-of-01000_4.json");
    let s = &load(&path).unwrap_or_else(|e| panic!("{e}"))[0];
    assert_eq!(s.id, "db4edc9bd0c9d18c");
    assert_eq!(s.ego, Some(safer_scenarios::scenario::TrackIndex(80)));
    assert_eq!(s.ego_origin, RoleOrigin::Source);
    assert_eq!(s.objects_of_interest.len(), 2);
    assert!(s.map.lanes.iter().any(|l| l.kind != safer_scenarios::map::LaneKind::Undefined));

    // A middle-generation file with traffic signals keyed by lane id.
    let path = crate::shared_data::data_dir().join("womd-json/tfrecord-00001-of-00150_c9bbd79edc48bbcb.json");
    let s = &load(&path).unwrap_or_else(|e| panic!("{e}"))[0];
    assert_eq!(s.map.traffic_signals.len(), 14);
    for signal in &s.map.traffic_signals {
        assert!(s.map.lane(signal.lane).is_some(), "signal of lane {:?} names no lane", signal.lane);
        assert!(signal.stop_point.is_some());
        assert!(signal.states.iter().any(|st| *st != safer_scenarios::map::SignalState::Unknown));
    }
}

fn fake_path() -> &'static Path {
    Path::new("in-memory/broken.json")
}

/// A minimal scene with one vehicle of `n` steps whose heading list has
/// `heading_len` entries.
fn scene(n: usize, heading_len: usize) -> String {
    let list = |item: &str, len: usize| format!("[{}]", vec![item; len].join(","));
    format!(
        r#"{{"name": "broken.json",
"objects": [{{"type": "vehicle", "length": 4.5, "width": 2.0,
  "position": {}, "heading": {}, "velocity": {}, "valid": {}}}],
"roads": [{{"type": "lane", "geometry": [{{"x": 0, "y": 0}}, {{"x": 10, "y": 0}}]}}],
"tl_states": {{}}}}"#,
        list(r#"{"x": 1.0, "y": 2.0}"#, n),
        list("0.0", heading_len),
        list(r#"{"x": 5.0, "y": 0.0}"#, n),
        list("true", n)
    )
}

#[test]
fn womd_json_minimal_scene_parses() {
    let s = womd_json::parse(scene(91, 91).as_bytes(), fake_path()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.num_steps(), 91);
    assert_eq!(s.current_step, 10);
    assert_eq!(s.id, "broken");
}

#[test]
fn womd_json_syntax_error_names_line_and_column() {
    let text = scene(91, 91).replacen(r#""width": 2.0,"#, r#""width": 2.0,,"#, 1);
    let e = womd_json::parse(text.as_bytes(), fake_path()).expect_err("syntax error must fail").to_string();
    assert!(e.contains("in-memory/broken.json"), "{e}");
    assert!(e.contains("line 2, column 61"), "{e}");
    // Truncated document.
    let text = scene(91, 91);
    let e = womd_json::parse(&text.as_bytes()[..text.len() / 2], fake_path()).unwrap_err().to_string();
    assert!(e.contains("in-memory/broken.json") && e.contains("line"), "{e}");
}

#[test]
fn womd_json_mismatched_list_lengths_name_the_element() {
    let e = womd_json::parse(scene(91, 90).as_bytes(), fake_path()).expect_err("must fail").to_string();
    assert!(e.contains("in-memory/broken.json"), "{e}");
    assert!(e.contains("objects[0].heading") && e.contains("90 entries"), "{e}");
}

#[test]
fn womd_json_wrong_shapes_are_errors_not_panics() {
    for (what, text) in [
        ("objects not a list", r#"{"objects": 3, "roads": []}"#.to_string()),
        ("no objects", r#"{"objects": [], "roads": []}"#.to_string()),
        ("heading strings", scene(91, 91).replace(r#""heading": [0.0"#, r#""heading": ["north""#)),
        ("negative size", scene(91, 91).replace(r#""length": 4.5"#, r#""length": -1"#)),
        ("bad signal key", scene(91, 91).replace(r#""tl_states": {}"#, r#""tl_states": {"lane": {"state": []}}"#)),
        (
            "signal step out of range",
            scene(91, 91)
                .replace(r#""tl_states": {}"#, r#""tl_states": {"1": {"state": ["go"], "time_index": [500]}}"#),
        ),
        ("empty", String::new()),
        ("not json", "\u{1}\u{2}garbage".to_string()),
    ] {
        let e = womd_json::parse(text.as_bytes(), fake_path()).expect_err(what).to_string();
        assert!(e.contains("in-memory/broken.json"), "{what}: {e}");
    }
}

/// WOMD JSON keeps no lane connectivity; the lane graph's geometric join
/// must still let the realism prior's map tokens read the turn ahead. In
/// the slip-lane scene `7fe71b1ddd04e369` the CBV starts in a right-turn
/// lane with no way straight on (the recorded CBV turns right; priors that
/// read only the nearby geometry drive on straight and off the road): the
/// lane token nearest to it must read a right turn and no other way, and
/// the lanes beside it, which go on straight, must read that.
#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn womd_json_slip_lane_tokens_read_a_right_turn_ahead_and_no_way_straight_on() {
    use safer_scenarios::geometry::wrap_angle;
    use safer_scenarios::models::prior_features::MapTokens;
    let path = crate::shared_data::data_dir().join("womd-interactive/tfrecord-00088-of-00150_48.json");
    let s = load(&path).unwrap_or_else(|e| panic!("{e}")).remove(0);
    assert_eq!(s.id, "7fe71b1ddd04e369");
    let cbv = s.tracks[s.cbv.expect("a labelled CBV").0].states[s.current_step].expect("the CBV is present");
    let tokens = MapTokens::build(&s.map);
    let mut along: Vec<_> = tokens
        .tokens
        .iter()
        .filter(|t| t.lane.is_some() && (t.midpoint - cbv.position).norm() < 6.0)
        .filter(|t| wrap_angle(t.direction_rad - cbv.heading_rad).abs() < 0.5)
        .collect();
    along.sort_by(|a, b| (a.midpoint - cbv.position).norm().total_cmp(&(b.midpoint - cbv.position).norm()));
    let turn = |t: &safer_scenarios::models::prior_features::MapToken| [t.features[7], t.features[8], t.features[9]];
    let [right, left, reach] = turn(along.first().expect("a lane token along the CBV within 6 m"));
    let quarter = std::f32::consts::FRAC_PI_2;
    assert!(
        (right + quarter).abs() < 0.3 && (left + quarter).abs() < 0.3 && reach > 30.0,
        "its lane: turn ahead {right} .. {left} rad over {reach} m"
    );
    let straight_beside = along.iter().filter(|t| t.lane != along[0].lane).any(|t| {
        let [right, left, _] = turn(t);
        right.abs() < 0.1 && left.abs() < 0.1
    });
    assert!(straight_beside, "no lane beside it goes straight on");
}

/// WOMD flags no lane as inside an intersection, so the lanes that cross
/// other lanes are taken to be (`RoadMap::mark_crossing_lanes_as_junctions`).
/// The recorded ego and CBV of the interactive set are human drivers: the
/// across-the-lanes measure (a second or more at over 30° to every lane an
/// agent is in, junctions left alone) must judge none of them across the
/// lanes. With every crossing lane read as an ordinary one it judges some
/// turning through a junction.
#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn womd_junction_lanes_are_where_lanes_cross_and_no_recorded_pair_drives_across_the_lanes() {
    use safer_scenarios::eval::traffic_rules::ACROSS_LANES_MIN_S;
    use safer_scenarios::map::RoadMap;
    let (mut lanes, mut junction_lanes, mut judged) = (0, 0, 0);
    let (mut across, mut across_unmarked) = (Vec::new(), Vec::new());
    for path in files("womd-interactive", "json") {
        for s in load(&path).unwrap_or_else(|e| panic!("{e}")) {
            let counts = s.map.counts();
            (lanes, junction_lanes) = (lanes + counts.lanes, junction_lanes + counts.junction_lanes);
            let mut unmarked = s.map.clone();
            unmarked.lanes.iter_mut().for_each(|l| l.crosses_lanes = false);
            let min_steps = (ACROSS_LANES_MIN_S / s.dt_s).round() as usize;
            for (role, agent) in [("ego", s.ego), ("CBV", s.cbv)] {
                let Some(agent) = agent else { continue };
                judged += 1;
                let states = &s.tracks[agent.0].states[s.current_step..];
                // The longest run of steps across the lanes, in steps.
                let longest = |map: &RoadMap| {
                    let (mut run, mut longest) = (0, 0);
                    for state in states {
                        let across = state.as_ref().is_some_and(|st| {
                            map.angle_across_lanes_at(&st.position, st.heading_rad, st.speed_mps()).is_some()
                        });
                        run = if across { run + 1 } else { 0 };
                        longest = longest.max(run);
                    }
                    longest
                };
                if longest(&s.map) >= min_steps {
                    across.push(format!("{} {role}", s.id));
                }
                if longest(&unmarked) >= min_steps {
                    across_unmarked.push(format!("{} {role}", s.id));
                }
            }
        }
    }
    assert!(judged > 0, "no recorded ego or CBV judged");
    assert!(!across_unmarked.is_empty(), "without the junction lanes no recorded driver is across the lanes");
    assert!(
        across.is_empty(),
        "recorded drivers across the lanes: {across:?} (without the junction lanes: {across_unmarked:?})"
    );
    // Urban scenes: a junction's connectors are a good share of their lanes.
    assert!(junction_lanes * 10 > lanes, "{junction_lanes} of {lanes} lanes in junctions");
}
