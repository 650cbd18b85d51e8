//! Traffic rules over the ego's rollout, the checks planner teams expect
//! from a scenario runner (CARLA ScenarioRunner's `WrongLaneTest` and
//! `RunningRedLightTest`): driving against the traffic of a lane, and
//! passing a stop line while its signal shows red.
//!
//! Both read the rollout's ego states and the map. **Wrong way**: the
//! ego's centre (or any agent's: [`wrong_way_of`] judges the CBV by the
//! same rule) lies in a lane (its area, as [`RoadMap::lanes_containing`]
//! measures it) whose direction is more than [`WRONG_WAY_MIN_ANGLE_RAD`]
//! from the ego's heading, in no lane running the ego's way and more than
//! 3 m from the centreline of any such lane (a wide lane, or a swerve past a
//! parked car, is not wrong way), outside intersections (where lanes cross
//! at every angle), while the ego moves. On the shared recorded scenes the
//! logged egos are flagged in 2 of 196 (`recorded_egos_mostly_keep_the_traffic_rules`).
//! **Across the lanes** ([`across_lanes_of`], a measure of how plausibly
//! an agent drives rather than a rule a planner is failed by): more than
//! 30° from every lane its centre lies in, outside intersections, at
//! 3 m/s or more.
//! **Red light**: the ego's centre passes the stop point of a signal that
//! shows red (a red circle or a red arrow for its lane; flashing red means
//! stop, then go, and is not counted) at the step it passes, while the
//! ego is in that lane. The centre, not the front bumper, so that stopping
//! a little over the line is not running the light. **Speeding**: the ego
//! drives more than [`SPEEDING_TOLERANCE`] above the speed limit of the lane
//! it is in (the nearest lane running its way within 3 m), for longer
//! than [`SPEEDING_MIN_S`] (a moment's overshoot is not speeding).

use crate::geometry::Vector2;
use crate::map::{MapElementId, RoadMap, SignalState};
use crate::scenario::{AgentState, TrackIndex};
use crate::sim::Rollout;

use crate::map::OWN_LANE_CLEARANCE_M;
pub use crate::map::{ACROSS_LANES_MIN_ANGLE_RAD, WRONG_WAY_MIN_ANGLE_RAD};

/// The ego's longest stretch against the traffic of a lane.
#[derive(Debug, Clone, PartialEq)]
pub struct WrongWay {
    /// When it began, s after the rollout's start.
    pub start_s: f64,
    /// How long it lasted, s (one step counts as `dt_s`).
    pub duration_s: f64,
    /// The lane whose traffic the ego drove against when it began.
    pub lane: MapElementId,
}

/// The ego passing a red light.
#[derive(Debug, Clone, PartialEq)]
pub struct RedLightRun {
    /// When its centre passed the stop point, s after the rollout's start.
    pub time_s: f64,
    /// The signal-controlled lane.
    pub lane: MapElementId,
    /// The signal's state then.
    pub state: SignalState,
}

/// Shortest centreline that gives a lane a direction, m: a lane cut to a
/// point, or to a few centimetres, says nothing about which way traffic
/// flows.
pub const MIN_DIRECTED_LANE_M: f64 = 1.0;

/// Whether `map` has a lane that tells the traffic's direction (at least
/// [`MIN_DIRECTED_LANE_M`] long); without one, driving the wrong way
/// cannot be measured.
pub fn has_directed_lanes(map: &RoadMap) -> bool {
    map.lanes.iter().any(|l| l.centreline.len() >= 2 && l.centreline.length_m() >= MIN_DIRECTED_LANE_M)
}

/// The ego's longest stretch of driving against a lane's traffic, or
/// `None` when it never did. Ties go to the earliest.
pub fn wrong_way(rollout: &Rollout, map: &RoadMap) -> Option<WrongWay> {
    wrong_way_of(rollout, map, rollout.ego)
}

/// [`wrong_way`] for any agent of the rollout (the CBV, to judge how
/// plausibly an adversary drives): its longest stretch against a lane's
/// traffic, by the same rule as the ego's.
pub fn wrong_way_of(rollout: &Rollout, map: &RoadMap, agent: TrackIndex) -> Option<WrongWay> {
    let against_at = |row: &Vec<Option<AgentState>>| against_traffic(map, row.get(agent.0)?.as_ref()?);
    let (first, found) = longest_stretch(rollout.states.iter().map(against_at))?;
    Some(WrongWay {
        start_s: first as f64 * rollout.dt_s,
        duration_s: found.len() as f64 * rollout.dt_s,
        lane: found[0],
    })
}

/// A road user's longest stretch of driving across the lanes.
#[derive(Debug, Clone, PartialEq)]
pub struct AcrossLanes {
    /// When it began, s after the rollout's start.
    pub start_s: f64,
    /// How long it lasted, s (one step counts as `dt_s`).
    pub duration_s: f64,
    /// The largest angle to the lanes over the stretch, rad.
    pub max_angle_rad: f64,
}

/// How long a road user must drive across the lanes for it to count, s:
/// longer than a recorded heading's noise lasts, shorter than any lane
/// change made at 30° or more (at 3 m/s one crosses a lane in about 2 s).
pub const ACROSS_LANES_MIN_S: f64 = 1.0;

/// An agent's longest stretch of driving across the lanes it is in (at
/// more than [`ACROSS_LANES_MIN_ANGLE_RAD`] to every one of them, outside
/// intersections: [`RoadMap::angle_across_lanes_at`]), or `None` when it
/// never did. Ties go to the earliest. Humans change lanes at a few
/// degrees; a CBV cutting across a freeway at 40° is not driving as they
/// do, though its speed and acceleration may be.
pub fn across_lanes_of(rollout: &Rollout, map: &RoadMap, agent: TrackIndex) -> Option<AcrossLanes> {
    let angle_at = |row: &Vec<Option<AgentState>>| {
        let s = row.get(agent.0)?.as_ref()?;
        map.angle_across_lanes_at(&s.position, s.heading_rad, s.speed_mps())
    };
    let (first, found) = longest_stretch(rollout.states.iter().map(angle_at))?;
    Some(AcrossLanes {
        start_s: first as f64 * rollout.dt_s,
        duration_s: found.len() as f64 * rollout.dt_s,
        max_angle_rad: found.iter().copied().fold(0.0, f64::max),
    })
}

/// The lane whose traffic a road user in `s` drives against (the
/// module's rule, [`RoadMap::oncoming_lane_at`]), or `None` when it drives
/// with the traffic, stands, or is where no lane tells the way.
pub fn against_traffic(map: &RoadMap, s: &AgentState) -> Option<MapElementId> {
    map.oncoming_lane_at(&s.position, s.heading_rad, s.speed_mps())
}

/// The longest run of consecutive `Some` in `steps`: its first step and
/// its values, in order; ties go to the earliest. `None` when every step
/// is `None`.
fn longest_stretch<T>(steps: impl Iterator<Item = Option<T>>) -> Option<(usize, Vec<T>)> {
    let mut best: Option<(usize, Vec<T>)> = None;
    let mut current: Option<(usize, Vec<T>)> = None;
    let keep_longer = |run: Option<(usize, Vec<T>)>, best: &mut Option<(usize, Vec<T>)>| {
        if let Some(run) = run
            && best.as_ref().is_none_or(|b| run.1.len() > b.1.len())
        {
            *best = Some(run);
        }
    };
    for (k, step) in steps.enumerate() {
        match (step, current.as_mut()) {
            (Some(v), Some(run)) => run.1.push(v),
            (Some(v), None) => current = Some((k, vec![v])),
            (None, _) => keep_longer(current.take(), &mut best),
        }
    }
    keep_longer(current, &mut best);
    best
}

/// How far above a lane's limit the ego may drive: 10 %, about what
/// enforcement tolerates.
pub const SPEEDING_TOLERANCE: f64 = 0.10;

/// How long the ego must be over the tolerance to be speeding, s.
pub const SPEEDING_MIN_S: f64 = 1.0;

/// The ego's longest stretch above a lane's limit.
#[derive(Debug, Clone, PartialEq)]
pub struct Speeding {
    /// When it began, s after the rollout's start.
    pub start_s: f64,
    /// How long it lasted, s.
    pub duration_s: f64,
    /// The highest speed in it, m/s.
    pub max_speed_mps: f64,
    /// The limit of the lane the ego was in when it began, m/s.
    pub limit_mps: f64,
    /// That lane.
    pub lane: MapElementId,
}

/// Whether any lane of `map` has a speed limit (otherwise speeding cannot
/// be measured).
pub fn has_speed_limits(map: &RoadMap) -> bool {
    map.lanes.iter().any(|l| l.speed_limit_mps.is_some_and(|v| v.is_finite() && v > 0.0))
}

/// The ego's longest stretch of driving more than [`SPEEDING_TOLERANCE`]
/// above its lane's limit, when it lasted longer than [`SPEEDING_MIN_S`];
/// `None` otherwise. Steps off every lane, or in a lane without a limit,
/// end a stretch.
pub fn speeding(rollout: &Rollout, map: &RoadMap) -> Option<Speeding> {
    let ego = rollout.ego.0;
    let over_at = |row: &Vec<Option<crate::scenario::AgentState>>| -> Option<(MapElementId, f64, f64)> {
        let s = row.get(ego)?.as_ref()?;
        let m = map.nearest_lane(&s.position, Some(s.heading_rad), OWN_LANE_CLEARANCE_M)?;
        let lane = &map.lanes[m.lane_index];
        let heading = Vector2::new(s.heading_rad.cos(), s.heading_rad.sin());
        if m.projection.tangent.dot(&heading) < crate::map::ALIGNED_LANE_MAX_ANGLE_RAD.cos() {
            return None;
        }
        let limit = lane.speed_limit_mps.filter(|v| v.is_finite() && *v > 0.0)?;
        (s.speed_mps() > limit * (1.0 + SPEEDING_TOLERANCE)).then_some((lane.id, limit, s.speed_mps()))
    };
    let (first, over) = longest_stretch(rollout.states.iter().map(over_at))?;
    let duration_s = over.len() as f64 * rollout.dt_s;
    (duration_s > SPEEDING_MIN_S + 1e-9).then(|| Speeding {
        start_s: first as f64 * rollout.dt_s,
        duration_s,
        max_speed_mps: over.iter().map(|&(_, _, v)| v).fold(f64::NEG_INFINITY, f64::max),
        limit_mps: over[0].1,
        lane: over[0].0,
    })
}

/// The first time the ego's centre passed a stop point on red, if it did.
pub fn red_light_run(rollout: &Rollout, map: &RoadMap) -> Option<RedLightRun> {
    let ego = rollout.ego.0;
    for (k, pair) in rollout.states.windows(2).enumerate() {
        let (Some(Some(from)), Some(Some(to))) = (pair[0].get(ego), pair[1].get(ego)) else { continue };
        let step = rollout.start_step + k;
        // The lanes holding the centre before and after the step, looked
        // up once per step and only when a light there is red.
        let mut holding: Option<Vec<MapElementId>> = None;
        for signal in &map.traffic_signals {
            let Some(state) = signal.states.get(step).copied() else { continue };
            if !matches!(state, SignalState::Stop | SignalState::ArrowStop) {
                continue;
            }
            let (Some(stop), Some(lane)) = (signal.stop_point, map.lane(signal.lane)) else { continue };
            // In the controlled lane when it passes: its area holds the
            // centre before or after the step.
            let holding = holding.get_or_insert_with(|| {
                [from, to].iter().flat_map(|s| map.lanes_containing(&s.position, s.heading_rad)).collect()
            });
            if !holding.contains(&lane.id) {
                continue;
            }
            let (Some(a), Some(b), Some(line)) = (
                lane.centreline.project(&from.position),
                lane.centreline.project(&to.position),
                lane.centreline.project(&stop),
            ) else {
                continue;
            };
            if a.arc_length_m < line.arc_length_m && b.arc_length_m >= line.arc_length_m {
                return Some(RedLightRun { time_s: (k + 1) as f64 * rollout.dt_s, lane: lane.id, state });
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point2;
    use crate::map::templates::{Intersection, StraightRoad};
    use crate::scenario::{AgentBody, AgentId, AgentKind, AgentState, TrackIndex};
    use crate::sim::Termination;

    /// A one-car rollout through `states` (0.1 s apart), starting at step 0.
    fn rollout(states: Vec<AgentState>) -> Rollout {
        Rollout {
            scenario_id: "rules".into(),
            dt_s: 0.1,
            start_step: 0,
            ego: TrackIndex(0),
            cbv: None,
            agent_ids: vec![AgentId("ego".into())],
            bodies: vec![AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 1.9 }],
            states: states.into_iter().map(|s| vec![Some(s)]).collect(),
            collisions: Vec::new(),
            off_road: Vec::new(),
            min_distance_to_ego: None,
            termination: Termination::Completed,
            planner: "test".into(),
            planner_debug: Vec::new(),
        }
    }

    /// Driving along +x at `speed` from `x0` at height `y`, `steps` steps.
    fn drive(x0: f64, y: f64, heading_rad: f64, speed: f64, steps: usize) -> Vec<AgentState> {
        let v = Vector2::new(heading_rad.cos(), heading_rad.sin()) * speed;
        (0..steps)
            .map(|k| AgentState { position: Point2::new(x0, y) + v * (k as f64 * 0.1), heading_rad, velocity_mps: v })
            .collect()
    }

    fn two_way_road() -> RoadMap {
        StraightRoad { lanes: 1, oncoming_lanes: 1, lane_width_m: 3.5, length_m: 200.0, speed_limit_mps: None }.build()
    }

    /// A one-lane road along +x with a 20 m/s limit.
    fn limited_road() -> RoadMap {
        StraightRoad { lanes: 1, oncoming_lanes: 0, lane_width_m: 3.5, length_m: 400.0, speed_limit_mps: Some(20.0) }
            .build()
    }

    #[test]
    fn speeding_is_more_than_ten_percent_over_the_limit_for_more_than_a_second() {
        let map = limited_road();
        let y = lane_centre_y(&map, 0);
        assert!(has_speed_limits(&map) && !has_speed_limits(&two_way_road()));
        // At the tolerance, or over it for exactly 1 s: not speeding.
        assert_eq!(speeding(&rollout(drive(10.0, y, 0.0, 22.0, 60)), &map), None);
        let mut brief = drive(10.0, y, 0.0, 19.0, 30);
        brief.extend(drive(80.0, y, 0.0, 25.0, 10));
        brief.extend(drive(110.0, y, 0.0, 19.0, 20));
        assert_eq!(speeding(&rollout(brief), &map), None);
        // 39 m/s in a 20 m/s zone for 2 s.
        let mut fast = drive(10.0, y, 0.0, 19.0, 10);
        fast.extend(drive(30.0, y, 0.0, 39.0, 20));
        let v = speeding(&rollout(fast), &map).expect("speeding");
        assert_eq!((v.limit_mps, v.max_speed_mps, v.lane), (20.0, 39.0, MapElementId(0)));
        assert!((v.start_s - 1.0).abs() < 1e-9 && (v.duration_s - 2.0).abs() < 1e-9, "{v:?}");
        // Off every lane, or against the lane's direction, no limit applies.
        assert_eq!(speeding(&rollout(drive(10.0, y + 30.0, 0.0, 39.0, 40)), &map), None);
        assert_eq!(speeding(&rollout(drive(300.0, y, std::f64::consts::PI, 39.0, 40)), &map), None);
    }

    fn lane_centre_y(map: &RoadMap, id: i64) -> f64 {
        map.lane(MapElementId(id)).unwrap().centreline.points()[0].y
    }

    #[test]
    fn driving_in_the_oncoming_lane_is_wrong_way_for_as_long_as_it_lasts() {
        let map = two_way_road();
        let oncoming = lane_centre_y(&map, 100);
        // 25 steps (2.5 s) along +x in the lane whose traffic runs along −x.
        let w = wrong_way(&rollout(drive(20.0, oncoming, 0.0, 10.0, 25)), &map).expect("wrong way");
        assert_eq!((w.start_s, w.lane), (0.0, MapElementId(100)));
        assert!((w.duration_s - 2.5).abs() < 1e-9, "{w:?}");
        // The same drive in the ego's own lane, and standing in the oncoming one.
        let own = lane_centre_y(&map, 0);
        assert_eq!(wrong_way(&rollout(drive(20.0, own, 0.0, 10.0, 25)), &map), None);
        assert_eq!(wrong_way(&rollout(drive(20.0, oncoming, 0.0, 0.0, 25)), &map), None);
        // Crossing the oncoming lane at 60° is a turn, not wrong way.
        assert_eq!(wrong_way(&rollout(drive(20.0, own, 1.05, 5.0, 12)), &map), None);
    }

    #[test]
    fn the_longest_stretch_against_the_traffic_is_reported() {
        let map = two_way_road();
        let (own, oncoming) = (lane_centre_y(&map, 0), lane_centre_y(&map, 100));
        let mut states = drive(20.0, oncoming, 0.0, 10.0, 3);
        states.extend(drive(23.0, own, 0.0, 10.0, 5));
        states.extend(drive(28.0, oncoming, 0.0, 10.0, 7));
        let w = wrong_way(&rollout(states), &map).unwrap();
        assert!((w.start_s - 0.8).abs() < 1e-9 && (w.duration_s - 0.7).abs() < 1e-9, "{w:?}");
    }

    #[test]
    fn any_agent_of_the_rollout_is_judged_by_the_egos_rule() {
        let map = two_way_road();
        let (own, oncoming) = (lane_centre_y(&map, 0), lane_centre_y(&map, 100));
        // The ego keeps its lane; the second car (a CBV) turns into the
        // oncoming lane and drives along it against its traffic for 1.5 s.
        let ego = drive(20.0, own, 0.0, 10.0, 20);
        let mut cbv = drive(60.0, own, 0.0, 0.0, 5);
        cbv.extend(drive(60.0, oncoming, 0.0, 8.0, 15));
        let mut r = rollout(ego);
        r.agent_ids.push(AgentId("cbv".into()));
        r.bodies.push(r.bodies[0]);
        for (row, c) in r.states.iter_mut().zip(cbv) {
            row.push(Some(c));
        }
        assert_eq!(wrong_way(&r, &map), None, "the ego kept its lane");
        let w = wrong_way_of(&r, &map, TrackIndex(1)).expect("the CBV drove against the traffic");
        assert_eq!((w.start_s, w.lane), (0.5, MapElementId(100)));
        assert!((w.duration_s - 1.5).abs() < 1e-9, "{w:?}");
        // Standing in its own lane it broke no rule (the first 0.5 s alone).
        let still = drive(60.0, own, 0.0, 0.0, 5);
        assert!(still.iter().all(|s| against_traffic(&map, s).is_none()));
    }

    #[test]
    fn cutting_across_the_lanes_at_forty_degrees_counts_and_a_lane_change_or_a_turn_at_a_junction_does_not() {
        let map =
            StraightRoad { lanes: 3, oncoming_lanes: 0, lane_width_m: 3.5, length_m: 200.0, speed_limit_mps: None }
                .build();
        let (right, left) = (lane_centre_y(&map, 0), lane_centre_y(&map, 2));
        let towards_left = (left - right).signum();
        // 8 m/s at 40° from the right lane towards the left one: about 2 s
        // inside the three lanes, then off the road (no lane: not judged).
        let across = drive(20.0, right, towards_left * 40f64.to_radians(), 8.0, 40);
        let a = across_lanes_of(&rollout(across), &map, TrackIndex(0)).expect("it cut across the lanes");
        assert_eq!(a.start_s, 0.0);
        assert!(a.duration_s >= 1.5 && a.duration_s <= 2.5, "{a:?}");
        assert!((a.max_angle_rad - 40f64.to_radians()).abs() < 1e-6, "{a:?}");
        // A brisk lane change (8°) at 20 m/s, and the same 40° at walking pace.
        let lane_change = drive(20.0, right, towards_left * 8f64.to_radians(), 20.0, 40);
        assert_eq!(across_lanes_of(&rollout(lane_change), &map, TrackIndex(0)), None);
        let slow = drive(20.0, right, towards_left * 40f64.to_radians(), 2.0, 40);
        assert_eq!(across_lanes_of(&rollout(slow), &map, TrackIndex(0)), None);
        // Against the traffic is wrong way, not across the lanes.
        let against = drive(150.0, right, std::f64::consts::PI, 10.0, 40);
        assert_eq!(across_lanes_of(&rollout(against), &map, TrackIndex(0)), None);
        assert!(wrong_way(&rollout(drive(150.0, right, std::f64::consts::PI, 10.0, 40)), &map).is_some());
        // In a junction's box, where lanes cross at every angle: 45° off a
        // lane through it is not judged.
        let junction = crossing();
        let through = junction.lanes.iter().find(|l| l.in_intersection).expect("a junction lane");
        let (p, t) = through.centreline.sample(0.5 * through.centreline.length_m()).unwrap();
        let heading = t.y.atan2(t.x) + std::f64::consts::FRAC_PI_4;
        assert!(junction.lanes_containing(&p, t.y.atan2(t.x)).contains(&through.id));
        assert_eq!(junction.angle_across_lanes_at(&p, heading, 8.0), None);
    }

    /// The template crossing: east–west green for the first 12 s, so the
    /// northern approach (arm 1, lane 10, driving south) is red.
    fn crossing() -> RoadMap {
        Intersection {
            missing_arm: None,
            right_turn_lanes: false,
            lanes_per_direction: 1,
            lane_width_m: 3.5,
            arm_length_m: 60.0,
            green_s: Some(12.0),
            speed_limit_mps: None,
        }
        .build_with_signals(200, 0.1)
    }

    /// An ego on `lane` from `s_m` along it, driving its way at `speed`.
    fn along(map: &RoadMap, lane: i64, s_m: f64, speed: f64, steps: usize) -> Vec<AgentState> {
        let line = &map.lane(MapElementId(lane)).unwrap().centreline;
        let (p, t) = line.sample(s_m).unwrap();
        let heading = t.y.atan2(t.x);
        drive(p.x, p.y, heading, speed, steps)
    }

    #[test]
    fn passing_the_stop_line_on_red_is_running_it_and_stopping_before_it_is_not() {
        let map = crossing();
        let red_lane = map.lane(MapElementId(10)).unwrap();
        assert!(map.signal_state(MapElementId(10), 0).is_some_and(SignalState::requires_stop));
        let length = red_lane.centreline.length_m();
        // 10 m before the line at 10 m/s: past it at t = 1.0 s.
        let run = red_light_run(&rollout(along(&map, 10, length - 10.0, 10.0, 20)), &map).expect("ran the red");
        assert_eq!((run.lane, run.state), (MapElementId(10), SignalState::Stop));
        assert!((run.time_s - 1.0).abs() < 0.1 + 1e-9, "{run:?}");
        // Standing 10 m short of it.
        assert_eq!(red_light_run(&rollout(along(&map, 10, length - 10.0, 0.0, 20)), &map), None);
        // The east approach is green: passing its line is allowed.
        let east = map.lane(MapElementId(0)).unwrap().centreline.length_m();
        assert_eq!(red_light_run(&rollout(along(&map, 0, east - 10.0, 10.0, 20)), &map), None);
    }
}
