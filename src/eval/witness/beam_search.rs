//! One beam search: token period by token period, every candidate of the
//! beam expanded by every choice, a child dropped as soon as it touches,
//! leaves the road or can no longer enter the beam, and the beam's first
//! few tried to the horizon straight on before each period. Its answer
//! ([`Witness`]) is bit for bit that of the plain search without the
//! pruning and the memos.

use super::actions::{ACCELS_MPS2, ACTIONS, YAW_RATES_RADPS, period_speeds};
use super::beam::{BandFloors, BeamFloor, ROOM_CAP_M, beam_order, select_beam, speed_band};
use super::budget::WitnessBudget;
use super::candidates::{Candidate, Siblings, repeats_a_sibling, trajectory_to};
use super::completion::Completer;
use super::memo::{ClearanceMemo, TurnsMemo};
use super::road_cells::RoadCells;
use super::traffic::FixedTraffic;
use crate::geometry::{OrientedBox, Pose2};
use crate::motion::KinematicState;
use crate::motion::kinematics::{max_travel_m, step_to_heading, turn_bounded_yaw_rate, turned_heading_rad};
use crate::motion::tokens::{MAX_YAW_RATE_RADPS, SIM_DT_S, TOKEN_PERIOD_STEPS};
use crate::scenario::{AgentBody, AgentState};

/// What the search found.
#[derive(Debug, Clone, PartialEq)]
pub enum Witness {
    /// A collision-free ego trajectory, one state per simulator step from the start.
    Found {
        /// The ego's states, `trajectory[0]` = the start state.
        trajectory: Vec<AgentState>,
        /// Smallest clearance to any agent along it, m.
        min_clearance_m: f64,
        /// Expansions used.
        expansions: usize,
    },
    /// No collision-free trajectory within the budget.
    NoneWithinBudget {
        /// Expansions used.
        expansions: usize,
    },
}

impl Witness {
    /// Whether a witness was found.
    pub fn is_found(&self) -> bool {
        matches!(self, Witness::Found { .. })
    }

    /// Candidates expanded by the search, whatever it found.
    pub fn expansions(&self) -> usize {
        let (Witness::Found { expansions, .. } | Witness::NoneWithinBudget { expansions }) = self;
        *expansions
    }
}

/// Slack of the reach filter of the obstacles, m: far above the rounding of
/// the positions it bounds, small beside the distances it prunes.
const REACH_SLACK_M: f64 = 0.1;

/// One beam search of [`search_witness`](super::search_witness) with `budget`'s beam and
/// expansions (its `widenings` unused).
#[cfg(test)]
pub(super) fn beam_search(
    start: &AgentState,
    body: AgentBody,
    traffic: &FixedTraffic<'_>,
    horizon_steps: usize,
    budget: WitnessBudget,
) -> Witness {
    let mut road = RoadCells::new(traffic.road, body, &start.position);
    beam_search_on(start, body, traffic, &mut road, horizon_steps, budget)
}

/// One beam search of [`search_witness`](super::search_witness) with `budget`'s beam and
/// expansions (its `widenings` unused), keeping to `road`.
pub(super) fn beam_search_on(
    start: &AgentState,
    body: AgentBody,
    traffic: &FixedTraffic<'_>,
    road: &mut RoadCells<'_>,
    horizon_steps: usize,
    budget: WitnessBudget,
) -> Witness {
    let start = KinematicState::from_agent_state(start);
    let mut obstacles = vec![traffic.obstacles_at(0, &start.position, f64::INFINITY)];
    let pose = Pose2 { position: start.position, heading_rad: start.heading_rad };
    let first_clearance =
        obstacles[0].clearance_below(&OrientedBox::new(pose, body.length_m, body.width_m), f64::INFINITY);
    if first_clearance <= budget.margin_m {
        // Already touching at the start: nothing the ego does can undo it.
        return Witness::NoneWithinBudget { expansions: 0 };
    }
    // Clearances only fall from the first one, rooms are capped, and by
    // step k the ego is at most `max_travel_m` from its start: a box
    // farther than that plus the larger of the first clearance and the
    // room's cap, and both bounding radii, never decides either.
    let max_accel_mps2 = ACCELS_MPS2.iter().copied().fold(0.0, f64::max);
    let ego_radius_m = 0.5 * body.length_m.hypot(body.width_m);
    obstacles.extend((1..traffic.states.len()).map(|k| {
        let travel_m = max_travel_m(start.speed_mps, max_accel_mps2, SIM_DT_S, k);
        let keep_within_m = travel_m + first_clearance.max(ROOM_CAP_M) + ego_radius_m + REACH_SLACK_M;
        traffic.obstacles_at(k, &start.position, if keep_within_m.is_nan() { f64::INFINITY } else { keep_within_m })
    }));
    let root = Candidate {
        parent: 0,
        segment: [start; TOKEN_PERIOD_STEPS],
        len: 0,
        clearance_m: first_clearance,
        room_m: first_clearance.min(ROOM_CAP_M),
    };
    // `beams[p]`: the beam after period p (`beams[0]`: the start alone).
    let mut beams: Vec<Vec<Candidate>> = vec![vec![root]];
    let mut memo = ClearanceMemo::default();
    let mut turns_memo = TurnsMemo::default();
    let mut expansions = 0;
    let periods = horizon_steps.div_ceil(TOKEN_PERIOD_STEPS);
    for period in 0..periods {
        // Before expanding: can one of the best so far finish straight on?
        let step = period * TOKEN_PERIOD_STEPS;
        let mut completer =
            Completer { obstacles: &obstacles, memo: &mut memo, road, body, margin_m: budget.margin_m, horizon_steps };
        if let Some((trajectory, min_clearance_m)) = completer.first_clear(&beams, &start, step) {
            return Witness::Found { trajectory, min_clearance_m, expansions };
        }
        let beam = beams.last().expect("the start's beam");
        let steps = TOKEN_PERIOD_STEPS.min(horizon_steps - period * TOKEN_PERIOD_STEPS);
        let mut next: Vec<Candidate> = Vec::with_capacity(2 * budget.beam_width.min(beam.len() * ACTIONS));
        let mut floor = BeamFloor::new(budget.beam_width);
        let mut band_floors = BandFloors::new(budget.per_speed_band);
        let mut siblings = Siblings::default();
        for (parent, c) in beam.iter().enumerate() {
            let from = c.last(&start);
            let speeds = ACCELS_MPS2.map(|a| period_speeds(from.speed_mps, a, steps));
            // A child never has more clearance than its parent: once the
            // parent is below the floor of the beam and of every band its
            // children can land in, none of them can enter. They still
            // count as tried, as when they were run.
            let below = |f: Option<f64>| f.is_some_and(|f| c.clearance_m < f);
            if below(floor.get()) && speeds.iter().all(|v| below(band_floors.get(speed_band(v[steps - 1])))) {
                if expansions + ACTIONS > budget.max_expansions {
                    return Witness::NoneWithinBudget { expansions: budget.max_expansions.max(expansions) };
                }
                expansions += ACTIONS;
                continue;
            }
            siblings.clear();
            let turns = turns_memo.from(from.heading_rad);
            for (&a, speeds) in ACCELS_MPS2.iter().zip(&speeds) {
                let band = speed_band(speeds[steps - 1]);
                for (&yaw_rate_radps, turn) in YAW_RATES_RADPS.iter().zip(turns) {
                    if expansions >= budget.max_expansions {
                        return Witness::NoneWithinBudget { expansions };
                    }
                    expansions += 1;
                    // Dropped at or below the margin, or below both the
                    // beam's floor and its band's.
                    let enter_at = floor.get().zip(band_floors.get(band)).map(|(f, b)| f.min(b));
                    let drop_at_m = enter_at.map_or(budget.margin_m, |f| f.next_down().max(budget.margin_m));
                    let yaw_rate_radps = yaw_rate_radps.clamp(-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS);
                    let mut s = from;
                    // Whether every step so far turned at the full rate, so
                    // that the remembered headings apply.
                    let mut as_remembered = true;
                    // The heading's `sin_cos()` of the last state stepped to.
                    let mut sin_cos = (0.0, 0.0);
                    let mut child = Candidate {
                        parent,
                        segment: [s; TOKEN_PERIOD_STEPS],
                        len: 0,
                        clearance_m: c.clearance_m,
                        room_m: 0.0,
                    };
                    for (k, &remembered) in turn.iter().enumerate().take(steps) {
                        let step = period * TOKEN_PERIOD_STEPS + k + 1;
                        let bounded = turn_bounded_yaw_rate(yaw_rate_radps, speeds[k]);
                        as_remembered &= bounded == yaw_rate_radps;
                        let (heading_rad, trig) = if as_remembered {
                            remembered
                        } else {
                            let heading_rad = turned_heading_rad(s.heading_rad, bounded, SIM_DT_S);
                            (heading_rad, heading_rad.sin_cos())
                        };
                        (s, sin_cos) = (step_to_heading(&s, a, heading_rad, trig, SIM_DT_S), trig);
                        if !road.allows(&s.position) {
                            // Off the road: dropped as if it touched something.
                            child.clearance_m = f64::NEG_INFINITY;
                            break;
                        }
                        child.clearance_m =
                            memo.clearance_below(&obstacles, step, (&s, trig), body, child.clearance_m, drop_at_m);
                        if child.clearance_m <= drop_at_m {
                            break;
                        }
                        child.segment[child.len] = s;
                        child.len += 1;
                    }
                    if child.clearance_m > drop_at_m && !repeats_a_sibling(&mut siblings, &next, &child) {
                        let step = period * TOKEN_PERIOD_STEPS + child.len;
                        child.room_m =
                            memo.clearance_below(&obstacles, step, (&s, sin_cos), body, ROOM_CAP_M, f64::NEG_INFINITY);
                        floor.keep(child.clearance_m);
                        band_floors.keep(band, child.clearance_m);
                        next.push(child);
                    }
                }
            }
        }
        if next.is_empty() {
            return Witness::NoneWithinBudget { expansions };
        }
        // Keep the widest margins, then the most room, and a few of every
        // speed band; full ties by the order tried (deterministic).
        next.sort_by(beam_order);
        beams.push(select_beam(next, &start, budget.beam_width, budget.per_speed_band));
    }
    let best = &beams.last().expect("the start's beam")[0];
    Witness::Found { trajectory: trajectory_to(&beams, 0, &start), min_clearance_m: best.clearance_m, expansions }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::witness::completion::{COMPLETED_PER_BEAM, COMPLETIONS_MPS2};
    use crate::eval::witness::test_support::{at, car, random_traffic, straight_road};
    use crate::eval::witness::{MIN_TURN_RADIUS_M, ROAD_CELL_M, RoadKeeping, RoadRule};
    use crate::geometry::Point2;
    use crate::motion::kinematics::stepped_speed_mps;
    use crate::motion::{Action, kinematic_step};

    /// The search without its pruning and memos: every child of
    /// every candidate run to the end of its period, every clearance a full
    /// query over all boxes.
    fn plain_search(
        start: &AgentState,
        body: AgentBody,
        traffic: &FixedTraffic<'_>,
        horizon_steps: usize,
        budget: WitnessBudget,
    ) -> Witness {
        let clearance = |step: usize, s: &KinematicState, bound: f64| {
            let Some(row) = traffic.states.get(step) else { return bound };
            let ego_box = OrientedBox::new(s.to_agent_state().pose(), body.length_m, body.width_m);
            row.iter()
                .enumerate()
                .filter(|(i, _)| *i != traffic.ego)
                .filter_map(|(i, o)| o.map(|o| (traffic.bodies[i], o)))
                .map(|(b, o)| OrientedBox::new(o.pose(), b.length_m, b.width_m))
                .map(|b| if ego_box.intersects(&b) { 0.0 } else { ego_box.distance(&b) })
                .fold(bound, f64::min)
        };
        // The road rule queried afresh at every step, at the cell's centre.
        let cell_off_road = |p: &Point2| {
            let cell = |x: f64| ((x / ROAD_CELL_M).floor() + 0.5) * ROAD_CELL_M;
            traffic.road.is_some_and(|r| r.map.is_off_road_within_map(&Point2::new(cell(p.x), cell(p.y))))
        };
        let starts_off_road = cell_off_road(&start.position);
        let off_road = |p: &Point2| !starts_off_road && cell_off_road(p);
        let start = KinematicState::from_agent_state(start);
        let first_clearance = clearance(0, &start, f64::INFINITY);
        if first_clearance <= budget.margin_m {
            return Witness::NoneWithinBudget { expansions: 0 };
        }
        let root = Candidate {
            parent: 0,
            segment: [start; TOKEN_PERIOD_STEPS],
            len: 0,
            clearance_m: first_clearance,
            room_m: first_clearance.min(ROOM_CAP_M),
        };
        let mut beams: Vec<Vec<Candidate>> = vec![vec![root]];
        let mut expansions = 0;
        for period in 0..horizon_steps.div_ceil(TOKEN_PERIOD_STEPS) {
            let beam = beams.last().unwrap();
            // The completions of the first few, straight on to the horizon.
            for (at, c) in beam.iter().enumerate().take(COMPLETED_PER_BEAM) {
                for a in COMPLETIONS_MPS2 {
                    let mut s = c.last(&start);
                    let mut clearance_m = c.clearance_m;
                    let mut rest = Vec::new();
                    for step in period * TOKEN_PERIOD_STEPS + 1..=horizon_steps {
                        s = kinematic_step(&s, Action { accel_mps2: a, yaw_rate_radps: 0.0 }, SIM_DT_S);
                        clearance_m =
                            if off_road(&s.position) { f64::NEG_INFINITY } else { clearance(step, &s, clearance_m) };
                        if clearance_m <= budget.margin_m {
                            break;
                        }
                        rest.push(s.to_agent_state());
                    }
                    if clearance_m > budget.margin_m {
                        let mut trajectory = trajectory_to(&beams, at, &start);
                        trajectory.extend(rest);
                        return Witness::Found { trajectory, min_clearance_m: clearance_m, expansions };
                    }
                }
            }
            let mut next = Vec::new();
            for (parent, c) in beam.iter().enumerate() {
                let mut siblings = Siblings::default();
                for &a in &ACCELS_MPS2 {
                    for &w in &YAW_RATES_RADPS {
                        if expansions >= budget.max_expansions {
                            return Witness::NoneWithinBudget { expansions };
                        }
                        expansions += 1;
                        let w = w.clamp(-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS);
                        let mut s = c.last(&start);
                        let mut child = Candidate {
                            parent,
                            segment: [s; TOKEN_PERIOD_STEPS],
                            len: 0,
                            clearance_m: c.clearance_m,
                            room_m: 0.0,
                        };
                        for k in 0..TOKEN_PERIOD_STEPS {
                            let step = period * TOKEN_PERIOD_STEPS + k + 1;
                            if step > horizon_steps {
                                break;
                            }
                            // The car's turning radius bounds the rate at the step's new speed.
                            let speed_mps = stepped_speed_mps(s.speed_mps, a, SIM_DT_S);
                            let yaw_rate_radps =
                                w.max(-speed_mps / MIN_TURN_RADIUS_M).min(speed_mps / MIN_TURN_RADIUS_M);
                            s = kinematic_step(&s, Action { accel_mps2: a, yaw_rate_radps }, SIM_DT_S);
                            if off_road(&s.position) {
                                child.clearance_m = f64::NEG_INFINITY;
                                break;
                            }
                            child.clearance_m = clearance(step, &s, child.clearance_m);
                            if child.clearance_m <= budget.margin_m {
                                break;
                            }
                            child.segment[child.len] = s;
                            child.len += 1;
                        }
                        if child.clearance_m > budget.margin_m && !repeats_a_sibling(&mut siblings, &next, &child) {
                            child.room_m = clearance(period * TOKEN_PERIOD_STEPS + child.len, &s, ROOM_CAP_M);
                            next.push(child);
                        }
                    }
                }
            }
            if next.is_empty() {
                return Witness::NoneWithinBudget { expansions };
            }
            next.sort_by(beam_order);
            beams.push(select_beam(next, &start, budget.beam_width, budget.per_speed_band));
        }
        let best = &beams.last().unwrap()[0];
        Witness::Found { trajectory: trajectory_to(&beams, 0, &start), min_clearance_m: best.clearance_m, expansions }
    }

    #[test]
    fn the_pruned_search_finds_what_the_plain_search_finds() {
        // Same witness or none, same trajectory bit for bit, same clearance
        // and expansions, for stopped and moving starts, wide and narrow
        // beams, and budgets that run out mid-search.
        let mut outcomes = [0usize; 3];
        for seed in 0..16u64 {
            let (states, bodies) = random_traffic(10 + (seed as usize % 4) * 8, 30, seed);
            let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0, road: None };
            let start = at(0.0, 0.0, [0.0, 0.0, 4.0, 9.0][seed as usize % 4]);
            for budget in [
                WitnessBudget::default(),
                WitnessBudget { beam_width: 5, ..WitnessBudget::default() },
                WitnessBudget { per_speed_band: 0, ..WitnessBudget::default() },
                WitnessBudget {
                    beam_width: 12,
                    max_expansions: 1_000,
                    margin_m: 0.3,
                    widenings: [1, 1, 1],
                    per_speed_band: 2,
                },
                WitnessBudget {
                    beam_width: 1,
                    max_expansions: 200,
                    margin_m: 0.05,
                    widenings: [1, 1, 1],
                    per_speed_band: 1,
                },
                WitnessBudget {
                    beam_width: 3,
                    max_expansions: 5_000,
                    margin_m: 0.05,
                    widenings: [1, 1, 1],
                    per_speed_band: 0,
                },
            ] {
                let plain = plain_search(&start, car(), &traffic, 30, budget);
                let pruned = beam_search(&start, car(), &traffic, 30, budget);
                assert_eq!(format!("{pruned:?}"), format!("{plain:?}"), "seed {seed} {budget:?}");
                outcomes[match plain {
                    Witness::Found { .. } => 0,
                    Witness::NoneWithinBudget { expansions } if expansions == budget.max_expansions => 1,
                    Witness::NoneWithinBudget { expansions } => {
                        assert!(expansions > 0, "seed {seed}: touching at the start");
                        2
                    }
                }] += 1;
            }
        }
        // Found, out of budget, and boxed in all occur.
        assert!(outcomes.iter().all(|&n| n > 0), "{outcomes:?}");
    }

    #[test]
    fn the_pruned_search_keeps_to_the_road_as_the_plain_search_does() {
        let road = straight_road(3);
        let mut kept_to_it = 0;
        for seed in 0..12u64 {
            let (states, bodies) = random_traffic(14, 30, seed);
            let traffic = FixedTraffic {
                states: &states,
                bodies: &bodies,
                ego: 0,
                road: Some(RoadRule { map: &road, keeping: RoadKeeping::Centre }),
            };
            let start = at(0.0, 0.0, [0.0, 4.0, 9.0][seed as usize % 3]);
            for budget in [
                WitnessBudget::default(),
                WitnessBudget { beam_width: 6, per_speed_band: 1, ..WitnessBudget::default() },
            ] {
                let plain = plain_search(&start, car(), &traffic, 30, budget);
                assert_eq!(
                    format!("{:?}", beam_search(&start, car(), &traffic, 30, budget)),
                    format!("{plain:?}"),
                    "seed {seed}"
                );
                let free = FixedTraffic { road: None, ..traffic };
                kept_to_it += usize::from(plain != plain_search(&start, car(), &free, 30, budget));
            }
        }
        assert!(kept_to_it > 0, "the road changed no search");
    }
}
