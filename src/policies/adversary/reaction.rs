//! When the adversary sees the ego: at once, or a human driver's reaction
//! time late.
//!
//! Driven closed loop against a planner, the adversary re-aims at the ego
//! at every token boundary. Seeing the ego at once, it answers an ego that
//! starts to brake or swerve within half a second, faster than any human
//! driver, and so follows an escape as it begins. Seeing it
//! [`REACTION_TIME_S`] late, it aims at where the ego it saw then would be
//! now, keeping the velocity it had: it still answers what the ego does,
//! as a human driver would, a reaction time later. Nothing else of its
//! choice changes.

use crate::motion::tokens::SIM_DT_S;
use crate::scenario::{AgentState, TrackIndex};

/// A human driver's reaction time, s: how late a delayed adversary sees
/// the ego (perception-reaction times of drivers to an unexpected event
/// are commonly put at 1 s or more).
pub const REACTION_TIME_S: f64 = 1.0;

/// [`REACTION_TIME_S`] in simulation steps.
const REACTION_STEPS: usize = (REACTION_TIME_S / SIM_DT_S + 0.5) as usize;

/// How the adversary sees the ego it aims at.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum EgoSight {
    /// As it is now (the paper's adversary, and stage 1, where the ego
    /// replays its log and has nothing to react to).
    #[default]
    Current,
    /// [`REACTION_TIME_S`] late, carried on to now at the velocity it had.
    ReactionTimeLate,
}

impl EgoSight {
    /// The ego's state as this sight has it at the last row of `frames`
    /// (every agent at each step of the rollout so far, the last row now).
    /// `None` where the ego is absent now; early in the rollout, where
    /// there is no row a reaction time back, the first row stands for it.
    pub(super) fn ego_seen(self, frames: &[Vec<Option<AgentState>>], ego: TrackIndex) -> Option<AgentState> {
        let now = frames.len().checked_sub(1)?;
        let current = frames[now].get(ego.0).copied().flatten()?;
        let back = match self {
            Self::Current => return Some(current),
            Self::ReactionTimeLate => now.saturating_sub(REACTION_STEPS),
        };
        let Some(seen) = frames[back].get(ego.0).copied().flatten() else { return Some(current) };
        let late_s = (now - back) as f64 * SIM_DT_S;
        Some(AgentState { position: seen.position + seen.velocity_mps * late_s, ..seen })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};

    fn at(x: f64, vx: f64) -> Option<AgentState> {
        Some(AgentState { position: Point2::new(x, 0.0), heading_rad: 0.0, velocity_mps: Vector2::new(vx, 0.0) })
    }

    #[test]
    fn a_late_sight_carries_the_ego_seen_a_reaction_time_ago_on_to_now() {
        let ego = TrackIndex(0);
        // The ego drove at 20 m/s and has braked to 10 m/s over the last
        // second; the other slot is the CBV.
        let frames: Vec<Vec<Option<AgentState>>> = (0..=25)
            .map(|k| {
                let v = if k <= 15 { 20.0 } else { 20.0 - (k - 15) as f64 };
                vec![at(2.0 * k as f64, v), at(100.0, 0.0)]
            })
            .collect();
        assert_eq!(EgoSight::Current.ego_seen(&frames, ego), frames[25][0]);
        // Seen at step 15 (x 30 m, 20 m/s), carried on for 1 s: 50 m at 20 m/s.
        let late = EgoSight::ReactionTimeLate.ego_seen(&frames, ego).expect("seen");
        assert!((late.position.x - 50.0).abs() < 1e-9, "{late:?}");
        assert_eq!(late.velocity_mps, Vector2::new(20.0, 0.0));
        // Less than a reaction time into the rollout: the first row, carried on.
        let early = EgoSight::ReactionTimeLate.ego_seen(&frames[..4], ego).expect("seen");
        assert!((early.position.x - 6.0).abs() < 1e-9, "{early:?}");
        // An ego absent now is not seen; one absent then is seen as it is now.
        let mut gone = frames.clone();
        gone[25][0] = None;
        assert_eq!(EgoSight::ReactionTimeLate.ego_seen(&gone, ego), None);
        let mut late_arrival = frames.clone();
        late_arrival[15][0] = None;
        assert_eq!(EgoSight::ReactionTimeLate.ego_seen(&late_arrival, ego), frames[25][0]);
        assert_eq!(EgoSight::ReactionTimeLate.ego_seen(&[], ego), None);
    }
}
