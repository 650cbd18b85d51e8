//! A suite that requires kinds of conflict: it passes when its variants
//! make them with the planner's ego and fails naming the kind that is
//! short; a requirement that asks nothing, or names no kind, is refused.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn safer(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_safer")).args(args).output().expect("run safer")
}

/// A suite over the authored scene with the CBV closing from behind in
/// the next lane (SaFeR variants with the distinct-behaviour trust region,
/// whose CBV cuts in; the evasive planner), requiring `coverage`.
fn suite(name: &str, coverage: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("conflict-coverage");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = Path::new(repo_root!()).join("tests/fixtures/closed_loop/cbv-behind-in-the-next-lane.yaml");
    let path = dir.join(format!("{name}.yaml"));
    std::fs::write(
        &path,
        format!(
            "name: {name}\nscenarios:\n  - {}\nplanner: {{ builtin: evasive }}\nadversary: {{ method: safer-distinct }}\n\
             variants: 4\nacceptance:\n  variant: {{ no_collision: false }}\n  suite: {{ conflict_coverage_min: {coverage} }}\n",
            scene.display()
        ),
    )
    .unwrap();
    path
}

#[test]
fn a_suite_fails_naming_the_kind_of_conflict_it_lacks() {
    let json = Path::new(env!("CARGO_TARGET_TMPDIR")).join("conflict-coverage/report.json");
    let met = suite("met", "{ rear-end: 1 }");
    let out = safer(&["run", met.to_str().unwrap(), "--json", json.to_str().unwrap()]);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{table}{}", String::from_utf8_lossy(&out.stderr));
    assert!(table.contains("conflict coverage") && table.contains("met::conflict_coverage"), "{table}");
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let text = report.to_string();
    assert!(text.contains("\"conflict\":\"rear-end\"") && text.contains("\"coverage\""), "{text}");

    let short = suite("short", "{ rear-end: 1, head-on: 2 }");
    let out = safer(&["run", short.to_str().unwrap()]);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(!out.status.success(), "{table}");
    assert!(table.contains("conflict coverage short: head-on 0 < 2"), "{table}");
}

#[test]
fn a_coverage_requirement_must_ask_for_something_real() {
    for (coverage, message) in [
        ("{}", "names no kind of conflict"),
        ("{ crossing: 0 }", "`crossing: 0` requires nothing"),
        ("{ crosing: 1 }", "crosing"),
    ] {
        let path = suite("bad", coverage);
        let out = safer(&["run", path.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(message), "{coverage}: {err}");
        assert!(err.contains("conflict_coverage_min"), "{coverage}: {err}");
    }
}
