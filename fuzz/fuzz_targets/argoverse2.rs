//! Fuzz target: arbitrary bytes through the Argoverse 2 importer, which
//! takes two inputs. The first four bytes (little-endian `u32`, taken
//! modulo what is left) say how many of the following bytes are the
//! scenario parquet; the rest is the map JSON. Any input must give `Ok` or
//! an `ImportError`, never a panic.
//!
//! The importer turns a panic inside the `parquet` decoder into an error,
//! but libFuzzer's panic hook aborts before that can happen, so such
//! panics show up here as crashes: they are the dependency's, and worth
//! reporting upstream.
//!
//! The importer decodes each parquet file on its own thread, given up on
//! after a deadline; a thread still running when the fuzzer exits shows as
//! a leak, so run it with `ASAN_OPTIONS=detect_leaks=0`.

#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (head, rest) = data.split_at(data.len().min(4));
    let mut prefix = [0u8; 4];
    prefix[..head.len()].copy_from_slice(head);
    let split = (u32::from_le_bytes(prefix) as usize) % (rest.len() + 1);
    let (scenario, map) = rest.split_at(split);
    let _ = safer_scenarios::scenario::import::argoverse2::parse(scenario, map, Path::new("scenario_fuzz.parquet"));
});
