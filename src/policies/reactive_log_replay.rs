//! Reactive log replay: a recorded agent keeps to its recorded path but not
//! blindly to its recorded timing. While nothing is in its way it replays
//! the log exactly. When a road user is on its path ahead closer than a
//! short safe gap (someone the log did not put there: the ego under test,
//! the CBV, or another agent that left its recording), it brakes along its
//! path with IDM's interaction term, then catches up with its recording at
//! a comfortable acceleration, never getting ahead of it. Its presence
//! follows the log. The safe gap is short (1.5 m plus 0.5 s of headway), so
//! the closer following that recorded drivers show does not trigger it.

use super::lane_follower::idm_desired_gap_m;
use super::{AgentAction, AgentPolicy, WorldView};
use crate::geometry::{Point2, Polyline};
use crate::motion::kinematics::stepped_speed_mps;
use crate::motion::tokens::SIM_DT_S;
use crate::scenario::{AgentState, Track, TrackIndex};

/// Standstill part of the safe gap, m.
const SAFE_GAP_M: f64 = 1.5;
/// Headway part of the safe gap, s.
const SAFE_HEADWAY_S: f64 = 0.5;
/// IDM's maximum acceleration in the interaction term, m/s².
const IDM_ACCEL_MPS2: f64 = 2.0;
/// IDM's comfortable deceleration, m/s².
const IDM_COMFORT_DECEL_MPS2: f64 = 3.0;
/// The hardest braking, m/s².
const MAX_DECEL_MPS2: f64 = 8.0;
/// Acceleration while catching up with the recording, m/s².
const CATCH_UP_ACCEL_MPS2: f64 = 2.0;
/// How far ahead along its path an agent looks, m.
const LOOKAHEAD_M: f64 = 60.0;
/// Recorded points closer than this are merged (tracking jitter at a stop).
const MIN_STEP_M: f64 = 0.05;

/// Replays a recorded track, braking for whoever is in its way.
#[derive(Debug, Clone)]
pub struct ReactiveLogReplay {
    track: Track,
    /// The recorded positions in order, jitter merged.
    path: Polyline,
    /// Arc length along `path` of the recorded position at each step
    /// (`None`: absent).
    schedule_m: Vec<Option<f64>>,
    /// Own progress and speed while behind the recording.
    behind: Option<(f64, f64)>,
}

impl ReactiveLogReplay {
    /// Replays `track`.
    pub fn new(track: Track) -> Self {
        let mut points: Vec<Point2> = Vec::new();
        let mut arc_m = 0.0;
        let schedule_m = track
            .states
            .iter()
            .map(|s| {
                let s = s.as_ref()?;
                match points.last() {
                    Some(last) if (s.position - last).norm() < MIN_STEP_M => {}
                    last => {
                        arc_m += last.map_or(0.0, |l| (s.position - l).norm());
                        points.push(s.position);
                    }
                }
                Some(arc_m)
            })
            .collect();
        Self { track, path: Polyline::new(points), schedule_m, behind: None }
    }

    /// The nearest road user on the path ahead of arc length `s_m`:
    /// (bumper-to-bumper gap along the path, its speed along the path).
    fn leader(&self, world: &WorldView<'_>, agent: TrackIndex, s_m: f64) -> Option<(f64, f64)> {
        let me = world.body(agent);
        let ahead = self.path.segments_between(s_m, s_m + LOOKAHEAD_M);
        let (here, _) = self.path.sample(s_m)?;
        world
            .states
            .iter()
            .enumerate()
            .filter(|&(j, s)| j != agent.0 && s.is_some_and(|s| (s.position - here).norm() < LOOKAHEAD_M + 10.0))
            .filter_map(|(j, s)| {
                let s = s.as_ref()?;
                let other = world.bodies[j];
                // Its nearest point on the path's segments ahead.
                let on_path = self.path.project_segments(&s.position, ahead.clone())?;
                let in_path = on_path.distance_m < 0.5 * (me.width_m + other.width_m);
                let gap = on_path.arc_length_m - s_m - 0.5 * (me.length_m + other.length_m);
                (in_path && on_path.arc_length_m > s_m).then_some((gap, s.velocity_mps.dot(&on_path.tangent)))
            })
            .min_by(|x, y| x.0.total_cmp(&y.0))
    }
}

impl AgentPolicy for ReactiveLogReplay {
    fn name(&self) -> &'static str {
        "reactive-log-replay"
    }

    fn act(&mut self, world: &WorldView<'_>, agent: TrackIndex) -> AgentAction {
        let next = world.step + 1;
        let Some(logged_next) = self.track.state(next).copied() else {
            self.behind = None;
            return AgentAction::Absent;
        };
        let (Some(scheduled_next), Some(now)) =
            (self.schedule_m.get(next).copied().flatten(), world.state(agent).copied())
        else {
            return AgentAction::Teleport(logged_next);
        };
        if self.path.len() < 2 {
            return AgentAction::Teleport(logged_next);
        }
        let (s, v) = match self.behind {
            Some(b) => b,
            None => match self.schedule_m.get(world.step).copied().flatten() {
                Some(s) => (s, now.speed_mps()),
                None => return AgentAction::Teleport(logged_next),
            },
        };
        let braking = self.leader(world, agent, s).and_then(|(gap, leader_mps)| {
            let wanted = idm_desired_gap_m(
                v,
                v - leader_mps,
                SAFE_GAP_M,
                SAFE_HEADWAY_S,
                IDM_ACCEL_MPS2,
                IDM_COMFORT_DECEL_MPS2,
            );
            (gap < wanted).then(|| (-IDM_ACCEL_MPS2 * (wanted / gap.max(0.1)).powi(2)).max(-MAX_DECEL_MPS2))
        });
        let (v_next, s_next) = match braking {
            Some(a) => {
                let v_next = stepped_speed_mps(v, a, SIM_DT_S);
                (v_next, (s + 0.5 * (v + v_next) * SIM_DT_S).min(scheduled_next))
            }
            None if self.behind.is_none() => return AgentAction::Teleport(logged_next),
            None => {
                let v_next = v + CATCH_UP_ACCEL_MPS2 * SIM_DT_S;
                (v_next, (s + 0.5 * (v + v_next) * SIM_DT_S).min(scheduled_next))
            }
        };
        if s_next >= scheduled_next - 1e-3 {
            // Back on the recording's timing.
            self.behind = None;
            return AgentAction::Teleport(logged_next);
        }
        self.behind = Some((s_next, v_next));
        let Some((position, tangent)) = self.path.sample(s_next) else {
            return AgentAction::Teleport(logged_next);
        };
        AgentAction::Teleport(AgentState {
            position,
            heading_rad: tangent.y.atan2(tangent.x),
            velocity_mps: tangent * v_next,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Vector2;
    use crate::scenario::{AgentBody, AgentId, AgentKind};

    /// A car recorded driving east at 10 m/s along y = 0 for 5 s.
    fn recorded() -> Track {
        Track {
            id: AgentId("follower".into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 1.9,
            states: (0..51)
                .map(|k| {
                    Some(AgentState {
                        position: Point2::new(k as f64, 0.0),
                        heading_rad: 0.0,
                        velocity_mps: Vector2::new(10.0, 0.0),
                    })
                })
                .collect(),
        }
    }

    fn body() -> AgentBody {
        AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 1.9 }
    }

    /// Steps `policy` from step 0 with a stopped car at `blocker` (or none),
    /// returning the follower's states.
    fn run(blocker: Option<Point2>, steps: usize) -> Vec<AgentState> {
        let track = recorded();
        let mut policy = ReactiveLogReplay::new(track.clone());
        let bodies = [body(), body()];
        let mut me = track.states[0].unwrap();
        let mut out = vec![me];
        for step in 0..steps {
            let other = blocker.map(|p| AgentState { position: p, heading_rad: 0.0, velocity_mps: Vector2::zeros() });
            let states = [Some(me), other];
            let map = crate::map::RoadMap::from_lanes(vec![]);
            let world = WorldView { map: &map, step, bodies: &bodies, states: &states };
            match policy.act(&world, TrackIndex(0)) {
                AgentAction::Teleport(s) => me = s,
                other => panic!("{other:?}"),
            }
            out.push(me);
        }
        out
    }

    #[test]
    fn with_nothing_in_the_way_it_is_the_log() {
        let track = recorded();
        let states = run(None, 50);
        for (k, s) in states.iter().enumerate() {
            assert_eq!(Some(*s), track.states[k], "step {k}");
        }
        // A car beside the path is not in the way either.
        let beside = run(Some(Point2::new(30.0, 3.5)), 50);
        assert_eq!(beside, states);
    }

    #[test]
    fn it_stops_behind_a_stopped_car_on_its_path_and_stays_on_the_path() {
        let states = run(Some(Point2::new(30.0, 0.3)), 50);
        let last = states.last().unwrap();
        // Bumper to bumper the gap is 30 - 4.5 - x: it never closes to contact.
        assert!(states.iter().all(|s| 30.0 - s.position.x > 4.5), "{last:?}");
        assert!(last.speed_mps() < 0.5, "{last:?}");
        assert!(states.iter().all(|s| s.position.y == 0.0 && s.heading_rad == 0.0));
        // It braked before it had to: the recording reaches x = 25.5 at step 25.
        assert!(states[20].speed_mps() < 10.0);
    }
}
