//! What a person needs to review a failed variant: an MCAP recording of the
//! stage-2 rollout (opens in Foxglove's 3D panel), an SVG picture and, for
//! an external planner, everything it wrote to stderr, all written by
//! [`crate::record::write_output`] under
//! `<dir>/<suite>/<scenario>/<variant>.{mcap,svg,stderr.txt}`.
//!
//! Every path stays inside `<dir>` whatever the suite and scenario are
//! called: each `::`-separated part of the variant name must be a plain
//! file name (not empty, `.` or `..`, no path separator, not absolute), or
//! nothing is written and the variant's artefacts fail with an error. Spec
//! loading already rejects such names; this is the second line of defence.

use std::path::{Component, Path, PathBuf};

use super::VariantOutcome;
use crate::record::{self, RecordError, SvgOptions};

/// Paths of a variant's artefacts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Artefacts {
    /// The recording.
    pub mcap: PathBuf,
    /// The picture.
    pub svg: PathBuf,
    /// The planner's stderr (external planners only, even when empty).
    pub stderr: Option<PathBuf>,
}

/// Writes the artefacts of `outcome` under `dir`.
pub fn write(dir: &Path, outcome: &VariantOutcome) -> Result<Artefacts, RecordError> {
    let base = dir.join(relative_path(dir, &outcome.name)?);
    if let Some(parent) = base.parent() {
        std::fs::create_dir_all(parent).map_err(|source| RecordError::Io { path: parent.to_path_buf(), source })?;
    }
    let mcap = base.with_extension("mcap");
    let svg = base.with_extension("svg");
    record::write_rollout_mcap(&mcap, &outcome.scenario, &outcome.stage2, &[])?;
    record::write_svg(&svg, &record::render_rollout_svg(&outcome.scenario, &outcome.stage2, &SvgOptions::default()))?;
    let stderr = match &outcome.planner_stderr {
        Some(log) => {
            let path = base.with_extension("stderr.txt");
            record::write_output(&path, log.as_bytes())?;
            Some(path)
        }
        None => None,
    };
    Ok(Artefacts { mcap, svg, stderr })
}

/// The artefacts' path under `dir` (without extension) for the variant
/// `suite::scenario::seed-k`: one folder level per `::` part, each checked
/// to be a plain file name.
pub fn relative_path(dir: &Path, variant: &str) -> Result<PathBuf, RecordError> {
    let mut rel = PathBuf::new();
    for part in variant.split("::") {
        let plain = !part.contains(['/', '\\', '\0'])
            && matches!(Path::new(part).components().collect::<Vec<_>>().as_slice(), [Component::Normal(_)]);
        if !plain {
            return Err(RecordError::InvalidPath {
                path: dir.join(variant.replace("::", "/")),
                reason: format!(
                    "variant name `{variant}` has the part `{part}`, which is not a plain file name \
                     (empty, `.`, `..`, absolute or holding a path separator), so its artefacts \
                     could land outside {}",
                    dir.display()
                ),
            });
        }
        rel.push(part);
    }
    Ok(rel)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plain_variant_name_nests_one_folder_per_part() {
        let rel = relative_path(Path::new("out"), "authored::highway-overtake::seed-0").unwrap();
        assert_eq!(rel, Path::new("authored/highway-overtake/seed-0"));
        // A dot inside a name is fine; only whole `.`/`..` parts are not.
        assert!(relative_path(Path::new("out"), "v1.2::a..b::seed-3").is_ok());
    }

    #[test]
    fn parts_that_could_escape_the_folder_are_refused() {
        for bad in [
            "..::scenario::seed-0",
            "suite::..::seed-0",
            ".::scenario::seed-0",
            "suite::::seed-0",
            "suite::a/../../etc::seed-0",
            "suite::/etc::seed-0",
            "suite::a\\b::seed-0",
            "suite::scenario::",
            "",
        ] {
            let err = relative_path(Path::new("out"), bad).unwrap_err();
            assert!(matches!(err, RecordError::InvalidPath { .. }), "{bad}: {err}");
            assert!(err.to_string().contains("not a plain file name"), "{bad}: {err}");
        }
    }
}
