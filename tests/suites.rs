//! This repository's scenario suites as tests, through the same library
//! runner a planner crate uses ([`safer_scenarios::runner`]): `specs/suites` (the
//! default suites, data shipped in the repository) and `specs/extended`
//! (recorded scenes from `$SAFER_DATA_DIR`: listed as ignored where it is
//! unset, failing loudly where `CI` or `SAFER_REQUIRE_DATA` says the data
//! must be there), snapshots in `snapshots/`. Spec warnings are denied:
//! every shipped suite says what it means, so a suite that warns fails.

fn main() {
    safer_scenarios::runner::Runner::new(env!("CARGO_MANIFEST_DIR"))
        .suites("specs/suites")
        .suites("specs/extended")
        .deny_warnings(true)
        .run()
}
