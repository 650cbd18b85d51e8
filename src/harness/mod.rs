//! Specs to runnable tests: a suite resolves to named variants
//! (`suite::scenario::seed-k`) and suite metrics (`suite::metric`); each
//! variant runs the dual-stage pipeline ([`pipeline`]: stage 1, the ego
//! replays its log while the adversary drives the CBV; stage 2, the planner
//! under test drives the ego while the CBV replays its stage-1 trajectory),
//! is checked against the acceptance criteria, and on failure leaves an MCAP
//! recording and an SVG picture.
//!
//! One pipeline, one set of metrics: the `cargo test` runner
//! (`tests/suites.rs`) and `safer run` call [`run_variant`], `safer
//! evaluate` calls [`evaluation::evaluate`]; both run [`pipeline::run`] and
//! reduce variants to [`metrics::VariantTally`] for CR, SR, VJ and AJ.
//!
//! The results of a run ([`report::RunResults`]) are written as a JUnit
//! XML report ([`report::junit`]) and a static review page ([`report::review_page`]).

pub mod acceptance;
pub mod artefacts;
pub mod evaluation;
pub mod kill_ratio;
pub mod methods;
pub mod metrics;
pub mod mutation;
pub mod pipeline;
pub mod report;
pub mod shrink;
mod stable_hash;
pub mod suite;
pub mod trust_region;
pub mod variant;

pub use acceptance::AcceptanceFailure;
pub use metrics::{MetricCheck, SuiteMetrics, VariantTally};
pub use pipeline::{DualStage, Stage2Verdict};
pub use report::{RunResults, SuiteLoadFailure, SuiteRun, VariantRun};
pub use suite::{Suite, SuiteScenario};
pub use variant::{VariantOutcome, VariantSummary, run_variant};

/// Why a variant could not be run at all (as opposed to failing its criteria).
#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    /// A spec is broken.
    #[error(transparent)]
    Spec(#[from] crate::spec::SpecError),
    /// The rollout could not be set up.
    #[error(transparent)]
    Sim(#[from] crate::sim::SimError),
    /// The planner could not be started.
    #[error("planner `{planner}` could not be started: {source}")]
    PlannerStart {
        /// Planner name.
        planner: String,
        /// Why.
        source: crate::planners::PlannerError,
    },
    /// A learned model a method needs is missing or broken, or failed
    /// during the rollout.
    #[error("adversary method `{method:?}` cannot run: {source}")]
    Model {
        /// The method.
        method: crate::spec::suite::AdversaryMethod,
        /// Which model, which file, what differs (shared: one load error is
        /// reported by every variant that needs the model).
        source: std::sync::Arc<crate::models::ModelError>,
    },
    /// A scenario has no CBV to drive.
    #[error("scenario {0} has no CBV (name one with `cbv:` in the scenario spec)")]
    NoCbv(String),
    /// A failing variant's recording or picture could not be written.
    #[error("the variant's artefacts could not be written: {0}")]
    Artefacts(#[source] crate::record::RecordError),
}
