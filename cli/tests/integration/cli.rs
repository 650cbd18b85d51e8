//! The `safer` binary end to end: what a user sees.

use std::path::Path;
use std::process::Command;

use crate::shared_data::data_dir;

fn safer(args: &[&str]) -> std::process::Output {
    // From the repository's root, as a user runs it.
    Command::new(env!("CARGO_BIN_EXE_safer")).args(args).current_dir(repo_root!()).output().expect("run safer")
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn inspect_json_reports_format_roles_and_map() {
    let file = data_dir().join("womd-tfrecord/motion_data_one_scenario.tfrecord");
    let out = safer(&["inspect", file.to_str().unwrap(), "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let s = &v[0];
    assert_eq!(s["format"], "womd-proto");
    assert_eq!(s["agents"], 83);
    assert_eq!(s["steps"], 91);
    assert_eq!(s["current_step"], 10);
    assert_eq!(s["map"]["lanes"], 199);
    // WOMD flags no intersection lanes: these are the lanes that cross
    // another at a junction's angle.
    assert_eq!(s["map"]["junction_lanes"], 37);
    assert_eq!(s["ego"]["assigned_by"], "source");
    assert!(s["cbv"]["id"].is_string());
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn simulate_prints_a_row_per_scene_and_a_total() {
    let dir = data_dir().join("womd-tfrecord");
    let out = safer(&["simulate", dir.to_str().unwrap(), "--planner", "idm"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("637f20cafde22ff8") && text.contains("ee519cf571686d19"), "{text}");
    assert!(text.contains("2 rollouts:"), "{text}");
}

/// `simulate --planner` takes a planner spec file as `run` and `evaluate`
/// do: the protocol-1.2 lane follower drives a shipped NGSIM scene, and a
/// name that is neither is refused saying what it takes.
#[test]
fn simulate_drives_a_scene_with_a_planner_spec_file() {
    let scene = Path::new(repo_root!()).join("scenes/ngsim/USA_US101-15_1_T-1.xml");
    let spec = Path::new(repo_root!()).join("planners/lane-follower.yaml");
    let out = safer(&["simulate", scene.to_str().unwrap(), "--planner", spec.to_str().unwrap(), "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(rows[0]["scenario"], "USA_US101-15_1_T-1");
    assert_eq!(rows[0]["planner"], "lane-follower", "{rows}");
    assert!(rows[0]["steps"].as_u64().unwrap() > 10, "{rows}");
    let out = safer(&["simulate", scene.to_str().unwrap(), "--planner", "no-such-planner"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("neither a built-in planner") && err.contains("nor a planner spec file"), "{err}");
}

#[test]
fn a_corrupt_file_is_an_error_naming_it_not_a_panic() {
    let dir = crate::scratch::Scratch::new("cli-test");
    let bad = dir.join("broken.tfrecord");
    std::fs::write(&bad, b"\x10\x00\x00\x00\x00\x00\x00\x00garbage").unwrap();
    let out = safer(&["inspect", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("broken.tfrecord"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let unknown = dir.join("notes.txt");
    std::fs::write(&unknown, "hello").unwrap();
    let out = safer(&["inspect", unknown.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a scenario file"));
    // A path that is not there says so, whatever its name.
    for missing in [dir.join("no-such-set"), dir.join("no-such-scene.json")] {
        let out = safer(&["inspect", missing.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains("no such file or folder") && !err.contains("not a scenario file"), "{err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn feasibility_eval_writes_its_figures_as_json_and_nothing_into_docs_unless_asked() {
    let dir = crate::scratch::Scratch::new("feasibility-eval");
    let recorded = data_dir().join("commonroad-ngsim");
    let out = Command::new(env!("CARGO_BIN_EXE_safer"))
        .current_dir(&dir)
        .env("SAFER_MODELS", concat!(repo_root!(), "/models"))
        .args(["feasibility-eval", "--recorded", recorded.to_str().unwrap()])
        .args(["--synthetic-scenes", "2", "--states", "40", "--json", "-"])
        .output()
        .expect("run safer");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(v["split"], "held-out");
    assert_eq!(v["states"], 40);
    for key in ["precision", "recall", "accuracy"] {
        assert!(v[key].is_null() || (0.0..=1.0).contains(&v[key].as_f64().unwrap()), "{key}: {}", v[key]);
    }
    assert!(v["mean_vh"].as_f64().is_some_and(f64::is_finite), "{}", v["mean_vh"]);
    let cells = ["true_infeasible", "false_infeasible", "missed_infeasible", "true_feasible"];
    let scored: u64 = cells.iter().map(|c| v["at_zero"][c].as_u64().unwrap()).sum();
    assert_eq!(scored + v["unscored"].as_u64().unwrap(), 40);
    // The table went to stderr, and no picture was drawn anywhere.
    assert!(String::from_utf8_lossy(&out.stderr).contains("held-out states: 40"));
    let written: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(written.is_empty(), "feasibility-eval wrote {written:?} without --svg");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn feasibility_eval_writes_the_labelled_states_for_calibration() {
    let dir = crate::scratch::Scratch::new("feasibility-labels");
    let labels = dir.join("labels.safetensors");
    let recorded = data_dir().join("commonroad-ngsim");
    let out = Command::new(env!("CARGO_BIN_EXE_safer"))
        .env("SAFER_MODELS", concat!(repo_root!(), "/models"))
        .args(["feasibility-eval", "--recorded", recorded.to_str().unwrap(), "--split", "train"])
        .args(["--synthetic-scenes", "2", "--states", "40", "--json", "-", "--labels", labels.to_str().unwrap()])
        .output()
        .expect("run safer");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let bytes = std::fs::read(&labels).expect("labels written");
    let (_, meta) = safetensors::SafeTensors::read_metadata(&bytes).unwrap();
    assert_eq!(meta.metadata().as_ref().and_then(|m| m.get("split")).map(String::as_str), Some("\"train\""));
    let file = safetensors::SafeTensors::deserialize(&bytes).unwrap();
    let column = |name: &str| {
        let t = file.tensor(name).unwrap();
        let values: Vec<f32> = t.data().chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        (t.shape().to_vec(), values)
    };
    let (state_shape, _) = column("state");
    assert_eq!(state_shape, vec![40, 13]);
    let (found_shape, found) = column("witness_found");
    assert_eq!(found_shape, vec![40]);
    assert!(found.iter().all(|f| *f == 0.0 || *f == 1.0), "{found:?}");
    // The file's labels are the report's: its infeasible states are the ones without a witness.
    let infeasible =
        v["at_zero"]["true_infeasible"].as_u64().unwrap() + v["at_zero"]["missed_infeasible"].as_u64().unwrap();
    assert_eq!(found.iter().filter(|f| **f == 0.0).count() as u64, infeasible);
    let (_, value) = column("value");
    assert!(value.iter().all(|x| x.is_finite()));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn realism_scores_the_shipped_prior_unless_told_otherwise() {
    // One rollout of one shipped NGSIM scene: the report names the policy it scored.
    let scene = concat!(repo_root!(), "/scenes/ngsim/USA_US101-4_3_T-1.xml");
    let out = safer(&["realism", "--scenes", scene, "--rollouts", "1"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("realism, policy prior,"), "{text}");
}

#[test]
fn jobs_beyond_the_bound_are_refused_naming_the_range() {
    for command in [&["run", "specs/suites/authored.yaml"][..], &["evaluate", "--scenes", "scenes/ngsim"][..]] {
        let mut args = command.to_vec();
        args.extend(["--jobs", "10000"]);
        let out = safer(&args);
        assert_eq!(out.status.code(), Some(2));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains("10000 is not in 1..=256"), "{stderr}");
    }
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn prior_dataset_refuses_non_commercial_scenes_unless_the_model_is_for_evaluation_only() {
    let scratch = crate::scratch::Scratch::new("prior-dataset-purpose");
    let dir = scratch.join("shards");
    let recorded = data_dir().join("womd-tfrecord");
    let run = |extra: &[&str]| {
        safer(
            &[
                &["prior-dataset", "--recorded", recorded.to_str().unwrap(), "--out", dir.to_str().unwrap()],
                &["--template-scenes", "1", "--recorded-map-scenes", "0", "--force"][..],
                extra,
            ]
            .concat(),
        )
    };
    // Shards already there survive a refused run, even with --force.
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("shard-000.safetensors"), b"earlier shards").unwrap();
    let refused = run(&[]);
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(err.contains("womd") && err.to_lowercase().contains("licen"), "{err}");
    let typo = run(&["--evaluation-only", "--t-junction-share", "2"]);
    assert_eq!(typo.status.code(), Some(2));
    let err = String::from_utf8_lossy(&typo.stderr);
    assert!(err.contains("--t-junction-share must be a share in [0, 1], got 2"), "{err}");
    let typo = run(&["--evaluation-only", "--pedestrian-share=-0.5"]);
    assert_eq!(typo.status.code(), Some(2));
    let err = String::from_utf8_lossy(&typo.stderr);
    assert!(err.contains("--pedestrian-share must be a share in [0, 1], got -0.5"), "{err}");
    let typo = run(&["--evaluation-only", "--right-turn-lane-share", "1.5"]);
    assert_eq!(typo.status.code(), Some(2));
    let err = String::from_utf8_lossy(&typo.stderr);
    assert!(err.contains("--right-turn-lane-share must be a share in [0, 1], got 1.5"), "{err}");
    assert_eq!(std::fs::read(dir.join("shard-000.safetensors")).unwrap(), b"earlier shards");

    let out = run(&["--evaluation-only"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let bytes = std::fs::read(dir.join("shard-000.safetensors")).expect("a shard");
    let (_, meta) = safetensors::SafeTensors::read_metadata(&bytes).unwrap();
    let meta = meta.metadata().as_ref().unwrap();
    assert_eq!(meta["purpose"], "evaluation-only");
    assert!(meta["scenes"].contains("\"source\":\"recorded-evaluation-only\""), "{}", meta["scenes"]);
    assert!(meta["recipe"].contains("token drift"), "{}", meta["recipe"]);
    // The arguments that remake the data, every one written out (the
    // model card's command names them), without the output folder.
    assert_eq!(meta["contract_version"], "2");
    let arguments = &meta["arguments"];
    for part in [
        "--template-scenes 1 ",
        "--recorded-map-scenes 0 ",
        "--pedestrian-share 0 ",
        "--token-drift 0.3 ",
        "--evaluation-only",
    ] {
        assert!(arguments.contains(part), "{part:?} not in {arguments}");
    }
    // The shared data folder's scenes are named as a user names them.
    assert!(arguments.starts_with("--recorded data:womd-tfrecord "), "{arguments}");
    assert!(!arguments.contains("--out") && !arguments.contains("--force"), "{arguments}");
}

#[test]
fn prior_fit_scores_both_history_alignments_names_unreadable_files_and_refuses_a_negative_speed() {
    let scene = concat!(repo_root!(), "/scenes/ngsim/USA_US101-15_1_T-1.xml");
    let out = safer(&["prior-fit", "--scenes", scene]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}{}", String::from_utf8_lossy(&out.stderr));
    let rows: Vec<Vec<&str>> = text
        .lines()
        .filter(|l| l.starts_with("at boundary") || l.starts_with("one step late"))
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert_eq!(rows.len(), 6, "{text}");
    // "at boundary all N NLL ...": the same samples both ways, and a NLL
    // below the uniform distribution's 8.29 nats.
    let samples = |r: &Vec<&str>| r[r.len() - 6].parse::<usize>().unwrap();
    assert!(samples(&rows[0]) > 20 && samples(&rows[0]) == samples(&rows[3]), "{text}");
    assert!(rows[0][rows[0].len() - 5].parse::<f64>().unwrap() < 8.29, "{text}");
    // The JSON report carries the same rows, and each scene's sums.
    let out = safer(&["prior-fit", "--scenes", scene, "--json", "-"]);
    assert!(out.status.success());
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let json_rows = report["rows"].as_array().unwrap();
    assert_eq!(json_rows.len(), 6);
    assert_eq!(json_rows[0]["history"], "at-boundary");
    assert_eq!(json_rows[0]["samples"].as_u64().unwrap() as usize, samples(&rows[0]));
    assert_eq!(report["per_scene"][0]["at_boundary"]["samples"].as_u64().unwrap() as usize, samples(&rows[0]));
    assert!(text.contains("recorded tokens that turn") && text.contains("6+ bins"), "{text}");
    // Every recorded turn and turn onset falls in one bucket of how far the
    // top n miss it, and the table says how many there are.
    for (kind, label) in [("turning", "turning "), ("turn_onset", "turn onset ")] {
        let samples = json_rows[0][kind]["samples"].as_u64().unwrap();
        assert!(samples > 0 && samples <= json_rows[0]["samples"].as_u64().unwrap(), "{}", json_rows[0]);
        let shares = json_rows[0][kind]["yaw_rate_miss_shares"].as_array().unwrap();
        let total: f64 = shares.iter().map(|s| s.as_f64().unwrap()).sum();
        assert!(shares.len() == 4 && (total - 1.0).abs() < 1e-9, "{}", json_rows[0]);
        let row = text.lines().find(|l| l.starts_with(label) && l.contains(" all ")).unwrap();
        assert!(row.split_whitespace().any(|w| w == samples.to_string()), "{row}");
    }
    // A file that does not load is named, the others are scored, and the
    // run fails.
    let dir = crate::scratch::Scratch::new("prior-fit");
    std::fs::copy(scene, dir.join("good.xml")).unwrap();
    std::fs::write(dir.join("broken.xml"), "<commonRoad>").unwrap();
    let out = safer(&["prior-fit", "--scenes", dir.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("broken.xml") && !err.contains("panicked"), "{err}");
    assert!(String::from_utf8_lossy(&out.stdout).contains(&format!(" {} ", samples(&rows[0]))));
    let out = safer(&["prior-fit", "--scenes", scene, "--min-speed-mps", "-1"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--min-speed-mps"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
