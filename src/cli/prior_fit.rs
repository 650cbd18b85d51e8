//! `safer prior-fit --scenes DIR`: how well the realism prior predicts the
//! recorded driving of a folder of scenes (`eval::prior_fit`), with its
//! history ending at each token boundary (as in closed loop) and one step
//! late (0.1 s into the token to be predicted), side by side; the
//! held-out tenth of the scenes (by id) beside the rest.
//!
//! Scenes run in parallel; each scene's sums are added in scenario-id
//! order, so the output does not depend on the thread count.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use rayon::prelude::*;

use super::{CliError, scene_paths};
use safer::eval::prior_fit::{HistoryAlignment, PriorFit, prior_fit};
use safer::harness::evaluation::held_out_scenes;
use safer::models::ModelSource;
use safer::models::prior::{PriorVariant, RealismPrior};
use safer::scenario::{Scenario, import};

/// What `safer prior-fit` was asked.
#[derive(Debug, Clone)]
pub struct PriorFitArgs {
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
}

/// One row's figures, `—` where there are no samples.
fn row(out: &mut dyn Write, history: &str, scenes: &str, fit: &PriorFit) -> std::io::Result<()> {
    let f = |v: Option<f64>, d: usize| v.map_or("—".to_string(), |v| format!("{v:.d$}"));
    writeln!(
        out,
        "{history:<15} {scenes:<9} {:>8} {:>7} {:>7} {:>9} {:>11} {:>10}",
        fit.samples,
        f(fit.nll(), 3),
        f(fit.top1_share(), 3),
        f(fit.in_top_n_share(), 3),
        f(fit.accel_range_mps2(), 2),
        f(fit.yaw_rate_range_radps(), 3),
    )
}

/// Runs the command.
pub(super) fn run(args: &PriorFitArgs) -> Result<ExitCode, CliError> {
    let prior = RealismPrior::load(&ModelSource::shipped(), args.variant)?;
    let mut scenes: Vec<Scenario> = Vec::new();
    for path in scene_paths(&args.scenes)? {
        scenes.extend(import::load(&path)?);
    }
    scenes.sort_by(|a, b| a.id.cmp(&b.id));
    if let Some(n) = args.max_scenes {
        scenes.truncate(n);
    }
    let held_out = held_out_scenes(scenes.iter().map(|s| s.id.as_str()));
    let alignments = [HistoryAlignment::AtBoundary, HistoryAlignment::OneStepLate];
    let per_scene: Vec<[PriorFit; 2]> = scenes
        .par_iter()
        .map(|scenario| -> Result<[PriorFit; 2], CliError> {
            let fit = |a| prior_fit(&prior, scenario, a, args.top_n, args.min_speed_mps);
            Ok([fit(alignments[0])?, fit(alignments[1])?])
        })
        .collect::<Result<_, _>>()?;
    let total = |keep: &dyn Fn(&Scenario) -> bool, a: usize| {
        scenes.iter().zip(&per_scene).filter(|(s, _)| keep(s)).fold(PriorFit::default(), |acc, (_, f)| acc + f[a])
    };
    let out = &mut std::io::stdout().lock();
    writeln!(
        out,
        "{} scenes; {} prior; moving vehicles (> {} m/s) at token boundaries; top n = {}",
        scenes.len(),
        serde_json::to_value(args.variant)?.as_str().unwrap_or("?"),
        args.min_speed_mps,
        args.top_n
    )?;
    writeln!(
        out,
        "{:<15} {:<9} {:>8} {:>7} {:>7} {:>9} {:>11} {:>10}",
        "history", "scenes", "samples", "NLL", "top-1", "in top n", "accel m/s²", "yaw rad/s"
    )?;
    for (a, history) in ["at boundary", "one step late"].iter().enumerate() {
        row(out, history, "all", &total(&|_| true, a))?;
        row(out, history, "held out", &total(&|s| held_out.contains(s.id.as_str()), a))?;
        row(out, history, "rest", &total(&|s| !held_out.contains(s.id.as_str()), a))?;
    }
    writeln!(
        out,
        "history at boundary: ending at the token boundary, as in closed loop; one step late: ending 0.1 s into \
         the token to be predicted (a prior that fits far better so reads the token's start from its input)"
    )?;
    writeln!(out, "held out: every tenth scene by id ({} of {})", held_out.len(), scenes.len())?;
    writeln!(out, "NLL in nats (uniform over the 3 969 tokens: 8.29); accel / yaw: mean range of the top n")?;
    Ok(ExitCode::SUCCESS)
}
