//! The model card (**contract**): the YAML file beside every ONNX model in
//! `models/` that says what the graph consumes and produces, how inputs are
//! normalised, which token grid and period it assumes, what it was trained
//! on (and under which licence), how to retrain it, and what it scored on
//! held-out data. Code states what it expects as an [`ExpectedContract`]; a
//! card that differs is refused at load with the field that differs.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::ModelError;
use crate::motion::tokens::{BINS_PER_AXIS, MAX_ACCEL_MPS2, MAX_YAW_RATE_RADPS, TOKEN_PERIOD_S};

/// The card format this build reads.
pub const CONTRACT_VERSION: u32 = 1;

/// What a model is for; decides which code may load it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModelKind {
    /// The realism prior's decoder: query features → next-token logits.
    RealismPriorDecoder,
    /// The realism prior's map encoder: map tokens → embeddings (run once per scenario).
    RealismPriorMapEncoder,
    /// The feasibility value V_h of an ego–CBV state.
    FeasibilityValue,
}

/// Element type of a tensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DType {
    /// 32-bit float.
    F32,
    /// 64-bit signed integer.
    I64,
}

/// One dimension of a tensor shape: fixed, or named and fixed at load.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Dim {
    /// A fixed size.
    Fixed(usize),
    /// A symbolic size (e.g. `batch`), fixed when the model is loaded.
    Symbol(String),
}

impl std::fmt::Display for Dim {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Dim::Fixed(n) => write!(f, "{n}"),
            Dim::Symbol(s) => f.write_str(s),
        }
    }
}

/// Name, type, shape and meaning of one graph input or output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TensorSpec {
    /// Name in the ONNX graph.
    pub name: String,
    /// Element type.
    pub dtype: DType,
    /// Shape.
    pub shape: Vec<Dim>,
    /// What the values are, with units.
    pub meaning: String,
}

/// The motion-token grid a model was trained with.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TokenGridSpec {
    /// Bins per axis (acceleration, yaw rate).
    pub bins_per_axis: usize,
    /// Acceleration range ± this, m/s².
    pub max_accel_mps2: f64,
    /// Yaw-rate range ± this, rad/s.
    pub max_yaw_rate_radps: f64,
}

impl TokenGridSpec {
    /// The grid this build uses (`motion::tokens`).
    pub fn current() -> Self {
        Self { bins_per_axis: BINS_PER_AXIS, max_accel_mps2: MAX_ACCEL_MPS2, max_yaw_rate_radps: MAX_YAW_RATE_RADPS }
    }
}

/// Where a model came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainingProvenance {
    /// The training data, one line per source.
    pub data: Vec<String>,
    /// Licence(s) of that data.
    pub licence: String,
    /// The command that reproduces the model.
    pub command: String,
}

/// A model card as written in `models/<name>.card.yaml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelCard {
    /// Card format version; must be [`CONTRACT_VERSION`].
    pub contract_version: u32,
    /// Model name (the file stem).
    pub name: String,
    /// What the model is for.
    pub kind: ModelKind,
    /// ONNX file, relative to the card.
    pub file: PathBuf,
    /// SHA-256 of the ONNX file, hex.
    pub sha256: String,
    /// ONNX opset the graph was exported with.
    pub opset: u32,
    /// Graph inputs, in order.
    pub inputs: Vec<TensorSpec>,
    /// Graph outputs, in order.
    pub outputs: Vec<TensorSpec>,
    /// What the graph expects (physical units) and what it does inside.
    pub normalisation: String,
    /// Architecture and sizing, with the reasons (free text).
    #[serde(default)]
    pub architecture: Option<String>,
    /// Token grid, for models that speak tokens.
    #[serde(default)]
    pub token_grid: Option<TokenGridSpec>,
    /// Token period, s, for models that speak tokens.
    #[serde(default)]
    pub token_period_s: Option<f64>,
    /// Training data, licence and command.
    pub training: TrainingProvenance,
    /// Metrics measured on held-out data.
    pub metrics: BTreeMap<String, f64>,
    /// Golden inputs/outputs (safetensors, `input.<name>` / `output.<name>`), relative to the card.
    pub golden: PathBuf,
    /// Largest absolute difference allowed when replaying the goldens.
    pub golden_tolerance: f64,
}

/// What code expects of a model: checked against its card at load.
#[derive(Debug, Clone)]
pub struct ExpectedContract {
    /// Required kind.
    pub kind: ModelKind,
    /// Inputs in order: name, dtype, shape (`None` = any size, e.g. the batch).
    pub inputs: Vec<(&'static str, DType, Vec<Option<usize>>)>,
    /// Outputs in order, likewise.
    pub outputs: Vec<(&'static str, DType, Vec<Option<usize>>)>,
    /// Whether the model must carry this build's token grid and period.
    pub speaks_tokens: bool,
}

impl ModelCard {
    /// Reads and parses a card file; errors carry the file and the YAML location.
    pub fn load(path: &Path) -> Result<Self, ModelError> {
        let bytes = std::fs::read(path).map_err(|source| ModelError::Io { path: path.to_path_buf(), source })?;
        Self::parse(&bytes, path)
    }

    /// Parses a card's bytes; `path` names it in errors.
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Self, ModelError> {
        let text = std::str::from_utf8(bytes)
            .map_err(|e| ModelError::Card { path: path.to_path_buf(), message: format!("not UTF-8: {e}") })?;
        serde_saphyr::from_str::<ModelCard>(text)
            .map_err(|e| ModelError::Card { path: path.to_path_buf(), message: e.to_string() })
    }

    /// Checks the card against what the code expects; the error names the
    /// first field that differs.
    pub fn check(&self, path: &Path, expected: &ExpectedContract) -> Result<(), ModelError> {
        let mismatch = |field: String, expected: String, found: String| ModelError::CardMismatch {
            path: path.to_path_buf(),
            field,
            expected,
            found,
        };
        if self.contract_version != CONTRACT_VERSION {
            return Err(mismatch(
                "contract_version".into(),
                CONTRACT_VERSION.to_string(),
                self.contract_version.to_string(),
            ));
        }
        if self.kind != expected.kind {
            return Err(mismatch("kind".into(), format!("{:?}", expected.kind), format!("{:?}", self.kind)));
        }
        for (section, specs, wanted) in
            [("inputs", &self.inputs, &expected.inputs), ("outputs", &self.outputs, &expected.outputs)]
        {
            if specs.len() != wanted.len() {
                return Err(mismatch(format!("{section} (count)"), wanted.len().to_string(), specs.len().to_string()));
            }
            for (i, (spec, (name, dtype, shape))) in specs.iter().zip(wanted).enumerate() {
                let at = format!("{section}[{i}]");
                if spec.name != *name {
                    return Err(mismatch(format!("{at}.name"), (*name).into(), spec.name.clone()));
                }
                if spec.dtype != *dtype {
                    return Err(mismatch(format!("{at}.dtype"), format!("{dtype:?}"), format!("{:?}", spec.dtype)));
                }
                let shape_ok = spec.shape.len() == shape.len()
                    && spec.shape.iter().zip(shape).all(|(d, w)| match (d, w) {
                        (_, None) => true,
                        (Dim::Fixed(n), Some(m)) => n == m,
                        (Dim::Symbol(_), Some(_)) => false,
                    });
                if !shape_ok {
                    let show = |s: Vec<String>| format!("[{}]", s.join(", "));
                    return Err(mismatch(
                        format!("{at}.shape ({name})"),
                        show(shape.iter().map(|d| d.map_or("any".into(), |n| n.to_string())).collect()),
                        show(spec.shape.iter().map(|d| d.to_string()).collect()),
                    ));
                }
            }
        }
        if expected.speaks_tokens {
            let grid = TokenGridSpec::current();
            if self.token_grid != Some(grid) {
                return Err(mismatch("token_grid".into(), format!("{grid:?}"), format!("{:?}", self.token_grid)));
            }
            let period_ok = self.token_period_s.is_some_and(|p| (p - TOKEN_PERIOD_S).abs() < 1e-9);
            if !period_ok {
                return Err(mismatch(
                    "token_period_s".into(),
                    TOKEN_PERIOD_S.to_string(),
                    format!("{:?}", self.token_period_s),
                ));
            }
        }
        if !(self.golden_tolerance.is_finite() && self.golden_tolerance > 0.0) {
            return Err(mismatch(
                "golden_tolerance".into(),
                "a positive number".into(),
                self.golden_tolerance.to_string(),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn card_yaml(extra: &str) -> String {
        format!(
            r#"contract_version: 1
name: tiny
kind: feasibility-value
file: tiny.onnx
sha256: "00"
opset: 17
inputs:
  - {{name: state, dtype: f32, shape: [20, 12], meaning: "relative state"}}
outputs:
  - {{name: value, dtype: f32, shape: [20, 1], meaning: "V_h"}}
normalisation: "physical units"
training: {{data: ["synthetic"], licence: "project", command: "python train.py"}}
metrics: {{held_out_loss: 0.5}}
golden: tiny.golden.safetensors
golden_tolerance: 1.0e-4
{extra}"#
        )
    }

    fn expected() -> ExpectedContract {
        ExpectedContract {
            kind: ModelKind::FeasibilityValue,
            inputs: vec![("state", DType::F32, vec![Some(20), Some(12)])],
            outputs: vec![("value", DType::F32, vec![Some(20), Some(1)])],
            speaks_tokens: false,
        }
    }

    fn parse(text: &str) -> Result<ModelCard, String> {
        serde_saphyr::from_str::<ModelCard>(text).map_err(|e| e.to_string())
    }

    #[test]
    fn a_matching_card_is_accepted() {
        let card = parse(&card_yaml("")).unwrap();
        card.check(Path::new("tiny.card.yaml"), &expected()).unwrap();
    }

    #[test]
    fn a_typo_in_a_field_name_is_an_error_with_a_location() {
        let err = parse(&card_yaml("golden_tolerence: 1.0\n")).unwrap_err();
        assert!(err.contains("golden_tolerence"), "{err}");
        assert!(err.contains("line"), "{err}");
    }

    #[test]
    fn a_shape_that_differs_names_the_field() {
        let card = parse(&card_yaml("").replace("[20, 12]", "[20, 11]")).unwrap();
        let err = card.check(Path::new("tiny.card.yaml"), &expected()).unwrap_err().to_string();
        assert!(err.contains("inputs[0].shape (state)"), "{err}");
        assert!(err.contains("[20, 12]") && err.contains("[20, 11]"), "{err}");
    }

    #[test]
    fn a_token_model_without_the_grid_is_refused() {
        let card = parse(&card_yaml("")).unwrap();
        let mut wanted = expected();
        wanted.speaks_tokens = true;
        let err = card.check(Path::new("tiny.card.yaml"), &wanted).unwrap_err().to_string();
        assert!(err.contains("token_grid"), "{err}");
    }
}
