//! The closed-loop feasibility witness: evidence that a stage-2 collision
//! was avoidable when the CBV *reacts* to the ego.
//!
//! The fixed-traffic witness ([`super::witness`]) searches an ego path
//! against the other agents as they drove. Once the CBV is driven closed
//! loop, that proves nothing: a different ego would have met a different
//! CBV. So an escape here is only accepted after it was *played*: the
//! whole stage-2 rollout is run again, every agent driven as it was (the
//! CBV by the same deterministic, seeded policy, the background by its
//! policy), with the ego following the candidate path; the collision was
//! avoidable exactly when that rollout ends without an ego collision.
//!
//! Candidates come from the fixed-traffic search, by best response: the
//! first against the realised rollout (the *pre-check*: it proves only that
//! the ego could have escaped a CBV that did not react), each next one
//! against the rollout its predecessor produced, with every CBV path seen
//! so far kept as an obstacle (an escape from all of them is less likely to
//! be chased into the next), falling back to the newest path alone when
//! no path avoids them all. The search ends at the first verified escape,
//! when the fixed-traffic search finds nothing, or when its verification
//! rollouts are spent; the last two are "no escape within budget", which is
//! not a proof that none exists: it is reported as the generator's fault,
//! never as the planner's.
//!
//! The search is a pure function of the realised rollout and the replay it
//! is given: deterministic whenever the replay is.

use crate::motion::tokens::SIM_DT_S;
use crate::planners::{Observation, Planner, PlannerError, PlannerOutput, TrajectoryPoint};
use crate::scenario::{AgentBody, AgentState, Scenario};
use crate::sim::{Rollout, Termination};

use super::witness::{FixedTraffic, RoadKeeping, RoadRule, Witness, WitnessBudget, search_witness};

/// How much the closed-loop search may spend.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EscapeBudget {
    /// Closed-loop rollouts that play a candidate escape, at most.
    pub verifications: usize,
    /// The fixed-traffic search of the pre-check.
    pub precheck: WitnessBudget,
    /// The fixed-traffic search of every later candidate (narrower: each
    /// runs against a CBV that has already reacted once).
    pub follow_up: WitnessBudget,
    /// How much of the ego keeps to the road.
    pub keeping: RoadKeeping,
}

impl Default for EscapeBudget {
    fn default() -> Self {
        Self {
            verifications: 6,
            precheck: WitnessBudget::default(),
            follow_up: WitnessBudget::widening_up_to(super::witness::FIRST_WIDENING),
            keeping: RoadKeeping::default(),
        }
    }
}

/// Why no escape was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum NoEscapeReason {
    /// The fixed-traffic search found no path against the traffic of the
    /// last rollout.
    SearchFoundNone,
    /// Every verification rollout was spent on a candidate the reacting
    /// CBV still hit.
    VerificationsSpent,
}

/// The verdict on a stage-2 collision.
#[derive(Debug, Clone, PartialEq)]
pub enum EscapeVerdict {
    /// An ego path that, played closed loop, touches nobody: the collision
    /// was avoidable.
    Verified {
        /// The ego's states, one per simulator step from the start.
        trajectory: Vec<AgentState>,
        /// Closest box distance to any agent in the verifying rollout, m.
        min_gap_m: f64,
    },
    /// None within the budget (not a proof that none exists).
    NoneWithinBudget(NoEscapeReason),
}

/// What the closed-loop witness found, and what it cost.
#[derive(Debug, Clone, PartialEq)]
pub struct EscapeSearch {
    /// The pre-check: whether an escape from the realised traffic (the CBV
    /// as it drove) exists. Proves avoidability only when nothing reacts.
    pub precheck_found: bool,
    /// The verdict.
    pub verdict: EscapeVerdict,
    /// Closed-loop rollouts played.
    pub rollouts: usize,
    /// Fixed-traffic searches run (the pre-check included).
    pub searches: usize,
}

impl EscapeSearch {
    /// Whether the collision was shown avoidable.
    pub fn avoidable(&self) -> bool {
        matches!(self.verdict, EscapeVerdict::Verified { .. })
    }

    /// The verified escape, when there is one.
    pub fn trajectory(&self) -> Option<&[AgentState]> {
        match &self.verdict {
            EscapeVerdict::Verified { trajectory, .. } => Some(trajectory),
            EscapeVerdict::NoneWithinBudget(_) => None,
        }
    }
}

/// Whether a rollout is an escape over its first `steps` states: it did
/// not abort (a planner failure, an invalid state) and the ego touched
/// nobody before that. The realised rollout may have ended early (the ego
/// left the mapped area): an escape need not outlast what it escapes.
pub fn is_clear_over(rollout: &Rollout, steps: usize) -> bool {
    let aborted = !matches!(rollout.termination, Termination::Completed | Termination::LeftMappedArea { .. });
    !aborted && rollout.ego_collision().is_none_or(|c| c.step >= rollout.start_step + steps)
}

/// Searches a verified escape for the ego of `realised` (a stage-2 rollout
/// of `scenario`), `replay` playing a candidate ego path closed loop and
/// returning the rollout (the same start, horizon and agents as
/// `realised`). `Ok(None)` when the ego has no start state.
pub fn search_escape<E>(
    scenario: &Scenario,
    realised: &Rollout,
    budget: EscapeBudget,
    replay: &mut dyn FnMut(&[AgentState]) -> Result<Rollout, E>,
) -> Result<Option<EscapeSearch>, E> {
    let ego = realised.ego.0;
    let Some(start) = realised.states.first().and_then(|row| row.get(ego).copied().flatten()) else {
        return Ok(None);
    };
    let horizon = realised.states.len().saturating_sub(1);
    let body = scenario.track(realised.ego).body();
    let road = Some(RoadRule { map: &scenario.map, keeping: budget.keeping });
    let search = |latest: &Rollout, earlier: &[Vec<Option<AgentState>>], witness_budget: WitnessBudget| {
        let (states, bodies) = traffic_with(latest, earlier);
        let traffic = FixedTraffic { states: &states, bodies: &bodies, ego, road };
        search_witness(&start, body, &traffic, horizon, witness_budget)
    };

    let precheck = search(realised, &[], budget.precheck);
    let mut out = EscapeSearch {
        precheck_found: precheck.is_found(),
        verdict: EscapeVerdict::NoneWithinBudget(NoEscapeReason::SearchFoundNone),
        rollouts: 0,
        searches: 1,
    };
    let mut candidate = precheck;
    let mut latest: Option<Rollout> = None;
    let mut earlier: Vec<Vec<Option<AgentState>>> = Vec::new();
    loop {
        let Witness::Found { trajectory, .. } = candidate else {
            out.verdict = EscapeVerdict::NoneWithinBudget(NoEscapeReason::SearchFoundNone);
            return Ok(Some(out));
        };
        if out.rollouts >= budget.verifications {
            out.verdict = EscapeVerdict::NoneWithinBudget(NoEscapeReason::VerificationsSpent);
            return Ok(Some(out));
        }
        let played = replay(&trajectory)?;
        out.rollouts += 1;
        if is_clear_over(&played, realised.states.len()) {
            let min_gap_m = played.summary().min_distance_to_ego_m.unwrap_or(f64::INFINITY);
            out.verdict = EscapeVerdict::Verified { trajectory, min_gap_m };
            return Ok(Some(out));
        }
        // The CBV path the failed candidate was searched against stays an
        // obstacle; the new rollout is the traffic to escape next.
        if let Some(cbv) = realised.cbv {
            earlier.push(agent_path(latest.as_ref().unwrap_or(realised), cbv.0));
        }
        let newest = latest.insert(played);
        candidate = search(newest, &earlier, budget.follow_up);
        out.searches += 1;
        if !candidate.is_found() && !earlier.is_empty() {
            candidate = search(newest, &[], budget.follow_up);
            out.searches += 1;
        }
    }
}

/// One agent's states over a rollout (`None` where absent).
fn agent_path(rollout: &Rollout, agent: usize) -> Vec<Option<AgentState>> {
    rollout.states.iter().map(|row| row.get(agent).copied().flatten()).collect()
}

/// The traffic of `latest` with each of `earlier` as one more agent (with
/// the CBV's body), as the fixed-traffic search takes it.
fn traffic_with(
    latest: &Rollout,
    earlier: &[Vec<Option<AgentState>>],
) -> (Vec<Vec<Option<AgentState>>>, Vec<AgentBody>) {
    let mut bodies = latest.bodies.clone();
    let cbv_body = latest.cbv.and_then(|c| latest.bodies.get(c.0).copied());
    let Some(cbv_body) = cbv_body.filter(|_| !earlier.is_empty()) else {
        return (latest.states.clone(), bodies);
    };
    bodies.extend(std::iter::repeat_n(cbv_body, earlier.len()));
    let states = latest
        .states
        .iter()
        .enumerate()
        .map(|(k, row)| {
            let mut row = row.clone();
            row.extend(earlier.iter().map(|path| path.get(k).copied().flatten()));
            row
        })
        .collect();
    (states, bodies)
}

/// The ego of a replay: follows `plan` (one state per simulator step from
/// the start) exactly, then holds its last speed and heading.
#[derive(Debug, Clone)]
pub struct PlannedPath {
    plan: Vec<AgentState>,
}

impl PlannedPath {
    /// A planner that drives `plan`.
    pub fn new(plan: Vec<AgentState>) -> Self {
        Self { plan }
    }
}

impl Planner for PlannedPath {
    fn name(&self) -> &str {
        "escape-witness"
    }

    fn plan(&mut self, observation: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        let k = (observation.time_s / SIM_DT_S).round() as usize;
        match self.plan.get(k + 1) {
            Some(next) => Ok(PlannerOutput::Trajectory(vec![TrajectoryPoint { time_s: SIM_DT_S, state: *next }])),
            None => Ok(PlannerOutput::Control(crate::motion::Action { accel_mps2: 0.0, yaw_rate_radps: 0.0 })),
        }
    }
}

/// The closed-loop witness's verdict on a stage-2 collision, as reports
/// and snapshots carry it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CollisionEscape {
    /// An escape, played closed loop with the CBV reacting, touched
    /// nobody: the collision was avoidable, a planner failure.
    Avoidable,
    /// The fixed-traffic search found no escape from the last rollout's
    /// traffic: counted as the generator's fault, not the planner's.
    NoEscapeFound,
    /// Every verification rollout was spent on an escape the reacting CBV
    /// still hit: counted as the generator's fault, not the planner's.
    NoEscapeVerified,
}

impl CollisionEscape {
    /// The verdict of a search.
    pub fn of(search: &EscapeSearch) -> Self {
        match search.verdict {
            EscapeVerdict::Verified { .. } => Self::Avoidable,
            EscapeVerdict::NoneWithinBudget(NoEscapeReason::SearchFoundNone) => Self::NoEscapeFound,
            EscapeVerdict::NoneWithinBudget(NoEscapeReason::VerificationsSpent) => Self::NoEscapeVerified,
        }
    }

    /// Whether the collision counts against the planner.
    pub fn avoidable(self) -> bool {
        self == Self::Avoidable
    }

    /// One line for a person reading the report.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Avoidable => {
                "avoidable: an escape played closed loop, the CBV reacting, touches nobody (drawn in the recording and picture)"
            }
            Self::NoEscapeFound => {
                "no escape found within budget: the generator's fault, not the planner's (not a proof that none exists)"
            }
            Self::NoEscapeVerified => {
                "no escape survived the reacting CBV within budget: the generator's fault, not the planner's (not a proof that none exists)"
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Polyline, Vector2};
    use crate::map::{Lane, MapElementId, RoadMap};
    use crate::policies::{AgentAction, AgentPolicy, WorldView};
    use crate::scenario::{AgentId, AgentKind, ScenarioSource, Track, TrackIndex};
    use crate::sim::{SimConfig, Simulation};

    /// A three-lane road along x (lanes at y = -3.5, 0, 3.5); the ego at the
    /// origin at 10 m/s, a CBV 25 m ahead coming head-on at `cbv_speed`.
    fn head_on(cbv_speed_mps: f64) -> Scenario {
        let lane = |id, y: f64| {
            Lane::new(MapElementId(id), Polyline::new(vec![Point2::new(-100.0, y), Point2::new(300.0, y)]))
        };
        let map = RoadMap::new(
            vec![lane(1, -3.5), lane(2, 0.0), lane(3, 3.5)],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
            vec![],
        );
        let track = |id: &str, x0: f64, vx: f64, heading: f64| Track {
            id: AgentId(id.into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            states: (0..61)
                .map(|k| {
                    Some(AgentState {
                        position: Point2::new(x0 + vx * 0.1 * k as f64, 0.0),
                        heading_rad: heading,
                        velocity_mps: Vector2::new(vx, 0.0),
                    })
                })
                .collect(),
        };
        let tracks = vec![track("ego", 0.0, 10.0, 0.0), track("cbv", 25.0, -cbv_speed_mps, std::f64::consts::PI)];
        Scenario::new("head-on", ScenarioSource::authored("test"), 0.1, map, tracks)
            .with_roles(TrackIndex(0), Some(TrackIndex(1)))
    }

    /// A CBV that steers straight at where the ego is now, at its speed
    /// (a pure pursuer: it reacts to every ego move).
    struct Pursuer {
        speed_mps: f64,
    }

    impl AgentPolicy for Pursuer {
        fn name(&self) -> &'static str {
            "pursuer"
        }

        fn act(&mut self, world: &WorldView<'_>, me: TrackIndex) -> AgentAction {
            let (Some(mine), Some(ego)) = (world.state(me), world.state(TrackIndex(0))) else {
                return AgentAction::Absent;
            };
            let to = ego.position - mine.position;
            let heading = to.y.atan2(to.x);
            let velocity = Vector2::new(heading.cos(), heading.sin()) * self.speed_mps;
            AgentAction::Teleport(AgentState {
                position: mine.position + velocity * SIM_DT_S,
                heading_rad: heading,
                velocity_mps: velocity,
            })
        }
    }

    /// Stage 2 of `scenario` with the CBV pursuing at `speed` and the ego
    /// driven by `planner`.
    fn rollout(scenario: &Scenario, speed_mps: f64, planner: &mut dyn Planner) -> Rollout {
        let mut sim = Simulation::new(scenario, SimConfig::default()).unwrap();
        sim.set_policy(TrackIndex(1), Box::new(Pursuer { speed_mps }));
        sim.run(planner)
    }

    /// Holds 10 m/s straight on: meets the CBV head-on.
    struct Straight;
    impl Planner for Straight {
        fn name(&self) -> &str {
            "straight"
        }
        fn plan(&mut self, _: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
            Ok(PlannerOutput::Control(crate::motion::Action { accel_mps2: 0.0, yaw_rate_radps: 0.0 }))
        }
    }

    fn search(scenario: &Scenario, speed_mps: f64) -> EscapeSearch {
        let realised = rollout(scenario, speed_mps, &mut Straight);
        assert!(realised.ego_collision().is_some(), "the ego holding its lane must be hit");
        let mut replay = |plan: &[AgentState]| -> Result<Rollout, ()> {
            Ok(rollout(scenario, speed_mps, &mut PlannedPath::new(plan.to_vec())))
        };
        search_escape(scenario, &realised, EscapeBudget::default(), &mut replay).unwrap().unwrap()
    }

    #[test]
    fn a_slow_pursuer_is_escaped_and_the_escape_is_verified_by_playing_it() {
        // At 2 m/s the CBV cannot catch a car that swerves away at 10 m/s.
        let scenario = head_on(2.0);
        let found = search(&scenario, 2.0);
        assert!(found.avoidable(), "{found:?}");
        let plan = found.trajectory().unwrap().to_vec();
        let played = rollout(&scenario, 2.0, &mut PlannedPath::new(plan));
        assert!(is_clear_over(&played, played.states.len()), "the verdict's escape must be clear when played");
        assert!(found.rollouts >= 1);
    }

    #[test]
    fn a_pursuer_faster_than_any_escape_is_no_escape_though_the_precheck_finds_one() {
        // At 12 m/s, turning on the spot towards the ego every step, it
        // runs down any ego: the fixed-traffic pre-check finds a path
        // around the CBV as it drove, but played closed loop the CBV
        // follows the ego onto it, every time, until the budget is spent.
        let scenario = head_on(12.0);
        let found = search(&scenario, 12.0);
        assert!(found.precheck_found, "{found:?}");
        assert!(!found.avoidable(), "{found:?}");
        assert_eq!(found.rollouts, EscapeBudget::default().verifications, "{found:?}");
        assert_eq!(found.verdict, EscapeVerdict::NoneWithinBudget(NoEscapeReason::VerificationsSpent));
    }

    #[test]
    fn an_escape_need_not_outlast_the_rollout_it_escapes() {
        // The realised rollout ended after 27 states (the ego left the
        // mapped area); a played escape that touches someone at state 40
        // still escaped everything the realised rollout had.
        let scenario = head_on(2.0);
        let mut played = rollout(&scenario, 2.0, &mut Straight);
        let first = played.ego_collision().expect("a collision").step - played.start_step;
        assert!(!is_clear_over(&played, first + 1));
        assert!(is_clear_over(&played, first));
        played.termination = Termination::PlannerFailed { step: 3, reason: "crashed".into() };
        assert!(!is_clear_over(&played, first), "an aborted rollout is never an escape");
    }

    #[test]
    fn a_plan_is_followed_exactly_then_held() {
        let scenario = head_on(2.0);
        let plan: Vec<AgentState> = (0..5)
            .map(|k| AgentState {
                position: Point2::new(k as f64, 0.5 * k as f64),
                heading_rad: 0.2,
                velocity_mps: Vector2::new(10.0, 0.0),
            })
            .collect();
        let played = rollout(&scenario, 0.0, &mut PlannedPath::new(plan.clone()));
        for (k, s) in plan.iter().enumerate() {
            assert_eq!(played.states[k][0].unwrap().position, s.position, "step {k}");
        }
        assert!(played.states.len() > plan.len());
    }
}
