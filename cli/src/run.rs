//! `safer run SUITE.yaml... [--json OUT] [--artifacts DIR] [--filter SUBSTR]`:
//! the scenario suites outside `cargo test`, with the same variants, the
//! same outcomes and the same artefacts (both go through [`safer_scenarios::harness`]).
//!
//! Every suite is loaded first; one that does not load is reported with its
//! YAML snippet and the others still run. Variants of all suites run in
//! parallel (rayon); the table lists them per suite, sorted by scenario
//! name and seed number, so the output does not depend on scheduling.
//! `--filter` selects like a test filter: variants whose name
//! (`suite::scenario::seed-k`) contains it, and suite metrics whose name
//! (`suite::metric`) contains it; a selected metric runs all of its suite's
//! variants, as the metric trial of `cargo test --test suites` does.
//!
//! `--json -` (or `--junit -`) writes that report to standard output and
//! the table to stderr. `--junit FILE` writes a JUnit XML report
//! ([`harness::report::junit`]); `--html DIR` a static review page
//! ([`harness::report::review_page`]). All reports are written from one
//! [`RunResults`].
//!
//! Exit code: 0 when every selected variant and metric passed, 1 when one
//! failed (or could not run), 2 on usage errors and suites that do not load.

use super::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use rayon::prelude::*;
use serde::Serialize;

use super::CliError;
use safer_scenarios::harness::mutation::{MutantRun, MutationReport};
use safer_scenarios::harness::report::{RunResults, SuiteLoadFailure, SuiteRun, VariantRun};
use safer_scenarios::harness::{self, HarnessError, Suite, SuiteMetrics, VariantOutcome, VariantSummary};
use safer_scenarios::planners::FaultOperator;
use safer_scenarios::record::OutputKind;
use safer_scenarios::spec::{WarningsDenied, warnings_denied_by_env};

/// One variant to run.
struct Job {
    /// Index into the loaded suites.
    suite: usize,
    /// Index into the suite's scenarios.
    scenario: usize,
    /// Variant index (seed number).
    index: u32,
    /// Whether the filter selected it (otherwise it only feeds a selected metric).
    shown: bool,
}

/// What a job produced.
struct Done {
    outcome: Result<VariantOutcome, HarnessError>,
    /// The mutants' runs on the variant (none unless mutants were asked for).
    mutants: Vec<MutantRun>,
    /// Artefacts of a shown failing variant, or why they could not be written.
    artefacts: Option<Result<harness::artefacts::Artefacts, String>>,
    /// When it started and ended, s from the start of the run.
    span: (f64, f64),
}

/// The JSON report.
#[derive(Debug, Serialize)]
struct Report {
    /// Every selected variant and metric passed and every suite loaded.
    passed: bool,
    /// Suites that could not be loaded.
    load_errors: Vec<LoadErrorReport>,
    /// Per suite, in command-line order.
    suites: Vec<SuiteReport>,
    /// Wall time of the run, s, from its first variant to the reports.
    wall_s: f64,
}

#[derive(Debug, Serialize)]
struct LoadErrorReport {
    file: String,
    message: String,
}

#[derive(Debug, Serialize)]
struct SuiteReport {
    file: String,
    name: String,
    planner: String,
    passed: bool,
    variants: Vec<VariantEntry>,
    /// `None` when no metric was selected or a variant the metrics need could not run.
    metrics: Option<SuiteMetrics>,
    checks: Vec<CheckReport>,
    /// The mutation run, when mutants were planted.
    #[serde(skip_serializing_if = "Option::is_none")]
    mutation: Option<MutationReport>,
    /// Wall time, s: from its first variant's start to its last one's end
    /// (suites run side by side, so theirs overlap).
    wall_s: Option<f64>,
    /// Its variants' wall times summed, s (with `wall_s`, how much the
    /// suite gained from running its variants side by side).
    variants_wall_s: f64,
    /// What its spec says that is valid but most likely not meant, each
    /// `PATH:LINE:COLUMN: message` (the verdict does not count them).
    warnings: Vec<String>,
}

/// A variant in the report: its summary, or why it could not run.
#[derive(Debug, Serialize)]
#[serde(untagged)]
enum VariantEntry {
    Ran {
        // Boxed: the summary dwarfs the error arm.
        #[serde(flatten)]
        summary: Box<VariantSummary>,
        #[serde(skip_serializing_if = "Option::is_none")]
        artefacts: Option<ArtefactReport>,
        #[serde(skip_serializing_if = "Option::is_none")]
        artefacts_error: Option<String>,
        /// Wall-clock time per planner answer (not in the snapshot summary).
        #[serde(skip_serializing_if = "Option::is_none")]
        planner_latency: Option<harness::pipeline::PlannerLatency>,
        /// Wall time of the variant (its stages, shrink and mutants), s.
        #[serde(skip_serializing_if = "Option::is_none")]
        wall_s: Option<f64>,
    },
    Error {
        variant: String,
        passed: bool,
        error: String,
        #[serde(skip_serializing_if = "Option::is_none")]
        wall_s: Option<f64>,
    },
}

#[derive(Debug, Serialize)]
struct ArtefactReport {
    mcap: String,
    svg: String,
    /// Stage 1's recording and picture: the ego replaying its log against the variant's CBV.
    stage1_mcap: String,
    stage1_svg: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    stderr: Option<String>,
    /// What the witness search said about the ego's collision.
    #[serde(skip_serializing_if = "Option::is_none")]
    witness: Option<harness::variant::CollisionEscape>,
}

#[derive(Debug, Serialize)]
struct CheckReport {
    name: String,
    value: Option<f64>,
    passed: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    message: Option<String>,
}

/// Where `safer run` writes its reports besides the table.
pub(super) struct RunOutputs<'a> {
    /// The JSON report.
    pub json: Option<&'a Path>,
    /// The JUnit XML report.
    pub junit: Option<&'a Path>,
    /// The folder of the review page.
    pub html: Option<&'a Path>,
    /// The folder of failing variants' recordings and pictures.
    pub artifacts: &'a Path,
    /// Where to write variants as CommonRoad scenarios, and whether every
    /// variant (else the failing ones).
    pub commonroad: Option<(&'a Path, bool)>,
}

/// The files `--export-commonroad DIR` writes for a variant whose
/// artefact base path under `DIR` is `base`: the variant as safer shows it
/// (`NAME.xml`, shrunk where it was) and the variant as generated beside it
/// (`NAME.unshrunk.xml`, only for a shrunk one), each with its sidecar.
fn export_paths(base: &Path) -> [PathBuf; 4] {
    let shown = base.with_extension("xml");
    let unshrunk = base.with_extension("unshrunk.xml");
    let [a, b] = [&shown, &unshrunk].map(|p| safer_scenarios::record::commonroad::sidecar_path(p));
    [shown, unshrunk, a, b]
}

/// Writes `outcome`'s stage 2 as a CommonRoad scenario under `dir`, at the
/// variant's artefact path with `.xml`: the shrunk variant where there is
/// one (as the artefacts show it first), the unshrunk one beside it. Returns
/// the shown file and the export's notes.
fn export_commonroad(dir: &Path, outcome: &harness::VariantOutcome) -> Result<(PathBuf, Vec<String>), String> {
    use safer_scenarios::record::commonroad::write_commonroad;
    let base = harness::artefacts::base_path(dir, &outcome.name).map_err(|e| e.to_string())?;
    let [shown, unshrunk, ..] = export_paths(&base);
    let notes = match &outcome.shrunk {
        Some(shrunk) => {
            let notes = write_commonroad(&shown, &outcome.scenario, &shrunk.stage2, &outcome.name, true)
                .map_err(|e| e.to_string())?;
            write_commonroad(&unshrunk, &outcome.scenario, &outcome.stage2, &outcome.name, false)
                .map_err(|e| e.to_string())?;
            notes
        }
        None => write_commonroad(&shown, &outcome.scenario, &outcome.stage2, &outcome.name, false)
            .map_err(|e| e.to_string())?,
    };
    Ok((shown, notes))
}

/// Checks, before the run, every file `--export-commonroad DIR` may write
/// for the variants `names` (the scenarios, unshrunk ones and sidecars):
/// none may be a file the run reads, and an existing one must be an export
/// safer made, so a recorded CommonRoad scene kept in `DIR` is never
/// replaced.
fn check_exports(dir: &Path, names: impl Iterator<Item = String>, inputs: &[PathBuf]) -> Result<(), CliError> {
    for name in names {
        let base = dir.join(harness::artefacts::relative_path(dir, &name)?);
        let [shown, unshrunk, shown_sidecar, unshrunk_sidecar] = export_paths(&base);
        for (path, kind) in [
            (shown, OutputKind::CommonRoadExport),
            (unshrunk, OutputKind::CommonRoadExport),
            (shown_sidecar, OutputKind::CommonRoadSidecar),
            (unshrunk_sidecar, OutputKind::CommonRoadSidecar),
        ] {
            let out = [safer_scenarios::record::NamedOutput { flag: "--export-commonroad", path: &path }];
            if path.parent().is_some_and(Path::is_dir) {
                safer_scenarios::record::check_outputs_apart(&out, inputs)?;
            }
            safer_scenarios::record::check_replaceable("--export-commonroad", &path, kind, false)?;
        }
    }
    Ok(())
}

pub(super) fn run(
    files: &[PathBuf],
    outputs: RunOutputs<'_>,
    filter: Option<&str>,
    loading: Loading,
    mutants: Option<&[FaultOperator]>,
) -> Result<ExitCode, CliError> {
    let RunOutputs { json, junit, html, artifacts, commonroad } = outputs;
    // Refused before anything runs: a report that cannot be written should not cost a run.
    for out in [json, junit].into_iter().flatten() {
        safer_scenarios::record::output::check_output(out)?;
    }
    if let Some(dir) = html {
        harness::report::review_page::check_folder(dir)?;
    }
    let (suites, load_failures) = load_suites(files, loading)?;

    let inputs = check_reports(files, &suites, json, junit)?;

    let (jobs, metrics_selected) = select_jobs(&suites, filter)?;

    if let Some((dir, _)) = commonroad {
        let names = jobs.iter().filter(|j| j.shown).map(|j| {
            let suite = &suites[j.suite].1;
            suite.variant_name(&suite.scenarios[j.scenario], j.index)
        });
        check_exports(dir, names, &inputs)?;
    }

    // The mutants each suite plants: the flag's, else its own when it asks
    // for a mutation score.
    let operators: Vec<Vec<FaultOperator>> =
        suites.iter().map(|(_, s)| harness::mutation::operators_for(&s.spec.value.acceptance.suite, mutants)).collect();
    let progress = super::progress::Progress::new("run", "variants", jobs.len());
    let started = std::time::Instant::now();
    type Written = Result<(PathBuf, Vec<String>), String>;
    let exports: std::sync::Mutex<Vec<(String, Written)>> = std::sync::Mutex::new(Vec::new());
    let done: Vec<Done> = jobs
        .par_iter()
        .map(|j| {
            let begin = started.elapsed().as_secs_f64();
            let suite = &suites[j.suite].1;
            let scenario = &suite.scenarios[j.scenario];
            let outcome = harness::run_variant(suite, scenario, j.index);
            let mutants = match &outcome {
                Ok(o) => harness::mutation::run_mutants(suite, scenario, j.index, o, &operators[j.suite]),
                Err(_) => Vec::new(),
            };
            let artefacts = match &outcome {
                Ok(o) if j.shown && !o.failures.is_empty() => Some(
                    harness::artefacts::write(artifacts, o, harness::artefacts::search_stage1_escape(o))
                        .map_err(|e| e.to_string()),
                ),
                _ => None,
            };
            if let (Ok(o), Some((dir, all))) = (&outcome, commonroad)
                && j.shown
                && (all || !o.failures.is_empty())
            {
                let written = export_commonroad(dir, o);
                exports.lock().unwrap_or_else(|p| p.into_inner()).push((o.name.clone(), written));
            }
            progress.tick();
            Done { outcome, mutants, artefacts, span: (begin, started.elapsed().as_secs_f64()) }
        })
        .collect();
    drop(progress);

    // Each suite's jobs, sorted by scenario name and seed number so the
    // reports do not depend on scheduling.
    let mut per_suite: Vec<Vec<(Job, Done)>> = suites.iter().map(|_| Vec::new()).collect();
    for (j, d) in jobs.into_iter().zip(done) {
        per_suite[j.suite].push((j, d));
    }
    let mut results = RunResults { load_failures, suites: Vec::new() };
    for (((file, suite), (mut mine, metrics)), ops) in
        suites.iter().zip(per_suite.into_iter().zip(&metrics_selected)).zip(&operators)
    {
        mine.sort_by_cached_key(|(j, _)| (suite.scenarios[j.scenario].name.clone(), j.index));
        results.suites.push(suite_run(file, suite, mine, metrics, ops));
    }
    let load_failed = !results.load_failures.is_empty();
    let report = Report {
        passed: results.passed(),
        load_errors: results
            .load_failures
            .iter()
            .map(|f| LoadErrorReport { file: f.file.display().to_string(), message: f.message.clone() })
            .collect(),
        suites: results.suites.iter().map(suite_report).collect(),
        wall_s: started.elapsed().as_secs_f64(),
    };

    // The table goes to stderr when a report takes standard output.
    // File reports before anything goes to standard output: a reader that
    // closes it early (`| head`) must not cost the run its reports.
    let to_file = |p: &&Path| !safer_scenarios::record::is_stdout(p);
    let to_stdout = |p: &&Path| safer_scenarios::record::is_stdout(p);
    let write_json = |out: &Path| -> Result<(), CliError> {
        let text = serde_json::to_string_pretty(&report)? + "\n";
        Ok(safer_scenarios::record::write_output(out, text.as_bytes())?)
    };
    let write_junit =
        |out: &Path| safer_scenarios::record::write_output(out, harness::report::junit::junit_xml(&results).as_bytes());
    if let Some(out) = json.filter(to_file) {
        write_json(out)?;
    }
    if let Some(out) = junit.filter(to_file) {
        write_junit(out)?;
    }
    let mut table =
        super::table_writer([json, junit].into_iter().flatten().find(|p| safer_scenarios::record::is_stdout(p)));
    match print_report(&mut table, &report).and_then(|()| table.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other?,
    }
    if let Some(out) = json.filter(to_stdout) {
        write_json(out)?;
    }
    if let Some(out) = junit.filter(to_stdout) {
        write_junit(out)?;
    }
    if let Some(dir) = html {
        let page = harness::report::review_page::write_review_page(dir, &results)?;
        eprintln!("review page: {}", page.display());
    }
    let mut exports = exports.into_inner().unwrap_or_else(|p| p.into_inner());
    exports.sort_by(|a, b| a.0.cmp(&b.0));
    let export_failed = exports.iter().any(|(_, r)| r.is_err());
    if let Some((dir, _)) = commonroad {
        for (variant, written) in &exports {
            match written {
                Err(e) => eprintln!("error: {variant} could not be exported as a CommonRoad scenario: {e}"),
                Ok((_, notes)) => notes.iter().for_each(|n| eprintln!("note: {variant}: CommonRoad export: {n}")),
            }
        }
        let ok = exports.iter().filter(|(_, r)| r.is_ok()).count();
        eprintln!("CommonRoad scenarios: {ok} written under {}", dir.display());
    }
    Ok(if load_failed {
        ExitCode::from(2)
    } else if report.passed && !export_failed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// A suite file and the suite it holds.
type LoadedSuite = (PathBuf, Suite);

/// How the command line has the suites loaded.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Loading {
    /// The shrink bounds over each suite's own.
    pub shrink: ShrinkOverride,
    /// Whether a suite whose spec warns is refused (`--deny-warnings`,
    /// `SAFER_DENY_WARNINGS`).
    pub deny_warnings: bool,
}

/// The shrink bounds the command line sets, over each suite's own.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct ShrinkOverride {
    /// Candidate rollouts (`Some(0)`: `--no-shrink`).
    pub rollouts: Option<usize>,
    /// Wall time of one variant's search.
    pub time_limit: Option<std::time::Duration>,
}

impl ShrinkOverride {
    /// `suite`'s bounds with the command line's in their place.
    fn over(self, suite: harness::shrink::ShrinkBudget) -> harness::shrink::ShrinkBudget {
        harness::shrink::ShrinkBudget {
            rollouts: self.rollouts.unwrap_or(suite.rollouts),
            time_limit: self.time_limit.or(suite.time_limit),
        }
    }
}

/// `--shrink-time-limit`: seconds above 0, at most a day.
fn shrink_time_limit(text: &str) -> Result<f64, String> {
    let max = safer_scenarios::spec::suite::MAX_SHRINK_TIME_LIMIT_S;
    match text.parse::<f64>() {
        Ok(s) if s > 0.0 && s <= max => Ok(s),
        _ => Err(format!("expected seconds above 0 and at most {max}, got `{text}`")),
    }
}

/// Loads the suites (a broken one, or one whose warnings are denied, is
/// reported and left out) and refuses two suites of one name.
fn load_suites(files: &[PathBuf], loading: Loading) -> Result<(Vec<LoadedSuite>, Vec<SuiteLoadFailure>), CliError> {
    let colour = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let mut load_failures = Vec::new();
    let mut suites: Vec<LoadedSuite> = Vec::new();
    for file in files {
        match Suite::load(file) {
            Ok(mut s) => {
                let warnings = s.spec.warnings();
                if loading.deny_warnings
                    && let Some(denied) = WarningsDenied::of(warnings.clone())
                {
                    eprintln!("{}", denied.render(colour));
                    load_failures.push(SuiteLoadFailure { file: file.clone(), message: denied.to_string() });
                    continue;
                }
                warnings.iter().for_each(|w| eprintln!("{}", w.render(colour)));
                s.shrink = loading.shrink.over(s.shrink);
                suites.push((file.clone(), s));
            }
            Err(e) => {
                eprintln!("{}", e.render(colour));
                load_failures.push(SuiteLoadFailure { file: file.clone(), message: e.to_string() });
            }
        }
    }

    // Two suites of one name would share test names and artefact paths,
    // and one recording would silently replace the other.
    for (i, (file, suite)) in suites.iter().enumerate() {
        if let Some((first, _)) = suites[..i].iter().find(|(_, s)| s.name() == suite.name()) {
            return Err(CliError::Usage(format!(
                "{} and {} are both named `{}`; suites run together need different names (their tests and \
                 artefacts are named after them)",
                first.display(),
                file.display(),
                suite.name()
            )));
        }
    }
    Ok((suites, load_failures))
}

/// Checks, before the run, that `--json` and `--junit` can take their
/// reports without replacing a file the run reads or another report; the
/// files the run reads.
fn check_reports(
    files: &[PathBuf],
    suites: &[LoadedSuite],
    json: Option<&Path>,
    junit: Option<&Path>,
) -> Result<Vec<PathBuf>, CliError> {
    // No report may replace a file the run reads, or another report.
    let inputs: Vec<PathBuf> = files.iter().cloned().chain(suites.iter().flat_map(|(_, s)| s.input_files())).collect();
    let named = [("--json", json), ("--junit", junit)];
    let outputs: Vec<safer_scenarios::record::NamedOutput<'_>> = named
        .iter()
        .filter_map(|(flag, p)| p.map(|path| safer_scenarios::record::NamedOutput { flag, path }))
        .collect();
    safer_scenarios::record::check_outputs_apart(&outputs, &inputs)?;
    for out in &outputs {
        let kind = if out.flag == "--junit" { OutputKind::JunitXml } else { OutputKind::Json };
        safer_scenarios::record::check_replaceable(out.flag, out.path, kind, false)?;
    }
    Ok(inputs)
}

/// The variants to run (those the filter selects, and every variant of a
/// suite whose metric it selects) and each suite's selected metrics.
fn select_jobs(suites: &[LoadedSuite], filter: Option<&str>) -> Result<(Vec<Job>, Vec<Vec<&'static str>>), CliError> {
    let selects = |name: &str| filter.is_none_or(|f| name.contains(f));
    let mut jobs = Vec::new();
    let mut metrics_selected: Vec<Vec<&'static str>> = Vec::new();
    for (si, (_, suite)) in suites.iter().enumerate() {
        let metrics: Vec<&'static str> = harness::metrics::metric_names(&suite.spec.value.acceptance.suite)
            .into_iter()
            .filter(|m| selects(&format!("{}::{m}", suite.name())))
            .collect();
        for (ci, scenario) in suite.scenarios.iter().enumerate() {
            for k in 0..suite.spec.value.variants {
                let shown = selects(&suite.variant_name(scenario, k));
                if shown || !metrics.is_empty() {
                    jobs.push(Job { suite: si, scenario: ci, index: k, shown });
                }
            }
        }
        metrics_selected.push(metrics);
    }
    if let Some(f) = filter
        && !suites.is_empty()
        && !jobs.iter().any(|j| j.shown)
        && metrics_selected.iter().all(Vec::is_empty)
    {
        // A mistyped filter would otherwise "pass" with nothing run.
        return Err(CliError::Usage(format!("--filter `{f}` matches no variant and no suite metric")));
    }
    Ok((jobs, metrics_selected))
}

/// The results of one suite: its shown variants and its selected metrics.
fn suite_run(
    file: &Path,
    suite: &Suite,
    jobs: Vec<(Job, Done)>,
    metrics: &[&'static str],
    operators: &[FaultOperator],
) -> SuiteRun {
    let names: Vec<String> =
        jobs.iter().map(|(job, _)| suite.variant_name(&suite.scenarios[job.scenario], job.index)).collect();
    // Every job counts, shown or only feeding a selected metric.
    let first = jobs.iter().map(|(_, d)| d.span.0).min_by(f64::total_cmp);
    let last = jobs.iter().map(|(_, d)| d.span.1).max_by(f64::total_cmp);
    let wall_s = first.zip(last).map(|(a, b)| b - a);
    let mutation = (!operators.is_empty()).then(|| {
        MutationReport::of(
            operators,
            jobs.iter().zip(&names).map(|((_, done), name)| {
                (name.as_str(), done.outcome.as_ref().ok().map(|o| o.failures.as_slice()), done.mutants.as_slice())
            }),
        )
    });
    let (suite_metrics, checks) = if metrics.is_empty() {
        (None, Vec::new())
    } else {
        let (m, checks) = harness::metrics::suite_verdict(
            &suite.spec.value.acceptance.suite,
            jobs.iter().map(|(job, done)| {
                let name = suite.variant_name(&suite.scenarios[job.scenario], job.index);
                (name, done.outcome.as_ref().map(|o| &o.tally).map_err(|e| e.to_string()))
            }),
            mutation.as_ref().and_then(|m| m.check(&suite.spec.value.acceptance.suite)),
        );
        (m, checks.into_iter().filter(|c| metrics.contains(&c.name)).collect())
    };
    let variants = jobs
        .into_iter()
        .filter(|(j, _)| j.shown)
        .map(|(job, done)| VariantRun {
            name: suite.variant_name(&suite.scenarios[job.scenario], job.index),
            outcome: done.outcome.map_err(|e| e.to_string()),
            artefacts: done.artefacts,
            snapshot: safer_scenarios::harness::report::SnapshotCheck::NotCompared,
            wall_s: Some(done.span.1 - done.span.0),
        })
        .collect();
    SuiteRun {
        file: file.to_path_buf(),
        name: suite.name(),
        planner: suite.planner.name().to_string(),
        variants,
        metrics: suite_metrics,
        checks,
        mutation,
        wall_s,
        warnings: suite.spec.warnings().iter().map(ToString::to_string).collect(),
    }
}

/// The JSON report of one suite.
fn suite_report(run: &SuiteRun) -> SuiteReport {
    let variants = run
        .variants
        .iter()
        .map(|v| match &v.outcome {
            Ok(o) => {
                let (artefacts, artefacts_error) = match &v.artefacts {
                    Some(Ok(a)) => (
                        Some(ArtefactReport {
                            mcap: a.mcap.display().to_string(),
                            svg: a.svg.display().to_string(),
                            stage1_mcap: a.stage1.0.display().to_string(),
                            stage1_svg: a.stage1.1.display().to_string(),
                            stderr: a.stderr.as_ref().map(|p| p.display().to_string()),
                            witness: a.witness.as_ref().map(harness::artefacts::WitnessArtefact::verdict),
                        }),
                        None,
                    ),
                    Some(Err(e)) => (None, Some(e.clone())),
                    None => (None, None),
                };
                VariantEntry::Ran {
                    summary: Box::new(o.summary()),
                    artefacts,
                    artefacts_error,
                    planner_latency: o.planner_latency,
                    wall_s: v.wall_s,
                }
            }
            Err(e) => {
                VariantEntry::Error { variant: v.name.clone(), passed: false, error: e.clone(), wall_s: v.wall_s }
            }
        })
        .collect();
    let checks = run
        .checks
        .iter()
        .map(|c| CheckReport {
            name: c.name.to_string(),
            value: c.value,
            passed: c.result.is_ok(),
            message: c.result.clone().err(),
        })
        .collect();
    SuiteReport {
        file: run.file.display().to_string(),
        name: run.name.clone(),
        planner: run.planner.clone(),
        passed: run.passed(),
        variants,
        metrics: run.metrics.clone(),
        checks,
        mutation: run.mutation.clone(),
        wall_s: run.wall_s,
        variants_wall_s: run.variants.iter().filter_map(|v| v.wall_s).sum(),
        warnings: run.warnings.clone(),
    }
}

/// `4.2 s`, `3 min 07 s`.
fn duration(s: f64) -> String {
    if s < 60.0 {
        format!("{s:.1} s")
    } else {
        let whole = s.round() as u64;
        format!("{} min {:02} s", whole / 60, whole % 60)
    }
}

/// `1 variant`, `2 variants`.
fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

fn opt(v: Option<f64>, decimals: usize) -> String {
    v.map_or_else(|| "-".to_string(), |x| format!("{x:.decimals$}"))
}

/// The human-readable table (on stdout, or stderr when the JSON report
/// takes stdout).
fn print_report(out: &mut dyn Write, report: &Report) -> std::io::Result<()> {
    let mut failing = Vec::new();
    let (mut variants, mut variants_failed, mut checks, mut checks_failed) = (0, 0, 0, 0);
    for (i, s) in report.suites.iter().enumerate() {
        if i > 0 {
            writeln!(out)?;
        }
        writeln!(out, "suite {} ({}), planner {}", s.name, s.file, s.planner)?;
        let width = s
            .variants
            .iter()
            .map(|v| match v {
                VariantEntry::Ran { summary, .. } => summary.variant.len(),
                VariantEntry::Error { variant, .. } => variant.len(),
            })
            .max()
            .unwrap_or(0)
            .max("variant".len());
        if !s.variants.is_empty() {
            writeln!(
                out,
                "  {:<width$}  {:>10}  {:>9}  {:>9}  {:>5}  {:>9}  stage 2",
                "variant", "S1 CBV hit", "gap CBV m", "min gap m", "reach", "min TTC s"
            )?;
        }
        for v in &s.variants {
            variants += 1;
            match v {
                VariantEntry::Ran { summary, artefacts, artefacts_error, .. } => {
                    let result = match summary.failures.first() {
                        // The criteria may allow a collision (not at fault);
                        // say so, as it does not count as solved.
                        None => match (&summary.stage2_collision, summary.stage2_escape) {
                            (Some(collision), Some(escape)) if !escape.avoidable() => {
                                format!(
                                    "pass (ego collision: {collision}; no escape within budget: the generator's fault; not solved)"
                                )
                            }
                            (Some(collision), _) => format!("pass (ego collision: {collision}; not solved)"),
                            (None, _) => "pass".to_string(),
                        },
                        Some(first) => {
                            variants_failed += 1;
                            let more = summary.failures.len() - 1;
                            let more = if more > 0 { format!(" (+{more} more)") } else { String::new() };
                            failing.push((summary.variant.clone(), artefacts, artefacts_error));
                            format!("FAIL {first}{more}")
                        }
                    };
                    writeln!(
                        out,
                        "  {:<width$}  {:>10}  {:>9}  {:>9}  {:>5}  {:>9}  {result}",
                        summary.variant,
                        if summary.stage1_cbv_hit_ego { "yes" } else { "no" },
                        opt(summary.stage2_min_gap_to_cbv_m, 2),
                        opt(summary.stage2_min_gap_m, 2),
                        if summary.conflict_reached { "yes" } else { "no" },
                        opt(summary.stage2_min_ttc_s, 1),
                    )?;
                    if let Some(shrunk) = &summary.shrunk {
                        writeln!(out, "  {:<width$}  shrunk: {}", "", shrunk.describe())?;
                    }
                    if let Some(why) = &summary.not_shrunk {
                        writeln!(out, "  {:<width$}  not shrunk: {why}", "")?;
                    }
                }
                VariantEntry::Error { variant, error, .. } => {
                    variants_failed += 1;
                    writeln!(
                        out,
                        "  {variant:<width$}  {:>10}  {:>9}  {:>9}  {:>5}  {:>9}  ERROR could not run: {error}",
                        "-", "-", "-", "-", "-"
                    )?;
                }
            }
        }
        if let Some(m) = &s.metrics {
            writeln!(out, "  {}", m.headline("  "))?;
            for line in m.coverage_table() {
                writeln!(out, "  {line}")?;
            }
        }
        let metric_width = s.checks.iter().map(|c| s.name.len() + 2 + c.name.len()).max().unwrap_or(0);
        for c in &s.checks {
            checks += 1;
            let verdict = if c.passed {
                "PASS".to_string()
            } else {
                checks_failed += 1;
                format!("FAIL {}", c.message.as_deref().unwrap_or_default())
            };
            writeln!(out, "  {:<metric_width$}  {:>7}  {verdict}", format!("{}::{}", s.name, c.name), opt(c.value, 3))?;
        }
        if let Some(m) = &s.mutation {
            writeln!(out, "  {}", m.headline())?;
            for line in m.table() {
                writeln!(out, "    {line}")?;
            }
        }
        if let Some(wall) = s.wall_s {
            writeln!(
                out,
                "  time: {} wall, {} summed over its variants{}",
                duration(wall),
                duration(s.variants_wall_s),
                if report.suites.len() > 1 { " (suites run side by side)" } else { "" }
            )?;
        }
    }
    if !failing.is_empty() {
        writeln!(out, "\nartefacts of failing variants:")?;
        for (name, artefacts, error) in failing {
            writeln!(out, "  {name}")?;
            match (artefacts, error) {
                (Some(a), _) => {
                    writeln!(out, "    recording: {}\n    picture:   {}", a.mcap, a.svg)?;
                    writeln!(out, "    stage 1:   {} ({})", a.stage1_svg, harness::artefacts::STAGE1_SHOWS)?;
                    if let Some(stderr) = &a.stderr {
                        writeln!(out, "    stderr:    {stderr}")?;
                    }
                    if let Some(witness) = a.witness {
                        writeln!(out, "    witness:   {}", witness.describe())?;
                    }
                }
                (None, Some(e)) => writeln!(out, "    (could not write artefacts: {e})")?,
                (None, None) => {}
            }
        }
    }
    let mut aside = if report.load_errors.is_empty() {
        String::new()
    } else {
        format!("; {} could not be loaded", count(report.load_errors.len(), "suite file"))
    };
    // Shown in full on stderr as the suites load; counted here, since the
    // table may be all a reader keeps.
    let warnings: usize = report.suites.iter().map(|s| s.warnings.len()).sum();
    if warnings > 0 {
        aside.push_str(&format!("; {}", count(warnings, "spec warning")));
    }
    writeln!(
        out,
        "\n{}: {}, {variants_failed} failed; {}, {checks_failed} failed{aside}; {}",
        if report.passed { "PASS" } else { "FAIL" },
        count(variants, "variant"),
        count(checks, "metric check"),
        duration(report.wall_s),
    )?;
    Ok(())
}

/// The arguments of `safer run`.
#[derive(Debug, clap::Args)]
pub(crate) struct RunArgs {
    /// Suite spec files (`specs/suites/*.yaml`).
    #[arg(required = true)]
    pub(crate) suites: Vec<PathBuf>,
    /// Also write a JSON report to this file (`-`: standard output, the table then goes to stderr).
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub(crate) json: Option<PathBuf>,
    /// Also write a JUnit XML report to this file (`-`: standard output, the table then goes to stderr): one testcase per variant and per suite metric.
    #[arg(long, value_name = "FILE")]
    pub(crate) junit: Option<PathBuf>,
    /// Also write a static review page (index.html and the pictures of failing variants) into this folder; it must be missing, empty, or hold an earlier review page.
    #[arg(long, value_name = "DIR")]
    pub(crate) html: Option<PathBuf>,
    /// Folder for the recordings and pictures of failing variants.
    #[arg(long, value_name = "DIR", default_value = "target/safer-artifacts")]
    pub(crate) artifacts: PathBuf,
    /// Write each failing variant as a CommonRoad 2020a scenario (the lanelet network, every other agent as a dynamic obstacle on its stage-2 trajectory, the ego as the planning problem) under DIR/SUITE/SCENARIO/seed-K.xml.
    #[arg(long, value_name = "DIR")]
    pub(crate) export_commonroad: Option<PathBuf>,
    /// With --export-commonroad: every variant, not only the failing ones.
    #[arg(long, requires = "export_commonroad")]
    pub(crate) export_commonroad_all: bool,
    /// Do not shrink failing variants (by default each is shrunk to the smallest deviation from the logged CBV that fails the same way, shown first in its artefacts).
    #[arg(long)]
    pub(crate) no_shrink: bool,
    /// Candidate rollouts a failing variant's shrink may play, at least 1 (default: the suite's `shrink.budget`, else 16).
    #[arg(long, value_name = "N", value_parser = at_least_one())]
    pub(crate) shrink_budget: Option<usize>,
    /// Wall time a failing variant's shrink may take, s (default: the suite's `shrink.time_limit_s`, else none). The shrunk result then depends on the machine; the report says when the search stopped at the limit. The verdict never depends on it.
    #[arg(long, value_name = "SECONDS", value_parser = shrink_time_limit)]
    pub(crate) shrink_time_limit: Option<f64>,
    /// Only variants and metrics whose test name contains this.
    #[arg(long, value_name = "SUBSTR")]
    pub(crate) filter: Option<String>,
    /// Worker threads for the variants, 1 to 256 (default: one per core). Each may run a planner process: far more than the cores only thrashes.
    #[arg(short, long, value_name = "N", value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_JOBS as u64))]
    pub(crate) jobs: Option<usize>,
    /// Make spec warnings errors: a suite whose spec warns (recorded scenes left to replay, or judged by any collision) is refused as a spec error is, with exit status 2. Also set by SAFER_DENY_WARNINGS=1.
    #[arg(long)]
    pub(crate) deny_warnings: bool,
    /// Mutation testing: also run each suite's variants with these faults planted in its planner (comma-separated; alone, or `all`: every operator), and report which mutants the suite kills. Operators: no-brake, weak-brake, late, blind-cbv, blind-side, no-evade, speeding. Replaces a suite's own `mutation_operators`.
    #[arg(long, value_name = "OPS", num_args = 0..=1, default_missing_value = "all", value_parser = fault_operators)]
    pub(crate) mutants: Option<FaultOperators>,
}

/// Runs `safer run`.
pub(crate) fn command(args: RunArgs) -> Result<ExitCode, CliError> {
    let RunArgs {
        suites,
        json,
        junit,
        html,
        artifacts,
        export_commonroad,
        export_commonroad_all,
        no_shrink,
        shrink_budget,
        shrink_time_limit,
        filter,
        jobs,
        mutants,
        deny_warnings,
    } = args;
    if json.as_deref().is_some_and(safer_scenarios::record::is_stdout)
        && junit.as_deref().is_some_and(safer_scenarios::record::is_stdout)
    {
        Err(CliError::Usage("--json - and --junit - cannot both take standard output".into()))
    } else {
        let outputs = RunOutputs {
            json: json.as_deref(),
            junit: junit.as_deref(),
            html: html.as_deref(),
            artifacts: &artifacts,
            commonroad: export_commonroad.as_deref().map(|dir| (dir, export_commonroad_all)),
        };
        let budget = ShrinkOverride {
            rollouts: if no_shrink { Some(0) } else { shrink_budget },
            time_limit: shrink_time_limit.map(std::time::Duration::from_secs_f64),
        };
        let loading = Loading { shrink: budget, deny_warnings: deny_warnings || warnings_denied_by_env() };
        let mutants = mutants.as_ref().map(|m| m.0.as_slice());
        set_jobs(jobs).and_then(|()| run(&suites, outputs, filter.as_deref(), loading, mutants))
    }
}
