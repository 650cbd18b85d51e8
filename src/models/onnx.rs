//! Loading an ONNX model with tract, checked against its card: the file's
//! checksum, the graph's input and output names, and (optionally) a replay
//! of the golden inputs/outputs stored beside it. The optimised plan is
//! immutable and `Send + Sync`: load once, share it (e.g. in an `Arc`) with
//! every rayon worker; tract runs each call single-threaded.

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use sha2::{Digest, Sha256};
use thread_local::ThreadLocal;
use tract_onnx::prelude::*;

use super::card::{DType, Dim, ExpectedContract, ModelCard};
use super::{ModelError, ModelSource};

/// The instruction sets tract may not use, as its `TRACT_CPU_ISA` knob
/// writes them. tract picks its matrix kernels by the CPU: on a machine
/// with AVX-512 it multiplies a batch of one and a batch of 32 with
/// different kernels that sum in different orders, so a query's logits
/// differed in the last bits with the batch around it (and from an AVX2
/// machine's), and the contract that a variant is the same on any machine
/// broke (measured: the batch-invariance test of the prior failed on an
/// AVX-512 Xeon and passes with these removed). The AVX2/FMA kernels are
/// what every x86-64 machine this runs on has.
const WITHOUT_INSTRUCTION_SETS: &str = "-avx512f,-avx512vnni,-avx512fp16";

/// Keeps tract on the same kernels on every x86-64 machine (see
/// [`WITHOUT_INSTRUCTION_SETS`]): set before tract first probes the CPU,
/// which it does once, when the first graph is optimised.
fn pin_kernels() {
    static PINNED: std::sync::Once = std::sync::Once::new();
    PINNED.call_once(|| {
        tract_onnx::tract_core::tract_linalg::knobs::TRACT_CPU_ISA.set(Some(WITHOUT_INSTRUCTION_SETS.to_string()));
    });
}

/// A loaded, optimised model with its card.
#[derive(Debug, Clone)]
pub struct OnnxModel {
    card: ModelCard,
    /// Where the card, the graph and the goldens were read from.
    source: ModelSource,
    /// The card's file name in `source`.
    card_file: PathBuf,
    /// The parsed graph before its shapes were fixed, checked against the
    /// card: kept so that other batch sizes are optimised without reading
    /// and hashing the file again (`with_batch`).
    graph: Arc<InferenceModel>,
    batch: usize,
    plan: Arc<TypedRunnableModel>,
    /// Each thread's session of `plan`, kept from run to run: a run on a
    /// fresh session allocates the intermediate tensors anew. Clones share
    /// them (they share the plan); dropped with the last clone.
    sessions: Arc<ThreadLocal<RefCell<TypedSimpleState>>>,
}

/// A session of an optimised plan.
type TypedSimpleState = tract_onnx::tract_core::plan::SimpleState<TypedFact, Box<dyn TypedOp>>;

/// Result of replaying a model's golden file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GoldenReplay {
    /// Largest absolute difference over all outputs.
    pub max_abs_diff: f64,
    /// The card's tolerance.
    pub tolerance: f64,
    /// Number of output values compared.
    pub values: usize,
}

/// Time spent in one node of the optimised plan (`OnnxModel::profile`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct NodeCost {
    /// The node's name in the optimised plan.
    pub node: String,
    /// The operator, as tract names it (e.g. `EinSum`, `OptMatMul`).
    pub op: String,
    /// Median over the profiled runs, µs.
    pub median_us: f64,
}

/// The values of an `f32` tensor, in row-major order.
pub fn f32_values(t: &Tensor) -> TractResult<Vec<f32>> {
    Ok(t.to_plain_array_view::<f32>()?.iter().copied().collect())
}

/// Hex SHA-256 of a file's bytes.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

impl OnnxModel {
    /// Loads the card `card_file` of `source`, checks it against
    /// `expected`, checks the ONNX file's checksum and graph I/O names, and
    /// optimises the graph with every symbolic dimension fixed to `batch`.
    pub fn load(
        source: &ModelSource,
        card_file: impl AsRef<Path>,
        expected: &ExpectedContract,
        batch: usize,
    ) -> Result<Self, ModelError> {
        pin_kernels();
        let card_file = card_file.as_ref();
        let card_path = &source.path(card_file);
        let card = ModelCard::parse(&source.read(card_file)?, card_path)?;
        card.check(card_path, expected)?;
        let onnx_path = source.path(&card.file);
        let bytes = source.read(&card.file)?;
        let found = sha256_hex(&bytes);
        if !found.eq_ignore_ascii_case(&card.sha256) {
            return Err(ModelError::CardMismatch {
                path: card_path.to_path_buf(),
                field: "sha256".into(),
                expected: card.sha256.clone(),
                found: format!("{found} (the ONNX file changed after the card was written)"),
            });
        }
        let onnx_err = |e: TractError| ModelError::Onnx { path: onnx_path.clone(), message: format!("{e:#}") };
        let model = tract_onnx::onnx().model_for_read(&mut &bytes[..]).map_err(onnx_err)?;
        let graph_inputs: Vec<String> =
            model.input_outlets().map_err(onnx_err)?.iter().map(|o| model.node(o.node).name.clone()).collect();
        let card_inputs: Vec<String> = card.inputs.iter().map(|s| s.name.clone()).collect();
        if graph_inputs != card_inputs {
            return Err(ModelError::CardMismatch {
                path: card_path.to_path_buf(),
                field: "inputs (names in the ONNX graph)".into(),
                expected: card_inputs.join(", "),
                found: graph_inputs.join(", "),
            });
        }
        let plan = Self::plan_for(&card, card_path, &onnx_path, &model, batch)?;
        Ok(Self {
            card,
            source: source.clone(),
            card_file: card_file.to_path_buf(),
            graph: Arc::new(model),
            batch,
            plan,
            sessions: Arc::default(),
        })
    }

    /// The same model optimised with every symbolic dimension fixed to
    /// `batch` (tract plans are fixed-shape), from the graph parsed and
    /// checked at load.
    pub fn with_batch(&self, batch: usize) -> Result<Self, ModelError> {
        let plan =
            Self::plan_for(&self.card, &self.card_path(), &self.source.path(&self.card.file), &self.graph, batch)?;
        Ok(Self { batch, plan, sessions: Arc::default(), ..self.clone() })
    }

    /// Fixes the symbolic dimensions of `graph` to `batch`, optimises it and
    /// checks its outputs against the card.
    fn plan_for(
        card: &ModelCard,
        card_path: &Path,
        onnx_path: &Path,
        graph: &InferenceModel,
        batch: usize,
    ) -> Result<Arc<TypedRunnableModel>, ModelError> {
        let onnx_err = |e: TractError| ModelError::Onnx { path: onnx_path.to_path_buf(), message: format!("{e:#}") };
        let mut model = graph.clone();
        for (i, spec) in card.inputs.iter().enumerate() {
            let shape: Vec<usize> = spec
                .shape
                .iter()
                .map(|d| match d {
                    Dim::Fixed(n) => *n,
                    Dim::Symbol(_) => batch,
                })
                .collect();
            let dt = match spec.dtype {
                DType::F32 => f32::datum_type(),
                DType::I64 => i64::datum_type(),
            };
            model = model.with_input_fact(i, InferenceFact::dt_shape(dt, shape)).map_err(onnx_err)?;
        }
        let optimised = model.into_optimized().map_err(onnx_err)?;
        let graph_outputs: Vec<String> =
            optimised.output_outlets().map_err(onnx_err)?.iter().map(|o| optimised.node(o.node).name.clone()).collect();
        let card_outputs: Vec<String> = card.outputs.iter().map(|s| s.name.clone()).collect();
        if graph_outputs.len() != card_outputs.len() {
            return Err(ModelError::CardMismatch {
                path: card_path.to_path_buf(),
                field: "outputs (count in the ONNX graph)".into(),
                expected: card_outputs.len().to_string(),
                found: graph_outputs.len().to_string(),
            });
        }
        optimised.into_runnable().map_err(onnx_err)
    }

    /// The card.
    pub fn card(&self) -> &ModelCard {
        &self.card
    }

    /// Where the model was read from.
    pub fn source(&self) -> &ModelSource {
        &self.source
    }

    /// The card's path (or embedded name), for messages.
    pub fn card_path(&self) -> PathBuf {
        self.source.path(&self.card_file)
    }

    /// The batch size the symbolic dimensions were fixed to.
    pub fn batch(&self) -> usize {
        self.batch
    }

    /// Runs the graph on inputs in card order (shapes as fixed at load).
    pub fn run(&self, inputs: TVec<TValue>) -> Result<TVec<TValue>, ModelError> {
        let fail = |e: TractError| ModelError::Inference { model: self.card.name.clone(), message: format!("{e:#}") };
        let session = self.sessions.get_or_try(|| self.plan.spawn().map(RefCell::new)).map_err(fail)?;
        match session.try_borrow_mut() {
            Ok(mut session) => session.run(inputs).map_err(fail),
            // Only a run inside a run on this thread finds it taken: that
            // one gets a session of its own.
            Err(_) => self.plan.run(inputs).map_err(fail),
        }
    }

    /// Runs the plan `repeat` times on `inputs` timing every node, and
    /// returns each node's median time, the costliest first. This is the
    /// per-node view tract's own `profile` tooling gives, without its CLI.
    pub fn profile(&self, inputs: &TVec<TValue>, repeat: usize) -> Result<Vec<NodeCost>, ModelError> {
        let fail = |e: TractError| ModelError::Inference { model: self.card.name.clone(), message: format!("{e:#}") };
        let mut state = self.plan.spawn().map_err(fail)?;
        let nodes = self.plan.model().nodes();
        let mut samples: Vec<Vec<f64>> = vec![Vec::with_capacity(repeat); nodes.len()];
        // One warm-up run, then the timed ones.
        for run in 0..=repeat.max(1) {
            let mut eval = |ctx: &tract_onnx::tract_core::plan::EvalContext<'_>,
                            op_state: Option<&mut (dyn tract_onnx::tract_core::ops::OpState + 'static)>,
                            node: &TypedNode,
                            input: TVec<TValue>| {
                let started = std::time::Instant::now();
                let out = tract_onnx::tract_core::plan::eval(ctx, op_state, node, input);
                if run > 0 {
                    samples[node.id].push(started.elapsed().as_secs_f64() * 1e6);
                }
                out
            };
            state.run_plan_with_eval(inputs.clone(), &mut eval).map_err(fail)?;
        }
        let mut costs: Vec<NodeCost> = nodes
            .iter()
            .zip(samples)
            .filter(|(_, s)| !s.is_empty())
            .map(|(node, mut s)| {
                s.sort_by(f64::total_cmp);
                NodeCost { node: node.name.clone(), op: node.op().name().to_string(), median_us: s[s.len() / 2] }
            })
            .collect();
        costs.sort_by(|a, b| b.median_us.total_cmp(&a.median_us).then_with(|| a.node.cmp(&b.node)));
        Ok(costs)
    }

    /// Replays the golden file: feeds `input.<name>` tensors, compares with
    /// `output.<name>`. NaN anywhere fails (a NaN never passes a `<=`).
    pub fn replay_golden(&self) -> Result<GoldenReplay, ModelError> {
        let path = self.source.path(&self.card.golden);
        let bytes = self.source.read(&self.card.golden)?;
        let golden = safetensors::SafeTensors::deserialize(&bytes)
            .map_err(|e| ModelError::Golden { path: path.clone(), message: e.to_string() })?;
        let tensor = |name: &str| -> Result<Tensor, ModelError> {
            let view = golden
                .tensor(name)
                .map_err(|e| ModelError::Golden { path: path.clone(), message: format!("{name}: {e}") })?;
            let shape = view.shape().to_vec();
            let data = view.data();
            let t = match view.dtype() {
                safetensors::Dtype::F32 => {
                    let v: Vec<f32> =
                        data.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
                    Tensor::from_shape(&shape, &v)
                }
                safetensors::Dtype::I64 => {
                    let v: Vec<i64> =
                        data.chunks_exact(8).map(|c| i64::from_le_bytes(c.try_into().expect("chunk of 8"))).collect();
                    Tensor::from_shape(&shape, &v)
                }
                other => {
                    return Err(ModelError::Golden { path: path.clone(), message: format!("{name}: dtype {other:?}") });
                }
            };
            t.map_err(|e| ModelError::Golden { path: path.clone(), message: format!("{name}: {e}") })
        };
        let mut inputs = TVec::new();
        for spec in &self.card.inputs {
            let t = tensor(&format!("input.{}", spec.name))?;
            let expected: Vec<usize> = spec
                .shape
                .iter()
                .map(|d| match d {
                    Dim::Fixed(n) => *n,
                    Dim::Symbol(_) => self.batch,
                })
                .collect();
            if t.shape() != expected.as_slice() {
                return Err(ModelError::Golden {
                    path: path.clone(),
                    message: format!(
                        "input.{} has shape {:?}, the model was loaded for {:?}",
                        spec.name,
                        t.shape(),
                        expected
                    ),
                });
            }
            inputs.push(t.into_tvalue());
        }
        let outputs = self.run(inputs)?;
        let mut max_abs_diff = 0.0f64;
        let mut values = 0;
        for (spec, got) in self.card.outputs.iter().zip(outputs.iter()) {
            let want = tensor(&format!("output.{}", spec.name))?;
            let got = got
                .cast_to::<f32>()
                .map_err(|e| ModelError::Inference { model: self.card.name.clone(), message: format!("{e:#}") })?;
            let want = want
                .cast_to::<f32>()
                .map_err(|e| ModelError::Golden { path: path.clone(), message: format!("{e:#}") })?;
            if got.shape() != want.shape() {
                return Err(ModelError::Golden {
                    path: path.clone(),
                    message: format!("output.{}: shape {:?}, golden {:?}", spec.name, got.shape(), want.shape()),
                });
            }
            let g = f32_values(&got)
                .map_err(|e| ModelError::Inference { model: self.card.name.clone(), message: format!("{e:#}") })?;
            let w =
                f32_values(&want).map_err(|e| ModelError::Golden { path: path.clone(), message: format!("{e:#}") })?;
            for (a, b) in g.iter().zip(&w) {
                let d = (*a as f64 - *b as f64).abs();
                // NaN-safe: a NaN difference becomes infinite.
                max_abs_diff = if d.is_nan() { f64::INFINITY } else { max_abs_diff.max(d) };
                values += 1;
            }
        }
        let replay = GoldenReplay { max_abs_diff, tolerance: self.card.golden_tolerance, values };
        // NaN differences were turned into infinity above; a NaN tolerance fails too.
        if replay.max_abs_diff.is_nan() || replay.tolerance.is_nan() || replay.max_abs_diff > replay.tolerance {
            return Err(ModelError::Golden {
                path,
                message: format!(
                    "outputs differ from the golden file by {:.3e} (tolerance {:.1e})",
                    replay.max_abs_diff, replay.tolerance
                ),
            });
        }
        Ok(replay)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::feasibility::FeasibilityValue;

    /// Each thread keeps its session of a plan from run to run: the
    /// answers must not depend on how many runs a session has made, on
    /// which thread, or on a clone sharing the sessions.
    #[test]
    fn reused_sessions_answer_as_fresh_ones() {
        let model = FeasibilityValue::load(&ModelSource::shipped()).expect("shipped model").model().clone();
        let first = model.replay_golden().expect("golden").max_abs_diff;
        for _ in 0..3 {
            assert_eq!(model.replay_golden().unwrap().max_abs_diff.to_bits(), first.to_bits());
        }
        let clone = model.clone();
        let elsewhere = std::thread::spawn(move || {
            (0..3).map(|_| clone.replay_golden().unwrap().max_abs_diff.to_bits()).collect::<Vec<_>>()
        })
        .join()
        .unwrap();
        assert_eq!(elsewhere, vec![first.to_bits(); 3]);
        let rebatched = model.with_batch(model.batch()).expect("same batch");
        assert_eq!(rebatched.replay_golden().unwrap().max_abs_diff.to_bits(), first.to_bits());
    }
}
