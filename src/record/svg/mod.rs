//! Top-down SVG pictures of a scenario or a rollout, for a person reviewing
//! a failed planner test.
//!
//! What a picture shows, bottom to top: the map (drivable areas very light,
//! crosswalks hatched, lane centrelines light and dashed, road lines, road
//! edges dark), every agent's trail over the whole run (faint), the ego's
//! and the CBV's paths (solid up to the displayed step, dashed after it,
//! a dot every second), extra trajectories such as a feasibility witness,
//! every agent's footprint at the displayed step with a heading tick (ego
//! blue, CBV orange, agents that have collided outlined red), a marker at
//! each collision point, a scale bar, a caption (scenario, planner, the
//! displayed time, the ego's collision: when and with whom) and a legend.
//!
//! The view is cropped to the ego's and CBV's paths (and extra
//! trajectories) plus a margin, never to the whole map: recorded maps span
//! kilometres and would shrink the conflict to a few pixels.
//!
//! Coordinates are metres with y up in the scenario; the picture flips y
//! so north is up. Pixel coordinates are written with two decimals, and
//! everything is emitted in index order, so the same input gives a
//! byte-identical SVG. Non-finite states and map points are skipped.

mod lfr;

pub use lfr::render_lfr_svg;

use std::collections::BTreeSet;
use std::fmt::{self, Write as _};

use super::NamedTrajectory;
use crate::geometry::{OrientedBox, Point2, Pose2};
use crate::map::{AreaKind, RoadLineKind, RoadMap};
use crate::scenario::{AgentBody, AgentKind, AgentState, RoleOrigin, Scenario, Track, TrackIndex};
use crate::sim::{Rollout, Termination};

/// How a picture is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct SvgOptions {
    /// Scenario step whose footprints are drawn. `None`: for a rollout, the
    /// ego's collision step if it has one, else its last step; for a
    /// scenario, its current step. Clamped into the run.
    pub step: Option<usize>,
    /// Length of the longer side of the map area, pixels.
    pub size_px: u32,
    /// Margin around the ego's and CBV's paths, metres.
    pub margin_m: f64,
    /// Smallest side of the view, metres (a standing ego still gets context).
    pub min_extent_m: f64,
    /// Largest ratio of the view's long side to its short side; a longer
    /// crop is widened on its short side (more context, no distortion).
    pub max_aspect: f64,
    /// Draw every agent's trail, not only the ego's and the CBV's.
    pub all_trails: bool,
}

impl Default for SvgOptions {
    fn default() -> Self {
        Self { step: None, size_px: 1200, margin_m: 15.0, min_extent_m: 60.0, max_aspect: 2.0, all_trails: true }
    }
}

/// Narrowest picture, pixels: the caption and the legend need the room.
const MIN_WIDTH_PX: f64 = 760.0;
/// Height of the caption band, pixels.
const CAPTION_PX: f64 = 54.0;
/// Smallest drawn footprint side, pixels, so pedestrians stay visible.
const MIN_BOX_PX: f64 = 4.0;

// Colours: ego blue and CBV orange are distinguishable for the common
// colour-vision deficiencies; red is kept for collisions only.
const EGO: &str = "#1f6fd1";
const CBV: &str = "#ef8a00";
const COLLISION: &str = "#d62728";
const WITNESS: &str = "#1a9850";
const PLAN: &str = "#7b3294";
const REFERENCE: &str = "#5a5a5a";

const STYLE: &str = "\
.bg{fill:#ffffff}\
.drivable{fill:#eef1f5;stroke:none}\
.crosswalk{fill:url(#hatch);stroke:#b4b4b4;stroke-width:0.8}\
.bump{fill:#f3dfc1;stroke:none}\
.driveway{fill:#f1f1f1;stroke:#dddddd;stroke-width:0.6}\
.lane{fill:none;stroke:#a9bdd3;stroke-width:1;stroke-dasharray:6 4}\
.line{fill:none;stroke:#9a9a9a;stroke-width:1.1}\
.line.yellow{stroke:#d9a400}\
.line.broken{stroke-dasharray:5 5}\
.edge{fill:none;stroke:#3b3b3b;stroke-width:1.8;stroke-linejoin:round}\
.stop{fill:#c0392b;stroke:#ffffff;stroke-width:0.8}\
.trail{fill:none;stroke:#7d8791;stroke-width:1;stroke-opacity:0.45}\
.path{fill:none;stroke-width:2.6;stroke-linejoin:round;stroke-linecap:round}\
.path.after{stroke-width:1.6;stroke-dasharray:5 4;stroke-opacity:0.7}\
.tick{stroke:none}\
.box{stroke-width:1.1;stroke-linejoin:round}\
.box.vehicle{fill:#c3c8ce;stroke:#59616b}\
.box.pedestrian{fill:#cdb9e8;stroke:#5f4596}\
.box.cyclist{fill:#a8dcc8;stroke:#23795c}\
.box.other{fill:#dedbd2;stroke:#7a7568}\
.head{stroke:none}\
.box.ego{fill:#1f6fd1;stroke:#0b3a78;stroke-width:1.6}\
.box.cbv{fill:#ef8a00;stroke:#8a4f00;stroke-width:1.6}\
.box.collided{stroke:#d62728;stroke-width:3}\
.ghost{fill-opacity:0.12;stroke-width:1.6;stroke-dasharray:4 3}\
.extra{fill:none;stroke-width:2.2;stroke-dasharray:7 4;stroke-linecap:round}\
.marker{fill:#ffffff;fill-opacity:0.8;stroke:#d62728;stroke-width:2.4}\
.label{font-size:13px;font-weight:bold;paint-order:stroke;stroke:#ffffff;stroke-width:3.5px;stroke-linejoin:round}\
.caption{font-size:15px;font-weight:bold;fill:#1b1b1b}\
.sub{font-size:13px;fill:#333333}\
.legend{font-size:12px;fill:#333333}\
.scale{stroke:#222222;stroke-width:1.6;fill:none}\
.band{fill:#f7f7f7;stroke:#d0d0d0;stroke-width:1}";

/// Who an agent is in the picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Ego,
    Cbv,
    Other,
}

/// States of a scenario (track-major) or a rollout (step-major), read
/// through one accessor that drops non-finite states.
enum StateTable<'a> {
    Tracks(&'a [Track]),
    Steps(&'a [Vec<Option<AgentState>>]),
}

impl StateTable<'_> {
    fn get(&self, k: usize, i: usize) -> Option<&AgentState> {
        let s = match self {
            Self::Tracks(t) => t.get(i)?.states.get(k)?.as_ref()?,
            Self::Steps(s) => s.get(k)?.get(i)?.as_ref()?,
        };
        let finite = s.position.x.is_finite() && s.position.y.is_finite() && s.heading_rad.is_finite();
        finite.then_some(s)
    }

    fn num_steps(&self) -> usize {
        match self {
            Self::Tracks(t) => t.iter().map(|t| t.states.len()).max().unwrap_or(0),
            Self::Steps(s) => s.len(),
        }
    }
}

struct Agent<'a> {
    id: &'a str,
    body: AgentBody,
    role: Role,
}

struct Collision {
    /// Index into the state table.
    k: usize,
    a: usize,
    b: usize,
}

/// Everything a picture needs, from either a scenario or a rollout.
struct Picture<'a> {
    title: String,
    map: &'a RoadMap,
    agents: Vec<Agent<'a>>,
    states: StateTable<'a>,
    dt_s: f64,
    /// Index of the displayed step in the state table.
    shown: usize,
    collisions: Vec<Collision>,
    extras: &'a [NamedTrajectory],
    caption: [String; 2],
}

/// The picture of a scenario without a rollout.
pub(super) fn render_scenario(scenario: &Scenario, opts: &SvgOptions) -> String {
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
    draw(
        &Picture {
            title: format!("scenario {}", scenario.id),
            map: &scenario.map,
            agents,
            states,
            dt_s: scenario.dt_s,
            shown,
            collisions: Vec::new(),
            extras: &[],
            caption: [line1, line2],
        },
        opts,
    )
}

/// The picture of a rollout, with extra trajectories.
pub(super) fn render_rollout(
    scenario: &Scenario,
    rollout: &Rollout,
    extras: &[NamedTrajectory],
    opts: &SvgOptions,
) -> String {
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
    let collisions =
        rollout.collisions.iter().filter_map(|c| Some(Collision { k: to_k(c.step)?, a: c.a.0, b: c.b.0 })).collect();
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
        Termination::InvalidAgentState { step, agent, reason } => {
            let when = to_k(*step).map_or_else(|| "?".to_string(), |k| time_text(k, rollout.dt_s));
            let _ = write!(line2, " · aborted at {when}: agent {agent}: {reason}");
        }
        Termination::Completed | Termination::EgoCollision { .. } => {}
    }
    draw(
        &Picture {
            title: format!("rollout of scenario {} with planner {}", rollout.scenario_id, rollout.planner),
            map: &scenario.map,
            agents,
            states,
            dt_s: rollout.dt_s,
            shown,
            collisions,
            extras,
            caption: [line1, line2],
        },
        opts,
    )
}

fn role_of(i: usize, ego: Option<TrackIndex>, cbv: Option<TrackIndex>) -> Role {
    if ego == Some(TrackIndex(i)) {
        Role::Ego
    } else if cbv == Some(TrackIndex(i)) {
        Role::Cbv
    } else {
        Role::Other
    }
}

fn kind_name(kind: AgentKind) -> &'static str {
    match kind {
        AgentKind::Vehicle => "vehicle",
        AgentKind::Pedestrian => "pedestrian",
        AgentKind::Cyclist => "cyclist",
        AgentKind::Other => "other",
    }
}

/// "t = 4.7 s", or the step alone where the step length is unusable.
fn time_text(k: usize, dt_s: f64) -> String {
    let t = k as f64 * dt_s;
    if t.is_finite() { format!("t = {t:.1} s") } else { format!("step {k}") }
}

/// A number with two decimals, never `-0.00`, never `NaN` (callers skip
/// non-finite values; this is the last guard).
struct N(f64);

impl fmt::Display for N {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = if self.0.is_finite() && self.0.abs() >= 0.005 { self.0 } else { 0.0 };
        write!(f, "{v:.2}")
    }
}

/// Escapes text for XML content and attribute values.
fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // Control characters are not allowed in XML 1.0.
            c if (c as u32) < 0x20 && !matches!(c, '\t' | '\n' | '\r') => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

/// An axis-aligned box in metres; empty until something is included.
#[derive(Debug, Clone, Copy)]
struct Bounds {
    lo: Point2,
    hi: Point2,
}

impl Bounds {
    fn empty() -> Self {
        Self { lo: Point2::new(f64::INFINITY, f64::INFINITY), hi: Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY) }
    }

    fn is_empty(&self) -> bool {
        !(self.lo.x <= self.hi.x && self.lo.y <= self.hi.y)
    }

    fn include(&mut self, p: &Point2, r: f64) {
        if p.x.is_finite() && p.y.is_finite() && r.is_finite() {
            self.lo = Point2::new(self.lo.x.min(p.x - r), self.lo.y.min(p.y - r));
            self.hi = Point2::new(self.hi.x.max(p.x + r), self.hi.y.max(p.y + r));
        }
    }

    fn of_points<'p>(pts: impl IntoIterator<Item = &'p Point2>) -> Self {
        let mut b = Self::empty();
        for p in pts {
            b.include(p, 0.0);
        }
        b
    }

    fn intersects(&self, other: &Bounds) -> bool {
        !self.is_empty()
            && !other.is_empty()
            && self.lo.x <= other.hi.x
            && other.lo.x <= self.hi.x
            && self.lo.y <= other.hi.y
            && other.lo.y <= self.hi.y
    }

    fn width(&self) -> f64 {
        self.hi.x - self.lo.x
    }

    fn height(&self) -> f64 {
        self.hi.y - self.lo.y
    }

    /// Grows the box symmetrically to at least `w` × `h`.
    fn grow_to(&mut self, w: f64, h: f64) {
        let dx = (w - self.width()).max(0.0) * 0.5;
        let dy = (h - self.height()).max(0.0) * 0.5;
        self.lo = Point2::new(self.lo.x - dx, self.lo.y - dy);
        self.hi = Point2::new(self.hi.x + dx, self.hi.y + dy);
    }
}

/// Metres to pixels: y flipped, map band below the caption.
struct View {
    bounds: Bounds,
    scale: f64,
    top: f64,
    width: f64,
    height: f64,
}

impl View {
    fn px(&self, p: &Point2) -> (f64, f64) {
        ((p.x - self.bounds.lo.x) * self.scale, self.top + (self.bounds.hi.y - p.y) * self.scale)
    }

    /// `points` attribute text for a polyline, dropping points closer than
    /// half a pixel to the last one kept (smaller files, same picture).
    fn points(&self, pts: &[Point2]) -> String {
        let mut out = String::new();
        let mut last: Option<(f64, f64)> = None;
        for (i, p) in pts.iter().enumerate() {
            if !(p.x.is_finite() && p.y.is_finite()) {
                continue;
            }
            let q = self.px(p);
            let keep = match last {
                None => true,
                Some(l) => i + 1 == pts.len() || (q.0 - l.0).hypot(q.1 - l.1) >= 0.5,
            };
            if keep {
                if !out.is_empty() {
                    out.push(' ');
                }
                let _ = write!(out, "{},{}", N(q.0), N(q.1));
                last = Some(q);
            }
        }
        out
    }
}

/// Steps of ego and CBV path kept in view before and after the ego's
/// collision: on a long road the whole paths would shrink the crash to a dot.
const COLLISION_WINDOW_BEFORE: usize = 20;
const COLLISION_WINDOW_AFTER: usize = 10;

/// The view: ego and CBV paths (around the ego's collision, when one is
/// shown), extra trajectories and the ego's collision partners, plus margin,
/// at least `min_extent_m`, at most `max_aspect`.
fn focus(pic: &Picture, opts: &SvgOptions) -> Bounds {
    let mut b = Bounds::empty();
    let n = pic.states.num_steps();
    let is_ego = |i: usize| pic.agents.get(i).is_some_and(|a| a.role == Role::Ego);
    let ego_collision =
        pic.collisions.iter().filter(|c| c.k <= pic.shown && (is_ego(c.a) || is_ego(c.b))).map(|c| c.k).min();
    let steps = match ego_collision {
        Some(k) => k.saturating_sub(COLLISION_WINDOW_BEFORE)..(k + COLLISION_WINDOW_AFTER + 1).min(n),
        None => 0..n,
    };
    for (i, a) in pic.agents.iter().enumerate() {
        if a.role == Role::Other {
            continue;
        }
        let r = radius(&a.body);
        for k in steps.clone() {
            if let Some(s) = pic.states.get(k, i) {
                b.include(&s.position, r);
            }
        }
    }
    for e in pic.extras {
        let r = e.body.as_ref().map_or(1.0, radius);
        for p in &e.poses {
            b.include(&p.pose.position, r);
        }
    }
    // The ego's collision partners, where they hit it and where they are shown.
    for c in pic.collisions.iter().filter(|c| c.k <= pic.shown && (is_ego(c.a) || is_ego(c.b))) {
        for i in [c.a, c.b] {
            let Some(a) = pic.agents.get(i) else { continue };
            for k in [c.k, pic.shown] {
                if let Some(s) = pic.states.get(k, i) {
                    b.include(&s.position, radius(&a.body));
                }
            }
        }
    }
    if b.is_empty() {
        // No ego or CBV to follow: everyone present at the displayed step.
        for (i, a) in pic.agents.iter().enumerate() {
            if let Some(s) = pic.states.get(pic.shown, i) {
                b.include(&s.position, radius(&a.body));
            }
        }
    }
    if b.is_empty() {
        for l in &pic.map.lanes {
            for p in l.centreline.points() {
                b.include(p, 0.0);
            }
        }
        for e in &pic.map.road_edges {
            for p in e.polyline.points() {
                b.include(p, 0.0);
            }
        }
    }
    if b.is_empty() {
        b.include(&Point2::origin(), 0.0);
    }
    let margin = if opts.margin_m.is_finite() { opts.margin_m.max(0.0) } else { 0.0 };
    b.grow_to(b.width() + 2.0 * margin, b.height() + 2.0 * margin);
    let min_extent = if opts.min_extent_m.is_finite() { opts.min_extent_m.max(1.0) } else { 1.0 };
    b.grow_to(min_extent, min_extent);
    let aspect = if opts.max_aspect.is_finite() { opts.max_aspect.max(1.0) } else { 2.0 };
    b.grow_to(b.height() / aspect, b.width() / aspect);
    b
}

fn radius(body: &AgentBody) -> f64 {
    let r = 0.5 * body.length_m.hypot(body.width_m);
    if r.is_finite() { r } else { 0.0 }
}

/// Runs of consecutive valid positions of agent `i` over `range`.
fn runs(pic: &Picture, i: usize, range: std::ops::Range<usize>) -> Vec<Vec<Point2>> {
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

/// The overlap of two footprints (Sutherland–Hodgman on convex quads),
/// its centroid being the collision point; `None` when they only touch.
fn overlap_centroid(a: &OrientedBox, b: &OrientedBox) -> Option<Point2> {
    let mut poly: Vec<Point2> = a.corners().to_vec();
    let clip = b.corners();
    for e in 0..4 {
        let (p, q) = (clip[e], clip[(e + 1) % 4]);
        // Corners are counter-clockwise, so inside is to the left of p→q.
        let side = |x: &Point2| (q.x - p.x) * (x.y - p.y) - (q.y - p.y) * (x.x - p.x);
        let input = std::mem::take(&mut poly);
        for j in 0..input.len() {
            let (cur, prev) = (input[j], input[(j + input.len() - 1) % input.len()]);
            let (sc, sp) = (side(&cur), side(&prev));
            if sc >= 0.0 {
                if sp < 0.0 {
                    poly.push(prev + (cur - prev) * (sp / (sp - sc)));
                }
                poly.push(cur);
            } else if sp >= 0.0 {
                poly.push(prev + (cur - prev) * (sp / (sp - sc)));
            }
        }
        if poly.is_empty() {
            return None;
        }
    }
    let n = poly.len() as f64;
    let c = Point2::new(poly.iter().map(|p| p.x).sum::<f64>() / n, poly.iter().map(|p| p.y).sum::<f64>() / n);
    (c.x.is_finite() && c.y.is_finite()).then_some(c)
}

fn collision_point(pic: &Picture, c: &Collision) -> Option<Point2> {
    let footprint = |i: usize| {
        let s = pic.states.get(c.k, i)?;
        let body = pic.agents.get(i)?.body;
        Some(OrientedBox::new(s.pose(), body.length_m, body.width_m))
    };
    Some(contact_point(&footprint(c.a)?, &footprint(c.b)?))
}

/// Where two colliding footprints meet: the centroid of their overlap, or
/// the midpoint of their centres when they only touch.
pub(super) fn contact_point(a: &OrientedBox, b: &OrientedBox) -> Point2 {
    overlap_centroid(a, b).unwrap_or_else(|| nalgebra::center(&a.pose.position, &b.pose.position))
}

fn extra_colour(e: &NamedTrajectory) -> &'static str {
    match e.role {
        super::TrajectoryRole::FeasibilityWitness => WITNESS,
        super::TrajectoryRole::EgoPlan => PLAN,
        super::TrajectoryRole::Reference => REFERENCE,
    }
}

/// A footprint in pixels.
struct BoxPx {
    /// `points` text of the outline.
    outline: String,
    /// `points` text of the heading arrowhead in the front third.
    head: String,
    /// Pixel extent, for placing labels around it.
    extent: Rect,
}

fn points_text(view: &View, pts: &[Point2]) -> String {
    let mut out = String::new();
    for (j, c) in pts.iter().enumerate() {
        let q = view.px(c);
        if j > 0 {
            out.push(' ');
        }
        let _ = write!(out, "{},{}", N(q.0), N(q.1));
    }
    out
}

/// The footprint at `pose`, at least [`MIN_BOX_PX`] on each side so small
/// agents stay visible; `None` for a non-finite size.
fn box_px(view: &View, pose: &Pose2, body: &AgentBody) -> Option<BoxPx> {
    let (l, w) = (body.length_m, body.width_m);
    if !(l.is_finite() && w.is_finite()) {
        return None;
    }
    let (l, w) = ((l * view.scale).max(MIN_BOX_PX) / view.scale, (w * view.scale).max(MIN_BOX_PX) / view.scale);
    let corners = OrientedBox::new(*pose, l, w).corners();
    let at = |x: f64, y: f64| pose.from_body(&crate::geometry::Vector2::new(x, y));
    let back = 0.5 * l - (0.22 * l).min(1.2);
    let head = [at(0.5 * l, 0.0), at(back, 0.25 * w), at(back, -0.25 * w)];
    let px: Vec<(f64, f64)> = corners.iter().map(|c| view.px(c)).collect();
    Some(BoxPx { outline: points_text(view, &corners), head: points_text(view, &head), extent: Rect::around(&px) })
}

fn draw(pic: &Picture, opts: &SvgOptions) -> String {
    let mut bounds = focus(pic, opts);
    let size = f64::from(opts.size_px.max(100));
    let mut scale = size / bounds.width().max(bounds.height());
    if !(scale.is_finite() && scale > 0.0) {
        scale = 1.0;
    }
    // Widen narrow views instead of squeezing the caption and legend.
    bounds.grow_to(MIN_WIDTH_PX / scale, 0.0);
    let width = (bounds.width() * scale).round();
    let map_h = (bounds.height() * scale).round();
    let view = View { bounds, scale, top: CAPTION_PX, width, height: map_h };
    let legend = legend_items(pic, &view.bounds);
    let legend_rows = layout_legend(&legend, width);
    let legend_h = 14.0 + 22.0 * legend_rows.iter().map(|r| r.1 + 1).max().unwrap_or(0) as f64;
    let height = CAPTION_PX + map_h + legend_h;

    let mut s = String::with_capacity(256 * 1024);
    let _ = write!(
        s,
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" \
         height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\">\n\
         <title>{title}</title>\n<defs>\n<style>{STYLE}</style>\n\
         <clipPath id=\"map-clip\"><rect x=\"0\" y=\"{top}\" width=\"{w}\" height=\"{mh}\"/></clipPath>\n\
         <pattern id=\"hatch\" patternUnits=\"userSpaceOnUse\" width=\"6\" height=\"6\" \
         patternTransform=\"rotate(45)\"><rect width=\"6\" height=\"6\" fill=\"#f4f4f4\"/>\
         <line x1=\"0\" y1=\"0\" x2=\"0\" y2=\"6\" stroke=\"#bdbdbd\" stroke-width=\"2.5\"/></pattern>\n</defs>\n",
        w = N(width),
        h = N(height),
        title = esc(&pic.title),
        top = N(CAPTION_PX),
        mh = N(map_h),
    );
    let _ = writeln!(s, "<rect class=\"bg\" x=\"0\" y=\"0\" width=\"{}\" height=\"{}\"/>", N(width), N(height));
    let _ = writeln!(s, "<g clip-path=\"url(#map-clip)\">");
    draw_map(&mut s, pic.map, &view);
    draw_trails(&mut s, pic, &view, opts);
    draw_extras(&mut s, pic, &view);
    let (mut taken, mut labels) = draw_agents(&mut s, pic, &view);
    let (markers, collision_labels) = draw_collisions(&mut s, pic, &view);
    taken.extend(markers);
    // Role labels first, then collision times, then other agents' ids.
    let roles = labels.iter().take_while(|l| l.colour != COLLISION).count();
    let others = labels.split_off(roles);
    labels.extend(collision_labels);
    labels.extend(others);
    place_labels(&mut s, &view, &labels, taken);
    let _ = writeln!(s, "</g>");
    draw_scale_bar(&mut s, &view);
    // Caption band on top, legend band below the map: neither hides the scene.
    let _ = writeln!(
        s,
        "<rect class=\"band\" x=\"0.5\" y=\"0.5\" width=\"{}\" height=\"{}\"/>\n\
         <text class=\"caption\" x=\"10\" y=\"22\">{}</text>\n<text class=\"sub\" x=\"10\" y=\"43\">{}</text>",
        N(width - 1.0),
        N(CAPTION_PX - 1.0),
        esc(&pic.caption[0]),
        esc(&pic.caption[1])
    );
    draw_legend(&mut s, &legend, &legend_rows, CAPTION_PX + map_h, width, legend_h);
    s.push_str("</svg>\n");
    s
}

fn draw_map(s: &mut String, map: &RoadMap, view: &View) {
    // A little slack so lines leaving the view are still drawn to its edge.
    let mut visible = view.bounds;
    visible.grow_to(view.bounds.width() + 20.0, view.bounds.height() + 20.0);
    let poly = |s: &mut String, class: &str, pts: &[Point2]| {
        if pts.len() >= 3 && Bounds::of_points(pts).intersects(&visible) {
            let _ = writeln!(s, "<polygon class=\"{class}\" points=\"{}\"/>", view.points(pts));
        }
    };
    let line = |s: &mut String, class: &str, pts: &[Point2]| {
        if pts.len() >= 2 && Bounds::of_points(pts).intersects(&visible) {
            let _ = writeln!(s, "<polyline class=\"{class}\" points=\"{}\"/>", view.points(pts));
        }
    };
    for a in &map.drivable_areas {
        poly(s, "drivable", &a.vertices);
    }
    for a in &map.areas {
        let class = match a.kind {
            AreaKind::Crosswalk => "crosswalk",
            AreaKind::SpeedBump => "bump",
            AreaKind::Driveway => "driveway",
        };
        poly(s, class, &a.polygon.vertices);
    }
    for l in &map.lanes {
        line(s, "lane", l.centreline.points());
    }
    for l in &map.road_lines {
        use RoadLineKind as K;
        let class = match l.kind {
            K::BrokenSingleWhite => "line broken",
            K::SolidSingleWhite | K::SolidDoubleWhite | K::Unknown => "line",
            K::BrokenSingleYellow | K::BrokenDoubleYellow => "line yellow broken",
            K::SolidSingleYellow | K::SolidDoubleYellow | K::PassingDoubleYellow => "line yellow",
        };
        line(s, class, l.polyline.points());
    }
    for e in &map.road_edges {
        line(s, "edge", e.polyline.points());
    }
    for st in &map.stop_signs {
        let p = st.position;
        if p.x.is_finite() && p.y.is_finite() && Bounds::of_points([&p]).intersects(&visible) {
            let (x, y) = view.px(&p);
            let _ = writeln!(s, "<circle class=\"stop\" cx=\"{}\" cy=\"{}\" r=\"3.5\"/>", N(x), N(y));
        }
    }
}

fn role_class(role: Role) -> &'static str {
    match role {
        Role::Ego => "ego",
        Role::Cbv => "cbv",
        Role::Other => "other",
    }
}

fn role_colour(role: Role) -> &'static str {
    match role {
        Role::Ego => EGO,
        Role::Cbv => CBV,
        Role::Other => "#7d8791",
    }
}

fn draw_trails(s: &mut String, pic: &Picture, view: &View, opts: &SvgOptions) {
    let n = pic.states.num_steps();
    let mut visible = view.bounds;
    visible.grow_to(view.bounds.width() + 20.0, view.bounds.height() + 20.0);
    if opts.all_trails {
        for (i, a) in pic.agents.iter().enumerate() {
            if a.role != Role::Other {
                continue;
            }
            for run in runs(pic, i, 0..n) {
                if run.len() >= 2 && Bounds::of_points(&run).intersects(&visible) {
                    let _ = writeln!(s, "<polyline class=\"trail\" points=\"{}\"/>", view.points(&run));
                }
            }
        }
    }
    // CBV first, ego on top: the ego's path is what the reviewer follows.
    for role in [Role::Cbv, Role::Ego] {
        for (i, a) in pic.agents.iter().enumerate().filter(|(_, a)| a.role == role) {
            let colour = role_colour(a.role);
            let class = role_class(a.role);
            let split = (pic.shown + 1).min(n);
            // The part after the displayed step starts at it, so the two parts join.
            for run in runs(pic, i, pic.shown.min(n)..n) {
                if run.len() >= 2 {
                    let _ = writeln!(
                        s,
                        "<polyline class=\"path after {class}\" stroke=\"{colour}\" points=\"{}\"/>",
                        view.points(&run)
                    );
                }
            }
            for run in runs(pic, i, 0..split) {
                if run.len() >= 2 {
                    let _ = writeln!(
                        s,
                        "<polyline class=\"path {class}\" stroke=\"{colour}\" points=\"{}\"/>",
                        view.points(&run)
                    );
                }
            }
            // A dot every second shows speed along the path.
            let every =
                if pic.dt_s.is_finite() && pic.dt_s > 0.0 { (1.0 / pic.dt_s).round().max(1.0) as usize } else { 10 };
            for k in (0..n).step_by(every) {
                if let Some(st) = pic.states.get(k, i) {
                    let (x, y) = view.px(&st.position);
                    let _ = writeln!(
                        s,
                        "<circle class=\"tick {class}\" fill=\"{colour}\" cx=\"{}\" cy=\"{}\" r=\"2\"/>",
                        N(x),
                        N(y)
                    );
                }
            }
        }
    }
}

fn draw_extras(s: &mut String, pic: &Picture, view: &View) {
    let t_shown = pic.shown as f64 * pic.dt_s;
    for e in pic.extras {
        let colour = extra_colour(e);
        let pts: Vec<Point2> = e
            .poses
            .iter()
            .filter(|p| p.time_s.is_finite() && p.pose.heading_rad.is_finite())
            .map(|p| p.pose.position)
            .collect();
        if pts.len() >= 2 {
            let _ = writeln!(
                s,
                "<polyline class=\"extra\" stroke=\"{colour}\" points=\"{}\"><title>{}</title></polyline>",
                view.points(&pts),
                esc(&e.name)
            );
        }
        let Some(pose) = e.pose_at(t_shown) else { continue };
        match e.body.as_ref().and_then(|b| box_px(view, &pose, b)) {
            Some(b) => {
                let _ = writeln!(
                    s,
                    "<polygon class=\"ghost\" fill=\"{colour}\" stroke=\"{colour}\" points=\"{}\"/>",
                    b.outline
                );
            }
            None => {
                let (x, y) = view.px(&pose.position);
                let _ = writeln!(
                    s,
                    "<circle class=\"ghost\" fill=\"{colour}\" stroke=\"{colour}\" cx=\"{}\" cy=\"{}\" r=\"4\"/>",
                    N(x),
                    N(y)
                );
            }
        }
    }
}

fn involves_role(pic: &Picture, i: usize) -> bool {
    pic.agents.get(i).is_some_and(|a| a.role != Role::Other)
}

/// Agents that have collided at or before the displayed step.
fn collided(pic: &Picture) -> BTreeSet<usize> {
    pic.collisions.iter().filter(|c| c.k <= pic.shown).flat_map(|c| [c.a, c.b]).collect()
}

/// A pixel rectangle: a footprint's or marker's extent, or a label's.
#[derive(Debug, Clone, Copy)]
struct Rect {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

impl Rect {
    fn around(points: &[(f64, f64)]) -> Self {
        let mut r = Rect { x0: f64::INFINITY, y0: f64::INFINITY, x1: f64::NEG_INFINITY, y1: f64::NEG_INFINITY };
        for &(x, y) in points {
            r = Rect { x0: r.x0.min(x), y0: r.y0.min(y), x1: r.x1.max(x), y1: r.y1.max(y) };
        }
        r
    }

    fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    fn inside(&self, o: &Rect) -> bool {
        self.x0 >= o.x0 && self.x1 <= o.x1 && self.y0 >= o.y0 && self.y1 <= o.y1
    }
}

/// A label to place next to `anchor`.
struct LabelRequest {
    anchor: Rect,
    text: String,
    colour: &'static str,
}

/// Draws the footprints; returns their extents (for label placement) and
/// the labels they want, most important first.
fn draw_agents(s: &mut String, pic: &Picture, view: &View) -> (Vec<Rect>, Vec<LabelRequest>) {
    let collided = collided(pic);
    // Others that hit the ego or CBV get their id; background collisions
    // only their red outline (a busy crosswalk would be unreadable).
    let hit_role: BTreeSet<usize> = pic
        .collisions
        .iter()
        .filter(|c| c.k <= pic.shown && (involves_role(pic, c.a) || involves_role(pic, c.b)))
        .flat_map(|c| [c.a, c.b])
        .collect();
    let mut extents = Vec::new();
    let mut role_labels = Vec::new();
    let mut other_labels = Vec::new();
    // Others first, then CBV, then ego, so the roles are never hidden.
    for role in [Role::Other, Role::Cbv, Role::Ego] {
        for (i, a) in pic.agents.iter().enumerate().filter(|(_, a)| a.role == role) {
            let Some(st) = pic.states.get(pic.shown, i) else { continue };
            let Some(b) = box_px(view, &st.pose(), &a.body) else { continue };
            let kind = kind_name(a.body.kind);
            let hit = collided.contains(&i);
            let class = match (role, hit) {
                (Role::Other, false) => format!("box {kind}"),
                (Role::Other, true) => format!("box {kind} collided"),
                (_, false) => format!("box {}", role_class(role)),
                (_, true) => format!("box {} collided", role_class(role)),
            };
            let head = match role {
                Role::Other => "#7a828c",
                _ => "#ffffff",
            };
            let _ = writeln!(
                s,
                "<g><title>{kind} {} ({:.1} m/s)</title><polygon class=\"{class}\" points=\"{}\"/>\
                 <polygon class=\"head\" fill=\"{head}\" points=\"{}\"/></g>",
                esc(a.id),
                st.speed_mps(),
                b.outline,
                b.head
            );
            extents.push(b.extent);
            let request = |text: &str, colour| LabelRequest { anchor: b.extent, text: text.to_string(), colour };
            match role {
                Role::Ego => role_labels.insert(0, request("ego", EGO)),
                Role::Cbv => role_labels.push(request("CBV", CBV)),
                Role::Other if hit_role.contains(&i) => other_labels.push(request(a.id, COLLISION)),
                Role::Other => {}
            }
        }
    }
    role_labels.extend(other_labels);
    (extents, role_labels)
}

/// Draws a marker at each collision up to the displayed step; returns the
/// markers' extents and the time labels of the ego's and CBV's collisions.
fn draw_collisions(s: &mut String, pic: &Picture, view: &View) -> (Vec<Rect>, Vec<LabelRequest>) {
    let mut extents = Vec::new();
    let mut labels = Vec::new();
    for c in pic.collisions.iter().filter(|c| c.k <= pic.shown) {
        let Some(p) = collision_point(pic, c) else { continue };
        let (x, y) = view.px(&p);
        let main = involves_role(pic, c.a) || involves_role(pic, c.b);
        let (r, d) = if main { (9.0, 5.0) } else { (5.0, 3.0) };
        let _ = writeln!(
            s,
            "<g class=\"collision\"><title>collision of {} and {} at {}</title>\
             <circle class=\"marker\" cx=\"{}\" cy=\"{}\" r=\"{}\"/>\
             <path class=\"marker\" d=\"M{},{} L{},{} M{},{} L{},{}\"/></g>",
            esc(pic.agents.get(c.a).map_or("?", |a| a.id)),
            esc(pic.agents.get(c.b).map_or("?", |a| a.id)),
            time_text(c.k, pic.dt_s),
            N(x),
            N(y),
            N(r),
            N(x - d),
            N(y - d),
            N(x + d),
            N(y + d),
            N(x - d),
            N(y + d),
            N(x + d),
            N(y - d),
        );
        let extent = Rect { x0: x - r, y0: y - r, x1: x + r, y1: y + r };
        extents.push(extent);
        if main {
            labels.push(LabelRequest { anchor: extent, text: time_text(c.k, pic.dt_s), colour: COLLISION });
        }
    }
    (extents, labels)
}

/// Places each label at the first spot around its anchor that stays in the
/// map band and overlaps no footprint, marker or earlier label (greedy, in
/// request order, so the result is deterministic); falls back to the
/// first spot.
fn place_labels(s: &mut String, view: &View, requests: &[LabelRequest], mut taken: Vec<Rect>) {
    let band = Rect { x0: 0.0, y0: view.top, x1: view.width, y1: view.top + view.height };
    for r in requests {
        // Bold 13 px sans-serif: about 8.5 px per character.
        let (w, h) = (8.5 * r.text.chars().count() as f64 + 2.0, 13.0);
        let a = r.anchor;
        let (xc, yc) = (0.5 * (a.x0 + a.x1), 0.5 * (a.y0 + a.y1));
        let at = |x: f64, y: f64| Rect { x0: x, y0: y, x1: x + w, y1: y + h };
        let mut candidates = Vec::new();
        for g in [4.0, 16.0, 32.0] {
            candidates.extend([
                at(a.x1 + g, yc - 0.5 * h),
                at(a.x0 - g - w, yc - 0.5 * h),
                at(xc - 0.5 * w, a.y0 - g - h),
                at(xc - 0.5 * w, a.y1 + g),
                at(a.x1 + g, a.y0 - g - h),
                at(a.x1 + g, a.y1 + g),
                at(a.x0 - g - w, a.y0 - g - h),
                at(a.x0 - g - w, a.y1 + g),
            ]);
        }
        let chosen = candidates
            .iter()
            .find(|c| c.inside(&band) && !taken.iter().any(|t| t.overlaps(c)))
            .copied()
            .unwrap_or(candidates[0]);
        taken.push(chosen);
        let _ = writeln!(
            s,
            "<text class=\"label\" fill=\"{}\" x=\"{}\" y=\"{}\">{}</text>",
            r.colour,
            N(chosen.x0 + 1.0),
            N(chosen.y1 - 2.0),
            esc(&r.text)
        );
    }
}

/// A bar of a round length (1, 2 or 5 × 10ⁿ m) about a sixth of the width.
fn draw_scale_bar(s: &mut String, view: &View) {
    let target = view.width / view.scale / 6.0;
    if !(target.is_finite() && target > 0.0) {
        return;
    }
    let p = 10f64.powf((target * (1.0 + 1e-9)).log10().floor());
    let len_m = [5.0, 2.0, 1.0].into_iter().map(|m| m * p).find(|l| *l <= target).unwrap_or(p);
    let len_px = len_m * view.scale;
    let (x0, y) = (14.0, view.top + view.height - 16.0);
    let _ = writeln!(
        s,
        "<g><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"22\" fill=\"#ffffff\" fill-opacity=\"0.85\"/>\
         <path class=\"scale\" d=\"M{},{} V{} H{} V{}\"/><text class=\"legend\" x=\"{}\" y=\"{}\">{} m</text></g>",
        N(x0 - 6.0),
        N(y - 14.0),
        N(len_px + 52.0),
        N(x0),
        N(y - 6.0),
        N(y),
        N(x0 + len_px),
        N(y - 6.0),
        N(x0 + len_px + 6.0),
        N(y + 1.0),
        if len_m >= 1.0 { format!("{len_m:.0}") } else { format!("{len_m}") }
    );
}

/// What a legend entry's swatch looks like.
enum Swatch {
    Box(&'static str),
    Line(&'static str, &'static str),
    Marker,
}

/// Legend entries for what the picture shows (agent kinds only where one
/// is in `view`).
fn legend_items(pic: &Picture, view: &Bounds) -> Vec<(Swatch, String)> {
    let mut items = Vec::new();
    let id_of = |role: Role| pic.agents.iter().find(|a| a.role == role).map(|a| a.id);
    if let Some(id) = id_of(Role::Ego) {
        items.push((Swatch::Box("box ego"), format!("ego ({id})")));
    }
    if let Some(id) = id_of(Role::Cbv) {
        items.push((Swatch::Box("box cbv"), format!("CBV ({id})")));
    }
    let kinds: BTreeSet<AgentKind> = pic
        .agents
        .iter()
        .enumerate()
        .filter(|(i, a)| {
            a.role == Role::Other
                && pic.states.get(pic.shown, *i).is_some_and(|s| Bounds::of_points([&s.position]).intersects(view))
        })
        .map(|(_, a)| a.body.kind)
        .collect();
    for k in kinds {
        let class = match k {
            AgentKind::Vehicle => "box vehicle",
            AgentKind::Pedestrian => "box pedestrian",
            AgentKind::Cyclist => "box cyclist",
            AgentKind::Other => "box other",
        };
        items.push((Swatch::Box(class), kind_name(k).to_string()));
    }
    if pic.collisions.iter().any(|c| c.k <= pic.shown) {
        items.push((Swatch::Box("box vehicle collided"), "collided".into()));
        items.push((Swatch::Marker, "collision point".into()));
    }
    items.push((Swatch::Line("path", EGO), "path so far".into()));
    items.push((Swatch::Line("path after", EGO), "path after shown step".into()));
    for e in pic.extras {
        items.push((Swatch::Line("extra", extra_colour(e)), format!("{}: {}", e.role.label(), e.name)));
    }
    items.push((Swatch::Line("edge", ""), "road edge".into()));
    items.push((Swatch::Line("lane", ""), "lane centreline".into()));
    if !pic.map.road_lines.is_empty() {
        items.push((Swatch::Line("line", ""), "road line".into()));
    }
    if pic.map.areas.iter().any(|a| a.kind == AreaKind::Crosswalk) {
        items.push((Swatch::Box("crosswalk"), "crosswalk".into()));
    }
    items
}

/// Row and x of every legend entry, wrapped to the picture's width.
fn layout_legend(items: &[(Swatch, String)], width: f64) -> Vec<(f64, usize)> {
    let mut out = Vec::with_capacity(items.len());
    let (mut x, mut row) = (10.0, 0usize);
    for (_, text) in items {
        // 7 px per character is a safe estimate for 12 px sans-serif.
        let w = 34.0 + 7.0 * text.chars().count() as f64 + 14.0;
        if x + w > width - 10.0 && x > 10.0 {
            x = 10.0;
            row += 1;
        }
        out.push((x, row));
        x += w;
    }
    out
}

fn draw_legend(s: &mut String, items: &[(Swatch, String)], rows: &[(f64, usize)], top: f64, width: f64, h: f64) {
    let _ = writeln!(
        s,
        "<g class=\"legend-band\"><rect class=\"band\" x=\"0.5\" y=\"{}\" width=\"{}\" height=\"{}\"/>",
        N(top + 0.5),
        N(width - 1.0),
        N(h - 1.0)
    );
    for ((swatch, text), (x, row)) in items.iter().zip(rows) {
        let y = top + 18.0 + 22.0 * *row as f64;
        match swatch {
            Swatch::Box(class) => {
                let _ = write!(
                    s,
                    "<rect class=\"{class}\" x=\"{}\" y=\"{}\" width=\"24\" height=\"11\"/>",
                    N(*x),
                    N(y - 9.0)
                );
            }
            Swatch::Line(class, colour) => {
                let stroke = if colour.is_empty() { String::new() } else { format!(" stroke=\"{colour}\"") };
                let _ = write!(
                    s,
                    "<polyline class=\"{class}\"{stroke} points=\"{},{} {},{}\"/>",
                    N(*x),
                    N(y - 4.0),
                    N(x + 24.0),
                    N(y - 4.0)
                );
            }
            Swatch::Marker => {
                let _ = write!(s, "<circle class=\"marker\" cx=\"{}\" cy=\"{}\" r=\"6\"/>", N(x + 12.0), N(y - 4.0));
            }
        }
        let _ = writeln!(s, "<text class=\"legend\" x=\"{}\" y=\"{}\">{}</text>", N(x + 32.0), N(y), esc(text));
    }
    let _ = writeln!(s, "</g>");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::test_support::{crossing_rollout, crossing_scenario};
    use crate::record::{NamedTrajectory, TimedPose, TrajectoryRole, render_rollout_svg, render_rollout_svg_with};

    fn classes<'a>(doc: &'a roxmltree::Document) -> Vec<&'a str> {
        doc.descendants().filter_map(|n| n.attribute("class")).collect()
    }

    fn has_class(doc: &roxmltree::Document, wanted: &[&str]) -> bool {
        classes(doc).iter().any(|c| {
            let set: Vec<&str> = c.split_whitespace().collect();
            wanted.iter().all(|w| set.contains(w))
        })
    }

    fn texts(doc: &roxmltree::Document) -> String {
        doc.descendants().filter(|n| n.has_tag_name("text")).filter_map(|n| n.text()).collect::<Vec<_>>().join("\n")
    }

    #[test]
    fn svg_of_a_collision_is_well_formed_and_marks_roles_and_the_collision() {
        let s = crossing_scenario();
        let r = crossing_rollout(&s);
        let c = r.ego_collision().expect("the fixture collides");
        assert_eq!(c.step, 39);
        let svg = render_rollout_svg(&s, &r, &SvgOptions::default());
        let doc = roxmltree::Document::parse(&svg).expect("well-formed XML");
        assert!(has_class(&doc, &["box", "ego", "collided"]), "ego outlined as collided");
        assert!(has_class(&doc, &["box", "cbv", "collided"]), "CBV outlined as collided");
        assert!(has_class(&doc, &["box", "vehicle"]) && has_class(&doc, &["box", "pedestrian"]));
        assert!(has_class(&doc, &["path", "ego"]) && has_class(&doc, &["path", "after", "cbv"]));
        assert!(has_class(&doc, &["collision"]) && has_class(&doc, &["marker"]), "collision marker");
        assert!(has_class(&doc, &["crosswalk"]) && has_class(&doc, &["edge"]) && has_class(&doc, &["lane"]));
        let t = texts(&doc);
        assert!(t.contains("crossing · planner constant-velocity"), "{t}");
        assert!(t.contains("collides with the CBV (cbv-2, vehicle) at t = 3.9 s"), "{t}");
        assert!(t.contains("ego (ego-1)") && t.contains("CBV (cbv-2)"), "legend names the roles: {t}");
        assert!(!svg.contains("NaN") && !svg.contains("-0.00"));
    }

    #[test]
    fn svg_is_byte_identical_on_a_second_render() {
        let s = crossing_scenario();
        let r = crossing_rollout(&s);
        let a = render_rollout_svg(&s, &r, &SvgOptions::default());
        let b = render_rollout_svg(&s, &r, &SvgOptions::default());
        assert_eq!(a, b);
        assert_eq!(render_scenario_svg_default(&s), render_scenario_svg_default(&s));
    }

    fn render_scenario_svg_default(s: &Scenario) -> String {
        crate::record::render_scenario_svg(s, &SvgOptions::default())
    }

    #[test]
    fn svg_crop_holds_every_ego_and_cbv_position_and_not_the_whole_map() {
        let s = crossing_scenario();
        let r = crossing_rollout(&s);
        let opts = SvgOptions::default();
        let pic_states = StateTable::Steps(&r.states);
        let pic = Picture {
            title: String::new(),
            map: &s.map,
            agents: r
                .bodies
                .iter()
                .enumerate()
                .map(|(i, b)| Agent { id: r.agent_ids[i].0.as_str(), body: *b, role: role_of(i, Some(r.ego), r.cbv) })
                .collect(),
            states: pic_states,
            dt_s: r.dt_s,
            shown: 10,
            collisions: vec![],
            extras: &[],
            caption: [String::new(), String::new()],
        };
        let b = focus(&pic, &opts);
        for st in r.states.iter().flat_map(|k| [k[0], k[1]]).flatten() {
            let p = st.position;
            assert!(p.x > b.lo.x && p.x < b.hi.x && p.y > b.lo.y && p.y < b.hi.y, "{p:?} outside {b:?}");
        }
        // The lanes span 200 m x 150 m; the crop follows the conflict.
        assert!(b.width() < 120.0 && b.height() < 120.0, "{b:?}");
        assert!(b.width() <= 2.0 * b.height() + 1e-9 && b.height() <= 2.0 * b.width() + 1e-9);
    }

    #[test]
    fn svg_of_a_scenario_shows_the_current_step_without_collisions() {
        let s = crossing_scenario();
        let svg = crate::record::render_scenario_svg(&s, &SvgOptions { step: Some(20), ..SvgOptions::default() });
        let doc = roxmltree::Document::parse(&svg).expect("well-formed XML");
        assert!(has_class(&doc, &["box", "ego"]) && has_class(&doc, &["box", "cbv"]));
        assert!(!has_class(&doc, &["collided"]) && !has_class(&doc, &["collision"]));
        let t = texts(&doc);
        assert!(t.contains("shown: t = 2.0 s (step 20 of 60)"), "{t}");
        assert!(t.contains("ego ego-1 (named by the source)"), "{t}");
    }

    #[test]
    fn svg_skips_non_finite_states_and_escapes_ids() {
        let mut s = crossing_scenario();
        s.id = "a<b&c\"d'".into();
        let mut r = crossing_rollout(&s);
        r.scenario_id = s.id.clone();
        r.agent_ids[2].0 = "<parked>".into();
        r.states[5][2].as_mut().unwrap().position.x = f64::NAN;
        r.states[39][3].as_mut().unwrap().heading_rad = f64::INFINITY;
        // A ragged row must not panic either.
        r.states[6].pop();
        let svg = render_rollout_svg(&s, &r, &SvgOptions::default());
        let doc = roxmltree::Document::parse(&svg).expect("well-formed XML");
        assert!(texts(&doc).contains("a<b&c\"d'"));
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
        // The pedestrian has no finite state at the shown step: no box for it.
        assert!(!has_class(&doc, &["box", "pedestrian"]));
    }

    #[test]
    fn svg_draws_a_feasibility_witness_and_its_footprint() {
        let s = crossing_scenario();
        let r = crossing_rollout(&s);
        // The ego braking to a stop before the crossing.
        let poses = (0..=60)
            .map(|k| {
                let t = 0.1 * k as f64;
                TimedPose { time_s: t, pose: Pose2::new((10.0 * t).min(30.0), -1.75, 0.0) }
            })
            .collect();
        let witness = NamedTrajectory {
            name: "brake".into(),
            role: TrajectoryRole::FeasibilityWitness,
            body: Some(r.bodies[0]),
            poses,
        };
        let svg = render_rollout_svg_with(&s, &r, &[witness], &SvgOptions::default());
        let doc = roxmltree::Document::parse(&svg).expect("well-formed XML");
        assert!(has_class(&doc, &["extra"]) && has_class(&doc, &["ghost"]));
        assert!(texts(&doc).contains("feasibility witness: brake"));
    }

    #[test]
    fn contact_point_lies_in_the_overlap() {
        let a = OrientedBox::new(Pose2::new(0.0, 0.0, 0.0), 4.0, 2.0);
        let b = OrientedBox::new(Pose2::new(3.0, 0.0, 0.0), 4.0, 2.0);
        let p = contact_point(&a, &b);
        assert!((p.x - 1.5).abs() < 1e-9 && p.y.abs() < 1e-9, "{p:?}");
        // Apart: the midpoint of the centres.
        let c = OrientedBox::new(Pose2::new(10.0, 0.0, 0.0), 4.0, 2.0);
        assert!((contact_point(&a, &c).x - 5.0).abs() < 1e-9);
    }
}
