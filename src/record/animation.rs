//! A rollout as data for an animated top-down view in a browser: the view
//! (cropped like the SVG picture to the ego's and CBV's paths plus a
//! margin), the map lines inside it, every agent that enters it (id, role,
//! box size) and, per simulation step, each agent's pose (`[x, y,
//! heading]`, `null` when absent), plus the collisions. The review page
//! ([`crate::harness::report::review_page`]) embeds it as JSON and its script
//! draws the agents as oriented boxes over the road.
//!
//! Positions are metres in the scenario frame with y up, rounded to the
//! centimetre, headings to the milliradian, so a 9 s rollout of a busy
//! recorded scene stays a few hundred kilobytes. Non-finite states are
//! written as absent; the same rollout gives the same data.

use serde::Serialize;

use crate::geometry::Point2;
use crate::scenario::{AgentKind, Scenario};
use crate::sim::Rollout;

/// Margin around the ego's and CBV's paths, metres (as the SVG picture).
const MARGIN_M: f64 = 15.0;
/// Smallest side of the view, metres.
const MIN_EXTENT_M: f64 = 60.0;

/// A rollout, ready to animate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RolloutAnimation {
    /// Scenario id.
    pub scenario: String,
    /// Step length, s.
    pub dt_s: f64,
    /// The view: `[min x, min y, max x, max y]`, metres.
    pub view: [f64; 4],
    /// Map lines crossing the view.
    pub map: Vec<MapLine>,
    /// Agents that are inside the view at some step (ego and CBV first).
    pub agents: Vec<AnimatedAgent>,
    /// `frames[k][i]`: agent `i` at step `k` as `[x, y, heading rad]`.
    pub frames: Vec<Vec<Option<[f64; 3]>>>,
    /// Collisions: first-contact frame and the two agents (indices into `agents`).
    pub collisions: Vec<AnimatedCollision>,
    /// The frame to show first: the ego's collision, else the last.
    pub initial_frame: usize,
}

/// What a map line is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MapLineKind {
    /// A road edge.
    Edge,
    /// A lane centreline.
    Lane,
    /// A painted line.
    Line,
    /// A drivable-area outline (closed).
    Drivable,
}

/// A map line, `[x, y]` points.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MapLine {
    /// What it is.
    pub kind: MapLineKind,
    /// Points, metres.
    pub points: Vec<[f64; 2]>,
}

/// Who an agent is in the animation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum AnimatedRole {
    /// The ego.
    Ego,
    /// The critical background vehicle.
    Cbv,
    /// A background vehicle.
    Vehicle,
    /// A pedestrian.
    Pedestrian,
    /// A cyclist.
    Cyclist,
    /// Anything else.
    Other,
}

/// An agent's identity and box.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AnimatedAgent {
    /// Source id.
    pub id: String,
    /// Role or type.
    pub role: AnimatedRole,
    /// Box length, m.
    pub length_m: f64,
    /// Box width, m.
    pub width_m: f64,
}

/// A collision in the animation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct AnimatedCollision {
    /// Frame of first contact.
    pub frame: usize,
    /// The two agents, indices into [`RolloutAnimation::agents`].
    pub agents: [usize; 2],
}

fn round(x: f64, unit: f64) -> f64 {
    (x / unit).round() * unit
}

impl RolloutAnimation {
    /// The animation of `rollout` in `scenario`.
    pub fn of_rollout(scenario: &Scenario, rollout: &Rollout) -> Self {
        let finite = |s: &crate::scenario::AgentState| {
            s.position.x.is_finite() && s.position.y.is_finite() && s.heading_rad.is_finite()
        };
        let pose = |k: usize, i: usize| rollout.states.get(k)?.get(i)?.as_ref().filter(|s| finite(s));
        let n_agents = rollout.bodies.len();
        let roles: Vec<usize> = std::iter::once(rollout.ego.0).chain(rollout.cbv.map(|c| c.0)).collect();

        // The view: the ego's and CBV's paths, a margin, a smallest size.
        let (mut lo, mut hi) =
            (Point2::new(f64::INFINITY, f64::INFINITY), Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY));
        for k in 0..rollout.states.len() {
            for &i in &roles {
                if let Some(s) = pose(k, i) {
                    lo = Point2::new(lo.x.min(s.position.x), lo.y.min(s.position.y));
                    hi = Point2::new(hi.x.max(s.position.x), hi.y.max(s.position.y));
                }
            }
        }
        if !(lo.x.is_finite() && hi.x.is_finite()) {
            (lo, hi) = (Point2::new(0.0, 0.0), Point2::new(0.0, 0.0));
        }
        let grow = |a: f64, b: f64| {
            let (a, b) = (a - MARGIN_M, b + MARGIN_M);
            let short = (MIN_EXTENT_M - (b - a)).max(0.0) / 2.0;
            (a - short, b + short)
        };
        let (x0, x1) = grow(lo.x, hi.x);
        let (y0, y1) = grow(lo.y, hi.y);
        let inside =
            |p: &Point2, slack: f64| p.x >= x0 - slack && p.x <= x1 + slack && p.y >= y0 - slack && p.y <= y1 + slack;

        // Agents that ever enter the view, ego and CBV first.
        let mut shown: Vec<usize> = roles.clone();
        shown.extend((0..n_agents).filter(|i| {
            !roles.contains(i)
                && (0..rollout.states.len()).any(|k| pose(k, *i).is_some_and(|s| inside(&s.position, 5.0)))
        }));
        let agents = shown
            .iter()
            .map(|&i| {
                let body = rollout.bodies[i];
                let role = if i == rollout.ego.0 {
                    AnimatedRole::Ego
                } else if Some(i) == rollout.cbv.map(|c| c.0) {
                    AnimatedRole::Cbv
                } else {
                    match body.kind {
                        AgentKind::Vehicle => AnimatedRole::Vehicle,
                        AgentKind::Pedestrian => AnimatedRole::Pedestrian,
                        AgentKind::Cyclist => AnimatedRole::Cyclist,
                        AgentKind::Other => AnimatedRole::Other,
                    }
                };
                AnimatedAgent {
                    id: rollout.agent_ids.get(i).map(|a| a.0.clone()).unwrap_or_else(|| format!("#{i}")),
                    role,
                    length_m: round(body.length_m, 0.01),
                    width_m: round(body.width_m, 0.01),
                }
            })
            .collect();
        let frames = (0..rollout.states.len())
            .map(|k| {
                shown
                    .iter()
                    .map(|&i| {
                        pose(k, i).map(|s| {
                            [round(s.position.x, 0.01), round(s.position.y, 0.01), round(s.heading_rad, 0.001)]
                        })
                    })
                    .collect()
            })
            .collect();
        let index_of = |i: usize| shown.iter().position(|&s| s == i);
        let collisions = rollout
            .collisions
            .iter()
            .filter_map(|c| {
                Some(AnimatedCollision {
                    frame: c.step.checked_sub(rollout.start_step)?,
                    agents: [index_of(c.a.0)?, index_of(c.b.0)?],
                })
            })
            .collect();
        let last = rollout.states.len().saturating_sub(1);
        let initial_frame =
            rollout.ego_collision().and_then(|c| c.step.checked_sub(rollout.start_step)).map_or(last, |k| k.min(last));

        let m = &scenario.map;
        // Map lines with a point near the view: runs of consecutive points
        // near it, so a kilometre-long edge keeps only what is seen.
        let mut map = Vec::new();
        for area in &m.drivable_areas {
            if area.vertices.iter().any(|p| inside(p, 30.0)) {
                let mut closed = area.vertices.clone();
                closed.extend(area.vertices.first().copied());
                // A whole polygon: clipping would open it.
                let points = closed.iter().filter(|p| p.x.is_finite() && p.y.is_finite());
                let points: Vec<[f64; 2]> = points.map(|p| [round(p.x, 0.01), round(p.y, 0.01)]).collect();
                if points.len() >= 3 {
                    map.push(MapLine { kind: MapLineKind::Drivable, points });
                }
            }
        }
        let mut add = |kind: MapLineKind, points: &[Point2]| {
            let near = |p: &Point2| p.x.is_finite() && p.y.is_finite() && inside(p, 30.0);
            let mut run: Vec<[f64; 2]> = Vec::new();
            for (j, p) in points.iter().enumerate() {
                // Keep a point next to a near one too, so segments crossing the border are drawn.
                let keep = near(p) || (j > 0 && near(&points[j - 1])) || points.get(j + 1).is_some_and(near);
                if keep && p.x.is_finite() && p.y.is_finite() {
                    run.push([round(p.x, 0.01), round(p.y, 0.01)]);
                } else if run.len() >= 2 {
                    map.push(MapLine { kind, points: std::mem::take(&mut run) });
                } else {
                    run.clear();
                }
            }
            if run.len() >= 2 {
                map.push(MapLine { kind, points: run });
            }
        };
        for lane in &m.lanes {
            add(MapLineKind::Lane, lane.centreline.points());
        }
        for line in &m.road_lines {
            add(MapLineKind::Line, line.polyline.points());
        }
        for edge in &m.road_edges {
            add(MapLineKind::Edge, edge.polyline.points());
        }

        RolloutAnimation {
            scenario: rollout.scenario_id.clone(),
            dt_s: rollout.dt_s,
            view: [round(x0, 0.01), round(y0, 0.01), round(x1, 0.01), round(y1, 0.01)],
            map,
            agents,
            frames,
            collisions,
            initial_frame,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::test_support::{crossing_rollout, crossing_scenario};

    #[test]
    fn the_crossing_animates_ego_and_cbv_first_with_their_collision() {
        let s = crossing_scenario();
        let r = crossing_rollout(&s);
        let a = RolloutAnimation::of_rollout(&s, &r);
        assert_eq!(a.frames.len(), r.states.len());
        assert_eq!(a.agents[0].role, AnimatedRole::Ego);
        assert_eq!(a.agents[1].role, AnimatedRole::Cbv);
        assert_eq!(a.agents[0].id, "ego-1");
        // The ego meets the CBV at step 39: that frame is shown first.
        assert_eq!(a.initial_frame, 39);
        assert!(a.collisions.iter().any(|c| c.frame == 39 && c.agents == [0, 1]), "{:?}", a.collisions);
        assert_eq!(a.frames[0][0], Some([0.0, -1.75, 0.0]));
        // The view holds both paths with the margin.
        let [x0, y0, x1, y1] = a.view;
        assert!(x0 <= -15.0 && x1 >= 54.0 && y0 <= -45.0 && y1 >= 0.0, "{:?}", a.view);
        assert!(a.map.iter().any(|l| l.kind == MapLineKind::Edge));
        assert!(a.frames.iter().all(|f| f.len() == a.agents.len()));
    }
}
