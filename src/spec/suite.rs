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
//!   method: safer
//!   stage2_cbv: closed-loop   # the default: SaFeR drives the CBV against the planner's ego
//! variants: 3
//! acceptance:
//!   variant: { no_collision: true, no_off_road: true, min_gap_m: 0.2 }
//!   suite: { solution_rate_min: 0.9 }
//! ```

use schemars::JsonSchema;
use serde::Deserialize;
use serde_saphyr::Spanned;

use super::{Loaded, SpecError, SpecLocation, SpecWarning, paths};
use crate::policies::BackgroundPolicy;
use crate::policies::adversary::{
    ApproachPhase, CbvTurningCost, CbvTurningLimit, EgoContactRule, FeasibilityScope, MAX_TURNING_COST_M_PER_MPS2,
    WrongWayRule,
};

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
    /// The planner under test: a planner spec file, `builtin: NAME`, or
    /// `rust: NAME` (an in-process planner the test target registers).
    pub planner: PlannerRef,
    /// How variants are generated.
    #[serde(default)]
    pub adversary: AdversarySpec,
    /// Variants (seeds) per scenario, 1..=1000; 1 with `method: log`, which samples nothing.
    #[serde(default = "one")]
    #[schemars(range(min = 1, max = 1000))]
    pub variants: u32,
    /// Base seed; variant k uses a seed derived from (seed, scenario, k).
    #[serde(default)]
    pub seed: u64,
    /// Pass/fail criteria.
    #[serde(default)]
    pub acceptance: Acceptance,
    /// How far a failing variant's shrink may search.
    #[serde(default)]
    pub shrink: ShrinkSpec,
}

fn one() -> u32 {
    1
}

/// How far a failing variant's shrink searches (`shrink: { budget: 16,
/// time_limit_s: 600 }`): at most `budget` candidate rollouts and, when set,
/// `time_limit_s` of wall time. `safer run --shrink-budget` and
/// `--shrink-time-limit` override them. Shrinking never changes a variant's
/// verdict; a time limit makes the shrunk result depend on the machine, and
/// the report says when the search stopped at it.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ShrinkSpec {
    /// Candidate rollouts, 0..=10000 (0: failing variants are not shrunk).
    #[serde(default = "default_shrink_budget")]
    #[schemars(range(min = 0, max = 10000))]
    pub budget: usize,
    /// Wall time of one variant's search, s, above 0 and at most 86400
    /// (none: bounded by `budget` alone). Each candidate plays stage 2
    /// again with the planner under test, so a slow external planner makes
    /// each one cost its whole rollout.
    #[serde(default)]
    pub time_limit_s: Option<f64>,
}

fn default_shrink_budget() -> usize {
    crate::harness::shrink::DEFAULT_SHRINK_BUDGET
}

impl Default for ShrinkSpec {
    fn default() -> Self {
        Self { budget: default_shrink_budget(), time_limit_s: None }
    }
}

/// The most candidate rollouts `shrink.budget` may allow.
pub const MAX_SHRINK_BUDGET: usize = 10_000;

/// The longest `shrink.time_limit_s`, s (a day).
pub const MAX_SHRINK_TIME_LIMIT_S: f64 = 86_400.0;

/// One entry of `scenarios:`: a scenario spec path, `glob: PATTERN`, or
/// `recorded: PATH` with an optional `limit: N` and `roles: PAIRING`.
// Untagged: serde refuses a mistyped key (`deny_unknown_fields`) but says
// only "did not match any variant", so `check_shapes` refuses those first,
// at the key, listing the forms.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(untagged, deny_unknown_fields)]
pub enum ScenarioEntry {
    /// A scenario spec file.
    File(#[schemars(with = "String")] Spanned<String>),
    /// Scenario spec files matching a glob.
    #[schemars(extend("additionalProperties" = false))]
    Glob {
        /// The pattern, relative to the suite.
        #[schemars(with = "String")]
        glob: Spanned<String>,
    },
    /// Every recorded log in a file or folder; every scene of a file that
    /// holds several (a WOMD TFRecord shard, each named `STEM-SCENARIO_ID`).
    #[schemars(extend("additionalProperties" = false))]
    Recorded {
        /// File or folder; `data:REL` for the recorded-data folder, `safer:REL` for a file safer ships.
        #[schemars(with = "String")]
        recorded: Spanned<String>,
        /// At most this many scenes (in path order, then record order), at least 1.
        #[serde(default)]
        #[schemars(range(min = 1))]
        limit: Option<usize>,
        /// Which ego–CBV pair each scene is tested with: `as-loaded` (the
        /// default: the source's roles, else the labelled pair, else the
        /// closest approach), `merging` (a CBV in a lane merging with the
        /// ego's), `leader` (the ego's leader: the nearest moving car
        /// ahead along its recorded path) or `crossing` (a car whose
        /// recorded path crosses the ego's, the least post-encroachment
        /// time first). With another pairing than
        /// `as-loaded` the scenes are imported when the suite loads, those
        /// without such a pair are left out (`limit` counts those kept), and
        /// each is named `NAME-PAIRING`.
        #[serde(default)]
        roles: crate::scenario::roles::RolePairing,
    },
}

/// The planner under test: a planner spec file, `builtin: NAME`, or
/// `rust: NAME`.
// Untagged and checked by `check_shapes` like `ScenarioEntry`.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(untagged, deny_unknown_fields)]
pub enum PlannerRef {
    /// A planner spec file.
    File(#[schemars(with = "String")] Spanned<String>),
    /// Inline built-in.
    #[schemars(extend("additionalProperties" = false))]
    Builtin {
        /// Which built-in.
        builtin: crate::planners::BuiltinPlanner,
    },
    /// An in-process Rust planner registered under this name by the test
    /// target running the suite (`safer_scenarios::runner::Runner::planner`).
    #[schemars(extend("additionalProperties" = false))]
    Rust {
        /// The registered name.
        #[schemars(with = "String")]
        rust: Spanned<String>,
    },
}

/// Adversarial variant generation methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, JsonSchema, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
#[derive(Hash, PartialOrd, Ord)]
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
    /// Beyond the paper: SaFeR scoring each token by its best continuation
    /// over 1.5 s (receding horizon) inside the same trust region and
    /// feasibility constraint.
    SaferLookahead,
    /// Beyond the paper: SaFeR whose trust region holds the prior's n
    /// likeliest distinct behaviours (tokens whose 2 s holds end more than
    /// 1 m apart) instead of its n likeliest tokens, which on the fine
    /// token grid are often near-duplicates of one manoeuvre.
    SaferDistinct,
    /// Beyond the paper: SaFeR whose trust region comes from the prior
    /// predicting the CBV with the ego hidden from its view (an
    /// inattentive driver): a prior that sees the ego ranks the tokens that
    /// yield to it first, the conflicts the adversary looks for last.
    SaferInattentive,
    /// Beyond the paper: SaFeR over the prior's n likeliest distinct
    /// behaviours (as `safer-distinct`) whose loss is how close a token
    /// puts the CBV to the ego's path ahead of it (within 1.5 s, a car
    /// ahead of the ego scoring better than one beside or behind it)
    /// rather than to the ego: the CBV gets in front of the ego and brakes
    /// there, the conflicts a planner must answer by braking or steering.
    SaferInPath,
    /// Beyond the paper: `safer-in-path` with a loss that finishes the cut-in
    /// it starts. Ahead of the ego a token also pays half a metre per metre
    /// of the CBV's centre off the ego's heading line, so the CBV comes all
    /// the way into the ego's lane instead of stopping with a corner over
    /// the line; beside the ego it pays 2 m per metre short of the ego's
    /// front bumper (up to the 5 m penalty), so it draws ahead rather than
    /// hugging the ego's side.
    SaferCutIn,
    /// Beyond the paper: `safer-in-path` scoring each behaviour by the best
    /// its continuations reach over 1.5 s (the receding horizon of
    /// `safer-lookahead`, inside the same region, constraint and
    /// plausibility rule): the CBV picks the behaviour that leads into the
    /// ego's path, not only the one that is nearest it after 0.5 s. A
    /// contact beside or behind the ego scores as not ahead of it.
    SaferInPathLookahead,
}

impl AdversaryMethod {
    /// Whether the realism prior sees the ego when it predicts the CBV
    /// (all but `safer-inattentive`).
    pub fn prior_sees_ego(self) -> bool {
        self != Self::SaferInattentive
    }

    /// Whether the SaFeR adversary drives the CBV (every method but `log`
    /// and `prior`): the methods with an approach phase.
    pub fn is_adversary(self) -> bool {
        !matches!(self, Self::Log | Self::Prior)
    }

    /// Whether the method constrains the CBV by the feasibility value V_h
    /// (every SaFeR method but the `no-lfr` ablation).
    pub fn uses_feasibility(self) -> bool {
        self.is_adversary() && self != Self::NoLfr
    }

    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[
        Self::Log,
        Self::Prior,
        Self::Safer,
        Self::NoLfr,
        Self::NoTrustRegion,
        Self::NoMda,
        Self::SaferLookahead,
        Self::SaferDistinct,
        Self::SaferInattentive,
        Self::SaferInPath,
        Self::SaferCutIn,
        Self::SaferInPathLookahead,
    ];
}

/// How variants are made.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AdversarySpec {
    /// Method.
    #[serde(default)]
    pub method: AdversaryMethod,
    /// Trust-region size n (the prior's top n tokens; for `safer-distinct`, its
    /// n likeliest distinct behaviours), 1..=3969.
    #[serde(default = "twenty")]
    #[schemars(range(min = 1, max = 3969))]
    pub trust_region: usize,
    /// Policy of the other agents.
    #[serde(default)]
    pub background: BackgroundPolicy,
    /// The CBV while the planner under test drives (stage 2):
    /// `closed-loop` (the default) drives it by the method again, against
    /// the planner's actual ego, so the conflict meets the planner;
    /// `replay` replays its stage-1 path, made against the recorded ego,
    /// which compares generators on equal terms and is why `safer
    /// evaluate` defaults to it (the paper does not say whether its CBV
    /// reacts in stage 2); a suite tests a planner, so its default is
    /// `closed-loop`. `closed-loop-delayed` is `closed-loop` with the CBV
    /// seeing the ego a driver's reaction time (1 s) late, so it does not
    /// follow an escape as it begins.
    #[serde(default = "closed_loop")]
    pub stage2_cbv: Stage2Cbv,
    /// The approach phase of the SaFeR methods: `seeded` (the default), the
    /// prior drives the CBV for 1–4 tokens drawn from the variant's seed
    /// before the adversary engages, so that seeds differ; `none`, the
    /// adversary engages at the first token (the paper's protocol), and
    /// every seed gives the same variant.
    #[serde(default)]
    pub approach_phase: ApproachPhase,
    /// What the feasibility constraint of the methods with V_h takes into
    /// account: `pair` (the default, the paper's), V_h of the ego–CBV pair
    /// alone; `pair-in-traffic` (beyond the paper), near the ego a state V_h
    /// calls escapable counts only where the traffic around the ego leaves
    /// it room to escape; `witnessed` (beyond the paper), a candidate near
    /// the ego is taken only where the feasibility witness finds the ego an
    /// escape from it.
    #[serde(default)]
    pub feasibility: FeasibilityScope,
    /// Which contacts with the planner's ego the SaFeR methods' CBV may
    /// make: `any` (the default, the paper's), or `not-from-behind`
    /// (beyond the paper): none from behind the ego or with it standing
    /// still, the collisions nuPlan's rule never blames the ego for and
    /// no planner can escape a chasing CBV from, and no riding the ego's
    /// bumper (closing within half a second's gap).
    #[serde(default)]
    pub ego_contact: EgoContactRule,
    /// Whether the SaFeR methods' CBV may drive against a lane's traffic:
    /// `allowed` (the default, as the paper's method allows it);
    /// `forbidden` (beyond the paper): a token that turns the CBV into a
    /// lane against its traffic, outside intersections, or after which
    /// braking would not keep it out of one, is implausible, as leaving
    /// the road is, and a CBV against the traffic already must head back
    /// to a lane of its way; `along-the-lanes` (beyond the paper): as
    /// `forbidden`, and a token that takes the CBV across the lanes, or
    /// does not turn one already across them back towards them, is
    /// implausible too; or `human-lane-changes` (beyond the paper): as
    /// `along-the-lanes`, and a token that moves the CBV sideways across
    /// its lanes faster than 1.7 m/s (recorded drivers' lane changes), or
    /// does not slow one moving faster already, is implausible too.
    #[serde(default)]
    pub wrong_way: WrongWayRule,
    /// How hard the SaFeR methods' CBV may turn, m/s² (beyond the paper):
    /// a token that pulls it more sideways at some step (its speed times
    /// its yaw rate) is implausible, as leaving the road is. Above 0 and
    /// at most 9, the default: the tyres' grip, the ego's own default
    /// limit. Lower holds the CBV to how people turn (`safer evaluate`
    /// prints the CBV's peaks beside the recorded CBV's).
    #[serde(default)]
    #[schemars(range(max = 9.0), extend("exclusiveMinimum" = 0.0))]
    pub max_lateral_accel_mps2: Option<f64>,
    /// What a m/s² of the SaFeR methods' CBV's lateral acceleration adds
    /// to a candidate token's loss, m (beyond the paper): the token's peak
    /// over its steps, measured as `max_lateral_accel_mps2` measures it. A
    /// harder turn is then taken only where it gets the CBV closer by more
    /// than it costs. 0 to 5; unset (0) is the paper's loss.
    #[serde(default)]
    #[schemars(range(min = 0.0, max = 5.0))]
    pub turning_cost_m_per_mps2: Option<f64>,
}

impl AdversarySpec {
    /// How hard the CBV may turn: [`Self::max_lateral_accel_mps2`], the
    /// tyres' grip where it is not set (or, before validation, out of range).
    pub fn turning_limit(&self) -> CbvTurningLimit {
        self.max_lateral_accel_mps2.and_then(CbvTurningLimit::new).unwrap_or_default()
    }

    /// What a turn adds to the CBV's loss: [`Self::turning_cost_m_per_mps2`],
    /// none where it is not set (or, before validation, out of range).
    pub fn turning_cost(&self) -> CbvTurningCost {
        self.turning_cost_m_per_mps2.and_then(CbvTurningCost::new).unwrap_or_default()
    }
}

fn twenty() -> usize {
    20
}

fn closed_loop() -> Stage2Cbv {
    Stage2Cbv::ClosedLoop
}

impl Default for AdversarySpec {
    fn default() -> Self {
        Self {
            method: AdversaryMethod::Log,
            trust_region: 20,
            background: BackgroundPolicy::LogReplay,
            stage2_cbv: Stage2Cbv::ClosedLoop,
            approach_phase: ApproachPhase::Seeded,
            feasibility: FeasibilityScope::Pair,
            ego_contact: EgoContactRule::Any,
            wrong_way: WrongWayRule::Allowed,
            max_lateral_accel_mps2: None,
            turning_cost_m_per_mps2: None,
        }
    }
}

/// How the CBV behaves while the planner under test drives (stage 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Deserialize, JsonSchema, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stage2Cbv {
    /// Replays its stage-1 trajectory, made against the recorded ego (it
    /// measures the generator: `safer evaluate`'s default).
    Replay,
    /// Is driven by the method again, closed loop: the same trust region,
    /// plausibility rule and seed, with the feasibility value taken on the
    /// planner's actual ego at every token (it tests the planner).
    ClosedLoop,
    /// Is driven by the method closed loop, as `closed-loop`, but sees the
    /// planner's ego a human driver's reaction time (1 s) late, carried on
    /// at the velocity it had: it answers an ego that brakes or swerves
    /// a second later, rather than following its escape as it begins
    /// (beyond the paper).
    ClosedLoopDelayed,
}

impl Stage2Cbv {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Replay, Self::ClosedLoop, Self::ClosedLoopDelayed];
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
    /// The ego must not collide, whoever is at fault. Against replayed
    /// recorded traffic, which cannot react, prefer `no_collision: false`
    /// with `no_at_fault_collision: true`.
    #[serde(default = "yes")]
    pub no_collision: bool,
    /// The ego must not cause a collision: contacts where it was hit from
    /// behind or while stopped, and side contacts while it kept within one
    /// lane, are allowed (nuPlan's at-fault rule). Use this, with
    /// `no_collision: false`, wherever the background replays recorded
    /// traffic (`background: log-replay`, the default): a recorded car
    /// cannot react, so `no_collision` would fail the planner for being hit
    /// from behind. Refused beside `no_collision: true`, which already fails
    /// every collision.
    #[serde(default)]
    pub no_at_fault_collision: bool,
    /// The ego must stay on the road.
    #[serde(default)]
    pub no_off_road: bool,
    /// The ego must not drive against the traffic of a lane: its centre in
    /// a lane whose direction is more than 120° from its heading, in none
    /// running its way and more than 3 m from any such lane's centreline,
    /// outside intersections, while moving. Fails as unmeasurable on a map
    /// without lanes.
    #[serde(default)]
    pub no_wrong_way: bool,
    /// The ego must not pass a stop line while its signal shows red (a red
    /// light or a red arrow for its lane; its centre passing the line
    /// counts). Passes trivially on a map without signals.
    #[serde(default)]
    pub no_red_light: bool,
    /// The ego must not drive more than 10 % above the speed limit of the
    /// lane it is in for longer than 1 s. Fails as unmeasurable on a map
    /// whose lanes give no speed limit.
    #[serde(default)]
    pub no_speeding: bool,
    /// The ego must drive at least this share, in (0, 1], of the distance
    /// the logged ego drove over the same steps, unless it ends stopped
    /// behind an agent within 10 m in its path. Catches a planner that
    /// stops dead in a free lane. Fails as unmeasurable where the logged
    /// ego drives under 5 m (no route to measure along).
    #[serde(default)]
    #[schemars(range(min = 0, max = 1))]
    pub min_progress: Option<f64>,
    /// Minimum box distance to any agent, m, in [0, 100].
    #[serde(default)]
    #[schemars(range(min = 0, max = 100))]
    pub min_gap_m: Option<f64>,
    /// Minimum time to collision (constant-velocity extrapolation), s, in [0, 60].
    #[serde(default)]
    #[schemars(range(min = 0, max = 60))]
    pub min_ttc_s: Option<f64>,
    /// The planner must answer at every step (external planners); always
    /// true (`false` is refused: a planner that fails never passes).
    #[serde(default = "yes")]
    pub planner_must_answer: bool,
    /// The physics the ego is held to at every step: a planner that moves
    /// it beyond these limits fails the variant, which is never solved.
    /// Each key is optional, with a documented default.
    #[serde(default)]
    pub vehicle_limits: crate::sim::VehicleLimits,
}

fn yes() -> bool {
    true
}

impl VariantAcceptance {
    /// Whether the closed-loop witness is asked about a collision of the
    /// ego (at fault or not): always, except for one the ego was not at
    /// fault for under `no_at_fault_collision`. That one fails no
    /// criterion, whatever the witness finds, and a planner that lets it
    /// happen (being hit from behind) is not escaping it, so the witness
    /// would count an escape the planner never tried for as the
    /// generator's fault.
    pub fn witnesses_collision(&self, at_fault: bool) -> bool {
        !self.no_at_fault_collision || self.no_collision || at_fault
    }
}

impl Default for VariantAcceptance {
    fn default() -> Self {
        Self {
            no_collision: true,
            no_at_fault_collision: false,
            no_off_road: false,
            no_wrong_way: false,
            no_red_light: false,
            no_speeding: false,
            min_progress: None,
            min_gap_m: None,
            min_ttc_s: None,
            planner_must_answer: true,
            vehicle_limits: crate::sim::VehicleLimits::default(),
        }
    }
}

/// Suite-level metrics and their thresholds; each given one is a test.
#[derive(Debug, Clone, Default, Deserialize, JsonSchema, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct SuiteAcceptance {
    /// Stage 1 (ego on log replay): share of variants where the CBV hits the ego must be at least this
    /// (the generator must actually produce conflicts). In [0, 1].
    #[serde(default)]
    #[schemars(range(min = 0, max = 1))]
    pub collision_rate_min: Option<f64>,
    /// Stage 2: share of variants the planner under test survives must be at least this. In [0, 1].
    #[serde(default)]
    #[schemars(range(min = 0, max = 1))]
    pub solution_rate_min: Option<f64>,
    /// Jensen–Shannon divergence (base 2, in [0, 1]) of the CBV's speed vs its logged speed must be
    /// at most this. Not with `method: log`, where it compares the log with itself.
    #[serde(default)]
    #[schemars(range(min = 0, max = 1))]
    pub velocity_jsd_max: Option<f64>,
    /// Jensen–Shannon divergence (base 2, in [0, 1]) of the CBV's acceleration vs logged must be at
    /// most this. Not with `method: log`.
    #[serde(default)]
    #[schemars(range(min = 0, max = 1))]
    pub acceleration_jsd_max: Option<f64>,
    /// Stage 2: share of the stage-1-critical variants whose CBV came
    /// within 1 m (box distance) of the planner's ego must be at least
    /// this: the conflicts must reach the planner under test. In [0, 1].
    #[serde(default)]
    #[schemars(range(min = 0, max = 1))]
    pub conflict_reach_min: Option<f64>,
    /// Stage 2: share of variants whose ego collision has no escape within
    /// the closed-loop witness's budget (the generator's fault, not the
    /// planner's) must be at most this. In [0, 1].
    #[serde(default)]
    #[schemars(range(min = 0, max = 1))]
    pub no_escape_collision_rate_max: Option<f64>,
    /// Stage 2: at least this many variants must make each named kind of
    /// conflict with the planner's ego (`{ crossing: 2, cut-in: 1 }`);
    /// kinds: rear-end, cut-in, merge, crossing, left-turn-across-path,
    /// head-on, sideswipe, other. The suite fails when a kind is short.
    #[serde(default)]
    pub conflict_coverage_min: Option<std::collections::BTreeMap<crate::eval::ConflictKind, usize>>,
    /// Mutation testing: the share of fault operators (mutants of the
    /// planner under test) that the suite kills must be at least this. A
    /// mutant is killed when some variant the planner passes is failed by
    /// the mutant, on any criterion. In [0, 1]. Runs the mutants of
    /// `mutation_operators` (default: every operator) on the suite's
    /// variants; one test, `suite::mutation_score`.
    #[serde(default)]
    #[schemars(range(min = 0, max = 1))]
    pub mutation_score_min: Option<f64>,
    /// The fault operators `mutation_score_min` is measured over (default:
    /// all of them): no-brake, weak-brake, late, blind-cbv, blind-side,
    /// no-evade, speeding.
    #[serde(default)]
    pub mutation_operators: Option<Vec<crate::planners::FaultOperator>>,
}

/// Where a scenario of the suite comes from, resolved.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ScenarioSource {
    /// A scenario spec file.
    Spec(std::path::PathBuf),
    /// A recorded log file or AV2 folder.
    Recorded(std::path::PathBuf),
}

/// Reads, parses and validates a suite file: the one way a suite is read,
/// so no caller can skip [`check_shapes`] or [`Loaded::validate`].
pub fn load(path: &std::path::Path) -> Result<Loaded<SuiteSpec>, SpecError> {
    let text = super::read_text(path)?;
    check_shapes(&text, path)?;
    let spec = super::parse_yaml::<SuiteSpec>(&text, path)?;
    spec.validate()?;
    Ok(spec)
}

impl Loaded<SuiteSpec> {
    /// Resolves `scenarios:` to files, in order, each with the index of the
    /// entry it came from; fails on entries that match nothing.
    pub fn scenario_sources(&self) -> Result<Vec<(usize, ScenarioSource)>, SpecError> {
        let mut out = Vec::new();
        for (i, entry) in self.value.scenarios.iter().enumerate() {
            match entry {
                ScenarioEntry::File(f) => {
                    let at = format!("scenarios[{i}]");
                    let p = paths::resolve_checked(self.dir(), &f.value).map_err(|e| self.invalid_at(&at, e))?;
                    if !p.is_file() {
                        let hint = paths::missing_hint(&f.value);
                        return Err(
                            self.reference_at(&at, format!("scenario spec {} does not exist{hint}", p.display()))
                        );
                    }
                    out.push((i, ScenarioSource::Spec(p)));
                }
                ScenarioEntry::Glob { glob } => {
                    let at = format!("scenarios[{i}].glob");
                    let pattern =
                        paths::resolve_checked(self.dir(), &glob.value).map_err(|e| self.invalid_at(&at, e))?;
                    let files = paths::glob_files(&pattern).map_err(|e| self.invalid_at(&at, e))?;
                    if files.is_empty() {
                        return Err(self.reference_at(&at, format!("glob {} matches no file", pattern.display())));
                    }
                    out.extend(files.into_iter().map(|f| (i, ScenarioSource::Spec(f))));
                }
                ScenarioEntry::Recorded { recorded, limit, roles } => {
                    let at = format!("scenarios[{i}].recorded");
                    let p = paths::resolve_checked(self.dir(), &recorded.value).map_err(|e| self.invalid_at(&at, e))?;
                    let files = if p.is_dir() && crate::scenario::import::argoverse2::find_scenario_files(&p).is_err() {
                        crate::scenario::import::discover(&p).map_err(|e| self.reference_at(&at, e.to_string()))?
                    } else if p.exists() {
                        vec![p.clone()]
                    } else {
                        return Err(self.reference_at(
                            &at,
                            format!("{} does not exist{}", p.display(), paths::missing_hint(&recorded.value)),
                        ));
                    };
                    if files.is_empty() {
                        return Err(self.reference_at(&at, format!("no scenario files under {}", p.display())));
                    }
                    // With a pairing, `limit` counts the scenes that have the
                    // pair, which only importing them tells.
                    let n = if *roles == crate::scenario::roles::RolePairing::AsLoaded {
                        limit.unwrap_or(usize::MAX)
                    } else {
                        usize::MAX
                    };
                    out.extend(files.into_iter().take(n).map(|f| (i, ScenarioSource::Recorded(f))));
                }
            }
        }
        Ok(out)
    }

    /// What the suite says that is valid but most likely not meant, each
    /// at its place:
    /// - recorded scenes with no `adversary.method`, which the default
    ///   replays as recorded (`log`). Such a suite tests only the conflicts
    ///   its recordings hold, as a regression suite may mean to; writing
    ///   `method: log` says so and silences the warning.
    /// - recorded scenes judged by the default `no_collision: true` where
    ///   something may run into the ego from behind: recorded cars that
    ///   cannot brake for it (`background: log-replay` or
    ///   `constant-velocity`), or a CBV that may make any contact (the
    ///   prior's, or a SaFeR method's under `ego_contact: any`). No
    ///   planner answers for such a contact, so
    ///   the suite would fail planners for the traffic's doing; writing
    ///   `no_collision` out, either way, silences the warning.
    pub fn warnings(&self) -> Vec<SpecWarning> {
        let Some(first_recorded) =
            self.value.scenarios.iter().position(|e| matches!(e, ScenarioEntry::Recorded { .. }))
        else {
            return Vec::new();
        };
        let recorded_at = format!("scenarios[{first_recorded}].recorded");
        [self.replay_by_default_warning(&recorded_at), self.contact_from_behind_warning(&recorded_at)]
            .into_iter()
            .flatten()
            .collect()
    }

    /// The recorded scenes left to the default `log`, at the `adversary:`
    /// block if there is one, else at the first recorded entry.
    fn replay_by_default_warning(&self, recorded_at: &str) -> Option<SpecWarning> {
        if self.writes("adversary.method") {
            return None;
        }
        let at = if self.writes("adversary") { "adversary" } else { recorded_at };
        Some(self.warning_at(
            at,
            "no `adversary.method`: the recorded scenes are replayed as recorded (`log`, the default) and meet only \
             the conflicts their recordings hold; name a SaFeR method for adversarial variants (the shipped \
             adversarial suites use `safer-in-path-lookahead`: docs/guide/adversary.md), or write `method: log` to \
             replay on purpose",
        ))
    }

    /// The recorded scenes judged by the default `no_collision: true`
    /// where a contact from behind may fail the planner, at the
    /// acceptance (its `variant:` where written) if there is one, else
    /// at the first recorded entry.
    fn contact_from_behind_warning(&self, recorded_at: &str) -> Option<SpecWarning> {
        let adversary = &self.value.adversary;
        if !self.value.acceptance.variant.no_collision || self.writes("acceptance.variant.no_collision") {
            return None;
        }
        let blind_traffic =
            matches!(adversary.background, BackgroundPolicy::LogReplay | BackgroundPolicy::ConstantVelocity);
        // The prior's CBV keeps from no contact; a SaFeR CBV only under
        // `ego_contact: not-from-behind`.
        let by_prior = adversary.method == AdversaryMethod::Prior;
        let chasing_cbv = by_prior || (adversary.method.is_adversary() && adversary.ego_contact == EgoContactRule::Any);
        let blind = format!(
            "the recorded cars (`background: {}`) cannot brake for it",
            crate::spec::spec_name(&adversary.background)
        );
        let chasing = if by_prior {
            "the CBV, driven by the prior, may run into it"
        } else {
            "the CBV may run into it (`ego_contact: any`)"
        };
        let who = match (blind_traffic, chasing_cbv) {
            (false, false) => return None,
            (true, false) => blind,
            (false, true) => chasing.to_string(),
            (true, true) => format!("{blind} and {chasing}"),
        };
        let at = if self.writes("acceptance") { "acceptance.variant.no_collision" } else { recorded_at };
        Some(self.warning_at(
            at,
            format!(
                "`no_collision` is left at its default, true: it fails the planner for every collision, one from \
                 behind too, and on the recorded scenes {who}; judge by nuPlan's at-fault rule with \
                 `no_collision: false, no_at_fault_collision: true`, as the shipped recorded suites do, or write \
                 `no_collision: true` to fail every contact on purpose"
            ),
        ))
    }

    /// Checks settings that serde cannot, each error at the offending value.
    pub fn validate(&self) -> Result<(), SpecError> {
        use super::NumberRange;
        let s = &self.value;
        check_test_name(self, "name", &s.name)?;
        if s.scenarios.is_empty() {
            return Err(
                self.invalid_at("scenarios", "`scenarios:` lists no scenario; a suite that runs nothing cannot pass")
            );
        }
        for (i, entry) in s.scenarios.iter().enumerate() {
            if let ScenarioEntry::Recorded { limit: Some(0), .. } = entry {
                return Err(self.invalid_at(&format!("scenarios[{i}].limit"), "`limit` must be at least 1"));
            }
        }
        if s.variants == 0 || s.variants > 1000 {
            return Err(self.invalid_at("variants", format!("variants must be 1..=1000, got {}", s.variants)));
        }
        let log = s.adversary.method == AdversaryMethod::Log;
        if log && s.variants > 1 {
            return Err(self.invalid_at(
                "variants",
                format!(
                    "with `adversary.method: log` every seed gives the same variant (nothing is sampled), so \
                     variants: {} would run one variant {0} times; set `variants: 1` or choose a generative method \
                     (prior, safer, …)",
                    s.variants
                ),
            ));
        }
        if s.adversary.approach_phase == ApproachPhase::None {
            if !s.adversary.method.is_adversary() {
                return Err(self.invalid_at(
                    "adversary.approach_phase",
                    format!(
                        "`approach_phase` applies to the SaFeR methods (safer, no-lfr, …); `{}` has none: remove \
                         the key",
                        crate::spec::spec_name(&s.adversary.method)
                    ),
                ));
            }
            if s.variants > 1 {
                return Err(self.invalid_at(
                    "variants",
                    format!(
                        "with `adversary.approach_phase: none` every seed gives the same variant (the adversary's \
                         choice is a strict arg min and the background is deterministic), so variants: {} would run \
                         one variant {0} times; set `variants: 1` or remove `approach_phase`",
                        s.variants
                    ),
                ));
            }
        }
        if s.adversary.feasibility != FeasibilityScope::Pair && !s.adversary.method.uses_feasibility() {
            return Err(self.invalid_at(
                "adversary.feasibility",
                format!(
                    "`feasibility` applies to the methods with the feasibility value (safer, safer-in-path, …); \
                     `{}` has none: remove the key",
                    crate::spec::spec_name(&s.adversary.method)
                ),
            ));
        }
        // The keys only the SaFeR methods read, each set away from its default, and why.
        let safer_only = [
            ("ego_contact", s.adversary.ego_contact != EgoContactRule::Any, "which aim at the ego"),
            ("wrong_way", s.adversary.wrong_way != WrongWayRule::Allowed, "which the plausibility rule holds"),
            (
                "max_lateral_accel_mps2",
                s.adversary.max_lateral_accel_mps2.is_some(),
                "which the plausibility rule holds",
            ),
            ("turning_cost_m_per_mps2", s.adversary.turning_cost_m_per_mps2.is_some(), "whose loss it weighs"),
        ];
        if !s.adversary.method.is_adversary()
            && let Some((key, _, why)) = safer_only.iter().find(|(_, set, _)| *set)
        {
            return Err(self.invalid_at(
                &format!("adversary.{key}"),
                format!(
                    "`{key}` applies to the SaFeR methods (safer, safer-in-path, …), {why}; `{}` does not: remove \
                     the key",
                    crate::spec::spec_name(&s.adversary.method)
                ),
            ));
        }
        if s.adversary.trust_region == 0 || s.adversary.trust_region > crate::motion::tokens::VOCABULARY_SIZE {
            return Err(self.invalid_at(
                "adversary.trust_region",
                format!("adversary.trust_region must be 1..=3969, got {}", s.adversary.trust_region),
            ));
        }
        if let Some(x) = s.adversary.max_lateral_accel_mps2 {
            let grip = CbvTurningLimit::GRIP.max_lateral_accel_mps2();
            self.check_number("adversary.max_lateral_accel_mps2", x, NumberRange::above(0.0, grip), "m/s²")?;
        }
        if let Some(x) = s.adversary.turning_cost_m_per_mps2 {
            let range = NumberRange::closed(0.0, MAX_TURNING_COST_M_PER_MPS2);
            self.check_number("adversary.turning_cost_m_per_mps2", x, range, "m per m/s²")?;
        }
        if s.shrink.budget > MAX_SHRINK_BUDGET {
            return Err(self.invalid_at(
                "shrink.budget",
                format!("shrink.budget must be 0..={MAX_SHRINK_BUDGET} candidate rollouts, got {}", s.shrink.budget),
            ));
        }
        if let Some(x) = s.shrink.time_limit_s {
            self.check_number("shrink.time_limit_s", x, NumberRange::above(0.0, MAX_SHRINK_TIME_LIMIT_S), "s")?;
        }
        let v = &s.acceptance.variant;
        if v.no_at_fault_collision && v.no_collision {
            // Otherwise every collision fails, whoever's fault: the suite
            // would read as at-fault only and test something else.
            return Err(self.invalid_at(
                "acceptance.variant.no_at_fault_collision",
                "`no_at_fault_collision: true` has no effect while `no_collision` is true (its default): every \
                 collision fails, the ego's fault or not. Against replayed traffic, which cannot react to the ego, \
                 set `no_collision: false` beside it",
            ));
        }
        if let Some(x) = v.min_gap_m {
            self.check_number("acceptance.variant.min_gap_m", x, NumberRange::closed(0.0, 100.0), "m")?;
        }
        if let Some(x) = v.min_progress {
            self.check_number("acceptance.variant.min_progress", x, NumberRange::above(0.0, 1.0), "(a share)")?;
        }
        if let Some(x) = v.min_ttc_s {
            self.check_number("acceptance.variant.min_ttc_s", x, NumberRange::closed(0.0, 60.0), "s")?;
        }
        for (name, value, unit) in v.vehicle_limits.entries() {
            let path = format!("acceptance.variant.vehicle_limits.{name}");
            self.check_number(&path, value, NumberRange::closed(0.0, 1e3), unit)?;
        }
        if !v.planner_must_answer {
            return Err(self.invalid_at(
                "acceptance.variant.planner_must_answer",
                "`planner_must_answer: false` is not allowed: a planner that crashes, hangs or answers garbage \
                 never passes a variant (remove the key)",
            ));
        }
        let u = &s.acceptance.suite;
        for (name, value) in [
            ("collision_rate_min", u.collision_rate_min),
            ("solution_rate_min", u.solution_rate_min),
            ("conflict_reach_min", u.conflict_reach_min),
            ("no_escape_collision_rate_max", u.no_escape_collision_rate_max),
            ("mutation_score_min", u.mutation_score_min),
        ] {
            if let Some(x) = value {
                self.check_number(&format!("acceptance.suite.{name}"), x, NumberRange::closed(0.0, 1.0), "")?;
            }
        }
        if let Some(ops) = &u.mutation_operators {
            let path = "acceptance.suite.mutation_operators";
            if ops.is_empty() {
                return Err(self.invalid_at(path, "names no fault operator: name at least one, or remove the key"));
            }
            if u.mutation_score_min.is_none() {
                return Err(self.invalid_at(
                    path,
                    "is used only with `mutation_score_min`: set a minimum score, or remove the key",
                ));
            }
        }
        if let Some(required) = &u.conflict_coverage_min {
            let path = "acceptance.suite.conflict_coverage_min";
            if required.is_empty() {
                return Err(self.invalid_at(path, "names no kind of conflict: name at least one, or remove the key"));
            }
            if let Some((kind, _)) = required.iter().find(|&(_, &min)| min == 0) {
                return Err(self.invalid_at(
                    path,
                    format!("`{}: 0` requires nothing: give at least 1, or remove the kind", kind.name()),
                ));
            }
        }
        for (name, value) in
            [("velocity_jsd_max", u.velocity_jsd_max), ("acceleration_jsd_max", u.acceleration_jsd_max)]
        {
            let path = format!("acceptance.suite.{name}");
            if let Some(x) = value {
                // Base-2 Jensen–Shannon divergence lies in [0, 1].
                self.check_number(&path, x, NumberRange::closed(0.0, 1.0), "(bits)")?;
                if log {
                    return Err(self.invalid_at(
                        &path,
                        format!(
                            "`{name}` with `adversary.method: log` compares the log with itself (0 by \
                             construction); use it with a generative method"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Longest suite or scenario name, bytes: each is a folder of the
/// artefacts' paths, and file systems take 255 bytes a component (less the
/// room a variant's `seed-N.stderr.txt` needs beside it).
pub const MAX_NAME_BYTES: usize = 200;

/// Refuses a name that cannot be a test-name part and an artefact folder:
/// empty, `.`/`..`, anything but letters, digits, `-`, `_` and `.`, or
/// longer than [`MAX_NAME_BYTES`].
pub(crate) fn check_test_name<T>(spec: &Loaded<T>, path: &str, name: &str) -> Result<(), SpecError> {
    if name.len() > MAX_NAME_BYTES {
        return Err(spec.invalid_at(
            path,
            format!(
                "the name is {} bytes long; names are folders of the artefacts' paths and may have at most \
                 {MAX_NAME_BYTES}",
                name.len()
            ),
        ));
    }
    let allowed = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.';
    if name.is_empty() || name == "." || name == ".." || !name.chars().all(allowed) {
        return Err(spec.invalid_at(
            path,
            format!(
                "name `{name}` cannot be used in test names and artefact paths: use letters, digits, `-`, `_` \
                 and `.`, not `.` or `..` alone"
            ),
        ));
    }
    Ok(())
}

/// Checks the parts of a suite that untagged enums cannot (a `scenarios:`
/// entry or inline `planner:` with a mistyped or unknown key, an unknown
/// built-in), with the offending key or value located. Runs before the
/// typed parse so its plain message wins over serde's "did not match any
/// variant".
pub fn check_shapes(text: &str, path: &std::path::Path) -> Result<(), SpecError> {
    use super::locate::{Node, Step, tree};
    let Some(root) = tree(text) else { return Ok(()) };
    let invalid = |at: SpecLocation, message: String| SpecError::Invalid {
        path: path.to_path_buf(),
        location: Some(at),
        message,
        text: text.to_string(),
    };
    if let Some(Node::Sequence { items, .. }) = root.child(Step::Key("scenarios")) {
        const FORMS: &str = "an entry is a scenario spec path, `glob: PATTERN`, or `recorded: PATH` with an optional `limit: N` and `roles: PAIRING`";
        for (i, item) in items.iter().enumerate() {
            let keys = item.keys();
            match item {
                Node::Scalar { .. } => continue,
                Node::Sequence { .. } => {
                    return Err(invalid(item.at(), format!("scenarios[{i}] is a list: {FORMS}")));
                }
                Node::Mapping { .. } if keys.is_empty() => {
                    return Err(invalid(item.at(), format!("scenarios[{i}] is empty: {FORMS}")));
                }
                Node::Mapping { .. } => {}
            }
            if let Some((key, at)) = keys.iter().find(|(k, _)| !["glob", "recorded", "limit", "roles"].contains(k)) {
                return Err(invalid(*at, format!("unknown key `{key}` in scenarios[{i}]: {FORMS}")));
            }
            let key_at = |k: &str| keys.iter().find(|(key, _)| *key == k).map(|(_, at)| *at);
            match (key_at("glob"), key_at("recorded"), key_at("limit")) {
                (Some(_), Some(_), _) => {
                    return Err(invalid(item.at(), format!("scenarios[{i}] has both `glob` and `recorded`: {FORMS}")));
                }
                (None, None, _) => {
                    return Err(invalid(
                        item.at(),
                        format!("scenarios[{i}] has neither `glob` nor `recorded`: {FORMS}"),
                    ));
                }
                (Some(_), None, Some(at)) => {
                    return Err(invalid(at, format!("`limit` applies to `recorded:` entries only: {FORMS}")));
                }
                _ => {}
            }
            if let (Some(_), Some(at)) = (key_at("glob"), key_at("roles")) {
                return Err(invalid(at, format!("`roles` applies to `recorded:` entries only: {FORMS}")));
            }
            if let Some((_, value)) = item.entry("limit")
                && let Some(text) = value.text()
                && text.trim().parse::<u64>().is_err()
            {
                return Err(invalid(
                    value.at(),
                    format!("`limit` must be a whole number of scenes, at least 1, got {}", text.trim()),
                ));
            }
            if let Some((_, value)) = item.entry("roles") {
                let names: Vec<String> =
                    crate::scenario::roles::RolePairing::ALL.iter().map(super::spec_name).collect();
                let text = value.text().map(str::trim).unwrap_or_default();
                if !names.iter().any(|n| n == text) {
                    return Err(invalid(
                        value.at(),
                        format!("unknown `roles` `{text}`; a scene is tested with {}", names.join(", ")),
                    ));
                }
            }
        }
    }
    if let Some((_, planner)) = root.entry("planner") {
        let builtins: Vec<String> = crate::planners::BuiltinPlanner::ALL
            .iter()
            .filter_map(|b| serde_json::to_value(b).ok().and_then(|v| v.as_str().map(String::from)))
            .collect();
        const FORMS: &str = "give a planner spec file, `builtin: NAME` or `rust: NAME`";
        if let Some((key, at)) = planner.keys().into_iter().find(|(k, _)| !matches!(*k, "builtin" | "rust")) {
            return Err(invalid(at, format!("unknown key `{key}` in `planner:`: {FORMS}")));
        }
        if let [_, (_, second)] = planner.keys().as_slice() {
            return Err(invalid(*second, format!("`planner:` names both a built-in and a Rust planner: {FORMS}")));
        }
        match planner {
            Node::Sequence { .. } => return Err(invalid(planner.at(), format!("`planner:` is a list: {FORMS}"))),
            Node::Mapping { entries, .. } if entries.is_empty() => {
                return Err(invalid(planner.at(), format!("`planner:` is empty: {FORMS}")));
            }
            _ => {}
        }
        if let Some((_, name)) = planner.entry("builtin")
            && let Some(text) = name.text()
            && !builtins.iter().any(|b| b == text)
        {
            return Err(invalid(
                name.at(),
                format!("unknown built-in planner `{text}`; the built-ins are {}", builtins.join(", ")),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::parse_yaml;
    use std::path::Path;

    const SUITE: &str = "\
name: s
scenarios:
  - recorded: data:x
planner: { builtin: idm }
adversary: { method: prior }
variants: 2
acceptance:
  variant: { min_gap_m: 0.5 }
  suite: { velocity_jsd_max: 0.2 }
";

    /// The suite with `from` replaced by `to`, checked as `Suite::load` does.
    fn error(from: &str, to: &str) -> String {
        assert!(SUITE.contains(from), "{from}");
        let text = SUITE.replace(from, to);
        let path = Path::new("s.yaml");
        check_shapes(&text, path)
            .and_then(|()| parse_yaml::<SuiteSpec>(&text, path)?.validate())
            .expect_err("must be refused")
            .to_string()
    }

    /// The warnings of the suite `text` (named `s.yaml`), as text.
    fn warnings_of(text: &str) -> Vec<String> {
        let spec = parse_yaml::<SuiteSpec>(text, Path::new("s.yaml")).unwrap();
        spec.warnings().iter().map(ToString::to_string).collect()
    }

    /// The warnings of the suite with `from` replaced by `to`, as text.
    fn warnings(from: &str, to: &str) -> Vec<String> {
        assert!(SUITE.contains(from), "{from}");
        warnings_of(&SUITE.replace(from, to))
    }

    /// The base suite with its acceptance judging collisions by the
    /// at-fault rule, written out: no contact-from-behind warning.
    const AT_FAULT: &str = "variant: { no_collision: false, no_at_fault_collision: true, min_gap_m: 0.5 }";

    #[test]
    fn denied_warnings_say_how_many_and_where_each_is() {
        let spec =
            parse_yaml::<SuiteSpec>(&SUITE.replace("adversary: { method: prior }\n", ""), Path::new("s.yaml")).unwrap();
        let denied = crate::spec::WarningsDenied::of(spec.warnings()).expect("the bare recorded suite warns");
        let plain = denied.to_string();
        let lines: Vec<&str> = plain.lines().collect();
        assert_eq!(lines.len(), 3, "{plain}");
        assert!(
            lines[0].starts_with("2 spec warnings denied (SAFER_DENY_WARNINGS or --deny-warnings is set)"),
            "{plain}"
        );
        assert!(lines[1].starts_with("s.yaml:3:15: no `adversary.method`"), "{plain}");
        assert!(lines[2].starts_with("s.yaml:7:12: `no_collision` is left at its default"), "{plain}");
        // The rendered report: each warning with its snippet, then the error.
        let shown = denied.render(false);
        assert_eq!(shown.matches("warning: ").count(), 2, "{shown}");
        assert!(shown.lines().last().unwrap().starts_with("error: 2 spec warnings denied"), "{shown}");
        // Nothing to deny, no denial.
        assert_eq!(crate::spec::WarningsDenied::of(Vec::new()), None);
    }

    #[test]
    fn recorded_scenes_left_to_the_default_replay_are_warned_of_where_the_method_would_go() {
        let at_fault = SUITE.replace("variant: { min_gap_m: 0.5 }", AT_FAULT);
        let warnings = |from: &str, to: &str| {
            assert!(at_fault.contains(from), "{from}");
            warnings_of(&at_fault.replace(from, to))
        };
        // No adversary at all: at the recorded entry.
        let w = warnings("adversary: { method: prior }\nvariants: 2", "variants: 1");
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].starts_with("s.yaml:3:15: no `adversary.method`: the recorded scenes are replayed"), "{w:?}");
        assert!(w[0].contains("write `method: log` to replay on purpose"), "{w:?}");
        // An adversary without a method: at the adversary.
        let w = warnings("adversary: { method: prior }\nvariants: 2", "adversary: { trust_region: 20 }\nvariants: 1");
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].starts_with("s.yaml:5:12: no `adversary.method`"), "{w:?}");
        // A method written, `log` too: nothing to warn of.
        assert!(warnings("method: prior }", "method: prior }").is_empty());
        assert!(warnings("method: prior }\nvariants: 2", "method: log }\nvariants: 1").is_empty());
        // Authored scenes only: the default replays what the author wrote.
        let authored = warnings("  - recorded: data:x\n", "  - glob: x/*.yaml\n");
        let authored_default = SUITE
            .replace("  - recorded: data:x\n", "  - glob: x/*.yaml\n")
            .replace("adversary: { method: prior }\nvariants: 2", "variants: 1");
        let default_warnings = warnings_of(&authored_default);
        assert!(authored.is_empty() && default_warnings.is_empty(), "{authored:?} {default_warnings:?}");
    }

    #[test]
    fn recorded_scenes_judged_by_any_collision_are_warned_of_where_something_may_run_into_the_ego() {
        // Replayed recorded cars cannot brake for the ego: at the variant acceptance.
        let w = warnings("method: prior }", "method: log }");
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].starts_with("s.yaml:8:12: `no_collision` is left at its default, true"), "{w:?}");
        assert!(w[0].contains("the recorded cars (`background: log-replay`) cannot brake for it;"), "{w:?}");
        assert!(w[0].contains("`no_collision: false, no_at_fault_collision: true`"), "{w:?}");
        // A SaFeR CBV allowed any contact, among recorded cars that brake.
        let w =
            warnings("method: prior }\nvariants: 2", "method: safer, background: reactive-log-replay }\nvariants: 2");
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("on the recorded scenes the CBV may run into it (`ego_contact: any`);"), "{w:?}");
        // Both, named together.
        let w = warnings("method: prior }", "method: safer }");
        assert!(w[0].contains("cannot brake for it and the CBV may run into it"), "{w:?}");
        // No acceptance written: at the recorded entry, beside the default replay's.
        let w = warnings_of(
            &SUITE.replace("acceptance:\n  variant: { min_gap_m: 0.5 }\n  suite: { velocity_jsd_max: 0.2 }\n", ""),
        );
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].starts_with("s.yaml:3:15: `no_collision` is left at its default"), "{w:?}");
        // Silent where nothing may run into the ego unanswered, or the rule is written out.
        let braking = "method: safer, background: reactive-log-replay, ego_contact: not-from-behind }";
        assert!(warnings("method: prior }", braking).is_empty());
        assert!(
            warnings("method: prior }", "method: safer, background: idm, ego_contact: not-from-behind }").is_empty()
        );
        // The prior's CBV keeps from no contact.
        let w = warnings("method: prior }", "method: prior, background: idm }");
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("on the recorded scenes the CBV, driven by the prior, may run into it;"), "{w:?}");
        let w = warnings("method: prior }", "method: prior }");
        assert!(w[0].contains("cannot brake for it and the CBV, driven by the prior, may run into it;"), "{w:?}");
        assert!(warnings("min_gap_m: 0.5 }", "no_collision: true, min_gap_m: 0.5 }").is_empty());
        assert!(warnings("min_gap_m: 0.5 }", "no_collision: false, min_gap_m: 0.5 }").is_empty());
        // Authored scenes only: their traffic is the author's to judge.
        assert!(warnings("  - recorded: data:x\n", "  - glob: x/*.yaml\n").is_empty());
    }

    #[test]
    fn the_base_suite_is_valid() {
        let spec = parse_yaml::<SuiteSpec>(SUITE, Path::new("s.yaml")).unwrap();
        check_shapes(SUITE, Path::new("s.yaml")).unwrap();
        spec.validate().unwrap();
    }

    #[test]
    fn a_mistyped_key_in_an_entry_is_refused_at_the_key_even_without_the_shape_check() {
        let text = SUITE.replace("data:x\n", "data:x\n    limt: 1\n");
        let e = check_shapes(&text, Path::new("s.yaml")).unwrap_err().to_string();
        assert!(e.starts_with("s.yaml:4:5: unknown key `limt` in scenarios[0]"), "{e}");
        assert!(e.contains("`recorded: PATH` with an optional `limit: N`"), "{e}");
        // The typed parse alone refuses it too (never silently ignored).
        assert!(parse_yaml::<SuiteSpec>(&text, Path::new("s.yaml")).is_err());
        let e = error("- recorded: data:x", "- { recorded: data:x, glob: '*.yaml' }");
        assert!(e.contains("both `glob` and `recorded`"), "{e}");
        let e = error("- recorded: data:x", "- [a, b]");
        assert!(e.starts_with("s.yaml:3:5: scenarios[0] is a list: an entry is a scenario spec path"), "{e}");
        let e = error("- recorded: data:x", "- {}");
        assert!(e.starts_with("s.yaml:3:5: scenarios[0] is empty"), "{e}");
        let e = error("{ builtin: idm }", "{}");
        assert!(
            e.starts_with(
                "s.yaml:4:10: `planner:` is empty: give a planner spec file, `builtin: NAME` or `rust: NAME`"
            ),
            "{e}"
        );
        let e = error("{ builtin: idm }", "{ builtin: idm, rust: mine }");
        assert!(e.contains("`planner:` names both a built-in and a Rust planner"), "{e}");
        assert!(
            parse_yaml::<SuiteSpec>(&SUITE.replace("{ builtin: idm }", "{ rust: mine }"), Path::new("s.yaml")).is_ok()
        );
        let e = error("- recorded: data:x", "- { glob: '*.yaml', limit: 2 }");
        assert!(e.starts_with("s.yaml:3:23: `limit` applies to `recorded:` entries only"), "{e}");
        let e = error("- recorded: data:x", "- { glob: '*.yaml', roles: leader }");
        assert!(e.starts_with("s.yaml:3:23: `roles` applies to `recorded:` entries only"), "{e}");
        let e = error("- recorded: data:x", "- { recorded: data:x, roles: leaders }");
        assert_eq!(
            e,
            "s.yaml:3:32: unknown `roles` `leaders`; a scene is tested with as-loaded, merging, leader, crossing"
        );
        let text = SUITE.replace("- recorded: data:x", "- { recorded: data:x, roles: leader }");
        check_shapes(&text, Path::new("s.yaml")).unwrap();
        let spec = parse_yaml::<SuiteSpec>(&text, Path::new("s.yaml")).unwrap();
        let ScenarioEntry::Recorded { roles, .. } = &spec.value.scenarios[0] else { panic!("a recorded entry") };
        assert_eq!(*roles, crate::scenario::roles::RolePairing::Leader);
    }

    #[test]
    fn an_unknown_builtin_lists_the_builtins_at_its_value() {
        let e = error("builtin: idm", "builtin: idmm");
        assert!(e.starts_with("s.yaml:4:21: unknown built-in planner `idmm`; the built-ins are"), "{e}");
        assert!(e.contains("idm") && e.contains("constant-velocity"), "{e}");
        let e = error("{ builtin: idm }", "{ builtin: idm, timeout: 3 }");
        assert!(e.starts_with("s.yaml:4:26: unknown key `timeout` in `planner:`"), "{e}");
    }

    #[test]
    fn nan_negative_and_out_of_range_criteria_are_refused_at_their_value() {
        let e = error("min_gap_m: 0.5", "min_gap_m: .nan");
        assert_eq!(e, "s.yaml:8:25: `min_gap_m` must be a number in [0, 100] m, got NaN");
        assert!(error("min_gap_m: 0.5", "min_gap_m: -5").contains("got -5"));
        let e = error("min_gap_m: 0.5", "min_ttc_s: .inf");
        assert!(e.starts_with("s.yaml:8:25: `min_ttc_s` must be a number in [0, 60] s, got inf"), "{e}");
        let e = error("velocity_jsd_max: 0.2", "velocity_jsd_max: -1");
        assert!(e.starts_with("s.yaml:9:30: `velocity_jsd_max` must be a number in [0, 1]"), "{e}");
        let e = error("velocity_jsd_max: 0.2", "solution_rate_min: 1.5");
        assert!(e.contains("`solution_rate_min` must be a number in [0, 1]"), "{e}");
        assert!(error("variants: 2", "variants: 0").starts_with("s.yaml:6:11: variants must be 1..=1000, got 0"));
        let e = error("method: prior }", "method: prior, trust_region: 0 }");
        assert!(e.contains("trust_region must be 1..=3969, got 0"), "{e}");
        let e = error("scenarios:\n  - recorded: data:x\n", "scenarios: []\n");
        assert!(e.starts_with("s.yaml:2:12: `scenarios:` lists no scenario"), "{e}");
        let e = error("data:x\n", "data:x\n    limit: 0\n");
        assert!(e.starts_with("s.yaml:4:12: `limit` must be at least 1"), "{e}");
        let e = error("min_gap_m: 0.5", "min_gap_m: 0.5, vehicle_limits: { max_decel_mps2: -1 }");
        assert!(e.contains("`max_decel_mps2` must be a number in [0, 1000] m/s², got -1"), "{e}");
        let e = error("min_gap_m: 0.5", "min_gap_m: 0.5, vehicle_limits: { max_decel: 9 }");
        assert!(e.contains("max_decel"), "a misspelt limit is refused: {e}");
    }

    #[test]
    fn approach_phase_none_is_for_one_variant_of_a_safer_method() {
        let e = error("method: prior }", "method: prior, approach_phase: none }");
        assert!(e.starts_with("s.yaml:5:45: `approach_phase` applies to the SaFeR methods"), "{e}");
        let e = error("method: prior }", "method: safer, approach_phase: none }");
        assert!(e.starts_with("s.yaml:6:11: with `adversary.approach_phase: none` every seed gives the same"), "{e}");
        let e = error("method: prior }", "method: safer, approach_phase: nope }");
        assert!(e.contains("nope") && e.contains("seeded"), "a misspelt phase is refused, naming the choices: {e}");
        let text = SUITE.replace("method: prior }\nvariants: 2", "method: safer, approach_phase: none }\nvariants: 1");
        let spec = parse_yaml::<SuiteSpec>(&text, Path::new("s.yaml")).unwrap();
        spec.validate().unwrap();
        assert_eq!(spec.value.adversary.approach_phase, ApproachPhase::None);
    }

    #[test]
    fn feasibility_in_traffic_is_for_the_methods_with_v_h() {
        for method in ["prior", "no-lfr"] {
            for scope in ["pair-in-traffic", "witnessed"] {
                let e = error("method: prior }", &format!("method: {method}, feasibility: {scope} }}"));
                assert!(e.contains("`feasibility` applies to the methods with the feasibility value"), "{method}: {e}");
            }
        }
        let e = error("method: prior }", "method: safer, feasibility: traffic }");
        assert!(e.contains("traffic") && e.contains("pair-in-traffic"), "a misspelt scope is refused: {e}");
        let text = SUITE.replace("method: prior }", "method: safer-in-path, feasibility: pair-in-traffic }");
        let spec = parse_yaml::<SuiteSpec>(&text, Path::new("s.yaml")).unwrap();
        spec.validate().unwrap();
        assert_eq!(spec.value.adversary.feasibility, FeasibilityScope::PairInTraffic);
        let text = SUITE.replace("method: prior }", "method: safer-in-path-lookahead, feasibility: witnessed }");
        let spec = parse_yaml::<SuiteSpec>(&text, Path::new("s.yaml")).unwrap();
        spec.validate().unwrap();
        assert_eq!(spec.value.adversary.feasibility, FeasibilityScope::Witnessed);
        let spec = parse_yaml::<SuiteSpec>(SUITE, Path::new("s.yaml")).unwrap();
        assert_eq!(spec.value.adversary.feasibility, FeasibilityScope::Pair);
    }

    /// The adversary of the test suite with `method: prior }` replaced by
    /// `adversary` (validated), and of the suite as it is.
    fn adversary_with(adversary: &str) -> (AdversarySpec, AdversarySpec) {
        let text = SUITE.replace("method: prior }", adversary);
        let spec = parse_yaml::<SuiteSpec>(&text, Path::new("s.yaml")).unwrap();
        spec.validate().unwrap();
        (spec.value.adversary, parse_yaml::<SuiteSpec>(SUITE, Path::new("s.yaml")).unwrap().value.adversary)
    }

    #[test]
    fn the_wrong_way_rule_is_for_the_safer_methods_and_allows_it_by_default() {
        let e = error("method: prior }", "method: prior, wrong_way: forbidden }");
        assert!(e.contains("`wrong_way` applies to the SaFeR methods"), "{e}");
        let e = error("method: prior }", "method: safer, wrong_way: never }");
        assert!(e.contains("never") && e.contains("forbidden"), "a misspelt rule is refused: {e}");
        let (set, default) = adversary_with("method: safer-in-path, wrong_way: forbidden }");
        assert_eq!((set.wrong_way, default.wrong_way), (WrongWayRule::Forbidden, WrongWayRule::Allowed));
    }

    #[test]
    fn the_turning_limit_is_for_the_safer_methods_within_grip_and_grip_by_default() {
        let e = error("method: prior }", "method: prior, max_lateral_accel_mps2: 4.0 }");
        assert!(e.contains("`max_lateral_accel_mps2` applies to the SaFeR methods"), "{e}");
        for refused in ["0.0", "9.5", "-1"] {
            let e = error("method: prior }", &format!("method: safer, max_lateral_accel_mps2: {refused} }}"));
            assert!(e.contains("`max_lateral_accel_mps2` must be a number in (0, 9] m/s²"), "{refused}: {e}");
        }
        let (set, default) = adversary_with("method: safer-in-path, max_lateral_accel_mps2: 4.0 }");
        assert_eq!(set.turning_limit(), CbvTurningLimit::new(4.0).unwrap());
        assert_eq!(default.turning_limit(), CbvTurningLimit::GRIP);
    }

    #[test]
    fn the_turning_cost_is_for_the_safer_methods_within_its_range_and_none_by_default() {
        let e = error("method: prior }", "method: prior, turning_cost_m_per_mps2: 0.1 }");
        assert!(e.contains("`turning_cost_m_per_mps2` applies to the SaFeR methods"), "{e}");
        for refused in ["-0.1", "5.5", ".nan"] {
            let e = error("method: prior }", &format!("method: safer, turning_cost_m_per_mps2: {refused} }}"));
            assert!(e.contains("`turning_cost_m_per_mps2` must be a number in [0, 5] m per m/s²"), "{refused}: {e}");
        }
        let (set, default) = adversary_with("method: safer-in-path-lookahead, turning_cost_m_per_mps2: 0.1 }");
        assert_eq!(set.turning_cost(), CbvTurningCost::new(0.1).unwrap());
        assert_eq!(default.turning_cost(), CbvTurningCost::NONE);
    }

    #[test]
    fn a_collision_is_witnessed_unless_at_fault_collisions_alone_count_and_the_ego_was_not() {
        let criteria = |no_collision, no_at_fault_collision| VariantAcceptance {
            no_collision,
            no_at_fault_collision,
            ..VariantAcceptance::default()
        };
        // (criteria, at fault) -> witnessed
        for ((any, at_fault_only), at_fault, witnessed) in [
            ((true, false), false, true),
            ((true, false), true, true),
            ((false, true), false, false),
            ((false, true), true, true),
            // No collision criterion: the witness still tells the generator's faults.
            ((false, false), false, true),
            ((false, false), true, true),
        ] {
            assert_eq!(
                criteria(any, at_fault_only).witnesses_collision(at_fault),
                witnessed,
                "{any} {at_fault_only} {at_fault}"
            );
        }
    }

    #[test]
    fn ego_contact_not_from_behind_is_for_the_methods_that_aim_at_the_ego() {
        let e = error("method: prior }", "method: prior, ego_contact: not-from-behind }");
        assert!(e.contains("`ego_contact` applies to the SaFeR methods"), "{e}");
        let e = error("method: prior }", "method: safer, ego_contact: behind }");
        assert!(e.contains("behind") && e.contains("not-from-behind"), "a misspelt rule is refused: {e}");
        let (set, default) = adversary_with("method: safer-in-path-lookahead, ego_contact: not-from-behind }");
        assert_eq!((set.ego_contact, default.ego_contact), (EgoContactRule::NotFromBehind, EgoContactRule::Any));
    }

    #[test]
    fn method_log_refuses_more_than_one_variant_and_jsd_bounds() {
        let e = error("method: prior", "method: log");
        assert!(e.starts_with("s.yaml:6:11: with `adversary.method: log` every seed gives the same variant"), "{e}");
        let e = error("method: prior }\nvariants: 2", "method: log }\nvariants: 1");
        assert!(e.starts_with("s.yaml:9:30: `velocity_jsd_max` with `adversary.method: log` compares the log"), "{e}");
    }

    #[test]
    fn names_that_cannot_be_test_or_path_parts_are_refused() {
        for bad in ["..", ".", "''", "a/b", "a b", "x::y"] {
            let e = error("name: s", &format!("name: {bad}"));
            assert!(e.starts_with("s.yaml:1:7: name `"), "{bad}: {e}");
            assert!(e.contains("use letters, digits, `-`, `_` and `.`"), "{e}");
        }
        let spec = parse_yaml::<SuiteSpec>(&SUITE.replace("name: s", "name: highway-2.b_c"), Path::new("s.yaml"));
        spec.unwrap().validate().unwrap();
    }

    #[test]
    fn planner_must_answer_false_is_refused() {
        let e = error("min_gap_m: 0.5", "planner_must_answer: false");
        assert!(e.starts_with("s.yaml:8:35: `planner_must_answer: false` is not allowed"), "{e}");
    }
}
