//! Failure shrinking in `safer run`: each failing variant comes with the
//! smallest deviation from the logged CBV that fails the same way, no larger
//! than the variant, found within the budget, the same on every run; its
//! recording and picture are shown first, the variant as made beside them;
//! `--no-shrink` turns it off.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

fn run(args: &[&str], json: &Path) -> Value {
    let suite = Path::new(repo_root!()).join("tests/fixtures/shrink/constant-velocity-under-safer.yaml");
    let out = Command::new(env!("CARGO_BIN_EXE_safer"))
        .arg("run")
        .arg(&suite)
        .args(args)
        .arg("--json")
        .arg(json)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "some variants fail: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}

/// Each failing variant's summary.
fn failing(report: &Value) -> Vec<Value> {
    let text = report.to_string();
    let mut found = Vec::new();
    fn walk(v: &Value, found: &mut Vec<Value>) {
        match v {
            Value::Object(m) => {
                if m.get("passed") == Some(&Value::Bool(false)) && m.contains_key("shrunk") {
                    found.push(v.clone());
                }
                m.values().for_each(|x| walk(x, found));
            }
            Value::Array(a) => a.iter().for_each(|x| walk(x, found)),
            _ => {}
        }
    }
    walk(report, &mut found);
    assert!(!found.is_empty(), "no failing variant in {text}");
    found
}

#[test]
fn failing_variants_are_shrunk_deterministically_within_the_budget() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("shrink");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let artefacts: PathBuf = dir.join("artefacts");
    let first = run(&["--artifacts", artefacts.to_str().unwrap()], &dir.join("a.json"));
    let variants = failing(&first);
    let mut shrunk_some = false;
    for v in &variants {
        let s = &v["shrunk"];
        assert!(s.is_object(), "every failing variant here is shrunk: {v}");
        let tokens = s["adversarial_tokens"].as_array().unwrap();
        let (before, after) = (tokens[0].as_u64().unwrap(), tokens[1].as_u64().unwrap());
        assert!(after <= before, "{v}");
        shrunk_some |= after < before;
        assert!(s["candidates"].as_u64().unwrap() <= 16, "{v}");
        // The same way: the shrunk variant's first failure is the variant's criterion.
        let criterion = |text: &str| text.split(':').next().unwrap_or_default().to_string();
        assert_eq!(criterion(s["failure"].as_str().unwrap()), criterion(v["failures"][0].as_str().unwrap()));
        let name = v["variant"].as_str().unwrap().replace("::", "/");
        for suffix in ["mcap", "svg", "unshrunk.mcap", "unshrunk.svg"] {
            let f = artefacts.join(format!("{name}.{suffix}"));
            assert!(f.is_file(), "{} missing", f.display());
        }
    }
    assert!(shrunk_some, "no variant lost an adversarial token: {variants:?}");
    // Deterministic.
    let again = failing(&run(&[], &dir.join("b.json")));
    assert_eq!(
        again.iter().map(|v| v["shrunk"].clone()).collect::<Vec<_>>(),
        variants.iter().map(|v| v["shrunk"].clone()).collect::<Vec<_>>()
    );
    // Bounded, and off when asked.
    for v in failing(&run(&["--shrink-budget", "2"], &dir.join("c.json"))) {
        assert!(v["shrunk"].is_null() || v["shrunk"]["candidates"].as_u64().unwrap() <= 2, "{v}");
    }
    for v in failing(&run(&["--no-shrink"], &dir.join("d.json"))) {
        assert!(v["shrunk"].is_null(), "{v}");
    }
}
