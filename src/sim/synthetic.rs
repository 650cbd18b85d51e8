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

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::authoring::{AuthoredAgent, AuthoredBehaviour, AuthoredScenario, synthesize};
use crate::geometry::{OrientedBox, Pose2, Vector2};
use crate::map::RoadMap;
use crate::map::templates::{Intersection, Merge, StraightRoad};
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
}

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
            };
            // Drawn last, and only when asked for, so that a share of zero
            // leaves every other draw where it was.
            if mix.t_junction_share > 0.0 && rng.random_bool(mix.t_junction_share.min(1.0)) {
                crossing.missing_arm = Some(rng.random_range(0..4));
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

    #[test]
    fn speeds_are_drawn_from_the_sample_scaled_to_the_limit() {
        let sample = SpeedSample::new(vec![0.5, 10.0, 20.0, f64::NAN]);
        assert_eq!(sample.speeds_mps, vec![10.0, 20.0]);
        assert_eq!(sample.quantile(1.0), 20.0);
    }
}
