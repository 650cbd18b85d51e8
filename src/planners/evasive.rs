//! A sampling-based evasive planner, the competent reference ego for stage 2
//! (the paper uses a learned planner here; this is the transparent
//! stand-in that SR is measured with until one is shipped).
//!
//! Every step it rolls out a lattice of candidates for a few seconds through
//! the kinematic model `K`: each a constant acceleration combined with
//! pure-pursuit tracking of the route at a lateral offset (stay in lane,
//! or swerve half a lane up to two lanes either way, in half-lane steps);
//! the ego steers only as it moves
//! (a car does not turn on the spot). Other agents are predicted at
//! constant velocity and, where they were seen a step earlier, also at
//! the turn rate and acceleration they showed since (a car cutting in or
//! braking is where constant velocity is most wrong), turning no further
//! than the lanes turn and not off the road; a candidate must clear both.
//! A candidate that hits a predicted box (with a safety margin), runs a
//! red light or leaves the road is heavily penalised, one that swerves
//! past a car stopped in the ego's lane without a berth beside it (it may
//! move off into the gap) more than waiting behind it, and one that lets
//! another agent into about a second of headway ahead is penalised
//! softly; among the rest, progress towards the desired speed,
//! staying centred and gentle accelerations win. The first control of the best candidate is
//! applied, and the lattice is rebuilt at the next step.
//!
//! Its route follows the lanes from where the ego is; at a junction it
//! takes the lane of its *mission* (the way the ego's recording went, as a
//! route planner would give it) and the straightest lane where it has none
//! or the mission does not decide.

use super::{Observation, Planner, PlannerError, PlannerOutput};
use crate::geometry::{BoxSet, OrientedBox, Point2, Pose2, Vector2, wrap_angle};
use crate::motion::kinematics::{HeldHeadingStepper, stepped_speed_mps};
use crate::motion::tokens::{MAX_ACCEL_MPS2, MAX_YAW_RATE_RADPS, SIM_DT_S};
use crate::motion::{Action, BUILTIN_MAX_LATERAL_ACCEL_MPS2, KinematicState, kinematic_step_with_sin_cos, within_grip};
use crate::policies::{Route, build_route_along};
use crate::scenario::contact::EgoCollisionKind;
use crate::scenario::{AgentKind, AgentState};

/// Parameters of the evasive planner.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EvasiveParams {
    /// Look-ahead of each candidate, s.
    pub horizon_s: f64,
    /// Accelerations sampled, m/s².
    pub accelerations_mps2: Vec<f64>,
    /// Lateral offsets from the route sampled, m (positive: left).
    pub lateral_offsets_m: Vec<f64>,
    /// Desired speed, m/s; `None`: the lane's limit, else the larger of the
    /// start speed and 10 m/s.
    pub desired_speed_mps: Option<f64>,
    /// Margin added around the ego's box in the collision check, m.
    pub safety_margin_m: f64,
    /// Room kept beside a road user stopped in the ego's lane ahead by a
    /// candidate that swerves (any lateral offset), m, on top of the
    /// safety margin: a car that stopped in the lane (seen moving, now
    /// standing: a queue's last car, a car waiting to turn) may move off
    /// and turn into the gap as the ego squeezes past it on the lane line.
    /// Road users standing since the planner first saw them (parked) or
    /// off the ego's lane are passed at the safety margin alone.
    pub standing_berth_m: f64,
    /// Also predict each agent at the turn rate and acceleration it showed
    /// since the previous step (as well as at constant velocity).
    pub turning_predictions: bool,
    /// Which predicted contacts the planner avoids at any price.
    pub avoided_contacts: AvoidedContacts,
}

impl EvasiveParams {
    /// The first parameter outside its plausible range, with why (for a
    /// planner spec's error): the horizon in (0, 60] s, the margin in
    /// [0, 5] m, a desired speed in (0, 70] m/s, at least one acceleration
    /// (each within the kinematic limit) and one lateral offset (each
    /// within 20 m).
    pub fn implausible_field(&self) -> Option<(&'static str, String)> {
        let within =
            |v: f64, min: f64, max: f64, min_ok: bool| v.is_finite() && (v > min || (min_ok && v == min)) && v <= max;
        if !within(self.horizon_s, 0.0, 60.0, false) {
            return Some(("horizon_s", format!("must be a number in (0, 60] s, got {}", self.horizon_s)));
        }
        if !within(self.safety_margin_m, 0.0, 5.0, true) {
            return Some(("safety_margin_m", format!("must be a number in [0, 5] m, got {}", self.safety_margin_m)));
        }
        if !within(self.standing_berth_m, 0.0, 5.0, true) {
            return Some(("standing_berth_m", format!("must be a number in [0, 5] m, got {}", self.standing_berth_m)));
        }
        if let Some(v) = self.desired_speed_mps
            && !within(v, 0.0, 70.0, false)
        {
            return Some(("desired_speed_mps", format!("must be a number in (0, 70] m/s, got {v}")));
        }
        let lists: [(&'static str, &[f64], f64); 2] = [
            ("accelerations_mps2", &self.accelerations_mps2, MAX_ACCEL_MPS2),
            ("lateral_offsets_m", &self.lateral_offsets_m, 20.0),
        ];
        lists.into_iter().find_map(|(name, values, bound)| {
            if values.is_empty() {
                return Some((name, "must list at least one value".to_string()));
            }
            let bad = values.iter().find(|v| !within(v.abs(), 0.0, bound, true))?;
            Some((name, format!("must hold numbers in [-{bound}, {bound}], got {bad}")))
        })
    }
}

/// Which predicted contacts the evasive planner avoids at any price.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AvoidedContacts {
    /// Every contact: being hit from behind costs as much as hitting
    /// another road user (a planner judged by `no_collision`).
    #[default]
    All,
    /// The contacts the ego could be at fault for, as the
    /// `no_at_fault_collision` criterion judges them (nuPlan's rule). One
    /// from behind or with the ego standing, which that rule never blames
    /// it for, costs at most half a second off the road: worth a swerve
    /// into a free lane or a harder brake, not leaving the road or a
    /// contact it would be to blame for. A side contact still counts as the
    /// ego's (a predicted sideswipe by a car cutting in ends as a front
    /// contact as often as not). A planner judged by `no_at_fault_collision`
    /// that flees a car chasing it from behind trades a contact it is not
    /// blamed for against ones it is.
    AtFault,
}

impl Default for EvasiveParams {
    fn default() -> Self {
        Self {
            horizon_s: 4.0,
            // Up to the kinematic limit either way: the witness search
            // escapes with full acceleration too, and with 3 m/s² at most
            // the planner loses variants the witness shows a way out of (a
            // CBV or a replayed follower closing from behind).
            accelerations_mps2: vec![-MAX_ACCEL_MPS2, -3.0, -1.5, 0.0, 1.0, 2.0, 3.0, MAX_ACCEL_MPS2],
            // Up to two lanes (of 3.5 m) either way: with one lane at most,
            // the planner fails more of the conflicts that the witness
            // search shows a way out of.
            lateral_offsets_m: vec![-7.0, -5.25, -3.5, -1.75, 0.0, 1.75, 3.5, 5.25, 7.0],
            desired_speed_mps: None,
            safety_margin_m: 0.3,
            standing_berth_m: 0.5,
            turning_predictions: true,
            avoided_contacts: AvoidedContacts::All,
        }
    }
}

/// Re-plan the route when less than this remains ahead, m.
/// Tightest path the planner steers, 1/m: a 1.25 m radius, inside the
/// default vehicle limit (1 /m) the harness holds a planner to. Pure
/// pursuit towards a route point close by otherwise asked for turns on the
/// spot at walking pace. A car's own radius (5 m) is tighter than this
/// planner's path following can keep on recorded intersections: capped at
/// 0.2 /m it failed 10 of 540 log-replay variants on the WOMD interactive
/// scenes (SR 1.000 → 0.981).
const MAX_CURVATURE_PER_M: f64 = 0.8;

/// Desired speed on a route without a speed limit, when the ego starts
/// slower than this, m/s.
const FALLBACK_SPEED_MPS: f64 = 10.0;
/// Agents farther than this are not predicted, m.
const PREDICTION_RANGE_M: f64 = 80.0;
/// Slack of the reach filter of the predictions, m: far above the rounding
/// of the positions it bounds, small beside the distances it prunes.
const REACH_SLACK_M: f64 = 0.1;
/// The largest turn rate a turning prediction keeps, rad/s: a lane change
/// turns at about 0.1–0.3 rad/s, a tight urban turn at 0.5; more than this
/// is noise in the heading, not a turn to extrapolate.
const TURNING_PREDICTION_MAX_YAW_RATE_RADPS: f64 = 0.5;
/// The turn rate and acceleration of a turning prediction are measured
/// over this much of the past, s: long enough to average out the noise of
/// recorded headings and speeds, short enough to catch a cut-in starting.
const TURNING_PREDICTION_WINDOW_S: f64 = 0.5;
/// Below this turn rate and acceleration an agent is going straight at a
/// constant speed, and its constant-velocity prediction is enough.
const TURNING_PREDICTION_MIN_YAW_RATE_RADPS: f64 = 0.02;
const TURNING_PREDICTION_MIN_ACCEL_MPS2: f64 = 0.5;
/// Below this speed an agent's turn is not extrapolated, m/s.
const TURNING_PREDICTION_MIN_SPEED_MPS: f64 = 1.0;
/// A turning prediction turns no further than this from the direction of
/// the nearest lane, rad: about the angle of a brisk lane change (a turn
/// through a junction follows its connecting lane and stays well inside).
const TURNING_PREDICTION_MAX_LANE_DEVIATION_RAD: f64 = 0.35;
/// A turning prediction is held to the map once it has turned this far
/// from the agent's heading, rad: a car's width of sideways drift within
/// the 4 s horizon at urban speeds, and beyond what noisy headings give.
const TURNING_PREDICTION_MAP_CHECK_AFTER_RAD: f64 = 0.15;
/// The nearest lane of a turning prediction is searched this far, m.
const TURNING_PREDICTION_LANE_SEARCH_M: f64 = 5.0;
/// A turning prediction ends where it would carry the agent's centre this
/// far past the road's edge, m: about a car's width, no place to drive to
/// (an adversarial CBV near the kerb is still predicted up to it).
const TURNING_PREDICTION_MAX_OFF_ROAD_M: f64 = 2.0;
/// Every this many steps a turning prediction's heading is checked against
/// the nearest lane's: it overshoots the bound by at most
/// [`TURNING_PREDICTION_MAX_YAW_RATE_RADPS`] times this many steps (0.1 rad).
const TURNING_PREDICTION_LANE_CHECK_EVERY: usize = 2;
/// Every this many steps a turning prediction is checked for leaving the road.
const TURNING_PREDICTION_OFF_ROAD_CHECK_EVERY: usize = 5;
/// Every this many steps (0.5 s) a candidate's corners are checked for
/// off-road: at every 10, a swerve could cross a kerb between two checks
/// (plain logs: 38 of 196 rollouts off the road, 31 at every 5).
const OFF_ROAD_CHECK_EVERY: usize = 5;
/// Over this many first steps (1 s) the corners are checked at every step:
/// a kerb's corner that a path clips between two checks lies, at some
/// later plan, within its first second, and the plan is made every step.
const OFF_ROAD_CHECK_EACH_STEP_FIRST: usize = 10;

const COLLISION_COST: f64 = 1.0e4;
/// Per step with another agent inside the headway zone ahead of the ego.
const HEADWAY_COST: f64 = 200.0;
/// The headway zone reaches this many seconds of travel ahead (at least 3 m).
const HEADWAY_S: f64 = 1.0;
const RED_LIGHT_COST: f64 = 5.0e3;
/// For the first predicted contact of a rollout the ego would not be at
/// fault for, under [`AvoidedContacts::AtFault`], scaled as
/// [`COLLISION_COST`] (earlier is worse, up to twice this): at most half a
/// second off the road. The rollout goes on through it.
const BLAMELESS_CONTACT_COST: f64 = 1.0e3;
/// Per 0.5 s (a check every [`OFF_ROAD_CHECK_EVERY`] steps) of a candidate
/// off the road inside the mapped area (driving on past the map's cut is
/// not leaving the road: the ego need not stop there).
const OFF_ROAD_COST: f64 = 2.0e3;
/// For a candidate that swerves past a road user stopped in the ego's
/// lane inside [`EvasiveParams::standing_berth_m`], scaled as [`COLLISION_COST`]
/// (earlier is worse): more than waiting behind a car stopped ahead for
/// the whole horizon, far less than a contact.
const CLOSE_PASS_COST: f64 = 1.0e3;
/// An agent seen faster than this, m/s, has moved: standing later, it
/// stopped in traffic (walking pace and recorded jitter are not moving).
const MOVED_MIN_SPEED_MPS: f64 = 1.0;
/// A road user stands in the ego's lane where its centre is within this
/// of the route's centreline, m: inside a lane of 3 m or more.
const IN_LANE_M: f64 = 1.5;
/// A candidate is dropped once its cost is sure to exceed the best one's by
/// this much: far above the rounding of the sums, far below any term.
const ABANDON_SLACK: f64 = 0.01;

/// The agents the last few plans saw (up to
/// [`TURNING_PREDICTION_WINDOW_S`] back), and when. Each agent is numbered
/// once, at first sight, and each plan's states are kept by number: a
/// plan clones no id and builds no map (with 141 agents a step, the
/// cloned ids and a map of them per plan were 8 % of the plan calls).
#[derive(Debug, Clone, Default)]
struct SeenAgents {
    /// Each id's number. Hashed with foldhash's fixed state: only lookups
    /// are made, so the map's order never matters.
    numbers: std::collections::HashMap<crate::scenario::AgentId, usize, foldhash::fast::FixedState>,
    /// Oldest first: each plan's time and every numbered agent's state
    /// then (`None`: not seen by that plan).
    plans: std::collections::VecDeque<(f64, Vec<Option<AgentState>>)>,
    /// By number: whether the agent was ever seen moving (faster than
    /// [`MOVED_MIN_SPEED_MPS`]) since the first plan.
    moved: Vec<bool>,
}

impl SeenAgents {
    fn clear(&mut self) {
        self.numbers.clear();
        self.plans.clear();
        self.moved.clear();
    }

    /// Whether `id` was seen moving by some plan since the first: a car
    /// that stands now has stopped in traffic, not been parked all along.
    fn has_moved(&self, id: &crate::scenario::AgentId) -> bool {
        self.numbers.get(id).is_some_and(|&number| self.moved.get(number).copied().unwrap_or(false))
    }

    /// When the oldest plan kept that saw `id` was made, and the state it saw.
    fn oldest(&self, id: &crate::scenario::AgentId) -> Option<(f64, &AgentState)> {
        let number = *self.numbers.get(id)?;
        self.plans.iter().find_map(|(t, states)| Some((*t, states.get(number)?.as_ref()?)))
    }

    /// Keeps what a plan at `time_s` saw (of an id given twice, the last
    /// state) and forgets the plans more than
    /// [`TURNING_PREDICTION_WINDOW_S`] before it.
    fn record<'a>(
        &mut self,
        time_s: f64,
        agents: impl IntoIterator<Item = (&'a crate::scenario::AgentId, AgentState)>,
    ) {
        let mut forgotten = None;
        while self.plans.front().is_some_and(|(t, _)| time_s - t > TURNING_PREDICTION_WINDOW_S + 1e-6) {
            forgotten = self.plans.pop_front().map(|(_, states)| states);
        }
        // A forgotten plan's storage is reused.
        let mut states = forgotten.unwrap_or_default();
        states.clear();
        for (id, state) in agents {
            let number = match self.numbers.get(id) {
                Some(&number) => number,
                None => {
                    let next = self.numbers.len();
                    self.numbers.insert(id.clone(), next);
                    next
                }
            };
            if states.len() <= number {
                states.resize(number + 1, None);
            }
            if self.moved.len() <= number {
                self.moved.resize(number + 1, false);
            }
            self.moved[number] |= state.speed_mps() > MOVED_MIN_SPEED_MPS;
            states[number] = Some(state);
        }
        self.plans.push_back((time_s, states));
    }
}

/// The evasive planner.
#[derive(Debug, Clone, Default)]
pub struct EvasivePlanner {
    params: EvasiveParams,
    /// The way the ego is to go: the route takes, at each junction, the
    /// lane these points keep to (empty: the straightest).
    mission: Vec<Point2>,
    route: Option<Route>,
    desired_speed_mps: Option<f64>,
    /// The predictions' storage, kept from one plan to the next (it is
    /// refilled every step; only the allocations are reused).
    predictions: Vec<BoxSet>,
    /// The standing agents' boxes (one set for every step), the same way.
    standing: BoxSet,
    /// Those of them stopped in the ego's lane ahead (seen moving before),
    /// the same way.
    stopped_in_lane: BoxSet,
    /// The agents as seen at the last few plans.
    seen: SeenAgents,
    /// The candidate (offset, acceleration) the last plan chose: tried
    /// first in the next one (see `plan`).
    last_choice: Option<(usize, usize)>,
    /// Every candidate runs to the end in the configured order: the plain
    /// search the pruned one must agree with.
    #[cfg(test)]
    exhaustive: bool,
}

impl EvasivePlanner {
    /// A planner with these parameters.
    pub fn new(params: EvasiveParams) -> Self {
        Self {
            params,
            mission: Vec::new(),
            route: None,
            desired_speed_mps: None,
            predictions: Vec::new(),
            standing: BoxSet::default(),
            stopped_in_lane: BoxSet::default(),
            seen: Default::default(),
            last_choice: None,
            #[cfg(test)]
            exhaustive: false,
        }
    }

    /// The same planner with a mission: the points of the way the ego is to
    /// go (its recording, in a recorded scene), which pick the lane at each
    /// junction of its route ([`crate::map::lane_followed`]).
    pub fn with_mission(mut self, mission: Vec<Point2>) -> Self {
        self.mission = mission;
        self
    }

    /// A planner with these parameters for the ego `ego` of `scenario`,
    /// whose mission is the way the recorded ego went.
    pub fn for_recorded_ego(
        params: EvasiveParams,
        scenario: &crate::scenario::Scenario,
        ego: crate::scenario::TrackIndex,
    ) -> Self {
        let mission = scenario.track(ego).states.iter().flatten().map(|s| s.position).collect();
        Self::new(params).with_mission(mission)
    }

    /// The turn rate (rad/s) and acceleration (m/s²) `agent` showed over
    /// the window (since the oldest plan kept that saw it), when either is
    /// worth extrapolating.
    fn observed_turning(&self, now_s: f64, agent: &crate::planners::PerceivedAgent) -> Option<Action> {
        let (then_s, before) = self.seen.oldest(&agent.id)?;
        let dt_s = now_s - then_s;
        // Not seen before now (or a NaN clock): nothing to measure.
        if dt_s.is_nan() || dt_s <= 0.0 {
            return None;
        }
        let yaw_rate_radps = (wrap_angle(agent.state.heading_rad - before.heading_rad) / dt_s)
            .clamp(-TURNING_PREDICTION_MAX_YAW_RATE_RADPS, TURNING_PREDICTION_MAX_YAW_RATE_RADPS);
        let accel_mps2 = ((agent.state.speed_mps() - before.speed_mps()) / dt_s).clamp(-MAX_ACCEL_MPS2, MAX_ACCEL_MPS2);
        // A car turns only as it moves: the heading of one that stands (or
        // creeps) is noise, and held it would spin the box on the spot.
        let yaw_rate_radps =
            if agent.state.speed_mps() < TURNING_PREDICTION_MIN_SPEED_MPS { 0.0 } else { yaw_rate_radps };
        let worth = yaw_rate_radps.abs() >= TURNING_PREDICTION_MIN_YAW_RATE_RADPS
            || accel_mps2.abs() >= TURNING_PREDICTION_MIN_ACCEL_MPS2;
        (worth && yaw_rate_radps.is_finite() && accel_mps2.is_finite()).then_some(Action { accel_mps2, yaw_rate_radps })
    }
}

/// A turning prediction's states, each with its heading's `sin_cos()`.
type TurningPrediction = Vec<(KinematicState, (f64, f64))>;

/// The states of a turning prediction over `steps` steps (fewer where it
/// ends): the agent holds the turn rate and acceleration it showed, as far
/// as the road allows. Held regardless of the map, a turn seen in noisy
/// headings sweeps a box across lanes and kerbs where no driver goes, and
/// the ego swerves off the road or brakes for it. So once the prediction
/// has turned [`TURNING_PREDICTION_MAP_CHECK_AFTER_RAD`] away from the
/// agent's heading (less, and it stays near the constant-velocity one,
/// which is not held to the map either), the turn stops (the heading is
/// then held) where it has carried the agent more than
/// [`TURNING_PREDICTION_MAX_LANE_DEVIATION_RAD`] off the direction of the
/// nearest lane and would carry it further, and the prediction ends where
/// it would take the agent more than [`TURNING_PREDICTION_MAX_OFF_ROAD_M`]
/// past the road's edge (the constant-velocity prediction still covers
/// the agent there).
fn road_bounded_turn(
    map: &crate::map::RoadMap,
    start: &AgentState,
    mut action: Action,
    steps: usize,
) -> TurningPrediction {
    let mut s = KinematicState::from_agent_state(start);
    let mut states = Vec::with_capacity(steps);
    // The heading's sine and cosine, computed again only when it changes
    // (most predictions hold it for most steps): the step and the box set
    // both need them, and they were a fifth of an evaluation.
    let mut stepper = HeldHeadingStepper::default();
    for k in 0..steps {
        let (next, sin_cos) = stepper.step(&s, action, SIM_DT_S);
        s = next;
        let turned = wrap_angle(s.heading_rad - start.heading_rad).abs() > TURNING_PREDICTION_MAP_CHECK_AFTER_RAD;
        if turned && action.yaw_rate_radps != 0.0 && k % TURNING_PREDICTION_LANE_CHECK_EVERY == 0 {
            let lane = map.nearest_lane(&s.position, Some(s.heading_rad), TURNING_PREDICTION_LANE_SEARCH_M);
            let deviation_rad = lane.map(|lane| {
                let tangent = lane.projection.tangent;
                wrap_angle(s.heading_rad - tangent.y.atan2(tangent.x))
            });
            if deviation_rad.is_some_and(|d| {
                d.abs() > TURNING_PREDICTION_MAX_LANE_DEVIATION_RAD && d.signum() == action.yaw_rate_radps.signum()
            }) {
                action.yaw_rate_radps = 0.0;
            }
        }
        if turned
            && k % TURNING_PREDICTION_OFF_ROAD_CHECK_EVERY == 0
            && map.is_beyond_road_edge(&s.position, TURNING_PREDICTION_MAX_OFF_ROAD_M)
        {
            break;
        }
        states.push((s, sin_cos));
    }
    states
}

/// Whether a corner of the ego's body (without the safety margin) in state
/// `s` is off the road inside the mapped area: the verdict judges the
/// body's corners, so a centre on the road with a wheel over the kerb is
/// already off it.
fn body_leaves_the_road(obs: &Observation<'_>, s: &KinematicState) -> bool {
    let body =
        OrientedBox::new(Pose2 { position: s.position, heading_rad: s.heading_rad }, obs.ego_length_m, obs.ego_width_m);
    obs.map.any_off_road_within_map(&body.corners())
}

/// Whether a box of bounding radius `radius_m` centred at `position` is
/// within `reach_m` of the ego's position: the one test both the per-step
/// sets and the standing set filter their boxes by.
fn within_reach(position: crate::geometry::Point2, ego: &AgentState, reach_m: f64, radius_m: f64) -> bool {
    (position - ego.position).norm_squared() <= (reach_m + radius_m).powi(2)
}

/// The acceleration a candidate of acceleration `accel` applies at
/// `speed_mps`: it accelerates only up to the desired speed `v_des`.
fn applied_accel_mps2(accel: f64, speed_mps: f64, v_des: f64) -> f64 {
    if accel > 0.0 && speed_mps >= v_des { 0.0 } else { accel }
}

/// A step's speed term of a candidate's cost at `speed_mps`.
fn speed_cost(speed_mps: f64, v_des: f64) -> f64 {
    0.01 * (speed_mps - v_des).powi(2)
}

/// The speed terms of a candidate's cost (`0.01·(v − v_des)²` a step)
/// from each step to the horizon, for a candidate of acceleration `accel`
/// starting at `start_speed_mps`: its speeds follow from these alone, as
/// [`EvasivePlanner::evaluate`] steps them. Each is capped at
/// [`RED_LIGHT_COST`], the least that a rollout stopping early (at a
/// collision or a red light) adds instead of the rest, so that each stays
/// a lower bound on what is still to come. `steps + 1` values, the last 0.
fn speed_costs_to_come(start_speed_mps: f64, accel: f64, v_des: f64, steps: usize) -> Vec<f64> {
    let mut speed_mps = start_speed_mps;
    let mut terms = Vec::with_capacity(steps + 1);
    for _ in 0..steps {
        let a = applied_accel_mps2(accel, speed_mps, v_des);
        speed_mps = stepped_speed_mps(speed_mps, a, SIM_DT_S);
        terms.push(speed_cost(speed_mps, v_des));
    }
    terms.push(0.0);
    let mut to_come = 0.0;
    for t in terms.iter_mut().rev() {
        to_come += *t;
        *t = to_come.min(RED_LIGHT_COST);
    }
    terms
}

/// One candidate's rollout and its cost.
struct Candidate {
    first: Action,
    cost: f64,
}

impl Planner for EvasivePlanner {
    fn name(&self) -> &str {
        "evasive"
    }

    fn plan(&mut self, obs: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        let ego = obs.ego;
        let v_des = self.follow_the_route(obs)?;
        let route = self.route.as_ref().ok_or_else(|| PlannerError::InvalidOutput("no route".into()))?;
        // Bounded for any horizon (an infinite one would never finish): 10 minutes at most.
        let steps = (self.params.horizon_s / SIM_DT_S).round().clamp(1.0, 6000.0) as usize;

        // Constant-velocity predictions of everyone within range, one box
        // set per step (`predictions[k]`: after k + 1 steps). A box that no
        // candidate's ego box or headway zone can reach by then is left out
        // of that step's set: it could not touch either, so every answer
        // stays the same. An agent that stands (a velocity of exactly zero:
        // most of a car park) has the same box at every step, so those
        // boxes go into one set for the whole horizon (`standing`) instead
        // of into every step's: the sets are only asked whether any box
        // touches, and that answer is the same for the union.
        let near: Vec<_> = obs
            .agents
            .iter()
            .filter(|a| (a.state.position - ego.position).norm() < PREDICTION_RANGE_M)
            .map(|a| (a, a.state.heading_rad.sin_cos(), 0.5 * a.length_m.hypot(a.width_m)))
            .collect();
        // The turning predictions: each near agent's states over the
        // horizon at the turn rate and acceleration it showed.
        if obs.time_s == 0.0 {
            self.seen.clear();
        }
        let turning: Vec<(usize, TurningPrediction)> = if self.params.turning_predictions {
            near.iter()
                .enumerate()
                .filter_map(|(i, (a, _, _))| Some((i, self.observed_turning(obs.time_s, a)?, a)))
                .map(|(i, action, a)| (i, road_bounded_turn(obs.map, &a.state, action, steps)))
                .collect()
        } else {
            Vec::new()
        };
        self.seen.record(obs.time_s, obs.agents.iter().map(|a| (&a.id, a.state)));
        let start_speed_mps = KinematicState::from_agent_state(&ego).speed_mps;
        let max_accel_mps2 = self.params.accelerations_mps2.iter().copied().fold(0.0, f64::max);
        let (len, wid) = self.checked_extent_m(obs);
        // No candidate drives faster than this: one accelerates only while
        // below the desired speed (see `evaluate`), so it passes it by at
        // most one step's acceleration (none for a NaN desired speed).
        let speed_cap_mps =
            if v_des.is_nan() { f64::INFINITY } else { start_speed_mps.max(v_des + max_accel_mps2 * SIM_DT_S) };
        // A bound on every candidate's speed and distance travelled after
        // k steps: `max_travel_m`'s, step by step, with the speed held to
        // the cap (on a busy road it halves the reach at the horizon, and
        // with it the boxes each set holds).
        let mut predictions = std::mem::take(&mut self.predictions);
        let reach = CandidateReach { start_speed_mps, max_accel_mps2, speed_cap_mps, extent_m: (len, wid) };
        let horizon_reach_m = reach.fill_predictions(&mut predictions, &ego, (&near, &turning), steps);
        let mut standing = std::mem::take(&mut self.standing);
        standing.refill_with_sin_cos(
            near.iter()
                .filter(|&&(a, _, radius_m)| {
                    stands(a) && within_reach(a.state.position, &ego, horizon_reach_m, radius_m)
                })
                .map(|&(a, sin_cos, _)| (OrientedBox::new(a.state.pose(), a.length_m, a.width_m), sin_cos)),
        );
        let here_projection = route.path.project(&ego.position);
        let here = here_projection.map_or(0.0, |p| p.arc_length_m);
        let mut stopped_in_lane = std::mem::take(&mut self.stopped_in_lane);
        stopped_in_lane.refill_with_sin_cos(
            near.iter()
                .filter(|&&(a, _, radius_m)| {
                    stands(a)
                        && self.seen.has_moved(&a.id)
                        && within_reach(a.state.position, &ego, horizon_reach_m, radius_m)
                        && route
                            .path
                            .project(&a.state.position)
                            .is_some_and(|p| p.distance_m <= IN_LANE_M && p.arc_length_m > here)
                })
                .map(|&(a, sin_cos, _)| (OrientedBox::new(a.state.pose(), a.length_m, a.width_m), sin_cos)),
        );
        let red_stop_s = first_red_stop_s(obs, route, here);

        let ctx = PlanContext {
            obs,
            route,
            near: &near,
            turning: &turning,
            predictions: &predictions,
            standing: &standing,
            stopped_in_lane: &stopped_in_lane,
            red_stop_s,
            start_s: here,
            start_segment: here_projection.map_or(0, |p| p.segment),
            v_des,
            steps,
            max_progress_m: route.path.length_m() - here,
            speed_costs_to_come: self
                .params
                .accelerations_mps2
                .iter()
                .map(|&accel| speed_costs_to_come(start_speed_mps, accel, v_des, steps))
                .collect(),
        };
        let best = self.cheapest(&ctx);
        let n_accels = self.params.accelerations_mps2.len();
        self.last_choice = best.as_ref().map(|(_, i)| (i / n_accels, i % n_accels));
        self.predictions = predictions;
        self.standing = standing;
        self.stopped_in_lane = stopped_in_lane;
        let (best, _) = best.ok_or_else(|| PlannerError::InvalidOutput("no candidates configured".into()))?;
        Ok(PlannerOutput::Control(best.first))
    }
}

impl EvasivePlanner {
    /// Builds the route at the start and whenever the ego has left it, and
    /// settles the desired speed at the start: the speed the plans aim for.
    fn follow_the_route(&mut self, obs: &Observation<'_>) -> Result<f64, PlannerError> {
        let ego = obs.ego;
        let rebuild = Route::needs_rebuild(self.route.as_ref(), &ego.position);
        if obs.time_s == 0.0 || rebuild {
            if obs.time_s == 0.0 {
                self.desired_speed_mps = None;
            }
            let mission = &self.mission;
            let mut at_junction = |_: &crate::map::Lane, next: &[&crate::map::Lane]| {
                crate::map::lane_followed(next, mission).unwrap_or(0)
            };
            self.route = Some(build_route_along(obs.map, &ego, AgentKind::Vehicle, mission, &mut at_junction));
        }
        let route = self.route.as_ref().ok_or_else(|| PlannerError::InvalidOutput("no route".into()))?;
        Ok(*self.desired_speed_mps.get_or_insert_with(|| {
            route.desired_speed_mps(obs.map, self.params.desired_speed_mps, ego.speed_mps(), FALLBACK_SPEED_MPS)
        }))
    }

    /// The cheapest candidate of the plan `ctx` and its index (offset, then
    /// acceleration, in the configured order); `None` with no candidate
    /// configured.
    fn cheapest(&self, ctx: &PlanContext<'_>) -> Option<(Candidate, usize)> {
        let (obs, ego) = (ctx.obs, &ctx.obs.ego);
        // The best candidate is the cheapest, ties to the first in the
        // configured order (offsets, then accelerations). Trying the
        // smallest offsets first finds a cheap candidate early, and a later
        // one is dropped as soon as even its best possible ending costs more
        // (see `evaluate`): it could not have won. With anything non-finite
        // about, where costs may be NaN and the order matters, every
        // candidate runs to the end in the configured order, as a plain loop.
        let n_accels = self.params.accelerations_mps2.len();
        let finite = [ctx.v_des, ctx.start_s, ctx.max_progress_m, ego.position.x, ego.position.y, ego.heading_rad]
            .iter()
            .chain(&[ego.velocity_mps.x, ego.velocity_mps.y, obs.ego_length_m, obs.ego_width_m])
            .chain(&self.params.accelerations_mps2)
            .chain(&self.params.lateral_offsets_m)
            .all(|x| x.is_finite());
        #[cfg(test)]
        let finite = finite && !self.exhaustive;
        let mut offsets: Vec<usize> = (0..self.params.lateral_offsets_m.len()).collect();
        if finite {
            offsets.sort_by(|&a, &b| {
                self.params.lateral_offsets_m[a].abs().total_cmp(&self.params.lateral_offsets_m[b].abs())
            });
        }
        let mut order: Vec<(usize, usize)> = offsets.iter().flat_map(|&o| (0..n_accels).map(move |a| (o, a))).collect();
        // The last plan's choice first: the traffic has moved a tenth of a
        // second, and it is most often the best again or close to it, so
        // the candidates after it are dropped early. Only the time spent
        // depends on the order: a dropped candidate is one that could not
        // have won or tied, whatever came before it.
        if finite
            && obs.time_s != 0.0
            && let Some(at) = self.last_choice.and_then(|c| order.iter().position(|&o| o == c))
        {
            order[..=at].rotate_right(1);
        }
        let mut best: Option<(Candidate, usize)> = None;
        for (o, a) in order {
            let offset = self.params.lateral_offsets_m[o];
            let index = o * n_accels + a;
            let abandon_above = best.as_ref().filter(|_| finite).map_or(f64::INFINITY, |(b, _)| b.cost + ABANDON_SLACK);
            let Some(c) = self.evaluate(ctx, a, offset, abandon_above) else { continue };
            let better = best.as_ref().is_none_or(|(b, i)| c.cost < b.cost || (c.cost == b.cost && index < *i));
            if better {
                best = Some((c, index));
            }
        }
        best
    }
}

/// Whether `a` stands: a velocity of exactly zero (most of a car park).
fn stands(a: &crate::planners::PerceivedAgent) -> bool {
    a.state.velocity_mps.x == 0.0 && a.state.velocity_mps.y == 0.0
}

/// The first red stop line ahead of the ego (at arc length `here`) on
/// `route`, as an arc length.
fn first_red_stop_s(obs: &Observation<'_>, route: &Route, here: f64) -> Option<f64> {
    route
        .lanes
        .iter()
        .filter(|(lane, _, end)| {
            *end > here + 0.5 * obs.ego_length_m
                && obs.map.signal_state(*lane, obs.step).is_some_and(|s| s.requires_stop())
        })
        .map(|(_, _, end)| *end)
        .next()
}

/// How far any candidate of one plan can reach, step by step: the bound
/// that leaves out of each step's predictions the boxes no candidate's
/// ego box or headway zone could touch.
struct CandidateReach {
    start_speed_mps: f64,
    /// The largest configured acceleration, m/s².
    max_accel_mps2: f64,
    /// No candidate drives faster than this, m/s.
    speed_cap_mps: f64,
    /// The checked ego's length and width, m.
    extent_m: (f64, f64),
}

impl CandidateReach {
    /// Fills `predictions` (one box set a step, `steps` of them) with the
    /// moving agents of `near` at constant velocity and along `turning`,
    /// each where a candidate of the ego at `ego` could reach it by then;
    /// returns the reach at the horizon, the largest (it grows step by
    /// step): a standing box beyond it is beyond every step's.
    fn fill_predictions(
        &self,
        predictions: &mut Vec<BoxSet>,
        ego: &AgentState,
        (near, turning): (&[NearAgent<'_>], &[(usize, TurningPrediction)]),
        steps: usize,
    ) -> f64 {
        let (len, wid) = self.extent_m;
        let ego_radius_m = 0.5 * len.hypot(wid);
        let (mut speed_bound_mps, mut travel_m) = (self.start_speed_mps.max(0.0), 0.0);
        predictions.resize_with(steps, BoxSet::default);
        let mut horizon_reach_m = f64::NAN;
        for (set, k) in predictions.iter_mut().zip(1..) {
            let t = k as f64 * SIM_DT_S;
            speed_bound_mps = (speed_bound_mps + self.max_accel_mps2 * SIM_DT_S).min(self.speed_cap_mps);
            travel_m += speed_bound_mps * SIM_DT_S;
            let headway_m = (HEADWAY_S * speed_bound_mps).max(3.0);
            let zone_reach_m = 0.5 * (len + headway_m) + 0.5 * headway_m.hypot(wid);
            let reach_m = travel_m + ego_radius_m.max(zone_reach_m) + REACH_SLACK_M;
            horizon_reach_m = reach_m;
            let reachable =
                |position: crate::geometry::Point2, radius_m: f64| within_reach(position, ego, reach_m, radius_m);
            let constant_velocity = near.iter().filter(|(a, _, _)| !stands(a)).filter_map(|&(a, sin_cos, radius_m)| {
                let position = a.state.position + a.state.velocity_mps * t;
                let pose = Pose2 { position, heading_rad: a.state.heading_rad };
                reachable(position, radius_m).then(|| (OrientedBox::new(pose, a.length_m, a.width_m), sin_cos))
            });
            let turning_boxes = turning.iter().filter_map(|(i, states)| {
                let (a, _, radius_m) = near[*i];
                // A prediction that left the road has ended.
                let (at, sin_cos) = *states.get(k - 1)?;
                let pose = Pose2 { position: at.position, heading_rad: at.heading_rad };
                reachable(at.position, radius_m).then(|| (OrientedBox::new(pose, a.length_m, a.width_m), sin_cos))
            });
            set.refill_with_sin_cos(constant_velocity.chain(turning_boxes));
        }
        horizon_reach_m
    }
}

/// An agent within prediction range of the ego, with its heading's
/// `sin_cos()` and its bounding circle's radius, m.
type NearAgent<'a> = (&'a crate::planners::PerceivedAgent, (f64, f64), f64);

/// What every candidate of one plan shares.
struct PlanContext<'a> {
    obs: &'a Observation<'a>,
    route: &'a Route,
    /// The agents predicted: each with its heading's `sin_cos()` and its
    /// bounding circle's radius, m.
    near: &'a [NearAgent<'a>],
    /// The turning predictions, each of the agent `near[i]`.
    turning: &'a [(usize, TurningPrediction)],
    /// `predictions[k]`: the moving agents after k + 1 steps (boxes of
    /// `near`, at constant velocity and along `turning`).
    predictions: &'a [BoxSet],
    /// The standing agents, at every step.
    standing: &'a BoxSet,
    /// Those of them stopped in the ego's lane ahead (seen moving before).
    stopped_in_lane: &'a BoxSet,
    /// The first red stop line ahead on the route, as an arc length.
    red_stop_s: Option<f64>,
    /// The ego's arc length on the route at the start.
    start_s: f64,
    /// The route's segment nearest to the ego at the start.
    start_segment: usize,
    /// Desired speed, m/s.
    v_des: f64,
    /// Steps per candidate.
    steps: usize,
    /// The most progress along the route a candidate can be credited with
    /// (to the route's end), m.
    max_progress_m: f64,
    /// For each configured acceleration, the speed terms of the cost
    /// still to come before each step (see [`speed_costs_to_come`]).
    speed_costs_to_come: Vec<Vec<f64>>,
}

/// A rollout's contact with the predictions at one step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PredictedContact {
    /// Only with agents it already passed through blamelessly.
    None,
    /// Only contacts the ego would not be at fault for.
    Blameless,
    /// Some contact the ego would be at fault for.
    AtFault,
}

impl PlanContext<'_> {
    /// The contact of the ego in state `s` (heading `sin_cos`, checked box
    /// `ego_box`) after `k + 1` steps with the predicted agents other than
    /// those of `passed` (indices into `near`). Blameless where each touch
    /// is from behind the ego or with it standing (the contacts nuPlan's
    /// rule never blames it for; the agents are then added to `passed`, so
    /// that a car running on through the ego is not blamed on it later); a
    /// side contact counts as the ego's, the cautious reading, since a
    /// predicted sideswipe by a car cutting in ends as a front contact as
    /// often as not. Only asked once a rollout touches the predictions, so
    /// it looks at every agent again instead of keeping their states beside
    /// the boxes.
    fn judge_contact(
        &self,
        k: usize,
        s: &KinematicState,
        sin_cos: (f64, f64),
        ego_box: &OrientedBox,
        passed: &mut Vec<usize>,
    ) -> PredictedContact {
        let t = (k + 1) as f64 * SIM_DT_S;
        let ego = s.to_agent_state_with_sin_cos(sin_cos);
        // A standing agent's constant-velocity state is its state now.
        let at_constant_velocity = self.near.iter().enumerate().map(|(i, &(a, _, _))| {
            (i, AgentState { position: a.state.position + a.state.velocity_mps * t, ..a.state })
        });
        let turning = self.turning.iter().filter_map(|(i, states)| {
            states.get(k).map(|(at, sin_cos)| (*i, at.to_agent_state_with_sin_cos(*sin_cos)))
        });
        let mut touched = Vec::new();
        for (i, other) in at_constant_velocity.chain(turning) {
            let agent = self.near[i].0;
            if passed.contains(&i) || !OrientedBox::new(other.pose(), agent.length_m, agent.width_m).intersects(ego_box)
            {
                continue;
            }
            if !matches!(
                EgoCollisionKind::classify(&ego, &other),
                EgoCollisionKind::ActiveRear | EgoCollisionKind::StoppedEgo
            ) {
                return PredictedContact::AtFault;
            }
            touched.push(i);
        }
        if touched.is_empty() {
            return PredictedContact::None;
        }
        passed.extend(touched);
        PredictedContact::Blameless
    }
}

impl EvasivePlanner {
    /// Length and width of the ego's box in the collision check (with the
    /// safety margin), m.
    fn checked_extent_m(&self, obs: &Observation<'_>) -> (f64, f64) {
        (obs.ego_length_m + 2.0 * self.params.safety_margin_m, obs.ego_width_m + 2.0 * self.params.safety_margin_m)
    }

    /// The candidate with acceleration `accel_index` (of the configured
    /// ones) and this lateral offset, or `None` once its cost is sure to end
    /// above `abandon_above`: every term added along the way is
    /// non-negative, the speed terms still to come are known in advance
    /// (a candidate's speeds do not depend on its path; a rollout that
    /// stops early adds more than they could), and the progress credit at
    /// the end is at most `max_progress_m`, so the running cost plus those
    /// bounds the final cost from below.
    fn evaluate(
        &self,
        ctx: &PlanContext<'_>,
        accel_index: usize,
        offset: f64,
        abandon_above: f64,
    ) -> Option<Candidate> {
        let obs = ctx.obs;
        let route = ctx.route;
        let (start_s, v_des, steps) = (ctx.start_s, ctx.v_des, ctx.steps);
        let accel = self.params.accelerations_mps2[accel_index];
        let speed_costs_to_come = &ctx.speed_costs_to_come[accel_index];
        // Swerving is a last resort: a full lane costs about as much as a second in the headway zone.
        let choice_cost = 10.0 * offset * offset + 0.5 * accel * accel;
        let least_to_come = choice_cost - 0.5 * ctx.max_progress_m;
        let mut s = KinematicState::from_agent_state(&obs.ego);
        let (len, wid) = self.checked_extent_m(obs);
        let mut cost = 0.0;
        let mut first = None;
        let mut travelled_s = start_s;
        // Each step's projection starts from the last one's segment.
        let mut segment = ctx.start_segment;
        // The agents passed through blamelessly (see `judge_contact`): the
        // first such contact is charged, while none is passed yet.
        let mut passed = Vec::new();
        // Whether a close pass of a road user stopped in the ego's lane is
        // still to be looked for: only a swerve keeps the berth, and it is
        // charged once a rollout.
        let berth_m = self.params.standing_berth_m;
        let mut berth_unbroken = offset != 0.0 && berth_m > 0.0 && !ctx.stopped_in_lane.is_empty();
        for (k, others) in ctx.predictions.iter().enumerate().take(steps) {
            if cost + least_to_come + speed_costs_to_come[k] > abandon_above {
                return None;
            }
            // Pure pursuit towards the route point ahead, shifted sideways by `offset`.
            let proj = route.path.project_near(&s.position, segment);
            segment = proj.map_or(segment, |p| p.segment);
            let s_here = proj.map_or(travelled_s, |p| p.arc_length_m);
            travelled_s = s_here;
            let lookahead = (0.8 * s.speed_mps).max(5.0);
            let a = applied_accel_mps2(accel, s.speed_mps, v_des);
            // Pure pursuit's yaw rate at the speed the step ends with: none
            // at a standstill, where a car cannot turn.
            let moving_mps = stepped_speed_mps(s.speed_mps, a, SIM_DT_S);
            let yaw_rate = match route.path.sample(s_here + lookahead) {
                Some((p, t)) => {
                    let target = p + Vector2::new(-t.y, t.x) * offset;
                    let to = target - s.position;
                    let alpha = wrap_angle(to.y.atan2(to.x) - s.heading_rad);
                    let curvature_per_m =
                        (2.0 * alpha.sin() / to.norm().max(1e-3)).clamp(-MAX_CURVATURE_PER_M, MAX_CURVATURE_PER_M);
                    let yaw_rate = (curvature_per_m * moving_mps).clamp(-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS);
                    within_grip(yaw_rate, s.speed_mps, moving_mps, BUILTIN_MAX_LATERAL_ACCEL_MPS2)
                }
                None => 0.0,
            };
            let action = Action { accel_mps2: a, yaw_rate_radps: yaw_rate };
            first.get_or_insert(action);
            let (next, sin_cos) = kinematic_step_with_sin_cos(&s, action, SIM_DT_S);
            s = next;
            let ego_box = OrientedBox::new(Pose2 { position: s.position, heading_rad: s.heading_rad }, len, wid);
            let touches = |b: &OrientedBox| {
                others.any_intersects_with_sin_cos(b, sin_cos) || ctx.standing.any_intersects_with_sin_cos(b, sin_cos)
            };
            let earlier = 2.0 - k as f64 / steps as f64;
            if berth_unbroken {
                let pose = Pose2 { position: s.position, heading_rad: s.heading_rad };
                let berth_box = OrientedBox::new(pose, len, wid + 2.0 * berth_m);
                if ctx.stopped_in_lane.any_intersects_with_sin_cos(&berth_box, sin_cos) {
                    berth_unbroken = false;
                    cost += CLOSE_PASS_COST * earlier;
                }
            }
            if touches(&ego_box) {
                let first_blameless = passed.is_empty();
                let contact = match self.params.avoided_contacts {
                    AvoidedContacts::All => PredictedContact::AtFault,
                    AvoidedContacts::AtFault => ctx.judge_contact(k, &s, sin_cos, &ego_box, &mut passed),
                };
                // Earlier contacts are worse; one the ego is to blame for
                // dominates every other term and ends the rollout. The
                // first blameless one is charged, and the rollout goes on
                // through it: a contact the ego is to blame for may follow.
                match contact {
                    PredictedContact::AtFault => {
                        cost += COLLISION_COST * earlier;
                        break;
                    }
                    PredictedContact::Blameless if first_blameless => cost += BLAMELESS_CONTACT_COST * earlier,
                    PredictedContact::Blameless | PredictedContact::None => {}
                }
            }
            // Soft: keep about a second of headway to whatever is ahead.
            let headway_m = (HEADWAY_S * s.speed_mps).max(3.0);
            let forward = Vector2::new(sin_cos.1, sin_cos.0);
            let zone = OrientedBox::new(
                Pose2 { position: s.position + forward * (0.5 * (len + headway_m)), heading_rad: s.heading_rad },
                headway_m,
                wid,
            );
            if touches(&zone) {
                cost += HEADWAY_COST;
            }
            if let Some(stop) = ctx.red_stop_s
                && s_here + 0.5 * obs.ego_length_m > stop
            {
                cost += RED_LIGHT_COST;
                break;
            }
            // Each check is charged for the steps it stands for: leaving the
            // road costs as much a second however finely it is looked for.
            let steps_checked = if k < OFF_ROAD_CHECK_EACH_STEP_FIRST {
                1
            } else if k % OFF_ROAD_CHECK_EVERY == OFF_ROAD_CHECK_EVERY - 1 {
                OFF_ROAD_CHECK_EVERY.min(k + 1 - OFF_ROAD_CHECK_EACH_STEP_FIRST)
            } else {
                0
            };
            if steps_checked > 0 && body_leaves_the_road(obs, &s) {
                cost += OFF_ROAD_COST * steps_checked as f64 / OFF_ROAD_CHECK_EVERY as f64;
            }
            cost += speed_cost(s.speed_mps, v_des);
        }
        cost -= 0.5 * (travelled_s - start_s);
        cost += choice_cost;
        Some(Candidate { first: first.unwrap_or_default(), cost })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Polyline};
    use crate::map::{Lane, MapElementId, RoadMap};
    use crate::motion::kinematic_step;
    use crate::planners::PerceivedAgent;
    use crate::scenario::{AgentId, AgentState};

    /// The ego's first control at 0.1 s with a car 12 m ahead in the lane
    /// to its left, both at 10 m/s, that has begun to turn towards the
    /// ego's lane at 0.2 rad/s (heading 0 at 0 s, -0.02 rad at 0.1 s).
    fn control_beside_a_car_cutting_in(turning_predictions: bool) -> Action {
        let lane = Lane::new(MapElementId(1), Polyline::new(vec![Point2::new(-50.0, 0.0), Point2::new(500.0, 0.0)]));
        let map = RoadMap::new(vec![lane], vec![], vec![], vec![], vec![], vec![], vec![]);
        let mut planner = EvasivePlanner::new(EvasiveParams { turning_predictions, ..EvasiveParams::default() });
        let mut output = None;
        for (k, heading_rad) in [0.0f64, -0.02].into_iter().enumerate() {
            let t = k as f64 * SIM_DT_S;
            let ego = AgentState {
                position: Point2::new(10.0 * t, 0.0),
                heading_rad: 0.0,
                velocity_mps: Vector2::new(10.0, 0.0),
            };
            let car = PerceivedAgent {
                id: AgentId("cutting-in".into()),
                kind: AgentKind::Vehicle,
                length_m: 4.5,
                width_m: 2.0,
                state: AgentState {
                    position: Point2::new(12.0 + 10.0 * t, 3.5),
                    heading_rad,
                    velocity_mps: Vector2::new(heading_rad.cos(), heading_rad.sin()) * 10.0,
                },
            };
            let obs = Observation {
                step: k,
                time_s: t,
                dt_s: SIM_DT_S,
                ego,
                ego_length_m: 4.5,
                ego_width_m: 2.0,
                agents: vec![car],
                ..Observation::new(&map, ego)
            };
            output = Some(planner.plan(&obs).unwrap());
        }
        match output {
            Some(PlannerOutput::Control(a)) => a,
            other => panic!("{other:?}"),
        }
    }

    /// A wall of cars, one in each of the lanes at `lanes_y_m`, 4.5 m long
    /// and 2 m wide, heading along +x at `speed_mps` (negative: the other
    /// way) with their centres at `x_m`.
    fn wall(lanes_y_m: &[f64], x_m: f64, speed_mps: f64) -> Vec<PerceivedAgent> {
        let heading_rad = if speed_mps < 0.0 { std::f64::consts::PI } else { 0.0 };
        lanes_y_m
            .iter()
            .map(|&y| PerceivedAgent {
                id: AgentId(format!("wall-{y}")),
                kind: AgentKind::Vehicle,
                length_m: 4.5,
                width_m: 2.0,
                state: AgentState {
                    position: Point2::new(x_m, y),
                    heading_rad,
                    velocity_mps: Vector2::new(speed_mps, 0.0),
                },
            })
            .collect()
    }

    /// The ego's state at the origin, heading along +x at `speed_mps`.
    fn at_the_origin(speed_mps: f64) -> KinematicState {
        KinematicState::from_agent_state(&AgentState {
            position: Point2::new(0.0, 0.0),
            heading_rad: 0.0,
            velocity_mps: Vector2::new(speed_mps, 0.0),
        })
    }

    /// What the planner sees at step `k`: the ego (4.5 m by 2 m) at `ego`
    /// among `agents` on `map`, no signals.
    fn observation_at<'m>(
        k: usize,
        ego: &KinematicState,
        agents: Vec<PerceivedAgent>,
        map: &'m RoadMap,
    ) -> Observation<'m> {
        Observation {
            step: k,
            time_s: k as f64 * SIM_DT_S,
            dt_s: SIM_DT_S,
            ego: ego.to_agent_state(),
            ego_length_m: 4.5,
            ego_width_m: 2.0,
            agents,
            signals: vec![],
            ..Observation::new(map, ego.to_agent_state())
        }
    }

    /// A car (4.5 m by 2 m) at (`x`, `y`) heading `heading_rad` at `speed_mps`.
    fn car(id: &str, x: f64, y: f64, heading_rad: f64, speed_mps: f64) -> PerceivedAgent {
        PerceivedAgent {
            id: AgentId(id.into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            state: AgentState {
                position: Point2::new(x, y),
                heading_rad,
                velocity_mps: Vector2::new(heading_rad.cos(), heading_rad.sin()) * speed_mps,
            },
        }
    }

    /// A straight road along +x from -50 to 400 m: lanes at `lanes_y_m`
    /// (ids from 1, in order) and a kerb on each side (the next ids).
    fn kerbed_road(lanes_y_m: &[f64], right_kerb_y_m: f64, left_kerb_y_m: f64) -> RoadMap {
        use crate::map::{RoadEdge, RoadEdgeKind};
        let line = |y: f64, from: f64, to: f64| Polyline::new(vec![Point2::new(from, y), Point2::new(to, y)]);
        let lanes: Vec<Lane> = lanes_y_m
            .iter()
            .enumerate()
            .map(|(i, &y)| Lane::new(MapElementId(i as i64 + 1), line(y, -50.0, 400.0)))
            .collect();
        let kerb = |k: i64, polyline| RoadEdge {
            id: MapElementId(lanes_y_m.len() as i64 + k),
            polyline,
            kind: RoadEdgeKind::Boundary,
        };
        let kerbs = vec![kerb(1, line(right_kerb_y_m, -50.0, 400.0)), kerb(2, line(left_kerb_y_m, 400.0, -50.0))];
        RoadMap::new(lanes, kerbs, vec![], vec![], vec![], vec![], vec![])
    }

    /// Closed loop for 8 s: the ego (4.5 m by 2 m) from the origin at
    /// `speed_mps` along a lane on +x, the others `traffic(t)` at time t.
    /// Whether the ego touches one of them.
    fn ego_is_hit(params: EvasiveParams, speed_mps: f64, traffic: impl Fn(f64) -> Vec<PerceivedAgent>) -> bool {
        let lane = Lane::new(MapElementId(1), Polyline::new(vec![Point2::new(-50.0, 0.0), Point2::new(500.0, 0.0)]));
        let map = RoadMap::new(vec![lane], vec![], vec![], vec![], vec![], vec![], vec![]);
        let mut planner = EvasivePlanner::new(params);
        let mut ego = at_the_origin(speed_mps);
        for k in 0..80 {
            let t = k as f64 * SIM_DT_S;
            let cars = traffic(t);
            let ego_box = OrientedBox::new(Pose2 { position: ego.position, heading_rad: ego.heading_rad }, 4.5, 2.0);
            if cars.iter().any(|c| ego_box.intersects(&OrientedBox::new(c.state.pose(), 4.5, 2.0))) {
                return true;
            }
            let obs = observation_at(k, &ego, cars, &map);
            let PlannerOutput::Control(action) = planner.plan(&obs).unwrap() else { panic!("not a control") };
            ego = kinematic_step(&ego, action, SIM_DT_S);
        }
        false
    }

    /// The ego at 10 m/s and a wall of three cars coming the other way at
    /// 8 m/s, 60 m ahead, in its lane and the lanes either side.
    fn ego_hits_an_oncoming_wall(params: EvasiveParams) -> bool {
        ego_is_hit(params, 10.0, |t| wall(&[-3.5, 0.0, 3.5], 60.0 - 8.0 * t, -8.0))
    }

    #[test]
    fn the_pruned_search_chooses_what_running_every_candidate_to_the_end_chooses() {
        // Busy traffic on a three-lane road with kerbs, some of it turning
        // and braking: the pruned search (last choice first, candidates
        // dropped on their cost bound) and the plain one must give the same
        // control at every step, to the bit.
        let map = kerbed_road(&[0.0, 3.5, -3.5], -5.5, 5.5);
        let traffic = |t: f64| {
            vec![
                // Braking ahead in the ego's lane.
                car("lead", 25.0 + 8.0 * t - 1.0 * t * t, 0.0, 0.0, (8.0 - 2.0 * t).max(0.0)),
                // Cutting in from the left.
                car("cut-in", 15.0 + 11.0 * t, 3.5 - 0.6 * t, -0.05 * t, 11.0),
                // Closing fast from behind on the right, and one oncoming.
                car("behind", -20.0 + 16.0 * t, -3.5, 0.0, 16.0),
                car("oncoming", 120.0 - 9.0 * t, 3.5, std::f64::consts::PI, 9.0),
                // Standing at the kerb.
                car("parked", 60.0, -4.5, 0.0, 0.0),
            ]
        };
        // Starting slower, at and faster than it wants to go, so the speed
        // terms of the bound weigh differently.
        // Either way of weighing a contact from behind (the car closing on
        // the right is one).
        let mut choices = std::collections::BTreeSet::new();
        let starts = [(3.0, 15.0), (10.0, 10.0), (18.0, 8.0), (6.0, 25.0)];
        let runs = [AvoidedContacts::All, AvoidedContacts::AtFault].into_iter().flat_map(|a| starts.map(|s| (a, s)));
        for (avoided_contacts, (start_mps, desired_mps)) in runs {
            let params =
                EvasiveParams { desired_speed_mps: Some(desired_mps), avoided_contacts, ..EvasiveParams::default() };
            let mut pruned = EvasivePlanner::new(params.clone());
            let mut plain = EvasivePlanner { exhaustive: true, ..EvasivePlanner::new(params) };
            let mut ego = at_the_origin(start_mps);
            for k in 0..50 {
                let obs = observation_at(k, &ego, traffic(k as f64 * SIM_DT_S), &map);
                let (PlannerOutput::Control(a), PlannerOutput::Control(b)) =
                    (pruned.plan(&obs).unwrap(), plain.plan(&obs).unwrap())
                else {
                    panic!("not a control")
                };
                assert_eq!(
                    (a.accel_mps2.to_bits(), a.yaw_rate_radps.to_bits()),
                    (b.accel_mps2.to_bits(), b.yaw_rate_radps.to_bits()),
                    "{avoided_contacts:?}, from {start_mps} m/s wanting {desired_mps}, step {k}: {a:?} against {b:?}"
                );
                choices.insert(pruned.last_choice);
                ego = kinematic_step(&ego, a, SIM_DT_S);
            }
        }
        // The scene makes the planner change its mind, or it shows little.
        assert!(choices.len() >= 5, "{choices:?}");
    }

    #[test]
    fn a_swerve_keeps_the_whole_body_on_the_road_not_only_its_centre() {
        // Two lanes (y = 0 and 3.5) with the right kerb 1.9 m from the ego's
        // lane centre: a swerve of half a lane to the right keeps the
        // centre on the road (0.15 m inside) and puts the right-hand corners
        // 0.85 m over the kerb. A car stands astride the lane line ahead and
        // another drives beside the ego on the left: passing on the right
        // is the way past, and a planner that checks its centre alone
        // takes it.
        let map = kerbed_road(&[0.0, 3.5], -1.9, 5.4);
        let mut planner = EvasivePlanner::new(EvasiveParams::default());
        let mut ego = at_the_origin(10.0);
        let mut farthest_over_m = f64::NEG_INFINITY;
        for k in 0..60 {
            let t = k as f64 * SIM_DT_S;
            let cars = vec![car("standing", 30.0, 1.0, 0.0, 0.0), car("beside", 1.0 + 10.0 * t, 3.5, 0.0, 10.0)];
            let body = OrientedBox::new(Pose2 { position: ego.position, heading_rad: ego.heading_rad }, 4.5, 2.0);
            assert!(!cars.iter().any(|c| body.intersects(&OrientedBox::new(c.state.pose(), 4.5, 2.0))), "hit at {t} s");
            for c in body.corners() {
                farthest_over_m = farthest_over_m.max(map.signed_distance_to_road_edge(&c).expect("edges"));
            }
            let obs = observation_at(k, &ego, cars, &map);
            let PlannerOutput::Control(action) = planner.plan(&obs).unwrap() else { panic!("not a control") };
            ego = kinematic_step(&ego, action, SIM_DT_S);
        }
        assert!(farthest_over_m <= 0.0, "a corner went {farthest_over_m:.2} m over the kerb");
    }

    #[test]
    fn a_swerve_of_two_lanes_escapes_an_oncoming_wall_that_one_lane_does_not() {
        assert!(!ego_hits_an_oncoming_wall(EvasiveParams::default()));
        let one_lane =
            EvasiveParams { lateral_offsets_m: vec![-3.5, -1.75, 0.0, 1.75, 3.5], ..EvasiveParams::default() };
        assert!(ego_hits_an_oncoming_wall(one_lane));
    }

    #[test]
    fn full_acceleration_escapes_a_wall_closing_from_behind_that_three_metres_per_second_squared_does_not() {
        // The ego at 8 m/s with a wall across all five lanes a swerve could
        // reach closing from behind at 14 m/s, 5 m bumper to bumper: the gap
        // shrinks by 6²/(2a) m before the ego matches the wall's speed, 6 m
        // at 3 m/s² (too much), 3.6 m at 5 m/s². The desired speed is above
        // the wall's so that the ego may run from it.
        let hit = |accelerations_mps2: Vec<f64>| {
            let params =
                EvasiveParams { accelerations_mps2, desired_speed_mps: Some(20.0), ..EvasiveParams::default() };
            ego_is_hit(params, 8.0, |t| wall(&[-7.0, -3.5, 0.0, 3.5, 7.0], -9.5 + 14.0 * t, 14.0))
        };
        assert!(!hit(EvasiveParams::default().accelerations_mps2));
        assert!(hit(vec![-MAX_ACCEL_MPS2, -3.0, -1.5, 0.0, 1.0, 2.0, 3.0]));
    }

    /// Closed loop for 6 s on a one-lane road with kerbs 2.5 m either side
    /// of the lane's centre: the ego from the origin at 8 m/s, wanting 8,
    /// and a car 30 m behind in its lane closing at 20 m/s, faster than
    /// the ego can run from it. Whether the car hits the ego, and how far
    /// past a kerb any corner of the ego went, m.
    fn chased_on_a_one_lane_road(avoided_contacts: AvoidedContacts) -> (bool, f64) {
        let map = kerbed_road(&[0.0], -2.5, 2.5);
        let params = EvasiveParams { avoided_contacts, desired_speed_mps: Some(8.0), ..EvasiveParams::default() };
        let mut planner = EvasivePlanner::new(params);
        let mut ego = at_the_origin(8.0);
        let mut farthest_over_m = f64::NEG_INFINITY;
        for k in 0..60 {
            let chaser = car("chaser", -30.0 + 20.0 * k as f64 * SIM_DT_S, 0.0, 0.0, 20.0);
            let body = OrientedBox::new(Pose2 { position: ego.position, heading_rad: ego.heading_rad }, 4.5, 2.0);
            if body.intersects(&OrientedBox::new(chaser.state.pose(), 4.5, 2.0)) {
                return (true, farthest_over_m);
            }
            for c in body.corners() {
                farthest_over_m = farthest_over_m.max(map.signed_distance_to_road_edge(&c).expect("edges"));
            }
            let obs = observation_at(k, &ego, vec![chaser], &map);
            let PlannerOutput::Control(action) = planner.plan(&obs).unwrap() else { panic!("not a control") };
            ego = kinematic_step(&ego, action, SIM_DT_S);
        }
        (false, farthest_over_m)
    }

    #[test]
    fn a_planner_avoiding_only_at_fault_contacts_keeps_the_road_when_chased_from_behind() {
        // Avoiding every contact, the only way out is over the kerb.
        let (hit, over_m) = chased_on_a_one_lane_road(AvoidedContacts::All);
        assert!(!hit && over_m > 0.5, "avoiding every contact: hit {hit}, {over_m:.2} m over the kerb");
        // Being hit from behind is not the ego's fault: not worth leaving the road for.
        let (hit, over_m) = chased_on_a_one_lane_road(AvoidedContacts::AtFault);
        assert!(hit && over_m <= 0.0, "avoiding at-fault contacts: hit {hit}, {over_m:.2} m over the kerb");
    }

    #[test]
    fn a_planner_avoiding_only_at_fault_contacts_still_escapes_what_it_would_hit() {
        let at_fault = EvasiveParams { avoided_contacts: AvoidedContacts::AtFault, ..EvasiveParams::default() };
        assert!(!ego_hits_an_oncoming_wall(at_fault.clone()));
        // On a one-lane road with kerbs, a leader 20 m ahead brakes to a
        // stop at 5 m/s² and a blind follower 8 m behind drives on at
        // 10 m/s: the ego brakes short of the leader and takes the contact
        // from behind, which is not its fault, rather than run into the
        // leader or over a kerb.
        let map = kerbed_road(&[0.0], -2.5, 2.5);
        let mut planner = EvasivePlanner::new(EvasiveParams { desired_speed_mps: Some(10.0), ..at_fault });
        let mut ego = at_the_origin(10.0);
        for k in 0..60 {
            let t = k as f64 * SIM_DT_S;
            let braking_s = t.min(2.0);
            let lead =
                car("lead", 20.0 + 10.0 * braking_s - 2.5 * braking_s * braking_s, 0.0, 0.0, 10.0 - 5.0 * braking_s);
            let follower = car("follower", -8.0 + 10.0 * t, 0.0, 0.0, 10.0);
            let body = OrientedBox::new(Pose2 { position: ego.position, heading_rad: ego.heading_rad }, 4.5, 2.0);
            assert!(
                !body.intersects(&OrientedBox::new(lead.state.pose(), 4.5, 2.0)),
                "ran into the leader at {t:.1} s"
            );
            assert!(body.corners().iter().all(|c| map.signed_distance_to_road_edge(c).expect("edges") <= 0.0));
            if body.intersects(&OrientedBox::new(follower.state.pose(), 4.5, 2.0)) {
                return;
            }
            let obs = observation_at(k, &ego, vec![lead, follower], &map);
            let PlannerOutput::Control(action) = planner.plan(&obs).unwrap() else { panic!("not a control") };
            ego = kinematic_step(&ego, action, SIM_DT_S);
        }
        panic!("the follower never reached the ego: the scene tests nothing");
    }

    /// Closed loop for 8 s on a two-lane road (lanes at y = 0 and 3.5 m,
    /// kerbs 1.75 m beyond them): the ego from the origin at 3 m/s, wanting
    /// 12, and a car in its lane, 0.6 m right of the lane's centre (room to
    /// squeeze past on the lane line), standing 25 m ahead; if
    /// `stopped_in_traffic`, it drove there at 4 m/s and braked to a stop
    /// over the first 2 s, else it stood there all along (parked). The
    /// ego's smallest sideways gap to it while beside it (their lengths
    /// overlapping), m; `None` if it never came beside it.
    fn gap_passing_a_standing_car(params: EvasiveParams, stopped_in_traffic: bool) -> Option<f64> {
        let map = kerbed_road(&[0.0, 3.5], -1.75, 5.25);
        let mut planner = EvasivePlanner::new(EvasiveParams { desired_speed_mps: Some(12.0), ..params });
        let mut ego = at_the_origin(3.0);
        let mut gap_m: Option<f64> = None;
        for k in 0..80 {
            let braking_s = if stopped_in_traffic { (2.0 - k as f64 * SIM_DT_S).max(0.0) } else { 0.0 };
            // At 4 m/s braking at 2 m/s², `braking_s` before it stands.
            let other = car("other", 25.0 - braking_s * braking_s, -0.6, 0.0, 2.0 * braking_s);
            if (ego.position.x - other.state.position.x).abs() < 4.5 {
                let gap = (ego.position.y - other.state.position.y).abs() - 2.0;
                gap_m = Some(gap_m.map_or(gap, |g| g.min(gap)));
            }
            let obs = observation_at(k, &ego, vec![other], &map);
            let PlannerOutput::Control(action) = planner.plan(&obs).unwrap() else { panic!("not a control") };
            ego = kinematic_step(&ego, action, SIM_DT_S);
        }
        gap_m
    }

    #[test]
    fn a_swerve_past_a_car_stopped_in_the_lane_keeps_the_berth_or_does_not_pass() {
        let without_berth = EvasiveParams { standing_berth_m: 0.0, ..EvasiveParams::default() };
        let params = EvasiveParams::default();
        let room_m = params.safety_margin_m + params.standing_berth_m;
        // Without the berth the ego squeezes past on the lane line, within
        // a metre of a car that may move off into it.
        let squeezed = gap_passing_a_standing_car(without_berth, true);
        assert!(squeezed.is_some_and(|g| g < room_m), "without the berth: {squeezed:?}");
        // With it, the ego keeps the safety margin and the berth beside it
        // (a whole lane over), or stays behind.
        let gap = gap_passing_a_standing_car(params.clone(), true);
        assert!(gap.is_none_or(|g| g >= room_m), "with the berth: {gap:?}, wanted {room_m} m or no pass");
        // A car standing there all along (parked) is passed as before.
        let parked = gap_passing_a_standing_car(params, false);
        assert!(parked.is_some_and(|g| g < room_m), "past a parked car: {parked:?}");
    }

    #[test]
    fn a_planner_spec_gives_the_evasive_planner_its_parameters_and_refuses_implausible_ones() {
        let params: EvasiveParams = serde_saphyr::from_str("avoided_contacts: at-fault").unwrap();
        assert_eq!(params, EvasiveParams { avoided_contacts: AvoidedContacts::AtFault, ..EvasiveParams::default() });
        assert_eq!(EvasiveParams::default().implausible_field(), None);
        let bad = |p: EvasiveParams| p.implausible_field().map(|(field, _)| field);
        assert_eq!(bad(EvasiveParams { horizon_s: 0.0, ..EvasiveParams::default() }), Some("horizon_s"));
        assert_eq!(
            bad(EvasiveParams { lateral_offsets_m: vec![], ..EvasiveParams::default() }),
            Some("lateral_offsets_m")
        );
        assert_eq!(
            bad(EvasiveParams { accelerations_mps2: vec![f64::NAN], ..EvasiveParams::default() }),
            Some("accelerations_mps2")
        );
        for berth_m in [-0.5, f64::NAN, 6.0] {
            assert_eq!(
                bad(EvasiveParams { standing_berth_m: berth_m, ..EvasiveParams::default() }),
                Some("standing_berth_m")
            );
        }
        let berth: EvasiveParams = serde_saphyr::from_str("standing_berth_m: 0").unwrap();
        assert_eq!(berth, EvasiveParams { standing_berth_m: 0.0, ..EvasiveParams::default() });
    }

    #[test]
    fn a_car_turning_into_the_lane_is_predicted_where_its_turn_takes_it() {
        // At constant velocity the car drifts 0.2 m/s sideways and stays
        // clear of the ego's lane for the 4 s horizon: no reason to brake.
        let straight = control_beside_a_car_cutting_in(false);
        assert!(straight.accel_mps2 >= 0.0, "{straight:?}");
        // Held, its turn brings it into the ego's lane ahead within 2 s.
        let turning = control_beside_a_car_cutting_in(true);
        assert!(turning.accel_mps2 < 0.0, "{turning:?}");
    }

    #[test]
    fn a_turning_prediction_turns_no_further_than_the_lanes_and_ends_off_the_road() {
        use crate::map::{RoadEdge, RoadEdgeKind};
        // A straight road along +x, its edges 4 m either side of the lane.
        let lane = Lane::new(MapElementId(1), Polyline::new(vec![Point2::new(-50.0, 0.0), Point2::new(500.0, 0.0)]));
        let edge = |id, y: f64, from: f64, to: f64| RoadEdge {
            id: MapElementId(id),
            polyline: Polyline::new(vec![Point2::new(from, y), Point2::new(to, y)]),
            kind: RoadEdgeKind::Boundary,
        };
        let map = RoadMap::new(
            vec![lane],
            vec![edge(2, -4.0, -50.0, 500.0), edge(3, 4.0, 500.0, -50.0)],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
        );
        let start =
            AgentState { position: Point2::new(0.0, 0.0), heading_rad: 0.0, velocity_mps: Vector2::new(10.0, 0.0) };
        let turn = Action { accel_mps2: 0.0, yaw_rate_radps: 0.5 };
        let states: Vec<_> = road_bounded_turn(&map, &start, turn, 40).into_iter().map(|(s, _)| s).collect();
        // Held for 4 s the turn would reach 2 rad; along the lane it stops
        // within a lane check (0.1 rad) of the deviation bound.
        let max_heading = states.iter().map(|s| s.heading_rad).fold(f64::MIN, f64::max);
        assert!(max_heading > TURNING_PREDICTION_MAX_LANE_DEVIATION_RAD, "{max_heading}");
        assert!(max_heading <= TURNING_PREDICTION_MAX_LANE_DEVIATION_RAD + 0.1 + 1e-9, "{max_heading}");
        // Crossing the edge at y = 4 it ends, within a check of the bound.
        assert!(states.len() < 40, "{}", states.len());
        let last_y = states.last().unwrap().position.y;
        assert!(last_y <= 4.0 + TURNING_PREDICTION_MAX_OFF_ROAD_M + 0.5 * 10.0 * 0.35f64.sin(), "{last_y}");
        // Without a map the turn is held all the way.
        let free = road_bounded_turn(&RoadMap::default(), &start, turn, 40);
        assert_eq!(free.len(), 40);
        assert!((free[39].0.heading_rad - 2.0).abs() < 1e-9, "{}", free[39].0.heading_rad);
    }

    #[test]
    fn a_turning_prediction_steps_exactly_as_the_kinematic_model_with_its_headings_trigonometry() {
        // The rollout caches the heading's sine and cosine; every state and
        // every cached pair must be what the model and `sin_cos` give, to
        // the bit, whether the heading turns, is held, or is held after a turn.
        let start =
            AgentState { position: Point2::new(3.0, -2.0), heading_rad: 3.1, velocity_mps: Vector2::new(-7.0, 0.3) };
        for action in [
            Action { accel_mps2: -2.0, yaw_rate_radps: 0.0 },
            Action { accel_mps2: 1.0, yaw_rate_radps: 0.3 },
            Action { accel_mps2: 0.0, yaw_rate_radps: -0.45 },
        ] {
            let rollout = road_bounded_turn(&RoadMap::default(), &start, action, 40);
            assert_eq!(rollout.len(), 40);
            let mut s = KinematicState::from_agent_state(&start);
            for (at, (sin, cos)) in rollout {
                s = kinematic_step(&s, action, SIM_DT_S);
                assert_eq!(at, s, "{action:?}");
                assert_eq!(
                    (sin.to_bits(), cos.to_bits()),
                    (s.heading_rad.sin().to_bits(), s.heading_rad.cos().to_bits())
                );
            }
        }
    }

    #[test]
    fn the_agents_seen_are_remembered_as_a_map_of_each_plan_would_remember_them() {
        // Against the plain record (one map of ids per plan, the plans
        // within the window kept): agents come, go, come back and are
        // given twice; the plans are 0.1 s apart, the window 0.5 s.
        type Plain = std::collections::VecDeque<(f64, std::collections::HashMap<AgentId, AgentState>)>;
        let (mut seen, mut plain) = (SeenAgents::default(), Plain::new());
        let state =
            |x: f64| AgentState { position: Point2::new(x, 0.0), heading_rad: 0.0, velocity_mps: Vector2::zeros() };
        let ids: Vec<AgentId> = (0..7).map(|i| AgentId(format!("a{i}"))).collect();
        for plan in 0..40 {
            let time_s = plan as f64 * 0.1;
            // Agent i is seen in the plans where (plan + i) % (i + 2) != 0;
            // agent 3 twice, the second state the one that counts.
            let agents: Vec<(&AgentId, AgentState)> = ids
                .iter()
                .enumerate()
                .filter(|(i, _)| (plan + i) % (i + 2) != 0 && (*i != 6 || plan > 20))
                .flat_map(|(i, id)| {
                    let twice = if i == 3 { vec![(id, state(-1.0))] } else { vec![] };
                    twice.into_iter().chain([(id, state(plan as f64 * 10.0 + i as f64))])
                })
                .collect();
            for id in &ids {
                let plain_oldest =
                    plain.iter().find_map(|(t, m): &(f64, std::collections::HashMap<_, _>)| Some((*t, m.get(id)?)));
                assert_eq!(seen.oldest(id), plain_oldest, "{id} before plan {plan}");
            }
            seen.record(time_s, agents.iter().copied());
            plain.push_back((time_s, agents.iter().map(|(id, s)| ((*id).clone(), *s)).collect()));
            while plain.front().is_some_and(|(t, _)| time_s - t > TURNING_PREDICTION_WINDOW_S + 1e-6) {
                plain.pop_front();
            }
            assert_eq!(seen.plans.len(), plain.len());
        }
    }

    #[test]
    fn a_standing_agent_is_not_predicted_to_turn() {
        let mut planner = EvasivePlanner::new(EvasiveParams::default());
        let seen = |heading_rad: f64, speed_mps: f64| AgentState {
            position: Point2::new(0.0, 0.0),
            heading_rad,
            velocity_mps: Vector2::new(heading_rad.cos(), heading_rad.sin()) * speed_mps,
        };
        let agent = |state| PerceivedAgent {
            id: AgentId("parked".into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            state,
        };
        // Its heading jumped 0.1 rad in 0.5 s: a turn at 0.2 rad/s if it moves.
        let parked = AgentId("parked".into());
        planner.seen.record(0.0, [(&parked, seen(0.0, 0.5))]);
        assert_eq!(planner.observed_turning(0.5, &agent(seen(0.1, 0.5))), None);
        planner.seen.clear();
        planner.seen.record(0.0, [(&parked, seen(0.0, 5.0))]);
        let moving = planner.observed_turning(0.5, &agent(seen(0.1, 5.0))).unwrap();
        assert!((moving.yaw_rate_radps - 0.2).abs() < 1e-9, "{moving:?}");
    }

    /// The observation at a rollout's start of a 4.5 m × 2 m ego among `agents`.
    fn first_observation(ego: AgentState, agents: Vec<PerceivedAgent>, map: &RoadMap) -> Observation<'_> {
        Observation {
            step: 0,
            time_s: 0.0,
            dt_s: SIM_DT_S,
            ego,
            ego_length_m: 4.5,
            ego_width_m: 2.0,
            agents,
            ..Observation::new(map, ego)
        }
    }

    #[test]
    fn a_stopped_ego_that_does_not_move_off_does_not_turn_on_the_spot() {
        // The lane runs along +x; the ego stands at 0.3 rad to it with a
        // stopped car 1 m ahead of its bumper: every way forward collides,
        // so it holds still, and a car that holds still cannot steer.
        let lane = Lane::new(MapElementId(1), Polyline::new(vec![Point2::new(-50.0, 0.0), Point2::new(500.0, 0.0)]));
        let map = RoadMap::new(vec![lane], vec![], vec![], vec![], vec![], vec![], vec![]);
        let ego = AgentState { position: Point2::new(0.0, 0.0), heading_rad: 0.3, velocity_mps: Vector2::zeros() };
        let ahead = ego.position + Vector2::new(0.3f64.cos(), 0.3f64.sin()) * 5.5;
        let blocker = PerceivedAgent {
            id: AgentId("blocker".into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            state: AgentState { position: ahead, heading_rad: 0.3, velocity_mps: Vector2::zeros() },
        };
        let obs = first_observation(ego, vec![blocker], &map);
        let mut planner = EvasivePlanner::new(EvasiveParams::default());
        match planner.plan(&obs).unwrap() {
            PlannerOutput::Control(a) => {
                assert!(a.accel_mps2 <= 0.0, "{a:?}");
                assert_eq!(a.yaw_rate_radps, 0.0, "{a:?}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn at_a_fork_the_route_takes_the_missions_lane_and_the_straightest_without_one() {
        // Lane 1 runs east to a fork at (50, 0): lane 2 straight on, lane 3
        // turning right (south) on a 20 m radius.
        let line = |pts: Vec<Point2>| Polyline::new(pts);
        let turn: Vec<Point2> = (0..=20)
            .map(|i| std::f64::consts::FRAC_PI_2 * i as f64 / 20.0)
            .map(|a| Point2::new(50.0 + 20.0 * a.sin(), -20.0 * (1.0 - a.cos())))
            .chain([Point2::new(70.0, -200.0)])
            .collect();
        let mut lanes = vec![
            Lane::new(MapElementId(1), line(vec![Point2::new(-50.0, 0.0), Point2::new(50.0, 0.0)])),
            Lane::new(MapElementId(2), line(vec![Point2::new(50.0, 0.0), Point2::new(300.0, 0.0)])),
            Lane::new(MapElementId(3), line(turn.clone())),
        ];
        // The recorded ego went right: points every metre along lane 1, then the turn.
        let mut mission: Vec<Point2> = (-10..=50).map(|x| Point2::new(x as f64, 0.0)).collect();
        let turning = Polyline::new(turn);
        mission.extend((0..40).filter_map(|d| turning.sample(d as f64).map(|(p, _)| p)));
        let ego =
            AgentState { position: Point2::new(0.0, 0.0), heading_rad: 0.0, velocity_mps: Vector2::new(10.0, 0.0) };
        let route_lanes = |map: &RoadMap, mut planner: EvasivePlanner| {
            planner.plan(&first_observation(ego, vec![], map)).unwrap();
            planner.route.unwrap().lanes.iter().map(|(id, _, _)| id.0).collect::<Vec<_>>()
        };
        // A source without lane connectivity (GPUDrive's WOMD JSON): the
        // lanes starting where lane 1 ends follow it all the same.
        let unconnected = RoadMap::new(lanes.clone(), vec![], vec![], vec![], vec![], vec![], vec![]);
        lanes[0].successors = vec![MapElementId(2), MapElementId(3)];
        let connected = RoadMap::new(lanes, vec![], vec![], vec![], vec![], vec![], vec![]);
        for map in [&connected, &unconnected] {
            assert_eq!(route_lanes(map, EvasivePlanner::new(EvasiveParams::default())), vec![1, 2]);
            let planner = EvasivePlanner::new(EvasiveParams::default()).with_mission(mission.clone());
            assert_eq!(route_lanes(map, planner), vec![1, 3]);
        }
    }
}
