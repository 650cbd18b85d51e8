//! The `safer` command line: argument parsing and the commands, each in its
//! own module. Commands print human-readable tables by default and JSON
//! with `--json`; errors go to stderr with the file and place at fault.
//!
//! Arguments are checked by clap before a command starts: counts that must
//! be at least one, the trust region within the token vocabulary, durations
//! positive and finite; a bad number is refused naming the flag and the
//! accepted range, never clamped. Paths written `data:REL` name `REL` in the
//! recorded-data folder `$SAFER_DATA_DIR`, and `safer:REL` a file safer
//! ships, by the rule specs use ([`spec::paths`]); the data defaults are
//! written that way. Every output path goes through
//! [`record::write_output`] (`-` is standard output, symlinks followed,
//! devices written in place, folders refused).
//!
//! [`spec::paths`]: safer_scenarios::spec::paths
//! [`record::write_output`]: safer_scenarios::record::write_output

mod bench;
mod bench_baseline;
mod bench_models;
mod choice;
mod evaluate;
mod feasibility_dataset;
mod feasibility_eval;
mod inspect;
mod prior_dataset;
mod prior_fit;
mod progress;
mod realism;
mod render;
mod run;
mod schema;
mod simulate;
mod token_roundtrip;
mod trust_region;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use choice::choice;
use clap::builder::{RangedU64ValueParser, TypedValueParser};
use clap::{Parser, Subcommand};

use safer_scenarios::eval::witness::RoadKeeping;
use safer_scenarios::harness::HarnessError;
use safer_scenarios::harness::evaluation::ArtefactVariants;
use safer_scenarios::harness::evaluation::{EvaluationRequest, Partition, Stage2Cbv};
use safer_scenarios::harness::methods::BackgroundDriver;
use safer_scenarios::models::ModelError;
use safer_scenarios::motion::tokens::VOCABULARY_SIZE;
use safer_scenarios::planners::BuiltinPlanner;
use safer_scenarios::policies::BackgroundPolicy;
use safer_scenarios::policies::adversary::ApproachPhase;
use safer_scenarios::record::RecordError;
use safer_scenarios::scenario::import::ImportError;
use safer_scenarios::sim::SimError;
use safer_scenarios::spec::planner::PlannerAdapter;
use safer_scenarios::spec::suite::AdversaryMethod;
use safer_scenarios::spec::{SpecError, SpecKind};

/// How `data:` paths and output paths are read, for `safer --help`.
const PATHS_HELP: &str = "Paths: `data:REL` names REL in the recorded-data folder $SAFER_DATA_DIR, and `safer:REL` \
a file safer ships (scenes/, specs/, planners/), as in specs. An output path of `-` is \
standard output; a symlink is followed (the file it names is replaced atomically, the link stays); a FIFO or \
character device is written in place; a folder is refused.";

/// Scenario tests for autonomous-driving planners: safety-critical,
/// realistic and avoidable conflicts (SaFeR).
#[derive(Debug, Parser)]
#[command(name = "safer", version, about, after_help = PATHS_HELP)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

// Parsed once per process: a variant's size costs nothing, and boxing
// the evaluation's options would only complicate clap's derive.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
enum Command {
    /// Run scenario suites: the same variants, metrics and verdicts as a planner crate's `cargo test`.
    Run {
        /// Suite spec files (`specs/suites/*.yaml`).
        #[arg(required = true)]
        suites: Vec<PathBuf>,
        /// Also write a JSON report to this file (`-`: standard output, the table then goes to stderr).
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
        /// Also write a JUnit XML report to this file (`-`: standard output, the table then goes to stderr): one testcase per variant and per suite metric.
        #[arg(long, value_name = "FILE")]
        junit: Option<PathBuf>,
        /// Also write a static review page (index.html and the pictures of failing variants) into this folder; it must be missing, empty, or hold an earlier review page.
        #[arg(long, value_name = "DIR")]
        html: Option<PathBuf>,
        /// Folder for the recordings and pictures of failing variants.
        #[arg(long, value_name = "DIR", default_value = "target/safer-artifacts")]
        artifacts: PathBuf,
        /// Write each failing variant as a CommonRoad 2020a scenario (the lanelet network, every other agent as a dynamic obstacle on its stage-2 trajectory, the ego as the planning problem) under DIR/SUITE/SCENARIO/seed-K.xml.
        #[arg(long, value_name = "DIR")]
        export_commonroad: Option<PathBuf>,
        /// With --export-commonroad: every variant, not only the failing ones.
        #[arg(long, requires = "export_commonroad")]
        export_commonroad_all: bool,
        /// Do not shrink failing variants (by default each is shrunk to the smallest deviation from the logged CBV that fails the same way, shown first in its artefacts).
        #[arg(long)]
        no_shrink: bool,
        /// Candidate rollouts a failing variant's shrink may play, at least 1.
        #[arg(long, value_name = "N", default_value_t = safer_scenarios::harness::shrink::DEFAULT_SHRINK_BUDGET, value_parser = at_least_one())]
        shrink_budget: usize,
        /// Only variants and metrics whose test name contains this.
        #[arg(long, value_name = "SUBSTR")]
        filter: Option<String>,
        /// Worker threads for the variants, 1 to 256 (default: one per core). Each may run a planner process: far more than the cores only thrashes.
        #[arg(short, long, value_name = "N", value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_JOBS as u64))]
        jobs: Option<usize>,
        /// Mutation testing: also run each suite's variants with these faults planted in its planner (comma-separated; alone, or `all`: every operator), and report which mutants the suite kills. Operators: no-brake, weak-brake, late, blind-cbv, blind-side, no-evade, speeding. Replaces a suite's own `mutation_operators`.
        #[arg(long, value_name = "OPS", num_args = 0..=1, default_missing_value = "all", value_parser = fault_operators)]
        mutants: Option<FaultOperators>,
    },
    /// Dual-stage evaluation of adversary methods: CR, SR, SR on critical variants, witness rate, VJ, AJ.
    Evaluate {
        /// Folder of recorded scenes (searched recursively); scenes need an ego and a CBV; `data:REL` is in $SAFER_DATA_DIR.
        #[arg(long, value_parser = data_path)]
        scenes: PathBuf,
        /// Methods to compare, one table row each.
        #[arg(long, value_parser = choice(AdversaryMethod::ALL), value_delimiter = ',', default_values = ["safer", "safer-distinct", "safer-lookahead", "safer-inattentive", "no-lfr", "no-trust-region", "no-mda", "prior", "log"])]
        methods: Vec<AdversaryMethod>,
        /// Seeds per scene and method, at least 1.
        #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
        seeds: u32,
        /// Base seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Reactive planner driving the ego in stage 2: a built-in (log-replay, constant-velocity, idm, evasive) or a planner spec file (`planners/NAME.yaml`).
        #[arg(long, default_value = "evasive", value_parser = planner_arg, value_name = "BUILTIN|SPEC.yaml")]
        planner: PlannerAdapter,
        /// Trust-region size n (top-n tokens of the prior), from 1 to the vocabulary size.
        #[arg(long, default_value_t = 20, value_parser = RangedU64ValueParser::<usize>::new().range(1..=VOCABULARY_SIZE as u64))]
        trust_region: usize,
        /// Who drives the background agents.
        #[arg(long, value_parser = choice(BackgroundDriver::ALL), default_value = "configured")]
        background: BackgroundDriver,
        /// The approach phase of the SaFeR methods: `seeded`, the prior drives the CBV for 1-4 tokens drawn from the variant's seed before the adversary engages, so that seeds differ; `none`, the adversary engages at the first token, as the paper describes its resampling (with the background on log replay every seed of a scene then gives the same variant).
        #[arg(long, value_parser = choice(ApproachPhase::ALL), default_value = "seeded")]
        approach_phase: ApproachPhase,
        /// The CBV in stage 2: replaying its stage-1 trajectory, or driven by the method again against the planner's ego (closed-loop); `replay,closed-loop` reports both side by side. The default here is `replay`, so that every method's stage 2 meets the same recorded CBV path and the methods compare on equal terms (the paper does not say whether its CBV reacts in stage 2); suites default to `closed-loop` (`adversary.stage2_cbv`), because a planner test should meet a CBV that answers the planner.
        #[arg(long, value_parser = choice(Stage2Cbv::ALL), value_delimiter = ',', default_values = ["replay"])]
        stage2_cbv: Vec<Stage2Cbv>,
        /// Horizon of both stages from the scene's current step, s (positive, finite).
        #[arg(long, default_value_t = 8.0, value_parser = positive_finite, allow_negative_numbers = true)]
        horizon_s: f64,
        /// Evaluate only the first N scenes (by id), at least 1.
        #[arg(long, value_name = "N", value_parser = at_least_one())]
        max_scenes: Option<usize>,
        /// Evaluate only the scenes with these scenario ids (comma-separated, as the tables name them). Each variant is the one the whole set's evaluation makes: its seed comes from its scene's id, not the scene's place in the list. The held-out split is then drawn among these scenes.
        #[arg(long, value_name = "ID,...", value_delimiter = ',', conflicts_with = "max_scenes")]
        scene: Vec<String>,
        /// Also write every variant and the table as JSON (`-`: standard output).
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
        /// Worker threads for the variants, 1 to 256 (default: one per core). Each may run a planner process: far more than the cores only thrashes.
        #[arg(short, long, value_name = "N", value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_JOBS as u64))]
        jobs: Option<usize>,
        /// How much of the witness's ego must stay on the road: its centre (the CBV's rule), or its whole width (no escape over the edge line).
        #[arg(long, value_parser = choice(RoadKeeping::ALL), default_value = "centre")]
        witness_road: RoadKeeping,
        /// The widest beam the witness search tries when narrower ones find nothing, as a multiple of the narrow one (48 candidates); 1 to 4096. Wider finds escapes narrower ones miss, at seconds to minutes a search where none exists.
        #[arg(long, value_name = "N", default_value_t = safer_scenarios::eval::witness::DEFAULT_WIDEST, value_parser = RangedU64ValueParser::<usize>::new().range(1..=safer_scenarios::eval::witness::MOST_WIDEST as u64))]
        witness_widest: usize,
        /// Run only part K of N (1 ≤ K ≤ N): scene i of the sorted scene list belongs to part i mod N + 1. Merge the parts' `--json` reports with `safer evaluate-merge`.
        #[arg(long, value_name = "K/N", value_parser = clap::value_parser!(Partition))]
        partition: Option<Partition>,
        /// Write each failing variant's MCAP recording, SVG picture and planner stderr under DIR/METHOD/SCENARIO/seed-K.* (as `safer run` does).
        #[arg(long, value_name = "DIR")]
        artifacts: Option<PathBuf>,
        /// Which variants `--artifacts` writes: the failing ones, or all (solved ones too, to see what the CBV did where nothing failed).
        #[arg(long, value_parser = choice(ArtefactVariants::ALL), default_value = "failing", requires = "artifacts")]
        artifacts_of: ArtefactVariants,
        /// Mutation testing: plant these faults in the planner (comma-separated; alone, or `all`: every operator) and count, per method, the variants the planner passes and each mutant fails (no at-fault collision, no leaving the road, an answer inside the vehicle limits at every step). The measure an adversary is judged by.
        #[arg(long, value_name = "OPS", num_args = 0..=1, default_missing_value = "all", value_parser = fault_operators)]
        mutants: Option<FaultOperators>,
    },
    /// Merge the JSON reports of `safer evaluate --partition K/N` runs into the table and report one run would give.
    EvaluateMerge {
        /// The partitions' reports, one per part, in any order.
        #[arg(required = true, value_name = "PART.json")]
        parts: Vec<PathBuf>,
        /// Also write the merged report as JSON (`-`: standard output).
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
    },
    /// Draw a scenario (a recorded file or a scenario spec YAML) as an SVG picture.
    Render {
        /// A recorded scenario (.tfrecord, .json, .xml, .parquet / AV2 folder; `data:REL`: in $SAFER_DATA_DIR) or a scenario spec (.yaml).
        #[arg(value_parser = data_path)]
        file: PathBuf,
        /// Step whose footprints are drawn (default: the scenario's current step).
        #[arg(long, value_name = "N")]
        step: Option<usize>,
        /// Output file (default: `<stem>.svg` in the current folder; `-`: standard output); a folder when FILE holds several scenarios.
        #[arg(long, value_name = "OUT")]
        out: Option<PathBuf>,
        /// Overwrite existing pictures.
        #[arg(long)]
        force: bool,
    },
    /// Summarise a scenario file: format, id, agents by type, steps, map, ego and CBV.
    Inspect {
        /// A WOMD .tfrecord or .json, CommonRoad .xml, or Argoverse 2 .parquet / folder (`data:REL`: in $SAFER_DATA_DIR; `safer:REL`: a file safer ships).
        #[arg(value_parser = data_path)]
        file: PathBuf,
        /// Print JSON instead of text.
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
    },
    /// Run closed-loop rollouts: the ego driven by a planner, the others by a background policy.
    Simulate {
        /// A scenario file, or a folder searched recursively for scenario files (`data:REL`: in $SAFER_DATA_DIR; `safer:REL`: a file safer ships).
        #[arg(value_parser = data_path, required_unless_present = "scenes", conflicts_with = "scenes")]
        path: Option<PathBuf>,
        /// The same as the positional path, named as the other commands name it.
        #[arg(long, value_parser = data_path)]
        scenes: Option<PathBuf>,
        /// Planner driving the ego: a built-in (log-replay, constant-velocity,
        /// idm, evasive) or a planner spec file, as `run` and `evaluate` take.
        #[arg(long, default_value = "idm", value_parser = planner_arg, value_name = "BUILTIN|SPEC.yaml")]
        planner: PlannerAdapter,
        /// Policy driving the other agents.
        #[arg(long, value_parser = choice(BackgroundPolicy::ALL), default_value = "log-replay")]
        background: BackgroundPolicy,
        /// Print JSON instead of a table.
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
    },
    /// Print the JSON Schema of a spec kind (for editors: yaml-language-server `$schema`).
    Schema {
        /// Which spec.
        #[arg(value_parser = choice(SpecKind::ALL))]
        kind: SpecKind,
        /// Write to this file instead of stdout (`-`: stdout).
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
        /// Replace an existing file at --out.
        #[arg(long)]
        force: bool,
    },
    /// WOSAC 2025 realism metrics of a traffic policy: roll out every agent of each scene N times and score the rollouts against the log.
    #[command(after_help = realism::WINDOW_RULE_HELP)]
    Realism {
        /// Folder of scenario files (searched recursively), or one file; `data:REL` is in $SAFER_DATA_DIR.
        #[arg(long, value_parser = data_path)]
        scenes: PathBuf,
        /// Rollouts per scene (WOSAC: 32), at least 1.
        #[arg(long, default_value_t = 32, value_parser = at_least_one())]
        rollouts: usize,
        /// Also write a JSON report (per scene and aggregates) to this file (`-`: standard output).
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
        /// Policy driving every agent present at the window's start (default: the shipped realism prior).
        #[arg(long, value_enum, default_value_t = realism::RealismPolicy::Prior)]
        policy: realism::RealismPolicy,
        /// Base seed (per-rollout seeds derive from it, the scenario id and the rollout index).
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Score at most this many scenes (at least 1).
        #[arg(long, value_name = "N", value_parser = at_least_one())]
        max_scenes: Option<usize>,
        /// The prior policies draw each token among this many most likely ones (default 10), from 1 to the vocabulary size.
        #[arg(long, value_name = "K", value_parser = RangedU64ValueParser::<usize>::new().range(1..=VOCABULARY_SIZE as u64))]
        top_k: Option<usize>,
        /// Softmax temperature of the prior policies' draw (default 1: the model's distribution; lower is greedier), positive and finite.
        #[arg(long, value_parser = positive_finite)]
        temperature: Option<f64>,
    },
    /// What the realism prior's trust region offers the adversary: per method, the probability mass of the tokens of its region (the top n, or the n likeliest distinct behaviours for `safer-distinct`), their acceleration and yaw-rate range, distinct behaviours and plausible share, at the CBV's token boundaries of stage 1.
    TrustRegion {
        /// Folder of recorded scenes (searched recursively); scenes need an ego and a CBV; `data:REL` is in $SAFER_DATA_DIR.
        #[arg(long, value_parser = data_path)]
        scenes: PathBuf,
        /// Methods whose stage 1 is profiled, one row each (`no-mda` runs the plain-attention prior; `$SAFER_MODELS` swaps in another model set).
        #[arg(long, value_parser = choice(AdversaryMethod::ALL), value_delimiter = ',', default_values = ["safer", "safer-distinct", "no-mda"])]
        methods: Vec<AdversaryMethod>,
        /// Seeds per scene and method, at least 1.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
        seeds: u32,
        /// Base seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Trust-region size n (top-n tokens of the prior), from 1 to the vocabulary size.
        #[arg(long, default_value_t = 20, value_parser = RangedU64ValueParser::<usize>::new().range(1..=VOCABULARY_SIZE as u64))]
        trust_region: usize,
        /// The approach phase of the SaFeR methods, as in `safer evaluate`: `seeded` (1-4 tokens of the prior, drawn from the seed, before the adversary engages) or `none` (the adversary from the first token).
        #[arg(long, value_parser = choice(ApproachPhase::ALL), default_value = "seeded")]
        approach_phase: ApproachPhase,
        /// Horizon of stage 1 from the scene's current step, s (positive, finite).
        #[arg(long, default_value_t = 8.0, value_parser = positive_finite, allow_negative_numbers = true)]
        horizon_s: f64,
        /// Profile only the first N scenes (by id), at least 1.
        #[arg(long, value_name = "N", value_parser = at_least_one())]
        max_scenes: Option<usize>,
        /// Also write the summaries and every boundary's profile as JSON (`-`: standard output).
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
        /// Worker threads, 1 to 256 (default: one per core).
        #[arg(short, long, value_name = "N", value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_JOBS as u64))]
        jobs: Option<usize>,
    },
    /// Benchmarks: import time per scene per format, simulator steps per second, one SaFeR variant and its witness search; each beside its reference.
    Bench {
        /// Folder of scenario files (searched recursively); `data:` is $SAFER_DATA_DIR.
        #[arg(long, default_value = "data:", value_parser = data_path)]
        scenes: PathBuf,
        /// Repetitions of each measurement (the median is reported), at least 1.
        #[arg(long, default_value_t = 3, value_parser = at_least_one())]
        repeat: usize,
        /// Also write the figures as JSON (`-`: standard output, the table then goes to stderr).
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
        /// Another build's `safer` binary to compare with: both builds' bench run in turn, round by round, and each timed figure is printed for both with their ratio.
        #[arg(long, value_name = "SAFER-BINARY")]
        baseline: Option<PathBuf>,
        /// Rounds of `--baseline`, each running both builds' bench once, at least 1.
        #[arg(long, default_value_t = 5, value_parser = at_least_one(), requires = "baseline")]
        rounds: usize,
    },
    /// Measure the log → token → log round trip (ADE/FDE) over recorded scenes.
    TokenRoundtrip {
        /// Folder of scenario files (searched recursively); `data:REL` is in $SAFER_DATA_DIR.
        #[arg(long, value_parser = data_path)]
        scenes: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
    },
    /// [model tools] Write the realism prior's training shards (NGSIM scenes + calibrated synthetic traffic).
    PriorDataset {
        /// Recorded scenes whose licence allows training the shipped models (NGSIM); `data:REL` is in $SAFER_DATA_DIR.
        #[arg(long, default_value = "data:commonroad-ngsim", value_parser = data_path)]
        recorded: PathBuf,
        /// Output folder for the shards.
        #[arg(long, default_value = "training/data/prior")]
        out: PathBuf,
        /// Synthetic scenes on procedural templates (straight roads, merges, crossings).
        #[arg(long, default_value_t = 1200)]
        template_scenes: usize,
        /// Synthetic scenes on the recorded maps.
        #[arg(long, default_value_t = 400)]
        recorded_map_scenes: usize,
        /// Base seed of the synthetic traffic.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Samples per shard, at least 1.
        #[arg(long, default_value_t = 50_000, value_parser = at_least_one())]
        shard_size: usize,
        /// Synthetic drivers keep their lane and go straight at junctions
        /// (the first shipped prior's data) instead of turning, changing
        /// lanes and accepting gaps.
        #[arg(long)]
        no_driver_choices: bool,
        /// Share of the template crossings built as T-junctions (one arm
        /// left out, so traffic arriving opposite it must turn); 0 draws
        /// the shipped priors' data.
        #[arg(long, default_value_t = 0.0)]
        t_junction_share: f64,
        /// Share of the template crossings with two lanes per direction
        /// whose kerb lanes turn right only (dedicated right-turn lanes, so
        /// traffic in them must turn); 0 draws the shipped priors' data.
        #[arg(long, default_value_t = 0.0)]
        right_turn_lane_share: f64,
        /// Share of synthetic scenes with pedestrians walking across the
        /// road (on crosswalks, and mid-block on streets of at most 17 m/s),
        /// whom the drivers yield to; 0 draws the shipped priors' data.
        #[arg(long, default_value_t = 0.0)]
        pedestrian_share: f64,
        /// Chance that a training scene's token reconstruction applies a
        /// perturbed token in a period (0 turns the drift off); held-out
        /// scenes never drift.
        #[arg(long, default_value_t = 0.3)]
        token_drift: f64,
        /// Largest token perturbation, in bins per axis.
        #[arg(long, default_value_t = 3)]
        token_drift_bins: usize,
        /// Largest perturbation of the yaw rate, in bins, where it should
        /// differ from `--token-drift-bins` (which then bounds the
        /// acceleration alone); 0 keeps the drift longitudinal.
        #[arg(long, value_name = "BINS")]
        token_drift_yaw_rate_bins: Option<usize>,
        /// Accept recorded scenes under any licence (Waymo, Argoverse) for
        /// a model that is measured and never shipped: the shards say so and
        /// `training/prior/export.py` refuses to write it into `models/`.
        #[arg(long)]
        evaluation_only: bool,
        /// Replace shards already in the output folder.
        #[arg(long)]
        force: bool,
    },
    /// [model tools] How well the realism prior predicts recorded driving: NLL, top-1 and how often the recorded token is in the top n, at every token boundary of every moving vehicle, with the history ending at the boundary (as in closed loop) and one step late (a probe of whether the prior reads the start of the token it predicts).
    PriorFit {
        /// Folder of scenario files (searched recursively), or one file; `data:REL` is in $SAFER_DATA_DIR.
        #[arg(long, value_parser = data_path)]
        scenes: PathBuf,
        /// Trust-region size n (top-n tokens of the prior), from 1 to the vocabulary size
        /// (`--trust-region`, as `evaluate` and `trust-region` name it; `--top-n` is accepted too).
        #[arg(long = "trust-region", alias = "top-n", value_name = "N", default_value_t = 20, value_parser = RangedU64ValueParser::<usize>::new().range(1..=VOCABULARY_SIZE as u64))]
        top_n: usize,
        /// Vehicles slower than this at a boundary are not scored, m/s (non-negative, finite; standing cars' tokens are trivial).
        #[arg(long, default_value_t = 1.0, value_parser = non_negative_finite, allow_negative_numbers = true)]
        min_speed_mps: f64,
        /// Which prior: the differential-attention one (default) or the plain-attention one; `$SAFER_MODELS` swaps in another model set.
        #[arg(long, value_parser = choice(safer_scenarios::models::prior::PriorVariant::ALL), default_value = "differential")]
        prior: safer_scenarios::models::prior::PriorVariant,
        /// Score at most this many scenes (by id), at least 1.
        #[arg(long, value_name = "N", value_parser = at_least_one())]
        max_scenes: Option<usize>,
        /// Also write the fits (all, held-out and other scenes, and each scene's sums) as JSON (`-`: standard output).
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
    },
    /// [model tools] Write the feasibility value's training transitions (NGSIM + synthetic, several ego and CBV policies).
    FeasibilityDataset {
        /// Recorded scenes whose licence allows training the shipped models (NGSIM); `data:REL` is in $SAFER_DATA_DIR.
        #[arg(long, default_value = "data:commonroad-ngsim", value_parser = data_path)]
        recorded: PathBuf,
        /// Output folder.
        #[arg(long, default_value = "training/data/feasibility")]
        out: PathBuf,
        /// Synthetic scenes.
        #[arg(long, default_value_t = 300)]
        synthetic_scenes: usize,
        /// Base seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Replace an existing dataset.
        #[arg(long)]
        force: bool,
    },
    /// [model tools] Accuracy of the shipped V_h against the witness search on held-out states, V_h latency, and the LFR picture.
    FeasibilityEval {
        /// Recorded scenes of the collection (NGSIM); `data:REL` is in $SAFER_DATA_DIR.
        #[arg(long, default_value = "data:commonroad-ngsim", value_parser = data_path)]
        recorded: PathBuf,
        /// Synthetic scenes of the collection (same as for `feasibility-dataset`).
        #[arg(long, default_value_t = 300)]
        synthetic_scenes: usize,
        /// Base seed of the collection.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Most held-out states to label, at least 1.
        #[arg(long, default_value_t = 3000, value_parser = at_least_one())]
        states: usize,
        /// Where to draw V_h over relative CBV positions (the README's
        /// picture is `docs/feasibility-lfr.svg`); none unless asked.
        #[arg(long)]
        svg: Option<PathBuf>,
        /// Write the figures as JSON (`-`: standard output, the table then on stderr).
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
        /// Which scenes' states to label: the held-out ones (never trained
        /// on; the reported figures) or the training ones (to calibrate a
        /// decision threshold on without touching the held-out set).
        #[arg(long, value_parser = choice(safer_scenarios::datasets::held_out::Split::ALL), default_value = "held-out")]
        split: safer_scenarios::datasets::held_out::Split,
        /// Write every labelled state (its V_h features, witness label and
        /// V_h) as a safetensors file, for `training/feasibility/train.py
        /// --calibration` (label the training split for that, never the
        /// held-out one).
        #[arg(long, value_name = "OUT")]
        labels: Option<PathBuf>,
    },
    /// [model tools] Latency of the learned models in tract (map encoding, CBV query, full-scene step), against onnxruntime/PyTorch.
    BenchModels {
        /// Scenes to pick the busiest from; `data:REL` is in $SAFER_DATA_DIR.
        #[arg(long, default_value = "data:womd-tfrecord", value_parser = data_path)]
        scenes: PathBuf,
        /// Folder of the models and their cards (default: $SAFER_MODELS, else the models embedded in safer).
        #[arg(long)]
        models: Option<PathBuf>,
        /// Repetitions (the median is reported), at least 1.
        #[arg(long, default_value_t = 200, value_parser = at_least_one())]
        repeat: usize,
        /// Python of the training environment, which times the reference (onnxruntime, PyTorch); without it the report says there is none.
        #[arg(long, default_value = "training/.venv/bin/python")]
        python: PathBuf,
        /// Also print where the decoder's time goes: the N costliest nodes of tract's plan and the time per operator, at batch 1 and the scene batch.
        #[arg(long, value_name = "N")]
        profile: Option<usize>,
        /// Also write the figures as JSON (`-`: standard output, the table then goes to stderr).
        #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
        json: Option<PathBuf>,
    },
}

/// Errors the commands report.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// A scenario could not be imported.
    #[error(transparent)]
    Import(#[from] ImportError),
    /// A rollout could not be set up.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// Writing output failed.
    #[error("cannot write output: {0}")]
    Output(#[from] std::io::Error),
    /// Serialising JSON failed.
    #[error("cannot serialise JSON: {0}")]
    Json(#[from] serde_json::Error),
    /// A folder held no scenario files.
    #[error("{0}: no scenario files found (looked for .tfrecord, .json, .xml, Argoverse 2 folders)")]
    NoScenes(PathBuf),
    /// A spec file could not be loaded (printed as a report with the YAML snippet).
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// A suite variant could not be run.
    #[error(transparent)]
    Harness(#[from] HarnessError),
    /// An artefact could not be written.
    #[error(transparent)]
    Record(#[from] RecordError),
    /// A learned model could not be loaded or run.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The `--baseline` build of `safer bench` could not be run or read.
    #[error("--baseline {}: {problem}", binary.display())]
    Baseline {
        /// The baseline's binary, as given.
        binary: PathBuf,
        /// What went wrong, in words.
        problem: String,
    },
    /// The arguments ask for something that cannot be done.
    #[error("{0}")]
    Usage(String),
}

/// Runs the command line; returns the process exit code.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Inspect { file, json } => inspect::run(&file, json.as_deref()),
        Command::Simulate { path, scenes, planner, background, json } => {
            let path = path.or(scenes).expect("clap requires the path or --scenes");
            simulate::run(&path, &planner, background, json.as_deref())
        }
        Command::TokenRoundtrip { scenes, json } => token_roundtrip::run(&scenes, json.as_deref()),
        Command::Bench { scenes, repeat, json, baseline: None, rounds: _ } => {
            bench::run(&scenes, repeat, json.as_deref())
        }
        Command::Bench { scenes, repeat, json, baseline: Some(baseline), rounds } => bench_baseline::run(
            bench_baseline::BaselineBench { scenes: &scenes, repeat, rounds, baseline: &baseline },
            json.as_deref(),
        ),
        Command::Run {
            suites,
            json,
            junit,
            html,
            artifacts,
            export_commonroad,
            export_commonroad_all,
            no_shrink,
            shrink_budget,
            filter,
            jobs,
            mutants,
        } => {
            if json.as_deref().is_some_and(safer_scenarios::record::is_stdout)
                && junit.as_deref().is_some_and(safer_scenarios::record::is_stdout)
            {
                Err(CliError::Usage("--json - and --junit - cannot both take standard output".into()))
            } else {
                let outputs = run::RunOutputs {
                    json: json.as_deref(),
                    junit: junit.as_deref(),
                    html: html.as_deref(),
                    artifacts: &artifacts,
                    commonroad: export_commonroad.as_deref().map(|dir| (dir, export_commonroad_all)),
                };
                let budget = if no_shrink { 0 } else { shrink_budget };
                let mutants = mutants.as_ref().map(|m| m.0.as_slice());
                set_jobs(jobs).and_then(|()| run::run(&suites, outputs, filter.as_deref(), budget, mutants))
            }
        }
        Command::Realism { scenes, rollouts, json, policy, seed, max_scenes, top_k, temperature } => {
            realism::sampling_for(policy, top_k, temperature).and_then(|sampling| {
                realism::run(&realism::RealismArgs { scenes, rollouts, json, policy, seed, max_scenes, sampling })
            })
        }
        Command::PriorFit { scenes, top_n, min_speed_mps, prior, max_scenes, json } => {
            prior_fit::run(&prior_fit::PriorFitArgs { scenes, top_n, min_speed_mps, variant: prior, max_scenes, json })
        }
        Command::Schema { kind, out, force } => schema::run(kind, out.as_deref(), force),
        Command::Render { file, step, out, force } => render::run(&file, step, out.as_deref(), force),
        Command::BenchModels { scenes, models, repeat, python, profile, json } => bench_models::run(
            &scenes,
            &safer_scenarios::models::ModelSource::folder_or_shipped(models),
            repeat,
            &python,
            profile,
            json.as_deref(),
        ),
        Command::Evaluate {
            scenes,
            methods,
            seeds,
            seed,
            planner,
            trust_region,
            background,
            approach_phase,
            stage2_cbv,
            horizon_s,
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
        } => {
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
                background,
                stage2_cbv,
                escape: Some(escape),
                horizon_s,
                artefacts: artifacts,
                artefacts_of: artifacts_of,
                mutants: mutants.map(|m| m.0).unwrap_or_default(),
            };
            let witness = evaluate::WitnessSettings { road: witness_road, widest: witness_widest };
            set_jobs(jobs).and_then(|()| {
                evaluate::run(
                    &scenes,
                    &request,
                    evaluate::SceneSelection { max_scenes, ids: &scene },
                    json.as_deref(),
                    witness,
                    partition,
                )
            })
        }
        Command::EvaluateMerge { parts, json } => evaluate::merge(&parts, json.as_deref()),
        Command::TrustRegion {
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
        } => {
            let request = EvaluationRequest {
                methods,
                seeds,
                base_seed: seed,
                // Stage 2 is not run.
                planner: PlannerAdapter::builtin(BuiltinPlanner::LogReplay),
                trust_region,
                approach: approach_phase,
                background: BackgroundDriver::Configured,
                stage2_cbv: vec![Stage2Cbv::Replay],
                escape: None,
                horizon_s,
                artefacts: None,
                artefacts_of: ArtefactVariants::Failing,
                mutants: Vec::new(),
            };
            set_jobs(jobs).and_then(|()| trust_region::run(&scenes, &request, max_scenes, json.as_deref()))
        }
        Command::FeasibilityDataset { recorded, out, synthetic_scenes, seed, force } => {
            feasibility_dataset::run(&feasibility_dataset::FeasibilityDatasetRequest {
                recorded,
                out,
                synthetic_scenes,
                seed,
                force,
            })
        }
        Command::FeasibilityEval { recorded, synthetic_scenes, seed, states, svg, json, split, labels } => {
            feasibility_eval::run(
                &feasibility_dataset::FeasibilityDatasetRequest {
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
        Command::PriorDataset {
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
        } => prior_dataset::run(&prior_dataset::DatasetRequest {
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
        }),
    };
    match result {
        Ok(code) => code,
        // A spec error reads best as the report with the offending YAML line.
        Err(CliError::Spec(e)) => {
            eprintln!("{}", e.render(std::io::IsTerminal::is_terminal(&std::io::stderr())));
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("{}", error_report(&e));
            ExitCode::from(2)
        }
    }
}

/// `error: MESSAGE` and, one per line, each cause the message does not
/// already include (the sources carried by the error enums).
fn error_report(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = format!("error: {e}");
    let mut source = e.source();
    while let Some(cause) = source {
        let line = cause.to_string();
        if !text.contains(&line) {
            text.push_str("\n  caused by: ");
            text.push_str(&line);
        }
        source = cause.source();
    }
    text
}

/// A command-line path: `data:REL` is `REL` in the shared recorded-data
/// folder, by the rule of [`safer_scenarios::spec::paths`] for the project this
/// binary was built from; anything else is taken as written.
/// Checks, before a command runs, that `--json PATH` can take its report:
/// a file, `-` or a device ([`safer_scenarios::record::output::check_output`]), and
/// not an existing file of another kind than JSON.
fn check_json_report(path: &Path) -> Result<(), CliError> {
    safer_scenarios::record::output::check_output(path)?;
    safer_scenarios::record::check_replaceable("--json", path, safer_scenarios::record::OutputKind::Json, false)?;
    Ok(())
}

/// Writes `report` as pretty JSON to `path` (`-`: standard output), after
/// the same checks as every `--json` report.
fn write_json_report(path: &Path, report: &impl serde::Serialize) -> Result<(), CliError> {
    check_json_report(path)?;
    safer_scenarios::record::write_output(path, (serde_json::to_string_pretty(report)? + "\n").as_bytes())?;
    Ok(())
}

/// Parses a scene path: `data:REL` and `safer:REL` resolved as in specs,
/// anything else as written; a path that does not exist is refused here,
/// naming it, before any command runs.
fn data_path(written: &str) -> Result<PathBuf, String> {
    let path = if written.starts_with("data:") || written.starts_with("safer:") {
        safer_scenarios::spec::paths::resolve_checked(safer_scenarios::spec::paths::shipped_dir(), written)?
    } else {
        PathBuf::from(written)
    };
    if !path.exists() {
        return Err(format!(
            "no such file or folder: {}{}",
            path.display(),
            safer_scenarios::spec::paths::missing_hint(written)
        ));
    }
    Ok(path)
}

/// Parses `--planner`: a built-in's name, else a planner spec file.
fn planner_arg(written: &str) -> Result<PlannerAdapter, String> {
    if let Ok(builtin) =
        BuiltinPlanner::ALL.iter().copied().find(|b| safer_scenarios::spec::spec_name(b) == written).ok_or(())
    {
        return Ok(PlannerAdapter::builtin(builtin));
    }
    let path = Path::new(written);
    if !path.exists() {
        return Err(format!(
            "`{written}` is neither a built-in planner (log-replay, constant-velocity, idm, evasive) nor a planner spec file"
        ));
    }
    PlannerAdapter::load(path).map_err(|e| e.to_string())
}

/// Most worker threads `--jobs` takes: `--jobs 10000` turned a 0.2 s suite
/// into more than a minute at a load of about 1000.
const MAX_JOBS: usize = 256;

/// Sets the number of rayon worker threads (`--jobs`).
fn set_jobs(jobs: Option<usize>) -> Result<(), CliError> {
    let Some(n) = jobs else { return Ok(()) };
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build_global()
        .map_err(|e| CliError::Usage(format!("--jobs {n}: could not set up the worker threads: {e}")))
}

/// A list of fault operators, as `--mutants` takes it.
#[derive(Debug, Clone)]
pub(crate) struct FaultOperators(pub(crate) Vec<safer_scenarios::planners::FaultOperator>);

/// `no-brake,late` or `all`.
fn fault_operators(text: &str) -> Result<FaultOperators, String> {
    safer_scenarios::planners::FaultOperator::parse_list(text).map(FaultOperators)
}

/// Parses a count that must be at least 1 (clap names the flag and the
/// range when it is not).
fn at_least_one() -> impl TypedValueParser<Value = usize> {
    RangedU64ValueParser::<usize>::new().range(1..)
}

/// Parses a positive, finite number (durations, distances).
fn positive_finite(written: &str) -> Result<f64, String> {
    let v: f64 = written.trim().parse().map_err(|_| format!("`{written}` is not a number; expected 0 < x < inf"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{v} is outside the accepted range 0 < x < inf (a positive, finite number)"))
    }
}

/// Parses a non-negative, finite number (speeds, thresholds).
fn non_negative_finite(written: &str) -> Result<f64, String> {
    let v: f64 = written.trim().parse().map_err(|_| format!("`{written}` is not a number; expected 0 <= x < inf"))?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("{v} is outside the accepted range 0 <= x < inf (a non-negative, finite number)"))
    }
}

/// A mean to `decimals` places for a table, `—` where there is none.
fn figure(value: Option<f64>, decimals: usize) -> String {
    value.map_or("—".into(), |v| format!("{v:.decimals$}"))
}

/// Writes a command's JSON report to `json` (if asked) and its table
/// (`print`) to standard output, or to standard error when the report
/// takes standard output. A report file is written before the table: a
/// reader that closes standard output early (`| head`) must not cost the
/// run its report, and a closed pipe ends the table quietly.
fn write_report_and_table(
    json: Option<&Path>,
    report: &impl serde::Serialize,
    print: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
) -> Result<(), CliError> {
    let report_text = || serde_json::to_string_pretty(report).map(|t| t + "\n");
    if let Some(path) = json.filter(|p| !safer_scenarios::record::is_stdout(p)) {
        safer_scenarios::record::write_output(path, report_text()?.as_bytes())?;
        eprintln!("wrote {}", path.display());
    }
    let mut table = table_writer(json);
    match print(&mut table).and_then(|()| table.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other?,
    }
    if let Some(path) = json.filter(|p| safer_scenarios::record::is_stdout(p)) {
        safer_scenarios::record::write_output(path, report_text()?.as_bytes())?;
    }
    Ok(())
}

/// Where a command's human-readable table goes: standard output, or
/// standard error when the JSON report takes standard output (`--json -`),
/// so the JSON stays parseable.
fn table_writer(json: Option<&Path>) -> Box<dyn std::io::Write> {
    if json.is_some_and(safer_scenarios::record::is_stdout) {
        Box::new(std::io::stderr().lock())
    } else {
        Box::new(std::io::stdout().lock())
    }
}

/// Scenario files under `path` (or `path` itself when it is a file).
fn scene_paths(path: &std::path::Path) -> Result<Vec<PathBuf>, CliError> {
    if let Err(e) = std::fs::metadata(path) {
        return Err(CliError::Usage(format!("{}: no such file or folder ({e})", path.display())));
    }
    let is_av2_folder = safer_scenarios::scenario::import::argoverse2::find_scenario_files(path).is_ok();
    if path.is_dir() && !is_av2_folder {
        let found = safer_scenarios::scenario::import::discover(path)?;
        if found.is_empty() {
            return Err(CliError::NoScenes(path.to_path_buf()));
        }
        Ok(found)
    } else {
        Ok(vec![path.to_path_buf()])
    }
}
