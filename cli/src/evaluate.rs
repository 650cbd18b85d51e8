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

use super::*;
use std::io::Write;
use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;

use rayon::prelude::*;

use super::{CliError, scene_paths};
use safer_scenarios::eval::sideways_speed::SidewaysSpread;
use safer_scenarios::eval::spread::Spread;
use safer_scenarios::eval::witness::{DEFAULT_WIDEST, RoadKeeping, WitnessBudget, search_rollout_witness};
use safer_scenarios::harness::evaluation::{
    self, BlindTwinHits, CbvStartRows, EvaluationRequest, HeldOutSplit, MethodRow, Partition, Stage2Cbv, VariantRecord,
};
use safer_scenarios::harness::kill_ratio::{self, KillRatioRange};
use safer_scenarios::harness::methods::BackgroundDriver;
use safer_scenarios::harness::methods::ModelSet;
use safer_scenarios::harness::mutation::{MethodKills, OFF_PATH_M, OperatorKills};
use safer_scenarios::planners::FaultOperator;
use safer_scenarios::policies::adversary::{
    ApproachPhase, CbvTurningCost, CbvTurningLimit, EgoContactRule, FeasibilityScope, MAX_TURNING_COST_M_PER_MPS2,
    WrongWayRule,
};
use safer_scenarios::scenario::roles::RolePairing;
use safer_scenarios::scenario::{Scenario, import};
use safer_scenarios::spec::suite::AdversaryMethod;

/// Loads every scene under `path` that has an ego and a CBV.
pub(super) fn load_scenes(path: &Path, max_scenes: Option<usize>) -> Result<Vec<Arc<Scenario>>, CliError> {
    let paths = scene_paths(path)?;
    let loaded: Vec<Result<Vec<Scenario>, _>> = paths.par_iter().map(|p| import::load(p)).collect();
    let mut scenes = Vec::new();
    // Records, seeds and the held-out split go by scenario id: one id in
    // two files would merge two scenes' rows silently.
    let mut files_of: std::collections::HashMap<String, (&Path, usize)> = std::collections::HashMap::new();
    for (p, r) in paths.iter().zip(loaded) {
        match r {
            Ok(s) => {
                for (record, scene) in s.iter().enumerate() {
                    match files_of.insert(scene.id.clone(), (p, record)) {
                        None => {}
                        Some((first, first_record)) if first == p => {
                            return Err(CliError::Usage(format!(
                                "scenario id `{}` is in {} twice (records {first_record} and {record}); an \
                                 evaluation tells scenes apart by id, so it would count the scene twice",
                                scene.id,
                                p.display()
                            )));
                        }
                        Some((first, _)) => {
                            return Err(CliError::Usage(format!(
                                "scenario id `{}` is in both {} and {}; an evaluation tells scenes apart by id, \
                                 so keep one of the files",
                                scene.id,
                                first.display(),
                                p.display()
                            )));
                        }
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

/// The width of the tables' method column: the longest row name, and at
/// least 28 characters (a column as wide as the longest method's name).
fn method_column(rows: &[MethodRow], name: &dyn Fn(&MethodRow) -> String) -> usize {
    name_column(rows, name, 28)
}

/// The width of a column of row names: the longest, and at least `min`.
fn name_column(rows: &[MethodRow], name: &dyn Fn(&MethodRow) -> String, min: usize) -> usize {
    rows.iter().map(|r| name(r).chars().count()).max().unwrap_or(0).max(min)
}

/// A row's name: the method, and its stage-2 CBV mode when the table holds
/// more than one.
fn label(method: safer_scenarios::spec::suite::AdversaryMethod, mode: Stage2Cbv, modes: usize) -> String {
    let method = safer_scenarios::spec::spec_name(&method);
    if modes > 1 { format!("{method} ({})", safer_scenarios::spec::spec_name(&mode)) } else { method }
}

/// What the witness search holds an escape to, and how hard it looks.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(super) struct WitnessSettings {
    /// How much of the ego must stay on the road.
    pub road: RoadKeeping,
    /// The widest beam tried, as a multiple of the narrow one.
    pub widest: usize,
}

fn is_as_loaded(roles: &RolePairing) -> bool {
    *roles == RolePairing::AsLoaded
}

/// The option that asked for `roles`, as a message names it: ` (--roles
/// leader)`, nothing for the scenes' own pairs.
fn roles_flag(roles: RolePairing) -> String {
    match roles {
        RolePairing::AsLoaded => String::new(),
        other => format!(" (--roles {})", safer_scenarios::spec::spec_name(&other)),
    }
}

fn is_pair(scope: &FeasibilityScope) -> bool {
    *scope == FeasibilityScope::Pair
}

fn is_allowed(rule: &WrongWayRule) -> bool {
    *rule == WrongWayRule::Allowed
}

fn grip_mps2() -> f64 {
    CbvTurningLimit::GRIP.max_lateral_accel_mps2()
}

fn is_grip(mps2: &f64) -> bool {
    *mps2 == grip_mps2()
}

/// Parses `--max-lateral-accel`: above 0 and at most the tyres' grip.
fn turning_limit(written: &str) -> Result<f64, String> {
    let why = " m/s² (no car turns harder than its tyres' grip)";
    number_in(written, &format!("0 < x <= {}", grip_mps2()), why, |v| {
        CbvTurningLimit::new(v).map(CbvTurningLimit::max_lateral_accel_mps2)
    })
}

/// Parses `--turning-cost`: at least 0 and at most the largest cost.
fn turning_cost(written: &str) -> Result<f64, String> {
    number_in(written, &format!("0 <= x <= {MAX_TURNING_COST_M_PER_MPS2}"), " m per m/s²", |v| {
        CbvTurningCost::new(v).map(CbvTurningCost::m_per_mps2)
    })
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

fn is_any_contact(rule: &EgoContactRule) -> bool {
    *rule == EgoContactRule::Any
}

/// What an evaluation was asked, as its report records it: partitions of
/// one evaluation have equal settings, and the merge checks that they do.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub(super) struct EvaluationSettings {
    methods: Vec<AdversaryMethod>,
    seeds: u32,
    base_seed: u64,
    /// The stage-2 planner's name.
    planner: String,
    trust_region: usize,
    /// Reports written before the option existed had the seeded phase.
    #[serde(default)]
    approach: ApproachPhase,
    /// Reports written before the option existed had the pair's.
    #[serde(default, skip_serializing_if = "is_pair")]
    feasibility: FeasibilityScope,
    /// Reports written before the option existed had any contact.
    #[serde(default, skip_serializing_if = "is_any_contact")]
    ego_contact: EgoContactRule,
    /// Reports written before the option existed allowed driving the wrong way.
    #[serde(default, skip_serializing_if = "is_allowed")]
    wrong_way: WrongWayRule,
    /// Reports written before the option existed held the CBV to grip.
    #[serde(default = "grip_mps2", skip_serializing_if = "is_grip")]
    max_lateral_accel_mps2: f64,
    /// Reports written before the option existed had no turning cost.
    #[serde(default, skip_serializing_if = "is_zero")]
    turning_cost_m_per_mps2: f64,
    background: BackgroundDriver,
    stage2_cbv: Vec<Stage2Cbv>,
    horizon_s: f64,
    max_scenes: Option<usize>,
    /// The scenario ids `--scene` named (none: every scene).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    only_scenes: Vec<String>,
    /// The ego–CBV pairs (`--roles`); reports written before the option
    /// existed had the scenes' own.
    #[serde(default, skip_serializing_if = "is_as_loaded")]
    roles: RolePairing,
    witness: WitnessSettings,
    /// The fault operators planted (`--mutants`; none: no mutation run).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    mutants: Vec<safer_scenarios::planners::FaultOperator>,
}

impl EvaluationSettings {
    fn of(request: &EvaluationRequest, selection: &SceneSelection<'_>, witness: WitnessSettings) -> Self {
        EvaluationSettings {
            methods: request.methods.clone(),
            seeds: request.seeds,
            base_seed: request.base_seed,
            planner: request.planner.name().to_string(),
            trust_region: request.trust_region,
            approach: request.approach,
            feasibility: request.feasibility,
            ego_contact: request.ego_contact,
            wrong_way: request.wrong_way,
            max_lateral_accel_mps2: request.turning.max_lateral_accel_mps2(),
            turning_cost_m_per_mps2: request.turning_cost.m_per_mps2(),
            background: request.background,
            stage2_cbv: request.stage2_cbv.clone(),
            horizon_s: request.horizon_s,
            max_scenes: selection.max_scenes,
            only_scenes: selection.ids.to_vec(),
            roles: selection.roles,
            witness,
            mutants: request.mutants.clone(),
        }
    }
}

/// The human-readable table (on stdout, or stderr when the JSON report
/// takes stdout).
fn print_table(
    out: &mut dyn Write,
    rows: &[MethodRow],
    records: &[VariantRecord],
    held_out: &HeldOutSplit,
    by_start: &[CbvStartRows],
    scenes: usize,
    request: &EvaluationSettings,
) -> std::io::Result<()> {
    let witness = request.witness;
    let modes = request.stage2_cbv.len();
    let name = |r: &MethodRow| label(r.method, r.stage2_cbv, modes);
    writeln!(
        out,
        "{scenes} scenes × {} seeds; stage 2 planner `{}`, stage-2 CBV {}, trust region n = {}, horizon {} s{}{}{}{}{}{}{}{}{}",
        request.seeds,
        request.planner,
        request.stage2_cbv.iter().map(safer_scenarios::spec::spec_name).collect::<Vec<_>>().join(" and "),
        request.trust_region,
        request.horizon_s,
        match request.approach {
            ApproachPhase::Seeded => "",
            ApproachPhase::None => "; no approach phase (the adversary engages at the first token)",
        },
        match request.feasibility {
            FeasibilityScope::Pair => "",
            FeasibilityScope::PairInTraffic =>
                "; feasibility pair-in-traffic (V_h and the ego's room among the traffic)",
            FeasibilityScope::Witnessed => "; feasibility witnessed (V_h and the witness's escape before a contact)",
        },
        match request.ego_contact {
            EgoContactRule::Any => "",
            EgoContactRule::NotFromBehind => "; no contact from behind the ego",
        },
        match request.wrong_way {
            WrongWayRule::Allowed => "",
            WrongWayRule::Forbidden => "; no driving against the traffic",
            WrongWayRule::AlongTheLanes => "; no driving against the traffic or across the lanes",
            WrongWayRule::HumanLaneChanges => {
                "; no driving against the traffic or across the lanes, lane changes at a human pace"
            }
        },
        if is_grip(&request.max_lateral_accel_mps2) {
            String::new()
        } else {
            format!("; the CBV turning at most {} m/s²", request.max_lateral_accel_mps2)
        },
        if is_zero(&request.turning_cost_m_per_mps2) {
            String::new()
        } else {
            format!("; a turn costing {} m per m/s²", request.turning_cost_m_per_mps2)
        },
        match witness.road {
            RoadKeeping::Centre => "",
            RoadKeeping::WholeWidth => "; the witness keeps its whole width on the road",
        },
        if witness.widest == DEFAULT_WIDEST {
            String::new()
        } else {
            format!("; the witness search widens its beam up to ×{}", witness.widest)
        },
        match request.roles.cbv_in_words() {
            Some(cbv) => format!("; {cbv}{}", roles_flag(request.roles)),
            None => String::new(),
        }
    )?;
    print_outcomes(out, rows, &name)?;
    print_plausibility(out, rows, &name)?;
    print_scenes_that_broke_the_rules(out, rows, &held_out.scenes, &name)?;
    print_peak_lateral(out, rows, &name)?;
    print_sideways(out, rows, &name)?;
    print_lane_changes(out, rows, held_out, &name)?;
    print_held_out(out, &name, held_out)?;
    print_conflicts_met(out, rows, &name, held_out)?;
    print_stage2_approach(out, rows, &name, held_out)?;
    print_stage2_contacts(out, rows, records, &name)?;
    print_closest_approach(out, rows, &name)?;
    print_stage1_contacts(out, rows, records, &name)?;
    print_cr_by_cbv_start(out, rows, by_start, &name)?;
    print_conflict_kinds(out, rows, &name)?;
    print_time(out, rows, &name)?;
    print_legend(out)?;
    Ok(())
}

/// Each method's CR, SR, witness rate and realism (VJ, AJ, YJ).
fn print_outcomes(out: &mut dyn Write, rows: &[MethodRow], name: &dyn Fn(&MethodRow) -> String) -> std::io::Result<()> {
    let w = method_column(rows, name);
    writeln!(
        out,
        "{:<w$} {:>8} {:>7} {:>7} {:>7} {:>9} {:>9} {:>7} {:>7} {:>7} {:>11}",
        "method", "variants", "errors", "CR", "SR", "SR-crit", "witness", "VJ", "AJ", "YJ", "s/variant"
    )?;
    for r in rows {
        writeln!(
            out,
            "{:<w$} {:>8} {:>7} {:>7} {:>7} {:>9} {:>9} {:>7} {:>7} {:>7} {:>11.3}",
            name(r),
            r.variants,
            r.errors,
            fmt(r.cr),
            fmt(r.sr),
            fmt(r.sr_critical),
            fmt(r.witness_rate),
            fmt(r.vj),
            fmt(r.aj),
            fmt(r.yj),
            r.time_per_variant_s
        )?;
    }
    Ok(())
}

/// The CBV's plausibility, the seeds' variety and the reference planner.
fn print_plausibility(
    out: &mut dyn Write,
    rows: &[MethodRow],
    name: &dyn Fn(&MethodRow) -> String,
) -> std::io::Result<()> {
    let w = method_column(rows, name);
    writeln!(out, "\nplausibility of the CBV, the seeds' variety and the reference planner:")?;
    writeln!(
        out,
        "{:<w$} {:>12} {:>14} {:>15} {:>12} {:>14} {:>10} {:>13} {:>9} {:>12} {:>13} {:>10} {:>11} {:>12} {:>10}",
        "method",
        "CBV-bg coll",
        "CBV at fault",
        "of it: ped/cyc",
        "CBV off-road",
        "off-road s/var",
        "wrong way",
        "wrong way s2",
        "distinct",
        "SR-witnessed",
        "across lanes",
        "across s2",
        "beyond grip",
        "tighter turn",
        "tailgating"
    )?;
    for r in rows {
        writeln!(
            out,
            "{:<w$} {:>12} {:>14} {:>15} {:>12} {:>14} {:>10} {:>13} {:>9} {:>12} {:>13} {:>10} {:>11} {:>12} {:>10}",
            name(r),
            fmt(r.cbv_background_collision_rate),
            fmt(r.cbv_at_fault_background_collision_rate),
            fmt(r.cbv_at_fault_vulnerable_rate),
            fmt(r.cbv_off_road_rate),
            fmt(r.cbv_off_road_s),
            fmt(r.cbv_wrong_way_rate),
            fmt(r.cbv_wrong_way_rate_stage2),
            fmt(r.distinct_rate),
            fmt(r.sr_witnessed),
            fmt(r.cbv_across_lanes_rate),
            fmt(r.cbv_across_lanes_rate_stage2),
            fmt(r.cbv_beyond_grip_rate),
            fmt(r.cbv_tighter_than_a_car_rate),
            fmt(r.cbv_tailgating_rate)
        )?;
    }
    Ok(())
}

/// How hard each method's CBV turned in stage 1, beside the recorded CBV
/// over the same steps.
fn print_peak_lateral(
    out: &mut dyn Write,
    rows: &[MethodRow],
    name: &dyn Fn(&MethodRow) -> String,
) -> std::io::Result<()> {
    let title = "lateral acceleration of the CBV in stage 1 (each variant's peak over 0.5 s, m/s²), beside the recorded CBV's over the same steps:";
    print_beside_recorded(out, rows, name, title, &|r| {
        [r.cbv_peak_lateral_accel_mps2, r.logged_cbv_peak_lateral_accel_mps2]
    })
}

/// How briskly each method's CBV moved across its lanes in stage 1,
/// beside the recorded CBV over the same steps.
fn print_sideways(out: &mut dyn Write, rows: &[MethodRow], name: &dyn Fn(&MethodRow) -> String) -> std::io::Result<()> {
    let title = "sideways speed of the CBV across its lanes in stage 1 (each variant's largest held 0.5 s, m/s), beside the recorded CBV's over the same steps:";
    print_beside_recorded(out, rows, name, title, &|r| {
        [r.cbv_sideways, r.logged_cbv_sideways].map(|s| s.map(spread_of))
    })
}

/// A table under `title` of each method's spread of a per-variant figure
/// of its CBV, beside the recorded CBV's (`spreads`: the two, in that
/// order).
fn print_beside_recorded(
    out: &mut dyn Write,
    rows: &[MethodRow],
    name: &dyn Fn(&MethodRow) -> String,
    title: &str,
    spreads: &dyn Fn(&MethodRow) -> [Option<Spread>; 2],
) -> std::io::Result<()> {
    let w = method_column(rows, name);
    writeln!(out, "\n{title}")?;
    writeln!(
        out,
        "{:<w$} {:>9} {:>7} {:>7} {:>7} | {:>9} {:>7} {:>7} {:>7}",
        "method", "measured", "p50", "p90", "max", "recorded", "p50", "p90", "max"
    )?;
    for r in rows {
        let [generated, recorded] = spreads(r);
        let [n, p50, p90, max] = spread_cells(generated);
        let [ln, lp50, lp90, lmax] = spread_cells(recorded);
        writeln!(out, "{:<w$} {n:>9} {p50:>7} {p90:>7} {max:>7} | {ln:>9} {lp50:>7} {lp90:>7} {lmax:>7}", name(r))?;
    }
    Ok(())
}

/// A spread's cells: how many, median, 90th percentile, largest.
fn spread_cells(spread: Option<Spread>) -> [String; 4] {
    match spread {
        Some(s) => [s.measured.to_string(), format!("{:.2}", s.p50), format!("{:.2}", s.p90), format!("{:.2}", s.max)],
        None => ["0".into(), "—".into(), "—".into(), "—".into()],
    }
}

/// A sideways-speed spread as a spread (in m/s).
fn spread_of(s: SidewaysSpread) -> Spread {
    Spread { measured: s.measured, p50: s.p50_mps, p90: s.p90_mps, max: s.max_mps }
}

/// A sideways-speed spread's cells: how many, median, 90th percentile,
/// largest.
fn sideways_cells(spread: Option<SidewaysSpread>) -> [String; 4] {
    spread_cells(spread.map(spread_of))
}

/// How briskly each method's CBV changed lanes in stage 1, beside the
/// recorded vehicles that changed lanes in the same scenes; over all
/// scenes and over the held-out ones.
fn print_lane_changes(
    out: &mut dyn Write,
    rows: &[MethodRow],
    held_out: &HeldOutSplit,
    name: &dyn Fn(&MethodRow) -> String,
) -> std::io::Result<()> {
    let w = method_column(rows, name);
    writeln!(
        out,
        "\nlane changes: sideways speed of the CBVs that changed lanes in stage 1 (m/s, as above), beside every recorded vehicle that changed lanes in the same scenes over the same steps; all scenes | held out:"
    )?;
    writeln!(
        out,
        "{:<w$} {:>9} {:>7} {:>7} {:>7} | {:>9} {:>7} {:>7} {:>7} | {:>9} {:>7} {:>7} | {:>9} {:>7} {:>7}",
        "method",
        "changed",
        "p50",
        "p90",
        "max",
        "recorded",
        "p50",
        "p90",
        "max",
        "changed",
        "p50",
        "p90",
        "recorded",
        "p50",
        "p90"
    )?;
    for r in rows {
        let held = held_out.held_out.iter().find(|h| h.method == r.method && h.stage2_cbv == r.stage2_cbv);
        let [n, p50, p90, max] = sideways_cells(r.cbv_lane_change_sideways);
        let [rn, rp50, rp90, rmax] = sideways_cells(r.recorded_lane_change_sideways);
        let [hn, hp50, hp90, _] = sideways_cells(held.and_then(|h| h.cbv_lane_change_sideways));
        let [hrn, hrp50, hrp90, _] = sideways_cells(held.and_then(|h| h.recorded_lane_change_sideways));
        writeln!(
            out,
            "{:<w$} {n:>9} {p50:>7} {p90:>7} {max:>7} | {rn:>9} {rp50:>7} {rp90:>7} {rmax:>7} | {hn:>9} {hp50:>7} {hp90:>7} | {hrn:>9} {hrp50:>7} {hrp90:>7}",
            name(r)
        )?;
    }
    Ok(())
}

/// The held-out scenes beside the rest, with the CR a random draw gives.
fn print_held_out(
    out: &mut dyn Write,
    name: &dyn Fn(&MethodRow) -> String,
    held_out: &HeldOutSplit,
) -> std::io::Result<()> {
    let w = method_column(&held_out.held_out, name);
    writeln!(
        out,
        "\nheld out (every tenth scene by id: {} of {}) | the other scenes:",
        held_out.scenes.len(),
        held_out.of_scenes
    )?;
    writeln!(
        out,
        "{:<w$} {:>7} {:>7} {:>9} {:>12} | {:>7} {:>7} {:>9} {:>12} | {:>13}",
        "method", "CR", "SR", "witness", "SR-witnessed", "CR", "SR", "witness", "SR-witnessed", "CR by chance"
    )?;
    for ((h, r), chance) in held_out.held_out.iter().zip(&held_out.rest).zip(&held_out.cr_by_chance) {
        let chance = chance_range(*chance);
        writeln!(
            out,
            "{:<w$} {:>7} {:>7} {:>9} {:>12} | {:>7} {:>7} {:>9} {:>12} | {:>13}",
            name(h),
            fmt(h.cr),
            fmt(h.sr),
            fmt(h.witness_rate),
            fmt(h.sr_witnessed),
            fmt(r.cr),
            fmt(r.sr),
            fmt(r.witness_rate),
            fmt(r.sr_witnessed),
            chance
        )?;
    }
    write_chance_note(out, held_out, "CR", "draws")
}

/// The note under a table that gives a held-out `figure`'s range by
/// chance: where it falls over as many scenes drawn at random, in 95 % of
/// `draws` (nothing where no scene is held out).
fn write_chance_note(out: &mut dyn Write, held_out: &HeldOutSplit, figure: &str, draws: &str) -> std::io::Result<()> {
    if held_out.scenes.is_empty() {
        return Ok(());
    }
    writeln!(
        out,
        "{figure} by chance: where the {figure} of {} scenes drawn at random from all {} falls in 95 % of {draws}",
        held_out.scenes.len(),
        held_out.of_scenes
    )
}

/// A held-out figure's range by chance (see [`HeldOutSplit`]), or a dash.
fn chance_range(range: Option<[f64; 2]>) -> String {
    range.map_or("—".to_string(), |[lo, hi]| format!("{lo:.3}–{hi:.3}"))
}

/// The conflicts the planner under test met in stage 2.
fn print_conflicts_met(
    out: &mut dyn Write,
    rows: &[MethodRow],
    name: &dyn Fn(&MethodRow) -> String,
    held_out: &HeldOutSplit,
) -> std::io::Result<()> {
    let w = method_column(rows, name);
    writeln!(out, "\nconflicts at the planner under test (stage 2):")?;
    writeln!(
        out,
        "{:<w$} {:>7} {:>10} {:>9} {:>10} {:>10} {:>9} {:>9} | {:>7} {:>10} {:>9} | {:>20}",
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
        "SR-avoid",
        "reach-crit by chance"
    )?;
    for ((r, h), chance) in rows.iter().zip(&held_out.held_out).zip(&held_out.reach_critical_by_chance) {
        writeln!(
            out,
            "{:<w$} {:>7} {:>10} {:>9} {:>10} {:>10} {:>9} {:>9} | {:>7} {:>10} {:>9} | {:>20}",
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
            chance_range(*chance),
        )?;
    }
    write_chance_note(out, held_out, "reach-crit", "the draws with a critical variant")?;
    if let Some(line) = failures_beyond_log(rows) {
        writeln!(out, "{line}")?;
    }
    Ok(())
}

/// Where the stage-1-critical conflicts met the planner's ego in stage 2.
fn print_stage2_approach(
    out: &mut dyn Write,
    rows: &[MethodRow],
    name: &dyn Fn(&MethodRow) -> String,
    held_out: &HeldOutSplit,
) -> std::io::Result<()> {
    if rows.iter().all(|r| r.stage2_closest_critical.is_none()) {
        return Ok(());
    }
    let w = method_column(rows, name);
    writeln!(
        out,
        "\nthe critical variants at the planner (stage 2: the CBV's closest approach to the planner's ego, variants):"
    )?;
    writeln!(
        out,
        "{:<w$} {:>8} {:>8} {:>8} {:>13} {:>8} {:>8} {:>8}",
        "method", "critical", "contact", "<1 m", "other first", "1-2 m", "2-5 m", ">=5 m"
    )?;
    for r in rows {
        let Some(c) = r.stage2_closest_critical else { continue };
        writeln!(
            out,
            "{:<w$} {:>8} {:>8} {:>8} {:>13} {:>8} {:>8} {:>8}",
            name(r),
            c.critical,
            c.contact,
            c.under_1_m,
            c.other_collision_first,
            c.under_2_m,
            c.under_5_m,
            c.farther
        )?;
    }
    print_blind_twin(out, rows, name, held_out)
}

/// Whether the critical conflicts the CBV did not bring within 1 m of the
/// planner's ego would have hit its CBV-blind twin (where `blind-cbv` was
/// planted): a conflict the planner answered with a margin, against one
/// that never came its way.
fn print_blind_twin(
    out: &mut dyn Write,
    rows: &[MethodRow],
    name: &dyn Fn(&MethodRow) -> String,
    held_out: &HeldOutSplit,
) -> std::io::Result<()> {
    if !rows.iter().any(|r| r.stage2_closest_critical.as_ref().is_some_and(|c| c.blind_twin().ran > 0)) {
        return Ok(());
    }
    let w = method_column(rows, name);
    writeln!(
        out,
        "\nthe critical variants not reached, by band: how many of those the planner passed hit its CBV-blind twin (blind-cbv hit the CBV / ran):"
    )?;
    writeln!(out, "{:<w$} {:>8} {:>8} {:>8} {:>8} | {:>8}", "method", "1-2 m", "2-5 m", ">=5 m", "met", "held out")?;
    for (r, h) in rows.iter().zip(&held_out.held_out) {
        let Some(c) = r.stage2_closest_critical else { continue };
        let cell = |t: BlindTwinHits| format!("{}/{}", t.hit, t.ran);
        writeln!(
            out,
            "{:<w$} {:>8} {:>8} {:>8} {:>8} | {:>8}",
            name(r),
            cell(c.blind_twin_under_2_m),
            cell(c.blind_twin_under_5_m),
            cell(c.blind_twin_farther),
            fmt(c.met()),
            fmt(h.stage2_closest_critical.and_then(|c| c.met()))
        )?;
    }
    Ok(())
}

/// How close the CBV came to the recorded ego in stage 1.
fn print_closest_approach(
    out: &mut dyn Write,
    rows: &[MethodRow],
    name: &dyn Fn(&MethodRow) -> String,
) -> std::io::Result<()> {
    let w = method_column(rows, name);
    writeln!(out, "\nclosest approach of the CBV to the recorded ego (stage 1, shares of the variants):")?;
    writeln!(out, "{:<w$} {:>9} {:>16} {:>16} {:>9}", "method", "contact", "no contact <0.5m", "0.5-1 m", ">=1 m")?;
    for r in rows {
        let c = r.stage1_closest;
        let share = |f: fn(&safer_scenarios::harness::evaluation::ClosestApproach) -> f64| fmt(c.as_ref().map(f));
        writeln!(
            out,
            "{:<w$} {:>9} {:>16} {:>16} {:>9}",
            name(r),
            share(|c| c.contact),
            share(|c| c.under_half_m),
            share(|c| c.under_1_m),
            share(|c| c.farther)
        )?;
    }
    Ok(())
}

/// The variants of a row: its method, with its stage-2 CBV.
fn records_of<'a>(records: &'a [VariantRecord], row: &MethodRow) -> impl Iterator<Item = &'a VariantRecord> {
    let (method, stage2_cbv) = (row.method, row.stage2_cbv);
    records.iter().filter(move |v| v.method == method && v.stage2_cbv == stage2_cbv)
}

/// How the CBV touched the recorded ego in stage 1, per row: the critical
/// variants by nuPlan's category of their first contact, seen from the ego.
/// A CBV that runs into the ego from behind, or into a standing ego, makes
/// a collision no planner is at fault for (what `--ego-contact
/// not-from-behind` holds the CBV back from). Under each row with a
/// critical variant, the same count of those whose CBV did not reach the
/// planner's ego in stage 2: which conflicts reach-crit misses (a car
/// ahead that the planner stops short of is one of the ego's front).
fn print_stage1_contacts(
    out: &mut dyn Write,
    rows: &[MethodRow],
    records: &[VariantRecord],
    name: &dyn Fn(&MethodRow) -> String,
) -> std::io::Result<()> {
    use safer_scenarios::sim::EgoCollisionKind as Kind;
    const KINDS: [(Kind, &str); 5] = [
        (Kind::ActiveFront, "ego's front"),
        (Kind::ActiveLateral, "side"),
        (Kind::ActiveRear, "from behind"),
        (Kind::StoppedEgo, "ego standing"),
        (Kind::StoppedOther, "CBV standing"),
    ];
    let w = method_column(rows, name);
    writeln!(out, "\nhow the CBV touched the recorded ego (stage 1, the first contact, critical variants):")?;
    write!(out, "{:<w$} {:>8}", "method", "critical")?;
    for (_, heading) in KINDS {
        write!(out, " {heading:>12}")?;
    }
    writeln!(out)?;
    // A line: its label, how many, and how many of `variants` by first contact.
    let line = |out: &mut dyn Write, label: &str, count: usize, variants: &[&VariantRecord]| {
        write!(out, "{label:<w$} {count:>8}")?;
        for (kind, _) in KINDS {
            write!(out, " {:>12}", variants.iter().filter(|v| v.stage1_contact == Some(kind)).count())?;
        }
        writeln!(out)
    };
    for r in rows {
        let of_row: Vec<&VariantRecord> = records_of(records, r).collect();
        line(out, &name(r), of_row.iter().filter(|v| v.stage1_collision).count(), &of_row)?;
        if r.stage2_closest_critical.is_some() {
            let not_reached: Vec<&VariantRecord> =
                of_row.iter().copied().filter(|v| v.tally.critical && !v.tally.reached).collect();
            line(out, "  of them not reached", not_reached.len(), &not_reached)?;
        }
    }
    Ok(())
}

/// The collision rate by where each scene's CBV starts relative to the
/// recorded ego (columns for the starts some scene has, each with its
/// scene count): how much of a method's CR the scenes' pairs allow.
fn print_cr_by_cbv_start(
    out: &mut dyn Write,
    rows: &[MethodRow],
    by_start: &[CbvStartRows],
    name: &dyn Fn(&MethodRow) -> String,
) -> std::io::Result<()> {
    if by_start.is_empty() {
        return Ok(());
    }
    let w = method_column(rows, name);
    writeln!(out, "\nCR by where the CBV starts (relative to the recorded ego where the variants start; scenes):")?;
    write!(out, "{:<w$}", "method")?;
    for s in by_start {
        write!(out, " {:>14}", s.start.name())?;
    }
    writeln!(out)?;
    for r in rows {
        write!(out, "{:<w$}", name(r))?;
        for s in by_start {
            let same = s.rows.iter().find(|o| o.method == r.method && o.stage2_cbv == r.stage2_cbv);
            write!(out, " {:>14}", format!("{} ({})", fmt(same.and_then(|o| o.cr)), s.scenes))?;
        }
        writeln!(out)?;
    }
    Ok(())
}

/// The kinds of conflict, per stage.
fn print_conflict_kinds(
    out: &mut dyn Write,
    rows: &[MethodRow],
    name: &dyn Fn(&MethodRow) -> String,
) -> std::io::Result<()> {
    let w = method_column(rows, name);
    writeln!(out, "\nkinds of conflict (stage 1, with the recorded ego / stage 2, with the planner's):")?;
    let kinds = safer_scenarios::eval::ConflictKind::ALL;
    writeln!(
        out,
        "{:<w$} {}",
        "method",
        kinds.iter().map(|k| format!("{:>22}", k.name())).collect::<Vec<_>>().join("")
    )?;
    for r in rows {
        let cells: Vec<String> = kinds
            .iter()
            .map(|&kind| {
                let c = r.conflicts.iter().find(|c| c.kind == kind);
                format!("{:>22}", format!("{} / {}", c.map_or(0, |c| c.stage1), c.map_or(0, |c| c.variants)))
            })
            .collect();
        writeln!(out, "{:<w$} {}", name(r), cells.join(""))?;
    }
    Ok(())
}

/// Where the time goes, per variant.
fn print_time(out: &mut dyn Write, rows: &[MethodRow], name: &dyn Fn(&MethodRow) -> String) -> std::io::Result<()> {
    let w = method_column(rows, name);
    writeln!(out, "\nwhere the time goes (mean s per variant):")?;
    writeln!(
        out,
        "{:<w$} {:>9} {:>10} {:>9} {:>12} {:>9} {:>9} {:>9}",
        "method", "stage 1", "features", "decoder", "feasibility", "stage 2", "witness", "escape"
    )?;
    for r in rows {
        let p = &r.profile;
        writeln!(
            out,
            "{:<w$} {:>9.3} {:>10.3} {:>9.3} {:>12.3} {:>9.3} {:>9.3} {:>9.3}",
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
    Ok(())
}

/// What the columns mean.
fn print_legend(out: &mut dyn Write) -> std::io::Result<()> {
    writeln!(
        out,
        "VJ/AJ/YJ: Jensen–Shannon divergence (bits) of the CBV's stage-1 speed (0–40 m/s, 1 m/s bins), acceleration (0.5 m/s² bins centred on 0, over ±8.25 m/s², finite differences at 0.1 s) and yaw rate (0.05 rad/s bins centred on 0, over ±1.025 rad/s, heading change over 0.5 s) against the logged CBV over the same window."
    )?;
    writeln!(
        out,
        "reach: share of variants whose CBV came within 1 m (box distance) of the planner's ego in stage 2 (reach-crit: of the stage-1-critical ones; right of | : the held-out scenes). SR-avoid: SR over the avoidable conflicts (reached or collided, less collisions without an escape); avoid-fail: the planner's failures among them. no-escape: stage-2 collisions whose closed-loop witness found no escape within budget (the generator's fault); refuted: of those, the ones whose pre-check found an escape from the CBV as it drove."
    )?;
    writeln!(
        out,
        "the critical variants at the planner: the stage-1-critical variants by the CBV's closest approach to the planner's ego in stage 2, each in one column: contact (a collision with the CBV) and <1 m make reach-crit; other first: the planner's ego hit another agent first, which ended the rollout; then the closest gap of the rest (>=5 m: or never beside it on the road). With blind-cbv planted, the critical variants not reached that the planner passed, per band: those where its CBV-blind twin (blind-cbv) hit the CBV / those it ran on; met: reach-crit plus those hits (a conflict that would have hit a planner blind to it, which the planner answered with a margin)."
    )?;
    writeln!(
        out,
        "how the CBV touched the recorded ego: the critical variants by their first contact, seen from the ego (nuPlan's categories): the ego's front (within 45° of its heading), its side, from behind (within 45° of its tail), the ego standing, the CBV standing; from behind and the ego standing are never the ego's fault (`--ego-contact not-from-behind` holds the CBV back from them). of them not reached: the same count of the critical variants whose CBV did not come within 1 m of the planner's ego in stage 2 (what reach-crit misses, by kind: a car ahead the planner stopped short of, or passed, is one of the ego's front)."
    )?;
    writeln!(
        out,
        "CR by where the CBV starts: CR over the scenes whose CBV, at the step the variants start from, goes the recorded ego's way wholly behind its tail (behind), overlapping it along its heading (beside, in any lane) or wholly ahead of its front (ahead), or heads 45° to 135° off its way (crossing) or more (oncoming); a CBV behind the ego meets its front only by overtaking it."
    )?;
    writeln!(
        out,
        "distinct: distinct stage-1 CBV paths (to the centimetre) per variant, over each scene's seeds; 1.000 when no two seeds made the same variant."
    )?;
    writeln!(
        out,
        "wrong way: share of variants whose CBV drove against a lane's traffic in stage 1 (s2: in stage 2), by the rule of the ego's `wrong_way` check (CARLA's WrongLaneTest: in a lane running more than 120° from its heading, outside intersections, no lane its way within 3 m); the `log` row is the recorded CBV."
    )?;
    writeln!(
        out,
        "across lanes: share of variants whose CBV drove across the lanes for 1 s or more in stage 1 (s2: in stage 2): at 3 m/s or more, more than 30° from every lane its centre was in, outside intersections (a brisk lane change turns 5–10°); the `log` row is the recorded CBV."
    )?;
    writeln!(
        out,
        "beyond grip: share of variants whose CBV, in stage 1, turned harder than a car's tyres hold: its heading change over 0.5 s per second times its mean speed over them above 9 m/s² (the ego's default `max_lateral_accel_mps2`); the `log` row is the recorded CBV."
    )?;
    writeln!(
        out,
        "tighter turn: share of variants whose CBV, in stage 1, turned tighter than a car steers: its heading turned over 0.5 s by more than 0.25 rad a metre it drove then (a 4 m radius) and 0.05 rad (the recorded headings' jitter) besides, a turn on the spot included; the `log` row is the recorded CBV, whose headings jump now and then (a tracking glitch)."
    )?;
    writeln!(
        out,
        "tailgating: share of variants whose CBV, in stage 1, drove on the ego's bumper for 1 s or more: at 5 m/s or more, going the ego's way (within 45°), behind its tail and within the two cars' half widths of its heading line, the gap between them under 0.5 s of the CBV's speed (drivers keep one to two seconds); the `log` row is the recorded CBV behind the recorded ego."
    )?;
    writeln!(
        out,
        "lateral acceleration: each variant's peak, in stage 1, of the CBV's heading change over 0.5 s per second times its mean speed over them (as beyond grip measures it; p90: nearest rank); recorded: the recorded CBV of the same variants over the same steps."
    )?;
    writeln!(
        out,
        "sideways speed: the CBV's speed times the sine of its smallest angle to a lane of its way that holds its centre, at 3 m/s or more, outside intersections; each variant's largest such speed held for 0.5 s at every step (a recorded heading's one-step noise does not count), over the variants where it was measured that long (p90: nearest rank); recorded: the recorded CBV of the same variants over the same steps."
    )?;
    writeln!(
        out,
        "lane changes: the sideways speed over the variants whose CBV changed lanes in stage 1: its lane (the lane of its way holding its centre with the nearest centreline) became another, its centre between the two centrelines and these 2.5 m or more apart (overlapping lanes are no lane change), having been out of the new lane for 1 s before and staying out of the old one for 1 s after; recorded: every recorded vehicle of the row's scenes that changed lanes so over the same steps (both stages' horizon), each scene once: the pace of human lane changes (the recorded CBVs mostly keep their lane)."
    )?;
    Ok(())
}

/// How far each method's kill ratios over log replay's and the prior's
/// move over resampled scenes, when mutants were planted.
fn print_kill_ratios(
    out: &mut dyn Write,
    ranges: &[KillRatioRange],
    settings: &EvaluationSettings,
) -> std::io::Result<()> {
    if settings.mutants.is_empty() || ranges.is_empty() {
        return Ok(());
    }
    let modes = settings.stage2_cbv.len();
    let width = ranges.iter().map(|r| label(r.method, r.stage2_cbv, modes).len()).max().unwrap_or(0).max(6);
    writeln!(
        out,
        "\nkills over resampled scenes: the middle 95 % of {} draws of as many scenes, with replacement, of the kills over log replay's and the prior's",
        kill_ratio::RESAMPLES
    )?;
    writeln!(out, "{:<width$}  {:>13}  {:>13}", "method", "×log 95 %", "×prior 95 %")?;
    let range = |r: Option<[f64; 2]>| match r {
        Some([low, high]) => format!("{}–{}", ratio_cell(low), ratio_cell(high)),
        None => "-".to_string(),
    };
    for r in ranges {
        writeln!(
            out,
            "{:<width$}  {:>13}  {:>13}",
            label(r.method, r.stage2_cbv, modes),
            range(r.over_log),
            range(r.over_prior)
        )?;
    }
    Ok(())
}

/// A kill ratio as the tables print it (`inf` where the base killed none).
fn ratio_cell(x: f64) -> String {
    if x.is_infinite() { "inf".to_string() } else { format!("{x:.2}") }
}

/// The mutation table, when mutants were planted: per method row, the
/// variants the planner passes, the mutant-variants killed (with the
/// ratio to log replay's and the prior's where those rows ran), the
/// mutants killed, and per operator its kills and the share of scenes
/// where it was killed; the held-out scenes' kills after `|`.
fn print_kills(
    out: &mut dyn Write,
    rows: &[MethodRow],
    held_out: &HeldOutSplit,
    settings: &EvaluationSettings,
) -> std::io::Result<()> {
    if settings.mutants.is_empty() {
        return Ok(());
    }
    let modes = settings.stage2_cbv.len();
    let kills_of = |method: AdversaryMethod, mode: Stage2Cbv, count: fn(&MethodKills) -> usize| {
        rows.iter().find(|r| r.method == method && r.stage2_cbv == mode).and_then(|r| r.kills.as_ref()).map(count)
    };
    let ratio = |k: usize, of: Option<usize>| match of {
        Some(base) if k > 0 || base > 0 => ratio_cell(k as f64 / base as f64),
        _ => "-".to_string(),
    };
    writeln!(
        out,
        "\nmutants killed (the planner passes the variant, the mutant fails it: at-fault collision, off road, no answer or beyond the vehicle limits)"
    )?;
    let ops: Vec<String> = settings.mutants.iter().map(|o| o.name().to_string()).collect();
    let width = name_column(rows, &|r| label(r.method, r.stage2_cbv, modes), 6);
    write!(
        out,
        "{:<width$}  {:>6}  {:>18}  {:>6}  {:>6}  {:>11}  {:>6}  {:>6}  {:>6}  {:>10}  {:>6}  {:>7}",
        "method",
        "passed",
        "kills | held out",
        "×log",
        "×prior",
        "scene kills",
        "×log",
        "×prior",
        "by CBV",
        "beyond log",
        "×prior",
        "mutants"
    )?;
    for op in &ops {
        write!(out, "  {op:>12}")?;
    }
    writeln!(out)?;
    for r in rows {
        let Some(k) = &r.kills else { continue };
        let held = held_out
            .held_out
            .iter()
            .find(|h| h.method == r.method && h.stage2_cbv == r.stage2_cbv)
            .and_then(|h| h.kills.as_ref());
        let kills = match held {
            Some(h) => format!("{}/{} | {}/{}", k.kills, k.mutant_variants, h.kills, h.mutant_variants),
            None => format!("{}/{}", k.kills, k.mutant_variants),
        };
        write!(
            out,
            "{:<width$}  {:>6}  {:>18}  {:>6}  {:>6}  {:>11}  {:>6}  {:>6}  {:>6}  {:>10}  {:>6}  {:>7}",
            label(r.method, r.stage2_cbv, modes),
            k.variants_passed,
            kills,
            ratio(k.kills, kills_of(AdversaryMethod::Log, r.stage2_cbv, |k| k.kills)),
            ratio(k.kills, kills_of(AdversaryMethod::Prior, r.stage2_cbv, |k| k.kills)),
            k.scene_kills,
            ratio(k.scene_kills, kills_of(AdversaryMethod::Log, r.stage2_cbv, |k| k.scene_kills)),
            ratio(k.scene_kills, kills_of(AdversaryMethod::Prior, r.stage2_cbv, |k| k.scene_kills)),
            k.cbv_kills,
            k.beyond_replay.map_or_else(|| "-".to_string(), |b| b.to_string()),
            match (k.beyond_replay, kills_of(AdversaryMethod::Prior, r.stage2_cbv, |k| k.beyond_replay.unwrap_or(0))) {
                (Some(b), prior) => ratio(b, prior),
                (None, _) => "-".to_string(),
            },
            format!("{}/{}", k.mutants_killed, k.operators.len()),
        )?;
        for op in &settings.mutants {
            let cell = k
                .operators
                .iter()
                .find(|o| o.operator == *op)
                .map_or_else(|| "-".to_string(), |o| format!("{} ({}/{})", o.kills, o.scenes_killed, o.scenes));
            write!(out, "  {cell:>12}")?;
        }
        writeln!(out)?;
    }
    writeln!(
        out,
        "kills: mutant-variants killed / passed variants × mutants, over distinct variants (right of | : on the held-out scenes); a seed that repeats another seed's variant of its scene (the same stage-1 CBV path and the same results, as all of log replay's do) counts once{}; scene kills: (scene, mutant) pairs where some variant killed the mutant; by CBV: kills whose mutant collided with the CBV (the rest it failed against the recorded traffic, the road or the vehicle limits); beyond log: kills of a mutant in a scene where no variant of log replay kills it (the faults replaying the recording misses; with log replay in the run); ×log, ×prior: over log replay's and the prior's on the same scenes and seeds; per mutant: kills (scenes where it was killed / scenes with a passed variant).",
        repeats_note(rows, modes)
    )?;
    write_mutant_effects(out, rows, modes, &settings.mutants, width)
}

/// The mutants' effect tables, each left out for reports that did not
/// record it. First, per method and mutant, the distinct passed variants
/// where the mutant's ego drove otherwise than the planner's: a mutant at
/// 0 never had its fault come into play, so nothing could kill it there,
/// a survivor the scenes leave untested, not one they test and miss.
/// Then the mutants' paths: the distinct passed variants where the
/// mutant's path left the planner's by more than [`OFF_PATH_M`], and the
/// farthest it did. A fault that changes only the steering and never left
/// the path took away no swerve, however its lane keeping differs.
fn write_mutant_effects(
    out: &mut dyn Write,
    rows: &[MethodRow],
    modes: usize,
    mutants: &[FaultOperator],
    width: usize,
) -> std::io::Result<()> {
    if any_recorded(rows, |o| o.variants_driven_differently.is_some()) {
        writeln!(
            out,
            "\nmutants' effect (distinct passed variants where the mutant drove otherwise than the planner / passed variants)"
        )?;
        let never = write_per_mutant_table(out, rows, modes, mutants, width, 12, |k, op| {
            let differently = k.operators.iter().find(|o| o.operator == op)?.variants_driven_differently?;
            let never = (differently == 0 && k.variants_passed > 0).then(String::new);
            Some((format!("{differently}/{}", k.variants_passed), never))
        })?;
        writeln!(
            out,
            "drove otherwise: the mutant's ego was more than 1 cm from the planner's at some step (or its rollout ended at another step). Never (the fault never came into play, so no variant could kill it): {never}."
        )?;
    }
    if any_recorded(rows, |o| o.variants_off_path.is_some()) {
        writeln!(
            out,
            "\nmutants' paths (distinct passed variants where the mutant's path left the planner's by more than {OFF_PATH_M} m / passed variants, and the farthest it did, m)"
        )?;
        let kept = write_per_mutant_table(out, rows, modes, mutants, width, 16, |k, op| {
            let o = k.operators.iter().find(|o| o.operator == op)?;
            let (off, farthest) = (o.variants_off_path?, o.largest_path_departure_m?);
            let kept = (op.changes_only_the_steering() && off == 0 && k.variants_passed > 0)
                .then(|| format!(" (at most {farthest:.2} m)"));
            Some((format!("{off}/{} {farthest:.2}", k.variants_passed), kept))
        })?;
        writeln!(
            out,
            "left the path: the two egos were more than {OFF_PATH_M} m apart sideways at some step (either one farther than that from the path the other drove, joined step to step and carried on straight past both ends); a mutant that drove the same way faster or slower does not leave it. A fault that changes only the steering (no-evade) took away no swerve where it kept to the path, however its lane keeping differs, and its kills there are the lane keeping's; kept to the path in every variant: {kept}."
        )?;
    }
    Ok(())
}

/// Whether some method's mutation run recorded what `recorded` asks of a
/// mutant (reports written before a measure was made lack it).
fn any_recorded(rows: &[MethodRow], recorded: impl Fn(&OperatorKills) -> bool) -> bool {
    rows.iter().filter_map(|r| r.kills.as_ref()).any(|k| k.operators.iter().any(&recorded))
}

/// The body of a per-mutant table of the methods' mutation runs, under
/// its title: a header of the mutants, then a row for each method with a
/// run, each cell `cell(kills, mutant)` right-aligned in `cell_width`
/// (`-` where it gives none). Returns, for the note under the table, the
/// cells `cell` flags, each as `METHOD: MUTANT` and the flag's text, or
/// `none`.
fn write_per_mutant_table(
    out: &mut dyn Write,
    rows: &[MethodRow],
    modes: usize,
    mutants: &[FaultOperator],
    width: usize,
    cell_width: usize,
    cell: impl Fn(&MethodKills, FaultOperator) -> Option<(String, Option<String>)>,
) -> std::io::Result<String> {
    write!(out, "{:<width$}", "method")?;
    for op in mutants {
        write!(out, "  {:>cell_width$}", op.name())?;
    }
    writeln!(out)?;
    let mut flagged: Vec<String> = Vec::new();
    for r in rows {
        let Some(k) = &r.kills else { continue };
        let method = label(r.method, r.stage2_cbv, modes);
        write!(out, "{method:<width$}")?;
        for &op in mutants {
            let (text, flag) = cell(k, op).unwrap_or_else(|| ("-".to_string(), None));
            if let Some(flag) = flag {
                flagged.push(format!("{method}: {}{flag}", op.name()));
            }
            write!(out, "  {text:>cell_width$}")?;
        }
        writeln!(out)?;
    }
    Ok(if flagged.is_empty() { "none".to_string() } else { flagged.join(", ") })
}

/// The repeated variants each row left out, for the kills table's note
/// (empty when none did).
fn repeats_note(rows: &[MethodRow], modes: usize) -> String {
    let left_out: Vec<String> = rows
        .iter()
        .filter_map(|r| Some((label(r.method, r.stage2_cbv, modes), r.kills.as_ref()?.repeated_variants)))
        .filter(|(_, n)| *n > 0)
        .map(|(m, n)| format!("{m} {n}"))
        .collect();
    if left_out.is_empty() { String::new() } else { format!(" (repeats left out: {})", left_out.join(", ")) }
}

/// How many scenes [`print_scenes_that_broke_the_rules`] names per list.
const SCENES_NAMED: usize = 3;

/// Where the CBV left the road or was at fault with background traffic,
/// scene by scene, for the rows where it did: the scenes with the most
/// such variants (of the scene's seeds), held-out ones starred, and how
/// many more scenes share the rest. Nothing where no CBV broke a rule.
fn print_scenes_that_broke_the_rules(
    out: &mut dyn Write,
    rows: &[MethodRow],
    held_out: &[String],
    name: &dyn Fn(&MethodRow) -> String,
) -> std::io::Result<()> {
    let w = method_column(rows, name);
    let broke: Vec<&MethodRow> = rows
        .iter()
        .filter(|r| {
            !r.off_road_scenes.is_empty()
                || !r.at_fault_scenes.is_empty()
                || !r.wrong_way_scenes.is_empty()
                || !r.across_lanes_scenes.is_empty()
        })
        .collect();
    if broke.is_empty() {
        return Ok(());
    }
    writeln!(
        out,
        "where the CBV left the road / was at fault / drove the wrong way or across the lanes (in either stage): the scenes with the most such variants (k/n: k of the scene's n; \
         * held out; `--scene ID --artifacts DIR --artifacts-of all` draws them)"
    )?;
    for r in broke {
        let kinds = [
            ("off road", &r.off_road_scenes),
            ("at fault", &r.at_fault_scenes),
            ("wrong way", &r.wrong_way_scenes),
            ("across lanes", &r.across_lanes_scenes),
        ];
        for (i, (what, scenes)) in kinds.into_iter().filter(|(_, scenes)| !scenes.is_empty()).enumerate() {
            let method = if i == 0 { name(r) } else { String::new() };
            writeln!(out, "{method:<w$} {what}: {}", named_scenes(scenes, held_out))?;
        }
    }
    Ok(())
}

/// The first [`SCENES_NAMED`] of `scenes` as `ID k/n` (a star after a
/// held-out id; `held_out` sorted), then how many variants the others
/// hold between them.
fn named_scenes(scenes: &[safer_scenarios::harness::evaluation::SceneCount], held_out: &[String]) -> String {
    let mut parts: Vec<String> = scenes
        .iter()
        .take(SCENES_NAMED)
        .map(|c| {
            let star = if held_out.binary_search(&c.scenario).is_ok() { "*" } else { "" };
            format!("{}{star} {}/{}", c.scenario, c.variants, c.of)
        })
        .collect();
    let more = scenes.len().saturating_sub(SCENES_NAMED);
    if more > 0 {
        let variants: usize = scenes[SCENES_NAMED..].iter().map(|c| c.variants).sum();
        parts.push(format!("{variants} in {more} more scene{}", if more == 1 { "" } else { "s" }));
    }
    parts.join(", ")
}

/// For each method with both stage-2 modes, its planner failures beside
/// plain log replay's, in words: how many more or fewer each mode finds
/// than log replay, and how the modes' extra failures compare (closed
/// loop's as a multiple of replay's, where both found some). `None` when no
/// method has both modes; a line saying so without a `log` row.
fn failures_beyond_log(rows: &[MethodRow]) -> Option<String> {
    failures_beside_log(&rows.iter().map(|r| (r.method, r.stage2_cbv, r.failures)).collect::<Vec<_>>())
}

/// [`failures_beyond_log`] of rows given as (method, stage-2 CBV mode,
/// planner failures).
fn failures_beside_log(rows: &[(AdversaryMethod, Stage2Cbv, usize)]) -> Option<String> {
    let pairs: Vec<(AdversaryMethod, usize, usize)> = rows
        .iter()
        .filter(|r| r.0 != AdversaryMethod::Log && r.1 == Stage2Cbv::ClosedLoop)
        .filter_map(|closed| {
            let replay = rows.iter().find(|r| r.0 == closed.0 && r.1 == Stage2Cbv::Replay)?;
            Some((closed.0, closed.2, replay.2))
        })
        .collect();
    if pairs.is_empty() {
        return None;
    }
    let Some(&(_, _, log)) = rows.iter().find(|r| r.0 == AdversaryMethod::Log) else {
        return Some(
            "planner failures beside log replay's: not measured (no `log` row to compare with: add `log` to --methods)"
                .to_string(),
        );
    };
    let baseline = log as i64;
    let parts: Vec<String> = pairs
        .iter()
        .map(|&(method, closed, replay)| {
            let (c, p) = (closed as i64 - baseline, replay as i64 - baseline);
            format!(
                "{}: closed loop {closed} ({}), replay {replay} ({}); {}",
                safer_scenarios::spec::spec_name(&method),
                beside_log(c),
                beside_log(p),
                compare_beyond(c, p)
            )
        })
        .collect();
    Some(format!("planner failures beside log replay's {}: {}", count_of(log, "failure"), parts.join("; ")))
}

/// `5 more than log replay`, `as many as log replay`, `2 fewer than log replay`.
fn beside_log(difference: i64) -> String {
    match difference {
        0 => "as many as log replay".to_string(),
        d if d > 0 => format!("{d} more than log replay"),
        d => format!("{} fewer than log replay", -d),
    }
}

/// How closed loop's failures beyond log replay's (`closed`) compare with
/// replay's (`replay`), in words.
fn compare_beyond(closed: i64, replay: i64) -> String {
    match (closed > 0, replay > 0) {
        (true, true) => {
            format!("closed loop finds {:.2}× as many beyond log replay's as replay", closed as f64 / replay as f64)
        }
        (true, false) => "only closed loop finds failures beyond log replay's".to_string(),
        (false, true) => "only replay finds failures beyond log replay's".to_string(),
        (false, false) => "neither finds failures beyond log replay's".to_string(),
    }
}

/// `1 failure`, `6 failures`.
fn count_of(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

/// How many of the variants an agent is shown for, per row, in
/// [`print_stage2_contacts`].
const CONTACTS_NAMED: usize = 3;

/// Whom the planner's ego hit in stage 2, per row: the CBV or another
/// agent, and whether the ego was at fault; then the first few such
/// variants by scene and seed, naming the agent (the JSON report's
/// `stage2_contact` of each variant).
fn print_stage2_contacts(
    out: &mut dyn Write,
    rows: &[MethodRow],
    records: &[VariantRecord],
    name: &dyn Fn(&MethodRow) -> String,
) -> std::io::Result<()> {
    let w = method_column(rows, name);
    writeln!(
        out,
        "\nwhom the planner's ego hit in stage 2 (at fault: the ego's fault; scenes: the scenes with a collision / \
         the row's scenes; most in one: the most collisions in one scene):"
    )?;
    writeln!(
        out,
        "{:<w$} {:>8} {:>8} {:>8} {:>11} {:>20} {:>20}",
        "method", "variants", "collided", "scenes", "most in one", "with the CBV", "with other agents"
    )?;
    for r in rows {
        let of_row: Vec<(&VariantRecord, &safer_scenarios::harness::evaluation::Stage2Contact)> =
            records_of(records, r).filter_map(|v| v.stage2_contact.as_ref().map(|c| (v, c))).collect();
        let with_cbv = of_row.iter().filter(|(_, c)| c.with_cbv).count();
        let at_fault = |cbv: bool| of_row.iter().filter(|(_, c)| c.with_cbv == cbv && c.at_fault).count();
        let (scenes, most_in_one) = collisions_by_scene(records_of(records, r), of_row.iter().map(|(v, _)| *v));
        writeln!(
            out,
            "{:<w$} {:>8} {:>8} {:>8} {:>11} {:>20} {:>20}",
            name(r),
            r.variants,
            of_row.len(),
            scenes,
            most_in_one,
            format!("{with_cbv} ({} at fault)", at_fault(true)),
            format!("{} ({} at fault)", of_row.len() - with_cbv, at_fault(false)),
        )?;
        for (v, c) in of_row.iter().take(CONTACTS_NAMED) {
            writeln!(out, "{:<w$} {} seed {}: {}", "", v.scenario, v.seed, describe_contact(c))?;
        }
        if of_row.len() > CONTACTS_NAMED {
            writeln!(
                out,
                "{:<w$} and {} more (the JSON report's `stage2_contact` names each)",
                "",
                of_row.len() - CONTACTS_NAMED
            )?;
        }
    }
    Ok(())
}

/// How a row's stage-2 collisions spread over its scenes: `K/N` (K of
/// the row's N scenes hold one) and the most in one scene. A planner that
/// fails eleven times in one scene has one fault to fix, not eleven.
fn collisions_by_scene<'a>(
    row: impl Iterator<Item = &'a VariantRecord>,
    collided: impl Iterator<Item = &'a VariantRecord>,
) -> (String, usize) {
    let scenes: std::collections::BTreeSet<&str> = row.map(|v| v.scenario.as_str()).collect();
    let mut per_scene: std::collections::BTreeMap<&str, usize> = std::collections::BTreeMap::new();
    for v in collided {
        *per_scene.entry(v.scenario.as_str()).or_default() += 1;
    }
    (format!("{}/{}", per_scene.len(), scenes.len()), per_scene.values().copied().max().unwrap_or(0))
}

/// `agent 123 (the CBV), the ego at fault`.
fn describe_contact(c: &safer_scenarios::harness::evaluation::Stage2Contact) -> String {
    format!(
        "agent {}{}, {}",
        c.other,
        if c.with_cbv { " (the CBV)" } else { "" },
        if c.at_fault { "the ego at fault" } else { "not the ego's fault" }
    )
}

/// The JSON report: the settings, the tables and every variant (with what
/// it contributes to the tables, so that partitions merge).
#[derive(serde::Serialize)]
struct Report<'a> {
    settings: &'a EvaluationSettings,
    /// Which part of a partitioned evaluation this is (`None`: all of it).
    partition: Option<Partition>,
    scenes: usize,
    scene_list: &'a SceneList,
    rows: &'a [MethodRow],
    /// The same rows over the held-out scenes and over the rest.
    held_out: &'a HeldOutSplit,
    /// The same rows over the scenes by where their CBV starts.
    by_cbv_start: &'a [CbvStartRows],
    /// How far each row's kill ratios move over resampled scenes (empty
    /// without mutants).
    kill_ratios: &'a [KillRatioRange],
    variants: &'a [VariantRecord],
}

/// A report as read back for merging: the settings, the partition and the
/// variants (the tables are made again from the variants).
#[derive(serde::Deserialize)]
struct PartReport {
    settings: EvaluationSettings,
    partition: Option<Partition>,
    scene_list: SceneList,
    variants: Vec<VariantRecord>,
}

/// The scenes a report covers, and which evaluation they belong to.
#[derive(serde::Serialize, serde::Deserialize)]
struct SceneList {
    /// [`evaluation::scene_list_digest`] of the whole evaluation's sorted
    /// scene ids, before any partition: equal in every part of one split.
    digest: String,
    /// This report's scenario ids, sorted.
    ids: Vec<String>,
}

/// Which of a folder's scenes an evaluation runs.
pub(super) struct SceneSelection<'a> {
    /// Only the first N by id.
    pub max_scenes: Option<usize>,
    /// Only these scenario ids (none: all).
    pub ids: &'a [String],
    /// The ego–CBV pair each scene is tested with.
    pub roles: RolePairing,
}

impl SceneSelection<'_> {
    /// `scenes` with the roles this selection asks for; with `merging`,
    /// the scenes that have a merging pair.
    fn paired(&self, scenes: Vec<Arc<Scenario>>) -> Vec<Arc<Scenario>> {
        if self.roles == RolePairing::AsLoaded {
            return scenes;
        }
        let all = scenes.len();
        let paired: Vec<Arc<Scenario>> = scenes
            .into_iter()
            .filter_map(|s| {
                let mut s = Arc::unwrap_or_clone(s);
                self.roles.assign(&mut s).then(|| Arc::new(s))
            })
            .collect();
        let flag = safer_scenarios::spec::spec_name(&self.roles);
        eprintln!("evaluate: --roles {flag}: {} of {all} scenes have {}", paired.len(), self.roles.pair_in_brief());
        paired
    }

    /// The scenes under `dir` this selection keeps, by id; an id that no
    /// scene with an ego and a CBV has is an error naming it.
    fn load(&self, dir: &Path) -> Result<Vec<Arc<Scenario>>, CliError> {
        let scenes = self.paired(load_scenes(dir, self.max_scenes)?);
        if self.ids.is_empty() {
            return Ok(scenes);
        }
        if let Some(missing) = self.ids.iter().find(|id| !scenes.iter().any(|s| &s.id == *id)) {
            return Err(CliError::Usage(format!(
                "--scene {missing}: no scene with {}{} under {} has that id ({} do; the tables name them)",
                self.roles.pair_in_words(),
                roles_flag(self.roles),
                dir.display(),
                scenes.len()
            )));
        }
        Ok(scenes.into_iter().filter(|s| self.ids.contains(&s.id)).collect())
    }
}

/// Runs the command.
pub(super) fn run(
    scenes_dir: &Path,
    request: &EvaluationRequest,
    selection: SceneSelection<'_>,
    json: Option<&Path>,
    witness: WitnessSettings,
    partition: Option<Partition>,
) -> Result<ExitCode, CliError> {
    let mut outputs = Vec::new();
    if let Some(path) = json {
        safer_scenarios::record::output::check_output(path)?;
        outputs.push(safer_scenarios::record::NamedOutput { flag: "--json", path });
    }
    if let Some(path) = request.artefacts.as_deref() {
        outputs.push(safer_scenarios::record::NamedOutput { flag: "--artifacts", path });
    }
    if !outputs.is_empty() {
        // The outputs must not replace a scene the evaluation reads, nor
        // the planner's spec.
        let mut inputs = scene_paths(scenes_dir)?;
        inputs.extend(request.planner.argument_files());
        safer_scenarios::record::check_outputs_apart(&outputs, &inputs)?;
    }
    if let Some(path) = json {
        super::check_json_report(path)?;
    }
    super::progress::stage("evaluate", &format!("loading the scenes under {}", scenes_dir.display()));
    let scenes: Vec<Arc<Scenario>> = selection
        .load(scenes_dir)?
        .into_iter()
        .filter(|s| match safer_scenarios::scenario::roles::recorded_ego_contact(s) {
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
        return Err(CliError::Usage(format!(
            "{}: no scene with {}{}",
            scenes_dir.display(),
            selection.roles.pair_in_words(),
            roles_flag(selection.roles)
        )));
    }
    let digest = evaluation::scene_list_digest(&scenes.iter().map(|s| s.id.as_str()).collect::<Vec<_>>());
    let scenes = match partition {
        Some(part) => {
            let all = scenes.len();
            let mine = part.select(scenes);
            eprintln!("partition {}/{}: {} of {all} scenes", part.index, part.count, mine.len());
            mine
        }
        None => scenes,
    };
    let models = ModelSet::shipped();
    let total = (scenes.len() * request.methods.len() * request.stage2_cbv.len() * request.seeds as usize) as u64;
    let budget = WitnessBudget::widening_up_to(witness.widest);
    let search = move |scenario: &Scenario, stage1: &safer_scenarios::sim::Rollout| {
        search_rollout_witness(scenario, stage1, witness.road, budget)
    };
    super::progress::stage("evaluate", &variant_work(request));
    let progress = super::progress::Progress::new("evaluate", "variants", total as usize);
    let records = evaluation::evaluate(&scenes, request, &models, Some(&search), &|| progress.tick());
    drop(progress);
    for r in records.iter().filter(|r| r.error.is_some()).take(5) {
        let method = safer_scenarios::spec::spec_name(&r.method);
        eprintln!("error: {} {method} seed {}: {}", r.scenario, r.seed, r.error.as_deref().unwrap_or(""));
    }
    let settings = EvaluationSettings::of(request, &selection, witness);
    let scene_list = SceneList { digest, ids: scenes.iter().map(|s| s.id.clone()).collect() };
    report(&settings, partition, &scene_list, &records, json)
}

/// What each variant of `request` runs, for the progress a slow one leaves
/// long between counts.
fn variant_work(request: &EvaluationRequest) -> String {
    let mut parts = vec!["stage 1".to_string(), format!("stage 2 with `{}`", request.planner.name())];
    if request.escape.is_some() {
        parts.push("the escape search on a collision".into());
    }
    parts.push("the witness search on a stage-1 collision".into());
    if !request.mutants.is_empty() {
        parts.push(format!("{} mutants' stage 2", request.mutants.len()));
    }
    if request.artefacts.is_some() {
        parts.push("the artefacts".into());
    }
    format!("each variant runs {}", parts.join(", "))
}

/// Prints the tables of `records` and writes the JSON report; exit code 1
/// when every variant of some row failed to run.
fn report(
    settings: &EvaluationSettings,
    partition: Option<Partition>,
    scene_list: &SceneList,
    records: &[VariantRecord],
    json: Option<&Path>,
) -> Result<ExitCode, CliError> {
    let rows = evaluation::table(records, &settings.methods);
    let held_out = evaluation::held_out_split(records, &settings.methods);
    let by_cbv_start = evaluation::by_cbv_start(records, &settings.methods);
    let kill_ratios = kill_ratio::kill_ratio_ranges(records, &settings.methods);
    let scenes = scene_list.ids.len();
    let report = Report {
        settings,
        partition,
        scenes,
        scene_list,
        rows: &rows,
        held_out: &held_out,
        by_cbv_start: &by_cbv_start,
        kill_ratios: &kill_ratios,
        variants: records,
    };
    super::write_report_and_table(json, &report, |table| {
        print_table(table, &rows, records, &held_out, &by_cbv_start, scenes, settings)?;
        print_kills(table, &rows, &held_out, settings)?;
        print_kill_ratios(table, &kill_ratios, settings)
    })?;
    let failed = rows.iter().any(|r| r.errors == r.variants && r.variants > 0);
    Ok(if failed { ExitCode::from(1) } else { ExitCode::SUCCESS })
}

/// `safer evaluate-merge`: the reports of an evaluation's partitions (each
/// `safer evaluate --partition K/N --json F`) as one run's table and
/// report. The parts must share their settings and be the N distinct parts
/// of one N-way split.
pub(super) fn merge(parts: &[std::path::PathBuf], json: Option<&Path>) -> Result<ExitCode, CliError> {
    if let Some(path) = json {
        safer_scenarios::record::check_outputs_apart(
            &[safer_scenarios::record::NamedOutput { flag: "--json", path }],
            parts,
        )?;
        super::check_json_report(path)?;
    }
    let mut read: Vec<(&Path, PartReport)> = Vec::new();
    for path in parts {
        let text = std::fs::read_to_string(path)
            .map_err(|e| CliError::Usage(format!("{}: cannot read the report: {e}", path.display())))?;
        let part: PartReport = serde_json::from_str(&text).map_err(|e| {
            CliError::Usage(format!(
                "{}: not a report of `safer evaluate --json` from this version (line {}, column {}: {e})",
                path.display(),
                e.line(),
                e.column()
            ))
        })?;
        read.push((path, part));
    }
    let Some((first_path, first)) = read.first() else {
        return Err(CliError::Usage("name the partitions' reports to merge".into()));
    };
    let count = match first.partition {
        Some(p) => p.count,
        None => {
            return Err(CliError::Usage(format!(
                "{}: not a partition's report (run `safer evaluate --partition K/N --json F`)",
                first_path.display()
            )));
        }
    };
    let mut seen: Vec<Option<&Path>> = vec![None; count];
    for (path, part) in &read {
        if let Some(difference) = settings_difference(&first.settings, &part.settings) {
            return Err(CliError::Usage(format!(
                "{} and {} are parts of different evaluations: their settings differ ({difference})",
                first_path.display(),
                path.display()
            )));
        }
        if part.scene_list.digest != first.scene_list.digest {
            return Err(CliError::Usage(format!(
                "{} and {} are parts of different evaluations: they split different scene lists (another \
                 folder, --max-scenes or --scene)",
                first_path.display(),
                path.display()
            )));
        }
        let p = part.partition.filter(|p| p.count == count).ok_or_else(|| {
            CliError::Usage(format!(
                "{}: not one of {count} partitions, as {} is",
                path.display(),
                first_path.display()
            ))
        })?;
        if let Some(other) = seen[p.index - 1].replace(path) {
            return Err(CliError::Usage(format!(
                "{} and {} are both partition {}/{count}",
                other.display(),
                path.display(),
                p.index
            )));
        }
        check_part_variants(path, part)?;
    }
    let missing: Vec<String> =
        seen.iter().enumerate().filter(|(_, s)| s.is_none()).map(|(i, _)| format!("{}/{count}", i + 1)).collect();
    if !missing.is_empty() {
        return Err(CliError::Usage(format!("partitions {} are missing", missing.join(", "))));
    }
    let mut part_of: std::collections::HashMap<&str, &Path> = std::collections::HashMap::new();
    for (path, part) in &read {
        for id in &part.scene_list.ids {
            if let Some(other) = part_of.insert(id, path) {
                return Err(CliError::Usage(format!(
                    "scenario `{id}` is in both {} and {}; the parts of one evaluation share no scene",
                    other.display(),
                    path.display()
                )));
            }
        }
    }
    let mut ids: Vec<String> = part_of.into_keys().map(String::from).collect();
    ids.sort();
    let digest = evaluation::scene_list_digest(&ids);
    if digest != first.scene_list.digest {
        return Err(CliError::Usage(format!(
            "the parts cover {} scenes, which are not the scene list they were split from",
            ids.len()
        )));
    }
    let settings = first.settings.clone();
    let records: Vec<VariantRecord> = read.into_iter().flat_map(|(_, p)| p.variants).collect();
    let mut records = records;
    evaluation::sort_records(&mut records);
    report(&settings, None, &SceneList { digest, ids }, &records, json)
}

/// The first setting in which `a` and `b` differ, as `field: A against B`.
fn settings_difference(a: &EvaluationSettings, b: &EvaluationSettings) -> Option<String> {
    let (serde_json::Value::Object(a), serde_json::Value::Object(b)) =
        (serde_json::to_value(a).ok()?, serde_json::to_value(b).ok()?)
    else {
        return None;
    };
    let mut fields: Vec<&String> = a.keys().chain(b.keys()).collect();
    fields.sort();
    fields.dedup();
    let shown = |v: Option<&serde_json::Value>| v.map_or("absent".to_string(), |v| v.to_string());
    fields
        .into_iter()
        .find(|f| a.get(*f) != b.get(*f))
        .map(|f| format!("{f}: {} against {}", shown(a.get(f)), shown(b.get(f))))
}

/// Checks that a part holds exactly one variant per scene, method,
/// stage-2 CBV mode and seed of its settings, and none of another scene.
fn check_part_variants(path: &Path, part: &PartReport) -> Result<(), CliError> {
    let s = &part.settings;
    let expected = part.scene_list.ids.len() * s.methods.len() * s.stage2_cbv.len() * s.seeds as usize;
    if let Some(stray) = part.variants.iter().find(|v| part.scene_list.ids.binary_search(&v.scenario).is_err()) {
        return Err(CliError::Usage(format!(
            "{}: variant of scenario `{}`, which is not among the part's scenes",
            path.display(),
            stray.scenario
        )));
    }
    let mut keys: Vec<_> = part.variants.iter().map(|v| (&v.scenario, v.method, v.stage2_cbv, v.seed)).collect();
    keys.sort();
    keys.dedup();
    if part.variants.len() != expected || keys.len() != expected {
        return Err(CliError::Usage(format!(
            "{}: holds {} variants ({} distinct), where {} scenes × {} methods × {} stage-2 CBV modes × {} seeds \
             make {expected}",
            path.display(),
            part.variants.len(),
            keys.len(),
            part.scene_list.ids.len(),
            s.methods.len(),
            s.stage2_cbv.len(),
            s.seeds
        )));
    }
    Ok(())
}

/// The arguments of `safer evaluate`.
#[derive(Debug, clap::Args)]
pub(crate) struct EvaluateArgs {
    /// Folder of recorded scenes (searched recursively); scenes need an ego and a CBV; `data:REL` is in $SAFER_DATA_DIR.
    #[arg(long, value_parser = data_path)]
    pub(crate) scenes: PathBuf,
    /// Methods to compare, one table row each.
    #[arg(long, value_parser = choice(AdversaryMethod::ALL), value_delimiter = ',', default_values = ["safer", "safer-in-path", "safer-cut-in", "safer-in-path-lookahead", "safer-distinct", "safer-lookahead", "safer-inattentive", "no-lfr", "no-trust-region", "no-mda", "prior", "log"])]
    pub(crate) methods: Vec<AdversaryMethod>,
    /// Seeds per scene and method, at least 1.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) seeds: u32,
    /// Base seed.
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    /// Reactive planner driving the ego in stage 2: a built-in (log-replay, constant-velocity, idm, evasive) or a planner spec file (`planners/NAME.yaml`).
    #[arg(long, default_value = "evasive", value_parser = planner_arg, value_name = "BUILTIN|SPEC.yaml")]
    pub(crate) planner: PlannerAdapter,
    /// Trust-region size n (top-n tokens of the prior), from 1 to the vocabulary size.
    #[arg(long, default_value_t = 20, value_parser = RangedU64ValueParser::<usize>::new().range(1..=VOCABULARY_SIZE as u64))]
    pub(crate) trust_region: usize,
    /// Who drives the background agents.
    #[arg(long, value_parser = choice(BackgroundDriver::ALL), default_value = "configured")]
    pub(crate) background: BackgroundDriver,
    /// The approach phase of the SaFeR methods: `seeded`, the prior drives the CBV for 1-4 tokens drawn from the variant's seed before the adversary engages, so that seeds differ; `none`, the adversary engages at the first token, as the paper describes its resampling (with the background on log replay every seed of a scene then gives the same variant).
    #[arg(long, value_parser = choice(ApproachPhase::ALL), default_value = "seeded")]
    pub(crate) approach_phase: ApproachPhase,
    /// What the feasibility constraint of the methods with V_h takes into account: `pair`, V_h of the ego–CBV pair alone (the paper's); `pair-in-traffic` (beyond the paper), near the ego a state V_h calls escapable counts only where one of a few held manoeuvres keeps the ego clear of the CBV, of the traffic around it and on the road for 2 s; `witnessed` (beyond the paper), a candidate that leads the CBV within 1.5 m of the ego (both held on at constant velocity for 2 s) is taken only where the feasibility witness finds the ego an escape from the CBV along it.
    #[arg(long, value_parser = choice(FeasibilityScope::ALL), default_value = "pair")]
    pub(crate) feasibility: FeasibilityScope,
    /// Which contacts with the ego the SaFeR methods' CBV may make: `any` (the paper's); `not-from-behind` (beyond the paper), none from behind the ego or with it standing still (the collisions nuPlan's rule never blames the ego for, which no planner can escape a chasing CBV from): a candidate after which the CBV, braking as hard as it can, would still run into the ego held on at its velocity from behind is infeasible, and one after which, braking at 3.4 m/s² to the ego's speed, it would ride the ego's bumper (under half a second's gap at speed) is taken only where no plausible token keeps off it.
    #[arg(long, value_parser = choice(EgoContactRule::ALL), default_value = "any")]
    pub(crate) ego_contact: EgoContactRule,
    /// Whether the SaFeR methods' CBV may drive against a lane's traffic: `allowed` (as the paper's method allows it); `forbidden` (beyond the paper), a token that turns the CBV into a lane against its traffic outside intersections (the ego's wrong-way rule, CARLA's WrongLaneTest), or after which braking would not keep it out of one, is implausible, as leaving the road is, and a CBV against the traffic already must end each token out of the oncoming lane or nearer a lane of its way; `along-the-lanes` (beyond the paper), as `forbidden`, and a token that takes the CBV across the lanes (at 3 m/s or more, more than 30° from every lane it is in, outside intersections) is implausible too, and a CBV across them already must end each token at a smaller angle to them or along them; `human-lane-changes` (beyond the paper), as `along-the-lanes`, and a token that moves the CBV sideways across its lanes faster than 1.7 m/s (the 90th percentile of recorded drivers' lane changes) is implausible too, and a CBV moving faster already must end each token slower sideways or within it.
    #[arg(long, value_parser = choice(WrongWayRule::ALL), default_value = "allowed")]
    pub(crate) wrong_way: WrongWayRule,
    /// How hard the SaFeR methods' CBV may turn, m/s² (beyond the paper): a token that pulls it more sideways at some step (its speed times its yaw rate) is implausible, as leaving the road is. Above 0 and at most 9, the default: the tyres' grip, the ego's own default limit. Lower holds the CBV to how people turn: the lateral acceleration table sets the CBV's peaks beside the recorded CBV's.
    #[arg(long, value_name = "M/S2", default_value_t = CbvTurningLimit::GRIP.max_lateral_accel_mps2(), value_parser = turning_limit)]
    pub(crate) max_lateral_accel: f64,
    /// What a m/s² of the SaFeR methods' CBV's lateral acceleration adds to a candidate token's loss, m (beyond the paper): the token's peak over its steps, measured as `--max-lateral-accel` measures it, so that a harder turn is taken only where it gets the CBV closer by more than it costs. 0 (the default, the paper's loss) to 5.
    #[arg(long, value_name = "M", default_value_t = 0.0, value_parser = turning_cost)]
    pub(crate) turning_cost: f64,
    /// The CBV in stage 2: replaying its stage-1 trajectory, or driven by the method again against the planner's ego (closed-loop), or so with the CBV seeing the planner's ego a driver's reaction time (1 s) late, carried on at the velocity it had, so that it does not follow an escape as it begins (closed-loop-delayed, beyond the paper); `replay,closed-loop` reports both side by side. The default here is `replay`, so that every method's stage 2 meets the same recorded CBV path and the methods compare on equal terms (the paper does not say whether its CBV reacts in stage 2); suites default to `closed-loop` (`adversary.stage2_cbv`), because a planner test should meet a CBV that answers the planner.
    #[arg(long, value_parser = choice(Stage2Cbv::ALL), value_delimiter = ',', default_values = ["replay"])]
    pub(crate) stage2_cbv: Vec<Stage2Cbv>,
    /// Horizon of both stages from the scene's current step, s (positive, finite).
    #[arg(long, default_value_t = 8.0, value_parser = positive_finite, allow_negative_numbers = true)]
    pub(crate) horizon_s: f64,
    /// Which ego–CBV pair each scene is tested with: `as-loaded`, the source's roles, else the labelled pair, else the pair of moving vehicles with the closest approach; `merging`, a CBV in a lane that merges with the ego's ahead of both (an on-ramp, a lane drop, two ways through a junction), of those reaching the merge point (at their speeds) between 1 s and the recording's end, the one arriving nearest in time to the ego; a mined ego is mined again with it; `leader`, the ego's leader: the nearest moving vehicle now ahead of it along its recorded path (within its width plus 0.4 m, heading its way, at most 60 m ahead of its front): the car it follows, or comes up behind in the lane it moves into; the ego as loaded; `crossing`, a car whose recorded path crosses the ego's at 45° or more (across its way at a junction, or turning across it), both passing the crossing point 1 s or more from now: the one with the least post-encroachment time (the time between the two passing it); a mined ego is mined again with it. Scenes without such a pair are left out.
    #[arg(long, value_parser = choice(RolePairing::ALL), default_value = "as-loaded")]
    pub(crate) roles: RolePairing,
    /// Evaluate only the first N scenes (by id), at least 1.
    #[arg(long, value_name = "N", value_parser = at_least_one())]
    pub(crate) max_scenes: Option<usize>,
    /// Evaluate only the scenes with these scenario ids (comma-separated, as the tables name them). Each variant is the one the whole set's evaluation makes: its seed comes from its scene's id, not the scene's place in the list. The held-out split is then drawn among these scenes.
    #[arg(long, value_name = "ID,...", value_delimiter = ',', conflicts_with = "max_scenes")]
    pub(crate) scene: Vec<String>,
    /// Also write every variant and the table as JSON (`-`: standard output).
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub(crate) json: Option<PathBuf>,
    /// Worker threads for the variants, 1 to 256 (default: one per core). Each may run a planner process: far more than the cores only thrashes.
    #[arg(short, long, value_name = "N", value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_JOBS as u64))]
    pub(crate) jobs: Option<usize>,
    /// How much of the witness's ego must stay on the road: its centre (the CBV's rule), or its whole width (no escape over the edge line).
    #[arg(long, value_parser = choice(RoadKeeping::ALL), default_value = "centre")]
    pub(crate) witness_road: RoadKeeping,
    /// The widest beam the witness search tries when narrower ones find nothing, as a multiple of the narrow one (48 candidates); 1 to 4096. Wider finds escapes narrower ones miss, at seconds to minutes a search where none exists.
    #[arg(long, value_name = "N", default_value_t = safer_scenarios::eval::witness::DEFAULT_WIDEST, value_parser = RangedU64ValueParser::<usize>::new().range(1..=safer_scenarios::eval::witness::MOST_WIDEST as u64))]
    pub(crate) witness_widest: usize,
    /// Run only part K of N (1 ≤ K ≤ N): scene i of the sorted scene list belongs to part i mod N + 1. Merge the parts' `--json` reports with `safer evaluate-merge`.
    #[arg(long, value_name = "K/N", value_parser = clap::value_parser!(Partition))]
    pub(crate) partition: Option<Partition>,
    /// Write each failing variant's MCAP recording, SVG picture and planner stderr under DIR/METHOD/SCENARIO/seed-K.* (as `safer run` does).
    #[arg(long, value_name = "DIR")]
    pub(crate) artifacts: Option<PathBuf>,
    /// Which variants `--artifacts` writes: the failing ones, or all (solved ones too, to see what the CBV did where nothing failed).
    #[arg(long, value_parser = choice(ArtefactVariants::ALL), default_value = "failing", requires = "artifacts")]
    pub(crate) artifacts_of: ArtefactVariants,
    /// Mutation testing: plant these faults in the planner (comma-separated; alone, or `all`: every operator) and count, per method, the variants the planner passes and each mutant fails (no at-fault collision, no leaving the road, an answer inside the vehicle limits at every step). The measure an adversary is judged by.
    #[arg(long, value_name = "OPS", num_args = 0..=1, default_missing_value = "all", value_parser = fault_operators)]
    pub(crate) mutants: Option<FaultOperators>,
}

/// Runs `safer evaluate`.
pub(crate) fn command(args: EvaluateArgs) -> Result<ExitCode, CliError> {
    let EvaluateArgs {
        scenes,
        methods,
        seeds,
        seed,
        planner,
        trust_region,
        background,
        approach_phase,
        feasibility,
        ego_contact,
        wrong_way,
        max_lateral_accel,
        turning_cost,
        stage2_cbv,
        horizon_s,
        roles,
        max_scenes,
        scene,
        json,
        jobs,
        witness_road,
        witness_widest,
        partition,
        artifacts,
        artifacts_of,
        mutants,
    } = args;
    let mut stage2_cbv = stage2_cbv;
    stage2_cbv.sort();
    stage2_cbv.dedup();
    let escape = safer_scenarios::eval::escape::EscapeBudget { keeping: witness_road, ..Default::default() };
    let request = EvaluationRequest {
        methods,
        seeds,
        base_seed: seed,
        planner,
        trust_region,
        approach: approach_phase,
        feasibility,
        ego_contact,
        wrong_way,
        turning: CbvTurningLimit::new(max_lateral_accel).unwrap_or_default(),
        turning_cost: CbvTurningCost::new(turning_cost).unwrap_or_default(),
        background,
        stage2_cbv,
        escape: Some(escape),
        horizon_s,
        artefacts: artifacts,
        artefacts_of: artifacts_of,
        mutants: mutants.map(|m| m.0).unwrap_or_default(),
    };
    let witness = WitnessSettings { road: witness_road, widest: witness_widest };
    set_jobs(jobs).and_then(|()| {
        run(&scenes, &request, SceneSelection { max_scenes, ids: &scene, roles }, json.as_deref(), witness, partition)
    })
}

/// The arguments of `safer evaluate-merge`.
#[derive(Debug, clap::Args)]
pub(crate) struct EvaluateMergeArgs {
    /// The partitions' reports, one per part, in any order.
    #[arg(required = true, value_name = "PART.json")]
    pub(crate) parts: Vec<PathBuf>,
    /// Also write the merged report as JSON (`-`: standard output).
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub(crate) json: Option<PathBuf>,
}

/// Runs `safer evaluate-merge`.
pub(crate) fn merge_command(args: EvaluateMergeArgs) -> Result<ExitCode, CliError> {
    let EvaluateMergeArgs { parts, json } = args;
    merge(&parts, json.as_deref())
}

#[cfg(test)]
mod tests {
    use super::*;
    use safer_scenarios::harness::evaluation::SceneCount;

    fn count(scenario: &str, variants: usize) -> SceneCount {
        SceneCount { scenario: scenario.into(), variants, of: 10 }
    }

    #[test]
    fn the_scene_list_names_the_first_three_stars_the_held_out_and_sums_the_rest() {
        let held_out = ["b".to_string(), "e".to_string()];
        let scenes = [count("a", 9), count("b", 7), count("c", 3), count("d", 2), count("e", 1)];
        assert_eq!(named_scenes(&scenes, &held_out), "a 9/10, b* 7/10, c 3/10, 3 in 2 more scenes");
        assert_eq!(named_scenes(&scenes[..4], &held_out), "a 9/10, b* 7/10, c 3/10, 2 in 1 more scene");
        assert_eq!(named_scenes(&scenes[..3], &[]), "a 9/10, b 7/10, c 3/10");
        assert_eq!(named_scenes(&[], &held_out), "");
    }

    /// The line for `safer` against a `log` row, both modes.
    fn beside(log: Option<usize>, closed: usize, replay: usize) -> Option<String> {
        let mut rows = vec![
            (AdversaryMethod::Safer, Stage2Cbv::ClosedLoop, closed),
            (AdversaryMethod::Safer, Stage2Cbv::Replay, replay),
        ];
        rows.extend(log.map(|l| (AdversaryMethod::Log, Stage2Cbv::Replay, l)));
        failures_beside_log(&rows)
    }

    #[test]
    fn failures_beside_log_replay_are_said_in_words_whatever_their_sign() {
        // More than log replay in both modes: a ratio.
        assert_eq!(
            beside(Some(2), 8, 5).unwrap(),
            "planner failures beside log replay's 2 failures: safer: closed loop 8 (6 more than log replay), \
             replay 5 (3 more than log replay); closed loop finds 2.00× as many beyond log replay's as replay"
        );
        // As many as log replay: no ratio of nothing.
        assert_eq!(
            beside(Some(1), 1, 1).unwrap(),
            "planner failures beside log replay's 1 failure: safer: closed loop 1 (as many as log replay), \
             replay 1 (as many as log replay); neither finds failures beyond log replay's"
        );
        // Fewer than log replay (the line that once read `-5 / -2 = —`).
        assert_eq!(
            beside(Some(6), 1, 4).unwrap(),
            "planner failures beside log replay's 6 failures: safer: closed loop 1 (5 fewer than log replay), \
             replay 4 (2 fewer than log replay); neither finds failures beyond log replay's"
        );
        let mixed = beside(Some(3), 5, 1).unwrap();
        assert!(
            mixed.contains(
                "closed loop 5 (2 more than log replay), replay 1 (2 fewer than log replay); only closed loop finds"
            ),
            "{mixed}"
        );
        let mixed = beside(Some(3), 0, 4).unwrap();
        assert!(mixed.ends_with("only replay finds failures beyond log replay's"), "{mixed}");
        // No log row: said, not left out.
        assert_eq!(
            beside(None, 3, 2).unwrap(),
            "planner failures beside log replay's: not measured (no `log` row to compare with: add `log` to --methods)"
        );
        // One mode only: nothing to compare.
        assert_eq!(
            failures_beside_log(&[
                (AdversaryMethod::Safer, Stage2Cbv::Replay, 4),
                (AdversaryMethod::Log, Stage2Cbv::Replay, 2)
            ]),
            None
        );
        assert!(!beside(Some(6), 1, 4).unwrap().contains('-'), "no negative numbers");
    }
}
