//! The published WOSAC 2025 metric configuration
//! (`challenge_2025_sim_agents_config.textproto`): per feature, its
//! estimator (histogram range, bins and additive smoothing, or Bernoulli),
//! whether time steps are pooled, and its meta-metric weight; and the three
//! buckets the leaderboard reports.

/// How the simulated distribution of a feature is estimated.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum Estimator {
    /// A histogram over `[min, max]` with `bins` equal bins; values are
    /// clipped into the range first, and every bin gets `pseudocount`
    /// added before normalising.
    Histogram {
        /// Lower edge.
        min: f64,
        /// Upper edge (the last bin is closed).
        max: f64,
        /// Number of bins.
        bins: usize,
        /// Additive smoothing per bin.
        pseudocount: f64,
    },
    /// Two bins (false, true) with additive smoothing.
    Bernoulli {
        /// Additive smoothing per bin.
        pseudocount: f64,
    },
}

/// One feature's configuration.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FeatureConfig {
    /// The estimator.
    pub estimator: Estimator,
    /// Pool every simulated step of an object into one distribution (true
    /// for every time series in 2025) instead of one distribution per step.
    pub independent_timesteps: bool,
    /// Weight in the meta metric.
    pub metametric_weight: f64,
}

/// The ten realism features, in Waymo's order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Feature {
    /// Speed, m/s (central difference of positions).
    LinearSpeed,
    /// Change of speed, m/s² (central difference of speeds).
    LinearAcceleration,
    /// Yaw rate, rad/s (central difference of headings).
    AngularSpeed,
    /// Yaw acceleration, rad/s².
    AngularAcceleration,
    /// Signed box distance to the nearest other object, m.
    DistanceToNearestObject,
    /// Whether the object's box overlaps another one at any step.
    CollisionIndication,
    /// Time to collision with the object followed, s.
    TimeToCollision,
    /// Signed distance of the most off-road box corner to the road edge, m.
    DistanceToRoadEdge,
    /// Whether any box corner leaves the road at any step.
    OffroadIndication,
    /// Whether a vehicle crosses a stop line on red at any step.
    TrafficLightViolation,
}

impl Feature {
    /// Every feature, in Waymo's order.
    pub const ALL: [Feature; 10] = [
        Feature::LinearSpeed,
        Feature::LinearAcceleration,
        Feature::AngularSpeed,
        Feature::AngularAcceleration,
        Feature::DistanceToNearestObject,
        Feature::CollisionIndication,
        Feature::TimeToCollision,
        Feature::DistanceToRoadEdge,
        Feature::OffroadIndication,
        Feature::TrafficLightViolation,
    ];

    /// Waymo's field name (`linear_speed`, …).
    pub fn name(self) -> &'static str {
        match self {
            Feature::LinearSpeed => "linear_speed",
            Feature::LinearAcceleration => "linear_acceleration",
            Feature::AngularSpeed => "angular_speed",
            Feature::AngularAcceleration => "angular_acceleration",
            Feature::DistanceToNearestObject => "distance_to_nearest_object",
            Feature::CollisionIndication => "collision_indication",
            Feature::TimeToCollision => "time_to_collision",
            Feature::DistanceToRoadEdge => "distance_to_road_edge",
            Feature::OffroadIndication => "offroad_indication",
            Feature::TrafficLightViolation => "traffic_light_violation",
        }
    }

    /// The bucket the feature is reported in.
    pub fn bucket(self) -> Bucket {
        match self {
            Feature::LinearSpeed
            | Feature::LinearAcceleration
            | Feature::AngularSpeed
            | Feature::AngularAcceleration => Bucket::Kinematic,
            Feature::DistanceToNearestObject | Feature::CollisionIndication | Feature::TimeToCollision => {
                Bucket::Interactive
            }
            Feature::DistanceToRoadEdge | Feature::OffroadIndication | Feature::TrafficLightViolation => {
                Bucket::MapBased
            }
        }
    }
}

/// The leaderboard's groups of features (`_METRIC_FIELD_NAMES_BY_BUCKET`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Bucket {
    /// Linear and angular speed and acceleration.
    Kinematic,
    /// Distance to the nearest object, collision, time to collision.
    Interactive,
    /// Distance to the road edge, off-road, traffic-light violation.
    MapBased,
}

impl Bucket {
    /// The three buckets.
    pub const ALL: [Bucket; 3] = [Bucket::Kinematic, Bucket::Interactive, Bucket::MapBased];
}

/// The metric configuration: one [`FeatureConfig`] per [`Feature`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RealismConfig {
    /// Per feature, in [`Feature::ALL`] order.
    pub features: [FeatureConfig; 10],
    /// Future steps scored (WOSAC: 80, i.e. 8 s at 10 Hz).
    pub future_steps: usize,
    /// Step length the finite differences divide by, s (WOSAC: 0.1).
    pub step_s: f64,
}

const fn histogram(min: f64, max: f64, bins: usize, weight: f64) -> FeatureConfig {
    FeatureConfig {
        estimator: Estimator::Histogram { min, max, bins, pseudocount: 0.1 },
        independent_timesteps: true,
        metametric_weight: weight,
    }
}

/// `BernoulliEstimate.additive_smoothing_pseudocount` default in
/// `sim_agents_metrics.proto` (the 2025 config leaves it unset).
const BERNOULLI_DEFAULT_PSEUDOCOUNT: f64 = 0.001;

const fn bernoulli(weight: f64) -> FeatureConfig {
    FeatureConfig {
        estimator: Estimator::Bernoulli { pseudocount: BERNOULLI_DEFAULT_PSEUDOCOUNT },
        independent_timesteps: false,
        metametric_weight: weight,
    }
}

impl RealismConfig {
    /// `challenge_2025_sim_agents_config.textproto`, value for value.
    // The config says 3.14 and 0.628 (not π, π/5): the bin edges follow it.
    #[allow(clippy::approx_constant)]
    pub fn wosac_2025() -> Self {
        Self {
            features: [
                histogram(0.0, 25.0, 10, 0.05),
                histogram(-12.0, 12.0, 11, 0.05),
                histogram(-0.628, 0.628, 11, 0.05),
                histogram(-3.14, 3.14, 11, 0.05),
                histogram(-5.0, 40.0, 10, 0.10),
                bernoulli(0.25),
                histogram(0.0, 5.0, 10, 0.10),
                histogram(-20.0, 40.0, 10, 0.05),
                bernoulli(0.25),
                bernoulli(0.05),
            ],
            future_steps: 80,
            step_s: 0.1,
        }
    }

    /// The configuration of `feature`.
    pub fn feature(&self, feature: Feature) -> &FeatureConfig {
        &self.features[feature as usize]
    }

    /// Sum of the meta-metric weights of a bucket's features.
    pub fn bucket_weight(&self, bucket: Bucket) -> f64 {
        Feature::ALL.iter().filter(|f| f.bucket() == bucket).map(|f| self.feature(*f).metametric_weight).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one_and_buckets_partition_them() {
        let c = RealismConfig::wosac_2025();
        let total: f64 = Feature::ALL.iter().map(|f| c.feature(*f).metametric_weight).sum();
        assert!((total - 1.0).abs() < 1e-12, "{total}");
        let by_bucket: f64 = Bucket::ALL.iter().map(|b| c.bucket_weight(*b)).sum();
        assert!((by_bucket - 1.0).abs() < 1e-12);
        assert!((c.bucket_weight(Bucket::Kinematic) - 0.2).abs() < 1e-12);
        assert!((c.bucket_weight(Bucket::Interactive) - 0.45).abs() < 1e-12);
        assert!((c.bucket_weight(Bucket::MapBased) - 0.35).abs() < 1e-12);
    }

    #[test]
    fn feature_order_matches_the_array() {
        for (i, f) in Feature::ALL.iter().enumerate() {
            assert_eq!(*f as usize, i);
        }
        let c = RealismConfig::wosac_2025();
        assert!(matches!(c.feature(Feature::CollisionIndication).estimator, Estimator::Bernoulli { .. }));
        assert!(matches!(
            c.feature(Feature::TimeToCollision).estimator,
            Estimator::Histogram { min: 0.0, max: 5.0, bins: 10, .. }
        ));
    }
}
