//! Whether a variant's conflict reached the planner under test: the
//! closest box distance between the ego and the CBV over a rollout, and
//! whether it fell to [`CONFLICT_REACH_M`]. A CBV aimed at the recorded ego
//! that the planner's ego never comes near tests nothing; the rollout's
//! closest gap to *anyone* cannot tell, since it is often the start-of-log
//! gap to another car, the same for every seed.

use crate::sim::Rollout;

/// The box distance at which a CBV has reached the ego, m.
pub const CONFLICT_REACH_M: f64 = 1.0;

/// How close the CBV came to the ego over a rollout.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct ConflictReach {
    /// Smallest ego–CBV box distance, m (0 at a contact); `None` when they
    /// were never present at the same step (or there is no CBV).
    pub min_gap_to_cbv_m: Option<f64>,
    /// The CBV came within [`CONFLICT_REACH_M`] of the ego.
    pub reached: bool,
}

impl ConflictReach {
    /// The reach of `rollout`'s CBV to its ego.
    pub fn of(rollout: &Rollout) -> Self {
        let (ego, Some(cbv)) = (rollout.ego.0, rollout.cbv) else { return Self::default() };
        let (eb, cb) = (rollout.bodies[ego], rollout.bodies[cbv.0]);
        let min_gap_to_cbv_m = rollout
            .states
            .iter()
            .filter_map(|row| Some(eb.footprint(row[ego].as_ref()?).distance(&cb.footprint(row[cbv.0].as_ref()?))))
            .reduce(f64::min);
        Self { min_gap_to_cbv_m, reached: min_gap_to_cbv_m.is_some_and(|d| d <= CONFLICT_REACH_M) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::scenario::{AgentBody, AgentId, AgentKind, AgentState, TrackIndex};
    use crate::sim::Termination;

    /// A rollout of two cars along x, the CBV at `cbv_x[k]` at step k and
    /// the ego standing at 0.
    fn rollout(cbv_x: &[f64]) -> Rollout {
        let at = |x: f64| {
            Some(AgentState { position: Point2::new(x, 0.0), heading_rad: 0.0, velocity_mps: Vector2::zeros() })
        };
        let body = AgentBody { kind: AgentKind::Vehicle, length_m: 4.0, width_m: 2.0 };
        Rollout {
            scenario_id: "reach".into(),
            dt_s: 0.1,
            start_step: 0,
            ego: TrackIndex(0),
            cbv: Some(TrackIndex(1)),
            agent_ids: vec![AgentId("ego".into()), AgentId("cbv".into())],
            bodies: vec![body, body],
            states: cbv_x.iter().map(|&x| vec![at(0.0), at(x)]).collect(),
            collisions: Vec::new(),
            off_road: Vec::new(),
            min_distance_to_ego: None,
            termination: Termination::Completed,
            planner: "test".into(),
            planner_debug: Vec::new(),
        }
    }

    #[test]
    fn the_closest_gap_to_the_cbv_decides_the_reach() {
        // Centres 30 m, then 5.5 m apart: boxes 4 m long, 1.5 m apart.
        let near = ConflictReach::of(&rollout(&[30.0, 5.5, 20.0]));
        assert!((near.min_gap_to_cbv_m.unwrap() - 1.5).abs() < 1e-4, "{near:?}");
        assert!(!near.reached);
        let reached = ConflictReach::of(&rollout(&[30.0, 4.9, 20.0]));
        assert!(reached.reached && (reached.min_gap_to_cbv_m.unwrap() - 0.9).abs() < 1e-4, "{reached:?}");
        assert_eq!(ConflictReach::of(&rollout(&[3.0])).min_gap_to_cbv_m, Some(0.0));
    }

    #[test]
    fn without_a_cbv_nothing_is_reached() {
        let mut r = rollout(&[4.0]);
        r.cbv = None;
        assert_eq!(ConflictReach::of(&r), ConflictReach::default());
    }
}
