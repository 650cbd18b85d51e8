//! A pedestrian crossing the road on foot: it walks straight at its own
//! pace and waits, where it stands, while a vehicle is in its way or about
//! to be (a car already on the crosswalk, one that would not stop in
//! time), then walks on. It makes the people of the realism prior's
//! synthetic training traffic, beside drivers that yield to them.

use super::{AgentAction, AgentPolicy, WorldView};
use crate::geometry::{OrientedBox, Pose2, Vector2};
use crate::motion::Action;
use crate::scenario::{AgentKind, TrackIndex};

/// How far ahead in time the pedestrian checks its path, s.
const LOOKAHEAD_S: f64 = 1.5;
/// Clearance kept around a vehicle's footprint, m.
const CLEARANCE_M: f64 = 1.0;
/// Vehicles farther than this are not checked, m.
const SENSING_RANGE_M: f64 = 30.0;
/// Acceleration towards the walking pace, and braking to a stand, m/s².
const WALK_ACCEL_MPS2: f64 = 1.5;
const STOP_DECEL_MPS2: f64 = 3.0;

/// A pedestrian that walks straight ahead at `speed_mps` and waits for
/// vehicles in its way.
#[derive(Debug, Clone, Copy)]
pub struct CrossingPedestrian {
    /// Walking pace, m/s.
    pub speed_mps: f64,
}

impl CrossingPedestrian {
    /// Whether a vehicle's footprint, inflated by the clearance and moved
    /// on at its velocity, meets the pedestrian walking on at its pace
    /// within the look-ahead.
    fn blocked(&self, world: &WorldView<'_>, agent: TrackIndex) -> bool {
        let Some(me) = world.state(agent) else { return false };
        let body = world.body(agent);
        let forward = Vector2::new(me.heading_rad.cos(), me.heading_rad.sin());
        world.states.iter().enumerate().any(|(j, other)| {
            let Some(other) = other else { return false };
            if j == agent.0
                || world.bodies[j].kind != AgentKind::Vehicle
                || (other.position - me.position).norm() > SENSING_RANGE_M
            {
                return false;
            }
            let them = world.bodies[j];
            (0..=(LOOKAHEAD_S / 0.5) as usize).any(|k| {
                let t = k as f64 * 0.5;
                let mine = OrientedBox::new(
                    Pose2 { position: me.position + forward * (self.speed_mps * t), heading_rad: me.heading_rad },
                    body.length_m,
                    body.width_m,
                );
                let theirs = OrientedBox::new(
                    Pose2 { position: other.position + other.velocity_mps * t, heading_rad: other.heading_rad },
                    them.length_m + 2.0 * CLEARANCE_M,
                    them.width_m + 2.0 * CLEARANCE_M,
                );
                mine.intersects(&theirs)
            })
        })
    }
}

impl AgentPolicy for CrossingPedestrian {
    fn name(&self) -> &'static str {
        "crossing-pedestrian"
    }

    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
        let Some(me) = world.state(agent) else { return AgentAction::Absent };
        let speed = me.speed_mps();
        let accel = if self.blocked(world, agent) {
            -STOP_DECEL_MPS2.min(speed / crate::motion::tokens::SIM_DT_S)
        } else {
            ((self.speed_mps - speed) / crate::motion::tokens::SIM_DT_S).clamp(-STOP_DECEL_MPS2, WALK_ACCEL_MPS2)
        };
        AgentAction::Control(Action { accel_mps2: accel, yaw_rate_radps: 0.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::RoadMap;
    use crate::scenario::{AgentBody, AgentState};

    fn accel_with_car_at(car_x_m: f64) -> f64 {
        let map = RoadMap::from_lanes(vec![]);
        let bodies = [
            AgentBody { kind: AgentKind::Pedestrian, length_m: 0.6, width_m: 0.6 },
            AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 1.9 },
        ];
        // On the kerb at y = -1, about to walk north across a lane at y = 1.75, 1.2 m/s.
        let walker = AgentState {
            position: crate::geometry::Point2::new(0.0, -1.0),
            heading_rad: std::f64::consts::FRAC_PI_2,
            velocity_mps: Vector2::new(0.0, 1.2),
        };
        let car = AgentState {
            position: crate::geometry::Point2::new(car_x_m, 1.75),
            heading_rad: 0.0,
            velocity_mps: Vector2::new(10.0, 0.0),
        };
        let states = [Some(walker), Some(car)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        match (CrossingPedestrian { speed_mps: 1.4 }).act(&world, TrackIndex(0)) {
            AgentAction::Control(a) => a.accel_mps2,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn waits_for_a_car_about_to_pass_and_walks_when_the_road_is_clear() {
        assert!(accel_with_car_at(-8.0) < 0.0, "a car 8 m away at 10 m/s: wait");
        assert!(accel_with_car_at(-60.0) > 0.0, "a car 60 m away: walk on, up to its pace");
        assert!(accel_with_car_at(6.0) > 0.0, "a car that has passed: walk on");
    }
}
