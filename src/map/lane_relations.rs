//! How the lanes of one map relate, for rules that read the road's
//! topology: which lanes continue which, which lanes two or more lanes lead
//! into (merge points, a junction's exits), and the lanes ahead of a lane
//! as far as a vehicle drives. The map's recorded successors are used where
//! it has any; a map that records none at all (GPUDrive's WOMD JSON) has
//! its lanes joined by geometry ([`LaneGraph`]).

use std::collections::{BTreeMap, BTreeSet};

use super::lane_graph::LaneGraph;
use super::{MapElementId, RoadMap};

/// Most lane pieces followed ahead of a lane (a loop or a chain of very
/// short pieces stops there).
pub const MAX_LANES_AHEAD: usize = 12;

/// How lanes on one map relate: the recorded successors and neighbours,
/// or (where the map records none at all) geometry.
pub struct LaneRelations<'a> {
    map: &'a RoadMap,
    /// Successors joined by geometry, when the map records none at all.
    joined: Option<&'a LaneGraph>,
    neighbours_recorded: bool,
    /// The lanes two or more lanes lead into (a merge point, a junction's exit).
    junctions: BTreeSet<MapElementId>,
}

/// A lane ahead of a vehicle's ([`LaneRelations::lanes_ahead`]).
#[derive(Debug, Clone, Copy)]
pub struct LaneAhead {
    /// The lane.
    pub id: MapElementId,
    /// Whether the way to it enters a lane that another lane also leads
    /// into (this one included): a lane only continuing the vehicle's own
    /// in pieces has none.
    pub through_junction: bool,
    /// How far its start is from the start of the vehicle's lane the way
    /// to it began in, along that way, m.
    pub start_m: f64,
}

impl<'a> LaneRelations<'a> {
    /// The relations of `map`'s lanes.
    pub fn of(map: &'a RoadMap) -> Self {
        let successors_recorded = map.lanes.iter().any(|l| !l.successors.is_empty());
        let neighbours_recorded =
            map.lanes.iter().any(|l| !l.left_neighbours.is_empty() || !l.right_neighbours.is_empty());
        let mut relations = Self {
            map,
            joined: (!successors_recorded).then(|| map.lane_graph()),
            neighbours_recorded,
            junctions: BTreeSet::new(),
        };
        let mut predecessors: BTreeMap<MapElementId, BTreeSet<MapElementId>> = BTreeMap::new();
        for lane in &map.lanes {
            for next in relations.successors_of(&[lane.id]) {
                predecessors.entry(next).or_default().insert(lane.id);
            }
            predecessors.entry(lane.id).or_default().extend(lane.predecessors.iter().copied());
        }
        relations.junctions = predecessors.into_iter().filter(|(_, p)| p.len() >= 2).map(|(id, _)| id).collect();
        relations
    }

    /// Whether the map records any lane's neighbours (else only lateral
    /// offsets can tell a lane beside another).
    pub fn neighbours_recorded(&self) -> bool {
        self.neighbours_recorded
    }

    /// The successors of `lanes`.
    pub fn successors_of(&self, lanes: &[MapElementId]) -> Vec<MapElementId> {
        match &self.joined {
            None => self.map.successors_of(lanes),
            Some(graph) => lanes
                .iter()
                .filter_map(|&id| self.map.lane_index(id))
                .flat_map(|i| graph.successors(i).iter().map(|&j| self.map.lanes[j].id))
                .collect(),
        }
    }

    /// The lanes ahead of `lanes` (not `lanes` themselves): their
    /// successors, and the successors of those that start within
    /// `within_m` of the start of one of `lanes`, at most
    /// [`MAX_LANES_AHEAD`] pieces on.
    pub fn lanes_ahead(&self, lanes: &[MapElementId], within_m: f64) -> Vec<LaneAhead> {
        let length_m = |id: MapElementId| self.map.lane(id).map_or(f64::INFINITY, |l| l.centreline.length_m());
        let mut ahead: Vec<LaneAhead> = Vec::new();
        // (lane, distance from the start of `lanes` to its start, through a junction)
        let mut frontier: Vec<(MapElementId, f64, bool)> = lanes.iter().map(|&id| (id, 0.0, false)).collect();
        for _ in 0..MAX_LANES_AHEAD {
            let mut next = Vec::new();
            for (id, start_m, through) in frontier {
                let end_m = start_m + length_m(id);
                for succ in self.successors_of(&[id]) {
                    if !ahead.iter().any(|a| a.id == succ) && !lanes.contains(&succ) {
                        let through_junction = through || self.junctions.contains(&succ);
                        ahead.push(LaneAhead { id: succ, through_junction, start_m: end_m });
                        if end_m < within_m {
                            next.push((succ, end_m, through_junction));
                        }
                    }
                }
            }
            if next.is_empty() {
                break;
            }
            frontier = next;
        }
        ahead
    }

    /// Whether some lane of `a` is one of `b` or continues it, or the other way round.
    pub fn any_connected(&self, a: &[MapElementId], b: &[MapElementId]) -> bool {
        if self.joined.is_none() {
            return self.map.any_lanes_connected(a, b);
        }
        let (a_next, b_next) = (self.successors_of(a), self.successors_of(b));
        a.iter().any(|x| b.contains(x) || b_next.contains(x)) || b.iter().any(|y| a_next.contains(y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Polyline};
    use crate::map::Lane;

    fn lane(id: i64, points: &[(f64, f64)]) -> Lane {
        Lane::new(MapElementId(id), Polyline::new(points.iter().map(|&(x, y)| Point2::new(x, y)).collect()))
    }

    /// 1 → 2 → 3 along y = 0 and 4 into 3's start; no recorded connectivity.
    fn junction() -> RoadMap {
        RoadMap::from_lanes(vec![
            lane(1, &[(0.0, 0.0), (50.0, 0.0)]),
            lane(2, &[(50.0, 0.0), (60.0, 0.0)]),
            lane(3, &[(60.0, 0.0), (100.0, 0.0)]),
            lane(4, &[(40.0, -5.0), (60.0, 0.0)]),
        ])
    }

    #[test]
    fn lanes_ahead_reach_as_far_as_asked_and_know_where_two_ways_joined() {
        let map = junction();
        let relations = LaneRelations::of(&map);
        assert!(!relations.neighbours_recorded());
        let ids = |ahead: Vec<LaneAhead>| ahead.iter().map(|a| (a.id.0, a.through_junction)).collect::<Vec<_>>();
        // The next piece always; the one after only once lane 1's 50 m are within reach.
        assert_eq!(ids(relations.lanes_ahead(&[MapElementId(1)], 40.0)), [(2, false)]);
        assert_eq!(ids(relations.lanes_ahead(&[MapElementId(1)], 70.0)), [(2, false), (3, true)]);
        assert_eq!(ids(relations.lanes_ahead(&[MapElementId(4)], 10.0)), [(3, true)]);
        // Where each starts, along the way from the start of the first lane.
        let starts = |ahead: Vec<LaneAhead>| ahead.iter().map(|a| a.start_m).collect::<Vec<_>>();
        assert_eq!(starts(relations.lanes_ahead(&[MapElementId(1)], 70.0)), [50.0, 60.0]);
        assert!((relations.lanes_ahead(&[MapElementId(4)], 10.0)[0].start_m - 17.0_f64.sqrt() * 5.0).abs() < 1e-9);
        assert!(relations.any_connected(&[MapElementId(2)], &[MapElementId(3)]));
        assert!(!relations.any_connected(&[MapElementId(1)], &[MapElementId(3)]));
    }
}
