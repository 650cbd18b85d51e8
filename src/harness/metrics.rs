//! Suite-level metrics over variants, and their checks: CR (stage 1: share
//! of variants where the CBV hits the replayed ego), SR (stage 2: share the
//! planner under test solves — see [`Stage2Verdict`]), SR over the
//! stage-1-critical variants, and VJ / AJ / YJ (Jensen–Shannon divergence of
//! the CBV's stage-1 speed, acceleration and yaw rate against its logged
//! values over the same steps; bins in [`crate::eval::divergence`]). Two plausibility
//! rates say whether the CBV stayed a road user in stage 1: the share of
//! variants where it collided with a background agent, and the share where
//! it left the road (centre off the road while it started on it), with the
//! mean time it spent off the road.
//!
//! Three more say whether the conflict reached the planner under test in
//! stage 2: *conflict reach* (the share of variants, and of the
//! stage-1-critical ones, whose CBV came within 1 m of the planner's ego),
//! SR over the *avoidable conflicts* (variants the conflict reached, or
//! where the ego collided, less the collisions with no escape), and the
//! share of variants whose ego collision has no escape within the
//! closed-loop witness's budget (the generator's fault).
//!
//! This is the one definition of these metrics: the suite runner, `safer
//! run` and `safer evaluate` each reduce a variant to a [`VariantTally`] and
//! aggregate tallies with [`SuiteMetrics::aggregate`].
//!
//! [`Stage2Verdict`]: super::pipeline::Stage2Verdict

use super::pipeline::DualStage;
use crate::eval::sideways_speed::{SidewaysSpread, changed_lanes, held_sideways_speed_mps};
use crate::eval::spread::Spread;
use crate::eval::tailgating::{TAILGATE_HELD_S, longest_tailgating_s};
use crate::eval::traffic_rules::{ACROSS_LANES_MIN_S, across_lanes_of, wrong_way_of};
use crate::eval::{ConflictKind, Histogram, jensen_shannon, rollout_conflict};
use crate::geometry::wrap_angle;
use crate::map::RoadMap;
use crate::motion::vehicle_limits::{CAR_MAX_CURVATURE_PER_M, DEFAULT_MAX_LATERAL_ACCEL_MPS2};
use crate::scenario::{AgentKind, AgentState, Scenario, TrackIndex};
use crate::sim::EgoContact;
use crate::sim::Rollout;
use crate::spec::suite::SuiteAcceptance;

/// Speeds, accelerations and yaw rates of one agent over a stretch of steps.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KinematicSamples {
    /// Speed at every step the agent is present, m/s.
    pub speeds_mps: Vec<f64>,
    /// Finite-difference acceleration between consecutive present steps, m/s².
    pub accels_mps2: Vec<f64>,
    /// Heading change over [`YAW_RATE_WINDOW_S`] between present steps
    /// that far apart, per second, rad/s.
    #[serde(default)]
    pub yaw_rates_radps: Vec<f64>,
    /// The largest sideways speed across its lanes the agent held for
    /// [`SIDEWAYS_HELD_S`](crate::eval::sideways_speed::SIDEWAYS_HELD_S), m/s (`held_sideways_speed_mps`; `None` when
    /// never measured that long, or not measured: older reports lack it).
    #[serde(default)]
    pub held_sideways_mps: Option<f64>,
    /// Whether the agent changed lanes over these steps
    /// ([`changed_lanes`]; `None` when not measured: older reports lack
    /// it).
    #[serde(default)]
    pub changed_lanes: Option<bool>,
    /// The largest lateral acceleration over [`YAW_RATE_WINDOW_S`]
    /// between present steps that far apart: the heading change per
    /// second times the mean of the two steps' speeds, m/s² (`None` when
    /// never measured: older reports lack it).
    #[serde(default)]
    pub peak_lateral_accel_mps2: Option<f64>,
    /// The most the heading turned over [`YAW_RATE_WINDOW_S`], with every
    /// step between present, beyond what a car turns over the path it
    /// drove then ([`CAR_MAX_CURVATURE_PER_M`] a metre), rad: above 0 the
    /// agent turned tighter than a car steers, on the spot included
    /// (`None` when never measured: older reports lack it).
    #[serde(default)]
    pub peak_turn_beyond_a_car_rad: Option<f64>,
    /// The longest the agent drove on the ego's bumper
    /// ([`longest_tailgating_s`]: behind it within a time gap of
    /// [`TAILGATE_TIME_GAP_S`](crate::eval::tailgating::TAILGATE_TIME_GAP_S)), s (`None`
    /// when the two never shared a step, or not measured: older reports
    /// lack it).
    #[serde(default)]
    pub tailgating_ego_s: Option<f64>,
}

/// The window yaw rates are measured over, s: recorded headings jitter
/// from step to step (a few mrad at 0.1 s is a few hundredths of a rad/s),
/// and over 0.5 s, the token period, that noise is a tenth of what it is
/// between neighbouring steps.
pub const YAW_RATE_WINDOW_S: f64 = 0.5;

/// How far beyond a car's turn the heading must turn over
/// [`YAW_RATE_WINDOW_S`] for [`SuiteMetrics::cbv_tighter_than_a_car_rate`]
/// to count it, rad (3°): the recorded headings' jitter. Over 0.5 s in
/// which they move less than 0.5 m, the recorded vehicles of WOMD
/// interactive turn beyond a car's turn by more than this in 1 of 4 000
/// windows.
pub const TURN_BEYOND_A_CAR_SLACK_RAD: f64 = 0.05;

impl KinematicSamples {
    /// Samples of a sequence of per-step states (`None` where absent) at `dt_s`.
    pub fn of_states(states: impl IntoIterator<Item = Option<AgentState>>, dt_s: f64) -> Self {
        let states: Vec<Option<AgentState>> = states.into_iter().collect();
        let window = ((YAW_RATE_WINDOW_S / dt_s).round() as usize).max(1);
        let windows: Vec<(&AgentState, &AgentState)> = states
            .iter()
            .zip(states.iter().skip(window))
            .filter_map(|(a, b)| Some((a.as_ref()?, b.as_ref()?)))
            .collect();
        let yaw_rate =
            |(a, b): &(&AgentState, &AgentState)| wrap_angle(b.heading_rad - a.heading_rad) / (window as f64 * dt_s);
        let yaw_rates_radps = windows.iter().map(yaw_rate).collect();
        let peak_lateral_accel_mps2 =
            windows.iter().map(|w| yaw_rate(w).abs() * 0.5 * (w.0.speed_mps() + w.1.speed_mps())).reduce(f64::max);
        let speeds = states.iter().map(|s| s.map(|s| s.speed_mps()));
        let peak_turn_beyond_a_car_rad = peak_turn_beyond_a_car_rad(&states, window);
        KinematicSamples {
            yaw_rates_radps,
            peak_lateral_accel_mps2,
            peak_turn_beyond_a_car_rad,
            ..Self::of_speeds(speeds, dt_s)
        }
    }

    /// These samples with the held sideways speed of the same `states`
    /// on `map` ([`held_sideways_speed_mps`]), and whether they change
    /// lanes ([`changed_lanes`]).
    pub fn with_sideways(self, map: &RoadMap, states: &[Option<AgentState>], dt_s: f64) -> Self {
        Self {
            held_sideways_mps: held_sideways_speed_mps(map, states.iter().map(Option::as_ref), dt_s),
            changed_lanes: Some(changed_lanes(map, states, dt_s)),
            ..self
        }
    }

    /// Samples of a sequence of per-step speeds (`None` where absent) at `dt_s`.
    pub fn of_speeds(speeds: impl IntoIterator<Item = Option<f64>>, dt_s: f64) -> Self {
        let v: Vec<Option<f64>> = speeds.into_iter().collect();
        KinematicSamples {
            speeds_mps: v.iter().flatten().copied().collect(),
            accels_mps2: v.windows(2).filter_map(|w| Some((w[1]? - w[0]?) / dt_s)).collect(),
            yaw_rates_radps: Vec::new(),
            held_sideways_mps: None,
            changed_lanes: None,
            peak_lateral_accel_mps2: None,
            peak_turn_beyond_a_car_rad: None,
            tailgating_ego_s: None,
        }
    }
}

/// The largest heading change over `window` steps of `states` all
/// present beyond [`CAR_MAX_CURVATURE_PER_M`] times the path driven (the
/// steps' straight lines added up), rad.
fn peak_turn_beyond_a_car_rad(states: &[Option<AgentState>], window: usize) -> Option<f64> {
    states
        .windows(window + 1)
        .filter_map(|w| {
            let w: Vec<&AgentState> = w.iter().map(Option::as_ref).collect::<Option<_>>()?;
            let path_m: f64 = w.windows(2).map(|p| (p[1].position - p[0].position).norm()).sum();
            let turned_rad = wrap_angle(w[window].heading_rad - w[0].heading_rad).abs();
            Some(turned_rad - CAR_MAX_CURVATURE_PER_M * path_m)
        })
        .reduce(f64::max)
}

/// The CBV's kinematics in a variant: as generated in stage 1, and as
/// logged over exactly the steps stage 1 covered.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CbvKinematics {
    /// Stage 1, driven by the method.
    pub generated: KinematicSamples,
    /// The recording over the same steps.
    pub logged: KinematicSamples,
}

impl CbvKinematics {
    /// The CBV's samples of a stage-1 rollout (`None` without a CBV).
    pub fn of_stage1(scenario: &Scenario, stage1: &Rollout) -> Option<Self> {
        let cbv = stage1.cbv?;
        let map = &scenario.map;
        let ego = stage1.ego;
        let steps = stage1.start_step..stage1.start_step + stage1.states.len();
        // The recording over the same steps, and stage 1's own rows.
        let recorded = |t: TrackIndex| -> Vec<Option<AgentState>> {
            steps.clone().map(|k| scenario.track(t).state(k).copied()).collect()
        };
        let driven = |t: TrackIndex| -> Vec<Option<AgentState>> {
            stage1.states.iter().map(|row| row.get(t.0).copied().flatten()).collect()
        };
        let (generated, logged) = (driven(cbv), recorded(cbv));
        let (replayed_ego, recorded_ego) = (driven(ego), recorded(ego));
        let (cbv_body, ego_body) = (scenario.track(cbv).body(), scenario.track(ego).body());
        let samples = |states: &[Option<AgentState>], ego: &[Option<AgentState>], dt_s: f64| KinematicSamples {
            tailgating_ego_s: longest_tailgating_s((states, cbv_body), (ego, ego_body), dt_s),
            ..KinematicSamples::of_states(states.iter().copied(), dt_s).with_sideways(map, states, dt_s)
        };
        Some(CbvKinematics {
            generated: samples(&generated, &replayed_ego, stage1.dt_s),
            logged: samples(&logged, &recorded_ego, scenario.dt_s),
        })
    }
}

/// What one variant contributes to the suite metrics (serialised in
/// evaluation reports, so that partitions' reports merge into one table).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VariantTally {
    /// The CBV hit the ego in stage 1.
    pub critical: bool,
    /// The planner under test solved stage 2.
    pub solved: bool,
    /// The CBV's kinematics (`None` without a CBV).
    pub cbv: Option<CbvKinematics>,
    /// The CBV collided with a background agent (not the ego) in stage 1.
    pub cbv_hit_background: bool,
    /// ... and was at fault in at least one such collision (classified as
    /// an ego collision is, from the CBV's side: not stopped, not hit from
    /// behind); the rest are a replayed background driving into it.
    pub cbv_at_fault_with_background: bool,
    /// ... and at fault in one with a pedestrian or cyclist (older
    /// reports lack it: read as `false`).
    #[serde(default)]
    pub cbv_at_fault_with_vulnerable: bool,
    /// Time the CBV's centre spent off the road in stage 1, having started
    /// on it, s (0 when it started off the road: a car park is not a fault).
    pub cbv_off_road_s: f64,
    /// The CBV's longest stretch against a lane's traffic in stage 1, s
    /// (the ego's wrong-way rule, [`wrong_way_of`]; 0 when it never drove
    /// against it; older reports lack it: read as 0).
    #[serde(default)]
    pub cbv_wrong_way_s: f64,
    /// The same in stage 2, against the planner's ego.
    #[serde(default)]
    pub cbv_wrong_way_stage2_s: f64,
    /// The CBV's longest stretch driving across the lanes in stage 1, s
    /// ([`across_lanes_of`]; 0 when it never did; older reports lack it:
    /// read as 0).
    #[serde(default)]
    pub cbv_across_lanes_s: f64,
    /// The same in stage 2, against the planner's ego.
    #[serde(default)]
    pub cbv_across_lanes_stage2_s: f64,
    /// A digest of the CBV's stage-1 path (`cbv_path_digest`): two
    /// seeds with equal digests made the same variant.
    pub cbv_path_digest: Option<u64>,
    /// Stage 2: the CBV came within 1 m of the planner's ego.
    pub reached: bool,
    /// Stage 2: the ego collided (with anyone).
    pub collided: bool,
    /// Stage 2: for an ego collision, whether the closed-loop witness
    /// verified an escape (`None`: no collision, or not searched).
    pub escape: Option<bool>,
    /// Stage 2: the ego's first collision was with an agent other than the
    /// CBV (older reports lack it: read as `false`).
    #[serde(default)]
    pub collided_with_other: bool,
    /// Stage 1: the kind of conflict the CBV made with the recorded ego
    /// (`None`: it never came within 1 m).
    #[serde(default)]
    pub stage1_conflict: Option<ConflictKind>,
    /// Stage 2: the kind of conflict the CBV made with the planner's ego.
    #[serde(default)]
    pub conflict: Option<ConflictKind>,
}

impl VariantTally {
    /// Whether the variant is an avoidable conflict: the CBV reached the
    /// ego or the ego collided, and not in a collision without an escape.
    pub fn avoidable_conflict(&self) -> bool {
        (self.reached || self.collided) && self.escape != Some(false)
    }

    /// Whether the CBV drove against a lane's traffic in stage 1 (what
    /// the wrong-way rate counts).
    pub fn cbv_drove_wrong_way(&self) -> bool {
        self.cbv_wrong_way_s > 0.0
    }

    /// The same in stage 2 (what the stage-2 wrong-way rate counts).
    pub fn cbv_drove_wrong_way_in_stage2(&self) -> bool {
        self.cbv_wrong_way_stage2_s > 0.0
    }

    /// Whether the CBV drove across the lanes for at least
    /// [`ACROSS_LANES_MIN_S`] in stage 1 (what the across-lanes rate
    /// counts).
    pub fn cbv_drove_across_lanes(&self) -> bool {
        self.cbv_across_lanes_s >= ACROSS_LANES_MIN_S - 1e-9
    }

    /// The same in stage 2 (what the stage-2 across-lanes rate counts).
    pub fn cbv_drove_across_lanes_in_stage2(&self) -> bool {
        self.cbv_across_lanes_stage2_s >= ACROSS_LANES_MIN_S - 1e-9
    }

    /// Whether the CBV left the road in stage 1 (what the off-road rate
    /// counts).
    pub fn cbv_left_road(&self) -> bool {
        self.cbv_off_road_s > 0.0
    }
}

impl VariantTally {
    /// The tally of a finished variant.
    pub fn of(scenario: &Scenario, stages: &DualStage) -> Self {
        Self::with_background(scenario, stages, &cbv_background_collisions(scenario, &stages.stage1))
    }

    /// [`VariantTally::of`], given the CBV's stage-1 contacts with
    /// background traffic ([`cbv_background_collisions`]) already found.
    pub fn with_background(scenario: &Scenario, stages: &DualStage, background: &[CbvBackgroundContact]) -> Self {
        VariantTally {
            critical: stages.stage1_cbv_hit_ego(),
            solved: stages.verdict.solved(),
            cbv: CbvKinematics::of_stage1(scenario, &stages.stage1),
            cbv_hit_background: !background.is_empty(),
            cbv_at_fault_with_background: background.iter().any(|c| c.at_fault),
            cbv_at_fault_with_vulnerable: background.iter().any(|c| c.at_fault && c.other_kind != AgentKind::Vehicle),
            cbv_off_road_s: cbv_off_road_s(scenario, &stages.stage1),
            cbv_wrong_way_s: cbv_wrong_way_s(scenario, &stages.stage1),
            cbv_wrong_way_stage2_s: cbv_wrong_way_s(scenario, &stages.stage2),
            cbv_across_lanes_s: cbv_across_lanes_s(scenario, &stages.stage1),
            cbv_across_lanes_stage2_s: cbv_across_lanes_s(scenario, &stages.stage2),
            cbv_path_digest: cbv_path_digest(&stages.stage1),
            reached: stages.reach.reached,
            collided: stages.stage2.ego_collision().is_some(),
            collided_with_other: stages
                .stage2
                .ego_collision_other()
                .is_some_and(|other| Some(other) != stages.stage2.cbv),
            escape: stages.escape.as_ref().map(crate::eval::escape::EscapeSearch::avoidable),
            stage1_conflict: rollout_conflict(&scenario.map, &stages.stage1),
            conflict: rollout_conflict(&scenario.map, &stages.stage2),
        }
    }
}

/// One stage-1 collision of the CBV with anyone but the ego (in
/// evaluation reports, to find what the CBV hit and when).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CbvBackgroundContact {
    /// The other agent's id.
    pub other: String,
    /// What it is.
    pub other_kind: AgentKind,
    /// When they first touched, s after the rollout's start.
    pub t_s: f64,
    /// Whether the CBV was at fault (judged as an ego's contact is).
    pub at_fault: bool,
}

/// The CBV's collisions with anyone but the ego in `stage1`.
pub fn cbv_background_collisions(scenario: &Scenario, stage1: &Rollout) -> Vec<CbvBackgroundContact> {
    let Some(cbv) = stage1.cbv else { return Vec::new() };
    let Some(body) = stage1.bodies.get(cbv.0) else { return Vec::new() };
    let state = |step: usize, agent: TrackIndex| {
        stage1.states.get(step.checked_sub(stage1.start_step)?)?.get(agent.0).copied().flatten()
    };
    stage1
        .collisions
        .iter()
        .filter(|c| !c.involves_ego && (c.a == cbv || c.b == cbv))
        .map(|c| {
            let other = c.other_than(cbv);
            let at_fault = match (state(c.step, cbv), state(c.step, other)) {
                (Some(me), Some(them)) => EgoContact::ego_at_fault(&scenario.map, &me, &body.footprint(&me), &them),
                _ => true,
            };
            CbvBackgroundContact {
                other: stage1.agent_ids.get(other.0).map_or_else(|| format!("#{}", other.0), |id| id.0.clone()),
                other_kind: stage1.bodies.get(other.0).map_or(AgentKind::Vehicle, |b| b.kind),
                t_s: (c.step.saturating_sub(stage1.start_step) as f64 * stage1.dt_s * 10.0).round() / 10.0,
                at_fault,
            }
        })
        .collect()
}

/// The digest ([`path_digest`]) of the CBV's path in `stage1`; `None`
/// without a CBV.
fn cbv_path_digest(stage1: &Rollout) -> Option<u64> {
    let cbv = stage1.cbv?;
    Some(path_digest(stage1.states.iter().map(|row| row.get(cbv.0).copied().flatten().map(|s| s.position))))
}

/// A digest (64-bit FNV-1a, the same on every machine) of a path: its
/// position at every step, to the centimetre, and the steps where it is
/// absent (`None`).
fn path_digest(positions: impl Iterator<Item = Option<crate::geometry::Point2>>) -> u64 {
    let mut bytes = Vec::new();
    for p in positions {
        match p {
            Some(p) => {
                bytes.extend(((p.x * 100.0).round() as i64).to_le_bytes());
                bytes.extend(((p.y * 100.0).round() as i64).to_le_bytes());
            }
            None => bytes.extend(i64::MIN.to_le_bytes()),
        }
    }
    super::stable_hash::fnv1a(&bytes)
}

/// Seconds the CBV's centre was off the road in `stage1`, when it started on
/// it. Past the mapped end of the road (where the recording's map was cut
/// off) the road is not known to end, so that is not counted.
pub(crate) fn cbv_off_road_s(scenario: &Scenario, stage1: &Rollout) -> f64 {
    let Some(cbv) = stage1.cbv else { return 0.0 };
    let mut states = stage1.states.iter().filter_map(|row| row.get(cbv.0).copied().flatten());
    let map = &scenario.map;
    match states.next() {
        Some(first) if !map.is_off_road_within_map(&first.position) => {
            states.filter(|s| map.is_off_road_within_map(&s.position)).count() as f64 * stage1.dt_s
        }
        _ => 0.0,
    }
}

/// The CBV's longest stretch against a lane's traffic in `rollout`, s (0
/// without a CBV or when it never drove against one).
fn cbv_wrong_way_s(scenario: &Scenario, rollout: &Rollout) -> f64 {
    rollout.cbv.and_then(|cbv| wrong_way_of(rollout, &scenario.map, cbv)).map_or(0.0, |w| w.duration_s)
}

/// The CBV's longest stretch across the lanes in `rollout`, s (0 without
/// a CBV or when it never drove across them).
fn cbv_across_lanes_s(scenario: &Scenario, rollout: &Rollout) -> f64 {
    rollout.cbv.and_then(|cbv| across_lanes_of(rollout, &scenario.map, cbv)).map_or(0.0, |a| a.duration_s)
}

/// The metrics of a set of variants.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SuiteMetrics {
    /// Variants evaluated.
    pub variants: usize,
    /// Stage-1 collision rate (CR); `None` over no variant.
    pub collision_rate: Option<f64>,
    /// Stage-2 solution rate (SR); `None` over no variant.
    pub solution_rate: Option<f64>,
    /// SR over the variants that were critical in stage 1 (`None` if none were).
    pub solution_rate_critical: Option<f64>,
    /// VJ: JSD of CBV speed, generated vs logged.
    pub velocity_jsd: Option<f64>,
    /// AJ: JSD of CBV acceleration, generated vs logged.
    pub acceleration_jsd: Option<f64>,
    /// YJ: JSD of CBV yaw rate (over [`YAW_RATE_WINDOW_S`]), generated vs logged.
    pub yaw_rate_jsd: Option<f64>,
    /// Share of variants whose CBV collided with a background agent in stage 1.
    pub cbv_background_collision_rate: Option<f64>,
    /// Share of variants where the CBV was at fault in such a collision.
    pub cbv_at_fault_background_collision_rate: Option<f64>,
    /// ... in one with a pedestrian or cyclist.
    pub cbv_at_fault_vulnerable_rate: Option<f64>,
    /// Share of variants whose CBV left the road in stage 1.
    pub cbv_off_road_rate: Option<f64>,
    /// Mean time the CBV spent off the road per variant, s.
    pub cbv_off_road_s: Option<f64>,
    /// Share of variants whose CBV drove against a lane's traffic in
    /// stage 1 (the ego's wrong-way rule).
    pub cbv_wrong_way_rate: Option<f64>,
    /// The same in stage 2, against the planner's ego.
    pub cbv_wrong_way_rate_stage2: Option<f64>,
    /// Share of variants whose CBV drove across the lanes (more than 30°
    /// from every lane it was in, outside intersections) for at least
    /// [`ACROSS_LANES_MIN_S`] in stage 1.
    pub cbv_across_lanes_rate: Option<f64>,
    /// The same in stage 2, against the planner's ego.
    pub cbv_across_lanes_rate_stage2: Option<f64>,
    /// Share of variants whose CBV turned harder than a car's tyres hold
    /// in stage 1: its peak lateral acceleration
    /// ([`KinematicSamples::peak_lateral_accel_mps2`]) over
    /// [`DEFAULT_MAX_LATERAL_ACCEL_MPS2`].
    pub cbv_beyond_grip_rate: Option<f64>,
    /// Share of variants whose CBV turned tighter than a car steers in
    /// stage 1: its heading turned beyond a car's turn
    /// ([`KinematicSamples::peak_turn_beyond_a_car_rad`]) by more than
    /// [`TURN_BEYOND_A_CAR_SLACK_RAD`].
    pub cbv_tighter_than_a_car_rate: Option<f64>,
    /// Share of variants whose CBV drove on the ego's bumper in stage 1
    /// for [`TAILGATE_HELD_S`] or more ([`KinematicSamples::tailgating_ego_s`]).
    pub cbv_tailgating_rate: Option<f64>,
    /// How hard the CBV turned in stage 1: the spread of each variant's
    /// peak lateral acceleration
    /// ([`KinematicSamples::peak_lateral_accel_mps2`]), m/s².
    pub cbv_peak_lateral_accel_mps2: Option<Spread>,
    /// The same for the recorded CBV over the same steps: the reference.
    pub logged_cbv_peak_lateral_accel_mps2: Option<Spread>,
    /// How briskly the CBV moved across its lanes in stage 1: the spread
    /// of each variant's largest sideways speed held for
    /// [`SIDEWAYS_HELD_S`](crate::eval::sideways_speed::SIDEWAYS_HELD_S) (`None` when none was measured).
    pub cbv_sideways: Option<SidewaysSpread>,
    /// The same for the recorded CBV over the same steps: the reference.
    pub logged_cbv_sideways: Option<SidewaysSpread>,
    /// [`SuiteMetrics::cbv_sideways`] over the variants whose CBV changed
    /// lanes in stage 1 ([`changed_lanes`]): the pace of its lane changes.
    pub cbv_lane_change_sideways: Option<SidewaysSpread>,
    /// Stage 2: share of variants whose CBV came within 1 m of the
    /// planner's ego.
    pub conflict_reach: Option<f64>,
    /// The same over the stage-1-critical variants (`None` if none were).
    pub conflict_reach_critical: Option<f64>,
    /// Stage 2: variants that were avoidable conflicts (see
    /// [`VariantTally::avoidable_conflict`]).
    pub avoidable_conflicts: usize,
    /// Of which the planner did not solve: its failures on conflicts it
    /// could have avoided.
    pub avoidable_failures: usize,
    /// SR over the avoidable conflicts (`None` if there were none).
    pub solution_rate_avoidable: Option<f64>,
    /// Stage 2: ego collisions with no escape within the witness's budget
    /// (the generator's fault).
    pub no_escape_collisions: usize,
    /// Of those, the ones with an agent other than the CBV: with recorded
    /// traffic on log replay, mostly a car behind that cannot brake for an
    /// ego braking for the CBV.
    pub no_escape_collisions_with_others: usize,
    /// Their share of the variants.
    pub no_escape_collision_rate: Option<f64>,
    /// Per kind of conflict met by any variant, in [`ConflictKind::ALL`]'s
    /// order: how many variants made it in each stage, and how the
    /// planner fared where it met it.
    pub coverage: Vec<KindCoverage>,
}

/// One row of a suite's conflict coverage.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KindCoverage {
    /// The kind.
    pub kind: ConflictKind,
    /// Variants whose CBV made it with the recorded ego (stage 1).
    pub stage1: usize,
    /// Variants whose CBV made it with the planner's ego (stage 2): the
    /// conflicts the planner met.
    pub variants: usize,
    /// Of those, the ones the planner did not solve.
    pub failures: usize,
    /// SR over them (`None` over none).
    pub solution_rate: Option<f64>,
}

/// The coverage of `tallies` (see [`SuiteMetrics::coverage`]).
fn coverage<'a>(tallies: impl IntoIterator<Item = &'a VariantTally> + Clone) -> Vec<KindCoverage> {
    ConflictKind::ALL
        .iter()
        .map(|&kind| {
            let (mut stage1, mut variants, mut failures) = (0, 0, 0);
            for t in tallies.clone() {
                stage1 += usize::from(t.stage1_conflict == Some(kind));
                if t.conflict == Some(kind) {
                    variants += 1;
                    failures += usize::from(!t.solved);
                }
            }
            KindCoverage { kind, stage1, variants, failures, solution_rate: share(variants - failures, variants) }
        })
        .filter(|c| c.stage1 > 0 || c.variants > 0)
        .collect()
}

/// One suite-level check (a test).
#[derive(Debug, Clone, PartialEq)]
pub struct MetricCheck {
    /// Metric name, as in the test name (`suite::collision_rate`).
    pub name: &'static str,
    /// Measured value.
    pub value: Option<f64>,
    /// Pass/fail with the reason.
    pub result: Result<(), String>,
}

/// `k / of`, or `None` when `of` is zero (a rate over nothing is unknown, not 0 or 1).
fn share(k: usize, of: usize) -> Option<f64> {
    (of > 0).then(|| k as f64 / of as f64)
}

impl SuiteMetrics {
    /// "metrics over N variants: CR … SR … SR(critical) … VJ … AJ …", the
    /// items joined by `separator`, unmeasured values as `-`: the line the
    /// run table and the review page both print.
    pub fn headline(&self, separator: &str) -> String {
        let value = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |x| format!("{x:.3}"));
        let plural = if self.variants == 1 { "" } else { "s" };
        [
            format!("metrics over {} variant{plural}: CR {}", self.variants, value(self.collision_rate)),
            format!("SR {}", value(self.solution_rate)),
            format!("SR(critical) {}", value(self.solution_rate_critical)),
            format!("VJ {}", value(self.velocity_jsd)),
            format!("AJ {}", value(self.acceleration_jsd)),
            format!("reach {}", value(self.conflict_reach)),
            format!("SR(avoidable) {}", value(self.solution_rate_avoidable)),
            format!("no-escape collisions {}", self.no_escape_collisions_named()),
        ]
        .join(separator)
    }

    /// The no-escape collisions, with how many were with other agents than
    /// the CBV where any were.
    fn no_escape_collisions_named(&self) -> String {
        match self.no_escape_collisions_with_others {
            0 => self.no_escape_collisions.to_string(),
            others => format!("{} ({others} with other agents than the CBV)", self.no_escape_collisions),
        }
    }

    /// The conflict coverage as a small table, one line per kind met (none
    /// when no variant made a conflict): kind, stage-1 variants, variants
    /// whose conflict reached the planner, its failures among them, SR.
    pub fn coverage_table(&self) -> Vec<String> {
        if self.coverage.is_empty() {
            return Vec::new();
        }
        let mut lines = vec![format!(
            "{:<22} {:>7} {:>7} {:>8} {:>6}",
            "conflict coverage", "stage 1", "planner", "failures", "SR"
        )];
        for c in &self.coverage {
            lines.push(format!(
                "{:<22} {:>7} {:>7} {:>8} {:>6}",
                c.kind.name(),
                c.stage1,
                c.variants,
                c.failures,
                c.solution_rate.map_or("-".into(), |sr| format!("{sr:.3}"))
            ));
        }
        lines
    }

    /// The metrics of a suite's variant outcomes.
    pub fn compute(outcomes: &[super::VariantOutcome]) -> SuiteMetrics {
        Self::aggregate(outcomes.iter().map(|o| &o.tally))
    }

    /// Aggregates variant tallies.
    pub fn aggregate<'a>(tallies: impl IntoIterator<Item = &'a VariantTally>) -> SuiteMetrics {
        let tallies: Vec<&VariantTally> = tallies.into_iter().collect();
        let (mut n, mut critical, mut solved, mut solved_critical) = (0, 0, 0, 0);
        let (mut hit_background, mut at_fault, mut off_road, mut off_road_s) = (0, 0, 0, 0.0);
        let mut at_fault_vulnerable = 0;
        let (mut wrong_way, mut wrong_way_stage2) = (0, 0);
        let (mut across_lanes, mut across_lanes_stage2) = (0, 0);
        let (mut beyond_grip, mut tighter_than_a_car, mut tailgating) = (0, 0, 0);
        let (mut generated_peak_lateral, mut logged_peak_lateral) = (Vec::new(), Vec::new());
        let (mut reached, mut reached_critical, mut avoidable, mut avoidable_solved, mut no_escape) = (0, 0, 0, 0, 0);
        let mut no_escape_with_others = 0;
        let (mut gv, mut ga, mut lv, mut la) =
            (Histogram::speed(), Histogram::acceleration(), Histogram::speed(), Histogram::acceleration());
        let (mut gy, mut ly) = (Histogram::yaw_rate(), Histogram::yaw_rate());
        let (mut generated_sideways, mut logged_sideways) = (Vec::new(), Vec::new());
        let mut lane_change_sideways = Vec::new();
        for &t in &tallies {
            n += 1;
            critical += usize::from(t.critical);
            solved += usize::from(t.solved);
            solved_critical += usize::from(t.critical && t.solved);
            hit_background += usize::from(t.cbv_hit_background);
            at_fault += usize::from(t.cbv_at_fault_with_background);
            at_fault_vulnerable += usize::from(t.cbv_at_fault_with_vulnerable);
            off_road += usize::from(t.cbv_left_road());
            off_road_s += t.cbv_off_road_s;
            wrong_way += usize::from(t.cbv_drove_wrong_way());
            wrong_way_stage2 += usize::from(t.cbv_drove_wrong_way_in_stage2());
            across_lanes += usize::from(t.cbv_drove_across_lanes());
            across_lanes_stage2 += usize::from(t.cbv_drove_across_lanes_in_stage2());
            reached += usize::from(t.reached);
            reached_critical += usize::from(t.reached && t.critical);
            avoidable += usize::from(t.avoidable_conflict());
            avoidable_solved += usize::from(t.avoidable_conflict() && t.solved);
            no_escape += usize::from(t.escape == Some(false));
            no_escape_with_others += usize::from(t.escape == Some(false) && t.collided_with_other);
            if let Some(cbv) = &t.cbv {
                cbv.generated.speeds_mps.iter().for_each(|v| gv.add(*v));
                cbv.generated.accels_mps2.iter().for_each(|a| ga.add(*a));
                cbv.logged.speeds_mps.iter().for_each(|v| lv.add(*v));
                cbv.logged.accels_mps2.iter().for_each(|a| la.add(*a));
                cbv.generated.yaw_rates_radps.iter().for_each(|y| gy.add(*y));
                cbv.logged.yaw_rates_radps.iter().for_each(|y| ly.add(*y));
                beyond_grip += usize::from(
                    cbv.generated.peak_lateral_accel_mps2.is_some_and(|a| a > DEFAULT_MAX_LATERAL_ACCEL_MPS2),
                );
                tighter_than_a_car += usize::from(
                    cbv.generated.peak_turn_beyond_a_car_rad.is_some_and(|r| r > TURN_BEYOND_A_CAR_SLACK_RAD),
                );
                // A run of exactly the held time counts, whatever the
                // rounding of steps × dt.
                tailgating += usize::from(cbv.generated.tailgating_ego_s.is_some_and(|t| t >= TAILGATE_HELD_S - 1e-9));
                generated_peak_lateral.extend(cbv.generated.peak_lateral_accel_mps2);
                logged_peak_lateral.extend(cbv.logged.peak_lateral_accel_mps2);
                generated_sideways.extend(cbv.generated.held_sideways_mps);
                logged_sideways.extend(cbv.logged.held_sideways_mps);
                if cbv.generated.changed_lanes == Some(true) {
                    lane_change_sideways.extend(cbv.generated.held_sideways_mps);
                }
            }
        }
        SuiteMetrics {
            variants: n,
            collision_rate: share(critical, n),
            solution_rate: share(solved, n),
            solution_rate_critical: share(solved_critical, critical),
            velocity_jsd: jensen_shannon(&gv, &lv),
            acceleration_jsd: jensen_shannon(&ga, &la),
            yaw_rate_jsd: jensen_shannon(&gy, &ly),
            cbv_background_collision_rate: share(hit_background, n),
            cbv_at_fault_background_collision_rate: share(at_fault, n),
            cbv_at_fault_vulnerable_rate: share(at_fault_vulnerable, n),
            cbv_off_road_rate: share(off_road, n),
            cbv_off_road_s: (n > 0).then(|| off_road_s / n as f64),
            cbv_wrong_way_rate: share(wrong_way, n),
            cbv_wrong_way_rate_stage2: share(wrong_way_stage2, n),
            cbv_across_lanes_rate: share(across_lanes, n),
            cbv_across_lanes_rate_stage2: share(across_lanes_stage2, n),
            cbv_beyond_grip_rate: share(beyond_grip, n),
            cbv_tighter_than_a_car_rate: share(tighter_than_a_car, n),
            cbv_tailgating_rate: share(tailgating, n),
            cbv_peak_lateral_accel_mps2: Spread::of(generated_peak_lateral),
            logged_cbv_peak_lateral_accel_mps2: Spread::of(logged_peak_lateral),
            cbv_sideways: SidewaysSpread::of(generated_sideways),
            logged_cbv_sideways: SidewaysSpread::of(logged_sideways),
            cbv_lane_change_sideways: SidewaysSpread::of(lane_change_sideways),
            conflict_reach: share(reached, n),
            conflict_reach_critical: share(reached_critical, critical),
            avoidable_conflicts: avoidable,
            avoidable_failures: avoidable - avoidable_solved,
            solution_rate_avoidable: share(avoidable_solved, avoidable),
            no_escape_collisions: no_escape,
            no_escape_collisions_with_others: no_escape_with_others,
            no_escape_collision_rate: share(no_escape, n),
            coverage: coverage(tallies.iter().copied()),
        }
    }

    /// The checks the spec asks for, in a fixed order. A check over no
    /// variant, or of a metric that could not be measured, fails: nothing
    /// run is not a pass.
    pub fn checks(&self, acceptance: &SuiteAcceptance) -> Vec<MetricCheck> {
        let n = self.variants;
        let unmeasured = |name: &str, why: &str| Err(format!("{name} could not be measured: {why}"));
        let why = |name: &str| match (n, name) {
            (0, _) => "no variant ran",
            (_, "velocity_jsd" | "acceleration_jsd") => "no CBV speeds in stage 1 or in the log",
            (_, "conflict_reach") => "no variant was critical in stage 1",
            _ => "no variant qualified",
        };
        let mut out = Vec::new();
        // (metric, value, lower bound, upper bound, what a failure adds)
        type Bounds = (&'static str, Option<f64>, Option<f64>, Option<f64>, Option<String>);
        let no_escape_cause = (self.no_escape_collisions_with_others > 0).then(|| {
            format!(
                "{} of the {} were with other agents than the CBV (recorded traffic on log replay cannot brake for \
                 an ego that brakes for the CBV; `adversary.background: reactive-log-replay` lets it)",
                self.no_escape_collisions_with_others, self.no_escape_collisions
            )
        });
        let bounds: [Bounds; 6] = [
            ("collision_rate", self.collision_rate, acceptance.collision_rate_min, None, None),
            ("solution_rate", self.solution_rate, acceptance.solution_rate_min, None, None),
            ("velocity_jsd", self.velocity_jsd, None, acceptance.velocity_jsd_max, None),
            ("acceleration_jsd", self.acceleration_jsd, None, acceptance.acceleration_jsd_max, None),
            ("conflict_reach", self.conflict_reach_critical, acceptance.conflict_reach_min, None, None),
            (
                "no_escape_collision_rate",
                self.no_escape_collision_rate,
                None,
                acceptance.no_escape_collision_rate_max,
                no_escape_cause,
            ),
        ];
        for (name, value, min, max, cause) in bounds {
            if min.is_none() && max.is_none() {
                continue;
            }
            let result = match (value, min, max) {
                (Some(v), _, _) if !v.is_finite() => Err(format!("{name} = {v} is not a number over {n} variants")),
                (Some(v), Some(min), _) if v < min || min.is_nan() => {
                    Err(format!("{name} = {v:.3} < {min} over {n} variants"))
                }
                (Some(v), _, Some(max)) if v > max || max.is_nan() => {
                    Err(format!("{name} = {v:.3} > {max} over {n} variants"))
                }
                (Some(_), _, _) => Ok(()),
                (None, _, _) => unmeasured(name, why(name)),
            };
            let result = result.map_err(|e| match &cause {
                Some(cause) => format!("{e}: {cause}"),
                None => e,
            });
            out.push(MetricCheck { name, value, result });
        }
        if let Some(required) = &acceptance.conflict_coverage_min {
            let met = |kind: ConflictKind| self.coverage.iter().find(|c| c.kind == kind).map_or(0, |c| c.variants);
            let short: Vec<String> = required
                .iter()
                .filter(|&(&kind, &min)| met(kind) < min)
                .map(|(&kind, min)| format!("{} {} < {min}", kind.name(), met(kind)))
                .collect();
            let result = if short.is_empty() {
                Ok(())
            } else {
                Err(format!(
                    "conflict coverage short: {} (conflicts the planner met, over {n} variants)",
                    short.join(", ")
                ))
            };
            let covered = required.iter().filter(|&(&kind, &min)| met(kind) >= min).count();
            out.push(MetricCheck { name: "conflict_coverage", value: Some(covered as f64), result });
        }
        out
    }
}

/// The name of the mutation-score check (`suite::mutation_score`), made by
/// the suite's mutation run ([`super::mutation`]).
pub const MUTATION_SCORE: &str = "mutation_score";

/// Names of the metric tests a suite has (known without running anything).
pub fn metric_names(acceptance: &SuiteAcceptance) -> Vec<&'static str> {
    [
        ("collision_rate", acceptance.collision_rate_min.is_some()),
        ("solution_rate", acceptance.solution_rate_min.is_some()),
        ("velocity_jsd", acceptance.velocity_jsd_max.is_some()),
        ("acceleration_jsd", acceptance.acceleration_jsd_max.is_some()),
        ("conflict_reach", acceptance.conflict_reach_min.is_some()),
        ("no_escape_collision_rate", acceptance.no_escape_collision_rate_max.is_some()),
        ("conflict_coverage", acceptance.conflict_coverage_min.is_some()),
        (MUTATION_SCORE, acceptance.mutation_score_min.is_some()),
    ]
    .into_iter()
    .filter_map(|(n, on)| on.then_some(n))
    .collect()
}

/// The suite's verdict over all its variants, in order: when a variant
/// could not run, there are no metrics and every configured metric fails
/// naming the first such variant (an error is never a pass, and a rate over
/// the variants that happened to run would be silently wrong); otherwise
/// the aggregate and its checks, the mutation score's last (`mutation_score`:
/// the check the suite's mutation run made, [`super::mutation::MutationReport::check`]).
/// The one rule behind the metric tests of
/// the cargo-test runner, `safer run` and the review page.
pub fn suite_verdict<'a>(
    acceptance: &SuiteAcceptance,
    variants: impl IntoIterator<Item = (String, Result<&'a VariantTally, String>)>,
    mutation_score: Option<MetricCheck>,
) -> (Option<SuiteMetrics>, Vec<MetricCheck>) {
    let mut tallies = Vec::new();
    for (name, tally) in variants {
        match tally {
            Ok(t) => tallies.push(t),
            Err(e) => {
                let why = format!("variant {name} could not run: {e}");
                let checks = metric_names(acceptance)
                    .into_iter()
                    .map(|m| MetricCheck { name: m, value: None, result: Err(why.clone()) })
                    .collect();
                return (None, checks);
            }
        }
    }
    let metrics = SuiteMetrics::aggregate(tallies);
    let mut checks = metrics.checks(acceptance);
    if acceptance.mutation_score_min.is_some() {
        checks.push(mutation_score.unwrap_or(MetricCheck {
            name: MUTATION_SCORE,
            value: None,
            result: Err("mutation_score could not be measured: the mutants were not run".into()),
        }));
    }
    (Some(metrics), checks)
}

#[cfg(test)]
mod tests {

    #[test]
    fn the_headline_names_every_rate_and_dashes_what_was_not_measured() {
        let solved = VariantTally { critical: true, solved: true, ..VariantTally::default() };
        let failed = VariantTally::default();
        let m = SuiteMetrics::aggregate([&solved, &failed]);
        let line = m.headline(" · ");
        assert!(line.starts_with("metrics over 2 variants: CR 0.500 · SR 0.500 · SR(critical) 1.000"), "{line}");
        // No velocity profiles were tallied: VJ and AJ are unmeasured, not 0.
        assert!(line.contains("VJ - · AJ -"), "{line}");
        assert!(line.ends_with("reach 0.000 · SR(avoidable) - · no-escape collisions 0"), "{line}");
    }

    use super::*;

    fn tally(critical: bool, solved: bool) -> VariantTally {
        VariantTally { critical, solved, ..VariantTally::default() }
    }

    fn acceptance(sr_min: Option<f64>, cr_min: Option<f64>) -> SuiteAcceptance {
        SuiteAcceptance { solution_rate_min: sr_min, collision_rate_min: cr_min, ..SuiteAcceptance::default() }
    }

    #[test]
    fn rates_count_critical_and_solved_variants() {
        let t = [tally(true, true), tally(true, false), tally(false, true), tally(false, false)];
        let m = SuiteMetrics::aggregate(&t);
        assert_eq!(m.variants, 4);
        assert_eq!(m.collision_rate, Some(0.5));
        assert_eq!(m.solution_rate, Some(0.5));
        assert_eq!(m.solution_rate_critical, Some(0.5));
    }

    #[test]
    fn a_variant_that_could_not_run_fails_every_metric_and_hides_the_rates() {
        let (ok, broken) = (tally(true, true), "planner exited with status 3".to_string());
        let variants = vec![
            ("s::a::seed-0".to_string(), Ok(&ok)),
            ("s::b::seed-0".to_string(), Err(broken)),
            ("s::c::seed-0".to_string(), Err("timed out".to_string())),
        ];
        let (metrics, checks) = suite_verdict(&acceptance(Some(0.0), Some(0.0)), variants, None);
        // No rate over the variants that happened to run.
        assert_eq!(metrics, None);
        assert_eq!(checks.iter().map(|c| c.name).collect::<Vec<_>>(), ["collision_rate", "solution_rate"]);
        for c in &checks {
            let err = c.result.clone().unwrap_err();
            assert_eq!(err, "variant s::b::seed-0 could not run: planner exited with status 3");
        }
        // Every variant ran: the aggregate and its checks.
        let (metrics, checks) =
            suite_verdict(&acceptance(Some(1.0), None), vec![("s::a::seed-0".to_string(), Ok(&ok))], None);
        assert_eq!(metrics.and_then(|m| m.solution_rate), Some(1.0));
        assert!(checks.iter().all(|c| c.result.is_ok()), "{checks:?}");
    }

    #[test]
    fn no_variant_is_no_pass() {
        let m = SuiteMetrics::aggregate(&[]);
        assert_eq!(m.solution_rate, None);
        let checks = m.checks(&acceptance(Some(0.0), None));
        assert_eq!(checks.len(), 1);
        let err = checks[0].result.clone().unwrap_err();
        assert!(err.contains("no variant ran"), "{err}");
    }

    #[test]
    fn thresholds_are_inclusive_and_failures_say_by_how_much() {
        let t = [tally(true, true), tally(false, false)];
        let m = SuiteMetrics::aggregate(&t);
        let ok = m.checks(&acceptance(Some(0.5), Some(0.5)));
        assert!(ok.iter().all(|c| c.result.is_ok()), "{ok:?}");
        let bad = m.checks(&acceptance(Some(0.6), None));
        assert_eq!(bad[0].result, Err("solution_rate = 0.500 < 0.6 over 2 variants".to_string()));
    }

    #[test]
    fn a_nan_bound_never_passes() {
        // Specs refuse NaN bounds at load; the check itself must not read
        // NaN as "criterion off" either.
        let m = SuiteMetrics::aggregate(&[tally(false, true)]);
        let checks = m.checks(&acceptance(Some(f64::NAN), None));
        assert!(checks[0].result.is_err(), "{checks:?}");
    }

    #[test]
    fn reach_counts_the_critical_variants_and_sr_avoidable_leaves_out_no_escape_collisions() {
        let t = |critical, reached, collided, escape: Option<bool>| VariantTally {
            critical,
            reached,
            collided,
            escape,
            solved: !collided,
            ..VariantTally::default()
        };
        let tallies = [
            // Critical, reached, solved: an avoidable conflict the planner met.
            t(true, true, false, None),
            // Critical, never reached: replay missed the planner's ego.
            t(true, false, false, None),
            // Reached, collided with an escape: a planner failure.
            t(false, true, true, Some(true)),
            // Collided with no escape: the generator's fault, not counted.
            t(true, true, true, Some(false)),
        ];
        let m = SuiteMetrics::aggregate(&tallies);
        assert_eq!(m.conflict_reach, Some(0.75));
        assert_eq!(m.conflict_reach_critical, Some(2.0 / 3.0));
        assert_eq!((m.avoidable_conflicts, m.avoidable_failures), (2, 1));
        assert_eq!(m.solution_rate_avoidable, Some(0.5));
        assert_eq!((m.no_escape_collisions, m.no_escape_collision_rate), (1, Some(0.25)));
        // The suite checks: reach is over the critical variants.
        let acceptance = SuiteAcceptance {
            conflict_reach_min: Some(0.8),
            no_escape_collision_rate_max: Some(0.25),
            ..SuiteAcceptance::default()
        };
        let checks = m.checks(&acceptance);
        assert_eq!(checks[0].name, "conflict_reach");
        assert_eq!(checks[0].result, Err("conflict_reach = 0.667 < 0.8 over 4 variants".to_string()));
        assert_eq!(checks[1].name, "no_escape_collision_rate");
        assert!(checks[1].result.is_ok(), "{checks:?}");
        // With no critical variant, reach cannot be measured: it fails.
        let none = SuiteMetrics::aggregate(&[t(false, true, false, None)]);
        let err = none.checks(&acceptance)[0].result.clone().unwrap_err();
        assert!(err.contains("no variant was critical in stage 1"), "{err}");
    }

    #[test]
    fn no_escape_collisions_with_other_agents_are_counted_and_named_in_the_failing_check() {
        let no_escape = |collided_with_other| VariantTally {
            critical: true,
            collided: true,
            collided_with_other,
            escape: Some(false),
            ..VariantTally::default()
        };
        // A recorded car into the ego twice, the CBV once; an escapable
        // collision with another agent does not count.
        let escapable_with_other =
            VariantTally { collided: true, collided_with_other: true, escape: Some(true), ..VariantTally::default() };
        let tallies = [no_escape(true), no_escape(false), no_escape(true), escapable_with_other];
        let m = SuiteMetrics::aggregate(&tallies);
        assert_eq!((m.no_escape_collisions, m.no_escape_collisions_with_others), (3, 2));
        assert!(m.headline(" · ").ends_with("no-escape collisions 3 (2 with other agents than the CBV)"));
        let acceptance = SuiteAcceptance { no_escape_collision_rate_max: Some(0.05), ..SuiteAcceptance::default() };
        let err = m.checks(&acceptance)[0].result.clone().unwrap_err();
        assert!(
            err.starts_with("no_escape_collision_rate = 0.750 > 0.05 over 4 variants: 2 of the 3 were with"),
            "{err}"
        );
        assert!(err.contains("`adversary.background: reactive-log-replay`"), "{err}");
        // With the CBV alone, the message is the bare bound.
        let with_cbv = SuiteMetrics::aggregate(&[no_escape(false)]);
        let err = with_cbv.checks(&acceptance)[0].result.clone().unwrap_err();
        assert_eq!(err, "no_escape_collision_rate = 1.000 > 0.05 over 1 variants");
        assert!(with_cbv.headline(" · ").ends_with("no-escape collisions 1"));
    }

    #[test]
    fn the_across_lanes_rates_count_a_second_or_more_and_each_stage_apart() {
        let across = |stage1_s: f64, stage2_s: f64| VariantTally {
            cbv_across_lanes_s: stage1_s,
            cbv_across_lanes_stage2_s: stage2_s,
            ..VariantTally::default()
        };
        // 1 s counts (a sum of 0.1 s steps may fall a hair short of it);
        // 0.9 s, a heading's noise or the start of a turn, does not.
        let tallies = [across(1.0, 0.0), across(0.1 * 10.0 - 1e-12, 1.5), across(0.9, 0.9), across(0.0, 0.0)];
        let m = SuiteMetrics::aggregate(&tallies);
        assert_eq!((m.cbv_across_lanes_rate, m.cbv_across_lanes_rate_stage2), (Some(0.5), Some(0.25)));
        assert!(!across(0.9, 0.0).cbv_drove_across_lanes() && across(0.0, 2.0).cbv_drove_across_lanes_in_stage2());
    }

    #[test]
    fn paths_have_the_same_digest_only_when_they_agree_to_the_centimetre() {
        use crate::geometry::Point2;
        let path = |last_x: f64| path_digest([Some(Point2::new(0.0, 0.0)), Some(Point2::new(last_x, 1.0))].into_iter());
        assert_eq!(path(2.0), path(2.004));
        assert_ne!(path(2.0), path(2.01));
        // Absent at a step is not being at the origin.
        let absent = path_digest([None, Some(Point2::new(2.0, 1.0))].into_iter());
        assert_ne!(absent, path(2.0));
        // Pinned (FNV-1a of the little-endian centimetres 0, 0, 200, 100):
        // the same on every machine and build.
        assert_eq!(path(2.0), 0xe8b4_3378_21d3_5b49);
    }

    #[test]
    fn coverage_counts_each_kind_per_stage_and_the_criterion_fails_when_a_kind_is_short() {
        use crate::eval::ConflictKind::{Crossing, CutIn, RearEnd};
        let tally = |stage1, stage2, solved| VariantTally {
            stage1_conflict: stage1,
            conflict: stage2,
            solved,
            ..VariantTally::default()
        };
        let tallies = [
            tally(Some(CutIn), Some(CutIn), false),
            tally(Some(CutIn), Some(RearEnd), true),
            tally(Some(Crossing), None, true),
            tally(None, None, true),
        ];
        let m = SuiteMetrics::aggregate(&tallies);
        let row = |k| m.coverage.iter().find(|c| c.kind == k).cloned();
        let cut_in = row(CutIn).unwrap();
        assert_eq!((cut_in.stage1, cut_in.variants, cut_in.failures, cut_in.solution_rate), (2, 1, 1, Some(0.0)));
        let rear_end = row(RearEnd).unwrap();
        assert_eq!((rear_end.stage1, rear_end.variants, rear_end.solution_rate), (0, 1, Some(1.0)));
        // Made against the recorded ego only: in the table, not met by the planner.
        let crossing = row(Crossing).unwrap();
        assert_eq!((crossing.stage1, crossing.variants, crossing.solution_rate), (1, 0, None));
        assert_eq!(m.coverage.len(), 3, "kinds nobody made are left out");
        let acceptance = |required: &[(crate::eval::ConflictKind, usize)]| SuiteAcceptance {
            conflict_coverage_min: Some(required.iter().copied().collect()),
            ..SuiteAcceptance::default()
        };
        let check = |required: &[(crate::eval::ConflictKind, usize)]| m.checks(&acceptance(required)).pop().unwrap();
        assert_eq!(check(&[(CutIn, 1), (RearEnd, 1)]).result, Ok(()));
        // The crossing was made against the recorded ego, never met by the planner: short.
        let short = check(&[(CutIn, 1), (Crossing, 1)]);
        assert_eq!(short.name, "conflict_coverage");
        assert_eq!(
            short.result,
            Err("conflict coverage short: crossing 0 < 1 (conflicts the planner met, over 4 variants)".into())
        );
        assert_eq!(short.value, Some(1.0));
        assert!(metric_names(&acceptance(&[(CutIn, 2)])).contains(&"conflict_coverage"));
    }

    #[test]
    fn logged_and_generated_samples_use_the_same_rule() {
        let s = KinematicSamples::of_speeds([Some(1.0), Some(2.0), None, Some(4.0), Some(4.5)], 0.5);
        assert_eq!(s.speeds_mps, vec![1.0, 2.0, 4.0, 4.5]);
        // No acceleration across the gap.
        assert_eq!(s.accels_mps2, vec![2.0, 1.0]);
    }

    #[test]
    fn yaw_rates_are_heading_changes_over_half_a_second_across_the_wrap() {
        use crate::geometry::{Point2, Vector2};
        let at = |heading_rad: f64| {
            Some(AgentState { position: Point2::origin(), heading_rad, velocity_mps: Vector2::new(5.0, 0.0) })
        };
        // 0.1 s steps turning at 0.2 rad/s through ±π, one step missing.
        let pi = std::f64::consts::PI;
        let mut states: Vec<Option<AgentState>> =
            (0..8).map(|k| at(crate::geometry::wrap_angle(pi - 0.06 + 0.02 * k as f64))).collect();
        states[6] = None;
        let s = KinematicSamples::of_states(states, 0.1);
        // Windows 0→5, 2→7 (1→6 has a missing end).
        assert_eq!(s.yaw_rates_radps.len(), 2, "{:?}", s.yaw_rates_radps);
        assert!(s.yaw_rates_radps.iter().all(|y| (y - 0.2).abs() < 1e-9), "{:?}", s.yaw_rates_radps);
        assert_eq!(s.speeds_mps.len(), 7);
    }

    #[test]
    fn the_peak_lateral_acceleration_counts_a_cbv_beyond_grip() {
        use crate::geometry::{Point2, Vector2};
        // Ten 0.1 s steps at `speed`, turning at `yaw_rate` from step `from`.
        let samples = |speed: f64, yaw_rate: f64, from: usize| {
            let states = (0..10usize).map(|k| {
                let heading_rad = yaw_rate * 0.1 * k.saturating_sub(from) as f64;
                let velocity_mps = Vector2::new(heading_rad.cos(), heading_rad.sin()) * speed;
                Some(AgentState { position: Point2::origin(), heading_rad, velocity_mps })
            });
            KinematicSamples::of_states(states, 0.1)
        };
        // 10 m/s at 1 rad/s over a whole 0.5 s window: 10 m/s²; over one
        // 0.1 s step of a window, a fifth of it.
        let beyond = samples(10.0, 1.0, 0);
        assert!((beyond.peak_lateral_accel_mps2.unwrap() - 10.0).abs() < 1e-9, "{beyond:?}");
        let brief = samples(10.0, 1.0, 8);
        assert!((brief.peak_lateral_accel_mps2.unwrap() - 2.0).abs() < 1e-9, "{brief:?}");
        let within = samples(10.0, 0.85, 0);
        assert_eq!(KinematicSamples::of_speeds([Some(1.0)], 0.1).peak_lateral_accel_mps2, None);
        let tally = |generated: KinematicSamples| VariantTally {
            cbv: Some(CbvKinematics { generated, ..CbvKinematics::default() }),
            ..VariantTally::default()
        };
        let tallies = [tally(beyond), tally(brief), tally(within), VariantTally::default()];
        let metrics = SuiteMetrics::aggregate(&tallies);
        assert_eq!(metrics.cbv_beyond_grip_rate, Some(0.25));
        // The peaks' spread is over the three CBVs measured (2, 8.5, 10);
        // the recorded CBV here has none.
        let peaks = metrics.cbv_peak_lateral_accel_mps2.unwrap();
        assert_eq!(peaks.measured, 3);
        assert!((peaks.p50 - 8.5).abs() < 1e-9 && (peaks.max - 10.0).abs() < 1e-9, "{peaks:?}");
        assert_eq!(metrics.logged_cbv_peak_lateral_accel_mps2, None);
    }

    #[test]
    fn the_turn_beyond_a_car_counts_a_cbv_turning_tighter_than_a_car_or_on_the_spot() {
        use crate::geometry::Point2;
        // Ten 0.1 s steps of a unicycle at `speed`, turning at `yaw_rate`.
        let samples = |speed: f64, yaw_rate: f64| {
            let mut state =
                crate::motion::KinematicState { position: Point2::origin(), heading_rad: 0.0, speed_mps: speed };
            let action = crate::motion::Action { accel_mps2: 0.0, yaw_rate_radps: yaw_rate };
            let states = (0..10).map(|_| {
                let now = state.to_agent_state();
                state = crate::motion::kinematic_step(&state, action, 0.1);
                Some(now)
            });
            KinematicSamples::of_states(states, 0.1)
        };
        // Over 0.5 s: 2 m/s at 0.3 rad/s turns 0.15 rad over 1 m, 0.1 less
        // than a car may; at 0.8 rad/s 0.4 rad, 0.15 more; standing, all
        // of a turn is beyond a car's.
        let beyond = |s: &KinematicSamples| s.peak_turn_beyond_a_car_rad.unwrap();
        let car = samples(2.0, 0.3);
        assert!((beyond(&car) + 0.1).abs() < 1e-9, "{car:?}");
        let tight = samples(2.0, 0.8);
        assert!((beyond(&tight) - 0.15).abs() < 1e-9, "{tight:?}");
        let on_the_spot = samples(0.0, 0.2);
        assert!((beyond(&on_the_spot) - 0.1).abs() < 1e-9, "{on_the_spot:?}");
        let jitter = samples(0.0, 0.05);
        assert_eq!(KinematicSamples::of_speeds([Some(1.0)], 0.1).peak_turn_beyond_a_car_rad, None);
        let tally = |generated: KinematicSamples| VariantTally {
            cbv: Some(CbvKinematics { generated, ..CbvKinematics::default() }),
            ..VariantTally::default()
        };
        // The tight turn and the one on the spot count; the car's turn and
        // 0.025 rad on the spot (within the recorded headings' jitter) do not.
        let tallies = [tally(car), tally(tight), tally(on_the_spot), tally(jitter), VariantTally::default()];
        assert_eq!(SuiteMetrics::aggregate(&tallies).cbv_tighter_than_a_car_rate, Some(0.4));
    }

    #[test]
    fn a_cbv_counts_as_tailgating_from_a_second_on_the_egos_bumper() {
        let tally = |tailgating_ego_s: Option<f64>| VariantTally {
            cbv: Some(CbvKinematics {
                generated: KinematicSamples { tailgating_ego_s, ..KinematicSamples::default() },
                ..CbvKinematics::default()
            }),
            ..VariantTally::default()
        };
        // 10 steps of 0.1 s make the held second; 0.9 s and unmeasured do not.
        let held = 10.0 * 0.1;
        let tallies = [tally(Some(held)), tally(Some(2.5)), tally(Some(0.9)), tally(Some(0.0)), tally(None)];
        assert_eq!(SuiteMetrics::aggregate(&tallies).cbv_tailgating_rate, Some(0.4));
    }

    #[test]
    fn the_stage1_cbv_on_the_replayed_egos_bumper_is_measured_beside_the_recorded_one() {
        use crate::geometry::{Point2, Vector2};
        use crate::scenario::{AgentId, ScenarioSource, Track};
        let car = |x: f64| {
            Some(AgentState { position: Point2::new(x, 0.0), heading_rad: 0.0, velocity_mps: Vector2::new(20.0, 0.0) })
        };
        let track = |id: &str, states: Vec<Option<AgentState>>| Track {
            id: AgentId(id.into()),
            kind: AgentKind::Vehicle,
            length_m: 4.5,
            width_m: 2.0,
            states,
        };
        // The ego at 20 m/s; the recorded CBV 30 m behind it, the
        // generated one 0.2 m off its tail for the whole 2 s.
        let ego: Vec<_> = (0..21).map(|k| car(2.0 * k as f64)).collect();
        let recorded_cbv: Vec<_> = (0..21).map(|k| car(2.0 * k as f64 - 34.5)).collect();
        let generated_cbv: Vec<_> = (0..21).map(|k| car(2.0 * k as f64 - 4.7)).collect();
        let tracks = vec![track("ego", ego.clone()), track("cbv", recorded_cbv)];
        let scenario = Scenario::new("s", ScenarioSource::authored("test"), 0.1, RoadMap::default(), tracks)
            .with_roles(TrackIndex(0), Some(TrackIndex(1)));
        let stage1 = Rollout {
            scenario_id: "s".into(),
            dt_s: 0.1,
            start_step: 0,
            ego: TrackIndex(0),
            cbv: Some(TrackIndex(1)),
            agent_ids: vec![],
            bodies: vec![],
            states: ego.iter().zip(&generated_cbv).map(|(e, c)| vec![*e, *c]).collect(),
            collisions: vec![],
            off_road: vec![],
            min_distance_to_ego: None,
            termination: crate::sim::Termination::Completed,
            planner: "log-replay".into(),
            planner_debug: vec![],
        };
        let k = CbvKinematics::of_stage1(&scenario, &stage1).unwrap();
        assert!((k.generated.tailgating_ego_s.unwrap() - 2.1).abs() < 1e-9, "{:?}", k.generated.tailgating_ego_s);
        assert_eq!(k.logged.tailgating_ego_s, Some(0.0));
    }
}
