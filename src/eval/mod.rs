//! Evaluation measures over rollouts: time to collision, and the
//! Jensen–Shannon divergence of speed/acceleration distributions (VJ, AJ).
//! (CR, SR, realism metrics and the feasibility witness join here;
//! [`feasibility_accuracy`] checks V_h against the witness; [`escape`] is
//! the witness of a stage-2 collision when the CBV reacts to the ego;
//! [`traffic_rules`] judges wrong-way driving and red-light running;
//! [`cbv_start`] says where the CBV starts relative to the ego;
//! [`sideways_speed`] how briskly a road user moves across its lanes;
//! [`tailgating`] how long one drove on another's bumper;
//! [`spread`] how a set of per-variant figures spreads.)

pub mod cbv_start;
pub mod conflict_kind;
pub mod conflict_reach;
pub mod divergence;
pub mod escape;
pub mod feasibility_accuracy;
pub mod prior_fit;
pub mod progress;
pub mod realism;
pub mod sideways_speed;
pub mod spread;
pub mod tailgating;
pub mod traffic_rules;
pub mod ttc;
pub mod witness;

pub use cbv_start::CbvStart;
pub use conflict_kind::{ConflictKind, ConflictParty, classify_conflict, rollout_conflict};
pub use conflict_reach::{CONFLICT_REACH_M, ConflictReach};
pub use divergence::{Histogram, jensen_shannon};
pub use ttc::min_time_to_collision;
