//! Histograms and the Jensen–Shannon divergence (base 2, so it lies in
//! [0, 1]) used for VJ and AJ: how far a generated CBV's speed or
//! acceleration distribution is from the logged one.

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

    /// Acceleration bins for AJ: −8 to 8 m/s² in 0.5 m/s² bins.
    pub fn acceleration() -> Self {
        Self::new(-8.0, 8.0, 32)
    }

    /// Yaw-rate bins for YJ: −1 to 1 rad/s in 0.05 rad/s bins.
    pub fn yaw_rate() -> Self {
        Self::new(-1.0, 1.0, 40)
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
}
