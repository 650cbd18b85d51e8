//! Open simulation of all agents, with no ego planner: what the Waymo Sim
//! Agents realism metrics score. WOSAC simulates the ego (the SDC) like any
//! other agent, so here every agent present at the start step is driven by
//! its own [`AgentPolicy`]; agents absent at the start follow log replay
//! (they appear and disappear as logged).
//!
//! Deterministic: agents act in track order on the same world view, and the
//! result depends only on the scenario, the range and the policies.

use super::{DT_TOLERANCE, SimError, advance};
use crate::motion::tokens::SIM_DT_S;
use crate::policies::{AgentAction, AgentPolicy, LogReplay, WorldView};
use crate::scenario::{AgentBody, AgentState, Scenario, TrackIndex};

/// Simulates every agent of `scenario` from `start_step` to `end_step`
/// (inclusive). `policies` is asked once, in track order, for the policy of
/// each agent present at `start_step`; agents absent then replay their log
/// and appear and disappear as logged.
///
/// Returns `states[k][i]`: track `i` at step `start_step + k` (as
/// `Rollout::states`), `k = 0..=end_step - start_step`, `states[0]` the
/// logged start.
pub fn simulate_all_agents(
    scenario: &Scenario,
    start_step: usize,
    end_step: usize,
    mut policies: impl FnMut(TrackIndex) -> Box<dyn AgentPolicy>,
) -> Result<Vec<Vec<Option<AgentState>>>, SimError> {
    let mut all = simulate_rollouts_in_lockstep(scenario, start_step, end_step, 1, |_, a| policies(a), |_| {})?;
    Ok(all.pop().unwrap_or_default())
}

/// Simulates `rollouts` independent rollouts of `scenario` (each as
/// [`simulate_all_agents`]) step by step side by side, so that work shared
/// by the rollouts can be done once per step: `before_step` sees the world
/// of every rollout at each step before any agent acts (the prior's
/// decoder batches every rollout's queries there). `policies(r, agent)` is
/// asked rollout by rollout, in track order. Each rollout's result is the
/// same as simulating it alone with the same policies.
pub fn simulate_rollouts_in_lockstep(
    scenario: &Scenario,
    start_step: usize,
    end_step: usize,
    rollouts: usize,
    mut policies: impl FnMut(usize, TrackIndex) -> Box<dyn AgentPolicy>,
    mut before_step: impl FnMut(&[WorldView<'_>]),
) -> Result<Vec<Vec<Vec<Option<AgentState>>>>, SimError> {
    if (scenario.dt_s - SIM_DT_S).abs() > DT_TOLERANCE * SIM_DT_S {
        return Err(SimError::StepMismatch { scenario: scenario.id.clone(), dt_s: scenario.dt_s });
    }
    if start_step >= end_step || end_step >= scenario.num_steps() {
        return Err(SimError::BadRange {
            scenario: scenario.id.clone(),
            start: start_step,
            end: end_step,
            steps: scenario.num_steps(),
        });
    }
    let bodies: Vec<AgentBody> = scenario.tracks.iter().map(|t| t.body()).collect();
    let mut drivers: Vec<Vec<Box<dyn AgentPolicy>>> = (0..rollouts)
        .map(|r| {
            (0..scenario.tracks.len())
                .map(|i| {
                    let agent = TrackIndex(i);
                    if scenario.track(agent).state(start_step).is_some() {
                        policies(r, agent)
                    } else {
                        Box::new(LogReplay::new(scenario.track(agent).clone())) as Box<dyn AgentPolicy>
                    }
                })
                .collect()
        })
        .collect();
    let initial: Vec<Option<AgentState>> = scenario.tracks.iter().map(|t| t.state(start_step).copied()).collect();
    let mut states: Vec<Vec<Option<AgentState>>> = vec![initial; rollouts];
    let mut records: Vec<Vec<Vec<Option<AgentState>>>> = states
        .iter()
        .map(|s| {
            let mut record = Vec::with_capacity(end_step - start_step + 1);
            record.push(s.clone());
            record
        })
        .collect();
    for step in start_step..end_step {
        let worlds: Vec<WorldView<'_>> =
            states.iter().map(|s| WorldView { map: &scenario.map, step, bodies: &bodies, states: s }).collect();
        before_step(&worlds);
        let actions: Vec<Vec<AgentAction>> = drivers
            .iter_mut()
            .zip(&worlds)
            .map(|(d, world)| d.iter_mut().enumerate().map(|(i, p)| p.act(world, TrackIndex(i))).collect())
            .collect();
        drop(worlds);
        for ((s, a), record) in states.iter_mut().zip(&actions).zip(&mut records) {
            *s = advance(s, a);
            record.push(s.clone());
        }
    }
    Ok(records)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::map::RoadMap;
    use crate::policies::{BackgroundPolicy, ConstantVelocity};
    use crate::scenario::{AgentId, AgentKind, ScenarioSource, Track};

    /// Agent 0 drives at 10 m/s from step 0 but turns in the log; agent 1
    /// appears at step 5 and leaves after step 8.
    fn scene() -> Scenario {
        let state = |x: f64, y: f64, h: f64| AgentState {
            position: Point2::new(x, y),
            heading_rad: h,
            velocity_mps: Vector2::new(10.0 * h.cos(), 10.0 * h.sin()),
        };
        let turning = Track {
            id: AgentId("0".into()),
            kind: AgentKind::Vehicle,
            length_m: 4.0,
            width_m: 2.0,
            states: (0..12).map(|k| Some(state(k as f64, 0.1 * k as f64, 0.1))).collect(),
        };
        let late = Track {
            id: AgentId("1".into()),
            kind: AgentKind::Vehicle,
            length_m: 4.0,
            width_m: 2.0,
            states: (0..12).map(|k| (5..=8).contains(&k).then(|| state(50.0 + k as f64, 10.0, 0.0))).collect(),
        };
        Scenario::new("traffic", ScenarioSource::authored("test"), 0.1, RoadMap::default(), vec![turning, late])
    }

    #[test]
    fn present_agents_follow_their_policy_and_late_ones_replay_the_log() {
        let s = scene();
        let states = simulate_all_agents(&s, 0, 11, |_| Box::new(ConstantVelocity)).unwrap();
        assert_eq!(states.len(), 12);
        assert_eq!(states[0][0], s.tracks[0].states[0]);
        // Constant velocity: heading stays 0.1 and speed 10 m/s along it.
        let last = states[11][0].unwrap();
        assert!((last.heading_rad - 0.1).abs() < 1e-12);
        let travelled = (last.position - states[0][0].unwrap().position).norm();
        assert!((travelled - 11.0).abs() < 1e-9, "{travelled}");
        // The late agent appears at step 5, leaves after step 8, as logged.
        for (k, row) in states.iter().enumerate() {
            assert_eq!(row[1], s.tracks[1].states[k], "step {k}");
        }
    }

    #[test]
    fn rollouts_in_lockstep_equal_rollouts_alone_and_the_hook_sees_every_step() {
        let s = scene();
        let policy = |r: usize, a: TrackIndex| match r {
            0 => Box::new(ConstantVelocity) as Box<dyn AgentPolicy>,
            _ => BackgroundPolicy::LogReplay.instantiate(&s, a),
        };
        let mut seen = Vec::new();
        let together = simulate_rollouts_in_lockstep(&s, 1, 11, 2, policy, |worlds| {
            seen.push((worlds.len(), worlds[0].step, worlds[1].step));
        })
        .unwrap();
        assert_eq!(seen, (1..11).map(|k| (2, k, k)).collect::<Vec<_>>());
        for (r, states) in together.iter().enumerate() {
            assert_eq!(states, &simulate_all_agents(&s, 1, 11, |a| policy(r, a)).unwrap(), "rollout {r}");
        }
        assert_ne!(together[0], together[1]);
    }

    #[test]
    fn log_replay_of_everyone_reproduces_the_log_and_bad_ranges_are_errors() {
        let s = scene();
        let states = simulate_all_agents(&s, 2, 11, |a| BackgroundPolicy::LogReplay.instantiate(&s, a)).unwrap();
        for (k, row) in states.iter().enumerate() {
            for (i, t) in s.tracks.iter().enumerate() {
                assert_eq!(row[i], t.states[2 + k]);
            }
        }
        assert!(matches!(
            simulate_all_agents(&s, 5, 12, |_| Box::new(ConstantVelocity)),
            Err(SimError::BadRange { .. })
        ));
        assert!(matches!(
            simulate_all_agents(&s, 5, 5, |_| Box::new(ConstantVelocity)),
            Err(SimError::BadRange { .. })
        ));
    }
}
