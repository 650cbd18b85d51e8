//! `safer trust-region`: the trust region's profile at the CBV's token
//! boundaries, from the prior's logits decoded again over the stage-1
//! rollout. The logits must be the ones the adversary saw: wherever the
//! region held a plausible token, the token the CBV then drove is found in
//! it.

use std::path::Path;
use std::process::Command;

use serde_json::Value;

#[test]
fn the_profiled_region_holds_the_token_the_adversary_drove() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("trust-region");
    std::fs::create_dir_all(&dir).unwrap();
    let json = dir.join("profile.json");
    let scenes = Path::new(repo_root!()).join("scenes/ngsim");
    let out = Command::new(env!("CARGO_BIN_EXE_safer"))
        .args(["trust-region", "--scenes", scenes.to_str().unwrap(), "--seeds", "2", "--json"])
        .arg(&json)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("behaviours") && table.contains("no-mda"), "{table}");
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let boundaries = report["boundaries"].as_array().unwrap();
    let engaged: Vec<&Value> = boundaries.iter().filter(|b| b["engaged"] == true).collect();
    assert!(engaged.len() > 30, "{} engaged boundaries", engaged.len());
    let mut checked = 0;
    for b in &engaged {
        let p = &b["profile"];
        assert_eq!(p["tokens"], 20);
        let mass = p["probability_mass"].as_f64().unwrap();
        assert!(mass > 0.0 && mass <= 1.0 + 1e-12, "{b}");
        let (tokens, plausible, behaviours) = (20, p["plausible"].as_u64().unwrap(), p["behaviours"].as_u64().unwrap());
        assert!(plausible <= tokens && (1..=tokens).contains(&behaviours), "{b}");
        let next = boundaries.iter().any(|n| {
            n["scenario"] == b["scenario"]
                && n["method"] == b["method"]
                && n["seed"] == b["seed"]
                && n["step"].as_u64() == b["step"].as_u64().map(|s| s + 5)
        });
        if next && plausible > 0 {
            assert!(b["driven_rank"].as_u64().is_some_and(|r| r < 20), "the driven token is not in the region: {b}");
            checked += 1;
        }
    }
    assert!(checked > 20, "only {checked} boundaries checked");
    for row in report["summary"].as_array().unwrap() {
        assert!(row["boundaries"].as_u64().unwrap() > 0, "{row}");
    }
}
