//! `safer run`, `safer schema` and `safer render` end to end, through the
//! real binary; and the committed JSON Schemas under `schemas/` kept equal
//! to what the spec types export.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicU32, Ordering};

use safer::spec::{SpecKind, json_schema};

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Runs the binary from the repository root, so shipped spec paths are relative as a user types them.
fn safer(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_safer")).args(args).current_dir(repo()).output().expect("run safer")
}

/// A fresh folder per test (tests run in parallel and share the process id).
fn temp_dir(tag: &str) -> PathBuf {
    static NEXT: AtomicU32 = AtomicU32::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("safer-cli-run-{tag}-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create temp dir");
    dir
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn run_authored_suite_passes_and_writes_the_json_report() {
    let dir = temp_dir("authored");
    let json = dir.join("report.json");
    let out = safer(&["run", "specs/suites/authored.yaml", "--json", json.to_str().unwrap()]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}\n{}", text(&out.stderr));
    assert!(stdout.contains("authored::highway-overtake::seed-0") && stdout.contains("PASS"), "{stdout}");

    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).expect("report written")).unwrap();
    assert_eq!(v["passed"], true);
    let suite = &v["suites"][0];
    assert_eq!(suite["name"], "authored");
    let variants = suite["variants"].as_array().expect("variants");
    assert_eq!(variants.len(), 3, "{suite:#}"); // one per scene: `method: log` samples nothing
    assert!(variants.iter().all(|x| x["passed"] == true && x["failures"].as_array().is_some_and(Vec::is_empty)));
    // Sorted by name, whatever order rayon finished them in.
    let names: Vec<&str> = variants.iter().filter_map(|x| x["variant"].as_str()).collect();
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(names, sorted);
    assert_eq!(suite["metrics"]["solution_rate"], 1.0);
    let check = suite["checks"].as_array().unwrap().iter().find(|c| c["name"] == "solution_rate").expect("check");
    assert_eq!(check["passed"], true);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn run_reports_a_typo_with_file_line_and_field_and_exits_2() {
    let dir = temp_dir("typo");
    let suite = dir.join("typo.yaml");
    let scenarios = repo().join("specs/scenarios/*.yaml");
    std::fs::write(
        &suite,
        format!(
            "name: typo\nscenarios:\n  - glob: {}\nplanner: {{ builtin: idm }}\nvariantz: 2\n",
            scenarios.display()
        ),
    )
    .unwrap();
    // A good suite next to it still runs.
    let out = safer(&["run", suite.to_str().unwrap(), "specs/suites/authored.yaml"]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("typo.yaml"), "{stderr}");
    assert!(stderr.contains("variantz"), "{stderr}");
    assert!(stderr.contains("line 5") || stderr.contains("typo.yaml:5:"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(text(&out.stdout).contains("authored::on-ramp-merge::seed-0"), "{}", text(&out.stdout));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn run_failing_planner_exits_1_and_leaves_artefacts() {
    let dir = temp_dir("failing");
    let suite = dir.join("cv.yaml");
    let scenario = repo().join("specs/scenarios/highway-overtake.yaml");
    // Constant velocity closes on the slower leader: it hits it or comes within a few seconds
    // of it, so it fails one of the two criteria whatever the leader's exact behaviour.
    std::fs::write(
        &suite,
        format!(
            "name: cv\nscenarios:\n  - {}\nplanner: {{ builtin: constant-velocity }}\n\
             acceptance:\n  variant: {{ no_collision: true, min_ttc_s: 4.0 }}\n",
            scenario.display()
        ),
    )
    .unwrap();
    let artefacts = dir.join("artefacts");
    let json = dir.join("report.json");
    let out = safer(&[
        "run",
        suite.to_str().unwrap(),
        "--artifacts",
        artefacts.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{}", text(&out.stderr));
    assert!(stdout.contains("cv::highway-overtake::seed-0") && stdout.contains("FAIL"), "{stdout}");
    let base = artefacts.join("cv/highway-overtake/seed-0");
    for ext in ["mcap", "svg"] {
        let p = base.with_extension(ext);
        assert!(p.is_file(), "{} missing\n{stdout}", p.display());
        assert!(stdout.contains(&p.display().to_string()), "{stdout}");
    }
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(v["passed"], false);
    assert_eq!(v["suites"][0]["variants"][0]["passed"], false);
    assert!(v["suites"][0]["variants"][0]["artefacts"]["mcap"].is_string());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_passing_variant_with_an_allowed_collision_says_it_collided_and_is_not_solved() {
    // recorded-regression allows collisions that are not the ego's fault
    // (logged followers cannot react); on USA_Peach-4_2_T-1 the IDM ego is
    // rear-ended. The row must not read as a clean pass.
    let out = safer(&["run", "specs/extended/recorded-regression.yaml", "--filter", "USA_Peach-4_2_T-1"]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}\n{}", text(&out.stderr));
    let row = stdout.lines().find(|l| l.contains("USA_Peach-4_2_T-1::seed-0")).unwrap_or_else(|| panic!("{stdout}"));
    assert!(row.contains("pass (ego collision: ") && row.contains("not solved)"), "{row}");
}

#[test]
fn run_filter_selects_by_name_and_refuses_a_filter_matching_nothing() {
    let out = safer(&["run", "specs/suites/authored.yaml", "--filter", "on-ramp"]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("authored::on-ramp-merge::seed-0"), "{stdout}");
    assert!(!stdout.contains("highway-overtake") && !stdout.contains("solution_rate"), "{stdout}");
    let out = safer(&["run", "specs/suites/authored.yaml", "--filter", "no-such-variant"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("no-such-variant"), "{}", text(&out.stderr));
}

#[test]
fn schema_suite_prints_json_with_variants() {
    let out = safer(&["schema", "suite"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert!(v["properties"]["variants"].is_object(), "{v:#}");
    assert_eq!(v, json_schema(SpecKind::Suite));
}

#[test]
fn committed_schemas_match_the_spec_types() {
    for (kind, name) in [(SpecKind::Scenario, "scenario"), (SpecKind::Suite, "suite"), (SpecKind::Planner, "planner")] {
        let path = repo().join(format!("schemas/{name}.schema.json"));
        let committed: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(
            committed == json_schema(kind),
            "{} is stale; regenerate it with `cargo run -- schema {name} --out schemas/{name}.schema.json`",
            path.display()
        );
    }
}

#[test]
fn shipped_specs_point_editors_at_their_schema() {
    let dirs = [
        ("specs/suites", "../../schemas/suite"),
        ("specs/scenarios", "../../schemas/scenario"),
        ("planners", "../schemas/planner"),
    ];
    for (dir, schema) in dirs {
        for entry in std::fs::read_dir(repo().join(dir)).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "yaml") {
                let first = std::fs::read_to_string(&path).unwrap().lines().next().unwrap_or_default().to_string();
                assert_eq!(
                    first,
                    format!("# yaml-language-server: $schema={schema}.schema.json"),
                    "{}",
                    path.display()
                );
                // The reference resolves from the spec's folder.
                let target = path.parent().unwrap().join(format!("{schema}.schema.json"));
                assert!(target.is_file(), "{}", target.display());
            }
        }
    }
}

#[test]
fn render_scenario_spec_writes_svg_and_refuses_to_overwrite() {
    let dir = temp_dir("render");
    let svg = dir.join("merge.svg");
    let out = safer(&["render", "specs/scenarios/on-ramp-merge.yaml", "--out", svg.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let content = std::fs::read_to_string(&svg).expect("svg written");
    let doc = roxmltree::Document::parse(&content).expect("valid XML");
    assert_eq!(doc.root_element().tag_name().name(), "svg");

    let again = safer(&["render", "specs/scenarios/on-ramp-merge.yaml", "--out", svg.to_str().unwrap()]);
    assert_eq!(again.status.code(), Some(2));
    assert!(text(&again.stderr).contains("--force"), "{}", text(&again.stderr));
    assert_eq!(std::fs::read_to_string(&svg).unwrap(), content, "refused call must leave the file alone");

    let forced = safer(&[
        "render",
        "specs/scenarios/on-ramp-merge.yaml",
        "--out",
        svg.to_str().unwrap(),
        "--step",
        "40",
        "--force",
    ]);
    assert!(forced.status.success(), "{}", text(&forced.stderr));
    roxmltree::Document::parse(&std::fs::read_to_string(&svg).unwrap()).expect("valid XML");

    let bad_step = safer(&[
        "render",
        "specs/scenarios/on-ramp-merge.yaml",
        "--out",
        svg.to_str().unwrap(),
        "--step",
        "9999",
        "--force",
    ]);
    assert_eq!(bad_step.status.code(), Some(2));
    assert!(text(&bad_step.stderr).contains("9999"), "{}", text(&bad_step.stderr));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn render_a_broken_spec_shows_the_yaml_line() {
    let dir = temp_dir("render-bad");
    let spec = dir.join("bad.yaml");
    std::fs::write(&spec, "name: bad\nduration_s: 5\nmapp: {}\n").unwrap();
    let out = safer(&["render", spec.to_str().unwrap(), "--out", dir.join("x.svg").to_str().unwrap()]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("bad.yaml") && stderr.contains("mapp"), "{stderr}");
    assert!(!dir.join("x.svg").exists());
    std::fs::remove_dir_all(&dir).ok();
}
