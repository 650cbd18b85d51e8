//! What a person needs to review a scenario or a failed planner test:
//! a top-down picture (SVG) and a recording that opens in Foxglove (MCAP
//! with Foxglove's well-known protobuf schemas).
//!
//! This layer owns:
//!
//! - [`svg`]: the top-down picture of a scenario or a rollout (map, agent
//!   footprints at one step, trails, ego/CBV highlighting, collision markers,
//!   legend, caption). Entry points: [`render_scenario_svg`],
//!   [`render_rollout_svg`], [`render_rollout_svg_with`].
//! - [`mcap`]: one MCAP file per rollout (`foxglove.SceneUpdate` per step,
//!   the map once, ego/CBV paths, extra trajectories, collision events).
//!   Entry points: [`encode_rollout_mcap`], [`write_rollout_mcap`].
//! - [`animation`]: a rollout as per-step agent poses and the map lines
//!   around the conflict, for the review page's animated view
//!   ([`animation::RolloutAnimation`]).
//! - [`atomic`]: write-to-temporary-then-rename, so a reader never sees a
//!   half-written artefact; stale temporaries of killed runs are removed.
//! - [`output`]: the one way to write a path the user chose (`-` is
//!   standard output, symlinks followed, devices and FIFOs written in
//!   place, folders refused); everything the CLI and the harness write
//!   goes through [`write_output`].
//!
//! It sits above `sim` (it reads [`Rollout`]s and [`Scenario`]s) and below
//! `harness` and `cli`, which decide when and where artefacts are written.
//!
//! Everything here is deterministic: the same inputs give byte-identical
//! files (floats are written with fixed precision, iteration is in index
//! order, timestamps are simulation time from 0, never the wall clock).
//! Nothing here panics on bad input: non-finite states and points are
//! skipped in pictures; recordings refuse inconsistent rollouts with a
//! [`RecordError`].

pub mod animation;
pub mod atomic;
pub mod commonroad;
pub mod markup;
pub mod mcap;
pub mod output;
pub mod svg;

use std::path::{Path, PathBuf};

use crate::geometry::Pose2;
use crate::scenario::{AgentBody, Scenario};
use crate::sim::Rollout;

pub use atomic::{write_atomically, write_atomically_with};
pub use mcap::encode_rollout_mcap;
pub use output::{
    NamedOutput, OutputKind, check_new_or_forced, check_outputs_apart, check_replaceable, create_parent_folder,
    is_stdout, write_output, write_output_with,
};
pub use svg::SvgOptions;

/// Why an artefact could not be written.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The artefact's path.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The path cannot name an artefact.
    #[error("{path}: cannot write an artefact there: {reason}")]
    InvalidPath {
        /// The path given.
        path: PathBuf,
        /// Why not.
        reason: String,
    },
    /// The MCAP writer refused a record.
    #[error("MCAP writer: {0}")]
    Mcap(#[from] ::mcap::McapError),
    /// A message could not be encoded as protobuf.
    #[error("protobuf encoding: {0}")]
    Encode(#[from] prost::EncodeError),
    /// The rollout contradicts itself (ragged state table, role index
    /// outside the agents, non-positive step length).
    #[error("rollout of scenario {scenario}: {what}")]
    InconsistentRollout {
        /// Scenario id.
        scenario: String,
        /// What is wrong.
        what: String,
    },
}

/// What an extra trajectory drawn beside a rollout stands for; decides its
/// colour and line style in pictures and recordings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub enum TrajectoryRole {
    /// An alternative ego trajectory that avoids the collision: the
    /// evidence that a failure was avoidable.
    #[default]
    FeasibilityWitness,
    /// What the planner said it would do.
    EgoPlan,
    /// Anything else worth drawing (a logged reference, a debug path).
    Reference,
}

impl TrajectoryRole {
    /// Short name for legends and entity ids.
    pub fn label(self) -> &'static str {
        match self {
            Self::FeasibilityWitness => "feasibility witness",
            Self::EgoPlan => "ego plan",
            Self::Reference => "reference",
        }
    }
}

/// A pose at a time, the time in seconds after the rollout's first step
/// (the same clock as the recording's log times).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimedPose {
    /// Seconds after the rollout's start.
    pub time_s: f64,
    /// Position and heading in the scenario frame.
    pub pose: Pose2,
}

/// An extra trajectory to draw next to a rollout, e.g. a feasibility
/// witness next to a failure.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedTrajectory {
    /// Name shown in legends and used as the entity id (unique per call).
    pub name: String,
    /// What it stands for.
    pub role: TrajectoryRole,
    /// Type and footprint size of the agent that would drive it; when
    /// given, its footprint is drawn at the displayed time.
    pub body: Option<AgentBody>,
    /// Poses in increasing time.
    pub poses: Vec<TimedPose>,
}

impl NamedTrajectory {
    /// The pose at `time_s`, interpolated linearly between the two poses
    /// around it; `None` outside the trajectory's time span or where its
    /// poses are not finite.
    pub fn pose_at(&self, time_s: f64) -> Option<Pose2> {
        let finite = |p: &TimedPose| {
            p.time_s.is_finite()
                && p.pose.position.x.is_finite()
                && p.pose.position.y.is_finite()
                && p.pose.heading_rad.is_finite()
        };
        let mut prev: Option<&TimedPose> = None;
        for p in self.poses.iter().filter(|p| finite(p)) {
            // Half a microsecond of slack so a query at a step time matches
            // a pose stored at that step despite float rounding.
            if (p.time_s - time_s).abs() <= 5e-7 {
                return Some(p.pose);
            }
            if p.time_s > time_s {
                let a = prev?;
                let w = (time_s - a.time_s) / (p.time_s - a.time_s);
                if !(0.0..=1.0).contains(&w) {
                    return None;
                }
                let dh = crate::geometry::wrap_angle(p.pose.heading_rad - a.pose.heading_rad);
                return Some(Pose2 {
                    position: a.pose.position + (p.pose.position - a.pose.position) * w,
                    heading_rad: crate::geometry::wrap_angle(a.pose.heading_rad + dh * w),
                });
            }
            prev = Some(p);
        }
        None
    }
}

/// The top-down picture of a scenario without a rollout: recorded tracks as
/// trails, footprints at `opts.step` (default: the scenario's current step),
/// ego and CBV highlighted.
pub fn render_scenario_svg(scenario: &Scenario, opts: &SvgOptions) -> String {
    svg::render_scenario(scenario, opts)
}

/// The top-down picture of a rollout: footprints at `opts.step` (default:
/// the ego's collision step if any, else the last step), trails of the
/// whole rollout, ego and CBV highlighted, collisions marked.
pub fn render_rollout_svg(scenario: &Scenario, rollout: &Rollout, opts: &SvgOptions) -> String {
    svg::render_rollout(scenario, rollout, &[], opts)
}

/// [`render_rollout_svg`] with extra trajectories (e.g. a feasibility
/// witness) drawn beside the rollout.
pub fn render_rollout_svg_with(
    scenario: &Scenario,
    rollout: &Rollout,
    extra: &[NamedTrajectory],
    opts: &SvgOptions,
) -> String {
    svg::render_rollout(scenario, rollout, extra, opts)
}

/// Writes a picture (or any text artefact) by the rules of [`output`]
/// (a file is replaced atomically).
pub fn write_svg(path: &Path, svg: &str) -> Result<(), RecordError> {
    output::write_output(path, svg.as_bytes())
}

/// Writes the rollout's MCAP recording to `path` by the rules of
/// [`output`] (a file is replaced atomically; see [`mcap`] for the topics).
/// The same inputs give the same bytes.
pub fn write_rollout_mcap(
    path: &Path,
    scenario: &Scenario,
    rollout: &Rollout,
    extra: &[NamedTrajectory],
) -> Result<(), RecordError> {
    let bytes = mcap::encode_rollout_mcap(scenario, rollout, extra)?;
    output::write_output(path, &bytes)
}

/// Fixtures shared by this layer's tests: a crossing where the ego, driven
/// at constant velocity, hits the CBV that crosses its lane.
#[cfg(test)]
pub(crate) mod test_support {
    use crate::geometry::{Point2, Polygon, Polyline, Vector2};
    use crate::map::{
        AreaKind, Lane, LaneKind, MapArea, MapElementId, RoadEdge, RoadEdgeKind, RoadLine, RoadLineKind, RoadMap,
        StopSign,
    };
    use crate::planners::BuiltinPlanner;
    use crate::scenario::{
        AgentId, AgentKind, AgentState, DataLicence, RoleOrigin, Scenario, ScenarioSource, SourceFormat, Track,
        TrackIndex,
    };
    use crate::sim::{Rollout, SimConfig, Simulation};

    fn pl(pts: &[(f64, f64)]) -> Polyline {
        Polyline::new(pts.iter().map(|&(x, y)| Point2::new(x, y)).collect())
    }

    fn lane(id: i64, pts: &[(f64, f64)]) -> Lane {
        Lane { kind: LaneKind::SurfaceStreet, ..Lane::new(MapElementId(id), pl(pts)) }
    }

    /// A cross of two two-lane roads at (40, 0); 61 steps of 0.1 s.
    /// Agents: 0 ego (east at 10 m/s in its lane from x = 0), 1 CBV (north
    /// at 7.5 m/s from (41.75, -30)), 2 a parked car, 3 a pedestrian. The
    /// ego's box meets the CBV's at t = 3.9 s (step 39).
    pub(crate) fn crossing_scenario() -> Scenario {
        let edge =
            |id, pts: &[(f64, f64)]| RoadEdge { id: MapElementId(id), polyline: pl(pts), kind: RoadEdgeKind::Boundary };
        let map = RoadMap::new(
            vec![
                lane(1, &[(-60.0, -1.75), (140.0, -1.75)]),
                lane(2, &[(140.0, 1.75), (-60.0, 1.75)]),
                lane(3, &[(41.75, -90.0), (41.75, 60.0)]),
                lane(4, &[(38.25, 60.0), (38.25, -90.0)]),
            ],
            vec![
                edge(10, &[(-60.0, -3.5), (36.5, -3.5), (36.5, -90.0)]),
                edge(11, &[(43.5, -90.0), (43.5, -3.5), (140.0, -3.5)]),
                edge(12, &[(140.0, 3.5), (43.5, 3.5), (43.5, 60.0)]),
                edge(13, &[(36.5, 60.0), (36.5, 3.5), (-60.0, 3.5)]),
            ],
            vec![
                RoadLine {
                    id: MapElementId(20),
                    polyline: pl(&[(-60.0, 0.0), (36.5, 0.0)]),
                    kind: RoadLineKind::SolidDoubleYellow,
                },
                RoadLine {
                    id: MapElementId(21),
                    polyline: pl(&[(40.0, -90.0), (40.0, -3.5)]),
                    kind: RoadLineKind::BrokenSingleWhite,
                },
            ],
            vec![MapArea {
                id: MapElementId(30),
                kind: AreaKind::Crosswalk,
                polygon: Polygon::new(vec![
                    Point2::new(30.0, -3.5),
                    Point2::new(34.0, -3.5),
                    Point2::new(34.0, 3.5),
                    Point2::new(30.0, 3.5),
                ]),
            }],
            vec![],
            vec![StopSign { id: MapElementId(40), position: Point2::new(45.0, -6.0), lanes: vec![MapElementId(3)] }],
            vec![],
        );
        let track = |id: &str, kind, (l, w): (f64, f64), (x, y): (f64, f64), h: f64, v: f64| Track {
            id: AgentId(id.into()),
            kind,
            length_m: l,
            width_m: w,
            states: (0..61)
                .map(|k| {
                    let t = 0.1 * k as f64;
                    let vel = Vector2::new(h.cos(), h.sin()) * v;
                    Some(AgentState { position: Point2::new(x, y) + vel * t, heading_rad: h, velocity_mps: vel })
                })
                .collect(),
        };
        let half_pi = std::f64::consts::FRAC_PI_2;
        Scenario {
            id: "crossing".into(),
            source: ScenarioSource {
                format: SourceFormat::Authored,
                path: "test".into(),
                licence: DataLicence::Project,
                notes: vec![],
            },
            dt_s: 0.1,
            current_step: 0,
            tracks: vec![
                track("ego-1", AgentKind::Vehicle, (4.5, 2.0), (0.0, -1.75), 0.0, 10.0),
                track("cbv-2", AgentKind::Vehicle, (4.5, 2.0), (41.75, -30.0), half_pi, 7.5),
                track("parked-3", AgentKind::Vehicle, (4.8, 2.0), (80.0, 1.75), std::f64::consts::PI, 0.0),
                track("walker-4", AgentKind::Pedestrian, (0.6, 0.6), (20.0, 8.0), 0.0, 1.2),
            ],
            map,
            ego: Some(TrackIndex(0)),
            ego_origin: RoleOrigin::Source,
            cbv: Some(TrackIndex(1)),
            cbv_origin: RoleOrigin::Source,
            objects_of_interest: vec![],
            origin_world: Vector2::new(1000.0, 2000.0),
        }
    }

    /// The ego at constant velocity, background replaying the log.
    pub(crate) fn crossing_rollout(s: &Scenario) -> Rollout {
        let mut planner = BuiltinPlanner::ConstantVelocity.instantiate(s, TrackIndex(0));
        Simulation::new(s, SimConfig::default()).expect("valid set-up").run(planner.as_mut())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planners::BuiltinPlanner;
    use crate::policies::BackgroundPolicy;
    use crate::sim::{SimConfig, Simulation};

    #[test]
    fn pose_at_interpolates_inside_the_span_and_refuses_outside() {
        let t = NamedTrajectory {
            name: "w".into(),
            role: TrajectoryRole::FeasibilityWitness,
            body: None,
            poses: vec![
                TimedPose { time_s: 0.0, pose: Pose2::new(0.0, 0.0, 3.0) },
                TimedPose { time_s: 1.0, pose: Pose2::new(10.0, 2.0, -3.0) },
                TimedPose { time_s: 2.0, pose: Pose2::new(f64::NAN, 0.0, 0.0) },
            ],
        };
        let p = t.pose_at(0.5).unwrap();
        assert!((p.position.x - 5.0).abs() < 1e-12 && (p.position.y - 1.0).abs() < 1e-12);
        // Heading interpolates the short way round, through ±π.
        assert!(p.heading_rad.abs() > 3.1, "{}", p.heading_rad);
        assert_eq!(t.pose_at(1.0).unwrap().position.x, 10.0);
        assert!(t.pose_at(-0.1).is_none() && t.pose_at(1.5).is_none() && t.pose_at(f64::NAN).is_none());
    }

    #[test]
    fn empty_scenario_renders_without_panicking() {
        let mut s = test_support::crossing_scenario();
        s.tracks.clear();
        s.ego = None;
        s.cbv = None;
        s.map = crate::map::RoadMap::default();
        let svg = render_scenario_svg(&s, &SvgOptions { size_px: 0, margin_m: f64::NAN, ..SvgOptions::default() });
        roxmltree::Document::parse(&svg).expect("well-formed XML");
    }

    /// Writes pictures and a recording of the fixture and of the first
    /// recorded WOMD scene to `$SAFER_RECORD_OUT` (default: the temp dir),
    /// for a person to look at: `cargo test --lib record -- --ignored`.
    #[test]
    #[ignore = "writes artefacts for manual inspection"]
    fn write_artefacts_for_inspection() {
        let out = std::env::var_os("SAFER_RECORD_OUT").map_or_else(std::env::temp_dir, PathBuf::from);
        let s = test_support::crossing_scenario();
        let r = test_support::crossing_rollout(&s);
        write_svg(&out.join("crossing-rollout.svg"), &render_rollout_svg(&s, &r, &SvgOptions::default())).unwrap();
        // A witness: the ego braking at 4 m/s² from t = 0.5 s, stopping before the crossing.
        let brake = NamedTrajectory {
            name: "brake at 0.5 s".into(),
            role: TrajectoryRole::FeasibilityWitness,
            body: Some(r.bodies[0]),
            poses: (0..=60)
                .map(|k| {
                    let t = 0.1 * f64::from(k);
                    let tb = (t - 0.5).clamp(0.0, 2.5);
                    let x = 10.0 * t.min(0.5) + 10.0 * tb - 2.0 * tb * tb;
                    TimedPose { time_s: t, pose: Pose2::new(x, -1.75, 0.0) }
                })
                .collect(),
        };
        let with = render_rollout_svg_with(&s, &r, std::slice::from_ref(&brake), &SvgOptions::default());
        write_svg(&out.join("crossing-witness.svg"), &with).unwrap();
        write_rollout_mcap(&out.join("crossing-witness.mcap"), &s, &r, &[brake]).unwrap();
        write_svg(&out.join("crossing-scenario.svg"), &render_scenario_svg(&s, &SvgOptions::default())).unwrap();
        write_rollout_mcap(&out.join("crossing.mcap"), &s, &r, &[]).unwrap();
        // The recorded example, where the recorded data is at hand.
        let Some(data) = crate::spec::paths::data_dir() else { return };
        let womd = data.join("womd-tfrecord/motion_data_one_scenario.tfrecord");
        let Ok(scenarios) = crate::scenario::import::load(&womd) else { return };
        for s in scenarios.iter().take(1) {
            write_svg(&out.join(format!("{}-scenario.svg", s.id)), &render_scenario_svg(s, &SvgOptions::default()))
                .unwrap();
            // The last one drives the background at constant velocity: the
            // CBV, queued behind the ego, runs into it.
            let runs = [
                (BuiltinPlanner::ConstantVelocity, BackgroundPolicy::LogReplay),
                (BuiltinPlanner::Idm, BackgroundPolicy::LogReplay),
                (BuiltinPlanner::LogReplay, BackgroundPolicy::ConstantVelocity),
            ];
            for (planner, background) in runs {
                let mut p = planner.instantiate(s, s.ego.unwrap());
                let config = SimConfig { background, ..SimConfig::default() };
                let r = Simulation::new(s, config).unwrap().run(p.as_mut());
                let name = format!("{}-{}-{background:?}", s.id, r.planner);
                write_svg(&out.join(format!("{name}.svg")), &render_rollout_svg(s, &r, &SvgOptions::default()))
                    .unwrap();
                let mcap = out.join(format!("{name}.mcap"));
                write_rollout_mcap(&mcap, s, &r, &[]).unwrap();
                let size = std::fs::metadata(&mcap).unwrap().len();
                println!(
                    "{name}: {} agents, {} steps, {} collisions, MCAP {size} bytes",
                    r.bodies.len(),
                    r.steps(),
                    r.collisions.len()
                );
            }
        }
    }
}
