//! The map's elements: ids, lanes with their connectivity, road edges,
//! road lines, areas (crosswalks, speed bumps, driveways), stop signs,
//! and traffic signals with their states.

use crate::geometry::{Point2, Polygon, Polyline};

/// Identifier of a map element, unique within one map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct MapElementId(pub i64);

/// What kind of lane a centreline belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
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
#[non_exhaustive]
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
    /// Whether the source flags this lane as inside an intersection.
    pub in_intersection: bool,
    /// Whether this lane's centreline crosses another lane's at a
    /// junction's angle, on a map whose source flags no intersections
    /// (WOMD): set by
    /// [`RoadMap::mark_crossing_lanes_as_junctions`](super::RoadMap::mark_crossing_lanes_as_junctions).
    pub crosses_lanes: bool,
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
            crosses_lanes: false,
            stop_line: None,
        }
    }

    /// Whether this lane lies inside a junction, where lanes cross at every
    /// angle: the source flags it ([`Self::in_intersection`]), or on a map
    /// that flags none it crosses another lane ([`Self::crosses_lanes`]).
    /// The traffic rules read this; the realism prior's map input reads the
    /// source's flag alone, as it was trained and measured.
    pub fn in_junction(&self) -> bool {
        self.in_intersection || self.crosses_lanes
    }
}

/// Kind of a road edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
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
#[non_exhaustive]
pub struct RoadEdge {
    /// Map-unique id.
    pub id: MapElementId,
    /// The edge, road to the left.
    pub polyline: Polyline,
    /// Edge type.
    pub kind: RoadEdgeKind,
}

impl RoadEdge {
    /// A road edge (the road to the left of `polyline`).
    pub fn new(id: MapElementId, polyline: Polyline, kind: RoadEdgeKind) -> Self {
        RoadEdge { id, polyline, kind }
    }
}

/// Painted line type of a road line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
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
#[non_exhaustive]
pub struct RoadLine {
    /// Map-unique id.
    pub id: MapElementId,
    /// The line.
    pub polyline: Polyline,
    /// Line type.
    pub kind: RoadLineKind,
}

impl RoadLine {
    /// A painted line.
    pub fn new(id: MapElementId, polyline: Polyline, kind: RoadLineKind) -> Self {
        RoadLine { id, polyline, kind }
    }
}

/// Kind of an area element of the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[non_exhaustive]
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
#[non_exhaustive]
pub struct MapArea {
    /// Map-unique id.
    pub id: MapElementId,
    /// What it is.
    pub kind: AreaKind,
    /// Its outline.
    pub polygon: Polygon,
}

impl MapArea {
    /// An area element.
    pub fn new(id: MapElementId, kind: AreaKind, polygon: Polygon) -> Self {
        MapArea { id, kind, polygon }
    }
}

/// A stop sign and the lanes it controls.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct StopSign {
    /// Map-unique id.
    pub id: MapElementId,
    /// Position of the sign.
    pub position: Point2,
    /// Controlled lanes.
    pub lanes: Vec<MapElementId>,
}

impl StopSign {
    /// A stop sign at `position` controlling `lanes`.
    pub fn new(id: MapElementId, position: Point2, lanes: Vec<MapElementId>) -> Self {
        StopSign { id, position, lanes }
    }
}

/// State of a traffic signal for one lane at one step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
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

    /// In words, for messages (`a red arrow`).
    pub fn describe(self) -> &'static str {
        match self {
            Self::Unknown => "an unknown signal",
            Self::ArrowStop => "a red arrow",
            Self::ArrowCaution => "a yellow arrow",
            Self::ArrowGo => "a green arrow",
            Self::Stop => "red",
            Self::Caution => "yellow",
            Self::Go => "green",
            Self::FlashingStop => "flashing red",
            Self::FlashingCaution => "flashing yellow",
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
#[non_exhaustive]
pub struct TrafficSignal {
    /// Controlled lane (the one ending at the stop line).
    pub lane: MapElementId,
    /// Stop line point, where known.
    pub stop_point: Option<Point2>,
    /// State per scenario step (same length as the tracks).
    pub states: Vec<SignalState>,
}

impl TrafficSignal {
    /// The signal of `lane`, with its state at every scenario step.
    pub fn new(lane: MapElementId, stop_point: Option<Point2>, states: Vec<SignalState>) -> Self {
        TrafficSignal { lane, stop_point, states }
    }
}
