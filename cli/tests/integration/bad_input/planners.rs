//! Bad input: planners (see the parent module). External planners that
//! crash, hang, answer garbage or absurd numbers, or leave processes
//! behind, each through `Simulation::run` as a variant runs it: every case
//! ends within a deadline, fails as a planner failure (never a pass), says
//! which of these happened, and leaves no process of the planner's process
//! group running. The planners are `planners/misbehaving_planner.py` modes,
//! some behind `tests/fixtures/bad-input/planners/wrapper-without-exec.sh`.

use std::path::Path;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use safer_scenarios::geometry::{Point2, Vector2};

use super::binary::live_group_members;
use safer_scenarios::map::templates::StraightRoad;
use safer_scenarios::planners::external::{ExternalPlanner, ExternalPlannerConfig};
use safer_scenarios::scenario::{AgentId, AgentKind, AgentState, Scenario, ScenarioSource, Track, TrackIndex};
use safer_scenarios::sim::{Rollout, SimConfig, Simulation, Termination, VehicleLimits};

/// Time a case may take; every one needs well under a second or two.
const DEADLINE: Duration = Duration::from_secs(30);

fn repo(path: &str) -> String {
    Path::new(repo_root!()).join(path).display().to_string()
}

/// `misbehaving_planner.py MODE GOOD_STEPS`, run by python3 directly.
fn misbehaving(mode: &str, good_steps: usize) -> ExternalPlannerConfig {
    let mut c = ExternalPlannerConfig::new(mode, "python3");
    c.args = vec![repo("planners/misbehaving_planner.py"), mode.into(), good_steps.to_string()];
    c
}

/// `misbehaving_planner.py MODE GOOD_STEPS MINOR`: speaking protocol 1.MINOR.
fn misbehaving_speaking(mode: &str, good_steps: usize, minor: u32) -> ExternalPlannerConfig {
    let mut c = misbehaving(mode, good_steps);
    c.args.push(minor.to_string());
    c
}

/// The same planner behind a shell script that does not `exec` it.
fn wrapped(mode: &str, good_steps: usize) -> ExternalPlannerConfig {
    let mut c = ExternalPlannerConfig::new(format!("wrapped-{mode}"), "sh");
    c.args =
        vec![repo("tests/fixtures/bad-input/planners/wrapper-without-exec.sh"), mode.into(), good_steps.to_string()];
    c
}

/// A 300 m straight road, the ego at x = 10 doing 10 m/s, 31 steps (3 s).
fn scene() -> Scenario {
    let map =
        StraightRoad { lanes: 1, oncoming_lanes: 0, lane_width_m: 3.5, length_m: 300.0, speed_limit_mps: None }.build();
    let ego = Track {
        id: AgentId("ego".into()),
        kind: AgentKind::Vehicle,
        length_m: 4.5,
        width_m: 2.0,
        states: (0..31)
            .map(|k| {
                Some(AgentState {
                    position: Point2::new(10.0 + k as f64, 1.75),
                    heading_rad: 0.0,
                    velocity_mps: Vector2::new(10.0, 0.0),
                })
            })
            .collect(),
    };
    Scenario::new("planner-bad-input", ScenarioSource::authored("test"), 0.1, map, vec![ego])
        .with_roles(TrackIndex(0), None)
}

/// Runs `f` on a thread; panics if it has not finished within [`DEADLINE`].
fn within_deadline<T: Send + 'static>(what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    match rx.recv_timeout(DEADLINE) {
        Ok(value) => value,
        Err(e) => panic!("{what} did not end within {DEADLINE:?} ({e})"),
    }
}

/// Starts the planner (so its process group is known), runs the scene with
/// it, and drops it; the rollout and the group id.
fn run_variant(config: ExternalPlannerConfig) -> (Rollout, u32, Vec<u32>) {
    let name = config.name.clone();
    within_deadline(&format!("a variant with planner `{name}`"), move || {
        let mut planner = ExternalPlanner::start(config, 4.5, 2.0).expect("the planner starts");
        let pgid = planner.pid().expect("a started planner has a process");
        let members_at_start = live_group_members(pgid);
        let scenario = scene();
        let rollout = Simulation::new(&scenario, SimConfig::default()).unwrap().run(&mut planner);
        drop(planner);
        (rollout, pgid, members_at_start)
    })
}

/// The failure step and reason; a test failure for any other termination.
fn failure(r: &Rollout) -> (usize, String) {
    match &r.termination {
        Termination::PlannerFailed { step, reason } => (*step, reason.clone()),
        other => panic!("expected a planner failure, got {other:?}"),
    }
}

/// No process of the group is left; allows a moment for SIGKILL to land.
fn assert_group_gone(pgid: u32) {
    let deadline = Instant::now() + Duration::from_millis(500);
    while !live_group_members(pgid).is_empty() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(live_group_members(pgid), Vec::<u32>::new(), "processes of planner group {pgid} survived");
}

#[test]
fn a_15_mib_error_message_is_cut_before_it_reaches_any_report() {
    // It went whole into the JUnit report, the review page and the MCAP.
    let (rollout, pgid, _) = run_variant(misbehaving("long-error", 1));
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 1);
    assert!(reason.len() < 3_000, "{} bytes", reason.len());
    assert!(
        reason.contains("lost xxxx") && reason.contains("(15728645 characters in all)"),
        "{}",
        reason.chars().take(200).collect::<String>()
    );
    assert_group_gone(pgid);
}

#[test]
fn an_endless_reply_line_fails_as_soon_as_it_passes_the_line_limit() {
    // It was reported only when the step timeout ran out, as "did not answer".
    let mut config = misbehaving("endless-line", 0);
    config.step_timeout_ms = 60_000;
    let started = Instant::now();
    let (rollout, pgid, _) = run_variant(config);
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 0);
    assert!(reason.contains("a line longer than 16777216 bytes"), "{reason}");
    assert!(started.elapsed() < Duration::from_secs(20), "took {:?}", started.elapsed());
    assert_group_gone(pgid);
}

#[cfg(target_os = "linux")]
#[test]
fn a_wrapper_without_exec_leaves_no_process_after_a_hang() {
    let mut config = wrapped("hang", 2);
    config.step_timeout_ms = 300;
    let (rollout, pgid, at_start) = run_variant(config);
    assert_eq!(at_start.len(), 2, "the shell and the planner under it: {at_start:?}");
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 2);
    assert_eq!(reason, "external planner `wrapped-hang` did not answer at step 2 within 300 ms");
    assert_group_gone(pgid);
}

#[cfg(target_os = "linux")]
#[test]
fn a_wrapper_without_exec_leaves_no_process_after_a_completed_variant() {
    let (rollout, pgid, at_start) = run_variant(wrapped("spawn-child", 0));
    // The shell, python and python's `sleep 600`.
    assert_eq!(at_start.len(), 3, "{at_start:?}");
    assert_eq!(rollout.termination, Termination::Completed);
    assert_group_gone(pgid);
}

#[cfg(target_os = "linux")]
#[test]
fn a_child_the_planner_spawned_does_not_outlive_the_variant() {
    let (rollout, pgid, at_start) = run_variant(misbehaving("spawn-child", 0));
    assert_eq!(at_start.len(), 2, "the planner and its `sleep 600`: {at_start:?}");
    assert_eq!(rollout.termination, Termination::Completed);
    assert_eq!(rollout.states.len(), 31, "every step was planned");
    assert_group_gone(pgid);
}

#[test]
fn a_planner_crashing_mid_run_fails_with_its_exit_status_and_stderr() {
    let (rollout, pgid, _) = run_variant(misbehaving("crash", 4));
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 4);
    assert!(reason.starts_with("external planner `crash` exited with exit status: 3 at step 4"), "{reason}");
    assert!(reason.contains("| misbehaving_planner: crashing at step 4"), "{reason}");
    assert_eq!(rollout.states.len(), 5, "steps 0..4 were simulated");
    assert_group_gone(pgid);
}

#[test]
fn a_crash_behind_a_wrapper_names_the_wrapper_status_and_both_stderr_tails() {
    let (rollout, pgid, _) = run_variant(wrapped("crash", 1));
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 1);
    assert!(reason.contains("exited with exit status: 0 at step 1"), "the shell's own status: {reason}");
    assert!(reason.contains("| misbehaving_planner: crashing at step 1"), "{reason}");
    assert!(reason.contains("| wrapper-without-exec: the planner exited with status 3"), "{reason}");
    assert_group_gone(pgid);
}

#[test]
fn a_planner_that_never_answers_times_out_naming_the_step_and_the_timeout() {
    let mut config = misbehaving("hang", 0);
    config.step_timeout_ms = 200;
    let t0 = Instant::now();
    let (rollout, pgid, _) = run_variant(config);
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 0);
    assert_eq!(reason, "external planner `hang` did not answer at step 0 within 200 ms");
    assert!(t0.elapsed() < Duration::from_secs(5), "{:?}", t0.elapsed());
    assert_group_gone(pgid);
}

#[test]
fn a_planner_that_never_starts_times_out_during_startup() {
    let mut config = misbehaving("slow-start", 0);
    config.startup_timeout_ms = 200;
    let err = within_deadline("a planner that never answers hello", move || {
        ExternalPlanner::start(config, 4.5, 2.0).expect_err("no ready within 200 ms")
    });
    assert_eq!(err.to_string(), "external planner `slow-start` did not answer during startup within 200 ms");
}

#[test]
fn a_planner_writing_garbage_fails_quoting_the_line() {
    let (rollout, pgid, _) = run_variant(misbehaving("garbage", 3));
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 3);
    assert!(reason.starts_with("external planner `garbage` broke the protocol at step 3: a line that is not JSON"));
    assert!(reason.contains("`this is not JSON, it is a planner talking to itself`"), "{reason}");
    assert_group_gone(pgid);
}

#[test]
fn a_planner_replying_nan_fails_naming_the_non_finite_number() {
    let (rollout, _, _) = run_variant(misbehaving("nan", 1));
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 1);
    assert!(reason.contains("non-finite number `NaN`"), "{reason}");
}

#[test]
fn a_planner_replying_accel_1e100_fails_its_variant_naming_the_invalid_state() {
    let (rollout, pgid, _) = run_variant(misbehaving("huge", 2));
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 2);
    assert!(reason.contains("invalid state"), "{reason}");
    assert!(rollout.ego_collision().is_none());
    assert_group_gone(pgid);
}

/// Runs the scene with `config` and the default vehicle limits, as a
/// suite's stage 2 holds the planner under test to them.
fn run_with_limits(config: ExternalPlannerConfig) -> Rollout {
    let name = config.name.clone();
    within_deadline(&format!("a variant with planner `{name}`"), move || {
        let mut planner = ExternalPlanner::start(config, 4.5, 2.0).expect("the planner starts");
        let config = SimConfig { ego_limits: Some(VehicleLimits::default()), ..SimConfig::default() };
        Simulation::new(&scene(), config).unwrap().run(&mut planner)
    })
}

/// The step and reason of a rollout ended by a vehicle limit.
fn limit_exceeded(r: &Rollout) -> (usize, String) {
    match &r.termination {
        Termination::VehicleLimitExceeded { step, reason } => (*step, reason.clone()),
        other => panic!("expected a vehicle limit to end the rollout, got {other:?}"),
    }
}

#[test]
fn a_planner_that_teleports_the_ego_is_stopped_at_the_step_naming_the_limit() {
    let rollout = run_with_limits(misbehaving("teleport", 3));
    let (step, reason) = limit_exceeded(&rollout);
    assert_eq!(step, 3);
    assert!(reason.contains("exceeds the vehicle limit max_position_error_m = 0.5 m"), "{reason}");
    // The ego never reached the teleported state: the record stops before it.
    assert_eq!(rollout.states.len(), 4);
}

#[test]
fn a_planner_that_stops_the_ego_instantly_is_stopped_naming_the_deceleration() {
    let (step, reason) = limit_exceeded(&run_with_limits(misbehaving("instant-stop", 2)));
    assert_eq!(step, 2);
    // From about 9.8 m/s (two steps of −1 m/s²) to 0 in 0.1 s.
    assert!(reason.starts_with("deceleration 98.000 m/s² exceeds the vehicle limit max_decel_mps2 = 12"), "{reason}");
}

#[test]
fn a_planner_reversing_while_reporting_a_standstill_is_stopped_naming_the_reversing_speed() {
    let (step, reason) = limit_exceeded(&run_with_limits(misbehaving("reverse-reporting-standstill", 0)));
    assert_eq!(step, 0);
    // Backwards 1.5 m in 0.1 s: 15 m/s; the speed drop from 10 m/s to the
    // reported 0 comes first (100 m/s²).
    assert!(reason.contains("exceeds the vehicle limit max_decel_mps2"), "{reason}");
}

#[test]
fn a_planner_crabbing_sideways_is_stopped_when_the_drift_adds_up() {
    // 0.35 m sideways a step passes the 0.5 m position check every step.
    let (step, reason) = limit_exceeded(&run_with_limits(misbehaving("crab", 0)));
    assert_eq!(step, 1, "{reason}");
    assert!(reason.contains("exceeds the vehicle limit max_lateral_slip_m = 0.5 m"), "{reason}");
}

#[test]
fn a_swerve_beyond_a_cars_grip_is_stopped_naming_the_lateral_acceleration() {
    // 1.4 rad/s is inside the yaw-rate limit; at 10 m/s it pulls 14 m/s².
    let (step, reason) = limit_exceeded(&run_with_limits(misbehaving("swerve", 0)));
    assert_eq!(step, 0);
    assert!(
        reason.starts_with("lateral acceleration 14.000 m/s² exceeds the vehicle limit max_lateral_accel_mps2 = 9"),
        "{reason}"
    );
}

#[test]
fn a_yaw_rate_of_1e308_is_reported_as_sent() {
    // It was reported as the wrapped heading change, "yaw rate 24.053 rad/s".
    let (step, reason) = limit_exceeded(&run_with_limits(misbehaving("huge-yaw", 0)));
    assert_eq!(step, 0);
    assert!(
        reason.starts_with("yaw rate sent 1e308 rad/s exceeds the vehicle limit max_yaw_rate_radps = 1.5"),
        "{reason}"
    );
}

#[test]
fn without_limits_the_same_replies_run_on_which_is_what_the_check_exists_for() {
    // The unchecked simulator accepts a teleport: the check, not the
    // simulator, is what stops it.
    let (rollout, _, _) = run_variant(misbehaving("teleport", 3));
    assert!(matches!(rollout.termination, Termination::Completed | Termination::LeftMappedArea { .. }), "{rollout:?}");
}

/// One reply too many puts every later reply one step late. A planner
/// speaking 1.2 names the step each reply answers, so the run fails at the
/// next step, every time, naming the step answered twice (the second reply
/// is either waiting before the next observation is sent or read as its
/// answer: both fail there).
#[test]
fn an_extra_reply_from_a_1_2_planner_fails_the_next_step_every_time() {
    for run in 0..6 {
        let (rollout, pgid, _) = run_variant(misbehaving_speaking("extra-reply", 4, 2));
        let (step, reason) = failure(&rollout);
        assert_eq!(step, 5, "run {run}: {reason}");
        assert!(reason.contains("\"step\": 4}") || reason.contains("answers step 4"), "run {run}: {reason}");
        assert!(reason.contains("out of step"), "run {run}: {reason}");
        assert_group_gone(pgid);
    }
}

/// A 1.2 planner that leaves `step` out of a reply breaks the protocol.
#[test]
fn a_1_2_reply_without_its_step_fails_naming_the_step_expected() {
    // Speaks 1.2 in `ready` but its replies carry no step, as in 1.1.
    let (rollout, pgid, _) = run_variant(misbehaving_speaking("untagged", 0, 2));
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 0);
    assert_eq!(
        reason,
        "external planner `untagged` broke the protocol at step 0: its `control` names no `step`; a planner speaking protocol 1.2 names the step it answers (0 here)"
    );
    assert_group_gone(pgid);
}

/// 1.0 and 1.1 planners name no step and keep working; a step they do
/// name is checked.
#[test]
fn older_planners_run_untagged_and_a_step_they_name_is_checked() {
    for minor in [0, 1] {
        let (rollout, _, _) = run_variant(misbehaving_speaking("untagged", 0, minor));
        assert_eq!(rollout.termination, Termination::Completed, "1.{minor}");
    }
    let (rollout, _, _) = run_variant(misbehaving_speaking("wrong-step", 2, 1));
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 2);
    assert!(reason.contains("answers step 3, but the observation was step 2"), "{reason}");
}

/// A planner that writes controls without reading its observations passed
/// every variant before. Speaking 1.0 its lines are answers to no question:
/// the run fails as soon as one is found waiting (which step depends on
/// how fast its lines arrive). Speaking 1.2 it cannot name the step it
/// answers (or its lines arrive in place of `prepared`), and fails at the
/// first.
#[test]
fn a_planner_writing_controls_without_reading_fails() {
    let mut config = misbehaving("blind", 0);
    config.step_timeout_ms = 2000;
    let (rollout, pgid, _) = run_variant(config);
    let (_, reason) = failure(&rollout);
    assert!(reason.contains("nobody asked for"), "{reason}");
    assert_group_gone(pgid);
    let (rollout, pgid, _) = run_variant(misbehaving_speaking("blind", 0, 2));
    let (step, reason) = failure(&rollout);
    assert_eq!(step, 0, "{reason}");
    // Which of its stray lines the harness meets first depends on timing:
    // one in place of `prepared` (under load), or an untagged reply.
    let broke_the_protocol = ["names no `step`", "nobody asked for", "expected `prepared` in answer to `prepare`"];
    assert!(broke_the_protocol.iter().any(|m| reason.contains(m)), "{reason}");
    assert_group_gone(pgid);
}
