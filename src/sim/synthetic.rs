//! Synthetic traffic: random vehicles placed on the lanes of a map (a
//! procedural template or a real recorded map) with per-driver IDM
//! parameters and a seeded acceleration disturbance ([`crate::policies::noisy_idm::NoisyIdm`]),
//! simulated into a full scenario like a recording. Used to make training
//! data whose licence allows shipping the models trained on it.
//!
//! Desired speeds are drawn from a [`SpeedSample`] of recorded speeds (the
//! caller calibrates it against real scenes), scaled to the map's limit.
//! Drivers make lateral choices ([`SyntheticDriver`](crate::policies::synthetic_driver::SyntheticDriver)):
//! they turn at junctions, change lanes when there is room and accept or
//! refuse gaps in crossing traffic, each at its own drawn rate; with
//! [`SyntheticTraffic::choices`] off they keep their lane and go straight.
//!
//! With a [`SyntheticTraffic::pedestrian_share`], that share of the scenes
//! also has pedestrians walking across the road, on its crosswalks and
//! mid-block on urban streets, and the drivers yield to them: a prior
//! trained on vehicles alone has never seen a person in its way.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::authoring::{AuthoredAgent, AuthoredBehaviour, AuthoredScenario, synthesize};
use crate::geometry::{OrientedBox, Point2, Pose2, Vector2};
use crate::map::templates::{Intersection, Merge, StraightRoad};
use crate::map::{AreaKind, RoadMap};
use crate::policies::IdmParams;
use crate::policies::noisy_idm::DriverNoise;
use crate::policies::synthetic_driver::DriverChoices;
use crate::scenario::{AgentBody, AgentId, AgentKind, AgentState, Scenario};

/// Recorded speeds that synthetic desired speeds are drawn from, m/s.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedSample {
    /// Speeds of moving vehicles, sorted.
    pub speeds_mps: Vec<f64>,
}

impl SpeedSample {
    /// A sample from raw speeds (non-finite and near-zero speeds dropped).
    pub fn new(mut speeds_mps: Vec<f64>) -> Self {
        speeds_mps.retain(|v| v.is_finite() && *v > 1.0);
        speeds_mps.sort_by(f64::total_cmp);
        Self { speeds_mps }
    }

    /// A random draw (a fixed fallback when the sample is empty).
    pub fn draw(&self, rng: &mut impl Rng) -> f64 {
        if self.speeds_mps.is_empty() {
            return 12.0;
        }
        self.speeds_mps[rng.random_range(0..self.speeds_mps.len())]
    }

    /// The `q` quantile.
    pub fn quantile(&self, q: f64) -> f64 {
        if self.speeds_mps.is_empty() {
            return f64::NAN;
        }
        let i = ((self.speeds_mps.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize;
        self.speeds_mps[i]
    }
}

/// Settings of the traffic generator.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticTraffic {
    /// Desired speeds come from here.
    pub speeds: SpeedSample,
    /// Standard deviation of the drivers' acceleration disturbance, m/s².
    pub accel_noise_std_mps2: f64,
    /// Duration of the generated scene, s.
    pub duration_s: f64,
    /// Most vehicles placed.
    pub max_agents: usize,
    /// Whether drivers turn, change lanes and accept gaps (else they keep
    /// their lane and go straight).
    pub choices: bool,
    /// Share of scenes with pedestrians crossing the road (0: none). Drawn
    /// from a generator of their own, so that the vehicles of a scene are
    /// the same whatever the share.
    pub pedestrian_share: f64,
}

/// Fastest speed limit of a street where pedestrians cross mid-block, m/s
/// (about 60 km/h: urban streets, not highways).
const MID_BLOCK_MAX_LIMIT_MPS: f64 = 17.0;
/// Walking speeds, m/s.
const WALKING_SPEED_MPS: std::ops::Range<f64> = 1.0..1.8;
/// How far before the kerb a crossing pedestrian starts, m (so that its
/// arrival at the road varies over the scene).
const KERB_APPROACH_M: std::ops::Range<f64> = 0.5..9.0;
/// Longest road crossing looked for, m.
const MAX_CROSSING_M: f64 = 40.0;

/// A random procedural map: a straight multi-lane road (sometimes with
/// oncoming lanes), an on-ramp merge, or a signalised four-way crossing.
pub fn random_template(rng: &mut impl Rng, steps: usize, dt_s: f64) -> (String, RoadMap) {
    random_template_with(rng, steps, dt_s, CrossingMix::default())
}

/// What share of the template crossings [`random_template_with`] draws
/// without signals and as T-junctions.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CrossingMix {
    /// Crossings without signals (drivers then settle who goes by gap
    /// acceptance).
    pub unsignalised_share: f64,
    /// Crossings with one arm left out, where traffic arriving opposite it
    /// must turn.
    pub t_junction_share: f64,
    /// Crossings of two lanes per direction whose kerb lanes turn right
    /// only (share of those crossings).
    pub right_turn_lane_share: f64,
}

/// [`random_template`] with the crossings drawn by `mix`; shares of zero
/// draw exactly what [`random_template`] draws.
pub fn random_template_with(rng: &mut impl Rng, steps: usize, dt_s: f64, mix: CrossingMix) -> (String, RoadMap) {
    let width = rng.random_range(3.2..3.9);
    match rng.random_range(0..3) {
        0 => {
            let road = StraightRoad {
                lanes: rng.random_range(1..=4),
                oncoming_lanes: if rng.random_bool(0.4) { rng.random_range(1..=2) } else { 0 },
                lane_width_m: width,
                length_m: 600.0,
                speed_limit_mps: Some(rng.random_range(13.0..31.0)),
            };
            ("straight".into(), road.build())
        }
        1 => {
            let merge = Merge {
                lanes: rng.random_range(1..=3),
                lane_width_m: width,
                length_m: 600.0,
                merge_end_m: rng.random_range(200.0..350.0),
                acceleration_lane_m: rng.random_range(50.0..120.0),
                speed_limit_mps: Some(rng.random_range(20.0..31.0)),
            };
            ("merge".into(), merge.build())
        }
        _ => {
            let mut crossing = Intersection {
                lanes_per_direction: rng.random_range(1..=2),
                lane_width_m: width,
                arm_length_m: 150.0,
                green_s: if mix.unsignalised_share > 0.0 && rng.random_bool(mix.unsignalised_share.min(1.0)) {
                    None
                } else {
                    Some(rng.random_range(6.0..20.0))
                },
                speed_limit_mps: Some(rng.random_range(11.0..17.0)),
                missing_arm: None,
                right_turn_lanes: false,
            };
            // Drawn last, and only when asked for, so that a share of zero
            // leaves every other draw where it was.
            if mix.t_junction_share > 0.0 && rng.random_bool(mix.t_junction_share.min(1.0)) {
                crossing.missing_arm = Some(rng.random_range(0..4));
            }
            if crossing.lanes_per_direction >= 2
                && mix.right_turn_lane_share > 0.0
                && rng.random_bool(mix.right_turn_lane_share.min(1.0))
            {
                crossing.right_turn_lanes = true;
            }
            let key = if crossing.missing_arm.is_some() { "t-junction" } else { "intersection" };
            (key.into(), crossing.build_with_signals(steps, dt_s))
        }
    }
}

impl SyntheticTraffic {
    /// Places vehicles on the lanes of `map` and simulates them; the first
    /// placed vehicle is the ego (the scene is for training, not testing).
    /// Deterministic in `seed`. `None` when no vehicle fits.
    pub fn generate(&self, id: &str, map: RoadMap, seed: u64) -> Option<Scenario> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let density_per_m = rng.random_range(1.0 / 60.0..1.0 / 15.0);
        let mut placed: Vec<OrientedBox> = Vec::new();
        let mut agents = Vec::new();
        let mut lane_order: Vec<usize> = (0..map.lanes.len()).filter(|&i| !map.lanes[i].in_intersection).collect();
        // Fisher–Yates with the seeded generator (deterministic order).
        for i in (1..lane_order.len()).rev() {
            lane_order.swap(i, rng.random_range(0..=i));
        }
        for lane_index in lane_order {
            let lane = &map.lanes[lane_index];
            let length = lane.centreline.length_m();
            let mut s = rng.random_range(2.0..20.0);
            while s < length - 5.0 && agents.len() < self.max_agents {
                let Some((p, dir)) = lane.centreline.sample(s) else { break };
                let heading = dir.y.atan2(dir.x);
                let body = random_vehicle(&mut rng);
                let pose = Pose2 { position: p, heading_rad: heading };
                let footprint = OrientedBox::new(pose, body.length_m + 4.0, body.width_m + 0.5);
                if placed.iter().all(|b| !b.intersects(&footprint)) {
                    // Recorded speeds, scaled on a map with a limit so that
                    // their 90th percentile sits at it: the shape stays the
                    // recorded one. Recorded maps without limits keep them.
                    let (scale, cap) = match lane.speed_limit_mps {
                        Some(limit) => (limit / self.speeds.quantile(0.9).max(1.0), limit * 1.2),
                        None => (1.0, self.speeds.quantile(0.99) * 1.1),
                    };
                    let desired = (self.speeds.draw(&mut rng) * scale).clamp(2.0, cap.max(2.0));
                    let speed = desired * rng.random_range(0.8..1.0);
                    let params = IdmParams {
                        desired_speed_mps: Some(desired),
                        max_accel_mps2: rng.random_range(0.8..2.5),
                        comfort_decel_mps2: rng.random_range(1.5..3.0),
                        time_headway_s: rng.random_range(0.9..2.2),
                        min_gap_m: rng.random_range(1.5..3.5),
                        ..IdmParams::default()
                    };
                    let noise = DriverNoise {
                        accel_std_mps2: self.accel_noise_std_mps2 * rng.random_range(0.5..1.5),
                        correlation_time_s: rng.random_range(1.0..4.0),
                        seed: rng.random(),
                    };
                    let behaviour = if self.choices {
                        let choices = DriverChoices {
                            turn_probability: rng.random_range(0.4..0.9),
                            lane_change_rate_per_s: rng.random_range(0.02..0.25),
                            lane_change_duration_s: rng.random_range(3.0..6.0),
                            accepted_gap_s: if rng.random_bool(0.15) { 0.0 } else { rng.random_range(1.5..4.5) },
                            seed: rng.random(),
                        };
                        AuthoredBehaviour::Synthetic(params, noise, choices)
                    } else {
                        AuthoredBehaviour::NoisyIdm(params, noise)
                    };
                    placed.push(footprint);
                    agents.push(AuthoredAgent {
                        id: AgentId(format!("synthetic-{}", agents.len())),
                        body,
                        initial: AgentState {
                            position: p,
                            heading_rad: heading,
                            velocity_mps: Vector2::new(heading.cos(), heading.sin()) * speed,
                        },
                        behaviour,
                    });
                }
                s += body.length_m + 4.0 + rng.random_range(0.0..2.0) / density_per_m;
            }
        }
        if agents.is_empty() {
            return None;
        }
        if self.pedestrian_share > 0.0 {
            let mut walkers = ChaCha8Rng::seed_from_u64(seed ^ 0x005E_ED0F_7ED5_u64);
            if walkers.random_bool(self.pedestrian_share.min(1.0)) {
                let first = agents.len();
                for (k, initial) in crossing_pedestrians(&map, &mut walkers).into_iter().enumerate() {
                    agents.push(AuthoredAgent {
                        id: AgentId(format!("synthetic-pedestrian-{}", first + k)),
                        body: AgentBody {
                            kind: AgentKind::Pedestrian,
                            length_m: walkers.random_range(0.5..0.9),
                            width_m: walkers.random_range(0.5..0.9),
                        },
                        behaviour: AuthoredBehaviour::CrossingPedestrian(initial.speed_mps()),
                        initial,
                    });
                }
            }
        }
        let authored = AuthoredScenario {
            id: id.to_string(),
            path: format!("synthetic:{id}").into(),
            map,
            agents,
            ego: 0,
            cbv: None,
            duration_s: self.duration_s,
        };
        Some(synthesize(&authored))
    }
}

/// Start states of pedestrians crossing `map`'s road: up to two on each
/// crosswalk (along its long side, either way) and, on streets with a
/// limit of at most 17 m/s, a few mid-block. Each
/// starts off the road, a random distance before the kerb, and walks
/// straight across at its own pace.
pub fn crossing_pedestrians(map: &RoadMap, rng: &mut impl Rng) -> Vec<AgentState> {
    let mut lines: Vec<(Point2, Vector2)> = Vec::new();
    for area in map.areas.iter().filter(|a| a.kind == AreaKind::Crosswalk) {
        let v = &area.polygon.vertices;
        if v.len() < 3 {
            continue;
        }
        let centre = v.iter().fold(Vector2::zeros(), |acc, p| acc + p.coords) / v.len() as f64;
        let (e1, e2) = (v[1] - v[0], v[2] - v[1]);
        let along = if e1.norm() >= e2.norm() { e1 } else { e2 };
        if along.norm() < 1e-6 {
            continue;
        }
        for _ in 0..[1, 1, 2][rng.random_range(0..3)] {
            // Where on the crosswalk's width the walker keeps, a little off the middle.
            let across = Vector2::new(-along.y, along.x).normalize() * rng.random_range(-0.8..0.8);
            lines.push((Point2::from(centre) + across, along.normalize()));
        }
    }
    let streets: Vec<&crate::map::Lane> = map
        .lanes
        .iter()
        .filter(|l| !l.in_intersection && l.speed_limit_mps.is_some_and(|v| v <= MID_BLOCK_MAX_LIMIT_MPS))
        .collect();
    if !streets.is_empty() {
        for _ in 0..rng.random_range(0..=2) {
            let lane = streets[rng.random_range(0..streets.len())];
            let length = lane.centreline.length_m();
            if length < 30.0 {
                continue;
            }
            let Some((p, dir)) = lane.centreline.sample(rng.random_range(10.0..length - 10.0)) else { continue };
            lines.push((p, Vector2::new(-dir.y, dir.x)));
        }
    }
    let mut starts = Vec::new();
    for (point, along) in lines {
        if map.is_off_road(&point) {
            continue;
        }
        // The road's extent along the walk, found by stepping out to each kerb.
        let kerb = |sign: f64| {
            (1..=(MAX_CROSSING_M / 0.5) as usize)
                .map(|k| k as f64 * 0.5 * sign)
                .find(|&t| map.is_off_road(&(point + along * t)))
        };
        let (Some(a), Some(b)) = (kerb(-1.0), kerb(1.0)) else { continue };
        let (from, heading_vec) = if rng.random_bool(0.5) { (a, along) } else { (b, -along) };
        let start = point + along * from - heading_vec * rng.random_range(KERB_APPROACH_M);
        let speed = rng.random_range(WALKING_SPEED_MPS);
        starts.push(AgentState {
            position: start,
            heading_rad: heading_vec.y.atan2(heading_vec.x),
            velocity_mps: heading_vec * speed,
        });
    }
    starts
}

fn random_vehicle(rng: &mut impl Rng) -> AgentBody {
    if rng.random_bool(0.08) {
        AgentBody {
            kind: AgentKind::Vehicle,
            length_m: rng.random_range(8.0..14.0),
            width_m: rng.random_range(2.4..2.6),
        }
    } else {
        AgentBody {
            kind: AgentKind::Vehicle,
            length_m: rng.random_range(4.0..5.4),
            width_m: rng.random_range(1.7..2.1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn traffic() -> SyntheticTraffic {
        SyntheticTraffic {
            speeds: SpeedSample::new((5..30).map(f64::from).collect()),
            accel_noise_std_mps2: 0.4,
            duration_s: 6.0,
            max_agents: 40,
            choices: true,
            pedestrian_share: 0.0,
        }
    }

    #[test]
    fn the_same_seed_gives_the_same_scene() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (_, map) = random_template(&mut rng, 61, 0.1);
        let a = traffic().generate("a", map.clone(), 11).unwrap();
        let b = traffic().generate("a", map, 11).unwrap();
        assert_eq!(a.tracks, b.tracks);
        assert!(a.tracks.len() >= 2);
        assert_eq!(a.num_steps(), 61);
    }

    #[test]
    fn placed_vehicles_do_not_overlap_at_the_start() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for seed in 0..6 {
            let (_, map) = random_template(&mut rng, 61, 0.1);
            let Some(s) = traffic().generate("x", map, seed) else { continue };
            for (i, a) in s.tracks.iter().enumerate() {
                for b in &s.tracks[i + 1..] {
                    assert!(!a.footprint(0).unwrap().intersects(&b.footprint(0).unwrap()));
                }
            }
        }
    }

    /// One car of the synthetic driver, placed on a template map.
    fn driver(id: &str, pose: Pose2, speed_mps: f64, choices: DriverChoices) -> AuthoredAgent {
        let noise = DriverNoise { accel_std_mps2: 0.0, correlation_time_s: 2.0, seed: 0 };
        AuthoredAgent {
            id: AgentId(id.into()),
            body: AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 1.9 },
            initial: AgentState {
                position: pose.position,
                heading_rad: pose.heading_rad,
                velocity_mps: Vector2::new(pose.heading_rad.cos(), pose.heading_rad.sin()) * speed_mps,
            },
            behaviour: AuthoredBehaviour::Synthetic(
                IdmParams { desired_speed_mps: Some(speed_mps), ..IdmParams::default() },
                noise,
                choices,
            ),
        }
    }

    fn keeps_going(seed: u64) -> DriverChoices {
        DriverChoices {
            turn_probability: 0.0,
            lane_change_rate_per_s: 0.0,
            lane_change_duration_s: 4.0,
            accepted_gap_s: 3.0,
            seed,
        }
    }

    fn simulate(map: RoadMap, agents: Vec<AuthoredAgent>, duration_s: f64) -> Scenario {
        synthesize(&AuthoredScenario {
            id: "choices".into(),
            path: "synthetic:choices".into(),
            map,
            agents,
            ego: 0,
            cbv: None,
            duration_s,
        })
    }

    fn crossing() -> Intersection {
        Intersection {
            missing_arm: None,
            right_turn_lanes: false,
            lanes_per_direction: 1,
            lane_width_m: 3.5,
            arm_length_m: 80.0,
            green_s: None,
            speed_limit_mps: Some(12.0),
        }
    }

    /// Heading change of a track from its first to its last state, rad.
    fn turned_rad(s: &Scenario, track: usize) -> f64 {
        let t = &s.tracks[track];
        let (a, b) = (t.states.first().unwrap().unwrap(), t.states.last().unwrap().unwrap());
        crate::geometry::wrap_angle(b.heading_rad - a.heading_rad)
    }

    #[test]
    fn a_driver_that_always_turns_leaves_the_crossing_on_another_arm() {
        let c = crossing();
        let start = c.approach_pose(0, 0, 25.0);
        let straight = simulate(c.build(), vec![driver("a", start, 8.0, keeps_going(1))], 10.0);
        assert!(turned_rad(&straight, 0).abs() < 0.1, "went straight: {}", turned_rad(&straight, 0));
        let turns: Vec<f64> = (0..8)
            .map(|seed| {
                let choices = DriverChoices { turn_probability: 1.0, ..keeps_going(seed) };
                turned_rad(&simulate(c.build(), vec![driver("a", start, 8.0, choices)], 10.0), 0)
            })
            .collect();
        assert!(turns.iter().all(|t| (t.abs() - std::f64::consts::FRAC_PI_2).abs() < 0.35), "{turns:?}");
        assert!(turns.iter().any(|t| *t > 0.0) && turns.iter().any(|t| *t < 0.0), "left and right: {turns:?}");
    }

    #[test]
    fn at_a_t_junction_a_driver_that_would_go_straight_turns_and_stays_on_the_road() {
        // The north arm is missing: from the south (arm 3) there is no way on.
        let t = Intersection { missing_arm: Some(1), ..crossing() };
        let start = t.approach_pose(3, 0, 25.0);
        for seed in 0..4 {
            let scene = simulate(t.build(), vec![driver("a", start, 8.0, keeps_going(seed))], 10.0);
            let turned = turned_rad(&scene, 0);
            assert!((turned.abs() - std::f64::consts::FRAC_PI_2).abs() < 0.35, "seed {seed}: turned {turned}");
            let off = scene.tracks[0].states.iter().flatten().filter(|s| scene.map.is_off_road(&s.position)).count();
            assert_eq!(off, 0, "seed {seed}: {off} states off the road");
        }
    }

    #[test]
    fn in_a_right_turn_lane_a_driver_that_would_go_straight_turns_right_and_the_lane_beside_it_goes_on() {
        let c = Intersection { lanes_per_direction: 2, right_turn_lanes: true, ..crossing() };
        let kerb_lane = c.approach_pose(0, 1, 25.0);
        let beside = c.approach_pose(0, 0, 25.0);
        for seed in 0..4 {
            let scene = simulate(c.build(), vec![driver("a", kerb_lane, 8.0, keeps_going(seed))], 10.0);
            // Right-hand traffic: a right turn is clockwise, a negative heading change.
            let turned = turned_rad(&scene, 0);
            assert!((turned + std::f64::consts::FRAC_PI_2).abs() < 0.35, "seed {seed}: turned {turned}");
            let off = scene.tracks[0].states.iter().flatten().filter(|s| scene.map.is_off_road(&s.position)).count();
            assert_eq!(off, 0, "seed {seed}: {off} states off the road");
            let straight = simulate(c.build(), vec![driver("b", beside, 8.0, keeps_going(seed))], 10.0);
            assert!(turned_rad(&straight, 0).abs() < 0.1, "seed {seed}: beside it turned {}", turned_rad(&straight, 0));
        }
    }

    #[test]
    fn a_driver_changes_lanes_only_when_the_neighbour_lane_has_room() {
        let road =
            StraightRoad { lanes: 2, oncoming_lanes: 0, lane_width_m: 3.5, length_m: 400.0, speed_limit_mps: None };
        let start = Pose2::new(20.0, 0.5 * 3.5, 0.0);
        let eager = DriverChoices { lane_change_rate_per_s: 100.0, ..keeps_going(3) };
        let free = simulate(road.build(), vec![driver("a", start, 12.0, eager)], 8.0);
        let end = free.tracks[0].states.last().unwrap().unwrap();
        assert!((end.position.y - 1.5 * 3.5).abs() < 0.4, "in the left lane at the end: y = {}", end.position.y);
        let beside = driver("b", Pose2::new(20.0, 1.5 * 3.5, 0.0), 12.0, keeps_going(4));
        let blocked = simulate(road.build(), vec![driver("a", start, 12.0, eager), beside], 8.0);
        let max_offset =
            blocked.tracks[0].states.iter().flatten().map(|s| (s.position.y - 1.75).abs()).fold(0.0, f64::max);
        assert!(max_offset < 0.3, "stayed in its lane beside a car: offset {max_offset}");
    }

    #[test]
    fn a_turning_driver_yields_to_oncoming_traffic_unless_it_accepts_no_gap() {
        let c = crossing();
        // A seed whose driver turns left from arm 0.
        let left = (0..32)
            .map(|seed| DriverChoices { turn_probability: 1.0, ..keeps_going(seed) })
            .find(|ch| {
                turned_rad(&simulate(c.build(), vec![driver("a", c.approach_pose(0, 0, 25.0), 8.0, *ch)], 10.0), 0)
                    > 1.0
            })
            .expect("one of 32 seeds turns left");
        let oncoming = driver("b", c.approach_pose(2, 0, 30.0), 10.0, keeps_going(9));
        let min_speed =
            |s: &Scenario| s.tracks[0].states.iter().flatten().map(|s| s.speed_mps()).fold(f64::INFINITY, f64::min);
        let careful =
            simulate(c.build(), vec![driver("a", c.approach_pose(0, 0, 25.0), 8.0, left), oncoming.clone()], 10.0);
        let bold = DriverChoices { accepted_gap_s: 0.0, ..left };
        let rushed = simulate(c.build(), vec![driver("a", c.approach_pose(0, 0, 25.0), 8.0, bold), oncoming], 10.0);
        // Steps at which a track is inside the crossing's box.
        let h = c.half_box_m();
        let in_box = |s: &Scenario, t: usize| -> Vec<usize> {
            (0..s.num_steps())
                .filter(|&k| s.tracks[t].state(k).is_some_and(|p| p.position.x.abs() < h && p.position.y.abs() < h))
                .collect()
        };
        let (careful_speed, rushed_speed) = (min_speed(&careful), min_speed(&rushed));
        assert!(careful_speed < 3.0 && rushed_speed > careful_speed + 3.0, "waited: {careful_speed} vs {rushed_speed}");
        assert!(turned_rad(&careful, 0) > 1.0, "and then turned");
        // The careful turner enters the box after the oncoming car has left it; the bold one before.
        let (a, b) = (in_box(&careful, 0), in_box(&careful, 1));
        assert!(
            a.first() > b.last(),
            "careful turner entered at step {:?}, oncoming left at {:?}",
            a.first(),
            b.last()
        );
        let (a, b) = (in_box(&rushed, 0), in_box(&rushed, 1));
        assert!(a.first() < b.last(), "bold turner entered at step {:?}, oncoming left at {:?}", a.first(), b.last());
    }

    /// Steps at which two tracks' footprints overlap.
    fn contacts(s: &Scenario, a: usize, b: usize) -> usize {
        (0..s.num_steps())
            .filter(|&k| match (s.tracks[a].footprint(k), s.tracks[b].footprint(k)) {
                (Some(x), Some(y)) => x.intersects(&y),
                _ => false,
            })
            .count()
    }

    #[test]
    fn pedestrians_walk_across_the_road_and_no_vehicle_touches_them() {
        let walking = SyntheticTraffic { pedestrian_share: 1.0, duration_s: 10.0, max_agents: 80, ..traffic() };
        let (mut scenes, mut pedestrians, mut on_road) = (0, 0, 0);
        for seed in 0..40u64 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let (key, map) = random_template(&mut rng, 101, 0.1);
            let Some(s) = walking.generate("walk", map, seed) else { continue };
            let people: Vec<usize> =
                (0..s.tracks.len()).filter(|&i| s.tracks[i].kind == AgentKind::Pedestrian).collect();
            if key != "intersection" {
                // Nobody crosses a highway: only streets of at most 17 m/s have walkers.
                let street = s.map.lanes.iter().any(|l| l.speed_limit_mps.is_some_and(|v| v <= 17.0));
                assert!(street || people.is_empty(), "seed {seed}: {} pedestrians on a {key}", people.len());
                continue;
            }
            scenes += 1;
            pedestrians += people.len();
            for &p in &people {
                let states: Vec<&AgentState> = s.tracks[p].states.iter().flatten().collect();
                assert!(s.map.is_off_road(&states[0].position), "seed {seed}: pedestrian {p} starts on the road");
                on_road += usize::from(states.iter().any(|st| !s.map.is_off_road(&st.position)));
                for v in (0..s.tracks.len()).filter(|&v| s.tracks[v].kind == AgentKind::Vehicle) {
                    assert_eq!(contacts(&s, p, v), 0, "seed {seed}: vehicle {v} touched pedestrian {p}");
                }
            }
        }
        assert!(scenes >= 8 && pedestrians >= 4 * scenes, "{pedestrians} pedestrians in {scenes} crossings");
        assert!(on_road * 10 >= pedestrians * 8, "only {on_road} of {pedestrians} stepped onto the road");
    }

    #[test]
    fn the_pedestrian_share_leaves_the_vehicles_where_they_were() {
        let map = crossing().build_with_signals(61, 0.1);
        let without = traffic().generate("a", map.clone(), 21).unwrap();
        let with = SyntheticTraffic { pedestrian_share: 1.0, ..traffic() }.generate("a", map, 21).unwrap();
        assert!(without.tracks.iter().all(|t| t.kind == AgentKind::Vehicle));
        assert!(with.tracks.len() > without.tracks.len(), "pedestrians were added");
        for (a, b) in without.tracks.iter().zip(&with.tracks) {
            assert_eq!((a.kind, a.state(0)), (b.kind, b.state(0)), "placed where it was without pedestrians");
        }
    }

    #[test]
    fn a_driver_stops_for_a_pedestrian_crossing_mid_block_and_then_drives_on() {
        let road = StraightRoad {
            lanes: 1,
            oncoming_lanes: 1,
            lane_width_m: 3.5,
            length_m: 300.0,
            speed_limit_mps: Some(12.0),
        };
        let car = driver("car", Pose2::new(20.0, 1.75, 0.0), 10.0, keeps_going(2));
        // Two metres below the near kerb (y = 0), 40 m ahead, walking across to y > 7.
        let walker = AuthoredAgent {
            id: AgentId("walker".into()),
            body: AgentBody { kind: AgentKind::Pedestrian, length_m: 0.6, width_m: 0.6 },
            initial: AgentState {
                position: Point2::new(60.0, -2.0),
                heading_rad: std::f64::consts::FRAC_PI_2,
                velocity_mps: Vector2::new(0.0, 1.4),
            },
            behaviour: AuthoredBehaviour::CrossingPedestrian(1.4),
        };
        let alone = simulate(road.build(), vec![car.clone()], 12.0);
        let with = simulate(road.build(), vec![car, walker], 12.0);
        let speeds = |s: &Scenario| s.tracks[0].states.iter().flatten().map(|s| s.speed_mps()).collect::<Vec<_>>();
        let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(min(&speeds(&alone)) > 8.0, "an empty street: {}", min(&speeds(&alone)));
        assert!(min(&speeds(&with)) < 6.0, "slowed for the walker to {}", min(&speeds(&with)));
        assert_eq!(contacts(&with, 0, 1), 0);
        // When the car's front reaches the walker's line, the walker is out of the car's lane (0–3.5 m).
        let reaches = (0..with.num_steps())
            .find(|&k| with.tracks[0].state(k).is_some_and(|c| c.position.x + 2.25 >= 59.7))
            .expect("the car reaches the crossing");
        let y = with.tracks[1].state(reaches).unwrap().position.y;
        assert!(!(-0.3..=3.8).contains(&y), "the walker was in the car's lane (y = {y}) as it passed");
        let (car_end, walker_end) =
            (with.tracks[0].states.last().unwrap().unwrap(), with.tracks[1].states.last().unwrap().unwrap());
        assert!(walker_end.position.y > 7.0, "crossed: y = {}", walker_end.position.y);
        assert!(car_end.position.x > 70.0 && car_end.speed_mps() > 4.0, "drove on: {car_end:?}");
    }

    #[test]
    fn speeds_are_drawn_from_the_sample_scaled_to_the_limit() {
        let sample = SpeedSample::new(vec![0.5, 10.0, 20.0, f64::NAN]);
        assert_eq!(sample.speeds_mps, vec![10.0, 20.0]);
        assert_eq!(sample.quantile(1.0), 20.0);
    }
}
