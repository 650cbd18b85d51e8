//! Suite specs (`specs/suites/*.yaml`): which scenarios, which planner,
//! how adversarial variants are made, and what counts as passing.
//!
//! ```yaml
//! name: highway
//! scenarios:
//!   - ../scenarios/highway-cut-in.yaml     # a scenario spec
//!   - glob: ../scenarios/merge-*.yaml       # several
//!   - recorded: data:womd-tfrecord          # every log in a file or folder
//! planner: ../../planners/idm.yaml
//! adversary:
//!   method: log
//! variants: 3
//! acceptance:
//!   variant: { no_collision: true, no_off_road: true, min_gap_m: 0.2 }
//!   suite: { solution_rate_min: 0.9 }
//! ```

use schemars::JsonSchema;
use serde::Deserialize;
use serde_saphyr::Spanned;

use super::{Loaded, SpecError, SpecLocation, paths};
use crate::policies::BackgroundPolicy;

/// A suite.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SuiteSpec {
    /// Name: the first part of every test name.
    pub name: String,
    /// What the suite checks.
    #[serde(default)]
    pub description: Option<String>,
    /// Base scenarios.
    pub scenarios: Vec<ScenarioEntry>,
    /// The planner under test: a planner spec file, or `builtin: NAME` inline.
    pub planner: PlannerRef,
    /// How variants are generated.
    #[serde(default)]
    pub adversary: AdversarySpec,
    /// Variants (seeds) per scenario.
    #[serde(default = "one")]
    pub variants: u32,
    /// Base seed; variant k uses a seed derived from (seed, scenario, k).
    #[serde(default)]
    pub seed: u64,
    /// Pass/fail criteria.
    #[serde(default)]
    pub acceptance: Acceptance,
}

fn one() -> u32 {
    1
}

/// One entry of `scenarios:`.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum ScenarioEntry {
    /// A scenario spec file.
    File(#[schemars(with = "String")] Spanned<String>),
    /// Scenario spec files matching a glob.
    Glob {
        /// The pattern, relative to the suite.
        #[schemars(with = "String")]
        glob: Spanned<String>,
    },
    /// Every recorded log in a file or folder.
    Recorded {
        /// File or folder; `data:REL` for the shared data.
        #[schemars(with = "String")]
        recorded: Spanned<String>,
        /// At most this many scenes (in path order).
        #[serde(default)]
        limit: Option<usize>,
    },
}

/// The planner under test.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum PlannerRef {
    /// A planner spec file.
    File(#[schemars(with = "String")] Spanned<String>),
    /// Inline built-in.
    Builtin {
        /// Which built-in.
        builtin: crate::planners::BuiltinPlanner,
    },
}

/// Adversarial variant generation methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, JsonSchema, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
#[derive(clap::ValueEnum, Hash, PartialOrd, Ord)]
pub enum AdversaryMethod {
    /// The CBV replays its log (no adversary): the baseline.
    #[default]
    Log,
    /// The realism prior samples the CBV (needs the prior model).
    Prior,
    /// SaFeR: prior top-n trust region + feasibility value (needs both models).
    Safer,
    /// Ablation: distance only, no feasibility constraint.
    NoLfr,
    /// Ablation: the whole vocabulary instead of the trust region.
    NoTrustRegion,
    /// Ablation: SaFeR with the plain-attention prior instead of differential attention.
    NoMda,
}

/// How variants are made.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AdversarySpec {
    /// Method.
    #[serde(default)]
    pub method: AdversaryMethod,
    /// Trust-region size n (top-n tokens of the prior).
    #[serde(default = "twenty")]
    pub trust_region: usize,
    /// Policy of the other agents.
    #[serde(default)]
    pub background: BackgroundPolicy,
}

fn twenty() -> usize {
    20
}

impl Default for AdversarySpec {
    fn default() -> Self {
        Self { method: AdversaryMethod::Log, trust_region: 20, background: BackgroundPolicy::LogReplay }
    }
}

/// Pass/fail criteria.
#[derive(Debug, Clone, Default, Deserialize, JsonSchema, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Acceptance {
    /// Per variant (each a test).
    #[serde(default)]
    pub variant: VariantAcceptance,
    /// Per suite (each metric a test).
    #[serde(default)]
    pub suite: SuiteAcceptance,
}

/// What each variant's rollout of the planner under test must satisfy.
#[derive(Debug, Clone, Deserialize, JsonSchema, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct VariantAcceptance {
    /// The ego must not collide.
    #[serde(default = "yes")]
    pub no_collision: bool,
    /// The ego must not cause a collision: contacts where it was hit from
    /// behind or while stopped are allowed (nuPlan's at-fault rule). Use this
    /// against non-reactive logged traffic, which cannot avoid the ego.
    #[serde(default)]
    pub no_at_fault_collision: bool,
    /// The ego must stay on the road.
    #[serde(default)]
    pub no_off_road: bool,
    /// Minimum box distance to any agent, m.
    #[serde(default)]
    pub min_gap_m: Option<f64>,
    /// Minimum time to collision (constant-velocity extrapolation), s.
    #[serde(default)]
    pub min_ttc_s: Option<f64>,
    /// The planner must answer at every step (external planners).
    #[serde(default = "yes")]
    pub planner_must_answer: bool,
}

fn yes() -> bool {
    true
}

impl Default for VariantAcceptance {
    fn default() -> Self {
        Self {
            no_collision: true,
            no_at_fault_collision: false,
            no_off_road: false,
            min_gap_m: None,
            min_ttc_s: None,
            planner_must_answer: true,
        }
    }
}

/// Suite-level metrics and their thresholds; each given one is a test.
#[derive(Debug, Clone, Default, Deserialize, JsonSchema, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct SuiteAcceptance {
    /// Stage 1 (ego on log replay): share of variants where the CBV hits the ego must be at least this
    /// (the generator must actually produce conflicts).
    #[serde(default)]
    pub collision_rate_min: Option<f64>,
    /// Stage 2: share of variants the planner under test survives must be at least this.
    #[serde(default)]
    pub solution_rate_min: Option<f64>,
    /// Jensen–Shannon divergence of the CBV's speed vs its logged speed must be at most this.
    #[serde(default)]
    pub velocity_jsd_max: Option<f64>,
    /// Jensen–Shannon divergence of the CBV's acceleration vs logged must be at most this.
    #[serde(default)]
    pub acceleration_jsd_max: Option<f64>,
}

/// Where a scenario of the suite comes from, resolved.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ScenarioSource {
    /// A scenario spec file.
    Spec(std::path::PathBuf),
    /// A recorded log file or AV2 folder.
    Recorded(std::path::PathBuf),
}

fn loc<T>(s: &Spanned<T>) -> Option<SpecLocation> {
    SpecLocation::from_saphyr(&s.referenced)
}

impl Loaded<SuiteSpec> {
    /// Resolves `scenarios:` to files, in order, failing on entries that match nothing.
    pub fn scenario_sources(&self) -> Result<Vec<ScenarioSource>, SpecError> {
        let mut out = Vec::new();
        for entry in &self.value.scenarios {
            match entry {
                ScenarioEntry::File(f) => {
                    let p = paths::resolve(self.dir(), &f.value);
                    if !p.is_file() {
                        return Err(self.reference(loc(f), format!("scenario spec {} does not exist", p.display())));
                    }
                    out.push(ScenarioSource::Spec(p));
                }
                ScenarioEntry::Glob { glob } => {
                    let pattern = paths::resolve(self.dir(), &glob.value);
                    let matches = ::glob::glob(&pattern.to_string_lossy())
                        .map_err(|e| self.invalid(loc(glob), format!("bad glob: {e}")))?;
                    let mut files: Vec<_> = matches.filter_map(Result::ok).filter(|p| p.is_file()).collect();
                    files.sort();
                    if files.is_empty() {
                        return Err(self.reference(loc(glob), format!("glob {} matches no file", pattern.display())));
                    }
                    out.extend(files.into_iter().map(ScenarioSource::Spec));
                }
                ScenarioEntry::Recorded { recorded, limit } => {
                    let p = paths::resolve(self.dir(), &recorded.value);
                    let files = if p.is_dir() && crate::scenario::import::argoverse2::find_scenario_files(&p).is_err() {
                        crate::scenario::import::discover(&p)
                            .map_err(|e| self.reference(loc(recorded), e.to_string()))?
                    } else if p.exists() {
                        vec![p.clone()]
                    } else {
                        return Err(self.reference(
                            loc(recorded),
                            format!(
                                "{} does not exist (recorded data: set SAFER_DATA_DIR or put it at ../shared/data)",
                                p.display()
                            ),
                        ));
                    };
                    if files.is_empty() {
                        return Err(self.reference(loc(recorded), format!("no scenario files under {}", p.display())));
                    }
                    let n = limit.unwrap_or(usize::MAX);
                    out.extend(files.into_iter().take(n).map(ScenarioSource::Recorded));
                }
            }
        }
        Ok(out)
    }

    /// Checks settings that serde cannot.
    pub fn validate(&self) -> Result<(), SpecError> {
        let s = &self.value;
        if s.variants == 0 || s.variants > 1000 {
            return Err(self.invalid(None, format!("variants must be 1..=1000, got {}", s.variants)));
        }
        if s.adversary.trust_region == 0 || s.adversary.trust_region > crate::motion::tokens::VOCABULARY_SIZE {
            return Err(self.invalid(None, "adversary.trust_region must be 1..=3969"));
        }
        let rate = |v: Option<f64>, name: &str| match v {
            Some(x) if !(0.0..=1.0).contains(&x) => {
                Err(self.invalid(None, format!("acceptance.suite.{name} must be in [0, 1], got {x}")))
            }
            _ => Ok(()),
        };
        rate(s.acceptance.suite.collision_rate_min, "collision_rate_min")?;
        rate(s.acceptance.suite.solution_rate_min, "solution_rate_min")?;
        Ok(())
    }
}
