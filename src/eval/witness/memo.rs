//! What the search remembers so as not to work the same thing out twice:
//! clearance queries by exact ego pose and step ([`ClearanceMemo`]), the
//! headings each yaw rate turns to from a start heading ([`TurnsMemo`]),
//! and the word hasher ([`PoseHasher`]) their tables, the road cells and
//! the sibling check key by.

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use super::actions::YAW_RATES_RADPS;
use crate::geometry::{BoxSet, OrientedBox, Pose2};
use crate::motion::KinematicState;
use crate::motion::kinematics::turned_heading_rad;
use crate::motion::tokens::{MAX_YAW_RATE_RADPS, SIM_DT_S, TOKEN_PERIOD_STEPS};
use crate::scenario::AgentBody;

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
pub(super) struct PoseHasher(u64);

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
pub(super) struct ClearanceMemo {
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
    pub(super) fn clearance_below(
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
pub(super) type Turns = [[(f64, (f64, f64)); TOKEN_PERIOD_STEPS]; YAW_RATES_RADPS.len()];

/// [`Turns`] by start heading (its bits), remembered over a search. A
/// child's headings depend on its parent's heading and its yaw rate only,
/// not on its acceleration or position, and many candidates in a beam share
/// a heading (they differ in speed only): sines and cosines were most of
/// the search's time.
#[derive(Default)]
pub(super) struct TurnsMemo {
    known: HashMap<u64, Box<Turns>, BuildHasherDefault<PoseHasher>>,
}

impl TurnsMemo {
    pub(super) fn from(&mut self, heading_rad: f64) -> &Turns {
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
