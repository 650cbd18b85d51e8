//! Traffic rules a planner must keep: an ego driving 3 s against the
//! traffic of the oncoming lane passed every criterion before
//! `no_wrong_way`; an ego that runs a red light passed before
//! `no_red_light`. Fixtures: `tests/fixtures/bad-input/traffic-rules/`.

use std::path::{Path, PathBuf};

use safer_scenarios::geometry::Polyline;
use safer_scenarios::harness::acceptance;
use safer_scenarios::harness::{Suite, run_variant};
use safer_scenarios::map::RoadMap;

fn fixture(name: &str) -> PathBuf {
    Path::new(repo_root!()).join("tests/fixtures/bad-input/traffic-rules").join(name)
}

/// The failed criteria of the suite's single variant, with their messages.
fn failures(suite: &str) -> Vec<(String, String)> {
    let suite = Suite::load(&fixture(suite)).unwrap_or_else(|e| panic!("{e}"));
    let outcome = run_variant(&suite, &suite.scenarios[0], 0).unwrap_or_else(|e| panic!("{e}"));
    outcome.failures.into_iter().map(|f| (f.criterion, f.what)).collect()
}

#[test]
fn driving_against_the_oncoming_lanes_traffic_fails_no_wrong_way() {
    assert_eq!(
        failures("wrong-way.suite.yaml"),
        [(
            "no_wrong_way".to_string(),
            "ego drove against the traffic of lane 100 for 3.1 s from t = 0.0 s".to_string()
        )]
    );
}

#[test]
fn running_a_red_light_fails_no_red_light_and_stopping_for_it_passes() {
    let failed = failures("red-light-constant-velocity.suite.yaml");
    assert_eq!(failed.len(), 1, "{failed:?}");
    assert_eq!(failed[0].0, "no_red_light");
    assert!(failed[0].1.starts_with("ego passed the stop line of lane 10 on red at t = 1."), "{failed:?}");
    assert_eq!(failures("red-light-idm.suite.yaml"), []);
}

/// The wrong-way scene's stage 2, judged by `no_wrong_way` on its map with
/// every lane centreline replaced by `cut(centreline)`.
fn wrong_way_on_cut_lanes(cut: impl Fn(&Polyline) -> Polyline) -> Vec<String> {
    let suite = Suite::load(&fixture("wrong-way.suite.yaml")).unwrap_or_else(|e| panic!("{e}"));
    let outcome = run_variant(&suite, &suite.scenarios[0], 0).unwrap_or_else(|e| panic!("{e}"));
    let m = &outcome.scenario.map;
    let lanes = m
        .lanes
        .iter()
        .map(|l| {
            let mut l = l.clone();
            l.centreline = cut(&l.centreline);
            l
        })
        .collect();
    let map = RoadMap::new(
        lanes,
        m.road_edges.clone(),
        m.road_lines.clone(),
        m.areas.clone(),
        m.drivable_areas.clone(),
        m.stop_signs.clone(),
        m.traffic_signals.clone(),
    );
    let criteria = safer_scenarios::spec::suite::VariantAcceptance { no_wrong_way: true, ..Default::default() };
    let base = safer_scenarios::scenario::Scenario { map, ..(*outcome.scenario).clone() };
    acceptance::check(&criteria, &outcome.stage2, &base, None, None).into_iter().map(|f| f.what).collect()
}

#[test]
fn lanes_cut_to_a_point_or_to_zero_length_leave_no_wrong_way_unmeasurable() {
    let intact = wrong_way_on_cut_lanes(Polyline::clone);
    assert_eq!(intact, ["ego drove against the traffic of lane 100 for 3.1 s from t = 0.0 s"]);
    let unmeasurable =
        "cannot be measured: the scene's map has no lane (of at least 1 m) to tell the traffic's direction";
    let one_point = wrong_way_on_cut_lanes(|c| Polyline::new(c.points()[..1].to_vec()));
    assert_eq!(one_point, [unmeasurable]);
    let zero_length = wrong_way_on_cut_lanes(|c| Polyline::new(vec![c.points()[0]; 2]));
    assert_eq!(zero_length, [unmeasurable]);
}

/// The failed criteria of each scenario's single variant, by scenario.
fn failures_by_scenario(suite: &str) -> Vec<(String, Vec<(String, String)>)> {
    let suite = Suite::load(&fixture(suite)).unwrap_or_else(|e| panic!("{e}"));
    suite
        .scenarios
        .iter()
        .map(|s| {
            let outcome = run_variant(&suite, s, 0).unwrap_or_else(|e| panic!("{e}"));
            (s.name.clone(), outcome.failures.into_iter().map(|f| (f.criterion, f.what)).collect())
        })
        .collect()
}

#[test]
fn a_planner_that_stays_put_in_a_free_lane_fails_min_progress() {
    let [(free, stays), (parked, unmeasurable)] = &failures_by_scenario("progress-constant-velocity.suite.yaml")[..]
    else {
        panic!("two scenarios")
    };
    assert_eq!(free, "free-lane");
    assert_eq!(stays.len(), 1, "{stays:?}");
    assert_eq!(stays[0].0, "min_progress");
    assert!(stays[0].1.starts_with("ego drove 0.0 m, 0 % of the logged ego's"), "{stays:?}");
    assert!(stays[0].1.ends_with("(at least 50 % asked), and nothing in its path stopped it"), "{stays:?}");
    // Where the logged ego stands still there is no route to measure along.
    assert_eq!(parked, "parked-ego");
    assert_eq!(unmeasurable.len(), 1, "{unmeasurable:?}");
    assert!(unmeasurable[0].1.starts_with("cannot be measured: the logged ego drives under 5 m"), "{unmeasurable:?}");
    // A planner that drives off passes in the free lane.
    let idm = failures_by_scenario("progress-idm.suite.yaml");
    assert_eq!(idm[0], ("free-lane".to_string(), vec![]), "{idm:?}");
}

#[test]
fn thirty_nine_m_per_s_in_a_25_m_per_s_zone_fails_no_speeding() {
    let [(limited, speeding), (unlimited, unmeasurable)] = &failures_by_scenario("speeding.suite.yaml")[..] else {
        panic!("two scenarios")
    };
    assert_eq!(limited, "speeding");
    assert_eq!(speeding.len(), 1, "{speeding:?}");
    assert_eq!(speeding[0].0, "no_speeding");
    assert!(speeding[0].1.contains("(25.0 m/s)") && speeding[0].1.ends_with("at up to 39.0 m/s"), "{speeding:?}");
    assert_eq!(unlimited, "speeding-unlimited");
    assert_eq!(unmeasurable.len(), 1, "{unmeasurable:?}");
    assert!(
        unmeasurable[0].1.starts_with("cannot be measured: the scene's map gives no lane a speed limit"),
        "{unmeasurable:?}"
    );
}
