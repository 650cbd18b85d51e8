//! `safer trust-region`: what the realism prior's trust region offers the
//! adversary over a folder of scenes (see `harness::trust_region`): per
//! method (each runs its own prior: `no-mda` the plain-attention one, and
//! `$SAFER_MODELS` swaps in another set), the mean probability mass of the
//! top n tokens, their acceleration and yaw-rate range and bins, the share
//! of boundaries with no steering choice at all, the distinct behaviours
//! and the plausible share; the held-out tenth of the scenes beside the
//! rest; optionally every boundary as JSON.

use super::*;
use std::io::Write;
use std::path::Path;
use std::process::ExitCode;

use super::evaluate::load_scenes;
use super::{CliError, figure};
use safer_scenarios::harness::evaluation::{EvaluationRequest, held_out_scenes};
use safer_scenarios::harness::methods::ModelSet;
use safer_scenarios::harness::trust_region::{BoundaryProfile, TrustRegionSummary, profile_scenes, summarise};
use safer_scenarios::policies::adversary::ApproachPhase;

fn print(out: &mut dyn Write, title: &str, rows: &[TrustRegionSummary]) -> std::io::Result<()> {
    writeln!(out, "{title}")?;
    writeln!(
        out,
        "{:<18} {:>10} {:>6} {:>10} {:>7} {:>11} {:>6} {:>9} {:>10} {:>9} {:>9} {:>6} {:>8}",
        "method",
        "boundaries",
        "mass",
        "accel m/s²",
        "a-bins",
        "yaw rad/s",
        "y-bins",
        "no-steer",
        "behaviours",
        "plausible",
        "none-pl.",
        "rank",
        "outside"
    )?;
    for r in rows {
        writeln!(
            out,
            "{:<18} {:>10} {:>6} {:>10} {:>7} {:>11} {:>6} {:>9} {:>10} {:>9} {:>9} {:>6} {:>8}",
            safer_scenarios::spec::spec_name(&r.method),
            r.boundaries,
            figure(r.probability_mass, 3),
            figure(r.accel_range_mps2, 2),
            figure(r.accel_bins, 1),
            figure(r.yaw_rate_range_radps, 3),
            figure(r.yaw_rate_bins, 1),
            figure(r.no_steering_share, 3),
            figure(r.behaviours, 1),
            figure(r.plausible_share, 3),
            figure(r.none_plausible_share, 3),
            figure(r.driven_rank, 1),
            figure(r.outside_share, 3)
        )?;
    }
    Ok(())
}

#[derive(serde::Serialize)]
struct Report<'a> {
    scenes: usize,
    trust_region: usize,
    approach: ApproachPhase,
    summary: &'a [TrustRegionSummary],
    held_out: &'a [TrustRegionSummary],
    rest: &'a [TrustRegionSummary],
    boundaries: &'a [BoundaryProfile],
}

/// Runs the command.
pub(super) fn run(
    scenes_dir: &Path,
    request: &EvaluationRequest,
    max_scenes: Option<usize>,
    json: Option<&Path>,
) -> Result<ExitCode, CliError> {
    if let Some(path) = json {
        let inputs = super::scene_paths(scenes_dir)?;
        safer_scenarios::record::check_outputs_apart(
            &[safer_scenarios::record::NamedOutput { flag: "--json", path }],
            &inputs,
        )?;
        super::check_json_report(path)?;
    }
    let scenes = load_scenes(scenes_dir, max_scenes)?;
    if scenes.is_empty() {
        return Err(CliError::Usage(format!("{}: no scene with both an ego and a CBV", scenes_dir.display())));
    }
    let total = scenes.len() * request.methods.len() * request.seeds as usize;
    let progress = super::progress::Progress::new("trust-region", "variants", total);
    let (profiles, errors) = profile_scenes(&scenes, request, &ModelSet::shipped(), &|| progress.tick());
    drop(progress);
    for (variant, error) in errors.iter().take(5) {
        eprintln!("error: {variant}: {error}");
    }
    let held = held_out_scenes(scenes.iter().map(|s| s.id.as_str()));
    let (held_out, rest): (Vec<BoundaryProfile>, Vec<BoundaryProfile>) =
        profiles.iter().cloned().partition(|b| held.contains(b.scenario.as_str()));
    let summary = summarise(&profiles, &request.methods);
    let held_out = summarise(&held_out, &request.methods);
    let rest = summarise(&rest, &request.methods);
    let report = Report {
        scenes: scenes.len(),
        trust_region: request.trust_region,
        approach: request.approach,
        summary: &summary,
        held_out: &held_out,
        rest: &rest,
        boundaries: &profiles,
    };
    super::write_report_and_table(json, &report, |out| {
        writeln!(
            out,
            "{} scenes × {} seeds; trust region n = {}; the CBV's token boundaries {}, stage 1",
            scenes.len(),
            request.seeds,
            request.trust_region,
            match request.approach {
                ApproachPhase::Seeded => "after the approach phase",
                ApproachPhase::None => "from the first (no approach phase)",
            }
        )?;
        print(out, "all scenes:", &summary)?;
        print(out, &format!("held out (every tenth scene by id: {} of {}):", held.len(), scenes.len()), &held_out)?;
        print(out, "the other scenes:", &rest)?;
        writeln!(
            out,
            "mass: the prior's probability of the top-n tokens together; accel/yaw: the range of the tokens' bin centres (longitudinal and lateral choice) and the distinct bins; no-steer: share of boundaries with one yaw-rate bin; behaviours: groups of the tokens' end positions after 2 s held, more than 1 m apart; plausible: share of the tokens the plausibility rule allows; none-pl.: share of boundaries where it allows none; rank: mean rank in the region of the token the adversary drove (0: the likeliest); outside: share of boundaries where it drove one from outside the region (the plausibility fallback)."
        )?;
        Ok(())
    })?;
    Ok(if errors.is_empty() { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

/// The arguments of `safer trust-region`.
#[derive(Debug, clap::Args)]
pub(crate) struct TrustRegionArgs {
    /// Folder of recorded scenes (searched recursively); scenes need an ego and a CBV; `data:REL` is in $SAFER_DATA_DIR.
    #[arg(long, value_parser = data_path)]
    pub(crate) scenes: PathBuf,
    /// Methods whose stage 1 is profiled, one row each (`no-mda` runs the plain-attention prior; `$SAFER_MODELS` swaps in another model set).
    #[arg(long, value_parser = choice(AdversaryMethod::ALL), value_delimiter = ',', default_values = ["safer", "safer-distinct", "safer-in-path", "no-mda"])]
    pub(crate) methods: Vec<AdversaryMethod>,
    /// Seeds per scene and method, at least 1.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) seeds: u32,
    /// Base seed.
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    /// Trust-region size n (top-n tokens of the prior), from 1 to the vocabulary size.
    #[arg(long, default_value_t = 20, value_parser = RangedU64ValueParser::<usize>::new().range(1..=VOCABULARY_SIZE as u64))]
    pub(crate) trust_region: usize,
    /// The approach phase of the SaFeR methods, as in `safer evaluate`: `seeded` (1-4 tokens of the prior, drawn from the seed, before the adversary engages) or `none` (the adversary from the first token).
    #[arg(long, value_parser = choice(ApproachPhase::ALL), default_value = "seeded")]
    pub(crate) approach_phase: ApproachPhase,
    /// Horizon of stage 1 from the scene's current step, s (positive, finite).
    #[arg(long, default_value_t = 8.0, value_parser = positive_finite, allow_negative_numbers = true)]
    pub(crate) horizon_s: f64,
    /// Profile only the first N scenes (by id), at least 1.
    #[arg(long, value_name = "N", value_parser = at_least_one())]
    pub(crate) max_scenes: Option<usize>,
    /// Also write the summaries and every boundary's profile as JSON (`-`: standard output).
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub(crate) json: Option<PathBuf>,
    /// Worker threads, 1 to 256 (default: one per core).
    #[arg(short, long, value_name = "N", value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_JOBS as u64))]
    pub(crate) jobs: Option<usize>,
}

/// Runs `safer trust-region`.
pub(crate) fn command(args: TrustRegionArgs) -> Result<ExitCode, CliError> {
    let TrustRegionArgs {
        scenes,
        methods,
        seeds,
        seed,
        trust_region,
        approach_phase,
        horizon_s,
        max_scenes,
        json,
        jobs,
    } = args;
    let request = EvaluationRequest {
        methods,
        seeds,
        base_seed: seed,
        // Stage 2 is not run.
        planner: PlannerAdapter::builtin(BuiltinPlanner::LogReplay),
        trust_region,
        approach: approach_phase,
        // The region is the same whatever the constraint takes into account.
        feasibility: Default::default(),
        ego_contact: Default::default(),
        wrong_way: Default::default(),
        turning: Default::default(),
        turning_cost: Default::default(),
        background: BackgroundDriver::Configured,
        stage2_cbv: vec![Stage2Cbv::Replay],
        escape: None,
        horizon_s,
        artefacts: None,
        artefacts_of: ArtefactVariants::Failing,
        mutants: Vec::new(),
    };
    set_jobs(jobs).and_then(|()| run(&scenes, &request, max_scenes, json.as_deref()))
}
