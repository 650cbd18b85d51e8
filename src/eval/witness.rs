//! The feasibility witness: proof that a generated collision was avoidable.
//! Given the other agents' trajectories fixed (as the variant produced
//! them), search for an ego trajectory within the ego's dynamic limits —
//! the token grid's acceleration and yaw-rate ranges, speed ≥ 0, through the
//! kinematic model — that touches no other agent over the horizon. The
//! search is a beam search over one (acceleration, yaw rate) choice per
//! token period, keeping the candidates with the largest clearance so far
//! (among equal ones, those with the most room at the period's end); it
//! returns the first collision-free trajectory it completes, or says that
//! none was found within its budget (which is not a proof of
//! infeasibility). When the beam finds nothing, the search runs once more
//! with a wider one.
//!
//! The search skips only work that cannot change its answer: a candidate
//! that can no longer enter the beam is dropped as soon as that is certain
//! (it still counts as an expansion), boxes the ego cannot reach in time
//! are left out of each step's obstacles, and clearance queries repeated
//! for the same pose at the same step are answered from memory. Each beam
//! search's result is bit for bit that of the plain one.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};
use std::hash::BuildHasherDefault;

use crate::geometry::{BoxSet, OrientedBox, Point2, Pose2};
use crate::motion::KinematicState;
use crate::motion::kinematics::max_travel_m;
use crate::motion::kinematics::{step_to_heading, turned_heading_rad};
use crate::motion::tokens::{MAX_ACCEL_MPS2, MAX_YAW_RATE_RADPS, SIM_DT_S, TOKEN_PERIOD_STEPS};
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
    /// When the search finds nothing, it searches once more with the beam
    /// and the expansion budget this many times as large (1: it does not).
    /// Most witnesses are found by the narrow beam; a few need the wide
    /// one, and the narrow one keeps the usual case cheap.
    pub widening: usize,
}

impl Default for WitnessBudget {
    fn default() -> Self {
        Self { beam_width: 48, max_expansions: 60_000, margin_m: 0.05, widening: 8 }
    }
}

/// Accelerations tried per period, m/s²: full braking to full acceleration
/// (the token grid's range; an escape from a car closing from behind may
/// need all of it).
const ACCELS_MPS2: [f64; 8] = [-MAX_ACCEL_MPS2, -3.5, -2.0, -0.8, 0.0, 1.0, 2.5, MAX_ACCEL_MPS2];
/// Yaw rates tried per period, rad/s (the grid allows ±1.5; ±1 rad/s is a
/// 10 m radius at 10 m/s, the sharpest swerve most escapes need; more
/// choices per period would outgrow the expansion budget of an 8 s
/// search: 48 candidates × 72 actions × 16 periods = 55 296 of 60 000).
const YAW_RATES_RADPS: [f64; 9] = [-1.0, -0.6, -0.3, -0.1, 0.0, 0.1, 0.3, 0.6, 1.0];

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
/// copies five states, not its whole history). The beam ranks entries by
/// their clearance so far and, among equally clear ones, by their room at
/// the period's end.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    /// Index of the parent in the previous period's beam (unused in period 0).
    parent: usize,
    /// The states of this period, `segment[..len]`.
    segment: [KinematicState; TOKEN_PERIOD_STEPS],
    len: usize,
    clearance_m: f64,
    /// Clearance at the period's last state, capped at [`ROOM_CAP_M`].
    room_m: f64,
}

impl Candidate {
    fn last(&self, start: &KinematicState) -> KinematicState {
        if self.len == 0 { *start } else { self.segment[self.len - 1] }
    }
}

impl FixedTraffic<'_> {
    /// The other agents' boxes at `step`, less those whose centre lies
    /// farther than `keep_within_m` (plus the box's bounding radius) from
    /// `around`.
    fn obstacles_at(&self, step: usize, around: &Point2, keep_within_m: f64) -> BoxSet {
        let row = self.states.get(step).map_or(&[][..], Vec::as_slice);
        BoxSet::new(row.iter().enumerate().filter(|(i, _)| *i != self.ego).filter_map(|(i, s)| {
            let b = self.bodies[i];
            let s = s.as_ref()?;
            let far = (s.position - around).norm() > keep_within_m + 0.5 * b.length_m.hypot(b.width_m);
            (!far).then(|| OrientedBox::new(s.pose(), b.length_m, b.width_m))
        }))
    }
}

/// Cap of a candidate's room, m. The clearance so far is the beam's first
/// key, and it often ties: every child that has not come nearer anything
/// than its parent already had keeps the parent's value. Ranking those
/// by the order tried filled the beam with hard braking (the first
/// acceleration tried) and lost escapes from a CBV closing from behind
/// (stage 2's planner escaped 17 of the 24 collisions on WOMD interactive
/// that the search called unwitnessed). Among equal clearances the beam
/// prefers the candidate with the most room now; beyond a few car lengths
/// more room says little, and the cap bounds the query.
pub const ROOM_CAP_M: f64 = 10.0;

/// The beam's order: larger clearance so far first, then more room (a
/// stable sort keeps the order tried among full ties).
fn beam_order(a: &Candidate, b: &Candidate) -> std::cmp::Ordering {
    b.clearance_m.total_cmp(&a.clearance_m).then(b.room_m.total_cmp(&a.room_m))
}

/// Slack of the reach filter of the obstacles, m: far above the rounding of
/// the positions it bounds, small beside the distances it prunes.
const REACH_SLACK_M: f64 = 0.1;

/// What one clearance query showed about the clearance of one ego pose at
/// one step to every box there (the unbounded answer `D`).
#[derive(Debug, Clone, Copy)]
enum Known {
    /// `D` itself.
    Exactly(f64),
    /// `D >= this`.
    AtLeast(f64),
    /// `D <= this`.
    AtMost(f64),
}

/// An ego pose at a step, bit for bit: the key of [`ClearanceMemo`].
type PoseKey = (usize, u64, u64, u64);

/// FxHash's word step: the memo's keys are a few machine words, and SipHash
/// would cost about as much as the query it saves.
#[derive(Default)]
struct PoseHasher(u64);

impl std::hash::Hasher for PoseHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.write_u64(u64::from(*b));
        }
    }
    fn write_u64(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, word: usize) {
        self.write_u64(word as u64);
    }
}

/// Clearance queries already answered, by exact ego pose and step. The
/// beam often holds candidates in the same pose (a stopped ego stays put
/// whichever braking it picks, and their children coincide too), and a
/// repeated query is answered from here when what is known settles it:
/// the answer is then the one the query itself would give (see
/// [`ClearanceMemo::clearance_below`]).
#[derive(Default)]
struct ClearanceMemo {
    known: HashMap<PoseKey, Known, BuildHasherDefault<PoseHasher>>,
}

impl ClearanceMemo {
    /// [`BoxSet::clearance_below_unless_at_most`] on the boxes at `step`
    /// (infinite clearance past the recorded steps) for the ego at `ego`
    /// (its state and its heading's `sin_cos()`), remembered. From memory
    /// it answers `min(bound, D)` where `D` is known, `bound` where
    /// `D >= bound` is known, and a known upper bound
    /// of `D` that is `<= floor` (a value `<= floor`, all the query promises
    /// there); otherwise it runs the query.
    fn clearance_below(
        &mut self,
        obstacles: &[BoxSet],
        step: usize,
        (ego, sin_cos): (&KinematicState, (f64, f64)),
        body: AgentBody,
        bound: f64,
        floor: f64,
    ) -> f64 {
        let Some(set) = obstacles.get(step) else { return bound };
        let key = (step, ego.position.x.to_bits(), ego.position.y.to_bits(), ego.heading_rad.to_bits());
        let known = self.known.get(&key).copied();
        match known {
            Some(Known::Exactly(d)) => return bound.min(d),
            Some(Known::AtLeast(lo)) if bound <= lo => return bound,
            Some(Known::AtMost(hi)) if hi <= floor => return hi,
            _ => {}
        }
        let pose = Pose2 { position: ego.position, heading_rad: ego.heading_rad };
        let ego_box = OrientedBox::new(pose, body.length_m, body.width_m);
        let r = set.clearance_below_unless_at_most_with_sin_cos(&ego_box, sin_cos, bound, floor);
        // Above the floor the answer is exact: `min(bound, D)`. At or below
        // it, the answer is a clearance to some box, so `D <= r` when `r`
        // came from a box rather than the bound.
        let learnt = if r > floor {
            if r < bound { Some(Known::Exactly(r)) } else { Some(Known::AtLeast(bound)) }
        } else {
            (r < bound).then_some(Known::AtMost(r))
        };
        if let Some(learnt) = learnt
            && !matches!(known, Some(Known::Exactly(_)))
        {
            self.known.insert(key, learnt);
        }
        r
    }
}

/// Each yaw rate's headings over one period from a start heading, with
/// their `sin_cos()`: `turns[w][k]` after k + 1 steps at `YAW_RATES_RADPS[w]`.
type Turns = [[(f64, (f64, f64)); TOKEN_PERIOD_STEPS]; YAW_RATES_RADPS.len()];

/// [`Turns`] by start heading (its bits), remembered over a search. A
/// child's headings depend on its parent's heading and its yaw rate only,
/// not on its acceleration or position, and many candidates in a beam share
/// a heading (they differ in speed only): sines and cosines were most of
/// the search's time.
#[derive(Default)]
struct TurnsMemo {
    known: HashMap<u64, Box<Turns>, BuildHasherDefault<PoseHasher>>,
}

impl TurnsMemo {
    fn from(&mut self, heading_rad: f64) -> &Turns {
        self.known.entry(heading_rad.to_bits()).or_insert_with(|| {
            Box::new(YAW_RATES_RADPS.map(|w| {
                let w = w.clamp(-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS);
                let mut heading_rad = heading_rad;
                [(); TOKEN_PERIOD_STEPS].map(|()| {
                    heading_rad = turned_heading_rad(heading_rad, w, SIM_DT_S);
                    (heading_rad, heading_rad.sin_cos())
                })
            }))
        })
    }
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

/// The clearances of the best `width` candidates of a period kept so far.
/// The beam keeps the largest clearances (ties to more room), so once
/// `width` are kept a later candidate whose clearance falls below the
/// smallest of them cannot enter it: the search drops it at once. One that
/// ties with it may still win on room, and is kept to the period's end.
struct BeamFloor {
    width: usize,
    kept: BinaryHeap<Reverse<Clearance>>,
}

impl BeamFloor {
    fn new(width: usize) -> Self {
        Self { width, kept: BinaryHeap::with_capacity(width + 1) }
    }

    /// The clearance a later candidate must beat, once the beam is full.
    fn get(&self) -> Option<f64> {
        (self.width > 0 && self.kept.len() == self.width).then(|| self.kept.peek().map_or(f64::INFINITY, |c| c.0.0))
    }

    fn keep(&mut self, clearance_m: f64) {
        self.kept.push(Reverse(Clearance(clearance_m)));
        if self.kept.len() > self.width {
            self.kept.pop();
        }
    }
}

/// Choices tried per candidate and period.
const ACTIONS: usize = ACCELS_MPS2.len() * YAW_RATES_RADPS.len();

/// Searches an ego trajectory from `start` over `horizon_steps` simulator
/// steps that avoids every agent of `traffic`: a beam search, widened once
/// by `budget.widening` when it finds nothing (the expansions reported are
/// those of both).
pub fn search_witness(
    start: &AgentState,
    body: AgentBody,
    traffic: &FixedTraffic<'_>,
    horizon_steps: usize,
    budget: WitnessBudget,
) -> Witness {
    let narrow = beam_search(start, body, traffic, horizon_steps, budget);
    let Witness::NoneWithinBudget { expansions: narrow_expansions } = narrow else { return narrow };
    if budget.widening <= 1 || narrow_expansions == 0 {
        // Nothing to widen, or touching at the start.
        return narrow;
    }
    let wide_budget = WitnessBudget {
        beam_width: budget.beam_width.saturating_mul(budget.widening),
        max_expansions: budget.max_expansions.saturating_mul(budget.widening),
        ..budget
    };
    let mut wide = beam_search(start, body, traffic, horizon_steps, wide_budget);
    let (Witness::Found { expansions, .. } | Witness::NoneWithinBudget { expansions }) = &mut wide;
    *expansions += narrow_expansions;
    wide
}

/// One beam search of [`search_witness`] with `budget`'s beam and
/// expansions (its `widening` unused).
fn beam_search(
    start: &AgentState,
    body: AgentBody,
    traffic: &FixedTraffic<'_>,
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
        let beam = beams.last().expect("the start's beam");
        let mut next: Vec<Candidate> = Vec::with_capacity(2 * budget.beam_width.min(beam.len() * ACTIONS));
        let mut floor = BeamFloor::new(budget.beam_width);
        for (parent, c) in beam.iter().enumerate() {
            // A child never has more clearance than its parent, and the beam
            // is sorted best first: once a parent is no better than the
            // floor, neither its children nor any later parent's can enter
            // the beam. They still count as tried, as when they were run.
            if floor.get().is_some_and(|f| c.clearance_m < f) {
                let skipped = (beam.len() - parent) * ACTIONS;
                if expansions + skipped > budget.max_expansions {
                    return Witness::NoneWithinBudget { expansions: budget.max_expansions.max(expansions) };
                }
                expansions += skipped;
                break;
            }
            let from = c.last(&start);
            let turns = turns_memo.from(from.heading_rad);
            for &a in &ACCELS_MPS2 {
                for turn in turns {
                    if expansions >= budget.max_expansions {
                        return Witness::NoneWithinBudget { expansions };
                    }
                    expansions += 1;
                    // Dropped at or below the margin, or below the floor.
                    let drop_at_m = floor.get().map_or(budget.margin_m, |f| f.next_down().max(budget.margin_m));
                    let mut s = from;
                    // The heading's `sin_cos()` of the last state stepped to.
                    let mut sin_cos = None;
                    let mut child = Candidate {
                        parent,
                        segment: [s; TOKEN_PERIOD_STEPS],
                        len: 0,
                        clearance_m: c.clearance_m,
                        room_m: 0.0,
                    };
                    for (k, &(heading_rad, trig)) in turn.iter().enumerate() {
                        let step = period * TOKEN_PERIOD_STEPS + k + 1;
                        if step > horizon_steps {
                            break;
                        }
                        (s, sin_cos) = (step_to_heading(&s, a, heading_rad, trig, SIM_DT_S), Some(trig));
                        child.clearance_m =
                            memo.clearance_below(&obstacles, step, (&s, trig), body, child.clearance_m, drop_at_m);
                        if child.clearance_m <= drop_at_m {
                            break;
                        }
                        child.segment[child.len] = s;
                        child.len += 1;
                    }
                    if child.clearance_m > drop_at_m {
                        let step = period * TOKEN_PERIOD_STEPS + child.len;
                        let trig = sin_cos.unwrap_or_else(|| s.heading_rad.sin_cos());
                        child.room_m =
                            memo.clearance_below(&obstacles, step, (&s, trig), body, ROOM_CAP_M, f64::NEG_INFINITY);
                        floor.keep(child.clearance_m);
                        next.push(child);
                    }
                }
            }
        }
        if next.is_empty() {
            return Witness::NoneWithinBudget { expansions };
        }
        // Keep the widest margins, then the most room; full ties by the
        // order tried (deterministic).
        next.sort_by(beam_order);
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
    use crate::motion::{Action, kinematic_step};
    use crate::scenario::AgentKind;

    fn car() -> AgentBody {
        AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }
    }

    fn at(x: f64, y: f64, v: f64) -> AgentState {
        AgentState { position: Point2::new(x, y), heading_rad: 0.0, velocity_mps: Vector2::new(v, 0.0) }
    }

    /// The search as it was before its pruning and memo: every child of
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
            let mut next = Vec::new();
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
                            s = kinematic_step(&s, action, SIM_DT_S);
                            child.clearance_m = clearance(step, &s, child.clearance_m);
                            if child.clearance_m <= budget.margin_m {
                                break;
                            }
                            child.segment[child.len] = s;
                            child.len += 1;
                        }
                        if child.clearance_m > budget.margin_m {
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
            next.truncate(budget.beam_width);
            beams.push(next);
        }
        let best = &beams.last().unwrap()[0];
        let mut segments = Vec::new();
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

    /// Traffic around a start at the origin: `n` cars on straight lines,
    /// some parked, from a fixed seed; some come and go mid-way.
    fn random_traffic(n: usize, steps: usize, seed: u64) -> (Vec<Vec<Option<AgentState>>>, Vec<AgentBody>) {
        let mut state = seed;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let agents: Vec<(Point2, f64, f64, AgentBody, usize)> = (0..n)
            .map(|_| {
                // Clear of the start, so most searches get going.
                let mut p = Point2::new(0.0, 0.0);
                while p.coords.norm() < 6.0 {
                    p = Point2::new(next() * 60.0 - 20.0, next() * 24.0 - 12.0);
                }
                let heading = next() * 6.3 - 3.15;
                let speed = if next() < 0.4 { 0.0 } else { next() * 12.0 };
                let body = AgentBody { kind: AgentKind::Vehicle, length_m: 3.5 + next() * 5.0, width_m: 1.6 + next() };
                (p, heading, speed, body, (next() * steps as f64 * 1.5) as usize)
            })
            .collect();
        let states = (0..=steps)
            .map(|k| {
                let t = k as f64 * SIM_DT_S;
                let mut row = vec![None];
                row.extend(agents.iter().map(|&(p, h, v, _, gone)| {
                    let dir = Vector2::new(h.cos(), h.sin());
                    (k < gone).then(|| AgentState { position: p + dir * v * t, heading_rad: h, velocity_mps: dir * v })
                }));
                row
            })
            .collect();
        let mut bodies = vec![car()];
        bodies.extend(agents.iter().map(|a| a.3));
        (states, bodies)
    }

    #[test]
    fn the_pruned_search_finds_what_the_plain_search_finds() {
        // Same witness or none, same trajectory bit for bit, same clearance
        // and expansions, for stopped and moving starts, wide and narrow
        // beams, and budgets that run out mid-search.
        let mut outcomes = [0usize; 3];
        for seed in 0..16u64 {
            let (states, bodies) = random_traffic(10 + (seed as usize % 4) * 8, 30, seed);
            let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0 };
            let start = at(0.0, 0.0, [0.0, 0.0, 4.0, 9.0][seed as usize % 4]);
            for budget in [
                WitnessBudget::default(),
                WitnessBudget { beam_width: 5, ..WitnessBudget::default() },
                WitnessBudget { beam_width: 12, max_expansions: 1_000, margin_m: 0.3, widening: 1 },
                WitnessBudget { beam_width: 1, max_expansions: 200, margin_m: 0.05, widening: 1 },
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
    fn the_search_widens_its_beam_only_when_the_narrow_one_finds_nothing() {
        let narrow = WitnessBudget { beam_width: 1, max_expansions: 2_000, margin_m: 0.05, widening: 1 };
        let widened = WitnessBudget { widening: 8, ..narrow };
        let wide = WitnessBudget { beam_width: 8, max_expansions: 16_000, ..narrow };
        let mut rescued = 0;
        for seed in 0..24u64 {
            let (states, bodies) = random_traffic(26, 30, seed);
            let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0 };
            let start = at(0.0, 0.0, [0.0, 4.0, 9.0][seed as usize % 3]);
            let first = beam_search(&start, car(), &traffic, 30, narrow);
            let got = search_witness(&start, car(), &traffic, 30, widened);
            match (&first, beam_search(&start, car(), &traffic, 30, wide)) {
                (Witness::Found { .. }, _) => assert_eq!(got, first, "seed {seed}"),
                (Witness::NoneWithinBudget { expansions: 0 }, _) => assert_eq!(got, first, "seed {seed}"),
                (Witness::NoneWithinBudget { expansions: e1 }, second) => {
                    assert_eq!(got.is_found(), second.is_found(), "seed {seed}");
                    assert_eq!(got.expansions(), e1 + second.expansions(), "seed {seed}");
                    rescued += usize::from(second.is_found());
                }
            }
        }
        assert!(rescued > 0, "no case where the wide beam found what the narrow one missed");
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
        assert_touches_no_car(&trajectory, &states);
    }

    /// Each step's agents, from steps 0 to `horizon`, by `at_time_s`.
    fn states_over(horizon: usize, at_time_s: impl Fn(f64) -> Vec<Option<AgentState>>) -> Vec<Vec<Option<AgentState>>> {
        (0..=horizon).map(|k| at_time_s(k as f64 * SIM_DT_S)).collect()
    }

    /// `search` from `start` (ego index 0) with the default budget, every agent a car.
    fn search_among_cars(
        search: fn(&AgentState, AgentBody, &FixedTraffic<'_>, usize, WitnessBudget) -> Witness,
        start: &AgentState,
        states: &[Vec<Option<AgentState>>],
        horizon: usize,
    ) -> Witness {
        let bodies = vec![car(); states[0].len()];
        let traffic = FixedTraffic { states, bodies: &bodies, ego: 0 };
        search(start, car(), &traffic, horizon, WitnessBudget::default())
    }

    /// Every state of `trajectory` (a car) clear of every car in `states`.
    fn assert_touches_no_car(trajectory: &[AgentState], states: &[Vec<Option<AgentState>>]) {
        for (k, s) in trajectory.iter().enumerate() {
            let ego = OrientedBox::new(s.pose(), 4.5, 2.0);
            for other in states[k].iter().flatten() {
                assert!(!ego.intersects(&OrientedBox::new(other.pose(), 4.5, 2.0)), "step {k}");
            }
        }
    }

    #[test]
    fn an_escape_from_a_cbv_closing_from_behind_is_found_though_clearances_tie() {
        // Ego at 10 m/s with a car 1 m to its left at its speed (the
        // clearance every candidate keeps while it holds its lane), another
        // ahead on the right, and a CBV 30 m behind closing at 8 m/s. Ranked
        // by clearance alone, the ties went to the order tried: the beam
        // filled with hard braking and the search found no escape.
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

    #[test]
    fn a_wall_closing_from_behind_is_escaped_at_full_acceleration() {
        // Ego at 10 m/s, a wall 40 m wide 4 m behind it at 15 m/s: no swerve
        // clears it, braking or holding speed is hit within a second, and
        // 2.5 m/s² (the firmest acceleration the search tried before) is
        // caught after 1.1 s; 5 m/s² keeps 1.5 m clear.
        let horizon = 20;
        let wall = AgentBody { kind: AgentKind::Vehicle, length_m: 4.0, width_m: 40.0 };
        let states = states_over(horizon, |t| vec![None, Some(at(-8.25 + 15.0 * t, 0.0, 15.0))]);
        let traffic = FixedTraffic { states: &states, bodies: &[car(), wall], ego: 0 };
        let w = search_witness(&at(0.0, 0.0, 10.0), car(), &traffic, horizon, WitnessBudget::default());
        let Witness::Found { trajectory, min_clearance_m, .. } = w else { panic!("{w:?}") };
        assert!(min_clearance_m > WitnessBudget::default().margin_m);
        // Faster than 2.5 m/s² could make it over the first second.
        assert!(trajectory[10].speed_mps() > 10.0 + 2.5 + 1.0, "{:?}", trajectory[10]);
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
