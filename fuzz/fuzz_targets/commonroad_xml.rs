//! Fuzz target: arbitrary bytes through the CommonRoad 2020a XML importer.
//! Any input must give `Ok` or an `ImportError` (with a line and column),
//! never a panic, a hang or a huge allocation.

#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = safer_scenarios::scenario::import::commonroad::parse(data, Path::new("fuzz.xml"));
});
