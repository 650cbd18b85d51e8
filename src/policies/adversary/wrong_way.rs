//! Whether the CBV may drive against the traffic of a lane
//! ([`WrongWayRule`]): the paper sets no such rule, and the in-path
//! methods, drawn towards the ego's path wherever it leads, take the CBV
//! into oncoming lanes and turn it round on a carriageway far more often
//! than recorded drivers do (`safer evaluate`'s "wrong way" columns, which
//! judge the CBV by the ego's wrong-way rule). Under
//! [`WrongWayRule::Forbidden`] a token that takes a CBV driving with the
//! traffic into a lane against it, by that same rule
//! ([`RoadMap::oncoming_lane_at`](crate::map::RoadMap::oncoming_lane_at)),
//! is implausible, like one that leaves the road, and so is one after
//! which braking as the road check brakes (holding the token's
//! curvature, on to a standstill) would still take the CBV into such a
//! lane: a rule held to each token's own half second lets the CBV be
//! driven straight on at speed where its road bends, until no token can
//! keep it out of the oncoming lane. A CBV already against the traffic
//! (a recording that starts so, or one the fallbacks put there when no
//! token was plausible) must head back: each token ends with the CBV out
//! of the oncoming lane or nearer a lane of its way than it is now
//! ([`TrafficDirectionHold::WayBack`]). Without that, a CBV swerving round
//! a pedestrian across the centre line stayed in the oncoming lane and
//! overtook the ego there for 1.9 s.
//!
//! Under [`WrongWayRule::AlongTheLanes`] the CBV is also held to drive
//! along the lanes, not across them: a token whose own states take a CBV
//! moving at 3 m/s or more more than 30° from every lane its centre is
//! in, outside intersections
//! ([`RoadMap::angle_across_lanes_at`](crate::map::RoadMap::angle_across_lanes_at),
//! what `safer evaluate`'s "across lanes" columns count), is implausible.
//! A lane change turns 5–10°; a closed-loop CBV chasing the ego's path
//! cut across a freeway's lanes at about 40°. Judged on the token's own
//! states, not on its path braked to a standstill: a CBV in a lane change
//! braking along its curvature would turn on past 30°. A CBV already
//! across the lanes must turn back towards them: each token ends with it
//! along them again, or at a smaller angle to them than now
//! ([`AcrossLanesHold::TurnBack`]).
//!
//! Under [`WrongWayRule::HumanLaneChanges`] the CBV's lane changes are
//! also held to a recorded driver's sideways pace (the `lane_change_pace`
//! module).

use crate::map::RoadMap;
use crate::scenario::AgentState;

/// Whether the adversary's CBV may drive against a lane's traffic.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum WrongWayRule {
    /// Allowed, as the paper's method allows it (the plausibility rule
    /// keeps the CBV on the road and off other traffic only).
    #[default]
    Allowed,
    /// Beyond the paper: a token that turns the CBV against a lane's
    /// traffic, or leaves it unable to brake short of such a lane, is
    /// implausible; so is one that leaves a CBV already against the
    /// traffic no nearer a lane of its way.
    Forbidden,
    /// As [`Self::Forbidden`], and a token that takes the CBV across the
    /// lanes (more than 30° from every lane it is in, outside
    /// intersections) is implausible too, as is one that leaves a CBV
    /// already across them at no smaller an angle to them.
    AlongTheLanes,
    /// As [`Self::AlongTheLanes`], and a token that moves the CBV sideways
    /// across its lanes faster than recorded drivers change lanes (1.7
    /// m/s, `HUMAN_LANE_CHANGE_MAX_SIDEWAYS_MPS`) is implausible, as is
    /// one that leaves a CBV moving faster already no slower.
    HumanLaneChanges,
}

impl WrongWayRule {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Allowed, Self::Forbidden, Self::AlongTheLanes, Self::HumanLaneChanges];

    /// Whether the CBV is kept out of lanes against their traffic.
    pub fn forbids_wrong_way(self) -> bool {
        self != Self::Allowed
    }

    /// Whether the CBV is kept from driving across the lanes.
    pub fn forbids_across_lanes(self) -> bool {
        matches!(self, Self::AlongTheLanes | Self::HumanLaneChanges)
    }

    /// Whether the CBV's sideways pace across its lanes is bounded by
    /// recorded drivers' lane changes.
    pub fn paces_lane_changes(self) -> bool {
        self == Self::HumanLaneChanges
    }
}

/// How far a CBV against the traffic looks for a lane of its way, m:
/// farther than a carriageway and its verge, near enough to be the road
/// it is on.
const WAY_BACK_SEARCH_RADIUS_M: f64 = 30.0;

/// A token that brings the CBV nearer a lane of its way by less than
/// this, m, does not head back: float noise, not a manoeuvre.
const WAY_BACK_MIN_GAIN_M: f64 = 0.01;

/// What the wrong-way rule holds a CBV to at one token boundary.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum TrafficDirectionHold {
    /// Nothing: the rule allows driving against the traffic.
    NotHeld,
    /// A CBV with the traffic: no token may take it against a lane's
    /// traffic, then or while it brakes after the token.
    KeepOut,
    /// A CBV against the traffic now: each token must end with it out of
    /// the oncoming lane or nearer a lane of its way than it is now
    /// (`distance_m`, infinite where none lies within
    /// [`WAY_BACK_SEARCH_RADIUS_M`]).
    WayBack {
        /// The CBV's distance now to the nearest lane of its way, m.
        distance_m: f64,
    },
}

impl TrafficDirectionHold {
    /// What `rule` holds a CBV in state `now` to.
    pub(super) fn of(rule: WrongWayRule, map: &RoadMap, now: &AgentState) -> Self {
        match (rule.forbids_wrong_way(), drives_wrong_way(map, now)) {
            (false, _) => Self::NotHeld,
            (true, false) => Self::KeepOut,
            (true, true) => Self::WayBack { distance_m: distance_to_a_lane_of_its_way(map, now) },
        }
    }

    /// The first state that breaks the hold: for [`Self::KeepOut`] the
    /// first of `moving_path` (the token's states `rollout` and the
    /// braking after them, rolled out only for this hold) against a
    /// lane's traffic; for [`Self::WayBack`] the token's last state, where
    /// the token does not end heading back.
    pub(super) fn first_breach<'p>(
        self,
        map: &RoadMap,
        rollout: &[AgentState],
        moving_path: impl FnOnce() -> &'p [AgentState],
    ) -> Option<usize> {
        match self {
            Self::NotHeld => None,
            Self::KeepOut => first_wrong_way(map, moving_path()),
            Self::WayBack { distance_m } => {
                let end = rollout.last()?;
                (drives_wrong_way(map, end)
                    && distance_to_a_lane_of_its_way(map, end) > distance_m - WAY_BACK_MIN_GAIN_M)
                    .then_some(rollout.len() - 1)
            }
        }
    }
}

/// A token that turns the CBV back towards its lanes by less than this,
/// rad, does not turn back: float noise, not a manoeuvre.
const TURN_BACK_MIN_GAIN_RAD: f64 = 1e-3;

/// What the rule against driving across the lanes holds a CBV to at one
/// token boundary.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum AcrossLanesHold {
    /// Nothing: the rule allows driving across the lanes.
    NotHeld,
    /// A CBV along the lanes: no state of a token may take it across them.
    KeepAlong,
    /// A CBV across the lanes now: each token must end with it along them
    /// again, or at a smaller angle to them than `angle_rad`.
    TurnBack {
        /// The CBV's angle to the lanes it is in now, rad.
        angle_rad: f64,
    },
}

impl AcrossLanesHold {
    /// What `rule` holds a CBV in state `now` to.
    pub(super) fn of(rule: WrongWayRule, map: &RoadMap, now: &AgentState) -> Self {
        match (rule.forbids_across_lanes(), angle_across_lanes(map, now)) {
            (false, _) => Self::NotHeld,
            (true, None) => Self::KeepAlong,
            (true, Some(angle_rad)) => Self::TurnBack { angle_rad },
        }
    }

    /// The first state of `rollout` (a token's states) that breaks the
    /// hold: for [`Self::KeepAlong`] the first across the lanes; for
    /// [`Self::TurnBack`] the token's last state, where the token does
    /// not end turned back.
    pub(super) fn first_breach(self, map: &RoadMap, rollout: &[AgentState]) -> Option<usize> {
        match self {
            Self::NotHeld => None,
            Self::KeepAlong => rollout.iter().position(|s| drives_across_lanes(map, s)),
            Self::TurnBack { angle_rad } => {
                let end = rollout.last()?;
                angle_across_lanes(map, end)
                    .is_some_and(|then| then > angle_rad - TURN_BACK_MIN_GAIN_RAD)
                    .then_some(rollout.len() - 1)
            }
        }
    }
}

/// The angle at which a CBV in `state` drives across the lanes it is in,
/// rad (`None`: along them, or not measured).
fn angle_across_lanes(map: &RoadMap, state: &AgentState) -> Option<f64> {
    map.angle_across_lanes_at(&state.position, state.heading_rad, state.speed_mps())
}

/// The distance from a CBV in `state` to the centreline of the nearest
/// lane running its way (within 45° of its heading), m; infinite where
/// none lies within [`WAY_BACK_SEARCH_RADIUS_M`].
fn distance_to_a_lane_of_its_way(map: &RoadMap, state: &AgentState) -> f64 {
    let heading = crate::geometry::Vector2::new(state.heading_rad.cos(), state.heading_rad.sin());
    // `nearest_lane` prefers lanes aligned with the heading: a misaligned
    // answer means no aligned lane lies within the radius.
    map.nearest_lane(&state.position, Some(state.heading_rad), WAY_BACK_SEARCH_RADIUS_M)
        .filter(|m| m.projection.tangent.dot(&heading) >= crate::map::ALIGNED_LANE_MAX_ANGLE_RAD.cos())
        .map_or(f64::INFINITY, |m| m.projection.distance_m)
}

/// Whether a CBV in `state` drives across the lanes it is in.
pub(super) fn drives_across_lanes(map: &RoadMap, state: &AgentState) -> bool {
    angle_across_lanes(map, state).is_some()
}

/// Whether a CBV in `state` drives against a lane's traffic.
pub(super) fn drives_wrong_way(map: &RoadMap, state: &AgentState) -> bool {
    map.oncoming_lane_at(&state.position, state.heading_rad, state.speed_mps()).is_some()
}

/// The first state of `path` (a token's states and the braking after
/// them) at which the CBV drives against a lane's traffic.
fn first_wrong_way(map: &RoadMap, path: &[AgentState]) -> Option<usize> {
    path.iter().position(|s| drives_wrong_way(map, s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::map::templates::StraightRoad;

    fn car(x: f64, y: f64, heading_rad: f64, speed: f64) -> AgentState {
        let v = Vector2::new(heading_rad.cos(), heading_rad.sin()) * speed;
        AgentState { position: Point2::new(x, y), heading_rad, velocity_mps: v }
    }

    #[test]
    fn a_moving_cbv_in_the_oncoming_lane_drives_the_wrong_way_and_one_in_its_own_does_not() {
        let map =
            StraightRoad { lanes: 1, oncoming_lanes: 1, lane_width_m: 3.5, length_m: 200.0, speed_limit_mps: None }
                .build();
        let y = |id| map.lane(crate::map::MapElementId(id)).unwrap().centreline.points()[0].y;
        let (own, oncoming) = (y(0), y(100));
        assert!(!drives_wrong_way(&map, &car(50.0, own, 0.0, 10.0)));
        assert!(drives_wrong_way(&map, &car(50.0, oncoming, 0.0, 10.0)));
        assert!(!drives_wrong_way(&map, &car(50.0, oncoming, 0.0, 0.0)), "standing");
        assert!(!drives_wrong_way(&map, &car(50.0, oncoming, std::f64::consts::PI, 10.0)), "with that lane's traffic");
        let path = [car(50.0, own, 0.0, 10.0), car(51.0, own, 0.0, 10.0), car(52.0, oncoming, 0.0, 10.0)];
        assert_eq!(first_wrong_way(&map, &path), Some(2));
        assert_eq!(first_wrong_way(&map, &path[..2]), None);
    }
}
