//! WOMD scenes in the nocturne / GPUDrive JSON format. Being written.

use std::path::Path;

use super::{ImportError, Location};
use crate::scenario::{Scenario, SourceFormat};

/// Parses one JSON scene.
pub fn parse(_bytes: &[u8], path: &Path) -> Result<Scenario, ImportError> {
    Err(ImportError::malformed(path, SourceFormat::WomdJson, Location::File, "importer not written yet"))
}
