//! How well V_h tells feasible from infeasible ego–CBV states: states are
//! sampled from closed-loop rollouts ([`sample_states`]), each is labelled
//! by the witness search — can the ego, from that state, keep the CBV
//! (replaying its rollout future) beyond d_th within its dynamic limits over
//! the next 4 s? ([`label_state`]) — and sign(V_h) is compared with that
//! label in a [`ConfusionTable`] of "infeasible". [`StateClass`] places
//! each state in the partitions the table is broken down by (box-distance
//! band, the kind of conflict around it, relative heading), and
//! [`tables_by`] counts one table per class, so that a reader sees where
//! V_h's false "infeasible" calls concentrate. [`lfr_panels`] samples V_h
//! over relative CBV positions in the ego frame (the paper's Largest
//! Feasible Region figure).

use std::collections::BTreeMap;
use std::time::Instant;

use super::conflict_kind::{ConflictKind, ConflictParty, LOOKBACK_S, classify_conflict};
use super::witness::{FixedTraffic, WitnessBudget, search_witness};
use crate::geometry::{Point2, Vector2, wrap_angle};
use crate::map::RoadMap;
use crate::models::ModelError;
use crate::models::feasibility::{DISTANCE_THRESHOLD_M, box_distance_m, pair};
use crate::models::feasibility_oracle::{EgoCbvState, FeasibilityOracle};
use crate::scenario::{AgentBody, AgentKind, AgentState, TrackIndex};
use crate::sim::Rollout;

/// Witness horizon from a sampled state, simulator steps (4 s).
pub const WITNESS_HORIZON_STEPS: usize = 40;
/// A state is sampled every this many steps of a rollout.
pub const SAMPLE_EVERY_STEPS: usize = 10;

/// An ego–CBV state sampled from a rollout, with the CBV's future there.
#[derive(Debug, Clone, PartialEq)]
pub struct SampledState {
    /// The rollout step (row of [`Rollout::states`]) the state was taken at.
    pub step: usize,
    /// The state.
    pub pair: EgoCbvState,
    /// The CBV from that step on (`[0]` = at the state), at most
    /// [`WITNESS_HORIZON_STEPS`] + 1 steps; `None` = absent.
    pub cbv_future: Vec<Option<AgentState>>,
}

/// The states of `rollout` every [`SAMPLE_EVERY_STEPS`] steps where both
/// `ego` and `cbv` are present and at least half the witness horizon of
/// the CBV's future is left.
pub fn sample_states(rollout: &Rollout, ego: TrackIndex, cbv: TrackIndex) -> Vec<SampledState> {
    let (Some(&eb), Some(&cb)) = (rollout.bodies.get(ego.0), rollout.bodies.get(cbv.0)) else {
        return Vec::new();
    };
    let agent = |k: usize, i: TrackIndex| rollout.states[k].get(i.0).copied().flatten();
    let n = rollout.states.len();
    (0..n)
        .step_by(SAMPLE_EVERY_STEPS)
        .filter_map(|k| {
            let (es, cs) = (agent(k, ego)?, agent(k, cbv)?);
            let cbv_future: Vec<Option<AgentState>> =
                (k..n).take(WITNESS_HORIZON_STEPS + 1).map(|j| agent(j, cbv)).collect();
            (cbv_future.len() >= WITNESS_HORIZON_STEPS / 2).then(|| SampledState {
                step: k,
                pair: pair(es, eb, cs, cb),
                cbv_future,
            })
        })
        .collect()
}

/// A sampled state with its witness label and V_h.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LabelledState {
    /// V_h of the state (NaN when the model failed on it).
    pub value: f32,
    /// Whether the witness search found an escape (the state is feasible).
    pub witness_found: bool,
    /// Time the witness search took, s.
    pub witness_s: f64,
}

/// Labels `state` by the witness search (margin d_th, the CBV replaying its
/// future) and evaluates V_h on it.
pub fn label_state(value: &dyn FeasibilityOracle, state: &SampledState) -> LabelledState {
    let p = &state.pair;
    let states: Vec<Vec<Option<AgentState>>> = state.cbv_future.iter().map(|c| vec![None, *c]).collect();
    let bodies = [p.ego_body, p.cbv_body];
    let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0, road: None };
    let budget = WitnessBudget { margin_m: DISTANCE_THRESHOLD_M, ..WitnessBudget::default() };
    let t = Instant::now();
    let horizon = states.len().saturating_sub(1);
    let witness_found = search_witness(&p.ego, p.ego_body, &traffic, horizon, budget).is_found();
    let witness_s = t.elapsed().as_secs_f64();
    let v = value.values(std::slice::from_ref(p)).ok().and_then(|v| v.first().copied()).unwrap_or(f32::NAN);
    LabelledState { value: v, witness_found, witness_s }
}

/// sign(V_h) against the witness label, for the class "infeasible"
/// (V_h > 0 predicts it; no witness is the label).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ConfusionTable {
    /// Predicted infeasible, no witness (true positive).
    pub true_infeasible: usize,
    /// Predicted infeasible, witness found (false positive, a false alarm).
    pub false_infeasible: usize,
    /// Predicted feasible, no witness (false negative, a miss).
    pub missed_infeasible: usize,
    /// Predicted feasible, witness found (true negative).
    pub true_feasible: usize,
    /// States whose V_h is not a number (counted in no cell).
    pub unscored: usize,
}

impl ConfusionTable {
    /// The table of `labelled` at the shipped decision rule (V_h > 0 predicts infeasible).
    pub fn of(labelled: &[LabelledState]) -> Self {
        Self::at_threshold(labelled, 0.0)
    }

    /// The table of `labelled` when V_h > `threshold` predicts infeasible:
    /// how a calibrated decision threshold would score.
    pub fn at_threshold(labelled: &[LabelledState], threshold: f32) -> Self {
        let mut t = Self::default();
        for l in labelled {
            t.count(l, threshold);
        }
        t
    }

    /// Counts `l` in its cell when V_h > `threshold` predicts infeasible.
    pub fn count(&mut self, l: &LabelledState, threshold: f32) {
        if l.value.is_nan() {
            self.unscored += 1;
            return;
        }
        match (l.value > threshold, !l.witness_found) {
            (true, true) => self.true_infeasible += 1,
            (true, false) => self.false_infeasible += 1,
            (false, true) => self.missed_infeasible += 1,
            (false, false) => self.true_feasible += 1,
        }
    }

    /// States in the four cells.
    pub fn scored(&self) -> usize {
        self.true_infeasible + self.false_infeasible + self.missed_infeasible + self.true_feasible
    }

    /// States labelled infeasible (no witness).
    pub fn infeasible(&self) -> usize {
        self.true_infeasible + self.missed_infeasible
    }

    /// States labelled feasible (witness found).
    pub fn feasible(&self) -> usize {
        self.false_infeasible + self.true_feasible
    }

    /// Share of predicted-infeasible states that are infeasible (`None` when none is predicted infeasible).
    pub fn precision(&self) -> Option<f64> {
        ratio(self.true_infeasible, self.true_infeasible + self.false_infeasible)
    }

    /// Share of infeasible states predicted infeasible (`None` when none is infeasible).
    pub fn recall(&self) -> Option<f64> {
        ratio(self.true_infeasible, self.infeasible())
    }

    /// Share of scored states predicted right (`None` when none is scored).
    pub fn accuracy(&self) -> Option<f64> {
        ratio(self.true_infeasible + self.true_feasible, self.scored())
    }

    /// Share of the states V_h calls infeasible from which the witness
    /// search finds an escape: the conflicts the constraint holds the CBV
    /// off although the ego could avoid them (1 − precision; `None` when
    /// none is predicted infeasible).
    pub fn escaped_share(&self) -> Option<f64> {
        ratio(self.false_infeasible, self.true_infeasible + self.false_infeasible)
    }
}

impl std::ops::AddAssign for ConfusionTable {
    fn add_assign(&mut self, o: Self) {
        self.true_infeasible += o.true_infeasible;
        self.false_infeasible += o.false_infeasible;
        self.missed_infeasible += o.missed_infeasible;
        self.true_feasible += o.true_feasible;
        self.unscored += o.unscored;
    }
}

impl std::iter::Sum for ConfusionTable {
    fn sum<I: Iterator<Item = Self>>(iter: I) -> Self {
        let mut total = Self::default();
        for t in iter {
            total += t;
        }
        total
    }
}

/// One table per class of a partition at the shipped decision rule (V_h > 0
/// predicts infeasible): each labelled state is counted under its class, so
/// the tables add up to [`ConfusionTable::of`] the whole set. Classes no
/// state falls in have no entry.
pub fn tables_by<K: Ord>(states: impl IntoIterator<Item = (K, LabelledState)>) -> BTreeMap<K, ConfusionTable> {
    let mut tables: BTreeMap<K, ConfusionTable> = BTreeMap::new();
    for (class, l) in states {
        tables.entry(class).or_default().count(&l, 0.0);
    }
    tables
}

/// The box-distance bands the accuracy is broken down by: the closer the
/// pair, the more a false "infeasible" call costs the adversary (it holds
/// the CBV off exactly where a conflict would be made).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum DistanceBand {
    /// Under 0.5 m (overlapping boxes included).
    UnderHalfMetre,
    /// 0.5 m up to 1 m.
    HalfToOneMetre,
    /// 1 m up to 3 m.
    OneToThreeMetres,
    /// 3 m or more.
    ThreeMetresOrMore,
}

impl DistanceBand {
    /// Every band, nearest first.
    pub const ALL: [Self; 4] =
        [Self::UnderHalfMetre, Self::HalfToOneMetre, Self::OneToThreeMetres, Self::ThreeMetresOrMore];

    /// The band of a box distance, m (a distance that is not a number counts as far).
    pub fn of(distance_m: f64) -> Self {
        Self::ALL.into_iter().find(|b| distance_m < b.range_m().1).unwrap_or(Self::ThreeMetresOrMore)
    }

    /// Its bounds, m: from the first (inclusive) up to the second (exclusive).
    pub fn range_m(self) -> (f64, f64) {
        match self {
            Self::UnderHalfMetre => (f64::NEG_INFINITY, 0.5),
            Self::HalfToOneMetre => (0.5, 1.0),
            Self::OneToThreeMetres => (1.0, 3.0),
            Self::ThreeMetresOrMore => (3.0, f64::INFINITY),
        }
    }

    /// Its name in tables (`< 0.5 m`, `0.5–1 m`, `1–3 m`, `≥ 3 m`).
    pub fn label(self) -> &'static str {
        match self {
            Self::UnderHalfMetre => "< 0.5 m",
            Self::HalfToOneMetre => "0.5–1 m",
            Self::OneToThreeMetres => "1–3 m",
            Self::ThreeMetresOrMore => "≥ 3 m",
        }
    }
}

/// Below this angle between the two headings the pair drives the same
/// direction, degrees (the conflict kinds' rule).
pub const SAME_DIRECTION_MAX_DEG: f64 = 45.0;
/// From this angle between the two headings on the pair drives opposite ways, degrees.
pub const OPPOSITE_MIN_DEG: f64 = 135.0;

/// How the CBV's heading lies to the ego's at a state: the classes of a
/// state whose neighbourhood holds no conflict to name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum RelativeHeading {
    /// Less than [`SAME_DIRECTION_MAX_DEG`] apart.
    SameDirection,
    /// Between the two.
    Crossing,
    /// [`OPPOSITE_MIN_DEG`] or more apart.
    Opposite,
}

impl RelativeHeading {
    /// Every class, in table order.
    pub const ALL: [Self; 3] = [Self::SameDirection, Self::Crossing, Self::Opposite];

    /// The class of two headings, rad.
    pub fn of(ego_heading_rad: f64, cbv_heading_rad: f64) -> Self {
        let apart = wrap_angle(cbv_heading_rad - ego_heading_rad).abs().to_degrees();
        if apart < SAME_DIRECTION_MAX_DEG {
            Self::SameDirection
        } else if apart < OPPOSITE_MIN_DEG {
            Self::Crossing
        } else {
            Self::Opposite
        }
    }

    /// Its name in tables and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::SameDirection => "same-direction",
            Self::Crossing => "crossing",
            Self::Opposite => "opposite",
        }
    }
}

/// Where a sampled state sits in the partitions its accuracy is broken
/// down by.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateClass {
    /// The pair's box distance at the state, m.
    pub box_distance_m: f64,
    /// Its band.
    pub band: DistanceBand,
    /// The kind of conflict the pair makes around the state (see
    /// [`neighbourhood_conflict`]); `None`: their boxes stay more than
    /// [`super::conflict_kind::NEAR_MISS_M`] apart there.
    pub conflict: Option<ConflictKind>,
    /// The relative heading at the state.
    pub heading: RelativeHeading,
}

impl StateClass {
    /// The class of `state`, sampled from `rollout` (on `map`) with `ego`
    /// and `cbv` as [`sample_states`] was given them.
    pub fn of(map: &RoadMap, rollout: &Rollout, ego: TrackIndex, cbv: TrackIndex, state: &SampledState) -> Self {
        let box_distance_m = box_distance_m(&state.pair);
        StateClass {
            box_distance_m,
            band: DistanceBand::of(box_distance_m),
            conflict: neighbourhood_conflict(map, rollout, ego, cbv, state.step),
            heading: RelativeHeading::of(state.pair.ego.heading_rad, state.pair.cbv.heading_rad),
        }
    }
}

/// The kind of conflict ([`classify_conflict`]) that `ego` and `cbv` make
/// in `rollout` around `step`: from [`LOOKBACK_S`] before it (the look-back
/// the kinds are judged with) to the witness horizon after it (what the
/// witness search judges), as the rollout drove them.
pub fn neighbourhood_conflict(
    map: &RoadMap,
    rollout: &Rollout,
    ego: TrackIndex,
    cbv: TrackIndex,
    step: usize,
) -> Option<ConflictKind> {
    let lookback = (LOOKBACK_S / rollout.dt_s).round() as usize;
    let rows = rollout.states.get(
        step.saturating_sub(lookback)..=(step + WITNESS_HORIZON_STEPS).min(rollout.states.len().checked_sub(1)?),
    )?;
    let column = |agent: TrackIndex| -> Vec<Option<AgentState>> {
        rows.iter().map(|row| row.get(agent.0).copied().flatten()).collect()
    };
    let (ego_states, cbv_states) = (column(ego), column(cbv));
    classify_conflict(
        map,
        ConflictParty { body: *rollout.bodies.get(ego.0)?, states: &ego_states },
        ConflictParty { body: *rollout.bodies.get(cbv.0)?, states: &cbv_states },
        rollout.dt_s,
    )
}

/// The threshold with the best precision among those whose recall of
/// "infeasible" is at least `min_recall`, tried at every distinct V_h of
/// `labelled` (and 0), with its table; `None` when no state is infeasible.
pub fn best_threshold_at_recall(labelled: &[LabelledState], min_recall: f64) -> Option<(f32, ConfusionTable)> {
    let mut thresholds: Vec<f32> = labelled.iter().map(|l| l.value).filter(|v| !v.is_nan()).collect();
    // A state is predicted infeasible when V_h > threshold: try just below each value.
    thresholds.iter_mut().for_each(|v| *v -= 1e-5 * v.abs().max(1.0));
    thresholds.push(0.0);
    thresholds.sort_by(f32::total_cmp);
    thresholds.dedup();
    let mut best: Option<(f32, ConfusionTable)> = None;
    for t in thresholds {
        let table = ConfusionTable::at_threshold(labelled, t);
        if table.recall().is_none_or(|r| r < min_recall) {
            continue;
        }
        let p = table.precision().unwrap_or(0.0);
        if best.as_ref().is_none_or(|(_, b)| p > b.precision().unwrap_or(0.0)) {
            best = Some((t, table));
        }
    }
    best
}

fn ratio(numerator: usize, denominator: usize) -> Option<f64> {
    (denominator > 0).then(|| numerator as f64 / denominator as f64)
}

/// The grid of an LFR panel: CBV centres in the ego frame (ego at the
/// origin heading +x), cell centres from the top-left, row by row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LfrGrid {
    /// Extent along the ego's heading, m.
    pub x_range_m: (f64, f64),
    /// Extent to its left, m.
    pub y_range_m: (f64, f64),
    /// Cell size, m.
    pub cell_m: f64,
}

impl LfrGrid {
    /// The grid of the shipped figure: x −15..35 m, y −12..12 m, 1 m cells.
    pub const FIGURE: Self = Self { x_range_m: (-15.0, 35.0), y_range_m: (-12.0, 12.0), cell_m: 1.0 };

    /// Cells along x and along y.
    pub fn cells(&self) -> (usize, usize) {
        let n = |r: (f64, f64)| ((r.1 - r.0) / self.cell_m).max(0.0) as usize;
        (n(self.x_range_m), n(self.y_range_m))
    }

    /// Centre of cell (`i` along x, `j` down from the top), m.
    pub fn centre(&self, i: usize, j: usize) -> Point2 {
        Point2::new(
            self.x_range_m.0 + (i as f64 + 0.5) * self.cell_m,
            self.y_range_m.1 - (j as f64 + 0.5) * self.cell_m,
        )
    }
}

/// V_h over one LFR panel.
#[derive(Debug, Clone, PartialEq)]
pub struct LfrPanel {
    /// Ego and CBV speed, m/s.
    pub speed_mps: f64,
    /// CBV heading in the ego frame, rad.
    pub cbv_heading_rad: f64,
    /// What the heading means (e.g. "same heading").
    pub label: &'static str,
    /// The grid.
    pub grid: LfrGrid,
    /// V_h per cell, row by row from the top-left.
    pub values: Vec<f32>,
    /// Whether the CBV's box touches the ego's in that cell.
    pub overlapping: Vec<bool>,
}

impl LfrPanel {
    /// Share of cells where V_h > 0 (`None` of an empty grid).
    pub fn infeasible_share(&self) -> Option<f64> {
        ratio(self.values.iter().filter(|v| **v > 0.0).count(), self.values.len())
    }
}

/// The car both agents are in the LFR figure, m.
pub const LFR_CAR: AgentBody = AgentBody { kind: AgentKind::Vehicle, length_m: 4.6, width_m: 1.9 };
/// The figure's speeds (rows), m/s.
pub const LFR_SPEEDS_MPS: [f64; 3] = [5.0, 10.0, 15.0];
/// The figure's CBV headings (columns), rad, with their labels.
pub const LFR_HEADINGS: [(f64, &str); 2] =
    [(0.0, "same heading"), (std::f64::consts::FRAC_PI_2, "crossing from the right")];

/// V_h over `grid` for every speed of [`LFR_SPEEDS_MPS`] × heading of
/// [`LFR_HEADINGS`] (row by row): ego and CBV the same car ([`LFR_CAR`]) at
/// the same speed.
pub fn lfr_panels(value: &dyn FeasibilityOracle, grid: LfrGrid) -> Result<Vec<LfrPanel>, ModelError> {
    let (nx, ny) = grid.cells();
    let mut panels = Vec::new();
    for &speed in &LFR_SPEEDS_MPS {
        for &(heading, label) in &LFR_HEADINGS {
            let ego =
                AgentState { position: Point2::origin(), heading_rad: 0.0, velocity_mps: Vector2::new(speed, 0.0) };
            let pairs: Vec<EgoCbvState> = (0..ny)
                .flat_map(|j| (0..nx).map(move |i| (i, j)))
                .map(|(i, j)| {
                    let cbv = AgentState {
                        position: grid.centre(i, j),
                        heading_rad: heading,
                        velocity_mps: Vector2::new(heading.cos(), heading.sin()) * speed,
                    };
                    pair(ego, LFR_CAR, cbv, LFR_CAR)
                })
                .collect();
            let values = value.values(&pairs)?;
            let overlapping = pairs.iter().map(|p| box_distance_m(p) <= 0.0).collect();
            panels.push(LfrPanel { speed_mps: speed, cbv_heading_rad: heading, label, grid, values, overlapping });
        }
    }
    Ok(panels)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::AgentId;
    use crate::sim::Termination;

    fn labelled(value: f32, witness_found: bool) -> LabelledState {
        LabelledState { value, witness_found, witness_s: 0.0 }
    }

    #[test]
    fn the_calibrated_threshold_keeps_the_recall_and_maximises_precision() {
        // Infeasible states at V_h 3, 2, 1 and -1; feasible ones at 2.5, 0.5, 0.2, -2.
        let mut l: Vec<LabelledState> = [3.0, 2.0, 1.0, -1.0].iter().map(|&v| labelled(v, false)).collect();
        l.extend([2.5, 0.5, 0.2, -2.0].iter().map(|&v| labelled(v, true)));
        // Recall ≥ 0.75 needs the threshold below 1: the best keeps 3 true, 1 false alarm (2.5).
        let (t, table) = best_threshold_at_recall(&l, 0.75).unwrap();
        assert!((0.5..1.0).contains(&t), "{t}");
        assert_eq!((table.true_infeasible, table.false_infeasible), (3, 1));
        // Recall 1 needs every infeasible state flagged, so a threshold below -1.
        let (t, table) = best_threshold_at_recall(&l, 1.0).unwrap();
        assert!((-2.0..-1.0).contains(&t), "{t}");
        assert_eq!(table.recall(), Some(1.0));
        assert_eq!(table.false_infeasible, 3);
        assert!(best_threshold_at_recall(&[labelled(1.0, true)], 0.9).is_none());
    }

    #[test]
    fn the_confusion_table_counts_each_cell() {
        // 3 true alarms, 1 false alarm, 2 misses, 4 correct "feasible", 1 unscored.
        let mut l = vec![labelled(2.0, false); 3];
        l.push(labelled(1.0, true));
        l.extend([labelled(-1.0, false), labelled(0.0, false)]);
        l.extend(vec![labelled(-0.5, true); 4]);
        l.push(labelled(f32::NAN, false));
        let t = ConfusionTable::of(&l);
        assert_eq!(
            t,
            ConfusionTable {
                true_infeasible: 3,
                false_infeasible: 1,
                missed_infeasible: 2,
                true_feasible: 4,
                unscored: 1
            }
        );
        assert_eq!((t.scored(), t.infeasible(), t.feasible()), (10, 5, 5));
        assert_eq!(t.precision(), Some(0.75));
        assert_eq!(t.recall(), Some(0.6));
        assert_eq!(t.accuracy(), Some(0.7));
    }

    #[test]
    fn rates_without_a_denominator_are_none_not_zero_or_one() {
        // Nothing predicted infeasible and nothing infeasible: no precision, no recall.
        let t = ConfusionTable::of(&[labelled(-1.0, true), labelled(-2.0, true)]);
        assert_eq!(t.precision(), None);
        assert_eq!(t.recall(), None);
        assert_eq!(t.accuracy(), Some(1.0));
        // Only infeasible states, all missed: recall 0, precision undefined.
        let t = ConfusionTable::of(&[labelled(-1.0, false)]);
        assert_eq!((t.precision(), t.recall()), (None, Some(0.0)));
        // Nothing scored at all.
        let t = ConfusionTable::of(&[labelled(f32::NAN, true)]);
        assert_eq!((t.precision(), t.recall(), t.accuracy()), (None, None, None));
        assert_eq!(t.unscored, 1);
    }

    /// V_h = 1 within 3 m box distance, else −1.
    struct NearIsInfeasible;
    impl FeasibilityOracle for NearIsInfeasible {
        fn values(&self, pairs: &[EgoCbvState]) -> Result<Vec<f32>, ModelError> {
            Ok(pairs.iter().map(|p| if box_distance_m(p) < 3.0 { 1.0 } else { -1.0 }).collect())
        }
    }

    #[test]
    fn lfr_panels_cover_the_grid_in_figure_order() {
        let grid = LfrGrid { x_range_m: (-10.0, 10.0), y_range_m: (-5.0, 5.0), cell_m: 1.0 };
        assert_eq!(grid.cells(), (20, 10));
        assert_eq!(grid.centre(0, 0), Point2::new(-9.5, 4.5));
        let panels = lfr_panels(&NearIsInfeasible, grid).unwrap();
        assert_eq!(panels.len(), LFR_SPEEDS_MPS.len() * LFR_HEADINGS.len());
        assert_eq!((panels[1].speed_mps, panels[1].label), (5.0, "crossing from the right"));
        for p in &panels {
            assert_eq!((p.values.len(), p.overlapping.len()), (200, 200));
            // The cell at the ego's centre overlaps and is infeasible; a far corner is neither.
            let centre = 5 * 20 + 10;
            assert!(p.overlapping[centre] && p.values[centre] > 0.0);
            assert!(!p.overlapping[0] && p.values[0] < 0.0);
            let infeasible = p.values.iter().filter(|v| **v > 0.0).count();
            assert!(infeasible > 0 && infeasible < 200);
            assert_eq!(p.infeasible_share(), Some(infeasible as f64 / 200.0));
        }
    }

    #[test]
    fn distance_bands_take_their_lower_bound_and_leave_out_their_upper() {
        use DistanceBand::*;
        let cases = [
            (-0.3, UnderHalfMetre),
            (0.0, UnderHalfMetre),
            (0.499, UnderHalfMetre),
            (0.5, HalfToOneMetre),
            (0.999, HalfToOneMetre),
            (1.0, OneToThreeMetres),
            (2.999, OneToThreeMetres),
            (3.0, ThreeMetresOrMore),
            (250.0, ThreeMetresOrMore),
            (f64::NAN, ThreeMetresOrMore),
        ];
        for (d, band) in cases {
            assert_eq!(DistanceBand::of(d), band, "{d} m");
        }
        // The bands tile the line: each starts where the one before ends.
        for w in DistanceBand::ALL.windows(2) {
            assert_eq!(w[0].range_m().1, w[1].range_m().0);
        }
    }

    #[test]
    fn relative_heading_classes_split_at_45_and_135_degrees() {
        let deg = |d: f64| d.to_radians();
        assert_eq!(RelativeHeading::of(deg(10.0), deg(50.0)), RelativeHeading::SameDirection);
        assert_eq!(RelativeHeading::of(deg(10.0), deg(55.0)), RelativeHeading::Crossing);
        assert_eq!(RelativeHeading::of(deg(0.0), deg(-90.0)), RelativeHeading::Crossing);
        assert_eq!(RelativeHeading::of(deg(0.0), deg(135.0)), RelativeHeading::Opposite);
        // Across ±180°: 170° and −170° are 20° apart.
        assert_eq!(RelativeHeading::of(deg(170.0), deg(-170.0)), RelativeHeading::SameDirection);
    }

    #[test]
    fn per_band_tables_count_each_cell_and_add_up_to_the_whole() {
        use DistanceBand::*;
        // (box distance m, V_h, witness found)
        let states = [
            (-0.1, 2.0, false), // < 0.5: true infeasible
            (0.2, 1.0, true),   // < 0.5: false infeasible
            (0.4, 3.0, true),   // < 0.5: false infeasible
            (0.7, 0.5, true),   // 0.5–1: false infeasible
            (0.9, -1.0, false), // 0.5–1: missed
            (1.0, 1.0, false),  // 1–3: true infeasible
            (2.0, -2.0, true),  // 1–3: true feasible
            (2.5, f32::NAN, true),
            (3.0, -5.0, true),  // ≥ 3: true feasible
            (12.0, -4.0, true), // ≥ 3: true feasible
        ];
        let banded: Vec<(DistanceBand, LabelledState)> =
            states.iter().map(|&(d, v, found)| (DistanceBand::of(d), labelled(v, found))).collect();
        let tables = tables_by(banded.iter().copied());
        let cells = |b: DistanceBand| {
            let t = tables[&b];
            (t.true_infeasible, t.false_infeasible, t.missed_infeasible, t.true_feasible, t.unscored)
        };
        assert_eq!(cells(UnderHalfMetre), (1, 2, 0, 0, 0));
        assert_eq!(cells(HalfToOneMetre), (0, 1, 1, 0, 0));
        assert_eq!(cells(OneToThreeMetres), (1, 0, 0, 1, 1));
        assert_eq!(cells(ThreeMetresOrMore), (0, 0, 0, 2, 0));
        let near = tables[&UnderHalfMetre];
        assert_eq!((near.precision(), near.recall()), (Some(1.0 / 3.0), Some(1.0)));
        assert_eq!(near.escaped_share(), Some(2.0 / 3.0));
        assert_eq!(tables[&HalfToOneMetre].recall(), Some(0.0));
        assert_eq!(tables[&ThreeMetresOrMore].escaped_share(), None);
        let whole = ConfusionTable::of(&banded.iter().map(|(_, l)| *l).collect::<Vec<_>>());
        assert_eq!(tables.values().copied().sum::<ConfusionTable>(), whole);
        assert_eq!(whole.escaped_share(), Some(3.0 / 5.0));
        // A class no state falls in has no entry.
        let only_near = tables_by([(UnderHalfMetre, labelled(1.0, false))]);
        assert_eq!(only_near.keys().copied().collect::<Vec<_>>(), vec![UnderHalfMetre]);
    }

    fn two_lane_rollout(states: Vec<Vec<Option<AgentState>>>) -> Rollout {
        let n = states.first().map_or(0, Vec::len);
        Rollout {
            scenario_id: "cars".into(),
            dt_s: 0.1,
            start_step: 0,
            ego: TrackIndex(0),
            cbv: Some(TrackIndex(1)),
            agent_ids: (0..n).map(|i| AgentId(format!("car-{i}"))).collect(),
            bodies: vec![LFR_CAR; n],
            states,
            collisions: Vec::new(),
            off_road: Vec::new(),
            min_distance_to_ego: None,
            termination: Termination::Completed,
            planner: "test".into(),
            planner_debug: Vec::new(),
        }
    }

    #[test]
    fn a_state_is_classed_by_its_band_heading_and_the_conflict_around_it() {
        let car = |x: f64, y: f64, heading: f64, speed: f64| {
            Some(AgentState {
                position: Point2::new(x, y),
                heading_rad: heading,
                velocity_mps: Vector2::new(heading.cos(), heading.sin()) * speed,
            })
        };
        // The ego at 5 m/s; a car closing on it from 20 m behind at 10 m/s
        // (boxes touch at step 31); one 10 m to its left; one coming the other way 10 m to the right.
        let states: Vec<Vec<Option<AgentState>>> = (0..60)
            .map(|k| {
                let t = k as f64 * 0.1;
                vec![
                    car(5.0 * t, 0.0, 0.0, 5.0),
                    car(-20.0 + 10.0 * t, 0.0, 0.0, 10.0),
                    car(5.0 * t, 10.0, 0.0, 5.0),
                    car(40.0 - 5.0 * t, -10.0, std::f64::consts::PI, 5.0),
                ]
            })
            .collect();
        let rollout = two_lane_rollout(states);
        let map = RoadMap::default();
        let (ego, behind) = (TrackIndex(0), TrackIndex(1));
        let sampled = sample_states(&rollout, ego, behind);
        assert_eq!(sampled.iter().map(|s| s.step).collect::<Vec<_>>(), vec![0, 10, 20, 30, 40]);
        let classes: Vec<StateClass> = sampled.iter().map(|s| StateClass::of(&map, &rollout, ego, behind, s)).collect();
        // 15.4 m apart at the start, 0.4 m at step 30, overlapping at 40.
        assert!((classes[0].box_distance_m - 15.4).abs() < 1e-4, "{}", classes[0].box_distance_m);
        let bands: Vec<DistanceBand> = classes.iter().map(|c| c.band).collect();
        use DistanceBand::*;
        assert_eq!(
            bands,
            vec![ThreeMetresOrMore, ThreeMetresOrMore, ThreeMetresOrMore, UnderHalfMetre, UnderHalfMetre]
        );
        // The contact at step 31 lies within 4 s after every state and 3 s before the last.
        assert!(classes.iter().all(|c| c.conflict == Some(ConflictKind::RearEnd)), "{classes:?}");
        assert!(classes.iter().all(|c| c.heading == RelativeHeading::SameDirection));
        // The car beside never comes within 1 m: no conflict, the same direction.
        let beside = sample_states(&rollout, ego, TrackIndex(2));
        let c = StateClass::of(&map, &rollout, ego, TrackIndex(2), &beside[0]);
        assert_eq!((c.conflict, c.heading, c.band), (None, RelativeHeading::SameDirection, ThreeMetresOrMore));
        let oncoming = sample_states(&rollout, ego, TrackIndex(3));
        let c = StateClass::of(&map, &rollout, ego, TrackIndex(3), &oncoming[0]);
        assert_eq!((c.conflict, c.heading), (None, RelativeHeading::Opposite));
    }

    #[test]
    fn a_conflict_beyond_the_witness_horizon_is_not_the_states() {
        let car = |x: f64| {
            Some(AgentState { position: Point2::new(x, 0.0), heading_rad: 0.0, velocity_mps: Vector2::new(10.0, 0.0) })
        };
        // The CBV stands 4.6 m (touching) ahead of where the ego is at step 60; the ego drives at 10 m/s from 0.
        let states: Vec<Vec<Option<AgentState>>> = (0..70)
            .map(|k| vec![car(k as f64), Some(AgentState { velocity_mps: Vector2::zeros(), ..car(64.6).unwrap() })])
            .collect();
        let rollout = two_lane_rollout(states);
        let map = RoadMap::default();
        // From step 0 the contact (step 60) is 6 s away: beyond the 4 s horizon.
        assert_eq!(neighbourhood_conflict(&map, &rollout, TrackIndex(0), TrackIndex(1), 0), None);
        assert_eq!(
            neighbourhood_conflict(&map, &rollout, TrackIndex(0), TrackIndex(1), 20),
            Some(ConflictKind::RearEnd)
        );
        // 3 s after it, the look-back still reaches it; at the last row nothing is out of range.
        assert_eq!(
            neighbourhood_conflict(&map, &rollout, TrackIndex(0), TrackIndex(1), 69),
            Some(ConflictKind::RearEnd)
        );
    }

    #[test]
    fn states_are_sampled_where_both_agents_are_present() {
        let body = LFR_CAR;
        let at = |x: f64| AgentState {
            position: Point2::new(x, 0.0),
            heading_rad: 0.0,
            velocity_mps: Vector2::new(10.0, 0.0),
        };
        let states: Vec<Vec<Option<AgentState>>> =
            (0..45).map(|k| vec![Some(at(k as f64)), if k == 10 { None } else { Some(at(k as f64 + 20.0)) }]).collect();
        let rollout = Rollout {
            scenario_id: "two-cars".into(),
            dt_s: 0.1,
            start_step: 0,
            ego: TrackIndex(0),
            cbv: Some(TrackIndex(1)),
            agent_ids: vec![AgentId("ego".into()), AgentId("cbv".into())],
            bodies: vec![body, body],
            states,
            collisions: Vec::new(),
            off_road: Vec::new(),
            min_distance_to_ego: None,
            termination: Termination::Completed,
            planner: "test".into(),
            planner_debug: Vec::new(),
        };
        let sampled = sample_states(&rollout, TrackIndex(0), TrackIndex(1));
        // Step 10 lacks the CBV; step 40 has 5 steps of future, under half the horizon.
        assert_eq!(sampled.len(), 2);
        assert_eq!(sampled[0].cbv_future.len(), WITNESS_HORIZON_STEPS + 1);
        assert_eq!(sampled[1].pair.ego.position, Point2::new(20.0, 0.0));
        assert_eq!(sampled[1].cbv_future.len(), 25);
    }
}
