//! What a person needs to review a failed variant: an MCAP recording of the
//! stage-2 rollout (opens in Foxglove's 3D panel), an SVG picture and, for
//! an external planner, everything it wrote to stderr, all written by
//! [`crate::record::write_output`] under
//! `<dir>/<suite>/<scenario>/<variant>.{mcap,svg,stderr.txt}`. Where the
//! ego collided, both show the feasibility witness beside it when the
//! search finds one: an ego path that avoids every agent as they drove,
//! the evidence that the collision was avoidable.
//!
//! Every path stays inside `<dir>` whatever the suite and scenario are
//! called: each `::`-separated part of the variant name must be a plain
//! file name (not empty, `.` or `..`, no path separator, not absolute), or
//! nothing is written and the variant's artefacts fail with an error. Spec
//! loading already rejects such names; this is the second line of defence.

use std::path::{Component, Path, PathBuf};

use super::{Stage2Verdict, VariantOutcome};
use crate::eval::witness::{RoadKeeping, Witness, WitnessBudget, search_rollout_witness};
use crate::record::{self, NamedTrajectory, RecordError, SvgOptions, TimedPose, TrajectoryRole};

/// Paths of a variant's artefacts.
#[derive(Debug, Clone, PartialEq)]
pub struct Artefacts {
    /// The recording.
    pub mcap: PathBuf,
    /// The picture.
    pub svg: PathBuf,
    /// The planner's stderr (external planners only, even when empty).
    pub stderr: Option<PathBuf>,
    /// What the witness search found for the ego's collision (`None`: it
    /// did not collide).
    pub witness: Option<WitnessArtefact>,
}

/// What the feasibility witness search found for a stage-2 collision.
#[derive(Debug, Clone, PartialEq)]
pub enum WitnessArtefact {
    /// An escape, drawn in the recording and the picture.
    Found(NamedTrajectory),
    /// None within the search's budget.
    NoneWithinBudget,
}

impl WitnessArtefact {
    /// The verdict, for reports.
    pub fn verdict(&self) -> CollisionWitness {
        match self {
            Self::Found(_) => CollisionWitness::Found,
            Self::NoneWithinBudget => CollisionWitness::NoneWithinBudget,
        }
    }

    /// The escape, when one was found.
    pub fn path(&self) -> Option<&NamedTrajectory> {
        match self {
            Self::Found(path) => Some(path),
            Self::NoneWithinBudget => None,
        }
    }
}

/// What the feasibility witness search said about a stage-2 collision.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CollisionWitness {
    /// An escape exists, drawn in the recording and the picture: the
    /// collision was avoidable.
    Found,
    /// The search found none within its budget (not a proof that none
    /// exists).
    NoneWithinBudget,
}

impl CollisionWitness {
    /// One line for a person reading the run's report.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Found => "found: the collision was avoidable (the escape is drawn in both)",
            Self::NoneWithinBudget => "none found within the search's budget (not a proof it was unavoidable)",
        }
    }
}

/// The feasibility witness of a variant whose ego collided in stage 2: an
/// ego path from the same start, within the ego's limits and on the road,
/// that touches no agent as they drove in stage 1 (the CBV replays that in
/// stage 2, and replayed background agents drive the same), searched as
/// `safer evaluate` does. `None` when the ego did not collide.
pub fn feasibility_witness(outcome: &VariantOutcome) -> Option<WitnessArtefact> {
    if !matches!(outcome.verdict, Stage2Verdict::Collided { .. }) {
        return None;
    }
    let stage1 = &outcome.stage1;
    let Witness::Found { trajectory, min_clearance_m, .. } =
        search_rollout_witness(&outcome.scenario, stage1, RoadKeeping::default(), WitnessBudget::default())
    else {
        return Some(WitnessArtefact::NoneWithinBudget);
    };
    let body = outcome.scenario.track(stage1.ego).body();
    let poses = trajectory
        .iter()
        .enumerate()
        .map(|(k, s)| TimedPose { time_s: k as f64 * stage1.dt_s, pose: s.pose() })
        .collect();
    let name = format!("an escape keeping {min_clearance_m:.2} m from every agent");
    Some(WitnessArtefact::Found(NamedTrajectory {
        name,
        role: TrajectoryRole::FeasibilityWitness,
        body: Some(body),
        poses,
    }))
}

/// Writes the artefacts of `outcome` under `dir`.
pub fn write(dir: &Path, outcome: &VariantOutcome) -> Result<Artefacts, RecordError> {
    let base = dir.join(relative_path(dir, &outcome.name)?);
    if let Some(parent) = base.parent() {
        std::fs::create_dir_all(parent).map_err(|source| RecordError::Io { path: parent.to_path_buf(), source })?;
    }
    let mcap = base.with_extension("mcap");
    let svg = base.with_extension("svg");
    let witness = feasibility_witness(outcome);
    let extra: Vec<NamedTrajectory> = witness.iter().filter_map(WitnessArtefact::path).cloned().collect();
    record::write_rollout_mcap(&mcap, &outcome.scenario, &outcome.stage2, &extra)?;
    let picture = record::render_rollout_svg_with(&outcome.scenario, &outcome.stage2, &extra, &SvgOptions::default());
    record::write_svg(&svg, &picture)?;
    let stderr = match &outcome.planner_stderr {
        Some(log) => {
            let path = base.with_extension("stderr.txt");
            record::write_output(&path, log.as_bytes())?;
            Some(path)
        }
        None => None,
    };
    Ok(Artefacts { mcap, svg, stderr, witness })
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
