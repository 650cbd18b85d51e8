//! Trust-region diagnostics over scenes: for each (scene, seed), stage 1
//! as an evaluation runs it (the ego replaying its log, the method driving
//! the CBV), then the prior's logits at every CBV token boundary, decoded
//! again from the rollout's own history (what the adversary saw), and the
//! [`TrustRegionProfile`] of the method's region there (the top n tokens, or
//! the n likeliest distinct behaviours for `safer-distinct`). The summary says
//! whether a prior offers the adversary different behaviours or only
//! speed choices: the probability the region holds, its longitudinal and
//! lateral range, its distinct behaviours and how many it may take.

use std::sync::Arc;

use rayon::prelude::*;

use super::HarnessError;
use super::evaluation::{EvaluationRequest, stage1_setup};
use super::methods::{MapEncodings, ModelSet};
use super::pipeline;
use crate::motion::tokens::TOKEN_PERIOD_STEPS;
use crate::policies::WorldView;
use crate::policies::adversary::{BackgroundForecast, TrustRegionProfile, profile_trust_region, rank_of_driven_token};
use crate::policies::prior_sampling::{PriorTraffic, TokenSampling};
use crate::scenario::Scenario;
use crate::spec::suite::AdversaryMethod;

/// The trust region at one CBV token boundary of one variant.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BoundaryProfile {
    /// Scenario id.
    pub scenario: String,
    /// Method whose stage 1 it is.
    pub method: AdversaryMethod,
    /// Seed index.
    pub seed: u32,
    /// Step of the boundary.
    pub step: usize,
    /// Whether the adversary chose here (after the approach phase, where
    /// the prior samples the CBV's tokens).
    pub engaged: bool,
    /// What the region held.
    pub profile: TrustRegionProfile,
    /// The rank in the region of the token the CBV then drove (0: the
    /// likeliest); `None` when it came from outside the region (the
    /// plausibility fallback) or the CBV left before the next boundary.
    pub driven_rank: Option<usize>,
}

/// The profiles at every CBV token boundary of stage 1 of `method` on
/// `scenario` with seed `seed_index`, the region being the one `method`
/// searches with `request.trust_region` tokens.
pub fn profile_variant(
    scenario: &Arc<Scenario>,
    method: AdversaryMethod,
    seed_index: u32,
    request: &EvaluationRequest,
    models: &ModelSet,
    maps: &MapEncodings,
) -> Result<Vec<BoundaryProfile>, HarnessError> {
    let (sim, seed) = stage1_setup(scenario, method, seed_index, request);
    let setup = pipeline::VariantSetup {
        scenario,
        settings: super::methods::MethodSettings {
            method,
            trust_region: request.trust_region,
            background: request.background,
            sampling: TokenSampling::default(),
            approach: request.approach,
            feasibility: request.feasibility,
            ego_contact: Default::default(),
            wrong_way: Default::default(),
            turning: Default::default(),
            turning_cost: Default::default(),
        },
        seed,
        sim: &sim,
        stage2_cbv: super::pipeline::Stage2Cbv::Replay,
        planner: &request.planner,
        models,
        maps,
        variant: None,
        escape: None,
        ego_limits: None,
        fault: None,
    };
    let stage1 = pipeline::run_stage1(&setup)?;
    let (Some(cbv), ego) = (stage1.cbv, stage1.ego) else { return Ok(Vec::new()) };
    let prior = models.prior_for(method)?;
    let map = maps.get(&prior, scenario)?;
    let start = stage1.start_step;
    let traffic = PriorTraffic::new(prior, scenario.clone(), map, start, vec![cbv.0], TokenSampling::default(), seed);
    let mut traffic = traffic.lock().unwrap_or_else(|p| p.into_inner());
    super::methods::set_cbv_view(method, &mut traffic, cbv, ego);
    let forecast = BackgroundForecast { recording: Some(scenario), not_replayed: &[cbv.0] };
    let approach = request.approach.tokens(seed, cbv);
    let region = super::methods::trust_region_of(method, request.trust_region);
    let mut profiles = Vec::new();
    for (k, states) in stage1.states.iter().enumerate() {
        let world = WorldView { map: &scenario.map, step: start + k, bodies: &stage1.bodies, states };
        traffic.observe(&world);
        if k % TOKEN_PERIOD_STEPS != 0 || states.get(cbv.0).copied().flatten().is_none() {
            continue;
        }
        let Some(logits) = traffic.logits_at(cbv.0, world.step).cloned() else { continue };
        if let Some(error) = traffic.error() {
            return Err(HarnessError::Model { method, source: error.clone() });
        }
        let state = |k: usize| stage1.states.get(k).and_then(|row| row.get(cbv.0).copied().flatten());
        // The CBV is present at this boundary (checked above).
        let Some(now) = state(k) else { continue };
        let tokens = region.tokens(&logits, &now);
        let Some(profile) = profile_trust_region(&world, (cbv, ego), &logits, &tokens, &forecast) else {
            continue;
        };
        // The whole next period, the CBV present throughout.
        let period: Option<Vec<_>> = (k + 1..=k + TOKEN_PERIOD_STEPS).map(state).collect();
        let driven_rank = period.and_then(|period| rank_of_driven_token(&now, &period, &tokens));
        profiles.push(BoundaryProfile {
            scenario: scenario.id.clone(),
            method,
            seed: seed_index,
            step: world.step,
            engaged: k / TOKEN_PERIOD_STEPS >= approach,
            profile,
            driven_rank,
        });
    }
    Ok(profiles)
}

/// [`profile_variant`] over every (scene, method, seed) of `request`, in
/// parallel; the profiles in (method, scene, seed, step) order, and the
/// variants that could not run with why. `tick` is called once a variant
/// is done (for progress).
pub fn profile_scenes(
    scenes: &[Arc<Scenario>],
    request: &EvaluationRequest,
    models: &ModelSet,
    tick: &(dyn Fn() + Sync),
) -> (Vec<BoundaryProfile>, Vec<(String, String)>) {
    let maps = MapEncodings::default();
    let jobs: Vec<(usize, AdversaryMethod, u32)> = scenes
        .iter()
        .enumerate()
        .flat_map(|(i, _)| request.methods.iter().flat_map(move |&m| (0..request.seeds).map(move |s| (i, m, s))))
        .collect();
    let results: Vec<Result<Vec<BoundaryProfile>, (String, String)>> = jobs
        .par_iter()
        .map(|&(i, method, seed)| {
            let profiled = profile_variant(&scenes[i], method, seed, request, models, &maps).map_err(|e| {
                (format!("{}::{}::seed-{seed}", scenes[i].id, crate::spec::spec_name(&method)), e.to_string())
            });
            tick();
            profiled
        })
        .collect();
    let mut profiles = Vec::new();
    let mut errors = Vec::new();
    for r in results {
        match r {
            Ok(p) => profiles.extend(p),
            Err(e) => errors.push(e),
        }
    }
    profiles.sort_by(|a, b| (a.method, &a.scenario, a.seed, a.step).cmp(&(b.method, &b.scenario, b.seed, b.step)));
    (profiles, errors)
}

/// The profiles of one method (one prior) summed up: means over the
/// boundaries where the adversary chose (`None` where there were none).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TrustRegionSummary {
    /// The method (its prior: `no-mda` runs the plain-attention one).
    pub method: AdversaryMethod,
    /// Boundaries where the adversary chose.
    pub boundaries: usize,
    /// Mean probability mass of the region.
    pub probability_mass: Option<f64>,
    /// Mean acceleration range, m/s².
    pub accel_range_mps2: Option<f64>,
    /// Mean distinct acceleration bins.
    pub accel_bins: Option<f64>,
    /// Mean yaw-rate range, rad/s.
    pub yaw_rate_range_radps: Option<f64>,
    /// Mean distinct yaw-rate bins.
    pub yaw_rate_bins: Option<f64>,
    /// Share of boundaries whose region has a single yaw-rate bin: no
    /// steering choice at all.
    pub no_steering_share: Option<f64>,
    /// Mean distinct behaviours.
    pub behaviours: Option<f64>,
    /// Mean share of the region's tokens that are plausible.
    pub plausible_share: Option<f64>,
    /// Share of boundaries where no token of the region is plausible.
    pub none_plausible_share: Option<f64>,
    /// Mean rank in the region of the token the adversary drove, over the
    /// boundaries where it drove one of the region's.
    pub driven_rank: Option<f64>,
    /// Share of boundaries (with a next one) where the adversary drove a
    /// token from outside the region: the plausibility fallback.
    pub outside_share: Option<f64>,
}

/// One summary per method of `methods` over the engaged boundaries of
/// `profiles`.
pub fn summarise(profiles: &[BoundaryProfile], methods: &[AdversaryMethod]) -> Vec<TrustRegionSummary> {
    methods
        .iter()
        .map(|&method| {
            let engaged: Vec<&BoundaryProfile> = profiles.iter().filter(|b| b.method == method && b.engaged).collect();
            let ps: Vec<&TrustRegionProfile> = engaged.iter().map(|b| &b.profile).collect();
            let ranks: Vec<usize> = engaged.iter().filter_map(|b| b.driven_rank).collect();
            // Boundaries followed by another one with the CBV present.
            let at: std::collections::HashSet<(&str, u32, usize)> =
                engaged.iter().map(|b| (b.scenario.as_str(), b.seed, b.step)).collect();
            let followed: Vec<&&BoundaryProfile> = engaged
                .iter()
                .filter(|b| at.contains(&(b.scenario.as_str(), b.seed, b.step + TOKEN_PERIOD_STEPS)))
                .collect();
            let n = ps.len() as f64;
            let mean = |f: &dyn Fn(&TrustRegionProfile) -> f64| {
                (!ps.is_empty()).then(|| ps.iter().map(|p| f(p)).sum::<f64>() / n)
            };
            TrustRegionSummary {
                method,
                boundaries: ps.len(),
                probability_mass: mean(&|p| p.probability_mass),
                accel_range_mps2: mean(&|p| p.accel_range_mps2),
                accel_bins: mean(&|p| p.accel_bins as f64),
                yaw_rate_range_radps: mean(&|p| p.yaw_rate_range_radps),
                yaw_rate_bins: mean(&|p| p.yaw_rate_bins as f64),
                no_steering_share: mean(&|p| f64::from(p.yaw_rate_bins == 1)),
                behaviours: mean(&|p| p.behaviours as f64),
                plausible_share: mean(&|p| p.plausible as f64 / p.tokens.max(1) as f64),
                none_plausible_share: mean(&|p| f64::from(p.plausible == 0)),
                driven_rank: (!ranks.is_empty()).then(|| ranks.iter().sum::<usize>() as f64 / ranks.len() as f64),
                outside_share: (!followed.is_empty()).then(|| {
                    followed.iter().filter(|b| b.driven_rank.is_none()).count() as f64 / followed.len() as f64
                }),
            }
        })
        .collect()
}
