//! Hand-built scenes whose realism scores can be derived by hand.

use super::*;
use crate::geometry::{Point2, Polyline, Vector2};
use crate::map::{Lane, MapElementId, RoadEdge, RoadEdgeKind, RoadMap, SignalState, TrafficSignal};
use crate::scenario::{AgentId, AgentKind, ScenarioSource, Track};

const STEPS: usize = 91;
const DT: f64 = 0.1;

/// Motion of one agent: position at time `t` s, constant heading and velocity.
#[derive(Clone, Copy)]
struct Motion {
    x0: f64,
    y: f64,
    speed_mps: f64,
    heading_rad: f64,
}

impl Motion {
    fn along_x(x0: f64, y: f64, speed_mps: f64) -> Self {
        Self { x0, y, speed_mps, heading_rad: 0.0 }
    }

    fn state(&self, step: usize) -> AgentState {
        let t = step as f64 * DT;
        let dir = Vector2::new(self.heading_rad.cos(), self.heading_rad.sin());
        AgentState {
            position: Point2::new(self.x0, self.y) + dir * self.speed_mps * t,
            heading_rad: self.heading_rad,
            velocity_mps: dir * self.speed_mps,
        }
    }
}

fn straight(y: f64, x0: f64, x1: f64) -> Polyline {
    Polyline::new(vec![Point2::new(x0, y), Point2::new(x1, y)])
}

/// Two lanes along +x (y = 0 and 3.5) between road edges at y = -2 and y = 5.5.
fn road(signals: Vec<TrafficSignal>) -> RoadMap {
    let lanes = vec![
        Lane::new(MapElementId(1), straight(0.0, -100.0, 400.0)),
        Lane::new(MapElementId(2), straight(3.5, -100.0, 400.0)),
    ];
    let edges = vec![
        RoadEdge { id: MapElementId(10), polyline: straight(-2.0, -100.0, 400.0), kind: RoadEdgeKind::Boundary },
        RoadEdge { id: MapElementId(11), polyline: straight(5.5, 400.0, -100.0), kind: RoadEdgeKind::Boundary },
    ];
    RoadMap::new(lanes, edges, vec![], vec![], vec![], vec![], signals)
}

fn scene(motions: &[Motion], map: RoadMap) -> Scenario {
    let tracks = motions
        .iter()
        .enumerate()
        .map(|(i, m)| Track {
            id: AgentId(i.to_string()),
            kind: AgentKind::Vehicle,
            length_m: 4.0,
            width_m: 2.0,
            states: (0..STEPS).map(|k| Some(m.state(k))).collect(),
        })
        .collect();
    let mut s = Scenario::new("hand-built", ScenarioSource::authored("test"), DT, map, tracks);
    s.current_step = 10;
    s
}

fn window() -> RealismWindow {
    RealismWindow { start_step: 10, future_steps: 80 }
}

/// A rollout of the window: the log's current step, then `motions` (track
/// order) from step 11 on.
fn rollout(scenario: &Scenario, motions: &[Motion]) -> Vec<Vec<Option<AgentState>>> {
    (10..=90)
        .map(|k| {
            if k == 10 {
                scenario.tracks.iter().map(|t| t.states[k]).collect()
            } else {
                motions.iter().map(|m| Some(m.state(k))).collect()
            }
        })
        .collect()
}

fn log_rollout(scenario: &Scenario) -> Vec<Vec<Option<AgentState>>> {
    (10..=90).map(|k| scenario.tracks.iter().map(|t| t.states[k]).collect()).collect()
}

#[test]
fn log_replay_reaches_the_hand_computed_speed_likelihood_and_a_wrong_speed_scores_lower() {
    // One car at a constant 11 m/s (bin 4 of 0–25 m/s in 2.5 m/s bins).
    let motions = [Motion::along_x(0.0, 0.0, 11.0)];
    let s = scene(&motions, road(vec![]));
    let r = 4;
    let config = RealismConfig::wosac_2025();
    let replay = score_scenario(&s, window(), &vec![log_rollout(&s); r], &config).unwrap();
    assert_eq!(replay.distinct_rollouts, 1);
    // Per rollout 79 speeds in bin 4 and the last step's NaN in bin 0
    // (central difference off the end), so p(bin 4) = (79R + 0.1) / (80R + 1.0):
    // the best any rollout can do, since every rollout has that NaN.
    let expected = (79.0 * r as f64 + 0.1) / (80.0 * r as f64 + 1.0);
    let got = replay.likelihoods.linear_speed.unwrap();
    assert!((got - expected).abs() < 1e-12, "{got} vs {expected}");
    // Zero acceleration and yaw: bin 5 of 11 for each; 78 finite per rollout.
    let expected_acc = (78.0 * r as f64 + 0.1) / (80.0 * r as f64 + 1.1);
    assert!((replay.likelihoods.linear_acceleration.unwrap() - expected_acc).abs() < 1e-12);
    assert!(
        (replay.likelihoods.angular_speed.unwrap() - (79.0 * r as f64 + 0.1) / (80.0 * r as f64 + 1.1)).abs() < 1e-12
    );

    // The same car at 21 m/s in every rollout: the log's bin holds only smoothing.
    let fast = [Motion::along_x(0.0, 0.0, 21.0)];
    let wrong = score_scenario(&s, window(), &vec![rollout(&s, &fast); r], &config).unwrap();
    let got = wrong.likelihoods.linear_speed.unwrap();
    // The first future step's speed differs (central difference straddles the
    // current step) but it never counts: speed validity drops the first step.
    assert!((got - 0.1 / (80.0 * r as f64 + 1.0)).abs() < 1e-12, "{got}");
    assert!(wrong.meta_metric.unwrap() < replay.meta_metric.unwrap());
    assert!(wrong.buckets.kinematic.unwrap() < replay.buckets.kinematic.unwrap());
}

#[test]
fn every_score_is_a_probability_and_the_meta_metric_is_the_weighted_sum() {
    let motions = [Motion::along_x(0.0, 0.0, 10.0), Motion::along_x(30.0, 0.0, 6.0), Motion::along_x(-10.0, 3.5, 12.0)];
    let s = scene(&motions, road(vec![]));
    let other = [Motion::along_x(0.0, 0.0, 8.0), Motion::along_x(30.0, 0.0, 7.0), Motion::along_x(-10.0, 3.5, 11.0)];
    let rollouts = vec![log_rollout(&s), rollout(&s, &other), log_rollout(&s)];
    let config = RealismConfig::wosac_2025();
    let r = score_scenario(&s, window(), &rollouts, &config).unwrap();
    assert_eq!((r.rollouts, r.distinct_rollouts, r.evaluated_objects), (3, 2, 3));
    let mut weighted = 0.0;
    for f in Feature::ALL {
        let l = r.likelihoods.get(f).unwrap_or_else(|| panic!("{f:?} undefined"));
        assert!((0.0..=1.0).contains(&l), "{f:?} = {l}");
        weighted += config.feature(f).metametric_weight * l;
    }
    assert!((r.meta_metric.unwrap() - weighted).abs() < 1e-12);
    for b in [r.buckets.kinematic, r.buckets.interactive, r.buckets.map_based] {
        assert!((0.0..=1.0).contains(&b.unwrap()));
    }
    let agg = RealismAggregate::mean([&r, &r], &config);
    assert_eq!(agg.scenarios, 2);
    assert!((agg.meta_metric.unwrap() - r.meta_metric.unwrap()).abs() < 1e-12);
}

#[test]
fn overlapping_boxes_are_collisions_and_score_as_derived() {
    // In the log the two cars are 10 m apart in different lanes; in every
    // rollout car 1 drives in car 0's lane, 1 m behind its centre: overlap.
    let motions = [Motion::along_x(0.0, 0.0, 10.0), Motion::along_x(0.0, 3.5, 10.0), Motion::along_x(50.0, 3.5, 10.0)];
    let s = scene(&motions, road(vec![]));
    let crash = [Motion::along_x(0.0, 0.0, 10.0), Motion::along_x(-1.0, 0.0, 10.0), Motion::along_x(50.0, 3.5, 10.0)];
    let r = 5;
    let config = RealismConfig::wosac_2025();
    let result = score_scenario(&s, window(), &vec![rollout(&s, &crash); r], &config).unwrap();
    let (miss, hit) = (0.001 / (r as f64 + 0.002), (r as f64 + 0.001) / (r as f64 + 0.002));
    // Cars 0 and 1 collide in every rollout but not in the log; car 2 agrees.
    let expected = ((2.0 * miss.ln() + hit.ln()) / 3.0).exp();
    assert!((result.likelihoods.collision_indication.unwrap() - expected).abs() < 1e-12);
    assert!((result.simulated_collision_rate - 2.0 / 3.0).abs() < 1e-12);
    // Log replay: no collisions anywhere, the indication likelihood is (R+0.001)/(R+0.002).
    let replay = score_scenario(&s, window(), &vec![log_rollout(&s); r], &config).unwrap();
    assert!((replay.likelihoods.collision_indication.unwrap() - hit).abs() < 1e-12);
    assert_eq!(replay.simulated_collision_rate, 0.0);
}

#[test]
fn time_to_collision_follows_the_leader_only() {
    // Follower at 10 m/s, leader 20 m ahead (centre to centre) at 5 m/s:
    // gap 20 - 2 - 2 = 16 m closing at 5 m/s. A car in the next lane and an
    // oncoming car in the same lane are not followed.
    let motions = [
        Motion::along_x(0.0, 0.0, 10.0),
        Motion::along_x(20.0, 0.0, 5.0),
        Motion::along_x(30.0, 3.5, 0.0),
        Motion { x0: 18.0, y: 0.0, speed_mps: 0.0, heading_rad: std::f64::consts::PI },
    ];
    let s = scene(&motions[..2], road(vec![]));
    let bodies: Vec<_> = (0..4).map(|_| s.tracks[0].body()).collect();
    let ctx = SceneContext::new(&s.map, bodies.clone(), vec![0], 0, 10, 20, 0.1);
    let traj: Vec<Vec<Option<AgentState>>> =
        motions.iter().map(|m| (0..=30).map(|k| Some(m.state(k))).collect()).collect();
    // Without the two distractors.
    let only_pair = SceneContext::new(&s.map, bodies[..2].to_vec(), vec![0], 0, 10, 20, 0.1);
    let f = only_pair.features(&traj[..2]);
    for t in 0..19 {
        let gap = 16.0 - 5.0 * DT * (11 + t) as f64;
        let expected = (gap / 5.0).min(5.0);
        assert!((f.time_to_collision[0][t] - expected).abs() < 1e-9, "step {t}: {}", f.time_to_collision[0][t]);
    }
    // The last step's speed is a NaN (window end): no closing speed, 5 s.
    assert_eq!(f.time_to_collision[0][19], 5.0);
    // The stopped car at x = 18 facing the follower sits in the gap: it is
    // nearer but heads the other way (|Δheading| = π > 75°), so the leader
    // still counts. The next-lane car never counts.
    let g = ctx.features(&traj);
    assert!((g.time_to_collision[0][0] - f.time_to_collision[0][0]).abs() < 1e-9);
    // Distance to the nearest object sees that car though: at step 11 the
    // follower's front is at 11 + 2 = 13, the stopped car's near end at 18 - 2 = 16.
    assert!((g.distance_to_nearest_object[0][0] - 3.0).abs() < 1e-9, "{}", g.distance_to_nearest_object[0][0]);
    assert!((f.distance_to_nearest_object[0][0] - 10.5).abs() < 1e-9);
    // The leader is also not following anyone: 5 s.
    let leader = SceneContext::new(&s.map, bodies[..2].to_vec(), vec![1], 0, 10, 20, 0.1).features(&traj[..2]);
    assert!(leader.time_to_collision[0].iter().all(|t| *t == 5.0));
}

#[test]
fn off_road_and_road_edge_distance_use_the_worst_corner() {
    let motions = [Motion::along_x(0.0, 0.0, 10.0)];
    let s = scene(&motions, road(vec![]));
    let bodies = vec![s.tracks[0].body()];
    let ctx = SceneContext::new(&s.map, bodies, vec![0], 0, 10, 5, 0.1);
    // Centre at y = -1.5: right corners at y = -2.5, half a metre beyond the edge at y = -2.
    let off = [Motion::along_x(0.0, -1.5, 10.0)];
    let traj: Vec<Vec<Option<AgentState>>> = vec![(0..=15).map(|k| Some(off[0].state(k))).collect()];
    let f = ctx.features(&traj);
    let d = f.distance_to_road_edge.as_ref().unwrap();
    assert!((d[0][0] - 0.5).abs() < 1e-9, "{}", d[0][0]);
    assert!(f.offroad.as_ref().unwrap()[0][0]);
    // On the lane centre the worst corner is 1 m inside: -1.
    let on: Vec<Vec<Option<AgentState>>> = vec![(0..=15).map(|k| Some(motions[0].state(k))).collect()];
    let g = ctx.features(&on);
    assert!((g.distance_to_road_edge.as_ref().unwrap()[0][0] + 1.0).abs() < 1e-9);
    assert!(!g.offroad.as_ref().unwrap()[0][0]);
}

#[test]
fn crossing_the_stop_line_on_red_is_a_violation_and_on_green_is_not() {
    // As in WOMD, the signal controls the lane *inside* the junction (lane 3,
    // from x = 50) and its stop point is that lane's start; lane 1 leads in.
    let signal = |state| TrafficSignal {
        lane: MapElementId(3),
        stop_point: Some(Point2::new(50.0, 0.0)),
        states: vec![state; STEPS],
    };
    let map_with = |state| {
        let lanes = vec![
            Lane::new(MapElementId(1), Polyline::new((0..=100).map(|i| Point2::new(-50.0 + i as f64, 0.0)).collect())),
            Lane::new(MapElementId(3), Polyline::new((0..=100).map(|i| Point2::new(50.0 + i as f64, 0.0)).collect())),
        ];
        let edges = vec![
            RoadEdge { id: MapElementId(10), polyline: straight(-2.0, -100.0, 400.0), kind: RoadEdgeKind::Boundary },
            RoadEdge { id: MapElementId(11), polyline: straight(5.5, 400.0, -100.0), kind: RoadEdgeKind::Boundary },
        ];
        RoadMap::new(lanes, edges, vec![], vec![], vec![], vec![], vec![signal(state)])
    };
    // At 10 m/s from x = 38.05 the centre is at 49.05 at step 11 and 50.05 at
    // step 12: it crosses the stop point into future index 1.
    let car = [Motion::along_x(38.05, 0.0, 10.0)];
    for (state, expect) in [(SignalState::Stop, true), (SignalState::Go, false), (SignalState::FlashingStop, false)] {
        let s = scene(&car, map_with(state));
        let ctx = SceneContext::new(&s.map, vec![s.tracks[0].body()], vec![0], 0, 10, 80, 0.1);
        let f = ctx.features(&[s.tracks[0].states.clone()]);
        let hits: Vec<usize> =
            f.traffic_light_violation[0].iter().enumerate().filter(|(_, v)| **v).map(|(t, _)| t).collect();
        if expect {
            assert_eq!(hits, vec![1], "{state:?}");
        } else {
            assert!(hits.is_empty(), "{state:?}: {hits:?}");
        }
    }
    // A rollout that stops before the line scores the log's red-light run as unlikely.
    let s = scene(&car, map_with(SignalState::Stop));
    let stopped = [Motion::along_x(48.05, 0.0, 0.0)];
    let config = RealismConfig::wosac_2025();
    let r = score_scenario(&s, window(), &[rollout(&s, &stopped)], &config).unwrap();
    assert!((r.likelihoods.traffic_light_violation.unwrap() - 0.001 / 1.002).abs() < 1e-12);
    assert_eq!(r.simulated_traffic_light_violation_rate, 0.0);
}

#[test]
fn window_rule() {
    let motions = [Motion::along_x(0.0, 0.0, 10.0)];
    let mut s = scene(&motions, road(vec![]));
    assert_eq!(RealismWindow::for_scenario(&s, 80), Some(window()));
    s.current_step = 0;
    assert_eq!(RealismWindow::for_scenario(&s, 80), Some(window()), "no history: current step 10");
    s.current_step = 49;
    assert_eq!(RealismWindow::for_scenario(&s, 80).map(|w| w.start_step), Some(10), "not enough future");
    for t in &mut s.tracks {
        t.states.truncate(90);
    }
    assert_eq!(RealismWindow::for_scenario(&s, 80), None, "90 steps cannot hold 1 s + 8 s");
}

#[test]
fn bad_rollouts_are_errors_not_panics() {
    let motions = [Motion::along_x(0.0, 0.0, 10.0)];
    let s = scene(&motions, road(vec![]));
    let config = RealismConfig::wosac_2025();
    assert!(matches!(score_scenario(&s, window(), &[], &config), Err(RealismError::NoRollouts(_))));
    let mut short = log_rollout(&s);
    short.pop();
    assert!(matches!(score_scenario(&s, window(), &[short], &config), Err(RealismError::RolloutShape { .. })));
    let mut wide = log_rollout(&s);
    wide[3].push(None);
    assert!(matches!(score_scenario(&s, window(), &[wide], &config), Err(RealismError::RolloutShape { .. })));
    let late = RealismWindow { start_step: 20, future_steps: 80 };
    assert!(matches!(score_scenario(&s, late, &[log_rollout(&s)], &config), Err(RealismError::WindowOutside { .. })));
}

#[test]
fn a_map_without_road_edges_leaves_the_map_features_undefined() {
    let motions = [Motion::along_x(0.0, 0.0, 10.0)];
    let s = scene(&motions, RoadMap::default());
    let config = RealismConfig::wosac_2025();
    let r = score_scenario(&s, window(), &[log_rollout(&s)], &config).unwrap();
    assert_eq!(r.likelihoods.distance_to_road_edge, None);
    assert_eq!(r.buckets.map_based, None);
    assert_eq!(r.meta_metric, None);
    assert!(r.buckets.kinematic.is_some());
}
