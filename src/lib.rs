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
//! the signals, the ego's [`Route`], the rollout's [`Horizon`] and
//! [`Goal`]) and answers a control or a trajectory. The observation has
//! the helpers the Python kit has: [`Observation::leader`] (the nearest
//! road user ahead in the ego's corridor along the route) and
//! [`Observation::nearest_lane`] (the ego's lane and its projection onto it).
//!
//! ```
//! use safer_scenarios::prelude::*;
//!
//! /// Keeps its lane (steering towards a point 10 m ahead on its route)
//! /// and brakes for a leader closer than 20 m.
//! struct Cautious;
//!
//! impl Planner for Cautious {
//!     fn name(&self) -> &str {
//!         "cautious"
//!     }
//!
//!     fn plan(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
//!         let speed = obs.ego.speed_mps();
//!         // Pure pursuit on the route: a point 10 m ahead of the ego's place on it.
//!         let yaw_rate_radps = match (obs.route_s_m, obs.route.at(obs.route_s_m.unwrap_or(0.0) + 10.0)) {
//!             (Some(_), Some((target, _))) => {
//!                 let to = target - obs.ego.position;
//!                 let heading_error = wrap_angle(to.y.atan2(to.x) - obs.ego.heading_rad);
//!                 2.0 * speed * heading_error.sin() / to.norm().max(1.0)
//!             }
//!             _ => 0.0, // off the lanes: straight on
//!         };
//!         let close = obs.leader().is_some_and(|leader| leader.gap_m < 20.0);
//!         let accel_mps2 = if close { -4.0 } else { 0.0 };
//!         Ok(PlannerOutput::Control(Action { accel_mps2, yaw_rate_radps }))
//!     }
//! }
//!
//! // On a lane curving left (radius 100 m) it keeps to the lane.
//! let arc = (0..=60).map(|k| 0.02 * k as f64).map(|a| Point2::new(100.0 * a.sin(), 100.0 * (1.0 - a.cos())));
//! let lane = Lane::new(MapElementId(1), Polyline::new(arc.collect()));
//! let map = RoadMap::new(vec![lane.clone()], vec![], vec![], vec![], vec![], vec![], vec![]);
//! let mut ego = AgentState { position: Point2::origin(), heading_rad: 0.0, velocity_mps: Vector2::new(10.0, 0.0) };
//! for _ in 0..60 {
//!     let obs = Observation::new(&map, ego);
//!     ego = Cautious.plan(&obs)?.next_state(&ego, obs.dt_s).expect("a finite control");
//! }
//! let off_m = lane.centreline.project(&ego.position).unwrap().distance_m;
//! assert!(off_m < 0.3, "{off_m} m off the lane");
//! # Ok::<(), PlannerError>(())
//! ```
//!
//! Add safer-scenarios as a dev-dependency with a test target of your own, and
//! optimise it in debug builds (it does much numeric work):
//!
//! ```toml
//! [dev-dependencies]
//! safer-scenarios = "0.1"
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
//! instead ([docs/planner-protocol.md]; a Python kit is in [python/]).
//!
//! [docs/planner-protocol.md]: https://github.com/safer-scenarios/safer/blob/main/docs/planner-protocol.md
//! [python/]: https://github.com/safer-scenarios/safer/blob/main/python
//!
//! ## What is public
//!
//! The items re-exported here (and in [`prelude`]) and the [`runner`]
//! module are the API a planner crate builds on; every type their
//! signatures name is among them. The modules behind them are the
//! implementation of the `safer` command line, its tests and benchmarks;
//! they are reachable but hidden from these docs and carry no stability
//! promise. The layers and what each owns are described in
//! [ARCHITECTURE.md].
//!
//! Foreign types in the API, whose major versions are part of it:
//!
//! - [nalgebra] 0.35: [`Point2`] and [`Vector2`] are its `Point2<f64>`
//!   and `Vector2<f64>` (re-exported, with the crate itself as
//!   [`nalgebra`], so a planner crate need not depend on the same version);
//! - [libtest-mimic] 0.8: [`runner::Arguments`], [`runner::Conclusion`],
//!   [`runner::Trial`] and [`runner::Failed`] of [`Runner::trials`] and
//!   [`Runner::run_with`], re-exported from [`runner`].
//!
//! Types that are expected to grow ([`AgentKind`], [`SignalState`], the
//! map's elements and kinds, [`PlannerError`], [`Observation`]) are
//! `#[non_exhaustive]`: match them with a `_` arm, and build map elements
//! with their `new` functions.
//!
//! [ARCHITECTURE.md]: https://github.com/safer-scenarios/safer/blob/main/ARCHITECTURE.md
//! [nalgebra]: https://docs.rs/nalgebra/0.35
//! [libtest-mimic]: https://docs.rs/libtest-mimic/0.8
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

/// The linear-algebra crate of [`Point2`] and [`Vector2`] (nalgebra 0.35).
pub use nalgebra;

pub use geometry::{OrientedBox, Point2, Polygon, Polyline, PolylineProjection, Pose2, Vector2, wrap_angle};
pub use map::{
    AreaKind, Lane, LaneKind, LaneMatch, MapArea, MapCounts, MapElementId, RoadEdge, RoadEdgeKind, RoadLine,
    RoadLineKind, RoadMap, SignalState, StopSign, TrafficSignal,
};
pub use motion::Action;
pub use planners::{
    EGO_LANE_SEARCH_M, Goal, Horizon, LEADER_MARGIN_M, LEADER_RANGE_M, Leader, Observation, OtherError, PerceivedAgent,
    Planner, PlannerError, PlannerOutput, PlannerStartup, Route, TrajectoryPoint,
};
pub use runner::Runner;
pub use scenario::{
    AgentBody, AgentId, AgentKind, AgentState, DataLicence, InvariantViolation, RoleOrigin, Scenario, ScenarioSource,
    SourceFormat, Track, TrackIndex,
};

/// What a planner crate needs, in one import: `use safer_scenarios::prelude::*;`.
pub mod prelude {
    pub use crate::{
        Action, AgentId, AgentKind, AgentState, Goal, Horizon, Lane, LaneMatch, Leader, MapElementId, Observation,
        PerceivedAgent, Planner, PlannerError, PlannerOutput, Point2, Polyline, PolylineProjection, RoadMap, Route,
        Runner, Scenario, SignalState, TrackIndex, TrajectoryPoint, Vector2, wrap_angle,
    };
}
