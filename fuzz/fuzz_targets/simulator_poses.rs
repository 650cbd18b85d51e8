//! Fuzz target: arbitrary finite and non-finite poses, speeds and map
//! points fed through `Simulation::run` on a small straight-road scene. The
//! recorded states of every agent, the background policies (log replay,
//! constant velocity, IDM with arbitrary parameters, or a policy answering
//! arbitrary states and controls) and the planner's outputs (controls,
//! trajectories, errors, or a built-in planner) all come from the input.
//! Scenes are either recorded-like (fuzzed tracks) or authored (fuzzed
//! initial states and behaviours, synthesised as a spec would be, so a
//! spec-level NaN or 1e300 is covered too). Every input must end — `Simulation::new` refusing the scene, or a
//! rollout with some termination — without a panic and without a hang (run
//! with `-timeout=10`: a value that once made a map query walk 1e19 empty
//! grid cells would time out here).

#![no_main]

use libfuzzer_sys::arbitrary::Unstructured;
use libfuzzer_sys::fuzz_target;
use safer_scenarios::geometry::{Point2, Polyline, Vector2};
use safer_scenarios::map::{Lane, MapElementId, RoadEdge, RoadEdgeKind, RoadMap};
use safer_scenarios::motion::Action;
use safer_scenarios::planners::{BuiltinPlanner, IdmPlanner, Observation, Planner, PlannerError, PlannerOutput, TrajectoryPoint};
use safer_scenarios::policies::noisy_idm::DriverNoise;
use safer_scenarios::policies::{AgentAction, AgentPolicy, BackgroundPolicy, IdmLaneFollower, IdmParams, WorldView};
use safer_scenarios::scenario::{AgentBody, AgentId, AgentKind, AgentState, Scenario, ScenarioSource, Track, TrackIndex};
use safer_scenarios::sim::authoring::{AuthoredAgent, AuthoredBehaviour, AuthoredScenario, synthesize};
use safer_scenarios::sim::{SimConfig, Simulation};

/// Steps of every track (3 s at 0.1 s): long enough for several planner
/// calls, short enough for thousands of runs a second.
const STEPS: usize = 31;

/// The values that once hung or panicked, and their neighbours.
const SPECIAL: [f64; 24] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    12.0,
    150.0,
    1e3,
    1.000_001e3,
    1e7,
    1.000_000_1e7,
    1e8,
    1e12,
    9.2e18,
    -9.3e18,
    1e20,
    -1e20,
    1e100,
    1e300,
    f64::MAX,
    f64::MIN,
    f64::MIN_POSITIVE,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NAN,
];

/// A value: mostly a special one or one at map scale, sometimes any bit pattern.
fn value(u: &mut Unstructured) -> f64 {
    match u.int_in_range(0..=3u8).unwrap_or(3) {
        0 => SPECIAL[u.choose_index(SPECIAL.len()).unwrap_or(0)],
        1 => f64::from_bits(u.arbitrary::<u64>().unwrap_or(0)),
        _ => f64::from(u.arbitrary::<i16>().unwrap_or(0)) * 0.25,
    }
}

/// A map-scale value, or an arbitrary one when the input says so.
fn maybe(u: &mut Unstructured, plausible: f64) -> f64 {
    if u.ratio(1u8, 4u8).unwrap_or(false) { value(u) } else { plausible }
}

fn state(u: &mut Unstructured, x: f64, y: f64, speed: f64) -> AgentState {
    AgentState {
        position: Point2::new(maybe(u, x), maybe(u, y)),
        heading_rad: maybe(u, 0.0),
        velocity_mps: Vector2::new(maybe(u, speed), maybe(u, 0.0)),
    }
}

/// Answers from a fixed list of fuzzed values, cycling.
struct Values {
    values: Vec<f64>,
    next: usize,
}

impl Values {
    fn take(&mut self) -> f64 {
        if self.values.is_empty() {
            return 0.0;
        }
        let v = self.values[self.next % self.values.len()];
        self.next += 1;
        v
    }

    fn state(&mut self) -> AgentState {
        AgentState {
            position: Point2::new(self.take(), self.take()),
            heading_rad: self.take(),
            velocity_mps: Vector2::new(self.take(), self.take()),
        }
    }
}

/// A background policy answering fuzzed states and controls.
struct FuzzPolicy(Values);

impl AgentPolicy for FuzzPolicy {
    fn name(&self) -> &'static str {
        "fuzz"
    }
    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
        match self.0.take().to_bits() % 3 {
            0 => AgentAction::Teleport(self.0.state()),
            1 => AgentAction::Control(Action { accel_mps2: self.0.take(), yaw_rate_radps: self.0.take() }),
            _ => match world.state(agent) {
                Some(s) => AgentAction::Teleport(*s),
                None => AgentAction::Absent,
            },
        }
    }
}

/// A planner answering fuzzed controls, trajectories and errors.
struct FuzzPlanner(Values);

impl Planner for FuzzPlanner {
    fn name(&self) -> &str {
        "fuzz"
    }
    fn plan(&mut self, _: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        match self.0.take().to_bits() % 4 {
            0 => Ok(PlannerOutput::Control(Action { accel_mps2: self.0.take(), yaw_rate_radps: self.0.take() })),
            1 | 2 => {
                let n = (self.0.take().to_bits() % 5) as usize;
                let points = (0..n).map(|_| TrajectoryPoint { time_s: self.0.take(), state: self.0.state() }).collect();
                Ok(PlannerOutput::Trajectory(points))
            }
            _ => Err(PlannerError::InvalidOutput("fuzzed failure".into())),
        }
    }
}

fn idm_params(u: &mut Unstructured) -> IdmParams {
    let d = IdmParams::default();
    IdmParams {
        desired_speed_mps: if u.ratio(1u8, 2u8).unwrap_or(false) { Some(value(u)) } else { d.desired_speed_mps },
        fallback_speed_mps: maybe(u, d.fallback_speed_mps),
        max_accel_mps2: maybe(u, d.max_accel_mps2),
        comfort_decel_mps2: maybe(u, d.comfort_decel_mps2),
        max_decel_mps2: maybe(u, d.max_decel_mps2),
        time_headway_s: maybe(u, d.time_headway_s),
        min_gap_m: maybe(u, d.min_gap_m),
        exponent: maybe(u, d.exponent),
        lookahead_time_s: maybe(u, d.lookahead_time_s),
        min_lookahead_m: maybe(u, d.min_lookahead_m),
        sensing_range_m: maybe(u, d.sensing_range_m),
    }
}

fn values(u: &mut Unstructured) -> Values {
    let n = u.int_in_range(0..=32u8).unwrap_or(0);
    Values { values: (0..n).map(|_| value(u)).collect(), next: 0 }
}

/// A 300 m straight two-edge road, one of whose points may be fuzzed.
fn road(u: &mut Unstructured) -> RoadMap {
    let line = |y: f64, x0: f64, x1: f64| vec![Point2::new(x0, y), Point2::new(x1, y)];
    let mut lines = [line(0.0, -50.0, 300.0), line(-2.0, -50.0, 300.0), line(2.0, 300.0, -50.0)];
    if u.ratio(1u8, 4u8).unwrap_or(false) {
        let which = u.choose_index(lines.len()).unwrap_or(0);
        let end = usize::from(u.arbitrary::<bool>().unwrap_or(false));
        lines[which][end] = Point2::new(value(u), value(u));
    }
    let [centre, right, left] = lines;
    let lane = Lane::new(MapElementId(1), Polyline::new(centre));
    let edges = vec![
        RoadEdge::new(MapElementId(2), Polyline::new(right), RoadEdgeKind::Boundary),
        RoadEdge::new(MapElementId(3), Polyline::new(left), RoadEdgeKind::Boundary),
    ];
    RoadMap::new(vec![lane], edges, vec![], vec![], vec![], vec![], vec![])
}

fn track(u: &mut Unstructured, id: &str, x0: f64, speed: f64) -> Track {
    Track {
        id: AgentId(id.into()),
        kind: AgentKind::Vehicle,
        length_m: 4.5,
        width_m: 2.0,
        states: (0..STEPS).map(|k| Some(state(u, x0 + speed * 0.1 * k as f64, 0.0, speed))).collect(),
    }
}

/// An authored scene: fuzzed initial states and behaviours, synthesised.
fn authored(u: &mut Unstructured, map: RoadMap, others: usize) -> Scenario {
    let agents = (0..=others)
        .map(|i| {
            let behaviour = match u.int_in_range(0..=3u8).unwrap_or(0) {
                0 => AuthoredBehaviour::ConstantVelocity,
                1 => AuthoredBehaviour::Idm(idm_params(u)),
                2 => AuthoredBehaviour::NoisyIdm(
                    idm_params(u),
                    DriverNoise {
                        accel_std_mps2: maybe(u, 0.3),
                        correlation_time_s: maybe(u, 2.0),
                        seed: u.arbitrary().unwrap_or(0),
                    },
                ),
                _ => AuthoredBehaviour::Parked,
            };
            AuthoredAgent {
                id: AgentId(format!("agent-{i}")),
                body: AgentBody { kind: AgentKind::Vehicle, length_m: maybe(u, 4.5), width_m: maybe(u, 2.0) },
                initial: state(u, 25.0 * i as f64, 0.0, 10.0),
                behaviour,
            }
        })
        .collect();
    let scene = AuthoredScenario {
        id: "fuzz".into(),
        path: "fuzz.yaml".into(),
        map,
        agents,
        ego: 0,
        cbv: (others > 0).then_some(1),
        duration_s: 3.0,
    };
    synthesize(&scene)
}

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let map = road(&mut u);
    let others = u.int_in_range(0..=3usize).unwrap_or(0);
    let scenario = if u.ratio(1u8, 3u8).unwrap_or(false) {
        authored(&mut u, map, others)
    } else {
        let mut tracks = vec![track(&mut u, "ego", 0.0, 12.0)];
        for i in 0..others {
            tracks.push(track(&mut u, &format!("agent-{i}"), 20.0 + 25.0 * i as f64, 8.0));
        }
        Scenario::new("fuzz", ScenarioSource::authored("fuzz"), 0.1, map, tracks)
            .with_roles(TrackIndex(0), (others > 0).then_some(TrackIndex(1)))
    };
    let background = match u.int_in_range(0..=2u8).unwrap_or(0) {
        0 => BackgroundPolicy::LogReplay,
        1 => BackgroundPolicy::ConstantVelocity,
        _ => BackgroundPolicy::Idm,
    };
    let config = SimConfig { start_step: Some(0), background, stop_on_ego_collision: false, ..SimConfig::default() };
    let Ok(mut sim) = Simulation::new(&scenario, config) else {
        return;
    };
    for i in 1..=others {
        match u.int_in_range(0..=2u8).unwrap_or(0) {
            0 => {}
            1 => sim.set_policy(TrackIndex(i), Box::new(IdmLaneFollower::new(idm_params(&mut u)))),
            _ => sim.set_policy(TrackIndex(i), Box::new(FuzzPolicy(values(&mut u)))),
        }
    }
    let mut planner: Box<dyn Planner> = match u.int_in_range(0..=5u8).unwrap_or(0) {
        0 => BuiltinPlanner::LogReplay.instantiate(&scenario, TrackIndex(0)),
        1 => BuiltinPlanner::ConstantVelocity.instantiate(&scenario, TrackIndex(0)),
        2 => BuiltinPlanner::Idm.instantiate(&scenario, TrackIndex(0)),
        3 => BuiltinPlanner::Evasive.instantiate(&scenario, TrackIndex(0)),
        4 => Box::new(IdmPlanner::new(idm_params(&mut u))),
        _ => Box::new(FuzzPlanner(values(&mut u))),
    };
    let rollout = sim.run(planner.as_mut());
    // Everything a report computes from the rollout must be total as well.
    let _ = rollout.summary();
    assert!(!rollout.states.is_empty(), "a rollout records at least its start");
});
