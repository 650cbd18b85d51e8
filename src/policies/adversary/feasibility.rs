//! V_h of candidate states of the CBV against the ego, timed, with a NaN
//! value (a broken model) turned into an error.

use crate::models::ModelError;
use crate::models::feasibility_oracle::{EgoCbvState, FeasibilityOracle};
use crate::scenario::AgentState;

/// V_h of the CBV in each of `predicted` against the ego in `ego`, timed
/// into `feasibility_s`; a NaN is a broken model and an error.
pub(super) fn feasibility_values(
    oracle: &dyn FeasibilityOracle,
    predicted: &[AgentState],
    ego: AgentState,
    ego_body: crate::scenario::AgentBody,
    cbv_body: crate::scenario::AgentBody,
    feasibility_s: &mut f64,
) -> Result<Vec<f32>, ModelError> {
    let pairs: Vec<EgoCbvState> = predicted.iter().map(|s| EgoCbvState { ego, ego_body, cbv: *s, cbv_body }).collect();
    let clock = std::time::Instant::now();
    let values = oracle.values(&pairs);
    *feasibility_s += clock.elapsed().as_secs_f64();
    let values = values?;
    // A NaN value is a broken model, not a feasible state: fail the
    // variant with the model named rather than guess.
    if let Some(i) = values.iter().position(|v| v.is_nan()) {
        return Err(ModelError::Inference {
            model: "feasibility value V_h".into(),
            message: format!("returned NaN for candidate token {} of {}", i, values.len()),
        });
    }
    Ok(values)
}
