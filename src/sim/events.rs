//! Collision and off-road detection during a rollout, and the ego's
//! closest approach to any other agent.
//!
//! Collisions are tested on every pair of present agents with a sweep
//! along x (sorted by index for ties) and the exact oriented-box test from
//! `geometry`. A collision is a contact *onset*: the pair overlaps now and
//! both were present and apart at the previous step. Pairs that overlap
//! from the first step they are both present are log artefacts (annotation
//! noise, agents appearing inside one another) and are not collisions.
//! Pedestrian–pedestrian contact is not a collision either: people walking
//! together touch boxes all the time in recorded data. A pair is reported once.

use std::collections::BTreeSet;

pub use crate::scenario::contact::{EgoCollisionKind, EgoContact, LaneOccupancy};
use crate::scenario::{AgentBody, AgentKind, AgentState, Scenario, TrackIndex};

/// Two agents' boxes touched.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CollisionEvent {
    /// Step of first contact.
    pub step: usize,
    /// Lower track index of the pair.
    pub a: TrackIndex,
    /// Higher track index of the pair.
    pub b: TrackIndex,
    /// Whether the ego is one of the two.
    pub involves_ego: bool,
    /// How the ego was involved and where it was among the lanes, when it
    /// was one of the two (judged at the first contact).
    pub ego_contact: Option<EgoContact>,
}

impl CollisionEvent {
    /// The other agent of the pair, seen from `agent` (one of the two).
    pub fn other_than(&self, agent: TrackIndex) -> TrackIndex {
        if self.a == agent { self.b } else { self.a }
    }
}

/// How much farther off the road than at its start an ego that starts off
/// it must go to count as leaving it, m: recorded starts are noisy, but a
/// start 0.1 m over the edge must not excuse driving 16 m off.
pub const OFF_ROAD_START_TOLERANCE_M: f64 = 0.5;

/// The ego left the road.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct OffRoadEvent {
    /// Step at which its most off-road corner crossed the road edge.
    pub step: usize,
    /// Signed distance of that corner to the road edge then, m (positive).
    pub distance_m: f64,
}

/// The ego's closest approach to another agent.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ClosestApproach {
    /// Box distance, m.
    pub distance_m: f64,
    /// Step.
    pub step: usize,
    /// The other agent.
    pub agent: TrackIndex,
}

pub(super) struct EventDetector<'a> {
    scenario: &'a Scenario,
    ego: TrackIndex,
    bodies: &'a [AgentBody],
    /// `diagonals(bodies)`.
    diagonals: Vec<f64>,
    previous: Vec<Option<AgentState>>,
    reported: BTreeSet<(usize, usize)>,
    collisions: Vec<CollisionEvent>,
    ego_was_off_road: bool,
    /// How far off the road the ego started, m, while it has not yet been
    /// back on it: it counts as leaving the road only once it is
    /// [`OFF_ROAD_START_TOLERANCE_M`] farther off than that.
    started_off_road_m: Option<f64>,
    off_road: Vec<OffRoadEvent>,
    /// Step at which the ego left the mapped area (went past a dead end of the map).
    left_mapped_area: Option<usize>,
    closest: Option<ClosestApproach>,
}

/// Each body's diagonal, `length.hypot(width)`: worked out once per rollout
/// rather than per pair and step.
fn diagonals(bodies: &[AgentBody]) -> Vec<f64> {
    bodies.iter().map(|b| b.length_m.hypot(b.width_m)).collect()
}

/// Every overlapping pair `(i, j)`, `i < j`, in ascending order. The pair
/// test is [`OrientedBox::intersects`] with the bodies' diagonals looked up
/// (the same bounding-circle reject, then the same exact test).
fn overlapping_pairs(bodies: &[AgentBody], diagonals: &[f64], states: &[Option<AgentState>]) -> Vec<(usize, usize)> {
    let radius = |i: usize| 0.5 * diagonals[i];
    let mut present: Vec<(f64, usize)> =
        states.iter().enumerate().filter_map(|(i, s)| s.map(|s| (s.position.x - radius(i), i))).collect();
    present.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut out = Vec::new();
    for (k, &(min_x, i)) in present.iter().enumerate() {
        let si = states[i].expect("present");
        let max_x = min_x + 2.0 * radius(i);
        let bi = bodies[i].footprint(&si);
        for &(other_min_x, j) in &present[k + 1..] {
            if other_min_x > max_x {
                break;
            }
            let sj = states[j].expect("present");
            let reach = 0.5 * (diagonals[i] + diagonals[j]);
            if (si.position - sj.position).norm_squared() > reach * reach {
                continue;
            }
            if bi.intersects_exact(&bodies[j].footprint(&sj)) {
                out.push((i.min(j), i.max(j)));
            }
        }
    }
    out.sort_unstable();
    out
}

impl<'a> EventDetector<'a> {
    pub(super) fn new(
        scenario: &'a Scenario,
        ego: TrackIndex,
        bodies: &'a [AgentBody],
        start_states: &[Option<AgentState>],
        start: usize,
    ) -> Self {
        let mut d = Self {
            scenario,
            ego,
            bodies,
            diagonals: diagonals(bodies),
            previous: start_states.to_vec(),
            reported: BTreeSet::new(),
            collisions: Vec::new(),
            ego_was_off_road: false,
            started_off_road_m: None,
            off_road: Vec::new(),
            left_mapped_area: None,
            closest: None,
        };
        d.started_off_road_m = d.ego_off_road_distance(start_states).map(|(x, _)| x).filter(|x| *x > 0.0);
        d.track_closest(start, start_states);
        d
    }

    /// Most off-road corner of the ego: its signed distance, m (Waymo
    /// convention: positive off road), and where it is.
    fn ego_off_road_distance(&self, states: &[Option<AgentState>]) -> Option<(f64, crate::geometry::Point2)> {
        let s = states[self.ego.0]?;
        let corners = self.bodies[self.ego.0].footprint(&s).corners();
        corners
            .iter()
            .filter_map(|c| self.scenario.map.signed_distance_to_road_edge(c).map(|d| (d, *c)))
            .reduce(|a, b| if b.0 > a.0 { b } else { a })
    }

    /// Whether the ego's centre is off the road past the mapped end of it.
    fn ego_centre_past_mapped_end(&self, states: &[Option<AgentState>]) -> bool {
        let Some(s) = states[self.ego.0] else { return false };
        let map = &self.scenario.map;
        map.signed_distance_to_road_edge(&s.position).is_some_and(|d| d > 0.0) && map.is_past_mapped_end(&s.position)
    }

    /// The step at which the ego left the mapped area, if it did.
    pub(super) fn left_mapped_area(&self) -> Option<usize> {
        self.left_mapped_area
    }

    fn track_closest(&mut self, step: usize, states: &[Option<AgentState>]) {
        let Some(ego) = states[self.ego.0] else { return };
        let ego_box = self.bodies[self.ego.0].footprint(&ego);
        let ego_radius_m = 0.5 * self.diagonals[self.ego.0];
        for (i, s) in states.iter().enumerate() {
            let Some(s) = s else { continue };
            if i == self.ego.0 {
                continue;
            }
            let lower = (s.position - ego.position).norm() - ego_radius_m - 0.5 * self.diagonals[i];
            if self.closest.is_some_and(|c| lower >= c.distance_m) {
                continue;
            }
            let d = ego_box.distance(&self.bodies[i].footprint(s));
            if self.closest.is_none_or(|c| d < c.distance_m) {
                self.closest = Some(ClosestApproach { distance_m: d, step, agent: TrackIndex(i) });
            }
        }
    }

    /// Records events at `step`; returns whether the ego collided for the first time.
    pub(super) fn observe(&mut self, step: usize, states: &[Option<AgentState>]) -> bool {
        let mut ego_hit = false;
        for (i, j) in overlapping_pairs(self.bodies, &self.diagonals, states) {
            let apart_before = match (self.previous[i], self.previous[j]) {
                (Some(pi), Some(pj)) => !self.bodies[i].footprint(&pi).intersects(&self.bodies[j].footprint(&pj)),
                _ => false,
            };
            let both_pedestrians =
                self.bodies[i].kind == AgentKind::Pedestrian && self.bodies[j].kind == AgentKind::Pedestrian;
            if !apart_before || both_pedestrians || !self.reported.insert((i, j)) {
                continue;
            }
            let involves_ego = i == self.ego.0 || j == self.ego.0;
            let first_for_ego = involves_ego && !self.collisions.iter().any(|c| c.involves_ego);
            ego_hit |= first_for_ego;
            let ego_contact = involves_ego.then(|| {
                let other = if i == self.ego.0 { j } else { i };
                let ego = states[self.ego.0].expect("present");
                let ego_box = self.bodies[self.ego.0].footprint(&ego);
                EgoContact::judge(&self.scenario.map, &ego, &ego_box, &states[other].expect("present"))
            });
            self.collisions.push(CollisionEvent {
                step,
                a: TrackIndex(i),
                b: TrackIndex(j),
                involves_ego,
                ego_contact,
            });
        }
        if let Some((d, corner)) = self.ego_off_road_distance(states) {
            // A recorded ego may start with a corner over the edge (or in a
            // car park): that is excused, driving farther off is not.
            let off = d > 0.0 && self.started_off_road_m.is_none_or(|d0| d > d0 + OFF_ROAD_START_TOLERANCE_M);
            if d <= 0.0 {
                self.started_off_road_m = None;
            }
            if off && !self.ego_was_off_road {
                // Past a dead end of the map the road is not known to end:
                // the recording's map does. That is not leaving the road.
                if self.scenario.map.is_past_mapped_end(&corner) {
                    self.left_mapped_area = Some(step);
                } else {
                    self.off_road.push(OffRoadEvent { step, distance_m: d });
                }
            } else if off && self.left_mapped_area.is_none() && self.ego_centre_past_mapped_end(states) {
                // Off the road already (a corner over a kerb near the cut) and
                // now through the cut itself: whatever came first, a rollout
                // does not go on past the map, in any mode.
                self.left_mapped_area = Some(step);
            }
            self.ego_was_off_road = off;
        }
        self.track_closest(step, states);
        self.previous.clear();
        self.previous.extend_from_slice(states);
        ego_hit
    }

    pub(super) fn finish(self) -> (Vec<CollisionEvent>, Vec<OffRoadEvent>, Option<ClosestApproach>) {
        (self.collisions, self.off_road, self.closest)
    }
}
