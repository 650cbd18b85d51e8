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
//! keep it out of the oncoming lane. A CBV already
//! against the traffic (a recording that starts so) is not held to it:
//! any way back is allowed.
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
//! braking along its curvature would turn on past 30°.

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
    /// implausible.
    Forbidden,
    /// As [`Self::Forbidden`], and a token that takes the CBV across the
    /// lanes (more than 30° from every lane it is in, outside
    /// intersections) is implausible too.
    AlongTheLanes,
}

impl WrongWayRule {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Allowed, Self::Forbidden, Self::AlongTheLanes];

    /// Whether the CBV is kept out of lanes against their traffic.
    pub fn forbids_wrong_way(self) -> bool {
        self != Self::Allowed
    }

    /// Whether the CBV is kept from driving across the lanes.
    pub fn forbids_across_lanes(self) -> bool {
        self == Self::AlongTheLanes
    }
}

/// Whether a CBV in `state` drives across the lanes it is in.
pub(super) fn drives_across_lanes(map: &RoadMap, state: &AgentState) -> bool {
    map.angle_across_lanes_at(&state.position, state.heading_rad, state.speed_mps()).is_some()
}

/// Whether a CBV in `state` drives against a lane's traffic.
pub(super) fn drives_wrong_way(map: &RoadMap, state: &AgentState) -> bool {
    map.oncoming_lane_at(&state.position, state.heading_rad, state.speed_mps()).is_some()
}

/// The first state of `path` (a token's states and the braking after
/// them) at which the CBV drives against a lane's traffic.
pub(super) fn first_wrong_way(map: &RoadMap, path: &[AgentState]) -> Option<usize> {
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
