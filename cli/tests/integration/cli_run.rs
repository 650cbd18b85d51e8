//! `safer run`, `safer schema` and `safer render` end to end, through the
//! real binary; and the committed JSON Schemas under `schemas/` kept equal
//! to what the spec types export.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use safer_scenarios::spec::{SpecKind, json_schema};

fn repo() -> &'static Path {
    Path::new(repo_root!())
}

/// Runs the binary from the repository root, so shipped spec paths are relative as a user types them.
fn safer(args: &[&str]) -> Output {
    // A user's SAFER_DENY_WARNINGS would refuse the suites some tests
    // write to see their warnings.
    Command::new(env!("CARGO_BIN_EXE_safer"))
        .args(args)
        .current_dir(repo())
        .env_remove("SAFER_DENY_WARNINGS")
        .output()
        .expect("run safer")
}

/// A suite over the shipped recorded scenes that writes neither a method
/// nor `no_collision`: both spec warnings.
const BARE_RECORDED_SUITE: &str =
    "name: replay\nscenarios:\n  - recorded: safer:scenes/ngsim\nplanner: { builtin: idm }\n";

/// A fresh folder per test (tests run in parallel and share the process id).
fn temp_dir(tag: &str) -> crate::scratch::Scratch {
    crate::scratch::Scratch::new(&format!("cli-run-{tag}"))
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
    // Wall times: the run's, the suite's and each variant's, and the
    // suite's in the table.
    let positive = |x: &serde_json::Value| x.as_f64().is_some_and(|t| t > 0.0);
    assert!(positive(&v["wall_s"]) && positive(&suite["wall_s"]), "{v:#}");
    assert!(variants.iter().all(|x| positive(&x["wall_s"])), "{suite:#}");
    assert!(suite["wall_s"].as_f64() <= v["wall_s"].as_f64(), "{v:#}");
    assert!(stdout.contains("  time: ") && stdout.contains(" summed over its variants"), "{stdout}");
    // Off a terminal, progress says at once what is to run.
    assert!(text(&out.stderr).contains("run: 3 variants to run"), "{}", text(&out.stderr));
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
fn run_warns_of_recorded_scenes_left_to_replay_and_judged_by_any_collision_and_runs_them() {
    let dir = temp_dir("replay-warning");
    let suite = dir.join("replay.yaml");
    let written = BARE_RECORDED_SUITE;
    std::fs::write(&suite, written).unwrap();
    let (json, junit) = (dir.join("report.json"), dir.join("junit.xml"));
    let reports = ["--json", json.to_str().unwrap(), "--junit", junit.to_str().unwrap()];
    let out = safer(&[&["run", suite.to_str().unwrap()][..], &reports].concat());
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(stderr.starts_with("warning: no `adversary.method`: the recorded scenes are replayed"), "{stderr}");
    assert!(stderr.contains("replay.yaml:3:15"), "{stderr}");
    assert!(stderr.contains("warning: `no_collision` is left at its default, true"), "{stderr}");
    assert_eq!(stderr.matches("warning: ").count(), 2, "{stderr}");
    assert!(text(&out.stdout).contains("PASS: 3 variants"), "{}", text(&out.stdout));
    assert!(text(&out.stdout).contains("; 2 spec warnings;"), "{}", text(&out.stdout));
    // The reports carry them too, for a CI that reads only its reports;
    // they leave the verdict as it was.
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let warnings: Vec<&str> =
        report["suites"][0]["warnings"].as_array().unwrap().iter().map(|w| w.as_str().unwrap()).collect();
    assert_eq!(warnings.len(), 2, "{report}");
    assert!(warnings[0].ends_with("replay.yaml:3:15: no `adversary.method`: the recorded scenes are replayed as recorded (`log`, the default) and meet only the conflicts their recordings hold; name a SaFeR method for adversarial variants (the shipped adversarial suites use `safer-in-path-lookahead`: docs/guide/adversary.md), or write `method: log` to replay on purpose"), "{report}");
    assert!(warnings[1].contains("replay.yaml:3:15: `no_collision` is left at its default, true"), "{report}");
    assert_eq!((&report["passed"], &report["suites"][0]["passed"]), (&true.into(), &true.into()), "{report}");
    let xml = std::fs::read_to_string(&junit).unwrap();
    let doc = roxmltree::Document::parse(&xml).unwrap();
    let properties: Vec<&str> = doc
        .descendants()
        .filter(|n| n.has_tag_name("property") && n.attribute("name") == Some("warning"))
        .filter_map(|n| n.attribute("value"))
        .collect();
    assert_eq!(properties, warnings, "{xml}");
    assert_eq!(doc.root_element().attribute("failures"), Some("0"), "{xml}");
    // Saying so silences each; the file the user wrote is left as written.
    let replay = written.replace("idm }\n", "idm }\nadversary: { method: log }\n");
    std::fs::write(&suite, &replay).unwrap();
    let out = safer(&["run", suite.to_str().unwrap()]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(!stderr.contains("no `adversary.method`") && stderr.contains("`no_collision` is left"), "{stderr}");
    let at_fault = "acceptance: { variant: { no_collision: false, no_at_fault_collision: true } }\n";
    std::fs::write(&suite, format!("{replay}{at_fault}")).unwrap();
    let out = safer(&[&["run", suite.to_str().unwrap()][..], &reports].concat());
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(!text(&out.stderr).contains("warning"), "{}", text(&out.stderr));
    assert!(!text(&out.stdout).contains("spec warning"), "{}", text(&out.stdout));
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(report["suites"][0]["warnings"], serde_json::json!([]), "{report}");
    assert!(!std::fs::read_to_string(&junit).unwrap().contains("<property name=\"warning\""));
    assert_eq!(std::fs::read_to_string(&suite).unwrap(), format!("{replay}{at_fault}"));
    std::fs::remove_dir_all(&dir).ok();
}

/// `--deny-warnings` (or `SAFER_DENY_WARNINGS`) refuses a suite whose spec
/// warns as a spec error refuses it: exit status 2, nothing run, and every
/// report says why; a suite without warnings runs as before.
#[test]
fn run_deny_warnings_refuses_a_suite_whose_spec_warns_and_every_report_says_why() {
    let dir = temp_dir("deny-warnings");
    let suite = dir.join("replay.yaml");
    let written = BARE_RECORDED_SUITE;
    std::fs::write(&suite, written).unwrap();
    let (json, junit) = (dir.join("report.json"), dir.join("junit.xml"));
    let reports = ["--json", json.to_str().unwrap(), "--junit", junit.to_str().unwrap()];
    let run = |env: Option<&str>, flag: bool| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_safer"));
        command.args(["run", suite.to_str().unwrap()]).args(reports).current_dir(repo());
        command.env_remove("SAFER_DENY_WARNINGS");
        if let Some(value) = env {
            command.env("SAFER_DENY_WARNINGS", value);
        }
        if flag {
            command.arg("--deny-warnings");
        }
        command.output().expect("run safer")
    };
    for (env, flag) in [(None, true), (Some("1"), false)] {
        let out = run(env, flag);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{env:?} {flag}: {stderr}");
        assert_eq!(stderr.matches("warning: ").count(), 2, "{stderr}");
        assert!(
            stderr.contains("error: 2 spec warnings denied (SAFER_DENY_WARNINGS or --deny-warnings is set)"),
            "{stderr}"
        );
        assert!(text(&out.stdout).contains("FAIL"), "{}", text(&out.stdout));
        let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        assert_eq!(report["passed"], false, "{report}");
        assert_eq!(report["suites"], serde_json::json!([]), "nothing ran: {report}");
        let message = report["load_errors"][0]["message"].as_str().unwrap();
        assert!(message.starts_with("2 spec warnings denied"), "{message}");
        assert!(message.contains("replay.yaml:3:15: no `adversary.method`"), "{message}");
        assert!(message.contains("replay.yaml:3:15: `no_collision` is left at its default, true"), "{message}");
        let xml = std::fs::read_to_string(&junit).unwrap();
        let doc = roxmltree::Document::parse(&xml).unwrap();
        assert_eq!(doc.root_element().attribute("errors"), Some("1"), "{xml}");
        assert!(xml.contains("2 spec warnings denied"), "{xml}");
    }
    // `0` leaves them warnings: the run goes ahead and passes.
    let out = run(Some("0"), false);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(!text(&out.stderr).contains("denied"), "{}", text(&out.stderr));
    // A suite that says what it means runs under the flag.
    let meant = format!(
        "{written}adversary: {{ method: log }}\nacceptance: {{ variant: {{ no_collision: false, no_at_fault_collision: true }} }}\n"
    );
    std::fs::write(&suite, &meant).unwrap();
    let out = run(None, true);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("PASS: 3 variants"), "{}", text(&out.stdout));
    assert_eq!(std::fs::read_to_string(&suite).unwrap(), meant);
    std::fs::remove_dir_all(&dir).ok();
}

/// `safer run SUITE --artifacts ARTEFACTS --json JSON`, then `more`.
fn run_with_artefacts(suite: &Path, artefacts: &Path, json: &Path, more: &[&str]) -> Output {
    let mut args = vec![
        "run",
        suite.to_str().unwrap(),
        "--artifacts",
        artefacts.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ];
    args.extend_from_slice(more);
    safer(&args)
}

/// `safer run` writes stage 1 beside a failing variant: the ego replaying
/// its log against the CBV the adversary drove. Where the CBV hit the ego
/// there, the stage-1 picture draws the feasibility witness's escape when
/// the search finds one, as `safer evaluate` does: here the planner replays
/// the log too, so every stage-1 collision repeats as the planner's failure.
#[test]
fn run_writes_stage_1_with_its_escape_beside_a_failing_variant() {
    let dir = temp_dir("stage1");
    let suite = dir.join("replay.yaml");
    std::fs::write(
        &suite,
        format!(
            "name: replay\nscenarios:\n  - recorded: {}\nplanner: {{ builtin: log-replay }}\n\
             adversary: {{ method: safer, stage2_cbv: replay }}\nvariants: 2\n\
             acceptance:\n  variant: {{ no_collision: true }}\n",
            repo().join("scenes/ngsim").display()
        ),
    )
    .unwrap();
    let (artefacts, json, page) = (dir.join("artefacts"), dir.join("report.json"), dir.join("review"));
    let out = run_with_artefacts(&suite, &artefacts, &json, &["--html", page.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1), "{}\n{}", text(&out.stdout), text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let failing: Vec<&serde_json::Value> = v["suites"][0]["variants"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|v| v["passed"] == false && v["stage1_cbv_hit_ego"] == true)
        .collect();
    assert!(!failing.is_empty(), "no stage-1 collision failed the replaying planner: {v}");
    let mut escapes = 0;
    for variant in failing {
        let stage1 = variant["artefacts"]["stage1_svg"].as_str().expect("a stage-1 picture");
        let picture = std::fs::read_to_string(stage1).unwrap();
        assert!(picture.contains("planner log-replay") && picture.contains("collides with the CBV"), "{stage1}");
        let escape = picture.contains("feasibility witness: an escape keeping");
        escapes += usize::from(escape);
        assert!(Path::new(variant["artefacts"]["stage1_mcap"].as_str().unwrap()).is_file());
        // The review page's stage-1 picture draws the same escape, or none.
        let name = variant["variant"].as_str().expect("a variant name").replace("::", "/");
        let on_page = std::fs::read_to_string(page.join("pictures").join(format!("{name}.stage1.svg"))).unwrap();
        assert_eq!(on_page.contains("feasibility witness: an escape keeping"), escape, "{name}");
    }
    assert!(escapes > 0, "no stage-1 picture draws an escape");
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
    let out = run_with_artefacts(&suite, &artefacts, &json, &[]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{}", text(&out.stderr));
    assert!(stdout.contains("cv::highway-overtake::seed-0") && stdout.contains("FAIL"), "{stdout}");
    let base = artefacts.join("cv/highway-overtake/seed-0");
    for ext in ["mcap", "svg", "stage1.svg"] {
        let p = base.with_extension(ext);
        assert!(p.is_file(), "{} missing\n{stdout}", p.display());
        assert!(stdout.contains(&p.display().to_string()), "{stdout}");
    }
    // Stage 1 is the ego replaying its log: its recording and picture say so.
    assert!(base.with_extension("stage1.mcap").is_file());
    let stage1_svg = std::fs::read_to_string(base.with_extension("stage1.svg")).unwrap();
    assert!(stage1_svg.contains("planner log-replay"), "the stage-1 picture is not stage 1's");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(v["passed"], false);
    assert_eq!(v["suites"][0]["variants"][0]["passed"], false);
    assert!(v["suites"][0]["variants"][0]["artefacts"]["mcap"].is_string());
    let stage1_svg = base.with_extension("stage1.svg").display().to_string();
    assert_eq!(v["suites"][0]["variants"][0]["artefacts"]["stage1_svg"], stage1_svg.as_str());
    // It ran into the leader, which braking avoids: the closed-loop witness
    // verifies the escape by playing it, and both artefacts draw it.
    assert!(v["suites"][0]["variants"][0]["stage2_collision"].is_string(), "{v}");
    assert_eq!(v["suites"][0]["variants"][0]["stage2_escape"], "avoidable");
    assert_eq!(v["suites"][0]["variants"][0]["artefacts"]["witness"], "avoidable");
    assert!(stdout.contains("witness:   avoidable: an escape played closed loop"), "{stdout}");
    let svg = std::fs::read_to_string(base.with_extension("svg")).unwrap();
    assert!(svg.contains("feasibility witness: an escape keeping"), "the picture draws no witness");
    let mcap = std::fs::read(base.with_extension("mcap")).unwrap();
    assert!(
        mcap.windows(b"feasibility witness".len()).any(|w| w == b"feasibility witness"),
        "the recording has no witness"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
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

/// A JUnit testcase as an independent parser reads it.
#[derive(Debug)]
struct JunitCase {
    classname: String,
    name: String,
    failure: Option<String>,
    failure_text: Option<String>,
    error: Option<String>,
}

/// The testcases of a JUnit document.
fn junit_cases(xml: &str) -> Vec<JunitCase> {
    let doc = roxmltree::Document::parse(xml).unwrap_or_else(|e| panic!("JUnit XML is not well-formed: {e}\n{xml}"));
    doc.descendants()
        .filter(|n| n.has_tag_name("testcase"))
        .map(|c| {
            let child = |tag: &str| c.children().find(|n| n.has_tag_name(tag));
            JunitCase {
                classname: c.attribute("classname").unwrap_or_default().to_string(),
                name: c.attribute("name").unwrap_or_default().to_string(),
                failure: child("failure").and_then(|f| f.attribute("message")).map(String::from),
                failure_text: child("failure").and_then(|f| f.text()).map(String::from),
                error: child("error").and_then(|f| f.attribute("message")).map(String::from),
            }
        })
        .collect()
}

#[test]
fn run_junit_reports_a_failing_and_a_passing_suite() {
    let dir = temp_dir("junit");
    let junit = dir.join("junit.xml");
    let artefacts = dir.join("artefacts");
    let out = safer(&[
        "run",
        "specs/examples/constant-velocity-fails.yaml",
        "specs/suites/authored.yaml",
        "--junit",
        junit.to_str().unwrap(),
        "--artifacts",
        artefacts.to_str().unwrap(),
    ]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{}", text(&out.stderr));
    // The table is unchanged by --junit.
    assert!(stdout.contains("FAIL: 6 variants, 1 failed; 2 metric checks, 1 failed"), "{stdout}");
    let xml = std::fs::read_to_string(&junit).expect("JUnit report written");
    let doc = roxmltree::Document::parse(&xml).unwrap();
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "testsuites");
    assert_eq!(
        (root.attribute("tests"), root.attribute("failures"), root.attribute("errors")),
        (Some("8"), Some("2"), Some("0"))
    );
    let cases = junit_cases(&xml);
    // 3 variants + solution_rate per suite.
    assert_eq!(cases.len(), 8, "{xml}");
    let fails: Vec<_> = cases.iter().filter(|c| c.classname == "constant-velocity-fails").collect();
    let passes: Vec<_> = cases.iter().filter(|c| c.classname == "authored").collect();
    assert_eq!((fails.len(), passes.len()), (4, 4), "{xml}");
    assert!(passes.iter().all(|c| c.failure.is_none() && c.error.is_none()), "{xml}");
    let names: Vec<&str> = passes.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        ["highway-overtake::seed-0", "on-ramp-merge::seed-0", "signalised-crossing::seed-0", "solution_rate"]
    );

    let failing = fails.iter().find(|c| c.name == "highway-overtake::seed-0").expect("failing variant");
    let message = failing.failure.as_deref().expect("a <failure>");
    assert!(message.starts_with("no_collision: ego collided with agent lead at t = "), "{message}");
    assert!(message.contains("; min_gap_m: "), "{message}");
    let body = failing.failure_text.as_deref().expect("failure text");
    assert!(body.contains("stage 2 (planner constant-velocity"), "{body}");
    // The collision's closed-loop verdict and the gap to the CBV.
    assert!(body.contains("collision avoidable: an escape played closed loop"), "{body}");
    assert!(body.contains("closest gap to the CBV "), "{body}");
    // Whether the conflicts reached the planner, as suite properties.
    let properties: Vec<(&str, &str)> = doc
        .descendants()
        .filter(|n| n.has_tag_name("property"))
        .filter_map(|n| Some((n.attribute("name")?, n.attribute("value")?)))
        .collect();
    for name in ["conflict_reach", "solution_rate_avoidable", "avoidable_failures", "no_escape_collisions"] {
        assert!(properties.iter().any(|(n, _)| *n == name), "no {name} property: {xml}");
    }
    // The table names the gap to the CBV and the reach beside the gap to anyone.
    assert!(stdout.contains("gap CBV m  min gap m  reach"), "{stdout}");
    for ext in ["mcap", "svg"] {
        let p = artefacts.join("constant-velocity-fails/highway-overtake/seed-0").with_extension(ext);
        assert!(p.is_file(), "{} missing", p.display());
        assert!(body.contains(&p.display().to_string()), "{body}");
    }
    // Each suite's and each variant's wall time; none on a metric.
    for suite in doc.descendants().filter(|n| n.has_tag_name("testsuite")) {
        let time: f64 = suite.attribute("time").expect("a testsuite time").parse().unwrap();
        assert!(time > 0.0, "{xml}");
        for case in suite.children().filter(|n| n.has_tag_name("testcase")) {
            let metric = case.attribute("name") == Some("solution_rate");
            assert_eq!(case.attribute("time").is_some(), !metric, "{xml}");
            assert!(case.attribute("time").is_none_or(|t| t.parse::<f64>().unwrap() >= 0.0), "{xml}");
        }
    }
    // A failing variant is shrunk or says why not (`method: log` drives no tokens).
    assert!(body.contains("shrunk: "), "{body}");
    let metric = fails.iter().find(|c| c.name == "solution_rate").expect("metric testcase");
    assert!(metric.failure.as_deref().is_some_and(|m| m.starts_with("solution_rate = 0.667 < 1")), "{metric:?}");
    assert!(fails.iter().filter(|c| c.failure.is_none()).count() == 2, "{xml}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn run_junit_reports_a_suite_that_does_not_load_as_an_error() {
    let dir = temp_dir("junit-load");
    let suite = dir.join("typo.yaml");
    std::fs::write(&suite, "name: typo\nscenarios: []\nplanner: { builtin: idm }\nvariantz: 2\n").unwrap();
    let out = safer(&["run", suite.to_str().unwrap(), "--junit", "-"]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    // --junit - takes standard output; the table goes to stderr.
    let xml = text(&out.stdout);
    let cases = junit_cases(&xml);
    assert_eq!(cases.len(), 1, "{xml}");
    assert_eq!((cases[0].classname.as_str(), cases[0].name.as_str()), ("typo", "load"));
    assert!(cases[0].error.as_deref().is_some_and(|m| m.contains("typo.yaml")), "{xml}");
    assert!(xml.contains("variantz"), "{xml}");
    assert!(text(&out.stderr).contains("FAIL: 0 variants"), "{}", text(&out.stderr));
    std::fs::remove_dir_all(&dir).ok();
}

/// Runs the failing example and the authored suite with `--html`; returns
/// the page folder (inside `dir`).
fn write_review_page(dir: &Path) -> PathBuf {
    let page = dir.join("review");
    let out = safer(&[
        "run",
        "specs/examples/constant-velocity-fails.yaml",
        "specs/suites/authored.yaml",
        "--html",
        page.to_str().unwrap(),
        "--artifacts",
        dir.join("artefacts").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1), "{}\n{}", text(&out.stdout), text(&out.stderr));
    page
}

#[test]
fn run_html_writes_a_well_formed_review_page_with_the_failing_variants_frames() {
    let dir = temp_dir("html");
    let page = write_review_page(&dir);
    let html = std::fs::read_to_string(page.join("index.html")).expect("index.html written");
    let options = roxmltree::ParsingOptions { allow_dtd: true, ..Default::default() };
    let doc =
        roxmltree::Document::parse_with_options(&html, options).unwrap_or_else(|e| panic!("not well-formed: {e}"));
    // Nothing loads from the network.
    for n in doc.descendants() {
        for a in ["src", "href"] {
            if let Some(v) = n.attribute(a) {
                assert!(!v.contains("://"), "external reference {v}");
            }
        }
    }
    let rows: Vec<String> = doc
        .descendants()
        .filter(|n| n.has_tag_name("table") && n.attribute("class") == Some("variants"))
        .flat_map(|t| t.descendants().filter(|n| n.has_tag_name("tr")).skip(1))
        .map(|tr| tr.children().find(|n| n.has_tag_name("td")).and_then(|td| td.text()).unwrap_or_default().to_string())
        .collect();
    let mut expected = Vec::new();
    for suite in ["constant-velocity-fails", "authored"] {
        for scenario in ["highway-overtake", "on-ramp-merge", "signalised-crossing"] {
            expected.push(format!("{suite}::{scenario}::seed-0"));
        }
    }
    assert_eq!(rows, expected);
    // One player, for the one failing variant, with its rollout's frames.
    let players: Vec<_> = doc.descendants().filter(|n| n.attribute("class") == Some("player")).collect();
    assert_eq!(players.len(), 1);
    assert_eq!(players[0].attribute("data-variant"), Some("constant-velocity-fails::highway-overtake::seed-0"));
    let json = players[0]
        .descendants()
        .find(|n| n.attribute("class") == Some("rollout"))
        .and_then(|n| n.text())
        .expect("rollout data");
    let data: serde_json::Value = serde_json::from_str(json).unwrap();
    let frames = data["frames"].as_array().unwrap();
    assert!(frames.len() > 50, "{} frames", frames.len());
    let agents = data["agents"].as_array().unwrap();
    assert_eq!(agents[0]["role"], "ego");
    assert!(agents.iter().any(|a| a["id"] == "lead"), "{agents:?}");
    assert!(frames.iter().all(|f| f.as_array().unwrap().len() == agents.len()));
    assert!(data["collisions"].as_array().is_some_and(|c| !c.is_empty()));
    // The picture beside the page and the recording it links to.
    let picture = page.join("pictures/constant-velocity-fails/highway-overtake/seed-0.svg");
    assert!(picture.is_file(), "{}", picture.display());
    // The collision was avoidable: the page says so and its picture draws the escape.
    assert!(html.contains("closed-loop feasibility witness: avoidable: an escape played closed loop"));
    let svg = std::fs::read_to_string(&picture).unwrap();
    assert!(svg.contains("feasibility witness: an escape keeping"), "the page's picture draws no witness");
    let mcap = doc.descendants().find(|n| n.attribute("class") == Some("mcap")).and_then(|a| a.attribute("href"));
    let mcap = page.join(mcap.expect("a link to the recording"));
    assert!(mcap.is_file(), "{}", mcap.display());
    // And the stage-1 picture it links to, beside the recording.
    let stage1 = doc.descendants().find(|n| n.attribute("class") == Some("stage1")).and_then(|a| a.attribute("href"));
    let stage1 = page.join(stage1.expect("a link to the stage-1 picture"));
    assert!(
        std::fs::read_to_string(&stage1).is_ok_and(|svg| svg.contains("planner log-replay")),
        "{}",
        stage1.display()
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Chromium, when asked for: `SAFER_CHROMIUM` or `/usr/bin/chromium`.
fn chromium() -> PathBuf {
    let path = std::env::var_os("SAFER_CHROMIUM").map_or_else(|| PathBuf::from("/usr/bin/chromium"), PathBuf::from);
    assert!(
        path.is_file(),
        "{} not found: this browser test needs Chromium (Debian: apt-get install chromium; or set SAFER_CHROMIUM)",
        path.display()
    );
    path
}

/// Runs headless Chromium on `url` with `args`; the machine's closed
/// network needs the background-networking flags.
fn headless(args: &[&str], url: &str, profile: &Path) -> Output {
    let out = Command::new(chromium())
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--window-size=1400,1000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .arg(url)
        .output()
        .expect("run chromium");
    assert!(out.status.success(), "chromium failed: {}", text(&out.stderr));
    out
}

/// The review page in a real browser: its script builds the animated view
/// without an error, and a screenshot is taken. Ignored by default (it
/// needs Chromium); run it with
/// `cargo test --test integration review_page_in_chromium -- --ignored`,
/// where a missing browser fails it.
#[test]
#[ignore = "needs Chromium (/usr/bin/chromium or $SAFER_CHROMIUM); run with -- --ignored"]
fn review_page_in_chromium() {
    // Fails before the run when the browser is missing.
    chromium();
    let dir = temp_dir("chromium");
    let page = write_review_page(&dir);
    let url = format!("file://{}", page.join("index.html").display());
    let profile = dir.join("profile");
    let dom = text(&headless(&["--dump-dom"], &url, &profile).stdout);
    let player = dom.split("class=\"player\"").nth(1).expect("the player is in the DOM");
    let player = player.split("</figure>").next().unwrap();
    assert!(player.contains("data-ready=\"true\""), "the script did not finish:\n{player}");
    // Every agent of the rollout got a box with corners, ego and CBV among them.
    let boxes = player.matches("<polygon class=\"box\" points=\"").count();
    let agents = player.matches("<g class=\"agent ").count();
    assert!(agents >= 3 && boxes == agents, "{agents} agents, {boxes} boxes drawn");
    assert!(player.contains("<g class=\"agent ego") && player.contains("<g class=\"agent cbv"), "{player}");
    // The ego rear-ends the leader at 3.6 s: that frame is shown first.
    assert!(player.contains("<output class=\"time\">t = 3.6 s (step 36 of 80)</output>"), "{player}");
    let errors = dom.split("id=\"js-errors\"").nth(1).unwrap().split("</pre>").next().unwrap();
    assert!(errors.starts_with(" hidden=\"hidden\">") && errors.ends_with('>'), "script errors: {errors}");

    let shot = std::env::var_os("SAFER_SCREENSHOT").map_or_else(|| dir.join("review.png"), PathBuf::from);
    headless(&[&format!("--screenshot={}", shot.display())], &url, &profile);
    let png = std::fs::read(&shot).expect("screenshot written");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let (w, h) =
        (u32::from_be_bytes(png[16..20].try_into().unwrap()), u32::from_be_bytes(png[20..24].try_into().unwrap()));
    assert_eq!((w, h), (1400, 1000));
    std::fs::remove_dir_all(&dir).ok();
}

/// A `safer` binary copied to another machine, where the folder it was
/// built from does not exist, still resolves `safer:` paths: from the
/// files embedded in it, unpacked into its cache folder. The copy runs
/// from an unrelated folder with `SAFER_SHIPPED_FILES=embedded`, which
/// makes it ignore its build folder as if it were gone.
/// The output of `command`, which runs a freshly copied binary. While the
/// copy was open for writing, a process that another test thread forked
/// could hold it open until its own exec, and Linux refuses to run a file
/// open for writing ("text file busy"): that is retried for a while.
fn output_of_copied(command: &mut Command) -> Output {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    loop {
        match command.output() {
            Err(e) if e.kind() == std::io::ErrorKind::ExecutableFileBusy && std::time::Instant::now() < deadline => {
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
            result => return result.expect("run the copied safer"),
        }
    }
}

#[test]
fn a_copied_binary_finds_the_shipped_files_without_its_build_folder() {
    let dir = temp_dir("copied-binary");
    let binary = dir.join("safer");
    std::fs::copy(env!("CARGO_BIN_EXE_safer"), &binary).unwrap();
    let suite = dir.join("suite.yaml");
    std::fs::write(
        &suite,
        "name: shipped\nscenarios:\n  - safer:specs/scenarios/highway-overtake.yaml\n\
         planner: { builtin: log-replay }\nadversary: { method: log }\nvariants: 1\n",
    )
    .unwrap();
    let cache = dir.join("cache");
    let run = || {
        output_of_copied(
            Command::new(&binary)
                .args(["run", suite.to_str().unwrap()])
                .current_dir(&*dir)
                .env("SAFER_SHIPPED_FILES", "embedded")
                .env("SAFER_CACHE_DIR", &cache)
                .env("SAFER_ARTIFACTS_DIR", dir.join("artefacts")),
        )
    };
    let out = run();
    let all = format!("{}\n{}", text(&out.stdout), text(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "{all}");
    assert!(all.contains("shipped::highway-overtake::seed-0"), "{all}");
    let unpacked: Vec<PathBuf> = std::fs::read_dir(&cache).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(unpacked.len(), 1, "one copy of the shipped files: {unpacked:?}");
    let copy = &unpacked[0];
    assert!(copy.join("specs/scenarios/highway-overtake.yaml").is_file());
    assert!(copy.join("planners/lane_follower.py").is_file() && copy.join("python/safer_planner/planner.py").is_file());
    // Nothing in the report points into the build folder.
    assert!(!all.contains(&format!("{}/specs", env!("CARGO_MANIFEST_DIR").trim_end_matches("/cli"))), "{all}");
    // Commands that read one scene take `safer:` paths too.
    let inspect = output_of_copied(
        Command::new(&binary)
            .args(["inspect", "safer:scenes/ngsim/USA_US101-4_3_T-1.xml"])
            .current_dir(&*dir)
            .env("SAFER_SHIPPED_FILES", "embedded")
            .env("SAFER_CACHE_DIR", &cache),
    );
    assert_eq!(inspect.status.code(), Some(0), "{}", text(&inspect.stderr));
    assert!(text(&inspect.stdout).contains(&copy.display().to_string()), "{}", text(&inspect.stdout));
    // A second run reuses the copy.
    let again = run();
    assert_eq!(again.status.code(), Some(0), "{}", text(&again.stderr));
    assert_eq!(std::fs::read_dir(&cache).unwrap().count(), 1);
}
