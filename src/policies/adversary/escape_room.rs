//! Whether the ego has room to escape the CBV among the traffic around it
//! ([`EscapeRoom`]), for the `pair-in-traffic` feasibility scope (beyond
//! the paper; [`FeasibilityScope`]).
//!
//! V_h is learned on the ego–CBV pair alone. It calls a state escapable
//! when an ego on an open road could brake, speed up or swerve away from
//! the CBV, and it cannot see the car a queued ego stands behind, the
//! recorded car beside it or the road edge: there a CBV closing from behind
//! or from the side makes a collision no ego could avoid, and the witness
//! later finds no escape. With `pair-in-traffic` a state V_h calls
//! escapable (V_h ≤ 0) within [`ESCAPE_CHECK_GAP_M`] of the ego counts as
//! escapable only when one of a few held manoeuvres of the ego (every
//! acceleration of [`ESCAPE_ACCELS_MPS2`], each with a swerve of
//! [`ESCAPE_YAW_RATES_RADPS`] over the first token period) keeps it clear,
//! for [`ESCAPE_HORIZON_S`], of every other agent as the adversary
//! forecasts it, with its centre on the road, and of a CBV that keeps
//! closing in ([`ESCAPE_PURSUIT_MPS2`] towards the ego). Elsewhere it is
//! given [`NO_ROOM_VALUE`]. The check is cruder than the witness (a few
//! manoeuvres over 2 s against its full search over the rollout), so it
//! also turns away some conflicts the witness would have found escapable.

use super::background_forecast::BackgroundForecast;
use crate::geometry::OrientedBox;
use crate::motion::kinematics::turn_bounded_yaw_rate;
use crate::motion::tokens::{MAX_ACCEL_MPS2, SIM_DT_S, TOKEN_PERIOD_STEPS};
use crate::motion::{Action, KinematicState, kinematic_step};
use crate::policies::WorldView;
use crate::scenario::{AgentBody, AgentState, TrackIndex};

/// What the feasibility constraint takes into account.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum FeasibilityScope {
    /// The paper's: V_h of the ego–CBV pair alone.
    #[default]
    Pair,
    /// Beyond the paper: V_h, and within 1.5 m of the ego the room the
    /// traffic around it leaves it to escape (a few held manoeuvres that
    /// keep clear of the traffic, the road's edge and a CBV closing in, for
    /// 2 s).
    PairInTraffic,
    /// Beyond the paper: V_h, and a candidate that leads the CBV within
    /// 1.5 m of the ego (both held on at constant velocity for 2 s) is
    /// taken only where the feasibility witness (the search `safer
    /// evaluate` checks stage-1 collisions with) finds the ego an escape
    /// from the CBV along it, among the traffic and on the road.
    Witnessed,
}

impl FeasibilityScope {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Pair, Self::PairInTraffic, Self::Witnessed];
}

/// How long an escape must keep the ego clear, s.
pub const ESCAPE_HORIZON_S: f64 = 2.0;

/// The box gap to the ego within which a state V_h calls escapable is
/// checked for room, m: farther out the ego has time to find its way.
pub const ESCAPE_CHECK_GAP_M: f64 = 1.5;

/// How hard the CBV closes in on the ego while it escapes, m/s² (half the
/// token grid's acceleration: the CBV keeps coming, not at its utmost).
pub const ESCAPE_PURSUIT_MPS2: f64 = MAX_ACCEL_MPS2 / 2.0;

/// The accelerations an escape holds, m/s² (full braking to full
/// acceleration: an escape from a car closing from behind may need all of it).
pub const ESCAPE_ACCELS_MPS2: [f64; 5] =
    [-MAX_ACCEL_MPS2, -MAX_ACCEL_MPS2 / 2.0, 0.0, MAX_ACCEL_MPS2 / 2.0, MAX_ACCEL_MPS2];

/// The yaw rates an escape swerves at over its first token period, rad/s,
/// bounded by [`MIN_TURN_RADIUS_M`](crate::motion::kinematics::MIN_TURN_RADIUS_M) (a swerve of 0.6 rad/s for 0.5 s moves
/// a car at 10 m/s about a lane aside within the horizon).
pub const ESCAPE_YAW_RATES_RADPS: [f64; 5] = [-0.6, -0.3, 0.0, 0.3, 0.6];

/// The value a state V_h calls escapable is given when the ego has no room
/// to escape it: infeasible, and level with every other such state.
pub const NO_ROOM_VALUE: f32 = 1.0;

/// How far from the ego an agent may be and still be in its way within the
/// horizon, m (two cars at 40 m/s closing head-on for the lookahead's and
/// the escape's 3.5 s, with room to spare).
const NEAR_RADIUS_M: f64 = 300.0;

const ESCAPE_STEPS: usize = (ESCAPE_HORIZON_S / SIM_DT_S + 0.5) as usize;

/// The traffic around the ego over the next seconds, for the room checks
/// of one token boundary: every agent but the ego and the CBV, as the
/// adversary forecasts it.
pub(super) struct EscapeRoom<'a> {
    world: &'a WorldView<'a>,
    ego_body: AgentBody,
    cbv_body: AgentBody,
    /// Each nearby agent's box now (index 0) and at each step ahead.
    traffic: Vec<Vec<Option<OrientedBox>>>,
    /// Whether the ego is on the road now (else its escapes need not be).
    ego_on_road: bool,
}

impl<'a> EscapeRoom<'a> {
    /// The traffic of `world` around `ego` for checks up to `after_steps`
    /// steps ahead (the lookahead's depth).
    pub(super) fn new(
        world: &'a WorldView<'a>,
        (cbv, ego): (TrackIndex, TrackIndex),
        forecast: &BackgroundForecast<'_>,
        after_steps: usize,
    ) -> Self {
        let steps = after_steps + ESCAPE_STEPS;
        let ego_now = world.state(ego).copied();
        let near = |s: &AgentState| ego_now.is_none_or(|e| (s.position - e.position).norm() <= NEAR_RADIUS_M);
        let traffic = (0..world.states.len())
            .filter(|&i| i != ego.0 && i != cbv.0)
            .filter_map(|i| {
                let now = world.state(TrackIndex(i)).filter(|s| near(s))?;
                let body = world.body(TrackIndex(i));
                let (ahead, _) = forecast.states(world, TrackIndex(i), steps);
                let boxes = std::iter::once(Some(body.footprint(now)))
                    .chain(ahead.iter().map(|s| s.as_ref().map(|s| body.footprint(s))))
                    .collect();
                Some(boxes)
            })
            .collect();
        let ego_on_road = ego_now.is_none_or(|e| !world.map.is_off_road_within_map(&e.position));
        Self { world, ego_body: world.body(ego), cbv_body: world.body(cbv), traffic, ego_on_road }
    }

    /// The escapes of the ego from `ego` (where it is `after_steps` steps
    /// ahead) that keep clear of the traffic and on the road: each the
    /// ego's box at every step of the horizon.
    pub(super) fn escapes(&self, ego: &AgentState, after_steps: usize) -> Escapes {
        let start = KinematicState::from_agent_state(ego);
        let mut paths = Vec::new();
        for &accel_mps2 in &ESCAPE_ACCELS_MPS2 {
            for &yaw_rate_radps in &ESCAPE_YAW_RATES_RADPS {
                let mut s = start;
                let mut path = Vec::with_capacity(ESCAPE_STEPS);
                let mut clear = true;
                for k in 1..=ESCAPE_STEPS {
                    let turn =
                        if k <= TOKEN_PERIOD_STEPS { turn_bounded_yaw_rate(yaw_rate_radps, s.speed_mps) } else { 0.0 };
                    s = kinematic_step(&s, Action { accel_mps2, yaw_rate_radps: turn }, SIM_DT_S);
                    let at = s.to_agent_state();
                    let ego_box = self.ego_body.footprint(&at);
                    let off_road = self.ego_on_road
                        && k % TOKEN_PERIOD_STEPS == 0
                        && self.world.map.is_off_road_within_map(&at.position);
                    if off_road || self.hits_traffic(&ego_box, after_steps + k) {
                        clear = false;
                        break;
                    }
                    path.push(ego_box);
                }
                if clear {
                    paths.push(path);
                }
            }
        }
        Escapes { paths, cbv_body: self.cbv_body, ego_at: ego.position }
    }

    /// Whether `ego_box` touches an agent of the traffic at `step` steps ahead.
    fn hits_traffic(&self, ego_box: &OrientedBox, step: usize) -> bool {
        // `intersects` rejects far-apart boxes cheaply before its exact test.
        self.traffic.iter().filter_map(|boxes| boxes.get(step).copied().flatten()).any(|b| ego_box.intersects(&b))
    }
}

/// The ego's escapes that keep clear of the traffic (see [`EscapeRoom::escapes`]).
pub(super) struct Escapes {
    /// Where the ego starts.
    ego_at: crate::geometry::Point2,
    /// The ego's box at each step of each escape.
    paths: Vec<Vec<OrientedBox>>,
    cbv_body: AgentBody,
}

impl Escapes {
    /// Whether one of them also keeps clear of a CBV at `cbv` that closes
    /// in: from its velocity it accelerates at [`ESCAPE_PURSUIT_MPS2`]
    /// towards where the ego starts.
    pub(super) fn clear_of(&self, cbv: &AgentState) -> bool {
        // The CBV's boxes over the horizon, the same for every escape.
        let cbv_boxes: Vec<OrientedBox> =
            closing_in(cbv, &self.ego_at, ESCAPE_STEPS).iter().map(|s| self.cbv_body.footprint(s)).collect();
        self.paths.iter().any(|path| path.iter().zip(&cbv_boxes).all(|(ego_box, cbv_box)| !ego_box.intersects(cbv_box)))
    }
}

/// A CBV at `cbv` closing in on `towards` over the `steps` simulator steps
/// after it: from its velocity it accelerates at [`ESCAPE_PURSUIT_MPS2`]
/// towards that point, keeping its heading (the pursuit both the room
/// check and the `witnessed` scope assume).
pub(super) fn closing_in(cbv: &AgentState, towards: &crate::geometry::Point2, steps: usize) -> Vec<AgentState> {
    let to = towards - cbv.position;
    let pursuit_mps2 = if to.norm() > 0.0 { to / to.norm() * ESCAPE_PURSUIT_MPS2 } else { to };
    (1..=steps)
        .map(|k| {
            let t_s = k as f64 * SIM_DT_S;
            let position = cbv.position + cbv.velocity_mps * t_s + pursuit_mps2 * (0.5 * t_s * t_s);
            AgentState { position, ..*cbv }
        })
        .collect()
}

/// Gives [`NO_ROOM_VALUE`] to each state of `predicted` that `values`
/// calls escapable (V_h ≤ 0), within [`ESCAPE_CHECK_GAP_M`] of the ego at
/// `ego` (`after_steps` steps ahead), from which no escape of `room`
/// keeps clear of the CBV.
pub(super) fn veto_without_room(
    room: &EscapeRoom<'_>,
    values: &mut [f32],
    predicted: &[AgentState],
    ego: &AgentState,
    after_steps: usize,
) {
    let ego_box = room.ego_body.footprint(ego);
    let mut escapes: Option<Escapes> = None;
    for (v, cbv) in values.iter_mut().zip(predicted) {
        if *v > 0.0 || ego_box.distance(&room.cbv_body.footprint(cbv)) > ESCAPE_CHECK_GAP_M {
            continue;
        }
        let escapes = escapes.get_or_insert_with(|| room.escapes(ego, after_steps));
        if !escapes.clear_of(cbv) {
            *v = NO_ROOM_VALUE;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::RoadMap;
    use crate::policies::adversary::test_support::car;
    use crate::scenario::AgentKind;

    /// A stopped ego with the CBV's box 1 m behind its own, closing at
    /// 1 m/s, and `others` around them (at constant velocity), on an open
    /// plane: `states` and V_h = -1 (escapable) of the CBV's state after
    /// the room check.
    fn queue(others: &[Option<AgentState>]) -> (Vec<Option<AgentState>>, f32) {
        let mut states = vec![car(0.0, 0.0, 0.0), car(-5.5, 0.0, 1.0)];
        states.extend_from_slice(others);
        let map = RoadMap::default();
        let bodies = vec![AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; states.len()];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let room = EscapeRoom::new(&world, (TrackIndex(1), TrackIndex(0)), &BackgroundForecast::default(), 0);
        let mut values = [-1.0f32];
        veto_without_room(&room, &mut values, &[states[1].unwrap()], &states[0].unwrap(), 0);
        (states, values[0])
    }

    /// A stopped car 1 m ahead of the ego and cars stopped in the lanes
    /// either side of it.
    const BOXED_IN: [Option<AgentState>; 3] = [
        Some(AgentState {
            position: crate::geometry::Point2::new(5.5, 0.0),
            heading_rad: 0.0,
            velocity_mps: crate::geometry::Vector2::new(0.0, 0.0),
        }),
        Some(AgentState {
            position: crate::geometry::Point2::new(0.0, 3.5),
            heading_rad: 0.0,
            velocity_mps: crate::geometry::Vector2::new(0.0, 0.0),
        }),
        Some(AgentState {
            position: crate::geometry::Point2::new(0.0, -3.5),
            heading_rad: 0.0,
            velocity_mps: crate::geometry::Vector2::new(0.0, 0.0),
        }),
    ];

    #[test]
    fn a_queued_ego_has_no_room_to_escape_a_car_closing_from_behind() {
        // Alone, it drives off ahead of the CBV.
        assert_eq!(queue(&[]).1, -1.0);
        // Boxed in, whatever V_h says.
        assert_eq!(queue(&BOXED_IN).1, NO_ROOM_VALUE);
        // With the car ahead driving off at 10 m/s the ego follows it out.
        let leaving = [car(5.5, 0.0, 10.0), BOXED_IN[1], BOXED_IN[2]];
        assert_eq!(queue(&leaving).1, -1.0);
    }

    #[test]
    fn only_states_v_h_calls_escapable_near_the_ego_are_checked() {
        let (states, _) = queue(&BOXED_IN);
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 5];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let room = EscapeRoom::new(&world, (TrackIndex(1), TrackIndex(0)), &BackgroundForecast::default(), 0);
        let near = states[1].unwrap();
        // 2 m behind the ego's box, beyond the checked gap.
        let far = car(-6.5, 0.0, 1.0).unwrap();
        let mut values = [0.7f32, -1.0, -1.0];
        veto_without_room(&room, &mut values, &[near, near, far], &states[0].unwrap(), 0);
        assert_eq!(values, [0.7, NO_ROOM_VALUE, -1.0]);
    }
}
