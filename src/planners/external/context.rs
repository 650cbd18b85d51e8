//! Which scene and variant an external planner drives: the
//! [`RolloutContext`] the harness hands to it, what `hello` tells of it
//! (scenario, frame origin, horizon, goal), the placeholders its `args`
//! and `env` values may use (`{scenario}`, `{variant}`, `{seed}`,
//! `{format}`, `{source}`), and the `SAFER_*` environment variables the
//! harness sets for it.

use std::sync::Arc;

use super::wire::{WireGoal, WireHorizon, WireScenario};
use crate::geometry::Point2;
use crate::scenario::{Scenario, TrackIndex};

/// The placeholders `args` and `env` values may use, each written `{name}`
/// (`{{` and `}}` stand for literal braces).
pub const PLACEHOLDERS: [&str; 5] = ["scenario", "variant", "seed", "format", "source"];

/// `id` with every character but ASCII letters, digits, `-`, `_` and `.`
/// replaced by `_`, and an all-dots id (`.`, `..`) by as many `_`: a
/// scene's id as a file name or an argument, never a path or shell syntax.
pub fn file_safe(id: &str) -> String {
    let safe: String =
        id.chars().map(|c| if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') { c } else { '_' }).collect();
    if safe.chars().all(|c| c == '.') { "_".repeat(safe.len().max(1)) } else { safe }
}

/// The scene and variant a planner drives.
#[derive(Debug, Clone)]
pub struct RolloutContext {
    /// The scenario.
    pub scenario: Arc<Scenario>,
    /// The ego's track.
    pub ego: TrackIndex,
    /// First step of the rollout.
    pub start_step: usize,
    /// Last step of the rollout (inclusive).
    pub end_step: usize,
    /// The variant's name (`suite::scenario::seed-k`), when there is one.
    pub variant: Option<String>,
    /// The variant's seed, when there is one.
    pub seed: Option<u64>,
}

impl RolloutContext {
    /// The seed the planner is told (`hello.scenario.seed`, `{seed}`,
    /// `SAFER_SEED`): the variant's 64-bit seed's top 53 bits, so it is the
    /// same number in every language, and still one per variant.
    pub fn planner_seed(&self) -> Option<u64> {
        self.seed.map(|seed| seed >> 11)
    }

    /// The values of the placeholders (and of the `SAFER_*` variables).
    fn values(&self) -> [(&'static str, String); 5] {
        let s = &self.scenario;
        // Ids come from the recorded files: made safe to use as file names
        // and arguments (no `/`, no `..`, no shell syntax) before they
        // reach a command line or an environment variable.
        let variant = self.variant.as_deref().unwrap_or(&s.id);
        [
            ("scenario", file_safe(&s.id)),
            ("variant", variant.split("::").map(file_safe).collect::<Vec<_>>().join("::")),
            ("seed", self.planner_seed().map(|v| v.to_string()).unwrap_or_default()),
            ("format", s.source.format.name().to_owned()),
            ("source", self.source_file()),
        ]
    }

    /// The scene's file as an absolute path: the planner runs in its own
    /// working folder, where a path relative to the harness's would name
    /// another file or none. Links are resolved where the file exists.
    fn source_file(&self) -> String {
        let path = &self.scenario.source.path;
        std::fs::canonicalize(path)
            .or_else(|_| std::path::absolute(path))
            .unwrap_or_else(|_| path.clone())
            .display()
            .to_string()
    }

    /// The environment variables the harness sets for the planner:
    /// `SAFER_SCENARIO`, `SAFER_VARIANT`, `SAFER_SEED` (empty without a
    /// seed), `SAFER_FORMAT`, `SAFER_SOURCE`, and `SAFER_PROTOCOL` (the harness's revision, `1.2`).
    pub fn env(&self) -> Vec<(String, String)> {
        let mut env: Vec<(String, String)> =
            self.values().into_iter().map(|(k, v)| (format!("SAFER_{}", k.to_uppercase()), v)).collect();
        env.push(("SAFER_PROTOCOL".into(), format!("{}.{}", super::PROTOCOL_VERSION, super::PROTOCOL_MINOR)));
        env
    }

    /// `text` with its placeholders replaced.
    pub fn expand(&self, text: &str) -> Result<String, String> {
        expand(text, &self.values())
    }

    /// The scenario part of `hello`.
    pub(super) fn wire_scenario(&self) -> WireScenario {
        let s = &self.scenario;
        WireScenario {
            id: s.id.clone(),
            format: s.source.format.name().to_owned(),
            source_file: self.source_file(),
            variant: self.variant.clone(),
            seed: self.planner_seed(),
        }
    }

    /// The horizon part of `hello`.
    pub(super) fn wire_horizon(&self, dt_s: f64) -> WireHorizon {
        let steps = self.end_step.saturating_sub(self.start_step);
        WireHorizon { start_step: self.start_step, steps, dt_s, duration_s: steps as f64 * dt_s }
    }

    /// The ego's last valid recorded state, as `hello`'s goal.
    pub(super) fn wire_goal(&self) -> Option<WireGoal> {
        let goal = crate::planners::Goal::recorded(&self.scenario, self.ego)?;
        let state = goal.state;
        Some(WireGoal { x: state.position.x, y: state.position.y, heading_rad: state.heading_rad, step: goal.step })
    }

    /// The ego's recorded positions from the start on (the route's guide at forks).
    pub(crate) fn recorded_path(&self) -> Vec<Point2> {
        crate::planners::route::recorded_path(&self.scenario, self.ego, self.start_step)
    }
}

/// `text` with every `{name}` replaced by its value; `{{`/`}}` are literal
/// braces. An unknown name or an unclosed brace is an error saying which.
pub fn expand(text: &str, values: &[(&str, String)]) -> Result<String, String> {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find(['{', '}']) {
        out.push_str(&rest[..i]);
        let tail = &rest[i..];
        if let Some(after) = tail.strip_prefix("{{") {
            out.push('{');
            rest = after;
        } else if let Some(after) = tail.strip_prefix("}}") {
            out.push('}');
            rest = after;
        } else if tail.starts_with('}') {
            return Err(format!("`{text}` has a `}}` without its `{{` (write `}}}}` for a literal brace)"));
        } else {
            let Some(end) = tail.find('}') else {
                return Err(format!("`{text}` has a `{{` without its `}}` (write `{{{{` for a literal brace)"));
            };
            let name = &tail[1..end];
            let Some((_, value)) = values.iter().find(|(k, _)| *k == name) else {
                return Err(format!(
                    "`{text}` uses the unknown placeholder `{{{name}}}`; known: {}",
                    PLACEHOLDERS.map(|p| format!("{{{p}}}")).join(", ")
                ));
            };
            out.push_str(value);
            rest = &tail[end + 1..];
        }
    }
    out.push_str(rest);
    Ok(out)
}

/// Checks `text`'s placeholders without values (for spec validation).
pub fn check_placeholders(text: &str) -> Result<(), String> {
    let values = PLACEHOLDERS.map(|p| (p, String::new()));
    expand(text, &values).map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_from_recorded_files_are_made_safe_for_file_names_and_arguments() {
        assert_eq!(file_safe("x$(touch PWNED)"), "x__touch_PWNED_");
        assert_eq!(file_safe("../../etc"), ".._.._etc");
        assert_eq!(file_safe(".."), "__");
        assert_eq!(file_safe(""), "_");
        assert_eq!(file_safe("USA_US101-4_3_T-1"), "USA_US101-4_3_T-1");
    }

    #[test]
    fn placeholders_are_replaced_and_unknown_ones_refused() {
        let values = [("scenario", "US101".to_string()), ("seed", "7".to_string())];
        assert_eq!(expand("--scene={scenario} -s {seed}", &values).unwrap(), "--scene=US101 -s 7");
        assert_eq!(expand("{{literal}} }}", &values).unwrap(), "{literal} }");
        let e = expand("{scene}", &values).unwrap_err();
        assert!(e.contains("unknown placeholder `{scene}`") && e.contains("{variant}"), "{e}");
        assert!(expand("{scenario", &values).unwrap_err().contains("without its `}`"));
        assert!(check_placeholders("out/{variant}.log").is_ok());
    }
}
