//! How briskly the adversary's CBV may move sideways across its lanes
//! ([`LaneChangePaceHold`], under [`WrongWayRule::HumanLaneChanges`]).
//! Along the lanes (the rule's 30° bound) an in-path CBV still changes
//! lanes a third faster than recorded drivers at the median and up to
//! 1.7 times faster at the 90th percentile (`safer evaluate`'s *lane
//! changes* table): a lane change at 20° and 8 m/s moves 2.7 m/s sideways.
//! Under the rule a token whose own states move the CBV sideways faster
//! than [`HUMAN_LANE_CHANGE_MAX_SIDEWAYS_MPS`] is implausible; a CBV that
//! moves faster already (a recording that starts so, or a fallback token)
//! must slow its sideways pace with each token. The rule holds a token
//! only where the CBV's pace is measured when the token starts: out of an
//! intersection, or driving off, the CBV enters its lane unbounded, and is
//! then held to slow down. Where the rule leaves no token plausible, the
//! choice drops it before any other rule (the fallbacks after it let the
//! CBV run into traffic or leave the road).
//!
//! The sideways speed is the map's
//! ([`RoadMap::sideways_speed_at`]): the CBV's speed times the sine of its
//! angle to the lanes of its way holding its centre, at 3 m/s or more,
//! outside intersections. It is the measure the *lane changes* table holds
//! for 0.5 s; the rule bounds it at every state of the tokens it holds, so
//! a lane change over it in that table is one the rule did not hold (out
//! of an intersection) or gave up (where it left no token).

use super::wrong_way::WrongWayRule;
use crate::map::RoadMap;
use crate::scenario::AgentState;

/// The fastest a CBV under [`WrongWayRule::HumanLaneChanges`] may move
/// sideways across its lanes, m/s: the 90th percentile (1.72 m/s) of the
/// held sideways speeds of the 111 recorded vehicles that changed lanes in
/// the scenes of NGSIM and WOMD interactive outside their held-out tenth.
pub const HUMAN_LANE_CHANGE_MAX_SIDEWAYS_MPS: f64 = 1.7;

/// A token that slows a CBV's sideways pace by less than this, m/s, does
/// not slow it: float noise, not a manoeuvre.
const SLOW_DOWN_MIN_GAIN_MPS: f64 = 1e-3;

/// What the lane-change pace rule holds a CBV to at one token boundary.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum LaneChangePaceHold {
    /// Nothing: the rule does not bound the sideways pace, or the CBV's
    /// pace is not measured now (inside an intersection, off the lanes of
    /// its way, or under 3 m/s). A turn ends at an angle to the lane it
    /// turns into, and driving off from a standstill starts at one: neither
    /// is a lane change, and held to the pace from the token's first state
    /// every token broke the rule (seen on WOMD interactive: a CBV leaving
    /// an intersection at 13 m/s, where then only the fallbacks were left
    /// and it drove off the road).
    NotHeld,
    /// A CBV at a human pace: no state of a token may move it sideways
    /// faster than [`HUMAN_LANE_CHANGE_MAX_SIDEWAYS_MPS`].
    KeepPace,
    /// A CBV moving sideways faster now: each token must end with it at a
    /// human pace again, or slower sideways than `sideways_mps`.
    SlowDown {
        /// The CBV's sideways speed now, m/s.
        sideways_mps: f64,
    },
}

impl LaneChangePaceHold {
    /// What `rule` holds a CBV in state `now` to.
    pub(super) fn of(rule: WrongWayRule, map: &RoadMap, now: &AgentState) -> Self {
        if !rule.paces_lane_changes() {
            return Self::NotHeld;
        }
        match sideways_speed_mps(map, now) {
            None => Self::NotHeld,
            Some(sideways_mps) if sideways_mps > HUMAN_LANE_CHANGE_MAX_SIDEWAYS_MPS => Self::SlowDown { sideways_mps },
            Some(_) => Self::KeepPace,
        }
    }

    /// The first state of `rollout` (a token's states) that breaks the
    /// hold: for [`Self::KeepPace`] the first that moves sideways too
    /// briskly; for [`Self::SlowDown`] the token's last state, where the
    /// token does not end slower sideways.
    pub(super) fn first_breach(self, map: &RoadMap, rollout: &[AgentState]) -> Option<usize> {
        match self {
            Self::NotHeld => None,
            Self::KeepPace => rollout.iter().position(|s| too_brisk(map, s).is_some()),
            Self::SlowDown { sideways_mps } => {
                let end = rollout.last()?;
                too_brisk(map, end)
                    .is_some_and(|then| then > sideways_mps - SLOW_DOWN_MIN_GAIN_MPS)
                    .then_some(rollout.len() - 1)
            }
        }
    }
}

/// The sideways speed of a CBV in `state` across its lanes, m/s (`None`:
/// not measured).
fn sideways_speed_mps(map: &RoadMap, state: &AgentState) -> Option<f64> {
    map.sideways_speed_at(&state.position, state.heading_rad, state.speed_mps())
}

/// [`sideways_speed_mps`] where it is above
/// [`HUMAN_LANE_CHANGE_MAX_SIDEWAYS_MPS`] (`None`: at a human pace, or not
/// measured).
fn too_brisk(map: &RoadMap, state: &AgentState) -> Option<f64> {
    sideways_speed_mps(map, state).filter(|&v| v > HUMAN_LANE_CHANGE_MAX_SIDEWAYS_MPS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::map::templates::StraightRoad;

    fn car(y: f64, heading_deg: f64, speed: f64) -> AgentState {
        let heading_rad = heading_deg.to_radians();
        let v = Vector2::new(heading_rad.cos(), heading_rad.sin()) * speed;
        AgentState { position: Point2::new(100.0, y), heading_rad, velocity_mps: v }
    }

    #[test]
    fn the_hold_bounds_the_sideways_speed_and_asks_a_brisker_cbv_to_slow_it() {
        let map =
            StraightRoad { lanes: 3, oncoming_lanes: 0, lane_width_m: 3.5, length_m: 200.0, speed_limit_mps: None }
                .build();
        let y = map.lane(crate::map::MapElementId(1)).unwrap().centreline.points()[0].y;
        // 8 m/s at 10° is 1.39 m/s sideways; at 15°, 2.07 m/s.
        let gentle = car(y, 10.0, 8.0);
        let brisk = car(y, 15.0, 8.0);
        assert_eq!(LaneChangePaceHold::of(WrongWayRule::AlongTheLanes, &map, &brisk), LaneChangePaceHold::NotHeld);
        let rule = WrongWayRule::HumanLaneChanges;
        assert_eq!(LaneChangePaceHold::of(rule, &map, &gentle), LaneChangePaceHold::KeepPace);
        let hold = LaneChangePaceHold::of(rule, &map, &brisk);
        assert!(
            matches!(hold, LaneChangePaceHold::SlowDown { sideways_mps } if (sideways_mps - 8.0 * 15f64.to_radians().sin()).abs() < 1e-9),
            "{hold:?}"
        );
        // Keeping the pace: the first state over it breaks the hold.
        assert_eq!(LaneChangePaceHold::KeepPace.first_breach(&map, &[gentle, gentle]), None);
        assert_eq!(LaneChangePaceHold::KeepPace.first_breach(&map, &[gentle, brisk, gentle]), Some(1));
        // Slowing down: ending slower sideways, or at a human pace, keeps
        // the hold; ending as brisk or brisker breaks it.
        let brisker = car(y, 20.0, 8.0);
        let slower = car(y, 13.0, 8.0);
        assert_eq!(hold.first_breach(&map, &[brisker, slower]), None);
        assert_eq!(hold.first_breach(&map, &[brisker, gentle]), None);
        assert_eq!(hold.first_breach(&map, &[slower, brisk]), Some(1));
        assert_eq!(hold.first_breach(&map, &[slower, brisker]), Some(1));
        // Without the rule nothing breaks.
        assert_eq!(LaneChangePaceHold::NotHeld.first_breach(&map, &[brisker]), None);
        // Nor where the pace is not measured now: under 3 m/s (driving off
        // at an angle to the lane) the hold starts at the next token.
        let driving_off = car(y, 30.0, 2.0);
        assert_eq!(LaneChangePaceHold::of(rule, &map, &driving_off), LaneChangePaceHold::NotHeld);
    }
}
