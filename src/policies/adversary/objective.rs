//! What a feasible candidate's loss measures ([`Objective`]): the paper's
//! box distance to the ego's prediction, or the in-path and cut-in losses
//! (`in_path`) that draw the CBV into the ego's path. The one-step choice
//! and the lookahead score candidates through it alike.

use super::in_path::{PathLoss, disc_reach_m};
use crate::geometry::{Point2, SweptSeparation};
use crate::scenario::{AgentBody, AgentState};

/// What a feasible candidate's loss measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Objective {
    /// The paper's: the box distance to the ego's constant-velocity
    /// prediction at the end of the token.
    #[default]
    Contact,
    /// Beyond the paper (`safer-in-path`): how close the CBV comes to the
    /// ego's path ahead of it. The least, over lead times up to
    /// [`IN_PATH_MAX_LEAD_S`](super::IN_PATH_MAX_LEAD_S), of the box distance
    /// to the ego's constant-velocity footprint that far ahead plus
    /// [`IN_PATH_LEAD_COST_M_PER_S`](super::IN_PATH_LEAD_COST_M_PER_S) per
    /// second of lead, plus [`NOT_AHEAD_PENALTY_M`](super::NOT_AHEAD_PENALTY_M)
    /// when the CBV's centre is not ahead of the ego's front bumper.
    InPath,
    /// Beyond the paper (`safer-cut-in`): the in-path loss made to finish a
    /// cut-in. Ahead of the ego it adds
    /// [`CUT_IN_LATERAL_COST`](super::CUT_IN_LATERAL_COST) per metre of the
    /// CBV's centre off the ego's heading line; short of the ego's front
    /// bumper it pays [`CUT_IN_NOT_AHEAD_COST`](super::CUT_IN_NOT_AHEAD_COST)
    /// per metre, up to the flat penalty, so a CBV beside the ego draws
    /// ahead rather than hugging its side.
    CutIn,
}

impl Objective {
    /// The loss of a CBV at `cbv` (body `cbv_body`) against the ego's
    /// constant-velocity prediction `ego_next` (body `ego_body`), whose
    /// box distance from it is `distance_m`, m.
    pub(super) fn loss(
        self,
        ego_next: &AgentState,
        ego_body: AgentBody,
        cbv: &AgentState,
        cbv_body: AgentBody,
        distance_m: f64,
    ) -> f64 {
        self.loss_unless(ego_next, ego_body, cbv, cbv_body, distance_m, |_| false)
    }

    /// [`Self::loss`] where `settled` (a monotone test of a loss: once
    /// true, true for every larger one) is false of the exact loss; else
    /// some value `settled` is true of, above or below the exact one, that
    /// a caller may only test with `settled`. So `settled` is true of the
    /// answer exactly when it is true of the exact loss. For a caller to
    /// whom every loss past some point is alike (the lookahead's last
    /// token, which only asks whether a continuation lowers its first
    /// token's loss), and which need not pay for the exact one there.
    pub(super) fn loss_unless(
        self,
        ego_next: &AgentState,
        ego_body: AgentBody,
        cbv: &AgentState,
        cbv_body: AgentBody,
        distance_m: f64,
        settled: impl Fn(f64) -> bool,
    ) -> f64 {
        match self.path_loss() {
            None => distance_m,
            Some(loss) => loss.loss_unless(ego_next, ego_body, cbv, cbv_body, settled),
        }
    }

    /// A lower bound of [`Self::loss`] from the separating axes of
    /// `sweep`, the [`path_sweep`](super::in_path::path_sweep) of the same ego and CBV, alone (no exact
    /// box distance; `ego_sin_cos` its heading's `sin_cos()`): for a caller
    /// ranking many candidates, which works out the exact loss only of
    /// those whose bound could still win.
    pub(super) fn loss_lower_bound(
        self,
        ego_next: (&AgentState, (f64, f64)),
        ego_body: AgentBody,
        cbv: &AgentState,
        sweep: &SweptSeparation,
    ) -> f64 {
        match self.path_loss() {
            None => sweep.lower_bound_m(0.0),
            Some(loss) => loss.lower_bound(ego_next, ego_body, cbv, sweep),
        }
    }

    /// A lower bound of [`Self::loss`] for every CBV (body `cbv_body`, any
    /// heading) whose centre lies within `radius_m` of `centre`, against
    /// the ego at `ego_next`: for a search that can pass over a state's
    /// continuations together (see
    /// [`TokenGrid::rollout_end_reach`](crate::motion::tokens::TokenGrid::rollout_end_reach)).
    pub(super) fn loss_lower_bound_within(
        self,
        ego_next: &AgentState,
        ego_body: AgentBody,
        within: (Point2, f64),
        cbv_body: AgentBody,
    ) -> f64 {
        match self.path_loss() {
            None => {
                let (centre, radius_m) = within;
                ego_body.footprint(ego_next).distance_to_point(&centre) - disc_reach_m(radius_m, cbv_body)
            }
            Some(loss) => loss.lower_bound_within(ego_next, ego_body, within, cbv_body),
        }
    }

    /// The in-path module's loss this objective is (`None`: the paper's).
    fn path_loss(self) -> Option<PathLoss> {
        match self {
            Objective::Contact => None,
            Objective::InPath => Some(PathLoss::InPath),
            Objective::CutIn => Some(PathLoss::CutIn),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Vector2;
    use crate::policies::adversary::test_support::car;
    use crate::scenario::AgentKind;

    const CAR: AgentBody = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };

    #[test]
    fn no_cbv_within_a_disc_scores_below_the_discs_bound() {
        // The ego at 12 m/s; discs ahead in its lane and the next, beside,
        // behind, crossing its path ahead and far off; CBVs on a grid over
        // each disc, rim included, at eight headings.
        let ego = car(0.0, 0.0, 12.0).unwrap();
        let ego_box = CAR.footprint(&ego);
        let discs = [(12.0, 0.0), (9.0, 3.5), (0.0, 3.6), (-9.0, 0.0), (18.0, 6.0), (40.0, -25.0), (3.0, 0.5)];
        for objective in [Objective::Contact, Objective::InPath, Objective::CutIn] {
            let (mut above_zero, mut penalised) = (0, 0);
            for (x, y) in discs {
                for radius_m in [0.3, 1.5, 4.0] {
                    let centre = Point2::new(x, y);
                    let bound = objective.loss_lower_bound_within(&ego, CAR, (centre, radius_m), CAR);
                    for (i, j, h) in disc_grid() {
                        let offset = Vector2::new(i, j) * radius_m;
                        if offset.norm() > radius_m {
                            continue;
                        }
                        let cbv = AgentState { heading_rad: h, ..car(x + offset.x, y + offset.y, 8.0).unwrap() };
                        let distance_m = ego_box.distance(&CAR.footprint(&cbv));
                        let loss = objective.loss(&ego, CAR, &cbv, CAR, distance_m);
                        assert!(
                            bound <= loss,
                            "{objective:?} ({x}, {y}) r {radius_m}: {bound} above {loss} at {cbv:?}"
                        );
                    }
                    above_zero += usize::from(bound > 0.0);
                    penalised += usize::from(bound >= crate::policies::adversary::NOT_AHEAD_PENALTY_M);
                }
            }
            // The bound tells discs apart: most are clear of the ego, and
            // the in-path loss's discs wholly behind or beside the ego pay
            // the penalty.
            assert!(above_zero >= 12, "{objective:?}: {above_zero}");
            if objective == Objective::InPath {
                assert!(penalised >= 4, "{penalised}");
            }
        }
    }

    /// Offsets over the unit square (to be kept within the unit disc) and
    /// headings.
    fn disc_grid() -> impl Iterator<Item = (f64, f64, f64)> {
        (-4..=4).flat_map(|i| {
            (-4..=4).flat_map(move |j| {
                (0..8).map(move |k| (i as f64 * 0.25, j as f64 * 0.25, k as f64 * std::f64::consts::FRAC_PI_4 - 3.0))
            })
        })
    }
}
