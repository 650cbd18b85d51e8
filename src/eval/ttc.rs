//! Time to collision of the ego: at each step, every agent within reach is
//! extrapolated with the ego at constant velocity, and the first time their
//! boxes overlap (within a horizon) is that pair's TTC. The rollout's TTC is
//! the minimum over steps and agents; `None` when no extrapolation collides.

use crate::geometry::{OrientedBox, Pose2};
use crate::sim::Rollout;

/// Horizon of the extrapolation, s.
pub const TTC_HORIZON_S: f64 = 5.0;
const TTC_STEP_S: f64 = 0.1;

/// Minimum TTC of the ego over the rollout, s (steps where the ego already
/// overlaps an agent count as 0).
pub fn min_time_to_collision(rollout: &Rollout) -> Option<f64> {
    let ego = rollout.ego.0;
    let eb = rollout.bodies[ego];
    let mut best: Option<f64> = None;
    // Each body's half-diagonal, once per rollout rather than per state.
    let half_diagonal_m: Vec<f64> = rollout.bodies.iter().map(|b| 0.5 * b.length_m.hypot(b.width_m)).collect();
    for row in &rollout.states {
        let Some(e) = row[ego] else { continue };
        let reach_ego = half_diagonal_m[ego];
        for (i, s) in row.iter().enumerate() {
            let Some(s) = s else { continue };
            if i == ego {
                continue;
            }
            let b = rollout.bodies[i];
            let reach = reach_ego + half_diagonal_m[i];
            let rel_v = (s.velocity_mps - e.velocity_mps).norm();
            // Cannot meet within the horizon (or within the best so far).
            let horizon = best.unwrap_or(TTC_HORIZON_S).min(TTC_HORIZON_S);
            if (s.position - e.position).norm() - reach > rel_v * horizon {
                continue;
            }
            let mut t = 0.0;
            while t <= horizon + 1e-9 {
                let pe = Pose2 { position: e.position + e.velocity_mps * t, heading_rad: e.heading_rad };
                let ps = Pose2 { position: s.position + s.velocity_mps * t, heading_rad: s.heading_rad };
                if OrientedBox::new(pe, eb.length_m, eb.width_m)
                    .intersects(&OrientedBox::new(ps, b.length_m, b.width_m))
                {
                    best = Some(best.map_or(t, |x: f64| x.min(t)));
                    break;
                }
                t += TTC_STEP_S;
            }
        }
    }
    best
}
