//! Junction lanes of maps whose source flags none. WOMD (its protobuf and
//! GPUDrive's JSON) marks no lane as inside an intersection, while the
//! rules that leave a road user in an intersection alone (the wrong-way
//! and across-the-lanes tests: lanes cross at every angle there) need to
//! know where one is. Here a lane is taken to be inside a junction where
//! its centreline crosses another lane's at a junction's angle: a
//! crossing, not a fork or a merge at a lane's end, and not two lanes side
//! by side. The mark is [`Lane::crosses_lanes`](super::Lane), beside the
//! source's own flag, which the realism prior's map input keeps reading.

use super::RoadMap;
use crate::geometry::Point2;

/// The smallest angle between two lanes' directions, where their
/// centrelines cross, that makes both junction lanes, rad (30°, as the
/// across-the-lanes test's [`super::ACROSS_LANES_MIN_ANGLE_RAD`]: a merge
/// or a lane change meets its lane at less).
pub const JUNCTION_CROSSING_MIN_ANGLE_RAD: f64 = std::f64::consts::FRAC_PI_6;

/// A crossing this near a lane's start or end, m, is where lanes fork or
/// merge (a turn lane leaving its approach lane's end), not a junction's.
const LANE_END_CLEARANCE_M: f64 = 1.0;

impl RoadMap {
    /// Marks as inside a junction ([`Lane::crosses_lanes`](super::Lane))
    /// every lane whose centreline crosses another lane's centreline at
    /// [`JUNCTION_CROSSING_MIN_ANGLE_RAD`] or more (and at most that much
    /// short of head-on), more than a metre from both lanes' ends; returns
    /// how many lanes it marked. For maps
    /// whose source flags no junction lanes: a source's own flags are kept,
    /// and a lane is never unmarked. Lanes that cross on different levels
    /// (a flyover) cannot be told apart on a flat map and are marked too:
    /// the rules that read the flag then leave a road user there alone.
    pub fn mark_crossing_lanes_as_junctions(&mut self) -> usize {
        let min_sin = JUNCTION_CROSSING_MIN_ANGLE_RAD.sin();
        let mut crossing = vec![false; self.lanes.len()];
        for (i, lane) in self.lanes.iter().enumerate() {
            let points = lane.centreline.points();
            let length_m = lane.centreline.length_m();
            for (k, w) in points.windows(2).enumerate() {
                let (a, b) = (w[0], w[1]);
                let seg_m = (b - a).norm();
                let seg_start_m = lane.centreline.arc_length_at_point_m(k).unwrap_or(0.0);
                if !(seg_m > 1e-6 && seg_m.is_finite()) {
                    continue;
                }
                let mid = Point2::from((a.coords + b.coords) * 0.5);
                // Each pair of lanes is tried from the first of them, which
                // marks both; a segment in two cells is visited twice, to
                // the same effect.
                self.lane_segments.for_each_candidate(&mid, seg_m / 2.0 + 1e-3, |(j, sj)| {
                    let j = j as usize;
                    if j <= i || (crossing[i] && crossing[j]) {
                        return;
                    }
                    let other = &self.lanes[j];
                    let other_points = other.centreline.points();
                    let Some((c, d)) = other_points.get(sj as usize).zip(other_points.get(sj as usize + 1)) else {
                        return;
                    };
                    let Some((u, v)) = proper_crossing([a, b], [*c, *d]) else { return };
                    let (ab, cd) = (b - a, d - c);
                    let sin = (ab.x * cd.y - ab.y * cd.x).abs() / (seg_m * cd.norm());
                    if sin < min_sin {
                        return;
                    }
                    let at_m = seg_start_m + u * seg_m;
                    let other_at_m = other.centreline.arc_length_at_point_m(sj as usize).unwrap_or(0.0) + v * cd.norm();
                    let near_end = |s: f64, total: f64| s < LANE_END_CLEARANCE_M || total - s < LANE_END_CLEARANCE_M;
                    if near_end(at_m, length_m) || near_end(other_at_m, other.centreline.length_m()) {
                        return;
                    }
                    crossing[i] = true;
                    crossing[j] = true;
                });
            }
        }
        let mut marked = 0;
        for (lane, crosses) in self.lanes.iter_mut().zip(crossing) {
            if crosses && !lane.crosses_lanes {
                lane.crosses_lanes = true;
                marked += 1;
            }
        }
        marked
    }
}

/// Where segments `[a, b]` and `[c, d]` cross, as the fractions `(u, v)`
/// along each (both strictly inside), or `None` (parallel, apart, or
/// touching at an end).
fn proper_crossing([a, b]: [Point2; 2], [c, d]: [Point2; 2]) -> Option<(f64, f64)> {
    let r = b - a;
    let s = d - c;
    let denom = r.x * s.y - r.y * s.x;
    if denom.abs() < 1e-12 {
        return None;
    }
    let ac = c - a;
    let u = (ac.x * s.y - ac.y * s.x) / denom;
    let v = (ac.x * r.y - ac.y * r.x) / denom;
    ((0.0 < u && u < 1.0) && (0.0 < v && v < 1.0)).then_some((u, v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Polyline;
    use crate::map::{Lane, MapElementId};

    fn lane(id: i64, points: &[(f64, f64)]) -> Lane {
        Lane::new(MapElementId(id), Polyline::new(points.iter().map(|&(x, y)| Point2::new(x, y)).collect()))
    }

    #[test]
    fn lanes_that_cross_are_junction_lanes_and_lanes_that_fork_merge_or_run_beside_are_not() {
        let mut map = RoadMap::from_lanes(vec![
            // Two lanes east side by side, and one north across both: a
            // junction.
            lane(1, &[(-30.0, 0.0), (80.0, 0.0)]),
            lane(3, &[(-30.0, 3.5), (80.0, 3.5)]),
            lane(2, &[(0.0, -30.0), (0.0, 30.0)]),
            // A lane crossing both eastward lanes at 20°, past the
            // junction (a merge, a lane change): not a junction's angle.
            lane(4, &[(20.0, -11.0), (70.0, 7.2)]),
            // A turn lane forking off lane 5's end at 90°.
            lane(5, &[(-30.0, 40.0), (-10.0, 40.0)]),
            lane(6, &[(-10.0, 40.0), (-10.0, 60.0)]),
        ]);
        assert_eq!(map.mark_crossing_lanes_as_junctions(), 3);
        let flagged: Vec<i64> = map.lanes.iter().filter(|l| l.crosses_lanes).map(|l| l.id.0).collect();
        assert_eq!(flagged, vec![1, 2, 3]);
        // A second pass marks nothing more, and keeps the marks.
        assert_eq!(map.mark_crossing_lanes_as_junctions(), 0);
        assert!(map.lane(MapElementId(1)).unwrap().in_junction());
    }

    #[test]
    fn the_across_the_lanes_and_wrong_way_tests_leave_a_road_user_in_a_junction_alone() {
        // A crossroads of two lanes that flags nothing, as WOMD's maps: a
        // road user turning across it at 45° is across both lanes until
        // they are marked as a junction's.
        let mut map =
            RoadMap::from_lanes(vec![lane(1, &[(-30.0, 0.0), (30.0, 0.0)]), lane(2, &[(0.0, -30.0), (0.0, 30.0)])]);
        let (at, heading_rad) = (Point2::new(0.5, 0.5), std::f64::consts::FRAC_PI_4);
        assert!(map.angle_across_lanes_at(&at, heading_rad, 10.0).is_some());
        // Heading back across lane 1's traffic, off lane 2: against lane 1.
        let (off_lane_2, back_rad) = (Point2::new(8.0, 0.3), std::f64::consts::PI - 0.2);
        assert!(map.oncoming_lane_at(&off_lane_2, back_rad, 10.0).is_some());
        map.mark_crossing_lanes_as_junctions();
        assert_eq!(map.angle_across_lanes_at(&at, heading_rad, 10.0), None);
        assert_eq!(map.oncoming_lane_at(&off_lane_2, back_rad, 10.0), None);
        assert_eq!(map.counts().junction_lanes, 2);
    }

    #[test]
    fn a_crossing_at_a_lane_end_is_a_fork_not_a_junction() {
        // Lane 2 starts half a metre past lane 1's centreline: it crosses
        // lane 1 within a metre of its own start.
        let mut map =
            RoadMap::from_lanes(vec![lane(1, &[(-30.0, 0.0), (30.0, 0.0)]), lane(2, &[(0.0, -0.5), (0.0, 30.0)])]);
        assert_eq!(map.mark_crossing_lanes_as_junctions(), 0);
        assert_eq!(
            proper_crossing(
                [Point2::new(0.0, 0.0), Point2::new(1.0, 0.0)],
                [Point2::new(0.5, -1.0), Point2::new(0.5, 1.0)]
            ),
            Some((0.5, 0.5))
        );
    }
}
