//! `safer bench` and `safer bench-models` write their figures, each beside
//! its reference, as JSON; a missing training environment (the reference of
//! `bench-models`) is said in the JSON, not an error.

use std::process::Command;

use super::scratch::Scratch;
use super::shared_data;

/// The smallest shared WOMD JSON scene (it has an ego and a CBV).
fn small_scene() -> std::path::PathBuf {
    shared_data::files("womd-json", "json")
        .into_iter()
        .min_by_key(|p| (std::fs::metadata(p).map(|m| m.len()).unwrap_or(u64::MAX), p.clone()))
        .expect("files() is never empty")
}

fn read_json(path: &std::path::Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}\n{text}", path.display()))
}

/// `safer bench --repeat 1 EXTRA… --scenes SMALL --json OUT`, which must succeed.
fn bench_small_scene(extra: &[&str], out: &std::path::Path) -> std::process::Output {
    let run = Command::new(env!("CARGO_BIN_EXE_safer"))
        .args(["bench", "--repeat", "1"])
        .args(extra)
        .arg("--scenes")
        .arg(small_scene())
        .arg("--json")
        .arg(out)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    run
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn bench_writes_every_figure_beside_its_reference_as_json() {
    let dir = Scratch::new("bench-json");
    let out = dir.join("bench.json");
    let run = bench_small_scene(&[], &out);
    let v = read_json(&out);
    assert_eq!(v["repeat"], 1);
    let import = v["import"].as_array().expect("import rows");
    assert_eq!(import.len(), 1, "{import:?}");
    assert_eq!(import[0]["format"], "womd-json");
    assert!(import[0]["ratio_to_file_read"].as_f64().unwrap() > 0.0);
    let variant = &v["variant"];
    for key in ["stage1_ms", "stage1_models_ms", "stage2_ms", "stage2_planner_ms", "variant_ms", "witness_ms"] {
        assert!(variant[key].as_f64().is_some_and(|ms| ms > 0.0), "{key}: {variant}");
    }
    // The parts are parts (medians of the same runs).
    let ms = |key: &str| variant[key].as_f64().unwrap();
    assert!(ms("stage1_models_ms") <= ms("stage1_ms") && ms("stage2_planner_ms") <= ms("stage2_ms"), "{variant}");
    assert_eq!(variant["variant_target_ms"], 50.0);
    assert_eq!(variant["witness_target_ms"], 10.0);
    let ratio = variant["variant_ratio_to_target"].as_f64().unwrap();
    assert!((ratio - variant["variant_ms"].as_f64().unwrap() / 50.0).abs() < 1e-9, "{variant}");
    assert!(variant["witness_found"].is_boolean());
    // The variants beyond the paper are timed beside `safer`'s, over the
    // NGSIM suite's region too.
    for key in [
        "in_path_variant_ms",
        "in_path_wide_variant_ms",
        "cut_in_wide_variant_ms",
        "in_path_lookahead_variant_ms",
        "in_path_lookahead_wide_variant_ms",
        "in_path_lookahead_wide_not_from_behind_variant_ms",
        "safer_seeds_mean_ms",
        "in_path_wide_seeds_mean_ms",
        "in_path_lookahead_wide_not_from_behind_seeds_mean_ms",
        "in_path_lookahead_interactive_not_from_behind_seeds_mean_ms",
        "in_path_lookahead_shipped_seeds_mean_ms",
    ] {
        assert!(variant[key].as_f64().is_some_and(|ms| ms > 0.0), "{key}: {variant}");
    }
    // The shipped suites' methods over ten seeds too, and the lookahead as
    // WOMD interactive's tables run it, each ratio that of the two means.
    assert_eq!(variant["seeds_timed"], 10);
    for method in [
        "in_path_wide",
        "in_path_lookahead_wide_not_from_behind",
        "in_path_lookahead_interactive_not_from_behind",
        "in_path_lookahead_shipped",
    ] {
        let seeds_ratio = ms(&format!("{method}_seeds_mean_ms")) / ms("safer_seeds_mean_ms");
        let reported = variant[format!("{method}_seeds_ratio_to_safer")].as_f64().unwrap();
        assert!((reported - seeds_ratio).abs() < 1e-9, "{method}: {variant}");
    }
    assert_eq!(variant["in_path_wide_trust_region"], 60);
    assert_eq!(variant["in_path_lookahead_wide_trust_region"], 60);
    assert_eq!(variant["in_path_lookahead_interactive_trust_region"], 28);
    // The table still went to stdout; a WOMD JSON scene alone times no
    // simulator row, and the table says so rather than print an empty one.
    let table = String::from_utf8_lossy(&run.stdout);
    assert!(table.contains("SaFeR variant"), "{table}");
    assert!(table.contains("variant made by safer-cut-in, n = 60"), "{table}");
    assert!(table.contains("variant made by safer-in-path-lookahead"), "{table}");
    assert!(table.contains("variant made by safer-in-path-lookahead, n = 60"), "{table}");
    assert!(table.contains("variant made by safer-in-path-lookahead, n = 60, not-from-behind"), "{table}");
    assert!(table.contains("safer-in-path, n = 60, mean of seeds 0..10 / safer (same run)"), "{table}");
    assert!(table.contains("n = 60, not-from-behind, mean of seeds 0..10 / safer (same run)"), "{table}");
    assert!(table.contains("n = 28, not-from-behind, mean of seeds 0..10 / safer (same run)"), "{table}");
    assert!(table.contains("n = 60, not-from-behind, along-the-lanes, mean of seeds 0..10 / safer"), "{table}");
    assert_eq!(v["simulator"].as_array().map(Vec::len), Some(0), "{v}");
    assert!(table.contains("the simulator is not timed"), "{table}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn bench_against_a_baseline_build_gives_each_timed_figure_of_both_builds_and_their_ratio_by_round() {
    // This build as its own baseline: the comparison's bookkeeping is what
    // is tested, not a speed.
    let dir = Scratch::new("bench-baseline");
    let out = dir.join("against.json");
    let run = bench_small_scene(&["--rounds", "2", "--baseline", env!("CARGO_BIN_EXE_safer")], &out);
    let v = read_json(&out);
    assert_eq!((v["rounds"].as_u64(), v["repeat"].as_u64()), (Some(2), Some(1)));
    let figures = v["figures"].as_array().expect("figures");
    let labels: Vec<&str> = figures.iter().filter_map(|f| f["figure"].as_str()).collect();
    for want in
        ["import[womd-json].import_ms_per_scene", "variant.stage1_ms", "variant.stage2_ms", "variant.variant_ms"]
    {
        assert!(labels.contains(&want), "{want} missing from {labels:?}");
    }
    assert!(!labels.iter().any(|l| l.contains("target") || l.contains("ratio")), "{labels:?}");
    for f in figures {
        let side = |key: &str| -> Vec<f64> {
            f[key].as_array().unwrap().iter().map(|x| x.as_f64().expect("both builds report every figure")).collect()
        };
        let (baseline, this) = (side("baseline_ms"), side("this_ms"));
        assert_eq!((baseline.len(), this.len()), (2, 2), "{f}");
        // Two rounds: the median ratio is the mean of the two rounds' ratios.
        let ratios: Vec<f64> = baseline.iter().zip(&this).filter(|(b, _)| **b > 0.0).map(|(b, t)| t / b).collect();
        if ratios.len() == 2 {
            let median = f["ratio_median"].as_f64().unwrap();
            assert!((median - 0.5 * (ratios[0] + ratios[1])).abs() < 1e-9, "{f}");
            // (serde_json's default float parsing may be off in the last bit.)
            assert!((f["ratio_min"].as_f64().unwrap() - ratios[0].min(ratios[1])).abs() < 1e-9, "{f}");
        }
    }
    assert_eq!(labels[..2], ["variant.variant_ms", "variant.stage1_ms"], "the headline first, its parts under it");
    let table = String::from_utf8_lossy(&run.stdout);
    assert!(table.contains("this ÷ baseline") && table.contains("variant.variant_ms"), "{table}");
    // Both builds ran in both rounds, the first round baseline first.
    let stderr = String::from_utf8_lossy(&run.stderr);
    let order: Vec<&str> = stderr.lines().filter(|l| l.starts_with("round ")).collect();
    assert_eq!(order.len(), 4, "{stderr}");
    assert!(order[0].contains("baseline build") && order[1].contains("this build"), "{order:?}");
    assert!(order[2].contains("this build") && order[3].contains("baseline build"), "{order:?}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn a_baseline_named_without_a_folder_is_the_file_in_the_working_folder_not_one_on_path() {
    let dir = Scratch::new("bench-baseline-bare-name");
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_safer"), dir.join("safer-before")).unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_safer"))
        .current_dir(&dir)
        .env("PATH", "/nonexistent")
        .args(["bench", "--repeat", "1", "--rounds", "1", "--baseline", "safer-before", "--scenes"])
        .arg(small_scene())
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(String::from_utf8_lossy(&run.stdout).contains("variant.variant_ms"));
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn a_baseline_that_is_missing_or_not_a_safer_build_is_an_error_naming_it() {
    let dir = Scratch::new("bench-baseline-bad");
    let missing = dir.join("no-such-safer");
    // `true` takes any arguments, succeeds and writes no report.
    for (baseline, says) in
        [(missing.as_path(), "no such file"), (std::path::Path::new("/bin/true"), "wrote no report")]
    {
        let run = Command::new(env!("CARGO_BIN_EXE_safer"))
            .args(["bench", "--repeat", "1", "--rounds", "1", "--baseline"])
            .arg(baseline)
            .arg("--scenes")
            .arg(small_scene())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(&format!("--baseline {}", baseline.display())) && stderr.contains(says), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    // --rounds means nothing without a baseline.
    let run = Command::new(env!("CARGO_BIN_EXE_safer")).args(["bench", "--rounds", "3"]).output().unwrap();
    assert_eq!(run.status.code(), Some(2), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(String::from_utf8_lossy(&run.stderr).contains("--baseline"));
}

/// `safer bench-models` on the small scene with `python` as the reference's
/// interpreter, from the crate root (where the reference scripts are).
fn bench_models(python: &std::path::Path, repeat: &str, out: &std::path::Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_safer"))
        .current_dir(repo_root!())
        .args(["bench-models", "--repeat", repeat, "--python"])
        .arg(python)
        .arg("--scenes")
        .arg(small_scene())
        .arg("--json")
        .arg(out)
        .output()
        .unwrap()
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn bench_models_json_says_plainly_when_the_reference_is_missing() {
    let dir = Scratch::new("bench-models-no-reference");
    let out = dir.join("models.json");
    let run = bench_models(&dir.join("no-such-python"), "1", &out);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let v = read_json(&out);
    for key in ["map_encoding_us", "cbv_query_us", "full_scene_step_us", "decoder_batch_1_us", "decoder_scene_batch_us"]
    {
        assert!(v["tract"][key].as_f64().is_some_and(|us| us > 0.0), "{key}: {v}");
    }
    assert_eq!(v["reference"]["available"], false);
    let why = v["reference"]["missing_because"].as_str().expect("a reason");
    assert!(why.contains("not installed") && why.contains("no-such-python"), "{why}");
    assert!(String::from_utf8_lossy(&run.stdout).contains("no reference in this run"));
}

/// Ignored by default (it needs the training environment); `.ci/run` runs it
/// with `--ignored` where `training/.venv` exists, and a missing
/// environment then fails it.
#[test]
#[ignore = "needs the training environment (training/.venv or $SAFER_TRAINING_PYTHON); run with -- --ignored"]
fn bench_models_json_carries_the_reference_ratios_when_the_training_environment_exists() {
    // `$SAFER_TRAINING_PYTHON` names an environment installed elsewhere
    // (another checkout's training/.venv).
    let python = std::env::var_os("SAFER_TRAINING_PYTHON")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::Path::new(repo_root!()).join("training/.venv/bin/python"));
    assert!(python.exists(), "{} is not installed (see training/README.md)", python.display());
    let dir = Scratch::new("bench-models-reference");
    let out = dir.join("models.json");
    let run = bench_models(&python, "2", &out);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let v = read_json(&out);
    assert_eq!(v["reference"]["available"], true, "{v}");
    let rows = v["reference"]["rows"].as_array().unwrap();
    assert!(rows.iter().any(|r| r["engine"] == "onnxruntime"), "{rows:?}");
    for r in rows {
        let (ours, theirs) = (r["tract_us"].as_f64().unwrap(), r["reference_us"].as_f64().unwrap());
        assert!((r["ratio"].as_f64().unwrap() - ours / theirs).abs() < 1e-9, "{r}");
    }
    // PyTorch either gave figures or the report says why not.
    let torch_rows = rows.iter().any(|r| r["engine"] == "torch");
    let torch_missing = v["reference"]["torch_missing_because"].as_str();
    assert!(torch_rows != torch_missing.is_some(), "{v}");
    if let Some(why) = torch_missing {
        assert!(String::from_utf8_lossy(&run.stdout).contains(why), "the table says why: {why}");
    }
}
