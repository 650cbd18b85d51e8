//! Base-scenario specs (`specs/scenarios/*.yaml`): authored on a map
//! template, or taken from a recorded log.
//!
//! ```yaml
//! name: highway-cut-in
//! duration_s: 8
//! map:
//!   straight: { lanes: 2, length_m: 400, speed_limit_mps: 25 }
//! agents:
//!   - { id: ego, lane: 0, s_m: 60, speed_mps: 22 }
//!   - { id: lead, lane: 0, s_m: 110, speed_mps: 18 }
//!   - { id: cbv, lane: 1, s_m: 45, speed_mps: 26 }
//! ego: ego
//! cbv: cbv
//! ```
//! ```yaml
//! name: womd-intersection
//! recorded:
//!   path: data:womd-tfrecord/motion_data_one_scenario.tfrecord
//!   ego: "2406"      # optional: override the source's ego
//!   cbv: "1641"      # optional: override conflict mining
//! ```

use schemars::JsonSchema;
use serde::Deserialize;
use serde_saphyr::Spanned;

use super::{Loaded, NumberRange, SpecError, SpecLocation, paths};
use crate::geometry::{Point2, Vector2};
use crate::map::MapElementId;
use crate::map::templates::MapTemplate;
use crate::policies::IdmParams;
use crate::scenario::{AgentBody, AgentId, AgentKind, AgentState, RoleOrigin, Scenario, TrackIndex, import};
use crate::sim::authoring::{AuthoredAgent, AuthoredBehaviour, AuthoredScenario, synthesize};

/// A base scenario: `map` + `agents` + `ego` (authored) or `recorded`.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ScenarioSpec {
    /// Name used in test names (`suite::scenario::variant`).
    pub name: String,
    /// What the scenario is about.
    #[serde(default)]
    pub description: Option<String>,
    /// Authored: the map template.
    #[serde(default)]
    pub map: Option<MapTemplate>,
    /// Authored: the agents.
    #[serde(default)]
    pub agents: Vec<AgentSpec>,
    /// Authored: id of the ego agent.
    #[serde(default)]
    #[schemars(with = "Option<String>")]
    pub ego: Option<Spanned<String>>,
    /// Authored: id of the critical background vehicle.
    #[serde(default)]
    #[schemars(with = "Option<String>")]
    pub cbv: Option<Spanned<String>>,
    /// Authored: duration, s, in [0.1, 60].
    #[serde(default)]
    #[schemars(range(min = 0.1, max = 60))]
    pub duration_s: Option<f64>,
    /// A recorded log instead of an authored scene.
    #[serde(default)]
    pub recorded: Option<RecordedSpec>,
}

/// A scenario taken from a recorded log.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RecordedSpec {
    /// The file (WOMD .tfrecord/.json, CommonRoad .xml, AV2 folder); `data:REL` for the recorded-data folder, `safer:REL` for a file safer ships.
    #[schemars(with = "String")]
    pub path: Spanned<String>,
    /// Override the ego by agent id.
    #[serde(default)]
    #[schemars(with = "Option<String>")]
    pub ego: Option<Spanned<String>>,
    /// Override the CBV by agent id.
    #[serde(default)]
    #[schemars(with = "Option<String>")]
    pub cbv: Option<Spanned<String>>,
    /// For files holding several scenarios (TFRecord): which one, by id.
    #[serde(default)]
    pub scenario_id: Option<String>,
}

/// Agent types in specs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum AgentKindSpec {
    /// Car.
    #[default]
    Vehicle,
    /// Pedestrian.
    Pedestrian,
    /// Cyclist.
    Cyclist,
}

/// How an authored agent drives while its log is generated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum BehaviourSpec {
    /// Lane following with IDM speed control.
    #[default]
    Idm,
    /// Constant speed and heading.
    ConstantVelocity,
    /// Standing still.
    Parked,
}

/// An authored agent: placed on a lane (`lane` + `s_m`) or at a pose (`x_m`, `y_m`, `heading_deg`).
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AgentSpec {
    /// Unique id.
    #[schemars(with = "String")]
    pub id: Spanned<String>,
    /// Type.
    #[serde(default)]
    pub kind: AgentKindSpec,
    /// Length, m, in (0, 30] (default by kind).
    #[serde(default)]
    #[schemars(extend("exclusiveMinimum" = 0, "maximum" = 30))]
    pub length_m: Option<f64>,
    /// Width, m, in (0, 10] (default by kind).
    #[serde(default)]
    #[schemars(extend("exclusiveMinimum" = 0, "maximum" = 10))]
    pub width_m: Option<f64>,
    /// Lane id of the template (see the template's docs).
    #[serde(default)]
    pub lane: Option<i64>,
    /// Arc length along the lane's centreline, m, from 0 to the lane's length.
    #[serde(default)]
    #[schemars(range(min = 0, max = 100_000))]
    pub s_m: Option<f64>,
    /// Offset to the left of the centreline, m, in [-20, 20].
    #[serde(default)]
    #[schemars(range(min = -20, max = 20))]
    pub lateral_offset_m: Option<f64>,
    /// Position x, m (pose placement), in [-100000, 100000].
    #[serde(default)]
    #[schemars(range(min = -100_000, max = 100_000))]
    pub x_m: Option<f64>,
    /// Position y, m (pose placement), in [-100000, 100000].
    #[serde(default)]
    #[schemars(range(min = -100_000, max = 100_000))]
    pub y_m: Option<f64>,
    /// Heading, degrees counter-clockwise from +x (pose placement), in [-720, 720].
    #[serde(default)]
    #[schemars(range(min = -720, max = 720))]
    pub heading_deg: Option<f64>,
    /// Initial speed, m/s, in [0, 70].
    #[schemars(range(min = 0, max = 70))]
    pub speed_mps: f64,
    /// Behaviour while the scene's log is generated.
    #[serde(default)]
    pub behaviour: BehaviourSpec,
    /// Desired speed for `idm`, m/s, in (0, 70] (default: lane limit, else start speed).
    #[serde(default)]
    #[schemars(extend("exclusiveMinimum" = 0, "maximum" = 70))]
    pub desired_speed_mps: Option<f64>,
}

fn loc<T>(s: &Spanned<T>) -> Option<SpecLocation> {
    SpecLocation::from_saphyr(&s.referenced)
}

fn default_size(kind: AgentKindSpec) -> (f64, f64) {
    match kind {
        AgentKindSpec::Vehicle => (4.6, 1.9),
        AgentKindSpec::Pedestrian => (0.6, 0.6),
        AgentKindSpec::Cyclist => (1.8, 0.7),
    }
}

impl Loaded<ScenarioSpec> {
    /// Builds the scenarios this spec describes (a recorded TFRecord may
    /// hold several), after [`Self::validate`].
    pub fn build(&self) -> Result<Vec<Scenario>, SpecError> {
        self.validate()?;
        match &self.value.recorded {
            Some(r) => self.build_recorded(r),
            None => Ok(vec![self.build_authored()?]),
        }
    }

    /// Checks everything that needs neither the map nor an import, each
    /// error at its value: the name (a test-name part and an artefact
    /// folder), recorded or authored, the recorded file's existence, the
    /// duration, the template's parameters and every agent's numbers. Cheap:
    /// a suite runs it on each scenario when it loads.
    pub fn validate(&self) -> Result<(), SpecError> {
        let s = &self.value;
        super::suite::check_test_name(self, "name", &s.name)?;
        let authored = s.map.is_some() || !s.agents.is_empty() || s.ego.is_some() || s.duration_s.is_some();
        match (&s.recorded, authored) {
            (Some(r), false) => {
                let path = paths::resolve_checked(self.dir(), &r.path.value)
                    .map_err(|e| self.invalid_at("recorded.path", e))?;
                if !path.exists() {
                    return Err(self.reference_at(
                        "recorded.path",
                        format!("{} does not exist{}", path.display(), paths::missing_hint(&r.path.value)),
                    ));
                }
                Ok(())
            }
            (None, true) => self.validate_authored(),
            (Some(_), true) => Err(self.invalid_at(
                "recorded",
                "a scenario is either `recorded:` or authored (`map`, `agents`, `ego`, `duration_s`), not both",
            )),
            (None, false) => Err(self.invalid_at(
                "name",
                "empty scenario: give `recorded: {path: ...}` or `map:`, `agents:`, `ego:` and `duration_s:`",
            )),
        }
    }

    /// The map template and duration every authored scenario must give.
    fn authored_map_and_duration(&self) -> Result<(&MapTemplate, f64), SpecError> {
        let s = &self.value;
        let template = s.map.as_ref().ok_or_else(|| {
            self.invalid_at("map", "authored scenario needs `map:` (straight, merge or intersection)")
        })?;
        let duration_s =
            s.duration_s.ok_or_else(|| self.invalid_at("duration_s", "authored scenario needs `duration_s:`"))?;
        Ok((template, duration_s))
    }

    fn validate_authored(&self) -> Result<(), SpecError> {
        let s = &self.value;
        let (template, duration_s) = self.authored_map_and_duration()?;
        // At least one simulation step (0.1 s), at most a minute.
        self.check_number("duration_s", duration_s, NumberRange::closed(0.1, 60.0), "s")?;
        template
            .validate()
            .map_err(|e| self.invalid_at(&format!("map.{}.{}", template.key(), e.parameter), format!("map: {e}")))?;
        for (i, a) in s.agents.iter().enumerate() {
            for (name, value, range, unit) in [
                ("length_m", a.length_m, NumberRange::above(0.0, 30.0), "m"),
                ("width_m", a.width_m, NumberRange::above(0.0, 10.0), "m"),
                ("s_m", a.s_m, NumberRange::closed(0.0, 1e5), "m"),
                ("lateral_offset_m", a.lateral_offset_m, NumberRange::closed(-20.0, 20.0), "m"),
                ("x_m", a.x_m, NumberRange::closed(-1e5, 1e5), "m"),
                ("y_m", a.y_m, NumberRange::closed(-1e5, 1e5), "m"),
                ("heading_deg", a.heading_deg, NumberRange::closed(-720.0, 720.0), "°"),
                ("speed_mps", Some(a.speed_mps), NumberRange::closed(0.0, 70.0), "m/s"),
                ("desired_speed_mps", a.desired_speed_mps, NumberRange::above(0.0, 70.0), "m/s"),
            ] {
                if let Some(v) = value {
                    self.check_number(&format!("agents[{i}].{name}"), v, range, unit)?;
                }
            }
        }
        Ok(())
    }

    fn build_recorded(&self, r: &RecordedSpec) -> Result<Vec<Scenario>, SpecError> {
        let path = paths::resolve_checked(self.dir(), &r.path.value).map_err(|e| self.invalid(loc(&r.path), e))?;
        let mut scenarios = import::load(&path).map_err(|e| self.reference(loc(&r.path), e.to_string()))?;
        if let Some(id) = &r.scenario_id {
            scenarios.retain(|s| &s.id == id);
            if scenarios.is_empty() {
                return Err(self.reference(loc(&r.path), format!("no scenario with id `{id}` in {}", path.display())));
            }
        }
        for sc in &mut scenarios {
            let find = |id: &Spanned<String>| {
                sc.tracks.iter().position(|t| t.id.0 == id.value).map(TrackIndex).ok_or_else(|| {
                    self.invalid(loc(id), format!("no agent with id `{}` in scenario {}", id.value, sc.id))
                })
            };
            let ego = r.ego.as_ref().map(find).transpose()?;
            let cbv = r.cbv.as_ref().map(find).transpose()?;
            if let Some(e) = ego {
                sc.ego = Some(e);
                sc.ego_origin = RoleOrigin::Source;
                if cbv.is_none() {
                    sc.cbv = None;
                    crate::scenario::roles::assign(sc);
                }
            }
            if let Some(c) = cbv {
                sc.cbv = Some(c);
                sc.cbv_origin = RoleOrigin::Source;
            }
            if sc.ego.is_some() && sc.ego == sc.cbv {
                return Err(self.invalid(r.cbv.as_ref().and_then(loc), "the CBV cannot be the ego"));
            }
        }
        Ok(scenarios)
    }

    fn build_authored(&self) -> Result<Scenario, SpecError> {
        let s = &self.value;
        let (template, duration_s) = self.authored_map_and_duration()?;
        let map = template.build();
        let mut agents = Vec::new();
        for (i, a) in s.agents.iter().enumerate() {
            let field = |name: &str| format!("agents[{i}].{name}");
            if agents.iter().any(|x: &AuthoredAgent| x.id.0 == a.id.value) {
                return Err(self.invalid(loc(&a.id), format!("duplicate agent id `{}`", a.id.value)));
            }
            let (position, heading_rad) = match (a.lane, a.s_m, a.x_m, a.y_m, a.heading_deg) {
                (Some(lane), Some(s_m), None, None, None) => {
                    let l = map.lane(MapElementId(lane)).ok_or_else(|| {
                        let ids: Vec<String> = map.lanes.iter().map(|l| l.id.0.to_string()).collect();
                        self.invalid_at(
                            &field("lane"),
                            format!("agent `{}`: no lane {lane} in this map; lanes are {}", a.id.value, ids.join(", ")),
                        )
                    })?;
                    if !(s_m.is_finite() && s_m >= 0.0 && s_m <= l.centreline.length_m()) {
                        return Err(self.invalid_at(
                            &field("s_m"),
                            format!(
                                "agent `{}`: s_m {s_m} is outside lane {lane} (0..{:.1} m)",
                                a.id.value,
                                l.centreline.length_m()
                            ),
                        ));
                    }
                    let (p, t) = l.centreline.sample(s_m).expect("lane has points");
                    let left = Vector2::new(-t.y, t.x);
                    (p + left * a.lateral_offset_m.unwrap_or(0.0), t.y.atan2(t.x))
                }
                (None, None, Some(x), Some(y), Some(h)) if a.lateral_offset_m.is_none() => {
                    (Point2::new(x, y), crate::geometry::wrap_angle(h.to_radians()))
                }
                _ => {
                    return Err(self.invalid(
                        loc(&a.id),
                        format!(
                            "agent `{}`: place it either on a lane (`lane`, `s_m`, optional `lateral_offset_m`) or at a pose (`x_m`, `y_m`, `heading_deg`)",
                            a.id.value
                        ),
                    ));
                }
            };
            let (dl, dw) = default_size(a.kind);
            let kind = match a.kind {
                AgentKindSpec::Vehicle => AgentKind::Vehicle,
                AgentKindSpec::Pedestrian => AgentKind::Pedestrian,
                AgentKindSpec::Cyclist => AgentKind::Cyclist,
            };
            let behaviour = match a.behaviour {
                BehaviourSpec::Idm => {
                    AuthoredBehaviour::Idm(IdmParams { desired_speed_mps: a.desired_speed_mps, ..IdmParams::default() })
                }
                BehaviourSpec::ConstantVelocity => AuthoredBehaviour::ConstantVelocity,
                BehaviourSpec::Parked => AuthoredBehaviour::Parked,
            };
            agents.push(AuthoredAgent {
                id: AgentId(a.id.value.clone()),
                body: AgentBody { kind, length_m: a.length_m.unwrap_or(dl), width_m: a.width_m.unwrap_or(dw) },
                initial: AgentState {
                    position,
                    heading_rad,
                    velocity_mps: Vector2::new(heading_rad.cos(), heading_rad.sin()) * a.speed_mps,
                },
                behaviour,
            });
        }
        // Two boxes that overlap at the start would be a collision from the
        // first step, which recorded scenes excuse as annotation noise and an
        // authored scene must not need: refuse it where it is written.
        for (j, b) in agents.iter().enumerate() {
            let later = b.body.footprint(&b.initial);
            if let Some(a) = agents[..j].iter().find(|a| a.body.footprint(&a.initial).intersects(&later)) {
                return Err(self.invalid(
                    loc(&s.agents[j].id),
                    format!(
                        "agents `{}` and `{}` overlap at the start (their boxes intersect); place them apart",
                        a.id.0, b.id.0
                    ),
                ));
            }
        }
        let find = |id: &Spanned<String>, role: &str| {
            agents.iter().position(|a| a.id.0 == id.value).ok_or_else(|| {
                let ids: Vec<&str> = agents.iter().map(|a| a.id.0.as_str()).collect();
                self.invalid(loc(id), format!("{role} `{}` is not one of the agents ({})", id.value, ids.join(", ")))
            })
        };
        let ego = s
            .ego
            .as_ref()
            .ok_or_else(|| self.invalid_at("ego", "authored scenario needs `ego:` naming one of the agents"))?;
        let ego = find(ego, "ego")?;
        let cbv = s.cbv.as_ref().map(|c| find(c, "cbv")).transpose()?;
        if cbv == Some(ego) {
            return Err(self.invalid(s.cbv.as_ref().and_then(loc), "the CBV cannot be the ego"));
        }
        Ok(synthesize(&AuthoredScenario {
            id: s.name.clone(),
            path: self.path.clone(),
            map,
            agents,
            ego,
            cbv,
            duration_s,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::parse_yaml;
    use std::path::Path;

    const CUT_IN: &str = "\
name: cut-in
duration_s: 6
map:
  straight: { lanes: 2, length_m: 400 }
agents:
  - { id: ego, lane: 0, s_m: 60, speed_mps: 20 }
  - { id: cbv, lane: 1, s_m: 40, speed_mps: 24, behaviour: constant-velocity }
ego: ego
cbv: cbv
";

    fn load(text: &str) -> Result<Vec<Scenario>, SpecError> {
        parse_yaml::<ScenarioSpec>(text, Path::new("specs/scenarios/t.yaml"))?.build()
    }

    #[test]
    fn agents_overlapping_at_the_start_are_refused_at_the_later_one() {
        let overlapping = CUT_IN.replace(
            "s_m: 40, speed_mps: 24",
            "s_m: 40, speed_mps: 24 }\n  - { id: lead, lane: 0, s_m: 63, speed_mps: 20",
        );
        let e = load(&overlapping).unwrap_err().to_string();
        assert!(e.contains("agents `ego` and `lead` overlap at the start"), "{e}");
        assert!(e.contains("t.yaml:8:"), "at the `lead` entry: {e}");
        // 5 m apart (a 4.5 m car) is not an overlap.
        assert!(load(&overlapping.replace("s_m: 63", "s_m: 65")).is_ok());
    }

    #[test]
    fn authored_scene_becomes_full_tracks() {
        let s = load(CUT_IN).unwrap().remove(0);
        assert_eq!(s.num_steps(), 61);
        assert_eq!(s.tracks.len(), 2);
        assert_eq!((s.ego, s.cbv), (Some(TrackIndex(0)), Some(TrackIndex(1))));
        assert!(s.tracks.iter().all(|t| t.valid_steps() == 61));
        // The constant-velocity CBV covers 24 m/s × 6 s.
        let x = |k: usize| s.tracks[1].state(k).unwrap().position.x;
        assert!((x(60) - x(0) - 144.0).abs() < 1e-6);
        s.validate().unwrap();
    }

    #[test]
    fn typo_in_a_field_names_line_and_column() {
        let err = load(&CUT_IN.replace("speed_mps: 20", "sped_mps: 20")).unwrap_err();
        let SpecError::Parse { location: Some(l), message, .. } = &err else { panic!("{err:?}") };
        assert_eq!(l.line, 6, "{err}");
        assert!(message.contains("sped_mps"), "{message}");
        assert!(err.to_string().starts_with("specs/scenarios/t.yaml:6:"), "{err}");
    }

    #[test]
    fn wrong_type_is_located() {
        let err = load(&CUT_IN.replace("duration_s: 6", "duration_s: six")).unwrap_err();
        assert!(matches!(&err, SpecError::Parse { location: Some(l), .. } if l.line == 2), "{err}");
    }

    #[test]
    fn unknown_ego_and_lane_point_at_the_agent() {
        let err = load(&CUT_IN.replace("ego: ego", "ego: eggo")).unwrap_err();
        let SpecError::Invalid { location: Some(l), message, .. } = &err else { panic!("{err:?}") };
        assert_eq!(l.line, 8);
        assert!(message.contains("eggo") && message.contains("ego, cbv"), "{message}");
        let err = load(&CUT_IN.replace("lane: 1,", "lane: 7,")).unwrap_err();
        assert!(err.to_string().contains("no lane 7") && err.to_string().contains(":7:"), "{err}");
    }

    #[test]
    fn half_placed_agent_and_mixed_kinds_are_refused() {
        let err = load(&CUT_IN.replace("lane: 0, s_m: 60,", "lane: 0,")).unwrap_err();
        assert!(err.to_string().contains("either on a lane"), "{err}");
        let err = load(&format!("{CUT_IN}recorded: {{ path: x.json }}\n")).unwrap_err();
        assert!(err.to_string().contains("not both"), "{err}");
    }

    #[test]
    fn oversized_or_inconsistent_templates_are_refused() {
        let err = load(
            &CUT_IN.replace("straight: { lanes: 2, length_m: 400 }", "straight: { lanes: 3000000, length_m: 400 }"),
        )
        .unwrap_err();
        assert!(err.to_string().contains("lanes must be in 1..=8"), "{err}");
        let err = load(
            &CUT_IN
                .replace("straight: { lanes: 2, length_m: 400 }", "merge: { lanes: 1, length_m: 20, merge_end_m: 10 }"),
        )
        .unwrap_err();
        assert!(err.to_string().contains("length_m"), "{err}");
    }

    #[test]
    fn nan_negative_and_huge_numbers_are_refused_at_their_value() {
        let cases = [
            (
                "s_m: 60, speed_mps: 20",
                "s_m: .nan, speed_mps: 20",
                "6:30: `s_m` must be a number in [0, 100000] m, got NaN",
            ),
            (
                "speed_mps: 20 }",
                "speed_mps: 20, length_m: -4 }",
                "6:59: `length_m` must be a number in (0, 30] m, got -4",
            ),
            ("speed_mps: 20 }", "speed_mps: 20, length_m: 0 }", "got 0"),
            (
                "speed_mps: 20 }",
                "speed_mps: 20, width_m: 1e300 }",
                "`width_m` must be a number in (0, 10] m, got 1e300",
            ),
            ("speed_mps: 20 }", "speed_mps: -1 }", "6:45: `speed_mps` must be a number in [0, 70] m/s, got -1"),
            (
                "speed_mps: 20 }",
                "speed_mps: 20, desired_speed_mps: .nan }",
                "`desired_speed_mps` must be a number in (0, 70]",
            ),
            ("duration_s: 6", "duration_s: 0.01", "2:13: `duration_s` must be a number in [0.1, 60] s, got 0.01"),
            ("duration_s: 6", "duration_s: .inf", "`duration_s` must be a number in [0.1, 60] s, got inf"),
            ("length_m: 400 }", "length_m: .nan }", "4:35: map: length_m must be in 30..=5000, got NaN"),
            ("lanes: 2,", "lanes: 2, lane_width_m: 60,", "4:39: map: lane_width_m must be in 2..=6, got 60"),
        ];
        for (from, to, words) in cases {
            assert!(CUT_IN.contains(from), "{from}");
            let e = load(&CUT_IN.replacen(from, to, 1)).unwrap_err().to_string();
            assert!(e.starts_with("specs/scenarios/t.yaml:") && e.contains(words), "{to}: {e}");
        }
    }

    #[test]
    fn a_scenario_name_that_cannot_be_a_test_or_path_part_is_refused() {
        let e = load(&CUT_IN.replace("name: cut-in", "name: ..")).unwrap_err().to_string();
        assert!(e.starts_with("specs/scenarios/t.yaml:1:7: name `..` cannot be used"), "{e}");
    }

    #[test]
    fn missing_recorded_file_is_a_reference_error() {
        let err = load("name: r\nrecorded:\n  path: nowhere.json\n").unwrap_err();
        assert!(matches!(&err, SpecError::Reference { location: Some(l), .. } if l.line == 3), "{err}");
        assert!(err.to_string().contains("nowhere.json"), "{err}");
    }
}
