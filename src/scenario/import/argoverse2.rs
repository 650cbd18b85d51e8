//! Argoverse 2 motion-forecasting scenarios. Being written.

use std::path::{Path, PathBuf};

use super::{ImportError, Location};
use crate::scenario::{Scenario, SourceFormat};

/// The two files of one Argoverse 2 scenario.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ScenarioFiles {
    /// `scenario_<id>.parquet`.
    pub scenario: PathBuf,
    /// `log_map_archive_<id>.json`.
    pub map: PathBuf,
}

/// Finds the parquet and map of the scenario at `path` (either file or their folder).
pub fn find_scenario_files(path: &Path) -> Result<ScenarioFiles, ImportError> {
    Err(ImportError::UnknownFormat { path: path.to_path_buf(), reason: "importer not written yet".into() })
}

/// Parses one scenario from its parquet and map JSON bytes.
pub fn parse(_scenario: &[u8], _map: &[u8], path: &Path) -> Result<Scenario, ImportError> {
    Err(ImportError::malformed(path, SourceFormat::Argoverse2, Location::File, "importer not written yet"))
}
