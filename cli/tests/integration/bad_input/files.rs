//! Bad input: output paths and numbers. What a user owns is never damaged
//! (a symlink stays a link, a device stays a device, `-` is standard
//! output and not a file named `-`), a bad number is refused naming the
//! flag instead of being clamped, and data defaults follow
//! `SAFER_DATA_DIR`. Each case runs the real `safer` binary with a
//! deadline, in a fresh temporary folder.

use std::path::{Path, PathBuf};

use std::time::Duration;

use super::binary::{safer_in, safer_within, text};

fn fixture(name: &str) -> PathBuf {
    Path::new(repo_root!()).join("tests/fixtures/bad-input/files").join(name)
}

/// A fresh folder per test (tests run in parallel and share the process id).
fn temp_dir(tag: &str) -> crate::scratch::Scratch {
    crate::scratch::Scratch::new(&format!("bad-files-{tag}"))
}

const RUN_DEADLINE: Duration = Duration::from_secs(180);

#[cfg(unix)]
#[test]
fn json_onto_a_symlink_fills_its_target_and_keeps_the_link() {
    let dir = temp_dir("symlink");
    std::fs::create_dir(dir.join("reports")).unwrap();
    std::fs::write(dir.join("reports/latest.json"), b"{\"previous\": \"report\"}").unwrap();
    std::os::unix::fs::symlink("reports/latest.json", dir.join("report.json")).unwrap();
    let suite = fixture("one-overtake.suite.yaml");
    let out = safer_in(&dir, &[], &["run", suite.to_str().unwrap(), "--json", "report.json"], RUN_DEADLINE);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let link = std::fs::symlink_metadata(dir.join("report.json")).unwrap();
    assert!(link.file_type().is_symlink(), "the link was replaced by a {:?}", link.file_type());
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("reports/latest.json")).unwrap()).expect("JSON in the target");
    assert_eq!(v["suites"][0]["name"], "one-overtake");
    let mut left: Vec<String> = std::fs::read_dir(dir.join("reports"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    left.sort();
    assert_eq!(left, vec!["latest.json".to_string()], "temporaries left beside the target");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn json_dash_prints_the_report_on_stdout_and_creates_no_file() {
    let dir = temp_dir("dash");
    let suite = fixture("one-overtake.suite.yaml");
    let out = safer_in(&dir, &[], &["run", suite.to_str().unwrap(), "--json", "-"], RUN_DEADLINE);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    // Only the JSON on stdout: the table moved to stderr.
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}\n{}", text(&out)));
    assert_eq!(v["passed"], true);
    assert!(String::from_utf8_lossy(&out.stderr).contains("one-overtake::"), "{}", text(&out));
    assert!(!dir.join("-").exists(), "a file named `-` was created");
    std::fs::remove_dir_all(&dir).ok();
}

#[cfg(target_os = "linux")]
#[test]
fn json_onto_dev_full_fails_naming_it_and_leaves_the_device() {
    use std::os::unix::fs::FileTypeExt;
    let full = Path::new("/dev/full");
    let is_char_device = |p: &Path| std::fs::metadata(p).is_ok_and(|m| m.file_type().is_char_device());
    if !is_char_device(full) {
        println!("skipped: /dev/full is not a character device here");
        return;
    }
    let dir = temp_dir("dev-full");
    let suite = fixture("one-overtake.suite.yaml");
    let out = safer_in(&dir, &[], &["run", suite.to_str().unwrap(), "--json", "/dev/full"], RUN_DEADLINE);
    assert!(!out.status.success(), "writing to /dev/full must fail: {}", text(&out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("/dev/full"), "{}", text(&out));
    assert!(stderr.to_lowercase().contains("no space left"), "{}", text(&out));
    assert!(is_char_device(full), "/dev/full is no longer a character device");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn json_onto_a_folder_is_refused_before_the_run() {
    let dir = temp_dir("folder");
    std::fs::create_dir(dir.join("out")).unwrap();
    let suite = fixture("one-overtake.suite.yaml");
    let out = safer_in(&dir, &[], &["run", suite.to_str().unwrap(), "--json", "out"], RUN_DEADLINE);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    let t = text(&out);
    assert!(t.contains("out") && t.contains("folder"), "{t}");
    assert!(!t.contains("one-overtake::"), "the suite ran before the output was refused: {t}");
    assert!(dir.join("out").is_dir());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_numbers_are_refused_naming_the_flag_and_the_range() {
    let dir = temp_dir("numbers");
    let scenes = dir.to_str().unwrap();
    let cases: [(&[&str], &str); 10] = [
        (&["evaluate", "--scenes", scenes, "--seeds", "0"], "--seeds"),
        (&["evaluate", "--scenes", scenes, "--horizon-s", "nan"], "--horizon-s"),
        (&["evaluate", "--scenes", scenes, "--horizon-s", "-1"], "--horizon-s"),
        (&["evaluate", "--scenes", scenes, "--trust-region", "0"], "--trust-region"),
        (&["realism", "--scenes", scenes, "--rollouts", "0"], "--rollouts"),
        (&["realism", "--scenes", scenes, "--top-k", "0"], "--top-k"),
        (&["realism", "--scenes", scenes, "--temperature", "0"], "--temperature"),
        (&["realism", "--scenes", scenes, "--temperature", "nan"], "--temperature"),
        (&["bench", "--repeat", "0"], "--repeat"),
        (&["prior-dataset", "--shard-size", "0"], "--shard-size"),
    ];
    for (args, flag) in cases {
        let out = safer_in(&dir, &[], args, Duration::from_secs(30));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "`safer {}` was accepted: {}", args.join(" "), text(&out));
        assert!(stderr.contains(flag), "`safer {}` did not name {flag}: {stderr}", args.join(" "));
        assert!(stderr.contains("invalid value"), "`safer {}`: {stderr}", args.join(" "));
    }
    // The accepted range is part of the message.
    let out = safer_in(&dir, &[], &["evaluate", "--scenes", scenes, "--seeds", "0"], Duration::from_secs(30));
    assert!(String::from_utf8_lossy(&out.stderr).contains("1.."), "{}", text(&out));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_data_folder_is_safer_data_dir_and_nothing_else() {
    let dir = temp_dir("data-dir");
    let data = dir.join("my-data");
    std::fs::create_dir(&data).unwrap();
    let scene =
        Path::new(repo_root!()).join("tests/fixtures/bad-input/hangs/folder-with-one-bad-scene/a-good-scene.json");
    std::fs::copy(&scene, data.join("a-good-scene.json")).unwrap();
    // Run from an unrelated folder: the default must not depend on it.
    let out = safer_in(&dir, &[("SAFER_DATA_DIR", &data)], &["bench", "--repeat", "1"], Duration::from_secs(120));
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let row = stdout.lines().find(|l| l.starts_with("womd-json")).unwrap_or_else(|| panic!("{}", text(&out)));
    assert_eq!(row.split_whitespace().nth(1), Some("1"), "one scene expected: {row}");

    // A missing data folder is an error naming the folder SAFER_DATA_DIR chose.
    let missing = dir.join("no-such-data");
    let out = safer_in(&dir, &[("SAFER_DATA_DIR", &missing)], &["bench", "--repeat", "1"], Duration::from_secs(60));
    assert!(!out.status.success(), "{}", text(&out));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no-such-data"), "{}", text(&out));

    // Set but empty is unset, and unset is no folder at all: not the
    // current one, not one guessed beside the project.
    let shared = "data:commonroad-ngsim/USA_US101-4_3_T-1.xml";
    let out = safer_in(&dir, &[("SAFER_DATA_DIR", Path::new(""))], &["inspect", shared], Duration::from_secs(60));
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("SAFER_DATA_DIR is not set"), "{}", text(&out));
    std::fs::remove_dir_all(&dir).ok();
}

/// The shipped NGSIM scene with its first `from` replaced by `to`, as
/// `name` in a fresh folder; `safer inspect` on it must refuse it with
/// `message`.
fn edited_ngsim_scene_is_refused(name: &str, from: &str, to: &str, message: &str) {
    let shipped = Path::new(repo_root!()).join("scenes/ngsim/USA_US101-4_3_T-1.xml");
    let scene = std::fs::read_to_string(shipped).unwrap();
    assert!(scene.contains(from), "{from}");
    let dir = temp_dir(name);
    let file = dir.join(name);
    std::fs::write(&file, scene.replacen(from, to, 1)).unwrap();
    let out = safer_within(&["inspect", file.to_str().unwrap()], Duration::from_secs(30));
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains(message), "{}", text(&out));
    assert!(text(&out).lines().all(|l| l.len() < 400), "a line too long: {}", text(&out));
}

/// 1e300 in a CommonRoad file was printed as a 301-digit number, and a
/// time step of 1e300 s was accepted; both now read `1e300`, in one short
/// line.
#[test]
fn numbers_of_1e300_in_a_recorded_scene_are_refused_in_a_short_line() {
    let cases = [
        ("x.xml", "<x>-40.54872163</x>", "<x>1e300</x>", "(1e300, 40.24680481) is more than 1e7 m from the origin"),
        ("v.xml", "<exact>16.322</exact>", "<exact>1e300</exact>", "m/s is outside the simulation bounds (±1000 m/s)"),
        ("w.xml", "<width>2.1031</width>", "<width>1e300</width>", "has size 4.7244 x 1e300 m"),
        (
            "dt.xml",
            "timeStepSize=\"0.1\"",
            "timeStepSize=\"1e300\"",
            "timeStepSize 1e300 s is not a recording's time step",
        ),
    ];
    for (name, from, to, message) in cases {
        edited_ngsim_scene_is_refused(name, from, to, message);
    }
}

#[test]
fn a_recorded_scene_with_two_tracks_of_one_id_is_refused_naming_the_id() {
    // Obstacle 375 renamed 373: the ego or the CBV could share an id with
    // another track.
    edited_ngsim_scene_is_refused(
        "two-tracks-with-id-373.xml",
        "<dynamicObstacle id=\"375\"",
        "<dynamicObstacle id=\"373\"",
        "agent 373: two tracks have this id",
    );
}

#[test]
fn an_evaluation_with_one_scenario_id_in_two_files_is_refused_naming_both() {
    let dir = temp_dir("same-id");
    let scene = Path::new(repo_root!()).join("scenes/ngsim/USA_US101-4_3_T-1.xml");
    std::fs::copy(&scene, dir.join("a.xml")).unwrap();
    std::fs::copy(&scene, dir.join("copy-of-a.xml")).unwrap();
    let out = safer_within(&["evaluate", "--scenes", dir.to_str().unwrap(), "--seeds", "1"], Duration::from_secs(60));
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    let t = text(&out);
    assert!(t.contains("scenario id `USA_US101-4_3_T-1` is in both") && t.contains("copy-of-a.xml"), "{t}");
}

#[test]
fn a_horizon_beyond_the_recording_is_the_whole_recording() {
    // 1e19 s once overflowed into an empty step range.
    let out = safer_within(
        &["evaluate", "--scenes", "scenes/ngsim", "--seeds", "1", "--methods", "log", "--horizon-s", "1e19"],
        Duration::from_secs(120),
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let t = text(&out);
    assert!(!t.contains("error:"), "{t}");
    assert!(t.lines().any(|l| l.starts_with("log ") && l.split_whitespace().nth(2) == Some("0")), "no errors: {t}");
}

#[test]
fn a_recorded_agent_longer_than_any_road_vehicle_is_refused_at_import() {
    // One vehicle 1e20 m long.
    edited_ngsim_scene_is_refused(
        "a-vehicle-1e20-m-long.xml",
        "<length>4.7244",
        "<length>1e20",
        "beyond the 100 m an agent's box may have",
    );
}

/// Runs `safer ARGS | true` from the repository (the reader gone before
/// the table is printed) and returns safer's own exit status.
fn safer_into_a_closed_pipe(args: &str) -> std::process::Output {
    let script = format!("'{}' {args} | true; exit ${{PIPESTATUS[0]}}", env!("CARGO_BIN_EXE_safer"));
    std::process::Command::new("bash").args(["-c", &script]).current_dir(repo_root!()).output().expect("run bash")
}

#[test]
fn a_closed_standard_output_does_not_cost_the_file_report() {
    // `safer evaluate --json F | true`: the report file is written first
    // and the run succeeds.
    let dir = temp_dir("closed-stdout");
    let report = dir.join("report.json");
    let out = safer_into_a_closed_pipe(&format!(
        "evaluate --scenes scenes/ngsim --seeds 1 --methods log --json '{}'",
        report.display()
    ));
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).expect("the report")).unwrap();
    assert_eq!(json["scenes"], 3);
    // `safer run` the same, with both file reports.
    let (json_out, junit_out) = (dir.join("run.json"), dir.join("run.xml"));
    let out = safer_into_a_closed_pipe(&format!(
        "run specs/suites/authored.yaml --json '{}' --junit '{}'",
        json_out.display(),
        junit_out.display()
    ));
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(json_out.is_file() && junit_out.is_file());
}

/// A WOMD TFRecord shard holds many scenes; a suite listing it ran only the
/// first. Two shipped single-scene files, concatenated, are a valid
/// two-record shard: the suite runs both (named `STEM-SCENARIO_ID`), each
/// variant on its own scene, and `limit` counts scenes.
#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn a_suite_over_a_tfrecord_shard_runs_every_scene_it_holds() {
    use safer_scenarios::harness::{Suite, run_variant};
    let dir = temp_dir("shard");
    let data = crate::shared_data::data_dir().join("womd-tfrecord");
    let mut shard = Vec::new();
    for f in ["womd_scenario_input.tfrecord", "motion_data_one_scenario.tfrecord"] {
        shard.extend(std::fs::read(data.join(f)).unwrap_or_else(|e| panic!("{f}: {e}")));
    }
    std::fs::write(dir.join("shard.tfrecord"), shard).unwrap();
    let suite_text = |limit: &str| {
        format!(
            "name: shard\nscenarios:\n  - {{ recorded: shard.tfrecord{limit} }}\nplanner: {{ builtin: constant-velocity }}\n\
             adversary: {{ method: log }}\nvariants: 1\nacceptance:\n  variant: {{ no_collision: false }}\n"
        )
    };
    std::fs::write(dir.join("shard.suite.yaml"), suite_text("")).unwrap();
    let suite = Suite::load(&dir.join("shard.suite.yaml")).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = suite.scenarios.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["shard-ee519cf571686d19", "shard-637f20cafde22ff8"]);
    for (scenario, id) in suite.scenarios.iter().zip(["ee519cf571686d19", "637f20cafde22ff8"]) {
        let outcome = run_variant(&suite, scenario, 0).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(outcome.stage2.scenario_id, id);
    }
    std::fs::write(dir.join("shard.suite.yaml"), suite_text(", limit: 1")).unwrap();
    let suite = Suite::load(&dir.join("shard.suite.yaml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(suite.scenarios.len(), 1);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A TFRecord holding one Scenario twice: `run` refuses it, and
/// `evaluate` counted the scene twice; it now refuses it naming the records.
#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn an_evaluation_over_a_tfrecord_holding_one_scene_twice_is_refused_naming_the_records() {
    let dir = temp_dir("twice");
    let one = crate::shared_data::data_dir().join("womd-tfrecord/womd_scenario_input.tfrecord");
    let record = std::fs::read(&one).unwrap_or_else(|e| panic!("{}: {e}", one.display()));
    std::fs::create_dir(dir.join("scenes")).unwrap();
    std::fs::write(dir.join("scenes/twice.tfrecord"), [record.clone(), record].concat()).unwrap();
    let out =
        safer_in(&dir, &[], &["evaluate", "--scenes", "scenes", "--seeds", "1", "--methods", "log"], RUN_DEADLINE);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("scenario id `ee519cf571686d19` is in scenes/twice.tfrecord twice (records 0 and 1)"), "{t}");
}

#[test]
fn a_recorded_heading_of_1e300_rad_is_refused_at_import() {
    // It wrapped into an arbitrary angle and was accepted.
    edited_ngsim_scene_is_refused(
        "a-heading-of-1e300-rad.xml",
        "<exact>-0.74444</exact>",
        "<exact>1e300</exact>",
        "heading 1e300 rad is not a plausible angle",
    );
}

/// A WOMD JSON scene with the ego named by `metadata.sdc_track_index`, and
/// the same scene with a copy of the ego appended under another id.
fn scene_with_ego_twin(dir: &Path) {
    let scene =
        Path::new(repo_root!()).join("tests/fixtures/bad-input/hangs/folder-with-one-bad-scene/a-good-scene.json");
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(scene).unwrap()).unwrap();
    v["metadata"] = serde_json::json!({ "sdc_track_index": 0 });
    std::fs::write(dir.join("plain.json"), serde_json::to_vec(&v).unwrap()).unwrap();
    let twin = v["objects"][0].clone();
    v["objects"].as_array_mut().unwrap().push(twin);
    std::fs::write(dir.join("twin.json"), serde_json::to_vec(&v).unwrap()).unwrap();
    for name in ["plain", "twin"] {
        std::fs::write(
            dir.join(format!("{name}.yaml")),
            format!(
                "name: {name}\nscenarios:\n  - recorded: {name}.json\nplanner: {{ builtin: idm }}\nvariants: 1\n\
                 acceptance:\n  variant:\n    no_collision: true\n"
            ),
        )
        .unwrap();
    }
}

#[test]
fn a_recorded_twin_of_the_ego_is_refused_and_never_excuses_a_collision() {
    let dir = temp_dir("ego-twin");
    scene_with_ego_twin(&dir);
    let plain = safer_in(&dir, &[], &["run", "plain.yaml"], RUN_DEADLINE);
    assert!(plain.status.code().is_some_and(|c| c < 2), "{}", text(&plain));
    let twin = safer_in(&dir, &[], &["run", "twin.yaml"], RUN_DEADLINE);
    let said = text(&twin);
    assert_eq!(twin.status.code(), Some(1), "{said}");
    assert!(said.contains("the recorded ego overlaps agent"), "{said}");
    assert!(!said.contains("generator's fault"), "{said}");
    assert!(!said.contains("panicked"), "{said}");
}

#[test]
fn an_evaluation_of_a_missing_folder_says_it_is_missing() {
    // It said "no scene with both an ego and a CBV".
    let out = safer_within(&["evaluate", "--scenes", "/no/such/scenes", "--seeds", "1"], Duration::from_secs(30));
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("no such file or folder: /no/such/scenes"), "{}", text(&out));
}
