//! `safer evaluate`: the dual-stage evaluation of adversary methods over a
//! folder of scenes (rows = methods; columns CR, SR, SR on the stage-1
//! critical variants, witness rate, VJ, AJ, time per variant; and CR, SR,
//! witness rate and SR on witnessed collisions over the held-out scenes
//! beside the rest), with a
//! progress bar, rayon across variants, and an optional JSON report with
//! every variant (`--json -`: on standard output, the table then on stderr).
//! Scenes whose recorded ego touches another agent (annotation overlaps)
//! are skipped with a warning: every variant of them would count against
//! the planner whatever it did.

use std::io::Write;
use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use super::{CliError, scene_paths};
use safer::eval::witness::{DEFAULT_WIDEST, RoadKeeping, WitnessBudget, search_rollout_witness};
use safer::harness::evaluation::{self, EvaluationRequest, HeldOutSplit, MethodRow, Stage2Cbv, VariantRecord};
use safer::harness::methods::ModelSet;
use safer::scenario::{Scenario, import};

/// Loads every scene under `path` that has an ego and a CBV.
pub(super) fn load_scenes(path: &Path, max_scenes: Option<usize>) -> Result<Vec<Arc<Scenario>>, CliError> {
    let paths = scene_paths(path)?;
    let loaded: Vec<Result<Vec<Scenario>, _>> = paths.par_iter().map(|p| import::load(p)).collect();
    let mut scenes = Vec::new();
    // Records, seeds and the held-out split go by scenario id: one id in
    // two files would merge two scenes' rows silently.
    let mut files_of: std::collections::HashMap<String, &Path> = std::collections::HashMap::new();
    for (p, r) in paths.iter().zip(loaded) {
        match r {
            Ok(s) => {
                for scene in &s {
                    if let Some(first) = files_of.insert(scene.id.clone(), p).filter(|first| first != p) {
                        return Err(CliError::Usage(format!(
                            "scenario id `{}` is in both {} and {}; an evaluation tells scenes apart by id, so \
                             keep one of the files",
                            scene.id,
                            first.display(),
                            p.display()
                        )));
                    }
                }
                scenes.extend(s.into_iter().filter(|s| s.ego.is_some() && s.cbv.is_some()).map(Arc::new))
            }
            Err(e) => eprintln!("warning: skipping {}: {e}", p.display()),
        }
    }
    scenes.sort_by(|a, b| a.id.cmp(&b.id));
    if let Some(n) = max_scenes {
        scenes.truncate(n);
    }
    Ok(scenes)
}

fn fmt(v: Option<f64>) -> String {
    v.map_or("—".into(), |x| format!("{x:.3}"))
}

/// A row's name: the method, and its stage-2 CBV mode when the table holds
/// more than one.
fn label(method: safer::spec::suite::AdversaryMethod, mode: Stage2Cbv, modes: usize) -> String {
    let method = safer::spec::spec_name(&method);
    if modes > 1 { format!("{method} ({})", safer::spec::spec_name(&mode)) } else { method }
}

/// What the witness search holds an escape to, and how hard it looks.
#[derive(Debug, Clone, Copy)]
pub(super) struct WitnessSettings {
    /// How much of the ego must stay on the road.
    pub road: RoadKeeping,
    /// The widest beam tried, as a multiple of the narrow one.
    pub widest: usize,
}

/// The human-readable table (on stdout, or stderr when the JSON report
/// takes stdout).
fn print_table(
    out: &mut dyn Write,
    rows: &[MethodRow],
    held_out: &HeldOutSplit,
    scenes: usize,
    request: &EvaluationRequest,
    witness: WitnessSettings,
) -> std::io::Result<()> {
    let modes = request.stage2_cbv.len();
    let name = |r: &MethodRow| label(r.method, r.stage2_cbv, modes);
    writeln!(
        out,
        "{scenes} scenes × {} seeds; stage 2 planner `{}`, stage-2 CBV {}, trust region n = {}, horizon {} s{}{}",
        request.seeds,
        request.planner.name(),
        request.stage2_cbv.iter().map(safer::spec::spec_name).collect::<Vec<_>>().join(" and "),
        request.trust_region,
        request.horizon_s,
        match witness.road {
            RoadKeeping::Centre => "",
            RoadKeeping::WholeWidth => "; the witness keeps its whole width on the road",
        },
        if witness.widest == DEFAULT_WIDEST {
            String::new()
        } else {
            format!("; the witness search widens its beam up to ×{}", witness.widest)
        }
    )?;
    writeln!(
        out,
        "{:<28} {:>8} {:>7} {:>7} {:>7} {:>9} {:>9} {:>7} {:>7} {:>11}",
        "method", "variants", "errors", "CR", "SR", "SR-crit", "witness", "VJ", "AJ", "s/variant"
    )?;
    for r in rows {
        writeln!(
            out,
            "{:<28} {:>8} {:>7} {:>7} {:>7} {:>9} {:>9} {:>7} {:>7} {:>11.3}",
            name(r),
            r.variants,
            r.errors,
            fmt(r.cr),
            fmt(r.sr),
            fmt(r.sr_critical),
            fmt(r.witness_rate),
            fmt(r.vj),
            fmt(r.aj),
            r.time_per_variant_s
        )?;
    }
    writeln!(out, "\nplausibility of the CBV, the seeds' variety and the reference planner:")?;
    writeln!(
        out,
        "{:<28} {:>12} {:>14} {:>12} {:>14} {:>9} {:>12}",
        "method", "CBV-bg coll", "CBV at fault", "CBV off-road", "off-road s/var", "distinct", "SR-witnessed"
    )?;
    for r in rows {
        writeln!(
            out,
            "{:<28} {:>12} {:>14} {:>12} {:>14} {:>9} {:>12}",
            name(r),
            fmt(r.cbv_background_collision_rate),
            fmt(r.cbv_at_fault_background_collision_rate),
            fmt(r.cbv_off_road_rate),
            fmt(r.cbv_off_road_s),
            fmt(r.distinct_rate),
            fmt(r.sr_witnessed)
        )?;
    }
    writeln!(
        out,
        "\nheld out (every tenth scene by id: {} of {}) | the other scenes:",
        held_out.scenes.len(),
        held_out.of_scenes
    )?;
    writeln!(
        out,
        "{:<28} {:>7} {:>7} {:>9} {:>12} | {:>7} {:>7} {:>9} {:>12}",
        "method", "CR", "SR", "witness", "SR-witnessed", "CR", "SR", "witness", "SR-witnessed"
    )?;
    for (h, r) in held_out.held_out.iter().zip(&held_out.rest) {
        writeln!(
            out,
            "{:<28} {:>7} {:>7} {:>9} {:>12} | {:>7} {:>7} {:>9} {:>12}",
            name(h),
            fmt(h.cr),
            fmt(h.sr),
            fmt(h.witness_rate),
            fmt(h.sr_witnessed),
            fmt(r.cr),
            fmt(r.sr),
            fmt(r.witness_rate),
            fmt(r.sr_witnessed)
        )?;
    }
    writeln!(out, "\nconflicts at the planner under test (stage 2):")?;
    writeln!(
        out,
        "{:<28} {:>7} {:>10} {:>9} {:>10} {:>10} {:>9} {:>9} | {:>7} {:>10} {:>9}",
        "method",
        "reach",
        "reach-crit",
        "SR-avoid",
        "avoid-fail",
        "no-escape",
        "refuted",
        "failures",
        "reach",
        "reach-crit",
        "SR-avoid"
    )?;
    for (r, h) in rows.iter().zip(&held_out.held_out) {
        writeln!(
            out,
            "{:<28} {:>7} {:>10} {:>9} {:>10} {:>10} {:>9} {:>9} | {:>7} {:>10} {:>9}",
            name(r),
            fmt(r.conflict_reach),
            fmt(r.conflict_reach_critical),
            fmt(r.sr_avoidable),
            r.avoidable_failures,
            r.no_escape_collisions,
            r.precheck_refuted,
            r.failures,
            fmt(h.conflict_reach),
            fmt(h.conflict_reach_critical),
            fmt(h.sr_avoidable),
        )?;
    }
    if let Some(line) = failures_beyond_log(rows) {
        writeln!(out, "{line}")?;
    }
    writeln!(out, "\nwhere the time goes (mean s per variant):")?;
    writeln!(
        out,
        "{:<28} {:>9} {:>10} {:>9} {:>12} {:>9} {:>9} {:>9}",
        "method", "stage 1", "features", "decoder", "feasibility", "stage 2", "witness", "escape"
    )?;
    for r in rows {
        let p = &r.profile;
        writeln!(
            out,
            "{:<28} {:>9.3} {:>10.3} {:>9.3} {:>12.3} {:>9.3} {:>9.3} {:>9.3}",
            name(r),
            p.stage1_s,
            p.stage1_features_s,
            p.stage1_decoder_s,
            p.stage1_feasibility_s,
            p.stage2_s,
            p.witness_s,
            p.escape_s
        )?;
    }
    writeln!(
        out,
        "VJ/AJ: Jensen–Shannon divergence (bits) of the CBV's stage-1 speed (0–40 m/s, 1 m/s bins) and acceleration (−8–8 m/s², 0.5 m/s² bins, finite differences at 0.1 s) against the logged CBV over the same window."
    )?;
    writeln!(
        out,
        "reach: share of variants whose CBV came within 1 m (box distance) of the planner's ego in stage 2 (reach-crit: of the stage-1-critical ones; right of | : the held-out scenes). SR-avoid: SR over the avoidable conflicts (reached or collided, less collisions without an escape); avoid-fail: the planner's failures among them. no-escape: stage-2 collisions whose closed-loop witness found no escape within budget (the generator's fault); refuted: of those, the ones whose pre-check found an escape from the CBV as it drove."
    )?;
    writeln!(
        out,
        "distinct: distinct stage-1 CBV paths (to the centimetre) per variant, over each scene's seeds; 1.000 when no two seeds made the same variant."
    )?;
    Ok(())
}

/// For each method with both stage-2 modes, how many more planner
/// failures closed loop finds beyond plain log replay's than replay does:
/// (closed-loop failures − `log` failures) / (replay failures − `log`
/// failures); `None` without a `log` row and both modes.
fn failures_beyond_log(rows: &[MethodRow]) -> Option<String> {
    use safer::spec::suite::AdversaryMethod;
    let log = rows.iter().find(|r| r.method == AdversaryMethod::Log)?.failures as f64;
    let parts: Vec<String> = rows
        .iter()
        .filter(|r| r.method != AdversaryMethod::Log && r.stage2_cbv == Stage2Cbv::ClosedLoop)
        .filter_map(|closed| {
            let replay = rows.iter().find(|r| r.method == closed.method && r.stage2_cbv == Stage2Cbv::Replay)?;
            let (c, p) = (closed.failures as f64 - log, replay.failures as f64 - log);
            let ratio = if p > 0.0 { format!("{:.2}×", c / p) } else { "—".into() };
            Some(format!("{}: {c} / {p} = {ratio}", safer::spec::spec_name(&closed.method)))
        })
        .collect();
    (!parts.is_empty())
        .then(|| format!("failures beyond log replay's ({log}), closed loop / replay: {}", parts.join("; ")))
}

#[derive(serde::Serialize)]
struct Report<'a> {
    scenes: usize,
    rows: &'a [MethodRow],
    /// The same rows over the held-out scenes and over the rest.
    held_out: &'a HeldOutSplit,
    variants: &'a [VariantRecord],
}

/// Runs the command.
pub(super) fn run(
    scenes_dir: &Path,
    request: &EvaluationRequest,
    max_scenes: Option<usize>,
    json: Option<&Path>,
    witness: WitnessSettings,
) -> Result<ExitCode, CliError> {
    if let Some(path) = json {
        safer::record::output::check_output(path)?;
        // The report must not replace a scene it reads, nor the planner's spec.
        let mut inputs = scene_paths(scenes_dir)?;
        inputs.extend(request.planner.argument_files());
        safer::record::check_outputs_apart(&[safer::record::NamedOutput { flag: "--json", path }], &inputs)?;
    }
    let scenes: Vec<Arc<Scenario>> = load_scenes(scenes_dir, max_scenes)?
        .into_iter()
        .filter(|s| match safer::scenario::roles::recorded_ego_contact(s) {
            Some((other, step)) => {
                eprintln!(
                    "warning: skipping {}: the recorded ego touches agent {} at t = {:.1} s (an annotation overlap: no planner can solve it)",
                    s.id,
                    s.track(other).id.0,
                    step.saturating_sub(s.current_step) as f64 * s.dt_s
                );
                false
            }
            None => true,
        })
        .collect();
    if scenes.is_empty() {
        return Err(CliError::Usage(format!("{}: no scene with both an ego and a CBV", scenes_dir.display())));
    }
    let models = ModelSet::shipped();
    let total = (scenes.len() * request.methods.len() * request.seeds as usize) as u64;
    let bar = ProgressBar::new(total).with_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} variants ({per_sec}, eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let budget = WitnessBudget::widening_up_to(witness.widest);
    let search = move |scenario: &Scenario, stage1: &safer::sim::Rollout| -> bool {
        search_rollout_witness(scenario, stage1, witness.road, budget).is_found()
    };
    let records = evaluation::evaluate(&scenes, request, &models, Some(&search), &|| bar.inc(1));
    bar.finish_and_clear();
    for r in records.iter().filter(|r| r.error.is_some()).take(5) {
        eprintln!("error: {} {:?} seed {}: {}", r.scenario, r.method, r.seed, r.error.as_deref().unwrap_or(""));
    }
    let rows = evaluation::table(&records, &request.methods);
    let held_out = evaluation::held_out_split(&records, &request.methods);
    // The file report first: a reader that closes standard output early
    // (`| head`) must not cost the evaluation its report.
    let report = Report { scenes: scenes.len(), rows: &rows, held_out: &held_out, variants: &records };
    let report_text = || serde_json::to_string_pretty(&report).map(|t| t + "\n");
    if let Some(path) = json.filter(|p| !safer::record::is_stdout(p)) {
        safer::record::write_output(path, report_text()?.as_bytes())?;
        eprintln!("wrote {}", path.display());
    }
    let mut table = super::table_writer(json);
    let printed =
        print_table(&mut table, &rows, &held_out, scenes.len(), request, witness).and_then(|()| table.flush());
    match printed {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other?,
    }
    if let Some(path) = json.filter(|p| safer::record::is_stdout(p)) {
        safer::record::write_output(path, report_text()?.as_bytes())?;
    }
    let failed = rows.iter().any(|r| r.errors == r.variants && r.variants > 0);
    Ok(if failed { ExitCode::from(1) } else { ExitCode::SUCCESS })
}
