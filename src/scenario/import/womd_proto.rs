//! WOMD `Scenario` protobuf records (in TFRecord framing). Being written.

use std::path::Path;

use super::{ImportError, Location};
use crate::scenario::{Scenario, SourceFormat};

/// Parses every `Scenario` record of a TFRecord file.
pub fn parse(_bytes: &[u8], path: &Path) -> Result<Vec<Scenario>, ImportError> {
    Err(ImportError::malformed(path, SourceFormat::WomdProto, Location::File, "importer not written yet"))
}
