//! CommonRoad 2020a XML (the NGSIM US-101, Lankershim and Peachtree
//! recordings) into a [`Scenario`].
//!
//! This module owns reading one `<commonRoad>` document: lanelets become
//! [`Lane`]s (centreline = mean of the two bounds), drivable-area polygons
//! and road edges; traffic lights become per-lanelet [`TrafficSignal`]s;
//! dynamic and static obstacles become [`Track`]s. The planning problem's
//! ego is ignored, because its recording was removed from these files: ego
//! and CBV are left to [`crate::scenario::roles`].
//!
//! Every error names the line and column of the element at fault. Nothing
//! here panics on bad input, and sizes that drive allocations (time steps,
//! obstacle counts) are bounded before anything is allocated.

use std::collections::{BTreeSet, HashMap, HashSet};
use std::path::Path;

use roxmltree::{Document, Node, ParsingOptions};

use super::{ImportError, Location};
use crate::geometry::{Point2, Polygon, Polyline, Vector2};
use crate::map::{Lane, LaneKind, MapElementId, RoadEdge, RoadEdgeKind, RoadMap, SignalState, TrafficSignal};
use crate::scenario::{AgentId, AgentKind, AgentState, DataLicence, Scenario, ScenarioSource, SourceFormat, Track};

const FORMAT: SourceFormat = SourceFormat::CommonRoad;

/// "Now" when a recording is long enough: 10 steps (1 s at 0.1 s) of
/// history, as WOMD has, so history-conditioned models see the same amount.
pub const CURRENT_STEP: usize = 10;

/// Largest time step accepted. One hour at 0.1 s; the NGSIM files stop
/// below 200. Bounds the per-track allocation on hostile input.
const MAX_TIME_STEP: i64 = 36_000;

/// Largest number of per-step state slots (tracks × steps) accepted, so a
/// file with many obstacles and one far-away time step cannot exhaust
/// memory. The largest shared file needs about 8 000.
const MAX_STATE_SLOTS: usize = 20_000_000;

/// Largest coordinate magnitude accepted, metres: projected (UTM-like)
/// frames stay below 1e7; beyond that a value is corrupt, and absurd
/// extents make the map's spatial grid allocate without bound.
const MAX_COORDINATE_M: f64 = 1e7;

/// The time steps a recording may have, s: CommonRoad's own scenes use
/// 0.04 to 0.1 s; beyond these a number is a typo, not a recording.
const MIN_TIME_STEP_S: f64 = 0.001;
/// See [`MIN_TIME_STEP_S`].
const MAX_TIME_STEP_S: f64 = 10.0;

/// Traffic-sign ids whose additional value is a speed limit in m/s (the
/// CommonRoad 2020a convention): US `R2-1` and the German/Zamunda `274`.
const MAX_SPEED_SIGN_IDS: [&str; 2] = ["R2-1", "274"];

/// Parses one CommonRoad file. See the module documentation for what is
/// read; `path` is used in messages only.
pub fn parse(bytes: &[u8], path: &Path) -> Result<Scenario, ImportError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        ImportError::malformed(path, FORMAT, Location::ByteOffset(e.valid_up_to() as u64), "not UTF-8 text")
    })?;
    // DTDs stay off (the default): entity expansion is a memory bomb and
    // CommonRoad files never need one.
    let options = ParsingOptions { allow_dtd: false, ..ParsingOptions::default() };
    let doc = Document::parse_with_options(text, options).map_err(|e| {
        // roxmltree reports 1:1 for a document that simply stops; the place
        // to look at then is where the text ends (a truncated file).
        let location = match e {
            roxmltree::Error::UnexpectedEndOfStream | roxmltree::Error::UnclosedRootNode => end_of(text),
            _ => Location::LineColumn { line: e.pos().row as usize, column: e.pos().col as usize },
        };
        ImportError::malformed(path, FORMAT, location, format!("not well-formed XML: {e}"))
    })?;
    let cx = Cx { doc: &doc, path };
    let root = doc.root_element();
    if root.tag_name().name() != "commonRoad" {
        return Err(cx.err(root, format!("root element is <{}>, expected <commonRoad>", root.tag_name().name())));
    }
    let mut notes = Vec::new();

    let dt_s = cx.attr_f64(root, "timeStepSize")?;
    if !(MIN_TIME_STEP_S..=MAX_TIME_STEP_S).contains(&dt_s) {
        return Err(cx.err(
            root,
            format!(
                "timeStepSize {} s is not a recording's time step (from {MIN_TIME_STEP_S} to {MAX_TIME_STEP_S} s)",
                crate::number::shown(dt_s)
            ),
        ));
    }
    let id = match root.attribute("benchmarkID") {
        Some(b) if !b.trim().is_empty() => b.trim().to_string(),
        _ => {
            let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("commonroad").to_string();
            notes.push(format!("no benchmarkID: scenario id taken from the file name ({stem})"));
            stem
        }
    };

    let agents = read_agents(&cx, root, &mut notes)?;
    let num_steps = agents.num_steps;
    let map = read_map(&cx, root, num_steps, &mut notes)?;

    let current_step = choose_current_step(&agents.tracks, num_steps);
    notes.push(format!("current step {current_step} of {num_steps} ({} s of history)", current_step as f64 * dt_s));
    if root.children().any(|n| n.has_tag_name("planningProblem")) {
        notes.push(
            "planning problem ignored: its ego's recording is not in the file; ego and CBV are mined from the obstacles"
                .to_string(),
        );
    }

    Ok(Scenario {
        current_step,
        ..Scenario::new(
            id,
            ScenarioSource { format: FORMAT, path: path.to_path_buf(), licence: DataLicence::PublicDomain, notes },
            dt_s,
            map,
            agents.tracks,
        )
    }
    .with_source_roles(None, None))
}

/// Line and column just past the last character of `text`.
fn end_of(text: &str) -> Location {
    let line = text.bytes().filter(|&b| b == b'\n').count() + 1;
    let column = text.rsplit('\n').next().map_or(0, |last| last.chars().count()) + 1;
    Location::LineColumn { line, column }
}

/// [`CURRENT_STEP`] when the recording reaches it and some agent is valid
/// there; otherwise the first step where any agent is valid (0 for an
/// empty scenario).
fn choose_current_step(tracks: &[Track], num_steps: usize) -> usize {
    let valid_at = |k: usize| tracks.iter().any(|t| t.state(k).is_some());
    if num_steps > CURRENT_STEP && valid_at(CURRENT_STEP) {
        return CURRENT_STEP;
    }
    (0..num_steps).find(|&k| valid_at(k)).unwrap_or(0)
}

/// Document access with errors located at an element's line and column.
struct Cx<'a, 'input> {
    doc: &'a Document<'input>,
    path: &'a Path,
}

impl Cx<'_, '_> {
    fn err(&self, node: Node<'_, '_>, message: impl Into<String>) -> ImportError {
        let pos = self.doc.text_pos_at(node.range().start);
        ImportError::malformed(
            self.path,
            FORMAT,
            Location::LineColumn { line: pos.row as usize, column: pos.col as usize },
            message,
        )
    }

    /// The first child element called `name`, or an error naming both.
    fn req<'n, 'i>(&self, node: Node<'n, 'i>, name: &str) -> Result<Node<'n, 'i>, ImportError> {
        child(node, name).ok_or_else(|| self.err(node, format!("<{}> has no <{name}>", describe(node))))
    }

    fn text_f64(&self, node: Node<'_, '_>) -> Result<f64, ImportError> {
        let text = node.text().unwrap_or("").trim();
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(v) => Err(self.err(node, format!("<{}> is {v}, expected a finite number", describe(node)))),
            Err(_) => Err(self.err(node, format!("<{}> is {text:?}, expected a number", describe(node)))),
        }
    }

    fn text_i64(&self, node: Node<'_, '_>) -> Result<i64, ImportError> {
        let text = node.text().unwrap_or("").trim();
        text.parse::<i64>()
            .map_err(|_| self.err(node, format!("<{}> is {text:?}, expected an integer", describe(node))))
    }

    fn child_f64(&self, node: Node<'_, '_>, name: &str) -> Result<f64, ImportError> {
        self.text_f64(self.req(node, name)?)
    }

    fn attr_f64(&self, node: Node<'_, '_>, name: &str) -> Result<f64, ImportError> {
        let Some(text) = node.attribute(name) else {
            return Err(self.err(node, format!("<{}> has no {name} attribute", describe(node))));
        };
        match text.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.err(node, format!("{name}={text:?} is not a finite number"))),
        }
    }

    fn attr_i64(&self, node: Node<'_, '_>, name: &str) -> Result<i64, ImportError> {
        let Some(text) = node.attribute(name) else {
            return Err(self.err(node, format!("<{}> has no {name} attribute", describe(node))));
        };
        text.trim().parse::<i64>().map_err(|_| self.err(node, format!("{name}={text:?} is not an integer")))
    }

    /// `<point><x/><y/></point>`, within [`MAX_COORDINATE_M`] of the origin.
    fn point(&self, node: Node<'_, '_>) -> Result<Point2, ImportError> {
        let p = Point2::new(self.child_f64(node, "x")?, self.child_f64(node, "y")?);
        if p.x.abs().max(p.y.abs()) > MAX_COORDINATE_M {
            return Err(self.err(
                node,
                format!(
                    "({}, {}) is more than {} m from the origin",
                    crate::number::shown(p.x),
                    crate::number::shown(p.y),
                    crate::number::shown(MAX_COORDINATE_M)
                ),
            ));
        }
        Ok(p)
    }

    /// The `<point>` children of a bound or stop line, in order.
    fn points(&self, node: Node<'_, '_>) -> Result<Vec<Point2>, ImportError> {
        node.children().filter(|n| n.has_tag_name("point")).map(|p| self.point(p)).collect()
    }

    /// A state value given as `<exact>` or as an interval (its midpoint).
    fn value(&self, node: Node<'_, '_>) -> Result<f64, ImportError> {
        if let Some(exact) = child(node, "exact") {
            return self.text_f64(exact);
        }
        match (child(node, "intervalStart"), child(node, "intervalEnd")) {
            (Some(a), Some(b)) => Ok(0.5 * (self.text_f64(a)? + self.text_f64(b)?)),
            _ => Err(self.err(node, format!("<{}> has neither <exact> nor an interval", describe(node)))),
        }
    }
}

fn child<'n, 'i>(node: Node<'n, 'i>, name: &str) -> Option<Node<'n, 'i>> {
    node.children().find(|n| n.has_tag_name(name))
}

fn children<'n, 'i>(node: Node<'n, 'i>, name: &'static str) -> impl Iterator<Item = Node<'n, 'i>> {
    node.children().filter(move |n| n.has_tag_name(name))
}

/// `lanelet 3419` style description of an element for messages.
fn describe(node: Node<'_, '_>) -> String {
    match node.attribute("id") {
        Some(id) => format!("{} id={id}", node.tag_name().name()),
        None => node.tag_name().name().to_string(),
    }
}

// ---------------------------------------------------------------------------
// Agents

struct Agents {
    tracks: Vec<Track>,
    num_steps: usize,
}

/// One obstacle before its states are laid out on the step grid.
struct RawObstacle {
    id: AgentId,
    kind: AgentKind,
    length_m: f64,
    width_m: f64,
    /// `(step, state)` in file order.
    states: Vec<(usize, AgentState)>,
    is_static: bool,
}

fn read_agents(cx: &Cx<'_, '_>, root: Node<'_, '_>, notes: &mut Vec<String>) -> Result<Agents, ImportError> {
    let mut raw = Vec::new();
    let mut with_occupancy = 0usize;
    let mut max_step: Option<usize> = None;
    for node in root.children().filter(|n| n.has_tag_name("dynamicObstacle") || n.has_tag_name("staticObstacle")) {
        let is_static = node.has_tag_name("staticObstacle");
        let obstacle = read_obstacle(cx, node, is_static)?;
        if child(node, "occupancySet").is_some() {
            with_occupancy += 1;
        }
        if !is_static {
            for &(k, _) in &obstacle.states {
                max_step = Some(max_step.map_or(k, |m| m.max(k)));
            }
        }
        raw.push(obstacle);
    }
    if with_occupancy > 0 {
        notes.push(format!(
            "{with_occupancy} obstacle(s) carry a set-based occupancy prediction instead of a recorded trajectory: \
             only their initial states are imported"
        ));
    }
    // A scenario of static obstacles only still has one step ("now").
    let num_steps = max_step.map_or(1, |m| m + 1);
    if raw.len().saturating_mul(num_steps) > MAX_STATE_SLOTS {
        return Err(cx.err(
            root,
            format!("{} obstacles over {num_steps} steps exceed the limit of {MAX_STATE_SLOTS} states", raw.len()),
        ));
    }
    let tracks = raw
        .into_iter()
        .map(|o| {
            let mut states = vec![None; num_steps];
            if o.is_static {
                // A static obstacle stands where its initial state puts it for
                // the whole recording.
                if let Some(&(_, s)) = o.states.first() {
                    states.iter_mut().for_each(|slot| *slot = Some(s));
                }
            } else {
                for (k, s) in o.states {
                    states[k] = Some(s);
                }
            }
            Track { id: o.id, kind: o.kind, length_m: o.length_m, width_m: o.width_m, states }
        })
        .collect();
    Ok(Agents { tracks, num_steps })
}

/// CommonRoad 2020a obstacle types to agent kinds. Parked and priority
/// vehicles and taxis are vehicles; trains, buildings, barriers and
/// `unknown` are `Other`.
fn agent_kind(obstacle_type: &str) -> AgentKind {
    match obstacle_type {
        "car" | "truck" | "bus" | "motorcycle" | "priorityVehicle" | "parkedVehicle" | "taxi" => AgentKind::Vehicle,
        "bicycle" => AgentKind::Cyclist,
        "pedestrian" => AgentKind::Pedestrian,
        _ => AgentKind::Other,
    }
}

fn read_obstacle(cx: &Cx<'_, '_>, node: Node<'_, '_>, is_static: bool) -> Result<RawObstacle, ImportError> {
    let id = match node.attribute("id") {
        Some(id) if !id.trim().is_empty() => AgentId(id.trim().to_string()),
        _ => return Err(cx.err(node, format!("<{}> has no id attribute", node.tag_name().name()))),
    };
    let type_node = cx.req(node, "type")?;
    let kind = agent_kind(type_node.text().unwrap_or("").trim());
    let (length_m, width_m) = read_shape(cx, cx.req(node, "shape")?)?;

    let initial = cx.req(node, "initialState")?;
    let mut states = vec![read_state(cx, initial)?];
    if !is_static && let Some(trajectory) = child(node, "trajectory") {
        let mut seen = HashSet::from([states[0].0]);
        for s in children(trajectory, "state") {
            let state = read_state(cx, s)?;
            if !seen.insert(state.0) {
                return Err(cx.err(s, format!("obstacle {id} has a second state for time step {}", state.0)));
            }
            states.push(state);
        }
    }
    Ok(RawObstacle { id, kind, length_m, width_m, states, is_static })
}

/// Length and width of a `<shape>`: a rectangle, or a circle as its
/// bounding square.
fn read_shape(cx: &Cx<'_, '_>, shape: Node<'_, '_>) -> Result<(f64, f64), ImportError> {
    let (length_m, width_m, at) = if let Some(r) = child(shape, "rectangle") {
        (cx.child_f64(r, "length")?, cx.child_f64(r, "width")?, r)
    } else if let Some(c) = child(shape, "circle") {
        let d = 2.0 * cx.child_f64(c, "radius")?;
        (d, d, c)
    } else {
        return Err(cx.err(shape, "<shape> has neither <rectangle> nor <circle>"));
    };
    if length_m <= 0.0 || width_m <= 0.0 {
        return Err(cx.err(at, format!("size {length_m} x {width_m} m is not positive")));
    }
    Ok((length_m, width_m))
}

/// One `<initialState>` or trajectory `<state>`: its time step and state.
/// The velocity is the scalar speed along the orientation.
fn read_state(cx: &Cx<'_, '_>, node: Node<'_, '_>) -> Result<(usize, AgentState), ImportError> {
    let time = cx.req(node, "time")?;
    let exact = cx.req(time, "exact")?;
    let step = cx.text_i64(exact)?;
    if !(0..=MAX_TIME_STEP).contains(&step) {
        return Err(cx.err(exact, format!("time step {step} outside 0..={MAX_TIME_STEP}")));
    }
    let position = cx.req(node, "position")?;
    let Some(point) = child(position, "point") else {
        return Err(cx.err(position, "<position> is not a <point> (uncertain positions are not supported)"));
    };
    let position = cx.point(point)?;
    let orientation = cx.req(node, "orientation")?;
    let heading_rad =
        crate::scenario::bounds::recorded_heading(cx.value(orientation)?).map_err(|e| cx.err(orientation, e))?;
    let speed_mps = cx.value(cx.req(node, "velocity")?)?;
    let velocity_mps = Vector2::new(heading_rad.cos(), heading_rad.sin()) * speed_mps;
    // The range check above makes this conversion lossless.
    Ok((step as usize, AgentState { position, heading_rad, velocity_mps }))
}

// ---------------------------------------------------------------------------
// Map

/// A lanelet as read, before ids are resolved into the map.
struct RawLanelet {
    id: i64,
    left: Vec<Point2>,
    right: Vec<Point2>,
    predecessors: Vec<MapElementId>,
    successors: Vec<MapElementId>,
    /// `(ref, same direction)`.
    adjacent_left: Option<(i64, bool)>,
    adjacent_right: Option<(i64, bool)>,
    kind: LaneKind,
    sign_refs: Vec<i64>,
    light_refs: Vec<i64>,
    /// Midpoint of the stop line's points, when it has them.
    stop_line_mid: Option<Point2>,
    /// Whether the lanelet has a `stopLine` (one without points lies at the
    /// lanelet's end, CommonRoad 2020a §3.2).
    has_stop_line: bool,
}

/// Movement through an intersection, from `<incoming>`'s successor lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Movement {
    Left,
    Straight,
    Right,
}

/// Colour of a traffic light over one cycle element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LightColour {
    Red,
    RedYellow,
    Yellow,
    Green,
    Inactive,
}

/// A `<trafficLight>`.
struct Light {
    /// `(colour, duration in steps)`.
    cycle: Vec<(LightColour, u64)>,
    cycle_steps: u64,
    offset: i64,
    /// Movements it governs.
    movements: BTreeSet<Movement>,
    active: bool,
}

impl Light {
    /// Colour at `step`, as commonroad-io computes it: the cycle starts at
    /// `timeOffset` and repeats, so the position in the cycle is
    /// `(step - offset) mod cycle length`.
    fn colour_at(&self, step: usize) -> LightColour {
        let cycle_steps = self.cycle_steps.max(1) as i128;
        let mut t = (step as i128 - self.offset as i128).rem_euclid(cycle_steps) as u64;
        for &(colour, duration) in &self.cycle {
            if t < duration {
                return colour;
            }
            t -= duration;
        }
        LightColour::Inactive
    }

    /// State of this light at `step` in the map's terms: a light for a
    /// single turn is an arrow; inactive or switched-off lights are
    /// unknown, so a more general light can speak instead.
    fn state_at(&self, step: usize) -> SignalState {
        if !self.active {
            return SignalState::Unknown;
        }
        let arrow = self.movements.len() == 1 && !self.movements.contains(&Movement::Straight);
        match (self.colour_at(step), arrow) {
            (LightColour::Red | LightColour::RedYellow, false) => SignalState::Stop,
            (LightColour::Red | LightColour::RedYellow, true) => SignalState::ArrowStop,
            (LightColour::Yellow, false) => SignalState::Caution,
            (LightColour::Yellow, true) => SignalState::ArrowCaution,
            (LightColour::Green, false) => SignalState::Go,
            (LightColour::Green, true) => SignalState::ArrowGo,
            (LightColour::Inactive, _) => SignalState::Unknown,
        }
    }
}

fn read_map(
    cx: &Cx<'_, '_>,
    root: Node<'_, '_>,
    num_steps: usize,
    notes: &mut Vec<String>,
) -> Result<RoadMap, ImportError> {
    let mut lanelets = Vec::new();
    let mut max_id = 0i64;
    let mut speed_limits: HashMap<i64, f64> = HashMap::new();
    let mut lights: HashMap<i64, Light> = HashMap::new();
    let mut movement_of: HashMap<i64, Movement> = HashMap::new();
    for node in root.children().filter(Node::is_element) {
        match node.tag_name().name() {
            "lanelet" => {
                let l = read_lanelet(cx, node)?;
                max_id = max_id.max(l.id);
                lanelets.push(l);
            }
            "trafficSign" => {
                let id = cx.attr_i64(node, "id")?;
                max_id = max_id.max(id);
                if let Some(v) = read_speed_limit(cx, node)? {
                    speed_limits.insert(id, v);
                }
            }
            "trafficLight" => {
                let id = cx.attr_i64(node, "id")?;
                max_id = max_id.max(id);
                lights.insert(id, read_light(cx, node)?);
            }
            "intersection" => {
                for incoming in children(node, "incoming") {
                    for (tag, movement) in [
                        ("successorsLeft", Movement::Left),
                        ("successorsStraight", Movement::Straight),
                        ("successorsRight", Movement::Right),
                    ] {
                        for s in children(incoming, tag) {
                            movement_of.insert(cx.attr_i64(s, "ref")?, movement);
                        }
                    }
                }
            }
            _ => {}
        }
    }

    // Road-edge ids follow every id in the file, so they can never collide
    // with a lanelet's.
    let mut next_edge_id = max_id.saturating_add(1);
    let mut lanes = Vec::with_capacity(lanelets.len());
    let mut candidate_edges = Vec::new();
    let mut drivable_areas = Vec::with_capacity(lanelets.len());
    let mut traffic_signals = Vec::new();
    let mut signalled_by_movement = 0usize;
    for l in &lanelets {
        let left = Polyline::new(l.left.clone());
        let right = Polyline::new(l.right.clone());
        let centreline = centreline(&left, &right);

        // Road on the port side: the right bound runs with traffic and has
        // the road on its left; the left bound does after reversal. An
        // adjacent lanelet of either direction means the road goes on.
        // Bounds without one are only candidates: where another lanelet
        // lies beyond them (an intersection, a lane the file does not
        // declare adjacent) they are trimmed below.
        if l.adjacent_right.is_none() {
            candidate_edges.push(right.clone());
        }
        if l.adjacent_left.is_none() {
            candidate_edges.push(left.reversed());
        }
        drivable_areas.push(Polygon::new(l.right.iter().chain(l.left.iter().rev()).copied().collect()));

        if !l.light_refs.is_empty() {
            let mut movements: Vec<Movement> =
                l.successors.iter().filter_map(|s| movement_of.get(&s.0).copied()).collect();
            movements.sort();
            movements.dedup();
            if !movements.is_empty() {
                signalled_by_movement += 1;
            }
            let referenced: Vec<&Light> = l.light_refs.iter().filter_map(|r| lights.get(r)).collect();
            if !referenced.is_empty() {
                let states = (0..num_steps).map(|k| lane_signal_state(&referenced, &movements, k)).collect();
                let stop_point = l.stop_line_mid.or_else(|| centreline.points().last().copied());
                traffic_signals.push(TrafficSignal { lane: MapElementId(l.id), stop_point, states });
            }
        }

        let speed_limit_mps = l.sign_refs.iter().filter_map(|r| speed_limits.get(r).copied()).reduce(f64::min);
        let in_intersection = movement_of.contains_key(&l.id);
        let stop_line =
            if l.has_stop_line { l.stop_line_mid.or_else(|| centreline.points().last().copied()) } else { None };
        lanes.push(Lane {
            id: MapElementId(l.id),
            centreline,
            kind: l.kind,
            speed_limit_mps,
            predecessors: l.predecessors.clone(),
            successors: l.successors.clone(),
            left_neighbours: same_direction(l.adjacent_left),
            right_neighbours: same_direction(l.adjacent_right),
            left_boundary: Some(left),
            right_boundary: Some(right),
            in_intersection,
            crosses_lanes: false,
            stop_line,
        });
    }
    let road_edges: Vec<RoadEdge> = uncovered_parts(&candidate_edges, &drivable_areas)
        .into_iter()
        .map(|polyline| {
            let id = MapElementId(next_edge_id);
            next_edge_id = next_edge_id.saturating_add(1);
            RoadEdge { id, polyline, kind: RoadEdgeKind::Boundary }
        })
        .collect();
    if !traffic_signals.is_empty() {
        notes.push(format!(
            "{} traffic lights mapped to {} signal-controlled lanelets (stop at the lanelet's end); \
             {signalled_by_movement} of them resolved per turn movement through the intersection",
            lights.len(),
            traffic_signals.len()
        ));
    }
    Ok(RoadMap::new(lanes, road_edges, Vec::new(), Vec::new(), drivable_areas, Vec::new(), traffic_signals))
}

/// How far beyond a bound the road is probed, metres: past the rounding of
/// shared bound points, well inside any lane.
const EDGE_PROBE_M: f64 = 0.3;

/// The longest stretch of a bound judged by one probe, metres: a lanelet
/// shorter than this beyond a bound can be missed.
const EDGE_PROBE_SPACING_M: f64 = 1.0;

/// The parts of the candidate edges (road on their port side) with no
/// lanelet on their starboard side: the outer boundary of the lanelet
/// union. A lanelet bound that runs through an intersection, or beside a
/// lane the file does not declare adjacent, has road on both sides and is
/// no road edge. Each candidate is cut into pieces of at most
/// [`EDGE_PROBE_SPACING_M`]; a piece is kept when the point
/// [`EDGE_PROBE_M`] off its middle, to starboard, lies in no lanelet, and
/// each run of kept pieces becomes one edge with the candidate's own
/// vertices plus the points where coverage changes, placed by bisection.
fn uncovered_parts(candidates: &[Polyline], lanelets: &[Polygon]) -> Vec<Polyline> {
    let bounds: Vec<Option<(Point2, Point2)>> = lanelets.iter().map(Polygon::bounds).collect();
    let covered = |p: Point2| {
        lanelets.iter().zip(&bounds).any(|(area, b)| {
            b.is_some_and(|(lo, hi)| p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y) && area.contains(&p)
        })
    };
    let mut parts = Vec::new();
    for candidate in candidates {
        let mut run: Vec<Point2> = Vec::new();
        for pair in candidate.points().windows(2) {
            let (a, b) = (pair[0], pair[1]);
            let along = b - a;
            let length = along.norm();
            if length.is_nan() || length <= 1e-9 {
                continue;
            }
            let starboard = Vector2::new(along.y, -along.x) * (EDGE_PROBE_M / length);
            let pieces = ((length / EDGE_PROBE_SPACING_M).ceil() as usize).max(1);
            let at = |t: f64| a + along * (t / pieces as f64);
            let piece_covered: Vec<bool> = (0..pieces).map(|j| covered(at(j as f64 + 0.5) + starboard)).collect();
            for (j, &is_covered) in piece_covered.iter().enumerate() {
                if is_covered {
                    if run.len() >= 2 {
                        parts.push(Polyline::new(std::mem::take(&mut run)));
                    }
                    run.clear();
                    continue;
                }
                // A run keeps the candidate's vertices and the points where
                // coverage changes (found to a millimetre between the two
                // pieces' probes), not every piece's end.
                let change = |from: f64, to: f64| {
                    let (mut kept, mut cut) = (from, to);
                    while (cut - kept).abs() * length / pieces as f64 > 1e-3 {
                        let t = 0.5 * (kept + cut);
                        if covered(at(t) + starboard) { cut = t } else { kept = t }
                    }
                    at(0.5 * (kept + cut))
                };
                if run.is_empty() {
                    run.push(if j > 0 { change(j as f64 + 0.5, j as f64 - 0.5) } else { a });
                }
                if j + 1 == pieces {
                    run.push(b);
                } else if piece_covered[j + 1] {
                    run.push(change(j as f64 + 0.5, j as f64 + 1.5));
                }
            }
        }
        if run.len() >= 2 {
            parts.push(Polyline::new(run));
        }
    }
    parts
}

fn same_direction(adjacent: Option<(i64, bool)>) -> Vec<MapElementId> {
    adjacent.filter(|&(_, same)| same).map(|(id, _)| MapElementId(id)).into_iter().collect()
}

/// Mean of the two bounds after resampling both to the larger point count
/// (at least 2), so bounds digitised with different densities pair up by
/// arc-length fraction.
fn centreline(left: &Polyline, right: &Polyline) -> Polyline {
    let n = left.len().max(right.len()).max(2);
    let (l, r) = (left.resample(n), right.resample(n));
    Polyline::new(l.points().iter().zip(r.points()).map(|(a, b)| Point2::from((a.coords + b.coords) * 0.5)).collect())
}

/// The state of a signal-controlled lanelet at `step`. For each movement
/// its successors make through the intersection, the most specific active
/// light governing that movement speaks (a turn arrow before a
/// `straightRight` light before an `all` light; an inactive arrow defers to
/// the general light). When the movements disagree the most restrictive
/// wins: one lane has one state, and stopping is the safe reading. Without
/// known movements every referenced light counts.
fn lane_signal_state(lights: &[&Light], movements: &[Movement], step: usize) -> SignalState {
    let governing = |m: Option<Movement>| -> SignalState {
        let mut candidates: Vec<&&Light> =
            lights.iter().filter(|l| m.is_none_or(|m| l.movements.contains(&m))).collect();
        candidates.sort_by_key(|l| l.movements.len());
        candidates.iter().map(|l| l.state_at(step)).find(|s| *s != SignalState::Unknown).unwrap_or_default()
    };
    let states: Vec<SignalState> = if movements.is_empty() {
        vec![governing(None)]
    } else {
        movements.iter().map(|&m| governing(Some(m))).collect()
    };
    states.into_iter().max_by_key(|s| restrictiveness(*s)).unwrap_or_default()
}

fn restrictiveness(state: SignalState) -> u8 {
    match state {
        SignalState::Unknown => 0,
        SignalState::Go | SignalState::ArrowGo => 1,
        SignalState::Caution | SignalState::ArrowCaution | SignalState::FlashingCaution => 2,
        SignalState::Stop | SignalState::ArrowStop | SignalState::FlashingStop => 3,
    }
}

fn read_lanelet(cx: &Cx<'_, '_>, node: Node<'_, '_>) -> Result<RawLanelet, ImportError> {
    let id = cx.attr_i64(node, "id")?;
    let bound = |name: &str| -> Result<Vec<Point2>, ImportError> {
        let b = cx.req(node, name)?;
        let pts = cx.points(b)?;
        // Fewer than two distinct points give no direction and no length.
        if Polyline::new(pts.clone()).len() < 2 {
            return Err(cx.err(b, format!("<{name}> of lanelet {id} needs at least two distinct points")));
        }
        Ok(pts)
    };
    let left = bound("leftBound")?;
    let right = bound("rightBound")?;
    let refs = |name: &'static str| -> Result<Vec<i64>, ImportError> {
        children(node, name).map(|n| cx.attr_i64(n, "ref")).collect()
    };
    let adjacent = |name: &str| -> Result<Option<(i64, bool)>, ImportError> {
        match child(node, name) {
            None => Ok(None),
            Some(a) => {
                let same = match a.attribute("drivingDir") {
                    Some("same") => true,
                    Some("opposite") => false,
                    other => {
                        return Err(cx.err(a, format!("drivingDir={other:?}, expected \"same\" or \"opposite\"")));
                    }
                };
                Ok(Some((cx.attr_i64(a, "ref")?, same)))
            }
        }
    };
    let kind = children(node, "laneletType")
        .map(|t| lane_kind(t.text().unwrap_or("").trim()))
        .find(|k| *k != LaneKind::Undefined)
        .unwrap_or_default();
    let stop_line_mid = match child(node, "stopLine") {
        Some(s) => {
            let pts = cx.points(s)?;
            match pts.as_slice() {
                [a, b, ..] => Some(Point2::from((a.coords + b.coords) * 0.5)),
                _ => None,
            }
        }
        None => None,
    };
    let ids = |v: Vec<i64>| v.into_iter().map(MapElementId).collect::<Vec<_>>();
    Ok(RawLanelet {
        id,
        left,
        right,
        predecessors: ids(refs("predecessor")?),
        successors: ids(refs("successor")?),
        adjacent_left: adjacent("adjacentLeft")?,
        adjacent_right: adjacent("adjacentRight")?,
        kind,
        sign_refs: refs("trafficSignRef")?,
        light_refs: refs("trafficLightRef")?,
        stop_line_mid,
        has_stop_line: child(node, "stopLine").is_some(),
    })
}

/// CommonRoad 2020a `laneletType` to lane kind.
fn lane_kind(lanelet_type: &str) -> LaneKind {
    match lanelet_type {
        "highway" | "interstate" | "mainCarriageWay" | "accessRamp" | "exitRamp" | "shoulder" => LaneKind::Freeway,
        "urban" | "country" | "driveWay" => LaneKind::SurfaceStreet,
        "busLane" => LaneKind::BusLane,
        "bicycleLane" => LaneKind::BikeLane,
        _ => LaneKind::Undefined,
    }
}

/// The speed limit a `<trafficSign>` sets, m/s, if it is a max-speed sign.
fn read_speed_limit(cx: &Cx<'_, '_>, node: Node<'_, '_>) -> Result<Option<f64>, ImportError> {
    for element in children(node, "trafficSignElement") {
        let sign_id = child(element, "trafficSignID").and_then(|n| n.text()).unwrap_or("").trim();
        if MAX_SPEED_SIGN_IDS.contains(&sign_id)
            && let Some(value) = child(element, "additionalValue")
        {
            let v = cx.text_f64(value)?;
            if v > 0.0 {
                return Ok(Some(v));
            }
        }
    }
    Ok(None)
}

fn read_light(cx: &Cx<'_, '_>, node: Node<'_, '_>) -> Result<Light, ImportError> {
    let mut cycle = Vec::new();
    let mut offset = 0;
    let mut cycle_steps = 0u64;
    if let Some(c) = child(node, "cycle") {
        for element in children(c, "cycleElement") {
            let d = cx.req(element, "duration")?;
            let duration = cx.text_i64(d)?;
            if !(0..=i64::from(u32::MAX)).contains(&duration) {
                return Err(cx.err(d, format!("duration {duration} outside 0..={}", u32::MAX)));
            }
            let colour_node = cx.req(element, "color")?;
            let colour = match colour_node.text().unwrap_or("").trim() {
                "red" => LightColour::Red,
                "redYellow" => LightColour::RedYellow,
                "yellow" => LightColour::Yellow,
                "green" => LightColour::Green,
                "inactive" => LightColour::Inactive,
                other => {
                    return Err(
                        cx.err(colour_node, format!("traffic-light colour {other:?} is not one of CommonRoad's"))
                    );
                }
            };
            cycle_steps += duration as u64;
            cycle.push((colour, duration as u64));
        }
        if let Some(o) = child(c, "timeOffset") {
            offset = cx.text_i64(o)?;
        }
    }
    let movements = match child(node, "direction").and_then(|d| d.text()).map(str::trim).unwrap_or("all") {
        "left" => BTreeSet::from([Movement::Left]),
        "straight" => BTreeSet::from([Movement::Straight]),
        "right" => BTreeSet::from([Movement::Right]),
        "leftStraight" => BTreeSet::from([Movement::Left, Movement::Straight]),
        "straightRight" => BTreeSet::from([Movement::Straight, Movement::Right]),
        "leftRight" => BTreeSet::from([Movement::Left, Movement::Right]),
        _ => BTreeSet::from([Movement::Left, Movement::Straight, Movement::Right]),
    };
    let active = child(node, "active").and_then(|a| a.text()).map(str::trim) != Some("false");
    // A light without a usable cycle is known to exist but says nothing.
    let active = active && cycle_steps > 0;
    Ok(Light { cycle, cycle_steps, offset, movements, active })
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = r#"<?xml version="1.0" ?>
<commonRoad benchmarkID="TEST_1" commonRoadVersion="2020a" timeStepSize="0.1">"#;

    fn lanelet(id: i64, y: f64, extra: &str) -> String {
        format!(
            r#"<lanelet id="{id}">
  <leftBound><point><x>0</x><y>{l}</y></point><point><x>50</x><y>{l}</y></point><point><x>100</x><y>{l}</y></point></leftBound>
  <rightBound><point><x>0</x><y>{y}</y></point><point><x>100</x><y>{y}</y></point></rightBound>
  {extra}
  <laneletType>urban</laneletType>
</lanelet>"#,
            l = y + 3.5
        )
    }

    fn obstacle(id: i64, states: &[(i64, f64)]) -> String {
        let state = |tag: &str, (t, x): (i64, f64)| {
            format!(
                "<{tag}><position><point><x>{x}</x><y>1.75</y></point></position><orientation><exact>0.0</exact></orientation>\
                 <time><exact>{t}</exact></time><velocity><exact>10.0</exact></velocity></{tag}>"
            )
        };
        let traj: String = states[1..].iter().map(|&s| state("state", s)).collect();
        format!(
            "<dynamicObstacle id=\"{id}\"><type>car</type><shape><rectangle><length>4.5</length><width>1.8</width>\
             </rectangle></shape>{}<trajectory>{traj}</trajectory></dynamicObstacle>",
            state("initialState", states[0])
        )
    }

    fn parse_str(xml: &str) -> Result<Scenario, ImportError> {
        parse(xml.as_bytes(), Path::new("test.xml"))
    }

    #[test]
    fn two_lanes_one_car() {
        let xml = format!(
            "{HEADER}{}{}{}</commonRoad>",
            lanelet(1, 0.0, r#"<adjacentLeft ref="2" drivingDir="same"/>"#),
            lanelet(2, 3.5, r#"<adjacentRight ref="1" drivingDir="same"/>"#),
            obstacle(7, &[(0, 10.0), (1, 11.0), (3, 13.0)])
        );
        let s = parse_str(&xml).unwrap();
        assert_eq!(s.id, "TEST_1");
        assert_eq!(s.num_steps(), 4);
        assert_eq!(s.current_step, 0, "too short for step 10");
        let t = &s.tracks[0];
        assert!(t.state(2).is_none() && t.state(3).is_some());
        assert!((t.state(0).unwrap().velocity_mps.x - 10.0).abs() < 1e-12);
        let lane = s.map.lane(MapElementId(1)).unwrap();
        assert_eq!(lane.centreline.len(), 3, "resampled to the larger bound");
        assert!(lane.centreline.points().iter().all(|p| (p.y - 1.75).abs() < 1e-9));
        assert_eq!(lane.left_neighbours, vec![MapElementId(2)]);
        // Outer edges only: right of lanelet 1, left of lanelet 2.
        assert_eq!(s.map.road_edges.len(), 2);
        assert!(!s.map.is_off_road(&Point2::new(50.0, 1.0)));
        assert!(s.map.is_off_road(&Point2::new(50.0, -1.0)));
        assert!(s.map.is_off_road(&Point2::new(50.0, 8.0)));
        s.validate().unwrap();
    }

    /// A northbound lanelet crossing an eastbound one: no bound of either
    /// is a road edge inside the crossing, and both go on beyond it.
    #[test]
    fn road_edges_stop_at_a_crossing() {
        let northbound = r#"<lanelet id="2">
  <leftBound><point><x>48</x><y>-50</y></point><point><x>48</x><y>50</y></point></leftBound>
  <rightBound><point><x>52</x><y>-50</y></point><point><x>52</x><y>50</y></point></rightBound>
  <laneletType>urban</laneletType>
</lanelet>"#;
        let xml =
            format!("{HEADER}{}{northbound}{}</commonRoad>", lanelet(1, 0.0, ""), obstacle(7, &[(0, 10.0), (1, 11.0)]));
        let map = parse_str(&xml).unwrap().map;
        // Each of the four bounds is cut in two by the other lanelet.
        assert_eq!(map.road_edges.len(), 8, "{:#?}", map.road_edges);
        let inside_crossing = |p: &Point2| p.x > 48.0 + 1e-9 && p.x < 52.0 - 1e-9 && p.y > 1e-9 && p.y < 3.5 - 1e-9;
        for edge in &map.road_edges {
            for pair in edge.polyline.points().windows(2) {
                let mid = Point2::from((pair[0].coords + pair[1].coords) * 0.5);
                assert!(!inside_crossing(&mid) && !inside_crossing(&pair[0]), "edge through the crossing: {edge:?}");
            }
        }
        // The middle of the crossing is as far from the kerb as its corners.
        let centre = Point2::new(50.0, 1.75);
        let d = map.signed_distance_to_road_edge(&centre).unwrap();
        assert!((d + (2.0f64.powi(2) + 1.75f64.powi(2)).sqrt()).abs() < 5e-3, "{d}");
        // Beside the crossing the kerbs are where they were.
        assert!(map.is_off_road(&Point2::new(20.0, -0.5)));
        assert!(map.is_off_road(&Point2::new(55.0, 20.0)));
        assert!(!map.is_off_road(&Point2::new(50.0, -0.5)), "the northbound lane is road");
        let d = map.signed_distance_to_road_edge(&Point2::new(20.0, 1.0)).unwrap();
        assert!((d + 1.0).abs() < 1e-9, "{d}");
    }

    #[test]
    fn missing_right_bound_is_located() {
        let bad = lanelet(1, 0.0, "").replace("rightBound", "rightBoundary");
        let err = parse_str(&format!("{HEADER}\n{bad}</commonRoad>")).unwrap_err().to_string();
        assert!(err.contains("has no <rightBound>") && err.contains("line 3, column 1"), "{err}");
    }

    #[test]
    fn bad_numbers_and_truncation_are_errors() {
        let xml = format!("{HEADER}{}</commonRoad>", obstacle(7, &[(0, 10.0)])).replace("<x>10</x>", "<x>ten</x>");
        assert!(parse_str(&xml).unwrap_err().to_string().contains("expected a number"));
        let xml = format!("{HEADER}{}</commonRoad>", obstacle(7, &[(0, 1.0), (99999999, 2.0)]));
        assert!(parse_str(&xml).unwrap_err().to_string().contains("time step 99999999"));
        let whole = format!("{HEADER}\n{}</commonRoad>", lanelet(1, 0.0, ""));
        let err = parse_str(&whole[..whole.len() / 2]).unwrap_err().to_string();
        assert!(err.contains("line 4, column 81"), "{err}");
        // Cut at an element boundary: the error points at the end of the text.
        let cut = whole.find("</lanelet>").unwrap() + "</lanelet>".len();
        let err = parse_str(&whole[..cut]).unwrap_err().to_string();
        assert!(err.contains("line 8, column 11") && err.contains("never closed"), "{err}");
    }

    #[test]
    fn light_cycle_follows_commonroad_io() {
        let light = Light {
            cycle: vec![(LightColour::Green, 2), (LightColour::Yellow, 3), (LightColour::Red, 2)],
            cycle_steps: 7,
            offset: 3,
            movements: BTreeSet::from([Movement::Straight]),
            active: true,
        };
        // commonroad-io's own test: with offset 3 the cycle starts at step 3.
        assert_eq!(light.colour_at(3), LightColour::Green);
        assert_eq!(light.colour_at(5), LightColour::Yellow);
        assert_eq!(light.colour_at(8), LightColour::Red);
        assert_eq!(light.colour_at(0), LightColour::Yellow);
        assert_eq!(light.state_at(8), SignalState::Stop);
    }

    #[test]
    fn arrow_defers_to_general_light_when_inactive() {
        let mk = |cycle: Vec<(LightColour, u64)>, movements: &[Movement]| Light {
            cycle_steps: cycle.iter().map(|c| c.1).sum(),
            cycle,
            offset: 0,
            movements: movements.iter().copied().collect(),
            active: true,
        };
        let main = mk(vec![(LightColour::Red, 10)], &[Movement::Straight, Movement::Right]);
        let arrow = mk(vec![(LightColour::Green, 5), (LightColour::Inactive, 5)], &[Movement::Right]);
        let lights = [&main, &arrow];
        assert_eq!(lane_signal_state(&lights, &[Movement::Right], 0), SignalState::ArrowGo);
        assert_eq!(lane_signal_state(&lights, &[Movement::Right], 7), SignalState::Stop);
        assert_eq!(lane_signal_state(&lights, &[Movement::Straight, Movement::Right], 0), SignalState::Stop);
    }
}
