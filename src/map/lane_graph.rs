//! The lanes as a graph to look ahead on: each lane's successors, from the
//! source where it gives them and otherwise from the geometry (the lanes
//! that start where this one ends, going its way), and how the way ahead
//! turns from any point of a lane.
//!
//! Recorded formats differ in what they keep: WOMD protobuf and CommonRoad
//! carry lane connectivity, GPUDrive's WOMD JSON keeps none. The geometric
//! join lets a consumer (the realism prior's map tokens) read the same
//! "this lane turns right ahead" from every source, and a route (the
//! planners' and the background's lane following) run on through a
//! junction the source did not connect.

use std::collections::HashMap;

use crate::geometry::{Point2, Vector2, wrap_angle};

use super::{Lane, RoadMap};

/// A lane's end and another's start closer than this are joined, m.
pub const JOIN_DISTANCE_M: f64 = 1.0;
/// ... when their directions there differ by less than this, rad (keeps
/// the lanes of the other direction and crossing lanes out).
pub const JOIN_MAX_ANGLE_RAD: f64 = std::f64::consts::FRAC_PI_2;
/// Most successor lanes followed from one point (through loops, and a
/// chain of very short lanes, the walk stops here).
const MAX_DEPTH: usize = 12;
/// Most ways ahead followed from one point.
const MAX_WAYS: usize = 32;

/// Where a lane's successors come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SuccessorSource {
    /// The map source named them.
    Recorded,
    /// Joined by geometry: the source named none for this lane.
    Geometric,
}

/// The lane graph of one map, by index into [`RoadMap::lanes`].
#[derive(Debug, Clone, Default)]
pub struct LaneGraph {
    successors: Vec<Vec<usize>>,
    source: Vec<Option<SuccessorSource>>,
    predecessors: Vec<Vec<usize>>,
    /// The lanes without successors (of two points or more), ascending.
    dead_ends: Vec<DeadEnd>,
}

/// Where a lane without successors ends: its last point and the direction
/// of its last segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeadEnd {
    /// The lane (an index into [`RoadMap::lanes`]).
    pub lane: usize,
    /// Its centreline's last point.
    pub end: Point2,
    /// The unit direction of its last segment.
    pub along: Vector2,
}

impl DeadEnd {
    /// Where `lane` (its index `lane_index`) ends; `None` under two points.
    pub fn of(lane_index: usize, lane: &Lane) -> Option<Self> {
        match lane.centreline.points() {
            [.., a, b] => Some(Self { lane: lane_index, end: *b, along: (b - a).normalize() }),
            _ => None,
        }
    }
}

/// How the ways ahead along the lane graph turn from one point of a lane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurnAhead {
    /// The most rightward heading change among the ways ahead (negative:
    /// right), rad, from the direction at the point to the direction at
    /// the look-ahead distance (or at a way's end where it ends sooner).
    pub rightmost_rad: f64,
    /// The most leftward heading change (positive: left), rad.
    pub leftmost_rad: f64,
    /// How far the longest way goes, m, at most the look-ahead.
    pub reach_m: f64,
}

impl LaneGraph {
    /// The graph of `map`: a lane's recorded successors where it has any,
    /// else the lanes starting within [`JOIN_DISTANCE_M`] of its end and
    /// within [`JOIN_MAX_ANGLE_RAD`] of its end direction.
    pub fn build(map: &RoadMap) -> Self {
        let joined = successors_by_geometry(&map.lanes);
        let mut successors = Vec::with_capacity(map.lanes.len());
        let mut source = Vec::with_capacity(map.lanes.len());
        for (lane, joined) in map.lanes.iter().zip(joined) {
            let recorded: Vec<usize> = lane.successors.iter().filter_map(|id| map.lane_index(*id)).collect();
            let (next, from) = if !recorded.is_empty() {
                (recorded, Some(SuccessorSource::Recorded))
            } else if !joined.is_empty() {
                (joined, Some(SuccessorSource::Geometric))
            } else {
                (Vec::new(), None)
            };
            successors.push(next);
            source.push(from);
        }
        // A lane's recorded predecessors where it has any, else the lanes
        // whose successors (recorded or joined) it is.
        let mut predecessors: Vec<Vec<usize>> =
            map.lanes.iter().map(|l| l.predecessors.iter().filter_map(|id| map.lane_index(*id)).collect()).collect();
        let recorded: Vec<bool> = predecessors.iter().map(|p| !p.is_empty()).collect();
        for (i, next) in successors.iter().enumerate() {
            for &j in next {
                if !recorded[j] && !predecessors[j].contains(&i) {
                    predecessors[j].push(i);
                }
            }
        }
        let dead_ends = (0..successors.len())
            .filter(|&i| successors[i].is_empty())
            .filter_map(|i| DeadEnd::of(i, &map.lanes[i]))
            .collect();
        Self { successors, source, predecessors, dead_ends }
    }

    /// How many lanes the graph was built over (the map's lanes then).
    pub fn lane_count(&self) -> usize {
        self.successors.len()
    }

    /// Where the lanes without [`successors`](Self::successors) end (those
    /// of two points or more, ascending by lane): where the road ends, or
    /// the map's record of it does.
    pub fn dead_ends(&self) -> &[DeadEnd] {
        &self.dead_ends
    }

    /// Predecessors of lane `lane` (indices into [`RoadMap::lanes`]): the
    /// recorded ones where the source names any, else the lanes whose
    /// [`successors`](Self::successors) it is, ascending.
    pub fn predecessors(&self, lane: usize) -> &[usize] {
        self.predecessors.get(lane).map_or(&[], Vec::as_slice)
    }

    /// Successors of lane `lane` (indices into [`RoadMap::lanes`]), sorted
    /// by index where they were joined by geometry.
    pub fn successors(&self, lane: usize) -> &[usize] {
        self.successors.get(lane).map_or(&[], Vec::as_slice)
    }

    /// Where lane `lane`'s successors come from; `None` when it has none.
    pub fn successor_source(&self, lane: usize) -> Option<SuccessorSource> {
        self.source.get(lane).copied().flatten()
    }

    /// How the ways ahead turn from arc length `from_m` of lane `lane`,
    /// looking `ahead_m` along the graph; `None` for a lane without a
    /// direction (under two points).
    pub fn turn_ahead(&self, map: &RoadMap, lane: usize, from_m: f64, ahead_m: f64) -> Option<TurnAhead> {
        let (_, here) = map.lanes.get(lane)?.centreline.sample(from_m)?;
        if map.lanes[lane].centreline.len() < 2 {
            return None;
        }
        let base = here.y.atan2(here.x);
        let mut turn = TurnAhead { rightmost_rad: f64::INFINITY, leftmost_rad: f64::NEG_INFINITY, reach_m: 0.0 };
        let mut ways = 0;
        self.walk(map, lane, from_m, ahead_m, ahead_m, base, 0, &mut ways, &mut turn);
        Some(turn)
    }

    #[allow(clippy::too_many_arguments)]
    fn walk(
        &self,
        map: &RoadMap,
        lane: usize,
        from_m: f64,
        left_m: f64,
        ahead_m: f64,
        base_rad: f64,
        depth: usize,
        ways: &mut usize,
        turn: &mut TurnAhead,
    ) {
        let line = &map.lanes[lane].centreline;
        let remaining_on_lane = (line.length_m() - from_m).max(0.0);
        let next: Vec<usize> =
            self.successors(lane).iter().copied().filter(|&j| map.lanes[j].centreline.len() >= 2).collect();
        let ends_here = left_m <= remaining_on_lane || next.is_empty() || depth >= MAX_DEPTH || *ways >= MAX_WAYS;
        if ends_here {
            let at = from_m + left_m.min(remaining_on_lane);
            if let Some((_, dir)) = line.sample(at) {
                let change = wrap_angle(dir.y.atan2(dir.x) - base_rad);
                turn.rightmost_rad = turn.rightmost_rad.min(change);
                turn.leftmost_rad = turn.leftmost_rad.max(change);
                turn.reach_m = turn.reach_m.max(ahead_m - (left_m - left_m.min(remaining_on_lane)));
            }
            *ways += 1;
            return;
        }
        for j in next {
            self.walk(map, j, 0.0, left_m - remaining_on_lane, ahead_m, base_rad, depth + 1, ways, turn);
        }
    }
}

/// For each lane without recorded successors, the lanes (indices into
/// `lanes`, ascending) that start within [`JOIN_DISTANCE_M`] of its end and
/// within [`JOIN_MAX_ANGLE_RAD`] of its end direction; empty for a lane
/// with recorded successors.
fn successors_by_geometry(lanes: &[Lane]) -> Vec<Vec<usize>> {
    let cell = |x: f64| (x / JOIN_DISTANCE_M).floor() as i64;
    let mut starts: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (i, lane) in lanes.iter().enumerate() {
        if let Some(p) = lane.centreline.points().first() {
            starts.entry((cell(p.x), cell(p.y))).or_default().push(i);
        }
    }
    lanes
        .iter()
        .enumerate()
        .map(|(i, lane)| {
            if !lane.successors.is_empty() || lane.centreline.len() < 2 {
                return Vec::new();
            }
            let Some((end, end_dir)) = lane.centreline.sample(lane.centreline.length_m()) else { return Vec::new() };
            let (cx, cy) = (cell(end.x), cell(end.y));
            let mut joined = Vec::new();
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for &j in starts.get(&(cx + dx, cy + dy)).map_or(&[][..], Vec::as_slice) {
                        let other = &lanes[j].centreline;
                        if j == i || other.len() < 2 {
                            continue;
                        }
                        let Some((start, start_dir)) = other.sample(0.0) else { continue };
                        if (start - end).norm() <= JOIN_DISTANCE_M && start_dir.dot(&end_dir) > JOIN_MAX_ANGLE_RAD.cos()
                        {
                            joined.push(j);
                        }
                    }
                }
            }
            joined.sort_unstable();
            joined
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Polyline};
    use crate::map::{Lane, MapElementId};

    fn lane(id: i64, points: &[(f64, f64)]) -> Lane {
        Lane::new(MapElementId(id), Polyline::new(points.iter().map(|&(x, y)| Point2::new(x, y)).collect()))
    }

    fn map(lanes: Vec<Lane>) -> RoadMap {
        RoadMap::from_lanes(lanes)
    }

    /// A quarter circle of radius `r` from (x0, 0) heading east, turning
    /// right (to heading south) when `right`, else left.
    fn quarter(x0: f64, r: f64, right: bool) -> Vec<(f64, f64)> {
        let sign = if right { -1.0 } else { 1.0 };
        (0..=18)
            .map(|k| {
                let a = k as f64 / 18.0 * std::f64::consts::FRAC_PI_2;
                (x0 + r * a.sin(), sign * r * (1.0 - a.cos()))
            })
            .collect()
    }

    #[test]
    fn lanes_without_recorded_successors_are_joined_where_one_starts_as_the_other_ends() {
        let approach = lane(1, &[(0.0, 0.0), (30.0, 0.0)]);
        let straight = lane(2, &[(30.3, 0.1), (60.0, 0.0)]);
        let right = lane(3, &quarter(30.0, 15.0, true));
        // Starts where the approach ends, but runs against it.
        let oncoming = lane(4, &[(30.0, 0.5), (0.0, 0.5)]);
        // Runs its way, but starts 3 m off.
        let beside = lane(5, &[(30.0, 3.0), (60.0, 3.0)]);
        let m = map(vec![approach, straight, right, oncoming, beside]);
        let g = LaneGraph::build(&m);
        assert_eq!(g.successors(0), &[1, 2]);
        assert_eq!(g.successor_source(0), Some(SuccessorSource::Geometric));
        assert_eq!(g.successors(1), &[] as &[usize]);
        assert_eq!(g.successor_source(1), None);
        assert_eq!(g.predecessors(1), &[0], "the join read backwards");
        assert_eq!(g.predecessors(2), &[0]);
        assert_eq!(g.predecessors(0), &[] as &[usize]);
        assert_eq!(g.predecessors(4), &[] as &[usize]);
    }

    #[test]
    fn recorded_successors_are_kept_and_not_joined_to() {
        let mut approach = lane(1, &[(0.0, 0.0), (30.0, 0.0)]);
        approach.successors.push(MapElementId(3));
        let straight = lane(2, &[(30.0, 0.0), (60.0, 0.0)]);
        let right = lane(3, &quarter(30.0, 15.0, true));
        let g = LaneGraph::build(&map(vec![approach, straight, right]));
        assert_eq!(g.successors(0), &[2], "only the recorded right turn");
        assert_eq!(g.successor_source(0), Some(SuccessorSource::Recorded));
        assert_eq!(g.predecessors(2), &[0]);
        assert_eq!(g.predecessors(1), &[] as &[usize], "not joined from a lane with recorded successors");
    }

    #[test]
    fn recorded_predecessors_are_kept() {
        let approach = lane(1, &[(0.0, 0.0), (30.0, 0.0)]);
        let side = lane(2, &[(30.0, -30.0), (30.0, -1.0)]);
        let mut straight = lane(3, &[(30.0, 0.0), (60.0, 0.0)]);
        straight.predecessors.push(MapElementId(2));
        let m = map(vec![approach, side, straight]);
        let g = LaneGraph::build(&m);
        assert_eq!(g.successors(0), &[2], "joined by geometry");
        assert_eq!(g.predecessors(2), &[1], "the recorded predecessor, not the join");
    }

    #[test]
    fn the_turn_ahead_spans_the_ways_and_stops_at_the_look_ahead() {
        let approach = lane(1, &[(0.0, 0.0), (30.0, 0.0)]);
        let straight = lane(2, &[(30.0, 0.0), (90.0, 0.0)]);
        let right = lane(3, &quarter(30.0, 15.0, true));
        let m = map(vec![approach, straight.clone(), right.clone()]);
        let g = LaneGraph::build(&m);
        let half_pi = std::f64::consts::FRAC_PI_2;
        // 20 m before the junction, looking 40 m: the right turn's 20 m
        // arc is past its quarter (23.6 m long) by less than its length.
        let t = g.turn_ahead(&m, 0, 10.0, 40.0).unwrap();
        assert!(t.leftmost_rad.abs() < 1e-9, "{t:?}");
        let arc_angle = 20.0 / 15.0;
        assert!((t.rightmost_rad + arc_angle).abs() < 0.06, "{t:?}");
        assert!((t.reach_m - 40.0).abs() < 1e-9);
        // Far ahead of the junction the look-ahead ends on the approach.
        let near = g.turn_ahead(&m, 0, 0.0, 10.0).unwrap();
        assert_eq!((near.rightmost_rad, near.leftmost_rad, near.reach_m), (0.0, 0.0, 10.0));
        // Past the end of the quarter the right way ends (no successor):
        // its whole turn counts, and the straight way reaches further.
        let t = g.turn_ahead(&m, 0, 20.0, 60.0).unwrap();
        assert!((t.rightmost_rad + half_pi).abs() < 0.05, "{t:?}");
        assert!((t.reach_m - 60.0).abs() < 1e-9);
        // A right-turn-only lane: both ends of the span turn right.
        let only_right = map(vec![lane(1, &[(0.0, 0.0), (30.0, 0.0)]), right]);
        let g = LaneGraph::build(&only_right);
        let t = g.turn_ahead(&only_right, 0, 10.0, 60.0).unwrap();
        assert!((t.leftmost_rad + half_pi).abs() < 0.05 && (t.rightmost_rad + half_pi).abs() < 0.05, "{t:?}");
        assert!((t.reach_m - 20.0 - 15.0 * half_pi).abs() < 0.1, "{t:?}");
    }

    #[test]
    fn a_loop_of_lanes_ends_the_walk() {
        // A square block, each side's successor recorded (its corners are
        // too sharp to join by geometry).
        let mut sides = vec![
            lane(1, &[(0.0, 0.0), (10.0, 0.0)]),
            lane(2, &[(10.0, 0.0), (10.0, 10.0)]),
            lane(3, &[(10.0, 10.0), (0.0, 10.0)]),
            lane(4, &[(0.0, 10.0), (0.0, 0.0)]),
        ];
        for (i, side) in sides.iter_mut().enumerate() {
            side.successors.push(MapElementId((i as i64 + 1) % 4 + 1));
        }
        let m = map(sides);
        let g = LaneGraph::build(&m);
        assert_eq!(g.successors(3), &[0]);
        let t = g.turn_ahead(&m, 0, 0.0, 1000.0).unwrap();
        assert!(t.reach_m < 1000.0 && t.reach_m >= 100.0, "{t:?}");
    }
}
