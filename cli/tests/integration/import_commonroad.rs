//! CommonRoad 2020a import: every shared NGSIM `.xml` file goes through
//! [`safer_scenarios::scenario::import::load`] and must keep the invariants (valid
//! agents now, finite values, headings that agree with the direction of
//! motion, a lane map whose centrelines are on the road), and broken XML
//! built here must fail with the file and line/column, never a panic. Also
//! home of [`heading_follows_motion`], shared with the Argoverse 2 tests.

use std::path::{Path, PathBuf};

use safer_scenarios::geometry::{Point2, Vector2, wrap_angle};
use safer_scenarios::scenario::import::{ImportError, Location, commonroad, discover, load};
use safer_scenarios::scenario::{AgentKind, DataLicence, RoleOrigin, Scenario};

use crate::shared_data::{ImportTimings, TimedImport, data_dir, files};

/// A vehicle moving at least this fast between two steps has a direction
/// of motion that tells its heading.
const MOVING_SPEED_MPS: f64 = 2.0;
/// Heading within this angle of the direction of motion agrees.
const AGREEMENT_RAD: f64 = 0.5;

/// Share of moving-vehicle samples (consecutive valid steps at least
/// [`MOVING_SPEED_MPS`] apart) whose heading agrees with the direction of
/// the displacement, and the number of samples. Uses positions, not the
/// velocity field, because CommonRoad velocities are derived from the
/// heading and would agree by construction.
pub fn heading_follows_motion(s: &Scenario) -> (f64, usize) {
    let (mut n, mut agree) = (0usize, 0usize);
    for t in s.tracks.iter().filter(|t| t.kind == AgentKind::Vehicle) {
        for pair in t.states.windows(2) {
            let (Some(a), Some(b)) = (&pair[0], &pair[1]) else { continue };
            let d = b.position - a.position;
            if d.norm() / s.dt_s < MOVING_SPEED_MPS {
                continue;
            }
            n += 1;
            let direction = d.y.atan2(d.x);
            agree += usize::from(wrap_angle(a.heading_rad - direction).abs() < AGREEMENT_RAD);
        }
    }
    (if n == 0 { 1.0 } else { agree as f64 / n as f64 }, n)
}

/// Share of centreline samples (every metre, starting 0.25 m in from the
/// lanelet's start and ending before its end) that the map says are on the
/// road, and how many were checked. The very ends lie on a lanelet
/// polygon's closing edge, where containment may go either way, and at the
/// map's border no other lanelet continues it.
fn centreline_on_road_share(s: &Scenario) -> (f64, usize) {
    let (mut n, mut on) = (0usize, 0usize);
    for lane in &s.map.lanes {
        let length = lane.centreline.length_m();
        let mut at = 0.25f64.min(0.5 * length);
        while at < length - 0.1 {
            let Some((p, _)) = lane.centreline.sample(at) else { break };
            n += 1;
            on += usize::from(!s.map.is_off_road(&p));
            at += 1.0;
        }
    }
    (if n == 0 { 1.0 } else { on as f64 / n as f64 }, n)
}

/// A point 50 m beyond the corner of the lanes' bounding box, hence at
/// least 50 m from every lane.
fn far_from_lanes(s: &Scenario) -> Point2 {
    let pts = s.map.lanes.iter().flat_map(|l| {
        l.centreline.points().iter().chain(l.left_boundary.iter().chain(&l.right_boundary).flat_map(|b| b.points()))
    });
    let (mut max_x, mut max_y) = (f64::MIN, f64::MIN);
    for p in pts {
        max_x = max_x.max(p.x);
        max_y = max_y.max(p.y);
    }
    Point2::new(max_x + 50.0, max_y + 50.0)
}

fn check(path: &Path, s: &Scenario) {
    let name = path.display();
    s.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(s.source.licence, DataLicence::PublicDomain, "{name}");
    assert_eq!(s.id, path.file_stem().unwrap().to_string_lossy(), "{name}: benchmarkID is the file name");
    assert!((s.dt_s - 0.1).abs() < 1e-9, "{name}: dt {}", s.dt_s);
    assert!(!s.tracks.is_empty(), "{name}: no tracks");
    let n = s.num_steps();
    assert!(n >= 1);
    if n > commonroad::CURRENT_STEP {
        assert_eq!(s.current_step, commonroad::CURRENT_STEP, "{name}: current step");
    } else {
        assert_eq!(s.current_step, 0, "{name}: current step of a short recording");
    }
    let valid_now = s.tracks.iter().filter(|t| t.state(s.current_step).is_some()).count();
    assert!(valid_now * 2 >= s.tracks.len(), "{name}: only {valid_now} of {} agents valid now", s.tracks.len());
    for t in &s.tracks {
        assert!(t.length_m > 0.0 && t.width_m > 0.0, "{name}: track {} size", t.id);
        assert_eq!(t.states.len(), n);
        for st in t.states.iter().flatten() {
            assert!(st.position.x.is_finite() && st.position.y.is_finite(), "{name}: track {}", t.id);
            assert!(st.position.coords.norm() < 2_000.0, "{name}: track {} far from the origin: {st:?}", t.id);
            assert!(st.heading_rad > -std::f64::consts::PI && st.heading_rad <= std::f64::consts::PI);
            assert!(st.speed_mps().is_finite() && st.speed_mps() < 60.0, "{name}: track {} speed", t.id);
        }
    }
    // The planning problem's ego is not in the file: roles come from mining.
    assert_ne!(s.ego_origin, RoleOrigin::Source, "{name}");

    assert!(!s.map.lanes.is_empty(), "{name}: no lanes");
    assert_eq!(s.map.drivable_areas.len(), s.map.lanes.len(), "{name}: one drivable polygon per lanelet");
    assert!(!s.map.road_edges.is_empty(), "{name}: no road edges");
    for lane in &s.map.lanes {
        assert!(lane.centreline.len() >= 2, "{name}: lane {:?} centreline", lane.id);
        assert!(lane.left_boundary.is_some() && lane.right_boundary.is_some());
    }
    let far = far_from_lanes(s);
    assert!(s.map.is_off_road(&far), "{name}: {far:?} is 50 m from every lane but on the road");
    for signal in &s.map.traffic_signals {
        assert_eq!(signal.states.len(), n, "{name}: signal of lane {:?}", signal.lane);
        assert!(s.map.lane(signal.lane).is_some(), "{name}: signal for unknown lane {:?}", signal.lane);
    }
}

/// Road-edge segments whose off-road side (starboard, 0.3 m out from the
/// middle) lies in a lanelet, and all road-edge segments.
fn edge_segments_with_road_beyond(s: &Scenario) -> (usize, usize) {
    let (mut through_road, mut total) = (0, 0);
    for edge in &s.map.road_edges {
        for pair in edge.polyline.points().windows(2) {
            let along = pair[1] - pair[0];
            if along.norm() < 1e-6 {
                continue;
            }
            total += 1;
            let starboard = Vector2::new(along.y, -along.x).normalize() * 0.3;
            let probe = Point2::from((pair[0].coords + pair[1].coords) * 0.5) + starboard;
            through_road += usize::from(s.map.drivable_areas.iter().any(|a| a.contains(&probe)));
        }
    }
    (through_road, total)
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn commonroad_every_file_imports_with_invariants() {
    let paths = files("commonroad-ngsim", "xml");
    assert_eq!(paths.len(), 84, "shared CommonRoad files");
    let mut timings = ImportTimings::default();
    let (mut agree_sum, mut samples_sum) = (0.0f64, 0usize);
    let (mut on_road_sum, mut points_sum) = (0.0f64, 0usize);
    let mut edges_sum = 0usize;
    let (mut with_signals, mut with_ego, mut at_step_10) = (0, 0, 0);
    for path in &paths {
        let TimedImport { bytes, scenarios, parse_s, .. } = timings.import(path, commonroad::parse);
        assert_eq!(scenarios.len(), 1, "{}: one scenario per file", path.display());
        let s = &scenarios[0];
        check(path, s);

        let (agreement, samples) = heading_follows_motion(s);
        assert!(
            samples < 10 || agreement > 0.9,
            "{}: heading agrees with motion in only {:.1}% of {samples} samples",
            path.display(),
            agreement * 100.0
        );
        agree_sum += agreement * samples as f64;
        samples_sum += samples;
        let (on_road, points) = centreline_on_road_share(s);
        assert!(
            on_road >= 0.99,
            "{}: only {:.1}% of {points} centreline points on the road",
            path.display(),
            on_road * 100.0
        );
        on_road_sum += on_road * points as f64;
        points_sum += points;
        // A road edge has road on one side only: none runs through an
        // intersection or between lanes the file does not call adjacent.
        let (through_road, edge_segments) = edge_segments_with_road_beyond(s);
        assert_eq!(
            through_road,
            0,
            "{}: {through_road} of {edge_segments} road-edge segments have a lanelet on their off-road side",
            path.display()
        );
        edges_sum += edge_segments;

        // Lankershim and Peachtree-4 files have signals; their lanelets must
        // carry them.
        let text = String::from_utf8_lossy(&bytes);
        if text.contains("<trafficLight ") {
            with_signals += 1;
            assert!(!s.map.traffic_signals.is_empty(), "{}: traffic lights not mapped", path.display());
        }
        with_ego += usize::from(s.ego.is_some());
        at_step_10 += usize::from(s.current_step == 10);
        println!(
            "{}: {} tracks x {} steps (now {}), {:?}; heading follows motion {:.1}% of {samples}; centreline on road {:.1}% of {points}; parse {:.0} ms",
            path.file_name().unwrap_or_default().to_string_lossy(),
            s.tracks.len(),
            s.num_steps(),
            s.current_step,
            s.map.counts(),
            agreement * 100.0,
            on_road * 100.0,
            parse_s * 1e3,
        );
    }
    println!(
        "commonroad: {} files, {}; heading follows motion {:.2}% of {samples_sum}; centreline on road {:.2}% of {points_sum}; {edges_sum} road-edge segments, none with road beyond; {with_signals} with signals; {with_ego} with a mined ego; {at_step_10} with now = step 10",
        paths.len(),
        timings.summary(),
        100.0 * agree_sum / samples_sum.max(1) as f64,
        100.0 * on_road_sum / points_sum.max(1) as f64,
    );
    assert_eq!(with_signals, 37, "Lankershim and Peachtree-4 files carry traffic lights");
    // All but the 4 set-based-prediction files (one step) reach step 10.
    assert_eq!(at_step_10, 80);
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn commonroad_discover_lists_every_file() {
    let found = discover(&data_dir().join("commonroad-ngsim")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(found, files("commonroad-ngsim", "xml"));
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn commonroad_lankershim_signals_cycle() {
    let path = data_dir().join("commonroad-ngsim/USA_Lanker-2_17_T-1.xml");
    let s = load(&path).unwrap_or_else(|e| panic!("{e}")).remove(0);
    assert!(s.map.traffic_signals.len() >= 10, "{} signalled lanelets", s.map.traffic_signals.len());
    for signal in &s.map.traffic_signals {
        assert!(signal.stop_point.is_some());
        assert!(
            signal.states.iter().all(|st| *st != safer_scenarios::map::SignalState::Unknown),
            "lane {:?}",
            signal.lane
        );
    }
    // Some approaches are red while others are green: the cycles are offset.
    let now = s.current_step;
    let red = s.map.traffic_signals.iter().filter(|sig| sig.states[now].requires_stop()).count();
    assert!(red > 0 && red < s.map.traffic_signals.len(), "{red} of {} red now", s.map.traffic_signals.len());
    // Speed limits come from the R2-1 signs (30 mph on Lankershim).
    assert!(s.map.lanes.iter().any(|l| l.speed_limit_mps.is_some_and(|v| (v - 13.4112).abs() < 1e-6)));
    assert!(s.map.lanes.iter().any(|l| l.in_intersection));
}

fn sample_bytes() -> (PathBuf, String) {
    let path = data_dir().join("commonroad-ngsim/USA_US101-1_1_T-1.xml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (path, text)
}

fn expect_line_column(err: &ImportError, path: &Path) -> (usize, usize) {
    let message = err.to_string();
    assert!(message.contains(&path.display().to_string()), "file not named: {message}");
    match err {
        ImportError::Malformed { location: Location::LineColumn { line, column }, .. } => (*line, *column),
        other => panic!("expected a line/column: {other}"),
    }
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn commonroad_truncated_xml_names_line_and_column() {
    let (path, text) = sample_bytes();
    for cut in [text.len() / 3, text.len() / 2, text.len() - 20] {
        let err = commonroad::parse(&text.as_bytes()[..cut], &path).expect_err("truncated XML must fail");
        let (line, _) = expect_line_column(&err, &path);
        assert!(line > 1, "{err}");
    }
    let err = commonroad::parse(b"", &path).expect_err("empty file must fail");
    expect_line_column(&err, &path);
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn commonroad_lanelet_without_right_bound_is_an_error() {
    let (path, text) = sample_bytes();
    let start = text.find("<rightBound>").unwrap();
    let end = text.find("</rightBound>").unwrap() + "</rightBound>".len();
    let broken = format!("{}{}", &text[..start], &text[end..]);
    let err = commonroad::parse(broken.as_bytes(), &path).expect_err("missing rightBound must fail");
    let (line, _) = expect_line_column(&err, &path);
    // The error points at the lanelet that lacks it.
    let lanelet_line = text[..text[..start].rfind("<lanelet ").unwrap()].matches('\n').count() + 1;
    assert_eq!(line, lanelet_line, "{err}");
    assert!(err.to_string().contains("rightBound"), "{err}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn commonroad_bad_values_are_errors_not_panics() {
    let (path, text) = sample_bytes();
    let cases = [
        ("<time>\n        <exact>0</exact>", "<time>\n        <exact>-3</exact>"),
        ("<time>\n          <exact>1</exact>", "<time>\n          <exact>1e9</exact>"),
        ("<time>\n          <exact>1</exact>", "<time>\n          <exact>123456789</exact>"),
        ("<length>", "<length>NaN"),
        ("timeStepSize=\"0.1\"", "timeStepSize=\"-1\""),
        ("drivingDir=\"same\"", "drivingDir=\"sideways\""),
        ("<commonRoad ", "<notCommonRoad "),
    ];
    for (from, to) in cases {
        assert!(text.contains(from), "{from}");
        let broken = text.replacen(from, to, 1);
        let broken = if from == "<commonRoad " { broken.replace("</commonRoad>", "</notCommonRoad>") } else { broken };
        let err = commonroad::parse(broken.as_bytes(), &path).expect_err(to);
        expect_line_column(&err, &path);
    }
    // A coordinate far beyond any projected frame (the map's spatial grid
    // would try to cover it).
    let start = text.find("<x>").unwrap() + "<x>".len();
    let end = start + text[start..].find("</x>").unwrap();
    let far = format!("{}2e7{}", &text[..start], &text[end..]);
    let err = commonroad::parse(far.as_bytes(), &path).expect_err("far coordinate");
    expect_line_column(&err, &path);
    assert!(err.to_string().contains("from the origin"), "{err}");
    // Not UTF-8.
    let err = commonroad::parse(&[0xff, 0xfe, 0x00], &path).expect_err("binary");
    assert!(err.to_string().contains(&path.display().to_string()));
}
