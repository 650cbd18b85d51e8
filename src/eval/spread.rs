//! How a set of per-variant figures spreads ([`Spread`]): the median, the
//! 90th percentile (nearest rank) and the largest, for the tables that set
//! a generated CBV's figures beside the recorded CBV's.

/// How a set of per-variant figures spreads, in the unit the field that
/// holds it names.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Spread {
    /// Figures measured (NaN left out).
    pub measured: usize,
    /// The median (nearest rank).
    pub p50: f64,
    /// The 90th percentile (nearest rank).
    pub p90: f64,
    /// The largest.
    pub max: f64,
}

impl Spread {
    /// The spread of `figures` (NaN left out); `None` for none.
    pub fn of(figures: impl IntoIterator<Item = f64>) -> Option<Self> {
        let mut sorted: Vec<f64> = figures.into_iter().filter(|v| !v.is_nan()).collect();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let nearest_rank = |p: f64| sorted[((p * n as f64).ceil() as usize).clamp(1, n) - 1];
        (n > 0).then(|| Self { measured: n, p50: nearest_rank(0.5), p90: nearest_rank(0.9), max: sorted[n - 1] })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spread_takes_nearest_ranks_and_leaves_out_nan() {
        let spread = Spread::of((1..=10).rev().map(f64::from).chain([f64::NAN])).unwrap();
        assert_eq!(spread, Spread { measured: 10, p50: 5.0, p90: 9.0, max: 10.0 });
        assert_eq!(Spread::of([2.5]), Some(Spread { measured: 1, p50: 2.5, p90: 2.5, max: 2.5 }));
        assert_eq!(Spread::of([f64::NAN]), None);
    }
}
