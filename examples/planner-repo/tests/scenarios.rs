//! The scenario suites of this planner, run by safer on `cargo test`: every
//! `specs/suites/*.yaml` becomes tests (`suite::scenario::seed-k` per
//! variant, `suite::metric` per suite metric), snapshots live in
//! `snapshots/`, and a failing variant's recording and picture go to
//! `target/safer-artifacts/`. The planner is registered under the name the
//! suites give it (`planner: { rust: cautious-cruiser }`); the adapter below
//! is all the glue between safer's observation and the planner's own types.

use cautious_cruiser::{CautiousCruiser, Command, EgoState, Point, RoadUser, Scene};
use safer_scenarios::prelude::*;

fn main() {
    Runner::new(env!("CARGO_MANIFEST_DIR")).planner("cautious-cruiser", |_scenario, _ego| Adapter::default()).run()
}

/// The planner behind safer's [`Planner`] trait.
#[derive(Default)]
struct Adapter {
    planner: CautiousCruiser,
    /// The lane the ego keeps: it stays on it (and its successors) rather
    /// than snapping to whichever centreline is nearest, which would steer
    /// it into the next lane when it drifts.
    lane: Option<MapElementId>,
}

impl Adapter {
    /// The kept lane, or its successor, if the ego is still on it; else the
    /// nearest lane in the ego's direction. Returns the lane and the ego's
    /// arc length along it.
    fn lane_under_ego<'m>(&mut self, map: &'m RoadMap, obs: &Observation<'_>) -> Option<(&'m Lane, f64)> {
        let p = &obs.ego.position;
        let kept = self.lane.and_then(|id| map.lane(id));
        let candidates =
            kept.into_iter().chain(kept.into_iter().flat_map(|l| l.successors.iter().filter_map(|id| map.lane(*id))));
        for lane in candidates {
            if let Some(proj) = lane.centreline.project(p)
                && proj.distance_m < 2.5
                && proj.arc_length_m < lane.centreline.length_m()
            {
                self.lane = Some(lane.id);
                return Some((lane, proj.arc_length_m));
            }
        }
        let m = map.nearest_lane(p, Some(obs.ego.heading_rad), 5.0)?;
        let lane = &map.lanes[m.lane_index];
        self.lane = Some(lane.id);
        Some((lane, m.projection.arc_length_m))
    }
}

impl Planner for Adapter {
    fn name(&self) -> &str {
        "cautious-cruiser"
    }

    fn plan(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        let point = |p: &Point2| Point { x: p.x, y: p.y };
        let ego = EgoState {
            position: point(&obs.ego.position),
            heading_rad: obs.ego.heading_rad,
            speed_mps: obs.ego.velocity_mps.norm(),
            length_m: obs.ego_length_m,
        };
        // The lane under the ego, then its first successors, up to 100 m.
        let mut reference_path = Vec::new();
        let mut speed_limit_mps = None;
        if let Some((mut lane, mut s)) = self.lane_under_ego(obs.map, obs) {
            speed_limit_mps = lane.speed_limit_mps;
            while reference_path.len() < 100 {
                let length = lane.centreline.length_m();
                while s <= length && reference_path.len() < 100 {
                    reference_path.extend(lane.centreline.sample(s).map(|(p, _)| point(&p)));
                    s += 1.0;
                }
                match lane.successors.first().and_then(|id| obs.map.lane(*id)) {
                    Some(next) => (lane, s) = (next, 0.0),
                    None => break,
                }
            }
        }
        let others = obs
            .agents
            .iter()
            .map(|a| RoadUser {
                position: point(&a.state.position),
                heading_rad: a.state.heading_rad,
                speed_mps: a.state.velocity_mps.norm(),
                length_m: a.length_m,
                width_m: a.width_m,
            })
            .collect();
        let Command { accel_mps2, yaw_rate_radps } =
            self.planner.plan(&Scene { ego, reference_path, speed_limit_mps, others });
        Ok(PlannerOutput::Control(Action { accel_mps2, yaw_rate_radps }))
    }
}
