//! `safer feasibility-eval`: how well the shipped V_h tells feasible from
//! infeasible ego–CBV states, on the held-out scenes of the feasibility
//! collection (never trained on; [`safer_scenarios::datasets::held_out`]). States
//! sampled from their episodes are labelled by the witness search and
//! compared with sign(V_h) ([`safer_scenarios::eval::feasibility_accuracy`]); prints
//! the confusion table with precision and recall of "infeasible", the V_h
//! batch-20 latency in tract and the witness time, the threshold that a
//! calibration would pick (best precision at recall ≥ 0.9) and mean V_h;
//! on request it draws V_h over relative CBV positions (the paper's LFR
//! figure) as an SVG (`--svg`) and writes the figures as JSON (`--json`).

use super::*;
use std::io::Write;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use rayon::prelude::*;

use super::CliError;
use super::feasibility_dataset::{FeasibilityDatasetRequest, collection};
use safer_scenarios::datasets::held_out::Split;
use safer_scenarios::eval::feasibility_accuracy::{
    ConfusionTable, LabelledState, LfrGrid, LfrPanel, SampledState, WITNESS_HORIZON_STEPS, best_threshold_at_recall,
    label_state, lfr_panels, sample_states,
};
use safer_scenarios::harness::methods::{MapEncodings, ModelSet};
use safer_scenarios::models::feasibility::{FEASIBILITY_FEATURES, FeasibilityValue, feasibility_features};
use safer_scenarios::models::feasibility_oracle::EgoCbvState;
use safer_scenarios::models::shard::{ShardColumn, write_shard};
use safer_scenarios::record::svg::render_lfr_svg;

/// The recall of "infeasible" the issue asks a calibrated V_h to keep.
const TARGET_RECALL: f64 = 0.9;

/// A confusion table with its rates, as the JSON report writes it.
#[derive(serde::Serialize)]
struct TableReport {
    threshold: f32,
    true_infeasible: usize,
    false_infeasible: usize,
    missed_infeasible: usize,
    true_feasible: usize,
    precision: Option<f64>,
    recall: Option<f64>,
    accuracy: Option<f64>,
}

impl TableReport {
    fn of(threshold: f32, t: &ConfusionTable) -> Self {
        TableReport {
            threshold,
            true_infeasible: t.true_infeasible,
            false_infeasible: t.false_infeasible,
            missed_infeasible: t.missed_infeasible,
            true_feasible: t.true_feasible,
            precision: t.precision(),
            recall: t.recall(),
            accuracy: t.accuracy(),
        }
    }
}

/// The `--json` report.
#[derive(serde::Serialize)]
struct Report {
    split: Split,
    episodes: usize,
    states: usize,
    unscored: usize,
    precision: Option<f64>,
    recall: Option<f64>,
    accuracy: Option<f64>,
    mean_vh: Option<f64>,
    /// sign(V_h): V_h > 0 predicts infeasible, as the adversary reads it.
    at_zero: TableReport,
    /// The best precision among thresholds with recall ≥ 0.9 (`None`: no infeasible state).
    calibrated: Option<TableReport>,
    witness_median_ms: Option<f64>,
    witness_p95_ms: Option<f64>,
}

/// Runs the command.
pub fn run(
    request: &FeasibilityDatasetRequest,
    max_states: usize,
    split: Split,
    svg: Option<&Path>,
    json: Option<&Path>,
    labels: Option<&Path>,
) -> Result<ExitCode, CliError> {
    if let Some(path) = json {
        super::check_json_report(path)?;
    }
    if let Some(path) = labels {
        safer_scenarios::record::output::check_output(path)?;
    }
    // The table goes to stderr when the JSON report takes stdout.
    let mut out: Box<dyn Write> = if json.is_some_and(safer_scenarios::record::is_stdout) {
        Box::new(std::io::stderr())
    } else {
        Box::new(std::io::stdout())
    };
    let value = FeasibilityValue::load(&safer_scenarios::models::ModelSource::shipped())?;
    let models = ModelSet::shipped();
    let maps = MapEncodings::default();
    let collection = collection(request, &models)?;
    let episodes = collection.episodes_of(split);
    let split_name = if split == Split::HeldOut { "held-out" } else { "training" };
    eprintln!("{} {split_name} episodes", episodes.len());
    let samples: Vec<SampledState> = episodes
        .par_iter()
        .flat_map_iter(|&e| {
            let scene = &collection.scenes[e.scene];
            let rollout = collection.run(e, request.seed, &models, &maps);
            rollout.map(|r| sample_states(&r, scene.ego, scene.cbv)).unwrap_or_default()
        })
        .collect();
    let samples: Vec<SampledState> = samples.into_iter().take(max_states).collect();
    let labelled: Vec<LabelledState> = samples.par_iter().map(|s| label_state(&value, s)).collect();
    let table = ConfusionTable::of(&labelled);
    if let Some(path) = labels {
        write_labels(path, split, &samples, &labelled)?;
    }
    let show = |r: Option<f64>| r.map_or("n/a".to_string(), |r| format!("{r:.3}"));
    writeln!(out, "{split_name} states: {} (from {} episodes)", labelled.len(), episodes.len())?;
    writeln!(out, "witness label: infeasible {}, feasible {}", table.infeasible(), table.feasible())?;
    writeln!(out, "sign(V_h) vs witness:      predicted infeasible  predicted feasible")?;
    writeln!(out, "  infeasible (no witness)  {:>20}  {:>18}", table.true_infeasible, table.missed_infeasible)?;
    writeln!(out, "  feasible (witness)       {:>20}  {:>18}", table.false_infeasible, table.true_feasible)?;
    let mean_vh = {
        let v: Vec<f64> = labelled.iter().filter(|l| !l.value.is_nan()).map(|l| l.value as f64).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    writeln!(out, "mean V_h over the {split_name} states: {}", show(mean_vh))?;
    let calibrated = best_threshold_at_recall(&labelled, TARGET_RECALL);
    match &calibrated {
        Some((t, c)) => writeln!(
            out,
            "calibrated: V_h > {t:.3} predicts infeasible → precision {}, recall {} (best precision at recall ≥ {TARGET_RECALL})",
            show(c.precision()),
            show(c.recall())
        )?,
        None => writeln!(out, "calibrated: no infeasible state to calibrate on")?,
    }
    if table.unscored > 0 {
        writeln!(out, "  V_h failed on {} state(s) (counted in no cell)", table.unscored)?;
    }
    writeln!(
        out,
        "precision of infeasible {}, recall {}, accuracy {}",
        show(table.precision()),
        show(table.recall()),
        show(table.accuracy())
    )?;
    let mut ws: Vec<f64> = labelled.iter().map(|l| l.witness_s * 1e3).collect();
    ws.sort_by(f64::total_cmp);
    let (witness_median_ms, witness_p95_ms) =
        if ws.is_empty() { (None, None) } else { (Some(ws[ws.len() / 2]), Some(ws[ws.len() * 95 / 100])) };
    if !ws.is_empty() {
        writeln!(
            out,
            "witness search: median {:.2} ms, p95 {:.2} ms per state ({} s horizon)",
            ws[ws.len() / 2],
            ws[ws.len() * 95 / 100],
            WITNESS_HORIZON_STEPS as f64 / 10.0
        )?;
    }
    let batch: Vec<EgoCbvState> = samples.iter().take(20).map(|s| s.pair).collect();
    if batch.len() == 20 {
        let mut times = Vec::with_capacity(1000);
        for _ in 0..1000 {
            let t = Instant::now();
            value.evaluate(&batch)?;
            times.push(t.elapsed().as_secs_f64() * 1e6);
        }
        times.sort_by(f64::total_cmp);
        writeln!(
            out,
            "V_h batch-20 query in tract: median {:.1} µs ({} build)",
            times[500],
            if cfg!(debug_assertions) { "debug" } else { "release" }
        )?;
    }
    let panels = lfr_panels(&value, LfrGrid::FIGURE)?;
    for p in &panels {
        print_panel(&mut out, p)?;
    }
    if let Some(svg) = svg {
        safer_scenarios::record::create_parent_folder(svg)?;
        safer_scenarios::record::write_output(svg, render_lfr_svg(&panels).as_bytes())?;
        if !safer_scenarios::record::is_stdout(svg) {
            writeln!(out, "wrote {}", svg.display())?;
        }
    }
    if let Some(path) = json {
        let report = Report {
            split,
            episodes: episodes.len(),
            states: labelled.len(),
            unscored: table.unscored,
            precision: table.precision(),
            recall: table.recall(),
            accuracy: table.accuracy(),
            mean_vh,
            at_zero: TableReport::of(0.0, &table),
            calibrated: calibrated.as_ref().map(|(t, c)| TableReport::of(*t, c)),
            witness_median_ms,
            witness_p95_ms,
        };
        let text = serde_json::to_string_pretty(&report).map_err(|e| CliError::Usage(e.to_string()))?;
        safer_scenarios::record::write_output(path, format!("{text}\n").as_bytes())?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Writes the labelled states as a safetensors file: `state` [N, 13] (the
/// V_h features), `witness_found` [N] (1 = the witness search found an
/// escape), `value` [N] (the shipped V_h), and the split in the metadata.
fn write_labels(
    path: &Path,
    split: Split,
    samples: &[SampledState],
    labelled: &[LabelledState],
) -> Result<(), CliError> {
    let n = labelled.len();
    let state: Vec<f32> = samples.iter().take(n).flat_map(|s| feasibility_features(&s.pair)).collect();
    let found: Vec<f32> = labelled.iter().map(|l| if l.witness_found { 1.0 } else { 0.0 }).collect();
    let value: Vec<f32> = labelled.iter().map(|l| l.value).collect();
    let columns = [
        ShardColumn::f32("state", vec![n, FEASIBILITY_FEATURES], &state),
        ShardColumn::f32("witness_found", vec![n], &found),
        ShardColumn::f32("value", vec![n], &value),
    ];
    let split = serde_json::to_string(&split).map_err(|e| CliError::Usage(e.to_string()))?;
    safer_scenarios::record::create_parent_folder(path)?;
    write_shard(path, &columns, std::collections::HashMap::from([("split".to_string(), split)]))?;
    eprintln!("wrote {} labelled states to {}", n, path.display());
    Ok(())
}

fn print_panel(out: &mut dyn Write, p: &LfrPanel) -> std::io::Result<()> {
    let g = p.grid;
    writeln!(
        out,
        "LFR panel: {:>4} m/s, CBV {:<24} infeasible cells {:>5.1} % of {} (x {}..{} m, y {}..{} m)",
        p.speed_mps,
        p.label,
        100.0 * p.infeasible_share().unwrap_or(f64::NAN),
        p.values.len(),
        g.x_range_m.0,
        g.x_range_m.1,
        g.y_range_m.0,
        g.y_range_m.1
    )
}

/// The arguments of `safer feasibility-eval`.
#[derive(Debug, clap::Args)]
pub(crate) struct FeasibilityEvalArgs {
    /// Recorded scenes of the collection (NGSIM); `data:REL` is in $SAFER_DATA_DIR.
    #[arg(long, default_value = "data:commonroad-ngsim", value_parser = data_path)]
    pub(crate) recorded: PathBuf,
    /// Synthetic scenes of the collection (same as for `feasibility-dataset`).
    #[arg(long, default_value_t = 300)]
    pub(crate) synthetic_scenes: usize,
    /// Base seed of the collection.
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    /// Most held-out states to label, at least 1.
    #[arg(long, default_value_t = 3000, value_parser = at_least_one())]
    pub(crate) states: usize,
    /// Where to draw V_h over relative CBV positions (the README's
    /// picture is `docs/feasibility-lfr.svg`); none unless asked.
    #[arg(long)]
    pub(crate) svg: Option<PathBuf>,
    /// Write the figures as JSON (`-`: standard output, the table then on stderr).
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub(crate) json: Option<PathBuf>,
    /// Which scenes' states to label: the held-out ones (never trained
    /// on; the reported figures) or the training ones (to calibrate a
    /// decision threshold on without touching the held-out set).
    #[arg(long, value_parser = choice(safer_scenarios::datasets::held_out::Split::ALL), default_value = "held-out")]
    pub(crate) split: safer_scenarios::datasets::held_out::Split,
    /// Write every labelled state (its V_h features, witness label and
    /// V_h) as a safetensors file, for `training/feasibility/train.py
    /// --calibration` (label the training split for that, never the
    /// held-out one).
    #[arg(long, value_name = "OUT")]
    pub(crate) labels: Option<PathBuf>,
}

/// Runs `safer feasibility-eval`.
pub(crate) fn command(args: FeasibilityEvalArgs) -> Result<ExitCode, CliError> {
    let FeasibilityEvalArgs { recorded, synthetic_scenes, seed, states, svg, json, split, labels } = args;
    run(
        &super::feasibility_dataset::FeasibilityDatasetRequest {
            recorded,
            out: PathBuf::new(),
            synthetic_scenes,
            seed,
            force: false,
        },
        states,
        split,
        svg.as_deref(),
        json.as_deref(),
        labels.as_deref(),
    )
}
