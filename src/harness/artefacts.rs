//! What a person needs to review a failed variant: an MCAP recording of the
//! stage-2 rollout (opens in Foxglove's 3D panel) and an SVG picture, both
//! written atomically under `<dir>/<suite>/<scenario>/<variant>.{mcap,svg}`.

use std::path::{Path, PathBuf};

use super::VariantOutcome;
use crate::record::{self, RecordError, SvgOptions};

/// Paths of a variant's artefacts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Artefacts {
    /// The recording.
    pub mcap: PathBuf,
    /// The picture.
    pub svg: PathBuf,
}

/// Writes the artefacts of `outcome` under `dir`.
pub fn write(dir: &Path, outcome: &VariantOutcome) -> Result<Artefacts, RecordError> {
    let rel: PathBuf = outcome.name.split("::").collect();
    let base = dir.join(rel);
    if let Some(parent) = base.parent() {
        std::fs::create_dir_all(parent).map_err(|source| RecordError::Io { path: parent.to_path_buf(), source })?;
    }
    let mcap = base.with_extension("mcap");
    let svg = base.with_extension("svg");
    record::write_rollout_mcap(&mcap, &outcome.scenario, &outcome.stage2, &[])?;
    record::write_svg(&svg, &record::render_rollout_svg(&outcome.scenario, &outcome.stage2, &SvgOptions::default()))?;
    Ok(Artefacts { mcap, svg })
}
