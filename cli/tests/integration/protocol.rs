//! Planner protocol 1.1 on recorded scenes: the protocol-1.1 lane follower
//! (`planners/lane-follower.yaml`) drives a recorded NGSIM scene through
//! the suite pipeline and solves it where constant velocity collides; the
//! version-1 example planner still drives it; the planner's stderr lands
//! beside the artefacts; and driving past the end of NGSIM's map ends the
//! rollout as "left the mapped area", not as an off-road event.

use std::path::{Path, PathBuf};

use safer_scenarios::harness::{Suite, artefacts, pipeline::Stage2Verdict, variant::run_variant};
use safer_scenarios::planners::BuiltinPlanner;
use safer_scenarios::scenario::import;
use safer_scenarios::sim::{SimConfig, Simulation, Termination};

use crate::shared_data::data_dir;

/// A recorded US 101 scene where a constant-velocity ego rear-ends its
/// leader and the recorded ego later drives past the end of the map.
const SCENE: &str = "commonroad-ngsim/USA_US101-21_1_T-1.xml";

fn repo() -> &'static Path {
    Path::new(repo_root!())
}

/// A one-scene, one-variant suite with `planner` (a YAML value), written
/// to a fresh folder.
fn suite(tag: &str, planner: &str) -> (Suite, crate::scratch::Scratch) {
    let dir = crate::scratch::Scratch::new(&format!("protocol-{tag}"));
    let scene = data_dir().join(SCENE);
    assert!(scene.is_file(), "{} is missing", scene.display());
    let text = format!(
        "name: protocol-{tag}\nscenarios:\n  - recorded: {}\nplanner: {planner}\nadversary: {{ method: log, background: log-replay }}\nvariants: 1\nacceptance:\n  variant: {{ no_collision: true }}\n",
        scene.display()
    );
    let path = dir.join("suite.yaml");
    std::fs::write(&path, text).unwrap();
    (Suite::load(&path).unwrap_or_else(|e| panic!("{e}")), dir)
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn the_lane_follower_solves_a_recorded_scene_that_constant_velocity_does_not() {
    let planner = repo().join("planners/lane-follower.yaml");
    let (lf, dir) = suite("lane-follower", &planner.display().to_string());
    let outcome = run_variant(&lf, &lf.scenarios[0], 0).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(outcome.verdict, Stage2Verdict::Solved, "{:?}", outcome.stage2.summary());
    assert!(outcome.failures.is_empty(), "{:?}", outcome.failures);
    let latency = outcome.planner_latency.expect("timed");
    assert_eq!(latency.steps, outcome.stage2.steps());
    assert!(latency.p50_ms > 0.0 && latency.p50_ms <= latency.p95_ms && latency.p95_ms <= latency.max_ms);
    // Its start is reported apart: to `ready`, and its answer to `prepare`.
    let startup = latency.startup.expect("an external planner's start-up");
    assert!(startup.launch_ms > 0.0 && startup.prepare_ms.is_some_and(|ms| ms > 0.0), "{startup:?}");
    // Its stderr is kept beside the recording and the picture, not only on a crash.
    let written = artefacts::write(&dir, &outcome, None).unwrap();
    let stderr = written.stderr.expect("an external planner's stderr file");
    assert_eq!(stderr.parent(), written.mcap.parent());
    let log = std::fs::read_to_string(&stderr).unwrap();
    assert!(log.contains("lane_follower: hello: scenario USA_US101-21_1_T-1 variant protocol-lane-follower::USA_US101-21_1_T-1::seed-0"), "{log}");
    assert!(log.contains("lane_follower: prepared:"), "{log}");

    let (cv, cv_dir) = suite("constant-velocity", "{ builtin: constant-velocity }");
    let outcome = run_variant(&cv, &cv.scenarios[0], 0).unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(outcome.verdict, Stage2Verdict::Collided { .. }), "{:?}", outcome.verdict);
    assert!(outcome.planner_stderr.is_none(), "a built-in has no stderr");
    assert!(outcome.planner_latency.is_some_and(|l| l.startup.is_none()), "a built-in starts nothing");
    std::fs::remove_dir_all(dir).unwrap();
    std::fs::remove_dir_all(cv_dir).unwrap();
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn the_version_1_example_planner_still_drives_recorded_scenes() {
    let planner = repo().join("planners/example-python.yaml");
    let (s, dir) = suite("example", &planner.display().to_string());
    let outcome = run_variant(&s, &s.scenarios[0], 0).unwrap_or_else(|e| panic!("{e}"));
    assert!(!matches!(outcome.verdict, Stage2Verdict::Aborted { .. }), "{:?}", outcome.verdict);
    assert!(outcome.stage2.steps() > 30, "{:?}", outcome.stage2.summary());
    let log = outcome.planner_stderr.expect("stderr");
    assert!(log.contains("example_planner: hello: ego"), "{log}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn driving_past_the_end_of_an_ngsim_map_is_leaving_the_mapped_area_not_the_road() {
    // The recording's map ends about 60 m ahead; an IDM ego keeps driving.
    let scene = data_dir().join("commonroad-ngsim/USA_US101-16_1_T-1.xml");
    let s = import::load(&scene).unwrap_or_else(|e| panic!("{e}")).remove(0);
    let mut planner = BuiltinPlanner::Idm.instantiate(&s, s.ego.unwrap());
    let r = Simulation::new(&s, SimConfig::default()).unwrap().run(planner.as_mut());
    let Termination::LeftMappedArea { step } = r.termination else { panic!("{:?}", r.termination) };
    assert!(step > r.start_step, "{step}");
    assert!(r.off_road.is_empty(), "{:?}", r.off_road);
    assert!(r.ego_collision().is_none());
    assert_eq!(Stage2Verdict::of(&r), Stage2Verdict::Solved);
    // The ego's nose is past the last lanes' ends, off the drivable area.
    let ego = r.states.last().unwrap()[r.ego.0].unwrap();
    let half = s.track(r.ego).length_m / 2.0;
    let nose =
        ego.position + safer_scenarios::geometry::Vector2::new(ego.heading_rad.cos(), ego.heading_rad.sin()) * half;
    assert!(s.map.is_off_road(&nose) && s.map.is_past_mapped_end(&nose), "{nose:?}");
}

/// Runs the `safer` binary from the repository root.
fn safer(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_safer")).args(args).current_dir(repo()).output().expect("run safer")
}

/// A fresh folder named for `tag` holding copies of `scenes`.
fn scenes_in_scratch(tag: &str, scenes: &[&Path]) -> crate::scratch::Scratch {
    let dir = crate::scratch::Scratch::new(tag);
    for scene in scenes {
        std::fs::copy(scene, dir.join(scene.file_name().unwrap())).unwrap();
    }
    dir
}

/// `safer evaluate` of log replay, one seed, over the scenes in `dir`, with `extra` flags.
fn evaluate_log_replay_once(dir: &Path, extra: &[&str]) -> std::process::Output {
    let common = ["evaluate", "--scenes", dir.to_str().unwrap(), "--methods", "log", "--seeds", "1"];
    safer(&[&common[..], extra].concat())
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn evaluate_with_merging_roles_tests_a_merging_pair_and_leaves_out_scenes_without_one() {
    // A WOMD JSON junction where two lanes lead into one, and the NGSIM
    // freeway scene above, whose lanes only run side by side.
    let merging = data_dir().join("womd-json/tfrecord-00094-of-00150_48b0814dee9301a0.json");
    let freeway = data_dir().join(SCENE);
    let dir = scenes_in_scratch("evaluate-merging-roles", &[&merging, &freeway]);
    let run = |extra: &[&str]| evaluate_log_replay_once(&dir, extra);
    let out = run(&["--roles", "merging", "--json", "-"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("--roles merging: 1 of 2 scenes have a merging pair"), "{err}");
    assert!(err.contains("ego and CBV in merging lanes"), "{err}");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["settings"]["roles"], "merging");
    assert_eq!(report["scene_list"]["ids"], serde_json::json!(["48b0814dee9301a0"]));
    // The pair picked is the one that reaches the junction's exit lane at
    // nearly the same time (about 1 s apart at their speeds): in the
    // recording they pass within 2 m of each other.
    let gap_m = report["variants"][0]["stage1_min_gap_m"].as_f64().unwrap();
    assert!(gap_m < 2.0, "{}", report["variants"][0]);
    // The default leaves the scenes' own pairs, and the report says nothing of roles.
    let out = run(&["--roles", "as-loaded", "--json", "-"]);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["scene_list"]["ids"].as_array().map(Vec::len), Some(2));
    assert!(report["settings"].get("roles").is_none(), "{}", report["settings"]);
    // A scene named that has no merging pair: said so, naming the option.
    let out = run(&["--roles", "merging", "--scene", "USA_US101-21_1_T-1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("no scene with a pair of vehicles in merging lanes (--roles merging)"),
        "{err}"
    );
    // Only the freeway: nothing to test, said so.
    std::fs::remove_file(dir.join(merging.file_name().unwrap())).unwrap();
    let out = run(&["--roles", "merging", "--json", "-"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("no scene with a pair of vehicles in merging lanes"), "{err}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn evaluate_with_crossing_roles_tests_a_car_across_the_egos_way_and_leaves_out_scenes_without_one() {
    // A WOMD JSON junction whose labelled CBV comes the other way, with a
    // car crossing the ego's way there; and the NGSIM freeway scene above,
    // where no two paths cross.
    let junction = data_dir().join("womd-json/tfrecord-00005-of-00150_2bd577a009790706.json");
    let freeway = data_dir().join(SCENE);
    let dir = scenes_in_scratch("evaluate-crossing-roles", &[&junction, &freeway]);
    let run = |extra: &[&str]| evaluate_log_replay_once(&dir, extra);
    let out = run(&["--roles", "as-loaded", "--json", "-"]);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let junction_start = |report: &serde_json::Value| {
        let variants = report["variants"].as_array().unwrap();
        let v = variants.iter().find(|v| v["scenario"] == "2bd577a009790706").expect("the junction scene");
        v["cbv_start"].clone()
    };
    assert_eq!(junction_start(&report), "oncoming", "the scene's own CBV");
    let out = run(&["--roles", "crossing", "--json", "-"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("--roles crossing: 1 of 2 scenes have a crossing pair"), "{err}");
    assert!(err.contains("the CBV's path crosses the ego's"), "{err}");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["settings"]["roles"], "crossing");
    assert_eq!(report["scene_list"]["ids"], serde_json::json!(["2bd577a009790706"]));
    assert_eq!(junction_start(&report), "crossing", "a car across the ego's way");
    // Only the freeway: nothing to test, said so.
    std::fs::remove_file(dir.join(junction.file_name().unwrap())).unwrap();
    let out = run(&["--roles", "crossing", "--json", "-"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("no scene with a vehicle whose path crosses the ego's"), "{err}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn the_closest_approach_table_bands_the_cbvs_gap_not_the_gap_to_whoever_came_closest() {
    // A WOMD JSON scene whose recorded ego passes another car 0.44 m off,
    // while its CBV stays more than 7 m away.
    let scene = data_dir().join("womd-json/tfrecord-00097-of-01000_266.json");
    let out = evaluate_log_replay_once(&scene, &["--json", "-"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let variant = &report["variants"][0];
    let (to_anyone, to_cbv) =
        (variant["stage1_min_gap_m"].as_f64().unwrap(), variant["stage1_min_gap_to_cbv_m"].as_f64().unwrap());
    assert!(to_anyone < 0.5 && to_cbv > 5.0, "{variant}");
    let closest = &report["rows"][0]["stage1_closest"];
    assert_eq!((closest["under_half_m"].as_f64(), closest["farther"].as_f64()), (Some(0.0), Some(1.0)), "{closest}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn evaluate_with_leader_roles_makes_the_car_ahead_of_the_ego_the_cbv_and_leaves_out_scenes_without_one() {
    use safer_scenarios::scenario::roles::RolePairing;
    // A freeway scene whose ego follows a car in its lane, and one whose
    // ego has no moving car ahead of it in its path.
    let with_leader = data_dir().join("commonroad-ngsim/USA_US101-9_3_T-1.xml");
    let without = data_dir().join("commonroad-ngsim/USA_US101-16_1_T-1.xml");
    // The leader is ahead of the ego's front, in its lane and heading its
    // way; the closest recorded approach is another car.
    let mut s = import::load(&with_leader).unwrap_or_else(|e| panic!("{e}")).remove(0);
    let closest = s.cbv;
    assert!(RolePairing::Leader.assign(&mut s));
    assert_ne!(s.cbv, closest);
    let now = s.current_step;
    let (ego, leader) = (s.track(s.ego.unwrap()), s.track(s.cbv.unwrap()));
    let (e, l) = (ego.state(now).unwrap(), leader.state(now).unwrap());
    let forward = safer_scenarios::geometry::Vector2::new(e.heading_rad.cos(), e.heading_rad.sin());
    let d = l.position - e.position;
    let (along_m, across_m) = (d.dot(&forward), (d.x * forward.y - d.y * forward.x).abs());
    assert!(along_m > 0.5 * (ego.length_m + leader.length_m), "{along_m} m ahead");
    assert!(across_m < 0.5 * (ego.width_m + leader.width_m), "{across_m} m to the side");
    assert!(safer_scenarios::geometry::wrap_angle(l.heading_rad - e.heading_rad).abs() < 0.3);
    let mut none = import::load(&without).unwrap_or_else(|e| panic!("{e}")).remove(0);
    let before = (none.ego, none.cbv);
    assert!(!RolePairing::Leader.assign(&mut none));
    assert_eq!((none.ego, none.cbv), before, "a scene without a leader is left as it was");

    let dir = scenes_in_scratch("evaluate-leader-roles", &[&with_leader, &without]);
    let run = |extra: &[&str]| evaluate_log_replay_once(&dir, extra);
    let out = run(&["--roles", "leader", "--json", "-"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("--roles leader: 1 of 2 scenes have a leader"), "{err}");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["settings"]["roles"], "leader");
    assert_eq!(report["scene_list"]["ids"], serde_json::json!(["USA_US101-9_3_T-1"]));
    // Replayed, the leader stays ahead of the recorded ego: no contact.
    let gap_m = report["variants"][0]["stage1_min_gap_m"].as_f64().unwrap();
    assert!(gap_m > 0.0, "{}", report["variants"][0]);
    // The table names the pairing.
    let out = run(&["--roles", "leader"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("the CBV is the ego's leader (--roles leader)"));
    // A scene named that has no leader: said so, naming the option.
    let out = run(&["--roles", "leader", "--scene", "USA_US101-16_1_T-1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("no scene with a leader for the ego (--roles leader)"), "{err}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn a_suite_entry_with_leader_roles_tests_each_scene_with_its_leader_and_leaves_out_those_without() {
    use safer_scenarios::scenario::{RoleOrigin, roles::RolePairing};
    let dir = crate::scratch::Scratch::new("suite-leader-roles");
    let (with_leader, without) = ("USA_US101-9_3_T-1.xml", "USA_US101-16_1_T-1.xml");
    for (folder, file) in [("both", with_leader), ("both", without), ("none", without)] {
        std::fs::create_dir_all(dir.join(folder)).unwrap();
        std::fs::copy(data_dir().join("commonroad-ngsim").join(file), dir.join(folder).join(file)).unwrap();
    }
    let write = |entries: &str| {
        let text = format!(
            "name: leaders\nscenarios:\n{entries}planner: {{ builtin: evasive }}\nadversary: {{ method: log }}\nvariants: 1\n"
        );
        let path = dir.join("suite.yaml");
        std::fs::write(&path, text).unwrap();
        Suite::load(&path)
    };
    // The folder as loaded, then again with each scene's leader as the CBV:
    // the scene without a leader is left out of the second.
    let suite = write("  - recorded: both\n  - { recorded: both, roles: leader }\n").unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = suite.scenarios.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["USA_US101-16_1_T-1", "USA_US101-9_3_T-1", "USA_US101-9_3_T-1-leader"]);
    let (own, led) = (suite.scenarios[1].load().unwrap(), suite.scenarios[2].load().unwrap());
    assert_eq!(suite.scenarios[2].roles, RolePairing::Leader);
    assert_eq!(own.ego, led.ego);
    assert_ne!(own.cbv, led.cbv);
    assert_eq!(led.cbv_origin, RoleOrigin::LeaderMining);
    let mut expected = (*own).clone();
    assert!(RolePairing::Leader.assign(&mut expected));
    assert_eq!(led.cbv, expected.cbv, "the pair `safer evaluate --roles leader` tests");
    // Its variant runs, with the leader as the CBV.
    let outcome = run_variant(&suite, &suite.scenarios[2], 0).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(outcome.stage2.cbv, led.cbv);
    // `limit` counts the scenes kept.
    let suite = write("  - { recorded: both, roles: leader, limit: 1 }\n").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(suite.scenarios.len(), 1);
    // An entry none of whose scenes has a leader is an error at its `roles`.
    let Err(e) = write("  - recorded: both\n  - { recorded: none, roles: leader }\n") else {
        panic!("must be refused")
    };
    let e = e.to_string();
    assert!(
        e.contains("suite.yaml:4:") && e.contains("no scene of none has a leader for the ego (roles: leader)"),
        "{e}"
    );
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn a_suite_entry_with_crossing_roles_tests_the_car_across_the_egos_way_and_refuses_a_folder_without_one() {
    use safer_scenarios::scenario::{RoleOrigin, roles::RolePairing};
    let dir = crate::scratch::Scratch::new("suite-crossing-roles");
    let junction = "tfrecord-00005-of-00150_2bd577a009790706.json";
    std::fs::create_dir_all(dir.join("junction")).unwrap();
    std::fs::copy(data_dir().join("womd-json").join(junction), dir.join("junction").join(junction)).unwrap();
    std::fs::create_dir_all(dir.join("freeway")).unwrap();
    std::fs::copy(data_dir().join(SCENE), dir.join("freeway/scene.xml")).unwrap();
    let write = |entries: &str| {
        let text = format!(
            "name: crossings\nscenarios:\n{entries}planner: {{ builtin: evasive }}\nadversary: {{ method: log }}\nvariants: 1\n"
        );
        let path = dir.join("suite.yaml");
        std::fs::write(&path, text).unwrap();
        Suite::load(&path)
    };
    let suite = write("  - recorded: junction\n  - { recorded: junction, roles: crossing }\n")
        .unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = suite.scenarios.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(
        names,
        ["tfrecord-00005-of-00150_2bd577a009790706", "tfrecord-00005-of-00150_2bd577a009790706-crossing"]
    );
    let (own, crossing) = (suite.scenarios[0].load().unwrap(), suite.scenarios[1].load().unwrap());
    assert_eq!(suite.scenarios[1].roles, RolePairing::Crossing);
    assert_eq!(own.ego, crossing.ego, "the source's ego keeps its place");
    assert_ne!(own.cbv, crossing.cbv);
    assert_eq!(crossing.cbv_origin, RoleOrigin::CrossingMining);
    let outcome = run_variant(&suite, &suite.scenarios[1], 0).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(outcome.stage2.cbv, crossing.cbv, "its variant runs with the crossing car as the CBV");
    // A folder where no two paths cross is refused at its `roles`.
    let Err(e) = write("  - recorded: junction\n  - { recorded: freeway, roles: crossing }\n") else {
        panic!("must be refused")
    };
    let e = e.to_string();
    assert!(
        e.contains("suite.yaml:4:") && e.contains("has a vehicle whose path crosses the ego's (roles: crossing)"),
        "{e}"
    );
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn evaluate_with_mutants_counts_the_kills_beyond_log_replay_alike_in_the_table_and_the_report() {
    // A WOMD interactive scene where log replay's variant kills the mutant
    // blind to the CBV, and the prior's first seed also kills the two that
    // cannot brake (at all, or hard).
    let scene = data_dir().join("womd-interactive/tfrecord-00100-of-00150_153.json");
    let run = |methods: &str| {
        let args = ["evaluate", "--scenes", scene.to_str().unwrap(), "--seeds", "2", "--methods", methods];
        let out = safer(&[&args[..], &["--stage2-cbv", "closed-loop", "--mutants", "--json", "-"]].concat());
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{err}");
        (serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap(), err)
    };
    let (report, table) = run("log,prior");
    let kills = |method: &str| {
        let row = report["rows"].as_array().unwrap().iter().find(|r| r["method"] == method).unwrap();
        row["kills"].clone()
    };
    let (log, prior) = (kills("log"), kills("prior"));
    // Log replay catches nothing beyond itself; the prior's kills beyond it
    // are those of the two mutants that cannot brake.
    assert_eq!(log["beyond_replay"], 0, "{log}");
    let beyond = prior["beyond_replay"].as_u64().unwrap();
    assert!(beyond > 0 && beyond < prior["kills"].as_u64().unwrap(), "{prior}");
    let operator = |name: &str| prior["operators"].as_array().unwrap().iter().find(|o| o["operator"] == name).unwrap();
    let braking_kills = ["no-brake", "weak-brake"].map(|name| operator(name)["kills"].as_u64().unwrap());
    assert_eq!(beyond, braking_kills.iter().sum::<u64>(), "{prior}");
    // The table prints the same counts.
    assert!(table.contains("beyond log"), "{table}");
    assert_eq!(beyond_log_cell(&table, "prior"), beyond.to_string(), "{table}");
    assert_eq!(beyond_log_cell(&table, "log"), "0", "{table}");
    // The mutants' effect: a killed mutant drove otherwise where it was
    // killed, and the table's cell is the report's count.
    let differently = operator("no-brake")["variants_driven_differently"].as_u64().unwrap();
    assert!(differently >= braking_kills[0], "{prior}");
    let effects = table.split("mutants' effect").nth(1).expect("the mutants' effect table");
    let row = effects.lines().find(|l| l.starts_with("prior ")).unwrap();
    let passed = prior["variants_passed"].as_u64().unwrap();
    assert_eq!(row.split_whitespace().nth(1), Some(format!("{differently}/{passed}").as_str()), "{effects}");
    // The mutants' paths: a mutant that cannot brake drove the planner's
    // way at another speed, and the table's cell is the report's count and
    // farthest departure.
    let off_path = operator("no-brake")["variants_off_path"].as_u64().unwrap();
    let farthest_m = operator("no-brake")["largest_path_departure_m"].as_f64().unwrap();
    assert!(off_path <= differently, "{prior}");
    let paths = effects.split("mutants' paths").nth(1).expect("the mutants' paths table");
    let row: Vec<&str> = paths.lines().find(|l| l.starts_with("prior ")).unwrap().split_whitespace().collect();
    let (off_cell, farthest_cell) = (format!("{off_path}/{passed}"), format!("{farthest_m:.2}"));
    assert_eq!(row[1..3], [off_cell.as_str(), farthest_cell.as_str()], "{paths}");
    // Without log replay in the run there is nothing to count beyond.
    let (report, table) = run("prior");
    assert!(report["rows"][0]["kills"]["beyond_replay"].is_null(), "{}", report["rows"][0]);
    assert_eq!(beyond_log_cell(&table, "prior"), "-", "{table}");
}

/// The "beyond log" cell of `method`'s row of the mutation table (its last
/// row): counted from the end, past the seven mutants' "kills (scenes)"
/// cells, the mutants killed and the ×prior.
fn beyond_log_cell(table: &str, method: &str) -> String {
    let kills_table = table.split("mutants' effect").next().unwrap();
    let line = kills_table.lines().rfind(|l| l.starts_with(&format!("{method} "))).unwrap();
    let cells: Vec<&str> = line.split_whitespace().collect();
    cells[cells.len() - 17].to_string()
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn evaluate_takes_a_planner_spec_and_jobs_and_reports_latency() {
    let scene = data_dir().join(SCENE);
    let scene = scene.to_str().unwrap();
    let common = ["evaluate", "--scenes", scene, "--methods", "log", "--seeds", "1", "--json", "-"];
    let out = safer(&[&common[..], &["--planner", "planners/lane-follower.yaml", "--jobs", "1"]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let variant = &report["variants"][0];
    assert_eq!(variant["stage2"]["verdict"], "solved", "{variant}");
    let latency = &variant["planner_latency"];
    assert!(latency["steps"].as_u64().unwrap() > 10, "{latency}");
    for key in ["p50_ms", "p95_ms", "max_ms"] {
        assert!(latency[key].as_f64().unwrap() > 0.0, "{latency}");
    }
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("stage 2 planner `lane-follower`"), "{err}");
    // The recorded CBV never touches the recorded ego: its closest approach
    // is one of the gap bands, and the four shares add up to one.
    assert!(err.contains("closest approach of the CBV to the recorded ego"), "{err}");
    let closest = &report["rows"][0]["stage1_closest"];
    assert_eq!(closest["contact"], 0.0, "{closest}");
    let bands = ["contact", "under_half_m", "under_1_m", "farther"].map(|k| closest[k].as_f64().unwrap());
    assert!((bands.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{closest}");
    // Not a built-in, not a file; no thread at all.
    let out = safer(&[&common[..], &["--planner", "no-such-planner"]].concat());
    assert!(String::from_utf8_lossy(&out.stderr).contains("neither a built-in planner"));
    // Refused, naming the option.
    let refused = |option: &str, value: &str| {
        let out = safer(&[&common[..], &[option, value]].concat());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(option), "{option} {value}: {err}");
    };
    refused("--jobs", "0");
    // The witness's road rule: named in the table's heading when not the default, refused when unknown.
    let out = safer(&[&common[..], &["--witness-road", "whole-width"]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("the witness keeps its whole width on the road"));
    refused("--witness-road", "kerb");
    // The witness search's widest beam: named when not the default, 1 to 4096.
    let out = safer(&[&common[..], &["--witness-widest", "512"]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("the witness search widens its beam up to ×512"));
    let out = safer(&common);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("widens its beam"));
    refused("--witness-widest", "0");
    refused("--witness-widest", "4097");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn run_reports_latency_per_variant() {
    let planner = repo().join("planners/lane-follower.yaml");
    let (_, dir) = suite("run-latency", &planner.display().to_string());
    let suite_file = dir.join("suite.yaml");
    let out = safer(&["run", suite_file.to_str().unwrap(), "--jobs", "1", "--json", "-"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let variant = &report["suites"][0]["variants"][0];
    assert!(variant["planner_latency"]["p95_ms"].as_f64().unwrap() > 0.0, "{variant}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn a_dead_end_inside_a_womd_map_is_still_off_road() {
    // Lane 142 of this WOMD scene ends without a successor about 110 m
    // from the ego's start, well inside the map: the kerbs go on around its
    // end, so driving on past it is off-road, not the map's edge (the
    // evasive ego used to leave the road there at 6.8 s).
    let path = data_dir().join("womd-json/tfrecord-00000-of-00150_2d84b1ab55ab81d3.json");
    let scene = import::load(&path).unwrap_or_else(|e| panic!("{e}")).remove(0);
    let lane = scene.map.lanes.iter().find(|l| l.id.0 == 142).expect("lane 142 in the scene");
    assert!(lane.successors.is_empty(), "lane 142 is a dead end");
    let points = lane.centreline.points();
    let end = points[points.len() - 1];
    let beyond = end + (end - points[points.len() - 2]).normalize() * 3.0;
    assert!(scene.map.is_off_road(&beyond), "3 m past the dead end is off the road");
    assert!(!scene.map.is_past_mapped_end(&beyond), "a dead end inside the map is not the map's edge");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn commonroad_stop_lines_are_kept_on_their_lanes() {
    let path = data_dir().join("commonroad-ngsim/USA_Lanker-1_1_T-1.xml");
    let xml = std::fs::read_to_string(&path).unwrap();
    let in_file = xml.matches("<stopLine").count();
    assert!(in_file > 0, "the fixture scene has no stop line");
    let s = import::load(&path).unwrap_or_else(|e| panic!("{e}")).remove(0);
    let with_stop_line: Vec<_> = s.map.lanes.iter().filter(|l| l.stop_line.is_some()).collect();
    assert_eq!(with_stop_line.len(), in_file);
    // Each near its lane's end, in the re-centred frame.
    for l in with_stop_line {
        let end = *l.centreline.points().last().unwrap();
        let d = (l.stop_line.unwrap() - end).norm();
        assert!(d < 10.0, "lane {}: stop line {d} m from its end", l.id.0);
    }
}

/// The stable route on arterial scenes, Peachtree and Lankershim (recorded
/// egos that start off their lane's centreline, lanes that begin just
/// behind them), driven by the probe planner, which holds its heading and
/// speed: the ego stays near the lane it started beside, so the route it
/// was given is not planned anew at every step, and it reaches 20 m
/// behind the ego where the map has lanes there.
#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn the_stable_route_is_not_planned_anew_while_the_ego_stays_beside_it() {
    let probe = repo().join("tests/fixtures/planners/probe_planner.py");
    let scenes = crate::shared_data::files("commonroad-ngsim", "xml");
    let arterial = |p: &&PathBuf| {
        p.file_name().is_some_and(|n| ["USA_Peach", "USA_Lanker-1_"].iter().any(|s| n.to_string_lossy().starts_with(s)))
    };
    let arterials: Vec<&PathBuf> = scenes.iter().filter(arterial).collect();
    assert_eq!(arterials.len(), 18, "Peachtree and Lankershim-1 scenes");
    let mut report = Vec::new();
    for scene in arterials {
        let dir = crate::scratch::Scratch::new("route");
        let spec = format!("name: probe\nexternal: {{ command: python3, args: ['{}'] }}\n", probe.display());
        std::fs::write(dir.join("probe.yaml"), spec).unwrap();
        let text = format!(
            "name: route\nscenarios:\n  - recorded: {}\nplanner: probe.yaml\nadversary: {{ method: log, background: log-replay }}\nvariants: 1\nacceptance:\n  variant: {{ no_collision: true }}\n",
            scene.display(),
        );
        std::fs::write(dir.join("suite.yaml"), text).unwrap();
        let suite = Suite::load(&dir.join("suite.yaml")).unwrap_or_else(|e| panic!("{e}"));
        let Ok(outcome) = run_variant(&suite, &suite.scenarios[0], 0) else {
            // Scenes without an ego or a CBV are not runnable suites.
            continue;
        };
        let log = outcome.planner_stderr.unwrap_or_default();
        let observations: Vec<serde_json::Value> = log
            .lines()
            .filter_map(|l| l.strip_prefix("probe: "))
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter(|r| r["type"] == "observation")
            .collect();
        assert!(!observations.is_empty(), "{}: no observations in the probe's log:\n{log}", scene.display());
        let revisions = observations.iter().filter_map(|o| o["route_revision"].as_u64()).max().unwrap_or(0);
        let first_s = observations[0]["route_s_m"].as_f64().unwrap_or(0.0);
        report.push((
            scene.file_name().unwrap().to_string_lossy().into_owned(),
            observations.len(),
            revisions,
            first_s,
        ));
        std::fs::remove_dir_all(dir).unwrap();
    }
    println!("(scene, steps, last route revision, ego's arc length on the first route) {report:?}");
    assert!(report.len() >= 10, "{report:?}");
    for (scene, steps, revisions, _) in &report {
        assert!(*revisions <= 2, "{scene}: route revision {revisions} after {steps} steps");
    }
    // 20 m back unless the mapped lanes end sooner (18.9 m on Lankershim).
    let short: Vec<_> = report.iter().filter(|r| r.3 < 15.0 || r.3 > 20.0 + 1e-6).collect();
    assert!(short.is_empty(), "the first route does not reach 15–20 m behind the ego: {short:?}");
}
