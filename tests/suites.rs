//! The scenario-suite runner: every `specs/suites/*.yaml` becomes tests,
//! `suite::scenario::seed-k` per variant and `suite::metric` per suite
//! metric, run by libtest-mimic, so `cargo test -- FILTER`, `--list`,
//! `--exact`, `--ignored` and cargo-nextest (`--partition hash:k/n`) work as
//! for ordinary tests.
//!
//! Listing only parses YAML; scenarios are built inside the trials and
//! shared per process. Each variant's stable summary is an insta snapshot
//! under `snapshots/`; a failing variant prints what happened, the failed
//! criteria and the paths of its MCAP recording and SVG picture (under
//! `target/safer-artifacts/`, or `$SAFER_ARTIFACTS_DIR`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use libtest_mimic::{Arguments, Failed, Trial};
use safer::harness::{self, Suite, SuiteMetrics, VariantOutcome};

fn manifest_dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn artefacts_dir() -> PathBuf {
    std::env::var_os("SAFER_ARTIFACTS_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| manifest_dir().join("target/safer-artifacts"))
}

type Shared = Arc<Result<VariantOutcome, String>>;

/// Variant outcomes computed in this process, shared by the variant trial
/// and the suite's metric trials (nextest runs each in its own process, so
/// metric trials then compute the variants themselves).
fn outcome(suite: &Suite, scenario: usize, index: u32) -> Shared {
    static CACHE: OnceLock<Mutex<HashMap<String, Shared>>> = OnceLock::new();
    let name = suite.variant_name(&suite.scenarios[scenario], index);
    let cache = CACHE.get_or_init(Default::default);
    if let Some(o) = cache.lock().unwrap().get(&name) {
        return o.clone();
    }
    let o = Arc::new(harness::run_variant(suite, &suite.scenarios[scenario], index).map_err(|e| e.to_string()));
    cache.lock().unwrap().entry(name).or_insert(o).clone()
}

/// The verdict comes first: a variant that fails its criteria reports what
/// happened and where its artefacts are, and only then is its snapshot
/// compared (a snapshot diff must never hide a failing verdict).
fn variant_trial(suite: Arc<Suite>, scenario: usize, index: u32) -> Result<(), Failed> {
    let shared = outcome(&suite, scenario, index);
    let o = shared.as_ref().as_ref().map_err(|e| Failed::from(format!("could not run the variant: {e}")))?;
    let mut verdict = String::new();
    for f in &o.failures {
        verdict.push_str(&format!("  ✗ {}: {}\n", f.criterion, f.what));
    }
    if !o.failures.is_empty() {
        match harness::artefacts::write(&artefacts_dir(), o) {
            Ok(a) => {
                verdict.push_str(&format!("  recording: {}\n  picture:   {}\n", a.mcap.display(), a.svg.display()))
            }
            Err(e) => verdict.push_str(&format!("  (could not write artefacts: {e})\n")),
        }
        // Printed before the snapshot comparison, whose diff insta prints itself.
        eprintln!("{}:\n{verdict}", o.name);
    }
    let summary = o.summary();
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path(manifest_dir().join("snapshots"));
    settings.set_prepend_module_to_snapshot(false);
    settings.set_omit_expression(true);
    // Explicit names: automatic ones race between parallel trials.
    let snapshot = o.name.replace("::", "__");
    let compared = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        settings.bind(|| insta::assert_yaml_snapshot!(snapshot.as_str(), summary))
    }));
    let snapshot_note = compared.err().map(|_| {
        format!("  snapshot snapshots/{snapshot}.snap differs (diff above; `cargo insta review` to accept)\n")
    });
    match (o.failures.is_empty(), snapshot_note) {
        (true, None) => Ok(()),
        (true, Some(note)) => Err(Failed::from(note)),
        (false, note) => Err(Failed::from(verdict + &note.unwrap_or_default())),
    }
}

fn metric_trial(suite: Arc<Suite>, metric: &'static str) -> Result<(), Failed> {
    let v = suite.spec.value.variants;
    let mut outcomes = Vec::new();
    for s in 0..suite.scenarios.len() {
        for k in 0..v {
            let shared = outcome(&suite, s, k);
            match shared.as_ref() {
                Ok(o) => outcomes.push(o.clone()),
                Err(e) => {
                    return Err(
                        format!("variant {} could not run: {e}", suite.variant_name(&suite.scenarios[s], k)).into()
                    );
                }
            }
        }
    }
    let metrics = SuiteMetrics::compute(&outcomes);
    let check = metrics
        .checks(&suite.spec.value.acceptance.suite)
        .into_iter()
        .find(|c| c.name == metric)
        .ok_or_else(|| Failed::from(format!("metric {metric} not configured")))?;
    check.result.map_err(Failed::from)
}

fn trials() -> Vec<Trial> {
    let mut out = Vec::new();
    let dir = manifest_dir().join("specs/suites");
    let files = Suite::discover(&dir);
    if files.is_empty() {
        // Zero trials would "pass": say instead that there was nothing to run.
        let message = format!("no suite (*.yaml) found in {}", dir.display());
        out.push(Trial::test("suites::discover", move || Err(Failed::from(message))));
    }
    for path in files {
        let file = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let suite = match Suite::load(&path) {
            Ok(s) => Arc::new(s),
            Err(e) => {
                // A broken suite is one failing test; the other suites still run.
                let report = format!("{:?}", e.to_report());
                out.push(Trial::test(format!("{file}::load"), move || Err(Failed::from(report))));
                continue;
            }
        };
        let name = suite.name();
        for (si, scenario) in suite.scenarios.iter().enumerate() {
            for k in 0..suite.spec.value.variants {
                let s = suite.clone();
                out.push(
                    Trial::test(suite.variant_name(scenario, k), move || variant_trial(s, si, k)).with_kind("variant"),
                );
            }
        }
        for metric in harness::metrics::metric_names(&suite.spec.value.acceptance.suite) {
            let s = suite.clone();
            out.push(Trial::test(format!("{name}::{metric}"), move || metric_trial(s, metric)).with_kind("metric"));
        }
    }
    out
}

fn main() {
    let args = Arguments::from_args();
    libtest_mimic::run(&args, trials()).exit();
}
