//! A human-like lane follower for synthetic traffic: the IDM lane follower
//! with a seeded, time-correlated acceleration disturbance (an
//! Ornstein–Uhlenbeck process), so that generated drivers do not all track
//! their IDM acceleration exactly. Used to make training traffic for the
//! realism prior; the disturbance size is calibrated against recorded
//! NGSIM accelerations (see `safer prior-dataset`).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{AgentAction, AgentPolicy, IdmLaneFollower, IdmParams, WorldView};
use crate::motion::tokens::{MAX_ACCEL_MPS2, SIM_DT_S};
use crate::scenario::TrackIndex;

/// Size and memory of the acceleration disturbance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriverNoise {
    /// Stationary standard deviation of the disturbance, m/s².
    pub accel_std_mps2: f64,
    /// Correlation time of the disturbance, s.
    pub correlation_time_s: f64,
    /// Seed of this driver's disturbance.
    pub seed: u64,
}

/// IDM lane following plus an Ornstein–Uhlenbeck acceleration disturbance.
#[derive(Debug)]
pub struct NoisyIdm {
    idm: IdmLaneFollower,
    noise: DriverNoise,
    rng: ChaCha8Rng,
    disturbance_mps2: f64,
}

impl NoisyIdm {
    /// A driver with IDM `params` and disturbance `noise`.
    pub fn new(params: IdmParams, noise: DriverNoise) -> Self {
        Self {
            idm: IdmLaneFollower::new(params),
            noise,
            rng: ChaCha8Rng::seed_from_u64(noise.seed),
            disturbance_mps2: 0.0,
        }
    }

    fn standard_normal(&mut self) -> f64 {
        // Box–Muller; `1 - u` keeps the logarithm finite.
        let u1: f64 = 1.0 - self.rng.random::<f64>();
        let u2: f64 = self.rng.random::<f64>();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

impl AgentPolicy for NoisyIdm {
    fn name(&self) -> &'static str {
        "noisy-idm"
    }

    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
        let decay = (-SIM_DT_S / self.noise.correlation_time_s.max(SIM_DT_S)).exp();
        let shock = self.standard_normal();
        self.disturbance_mps2 =
            decay * self.disturbance_mps2 + self.noise.accel_std_mps2 * (1.0 - decay * decay).sqrt() * shock;
        match self.idm.act(world, agent) {
            AgentAction::Control(mut a) => {
                a.accel_mps2 = (a.accel_mps2 + self.disturbance_mps2).clamp(-MAX_ACCEL_MPS2, MAX_ACCEL_MPS2);
                AgentAction::Control(a)
            }
            other => other,
        }
    }
}
