//! Fuzz target: arbitrary bytes (as lossy UTF-8) through the YAML spec
//! layer: suite, scenario and planner specs, their validation, the error
//! reports the CLI renders, and building authored scenarios. Any input must
//! give `Ok` or a `SpecError`, never a panic.
//!
//! Recorded scenarios (`recorded:`) and a suite's scenario list are not
//! resolved: both read the file system, which would make runs depend on
//! the machine and wander through its files.

#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use safer_scenarios::spec::planner::PlannerSpec;
use safer_scenarios::spec::scenario::ScenarioSpec;
use safer_scenarios::spec::suite::SuiteSpec;
use safer_scenarios::spec::{SpecError, parse_yaml};

/// Renders the miette report, as `safer` does, so offset arithmetic on
/// error locations is exercised too.
fn report(e: SpecError) {
    let _ = format!("{:?}", e.to_report());
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let path = Path::new("fuzz.yaml");

    match parse_yaml::<SuiteSpec>(&text, path) {
        Ok(suite) => {
            if let Err(e) = suite.validate() {
                report(e);
            }
        }
        Err(e) => report(e),
    }

    match parse_yaml::<PlannerSpec>(&text, path) {
        Ok(planner) => {
            if let Err(e) = planner.validate() {
                report(e);
            }
        }
        Err(e) => report(e),
    }

    match parse_yaml::<ScenarioSpec>(&text, path) {
        Ok(scenario) if scenario.value.recorded.is_none() => {
            if let Err(e) = scenario.build() {
                report(e);
            }
        }
        Ok(_) => {}
        Err(e) => report(e),
    }
});
