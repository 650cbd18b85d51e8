//! Log replay: the agent is where the recording says, and absent where the
//! recording has no valid state.

use super::{AgentAction, AgentPolicy, WorldView};
use crate::scenario::{Track, TrackIndex};

/// Replays a recorded track.
#[derive(Debug, Clone)]
pub struct LogReplay {
    track: Track,
}

impl LogReplay {
    /// Replays `track`.
    pub fn new(track: Track) -> Self {
        Self { track }
    }
}

impl AgentPolicy for LogReplay {
    fn name(&self) -> &'static str {
        "log-replay"
    }

    fn act(&mut self, world: &WorldView<'_>, _agent: TrackIndex) -> AgentAction {
        match self.track.state(world.step + 1) {
            Some(s) => AgentAction::Teleport(*s),
            None => AgentAction::Absent,
        }
    }
}
