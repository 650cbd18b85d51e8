//! Procedural road maps: a straight multi-lane road, an on-ramp merge and a
//! signalised 4-way intersection. Authored scenarios place agents on them,
//! and synthetic traffic for training is generated on them.
//!
//! Conventions: metres, lanes numbered from the right (0 = rightmost) in the
//! direction of travel, lane ids stable and documented per template so specs
//! can name them, road edges oriented with the road on their port side, and
//! every lane also a drivable-area polygon (which decides on-/off-road).

use std::f64::consts::FRAC_PI_2;

use crate::geometry::{Point2, Polygon, Polyline, Pose2, Vector2};

use super::{
    AreaKind, Lane, LaneKind, MapArea, MapElementId, RoadEdge, RoadEdgeKind, RoadLine, RoadLineKind, RoadMap,
    SignalState, TrafficSignal,
};

/// Which template, with its parameters.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum MapTemplate {
    /// A straight road along +x from x = 0.
    Straight(StraightRoad),
    /// A straight road with an on-ramp joining the rightmost lane.
    Merge(Merge),
    /// Two straight roads crossing at the origin, with signals.
    Intersection(Intersection),
}

/// Bounds on template parameters: generous for any real road, and small
/// enough that a typo (`lanes: 3000000`) cannot exhaust memory.
pub mod limits {
    /// Lanes per direction.
    pub const LANES: std::ops::RangeInclusive<usize> = 1..=8;
    /// Lane width, m.
    pub const LANE_WIDTH_M: std::ops::RangeInclusive<f64> = 2.0..=6.0;
    /// Road length, m.
    pub const LENGTH_M: std::ops::RangeInclusive<f64> = 30.0..=5000.0;
    /// Intersection arm length, m.
    pub const ARM_LENGTH_M: std::ops::RangeInclusive<f64> = 20.0..=1000.0;
    /// Green time per phase, s.
    pub const GREEN_S: std::ops::RangeInclusive<f64> = 1.0..=300.0;
    /// Speed limit, m/s.
    pub const SPEED_LIMIT_MPS: std::ops::RangeInclusive<f64> = 1.0..=60.0;
}

/// A template parameter outside its range: which one, and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{parameter} must be in {range}, got {got}")]
pub struct InvalidParameter {
    /// The parameter as written in a spec (`length_m`).
    pub parameter: &'static str,
    /// The accepted range (`30..=5000`).
    pub range: String,
    /// The value given.
    pub got: String,
}

fn check_range<T: PartialOrd + std::fmt::Display>(
    parameter: &'static str,
    v: T,
    r: &std::ops::RangeInclusive<T>,
) -> Result<(), InvalidParameter> {
    if r.contains(&v) {
        Ok(())
    } else {
        Err(InvalidParameter { parameter, range: format!("{}..={}", r.start(), r.end()), got: v.to_string() })
    }
}

impl MapTemplate {
    /// The template's key in a spec (`straight`, `merge`, `intersection`).
    pub fn key(&self) -> &'static str {
        match self {
            Self::Straight(_) => "straight",
            Self::Merge(_) => "merge",
            Self::Intersection(_) => "intersection",
        }
    }

    /// Checks the parameters against [`limits`] and each other (NaN is
    /// outside every range); `build` assumes they passed.
    pub fn validate(&self) -> Result<(), InvalidParameter> {
        let limit = |v: Option<f64>| v.map_or(Ok(()), |v| check_range("speed_limit_mps", v, &limits::SPEED_LIMIT_MPS));
        match self {
            Self::Straight(p) => {
                check_range("lanes", p.lanes, &limits::LANES)?;
                check_range("oncoming_lanes", p.oncoming_lanes, &(0..=*limits::LANES.end()))?;
                check_range("lane_width_m", p.lane_width_m, &limits::LANE_WIDTH_M)?;
                check_range("length_m", p.length_m, &limits::LENGTH_M)?;
                limit(p.speed_limit_mps)
            }
            Self::Merge(p) => {
                check_range("lanes", p.lanes, &limits::LANES)?;
                check_range("lane_width_m", p.lane_width_m, &limits::LANE_WIDTH_M)?;
                check_range("length_m", p.length_m, &limits::LENGTH_M)?;
                check_range("merge_end_m", p.merge_end_m, &(20.0..=p.length_m - 10.0))?;
                check_range("acceleration_lane_m", p.acceleration_lane_m, &(0.0..=p.merge_end_m))?;
                limit(p.speed_limit_mps)
            }
            Self::Intersection(p) => {
                check_range("lanes_per_direction", p.lanes_per_direction, &limits::LANES)?;
                check_range("lane_width_m", p.lane_width_m, &limits::LANE_WIDTH_M)?;
                check_range("arm_length_m", p.arm_length_m, &limits::ARM_LENGTH_M)?;
                p.green_s.map_or(Ok(()), |g| check_range("green_s", g, &limits::GREEN_S))?;
                p.missing_arm.map_or(Ok(()), |a| check_range("missing_arm", a, &(0..=3)))?;
                if p.right_turn_lanes && p.lanes_per_direction < 2 {
                    return Err(InvalidParameter {
                        parameter: "lanes_per_direction",
                        range: format!("2..={} with right_turn_lanes", limits::LANES.end()),
                        got: p.lanes_per_direction.to_string(),
                    });
                }
                limit(p.speed_limit_mps)
            }
        }
    }

    /// Builds the map.
    pub fn build(&self) -> RoadMap {
        match self {
            Self::Straight(p) => p.build(),
            Self::Merge(p) => p.build(),
            Self::Intersection(p) => p.build(),
        }
    }
}

fn default_lane_width() -> f64 {
    3.5
}
fn default_lanes() -> usize {
    2
}

/// A straight road. Lane `i` (from the right) has id `i`; oncoming lanes,
/// if any, have ids `100 + i`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StraightRoad {
    /// Lanes in the direction of travel.
    #[serde(default = "default_lanes")]
    pub lanes: usize,
    /// Lanes in the opposite direction (left of a double yellow line).
    #[serde(default)]
    pub oncoming_lanes: usize,
    /// Lane width, m.
    #[serde(default = "default_lane_width")]
    pub lane_width_m: f64,
    /// Length, m.
    pub length_m: f64,
    /// Speed limit, m/s.
    #[serde(default)]
    pub speed_limit_mps: Option<f64>,
}

fn line(points: &[(f64, f64)]) -> Polyline {
    Polyline::new(points.iter().map(|&(x, y)| Point2::new(x, y)).collect())
}

fn lane(id: i64, centreline: Polyline, half_width: f64, speed_limit_mps: Option<f64>) -> Lane {
    let (left, right) = offset_bounds(&centreline, half_width);
    Lane {
        kind: LaneKind::SurfaceStreet,
        speed_limit_mps,
        left_boundary: Some(left),
        right_boundary: Some(right),
        ..Lane::new(MapElementId(id), centreline)
    }
}

/// Left and right bounds at `half_width` from a centreline (per-vertex normals).
fn offset_bounds(centreline: &Polyline, half_width: f64) -> (Polyline, Polyline) {
    let pts = centreline.points();
    let n = pts.len();
    let normal = |i: usize| {
        let (a, b) = if i + 1 < n { (pts[i], pts[i + 1]) } else { (pts[i - 1], pts[i]) };
        let d = (b - a).normalize();
        Vector2::new(-d.y, d.x)
    };
    let left = (0..n).map(|i| pts[i] + normal(i) * half_width).collect();
    let right = (0..n).map(|i| pts[i] - normal(i) * half_width).collect();
    (Polyline::new(left), Polyline::new(right))
}

fn lane_polygon(l: &Lane) -> Polygon {
    let (left, right) =
        (l.left_boundary.as_ref().expect("template lanes have bounds"), l.right_boundary.as_ref().expect("bounds"));
    let mut v: Vec<Point2> = right.points().to_vec();
    v.extend(left.points().iter().rev());
    Polygon::new(v)
}

fn edge(id: i64, polyline: Polyline) -> RoadEdge {
    RoadEdge { id: MapElementId(id), polyline, kind: RoadEdgeKind::Boundary }
}

impl StraightRoad {
    /// Builds the map.
    pub fn build(&self) -> RoadMap {
        let (w, len) = (self.lane_width_m, self.length_m);
        let mut lanes = Vec::new();
        for i in 0..self.lanes {
            let y = (i as f64 + 0.5) * w;
            let mut l = lane(i as i64, line(&[(0.0, y), (len, y)]), w / 2.0, self.speed_limit_mps);
            if i + 1 < self.lanes {
                l.left_neighbours.push(MapElementId(i as i64 + 1));
            }
            if i > 0 {
                l.right_neighbours.push(MapElementId(i as i64 - 1));
            }
            lanes.push(l);
        }
        let top = (self.lanes + self.oncoming_lanes) as f64 * w;
        for i in 0..self.oncoming_lanes {
            // Oncoming lane i counted from its own right (the top edge).
            let y = top - (i as f64 + 0.5) * w;
            let mut l = lane(100 + i as i64, line(&[(len, y), (0.0, y)]), w / 2.0, self.speed_limit_mps);
            if i + 1 < self.oncoming_lanes {
                l.left_neighbours.push(MapElementId(100 + i as i64 + 1));
            }
            if i > 0 {
                l.right_neighbours.push(MapElementId(100 + i as i64 - 1));
            }
            lanes.push(l);
        }
        let mut road_lines = Vec::new();
        for i in 1..self.lanes + self.oncoming_lanes {
            let y = i as f64 * w;
            let kind = if i == self.lanes { RoadLineKind::SolidDoubleYellow } else { RoadLineKind::BrokenSingleWhite };
            road_lines.push(RoadLine { id: MapElementId(200 + i as i64), polyline: line(&[(0.0, y), (len, y)]), kind });
        }
        let drivable = lanes.iter().map(lane_polygon).collect();
        let edges = vec![edge(300, line(&[(0.0, 0.0), (len, 0.0)])), edge(301, line(&[(len, top), (0.0, top)]))];
        RoadMap::new(lanes, edges, road_lines, vec![], drivable, vec![], vec![])
    }
}

/// A straight road (as [`StraightRoad`], lanes `0..lanes`) with an on-ramp
/// from the right: the ramp (id 50) curves in, runs beside lane 0 as an
/// acceleration lane, and ends where it merges; lane 0 is split there into
/// lane 0 (before) and lane 10 (after), so the ramp's successor is lane 10.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Merge {
    /// Main-road lanes.
    #[serde(default = "default_lanes")]
    pub lanes: usize,
    /// Lane width, m.
    #[serde(default = "default_lane_width")]
    pub lane_width_m: f64,
    /// Length of the main road, m.
    pub length_m: f64,
    /// Where the acceleration lane ends and the ramp has merged, m along x.
    pub merge_end_m: f64,
    /// Length of the acceleration lane beside lane 0, m.
    #[serde(default = "default_acceleration_lane")]
    pub acceleration_lane_m: f64,
    /// Speed limit, m/s.
    #[serde(default)]
    pub speed_limit_mps: Option<f64>,
}

fn default_acceleration_lane() -> f64 {
    60.0
}

impl Merge {
    /// Builds the map.
    pub fn build(&self) -> RoadMap {
        // `validate` keeps these in range; max/min (not clamp) so unvalidated input cannot panic.
        let (w, len) = (self.lane_width_m, self.length_m.max(30.0));
        let end = self.merge_end_m.max(20.0).min(len - 10.0);
        let acc_start = (end - self.acceleration_lane_m).max(10.0);
        let mut lanes = Vec::new();
        for i in 0..self.lanes {
            let y = (i as f64 + 0.5) * w;
            let mut l = if i == 0 {
                lane(0, line(&[(0.0, y), (end, y)]), w / 2.0, self.speed_limit_mps)
            } else {
                lane(i as i64, line(&[(0.0, y), (len, y)]), w / 2.0, self.speed_limit_mps)
            };
            if i + 1 < self.lanes {
                l.left_neighbours.push(MapElementId(i as i64 + 1));
            }
            if i > 0 {
                l.right_neighbours.push(MapElementId(if i == 1 { 0 } else { i as i64 - 1 }));
            }
            if i == 0 {
                l.successors.push(MapElementId(10));
            }
            lanes.push(l);
        }
        let mut after = lane(10, line(&[(end, 0.5 * w), (len, 0.5 * w)]), w / 2.0, self.speed_limit_mps);
        after.predecessors = vec![MapElementId(0), MapElementId(50)];
        if self.lanes > 1 {
            after.left_neighbours.push(MapElementId(1));
        }
        lanes.push(after);
        // Ramp: a quarter-sine approach from 4 lane widths below, then parallel at y = -w/2, then a taper into lane 10's line.
        let approach = 50.0_f64.min(acc_start);
        let mut ramp_pts = Vec::new();
        for k in 0..=10 {
            let t = k as f64 / 10.0;
            let x = acc_start - approach * (1.0 - t);
            let y = -0.5 * w - 3.5 * w * (1.0 - (t * FRAC_PI_2).sin());
            ramp_pts.push((x, y));
        }
        let taper = 25.0_f64.min(end - acc_start);
        ramp_pts.push((end - taper, -0.5 * w));
        for k in 1..=5 {
            let t = k as f64 / 5.0;
            ramp_pts.push((end - taper + taper * t, -0.5 * w + w * (1.0 - (t * std::f64::consts::PI).cos()) / 2.0));
        }
        let mut ramp = lane(50, line(&ramp_pts), w / 2.0, self.speed_limit_mps);
        ramp.successors.push(MapElementId(10));
        ramp.left_neighbours.push(MapElementId(0));
        lanes[0].right_neighbours.push(MapElementId(50));
        lanes.push(ramp);

        let top = self.lanes as f64 * w;
        let mut road_lines = Vec::new();
        for i in 1..self.lanes {
            let y = i as f64 * w;
            road_lines.push(RoadLine {
                id: MapElementId(200 + i as i64),
                polyline: line(&[(0.0, y), (len, y)]),
                kind: RoadLineKind::BrokenSingleWhite,
            });
        }
        road_lines.push(RoadLine {
            id: MapElementId(250),
            polyline: line(&[(acc_start, 0.0), (end - taper, 0.0)]),
            kind: RoadLineKind::BrokenSingleWhite,
        });
        let drivable = lanes.iter().map(lane_polygon).collect();
        let ramp_lane = lanes.last().expect("ramp pushed");
        let edges = vec![
            edge(300, line(&[(0.0, 0.0), (acc_start - approach, 0.0)])),
            edge(301, line(&[(len, top), (0.0, top)])),
            // The ramp's right bound continues into the main road's right edge after the merge.
            edge(302, {
                let mut pts: Vec<Point2> = ramp_lane.right_boundary.as_ref().expect("bounds").points().to_vec();
                pts.push(Point2::new(len, 0.0));
                Polyline::new(pts)
            }),
            // The gore between the ramp's approach and the main road, road on both sides.
            edge(
                303,
                Polyline::new(
                    ramp_lane.left_boundary.as_ref().expect("bounds").points().iter().take(6).rev().copied().collect(),
                ),
            ),
        ];
        RoadMap::new(lanes, edges, road_lines, vec![], drivable, vec![], vec![])
    }
}

/// Two two-way roads crossing at the origin: arms east, north, west, south
/// (arm index 0..4, counter-clockwise from +x), right-hand traffic. Per arm,
/// lanes in (towards the centre) have ids `arm·10 + i`, lanes out
/// `arm·10 + 5 + i`, with lane 0 next to the centre line here;
/// connectors through the box `1000 + from·100 + to·10 + i`. Signals
/// alternate east–west and north–south green with a fixed cycle. With
/// `missing_arm` it is a T-junction: that arm, its connectors and signals
/// are left out and a kerb closes the box on its side, so traffic
/// arriving opposite it must turn. With `right_turn_lanes` the kerb lane
/// of every arm turns right only, like a dedicated right-turn lane.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Intersection {
    /// Lanes per direction on each arm.
    #[serde(default = "one")]
    pub lanes_per_direction: usize,
    /// Lane width, m.
    #[serde(default = "default_lane_width")]
    pub lane_width_m: f64,
    /// Arm length from the box edge, m.
    #[serde(default = "default_arm")]
    pub arm_length_m: f64,
    /// Green time per phase, s (yellow is 3 s; `None`: no signals).
    #[serde(default)]
    pub green_s: Option<f64>,
    /// Speed limit, m/s.
    #[serde(default)]
    pub speed_limit_mps: Option<f64>,
    /// The arm left out (0 east, 1 north, 2 west, 3 south), making a
    /// T-junction; absent: all four.
    #[serde(default)]
    pub missing_arm: Option<usize>,
    /// The kerb lane of every arm has no way straight on, only the right
    /// turn (a dedicated right-turn lane); needs two or more lanes per
    /// direction, so that the lane beside it goes straight.
    #[serde(default)]
    pub right_turn_lanes: bool,
}

fn one() -> usize {
    1
}
fn default_arm() -> f64 {
    80.0
}

/// Yellow time between phases, s.
const YELLOW_S: f64 = 3.0;

impl Intersection {
    /// Half the width of the box, m.
    pub fn half_box_m(&self) -> f64 {
        self.lanes_per_direction as f64 * self.lane_width_m + 2.0
    }

    /// The state of the signal for traffic entering from `arm` at time `t_s`.
    pub fn signal_at(&self, arm: usize, t_s: f64) -> SignalState {
        let Some(green) = self.green_s else { return SignalState::Unknown };
        let cycle = 2.0 * (green + YELLOW_S);
        let t = t_s.rem_euclid(cycle);
        let east_west = arm.is_multiple_of(2);
        let in_first = t < green + YELLOW_S;
        let phase_t = if in_first { t } else { t - green - YELLOW_S };
        if east_west == in_first {
            if phase_t < green { SignalState::Go } else { SignalState::Caution }
        } else {
            SignalState::Stop
        }
    }

    /// Builds the map, with signal states for `steps` steps of `dt_s`.
    pub fn build_with_signals(&self, steps: usize, dt_s: f64) -> RoadMap {
        let (w, n, h, arm) = (self.lane_width_m, self.lanes_per_direction, self.half_box_m(), self.arm_length_m);
        let rot = |arm: usize, x: f64, y: f64| {
            let a = arm as f64 * FRAC_PI_2;
            let (s, c) = a.sin_cos();
            Point2::new(c * x - s * y, s * x + c * y)
        };
        let present = |a: usize| self.missing_arm != Some(a);
        let mut lanes = Vec::new();
        let mut signals = Vec::new();
        for a in (0..4).filter(|&a| present(a)) {
            // In the arm's frame the arm lies along +x; inbound lanes travel -x, so with
            // right-hand traffic they lie on the +y side and outbound lanes on the -y side.
            for i in 0..n {
                let y = (i as f64 + 0.5) * w;
                let inbound = Polyline::new(vec![rot(a, h + arm, y), rot(a, h, y)]);
                let outbound = Polyline::new(vec![rot(a, h, -y), rot(a, h + arm, -y)]);
                let mut lin = lane((a * 10 + i) as i64, inbound, w / 2.0, self.speed_limit_mps);
                let mut lout = lane((a * 10 + 5 + i) as i64, outbound, w / 2.0, self.speed_limit_mps);
                if i + 1 < n {
                    lin.right_neighbours.push(MapElementId((a * 10 + i + 1) as i64));
                    lout.left_neighbours.push(MapElementId((a * 10 + 5 + i + 1) as i64));
                }
                if i > 0 {
                    lin.left_neighbours.push(MapElementId((a * 10 + i - 1) as i64));
                    lout.right_neighbours.push(MapElementId((a * 10 + 5 + i - 1) as i64));
                }
                lanes.push(lin);
                lanes.push(lout);
                if self.green_s.is_some() {
                    signals.push(TrafficSignal {
                        lane: MapElementId((a * 10 + i) as i64),
                        stop_point: Some(rot(a, h, y)),
                        states: (0..steps).map(|k| self.signal_at(a, k as f64 * dt_s)).collect(),
                    });
                }
            }
        }
        // Connectors: from inbound lane i of arm a to outbound lane i of arm b.
        // Right-hand traffic: b = a+1 is a right turn, a+2 straight, a+3 left.
        for a in (0..4).filter(|&a| present(a)) {
            for turn in 1..4 {
                let b = (a + turn) % 4;
                if !present(b) {
                    continue;
                }
                for i in 0..n {
                    // Right turns only from the curb lane (i = n-1), left turns only from the lane by the centre line (i = 0).
                    if (turn == 1 && i + 1 != n) || (turn == 3 && i != 0) {
                        continue;
                    }
                    // A dedicated right-turn lane goes nowhere else.
                    if self.right_turn_lanes && i + 1 == n && turn != 1 {
                        continue;
                    }
                    let y = (i as f64 + 0.5) * w;
                    let start = rot(a, h, y);
                    let end = rot(b, h, -y);
                    let start_dir = rot(a, -1.0, 0.0) - Point2::origin();
                    let end_dir = rot(b, 1.0, 0.0) - Point2::origin();
                    let pts: Vec<Point2> = if turn == 2 {
                        vec![start, end]
                    } else {
                        // Quadratic Bézier through the intersection of the two lane lines.
                        let denom = start_dir.x * end_dir.y - start_dir.y * end_dir.x;
                        let t = ((end - start).x * end_dir.y - (end - start).y * end_dir.x) / denom;
                        let control = start + start_dir * t;
                        (0..=12)
                            .map(|k| {
                                let u = k as f64 / 12.0;
                                let p = start.coords * (1.0 - u).powi(2)
                                    + control.coords * (2.0 * u * (1.0 - u))
                                    + end.coords * u * u;
                                Point2::from(p)
                            })
                            .collect()
                    };
                    let id = (1000 + a * 100 + b * 10 + i) as i64;
                    let mut c = lane(id, Polyline::new(pts), w / 2.0, self.speed_limit_mps);
                    c.in_intersection = true;
                    c.predecessors.push(MapElementId((a * 10 + i) as i64));
                    c.successors.push(MapElementId((b * 10 + 5 + i) as i64));
                    lanes.push(c);
                }
            }
        }
        let connector_ids: Vec<(MapElementId, MapElementId, MapElementId)> =
            lanes.iter().filter(|l| l.in_intersection).map(|l| (l.id, l.predecessors[0], l.successors[0])).collect();
        for l in lanes.iter_mut() {
            for &(c, from, to) in &connector_ids {
                if l.id == from {
                    l.successors.push(c);
                }
                if l.id == to {
                    l.predecessors.push(c);
                }
            }
        }
        // Drivable: the arms' lanes and the box itself.
        let mut drivable: Vec<Polygon> = lanes.iter().filter(|l| !l.in_intersection).map(lane_polygon).collect();
        drivable.push(Polygon::new(vec![
            Point2::new(-h, -h),
            Point2::new(h, -h),
            Point2::new(h, h),
            Point2::new(-h, h),
        ]));
        // Curbs: per corner between arm a and arm a+1, an L from arm a's left side to arm a+1's right side.
        let half_road = n as f64 * w;
        let mut edges = Vec::new();
        for a in (0..4).filter(|&a| present(a)) {
            let next = (a + 1) % 4;
            // Beside a missing arm the kerb runs on along the box's side to
            // the arm after it.
            let pts = if present(next) {
                vec![
                    rot(next, h + arm, -half_road),
                    rot(next, h, -half_road),
                    rot(a, h, half_road),
                    rot(a, h + arm, half_road),
                ]
            } else {
                let after = (next + 1) % 4;
                vec![
                    rot(after, h + arm, -half_road),
                    rot(after, h, -half_road),
                    rot(next, h, h),
                    rot(next, h, -h),
                    rot(a, h, half_road),
                    rot(a, h + arm, half_road),
                ]
            };
            // Road on the port side: walking outward along arm a+1's right side, then in along arm a's left side
            // keeps the road on the left only if reversed; orient by testing the box centre.
            let pl = Polyline::new(pts);
            let pl = if pl.project(&Point2::origin()).is_some_and(|p| p.signed_distance_m < 0.0) {
                pl
            } else {
                pl.reversed()
            };
            edges.push(edge(300 + a as i64, pl));
        }
        let mut road_lines = Vec::new();
        let mut areas = Vec::new();
        for a in (0..4).filter(|&a| present(a)) {
            road_lines.push(RoadLine {
                id: MapElementId(400 + a as i64),
                polyline: Polyline::new(vec![rot(a, h, 0.0), rot(a, h + arm, 0.0)]),
                kind: RoadLineKind::SolidDoubleYellow,
            });
            let cw = 3.0;
            areas.push(MapArea {
                id: MapElementId(500 + a as i64),
                kind: AreaKind::Crosswalk,
                polygon: Polygon::new(vec![
                    rot(a, h, -half_road),
                    rot(a, h + cw, -half_road),
                    rot(a, h + cw, half_road),
                    rot(a, h, half_road),
                ]),
            });
        }
        RoadMap::new(lanes, edges, road_lines, areas, drivable, vec![], signals)
    }

    /// Builds the map with signal states for 20 s at 0.1 s.
    pub fn build(&self) -> RoadMap {
        self.build_with_signals(201, 0.1)
    }

    /// The pose at distance `s_m` before the stop line on inbound lane `lane` of `arm`.
    pub fn approach_pose(&self, arm: usize, lane: usize, s_m: f64) -> Pose2 {
        let y = (lane as f64 + 0.5) * self.lane_width_m;
        let x = self.half_box_m() + s_m;
        let a = arm as f64 * FRAC_PI_2;
        let (s, c) = a.sin_cos();
        Pose2::new(c * x - s * y, s * x + c * y, crate::geometry::wrap_angle(a + std::f64::consts::PI))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn on_road_share(map: &RoadMap) -> f64 {
        let mut total = 0;
        let mut on = 0;
        for l in &map.lanes {
            let len = l.centreline.length_m();
            let mut s = 0.5;
            while s < len - 0.5 {
                let (p, _) = l.centreline.sample(s).unwrap();
                total += 1;
                if !map.is_off_road(&p) {
                    on += 1;
                }
                s += 2.0;
            }
        }
        on as f64 / total as f64
    }

    #[test]
    fn out_of_range_parameters_are_refused_and_never_panic() {
        let tiny_merge = MapTemplate::Merge(Merge {
            lanes: 1,
            lane_width_m: 3.5,
            length_m: 20.0,
            merge_end_m: 10.0,
            acceleration_lane_m: 60.0,
            speed_limit_mps: None,
        });
        let e = tiny_merge.validate().unwrap_err();
        assert_eq!(e.parameter, "length_m");
        assert_eq!(e.to_string(), "length_m must be in 30..=5000, got 20");
        let _ = tiny_merge.build(); // does not panic even unvalidated
        let huge = MapTemplate::Straight(StraightRoad {
            lanes: 3_000_000,
            oncoming_lanes: 0,
            lane_width_m: 3.5,
            length_m: 100.0,
            speed_limit_mps: None,
        });
        assert_eq!(huge.validate().unwrap_err().to_string(), "lanes must be in 1..=8, got 3000000");
        let nan = MapTemplate::Straight(StraightRoad {
            lanes: 2,
            oncoming_lanes: 0,
            lane_width_m: f64::NAN,
            length_m: 100.0,
            speed_limit_mps: None,
        });
        assert_eq!(nan.validate().unwrap_err().parameter, "lane_width_m");
    }

    #[test]
    fn straight_road_lanes_neighbours_and_edges() {
        let m = StraightRoad {
            lanes: 3,
            oncoming_lanes: 1,
            lane_width_m: 3.5,
            length_m: 200.0,
            speed_limit_mps: Some(20.0),
        }
        .build();
        assert_eq!(m.lanes.len(), 4);
        assert_eq!(m.lane(MapElementId(1)).unwrap().left_neighbours, vec![MapElementId(2)]);
        assert_eq!(on_road_share(&m), 1.0);
        assert!(m.is_off_road(&Point2::new(50.0, -1.0)));
        assert!(m.is_off_road(&Point2::new(50.0, 14.5)));
        let d = m.signed_distance_to_road_edge(&Point2::new(50.0, 1.0)).unwrap();
        assert!((d + 1.0).abs() < 1e-9, "{d}");
    }

    #[test]
    fn merge_ramp_leads_into_lane_after_the_merge() {
        let m = Merge {
            lanes: 2,
            lane_width_m: 3.5,
            length_m: 300.0,
            merge_end_m: 150.0,
            acceleration_lane_m: 60.0,
            speed_limit_mps: None,
        }
        .build();
        let ramp = m.lane(MapElementId(50)).unwrap();
        assert_eq!(ramp.successors, vec![MapElementId(10)]);
        let end = *ramp.centreline.points().last().unwrap();
        let start_10 = m.lane(MapElementId(10)).unwrap().centreline.points()[0];
        assert!((end - start_10).norm() < 1e-6, "ramp ends at {end}, lane 10 starts at {start_10}");
        assert!(on_road_share(&m) > 0.99, "{}", on_road_share(&m));
    }

    #[test]
    fn intersection_connectivity_signals_and_road() {
        let p = Intersection {
            missing_arm: None,
            lanes_per_direction: 1,
            lane_width_m: 3.5,
            arm_length_m: 60.0,
            green_s: Some(10.0),
            speed_limit_mps: None,
            right_turn_lanes: false,
        };
        let m = p.build();
        // Inbound east lane 0 (heading west) connects right to north-out 15, straight to west-out 25, left to south-out 35.
        let inbound = m.lane(MapElementId(0)).unwrap();
        assert_eq!(inbound.successors, vec![MapElementId(1000 + 10), MapElementId(1000 + 20), MapElementId(1000 + 30)]);
        let right_turn = m.lane(MapElementId(1010)).unwrap();
        assert_eq!(right_turn.successors, vec![MapElementId(15)]);
        // A right turn from heading west (-x) ends heading north (+y): the path bends right (negative cross product).
        let pts = right_turn.centreline.points();
        let (d0, d1) = (pts[1] - pts[0], pts[pts.len() - 1] - pts[pts.len() - 2]);
        assert!(d0.x * d1.y - d0.y * d1.x < 0.0);
        for c in &inbound.successors {
            let conn = m.lane(*c).unwrap();
            assert!(conn.in_intersection);
            let succ = m.lane(conn.successors[0]).unwrap();
            assert!((conn.centreline.points().last().unwrap() - succ.centreline.points()[0]).norm() < 1e-6);
        }
        assert!(on_road_share(&m) > 0.99, "{}", on_road_share(&m));
        assert!(m.is_off_road(&Point2::new(30.0, 30.0)));
        // Phases: east-west green at t=0, north-south red; swapped after green + yellow.
        assert_eq!(p.signal_at(0, 0.0), SignalState::Go);
        assert_eq!(p.signal_at(1, 0.0), SignalState::Stop);
        assert_eq!(p.signal_at(0, 11.0), SignalState::Caution);
        assert_eq!(p.signal_at(1, 14.0), SignalState::Go);
        assert_eq!(m.signal_state(MapElementId(10), 140), Some(SignalState::Go));
        // The approach pose faces the centre.
        let pose = p.approach_pose(0, 0, 20.0);
        assert!(pose.forward().dot(&(Point2::origin() - pose.position)) > 0.0);
    }

    #[test]
    fn a_t_junction_leaves_its_arm_out_and_closes_the_box_with_a_kerb() {
        let p = Intersection {
            missing_arm: Some(0),
            lanes_per_direction: 1,
            lane_width_m: 3.5,
            arm_length_m: 60.0,
            green_s: Some(10.0),
            speed_limit_mps: None,
            right_turn_lanes: false,
        };
        assert!(MapTemplate::Intersection(p.clone()).validate().is_ok());
        let m = p.build();
        // No east arm: no lane, connector or signal of it.
        assert!(m.lane(MapElementId(0)).is_none() && m.lane(MapElementId(5)).is_none());
        assert!(m.lanes.iter().all(|l| !(l.id.0 >= 1000 && ((l.id.0 - 1000) / 100 == 0 || (l.id.0 / 10) % 10 == 0))));
        assert!(m.signal_state(MapElementId(0), 0).is_none());
        // Arriving from the west (lane 20, heading east) there is no way
        // straight on: a right turn south or a left turn north.
        let inbound = m.lane(MapElementId(20)).unwrap();
        assert_eq!(inbound.successors, vec![MapElementId(1000 + 200 + 30), MapElementId(1000 + 200 + 10)]);
        // The north and south arms still cross straight through.
        let north_in = m.lane(MapElementId(10)).unwrap();
        assert!(north_in.successors.contains(&MapElementId(1000 + 100 + 30)));
        assert!(on_road_share(&m) > 0.99, "{}", on_road_share(&m));
        // Beyond the box on the missing side is off the road, and a kerb
        // runs along the box's side there: three kerbs in all.
        let h = p.half_box_m();
        assert!(m.is_off_road(&Point2::new(h + 10.0, 0.0)));
        assert!(!m.is_off_road(&Point2::new(h - 1.0, 0.0)));
        assert_eq!(m.road_edges.len(), 3);
        let kerb_dist = m
            .road_edges
            .iter()
            .filter_map(|e| e.polyline.project(&Point2::new(h + 0.5, 0.0)))
            .map(|pr| pr.distance_m)
            .fold(f64::INFINITY, f64::min);
        assert!(kerb_dist < 1.0, "{kerb_dist}");
        // An arm out of range is refused.
        let bad = MapTemplate::Intersection(Intersection { missing_arm: Some(4), ..p });
        assert_eq!(bad.validate().unwrap_err().parameter, "missing_arm");
    }

    #[test]
    fn a_right_turn_lane_turns_right_only_and_the_lane_beside_it_goes_straight() {
        let p = Intersection {
            missing_arm: None,
            lanes_per_direction: 2,
            lane_width_m: 3.5,
            arm_length_m: 60.0,
            green_s: None,
            speed_limit_mps: None,
            right_turn_lanes: true,
        };
        assert!(MapTemplate::Intersection(p.clone()).validate().is_ok());
        let m = p.build();
        // East arm, heading west: lane 1 is the kerb lane, lane 0 by the centre line.
        let kerb = m.lane(MapElementId(1)).unwrap();
        assert_eq!(kerb.successors, vec![MapElementId(1000 + 10 + 1)], "the right turn north only");
        let beside = m.lane(MapElementId(0)).unwrap();
        assert_eq!(beside.successors, vec![MapElementId(1000 + 20), MapElementId(1000 + 30)], "straight and left");
        // Without the option the kerb lane also goes straight.
        let plain = Intersection { right_turn_lanes: false, ..p.clone() }.build();
        assert_eq!(
            plain.lane(MapElementId(1)).unwrap().successors,
            vec![MapElementId(1000 + 10 + 1), MapElementId(1000 + 20 + 1)]
        );
        assert!(on_road_share(&m) > 0.99, "{}", on_road_share(&m));
        // One lane per direction has no lane beside the kerb lane to go straight.
        let bad = MapTemplate::Intersection(Intersection { lanes_per_direction: 1, ..p });
        let err = bad.validate().unwrap_err();
        assert_eq!(err.parameter, "lanes_per_direction");
        assert!(err.to_string().contains("right_turn_lanes"), "{err}");
    }
}
