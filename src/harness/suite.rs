//! Loading a suite: the spec, its planner adapter and its scenario list,
//! cheaply (no scenario is imported until a variant runs), so listing tests
//! is fast and deterministic.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use crate::scenario::Scenario;
use crate::spec::planner::{PlannerAdapter, PlannerSpec};
use crate::spec::scenario::ScenarioSpec;
use crate::spec::suite::{PlannerRef, ScenarioSource, SuiteSpec};
use crate::spec::{Loaded, SpecError, load_yaml};

/// A scenario of a suite, by name and source.
#[derive(Debug, Clone)]
pub struct SuiteScenario {
    /// Name in test names.
    pub name: String,
    /// Where it comes from.
    pub source: ScenarioSource,
}

/// A loaded suite.
#[derive(Debug, Clone)]
pub struct Suite {
    /// The parsed spec.
    pub spec: Loaded<SuiteSpec>,
    /// The planner under test.
    pub planner: PlannerAdapter,
    /// Scenarios in spec order.
    pub scenarios: Vec<SuiteScenario>,
}

/// Names may only use characters that filters and nextest handle plainly.
pub fn sanitize(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' { c } else { '-' }).collect()
}

impl Suite {
    /// Loads and validates a suite file (and its planner and scenario specs' names).
    pub fn load(path: &Path) -> Result<Suite, SpecError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| SpecError::Io { path: path.to_path_buf(), source })?;
        crate::spec::suite::check_shapes(&text, path)?;
        let spec = crate::spec::parse_yaml::<SuiteSpec>(&text, path)?;
        spec.validate()?;
        let planner = match &spec.value.planner {
            PlannerRef::Builtin { builtin } => PlannerAdapter::Builtin {
                name: serde_json::to_value(builtin).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default(),
                planner: *builtin,
                idm: Default::default(),
            },
            PlannerRef::File(f) => {
                let p = crate::spec::paths::resolve(spec.dir(), &f.value);
                if !p.is_file() {
                    return Err(spec.reference_at("planner", format!("planner spec {} does not exist", p.display())));
                }
                load_yaml::<PlannerSpec>(&p)?.validate()?
            }
        };
        let mut scenarios = Vec::new();
        for source in spec.scenario_sources()? {
            let name = match &source {
                ScenarioSource::Spec(p) => {
                    let scenario = load_yaml::<ScenarioSpec>(p)?;
                    crate::spec::suite::check_test_name(&scenario, "name", &scenario.value.name)?;
                    scenario.value.name
                }
                ScenarioSource::Recorded(p) => {
                    p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string())
                }
            };
            let name = sanitize(&name);
            if scenarios.iter().any(|s: &SuiteScenario| s.name == name) {
                return Err(spec
                    .invalid_at("scenarios", format!("two scenarios are named `{name}`; test names must be unique")));
            }
            scenarios.push(SuiteScenario { name, source });
        }
        Ok(Suite { spec, planner, scenarios })
    }

    /// The suite's name as used in test names.
    pub fn name(&self) -> String {
        sanitize(&self.spec.value.name)
    }

    /// Variant names of one scenario.
    pub fn variant_name(&self, scenario: &SuiteScenario, index: u32) -> String {
        format!("{}::{}::seed-{index}", self.name(), scenario.name)
    }

    /// All suite files under `dir`, sorted.
    pub fn discover(dir: &Path) -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|rd| {
                rd.filter_map(Result::ok)
                    .map(|e| e.path())
                    .filter(|p| p.extension().is_some_and(|e| e == "yaml" || e == "yml"))
                    .collect()
            })
            .unwrap_or_default();
        v.sort();
        v
    }
}

impl SuiteScenario {
    /// The base scenario, built once per process and shared.
    pub fn load(&self) -> Result<Arc<Scenario>, SpecError> {
        static CACHE: OnceLock<Mutex<HashMap<PathBuf, Arc<Scenario>>>> = OnceLock::new();
        let key = match &self.source {
            ScenarioSource::Spec(p) | ScenarioSource::Recorded(p) => p.clone(),
        };
        let cache = CACHE.get_or_init(Default::default);
        if let Some(s) = cache.lock().expect("scenario cache").get(&key) {
            return Ok(s.clone());
        }
        let scenario = match &self.source {
            ScenarioSource::Spec(p) => load_yaml::<ScenarioSpec>(p)?.build()?.into_iter().next(),
            ScenarioSource::Recorded(p) => crate::scenario::import::load(p)
                .map_err(|e| SpecError::Reference {
                    path: p.clone(),
                    location: None,
                    message: e.to_string(),
                    text: String::new(),
                })?
                .into_iter()
                .next(),
        }
        .ok_or_else(|| SpecError::Reference {
            path: key.clone(),
            location: None,
            message: "no scenario in the file".into(),
            text: String::new(),
        })?;
        let scenario = Arc::new(scenario);
        cache.lock().expect("scenario cache").insert(key, scenario.clone());
        Ok(scenario)
    }
}
