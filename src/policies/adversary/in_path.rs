//! The in-path objectives of `safer-in-path` and `safer-cut-in` (beyond
//! the paper): a candidate scores how close it puts the CBV to the ego's
//! path *ahead* of the ego, not to the ego's body.
//!
//! The paper's loss, the box distance to where the ego will be one token
//! later, is met as well by a CBV closing from behind or from the side as
//! by one in front, and a planner escapes the first two by speeding up or
//! keeping its lane: a planner that never brakes passes them. The
//! conflicts that test a planner
//! put the CBV in its path: a cut-in, a merge, a turn across, a car ahead
//! braking. So the in-path loss is the least, over lead times of 0 to
//! [`IN_PATH_MAX_LEAD_S`], of the box distance to the ego's
//! constant-velocity footprint that far ahead plus
//! [`IN_PATH_LEAD_COST_M_PER_S`] per second of lead: a CBV reaching the
//! ego's path 1 s ahead of it scores about 1 m, and it lowers its score by
//! letting the ego close in (braking ahead of it).
//!
//! Where the footprint meets the CBV, the lead is the exact time of first
//! contact, not the first lead step in contact. With the lead in steps
//! alone the loss is a staircase: every candidate that the footprint
//! meets within the same step scores that step's lead, and the tie goes
//! to the prior's likeliest token, holding speed. A leader with the ego
//! closing from behind then cruised until the ego was within a step of
//! it, and a planner that drives too fast met no braking at all. A CBV whose centre is
//! not ahead of the ego's front bumper pays [`NOT_AHEAD_PENALTY_M`], so
//! that beside the ego it prefers getting ahead and in over swiping its
//! side; from behind, with every candidate paying it, the order is the
//! paper's. The feasibility constraint and the plausibility rule are the
//! one-step choice's.
//!
//! The cut-in loss of `safer-cut-in` (beyond the paper) finishes what the
//! in-path loss starts. The box distance stops falling once a corner of
//! the CBV reaches the ego's path, so the in-path loss can leave a CBV
//! from the next lane with its corner over the lane line and its body
//! beside the ego's lane: a cut-in threatened, not made, which a planner
//! answers by keeping its lane. The cut-in loss adds, for a CBV ahead of the ego,
//! [`CUT_IN_LATERAL_COST`] per metre its centre lies to the side of the
//! ego's heading line, so it keeps coming over until it is in the ego's
//! path; and it grades the not-ahead penalty by how far the CBV's centre
//! is short of the ego's front bumper, [`CUT_IN_NOT_AHEAD_COST`] per
//! metre up to [`NOT_AHEAD_PENALTY_M`], so that a CBV beside the ego
//! gains by drawing ahead of it (where a flat penalty leaves it hugging
//! the ego's side, the one move that lowers the box distance).

use crate::geometry::{Point2, SweptSeparation, Vector2};
use crate::scenario::{AgentBody, AgentState};

/// The farthest lead time the in-path loss looks at, s.
pub const IN_PATH_MAX_LEAD_S: f64 = 1.5;

/// What a second of lead adds to the in-path loss, m: of two equally close
/// approaches to the ego's path, the one it reaches sooner wins.
pub const IN_PATH_LEAD_COST_M_PER_S: f64 = 1.0;

/// The lead step of the in-path loss, s (the simulation step): fine
/// enough that a CBV crossing the ego's path is not stepped over.
pub const IN_PATH_LEAD_STEP_S: f64 = 0.1;

/// How many lead steps the in-path loss looks ahead.
const LEAD_STEPS: usize = (IN_PATH_MAX_LEAD_S / IN_PATH_LEAD_STEP_S + 0.5) as usize;

/// Halvings of a lead step that place the first contact (0.1 s / 2¹⁰:
/// about 0.1 ms, a centimetre at freeway speed).
const CONTACT_BISECTIONS: usize = 10;

/// What a CBV whose centre is not ahead of the ego's front bumper adds to
/// the in-path loss, m.
pub const NOT_AHEAD_PENALTY_M: f64 = 5.0;

/// What a metre of the CBV's centre to the side of the ego's heading line
/// adds to the cut-in loss when the CBV is ahead of the ego, m per m.
pub const CUT_IN_LATERAL_COST: f64 = 0.5;

/// What a metre of the CBV's centre short of the ego's front bumper adds
/// to the cut-in loss, m per m, up to [`NOT_AHEAD_PENALTY_M`].
pub const CUT_IN_NOT_AHEAD_COST: f64 = 2.0;

/// Where the CBV stands against the ego's path ahead.
struct PathApproach {
    /// The least, over lead times, of the box distance to the ego's
    /// constant-velocity footprint plus the lead cost, m.
    closest_m: f64,
    /// How far the CBV's centre is short of the ego's front bumper along
    /// the ego's heading, m (negative: ahead of it).
    short_of_front_m: f64,
    /// How far the CBV's centre is to the side of the ego's heading line, m.
    lateral_m: f64,
}

impl PathApproach {
    /// Where the CBV at `cbv` stands against the ego's path ahead of
    /// `ego_next`. `settled` says of an approach (this one with another
    /// `closest_m`) whether it comes to the same for the caller as every
    /// approach farther off (it must be monotone in `closest_m`: once true,
    /// true for every larger value). Then `closest_m` is exact wherever
    /// `settled` is false of the exact approach, and otherwise settled and
    /// no less than the exact. `|_| false` asks for it exactly.
    fn of(
        ego_next: &AgentState,
        ego_body: AgentBody,
        cbv: &AgentState,
        cbv_body: AgentBody,
        settled: impl Fn(&PathApproach) -> bool,
    ) -> Self {
        let ego_sin_cos = ego_next.heading_rad.sin_cos();
        let placed = Self::placed(ego_next, ego_body, cbv, ego_sin_cos);
        let cbv_box = cbv_body.footprint(cbv);
        let ego_then = |lead_s: f64| {
            ego_body
                .footprint(&AgentState { position: ego_next.position + ego_next.velocity_mps * lead_s, ..*ego_next })
        };
        let gap_m = |lead_s: f64| ego_then(lead_s).distance_with_sin_cos(&cbv_box, ego_sin_cos);
        let sweep = path_sweep((ego_next, ego_sin_cos), ego_body, (cbv, cbv.heading_rad.sin_cos()), cbv_body);
        let lower_bound_m = |lead_s: f64| sweep.lower_bound_m(lead_s);
        let closest_m = closest_approach_m(lower_bound_m, &gap_m, |closest_m| settled(&Self { closest_m, ..placed }));
        Self { closest_m, ..placed }
    }

    /// [`Self::of`] with a lower bound of `closest_m` in its place, from
    /// the separating axes of `sweep` (see [`path_sweep`]) alone.
    fn lower_bound(
        ego_next: &AgentState,
        ego_body: AgentBody,
        ego_sin_cos: (f64, f64),
        cbv: &AgentState,
        sweep: &SweptSeparation,
    ) -> Self {
        let placed = Self::placed(ego_next, ego_body, cbv, ego_sin_cos);
        Self { closest_m: closest_lower_bound_m(|lead_s| sweep.lower_bound_m(lead_s)), ..placed }
    }

    /// Where the CBV's centre is against the ego's front bumper and
    /// heading line (`closest_m` still to be worked out: infinite).
    fn placed(ego_next: &AgentState, ego_body: AgentBody, cbv: &AgentState, (sin, cos): (f64, f64)) -> Self {
        let offset = cbv.position - ego_next.position;
        let ahead_m = offset.dot(&Vector2::new(cos, sin));
        let lateral_m = offset.dot(&Vector2::new(-sin, cos)).abs();
        Self { closest_m: f64::INFINITY, short_of_front_m: 0.5 * ego_body.length_m - ahead_m, lateral_m }
    }

    fn ahead(&self) -> bool {
        self.short_of_front_m < 0.0
    }

    /// The in-path loss (see the module).
    fn in_path_loss(&self) -> f64 {
        if self.ahead() { self.closest_m } else { self.closest_m + NOT_AHEAD_PENALTY_M }
    }

    /// The cut-in loss (see the module).
    fn cut_in_loss(&self) -> f64 {
        if self.ahead() {
            self.closest_m + CUT_IN_LATERAL_COST * self.lateral_m
        } else {
            self.closest_m + (CUT_IN_NOT_AHEAD_COST * self.short_of_front_m).min(NOT_AHEAD_PENALTY_M)
        }
    }
}

/// The least, over the lead steps, of the gap plus the lead cost, up to
/// the first contact (see the module): `gap_m(lead_s)` the box distance
/// that far ahead, `lower_bound_m(lead_s)` a lower bound of it (NaN:
/// none), `settled` as in [`PathApproach::of`].
///
/// The same value, bit for bit, as taking every lead step's exact gap in
/// turn: a minimum does not depend on the order it is taken in, and a lead
/// step is skipped only where its bound shows it cannot lower the least
/// so far (rounding is monotone, so neither can the exact sum) or can only
/// give a settled value. Most candidates lie well off the ego's path,
/// where the bound is the gap (an edge facing a side) and one or two exact
/// queries of the sixteen decide.
fn closest_approach_m(
    lower_bound_m: impl Fn(f64) -> f64,
    gap_m: &impl Fn(f64) -> f64,
    settled: impl Fn(f64) -> bool,
) -> f64 {
    let lead_s = |k: usize| k as f64 * IN_PATH_LEAD_STEP_S;
    let bounds: [f64; LEAD_STEPS + 1] = std::array::from_fn(|k| lower_bound_m(lead_s(k)));
    let mut gaps = [None; LEAD_STEPS + 1];
    // The first lead step in contact: only a step whose bound allows
    // contact (or is NaN) can be.
    let mut first_contact = None;
    for k in 0..=LEAD_STEPS {
        if bounds[k] > 0.0 {
            continue;
        }
        let gap = gap_m(lead_s(k));
        gaps[k] = Some(gap);
        // Not apart (NaN included) counts as contact, as in the lead scan.
        if gap.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            first_contact = Some(k);
            break;
        }
    }
    // In contact, later leads only add lead cost; the first contact lies
    // within the step before.
    let mut closest_m = match first_contact {
        None => f64::INFINITY,
        Some(0) => 0.0,
        Some(k) => IN_PATH_LEAD_COST_M_PER_S * first_contact_s(gap_m, lead_s(k) - IN_PATH_LEAD_STEP_S, lead_s(k)),
    };
    let clear = first_contact.unwrap_or(LEAD_STEPS + 1);
    let with_cost = |k: usize, gap: f64| gap + IN_PATH_LEAD_COST_M_PER_S * lead_s(k);
    for (k, gap) in gaps.iter().enumerate().take(clear) {
        if let Some(gap) = *gap {
            closest_m = closest_m.min(with_cost(k, gap));
        }
    }
    // The rest, the most promising bound first.
    let promising = (0..clear)
        .filter(|&k| gaps[k].is_none())
        .min_by(|&x, &y| with_cost(x, bounds[x]).total_cmp(&with_cost(y, bounds[y])));
    for k in promising.into_iter().chain(0..clear) {
        if gaps[k].is_some() {
            continue;
        }
        let bound = with_cost(k, bounds[k]);
        if bound >= closest_m || (!bound.is_nan() && settled(bound)) {
            continue;
        }
        let gap = gap_m(lead_s(k));
        gaps[k] = Some(gap);
        closest_m = closest_m.min(with_cost(k, gap));
    }
    closest_m
}

/// A lower bound of [`closest_approach_m`] from the lower bounds of the
/// gaps alone (`lower_bound_m` as there, convex in the lead as a
/// separating-axis bound of a box moving in a line is): no lead step's gap
/// plus lead cost is below its bound's, and a first contact, possible only
/// at a step whose bound allows it, lies after the step before the first
/// such. Once the bound stops falling it rises from there on (convexity),
/// so the later steps can neither touch nor lower the least: the scan
/// stops, and a micrometre off the least covers the rounding that
/// convexity holds to. NaN bounds give minus infinity (no bound).
fn closest_lower_bound_m(lower_bound_m: impl Fn(f64) -> f64) -> f64 {
    const ROUNDING_M: f64 = 1e-6;
    let lead_s = |k: usize| k as f64 * IN_PATH_LEAD_STEP_S;
    let mut least_m = f64::INFINITY;
    let mut previous = f64::INFINITY;
    for k in 0..=LEAD_STEPS {
        let bound = lower_bound_m(lead_s(k));
        if bound.is_nan() {
            return f64::NEG_INFINITY;
        }
        if bound <= 0.0 {
            let contact_m = if k == 0 { 0.0 } else { IN_PATH_LEAD_COST_M_PER_S * (lead_s(k) - IN_PATH_LEAD_STEP_S) };
            return least_m.min(contact_m) - ROUNDING_M;
        }
        least_m = least_m.min(bound + IN_PATH_LEAD_COST_M_PER_S * lead_s(k));
        if bound >= previous {
            break;
        }
        previous = bound;
    }
    least_m - ROUNDING_M
}

/// The first lead in contact between `clear_s` (boxes apart) and
/// `touching_s` (boxes in contact), by bisection. The ego's footprint moves
/// along a line and the CBV's box stands still, so the leads in contact
/// form one interval and the boundary is unique.
fn first_contact_s(gap_m: &impl Fn(f64) -> f64, clear_s: f64, touching_s: f64) -> f64 {
    let (mut clear_s, mut touching_s) = (clear_s, touching_s);
    for _ in 0..CONTACT_BISECTIONS {
        let mid_s = 0.5 * (clear_s + touching_s);
        if gap_m(mid_s) > 0.0 { clear_s = mid_s } else { touching_s = mid_s }
    }
    touching_s
}

/// Which of the two losses of the module a caller scores by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum PathLoss {
    /// The in-path loss of `safer-in-path`.
    InPath,
    /// The cut-in loss of `safer-cut-in`.
    CutIn,
}

impl PathLoss {
    /// A lower bound of the loss of every CBV (body `cbv_body`, any
    /// heading) whose centre lies within `radius_m` of `centre`, against
    /// the ego at `ego_next` (body `ego_body`): each lead step's box
    /// distance is at least the distance from `centre` to the ego's
    /// footprint then less [`disc_reach_m`]; a
    /// first contact comes no earlier than the step before the first
    /// step that bound allows it at; and the not-ahead penalty counts
    /// only where no such centre is ahead of the ego's front bumper.
    pub(super) fn lower_bound_within(
        self,
        ego_next: &AgentState,
        ego_body: AgentBody,
        (centre, radius_m): (Point2, f64),
        cbv_body: AgentBody,
    ) -> f64 {
        let reach_m = disc_reach_m(radius_m, cbv_body);
        let closest_m = (0..=LEAD_STEPS)
            .map(|k| {
                let lead_s = k as f64 * IN_PATH_LEAD_STEP_S;
                let ego_then = AgentState { position: ego_next.position + ego_next.velocity_mps * lead_s, ..*ego_next };
                let gap_m = ego_body.footprint(&ego_then).distance_to_point(&centre) - reach_m;
                if gap_m > 0.0 {
                    gap_m + IN_PATH_LEAD_COST_M_PER_S * lead_s
                } else {
                    IN_PATH_LEAD_COST_M_PER_S * (lead_s - IN_PATH_LEAD_STEP_S).max(0.0)
                }
            })
            .fold(f64::INFINITY, f64::min);
        let at_centre = AgentState { position: centre, ..*ego_next };
        let placed = PathApproach::placed(ego_next, ego_body, &at_centre, ego_next.heading_rad.sin_cos());
        // The nearest any centre in the disc comes to being ahead, and no
        // lateral cost (the disc may hold the heading line).
        let least = PathApproach { closest_m, short_of_front_m: placed.short_of_front_m - radius_m, lateral_m: 0.0 };
        self.of(&least)
    }

    fn of(self, approach: &PathApproach) -> f64 {
        match self {
            PathLoss::InPath => approach.in_path_loss(),
            PathLoss::CutIn => approach.cut_in_loss(),
        }
    }

    /// The loss of the CBV at `cbv` (body `cbv_body`) for the ego at
    /// `ego_next` (its constant-velocity prediction at the end of the
    /// token, body `ego_body`); see the module. `settled` and the answer
    /// as in [`Objective::loss_unless`](super::objective::Objective::loss_unless)
    /// (here a settled answer is no less than the exact loss; `|_| false`:
    /// always exact).
    pub(super) fn loss_unless(
        self,
        ego_next: &AgentState,
        ego_body: AgentBody,
        cbv: &AgentState,
        cbv_body: AgentBody,
        settled: impl Fn(f64) -> bool,
    ) -> f64 {
        self.of(&PathApproach::of(ego_next, ego_body, cbv, cbv_body, |a| settled(self.of(a))))
    }

    /// A lower bound of [`Self::loss_unless`]'s exact loss from the
    /// separating axes of `sweep` (the [`path_sweep`] of the same ego and
    /// CBV) alone: for a caller ranking many candidates, which works out
    /// the exact loss only of those whose bound could still win.
    pub(super) fn lower_bound(
        self,
        (ego_next, ego_sin_cos): (&AgentState, (f64, f64)),
        ego_body: AgentBody,
        cbv: &AgentState,
        sweep: &SweptSeparation,
    ) -> f64 {
        self.of(&PathApproach::lower_bound(ego_next, ego_body, ego_sin_cos, cbv, sweep))
    }
}

/// How far a box of `body` whose centre lies within `radius_m` of a point
/// reaches from that point, m, and a centimetre for the box distance's
/// single-precision arithmetic: the margin of the losses' bounds over a
/// disc of centres.
pub(super) fn disc_reach_m(radius_m: f64, body: AgentBody) -> f64 {
    const BOX_DISTANCE_ROUNDING_M: f64 = 0.01;
    radius_m + body.half_diagonal_m() + BOX_DISTANCE_ROUNDING_M
}

/// The separating-axis bounds of the ego's footprint moving along its
/// constant-velocity path from `ego_next` over the in-path losses' lead
/// times against the CBV's box at `cbv` (each with its heading's
/// `sin_cos()` at hand). The losses' lower bounds come from it, and at
/// lead 0 it bounds the box distance between the two.
pub(super) fn path_sweep(
    (ego_next, ego_sin_cos): (&AgentState, (f64, f64)),
    ego_body: AgentBody,
    (cbv, cbv_sin_cos): (&AgentState, (f64, f64)),
    cbv_body: AgentBody,
) -> SweptSeparation {
    SweptSeparation::new(
        &ego_body.footprint(ego_next),
        ego_sin_cos,
        ego_next.velocity_mps,
        &cbv_body.footprint(cbv),
        cbv_sin_cos,
        IN_PATH_MAX_LEAD_S,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::policies::adversary::test_support::car;
    use crate::scenario::AgentKind;

    fn in_path_loss(ego_next: &AgentState, ego_body: AgentBody, cbv: &AgentState, cbv_body: AgentBody) -> f64 {
        PathLoss::InPath.loss_unless(ego_next, ego_body, cbv, cbv_body, |_| false)
    }

    fn cut_in_loss(ego_next: &AgentState, ego_body: AgentBody, cbv: &AgentState, cbv_body: AgentBody) -> f64 {
        PathLoss::CutIn.loss_unless(ego_next, ego_body, cbv, cbv_body, |_| false)
    }

    const CAR: AgentBody = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };

    fn loss(cbv: Option<AgentState>) -> f64 {
        in_path_loss(&car(0.0, 0.0, 10.0).unwrap(), CAR, &cbv.unwrap(), CAR)
    }

    #[test]
    fn the_ego_path_ahead_scores_better_than_its_side_or_its_rear() {
        // In the ego's lane 10 m ahead (5.5 m between the bumpers): the
        // ego's footprint meets it 0.55 s on.
        let ahead = loss(car(10.0, 0.0, 10.0));
        assert!((ahead - 0.55).abs() < 1e-3, "{ahead}");
        // Beside it, 0.5 m off its side: close, but not ahead.
        let beside = loss(car(0.0, 2.5, 10.0));
        assert!((beside - (0.5 + NOT_AHEAD_PENALTY_M)).abs() < 1e-9, "{beside}");
        // Right behind it, touching its rear.
        let behind = loss(car(-4.5, 0.0, 10.0));
        assert!((behind - NOT_AHEAD_PENALTY_M).abs() < 1e-9, "{behind}");
        assert!(ahead < beside && ahead < behind);
        // Closer ahead is better: 5 m ahead meets the ego 0.05 s on.
        let closer = loss(car(5.0, 0.0, 10.0));
        assert!((closer - 0.05).abs() < 1e-3, "{closer}");
    }

    #[test]
    fn a_cbv_in_the_next_lane_ahead_scores_better_moving_in() {
        // 1.5 m beside the ego's path, which comes level with it 0.75 s on:
        // at the 0.7 s step it is 0.5 m short and 1.5 m aside.
        let staying = loss(car(12.0, 3.5, 10.0));
        assert!((staying - (0.5f64.hypot(1.5) + 0.7)).abs() < 1e-6, "{staying}");
        // Its side on the ego's path: met 0.75 s on.
        let moving_in = loss(car(12.0, 2.0, 10.0));
        assert!((moving_in - 0.75).abs() < 1e-3, "{moving_in}");
    }

    #[test]
    fn closing_on_a_leader_braking_scores_better_than_holding_speed() {
        // The ego at 15 m/s meets a leader 24 m ahead 1.3 s on; one that
        // braked 0.6 m shorter, 1.26 s on. Both first touch between the
        // same two token-period leads (1 s and 1.5 s), where a loss taken
        // at those leads alone scored both 1.5 and the tie went to the
        // prior's favourite, holding speed.
        let ego = car(0.0, 0.0, 15.0).unwrap();
        let at = |x: f64| in_path_loss(&ego, CAR, &car(x, 0.0, 14.0).unwrap(), CAR);
        let (holding, braking) = (at(24.0), at(23.4));
        assert!((holding - 1.3).abs() < 1e-3, "{holding}");
        assert!((braking - 1.26).abs() < 1e-3, "{braking}");
        assert!(braking < holding);
    }

    #[test]
    fn a_cbv_crossing_the_path_between_lead_steps_is_met() {
        // A CBV across the ego's path 20 m ahead, 2 m deep along it: the
        // ego's footprint at 20 m/s is in contact with it from 0.84 s to
        // 1.16 s, and the loss is the first contact.
        let ego = car(0.0, 0.0, 20.0).unwrap();
        let across = AgentState { heading_rad: std::f64::consts::FRAC_PI_2, ..car(20.0, 0.0, 10.0).unwrap() };
        let crossing = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };
        let loss = in_path_loss(&ego, CAR, &across, crossing);
        assert!((loss - 0.8375).abs() < 1e-3, "{loss}");
    }

    fn cut_in(cbv: Option<AgentState>) -> f64 {
        cut_in_loss(&car(0.0, 0.0, 10.0).unwrap(), CAR, &cbv.unwrap(), CAR)
    }

    #[test]
    fn ahead_of_the_ego_the_cut_in_loss_draws_the_cbv_all_the_way_into_its_path() {
        // 8 m ahead: with its side 0.5 m into the ego's path the box meets
        // the ego's footprint 0.35 s on, and coming farther over changes
        // nothing for the in-path loss.
        let (corner_in, centred) = (car(8.0, 1.5, 10.0), car(8.0, 0.0, 10.0));
        assert!((loss(corner_in) - 0.35).abs() < 1e-3 && (loss(centred) - 0.35).abs() < 1e-3);
        // The cut-in loss adds half the centre's offset from the ego's heading line.
        assert!((cut_in(corner_in) - 1.1).abs() < 1e-3, "{}", cut_in(corner_in));
        assert!((cut_in(centred) - 0.35).abs() < 1e-3, "{}", cut_in(centred));
        // Still in the next lane, its side 0.5 m off the ego's path: the
        // most (level with the ego's footprint 0.4 s on, 0.5 m aside).
        let next_lane = cut_in(car(8.0, 2.5, 10.0));
        assert!((next_lane - 2.15).abs() < 1e-6, "{next_lane}");
    }

    #[test]
    fn beside_the_ego_the_cut_in_loss_prefers_drawing_ahead_to_hugging_its_side() {
        let (beside, hugging, drawing_ahead) = (car(0.0, 2.5, 10.0), car(0.0, 2.2, 10.0), car(1.0, 2.5, 10.0));
        // The in-path loss pays the flat penalty for all three and prefers
        // the one nearest the ego's side.
        assert!(loss(hugging) < loss(drawing_ahead));
        assert!((loss(beside) - loss(drawing_ahead)).abs() < 1e-6);
        // The cut-in loss pays 2 m a metre short of the front bumper
        // (2.25 m for a centre level with the ego's, 1.25 m a metre on).
        assert!((cut_in(hugging) - (0.2 + 4.5)).abs() < 1e-6, "{}", cut_in(hugging));
        assert!((cut_in(drawing_ahead) - (0.5 + 2.5)).abs() < 1e-6, "{}", cut_in(drawing_ahead));
        assert!(cut_in(drawing_ahead) < cut_in(hugging) && cut_in(hugging) < cut_in(beside));
        // Far behind, the penalty is the in-path loss's.
        assert!((cut_in(car(-4.5, 0.0, 10.0)) - loss(car(-4.5, 0.0, 10.0))).abs() < 1e-6);
    }

    #[test]
    fn the_separating_axis_bound_of_either_loss_never_exceeds_it() {
        let ego = car(0.0, 0.0, 15.0).unwrap();
        let (mut tight, mut cases) = (0, 0);
        for i in -20..=40 {
            for j in -12..=12 {
                for h in [0.0, 0.15, -0.6, 1.57, 3.0] {
                    let cbv = AgentState { heading_rad: h, ..car(i as f64 * 0.9, j as f64 * 0.55, 9.0).unwrap() };
                    let path = in_path_loss(&ego, CAR, &cbv, CAR);
                    let sweep = path_sweep((&ego, ego.heading_rad.sin_cos()), CAR, (&cbv, h.sin_cos()), CAR);
                    let ego_sin_cos = (&ego, ego.heading_rad.sin_cos());
                    let path_bound = PathLoss::InPath.lower_bound(ego_sin_cos, CAR, &cbv, &sweep);
                    let (cut, cut_bound) = (
                        cut_in_loss(&ego, CAR, &cbv, CAR),
                        PathLoss::CutIn.lower_bound(ego_sin_cos, CAR, &cbv, &sweep),
                    );
                    assert!(path_bound <= path && cut_bound <= cut, "{cbv:?}: {path_bound} {path} {cut_bound} {cut}");
                    cases += 1;
                    tight += usize::from(path - path_bound < 0.01);
                }
            }
        }
        // Off the ego's path side-on it is the loss (within the bound's
        // margin): nearly half the grid.
        assert!(tight * 3 > cases, "{tight} of {cases}");
    }
}
