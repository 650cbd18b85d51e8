//! The question the SaFeR adversary asks of the feasibility model: for a
//! batch of ego–CBV state pairs, the value V_h of each (V_h ≤ 0: the ego can
//! still avoid a collision). A trait, so the adversary does not depend on
//! how V_h is computed (the shipped ONNX model, or a stand-in in tests).

use super::ModelError;
use crate::scenario::{AgentBody, AgentState};

/// An ego–CBV pair of states whose feasibility is asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EgoCbvState {
    /// The ego's state.
    pub ego: AgentState,
    /// The ego's type and size.
    pub ego_body: AgentBody,
    /// The CBV's state.
    pub cbv: AgentState,
    /// The CBV's type and size.
    pub cbv_body: AgentBody,
}

/// The learned feasibility value V_h over ego–CBV states.
pub trait FeasibilityOracle: Send + Sync {
    /// V_h of each pair, in order; V_h ≤ 0 means the ego can still avoid a collision.
    fn values(&self, pairs: &[EgoCbvState]) -> Result<Vec<f32>, ModelError>;
}
