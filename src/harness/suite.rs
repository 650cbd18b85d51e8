//! Loading a suite: the spec, its planner adapter and its scenario list,
//! cheaply (no scenario is imported until a variant runs, but those of a
//! recorded entry with `roles:`, which only importing tells to have the
//! pair), so listing tests is fast and deterministic.

use crate::planners::registry::PlannerRegistry;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use crate::scenario::Scenario;
use crate::scenario::roles::RolePairing;
use crate::spec::planner::{PlannerAdapter, PlannerSpec};
use crate::spec::scenario::ScenarioSpec;
use crate::spec::suite::{PlannerRef, ScenarioSource, SuiteSpec};
use crate::spec::{Loaded, SpecError, SpecLocation, load_yaml};

/// A scenario of a suite, by name and source.
#[derive(Debug, Clone)]
pub struct SuiteScenario {
    /// Name in test names.
    pub name: String,
    /// Where it comes from.
    pub source: ScenarioSource,
    /// Which scene of a recorded file holding several (a WOMD TFRecord
    /// shard), by record index; `None`: the file's only scene.
    pub record: Option<usize>,
    /// The ego–CBV pair it is tested with (a recorded entry's `roles:`).
    pub roles: RolePairing,
    /// The `scenarios:` entry it was listed by, where errors found when it
    /// is imported (a recorded log that does not import) are reported.
    pub entry: SuiteEntry,
}

/// A `scenarios:` entry of a suite file: the file, the entry's place and
/// the file's text (shared by every scenario the entry lists).
#[derive(Debug, Clone)]
pub struct SuiteEntry {
    /// The suite file.
    pub suite: PathBuf,
    /// Where the entry is written.
    pub location: Option<SpecLocation>,
    /// The suite file's text, for rendering the snippet.
    pub text: Arc<str>,
}

impl SuiteEntry {
    /// A [`SpecError::Reference`] at this entry.
    fn reference(&self, message: String) -> SpecError {
        SpecError::Reference { path: self.suite.clone(), location: self.location, message, text: self.text.to_string() }
    }
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
    /// How far a failing variant's shrink may search (the spec's
    /// `shrink:`, which `safer run`'s flags override).
    pub shrink: super::shrink::ShrinkBudget,
}

/// Names may only use characters that filters and nextest handle plainly.
pub fn sanitize(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' { c } else { '-' }).collect()
}

impl Suite {
    /// Loads and validates a suite file, its planner spec and each scenario
    /// spec (name, numbers, template parameters, a named CBV), every error
    /// located at its value. Recorded logs are only found, not imported: one
    /// that does not import is reported at its `scenarios:` entry when its
    /// variant runs ([`SuiteScenario::load`]). Those of an entry with
    /// `roles:` are imported, to leave out the scenes without the pair.
    pub fn load(path: &Path) -> Result<Suite, SpecError> {
        Self::load_with(path, &PlannerRegistry::default())
    }

    /// [`Suite::load`], resolving `planner: { rust: NAME }` among the
    /// in-process planners of `registry` (a runner's).
    pub fn load_with(path: &Path, registry: &PlannerRegistry) -> Result<Suite, SpecError> {
        let spec = crate::spec::suite::load(path)?;
        let planner = match &spec.value.planner {
            PlannerRef::Builtin { builtin } => PlannerAdapter::Builtin {
                name: crate::spec::spec_name(&builtin),
                planner: *builtin,
                idm: Default::default(),
                evasive: Default::default(),
            },
            PlannerRef::Rust { rust } => {
                let Some(factory) = registry.lookup(&rust.value) else {
                    let registered = registry.names();
                    let registered = if registered.is_empty() {
                        "the runner registers none".to_string()
                    } else {
                        format!("registered: {}", registered.join(", "))
                    };
                    return Err(spec.reference_at(
                        "planner.rust",
                        format!(
                            "no in-process planner named `{}` ({registered}); a `rust:` planner runs under the test \
                             target that registers it (`safer_scenarios::runner::Runner::planner`), not under `safer run`",
                            rust.value
                        ),
                    ));
                };
                PlannerAdapter::InProcess {
                    name: rust.value.clone(),
                    factory: crate::spec::planner::InProcessFactory(factory),
                }
            }
            PlannerRef::File(f) => {
                let p = crate::spec::paths::resolve_checked(spec.dir(), &f.value)
                    .map_err(|e| spec.invalid_at("planner", e))?;
                if !p.is_file() {
                    let hint = crate::spec::paths::missing_hint(&f.value);
                    return Err(
                        spec.reference_at("planner", format!("planner spec {} does not exist{hint}", p.display()))
                    );
                }
                load_yaml::<PlannerSpec>(&p)?.validate()?
            }
        };
        let mut scenarios = Vec::new();
        let text: Arc<str> = Arc::from(spec.text.as_str());
        let mut per_entry: HashMap<usize, usize> = HashMap::new();
        for (i, source) in spec.scenario_sources()? {
            let at = format!("scenarios[{i}]");
            let (limit, roles) = match &spec.value.scenarios[i] {
                crate::spec::suite::ScenarioEntry::Recorded { limit, roles, .. } => {
                    (limit.unwrap_or(usize::MAX), *roles)
                }
                _ => (usize::MAX, RolePairing::AsLoaded),
            };
            // A TFRecord shard holds many scenes: one suite scenario each,
            // named `STEM-SCENARIO_ID`, `limit` counting scenes.
            if let ScenarioSource::Recorded(p) = &source
                && let Some(ids) = crate::scenario::import::scenario_ids(p)
                    .map_err(|e| spec.reference_at(&at, format!("recorded log {} does not import: {e}", p.display())))?
                && ids.len() > 1
            {
                let stem = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                for (record, id) in ids.iter().enumerate() {
                    if per_entry.get(&i).is_some_and(|&taken| taken >= limit) {
                        break;
                    }
                    if !has_pair(&spec, &at, p, Some(record), roles)? {
                        continue;
                    }
                    *per_entry.entry(i).or_default() += 1;
                    let name = sanitize(&paired_name(&format!("{stem}-{id}"), roles));
                    let entry = SuiteEntry { suite: spec.path.clone(), location: spec.at(&at), text: text.clone() };
                    push_unique(
                        &spec,
                        &at,
                        &mut scenarios,
                        SuiteScenario { name, source: source.clone(), record: Some(record), roles, entry },
                    )?;
                }
                continue;
            }
            if let ScenarioSource::Recorded(p) = &source
                && roles != RolePairing::AsLoaded
                && (per_entry.get(&i).is_some_and(|&taken| taken >= limit) || !has_pair(&spec, &at, p, None, roles)?)
            {
                continue;
            }
            *per_entry.entry(i).or_default() += 1;
            let name = match &source {
                ScenarioSource::Spec(p) => {
                    let scenario = load_yaml::<ScenarioSpec>(p)?;
                    scenario.validate()?;
                    if scenario.value.recorded.is_none() {
                        // Errors that need the map (a lane that does not
                        // exist, agents overlapping at the start) show at
                        // load, not when the first variant runs; the scene
                        // built is the one the variants run.
                        if let Some(built) = scenario.build()?.into_iter().next() {
                            let key = (p.clone(), None, RolePairing::AsLoaded);
                            scene_cache().lock().expect("scenario cache").insert(key, Arc::new(built));
                        }
                    }
                    // Both stages drive the CBV; an authored scene gets none unless it names one.
                    if scenario.value.recorded.is_none() && scenario.value.cbv.is_none() {
                        return Err(scenario.invalid_at(
                            "ego",
                            "no `cbv:`: a suite drives the scenario's critical background vehicle, so name one of \
                             the agents with `cbv:`",
                        ));
                    }
                    scenario.value.name
                }
                ScenarioSource::Recorded(p) => paired_name(
                    &p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string()),
                    roles,
                ),
            };
            let name = sanitize(&name);
            if name.is_empty() || name == "." || name == ".." {
                // A recorded file named `...json`: the stem would climb out of the artefacts folder.
                return Err(spec.invalid_at(
                    &at,
                    format!(
                        "{} gives the scenario name `{name}`, which cannot be a test name or folder",
                        source_path(&source).display()
                    ),
                ));
            }
            let entry = SuiteEntry { suite: spec.path.clone(), location: spec.at(&at), text: text.clone() };
            push_unique(&spec, &at, &mut scenarios, SuiteScenario { name, source, record: None, roles, entry })?;
        }
        // An entry with a pairing that no scene of it has tests nothing.
        for (i, entry) in spec.value.scenarios.iter().enumerate() {
            if let crate::spec::suite::ScenarioEntry::Recorded { recorded, roles, .. } = entry
                && *roles != RolePairing::AsLoaded
                && !per_entry.contains_key(&i)
            {
                return Err(spec.reference_at(
                    &format!("scenarios[{i}].roles"),
                    format!(
                        "no scene of {} has {} (roles: {}), so this entry would test nothing",
                        recorded.value,
                        roles.pair_in_words(),
                        crate::spec::spec_name(roles)
                    ),
                ));
            }
        }
        let shrink = super::shrink::ShrinkBudget::of(&spec.value.shrink);
        Ok(Suite { spec, planner, scenarios, shrink })
    }

    /// The files a run of the suite reads: the suite, its planner spec and
    /// an external planner's file arguments, and each scenario's spec or
    /// recorded file. A run's outputs must not overwrite any of them.
    pub fn input_files(&self) -> Vec<std::path::PathBuf> {
        let mut files = vec![self.spec.path.clone()];
        if let PlannerRef::File(f) = &self.spec.value.planner {
            files.push(crate::spec::paths::resolve(self.spec.dir(), &f.value));
        }
        files.extend(self.planner.argument_files());
        files.extend(self.scenarios.iter().map(|s| source_path(&s.source).to_path_buf()));
        files
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

/// Adds `scenario`, refusing a name already taken (test names and artefact
/// folders must be unique).
fn push_unique(
    spec: &Loaded<SuiteSpec>,
    at: &str,
    scenarios: &mut Vec<SuiteScenario>,
    scenario: SuiteScenario,
) -> Result<(), SpecError> {
    if let Some(first) = scenarios.iter().find(|s| s.name == scenario.name) {
        return Err(spec.invalid_at(
            at,
            format!(
                "two scenarios are named `{}` ({} and {}); test names must be unique",
                scenario.name,
                source_path(&first.source).display(),
                source_path(&scenario.source).display()
            ),
        ));
    }
    scenarios.push(scenario);
    Ok(())
}

/// A scene's test name tested with `roles`: its own, or `NAME-PAIRING`.
fn paired_name(name: &str, roles: RolePairing) -> String {
    match roles {
        RolePairing::AsLoaded => name.to_string(),
        other => format!("{name}-{}", crate::spec::spec_name(&other)),
    }
}

/// Whether the recorded scene (`record` of a file of several) has the pair
/// `roles` asks for; it is imported, and kept for its variants.
fn has_pair(
    spec: &Loaded<SuiteSpec>,
    at: &str,
    path: &Path,
    record: Option<usize>,
    roles: RolePairing,
) -> Result<bool, SpecError> {
    let imported = import_paired(path, record, roles)
        .map_err(|e| spec.reference_at(at, format!("recorded log {} does not import: {e}", path.display())))?;
    Ok(imported.is_some())
}

/// The recorded scene (`record` of a file of several, else the file's
/// first) with the pair `roles` asks for, imported once per process;
/// `None` when it has no such pair (or the file holds no scene).
fn import_paired(
    path: &Path,
    record: Option<usize>,
    roles: RolePairing,
) -> Result<Option<Arc<Scenario>>, crate::scenario::import::ImportError> {
    let key = (path.to_path_buf(), record, roles);
    if let Some(s) = scene_cache().lock().expect("scenario cache").get(&key) {
        return Ok(Some(s.clone()));
    }
    let scenario = match record {
        Some(record) => Some(crate::scenario::import::load_one(path, record)?),
        None => crate::scenario::import::load(path)?.into_iter().next(),
    };
    let Some(mut scenario) = scenario else { return Ok(None) };
    if roles != RolePairing::AsLoaded && !roles.assign(&mut scenario) {
        return Ok(None);
    }
    let scenario = Arc::new(scenario);
    scene_cache().lock().expect("scenario cache").insert(key, scenario.clone());
    Ok(Some(scenario))
}

fn source_path(source: &ScenarioSource) -> &Path {
    match source {
        ScenarioSource::Spec(p) | ScenarioSource::Recorded(p) => p,
    }
}

/// A loaded scene's cache key: its file, for a file of several its record,
/// and the pair it is tested with.
type SceneKey = (PathBuf, Option<usize>, RolePairing);

/// The scenes built or imported in this process, shared by every variant.
fn scene_cache() -> &'static Mutex<HashMap<SceneKey, Arc<Scenario>>> {
    static CACHE: OnceLock<Mutex<HashMap<SceneKey, Arc<Scenario>>>> = OnceLock::new();
    CACHE.get_or_init(Default::default)
}

impl SuiteScenario {
    /// The base scenario, built once per process and shared.
    pub fn load(&self) -> Result<Arc<Scenario>, SpecError> {
        let scenario = match &self.source {
            ScenarioSource::Spec(p) => {
                let key = (p.clone(), None, RolePairing::AsLoaded);
                if let Some(s) = scene_cache().lock().expect("scenario cache").get(&key) {
                    return Ok(s.clone());
                }
                let built = load_yaml::<ScenarioSpec>(p)?.build()?.into_iter().next();
                let built =
                    Arc::new(built.ok_or_else(|| self.entry.reference(format!("no scenario in {}", p.display())))?);
                scene_cache().lock().expect("scenario cache").insert(key, built.clone());
                return Ok(built);
            }
            ScenarioSource::Recorded(p) => import_paired(p, self.record, self.roles)
                .map_err(|e| self.entry.reference(format!("recorded log {} does not import: {e}", p.display())))?
                .ok_or_else(|| match self.roles {
                    RolePairing::AsLoaded => self.entry.reference(format!("no scenario in {}", p.display())),
                    roles => self.entry.reference(format!(
                        "{} no longer has {} (roles: {})",
                        p.display(),
                        roles.pair_in_words(),
                        crate::spec::spec_name(&roles)
                    )),
                })?,
        };
        // A recorded agent overlapping the recorded ego where the rollout
        // starts (a copy of the ego under another id, an annotation error)
        // is a collision no planner can avoid, so the witness would excuse
        // it and every real collision with it: refused (on every call: the
        // scene is cached as imported). A later overlap is an annotation
        // error the witness judges like any collision.
        if let (ScenarioSource::Recorded(p), Some(other)) =
            (&self.source, crate::scenario::roles::recorded_ego_contact_at(&scenario, scenario.current_step))
        {
            return Err(self.entry.reference(format!(
                "recorded log {}: the recorded ego overlaps agent {} where the rollout starts, so no planner could \
                 avoid touching it (a copy of the ego, or an annotation error); remove that agent or choose another \
                 scene",
                p.display(),
                scenario.track(other).id.0,
            )));
        }
        Ok(scenario)
    }
}
