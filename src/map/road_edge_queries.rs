//! Road-edge queries on a [`RoadMap`]: the nearest road edge, the signed
//! distance to it, whether a point is off the road, past the mapped end of
//! it, or off the road inside the mapped area.

use super::RoadMap;
use super::lane_graph::DeadEnd;
use super::lane_queries::DEFAULT_LANE_HALF_WIDTH_M;
use crate::geometry::{Point2, Polygon, PolylineProjection};

/// How close to a drivable area a point outside every one of them still
/// counts as on it, m. Lanelets that share a boundary in the source are
/// stored as separate polygons whose shared edges need not meet exactly (the
/// NGSIM maps have millimetre seams between neighbouring lanelets), and a
/// car's corner in such a seam is on the road, not as far off it as the
/// nearest road edge is.
pub const DRIVABLE_SEAM_M: f64 = 0.05;

/// Whether `p` lies within [`DRIVABLE_SEAM_M`] of the box `lo`–`hi` (an
/// area's bounds): elsewhere it is neither inside that area nor in a seam
/// of it.
fn near_bounds((lo, hi): &(Point2, Point2), p: &Point2) -> bool {
    p.x >= lo.x - DRIVABLE_SEAM_M
        && p.y >= lo.y - DRIVABLE_SEAM_M
        && p.x <= hi.x + DRIVABLE_SEAM_M
        && p.y <= hi.y + DRIVABLE_SEAM_M
}

/// Whether `p` lies within [`DRIVABLE_SEAM_M`] of `area`'s boundary.
fn within_seam_of(area: &Polygon, p: &Point2) -> bool {
    let n = area.vertices.len();
    (0..n).any(|i| {
        let ends = [area.vertices[i], area.vertices[(i + 1) % n]];
        crate::geometry::polyline::segment_distance_squared(&ends, p).0 <= DRIVABLE_SEAM_M * DRIVABLE_SEAM_M
    })
}

/// How far beside a lane's end, m, a point ahead of it may lie and still
/// be past the map's cut there (and the least radius the lane index is
/// searched for that lane).
const PAST_END_SEARCH_M: f64 = 10.0;
/// Far past the cut the lane's end is as far away as the edge's: the
/// search reaches that far beyond [`PAST_END_SEARCH_M`], up to this, m.
const FARTHEST_PAST_END_M: f64 = 100.0;
/// Beyond its lane's half width a vehicle's corner may stick out, m.
const CORRIDOR_MARGIN_M: f64 = 0.5;

/// A lane without successors that a point lies ahead of the end of.
struct EndBehind {
    /// The lane (an index into [`RoadMap::lanes`]).
    lane: usize,
    /// Where it ends.
    at: Point2,
    /// Whether the point is past the map there whatever road edges lie
    /// between (the nearest edge ends there too).
    past: bool,
}

/// Slack on a bound of the nearest road edge's distance, m: far above the
/// rounding of the distances it adds, far below anything that matters.
const BOUND_SLACK_M: f64 = 0.01;

impl RoadMap {
    /// Whether `p` is on a drivable area: inside one, or in a seam between
    /// two (within [`DRIVABLE_SEAM_M`] of one).
    fn on_drivable_area(&self, p: &Point2) -> bool {
        // Only the areas whose bounds come near `p` can hold it: most of a
        // map's lanelets are skipped without a look at their vertices.
        let near = || {
            self.drivable_areas.iter().enumerate().filter_map(|(i, area)| {
                // (An area added after the map was built has no bounds kept.)
                let bounds = self.drivable_area_bounds.get(i).copied().unwrap_or_else(|| area.bounds());
                bounds.is_some_and(|b| near_bounds(&b, p)).then_some(area)
            })
        };
        near().any(|a| a.contains(p)) || near().any(|a| within_seam_of(a, p))
    }

    /// The road edge nearest to `p` (its index) and `p`'s projection on it.
    /// `None` without edges, and for a non-finite point (the simulator
    /// refuses such states, and the ring search would never reach its bound).
    fn nearest_road_edge(&self, p: &Point2) -> Option<(usize, PolylineProjection)> {
        if !(p.x.is_finite() && p.y.is_finite()) {
            return None;
        }
        // Edges are searched in growing rings so most queries touch few cells;
        // the ring reaches the farthest indexed point after at most ~256
        // quadruplings even from 1e300 m away.
        let mut radius = 8.0;
        loop {
            // The last ring sees every edge: the nearest is whatever it finds
            // (at absurd coordinates, even a distance that overflowed).
            let last = radius >= self.edge_segments.max_distance_from(p);
            let best = self.nearest_road_edge_within(p, if last { f64::INFINITY } else { radius });
            if best.is_some() || last {
                break best;
            }
            radius *= 4.0;
        }
    }

    /// The nearest road edge to `p` if one lies within `radius_m` of it
    /// (`None` otherwise): by distance, ties to the lower edge index, and
    /// on that edge the projection onto its nearest segment, ties to the
    /// lower segment index. That is one order over all the (edge, segment)
    /// pairs, so the pairs are taken as the index yields them, unsorted,
    /// some twice, nearest cells first and cells wholly beyond the best so
    /// far (at first, beyond `radius_m`) skipped; only a NaN distance (from
    /// absurd map coordinates, where that order is not total) falls back to
    /// visiting them all sorted, edge by edge.
    fn nearest_road_edge_within(&self, p: &Point2, radius_m: f64) -> Option<(usize, PolylineProjection)> {
        // (distance, edge, distance², segment)
        let mut best: Option<(f64, usize, f64, usize)> = None;
        let mut nan = false;
        self.edge_segments.for_each_candidate_nearest_first(p, radius_m, |(edge, seg), ends| {
            let (edge, seg) = (edge as usize, seg as usize);
            let (d2, _) = crate::geometry::polyline::segment_distance_squared(ends, p);
            nan |= d2.is_nan();
            // Most candidates are clearly farther than the best so far:
            // their square root (the costly part of the key) is never
            // needed, and could not tie with the best's.
            if !best.is_some_and(|b| crate::geometry::clearly_farther_squared(d2, b.2)) {
                let key = (d2.sqrt(), edge, d2, seg);
                if best.is_none_or(|b| key < b) {
                    best = Some(key);
                }
            }
            // Nothing beyond the radius is wanted: it bounds the search
            // until a nearer edge does.
            best.map_or(radius_m, |b| b.0)
        });
        if !nan {
            return best.filter(|b| b.0 <= radius_m).and_then(|(_, edge, _, seg)| {
                self.road_edges[edge].polyline.project_segments(p, [seg]).map(|proj| (edge, proj))
            });
        }
        let mut pairs = Vec::new();
        self.edge_segments.candidate_pairs_into(p, radius_m, &mut pairs);
        let mut best: Option<(usize, PolylineProjection)> = None;
        for run in pairs.chunk_by(|a, b| a.0 == b.0) {
            let edge = run[0].0 as usize;
            let segs = run.iter().map(|&(_, seg)| seg as usize);
            if let Some(proj) = self.road_edges[edge].polyline.project_segments(p, segs)
                && best.is_none_or(|(_, b)| proj.distance_m < b.distance_m)
            {
                best = Some((edge, proj));
            }
        }
        best.filter(|(_, b)| b.distance_m <= radius_m)
    }

    /// Signed distance from `p` to the nearest road edge, metres: negative on
    /// the road, positive off it. Where drivable areas exist, membership in
    /// any of them (or a seam between them, see [`DRIVABLE_SEAM_M`]) decides
    /// the sign. `None` when the map has no road edges
    /// (or `p` is not finite).
    pub fn signed_distance_to_road_edge(&self, p: &Point2) -> Option<f64> {
        self.signed_distance_given(p, self.nearest_road_edge(p).as_ref())
    }

    /// [`Self::signed_distance_to_road_edge`] with [`Self::nearest_road_edge`]'s
    /// answer for `p` at hand.
    fn signed_distance_given(&self, p: &Point2, nearest: Option<&(usize, PolylineProjection)>) -> Option<f64> {
        let (_, nearest) = nearest?;
        if self.drivable_areas.is_empty() {
            Some(nearest.signed_distance_m)
        } else {
            Some(if self.on_drivable_area(p) { -nearest.distance_m } else { nearest.distance_m })
        }
    }

    /// Whether `p` lies more than `margin_m` (non-negative) past the road's
    /// edge: `signed_distance_to_road_edge(p) > margin_m`, answered without
    /// the nearest-edge search wherever an edge lies within `margin_m` (then
    /// the distance to the nearest one is at most that, whatever its side).
    pub fn is_beyond_road_edge(&self, p: &Point2, margin_m: f64) -> bool {
        let mut edge_within = false;
        self.edge_segments.for_each_run_within(p, margin_m, |_, _, ends| {
            edge_within = edge_within
                || ends
                    .iter()
                    .any(|ends| crate::geometry::polyline::segment_distance_squared(ends, p).0.sqrt() <= margin_m);
        });
        !edge_within && self.signed_distance_to_road_edge(p).is_some_and(|d| d > margin_m)
    }

    /// Whether `p` lies past the end of the mapped road, where the
    /// recording's map was cut off (NGSIM's study area, WOMD's crop) rather
    /// than at a dead end inside the map, whose kerbs go on around it: ahead
    /// of the end of a lane within 10 m that has no successor on the
    /// [lane graph](Self::lane_graph) (neither recorded nor a lane starting
    /// at its end: WOMD maps record no successors), and either
    /// past the end of the nearest road edge (its closest point is the
    /// edge's first or last point), or within the lane's own corridor (its
    /// half width at the end, plus 0.5 m) with no road edge between the
    /// lane's end and `p`. The corridor rule makes the answer the same
    /// whichever lane an ego leaves the map in: beside a road edge that goes
    /// on (a ramp, the other carriageway) the nearest edge does not end
    /// there. A vehicle there has left the mapped area rather than the road.
    pub fn is_past_mapped_end(&self, p: &Point2) -> bool {
        self.is_past_mapped_end_given(p, self.nearest_road_edge(p).as_ref())
    }

    /// [`Self::is_past_mapped_end`] with [`Self::nearest_road_edge`]'s answer
    /// for `p` at hand.
    fn is_past_mapped_end_given(&self, p: &Point2, nearest: Option<&(usize, PolylineProjection)>) -> bool {
        let (edge_ends_here, past_edge_end_m) = match nearest {
            None => (true, 0.0),
            Some(&(edge, proj)) => {
                let length = self.road_edges[edge].polyline.length_m();
                (proj.arc_length_m <= 1e-6 || proj.arc_length_m >= length - 1e-6, proj.distance_m)
            }
        };
        let search_m = PAST_END_SEARCH_M + past_edge_end_m.min(FARTHEST_PAST_END_M);
        // Only a lane without successors can end the map, and `p` must lie
        // ahead of its end and beside its line: those few lanes are found
        // first, and the lane index is asked only whether it offers one of
        // them within the search radius (the answer is the same as asking
        // it for all its lanes there and testing each, without collecting
        // them: that was the costly part of an off-road check, which the
        // adversary's search makes for every candidate state off the road).
        let ends = self.dead_ends_behind(p, edge_ends_here);
        if ends.is_empty() {
            return false;
        }
        let mut offered = vec![false; ends.len()];
        self.lane_segments.for_each_candidate(p, search_m, |(lane_index, _)| {
            if let Some(k) = ends.iter().position(|e| e.lane == lane_index as usize) {
                offered[k] = true;
            }
        });
        ends.iter().zip(offered).any(|(end, offered)| offered && (end.past || !self.road_edge_crosses(&end.at, p)))
    }

    /// The lanes without successors that `p` lies ahead of the end of and
    /// beside the line of: within [`PAST_END_SEARCH_M`] of it where the
    /// nearest road edge ends here (`edge_ends_here`; then `p` is past the
    /// map if the lane is near it), else within the lane's corridor (then
    /// only if no road edge lies between).
    fn dead_ends_behind(&self, p: &Point2, edge_ends_here: bool) -> Vec<EndBehind> {
        let graph = self.lane_graph();
        // Lanes added since the graph was built have no successors on it.
        let unlisted = (graph.lane_count()..self.lanes.len()).filter_map(|i| DeadEnd::of(i, &self.lanes[i]));
        graph
            .dead_ends()
            .iter()
            .copied()
            .chain(unlisted)
            .filter_map(|DeadEnd { lane, end, along }| {
                let from_end = p - end;
                let ahead = from_end.dot(&along);
                if ahead.is_nan() || ahead <= 0.0 {
                    return None;
                }
                let sideways = (from_end.x * along.y - from_end.y * along.x).abs();
                // Ahead of the end, within a lane's reach sideways of its line.
                if edge_ends_here && sideways <= PAST_END_SEARCH_M {
                    return Some(EndBehind { lane, at: end, past: true });
                }
                let l = self.lanes.get(lane)?;
                let half_width_m = match (&l.left_boundary, &l.right_boundary) {
                    (Some(left), Some(right)) => match (left.points().last(), right.points().last()) {
                        (Some(left), Some(right)) => 0.5 * (left - right).norm(),
                        _ => DEFAULT_LANE_HALF_WIDTH_M,
                    },
                    _ => DEFAULT_LANE_HALF_WIDTH_M,
                };
                (sideways <= half_width_m + CORRIDOR_MARGIN_M).then_some(EndBehind { lane, at: end, past: false })
            })
            .collect()
    }

    /// Whether a road edge crosses the segment from `a` to `b`.
    fn road_edge_crosses(&self, a: &Point2, b: &Point2) -> bool {
        let cross = |o: &Point2, p: &Point2, q: &Point2| (p.x - o.x) * (q.y - o.y) - (p.y - o.y) * (q.x - o.x);
        let (lo_x, hi_x) = (a.x.min(b.x), a.x.max(b.x));
        let (lo_y, hi_y) = (a.y.min(b.y), a.y.max(b.y));
        self.road_edges.iter().any(|edge| {
            edge.polyline.points().windows(2).any(|s| {
                let (c, d) = (&s[0], &s[1]);
                if c.x.max(d.x) < lo_x || c.x.min(d.x) > hi_x || c.y.max(d.y) < lo_y || c.y.min(d.y) > hi_y {
                    return false;
                }
                let (d1, d2) = (cross(c, d, a), cross(c, d, b));
                let (d3, d4) = (cross(a, b, c), cross(a, b, d));
                d1 * d2 <= 0.0 && d3 * d4 <= 0.0 && !(d1 == 0.0 && d2 == 0.0)
            })
        })
    }

    /// Whether `p` is off the road inside the mapped area: off the road
    /// ([`Self::is_off_road`]) and not past the mapped end of it
    /// ([`Self::is_past_mapped_end`]), where the road goes on beyond what
    /// the recording mapped. What a road user must not do; driving on past
    /// the map's cut is not leaving the road.
    pub fn is_off_road_within_map(&self, p: &Point2) -> bool {
        // The nearest edge is looked up once for both tests.
        let nearest = self.nearest_road_edge(p);
        self.is_off_road_given(p, nearest.as_ref()) && !self.is_past_mapped_end_given(p, nearest.as_ref())
    }

    /// Whether any of `points` is off the road inside the mapped area
    /// ([`Self::is_off_road_within_map`] of each, the same answers): the
    /// corners of one body, say. A point's nearest road edge is no farther
    /// than the one before's plus the distance between them, so only the
    /// first point needs the growing-ring search; each of the others is one
    /// search of that radius, which sees every edge at least as near.
    pub fn any_off_road_within_map(&self, points: &[Point2]) -> bool {
        let mut before: Option<(Point2, f64)> = None;
        points.iter().any(|p| {
            let nearest = self.nearest_road_edge_from(p, before);
            before = nearest.as_ref().map(|(_, proj)| (*p, proj.distance_m));
            self.is_off_road_given(p, nearest.as_ref()) && !self.is_past_mapped_end_given(p, nearest.as_ref())
        })
    }

    /// [`Self::nearest_road_edge`] of `p` (the same answer), given a point
    /// `before` and its nearest edge's distance, when one is known: the
    /// search then goes straight to the radius that bounds `p`'s.
    fn nearest_road_edge_from(&self, p: &Point2, before: Option<(Point2, f64)>) -> Option<(usize, PolylineProjection)> {
        // Beyond this one search would visit its cells unordered, slower
        // than the rings.
        const MAX_BOUNDED_SEARCH_M: f64 = 32.0;
        let bound_m = before.map(|(q, distance_m)| distance_m + (p - q).norm() + BOUND_SLACK_M);
        match bound_m {
            Some(r) if r <= MAX_BOUNDED_SEARCH_M && p.x.is_finite() && p.y.is_finite() => {
                self.nearest_road_edge_within(p, r).or_else(|| self.nearest_road_edge(p))
            }
            _ => self.nearest_road_edge(p),
        }
    }

    /// Whether `p` is off the road. Unknown (no edges, no drivable areas) is
    /// treated as on-road.
    pub fn is_off_road(&self, p: &Point2) -> bool {
        self.is_off_road_given(p, self.nearest_road_edge(p).as_ref())
    }

    /// [`Self::is_off_road`] with [`Self::nearest_road_edge`]'s answer for
    /// `p` at hand.
    fn is_off_road_given(&self, p: &Point2, nearest: Option<&(usize, PolylineProjection)>) -> bool {
        if self.road_edges.is_empty() && !self.drivable_areas.is_empty() {
            return !self.on_drivable_area(p);
        }
        self.signed_distance_given(p, nearest).is_some_and(|d| d > 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::tests::{pl, straight_road};
    use crate::map::{Lane, MapElementId, RoadEdge, RoadEdgeKind};

    /// A lane from x = 0 to 100 between edges at y = ±2 that stop with it
    /// (where a recording's map is cut off).
    fn cut_lane() -> RoadMap {
        let edge =
            |id, pts: &[(f64, f64)]| RoadEdge { id: MapElementId(id), polyline: pl(pts), kind: RoadEdgeKind::Boundary };
        RoadMap::new(
            vec![Lane::new(MapElementId(1), pl(&[(0.0, 0.0), (100.0, 0.0)]))],
            vec![edge(2, &[(0.0, -2.0), (100.0, -2.0)]), edge(3, &[(100.0, 2.0), (0.0, 2.0)])],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
        )
    }

    /// Two lanes with an acceleration lane ending inside the map, from
    /// the merge template (with its drivable areas).
    fn merge() -> RoadMap {
        crate::map::templates::Merge {
            lanes: 2,
            lane_width_m: 3.5,
            length_m: 200.0,
            merge_end_m: 120.0,
            acceleration_lane_m: 60.0,
            speed_limit_mps: None,
        }
        .build()
    }

    /// A four-arm crossing of one lane each way, from the template (with
    /// its drivable areas).
    fn crossing() -> RoadMap {
        crate::map::templates::Intersection {
            missing_arm: None,
            right_turn_lanes: false,
            lanes_per_direction: 1,
            lane_width_m: 3.5,
            arm_length_m: 40.0,
            green_s: None,
            speed_limit_mps: None,
        }
        .build()
    }

    #[test]
    fn a_seam_between_two_lanelet_polygons_is_on_the_road() {
        // The straight road's two lanes as separate drivable polygons with a
        // 1 cm seam between them at y = 1.75 (as NGSIM's lanelets are stored).
        let road = straight_road();
        let square = |y0: f64, y1: f64| {
            Polygon::new(vec![
                Point2::new(0.0, y0),
                Point2::new(100.0, y0),
                Point2::new(100.0, y1),
                Point2::new(0.0, y1),
            ])
        };
        let areas = vec![square(-2.0, 1.745), square(1.755, 5.5)];
        let map = RoadMap::new(road.lanes.clone(), road.road_edges.clone(), vec![], vec![], areas, vec![], vec![]);
        let seam = Point2::new(50.0, 1.75);
        assert!(!map.drivable_areas.iter().any(|a| a.contains(&seam)));
        assert!(!map.is_off_road(&seam));
        assert!(
            map.signed_distance_to_road_edge(&seam).is_some_and(|d| d < -3.0),
            "{:?}",
            map.signed_distance_to_road_edge(&seam)
        );
        // Past the edge, farther than a seam from either area, is off the road.
        let out = Point2::new(50.0, -2.0 - 2.0 * DRIVABLE_SEAM_M);
        assert!(map.is_off_road(&out));
        assert!(map.signed_distance_to_road_edge(&out).is_some_and(|d| d > 0.0));
    }

    #[test]
    fn beyond_the_road_edge_is_the_signed_distance_past_the_margin() {
        // On maps with and without drivable areas, on a grid that crosses
        // the edges (and lies on them and at the margin from them).
        let crossing = crossing();
        let (mut beyond, mut near) = (0, 0);
        for map in [&straight_road(), &crossing, &RoadMap::default()] {
            for i in -20..=120 {
                for j in -60..=60 {
                    let p = Point2::new(i as f64 * 0.5 - 5.0, j as f64 * 0.25 - 2.0);
                    for margin_m in [0.0, 0.5, 2.0] {
                        let expected = map.signed_distance_to_road_edge(&p).is_some_and(|d| d > margin_m);
                        assert_eq!(map.is_beyond_road_edge(&p, margin_m), expected, "{p:?} {margin_m}");
                        beyond += usize::from(expected);
                        near += usize::from(map.signed_distance_to_road_edge(&p).is_some_and(|d| d.abs() <= margin_m));
                    }
                }
            }
        }
        assert!(beyond > 1000 && near > 1000, "{beyond} {near}");
    }

    #[test]
    fn off_road_within_the_map_is_off_road_and_not_past_the_mapped_end() {
        // The combined query shares one nearest-edge lookup; its answer is
        // the two queries' everywhere, on maps with and without drivable
        // areas (the template's and the same edges alone).
        let merge = merge();
        let crossing = crossing();
        let edges_only =
            RoadMap::new(merge.lanes.clone(), merge.road_edges.clone(), vec![], vec![], vec![], vec![], vec![]);
        let mut off = 0;
        for map in [&merge, &crossing, &edges_only] {
            for i in 0..80 {
                for j in 0..40 {
                    let p = Point2::new(-60.0 + i as f64 * 4.1, -50.0 + j as f64 * 2.7);
                    let expected = map.is_off_road(&p) && !map.is_past_mapped_end(&p);
                    assert_eq!(map.is_off_road_within_map(&p), expected, "{p:?}");
                    off += usize::from(expected);
                }
            }
        }
        assert!(off > 100 && off < 3 * 80 * 40 - 100, "{off}");
    }

    #[test]
    fn past_the_mapped_end_only_where_lane_and_edges_stop() {
        // A lane from x = 0 to 100 between edges at y = ±2 that stop with it.
        let edge =
            |id, pts: &[(f64, f64)]| RoadEdge { id: MapElementId(id), polyline: pl(pts), kind: RoadEdgeKind::Boundary };
        let cut = cut_lane();
        let lane = cut.lanes[0].clone();
        assert!(cut.is_past_mapped_end(&Point2::new(101.0, 1.0)));
        assert!(cut.is_past_mapped_end(&Point2::new(125.0, 3.0)), "far past the cut, still ahead of the lane");
        assert!(!cut.is_past_mapped_end(&Point2::new(125.0, 15.0)), "ahead, but beside the lane's line");
        assert!(!cut.is_past_mapped_end(&Point2::new(50.0, 3.0)), "beside the lane: off-road");
        assert!(!cut.is_past_mapped_end(&Point2::new(-1.0, 0.0)), "before its start");
        // A lane that starts at its end, with no link recorded (WOMD maps
        // record none): a junction inside the map, not its end.
        let turn = Lane::new(MapElementId(4), pl(&[(100.0, 0.0), (105.0, 2.0), (110.0, 10.0)]));
        let junction =
            RoadMap::new(vec![lane.clone(), turn], cut.road_edges.clone(), vec![], vec![], vec![], vec![], vec![]);
        assert!(junction.lanes[0].successors.is_empty());
        assert!(!junction.is_past_mapped_end(&Point2::new(101.0, 1.0)));
        assert!(!junction.is_past_mapped_end(&Point2::new(104.0, -1.0)));
        // The same lane ending at a kerb that closes the road (a dead end
        // inside the map): past the lane's end, but the edge goes on.
        let dead_end = RoadMap::new(
            vec![lane],
            vec![edge(2, &[(0.0, -2.0), (103.0, -2.0), (103.0, 2.0), (0.0, 2.0)])],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
        );
        assert!(!dead_end.is_past_mapped_end(&Point2::new(104.0, 1.0)));
        // Off the road inside the map: beside the lane and at the dead end;
        // past the cut the road is not known to end. With the lane's
        // surface as a drivable area (as CommonRoad maps have) the point
        // past the cut is off the road; only the mapped area ends there.
        let lane_surface = crate::geometry::Polygon::new(
            [(0.0, -2.0), (100.0, -2.0), (100.0, 2.0), (0.0, 2.0)].iter().map(|&(x, y)| Point2::new(x, y)).collect(),
        );
        let cut = RoadMap { drivable_areas: vec![lane_surface], ..cut };
        let past = Point2::new(101.0, 1.0);
        assert!(cut.is_off_road(&past) && cut.is_past_mapped_end(&past));
        assert!(!cut.is_off_road_within_map(&past));
        assert!(cut.is_off_road_within_map(&Point2::new(50.0, 3.0)));
        assert!(dead_end.is_off_road_within_map(&Point2::new(104.0, 1.0)));
        assert!(!cut.is_off_road_within_map(&Point2::new(50.0, 1.0)), "on the road");
    }

    /// [`RoadMap::is_past_mapped_end`] as it reads: every lane the lane
    /// index offers within the search radius, tested in turn.
    fn past_mapped_end_lane_by_lane(map: &RoadMap, p: &Point2) -> bool {
        let (edge_ends_here, past_edge_end_m) = match map.nearest_road_edge(p) {
            None => (true, 0.0),
            Some((edge, proj)) => {
                let length = map.road_edges[edge].polyline.length_m();
                (proj.arc_length_m <= 1e-6 || proj.arc_length_m >= length - 1e-6, proj.distance_m)
            }
        };
        let search_m = 10.0 + past_edge_end_m.min(100.0);
        map.lane_segments.candidates(p, search_m).into_keys().any(|lane_index| {
            let lane = &map.lanes[lane_index];
            let points = lane.centreline.points();
            if !map.lane_graph().successors(lane_index).is_empty() || points.len() < 2 {
                return false;
            }
            let (a, b) = (points[points.len() - 2], points[points.len() - 1]);
            let along = (b - a).normalize();
            let from_end = p - b;
            let ahead = from_end.dot(&along);
            let sideways = (from_end.x * along.y - from_end.y * along.x).abs();
            if ahead.is_nan() || ahead <= 0.0 {
                return false;
            }
            if edge_ends_here && sideways <= 10.0 {
                return true;
            }
            let half_width_m = match (&lane.left_boundary, &lane.right_boundary) {
                (Some(l), Some(r)) => match (l.points().last(), r.points().last()) {
                    (Some(l), Some(r)) => 0.5 * (l - r).norm(),
                    _ => 1.85,
                },
                _ => 1.85,
            };
            sideways <= half_width_m + 0.5 && !map.road_edge_crosses(&b, p)
        })
    }

    #[test]
    fn asking_the_lane_index_only_for_dead_ends_answers_as_testing_every_lane() {
        // The merge (its acceleration lane ends inside the map, its lanes
        // at the map's ends), the crossing (every arm cut off), a lane cut
        // with its edges, and the merge with a lane added after its graph
        // was built (a dead end the graph does not list).
        let merge = merge();
        let cut = cut_lane();
        let mut grown = merge.clone();
        let _ = grown.lane_graph();
        grown.lanes.push(Lane::new(MapElementId(999), pl(&[(-40.0, -20.0), (0.0, -20.0)])));
        let (mut past, mut not) = (0, 0);
        for map in [&merge, &crossing(), &cut, &grown] {
            for i in 0..120 {
                for j in 0..60 {
                    let p = Point2::new(-70.0 + i as f64 * 2.9, -55.0 + j as f64 * 1.9);
                    let expected = past_mapped_end_lane_by_lane(map, &p);
                    assert_eq!(map.is_past_mapped_end(&p), expected, "{p:?}");
                    if expected { past += 1 } else { not += 1 }
                }
            }
        }
        assert!(past > 200 && not > 200, "{past} {not}");
    }

    #[test]
    fn the_unsorted_nearest_edge_search_answers_as_the_sorted_one() {
        // Edges on a lattice, so distances tie between edges and between
        // segments of one edge, plus a duplicate edge and one that doubles
        // back on itself; queries on the lattice too.
        let edge = |id, pts: Vec<(f64, f64)>| RoadEdge {
            id: MapElementId(id),
            polyline: pl(&pts),
            kind: RoadEdgeKind::Boundary,
        };
        let mut edges: Vec<RoadEdge> = (0..12)
            .map(|k| {
                let (x0, y0) = ((k % 4) as f64 * 10.0, (k / 4) as f64 * 10.0);
                edge(k, vec![(x0, y0), (x0 + 10.0, y0), (x0 + 10.0, y0 + 10.0), (x0, y0 + 10.0)])
            })
            .collect();
        edges.push(edge(20, vec![(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]));
        edges.push(edge(21, vec![(5.0, 5.0), (25.0, 5.0), (5.0, 5.0), (5.0, 25.0)]));
        let map = RoadMap::new(vec![], edges, vec![], vec![], vec![], vec![], vec![]);
        let sorted = |p: &Point2, r: f64| {
            let mut best: Option<(usize, PolylineProjection)> = None;
            for (edge, segs) in map.edge_segments.candidates(p, r) {
                if let Some(proj) = map.road_edges[edge].polyline.project_segments(p, segs)
                    && best.is_none_or(|(_, b)| proj.distance_m < b.distance_m)
                {
                    best = Some((edge, proj));
                }
            }
            best
        };
        let mut checked = 0;
        for i in 0..=50 {
            for j in 0..=40 {
                let p = Point2::new(i as f64 * 1.25 - 5.0, j as f64 * 1.25 - 5.0);
                for r in [0.5, 8.0, 32.0, f64::INFINITY] {
                    let plain = sorted(&p, r).filter(|(_, b)| b.distance_m <= r);
                    let fast = map.nearest_road_edge_within(&p, r);
                    assert_eq!(format!("{fast:?}"), format!("{plain:?}"), "{p:?} r {r}");
                    checked += usize::from(plain.is_some());
                }
            }
        }
        assert!(checked > 5000, "{checked}");
    }

    #[test]
    fn a_search_bounded_by_a_neighbours_edge_finds_what_the_ring_search_finds() {
        // On the crossing (drivable areas decide the side) and on a lattice
        // of edges (distances tie), bodies at random poses from the middle to
        // far outside: each corner's nearest edge, and the body's verdict,
        // are the corner-by-corner ones.
        let lattice = RoadMap::new(
            vec![],
            (0..12)
                .map(|k| {
                    let (x0, y0) = ((k % 4) as f64 * 10.0, (k / 4) as f64 * 10.0);
                    RoadEdge {
                        id: MapElementId(k),
                        polyline: pl(&[(x0, y0), (x0 + 10.0, y0), (x0 + 10.0, y0 + 10.0), (x0, y0 + 10.0)]),
                        kind: RoadEdgeKind::Boundary,
                    }
                })
                .collect(),
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
        );
        let mut state = 7u64;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for map in [crossing(), lattice] {
            let (mut off, mut on) = (0, 0);
            for _ in 0..4000 {
                let reach_m = if next() < 0.8 { 45.0 } else { 150.0 };
                let centre = Point2::new((next() * 2.0 - 1.0) * reach_m, (next() * 2.0 - 1.0) * reach_m);
                let body = crate::geometry::OrientedBox::new(
                    crate::geometry::Pose2 { position: centre, heading_rad: next() * 7.0 },
                    1.0 + next() * 12.0,
                    1.0 + next() * 2.0,
                );
                let corners = body.corners();
                let mut before = None;
                for c in &corners {
                    let (chained, ring) = (map.nearest_road_edge_from(c, before), map.nearest_road_edge(c));
                    assert_eq!(format!("{chained:?}"), format!("{ring:?}"), "{c:?} after {before:?}");
                    before = ring.map(|(_, proj)| (*c, proj.distance_m));
                }
                let each = corners.iter().any(|c| map.is_off_road_within_map(c));
                assert_eq!(map.any_off_road_within_map(&corners), each, "{body:?}");
                (off, on) = if each { (off + 1, on) } else { (off, on + 1) };
            }
            assert!(off > 100 && on > 100, "{off} off, {on} on");
        }
    }

    #[test]
    fn skipping_the_drivable_areas_whose_bounds_are_far_changes_no_answer() {
        // Points on, just inside and just outside every area's boundary
        // (the seams), and scattered over the crossing and beyond it.
        let map = crossing();
        assert!(map.drivable_areas.len() > 4);
        let every_area = |p: &Point2| {
            map.drivable_areas.iter().any(|a| a.contains(p))
                || map
                    .drivable_areas
                    .iter()
                    .flat_map(|a| a.boundary_ccw().points().windows(2).map(|w| [w[0], w[1]]).collect::<Vec<_>>())
                    .any(|ends| {
                        crate::geometry::polyline::segment_distance_squared(&ends, p).0
                            <= DRIVABLE_SEAM_M * DRIVABLE_SEAM_M
                    })
        };
        let mut points: Vec<Point2> = Vec::new();
        for area in &map.drivable_areas {
            for v in &area.vertices {
                for (dx, dy) in [
                    (0.0, 0.0),
                    (0.04, 0.0),
                    (-0.04, 0.0),
                    (-0.06, 0.0),
                    (0.0, 0.049),
                    (0.0, -0.049),
                    (0.0, -0.051),
                    (0.3, -0.3),
                ] {
                    points.push(v + crate::geometry::Vector2::new(dx, dy));
                }
            }
        }
        points.extend((0..=120).flat_map(|i| (0..=120).map(move |j| Point2::new(i as f64 - 60.0, j as f64 - 60.0))));
        let on = points.iter().filter(|p| map.on_drivable_area(p)).count();
        for p in &points {
            assert_eq!(map.on_drivable_area(p), every_area(p), "{p:?}");
        }
        assert!(on > 500 && on < points.len() - 500, "{on} of {}", points.len());
    }

    #[test]
    fn road_edge_sign_and_off_road() {
        let m = straight_road();
        let inside = m.signed_distance_to_road_edge(&Point2::new(30.0, 0.0)).unwrap();
        assert!((inside + 2.0).abs() < 1e-9, "{inside}");
        let outside = m.signed_distance_to_road_edge(&Point2::new(30.0, 9.0)).unwrap();
        assert!((outside - 3.5).abs() < 1e-9, "{outside}");
        assert!(m.is_off_road(&Point2::new(30.0, -3.0)));
        assert!(!m.is_off_road(&Point2::new(30.0, 1.0)));
        // Far away: the ring search widens until it finds an edge.
        let far = m.signed_distance_to_road_edge(&Point2::new(30.0, 300.0)).unwrap();
        assert!((far - 294.5).abs() < 1e-9, "{far}");
    }
}
