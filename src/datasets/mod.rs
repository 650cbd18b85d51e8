//! Training data for the shipped models, generated from scenes whose
//! licence allows training them (NGSIM, synthetic traffic):
//!
//! - [`held_out`]: the one rule that decides which scenes are held out;
//! - [`prior_shards`]: the realism prior's training shards (NGSIM +
//!   synthetic traffic calibrated against it), written by
//!   `safer prior-dataset`;
//! - [`feasibility_transitions`]: the ego–CBV transitions V_h is trained
//!   on (several ego policies × several CBV policies), written by
//!   `safer feasibility-dataset` and re-run on held-out scenes by
//!   `safer feasibility-eval`.
//!
//! This layer sits above `harness` (the collection episodes drive the CBV
//! with the SaFeR adversary through `harness::methods`) and below `cli`,
//! which only parses arguments and prints. Nothing here prints; progress is
//! reported through callbacks.

pub mod feasibility_transitions;
pub mod held_out;
pub mod prior_shards;

use std::path::PathBuf;

use rayon::prelude::*;

use crate::models::ModelError;
use crate::scenario::import::{self, ImportError};
use crate::scenario::{DataLicence, Scenario};

/// Why training data could not be generated.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// A recorded scene could not be imported.
    #[error(transparent)]
    Import(#[from] ImportError),
    /// A recorded scene's licence does not allow training the shipped models.
    #[error(
        "{}: licence {licence:?} does not allow training the shipped models (use NGSIM or synthetic scenes)",
        path.display()
    )]
    Licence {
        /// The scene's file.
        path: PathBuf,
        /// Its licence.
        licence: DataLicence,
    },
    /// A shard could not be written.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A shard's scene list could not be serialised.
    #[error("{}: cannot serialise the scene list: {source}", path.display())]
    Metadata {
        /// The shard.
        path: PathBuf,
        /// Why.
        source: serde_json::Error,
    },
}

/// What a model trained on the data may become.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TrainingPurpose {
    /// A model shipped in `models/`: only data whose licence allows it.
    Shipped,
    /// A model for measurements only, never committed: any licence (the
    /// shards say so, and the exporter refuses to write it into `models/`).
    EvaluationOnly,
}

/// The scenes in `paths` (each file may hold several), sorted by id; fails
/// on the first scene (in path order) whose licence does not allow training
/// the shipped models.
pub fn load_training_scenes(paths: &[PathBuf]) -> Result<Vec<Scenario>, DatasetError> {
    load_scenes_for(paths, TrainingPurpose::Shipped)
}

/// The scenes in `paths`, sorted by id, for a model of `purpose`: a
/// shipped model's data fails on the first scene whose licence does not
/// allow it.
pub fn load_scenes_for(paths: &[PathBuf], purpose: TrainingPurpose) -> Result<Vec<Scenario>, DatasetError> {
    let loaded: Vec<Result<Vec<Scenario>, ImportError>> = paths.par_iter().map(|p| import::load(p)).collect();
    let mut scenes = Vec::new();
    for file in loaded {
        for scene in file? {
            if purpose == TrainingPurpose::Shipped {
                check_licence(&scene)?;
            }
            scenes.push(scene);
        }
    }
    scenes.sort_by(|a, b| a.id.cmp(&b.id));
    Ok(scenes)
}

/// Fails unless `scene`'s licence allows training the shipped models.
pub fn check_licence(scene: &Scenario) -> Result<(), DatasetError> {
    if scene.source.licence.allows_training_shipped_models() {
        Ok(())
    } else {
        Err(DatasetError::Licence { path: scene.source.path.clone(), licence: scene.source.licence })
    }
}

/// Where a scene of the training data came from, as written into shard
/// metadata: `ngsim` for recorded public-domain scenes, else `synthetic`.
pub fn source_name(scene: &Scenario) -> &'static str {
    if scene.source.licence == DataLicence::PublicDomain { "ngsim" } else { "synthetic" }
}
