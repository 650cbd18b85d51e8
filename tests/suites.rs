//! This repository's scenario suites as tests, through the same library
//! runner a planner crate uses ([`safer::runner`]): `specs/suites` (the
//! default suites, data shipped in the repository) and `specs/extended`
//! (recorded scenes from `../shared/data`, which fail loudly when it is
//! missing), snapshots in `snapshots/`.

fn main() {
    safer::runner::Runner::new(env!("CARGO_MANIFEST_DIR")).suites("specs/suites").suites("specs/extended").run()
}
