//! The `safer` binary end to end: what a user sees.

use std::process::Command;

use crate::shared_data::data_dir;

fn safer(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_safer")).args(args).output().expect("run safer")
}

#[test]
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
    assert_eq!(s["ego"]["assigned_by"], "source");
    assert!(s["cbv"]["id"].is_string());
}

#[test]
fn simulate_prints_a_row_per_scene_and_a_total() {
    let dir = data_dir().join("womd-tfrecord");
    let out = safer(&["simulate", dir.to_str().unwrap(), "--planner", "idm"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("637f20cafde22ff8") && text.contains("ee519cf571686d19"), "{text}");
    assert!(text.contains("2 rollouts:"), "{text}");
}

#[test]
fn a_corrupt_file_is_an_error_naming_it_not_a_panic() {
    let dir = std::env::temp_dir().join(format!("safer-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
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
    std::fs::remove_dir_all(&dir).ok();
}
