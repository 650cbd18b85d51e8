//! The road the witness's ego keeps to: the rule ([`RoadRule`], how much
//! of the ego by [`RoadKeeping`]) and where it lets the ego's centre be,
//! judged per grid cell and remembered ([`RoadCells`]).

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use super::memo::PoseHasher;
use crate::geometry::Point2;
use crate::map::RoadMap;
use crate::scenario::AgentBody;

/// The road a witness keeps to and how much of the ego must stay on it.
#[derive(Debug, Clone, Copy)]
pub struct RoadRule<'a> {
    /// The map.
    pub map: &'a RoadMap,
    /// How much of the ego must stay on the road.
    pub keeping: RoadKeeping,
}

/// How much of the witness's ego must stay on the road.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RoadKeeping {
    /// Its centre: the rule the CBV's off-road time counts by; half the
    /// car may be over the edge (on a shoulder, say).
    #[default]
    Centre,
    /// Its whole width: the centre at least half the ego's width inside the
    /// road's edge. An ego that starts closer to the edge than that is held
    /// to its centre instead.
    WholeWidth,
}

impl RoadKeeping {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Centre, Self::WholeWidth];
}

/// Side of the cells at whose centres [`RoadCells`] judges the road, m:
/// well below a car's width, so the rule is the exact one to within 0.36 m.
pub const ROAD_CELL_M: f64 = 0.5;

/// Where the witness's ego may put its centre: on the road inside the mapped
/// area ([`RoadMap::is_off_road_within_map`], the rule the CBV's off-road
/// time counts by), or that far inside it that its whole width is (see
/// [`RoadKeeping`]), judged at the centre of the [`ROAD_CELL_M`] grid cell
/// it falls in and remembered per cell (a search visits the same cells
/// again and again, and a map query costs far more than a look-up).
/// Anywhere, without a map or when the ego starts off the road.
pub struct RoadCells<'a> {
    rule: Option<RoadRule<'a>>,
    /// Half the ego's width, m (how far inside the edge [`RoadKeeping::WholeWidth`] keeps the centre).
    half_width_m: f64,
    on_road: HashMap<(i64, i64), bool, BuildHasherDefault<PoseHasher>>,
}

impl<'a> RoadCells<'a> {
    /// The rule for an ego of `body` starting at `start`.
    pub fn new(rule: Option<RoadRule<'a>>, body: AgentBody, start: &Point2) -> Self {
        let half_width_m = 0.5 * body.width_m;
        let with = |rule| Self { rule, half_width_m, on_road: HashMap::default() };
        let centre = rule.map(|r| RoadRule { keeping: RoadKeeping::Centre, ..r });
        if !with(centre).allows(start) {
            // Off the road at the start: not held to it.
            return with(None);
        }
        if rule.is_some_and(|r| r.keeping == RoadKeeping::WholeWidth) && !with(rule).allows(start) {
            // Closer to the edge than half its width at the start.
            return with(centre);
        }
        with(rule)
    }

    /// Whether the ego's centre may be at `p`.
    pub fn allows(&mut self, p: &Point2) -> bool {
        let Some(RoadRule { map, keeping }) = self.rule else { return true };
        let half_width_m = self.half_width_m;
        // A NaN coordinate falls into cell 0 (saturating casts).
        let cell = ((p.x / ROAD_CELL_M).floor() as i64, (p.y / ROAD_CELL_M).floor() as i64);
        *self.on_road.entry(cell).or_insert_with(|| {
            let centre = Point2::new((cell.0 as f64 + 0.5) * ROAD_CELL_M, (cell.1 as f64 + 0.5) * ROAD_CELL_M);
            match keeping {
                RoadKeeping::Centre => !map.is_off_road_within_map(&centre),
                RoadKeeping::WholeWidth => match map.signed_distance_to_road_edge(&centre) {
                    Some(d) => d <= -half_width_m || map.is_past_mapped_end(&centre),
                    // Without road edges the drivable areas decide alone.
                    None => !map.is_off_road_within_map(&centre),
                },
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::witness::test_support::{
        assert_touches_no_car, at, car, centre_on, oncoming_car, straight_road, straight_road_of,
    };
    use crate::eval::witness::{FixedTraffic, Witness, WitnessBudget, search_witness};
    use crate::scenario::AgentState;

    #[test]
    fn an_escape_only_off_the_road_is_no_witness() {
        // A car head-on in the ego's lane: swerving 2.05 m aside escapes, on
        // one lane only by leaving the road, on two by the other lane.
        let horizon = 60;
        let states = oncoming_car(horizon);
        let bodies = [car(), car()];
        let one_lane = straight_road(1);
        let two_lanes = straight_road(2);
        let search = |road: Option<RoadRule<'_>>| {
            let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0, road };
            search_witness(&at(0.0, 0.0, 4.0), car(), &traffic, horizon, WitnessBudget::default())
        };
        let Witness::Found { trajectory, .. } = search(None) else { panic!("no escape anywhere") };
        assert!(trajectory.iter().any(|s| one_lane.is_off_road_within_map(&s.position)));
        let w = search(centre_on(&one_lane));
        assert!(!w.is_found(), "{w:?}");
        let Witness::Found { trajectory, .. } = search(centre_on(&two_lanes)) else { panic!("no escape on two lanes") };
        assert_touches_no_car(&trajectory, &states);
        for s in &trajectory {
            // On the road to within the grid's half diagonal.
            let past_edge_m = two_lanes.signed_distance_to_road_edge(&s.position).unwrap();
            assert!(past_edge_m <= ROAD_CELL_M * std::f64::consts::FRAC_1_SQRT_2, "{s:?}: {past_edge_m} m off");
        }
    }

    #[test]
    fn keeping_the_whole_width_on_the_road_forbids_the_escape_over_the_edge_line() {
        // One lane 5.5 m wide, a car head-on in it: swerving 2.05 m aside
        // puts the centre 0.7 m from the edge, half the car over it.
        let horizon = 60;
        let states = oncoming_car(horizon);
        let bodies = [car(), car()];
        let wide_lane = straight_road_of(1, 5.5);
        let search = |keeping| {
            let road = Some(RoadRule { map: &wide_lane, keeping });
            let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0, road };
            search_witness(&at(0.0, 0.0, 4.0), car(), &traffic, horizon, WitnessBudget::default())
        };
        assert!(search(RoadKeeping::Centre).is_found());
        let w = search(RoadKeeping::WholeWidth);
        assert!(!w.is_found(), "{w:?}");
        // On two lanes of 3.5 m the other lane leaves room for the whole car.
        let two_lanes = straight_road(2);
        let road = Some(RoadRule { map: &two_lanes, keeping: RoadKeeping::WholeWidth });
        let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0, road };
        let w = search_witness(&at(0.0, 0.0, 4.0), car(), &traffic, horizon, WitnessBudget::default());
        let Witness::Found { trajectory, .. } = w else { panic!("{w:?}") };
        for s in &trajectory {
            let edge_m = two_lanes.signed_distance_to_road_edge(&s.position).unwrap();
            assert!(edge_m <= -1.0 + ROAD_CELL_M * std::f64::consts::FRAC_1_SQRT_2, "{s:?}: {edge_m} m");
        }
        // An ego starting nearer the edge than half its width is held to its
        // centre instead of having no move at all.
        let near_edge = at(0.0, -1.2, 4.0);
        let alone = vec![vec![None, None]; horizon + 1];
        let traffic = FixedTraffic { states: &alone, bodies: &bodies, ego: 0, road };
        assert!(search_witness(&near_edge, car(), &traffic, horizon, WitnessBudget::default()).is_found());
    }

    #[test]
    fn an_ego_starting_off_the_road_is_not_held_to_it() {
        let road = straight_road(1);
        let states = vec![vec![None]; 11];
        let bodies = [car()];
        let traffic = FixedTraffic {
            states: &states,
            bodies: &bodies,
            ego: 0,
            road: Some(RoadRule { map: &road, keeping: RoadKeeping::Centre }),
        };
        // 10 m beside the road, heading away from it.
        let start = AgentState { heading_rad: 1.5, ..at(0.0, 12.0, 5.0) };
        assert!(search_witness(&start, car(), &traffic, 10, WitnessBudget::default()).is_found());
    }
}
