//! Completions: a candidate of the beam tried on to the horizon straight
//! on, braking to a standstill or holding its speed
//! ([`COMPLETIONS_MPS2`]), checked as every beam step is (clearance above
//! the margin, on the road); once the ego is past the conflict one of them
//! is usually clear, and the search ends early with it.

use super::candidates::{Candidate, trajectory_to};
use super::memo::ClearanceMemo;
use super::road_cells::RoadCells;
use crate::geometry::BoxSet;
use crate::motion::KinematicState;
use crate::motion::kinematics::step_to_heading;
use crate::motion::tokens::{MAX_ACCEL_MPS2, SIM_DT_S};
use crate::scenario::{AgentBody, AgentState};

/// The accelerations with which a candidate may finish the horizon
/// straight on, without more search, in the order tried: braking as hard as
/// the token grid allows to a standstill (the minimal-risk manoeuvre of an
/// automated car) and holding its speed. Once the ego is past the conflict
/// one of them is usually clear of everything, and the beam's remaining
/// periods would only confirm it.
pub(super) const COMPLETIONS_MPS2: [f64; 2] = [-MAX_ACCEL_MPS2, 0.0];

/// Candidates of each beam, in beam order, whose completions are tried
/// (each completion costs up to one clearance query per remaining step).
pub(super) const COMPLETED_PER_BEAM: usize = 3;

/// Where the search stands when it tries completions: the step obstacles,
/// the memo and the road rule it shares with the beam.
pub(super) struct Completer<'s, 'r> {
    pub(super) obstacles: &'s [BoxSet],
    pub(super) memo: &'s mut ClearanceMemo,
    pub(super) road: &'s mut RoadCells<'r>,
    pub(super) body: AgentBody,
    pub(super) margin_m: f64,
    pub(super) horizon_steps: usize,
}

impl Completer<'_, '_> {
    /// The states after `from` (the ego at `step`, `clearance_m` kept so
    /// far) up to the horizon, driving straight on at `accel_mps2`, and the
    /// clearance kept over them all; `None` when they come within the
    /// margin of a box or leave the road.
    fn complete(
        &mut self,
        from: &KinematicState,
        step: usize,
        clearance_m: f64,
        accel_mps2: f64,
    ) -> Option<(Vec<KinematicState>, f64)> {
        let trig = from.heading_rad.sin_cos();
        let mut s = *from;
        let mut clearance_m = clearance_m;
        let mut states = Vec::with_capacity(self.horizon_steps - step);
        for k in step + 1..=self.horizon_steps {
            s = step_to_heading(&s, accel_mps2, from.heading_rad, trig, SIM_DT_S);
            if !self.road.allows(&s.position) {
                return None;
            }
            clearance_m =
                self.memo.clearance_below(self.obstacles, k, (&s, trig), self.body, clearance_m, self.margin_m);
            if clearance_m <= self.margin_m {
                return None;
            }
            states.push(s);
        }
        Some((states, clearance_m))
    }

    /// The first of the first [`COMPLETED_PER_BEAM`] candidates of `beams`'
    /// last beam (ending at `step`) whose completion by one of
    /// [`COMPLETIONS_MPS2`] keeps clear to the horizon, tried in that
    /// order: its whole trajectory from `start` and its clearance.
    pub(super) fn first_clear(
        &mut self,
        beams: &[Vec<Candidate>],
        start: &KinematicState,
        step: usize,
    ) -> Option<(Vec<AgentState>, f64)> {
        let beam = beams.last()?;
        for (at, c) in beam.iter().enumerate().take(COMPLETED_PER_BEAM) {
            for accel_mps2 in COMPLETIONS_MPS2 {
                if let Some((rest, clearance_m)) = self.complete(&c.last(start), step, c.clearance_m, accel_mps2) {
                    let mut trajectory = trajectory_to(beams, at, start);
                    trajectory.extend(rest.iter().map(KinematicState::to_agent_state));
                    return Some((trajectory, clearance_m));
                }
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use crate::eval::witness::test_support::{
        assert_touches_no_car, assert_turns_like_a_car, at, car, centre_on, search_among_cars, states_over,
        straight_road,
    };
    use crate::eval::witness::{FixedTraffic, ROAD_CELL_M, Witness, WitnessBudget, search_witness};
    use crate::geometry::Vector2;
    use crate::scenario::AgentState;

    #[test]
    fn braking_avoids_a_stopped_car_ahead() {
        // Ego at 10 m/s, a stopped car 20 m ahead: braking at 5 m/s² stops in 10 m.
        let horizon = 50;
        let states: Vec<Vec<Option<AgentState>>> =
            (0..=horizon).map(|_| vec![None, Some(at(20.0, 0.0, 0.0))]).collect();
        let traffic = FixedTraffic { states: &states, bodies: &[car(), car()], ego: 0, road: None };
        let w = search_witness(&at(0.0, 0.0, 10.0), car(), &traffic, horizon, WitnessBudget::default());
        let Witness::Found { trajectory, min_clearance_m, expansions } = w else { panic!("{w:?}") };
        assert_eq!(trajectory.len(), horizon + 1);
        assert!(min_clearance_m > 0.0);
        assert_touches_no_car(&trajectory, &states);
        // Found by braking straight on from the start, no search needed:
        // standing 9.5 m on (the model's semi-implicit steps), heading kept.
        assert_eq!(expansions, 0);
        let last = trajectory.last().unwrap();
        assert_eq!((last.speed_mps(), last.heading_rad, last.position.y), (0.0, 0.0, 0.0));
        assert!((last.position.x - 9.5).abs() < 1e-9, "{last:?}");
    }

    #[test]
    fn a_completion_run_into_later_is_not_taken() {
        // A car closes from 40 m behind at 20 m/s on an ego at 10 m/s:
        // braking or holding its speed straight on, the ego is hit within
        // 4 s. The search goes on and escapes it another way.
        let horizon = 50;
        let states = states_over(horizon, |t| vec![None, Some(at(-40.0 + 20.0 * t, 0.0, 20.0))]);
        let w = search_among_cars(search_witness, &at(0.0, 0.0, 10.0), &states, horizon);
        let Witness::Found { trajectory, expansions, .. } = w else { panic!("{w:?}") };
        assert!(expansions > 0);
        assert_touches_no_car(&trajectory, &states);
        assert_turns_like_a_car(&trajectory);
    }

    #[test]
    fn a_completion_that_leaves_the_road_is_not_taken() {
        // Alone on one lane, heading 0.3 rad towards its edge at 10 m/s:
        // straight on, braking (10 m) or not, the ego leaves the road, so
        // the witness must steer back.
        let road = straight_road(1);
        let states = vec![vec![None]; 31];
        let traffic = FixedTraffic { states: &states, bodies: &[car()], ego: 0, road: centre_on(&road) };
        let mut start = at(0.0, 0.0, 10.0);
        start.heading_rad = 0.3;
        start.velocity_mps = Vector2::new(0.3f64.cos(), 0.3f64.sin()) * 10.0;
        let w = search_witness(&start, car(), &traffic, 30, WitnessBudget::default());
        let Witness::Found { trajectory, expansions, .. } = w else { panic!("{w:?}") };
        assert!(expansions > 0);
        for s in &trajectory {
            let past_edge_m = road.signed_distance_to_road_edge(&s.position).unwrap();
            assert!(past_edge_m <= ROAD_CELL_M * std::f64::consts::FRAC_1_SQRT_2, "{s:?}: {past_edge_m} m off");
        }
        assert!(trajectory.iter().any(|s| s.heading_rad < 0.3), "never steered back");
    }
}
