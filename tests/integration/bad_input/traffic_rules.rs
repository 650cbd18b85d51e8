//! Traffic rules a planner must keep: an ego driving 3 s against the
//! traffic of the oncoming lane passed every criterion before
//! `no_wrong_way`; an ego that runs a red light passed before
//! `no_red_light`. Fixtures: `tests/fixtures/bad-input/traffic-rules/`.

use std::path::{Path, PathBuf};

use safer::harness::{Suite, run_variant};

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
