//! What a person needs to review a failed variant: an MCAP recording of the
//! stage-2 rollout (opens in Foxglove's 3D panel), an SVG picture and, for
//! an external planner, everything it wrote to stderr, all written by
//! [`crate::record::write_output`] under
//! `<dir>/<suite>/<scenario>/<variant>.{mcap,svg,stderr.txt}`; and the
//! recording and picture of stage 1 (`<variant>.stage1.{mcap,svg}`): the
//! conflict as the adversary made it, its CBV against the ego replaying
//! its log, which the planner's own run (where the CBV may react, and the
//! ego goes its own way) no longer shows. Where the
//! ego collided, both show the closed-loop feasibility witness beside it
//! when the search verified one: an ego path that, played again with the
//! CBV reacting, touches nobody, the evidence that the collision was
//! avoidable.
//!
//! Every path stays inside `<dir>` whatever the suite and scenario are
//! called: each `::`-separated part of the variant name must be a plain
//! file name (not empty, `.` or `..`, no path separator, not absolute), or
//! nothing is written and the variant's artefacts fail with an error. Spec
//! loading already rejects such names; this is the second line of defence.

use std::path::{Component, Path, PathBuf};

use super::{Stage2Verdict, VariantOutcome};
use crate::eval::escape::CollisionEscape;
use crate::eval::escape::EscapeVerdict;
use crate::eval::witness::{DEFAULT_WIDEST, RoadKeeping, Witness, WitnessBudget, search_rollout_witness};
use crate::record::{self, NamedTrajectory, RecordError, SvgOptions, TimedPose, TrajectoryRole};
use crate::scenario::AgentState;

/// What stage 1's recording and picture show, in the words every report
/// uses for them.
pub const STAGE1_SHOWS: &str = "the ego replaying its log against the variant's CBV";

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
    /// For a shrunk variant, the recording and picture of the variant as
    /// the adversary made it (`seed-K.unshrunk.{mcap,svg}`); the main ones
    /// show the shrunk variant.
    pub unshrunk: Option<(PathBuf, PathBuf)>,
    /// The recording and picture of stage 1 (`seed-K.stage1.{mcap,svg}`):
    /// the ego replaying its log and the CBV as the adversary drove it
    /// against it (the variant as made, before any shrinking).
    pub stage1: (PathBuf, PathBuf),
    /// Stage 1's feasibility witness drawn in them ([`stage1_escape`]), where
    /// the CBV hit the ego there and the search found an escape.
    pub stage1_escape: Option<NamedTrajectory>,
}

/// What the closed-loop feasibility witness found for a stage-2 collision.
#[derive(Debug, Clone, PartialEq)]
pub enum WitnessArtefact {
    /// A verified escape, drawn in the recording and the picture.
    Found(NamedTrajectory),
    /// None within the search's budget (how it ended).
    NoneWithinBudget(CollisionEscape),
}

impl WitnessArtefact {
    /// The verdict, for reports.
    pub fn verdict(&self) -> CollisionEscape {
        match self {
            Self::Found(_) => CollisionEscape::Avoidable,
            Self::NoneWithinBudget(verdict) => *verdict,
        }
    }

    /// The escape, when one was found.
    pub fn path(&self) -> Option<&NamedTrajectory> {
        match self {
            Self::Found(path) => Some(path),
            Self::NoneWithinBudget(_) => None,
        }
    }
}

/// The feasibility witness of a variant whose ego collided in stage 2, as
/// the variant's closed-loop witness search found it: an ego path from the
/// same start, within the ego's limits and on the road, that touched
/// nobody when stage 2 was played again with it, the CBV reacting as it
/// did. `None` when the ego did not collide (or no witness was searched).
pub fn feasibility_witness(outcome: &VariantOutcome) -> Option<WitnessArtefact> {
    if !matches!(outcome.verdict, Stage2Verdict::Collided { .. }) {
        return None;
    }
    let search = outcome.escape.as_ref()?;
    let EscapeVerdict::Verified { trajectory, min_gap_m } = &search.verdict else {
        return Some(WitnessArtefact::NoneWithinBudget(CollisionEscape::of(search)));
    };
    let name = format!("an escape keeping {min_gap_m:.2} m from every agent, the CBV reacting");
    Some(WitnessArtefact::Found(escape_trajectory(outcome, &outcome.stage2, trajectory, name)))
}

/// An ego escape from `rollout`'s start, drawn beside it: `states` one per
/// step, the ego's body.
fn escape_trajectory(
    outcome: &VariantOutcome,
    rollout: &crate::sim::Rollout,
    states: &[AgentState],
    name: String,
) -> NamedTrajectory {
    let dt_s = rollout.dt_s;
    NamedTrajectory {
        name,
        role: TrajectoryRole::FeasibilityWitness,
        body: Some(outcome.scenario.track(rollout.ego).body()),
        poses: states.iter().enumerate().map(|(k, s)| TimedPose { time_s: k as f64 * dt_s, pose: s.pose() }).collect(),
    }
}

/// Where `variant`'s artefacts go under `dir`, without extension
/// ([`relative_path`]), its folder created.
pub fn base_path(dir: &Path, variant: &str) -> Result<PathBuf, RecordError> {
    let base = dir.join(relative_path(dir, variant)?);
    if let Some(parent) = base.parent() {
        std::fs::create_dir_all(parent).map_err(|source| RecordError::Io { path: parent.to_path_buf(), source })?;
    }
    Ok(base)
}

/// Stage 1's feasibility witness `witness`, as drawn beside stage 1: the
/// ego's escape from the CBV and the traffic as they drove, when the
/// search found one.
pub fn stage1_escape(outcome: &VariantOutcome, witness: &Witness) -> Option<NamedTrajectory> {
    let Witness::Found { trajectory, min_clearance_m, .. } = witness else { return None };
    let name = format!("an escape keeping {min_clearance_m:.2} m from every agent as they drove");
    Some(escape_trajectory(outcome, &outcome.stage1, trajectory, name))
}

/// Searches stage 1's feasibility witness where the CBV hit the ego there,
/// as `safer evaluate` does by default (the ego's centre kept on the road,
/// the beam widened up to ×[`DEFAULT_WIDEST`]): its [`stage1_escape`]
/// when it finds one; `None` without a stage-1 collision or an escape.
pub fn search_stage1_escape(outcome: &VariantOutcome) -> Option<NamedTrajectory> {
    if !outcome.stage1_cbv_hit_ego() {
        return None;
    }
    let budget = WitnessBudget::widening_up_to(DEFAULT_WIDEST);
    stage1_escape(outcome, &search_rollout_witness(&outcome.scenario, &outcome.stage1, RoadKeeping::Centre, budget))
}

/// Writes the artefacts of `outcome` under `dir`, stage 1's with
/// `stage1_escape` drawn beside it (its [`stage1_escape`], where one was
/// searched for and found).
pub fn write(
    dir: &Path,
    outcome: &VariantOutcome,
    stage1_escape: Option<NamedTrajectory>,
) -> Result<Artefacts, RecordError> {
    let base = base_path(dir, &outcome.name)?;
    let mcap = base.with_extension("mcap");
    let svg = base.with_extension("svg");
    let witness = feasibility_witness(outcome);
    let extra: Vec<NamedTrajectory> = witness.iter().filter_map(WitnessArtefact::path).cloned().collect();
    let write_pair = |mcap: &Path, svg: &Path, rollout: &crate::sim::Rollout, extra: &[NamedTrajectory]| {
        record::write_rollout_mcap(mcap, &outcome.scenario, rollout, extra)?;
        let picture = record::render_rollout_svg_with(&outcome.scenario, rollout, extra, &SvgOptions::default());
        record::write_svg(svg, &picture)
    };
    // A shrunk variant is shown first; the escape drawn belongs to the
    // variant as made, so it goes with the unshrunk files.
    let unshrunk = match &outcome.shrunk {
        Some(shrunk) => {
            let (original_mcap, original_svg) =
                (base.with_extension("unshrunk.mcap"), base.with_extension("unshrunk.svg"));
            write_pair(&original_mcap, &original_svg, &outcome.stage2, &extra)?;
            let name = format!(
                "an escape keeping {:.2} m from every agent, the CBV on its shrunk path",
                shrunk.escape_clearance_m
            );
            let escape = escape_trajectory(outcome, &shrunk.stage2, &shrunk.escape, name);
            write_pair(&mcap, &svg, &shrunk.stage2, &[escape])?;
            Some((original_mcap, original_svg))
        }
        None => {
            write_pair(&mcap, &svg, &outcome.stage2, &extra)?;
            None
        }
    };
    let stage1 = (base.with_extension("stage1.mcap"), base.with_extension("stage1.svg"));
    write_pair(&stage1.0, &stage1.1, &outcome.stage1, stage1_escape.as_slice())?;
    let stderr = match &outcome.planner_stderr {
        Some(log) => {
            let path = base.with_extension("stderr.txt");
            record::write_output(&path, log.as_bytes())?;
            Some(path)
        }
        None => None,
    };
    Ok(Artefacts { mcap, svg, stderr, witness, unshrunk, stage1, stage1_escape })
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
