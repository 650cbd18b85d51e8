//! Failure shrinking in `safer run`: each failing variant comes with the
//! smallest deviation from the logged CBV that fails the same way, no larger
//! than the variant, found within the budget, the same on every run; its
//! recording and picture are shown first, the variant as made beside them;
//! `--no-shrink` turns it off. A time limit stops the search and says so,
//! never changing the verdict; every failed criterion shrinks, not only
//! collisions.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

fn run(args: &[&str], json: &Path) -> Value {
    let suite = Path::new(repo_root!()).join("tests/fixtures/shrink/constant-velocity-under-safer.yaml");
    let out = Command::new(env!("CARGO_BIN_EXE_safer"))
        .arg("run")
        .arg(&suite)
        .args(args)
        .arg("--json")
        .arg(json)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "some variants fail: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}

/// Each failing variant's summary.
fn failing(report: &Value) -> Vec<Value> {
    let text = report.to_string();
    let mut found = Vec::new();
    fn walk(v: &Value, found: &mut Vec<Value>) {
        match v {
            Value::Object(m) => {
                if m.get("passed") == Some(&Value::Bool(false)) && m.contains_key("shrunk") {
                    found.push(v.clone());
                }
                m.values().for_each(|x| walk(x, found));
            }
            Value::Array(a) => a.iter().for_each(|x| walk(x, found)),
            _ => {}
        }
    }
    walk(report, &mut found);
    assert!(!found.is_empty(), "no failing variant in {text}");
    found
}

#[test]
fn failing_variants_are_shrunk_deterministically_within_the_budget() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("shrink");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let artefacts: PathBuf = dir.join("artefacts");
    let first = run(&["--artifacts", artefacts.to_str().unwrap()], &dir.join("a.json"));
    let variants = failing(&first);
    let mut shrunk_some = false;
    for v in &variants {
        let s = &v["shrunk"];
        assert!(s.is_object(), "every failing variant here is shrunk: {v}");
        let tokens = s["adversarial_tokens"].as_array().unwrap();
        let (before, after) = (tokens[0].as_u64().unwrap(), tokens[1].as_u64().unwrap());
        assert!(after <= before, "{v}");
        shrunk_some |= after < before;
        assert!(s["candidates"].as_u64().unwrap() <= 16, "{v}");
        // The same way: the shrunk variant's first failure is the variant's criterion.
        let criterion = |text: &str| text.split(':').next().unwrap_or_default().to_string();
        assert_eq!(criterion(s["failure"].as_str().unwrap()), criterion(v["failures"][0].as_str().unwrap()));
        let name = v["variant"].as_str().unwrap().replace("::", "/");
        for suffix in ["mcap", "svg", "unshrunk.mcap", "unshrunk.svg"] {
            let f = artefacts.join(format!("{name}.{suffix}"));
            assert!(f.is_file(), "{} missing", f.display());
        }
    }
    assert!(shrunk_some, "no variant lost an adversarial token: {variants:?}");
    // Deterministic.
    let again = failing(&run(&[], &dir.join("b.json")));
    assert_eq!(
        again.iter().map(|v| v["shrunk"].clone()).collect::<Vec<_>>(),
        variants.iter().map(|v| v["shrunk"].clone()).collect::<Vec<_>>()
    );
    // Bounded, and off when asked.
    for v in failing(&run(&["--shrink-budget", "2"], &dir.join("c.json"))) {
        assert!(v["shrunk"].is_null() || v["shrunk"]["candidates"].as_u64().unwrap() <= 2, "{v}");
    }
    for v in failing(&run(&["--no-shrink"], &dir.join("d.json"))) {
        assert!(v["shrunk"].is_null(), "{v}");
    }
}

/// `safer run SUITE --json` of a suite file anywhere; the report and the table.
fn run_suite(suite: &Path, args: &[&str], json: &Path) -> (Value, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_safer"))
        .arg("run")
        .arg(suite)
        .args(args)
        .arg("--json")
        .arg(json)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "some variants fail: {}", String::from_utf8_lossy(&out.stderr));
    (serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap(), String::from_utf8(out.stdout).unwrap())
}

#[test]
fn a_time_limit_stops_the_search_says_so_and_leaves_the_verdict_alone() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("shrink-time-limit");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let fixture = Path::new(repo_root!()).join("tests/fixtures/shrink/constant-velocity-under-safer.yaml");
    // The suite's own bounds: a time limit too short for a second candidate.
    let text = std::fs::read_to_string(&fixture).unwrap();
    let bounded = dir.join("bounded.yaml");
    std::fs::write(&bounded, format!("{text}shrink: {{ budget: 16, time_limit_s: 0.001 }}\n")).unwrap();
    let (unbounded, _) = run_suite(&fixture, &[], &dir.join("a.json"));
    let (report, table) = run_suite(&bounded, &[], &dir.join("b.json"));
    let verdicts =
        |r: &Value| failing(r).iter().map(|v| (v["variant"].clone(), v["failures"].clone())).collect::<Vec<_>>();
    let names = |r: &Value| {
        failing(r)
            .iter()
            .map(|v| v["variant"].as_str().unwrap().split_once("::").unwrap().1.to_string())
            .collect::<Vec<_>>()
    };
    // The same variants fail the same criteria, however far the shrink got.
    assert_eq!(names(&report), names(&unbounded));
    assert_eq!(
        verdicts(&report).iter().map(|v| v.1.clone()).collect::<Vec<_>>(),
        verdicts(&unbounded).iter().map(|v| v.1.clone()).collect::<Vec<_>>()
    );
    for v in failing(&report) {
        let s = &v["shrunk"];
        if s.is_null() {
            assert!(v["not_shrunk"].is_string(), "a variant not shrunk says why: {v}");
            continue;
        }
        assert_eq!(s["stopped"], "time_limit", "{v}");
        assert_eq!(s["candidates"], 1, "only the variant's own script: {v}");
        assert_eq!(s["adversarial_tokens"][0], s["adversarial_tokens"][1], "{v}");
    }
    assert!(
        table.contains("stopped at its time limit after 1 candidate: another machine may shrink further"),
        "{table}"
    );
    // The command line overrides the suite: a budget of 2 rollouts, no time limit.
    let (report, _) = run_suite(&bounded, &["--shrink-budget", "2", "--shrink-time-limit", "600"], &dir.join("c.json"));
    for v in failing(&report) {
        let s = &v["shrunk"];
        assert!(s.is_null() || s["candidates"].as_u64().unwrap() <= 2, "{v}");
        assert!(s.is_null() || s["stopped"] != "time_limit", "{v}");
    }
    // Bad bounds are refused, in the spec and on the command line.
    std::fs::write(dir.join("zero.yaml"), format!("{text}shrink: {{ time_limit_s: 0 }}\n")).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_safer")).arg("run").arg(dir.join("zero.yaml")).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("`time_limit_s` must be a number in (0, 86400] s, got 0"), "{stderr}");
    let out = Command::new(env!("CARGO_BIN_EXE_safer"))
        .args(["run", fixture.to_str().unwrap(), "--shrink-time-limit", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected seconds above 0"));
}

#[test]
fn a_variant_that_leaves_the_road_is_shrunk_like_one_that_collides() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("shrink-off-road");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let suite = Path::new(repo_root!()).join("tests/fixtures/shrink/off-road-under-safer.yaml");
    let (report, table) = run_suite(&suite, &[], &dir.join("a.json"));
    let variants = failing(&report);
    for v in &variants {
        assert!(v["failures"][0].as_str().unwrap().starts_with("no_off_road: "), "{v}");
        let s = &v["shrunk"];
        assert!(s.is_object(), "an off-road failure is shrunk: {v}\n{table}");
        assert!(s["failure"].as_str().unwrap().starts_with("no_off_road: "), "{v}");
        let tokens = s["adversarial_tokens"].as_array().unwrap();
        assert!(tokens[1].as_u64() <= tokens[0].as_u64(), "{v}");
    }
    // A variant whose collision was excused (no escape: the generator's
    // fault) fails on the gap; its candidates are judged the same way, so
    // it is shrunk too instead of every candidate failing by the collision.
    let suite = Path::new(repo_root!()).join("tests/fixtures/shrink/excused-collision-under-safer.yaml");
    let (report, table) = run_suite(&suite, &[], &dir.join("b.json"));
    for v in &failing(&report) {
        assert!(v["failures"][0].as_str().unwrap().starts_with("min_gap_m: "), "{v}");
        assert!(v["shrunk"].is_object(), "shrunk judged as the variant was: {v}\n{table}");
        assert!(v["shrunk"]["failure"].as_str().unwrap().starts_with("min_gap_m: "), "{v}");
    }
}
