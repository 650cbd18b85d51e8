//! Who is at fault in a contact between two road users, after nuPlan's
//! categories: the one rule that the simulator's ego collision events, the
//! CBV plausibility metrics and the adversary's plausibility check share.

use super::AgentState;

/// How the ego was involved in a collision, after nuPlan's categories.
/// Rear-end hits on the ego and hits on a stopped ego are not its fault;
/// front and lateral contacts, and hitting a stopped agent, are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum EgoCollisionKind {
    /// The ego was (nearly) stopped.
    StoppedEgo,
    /// The other agent was stopped and the ego moved into it.
    StoppedOther,
    /// Contact ahead of the ego (within 45° of its heading).
    ActiveFront,
    /// Contact behind the ego (within 45° of its tail): it was hit from behind.
    ActiveRear,
    /// Contact on the ego's side.
    ActiveLateral,
}

impl EgoCollisionKind {
    /// Whether the ego is at fault.
    pub fn ego_at_fault(self) -> bool {
        !matches!(self, Self::StoppedEgo | Self::ActiveRear)
    }

    /// Classifies a contact between the ego and another agent.
    pub fn classify(ego: &AgentState, other: &AgentState) -> Self {
        const STOPPED_MPS: f64 = 0.05;
        if ego.speed_mps() < STOPPED_MPS {
            return Self::StoppedEgo;
        }
        if other.speed_mps() < STOPPED_MPS {
            return Self::StoppedOther;
        }
        let rel = ego.pose().to_body(&other.position);
        let bearing = rel.y.atan2(rel.x).abs();
        if bearing <= std::f64::consts::FRAC_PI_4 {
            Self::ActiveFront
        } else if bearing >= 3.0 * std::f64::consts::FRAC_PI_4 {
            Self::ActiveRear
        } else {
            Self::ActiveLateral
        }
    }
}
