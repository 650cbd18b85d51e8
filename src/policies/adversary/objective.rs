//! What a feasible candidate's loss measures ([`Objective`]): the paper's
//! box distance to the ego's prediction, or the in-path and cut-in losses
//! (`in_path`) that draw the CBV into the ego's path. The one-step choice
//! and the lookahead score candidates through it alike.

use super::in_path::PathLoss;
use crate::geometry::SweptSeparation;
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

    /// The in-path module's loss this objective is (`None`: the paper's).
    fn path_loss(self) -> Option<PathLoss> {
        match self {
            Objective::Contact => None,
            Objective::InPath => Some(PathLoss::InPath),
            Objective::CutIn => Some(PathLoss::CutIn),
        }
    }
}
