//! Lane queries on a [`RoadMap`]: the nearest lane to a point, preferring
//! lanes going the agent's way ([`LaneMatch`]), the lanes whose area holds
//! a point, the lane a road user drives against (wrong way), the angle at
//! which it drives across the lanes, whether two
//! lanes connect, and which of a junction's lanes a
//! recorded path takes ([`lane_followed`]).

use super::{Lane, MapElementId, RoadMap};
use crate::geometry::{Point2, PolylineProjection};

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

/// The smallest angle between a road user's heading and a lane's direction
/// that counts as driving against it (CARLA's `WrongLaneTest` uses 120°).
pub const WRONG_WAY_MIN_ANGLE_RAD: f64 = 2.0 * std::f64::consts::FRAC_PI_3;

/// Below this speed a road user is not driving anywhere, m/s, and drives
/// against no lane's traffic.
pub const WRONG_WAY_MIN_SPEED_MPS: f64 = 0.5;

/// The smallest angle between a road user's heading and every lane it is
/// in that counts as driving across the lanes, rad (30°: a brisk lane
/// change at speed turns about 5–10° from the lanes; 30° at 3 m/s or more
/// is a car cutting across them, or turning where no lane turns).
pub const ACROSS_LANES_MIN_ANGLE_RAD: f64 = std::f64::consts::FRAC_PI_6;

/// Below this speed a road user's angle to the lanes is not judged, m/s:
/// manoeuvring at walking pace (parking, turning out of a driveway) points
/// a car every way.
pub const ACROSS_LANES_MIN_SPEED_MPS: f64 = 3.0;

/// A lane running a road user's way this close to it, m, means it is
/// beside its own lane, not in the oncoming one (about a lane width: the
/// centrelines of two lanes side by side are one lane width apart).
pub const OWN_LANE_CLEARANCE_M: f64 = 3.0;

/// How far from a lane's centreline a path point still keeps to the lane,
/// m (a default lane's half-width).
pub const LANE_FOLLOW_LATERAL_M: f64 = DEFAULT_LANE_HALF_WIDTH_M;
/// How much farther a path must keep to one of a junction's lanes than to
/// any other before [`lane_followed`] names it, m: the lanes of a fork
/// share their first metres, where every path keeps to all of them.
pub const LANE_FOLLOW_MARGIN_M: f64 = 3.0;

/// How much of `lane`'s centreline `path` keeps to, m: the span of arc
/// lengths at which path points lie within [`LANE_FOLLOW_LATERAL_M`] of it
/// (0 when none does).
pub fn length_followed_m(lane: &Lane, path: &[Point2]) -> f64 {
    let mut span: Option<(f64, f64)> = None;
    for p in path {
        let Some(at) = lane.centreline.project(p) else { continue };
        if at.distance_m <= LANE_FOLLOW_LATERAL_M {
            let (lo, hi) = span.get_or_insert((at.arc_length_m, at.arc_length_m));
            *lo = lo.min(at.arc_length_m);
            *hi = hi.max(at.arc_length_m);
        }
    }
    span.map_or(0.0, |(lo, hi)| hi - lo)
}

/// Of `lanes` (a junction's successors, or predecessors), the index of the
/// one `path` (a recording) keeps to the farthest, when it keeps to it by
/// at least [`LANE_FOLLOW_MARGIN_M`] more than to any other; `None` when
/// the path does not decide (it ends before the junction, or two lanes
/// run together as far as it goes), so that the caller keeps its default.
pub fn lane_followed(lanes: &[&Lane], path: &[Point2]) -> Option<usize> {
    let followed: Vec<f64> = lanes.iter().map(|l| length_followed_m(l, path)).collect();
    let (best, &most) = followed.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
    let clear = followed.iter().enumerate().all(|(i, &m)| i == best || m + LANE_FOLLOW_MARGIN_M <= most);
    (clear && most > 0.0).then_some(best)
}

/// How close to the nearest lane's centreline another lane running the same
/// way must pass to lie on top of it, m, for [`RoadMap::lane_along`]: the
/// lanes of a junction's turns share their first metres, and lanes side by
/// side are a lane width apart.
pub const OVERLAPPING_LANE_M: f64 = 0.5;

/// Nearest-lane query result.
#[derive(Debug, Clone, Copy)]
pub struct LaneMatch {
    /// Index into [`RoadMap::lanes`].
    pub lane_index: usize,
    /// Projection of the query point on the lane's centreline.
    pub projection: PolylineProjection,
}

/// Whether a lane of direction `tangent` (a unit vector) goes against the
/// agent's `forward` unit vector by more than
/// [`ALIGNED_LANE_MAX_ANGLE_RAD`] (never without a heading).
fn misaligned(forward: Option<crate::geometry::Vector2>, tangent: &crate::geometry::Vector2) -> bool {
    forward.is_some_and(|f| f.dot(tangent) < ALIGNED_LANE_MAX_ANGLE_RAD.cos())
}

/// A lane's nearest segment to a query point so far in
/// [`RoadMap::nearest_lane`]: lane, segment, squared distance, and the
/// segment's ends.
type LaneCandidate = (u32, u32, f64, [Point2; 2]);

/// Slack of [`RoadMap::nearest_lane`]'s run pruning, m: far above the
/// rounding of the distances it compares, far below anything that matters.
const LANE_RUN_PRUNE_SLACK_M: f64 = 0.01;

/// How far a point may lie before a lane's start or past its end and still
/// be on it, m: a corner may sit on a joint between two segments, a little
/// off both perpendiculars.
const LANE_END_TOLERANCE_M: f64 = 0.25;

impl RoadMap {
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
            static NEAREST: std::cell::RefCell<Vec<LaneCandidate>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        // The heading's direction, worked out once for all candidate lanes.
        let forward = heading_rad.map(|h| crate::geometry::Vector2::new(h.cos(), h.sin()));
        let nearest = NEAREST.with_borrow_mut(|per_lane| {
            per_lane.clear();
            let mut nan = false;
            // Each lane's segment of least distance, ties to the lowest
            // index: what `project_segments` picks from its sorted run.
            self.lane_segments.for_each_run_within(p, radius_m, |run_distance_m, pairs, ends| {
                // A run is one lane's consecutive segments: one that lies
                // wholly farther than that lane's nearest segment so far
                // cannot change it (with a centimetre to spare).
                let lane = pairs[0].0;
                let mut at = match per_lane.last() {
                    Some(last) if last.0 == lane => Some(per_lane.len() - 1),
                    _ => per_lane.iter().position(|e| e.0 == lane),
                };
                if let Some(i) = at
                    && run_distance_m > per_lane[i].2.sqrt() + LANE_RUN_PRUNE_SLACK_M
                {
                    return;
                }
                for (&(_, segment), ends) in pairs.iter().zip(ends) {
                    let (d2, _) = crate::geometry::polyline::segment_distance_squared(ends, p);
                    nan |= d2.is_nan();
                    match at {
                        None => {
                            per_lane.push((lane, segment, d2, *ends));
                            at = Some(per_lane.len() - 1);
                        }
                        Some(i) => {
                            let e = &mut per_lane[i];
                            if d2 < e.2 || (d2 == e.2 && segment < e.1) {
                                *e = (lane, segment, d2, *ends);
                            }
                        }
                    }
                }
            });
            // A degenerate segment's NaN distance makes the pick depend on
            // the visiting order: then the sorted search decides.
            if nan {
                return None;
            }
            // `nearer_lane`'s choice, from each lane's nearest segment as
            // its projection would give it (the distance is the square
            // root of `d2`, the tangent the segment's direction): only the
            // winner is projected.
            let best =
                per_lane.iter().fold(None, |best: Option<(bool, f64, usize, u32)>, &(lane, segment, d2, [a, b])| {
                    let distance_m = d2.sqrt();
                    if distance_m > radius_m {
                        return best;
                    }
                    let tangent = (b - a) / (b - a).norm();
                    let misaligned = misaligned(forward, &tangent);
                    let key = (misaligned, distance_m, lane as usize);
                    let better = best.is_none_or(|(m, d, i, _)| key < (m, d, i));
                    if better { Some((misaligned, distance_m, lane as usize, segment)) } else { best }
                });
            Some(best.and_then(|(misaligned, distance_m, lane_index, segment)| {
                let projection = self.lanes[lane_index].centreline.project_segments(p, [segment as usize])?;
                Some((misaligned, distance_m, lane_index, projection))
            }))
        });
        nearest
            .unwrap_or_else(|| self.nearest_lane_sorted(p, heading_rad, radius_m))
            .map(|(_, _, lane_index, projection)| LaneMatch { lane_index, projection })
    }

    /// The lane at `p` running along `heading_rad` that `path` (a
    /// recording of the way the road user went) keeps to: the nearest
    /// aligned lane within `radius_m` ([`Self::nearest_lane`]), unless other
    /// aligned lanes pass within [`OVERLAPPING_LANE_M`] of the point where
    /// `p` meets it (a junction's turns start on top of one another), where
    /// it is the one of them `path` keeps to the farthest
    /// ([`lane_followed`]); the nearest where `path` does not decide. A
    /// route started from the nearest lane alone may take a turn the
    /// recording never took.
    pub fn lane_along(&self, p: &Point2, heading_rad: f64, radius_m: f64, path: &[Point2]) -> Option<LaneMatch> {
        let nearest = self.nearest_lane(p, Some(heading_rad), radius_m)?;
        let forward = crate::geometry::Vector2::new(heading_rad.cos(), heading_rad.sin());
        if path.is_empty() || misaligned(Some(forward), &nearest.projection.tangent) {
            return Some(nearest);
        }
        // The lanes on top of the nearest one where `p` meets it (a lane
        // beside it, a lane width away, is not).
        let on_nearest = nearest.projection.point;
        let overlapping: Vec<LaneMatch> = self
            .lanes
            .iter()
            .enumerate()
            .filter_map(|(lane_index, lane)| {
                // Most lanes are far off: `p` is projected only on the near ones.
                if lane.centreline.project(&on_nearest)?.distance_m > OVERLAPPING_LANE_M {
                    return None;
                }
                let projection = lane.centreline.project(p)?;
                (!misaligned(Some(forward), &projection.tangent)).then_some(LaneMatch { lane_index, projection })
            })
            .collect();
        if overlapping.len() < 2 {
            return Some(nearest);
        }
        let lanes: Vec<&Lane> = overlapping.iter().map(|m| &self.lanes[m.lane_index]).collect();
        Some(lane_followed(&lanes, path).map_or(nearest, |k| overlapping[k]))
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
        let misaligned = misaligned(forward, &proj.tangent);
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
        thread_local! {
            // The candidate (lane, segment) pairs, sorted: reused from call
            // to call, as this query runs for every corner of every contact
            // the adversary's plausibility check judges.
            static PAIRS: std::cell::RefCell<Vec<(u32, u32)>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        let heading = crate::geometry::Vector2::new(heading_rad.cos(), heading_rad.sin());
        let mut out: Vec<MapElementId> = PAIRS.with_borrow_mut(|pairs| {
            self.lane_segments.candidate_pairs_within_into(p, MAX_LANE_HALF_WIDTH_M, pairs);
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
                        .filter(|b| (proj.point - b.point).dot(&b.tangent).abs() < LANE_END_TOLERANCE_M)
                        .map_or(DEFAULT_LANE_HALF_WIDTH_M, |b| {
                            b.distance_m.clamp(MIN_LANE_HALF_WIDTH_M, MAX_LANE_HALF_WIDTH_M)
                        });
                    let inside = overhang <= LANE_END_TOLERANCE_M && proj.distance_m <= half_width;
                    (inside && proj.tangent.dot(&heading) > 0.0).then_some(lane.id)
                })
                .collect()
        });
        out.sort_unstable();
        out
    }

    /// The lane whose traffic a road user at `p`, heading `heading_rad`,
    /// drives against, or `None` (CARLA ScenarioRunner's `WrongLaneTest`
    /// rule): `p` lies in a lane running more than
    /// [`WRONG_WAY_MIN_ANGLE_RAD`] from the heading, outside intersections
    /// (where lanes cross at every angle), in no lane running its way and
    /// more than [`OWN_LANE_CLEARANCE_M`] from the centreline of any such
    /// lane (a wide lane, or a swerve past a parked car, is not wrong way),
    /// while it moves at `speed_mps` of at least [`WRONG_WAY_MIN_SPEED_MPS`].
    pub fn oncoming_lane_at(&self, p: &Point2, heading_rad: f64, speed_mps: f64) -> Option<MapElementId> {
        if speed_mps < WRONG_WAY_MIN_SPEED_MPS || !self.lanes_containing(p, heading_rad).is_empty() {
            return None;
        }
        let heading = crate::geometry::Vector2::new(heading_rad.cos(), heading_rad.sin());
        let own_way_nearby = self
            .nearest_lane(p, Some(heading_rad), OWN_LANE_CLEARANCE_M)
            .is_some_and(|m| m.projection.tangent.dot(&heading) >= ALIGNED_LANE_MAX_ANGLE_RAD.cos());
        if own_way_nearby {
            return None;
        }
        self.lanes_containing(p, heading_rad + std::f64::consts::PI).into_iter().find(|id| {
            self.lane(*id).is_some_and(|lane| {
                !lane.in_junction()
                    && lane
                        .centreline
                        .project(p)
                        .is_some_and(|proj| proj.tangent.dot(&heading) <= WRONG_WAY_MIN_ANGLE_RAD.cos())
            })
        })
    }

    /// The angle at which a road user at `p`, heading `heading_rad` and
    /// moving at `speed_mps`, drives across the lanes it is in, rad, or
    /// `None`: its centre lies in at least one lane (either way), in none
    /// inside an intersection (where lanes cross at every angle), and the
    /// smallest angle between its heading and the direction of any lane it
    /// is in is more than [`ACROSS_LANES_MIN_ANGLE_RAD`] and less than
    /// [`WRONG_WAY_MIN_ANGLE_RAD`] (beyond that it drives against the
    /// traffic: [`RoadMap::oncoming_lane_at`]), while it moves at
    /// [`ACROSS_LANES_MIN_SPEED_MPS`] or more.
    pub fn angle_across_lanes_at(&self, p: &Point2, heading_rad: f64, speed_mps: f64) -> Option<f64> {
        if speed_mps < ACROSS_LANES_MIN_SPEED_MPS {
            return None;
        }
        let heading = crate::geometry::Vector2::new(heading_rad.cos(), heading_rad.sin());
        let mut lanes = self.lanes_containing(p, heading_rad);
        lanes.extend(self.lanes_containing(p, heading_rad + std::f64::consts::PI));
        self.least_over_lanes(p, lanes, |tangent| tangent.dot(&heading).clamp(-1.0, 1.0).acos())
            .filter(|a| *a > ACROSS_LANES_MIN_ANGLE_RAD && *a < WRONG_WAY_MIN_ANGLE_RAD)
    }

    /// The speed at which a road user at `p`, heading `heading_rad` and
    /// moving at `speed_mps`, moves sideways across the lanes of its way
    /// that hold its centre, m/s: its speed times the sine of the smallest
    /// angle between its heading and any of them. `None` below
    /// [`ACROSS_LANES_MIN_SPEED_MPS`], in no lane of its way, or in an
    /// intersection's (where lanes cross at every angle).
    pub fn sideways_speed_at(&self, p: &Point2, heading_rad: f64, speed_mps: f64) -> Option<f64> {
        if speed_mps < ACROSS_LANES_MIN_SPEED_MPS {
            return None;
        }
        let heading = crate::geometry::Vector2::new(heading_rad.cos(), heading_rad.sin());
        let lanes = self.lanes_containing(p, heading_rad);
        self.least_over_lanes(p, lanes, |tangent| tangent.perp(&heading).abs().min(1.0)).map(|sine| speed_mps * sine)
    }

    /// The least of `measure` (of a lane's unit direction where `p`
    /// projects onto it) over `lanes`: `None` when none of them projects
    /// `p`, or when one lies inside an intersection (where lanes cross at
    /// every angle, and no angle to them says how a road user drives).
    fn least_over_lanes(
        &self,
        p: &Point2,
        lanes: Vec<MapElementId>,
        measure: impl Fn(&crate::geometry::Vector2) -> f64,
    ) -> Option<f64> {
        let mut least: Option<f64> = None;
        for id in lanes {
            let Some(lane) = self.lane(id) else { continue };
            if lane.in_junction() {
                return None;
            }
            let Some(at) = lane.centreline.project(p) else { continue };
            let value = measure(&at.tangent);
            least = Some(least.map_or(value, |l| l.min(value)));
        }
        least
    }

    /// Whether lane `id` runs beside `p`: `p` projects onto its centreline
    /// between its ends (to within the overhang [`RoadMap::lanes_containing`]
    /// allows), however far to one side. A road user that is beside a lane
    /// it was in, and no longer in it, left it sideways; one past its end
    /// drove on out of it.
    pub fn lane_runs_beside(&self, id: MapElementId, p: &Point2) -> bool {
        self.lane(id)
            .and_then(|lane| lane.centreline.project(p))
            .is_some_and(|proj| (p - proj.point).dot(&proj.tangent).abs() <= LANE_END_TOLERANCE_M)
    }

    /// Whether lanes `a` and `b` are one lane or one continues the other.
    pub fn lanes_connected(&self, a: MapElementId, b: MapElementId) -> bool {
        let follows = |x: MapElementId, y: MapElementId| self.lane(x).is_some_and(|l| l.successors.contains(&y));
        a == b || follows(a, b) || follows(b, a)
    }

    /// Whether some lane of `a` is connected to some lane of `b`
    /// ([`RoadMap::lanes_connected`]).
    pub fn any_lanes_connected(&self, a: &[MapElementId], b: &[MapElementId]) -> bool {
        a.iter().any(|&x| b.iter().any(|&y| self.lanes_connected(x, y)))
    }

    /// The successors of `lanes`, in their order (unknown ids give none).
    pub fn successors_of(&self, lanes: &[MapElementId]) -> Vec<MapElementId> {
        lanes.iter().filter_map(|&id| self.lane(id)).flat_map(|l| l.successors.iter().copied()).collect()
    }

    /// The left and right neighbours of `lanes`, in their order (unknown ids
    /// give none).
    pub fn neighbours_of(&self, lanes: &[MapElementId]) -> Vec<MapElementId> {
        lanes
            .iter()
            .filter_map(|&id| self.lane(id))
            .flat_map(|l| l.left_neighbours.iter().chain(&l.right_neighbours).copied())
            .collect()
    }

    /// Whether a vehicle that was at `from` (position, heading) and is now
    /// at `to` has changed lanes: both lie in lanes going their way, none of
    /// `to`'s lanes is one of `from`'s or continues it, and one of them is a
    /// left or right neighbour of one of `from`'s lanes, of a successor of
    /// one, or a successor of such a neighbour (a change over a few seconds
    /// may cross a joint between lane pieces on either side).
    pub fn changed_lane(&self, from: (&Point2, f64), to: (&Point2, f64)) -> bool {
        let (before, after) = (self.lanes_containing(from.0, from.1), self.lanes_containing(to.0, to.1));
        if before.is_empty() || after.is_empty() || self.any_lanes_connected(&after, &before) {
            return false;
        }
        let with_next: Vec<MapElementId> = before.iter().copied().chain(self.successors_of(&before)).collect();
        let beside = self.neighbours_of(&with_next);
        let reached: Vec<MapElementId> = beside.iter().copied().chain(self.successors_of(&beside)).collect();
        after.iter().any(|a| reached.contains(a))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::tests::{pl, straight_road};

    /// A recorded path every metre along `pts`' segments.
    fn dense(pts: &[(f64, f64)]) -> Vec<Point2> {
        let line = pl(pts);
        let n = line.length_m().floor() as usize;
        (0..=n).filter_map(|i| line.sample(i as f64).map(|(p, _)| p)).collect()
    }

    #[test]
    fn moving_into_the_neighbour_lane_is_a_lane_change_and_keeping_the_lane_is_not() {
        use crate::map::templates::{MapTemplate, StraightRoad};
        // Two lanes along +x, 3.5 m wide: lane centres at y = 1.75 and 5.25.
        let road: StraightRoad = serde_json::from_value(serde_json::json!({"lanes": 2, "length_m": 400})).unwrap();
        let map = MapTemplate::Straight(road).build();
        let at = |x: f64, y: f64| Point2::new(x, y);
        assert!(map.changed_lane((&at(50.0, 1.75), 0.0), (&at(110.0, 5.25), 0.0)));
        assert!(map.changed_lane((&at(50.0, 5.25), 0.0), (&at(110.0, 1.75), 0.0)));
        assert!(!map.changed_lane((&at(50.0, 1.75), 0.0), (&at(110.0, 1.75), 0.0)), "kept its lane");
        assert!(!map.changed_lane((&at(50.0, 1.75), 0.0), (&at(110.0, 30.0), 0.0)), "off the road is no lane");
    }

    #[test]
    fn a_recording_through_a_fork_names_the_lane_it_takes_and_one_ending_before_names_none() {
        // A straight lane and a right turn, both starting at the fork (0, 0).
        let straight = Lane::new(MapElementId(1), pl(&[(0.0, 0.0), (40.0, 0.0)]));
        let turn: Vec<(f64, f64)> = (0..=20)
            .map(|i| std::f64::consts::FRAC_PI_2 * i as f64 / 20.0)
            .map(|a| (15.0 * a.sin(), -15.0 * (1.0 - a.cos())))
            .collect();
        let right = Lane::new(MapElementId(2), pl(&turn));
        let lanes = [&straight, &right];
        // A dense recording, 0.6 m right of the turn's centreline (on a
        // 14.4 m radius), from 20 m before the fork: it keeps to both lanes
        // for their first metres, and to the turn only beyond.
        let inner: Vec<(f64, f64)> = (0..=20)
            .map(|i| std::f64::consts::FRAC_PI_2 * i as f64 / 20.0)
            .map(|a| (14.4 * a.sin(), -15.0 + 14.4 * a.cos()))
            .collect();
        let mut taken = dense(&[(-20.0, -0.6), (0.0, -0.6)]);
        taken.extend(dense(&inner));
        assert!(length_followed_m(&straight, &taken) > 2.0, "the shared start counts for the straight lane too");
        assert_eq!(lane_followed(&lanes, &taken), Some(1));
        let on = dense(&[(-20.0, 0.3), (40.0, 0.3)]);
        assert_eq!(lane_followed(&lanes, &on), Some(0));
        // Ending before the fork, or just past it: no decision.
        assert_eq!(lane_followed(&lanes, &dense(&[(-20.0, 0.0), (-1.0, 0.0)])), None);
        assert_eq!(lane_followed(&lanes, &dense(&[(-20.0, 0.0), (1.5, 0.0)])), None);
        assert_eq!(lane_followed(&lanes, &[]), None);
        assert_eq!(lane_followed(&[], &on), None);
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
    fn where_a_junctions_turns_overlap_the_lane_along_a_path_is_the_one_it_keeps_to() {
        // Two turns start where lane 1 ends, on top of each other for 10 m;
        // the nearest lane at (105, 0) is a tie, broken to the lower id.
        let lanes = vec![
            Lane::new(MapElementId(1), pl(&[(0.0, 0.0), (100.0, 0.0)])),
            Lane::new(MapElementId(2), pl(&[(100.0, 0.0), (110.0, 0.0), (200.0, 100.0)])),
            Lane::new(MapElementId(3), pl(&[(100.0, 0.0), (110.0, 0.0), (200.0, -100.0)])),
        ];
        let map = RoadMap::new(lanes, vec![], vec![], vec![], vec![], vec![], vec![]);
        let at = Point2::new(105.0, 0.0);
        let id = |m: Option<LaneMatch>| map.lanes[m.expect("a lane").lane_index].id;
        assert_eq!(id(map.nearest_lane(&at, Some(0.0), 10.0)), MapElementId(2));
        let right = dense(&[(0.0, 0.0), (110.0, 0.0), (200.0, -100.0)]);
        let left = dense(&[(0.0, 0.0), (110.0, 0.0), (200.0, 100.0)]);
        assert_eq!(id(map.lane_along(&at, 0.0, 10.0, &right)), MapElementId(3));
        assert_eq!(id(map.lane_along(&at, 0.0, 10.0, &left)), MapElementId(2));
        // No path, or one that ends before the turns part: the nearest.
        assert_eq!(id(map.lane_along(&at, 0.0, 10.0, &[])), MapElementId(2));
        assert_eq!(id(map.lane_along(&at, 0.0, 10.0, &dense(&[(0.0, 0.0), (108.0, 0.0)]))), MapElementId(2));
        // Away from the overlap (lane 1, 5 m back), the path does not move it.
        assert_eq!(id(map.lane_along(&Point2::new(95.0, 0.0), 0.0, 10.0, &right)), MapElementId(1));
        // The projection is the chosen lane's.
        let m = map.lane_along(&at, 0.0, 10.0, &right).unwrap();
        assert!((m.projection.arc_length_m - 5.0).abs() < 1e-9 && m.projection.distance_m < 1e-9);
    }
}
