//! What one training sample of the realism prior is: every (agent, token
//! boundary) of a scene becomes one sample — the
//! [`prior_features`](super::prior_features) of the query and the token the
//! agent applied next, from the log-to-token inversion. Histories come from
//! the *tokenized* tracks (the rollout of the inverted tokens through the
//! kinematic model), because in closed loop the prior sees states the
//! kinematic model produced.
//!
//! The features are the model's input contract, so they live here beside
//! the feature builder; which scenes become shards, their train/held-out
//! split and the shard files are `datasets::prior_shards`.

use std::collections::HashMap;

use super::prior_features::{MAP_TOKEN_FEATURES, MAP_TOKENS, MapTokens, QueryFeatures, StateHistory, build_query};
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
