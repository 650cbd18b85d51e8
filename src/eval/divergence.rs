//! Histograms and the Jensen–Shannon divergence (base 2, so it lies in
//! [0, 1]) used for VJ, AJ and YJ: how far a generated CBV's speed,
//! acceleration or yaw-rate distribution is from the logged one.
//!
//! The signed quantities' bins are centred on 0. A CBV driven by tokens
//! holds an acceleration or yaw rate of exactly 0 (the token grid has a 0
//! bin), where a recorded car jitters a little either side of it: with a
//! bin edge at 0 the exact zeros fall in one bin and the jitter in two,
//! and a CBV driving straight scored as unlike a recorded car driving
//! straight.

/// A fixed-bin histogram over `[min, max)`; values outside clamp to the edge bins.
#[derive(Debug, Clone, PartialEq)]
pub struct Histogram {
    min: f64,
    max: f64,
    counts: Vec<f64>,
}

impl Histogram {
    /// `bins` equal bins over `[min, max)`.
    pub fn new(min: f64, max: f64, bins: usize) -> Self {
        Self { min, max, counts: vec![0.0; bins.max(1)] }
    }

    /// Speed bins for VJ: 0–40 m/s in 1 m/s bins.
    pub fn speed() -> Self {
        Self::new(0.0, 40.0, 40)
    }

    /// Acceleration bins for AJ: 0.5 m/s² bins centred on 0 (the middle
    /// one −0.25 to 0.25), over −8.25 to 8.25 m/s².
    pub fn acceleration() -> Self {
        Self::centred_on_zero(0.5, 16)
    }

    /// Yaw-rate bins for YJ: 0.05 rad/s bins centred on 0 (the middle one
    /// −0.025 to 0.025), over −1.025 to 1.025 rad/s.
    pub fn yaw_rate() -> Self {
        Self::centred_on_zero(0.05, 20)
    }

    /// `2 × per_side + 1` bins `width` wide, the middle one centred on 0.
    fn centred_on_zero(width: f64, per_side: usize) -> Self {
        let half_span = (per_side as f64 + 0.5) * width;
        Self::new(-half_span, half_span, 2 * per_side + 1)
    }

    /// Adds a value (non-finite values are ignored).
    pub fn add(&mut self, v: f64) {
        if !v.is_finite() {
            return;
        }
        let n = self.counts.len();
        let i = ((v - self.min) / (self.max - self.min) * n as f64).floor();
        self.counts[(i.max(0.0) as usize).min(n - 1)] += 1.0;
    }

    /// Number of values added.
    pub fn total(&self) -> f64 {
        self.counts.iter().sum()
    }

    fn probabilities(&self) -> Vec<f64> {
        let t = self.total();
        self.counts.iter().map(|c| if t > 0.0 { c / t } else { 0.0 }).collect()
    }
}

/// Jensen–Shannon divergence of two histograms with the same bins, in bits;
/// `None` when either is empty or the bins differ.
pub fn jensen_shannon(p: &Histogram, q: &Histogram) -> Option<f64> {
    if p.counts.len() != q.counts.len() || p.min != q.min || p.max != q.max || p.total() == 0.0 || q.total() == 0.0 {
        return None;
    }
    let (p, q) = (p.probabilities(), q.probabilities());
    let kl = |a: &[f64], m: &[f64]| -> f64 {
        a.iter().zip(m).filter(|(x, _)| **x > 0.0).map(|(x, y)| x * (x / y).log2()).sum()
    };
    let m: Vec<f64> = p.iter().zip(&q).map(|(a, b)| 0.5 * (a + b)).collect();
    Some((0.5 * kl(&p, &m) + 0.5 * kl(&q, &m)).clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_is_zero_disjoint_is_one() {
        let mut a = Histogram::speed();
        let mut b = Histogram::speed();
        for v in [1.0, 2.5, 10.0] {
            a.add(v);
            b.add(v);
        }
        assert_eq!(jensen_shannon(&a, &b), Some(0.0));
        let mut c = Histogram::speed();
        c.add(30.0);
        assert!((jensen_shannon(&a, &c).unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(jensen_shannon(&a, &Histogram::speed()), None);
    }

    #[test]
    fn holding_exactly_zero_matches_recorded_jitter_around_zero() {
        // A token-driven CBV driving straight at constant speed, and a
        // recorded car doing the same with its tracker's jitter.
        for (mut generated, mut recorded, jitter) in [
            (Histogram::acceleration(), Histogram::acceleration(), 0.2),
            (Histogram::yaw_rate(), Histogram::yaw_rate(), 0.02),
        ] {
            for k in 0..100 {
                generated.add(0.0);
                recorded.add(if k % 2 == 0 { jitter } else { -jitter });
            }
            assert_eq!(jensen_shannon(&generated, &recorded), Some(0.0));
        }
    }

    #[test]
    fn the_signed_bins_are_symmetric_about_zero() {
        for (h, width) in [(Histogram::acceleration(), 0.5), (Histogram::yaw_rate(), 0.05)] {
            let n = h.counts.len();
            assert_eq!(n % 2, 1, "an odd number of bins, one of them in the middle");
            assert!((h.max + h.min).abs() < 1e-12);
            assert!(((h.max - h.min) / n as f64 - width).abs() < 1e-12);
            let bin = |v: f64| {
                let mut one = Histogram { counts: vec![0.0; n], ..h.clone() };
                one.add(v);
                one.counts.iter().position(|&c| c > 0.0).unwrap()
            };
            assert_eq!(bin(0.0), n / 2);
            assert_eq!(bin(0.49 * width), n / 2);
            assert_eq!(bin(-0.49 * width), n / 2);
            assert_eq!(bin(0.51 * width), n / 2 + 1);
            assert_eq!(bin(-0.51 * width), n / 2 - 1);
        }
    }
}
