//! What the adversary knows of the background's next seconds
//! ([`BackgroundForecast`]): replayed agents where their recording puts
//! them, every other agent at constant velocity.

use crate::motion::tokens::SIM_DT_S;
use crate::policies::WorldView;
use crate::scenario::{AgentState, TrackIndex};

/// What the adversary knows of the background's next seconds. An agent the
/// rollout replays from its recording (log replay, and reactive replay
/// while it keeps to the recording) will be where its recording says: the
/// scenario generator replays it, so it knows. Any other agent (driven by
/// the prior or a rule, or off its recording) is predicted at constant
/// velocity. Without a recording every agent is.
#[derive(Debug, Clone, Copy, Default)]
pub struct BackgroundForecast<'a> {
    /// The scenario whose recordings replayed agents follow.
    pub recording: Option<&'a crate::scenario::Scenario>,
    /// Agents that are not replayed (the prior drives them), sorted.
    pub not_replayed: &'a [usize],
}

/// How far an agent may be from its recorded position and still be taken
/// to follow its recording, m (reactive replay falls behind it when it
/// brakes; then it is predicted at constant velocity).
const ON_RECORDING_TOLERANCE_M: f64 = 0.5;

impl BackgroundForecast<'_> {
    /// The recorded track `agent` follows now, if it is replayed from it
    /// (not driven by the prior, and where its recording puts it).
    fn replayed_track(&self, world: &WorldView<'_>, agent: TrackIndex) -> Option<&crate::scenario::Track> {
        let now = world.state(agent);
        self.recording
            .filter(|_| self.not_replayed.binary_search(&agent.0).is_err())
            .and_then(|r| r.tracks.get(agent.0))
            .filter(|track| match (now, track.state(world.step)) {
                (Some(now), Some(then)) => (now.position - then.position).norm() <= ON_RECORDING_TOLERANCE_M,
                // A replayed agent enters (or leaves) as recorded.
                (None, _) => true,
                (Some(_), None) => false,
            })
    }

    /// `agent`'s predicted states over the `steps` simulator steps after
    /// `world.step` (`None`: absent at that step), and whether they come
    /// from its recording (a replayed agent, which cannot yield).
    pub(super) fn states(
        &self,
        world: &WorldView<'_>,
        agent: TrackIndex,
        steps: usize,
    ) -> (Vec<Option<AgentState>>, bool) {
        match (self.replayed_track(world, agent), world.state(agent)) {
            (Some(track), _) => ((1..=steps).map(|k| track.state(world.step + k).copied()).collect(), true),
            (None, Some(s)) => (
                (1..=steps)
                    .map(|k| Some(AgentState { position: s.position + s.velocity_mps * (k as f64 * SIM_DT_S), ..*s }))
                    .collect(),
                false,
            ),
            (None, None) => (Vec::new(), false),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::RoadMap;
    use crate::motion::tokens::MAX_ACCEL_MPS2;
    use crate::policies::adversary::plausibility::{ContactRule, PlausibilityCheck};
    use crate::policies::adversary::rollout::token_rollouts;
    use crate::policies::adversary::test_support::{car, token};
    use crate::scenario::{AgentBody, AgentKind};

    /// Ego far away, the CBV at 10 m/s, and a car 12 m ahead of it at
    /// 10 m/s whose recording brakes at 8 m/s² to a stop (6.25 m on).
    fn behind_a_recorded_braking_car() -> (crate::scenario::Scenario, [Option<AgentState>; 3]) {
        use crate::scenario::{AgentId, ScenarioSource, Track};
        let states = [car(0.0, 100.0, 0.0), car(0.0, 0.0, 10.0), car(12.0, 0.0, 10.0)];
        let braking = (0..40)
            .map(|k| {
                let t = (k as f64 * SIM_DT_S).min(1.25);
                car(12.0 + 10.0 * t - 4.0 * t * t, 0.0, 10.0 - 8.0 * t)
            })
            .collect();
        let held = |s: Option<AgentState>| (0..40).map(|_| s).collect();
        let track = |id: &str, states| Track {
            id: AgentId(id.into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            states,
        };
        let tracks = vec![track("ego", held(states[0])), track("cbv", held(states[1])), track("lead", braking)];
        let scenario = crate::scenario::Scenario::new(
            "braking-lead",
            ScenarioSource::authored("test"),
            SIM_DT_S,
            RoadMap::default(),
            tracks,
        )
        .with_roles(TrackIndex(0), Some(TrackIndex(1)));
        (scenario, states)
    }

    #[test]
    fn a_replayed_car_is_forecast_by_its_recording_and_others_at_constant_velocity() {
        let (scenario, states) = behind_a_recorded_braking_car();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let world = WorldView { map: &scenario.map, step: 0, bodies: &bodies, states: &states };
        let tokens = [token(0.0), token(-MAX_ACCEL_MPS2)];
        let rollouts = token_rollouts(states[1].as_ref().unwrap(), &tokens);
        let implausible = |world: &WorldView<'_>, forecast: BackgroundForecast<'_>| {
            let check = PlausibilityCheck::new(world, TrackIndex(1), TrackIndex(0), &forecast);
            rollouts.iter().map(|r| check.implausible(r, ContactRule::Any)).collect::<Vec<bool>>()
        };
        // Replayed: holding speed runs into the car as it brakes; braking does not.
        let replayed = BackgroundForecast { recording: Some(&scenario), not_replayed: &[] };
        assert_eq!(implausible(&world, replayed), vec![true, false]);
        // At constant velocity the car keeps its 10 m/s: both are plausible.
        assert_eq!(implausible(&world, BackgroundForecast::default()), vec![false, false]);
        // Driven by the prior, or 1 m off its recording: constant velocity too.
        assert_eq!(implausible(&world, BackgroundForecast { not_replayed: &[2], ..replayed }), vec![false, false]);
        let off = [states[0], states[1], car(13.0, 0.0, 10.0)];
        let world = WorldView { states: &off, ..world };
        assert_eq!(implausible(&world, replayed), vec![false, false]);
    }
}
