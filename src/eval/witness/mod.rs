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
//! speed (see [`COMPLETIONS_MPS2`]): once the ego is past the conflict one of
//! them is usually clear, and the witness is then that candidate's
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

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};
use std::hash::BuildHasherDefault;

use crate::geometry::{BoxSet, OrientedBox, Point2, Pose2};
use crate::map::RoadMap;
use crate::motion::KinematicState;
use crate::motion::kinematics::max_travel_m;
use crate::motion::kinematics::{step_to_heading, turned_heading_rad};
use crate::motion::tokens::{MAX_ACCEL_MPS2, MAX_YAW_RATE_RADPS, SIM_DT_S, TOKEN_PERIOD_STEPS};
use crate::scenario::{AgentBody, AgentState, Scenario};
use crate::sim::Rollout;

/// Search settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WitnessBudget {
    /// Candidates kept per token period.
    pub beam_width: usize,
    /// Most candidate expansions (one expansion = one token period of one candidate).
    pub max_expansions: usize,
    /// Clearance the witness keeps from every box, m.
    pub margin_m: f64,
    /// When the search finds nothing, it searches again with the beam and
    /// the expansion budget the first of these times as large, and when
    /// that finds nothing either, the next (1: that search is skipped).
    /// Most witnesses are found by the narrow beam and a few need a wide
    /// one; the narrow one keeps the usual case cheap, and only a search
    /// that finds nothing pays for the widest.
    pub widenings: [usize; 3],
    /// Candidates the beam keeps in every speed band ([`SPEED_BAND_MPS`])
    /// whatever their clearance, on top of the best overall up to
    /// `beam_width` (the beam may grow past it by these). Ranked by
    /// clearance alone, the beam fills with braking (slower means farther
    /// from a car closing head-on for the first seconds) and loses the
    /// swerves at speed that escape; widened with the beam.
    pub per_speed_band: usize,
}

impl Default for WitnessBudget {
    fn default() -> Self {
        Self {
            beam_width: 48,
            max_expansions: 60_000,
            margin_m: 0.05,
            widenings: [FIRST_WIDENING, DEFAULT_WIDEST, 1],
            per_speed_band: 3,
        }
    }
}

/// The first widening of the default search: most witnesses the narrow
/// beam misses, the ×8 one finds.
pub const FIRST_WIDENING: usize = 8;

/// The widest beam the default search tries, as a multiple of the narrow
/// one: the ×8 beam missed escapes from stage-1 collisions on recorded
/// scenes that the ×64 one finds (`docs/evaluation/issue-10-rounds.md`,
/// the twelfth round); only a search that finds nothing pays for it
/// (seconds on a busy scene).
pub const DEFAULT_WIDEST: usize = 64;

/// The widest beam `safer evaluate --witness-widest` accepts, as a multiple
/// of the narrow one (×512 already takes about a minute a search that finds
/// nothing on a busy scene).
pub const MOST_WIDEST: usize = 4096;

impl WitnessBudget {
    /// The default budget, widening at most to `widest` times the narrow
    /// beam: through the default's rungs (×[`FIRST_WIDENING`],
    /// ×[`DEFAULT_WIDEST`]) below `widest`, then ×`widest` (1: no
    /// widening), so that every witness the default finds is found as it
    /// finds it. A wider search finds escapes a narrower one misses, at
    /// more time where none exists.
    pub fn widening_up_to(widest: usize) -> Self {
        let widenings = if widest > DEFAULT_WIDEST {
            [FIRST_WIDENING, DEFAULT_WIDEST, widest]
        } else if widest > FIRST_WIDENING {
            [FIRST_WIDENING, widest, 1]
        } else {
            [widest, 1, 1]
        };
        Self { widenings, ..Self::default() }
    }
}

/// Tightest turning radius of the witness's ego, m: a passenger car's
/// (about 5 m kerb to kerb for a small car, more for most). Its yaw rate at
/// a step is at most the step's speed over it.
pub const MIN_TURN_RADIUS_M: f64 = 5.0;

/// Width of the beam's speed bands, m/s: the most one period's acceleration
/// changes the speed (5 m/s² for 0.5 s), so a child lands in its parent's
/// band or a neighbour.
pub const SPEED_BAND_MPS: f64 = MAX_ACCEL_MPS2 * TOKEN_PERIOD_STEPS as f64 * SIM_DT_S;

/// The speed band of `speed_mps` (a NaN speed counts as band 0; speeds
/// beyond any car's share the last band).
fn speed_band(speed_mps: f64) -> usize {
    ((speed_mps / SPEED_BAND_MPS) as usize).min(LAST_SPEED_BAND)
}

/// The last speed band (160 m/s and beyond).
const LAST_SPEED_BAND: usize = 63;

/// `yaw_rate_radps` bounded by what a car at `speed_mps` can turn (see
/// [`MIN_TURN_RADIUS_M`]); the unbounded rate, bit for bit, where it is
/// within reach.
fn turn_bounded_yaw_rate(yaw_rate_radps: f64, speed_mps: f64) -> f64 {
    let most = speed_mps / MIN_TURN_RADIUS_M;
    // Not `clamp`: a NaN speed leaves the rate as it is instead of panicking.
    yaw_rate_radps.max(-most).min(most)
}

/// The speeds over one period of `steps` steps from `speed_mps` at
/// `accel_mps2`, as [`step_to_heading`] computes them (`speeds[k]` after
/// k + 1 steps; the rest unused).
fn period_speeds(speed_mps: f64, accel_mps2: f64, steps: usize) -> [f64; TOKEN_PERIOD_STEPS] {
    let mut v = speed_mps;
    let mut speeds = [0.0; TOKEN_PERIOD_STEPS];
    for s in speeds.iter_mut().take(steps) {
        v = (v + accel_mps2 * SIM_DT_S).max(0.0);
        *s = v;
    }
    speeds
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
#[derive(Debug, Clone, Copy)]
pub struct FixedTraffic<'a> {
    /// `states[k][i]`: agent i at step k (`None` = absent).
    pub states: &'a [Vec<Option<AgentState>>],
    /// Bodies, same indexing.
    pub bodies: &'a [AgentBody],
    /// The ego's index in `states` (ignored as an obstacle).
    pub ego: usize,
    /// The road the ego must keep to (`None`: it may drive anywhere, as
    /// for V_h's labels: V_h sees no map either).
    pub road: Option<RoadRule<'a>>,
}

/// The road a witness keeps to and how much of the ego must stay on it.
#[derive(Debug, Clone, Copy)]
pub struct RoadRule<'a> {
    /// The map.
    pub map: &'a RoadMap,
    /// How much of the ego must stay on the road.
    pub keeping: RoadKeeping,
}

/// How much of the witness's ego must stay on the road.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RoadKeeping {
    /// Its centre: the rule the CBV's off-road time counts by; half the
    /// car may be over the edge (on a shoulder, say).
    #[default]
    Centre,
    /// Its whole width: the centre at least half the ego's width inside the
    /// road's edge. An ego that starts closer to the edge than that is held
    /// to its centre instead.
    WholeWidth,
}

impl RoadKeeping {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Centre, Self::WholeWidth];
}

/// Side of the cells at whose centres [`RoadCells`] judges the road, m:
/// well below a car's width, so the rule is the exact one to within 0.36 m.
pub const ROAD_CELL_M: f64 = 0.5;

/// Where the witness's ego may put its centre: on the road inside the mapped
/// area ([`RoadMap::is_off_road_within_map`], the rule the CBV's off-road
/// time counts by), or that far inside it that its whole width is (see
/// [`RoadKeeping`]), judged at the centre of the [`ROAD_CELL_M`] grid cell
/// it falls in and remembered per cell (a search visits the same cells
/// again and again; the map queries were a quarter of its time with the
/// memo). Anywhere, without a map or when the ego starts off
/// the road.
pub struct RoadCells<'a> {
    rule: Option<RoadRule<'a>>,
    /// Half the ego's width, m (how far inside the edge [`RoadKeeping::WholeWidth`] keeps the centre).
    half_width_m: f64,
    on_road: HashMap<(i64, i64), bool, BuildHasherDefault<PoseHasher>>,
}

impl<'a> RoadCells<'a> {
    /// The rule for an ego of `body` starting at `start`.
    pub fn new(rule: Option<RoadRule<'a>>, body: AgentBody, start: &Point2) -> Self {
        let half_width_m = 0.5 * body.width_m;
        let with = |rule| Self { rule, half_width_m, on_road: HashMap::default() };
        let centre = rule.map(|r| RoadRule { keeping: RoadKeeping::Centre, ..r });
        if !with(centre).allows(start) {
            // Off the road at the start: not held to it.
            return with(None);
        }
        if rule.is_some_and(|r| r.keeping == RoadKeeping::WholeWidth) && !with(rule).allows(start) {
            // Closer to the edge than half its width at the start.
            return with(centre);
        }
        with(rule)
    }

    /// Whether the ego's centre may be at `p`.
    pub fn allows(&mut self, p: &Point2) -> bool {
        let Some(RoadRule { map, keeping }) = self.rule else { return true };
        let half_width_m = self.half_width_m;
        // A NaN coordinate falls into cell 0 (saturating casts).
        let cell = ((p.x / ROAD_CELL_M).floor() as i64, (p.y / ROAD_CELL_M).floor() as i64);
        *self.on_road.entry(cell).or_insert_with(|| {
            let centre = Point2::new((cell.0 as f64 + 0.5) * ROAD_CELL_M, (cell.1 as f64 + 0.5) * ROAD_CELL_M);
            match keeping {
                RoadKeeping::Centre => !map.is_off_road_within_map(&centre),
                RoadKeeping::WholeWidth => match map.signed_distance_to_road_edge(&centre) {
                    Some(d) => d <= -half_width_m || map.is_past_mapped_end(&centre),
                    // Without road edges the drivable areas decide alone.
                    None => !map.is_off_road_within_map(&centre),
                },
            }
        })
    }
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

    /// Whether `self` and `other` drive the very same states this period.
    fn drives_as(&self, other: &Candidate) -> bool {
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
type Siblings = HashMap<u64, usize, BuildHasherDefault<PoseHasher>>;

/// Whether `child` drives as a sibling kept before it in `next` (and if
/// not, notes it as kept; `child` is then pushed at `next.len()`).
fn repeats_a_sibling(siblings: &mut Siblings, next: &[Candidate], child: &Candidate) -> bool {
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

/// The beam kept of a period's candidates `sorted` in [`beam_order`]: the
/// best `per_band` of every speed band and, of the rest, the best until
/// there are `width` in all; in [`beam_order`].
fn select_beam(sorted: Vec<Candidate>, start: &KinematicState, width: usize, per_band: usize) -> Vec<Candidate> {
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
    fn write_i64(&mut self, word: i64) {
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

/// Most clearances a [`BeamFloor`] makes room for before it is filled.
const PREALLOCATED_FLOOR: usize = 4096;

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
        // The heap grows to `width + 1`; storage for a usual beam up front,
        // not for an enormous one asked for (`--witness-widest`).
        Self { width, kept: BinaryHeap::with_capacity(width.min(PREALLOCATED_FLOOR).saturating_add(1)) }
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

/// The clearances of the best candidates of a period kept so far in each
/// speed band (see [`BeamFloor`]): the band's floor is the clearance a
/// later candidate must beat to be among its band's reserved best.
struct BandFloors {
    per_band: usize,
    floors: Vec<BeamFloor>,
}

impl BandFloors {
    fn new(per_band: usize) -> Self {
        Self { per_band, floors: Vec::new() }
    }

    /// The clearance a later candidate in `band` must beat to be among its
    /// band's reserved best, once that is certain (no band reserves
    /// anything: nothing gets in that way).
    fn get(&self, band: usize) -> Option<f64> {
        if self.per_band == 0 { Some(f64::INFINITY) } else { self.floors.get(band).and_then(BeamFloor::get) }
    }

    fn keep(&mut self, band: usize, clearance_m: f64) {
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

/// Choices tried per candidate and period.
const ACTIONS: usize = ACCELS_MPS2.len() * YAW_RATES_RADPS.len();

/// The accelerations with which a candidate may finish the horizon
/// straight on, without more search, in the order tried: braking as hard as
/// the token grid allows to a standstill (the minimal-risk manoeuvre of an
/// automated car) and holding its speed. Once the ego is past the conflict
/// one of them is usually clear of everything, and the beam's remaining
/// periods would only confirm it.
const COMPLETIONS_MPS2: [f64; 2] = [-MAX_ACCEL_MPS2, 0.0];

/// Candidates of each beam, in beam order, whose completions are tried
/// (each completion costs up to one clearance query per remaining step).
const COMPLETED_PER_BEAM: usize = 3;

/// Where the search stands when it tries completions: the step obstacles,
/// the memo and the road rule it shares with the beam.
struct Completer<'s, 'r> {
    obstacles: &'s [BoxSet],
    memo: &'s mut ClearanceMemo,
    road: &'s mut RoadCells<'r>,
    body: AgentBody,
    margin_m: f64,
    horizon_steps: usize,
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
    fn first_clear(
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

/// The trajectory from `start` of candidate `at` of the last of `beams`,
/// walking its links back.
fn trajectory_to(beams: &[Vec<Candidate>], at: usize, start: &KinematicState) -> Vec<AgentState> {
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

/// One beam search of [`search_witness`] with `budget`'s beam and
/// expansions (its `widenings` unused).
#[cfg(test)]
fn beam_search(
    start: &AgentState,
    body: AgentBody,
    traffic: &FixedTraffic<'_>,
    horizon_steps: usize,
    budget: WitnessBudget,
) -> Witness {
    let mut road = RoadCells::new(traffic.road, body, &start.position);
    beam_search_on(start, body, traffic, &mut road, horizon_steps, budget)
}

/// One beam search of [`search_witness`] with `budget`'s beam and
/// expansions (its `widenings` unused), keeping to `road`.
fn beam_search_on(
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
                            let speed_mps = (s.speed_mps + a * SIM_DT_S).max(0.0);
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

    /// A straight road 200 m long with `lanes` lanes of 3.5 m, the first
    /// lane's centre on the x axis and the origin 100 m from either end.
    fn straight_road(lanes: usize) -> RoadMap {
        straight_road_of(lanes, 3.5)
    }

    /// [`straight_road`] with lanes `lane_width_m` wide.
    fn straight_road_of(lanes: usize, lane_width_m: f64) -> RoadMap {
        let road = crate::map::templates::StraightRoad {
            lanes,
            oncoming_lanes: 0,
            lane_width_m,
            length_m: 200.0,
            speed_limit_mps: None,
        };
        road.build().translated(&Vector2::new(100.0, 0.5 * lane_width_m))
    }

    /// The rule keeping the ego's centre on `map`.
    fn centre_on(map: &RoadMap) -> Option<RoadRule<'_>> {
        Some(RoadRule { map, keeping: RoadKeeping::Centre })
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

    #[test]
    fn an_escape_only_off_the_road_is_no_witness() {
        // A car head-on in the ego's lane: swerving 2.05 m aside escapes, on
        // one lane only by leaving the road, on two by the other lane.
        let horizon = 60;
        let states = oncoming_car(horizon);
        let bodies = [car(), car()];
        let one_lane = straight_road(1);
        let two_lanes = straight_road(2);
        let search = |road: Option<RoadRule<'_>>| {
            let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0, road };
            search_witness(&at(0.0, 0.0, 4.0), car(), &traffic, horizon, WitnessBudget::default())
        };
        let Witness::Found { trajectory, .. } = search(None) else { panic!("no escape anywhere") };
        assert!(trajectory.iter().any(|s| one_lane.is_off_road_within_map(&s.position)));
        let w = search(centre_on(&one_lane));
        assert!(!w.is_found(), "{w:?}");
        let Witness::Found { trajectory, .. } = search(centre_on(&two_lanes)) else { panic!("no escape on two lanes") };
        assert_touches_no_car(&trajectory, &states);
        for s in &trajectory {
            // On the road to within the grid's half diagonal.
            let past_edge_m = two_lanes.signed_distance_to_road_edge(&s.position).unwrap();
            assert!(past_edge_m <= ROAD_CELL_M * std::f64::consts::FRAC_1_SQRT_2, "{s:?}: {past_edge_m} m off");
        }
    }

    #[test]
    fn keeping_the_whole_width_on_the_road_forbids_the_escape_over_the_edge_line() {
        // One lane 5.5 m wide, a car head-on in it: swerving 2.05 m aside
        // puts the centre 0.7 m from the edge, half the car over it.
        let horizon = 60;
        let states = oncoming_car(horizon);
        let bodies = [car(), car()];
        let wide_lane = straight_road_of(1, 5.5);
        let search = |keeping| {
            let road = Some(RoadRule { map: &wide_lane, keeping });
            let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0, road };
            search_witness(&at(0.0, 0.0, 4.0), car(), &traffic, horizon, WitnessBudget::default())
        };
        assert!(search(RoadKeeping::Centre).is_found());
        let w = search(RoadKeeping::WholeWidth);
        assert!(!w.is_found(), "{w:?}");
        // On two lanes of 3.5 m the other lane leaves room for the whole car.
        let two_lanes = straight_road(2);
        let road = Some(RoadRule { map: &two_lanes, keeping: RoadKeeping::WholeWidth });
        let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0, road };
        let w = search_witness(&at(0.0, 0.0, 4.0), car(), &traffic, horizon, WitnessBudget::default());
        let Witness::Found { trajectory, .. } = w else { panic!("{w:?}") };
        for s in &trajectory {
            let edge_m = two_lanes.signed_distance_to_road_edge(&s.position).unwrap();
            assert!(edge_m <= -1.0 + ROAD_CELL_M * std::f64::consts::FRAC_1_SQRT_2, "{s:?}: {edge_m} m");
        }
        // An ego starting nearer the edge than half its width is held to its
        // centre instead of having no move at all.
        let near_edge = at(0.0, -1.2, 4.0);
        let alone = vec![vec![None, None]; horizon + 1];
        let traffic = FixedTraffic { states: &alone, bodies: &bodies, ego: 0, road };
        assert!(search_witness(&near_edge, car(), &traffic, horizon, WitnessBudget::default()).is_found());
    }

    #[test]
    fn an_ego_starting_off_the_road_is_not_held_to_it() {
        let road = straight_road(1);
        let states = vec![vec![None]; 11];
        let bodies = [car()];
        let traffic = FixedTraffic {
            states: &states,
            bodies: &bodies,
            ego: 0,
            road: Some(RoadRule { map: &road, keeping: RoadKeeping::Centre }),
        };
        // 10 m beside the road, heading away from it.
        let start = AgentState { heading_rad: 1.5, ..at(0.0, 12.0, 5.0) };
        assert!(search_witness(&start, car(), &traffic, 10, WitnessBudget::default()).is_found());
    }

    #[test]
    fn a_budget_widening_up_to_n_ends_its_ladder_at_n() {
        assert_eq!(WitnessBudget::widening_up_to(DEFAULT_WIDEST), WitnessBudget::default());
        // Wider than the default: through its rungs first.
        assert_eq!(WitnessBudget::widening_up_to(512).widenings, [FIRST_WIDENING, DEFAULT_WIDEST, 512]);
        assert_eq!(WitnessBudget::widening_up_to(16).widenings, [FIRST_WIDENING, 16, 1]);
        // Up to the first rung: that rung alone, or none.
        assert_eq!(WitnessBudget::widening_up_to(FIRST_WIDENING).widenings, [FIRST_WIDENING, 1, 1]);
        assert_eq!(WitnessBudget::widening_up_to(4).widenings, [4, 1, 1]);
        assert_eq!(WitnessBudget::widening_up_to(1).widenings, [1, 1, 1]);
    }

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
        let traffic = FixedTraffic { states, bodies: &bodies, ego: 0, road: None };
        search(start, car(), &traffic, horizon, WitnessBudget::default())
    }

    /// Every state of `trajectory` (a car) clear of every car in `states`.
    fn assert_touches_no_car(trajectory: &[AgentState], states: &[Vec<Option<AgentState>>]) {
        assert_touches_none_of(trajectory, states, &vec![car(); states[0].len()]);
    }

    /// Every state of `trajectory` (a car) clear of every agent (of
    /// `bodies`) in `states`.
    fn assert_touches_none_of(trajectory: &[AgentState], states: &[Vec<Option<AgentState>>], bodies: &[AgentBody]) {
        for (k, s) in trajectory.iter().enumerate() {
            let ego = OrientedBox::new(s.pose(), 4.5, 2.0);
            for (other, b) in states[k].iter().zip(bodies).skip(1) {
                let Some(other) = other else { continue };
                assert!(!ego.intersects(&OrientedBox::new(other.pose(), b.length_m, b.width_m)), "step {k}");
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
        let traffic = FixedTraffic { states: &states, bodies: &[car(), wall], ego: 0, road: None };
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

    /// Every step of `trajectory` turns no tighter than [`MIN_TURN_RADIUS_M`]
    /// at the step's speed.
    fn assert_turns_like_a_car(trajectory: &[AgentState]) {
        for (k, pair) in trajectory.windows(2).enumerate() {
            let turned_rad = crate::geometry::wrap_angle(pair[1].heading_rad - pair[0].heading_rad).abs();
            let travelled_m = pair[1].speed_mps() * SIM_DT_S;
            assert!(
                turned_rad <= travelled_m / MIN_TURN_RADIUS_M + 1e-12,
                "step {k}: {turned_rad} rad in {travelled_m} m"
            );
        }
    }

    /// A car head-on from 40 m ahead at 10 m/s, from steps 0 to `horizon`.
    fn oncoming_car(horizon: usize) -> Vec<Vec<Option<AgentState>>> {
        states_over(horizon, |t| {
            let x = 40.0 - 10.0 * t;
            vec![
                None,
                Some(AgentState {
                    position: Point2::new(x, 0.0),
                    heading_rad: std::f64::consts::PI,
                    velocity_mps: Vector2::new(-10.0, 0.0),
                }),
            ]
        })
    }

    #[test]
    fn a_car_head_on_is_escaped_by_swerving_at_speed_not_by_braking() {
        // Ego at 4 m/s: stopping takes 0.8 s and the car still arrives, so
        // only a swerve escapes. Braking keeps the most clearance for the
        // first seconds, and a beam ranked by clearance alone kept only
        // braking candidates (and, turning no tighter than a car, found
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
    fn a_standing_car_moves_off_before_it_turns() {
        // Ego standing, the car head-on: it must pull away and steer out of
        // the lane; it may not turn in place.
        let horizon = 60;
        let states = oncoming_car(horizon);
        let w = search_among_cars(search_witness, &at(0.0, 0.0, 0.0), &states, horizon);
        let Witness::Found { trajectory, .. } = w else { panic!("{w:?}") };
        assert_touches_no_car(&trajectory, &states);
        assert_turns_like_a_car(&trajectory);
    }

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
                    let v = (s.speed_mps + a * SIM_DT_S).max(0.0);
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
    fn a_start_already_touching_has_no_witness() {
        let states = vec![vec![None, Some(at(1.0, 0.0, 0.0))]; 11];
        let traffic = FixedTraffic { states: &states, bodies: &[car(), car()], ego: 0, road: None };
        assert_eq!(
            search_witness(&at(0.0, 0.0, 5.0), car(), &traffic, 10, WitnessBudget::default()),
            Witness::NoneWithinBudget { expansions: 0 }
        );
    }
}
