//! `safer run --export-commonroad DIR`: failing variants written as
//! CommonRoad 2020a scenarios that safer's own importer reads back;
//! `--export-commonroad-all` writes every variant. (CI also reads them with
//! commonroad-io: `.ci/check-commonroad-export.py`.)

use std::path::Path;
use std::process::Command;

use safer_scenarios::scenario::import;

fn exported(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = walk(dir).into_iter().filter(|p| p.extension().is_some_and(|e| e == "xml")).collect();
    files.sort();
    files
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    entries.flatten().flat_map(|e| if e.path().is_dir() { walk(&e.path()) } else { vec![e.path()] }).collect()
}

#[test]
fn failing_variants_are_exported_and_read_back() {
    let root = Path::new(repo_root!());
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("commonroad-export");
    let _ = std::fs::remove_dir_all(&out);
    let (failing, all) = (out.join("failing"), out.join("all"));
    let suite = root.join("specs/examples/constant-velocity-fails.yaml");
    let run = |dir: &Path, every: bool| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_safer"));
        cmd.args(["run", suite.to_str().unwrap(), "--artifacts"]).arg(out.join("artefacts"));
        cmd.arg("--export-commonroad").arg(dir);
        if every {
            cmd.arg("--export-commonroad-all");
        }
        cmd.output().unwrap()
    };
    let red = run(&failing, false);
    assert!(!red.status.success(), "the example suite is meant to fail");
    let stderr = String::from_utf8_lossy(&red.stderr);
    let only_failing = exported(&failing);
    assert!(!only_failing.is_empty(), "{stderr}");
    assert!(stderr.contains(&format!("CommonRoad scenarios: {} written", only_failing.len())), "{stderr}");
    run(&all, true);
    let every = exported(&all);
    assert!(every.len() > only_failing.len(), "{} vs {}", every.len(), only_failing.len());
    for file in &every {
        let scene = import::load(file).unwrap_or_else(|e| panic!("{}: {e}", file.display())).remove(0);
        assert!(!scene.tracks.is_empty() && !scene.map.lanes.is_empty(), "{}", file.display());
    }
    // `--export-commonroad-all` alone is refused: it says which, not where.
    let alone = Command::new(env!("CARGO_BIN_EXE_safer"))
        .args(["run", suite.to_str().unwrap(), "--export-commonroad-all"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&alone.stderr);
    assert!(!alone.status.success() && err.contains("--export-commonroad <DIR>"), "{err}");
}
