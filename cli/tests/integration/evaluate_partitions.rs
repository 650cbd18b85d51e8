//! `safer evaluate --partition K/N` and `safer evaluate-merge`: the parts
//! of an evaluation, run apart and merged, give the table and report one
//! run gives; and `--artifacts` leaves a failing variant's recording,
//! picture and collision record behind.

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

fn safer(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_safer")).args(args).output().expect("run safer")
}

fn ok(out: Output) -> String {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("UTF-8 table")
}

/// The table without what the clock decides: the `s/variant` column of
/// the first table and the time-profile table.
fn without_times(table: &str) -> String {
    let mut kept = Vec::new();
    let mut in_first_table = false;
    let mut in_profile = false;
    for line in table.lines() {
        if line.starts_with("method") && line.ends_with("s/variant") {
            in_first_table = true;
        } else if line.is_empty() {
            in_first_table = false;
        }
        if line.starts_with("where the time goes") {
            in_profile = true;
        } else if line.starts_with("VJ/AJ:") {
            in_profile = false;
        }
        if in_profile {
            continue;
        }
        let line = if in_first_table { line.rsplit_once(' ').map_or(line, |(head, _)| head) } else { line };
        kept.push(line.to_string());
    }
    kept.join("\n")
}

/// A report without what the clock decides (times, profiles, latencies)
/// and without where artefacts went.
fn report_without_times(path: &Path) -> Value {
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    fn strip(v: &mut Value) {
        match v {
            Value::Object(map) => {
                for key in ["time_s", "time_per_variant_s", "profile", "planner_latency", "artefacts", "partition"] {
                    map.remove(key);
                }
                map.values_mut().for_each(strip);
            }
            Value::Array(items) => items.iter_mut().for_each(strip),
            _ => {}
        }
    }
    strip(&mut v);
    v
}

#[test]
fn an_evaluation_run_in_three_parts_and_merged_is_the_one_run() {
    let out = tempfile_dir("partitions");
    let scenes = Path::new(repo_root!()).join("scenes/ngsim");
    let common =
        ["evaluate", "--scenes", scenes.to_str().unwrap(), "--methods", "safer,log", "--seeds", "2", "--jobs", "2"];
    let run = |extra: &[&str]| safer(&[&common[..], extra].concat());
    let whole = out.join("whole.json");
    let whole_table = ok(run(&["--json", whole.to_str().unwrap()]));
    let mut parts = Vec::new();
    for k in 1..=3 {
        let part = out.join(format!("part-{k}.json"));
        let partition = format!("{k}/3");
        let out = run(&["--partition", &partition, "--json", part.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        ok(out);
        assert!(stderr.contains(&format!("partition {k}/3: 1 of 3 scenes")), "{stderr}");
        // Off a terminal, progress comes as plain lines.
        assert!(stderr.contains("evaluate: 4/4 variants done"), "{stderr}");
        parts.push(part);
    }
    let merged = out.join("merged.json");
    // In another order than the parts' numbers: the merge sorts.
    let order = [&parts[2], &parts[0], &parts[1]].map(|p| p.to_str().unwrap());
    let merged_table = ok(safer(&[&["evaluate-merge"][..], &order, &["--json", merged.to_str().unwrap()]].concat()));
    assert_eq!(without_times(&merged_table), without_times(&whole_table));
    assert!(merged_table.starts_with("3 scenes × 2 seeds"), "{merged_table}");
    assert_eq!(report_without_times(&merged), report_without_times(&whole));
    let report = report_without_times(&whole);
    assert_eq!(report["variants"].as_array().unwrap().len(), 12);
    assert!(report["variants"][0]["tally"].is_object(), "the tallies travel with the report");

    // Parts missing, given twice, or of another evaluation are refused.
    let two = safer(&["evaluate-merge", order[0], order[1]]);
    let text = String::from_utf8_lossy(&two.stderr);
    assert!(!two.status.success() && text.contains("partitions 2/3 are missing"), "{text}");
    let twice = safer(&["evaluate-merge", order[0], order[0], order[1], order[2]]);
    let text = String::from_utf8_lossy(&twice.stderr);
    assert!(!twice.status.success() && text.contains("are both partition 3/3"), "{text}");
    let other = out.join("other.json");
    ok(safer(&[&common[..], &["--seed", "7", "--partition", "1/3", "--json", other.to_str().unwrap()]].concat()));
    let mixed = safer(&["evaluate-merge", other.to_str().unwrap(), order[0], order[2]]);
    let text = String::from_utf8_lossy(&mixed.stderr);
    assert!(!mixed.status.success() && text.contains("parts of different evaluations"), "{text}");
    let paper = out.join("paper.json");
    ok(safer(
        &[&common[..], &["--approach-phase", "none", "--partition", "1/3", "--json", paper.to_str().unwrap()]].concat(),
    ));
    let mixed = safer(&["evaluate-merge", paper.to_str().unwrap(), order[0], order[2]]);
    let text = String::from_utf8_lossy(&mixed.stderr);
    assert!(!mixed.status.success() && text.contains("approach: \"none\" against"), "{text}");
    assert!(!text.contains("EvaluationSettings"), "no debug dump: {text}");
    // A part of the same split of another folder.
    let elsewhere = out.join("elsewhere");
    std::fs::create_dir(&elsewhere).unwrap();
    for f in ["USA_US101-15_1_T-1.xml", "USA_US101-21_2_T-1.xml"] {
        std::fs::copy(scenes.join(f), elsewhere.join(f)).unwrap();
    }
    let foreign = out.join("foreign.json");
    let mut foreign_run = common.to_vec();
    foreign_run[2] = elsewhere.to_str().unwrap();
    ok(safer(&[&foreign_run[..], &["--partition", "1/3", "--json", foreign.to_str().unwrap()]].concat()));
    let mixed = safer(&["evaluate-merge", foreign.to_str().unwrap(), order[0], order[2]]);
    let text = String::from_utf8_lossy(&mixed.stderr);
    assert!(!mixed.status.success() && text.contains("split different scene lists"), "{text}");
    // Parts edited: a scene counted in two parts, a variants list emptied.
    let edited = |k: usize, tag: &str, edit: &dyn Fn(&mut Value)| {
        let mut v: Value = serde_json::from_str(&std::fs::read_to_string(&parts[k]).unwrap()).unwrap();
        edit(&mut v);
        let path = out.join(format!("{tag}.json"));
        std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
        path
    };
    let part_1: Value = serde_json::from_str(&std::fs::read_to_string(&parts[0]).unwrap()).unwrap();
    let doubled = edited(1, "doubled", &|v| {
        v["scene_list"]["ids"].as_array_mut().unwrap().insert(0, part_1["scene_list"]["ids"][0].clone());
        v["variants"].as_array_mut().unwrap().extend(part_1["variants"].as_array().unwrap().iter().cloned());
    });
    let merged = safer(&["evaluate-merge", parts[0].to_str().unwrap(), doubled.to_str().unwrap(), order[0]]);
    let text = String::from_utf8_lossy(&merged.stderr);
    assert!(!merged.status.success() && text.contains("scenario `USA_US101-15_1_T-1` is in both"), "{text}");
    let short = edited(1, "short", &|v| {
        v["scene_list"]["ids"].as_array_mut().unwrap().insert(0, part_1["scene_list"]["ids"][0].clone());
    });
    let merged = safer(&["evaluate-merge", parts[0].to_str().unwrap(), short.to_str().unwrap(), order[0]]);
    let text = String::from_utf8_lossy(&merged.stderr);
    assert!(!merged.status.success() && text.contains("holds 4 variants (4 distinct), where 2 scenes"), "{text}");
    let emptied = edited(1, "emptied", &|v| v["variants"] = Value::Array(Vec::new()));
    let merged = safer(&["evaluate-merge", parts[0].to_str().unwrap(), emptied.to_str().unwrap(), order[0]]);
    let text = String::from_utf8_lossy(&merged.stderr);
    assert!(!merged.status.success() && text.contains("holds 0 variants (0 distinct), where 1 scenes"), "{text}");
    let unpartitioned = safer(&["evaluate-merge", whole.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&unpartitioned.stderr);
    assert!(!unpartitioned.status.success() && text.contains("not a partition's report"), "{text}");
    let bad = safer(&[&common[..], &["--partition", "4/3"]].concat());
    let text = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && text.contains("from 1 to the number of parts"), "{text}");
}

#[test]
fn an_evaluation_of_named_scenes_makes_the_variants_the_whole_evaluation_makes_of_them() {
    let out = tempfile_dir("named-scenes");
    let scenes = Path::new(repo_root!()).join("scenes/ngsim");
    let common =
        ["evaluate", "--scenes", scenes.to_str().unwrap(), "--methods", "safer,prior", "--seeds", "2", "--jobs", "2"];
    let run = |extra: &[&str]| safer(&[&common[..], extra].concat());
    let whole = out.join("whole.json");
    ok(run(&["--json", whole.to_str().unwrap()]));
    let whole = report_without_times(&whole);
    let ids: std::collections::BTreeSet<&str> =
        whole["variants"].as_array().unwrap().iter().map(|v| v["scenario"].as_str().unwrap()).collect();
    assert_eq!(ids.len(), 3, "{ids:?}");
    // The last scene by id: its place in the list changes, its variants must not.
    let last = *ids.iter().next_back().unwrap();
    let named = out.join("named.json");
    let table = ok(run(&["--scene", last, "--json", named.to_str().unwrap()]));
    assert!(table.starts_with("1 scenes × 2 seeds"), "{table}");
    let named = report_without_times(&named);
    let of_last = |report: &Value| -> Vec<Value> {
        report["variants"].as_array().unwrap().iter().filter(|v| v["scenario"] == last).cloned().collect()
    };
    assert_eq!(of_last(&named).len(), 4);
    assert_eq!(of_last(&named), of_last(&whole));
    assert_eq!(named["variants"].as_array().unwrap().len(), 4, "only the named scene runs");
    assert_eq!(named["settings"]["only_scenes"], serde_json::json!([last]));

    // An id no scene has is an error naming it; the first N and named ids do not mix.
    let missing = run(&["--scene", &format!("{last},no-such-scene")]);
    let text = String::from_utf8_lossy(&missing.stderr);
    assert!(!missing.status.success() && text.contains("--scene no-such-scene: no scene"), "{text}");
    let both = run(&["--scene", last, "--max-scenes", "1"]);
    let text = String::from_utf8_lossy(&both.stderr);
    assert!(!both.status.success() && text.contains("cannot be used with"), "{text}");
}

#[test]
fn evaluate_writes_a_failing_variants_artefacts_and_whom_it_hit() {
    let out = tempfile_dir("artefacts");
    let scenes = Path::new(repo_root!()).join("scenes/ngsim");
    let json = out.join("report.json");
    let artefacts = out.join("artefacts");
    // Log replay in stage 2: every stage-1 collision replays into a failure.
    ok(safer(&[
        "evaluate",
        "--scenes",
        scenes.to_str().unwrap(),
        "--methods",
        "safer",
        "--seeds",
        "4",
        "--planner",
        "log-replay",
        "--jobs",
        "2",
        "--json",
        json.to_str().unwrap(),
        "--artifacts",
        artefacts.to_str().unwrap(),
    ]));
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let variants = report["variants"].as_array().unwrap();
    let failing: Vec<&Value> = variants.iter().filter(|v| v["stage2"]["verdict"] != "solved").collect();
    assert!(!failing.is_empty(), "log replay fails no SaFeR variant of the shipped scenes");
    for v in &failing {
        let files: Vec<&str> = v["artefacts"].as_array().unwrap().iter().map(|f| f.as_str().unwrap()).collect();
        assert!(files.iter().any(|f| f.ends_with(".mcap")) && files.iter().any(|f| f.ends_with(".svg")), "{v}");
        // Stage 1 beside the planner's run: the conflict as the adversary
        // made it, the CBV against the ego replaying its log.
        let stage1 =
            files.iter().find(|f| f.ends_with(".stage1.svg")).unwrap_or_else(|| panic!("no stage-1 picture: {v}"));
        assert!(files.iter().any(|f| f.ends_with(".stage1.mcap")), "no stage-1 recording: {v}");
        let picture = std::fs::read_to_string(stage1).unwrap();
        assert!(picture.contains("planner log-replay"), "{stage1} does not show stage 1");
        if v["stage1_collision"] == true {
            assert!(picture.contains("collides with the CBV"), "{stage1} does not show the stage-1 collision");
        }
        // The stage-1 collision's feasibility witness is drawn where one was found.
        let escape = picture.contains("feasibility witness: an escape keeping") && picture.contains("as they drove");
        assert_eq!(escape, v["witness"] == true, "{stage1}: witness {}", v["witness"]);
        for f in &files {
            assert!(std::fs::metadata(f).unwrap().len() > 0, "{f} is empty");
            let expected = format!("artefacts/safer/{}/seed-{}.", v["scenario"].as_str().unwrap(), v["seed"]);
            assert!(f.contains(&expected), "{f} is not under {expected}");
        }
        if v["stage2_collision"] == true {
            let contact = &v["stage2_contact"];
            assert!(contact["other"].is_string() && contact["at_fault"].is_boolean(), "{v}");
        }
    }
    for v in variants.iter().filter(|v| v["stage2"]["verdict"] == "solved") {
        assert!(v.get("artefacts").is_none(), "a solved variant has no artefacts: {v}");
    }
}

#[test]
fn evaluate_writes_every_variants_artefacts_when_asked_and_refuses_the_choice_alone() {
    let out = tempfile_dir("artefacts-all");
    let scenes = Path::new(repo_root!()).join("scenes/ngsim");
    let json = out.join("report.json");
    let artefacts = out.join("artefacts");
    let args = |extra: &[&'static str]| -> Vec<String> {
        let mut a: Vec<String> = [
            "evaluate",
            "--scenes",
            scenes.to_str().unwrap(),
            "--methods",
            "log",
            "--seeds",
            "1",
            "--jobs",
            "2",
            "--json",
            json.to_str().unwrap(),
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let run = |a: Vec<String>| safer(&a.iter().map(String::as_str).collect::<Vec<_>>());
    // The recorded CBV against the evasive planner: solved variants, which
    // the default writes nothing for.
    let dir = artefacts.to_str().unwrap().to_string();
    let mut with_all = args(&["--artifacts-of", "all", "--artifacts"]);
    with_all.push(dir);
    ok(run(with_all));
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let variants = report["variants"].as_array().unwrap();
    assert!(variants.iter().any(|v| v["stage2"]["verdict"] == "solved"), "no solved variant to check");
    for v in variants {
        let files: Vec<&str> = v["artefacts"].as_array().unwrap().iter().map(|f| f.as_str().unwrap()).collect();
        assert!(files.iter().any(|f| f.ends_with(".svg")) && files.iter().any(|f| f.ends_with(".mcap")), "{v}");
    }
    let alone = run(args(&["--artifacts-of", "all"]));
    let text = String::from_utf8_lossy(&alone.stderr);
    assert!(!alone.status.success() && text.contains("--artifacts"), "{text}");
}

/// A fresh folder for one test's files under the target folder.
fn tempfile_dir(name: &str) -> std::path::PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("evaluate-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn the_table_names_whom_the_ego_hit_as_the_json_report_does_and_progress_says_what_runs() {
    let out = tempfile_dir("contacts");
    let scenes = Path::new(repo_root!()).join("scenes/ngsim");
    let json = out.join("report.json");
    let run = safer(&[
        "evaluate",
        "--scenes",
        scenes.to_str().unwrap(),
        "--methods",
        "safer,log",
        "--stage2-cbv",
        "replay,closed-loop",
        "--seeds",
        "2",
        "--planner",
        "constant-velocity",
        "--jobs",
        "2",
        "--json",
        json.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr).to_string();
    let table = ok(run);
    // Progress names the stages before the variants and what each runs.
    assert!(stderr.contains("evaluate: loading the scenes under"), "{stderr}");
    assert!(stderr.contains("evaluate: each variant runs stage 1, stage 2 with `constant-velocity`"), "{stderr}");
    assert!(stderr.contains("evaluate: 24 variants to run"), "{stderr}");
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let variants = report["variants"].as_array().unwrap();
    let section = table.split("whom the planner's ego hit in stage 2").nth(1).expect("the contacts table");
    let mut named = 0;
    for row in report["rows"].as_array().unwrap() {
        let (method, mode) = (row["method"].as_str().unwrap(), row["stage2_cbv"].as_str().unwrap());
        let contacts: Vec<&Value> = variants
            .iter()
            .filter(|v| v["method"] == method && v["stage2_cbv"] == mode)
            .filter_map(|v| v["stage2_contact"].as_object().map(|_| v))
            .collect();
        let with_cbv = contacts.iter().filter(|v| v["stage2_contact"]["with_cbv"] == true).count();
        let line = section
            .lines()
            .find(|l| l.starts_with(&format!("{method} ({mode})")))
            .unwrap_or_else(|| panic!("no row {method} ({mode}) in {section}"));
        let cells: Vec<&str> = line.split_whitespace().collect();
        // method (mode) variants collided K/N most N (K at fault) M (J at fault)
        assert_eq!(cells[3], contacts.len().to_string(), "{line}");
        let of_row = |v: &&Value| v["method"] == method && v["stage2_cbv"] == mode;
        let scenes: std::collections::BTreeSet<&str> =
            variants.iter().filter(of_row).map(|v| v["scenario"].as_str().unwrap()).collect();
        let mut per_scene: std::collections::BTreeMap<&str, usize> = std::collections::BTreeMap::new();
        for v in &contacts {
            *per_scene.entry(v["scenario"].as_str().unwrap()).or_default() += 1;
        }
        assert_eq!(cells[4], format!("{}/{}", per_scene.len(), scenes.len()), "{line}");
        assert_eq!(cells[5], per_scene.values().max().copied().unwrap_or(0).to_string(), "{line}");
        assert_eq!(cells[6], with_cbv.to_string(), "{line}");
        for v in contacts.iter().take(3) {
            let c = &v["stage2_contact"];
            let who = format!(
                "{} seed {}: agent {}",
                v["scenario"].as_str().unwrap(),
                v["seed"],
                c["other"].as_str().unwrap()
            );
            assert!(section.contains(&who), "{who} not in {section}");
            named += 1;
        }
    }
    assert!(named > 0, "constant velocity hits someone on these scenes: {table}");
    // The failures beside log replay's, in words.
    assert!(table.contains("planner failures beside log replay's "), "{table}");
    assert!(!table.contains(" = —"), "{table}");
    // Where the critical conflicts met the planner: the table's counts are
    // the JSON report's, each critical variant in one band, and the first
    // two bands make reach-crit.
    let approach = table.split("the critical variants at the planner (stage 2").nth(1).expect("the approach table");
    let mut rows_with_critical = 0;
    for row in report["rows"].as_array().unwrap() {
        let c = &row["stage2_closest_critical"];
        if c.is_null() {
            continue;
        }
        rows_with_critical += 1;
        let (method, mode) = (row["method"].as_str().unwrap(), row["stage2_cbv"].as_str().unwrap());
        let bands = ["critical", "contact", "under_1_m", "other_collision_first", "under_2_m", "under_5_m", "farther"]
            .map(|k| c[k].as_u64().unwrap());
        let line = approach.lines().find(|l| l.starts_with(&format!("{method} ({mode})"))).expect("its row");
        let cells: Vec<u64> = line.split_whitespace().skip(2).take(7).map(|c| c.parse().unwrap()).collect();
        assert_eq!(cells, bands, "{line}");
        assert_eq!(bands[1..].iter().sum::<u64>(), bands[0], "{c}");
        let reach = (bands[1] + bands[2]) as f64 / bands[0] as f64;
        assert!((reach - row["conflict_reach_critical"].as_f64().unwrap()).abs() < 1e-9, "{row}");
        let critical = variants.iter().filter(|v| v["method"] == method && v["stage2_cbv"] == mode);
        assert_eq!(critical.filter(|v| v["tally"]["critical"] == true).count() as u64, bands[0], "{c}");
    }
    assert!(rows_with_critical > 0, "safer makes critical variants on these scenes: {table}");
}

#[test]
fn the_blind_twin_table_counts_the_cbv_blind_mutant_on_the_critical_variants_not_reached_as_the_report_does() {
    // The shipped freeway scenes with the ego's leader as the CBV: the
    // evasive planner keeps some of the critical conflicts beyond 1 m, and
    // a planner blind to the CBV is hit by some of those and not by others.
    let out = tempfile_dir("blind-twin");
    let scenes = Path::new(repo_root!()).join("scenes/ngsim");
    let json = out.join("report.json");
    let run = safer(&[
        "evaluate",
        "--scenes",
        scenes.to_str().unwrap(),
        "--roles",
        "leader",
        "--methods",
        "safer-in-path",
        "--trust-region",
        "60",
        "--stage2-cbv",
        "closed-loop",
        "--background",
        "reactive-log-replay",
        "--seeds",
        "3",
        "--mutants",
        "blind-cbv",
        "--json",
        json.to_str().unwrap(),
    ]);
    let table = ok(run);
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    // Counted from the variants: each critical variant the CBV did not
    // reach, by its stage-2 gap band, and whether the CBV-blind twin ran
    // and hit the CBV there.
    let mut counted = [(0u64, 0u64); 3];
    for v in report["variants"].as_array().unwrap() {
        let tally = &v["tally"];
        if tally["critical"] != true || tally["reached"] == true || tally["collided_with_other"] == true {
            continue;
        }
        let band = match v["stage2_min_gap_to_cbv_m"].as_f64() {
            Some(g) if g < 2.0 => 0,
            Some(g) if g < 5.0 => 1,
            _ => 2,
        };
        let twin = v["mutation"]["mutants"]
            .as_array()
            .into_iter()
            .flatten()
            .find(|m| m["operator"] == "blind-cbv" && m["error"].is_null());
        if let Some(twin) = twin {
            counted[band].0 += 1;
            counted[band].1 += u64::from(twin["hit_cbv"] == true);
        }
    }
    let (ran, hit) = counted.iter().fold((0, 0), |(r, h), &(ran, hit)| (r + ran, h + hit));
    assert!(hit > 0 && hit < ran, "the twin is hit in some of these and not in others: {counted:?}");
    let c = &report["rows"][0]["stage2_closest_critical"];
    for (key, (ran, hit)) in ["blind_twin_under_2_m", "blind_twin_under_5_m", "blind_twin_farther"].iter().zip(counted)
    {
        assert_eq!((c[key]["ran"].as_u64(), c[key]["hit"].as_u64()), (Some(ran), Some(hit)), "{key}: {c}");
    }
    // The table prints the same cells, and `met` adds the twin's hits to reach.
    let section = table.split("the critical variants not reached, by band").nth(1).expect("the blind twin table");
    let line = section.lines().find(|l| l.starts_with("safer-in-path ")).expect("its row");
    let cells: Vec<&str> = line.split_whitespace().skip(1).collect();
    let expected: Vec<String> = counted.iter().map(|(ran, hit)| format!("{hit}/{ran}")).collect();
    assert_eq!(cells[..3], expected[..], "{line}");
    let met = (c["contact"].as_u64().unwrap() + c["under_1_m"].as_u64().unwrap() + hit) as f64
        / c["critical"].as_u64().unwrap() as f64;
    assert_eq!(cells[3], format!("{met:.3}"), "{line}");
    // Under ten scenes nothing is held out: the held-out `met` is a dash.
    assert_eq!(cells[4..], ["|", "—"], "{line}");
}

#[test]
fn the_table_says_how_the_cbv_touched_the_recorded_ego_as_the_json_report_does() {
    let out = tempfile_dir("stage1-contacts");
    let scenes = Path::new(repo_root!()).join("scenes/ngsim");
    // The table's row of each first-contact category, and the report's
    // critical variants by the same category, for one ego-contact rule;
    // then the same of those whose CBV did not reach the planner's ego.
    let counts = |rule: &str| -> (Vec<usize>, Vec<usize>) {
        let json = out.join(format!("{rule}.json"));
        let table = ok(safer(&[
            "evaluate",
            "--scenes",
            scenes.to_str().unwrap(),
            "--methods",
            "safer-in-path-lookahead",
            "--trust-region",
            "60",
            "--seeds",
            "4",
            "--ego-contact",
            rule,
            "--jobs",
            "2",
            "--json",
            json.to_str().unwrap(),
        ]));
        let section = table.split("how the CBV touched the recorded ego (stage 1").nth(1).expect("the contacts table");
        let mut lines = section.lines().skip_while(|l| !l.starts_with("safer-in-path-lookahead"));
        let parse = |line: &str, label: &str| -> Vec<usize> {
            let rest = line.strip_prefix(label).unwrap_or_else(|| panic!("no {label:?} row: {line}"));
            rest.split_whitespace().map(|c| c.parse().unwrap()).collect()
        };
        let mut cells = parse(lines.next().expect("its row"), "safer-in-path-lookahead");
        // Without a critical variant there is nothing to reach: no row.
        let not_reached = match cells[0] {
            0 => vec![0; 6],
            _ => parse(lines.next().expect("the row of those not reached"), "  of them not reached"),
        };
        let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let variants = report["variants"].as_array().unwrap();
        let by_kind = |of: &dyn Fn(&Value) -> bool| -> Vec<usize> {
            let kinds = ["active-front", "active-lateral", "active-rear", "stopped-ego", "stopped-other"];
            let of: Vec<&Value> = variants.iter().filter(|v| of(v)).collect();
            let counts = kinds.iter().map(|kind| of.iter().filter(|v| v["stage1_contact"] == *kind).count());
            std::iter::once(of.len()).chain(counts).collect()
        };
        let mut reported = by_kind(&|v| v["stage1_collision"] == true);
        let critical_not_reached = by_kind(&|v| v["tally"]["critical"] == true && v["conflict_reached"] == false);
        assert_eq!(not_reached, critical_not_reached, "the table's not reached and the JSON report disagree");
        assert_eq!(not_reached[0], not_reached[1..].iter().sum::<usize>(), "{not_reached:?}");
        assert!(not_reached.iter().zip(&cells).all(|(n, all)| n <= all), "{not_reached:?} of {cells:?}");
        cells.extend(not_reached);
        reported.extend(critical_not_reached);
        (cells, reported)
    };
    let (any, any_reported) = counts("any");
    assert_eq!(any, any_reported, "the table and the JSON report disagree");
    // Every critical variant in one category, and a contact only in a
    // critical variant.
    assert_eq!(any[0], any[1..6].iter().sum::<usize>(), "{any:?}");
    assert!(any[0] > 0, "the lookahead makes conflicts on the shipped scenes: {any:?}");
    // On these scenes the paper's rule lets the lookahead's CBV run into
    // the ego from behind; kept from it, it never does.
    assert!(any[3] > 0, "no contact from behind with any contact allowed: {any:?}");
    // Replayed against the evasive planner, some of these conflicts reach
    // it and some do not: the row tells the two apart.
    assert!(any[6] > 0 && any[6] < any[0], "not reached {} of {} critical", any[6], any[0]);
    let (kept, kept_reported) = counts("not-from-behind");
    assert_eq!(kept, kept_reported, "the table and the JSON report disagree");
    assert_eq!(kept[0], kept[1..6].iter().sum::<usize>(), "{kept:?}");
    assert_eq!((kept[3], kept[4]), (0, 0), "{kept:?}");
}

/// `safer evaluate` of `methods` over 60 behaviours on the shipped NGSIM
/// scenes with `seeds` seeds: its table and its JSON report (written
/// under a scratch folder named `name`).
fn evaluate_shipped_ngsim(name: &str, methods: &[&str], seeds: u32) -> (String, Value) {
    evaluate_shipped_ngsim_with(name, methods, seeds, &[])
}

/// [`evaluate_shipped_ngsim`] with the options `extra` added.
fn evaluate_shipped_ngsim_with(name: &str, methods: &[&str], seeds: u32, extra: &[&str]) -> (String, Value) {
    let json = tempfile_dir(name).join("report.json");
    let scenes = Path::new(repo_root!()).join("scenes/ngsim");
    let (methods, seeds) = (methods.join(","), seeds.to_string());
    let args = [
        "evaluate",
        "--scenes",
        scenes.to_str().unwrap(),
        "--methods",
        &methods,
        "--trust-region",
        "60",
        "--seeds",
        &seeds,
        "--jobs",
        "2",
        "--json",
        json.to_str().unwrap(),
    ];
    let table = ok(safer(&[&args[..], extra].concat()));
    (table, serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap())
}

#[test]
fn a_turning_cost_makes_the_cbv_turn_more_gently_and_the_reports_say_so() {
    let peaks = |report: &Value| -> Vec<f64> {
        let variants = report["variants"].as_array().unwrap();
        let mut peaks: Vec<f64> = variants
            .iter()
            .filter_map(|v| v["tally"]["cbv"]["generated"]["peak_lateral_accel_mps2"].as_f64())
            .collect();
        assert_eq!(peaks.len(), variants.len(), "every variant's CBV has a peak");
        peaks.sort_by(f64::total_cmp);
        peaks
    };
    let (plain_table, plain) = evaluate_shipped_ngsim("turning-cost-none", &["safer-in-path"], 3);
    let (table, costed) = evaluate_shipped_ngsim_with("turning-cost", &["safer-in-path"], 3, &["--turning-cost", "1"]);
    // The shipped scenes' in-path CBVs peak at 4 m/s² at the median
    // without the cost; a turn worth more than its metres is not taken.
    let (plain_peaks, costed_peaks) = (peaks(&plain), peaks(&costed));
    let median = |p: &[f64]| p[p.len() / 2];
    assert!(
        median(&costed_peaks) < median(&plain_peaks) / 2.0,
        "with the cost {costed_peaks:?}, without {plain_peaks:?}"
    );
    assert!(table.lines().next().unwrap().ends_with("; a turn costing 1 m per m/s²"), "{table}");
    assert!(!plain_table.lines().next().unwrap().contains("a turn costing"), "{plain_table}");
    assert_eq!(costed["settings"]["turning_cost_m_per_mps2"].as_f64(), Some(1.0));
    assert!(plain["settings"].get("turning_cost_m_per_mps2").is_none(), "no cost, no key: older reports read alike");
    let scenes = Path::new(repo_root!()).join("scenes/ngsim");
    let refused = safer(&["evaluate", "--scenes", scenes.to_str().unwrap(), "--turning-cost", "5.5"]);
    let text = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success() && text.contains("outside the accepted range 0 <= x <= 5"), "{text}");
}

#[test]
fn the_table_gives_the_cr_by_where_the_cbv_starts_as_the_json_report_does() {
    let methods = ["safer", "safer-in-path"];
    let (table, report) = evaluate_shipped_ngsim("cbv-start", &methods, 3);
    let section = table.split("CR by where the CBV starts (").nth(1).expect("the CR-by-start table");
    let mut lines = section.lines().skip(1);
    let starts: Vec<String> = lines.next().expect("its header").split_whitespace().skip(1).map(str::to_owned).collect();
    assert!(!starts.is_empty(), "no start in the header");
    let variants = report["variants"].as_array().unwrap();
    for method in methods {
        let line = lines.clone().find(|l| l.split_whitespace().next() == Some(method)).expect("the method's row");
        let cells: Vec<&str> = line.split_whitespace().skip(1).collect();
        // From the variants: per start, the CR of the method's variants
        // and how many scenes start so.
        let from_variants: Vec<String> = starts
            .iter()
            .map(|start| {
                let so: Vec<&Value> = variants.iter().filter(|v| v["cbv_start"] == start.as_str()).collect();
                let mut scenes: Vec<&str> = so.iter().map(|v| v["scenario"].as_str().unwrap()).collect();
                scenes.sort_unstable();
                scenes.dedup();
                let of_method: Vec<&&Value> = so.iter().filter(|v| v["method"] == method).collect();
                let hits = of_method.iter().filter(|v| v["stage1_collision"] == true).count();
                format!("{:.3} ({})", hits as f64 / of_method.len() as f64, scenes.len())
            })
            .collect();
        let quoted: Vec<String> = cells.chunks(2).map(|c| c.join(" ")).collect();
        assert_eq!(quoted, from_variants, "{method}: the table and the report's variants disagree");
        // And the report's own split, start by start.
        let split = report["by_cbv_start"].as_array().unwrap();
        let reported: Vec<String> = split
            .iter()
            .map(|s| {
                let row = s["rows"].as_array().unwrap().iter().find(|r| r["method"] == method).unwrap();
                format!("{:.3} ({})", row["cr"].as_f64().unwrap(), s["scenes"])
            })
            .collect();
        assert_eq!(quoted, reported, "{method}: the table and the report's split disagree");
    }
    // Every variant of the shipped scenes has both roles at the start.
    assert!(variants.iter().all(|v| v["cbv_start"].is_string()), "a variant without the CBV's start");
}

/// Each scene's recorded lane changes in a `--json` report (every variant
/// of a scene carries the same), m/s.
fn recorded_lane_changes_by_scene(report: &Value) -> std::collections::BTreeMap<&str, Vec<f64>> {
    report["variants"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| {
            let speeds = v["recorded_lane_changes_mps"]
                .as_array()
                .map_or(Vec::new(), |a| a.iter().map(|x| x.as_f64().unwrap()).collect());
            (v["scenario"].as_str().unwrap(), speeds)
        })
        .collect()
}

#[test]
fn the_tables_give_the_cbvs_sideways_speed_and_turning_as_the_json_report_does_and_log_replay_matches_the_recording() {
    let methods = ["log", "safer-in-path"];
    let (table, report) = evaluate_shipped_ngsim("sideways", &methods, 2);
    let variants = report["variants"].as_array().unwrap();
    // Nearest-rank p50, p90 and the largest, as the table prints them.
    let spread = |mut v: Vec<f64>| -> Vec<String> {
        v.sort_by(f64::total_cmp);
        let rank = |p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
        let mut cells = vec![v.len().to_string()];
        cells.extend([rank(0.5), rank(0.9), v[v.len() - 1]].map(|x| format!("{x:.2}")));
        cells
    };
    // The table titled `title` against each variant's `figure` of the CBV
    // as generated and as logged, and the row's spread `row_field`.
    let beside_recorded = |title: &str, figure: &str, row_field: &str| {
        let section = table.split(title).nth(1).unwrap_or_else(|| panic!("the table {title:?}"));
        for method in methods {
            let line = section.lines().find(|l| l.split_whitespace().next() == Some(method)).expect("the method's row");
            let cells: Vec<&str> = line.split_whitespace().skip(1).filter(|c| *c != "|").collect();
            let figures = |which: &str| -> Vec<f64> {
                variants
                    .iter()
                    .filter(|v| v["method"] == method)
                    .filter_map(|v| v["tally"]["cbv"][which][figure].as_f64())
                    .collect()
            };
            let (generated, recorded) = (figures("generated"), figures("logged"));
            assert!(!generated.is_empty() && !recorded.is_empty(), "{method}: no variant measured {figure}");
            let mut from_variants = spread(generated.clone());
            from_variants.extend(spread(recorded.clone()));
            assert_eq!(cells, from_variants, "{method}: the table and the report's variants disagree on {figure}");
            let row = report["rows"].as_array().unwrap().iter().find(|r| r["method"] == method).unwrap();
            assert_eq!(row[row_field]["measured"], generated.len(), "{method}: the report's row {row_field}");
            if method == "log" {
                // Log replay drives the CBV as recorded: the same figures.
                assert_eq!(generated, recorded, "log replay's CBV: {figure} unlike the recording");
            }
        }
    };
    // How briskly the CBV moved across its lanes, and how hard it turned.
    beside_recorded("\nsideways speed of the CBV", "held_sideways_mps", "cbv_sideways");
    beside_recorded("\nlateral acceleration of the CBV", "peak_lateral_accel_mps2", "cbv_peak_lateral_accel_mps2");

    // The lane changes: the CBVs that changed lanes, beside every recorded
    // vehicle that did in the same scenes, each scene once.
    let section = table.split("\nlane changes: sideways speed").nth(1).expect("the lane-change table");
    let recorded_by_scene = recorded_lane_changes_by_scene(&report);
    let recorded: Vec<f64> = recorded_by_scene.values().flatten().copied().collect();
    assert!(!recorded.is_empty(), "no recorded vehicle changed lanes in the shipped NGSIM scenes");
    for method in methods {
        let line = section.lines().find(|l| l.split_whitespace().next() == Some(method)).expect("the method's row");
        let cells: Vec<&str> = line.split_whitespace().skip(1).filter(|c| *c != "|").collect();
        let changing: Vec<&Value> = variants
            .iter()
            .filter(|v| v["method"] == method && v["tally"]["cbv"]["generated"]["changed_lanes"] == true)
            .collect();
        let generated: Vec<f64> =
            changing.iter().filter_map(|v| v["tally"]["cbv"]["generated"]["held_sideways_mps"].as_f64()).collect();
        let mut from_variants = if generated.is_empty() {
            vec!["0".into(), "—".into(), "—".into(), "—".into()]
        } else {
            spread(generated)
        };
        from_variants.extend(spread(recorded.clone()));
        assert_eq!(cells[..8], from_variants[..], "{method}: the lane-change table and the report's variants disagree");
        if method == "log" {
            // The recorded CBV is one of the recorded vehicles: where it
            // changed lanes, its pace is among its scene's.
            for v in changing {
                let held = v["tally"]["cbv"]["generated"]["held_sideways_mps"].as_f64().unwrap();
                let scene = &recorded_by_scene[v["scenario"].as_str().unwrap()];
                assert!(scene.contains(&held), "log replay's CBV changed lanes at {held} m/s, not among {scene:?}");
            }
        }
    }
    assert!(
        section
            .lines()
            .any(|l| l.split_whitespace().next() == Some("safer-in-path") && l.split_whitespace().nth(1) != Some("0")),
        "no CBV of safer-in-path changed lanes"
    );
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn the_kill_ratios_over_resampled_scenes_hold_the_mutation_tables_ratios_and_match_the_report() {
    // A third of the WOMD interactive scenes, where log replay and the
    // prior kill some faults and safer-in-path more.
    let scenes = crate::shared_data::data_dir().join("womd-interactive");
    let json = tempfile_dir("kill-ratios").join("report.json");
    let table = ok(safer(&[
        "evaluate",
        "--scenes",
        scenes.to_str().unwrap(),
        "--partition",
        "1/3",
        "--methods",
        "log,prior,safer-in-path",
        "--seeds",
        "2",
        "--stage2-cbv",
        "closed-loop",
        "--mutants",
        "no-brake,blind-cbv,late",
        "--jobs",
        "2",
        "--json",
        json.to_str().unwrap(),
    ]));
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let kills = table.split("\nmutants killed").nth(1).expect("the mutation table");
    let ranges = table.split("\nkills over resampled scenes").nth(1).expect("the resampled kill-ratio table");
    let cell = |r: &Value| match r.as_array() {
        Some(pair) => {
            let f = |v: &Value| v.as_f64().map_or("inf".to_string(), |x| format!("{x:.2}"));
            format!("{}–{}", f(&pair[0]), f(&pair[1]))
        }
        None => "-".to_string(),
    };
    let mut finite = 0;
    for method in ["log", "prior", "safer-in-path"] {
        let row = |section: &str| -> Vec<String> {
            let line = section.lines().find(|l| l.split_whitespace().next() == Some(method)).expect("the method's row");
            line.split_whitespace().skip(1).map(str::to_owned).collect()
        };
        let reported = report["kill_ratios"].as_array().unwrap().iter().find(|r| r["method"] == method).unwrap();
        let (over_log, over_prior) = (cell(&reported["over_log"]), cell(&reported["over_prior"]));
        assert_eq!(row(ranges), [over_log.clone(), over_prior.clone()], "{method}: the table and the report disagree");
        // The mutation table's ratio over all the scenes lies in its range.
        // passed, kills (`k/n | held-out k/n` where scenes are held out), ×log, ×prior, ...
        let kill_row = row(kills);
        let at = kill_row.iter().position(|c| c == "|").map_or(2, |bar| bar + 2);
        for (ratio, range) in [(&kill_row[at], &reported["over_log"]), (&kill_row[at + 1], &reported["over_prior"])] {
            let (Ok(ratio), Some([low, high])) = (ratio.parse::<f64>(), range.as_array().map(|a| [&a[0], &a[1]]))
            else {
                continue;
            };
            let (low, high) = (low.as_f64().unwrap(), high.as_f64().unwrap_or(f64::INFINITY));
            assert!(low <= ratio && ratio <= high, "{method}: {ratio} outside {low}–{high}");
            finite += usize::from(high.is_finite() && low < high);
        }
    }
    let log = report["kill_ratios"].as_array().unwrap().iter().find(|r| r["method"] == "log").unwrap();
    assert_eq!(cell(&log["over_log"]), "1.00–1.00", "log replay over itself");
    assert!(finite > 0, "no finite range to check: {ranges}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn the_human_lane_change_pace_is_the_90th_percentile_of_the_recorded_lane_changes_outside_the_held_out_scenes() {
    use safer_scenarios::policies::adversary::HUMAN_LANE_CHANGE_MAX_SIDEWAYS_MPS;
    // The recorded vehicles that changed lanes, as `safer evaluate` reads
    // them, in the scenes of both sets that are not held out.
    let mut development: Vec<f64> = Vec::new();
    for set in ["commonroad-ngsim", "womd-interactive"] {
        let scenes = crate::shared_data::data_dir().join(set);
        let json = tempfile_dir(&format!("lane-change-pace-{set}")).join("report.json");
        let args = ["evaluate", "--scenes", scenes.to_str().unwrap(), "--methods", "log", "--seeds", "1"];
        ok(safer(&[&args[..], &["--jobs", "2", "--json", json.to_str().unwrap()]].concat()));
        let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let held_out: Vec<&str> =
            report["held_out"]["scenes"].as_array().unwrap().iter().map(|s| s.as_str().unwrap()).collect();
        assert!(!held_out.is_empty(), "{set}: no held-out scene");
        let by_scene = recorded_lane_changes_by_scene(&report);
        development.extend(by_scene.iter().filter(|(s, _)| !held_out.contains(s)).flat_map(|(_, v)| v.iter().copied()));
    }
    assert!(development.len() >= 100, "only {} recorded lane changes", development.len());
    development.sort_by(f64::total_cmp);
    let p90 = development[(0.9 * development.len() as f64).ceil() as usize - 1];
    assert!(
        (p90 - HUMAN_LANE_CHANGE_MAX_SIDEWAYS_MPS).abs() < 0.05,
        "the recorded lane changes' 90th percentile is {p90:.2} m/s, the rule's pace {HUMAN_LANE_CHANGE_MAX_SIDEWAYS_MPS} m/s"
    );
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn at_a_human_lane_change_pace_the_cbv_does_not_run_into_traffic_where_the_pace_leaves_no_token() {
    // An urban NGSIM arterial whose lanes bend and part: held to the pace
    // with no way to yield it, the CBV had only the fallbacks left and ran
    // into the recorded traffic in every seed.
    let scenes = crate::shared_data::data_dir().join("commonroad-ngsim");
    let json = tempfile_dir("lane-change-pace-fallback").join("report.json");
    ok(safer(&[
        "evaluate",
        "--scenes",
        scenes.to_str().unwrap(),
        "--scene",
        "USA_Lanker-2_16_T-1",
        "--methods",
        "safer-in-path-lookahead",
        "--trust-region",
        "60",
        "--seeds",
        "3",
        "--background",
        "reactive-log-replay",
        "--ego-contact",
        "not-from-behind",
        "--wrong-way",
        "human-lane-changes",
        "--json",
        json.to_str().unwrap(),
    ]));
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let variants = report["variants"].as_array().unwrap();
    assert_eq!(variants.len(), 3);
    for v in variants {
        assert_eq!(v["cbv_at_fault_with_background"], false, "seed {}: the CBV was at fault", v["seed"]);
        assert_eq!(v["cbv_off_road_s"].as_f64(), Some(0.0), "seed {}: the CBV left the road", v["seed"]);
    }
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn the_cbv_turns_within_the_tyres_grip() {
    // A WOMD interactive scene where, before the plausibility rule held the
    // CBV to 9 m/s² sideways, `safer` turned beyond it in 5 of 10 seeds and
    // `safer-in-path` in 7 (up to 23 m/s²).
    let scenes = crate::shared_data::data_dir().join("womd-interactive");
    let json = tempfile_dir("within-grip").join("report.json");
    ok(safer(&[
        "evaluate",
        "--scenes",
        scenes.to_str().unwrap(),
        "--scene",
        "a914f739b8916d61",
        "--methods",
        "safer,safer-in-path",
        "--seeds",
        "10",
        "--json",
        json.to_str().unwrap(),
    ]));
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let variants = report["variants"].as_array().unwrap();
    assert_eq!(variants.len(), 20);
    for v in variants {
        let peak = v["tally"]["cbv"]["generated"]["peak_lateral_accel_mps2"].as_f64();
        let peak = peak.unwrap_or_else(|| panic!("{} seed {}: no peak lateral acceleration", v["method"], v["seed"]));
        assert!(peak <= 9.0, "{} seed {}: the CBV pulled {peak:.2} m/s² sideways", v["method"], v["seed"]);
    }
    for row in report["rows"].as_array().unwrap() {
        assert_eq!(row["cbv_beyond_grip_rate"].as_f64(), Some(0.0), "{}", row["method"]);
    }
}
