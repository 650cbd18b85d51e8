//! `safer run --export-commonroad DIR`: failing variants written as
//! CommonRoad 2020a scenarios that safer's own importer reads back, a
//! recorded CommonRoad scene's with the source's road, ids, frame and time;
//! `--export-commonroad-all` writes every variant. (CI also reads them with
//! commonroad-io and commonroad-drivability-checker:
//! `.ci/check-commonroad-export.py`.)

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
    let shown = only_failing.iter().filter(|f| !f.to_string_lossy().ends_with(".unshrunk.xml")).count();
    assert!(stderr.contains(&format!("CommonRoad scenarios: {shown} written")), "{stderr}");
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

/// A variant of a shipped NGSIM scene: the export holds the source's
/// lanelets (ids and bounds), its obstacles under their ids at the source's
/// time steps and in its frame, and a sidecar with the ego's size; a shrunk
/// variant is exported as shown with the unshrunk one beside it.
#[test]
fn a_recorded_ngsim_variant_is_exported_in_the_sources_terms() {
    let root = Path::new(repo_root!());
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("commonroad-export-ngsim");
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).unwrap();
    let source = root.join("scenes/ngsim/USA_US101-4_3_T-1.xml");
    let suite = out.join("ngsim.yaml");
    std::fs::write(
        &suite,
        format!(
            "name: ngsim\nscenarios:\n  - recorded: {}\nplanner: {{ builtin: constant-velocity }}\n\
             adversary: {{ method: safer, trust_region: 20, background: log-replay }}\nvariants: 1\n\
             acceptance:\n  variant: {{ no_collision: true, no_off_road: true, min_gap_m: 3.0 }}\n",
            source.display()
        ),
    )
    .unwrap();
    let dir = out.join("export");
    let run = Command::new(env!("CARGO_BIN_EXE_safer"))
        .args(["run", suite.to_str().unwrap(), "--artifacts"])
        .arg(out.join("artefacts"))
        .arg("--export-commonroad")
        .arg(&dir)
        .arg("--export-commonroad-all")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.code().is_some_and(|c| c < 2), "{stderr}");
    let files = exported(&dir);
    let shown = files.iter().find(|f| !f.to_string_lossy().ends_with(".unshrunk.xml")).expect("an export");
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(shown.with_extension("commonroad.json")).unwrap()).unwrap();
    assert_eq!(sidecar["map"], "copied", "{sidecar}");
    assert!(sidecar["ego"]["length_m"].as_f64().unwrap() > 3.0, "{sidecar}");
    // The constant-velocity planner fails this variant (too close a gap):
    // the shrunk variant is the one shown, the unshrunk one beside it.
    let unshrunk = shown.with_extension("unshrunk.xml");
    assert_eq!(sidecar["shrunk"], true, "{stderr}");
    assert!(unshrunk.exists(), "{files:?}");
    let beside: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(unshrunk.with_extension("commonroad.json")).unwrap()).unwrap();
    assert_eq!(beside["shrunk"], false);
    assert!(std::fs::read_to_string(&unshrunk).unwrap().contains("author=\"safer\""));

    // Both read as CommonRoad; the source's lanelets and obstacles come
    // back unchanged, in its frame; the export's time step t is the
    // source's t + source_first_time_step.
    let export = import::commonroad::parse(&std::fs::read(shown).unwrap(), shown).unwrap();
    let recorded = import::commonroad::parse(&std::fs::read(&source).unwrap(), &source).unwrap();
    let ids = |s: &safer_scenarios::scenario::Scenario| s.map.lanes.iter().map(|l| l.id).collect::<Vec<_>>();
    assert_eq!(ids(&export), ids(&recorded));
    for (a, b) in export.map.lanes.iter().zip(&recorded.map.lanes) {
        assert_eq!(a.left_boundary, b.left_boundary, "lanelet {:?}", a.id);
        assert_eq!(a.right_boundary, b.right_boundary, "lanelet {:?}", a.id);
    }
    let first = sidecar["source_first_time_step"].as_u64().unwrap() as usize;
    let cbv = sidecar["cbv"]["source_id"].as_str().unwrap_or("");
    let mut compared = 0;
    for track in export.tracks.iter().filter(|t| t.id.0 != cbv) {
        let theirs = recorded.tracks.iter().find(|t| t.id == track.id).expect("a source obstacle id");
        if let (Some(a), Some(b)) = (track.state(0), theirs.state(first)) {
            assert!((a.position - b.position).norm() < 1e-6, "obstacle {} at time step {first}", track.id);
            compared += 1;
        }
    }
    assert!(compared > 10, "{compared} obstacles compared");
}
