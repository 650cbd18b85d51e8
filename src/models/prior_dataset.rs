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
    /// Largest perturbation of the acceleration, in bins (and of the yaw
    /// rate, unless [`TokenDrift::max_yaw_rate_bins`] says otherwise).
    pub max_bins: usize,
    /// Largest perturbation of the yaw rate, in bins, where it differs from
    /// `max_bins` (`None`: the same).
    pub max_yaw_rate_bins: Option<usize>,
    /// Seed of the draws.
    pub seed: u64,
}

impl TokenDrift {
    /// `token` shifted by up to `max_bins` of acceleration and up to the
    /// yaw-rate limit of yaw rate (clamped to the grid), with the drift's
    /// probability.
    fn perturb(&self, rng: &mut ChaCha8Rng, token: Token) -> Token {
        if self.max_bins == 0 || rng.random::<f64>() >= self.probability {
            return token;
        }
        let shift = |bin: usize, k: usize, rng: &mut ChaCha8Rng| {
            let k = k as i64;
            (bin as i64 + rng.random_range(-k..=k)).clamp(0, BINS_PER_AXIS as i64 - 1) as usize
        };
        let a = shift(token.accel_bin(), self.max_bins, rng);
        let y = shift(token.yaw_rate_bin(), self.max_yaw_rate_bins.unwrap_or(self.max_bins), rng);
        Token::from_bins(a, y).unwrap_or(token)
    }
}

impl TokenizedScene {
    /// Every labelled `(step, agent)`: each agent at each token boundary
    /// where the inversion gives its next token, by step, then agent.
    pub fn labelled_boundaries(&self) -> Vec<(usize, usize)> {
        let mut keys: Vec<(usize, usize)> = self.labels.keys().map(|&(agent, step)| (step, agent)).collect();
        keys.sort_unstable();
        keys
    }

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
                // The segment starts at its logged state; the rollout holds
                // the steps after it (start + 1 ..= start + 5·len).
                let states = std::iter::once(segment.initial).chain(segment.rollout());
                for (k, state) in states.enumerate() {
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
    /// Whether the recorded agent is in another lane [`LANE_CHANGE_LOOKAHEAD_S`]
    /// later (a lane change under way or about to start: training may weight
    /// these samples; the prior never reads it).
    pub lane_change: bool,
}

/// How far ahead a sample looks for the lane change it is part of, s: a
/// lane change takes 3–6 s, so the samples of its first half and those
/// just before it look across it.
pub const LANE_CHANGE_LOOKAHEAD_S: f64 = 3.0;

/// Whether the recorded `agent` of `scenario` is in another lane
/// [`LANE_CHANGE_LOOKAHEAD_S`] after `step` than at `step` (false where the
/// track ends sooner or the map has no lane there).
fn changes_lane(scenario: &Scenario, agent: usize, step: usize) -> bool {
    let later = step + (LANE_CHANGE_LOOKAHEAD_S / scenario.dt_s).round() as usize;
    let track = &scenario.tracks[agent];
    match (track.state(step), track.state(later)) {
        (Some(a), Some(b)) => scenario.map.changed_lane((&a.position, a.heading_rad), (&b.position, b.heading_rad)),
        _ => false,
    }
}

/// Every sample of a scene: each agent at each token boundary where it has
/// a label. Ordered by step, then agent. `drift` perturbs the histories
/// (see [`TokenDrift`]).
pub fn scene_samples(scenario: &Scenario, drift: Option<TokenDrift>) -> Vec<PriorSample> {
    let scene = TokenizedScene::drifting(scenario, drift);
    let map = MapTokens::build(&scenario.map);
    scene
        .labelled_boundaries()
        .into_iter()
        .filter_map(|(step, agent)| {
            let query = build_query(&scene, &scene.bodies, &map, &scenario.map, agent, step)?;
            let mut map_tokens = vec![0.0f32; MAP_TOKENS * MAP_TOKEN_FEATURES];
            for (n, &i) in query.map_index.iter().enumerate() {
                if i != u32::MAX {
                    map_tokens[n * MAP_TOKEN_FEATURES..(n + 1) * MAP_TOKEN_FEATURES]
                        .copy_from_slice(&map.tokens[i as usize].features);
                }
            }
            let lane_change = changes_lane(scenario, agent, step);
            Some(PriorSample { query, map_tokens, next_token: scene.labels[&(agent, step)], lane_change })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point2;
    use crate::map::RoadMap;
    use crate::motion::KinematicState;
    use crate::motion::tokens::TokenGrid;
    use crate::scenario::{AgentId, AgentKind, ScenarioSource, Track};

    /// One car driving a gentle left curve, generated by the kinematic model
    /// from a known token, 40 periods long.
    fn curving_scene() -> Scenario {
        let token = Token::from_bins(33, 33).unwrap();
        let mut s = KinematicState { position: Point2::new(0.0, 0.0), heading_rad: 0.0, speed_mps: 9.0 };
        let mut states = vec![Some(s.to_agent_state())];
        for _ in 0..40 {
            let period = TokenGrid::rollout(&s, token);
            states.extend(period.iter().map(|k| Some(k.to_agent_state())));
            s = period[TOKEN_PERIOD_STEPS - 1];
        }
        let track = Track { id: AgentId("car".into()), kind: AgentKind::Vehicle, length_m: 4.5, width_m: 1.9, states };
        Scenario::new("curve", ScenarioSource::authored("test"), 0.1, RoadMap::default(), vec![track])
    }

    #[test]
    fn a_drifting_reconstruction_strays_from_the_log_and_its_labels_steer_back() {
        let scene = curving_scene();
        let clean = TokenizedScene::new(&scene);
        let drift = TokenDrift { probability: 0.5, max_bins: 3, max_yaw_rate_bins: None, seed: 7 };
        let drifted = TokenizedScene::drifting(&scene, Some(drift));
        assert_eq!(clean.labels.len(), drifted.labels.len(), "one label per period either way");
        // The clean reconstruction of a kinematic-model track is exact; the drifted one strays.
        let stray = |t: &TokenizedScene| {
            (0..scene.num_steps())
                .filter_map(|k| Some((t.state(k, 0)?.position - scene.tracks[0].state(k)?.position).norm()))
                .fold(0.0, f64::max)
        };
        assert!(stray(&clean) < 1e-6, "clean reconstruction strays {} m", stray(&clean));
        assert!(stray(&drifted) > 0.01, "drifted reconstruction stays on the log");
        // Labels are the tokens that lead back to the log: never further than the drift from the true one.
        let truth = Token::from_bins(33, 33).unwrap();
        let differing = drifted.labels.values().filter(|&&t| t != truth).count();
        assert!(differing > 0, "some labels correct the drift");
        assert!(stray(&drifted) < 2.0, "corrections keep it near the log: {} m", stray(&drifted));
        // Seeded: the same drift gives the same reconstruction.
        let again = TokenizedScene::drifting(&scene, Some(drift));
        assert_eq!(again.labels, drifted.labels);
        assert_eq!(again.frames, drifted.frames);
    }

    #[test]
    fn a_drift_without_yaw_rate_bins_perturbs_the_acceleration_only() {
        let drift = TokenDrift { probability: 1.0, max_bins: 3, max_yaw_rate_bins: Some(0), seed: 3 };
        let token = Token::from_bins(30, 40).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let drawn: Vec<Token> = (0..200).map(|_| drift.perturb(&mut rng, token)).collect();
        assert!(drawn.iter().all(|t| t.yaw_rate_bin() == 40), "the yaw rate never moves");
        assert!(drawn.iter().all(|t| t.accel_bin().abs_diff(30) <= 3));
        assert!(drawn.iter().any(|t| t.accel_bin() != 30), "the acceleration does");
        // Without its own limit the yaw rate moves as far as the acceleration.
        let both = TokenDrift { max_yaw_rate_bins: None, ..drift };
        let drawn: Vec<Token> = (0..200).map(|_| both.perturb(&mut rng, token)).collect();
        assert!(
            drawn.iter().any(|t| t.yaw_rate_bin() != 40) && drawn.iter().all(|t| t.yaw_rate_bin().abs_diff(40) <= 3)
        );
    }

    #[test]
    fn samples_before_a_recorded_lane_change_are_flagged_and_lane_keeping_ones_are_not() {
        use crate::map::templates::{MapTemplate, StraightRoad};
        let road: StraightRoad = serde_json::from_value(serde_json::json!({"lanes": 2, "length_m": 400})).unwrap();
        // 12 s at 10 m/s: in the right lane (y = 1.75) until 4 s, over to
        // the left one (y = 5.25) by 8 s, then on in it.
        let y = |t: f64| 1.75 + 3.5 * (0.5 - 0.5 * (std::f64::consts::PI * ((t - 4.0) / 4.0).clamp(0.0, 1.0)).cos());
        let states = (0..=120)
            .map(|k| {
                let t = k as f64 * 0.1;
                let heading = (y(t + 0.05) - y(t - 0.05)).atan2(1.0);
                Some(AgentState {
                    position: Point2::new(10.0 + 10.0 * t, y(t)),
                    heading_rad: heading,
                    velocity_mps: crate::geometry::Vector2::new(heading.cos(), heading.sin()) * 10.0,
                })
            })
            .collect();
        let track = Track { id: AgentId("car".into()), kind: AgentKind::Vehicle, length_m: 4.5, width_m: 1.9, states };
        let scene = Scenario::new(
            "lane-change",
            ScenarioSource::authored("test"),
            0.1,
            MapTemplate::Straight(road).build(),
            vec![track],
        );
        let flagged: Vec<(usize, bool)> = TokenizedScene::new(&scene)
            .labelled_boundaries()
            .into_iter()
            .map(|(step, agent)| (step, changes_lane(&scene, agent, step)))
            .collect();
        let at = |step: usize| flagged.iter().find(|(s, _)| *s == step).map(|(_, f)| *f);
        assert_eq!(at(5), Some(false), "3.5 s on it is still in its lane");
        assert_eq!(at(40), Some(true), "where the change starts it is in the other lane 3 s later");
        assert_eq!(at(90), Some(false), "after the change it keeps the new lane");
        assert_eq!(
            scene_samples(&scene, None).iter().filter(|s| s.lane_change).count(),
            flagged.iter().filter(|f| f.1).count()
        );
    }

    #[test]
    fn no_drift_is_the_plain_reconstruction() {
        let scene = curving_scene();
        let off = TokenizedScene::drifting(
            &scene,
            Some(TokenDrift { probability: 0.0, max_bins: 3, max_yaw_rate_bins: None, seed: 1 }),
        );
        let plain = TokenizedScene::new(&scene);
        assert_eq!(off.labels, plain.labels);
        assert_eq!(off.frames, plain.frames);
    }
}
