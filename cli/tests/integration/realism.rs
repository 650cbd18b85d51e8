//! WOSAC 2025 realism metrics on recorded WOMD scenes: log replay, constant
//! velocity and IDM rolled out over the metric window and scored against the
//! log. Log replay reproduces the log, so its Bernoulli features sit at their
//! smoothed maximum and its kinematics at the (degenerate, single-trajectory)
//! histogram of the log itself; constant velocity must score lower.

use std::process::Command;

use safer_scenarios::eval::realism::{
    Feature, RealismAggregate, RealismConfig, RealismWindow, ScenarioRealism, score_scenario,
};
use safer_scenarios::policies::BackgroundPolicy;
use safer_scenarios::scenario::{Scenario, import};
use safer_scenarios::sim::traffic::simulate_all_agents;

use crate::shared_data::{data_dir, files};

const ROLLOUTS: usize = 8;
const SCENES: usize = 4;

fn womd_scenes() -> Vec<Scenario> {
    let paths = files("womd-json", "json");
    paths.iter().take(SCENES).flat_map(|p| import::load(p).unwrap_or_else(|e| panic!("{e}"))).collect()
}

fn score(scenario: &Scenario, policy: BackgroundPolicy, config: &RealismConfig) -> ScenarioRealism {
    let window = RealismWindow::for_scenario(scenario, config.future_steps).expect("WOMD scenes fit the window");
    assert_eq!(window.start_step, 10, "{}: WOMD's current step", scenario.id);
    let rollouts: Vec<_> = (0..ROLLOUTS)
        .map(|_| {
            simulate_all_agents(scenario, window.start_step, window.end_step(), |a| policy.instantiate(scenario, a))
                .unwrap_or_else(|e| panic!("{e}"))
        })
        .collect();
    score_scenario(scenario, window, &rollouts, config).unwrap_or_else(|e| panic!("{e}"))
}

fn assert_probabilities(r: &ScenarioRealism) {
    for f in Feature::ALL {
        let l = r.likelihoods.get(f).unwrap_or_else(|| panic!("{} {f:?} undefined", r.scenario_id));
        assert!((0.0..=1.0).contains(&l), "{} {f:?} = {l}", r.scenario_id);
    }
    for b in [r.buckets.kinematic, r.buckets.interactive, r.buckets.map_based, r.meta_metric] {
        let b = b.unwrap_or_else(|| panic!("{}: undefined score", r.scenario_id));
        assert!((0.0..=1.0).contains(&b), "{}: {b}", r.scenario_id);
    }
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn log_replay_beats_constant_velocity_and_idm_on_womd() {
    let config = RealismConfig::wosac_2025();
    let scenes = womd_scenes();
    assert_eq!(scenes.len(), SCENES);
    let replay: Vec<ScenarioRealism> = scenes.iter().map(|s| score(s, BackgroundPolicy::LogReplay, &config)).collect();
    let cv: Vec<ScenarioRealism> =
        scenes.iter().map(|s| score(s, BackgroundPolicy::ConstantVelocity, &config)).collect();
    let idm: Vec<ScenarioRealism> = scenes.iter().map(|s| score(s, BackgroundPolicy::Idm, &config)).collect();
    let smoothed_max = (ROLLOUTS as f64 + 0.001) / (ROLLOUTS as f64 + 0.002);
    for ((r, c), i) in replay.iter().zip(&cv).zip(&idm) {
        for x in [r, c, i] {
            assert_probabilities(x);
        }
        // Log replay is the log: every indication agrees with it in every rollout.
        for f in [Feature::CollisionIndication, Feature::OffroadIndication, Feature::TrafficLightViolation] {
            let l = r.likelihoods.get(f).unwrap();
            assert!((l - smoothed_max).abs() < 1e-12, "{} {f:?} = {l}", r.scenario_id);
        }
        assert_eq!(r.min_average_displacement_error_m, Some(0.0), "{}", r.scenario_id);
        assert_eq!(r.distinct_rollouts, 1, "log replay is deterministic");
        // Constant velocity leaves the log, and that must show.
        assert!(c.min_average_displacement_error_m.unwrap() > 0.1, "{}", c.scenario_id);
        assert!(
            c.meta_metric.unwrap() < r.meta_metric.unwrap(),
            "{}: constant velocity {} vs log replay {}",
            r.scenario_id,
            c.meta_metric.unwrap(),
            r.meta_metric.unwrap()
        );
        assert!(c.buckets.kinematic.unwrap() < r.buckets.kinematic.unwrap(), "{}", r.scenario_id);
        assert!(i.meta_metric.unwrap() < r.meta_metric.unwrap(), "{}", r.scenario_id);
    }
    let (r, c, i) = (
        RealismAggregate::mean(&replay, &config),
        RealismAggregate::mean(&cv, &config),
        RealismAggregate::mean(&idm, &config),
    );
    eprintln!(
        "realism over {SCENES} WOMD scenes, {ROLLOUTS} rollouts: log replay {:.4}, constant velocity {:.4}, IDM {:.4}",
        r.meta_metric.unwrap(),
        c.meta_metric.unwrap(),
        i.meta_metric.unwrap()
    );
    assert!(c.meta_metric.unwrap() < r.meta_metric.unwrap());
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn scoring_is_deterministic() {
    let config = RealismConfig::wosac_2025();
    let scenes = womd_scenes();
    let a = score(&scenes[0], BackgroundPolicy::Idm, &config);
    let b = score(&scenes[0], BackgroundPolicy::Idm, &config);
    assert_eq!(a, b);
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn cli_realism_writes_a_sorted_json_report() {
    let dir = data_dir().join("womd-json");
    let scratch = crate::scratch::Scratch::new("realism");
    let out_file = scratch.join("report.json");
    let run = |policy: &str| {
        Command::new(env!("CARGO_BIN_EXE_safer"))
            .args(["realism", "--scenes", dir.to_str().unwrap(), "--max-scenes", "2", "--rollouts", "4"])
            .args(["--policy", policy, "--json", out_file.to_str().unwrap()])
            .output()
            .expect("run safer")
    };
    let out = run("constant-velocity");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("womd-json") && text.contains("overall"), "{text}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out_file).unwrap()).unwrap();
    assert_eq!(v["scenes"].as_array().map(Vec::len), Some(2));
    let meta = v["overall"]["meta_metric"].as_f64().expect("meta metric");
    assert!((0.0..=1.0).contains(&meta), "{meta}");
    let ids: Vec<&str> = v["scenes"].as_array().unwrap().iter().map(|s| s["scenario_id"].as_str().unwrap()).collect();
    let mut sorted = ids.clone();
    sorted.sort();
    assert_eq!(ids, sorted, "results are sorted by scenario id");
    // The time per scene is its rollouts' and its scoring's.
    let secs = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} missing"));
    let (scene, rollouts, scoring) = (secs("mean_scene_s"), secs("mean_rollouts_s"), secs("mean_scoring_s"));
    assert!(rollouts > 0.0 && scoring > 0.0, "{rollouts} {scoring}");
    assert!((scene - rollouts - scoring).abs() < 1e-9, "{scene} {rollouts} {scoring}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn cli_realism_draws_the_prior_as_asked_and_refuses_sampling_for_other_policies() {
    let scene = files("womd-json", "json").into_iter().next().expect("a WOMD JSON scene");
    let scratch = crate::scratch::Scratch::new("realism-sampling");
    let out_file = scratch.join("report.json");
    let run = |extra: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_safer"))
            .args(["realism", "--scenes", scene.to_str().unwrap(), "--rollouts", "3"])
            .args(["--json", out_file.to_str().unwrap()])
            .args(extra)
            .output()
            .expect("run safer");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out_file).unwrap()).unwrap();
        (String::from_utf8_lossy(&out.stdout).into_owned(), v)
    };
    // The default draw: among the ten likeliest tokens, so the rollouts differ.
    let (text, v) = run(&[]);
    assert_eq!((v["top_k"].as_u64(), v["temperature"].as_f64()), (Some(10), Some(1.0)));
    assert!(!text.contains("top-"), "the default draw is not announced: {text}");
    assert!(v["scenes"][0]["distinct_rollouts"].as_u64().unwrap() > 1, "{}", v["scenes"][0]);
    // The likeliest token only: every rollout is the same.
    let (text, v) = run(&["--top-k", "1", "--temperature", "0.5"]);
    assert_eq!((v["top_k"].as_u64(), v["temperature"].as_f64()), (Some(1), Some(0.5)));
    assert!(text.contains("policy prior (top-1, temperature 0.5)"), "{text}");
    assert_eq!(v["scenes"][0]["distinct_rollouts"].as_u64(), Some(1), "{}", v["scenes"][0]);
    // A policy that draws no tokens would ignore them: refused, naming them.
    let out = Command::new(env!("CARGO_BIN_EXE_safer"))
        .args(["realism", "--scenes", scene.to_str().unwrap(), "--policy", "idm", "--top-k", "5"])
        .output()
        .expect("run safer");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "accepted: {stderr}");
    assert!(stderr.contains("--top-k") && stderr.contains("idm"), "{stderr}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn cli_realism_reports_the_held_out_tenth_beside_the_rest() {
    let dir = data_dir().join("womd-json");
    let scratch = crate::scratch::Scratch::new("realism-held-out");
    let out_file = scratch.join("report.json");
    let out = Command::new(env!("CARGO_BIN_EXE_safer"))
        .args(["realism", "--scenes", dir.to_str().unwrap(), "--max-scenes", "10", "--rollouts", "1"])
        .args(["--policy", "constant-velocity", "--json", out_file.to_str().unwrap()])
        .output()
        .expect("run safer");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("held out ") && text.contains("the rest "), "{text}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out_file).unwrap()).unwrap();
    let scenes = v["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 10);
    // Every tenth scene by id: of ten, the last.
    let split = &v["held_out"];
    assert_eq!(split["held_out_scenes"].as_u64(), Some(1), "{split}");
    assert_eq!(split["held_out"]["scenarios"].as_u64(), Some(1), "{split}");
    assert_eq!(split["rest"]["scenarios"].as_u64(), Some(9), "{split}");
    let meta = |s: &serde_json::Value| s["meta_metric"].as_f64().expect("meta metric");
    assert_eq!(meta(&split["held_out"]), meta(&scenes[9]), "the held-out row is the tenth scene's");
    let rest_mean = scenes[..9].iter().map(meta).sum::<f64>() / 9.0;
    assert!((meta(&split["rest"]) - rest_mean).abs() < 1e-9, "{} vs {rest_mean}", meta(&split["rest"]));
}
