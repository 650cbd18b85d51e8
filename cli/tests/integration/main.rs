//! Integration tests: one binary (one link step) with a module per concern.
//! Tests that need the recorded scenes in `$SAFER_DATA_DIR` fail loudly when
//! it is missing; see [`shared_data`].

/// The repository's root, where the specs, scenes, planners and fixtures
/// these tests use lie (this package is its `cli/` folder). A literal, so
/// that `concat!` can extend it.
macro_rules! repo_root {
    () => {
        concat!(env!("CARGO_MANIFEST_DIR"), "/..")
    };
}

mod scratch;
mod shared_data;
mod shrink;

mod adversary;
mod bad_input;
mod bench;
mod cli;
mod cli_run;
mod closed_loop;
mod commonroad_export;
mod conflict_coverage;
mod docs_links;
mod docs_tables;
mod evaluate_partitions;
mod feasibility_eval;
mod feasibility_model;
mod import_argoverse2;
mod import_commonroad;
mod import_womd_json;
mod import_womd_proto;
mod mutation;
mod prior_model;
mod protocol;
mod protocol_road_edges;
mod realism;
mod runner;
mod simulate_recorded;
mod token_roundtrip;
mod trust_region;
mod verdicts;
