//! The feasibility witness: proof that a generated collision was avoidable.
//! Given the other agents' trajectories fixed (as the variant produced
//! them), search for an ego trajectory within the ego's dynamic limits —
//! the token grid's acceleration and yaw-rate ranges, speed ≥ 0, through the
//! kinematic model — that touches no other agent over the horizon. The
//! search is a beam search over one (acceleration, yaw rate) choice per
//! token period, keeping the candidates with the largest clearance so far
//! (among equal ones, those with the most room at the period's end), a few
//! of them in every speed band however they rank overall; it returns the
//! first collision-free trajectory it completes, or says that none was
//! found within its budget (which is not a proof of infeasibility). When
//! the beam finds nothing, the search runs again with a wider one, and
//! then with a wider one still.
//!
//! Before each period the first few candidates of the beam are tried on
//! to the horizon straight on, braking to a standstill or holding their
//! speed (see `completion::COMPLETIONS_MPS2`): once the
//! ego is past the conflict one of them is usually clear, and the witness
//! is then that candidate's
//! trajectory so far and its completion. Each completion is checked as
//! every beam step is (clearance above the margin, on the road), so it can
//! only find witnesses the beam might have missed, never accept a touch.
//!
//! The ego keeps to the road as the CBV is held to it: its centre stays on
//! the road inside the mapped area (see [`RoadCells`]; an ego that starts
//! off it is not held to it). Without that, the escape with the most
//! clearance is often to leave the road, through whatever is beside it.
//!
//! The ego turns no tighter than a car can: its yaw rate is bounded by its
//! speed over [`MIN_TURN_RADIUS_M`] at every step (the token grid's model
//! alone would let a standing car turn in place), and children of one
//! candidate that drive the very same states (a standing car's yaw rates
//! all collapse to one) are tried once.
//!
//! The search skips only work that cannot change its answer: a candidate
//! that can no longer enter the beam is dropped as soon as that is certain
//! (it still counts as an expansion), boxes the ego cannot reach in time
//! are left out of each step's obstacles, and clearance queries repeated
//! for the same pose at the same step are answered from memory. Each beam
//! search's result is bit for bit that of the plain one.
//!
//! The search lives in one file per concept: the [`WitnessBudget`] and
//! its widening ladder (`budget`), the choices tried per period and the
//! turning limit (`actions`), the [`FixedTraffic`] to avoid (`traffic`),
//! the road the ego keeps to ([`RoadCells`], `road_cells`), the beam's
//! entries (`candidates`) and how the beam keeps them (`beam`), the
//! memos (`memo`), the completions straight on to the horizon
//! (`completion`), and one beam search (`beam_search`); this file holds
//! the entry points, [`search_witness`] and [`search_rollout_witness`].

mod actions;
mod beam;
mod beam_search;
mod budget;
mod candidates;
mod completion;
mod memo;
mod road_cells;
#[cfg(test)]
mod test_support;
mod traffic;

pub use crate::motion::kinematics::MIN_TURN_RADIUS_M;
pub use beam::{ROOM_CAP_M, SPEED_BAND_MPS};
pub use beam_search::Witness;
pub use budget::{DEFAULT_WIDEST, FIRST_WIDENING, MOST_WIDEST, WitnessBudget};
pub use road_cells::{ROAD_CELL_M, RoadCells, RoadKeeping, RoadRule};
pub use traffic::FixedTraffic;

use crate::scenario::{AgentBody, AgentState, Scenario};
use crate::sim::Rollout;
use beam_search::beam_search_on;

/// The witness of a rollout's ego, as `safer evaluate` and a failing
/// variant's artefacts search it: from the ego's first state in `rollout`,
/// against every other agent as they drove in it, over its whole length,
/// keeping to `scenario`'s road by `keeping`, within `budget`. None
/// within budget (no expansion) when the ego has no first state.
pub fn search_rollout_witness(
    scenario: &Scenario,
    rollout: &Rollout,
    keeping: RoadKeeping,
    budget: WitnessBudget,
) -> Witness {
    let ego = rollout.ego.0;
    let Some(start) = rollout.states.first().and_then(|row| row.get(ego).copied().flatten()) else {
        return Witness::NoneWithinBudget { expansions: 0 };
    };
    let traffic = FixedTraffic {
        states: &rollout.states,
        bodies: &rollout.bodies,
        ego,
        road: Some(RoadRule { map: &scenario.map, keeping }),
    };
    let body = scenario.track(rollout.ego).body();
    search_witness(&start, body, &traffic, rollout.states.len().saturating_sub(1), budget)
}

/// Searches an ego trajectory from `start` over `horizon_steps` simulator
/// steps that avoids every agent of `traffic`: a beam search, widened by
/// each of `budget.widenings` in turn while it finds nothing (the
/// expansions reported are those of every search run).
pub fn search_witness(
    start: &AgentState,
    body: AgentBody,
    traffic: &FixedTraffic<'_>,
    horizon_steps: usize,
    budget: WitnessBudget,
) -> Witness {
    let mut road = RoadCells::new(traffic.road, body, &start.position);
    let mut result = beam_search_on(start, body, traffic, &mut road, horizon_steps, budget);
    for widening in budget.widenings {
        let Witness::NoneWithinBudget { expansions: so_far } = result else { return result };
        if widening <= 1 || so_far == 0 {
            // Nothing to widen, or touching at the start.
            continue;
        }
        let wide_budget = WitnessBudget {
            beam_width: budget.beam_width.saturating_mul(widening),
            max_expansions: budget.max_expansions.saturating_mul(widening),
            per_speed_band: budget.per_speed_band.saturating_mul(widening),
            ..budget
        };
        result = beam_search_on(start, body, traffic, &mut road, horizon_steps, wide_budget);
        let (Witness::Found { expansions, .. } | Witness::NoneWithinBudget { expansions }) = &mut result;
        *expansions += so_far;
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::witness::beam_search::beam_search;
    use crate::eval::witness::test_support::{at, car, random_traffic, search_among_cars, states_over};

    #[test]
    fn the_search_widens_its_beam_only_while_it_finds_nothing() {
        // Narrow, then ×4, then ×16 (a rung of 1 between them is skipped):
        // each runs only when the one before found nothing (touching at the
        // start is not widened), the expansions of every search run add up,
        // and each widening rescues some search.
        let narrow = WitnessBudget {
            beam_width: 1,
            max_expansions: 2_000,
            margin_m: 0.05,
            widenings: [1, 1, 1],
            per_speed_band: 0,
        };
        let ladder = WitnessBudget { widenings: [4, 1, 16], ..narrow };
        let times = |k: usize| WitnessBudget { beam_width: k, max_expansions: 2_000 * k, ..narrow };
        let mut rescued_by = [0usize; 3];
        for seed in 0..48u64 {
            let (states, bodies) = random_traffic(26, 30, seed);
            let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0, road: None };
            let start = at(0.0, 0.0, [0.0, 4.0, 9.0][seed as usize % 3]);
            let got = search_witness(&start, car(), &traffic, 30, ladder);
            let mut spent = 0;
            let mut expected = None;
            for (rung, k) in [1, 4, 16].into_iter().enumerate() {
                let w = beam_search(&start, car(), &traffic, 30, times(k));
                spent += w.expansions();
                if w.is_found() || w.expansions() == 0 || k == 16 {
                    rescued_by[rung] += usize::from(w.is_found());
                    expected = Some((w.is_found(), spent));
                    break;
                }
            }
            assert_eq!(Some((got.is_found(), got.expansions())), expected, "seed {seed}");
            // Found by the narrow search: its very witness.
            let first = beam_search(&start, car(), &traffic, 30, narrow);
            if first.is_found() {
                assert_eq!(got, first, "seed {seed}");
            }
        }
        assert!(rescued_by[1] > 0 && rescued_by[2] > 0, "a widening never rescued a search: {rescued_by:?}");
    }

    #[test]
    fn a_start_already_touching_has_no_witness() {
        let states = vec![vec![None, Some(at(1.0, 0.0, 0.0))]; 11];
        let traffic = FixedTraffic { states: &states, bodies: &[car(), car()], ego: 0, road: None };
        assert_eq!(
            search_witness(&at(0.0, 0.0, 5.0), car(), &traffic, 10, WitnessBudget::default()),
            Witness::NoneWithinBudget { expansions: 0 }
        );
    }

    #[test]
    fn an_unavoidable_hit_from_behind_has_no_witness() {
        // Ego stopped between a wall of cars left, right and ahead; a car from
        // behind at 20 m/s arrives within 0.5 s: no action gets away in time.
        let horizon = 20;
        let states = states_over(horizon, |t| {
            vec![
                None,
                Some(at(-10.0 + 20.0 * t, 0.0, 20.0)),
                Some(at(5.0, 0.0, 0.0)),
                Some(at(0.0, 2.3, 0.0)),
                Some(at(0.0, -2.3, 0.0)),
            ]
        });
        let w = search_among_cars(search_witness, &at(0.0, 0.0, 0.0), &states, horizon);
        assert!(!w.is_found(), "{w:?}");
    }
}
