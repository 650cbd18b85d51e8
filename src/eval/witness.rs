//! The feasibility witness: proof that a generated collision was avoidable.
//! Given the other agents' trajectories fixed (as the variant produced
//! them), search for an ego trajectory within the ego's dynamic limits —
//! the token grid's acceleration and yaw-rate ranges, speed ≥ 0, through the
//! kinematic model — that touches no other agent over the horizon. The
//! search is a beam search over one (acceleration, yaw rate) choice per
//! token period, keeping the candidates with the largest clearance so far;
//! it returns the first collision-free trajectory it completes, or says
//! that none was found within its budget (which is not a proof of
//! infeasibility).

use crate::geometry::{BoxSet, OrientedBox};
use crate::motion::tokens::{MAX_ACCEL_MPS2, MAX_YAW_RATE_RADPS, SIM_DT_S, TOKEN_PERIOD_STEPS};
use crate::motion::{Action, KinematicState, kinematic_step};
use crate::scenario::{AgentBody, AgentState};

/// Search settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WitnessBudget {
    /// Candidates kept per token period.
    pub beam_width: usize,
    /// Most candidate expansions (one expansion = one token period of one candidate).
    pub max_expansions: usize,
    /// Clearance the witness keeps from every box, m.
    pub margin_m: f64,
}

impl Default for WitnessBudget {
    fn default() -> Self {
        Self { beam_width: 48, max_expansions: 60_000, margin_m: 0.05 }
    }
}

/// Accelerations tried per period, m/s² (full braking to firm acceleration).
const ACCELS_MPS2: [f64; 7] = [-MAX_ACCEL_MPS2, -3.5, -2.0, -0.8, 0.0, 1.0, 2.5];
/// Yaw rates tried per period, rad/s.
const YAW_RATES_RADPS: [f64; 7] = [-0.6, -0.3, -0.1, 0.0, 0.1, 0.3, 0.6];

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
}

/// The obstacles: every other agent's state per simulator step from the start
/// (`obstacles[k]` = the agents at step k), with their bodies.
#[derive(Debug, Clone)]
pub struct FixedTraffic<'a> {
    /// `states[k][i]`: agent i at step k (`None` = absent).
    pub states: &'a [Vec<Option<AgentState>>],
    /// Bodies, same indexing.
    pub bodies: &'a [AgentBody],
    /// The ego's index in `states` (ignored as an obstacle).
    pub ego: usize,
}

/// One beam entry: the states of its last token period, linked to the
/// entry of the period before it it grew from (so expanding a candidate
/// copies five states, not its whole history).
#[derive(Debug, Clone, Copy)]
struct Candidate {
    /// Index of the parent in the previous period's beam (unused in period 0).
    parent: usize,
    /// The states of this period, `segment[..len]`.
    segment: [KinematicState; TOKEN_PERIOD_STEPS],
    len: usize,
    clearance_m: f64,
}

impl Candidate {
    fn last(&self, start: &KinematicState) -> KinematicState {
        if self.len == 0 { *start } else { self.segment[self.len - 1] }
    }
}

impl FixedTraffic<'_> {
    /// Every other agent's box at every step, for the broad phase.
    fn obstacles(&self) -> Vec<BoxSet> {
        self.states
            .iter()
            .map(|row| {
                BoxSet::new(row.iter().enumerate().filter(|(i, _)| *i != self.ego).filter_map(|(i, s)| {
                    s.map(|s| {
                        let b = self.bodies[i];
                        OrientedBox::new(s.pose(), b.length_m, b.width_m)
                    })
                }))
            })
            .collect()
    }
}

/// The smaller of `bound` and the smallest box distance from the ego at
/// `step` to any other agent (infinite past the recorded steps).
fn clearance_below(obstacles: &[BoxSet], step: usize, ego: &KinematicState, body: AgentBody, bound: f64) -> f64 {
    let Some(set) = obstacles.get(step) else { return bound };
    let ego_box = OrientedBox::new(ego.to_agent_state().pose(), body.length_m, body.width_m);
    set.clearance_below(&ego_box, bound)
}

/// Searches an ego trajectory from `start` over `horizon_steps` simulator
/// steps that avoids every agent of `traffic`.
pub fn search_witness(
    start: &AgentState,
    body: AgentBody,
    traffic: &FixedTraffic<'_>,
    horizon_steps: usize,
    budget: WitnessBudget,
) -> Witness {
    let start = KinematicState::from_agent_state(start);
    let obstacles = traffic.obstacles();
    let first_clearance = clearance_below(&obstacles, 0, &start, body, f64::INFINITY);
    if first_clearance <= budget.margin_m {
        // Already touching at the start: nothing the ego does can undo it.
        return Witness::NoneWithinBudget { expansions: 0 };
    }
    let root = Candidate { parent: 0, segment: [start; TOKEN_PERIOD_STEPS], len: 0, clearance_m: first_clearance };
    // `beams[p]`: the beam after period p (`beams[0]`: the start alone).
    let mut beams: Vec<Vec<Candidate>> = vec![vec![root]];
    let mut expansions = 0;
    let periods = horizon_steps.div_ceil(TOKEN_PERIOD_STEPS);
    for period in 0..periods {
        let beam = beams.last().expect("the start's beam");
        let mut next: Vec<Candidate> = Vec::with_capacity(beam.len() * ACCELS_MPS2.len() * YAW_RATES_RADPS.len());
        for (parent, c) in beam.iter().enumerate() {
            for &a in &ACCELS_MPS2 {
                for &w in &YAW_RATES_RADPS {
                    if expansions >= budget.max_expansions {
                        return Witness::NoneWithinBudget { expansions };
                    }
                    expansions += 1;
                    let action =
                        Action { accel_mps2: a, yaw_rate_radps: w.clamp(-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS) };
                    let mut s = c.last(&start);
                    let mut child =
                        Candidate { parent, segment: [s; TOKEN_PERIOD_STEPS], len: 0, clearance_m: c.clearance_m };
                    for k in 0..TOKEN_PERIOD_STEPS {
                        let step = period * TOKEN_PERIOD_STEPS + k + 1;
                        if step > horizon_steps {
                            break;
                        }
                        s = kinematic_step(&s, action, SIM_DT_S);
                        child.clearance_m = clearance_below(&obstacles, step, &s, body, child.clearance_m);
                        if child.clearance_m <= budget.margin_m {
                            break;
                        }
                        child.segment[child.len] = s;
                        child.len += 1;
                    }
                    if child.clearance_m > budget.margin_m {
                        next.push(child);
                    }
                }
            }
        }
        if next.is_empty() {
            return Witness::NoneWithinBudget { expansions };
        }
        // Keep the widest margins; ties by the order tried (deterministic).
        next.sort_by(|a, b| b.clearance_m.total_cmp(&a.clearance_m));
        next.truncate(budget.beam_width);
        beams.push(next);
    }
    // Walk the best candidate's links back to the start.
    let best = &beams.last().expect("the start's beam")[0];
    let mut segments = Vec::with_capacity(beams.len());
    let mut at = 0;
    for beam in beams.iter().rev() {
        let c = &beam[at];
        segments.push(&c.segment[..c.len]);
        at = c.parent;
    }
    let mut trajectory = vec![start.to_agent_state()];
    trajectory.extend(segments.iter().rev().flat_map(|seg| seg.iter().map(KinematicState::to_agent_state)));
    Witness::Found { trajectory, min_clearance_m: best.clearance_m, expansions }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::scenario::AgentKind;

    fn car() -> AgentBody {
        AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }
    }

    fn at(x: f64, y: f64, v: f64) -> AgentState {
        AgentState { position: Point2::new(x, y), heading_rad: 0.0, velocity_mps: Vector2::new(v, 0.0) }
    }

    #[test]
    fn braking_avoids_a_stopped_car_ahead() {
        // Ego at 10 m/s, a stopped car 20 m ahead: braking at 5 m/s² stops in 10 m.
        let horizon = 50;
        let states: Vec<Vec<Option<AgentState>>> =
            (0..=horizon).map(|_| vec![None, Some(at(20.0, 0.0, 0.0))]).collect();
        let traffic = FixedTraffic { states: &states, bodies: &[car(), car()], ego: 0 };
        let w = search_witness(&at(0.0, 0.0, 10.0), car(), &traffic, horizon, WitnessBudget::default());
        let Witness::Found { trajectory, min_clearance_m, .. } = w else { panic!("{w:?}") };
        assert_eq!(trajectory.len(), horizon + 1);
        assert!(min_clearance_m > 0.0);
        for (k, s) in trajectory.iter().enumerate() {
            let other = OrientedBox::new(states[k][1].unwrap().pose(), 4.5, 2.0);
            assert!(!OrientedBox::new(s.pose(), 4.5, 2.0).intersects(&other), "step {k}");
        }
    }

    #[test]
    fn an_unavoidable_hit_from_behind_has_no_witness() {
        // Ego stopped between a wall of cars left, right and ahead; a car from
        // behind at 20 m/s arrives within 0.5 s: no action gets away in time.
        let horizon = 20;
        let states: Vec<Vec<Option<AgentState>>> = (0..=horizon)
            .map(|k| {
                let t = k as f64 * SIM_DT_S;
                vec![
                    None,
                    Some(at(-10.0 + 20.0 * t, 0.0, 20.0)),
                    Some(at(5.0, 0.0, 0.0)),
                    Some(at(0.0, 2.3, 0.0)),
                    Some(at(0.0, -2.3, 0.0)),
                ]
            })
            .collect();
        let bodies = [car(), car(), car(), car(), car()];
        let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0 };
        let w = search_witness(&at(0.0, 0.0, 0.0), car(), &traffic, horizon, WitnessBudget::default());
        assert!(!w.is_found(), "{w:?}");
    }

    #[test]
    fn a_start_already_touching_has_no_witness() {
        let states = vec![vec![None, Some(at(1.0, 0.0, 0.0))]; 11];
        let traffic = FixedTraffic { states: &states, bodies: &[car(), car()], ego: 0 };
        assert_eq!(
            search_witness(&at(0.0, 0.0, 5.0), car(), &traffic, 10, WitnessBudget::default()),
            Witness::NoneWithinBudget { expansions: 0 }
        );
    }
}
