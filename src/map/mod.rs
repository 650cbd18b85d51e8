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

mod spatial_index;
pub mod templates;

pub use spatial_index::SegmentIndex;

use std::collections::BTreeMap;

use crate::geometry::{Point2, Polygon, Polyline, PolylineProjection};

/// A lane's half-width where the source maps no boundary on that side, m
/// (half of a 3.7 m lane, the US freeway standard and WOMD's typical width).
pub const DEFAULT_LANE_HALF_WIDTH_M: f64 = 1.85;
/// The narrowest half-width a mapped boundary may give a lane, m.
pub const MIN_LANE_HALF_WIDTH_M: f64 = 1.2;
/// The widest half-width a mapped boundary may give a lane, m (a boundary
/// farther than this is a shoulder or a road edge, not the lane's).
pub const MAX_LANE_HALF_WIDTH_M: f64 = 2.5;

/// The largest angle between an agent's heading and a lane's direction at
/// which the lane still counts as going the agent's way (lane changes and
/// the start of a turn stay well inside it; a crossing lane does not).
pub const ALIGNED_LANE_MAX_ANGLE_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// Identifier of a map element, unique within one map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct MapElementId(pub i64);

/// What kind of lane a centreline belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LaneKind {
    /// Source does not say.
    #[default]
    Undefined,
    /// Freeway lane.
    Freeway,
    /// Surface-street lane.
    SurfaceStreet,
    /// Bike lane.
    BikeLane,
    /// Bus lane.
    BusLane,
}

/// A lane: its centreline in driving direction and its connectivity.
#[derive(Debug, Clone, PartialEq)]
pub struct Lane {
    /// Map-unique id.
    pub id: MapElementId,
    /// Centreline, in the direction of travel.
    pub centreline: Polyline,
    /// Lane type.
    pub kind: LaneKind,
    /// Speed limit where the source gives one, m/s.
    pub speed_limit_mps: Option<f64>,
    /// Lanes whose end connects to this lane's start.
    pub predecessors: Vec<MapElementId>,
    /// Lanes this lane's end connects to.
    pub successors: Vec<MapElementId>,
    /// Neighbouring lanes on the left (same direction unless the source says otherwise).
    pub left_neighbours: Vec<MapElementId>,
    /// Neighbouring lanes on the right.
    pub right_neighbours: Vec<MapElementId>,
    /// Left boundary, where the source has one.
    pub left_boundary: Option<Polyline>,
    /// Right boundary, where the source has one.
    pub right_boundary: Option<Polyline>,
    /// Whether this lane lies inside an intersection.
    pub in_intersection: bool,
    /// Midpoint of the lane's stop line, where the source has one
    /// (CommonRoad `stopLine`, also on lanes without a signal).
    pub stop_line: Option<Point2>,
}

impl Lane {
    /// A lane with this centreline and no connectivity, bounds or limits
    /// (fill in what the source has).
    pub fn new(id: MapElementId, centreline: Polyline) -> Self {
        Self {
            id,
            centreline,
            kind: LaneKind::Undefined,
            speed_limit_mps: None,
            predecessors: vec![],
            successors: vec![],
            left_neighbours: vec![],
            right_neighbours: vec![],
            left_boundary: None,
            right_boundary: None,
            in_intersection: false,
            stop_line: None,
        }
    }
}

/// Kind of a road edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RoadEdgeKind {
    /// Source does not say.
    #[default]
    Unknown,
    /// Physical road boundary (curb).
    Boundary,
    /// Median between opposing carriageways.
    Median,
}

/// A road edge, oriented with the road on its port side.
#[derive(Debug, Clone, PartialEq)]
pub struct RoadEdge {
    /// Map-unique id.
    pub id: MapElementId,
    /// The edge, road to the left.
    pub polyline: Polyline,
    /// Edge type.
    pub kind: RoadEdgeKind,
}

/// Painted line type of a road line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RoadLineKind {
    /// Source does not say.
    #[default]
    Unknown,
    /// Broken single white.
    BrokenSingleWhite,
    /// Solid single white.
    SolidSingleWhite,
    /// Solid double white.
    SolidDoubleWhite,
    /// Broken single yellow.
    BrokenSingleYellow,
    /// Broken double yellow.
    BrokenDoubleYellow,
    /// Solid single yellow.
    SolidSingleYellow,
    /// Solid double yellow.
    SolidDoubleYellow,
    /// Passing double yellow.
    PassingDoubleYellow,
}

impl RoadLineKind {
    /// From the WOMD `RoadLine.type` enum value.
    pub fn from_womd(code: i32) -> Self {
        match code {
            1 => Self::BrokenSingleWhite,
            2 => Self::SolidSingleWhite,
            3 => Self::SolidDoubleWhite,
            4 => Self::BrokenSingleYellow,
            5 => Self::BrokenDoubleYellow,
            6 => Self::SolidSingleYellow,
            7 => Self::SolidDoubleYellow,
            8 => Self::PassingDoubleYellow,
            _ => Self::Unknown,
        }
    }
}

/// A painted road line (lane divider).
#[derive(Debug, Clone, PartialEq)]
pub struct RoadLine {
    /// Map-unique id.
    pub id: MapElementId,
    /// The line.
    pub polyline: Polyline,
    /// Line type.
    pub kind: RoadLineKind,
}

/// Kind of an area element of the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum AreaKind {
    /// Pedestrian crosswalk.
    Crosswalk,
    /// Speed bump.
    SpeedBump,
    /// Driveway.
    Driveway,
}

/// A polygonal map element (crosswalk, speed bump, driveway).
#[derive(Debug, Clone, PartialEq)]
pub struct MapArea {
    /// Map-unique id.
    pub id: MapElementId,
    /// What it is.
    pub kind: AreaKind,
    /// Its outline.
    pub polygon: Polygon,
}

/// A stop sign and the lanes it controls.
#[derive(Debug, Clone, PartialEq)]
pub struct StopSign {
    /// Map-unique id.
    pub id: MapElementId,
    /// Position of the sign.
    pub position: Point2,
    /// Controlled lanes.
    pub lanes: Vec<MapElementId>,
}

/// State of a traffic signal for one lane at one step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SignalState {
    /// Unknown or not observed.
    #[default]
    Unknown,
    /// Red arrow.
    ArrowStop,
    /// Yellow arrow.
    ArrowCaution,
    /// Green arrow.
    ArrowGo,
    /// Red.
    Stop,
    /// Yellow.
    Caution,
    /// Green.
    Go,
    /// Flashing red.
    FlashingStop,
    /// Flashing yellow.
    FlashingCaution,
}

impl SignalState {
    /// From the WOMD `TrafficSignalLaneState.State` enum value.
    pub fn from_womd(code: i32) -> Self {
        match code {
            1 => Self::ArrowStop,
            2 => Self::ArrowCaution,
            3 => Self::ArrowGo,
            4 => Self::Stop,
            5 => Self::Caution,
            6 => Self::Go,
            7 => Self::FlashingStop,
            8 => Self::FlashingCaution,
            _ => Self::Unknown,
        }
    }

    /// Whether a vehicle facing this signal must stop.
    pub fn requires_stop(self) -> bool {
        matches!(self, Self::ArrowStop | Self::Stop | Self::FlashingStop)
    }
}

/// The signal controlling one lane over the scenario's steps. Traffic on
/// `lane` must stop at the lane's *end* (its stop line, `stop_point` where
/// the source gives one) while the state requires stopping; every importer
/// and the template intersection place signals on the lane that leads into
/// the junction, and the lane follower and evasive planner stop there.
#[derive(Debug, Clone, PartialEq)]
pub struct TrafficSignal {
    /// Controlled lane (the one ending at the stop line).
    pub lane: MapElementId,
    /// Stop line point, where known.
    pub stop_point: Option<Point2>,
    /// State per scenario step (same length as the tracks).
    pub states: Vec<SignalState>,
}

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
}

/// Element counts of a map, for summaries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct MapCounts {
    /// Lanes.
    pub lanes: usize,
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

/// Nearest-lane query result.
#[derive(Debug, Clone, Copy)]
pub struct LaneMatch {
    /// Index into [`RoadMap::lanes`].
    pub lane_index: usize,
    /// Projection of the query point on the lane's centreline.
    pub projection: PolylineProjection,
}

impl RoadMap {
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
        }
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

    /// The lane centreline closest to `p` within `radius_m`, preferring
    /// lanes whose direction agrees with `heading_rad` (when given) to within
    /// [`ALIGNED_LANE_MAX_ANGLE_RAD`]: at an intersection a crossing lane
    /// may be nearer than the agent's own, and is not the agent's. Ties
    /// break on lane id, so the answer is deterministic.
    pub fn nearest_lane(&self, p: &Point2, heading_rad: Option<f64>, radius_m: f64) -> Option<LaneMatch> {
        thread_local! {
            // Each candidate lane's nearest segment so far, reused from call
            // to call: this query runs in hot loops (every step of every
            // prediction), where allocating and sorting per call showed.
            static NEAREST: std::cell::RefCell<Vec<(u32, u32, f64)>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        // The heading's direction, worked out once for all candidate lanes.
        let forward = heading_rad.map(|h| crate::geometry::Vector2::new(h.cos(), h.sin()));
        let nearest = NEAREST.with_borrow_mut(|per_lane| {
            per_lane.clear();
            let mut nan = false;
            // Each lane's segment of least distance, ties to the lowest
            // index: what `project_segments` picks from its sorted run.
            self.lane_segments.for_each_candidate(p, radius_m, |(lane, segment)| {
                let (d2, _) = self.lanes[lane as usize].centreline.segment_distance_squared(p, segment as usize);
                nan |= d2.is_nan();
                let entry = match per_lane.last_mut() {
                    Some(last) if last.0 == lane => Some(last),
                    _ => per_lane.iter_mut().find(|e| e.0 == lane),
                };
                match entry {
                    None => per_lane.push((lane, segment, d2)),
                    Some(e) if d2 < e.2 || (d2 == e.2 && segment < e.1) => *e = (lane, segment, d2),
                    Some(_) => {}
                }
            });
            // A degenerate segment's NaN distance makes the pick depend on
            // the visiting order: then the sorted search decides.
            (!nan).then(|| {
                per_lane.iter().fold(None, |best, &(lane, segment, _)| {
                    self.nearer_lane(best, p, forward, radius_m, lane as usize, [segment as usize])
                })
            })
        });
        nearest
            .unwrap_or_else(|| self.nearest_lane_sorted(p, heading_rad, radius_m))
            .map(|(_, _, lane_index, projection)| LaneMatch { lane_index, projection })
    }

    /// [`Self::nearest_lane`] over the candidates sorted by lane and
    /// segment, as `project_segments` takes them.
    fn nearest_lane_sorted(
        &self,
        p: &Point2,
        heading_rad: Option<f64>,
        radius_m: f64,
    ) -> Option<(bool, f64, usize, PolylineProjection)> {
        let forward = heading_rad.map(|h| crate::geometry::Vector2::new(h.cos(), h.sin()));
        self.lane_segments
            .candidates(p, radius_m)
            .into_iter()
            .fold(None, |best, (lane_index, segs)| self.nearer_lane(best, p, forward, radius_m, lane_index, segs))
    }

    /// [`Self::nearest_lane`]'s step: `best` or lane `lane_index`
    /// (projected on `segs`), whichever is nearer, aligned lanes first
    /// (aligned with the unit vector `forward`, when given).
    fn nearer_lane(
        &self,
        best: Option<(bool, f64, usize, PolylineProjection)>,
        p: &Point2,
        forward: Option<crate::geometry::Vector2>,
        radius_m: f64,
        lane_index: usize,
        segs: impl IntoIterator<Item = usize>,
    ) -> Option<(bool, f64, usize, PolylineProjection)> {
        let lane = &self.lanes[lane_index];
        let Some(proj) = lane.centreline.project_segments(p, segs) else {
            return best;
        };
        if proj.distance_m > radius_m {
            return best;
        }
        let misaligned = forward.is_some_and(|f| f.dot(&proj.tangent) < ALIGNED_LANE_MAX_ANGLE_RAD.cos());
        let key = (misaligned, proj.distance_m, lane_index);
        let better = match &best {
            None => true,
            Some((m, d, i, _)) => key < (*m, *d, *i),
        };
        if better { Some((misaligned, proj.distance_m, lane_index, proj)) } else { best }
    }

    /// The lanes whose area holds `p`, driven in `heading_rad`'s direction
    /// (to within 90°), by id. A lane's area is its centreline swept
    /// sideways by its half-width: the distance from the centreline to its
    /// boundary on `p`'s side where the source maps one there (clamped to
    /// [`MIN_LANE_HALF_WIDTH_M`, `MAX_LANE_HALF_WIDTH_M`]), else
    /// [`DEFAULT_LANE_HALF_WIDTH_M`]. A point before a lane's start or past
    /// its end is not on it (its predecessor or successor holds it).
    pub fn lanes_containing(&self, p: &Point2, heading_rad: f64) -> Vec<MapElementId> {
        // A corner may sit on a joint between two segments, a little off
        // both perpendiculars: this much overhang still counts.
        const END_TOLERANCE_M: f64 = 0.25;
        thread_local! {
            // The candidate (lane, segment) pairs, sorted: reused from call
            // to call, as this query runs for every corner of every contact
            // the adversary's plausibility check judges.
            static PAIRS: std::cell::RefCell<Vec<(u32, u32)>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        let heading = crate::geometry::Vector2::new(heading_rad.cos(), heading_rad.sin());
        let mut out: Vec<MapElementId> = PAIRS.with_borrow_mut(|pairs| {
            self.lane_segments.candidate_pairs_into(p, MAX_LANE_HALF_WIDTH_M, pairs);
            // Each lane's run of segments, as `candidates` would group them.
            pairs
                .chunk_by(|a, b| a.0 == b.0)
                .filter_map(|run| {
                    let lane = &self.lanes[run[0].0 as usize];
                    let proj = lane.centreline.project_segments(p, run.iter().map(|&(_, s)| s as usize))?;
                    let offset = p - proj.point;
                    let overhang = offset.dot(&proj.tangent).abs();
                    let left = proj.tangent.x * offset.y - proj.tangent.y * offset.x > 0.0;
                    let boundary = if left { &lane.left_boundary } else { &lane.right_boundary };
                    let half_width = boundary
                        .as_ref()
                        .and_then(|b| b.project(&proj.point))
                        // A partial boundary that ends before this point says nothing here.
                        .filter(|b| (proj.point - b.point).dot(&b.tangent).abs() < END_TOLERANCE_M)
                        .map_or(DEFAULT_LANE_HALF_WIDTH_M, |b| {
                            b.distance_m.clamp(MIN_LANE_HALF_WIDTH_M, MAX_LANE_HALF_WIDTH_M)
                        });
                    let inside = overhang <= END_TOLERANCE_M && proj.distance_m <= half_width;
                    (inside && proj.tangent.dot(&heading) > 0.0).then_some(lane.id)
                })
                .collect()
        });
        out.sort_unstable();
        out
    }

    /// Whether lanes `a` and `b` are one lane or one continues the other.
    pub fn lanes_connected(&self, a: MapElementId, b: MapElementId) -> bool {
        let follows = |x: MapElementId, y: MapElementId| self.lane(x).is_some_and(|l| l.successors.contains(&y));
        a == b || follows(a, b) || follows(b, a)
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
            let best = self.nearest_road_edge_within(p, radius);
            match best {
                Some((_, b)) if b.distance_m <= radius => break best,
                _ if radius >= self.edge_segments.max_distance_from(p) => break best,
                _ => radius *= 4.0,
            }
        }
    }

    /// The nearest of the road edges with a segment in the index cells
    /// within `radius_m` of `p`: by distance, ties to the lower edge index,
    /// and on that edge the projection onto its nearest candidate segment,
    /// ties to the lower segment index. That is one order over all the
    /// (edge, segment) pairs, so the pairs are taken as the index yields
    /// them, unsorted, some twice, nearest cells first and cells wholly
    /// beyond the best so far skipped; only a NaN distance (from absurd map
    /// coordinates, where that order is not total) falls back to visiting
    /// them all sorted, edge by edge.
    fn nearest_road_edge_within(&self, p: &Point2, radius_m: f64) -> Option<(usize, PolylineProjection)> {
        // (distance, edge, distance², segment)
        let mut best: Option<(f64, usize, f64, usize)> = None;
        let mut nan = false;
        self.edge_segments.for_each_candidate_nearest_first(p, radius_m, |(edge, seg)| {
            let (edge, seg) = (edge as usize, seg as usize);
            let (d2, _) = self.road_edges[edge].polyline.segment_distance_squared(p, seg);
            nan |= d2.is_nan();
            let key = (d2.sqrt(), edge, d2, seg);
            if best.is_none_or(|b| key < b) {
                best = Some(key);
            }
            best.map_or(f64::INFINITY, |b| b.0)
        });
        if !nan {
            return best.and_then(|(_, edge, _, seg)| {
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
        best
    }

    /// Signed distance from `p` to the nearest road edge, metres: negative on
    /// the road, positive off it. Where drivable areas exist, membership in
    /// any of them decides the sign. `None` when the map has no road edges
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
            let on_road = self.drivable_areas.iter().any(|a| a.contains(p));
            Some(if on_road { -nearest.distance_m } else { nearest.distance_m })
        }
    }

    /// Whether `p` lies past the end of the mapped road: ahead of the end
    /// of a lane within 10 m that has no successor, *and* past the end of
    /// the nearest road edge (its closest point is the edge's first or last
    /// point): where the recording's map was cut off (NGSIM's study area,
    /// WOMD's crop), not a dead end inside the map, whose kerbs go on
    /// around it. A vehicle there has left the mapped area rather than the
    /// road.
    pub fn is_past_mapped_end(&self, p: &Point2) -> bool {
        self.is_past_mapped_end_given(p, self.nearest_road_edge(p).as_ref())
    }

    /// [`Self::is_past_mapped_end`] with [`Self::nearest_road_edge`]'s answer
    /// for `p` at hand.
    fn is_past_mapped_end_given(&self, p: &Point2, nearest: Option<&(usize, PolylineProjection)>) -> bool {
        const SEARCH_M: f64 = 10.0;
        // Far past the cut the lane's end is as far away as the edge's:
        // search that far (up to a limit), not only the 10 m beside `p`.
        const FARTHEST_PAST_END_M: f64 = 100.0;
        let (edge_ends_here, past_edge_end_m) = match nearest {
            None => (true, 0.0),
            Some(&(edge, proj)) => {
                let length = self.road_edges[edge].polyline.length_m();
                (proj.arc_length_m <= 1e-6 || proj.arc_length_m >= length - 1e-6, proj.distance_m)
            }
        };
        let search_m = SEARCH_M + past_edge_end_m.min(FARTHEST_PAST_END_M);
        edge_ends_here
            && self.lane_segments.candidates(p, search_m).into_keys().any(|lane_index| {
                let lane = &self.lanes[lane_index];
                let points = lane.centreline.points();
                if !lane.successors.is_empty() || points.len() < 2 {
                    return false;
                }
                let (a, b) = (points[points.len() - 2], points[points.len() - 1]);
                let along = (b - a).normalize();
                let from_end = p - b;
                // Ahead of the end, within a lane's reach sideways of its line.
                from_end.dot(&along) > 0.0 && (from_end.x * along.y - from_end.y * along.x).abs() <= SEARCH_M
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

    /// Whether `p` is off the road. Unknown (no edges, no drivable areas) is
    /// treated as on-road.
    pub fn is_off_road(&self, p: &Point2) -> bool {
        self.is_off_road_given(p, self.nearest_road_edge(p).as_ref())
    }

    /// [`Self::is_off_road`] with [`Self::nearest_road_edge`]'s answer for
    /// `p` at hand.
    fn is_off_road_given(&self, p: &Point2, nearest: Option<&(usize, PolylineProjection)>) -> bool {
        if self.road_edges.is_empty() && !self.drivable_areas.is_empty() {
            return !self.drivable_areas.iter().any(|a| a.contains(p));
        }
        self.signed_distance_given(p, nearest).is_some_and(|d| d > 0.0)
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

    fn pl(pts: &[(f64, f64)]) -> Polyline {
        Polyline::new(pts.iter().map(|&(x, y)| Point2::new(x, y)).collect())
    }

    #[test]
    fn off_road_within_the_map_is_off_road_and_not_past_the_mapped_end() {
        // The combined query shares one nearest-edge lookup; its answer is
        // the two queries' everywhere, on maps with and without drivable
        // areas (the template's and the same edges alone).
        use crate::map::templates::{Intersection, Merge};
        let merge = Merge {
            lanes: 2,
            lane_width_m: 3.5,
            length_m: 200.0,
            merge_end_m: 120.0,
            acceleration_lane_m: 60.0,
            speed_limit_mps: None,
        }
        .build();
        let crossing = Intersection {
            lanes_per_direction: 1,
            lane_width_m: 3.5,
            arm_length_m: 40.0,
            green_s: None,
            speed_limit_mps: None,
        }
        .build();
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
        let lane = Lane::new(MapElementId(1), pl(&[(0.0, 0.0), (100.0, 0.0)]));
        let cut = RoadMap::new(
            vec![lane.clone()],
            vec![edge(2, &[(0.0, -2.0), (100.0, -2.0)]), edge(3, &[(100.0, 2.0), (0.0, 2.0)])],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
        );
        assert!(cut.is_past_mapped_end(&Point2::new(101.0, 1.0)));
        assert!(cut.is_past_mapped_end(&Point2::new(125.0, 3.0)), "far past the cut, still ahead of the lane");
        assert!(!cut.is_past_mapped_end(&Point2::new(125.0, 15.0)), "ahead, but beside the lane's line");
        assert!(!cut.is_past_mapped_end(&Point2::new(50.0, 3.0)), "beside the lane: off-road");
        assert!(!cut.is_past_mapped_end(&Point2::new(-1.0, 0.0)), "before its start");
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
                    let (fast, plain) = (map.nearest_road_edge_within(&p, r), sorted(&p, r));
                    assert_eq!(format!("{fast:?}"), format!("{plain:?}"), "{p:?} r {r}");
                    checked += usize::from(plain.is_some());
                }
            }
        }
        assert!(checked > 5000, "{checked}");
    }

    fn straight_road() -> RoadMap {
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
    fn a_nearer_crossing_lane_is_not_the_agents() {
        // The agent drives east on lane 1 (y = 0), 1.5 m off its centreline;
        // lane 2 crosses northwards at x = 50.5, 0.5 m away, and lane 3
        // runs 80° off east: near, and within 90°, but crossing.
        let own = Lane::new(MapElementId(1), pl(&[(0.0, -1.5), (100.0, -1.5)]));
        let crossing = Lane::new(MapElementId(2), pl(&[(50.5, -50.0), (50.5, 50.0)]));
        let skew = 80f64.to_radians();
        let oblique =
            Lane::new(MapElementId(3), pl(&[(50.0, 0.5), (50.0 + 40.0 * skew.cos(), 0.5 + 40.0 * skew.sin())]));
        let map = RoadMap::new(vec![own, crossing, oblique], vec![], vec![], vec![], vec![], vec![], vec![]);
        let hit = map.nearest_lane(&Point2::new(50.0, 0.0), Some(0.0), 4.0).unwrap();
        assert_eq!(map.lanes[hit.lane_index].id, MapElementId(1));
        // With nothing aligned in reach, the nearest lane is still returned.
        let hit = map.nearest_lane(&Point2::new(50.0, 0.0), Some(0.0), 1.0).unwrap();
        assert_ne!(map.lanes[hit.lane_index].id, MapElementId(1));
    }

    #[test]
    fn nearest_lane_answers_as_the_sorted_search_does() {
        // Crossing, curving and parallel lanes, finely sampled as recorded
        // maps are: many lanes and segments share each grid cell.
        let arc = |id, cx: f64, cy: f64, r: f64, from: f64, to: f64| {
            let pts: Vec<(f64, f64)> = (0..=60)
                .map(|i| from + (to - from) * i as f64 / 60.0)
                .map(|a: f64| (cx + r * a.cos(), cy + r * a.sin()))
                .collect();
            Lane::new(MapElementId(id), pl(&pts))
        };
        let line = |id, a: (f64, f64), b: (f64, f64)| {
            let pts: Vec<(f64, f64)> =
                (0..=80).map(|i| i as f64 / 80.0).map(|t| (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t)).collect();
            Lane::new(MapElementId(id), pl(&pts))
        };
        let lanes = vec![
            line(1, (-40.0, 0.0), (40.0, 0.0)),
            line(2, (40.0, 3.5), (-40.0, 3.5)),
            line(3, (0.0, -40.0), (0.0, 40.0)),
            line(4, (-3.5, 40.0), (-3.5, -40.0)),
            arc(5, 0.0, 0.0, 12.0, 0.0, 3.0),
            arc(6, 10.0, -10.0, 8.0, 2.0, -1.0),
            line(7, (-30.0, -30.0), (30.0, 30.0)),
        ];
        let map = RoadMap::new(lanes, vec![], vec![], vec![], vec![], vec![], vec![]);
        let mut checked = 0;
        for ix in -30..=30 {
            for iy in -30..=30 {
                let p = Point2::new(ix as f64 * 1.3, iy as f64 * 1.3);
                for heading_rad in [None, Some(0.0), Some(1.2), Some(-2.5), Some(3.1)] {
                    for radius_m in [1.0, 5.0, 25.0] {
                        let fast = map.nearest_lane(&p, heading_rad, radius_m);
                        let sorted = map.nearest_lane_sorted(&p, heading_rad, radius_m);
                        let key = |m: Option<(usize, PolylineProjection)>| {
                            m.map(|(i, pr)| (i, pr.segment, pr.distance_m, pr.arc_length_m))
                        };
                        assert_eq!(
                            key(fast.map(|m| (m.lane_index, m.projection))),
                            key(sorted.map(|(_, _, i, pr)| (i, pr))),
                            "at {p:?}, heading {heading_rad:?}, radius {radius_m}"
                        );
                        checked += usize::from(fast.is_some());
                    }
                }
            }
        }
        assert!(checked > 10_000, "{checked}");
    }

    #[test]
    fn lanes_sorted_and_nearest_lane_found() {
        let m = straight_road();
        assert_eq!(m.lanes[0].id, MapElementId(1));
        let hit = m.nearest_lane(&Point2::new(50.0, 3.0), Some(0.0), 10.0).unwrap();
        assert_eq!(m.lanes[hit.lane_index].id, MapElementId(2));
        assert!((hit.projection.arc_length_m - 50.0).abs() < 1e-9);
        assert!(m.nearest_lane(&Point2::new(50.0, 40.0), None, 10.0).is_none());
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
        // Building the index over a 1e20 m edge once walked ~1e19 grid cells.
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
