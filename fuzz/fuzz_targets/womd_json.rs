//! Fuzz target: arbitrary bytes through the WOMD JSON (nocturne / GPUDrive)
//! importer. Any input must give `Ok` or an `ImportError`, never a panic.

#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = safer_scenarios::scenario::import::womd_json::parse(data, Path::new("fuzz.json"));
});
