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
//! traffic witness finds escapable (avoidable) is the shrunk variant.
//!
//! Deviation is measured by the number of adversarial tokens (periods
//! whose token differs from the log's there) and the largest distance of
//! the CBV from its recorded path, m.

use std::time::Instant;

use super::HarnessError;
use super::acceptance::{self, AcceptanceFailure};
use super::metrics::{cbv_background_collisions, cbv_off_road_s};
use super::pipeline::{self, Stage2Cbv, VariantSetup};
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
}

/// Shrinks `variant` with at most `budget` candidate rollouts; `None` when
/// its CBV's path is not made of tokens (it was absent at some step), or
/// not even the variant's own script is found escapable.
pub fn shrink(variant: &FailingVariant<'_>, budget: usize) -> Result<Option<Shrunk>, HarnessError> {
    let clock = Instant::now();
    let scenario: &Scenario = variant.setup.scenario;
    let (Some(cbv), Some(first_failure)) = (variant.stage2.cbv, variant.failures.first()) else { return Ok(None) };
    let Some(tokens) = driven_tokens(variant.stage2, cbv) else { return Ok(None) };
    let periods = variant.stage1.states.len().saturating_sub(1).div_ceil(TOKEN_PERIOD_STEPS);
    // The variant's tokens, then the log's where its stage 2 ended early.
    let original: Vec<Choice> =
        (0..periods).map(|k| tokens.get(k).map_or(Choice::Log, |&t| Choice::Variant(t))).collect();
    let start = variant.stage1.start_step;
    let Some(cbv_start) = variant.stage2.states.first().and_then(|row| row[cbv.0]) else { return Ok(None) };
    let path_of = |script: &[Choice]| cbv_path(scenario, cbv, start, cbv_start, script);
    let collided_with = |r: &Rollout| r.summary().ego_collision.map(|c| c.other);
    let baseline_off_road = cbv_off_road_s(scenario, variant.stage2);
    let baseline_at_fault =
        cbv_background_collisions(scenario, variant.stage2).into_iter().filter(|c| c.at_fault).count();
    let setup = VariantSetup { stage2_cbv: Stage2Cbv::Replay, escape: None, ..variant.setup };
    let candidates = std::cell::Cell::new(0);
    // Plays `script`; the rollout and failures when it fails as the variant did.
    let fails_alike = |script: &[Choice]| -> Result<Option<(Rollout, Vec<AcceptanceFailure>)>, HarnessError> {
        candidates.set(candidates.get() + 1);
        let (path, _) = path_of(script);
        let mut stage1 = variant.stage1.clone();
        for (row, state) in stage1.states.iter_mut().zip(&path) {
            row[cbv.0] = *state;
        }
        let played = pipeline::play_stage2(&setup, &stage1)?;
        let stage2 = played.stage2;
        let failures = acceptance::check(variant.criteria, &stage2, scenario, min_time_to_collision(&stage2), None);
        let same = failures.first().is_some_and(|f| f.criterion == first_failure.criterion)
            && collided_with(&stage2) == collided_with(variant.stage2);
        let plausible = cbv_off_road_s(scenario, &stage2) <= baseline_off_road
            && cbv_background_collisions(scenario, &stage2).into_iter().filter(|c| c.at_fault).count()
                <= baseline_at_fault;
        Ok((same && plausible).then_some((stage2, failures)))
    };

    // Kept scripts, each smaller than the one before.
    let mut kept: Vec<(Vec<Choice>, Rollout, Vec<AcceptanceFailure>)> = Vec::new();
    let Some((stage2, failures)) = fails_alike(&original)? else { return Ok(None) };
    kept.push((original.clone(), stage2, failures));
    // Engage later: the longest log prefix that still fails alike.
    let with_prefix = |k: usize| -> Vec<Choice> {
        original.iter().enumerate().map(|(i, c)| if i < k { Choice::Log } else { *c }).collect()
    };
    let (mut lo, mut hi) = (0, periods);
    while lo < hi && candidates.get() < budget {
        let mid = (lo + hi).div_ceil(2);
        let script = with_prefix(mid);
        match fails_alike(&script)? {
            Some((stage2, failures)) => {
                lo = mid;
                kept.push((script, stage2, failures));
            }
            None => hi = mid - 1,
        }
    }
    // Fewer adversarial tokens: each remaining one given back to the log.
    let mut script = kept.last().map(|k| k.0.clone()).unwrap_or_default();
    for i in 0..periods {
        if candidates.get() >= budget {
            break;
        }
        if script[i] == Choice::Log {
            continue;
        }
        let mut candidate = script.clone();
        candidate[i] = Choice::Log;
        if let Some((stage2, failures)) = fails_alike(&candidate)? {
            script = candidate.clone();
            kept.push((candidate, stage2, failures));
        }
    }
    // The smallest kept script whose conflict has an escape.
    let escape_from =
        |r: &Rollout| match search_rollout_witness(scenario, r, RoadKeeping::Centre, WitnessBudget::default()) {
            Witness::Found { trajectory, min_clearance_m, .. } => Some((trajectory, min_clearance_m)),
            Witness::NoneWithinBudget { .. } => None,
        };
    let Some(((script, stage2, failures), (escape, escape_clearance_m))) =
        kept.into_iter().rev().find_map(|k| escape_from(&k.1).map(|e| (k, e)))
    else {
        return Ok(None);
    };
    let before = path_of(&original).1;
    let after = path_of(&script).1;
    Ok(Some(Shrunk {
        stage2,
        failures,
        before,
        after,
        tokens_changed: original.iter().zip(&script).filter(|(a, b)| a != b).count(),
        candidates: candidates.get(),
        time_s: clock.elapsed().as_secs_f64(),
        escape,
        escape_clearance_m,
    }))
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
