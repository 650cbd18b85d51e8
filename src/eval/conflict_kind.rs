//! What kind of conflict a CBV made with the ego, from the geometry at
//! their closest approach: the kinds a planner team's coverage table
//! counts (`rear-end`, `cut-in`, `merge`, `crossing`,
//! `left-turn-across-path`, `head-on`, `sideswipe`, `other`). Headings
//! come from the states, lanes from the map where it has them.
//!
//! The rules, in the order they are tried, with Δ the angle between the
//! two headings at the closest approach and "before" the states
//! [`LOOKBACK_S`] earlier (or the first both were present):
//! 1. no conflict unless the boxes came within [`NEAR_MISS_M`];
//! 2. `other` when either is not a vehicle;
//! 3. `head-on` when Δ ≥ 150°;
//! 4. `left-turn-across-path` when Δ ≥ 45°, the two drove opposite ways
//!    before (≥ 135° apart) and one of them has since turned left by 30°
//!    or more; `crossing` for every other Δ ≥ 45°;
//! 5. below 45° (the same direction): `merge` when the CBV came from a
//!    lane other than the ego's that runs into the ego's lane (the lanes
//!    ahead of the CBV's, as far as either drove since "before" plus
//!    [`MERGE_MARGIN_M`], pass a lane two lanes lead into and reach the
//!    ego's lane "before" or a lane ahead of it: an on-ramp, a lane drop,
//!    two ways through a junction) and the CBV took that way (on the map
//!    a lane may branch): between [`PATH_AFTER_S`] and [`MERGED_WITHIN_S`]
//!    after the closest approach it drove on the ego's track; unless the
//!    CBV's way runs through a lane the ego drove earlier (it follows the
//!    ego). `cut-in` when the CBV moved sideways into the ego's path ahead
//!    of it (in the map: from a lane neighbouring the ego's into the
//!    ego's; without lanes: from more than [`LANE_OFFSET_M`] to the side
//!    to less than half of it). Neither is the CBV's when the ego moved
//!    sideways more than half of [`LANE_OFFSET_M`] farther than the CBV
//!    since "before": the ego changed lanes. `rear-end` when one is behind
//!    the other (the other's centre within 45° of its heading or its
//!    tail); `sideswipe` otherwise (side by side).
//!
//! Lane relations come from the map where it records them. A map that
//! records no successors at all (GPUDrive's WOMD JSON keeps none) has them
//! joined by geometry ([`LaneGraph`](crate::map::lane_graph::LaneGraph): a lane that starts where another
//! ends, going its way); a map that records no neighbours at all has the
//! cut-in judged by lateral offset, as without lanes. Without this, every
//! cut-in and merge on such a map reads as a sideswipe or rear-end.

use crate::geometry::polyline::segment_distance_squared;
use crate::geometry::wrap_angle;
use crate::map::lane_relations::{LaneAhead, LaneRelations};
use crate::map::{MapElementId, RoadMap};
use crate::scenario::{AgentBody, AgentKind, AgentState};
use crate::sim::Rollout;

/// Closest approach under which the pair counts as a conflict (a
/// collision or a near miss), m (box distance).
pub const NEAR_MISS_M: f64 = 1.0;

/// How far before the closest approach "before" is, s.
pub const LOOKBACK_S: f64 = 3.0;

/// Lateral offset of a neighbouring lane's car, where the map has no lanes, m.
pub const LANE_OFFSET_M: f64 = 2.5;

/// How much farther than either party drove over the look-back the lanes
/// ahead are followed to find where the CBV's lane and the ego's meet, m.
pub const MERGE_MARGIN_M: f64 = 10.0;

/// Every this many steps the ego's lanes before the closest approach are
/// read, to tell a CBV following the ego's way from one merging into it.
const EGO_PATH_EVERY: usize = 5;

/// A merge is read from the way the CBV took from this long after the
/// closest approach, s; a rollout that ends sooner leaves it to the map.
pub const PATH_AFTER_S: f64 = 1.0;

/// … up to this long after it, s: by then a CBV that merged drives on the
/// ego's track.
pub const MERGED_WITHIN_S: f64 = 3.0;

/// On the ego's track, the CBV heads within this of the ego's heading, °.
pub const ON_TRACK_MAX_HEADING_DEG: f64 = 30.0;

/// The kinds of conflict.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum ConflictKind {
    /// One drives into the other from behind, in one lane.
    RearEnd,
    /// The CBV moves sideways into the ego's lane just ahead of it.
    CutIn,
    /// The CBV's lane runs into the ego's (an on-ramp, a lane drop).
    Merge,
    /// Paths crossing at an angle (an intersection, a driveway).
    Crossing,
    /// One turns left across the path of the other coming the other way.
    LeftTurnAcrossPath,
    /// Driving at each other.
    HeadOn,
    /// Side by side, the same direction.
    Sideswipe,
    /// Anything else (a pedestrian or cyclist involved).
    Other,
}

impl ConflictKind {
    /// Every kind, in the order tables list them.
    pub const ALL: &'static [Self] = &[
        Self::RearEnd,
        Self::CutIn,
        Self::Merge,
        Self::Crossing,
        Self::LeftTurnAcrossPath,
        Self::HeadOn,
        Self::Sideswipe,
        Self::Other,
    ];

    /// Its name in reports and specs (`rear-end`, `cut-in`, …).
    pub fn name(self) -> &'static str {
        match self {
            Self::RearEnd => "rear-end",
            Self::CutIn => "cut-in",
            Self::Merge => "merge",
            Self::Crossing => "crossing",
            Self::LeftTurnAcrossPath => "left-turn-across-path",
            Self::HeadOn => "head-on",
            Self::Sideswipe => "sideswipe",
            Self::Other => "other",
        }
    }
}

/// One of the pair over a rollout: its body and its state per step
/// (`None`: absent).
#[derive(Debug, Clone, Copy)]
pub struct ConflictParty<'a> {
    /// Type and size.
    pub body: AgentBody,
    /// State per step, the same steps for both parties.
    pub states: &'a [Option<AgentState>],
}

/// The kind of conflict between a rollout's ego and CBV (`None`: no CBV,
/// or it never came within [`NEAR_MISS_M`]).
pub fn rollout_conflict(map: &RoadMap, rollout: &Rollout) -> Option<ConflictKind> {
    let cbv = rollout.cbv?;
    let column = |agent: usize| -> Vec<Option<AgentState>> {
        rollout.states.iter().map(|row| row.get(agent).copied().flatten()).collect()
    };
    let (ego_states, cbv_states) = (column(rollout.ego.0), column(cbv.0));
    classify_conflict(
        map,
        ConflictParty { body: *rollout.bodies.get(rollout.ego.0)?, states: &ego_states },
        ConflictParty { body: *rollout.bodies.get(cbv.0)?, states: &cbv_states },
        rollout.dt_s,
    )
}

/// The kind of conflict between `ego` and `cbv` over a rollout at `dt_s`
/// per step (the module's rules), or `None` when their boxes never came
/// within [`NEAR_MISS_M`].
pub fn classify_conflict(
    map: &RoadMap,
    ego: ConflictParty<'_>,
    cbv: ConflictParty<'_>,
    dt_s: f64,
) -> Option<ConflictKind> {
    let both = |k: usize| Some((ego.states.get(k).copied().flatten()?, cbv.states.get(k).copied().flatten()?));
    let steps = ego.states.len().min(cbv.states.len());
    // The closest approach (the first step at the least distance).
    let (closest, gap_m) = (0..steps)
        .filter_map(|k| both(k).map(|(e, c)| (k, ego.body.footprint(&e).distance(&cbv.body.footprint(&c)))))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    if gap_m.is_nan() || gap_m > NEAR_MISS_M {
        return None;
    }
    let vehicle = |b: &AgentBody| b.kind == AgentKind::Vehicle;
    if !vehicle(&ego.body) || !vehicle(&cbv.body) {
        return Some(ConflictKind::Other);
    }
    let (e, c) = both(closest)?;
    let lookback = (LOOKBACK_S / dt_s).round() as usize;
    let (e0, c0) = (closest.saturating_sub(lookback)..=closest).find_map(both)?;
    let apart = |a: f64, b: f64| wrap_angle(a - b).abs().to_degrees();
    let delta = apart(c.heading_rad, e.heading_rad);
    if delta >= 150.0 {
        return Some(ConflictKind::HeadOn);
    }
    if delta >= 45.0 {
        let turned_left = |now: f64, then: f64| wrap_angle(now - then).to_degrees() >= 30.0;
        let opposite_before = apart(c0.heading_rad, e0.heading_rad) >= 135.0;
        let left_turn = turned_left(c.heading_rad, c0.heading_rad) || turned_left(e.heading_rad, e0.heading_rad);
        return Some(if opposite_before && left_turn {
            ConflictKind::LeftTurnAcrossPath
        } else {
            ConflictKind::Crossing
        });
    }
    let relations = LaneRelations::of(map);
    let lanes = |s: &AgentState| map.lanes_containing(&s.position, s.heading_rad);
    let (ego_now, ego_then, cbv_now, cbv_then) = (lanes(&e), lanes(&e0), lanes(&c), lanes(&c0));
    let ego_lanes: Vec<MapElementId> = ego_now.iter().chain(&ego_then).copied().collect();
    // An ego that steers across into the CBV's lane looks, by lanes and
    // offsets between the two alone, like the CBV merging or cutting in:
    // the one that moved sideways is the one that changed lanes.
    let sideways_m = |from: &AgentState, to: &AgentState| from.pose().to_body(&to.position).y.abs();
    let ego_moved_over = sideways_m(&e0, &e) > sideways_m(&c0, &c) + LANE_OFFSET_M / 2.0;
    let from_elsewhere =
        !cbv_then.is_empty() && !ego_then.is_empty() && !relations.any_connected(&cbv_then, &ego_lanes);
    if from_elsewhere {
        // Where the two lanes meet may lie a few lane pieces on (short
        // pieces through a junction): look as far as either drove.
        let within_m = (c.position - c0.position).norm().max((e.position - e0.position).norm()) + MERGE_MARGIN_M;
        let (cbv_ahead, ego_ahead) =
            (relations.lanes_ahead(&cbv_then, within_m), relations.lanes_ahead(&ego_then, within_m));
        // The lanes the ego drove before: a CBV whose way ahead runs
        // through one of them (not the lane the ego is in) follows it.
        let ego_before: Vec<MapElementId> = (0..closest)
            .step_by(EGO_PATH_EVERY)
            .filter_map(|k| ego.states.get(k).copied().flatten())
            .flat_map(|s| lanes(&s))
            .collect();
        let on_the_egos_way = |l: &LaneAhead| ego_before.contains(&l.id) && !ego_lanes.contains(&l.id);
        let one_behind_the_other = cbv_ahead.iter().any(on_the_egos_way)
            || ego_ahead.iter().map(|l| &l.id).chain(&ego_before).any(|l| cbv_then.contains(l));
        // The CBV's way must pass a lane two lanes lead into (a lane that
        // only goes on into the ego's in pieces leaves the CBV behind in the
        // ego's lane, however far back), and meet the ego's own way (its
        // lane before and those ahead of it), not a lane the ego moved
        // into: an ego changing into the CBV's lane is no merge.
        let lanes_meet = cbv_ahead
            .iter()
            .any(|l| l.through_junction && (ego_then.contains(&l.id) || ego_ahead.iter().any(|a| a.id == l.id)));
        if lanes_meet
            && !one_behind_the_other
            && !ego_moved_over
            && cbv_took_the_egos_track(ego, cbv, closest.saturating_sub(lookback), closest, dt_s)
        {
            return Some(ConflictKind::Merge);
        }
    }
    let ahead = e.pose().to_body(&c.position).x > 0.0;
    let side_then = e0.pose().to_body(&c0.position).y.abs();
    let side_now = e.pose().to_body(&c.position).y.abs();
    let moved_sideways_in = side_then > LANE_OFFSET_M && side_now < LANE_OFFSET_M / 2.0;
    let moved_in = if cbv_then.is_empty() || ego_then.is_empty() {
        moved_sideways_in
    } else if relations.neighbours_recorded() {
        let beside = map.neighbours_of(&cbv_then).iter().any(|n| ego_then.contains(n));
        from_elsewhere && beside && relations.any_connected(&cbv_now, &ego_lanes)
    } else {
        from_elsewhere && moved_sideways_in
    };
    if moved_in && ahead && !ego_moved_over {
        return Some(ConflictKind::CutIn);
    }
    let bearing = |from: &AgentState, to: &AgentState| {
        let rel = from.pose().to_body(&to.position);
        rel.y.atan2(rel.x).abs().to_degrees()
    };
    let in_line = |b: f64| b <= 45.0 || b >= 135.0;
    Some(if in_line(bearing(&e, &c)) && in_line(bearing(&c, &e)) {
        ConflictKind::RearEnd
    } else {
        ConflictKind::Sideswipe
    })
}

/// Whether the CBV, between [`PATH_AFTER_S`] and [`MERGED_WITHIN_S`]
/// after the closest approach, drove on the ego's track (its path from
/// "before" to the end of the rollout): within half a lane of it and
/// within [`ON_TRACK_MAX_HEADING_DEG`] of the ego's heading there. Where
/// the map lets the CBV's lane run into the ego's, the merge happened
/// only if the CBV took that way: a truck going straight through a
/// junction beside an ego turning left shares the left-turn exit with it
/// on the map, not on the road. A rollout that ends sooner leaves the way
/// each would have taken unknown, and the map's answer stands.
fn cbv_took_the_egos_track(
    ego: ConflictParty<'_>,
    cbv: ConflictParty<'_>,
    then: usize,
    closest: usize,
    dt_s: f64,
) -> bool {
    let steps = |s: f64| (s / dt_s).round() as usize;
    let (from, to) = (closest + steps(PATH_AFTER_S), closest + steps(MERGED_WITHIN_S));
    let last = |p: &ConflictParty<'_>| p.states.iter().rposition(Option::is_some);
    if last(&ego).is_none_or(|k| k < from) || last(&cbv).is_none_or(|k| k < from) {
        return true;
    }
    let track: Vec<AgentState> = ego.states.iter().skip(then).flatten().copied().collect();
    let on_track = |c: &AgentState| {
        track.windows(2).any(|w| {
            let ends = [w[0].position, w[1].position];
            // A standing ego's step is a point, which the segment helper has no direction for.
            let off_m = if ends[0] == ends[1] {
                (c.position - ends[0]).norm()
            } else {
                segment_distance_squared(&ends, &c.position).0.sqrt()
            };
            off_m < LANE_OFFSET_M / 2.0
                && wrap_angle(c.heading_rad - w[0].heading_rad).abs().to_degrees() < ON_TRACK_MAX_HEADING_DEG
        })
    };
    cbv.states.iter().take(to + 1).skip(from).flatten().any(on_track)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Polyline, Vector2};
    use crate::map::Lane;
    use crate::map::templates::{MapTemplate, Merge, StraightRoad};
    use crate::motion::{Action, KinematicState, kinematic_step};

    const DT_S: f64 = 0.1;
    const CAR: AgentBody = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };

    /// 8 s from (x, y, heading°) at `speed_mps`, the yaw rate (°/s) given
    /// per second by `turn`.
    fn drive(x: f64, y: f64, heading_deg: f64, speed_mps: f64, turn: impl Fn(f64) -> f64) -> Vec<Option<AgentState>> {
        let h = heading_deg.to_radians();
        let mut state = KinematicState::from_agent_state(&AgentState {
            position: Point2::new(x, y),
            heading_rad: h,
            velocity_mps: Vector2::new(h.cos(), h.sin()) * speed_mps,
        });
        (0..80)
            .map(|k| {
                let now = state.to_agent_state();
                let action = Action { accel_mps2: 0.0, yaw_rate_radps: turn(k as f64 * DT_S).to_radians() };
                state = kinematic_step(&state, action, DT_S);
                Some(now)
            })
            .collect()
    }

    /// A lane change's yaw rate (°/s at time t, s): `rate_degps` over
    /// `turn`, as much the other way over `back`.
    fn turn_and_back(turn: std::ops::Range<f64>, back: std::ops::Range<f64>, rate_degps: f64) -> impl Fn(f64) -> f64 {
        move |t| {
            if turn.contains(&t) {
                rate_degps
            } else if back.contains(&t) {
                -rate_degps
            } else {
                0.0
            }
        }
    }

    fn straight(x: f64, y: f64, heading_deg: f64, speed_mps: f64) -> Vec<Option<AgentState>> {
        drive(x, y, heading_deg, speed_mps, |_| 0.0)
    }

    /// A lane `id` along `points`, without recorded connectivity.
    fn lane(id: i64, points: &[(f64, f64)]) -> Lane {
        Lane::new(MapElementId(id), Polyline::new(points.iter().map(|&(x, y)| Point2::new(x, y)).collect()))
    }

    fn kind(map: &RoadMap, ego: &[Option<AgentState>], cbv: &[Option<AgentState>]) -> Option<ConflictKind> {
        classify_conflict(map, ConflictParty { body: CAR, states: ego }, ConflictParty { body: CAR, states: cbv }, DT_S)
    }

    /// Two lanes along +x, 3.5 m wide: lane 0 at y = 1.75, lane 1 at 5.25.
    fn two_lanes() -> RoadMap {
        let road: StraightRoad = serde_json::from_value(serde_json::json!({"lanes": 2, "length_m": 400})).unwrap();
        MapTemplate::Straight(road).build()
    }

    #[test]
    fn a_faster_car_behind_in_the_same_lane_is_a_rear_end() {
        let map = two_lanes();
        assert_eq!(
            kind(&map, &straight(50.0, 1.75, 0.0, 10.0), &straight(20.0, 1.75, 0.0, 20.0)),
            Some(ConflictKind::RearEnd)
        );
    }

    #[test]
    fn a_car_from_the_next_lane_ahead_is_a_cut_in_and_beside_it_a_sideswipe() {
        let map = two_lanes();
        let ego = straight(0.0, 1.75, 0.0, 10.0);
        // 12 m ahead, slower, heading 8° into lane 0: it is in the ego's lane when they touch.
        let cutting_in = straight(12.0, 5.25, -8.0, 7.0);
        assert_eq!(kind(&map, &ego, &cutting_in), Some(ConflictKind::CutIn));
        // Without lanes, the same by lateral offset.
        assert_eq!(kind(&RoadMap::default(), &ego, &cutting_in), Some(ConflictKind::CutIn));
        // Level with the ego, drifting in: they touch side by side, the CBV still in lane 1.
        assert_eq!(kind(&map, &ego, &straight(0.5, 5.25, -8.0, 10.0)), Some(ConflictKind::Sideswipe));
    }

    #[test]
    fn a_car_from_the_on_ramp_is_a_merge() {
        let merge: Merge = serde_json::from_value(serde_json::json!({
            "lanes": 2, "length_m": 400, "merge_end_m": 200, "acceleration_lane_m": 70
        }))
        .unwrap();
        let map = MapTemplate::Merge(merge).build();
        // The ramp runs at y = -1.75 from x = 130 to 200 and leads into lane 10, lane 0's successor.
        let ego = straight(135.0, 1.75, 0.0, 11.0);
        assert_eq!(kind(&map, &ego, &straight(140.0, -1.75, 7.0, 10.0)), Some(ConflictKind::Merge));
    }

    /// `map` as a source without lane connectivity keeps it (GPUDrive's
    /// WOMD JSON): no successors, predecessors or neighbours.
    fn without_connectivity(mut map: RoadMap) -> RoadMap {
        for lane in &mut map.lanes {
            lane.successors.clear();
            lane.predecessors.clear();
            lane.left_neighbours.clear();
            lane.right_neighbours.clear();
        }
        map
    }

    #[test]
    fn without_recorded_connectivity_cut_ins_and_merges_are_read_from_the_geometry() {
        let bare = without_connectivity(two_lanes());
        let ego = straight(0.0, 1.75, 0.0, 10.0);
        assert_eq!(kind(&bare, &ego, &straight(12.0, 5.25, -8.0, 7.0)), Some(ConflictKind::CutIn));
        assert_eq!(kind(&bare, &ego, &straight(0.5, 5.25, -8.0, 10.0)), Some(ConflictKind::Sideswipe));
        assert_eq!(
            kind(&bare, &straight(50.0, 1.75, 0.0, 10.0), &straight(20.0, 1.75, 0.0, 20.0)),
            Some(ConflictKind::RearEnd)
        );
        let merge: Merge = serde_json::from_value(serde_json::json!({
            "lanes": 2, "length_m": 400, "merge_end_m": 200, "acceleration_lane_m": 70
        }))
        .unwrap();
        let bare = without_connectivity(MapTemplate::Merge(merge).build());
        let ego = straight(135.0, 1.75, 0.0, 11.0);
        assert_eq!(kind(&bare, &ego, &straight(140.0, -1.75, 7.0, 10.0)), Some(ConflictKind::Merge));
    }

    const EGO_X0: f64 = 8.0;
    const CBV_AIM_X: f64 = 30.0;
    const CBV_SPEED: f64 = 8.0;

    #[test]
    fn lanes_that_meet_a_few_short_pieces_on_make_a_merge_and_one_lane_in_pieces_a_rear_end() {
        // No recorded connectivity, short pieces as through a junction:
        // 0 → 1 → 2 → 3 along y = 0, and 4 → 5 from the south-west into 3's start.
        let map = RoadMap::from_lanes(vec![
            lane(0, &[(-60.0, 0.0), (0.0, 0.0)]),
            lane(1, &[(0.0, 0.0), (20.0, 0.0)]),
            lane(2, &[(20.0, 0.0), (30.0, 0.0)]),
            lane(3, &[(30.0, 0.0), (100.0, 0.0)]),
            lane(4, &[(0.0, -8.0), (20.0, -2.7)]),
            lane(5, &[(20.0, -2.7), (30.0, 0.0)]),
        ]);
        // The ego drives 1 → 2 → 3 at 5 m/s.
        let ego = straight(EGO_X0, 0.0, 0.0, 5.0);
        // From lane 4 up to the ego's tail in lane 3: their lanes meet two pieces on.
        let heading_deg = (8.0f64).atan2(CBV_AIM_X).to_degrees();
        assert_eq!(kind(&map, &ego, &straight(0.0, -8.0, heading_deg, CBV_SPEED)), Some(ConflictKind::Merge));
        // From lane 0 behind the ego, faster: the same way, a rear-end,
        // though lane 1 is two pieces behind lane 3 when they meet.
        assert_eq!(kind(&map, &ego, &straight(-50.0, 0.0, 0.0, 12.0)), Some(ConflictKind::RearEnd));
        // An ego waiting in lane 2, which only lane 1 leads into, and a CBV
        // from lane 0: however far back, it is in the ego's lane.
        let waiting =
            vec![
                Some(AgentState { position: Point2::new(26.0, 0.0), heading_rad: 0.0, velocity_mps: Vector2::zeros() });
                80
            ];
        assert_eq!(kind(&map, &waiting, &straight(-50.0, 0.0, 0.0, 20.0)), Some(ConflictKind::RearEnd));
    }

    #[test]
    fn a_cbv_whose_lane_could_run_into_the_egos_but_turns_away_makes_no_merge() {
        // No recorded connectivity: the ego's lane 1 → 3 along y = 0; the
        // CBV's lane 40 → 4 forks where it nears the ego's: 5 runs into 3, 6 away.
        let map = RoadMap::from_lanes(vec![
            lane(1, &[(-60.0, 0.0), (30.0, 0.0)]),
            lane(3, &[(30.0, 0.0), (150.0, 0.0)]),
            lane(40, &[(-10.0, -10.65), (0.0, -8.0)]),
            lane(4, &[(0.0, -8.0), (20.0, -2.7)]),
            lane(5, &[(20.0, -2.7), (30.0, 0.0)]),
            lane(6, &[(20.0, -2.7), (150.0, -11.3)]),
        ]);
        let ego = straight(-6.0, 0.0, 0.0, 5.0);
        let (into_deg, away_deg) = (10.6f64.atan2(40.0).to_degrees(), (-8.6f64).atan2(130.0).to_degrees());
        // Up lanes 40 and 4 at 8 m/s, reaching the fork at 5.2 s, then turning for 1 s
        // into lane 5 (it drives on in the ego's lane 3) or lane 6.
        let cbv = |to_deg: f64| {
            drive(-20.0, -13.3, into_deg, 8.0, move |t| if (4.7..5.7).contains(&t) { to_deg - into_deg } else { 0.0 })
        };
        let into_5 = 2.7f64.atan2(10.0).to_degrees();
        assert_eq!(kind(&map, &ego, &cbv(into_5)), Some(ConflictKind::Merge));
        let away = kind(&map, &ego, &cbv(away_deg));
        assert!(away.is_some() && away != Some(ConflictKind::Merge), "{away:?}");
    }

    #[test]
    fn an_ego_that_moves_over_into_the_cbvs_lane_makes_no_cbv_merge_or_cut_in() {
        // No recorded connectivity: the ego's lane 1 → 2 bends into lane 3,
        // which the CBV's lane 10 → 11 also leads into (the ego's lane drops).
        let map = RoadMap::from_lanes(vec![
            lane(1, &[(-40.0, 0.0), (0.0, 0.0)]),
            lane(2, &[(0.0, 0.0), (20.0, 3.5)]),
            lane(10, &[(-40.0, 3.5), (-10.0, 3.5)]),
            lane(12, &[(-10.0, 3.5), (5.0, 3.5)]),
            lane(11, &[(5.0, 3.5), (20.0, 3.5)]),
            lane(3, &[(20.0, 3.5), (300.0, 3.5)]),
        ]);
        // Both at 12 m/s; the ego moves over from 2 s to 4 s and ends 0.6 m
        // behind the CBV, which keeps its lane.
        let ego = drive(-24.0, 0.0, 0.0, 12.0, turn_and_back(2.0..2.5, 3.5..4.0, 20.0));
        let ego_at_4s = ego[40].unwrap().position;
        let cbv = straight(ego_at_4s.x + CAR.length_m + 0.6 - 48.0, 3.5, 0.0, 12.0);
        // By lanes alone the CBV's lane runs into the ego's way, and by
        // offsets the CBV came from the side into the ego's path ahead.
        assert_eq!(kind(&map, &ego, &cbv), Some(ConflictKind::RearEnd));
    }

    #[test]
    fn an_ego_changing_into_the_cbvs_lane_past_a_junction_is_no_merge() {
        // No recorded connectivity: lane 1 → 2 → 3 at y = 0, lane 11 → 12 → 13
        // at y = 3.5, and a ramp 20 joining lane 12 where it starts.
        let map = RoadMap::from_lanes(vec![
            lane(1, &[(0.0, 0.0), (20.0, 0.0)]),
            lane(2, &[(20.0, 0.0), (40.0, 0.0)]),
            lane(3, &[(40.0, 0.0), (200.0, 0.0)]),
            lane(11, &[(0.0, 3.5), (20.0, 3.5)]),
            lane(12, &[(20.0, 3.5), (40.0, 3.5)]),
            lane(13, &[(40.0, 3.5), (200.0, 3.5)]),
            lane(20, &[(0.0, 8.0), (20.0, 3.5)]),
        ]);
        // The CBV keeps lane 11 → 12 → 13 at 12 m/s; the ego, ahead and
        // slower, steers from lane 2 into lane 13 (2 s, ±30°/s) past the junction.
        let cbv = straight(-10.0, 3.5, 0.0, 12.0);
        let ego = drive(25.0, 0.0, 0.0, 6.0, turn_and_back(2.0..3.0, 3.0..4.0, 30.0));
        let got = kind(&map, &ego, &cbv);
        assert!(got.is_some() && got != Some(ConflictKind::Merge), "{got:?}");
    }

    #[test]
    fn crossing_paths_left_turns_and_head_on() {
        let open = RoadMap::default();
        let ego = straight(-30.0, 0.0, 0.0, 10.0);
        assert_eq!(kind(&open, &ego, &straight(0.0, -30.0, 90.0, 10.0)), Some(ConflictKind::Crossing));
        assert_eq!(kind(&open, &ego, &straight(60.0, 0.5, 180.0, 10.0)), Some(ConflictKind::HeadOn));
        // The CBV drives east for 2 s, then turns left by 60° over 2 s.
        let turning = drive(-30.0, -1.75, 0.0, 8.0, |t| if (2.0..4.0).contains(&t) { 30.0 } else { 0.0 });
        let at_4s = turning[40].unwrap().position;
        // Oncoming from the east, timed to meet it there: a left turn across its path.
        let oncoming = straight(at_4s.x + 2.0 + 40.0, at_4s.y, 180.0, 10.0);
        assert_eq!(kind(&open, &oncoming, &turning), Some(ConflictKind::LeftTurnAcrossPath));
        // The same turn met by a car from the north: they did not come from opposite ways.
        let from_north = straight(at_4s.x, at_4s.y + 2.0 + 40.0, -90.0, 10.0);
        assert_eq!(kind(&open, &from_north, &turning), Some(ConflictKind::Crossing));
    }

    #[test]
    fn a_pedestrian_is_other_and_a_pair_never_near_is_no_conflict() {
        let open = RoadMap::default();
        let ego = straight(-30.0, 0.0, 0.0, 10.0);
        let walker = AgentBody { kind: AgentKind::Pedestrian, length_m: 0.5, width_m: 0.5 };
        let crossing = straight(0.0, -4.0, 90.0, 1.4);
        let got = classify_conflict(
            &open,
            ConflictParty { body: CAR, states: &ego },
            ConflictParty { body: walker, states: &crossing },
            DT_S,
        );
        assert_eq!(got, Some(ConflictKind::Other));
        assert_eq!(kind(&open, &ego, &straight(-30.0, 10.0, 0.0, 10.0)), None);
        // 1 m is still a near miss; 1.2 m is not.
        assert_eq!(kind(&open, &ego, &straight(-30.0, 3.0, 0.0, 10.0)), Some(ConflictKind::Sideswipe));
        assert_eq!(kind(&open, &ego, &straight(-30.0, 3.2, 0.0, 10.0)), None);
    }

    #[test]
    fn kinds_are_named_as_they_serialise() {
        for kind in ConflictKind::ALL {
            assert_eq!(serde_json::to_value(kind).unwrap(), kind.name());
        }
    }
}
