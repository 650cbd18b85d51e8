//! Agents driven by the learned realism prior: every token period (0.5 s)
//! each prior-driven agent samples its next motion token from the prior's
//! distribution (top-k, temperature), and the kinematic model applies it
//! over the next five 0.1 s steps.
//!
//! All prior-driven agents of one rollout share a [`PriorTraffic`]: the
//! first agent asked at a token boundary builds the queries of all of them
//! and runs the decoder once in a batch; the others read their token. It
//! also keeps the closed-loop history the features need (the log before the
//! rollout's start, the simulated states after). Every draw comes from a
//! generator seeded by (seed, agent, step), so a rollout does not depend on
//! the order agents are asked in or on the thread it runs on.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{AgentAction, AgentPolicy, WorldView};
use crate::models::ModelError;
use crate::models::prior::{MapEmbedding, RealismPrior, TokenLogits};
use crate::models::prior_features::{MapTokens, QueryFeatures, StateHistory, build_query};
use crate::motion::tokens::{TOKEN_PERIOD_STEPS, Token, TokenGrid};
use crate::scenario::{AgentBody, AgentState, Scenario, TrackIndex};

/// How tokens are drawn from the prior's distribution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TokenSampling {
    /// Draw among this many most likely tokens.
    pub top_k: usize,
    /// Softmax temperature (1 = the model's distribution).
    pub temperature: f64,
}

impl Default for TokenSampling {
    fn default() -> Self {
        Self { top_k: 10, temperature: 1.0 }
    }
}

/// The prior's per-scenario inputs, computed once and shared by rollouts.
#[derive(Debug, Clone)]
pub struct ScenarioMapEncoding {
    /// Map tokens.
    pub tokens: Arc<MapTokens>,
    /// Their embeddings.
    pub embedding: Arc<MapEmbedding>,
}

impl ScenarioMapEncoding {
    /// Cuts and encodes the map of `scenario`.
    pub fn new(prior: &RealismPrior, scenario: &Scenario) -> Result<Self, ModelError> {
        let tokens = MapTokens::build(&scenario.map);
        let embedding = prior.encode_map(&tokens)?;
        Ok(Self { tokens: Arc::new(tokens), embedding: Arc::new(embedding) })
    }
}

/// Mixes (seed, agent, step) into one generator seed (SplitMix64 finaliser).
pub fn draw_seed(seed: u64, agent: usize, step: usize) -> u64 {
    let mut z =
        seed ^ (agent as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (step as u64).wrapping_mul(0xD1B5_4A32_D192_ED03);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Tokens ordered by logit, most likely first (ties to the lower id).
pub fn ranked_tokens(logits: &[f32]) -> Vec<Token> {
    let mut ids: Vec<u16> = (0..logits.len() as u16).collect();
    ids.sort_by(|&a, &b| logits[b as usize].total_cmp(&logits[a as usize]).then(a.cmp(&b)));
    ids.into_iter().map(Token).collect()
}

/// The `k` most likely tokens in the order of [`ranked_tokens`], found
/// without sorting the whole vocabulary (a sampled token needs only these;
/// the order is total, so the result is exactly `ranked_tokens(logits)[..k]`).
pub fn top_tokens(logits: &[f32], k: usize) -> Vec<Token> {
    /// Up to this many, the head is kept in one pass over the logits.
    const ONE_PASS_MAX_K: usize = 64;
    let k = k.min(logits.len());
    if k == 0 {
        return Vec::new();
    }
    if k <= ONE_PASS_MAX_K {
        // The best `k` so far, in ranking order. Ids come in increasing
        // order, so a later id enters only with a strictly larger logit
        // (ties go to the lower id), and most are turned away by one
        // comparison with the last kept: a tenth of the time of selecting
        // over the whole vocabulary, which showed in realism rollouts.
        // Once the head is full, whole chunks whose largest logit (in
        // `total_cmp`'s order, through its integer key) does not beat the
        // last kept are turned away at once: a scan the compiler
        // vectorises.
        const CHUNK: usize = 16;
        let mut head: Vec<(f32, u16)> = Vec::with_capacity(k + 1);
        for (c, chunk) in logits.chunks(CHUNK).enumerate() {
            if head.len() == k {
                let chunk_max = chunk.iter().map(|&l| total_order_key(l)).fold(i32::MIN, i32::max);
                if chunk_max <= total_order_key(head[k - 1].0) {
                    continue;
                }
            }
            for (i, &logit) in chunk.iter().enumerate() {
                if head.len() == k && logit.total_cmp(&head[k - 1].0).is_le() {
                    continue;
                }
                let at = head.partition_point(|&(kept, _)| kept.total_cmp(&logit).is_ge());
                head.insert(at, (logit, (c * CHUNK + i) as u16));
                head.truncate(k);
            }
        }
        return head.into_iter().map(|(_, id)| Token(id)).collect();
    }
    let mut ids: Vec<u16> = (0..logits.len() as u16).collect();
    let order = |a: &u16, b: &u16| logits[*b as usize].total_cmp(&logits[*a as usize]).then(a.cmp(b));
    if k < ids.len() {
        ids.select_nth_unstable_by(k - 1, order);
        ids.truncate(k);
    }
    ids.sort_by(order);
    ids.into_iter().map(Token).collect()
}

/// An integer whose order is `f32::total_cmp`'s (the key that function
/// compares).
fn total_order_key(x: f32) -> i32 {
    let bits = x.to_bits() as i32;
    bits ^ (((bits >> 31) as u32) >> 1) as i32
}

/// Draws a token from the top `k` of `logits` at `temperature`.
pub fn sample_token(logits: &[f32], sampling: TokenSampling, rng: &mut impl Rng) -> Token {
    let top = &top_tokens(logits, sampling.top_k.clamp(1, logits.len()))[..];
    let t = sampling.temperature.max(1e-6);
    let best = logits[top[0].0 as usize] as f64;
    let weights: Vec<f64> = top.iter().map(|k| ((logits[k.0 as usize] as f64 - best) / t).exp()).collect();
    let total: f64 = weights.iter().sum();
    let mut u = rng.random::<f64>() * total;
    for (k, w) in top.iter().zip(&weights) {
        if u < *w {
            return *k;
        }
        u -= w;
    }
    top[top.len() - 1]
}

/// The closed-loop state of a rollout as the prior's features read it.
struct RolloutHistory<'a> {
    scenario: &'a Scenario,
    start: usize,
    frames: &'a [Vec<Option<AgentState>>],
}

impl StateHistory for RolloutHistory<'_> {
    fn state(&self, step: usize, agent: usize) -> Option<AgentState> {
        if step < self.start {
            self.scenario.tracks.get(agent).and_then(|t| t.state(step).copied())
        } else {
            self.frames.get(step - self.start).and_then(|f| f.get(agent).copied().flatten())
        }
    }
    fn agents(&self) -> usize {
        self.scenario.tracks.len()
    }
}

/// What the prior-driven agents of one rollout share.
pub struct PriorTraffic {
    prior: Arc<RealismPrior>,
    scenario: Arc<Scenario>,
    map: ScenarioMapEncoding,
    bodies: Vec<AgentBody>,
    start: usize,
    frames: Vec<Vec<Option<AgentState>>>,
    members: Vec<usize>,
    sampling: TokenSampling,
    seed: u64,
    tokens: HashMap<(usize, usize), Token>,
    logits: HashMap<(usize, usize), TokenLogits>,
    error: Option<Arc<ModelError>>,
    timings: TrafficTimings,
    /// (viewer, hidden): the member whose queries do not see the other
    /// agent (see [`PriorTraffic::hide_from`]).
    unseen: Option<(usize, usize)>,
}

/// A history in which one agent is absent: what a viewer that has not
/// noticed it reads.
struct WithoutAgent<'a> {
    history: &'a dyn StateHistory,
    hidden: usize,
}

impl StateHistory for WithoutAgent<'_> {
    fn state(&self, step: usize, agent: usize) -> Option<AgentState> {
        if agent == self.hidden { None } else { self.history.state(step, agent) }
    }
    fn agents(&self) -> usize {
        self.history.agents()
    }
}

/// Where a rollout's learned-model time went, s.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct TrafficTimings {
    /// Building the prior's query features.
    pub features_s: f64,
    /// The prior's decoder.
    pub decoder_s: f64,
    /// Feasibility value queries (the adversary).
    pub feasibility_s: f64,
    /// Decoder calls.
    pub decoder_calls: usize,
}

impl std::fmt::Debug for PriorTraffic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PriorTraffic").field("members", &self.members).field("start", &self.start).finish()
    }
}

impl PriorTraffic {
    /// Shared state for a rollout of `scenario` from `start`; `members` are
    /// the agents the prior drives (kept sorted).
    pub fn new(
        prior: Arc<RealismPrior>,
        scenario: Arc<Scenario>,
        map: ScenarioMapEncoding,
        start: usize,
        members: Vec<usize>,
        sampling: TokenSampling,
        seed: u64,
    ) -> Arc<Mutex<Self>> {
        let bodies = scenario.tracks.iter().map(|t| t.body()).collect();
        let mut members = members;
        members.sort_unstable();
        Arc::new(Mutex::new(Self {
            prior,
            scenario,
            map,
            bodies,
            start,
            frames: Vec::new(),
            members,
            sampling,
            seed,
            tokens: HashMap::new(),
            logits: HashMap::new(),
            error: None,
            timings: TrafficTimings::default(),
            unseen: None,
        }))
    }

    /// Records the world at `world.step` (once per step; repeated calls are no-ops).
    pub fn observe(&mut self, world: &WorldView<'_>) {
        if world.step < self.start {
            return;
        }
        // Every member observes every step, so gaps only appear if none was
        // present for a while; they are filled with the state seen now.
        while self.frames.len() <= world.step - self.start {
            self.frames.push(world.states.to_vec());
        }
    }

    /// Every agent's state at each step observed so far, from the rollout's
    /// first step (the last row is the latest step observed).
    pub fn frames(&self) -> &[Vec<Option<AgentState>>] {
        &self.frames
    }

    /// The logits of `agent` at `step` (computing every member's at once).
    pub fn logits_at(&mut self, agent: usize, step: usize) -> Option<&TokenLogits> {
        if !self.logits.contains_key(&(agent, step)) {
            self.run_decoder(step);
        }
        self.logits.get(&(agent, step))
    }

    /// From now on `viewer`'s queries leave `hidden` out of its
    /// neighbours: the prior predicts `viewer` as a driver who has not
    /// noticed `hidden` (the other members still see it). Logits already
    /// computed stay as they were.
    pub fn hide_from(&mut self, viewer: usize, hidden: usize) {
        self.unseen = Some((viewer, hidden));
    }

    /// The query of every member present at `step`: (agents, features).
    fn queries(&self, step: usize) -> (Vec<usize>, Vec<QueryFeatures>) {
        let history = RolloutHistory { scenario: &self.scenario, start: self.start, frames: &self.frames };
        let mut agents = Vec::new();
        let mut queries = Vec::new();
        for &a in &self.members {
            let without;
            let seen: &dyn StateHistory = match self.unseen {
                Some((viewer, hidden)) if viewer == a => {
                    without = WithoutAgent { history: &history, hidden };
                    &without
                }
                _ => &history,
            };
            if let Some(q) = build_query(seen, &self.bodies, &self.map.tokens, &self.scenario.map, a, step) {
                agents.push(a);
                queries.push(q);
            }
        }
        (agents, queries)
    }

    fn run_decoder(&mut self, step: usize) {
        let clock = std::time::Instant::now();
        let (agents, queries) = self.queries(step);
        let refs: Vec<_> = queries.iter().collect();
        let features_done = std::time::Instant::now();
        self.timings.features_s += (features_done - clock).as_secs_f64();
        let result = self.prior.logits(&refs, &self.map.embedding);
        self.timings.decoder_s += features_done.elapsed().as_secs_f64();
        self.timings.decoder_calls += 1;
        match result {
            Ok(all) => {
                self.keep_logits_of(step);
                for (a, l) in agents.into_iter().zip(all) {
                    self.logits.insert((a, step), l);
                }
            }
            Err(e) => self.record_error(Arc::new(e)),
        }
    }

    /// Drops the logits of every boundary but `step`'s. Only the current
    /// boundary's are ever asked for (a past boundary's tokens are kept in
    /// `tokens`), and keeping them all held some 800 MB for 32 rollouts of
    /// a busy WOMD scene.
    fn keep_logits_of(&mut self, step: usize) {
        self.logits.retain(|&(_, s), _| s == step);
    }

    fn token(&mut self, agent: usize, step: usize) -> Option<Token> {
        if let Some(t) = self.tokens.get(&(agent, step)) {
            return Some(*t);
        }
        let sampling = self.sampling;
        let seed = draw_seed(self.seed, agent, step);
        let logits = self.logits_at(agent, step)?;
        let token = sample_token(logits, sampling, &mut ChaCha8Rng::seed_from_u64(seed));
        self.tokens.insert((agent, step), token);
        Some(token)
    }

    /// How the rollout's tokens are drawn.
    pub fn sampling(&self) -> TokenSampling {
        self.sampling
    }

    /// The rollout's seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The rollout's first step.
    pub fn start(&self) -> usize {
        self.start
    }

    /// The scenario being rolled out.
    pub fn scenario(&self) -> &Arc<Scenario> {
        &self.scenario
    }

    /// The agents the prior drives, sorted.
    pub fn members(&self) -> &[usize] {
        &self.members
    }

    /// Keeps the first error met by an agent of this rollout.
    pub fn record_error(&mut self, error: Arc<ModelError>) {
        self.error.get_or_insert(error);
    }

    /// Adds time spent on feasibility queries.
    pub fn add_feasibility_time(&mut self, seconds: f64) {
        self.timings.feasibility_s += seconds;
    }

    /// Where this rollout's model time went.
    pub fn timings(&self) -> TrafficTimings {
        self.timings
    }

    /// The first inference error, if any (the rollout should be reported failed).
    pub fn error(&self) -> Option<&Arc<ModelError>> {
        self.error.as_ref()
    }
}

/// Runs the decoder once for every rollout of a scene at a token boundary:
/// `traffics[r]` is rollout `r`'s shared state and `worlds[r]` its world
/// now (as [`crate::sim::traffic::simulate_rollouts_in_lockstep`] gives
/// them before the agents act). All rollouts' queries go into the decoder
/// together, in full batches, and a query equal to rollout 0's query of the
/// same agent (every rollout's first boundary, where no rollout has moved
/// yet) is decoded once. Each rollout then finds its logits as if its first
/// agent had run the decoder for it: the same queries, and the same logits,
/// since the decoder computes each query's row alone whatever the batch.
/// Off a boundary, or for rollouts of different priors or maps, nothing is
/// done and the agents decode lazily as before.
pub fn decode_rollouts_together(traffics: &[Arc<Mutex<PriorTraffic>>], worlds: &[WorldView<'_>]) {
    let Some(first) = traffics.first() else { return };
    let Some(step) = worlds.first().map(|w| w.step) else { return };
    let (prior, map) = {
        let t = first.lock().unwrap_or_else(|p| p.into_inner());
        if step < t.start || !(step - t.start).is_multiple_of(TOKEN_PERIOD_STEPS) {
            return;
        }
        (t.prior.clone(), t.map.clone())
    };
    let clock = std::time::Instant::now();
    // Per rollout: (agent, index into `unique`) of each query.
    let mut slots: Vec<Vec<(usize, usize)>> = Vec::with_capacity(traffics.len());
    let mut unique: Vec<QueryFeatures> = Vec::new();
    let mut first_rollout: HashMap<usize, usize> = HashMap::new();
    for (r, (traffic, world)) in traffics.iter().zip(worlds).enumerate() {
        let mut t = traffic.lock().unwrap_or_else(|p| p.into_inner());
        let shares = Arc::ptr_eq(&t.prior, &prior) && Arc::ptr_eq(&t.map.embedding, &map.embedding);
        if world.step != step || t.start > step || !shares || t.error.is_some() {
            slots.push(Vec::new());
            continue;
        }
        t.observe(world);
        let (agents, queries) = t.queries(step);
        let mut mine = Vec::with_capacity(agents.len());
        for (a, q) in agents.into_iter().zip(queries) {
            let same = first_rollout.get(&a).filter(|&&i| r > 0 && unique[i] == q).copied();
            let index = same.unwrap_or_else(|| {
                unique.push(q);
                unique.len() - 1
            });
            if r == 0 {
                first_rollout.insert(a, index);
            }
            mine.push((a, index));
        }
        slots.push(mine);
    }
    let features_done = std::time::Instant::now();
    let refs: Vec<&QueryFeatures> = unique.iter().collect();
    let result = prior.logits(&refs, &map.embedding);
    let share = traffics.len().max(1) as f64;
    let (features_s, decoder_s) =
        ((features_done - clock).as_secs_f64() / share, features_done.elapsed().as_secs_f64() / share);
    let result = result.map_err(Arc::new);
    for (traffic, mine) in traffics.iter().zip(slots) {
        let mut t = traffic.lock().unwrap_or_else(|p| p.into_inner());
        t.timings.features_s += features_s;
        t.timings.decoder_s += decoder_s;
        match &result {
            Ok(all) => {
                t.keep_logits_of(step);
                for (a, i) in mine {
                    t.logits.insert((a, step), all[i].clone());
                }
            }
            Err(e) => t.record_error(e.clone()),
        }
    }
}

/// One agent driven by the prior through a shared [`PriorTraffic`].
#[derive(Debug)]
pub struct PriorAgent {
    shared: Arc<Mutex<PriorTraffic>>,
    current: Option<Token>,
}

impl PriorAgent {
    /// An agent policy reading from `shared`.
    pub fn new(shared: Arc<Mutex<PriorTraffic>>) -> Self {
        Self { shared, current: None }
    }
}

impl AgentPolicy for PriorAgent {
    fn name(&self) -> &'static str {
        "prior"
    }

    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
        let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
        shared.observe(world);
        if world.state(agent).is_none() {
            return AgentAction::Absent;
        }
        let boundary = (world.step - shared.start.min(world.step)).is_multiple_of(TOKEN_PERIOD_STEPS);
        if boundary || self.current.is_none() {
            self.current = shared.token(agent.0, world.step).or(self.current);
        }
        // Without a token (inference failed; the error is kept for the
        // report), the agent holds its speed rather than inventing motion.
        AgentAction::Control(self.current.map(TokenGrid::action).unwrap_or_default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn top_k_sampling_never_leaves_the_top_k() {
        let logits: Vec<f32> = (0..100).map(|i| i as f32 * 0.1).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for _ in 0..200 {
            let t = sample_token(&logits, TokenSampling { top_k: 3, temperature: 1.0 }, &mut rng);
            assert!(t.0 >= 97, "{t:?}");
        }
    }

    #[test]
    fn top_tokens_are_the_head_of_the_ranking_ties_included() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..50 {
            // Few distinct values: many ties, broken by the lower id.
            let logits: Vec<f32> = (0..300).map(|_| (rng.random::<u8>() % 7) as f32 * 0.5).collect();
            let ranked = ranked_tokens(&logits);
            for k in [1, 2, 10, 63, 64, 65, 299, 300, 400] {
                assert_eq!(top_tokens(&logits, k), ranked[..k.min(300)], "k {k}");
            }
        }
        assert!(top_tokens(&[], 3).is_empty());
    }

    #[test]
    fn top_tokens_follow_total_order_across_skipped_chunks() {
        // Signed zeros, infinities and NaNs of both signs rank as
        // `total_cmp` ranks them, whether a chunk is scanned or skipped.
        let special = [0.0, -0.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, -f32::NAN, f32::MIN_POSITIVE];
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for _ in 0..50 {
            let logits: Vec<f32> = (0..3969)
                .map(|_| match rng.random::<u8>() % 16 {
                    0 => special[rng.random::<u8>() as usize % special.len()],
                    _ => (rng.random::<f32>() - 0.5) * 40.0,
                })
                .collect();
            let ranked = ranked_tokens(&logits);
            for k in [1, 5, 20, 64] {
                assert_eq!(top_tokens(&logits, k), ranked[..k], "k {k}");
            }
        }
    }

    #[test]
    fn a_cold_temperature_takes_the_most_likely_token() {
        let mut logits = vec![0.0f32; 50];
        logits[17] = 2.0;
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let t = sample_token(&logits, TokenSampling { top_k: 10, temperature: 1e-3 }, &mut rng);
        assert_eq!(t, Token(17));
    }

    /// A shipped NGSIM scene with the shipped differential prior and its map encoding.
    fn ngsim_scene_with_prior() -> (Arc<Scenario>, Arc<RealismPrior>, ScenarioMapEncoding) {
        use crate::models::ModelSource;
        use crate::models::prior::PriorVariant;
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/ngsim/USA_US101-15_1_T-1.xml");
        let scenario = Arc::new(crate::scenario::import::load(&path).unwrap().remove(0));
        let prior = Arc::new(RealismPrior::load(&ModelSource::shipped(), PriorVariant::Differential).unwrap());
        let map = ScenarioMapEncoding::new(&prior, &scenario).unwrap();
        (scenario, prior, map)
    }

    /// Rollouts decoded together (every rollout's agents in one batch per
    /// token boundary, the first boundary decoded once) move exactly as
    /// rollouts decoded alone, one decoder call per boundary each.
    #[test]
    fn rollouts_decoded_together_equal_rollouts_decoded_alone() {
        use crate::sim::traffic::{simulate_all_agents, simulate_rollouts_in_lockstep};
        let (scenario, prior, map) = ngsim_scene_with_prior();
        let (start, end, rollouts) = (10, 30, 3);
        let members: Vec<usize> =
            (0..scenario.tracks.len()).filter(|&i| scenario.tracks[i].state(start).is_some()).collect();
        assert!(members.len() > 1, "the scene needs several agents");
        let traffic = |r: usize| {
            let sampling = TokenSampling::default();
            PriorTraffic::new(prior.clone(), scenario.clone(), map.clone(), start, members.clone(), sampling, r as u64)
        };
        let together: Vec<_> = (0..rollouts).map(traffic).collect();
        let batched = simulate_rollouts_in_lockstep(
            &scenario,
            start,
            end,
            rollouts,
            |r, _| -> Box<dyn AgentPolicy> { Box::new(PriorAgent::new(together[r].clone())) },
            |worlds| decode_rollouts_together(&together, worlds),
        )
        .unwrap();
        for (r, shared) in together.iter().enumerate() {
            let alone = traffic(r);
            let states =
                simulate_all_agents(&scenario, start, end, |_| Box::new(PriorAgent::new(alone.clone()))).unwrap();
            assert_eq!(states, batched[r], "rollout {r}");
            let t = shared.lock().unwrap();
            assert!(t.error().is_none());
            assert_eq!(t.timings().decoder_calls, 0, "rollout {r} decoded on its own");
            assert_eq!(alone.lock().unwrap().timings().decoder_calls, (end - start) / TOKEN_PERIOD_STEPS);
            // Only the last boundary's logits are kept, batched or alone;
            // every boundary's tokens are.
            let last_boundary = start + (end - 1 - start) / TOKEN_PERIOD_STEPS * TOKEN_PERIOD_STEPS;
            for kept in [&*t, &*alone.lock().unwrap()] {
                assert!(!kept.logits.is_empty());
                assert!(kept.logits.keys().all(|&(_, step)| step == last_boundary), "rollout {r}");
                assert!(kept.tokens.keys().any(|&(_, step)| step == start), "rollout {r}");
            }
        }
        assert_ne!(batched[0], batched[1], "different seeds, different rollouts");
    }

    /// An agent hidden from a viewer is missing from the viewer's
    /// neighbours only: the other members still see it.
    #[test]
    fn an_agent_hidden_from_the_viewer_is_gone_from_its_query_only() {
        use crate::models::prior_features::{NEIGHBOUR_RADIUS_M, NEIGHBOURS, POSE_FEATURES};
        let (scenario, prior, map) = ngsim_scene_with_prior();
        let start = 10;
        let states: Vec<Option<AgentState>> = scenario.tracks.iter().map(|t| t.state(start).copied()).collect();
        let bodies: Vec<AgentBody> = scenario.tracks.iter().map(|t| t.body()).collect();
        let present: Vec<usize> = (0..states.len()).filter(|&i| states[i].is_some()).collect();
        let distance = |i: usize, j: usize| (states[i].unwrap().position - states[j].unwrap().position).norm();
        // The viewer, its nearest neighbour (hidden from it), and another
        // agent that sees the hidden one too.
        let viewer = present[0];
        let hidden = *present
            .iter()
            .filter(|&&j| j != viewer)
            .min_by(|&&a, &&b| distance(viewer, a).total_cmp(&distance(viewer, b)))
            .unwrap();
        let other =
            *present.iter().find(|&&j| j != viewer && j != hidden && distance(j, hidden) < NEIGHBOUR_RADIUS_M).unwrap();
        let queries = |hide: bool| {
            let traffic = PriorTraffic::new(
                prior.clone(),
                scenario.clone(),
                map.clone(),
                start,
                vec![viewer, other],
                TokenSampling::default(),
                0,
            );
            let mut t = traffic.lock().unwrap();
            if hide {
                t.hide_from(viewer, hidden);
            }
            t.observe(&WorldView { map: &scenario.map, step: start, bodies: &bodies, states: &states });
            let (agents, queries) = t.queries(start);
            assert_eq!(agents, vec![viewer.min(other), viewer.max(other)]);
            agents.into_iter().zip(queries).collect::<std::collections::HashMap<_, _>>()
        };
        let (seen, unseen) = (queries(false), queries(true));
        // The hidden agent's position in the viewer's frame, among its neighbours' poses.
        let now = states[viewer].unwrap();
        let frame = crate::geometry::Pose2 { position: now.position, heading_rad: now.heading_rad };
        let at = frame.to_body(&states[hidden].unwrap().position);
        let holds_hidden = |q: &QueryFeatures| {
            (0..NEIGHBOURS).any(|n| {
                q.neighbour_mask[n] == 1.0
                    && q.neighbour_pose[n * POSE_FEATURES] == at.x as f32
                    && q.neighbour_pose[n * POSE_FEATURES + 1] == at.y as f32
            })
        };
        assert!(holds_hidden(&seen[&viewer]), "the viewer sees its nearest neighbour");
        assert!(!holds_hidden(&unseen[&viewer]), "hidden from the viewer");
        assert_eq!(seen[&other].neighbours, unseen[&other].neighbours, "the other member still sees it");
        assert_eq!(seen[&other].neighbour_pose, unseen[&other].neighbour_pose);
    }

    #[test]
    fn draw_seeds_differ_by_agent_and_step() {
        assert_ne!(draw_seed(1, 2, 3), draw_seed(1, 3, 2));
        assert_ne!(draw_seed(1, 2, 3), draw_seed(2, 2, 3));
        assert_eq!(draw_seed(1, 2, 3), draw_seed(1, 2, 3));
    }
}
