//! Who is at fault in a contact between two road users, after nuPlan's
//! `no_ego_at_fault_collisions`: the one rule that the simulator's ego
//! collision events, the CBV plausibility metrics and the adversary's
//! plausibility check share. "Ego" is whoever is judged (the ego under
//! test, or the CBV against background traffic).

use super::AgentState;
use crate::geometry::OrientedBox;
use crate::map::RoadMap;

/// How the ego was involved in a collision, after nuPlan's categories.
/// Rear-end hits on the ego and hits on a stopped ego are not its fault;
/// front contacts and hitting a stopped agent are; a lateral contact is
/// when the ego was not within one lane (see [`EgoContact::at_fault`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EgoCollisionKind {
    /// The ego was (nearly) stopped.
    StoppedEgo,
    /// The other agent was stopped and the ego moved into it.
    StoppedOther,
    /// Contact ahead of the ego (within 45° of its heading).
    ActiveFront,
    /// Contact behind the ego (within 45° of its tail): it was hit from behind.
    ActiveRear,
    /// Contact on the ego's side.
    ActiveLateral,
}

impl EgoCollisionKind {
    /// In words, for messages (`front contact`).
    pub fn describe(self) -> &'static str {
        match self {
            Self::StoppedEgo => "the ego stopped",
            Self::StoppedOther => "the ego into a stopped agent",
            Self::ActiveFront => "front contact",
            Self::ActiveRear => "hit from behind",
            Self::ActiveLateral => "side contact",
        }
    }

    /// Classifies a contact between the ego and another agent.
    pub fn classify(ego: &AgentState, other: &AgentState) -> Self {
        const STOPPED_MPS: f64 = 0.05;
        if ego.speed_mps() < STOPPED_MPS {
            return Self::StoppedEgo;
        }
        if other.speed_mps() < STOPPED_MPS {
            return Self::StoppedOther;
        }
        let rel = ego.pose().to_body(&other.position);
        let bearing = rel.y.atan2(rel.x).abs();
        if bearing <= std::f64::consts::FRAC_PI_4 {
            Self::ActiveFront
        } else if bearing >= 3.0 * std::f64::consts::FRAC_PI_4 {
            Self::ActiveRear
        } else {
            Self::ActiveLateral
        }
    }
}

/// Where the ego's footprint lay among the lanes at a contact, as nuPlan's
/// "ego in multiple lanes or non-drivable area" test asks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LaneOccupancy {
    /// All four corners in one lane (or in a lane and the one it continues
    /// into), driven in the ego's direction: the ego kept its lane.
    OneLane,
    /// The corners lie in lanes that do not continue one another: the ego
    /// was changing lanes or straddling a lane line.
    SeveralLanes,
    /// A corner lies in no lane driven the ego's way (a shoulder, the
    /// oncoming side, an unmapped gap), or off the road.
    OutsideLanes,
    /// The map has no lanes: where the ego was cannot be told.
    Unmapped,
}

impl LaneOccupancy {
    /// Where `footprint`, heading `heading_rad`, lies among `map`'s lanes.
    pub fn of_footprint(map: &RoadMap, footprint: &OrientedBox, heading_rad: f64) -> Self {
        if map.lanes.is_empty() {
            return Self::Unmapped;
        }
        let corners = footprint.corners();
        if corners.iter().any(|c| map.is_off_road(c)) {
            return Self::OutsideLanes;
        }
        let per_corner: Vec<Vec<_>> = corners.iter().map(|c| map.lanes_containing(c, heading_rad)).collect();
        if per_corner.iter().any(Vec::is_empty) {
            return Self::OutsideLanes;
        }
        // One lane holds every corner, or (across a lane's end) each pair
        // of corners shares a lane or a lane and its continuation.
        let shared = per_corner[0].iter().any(|l| per_corner[1..].iter().all(|c| c.contains(l)));
        let chained = per_corner.iter().enumerate().all(|(i, a)| {
            per_corner[i + 1..].iter().all(|b| a.iter().any(|&x| b.iter().any(|&y| map.lanes_connected(x, y))))
        });
        if shared || chained { Self::OneLane } else { Self::SeveralLanes }
    }
}

/// A contact as the fault rule sees it: its kind and where the ego was.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct EgoContact {
    /// How the ego was involved.
    pub kind: EgoCollisionKind,
    /// Where its footprint lay among the lanes.
    pub lanes: LaneOccupancy,
}

impl EgoContact {
    /// Judges a contact between the ego, with footprint `ego_box`, and
    /// `other`. The lanes are looked up for every kind (for reports),
    /// though only a lateral contact's fault depends on them.
    pub fn judge(map: &RoadMap, ego: &AgentState, ego_box: &OrientedBox, other: &AgentState) -> Self {
        let kind = EgoCollisionKind::classify(ego, other);
        Self { kind, lanes: LaneOccupancy::of_footprint(map, ego_box, ego.heading_rad) }
    }

    /// Whether the ego, with footprint `ego_box`, is at fault for a
    /// contact with `other`: [`Self::judge`]'s [`Self::at_fault`], with the
    /// lanes looked up only where the answer depends on them (a lateral
    /// contact), for hot callers that need no report.
    pub fn ego_at_fault(map: &RoadMap, ego: &AgentState, ego_box: &OrientedBox, other: &AgentState) -> bool {
        match EgoCollisionKind::classify(ego, other) {
            EgoCollisionKind::ActiveLateral => Self::judge(map, ego, ego_box, other).at_fault(),
            kind => Self { kind, lanes: LaneOccupancy::Unmapped }.at_fault(),
        }
    }

    /// Whether the ego is at fault. As in nuPlan: never for a stopped ego
    /// or a hit from behind; always for a front contact or one with a
    /// stopped agent; for a lateral contact only when the ego was not
    /// within one lane (changing lanes, straddling a line, off its lanes),
    /// since one that keeps its lane is sideswiped by whoever leaves
    /// theirs. Without lanes to tell, a lateral contact counts as the
    /// ego's fault, the cautious reading.
    pub fn at_fault(&self) -> bool {
        match self.kind {
            EgoCollisionKind::StoppedEgo | EgoCollisionKind::ActiveRear => false,
            EgoCollisionKind::StoppedOther | EgoCollisionKind::ActiveFront => true,
            EgoCollisionKind::ActiveLateral => self.lanes != LaneOccupancy::OneLane,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Polyline, Vector2};
    use crate::map::templates::StraightRoad;
    use crate::map::{Lane, MapElementId};

    /// Two 3.5 m lanes eastbound, centrelines at y = 1.75 and 5.25.
    fn two_lanes() -> RoadMap {
        StraightRoad { lanes: 2, oncoming_lanes: 0, lane_width_m: 3.5, length_m: 200.0, speed_limit_mps: None }.build()
    }

    fn car(x: f64, y: f64, heading_rad: f64, speed_mps: f64) -> (AgentState, OrientedBox) {
        let s = AgentState {
            position: Point2::new(x, y),
            heading_rad,
            velocity_mps: Vector2::new(heading_rad.cos(), heading_rad.sin()) * speed_mps,
        };
        (s, OrientedBox::new(s.pose(), 4.5, 1.9))
    }

    fn occupancy(map: &RoadMap, x: f64, y: f64, heading_rad: f64) -> LaneOccupancy {
        let (s, b) = car(x, y, heading_rad, 10.0);
        LaneOccupancy::of_footprint(map, &b, s.heading_rad)
    }

    #[test]
    fn a_car_in_its_lane_straddling_a_line_the_wrong_way_and_off_the_road() {
        let map = two_lanes();
        assert_eq!(occupancy(&map, 100.0, 1.75, 0.0), LaneOccupancy::OneLane);
        assert_eq!(occupancy(&map, 100.0, 2.3, 0.0), LaneOccupancy::OneLane, "drifting, still inside the lines");
        assert_eq!(occupancy(&map, 100.0, 3.5, 0.0), LaneOccupancy::SeveralLanes, "on the lane line");
        assert_eq!(occupancy(&map, 100.0, 1.75, std::f64::consts::PI), LaneOccupancy::OutsideLanes, "wrong way");
        assert_eq!(occupancy(&map, 100.0, 0.5, 0.0), LaneOccupancy::OutsideLanes, "over the kerb");
        let bare = RoadMap::from_lanes(vec![]);
        assert_eq!(occupancy(&bare, 100.0, 1.75, 0.0), LaneOccupancy::Unmapped);
    }

    #[test]
    fn crossing_from_a_lane_into_its_successor_is_one_lane() {
        let line = |x0: f64, x1: f64| Polyline::new(vec![Point2::new(x0, 0.0), Point2::new(x1, 0.0)]);
        let mut first = Lane::new(MapElementId(1), line(0.0, 50.0));
        first.successors.push(MapElementId(2));
        let mut second = Lane::new(MapElementId(2), line(50.0, 100.0));
        second.predecessors.push(MapElementId(1));
        let map = RoadMap::from_lanes(vec![first, second]);
        assert_eq!(occupancy(&map, 50.0, 0.0, 0.0), LaneOccupancy::OneLane);
        // Without the link the two are separate lanes end to end.
        let first = Lane::new(MapElementId(1), line(0.0, 50.0));
        let second = Lane::new(MapElementId(2), line(50.0, 100.0));
        let unlinked = RoadMap::from_lanes(vec![first, second]);
        assert_eq!(occupancy(&unlinked, 50.0, 0.0, 0.0), LaneOccupancy::SeveralLanes);
        // Boundary-less lanes are 2 × 1.85 m wide.
        assert_eq!(occupancy(&map, 25.0, 0.8, 0.0), LaneOccupancy::OneLane);
        assert_eq!(occupancy(&map, 25.0, 1.2, 0.0), LaneOccupancy::OutsideLanes);
    }

    #[test]
    fn fault_follows_nuplan() {
        use EgoCollisionKind::*;
        use LaneOccupancy::*;
        let fault = |kind, lanes| EgoContact { kind, lanes }.at_fault();
        for lanes in [OneLane, SeveralLanes, OutsideLanes, Unmapped] {
            assert!(!fault(StoppedEgo, lanes));
            assert!(!fault(ActiveRear, lanes));
            assert!(fault(StoppedOther, lanes));
            assert!(fault(ActiveFront, lanes));
        }
        assert!(!fault(ActiveLateral, OneLane), "sideswiped in its own lane");
        assert!(fault(ActiveLateral, SeveralLanes), "changing lanes into someone");
        assert!(fault(ActiveLateral, OutsideLanes));
        assert!(fault(ActiveLateral, Unmapped), "no lanes to tell: the cautious reading");
    }

    #[test]
    fn a_neighbour_cutting_into_a_lane_keeping_ego_is_at_fault_not_the_ego() {
        let map = two_lanes();
        // The ego keeps lane 0; the neighbour, half over the line, turns into it.
        let (ego, ego_box) = car(100.0, 1.75, 0.0, 10.0);
        let (cutter, cutter_box) = car(100.5, 3.6, -0.15, 11.0);
        let ego_side = EgoContact::judge(&map, &ego, &ego_box, &cutter);
        assert_eq!(ego_side.kind, EgoCollisionKind::ActiveLateral);
        assert!(!ego_side.at_fault());
        let cutter_side = EgoContact::judge(&map, &cutter, &cutter_box, &ego);
        assert_eq!(
            cutter_side,
            EgoContact { kind: EgoCollisionKind::ActiveLateral, lanes: LaneOccupancy::SeveralLanes }
        );
        assert!(cutter_side.at_fault());
    }

    #[test]
    fn the_quick_fault_answer_is_the_full_judgements() {
        // Every kind of contact, in and between lanes and off the road.
        let map = two_lanes();
        let mut kinds = std::collections::BTreeSet::new();
        for (x, y, heading_rad, speed_mps) in
            [(100.0, 1.75, 0.0, 10.0), (100.0, 3.5, 0.1, 8.0), (100.0, 0.4, -0.2, 5.0)]
        {
            let (ego, ego_box) = car(x, y, heading_rad, speed_mps);
            for dx in [-6.0, -3.0, 0.0, 3.0, 6.0] {
                for dy in [-2.5, 0.0, 2.5] {
                    for other_speed_mps in [0.0, 9.0] {
                        let (other, _) = car(x + dx, y + dy, 0.0, other_speed_mps);
                        let full = EgoContact::judge(&map, &ego, &ego_box, &other);
                        assert_eq!(EgoContact::ego_at_fault(&map, &ego, &ego_box, &other), full.at_fault(), "{full:?}");
                        kinds.insert(format!("{:?}/{:?}", full.kind, full.lanes));
                    }
                }
            }
        }
        assert!(kinds.len() >= 6, "{kinds:?}");
    }
}
