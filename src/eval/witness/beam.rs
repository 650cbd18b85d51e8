//! Which of a period's candidates the beam keeps: the clearest so far,
//! ties to the most room ([`ROOM_CAP_M`]), with a few reserved in every
//! speed band ([`SPEED_BAND_MPS`]); and the floors ([`BeamFloor`],
//! [`BandFloors`]) that tell as soon as it is certain that a candidate
//! can no longer enter it.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::candidates::Candidate;
use crate::motion::KinematicState;
use crate::motion::tokens::{MAX_ACCEL_MPS2, SIM_DT_S, TOKEN_PERIOD_STEPS};

/// Width of the beam's speed bands, m/s: the most one period's acceleration
/// changes the speed (5 m/s² for 0.5 s), so a child lands in its parent's
/// band or a neighbour.
pub const SPEED_BAND_MPS: f64 = MAX_ACCEL_MPS2 * TOKEN_PERIOD_STEPS as f64 * SIM_DT_S;

/// The speed band of `speed_mps` (a NaN speed counts as band 0; speeds
/// beyond any car's share the last band).
pub(super) fn speed_band(speed_mps: f64) -> usize {
    ((speed_mps / SPEED_BAND_MPS) as usize).min(LAST_SPEED_BAND)
}

/// The last speed band (160 m/s and beyond).
const LAST_SPEED_BAND: usize = 63;

/// Cap of a candidate's room, m. The clearance so far is the beam's first
/// key, and it often ties: every child that has not come nearer anything
/// than its parent already had keeps the parent's value. Ranked by the
/// order tried, those would fill the beam with hard braking (the first
/// acceleration tried) and lose escapes from a CBV closing from behind
/// (on WOMD interactive, stage 2's planner escaped 17 of the 24 collisions
/// that a search so ranked called unwitnessed). Among equal clearances the beam
/// prefers the candidate with the most room now; beyond a few car lengths
/// more room says little, and the cap bounds the query.
pub const ROOM_CAP_M: f64 = 10.0;

/// The beam's order: larger clearance so far first, then more room (a
/// stable sort keeps the order tried among full ties).
pub(super) fn beam_order(a: &Candidate, b: &Candidate) -> std::cmp::Ordering {
    b.clearance_m.total_cmp(&a.clearance_m).then(b.room_m.total_cmp(&a.room_m))
}

/// The beam kept of a period's candidates `sorted` in [`beam_order`]: the
/// best `per_band` of every speed band and, of the rest, the best until
/// there are `width` in all; in [`beam_order`].
pub(super) fn select_beam(
    sorted: Vec<Candidate>,
    start: &KinematicState,
    width: usize,
    per_band: usize,
) -> Vec<Candidate> {
    let mut in_band = [0usize; LAST_SPEED_BAND + 1];
    let reserved: Vec<bool> = sorted
        .iter()
        .map(|c| {
            let band = &mut in_band[speed_band(c.last(start).speed_mps)];
            let reserved = *band < per_band;
            *band += usize::from(reserved);
            reserved
        })
        .collect();
    let mut fill = width.saturating_sub(reserved.iter().filter(|r| **r).count());
    sorted
        .into_iter()
        .zip(reserved)
        .filter(|&(_, reserved)| {
            reserved
                || (fill > 0 && {
                    fill -= 1;
                    true
                })
        })
        .map(|(c, _)| c)
        .collect()
}

/// A clearance ordered by `f64::total_cmp`, for the heap of [`BeamFloor`].
#[derive(Debug, Clone, Copy, PartialEq)]
struct Clearance(f64);

impl Eq for Clearance {}

impl PartialOrd for Clearance {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Clearance {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// Most clearances a [`BeamFloor`] makes room for before it is filled.
const PREALLOCATED_FLOOR: usize = 4096;

/// The clearances of the best `width` candidates of a period kept so far.
/// The beam keeps the largest clearances (ties to more room), so once
/// `width` are kept a later candidate whose clearance falls below the
/// smallest of them cannot enter it: the search drops it at once. One that
/// ties with it may still win on room, and is kept to the period's end.
pub(super) struct BeamFloor {
    width: usize,
    kept: BinaryHeap<Reverse<Clearance>>,
}

impl BeamFloor {
    pub(super) fn new(width: usize) -> Self {
        // The heap grows to `width + 1`; storage for a usual beam up front,
        // not for an enormous one asked for (`--witness-widest`).
        Self { width, kept: BinaryHeap::with_capacity(width.min(PREALLOCATED_FLOOR).saturating_add(1)) }
    }

    /// The clearance a later candidate must beat, once the beam is full.
    pub(super) fn get(&self) -> Option<f64> {
        (self.width > 0 && self.kept.len() == self.width).then(|| self.kept.peek().map_or(f64::INFINITY, |c| c.0.0))
    }

    pub(super) fn keep(&mut self, clearance_m: f64) {
        self.kept.push(Reverse(Clearance(clearance_m)));
        if self.kept.len() > self.width {
            self.kept.pop();
        }
    }
}

/// The clearances of the best candidates of a period kept so far in each
/// speed band (see [`BeamFloor`]): the band's floor is the clearance a
/// later candidate must beat to be among its band's reserved best.
pub(super) struct BandFloors {
    per_band: usize,
    floors: Vec<BeamFloor>,
}

impl BandFloors {
    pub(super) fn new(per_band: usize) -> Self {
        Self { per_band, floors: Vec::new() }
    }

    /// The clearance a later candidate in `band` must beat to be among its
    /// band's reserved best, once that is certain (no band reserves
    /// anything: nothing gets in that way).
    pub(super) fn get(&self, band: usize) -> Option<f64> {
        if self.per_band == 0 { Some(f64::INFINITY) } else { self.floors.get(band).and_then(BeamFloor::get) }
    }

    pub(super) fn keep(&mut self, band: usize, clearance_m: f64) {
        if self.per_band == 0 {
            return;
        }
        if self.floors.len() <= band {
            let per_band = self.per_band;
            self.floors.resize_with(band + 1, || BeamFloor::new(per_band));
        }
        self.floors[band].keep(clearance_m);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::witness::beam_search::beam_search;
    use crate::eval::witness::test_support::{
        assert_touches_no_car, assert_turns_like_a_car, at, car, oncoming_car, search_among_cars, states_over,
    };
    use crate::eval::witness::{FixedTraffic, Witness, WitnessBudget, search_witness};

    #[test]
    fn the_beam_keeps_the_best_of_every_speed_band_then_the_best_overall() {
        let start = KinematicState::from_agent_state(&at(0.0, 0.0, 0.0));
        // Sorted best first: four at 1 m/s (band 0), then one each at 3
        // and 8 m/s (bands 1 and 3).
        let sorted: Vec<Candidate> = [(9.0, 1.0), (8.0, 1.0), (7.0, 1.0), (6.0, 1.0), (5.0, 3.0), (4.0, 8.0)]
            .map(|(clearance_m, speed_mps)| {
                let s = KinematicState { speed_mps, ..start };
                Candidate { parent: 0, segment: [s; TOKEN_PERIOD_STEPS], len: 1, clearance_m, room_m: 0.0 }
            })
            .to_vec();
        let clearances = |beam: Vec<Candidate>| beam.iter().map(|c| c.clearance_m).collect::<Vec<_>>();
        assert_eq!(clearances(select_beam(sorted.clone(), &start, 3, 0)), [9.0, 8.0, 7.0]);
        assert_eq!(clearances(select_beam(sorted.clone(), &start, 3, 1)), [9.0, 5.0, 4.0]);
        assert_eq!(clearances(select_beam(sorted.clone(), &start, 4, 1)), [9.0, 8.0, 5.0, 4.0]);
        // The reserve may outgrow the width.
        assert_eq!(clearances(select_beam(sorted.clone(), &start, 1, 2)), [9.0, 8.0, 5.0, 4.0]);
        assert_eq!(clearances(select_beam(sorted, &start, 10, 1)), [9.0, 8.0, 7.0, 6.0, 5.0, 4.0]);
    }

    #[test]
    fn a_car_head_on_is_escaped_by_swerving_at_speed_not_by_braking() {
        // Ego at 4 m/s: stopping takes 0.8 s and the car still arrives, so
        // only a swerve escapes. Braking keeps the most clearance for the
        // first seconds, and a beam ranked by clearance alone keeps only
        // braking candidates (and, turning no tighter than a car, finds
        // nothing even widened); its speed bands keep swerves at speed.
        let horizon = 60;
        let states = oncoming_car(horizon);
        let bodies = [car(), car()];
        let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0, road: None };
        let greedy = WitnessBudget { per_speed_band: 0, ..WitnessBudget::default() };
        assert!(!search_witness(&at(0.0, 0.0, 4.0), car(), &traffic, horizon, greedy).is_found());
        let w = beam_search(&at(0.0, 0.0, 4.0), car(), &traffic, horizon, WitnessBudget::default());
        let Witness::Found { trajectory, .. } = w else { panic!("{w:?}") };
        assert_touches_no_car(&trajectory, &states);
        assert_turns_like_a_car(&trajectory);
        assert!(trajectory.iter().map(|s| s.position.y.abs()).fold(0.0, f64::max) > 2.0);
    }

    #[test]
    fn an_escape_from_a_cbv_closing_from_behind_is_found_though_clearances_tie() {
        // Ego at 10 m/s with a car 1 m to its left at its speed (the
        // clearance every candidate keeps while it holds its lane), another
        // ahead on the right, and a CBV 30 m behind closing at 8 m/s. Ranked
        // by clearance alone, the ties would go to the order tried: the beam
        // would fill with hard braking and the search find no escape.
        let horizon = 60;
        let states = states_over(horizon, |t| {
            vec![
                None,
                Some(at(10.0 * t, 3.0, 10.0)),
                Some(at(-30.0 + 18.0 * t, 0.0, 18.0)),
                Some(at(8.0 + 10.0 * t, -4.0, 10.0)),
            ]
        });
        // The narrow beam alone, without the widening.
        let w = search_among_cars(beam_search, &at(0.0, 0.0, 10.0), &states, horizon);
        let Witness::Found { trajectory, min_clearance_m, .. } = w else { panic!("{w:?}") };
        assert!(min_clearance_m > WitnessBudget::default().margin_m);
        assert_touches_no_car(&trajectory, &states);
    }
}
