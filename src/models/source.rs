//! Where model files come from: the copies embedded in the library at build
//! time (so a crate that depends on safer, or a `safer` binary copied
//! anywhere, finds the shipped models without a path to this checkout), or a
//! folder of custom models (`SAFER_MODELS`, `--models`). Either way every
//! file is checked against its card when it loads ([`super::OnnxModel`]).

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use super::ModelError;

/// The files of `models/`, embedded at build time (cards, ONNX graphs and
/// goldens). A test checks that this list and the folder agree, so a model
/// added to `models/` without being listed here fails CI.
macro_rules! embedded_models {
    ($($file:literal),* $(,)?) => {
        &[$(($file, include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/models/", $file)) as &[u8])),*]
    };
}

/// Embedded model files, by file name.
pub const EMBEDDED_FILES: &[(&str, &[u8])] = embedded_models!(
    "feasibility-value.card.yaml",
    "feasibility-value.golden.safetensors",
    "feasibility-value.onnx",
    "prior-decoder-plain.card.yaml",
    "prior-decoder-plain.golden.safetensors",
    "prior-decoder-plain.onnx",
    "prior-decoder.card.yaml",
    "prior-decoder.golden.safetensors",
    "prior-decoder.onnx",
    "prior-map-encoder-plain.card.yaml",
    "prior-map-encoder-plain.golden.safetensors",
    "prior-map-encoder-plain.onnx",
    "prior-map-encoder.card.yaml",
    "prior-map-encoder.golden.safetensors",
    "prior-map-encoder.onnx",
);

/// The folder, relative to the crate root, whose files are embedded.
pub const MODELS_FOLDER: &str = "models";

/// The environment variable naming a folder of custom models.
pub const MODELS_ENV: &str = "SAFER_MODELS";

/// Where a set of model files is read from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ModelSource {
    /// The shipped models, embedded in the library.
    Embedded,
    /// A folder holding cards, ONNX files and goldens side by side.
    Folder(PathBuf),
}

impl ModelSource {
    /// The models a run uses unless told otherwise: the folder in
    /// `$SAFER_MODELS` if set (custom models), else the embedded ones.
    pub fn shipped() -> Self {
        match std::env::var_os(MODELS_ENV).filter(|v| !v.is_empty()) {
            Some(dir) => Self::Folder(PathBuf::from(dir)),
            None => Self::Embedded,
        }
    }

    /// The folder `dir`, or the shipped models when `None`.
    pub fn folder_or_shipped(dir: Option<PathBuf>) -> Self {
        dir.map(Self::Folder).unwrap_or_else(Self::shipped)
    }

    /// The bytes of `file` (a name relative to the models root, as cards write it).
    pub fn read(&self, file: &Path) -> Result<Cow<'static, [u8]>, ModelError> {
        match self {
            Self::Folder(dir) => {
                let path = dir.join(file);
                std::fs::read(&path).map(Cow::Owned).map_err(|source| ModelError::Io { path, source })
            }
            Self::Embedded => file
                .to_str()
                .and_then(|name| EMBEDDED_FILES.iter().find(|(n, _)| *n == name))
                .map(|(_, bytes)| Cow::Borrowed(*bytes))
                .ok_or_else(|| ModelError::Io {
                    path: self.path(file),
                    source: std::io::Error::new(
                        std::io::ErrorKind::NotFound,
                        "not among the models embedded in this build of safer",
                    ),
                }),
        }
    }

    /// How `file` is named in messages: its path in a folder, or
    /// `models/FILE (embedded)` for the shipped copies.
    pub fn path(&self, file: &Path) -> PathBuf {
        match self {
            Self::Folder(dir) => dir.join(file),
            Self::Embedded => PathBuf::from(format!("models/{} (embedded)", file.display())),
        }
    }
}

impl std::fmt::Display for ModelSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Embedded => write!(f, "the models embedded in safer {}", env!("CARGO_PKG_VERSION")),
            Self::Folder(dir) => write!(f, "{}", dir.display()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_file_of_the_models_folder_is_embedded_byte_for_byte() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
        let mut on_disk: Vec<String> =
            std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        on_disk.sort();
        let mut embedded: Vec<String> = EMBEDDED_FILES.iter().map(|(n, _)| n.to_string()).collect();
        embedded.sort();
        assert_eq!(embedded, on_disk, "models/ and EMBEDDED_FILES must list the same files");
        for (name, bytes) in EMBEDDED_FILES {
            assert_eq!(std::fs::read(dir.join(name)).unwrap(), *bytes, "{name}");
        }
    }

    #[test]
    fn a_file_that_is_not_embedded_is_an_error_naming_it() {
        let err = ModelSource::Embedded.read(Path::new("no-such.onnx")).unwrap_err().to_string();
        assert!(err.contains("models/no-such.onnx (embedded)") && err.contains("not among"), "{err}");
    }
}
