//! The feasibility witness asked before a contact is made, for the
//! `witnessed` feasibility scope (beyond the paper; [`FeasibilityScope`](super::FeasibilityScope)).
//!
//! V_h answers for the ego–CBV pair alone; the witness that `safer
//! evaluate` searches afterwards answers for the whole scene: is there an
//! ego trajectory, from the ego's first state, that keeps clear of every
//! other agent as they drove and stays on the road? In the `witnessed`
//! scope the candidate the adversary is about to take (the one-step token,
//! or the continuation that gave the lookahead's first token its loss) is
//! asked of the same search when it leads the CBV near the ego: when, both
//! held at constant velocity from the candidate's end, the CBV comes within
//! [`WITNESS_CHECK_GAP_M`] of the ego's prediction within
//! [`WITNESS_HOLD_S`]. The search runs on the rollout so far, continued by
//! the background as the adversary forecasts it and by the CBV along the
//! candidate and then, for [`WITNESS_HOLD_S`], closing in on where the ego
//! would be at the candidate's end at [`ESCAPE_PURSUIT_MPS2`](super::ESCAPE_PURSUIT_MPS2) (the
//! adversary keeps coming after a contact: a CBV creeping into a queued
//! ego's bumper is escaped by the ego inching forward, and then it pushes
//! on, which is what `safer evaluate`'s witness sees over the whole
//! rollout).
//! Where it finds no escape the candidate counts as infeasible and the
//! choice moves on. Only the candidate about to be taken is asked, and at
//! most [`WITNESS_CHECKS_PER_TOKEN`] a token boundary (after that every
//! near candidate counts as infeasible), so the search costs little where
//! escapes exist and stays bounded where none does.
//!
//! The search itself belongs to the evaluation layer: the adversary asks it
//! through [`EscapeWitness`], which the harness implements.

use std::cell::Cell;

use super::background_forecast::BackgroundForecast;
use super::escape_room::closing_in;
use crate::geometry::Point2;
use crate::map::RoadMap;
use crate::motion::tokens::SIM_DT_S;
use crate::policies::WorldView;
use crate::scenario::{AgentBody, AgentState, TrackIndex};

/// The box gap to the ego's prediction within which a candidate's CBV,
/// held at constant velocity after it, must come for the candidate to be
/// asked of the witness before it is taken, m (the gap `pair-in-traffic`
/// checks within).
pub const WITNESS_CHECK_GAP_M: f64 = super::ESCAPE_CHECK_GAP_M;

/// How long the CBV keeps closing in after a candidate's end in the
/// witness's traffic, s: the ego must escape what the candidate leads
/// into, not only the candidate (the escape horizon of `pair-in-traffic`).
pub const WITNESS_HOLD_S: f64 = super::ESCAPE_HORIZON_S;

const HOLD_STEPS: usize = (WITNESS_HOLD_S / SIM_DT_S + 0.5) as usize;

/// How many witness searches one token boundary may run; past them every
/// near candidate counts as infeasible (a boxed-in ego whose every contact
/// is unescapable would otherwise cost a failed search per candidate).
pub const WITNESS_CHECKS_PER_TOKEN: usize = 4;

/// The fixed-traffic feasibility witness, as the adversary asks it.
pub trait EscapeWitness: Send + Sync {
    /// Whether the ego, from its state in the first row of `states`, can
    /// keep clear of every other agent as `states` has them (`states[k][i]`:
    /// agent i at step k, `None`: absent) to the last row, keeping to
    /// `map`'s road.
    fn ego_escapes(&self, map: &RoadMap, states: &[Vec<Option<AgentState>>], bodies: &[AgentBody], ego: usize) -> bool;
}

/// Whether a CBV at `cbv_end` comes within [`WITNESS_CHECK_GAP_M`] of the
/// ego at `ego_end` (the same instant) within [`WITNESS_HOLD_S`], both
/// keeping their velocity: the candidates the witness is asked of.
pub(super) fn closes_in(ego_end: &AgentState, ego_body: AgentBody, cbv_end: &AgentState, cbv_body: AgentBody) -> bool {
    (0..=HOLD_STEPS).any(|k| {
        let t_s = k as f64 * SIM_DT_S;
        let ego = AgentState { position: ego_end.position + ego_end.velocity_mps * t_s, ..*ego_end };
        let cbv = AgentState { position: cbv_end.position + cbv_end.velocity_mps * t_s, ..*cbv_end };
        ego_body.footprint(&ego).distance(&cbv_body.footprint(&cbv)) <= WITNESS_CHECK_GAP_M
    })
}

/// One token boundary's witness questions: the rollout so far and the
/// background's forecast, to be continued by a candidate path of the CBV.
pub(super) struct ContactWitness<'a> {
    witness: &'a dyn EscapeWitness,
    world: &'a WorldView<'a>,
    cbv: TrackIndex,
    ego: TrackIndex,
    /// Every agent at each step of the rollout so far, the last row now.
    history: &'a [Vec<Option<AgentState>>],
    /// Every agent but the ego and the CBV at each step after now, as forecast.
    ahead: Vec<Vec<Option<AgentState>>>,
    checks_left: Cell<usize>,
}

impl<'a> ContactWitness<'a> {
    /// The questions of the boundary at `world.step`, for CBV paths of up to
    /// `path_steps` steps; `history` is the rollout from its first step to
    /// now (an empty one stands for the world now).
    pub(super) fn new(
        witness: &'a dyn EscapeWitness,
        world: &'a WorldView<'a>,
        (cbv, ego): (TrackIndex, TrackIndex),
        forecast: &BackgroundForecast<'_>,
        history: &'a [Vec<Option<AgentState>>],
        path_steps: usize,
    ) -> Self {
        let ahead_steps = path_steps + HOLD_STEPS;
        let mut ahead = vec![vec![None; world.states.len()]; ahead_steps];
        for i in (0..world.states.len()).filter(|&i| i != cbv.0 && i != ego.0) {
            let (states, _) = forecast.states(world, TrackIndex(i), ahead_steps);
            for (row, s) in ahead.iter_mut().zip(states) {
                row[i] = s;
            }
        }
        Self { witness, world, cbv, ego, history, ahead, checks_left: Cell::new(WITNESS_CHECKS_PER_TOKEN) }
    }

    /// Whether the ego could escape a CBV that drives `cbv_path` (its
    /// states over the steps after now, at most the boundary's path
    /// length) and then, for [`WITNESS_HOLD_S`], accelerates from its
    /// velocity at [`ESCAPE_PURSUIT_MPS2`](super::ESCAPE_PURSUIT_MPS2) towards `ego_end` (where the
    /// ego's prediction is at the path's end): `false` once the
    /// boundary's searches are spent.
    pub(super) fn escapable(&self, cbv_path: &[AgentState], ego_end: &Point2) -> bool {
        let left = self.checks_left.get();
        if left == 0 {
            return false;
        }
        self.checks_left.set(left - 1);
        let now = [self.world.states.to_vec()];
        let history = if self.history.is_empty() { &now[..] } else { self.history };
        let mut states = history.to_vec();
        let held = cbv_path.last().map(|end| closing_in(end, ego_end, HOLD_STEPS)).unwrap_or_default();
        for (row, s) in self.ahead.iter().zip(cbv_path.iter().copied().chain(held)) {
            let mut row = row.clone();
            row[self.cbv.0] = Some(s);
            states.push(row);
        }
        self.witness.ego_escapes(self.world.map, &states, self.world.bodies, self.ego.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::policies::adversary::ESCAPE_PURSUIT_MPS2;
    use crate::policies::adversary::test_support::car;
    use crate::scenario::AgentKind;
    use std::sync::Mutex;

    /// Records what it was asked and answers `escapes`.
    struct Recording {
        escapes: bool,
        asked: Mutex<Vec<Vec<Vec<Option<AgentState>>>>>,
    }
    impl EscapeWitness for Recording {
        fn ego_escapes(&self, _: &RoadMap, states: &[Vec<Option<AgentState>>], _: &[AgentBody], ego: usize) -> bool {
            assert_eq!(ego, 0);
            self.asked.lock().unwrap().push(states.to_vec());
            self.escapes
        }
    }

    #[test]
    fn the_witness_sees_the_rollout_so_far_then_the_forecast_and_the_cbv_path() {
        // Ego, CBV, and a car at 10 m/s (forecast at constant velocity).
        let now = vec![car(0.0, 0.0, 5.0), car(-10.0, 0.0, 8.0), car(20.0, 0.0, 10.0)];
        let earlier = vec![car(-0.5, 0.0, 5.0), car(-10.8, 0.0, 8.0), car(19.0, 0.0, 10.0)];
        let history = vec![earlier.clone(), now.clone()];
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let world = WorldView { map: &map, step: 1, bodies: &bodies, states: &now };
        let witness = Recording { escapes: true, asked: Mutex::new(Vec::new()) };
        let forecast = BackgroundForecast::default();
        let check = ContactWitness::new(&witness, &world, (TrackIndex(1), TrackIndex(0)), &forecast, &history, 5);
        let path: Vec<AgentState> = (1..=3).map(|k| car(-10.0 + 0.8 * k as f64, 0.0, 8.0).unwrap()).collect();
        assert!(check.escapable(&path, &Point2::new(1.5, 0.0)));
        let asked = witness.asked.lock().unwrap()[0].clone();
        // Two rows of history, then the CBV's path, then the CBV closing in
        // on the ego's predicted place (ahead of it along +x) for the hold.
        assert_eq!(asked.len(), 2 + 3 + HOLD_STEPS);
        assert_eq!(asked[..2], history[..]);
        for (k, row) in asked[2..].iter().enumerate() {
            assert_eq!(row[0], None, "the ego's own future is the witness's to find");
            let t_s = (k as f64 - 2.0) * SIM_DT_S;
            let expected = if k < 3 {
                -10.0 + 0.8 * (k + 1) as f64
            } else {
                -7.6 + 8.0 * t_s + 0.5 * ESCAPE_PURSUIT_MPS2 * t_s * t_s
            };
            let cbv = row[1].unwrap();
            assert!((cbv.position.x - expected).abs() < 1e-9 && cbv.position.y == 0.0, "step {k}: {cbv:?}");
            let x = row[2].unwrap().position.x;
            assert!((x - (20.0 + (k + 1) as f64)).abs() < 1e-9, "{x}");
        }
    }

    #[test]
    fn a_candidate_is_near_when_held_on_it_closes_within_the_gap() {
        let body = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };
        let ego = car(0.0, 0.0, 0.0).unwrap();
        // 10 m behind the stopped ego's box at 7 m/s: within the gap in 1.3 s.
        assert!(closes_in(&ego, body, &car(-14.5, 0.0, 7.0).unwrap(), body));
        // The same gap at 2 m/s: 4 m in the hold, not near.
        assert!(!closes_in(&ego, body, &car(-14.5, 0.0, 2.0).unwrap(), body));
        // In the next lane, passing: never within the gap.
        assert!(!closes_in(&ego, body, &car(-14.5, 4.0, 7.0).unwrap(), body));
    }

    #[test]
    fn past_its_searches_a_boundary_counts_every_contact_unescapable() {
        let now = vec![car(0.0, 0.0, 5.0), car(-10.0, 0.0, 8.0)];
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &now };
        let witness = Recording { escapes: true, asked: Mutex::new(Vec::new()) };
        let forecast = BackgroundForecast::default();
        let check = ContactWitness::new(&witness, &world, (TrackIndex(1), TrackIndex(0)), &forecast, &[], 5);
        let path = [now[1].unwrap()];
        let answers: Vec<bool> =
            (0..WITNESS_CHECKS_PER_TOKEN + 2).map(|_| check.escapable(&path, &Point2::new(0.0, 0.0))).collect();
        assert!(answers[..WITNESS_CHECKS_PER_TOKEN].iter().all(|&a| a));
        assert!(answers[WITNESS_CHECKS_PER_TOKEN..].iter().all(|&a| !a));
        // Without a history the world now is the rollout's first row.
        assert_eq!(witness.asked.lock().unwrap()[0][0], now);
    }
}
