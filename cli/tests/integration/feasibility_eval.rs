//! `safer feasibility-eval`'s breakdowns on the shipped NGSIM scenes: the
//! per-band, per-conflict-kind and per-heading tables partition the states,
//! so each adds up to the whole table, for states from the feasibility
//! collection's episodes and from an adversary's stage-1 rollouts.

use std::process::Command;

use serde_json::Value;

const CELLS: [&str; 5] = ["true_infeasible", "false_infeasible", "missed_infeasible", "true_feasible", "unscored"];

/// Runs `safer feasibility-eval` on `scenes/ngsim` (all three scenes, no
/// synthetic ones) with `args`, and returns its JSON report.
fn report(args: &[&str]) -> Value {
    let out = Command::new(env!("CARGO_BIN_EXE_safer"))
        .env("SAFER_MODELS", concat!(repo_root!(), "/models"))
        .args(["feasibility-eval", "--scenes", concat!(repo_root!(), "/scenes/ngsim")])
        .args(["--synthetic-scenes", "0", "--split", "all", "--json", "-"])
        .args(args)
        .output()
        .expect("run safer");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

/// Checks that the rows of `breakdown` add up, cell by cell, to the whole
/// table; returns the number of rows.
fn rows_add_up(v: &Value, breakdown: &str) -> usize {
    let rows = v[breakdown].as_array().unwrap_or_else(|| panic!("{breakdown} missing: {v}"));
    for cell in CELLS {
        let sum: u64 = rows.iter().map(|r| r[cell].as_u64().unwrap()).sum();
        assert_eq!(sum, v["at_zero"][cell].as_u64().unwrap(), "{breakdown}: {cell}");
    }
    for r in rows {
        let (tp, fp) = (r["true_infeasible"].as_u64().unwrap(), r["false_infeasible"].as_u64().unwrap());
        match r["escaped_share"].as_f64() {
            Some(share) => assert!((share - fp as f64 / (tp + fp) as f64).abs() < 1e-12, "{r}"),
            None => assert_eq!(tp + fp, 0, "{r}"),
        }
    }
    rows.len()
}

/// Checks the report's breakdowns and that it labelled some states.
fn check_breakdowns(v: &Value) {
    let scored: u64 = CELLS.iter().map(|c| v["at_zero"][c].as_u64().unwrap()).sum();
    assert_eq!(scored, v["states"].as_u64().unwrap());
    assert!(scored > 20, "only {scored} states");
    assert_eq!(rows_add_up(v, "by_distance"), 4);
    let bands: Vec<(&str, Option<f64>, Option<f64>)> = v["by_distance"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| (r["band"].as_str().unwrap(), r["from_m"].as_f64(), r["to_m"].as_f64()))
        .collect();
    assert_eq!(
        bands,
        vec![
            ("< 0.5 m", None, Some(0.5)),
            ("0.5–1 m", Some(0.5), Some(1.0)),
            ("1–3 m", Some(1.0), Some(3.0)),
            ("≥ 3 m", Some(3.0), None)
        ]
    );
    assert_eq!(rows_add_up(v, "by_heading"), 3);
    assert!(rows_add_up(v, "by_conflict_kind") >= 1);
    // The states spread over more than one band.
    let filled = v["by_distance"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| CELLS.iter().any(|c| r[c].as_u64().unwrap() > 0))
        .count();
    assert!(filled >= 2, "{}", v["by_distance"]);
}

#[test]
fn the_band_kind_and_heading_rows_add_up_to_the_whole_table_on_collection_states() {
    let v = report(&["--states", "400"]);
    assert_eq!(
        (v["states_from"].as_str(), v["split"].as_str(), v["scenes"].as_u64()),
        (Some("collection"), Some("all"), Some(3))
    );
    check_breakdowns(&v);
}

#[test]
fn stage1_states_of_an_adversary_are_labelled_against_its_cbv_future() {
    let v = report(&["--states-from", "safer", "--seeds", "2"]);
    assert_eq!(v["states_from"], "safer");
    // Three scenes, two stage-1 variants each, all run.
    assert_eq!((v["rollouts"].as_u64(), v["failed_rollouts"].as_u64()), (Some(6), Some(0)));
    check_breakdowns(&v);
    // The same variants again: the same figures (determinism).
    let again = report(&["--states-from", "safer", "--seeds", "2"]);
    assert_eq!(again["at_zero"], v["at_zero"]);
    assert_eq!(again["by_distance"], v["by_distance"]);
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn any_set_is_measured_but_only_a_trainable_one_is_written_as_calibration_labels() {
    let dir = crate::scratch::Scratch::new("feasibility-womd-labels");
    let womd = crate::shared_data::data_dir().join("womd-interactive");
    let run = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_safer"))
            .env("SAFER_MODELS", concat!(repo_root!(), "/models"))
            .args(["feasibility-eval", "--scenes", womd.to_str().unwrap(), "--synthetic-scenes", "0"])
            .args(["--split", "all", "--max-scenes", "2", "--states", "30", "--json", "-"])
            .args(extra)
            .output()
            .expect("run safer")
    };
    let measured = run(&[]);
    assert!(measured.status.success(), "{}", String::from_utf8_lossy(&measured.stderr));
    let v: Value = serde_json::from_slice(&measured.stdout).unwrap();
    assert_eq!(v["scenes"], 2);
    rows_add_up(&v, "by_distance");
    let labels = dir.join("labels.safetensors");
    let refused = run(&["--labels", labels.to_str().unwrap()]);
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(err.contains("does not allow training the shipped models"), "{err}");
    assert!(!labels.exists());
}
