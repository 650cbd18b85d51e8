//! Suite-level metrics over all variants, and their checks: CR (stage 1:
//! share of variants where the CBV hits the replayed ego), SR (stage 2:
//! share the planner under test survives), SR over the stage-1-critical
//! variants, and VJ / AJ (Jensen–Shannon divergence of the CBV's speed and
//! acceleration in stage 1 against its logged values; bins in
//! `eval::divergence`).

use super::VariantOutcome;
use crate::eval::{Histogram, jensen_shannon};
use crate::spec::suite::SuiteAcceptance;

/// The metrics of a suite run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SuiteMetrics {
    /// Variants evaluated.
    pub variants: usize,
    /// Stage-1 collision rate (CR).
    pub collision_rate: f64,
    /// Stage-2 solution rate (SR).
    pub solution_rate: f64,
    /// SR over the variants that were critical in stage 1 (`None` if none were).
    pub solution_rate_critical: Option<f64>,
    /// VJ: JSD of CBV speed, generated vs logged.
    pub velocity_jsd: Option<f64>,
    /// AJ: JSD of CBV acceleration, generated vs logged.
    pub acceleration_jsd: Option<f64>,
}

/// One suite-level check (a test).
#[derive(Debug, Clone, PartialEq)]
pub struct MetricCheck {
    /// Metric name, as in the test name (`suite::collision_rate`).
    pub name: &'static str,
    /// Measured value.
    pub value: Option<f64>,
    /// Pass/fail with the reason.
    pub result: Result<(), String>,
}

fn add_cbv_samples(
    o: &VariantOutcome,
    generated: (&mut Histogram, &mut Histogram),
    logged: (&mut Histogram, &mut Histogram),
) {
    let Some(cbv) = o.stage1.cbv else { return };
    let dt = o.stage1.dt_s;
    let speeds: Vec<Option<f64>> = o.stage1.states.iter().map(|row| row[cbv.0].map(|s| s.speed_mps())).collect();
    for w in speeds.windows(2) {
        if let (Some(a), Some(b)) = (w[0], w[1]) {
            generated.0.add(b);
            generated.1.add((b - a) / dt);
        }
    }
    let track = o.scenario.track(cbv);
    let logged_speeds: Vec<Option<f64>> =
        (o.stage1.start_step..o.scenario.num_steps()).map(|k| track.state(k).map(|s| s.speed_mps())).collect();
    for w in logged_speeds.windows(2) {
        if let (Some(a), Some(b)) = (w[0], w[1]) {
            logged.0.add(b);
            logged.1.add((b - a) / dt);
        }
    }
}

impl SuiteMetrics {
    /// Computes the metrics over `outcomes`.
    pub fn compute(outcomes: &[VariantOutcome]) -> SuiteMetrics {
        let n = outcomes.len();
        let share = |k: usize, of: usize| if of == 0 { 0.0 } else { k as f64 / of as f64 };
        let critical: Vec<&VariantOutcome> = outcomes.iter().filter(|o| o.stage1_cbv_hit_ego()).collect();
        let (mut gv, mut ga, mut lv, mut la) =
            (Histogram::speed(), Histogram::acceleration(), Histogram::speed(), Histogram::acceleration());
        for o in outcomes {
            add_cbv_samples(o, (&mut gv, &mut ga), (&mut lv, &mut la));
        }
        SuiteMetrics {
            variants: n,
            collision_rate: share(critical.len(), n),
            solution_rate: share(outcomes.iter().filter(|o| o.solved()).count(), n),
            solution_rate_critical: (!critical.is_empty())
                .then(|| share(critical.iter().filter(|o| o.solved()).count(), critical.len())),
            velocity_jsd: jensen_shannon(&gv, &lv),
            acceleration_jsd: jensen_shannon(&ga, &la),
        }
    }

    /// The checks the spec asks for, in a fixed order.
    pub fn checks(&self, acceptance: &SuiteAcceptance) -> Vec<MetricCheck> {
        let mut out = Vec::new();
        let mut at_least = |name: &'static str, value: Option<f64>, min: Option<f64>| {
            if let Some(min) = min {
                let result = match value {
                    Some(v) if v >= min => Ok(()),
                    Some(v) => Err(format!("{name} = {v:.3} < {min} over {} variants", self.variants)),
                    None => Err(format!("{name} could not be measured")),
                };
                out.push(MetricCheck { name, value, result });
            }
        };
        at_least("collision_rate", Some(self.collision_rate), acceptance.collision_rate_min);
        at_least("solution_rate", Some(self.solution_rate), acceptance.solution_rate_min);
        let mut at_most = |name: &'static str, value: Option<f64>, max: Option<f64>| {
            if let Some(max) = max {
                let result = match value {
                    Some(v) if v <= max => Ok(()),
                    Some(v) => Err(format!("{name} = {v:.3} > {max}")),
                    None => Err(format!("{name} could not be measured (no CBV speeds)")),
                };
                out.push(MetricCheck { name, value, result });
            }
        };
        at_most("velocity_jsd", self.velocity_jsd, acceptance.velocity_jsd_max);
        at_most("acceleration_jsd", self.acceleration_jsd, acceptance.acceleration_jsd_max);
        out
    }
}

/// Names of the metric tests a suite has (known without running anything).
pub fn metric_names(acceptance: &SuiteAcceptance) -> Vec<&'static str> {
    [
        ("collision_rate", acceptance.collision_rate_min.is_some()),
        ("solution_rate", acceptance.solution_rate_min.is_some()),
        ("velocity_jsd", acceptance.velocity_jsd_max.is_some()),
        ("acceleration_jsd", acceptance.acceleration_jsd_max.is_some()),
    ]
    .into_iter()
    .filter_map(|(n, on)| on.then_some(n))
    .collect()
}
