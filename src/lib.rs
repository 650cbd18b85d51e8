//! # safer
//!
//! A scenario-test framework for autonomous-driving planners, built on the
//! SaFeR method (feasibility-constrained token resampling): safety-critical,
//! realistic and *avoidable* traffic conflicts on every `cargo test`.
//!
//! A planner crate describes its tests as YAML suites (`specs/suites/*.yaml`:
//! which scenes, which planner, how many adversarial variants, which
//! acceptance criteria) and adds one test target whose `main` hands them to
//! the [`Runner`]. Every variant becomes a test; a failing one prints what
//! happened and leaves an MCAP recording and a picture behind.
//!
//! ## Quick start
//!
//! Implement [`Planner`] for your planner (or wrap it in an adapter): it
//! reads an [`Observation`] (the ego, the perceived road users, the map,
//! the signals) and answers a control or a trajectory.
//!
//! ```
//! use safer_scenarios::prelude::*;
//!
//! /// Drives straight on (no turning) and brakes for anyone within 20 m ahead.
//! struct Cautious;
//!
//! impl Planner for Cautious {
//!     fn name(&self) -> &str {
//!         "cautious"
//!     }
//!
//!     fn plan(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
//!         let heading = obs.ego.heading_rad;
//!         let ahead = obs.agents.iter().any(|agent| {
//!             let offset = agent.state.position - obs.ego.position;
//!             let along_m = offset.x * heading.cos() + offset.y * heading.sin();
//!             let across_m = offset.x * heading.sin() - offset.y * heading.cos();
//!             (0.0..20.0).contains(&along_m) && across_m.abs() < 2.0
//!         });
//!         let accel_mps2 = if ahead { -4.0 } else { 0.0 };
//!         Ok(PlannerOutput::Control(Action { accel_mps2, yaw_rate_radps: 0.0 }))
//!     }
//! }
//!
//! # let _ = Cautious.name();
//! ```
//!
//! Add safer as a dev-dependency with a test target of your own, and
//! optimise safer in debug builds (it does much numeric work):
//!
//! ```toml
//! [dev-dependencies]
//! safer = "0.1"
//!
//! [[test]]
//! name = "scenarios"
//! harness = false
//!
//! [profile.dev.package."*"]
//! opt-level = 3
//! ```
//!
//! Register the planner in that target (`tests/scenarios.rs`):
//!
//! ```no_run
//! # use safer_scenarios::prelude::*;
//! # struct Cautious;
//! # impl Planner for Cautious {
//! #     fn name(&self) -> &str { "cautious" }
//! #     fn plan(&mut self, _: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
//! #         Ok(PlannerOutput::Control(Action::default()))
//! #     }
//! # }
//! fn main() {
//!     Runner::new(env!("CARGO_MANIFEST_DIR"))
//!         .planner("cautious", |_scenario, _ego| Cautious)
//!         .run()
//! }
//! ```
//!
//! and name it in a suite, `specs/suites/mine.yaml`:
//!
//! ```yaml
//! name: mine
//! scenarios:
//!   - safer:specs/scenarios/highway-overtake.yaml
//! planner: { rust: cautious }
//! variants: 3
//! acceptance:
//!   variant: { no_collision: true, min_gap_m: 0.5 }
//! ```
//!
//! `cargo test` now runs every variant of every suite; `cargo test --
//! FILTER`, `--list` and cargo-nextest's partitions work as for any test.
//! The first run of a new suite records each variant's outcome as an insta
//! snapshot in `snapshots/` and fails until you accept them
//! (`cargo insta accept`, or `INSTA_UPDATE=always cargo test` without
//! cargo-insta); after that a changed outcome fails until reviewed.
//! Planners in other languages speak the JSON-lines planner protocol
//! instead (`docs/planner-protocol.md`; a Python kit is in `python/`).
//!
//! ## What is public
//!
//! The items re-exported here (and in [`prelude`]) are the API a planner
//! crate builds on. The modules behind them are the implementation of the
//! `safer` command line, its tests and benchmarks; they are reachable but
//! hidden from these docs and carry no stability promise. The layers and
//! what each owns are described in `ARCHITECTURE.md`.
#![warn(missing_docs)]
// The quick start shows the whole test target a planner crate writes, `main` included.
#![allow(clippy::needless_doctest_main)]

#[doc(hidden)]
pub mod datasets;
#[doc(hidden)]
pub mod eval;
#[doc(hidden)]
pub mod geometry;
#[doc(hidden)]
pub mod harness;
#[doc(hidden)]
pub mod map;
#[doc(hidden)]
pub mod message_text;
#[doc(hidden)]
pub mod models;
#[doc(hidden)]
pub mod motion;
#[doc(hidden)]
pub mod number;
#[doc(hidden)]
pub mod planners;
#[doc(hidden)]
pub mod policies;
#[doc(hidden)]
pub mod record;
pub mod runner;
#[doc(hidden)]
pub mod scenario;
#[doc(hidden)]
pub mod sim;
#[doc(hidden)]
pub mod spec;

pub use geometry::{Point2, Polyline};
pub use map::{Lane, MapElementId, RoadMap, SignalState};
pub use motion::Action;
pub use planners::{
    Observation, PerceivedAgent, Planner, PlannerError, PlannerOutput, PlannerStartup, TrajectoryPoint,
};
pub use runner::Runner;
pub use scenario::{AgentId, AgentKind, AgentState, Scenario, TrackIndex};

/// What a planner crate needs, in one import: `use safer_scenarios::prelude::*;`.
pub mod prelude {
    pub use crate::{
        Action, AgentId, AgentKind, AgentState, Lane, MapElementId, Observation, PerceivedAgent, Planner, PlannerError,
        PlannerOutput, Point2, Polyline, RoadMap, Runner, Scenario, SignalState, TrackIndex, TrajectoryPoint,
    };
}
