//! The closed-loop simulator on every recorded scene.

use rayon::prelude::*;
use safer_scenarios::planners::BuiltinPlanner;
use safer_scenarios::policies::BackgroundPolicy;
use safer_scenarios::scenario::Scenario;
use safer_scenarios::sim::{Rollout, SimConfig, Simulation, Termination};

use crate::shared_data::all_scenes;

fn rollout(s: &Scenario, planner: BuiltinPlanner, background: BackgroundPolicy) -> Rollout {
    let ego = s.ego.unwrap_or_else(|| panic!("{}: no ego", s.id));
    let mut p = planner.instantiate(s, ego);
    Simulation::new(s, SimConfig { background, ..SimConfig::default() })
        .unwrap_or_else(|e| panic!("{e}"))
        .run(p.as_mut())
}

/// Scenes long enough for an adversarial variant (more than 20 future steps
/// after "now"); a few NGSIM files hold only 1.5 s.
fn long_enough(s: &Scenario) -> bool {
    s.num_steps() > s.current_step + 21
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn most_scenes_have_an_ego_and_a_cbv_and_the_others_say_why() {
    let scenes = all_scenes();
    assert!(scenes.len() >= 150, "only {} scenes imported", scenes.len());
    let with_roles = scenes.iter().filter(|s| s.ego.is_some() && s.cbv.is_some()).count();
    for s in scenes.iter().filter(|s| s.ego.is_none() || s.cbv.is_none()) {
        // Too short, or fewer than two moving vehicles: the notes must say so.
        assert!(s.source.notes.iter().any(|n| n.contains("conflict mining needs")), "{}: {:?}", s.id, s.source.notes);
    }
    assert!(with_roles * 10 >= scenes.len() * 9, "only {with_roles} of {} scenes have ego and CBV", scenes.len());
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn log_replay_reproduces_every_recorded_ego() {
    let logged_ego_collisions: Vec<String> = all_scenes()
        .par_iter()
        .filter(|s| s.ego.is_some())
        .filter_map(|s| {
            let r = rollout(s, BuiltinPlanner::LogReplay, BackgroundPolicy::LogReplay);
            let ego = s.track(r.ego);
            for (k, step) in r.states.iter().enumerate() {
                assert_eq!(step[r.ego.0].as_ref(), ego.state(r.start_step + k), "{}: ego differs at step {k}", s.id);
            }
            match &r.termination {
                Termination::Completed => assert_eq!(r.states.len(), s.num_steps() - s.current_step),
                // A few recordings drive on past the end of their map: the
                // replay stops there, with the recording still going.
                Termination::LeftMappedArea { step } => {
                    assert!(*step > r.start_step && ego.state(*step).is_some(), "{}: {:?}", s.id, r.termination)
                }
                // A replayed ego can only stop where its recording has a gap.
                Termination::PlannerFailed { step, .. } => {
                    assert!(ego.state(step + 1).is_none(), "{}: {:?}", s.id, r.termination)
                }
                other => panic!("{}: {other:?}", s.id),
            }
            // Replayed logs collide only where the recording itself has
            // overlapping boxes (known NGSIM annotation errors).
            r.ego_collision().map(|c| format!("{} at step {}", s.id, c.step))
        })
        .collect();
    eprintln!("logged ego collisions: {logged_ego_collisions:?}");
    assert!(logged_ego_collisions.len() * 20 <= all_scenes().len(), "{logged_ego_collisions:?}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn idm_rollouts_are_identical_on_one_and_two_threads() {
    // Two scenes of each format keep this quick.
    let mut picked: Vec<&Scenario> = Vec::new();
    for s in all_scenes().iter().filter(|s| long_enough(s)) {
        if picked.iter().filter(|p| p.source.format == s.source.format).count() < 2 {
            picked.push(s);
        }
    }
    assert!(picked.len() >= 2, "too few recorded scenes long enough to compare: {}", picked.len());
    let run_all = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            picked
                .par_iter()
                .map(|s| rollout(s, BuiltinPlanner::Idm, BackgroundPolicy::Idm))
                .map(|r| (r.states, r.collisions, r.termination))
                .collect::<Vec<_>>()
        })
    };
    let (one, two) = (run_all(1), run_all(2));
    assert_eq!(one.len(), picked.len());
    for ((a, b), s) in one.iter().zip(&two).zip(&picked) {
        assert!(a == b, "{}: rollout differs between 1 and 2 threads", s.id);
    }
}

/// The traffic-rule criteria on the recorded drivers themselves: the
/// logged ego of every shared scene, replayed. Real drivers rarely drive
/// against a lane's traffic or through a red light, so the rules must not
/// flag them wholesale; each flagged one is printed for a look.
#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn recorded_egos_mostly_keep_the_traffic_rules() {
    use safer_scenarios::eval::traffic_rules::{red_light_run, wrong_way};
    let scenes: Vec<&Scenario> = all_scenes().iter().filter(|s| s.ego.is_some()).collect();
    let flagged: Vec<(String, Option<String>, Option<String>)> = scenes
        .par_iter()
        .filter_map(|s| {
            let r = rollout(s, BuiltinPlanner::LogReplay, BackgroundPolicy::LogReplay);
            let wrong = wrong_way(&r, &s.map)
                .map(|w| format!("{:.1} s against lane {} from {:.1} s", w.duration_s, w.lane.0, w.start_s));
            let red =
                red_light_run(&r, &s.map).map(|x| format!("lane {} at {:.1} s ({:?})", x.lane.0, x.time_s, x.state));
            (wrong.is_some() || red.is_some()).then(|| (s.id.clone(), wrong, red))
        })
        .collect();
    let (wrong, red) =
        (flagged.iter().filter(|f| f.1.is_some()).count(), flagged.iter().filter(|f| f.2.is_some()).count());
    println!("{} recorded egos: {wrong} wrong way, {red} red light", scenes.len());
    for f in &flagged {
        println!("  {f:?}");
    }
    assert!(wrong * 20 <= scenes.len(), "{wrong} of {} recorded egos drove the wrong way: {flagged:?}", scenes.len());
    assert!(red * 20 <= scenes.len(), "{red} of {} recorded egos ran a red light: {flagged:?}", scenes.len());
}
