//! The bad-input suite: every way a user, a planner or a recording can hand
//! the harness something broken, each a fixture under
//! `tests/fixtures/bad-input/<area>/` named for what it shows. Each test
//! checks three things: the run ends (no hang), the verdict is right (a
//! broken variant is never a pass), and the message names the file, line
//! and column (or the record) of the offending value. Nothing outside the
//! chosen output paths is written.

mod binary;
mod files;
mod hangs;
mod outputs;
mod planners;
mod specs;
mod traffic_rules;
