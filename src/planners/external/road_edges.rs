//! The road edges a planner is sent: the map's edges less the stretches
//! that are not the outer boundary of the drivable area. Recorded maps
//! build their edges from lane bounds without a neighbour, and two kinds
//! of those are no kerb: a bound with another lane right beyond it (lanes
//! the source does not call adjacent), and the bound of a lane inside an
//! intersection with the junction's other lanes beyond it (a turning
//! lane's inner side crosses the junction area). A planner that treats
//! edges as walls finds no way through a junction with them, so they are
//! cut out here, by the lane polygons, once per map; maps without lane
//! boundaries (WOMD) keep their edges as they are.

use crate::geometry::{Point2, Polygon, Polyline, Vector2};
use crate::map::RoadMap;
use crate::planners::lane_walk::samples;

/// How far beyond an edge (on its off-road side) a lane must not begin, m:
/// a bound with a lane this close is a bound between lanes.
pub const BETWEEN_LANES_PROBE_M: f64 = 0.3;

/// How far beyond an intersection lane's bound other lanes are looked
/// for, m: a bound with a lane within this distance crosses the junction
/// area, one without is the junction's kerb.
pub const JUNCTION_REACH_M: f64 = 15.0;

/// Step of the probes along the ray beyond an intersection lane's bound, m.
const JUNCTION_PROBE_STEP_M: f64 = 0.5;

/// How close a sample of an edge lies to an intersection lane's bound for
/// it to be that bound, m (edges are cut from the bounds themselves).
const ON_BOUND_M: f64 = 0.15;

/// A lane's area with its bounding box, for quick rejects.
struct LaneArea {
    min: Point2,
    max: Point2,
    polygon: Polygon,
}

impl LaneArea {
    fn contains(&self, p: &Point2) -> bool {
        p.x >= self.min.x && p.x <= self.max.x && p.y >= self.min.y && p.y <= self.max.y && self.polygon.contains(p)
    }
}

/// The lane polygons and intersection bounds of a map.
struct Lanes<'m> {
    areas: Vec<LaneArea>,
    intersection_bounds: Vec<&'m Polyline>,
}

impl<'m> Lanes<'m> {
    fn of(map: &'m RoadMap) -> Self {
        let mut areas = Vec::new();
        let mut intersection_bounds = Vec::new();
        for lane in &map.lanes {
            let (Some(left), Some(right)) = (&lane.left_boundary, &lane.right_boundary) else { continue };
            let vertices: Vec<Point2> = right.points().iter().chain(left.points().iter().rev()).copied().collect();
            if vertices.len() < 3 || vertices.iter().any(|p| !(p.x.is_finite() && p.y.is_finite())) {
                continue;
            }
            let fold = |f: fn(f64, f64) -> f64| {
                vertices.iter().fold(vertices[0], |a, p| Point2::new(f(a.x, p.x), f(a.y, p.y)))
            };
            let (min, max) = (fold(f64::min), fold(f64::max));
            areas.push(LaneArea { min, max, polygon: Polygon::new(vertices) });
            if lane.in_intersection {
                intersection_bounds.extend([left, right]);
            }
        }
        Lanes { areas, intersection_bounds }
    }

    fn in_a_lane(&self, p: &Point2) -> bool {
        self.areas.iter().any(|a| a.contains(p))
    }

    fn on_intersection_bound(&self, p: &Point2) -> bool {
        self.intersection_bounds.iter().any(|b| b.project(p).is_some_and(|q| q.distance_m <= ON_BOUND_M))
    }

    /// Whether the segment `a`–`b` of an edge (road on its left) is a real
    /// road edge: no lane just beyond it, and, along an intersection
    /// lane's bound, none within [`JUNCTION_REACH_M`] beyond it.
    fn is_road_edge(&self, a: &Point2, b: &Point2) -> bool {
        let along: Vector2 = b - a;
        let length = along.norm();
        if length.is_nan() || length <= 1e-9 {
            return true;
        }
        let beyond = Vector2::new(along.y, -along.x) / length;
        let middle = Point2::from((a.coords + b.coords) * 0.5);
        if self.in_a_lane(&(middle + beyond * BETWEEN_LANES_PROBE_M)) {
            return false;
        }
        if !(self.on_intersection_bound(a) && self.on_intersection_bound(b)) {
            return true;
        }
        let probes = (JUNCTION_REACH_M / JUNCTION_PROBE_STEP_M) as usize;
        !(1..=probes).any(|k| self.in_a_lane(&(middle + beyond * (k as f64 * JUNCTION_PROBE_STEP_M))))
    }
}

/// The map's road edges as the protocol sends them: each resampled every
/// [`super::MAP_SPACING_M`] or less, with the stretches that are not the
/// drivable area's outer boundary cut out (a cut edge goes on as separate
/// pieces; pieces of a single point are dropped). In the map's edge order.
pub(super) fn road_edges(map: &RoadMap) -> Vec<Polyline> {
    let lanes = Lanes::of(map);
    let mut out = Vec::new();
    for edge in &map.road_edges {
        let points: Vec<Point2> = samples(&edge.polyline, 0.0, edge.polyline.length_m()).collect();
        if lanes.areas.is_empty() {
            out.push(Polyline::new(points));
            continue;
        }
        let mut piece: Vec<Point2> = Vec::new();
        for pair in points.windows(2) {
            if lanes.is_road_edge(&pair[0], &pair[1]) {
                if piece.is_empty() {
                    piece.push(pair[0]);
                }
                piece.push(pair[1]);
            } else if piece.len() >= 2 {
                out.push(Polyline::new(std::mem::take(&mut piece)));
            } else {
                piece.clear();
            }
        }
        if piece.len() >= 2 {
            out.push(Polyline::new(piece));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::{Lane, MapElementId, RoadEdge, RoadEdgeKind};

    fn pl(points: &[(f64, f64)]) -> Polyline {
        Polyline::new(points.iter().map(|&(x, y)| Point2::new(x, y)).collect())
    }

    fn lane(id: i64, left: &[(f64, f64)], right: &[(f64, f64)], in_intersection: bool) -> Lane {
        let (l, r) = (pl(left), pl(right));
        let centre = Polyline::new(
            l.points().iter().zip(r.points()).map(|(a, b)| Point2::from((a.coords + b.coords) * 0.5)).collect(),
        );
        Lane { left_boundary: Some(l), right_boundary: Some(r), in_intersection, ..Lane::new(MapElementId(id), centre) }
    }

    fn edge(id: i64, points: &[(f64, f64)]) -> RoadEdge {
        RoadEdge { id: MapElementId(id), polyline: pl(points), kind: RoadEdgeKind::Boundary }
    }

    #[test]
    fn kerbs_stay_bounds_between_lanes_and_across_a_junction_go() {
        // A road along +x (y in 0..3.5) and, 1 m beyond its right kerb, a
        // lane the map does not call adjacent (y in -4.5..-1); a junction
        // lane (y in 10..13.5) with another junction lane 5 m beyond its
        // right bound (y in 1.5..5, x in 100..110), and its left bound a
        // kerb with nothing beyond.
        let map = RoadMap::new(
            vec![
                lane(1, &[(0.0, 3.5), (50.0, 3.5)], &[(0.0, 0.0), (50.0, 0.0)], false),
                lane(2, &[(0.0, -1.2), (50.0, -1.2)], &[(0.0, -4.5), (50.0, -4.5)], false),
                lane(3, &[(100.0, 13.5), (110.0, 13.5)], &[(100.0, 10.0), (110.0, 10.0)], true),
                lane(4, &[(100.0, 5.0), (110.0, 5.0)], &[(100.0, 1.5), (110.0, 1.5)], true),
            ],
            vec![
                // Lane 1's right bound: lane 2 lies 1.2 m beyond, not 0.3 m: a kerb.
                edge(10, &[(0.0, 0.0), (50.0, 0.0)]),
                // Lane 2's left bound reversed (road on its left): lane 1 is 1.2 m beyond, kept.
                edge(11, &[(50.0, -1.2), (0.0, -1.2)]),
                // A line inside lane 1: the lane lies beyond it.
                edge(12, &[(0.0, 3.4), (50.0, 3.4)]),
                // Lane 3's right bound: lane 4 within 15 m beyond.
                edge(13, &[(100.0, 10.0), (110.0, 10.0)]),
                // Lane 3's left bound reversed: nothing beyond.
                edge(14, &[(110.0, 13.5), (100.0, 13.5)]),
            ],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
        );
        let edges = road_edges(&map);
        let ends = |e: &Polyline| (*e.points().first().unwrap(), *e.points().last().unwrap());
        let kept: Vec<(Point2, Point2)> = edges.iter().map(ends).collect();
        assert_eq!(
            kept,
            vec![
                (Point2::new(0.0, 0.0), Point2::new(50.0, 0.0)),
                (Point2::new(50.0, -1.2), Point2::new(0.0, -1.2)),
                (Point2::new(110.0, 13.5), Point2::new(100.0, 13.5)),
            ],
            "{edges:?}"
        );
        // Resampled every 2 m or less.
        assert!(edges[0].points().windows(2).all(|w| (w[1] - w[0]).norm() <= 2.0 + 1e-9));
    }

    #[test]
    fn a_bound_cut_in_the_middle_goes_on_in_two_pieces() {
        // A lane along +x and, beyond its right kerb for x in 20..30 only,
        // another lane touching it.
        let map = RoadMap::new(
            vec![
                lane(1, &[(0.0, 3.5), (50.0, 3.5)], &[(0.0, 0.0), (50.0, 0.0)], false),
                lane(2, &[(20.0, 0.0), (30.0, 0.0)], &[(20.0, -3.5), (30.0, -3.5)], false),
            ],
            vec![edge(10, &[(0.0, 0.0), (50.0, 0.0)])],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
        );
        let edges = road_edges(&map);
        assert_eq!(edges.len(), 2, "{edges:?}");
        assert_eq!(edges[0].points().last().unwrap().x, 20.0);
        assert_eq!(edges[1].points().first().unwrap().x, 30.0);
    }
}
