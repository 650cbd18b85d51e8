//! Rule-based aggressive CBV behaviour, for collecting feasibility data: the
//! CBV pursues a point defined relative to the ego — ahead of it in its
//! lane (a cut-in), at it (a rear-end or side approach), beside it (a
//! squeeze) — with pure-pursuit steering and a speed that closes the gap,
//! within the token grid's limits. Each instance draws its aim point and
//! aggressiveness from a seed, so a batch of rollouts covers near misses,
//! collisions and escapes.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{AgentAction, AgentPolicy, WorldView};
use crate::geometry::{Pose2, Vector2, wrap_angle};
use crate::motion::Action;
use crate::motion::tokens::{MAX_ACCEL_MPS2, MAX_YAW_RATE_RADPS};
use crate::scenario::TrackIndex;

/// A CBV that pursues an aim point relative to the ego.
#[derive(Debug, Clone)]
pub struct EgoPursuit {
    ego: TrackIndex,
    /// Aim point in the ego's frame: metres ahead of the ego's centre.
    ahead_m: f64,
    /// Aim point: metres to the ego's left.
    left_m: f64,
    /// Seconds of look-ahead on the ego's velocity for the aim point.
    lead_s: f64,
    /// Desired closing speed on top of the ego's speed, m/s.
    closing_mps: f64,
    /// Largest acceleration used, m/s².
    max_accel_mps2: f64,
}

impl EgoPursuit {
    /// A pursuer of `ego` with parameters drawn from `seed`.
    pub fn random(ego: TrackIndex, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let style = rng.random_range(0..3);
        let (ahead_m, left_m) = match style {
            0 => (rng.random_range(2.0..12.0), 0.0), // cut in ahead of the ego
            1 => (0.0, 0.0),                         // drive at the ego
            _ => (rng.random_range(-3.0..3.0), rng.random_range(-2.5..2.5)), // squeeze alongside
        };
        Self {
            ego,
            ahead_m,
            left_m,
            lead_s: rng.random_range(0.0..2.0),
            closing_mps: rng.random_range(-1.0..6.0),
            max_accel_mps2: rng.random_range(1.5..MAX_ACCEL_MPS2),
        }
    }
}

impl AgentPolicy for EgoPursuit {
    fn name(&self) -> &'static str {
        "ego-pursuit"
    }

    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
        let Some(me) = world.state(agent) else { return AgentAction::Absent };
        let Some(ego) = world.state(self.ego) else { return AgentAction::Control(Action::default()) };
        let ego_frame = Pose2 { position: ego.position + ego.velocity_mps * self.lead_s, heading_rad: ego.heading_rad };
        let aim = ego_frame.from_body(&Vector2::new(self.ahead_m, self.left_m));
        let to_aim = aim - me.position;
        let distance = to_aim.norm().max(1e-3);
        // Pure pursuit: curvature 2 sin(α) / L, yaw rate = v κ.
        let alpha = wrap_angle(to_aim.y.atan2(to_aim.x) - me.heading_rad);
        let speed = me.speed_mps();
        let yaw_rate =
            (speed.max(2.0) * 2.0 * alpha.sin() / distance.max(4.0)).clamp(-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS);
        let target_speed = (ego.speed_mps() + self.closing_mps * (distance / 10.0).min(1.0)).max(0.0);
        let accel = (1.2 * (target_speed - speed)).clamp(-MAX_ACCEL_MPS2, self.max_accel_mps2);
        AgentAction::Control(Action { accel_mps2: accel, yaw_rate_radps: yaw_rate })
    }
}
