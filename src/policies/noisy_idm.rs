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

/// The Ornstein–Uhlenbeck acceleration disturbance of one driver, advanced
/// once a simulator step.
#[derive(Debug, Clone)]
pub struct AccelDisturbance {
    noise: DriverNoise,
    rng: ChaCha8Rng,
    value_mps2: f64,
}

impl AccelDisturbance {
    /// A disturbance of size and memory `noise`, starting at zero.
    pub fn new(noise: DriverNoise) -> Self {
        Self { noise, rng: ChaCha8Rng::seed_from_u64(noise.seed), value_mps2: 0.0 }
    }

    /// Advances one simulator step and returns the disturbance, m/s².
    pub fn step(&mut self) -> f64 {
        let decay = (-SIM_DT_S / self.noise.correlation_time_s.max(SIM_DT_S)).exp();
        // Box–Muller; `1 - u` keeps the logarithm finite.
        let u1: f64 = 1.0 - self.rng.random::<f64>();
        let u2: f64 = self.rng.random::<f64>();
        let shock = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        self.value_mps2 = decay * self.value_mps2 + self.noise.accel_std_mps2 * (1.0 - decay * decay).sqrt() * shock;
        self.value_mps2
    }
}

/// IDM lane following plus an Ornstein–Uhlenbeck acceleration disturbance.
#[derive(Debug)]
pub struct NoisyIdm {
    idm: IdmLaneFollower,
    disturbance: AccelDisturbance,
}

impl NoisyIdm {
    /// A driver with IDM `params` and disturbance `noise`.
    pub fn new(params: IdmParams, noise: DriverNoise) -> Self {
        Self { idm: IdmLaneFollower::new(params), disturbance: AccelDisturbance::new(noise) }
    }
}

impl AgentPolicy for NoisyIdm {
    fn name(&self) -> &'static str {
        "noisy-idm"
    }

    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
        let disturbance = self.disturbance.step();
        match self.idm.act(world, agent) {
            AgentAction::Control(mut a) => {
                a.accel_mps2 = (a.accel_mps2 + disturbance).clamp(-MAX_ACCEL_MPS2, MAX_ACCEL_MPS2);
                AgentAction::Control(a)
            }
            other => other,
        }
    }
}
