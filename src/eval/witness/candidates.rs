//! The beam's entries ([`Candidate`]): one token period of states linked
//! to the entry it grew from, the check that drops a child driving the
//! very states of a sibling, and the walk back along the links to a whole
//! trajectory.

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use super::memo::PoseHasher;
use crate::motion::KinematicState;
use crate::motion::tokens::TOKEN_PERIOD_STEPS;
use crate::scenario::AgentState;

/// One beam entry: the states of its last token period, linked to the
/// entry of the period before it it grew from (so expanding a candidate
/// copies five states, not its whole history). The beam ranks entries by
/// their clearance so far and, among equally clear ones, by their room at
/// the period's end.
#[derive(Debug, Clone, Copy)]
pub(super) struct Candidate {
    /// Index of the parent in the previous period's beam (unused in period 0).
    pub(super) parent: usize,
    /// The states of this period, `segment[..len]`.
    pub(super) segment: [KinematicState; TOKEN_PERIOD_STEPS],
    pub(super) len: usize,
    pub(super) clearance_m: f64,
    /// Clearance at the period's last state, capped at [`ROOM_CAP_M`](super::ROOM_CAP_M).
    pub(super) room_m: f64,
}

impl Candidate {
    pub(super) fn last(&self, start: &KinematicState) -> KinematicState {
        if self.len == 0 { *start } else { self.segment[self.len - 1] }
    }

    /// Whether `self` and `other` drive the very same states this period.
    pub(super) fn drives_as(&self, other: &Candidate) -> bool {
        self.len == other.len && self.segment[..self.len] == other.segment[..other.len]
    }

    /// A hash of this period's states, for [`Candidate::drives_as`].
    fn segment_hash(&self) -> u64 {
        use std::hash::Hasher;
        let mut h = PoseHasher::default();
        for s in &self.segment[..self.len] {
            for word in [s.position.x, s.position.y, s.heading_rad, s.speed_mps] {
                h.write_u64(word.to_bits());
            }
        }
        h.finish()
    }
}

/// The children of one candidate kept so far, by [`Candidate::segment_hash`]
/// (index into the period's list): a child that drives as an earlier one
/// has the same clearance, room and future, and is not kept twice.
pub(super) type Siblings = HashMap<u64, usize, BuildHasherDefault<PoseHasher>>;

/// Whether `child` drives as a sibling kept before it in `next` (and if
/// not, notes it as kept; `child` is then pushed at `next.len()`).
pub(super) fn repeats_a_sibling(siblings: &mut Siblings, next: &[Candidate], child: &Candidate) -> bool {
    match siblings.entry(child.segment_hash()) {
        std::collections::hash_map::Entry::Occupied(e) => {
            // Equal hashes of different states (never seen) keep both.
            next[*e.get()].drives_as(child)
        }
        std::collections::hash_map::Entry::Vacant(e) => {
            e.insert(next.len());
            false
        }
    }
}

/// The trajectory from `start` of candidate `at` of the last of `beams`,
/// walking its links back.
pub(super) fn trajectory_to(beams: &[Vec<Candidate>], at: usize, start: &KinematicState) -> Vec<AgentState> {
    let mut segments = Vec::with_capacity(beams.len());
    let mut at = at;
    for beam in beams.iter().rev() {
        let c = &beam[at];
        segments.push(&c.segment[..c.len]);
        at = c.parent;
    }
    let mut trajectory = vec![start.to_agent_state()];
    trajectory.extend(segments.iter().rev().flat_map(|seg| seg.iter().map(KinematicState::to_agent_state)));
    trajectory
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::witness::actions::{ACCELS_MPS2, YAW_RATES_RADPS};
    use crate::eval::witness::test_support::{
        assert_touches_none_of, assert_turns_like_a_car, at, car, random_traffic,
    };
    use crate::eval::witness::{FixedTraffic, Witness, WitnessBudget, search_witness};
    use crate::motion::kinematics::stepped_speed_mps;
    use crate::motion::kinematics::turn_bounded_yaw_rate;
    use crate::motion::tokens::SIM_DT_S;
    use crate::motion::{Action, kinematic_step};

    #[test]
    fn witnesses_turn_no_tighter_than_a_car_and_a_standing_car_tries_its_choices_once() {
        let mut found = 0;
        for seed in 0..12u64 {
            let (states, bodies) = random_traffic(18, 30, seed);
            let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0, road: None };
            let start = at(0.0, 0.0, [0.0, 1.0, 4.0, 9.0][seed as usize % 4]);
            if let Witness::Found { trajectory, .. } =
                search_witness(&start, car(), &traffic, 30, WitnessBudget::default())
            {
                assert_turns_like_a_car(&trajectory);
                assert_touches_none_of(&trajectory, &states, &bodies);
                found += 1;
            }
        }
        assert!(found > 6, "{found} of 12 found");
        // Alone and standing: braking and holding still are one choice
        // whatever the yaw rate (5 accelerations x 9 rates), and pulling
        // away slowly turns the same at the sharper rates.
        let states = vec![vec![None]; 6];
        let traffic = FixedTraffic { states: &states, bodies: &[car()], ego: 0, road: None };
        let mut next = Vec::new();
        let start = KinematicState::from_agent_state(&at(0.0, 0.0, 0.0));
        let mut siblings = Siblings::default();
        for &a in &ACCELS_MPS2 {
            for &w in &YAW_RATES_RADPS {
                let mut child = Candidate {
                    parent: 0,
                    segment: [start; TOKEN_PERIOD_STEPS],
                    len: 0,
                    clearance_m: 1.0,
                    room_m: 0.0,
                };
                let mut s = start;
                for k in 0..TOKEN_PERIOD_STEPS {
                    let v = stepped_speed_mps(s.speed_mps, a, SIM_DT_S);
                    s = kinematic_step(
                        &s,
                        Action { accel_mps2: a, yaw_rate_radps: turn_bounded_yaw_rate(w, v) },
                        SIM_DT_S,
                    );
                    child.segment[k] = s;
                }
                child.len = TOKEN_PERIOD_STEPS;
                if !repeats_a_sibling(&mut siblings, &next, &child) {
                    next.push(child);
                }
            }
        }
        assert_eq!(next.iter().filter(|c| c.segment[4].speed_mps == 0.0).count(), 1);
        for (i, c) in next.iter().enumerate() {
            assert!(next[..i].iter().all(|d| !d.drives_as(c)), "child {i} repeats one");
        }
        // At 1 m/s² the speed stays below 0.5 m/s: at most 0.1 rad/s, so the
        // rates beyond it one way or the other collapse (3 of 9 stay).
        let moving = next.len() - 1;
        assert!(moving < 3 * YAW_RATES_RADPS.len(), "{moving}");
        assert_eq!(next.iter().filter(|c| c.segment[4].speed_mps == 0.5).count(), 3);
        // Alone, standing on is clear from the start: no expansion at all.
        let w = search_witness(&at(0.0, 0.0, 0.0), car(), &traffic, 5, WitnessBudget::default());
        assert!(w.is_found() && w.expansions() == 0, "{w:?}");
    }
}
