//! Fuzz target: one line as an external planner would answer an
//! observation, through `safer_scenarios::planners::external::decode_reply` (strict
//! JSON parsing, non-finite numbers, message kinds, trajectory checks) and,
//! when it decodes, through `Simulation::run` with a planner that gives
//! that output at every step. The line is either the raw input bytes or a
//! `control` / `trajectory` / `error` message whose numbers are arbitrary
//! JSON number texts (huge exponents, long digit strings, `1e400`, `-0`,
//! `NaN`). Any input must give an error or a rollout, never a panic, and
//! every number of a decoded output must be finite. The rollout runs with
//! the default vehicle limits, as suites run it: every step it kept must
//! pass the limits (checked again here, independently of where the
//! simulator checks), and one it stopped at must name a limit and a value.

#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::arbitrary::Unstructured;
use libfuzzer_sys::fuzz_target;
use safer_scenarios::geometry::{Point2, Vector2};
use safer_scenarios::map::templates::StraightRoad;
use safer_scenarios::planners::external::decode_reply;
use safer_scenarios::planners::{Observation, Planner, PlannerError, PlannerOutput};
use safer_scenarios::scenario::{AgentId, AgentKind, AgentState, Scenario, ScenarioSource, Track, TrackIndex};
use safer_scenarios::sim::{LimitMonitor, SimConfig, Simulation, Termination, VehicleLimits};

/// The simulator's step, s (what `hello` announces).
const DT_S: f64 = 0.1;
/// Steps of the scene: enough to apply the output a few times.
const STEPS: usize = 6;

/// Number texts that once broke parsers, and their neighbours.
const SPECIAL: [&str; 22] = [
    "0",
    "-0",
    "1",
    "-1.5",
    "0.1",
    "1e100",
    "-1e100",
    "1e20",
    "1e308",
    "1.7976931348623157e308",
    "1.8e308",
    "1e400",
    "-1e400",
    "1e-400",
    "4.9e-324",
    "123456789012345678901234567890",
    "NaN",
    "Infinity",
    "-Infinity",
    "null",
    "\"1\"",
    "1e",
];

/// A JSON number text (or something in its place).
fn number(u: &mut Unstructured) -> String {
    match u.int_in_range(0..=3u8).unwrap_or(0) {
        0 => SPECIAL[u.choose_index(SPECIAL.len()).unwrap_or(0)].to_string(),
        1 => {
            let mantissa = u.arbitrary::<i64>().unwrap_or(0);
            let exponent = u.arbitrary::<i16>().unwrap_or(0);
            format!("{mantissa}e{exponent}")
        }
        2 => format!("{:?}", f64::from_bits(u.arbitrary::<u64>().unwrap_or(0))),
        _ => format!("{}", f64::from(u.arbitrary::<i16>().unwrap_or(0)) * 0.05),
    }
}

/// A reply built from the input: mostly well-formed messages with fuzzed numbers.
fn structured(u: &mut Unstructured) -> String {
    match u.int_in_range(0..=3u8).unwrap_or(0) {
        0 => format!(r#"{{"type":"control","accel_mps2":{},"yaw_rate_radps":{}}}"#, number(u), number(u)),
        1 | 2 => {
            let n = u.int_in_range(0..=6usize).unwrap_or(0);
            let points: Vec<String> = (0..n)
                .map(|_| {
                    format!(
                        r#"{{"t":{},"x":{},"y":{},"heading_rad":{},"speed_mps":{}}}"#,
                        number(u),
                        number(u),
                        number(u),
                        number(u),
                        number(u)
                    )
                })
                .collect();
            format!(r#"{{"type":"trajectory","points":[{}]}}"#, points.join(","))
        }
        _ => format!(r#"{{"type":"error","message":"{}"}}"#, number(u).replace('"', "'")),
    }
}

/// A 200 m straight road with the ego at x = 10 doing 10 m/s.
fn scene() -> &'static Scenario {
    static SCENE: OnceLock<Scenario> = OnceLock::new();
    SCENE.get_or_init(|| {
        let map =
            StraightRoad { lanes: 1, oncoming_lanes: 0, lane_width_m: 3.5, length_m: 200.0, speed_limit_mps: None }
                .build();
        let ego = Track {
            id: AgentId("ego".into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            states: (0..STEPS)
                .map(|k| {
                    Some(AgentState {
                        position: Point2::new(10.0 + k as f64, 1.75),
                        heading_rad: 0.0,
                        velocity_mps: Vector2::new(10.0, 0.0),
                    })
                })
                .collect(),
        };
        Scenario::new("fuzz-replies", ScenarioSource::authored("fuzz"), DT_S, map, vec![ego])
            .with_roles(TrackIndex(0), None)
    })
}

/// Answers every observation with the decoded reply.
struct Replay(PlannerOutput);

impl Planner for Replay {
    fn name(&self) -> &str {
        "replay"
    }
    fn plan(&mut self, _: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        Ok(self.0.clone())
    }
}

fuzz_target!(|data: &[u8]| {
    let line = match data.split_first() {
        Some((&mode, rest)) if mode % 2 == 0 => structured(&mut Unstructured::new(rest)).into_bytes(),
        Some((_, rest)) => rest.to_vec(),
        None => Vec::new(),
    };
    let Ok(output) = decode_reply(&line, DT_S) else {
        return;
    };
    match &output {
        PlannerOutput::Control(a) => {
            assert!(a.accel_mps2.is_finite() && a.yaw_rate_radps.is_finite(), "{a:?}");
        }
        PlannerOutput::Trajectory(points) => {
            assert!(!points.is_empty());
            for p in points {
                let s = &p.state;
                let values = [p.time_s, s.position.x, s.position.y, s.heading_rad, s.velocity_mps.x, s.velocity_mps.y];
                assert!(values.iter().all(|v| v.is_finite()), "{p:?}");
            }
        }
        other => panic!("a reply decodes to a control or a trajectory, not {other:?}"),
    }
    let limits = VehicleLimits::default();
    let config = SimConfig { start_step: Some(0), ego_limits: Some(limits), ..SimConfig::default() };
    let Ok(sim) = Simulation::new(scene(), config) else {
        return;
    };
    let rollout = sim.run(&mut Replay(output));
    let _ = rollout.summary();
    assert!(!rollout.states.is_empty(), "a rollout records at least its start");
    // Every step the rollout kept is within the limits, the sideways
    // drift summed over the steps included.
    let ego = rollout.ego.0;
    let mut monitor = LimitMonitor::new(limits);
    for (k, pair) in rollout.states.windows(2).enumerate() {
        if let (Some(now), Some(next)) = (&pair[0][ego], &pair[1][ego]) {
            assert!(monitor.step(now, next, DT_S).is_none(), "step {k} kept beyond the limits: {now:?} -> {next:?}");
        }
    }
    match &rollout.termination {
        Termination::VehicleLimitExceeded { reason, .. } => {
            assert!(reason.contains("max_") || reason.contains("limit"), "{reason}");
            assert!(!reason.contains(" { ") && reason.len() < 400, "a reason in words: {reason}");
        }
        Termination::PlannerFailed { reason, .. } | Termination::InvalidAgentState { reason, .. } => {
            assert!(!reason.contains(" { ") && !reason.contains("Some("), "a reason in words: {reason}");
        }
        _ => {}
    }
});
