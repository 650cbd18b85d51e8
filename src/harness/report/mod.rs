//! The results of running suites, as one value every report is written
//! from: `safer run`'s table and JSON, the JUnit XML of [`junit`]
//! and the review page of [`review_page`]. The cargo-test runner can
//! build the same value from the outcomes its trials computed.
//!
//! A suite that did not load is a [`SuiteLoadFailure`]; a suite that did is
//! a [`SuiteRun`]: its variants in report order (each a [`VariantRun`]: the
//! outcome or why it could not run, and the artefacts of a failing one)
//! and its suite-metric checks.

use std::path::PathBuf;

pub mod junit;
pub mod review_page;

use crate::harness::artefacts::Artefacts;
use crate::harness::{MetricCheck, SuiteMetrics, VariantOutcome};

/// Everything a run of suites produced.
#[derive(Debug, Clone, Default)]
pub struct RunResults {
    /// Suites that could not be loaded, in command-line order.
    pub load_failures: Vec<SuiteLoadFailure>,
    /// Suites that ran, in command-line order.
    pub suites: Vec<SuiteRun>,
}

impl RunResults {
    /// Every suite loaded and every selected variant and metric passed.
    pub fn passed(&self) -> bool {
        self.load_failures.is_empty() && self.suites.iter().all(SuiteRun::passed)
    }
}

/// A suite file that could not be loaded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SuiteLoadFailure {
    /// The suite file.
    pub file: PathBuf,
    /// Why, with the place in the file.
    pub message: String,
}

/// One suite's results.
#[derive(Debug, Clone)]
pub struct SuiteRun {
    /// The suite file.
    pub file: PathBuf,
    /// The suite's name in test names.
    pub name: String,
    /// The planner under test.
    pub planner: String,
    /// The selected variants, sorted by scenario name and seed number.
    pub variants: Vec<VariantRun>,
    /// The suite metrics; `None` when no metric was selected or a variant
    /// the metrics need could not run.
    pub metrics: Option<SuiteMetrics>,
    /// The selected suite-metric checks, in the spec's fixed order.
    pub checks: Vec<MetricCheck>,
    /// The suite's mutation run, when mutants were planted
    /// ([`crate::harness::mutation`]).
    pub mutation: Option<crate::harness::mutation::MutationReport>,
    /// Wall time of the suite, s: from its first variant's start to its
    /// last one's end (suites run side by side, so theirs overlap); `None`
    /// where the run did not measure it.
    pub wall_s: Option<f64>,
    /// What the suite's spec says that is valid but most likely not meant
    /// ([`crate::spec::SpecWarning`]), each as `PATH:LINE:COLUMN: message`:
    /// every report carries them, so a CI that reads only its reports sees
    /// them. They do not change the verdict.
    pub warnings: Vec<String>,
}

impl SuiteRun {
    /// Every variant passed and every check held.
    pub fn passed(&self) -> bool {
        self.variants.iter().all(VariantRun::passed) && self.checks.iter().all(|c| c.result.is_ok())
    }

    /// Whether the checks could not be computed because a variant they
    /// need did not run (each check then fails saying which).
    pub fn checks_unmeasured(&self) -> bool {
        self.metrics.is_none() && !self.checks.is_empty()
    }
}

/// One variant's result.
#[derive(Debug, Clone)]
pub struct VariantRun {
    /// `suite::scenario::seed-k`.
    pub name: String,
    /// What it produced, or why it could not run.
    pub outcome: Result<VariantOutcome, String>,
    /// The recording and picture of a failing variant, or why they could
    /// not be written; `None` for a passing variant (or when none were asked for).
    pub artefacts: Option<Result<Artefacts, String>>,
    /// How its summary compared with its stored snapshot.
    pub snapshot: SnapshotCheck,
    /// Wall time of the variant (its stages, shrink and mutants), s;
    /// `None` where the run did not measure it.
    pub wall_s: Option<f64>,
}

/// How a variant's summary compared with its stored insta snapshot: the
/// test runner compares (a difference fails the test, and so the variant
/// in every report), `safer run` does not.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum SnapshotCheck {
    /// Not compared (`safer run`, or a variant that could not run).
    #[default]
    NotCompared,
    /// The same as the stored snapshot.
    Matches,
    /// Different from the stored snapshot at this path.
    Differs(std::path::PathBuf),
    /// No snapshot stored yet at this path.
    New(std::path::PathBuf),
}

impl SnapshotCheck {
    /// Why the comparison fails the variant, or `None` when it does not.
    pub fn failure(&self) -> Option<String> {
        match self {
            Self::NotCompared | Self::Matches => None,
            Self::Differs(path) => Some(format!("the summary differs from its snapshot {}", path.display())),
            Self::New(path) => Some(format!("no snapshot accepted yet at {}", path.display())),
        }
    }
}

impl VariantRun {
    /// It ran, met every criterion, and matched its snapshot where one was
    /// compared: the test runner's verdict.
    pub fn passed(&self) -> bool {
        self.outcome.as_ref().is_ok_and(|o| o.failures.is_empty()) && self.snapshot.failure().is_none()
    }

    /// The name without the suite: `scenario::seed-k`.
    pub fn name_in_suite(&self) -> &str {
        self.name.split_once("::").map_or(self.name.as_str(), |(_, rest)| rest)
    }
}

/// Results built from the record layer's crossing fixture (the ego at
/// constant velocity hits the CBV), for the report writers' tests.
#[cfg(test)]
pub(crate) mod tests_support {
    use std::sync::Arc;

    use super::*;
    use crate::harness::{AcceptanceFailure, Stage2Verdict, VariantTally};
    use crate::record::test_support::{crossing_rollout, crossing_scenario};

    /// A variant of the crossing, failing `no_collision` when `failing`.
    pub(crate) fn crossing_outcome(name: &str, failing: bool) -> VariantOutcome {
        let scenario = Arc::new(crossing_scenario());
        let rollout = crossing_rollout(&scenario);
        let failures = if failing {
            vec![AcceptanceFailure {
                criterion: "no_collision".into(),
                what: "ego collided with agent cbv-2 at t = 3.9 s (front contact)".into(),
            }]
        } else {
            Vec::new()
        };
        VariantOutcome {
            name: name.into(),
            seed: 7,
            scenario,
            stage1: rollout.clone(),
            stage2: rollout,
            verdict: Stage2Verdict::Collided { time_s: 3.9 },
            min_ttc_s: Some(0.4),
            reach: crate::eval::ConflictReach { min_gap_to_cbv_m: Some(0.0), reached: true },
            escape: None,
            tally: VariantTally { critical: true, ..VariantTally::default() },
            failures,
            planner_latency: None,
            planner_stderr: None,
            shrunk: None,
            not_shrunk: None,
        }
    }

    /// A failing variant with artefacts under `out/`.
    pub(crate) fn failing_variant(suite: &str) -> VariantRun {
        let name = format!("{suite}::crossing::seed-1");
        VariantRun {
            outcome: Ok(crossing_outcome(&name, true)),
            artefacts: Some(Ok(Artefacts {
                mcap: format!("out/{suite}/crossing/seed-1.mcap").into(),
                svg: format!("out/{suite}/crossing/seed-1.svg").into(),
                stderr: None,
                witness: None,
                unshrunk: None,
                stage1: (
                    format!("out/{suite}/crossing/seed-1.stage1.mcap").into(),
                    format!("out/{suite}/crossing/seed-1.stage1.svg").into(),
                ),
                stage1_escape: None,
            })),
            name,
            snapshot: SnapshotCheck::NotCompared,
            wall_s: Some(2.5),
        }
    }

    /// Suite `unit`: one passing variant and a passing collision-rate check.
    pub(crate) fn passing_run() -> SuiteRun {
        let name = "unit::crossing::seed-0".to_string();
        let outcome = crossing_outcome(&name, false);
        let metrics = SuiteMetrics::compute(std::slice::from_ref(&outcome));
        SuiteRun {
            file: "specs/suites/unit.yaml".into(),
            name: "unit".into(),
            planner: "constant-velocity".into(),
            variants: vec![VariantRun {
                name,
                outcome: Ok(outcome),
                artefacts: None,
                snapshot: SnapshotCheck::NotCompared,
                wall_s: Some(1.25),
            }],
            metrics: Some(metrics),
            checks: vec![MetricCheck { name: "collision_rate", value: Some(1.0), result: Ok(()) }],
            mutation: None,
            wall_s: Some(1.5),
            warnings: Vec::new(),
        }
    }
}
