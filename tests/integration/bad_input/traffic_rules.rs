//! Traffic rules a planner must keep: an ego driving 3 s against the
//! traffic of the oncoming lane passed every criterion before
//! `no_wrong_way`; an ego that runs a red light passed before
//! `no_red_light`. Fixtures: `tests/fixtures/bad-input/traffic-rules/`.

use std::path::{Path, PathBuf};

use safer::geometry::Polyline;
use safer::harness::acceptance;
use safer::harness::{Suite, run_variant};
use safer::map::RoadMap;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/bad-input/traffic-rules").join(name)
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
    assert!(failed[0].1.starts_with("ego passed the stop line of lane 10 on Stop at t = 1."), "{failed:?}");
    assert_eq!(failures("red-light-idm.suite.yaml"), []);
}

/// The wrong-way scene's stage 2, judged by `no_wrong_way` on its map with
/// every lane centreline replaced by `cut(centreline)`.
fn wrong_way_on_cut_lanes(cut: impl Fn(&Polyline) -> Polyline) -> Vec<String> {
    let suite = Suite::load(&fixture("wrong-way.suite.yaml")).unwrap_or_else(|e| panic!("{e}"));
    let outcome = run_variant(&suite, &suite.scenarios[0], 0).unwrap_or_else(|e| panic!("{e}"));
    let m = &outcome.scenario.map;
    let lanes = m.lanes.iter().map(|l| safer::map::Lane { centreline: cut(&l.centreline), ..l.clone() }).collect();
    let map = RoadMap::new(
        lanes,
        m.road_edges.clone(),
        m.road_lines.clone(),
        m.areas.clone(),
        m.drivable_areas.clone(),
        m.stop_signs.clone(),
        m.traffic_signals.clone(),
    );
    let criteria = safer::spec::suite::VariantAcceptance { no_wrong_way: true, ..Default::default() };
    acceptance::check(&criteria, &outcome.stage2, &map, None, None).into_iter().map(|f| f.what).collect()
}

#[test]
fn lanes_cut_to_a_point_or_to_zero_length_leave_no_wrong_way_unmeasurable() {
    let intact = wrong_way_on_cut_lanes(Polyline::clone);
    assert_eq!(intact, ["ego drove against the traffic of lane 100 for 3.1 s from t = 0.0 s"]);
    let unmeasurable = "cannot be measured: the scene's map has no lane (of at least 1 m) to tell the traffic's direction";
    let one_point = wrong_way_on_cut_lanes(|c| Polyline::new(c.points()[..1].to_vec()));
    assert_eq!(one_point, [unmeasurable]);
    let zero_length = wrong_way_on_cut_lanes(|c| Polyline::new(vec![c.points()[0]; 2]));
    assert_eq!(zero_length, [unmeasurable]);
}
