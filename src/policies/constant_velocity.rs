//! Constant velocity: zero acceleration and zero yaw rate from wherever the
//! agent is; the simplest reference a realism metric must beat.

use super::{AgentAction, AgentPolicy, WorldView};
use crate::motion::Action;
use crate::scenario::TrackIndex;

/// Holds speed and heading.
#[derive(Debug, Clone, Copy, Default)]
pub struct ConstantVelocity;

impl AgentPolicy for ConstantVelocity {
    fn name(&self) -> &'static str {
        "constant-velocity"
    }

    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
        match world.state(agent) {
            Some(_) => AgentAction::Control(Action::default()),
            None => AgentAction::Absent,
        }
    }
}
