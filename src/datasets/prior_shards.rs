//! The realism prior's training shards: every (agent, token boundary) of a
//! recorded NGSIM scene and of synthetic traffic becomes one
//! [`PriorSample`](crate::models::prior_dataset::PriorSample), written in
//! safetensors shards that `training/prior/` reads (column layout in
//! `docs/prior-features.md`; the metadata key `scenes` lists each scene's
//! id, source and [`Split`]).
//!
//! The synthetic drivers are calibrated against the recorded scenes:
//! desired speeds are drawn from the recorded vehicle speeds, and the
//! acceleration disturbance from their 0.5 s acceleration spread;
//! [`Calibration`] holds both distributions (and their Jensen–Shannon
//! divergence) so the calibration can be judged.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::held_out::Split;
use super::{DatasetError, TrainingPurpose};
use crate::eval::{Histogram, jensen_shannon};
use crate::models::prior_dataset::{PriorSample, TokenDrift, TokenizedScene, scene_samples};
use crate::models::prior_features::{
    HISTORY_FEATURES, HISTORY_POINTS, MAP_TOKEN_FEATURES, MAP_TOKENS, NEIGHBOUR_FEATURES, NEIGHBOURS, POSE_FEATURES,
    SELF_FEATURES, SIGNAL_FEATURES,
};
use crate::models::shard::{ShardColumn, write_shard};
use crate::motion::tokens::TokenGrid;
use crate::scenario::{AgentKind, Scenario};
use crate::sim::synthetic::{CrossingMix, SpeedSample, SyntheticTraffic, random_template_with};

/// Length of a synthetic scene, s.
pub const SYNTHETIC_DURATION_S: f64 = 12.0;
/// Simulator step of the synthetic scenes, s.
const SYNTHETIC_DT_S: f64 = 0.1;
/// Share of synthetic crossings without signals, where drivers settle who
/// goes by gap acceptance.
const UNSIGNALISED_SHARE: f64 = 1.0 / 3.0;
/// Scenes whose samples are built at once (and the granularity at which a
/// shard is closed once it reaches its size).
const SCENES_PER_CHUNK: usize = 32;
/// Source name of the recorded public-domain (NGSIM) scenes in shard metadata.
pub const RECORDED_SOURCE: &str = "ngsim";
/// Source name of recorded scenes under another licence (evaluation-only shards).
pub const RECORDED_EVALUATION_ONLY_SOURCE: &str = "recorded-evaluation-only";
/// Source name of the synthetic scenes in shard metadata.
pub const SYNTHETIC_SOURCE: &str = "synthetic";
/// The feature contract the shards are written in (`contract_version` in
/// their metadata): 2, with all [`MAP_TOKEN_FEATURES`] values per map
/// token (the trainer takes the first 7 for a version-1 prior).
pub const SHARD_CONTRACT_VERSION: u32 = 2;

/// A scene's entry in a shard's metadata.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ShardScene {
    /// Scenario id.
    pub id: String,
    /// Where it came from ([`RECORDED_SOURCE`], [`SYNTHETIC_SOURCE`]).
    pub source: String,
    /// Train or held out.
    pub split: Split,
}

/// Accumulates samples and writes them as one safetensors shard.
#[derive(Debug)]
pub struct ShardWriter {
    purpose: TrainingPurpose,
    recipe: String,
    arguments: String,
    scenes: Vec<ShardScene>,
    samples: Vec<(usize, PriorSample)>,
}

impl Default for ShardWriter {
    fn default() -> Self {
        Self::new(TrainingPurpose::Shipped, String::new())
    }
}

impl ShardWriter {
    /// An empty shard whose metadata names `purpose` and the data `recipe`.
    pub fn new(purpose: TrainingPurpose, recipe: String) -> Self {
        Self { purpose, recipe, arguments: String::new(), scenes: Vec::new(), samples: Vec::new() }
    }

    /// The same, naming the `safer prior-dataset` arguments that made the
    /// data (metadata `arguments`).
    pub fn with_arguments(mut self, arguments: String) -> Self {
        self.arguments = arguments;
        self
    }

    /// Adds a scene's samples.
    pub fn add_scene(&mut self, scene: ShardScene, samples: Vec<PriorSample>) {
        let index = self.scenes.len();
        self.scenes.push(scene);
        self.samples.extend(samples.into_iter().map(|s| (index, s)));
    }

    /// Number of samples so far.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Whether no sample was added.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Writes the shard to `path` (through a temporary file, so a reader
    /// never sees half a shard).
    pub fn write(&self, path: &Path) -> Result<(), DatasetError> {
        let n = self.samples.len();
        let mut cols: Vec<(&str, Vec<f32>, Vec<usize>)> = vec![
            (
                "history",
                Vec::with_capacity(n * HISTORY_POINTS * HISTORY_FEATURES),
                vec![n, HISTORY_POINTS, HISTORY_FEATURES],
            ),
            ("agent_self", Vec::with_capacity(n * SELF_FEATURES), vec![n, SELF_FEATURES]),
            (
                "neighbours",
                Vec::with_capacity(n * NEIGHBOURS * NEIGHBOUR_FEATURES),
                vec![n, NEIGHBOURS, NEIGHBOUR_FEATURES],
            ),
            ("neighbour_pose", Vec::with_capacity(n * NEIGHBOURS * POSE_FEATURES), vec![n, NEIGHBOURS, POSE_FEATURES]),
            ("neighbour_mask", Vec::with_capacity(n * NEIGHBOURS), vec![n, NEIGHBOURS]),
            (
                "map_tokens",
                Vec::with_capacity(n * MAP_TOKENS * MAP_TOKEN_FEATURES),
                vec![n, MAP_TOKENS, MAP_TOKEN_FEATURES],
            ),
            ("map_pose", Vec::with_capacity(n * MAP_TOKENS * POSE_FEATURES), vec![n, MAP_TOKENS, POSE_FEATURES]),
            ("map_signal", Vec::with_capacity(n * MAP_TOKENS * SIGNAL_FEATURES), vec![n, MAP_TOKENS, SIGNAL_FEATURES]),
            ("map_mask", Vec::with_capacity(n * MAP_TOKENS), vec![n, MAP_TOKENS]),
        ];
        let mut next_token = Vec::with_capacity(n);
        let mut scene = Vec::with_capacity(n);
        let mut lane_change = Vec::with_capacity(n);
        for (s, sample) in &self.samples {
            let q = &sample.query;
            for (name, col, _) in &mut cols {
                col.extend_from_slice(match *name {
                    "history" => &q.history[..],
                    "agent_self" => &q.agent_self[..],
                    "neighbours" => &q.neighbours[..],
                    "neighbour_pose" => &q.neighbour_pose[..],
                    "neighbour_mask" => &q.neighbour_mask[..],
                    "map_tokens" => &sample.map_tokens[..],
                    "map_pose" => &q.map_pose[..],
                    "map_signal" => &q.map_signal[..],
                    _ => &q.map_mask[..],
                });
            }
            next_token.push(i64::from(sample.next_token.0));
            scene.push(*s as i64);
            lane_change.push(i64::from(sample.lane_change));
        }
        let columns: Vec<ShardColumn> = cols
            .into_iter()
            .map(|(name, v, shape)| ShardColumn::f32(name, shape, &v))
            .chain([
                ShardColumn::i64("next_token", vec![n], &next_token),
                ShardColumn::i64("scene", vec![n], &scene),
                ShardColumn::i64("lane_change", vec![n], &lane_change),
            ])
            .collect();
        let scenes = serde_json::to_string(&self.scenes)
            .map_err(|source| DatasetError::Metadata { path: path.to_path_buf(), source })?;
        let purpose = match self.purpose {
            TrainingPurpose::Shipped => "shipped",
            TrainingPurpose::EvaluationOnly => "evaluation-only",
        };
        let metadata = HashMap::from([
            ("scenes".to_string(), scenes),
            ("contract_version".to_string(), SHARD_CONTRACT_VERSION.to_string()),
            ("purpose".to_string(), purpose.to_string()),
            ("recipe".to_string(), self.recipe.clone()),
            ("arguments".to_string(), self.arguments.clone()),
        ]);
        Ok(write_shard(path, &columns, metadata)?)
    }
}

/// Speeds and 0.5 s accelerations of the moving vehicles (faster than
/// 1 m/s) of tokenized scenes, one entry per token period.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VehicleKinematics {
    /// Speeds, m/s.
    pub speeds_mps: Vec<f64>,
    /// Accelerations of the applied tokens, m/s².
    pub accels_mps2: Vec<f64>,
    /// Yaw rates of the applied tokens, rad/s.
    pub yaw_rates_radps: Vec<f64>,
}

impl VehicleKinematics {
    /// The kinematics of `scenes` (in scene order).
    pub fn of(scenes: &[Scenario]) -> Self {
        let per_scene: Vec<VehicleKinematics> = scenes.par_iter().map(Self::of_scene).collect();
        per_scene.into_iter().fold(Self::default(), |mut all, s| {
            all.speeds_mps.extend(s.speeds_mps);
            all.accels_mps2.extend(s.accels_mps2);
            all.yaw_rates_radps.extend(s.yaw_rates_radps);
            all
        })
    }

    fn of_scene(scene: &Scenario) -> Self {
        let t = TokenizedScene::new(scene);
        let mut out = Self::default();
        // Sorted keys: the order of the samples does not depend on hashing.
        let mut keys: Vec<&(usize, usize)> = t.labels.keys().collect();
        keys.sort_unstable();
        for key @ &(agent, step) in keys {
            if t.bodies[agent].kind != AgentKind::Vehicle {
                continue;
            }
            if let Some(state) = t.frames.get(step).and_then(|f| f[agent])
                && state.speed_mps() > 1.0
            {
                out.speeds_mps.push(state.speed_mps());
                let action = TokenGrid::action(t.labels[key]);
                out.accels_mps2.push(action.accel_mps2);
                out.yaw_rates_radps.push(action.yaw_rate_radps);
            }
        }
        out
    }

    /// Number of token periods.
    pub fn len(&self) -> usize {
        self.speeds_mps.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.speeds_mps.is_empty()
    }

    /// Standard deviation of the accelerations (`None` without any), m/s².
    pub fn accel_std_mps2(&self) -> Option<f64> {
        std_dev(&self.accels_mps2)
    }

    /// Share of token periods steering at least `min_radps` either way
    /// (`None` without any): how often the traffic makes a lateral choice.
    pub fn steering_share(&self, min_radps: f64) -> Option<f64> {
        (!self.yaw_rates_radps.is_empty()).then(|| {
            self.yaw_rates_radps.iter().filter(|w| w.abs() >= min_radps).count() as f64
                / self.yaw_rates_radps.len() as f64
        })
    }
}

/// Population standard deviation (`None` of an empty slice).
pub fn std_dev(v: &[f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    Some((v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt())
}

fn histogram(v: &[f64], lo: f64, hi: f64, bins: usize) -> Histogram {
    let mut h = Histogram::new(lo, hi, bins);
    for &x in v {
        h.add(x);
    }
    h
}

/// Recorded vs synthetic vehicle kinematics.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// Of the recorded scenes.
    pub recorded: VehicleKinematics,
    /// Of the synthetic scenes.
    pub synthetic: VehicleKinematics,
    /// Jensen–Shannon divergence of the speeds (35 bins of 1 m/s over 0..35 m/s; `None` when a side is empty).
    pub speed_jsd: Option<f64>,
    /// Jensen–Shannon divergence of the accelerations (20 bins of 0.5 m/s² over ±5 m/s²).
    pub accel_jsd: Option<f64>,
    /// Jensen–Shannon divergence of the yaw rates (24 bins of 0.05 rad/s over ±0.6 rad/s).
    pub yaw_rate_jsd: Option<f64>,
}

impl Calibration {
    /// Compares the two.
    pub fn new(recorded: VehicleKinematics, synthetic: VehicleKinematics) -> Self {
        let speed_jsd = jensen_shannon(
            &histogram(&recorded.speeds_mps, 0.0, 35.0, 35),
            &histogram(&synthetic.speeds_mps, 0.0, 35.0, 35),
        );
        let accel_jsd = jensen_shannon(
            &histogram(&recorded.accels_mps2, -5.0, 5.0, 20),
            &histogram(&synthetic.accels_mps2, -5.0, 5.0, 20),
        );
        let yaw_rate_jsd = jensen_shannon(
            &histogram(&recorded.yaw_rates_radps, -0.6, 0.6, 24),
            &histogram(&synthetic.yaw_rates_radps, -0.6, 0.6, 24),
        );
        Self { recorded, synthetic, speed_jsd, accel_jsd, yaw_rate_jsd }
    }
}

/// How much synthetic traffic to generate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyntheticPlan {
    /// Scenes on procedural templates.
    pub template_scenes: usize,
    /// Scenes on the recorded maps (none without recorded scenes).
    pub recorded_map_scenes: usize,
    /// Base seed.
    pub seed: u64,
    /// Whether the drivers turn, change lanes and accept gaps (else they
    /// keep their lane and go straight, as the first shipped prior's data did).
    pub driver_choices: bool,
    /// Share of the template crossings built as T-junctions (0: none, as
    /// the shipped priors' data).
    pub t_junction_share: f64,
    /// Share of the two-lane template crossings whose kerb lanes turn
    /// right only (0: none, as the shipped priors' data).
    pub right_turn_lane_share: f64,
    /// Share of synthetic scenes with pedestrians crossing the road (0:
    /// none, as the shipped priors' data).
    pub pedestrian_share: f64,
}

/// The synthetic traffic generator calibrated against the recorded kinematics.
pub fn calibrated_traffic(
    recorded: &VehicleKinematics,
    driver_choices: bool,
    pedestrian_share: f64,
) -> SyntheticTraffic {
    SyntheticTraffic {
        speeds: SpeedSample::new(recorded.speeds_mps.clone()),
        // IDM alone already varies acceleration; the disturbance supplies
        // the rest of the recorded spread (checked by the calibration).
        accel_noise_std_mps2: 0.6 * recorded.accel_std_mps2().unwrap_or(0.0),
        duration_s: SYNTHETIC_DURATION_S,
        max_agents: 80,
        choices: driver_choices,
        pedestrian_share,
    }
}

/// Synthetic scenes (templates first, then recorded maps, each in index
/// order; a scene the generator cannot populate is skipped) and the
/// calibration of their kinematics against `recorded`.
pub fn synthetic_scenes(recorded: &[Scenario], plan: SyntheticPlan) -> (Vec<Scenario>, Calibration) {
    let recorded_kinematics = VehicleKinematics::of(recorded);
    let traffic = calibrated_traffic(&recorded_kinematics, plan.driver_choices, plan.pedestrian_share);
    let steps = (SYNTHETIC_DURATION_S / SYNTHETIC_DT_S).round() as usize + 1;
    let jobs: Vec<(String, u64, Option<usize>)> = (0..plan.template_scenes)
        .map(|i| (format!("synthetic-template-{i:05}"), plan.seed.wrapping_add(i as u64), None))
        .chain((0..plan.recorded_map_scenes).filter(|_| !recorded.is_empty()).map(|i| {
            (
                format!("synthetic-recorded-map-{i:05}"),
                plan.seed.wrapping_add(1_000_000 + i as u64),
                Some(i % recorded.len()),
            )
        }))
        .collect();
    let synthetic: Vec<Scenario> = jobs
        .par_iter()
        .filter_map(|(id, seed, map_of)| {
            let mut rng = ChaCha8Rng::seed_from_u64(*seed);
            let map = match map_of {
                Some(i) => recorded[*i].map.clone(),
                None => {
                    let mix = CrossingMix {
                        unsignalised_share: if plan.driver_choices { UNSIGNALISED_SHARE } else { 0.0 },
                        t_junction_share: plan.t_junction_share,
                        right_turn_lane_share: plan.right_turn_lane_share,
                    };
                    random_template_with(&mut rng, steps, SYNTHETIC_DT_S, mix).1
                }
            };
            traffic.generate(id, map, seed.wrapping_mul(0x9E37_79B9_7F4A_7C15))
        })
        .collect();
    let calibration = Calibration::new(recorded_kinematics, VehicleKinematics::of(&synthetic));
    (synthetic, calibration)
}

/// The scenes of the shards in their fixed order (recorded, then
/// synthetic), each with its metadata entry; the held-out rule counts in
/// each source on its own.
pub fn shard_scenes<'a>(recorded: &'a [Scenario], synthetic: &'a [Scenario]) -> Vec<(&'a Scenario, ShardScene)> {
    let entry = |source: &str, i: usize, s: &Scenario| ShardScene {
        id: s.id.clone(),
        source: source.to_string(),
        split: Split::of(i),
    };
    let recorded_source = |s: &Scenario| {
        if s.source.licence.allows_training_shipped_models() {
            RECORDED_SOURCE
        } else {
            RECORDED_EVALUATION_ONLY_SOURCE
        }
    };
    recorded
        .iter()
        .enumerate()
        .map(|(i, s)| (s, entry(recorded_source(s), i, s)))
        .chain(synthetic.iter().enumerate().map(|(i, s)| (s, entry(SYNTHETIC_SOURCE, i, s))))
        .collect()
}

/// What [`write_shards`] wrote.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ShardTotals {
    /// Samples of training scenes.
    pub train_samples: usize,
    /// Samples of held-out scenes.
    pub held_out_samples: usize,
    /// The shards, in order.
    pub shards: Vec<PathBuf>,
}

/// How the samples of [`write_shards`] are made.
#[derive(Debug, Clone, PartialEq)]
pub struct ShardOptions {
    /// Samples per shard: a new shard once one holds at least this many (checked every 32 scenes).
    pub shard_size: usize,
    /// Drift of the training scenes' reconstructions (held-out scenes stay
    /// undrifted, so the held-out NLL measures the recorded behaviour);
    /// its seed is offset by each scene's position.
    pub drift: Option<TokenDrift>,
    /// What the model trained on them may become.
    pub purpose: TrainingPurpose,
    /// One line on how the data was made, for the model card.
    pub recipe: String,
    /// The `safer prior-dataset` arguments that remake the data (all but
    /// the output folder), for the model card's command.
    pub arguments: String,
}

/// Writes the samples of `scenes` into `out/shard-NNN.safetensors`;
/// `on_shard` hears of each shard written (path, samples).
pub fn write_shards(
    scenes: &[(&Scenario, ShardScene)],
    out: &Path,
    options: &ShardOptions,
    mut on_shard: impl FnMut(&Path, usize),
) -> Result<ShardTotals, DatasetError> {
    let shard_size = options.shard_size;
    let mut totals = ShardTotals::default();
    let new_writer =
        || ShardWriter::new(options.purpose, options.recipe.clone()).with_arguments(options.arguments.clone());
    let mut writer = new_writer();
    let mut flush = |writer: &mut ShardWriter, totals: &mut ShardTotals| -> Result<(), DatasetError> {
        let path = out.join(format!("shard-{:03}.safetensors", totals.shards.len()));
        writer.write(&path)?;
        on_shard(&path, writer.len());
        totals.shards.push(path);
        *writer = new_writer();
        Ok(())
    };
    for (c, chunk) in scenes.chunks(SCENES_PER_CHUNK).enumerate() {
        let samples: Vec<Vec<PriorSample>> = chunk
            .par_iter()
            .enumerate()
            .map(|(k, (s, entry))| {
                let drift = options
                    .drift
                    .filter(|_| entry.split == Split::Train)
                    .map(|d| TokenDrift { seed: d.seed.wrapping_add(((c * SCENES_PER_CHUNK + k) as u64) << 20), ..d });
                scene_samples(s, drift)
            })
            .collect();
        for ((_, entry), samples) in chunk.iter().zip(samples) {
            match entry.split {
                Split::Train => totals.train_samples += samples.len(),
                Split::HeldOut => totals.held_out_samples += samples.len(),
            }
            writer.add_scene(entry.clone(), samples);
        }
        if writer.len() >= shard_size {
            flush(&mut writer, &mut totals)?;
        }
    }
    if !writer.is_empty() {
        flush(&mut writer, &mut totals)?;
    }
    Ok(totals)
}

#[cfg(test)]
mod tests {
    use safetensors::SafeTensors;

    use super::*;
    use crate::motion::tokens::VOCABULARY_SIZE;
    use crate::sim::synthetic::random_template;

    /// A small synthetic scene on a procedural template.
    fn synthetic_scene(seed: u64) -> Scenario {
        let traffic = SyntheticTraffic {
            speeds: SpeedSample::new(vec![8.0, 10.0, 12.0]),
            accel_noise_std_mps2: 0.3,
            duration_s: 4.0,
            max_agents: 6,
            choices: true,
            pedestrian_share: 0.0,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..20)
            .find_map(|k| {
                let (_, map) = random_template(&mut rng, 41, SYNTHETIC_DT_S);
                traffic.generate(&format!("test-{seed}-{k}"), map, seed + k)
            })
            .expect("the generator populates one of 20 templates")
    }

    #[test]
    fn std_dev_of_nothing_is_none_not_zero() {
        assert_eq!(std_dev(&[]), None);
        assert_eq!(std_dev(&[2.0, 4.0]), Some(1.0));
    }

    #[test]
    fn recorded_and_synthetic_scenes_are_split_per_source() {
        let scenes: Vec<Scenario> = (0..2).map(synthetic_scene).collect();
        let recorded: Vec<Scenario> = (0..12).map(|i| scenes[i % 2].clone()).collect();
        let synthetic: Vec<Scenario> = (0..15).map(|i| scenes[i % 2].clone()).collect();
        let entries = shard_scenes(&recorded, &synthetic);
        assert_eq!(entries.len(), 27);
        let held: Vec<(String, usize)> = entries
            .iter()
            .enumerate()
            .filter(|(_, (_, e))| e.split == Split::HeldOut)
            .map(|(k, (_, e))| (e.source.clone(), k))
            .collect();
        // Position 9 of the recorded scenes and position 9 of the synthetic ones (12 + 9).
        assert_eq!(held, vec![(RECORDED_SOURCE.to_string(), 9), (SYNTHETIC_SOURCE.to_string(), 21)]);
    }

    #[test]
    fn a_synthetic_scene_becomes_a_well_formed_shard() {
        let scene = synthetic_scene(7);
        let samples = scene_samples(&scene, None);
        assert!(!samples.is_empty(), "a 4 s scene with moving vehicles has token boundaries");
        let n = samples.len();
        let tmp = tempfile::Builder::new().prefix("safer-datasets-prior-").tempdir().unwrap();
        let dir = tmp.path().to_path_buf();
        let mut written = Vec::new();
        let entries =
            vec![(&scene, ShardScene { id: scene.id.clone(), source: "synthetic".into(), split: Split::HeldOut })];
        let options = ShardOptions {
            shard_size: 1,
            drift: None,
            purpose: TrainingPurpose::Shipped,
            recipe: "test".into(),
            arguments: "--seed 3".into(),
        };
        let totals = write_shards(&entries, &dir, &options, |p, k| written.push((p.to_path_buf(), k))).unwrap();
        assert_eq!(totals.held_out_samples, n);
        assert_eq!(totals.train_samples, 0);
        assert_eq!(written, vec![(dir.join("shard-000.safetensors"), n)]);

        let bytes = std::fs::read(&totals.shards[0]).unwrap();
        let (_, meta) = SafeTensors::read_metadata(&bytes).unwrap();
        let scenes = meta.metadata().as_ref().unwrap()["scenes"].clone();
        assert_eq!(scenes, format!(r#"[{{"id":"{}","source":"synthetic","split":"held-out"}}]"#, scene.id));
        let metadata = meta.metadata().as_ref().unwrap();
        assert_eq!(metadata["purpose"], "shipped");
        assert_eq!(metadata["recipe"], "test");
        assert_eq!(metadata["arguments"], "--seed 3");
        let shard = SafeTensors::deserialize(&bytes).unwrap();
        let expect = [
            ("history", vec![n, HISTORY_POINTS, HISTORY_FEATURES]),
            ("agent_self", vec![n, SELF_FEATURES]),
            ("neighbours", vec![n, NEIGHBOURS, NEIGHBOUR_FEATURES]),
            ("neighbour_pose", vec![n, NEIGHBOURS, POSE_FEATURES]),
            ("neighbour_mask", vec![n, NEIGHBOURS]),
            ("map_tokens", vec![n, MAP_TOKENS, MAP_TOKEN_FEATURES]),
            ("map_pose", vec![n, MAP_TOKENS, POSE_FEATURES]),
            ("map_signal", vec![n, MAP_TOKENS, SIGNAL_FEATURES]),
            ("map_mask", vec![n, MAP_TOKENS]),
        ];
        for (name, shape) in expect {
            let t = shard.tensor(name).unwrap();
            assert_eq!(t.shape(), &shape[..], "{name}");
            let finite = t.data().chunks_exact(4).all(|b| f32::from_le_bytes(b.try_into().unwrap()).is_finite());
            assert!(finite, "{name} holds a non-finite value");
        }
        let i64s = |name: &str| -> Vec<i64> {
            let t = shard.tensor(name).unwrap();
            t.data().chunks_exact(8).map(|b| i64::from_le_bytes(b.try_into().unwrap())).collect()
        };
        let tokens = i64s("next_token");
        assert_eq!(tokens.len(), n);
        assert!(tokens.iter().all(|&t| (0..VOCABULARY_SIZE as i64).contains(&t)));
        assert!(i64s("scene").iter().all(|&s| s == 0));
        let flagged: Vec<i64> = samples.iter().map(|s| i64::from(s.lane_change)).collect();
        assert_eq!(i64s("lane_change"), flagged, "one flag a sample, in the samples' order");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn synthetic_traffic_is_calibrated_against_the_recorded_kinematics() {
        let recorded = vec![synthetic_scene(3)];
        let plan = SyntheticPlan {
            template_scenes: 2,
            recorded_map_scenes: 1,
            seed: 5,
            driver_choices: true,
            t_junction_share: 0.0,
            right_turn_lane_share: 0.0,
            pedestrian_share: 0.0,
        };
        let (synthetic, calibration) = synthetic_scenes(&recorded, plan);
        assert!(!synthetic.is_empty() && synthetic.len() <= 3);
        assert!(!calibration.recorded.is_empty());
        let jsd = calibration.speed_jsd.expect("both sides have speeds");
        assert!((0.0..=1.0).contains(&jsd), "JSD in bits: {jsd}");
        let traffic = calibrated_traffic(&calibration.recorded, true, 0.0);
        let expected = 0.6 * calibration.recorded.accel_std_mps2().unwrap();
        assert!((traffic.accel_noise_std_mps2 - expected).abs() < 1e-12);
    }
}
