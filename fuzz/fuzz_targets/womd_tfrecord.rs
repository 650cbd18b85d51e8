//! Fuzz target: arbitrary bytes through the WOMD TFRecord + `Scenario`
//! protobuf importer. Any input must give `Ok` or an `ImportError`, never a
//! panic, a hang or a huge allocation.

#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = safer_scenarios::scenario::import::womd_proto::parse(data, Path::new("fuzz.tfrecord"));
    // Also with valid framing, so the fuzzer reaches the protobuf decoder and
    // the model mapping instead of stopping at the CRC checks.
    let framed = safer_scenarios::scenario::import::tfrecord::frame_record(data);
    let _ = safer_scenarios::scenario::import::womd_proto::parse(&framed, Path::new("fuzz.tfrecord"));
});
