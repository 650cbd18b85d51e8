//! The Waymo Open Sim Agents Challenge (WOSAC) 2025 realism metrics, in
//! Rust: how likely the logged future of a scenario is under the
//! distribution of N simulated rollouts of all its agents, feature by
//! feature, grouped into kinematic, interactive and map-based scores and
//! combined into the meta metric.
//!
//! Reference: waymo-research/waymo-open-dataset at commit
//! `508fb261f3b7dee9ebc969d05ff1311b5ea69dc1`,
//! `src/waymo_open_dataset/wdl_limited/sim_agents_metrics/`:
//! `challenge_2025_sim_agents_config.textproto` (ranges, bins, smoothing,
//! weights: [`config`]), `metrics.py` (aggregation), `estimators.py`
//! ([`estimators`]), `metric_features.py`, `trajectory_features.py`,
//! `interaction_features.py`, `map_metric_features.py`,
//! `traffic_light_features.py` ([`features`]); `protos/sim_agents_metrics.proto`
//! (Bernoulli smoothing default 0.001); `utils/sim_agents/submission_specs.py`
//! and `converters.py` (who is simulated, history, validity).
//!
//! Per scenario, as `metrics.py` does it:
//! - the *simulated objects* are the agents valid at the window's current
//!   step; agents appearing later are not part of the scene (Waymo's joint
//!   scenes hold only those). Trajectories are the logged history up to and
//!   including the current step, then the rollout (or the log) after it;
//! - each time-series feature's log-likelihood is taken per evaluated object
//!   and future step against the histogram of that object's simulated values
//!   pooled over rollouts and steps (`independent_timesteps: true`), and the
//!   likelihood is `exp` of the mean log-likelihood over all valid
//!   (object, step) pairs of the scenario (one mean over the scenario, not a
//!   mean of per-object likelihoods). Validity is the log's: speeds need the
//!   logged steps before and after (`central_logical_and` on the 80 future
//!   steps, so the first and last future steps never count), accelerations
//!   that twice, distances the step itself, time to collision the step and a
//!   vehicle;
//! - collision, off-road and traffic-light violation are per-object
//!   indications (any valid step; traffic lights: vehicles only), scored
//!   with the Bernoulli estimator, and the likelihood is `exp` of the mean
//!   over evaluated objects;
//! - the meta metric is the weighted sum of the ten likelihoods (weights sum
//!   to 1); each bucket is its features' weighted mean.
//!
//! Choices where the data or the inputs differ from WOMD's submission format:
//! - Evaluated objects: WOSAC scores the ego plus `tracks_to_predict`. The
//!   scenario model carries no `tracks_to_predict` (56 of the 67 shared WOMD
//!   JSON scenes have none), so by default every simulated object is
//!   evaluated ([`default_evaluated_objects`]); [`score_scenario_for`] takes
//!   an explicit set.
//! - A rollout may leave an agent absent (`None`, e.g. log replay of an agent
//!   that leaves the log). Waymo's submissions have every state; an absent
//!   evaluated object gets Waymo's values for an invalid box (no collision,
//!   distance 10¹⁰ to others, −10¹⁰ to the road edge, NaN kinematics) and is
//!   invisible to the others.
//! - Without road edges (e.g. a map without them) the two road-edge features
//!   are undefined (`None`) and so are the map-based bucket and the meta
//!   metric of that scenario; Waymo raises an error there.
//! - Positions are 2-D (the scenes carry no height).
//!
//! The window ([`RealismWindow::for_scenario`]): 80 future steps from the
//! scenario's current step when it has at least 10 steps of history and 80
//! of future (WOMD: current step 10 of 91); otherwise the window whose
//! current step is step 10 (1.0 s of history, 8.0 s of future) when the
//! scene has at least 91 steps; otherwise none.

pub mod config;
pub mod estimators;
pub mod features;

pub use config::{Bucket, Estimator, Feature, FeatureConfig, RealismConfig};
pub use features::{MetricFeatures, SceneContext, signed_box_distance};

use crate::scenario::{AgentState, Scenario, SourceFormat, TrackIndex};
use features::central_and;

/// Steps of logged history the window needs before its current step.
pub const HISTORY_STEPS: usize = 10;

/// The part of a scenario the metrics score.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct RealismWindow {
    /// The window's current step (rollouts start here; `states[0]`).
    pub start_step: usize,
    /// Future steps scored after it.
    pub future_steps: usize,
}

impl RealismWindow {
    /// The window for `scenario` with `future_steps` of future (see the
    /// module doc for the rule); `None` when the scene is too short.
    pub fn for_scenario(scenario: &Scenario, future_steps: usize) -> Option<Self> {
        let n = scenario.num_steps();
        let fits = |start: usize| start >= HISTORY_STEPS && start + future_steps < n;
        [scenario.current_step, HISTORY_STEPS]
            .into_iter()
            .find(|&s| fits(s))
            .map(|start_step| Self { start_step, future_steps })
    }

    /// The last scored step.
    pub fn end_step(&self) -> usize {
        self.start_step + self.future_steps
    }
}

/// Why a scenario could not be scored.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RealismError {
    /// No rollouts were given.
    #[error("scenario {0}: no rollouts to score")]
    NoRollouts(String),
    /// The window does not fit in the scenario.
    #[error("scenario {scenario}: window {start}..={end} outside its {steps} steps")]
    WindowOutside {
        /// Scenario id.
        scenario: String,
        /// Window start.
        start: usize,
        /// Window end.
        end: usize,
        /// Steps in the scenario.
        steps: usize,
    },
    /// A rollout has the wrong shape.
    #[error(
        "scenario {scenario}: rollout {rollout} has {rows} steps of {width} agents, expected {expected_rows} of {expected_width}"
    )]
    RolloutShape {
        /// Scenario id.
        scenario: String,
        /// Rollout index.
        rollout: usize,
        /// Its steps.
        rows: usize,
        /// Agents in its first mismatching step.
        width: usize,
        /// Steps expected (future steps + 1).
        expected_rows: usize,
        /// Agents expected (the scenario's tracks).
        expected_width: usize,
    },
    /// An evaluated object is not simulated (absent at the window's current step).
    #[error("scenario {scenario}: evaluated track {track} has no state at the window's current step {step}")]
    NotSimulated {
        /// Scenario id.
        scenario: String,
        /// The track.
        track: usize,
        /// The current step.
        step: usize,
    },
    /// Nothing to evaluate.
    #[error("scenario {0}: no agent is valid at the window's current step")]
    NoEvaluatedObjects(String),
}

/// The ten likelihoods, each in `[0, 1]`; `None` where undefined (no valid
/// step to average over, or no road edges).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct FeatureLikelihoods {
    /// Linear speed.
    pub linear_speed: Option<f64>,
    /// Linear acceleration.
    pub linear_acceleration: Option<f64>,
    /// Angular speed.
    pub angular_speed: Option<f64>,
    /// Angular acceleration.
    pub angular_acceleration: Option<f64>,
    /// Distance to the nearest object.
    pub distance_to_nearest_object: Option<f64>,
    /// Collision indication.
    pub collision_indication: Option<f64>,
    /// Time to collision.
    pub time_to_collision: Option<f64>,
    /// Distance to the road edge.
    pub distance_to_road_edge: Option<f64>,
    /// Off-road indication.
    pub offroad_indication: Option<f64>,
    /// Traffic-light violation.
    pub traffic_light_violation: Option<f64>,
}

impl FeatureLikelihoods {
    /// The likelihood of `feature`.
    pub fn get(&self, feature: Feature) -> Option<f64> {
        match feature {
            Feature::LinearSpeed => self.linear_speed,
            Feature::LinearAcceleration => self.linear_acceleration,
            Feature::AngularSpeed => self.angular_speed,
            Feature::AngularAcceleration => self.angular_acceleration,
            Feature::DistanceToNearestObject => self.distance_to_nearest_object,
            Feature::CollisionIndication => self.collision_indication,
            Feature::TimeToCollision => self.time_to_collision,
            Feature::DistanceToRoadEdge => self.distance_to_road_edge,
            Feature::OffroadIndication => self.offroad_indication,
            Feature::TrafficLightViolation => self.traffic_light_violation,
        }
    }

    fn slot(&mut self, feature: Feature) -> &mut Option<f64> {
        match feature {
            Feature::LinearSpeed => &mut self.linear_speed,
            Feature::LinearAcceleration => &mut self.linear_acceleration,
            Feature::AngularSpeed => &mut self.angular_speed,
            Feature::AngularAcceleration => &mut self.angular_acceleration,
            Feature::DistanceToNearestObject => &mut self.distance_to_nearest_object,
            Feature::CollisionIndication => &mut self.collision_indication,
            Feature::TimeToCollision => &mut self.time_to_collision,
            Feature::DistanceToRoadEdge => &mut self.distance_to_road_edge,
            Feature::OffroadIndication => &mut self.offroad_indication,
            Feature::TrafficLightViolation => &mut self.traffic_light_violation,
        }
    }

    /// Sets the likelihood of `feature`.
    pub fn set(&mut self, feature: Feature, value: Option<f64>) {
        *self.slot(feature) = value;
    }

    /// The meta metric: the weighted sum; `None` if any likelihood is.
    pub fn meta_metric(&self, config: &RealismConfig) -> Option<f64> {
        Feature::ALL.iter().map(|f| self.get(*f).map(|l| config.feature(*f).metametric_weight * l)).sum()
    }

    /// A bucket's score: the weighted mean of its likelihoods.
    pub fn bucket(&self, config: &RealismConfig, bucket: Bucket) -> Option<f64> {
        let total = config.bucket_weight(bucket);
        let sum: Option<f64> = Feature::ALL
            .iter()
            .filter(|f| f.bucket() == bucket)
            .map(|f| self.get(*f).map(|l| config.feature(*f).metametric_weight * l))
            .sum();
        sum.filter(|_| total > 0.0).map(|s| s / total)
    }

    /// The three bucket scores.
    pub fn buckets(&self, config: &RealismConfig) -> BucketScores {
        BucketScores {
            kinematic: self.bucket(config, Bucket::Kinematic),
            interactive: self.bucket(config, Bucket::Interactive),
            map_based: self.bucket(config, Bucket::MapBased),
        }
    }
}

/// The leaderboard's three bucket scores, each in `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct BucketScores {
    /// Kinematic metrics.
    pub kinematic: Option<f64>,
    /// Interactive metrics.
    pub interactive: Option<f64>,
    /// Map-based metrics.
    pub map_based: Option<f64>,
}

/// The realism of one scenario's rollouts.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ScenarioRealism {
    /// Scenario id.
    pub scenario_id: String,
    /// Format of the recording.
    pub format: SourceFormat,
    /// The window scored.
    pub window: RealismWindow,
    /// Rollouts scored.
    pub rollouts: usize,
    /// How many of them differ from one another.
    pub distinct_rollouts: usize,
    /// Simulated objects (valid at the window's current step).
    pub simulated_objects: usize,
    /// Evaluated objects.
    pub evaluated_objects: usize,
    /// The ten likelihoods.
    pub likelihoods: FeatureLikelihoods,
    /// Bucket scores.
    pub buckets: BucketScores,
    /// The meta metric.
    pub meta_metric: Option<f64>,
    /// Mean over rollouts and evaluated objects of the average displacement
    /// from the log, m (not scored; Waymo reports it too).
    pub average_displacement_error_m: Option<f64>,
    /// Minimum over rollouts of the mean over objects of that, m.
    pub min_average_displacement_error_m: Option<f64>,
    /// Fraction of (rollout, evaluated object) pairs with a collision.
    pub simulated_collision_rate: f64,
    /// Fraction with an off-road step (`None` without road edges).
    pub simulated_offroad_rate: Option<f64>,
    /// Fraction with a red-light crossing.
    pub simulated_traffic_light_violation_rate: f64,
}

/// The default evaluated objects: every agent valid at `start_step`.
pub fn default_evaluated_objects(scenario: &Scenario, start_step: usize) -> Vec<TrackIndex> {
    (0..scenario.tracks.len()).map(TrackIndex).filter(|&i| scenario.track(i).state(start_step).is_some()).collect()
}

/// Scores `rollouts` of `scenario` over `window`, evaluating every simulated
/// object. `rollouts[r][k][i]`: track `i` at step `window.start_step + k`
/// in rollout `r` (as `sim::Rollout::states`), `k = 0..=future_steps`.
pub fn score_scenario(
    scenario: &Scenario,
    window: RealismWindow,
    rollouts: &[Vec<Vec<Option<AgentState>>>],
    config: &RealismConfig,
) -> Result<ScenarioRealism, RealismError> {
    let evaluated = default_evaluated_objects(scenario, window.start_step);
    score_scenario_for(scenario, window, rollouts, &evaluated, config)
}

/// `exp` of the mean of `ll` over `mask`; `None` when nothing is valid.
fn masked_likelihood(ll: &[Vec<f64>], mask: &[Vec<bool>]) -> Option<f64> {
    let (mut sum, mut n) = (0.0, 0usize);
    for (row, m) in ll.iter().zip(mask) {
        for (v, ok) in row.iter().zip(m) {
            if *ok {
                sum += v;
                n += 1;
            }
        }
    }
    (n > 0).then(|| (sum / n as f64).exp())
}

/// `exp` of the mean of per-object log-likelihoods.
fn mean_likelihood(ll: &[f64]) -> Option<f64> {
    (!ll.is_empty()).then(|| (ll.iter().sum::<f64>() / ll.len() as f64).exp())
}

/// Any step where `mask` and `values` both hold, per object.
fn any_masked(values: &[Vec<bool>], mask: &[Vec<bool>]) -> Vec<bool> {
    values.iter().zip(mask).map(|(v, m)| v.iter().zip(m).any(|(a, b)| *a && *b)).collect()
}

fn rate(indications: &[Vec<bool>]) -> f64 {
    let total: usize = indications.iter().map(Vec::len).sum();
    let hits = indications.iter().flatten().filter(|b| **b).count();
    if total == 0 { 0.0 } else { hits as f64 / total as f64 }
}

/// As [`score_scenario`], evaluating only `evaluated` (each must be valid
/// at the window's current step).
pub fn score_scenario_for(
    scenario: &Scenario,
    window: RealismWindow,
    rollouts: &[Vec<Vec<Option<AgentState>>>],
    evaluated: &[TrackIndex],
    config: &RealismConfig,
) -> Result<ScenarioRealism, RealismError> {
    let id = || scenario.id.clone();
    let (start, f) = (window.start_step, window.future_steps);
    if start < 1 || window.end_step() >= scenario.num_steps() {
        return Err(RealismError::WindowOutside {
            scenario: id(),
            start,
            end: window.end_step(),
            steps: scenario.num_steps(),
        });
    }
    if rollouts.is_empty() {
        return Err(RealismError::NoRollouts(id()));
    }
    let width = scenario.tracks.len();
    for (r, rollout) in rollouts.iter().enumerate() {
        let bad_row = rollout.iter().find(|row| row.len() != width);
        if rollout.len() != f + 1 || bad_row.is_some() {
            return Err(RealismError::RolloutShape {
                scenario: id(),
                rollout: r,
                rows: rollout.len(),
                width: bad_row.map_or(width, Vec::len),
                expected_rows: f + 1,
                expected_width: width,
            });
        }
    }
    let simulated: Vec<TrackIndex> = default_evaluated_objects(scenario, start);
    let mut evaluated_pos = Vec::with_capacity(evaluated.len());
    for e in evaluated {
        match simulated.iter().position(|s| s == e) {
            Some(p) => evaluated_pos.push(p),
            None => return Err(RealismError::NotSimulated { scenario: id(), track: e.0, step: start }),
        }
    }
    if evaluated_pos.is_empty() {
        return Err(RealismError::NoEvaluatedObjects(id()));
    }

    let first = start.saturating_sub(HISTORY_STEPS);
    let current_index = start - first;
    let bodies = simulated.iter().map(|&i| scenario.track(i).body()).collect();
    let ctx = SceneContext::new(&scenario.map, bodies, evaluated_pos, first, current_index, f, config.step_s);
    let history = |i: TrackIndex| scenario.track(i).states[first..=start].to_vec();
    let log: Vec<Vec<Option<AgentState>>> =
        simulated.iter().map(|&i| scenario.track(i).states[first..=window.end_step()].to_vec()).collect();
    let log_features = ctx.features(&log);

    // Rule-based policies give identical rollouts: compute each distinct one once.
    let mut distinct: Vec<usize> = Vec::new();
    let mut which: Vec<usize> = Vec::with_capacity(rollouts.len());
    for (r, rollout) in rollouts.iter().enumerate() {
        match distinct.iter().position(|&d| rollouts[d] == *rollout) {
            Some(k) => which.push(k),
            None => {
                which.push(distinct.len());
                distinct.push(r);
            }
        }
    }
    let sim_traj = |rollout: &[Vec<Option<AgentState>>]| -> Vec<Vec<Option<AgentState>>> {
        simulated
            .iter()
            .map(|&i| {
                let mut tr = history(i);
                tr.extend(rollout[1..].iter().map(|row| row[i.0]));
                tr
            })
            .collect()
    };
    let distinct_features: Vec<(MetricFeatures, Vec<Vec<Option<AgentState>>>)> = distinct
        .iter()
        .map(|&r| {
            let tr = sim_traj(&rollouts[r]);
            (ctx.features(&tr), tr)
        })
        .collect();
    let sims: Vec<&MetricFeatures> = which.iter().map(|&k| &distinct_features[k].0).collect();

    let log_valid = &log_features.valid;
    let speed_valid: Vec<Vec<bool>> = log_valid.iter().map(|v| central_and(v)).collect();
    let accel_valid: Vec<Vec<bool>> = speed_valid.iter().map(|v| central_and(v)).collect();
    let vehicle_valid: Vec<Vec<bool>> =
        log_valid.iter().enumerate().map(|(e, v)| v.iter().map(|ok| *ok && ctx.is_vehicle(e)).collect()).collect();

    let mut likelihoods = FeatureLikelihoods::default();
    let series = |feature: Feature,
                  get: &dyn Fn(&MetricFeatures) -> Option<&Vec<Vec<f64>>>,
                  mask: &[Vec<bool>]|
     -> Option<f64> {
        let log_values = get(&log_features)?;
        let sim_values: Option<Vec<Vec<Vec<f64>>>> = sims.iter().map(|s| get(s).cloned()).collect();
        let ll = estimators::log_likelihood_timeseries(config.feature(feature), log_values, &sim_values?);
        masked_likelihood(&ll, mask)
    };
    likelihoods.set(Feature::LinearSpeed, series(Feature::LinearSpeed, &|m| Some(&m.linear_speed), &speed_valid));
    likelihoods.set(
        Feature::LinearAcceleration,
        series(Feature::LinearAcceleration, &|m| Some(&m.linear_acceleration), &accel_valid),
    );
    likelihoods.set(Feature::AngularSpeed, series(Feature::AngularSpeed, &|m| Some(&m.angular_speed), &speed_valid));
    likelihoods.set(
        Feature::AngularAcceleration,
        series(Feature::AngularAcceleration, &|m| Some(&m.angular_acceleration), &accel_valid),
    );
    likelihoods.set(
        Feature::DistanceToNearestObject,
        series(Feature::DistanceToNearestObject, &|m| Some(&m.distance_to_nearest_object), log_valid),
    );
    likelihoods.set(
        Feature::TimeToCollision,
        series(Feature::TimeToCollision, &|m| Some(&m.time_to_collision), &vehicle_valid),
    );
    likelihoods.set(
        Feature::DistanceToRoadEdge,
        series(Feature::DistanceToRoadEdge, &|m| m.distance_to_road_edge.as_ref(), log_valid),
    );

    let indication = |feature: Feature, log_ind: Vec<bool>, sim_ind: &[Vec<bool>]| -> Option<f64> {
        mean_likelihood(&estimators::log_likelihood_scenario_level(config.feature(feature), &log_ind, sim_ind))
    };
    let sim_collision: Vec<Vec<bool>> = sims.iter().map(|s| any_masked(&s.collision, log_valid)).collect();
    likelihoods.set(
        Feature::CollisionIndication,
        indication(Feature::CollisionIndication, any_masked(&log_features.collision, log_valid), &sim_collision),
    );
    let sim_offroad: Option<Vec<Vec<bool>>> =
        sims.iter().map(|s| s.offroad.as_ref().map(|o| any_masked(o, log_valid))).collect();
    if let (Some(log_off), Some(sim_off)) = (log_features.offroad.as_ref(), sim_offroad.as_ref()) {
        likelihoods.set(
            Feature::OffroadIndication,
            indication(Feature::OffroadIndication, any_masked(log_off, log_valid), sim_off),
        );
    }
    let sim_tl: Vec<Vec<bool>> = sims.iter().map(|s| any_masked(&s.traffic_light_violation, &vehicle_valid)).collect();
    likelihoods.set(
        Feature::TrafficLightViolation,
        indication(
            Feature::TrafficLightViolation,
            any_masked(&log_features.traffic_light_violation, &vehicle_valid),
            &sim_tl,
        ),
    );

    // Average displacement error over the history and future (the history
    // is the log's, so it adds only to the count, as in Waymo's ADE).
    let ade_per_rollout: Vec<Vec<f64>> = which
        .iter()
        .map(|&k| {
            let tr = &distinct_features[k].1;
            ctx.evaluated()
                .iter()
                .map(|&e| {
                    let (mut sum, mut n) = (0.0, 0usize);
                    for (s, l) in tr[e].iter().zip(&log[e]) {
                        if let Some(l) = l {
                            n += 1;
                            if let Some(s) = s {
                                sum += (s.position - l.position).norm();
                            }
                        }
                    }
                    if n > 0 { sum / n as f64 } else { f64::NAN }
                })
                .collect()
        })
        .collect();
    let finite_mean = |xs: &mut dyn Iterator<Item = f64>| {
        let v: Vec<f64> = xs.filter(|x| x.is_finite()).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let ade = finite_mean(&mut ade_per_rollout.iter().flatten().copied());
    let min_ade = ade_per_rollout
        .iter()
        .filter_map(|r| finite_mean(&mut r.iter().copied()))
        .fold(None, |m: Option<f64>, x| Some(m.map_or(x, |m| m.min(x))));
    let tl_rate_ind: Vec<Vec<bool>> = sims.iter().map(|s| any_masked(&s.traffic_light_violation, log_valid)).collect();

    Ok(ScenarioRealism {
        scenario_id: id(),
        format: scenario.source.format,
        window,
        rollouts: rollouts.len(),
        distinct_rollouts: distinct.len(),
        simulated_objects: simulated.len(),
        evaluated_objects: ctx.evaluated().len(),
        buckets: likelihoods.buckets(config),
        meta_metric: likelihoods.meta_metric(config),
        likelihoods,
        average_displacement_error_m: ade,
        min_average_displacement_error_m: min_ade,
        simulated_collision_rate: rate(&sim_collision),
        simulated_offroad_rate: sim_offroad.as_deref().map(rate),
        simulated_traffic_light_violation_rate: rate(&tl_rate_ind),
    })
}

/// Dataset-level realism: Waymo's `aggregate_scenario_metrics` (the mean
/// of each field over scenarios) followed by the buckets and the meta metric
/// of those means.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RealismAggregate {
    /// Scenarios averaged.
    pub scenarios: usize,
    /// Scenarios whose every likelihood is defined.
    pub scenarios_fully_defined: usize,
    /// Mean of each likelihood over the scenarios where it is defined.
    pub likelihoods: FeatureLikelihoods,
    /// Buckets of the mean likelihoods.
    pub buckets: BucketScores,
    /// Meta metric of the mean likelihoods (equal to the mean of the
    /// per-scenario meta metrics when every scenario is fully defined).
    pub meta_metric: Option<f64>,
    /// Mean ADE, m.
    pub average_displacement_error_m: Option<f64>,
    /// Mean minADE, m.
    pub min_average_displacement_error_m: Option<f64>,
    /// Mean simulated collision rate.
    pub simulated_collision_rate: Option<f64>,
    /// Mean simulated off-road rate.
    pub simulated_offroad_rate: Option<f64>,
    /// Mean simulated traffic-light violation rate.
    pub simulated_traffic_light_violation_rate: Option<f64>,
}

impl RealismAggregate {
    /// The aggregate of `results` under `config`.
    pub fn mean<'r>(results: impl IntoIterator<Item = &'r ScenarioRealism>, config: &RealismConfig) -> Self {
        let results: Vec<&ScenarioRealism> = results.into_iter().collect();
        let mean = |get: &dyn Fn(&ScenarioRealism) -> Option<f64>| {
            let v: Vec<f64> = results.iter().filter_map(|r| get(r)).collect();
            (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        };
        let mut likelihoods = FeatureLikelihoods::default();
        for f in Feature::ALL {
            likelihoods.set(f, mean(&|r| r.likelihoods.get(f)));
        }
        Self {
            scenarios: results.len(),
            scenarios_fully_defined: results.iter().filter(|r| r.meta_metric.is_some()).count(),
            buckets: likelihoods.buckets(config),
            meta_metric: likelihoods.meta_metric(config),
            likelihoods,
            average_displacement_error_m: mean(&|r| r.average_displacement_error_m),
            min_average_displacement_error_m: mean(&|r| r.min_average_displacement_error_m),
            simulated_collision_rate: mean(&|r| Some(r.simulated_collision_rate)),
            simulated_offroad_rate: mean(&|r| r.simulated_offroad_rate),
            simulated_traffic_light_violation_rate: mean(&|r| Some(r.simulated_traffic_light_violation_rate)),
        }
    }
}

#[cfg(test)]
mod tests;
