//! Failure shrinking: the smallest deviation from the recorded CBV that
//! still fails the planner the same way, as proptest shrinks a failing
//! input.
//!
//! A failing variant's CBV drove a token per period (the approach phase's
//! and the adversary's). The shrinker reads those tokens back from its
//! stage-2 path and searches scripts that give periods back to the log,
//! each period either the variant's token or the log's (the token that best
//! follows the recording from where the CBV then is). Each candidate's CBV
//! path is played as stage 2 again, the CBV replaying it (it does not react)
//! and the planner under test driving, and is kept when it is plausible (the
//! CBV leaves the road no more, and is at fault with background traffic no
//! more, than in the variant) and fails the same way: the same first failed
//! criterion, and a collision with the same agent where there was one.
//!
//! The search is deterministic and bounded by a budget of candidate
//! rollouts: first the longest log prefix (engaging later: a binary
//! search over how many periods the CBV follows the log), then each
//! remaining variant token, earliest first, given back to the log where the
//! failure persists. The smallest kept script whose conflict the fixed-
//! traffic witness finds escapable (avoidable) is the shrunk variant. A
//! time limit may bound it too (each candidate is a whole stage 2 with the
//! planner under test, which an external planner makes slow): the result
//! then depends on the machine, and says that the search stopped there.
//!
//! Every failed criterion shrinks alike (a collision, leaving the road or
//! the lanes, a traffic rule, a margin, a planner that stops answering):
//! the shrinker only asks whether a candidate fails the same first
//! criterion, judged as the variant was (a collision the variant's escape
//! search excused as the generator's fault is excused in a candidate that
//! hits the same agent, else a variant that also left the road would fail
//! every candidate by the collision first). What it cannot shrink it says why ([`NotShrunk`]): a CBV
//! that was absent for a while or driven by something other than tokens,
//! a failure the variant's own CBV path does not reproduce when replayed
//! (the planner is not deterministic, or the failure came from the CBV
//! reacting to it in stage 2), or no kept candidate with an escape. The
//! shrink never changes the variant's verdict: a candidate that cannot be
//! played ends the search, not the variant.
//!
//! Deviation is measured by the number of adversarial tokens (periods
//! whose token differs from the log's there) and the largest distance of
//! the CBV from its recorded path, m.

use std::time::{Duration, Instant};

use super::HarnessError;
use super::acceptance::{self, AcceptanceFailure};
use super::metrics::{cbv_background_collisions, cbv_off_road_s};
use super::pipeline::{self, Stage2Cbv, VariantSetup};
use crate::eval::escape::CollisionEscape;
use crate::eval::min_time_to_collision;
use crate::eval::witness::{RoadKeeping, Witness, WitnessBudget, search_rollout_witness};
use crate::motion::inversion::best_token;
use crate::motion::tokens::VOCABULARY_SIZE;
use crate::motion::{KinematicState, TOKEN_PERIOD_STEPS, Token, TokenGrid};
use crate::scenario::{AgentState, Scenario, TrackIndex};
use crate::sim::Rollout;
use crate::spec::suite::VariantAcceptance;

/// Candidate rollouts a shrink may play unless told otherwise.
pub const DEFAULT_SHRINK_BUDGET: usize = 16;

/// How far a failing variant's shrink may search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShrinkBudget {
    /// Candidate rollouts (0: failing variants are not shrunk).
    pub rollouts: usize,
    /// Wall time of the search (`None`: bounded by `rollouts` alone). The
    /// variant's own script is always played, whatever the limit.
    pub time_limit: Option<Duration>,
}

impl Default for ShrinkBudget {
    fn default() -> Self {
        Self { rollouts: DEFAULT_SHRINK_BUDGET, time_limit: None }
    }
}

impl ShrinkBudget {
    /// The budget a suite spec's `shrink:` sets.
    pub fn of(spec: &crate::spec::suite::ShrinkSpec) -> Self {
        Self { rollouts: spec.budget, time_limit: spec.time_limit_s.map(Duration::from_secs_f64) }
    }

    /// Whether failing variants are shrunk at all.
    pub fn enabled(&self) -> bool {
        self.rollouts > 0
    }
}

/// Why a search ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ShrinkStop {
    /// It tried every candidate it had.
    Searched,
    /// It played as many candidates as the budget allows.
    RolloutBudget,
    /// It ran out of its time limit: another machine may get further.
    TimeLimit,
    /// A candidate could not be played (the planner failed to start or
    /// answer): the search kept what it had found before it.
    CandidateFailed,
}

/// Why a failing variant was not shrunk.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NotShrunk {
    /// The variant has no CBV.
    #[error("the variant has no CBV to give back to the log")]
    NoCbv,
    /// The CBV was absent at a step of stage 2, or something other than
    /// tokens drove it.
    #[error(
        "the CBV's stage-2 path is not made of tokens (it was absent at some step, or something other than the \
         token decoder drove it), so there is nothing to give back to the log"
    )]
    NotTokens,
    /// Replaying the variant's own CBV path did not fail the same way.
    #[error(
        "replaying the variant's own CBV path against the planner does not fail the same way ({0}): the planner \
         is not deterministic, or the failure came from the CBV reacting to it in stage 2"
    )]
    NotReproduced(String),
    /// No kept candidate had an escape the witness search finds.
    #[error(
        "no failing candidate ({0} kept) has an escape the witness search finds: the failure may be unavoidable, \
         and a shrunk variant must be one the planner could have survived"
    )]
    NoEscape(usize),
    /// A candidate could not be played.
    #[error("candidate {candidate} could not be played: {error}")]
    CandidateFailed {
        /// Which candidate (1: the variant's own script).
        candidate: usize,
        /// Why.
        error: String,
    },
}

/// How far a CBV path is from the recording.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Deviation {
    /// Periods whose token differs from the log's there.
    pub adversarial_tokens: usize,
    /// The CBV's largest distance from its recorded position, m.
    pub max_distance_m: f64,
}

/// A failing variant shrunk.
#[derive(Debug, Clone)]
pub struct Shrunk {
    /// The shrunk stage 2.
    pub stage2: Rollout,
    /// Its failed criteria (the same first one as the variant's).
    pub failures: Vec<AcceptanceFailure>,
    /// The variant's deviation from the log.
    pub before: Deviation,
    /// The shrunk variant's.
    pub after: Deviation,
    /// Periods given back to the log.
    pub tokens_changed: usize,
    /// Candidate rollouts played.
    pub candidates: usize,
    /// Why the search ended: a [`ShrinkStop::TimeLimit`] result depends
    /// on the machine.
    pub stopped: ShrinkStop,
    /// Wall time of the search, s.
    pub time_s: f64,
    /// The escape the witness search found from the shrunk conflict: the
    /// ego's states, one per step from the start, touching nobody while
    /// the CBV drives the shrunk path (it does not react).
    pub escape: Vec<AgentState>,
    /// That escape's smallest clearance to any agent, m.
    pub escape_clearance_m: f64,
}

/// One period of a CBV script.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Choice {
    /// The token the variant's CBV drove.
    Variant(Token),
    /// The log's token from where the CBV is.
    Log,
}

/// What the shrinker needs of the failing variant.
pub struct FailingVariant<'a> {
    /// How it was set up (scenario, planner, seed, …).
    pub setup: VariantSetup<'a>,
    /// Its stage 1.
    pub stage1: &'a Rollout,
    /// Its stage 2.
    pub stage2: &'a Rollout,
    /// Its failed criteria (not empty).
    pub failures: &'a [AcceptanceFailure],
    /// The criteria.
    pub criteria: &'a VariantAcceptance,
    /// The closed-loop witness's verdict on the variant's collision, by
    /// which its criteria were checked: a candidate colliding with the same
    /// agent is checked by it too, so a collision the variant was excused
    /// (no escape: the generator's fault) does not make every candidate
    /// fail another way.
    pub escape: Option<CollisionEscape>,
}

/// Shrinks `variant` within `budget`; why not when it cannot (see
/// [`NotShrunk`]). A candidate that cannot be played ends the search with
/// what was kept before it, or, for the variant's own script, with
/// [`NotShrunk::CandidateFailed`].
pub fn shrink(variant: &FailingVariant<'_>, budget: ShrinkBudget) -> Result<Shrunk, NotShrunk> {
    let clock = Instant::now();
    let scenario: &Scenario = variant.setup.scenario;
    let (Some(cbv), Some(first_failure)) = (variant.stage2.cbv, variant.failures.first()) else {
        return Err(NotShrunk::NoCbv);
    };
    let tokens = driven_tokens(variant.stage2, cbv).ok_or(NotShrunk::NotTokens)?;
    let periods = variant.stage1.states.len().saturating_sub(1).div_ceil(TOKEN_PERIOD_STEPS);
    // The variant's tokens, then the log's where its stage 2 ended early.
    let original: Vec<Choice> =
        (0..periods).map(|k| tokens.get(k).map_or(Choice::Log, |&t| Choice::Variant(t))).collect();
    let start = variant.stage1.start_step;
    let cbv_start = variant.stage2.states.first().and_then(|row| row[cbv.0]).ok_or(NotShrunk::NotTokens)?;
    let path_of = |script: &[Choice]| cbv_path(scenario, cbv, start, cbv_start, script);
    let collided_with = |r: &Rollout| r.summary().ego_collision.map(|c| c.other);
    let baseline_off_road = cbv_off_road_s(scenario, variant.stage2);
    let baseline_at_fault =
        cbv_background_collisions(scenario, variant.stage2).into_iter().filter(|c| c.at_fault).count();
    let setup = VariantSetup { stage2_cbv: Stage2Cbv::Replay, escape: None, ..variant.setup };
    let candidates = std::cell::Cell::new(0);
    // Plays `script`: the rollout and failures, and whether it fails as the variant did.
    let play = |script: &[Choice]| -> Result<(Rollout, Vec<AcceptanceFailure>, bool), HarnessError> {
        candidates.set(candidates.get() + 1);
        let (path, _) = path_of(script);
        let mut stage1 = variant.stage1.clone();
        for (row, state) in stage1.states.iter_mut().zip(&path) {
            row[cbv.0] = *state;
        }
        let played = pipeline::play_stage2(&setup, &stage1)?;
        let stage2 = played.stage2;
        let same_agent = collided_with(&stage2) == collided_with(variant.stage2);
        let escape = if same_agent { variant.escape } else { None };
        let failures = acceptance::check(variant.criteria, &stage2, scenario, min_time_to_collision(&stage2), escape);
        let same = failures.first().is_some_and(|f| f.criterion == first_failure.criterion) && same_agent;
        let plausible = cbv_off_road_s(scenario, &stage2) <= baseline_off_road
            && cbv_background_collisions(scenario, &stage2).into_iter().filter(|c| c.at_fault).count()
                <= baseline_at_fault;
        Ok((stage2, failures, same && plausible))
    };
    let mut stopped = ShrinkStop::Searched;
    // Whether another candidate may be played; records why not.
    let may_play = |stopped: &mut ShrinkStop| {
        if candidates.get() >= budget.rollouts {
            *stopped = ShrinkStop::RolloutBudget;
        } else if budget.time_limit.is_some_and(|limit| clock.elapsed() >= limit) {
            *stopped = ShrinkStop::TimeLimit;
        }
        *stopped == ShrinkStop::Searched
    };

    // Kept scripts, each smaller than the one before.
    let mut kept: Vec<(Vec<Choice>, Rollout, Vec<AcceptanceFailure>)> = Vec::new();
    let (stage2, failures, alike) =
        play(&original).map_err(|e| NotShrunk::CandidateFailed { candidate: 1, error: e.to_string() })?;
    if !alike {
        let replayed = failures.first().map_or_else(
            || "it passes".to_string(),
            |f| {
                if f.criterion == first_failure.criterion {
                    format!("{}: {}", f.criterion, f.what)
                } else {
                    format!("it fails {} first", f.criterion)
                }
            },
        );
        return Err(NotShrunk::NotReproduced(replayed));
    }
    kept.push((original.clone(), stage2, failures));
    // A candidate that cannot be played ends the search with what was kept.
    let mut broken = false;
    // Engage later: the longest log prefix that still fails alike.
    let with_prefix = |k: usize| -> Vec<Choice> {
        original.iter().enumerate().map(|(i, c)| if i < k { Choice::Log } else { *c }).collect()
    };
    let (mut lo, mut hi) = (0, periods);
    while lo < hi && !broken && may_play(&mut stopped) {
        let mid = (lo + hi).div_ceil(2);
        let script = with_prefix(mid);
        match play(&script) {
            Ok((stage2, failures, true)) => {
                lo = mid;
                kept.push((script, stage2, failures));
            }
            Ok(_) => hi = mid - 1,
            Err(_) => {
                broken = true;
                stopped = ShrinkStop::CandidateFailed;
            }
        }
    }
    // Fewer adversarial tokens: each remaining one given back to the log.
    let mut script = kept.last().map(|k| k.0.clone()).unwrap_or_default();
    for i in 0..periods {
        if broken || script[i] == Choice::Log {
            continue;
        }
        if !may_play(&mut stopped) {
            break;
        }
        let mut candidate = script.clone();
        candidate[i] = Choice::Log;
        match play(&candidate) {
            Ok((stage2, failures, true)) => {
                script = candidate.clone();
                kept.push((candidate, stage2, failures));
            }
            Ok(_) => {}
            Err(_) => {
                broken = true;
                stopped = ShrinkStop::CandidateFailed;
            }
        }
    }
    // The smallest kept script whose conflict has an escape.
    let escape_from =
        |r: &Rollout| match search_rollout_witness(scenario, r, RoadKeeping::Centre, WitnessBudget::default()) {
            Witness::Found { trajectory, min_clearance_m, .. } => Some((trajectory, min_clearance_m)),
            Witness::NoneWithinBudget { .. } => None,
        };
    let kept_count = kept.len();
    let ((script, stage2, failures), (escape, escape_clearance_m)) = kept
        .into_iter()
        .rev()
        .find_map(|k| escape_from(&k.1).map(|e| (k, e)))
        .ok_or(NotShrunk::NoEscape(kept_count))?;
    let before = path_of(&original).1;
    let after = path_of(&script).1;
    Ok(Shrunk {
        stage2,
        failures,
        before,
        after,
        tokens_changed: original.iter().zip(&script).filter(|(a, b)| a != b).count(),
        candidates: candidates.get(),
        stopped,
        time_s: clock.elapsed().as_secs_f64(),
        escape,
        escape_clearance_m,
    })
}

/// The token the CBV drove in each full or partial period of `rollout`
/// (from its first step), found by replaying every token from the period's
/// first state; `None` when the CBV is absent at a step or no token gives
/// its path (something other than tokens drove it).
fn driven_tokens(rollout: &Rollout, cbv: TrackIndex) -> Option<Vec<Token>> {
    let states: Vec<AgentState> =
        rollout.states.iter().map(|row| row.get(cbv.0).copied().flatten()).collect::<Option<_>>()?;
    let mut tokens = Vec::new();
    for k in (0..states.len().saturating_sub(1)).step_by(TOKEN_PERIOD_STEPS) {
        let from = KinematicState::from_agent_state(&states[k]);
        let period = &states[k + 1..(k + 1 + TOKEN_PERIOD_STEPS).min(states.len())];
        tokens.push((0..VOCABULARY_SIZE as u16).map(Token).find(|&t| TokenGrid::reproduces(&from, t, period))?);
    }
    Some(tokens)
}

/// The CBV's states under `script` from `cbv_start` at `start` (one per
/// step, the first being `cbv_start`), and their deviation from the
/// recording.
fn cbv_path(
    scenario: &Scenario,
    cbv: TrackIndex,
    start: usize,
    cbv_start: AgentState,
    script: &[Choice],
) -> (Vec<Option<AgentState>>, Deviation) {
    let recorded = |step: usize| scenario.track(cbv).state(step);
    let mut state = KinematicState::from_agent_state(&cbv_start);
    let mut path = vec![Some(cbv_start)];
    let mut adversarial_tokens = 0;
    for (k, choice) in script.iter().enumerate() {
        let first = start + k * TOKEN_PERIOD_STEPS + 1;
        let log: Vec<Option<&AgentState>> = (first..first + TOKEN_PERIOD_STEPS).map(recorded).collect();
        let log_token = best_token(&state, &log);
        let token = match choice {
            Choice::Variant(t) => *t,
            Choice::Log => log_token,
        };
        adversarial_tokens += usize::from(token != log_token);
        for s in TokenGrid::rollout(&state, token) {
            path.push(Some(s.to_agent_state()));
            state = s;
        }
    }
    let max_distance_m = path
        .iter()
        .enumerate()
        .filter_map(|(k, s)| Some((s.as_ref()?.position - recorded(start + k)?.position).norm()))
        .fold(0.0, f64::max);
    (path, Deviation { adversarial_tokens, max_distance_m })
}
