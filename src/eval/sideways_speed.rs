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

use crate::map::RoadMap;
use crate::scenario::AgentState;

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
        let mut sorted: Vec<f64> = speeds.into_iter().filter(|v| !v.is_nan()).collect();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let nearest_rank = |p: f64| sorted[((p * n as f64).ceil() as usize).clamp(1, n) - 1];
        (n > 0).then(|| Self {
            measured: n,
            p50_mps: nearest_rank(0.5),
            p90_mps: nearest_rank(0.9),
            max_mps: sorted[n - 1],
        })
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

    #[test]
    fn the_spread_takes_nearest_ranks() {
        let spread = SidewaysSpread::of((1..=10).map(f64::from)).unwrap();
        assert_eq!((spread.measured, spread.p50_mps, spread.p90_mps, spread.max_mps), (10, 5.0, 9.0, 10.0));
        assert_eq!(SidewaysSpread::of([f64::NAN]), None);
    }
}
