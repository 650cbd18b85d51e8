//! The road map of a scenario: typed lane centrelines with connectivity,
//! road edges, road lines, crosswalks and other polygons, drivable areas,
//! stop signs and traffic-signal states, plus the spatial queries on them
//! (nearest lane, signed distance to the road edge, off-road test).
//!
//! Road edges follow the Waymo convention: oriented so the road is on their
//! port (left) side. Importers of polygon-based maps (CommonRoad lanelets,
//! Argoverse 2 drivable areas) also fill [`RoadMap::drivable_areas`]; when
//! those are present they decide on-/off-road and the edges give the
//! distance.
//!
//! The element types are in `elements`, the lane graph to look ahead on
//! in `lane_graph`, the lane queries in
//! `lane_queries`, the road-edge and off-road queries in
//! `road_edge_queries`; [`RoadMap`] itself (its elements, indices and
//! bookkeeping) is here.

mod elements;
mod junctions;
pub use junctions::JUNCTION_CROSSING_MIN_ANGLE_RAD;
pub mod lane_graph;
mod lane_queries;
pub mod lane_relations;
mod road_edge_queries;
pub use road_edge_queries::DRIVABLE_SEAM_M;
mod spatial_index;
pub mod templates;

pub use elements::{
    AreaKind, Lane, LaneKind, MapArea, MapElementId, RoadEdge, RoadEdgeKind, RoadLine, RoadLineKind, SignalState,
    StopSign, TrafficSignal,
};
pub use lane_queries::{
    ACROSS_LANES_MIN_ANGLE_RAD, ACROSS_LANES_MIN_SPEED_MPS, ALIGNED_LANE_MAX_ANGLE_RAD, DEFAULT_LANE_HALF_WIDTH_M,
    LANE_FOLLOW_LATERAL_M, LANE_FOLLOW_MARGIN_M, LaneMatch, MAX_LANE_HALF_WIDTH_M, MIN_LANE_HALF_WIDTH_M,
    OVERLAPPING_LANE_M, OWN_LANE_CLEARANCE_M, WRONG_WAY_MIN_ANGLE_RAD, WRONG_WAY_MIN_SPEED_MPS, lane_followed,
    length_followed_m,
};
pub use spatial_index::SegmentIndex;

use std::collections::BTreeMap;

use crate::geometry::{Point2, Polygon, Polyline};

/// The map of one scenario, in the scenario's local (re-centred) frame.
#[derive(Debug, Clone, Default)]
pub struct RoadMap {
    /// Lanes, sorted by id.
    pub lanes: Vec<Lane>,
    /// Road edges, road on the port side.
    pub road_edges: Vec<RoadEdge>,
    /// Painted lines.
    pub road_lines: Vec<RoadLine>,
    /// Crosswalks, speed bumps, driveways.
    pub areas: Vec<MapArea>,
    /// Drivable-area polygons where the source has them (lanelets, AV2
    /// drivable areas). Empty for WOMD, whose road edges decide alone.
    pub drivable_areas: Vec<Polygon>,
    /// Stop signs.
    pub stop_signs: Vec<StopSign>,
    /// Traffic signals per controlled lane.
    pub traffic_signals: Vec<TrafficSignal>,
    lane_index_by_id: BTreeMap<MapElementId, usize>,
    lane_segments: SegmentIndex,
    edge_segments: SegmentIndex,
    /// The bounds of each drivable area the map was built with (`None` for
    /// one without vertices).
    drivable_area_bounds: Vec<Option<(Point2, Point2)>>,
    /// The lane graph, built on first use ([`RoadMap::lane_graph`]).
    lane_graph: std::sync::OnceLock<lane_graph::LaneGraph>,
}

/// Element counts of a map, for summaries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct MapCounts {
    /// Lanes.
    pub lanes: usize,
    /// Lanes inside a junction ([`Lane::in_junction`]): flagged by the
    /// source, or crossing another lane on a map that flags none.
    pub junction_lanes: usize,
    /// Road edges.
    pub road_edges: usize,
    /// Road lines.
    pub road_lines: usize,
    /// Crosswalks.
    pub crosswalks: usize,
    /// Speed bumps.
    pub speed_bumps: usize,
    /// Driveways.
    pub driveways: usize,
    /// Drivable-area polygons.
    pub drivable_areas: usize,
    /// Stop signs.
    pub stop_signs: usize,
    /// Signal-controlled lanes.
    pub traffic_signals: usize,
}
impl RoadMap {
    /// A map of lanes alone (no road edges, lines, areas or signals), as a
    /// lane-graph source or a test scene needs.
    pub fn from_lanes(lanes: Vec<Lane>) -> Self {
        Self::new(lanes, Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new())
    }

    /// Builds a map and its spatial indices. Lanes are sorted by id so
    /// iteration order never depends on the source file's order.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        mut lanes: Vec<Lane>,
        road_edges: Vec<RoadEdge>,
        road_lines: Vec<RoadLine>,
        areas: Vec<MapArea>,
        drivable_areas: Vec<Polygon>,
        stop_signs: Vec<StopSign>,
        traffic_signals: Vec<TrafficSignal>,
    ) -> Self {
        lanes.sort_by_key(|l| l.id);
        let lane_index_by_id = lanes.iter().enumerate().map(|(i, l)| (l.id, i)).collect();
        let lane_segments = SegmentIndex::build(lanes.iter().map(|l| &l.centreline));
        let edge_segments = SegmentIndex::build(road_edges.iter().map(|e| &e.polyline));
        let drivable_area_bounds = drivable_areas.iter().map(Polygon::bounds).collect();
        Self {
            lanes,
            road_edges,
            road_lines,
            areas,
            drivable_areas,
            stop_signs,
            traffic_signals,
            lane_index_by_id,
            lane_segments,
            edge_segments,
            drivable_area_bounds,
            lane_graph: std::sync::OnceLock::new(),
        }
    }

    /// The lane graph to follow lanes on: each lane's recorded successors
    /// and predecessors, or where the source names none (GPUDrive's WOMD
    /// JSON names none at all) the lanes joined by geometry
    /// ([`lane_graph::LaneGraph::build`]). Built on first use, from the
    /// lanes as they are then.
    pub fn lane_graph(&self) -> &lane_graph::LaneGraph {
        self.lane_graph.get_or_init(|| lane_graph::LaneGraph::build(self))
    }

    /// The lanes that follow `lane` on the [`lane_graph`](Self::lane_graph),
    /// in the graph's order (none for a lane not on this map).
    pub fn lanes_after(&self, lane: MapElementId) -> Vec<&Lane> {
        let Some(i) = self.lane_index(lane) else { return Vec::new() };
        self.lane_graph().successors(i).iter().map(|&j| &self.lanes[j]).collect()
    }

    /// The lanes that lead into `lane` on the
    /// [`lane_graph`](Self::lane_graph), in the graph's order.
    pub fn lanes_before(&self, lane: MapElementId) -> Vec<&Lane> {
        let Some(i) = self.lane_index(lane) else { return Vec::new() };
        self.lane_graph().predecessors(i).iter().map(|&j| &self.lanes[j]).collect()
    }

    /// Rebuilds the map with every point moved by `-offset` (re-centring).
    pub fn translated(self, offset: &crate::geometry::Vector2) -> Self {
        let shift_line = |l: &Polyline| Polyline::new(l.points().iter().map(|p| p - offset).collect());
        let shift_poly = |p: &Polygon| Polygon::new(p.vertices.iter().map(|v| v - offset).collect());
        let lanes = self
            .lanes
            .into_iter()
            .map(|l| Lane {
                centreline: shift_line(&l.centreline),
                left_boundary: l.left_boundary.as_ref().map(shift_line),
                right_boundary: l.right_boundary.as_ref().map(shift_line),
                stop_line: l.stop_line.map(|p| p - offset),
                ..l
            })
            .collect();
        let road_edges =
            self.road_edges.into_iter().map(|e| RoadEdge { polyline: shift_line(&e.polyline), ..e }).collect();
        let road_lines =
            self.road_lines.into_iter().map(|e| RoadLine { polyline: shift_line(&e.polyline), ..e }).collect();
        let areas = self.areas.into_iter().map(|a| MapArea { polygon: shift_poly(&a.polygon), ..a }).collect();
        let drivable = self.drivable_areas.iter().map(shift_poly).collect();
        let stop_signs = self.stop_signs.into_iter().map(|s| StopSign { position: s.position - offset, ..s }).collect();
        let signals = self
            .traffic_signals
            .into_iter()
            .map(|s| TrafficSignal { stop_point: s.stop_point.map(|p| p - offset), ..s })
            .collect();
        RoadMap::new(lanes, road_edges, road_lines, areas, drivable, stop_signs, signals)
    }

    /// Element counts.
    pub fn counts(&self) -> MapCounts {
        let area = |k| self.areas.iter().filter(|a| a.kind == k).count();
        MapCounts {
            lanes: self.lanes.len(),
            junction_lanes: self.lanes.iter().filter(|l| l.in_junction()).count(),
            road_edges: self.road_edges.len(),
            road_lines: self.road_lines.len(),
            crosswalks: area(AreaKind::Crosswalk),
            speed_bumps: area(AreaKind::SpeedBump),
            driveways: area(AreaKind::Driveway),
            drivable_areas: self.drivable_areas.len(),
            stop_signs: self.stop_signs.len(),
            traffic_signals: self.traffic_signals.len(),
        }
    }

    /// True when the map has no lanes, edges or drivable areas.
    pub fn is_empty(&self) -> bool {
        self.lanes.is_empty() && self.road_edges.is_empty() && self.drivable_areas.is_empty()
    }

    /// The lane with this id.
    pub fn lane(&self, id: MapElementId) -> Option<&Lane> {
        self.lane_index_by_id.get(&id).map(|&i| &self.lanes[i])
    }

    /// Index of the lane with this id in [`RoadMap::lanes`].
    pub fn lane_index(&self, id: MapElementId) -> Option<usize> {
        self.lane_index_by_id.get(&id).copied()
    }
    /// The first map point with a coordinate that is not finite or exceeds
    /// `max_abs_m` in magnitude, as (which feature and point, the point).
    /// Features are visited in a fixed order: lanes (centreline, then
    /// boundaries), road edges, road lines, areas, drivable areas, stop
    /// signs, signal stop points. Importers use it to refuse absurd maps.
    pub fn first_point_outside(&self, max_abs_m: f64) -> Option<(String, Point2)> {
        let bad = |p: &Point2| !(p.x.abs() <= max_abs_m && p.y.abs() <= max_abs_m);
        let first = |what: &dyn Fn() -> String, pts: &[Point2]| {
            pts.iter().position(bad).map(|k| (format!("{}, point {k}", what()), pts[k]))
        };
        for l in &self.lanes {
            let lines = [Some(&l.centreline), l.left_boundary.as_ref(), l.right_boundary.as_ref()];
            let names = ["centreline", "left boundary", "right boundary"];
            for (line, name) in lines.iter().zip(names) {
                if let Some(found) = line.and_then(|line| first(&|| format!("lane {} {name}", l.id.0), line.points())) {
                    return Some(found);
                }
            }
        }
        let lines = self.road_edges.iter().map(|e| ("road edge", e.id, e.polyline.points()));
        let lines = lines.chain(self.road_lines.iter().map(|r| ("road line", r.id, r.polyline.points())));
        let lines = lines.chain(self.areas.iter().map(|a| ("area", a.id, a.polygon.vertices.as_slice())));
        for (kind, id, pts) in lines {
            if let Some(found) = first(&|| format!("{kind} {}", id.0), pts) {
                return Some(found);
            }
        }
        for (i, a) in self.drivable_areas.iter().enumerate() {
            if let Some(found) = first(&|| format!("drivable area {i}"), &a.vertices) {
                return Some(found);
            }
        }
        let stop_signs = self.stop_signs.iter().map(|s| (format!("stop sign {}", s.id.0), s.position));
        let signals =
            self.traffic_signals.iter().filter_map(|s| Some((format!("signal of lane {}", s.lane.0), s.stop_point?)));
        stop_signs.chain(signals).find(|(_, p)| bad(p))
    }

    /// The signal state of `lane` at `step`, if the lane is signal-controlled.
    pub fn signal_state(&self, lane: MapElementId, step: usize) -> Option<SignalState> {
        self.traffic_signals.iter().find(|s| s.lane == lane).and_then(|s| s.states.get(step).copied())
    }
}
#[cfg(test)]
mod tests {
    use super::*;

    /// A polyline through `pts`.
    pub(super) fn pl(pts: &[(f64, f64)]) -> Polyline {
        Polyline::new(pts.iter().map(|&(x, y)| Point2::new(x, y)).collect())
    }

    /// Two lanes along +x from 0 to 100 m (centrelines at y = 0 and 3.5)
    /// between road edges at y = -2 and 5.5.
    pub(super) fn straight_road() -> RoadMap {
        let lane = |id, y| Lane::new(MapElementId(id), pl(&[(0.0, y), (100.0, y)]));
        // Edges: right edge runs +x (road to its left), left edge runs -x.
        let edges = vec![
            RoadEdge {
                id: MapElementId(10),
                polyline: pl(&[(0.0, -2.0), (100.0, -2.0)]),
                kind: RoadEdgeKind::Boundary,
            },
            RoadEdge { id: MapElementId(11), polyline: pl(&[(100.0, 5.5), (0.0, 5.5)]), kind: RoadEdgeKind::Boundary },
        ];
        RoadMap::new(vec![lane(2, 3.5), lane(1, 0.0)], edges, vec![], vec![], vec![], vec![], vec![])
    }

    #[test]
    fn absurd_map_points_are_found_and_named_and_queries_on_them_end() {
        let map = straight_road();
        assert_eq!(map.first_point_outside(1e8), None);
        assert_eq!(map.first_point_outside(50.0).map(|(what, _)| what).as_deref(), Some("lane 1 centreline, point 1"));
        let far_edge =
            RoadEdge { id: MapElementId(12), polyline: pl(&[(0.0, 9.0), (1e20, 9.0)]), kind: RoadEdgeKind::Boundary };
        let nan_stop = StopSign { id: MapElementId(13), position: Point2::new(f64::NAN, 0.0), lanes: vec![] };
        let mut edges = map.road_edges.clone();
        edges.push(far_edge);
        // The index over a 1e20 m edge is built without walking ~1e19 grid cells.
        let map = RoadMap::new(map.lanes.clone(), edges, vec![], vec![], vec![], vec![nan_stop], vec![]);
        let (what, p) = map.first_point_outside(1e8).unwrap();
        assert_eq!((what.as_str(), p.x), ("road edge 12, point 1", 1e20));
        let map =
            RoadMap::new(map.lanes.clone(), straight_road().road_edges, vec![], vec![], vec![], map.stop_signs, vec![]);
        assert_eq!(map.first_point_outside(1e8).unwrap().0, "stop sign 13");
        // Queries at absurd points end with an answer or none.
        let map = straight_road();
        assert_eq!(map.signed_distance_to_road_edge(&Point2::new(f64::NAN, 0.0)), None);
        assert!(map.signed_distance_to_road_edge(&Point2::new(1e300, -1e300)).unwrap().abs() > 1e299);
        assert!(map.nearest_lane(&Point2::new(1e20, 0.0), None, 1e19).is_none());
        assert!(map.nearest_lane(&Point2::new(f64::INFINITY, 0.0), Some(f64::NAN), f64::INFINITY).is_none());
        assert!(map.nearest_lane(&Point2::new(50.0, 0.0), Some(0.0), f64::INFINITY).is_some());
    }
}
