//! Motion layer: the kinematic model `K`, the 63×63 (acceleration,
//! yaw-rate) token grid, and the inversion of logged trajectories into
//! tokens. All three are part of the token **contract** shared with the
//! learned models (see `models/*.card.yaml` once they exist): changing a
//! constant here changes what every token id means.

pub mod inversion;
pub mod kinematics;
pub mod tokens;
pub mod vehicle_limits;

pub use inversion::{TokenizedTrack, tokenize_track, tokenize_track_drifting};
pub use kinematics::{KinematicState, step as kinematic_step, step_with_sin_cos as kinematic_step_with_sin_cos};
pub use tokens::{Action, TOKEN_PERIOD_S, TOKEN_PERIOD_STEPS, Token, TokenGrid};
pub use vehicle_limits::{BUILTIN_MAX_LATERAL_ACCEL_MPS2, LimitMonitor, LimitViolation, VehicleLimits, within_grip};
