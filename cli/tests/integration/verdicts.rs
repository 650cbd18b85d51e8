//! The verdict logic itself: what counts as solved, failed or not run. A
//! planner that crashes mid-rollout leaves a short rollout without a
//! collision; it must fail its variant and lower the solution rate, never
//! raise it.

use std::path::{Path, PathBuf};

use safer_scenarios::harness::{Stage2Verdict, Suite, SuiteMetrics, run_variant};

fn fixture(name: &str) -> PathBuf {
    Path::new(repo_root!()).join("tests/fixtures/verdicts").join(name)
}

#[test]
fn a_crashed_planner_fails_its_variant_and_counts_against_the_solution_rate() {
    let suite = Suite::load(&fixture("crashing-planner.suite.yaml")).unwrap_or_else(|e| panic!("{e}"));
    let outcome = run_variant(&suite, &suite.scenarios[0], 0).unwrap_or_else(|e| panic!("{e}"));

    assert!(outcome.stage2.ego_collision().is_none(), "the crash, not a collision, must decide this variant");
    assert!(!outcome.solved(), "a crashed planner solved the variant: {:?}", outcome.verdict);
    match &outcome.verdict {
        Stage2Verdict::Aborted { reason } => {
            assert!(reason.contains("crashes-at-step-5") && reason.contains("exit"), "{reason}")
        }
        other => panic!("expected an aborted stage 2, got {other:?}"),
    }
    assert!(!outcome.failures.is_empty(), "the variant passed its criteria");
    assert!(!outcome.summary().passed);

    let metrics = SuiteMetrics::compute(std::slice::from_ref(&outcome));
    assert_eq!(metrics.solution_rate, Some(0.0));
    let checks = metrics.checks(&suite.spec.value.acceptance.suite);
    let sr = checks.iter().find(|c| c.name == "solution_rate").expect("solution_rate check");
    assert!(sr.result.is_err(), "{sr:?}");
}
