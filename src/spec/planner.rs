//! Planner adapters (`planners/*.yaml`): which planner drives the ego.
//!
//! ```yaml
//! # planners/idm.yaml
//! name: idm
//! builtin: idm
//! ```
//! ```yaml
//! # planners/example-python.yaml
//! name: example-python
//! external:
//!   command: python3
//!   args: [example_planner.py]
//!   step_timeout_ms: 1000
//! ```

use schemars::JsonSchema;
use serde::Deserialize;

use crate::planners::{BuiltinPlanner, EvasiveParams};
use crate::policies::IdmParams;

/// A planner adapter spec. Exactly one of `builtin`, `external` and `onnx`.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlannerSpec {
    /// Name used in reports and test names.
    pub name: String,
    /// A built-in planner.
    #[serde(default)]
    pub builtin: Option<BuiltinPlanner>,
    /// Parameters of the built-in IDM planner.
    #[serde(default)]
    #[schemars(with = "Option<serde_json::Value>")]
    pub idm: Option<IdmParams>,
    /// Parameters of the built-in evasive planner (any left out keep their
    /// defaults), for example `evasive: { avoided_contacts: at-fault }`.
    #[serde(default)]
    #[schemars(with = "Option<serde_json::Value>")]
    pub evasive: Option<EvasiveParams>,
    /// An external process speaking the JSON-lines planner protocol (docs/planner-protocol.md).
    #[serde(default)]
    pub external: Option<ExternalSpec>,
    /// An ONNX policy run with tract (not available yet: refused at load).
    #[serde(default)]
    pub onnx: Option<OnnxSpec>,
}

/// An external planner process.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExternalSpec {
    /// Program to run (looked up on PATH unless it contains a slash).
    pub command: String,
    /// Arguments; relative file arguments are relative to the working
    /// directory. `{scenario}`, `{variant}`, `{seed}`, `{format}` and
    /// `{source}` are replaced per variant (`{{`/`}}`: literal braces).
    #[serde(default)]
    pub args: Vec<String>,
    /// Per-step answer timeout, ms, 1..=600000 (10 min).
    #[serde(default = "default_step_timeout")]
    #[schemars(range(min = 1, max = 600_000))]
    pub step_timeout_ms: u64,
    /// Answer timeout of the first observation, ms, 1..=600000 (10 min);
    /// `step_timeout_ms` when absent.
    #[serde(default)]
    #[schemars(range(min = 1, max = 600_000))]
    pub first_step_timeout_ms: Option<u64>,
    /// Time allowed to start and answer `hello` (and, in protocol 1.1,
    /// `prepare`), ms, 1..=600000 (10 min).
    #[serde(default = "default_startup_timeout")]
    #[schemars(range(min = 1, max = 600_000))]
    pub startup_timeout_ms: u64,
    /// Extra environment variables for the process (added to the harness's
    /// own and its `SAFER_*` ones); values take the placeholders of `args`.
    #[serde(default)]
    pub env: std::collections::BTreeMap<String, String>,
    /// Working directory, relative to the planner spec's folder (default: that folder); must exist.
    #[serde(default)]
    pub working_dir: Option<String>,
}

/// The longest step or startup timeout a spec may ask for, ms (10 min): a
/// longer one is a typo, and would stall a CI run for hours.
pub const MAX_TIMEOUT_MS: u64 = 600_000;

fn default_step_timeout() -> u64 {
    1000
}
fn default_startup_timeout() -> u64 {
    10_000
}

/// An ONNX policy.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OnnxSpec {
    /// The model file.
    pub model: String,
}

/// The factory of an in-process planner, as a suite resolved it.
#[derive(Clone)]
pub struct InProcessFactory(pub crate::planners::registry::PlannerFactory);

impl std::fmt::Debug for InProcessFactory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("InProcessFactory")
    }
}

/// A validated planner adapter.
#[derive(Debug, Clone)]
pub enum PlannerAdapter {
    /// Built-in.
    Builtin {
        /// Name for reports.
        name: String,
        /// Which.
        planner: BuiltinPlanner,
        /// IDM parameters.
        idm: IdmParams,
        /// Evasive planner parameters.
        evasive: EvasiveParams,
    },
    /// An in-process planner registered under `name`
    /// ([`crate::planners::registry`]), resolved when the suite was loaded.
    InProcess {
        /// The registered name, also used in reports.
        name: String,
        /// Makes the planner, once per variant.
        factory: InProcessFactory,
    },
    /// External process, started in `working_dir` with `spec.env` added
    /// to its environment.
    External {
        /// Name for reports.
        name: String,
        /// The process.
        spec: ExternalSpec,
        /// Working directory: `spec.working_dir` resolved against the spec's
        /// folder, else that folder.
        working_dir: std::path::PathBuf,
    },
}

impl PlannerAdapter {
    /// A built-in planner with default parameters, named as in specs (`idm`, `evasive`, ...).
    pub fn builtin(planner: BuiltinPlanner) -> Self {
        Self::Builtin {
            name: super::spec_name(&planner),
            planner,
            idm: IdmParams::default(),
            evasive: EvasiveParams::default(),
        }
    }

    /// A planner spec file (`planners/NAME.yaml`), loaded and validated.
    pub fn load(path: &std::path::Path) -> Result<Self, super::SpecError> {
        super::load_yaml::<PlannerSpec>(path)?.validate()
    }

    /// Name for reports and test names.
    pub fn name(&self) -> &str {
        match self {
            Self::Builtin { name, .. } | Self::InProcess { name, .. } | Self::External { name, .. } => name,
        }
    }

    /// The files an external planner's arguments name (its program, say),
    /// resolved in its working folder: inputs a run must not overwrite.
    pub fn argument_files(&self) -> Vec<std::path::PathBuf> {
        match self {
            Self::External { spec, working_dir, .. } => {
                spec.args.iter().map(|a| working_dir.join(a)).filter(|p| p.is_file()).collect()
            }
            Self::Builtin { .. } | Self::InProcess { .. } => Vec::new(),
        }
    }
}

impl super::Loaded<PlannerSpec> {
    /// Checks that exactly one kind is given and that it is available.
    pub fn validate(&self) -> Result<PlannerAdapter, super::SpecError> {
        let s = &self.value;
        let given = [s.builtin.is_some(), s.external.is_some(), s.onnx.is_some()].iter().filter(|b| **b).count();
        if given != 1 {
            return Err(self.invalid_at(
                "name",
                format!(
                    "planner `{}` must have exactly one of `builtin: idm`, `external: {{command: ...}}` or `onnx: {{model: ...}}`; found {given}",
                    s.name
                ),
            ));
        }
        if s.idm.is_some() && s.builtin != Some(BuiltinPlanner::Idm) {
            return Err(self.invalid_at("idm", "`idm:` parameters apply only to `builtin: idm`"));
        }
        if let Some(idm) = &s.idm
            && let Some((field, why)) = idm.implausible_field()
        {
            return Err(self.invalid_at(&format!("idm.{field}"), format!("`idm.{field}` {why}")));
        }
        if s.evasive.is_some() && s.builtin != Some(BuiltinPlanner::Evasive) {
            return Err(self.invalid_at("evasive", "`evasive:` parameters apply only to `builtin: evasive`"));
        }
        if let Some(evasive) = &s.evasive
            && let Some((field, why)) = evasive.implausible_field()
        {
            return Err(self.invalid_at(&format!("evasive.{field}"), format!("`evasive.{field}` {why}")));
        }
        if let Some(b) = s.builtin {
            return Ok(PlannerAdapter::Builtin {
                name: s.name.clone(),
                planner: b,
                idm: s.idm.unwrap_or_default(),
                evasive: s.evasive.clone().unwrap_or_default(),
            });
        }
        if let Some(e) = &s.external {
            let timeouts = [
                ("step_timeout_ms", Some(e.step_timeout_ms)),
                ("first_step_timeout_ms", e.first_step_timeout_ms),
                ("startup_timeout_ms", Some(e.startup_timeout_ms)),
            ];
            for (key, value) in timeouts.into_iter().filter_map(|(k, v)| Some((k, v?))) {
                if value == 0 || value > MAX_TIMEOUT_MS {
                    return Err(self.invalid_at(
                        &format!("external.{key}"),
                        format!("`{key}` must be 1..={MAX_TIMEOUT_MS} ms (10 min), got {value}"),
                    ));
                }
            }
            if let Some(bad) = e.env.keys().find(|k| k.is_empty() || k.contains('=') || k.contains('\0')) {
                return Err(self.invalid_at("external.env", format!("environment variable name `{bad}` is not valid")));
            }
            for (i, arg) in e.args.iter().enumerate() {
                if let Err(why) = crate::planners::external::check_placeholders(arg) {
                    return Err(self.invalid_at(&format!("external.args.{i}"), why));
                }
            }
            for (k, v) in &e.env {
                if let Err(why) = crate::planners::external::check_placeholders(v) {
                    return Err(self.invalid_at(&format!("external.env.{k}"), why));
                }
            }
            let working_dir = match &e.working_dir {
                None => self.dir().to_path_buf(),
                Some(w) => {
                    let dir = self.dir().join(w);
                    if !dir.is_dir() {
                        let why = if dir.exists() { "is not a folder" } else { "does not exist" };
                        return Err(self.reference_at(
                            "external.working_dir",
                            format!("working directory {} {why}", dir.display()),
                        ));
                    }
                    dir
                }
            };
            return Ok(PlannerAdapter::External { name: s.name.clone(), spec: e.clone(), working_dir });
        }
        Err(self.invalid_at(
            "onnx",
            "ONNX planner policies are not supported yet (tract integration lands with the learned models); use `builtin` or `external`",
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::parse_yaml;
    use std::path::Path;

    const EXTERNAL: &str = "\
name: p
external:
  command: python3
  step_timeout_ms: 1000
";

    fn validate(text: &str, path: &Path) -> Result<PlannerAdapter, crate::spec::SpecError> {
        parse_yaml::<PlannerSpec>(text, path)?.validate()
    }

    #[test]
    fn timeouts_beyond_ten_minutes_or_zero_are_refused_at_their_value() {
        let e = validate(&EXTERNAL.replace("1000", "86400000"), Path::new("p.yaml")).unwrap_err().to_string();
        assert_eq!(e, "p.yaml:4:20: `step_timeout_ms` must be 1..=600000 ms (10 min), got 86400000");
        let text = format!("{EXTERNAL}  startup_timeout_ms: 0\n");
        let e = validate(&text, Path::new("p.yaml")).unwrap_err().to_string();
        assert!(e.starts_with("p.yaml:5:23: `startup_timeout_ms` must be 1..=600000 ms"), "{e}");
    }

    #[test]
    fn env_and_working_dir_reach_the_adapter() {
        let tmp = tempfile::Builder::new().prefix("safer-planner-spec-").tempdir().unwrap();
        let dir = tmp.path().to_path_buf();
        std::fs::create_dir_all(dir.join("bin")).unwrap();
        let spec = dir.join("p.yaml");
        let text = format!("{EXTERNAL}  working_dir: bin\n  env: {{ PYTHONHASHSEED: \"0\" }}\n");
        let adapter = validate(&text, &spec);
        let missing = validate(&text.replace("working_dir: bin", "working_dir: nope"), &spec);
        std::fs::write(dir.join("a-file"), "").unwrap();
        let a_file = validate(&text.replace("working_dir: bin", "working_dir: a-file"), &spec);
        std::fs::remove_dir_all(&dir).unwrap();
        let e = a_file.unwrap_err().to_string();
        assert!(e.ends_with("a-file is not a folder"), "{e}");
        let PlannerAdapter::External { spec: external, working_dir, .. } = adapter.unwrap() else { panic!() };
        assert_eq!(working_dir, dir.join("bin"));
        assert_eq!(external.env.get("PYTHONHASHSEED").map(String::as_str), Some("0"));
        let e = missing.unwrap_err().to_string();
        assert!(e.contains(":5:16: working directory") && e.ends_with("nope does not exist"), "{e}");
        // Without `working_dir`, the spec's folder; `.` for a bare file name.
        let PlannerAdapter::External { working_dir, .. } = validate(EXTERNAL, Path::new("p.yaml")).unwrap() else {
            panic!()
        };
        assert_eq!(working_dir, Path::new("."));
        let e = validate(&format!("{EXTERNAL}  env: {{ \"A=B\": x }}\n"), Path::new("p.yaml")).unwrap_err();
        assert!(e.to_string().contains("environment variable name `A=B` is not valid"), "{e}");
    }

    #[test]
    fn the_evasive_planners_parameters_reach_it_and_implausible_ones_are_refused_at_their_value() {
        let text = "name: e\nbuiltin: evasive\nevasive:\n  avoided_contacts: at-fault\n";
        let PlannerAdapter::Builtin { evasive, .. } = validate(text, Path::new("e.yaml")).unwrap() else { panic!() };
        assert_eq!(evasive.avoided_contacts, crate::planners::AvoidedContacts::AtFault);
        assert_eq!(evasive.horizon_s, EvasiveParams::default().horizon_s, "the rest keep their defaults");
        let e = validate(&text.replace("avoided_contacts: at-fault", "horizon_s: -1"), Path::new("e.yaml"));
        assert_eq!(
            e.unwrap_err().to_string(),
            "e.yaml:4:14: `evasive.horizon_s` must be a number in (0, 60] s, got -1"
        );
        let e = validate(&text.replace("at-fault", "some"), Path::new("e.yaml")).unwrap_err().to_string();
        assert!(e.starts_with("e.yaml:4:"), "{e}");
        let e = validate(&text.replace("builtin: evasive", "builtin: idm"), Path::new("e.yaml")).unwrap_err();
        assert!(e.to_string().starts_with("e.yaml:4:3: `evasive:` parameters apply only to `builtin: evasive`"), "{e}");
    }

    #[test]
    fn implausible_idm_parameters_are_refused_at_their_value() {
        let text = "name: i\nbuiltin: idm\nidm:\n  max_accel_mps2: 1e300\n";
        let e = validate(text, Path::new("i.yaml")).unwrap_err().to_string();
        assert_eq!(e, "i.yaml:4:19: `idm.max_accel_mps2` must be a number in (0, 10], got 1e300");
        let e = validate(&text.replace("max_accel_mps2: 1e300", "time_headway_s: .nan"), Path::new("i.yaml"));
        assert!(e.unwrap_err().to_string().contains("`idm.time_headway_s` must be a number in [0, 10], got NaN"));
        let e = validate("name: i\nbuiltin: evasive\nidm: {}\n", Path::new("i.yaml")).unwrap_err();
        assert!(e.to_string().starts_with("i.yaml:3:6: `idm:` parameters apply only to `builtin: idm`"), "{e}");
    }

    #[test]
    fn exactly_one_kind_is_required() {
        let e = validate("name: two\nbuiltin: idm\nexternal: { command: x }\n", Path::new("p.yaml")).unwrap_err();
        assert!(e.to_string().starts_with("p.yaml:1:7: planner `two` must have exactly one of"), "{e}");
    }
}
