//! The scenario-suite test runner a planner crate puts in its own
//! repository: a test target with `harness = false` whose `main` is a few
//! lines,
//!
//! ```no_run
//! # use safer_scenarios::prelude::*;
//! # #[derive(Default)]
//! # struct MyAdapter;
//! # impl Planner for MyAdapter {
//! #     fn name(&self) -> &str { "my-planner" }
//! #     fn plan(&mut self, _: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
//! #         Ok(PlannerOutput::Control(Action::default()))
//! #     }
//! # }
//! // tests/scenarios.rs of a planner crate; MyAdapter implements `Planner`
//! fn main() {
//!     safer_scenarios::runner::Runner::new(env!("CARGO_MANIFEST_DIR"))
//!         .planner("my-planner", |_scenario, _ego| MyAdapter::default())
//!         .run()
//! }
//! ```
//!
//! turns every `specs/suites/*.yaml` of that crate into tests run by
//! libtest-mimic: `suite::scenario::seed-k` per variant and `suite::metric`
//! per suite metric, so `cargo test -- FILTER`, `--list`, `--exact`,
//! `--ignored` and cargo-nextest (`--partition hash:k/n`) work as for
//! ordinary tests. Listing only parses YAML; scenarios are built inside the
//! trials and shared per process.
//!
//! Each variant's stable summary is an insta snapshot in the crate's
//! `snapshots/`; a failing variant prints what happened, the failed
//! criteria and the paths of its MCAP recording and SVG picture (under the
//! crate's `target/safer-artifacts/`, `$CARGO_TARGET_DIR/safer-artifacts/`
//! or `$SAFER_ARTIFACTS_DIR`). In-process planners are registered by name
//! ([`Runner::planner`]) and named in a suite with `planner: { rust: NAME }`.
//!
//! A suite whose spec warns (valid, but most likely not meant: recorded
//! scenes left to replay, or judged by any collision) runs, with the
//! warnings printed at the start of the run and carried by the review page.
//! Under cargo-nextest, which shows only failing tests' output, set
//! `SAFER_DENY_WARNINGS=1` (or [`Runner::deny_warnings`]): such a suite is
//! then one failing `SUITE::load` test that shows them.
//!
//! [`Runner::run`] is all most test targets need; [`Runner::trials`] and
//! [`Runner::run_with`] hand out and take [libtest-mimic] 0.8's types,
//! re-exported here ([`Arguments`], [`Conclusion`], [`Trial`], [`Failed`]).
//!
//! [libtest-mimic]: https://docs.rs/libtest-mimic/0.8

// The example shows the whole test target a planner crate writes, `main` included.
#![allow(clippy::needless_doctest_main)]

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

/// libtest-mimic 0.8's types, part of this API: the arguments
/// [`Runner::run_with`] takes and the conclusion it returns, the trials
/// [`Runner::trials`] makes (run them with your own `libtest_mimic::run`
/// alongside other trials) and a failing trial's message.
pub use libtest_mimic::{Arguments, Conclusion, Failed, Trial};

use crate::harness::artefacts::Artefacts;
use crate::harness::mutation::{MutantRun, MutationReport};
use crate::harness::report::SnapshotCheck;
use crate::harness::{self, RunResults, Suite, SuiteLoadFailure, SuiteRun, VariantOutcome, VariantRun};
use crate::planners::Planner;
use crate::planners::registry::{PlannerFactory, PlannerRegistry};
use crate::scenario::{Scenario, TrackIndex};

/// Where a planner crate keeps its suites, snapshots and artefacts, and
/// which in-process planners it registers.
#[derive(Debug, Clone)]
pub struct Runner {
    root: PathBuf,
    suite_dirs: Vec<PathBuf>,
    snapshots: PathBuf,
    artefacts: PathBuf,
    /// The in-process planners suites may name (`planner: { rust: NAME }`).
    planners: PlannerRegistry,
    /// Registration errors, reported as failing tests (a builder cannot
    /// fail without making every caller handle it).
    registration_errors: Vec<String>,
    /// Whether a suite with spec warnings fails to load instead of running.
    deny_warnings: bool,
}

impl Runner {
    /// A runner for the crate at `root` (pass `env!("CARGO_MANIFEST_DIR")`):
    /// suites in `root/specs/suites`, snapshots in `root/snapshots`,
    /// artefacts in `$SAFER_ARTIFACTS_DIR`, else
    /// `$CARGO_TARGET_DIR/safer-artifacts`, else `root/target/safer-artifacts`.
    pub fn new(root: impl Into<PathBuf>) -> Self {
        let root = root.into();
        let artefacts = std::env::var_os("SAFER_ARTIFACTS_DIR")
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("CARGO_TARGET_DIR").map(|t| root.join(t).join("safer-artifacts")))
            .unwrap_or_else(|| root.join("target/safer-artifacts"));
        Self {
            suite_dirs: Vec::new(),
            snapshots: root.join("snapshots"),
            artefacts,
            planners: PlannerRegistry::default(),
            registration_errors: Vec::new(),
            deny_warnings: crate::spec::warnings_denied_by_env(),
            root,
        }
    }

    /// Adds a folder of suites (`*.yaml`), relative to the root unless
    /// absolute. Without any, the runner reads `specs/suites`.
    pub fn suites(mut self, dir: impl AsRef<Path>) -> Self {
        self.suite_dirs.push(self.root.join(dir));
        self
    }

    /// The snapshots folder, relative to the root unless absolute.
    pub fn snapshots(mut self, dir: impl AsRef<Path>) -> Self {
        self.snapshots = self.root.join(dir);
        self
    }

    /// The artifacts folder (recordings and pictures of failing variants),
    /// relative to the root unless absolute; `$SAFER_ARTIFACTS_DIR` still
    /// wins. Named as `safer run --artifacts` and `SAFER_ARTIFACTS_DIR` are.
    pub fn artifacts(mut self, dir: impl AsRef<Path>) -> Self {
        if std::env::var_os("SAFER_ARTIFACTS_DIR").is_none() {
            self.artefacts = self.root.join(dir);
        }
        self
    }

    /// Whether a suite whose spec warns (recorded scenes left to replay,
    /// or judged by any collision: [`crate::spec::SpecWarning`]) is one
    /// failing `SUITE::load` test instead of running, as a spec error
    /// makes it. Off by default, on where
    /// [`SAFER_DENY_WARNINGS`](crate::spec::DENY_WARNINGS_ENV) is set: a
    /// test tool that shows only failing tests' output (cargo-nextest)
    /// would otherwise never show the warnings.
    pub fn deny_warnings(mut self, deny: bool) -> Self {
        self.deny_warnings = deny;
        self
    }

    /// The former name of [`Runner::artifacts`].
    #[deprecated(since = "0.1.0", note = "named `artifacts`, as the flag and `SAFER_ARTIFACTS_DIR` are")]
    pub fn artefacts(self, dir: impl AsRef<Path>) -> Self {
        self.artifacts(dir)
    }

    /// Registers an in-process planner under `name`, for suites that say
    /// `planner: { rust: NAME }`. `make` builds a fresh planner for each
    /// variant from the scenario and its ego.
    pub fn planner<P, F>(mut self, name: &str, make: F) -> Self
    where
        P: Planner + 'static,
        F: Fn(&Scenario, TrackIndex) -> P + Send + Sync + 'static,
    {
        let factory: PlannerFactory = Arc::new(move |s: &Scenario, ego: TrackIndex| Box::new(make(s, ego)) as _);
        if let Err(e) = self.planners.register(name, factory) {
            self.registration_errors.push(e.to_string());
        }
        self
    }

    /// The suite folders read: those given, else `specs/suites`.
    fn suite_dirs(&self) -> Vec<PathBuf> {
        if self.suite_dirs.is_empty() { vec![self.root.join("specs/suites")] } else { self.suite_dirs.clone() }
    }

    /// One trial per variant and per suite metric of every suite; a suite
    /// that does not load is one failing trial, a folder without suites too
    /// (zero trials would "pass").
    pub fn trials(&self) -> Vec<Trial> {
        self.load().trials
    }

    fn load(&self) -> Loaded {
        let mut loaded = Loaded::default();
        for (i, message) in self.registration_errors.iter().enumerate() {
            let message = message.clone();
            loaded.trials.push(Trial::test(format!("runner::planner-{i}"), move || Err(Failed::from(message))));
        }
        let context = Arc::new(TrialContext {
            snapshots: self.snapshots.clone(),
            artefacts: self.artefacts.clone(),
            deny_warnings: self.deny_warnings,
        });
        for dir in self.suite_dirs() {
            let files = Suite::discover(&dir);
            if files.is_empty() {
                let message = format!("no suite (*.yaml) found in {}", dir.display());
                loaded.trials.push(Trial::test(format!("suites::discover::{}", dir.display()), move || {
                    Err(Failed::from(message))
                }));
            }
            for path in files {
                suite_trials(&path, &self.planners, &context, &mut loaded);
            }
        }
        loaded
    }

    /// Runs the trials selected by `args`. When a variant or metric
    /// failed, it also writes the review page of what ran
    /// (one HTML page with every variant's verdict, picture and animation)
    /// to `ARTEFACTS/review/index.html` and says
    /// where; not under nextest, whose processes each run one test.
    pub fn run_with(&self, args: &Arguments) -> Conclusion {
        if cfg!(debug_assertions) && !args.list {
            // A planner crate's plain `cargo test` builds its dependencies
            // unoptimised, and safer's numeric work is then many times slower.
            eprintln!(
                "note: safer runs unoptimised in this build; add `[profile.dev.package.\"*\"] opt-level = 3` to \
                 your Cargo.toml (or test with `--release`) for suites many times faster"
            );
        }
        let loaded = self.load();
        if !loaded.skipped_for_data.is_empty() && !args.list {
            eprintln!(
                "note: {} suite(s) over recorded data are ignored: SAFER_DATA_DIR is not set \
                 (set it to run them; docs/guide/recorded-data.md)",
                loaded.skipped_for_data.len()
            );
        }
        if !args.list {
            for (_, suite) in &loaded.suites {
                suite.spec.warnings().iter().for_each(|w| eprintln!("{}", w.render(false)));
            }
        }
        let (suites, load_failures) = (loaded.suites, loaded.load_failures);
        let conclusion = libtest_mimic::run(args, loaded.trials);
        let under_nextest = std::env::var_os("NEXTEST").is_some();
        if conclusion.has_failed() && !args.list && !under_nextest {
            let results = results_of_this_process(&suites, load_failures);
            let dir = self.artefacts.join("review");
            match harness::report::review_page::write_review_page(&dir, &results) {
                Ok(page) => eprintln!("review page: {}", page.display()),
                Err(e) => eprintln!("(could not write the review page: {e})"),
            }
        }
        conclusion
    }

    /// Runs the trials selected by the command line (libtest's and
    /// nextest's arguments) and exits with libtest's exit code.
    pub fn run(self) -> ! {
        self.run_with(&Arguments::from_args()).exit()
    }
}

/// The trials of a run and what they were made from.
#[derive(Default)]
struct Loaded {
    trials: Vec<Trial>,
    /// Suites over recorded data, ignored for want of `SAFER_DATA_DIR`.
    skipped_for_data: Vec<PathBuf>,
    suites: Vec<(PathBuf, Arc<Suite>)>,
    load_failures: Vec<SuiteLoadFailure>,
}

/// The review page's input: every variant this process ran (in suite,
/// scenario and seed order), with the suite checks where all of a suite's
/// variants ran.
fn results_of_this_process(suites: &[(PathBuf, Arc<Suite>)], load_failures: Vec<SuiteLoadFailure>) -> RunResults {
    let mut results = RunResults { load_failures, suites: Vec::new() };
    for (file, suite) in suites {
        let mut variants = Vec::new();
        let mut all_ran = true;
        for scenario in &suite.scenarios {
            for k in 0..suite.spec.value.variants {
                let name = suite.variant_name(scenario, k);
                match ran(&name) {
                    Some(Ran { outcome, artefacts, snapshot }) => variants.push(VariantRun {
                        name,
                        outcome: outcome.as_ref().clone(),
                        artefacts,
                        snapshot,
                        wall_s: None,
                    }),
                    None => all_ran = false,
                }
            }
        }
        if variants.is_empty() {
            continue;
        }
        // The mutation run, where this process's mutation-score test made it.
        let mutation = mutations().lock().unwrap_or_else(|p| p.into_inner()).get(&suite.name()).cloned();
        // Metrics are shown only where this process ran every variant of
        // the suite (a filtered run has no verdict on the rest).
        let (metrics, checks) = if all_ran {
            harness::metrics::suite_verdict(
                &suite.spec.value.acceptance.suite,
                variants.iter().map(|v| (v.name.clone(), v.outcome.as_ref().map(|o| &o.tally).map_err(Clone::clone))),
                mutation.as_ref().and_then(|m| m.check(&suite.spec.value.acceptance.suite)),
            )
        } else {
            (None, Vec::new())
        };
        results.suites.push(SuiteRun {
            file: file.clone(),
            name: suite.name(),
            planner: suite.planner.name().to_string(),
            variants,
            metrics,
            checks,
            mutation: mutation.map(|m| m.as_ref().clone()),
            wall_s: None,
            warnings: suite.spec.warnings().iter().map(ToString::to_string).collect(),
        });
    }
    results
}

/// What every trial of a run needs besides its suite.
#[derive(Debug)]
struct TrialContext {
    snapshots: PathBuf,
    artefacts: PathBuf,
    /// [`Runner::deny_warnings`].
    deny_warnings: bool,
}

/// The trials of one suite file.
fn suite_trials(path: &Path, planners: &PlannerRegistry, context: &Arc<TrialContext>, loaded: &mut Loaded) {
    let file = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let out = &mut loaded.trials;
    let suite = match Suite::load_with(path, planners) {
        Ok(s) => Arc::new(s),
        Err(e)
            if crate::spec::paths::is_missing_data_dir(&e.to_string())
                && !crate::spec::paths::recorded_data_required() =>
        {
            // A suite over recorded data, on a machine without it: listed
            // as ignored, saying how to run it (CI sets `CI`, so there
            // the load error below fails instead).
            out.push(
                Trial::test(format!("{file}::recorded-data"), || {
                    Err(Failed::from("needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)"))
                })
                .with_ignored_flag(true),
            );
            loaded.skipped_for_data.push(path.to_path_buf());
            return;
        }
        Err(e) => {
            // A broken suite is one failing test; the other suites still run.
            let report = e.render(false);
            loaded.load_failures.push(SuiteLoadFailure { file: path.to_path_buf(), message: e.to_string() });
            out.push(Trial::test(format!("{file}::load"), move || Err(Failed::from(report))));
            return;
        }
    };
    if context.deny_warnings
        && let Some(denied) = crate::spec::WarningsDenied::of(suite.spec.warnings())
    {
        let report = denied.render(false);
        loaded.load_failures.push(SuiteLoadFailure { file: path.to_path_buf(), message: denied.to_string() });
        out.push(Trial::test(format!("{file}::load"), move || Err(Failed::from(report))));
        return;
    }
    loaded.suites.push((path.to_path_buf(), suite.clone()));
    let name = suite.name();
    for (si, scenario) in suite.scenarios.iter().enumerate() {
        for k in 0..suite.spec.value.variants {
            let (s, c) = (suite.clone(), context.clone());
            out.push(Trial::test(suite.variant_name(scenario, k), move || variant_trial(&s, &c, si, k)));
        }
    }
    for metric in harness::metrics::metric_names(&suite.spec.value.acceptance.suite) {
        let s = suite.clone();
        out.push(Trial::test(format!("{name}::{metric}"), move || metric_trial(&s, metric)));
    }
}

type Shared = Arc<Result<VariantOutcome, String>>;
type WrittenArtefacts = Option<Result<Artefacts, String>>;

/// A variant this process ran: its outcome, the artefacts its trial wrote
/// and how its snapshot compared.
#[derive(Clone)]
struct Ran {
    outcome: Shared,
    artefacts: WrittenArtefacts,
    snapshot: SnapshotCheck,
}

/// Variant outcomes computed in this process, shared by the variant trial
/// and the suite's metric trials (nextest runs each in its own process, so
/// metric trials then compute the variants themselves), with what the
/// variant trial added: the artefacts it wrote and its snapshot's verdict,
/// so the review page tells the verdict the test did.
fn cache() -> &'static Mutex<HashMap<String, Ran>> {
    static CACHE: OnceLock<Mutex<HashMap<String, Ran>>> = OnceLock::new();
    CACHE.get_or_init(Default::default)
}

fn outcome(suite: &Suite, scenario: usize, index: u32) -> Shared {
    let name = suite.variant_name(&suite.scenarios[scenario], index);
    if let Some(r) = cache().lock().unwrap_or_else(|p| p.into_inner()).get(&name) {
        return r.outcome.clone();
    }
    let o = Arc::new(harness::run_variant(suite, &suite.scenarios[scenario], index).map_err(|e| e.to_string()));
    let entry = Ran { outcome: o, artefacts: None, snapshot: SnapshotCheck::NotCompared };
    cache().lock().unwrap_or_else(|p| p.into_inner()).entry(name).or_insert(entry).outcome.clone()
}

/// What this process has of a variant it ran.
fn ran(name: &str) -> Option<Ran> {
    cache().lock().unwrap_or_else(|p| p.into_inner()).get(name).cloned()
}

/// The verdict comes first: a variant that fails its criteria reports what
/// happened and where its artefacts are, and only then is its snapshot
/// compared (a snapshot diff must never hide a failing verdict).
fn variant_trial(suite: &Suite, context: &TrialContext, scenario: usize, index: u32) -> Result<(), Failed> {
    let shared = outcome(suite, scenario, index);
    let o = shared.as_ref().as_ref().map_err(|e| Failed::from(format!("could not run the variant: {e}")))?;
    let mut verdict = String::new();
    for f in &o.failures {
        verdict.push_str(&format!("  ✗ {}: {}\n", f.criterion, f.what));
    }
    if !o.failures.is_empty() {
        if let Some(shrunk) = o.summary().shrunk {
            verdict.push_str(&format!(
                "  shrunk: {} (the recording and picture show the shrunk variant; `.unshrunk` ones the variant as made)\n",
                shrunk.describe()
            ));
        }
        if let Some(why) = &o.not_shrunk {
            verdict.push_str(&format!("  not shrunk: {why}\n"));
        }
        let written = harness::artefacts::write(&context.artefacts, o, harness::artefacts::search_stage1_escape(o));
        match &written {
            Ok(a) => {
                verdict.push_str(&format!("  recording: {}\n  picture:   {}\n", a.mcap.display(), a.svg.display()));
                verdict.push_str(&format!(
                    "  stage 1:   {} ({})\n",
                    a.stage1.1.display(),
                    harness::artefacts::STAGE1_SHOWS
                ));
                if let Some(stderr) = &a.stderr {
                    verdict.push_str(&format!("  planner stderr: {}\n", stderr.display()));
                }
                if let Some(witness) = &a.witness {
                    verdict.push_str(&format!("  feasibility witness: {}\n", witness.verdict().describe()));
                }
            }
            Err(e) => verdict.push_str(&format!("  (could not write artefacts: {e})\n")),
        }
        if let Some(entry) = cache().lock().unwrap_or_else(|p| p.into_inner()).get_mut(&o.name) {
            entry.artefacts = Some(written.map_err(|e| e.to_string()));
        }
        // Printed before the snapshot comparison, whose diff insta prints itself.
        eprintln!("{}:\n{verdict}", o.name);
    }
    let summary = o.summary();
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path(&context.snapshots);
    settings.set_prepend_module_to_snapshot(false);
    settings.set_omit_expression(true);
    // Explicit names: automatic ones race between parallel trials.
    let snapshot = o.name.replace("::", "__");
    let file = context.snapshots.join(format!("{snapshot}.snap"));
    let existed = file.is_file();
    // The snapshot names the suite it belongs to, not this file.
    settings.set_input_file(&suite.spec.path);
    let compared = quietly(|| settings.bind(|| insta::assert_yaml_snapshot!(snapshot.as_str(), summary)));
    let check = match (&compared, existed) {
        (Ok(()), _) => SnapshotCheck::Matches,
        (Err(_), true) => SnapshotCheck::Differs(file.clone()),
        (Err(_), false) => SnapshotCheck::New(file.clone()),
    };
    if let Some(entry) = cache().lock().unwrap_or_else(|p| p.into_inner()).get_mut(&o.name) {
        entry.snapshot = check;
    }
    let snapshot_note = compared.err().map(|_| {
        if existed {
            format!(
                "  snapshot {} differs (diff above); accept it with `cargo insta review`, or \
                 `INSTA_UPDATE=always cargo test` without cargo-insta\n",
                file.display()
            )
        } else {
            format!(
                "  snapshot {} is new (content above): a new suite's first run records its snapshots; accept \
                 them with `cargo insta accept`, or `INSTA_UPDATE=always cargo test` without cargo-insta\n",
                file.display()
            )
        }
    });
    match (o.failures.is_empty(), snapshot_note) {
        (true, None) => Ok(()),
        (true, Some(note)) => Err(Failed::from(note)),
        (false, note) => Err(Failed::from(verdict + &note.unwrap_or_default())),
    }
}

thread_local! {
    /// Set while a snapshot is compared on this thread: insta reports a
    /// mismatch by panicking, and the trial already says what it means.
    static QUIET_PANICS: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `compare`, catching its panic without the panic hook's message and
/// backtrace (60 lines a mismatch with `RUST_BACKTRACE=1`); panics on other
/// threads, and outside `compare`, are reported as before.
fn quietly(compare: impl FnOnce()) -> std::thread::Result<()> {
    static HOOK: OnceLock<()> = OnceLock::new();
    HOOK.get_or_init(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET_PANICS.with(std::cell::Cell::get) {
                previous(info);
            }
        }));
    });
    QUIET_PANICS.with(|q| q.set(true));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(compare));
    QUIET_PANICS.with(|q| q.set(false));
    result
}

fn metric_trial(suite: &Suite, metric: &'static str) -> Result<(), Failed> {
    let mut outcomes = Vec::new();
    for s in 0..suite.scenarios.len() {
        for k in 0..suite.spec.value.variants {
            outcomes.push((s, k, suite.variant_name(&suite.scenarios[s], k), outcome(suite, s, k)));
        }
    }
    let mutation = (metric == harness::metrics::MUTATION_SCORE).then(|| mutation_report(suite, &outcomes));
    let variants = outcomes
        .iter()
        .map(|(_, _, name, o)| (name.clone(), o.as_ref().as_ref().map(|o| &o.tally).map_err(|e| e.to_string())));
    let acceptance = &suite.spec.value.acceptance.suite;
    let mutation_score = mutation.as_ref().and_then(|m| m.check(acceptance));
    let (_, checks) = harness::metrics::suite_verdict(acceptance, variants, mutation_score);
    let check = checks
        .into_iter()
        .find(|c| c.name == metric)
        .ok_or_else(|| Failed::from(format!("metric {metric} not configured")))?;
    check.result.map_err(|why| match &mutation {
        // A failing mutation score says which mutant survived and what
        // scene would catch it.
        Some(m) => Failed::from(format!("{why}\n  {}\n    {}", m.headline(), m.table().join("\n    "))),
        None => Failed::from(why),
    })
}

/// Mutation runs made in this process, by suite name (for the review page).
fn mutations() -> &'static Mutex<HashMap<String, Arc<MutationReport>>> {
    static MUTATIONS: OnceLock<Mutex<HashMap<String, Arc<MutationReport>>>> = OnceLock::new();
    MUTATIONS.get_or_init(Default::default)
}

/// The suite's mutants run on every variant (in parallel, each on its
/// variant's own stage 1) and the report they make.
fn mutation_report(suite: &Suite, outcomes: &[(usize, u32, String, Shared)]) -> Arc<MutationReport> {
    use rayon::prelude::*;
    let operators = harness::mutation::operators_for(&suite.spec.value.acceptance.suite, None);
    let runs: Vec<Vec<MutantRun>> = outcomes
        .par_iter()
        .map(|(s, k, _, o)| match o.as_ref() {
            Ok(o) => harness::mutation::run_mutants(suite, &suite.scenarios[*s], *k, o, &operators),
            Err(_) => Vec::new(),
        })
        .collect();
    let report = Arc::new(MutationReport::of(
        &operators,
        outcomes.iter().zip(&runs).map(|((_, _, name, o), runs)| {
            (name.as_str(), o.as_ref().as_ref().ok().map(|o| o.failures.as_slice()), runs.as_slice())
        }),
    ));
    mutations().lock().unwrap_or_else(|p| p.into_inner()).insert(suite.name(), report.clone());
    report
}
