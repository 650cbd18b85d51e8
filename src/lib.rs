//! # safer
//!
//! A scenario-test framework for autonomous-driving planners, built on the
//! SaFeR method (feasibility-constrained token resampling): safety-critical,
//! realistic and *avoidable* traffic conflicts on every `cargo test`.
//!
//! The modules follow the layers of the design; a lower layer never imports
//! a higher one:
//!
//! | layer | owns |
//! | --- | --- |
//! | [`geometry`] | points, poses, oriented boxes (parry2d), polylines, polygons |
//! | [`map`] | typed map elements, lane graph, spatial index, road-edge distance |
//! | [`scenario`] | the in-memory scenario and the importers of recorded logs |
//! | [`motion`] | kinematic model, the 63×63 token grid, log-to-token inversion |
//! | [`models`] | ONNX models run by tract, model cards, feature builders |
//! | [`policies`] | who drives a background agent: log replay, constant velocity, IDM |
//! | [`planners`] | the ego under test: the planner trait and built-in planners |
//! | [`sim`] | the closed-loop engine, collision and off-road events, rollouts, authored scenes |
//! | [`eval`] | time to collision, Jensen–Shannon divergence (VJ, AJ), the feasibility witness and V_h's accuracy against it |
//! | [`spec`] | typed YAML specs (scenarios, planners, suites), JSON Schema export |
//! | [`harness`] | suites to variants, the dual-stage pipeline, acceptance, metrics, failure artefacts |
//! | [`record`] | MCAP recordings with Foxglove schemas, SVG pictures |
//! | [`datasets`] | training data for the shipped models: prior shards, feasibility transitions, the held-out rule |
//! | [`cli`] | the `safer` command line |
//! | [`runner`] | the scenario-suite test runner a planner crate's test target calls |

#![warn(missing_docs)]

pub mod cli;
pub mod datasets;
pub mod eval;
pub mod geometry;
pub mod harness;
pub mod map;
pub mod models;
pub mod motion;
pub mod planners;
pub mod policies;
pub mod record;
pub mod runner;
pub mod scenario;
pub mod sim;
pub mod spec;
