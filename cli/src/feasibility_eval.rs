//! `safer feasibility-eval`: how well the shipped V_h tells feasible from
//! infeasible ego–CBV states. States are sampled from the episodes of the
//! feasibility collection (`--states-from collection`, the default) or from
//! stage-1 rollouts of an adversary method (`--states-from safer`: the ego
//! replaying its log, the method driving the CBV, the states the
//! constraint actually judges), on the held-out scenes (never trained on;
//! [`safer_scenarios::datasets::held_out`]), the training ones or all. Each
//! is labelled by the witness search and compared with sign(V_h)
//! ([`safer_scenarios::eval::feasibility_accuracy`]); prints the confusion
//! table with precision and recall of "infeasible", the same broken down
//! by box-distance band, by the kind of conflict around the state and by
//! relative heading, the V_h batch-20 latency in tract and the witness
//! time, the threshold that a calibration would pick (best precision at
//! recall ≥ 0.9) and mean V_h; on request it draws V_h over relative CBV
//! positions (the paper's LFR figure) as an SVG (`--svg`) and writes the
//! figures as JSON (`--json`).

use super::*;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use clap::builder::PossibleValuesParser;
use rayon::prelude::*;

use super::CliError;
use super::feasibility_dataset::FeasibilityDatasetRequest;
use safer_scenarios::datasets::feasibility_transitions::{Collection, CollectionScene};
use safer_scenarios::datasets::held_out::Split;
use safer_scenarios::datasets::{TrainingPurpose, load_scenes_for};
use safer_scenarios::eval::conflict_kind::ConflictKind;
use safer_scenarios::eval::feasibility_accuracy::{
    ConfusionTable, DistanceBand, LabelledState, LfrGrid, LfrPanel, RelativeHeading, SampledState, StateClass,
    WITNESS_HORIZON_STEPS, best_threshold_at_recall, label_state, lfr_panels, sample_states, tables_by,
};
use safer_scenarios::harness::evaluation::{EvaluationRequest, stage1_setup};
use safer_scenarios::harness::methods::{MapEncodings, ModelSet};
use safer_scenarios::harness::pipeline::{VariantSetup, run_stage1};
use safer_scenarios::models::feasibility::{FEASIBILITY_FEATURES, FeasibilityValue, feasibility_features};
use safer_scenarios::models::feasibility_oracle::EgoCbvState;
use safer_scenarios::models::shard::{ShardColumn, write_shard};
use safer_scenarios::record::svg::render_lfr_svg;
use safer_scenarios::sim::Rollout;
use safer_scenarios::spec::suite::Stage2Cbv;

/// The recall of "infeasible" a calibrated V_h is asked to keep.
const TARGET_RECALL: f64 = 0.9;
/// Trust-region size of the stage-1 rollouts (`safer evaluate`'s default).
const STAGE1_TRUST_REGION: usize = 20;
/// Horizon of the stage-1 rollouts, s (`safer evaluate`'s default).
const STAGE1_HORIZON_S: f64 = 8.0;

/// Which scenes' states are labelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum StateSplit {
    /// The held-out scenes of the collection (never trained on).
    HeldOut,
    /// The training scenes (to calibrate a threshold on).
    Train,
    /// Every scene: for a set V_h was never trained on (WOMD).
    All,
}

impl StateSplit {
    /// Every choice, for the command line.
    pub(crate) const ALL: &'static [Self] = &[Self::HeldOut, Self::Train, Self::All];

    fn admits(self, split: Split) -> bool {
        match self {
            Self::HeldOut => split == Split::HeldOut,
            Self::Train => split == Split::Train,
            Self::All => true,
        }
    }

    fn name(self) -> String {
        safer_scenarios::spec::spec_name(&self)
    }
}

/// Where the labelled states come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum StateSource {
    /// The feasibility collection's episodes (several ego planners × CBV policies).
    Collection,
    /// Stage 1 of an adversary method: the ego replaying its log, the method driving the CBV.
    Stage1(AdversaryMethod),
}

impl StateSource {
    fn name(self) -> String {
        match self {
            Self::Collection => "collection".to_string(),
            Self::Stage1(m) => safer_scenarios::spec::spec_name(&m),
        }
    }
}

/// Parses `--states-from`: `collection` or an adversary method's name.
fn state_source() -> impl clap::builder::TypedValueParser<Value = StateSource> {
    let methods: Vec<String> = AdversaryMethod::ALL.iter().map(safer_scenarios::spec::spec_name).collect();
    let names: Vec<String> = std::iter::once("collection".to_string()).chain(methods).collect();
    PossibleValuesParser::new(names).map(|name| {
        AdversaryMethod::ALL
            .iter()
            .find(|m| safer_scenarios::spec::spec_name(*m) == name)
            .map_or(StateSource::Collection, |&m| StateSource::Stage1(m))
    })
}

/// A confusion table with its rates, as the JSON report writes it.
#[derive(serde::Serialize)]
struct TableReport {
    threshold: f32,
    true_infeasible: usize,
    false_infeasible: usize,
    missed_infeasible: usize,
    true_feasible: usize,
    unscored: usize,
    precision: Option<f64>,
    recall: Option<f64>,
    accuracy: Option<f64>,
    /// Share of the states V_h calls infeasible that the witness escapes.
    escaped_share: Option<f64>,
}

impl TableReport {
    fn of(threshold: f32, t: &ConfusionTable) -> Self {
        TableReport {
            threshold,
            true_infeasible: t.true_infeasible,
            false_infeasible: t.false_infeasible,
            missed_infeasible: t.missed_infeasible,
            true_feasible: t.true_feasible,
            unscored: t.unscored,
            precision: t.precision(),
            recall: t.recall(),
            accuracy: t.accuracy(),
            escaped_share: t.escaped_share(),
        }
    }
}

/// One box-distance band's table in the JSON report.
#[derive(serde::Serialize)]
struct BandReport {
    band: &'static str,
    /// Lower bound, m (inclusive; `None`: unbounded).
    from_m: Option<f64>,
    /// Upper bound, m (exclusive; `None`: unbounded).
    to_m: Option<f64>,
    #[serde(flatten)]
    table: TableReport,
}

/// One class's table in the JSON report (a conflict kind or a relative heading).
#[derive(serde::Serialize)]
struct ClassReport {
    class: &'static str,
    #[serde(flatten)]
    table: TableReport,
}

/// The `--json` report.
#[derive(serde::Serialize)]
struct Report {
    split: StateSplit,
    /// `collection` or the adversary method whose stage-1 rollouts the states come from.
    states_from: String,
    /// Scenes whose states were sampled.
    scenes: usize,
    /// Rollouts the states were sampled from (episodes, or stage-1 variants).
    rollouts: usize,
    /// Rollouts that could not be run (set up or driven).
    failed_rollouts: usize,
    /// The rollouts, under the name earlier reports gave them.
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
    /// sign(V_h) per box-distance band at the state, nearest first (every band).
    by_distance: Vec<BandReport>,
    /// sign(V_h) per kind of conflict the pair makes around the state
    /// (`none`: their boxes stay more than 1 m apart), the kinds that occur.
    by_conflict_kind: Vec<ClassReport>,
    /// sign(V_h) per relative heading at the state (every class).
    by_heading: Vec<ClassReport>,
    witness_median_ms: Option<f64>,
    witness_p95_ms: Option<f64>,
}

/// A sampled state with where it sits.
struct Sample {
    state: SampledState,
    class: StateClass,
}

/// The states of one rollout with their classes.
fn samples_of(rollout: &Rollout, scene: &CollectionScene) -> Vec<Sample> {
    sample_states(rollout, scene.ego, scene.cbv)
        .into_iter()
        .map(|state| {
            let class = StateClass::of(&scene.scene.map, rollout, scene.ego, scene.cbv, &state);
            Sample { state, class }
        })
        .collect()
}

/// What the sampling ran over.
struct Sampled {
    samples: Vec<Sample>,
    rollouts: usize,
    failed: usize,
}

/// Samples the states of the collection's episodes on `scenes`.
fn from_collection(collection: &Collection, scenes: &[usize], seed: u64, models: &ModelSet) -> Sampled {
    let maps = MapEncodings::default();
    let episodes: Vec<_> = collection.episodes.iter().filter(|e| scenes.contains(&e.scene)).copied().collect();
    let per_episode: Vec<Option<Vec<Sample>>> = episodes
        .par_iter()
        .map(|&e| collection.run(e, seed, models, &maps).map(|r| samples_of(&r, &collection.scenes[e.scene])))
        .collect();
    collect_rollouts(per_episode)
}

/// Samples the states of `method`'s stage-1 rollouts on `scenes`, `seeds`
/// variants each: the variants `safer evaluate --seed SEED` makes of the
/// same scenes (ego replaying its log, background on log replay, 8 s,
/// trust region 20, seeded approach phase). Scenes whose recorded ego
/// touches another agent are left out, as `safer evaluate` leaves them out.
fn from_stage1(
    collection: &Collection,
    scenes: &[usize],
    method: AdversaryMethod,
    seeds: u32,
    seed: u64,
    models: &ModelSet,
) -> Sampled {
    let maps = MapEncodings::default();
    let request = EvaluationRequest {
        methods: vec![method],
        seeds,
        base_seed: seed,
        planner: safer_scenarios::spec::planner::PlannerAdapter::builtin(BuiltinPlanner::LogReplay),
        trust_region: STAGE1_TRUST_REGION,
        approach: Default::default(),
        feasibility: Default::default(),
        ego_contact: Default::default(),
        wrong_way: Default::default(),
        turning: Default::default(),
        turning_cost: Default::default(),
        background: Default::default(),
        stage2_cbv: vec![Stage2Cbv::Replay],
        escape: None,
        horizon_s: STAGE1_HORIZON_S,
        artefacts: None,
        artefacts_of: Default::default(),
        mutants: Vec::new(),
    };
    let jobs: Vec<(usize, u32)> = scenes
        .iter()
        .filter(|&&i| {
            let scene = &collection.scenes[i].scene;
            let touching = safer_scenarios::scenario::roles::recorded_ego_contact(scene).is_some();
            if touching {
                eprintln!("warning: skipping {}: the recorded ego touches another agent", scene.id);
            }
            !touching
        })
        .flat_map(|&i| (0..seeds).map(move |k| (i, k)))
        .collect();
    let per_variant: Vec<Result<Vec<Sample>, String>> = jobs
        .par_iter()
        .map(|&(i, k)| {
            let scene = &collection.scenes[i];
            let (sim, variant_seed) = stage1_setup(&scene.scene, method, k, &request);
            let setup = VariantSetup {
                scenario: &scene.scene,
                settings: request.method_settings(method),
                seed: variant_seed,
                sim: &sim,
                stage2_cbv: Stage2Cbv::Replay,
                planner: &request.planner,
                models,
                maps: &maps,
                variant: None,
                escape: None,
                ego_limits: None,
                fault: None,
            };
            run_stage1(&setup).map(|r| samples_of(&r, scene)).map_err(|e| e.to_string())
        })
        .collect();
    // One warning per scene, however many of its variants failed.
    let mut failed: BTreeMap<usize, (usize, &str)> = BTreeMap::new();
    for (&(i, _), r) in jobs.iter().zip(&per_variant) {
        if let Err(e) = r {
            failed.entry(i).or_insert((0, e)).0 += 1;
        }
    }
    for (i, (n, e)) in failed {
        eprintln!("warning: {}: stage 1 failed in {n} of {seeds} variants: {e}", collection.scenes[i].scene.id);
    }
    let per_variant: Vec<Option<Vec<Sample>>> = per_variant.into_iter().map(Result::ok).collect();
    collect_rollouts(per_variant)
}

fn collect_rollouts(per_rollout: Vec<Option<Vec<Sample>>>) -> Sampled {
    let rollouts = per_rollout.len();
    let failed = per_rollout.iter().filter(|r| r.is_none()).count();
    Sampled { samples: per_rollout.into_iter().flatten().flatten().collect(), rollouts, failed }
}

/// What `safer feasibility-eval` is asked.
pub(crate) struct EvalRequest<'a> {
    /// The collection's scenes.
    pub(crate) collection: FeasibilityDatasetRequest,
    /// Where the states come from.
    pub(crate) states_from: StateSource,
    /// Stage-1 variants per scene (`--states-from METHOD`).
    pub(crate) seeds: u32,
    /// Most scenes of the split to sample (`None`: all).
    pub(crate) max_scenes: Option<usize>,
    /// Most states to label.
    pub(crate) max_states: usize,
    /// Which scenes.
    pub(crate) split: StateSplit,
    /// Where to draw the LFR figure.
    pub(crate) svg: Option<&'a Path>,
    /// Where to write the JSON report.
    pub(crate) json: Option<&'a Path>,
    /// Where to write the labelled states.
    pub(crate) labels: Option<&'a Path>,
}

/// Runs the command.
pub(crate) fn run(request: &EvalRequest<'_>) -> Result<ExitCode, CliError> {
    let EvalRequest { split, max_states, svg, json, labels, .. } = *request;
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
    let c = &request.collection;
    // Measuring needs no training licence, so any recorded set can be
    // measured; labels written for calibration feed a shipped model, so
    // their scenes must allow training it.
    let purpose = if labels.is_some() { TrainingPurpose::Shipped } else { TrainingPurpose::EvaluationOnly };
    let recorded = load_scenes_for(&scene_paths(&c.recorded)?, purpose)?;
    let collection = Collection::new(recorded, c.synthetic_scenes, c.seed, models.prior.is_ok());
    let scenes: Vec<usize> = (0..collection.scenes.len())
        .filter(|&i| split.admits(collection.scenes[i].split))
        .take(request.max_scenes.unwrap_or(usize::MAX))
        .collect();
    let split_name = split.name();
    let source = request.states_from;
    let sampled = match source {
        StateSource::Collection => {
            eprintln!("{} {split_name} scenes: the collection's episodes", scenes.len());
            from_collection(&collection, &scenes, c.seed, &models)
        }
        StateSource::Stage1(method) => {
            eprintln!("{} {split_name} scenes: {} × {} stage-1 variants", scenes.len(), source.name(), request.seeds);
            from_stage1(&collection, &scenes, method, request.seeds, c.seed, &models)
        }
    };
    let samples: Vec<Sample> = sampled.samples.into_iter().take(max_states).collect();
    let labelled: Vec<LabelledState> = samples.par_iter().map(|s| label_state(&value, &s.state)).collect();
    let table = ConfusionTable::of(&labelled);
    if let Some(path) = labels {
        write_labels(path, split, source, &samples, &labelled)?;
    }
    let show = |r: Option<f64>| r.map_or("n/a".to_string(), |r| format!("{r:.3}"));
    let what = match source {
        StateSource::Collection => "episodes".to_string(),
        StateSource::Stage1(_) => format!("{} stage-1 variants", source.name()),
    };
    writeln!(
        out,
        "{split_name} states: {} (from {} {what} on {} scenes)",
        labelled.len(),
        sampled.rollouts - sampled.failed,
        scenes.len()
    )?;
    if sampled.failed > 0 {
        writeln!(out, "  {} of {} rollouts could not be run (no states from them)", sampled.failed, sampled.rollouts)?;
    }
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
    let by_band = tables_by(samples.iter().zip(&labelled).map(|(s, l)| (s.class.band, *l)));
    let by_kind = tables_by(samples.iter().zip(&labelled).map(|(s, l)| (s.class.conflict, *l)));
    let by_heading = tables_by(samples.iter().zip(&labelled).map(|(s, l)| (s.class.heading, *l)));
    let band_rows: Vec<(&str, ConfusionTable)> =
        DistanceBand::ALL.iter().map(|b| (b.label(), by_band.get(b).copied().unwrap_or_default())).collect();
    let kind_rows: Vec<(&str, ConfusionTable)> = kind_rows(&by_kind);
    let heading_rows: Vec<(&str, ConfusionTable)> =
        RelativeHeading::ALL.iter().map(|h| (h.name(), by_heading.get(h).copied().unwrap_or_default())).collect();
    writeln!(
        out,
        "\nby box distance at the state (escaped: share of V_h's \"infeasible\" calls the witness escapes):"
    )?;
    print_rows(&mut out, "band", &band_rows)?;
    writeln!(
        out,
        "\nby conflict kind (the pair's closest approach from 3 s before to 4 s after the state; none: never within 1 m):"
    )?;
    print_rows(&mut out, "kind", &kind_rows)?;
    writeln!(out, "\nby relative heading (same direction < 45°, crossing 45–135°, opposite ≥ 135°):")?;
    print_rows(&mut out, "heading", &heading_rows)?;
    let mut ws: Vec<f64> = labelled.iter().map(|l| l.witness_s * 1e3).collect();
    ws.sort_by(f64::total_cmp);
    let (witness_median_ms, witness_p95_ms) =
        if ws.is_empty() { (None, None) } else { (Some(ws[ws.len() / 2]), Some(ws[ws.len() * 95 / 100])) };
    if !ws.is_empty() {
        writeln!(
            out,
            "\nwitness search: median {:.2} ms, p95 {:.2} ms per state ({} s horizon)",
            ws[ws.len() / 2],
            ws[ws.len() * 95 / 100],
            WITNESS_HORIZON_STEPS as f64 / 10.0
        )?;
    }
    let batch: Vec<EgoCbvState> = samples.iter().take(20).map(|s| s.state.pair).collect();
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
        let bound = |x: f64| x.is_finite().then_some(x);
        let class_rows = |rows: &[(&'static str, ConfusionTable)]| -> Vec<ClassReport> {
            rows.iter().map(|(class, t)| ClassReport { class, table: TableReport::of(0.0, t) }).collect()
        };
        let report = Report {
            split,
            states_from: source.name(),
            scenes: scenes.len(),
            rollouts: sampled.rollouts,
            failed_rollouts: sampled.failed,
            episodes: sampled.rollouts,
            states: labelled.len(),
            unscored: table.unscored,
            precision: table.precision(),
            recall: table.recall(),
            accuracy: table.accuracy(),
            mean_vh,
            at_zero: TableReport::of(0.0, &table),
            calibrated: calibrated.as_ref().map(|(t, c)| TableReport::of(*t, c)),
            by_distance: DistanceBand::ALL
                .iter()
                .zip(&band_rows)
                .map(|(b, (label, t))| BandReport {
                    band: label,
                    from_m: bound(b.range_m().0),
                    to_m: bound(b.range_m().1),
                    table: TableReport::of(0.0, t),
                })
                .collect(),
            by_conflict_kind: class_rows(&kind_rows),
            by_heading: class_rows(&heading_rows),
            witness_median_ms,
            witness_p95_ms,
        };
        let text = serde_json::to_string_pretty(&report).map_err(|e| CliError::Usage(e.to_string()))?;
        safer_scenarios::record::write_output(path, format!("{text}\n").as_bytes())?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The conflict kinds that occur, in table order, then `none`.
fn kind_rows(by_kind: &BTreeMap<Option<ConflictKind>, ConfusionTable>) -> Vec<(&'static str, ConfusionTable)> {
    let kinds = ConflictKind::ALL.iter().filter_map(|k| by_kind.get(&Some(*k)).map(|t| (k.name(), *t)));
    kinds.chain(by_kind.get(&None).map(|t| ("none", *t))).collect()
}

/// Prints a breakdown: one row per class with its cells and rates.
fn print_rows(out: &mut dyn Write, what: &str, rows: &[(&str, ConfusionTable)]) -> std::io::Result<()> {
    let show = |r: Option<f64>| r.map_or("n/a".to_string(), |r| format!("{r:.3}"));
    writeln!(
        out,
        "  {what:<22} {:>6} {:>6} {:>6} {:>7}  {:>9}  {:>6}  {:>7}",
        "TP", "FP", "FN", "TN", "precision", "recall", "escaped"
    )?;
    for (name, t) in rows {
        writeln!(
            out,
            "  {name:<22} {:>6} {:>6} {:>6} {:>7}  {:>9}  {:>6}  {:>7}",
            t.true_infeasible,
            t.false_infeasible,
            t.missed_infeasible,
            t.true_feasible,
            show(t.precision()),
            show(t.recall()),
            show(t.escaped_share())
        )?;
    }
    Ok(())
}

/// Writes the labelled states as a safetensors file: `state` [N, 13] (the
/// V_h features), `witness_found` [N] (1 = the witness search found an
/// escape), `value` [N] (the shipped V_h), and the split and the states'
/// source in the metadata.
fn write_labels(
    path: &Path,
    split: StateSplit,
    source: StateSource,
    samples: &[Sample],
    labelled: &[LabelledState],
) -> Result<(), CliError> {
    let n = labelled.len();
    let state: Vec<f32> = samples.iter().take(n).flat_map(|s| feasibility_features(&s.state.pair)).collect();
    let found: Vec<f32> = labelled.iter().map(|l| if l.witness_found { 1.0 } else { 0.0 }).collect();
    let value: Vec<f32> = labelled.iter().map(|l| l.value).collect();
    let columns = [
        ShardColumn::f32("state", vec![n, FEASIBILITY_FEATURES], &state),
        ShardColumn::f32("witness_found", vec![n], &found),
        ShardColumn::f32("value", vec![n], &value),
    ];
    let split = serde_json::to_string(&split).map_err(|e| CliError::Usage(e.to_string()))?;
    safer_scenarios::record::create_parent_folder(path)?;
    let metadata = std::collections::HashMap::from([
        ("split".to_string(), split),
        ("states_from".to_string(), format!("\"{}\"", source.name())),
    ]);
    write_shard(path, &columns, metadata)?;
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
    /// Recorded scenes of the collection (NGSIM by default; any recorded set, e.g. `data:womd-interactive`, can be measured); `data:REL` is in $SAFER_DATA_DIR.
    #[arg(long, visible_alias = "scenes", default_value = "data:commonroad-ngsim", value_parser = data_path)]
    pub(crate) recorded: PathBuf,
    /// Synthetic scenes of the collection (same as for `feasibility-dataset`; 0 to measure the recorded set alone).
    #[arg(long, default_value_t = 300)]
    pub(crate) synthetic_scenes: usize,
    /// Base seed of the collection and of the stage-1 variants (`safer evaluate --seed`).
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    /// Where the states come from: `collection`, the collection's episodes (several ego planners against several CBV policies); or an adversary method (`safer`, `safer-distinct`, …, `log`): its stage-1 rollouts, the ego replaying its log and the method driving the CBV, as `safer evaluate` runs them; the witness then escapes the CBV's stage-1 future.
    #[arg(long, value_name = "SOURCE", default_value = "collection", value_parser = state_source())]
    pub(crate) states_from: StateSource,
    /// Stage-1 variants per scene with `--states-from METHOD`, at least 1.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) seeds: u32,
    /// Sample only the first N scenes of the split (in collection order: recorded by id, then synthetic), at least 1.
    #[arg(long, value_name = "N", value_parser = at_least_one())]
    pub(crate) max_scenes: Option<usize>,
    /// Most states to label, at least 1.
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
    /// on; the reported figures), the training ones (to calibrate a
    /// decision threshold on without touching the held-out set), or all
    /// (for a recorded set V_h was never trained on, such as WOMD).
    #[arg(long, value_parser = choice(StateSplit::ALL), default_value = "held-out")]
    pub(crate) split: StateSplit,
    /// Write every labelled state (its V_h features, witness label and
    /// V_h) as a safetensors file, for `training/feasibility/train.py
    /// --calibration` (label the training split for that, never the
    /// held-out one); the scenes' licence must allow training the shipped
    /// models.
    #[arg(long, value_name = "OUT")]
    pub(crate) labels: Option<PathBuf>,
}

/// Runs `safer feasibility-eval`.
pub(crate) fn command(args: FeasibilityEvalArgs) -> Result<ExitCode, CliError> {
    let FeasibilityEvalArgs {
        recorded,
        synthetic_scenes,
        seed,
        states_from,
        seeds,
        max_scenes,
        states,
        svg,
        json,
        split,
        labels,
    } = args;
    run(&EvalRequest {
        collection: FeasibilityDatasetRequest { recorded, out: PathBuf::new(), synthetic_scenes, seed, force: false },
        states_from,
        seeds,
        max_scenes,
        max_states: states,
        split,
        svg: svg.as_deref(),
        json: json.as_deref(),
        labels: labels.as_deref(),
    })
}
