//! CommonRoad 2020a XML. Being written.

use std::path::Path;

use super::{ImportError, Location};
use crate::scenario::{Scenario, SourceFormat};

/// Parses one CommonRoad file.
pub fn parse(_bytes: &[u8], path: &Path) -> Result<Scenario, ImportError> {
    Err(ImportError::malformed(path, SourceFormat::CommonRoad, Location::File, "importer not written yet"))
}
