//! The in-memory scenario: agent tracks over time with valid masks, the
//! road map, the ego and the critical background vehicle (CBV), and where it
//! came from. [`import`] reads recorded logs into it; [`roles`] picks ego and
//! CBV where a source names none; [`contact`] says who is at fault in a
//! contact, and [`following`] whether one road user rides another's bumper.
//!
//! Coordinates are re-centred on import ([`Scenario::recentre`]): recorded
//! logs use city-scale frames (several kilometres), and the features the
//! learned models consume are `f32`. [`Scenario::origin_world`] keeps the
//! offset so outputs can be mapped back.

pub mod bounds;
pub mod contact;
pub mod following;
pub mod import;
pub mod roles;

use std::path::PathBuf;

use crate::geometry::{OrientedBox, Point2, Pose2, Vector2, wrap_angle};
use crate::map::RoadMap;

/// Identifier of an agent as the source names it (WOMD/CommonRoad integers,
/// Argoverse 2 strings such as `"AV"`).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
pub struct AgentId(pub String);

impl std::fmt::Display for AgentId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// Index of a track in [`Scenario::tracks`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
pub struct TrackIndex(pub usize);

/// What kind of road user a track is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum AgentKind {
    /// Car, truck, bus, motorcycle.
    Vehicle,
    /// Pedestrian.
    Pedestrian,
    /// Cyclist.
    Cyclist,
    /// Anything else (static objects, unknown).
    Other,
}

/// One agent's state at one step, in the scenario frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AgentState {
    /// Box centre, metres.
    pub position: Point2,
    /// Heading, radians in `(-π, π]`.
    pub heading_rad: f64,
    /// Velocity, m/s.
    pub velocity_mps: Vector2,
}

impl AgentState {
    /// Speed, m/s.
    pub fn speed_mps(&self) -> f64 {
        self.velocity_mps.norm()
    }

    /// Position and heading.
    pub fn pose(&self) -> Pose2 {
        Pose2 { position: self.position, heading_rad: self.heading_rad }
    }
}

/// An agent's type and footprint size: what others can see of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AgentBody {
    /// Agent type.
    pub kind: AgentKind,
    /// Box length, metres.
    pub length_m: f64,
    /// Box width, metres.
    pub width_m: f64,
}

impl AgentBody {
    /// The footprint of this body at `state`.
    pub fn footprint(&self, state: &AgentState) -> OrientedBox {
        OrientedBox::new(state.pose(), self.length_m, self.width_m)
    }

    /// Half the diagonal, m: how far the footprint reaches from its
    /// centre at any heading (see [`OrientedBox::half_diagonal_m`]).
    pub fn half_diagonal_m(&self) -> f64 {
        OrientedBox::new(crate::geometry::Pose2::new(0.0, 0.0, 0.0), self.length_m, self.width_m).half_diagonal_m()
    }
}

/// An agent's recorded (or simulated) trajectory.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// Source id.
    pub id: AgentId,
    /// Agent type.
    pub kind: AgentKind,
    /// Box length, metres.
    pub length_m: f64,
    /// Box width, metres.
    pub width_m: f64,
    /// State per step; `None` where the source has no valid observation.
    pub states: Vec<Option<AgentState>>,
}

impl Track {
    /// The state at `step`, if valid.
    pub fn state(&self, step: usize) -> Option<&AgentState> {
        self.states.get(step).and_then(Option::as_ref)
    }

    /// The footprint at `step`, if valid.
    pub fn footprint(&self, step: usize) -> Option<OrientedBox> {
        self.state(step).map(|s| OrientedBox::new(s.pose(), self.length_m, self.width_m))
    }

    /// Type and size.
    pub fn body(&self) -> AgentBody {
        AgentBody { kind: self.kind, length_m: self.length_m, width_m: self.width_m }
    }

    /// Number of valid steps.
    pub fn valid_steps(&self) -> usize {
        self.states.iter().filter(|s| s.is_some()).count()
    }
}

/// The recorded-data format a scenario came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SourceFormat {
    /// Waymo Open Motion Dataset `Scenario` protobuf in TFRecord framing.
    WomdProto,
    /// WOMD converted to the nocturne / GPUDrive JSON scene format.
    WomdJson,
    /// CommonRoad 2020a XML.
    CommonRoad,
    /// Argoverse 2 motion forecasting (parquet + map JSON).
    Argoverse2,
    /// Authored in a YAML spec, or generated.
    Authored,
}

impl SourceFormat {
    /// Its name in specs, reports and the planner protocol (`womd-proto`,
    /// `common-road`, …).
    pub fn name(self) -> &'static str {
        match self {
            Self::WomdProto => "womd-proto",
            Self::WomdJson => "womd-json",
            Self::CommonRoad => "common-road",
            Self::Argoverse2 => "argoverse2",
            Self::Authored => "authored",
        }
    }
}

/// Licence of the data a scenario was recorded from; decides whether it
/// may be used to train shipped models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DataLicence {
    /// Waymo Open Dataset licence: non-commercial.
    WaymoNonCommercial,
    /// US public domain (NGSIM).
    PublicDomain,
    /// CC BY-NC-SA 4.0 (Argoverse 2).
    CcByNcSa4,
    /// Authored or synthetic: the project's own.
    Project,
}

impl DataLicence {
    /// Whether models shipped in `models/` may be trained on such data.
    pub fn allows_training_shipped_models(self) -> bool {
        matches!(self, Self::PublicDomain | Self::Project)
    }
}

/// Where a scenario came from.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ScenarioSource {
    /// Format of the file.
    pub format: SourceFormat,
    /// File it was read from.
    pub path: PathBuf,
    /// Licence of the recording.
    pub licence: DataLicence,
    /// Facts the importer established that a user may need to know (e.g.
    /// the heading unit it detected), in reading order.
    pub notes: Vec<String>,
}

impl ScenarioSource {
    /// Provenance of a scenario authored or generated by this project.
    pub fn authored(path: impl Into<PathBuf>) -> Self {
        Self { format: SourceFormat::Authored, path: path.into(), licence: DataLicence::Project, notes: vec![] }
    }
}

/// How a role (ego, CBV) was assigned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RoleOrigin {
    /// Named by the source (WOMD `sdc_track_index`, AV2 `AV`, a spec).
    Source,
    /// Chosen by conflict mining (see [`roles`]).
    ConflictMining,
    /// The source's labelled interacting pair (WOMD `objects_of_interest`)
    /// when it leaves out the SDC (see [`roles::assign`]).
    LabelledPair,
    /// A vehicle in a lane merging with the ego's, chosen on request
    /// (`safer evaluate --roles merging`, see [`roles::assign_merging`]).
    MergeMining,
    /// The vehicle ahead of the ego in its path, chosen on request
    /// (`safer evaluate --roles leader`, see [`roles::assign_leader`]).
    LeaderMining,
    /// A vehicle whose recorded path crosses the ego's, chosen on request
    /// (`safer evaluate --roles crossing`, see [`roles::assign_crossing`]).
    CrossingMining,
    /// Not assigned.
    Unassigned,
}

/// A scenario: tracks, map, roles and provenance.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Scenario id (from the source, else the file stem).
    pub id: String,
    /// Provenance.
    pub source: ScenarioSource,
    /// Step length, seconds.
    pub dt_s: f64,
    /// Index of "now" (WOMD: 10); history before it, future after it.
    pub current_step: usize,
    /// All agents; every track has the same number of steps.
    pub tracks: Vec<Track>,
    /// The road map.
    pub map: RoadMap,
    /// The ego (self-driving car) track.
    pub ego: Option<TrackIndex>,
    /// How the ego was chosen.
    pub ego_origin: RoleOrigin,
    /// The critical background vehicle the adversary will drive.
    pub cbv: Option<TrackIndex>,
    /// How the CBV was chosen.
    pub cbv_origin: RoleOrigin,
    /// Tracks the source marks as interesting (WOMD objects of interest,
    /// AV2 focal track), in source order.
    pub objects_of_interest: Vec<TrackIndex>,
    /// World coordinates of this scenario's local origin, metres.
    pub origin_world: Vector2,
}

/// A broken invariant found by [`Scenario::validate`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("scenario {scenario}: {what}")]
pub struct InvariantViolation {
    /// Scenario id.
    pub scenario: String,
    /// What is wrong, with the track and step.
    pub what: String,
}

impl Scenario {
    /// A scenario from tracks and a map, "now" at step 0, no roles assigned
    /// and the origin where the coordinates already are.
    pub fn new(id: impl Into<String>, source: ScenarioSource, dt_s: f64, map: RoadMap, tracks: Vec<Track>) -> Self {
        Self {
            id: id.into(),
            source,
            dt_s,
            current_step: 0,
            tracks,
            map,
            ego: None,
            ego_origin: RoleOrigin::Unassigned,
            cbv: None,
            cbv_origin: RoleOrigin::Unassigned,
            objects_of_interest: vec![],
            origin_world: Vector2::zeros(),
        }
    }

    /// The same scenario with ego and CBV named by the author.
    pub fn with_roles(self, ego: TrackIndex, cbv: Option<TrackIndex>) -> Self {
        self.with_source_roles(Some(ego), cbv)
    }

    /// The same scenario with the roles its source names (each `None` stays
    /// unassigned, for conflict mining to fill).
    pub fn with_source_roles(mut self, ego: Option<TrackIndex>, cbv: Option<TrackIndex>) -> Self {
        let origin = |r: Option<TrackIndex>| if r.is_some() { RoleOrigin::Source } else { RoleOrigin::Unassigned };
        (self.ego, self.ego_origin, self.cbv, self.cbv_origin) = (ego, origin(ego), cbv, origin(cbv));
        self
    }

    /// Number of steps of every track.
    pub fn num_steps(&self) -> usize {
        self.tracks.first().map_or(0, |t| t.states.len())
    }

    /// Duration covered by the tracks, seconds.
    pub fn duration_s(&self) -> f64 {
        self.num_steps().saturating_sub(1) as f64 * self.dt_s
    }

    /// The track at `index`.
    pub fn track(&self, index: TrackIndex) -> &Track {
        &self.tracks[index.0]
    }

    /// Moves the local origin to the centre of the agents' bounding box at
    /// the current step (rounded to whole metres, so the offset is exact),
    /// shifting tracks and map. Idempotent up to that rounding.
    pub fn recentre(&mut self) {
        let step = self.current_step;
        let pts: Vec<Point2> = self
            .tracks
            .iter()
            .filter_map(|t| t.state(step).or_else(|| t.states.iter().flatten().next()))
            .map(|s| s.position)
            .collect();
        let Some(first) = pts.first().copied() else {
            return;
        };
        let (lo, hi) = pts.iter().fold((first, first), |(lo, hi), p| {
            (Point2::new(lo.x.min(p.x), lo.y.min(p.y)), Point2::new(hi.x.max(p.x), hi.y.max(p.y)))
        });
        let offset = Vector2::new(((lo.x + hi.x) * 0.5).round(), ((lo.y + hi.y) * 0.5).round());
        if offset == Vector2::zeros() {
            return;
        }
        for t in &mut self.tracks {
            for s in t.states.iter_mut().flatten() {
                s.position -= offset;
            }
        }
        self.map = std::mem::take(&mut self.map).translated(&offset);
        self.origin_world += offset;
    }

    /// The first recorded state (track, step, why) outside a box of
    /// ±`max_abs_position_m` or otherwise implausible ([`bounds`]).
    pub fn first_implausible_state(&self, max_abs_position_m: f64) -> Option<(TrackIndex, usize, String)> {
        self.tracks.iter().enumerate().find_map(|(i, t)| {
            t.states.iter().enumerate().find_map(|(k, s)| {
                bounds::implausibility_within(s.as_ref()?, max_abs_position_m).map(|why| (TrackIndex(i), k, why))
            })
        })
    }

    /// Checks the invariants every importer must establish: equal track
    /// lengths, finite values, headings in `(-π, π]`, positive sizes, roles
    /// that index existing tracks, `current_step` inside the tracks.
    pub fn validate(&self) -> Result<(), InvariantViolation> {
        let fail = |what: String| Err(InvariantViolation { scenario: self.id.clone(), what });
        let n = self.num_steps();
        if !(self.dt_s.is_finite() && self.dt_s > 0.0) {
            return fail(format!("step length {} s is not positive", self.dt_s));
        }
        if n > 0 && self.current_step >= n {
            return fail(format!("current step {} outside {} steps", self.current_step, n));
        }
        for (i, t) in self.tracks.iter().enumerate() {
            if t.states.len() != n {
                return fail(format!("track {} ({}) has {} steps, expected {n}", i, t.id, t.states.len()));
            }
            if !(t.length_m.is_finite() && t.length_m > 0.0 && t.width_m.is_finite() && t.width_m > 0.0) {
                return fail(format!(
                    "track {} ({}) has size {} x {} m",
                    i,
                    t.id,
                    crate::number::shown(t.length_m),
                    crate::number::shown(t.width_m)
                ));
            }
            if t.length_m.max(t.width_m) > bounds::MAX_BODY_M {
                return fail(format!(
                    "track {} ({}) has size {} x {} m, beyond the {} m an agent's box may have",
                    i,
                    t.id,
                    crate::number::shown(t.length_m),
                    crate::number::shown(t.width_m),
                    bounds::MAX_BODY_M
                ));
            }
            for (k, s) in t.states.iter().enumerate() {
                let Some(s) = s else { continue };
                let finite = s.position.x.is_finite()
                    && s.position.y.is_finite()
                    && s.heading_rad.is_finite()
                    && s.velocity_mps.x.is_finite()
                    && s.velocity_mps.y.is_finite();
                if !finite {
                    return fail(format!("track {} ({}) step {k}: non-finite state {s:?}", i, t.id));
                }
                if let Some(why) = bounds::implausibility(s) {
                    return fail(format!("track {} ({}) step {k}: {why} after re-centring", i, t.id));
                }
                if (wrap_angle(s.heading_rad) - s.heading_rad).abs() > 1e-9 {
                    return fail(format!("track {} ({}) step {k}: heading {} outside (-π, π]", i, t.id, s.heading_rad));
                }
            }
        }
        for (name, role) in [("ego", self.ego), ("CBV", self.cbv)] {
            if let Some(TrackIndex(i)) = role
                && i >= self.tracks.len()
            {
                return fail(format!("{name} index {i} outside {} tracks", self.tracks.len()));
            }
        }
        if self.ego.is_some() && self.ego == self.cbv {
            return fail("ego and CBV are the same track".to_string());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::SourceFormat;

    #[test]
    fn a_source_format_is_named_as_it_serialises() {
        for format in [
            SourceFormat::WomdProto,
            SourceFormat::WomdJson,
            SourceFormat::CommonRoad,
            SourceFormat::Argoverse2,
            SourceFormat::Authored,
        ] {
            assert_eq!(serde_json::to_value(format).unwrap(), format.name());
        }
    }
}
