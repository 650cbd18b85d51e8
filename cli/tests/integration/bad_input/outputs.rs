//! Bad input: output paths that would harm what the user wrote. `run` and
//! `evaluate` refuse, before anything runs, a report path that is a file
//! the run reads (also through a symbolic link or another spelling), two
//! reports on the same file, a report in a folder that does not exist and
//! a review page on standard output, and suites whose artefact folders
//! would collide or could not be made; the files are left as they were.

use std::path::Path;
use std::time::Duration;

use super::binary::{safer_in, text};

const DEADLINE: Duration = Duration::from_secs(60);

/// A fresh folder with a copy of the authored overtake scene and a suite
/// running it with the IDM planner.
fn workspace(tag: &str) -> crate::scratch::Scratch {
    let dir = crate::scratch::Scratch::new(&format!("bad-outputs-{tag}"));
    let repo = Path::new(repo_root!());
    std::fs::copy(repo.join("specs/scenarios/highway-overtake.yaml"), dir.join("overtake.yaml")).unwrap();
    std::fs::write(
        dir.join("suite.yaml"),
        "name: outputs\nscenarios:\n  - overtake.yaml\nplanner: { builtin: idm }\nvariants: 1\n",
    )
    .unwrap();
    dir
}

/// Runs `safer ARGS` in `dir`; asserts it is refused (exit 2) with
/// `message`, and that `kept` still holds what it held.
fn refused(dir: &Path, args: &[&str], message: &str, kept: &[&str]) {
    let before: Vec<Vec<u8>> = kept.iter().map(|f| std::fs::read(dir.join(f)).unwrap()).collect();
    let out = safer_in(dir, &[], args, DEADLINE);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains(message), "expected `{message}` in\n{}", text(&out));
    for (f, bytes) in kept.iter().zip(before) {
        assert_eq!(std::fs::read(dir.join(f)).unwrap(), bytes, "{f} was changed");
    }
}

#[test]
fn a_report_onto_the_suite_it_runs_is_refused_and_the_suite_kept() {
    let dir = workspace("suite");
    refused(&dir, &["run", "suite.yaml", "--json", "suite.yaml"], "--json would overwrite suite.yaml", &["suite.yaml"]);
    // Another spelling of the same file.
    let spelled = format!("../{}/./suite.yaml", dir.file_name().unwrap().to_string_lossy());
    refused(&dir, &["run", "suite.yaml", "--json", &spelled], "which this run reads", &["suite.yaml"]);
}

#[test]
fn a_junit_report_onto_a_scenario_the_suite_uses_or_a_link_to_it_is_refused() {
    let dir = workspace("scenario");
    refused(&dir, &["run", "suite.yaml", "--junit", "overtake.yaml"], "--junit would overwrite", &["overtake.yaml"]);
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(dir.join("overtake.yaml"), dir.join("link.xml")).unwrap();
        refused(&dir, &["run", "suite.yaml", "--junit", "link.xml"], "--junit would overwrite", &["overtake.yaml"]);
    }
}

#[test]
fn two_reports_on_one_file_are_refused() {
    let dir = workspace("same");
    refused(
        &dir,
        &["run", "suite.yaml", "--json", "r.out", "--junit", "r.out"],
        "--json and --junit name the same file",
        &[],
    );
    refused(&dir, &["run", "suite.yaml", "--json", "-", "--junit", "-"], "cannot both take standard output", &[]);
    assert!(!dir.join("r.out").exists());
}

#[test]
fn a_report_in_a_missing_folder_is_refused_before_the_run() {
    let dir = workspace("parent");
    refused(
        &dir,
        &["run", "suite.yaml", "--json", "no/such/folder/r.json"],
        "the folder no/such/folder does not exist",
        &[],
    );
}

#[test]
fn a_review_page_on_standard_output_is_refused_and_no_folder_named_dash_is_made() {
    let dir = workspace("html");
    refused(&dir, &["run", "suite.yaml", "--html", "-"], "not standard output", &[]);
    assert!(!dir.join("-").exists());
}

#[test]
fn an_evaluation_report_onto_a_scene_it_reads_is_refused() {
    let dir = workspace("evaluate");
    let scenes = dir.join("scenes");
    std::fs::create_dir_all(&scenes).unwrap();
    let repo = Path::new(repo_root!());
    std::fs::copy(repo.join("scenes/ngsim/USA_US101-4_3_T-1.xml"), scenes.join("scene.xml")).unwrap();
    refused(
        &dir,
        &["evaluate", "--scenes", "scenes", "--seeds", "1", "--json", "scenes/scene.xml"],
        "--json would overwrite",
        &["scenes/scene.xml"],
    );
}

#[test]
fn two_suites_of_one_name_are_refused_as_their_artefacts_would_collide() {
    let dir = workspace("same-name");
    std::fs::copy(dir.join("suite.yaml"), dir.join("copy.yaml")).unwrap();
    refused(&dir, &["run", "suite.yaml", "copy.yaml"], "are both named `outputs`", &[]);
}

#[test]
fn a_suite_name_too_long_for_an_artefact_folder_is_refused_at_load() {
    let dir = workspace("long-name");
    let suite = format!("name: {}\nscenarios:\n  - overtake.yaml\nplanner: {{ builtin: idm }}\n", "a".repeat(70_000));
    std::fs::write(dir.join("long.yaml"), suite).unwrap();
    let out = safer_in(&dir, &[], &["run", "long.yaml"], DEADLINE);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("the name is 70000 bytes long"), "{}", text(&out));
    assert!(!text(&out).contains("panicked"), "{}", text(&out));
}

/// A suite named `fs` over a copy of a recorded NGSIM scene at
/// `X/fs/seed-0/seed-0.xml`: exactly where `--export-commonroad X` would
/// write the export of its variant `fs::seed-0::seed-0`.
fn export_workspace(tag: &str) -> crate::scratch::Scratch {
    let dir = crate::scratch::Scratch::new(&format!("bad-outputs-{tag}"));
    let repo = Path::new(repo_root!());
    std::fs::create_dir_all(dir.join("X/fs/seed-0")).unwrap();
    std::fs::copy(repo.join("scenes/ngsim/USA_US101-4_3_T-1.xml"), dir.join("X/fs/seed-0/seed-0.xml")).unwrap();
    std::fs::write(
        dir.join("fs.yaml"),
        "name: fs\nscenarios:\n  - recorded: X/fs/seed-0/seed-0.xml\nplanner: { builtin: idm }\nvariants: 1\n",
    )
    .unwrap();
    dir
}

#[test]
fn an_export_onto_a_scene_the_run_reads_is_refused_and_the_scene_kept() {
    let dir = export_workspace("export-input");
    refused(
        &dir,
        &["run", "fs.yaml", "--export-commonroad", "X", "--export-commonroad-all"],
        "--export-commonroad would overwrite",
        &["X/fs/seed-0/seed-0.xml"],
    );
}

#[test]
fn an_export_replaces_only_its_own_earlier_export() {
    let dir = export_workspace("export-foreign");
    // A CommonRoad scene safer did not write, at the export's path, is kept.
    std::fs::create_dir_all(dir.join("out/fs/seed-0")).unwrap();
    std::fs::copy(dir.join("X/fs/seed-0/seed-0.xml"), dir.join("out/fs/seed-0/seed-0.xml")).unwrap();
    refused(
        &dir,
        &["run", "fs.yaml", "--export-commonroad", "out", "--export-commonroad-all"],
        "is not a CommonRoad scenario exported by safer",
        &["out/fs/seed-0/seed-0.xml"],
    );
    // Nor is a JSON file of the user's at the sidecar's path.
    std::fs::remove_file(dir.join("out/fs/seed-0/seed-0.xml")).unwrap();
    std::fs::write(dir.join("out/fs/seed-0/seed-0.commonroad.json"), "{\"mine\": 1}\n").unwrap();
    refused(
        &dir,
        &["run", "fs.yaml", "--export-commonroad", "out", "--export-commonroad-all"],
        "is not the sidecar of a CommonRoad export by safer",
        &["out/fs/seed-0/seed-0.commonroad.json"],
    );
    // Safer's own export is rewritten on the next run.
    std::fs::remove_file(dir.join("out/fs/seed-0/seed-0.commonroad.json")).unwrap();
    for _ in 0..2 {
        let out =
            safer_in(&dir, &[], &["run", "fs.yaml", "--export-commonroad", "out", "--export-commonroad-all"], DEADLINE);
        assert!(out.status.code().is_some_and(|c| c < 2), "{}", text(&out));
        assert!(std::fs::read_to_string(dir.join("out/fs/seed-0/seed-0.xml")).unwrap().contains("author=\"safer\""));
        assert!(
            std::fs::read_to_string(dir.join("out/fs/seed-0/seed-0.commonroad.json"))
                .unwrap()
                .contains("\"format\": \"safer-commonroad-export\"")
        );
    }
}

#[test]
fn a_report_onto_a_file_of_another_kind_is_refused() {
    let dir = workspace("kind");
    std::fs::write(dir.join("notes.yaml"), "keep: me\n").unwrap();
    refused(&dir, &["run", "suite.yaml", "--json", "notes.yaml"], "is not a JSON document", &["notes.yaml"]);
    refused(&dir, &["run", "suite.yaml", "--junit", "notes.yaml"], "is not a JUnit report", &["notes.yaml"]);
    // A report of the same kind is replaced, as reruns need.
    std::fs::write(dir.join("old.json"), "{\"passed\": false}\n").unwrap();
    let out = safer_in(&dir, &[], &["run", "suite.yaml", "--json", "old.json"], DEADLINE);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(std::fs::read_to_string(dir.join("old.json")).unwrap().contains("\"suites\""));
}

#[test]
fn a_picture_onto_the_scenario_it_draws_is_refused_even_with_force() {
    let dir = workspace("render");
    refused(
        &dir,
        &["render", "overtake.yaml", "--out", "overtake.yaml", "--force"],
        "which this run reads",
        &["overtake.yaml"],
    );
}

#[test]
fn a_schema_onto_an_existing_file_needs_force() {
    let dir = workspace("schema");
    refused(&dir, &["schema", "suite", "--out", "suite.yaml"], "pass --force to replace it", &["suite.yaml"]);
    let out = safer_in(&dir, &[], &["schema", "suite", "--out", "suite.yaml", "--force"], DEADLINE);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(std::fs::read_to_string(dir.join("suite.yaml")).unwrap().contains("\"$schema\""));
}
