//! Walking the lane graph from the ego: the lanes behind and ahead of it,
//! as points at the protocol's spacing. Both routes the protocol sends (the
//! 1.0 `route` hint and the 1.1 stable route) are such walks; which lane
//! follows at a fork is the caller's choice.

use crate::geometry::{Point2, Polyline, Vector2};
use crate::map::{Lane, MapElementId, RoadMap};
use crate::scenario::AgentState;

/// Polylines in observations are resampled at equal arc-length steps of at
/// most this, m: dense recorded maps are thinned and long straight segments
/// filled in, so messages stay small and planners need not interpolate.
pub const MAP_SPACING_M: f64 = 2.0;

/// Points at equal arc-length steps of at most [`MAP_SPACING_M`] over
/// `[s0, s0 + length]`, both ends included.
pub(crate) fn samples(line: &Polyline, s0: f64, length_m: f64) -> impl Iterator<Item = Point2> + '_ {
    let n = (length_m / MAP_SPACING_M).ceil().max(1.0) as usize;
    (0..=n).filter_map(move |k| line.sample(s0 + length_m * k as f64 / n as f64).map(|(p, _)| p))
}

/// A path along lane centrelines: the lanes, in order, and their points.
#[derive(Debug, Default)]
pub(crate) struct LaneWalk {
    /// The lanes walked, in order.
    pub(crate) lanes: Vec<MapElementId>,
    /// Points every [`MAP_SPACING_M`] or less, joints kept once.
    pub(crate) points: Vec<[f64; 2]>,
    /// Whether the walk reached the length asked for (else the lanes ran out).
    pub(crate) reached_length: bool,
}

/// Which way a [`walk_lanes`] step goes from a lane: to one of its
/// successors (ahead) or one of its predecessors (behind the ego).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum WalkDirection {
    /// Past the lane's end, among its successors.
    Ahead,
    /// Back before the lane's start, among its predecessors.
    Behind,
}

/// Walks from the ego's lane (the nearest within `search_m` running its
/// way, or where a junction's lanes overlap there the one `guide` keeps
/// to, [`RoadMap::lane_along`]; `None` when there is none) from
/// `behind_m` behind the ego's projection to `ahead_m` ahead, taking
/// `next(lane, direction)` at each lane's end (ahead) or start (behind,
/// where the ego's lane begins less than `behind_m` back), over at most
/// `max_lanes` lanes each way. Both routes of the protocol (the 1.0 hint
/// and the 1.1 stable route) are such walks.
pub(crate) fn walk_lanes<'m>(
    map: &'m RoadMap,
    (ego, guide): (&AgentState, &[Point2]),
    search_m: f64,
    behind_m: f64,
    ahead_m: f64,
    max_lanes: usize,
    mut next: impl FnMut(&'m Lane, WalkDirection) -> Option<&'m Lane>,
) -> Option<LaneWalk> {
    // Where a junction's lanes overlap at the ego, the one `guide` keeps to.
    let m = map.lane_along(&ego.position, ego.heading_rad, search_m, guide)?;
    // nearest_lane prefers lanes in the ego's direction but falls back to
    // others; a route against the traffic or across it would mislead.
    let forward = Vector2::new(ego.heading_rad.cos(), ego.heading_rad.sin());
    if m.projection.tangent.dot(&forward) < crate::map::ALIGNED_LANE_MAX_ANGLE_RAD.cos() {
        return None;
    }
    let own = &map.lanes[m.lane_index];
    // Back from the ego's projection: into the predecessors where the ego's
    // lane starts too close behind it.
    let mut start = (own, (m.projection.arc_length_m - behind_m).max(0.0));
    let mut back_m = behind_m - m.projection.arc_length_m;
    let mut walked_back = 0.0;
    let mut earlier = Vec::new();
    while back_m > 1e-9 && earlier.len() < max_lanes {
        let Some(previous) = next(start.0, WalkDirection::Behind) else {
            break;
        };
        let length = previous.centreline.length_m();
        let take = length.min(back_m);
        earlier.push(start.0);
        start = (previous, length - take);
        back_m -= take;
        walked_back += take;
    }
    earlier.reverse();
    let mut walk = LaneWalk::default();
    let (mut lane, mut s0) = start;
    let behind_on_own_m = m.projection.arc_length_m - if earlier.is_empty() { s0 } else { 0.0 };
    let mut remaining = walked_back + behind_on_own_m + ahead_m;
    let mut queued = earlier.into_iter();
    for _ in 0..max_lanes.saturating_mul(2) {
        walk.lanes.push(lane.id);
        let take = (lane.centreline.length_m() - s0).max(0.0).min(remaining);
        for p in samples(&lane.centreline, s0, take) {
            // Consecutive lanes share their joining point: keep it once.
            if walk.points.last().is_none_or(|q| (q[0] - p.x).hypot(q[1] - p.y) > 1e-6) {
                walk.points.push([p.x, p.y]);
            }
        }
        remaining -= take;
        if remaining <= 1e-9 {
            walk.reached_length = true;
            break;
        }
        let Some(following) = queued.next().or_else(|| next(lane, WalkDirection::Ahead)) else {
            break;
        };
        lane = following;
        s0 = 0.0;
    }
    Some(walk)
}
