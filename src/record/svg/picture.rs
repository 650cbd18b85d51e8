//! What a picture shows, taken from either a scenario or a rollout: the
//! agents with their roles (ego, CBV, others), their states through one
//! accessor that drops non-finite ones, the collisions, the displayed step
//! and the two caption lines (scenario, planner, shown time, the ego's
//! collision or closest approach, off-road and planner failures).

use std::collections::BTreeSet;
use std::fmt::Write as _;

use super::SvgOptions;
use crate::geometry::Point2;
use crate::map::RoadMap;
use crate::record::NamedTrajectory;
use crate::scenario::{AgentBody, AgentKind, AgentState, RoleOrigin, Scenario, Track, TrackIndex};
use crate::sim::{Rollout, Termination};

/// Who an agent is in the picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Role {
    Ego,
    Cbv,
    Other,
}

/// States of a scenario (track-major) or a rollout (step-major), read
/// through one accessor that drops non-finite states.
pub(super) enum StateTable<'a> {
    Tracks(&'a [Track]),
    Steps(&'a [Vec<Option<AgentState>>]),
}

impl StateTable<'_> {
    pub(super) fn get(&self, k: usize, i: usize) -> Option<&AgentState> {
        let s = match self {
            Self::Tracks(t) => t.get(i)?.states.get(k)?.as_ref()?,
            Self::Steps(s) => s.get(k)?.get(i)?.as_ref()?,
        };
        let finite = s.position.x.is_finite() && s.position.y.is_finite() && s.heading_rad.is_finite();
        finite.then_some(s)
    }

    pub(super) fn num_steps(&self) -> usize {
        match self {
            Self::Tracks(t) => t.iter().map(|t| t.states.len()).max().unwrap_or(0),
            Self::Steps(s) => s.len(),
        }
    }
}

pub(super) struct Agent<'a> {
    pub(super) id: &'a str,
    pub(super) body: AgentBody,
    pub(super) role: Role,
}

pub(super) struct Collision {
    /// Index into the state table.
    pub(super) k: usize,
    pub(super) a: usize,
    pub(super) b: usize,
}

/// Everything a picture needs, from either a scenario or a rollout.
pub(super) struct Picture<'a> {
    pub(super) title: String,
    pub(super) map: &'a RoadMap,
    pub(super) agents: Vec<Agent<'a>>,
    pub(super) states: StateTable<'a>,
    pub(super) dt_s: f64,
    /// Index of the displayed step in the state table.
    pub(super) shown: usize,
    pub(super) collisions: Vec<Collision>,
    pub(super) extras: &'a [NamedTrajectory],
    pub(super) caption: [String; 2],
}

impl<'a> Picture<'a> {
    /// The picture of a scenario without a rollout.
    pub(super) fn of_scenario(scenario: &'a Scenario, opts: &SvgOptions) -> Self {
        let states = StateTable::Tracks(&scenario.tracks);
        let n = states.num_steps();
        let shown = opts.step.unwrap_or(scenario.current_step).min(n.saturating_sub(1));
        let role = |i: usize| role_of(i, scenario.ego, scenario.cbv);
        let agents = scenario
            .tracks
            .iter()
            .enumerate()
            .map(|(i, t)| Agent { id: t.id.0.as_str(), body: t.body(), role: role(i) })
            .collect();
        let track_id = |r: Option<TrackIndex>| r.and_then(|r| scenario.tracks.get(r.0)).map(|t| t.id.0.as_str());
        let format = serde_json::to_value(scenario.source.format)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default();
        let line1 = format!(
            "{} · recorded ({format}) · shown: {} (step {shown} of {})",
            scenario.id,
            time_text(shown, scenario.dt_s),
            n.saturating_sub(1)
        );
        let origin = |o: RoleOrigin| match o {
            RoleOrigin::Source => "named by the source",
            RoleOrigin::ConflictMining => "by conflict mining",
            RoleOrigin::LabelledPair => "the labelled interacting pair",
            RoleOrigin::MergeMining => "in a lane merging with the other's",
            RoleOrigin::LeaderMining => "the ego's leader",
            RoleOrigin::CrossingMining => "on a path crossing the other's",
            RoleOrigin::Unassigned => "unassigned",
        };
        let line2 = format!(
            "ego {} ({}) · CBV {} ({}) · {} agents",
            track_id(scenario.ego).unwrap_or("none"),
            origin(scenario.ego_origin),
            track_id(scenario.cbv).unwrap_or("none"),
            origin(scenario.cbv_origin),
            scenario.tracks.len()
        );
        Picture {
            title: format!("scenario {}", scenario.id),
            map: &scenario.map,
            agents,
            states,
            dt_s: scenario.dt_s,
            shown,
            collisions: Vec::new(),
            extras: &[],
            caption: [line1, line2],
        }
    }

    /// The picture of a rollout, with extra trajectories.
    pub(super) fn of_rollout(
        scenario: &'a Scenario,
        rollout: &'a Rollout,
        extras: &'a [NamedTrajectory],
        opts: &SvgOptions,
    ) -> Self {
        let states = StateTable::Steps(&rollout.states);
        let n = states.num_steps();
        let last = n.saturating_sub(1);
        let to_k = |step: usize| step.checked_sub(rollout.start_step);
        let ego_hit = rollout.ego_collision();
        let shown = match opts.step {
            Some(s) => s.saturating_sub(rollout.start_step).min(last),
            None => ego_hit.and_then(|c| to_k(c.step)).unwrap_or(last).min(last),
        };
        let agents: Vec<Agent> = rollout
            .bodies
            .iter()
            .enumerate()
            .map(|(i, b)| Agent {
                id: rollout.agent_ids.get(i).map_or("?", |a| a.0.as_str()),
                body: *b,
                role: role_of(i, Some(rollout.ego), rollout.cbv),
            })
            .collect();
        let collisions = rollout
            .collisions
            .iter()
            .filter_map(|c| Some(Collision { k: to_k(c.step)?, a: c.a.0, b: c.b.0 }))
            .collect();
        let id = |i: usize| agents.get(i).map_or("?", |a| a.id);
        let kind = |i: usize| agents.get(i).map_or("agent", |a| kind_name(a.body.kind));
        let line1 = format!(
            "{} · planner {} · shown: {} (step {})",
            rollout.scenario_id,
            rollout.planner,
            time_text(shown, rollout.dt_s),
            rollout.start_step + shown
        );
        let mut line2 = match ego_hit {
            Some(c) => {
                let other = if c.a == rollout.ego { c.b.0 } else { c.a.0 };
                let who = if Some(TrackIndex(other)) == rollout.cbv {
                    format!("the CBV ({}, {})", id(other), kind(other))
                } else {
                    format!("{} {}", kind(other), id(other))
                };
                let when = to_k(c.step).map_or_else(|| "?".to_string(), |k| time_text(k, rollout.dt_s));
                format!("ego ({}) collides with {who} at {when}", id(rollout.ego.0))
            }
            None => match rollout.min_distance_to_ego {
                Some(c) if c.distance_m.is_finite() => format!(
                    "no ego collision · closest approach {:.2} m to {} {} at {}",
                    c.distance_m,
                    kind(c.agent.0),
                    id(c.agent.0),
                    to_k(c.step).map_or_else(|| "?".to_string(), |k| time_text(k, rollout.dt_s))
                ),
                _ => "no ego collision".to_string(),
            },
        };
        if let Some(o) = rollout.off_road.first() {
            let when = to_k(o.step).map_or_else(|| "?".to_string(), |k| time_text(k, rollout.dt_s));
            let _ = write!(line2, " · ego off road at {when}");
        }
        let background = rollout.collisions.iter().filter(|c| !c.involves_ego).count();
        if background > 0 {
            let _ = write!(line2, " · {background} background collision{}", if background == 1 { "" } else { "s" });
        }
        match &rollout.termination {
            Termination::PlannerFailed { step, reason } => {
                let when = to_k(*step).map_or_else(|| "?".to_string(), |k| time_text(k, rollout.dt_s));
                let _ = write!(line2, " · planner failed at {when}: {reason}");
            }
            Termination::VehicleLimitExceeded { step, reason } => {
                let when = to_k(*step).map_or_else(|| "?".to_string(), |k| time_text(k, rollout.dt_s));
                let _ = write!(line2, " · beyond the vehicle limits at {when}: {reason}");
            }
            Termination::InvalidAgentState { step, agent, reason } => {
                let when = to_k(*step).map_or_else(|| "?".to_string(), |k| time_text(k, rollout.dt_s));
                let _ = write!(line2, " · aborted at {when}: agent {agent}: {reason}");
            }
            Termination::Completed | Termination::EgoCollision { .. } | Termination::LeftMappedArea { .. } => {}
        }
        Picture {
            title: format!("rollout of scenario {} with planner {}", rollout.scenario_id, rollout.planner),
            map: &scenario.map,
            agents,
            states,
            dt_s: rollout.dt_s,
            shown,
            collisions,
            extras,
            caption: [line1, line2],
        }
    }
}

pub(super) fn role_of(i: usize, ego: Option<TrackIndex>, cbv: Option<TrackIndex>) -> Role {
    if ego == Some(TrackIndex(i)) {
        Role::Ego
    } else if cbv == Some(TrackIndex(i)) {
        Role::Cbv
    } else {
        Role::Other
    }
}

pub(super) fn kind_name(kind: AgentKind) -> &'static str {
    match kind {
        AgentKind::Vehicle => "vehicle",
        AgentKind::Pedestrian => "pedestrian",
        AgentKind::Cyclist => "cyclist",
        AgentKind::Other => "other",
    }
}

/// "t = 4.7 s", or the step alone where the step length is unusable.
pub(super) fn time_text(k: usize, dt_s: f64) -> String {
    let t = k as f64 * dt_s;
    if t.is_finite() { format!("t = {t:.1} s") } else { format!("step {k}") }
}

pub(super) fn radius(body: &AgentBody) -> f64 {
    let r = 0.5 * body.length_m.hypot(body.width_m);
    if r.is_finite() { r } else { 0.0 }
}

/// Runs of consecutive valid positions of agent `i` over `range`.
pub(super) fn runs(pic: &Picture, i: usize, range: std::ops::Range<usize>) -> Vec<Vec<Point2>> {
    let mut out: Vec<Vec<Point2>> = Vec::new();
    let mut current = Vec::new();
    for k in range {
        match pic.states.get(k, i) {
            Some(s) => current.push(s.position),
            None if !current.is_empty() => out.push(std::mem::take(&mut current)),
            None => {}
        }
    }
    if !current.is_empty() {
        out.push(current);
    }
    out
}

pub(super) fn involves_role(pic: &Picture, i: usize) -> bool {
    pic.agents.get(i).is_some_and(|a| a.role != Role::Other)
}

/// Agents that have collided at or before the displayed step.
pub(super) fn collided(pic: &Picture) -> BTreeSet<usize> {
    pic.collisions.iter().filter(|c| c.k <= pic.shown).flat_map(|c| [c.a, c.b]).collect()
}
