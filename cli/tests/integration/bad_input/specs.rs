//! Bad input: broken specs. Every case is refused when the spec loads,
//! before anything runs, with the file, the line and column of the
//! offending value, and what is wrong. Fixtures are in
//! `tests/fixtures/bad-input/specs/`, one per case, named for what they show.

use std::path::{Path, PathBuf};
use std::time::Duration;

use safer_scenarios::harness::Suite;
use safer_scenarios::spec::planner::PlannerSpec;
use safer_scenarios::spec::scenario::ScenarioSpec;
use safer_scenarios::spec::{SpecError, load_yaml};

fn fixture(name: &str) -> PathBuf {
    Path::new(repo_root!()).join("tests/fixtures/bad-input/specs").join(name)
}

/// Loads a fixture the way the runner does, for its kind.
fn load_error(name: &str) -> SpecError {
    let path = fixture(name);
    let result = if name.ends_with(".suite.yaml") {
        Suite::load(&path).map(|_| ())
    } else if name.ends_with(".scenario.yaml") {
        load_yaml::<ScenarioSpec>(&path).and_then(|s| s.build()).map(|_| ())
    } else {
        load_yaml::<PlannerSpec>(&path).and_then(|s| s.validate()).map(|_| ())
    };
    match result {
        Ok(()) => panic!("{name} loaded; it must be refused"),
        Err(e) => e,
    }
}

/// (fixture, line, column of the offending value, words the message must hold)
const CASES: &[(&str, u64, u64, &str)] = &[
    ("min-gap-nan.suite.yaml", 7, 45, "`min_gap_m` must be a number in [0, 100] m, got NaN"),
    ("min-ttc-nan.suite.yaml", 8, 16, "`min_ttc_s` must be a number in [0, 60] s, got NaN"),
    ("min-gap-negative.suite.yaml", 7, 25, "`min_gap_m` must be a number in [0, 100] m, got -5"),
    ("jsd-bound-nan.suite.yaml", 9, 30, "`velocity_jsd_max` must be a number in [0, 1]"),
    ("jsd-bound-negative.suite.yaml", 10, 27, "`acceleration_jsd_max` must be a number in [0, 1]"),
    ("solution-rate-above-one.suite.yaml", 7, 31, "`solution_rate_min` must be a number in [0, 1]"),
    ("recorded-entry-typo-limt.suite.yaml", 5, 5, "unknown key `limt` in scenarios[0]"),
    (
        "unknown-builtin-idmm.suite.yaml",
        5,
        21,
        "unknown built-in planner `idmm`; the built-ins are log-replay, constant-velocity, idm, evasive",
    ),
    ("suite-named-dotdot.suite.yaml", 2, 7, "name `..` cannot be used in test names and artefact paths"),
    ("log-method-two-variants.suite.yaml", 7, 11, "every seed gives the same variant"),
    ("log-method-jsd-bound.suite.yaml", 8, 30, "compares the log with itself"),
    ("variants-zero.suite.yaml", 6, 11, "variants must be 1..=1000, got 0"),
    ("missing-scenario-file.suite.yaml", 4, 5, "no-such-scenario.yaml does not exist"),
    ("planner-must-answer-false.suite.yaml", 7, 35, "`planner_must_answer: false` is not allowed"),
    (
        "at-fault-beside-no-collision.suite.yaml",
        7,
        37,
        "`no_at_fault_collision: true` has no effect while `no_collision` is true",
    ),
    ("shrink-budget-huge.suite.yaml", 6, 19, "shrink.budget must be 0..=10000 candidate rollouts, got 100000"),
    ("duplicate-key.suite.yaml", 7, 1, "key `variants` appears twice in the same mapping (first at line 6)"),
    ("two-documents.suite.yaml", 7, 1, "a spec file holds one YAML document"),
    ("length-negative.scenario.yaml", 8, 61, "`length_m` must be a number in (0, 30] m, got -4"),
    ("length-zero.scenario.yaml", 8, 61, "`length_m` must be a number in (0, 30] m, got 0"),
    ("length-nan.scenario.yaml", 12, 15, "`length_m` must be a number in (0, 30] m, got NaN"),
    ("length-1e300.scenario.yaml", 8, 61, "`length_m` must be a number in (0, 30] m, got 1e300"),
    ("safer-path-leaves-the-crate.suite.yaml", 4, 5, "`safer:../../../../etc/passwd` leaves the folder `safer:` names"),
    ("data-path-leaves-the-data-folder.suite.yaml", 4, 15, "`data:../../..` leaves the folder `data:` names"),
    ("safer-path-missing.suite.yaml", 4, 5, "(`safer:` names a file safer ships: under scenes/, planners/ or specs/)"),
    ("min-progress-above-one.suite.yaml", 7, 28, "`min_progress` must be a number in (0, 1] (a share), got 1.5"),
    ("desired-speed-nan.scenario.yaml", 8, 70, "`desired_speed_mps` must be a number in (0, 70] m/s, got NaN"),
    ("desired-speed-negative.scenario.yaml", 8, 70, "`desired_speed_mps` must be a number in (0, 70] m/s, got -3"),
    ("ego-s-nan.scenario.yaml", 7, 30, "`s_m` must be a number in [0, 100000] m, got NaN"),
    ("agent-at-nan.scenario.yaml", 8, 23, "`x_m` must be a number in [-100000, 100000] m, got NaN"),
    ("duration-0.01.scenario.yaml", 3, 13, "`duration_s` must be a number in [0.1, 60] s, got 0.01"),
    ("step-timeout-huge.planner.yaml", 5, 20, "`step_timeout_ms` must be 1..=600000 ms"),
    ("idm-1e300.planner.yaml", 5, 19, "`idm.max_accel_mps2` must be a number in (0, 10], got 1e300"),
    ("working-dir-missing.planner.yaml", 5, 16, "no-such-folder does not exist"),
    ("startup-timeout-zero.planner.yaml", 5, 23, "`startup_timeout_ms` must be 1..=600000 ms (10 min), got 0"),
    ("scenario-named-dotdot.scenario.yaml", 2, 7, "name `..` cannot be used in test names and artefact paths"),
    ("template-length-nan.scenario.yaml", 7, 15, "map: length_m must be in 30..=5000, got NaN"),
    ("unknown-lane.scenario.yaml", 7, 22, "agent `ego`: no lane 5 in this map; lanes are 0, 1"),
    ("recorded-limit-zero.suite.yaml", 5, 12, "`limit` must be at least 1"),
    ("missing-planner-file.suite.yaml", 5, 10, "no-such-planner.yaml does not exist"),
    ("duplicate-scenario-name.suite.yaml", 5, 5, "two scenarios are named `highway-overtake`"),
    ("no-scenarios.suite.yaml", 3, 12, "`scenarios:` lists no scenario; a suite that runs nothing cannot pass"),
    ("variants-negative.suite.yaml", 6, 11, "expected a whole number from 0 to 4294967295 here"),
    ("recorded-limit-negative.suite.yaml", 5, 12, "`limit` must be a whole number of scenes, at least 1, got -3"),
    (
        "planner-is-a-number.suite.yaml",
        5,
        10,
        "`planner:` takes a planner spec file (a path), `builtin: NAME` or `rust: NAME`",
    ),
    ("ego-overlaps-the-car-ahead.scenario.yaml", 9, 11, "agents `ego` and `lead` overlap at the start"),
    ("latin-1.suite.yaml", 1, 33, "not UTF-8 text: byte 0xe9 at offset 32"),
];

/// Fixtures asserted by their own tests below (not through [`CASES`]).
const OTHER_FIXTURES: &[&str] = &[
    "lists-a-broken-scenario.suite.yaml",
    "recorded-not-a-log.suite.yaml",
    "lists-a-scenario-without-cbv.suite.yaml",
    "without-cbv.scenario.yaml",
];

#[test]
fn every_broken_spec_is_refused_at_its_value_with_what_is_wrong() {
    let mut wrong = Vec::new();
    for &(name, line, column, words) in CASES {
        let message = load_error(name).to_string();
        let place = format!("{}:{line}:{column}: ", fixture(name).display());
        if !message.starts_with(&place) || !message.contains(words) {
            wrong.push(format!("{name}\n  expected {place}… {words}\n  got      {message}"));
        }
    }
    assert!(wrong.is_empty(), "{} of {} cases:\n{}", wrong.len(), CASES.len(), wrong.join("\n"));
}

#[test]
fn every_fixture_in_the_folder_is_a_case() {
    // A fixture nobody asserts on would show nothing.
    let mut files: Vec<String> = std::fs::read_dir(fixture(""))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".yaml"))
        .collect();
    files.sort();
    let mut cases: Vec<String> =
        CASES.iter().map(|c| c.0.to_string()).chain(OTHER_FIXTURES.iter().map(|n| n.to_string())).collect();
    cases.sort();
    assert_eq!(files, cases);
}

#[test]
fn safer_run_refuses_broken_suites_with_exit_2_and_the_located_message() {
    let scratch = crate::scratch::Scratch::new("bad-specs");
    let artefacts = scratch.join("artefacts");
    let suites = CASES.iter().filter(|c| c.0.ends_with(".suite.yaml"));
    let mut wrong = Vec::new();
    for &(name, line, column, words) in suites {
        let file = fixture(name);
        let args = ["run", file.to_str().unwrap(), "--artifacts", artefacts.to_str().unwrap()];
        let out = super::binary::safer_within(&args, Duration::from_secs(60));
        let stderr = String::from_utf8_lossy(&out.stderr);
        let place = format!("{name}:{line}:{column}");
        // The report may wrap the message (with a `│` margin): compare without layout.
        let flat = |t: &str| t.chars().filter(|c| !c.is_whitespace() && *c != '│').collect::<String>();
        if out.status.code() != Some(2) || !stderr.contains(&place) || !flat(&stderr).contains(&flat(words)) {
            wrong.push(format!("{name}: exit {:?}, expected {place} … {words}\n{stderr}", out.status.code()));
        }
    }
    // Refused before anything ran: no artefact written.
    assert!(!artefacts.exists(), "{} was written", artefacts.display());
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn a_suite_refuses_a_broken_scenario_when_it_loads_not_when_the_variant_runs() {
    let e = load_error("lists-a-broken-scenario.suite.yaml").to_string();
    let place = format!("{}:12:15: ", fixture("length-nan.scenario.yaml").display());
    assert!(e.starts_with(&place), "{e}");
    assert!(e.contains("`length_m` must be a number in (0, 30] m, got NaN"), "{e}");
}

#[test]
fn a_suite_refuses_an_authored_scenario_without_a_cbv_when_it_loads() {
    // The scene itself is valid (it renders); only a suite needs a CBV.
    load_yaml::<ScenarioSpec>(&fixture("without-cbv.scenario.yaml")).unwrap().build().unwrap();
    let e = load_error("lists-a-scenario-without-cbv.suite.yaml").to_string();
    let place = format!("{}:9:6: ", fixture("without-cbv.scenario.yaml").display());
    assert!(e.starts_with(&place), "{e}");
    assert!(e.contains("no `cbv:`: a suite drives the scenario's critical background vehicle"), "{e}");
}

#[test]
fn a_recorded_log_that_does_not_import_is_reported_at_its_suite_entry() {
    let path = fixture("recorded-not-a-log.suite.yaml");
    let suite = Suite::load(&path).expect("listing does not import");
    let e = suite.scenarios[0].load().expect_err("not a log").to_string();
    let place = format!("{}:5:5: recorded log ", path.display());
    assert!(e.starts_with(&place), "{e}");
    assert!(e.contains("not-a-log.json does not import"), "{e}");
}

/// `safer run s.yaml` from the suite's own folder: the spec's folder is `.`,
/// not the empty path that once made an external planner fail to start.
#[test]
fn a_suite_given_by_a_bare_file_name_runs_its_external_planner_in_that_folder() {
    let dir = crate::scratch::Scratch::new("bare-name");
    let repo = Path::new(repo_root!());
    std::fs::copy(repo.join("planners/example_planner.py"), dir.join("example_planner.py")).unwrap();
    let files = [
        ("p.yaml", "name: py\nexternal:\n  command: python3\n  args: [example_planner.py]\n  step_timeout_ms: 5000\n"),
        (
            "road.yaml",
            "name: road\nduration_s: 1\nmap:\n  straight: { lanes: 1, length_m: 200 }\n\
             agents:\n  - { id: ego, lane: 0, s_m: 20, speed_mps: 10 }\n  - { id: lead, lane: 0, s_m: 80, speed_mps: 10 }\n\
             ego: ego\ncbv: lead\n",
        ),
        ("s.yaml", "name: bare\nscenarios: [road.yaml]\nplanner: p.yaml\n"),
    ];
    for (name, text) in files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    let out =
        // The planner imports safer's Python planner kit, found on PYTHONPATH.
        super::binary::safer_in(
            &dir,
            &[("PYTHONPATH", &repo.join("python"))],
            &["run", "s.yaml", "--artifacts", "artefacts"],
            Duration::from_secs(60),
        );
    std::fs::remove_dir_all(&dir).ok();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(text.contains("bare::road::seed-0") && !text.contains("No such file"), "{text}");
}
