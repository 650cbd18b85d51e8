//! What one training sample of the realism prior is: every (agent, token
//! boundary) of a scene becomes one sample — the
//! [`prior_features`](super::prior_features) of the query and the token the
//! agent applied next, from the log-to-token inversion. Histories come from
//! the *tokenized* tracks (the rollout of the inverted tokens through the
//! kinematic model), because in closed loop the prior sees states the
//! kinematic model produced. With [`TokenDrift`] the reconstruction also
//! applies perturbed tokens now and then while the labels stay the intended
//! ones, so the prior sees drifted histories and learns the tokens that
//! steer back (the rollout-noise remedy of next-token traffic models).
//!
//! The features are the model's input contract, so they live here beside
//! the feature builder; which scenes become shards, their train/held-out
//! split and the shard files are `datasets::prior_shards`.

use std::collections::HashMap;

use super::prior_features::{MAP_TOKEN_FEATURES, MAP_TOKENS, MapTokens, QueryFeatures, StateHistory, build_query};
use crate::motion::tokens::TOKEN_PERIOD_STEPS;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::motion::tokens::BINS_PER_AXIS;
use crate::motion::{Token, tokenize_track_drifting};
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

/// How often and how far the reconstruction of a training scene strays
/// from each period's best token.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TokenDrift {
    /// Chance that a period applies a perturbed token.
    pub probability: f64,
    /// Largest perturbation, in bins on each axis (acceleration, yaw rate).
    pub max_bins: usize,
    /// Seed of the draws.
    pub seed: u64,
}

impl TokenDrift {
    /// `token` shifted by up to `max_bins` on each axis (clamped to the
    /// grid), with the drift's probability.
    fn perturb(&self, rng: &mut ChaCha8Rng, token: Token) -> Token {
        if self.max_bins == 0 || rng.random::<f64>() >= self.probability {
            return token;
        }
        let k = self.max_bins as i64;
        let shift = |bin: usize, rng: &mut ChaCha8Rng| {
            (bin as i64 + rng.random_range(-k..=k)).clamp(0, BINS_PER_AXIS as i64 - 1) as usize
        };
        let (a, y) = (shift(token.accel_bin(), rng), shift(token.yaw_rate_bin(), rng));
        Token::from_bins(a, y).unwrap_or(token)
    }
}

impl TokenizedScene {
    /// Tokenizes every track on periods aligned to the scene's current step.
    pub fn new(scenario: &Scenario) -> Self {
        Self::drifting(scenario, None)
    }

    /// [`TokenizedScene::new`], with the reconstruction drifting by `drift`
    /// (labels stay each period's best token).
    pub fn drifting(scenario: &Scenario, drift: Option<TokenDrift>) -> Self {
        let steps = scenario.num_steps();
        let agents = scenario.tracks.len();
        let mut frames = vec![vec![None; agents]; steps];
        let mut labels = HashMap::new();
        for (i, track) in scenario.tracks.iter().enumerate() {
            let mut rng = ChaCha8Rng::seed_from_u64(drift.map_or(0, |d| d.seed).wrapping_add(i as u64));
            let (tokenized, intended) = tokenize_track_drifting(track, scenario.current_step, &mut |t| match drift {
                Some(d) => d.perturb(&mut rng, t),
                None => t,
            });
            for (segment, best) in tokenized.segments.iter().zip(&intended) {
                for (k, state) in segment.rollout().iter().enumerate() {
                    if let Some(row) = frames.get_mut(segment.start_step + k) {
                        row[i] = Some(state.to_agent_state());
                    }
                }
                for (j, token) in best.iter().enumerate() {
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
/// a label. Ordered by step, then agent. `drift` perturbs the histories
/// (see [`TokenDrift`]).
pub fn scene_samples(scenario: &Scenario, drift: Option<TokenDrift>) -> Vec<PriorSample> {
    let scene = TokenizedScene::drifting(scenario, drift);
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
