//! `safer feasibility-dataset`: collects the transitions (s, a, h(s), s',
//! done) V_h is trained on ([`safer_scenarios::datasets::feasibility_transitions`])
//! and prints their coverage (violations, near states, per CBV policy).

use super::*;
use std::path::PathBuf;
use std::process::ExitCode;

use super::{CliError, scene_paths};
use safer_scenarios::datasets::feasibility_transitions::Collection;
use safer_scenarios::datasets::load_training_scenes;
use safer_scenarios::harness::methods::{MapEncodings, ModelSet};

/// Settings of the command.
#[derive(Debug, Clone)]
pub struct FeasibilityDatasetRequest {
    /// Recorded scenes (licence must allow training).
    pub recorded: PathBuf,
    /// Output folder.
    pub out: PathBuf,
    /// Synthetic scenes.
    pub synthetic_scenes: usize,
    /// Base seed.
    pub seed: u64,
    /// Replace an existing dataset.
    pub force: bool,
}

/// The collection the request describes (shared with `feasibility-eval`).
pub(super) fn collection(request: &FeasibilityDatasetRequest, models: &ModelSet) -> Result<Collection, CliError> {
    let recorded = load_training_scenes(&scene_paths(&request.recorded)?)?;
    Ok(Collection::new(recorded, request.synthetic_scenes, request.seed, models.prior.is_ok()))
}

/// Runs the command.
pub fn run(request: &FeasibilityDatasetRequest) -> Result<ExitCode, CliError> {
    let out_file = request.out.join("transitions.safetensors");
    if out_file.exists() && !request.force {
        return Err(CliError::Usage(format!("{} exists; pass --force to replace it", out_file.display())));
    }
    std::fs::create_dir_all(&request.out)?;
    let models = ModelSet::shipped();
    let collection = collection(request, &models)?;
    eprintln!(
        "{} scenes, {} episodes (CBV policies: {:?})",
        collection.scenes.len(),
        collection.episodes.len(),
        collection.cbv_policies
    );
    let collected = collection.collect(request.seed, &models, &MapEncodings::default());
    let all = &collected.transitions;
    println!("transitions: {} from {} scenes", all.len(), collection.scenes.len());
    println!(
        "coverage: {} with h = M (box distance <= 0.3 m), {} within 2 m, {} within 5 m",
        all.violating(),
        all.within(2.0),
        all.within(5.0)
    );
    println!(
        "witness branches: {} ({} transitions, escapes from states with the CBV within {} m)",
        collected.witness_branches,
        collected.witness_branch_transitions,
        safer_scenarios::datasets::feasibility_transitions::BRANCH_MAX_DISTANCE_M
    );
    let mut per_cbv: Vec<(String, usize, usize)> =
        collected.per_cbv.iter().map(|(c, k)| (format!("{c:?}"), k.transitions, k.violating)).collect();
    per_cbv.sort();
    for (k, t, v) in per_cbv {
        println!("  CBV {k:<22} {t:>8} transitions {v:>7} violating");
    }
    collection.write(all, &out_file)?;
    println!("wrote {}", out_file.display());
    Ok(ExitCode::SUCCESS)
}

/// The arguments of `safer feasibility-dataset`.
#[derive(Debug, clap::Args)]
pub(crate) struct FeasibilityDatasetArgs {
    /// Recorded scenes whose licence allows training the shipped models (NGSIM); `data:REL` is in $SAFER_DATA_DIR.
    #[arg(long, default_value = "data:commonroad-ngsim", value_parser = data_path)]
    pub(crate) recorded: PathBuf,
    /// Output folder.
    #[arg(long, default_value = "training/data/feasibility")]
    pub(crate) out: PathBuf,
    /// Synthetic scenes.
    #[arg(long, default_value_t = 300)]
    pub(crate) synthetic_scenes: usize,
    /// Base seed.
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    /// Replace an existing dataset.
    #[arg(long)]
    pub(crate) force: bool,
}

/// Runs `safer feasibility-dataset`.
pub(crate) fn command(args: FeasibilityDatasetArgs) -> Result<ExitCode, CliError> {
    let FeasibilityDatasetArgs { recorded, out, synthetic_scenes, seed, force } = args;
    run(&FeasibilityDatasetRequest { recorded, out, synthetic_scenes, seed, force })
}
