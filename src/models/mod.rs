//! Learned models: ONNX files run by tract, each checked against its model
//! card ([`card`]) at load, plus the feature builders that turn scenes into
//! their inputs (the same code writes the training shards and feeds
//! inference, so the two cannot disagree). A loaded model is immutable and
//! shared by every worker thread.

pub mod card;
pub mod feasibility;
pub mod feasibility_oracle;
pub mod onnx;
pub mod prior;
pub mod prior_dataset;
pub mod prior_features;
pub mod shard;
pub mod source;

use std::path::PathBuf;

pub use card::{DType, Dim, ExpectedContract, ModelCard, ModelKind, TensorSpec};
pub use onnx::{GoldenReplay, OnnxModel};
pub use source::ModelSource;

/// The feasibility value V_h in `source`, as the adversary asks it.
pub fn feasibility_oracle(
    source: &ModelSource,
) -> Result<std::sync::Arc<dyn feasibility_oracle::FeasibilityOracle>, ModelError> {
    feasibility::FeasibilityValue::load(source)
        .map(|v| std::sync::Arc::new(v) as std::sync::Arc<dyn feasibility_oracle::FeasibilityOracle>)
}

/// Errors of the models layer.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// A file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A card is not valid YAML for the card format.
    #[error("model card {}: {message}", path.display())]
    Card {
        /// The card.
        path: PathBuf,
        /// Parser message with line and column.
        message: String,
    },
    /// A card (or the file it describes) differs from what the code expects.
    #[error("model card {}: field `{field}` is {found}, this build expects {expected}", path.display())]
    CardMismatch {
        /// The card.
        path: PathBuf,
        /// The field that differs.
        field: String,
        /// What the code expects.
        expected: String,
        /// What the card (or file) says.
        found: String,
    },
    /// tract could not load or optimise the graph.
    #[error("ONNX model {}: {message}", path.display())]
    Onnx {
        /// The ONNX file.
        path: PathBuf,
        /// tract's message.
        message: String,
    },
    /// Running the graph failed.
    #[error("model {model}: inference failed: {message}")]
    Inference {
        /// Model name.
        model: String,
        /// tract's message.
        message: String,
    },
    /// The golden file is unreadable or the outputs differ from it.
    #[error("golden file {}: {message}", path.display())]
    Golden {
        /// The golden file.
        path: PathBuf,
        /// What differs.
        message: String,
    },
    /// A training shard could not be written.
    #[error("training shard {}: {message}", path.display())]
    Shard {
        /// The shard.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// Inputs handed to a model wrapper have the wrong size.
    #[error("model {model}: {message}")]
    Input {
        /// Model name.
        model: String,
        /// What is wrong.
        message: String,
    },
}
