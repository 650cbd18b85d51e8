//! Writing training data as safetensors files (the format `training/` reads):
//! named columns with a dtype and shape, plus string metadata, written
//! through a temporary file so a reader never sees half a file.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use safetensors::tensor::{Dtype, TensorView};

use super::ModelError;

/// One named tensor of a shard.
#[derive(Debug, Clone, PartialEq)]
pub struct ShardColumn {
    /// Tensor name.
    pub name: String,
    /// Element type.
    pub dtype: Dtype,
    /// Shape.
    pub shape: Vec<usize>,
    /// Little-endian bytes.
    pub bytes: Vec<u8>,
}

impl ShardColumn {
    /// An `f32` column.
    pub fn f32(name: &str, shape: Vec<usize>, values: &[f32]) -> Self {
        Self {
            name: name.into(),
            dtype: Dtype::F32,
            shape,
            bytes: values.iter().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }

    /// An `i64` column.
    pub fn i64(name: &str, shape: Vec<usize>, values: &[i64]) -> Self {
        Self {
            name: name.into(),
            dtype: Dtype::I64,
            shape,
            bytes: values.iter().flat_map(|x| x.to_le_bytes()).collect(),
        }
    }
}

/// Writes `columns` and `metadata` to `path` atomically.
pub fn write_shard(path: &Path, columns: &[ShardColumn], metadata: HashMap<String, String>) -> Result<(), ModelError> {
    let err = |message: String| ModelError::Shard { path: path.to_path_buf(), message };
    let views = columns
        .iter()
        .map(|c| {
            TensorView::new(c.dtype, c.shape.clone(), &c.bytes)
                .map(|v| (c.name.clone(), v))
                .map_err(|e| err(format!("{}: {e}", c.name)))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let bytes = safetensors::serialize(views, Some(metadata)).map_err(|e| err(e.to_string()))?;
    let tmp = PathBuf::from(format!("{}.partial", path.display()));
    std::fs::write(&tmp, bytes).map_err(|source| ModelError::Io { path: tmp.clone(), source })?;
    std::fs::rename(&tmp, path).map_err(|source| ModelError::Io { path: path.to_path_buf(), source })
}
