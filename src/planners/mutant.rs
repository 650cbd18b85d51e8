//! Planted faults for mutation testing: a planner wrapped so that it drives
//! like a broken copy of itself. Each [`FaultOperator`] acts only at the
//! boundary between the planner and the simulator (what the planner sees,
//! what its answer does), so it works alike on built-ins, in-process Rust
//! planners and external processes of any protocol version, and the
//! planner's own code is never touched.
//!
//! A mutant is a bad driver, not an impossible one: every answer an
//! operator changes is a control kept inside the suite's vehicle limits
//! ([`clamp_to_limits`]). An answer the operator leaves as it is goes to the
//! simulator unchanged (a trajectory stays a trajectory), so a mutant
//! differs from its planner only where its fault acts.

use std::collections::VecDeque;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::external::RolloutContext;
use super::route::Route as StableRoute;
use super::{Observation, PerceivedAgent, Planner, PlannerError, PlannerOutput, PlannerStartup};
use crate::geometry::{Point2, wrap_angle};
use crate::map::{MapElementId, SignalState};
use crate::motion::{Action, KinematicState, VehicleLimits, kinematic_step};
use crate::policies::lane_follower::pursuit_curvature;
use crate::scenario::{AgentId, AgentState};

/// Braking that `weak-brake` allows at most, m/s² (positive).
pub const WEAK_BRAKE_MPS2: f64 = 2.0;
/// How late `late` shows the planner the world, s.
pub const LATE_S: f64 = 0.5;
/// Half the cone ahead that `blind-side` still sees, rad (30°).
pub const BLIND_SIDE_HALF_CONE_RAD: f64 = std::f64::consts::PI / 6.0;
/// How far above the planner's own speed target `speeding` drives (1.2: 20 %).
pub const SPEEDING_FACTOR: f64 = 1.2;
/// `no-evade`'s pure-pursuit look-ahead per m/s of speed, s.
const NO_EVADE_LOOKAHEAD_S: f64 = 1.0;
/// `no-evade`'s shortest look-ahead, m.
const NO_EVADE_MIN_LOOKAHEAD_M: f64 = 6.0;

/// A fault planted between a planner and the simulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
#[non_exhaustive]
pub enum FaultOperator {
    /// Acceleration clipped at 0: the ego never brakes.
    NoBrake,
    /// Braking capped at 2 m/s².
    WeakBrake,
    /// The planner sees the other road users and the signals 0.5 s late;
    /// its own pose is current.
    Late,
    /// The CBV is removed from every observation.
    BlindCbv,
    /// Road users outside a ±30° cone ahead of the ego are removed from
    /// every observation.
    BlindSide,
    /// The planner's yaw rate is replaced by plain lane keeping on its route.
    NoEvade,
    /// The planner's speed reads 20 % low, so it drives 20 % above the
    /// speed it aims for.
    Speeding,
}

impl FaultOperator {
    /// Every operator, in the order reports list them.
    pub const ALL: &'static [Self] =
        &[Self::NoBrake, Self::WeakBrake, Self::Late, Self::BlindCbv, Self::BlindSide, Self::NoEvade, Self::Speeding];

    /// Its name in specs, flags and reports (`no-brake`).
    pub fn name(self) -> &'static str {
        match self {
            Self::NoBrake => "no-brake",
            Self::WeakBrake => "weak-brake",
            Self::Late => "late",
            Self::BlindCbv => "blind-cbv",
            Self::BlindSide => "blind-side",
            Self::NoEvade => "no-evade",
            Self::Speeding => "speeding",
        }
    }

    /// What the fault does, in one sentence.
    pub fn describe(self) -> &'static str {
        match self {
            Self::NoBrake => "the planner's acceleration is clipped at 0, so the ego never brakes",
            Self::WeakBrake => "the planner's braking is capped at 2 m/s²",
            Self::Late => {
                "the planner sees the other road users and the signals 0.5 s late (its own pose is current), so it reacts 0.5 s late"
            }
            Self::BlindCbv => "the CBV is removed from every observation the planner gets",
            Self::BlindSide => "road users outside a ±30° cone ahead of the ego are removed from every observation",
            Self::NoEvade => {
                "the planner's yaw rate is replaced by plain lane keeping on its route, so it cannot swerve"
            }
            Self::Speeding => {
                "the planner's speed reads 20 % low, so it drives its path 20 % above the speed it aims for"
            }
        }
    }

    /// Whether the fault changes the planner's steering and nothing else
    /// (`no-evade`): where the mutant kept to the planner's path, it has
    /// not come into play, however its lane keeping differs.
    pub fn changes_only_the_steering(self) -> bool {
        matches!(self, Self::NoEvade)
    }

    /// What kind of scene would catch the fault, for a suite it survives.
    pub fn blind_spot_hint(self) -> &'static str {
        match self {
            Self::NoBrake => {
                "add a scene where the ego must brake: a leader braking hard ahead, or a cut-in close in front, with nothing to steer into"
            }
            Self::WeakBrake => {
                "add a scene that needs hard braking (4 m/s² or more): a sudden stop ahead, or a cut-in with a short gap"
            }
            Self::Late => {
                "add a scene where a road user acts suddenly and close: a cut-in or a hard brake inside 2 s of the ego, where half a second of reaction matters"
            }
            Self::BlindCbv => {
                "add a scene where the CBV itself is the hazard the ego must answer (a cut-in, a merge, a braking leader), not the background"
            }
            Self::BlindSide => {
                "add a scene where the threat comes from the side: a merge, a crossing at a junction, a car entering from an adjacent lane"
            }
            Self::NoEvade => "add a scene where braking alone is not enough and the ego must steer around an obstacle",
            Self::Speeding => {
                "add a scene with a tight speed budget: a curve, a queue ahead or a crossing where 20 % more speed turns a near miss into a collision"
            }
        }
    }

    /// Parses a comma-separated list of names (`no-brake,late`); `all`
    /// stands for every operator.
    pub fn parse_list(text: &str) -> Result<Vec<Self>, String> {
        let mut out: Vec<Self> = Vec::new();
        for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            if part == "all" {
                out.extend(Self::ALL);
                continue;
            }
            let op = Self::ALL.iter().copied().find(|o| o.name() == part).ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|o| o.name()).collect();
                format!("unknown fault operator `{part}` (known: {}, or all)", names.join(", "))
            })?;
            out.push(op);
        }
        if out.is_empty() {
            return Err("no fault operator named".into());
        }
        out.sort();
        out.dedup();
        Ok(out)
    }
}

impl std::fmt::Display for FaultOperator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `action` from `now` held inside `limits`: the acceleration and the yaw
/// rate clamped to their bounds (the speed kept in range, the curvature
/// at the new speed too), then the yaw rate shrunk until the step passes
/// every check the simulator makes (the heading change must agree with the
/// velocities it reports).
pub fn clamp_to_limits(limits: &VehicleLimits, now: &AgentState, action: Action, dt_s: f64) -> Action {
    // A hair inside every bound: the simulator measures from positions and
    // headings, whose rounding must not tip a step over.
    const INSIDE: f64 = 1.0 - 1e-9;
    let speed = KinematicState::from_agent_state(now).speed_mps;
    let top = (limits.max_speed_mps * INSIDE - speed) / dt_s;
    let accel = action
        .accel_mps2
        .clamp(-limits.max_decel_mps2 * INSIDE, limits.max_accel_mps2 * INSIDE)
        .min(top.max(-limits.max_decel_mps2 * INSIDE));
    let next_speed = (speed + accel * dt_s).max(0.0);
    let yaw_max = (limits.max_yaw_rate_radps * INSIDE).min(limits.max_curvature_per_m * INSIDE * next_speed);
    let clamped = Action { accel_mps2: accel, yaw_rate_radps: action.yaw_rate_radps.clamp(-yaw_max, yaw_max) };
    let with_yaw_share = |share: f64| Action { yaw_rate_radps: clamped.yaw_rate_radps * share, ..clamped };
    let inside = |a: Action| {
        let next = kinematic_step(&KinematicState::from_agent_state(now), a, dt_s).to_agent_state();
        limits.check(now, &next, dt_s).is_none()
    };
    if inside(clamped) || !inside(with_yaw_share(0.0)) {
        // Inside already; or outside whatever the yaw rate, from a state the
        // planner itself brought about.
        return clamped;
    }
    let (mut ok, mut bad) = (0.0, 1.0);
    for _ in 0..40 {
        let mid = 0.5 * (ok + bad);
        if inside(with_yaw_share(mid)) {
            ok = mid;
        } else {
            bad = mid;
        }
    }
    with_yaw_share(ok)
}

/// What the planner saw at one step, kept for `late`.
type Seen = (Vec<PerceivedAgent>, Vec<(MapElementId, SignalState)>);

/// A planner with a fault planted at its boundary.
pub struct MutantPlanner {
    inner: Box<dyn Planner>,
    operator: FaultOperator,
    limits: VehicleLimits,
    name: String,
    /// The CBV's id (`blind-cbv`).
    cbv: Option<AgentId>,
    /// The recorded ego's path from the start (`no-evade`'s route at forks).
    recorded: Vec<Point2>,
    /// `no-evade`'s route: the one external planners are sent.
    route: StableRoute,
    /// What the world looked like over the last 0.5 s, oldest first (`late`).
    history: VecDeque<Seen>,
}

impl MutantPlanner {
    /// `inner` with `operator` planted, for the rollout of `context`, its
    /// changed controls held inside `bounds`.
    pub fn new(
        inner: Box<dyn Planner>,
        operator: FaultOperator,
        limits: VehicleLimits,
        context: &RolloutContext,
    ) -> Self {
        let scenario = &context.scenario;
        Self {
            name: format!("{} [{operator}]", inner.name()),
            cbv: scenario.cbv.and_then(|c| scenario.tracks.get(c.0)).map(|t| t.id.clone()),
            recorded: context.recorded_path(),
            route: StableRoute::default(),
            history: VecDeque::new(),
            inner,
            operator,
            limits,
        }
    }

    /// The fault.
    pub fn operator(&self) -> FaultOperator {
        self.operator
    }

    /// The observation the planner is shown instead of `observation`.
    fn seen<'a>(&mut self, observation: &Observation<'a>) -> Observation<'a> {
        let mut seen = observation.clone();
        match self.operator {
            FaultOperator::Late => {
                let delay = (LATE_S / observation.dt_s).round().max(1.0) as usize;
                self.history.push_back((observation.agents.clone(), observation.signals.clone()));
                while self.history.len() > delay + 1 {
                    self.history.pop_front();
                }
                // Before 0.5 s has passed, the first observation stands in
                // for the older ones it lacks.
                if let Some((agents, signals)) = self.history.front() {
                    seen.agents.clone_from(agents);
                    seen.signals.clone_from(signals);
                }
            }
            FaultOperator::BlindCbv => seen.agents.retain(|a| Some(&a.id) != self.cbv.as_ref()),
            FaultOperator::BlindSide => {
                let ego = observation.ego;
                seen.agents.retain(|a| {
                    let d = a.state.position - ego.position;
                    d.norm() < 1e-9 || wrap_angle(d.y.atan2(d.x) - ego.heading_rad).abs() <= BLIND_SIDE_HALF_CONE_RAD
                });
            }
            FaultOperator::Speeding => seen.ego.velocity_mps /= SPEEDING_FACTOR,
            FaultOperator::NoBrake | FaultOperator::WeakBrake | FaultOperator::NoEvade => {}
        }
        seen
    }

    /// The control `out` stands for, from the state the planner saw: a
    /// control itself; for a trajectory, its acceleration along the heading
    /// and its yaw rate over one step.
    fn implied_action(seen: &AgentState, out: &PlannerOutput, dt_s: f64) -> Option<Action> {
        if let PlannerOutput::Control(a) = out {
            return (a.accel_mps2.is_finite() && a.yaw_rate_radps.is_finite()).then_some(*a);
        }
        let next = out.next_state(seen, dt_s).ok()?;
        let v0 = KinematicState::from_agent_state(seen).speed_mps;
        let v1 = KinematicState::from_agent_state(&next).speed_mps;
        Some(Action {
            accel_mps2: (v1 - v0) / dt_s,
            yaw_rate_radps: wrap_angle(next.heading_rad - seen.heading_rad) / dt_s,
        })
    }

    /// The answer the simulator gets: `out` itself where the fault leaves
    /// it, else the faulty control inside the bounds.
    fn mutate(&mut self, observation: &Observation<'_>, seen: &AgentState, out: PlannerOutput) -> PlannerOutput {
        let dt = observation.dt_s;
        // An answer that cannot be applied goes through as it is: the
        // simulator reports it as the planner's own failure.
        let Some(asked) = Self::implied_action(seen, &out, dt) else { return out };
        let speed = KinematicState::from_agent_state(&observation.ego).speed_mps;
        let faulty = match self.operator {
            FaultOperator::NoBrake if asked.accel_mps2 < 0.0 => Action { accel_mps2: 0.0, ..asked },
            FaultOperator::WeakBrake if asked.accel_mps2 < -WEAK_BRAKE_MPS2 => {
                Action { accel_mps2: -WEAK_BRAKE_MPS2, ..asked }
            }
            FaultOperator::Speeding => {
                // The path stays the planner's: the yaw rate grows with the
                // speed, so the curvature is what it asked for.
                let aimed = (KinematicState::from_agent_state(seen).speed_mps + asked.accel_mps2 * dt).max(0.0);
                let accel_mps2 = (aimed * SPEEDING_FACTOR - speed) / dt;
                let driven = (speed + accel_mps2 * dt).max(0.0);
                let yaw_rate_radps =
                    if aimed > 1e-6 { asked.yaw_rate_radps * driven / aimed } else { asked.yaw_rate_radps };
                Action { accel_mps2, yaw_rate_radps }
            }
            FaultOperator::NoEvade => match self.lane_keeping_yaw_rate(observation) {
                Some(yaw_rate_radps) => Action { yaw_rate_radps, ..asked },
                None => return out,
            },
            _ => return out,
        };
        PlannerOutput::Control(clamp_to_limits(&self.limits, &observation.ego, faulty, dt))
    }

    /// Pure pursuit along the route external planners are sent; `None`
    /// off the lanes (no route).
    fn lane_keeping_yaw_rate(&mut self, observation: &Observation<'_>) -> Option<f64> {
        let ego = observation.ego;
        let s = self.route.update(observation.map, &ego, &self.recorded);
        let line = self.route.line();
        if line.len() < 2 {
            return None;
        }
        let speed = KinematicState::from_agent_state(&ego).speed_mps;
        let lookahead = (NO_EVADE_LOOKAHEAD_S * speed).max(NO_EVADE_MIN_LOOKAHEAD_M);
        Some(pursuit_curvature(line, s + lookahead, &ego)? * speed)
    }
}

impl Planner for MutantPlanner {
    fn name(&self) -> &str {
        &self.name
    }

    fn plan(&mut self, observation: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        let seen = self.seen(observation);
        let out = self.inner.plan(&seen)?;
        Ok(self.mutate(observation, &seen.ego, out))
    }

    fn end_rollout(&mut self) -> Option<String> {
        self.inner.end_rollout()
    }

    fn take_debug(&mut self) -> Option<serde_json::Value> {
        self.inner.take_debug()
    }

    fn startup(&self) -> Option<PlannerStartup> {
        self.inner.startup()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_all_expands() {
        for op in FaultOperator::ALL {
            assert_eq!(FaultOperator::parse_list(op.name()).unwrap(), vec![*op]);
            let json = serde_json::to_string(op).unwrap();
            assert_eq!(json, format!("\"{}\"", op.name()));
        }
        assert_eq!(FaultOperator::parse_list("all").unwrap(), FaultOperator::ALL);
        assert_eq!(
            FaultOperator::parse_list("late, no-brake,late").unwrap(),
            vec![FaultOperator::NoBrake, FaultOperator::Late]
        );
        let err = FaultOperator::parse_list("no-brakes").unwrap_err();
        assert!(err.contains("`no-brakes`") && err.contains("weak-brake"), "{err}");
        assert!(FaultOperator::parse_list(" , ").is_err());
    }

    use crate::geometry::Vector2;
    use crate::map::{Lane, RoadMap};
    use crate::scenario::{AgentKind, Scenario, ScenarioSource, Track, TrackIndex};
    use std::sync::{Arc, Mutex};

    /// What a planner was shown at each step: the ego, the others' ids and
    /// their x positions.
    type Shown = Arc<Mutex<Vec<(AgentState, Vec<AgentId>, Vec<f64>)>>>;

    /// Answers `answer`, and keeps what it was shown.
    struct Recording {
        answer: PlannerOutput,
        seen: Shown,
    }

    impl Planner for Recording {
        fn name(&self) -> &str {
            "recording"
        }
        fn plan(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
            let ids = obs.agents.iter().map(|a| a.id.clone()).collect();
            let xs = obs.agents.iter().map(|a| a.state.position.x).collect();
            self.seen.lock().unwrap().push((obs.ego, ids, xs));
            Ok(self.answer.clone())
        }
    }

    fn state(x: f64, y: f64, v: f64) -> AgentState {
        AgentState { position: Point2::new(x, y), heading_rad: 0.0, velocity_mps: Vector2::new(v, 0.0) }
    }

    /// A straight lane along +x; the ego at 0, the CBV 20 m ahead, a car
    /// 3 m to the side and 2 m ahead (56° off the heading).
    fn scene() -> Arc<Scenario> {
        let lane = Lane::new(
            MapElementId(1),
            crate::geometry::Polyline::new(vec![Point2::new(-50.0, 0.0), Point2::new(500.0, 0.0)]),
        );
        let map = RoadMap::new(vec![lane], vec![], vec![], vec![], vec![], vec![], vec![]);
        let track = |id: &str, x: f64, y: f64| Track {
            id: AgentId(id.into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            states: (0..40).map(|k| Some(state(x + k as f64, y, 10.0))).collect(),
        };
        let tracks = vec![track("ego", 0.0, 0.0), track("cbv", 20.0, 0.0), track("side", 2.0, 3.0)];
        Arc::new(
            Scenario::new("mutant", ScenarioSource::authored("test"), 0.1, map, tracks)
                .with_roles(TrackIndex(0), Some(TrackIndex(1))),
        )
    }

    /// `operator` planted in a planner answering `answer`, driven over
    /// `steps` observations of [`scene`]: the answers and what it saw.
    fn drive(operator: FaultOperator, answer: PlannerOutput, steps: usize) -> (Vec<PlannerOutput>, Shown) {
        let scenario = scene();
        let context = RolloutContext {
            scenario: scenario.clone(),
            ego: TrackIndex(0),
            start_step: 0,
            end_step: 39,
            variant: None,
            seed: None,
        };
        let seen: Shown = Arc::default();
        let inner = Box::new(Recording { answer, seen: seen.clone() });
        let mut mutant = MutantPlanner::new(inner, operator, VehicleLimits::default(), &context);
        assert_eq!(mutant.name(), format!("recording [{operator}]"));
        let answers = (0..steps)
            .map(|k| {
                let mut obs = Observation::new(&scenario.map, scenario.tracks[0].states[k].unwrap());
                obs.step = k;
                obs.agents = scenario.tracks[1..]
                    .iter()
                    .map(|t| PerceivedAgent {
                        id: t.id.clone(),
                        kind: t.kind,
                        length_m: t.length_m,
                        width_m: t.width_m,
                        state: t.states[k].unwrap(),
                    })
                    .collect();
                mutant.plan(&obs).unwrap()
            })
            .collect();
        (answers, seen)
    }

    fn control(a: f64, w: f64) -> PlannerOutput {
        PlannerOutput::Control(Action { accel_mps2: a, yaw_rate_radps: w })
    }

    #[test]
    fn braking_faults_clip_the_braking_and_leave_the_rest() {
        let (out, _) = drive(FaultOperator::NoBrake, control(-6.0, 0.1), 1);
        assert_eq!(out[0], control(0.0, 0.1));
        let (out, _) = drive(FaultOperator::NoBrake, control(2.0, 0.1), 1);
        assert_eq!(out[0], control(2.0, 0.1), "an answer the fault leaves alone is passed through");
        let (out, _) = drive(FaultOperator::WeakBrake, control(-6.0, 0.0), 1);
        assert_eq!(out[0], control(-WEAK_BRAKE_MPS2, 0.0));
        let (out, _) = drive(FaultOperator::WeakBrake, control(-1.0, 0.0), 1);
        assert_eq!(out[0], control(-1.0, 0.0));
    }

    #[test]
    fn late_shows_the_world_half_a_second_old_with_the_ego_current() {
        let (_, seen) = drive(FaultOperator::Late, control(0.0, 0.0), 12);
        let seen = seen.lock().unwrap();
        for (k, (ego, _, xs)) in seen.iter().enumerate() {
            assert_eq!(ego.position.x, k as f64, "the ego's own pose is current");
            // The CBV moves 1 m a step: 5 steps late, the first observation
            // standing in before then.
            assert_eq!(xs[0], 20.0 + k.saturating_sub(5) as f64, "step {k}");
        }
    }

    #[test]
    fn blind_faults_remove_the_cbv_or_what_is_beside() {
        let (_, seen) = drive(FaultOperator::BlindCbv, control(0.0, 0.0), 1);
        assert_eq!(seen.lock().unwrap()[0].1, vec![AgentId("side".into())]);
        let (_, seen) = drive(FaultOperator::BlindSide, control(0.0, 0.0), 1);
        assert_eq!(seen.lock().unwrap()[0].1, vec![AgentId("cbv".into())]);
        let (_, seen) = drive(FaultOperator::NoEvade, control(0.0, 0.0), 1);
        assert_eq!(seen.lock().unwrap()[0].1.len(), 2, "faults on the answer leave the observation alone");
    }

    #[test]
    fn speeding_reads_the_speed_low_and_scales_what_the_planner_asks() {
        let (out, seen) = drive(FaultOperator::Speeding, control(1.0, 0.2), 1);
        assert!((seen.lock().unwrap()[0].0.speed_mps() - 10.0 / SPEEDING_FACTOR).abs() < 1e-12);
        // It asked for 10/1.2 + 0.1 m/s: it gets 1.2 times that, on the same path.
        let PlannerOutput::Control(a) = out[0] else { panic!("{:?}", out[0]) };
        let asked = 10.0 / SPEEDING_FACTOR + 0.1;
        assert!((10.0 + a.accel_mps2 * 0.1 - asked * SPEEDING_FACTOR).abs() < 1e-9, "{a:?}");
        assert!((a.yaw_rate_radps / (10.0 + a.accel_mps2 * 0.1) - 0.2 / asked).abs() < 1e-9, "{a:?}");
    }

    #[test]
    fn no_evade_steers_back_to_the_route_whatever_the_planner_asks() {
        let (out, _) = drive(FaultOperator::NoEvade, control(-1.0, 1.0), 1);
        let PlannerOutput::Control(a) = out[0] else { panic!("{:?}", out[0]) };
        assert_eq!(a.accel_mps2, -1.0);
        assert!(a.yaw_rate_radps.abs() < 1e-9, "on the lane's centreline, heading along it: {a:?}");
    }

    #[test]
    fn clamping_keeps_every_step_inside_the_limits() {
        let limits = VehicleLimits { max_speed_mps: 30.0, max_curvature_per_m: 0.2, ..VehicleLimits::default() };
        let at = |v: f64| AgentState {
            position: Point2::new(0.0, 0.0),
            heading_rad: 0.3,
            velocity_mps: crate::geometry::Vector2::new(0.3f64.cos(), 0.3f64.sin()) * v,
        };
        for (v, a, w) in [(29.5, 20.0, 3.0), (2.0, -50.0, -3.0), (29.9, 0.0, 1.5), (0.0, 8.0, 1.5), (12.0, -12.0, 1.4)]
        {
            let now = at(v);
            let c = clamp_to_limits(&limits, &now, Action { accel_mps2: a, yaw_rate_radps: w }, 0.1);
            let next = kinematic_step(&KinematicState::from_agent_state(&now), c, 0.1).to_agent_state();
            assert_eq!(limits.check(&now, &next, 0.1), None, "{v} m/s, {a} m/s², {w} rad/s -> {c:?}");
            assert!(c.accel_mps2.signum() == a.signum() || c.accel_mps2 == 0.0, "{c:?}");
        }
    }
}
