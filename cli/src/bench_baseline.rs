//! `safer bench --baseline OTHER`: this build's `safer bench` beside
//! another build's, in one run. A shared machine's speed drifts by more
//! than most changes gain, so two builds compare only when their runs
//! interleave: each round runs both builds' `safer bench` once (which goes
//! first alternates from round to round), each timed figure's ratio is
//! taken within its round, and the report gives the rounds' median ratio
//! and range beside each build's median.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};

use serde_json::Value;

use super::CliError;

/// What to compare: the `safer bench` options both builds run with.
pub(super) struct BaselineBench<'a> {
    /// Scenes both builds read (`--scenes`, already resolved).
    pub scenes: &'a Path,
    /// `--repeat` of each build's runs.
    pub repeat: usize,
    /// Rounds, each running both builds once.
    pub rounds: usize,
    /// The other build's `safer` binary.
    pub baseline: &'a Path,
}

/// The timed figures of one `safer bench` report, in ms, in the report's
/// order, each labelled by its place in it (`variant.stage2_ms`,
/// `import[womd-json].import_ms_per_scene`, `simulator[ID].run_ms`).
type TimedFigures = Vec<(String, f64)>;

/// The two builds, in the order each report lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Build {
    Baseline,
    This,
}

/// One figure of both builds over the rounds.
#[derive(Debug, serde::Serialize)]
struct FigureComparison {
    /// Where the figure sits in `safer bench --json`'s report.
    figure: String,
    /// The baseline's figure, one a round (`None`: its report lacked it).
    baseline_ms: Vec<Option<f64>>,
    /// This build's figure, one a round.
    this_ms: Vec<Option<f64>>,
    baseline_median_ms: Option<f64>,
    this_median_ms: Option<f64>,
    /// Median over the rounds of `this / baseline` within a round.
    ratio_median: Option<f64>,
    ratio_min: Option<f64>,
    ratio_max: Option<f64>,
}

/// The whole comparison (`--json`).
#[derive(Debug, serde::Serialize)]
struct BaselineReport {
    baseline: PathBuf,
    this_build: PathBuf,
    rounds: usize,
    repeat: usize,
    figures: Vec<FigureComparison>,
}

/// Runs both builds' `safer bench` round by round and prints each timed
/// figure of both beside their ratio.
pub(super) fn run(bench: BaselineBench<'_>, json: Option<&Path>) -> Result<ExitCode, CliError> {
    if let Some(path) = json {
        super::check_json_report(path)?;
    }
    let fail = |problem: String| CliError::Baseline { binary: bench.baseline.to_path_buf(), problem };
    if !bench.baseline.is_file() {
        return Err(fail("no such file".into()));
    }
    // Run by its full path: a bare name would otherwise be looked up on
    // PATH rather than in the folder where it was found.
    let baseline = std::fs::canonicalize(bench.baseline).map_err(|e| fail(format!("cannot resolve its path: {e}")))?;
    let this_build = std::env::current_exe()
        .map_err(|e| CliError::Usage(format!("cannot find this build's own binary to run it: {e}")))?;
    let scratch = ReportFolder::new()?;
    let mut reports: BTreeMap<String, [Vec<Option<f64>>; 2]> = BTreeMap::new();
    let mut order: Vec<String> = Vec::new();
    for round in 0..bench.rounds {
        let builds = if round % 2 == 0 { [Build::Baseline, Build::This] } else { [Build::This, Build::Baseline] };
        for build in builds {
            let binary = match build {
                Build::Baseline => baseline.as_path(),
                Build::This => this_build.as_path(),
            };
            eprintln!("round {} of {}: {} build ({})", round + 1, bench.rounds, build.name(), binary.display());
            let report = scratch.path().join(format!("round-{round}-{}.json", build.name()));
            let figures = bench_once(binary, &bench, &report).map_err(|problem| match build {
                Build::Baseline => fail(problem),
                Build::This => CliError::Usage(format!("this build's bench: {problem}")),
            })?;
            for (figure, ms) in figures {
                let rows = reports.entry(figure.clone()).or_insert_with(|| {
                    order.push(figure);
                    [vec![None; bench.rounds], vec![None; bench.rounds]]
                });
                rows[build as usize][round] = Some(ms);
            }
        }
    }
    // The variant's figures first, then the rest as they came (a stable
    // sort); the figures only the baseline reports last.
    order.sort_by_key(|f| (reports[f][Build::This as usize].iter().all(Option::is_none), table_rank(f)));
    let figures: Vec<FigureComparison> = order
        .into_iter()
        .map(|figure| {
            let [baseline_ms, this_ms] = reports.remove(&figure).expect("every label has its rows");
            FigureComparison::new(figure, baseline_ms, this_ms)
        })
        .collect();

    let report = BaselineReport { baseline, this_build, rounds: bench.rounds, repeat: bench.repeat, figures };
    super::write_report_and_table(json, &report, |out| print_table(out, &report))?;
    Ok(ExitCode::SUCCESS)
}

/// The comparison as a table: each figure's medians and ratio.
fn print_table(out: &mut dyn Write, report: &BaselineReport) -> std::io::Result<()> {
    writeln!(
        out,
        "safer bench against a baseline build: {} rounds, each running both builds once (which goes first alternates), each run the median of {}\n  baseline:   {}\n  this build: {}\n",
        report.rounds,
        report.repeat,
        report.baseline.display(),
        report.this_build.display()
    )?;
    let width = report.figures.iter().map(|f| f.figure.chars().count()).max().unwrap_or(0).max(6);
    writeln!(
        out,
        "{:<width$} {:>12} {:>12} {:>16} {:>15}",
        "figure", "baseline ms", "this ms", "this ÷ baseline", "rounds' range"
    )?;
    for f in &report.figures {
        let range = match (f.ratio_min, f.ratio_max) {
            (Some(lo), Some(hi)) => format!("{lo:.2}–{hi:.2}"),
            _ => super::figure(None, 0),
        };
        writeln!(
            out,
            "{:<width$} {:>12} {:>12} {:>16} {:>15}",
            f.figure,
            super::figure(f.baseline_median_ms, 1),
            super::figure(f.this_median_ms, 1),
            super::figure(f.ratio_median, 2),
            range
        )?;
    }
    Ok(())
}

/// A folder of this process's own for the builds' JSON reports, removed
/// with everything in it when dropped.
struct ReportFolder(PathBuf);

impl ReportFolder {
    fn new() -> std::io::Result<Self> {
        let path = std::env::temp_dir().join(format!("safer-bench-baseline-{}", std::process::id()));
        std::fs::create_dir_all(&path)?;
        Ok(Self(path))
    }

    fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for ReportFolder {
    fn drop(&mut self) {
        // Best effort: a left-over folder in the temporary folder harms nothing.
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

impl Build {
    fn name(self) -> &'static str {
        match self {
            Build::Baseline => "baseline",
            Build::This => "this",
        }
    }
}

impl FigureComparison {
    fn new(figure: String, baseline_ms: Vec<Option<f64>>, this_ms: Vec<Option<f64>>) -> Self {
        let ratios: Vec<f64> =
            baseline_ms.iter().zip(&this_ms).filter_map(|(b, t)| Some(t.as_ref()? / b.filter(|b| *b > 0.0)?)).collect();
        let present = |v: &[Option<f64>]| v.iter().flatten().copied().collect::<Vec<_>>();
        Self {
            figure,
            baseline_median_ms: median(present(&baseline_ms)),
            this_median_ms: median(present(&this_ms)),
            ratio_median: median(ratios.clone()),
            ratio_min: ratios.iter().copied().reduce(f64::min),
            ratio_max: ratios.iter().copied().reduce(f64::max),
            baseline_ms,
            this_ms,
        }
    }
}

/// Where a figure goes in the table: the variant's, the headline, first,
/// with its parts under it as `safer bench` prints them; every other
/// figure after them. (The reports' own order is lost: serde_json's maps
/// sort their keys.)
fn table_rank(figure: &str) -> usize {
    const VARIANT: [&str; 9] = [
        "variant.variant_ms",
        "variant.stage1_ms",
        "variant.stage1_models_ms",
        "variant.stage2_ms",
        "variant.stage2_planner_ms",
        "variant.witness_ms",
        "variant.closed_loop_variant_ms",
        "variant.in_path_variant_ms",
        "variant.closed_loop_witness.ms",
    ];
    VARIANT.iter().position(|v| *v == figure).unwrap_or(VARIANT.len())
}

/// The median (the mean of the middle two for an even count); `None` for none.
fn median(mut v: Vec<f64>) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some(0.5 * (v[n / 2 - 1] + v[n / 2])),
    }
}

/// Runs `binary bench` with `bench`'s options, its JSON report written to
/// `report`, and reads that report's timed figures; the problem in words
/// when it fails or writes no report (not a `safer` build, or one without
/// `bench --json`).
fn bench_once(binary: &Path, bench: &BaselineBench<'_>, report: &Path) -> Result<TimedFigures, String> {
    // Whatever is found there afterwards is this run's report.
    let _ = std::fs::remove_file(report);
    let ran = Command::new(binary)
        .arg("bench")
        .arg("--scenes")
        .arg(bench.scenes)
        .args(["--repeat", &bench.repeat.to_string(), "--json"])
        .arg(report)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .map_err(|e| format!("could not be started: {e}"))?;
    let stderr = String::from_utf8_lossy(&ran.stderr);
    if !ran.status.success() {
        let tail: Vec<&str> = stderr.lines().rev().take(5).collect();
        let tail: Vec<&str> = tail.into_iter().rev().collect();
        return Err(format!("`bench` failed ({}):\n{}", ran.status, tail.join("\n")));
    }
    let text = std::fs::read(report).map_err(|e| {
        format!("`bench --json {}` wrote no report ({e}); is it a safer build with `bench --json`?", report.display())
    })?;
    let value: Value = serde_json::from_slice(&text)
        .map_err(|e| format!("its report {} is not JSON ({e}); is it a safer build?", report.display()))?;
    let figures = timed_figures(&value);
    if figures.is_empty() {
        return Err(format!("its report {} holds no timed figures; is it a safer build?", report.display()));
    }
    Ok(figures)
}

/// The timed figures of a `safer bench` JSON report: every number under a
/// key `ms` or ending in `_ms` or `_ms_per_scene` (targets, constants
/// rather than measurements, left out), and each simulator row's run time
/// (its steps over its steps per second). Rows of a list are named by
/// their `format` or `scene`.
fn timed_figures(report: &Value) -> TimedFigures {
    fn collect(v: &Value, at: &str, out: &mut TimedFigures) {
        let join = |key: &str| if at.is_empty() { key.to_string() } else { format!("{at}.{key}") };
        match v {
            Value::Object(map) => {
                let rate = |key: &str| map.get(key).and_then(Value::as_f64);
                if let (Some(steps), Some(per_s)) = (rate("steps"), rate("steps_per_s"))
                    && per_s > 0.0
                {
                    out.push((join("run_ms"), steps / per_s * 1e3));
                }
                for (key, value) in map {
                    let timed = (key == "ms" || key.ends_with("_ms") || key.ends_with("_ms_per_scene"))
                        && !key.contains("target");
                    match value {
                        Value::Number(n) if timed => out.extend(n.as_f64().map(|ms| (join(key), ms))),
                        Value::Object(_) | Value::Array(_) => collect(value, &join(key), out),
                        _ => {}
                    }
                }
            }
            Value::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    let name = ["format", "scene"]
                        .iter()
                        .find_map(|k| item.get(k)?.as_str())
                        .map_or_else(|| i.to_string(), str::to_string);
                    collect(item, &format!("{at}[{name}]"), out);
                }
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    collect(report, "", &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reports_timed_figures_are_its_times_by_place_without_targets_or_ratios() {
        let report = serde_json::json!({
            "profile": "release",
            "repeat": 3,
            "import": [{"format": "womd-json", "scenes": 2, "import_ms_per_scene": 4.0, "ratio_to_file_read": 9.0}],
            "simulator": [{"scene": "s1", "steps": 80, "steps_per_s": 400.0, "bare_replay_ms": 0.5}],
            "variant": {
                "stage1_ms": 20.0,
                "variant_ms": 55.0,
                "variant_target_ms": 50.0,
                "variant_ratio_to_target": 1.1,
                "closed_loop_witness": {"seed": 3, "ms": 900.0, "target_ms": 2000.0}
            }
        });
        let figures = timed_figures(&report);
        let get = |label: &str| figures.iter().find(|(l, _)| l == label).map(|(_, ms)| *ms);
        assert_eq!(get("import[womd-json].import_ms_per_scene"), Some(4.0));
        assert_eq!(get("simulator[s1].run_ms"), Some(200.0));
        assert_eq!(get("simulator[s1].bare_replay_ms"), Some(0.5));
        assert_eq!(get("variant.stage1_ms"), Some(20.0));
        assert_eq!(get("variant.variant_ms"), Some(55.0));
        assert_eq!(get("variant.closed_loop_witness.ms"), Some(900.0));
        assert_eq!(figures.len(), 6, "targets, ratios and counts are not times: {figures:?}");
    }

    #[test]
    fn each_ratio_is_taken_within_its_round_and_a_missing_side_gives_none() {
        // Round 2 ran on a slow patch: both builds twice as slow, the
        // ratio the same. Medians of each build's own figures would mix
        // the patch into both; the per-round ratios do not see it.
        let f = FigureComparison::new(
            "variant.variant_ms".into(),
            vec![Some(64.0), Some(128.0), Some(72.0), Some(80.0)],
            vec![Some(48.0), Some(96.0), Some(54.0), Some(64.0)],
        );
        assert_eq!(f.ratio_min, Some(0.75));
        assert_eq!(f.ratio_max, Some(0.8));
        assert_eq!(f.ratio_median, Some(0.75), "the mean of the middle two (0.75, 0.75)");
        assert_eq!(f.baseline_median_ms, Some(76.0));
        let only_this = FigureComparison::new("x".into(), vec![None, None], vec![Some(1.0), Some(3.0)]);
        assert_eq!((only_this.ratio_median, only_this.this_median_ms), (None, Some(2.0)));
        let zero_baseline = FigureComparison::new("x".into(), vec![Some(0.0)], vec![Some(1.0)]);
        assert_eq!(zero_baseline.ratio_median, None, "no ratio to a zero");
    }
}
