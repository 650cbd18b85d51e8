//! Likelihood estimators (`estimators.py`): the log-likelihood of each logged
//! value under the distribution of the simulated values, estimated with a
//! smoothed histogram, or a two-bin histogram for booleans (Bernoulli).
//!
//! Binning follows `tfp.stats.histogram` after `tf.clip_by_value`: edges are
//! `linspace(min, max, bins + 1)`, bin `j` is `[e_j, e_{j+1})` and the last
//! bin is closed. A NaN sample falls into bin 0 (tfp's `find_bins` maps NaN
//! to index 0 for integer output). Waymo's simulated series carry NaN where
//! a central difference runs off the end of the window (the last step of
//! speeds, the last two of accelerations), so those samples do land in bin 0
//! of the published metric; this module reproduces that.

use super::config::{Estimator, FeatureConfig};

/// Bin edges as `tf.linspace(min, max, bins + 1)`.
fn edges(min: f64, max: f64, bins: usize) -> Vec<f64> {
    let step = (max - min) / bins as f64;
    (0..=bins).map(|j| if j == bins { max } else { min + j as f64 * step }).collect()
}

/// A smoothed categorical distribution over an estimator's bins.
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothedHistogram {
    min: f64,
    max: f64,
    edges: Vec<f64>,
    log_probs: Vec<f64>,
}

impl SmoothedHistogram {
    /// Histogram of `samples` (NaN counts in bin 0), plus the estimator's
    /// pseudocount in every bin, normalised.
    pub fn from_samples(estimator: &Estimator, samples: impl IntoIterator<Item = f64>) -> Self {
        let (min, max, bins, pseudocount) = match *estimator {
            Estimator::Histogram { min, max, bins, pseudocount } => (min, max, bins.max(1), pseudocount),
            Estimator::Bernoulli { pseudocount } => (-0.5, 1.5, 2, pseudocount),
        };
        let mut h = Self { min, max, edges: edges(min, max, bins), log_probs: vec![0.0; bins] };
        let mut counts = vec![pseudocount; bins];
        for v in samples {
            counts[h.bin(v)] += 1.0;
        }
        let total: f64 = counts.iter().sum();
        h.log_probs = counts.iter().map(|c| (c / total).ln()).collect();
        h
    }

    /// The bin a value falls into after clipping (NaN: bin 0).
    pub fn bin(&self, v: f64) -> usize {
        if v.is_nan() {
            return 0;
        }
        let v = v.clamp(self.min, self.max);
        // `searchsorted(edges, v, side='right') - 1`, clipped to the bins.
        let above = self.edges.partition_point(|e| *e <= v);
        above.saturating_sub(1).min(self.log_probs.len() - 1)
    }

    /// Log-probability of the bin `v` falls into.
    pub fn log_prob(&self, v: f64) -> f64 {
        self.log_probs[self.bin(v)]
    }

    /// Number of bins.
    pub fn bins(&self) -> usize {
        self.log_probs.len()
    }
}

/// Per-object, per-step log-likelihoods of a time-series feature
/// (`log_likelihood_estimate_timeseries`, agent level).
///
/// `log[i][t]` is object `i`'s logged value at future step `t`;
/// `sim[r][i][t]` the same in rollout `r`. With `independent_timesteps` an
/// object's distribution pools all its simulated steps (`R × T` samples);
/// otherwise each step has its own (`R` samples). Every simulated value
/// counts, whatever the validity: the caller masks the logged side.
pub fn log_likelihood_timeseries(config: &FeatureConfig, log: &[Vec<f64>], sim: &[Vec<Vec<f64>>]) -> Vec<Vec<f64>> {
    log.iter()
        .enumerate()
        .map(|(i, log_i)| {
            if config.independent_timesteps {
                let h =
                    SmoothedHistogram::from_samples(&config.estimator, sim.iter().flat_map(|r| r[i].iter().copied()));
                log_i.iter().map(|v| h.log_prob(*v)).collect()
            } else {
                log_i
                    .iter()
                    .enumerate()
                    .map(|(t, v)| {
                        SmoothedHistogram::from_samples(&config.estimator, sim.iter().map(|r| r[i][t])).log_prob(*v)
                    })
                    .collect()
            }
        })
        .collect()
}

/// Per-object log-likelihoods of a per-object boolean
/// (`log_likelihood_estimate_scenario_level` with a Bernoulli estimator):
/// `log[i]` against the `R` simulated values `sim[r][i]`.
pub fn log_likelihood_scenario_level(config: &FeatureConfig, log: &[bool], sim: &[Vec<bool>]) -> Vec<f64> {
    let as_f = |b: bool| if b { 1.0 } else { 0.0 };
    log.iter()
        .enumerate()
        .map(|(i, v)| {
            SmoothedHistogram::from_samples(&config.estimator, sim.iter().map(|r| as_f(r[i]))).log_prob(as_f(*v))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hist(min: f64, max: f64, bins: usize) -> Estimator {
        Estimator::Histogram { min, max, bins, pseudocount: 0.1 }
    }

    #[test]
    fn binning_follows_tfp_with_clipping_and_nan_in_bin_zero() {
        let h = SmoothedHistogram::from_samples(&hist(0.0, 25.0, 10), []);
        assert_eq!(h.bin(0.0), 0);
        assert_eq!(h.bin(2.4999), 0);
        assert_eq!(h.bin(2.5), 1, "left edge is inclusive");
        assert_eq!(h.bin(25.0), 9, "last bin is closed");
        assert_eq!(h.bin(1e6), 9, "clipped");
        assert_eq!(h.bin(-3.0), 0, "clipped");
        assert_eq!(h.bin(f64::NAN), 0);
    }

    #[test]
    fn smoothing_gives_hand_computed_probabilities() {
        // 3 samples in bin 0, 1 in bin 1 of 10: (3.1)/(4+1.0) and (1.1)/5 and 0.1/5.
        let h = SmoothedHistogram::from_samples(&hist(0.0, 25.0, 10), [0.1, 1.0, 2.0, 3.0]);
        assert!((h.log_prob(0.5) - (3.1f64 / 5.0).ln()).abs() < 1e-12);
        assert!((h.log_prob(4.0) - (1.1f64 / 5.0).ln()).abs() < 1e-12);
        assert!((h.log_prob(20.0) - (0.1f64 / 5.0).ln()).abs() < 1e-12);
    }

    #[test]
    fn bernoulli_is_a_two_bin_histogram() {
        let c = FeatureConfig {
            estimator: Estimator::Bernoulli { pseudocount: 0.001 },
            independent_timesteps: false,
            metametric_weight: 0.25,
        };
        // Object 0: 3 of 4 rollouts collide; the log did not.
        let sim = vec![vec![true], vec![true], vec![false], vec![true]];
        let ll = log_likelihood_scenario_level(&c, &[false], &sim);
        assert!((ll[0] - (1.001f64 / 4.002).ln()).abs() < 1e-12);
        let ll = log_likelihood_scenario_level(&c, &[true], &sim);
        assert!((ll[0] - (3.001f64 / 4.002).ln()).abs() < 1e-12);
    }

    #[test]
    fn pooled_and_per_step_distributions_differ_as_defined() {
        let mut c = FeatureConfig {
            estimator: Estimator::Histogram { min: 0.0, max: 2.0, bins: 2, pseudocount: 0.1 },
            independent_timesteps: true,
            metametric_weight: 0.05,
        };
        // One object, two steps; rollouts put step 0 in bin 0 and step 1 in bin 1.
        let sim = vec![vec![vec![0.5, 1.5]], vec![vec![0.5, 1.5]]];
        let log = vec![vec![0.5, 1.5]];
        let pooled = log_likelihood_timeseries(&c, &log, &sim);
        assert!((pooled[0][0] - (2.1f64 / 4.2).ln()).abs() < 1e-12);
        c.independent_timesteps = false;
        let per_step = log_likelihood_timeseries(&c, &log, &sim);
        assert!((per_step[0][0] - (2.1f64 / 2.2).ln()).abs() < 1e-12);
        assert!((per_step[0][1] - (2.1f64 / 2.2).ln()).abs() < 1e-12);
    }
}
