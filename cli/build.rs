//! Marks the build for the tests over recorded data: `cfg(recorded_data)`
//! where `SAFER_DATA_DIR` is set, or where missing data must fail (`CI`,
//! `SAFER_REQUIRE_DATA`). Without it those tests are listed as ignored,
//! with a message saying how to run them, so `cargo test` passes on a
//! machine with only the clone and never skips them silently in CI.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(recorded_data)");
    for name in ["SAFER_DATA_DIR", "CI", "SAFER_REQUIRE_DATA"] {
        println!("cargo::rerun-if-env-changed={name}");
    }
    let set = |name: &str| std::env::var(name).is_ok_and(|v| !v.is_empty() && v != "0" && v != "false");
    if set("SAFER_DATA_DIR") || set("CI") || set("SAFER_REQUIRE_DATA") {
        println!("cargo::rustc-cfg=recorded_data");
    }
}
