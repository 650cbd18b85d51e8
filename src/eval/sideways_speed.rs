//! How briskly a road user moves sideways across the lanes it drives
//! along: the realism measure a lane change's pace needs. VJ, AJ and YJ
//! judge speed, acceleration and yaw rate along the path, and the
//! across-lanes measure ([`across_lanes_of`](super::traffic_rules::across_lanes_of))
//! catches only angles of 30° or more; neither sees a CBV that changes
//! lanes at 20° and 8 m/s, 2.7 m/s sideways, where recorded drivers on a
//! freeway seldom pass 1.5 m/s.
//!
//! The sideways speed at a step ([`sideways_speed_mps`]) is the road
//! user's speed times the sine of the smallest angle between its heading
//! and a lane of its way that holds its centre, outside intersections
//! (where lanes cross at every angle), while it moves at
//! [`ACROSS_LANES_MIN_SPEED_MPS`](crate::map::ACROSS_LANES_MIN_SPEED_MPS) or more (a slow turn out of a parking
//! spot is not a lane change). A road user's figure
//! ([`held_sideways_speed_mps`]) is the largest sideways speed it holds
//! for [`SIDEWAYS_HELD_S`] (at every step of the window, in lanes as
//! above): a single step's heading noise in a recording does not count.
//!
//! Most recorded road users keep their lane, so a figure over all of them
//! says little of how briskly they change it. [`changed_lanes`] picks the
//! lane changes out, and [`recorded_lane_changes_mps`] gives the recorded
//! vehicles' that did: the reference for a CBV's own.

use std::ops::RangeInclusive;

use super::spread::Spread;

use crate::map::{MapElementId, RoadMap};
use crate::scenario::{AgentKind, AgentState, Scenario};

/// How long a sideways speed must be held to count, s: a lane change
/// lasts 3–6 s, a recorded heading's noise a step or two.
pub const SIDEWAYS_HELD_S: f64 = 0.5;

/// The sideways speed of a road user in state `s` across the lanes of
/// its way that hold its centre, m/s
/// ([`RoadMap::sideways_speed_at`]).
pub fn sideways_speed_mps(map: &RoadMap, s: &AgentState) -> Option<f64> {
    map.sideways_speed_at(&s.position, s.heading_rad, s.speed_mps())
}

/// The largest sideways speed ([`sideways_speed_mps`]) a road user holds
/// for [`SIDEWAYS_HELD_S`] over `states` (one per step of `dt_s`, `None`
/// where absent), m/s: the largest, over every run of that many
/// consecutive measured steps, of the run's least. `None` when it is never
/// measured for that long.
pub fn held_sideways_speed_mps<'a>(
    map: &RoadMap,
    states: impl IntoIterator<Item = Option<&'a AgentState>>,
    dt_s: f64,
) -> Option<f64> {
    let window = ((SIDEWAYS_HELD_S / dt_s).round() as usize).max(1);
    let mut run: std::collections::VecDeque<f64> = std::collections::VecDeque::with_capacity(window);
    let mut largest: Option<f64> = None;
    for speed in states.into_iter().map(|s| s.and_then(|s| sideways_speed_mps(map, s))) {
        let Some(speed) = speed else {
            run.clear();
            continue;
        };
        if run.len() == window {
            run.pop_front();
        }
        run.push_back(speed);
        if run.len() == window {
            let held = run.iter().copied().fold(f64::INFINITY, f64::min);
            largest = Some(largest.map_or(held, |l| l.max(held)));
        }
    }
    largest
}

/// How long a road user must have been out of the lane it enters, and
/// stay out of the lane it leaves, for a lane change to count, s: one that
/// rides the line between two lanes, or swerves over it and back, has not
/// changed lanes.
pub const LANE_CHANGE_HELD_S: f64 = 1.0;

/// How far apart two lanes' centrelines must be, where a road user
/// crosses from one to the other, for the move to be a lane change, m:
/// lanes that overlap (a fork, a turn pocket's taper, a junction's
/// connectors) are nearer than that, neighbours about a lane's width
/// (3–3.7 m) apart.
pub const LANE_CHANGE_MIN_SEPARATION_M: f64 = 2.5;

/// Whether a road user changed lanes over `states` (one per step of
/// `dt_s`, `None` where absent). Its lane at a step is the lane of its way
/// that holds its centre with the centreline nearest to it. It changed
/// lanes where, from one step to the next, that lane became another,
/// with its centre between the two lanes' centrelines and these at least
/// [`LANE_CHANGE_MIN_SEPARATION_M`] apart, the lane it left still running
/// beside it ([`RoadMap::lane_runs_beside`]), and where it was out of the
/// new lane for [`LANE_CHANGE_HELD_S`] before and stayed out of the old
/// one for as long after. It reads the lanes' geometry alone, so it holds
/// on maps that record no lane's neighbours (WOMD JSON) as on those that
/// do. Lanes inside intersections take no part.
pub fn changed_lanes(map: &RoadMap, states: &[Option<AgentState>], dt_s: f64) -> bool {
    let held = ((LANE_CHANGE_HELD_S / dt_s).round() as usize).max(1);
    let lanes: Vec<Option<MapElementId>> = states.iter().map(|s| s.as_ref().and_then(|s| lane_of(map, s))).collect();
    let out_of =
        |steps: &[Option<MapElementId>], lane: MapElementId| steps.iter().all(|l| l.is_some_and(|l| l != lane));
    (held.saturating_sub(1)..states.len().saturating_sub(held)).any(|k| {
        let (Some(from), Some(to), Some(at)) = (lanes[k], lanes[k + 1], &states[k + 1]) else {
            return false;
        };
        from != to
            && crossed_between(map, (from, to), &at.position)
            && out_of(&lanes[k + 1 - held..=k], to)
            && out_of(&lanes[k + 1..=k + held], from)
    })
}

/// The lane of its way that holds `s`'s centre with the centreline
/// nearest to it.
fn lane_of(map: &RoadMap, s: &AgentState) -> Option<MapElementId> {
    let distance_m = |id: MapElementId| {
        map.lane(id).and_then(|l| l.centreline.project(&s.position)).map_or(f64::INFINITY, |p| p.distance_m)
    };
    map.lanes_containing(&s.position, s.heading_rad)
        .into_iter()
        .min_by(|&a, &b| distance_m(a).total_cmp(&distance_m(b)))
}

/// Whether `p` lies between the centrelines of lanes `from` and `to`, these
/// at least [`LANE_CHANGE_MIN_SEPARATION_M`] apart there, with `from`
/// running beside `p`, and neither inside an intersection (whose
/// connectors part as they turn off: a car that keeps to one is not
/// changing lanes).
fn crossed_between(map: &RoadMap, (from, to): (MapElementId, MapElementId), p: &crate::geometry::Point2) -> bool {
    let signed_m = |id: MapElementId| {
        let lane = map.lane(id).filter(|l| !l.in_junction())?;
        lane.centreline.project(p).map(|proj| proj.signed_distance_m)
    };
    let (Some(a), Some(b)) = (signed_m(from), signed_m(to)) else {
        return false;
    };
    a * b <= 0.0 && a.abs() + b.abs() >= LANE_CHANGE_MIN_SEPARATION_M && map.lane_runs_beside(from, p)
}

/// The held sideways speed ([`held_sideways_speed_mps`]) of every recorded
/// vehicle of `scenario` that changed lanes ([`changed_lanes`]) over
/// `steps`, where it was measured, in track order, m/s.
pub fn recorded_lane_changes_mps(scenario: &Scenario, steps: RangeInclusive<usize>) -> Vec<f64> {
    let map = &scenario.map;
    scenario
        .tracks
        .iter()
        .filter(|t| t.kind == AgentKind::Vehicle)
        .filter_map(|track| {
            let states: Vec<Option<AgentState>> = steps.clone().map(|k| track.state(k).copied()).collect();
            changed_lanes(map, &states, scenario.dt_s)
                .then(|| held_sideways_speed_mps(map, states.iter().map(Option::as_ref), scenario.dt_s))
                .flatten()
        })
        .collect()
}

/// How a set of road users' held sideways speeds spread, m/s.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SidewaysSpread {
    /// Road users measured (the others never held a measured speed).
    pub measured: usize,
    /// The median.
    pub p50_mps: f64,
    /// The 90th percentile (nearest rank).
    pub p90_mps: f64,
    /// The largest.
    pub max_mps: f64,
}

impl SidewaysSpread {
    /// The spread of `speeds` (NaN left out); `None` for none.
    pub fn of(speeds: impl IntoIterator<Item = f64>) -> Option<Self> {
        Spread::of(speeds).map(|s| Self { measured: s.measured, p50_mps: s.p50, p90_mps: s.p90, max_mps: s.max })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::map::templates::StraightRoad;

    fn road() -> RoadMap {
        StraightRoad { lanes: 3, oncoming_lanes: 0, lane_width_m: 3.5, length_m: 300.0, speed_limit_mps: None }.build()
    }

    fn car(x: f64, y: f64, heading_deg: f64, speed: f64) -> AgentState {
        let h = heading_deg.to_radians();
        AgentState { position: Point2::new(x, y), heading_rad: h, velocity_mps: Vector2::new(h.cos(), h.sin()) * speed }
    }

    fn middle_lane_y(map: &RoadMap) -> f64 {
        map.lane(crate::map::MapElementId(1)).unwrap().centreline.points()[0].y
    }

    #[test]
    fn the_sideways_speed_is_the_speed_times_the_sine_of_the_angle_to_the_lane() {
        let map = road();
        let y = middle_lane_y(&map);
        let along = sideways_speed_mps(&map, &car(100.0, y, 0.0, 20.0)).unwrap();
        assert!(along.abs() < 1e-9, "{along}");
        let changing = sideways_speed_mps(&map, &car(100.0, y, 10.0, 20.0)).unwrap();
        assert!((changing - 20.0 * 10f64.to_radians().sin()).abs() < 1e-9, "{changing}");
        // Too slow to be a lane change, and off the lanes: not measured.
        assert_eq!(sideways_speed_mps(&map, &car(100.0, y, 10.0, 2.0)), None);
        assert_eq!(sideways_speed_mps(&map, &car(100.0, y + 50.0, 10.0, 20.0)), None);
    }

    #[test]
    fn a_sideways_speed_counts_only_when_held_for_half_a_second() {
        let map = road();
        let y = middle_lane_y(&map);
        // 0.1 s steps: one step of a 30° heading (noise) amid driving along
        // the lane, then five steps at 10°.
        let mut states: Vec<AgentState> = (0..10).map(|k| car(10.0 + 2.0 * k as f64, y, 0.0, 20.0)).collect();
        states[3] = car(16.0, y, 30.0, 20.0);
        states.extend((0..5).map(|k| car(40.0 + 2.0 * k as f64, y, 10.0, 20.0)));
        let held = held_sideways_speed_mps(&map, states.iter().map(Some), 0.1).unwrap();
        assert!((held - 20.0 * 10f64.to_radians().sin()).abs() < 1e-9, "{held}");
        // A gap (absent, or out of the lanes) breaks the run.
        let mut gapped: Vec<Option<&AgentState>> = states.iter().map(Some).collect();
        gapped[12] = None;
        let held = held_sideways_speed_mps(&map, gapped, 0.1).unwrap();
        assert!(held < 1e-9, "{held}");
        assert_eq!(held_sideways_speed_mps(&map, states[..4].iter().map(Some), 0.1), None);
    }

    /// `map` with `change` made to each of its lanes.
    fn with_each_lane(map: &RoadMap, change: impl Fn(&mut crate::map::Lane)) -> RoadMap {
        RoadMap::from_lanes(
            map.lanes
                .iter()
                .cloned()
                .map(|mut l| {
                    change(&mut l);
                    l
                })
                .collect(),
        )
    }

    /// A car at 20 m/s along the lane at `y0` that moves over to `y1` at
    /// `sideways_mps` from 2 s on, over 8 s at 0.1 s steps.
    fn changing_over(y0: f64, y1: f64, sideways_mps: f64) -> Vec<Option<AgentState>> {
        let (mut y, mut states) = (y0, Vec::new());
        for k in 0..80 {
            let v_side = if k >= 20 && (y1 - y).abs() > 1e-9 { sideways_mps.min((y1 - y).abs() / 0.1) } else { 0.0 };
            let v_side = v_side * (y1 - y0).signum();
            let velocity = Vector2::new((400.0 - v_side * v_side).sqrt(), v_side);
            let h = velocity.y.atan2(velocity.x);
            states.push(Some(AgentState {
                position: Point2::new(10.0 + 2.0 * k as f64, y),
                heading_rad: h,
                velocity_mps: velocity,
            }));
            y += v_side * 0.1;
        }
        states
    }

    #[test]
    fn a_move_to_the_next_lane_is_a_lane_change_and_its_pace_is_what_the_recording_gives() {
        use crate::scenario::{AgentId, ScenarioSource, Track};
        let map = road();
        let y = middle_lane_y(&map);
        let change = changing_over(y, y + 3.5, 1.0);
        let keep = changing_over(y, y, 1.0);
        // A swerve of a metre that stays in the lane is no lane change.
        let swerve = changing_over(y, y + 1.0, 1.0);
        assert!(changed_lanes(&map, &change, 0.1));
        assert!(!changed_lanes(&map, &keep, 0.1));
        assert!(!changed_lanes(&map, &swerve, 0.1));
        // Over the line into the next lane (at step 38), but not yet held
        // there for a second.
        assert!(!changed_lanes(&map, &change[..45], 0.1));
        assert!(changed_lanes(&map, &change[..50], 0.1));
        // Over the line and back within the second: no lane change.
        let mut back = change[..40].to_vec();
        back.extend(
            changing_over(y + 2.0, y, 1.0)[20..60]
                .iter()
                .map(|s| s.map(|s| AgentState { position: Point2::new(s.position.x + 40.0, s.position.y), ..s })),
        );
        assert!(!changed_lanes(&map, &back, 0.1));
        // A map that records no lane's neighbours (WOMD JSON) tells the same.
        let bare = with_each_lane(&map, |l| {
            l.left_neighbours.clear();
            l.right_neighbours.clear();
        });
        assert!(changed_lanes(&bare, &change, 0.1));
        assert!(!changed_lanes(&bare, &swerve, 0.1));
        // Inside an intersection lanes part as they turn off: no lane change.
        let junction = with_each_lane(&map, |l| l.in_intersection = true);
        assert!(!changed_lanes(&junction, &change, 0.1));
        // Lanes that overlap (centrelines 1.2 m apart, each wider than
        // that): a move from one centreline to the next is no lane change.
        let overlapping =
            StraightRoad { lanes: 3, oncoming_lanes: 0, lane_width_m: 1.2, length_m: 300.0, speed_limit_mps: None }
                .build();
        let y = middle_lane_y(&overlapping);
        assert!(!changed_lanes(&overlapping, &changing_over(y, y + 1.2, 1.0), 0.1));

        let track = |i: usize, kind: AgentKind, states: &[Option<AgentState>]| Track {
            id: AgentId(format!("agent-{i}")),
            kind,
            length_m: 4.5,
            width_m: 2.0,
            states: states.to_vec(),
        };
        let tracks = vec![
            track(0, AgentKind::Vehicle, &keep),
            track(1, AgentKind::Vehicle, &change),
            track(2, AgentKind::Cyclist, &change),
            track(3, AgentKind::Vehicle, &swerve),
        ];
        let scenario = Scenario::new("lane-change", ScenarioSource::authored("test"), 0.1, map, tracks);
        let speeds = recorded_lane_changes_mps(&scenario, 0..=79);
        assert_eq!(speeds.len(), 1, "only the vehicle that changed lanes: {speeds:?}");
        assert!((speeds[0] - 1.0).abs() < 1e-6, "{speeds:?}");
        // Over steps that end before the change begins, nobody changed lanes.
        assert_eq!(recorded_lane_changes_mps(&scenario, 0..=30), Vec::<f64>::new());
    }

    #[test]
    fn the_spread_takes_nearest_ranks() {
        let spread = SidewaysSpread::of((1..=10).map(f64::from)).unwrap();
        assert_eq!((spread.measured, spread.p50_mps, spread.p90_mps, spread.max_mps), (10, 5.0, 9.0, 10.0));
        assert_eq!(SidewaysSpread::of([f64::NAN]), None);
    }
}
