//! The library runner a planner crate calls from its own test target: it
//! finds the crate's suites, runs an in-process planner registered by name,
//! writes artefacts under the crate's own folders, and reports a suite that
//! names an unregistered planner as a failing test.

use std::path::Path;

use libtest_mimic::Arguments;
use safer::planners::{ConstantVelocityPlanner, IdmPlanner};
use safer::runner::Runner;

/// A fresh "planner crate" root with one suite naming `planner`.
fn crate_root(name: &str, planner: &str) -> crate::scratch::Scratch {
    let root = crate::scratch::Scratch::new(&format!("runner-{name}"));
    std::fs::create_dir_all(root.join("specs/suites")).unwrap();
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("specs/scenarios/highway-overtake.yaml");
    let suite = format!(
        "name: mine\nscenarios:\n  - {}\nplanner: {{ rust: {planner} }}\nvariants: 1\n\
         acceptance:\n  variant: {{ no_collision: true, min_gap_m: 0.5 }}\n",
        scenario.display()
    );
    std::fs::write(root.join("specs/suites/mine.yaml"), suite).unwrap();
    root
}

/// One thread, and the inner runner's report in a log file, so that its
/// "test result: FAILED" lines do not mix with this test binary's output.
fn one_thread() -> Arguments {
    let log = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("runner-{}.log", std::process::id()));
    Arguments { test_threads: Some(1), quiet: true, logfile: Some(log.display().to_string()), ..Arguments::default() }
}

#[test]
fn a_registered_planner_runs_and_its_failure_leaves_artefacts_in_the_crates_own_target() {
    let root = crate_root("failing", "runner-test-cv");
    let runner = Runner::new(&*root).planner("runner-test-cv", |_, _| ConstantVelocityPlanner);
    let names: Vec<String> = runner.trials().iter().map(|t| t.name().to_string()).collect();
    assert_eq!(names, ["mine::highway-overtake::seed-0"]);
    let conclusion = runner.run_with(&one_thread());
    // Constant velocity rear-ends the slow leader of the authored overtake scene.
    assert_eq!((conclusion.num_passed, conclusion.num_failed), (0, 1));
    let artefacts = root.join("target/safer-artifacts/mine/highway-overtake");
    for file in ["seed-0.mcap", "seed-0.svg"] {
        assert!(artefacts.join(file).is_file(), "{} missing", artefacts.join(file).display());
    }
    // A failing run leaves the review page of what it ran beside them.
    let page = std::fs::read_to_string(root.join("target/safer-artifacts/review/index.html")).unwrap();
    assert!(page.contains("mine::highway-overtake::seed-0") || page.contains("highway-overtake"), "{page}");
}

#[test]
fn a_suite_naming_an_unregistered_planner_is_one_failing_test_and_listing_it_says_why() {
    let root = crate_root("unregistered", "runner-test-nobody");
    let runner = Runner::new(&*root).planner("runner-test-idm", |_, _| IdmPlanner::new(Default::default()));
    let names: Vec<String> = runner.trials().iter().map(|t| t.name().to_string()).collect();
    assert_eq!(names, ["mine::load"]);
    let conclusion = runner.run_with(&one_thread());
    assert_eq!((conclusion.num_passed, conclusion.num_failed), (0, 1));
}

#[test]
fn registering_two_planners_under_one_name_is_a_failing_test_not_a_panic() {
    let root = crate_root("duplicate", "runner-test-twice");
    let runner = Runner::new(&*root)
        .planner("runner-test-twice", |_, _| ConstantVelocityPlanner)
        .planner("runner-test-twice", |_, _| ConstantVelocityPlanner);
    let names: Vec<String> = runner.trials().iter().map(|t| t.name().to_string()).collect();
    assert!(names.contains(&"runner::planner-0".to_string()), "{names:?}");
}

#[test]
fn a_crate_without_suites_fails_instead_of_passing_zero_tests() {
    let root = crate::scratch::Scratch::new("runner-empty");
    let conclusion = Runner::new(&*root).run_with(&one_thread());
    assert_eq!((conclusion.num_passed, conclusion.num_failed), (0, 1));
}
