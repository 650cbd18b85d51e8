//! The library runner a planner crate calls from its own test target: it
//! finds the crate's suites, runs an in-process planner registered by name,
//! writes artefacts under the crate's own folders, and reports a suite that
//! names an unregistered planner as a failing test.

use std::path::Path;

use libtest_mimic::Arguments;
use safer_scenarios::planners::{ConstantVelocityPlanner, IdmPlanner};
use safer_scenarios::runner::Runner;

/// A fresh "planner crate" root with one suite naming `planner`.
fn crate_root(name: &str, planner: &str) -> crate::scratch::Scratch {
    let root = crate::scratch::Scratch::new(&format!("runner-{name}"));
    std::fs::create_dir_all(root.join("specs/suites")).unwrap();
    let scenario = Path::new(repo_root!()).join("specs/scenarios/highway-overtake.yaml");
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

/// A crate root whose suite asks for a mutation score over the braking
/// faults and the late one, against the built-in evasive planner.
fn crate_with_mutation_score(name: &str, min: f64) -> crate::scratch::Scratch {
    let root = crate::scratch::Scratch::new(&format!("runner-{name}"));
    std::fs::create_dir_all(root.join("specs/suites")).unwrap();
    let scenario = Path::new(repo_root!()).join("specs/scenarios/highway-overtake.yaml");
    let suite = format!(
        "name: mutating\nscenarios:\n  - {}\nplanner: {{ builtin: evasive }}\nvariants: 1\n\
         acceptance:\n  variant: {{ no_collision: true, min_gap_m: 0.5 }}\n  \
         suite: {{ mutation_score_min: {min}, mutation_operators: [weak-brake, late, blind-side] }}\n",
        scenario.display()
    );
    std::fs::write(root.join("specs/suites/mine.yaml"), suite).unwrap();
    std::fs::create_dir_all(root.join("snapshots")).unwrap();
    root
}

#[test]
fn a_suite_asking_for_a_mutation_score_gets_one_test_that_passes_or_fails_by_it() {
    // weak-brake and late are killed on the overtake scene, blind-side
    // survives: 2/3. The two runs share the process, and so the variant.
    for (min, passes) in [(0.6, true), (0.7, false)] {
        let root = crate_with_mutation_score(&format!("mutation-{min}"), min);
        let runner = Runner::new(&*root);
        let names: Vec<String> = runner.trials().iter().map(|t| t.name().to_string()).collect();
        // Its own suite name: the runner shares variant outcomes in the
        // process by test name, and other tests here run suites named `mine`.
        assert_eq!(names, ["mutating::highway-overtake::seed-0", "mutating::mutation_score"]);
        let log =
            Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("runner-mutation-{min}-{}.log", std::process::id()));
        let args = Arguments {
            filter: Some("mutating::mutation_score".into()),
            exact: true,
            logfile: Some(log.display().to_string()),
            ..one_thread()
        };
        let conclusion = runner.run_with(&args);
        assert_eq!((conclusion.num_passed, conclusion.num_failed), (u64::from(passes), u64::from(!passes)), "{min}");
        if !passes {
            // The failing score leaves the review page, with the survivor named.
            let page = std::fs::read_to_string(root.join("target/safer-artifacts/review/index.html")).unwrap();
            assert!(page.contains("blind-side") && page.contains("SURVIVED"), "{page}");
        }
    }
}

#[test]
fn a_suite_without_a_mutation_score_has_no_mutation_test() {
    let root = crate_root("no-mutation", "runner-test-cv-2");
    let runner = Runner::new(&*root).planner("runner-test-cv-2", |_, _| ConstantVelocityPlanner);
    assert!(runner.trials().iter().all(|t| !t.name().contains("mutation")));
}

/// Panics in `plan` at its sixth call.
struct PanicsAtStep5(usize);

impl safer_scenarios::planners::Planner for PanicsAtStep5 {
    fn name(&self) -> &str {
        "boom"
    }
    fn plan(
        &mut self,
        o: &safer_scenarios::planners::Observation<'_>,
    ) -> Result<safer_scenarios::planners::PlannerOutput, safer_scenarios::planners::PlannerError> {
        self.0 += 1;
        assert!(self.0 <= 5, "boom");
        IdmPlanner::new(Default::default()).plan(o)
    }
}

/// A suite file `name.yaml` over the overtake scene naming `planner`.
fn add_suite(root: &Path, name: &str, planner: &str) {
    let scenario = Path::new(repo_root!()).join("specs/scenarios/highway-overtake.yaml");
    let suite = format!(
        "name: {name}\nscenarios:\n  - {}\nplanner: {{ rust: {planner} }}\nvariants: 1\n\
         acceptance:\n  variant: {{ no_collision: true }}\n",
        scenario.display()
    );
    std::fs::write(root.join(format!("specs/suites/{name}.yaml")), suite).unwrap();
}

#[test]
fn the_review_page_tells_the_verdicts_the_tests_gave_for_a_snapshot_diff_a_panic_and_a_collision() {
    let root = crate::scratch::Scratch::new("runner-one-verdict");
    std::fs::create_dir_all(root.join("specs/suites")).unwrap();
    std::fs::create_dir_all(root.join("snapshots")).unwrap();
    add_suite(&root, "diff", "runner-test-idm-diff");
    add_suite(&root, "boom", "runner-test-boom");
    add_suite(&root, "crash", "runner-test-cv-crash");
    // The IDM ego passes the overtake scene; its stored snapshot is stale.
    std::fs::write(
        root.join("snapshots/diff__highway-overtake__seed-0.snap"),
        "---\nsource: stale\n---\nstale: true\n",
    )
    .unwrap();
    let runner = Runner::new(&*root)
        .planner("runner-test-idm-diff", |_, _| IdmPlanner::new(Default::default()))
        .planner("runner-test-boom", |_, _| PanicsAtStep5(0))
        .planner("runner-test-cv-crash", |_, _| ConstantVelocityPlanner);
    let conclusion = runner.run_with(&one_thread());
    assert_eq!((conclusion.num_passed, conclusion.num_failed), (0, 3), "every test fails");
    let page = std::fs::read_to_string(root.join("target/safer-artifacts/review/index.html")).unwrap();
    assert!(page.contains("FAIL: 3 variants, 3 failed"), "the page agrees with the tests");
    assert!(page.contains("snapshot: the summary differs from its snapshot"), "the diff is named");
    assert!(page.contains("planner `boom` panicked: boom"), "the panic is the variant's failure");
    // The panicking variant has its recording and picture, as a crashed process's has.
    for file in ["seed-0.mcap", "seed-0.svg"] {
        let path = root.join("target/safer-artifacts/boom/highway-overtake").join(file);
        assert!(path.is_file(), "{} missing", path.display());
    }
}

/// A suite whose spec warns runs, unless the runner denies warnings
/// (`SAFER_DENY_WARNINGS`): then it is one failing `SUITE::load` test,
/// whose output (all cargo-nextest shows of a run) holds the warnings.
#[test]
fn denied_spec_warnings_make_the_suite_one_failing_load_test() {
    let root = crate::scratch::Scratch::new("runner-deny-warnings");
    std::fs::create_dir_all(root.join("specs/suites")).unwrap();
    let scenes = Path::new(repo_root!()).join("scenes/ngsim");
    let suite = format!("name: replay\nscenarios:\n  - recorded: {}\nplanner: {{ builtin: idm }}\n", scenes.display());
    std::fs::write(root.join("specs/suites/replay.yaml"), suite).unwrap();
    let names = |runner: &Runner| -> Vec<String> { runner.trials().iter().map(|t| t.name().to_string()).collect() };
    let warned = Runner::new(&*root).deny_warnings(false);
    let variants = names(&warned);
    assert!(
        !variants.is_empty() && variants.iter().all(|n| n.starts_with("replay::") && n.contains("::seed-")),
        "{variants:?}"
    );
    let denied = Runner::new(&*root).deny_warnings(true);
    assert_eq!(names(&denied), ["replay::load"]);
    let log = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("runner-deny-{}.log", std::process::id()));
    let args = Arguments {
        test_threads: Some(1),
        quiet: true,
        logfile: Some(log.display().to_string()),
        ..Arguments::default()
    };
    let conclusion = denied.run_with(&args);
    assert_eq!((conclusion.num_passed, conclusion.num_failed), (0, 1));
    // The failure's message, as libtest (and nextest) shows it.
    let shown = std::fs::read_to_string(&log).unwrap();
    assert!(shown.contains("replay::load"), "{shown}");
    assert_eq!(shown.matches("warning: ").count(), 2, "{shown}");
    assert!(shown.contains("error: 2 spec warnings denied"), "{shown}");
}
