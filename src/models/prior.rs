//! The realism prior at inference: the map encoder, run once per scenario
//! over all its map tokens, and the decoder, run for just the agents whose
//! next token is needed (one CBV query, or every prior-driven agent in
//! chunks). Both graphs are loaded once, checked against their cards, and
//! shared read-only by every worker thread.

use std::path::Path;
use std::sync::{Arc, OnceLock};

use tract_onnx::prelude::*;

use super::card::{DType, ExpectedContract, ModelCard, ModelKind};
use super::onnx::{NodeCost, OnnxModel, f32_values};
use super::prior_features::{
    HISTORY_FEATURES, HISTORY_POINTS, MAP_ENCODER_CHUNK, MAP_TOKENS, MapTokenWidth, MapTokens, NEIGHBOUR_FEATURES,
    NEIGHBOURS, POSE_FEATURES, QueryFeatures, SELF_FEATURES, SIGNAL_FEATURES,
};
use super::{Dim, ModelError, ModelSource};
use crate::motion::tokens::VOCABULARY_SIZE;

/// Which decoder: the paper's differential attention, or plain attention
/// (the `no-mda` ablation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PriorVariant {
    /// Multi-head differential attention (the default).
    Differential,
    /// Plain multi-head attention of the same size.
    Plain,
}

impl PriorVariant {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Differential, Self::Plain];
}

impl PriorVariant {
    /// File stems of (map encoder, decoder) in `models/`.
    pub fn stems(self) -> (&'static str, &'static str) {
        match self {
            Self::Differential => ("prior-map-encoder", "prior-decoder"),
            Self::Plain => ("prior-map-encoder-plain", "prior-decoder-plain"),
        }
    }
}

/// Decoder batch for full-scene steps; smaller batches are padded.
pub const SCENE_BATCH: usize = 32;

/// Decoder batch for what is left after the full [`SCENE_BATCH`] chunks
/// (padded), so a tail of a few queries does not pay for 32 rows. Each
/// query's logits are the same bits at batch 1, 8 and 32 (tract computes
/// the rows independently; checked by `batch_sizes_give_identical_logits`).
pub const TAIL_BATCH: usize = 8;

/// The map embedding of one scenario: one row of width `d` per map token.
#[derive(Debug, Clone)]
pub struct MapEmbedding {
    /// Row-major [tokens × d].
    pub rows: Vec<f32>,
    /// Embedding width.
    pub d: usize,
}

/// Per-token logits of one query ([`VOCABULARY_SIZE`] values). Shared, not
/// copied: a rollout batch decodes thousands of queries per token
/// boundary, and each is read by its agent, the adversary and profilers.
pub type TokenLogits = Arc<[f32]>;

/// The loaded prior.
#[derive(Debug, Clone)]
pub struct RealismPrior {
    variant: PriorVariant,
    map_encoder: OnnxModel,
    decoder_single: OnnxModel,
    /// The decoder at [`SCENE_BATCH`] and [`TAIL_BATCH`], optimised on first
    /// use (from the graph parsed for batch 1): a CBV-only user such as the
    /// adversary never pays for them.
    decoder_scene: OnceLock<OnnxModel>,
    decoder_tail: OnceLock<OnnxModel>,
    d: usize,
    map_token_width: MapTokenWidth,
}

/// What this build expects of a map encoder that reads `width` values per
/// map token.
pub fn map_encoder_contract(width: MapTokenWidth) -> ExpectedContract {
    ExpectedContract {
        kind: ModelKind::RealismPriorMapEncoder,
        inputs: vec![("map_tokens", DType::F32, vec![Some(MAP_ENCODER_CHUNK), Some(width.values())])],
        outputs: vec![("map_embedding", DType::F32, vec![Some(MAP_ENCODER_CHUNK), None])],
        speaks_tokens: false,
    }
}

/// What this build expects of a decoder.
pub fn decoder_contract() -> ExpectedContract {
    ExpectedContract {
        kind: ModelKind::RealismPriorDecoder,
        inputs: vec![
            ("history", DType::F32, vec![None, Some(HISTORY_POINTS), Some(HISTORY_FEATURES)]),
            ("agent_self", DType::F32, vec![None, Some(SELF_FEATURES)]),
            ("neighbours", DType::F32, vec![None, Some(NEIGHBOURS), Some(NEIGHBOUR_FEATURES)]),
            ("neighbour_pose", DType::F32, vec![None, Some(NEIGHBOURS), Some(POSE_FEATURES)]),
            ("neighbour_mask", DType::F32, vec![None, Some(NEIGHBOURS)]),
            ("map_embedding", DType::F32, vec![None, Some(MAP_TOKENS), None]),
            ("map_pose", DType::F32, vec![None, Some(MAP_TOKENS), Some(POSE_FEATURES)]),
            ("map_signal", DType::F32, vec![None, Some(MAP_TOKENS), Some(SIGNAL_FEATURES)]),
            ("map_mask", DType::F32, vec![None, Some(MAP_TOKENS)]),
        ],
        outputs: vec![("logits", DType::F32, vec![None, Some(VOCABULARY_SIZE)])],
        speaks_tokens: true,
    }
}

impl RealismPrior {
    /// Loads `variant` from `source` (usually [`ModelSource::shipped`]).
    pub fn load(source: &ModelSource, variant: PriorVariant) -> Result<Self, ModelError> {
        let (enc, dec) = variant.stems();
        let card_file = |stem: &str| format!("{stem}.card.yaml");
        let card = |stem: &str| source.path(Path::new(&card_file(stem)));
        // The encoder's card says which map-token values it reads.
        let enc_card_path = card(enc);
        let enc_card = ModelCard::parse(&source.read(Path::new(&card_file(enc)))?, &enc_card_path)?;
        let width = enc_card.inputs.first().and_then(|i| i.shape.get(1));
        let map_token_width = match width {
            Some(Dim::Fixed(w)) => MapTokenWidth::from_values(*w),
            _ => None,
        }
        .ok_or_else(|| ModelError::CardMismatch {
            path: enc_card_path.clone(),
            field: "inputs[0].shape[1] (values per map token)".into(),
            expected: format!(
                "{} (feature contract 1) or {} (2, with the lane's turn ahead)",
                MapTokenWidth::Base.values(),
                MapTokenWidth::WithTurnAhead.values()
            ),
            found: format!("{width:?}"),
        })?;
        let map_encoder =
            OnnxModel::load(source, card_file(enc), &map_encoder_contract(map_token_width), MAP_ENCODER_CHUNK)?;
        let d = match map_encoder.card().outputs[0].shape.get(1) {
            Some(Dim::Fixed(d)) => *d,
            other => {
                return Err(ModelError::CardMismatch {
                    path: card(enc),
                    field: "outputs[0].shape[1]".into(),
                    expected: "a fixed embedding width".into(),
                    found: format!("{other:?}"),
                });
            }
        };
        let decoder_single = OnnxModel::load(source, card_file(dec), &decoder_contract(), 1)?;
        let width_ok = matches!(decoder_single.card().inputs[5].shape.get(2), Some(Dim::Fixed(w)) if *w == d);
        if !width_ok {
            return Err(ModelError::CardMismatch {
                path: card(dec),
                field: "inputs[5].shape[2] (map_embedding width)".into(),
                expected: format!("{d} (the map encoder's output width)"),
                found: format!("{:?}", decoder_single.card().inputs[5].shape.get(2)),
            });
        }
        Ok(Self {
            variant,
            map_encoder,
            decoder_single,
            decoder_scene: OnceLock::new(),
            decoder_tail: OnceLock::new(),
            d,
            map_token_width,
        })
    }

    /// Which decoder this is.
    pub fn variant(&self) -> PriorVariant {
        self.variant
    }

    /// Which map-token values the map encoder reads.
    pub fn map_token_width(&self) -> MapTokenWidth {
        self.map_token_width
    }

    /// The map encoder (for golden replay).
    pub fn map_encoder(&self) -> &OnnxModel {
        &self.map_encoder
    }

    /// The decoder loaded for batch 1 (for golden replay).
    pub fn decoder(&self) -> &OnnxModel {
        &self.decoder_single
    }

    /// Embeds every map token of a scenario (once per scenario).
    pub fn encode_map(&self, tokens: &MapTokens) -> Result<MapEmbedding, ModelError> {
        let w = self.map_token_width.values();
        let input = tokens.encoder_input(self.map_token_width);
        let mut rows = Vec::with_capacity(tokens.tokens.len() * self.d);
        for chunk in input.chunks(MAP_ENCODER_CHUNK * w) {
            let t = Tensor::from_shape(&[MAP_ENCODER_CHUNK, w], chunk).map_err(|e| self.input_error(e))?;
            let out = self.map_encoder.run(tvec!(t.into_tvalue()))?;
            rows.extend(f32_values(&out[0]).map_err(|e| self.input_error(e))?);
        }
        rows.truncate(tokens.tokens.len() * self.d);
        Ok(MapEmbedding { rows, d: self.d })
    }

    fn input_error(&self, e: impl std::fmt::Display) -> ModelError {
        ModelError::Input { model: self.decoder_single.card().name.clone(), message: e.to_string() }
    }

    /// Next-token logits of each query, in order: chunks of
    /// [`SCENE_BATCH`], the rest in chunks of [`TAIL_BATCH`], and a single
    /// query (alone or left over) at batch 1, so little is padded.
    pub fn logits(&self, queries: &[&QueryFeatures], map: &MapEmbedding) -> Result<Vec<TokenLogits>, ModelError> {
        let mut out = Vec::with_capacity(queries.len());
        let full = queries.len() / SCENE_BATCH * SCENE_BATCH;
        let (head, tail) = queries.split_at(full);
        for chunk in head.chunks(SCENE_BATCH) {
            out.extend(self.logits_on(self.decoder_at(SCENE_BATCH)?, chunk, map)?);
        }
        for chunk in tail.chunks(TAIL_BATCH) {
            let batch = if chunk.len() == 1 { 1 } else { TAIL_BATCH };
            out.extend(self.logits_on(self.decoder_at(batch)?, chunk, map)?);
        }
        Ok(out)
    }

    /// The decoder loaded for `batch` (1, [`TAIL_BATCH`] or [`SCENE_BATCH`]),
    /// optimised on first use.
    pub fn decoder_at(&self, batch: usize) -> Result<&OnnxModel, ModelError> {
        let lazy = match batch {
            1 => return Ok(&self.decoder_single),
            TAIL_BATCH => &self.decoder_tail,
            SCENE_BATCH => &self.decoder_scene,
            other => {
                return Err(
                    self.input_error(format!("no decoder for batch {other} (1, {TAIL_BATCH} and {SCENE_BATCH} are)"))
                );
            }
        };
        if let Some(model) = lazy.get() {
            return Ok(model);
        }
        let model = self.decoder_single.with_batch(batch)?;
        // Another thread may have set it meanwhile: both are the same plan.
        Ok(lazy.get_or_init(|| model))
    }

    /// Profiles the decoder loaded for `model_batch` (1, [`TAIL_BATCH`] or
    /// [`SCENE_BATCH`]) on `chunk`: each node's median time over `repeat`
    /// runs, the costliest first (`safer bench-models --profile`).
    pub fn profile_decoder(
        &self,
        model_batch: usize,
        chunk: &[&QueryFeatures],
        map: &MapEmbedding,
        repeat: usize,
    ) -> Result<Vec<NodeCost>, ModelError> {
        let model = self.decoder_at(model_batch)?;
        if chunk.len() > model_batch {
            return Err(self.input_error(format!("{} queries for a decoder of batch {model_batch}", chunk.len())));
        }
        model.profile(&self.batch_inputs(chunk, model_batch, map)?, repeat)
    }

    /// Runs `model` (a decoder of this prior) once on `chunk`, padded to
    /// the model's batch: the logits of each query, in order.
    pub fn logits_on(
        &self,
        model: &OnnxModel,
        chunk: &[&QueryFeatures],
        map: &MapEmbedding,
    ) -> Result<Vec<TokenLogits>, ModelError> {
        let batch = model.batch();
        if chunk.len() > batch || map.d != self.d {
            return Err(self.input_error(format!(
                "{} queries for a decoder of batch {batch} (map width {} vs {})",
                chunk.len(),
                map.d,
                self.d
            )));
        }
        let result = model.run(self.batch_inputs(chunk, batch, map)?)?;
        // Rows are copied straight out of the output tensor (one copy, not two).
        let view = result[0].to_plain_array_view::<f32>().map_err(|e| self.input_error(e))?;
        let copied;
        let logits = match view.as_slice() {
            Some(contiguous) => contiguous,
            None => {
                copied = view.iter().copied().collect::<Vec<f32>>();
                &copied
            }
        };
        Ok((0..chunk.len())
            .map(|q| TokenLogits::from(&logits[q * VOCABULARY_SIZE..(q + 1) * VOCABULARY_SIZE]))
            .collect())
    }

    fn batch_inputs(
        &self,
        chunk: &[&QueryFeatures],
        batch: usize,
        map: &MapEmbedding,
    ) -> Result<TVec<TValue>, ModelError> {
        let d = self.d;
        let mut history = vec![0.0f32; batch * HISTORY_POINTS * HISTORY_FEATURES];
        let mut agent_self = vec![0.0f32; batch * SELF_FEATURES];
        let mut neighbours = vec![0.0f32; batch * NEIGHBOURS * NEIGHBOUR_FEATURES];
        let mut neighbour_pose = vec![0.0f32; batch * NEIGHBOURS * POSE_FEATURES];
        let mut neighbour_mask = vec![0.0f32; batch * NEIGHBOURS];
        let mut map_embedding = vec![0.0f32; batch * MAP_TOKENS * d];
        let mut map_pose = vec![0.0f32; batch * MAP_TOKENS * POSE_FEATURES];
        let mut map_signal = vec![0.0f32; batch * MAP_TOKENS * SIGNAL_FEATURES];
        let mut map_mask = vec![0.0f32; batch * MAP_TOKENS];
        fn put(dst: &mut [f32], b: usize, src: &[f32]) {
            dst[b * src.len()..(b + 1) * src.len()].copy_from_slice(src);
        }
        for (b, q) in chunk.iter().enumerate() {
            put(&mut history, b, &q.history);
            put(&mut agent_self, b, &q.agent_self);
            put(&mut neighbours, b, &q.neighbours);
            put(&mut neighbour_pose, b, &q.neighbour_pose);
            put(&mut neighbour_mask, b, &q.neighbour_mask);
            put(&mut map_pose, b, &q.map_pose);
            put(&mut map_signal, b, &q.map_signal);
            put(&mut map_mask, b, &q.map_mask);
            for (n, &i) in q.map_index.iter().enumerate() {
                if i == u32::MAX {
                    continue;
                }
                let row = map
                    .rows
                    .get(i as usize * d..(i as usize + 1) * d)
                    .ok_or_else(|| self.input_error(format!("map token {i} outside the embedding")))?;
                let at = (b * MAP_TOKENS + n) * d;
                map_embedding[at..at + d].copy_from_slice(row);
            }
        }
        let t = |shape: &[usize], v: Vec<f32>| -> Result<TValue, ModelError> {
            // The vector becomes the tensor's storage (no copy).
            tract_ndarray::ArrayD::from_shape_vec(shape, v)
                .map(|a| a.into_tensor().into_tvalue())
                .map_err(|e| self.input_error(e))
        };
        Ok(tvec![
            t(&[batch, HISTORY_POINTS, HISTORY_FEATURES], history)?,
            t(&[batch, SELF_FEATURES], agent_self)?,
            t(&[batch, NEIGHBOURS, NEIGHBOUR_FEATURES], neighbours)?,
            t(&[batch, NEIGHBOURS, POSE_FEATURES], neighbour_pose)?,
            t(&[batch, NEIGHBOURS], neighbour_mask)?,
            t(&[batch, MAP_TOKENS, d], map_embedding)?,
            t(&[batch, MAP_TOKENS, POSE_FEATURES], map_pose)?,
            t(&[batch, MAP_TOKENS, SIGNAL_FEATURES], map_signal)?,
            t(&[batch, MAP_TOKENS], map_mask)?,
        ])
    }
}

/// A prior shared by every worker.
pub type SharedPrior = Arc<RealismPrior>;

#[cfg(test)]
mod tests {
    use super::*;

    /// A query with every feature filled from a small generator, map rows
    /// spread over the embedding.
    fn query(seed: u32, map_tokens: u32) -> QueryFeatures {
        let mut x = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x % 2000) as f32 / 1000.0 - 1.0
        };
        let mut q = QueryFeatures {
            history: [0.0; HISTORY_POINTS * HISTORY_FEATURES],
            agent_self: [0.0; SELF_FEATURES],
            neighbours: [0.0; NEIGHBOURS * NEIGHBOUR_FEATURES],
            neighbour_pose: [0.0; NEIGHBOURS * POSE_FEATURES],
            neighbour_mask: [1.0; NEIGHBOURS],
            map_index: [0; MAP_TOKENS],
            map_pose: [0.0; MAP_TOKENS * POSE_FEATURES],
            map_signal: [0.0; MAP_TOKENS * SIGNAL_FEATURES],
            map_mask: [1.0; MAP_TOKENS],
        };
        for v in q.history.iter_mut().chain(&mut q.agent_self).chain(&mut q.neighbours).chain(&mut q.neighbour_pose) {
            *v = next();
        }
        for v in q.map_pose.iter_mut().chain(&mut q.map_signal) {
            *v = next();
        }
        for (n, i) in q.map_index.iter_mut().enumerate() {
            *i = (seed + n as u32) % map_tokens;
        }
        q.neighbour_mask[seed as usize % NEIGHBOURS] = 0.0;
        q
    }

    /// Batching rollouts together relies on this: a query's logits are the
    /// same bits whatever the batch size, its place in the batch, the other
    /// queries beside it and the padding.
    #[test]
    fn batch_sizes_give_identical_logits() {
        let source = ModelSource::shipped();
        let prior = RealismPrior::load(&source, PriorVariant::Differential).unwrap();
        let rows = 20;
        let map = MapEmbedding {
            rows: (0..rows * prior.d).map(|i| ((i * 37) % 101) as f32 / 50.0 - 1.0).collect(),
            d: prior.d,
        };
        let queries: Vec<QueryFeatures> = (0..40).map(|s| query(s, rows as u32)).collect();
        let refs: Vec<&QueryFeatures> = queries.iter().collect();
        let alone: Vec<TokenLogits> =
            refs.iter().map(|q| prior.logits_on(prior.decoder_at(1).unwrap(), &[q], &map).unwrap().remove(0)).collect();
        let mut shifted = refs.clone();
        shifted.rotate_left(3);
        for (batch, chunk) in [(SCENE_BATCH, 32), (TAIL_BATCH, 8), (TAIL_BATCH, 5)] {
            let model = prior.decoder_at(batch).unwrap();
            let out: Vec<TokenLogits> =
                shifted.chunks(chunk).flat_map(|c| prior.logits_on(model, c, &map).unwrap()).collect();
            for (i, l) in out.iter().enumerate() {
                assert_eq!(l, &alone[(i + 3) % refs.len()], "batch {}, chunks of {chunk}, row {i}", model.batch());
            }
        }
        assert_eq!(prior.logits(&refs, &map).unwrap(), alone);
        assert_ne!(alone[0], alone[1]);
        // Only the three planned batch sizes exist; another is an error, not a panic.
        let err = prior.decoder_at(5).unwrap_err().to_string();
        assert!(err.contains("no decoder for batch 5"), "{err}");
    }
}
