//! The dual-stage pipeline, the one copy that `cargo test` (the suite
//! runner), `safer run` and `safer evaluate` all run. Stage 1: the ego
//! replays its log while the adversary method drives the CBV; a CBV–ego
//! collision makes the variant *critical* (it counts toward CR). Stage 2: the
//! planner under test drives the ego through the same variant, with the CBV
//! replaying its stage-1 trajectory (the paper's protocol) or driven by the
//! method again, closed loop; the planner *solves* the variant only if the
//! rollout ran to its end without an ego collision and without the planner
//! failing ([`Stage2Verdict`]). Stage 2 also measures whether the conflict
//! reached the planner ([`ConflictReach`]) and, for an ego collision, runs
//! the closed-loop feasibility witness ([`crate::eval::escape`]): stage 2
//! played again, everything driven as it was, with the ego on a candidate
//! escape.
//!
//! A variant is a pure function of (scenario, planner, method settings,
//! seed): the pipeline reads no clock except to report where time went.

use std::sync::Arc;
use std::time::Instant;

use super::HarnessError;
use super::methods::{self, MapEncodings, MethodSettings, ModelSet};
use crate::eval::escape::{EscapeBudget, EscapeSearch, PlannedPath, search_escape};
use crate::eval::{ConflictReach, min_time_to_collision};
use crate::planners::external::{ExternalPlanner, ExternalPlannerConfig, RolloutContext};
use crate::planners::panic_guard::PanicGuard;
use crate::planners::{
    BuiltinPlanner, EvasivePlanner, FaultOperator, IdmPlanner, MutantPlanner, Observation, Planner, PlannerError,
    PlannerOutput,
};
use crate::policies::LogReplay;
use crate::policies::adversary::EgoSight;
use crate::policies::prior_sampling::TrafficTimings;
use crate::scenario::{Scenario, Track, TrackIndex};
use crate::sim::{Rollout, SimConfig, Simulation, Termination, VehicleLimits};
use crate::spec::planner::PlannerAdapter;

pub use crate::spec::suite::Stage2Cbv;

/// Everything that defines one variant.
#[derive(Debug, Clone, Copy)]
pub struct VariantSetup<'a> {
    /// The base scenario (with an ego and a CBV).
    pub scenario: &'a Arc<Scenario>,
    /// How the method drives the CBV (and the background).
    pub settings: MethodSettings,
    /// The variant's seed.
    pub seed: u64,
    /// Start and end steps and the configured background, both stages.
    pub sim: &'a SimConfig,
    /// The CBV in stage 2.
    pub stage2_cbv: Stage2Cbv,
    /// The planner under test.
    pub planner: &'a PlannerAdapter,
    /// The learned models the method may need.
    pub models: &'a ModelSet,
    /// Map encodings shared across variants.
    pub maps: &'a MapEncodings,
    /// The variant's name (`suite::scenario::seed-k`), told to external
    /// planners (`{variant}`, `SAFER_VARIANT`); `None`: the scenario id.
    pub variant: Option<&'a str>,
    /// The closed-loop witness's budget for an ego collision in stage 2
    /// (`None`: no witness is searched).
    pub escape: Option<EscapeBudget>,
    /// The limits the planner under test's ego is held to in stage 2
    /// (`None`, or a planner replaying the log: unchecked).
    pub ego_limits: Option<VehicleLimits>,
    /// A fault planted in the planner under test for stage 2 (a mutant of
    /// mutation testing); `None`: the planner as it is.
    pub fault: Option<FaultOperator>,
}

/// Where a variant's time went, s.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VariantProfile {
    /// Stage 1, whole (simulation, CBV method, models).
    pub stage1_s: f64,
    /// Of which: the prior's query features.
    pub stage1_features_s: f64,
    /// Of which: the prior's decoder.
    pub stage1_decoder_s: f64,
    /// Of which: feasibility value queries.
    pub stage1_feasibility_s: f64,
    /// Stage 2 (the planner under test).
    pub stage2_s: f64,
    /// Of which: the planner's `plan` calls (the rest is the simulator:
    /// the other agents, events).
    pub stage2_planner_s: f64,
    /// The stage-1 witness search (only `safer evaluate` runs it).
    pub witness_s: f64,
    /// The closed-loop witness of a stage-2 collision.
    pub escape_s: f64,
}

impl VariantProfile {
    /// Adds `o` part by part.
    pub fn add(&mut self, o: &VariantProfile) {
        self.stage1_s += o.stage1_s;
        self.stage1_features_s += o.stage1_features_s;
        self.stage1_decoder_s += o.stage1_decoder_s;
        self.stage1_feasibility_s += o.stage1_feasibility_s;
        self.stage2_s += o.stage2_s;
        self.stage2_planner_s += o.stage2_planner_s;
        self.witness_s += o.witness_s;
        self.escape_s += o.escape_s;
    }

    /// Every part multiplied by `k`.
    pub fn scaled(&self, k: f64) -> VariantProfile {
        VariantProfile {
            stage1_s: self.stage1_s * k,
            stage1_features_s: self.stage1_features_s * k,
            stage1_decoder_s: self.stage1_decoder_s * k,
            stage1_feasibility_s: self.stage1_feasibility_s * k,
            stage2_s: self.stage2_s * k,
            stage2_planner_s: self.stage2_planner_s * k,
            witness_s: self.witness_s * k,
            escape_s: self.escape_s * k,
        }
    }
}

/// How long the planner under test took to answer, over the observations
/// of one stage-2 rollout (wall clock of each `plan` call: for an external
/// planner the whole round trip, message encoding and pipes included).
/// Percentiles are nearest-rank. Not deterministic: reports carry it, test
/// snapshots do not.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlannerLatency {
    /// Observations answered (or failed).
    pub steps: usize,
    /// The first answer, ms (includes a lazily started process's startup).
    pub first_ms: f64,
    /// Median, ms.
    pub p50_ms: f64,
    /// 95th percentile, ms.
    pub p95_ms: f64,
    /// Slowest, ms.
    pub max_ms: f64,
    /// How long the planner took to start before its first observation
    /// (an external process: to `ready`, and to answer `prepare`).
    pub startup: Option<crate::planners::PlannerStartup>,
}

impl PlannerLatency {
    /// The summary of per-call times in ms and of the planner's start,
    /// each rounded to the microsecond; `None` for no call.
    pub fn of(times_ms: &[f64], startup: Option<crate::planners::PlannerStartup>) -> Option<PlannerLatency> {
        let first_ms = *times_ms.first()?;
        let mut sorted = times_ms.to_vec();
        sorted.sort_by(f64::total_cmp);
        let rank = |q: f64| sorted[((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len()) - 1];
        let round = |x: f64| (x * 1000.0).round() / 1000.0;
        Some(PlannerLatency {
            steps: sorted.len(),
            first_ms: round(first_ms),
            p50_ms: round(rank(0.5)),
            p95_ms: round(rank(0.95)),
            max_ms: round(sorted[sorted.len() - 1]),
            startup: startup.map(|s| crate::planners::PlannerStartup {
                launch_ms: round(s.launch_ms),
                prepare_ms: s.prepare_ms.map(round),
            }),
        })
    }
}

/// A planner whose `plan` calls are timed.
struct Timed<'p> {
    inner: &'p mut dyn Planner,
    times_ms: Vec<f64>,
}

impl Planner for Timed<'_> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn plan(&mut self, observation: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        let clock = Instant::now();
        let out = self.inner.plan(observation);
        self.times_ms.push(clock.elapsed().as_secs_f64() * 1e3);
        out
    }

    fn end_rollout(&mut self) -> Option<String> {
        self.inner.end_rollout()
    }

    fn take_debug(&mut self) -> Option<serde_json::Value> {
        self.inner.take_debug()
    }

    fn startup(&self) -> Option<crate::planners::PlannerStartup> {
        self.inner.startup()
    }
}

/// What the planner under test made of stage 2.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case", tag = "verdict")]
pub enum Stage2Verdict {
    /// Ran to the end without an ego collision.
    Solved,
    /// The ego collided.
    Collided {
        /// Time of the first ego collision after the start, s.
        time_s: f64,
    },
    /// The rollout could not go on: the planner crashed, hung, answered
    /// garbage or drove the ego out of bounds, or an agent's state became
    /// invalid. Never a success: a planner that stops answering must not
    /// raise the solution rate.
    Aborted {
        /// What ended it, in words.
        reason: String,
    },
}

impl Stage2Verdict {
    /// The verdict on a finished stage-2 rollout.
    pub fn of(stage2: &Rollout) -> Stage2Verdict {
        match &stage2.termination {
            Termination::Completed | Termination::EgoCollision { .. } | Termination::LeftMappedArea { .. } => {
                match stage2.ego_collision() {
                    Some(c) => Stage2Verdict::Collided { time_s: (c.step - stage2.start_step) as f64 * stage2.dt_s },
                    None => Stage2Verdict::Solved,
                }
            }
            other => Stage2Verdict::Aborted { reason: termination_reason(other, stage2) },
        }
    }

    /// Whether the planner solved the variant (counts toward SR).
    pub fn solved(&self) -> bool {
        matches!(self, Stage2Verdict::Solved)
    }
}

/// A termination that is not a normal end, in words.
fn termination_reason(termination: &Termination, rollout: &Rollout) -> String {
    let at = |step: usize| step.saturating_sub(rollout.start_step) as f64 * rollout.dt_s;
    match termination {
        Termination::PlannerFailed { step, reason } => {
            format!("planner `{}` failed at t = {:.1} s: {reason}", rollout.planner, at(*step))
        }
        Termination::VehicleLimitExceeded { step, reason } => {
            format!(
                "planner `{}` drove the ego beyond its vehicle limits at t = {:.1} s: {reason}",
                rollout.planner,
                at(*step)
            )
        }
        Termination::InvalidAgentState { step, agent, reason } => {
            format!("the rollout was aborted at t = {:.1} s: agent {agent} has an invalid state: {reason}", at(*step))
        }
        Termination::Completed | Termination::EgoCollision { .. } | Termination::LeftMappedArea { .. } => String::new(),
    }
}

/// The two rollouts of a variant and what was measured on them.
#[derive(Debug, Clone)]
pub struct DualStage {
    /// Stage 1: the ego on log replay, the CBV driven by the method.
    pub stage1: Rollout,
    /// Stage 2: the planner under test.
    pub stage2: Rollout,
    /// Stage 2's verdict.
    pub verdict: Stage2Verdict,
    /// Minimum time to collision in stage 2, s.
    pub min_ttc_s: Option<f64>,
    /// How close the CBV came to the planner's ego in stage 2.
    pub reach: ConflictReach,
    /// The closed-loop witness of an ego collision in stage 2 (`None`: no
    /// collision, or no witness asked for).
    pub escape: Option<EscapeSearch>,
    /// Where the time went (the stage-1 witness part is left at zero).
    pub profile: VariantProfile,
    /// How long the planner under test took per observation.
    pub planner_latency: Option<PlannerLatency>,
    /// What the planner under test wrote to stderr (external planners).
    pub planner_stderr: Option<String>,
}

impl DualStage {
    /// Whether the CBV hit the ego in stage 1 (counts toward CR).
    pub fn stage1_cbv_hit_ego(&self) -> bool {
        self.stage1.summary().ego_collision.is_some_and(|c| c.with_cbv)
    }
}

/// A fresh planner for the ego of the context's scenario. An external
/// planner is started at once (through `hello` and, in protocol 1.1,
/// `prepare`), told the scene and variant of `context`.
pub fn make_planner(adapter: &PlannerAdapter, context: RolloutContext) -> Result<Box<dyn Planner>, HarnessError> {
    let scenario = &context.scenario;
    match adapter {
        PlannerAdapter::Builtin { planner: BuiltinPlanner::Idm, idm, .. } => Ok(Box::new(IdmPlanner::new(*idm))),
        PlannerAdapter::Builtin { planner: BuiltinPlanner::Evasive, evasive, .. } => {
            Ok(Box::new(EvasivePlanner::for_recorded_ego(evasive.clone(), scenario, context.ego)))
        }
        PlannerAdapter::Builtin { planner, .. } => Ok(planner.instantiate(scenario, context.ego)),
        PlannerAdapter::InProcess { name, factory } => {
            let factory = &factory.0;
            // A team's planner may panic, in its constructor or in `plan`:
            // its variant fails at the step, as a crashed process's does.
            let made = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| factory(scenario, context.ego)));
            match made {
                Ok(planner) => Ok(Box::new(PanicGuard::new(planner)) as Box<dyn Planner>),
                Err(payload) => Err(HarnessError::PlannerStart {
                    planner: name.clone(),
                    source: crate::planners::PlannerError::Panicked {
                        planner: name.clone(),
                        message: crate::planners::panic_guard::panic_message(payload.as_ref()),
                    },
                }),
            }
        }
        PlannerAdapter::External { name, spec, working_dir } => {
            let mut config = ExternalPlannerConfig::new(name.clone(), spec.command.clone());
            config.args = spec.args.clone();
            config.working_dir = Some(working_dir.clone());
            config.env = spec.env.clone();
            config.step_timeout_ms = spec.step_timeout_ms;
            config.first_step_timeout_ms = spec.first_step_timeout_ms;
            config.startup_timeout_ms = spec.startup_timeout_ms;
            ExternalPlanner::start_with_context(config, context)
                .map(|p| Box::new(p) as Box<dyn Planner>)
                .map_err(|source| HarnessError::PlannerStart { planner: name.clone(), source })
        }
    }
}

/// The CBV's stage-1 trajectory as a track (`None` before the start step).
pub fn track_from_rollout(scenario: &Scenario, rollout: &Rollout, agent: TrackIndex) -> Track {
    let mut t = scenario.track(agent).clone();
    t.states = (0..scenario.num_steps())
        .map(|k| k.checked_sub(rollout.start_step).and_then(|i| rollout.states.get(i)).and_then(|row| row[agent.0]))
        .collect();
    t
}

/// Runs both stages of one variant.
pub fn run(setup: VariantSetup<'_>) -> Result<DualStage, HarnessError> {
    run_witnessing(setup, |_| true)
}

/// [`run`], the witness searched only for a stage-2 collision `witnessed`
/// asks it of (given the stage-2 rollout): a suite's criteria leave out a
/// collision that fails none of them and is no generator's fault
/// ([`acceptance::asks_witness`](super::acceptance::asks_witness)).
pub fn run_witnessing(
    setup: VariantSetup<'_>,
    witnessed: impl FnOnce(&Rollout) -> bool,
) -> Result<DualStage, HarnessError> {
    let scenario = setup.scenario;
    let clock = Instant::now();
    scenario.ego.ok_or_else(|| crate::sim::SimError::NoEgo(scenario.id.clone()))?;
    // A scene without a CBV is refused before anything is simulated.
    scenario.cbv.ok_or_else(|| HarnessError::NoCbv(scenario.id.clone()))?;

    let (stage1, models_time) = stage1(&setup)?;
    let mut profile = VariantProfile {
        stage1_s: clock.elapsed().as_secs_f64(),
        stage1_features_s: models_time.features_s,
        stage1_decoder_s: models_time.decoder_s,
        stage1_feasibility_s: models_time.feasibility_s,
        ..VariantProfile::default()
    };

    // Stage 2: the planner under test.
    let stage2_clock = Instant::now();
    let PlayedStage2 { stage2, planner_latency, planner_stderr, planner_s } = play_stage2(&setup, &stage1)?;
    profile.stage2_planner_s = planner_s;
    profile.stage2_s = stage2_clock.elapsed().as_secs_f64();

    let verdict = Stage2Verdict::of(&stage2);
    let escape_clock = Instant::now();
    let escape = stage2_witness(&setup, &stage1, &stage2, witnessed)?;
    profile.escape_s = escape_clock.elapsed().as_secs_f64();

    Ok(DualStage {
        verdict,
        min_ttc_s: min_time_to_collision(&stage2),
        reach: ConflictReach::of(&stage2),
        escape,
        stage1,
        stage2,
        profile,
        planner_latency,
        planner_stderr,
    })
}

/// A stage 2 played: the rollout and what the planner cost.
pub struct PlayedStage2 {
    /// The rollout.
    pub stage2: Rollout,
    /// The planner's time per observation.
    pub planner_latency: Option<PlannerLatency>,
    /// What it wrote to its error stream.
    pub planner_stderr: Option<String>,
    /// Its total time answering, s.
    pub planner_s: f64,
}

/// Stage 2 of `setup` after `stage1`: the planner under test drives the
/// ego, the CBV replays its stage-1 path or is driven again by the method
/// (`setup.stage2_cbv`).
pub fn play_stage2(setup: &VariantSetup<'_>, stage1: &Rollout) -> Result<PlayedStage2, HarnessError> {
    let scenario = setup.scenario;
    let ego = scenario.ego.ok_or_else(|| crate::sim::SimError::NoEgo(scenario.id.clone()))?;
    let start = setup.sim.start_step.unwrap_or(scenario.current_step);
    let (stage2, closed_loop) = stage2_simulation(setup, stage1)?;
    let end = setup.sim.end_step.unwrap_or(scenario.num_steps().saturating_sub(1));
    let context = RolloutContext {
        scenario: scenario.clone(),
        ego,
        start_step: start,
        end_step: end,
        variant: setup.variant.map(String::from),
        seed: Some(setup.seed),
    };
    let mut planner = make_planner(setup.planner, context.clone())?;
    if let Some(operator) = setup.fault {
        let limits = setup.ego_limits.unwrap_or_default();
        planner = Box::new(MutantPlanner::new(planner, operator, limits, &context));
    }
    let mut timed = Timed { inner: planner.as_mut(), times_ms: Vec::new() };
    let stage2 = stage2.run(&mut timed);
    let planner_latency = PlannerLatency::of(&timed.times_ms, timed.startup());
    let planner_s = timed.times_ms.iter().sum::<f64>() / 1e3;
    // Ends an external process before the next variant starts one, and
    // only then reads its stderr: lines still in the pipe are not lost.
    let planner_stderr = timed.end_rollout();
    drop(planner);
    model_error(setup, closed_loop.as_ref())?;
    Ok(PlayedStage2 { stage2, planner_latency, planner_stderr, planner_s })
}

/// Stage 1 alone: the ego replays its log while `setup`'s method drives
/// the CBV (what [`run`] does first).
pub fn run_stage1(setup: &VariantSetup<'_>) -> Result<Rollout, HarnessError> {
    stage1(setup).map(|(rollout, _)| rollout)
}

/// Stage 1 and the time its models took.
fn stage1(setup: &VariantSetup<'_>) -> Result<(Rollout, TrafficTimings), HarnessError> {
    let scenario = setup.scenario;
    let ego = scenario.ego.ok_or_else(|| crate::sim::SimError::NoEgo(scenario.id.clone()))?;
    let mut stage1 = Simulation::new(scenario, setup.sim.clone())?;
    let installed = install_method(setup, &mut stage1, EgoSight::Current)?;
    let mut replay_ego = BuiltinPlanner::LogReplay.instantiate(scenario, ego);
    let stage1 = stage1.run(replay_ego.as_mut());
    model_error(setup, Some(&installed))?;
    Ok((stage1, installed.timings()))
}

/// Installs `setup`'s method for the CBV in `sim` (stage 1, or stage 2
/// closed loop: the same seed, so the same policy).
fn install_method(
    setup: &VariantSetup<'_>,
    sim: &mut Simulation<'_>,
    sight: EgoSight,
) -> Result<methods::InstalledMethod, HarnessError> {
    let scenario = setup.scenario;
    let cbv = scenario.cbv.ok_or_else(|| HarnessError::NoCbv(scenario.id.clone()))?;
    let start = setup.sim.start_step.unwrap_or(scenario.current_step);
    let models = (setup.models, setup.maps);
    methods::install_seeing_ego(sim, scenario, cbv, start, setup.settings, models, setup.seed, sight)
}

/// The first model error an installed method met during its rollout.
fn model_error(setup: &VariantSetup<'_>, installed: Option<&methods::InstalledMethod>) -> Result<(), HarnessError> {
    match installed.and_then(methods::InstalledMethod::error) {
        Some(source) => Err(HarnessError::Model { method: setup.settings.method, source }),
        None => Ok(()),
    }
}

/// Stage 2 of `setup` set up to run: the CBV replaying its `stage1` path
/// or driven by the method again (then also its installation, whose
/// error the caller reads after the run).
fn stage2_simulation<'s>(
    setup: &VariantSetup<'s>,
    stage1: &Rollout,
) -> Result<(Simulation<'s>, Option<methods::InstalledMethod>), HarnessError> {
    let scenario = setup.scenario;
    let cbv = scenario.cbv.ok_or_else(|| HarnessError::NoCbv(scenario.id.clone()))?;
    let replays_the_log = matches!(setup.planner, PlannerAdapter::Builtin { planner: BuiltinPlanner::LogReplay, .. });
    let config = SimConfig { ego_limits: setup.ego_limits.filter(|_| !replays_the_log), ..setup.sim.clone() };
    let mut stage2 = Simulation::new(scenario, config)?;
    let installed = match setup.stage2_cbv {
        Stage2Cbv::Replay => {
            stage2.set_policy(cbv, Box::new(LogReplay::new(track_from_rollout(scenario, stage1, cbv))));
            None
        }
        Stage2Cbv::ClosedLoop => Some(install_method(setup, &mut stage2, EgoSight::Current)?),
        Stage2Cbv::ClosedLoopDelayed => Some(install_method(setup, &mut stage2, EgoSight::ReactionTimeLate)?),
    };
    Ok((stage2, installed))
}

/// The closed-loop witness of `stage2`'s ego collision
/// ([`search_stage2_escape`]), where the setup has a witness budget, the
/// ego collided and `witnessed` asks it of the rollout; `None` otherwise.
pub fn stage2_witness(
    setup: &VariantSetup<'_>,
    stage1: &Rollout,
    stage2: &Rollout,
    witnessed: impl FnOnce(&Rollout) -> bool,
) -> Result<Option<EscapeSearch>, HarnessError> {
    match (setup.escape, Stage2Verdict::of(stage2)) {
        (Some(budget), Stage2Verdict::Collided { .. }) if witnessed(stage2) => {
            search_stage2_escape(setup, stage1, stage2, budget)
        }
        _ => Ok(None),
    }
}

/// The closed-loop witness of `stage2`'s ego collision: each candidate
/// escape is played as stage 2 again, the CBV replaying or driven by the
/// method exactly as in `stage2` (same seed), the background by its policy,
/// the ego on the candidate. `None` when the ego has no start state.
pub fn search_stage2_escape(
    setup: &VariantSetup<'_>,
    stage1: &Rollout,
    stage2: &Rollout,
    budget: EscapeBudget,
) -> Result<Option<EscapeSearch>, HarnessError> {
    let mut replay = |plan: &[crate::scenario::AgentState]| -> Result<Rollout, HarnessError> {
        let (sim, installed) = stage2_simulation(setup, stage1)?;
        let played = sim.run(&mut PlannedPath::new(plan.to_vec()));
        model_error(setup, installed.as_ref()).map(|()| played)
    };
    search_escape(setup.scenario, stage2, budget, &mut replay)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Polyline, Vector2};
    use crate::map::{Lane, MapElementId, RoadMap};
    use crate::planners::{Observation, PlannerError, PlannerOutput};
    use crate::scenario::{AgentId, AgentKind, AgentState, ScenarioSource};
    use crate::sim::Simulation;

    /// Two cars 40 m apart on a straight lane, both at 10 m/s, 61 steps.
    fn two_cars() -> Scenario {
        let lane = Lane::new(MapElementId(1), Polyline::new(vec![Point2::new(-50.0, 0.0), Point2::new(500.0, 0.0)]));
        let map = RoadMap::from_lanes(vec![lane]);
        let track = |id: &str, x0: f64| crate::scenario::Track {
            id: AgentId(id.into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            states: (0..61)
                .map(|k| {
                    Some(AgentState {
                        position: Point2::new(x0 + k as f64, 0.0),
                        heading_rad: 0.0,
                        velocity_mps: Vector2::new(10.0, 0.0),
                    })
                })
                .collect(),
        };
        Scenario::new(
            "two-cars",
            ScenarioSource::authored("test"),
            0.1,
            map,
            vec![track("ego", 0.0), track("lead", 40.0)],
        )
        .with_roles(TrackIndex(0), Some(TrackIndex(1)))
    }

    /// Answers `ok_steps` times by holding speed, then fails.
    struct StopsAnswering {
        ok_steps: usize,
    }

    impl Planner for StopsAnswering {
        fn name(&self) -> &str {
            "stops-answering"
        }
        fn plan(&mut self, _: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
            if self.ok_steps == 0 {
                return Err(PlannerError::InvalidOutput("the planner process exited (status 1)".into()));
            }
            self.ok_steps -= 1;
            Ok(PlannerOutput::Control(crate::motion::Action { accel_mps2: 0.0, yaw_rate_radps: 0.0 }))
        }
    }

    fn stage2_with(planner: &mut dyn Planner) -> Rollout {
        let s = two_cars();
        Simulation::new(&s, SimConfig::default()).unwrap().run(planner)
    }

    #[test]
    fn a_planner_that_stops_answering_has_not_solved_the_variant() {
        // A crashed planner's short rollout has no collision: judged by
        // collisions alone, it would count as solved.
        let r = stage2_with(&mut StopsAnswering { ok_steps: 5 });
        assert!(r.ego_collision().is_none());
        let verdict = Stage2Verdict::of(&r);
        assert!(!verdict.solved(), "{verdict:?}");
        match verdict {
            Stage2Verdict::Aborted { reason } => {
                assert!(reason.contains("stops-answering") && reason.contains("t = 0.5 s"), "{reason}")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_planner_that_answers_to_the_end_without_contact_solves_it() {
        let r = stage2_with(&mut StopsAnswering { ok_steps: usize::MAX });
        assert_eq!(Stage2Verdict::of(&r), Stage2Verdict::Solved);
    }

    #[test]
    fn latency_percentiles_are_nearest_rank() {
        let times: Vec<f64> = (1..=100).map(f64::from).collect();
        let l = PlannerLatency::of(&times, None).unwrap();
        assert_eq!((l.steps, l.first_ms, l.p50_ms, l.p95_ms, l.max_ms), (100, 1.0, 50.0, 95.0, 100.0));
        assert_eq!(PlannerLatency::of(&[7.0], None).unwrap().p95_ms, 7.0);
        assert!(PlannerLatency::of(&[], None).is_none());
    }

    #[test]
    fn a_collision_is_not_a_solution() {
        struct Accelerates;
        impl Planner for Accelerates {
            fn name(&self) -> &str {
                "accelerates"
            }
            fn plan(&mut self, _: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
                Ok(PlannerOutput::Control(crate::motion::Action { accel_mps2: 5.0, yaw_rate_radps: 0.0 }))
            }
        }
        let r = stage2_with(&mut Accelerates);
        match Stage2Verdict::of(&r) {
            Stage2Verdict::Collided { time_s } => assert!(time_s > 0.0 && time_s < 6.0, "{time_s}"),
            other => panic!("{other:?}"),
        }
    }
}
