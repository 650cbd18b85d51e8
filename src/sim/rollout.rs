//! The record of one closed-loop run and its summary.

use super::events::{ClosestApproach, CollisionEvent, EgoCollisionKind, EgoContact, LaneOccupancy, OffRoadEvent};
use crate::scenario::{AgentBody, AgentId, AgentKind, AgentState, TrackIndex};

/// How a rollout ended.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum Termination {
    /// Ran to the end step.
    Completed,
    /// Stopped at the ego's first collision (when configured to).
    EgoCollision {
        /// Step of the collision.
        step: usize,
    },
    /// Stopped when the ego drove past the end of the map (the end of a
    /// lane with no successor where the road edges end too: the recording's
    /// map was cut off there, see [`crate::map::RoadMap::is_past_mapped_end`]): the
    /// scene is over there, not the road. Not an off-road event; the rollout
    /// counts as run to its end (see `docs/planner-protocol.md`).
    LeftMappedArea {
        /// Step at which the ego's leading corner crossed the map's end.
        step: usize,
    },
    /// The planner failed (crashed, hung, answered garbage, or drove the
    /// ego to a non-finite or out-of-bounds state); the rollout stops there.
    PlannerFailed {
        /// Step at which it was asked.
        step: usize,
        /// What went wrong.
        reason: String,
    },
    /// The planner's output moved the ego beyond its vehicle limits (see
    /// [`super::VehicleLimits`]): a teleport, an instant stop, a turn on the
    /// spot, a reverse reported as standing. The rollout stops there; the
    /// variant is never solved.
    VehicleLimitExceeded {
        /// Step at which the planner was asked.
        step: usize,
        /// Which limit, the value and the bound.
        reason: String,
    },
    /// A non-ego agent's state is non-finite or outside the plausible
    /// bounds of [`crate::scenario::bounds`] (±1e7 m from the scene origin,
    /// ≤ 1e3 m/s): its policy produced it, or its recorded start state is
    /// already out of bounds (then `step` is the start step and nothing is
    /// simulated). The rollout stops there rather than compute on nonsense;
    /// the variant it belongs to is not solved. Serialised as
    /// `{"kind": "invalid-agent-state", "step", "agent", "reason"}`.
    InvalidAgentState {
        /// Step of the invalid state.
        step: usize,
        /// The agent.
        agent: AgentId,
        /// Which value, and the bound it broke.
        reason: String,
    },
}

/// Everything a rollout produced.
#[derive(Debug, Clone)]
pub struct Rollout {
    /// Scenario id.
    pub scenario_id: String,
    /// Step length, s.
    pub dt_s: f64,
    /// Scenario step of `states[0]`.
    pub start_step: usize,
    /// The ego.
    pub ego: TrackIndex,
    /// The CBV, if the scenario has one.
    pub cbv: Option<TrackIndex>,
    /// Agent ids, indexed like the tracks.
    pub agent_ids: Vec<AgentId>,
    /// Agent types and sizes, indexed like the tracks.
    pub bodies: Vec<AgentBody>,
    /// `states[k][i]`: agent `i` at step `start_step + k`.
    pub states: Vec<Vec<Option<AgentState>>>,
    /// Collisions, in order of occurrence.
    pub collisions: Vec<CollisionEvent>,
    /// The ego leaving the road, in order.
    pub off_road: Vec<OffRoadEvent>,
    /// The ego's closest approach to another agent.
    pub min_distance_to_ego: Option<ClosestApproach>,
    /// How it ended.
    pub termination: Termination,
    /// Planner name.
    pub planner: String,
    /// What the planner gave to keep with its steps (an external planner's
    /// `debug` objects), in step order; empty for most planners.
    pub planner_debug: Vec<PlannerDebug>,
}

/// A planner's own data for one step (an external planner's `debug`
/// object), kept with the rollout for the recording.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PlannerDebug {
    /// The scenario step of the observation it answered.
    pub step: usize,
    /// The planner's JSON, as it sent it.
    pub debug: serde_json::Value,
}

/// The ego's first collision, for reports.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EgoCollision {
    /// Time after the start, s.
    pub time_s: f64,
    /// The other agent's id.
    pub other: AgentId,
    /// Whether the other agent is the CBV.
    pub with_cbv: bool,
    /// How the ego was involved.
    pub kind: EgoCollisionKind,
    /// Where the ego's footprint lay among the lanes at the contact.
    pub lanes: LaneOccupancy,
    /// Whether the ego is at fault (see [`EgoContact::at_fault`]).
    pub at_fault: bool,
}

/// A collision, for reports.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CollisionReport {
    /// Time after the start, s.
    pub time_s: f64,
    /// The two agents' ids.
    pub agents: [AgentId; 2],
    /// Their kinds.
    pub kinds: [AgentKind; 2],
}

/// A serialisable summary of a rollout.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RolloutSummary {
    /// Scenario id.
    pub scenario: String,
    /// Planner name.
    pub planner: String,
    /// Ego id.
    pub ego: AgentId,
    /// CBV id.
    pub cbv: Option<AgentId>,
    /// Steps simulated.
    pub steps: usize,
    /// Simulated time, s.
    pub duration_s: f64,
    /// The ego's first collision.
    pub ego_collision: Option<EgoCollision>,
    /// Time the ego first left the road, s after the start.
    pub ego_off_road_s: Option<f64>,
    /// Ego's minimum box distance to any agent, m.
    pub min_distance_to_ego_m: Option<f64>,
    /// The agent it was closest to.
    pub closest_agent: Option<AgentId>,
    /// Collisions not involving the ego.
    pub background_collisions: usize,
    /// Every collision, in order.
    pub collisions: Vec<CollisionReport>,
    /// How it ended.
    pub termination: Termination,
}

impl Rollout {
    /// Steps simulated (transitions).
    pub fn steps(&self) -> usize {
        self.states.len().saturating_sub(1)
    }

    /// The ego's first collision event.
    pub fn ego_collision(&self) -> Option<&CollisionEvent> {
        self.collisions.iter().find(|c| c.involves_ego)
    }

    /// The agent the ego first collided with, if any.
    pub fn ego_collision_other(&self) -> Option<TrackIndex> {
        self.ego_collision().map(|c| c.other_than(self.ego))
    }

    /// The summary.
    pub fn summary(&self) -> RolloutSummary {
        // Rounded to the millisecond so reports do not show float noise.
        let time = |step: usize| ((step - self.start_step) as f64 * self.dt_s * 1e3).round() / 1e3;
        let ego_collision = self.ego_collision().map(|c| {
            let other = c.other_than(self.ego);
            // Detected ego collisions always carry a judgement; a hand-built
            // event without one counts as an at-fault front contact.
            let contact = c
                .ego_contact
                .unwrap_or(EgoContact { kind: EgoCollisionKind::ActiveFront, lanes: LaneOccupancy::Unmapped });
            EgoCollision {
                time_s: time(c.step),
                other: self.agent_ids[other.0].clone(),
                with_cbv: Some(other) == self.cbv,
                kind: contact.kind,
                lanes: contact.lanes,
                at_fault: contact.at_fault(),
            }
        });
        RolloutSummary {
            scenario: self.scenario_id.clone(),
            planner: self.planner.clone(),
            ego: self.agent_ids[self.ego.0].clone(),
            cbv: self.cbv.map(|c| self.agent_ids[c.0].clone()),
            steps: self.steps(),
            duration_s: self.steps() as f64 * self.dt_s,
            ego_collision,
            ego_off_road_s: self.off_road.first().map(|o| time(o.step)),
            min_distance_to_ego_m: self.min_distance_to_ego.map(|c| c.distance_m),
            closest_agent: self.min_distance_to_ego.map(|c| self.agent_ids[c.agent.0].clone()),
            background_collisions: self.collisions.iter().filter(|c| !c.involves_ego).count(),
            collisions: self
                .collisions
                .iter()
                .map(|c| CollisionReport {
                    time_s: time(c.step),
                    agents: [self.agent_ids[c.a.0].clone(), self.agent_ids[c.b.0].clone()],
                    kinds: [self.bodies[c.a.0].kind, self.bodies[c.b.0].kind],
                })
                .collect(),
            termination: self.termination.clone(),
        }
    }
}
