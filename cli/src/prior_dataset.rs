//! `safer prior-dataset`: writes the realism prior's training shards from
//! recorded scenes whose licence allows training shipped models (NGSIM) and
//! from calibrated synthetic traffic ([`safer_scenarios::datasets::prior_shards`]),
//! and prints the calibration (recorded vs synthetic speeds and
//! accelerations, with their Jensen–Shannon divergence) so it can be judged.

use super::*;
use std::path::PathBuf;
use std::process::ExitCode;

use super::{CliError, scene_paths};
use safer_scenarios::datasets::prior_shards::{
    Calibration, ShardOptions, SyntheticPlan, shard_scenes, synthetic_scenes, write_shards,
};
use safer_scenarios::datasets::{DatasetError, TrainingPurpose, load_scenes_for};
use safer_scenarios::models::prior_dataset::TokenDrift;
use safer_scenarios::motion::tokens::TOKEN_PERIOD_STEPS;
use safer_scenarios::sim::synthetic::SpeedSample;

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
    /// Whether synthetic drivers turn, change lanes and accept gaps.
    pub driver_choices: bool,
    /// Share of the template crossings built as T-junctions.
    pub t_junction_share: f64,
    /// Share of the two-lane template crossings whose kerb lanes turn right only.
    pub right_turn_lane_share: f64,
    /// Share of synthetic scenes with pedestrians crossing the road.
    pub pedestrian_share: f64,
    /// Chance of a perturbed token per period in training scenes (0: no drift).
    pub token_drift: f64,
    /// Largest perturbation, bins per axis.
    pub token_drift_bins: usize,
    /// Largest yaw-rate perturbation where it differs from `token_drift_bins`.
    pub token_drift_yaw_rate_bins: Option<usize>,
    /// Accept any licence, for a model that is never shipped.
    pub evaluation_only: bool,
    /// Replace shards already in `out`.
    pub force: bool,
}

impl DatasetRequest {
    /// The `safer prior-dataset` arguments that decide what the shards hold
    /// (all but `--out` and `--force`), every one written out, so that a
    /// model card can name the command that remakes its data. A recorded
    /// folder inside $SAFER_DATA_DIR is written `data:REL`.
    pub fn data_arguments(&self) -> String {
        let data_root = safer_scenarios::spec::paths::resolve(safer_scenarios::spec::paths::shipped_dir(), "data:");
        let recorded = self
            .recorded
            .strip_prefix(&data_root)
            .map_or_else(|_| self.recorded.display().to_string(), |rel| format!("data:{}", rel.display()));
        let mut args = format!(
            "--recorded {recorded} --template-scenes {} --recorded-map-scenes {} --seed {} --shard-size {} \
             --t-junction-share {} --right-turn-lane-share {} --pedestrian-share {} --token-drift {} \
             --token-drift-bins {}",
            self.template_scenes,
            self.recorded_map_scenes,
            self.seed,
            self.shard_size,
            self.t_junction_share,
            self.right_turn_lane_share,
            self.pedestrian_share,
            self.token_drift,
            self.token_drift_bins
        );
        if let Some(bins) = self.token_drift_yaw_rate_bins {
            args.push_str(&format!(" --token-drift-yaw-rate-bins {bins}"));
        }
        if !self.driver_choices {
            args.push_str(" --no-driver-choices");
        }
        if self.evaluation_only {
            args.push_str(" --evaluation-only");
        }
        args
    }
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

/// Refuses a `flag` value (`what`: a share, a probability) outside [0, 1].
fn in_unit_interval(flag: &str, what: &str, value: f64) -> Result<(), CliError> {
    if (0.0..=1.0).contains(&value) {
        Ok(())
    } else {
        Err(CliError::Usage(format!("{flag} must be {what} in [0, 1], got {value}")))
    }
}

/// Runs the command.
pub fn run(request: &DatasetRequest) -> Result<ExitCode, CliError> {
    in_unit_interval("--t-junction-share", "a share", request.t_junction_share)?;
    in_unit_interval("--right-turn-lane-share", "a share", request.right_turn_lane_share)?;
    in_unit_interval("--pedestrian-share", "a share", request.pedestrian_share)?;
    in_unit_interval("--token-drift", "a probability", request.token_drift)?;
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

    let purpose = if request.evaluation_only { TrainingPurpose::EvaluationOnly } else { TrainingPurpose::Shipped };
    let recorded = load_scenes_for(&scene_paths(&request.recorded)?, purpose)?;
    eprintln!("recorded scenes: {}", recorded.len());
    let plan = SyntheticPlan {
        template_scenes: request.template_scenes,
        recorded_map_scenes: request.recorded_map_scenes,
        seed: request.seed,
        driver_choices: request.driver_choices,
        t_junction_share: request.t_junction_share,
        right_turn_lane_share: request.right_turn_lane_share,
        pedestrian_share: request.pedestrian_share,
    };
    let (synthetic, calibration) = synthetic_scenes(&recorded, plan);
    print_calibration(&calibration);

    // Samples, written shard by shard in a fixed order (recorded, then synthetic).
    let scenes = shard_scenes(&recorded, &synthetic);
    let drift = (request.token_drift > 0.0 && request.token_drift_bins > 0).then_some(TokenDrift {
        probability: request.token_drift,
        max_bins: request.token_drift_bins,
        max_yaw_rate_bins: request.token_drift_yaw_rate_bins,
        seed: request.seed,
    });
    let drivers = if request.driver_choices {
        "synthetic drivers turn at junctions, change lanes and accept or refuse gaps (a third of template crossings unsignalised)"
    } else {
        "synthetic drivers keep their lane and go straight"
    };
    let t_junctions = if request.t_junction_share > 0.0 {
        format!("; {} of template crossings T-junctions", request.t_junction_share)
    } else {
        String::new()
    };
    let right_turn_lanes = if request.right_turn_lane_share > 0.0 {
        format!("; kerb lanes turn right only at {} of two-lane template crossings", request.right_turn_lane_share)
    } else {
        String::new()
    };
    let pedestrians = if request.pedestrian_share > 0.0 {
        format!(
            "; pedestrians cross the road in {} of synthetic scenes, and drivers yield to them",
            request.pedestrian_share
        )
    } else {
        String::new()
    };
    let drift_text = drift.map_or("no token drift".to_string(), |d| {
        let yaw_rate = match d.max_yaw_rate_bins {
            Some(yaw) if yaw != d.max_bins => format!(" of acceleration and ±{yaw} of yaw rate"),
            _ => String::new(),
        };
        format!(
            "token drift on training scenes: p = {} per period, up to ±{} bins{yaw_rate}",
            d.probability, d.max_bins
        )
    });
    let recipe = format!(
        "{} recorded + {} template + {} recorded-map synthetic scenes (seed {}); {drivers}{t_junctions}{right_turn_lanes}{pedestrians}; {drift_text}",
        recorded.len(),
        request.template_scenes,
        request.recorded_map_scenes,
        request.seed
    );
    let options =
        ShardOptions { shard_size: request.shard_size, drift, purpose, recipe, arguments: request.data_arguments() };
    // Only now, with every input read and accepted: a typo or a refused
    // licence must not cost the shards that `--force` was to replace.
    for p in existing {
        std::fs::remove_file(p)?;
    }
    let totals = write_shards(&scenes, &request.out, &options, |path, samples| {
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
    println!(
        "  {:<22} {:>10} {:>10} {:>10} {:>12} {:>14}",
        "source", "samples", "speed p50", "speed p90", "accel std", "steering ≥0.1"
    );
    for (name, k) in [("recorded", &calibration.recorded), ("synthetic", &calibration.synthetic)] {
        let q = SpeedSample::new(k.speeds_mps.clone());
        let accel_std = k.accel_std_mps2().map_or("n/a".to_string(), |s| format!("{s:.2}"));
        let steering = k.steering_share(0.1).map_or("n/a".to_string(), |s| format!("{s:.3}"));
        println!(
            "  {:<22} {:>10} {:>8.1} m/s {:>6.1} m/s {:>8} m/s² {:>14}",
            name,
            k.len(),
            q.quantile(0.5),
            q.quantile(0.9),
            accel_std,
            steering
        );
    }
    let show = |j: Option<f64>| j.map_or("n/a".to_string(), |j| format!("{j:.3}"));
    println!(
        "  JSD synthetic vs recorded: speed {} (35 bins of 1 m/s), accel {} (20 bins of 0.5 m/s²), yaw rate {} (24 bins of 0.05 rad/s)",
        show(calibration.speed_jsd),
        show(calibration.accel_jsd),
        show(calibration.yaw_rate_jsd)
    );
    println!("  (steering ≥0.1: share of token periods with a yaw rate of at least 0.1 rad/s either way)");
}

/// The arguments of `safer prior-dataset`.
#[derive(Debug, clap::Args)]
pub(crate) struct PriorDatasetArgs {
    /// Recorded scenes whose licence allows training the shipped models (NGSIM); `data:REL` is in $SAFER_DATA_DIR.
    #[arg(long, default_value = "data:commonroad-ngsim", value_parser = data_path)]
    pub(crate) recorded: PathBuf,
    /// Output folder for the shards.
    #[arg(long, default_value = "training/data/prior")]
    pub(crate) out: PathBuf,
    /// Synthetic scenes on procedural templates (straight roads, merges, crossings).
    #[arg(long, default_value_t = 1200)]
    pub(crate) template_scenes: usize,
    /// Synthetic scenes on the recorded maps.
    #[arg(long, default_value_t = 400)]
    pub(crate) recorded_map_scenes: usize,
    /// Base seed of the synthetic traffic.
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    /// Samples per shard, at least 1.
    #[arg(long, default_value_t = 50_000, value_parser = at_least_one())]
    pub(crate) shard_size: usize,
    /// Synthetic drivers keep their lane and go straight at junctions
    /// (the first shipped prior's data) instead of turning, changing
    /// lanes and accepting gaps.
    #[arg(long)]
    pub(crate) no_driver_choices: bool,
    /// Share of the template crossings built as T-junctions (one arm
    /// left out, so traffic arriving opposite it must turn); 0 draws
    /// the shipped priors' data.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) t_junction_share: f64,
    /// Share of the template crossings with two lanes per direction
    /// whose kerb lanes turn right only (dedicated right-turn lanes, so
    /// traffic in them must turn); 0 draws the shipped priors' data.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) right_turn_lane_share: f64,
    /// Share of synthetic scenes with pedestrians walking across the
    /// road (on crosswalks, and mid-block on streets of at most 17 m/s),
    /// whom the drivers yield to; 0 draws the shipped priors' data.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) pedestrian_share: f64,
    /// Chance that a training scene's token reconstruction applies a
    /// perturbed token in a period (0 turns the drift off); held-out
    /// scenes never drift.
    #[arg(long, default_value_t = 0.3)]
    pub(crate) token_drift: f64,
    /// Largest token perturbation, in bins per axis.
    #[arg(long, default_value_t = 3)]
    pub(crate) token_drift_bins: usize,
    /// Largest perturbation of the yaw rate, in bins, where it should
    /// differ from `--token-drift-bins` (which then bounds the
    /// acceleration alone); 0 keeps the drift longitudinal.
    #[arg(long, value_name = "BINS")]
    pub(crate) token_drift_yaw_rate_bins: Option<usize>,
    /// Accept recorded scenes under any licence (Waymo, Argoverse) for
    /// a model that is measured and never shipped: the shards say so and
    /// `training/prior/export.py` refuses to write it into `models/`.
    #[arg(long)]
    pub(crate) evaluation_only: bool,
    /// Replace shards already in the output folder.
    #[arg(long)]
    pub(crate) force: bool,
}

/// Runs `safer prior-dataset`.
pub(crate) fn command(args: PriorDatasetArgs) -> Result<ExitCode, CliError> {
    let PriorDatasetArgs {
        recorded,
        out,
        template_scenes,
        recorded_map_scenes,
        seed,
        shard_size,
        no_driver_choices,
        t_junction_share,
        right_turn_lane_share,
        pedestrian_share,
        token_drift,
        token_drift_bins,
        token_drift_yaw_rate_bins,
        evaluation_only,
        force,
    } = args;
    run(&DatasetRequest {
        recorded,
        out,
        template_scenes,
        recorded_map_scenes,
        seed,
        shard_size,
        driver_choices: !no_driver_choices,
        t_junction_share,
        right_turn_lane_share,
        pedestrian_share,
        token_drift,
        token_drift_bins,
        token_drift_yaw_rate_bins,
        evaluation_only,
        force,
    })
}
