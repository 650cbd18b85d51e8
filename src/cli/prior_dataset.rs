//! `safer prior-dataset`: writes the realism prior's training shards from
//! recorded scenes whose licence allows training shipped models (NGSIM) and
//! from calibrated synthetic traffic ([`safer::datasets::prior_shards`]),
//! and prints the calibration (recorded vs synthetic speeds and
//! accelerations, with their Jensen–Shannon divergence) so it can be judged.

use std::path::PathBuf;
use std::process::ExitCode;

use super::{CliError, scene_paths};
use safer::datasets::prior_shards::{Calibration, SyntheticPlan, shard_scenes, synthetic_scenes, write_shards};
use safer::datasets::{DatasetError, load_training_scenes};
use safer::motion::tokens::TOKEN_PERIOD_STEPS;
use safer::sim::synthetic::SpeedSample;

/// What to generate.
#[derive(Debug, Clone)]
pub struct DatasetRequest {
    /// Recorded scenes (only those whose licence allows training are accepted).
    pub recorded: PathBuf,
    /// Output folder for the shards.
    pub out: PathBuf,
    /// Synthetic scenes on procedural templates.
    pub template_scenes: usize,
    /// Synthetic scenes on the recorded maps.
    pub recorded_map_scenes: usize,
    /// Base seed.
    pub seed: u64,
    /// Samples per shard (at least 1).
    pub shard_size: usize,
    /// Replace shards already in `out`.
    pub force: bool,
}

/// The dataset commands report a [`DatasetError`] through the variant that
/// carries its source (a licence or shard-metadata problem reads as a usage error).
impl From<DatasetError> for CliError {
    fn from(e: DatasetError) -> Self {
        match e {
            DatasetError::Import(e) => Self::Import(e),
            DatasetError::Model(e) => Self::Model(e),
            e @ (DatasetError::Licence { .. } | DatasetError::Metadata { .. }) => Self::Usage(e.to_string()),
        }
    }
}

/// Runs the command.
pub fn run(request: &DatasetRequest) -> Result<ExitCode, CliError> {
    std::fs::create_dir_all(&request.out)?;
    let existing: Vec<PathBuf> = std::fs::read_dir(&request.out)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "safetensors"))
        .collect();
    if !existing.is_empty() && !request.force {
        return Err(CliError::Usage(format!(
            "{} already holds {} shard(s); pass --force to replace them",
            request.out.display(),
            existing.len()
        )));
    }
    for p in existing {
        std::fs::remove_file(p)?;
    }

    let recorded = load_training_scenes(&scene_paths(&request.recorded)?)?;
    eprintln!("recorded scenes: {}", recorded.len());
    let plan = SyntheticPlan {
        template_scenes: request.template_scenes,
        recorded_map_scenes: request.recorded_map_scenes,
        seed: request.seed,
    };
    let (synthetic, calibration) = synthetic_scenes(&recorded, plan);
    print_calibration(&calibration);

    // Samples, written shard by shard in a fixed order (recorded, then synthetic).
    let scenes = shard_scenes(&recorded, &synthetic);
    let totals = write_shards(&scenes, &request.out, request.shard_size, |path, samples| {
        eprintln!("wrote {} ({samples} samples)", path.display());
    })?;
    println!(
        "samples: {} train, {} held out, in {} shard(s) under {} ({} recorded + {} synthetic scenes; token period {} steps)",
        totals.train_samples,
        totals.held_out_samples,
        totals.shards.len(),
        request.out.display(),
        recorded.len(),
        synthetic.len(),
        TOKEN_PERIOD_STEPS
    );
    Ok(ExitCode::SUCCESS)
}

fn print_calibration(calibration: &Calibration) {
    println!("calibration (moving vehicles, 0.5 s token periods):");
    println!("  {:<22} {:>10} {:>10} {:>10} {:>12}", "source", "samples", "speed p50", "speed p90", "accel std");
    for (name, k) in [("recorded (NGSIM)", &calibration.recorded), ("synthetic", &calibration.synthetic)] {
        let q = SpeedSample::new(k.speeds_mps.clone());
        let accel_std = k.accel_std_mps2().map_or("n/a".to_string(), |s| format!("{s:.2}"));
        println!(
            "  {:<22} {:>10} {:>8.1} m/s {:>6.1} m/s {:>8} m/s²",
            name,
            k.len(),
            q.quantile(0.5),
            q.quantile(0.9),
            accel_std
        );
    }
    let show = |j: Option<f64>| j.map_or("n/a".to_string(), |j| format!("{j:.3}"));
    println!(
        "  JSD synthetic vs recorded: speed {} (35 bins of 1 m/s), accel {} (20 bins of 0.5 m/s²)",
        show(calibration.speed_jsd),
        show(calibration.accel_jsd)
    );
}
