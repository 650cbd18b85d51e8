//! Training shards for the realism prior: every (agent, token boundary) of a
//! scene becomes one sample — the [`prior_features`](super::prior_features)
//! of the query and the token the agent applied next, from the log-to-token
//! inversion. Histories come from the *tokenized* tracks (the rollout of
//! the inverted tokens through the kinematic model), because in closed loop
//! the prior sees states the kinematic model produced.
//!
//! Shards are safetensors files that `training/prior/` reads; the metadata
//! key `scenes` lists each scene's id, source and split.

use std::collections::HashMap;
use std::path::Path;

use super::ModelError;
use super::prior_features::{
    HISTORY_FEATURES, HISTORY_POINTS, MAP_TOKEN_FEATURES, MAP_TOKENS, MapTokens, NEIGHBOUR_FEATURES, NEIGHBOURS,
    POSE_FEATURES, QueryFeatures, SELF_FEATURES, SIGNAL_FEATURES, StateHistory, build_query,
};
use super::shard::{ShardColumn, write_shard};
use crate::motion::tokens::TOKEN_PERIOD_STEPS;
use crate::motion::{Token, tokenize_track};
use crate::scenario::{AgentBody, AgentState, Scenario};

/// A scene's tracks after the log → token → log round trip, with the token
/// each agent applied from each token boundary.
#[derive(Debug, Clone)]
pub struct TokenizedScene {
    /// `frames[step][agent]`: reconstructed state.
    pub frames: Vec<Vec<Option<AgentState>>>,
    /// Token applied by `agent` from `step` (a token boundary) on.
    pub labels: HashMap<(usize, usize), Token>,
    /// Bodies, indexed like the tracks.
    pub bodies: Vec<AgentBody>,
}

impl StateHistory for TokenizedScene {
    fn state(&self, step: usize, agent: usize) -> Option<AgentState> {
        self.frames.get(step).and_then(|f| f.get(agent).copied().flatten())
    }
    fn agents(&self) -> usize {
        self.bodies.len()
    }
}

impl TokenizedScene {
    /// Tokenizes every track on periods aligned to the scene's current step.
    pub fn new(scenario: &Scenario) -> Self {
        let steps = scenario.num_steps();
        let agents = scenario.tracks.len();
        let mut frames = vec![vec![None; agents]; steps];
        let mut labels = HashMap::new();
        for (i, track) in scenario.tracks.iter().enumerate() {
            for segment in tokenize_track(track, scenario.current_step).segments {
                for (k, state) in segment.rollout().iter().enumerate() {
                    if let Some(row) = frames.get_mut(segment.start_step + k) {
                        row[i] = Some(state.to_agent_state());
                    }
                }
                for (j, token) in segment.tokens.iter().enumerate() {
                    labels.insert((i, segment.start_step + j * TOKEN_PERIOD_STEPS), *token);
                }
            }
        }
        Self { frames, labels, bodies: scenario.tracks.iter().map(|t| t.body()).collect() }
    }
}

/// One training sample: a query's features (map tokens gathered as their
/// pose-free features) and its label.
#[derive(Debug, Clone)]
pub struct PriorSample {
    /// The query's features.
    pub query: QueryFeatures,
    /// Pose-free features of the gathered map tokens, [MAP_TOKENS × MAP_TOKEN_FEATURES].
    pub map_tokens: Vec<f32>,
    /// The token applied next.
    pub next_token: Token,
}

/// Every sample of a scene: each agent at each token boundary where it has
/// a label. Ordered by step, then agent.
pub fn scene_samples(scenario: &Scenario) -> Vec<PriorSample> {
    let scene = TokenizedScene::new(scenario);
    let map = MapTokens::build(&scenario.map);
    let mut keys: Vec<(usize, usize)> = scene.labels.keys().map(|&(agent, step)| (step, agent)).collect();
    keys.sort_unstable();
    keys.into_iter()
        .filter_map(|(step, agent)| {
            let query = build_query(&scene, &scene.bodies, &map, &scenario.map, agent, step)?;
            let mut map_tokens = vec![0.0f32; MAP_TOKENS * MAP_TOKEN_FEATURES];
            for (n, &i) in query.map_index.iter().enumerate() {
                if i != u32::MAX {
                    map_tokens[n * MAP_TOKEN_FEATURES..(n + 1) * MAP_TOKEN_FEATURES]
                        .copy_from_slice(&map.tokens[i as usize].features);
                }
            }
            Some(PriorSample { query, map_tokens, next_token: scene.labels[&(agent, step)] })
        })
        .collect()
}

/// Which part of the data a scene belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Split {
    /// Used for training.
    Train,
    /// Held out for evaluation.
    HeldOut,
}

/// A scene's entry in a shard's metadata.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ShardScene {
    /// Scenario id.
    pub id: String,
    /// Where it came from (e.g. `ngsim`, `synthetic`).
    pub source: String,
    /// Train or held out.
    pub split: Split,
}

/// Accumulates samples and writes them as one safetensors shard.
#[derive(Debug, Default)]
pub struct ShardWriter {
    scenes: Vec<ShardScene>,
    samples: Vec<(usize, PriorSample)>,
}

impl ShardWriter {
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
    pub fn write(&self, path: &Path) -> Result<(), ModelError> {
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
            next_token.push(sample.next_token.0 as i64);
            scene.push(*s as i64);
        }
        let columns: Vec<ShardColumn> = cols
            .into_iter()
            .map(|(name, v, shape)| ShardColumn::f32(name, shape, &v))
            .chain([ShardColumn::i64("next_token", vec![n], &next_token), ShardColumn::i64("scene", vec![n], &scene)])
            .collect();
        let scenes = serde_json::to_string(&self.scenes)
            .map_err(|e| ModelError::Shard { path: path.to_path_buf(), message: e.to_string() })?;
        let metadata =
            HashMap::from([("scenes".to_string(), scenes), ("contract_version".to_string(), "1".to_string())]);
        write_shard(path, &columns, metadata)
    }
}
