//! Mutation testing of a suite: would it notice a broken planner? Each
//! [`FaultOperator`] plants one fault between the planner under test and the
//! simulator ([`crate::planners::mutant`]); the mutant drives stage 2 of
//! every variant again, on the variant's own stage 1 (the CBV's attack is
//! made once and shared), and is checked against the same criteria.
//!
//! A mutant is **killed** when some variant that the unmutated planner
//! passes is failed by the mutant, on any criterion. The **mutation score**
//! is killed mutants over all mutants. A surviving mutant is a blind spot
//! of the suite, reported with a hint of the scene that would catch it.
//! The one rule behind `safer run --mutants`, the `mutation_score` test of
//! the cargo-test runner and the review page.

use serde::Serialize;

use super::acceptance::{self, AcceptanceFailure};
use super::metrics::MUTATION_SCORE;
use super::pipeline::{self, VariantSetup};
use super::variant::VariantInputs;
use super::{HarnessError, MetricCheck, Suite, SuiteScenario, VariantOutcome};
use crate::eval::escape::CollisionEscape;
use crate::eval::min_time_to_collision;
use crate::geometry::Point2;
use crate::planners::FaultOperator;
use crate::sim::Rollout;
use crate::spec::suite::{SuiteAcceptance, VariantAcceptance};

/// How far a mutant's ego may be from the planner's ego at the same step,
/// m, and still count as driving as the planner drove: a centimetre, far
/// below anything a fault does once it comes into play, far above
/// rounding (a fault that never changes the planner's answer leaves the
/// path exactly as it was, the simulation being deterministic).
pub const SAME_DRIVING_M: f64 = 0.01;

/// Whether the ego of `mutant` (stage 2 with a fault planted) drove
/// otherwise than the ego of `planner` (the same stage 2 unmutated): it
/// was farther than [`SAME_DRIVING_M`] from it at some step, or present at
/// a step where the other was not (a rollout that ended sooner or later).
pub fn drove_differently(planner: &Rollout, mutant: &Rollout) -> bool {
    let ego = planner.ego.0;
    if planner.states.len() != mutant.states.len() {
        return true;
    }
    planner.states.iter().zip(&mutant.states).any(|(a, b)| {
        match (a.get(ego).copied().flatten(), b.get(ego).copied().flatten()) {
            // A NaN distance is no sameness.
            (Some(a), Some(b)) => {
                (a.position - b.position).norm().partial_cmp(&SAME_DRIVING_M).is_none_or(|o| o.is_gt())
            }
            (None, None) => false,
            _ => true,
        }
    })
}

/// How far a mutant's path may be from the planner's, m, and still be the
/// planner's way driven with other controls: its lane keeping retuned
/// (`no-evade`, the harness's lane keeping in place of the planner's,
/// moved the lane follower's ego 0.12 m on the shipped NGSIM scenes and
/// the evasive planner's 0.42 m on the authored ones), not a swerve (the
/// evasive planner's least aims half a lane, 1.75 m, aside).
pub const OFF_PATH_M: f64 = 0.5;

/// How far apart the ways of the egos of `planner` and `mutant` were, m:
/// the largest distance from either ego at any step to the path the other
/// drove (its positions joined step to step, carried on straight past
/// both ends), sideways, whenever each was there. A mutant that drove the
/// same way faster or slower, or on past where the planner stopped, is
/// 0 m off it; one that kept its lane where the planner swerved is as far
/// off as the swerve. `None` when either ego has no state, or a position
/// is not finite.
pub fn path_departure_m(planner: &Rollout, mutant: &Rollout) -> Option<f64> {
    let ego_positions = |r: &Rollout| -> Vec<Point2> {
        r.states.iter().filter_map(|step| step.get(r.ego.0).copied().flatten()).map(|s| s.position).collect()
    };
    let (planned, driven) = (ego_positions(planner), ego_positions(mutant));
    if planned.is_empty()
        || driven.is_empty()
        || planned.iter().chain(&driven).any(|p| !(p.x.is_finite() && p.y.is_finite()))
    {
        return None;
    }
    Some(farthest_from_path_m(&driven, &planned).max(farthest_from_path_m(&planned, &driven)))
}

/// The largest distance, m, from any of `points` to the path through
/// `path` (joined point to point, carried on straight past both ends; a
/// path that never moved is its one point). Both are non-empty and finite.
fn farthest_from_path_m(points: &[Point2], path: &[Point2]) -> f64 {
    // A step where the ego stood adds no segment: one of no length has no
    // direction to project on.
    let segments: Vec<[Point2; 2]> = path.windows(2).filter(|w| w[0] != w[1]).map(|w| [w[0], w[1]]).collect();
    let distance_m = |p: &Point2| {
        let Some(last) = segments.len().checked_sub(1) else { return (p - path[0]).norm() };
        segments
            .iter()
            .enumerate()
            .map(|(i, [a, b])| {
                let ab = b - a;
                // The first and the last segment run on past their ends.
                let (from, to) =
                    (if i == 0 { f64::NEG_INFINITY } else { 0.0 }, if i == last { f64::INFINITY } else { 1.0 });
                let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(from, to);
                (a + ab * t - p).norm_squared()
            })
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    };
    points.iter().map(distance_m).fold(0.0, f64::max)
}

/// A mutant's result on one variant.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MutantRun {
    /// The fault planted.
    pub operator: FaultOperator,
    /// The criteria the mutant failed (empty: it passed), or why it could
    /// not run.
    pub failures: Result<Vec<AcceptanceFailure>, String>,
    /// Whether its ego drove otherwise than the planner's
    /// ([`drove_differently`]); `false` when it could not run.
    pub drove_differently: bool,
    /// How far its path left the planner's ([`path_departure_m`]);
    /// `None` when it could not run.
    pub path_departure_m: Option<f64>,
    /// How close its ego came to another road user, and the planner's ego
    /// in the same variant ([`StageGaps`]); `None` when it could not run.
    pub gaps: Option<StageGaps>,
}

/// The closest box gap of the ego to any other road user in stage 2, m,
/// of a mutant and of the unmutated planner in the same variant: how near
/// a variant the mutant passed came to catching it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StageGaps {
    /// The mutant's ego, m (0 at a contact).
    pub mutant_m: f64,
    /// The planner's ego, m.
    pub planner_m: f64,
}

impl StageGaps {
    /// The gaps of `mutant` and `planner` (the same variant's stage 2);
    /// `None` where either rollout holds no other road user.
    pub fn of(planner: &Rollout, mutant: &Rollout) -> Option<Self> {
        let gap = |r: &Rollout| r.min_distance_to_ego.map(|c| c.distance_m).filter(|d| d.is_finite());
        Some(Self { mutant_m: gap(mutant)?, planner_m: gap(planner)? })
    }

    /// Whether the mutant came closer to another road user than the
    /// planner did, by more than [`SAME_DRIVING_M`]: the fault ate into
    /// the planner's margin.
    pub fn closer(&self) -> bool {
        self.mutant_m < self.planner_m - SAME_DRIVING_M
    }
}

impl MutantRun {
    /// Whether the mutant failed a criterion.
    pub fn failed(&self) -> bool {
        self.failures.as_ref().is_ok_and(|f| !f.is_empty())
    }
}

/// A mutant's stage 2 judged.
#[derive(Debug, Clone, PartialEq)]
pub struct MutantJudgement {
    /// The criteria it failed (empty: it passed).
    pub failures: Vec<AcceptanceFailure>,
    /// Its ego collided with the CBV.
    pub hit_cbv: bool,
    /// Its ego drove otherwise than the planner's ([`drove_differently`]).
    pub drove_differently: bool,
    /// How far its path left the planner's ([`path_departure_m`]).
    pub path_departure_m: Option<f64>,
    /// How close it and the planner came to another road user ([`StageGaps::of`]).
    pub gaps: Option<StageGaps>,
}

/// Stage 2 of `setup` played with `operator` planted, after `stage1`, and
/// judged by `criteria` as the unmutated planner is (the closed-loop
/// witness too, for a collision); `planner_stage2` is the unmutated
/// planner's stage 2, which the mutant's driving is compared with.
pub fn judge_mutant(
    setup: &VariantSetup<'_>,
    stage1: &Rollout,
    planner_stage2: &Rollout,
    criteria: &VariantAcceptance,
    operator: FaultOperator,
) -> Result<MutantJudgement, HarnessError> {
    let setup = VariantSetup { fault: Some(operator), ..*setup };
    let played = pipeline::play_stage2(&setup, stage1)?;
    let escape =
        pipeline::stage2_witness(&setup, stage1, &played.stage2, |stage2| acceptance::asks_witness(criteria, stage2))?;
    let min_ttc = min_time_to_collision(&played.stage2);
    let escape = escape.as_ref().map(CollisionEscape::of);
    Ok(MutantJudgement {
        failures: acceptance::check(criteria, &played.stage2, setup.scenario, min_ttc, escape),
        hit_cbv: played.stage2.summary().ego_collision.is_some_and(|c| c.with_cbv),
        drove_differently: drove_differently(planner_stage2, &played.stage2),
        path_departure_m: path_departure_m(planner_stage2, &played.stage2),
        gaps: StageGaps::of(planner_stage2, &played.stage2),
    })
}

/// The mutants of `operators` on variant `index` of `scenario`, whose
/// unmutated outcome is `base` (its stage 1 is reused, not made again).
/// A variant the planner does not pass cannot kill a mutant, so its
/// mutants are not run.
pub fn run_mutants(
    suite: &Suite,
    scenario: &SuiteScenario,
    index: u32,
    base: &VariantOutcome,
    operators: &[FaultOperator],
) -> Vec<MutantRun> {
    if !base.failures.is_empty() {
        return Vec::new();
    }
    let inputs = match VariantInputs::of(suite, scenario, index) {
        Ok(i) => i,
        Err(e) => {
            let why = e.to_string();
            return operators
                .iter()
                .map(|&operator| MutantRun {
                    operator,
                    failures: Err(why.clone()),
                    drove_differently: false,
                    path_departure_m: None,
                    gaps: None,
                })
                .collect();
        }
    };
    let setup = inputs.setup(suite);
    let criteria = &suite.spec.value.acceptance.variant;
    operators
        .iter()
        .map(|&operator| match judge_mutant(&setup, &base.stage1, &base.stage2, criteria, operator) {
            Ok(j) => MutantRun {
                operator,
                failures: Ok(j.failures),
                drove_differently: j.drove_differently,
                path_departure_m: j.path_departure_m,
                gaps: j.gaps,
            },
            Err(e) => MutantRun {
                operator,
                failures: Err(e.to_string()),
                drove_differently: false,
                path_departure_m: None,
                gaps: None,
            },
        })
        .collect()
}

/// The operators a suite's mutation run plants: `requested` when given
/// (`safer run --mutants`), else the suite's `mutation_operators` when it
/// asks for a mutation score, else none.
pub fn operators_for(acceptance: &SuiteAcceptance, requested: Option<&[FaultOperator]>) -> Vec<FaultOperator> {
    match requested {
        Some(ops) => ops.to_vec(),
        None if acceptance.mutation_score_min.is_some() => {
            acceptance.mutation_operators.clone().unwrap_or_else(|| FaultOperator::ALL.to_vec())
        }
        None => Vec::new(),
    }
}

/// A variant that killed a mutant, and how.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Kill {
    /// `suite::scenario::seed-k`.
    pub variant: String,
    /// The first criterion the mutant failed there.
    pub criterion: String,
    /// What happened, in words.
    pub what: String,
}

/// One operator's result over a suite.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OperatorResult {
    /// The fault.
    pub operator: FaultOperator,
    /// What it does, in one sentence.
    pub description: &'static str,
    /// Whether some variant killed it.
    pub killed: bool,
    /// The variants that killed it (the planner passes them, the mutant
    /// fails them), in report order.
    pub kills: Vec<Kill>,
    /// Variants where the mutant could not run, with why.
    pub errors: Vec<(String, String)>,
    /// Of the variants the planner passes and the mutant ran, those where
    /// its ego drove otherwise than the planner's ([`drove_differently`]).
    /// A survivor with none never had its fault come into play: no
    /// variant asked for what the fault breaks.
    pub variants_driven_differently: usize,
    /// Variants the planner passes where the mutant ran.
    pub variants_run: usize,
    /// The farthest its path left the planner's over those variants
    /// ([`path_departure_m`]); `None` when none measured it.
    pub largest_path_departure_m: Option<f64>,
    /// Of the variants it passed where its ego came closer to another
    /// road user than the planner's did ([`StageGaps::closer`]), the one
    /// where it came closest: where the suite came nearest to catching it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub closest_call: Option<ClosestCall>,
    /// Of the variants it passed, those where both egos had another road
    /// user to measure a gap to (what [`Self::closest_call`] is chosen from).
    pub variants_gap_measured: usize,
    /// For a survivor: the kind of scene that would catch it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hint: Option<&'static str>,
}

impl OperatorResult {
    /// A survivor's verdict after "SURVIVED": whether its fault ever
    /// changed the driving (and in how many variants), then the hint. A
    /// fault that changes only the steering has not come into play where
    /// its path kept within [`OFF_PATH_M`] of the planner's: the planner
    /// never steered off its way there.
    pub fn survivor_note(&self) -> String {
        let hint = self.operator.blind_spot_hint();
        let passed = |n: usize| if n == 1 { "the one variant".to_string() } else { format!("all {n} variants") };
        let kept_to_the_path = self.largest_path_departure_m.filter(|d| *d <= OFF_PATH_M);
        match (self.variants_run, self.variants_driven_differently, kept_to_the_path) {
            (0, _, _) => hint.to_string(),
            (n, 0, _) => format!(
                "it drove exactly as the planner in {} the planner passes: the fault never came into play; {hint}",
                passed(n)
            ),
            (n, _, Some(d)) if self.operator.changes_only_the_steering() => format!(
                "its path kept within {d:.2} m of the planner's in {} the planner passes: the planner never steered off its way, so the fault, which changes only the steering, never came into play (no scene can catch it if the planner never steers around anything); {hint}",
                passed(n)
            ),
            (n, k, _) => {
                let closest = match (&self.closest_call, self.variants_gap_measured) {
                    (Some(c), _) => format!(
                        " (its closest call: {:.2} m from another road user in {}, where the planner kept {:.2} m)",
                        c.gaps.mutant_m, c.variant, c.gaps.planner_m
                    ),
                    // No other road user to measure a gap to.
                    (None, 0) => String::new(),
                    (None, _) => " (in none did it come closer to another road user than the planner)".to_string(),
                };
                format!(
                    "it drove otherwise than the planner in {k} of {n} variants, and passed them all{closest}; {hint}"
                )
            }
        }
    }
}

/// The variant a mutant passed where its ego came closest to another
/// road user, beside how close the planner came there.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClosestCall {
    /// `suite::scenario::seed-k`.
    pub variant: String,
    /// The gaps there.
    pub gaps: StageGaps,
}

/// A suite's mutation run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MutationReport {
    /// Variants the suite has.
    pub variants: usize,
    /// Of which the unmutated planner passes (only these can kill).
    pub variants_passed: usize,
    /// Variants that could not run unmutated (the report is then
    /// incomplete, and the score check fails).
    pub variants_errored: usize,
    /// Per operator, in the order they were asked for.
    pub operators: Vec<OperatorResult>,
    /// Killed mutants.
    pub killed: usize,
    /// Killed mutants over all mutants; `None` with no mutant.
    pub score: Option<f64>,
}

impl MutationReport {
    /// The report of `operators` over a suite's variants, each given as
    /// its name, the criteria the unmutated planner failed there (`None`:
    /// it could not run; empty: it passed) and its mutants' runs.
    pub fn of<'a>(
        operators: &[FaultOperator],
        variants: impl IntoIterator<Item = (&'a str, Option<&'a [AcceptanceFailure]>, &'a [MutantRun])>,
    ) -> MutationReport {
        let mut results: Vec<OperatorResult> = operators
            .iter()
            .map(|&operator| OperatorResult {
                operator,
                description: operator.describe(),
                killed: false,
                kills: Vec::new(),
                errors: Vec::new(),
                variants_driven_differently: 0,
                variants_run: 0,
                largest_path_departure_m: None,
                closest_call: None,
                variants_gap_measured: 0,
                hint: None,
            })
            .collect();
        let (mut n, mut passed, mut errored) = (0, 0, 0);
        for (name, base, mutants) in variants {
            n += 1;
            match base {
                Some([]) => passed += 1,
                Some(_) => continue,
                None => {
                    errored += 1;
                    continue;
                }
            }
            for run in mutants {
                let Some(result) = results.iter_mut().find(|r| r.operator == run.operator) else { continue };
                match &run.failures {
                    Ok(failures) => {
                        result.variants_run += 1;
                        result.variants_driven_differently += usize::from(run.drove_differently);
                        if let Some(d) = run.path_departure_m {
                            result.largest_path_departure_m =
                                Some(result.largest_path_departure_m.map_or(d, |l| l.max(d)));
                        }
                        let passed_gaps = run.gaps.filter(|_| failures.is_empty());
                        result.variants_gap_measured += usize::from(passed_gaps.is_some());
                        if let Some(gaps) = passed_gaps.filter(StageGaps::closer) {
                            // The first variant of the least gap, in report order.
                            if result.closest_call.as_ref().is_none_or(|c| gaps.mutant_m < c.gaps.mutant_m) {
                                result.closest_call = Some(ClosestCall { variant: name.to_string(), gaps });
                            }
                        }
                        if let Some(first) = failures.first() {
                            result.kills.push(Kill {
                                variant: name.to_string(),
                                criterion: first.criterion.clone(),
                                what: first.what.clone(),
                            });
                        }
                    }
                    Err(e) => result.errors.push((name.to_string(), e.clone())),
                }
            }
        }
        for r in &mut results {
            r.killed = !r.kills.is_empty();
            r.hint = (!r.killed).then(|| r.operator.blind_spot_hint());
        }
        let killed = results.iter().filter(|r| r.killed).count();
        MutationReport {
            variants: n,
            variants_passed: passed,
            variants_errored: errored,
            score: (!results.is_empty()).then(|| killed as f64 / results.len() as f64),
            killed,
            operators: results,
        }
    }

    /// The surviving operators.
    pub fn survivors(&self) -> impl Iterator<Item = &OperatorResult> {
        self.operators.iter().filter(|r| !r.killed)
    }

    /// "mutation score 0.714 (5 of 7 mutants killed, over 9 variants the planner passes of 12)".
    pub fn headline(&self) -> String {
        let score = self.score.map_or_else(|| "-".to_string(), |s| format!("{s:.3}"));
        format!(
            "mutation score {score} ({} of {} mutants killed, over the {} of {} variants the planner passes)",
            self.killed,
            self.operators.len(),
            self.variants_passed,
            self.variants
        )
    }

    /// One line per operator: killed (by how many variants, the first of
    /// them and how) or survived (with the hint).
    pub fn table(&self) -> Vec<String> {
        let width = self.operators.iter().map(|r| r.operator.name().len()).max().unwrap_or(0);
        self.operators
            .iter()
            .map(|r| {
                let errors = if r.errors.is_empty() {
                    String::new()
                } else {
                    format!(" ({} could not run: {})", r.errors.len(), r.errors[0].1)
                };
                match r.kills.first() {
                    Some(k) => format!(
                        "{:<width$}  killed by {} of {} variants; first {}: {}: {}{errors}",
                        r.operator.name(),
                        r.kills.len(),
                        self.variants_passed,
                        k.variant,
                        k.criterion,
                        k.what
                    ),
                    None => format!("{:<width$}  SURVIVED: {}{errors}", r.operator.name(), r.survivor_note()),
                }
            })
            .collect()
    }

    /// The `mutation_score` check of `acceptance` on this run (`None` when
    /// the suite sets no `mutation_score_min`): fails below the bound, and
    /// fails as unmeasured when a variant could not run, when the planner
    /// passes no variant (no mutant can be killed there) or when no mutant
    /// ran. Without a run at all, [`super::metrics::suite_verdict`] fails it.
    pub fn check(&self, acceptance: &SuiteAcceptance) -> Option<MetricCheck> {
        let min = acceptance.mutation_score_min?;
        let unmeasured = |why: String| Some(MetricCheck { name: MUTATION_SCORE, value: None, result: Err(why) });
        let report = self;
        if report.variants_errored > 0 {
            return unmeasured(format!(
                "mutation_score could not be measured: {} of {} variants could not run",
                report.variants_errored, report.variants
            ));
        }
        if report.variants_passed == 0 {
            return unmeasured(format!(
                "mutation_score could not be measured: the planner passes none of the {} variants, so no mutant can be killed",
                report.variants
            ));
        }
        let Some(score) = report.score else {
            return unmeasured("mutation_score could not be measured: no fault operator was named".into());
        };
        let result = if score < min || min.is_nan() {
            let names: Vec<&str> = report.survivors().map(|r| r.operator.name()).collect();
            Err(format!(
                "mutation_score = {score:.3} < {min}: {} of {} mutants survived ({})",
                names.len(),
                report.operators.len(),
                names.join(", ")
            ))
        } else {
            Ok(())
        };
        Some(MetricCheck { name: MUTATION_SCORE, value: Some(score), result })
    }
}

/// The criteria `safer evaluate --mutants` judges the planner and its
/// mutants by: no collision the ego caused (nuPlan's at-fault rule: the
/// recorded background cannot avoid the ego), no leaving the road, and, as
/// always, an answer at every step inside the vehicle limits.
pub fn evaluation_criteria() -> VariantAcceptance {
    VariantAcceptance {
        no_collision: false,
        no_at_fault_collision: true,
        no_off_road: true,
        ..VariantAcceptance::default()
    }
}

/// One evaluation variant's mutation run.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct VariantMutation {
    /// The unmutated planner's first failed criterion (`None`: it passed,
    /// and the mutants were run).
    pub base_failure: Option<String>,
    /// Each mutant's result (none when the planner failed the variant).
    pub mutants: Vec<MutantRecord>,
}

impl VariantMutation {
    /// The variant's mutation run: `base` is the planner's own failures
    /// under the criteria; `judge` plays and judges one mutant.
    pub fn run(
        base: &[AcceptanceFailure],
        operators: &[FaultOperator],
        mut judge: impl FnMut(FaultOperator) -> Result<MutantJudgement, HarnessError>,
    ) -> VariantMutation {
        if let Some(first) = base.first() {
            return VariantMutation {
                base_failure: Some(format!("{}: {}", first.criterion, first.what)),
                mutants: vec![],
            };
        }
        let mutants = operators
            .iter()
            .map(|&operator| match judge(operator) {
                Ok(judged) => MutantRecord {
                    operator,
                    killed: !judged.failures.is_empty(),
                    failure: judged.failures.first().map(|f| format!("{}: {}", f.criterion, f.what)),
                    hit_cbv: judged.hit_cbv,
                    drove_differently: Some(judged.drove_differently),
                    path_departure_m: judged.path_departure_m,
                    error: None,
                },
                Err(e) => MutantRecord {
                    operator,
                    killed: false,
                    failure: None,
                    hit_cbv: false,
                    drove_differently: None,
                    path_departure_m: None,
                    error: Some(e.to_string()),
                },
            })
            .collect();
        VariantMutation { base_failure: None, mutants }
    }
}

impl VariantMutation {
    /// Whether `other` has the same results: the same failure of the
    /// planner and, mutant by mutant, the same verdict, failure, CBV hit,
    /// driving otherwise and error. How far a mutant's path was from the
    /// planner's is a measurement, not a result: a closed-loop CBV may
    /// drive a repeated variant's stage 2 a little otherwise.
    pub fn same_results(&self, other: &VariantMutation) -> bool {
        fn result(m: &MutantRecord) -> (FaultOperator, bool, &Option<String>, bool, Option<bool>, &Option<String>) {
            (m.operator, m.killed, &m.failure, m.hit_cbv, m.drove_differently, &m.error)
        }
        self.base_failure == other.base_failure
            && self.mutants.len() == other.mutants.len()
            && self.mutants.iter().zip(&other.mutants).all(|(a, b)| result(a) == result(b))
    }
}

/// A mutant on one evaluation variant.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct MutantRecord {
    /// The fault.
    pub operator: FaultOperator,
    /// The planner passed the variant and the mutant failed it.
    pub killed: bool,
    /// The mutant's first failed criterion.
    pub failure: Option<String>,
    /// The mutant's ego collided with the CBV (`false` in reports written
    /// before this was recorded).
    #[serde(default)]
    pub hit_cbv: bool,
    /// Whether the mutant's ego drove otherwise than the planner's
    /// ([`drove_differently`]); `None` when it could not run, and in
    /// reports written before this was recorded.
    #[serde(default)]
    pub drove_differently: Option<bool>,
    /// How far the mutant's path left the planner's
    /// ([`path_departure_m`]), m; `None` when it could not run, and in
    /// reports written before this was recorded.
    #[serde(default)]
    pub path_departure_m: Option<f64>,
    /// Why the mutant could not run.
    pub error: Option<String>,
}

/// How many mutants a method's variants kill: the measure an adversary is
/// judged by.
///
/// Kills are counted over *distinct* variants. A seed that repeats another
/// seed's variant of its scene (the same stage-1 CBV path, to the
/// centimetre, and the same mutation results) is one test run twice, not
/// two tests: log replay's seeds all repeat one variant, and counting each
/// would credit it once per seed with the same catch. The repeats are
/// reported in [`MethodKills::repeated_variants`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MethodKills {
    /// Distinct variants the unmutated planner passes (only these can kill).
    pub variants_passed: usize,
    /// Mutant-variants: distinct passed variants × operators.
    pub mutant_variants: usize,
    /// Mutant-variants killed (the planner passes, the mutant fails), each
    /// distinct variant once.
    pub kills: usize,
    /// (scene, fault) pairs caught: for each operator, the scenes where
    /// some variant killed it, summed over the operators.
    pub scene_kills: usize,
    /// Kills whose mutant collided with the CBV: the faults the CBV
    /// itself caught, not the recorded traffic or the road.
    pub cbv_kills: usize,
    /// Kills of a fault in a scene where log replay's variant does not
    /// kill it: the faults that replaying the recording misses (`None`
    /// when log replay was not run beside this method).
    pub beyond_replay: Option<usize>,
    /// Variants left out as repeats of a distinct one.
    pub repeated_variants: usize,
    /// Operators killed on at least one variant.
    pub mutants_killed: usize,
    /// Per operator.
    pub operators: Vec<OperatorKills>,
}

/// One operator's kills over a method's variants.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OperatorKills {
    /// The fault.
    pub operator: FaultOperator,
    /// Distinct variants that killed it.
    pub kills: usize,
    /// Scenes with at least one variant that killed it.
    pub scenes_killed: usize,
    /// Scenes with a variant the planner passes.
    pub scenes: usize,
    /// Distinct passed variants where its ego drove otherwise than the
    /// planner's ([`drove_differently`]); `None` when no run recorded it
    /// (reports written before it was). Zero: its fault never came into
    /// play, so it could not be killed there.
    pub variants_driven_differently: Option<usize>,
    /// Distinct passed variants where its path left the planner's by more
    /// than [`OFF_PATH_M`] ([`path_departure_m`]); `None` when no run
    /// recorded it (reports written before it was).
    pub variants_off_path: Option<usize>,
    /// The farthest its path left the planner's over those variants, m;
    /// `None` when no run recorded it.
    pub largest_path_departure_m: Option<f64>,
}

/// One variant's mutation run as [`MethodKills::of`] counts it.
#[derive(Debug, Clone, Copy)]
pub struct KillsInput<'a> {
    /// Its scene's id.
    pub scene: &'a str,
    /// The digest of its CBV's stage-1 path (`None`: no CBV path; never a
    /// repeat).
    pub cbv_path_digest: Option<u64>,
    /// The run.
    pub mutation: &'a VariantMutation,
}

/// The (scene, fault) pairs log replay's variants kill, for
/// [`MethodKills::beyond_replay`].
pub type ReplayCatches = std::collections::BTreeSet<(String, FaultOperator)>;

impl MethodKills {
    /// The (scene, fault) pairs that some variant of `variants` kills.
    pub fn catches<'a>(variants: impl IntoIterator<Item = KillsInput<'a>>) -> ReplayCatches {
        variants
            .into_iter()
            .filter(|v| v.mutation.base_failure.is_none())
            .flat_map(|v| v.mutation.mutants.iter().filter(|r| r.killed).map(|r| (v.scene.to_string(), r.operator)))
            .collect()
    }

    /// The kills of `variants`, repeats counted once; `None` when no
    /// variant carries a mutation run. With `replay`, the (scene, fault)
    /// pairs log replay kills ([`MethodKills::catches`] of its variants),
    /// the kills beyond them are counted too.
    pub fn of<'a>(
        variants: impl IntoIterator<Item = KillsInput<'a>>,
        replay: Option<&ReplayCatches>,
    ) -> Option<MethodKills> {
        use std::collections::{BTreeMap, BTreeSet};
        let mut any = false;
        let mut passed = 0;
        let mut repeated = 0;
        let mut cbv_kills = 0;
        let mut beyond_replay = 0;
        // The runs already counted, by (scene, CBV path).
        let mut seen: BTreeMap<(&str, u64), Vec<&VariantMutation>> = BTreeMap::new();
        let mut scenes: BTreeSet<&str> = BTreeSet::new();
        let mut per_op: BTreeMap<FaultOperator, (usize, BTreeSet<&str>)> = BTreeMap::new();
        let mut differently: BTreeMap<FaultOperator, Option<usize>> = BTreeMap::new();
        // Per operator: variants off the planner's path, and the farthest.
        let mut departures: BTreeMap<FaultOperator, (usize, f64)> = BTreeMap::new();
        for v in variants {
            any = true;
            if let Some(digest) = v.cbv_path_digest {
                let runs = seen.entry((v.scene, digest)).or_default();
                if runs.iter().any(|r| r.same_results(v.mutation)) {
                    repeated += 1;
                    continue;
                }
                runs.push(v.mutation);
            }
            if v.mutation.base_failure.is_some() {
                continue;
            }
            passed += 1;
            scenes.insert(v.scene);
            for r in &v.mutation.mutants {
                if let Some(d) = r.drove_differently {
                    *differently.entry(r.operator).or_default().get_or_insert(0) += usize::from(d);
                }
                if let Some(d) = r.path_departure_m {
                    let (off, farthest) = departures.entry(r.operator).or_insert((0, 0.0));
                    *off += usize::from(d > OFF_PATH_M);
                    *farthest = farthest.max(d);
                }
                let (kills, where_) = per_op.entry(r.operator).or_default();
                if r.killed {
                    *kills += 1;
                    cbv_kills += usize::from(r.hit_cbv);
                    beyond_replay +=
                        usize::from(replay.is_some_and(|c| !c.contains(&(v.scene.to_string(), r.operator))));
                    where_.insert(v.scene);
                }
            }
        }
        if !any {
            return None;
        }
        let operators: Vec<OperatorKills> = per_op
            .into_iter()
            .map(|(operator, (kills, where_))| OperatorKills {
                operator,
                kills,
                scenes_killed: where_.len(),
                scenes: scenes.len(),
                variants_driven_differently: differently.get(&operator).copied().flatten(),
                variants_off_path: departures.get(&operator).map(|(off, _)| *off),
                largest_path_departure_m: departures.get(&operator).map(|(_, farthest)| *farthest),
            })
            .collect();
        Some(MethodKills {
            variants_passed: passed,
            mutant_variants: passed * operators.len(),
            kills: operators.iter().map(|o| o.kills).sum(),
            scene_kills: operators.iter().map(|o| o.scenes_killed).sum(),
            cbv_kills,
            beyond_replay: replay.map(|_| beyond_replay),
            repeated_variants: repeated,
            mutants_killed: operators.iter().filter(|o| o.kills > 0).count(),
            operators,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn failure(criterion: &str) -> AcceptanceFailure {
        AcceptanceFailure { criterion: criterion.into(), what: "it happened".into() }
    }

    fn acceptance(min: f64) -> SuiteAcceptance {
        SuiteAcceptance { mutation_score_min: Some(min), ..SuiteAcceptance::default() }
    }

    #[test]
    fn a_check_without_a_bound_is_not_made_and_one_without_a_run_fails() {
        let report = MutationReport::of(&[FaultOperator::NoBrake], std::iter::empty());
        assert!(report.check(&SuiteAcceptance::default()).is_none());
        let ok = super::super::VariantTally::default();
        let (_, checks) =
            super::super::metrics::suite_verdict(&acceptance(0.5), [("s::a::seed-0".to_string(), Ok(&ok))], None);
        let c = checks.iter().find(|c| c.name == MUTATION_SCORE).unwrap();
        assert!(c.result.as_ref().unwrap_err().contains("not run"), "{c:?}");
    }

    #[test]
    fn thresholds_are_inclusive_and_survivors_are_named() {
        let report = MutationReport {
            variants: 2,
            variants_passed: 2,
            variants_errored: 0,
            operators: FaultOperator::ALL[..2]
                .iter()
                .map(|&operator| OperatorResult {
                    operator,
                    description: operator.describe(),
                    killed: operator == FaultOperator::NoBrake,
                    kills: Vec::new(),
                    errors: Vec::new(),
                    variants_driven_differently: 2,
                    variants_run: 2,
                    largest_path_departure_m: Some(1.0),
                    closest_call: None,
                    variants_gap_measured: 0,
                    hint: None,
                })
                .collect(),
            killed: 1,
            score: Some(0.5),
        };
        assert!(report.check(&acceptance(0.5)).unwrap().result.is_ok());
        let err = report.check(&acceptance(0.6)).unwrap().result.unwrap_err();
        assert!(err.contains("0.500 < 0.6") && err.contains("weak-brake") && !err.contains("no-brake"), "{err}");
        assert!(report.check(&acceptance(f64::NAN)).unwrap().result.is_err());
    }

    #[test]
    fn a_report_with_no_passing_variant_is_unmeasured() {
        let report = MutationReport::of(&[FaultOperator::NoBrake], std::iter::empty());
        assert_eq!((report.variants, report.killed, report.score), (0, 0, Some(0.0)));
        let err = report.check(&acceptance(0.0)).unwrap().result.unwrap_err();
        assert!(err.contains("passes none"), "{err}");
    }

    fn run(killed: &[bool]) -> VariantMutation {
        VariantMutation {
            base_failure: None,
            mutants: killed
                .iter()
                .zip(FaultOperator::ALL)
                .map(|(&killed, &operator)| MutantRecord {
                    operator,
                    killed,
                    failure: killed.then(|| "no_off_road: ego left the road at t = 2.0 s".into()),
                    hit_cbv: false,
                    drove_differently: Some(killed),
                    path_departure_m: Some(if killed { 2.0 } else { 0.0 }),
                    error: None,
                })
                .collect(),
        }
    }

    /// A rollout whose ego (agent 0) drives along x through `xs`, one
    /// step each, beside agent 1 standing at the origin.
    fn ego_along(xs: &[f64]) -> Rollout {
        use crate::geometry::{Point2, Vector2};
        let state = |x: f64| crate::scenario::AgentState {
            position: Point2::new(x, 0.0),
            heading_rad: 0.0,
            velocity_mps: Vector2::new(10.0, 0.0),
        };
        Rollout {
            scenario_id: "s".into(),
            dt_s: 0.1,
            start_step: 10,
            ego: crate::scenario::TrackIndex(0),
            cbv: None,
            agent_ids: vec![],
            bodies: vec![],
            states: xs.iter().map(|&x| vec![Some(state(x)), Some(state(0.0))]).collect(),
            collisions: vec![],
            off_road: vec![],
            min_distance_to_ego: None,
            termination: crate::sim::Termination::Completed,
            planner: "p".into(),
            planner_debug: vec![],
        }
    }

    #[test]
    fn a_mutant_drove_differently_when_its_ego_strayed_a_centimetre_or_its_rollout_ended_elsewhere() {
        let planner = ego_along(&[0.0, 1.0, 2.0]);
        assert!(!drove_differently(&planner, &ego_along(&[0.0, 1.0, 2.0])));
        assert!(!drove_differently(&planner, &ego_along(&[0.0, 1.0, 2.0 + 0.009])), "within a centimetre");
        assert!(drove_differently(&planner, &ego_along(&[0.0, 1.0 + 0.011, 2.0])));
        assert!(drove_differently(&planner, &ego_along(&[0.0, 1.0])), "ended a step sooner");
        assert!(drove_differently(&planner, &ego_along(&[0.0, f64::NAN, 2.0])), "a NaN is no sameness");
        let mut vanished = ego_along(&[0.0, 1.0, 2.0]);
        vanished.states[2][0] = None;
        assert!(drove_differently(&planner, &vanished));
    }

    /// A rollout whose ego (agent 0) drives through `points`, one a step.
    fn ego_through(points: &[(f64, f64)]) -> Rollout {
        let mut r = ego_along(&vec![0.0; points.len()]);
        for (step, &(x, y)) in r.states.iter_mut().zip(points) {
            step[0].as_mut().unwrap().position = crate::geometry::Point2::new(x, y);
        }
        r
    }

    #[test]
    fn a_mutant_departs_from_the_planners_path_by_its_farthest_distance_from_it_not_by_its_timing() {
        let planner = ego_along(&[0.0, 10.0, 20.0, 30.0]);
        // Faster along the same path, and on past its end: nothing.
        assert_eq!(path_departure_m(&planner, &ego_along(&[0.0, 12.0, 24.0, 36.0])), Some(0.0));
        // Slower and shorter, on the path throughout: nothing.
        assert_eq!(path_departure_m(&planner, &ego_along(&[0.0, 5.0])), Some(0.0));
        // A swerve of 1.75 m half way: 1.75, beyond OFF_PATH_M.
        let swerve = ego_through(&[(0.0, 0.0), (10.0, 1.0), (20.0, 1.75), (30.0, 0.0)]);
        let d = path_departure_m(&planner, &swerve).unwrap();
        assert!((d - 1.75).abs() < 1e-9 && d > OFF_PATH_M, "{d}");
        // Between two of the planner's points the path is the segment.
        let beside = ego_through(&[(5.0, 0.2), (25.0, 0.2)]);
        assert!(path_departure_m(&planner, &beside).is_some_and(|d| (d - 0.2).abs() < 1e-9));
        // Past the end and 0.4 m to the side of the path carried on.
        let beyond = ego_through(&[(0.0, 0.0), (45.0, 0.4)]);
        assert!(path_departure_m(&planner, &beyond).is_some_and(|d| (d - 0.4).abs() < 1e-9));
        // Keeping the lane where the planner swerved: as far as the swerve,
        // though each of the mutant's positions lies on the planner's path.
        let kept_lane = ego_along(&[0.0, 5.0, 10.0]);
        assert!(path_departure_m(&swerve, &kept_lane).is_some_and(|d| (d - 1.75).abs() < 1e-9));
        // A planner that stood still: the distance from where it stood.
        let stood = ego_along(&[3.0, 3.0]);
        assert!(path_departure_m(&stood, &ego_along(&[3.0, 7.0])).is_some_and(|d| (d - 4.0).abs() < 1e-9));
        // Nothing to compare, or a position that is not finite: unknown.
        let mut gone = ego_along(&[0.0]);
        gone.states[0][0] = None;
        assert_eq!(path_departure_m(&planner, &gone), None);
        assert_eq!(path_departure_m(&gone, &planner), None);
        assert_eq!(path_departure_m(&planner, &ego_along(&[0.0, f64::NAN])), None);
    }

    #[test]
    fn a_mutant_record_from_a_report_written_before_paths_were_measured_reads_as_unmeasured() {
        let old = r#"{"operator": "no-evade", "killed": false, "failure": null, "hit_cbv": false, "drove_differently": true, "error": null}"#;
        let record: MutantRecord = serde_json::from_str(old).unwrap();
        assert_eq!((record.drove_differently, record.path_departure_m), (Some(true), None));
        let now = serde_json::to_value(MutantRecord { path_departure_m: Some(0.25), ..record }).unwrap();
        assert_eq!(now["path_departure_m"], 0.25);
    }

    #[test]
    fn a_steering_fault_that_kept_to_the_planners_path_never_came_into_play() {
        let passed: &[AcceptanceFailure] = &[];
        let ran = |operator, path_departure_m| MutantRun {
            operator,
            failures: Ok(vec![]),
            drove_differently: true,
            path_departure_m: Some(path_departure_m),
            gaps: None,
        };
        let note = |operator, departures: [f64; 2]| {
            let runs = [[ran(operator, departures[0])], [ran(operator, departures[1])]];
            let report = MutationReport::of(
                &[operator],
                [("s::a::seed-0", Some(passed), &runs[0][..]), ("s::b::seed-0", Some(passed), &runs[1][..])],
            );
            assert_eq!(report.operators[0].largest_path_departure_m, Some(departures[0].max(departures[1])));
            report.operators[0].survivor_note()
        };
        // no-evade's lane keeping a few centimetres off the planner's: the
        // planner never steered off its way.
        let kept = note(FaultOperator::NoEvade, [0.12, 0.5]);
        assert!(
            kept.starts_with("its path kept within 0.50 m of the planner's in all 2 variants the planner passes: the planner never steered off its way, so the fault, which changes only the steering, never came into play"),
            "{kept}"
        );
        // Once it left the path by more, the fault was in play and missed.
        let missed = note(FaultOperator::NoEvade, [0.12, 0.51]);
        assert!(
            missed.starts_with("it drove otherwise than the planner in 2 of 2 variants, and passed them all; "),
            "{missed}"
        );
        // A fault that changes the speed keeps to the path and is in play.
        let speeding = note(FaultOperator::Speeding, [0.0, 0.1]);
        assert!(speeding.starts_with("it drove otherwise than the planner in 2 of 2 variants"), "{speeding}");
    }

    #[test]
    fn a_survivor_says_whether_its_fault_ever_changed_the_driving() {
        let ran = |operator, drove_differently| MutantRun {
            operator,
            failures: Ok(vec![]),
            drove_differently,
            path_departure_m: Some(if drove_differently { 1.0 } else { 0.0 }),
            gaps: None,
        };
        let killed = |operator| MutantRun {
            operator,
            failures: Ok(vec![failure("no_collision")]),
            drove_differently: true,
            path_departure_m: Some(1.0),
            gaps: None,
        };
        let passed: &[AcceptanceFailure] = &[];
        let runs_a =
            [ran(FaultOperator::NoBrake, false), ran(FaultOperator::NoEvade, true), killed(FaultOperator::Late)];
        let runs_b =
            [ran(FaultOperator::NoBrake, false), ran(FaultOperator::NoEvade, false), ran(FaultOperator::Late, true)];
        let ops = [FaultOperator::NoBrake, FaultOperator::NoEvade, FaultOperator::Late];
        let report = MutationReport::of(
            &ops,
            [("s::a::seed-0", Some(passed), &runs_a[..]), ("s::b::seed-0", Some(passed), &runs_b[..])],
        );
        let by = |op| report.operators.iter().find(|r| r.operator == op).unwrap();
        assert_eq!(
            (by(FaultOperator::NoBrake).variants_run, by(FaultOperator::NoBrake).variants_driven_differently),
            (2, 0)
        );
        assert_eq!(by(FaultOperator::NoEvade).variants_driven_differently, 1);
        assert_eq!(by(FaultOperator::Late).variants_driven_differently, 2);
        let table = report.table().join("\n");
        assert!(table.contains("no-brake  SURVIVED: it drove exactly as the planner in all 2 variants the planner passes: the fault never came into play; "), "{table}");
        assert!(
            table.contains(
                "no-evade  SURVIVED: it drove otherwise than the planner in 1 of 2 variants, and passed them all; "
            ),
            "{table}"
        );
        assert!(table.contains("late      killed by 1 of 2 variants"), "{table}");
    }

    #[test]
    fn a_survivors_closest_call_is_the_passed_variant_where_it_came_nearest_to_another_road_user() {
        let run = |failures: Vec<AcceptanceFailure>, mutant_m, planner_m| MutantRun {
            operator: FaultOperator::Speeding,
            failures: Ok(failures),
            drove_differently: true,
            path_departure_m: Some(0.0),
            gaps: Some(StageGaps { mutant_m, planner_m }),
        };
        let passed: &[AcceptanceFailure] = &[];
        // The third came as close as the second, and closer than the
        // planner; the fourth came closest, but no closer than the planner.
        let runs =
            [[run(vec![], 0.9, 1.4)], [run(vec![], 0.31, 1.2)], [run(vec![], 0.31, 0.5)], [run(vec![], 0.2, 0.2)]];
        let variants = ["s::a::seed-0", "s::b::seed-0", "s::c::seed-0", "s::d::seed-0"];
        let report = MutationReport::of(
            &[FaultOperator::Speeding],
            variants.iter().zip(&runs).map(|(name, r)| (*name, Some(passed), &r[..])),
        );
        // The least gap, the first variant of it in report order.
        let call = report.operators[0].closest_call.clone().unwrap();
        assert_eq!((call.variant.as_str(), call.gaps.mutant_m, call.gaps.planner_m), ("s::b::seed-0", 0.31, 1.2));
        let note = report.operators[0].survivor_note();
        assert!(
            note.starts_with(
                "it drove otherwise than the planner in 4 of 4 variants, and passed them all (its closest call: 0.31 m \
                 from another road user in s::b::seed-0, where the planner kept 1.20 m); "
            ),
            "{note}"
        );
        // A variant that killed the mutant is no close call.
        let killing = [[run(vec![failure("no_collision")], 0.0, 1.0)], [run(vec![], 0.7, 0.8)]];
        let report = MutationReport::of(
            &[FaultOperator::Speeding],
            variants.iter().zip(&killing).map(|(name, r)| (*name, Some(passed), &r[..])),
        );
        assert_eq!(report.operators[0].closest_call.as_ref().map(|c| c.variant.as_str()), Some("s::b::seed-0"));
        // Without gaps (no other road user), or none closer than the
        // planner's, there is none to show, and the note says so.
        let none_closer = [[MutantRun { gaps: None, ..run(vec![], 0.0, 0.0) }], [run(vec![], 0.6, 0.605)]];
        let report = MutationReport::of(
            &[FaultOperator::Speeding],
            variants.iter().zip(&none_closer).map(|(name, r)| (*name, Some(passed), &r[..])),
        );
        assert!(report.operators[0].closest_call.is_none());
        let note = report.operators[0].survivor_note();
        assert!(
            note.contains("and passed them all (in none did it come closer to another road user than the planner); "),
            "{note}"
        );
    }

    #[test]
    fn a_seed_that_repeats_a_variant_counts_once_and_scene_kills_count_scene_fault_pairs() {
        let (first, mut other) = (run(&[true, false]), run(&[true, true]));
        other.mutants[1].hit_cbv = true;
        let mut measured_otherwise = first.clone();
        measured_otherwise.mutants[0].path_departure_m = Some(0.3);
        let failed = VariantMutation { base_failure: Some("no_off_road: x".into()), mutants: vec![] };
        let input = |scene, digest, mutation| KillsInput { scene, cbv_path_digest: digest, mutation };
        let variants = [
            // Log replay's three seeds of one scene: one variant.
            input("a", Some(1), &first),
            input("a", Some(1), &first),
            input("a", Some(1), &first),
            // A mutant's path measured otherwise is the same result.
            input("a", Some(1), &measured_otherwise),
            // The same path with other results is not a repeat; nor is
            // the same result on another path, or in another scene.
            input("a", Some(1), &other),
            input("a", Some(2), &first),
            input("b", Some(1), &first),
            // Without a path digest nothing is a repeat.
            input("c", None, &first),
            input("c", None, &first),
            // A repeated failure of the planner is left out, too.
            input("d", Some(3), &failed),
            input("d", Some(3), &failed),
        ];
        let kills = MethodKills::of(variants, None).unwrap();
        assert_eq!(kills.repeated_variants, 4);
        assert_eq!(kills.variants_passed, 6);
        assert_eq!(kills.mutant_variants, 12);
        // no-brake by all six, weak-brake by the one with other results.
        assert_eq!(kills.kills, 7);
        assert_eq!((kills.operators[0].kills, kills.operators[0].scenes_killed, kills.operators[0].scenes), (6, 3, 3));
        assert_eq!((kills.operators[1].kills, kills.operators[1].scenes_killed), (1, 1));
        assert_eq!(kills.scene_kills, 4);
        assert_eq!(kills.cbv_kills, 1);
        assert_eq!(kills.beyond_replay, None);
        // Drove otherwise where killed (as `run` makes them): no-brake in
        // all six distinct passed variants, weak-brake in the one.
        let differently: Vec<Option<usize>> = kills.operators.iter().map(|o| o.variants_driven_differently).collect();
        assert_eq!(differently, vec![Some(6), Some(1)]);
        // Off the planner's path (2 m where killed, on it elsewhere, as
        // `run` makes them) in the same distinct variants, 2 m at most.
        let off_path: Vec<(Option<usize>, Option<f64>)> =
            kills.operators.iter().map(|o| (o.variants_off_path, o.largest_path_departure_m)).collect();
        assert_eq!(off_path, vec![(Some(6), Some(2.0)), (Some(1), Some(2.0))]);
        // Reports written before it was recorded say nothing of it.
        let mut old = run(&[true]);
        old.mutants[0].drove_differently = None;
        old.mutants[0].path_departure_m = None;
        let unrecorded = MethodKills::of([input("a", Some(1), &old)], None).unwrap();
        assert_eq!(unrecorded.operators[0].variants_driven_differently, None);
        assert_eq!(
            (unrecorded.operators[0].variants_off_path, unrecorded.operators[0].largest_path_departure_m),
            (None, None)
        );
        assert_eq!(MethodKills::of(std::iter::empty(), None), None);
    }

    #[test]
    fn kills_beyond_replay_are_faults_in_scenes_where_log_replay_does_not_catch_them() {
        let input = |scene, digest, mutation| KillsInput { scene, cbv_path_digest: digest, mutation };
        // Log replay kills no-brake in scene a, nothing in b; its planner
        // fails scene c, where what the mutants did is no catch.
        let (no_brake, both, neither) = (run(&[true, false]), run(&[true, true]), run(&[false, false]));
        let failed = VariantMutation { base_failure: Some("no_collision: x".into()), ..run(&[true, true]) };
        let replay = MethodKills::catches([
            input("a", Some(1), &no_brake),
            input("b", Some(1), &neither),
            input("c", Some(1), &failed),
        ]);
        assert_eq!(replay, ReplayCatches::from([("a".to_string(), FaultOperator::ALL[0])]));
        let kills = MethodKills::of(
            [
                // Two variants of a catching both: weak-brake is new, twice.
                input("a", Some(2), &both),
                input("a", Some(3), &both),
                // In b and c both are new.
                input("b", Some(2), &both),
                input("c", Some(2), &no_brake),
            ],
            Some(&replay),
        )
        .unwrap();
        assert_eq!((kills.kills, kills.beyond_replay), (7, Some(5)));
        // Log replay's own kills are none beyond itself.
        let own = MethodKills::of([input("a", Some(1), &no_brake)], Some(&replay)).unwrap();
        assert_eq!(own.beyond_replay, Some(0));
    }

    #[test]
    fn mutant_runs_count_as_failed_only_with_a_failed_criterion() {
        let ran = |failures| MutantRun {
            operator: FaultOperator::Late,
            failures,
            drove_differently: true,
            path_departure_m: Some(1.0),
            gaps: None,
        };
        assert!(ran(Ok(vec![failure("no_collision")])).failed());
        assert!(!ran(Ok(vec![])).failed());
        assert!(!ran(Err("could not start".into())).failed());
    }
}
