//! `safer prior-fit --scenes DIR`: how well the realism prior predicts the
//! recorded driving of a folder of scenes (`eval::prior_fit`), with its
//! history ending at each token boundary (as in closed loop) and one step
//! late (0.1 s into the token to be predicted), side by side; the
//! held-out tenth of the scenes (by id) beside the rest.
//!
//! Scenes run in parallel; each scene's sums are added in scenario-id
//! order, so the output does not depend on the thread count.

use super::*;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use rayon::prelude::*;

use super::{CliError, figure, scene_paths};
use safer_scenarios::eval::prior_fit::{
    HistoryAlignment, PriorFit, TURNING_YAW_RATE_RADPS, TokenKindFit, YAW_RATE_MISS_BUCKETS, prior_fit,
};
use safer_scenarios::harness::evaluation::held_out_scenes;
use safer_scenarios::models::ModelSource;
use safer_scenarios::models::prior::{PriorVariant, RealismPrior};
use safer_scenarios::scenario::{Scenario, import};

/// What `safer prior-fit` was asked.
#[derive(Debug, Clone)]
pub struct PriorFitRequest {
    /// Folder of scenes, or one file.
    pub scenes: PathBuf,
    /// Trust-region size n.
    pub top_n: usize,
    /// Agents slower than this at a boundary are not scored, m/s.
    pub min_speed_mps: f64,
    /// Which of the shipped priors (or `$SAFER_MODELS`'s).
    pub variant: PriorVariant,
    /// Score at most this many scenes (by id).
    pub max_scenes: Option<usize>,
    /// Also write the JSON report here (`-`: standard output).
    pub json: Option<PathBuf>,
}

/// Which scenes a row sums over.
type SceneFilter<'a> = dyn Fn(&Scenario) -> bool + 'a;

/// One group's fit, as the table and the JSON report give it (means, `None`
/// without samples).
#[derive(Debug, serde::Serialize)]
struct FitRow {
    history: HistoryAlignment,
    /// `all`, `held-out` (every tenth scene by id) or `rest`.
    scenes: &'static str,
    samples: usize,
    nll: Option<f64>,
    top1: Option<f64>,
    in_top_n: Option<f64>,
    accel_range_mps2: Option<f64>,
    yaw_rate_range_radps: Option<f64>,
    /// The recorded turning tokens (yaw rate at least 0.3 rad/s).
    turning: KindRow,
    /// The recorded turn onsets (a turning token after one that does not turn).
    turn_onset: KindRow,
}

/// One kind of recorded token in a row: samples, NLL, share in the top n
/// and how many yaw-rate bins the top n miss them by (mean, and shares of
/// 0, 1-2, 3-5, 6+ bins).
#[derive(Debug, serde::Serialize)]
struct KindRow {
    samples: usize,
    nll: Option<f64>,
    in_top_n: Option<f64>,
    yaw_rate_miss_bins: Option<f64>,
    yaw_rate_miss_shares: Option<[f64; YAW_RATE_MISS_BUCKETS.len()]>,
}

impl KindRow {
    fn new(fit: &TokenKindFit) -> Self {
        Self {
            samples: fit.samples,
            nll: fit.nll(),
            in_top_n: fit.in_top_n_share(),
            yaw_rate_miss_bins: fit.yaw_rate_miss_bins(),
            yaw_rate_miss_shares: fit.yaw_rate_miss_shares(),
        }
    }
}

impl FitRow {
    /// Kinds of recorded token scored apart.
    const KINDS: usize = 2;

    /// The kinds of recorded token scored apart, with their table labels.
    fn kinds(&self) -> [(&'static str, &KindRow); Self::KINDS] {
        [("turning", &self.turning), ("turn onset", &self.turn_onset)]
    }

    fn new(history: HistoryAlignment, scenes: &'static str, fit: &PriorFit) -> Self {
        Self {
            history,
            scenes,
            samples: fit.samples,
            nll: fit.nll(),
            top1: fit.top1_share(),
            in_top_n: fit.in_top_n_share(),
            accel_range_mps2: fit.accel_range_mps2(),
            yaw_rate_range_radps: fit.yaw_rate_range_radps(),
            turning: KindRow::new(&fit.turning),
            turn_onset: KindRow::new(&fit.turn_onset),
        }
    }
}

/// One scene's sums under both alignments.
#[derive(Debug, serde::Serialize)]
struct SceneFit<'a> {
    scenario: &'a str,
    at_boundary: PriorFit,
    one_step_late: PriorFit,
}

/// The JSON report.
#[derive(Debug, serde::Serialize)]
struct Report<'a> {
    scenes: usize,
    held_out_scenes: usize,
    prior: &'a str,
    top_n: usize,
    min_speed_mps: f64,
    rows: &'a [FitRow],
    per_scene: Vec<SceneFit<'a>>,
}

/// One row's figures, `—` where there are no samples.
fn row(out: &mut dyn Write, history: &str, scenes: &str, r: &FitRow) -> std::io::Result<()> {
    writeln!(
        out,
        "{history:<15} {scenes:<9} {:>8} {:>7} {:>7} {:>9} {:>11} {:>10}",
        r.samples,
        figure(r.nll, 3),
        figure(r.top1, 3),
        figure(r.in_top_n, 3),
        figure(r.accel_range_mps2, 2),
        figure(r.yaw_rate_range_radps, 3),
    )
}

/// Runs the command.
pub(super) fn run(args: &PriorFitRequest) -> Result<ExitCode, CliError> {
    let prior = RealismPrior::load(&ModelSource::shipped(), args.variant)?;
    // A file that does not load is reported and the others are scored; the
    // run then ends with status 1.
    let mut scenes: Vec<Scenario> = Vec::new();
    let mut failed = 0;
    for path in scene_paths(&args.scenes)? {
        match import::load(&path) {
            Ok(loaded) => scenes.extend(loaded),
            Err(e) => {
                eprintln!("error: {e}");
                failed += 1;
            }
        }
    }
    scenes.sort_by(|a, b| a.id.cmp(&b.id));
    if let Some(n) = args.max_scenes {
        scenes.truncate(n);
    }
    let held_out = held_out_scenes(scenes.iter().map(|s| s.id.as_str()));
    let alignments = [HistoryAlignment::AtBoundary, HistoryAlignment::OneStepLate];
    let progress = super::progress::Progress::new("prior-fit", "scenes", scenes.len());
    let per_scene: Vec<Vec<PriorFit>> = scenes
        .par_iter()
        .map(|scenario| {
            let fit = prior_fit(&prior, scenario, &alignments, args.top_n, args.min_speed_mps);
            progress.tick();
            fit
        })
        .collect::<Result<_, _>>()?;
    drop(progress);
    let total = |keep: &SceneFilter, a: usize| {
        scenes.iter().zip(&per_scene).filter(|(s, _)| keep(s)).fold(PriorFit::default(), |acc, (_, f)| acc + f[a])
    };
    let groups: [(&str, &SceneFilter); 3] = [
        ("all", &|_| true),
        ("held-out", &|s| held_out.contains(s.id.as_str())),
        ("rest", &|s| !held_out.contains(s.id.as_str())),
    ];
    let mut rows: Vec<FitRow> = Vec::new();
    for (a, &history) in alignments.iter().enumerate() {
        for &(group, keep) in &groups {
            rows.push(FitRow::new(history, group, &total(keep, a)));
        }
    }
    let prior_name = serde_json::to_value(args.variant)?.as_str().unwrap_or("?").to_string();
    let report = Report {
        scenes: scenes.len(),
        held_out_scenes: held_out.len(),
        prior: &prior_name,
        top_n: args.top_n,
        min_speed_mps: args.min_speed_mps,
        rows: &rows,
        per_scene: scenes
            .iter()
            .zip(&per_scene)
            .map(|(s, f)| SceneFit { scenario: &s.id, at_boundary: f[0], one_step_late: f[1] })
            .collect(),
    };
    super::write_report_and_table(args.json.as_deref(), &report, |out| {
        writeln!(
            out,
            "{} scenes; {prior_name} prior; moving vehicles (> {} m/s) at token boundaries; top n = {}",
            scenes.len(),
            args.min_speed_mps,
            args.top_n
        )?;
        writeln!(
            out,
            "{:<15} {:<9} {:>8} {:>7} {:>7} {:>9} {:>11} {:>10}",
            "history", "scenes", "samples", "NLL", "top-1", "in top n", "accel m/s²", "yaw rad/s"
        )?;
        for r in &rows {
            let history = match r.history {
                HistoryAlignment::AtBoundary => "at boundary",
                HistoryAlignment::OneStepLate => "one step late",
            };
            row(out, history, &r.scenes.replace('-', " "), r)?;
        }
        writeln!(
            out,
            "recorded tokens that turn (yaw rate ≥ {TURNING_YAW_RATE_RADPS} rad/s either way) and that begin a turn \
             (the token before does not turn), history at the boundary; miss: yaw-rate bins from the recorded token \
             to the nearest of the top n (0: one steers as it did)"
        )?;
        let buckets: String =
            YAW_RATE_MISS_BUCKETS.iter().map(|(label, _)| format!(" {:>9}", format!("{label} bins"))).collect();
        writeln!(
            out,
            "{:<16} {:<9} {:>8} {:>7} {:>9} {:>10}{buckets}",
            "kind", "scenes", "samples", "NLL", "in top n", "miss mean"
        )?;
        let at_boundary = || rows.iter().filter(|r| r.history == HistoryAlignment::AtBoundary);
        for kind in 0..FitRow::KINDS {
            for r in at_boundary() {
                let (label, k) = r.kinds()[kind];
                let shares: String = (0..YAW_RATE_MISS_BUCKETS.len())
                    .map(|i| format!(" {:>9}", figure(k.yaw_rate_miss_shares.map(|shares| shares[i]), 3)))
                    .collect();
                writeln!(
                    out,
                    "{label:<16} {:<9} {:>8} {:>7} {:>9} {:>10}{shares}",
                    r.scenes.replace('-', " "),
                    k.samples,
                    figure(k.nll, 3),
                    figure(k.in_top_n, 3),
                    figure(k.yaw_rate_miss_bins, 2)
                )?;
            }
        }
        writeln!(
            out,
            "history at boundary: ending at the token boundary, as in closed loop; one step late: ending 0.1 s \
             into the token to be predicted (a prior that fits far better so reads the token's start from its input)"
        )?;
        writeln!(out, "held out: every tenth scene by id ({} of {})", held_out.len(), scenes.len())?;
        writeln!(out, "NLL in nats (uniform over the 3 969 tokens: 8.29); accel / yaw: mean range of the top n")?;
        Ok(())
    })?;
    if failed > 0 {
        eprintln!("error: {failed} scene file(s) could not be read; the figures leave them out");
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

/// The arguments of `safer prior-fit`.
#[derive(Debug, clap::Args)]
pub(crate) struct PriorFitArgs {
    /// Folder of scenario files (searched recursively), or one file; `data:REL` is in $SAFER_DATA_DIR.
    #[arg(long, value_parser = data_path)]
    pub(crate) scenes: PathBuf,
    /// Trust-region size n (top-n tokens of the prior), from 1 to the vocabulary size
    /// (`--trust-region`, as `evaluate` and `trust-region` name it; `--top-n` is accepted too).
    #[arg(long = "trust-region", alias = "top-n", value_name = "N", default_value_t = 20, value_parser = RangedU64ValueParser::<usize>::new().range(1..=VOCABULARY_SIZE as u64))]
    pub(crate) top_n: usize,
    /// Vehicles slower than this at a boundary are not scored, m/s (non-negative, finite; standing cars' tokens are trivial).
    #[arg(long, default_value_t = 1.0, value_parser = non_negative_finite, allow_negative_numbers = true)]
    pub(crate) min_speed_mps: f64,
    /// Which prior: the differential-attention one (default) or the plain-attention one; `$SAFER_MODELS` swaps in another model set.
    #[arg(long, value_parser = choice(safer_scenarios::models::prior::PriorVariant::ALL), default_value = "differential")]
    pub(crate) prior: safer_scenarios::models::prior::PriorVariant,
    /// Score at most this many scenes (by id), at least 1.
    #[arg(long, value_name = "N", value_parser = at_least_one())]
    pub(crate) max_scenes: Option<usize>,
    /// Also write the fits (all, held-out and other scenes, and each scene's sums) as JSON (`-`: standard output).
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub(crate) json: Option<PathBuf>,
}

/// Runs `safer prior-fit`.
pub(crate) fn command(args: PriorFitArgs) -> Result<ExitCode, CliError> {
    let PriorFitArgs { scenes, top_n, min_speed_mps, prior, max_scenes, json } = args;
    run(&PriorFitRequest { scenes, top_n, min_speed_mps, variant: prior, max_scenes, json })
}
