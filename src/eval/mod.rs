//! Evaluation measures over rollouts: time to collision, and the
//! Jensen–Shannon divergence of speed/acceleration distributions (VJ, AJ).
//! (CR, SR, realism metrics and the feasibility witness join here;
//! [`feasibility_accuracy`] checks V_h against the witness.)

pub mod divergence;
pub mod feasibility_accuracy;
pub mod realism;
pub mod ttc;
pub mod witness;

pub use divergence::{Histogram, jensen_shannon};
pub use ttc::min_time_to_collision;
