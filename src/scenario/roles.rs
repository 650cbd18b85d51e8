//! Ego and CBV assignment by conflict mining, for sources that name no ego
//! (CommonRoad NGSIM, older WOMD JSON) or no critical background vehicle.
//!
//! A labelled interacting pair comes first: WOMD's interactive scenes name
//! two `objects_of_interest`, and the paper makes the object of interest
//! the CBV. When the SDC is one of the two, the importer already made the
//! other the CBV. When it is not and both are vehicles, the pair becomes ego
//! and CBV (the SDC drives as background): the labelled interaction is the
//! conflict to test, and the SDC is often nowhere near it. Of the two, the
//! ego is the one with more valid future steps, ties to the lower index (as
//! in mining). A pair with a pedestrian or cyclist falls back to mining a
//! CBV for the SDC.
//!
//! The conflict of two vehicles is their closest approach: the minimum box
//! distance over the steps from `current_step` on where both are valid. The
//! ego/CBV pair is the pair of *moving* vehicles with the closest approach;
//! ties break on the earlier time, then the lower track indices, so the
//! choice is a pure function of the scenario. Pairs whose recorded boxes
//! overlap at any step from the current one are skipped: in the shared data
//! these are annotation errors (NGSIM has many), and a pair that really
//! crashed in the log makes no avoidable test either. Without this rule the
//! closest pair is almost always such an overlap (12 of 84 NGSIM scenes).
//!
//! On request ([`RolePairing::Merging`]) a scene is tested with a merging
//! pair instead: of the vehicles in lanes that merge ahead of both, the
//! one that reaches the merge point nearest in time to the ego, so that
//! the CBV can meet the ego there (the closest recorded approach picks
//! cars that start beside each other, or are gone before the other comes).
//!
//! Or with the ego's leader ([`RolePairing::Leader`]): the nearest moving
//! vehicle ahead of the ego along its recorded path, the car it follows
//! (or comes up behind in the lane it moves into). The
//! closest recorded approach seldom picks it (a leader keeps its headway),
//! and a CBV beside or behind the ego can only close on it from the side
//! or the rear, which no braking fault of a planner answers to; a leader
//! that brakes is the conflict that tests the ego's braking.
//!
//! Or with a crossing pair ([`RolePairing::Crossing`]): a vehicle whose
//! recorded path crosses the ego's at 45° or more (across its way at a
//! junction, or turning across it), both passing the crossing point 1 s
//! or more from now; of those, the one with the least post-encroachment
//! time (centre to centre: how long after the first passed the point the
//! second did). The closest approach often picks a car beside or behind
//! the ego, which does not meet it at a junction.

use super::{AgentKind, AgentState, RoleOrigin, Scenario, TrackIndex};
use crate::geometry::{Point2, Polyline, Vector2, wrap_angle};
use crate::map::MapElementId;
use crate::map::lane_relations::{LaneAhead, LaneRelations};

/// A vehicle must reach this speed at some future step to count as moving;
/// parked cars make "closest" pairs that no adversary can use.
const MOVING_SPEED_MPS: f64 = 1.0;
/// A candidate needs this many valid future steps (2 s at 10 Hz) to be
/// worth driving adversarially.
const MIN_FUTURE_STEPS: usize = 20;

/// The closest approach of two tracks from the current step on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosestApproach {
    /// Minimum box distance, metres (0 when the boxes touch).
    pub distance_m: f64,
    /// Step at which it happens.
    pub step: usize,
}

/// Closest approach of tracks `a` and `b` over steps `current_step..`.
pub fn closest_approach(scenario: &Scenario, a: TrackIndex, b: TrackIndex) -> Option<ClosestApproach> {
    let (ta, tb) = (scenario.track(a), scenario.track(b));
    let reach = 0.5 * (ta.length_m.hypot(ta.width_m) + tb.length_m.hypot(tb.width_m));
    let mut best: Option<ClosestApproach> = None;
    for step in scenario.current_step..scenario.num_steps() {
        let (Some(sa), Some(sb)) = (ta.state(step), tb.state(step)) else { continue };
        // Centre distance minus both bounding radii is a lower bound on the
        // box distance: skip the exact query when it cannot win.
        let lower = (sa.position - sb.position).norm() - reach;
        if best.is_some_and(|b| lower >= b.distance_m) {
            continue;
        }
        let d = ta.footprint(step)?.distance(&tb.footprint(step)?);
        if best.is_none_or(|b| d < b.distance_m) {
            best = Some(ClosestApproach { distance_m: d, step });
        }
    }
    best
}

/// The first recorded contact of the ego with another agent from the
/// current step on, as (agent, step): in the shared data an annotation
/// error (the recorded boxes of two agents overlap), and a scene where the
/// recorded ego cannot drive without contact is no test for a planner.
pub fn recorded_ego_contact(scenario: &Scenario) -> Option<(TrackIndex, usize)> {
    (scenario.current_step..scenario.num_steps())
        .find_map(|step| recorded_ego_contact_at(scenario, step).map(|other| (other, step)))
}

/// The first agent whose recorded box overlaps the recorded ego's at
/// `step`, if any.
pub fn recorded_ego_contact_at(scenario: &Scenario, step: usize) -> Option<TrackIndex> {
    let ego = scenario.ego?;
    let own = scenario.track(ego).footprint(step)?;
    (0..scenario.tracks.len())
        .filter(|&i| i != ego.0)
        .find(|&i| scenario.tracks[i].footprint(step).is_some_and(|b| b.intersects(&own)))
        .map(TrackIndex)
}

/// Vehicles valid at the current step that move and have enough future.
fn candidates(scenario: &Scenario) -> Vec<TrackIndex> {
    let now = scenario.current_step;
    (0..scenario.tracks.len())
        .map(TrackIndex)
        .filter(|&i| {
            let t = scenario.track(i);
            t.kind == AgentKind::Vehicle
                && t.state(now).is_some()
                && t.states[now..].iter().flatten().count() > MIN_FUTURE_STEPS
                && t.states[now..].iter().flatten().any(|s| s.speed_mps() >= MOVING_SPEED_MPS)
        })
        .collect()
}

/// Ranking of a candidate pair: a score (lower first: the closest
/// approach, or the gap between arrivals at a merge point), then a step
/// (earlier first), then lower indices.
type PairKey = (f64, usize, TrackIndex, TrackIndex);

fn better(x: &PairKey, y: &PairKey) -> bool {
    x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)).then(x.3.cmp(&y.3)).is_lt()
}

/// The closest approach of a pair as a score, `None` where their recorded
/// boxes overlap (an annotation error; see the module's notes).
fn approach_score(scenario: &Scenario, a: TrackIndex, b: TrackIndex) -> Option<(f64, usize)> {
    closest_approach(scenario, a, b).filter(|c| c.distance_m > 0.0).map(|c| (c.distance_m, c.step))
}

/// The CBV for a given ego: the moving vehicle with the closest approach.
pub fn mine_cbv(scenario: &Scenario, ego: TrackIndex) -> Option<TrackIndex> {
    best_to(scenario, ego, |c| approach_score(scenario, ego, c))
}

/// Of the moving vehicles other than `ego` that `score` ranks, the best
/// ranked (lowest score, then step, then index). Every score leaves out
/// recorded overlaps ([`approach_score`]).
fn best_to(
    scenario: &Scenario,
    ego: TrackIndex,
    score: impl Fn(TrackIndex) -> Option<(f64, usize)>,
) -> Option<TrackIndex> {
    let mut best: Option<(PairKey, TrackIndex)> = None;
    for c in candidates(scenario) {
        if c == ego {
            continue;
        }
        let Some((value, step)) = score(c) else { continue };
        let k = (value, step, ego, c);
        if best.as_ref().is_none_or(|(bk, _)| better(&k, bk)) {
            best = Some((k, c));
        }
    }
    best.map(|(_, c)| c)
}

/// The (ego, CBV) pair with the closest approach among moving vehicles.
/// Of the two, the ego is the one with more valid future steps (more to
/// test), ties to the lower index.
pub fn mine_pair(scenario: &Scenario) -> Option<(TrackIndex, TrackIndex)> {
    best_pair(scenario, |a, b| approach_score(scenario, a, b))
}

/// Of the pairs of moving vehicles that `score` ranks, the best ranked
/// (as in [`best_to`]), as (ego, CBV): the ego is the one with more valid
/// future steps, ties to the lower index.
fn best_pair(
    scenario: &Scenario,
    score: impl Fn(TrackIndex, TrackIndex) -> Option<(f64, usize)>,
) -> Option<(TrackIndex, TrackIndex)> {
    let cands = candidates(scenario);
    let mut best: Option<(PairKey, (TrackIndex, TrackIndex))> = None;
    for (i, &a) in cands.iter().enumerate() {
        for &b in &cands[i + 1..] {
            let Some((value, step)) = score(a, b) else { continue };
            let k = (value, step, a, b);
            if best.as_ref().is_none_or(|(bk, _)| better(&k, bk)) {
                best = Some((k, (a, b)));
            }
        }
    }
    let (_, (a, b)) = best?;
    let future = |t: TrackIndex| scenario.track(t).states[scenario.current_step..].iter().flatten().count();
    Some(if future(b) > future(a) { (b, a) } else { (a, b) })
}

/// Which ego–CBV pair a scene is tested with.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum RolePairing {
    /// As the scene was loaded: the source's roles, else the labelled pair,
    /// else the closest approach ([`assign`]).
    #[default]
    AsLoaded,
    /// A CBV in a lane merging with the ego's ([`assign_merging`]); scenes
    /// without one are left out.
    Merging,
    /// The CBV is the ego's leader ([`assign_leader`]); scenes without one
    /// are left out.
    Leader,
    /// A CBV whose recorded path crosses the ego's at a junction
    /// ([`assign_crossing`]); scenes without one are left out.
    Crossing,
}

impl RolePairing {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::AsLoaded, Self::Merging, Self::Leader, Self::Crossing];

    /// Gives `scenario` the pair this pairing asks for; `false` (the
    /// scenario left as it was) when it has none.
    pub fn assign(self, scenario: &mut Scenario) -> bool {
        match self {
            Self::AsLoaded => scenario.ego.is_some() && scenario.cbv.is_some(),
            Self::Merging => assign_merging(scenario),
            Self::Leader => assign_leader(scenario),
            Self::Crossing => assign_crossing(scenario),
        }
    }

    /// The pair a scene needs for this pairing, in words ("a leader for
    /// the ego"), for the messages that say a scene lacks it.
    pub fn pair_in_words(self) -> &'static str {
        match self {
            Self::AsLoaded => "an ego and a CBV",
            Self::Merging => "a pair of vehicles in merging lanes",
            Self::Leader => "a leader for the ego",
            Self::Crossing => "a vehicle whose path crosses the ego's",
        }
    }

    /// The pair in a word or two ("a leader"), for counts of the scenes
    /// that have one.
    pub fn pair_in_brief(self) -> &'static str {
        match self {
            Self::AsLoaded => "an ego and a CBV",
            Self::Merging => "a merging pair",
            Self::Leader => "a leader",
            Self::Crossing => "a crossing pair",
        }
    }

    /// Who the CBV is under this pairing, in words (none for the scene's
    /// own pair), for a report's heading.
    pub fn cbv_in_words(self) -> Option<&'static str> {
        match self {
            Self::AsLoaded => None,
            Self::Merging => Some("ego and CBV in merging lanes"),
            Self::Leader => Some("the CBV is the ego's leader"),
            Self::Crossing => Some("the CBV's path crosses the ego's"),
        }
    }
}

/// How far ahead of the ego's front a leader may be, m (1.4 s of headway
/// at 43 m/s, beyond any freeway's).
pub const LEADER_MAX_GAP_M: f64 = 60.0;

/// How far a leader's box may reach out of the ego's corridor (the ego's
/// width along its path) and still be in its path, m: the margin of the
/// planners' own leader rule.
pub const LEADER_CORRIDOR_MARGIN_M: f64 = 0.4;

/// Most heading difference between a leader and the ego's path, rad (the
/// conflict classifier's bound for the same direction, 45°).
pub const LEADER_MAX_HEADING_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// The ego's leader now: of the moving vehicles with enough future to
/// drive (as conflict mining takes them) whose box at the current step
/// lies in the ego's corridor along its recorded path ahead (its recorded
/// positions from now on, then straight on along its last heading for
/// 10 m more than [`LEADER_MAX_GAP_M`]), heading its way, the one with the
/// least gap to the ego's front, within [`LEADER_MAX_GAP_M`]. A recorded
/// overlap with the ego rules a vehicle out (an annotation error, as in
/// mining).
pub fn mine_leader_cbv(scenario: &Scenario, ego: TrackIndex) -> Option<TrackIndex> {
    let now = scenario.current_step;
    let ego_track = scenario.track(ego);
    ego_track.state(now)?;
    // The path starts where the ego is now (arc length 0).
    let mut points: Vec<Point2> = Vec::new();
    let mut last = None;
    for s in ego_track.states[now..].iter().flatten() {
        if points.last().is_none_or(|p: &Point2| (s.position - p).norm() > 0.1) {
            points.push(s.position);
        }
        last = Some(s);
    }
    let last = last?;
    let beyond = Vector2::new(last.heading_rad.cos(), last.heading_rad.sin()) * (LEADER_MAX_GAP_M + 10.0);
    points.push(last.position + beyond);
    let path = Polyline::new(points);
    let gap_to = |c: TrackIndex| -> Option<(f64, usize)> {
        let track = scenario.track(c);
        let state = track.state(now)?;
        let p = path.project(&state.position)?;
        let heading = wrap_angle(state.heading_rad - p.tangent.y.atan2(p.tangent.x));
        if heading.abs() > LEADER_MAX_HEADING_RAD {
            return None;
        }
        let (sin, cos) = (heading.sin().abs(), heading.cos().abs());
        let half_across = 0.5 * (sin * track.length_m + cos * track.width_m);
        if p.distance_m > 0.5 * ego_track.width_m + half_across + LEADER_CORRIDOR_MARGIN_M {
            return None;
        }
        let half_along = 0.5 * (cos * track.length_m + sin * track.width_m);
        let gap_m = p.arc_length_m - 0.5 * ego_track.length_m - half_along;
        let ahead = p.arc_length_m > 0.0 && (0.0..=LEADER_MAX_GAP_M).contains(&gap_m);
        (ahead && approach_score(scenario, ego, c).is_some()).then_some((gap_m, 0))
    };
    best_to(scenario, ego, gap_to)
}

/// Makes the scenario's CBV the ego's leader ([`mine_leader_cbv`]), for
/// testing a planner's braking: the ego keeps its place (as the source
/// named it, or as conflict mining chose it). Returns whether the scene
/// has one; when it has none the scenario is left as it was.
pub fn assign_leader(scenario: &mut Scenario) -> bool {
    let Some(ego) = scenario.ego else { return false };
    let Some(cbv) = mine_leader_cbv(scenario, ego) else { return false };
    scenario.cbv = Some(cbv);
    scenario.cbv_origin = RoleOrigin::LeaderMining;
    true
}

/// How far ahead of both vehicles their lanes are followed to find where
/// they merge, m (about 8 s at 15 m/s).
pub const MERGE_LOOKAHEAD_M: f64 = 120.0;

/// Most heading difference of a merging pair at the current step, rad
/// (the conflict classifier's bound between the same direction and a
/// crossing).
pub const MERGE_MAX_HEADING_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// A merging or crossing pair must both be at least this far from the
/// point where their ways meet in time, s: a pair nearer has all but
/// merged or crossed, and a CBV needs time to act.
pub const PAIR_ARRIVAL_MIN_S: f64 = 1.0;

/// When each of a pair reaches the point where their ways meet, s from
/// the current step: the start of the lane their lanes merge into, at
/// its current speed (at least 1 m/s, the speed that counts as moving;
/// [`merge_arrivals`]), or where their recorded paths cross
/// ([`path_crossing`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairArrivals {
    /// When the first vehicle asked about (`a`) arrives.
    pub first_s: f64,
    /// When the second (`b`) arrives.
    pub second_s: f64,
}

impl PairArrivals {
    /// How far apart the two arrivals are, s: the gap a CBV must close
    /// (or open) to meet the ego there. Where recorded paths cross, the
    /// post-encroachment time centre to centre (the traffic engineer's
    /// measure of how near a crossing came to a collision takes it from
    /// the first's rear leaving to the second's front arriving).
    pub fn gap_s(&self) -> f64 {
        (self.first_s - self.second_s).abs()
    }
}

/// Whether `a` and `b` are in lanes that merge ahead of both at the
/// current step, and if so when each reaches the merge point: heading the
/// same way (within [`MERGE_MAX_HEADING_RAD`]), not one lane (nor one
/// continuing the other), neither's lane ahead of the other, and their
/// lanes ahead meet in a lane that two lanes lead into (an on-ramp's end,
/// a lane drop, two ways through a junction) within [`MERGE_LOOKAHEAD_M`]
/// of both; the map's lane relations ([`LaneRelations`]). The merge point
/// is the start of the first such lane, along the lanes from where each
/// vehicle is.
pub fn merge_arrivals(
    scenario: &Scenario,
    relations: &LaneRelations<'_>,
    a: TrackIndex,
    b: TrackIndex,
) -> Option<PairArrivals> {
    let now = scenario.current_step;
    let (sa, sb) = (scenario.track(a).state(now)?, scenario.track(b).state(now)?);
    // Two ways into one exit from opposite or crossing approaches make a
    // turn conflict, not a merge.
    if wrap_angle(sa.heading_rad - sb.heading_rad).abs() >= MERGE_MAX_HEADING_RAD {
        return None;
    }
    let lanes = |s: &AgentState| scenario.map.lanes_containing(&s.position, s.heading_rad);
    let (la, lb) = (lanes(sa), lanes(sb));
    if la.is_empty() || lb.is_empty() || relations.any_connected(&la, &lb) {
        return None;
    }
    let (ahead_a, ahead_b) =
        (lanes_ahead_of(scenario, relations, &la, sa), lanes_ahead_of(scenario, relations, &lb, sb));
    if ahead_a.iter().any(|(l, _)| lb.contains(&l.id)) || ahead_b.iter().any(|(l, _)| la.contains(&l.id)) {
        return None;
    }
    // Of the merge lanes ahead of both, the first the two reach.
    let (dist_a_m, dist_b_m) = ahead_a
        .iter()
        .filter(|(l, _)| l.through_junction)
        .filter_map(|&(l, da)| {
            let db =
                ahead_b.iter().filter(|(m, _)| m.id == l.id && m.through_junction).map(|&(_, d)| d).reduce(f64::min)?;
            Some((da, db))
        })
        .min_by(|x, y| (x.0 + x.1).total_cmp(&(y.0 + y.1)))?;
    let time_s = |d: f64, s: &AgentState| d / s.speed_mps().max(MOVING_SPEED_MPS);
    Some(PairArrivals { first_s: time_s(dist_a_m, sa), second_s: time_s(dist_b_m, sb) })
}

/// The lanes ahead of a vehicle at `state` in `lanes`, each with how far
/// its start is from the vehicle along the way, m (the nearest way where
/// a lane is reached from more than one of `lanes`), as far as
/// [`MERGE_LOOKAHEAD_M`] from the vehicle.
fn lanes_ahead_of(
    scenario: &Scenario,
    relations: &LaneRelations<'_>,
    lanes: &[MapElementId],
    state: &AgentState,
) -> Vec<(LaneAhead, f64)> {
    let mut ahead: Vec<(LaneAhead, f64)> = Vec::new();
    for &id in lanes {
        let along_m =
            scenario.map.lane(id).and_then(|l| l.centreline.project(&state.position)).map_or(0.0, |p| p.arc_length_m);
        for l in relations.lanes_ahead(&[id], along_m + MERGE_LOOKAHEAD_M) {
            let d = (l.start_m - along_m).max(0.0);
            match ahead.iter_mut().find(|(m, _)| m.id == l.id) {
                Some(seen) => {
                    if d < seen.1 {
                        *seen = (l, d);
                    }
                }
                None => ahead.push((l, d)),
            }
        }
    }
    ahead
}

/// The ranking of a merging pair: the gap between their arrivals at the
/// merge point, if both arrive there between [`PAIR_ARRIVAL_MIN_S`] and
/// the end of the recording; `None` for a pair not in merging lanes,
/// arriving outside that window, or whose recorded boxes overlap (as in
/// [`approach_score`]).
fn merge_gap_s(scenario: &Scenario, relations: &LaneRelations<'_>, a: TrackIndex, b: TrackIndex) -> Option<f64> {
    let arrivals = merge_arrivals(scenario, relations, a, b)?;
    let future_s = scenario.num_steps().saturating_sub(scenario.current_step + 1) as f64 * scenario.dt_s;
    let within = |t: f64| (PAIR_ARRIVAL_MIN_S..=future_s).contains(&t);
    let meets = within(arrivals.first_s) && within(arrivals.second_s);
    (meets && approach_score(scenario, a, b).is_some()).then(|| arrivals.gap_s())
}

/// The CBV for `ego` among the vehicles in lanes merging with the ego's
/// ([`merge_arrivals`]): of those that reach the merge point between
/// [`PAIR_ARRIVAL_MIN_S`] and the end of the recording, as the ego does,
/// the moving one that arrives nearest in time to the ego (a CBV that
/// can meet it there), whose recorded box never overlaps the ego's.
pub fn mine_merging_cbv(scenario: &Scenario, ego: TrackIndex) -> Option<TrackIndex> {
    let relations = LaneRelations::of(&scenario.map);
    best_to(scenario, ego, |c| merge_gap_s(scenario, &relations, ego, c).map(|gap| (gap, 0)))
}

/// The (ego, CBV) pair in merging lanes whose arrivals at the merge point
/// are nearest in time, as in [`mine_merging_cbv`]; the ego is the one
/// with more valid future steps, as in [`mine_pair`].
pub fn mine_merging_pair(scenario: &Scenario) -> Option<(TrackIndex, TrackIndex)> {
    let relations = LaneRelations::of(&scenario.map);
    best_pair(scenario, |a, b| merge_gap_s(scenario, &relations, a, b).map(|gap| (gap, 0)))
}

/// Makes the scenario's CBV a vehicle merging with the ego, for testing a
/// planner against merges: an ego the source named (or its labelled pair's)
/// keeps its place and gets the merging CBV [`mine_merging_cbv`] finds; a
/// mined ego is mined again with its CBV as a merging pair
/// ([`mine_merging_pair`]). Returns whether the scene has one; when it has
/// none the scenario is left as it was.
pub fn assign_merging(scenario: &mut Scenario) -> bool {
    assign_mined(scenario, mine_merging_cbv, mine_merging_pair, RoleOrigin::MergeMining)
}

/// Gives `scenario` the pair a pairing mines: an ego the source named (or
/// its labelled pair's) keeps its place and gets the CBV `mine_cbv` finds
/// for it; a mined ego is mined again with its CBV by `mine_pair`. Both
/// roles it sets are recorded as `origin`. Returns whether it found one;
/// when not, the scenario is left as it was.
fn assign_mined(
    scenario: &mut Scenario,
    mine_cbv: fn(&Scenario, TrackIndex) -> Option<TrackIndex>,
    mine_pair: fn(&Scenario) -> Option<(TrackIndex, TrackIndex)>,
    origin: RoleOrigin,
) -> bool {
    let named_ego =
        scenario.ego.filter(|_| matches!(scenario.ego_origin, RoleOrigin::Source | RoleOrigin::LabelledPair));
    let (ego, cbv) = match named_ego {
        Some(ego) => match mine_cbv(scenario, ego) {
            Some(cbv) => (ego, cbv),
            None => return false,
        },
        None => match mine_pair(scenario) {
            Some(pair) => pair,
            None => return false,
        },
    };
    if scenario.ego != Some(ego) {
        scenario.ego = Some(ego);
        scenario.ego_origin = origin;
    }
    scenario.cbv = Some(cbv);
    scenario.cbv_origin = origin;
    true
}

/// Least angle between two recorded paths where they cross for the pair
/// to be a crossing pair, rad: where a merging pair's headings end
/// ([`MERGE_MAX_HEADING_RAD`], the conflict classifier's bound between
/// the same direction and a crossing, 45°). A turn across the other's
/// way, a crossing at a junction, not two cars in one lane.
pub const CROSSING_MIN_ANGLE_RAD: f64 = MERGE_MAX_HEADING_RAD;

/// Where two recorded paths cross ([`path_crossing`]) and when each
/// vehicle passes there (centre over the point).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathCrossing {
    /// The crossing point of the two centres' paths.
    pub point: Point2,
    /// When the first vehicle asked about (`a`) and the second (`b`) pass
    /// it; their [`gap_s`](PairArrivals::gap_s) is the post-encroachment
    /// time, centre to centre.
    pub arrivals: PairArrivals,
}

/// A recorded path from the current step on: each valid state's time
/// after the current step, s, and its centre.
fn recorded_path(scenario: &Scenario, track: TrackIndex) -> Vec<(f64, Point2)> {
    let now = scenario.current_step;
    let states = &scenario.track(track).states;
    states
        .iter()
        .enumerate()
        .skip(now)
        .filter_map(|(step, s)| s.map(|s| ((step - now) as f64 * scenario.dt_s, s.position)))
        .collect()
}

/// The least and greatest corner of the box holding `path`.
fn path_bounds(path: &[(f64, Point2)]) -> (Point2, Point2) {
    path.iter().fold(
        (Point2::new(f64::INFINITY, f64::INFINITY), Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY)),
        |(lo, hi), (_, p)| (Point2::new(lo.x.min(p.x), lo.y.min(p.y)), Point2::new(hi.x.max(p.x), hi.y.max(p.y))),
    )
}

/// Where the recorded paths of `a` and `b` (their centres, from the
/// current step on, between consecutive recorded steps) cross at
/// [`CROSSING_MIN_ANGLE_RAD`] or more, both passing the point
/// [`PAIR_ARRIVAL_MIN_S`] or more after the current step: of the
/// crossings, the one with the least post-encroachment time (ties to the
/// earlier along `a`'s path). `None` where they do not so cross.
pub fn path_crossing(scenario: &Scenario, a: TrackIndex, b: TrackIndex) -> Option<PathCrossing> {
    let (pa, pb) = (recorded_path(scenario, a), recorded_path(scenario, b));
    let ((lo_a, hi_a), (lo_b, hi_b)) = (path_bounds(&pa), path_bounds(&pb));
    if lo_a.x > hi_b.x || lo_b.x > hi_a.x || lo_a.y > hi_b.y || lo_b.y > hi_a.y {
        return None;
    }
    let consecutive = |w: &[(f64, Point2)]| (w[1].0 - w[0].0) <= 1.5 * scenario.dt_s;
    let mut best: Option<PathCrossing> = None;
    for wa in pa.windows(2).filter(|w| consecutive(w)) {
        let ((ta0, a0), (ta1, a1)) = (wa[0], wa[1]);
        let da = a1 - a0;
        if da.norm() < 1e-6 {
            continue;
        }
        for wb in pb.windows(2).filter(|w| consecutive(w)) {
            let ((tb0, b0), (tb1, b1)) = (wb[0], wb[1]);
            let db = b1 - b0;
            let cross = da.x * db.y - da.y * db.x;
            // Parallel (or standing) segments do not cross at an angle.
            if cross.abs() < 1e-9 * da.norm() * db.norm().max(1e-9) {
                continue;
            }
            let w = b0 - a0;
            let (u, v) = ((w.x * db.y - w.y * db.x) / cross, (w.x * da.y - w.y * da.x) / cross);
            if !(0.0..=1.0).contains(&u) || !(0.0..=1.0).contains(&v) {
                continue;
            }
            let angle = wrap_angle(db.y.atan2(db.x) - da.y.atan2(da.x)).abs();
            if angle < CROSSING_MIN_ANGLE_RAD {
                continue;
            }
            let arrivals = PairArrivals { first_s: ta0 + u * (ta1 - ta0), second_s: tb0 + v * (tb1 - tb0) };
            if arrivals.first_s < PAIR_ARRIVAL_MIN_S || arrivals.second_s < PAIR_ARRIVAL_MIN_S {
                continue;
            }
            let found = PathCrossing { point: a0 + da * u, arrivals };
            if best.is_none_or(|b| found.arrivals.gap_s() < b.arrivals.gap_s()) {
                best = Some(found);
            }
        }
    }
    best
}

/// The ranking of a crossing pair: its post-encroachment time
/// ([`path_crossing`]); `None` for a pair whose paths do not so cross or
/// whose recorded boxes overlap (as in [`approach_score`]).
fn crossing_pet_s(scenario: &Scenario, a: TrackIndex, b: TrackIndex) -> Option<f64> {
    let crossing = path_crossing(scenario, a, b)?;
    approach_score(scenario, a, b).is_some().then(|| crossing.arrivals.gap_s())
}

/// The CBV for `ego` among the vehicles whose recorded paths cross the
/// ego's ([`path_crossing`]): the moving one with the least
/// post-encroachment time, a car that passed the crossing point nearest
/// in time to the ego (a CBV that can meet it there), whose recorded box
/// never overlaps the ego's.
pub fn mine_crossing_cbv(scenario: &Scenario, ego: TrackIndex) -> Option<TrackIndex> {
    best_to(scenario, ego, |c| crossing_pet_s(scenario, ego, c).map(|pet| (pet, 0)))
}

/// The (ego, CBV) pair of crossing paths with the least post-encroachment
/// time, as in [`mine_crossing_cbv`]; the ego is the one with more valid
/// future steps, as in [`mine_pair`].
pub fn mine_crossing_pair(scenario: &Scenario) -> Option<(TrackIndex, TrackIndex)> {
    best_pair(scenario, |a, b| crossing_pet_s(scenario, a, b).map(|pet| (pet, 0)))
}

/// Makes the scenario's CBV a vehicle whose path crosses the ego's, for
/// testing a planner at junctions (a car crossing its way, or turning
/// across it): an ego the source named (or its labelled pair's) keeps its
/// place and gets the crossing CBV [`mine_crossing_cbv`] finds; a mined
/// ego is mined again with its CBV as a crossing pair
/// ([`mine_crossing_pair`]). Returns whether the scene has one; when it
/// has none the scenario is left as it was.
pub fn assign_crossing(scenario: &mut Scenario) -> bool {
    assign_mined(scenario, mine_crossing_cbv, mine_crossing_pair, RoleOrigin::CrossingMining)
}

/// The labelled pair as (ego, CBV): two objects of interest, both moving
/// vehicles with enough future, neither of them the ego already named.
fn labelled_pair(scenario: &Scenario) -> Option<(TrackIndex, TrackIndex)> {
    let [a, b] = scenario.objects_of_interest[..] else { return None };
    if a == b || scenario.ego.is_some_and(|e| e == a || e == b) {
        return None;
    }
    let cands = candidates(scenario);
    // Same rules as mining: moving vehicles with a future, whose recorded
    // boxes never overlap (an overlap is an annotation error).
    if !(cands.contains(&a) && cands.contains(&b)) || closest_approach(scenario, a, b)?.distance_m <= 0.0 {
        return None;
    }
    let (a, b) = if a < b { (a, b) } else { (b, a) };
    let future = |t: TrackIndex| scenario.track(t).states[scenario.current_step..].iter().flatten().count();
    Some(if future(b) > future(a) { (b, a) } else { (a, b) })
}

/// Why conflict mining found nothing, for the scenario's notes.
fn no_candidates_note(scenario: &Scenario, role: &str) -> String {
    let future = scenario.num_steps().saturating_sub(scenario.current_step + 1);
    format!(
        "no {role} assigned: conflict mining needs vehicles valid at the current step that move (≥ {MOVING_SPEED_MPS} m/s) \
         with more than {MIN_FUTURE_STEPS} future steps; this scene has {future} steps after the current one and {} such vehicles",
        candidates(scenario).len()
    )
}

/// Fills in ego and CBV where the source named none, recording how (or,
/// in the notes, why not).
pub fn assign(scenario: &mut Scenario) {
    if scenario.cbv.is_none()
        && let Some((ego, cbv)) = labelled_pair(scenario)
    {
        if let Some(sdc) = scenario.ego {
            let id = &scenario.track(sdc).id.0;
            scenario.source.notes.push(format!(
                "ego and CBV are the labelled interacting pair (objects_of_interest); the SDC ({id}) is background"
            ));
        }
        scenario.ego = Some(ego);
        scenario.ego_origin = RoleOrigin::LabelledPair;
        scenario.cbv = Some(cbv);
        scenario.cbv_origin = RoleOrigin::LabelledPair;
        return;
    }
    match scenario.ego {
        None => match mine_pair(scenario) {
            Some((ego, cbv)) => {
                scenario.ego = Some(ego);
                scenario.ego_origin = RoleOrigin::ConflictMining;
                scenario.cbv = Some(cbv);
                scenario.cbv_origin = RoleOrigin::ConflictMining;
            }
            None => scenario.source.notes.push(no_candidates_note(scenario, "ego and CBV")),
        },
        Some(ego) if scenario.cbv.is_none() => match mine_cbv(scenario, ego) {
            Some(cbv) => {
                scenario.cbv = Some(cbv);
                scenario.cbv_origin = RoleOrigin::ConflictMining;
            }
            None => scenario.source.notes.push(no_candidates_note(scenario, "CBV")),
        },
        Some(_) => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::map::RoadMap;
    use crate::scenario::{AgentId, AgentState, ScenarioSource, Track};

    /// A straight-line track from (x0, y0) with velocity (vx, vy), 40 steps.
    fn track(id: &str, x0: f64, y0: f64, vx: f64, vy: f64) -> Track {
        track_of(id, x0, y0, vx, vy, 40)
    }

    /// [`track`] over `steps` steps.
    fn track_of(id: &str, x0: f64, y0: f64, vx: f64, vy: f64, steps: usize) -> Track {
        let states = (0..steps)
            .map(|k| {
                let t = k as f64 * 0.1;
                Some(AgentState {
                    position: Point2::new(x0 + vx * t, y0 + vy * t),
                    heading_rad: vy.atan2(vx),
                    velocity_mps: Vector2::new(vx, vy),
                })
            })
            .collect();
        Track { id: AgentId(id.into()), kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0, states }
    }

    fn scenario(tracks: Vec<Track>) -> Scenario {
        Scenario::new("t", ScenarioSource::authored("t"), 0.1, RoadMap::default(), tracks)
    }

    #[test]
    fn a_merging_pair_is_the_ramp_car_that_meets_the_main_lanes_car_at_the_merge_point() {
        use crate::map::templates::{MapTemplate, Merge};
        let merge: Merge = serde_json::from_value(serde_json::json!({
            "lanes": 2, "length_m": 400, "merge_end_m": 200, "acceleration_lane_m": 70
        }))
        .unwrap();
        // The acceleration lane runs at y = -1.75 from x = 130 to 200 and
        // leads into lane 0's successor, which starts at x = 200; lane 1
        // is beside lane 0. 9.9 s of recording.
        let along = |id: &str, x0: f64, y0: f64, vx: f64| track_of(id, x0, y0, vx, 0.0, 100);
        let mut slow = along("ramp-slow", 132.0, -1.75, 2.0);
        slow.width_m = 2.4;
        let tracks = vec![
            // Reaches the merge point at 9.0 s.
            along("main", 110.0, 1.75, 10.0),
            // 12 s: after the recording ends.
            along("follower", 80.0, 1.75, 10.0),
            // About 8.6 s, with the main lane's car: the merge to test.
            along("ramp-late", 131.0, -1.75, 8.0),
            // The main lane's car passes it 1.3 m away (the closest
            // approach), 34 s before it would reach the merge point.
            slow,
            // About 4 s: long gone by the time the main lane's car arrives.
            along("ramp-early", 160.0, -1.75, 10.0),
            along("beside", 100.0, 5.25, 10.0),
        ];
        let mut s = Scenario::new("t", ScenarioSource::authored("t"), 0.1, MapTemplate::Merge(merge).build(), tracks);
        let relations = LaneRelations::of(&s.map);
        let arrivals = merge_arrivals(&s, &relations, TrackIndex(0), TrackIndex(2)).expect("main and ramp-late merge");
        assert!((arrivals.first_s - 9.0).abs() < 0.05, "{arrivals:?}");
        assert!((8.5..9.0).contains(&arrivals.second_s), "{arrivals:?}");
        // The car beside, in a lane that only goes on, merges with nobody;
        // nor does the follower with the car ahead in its own lane.
        assert!(merge_arrivals(&s, &relations, TrackIndex(0), TrackIndex(5)).is_none());
        assert!(merge_arrivals(&s, &relations, TrackIndex(0), TrackIndex(1)).is_none());
        assign(&mut s);
        let name = |s: &Scenario, t: Option<TrackIndex>| t.map(|t| s.track(t).id.0.clone());
        // Closest approach picks the slow ramp car.
        assert_eq!(mine_cbv(&s, TrackIndex(0)), Some(TrackIndex(3)));
        let pair = mine_merging_pair(&s).map(|(a, b)| [s.track(a).id.0.clone(), s.track(b).id.0.clone()]);
        assert!(
            pair.as_ref().is_some_and(|p| p.contains(&"main".into()) && p.contains(&"ramp-late".into())),
            "{pair:?}"
        );
        let mut merging = s.clone();
        assert!(assign_merging(&mut merging));
        assert_eq!(merging.cbv_origin, RoleOrigin::MergeMining);
        // With the ego named by the source, it keeps its place.
        let mut named_ego = s.clone();
        named_ego.ego = Some(TrackIndex(0));
        named_ego.ego_origin = RoleOrigin::Source;
        assert!(assign_merging(&mut named_ego));
        assert_eq!(name(&named_ego, named_ego.cbv).as_deref(), Some("ramp-late"));
        assert_eq!(named_ego.ego, Some(TrackIndex(0)));
        // The follower arrives after the recording ends: no merge to test.
        assert_eq!(mine_merging_cbv(&s, TrackIndex(1)), None);
        assert_eq!(mine_merging_cbv(&s, TrackIndex(5)), None);
        // A map without lanes has no merges: the scenario is left as it was.
        let mut open = scenario(s.tracks.clone());
        assign(&mut open);
        let before = (open.ego, open.cbv);
        assert!(!assign_merging(&mut open));
        assert_eq!((open.ego, open.cbv), before);
    }

    #[test]
    fn closest_moving_pair_is_mined_and_logged_overlaps_are_not() {
        // 0 drives +x; 2 overtakes it 2.8 m to its right (0.8 m box gap throughout); 1 is 20 m away;
        // 3 is parked 3 m beside 0; 4 drives head-on into 0 (boxes overlap in the log).
        let mut parked = track("3", 0.0, 3.0, 0.0, 0.0);
        parked.states.iter_mut().flatten().for_each(|s| s.velocity_mps = Vector2::zeros());
        let mut s = scenario(vec![
            track("0", 0.0, 0.0, 10.0, 0.0),
            track("1", 0.0, 20.0, 10.0, 0.0),
            track("2", -3.0, -2.8, 11.0, 0.0),
            parked,
            track("4", 60.0, 0.5, -10.0, 0.0),
        ]);
        let pair = mine_pair(&s).map(|(a, b)| if a < b { (a, b) } else { (b, a) });
        assert_eq!(pair, Some((TrackIndex(0), TrackIndex(2))));
        assign(&mut s);
        assert!(s.ego.is_some() && s.cbv.is_some());
        assert_eq!(s.ego_origin, RoleOrigin::ConflictMining);
        // Deterministic: the same answer on a second run.
        let mut again = s.clone();
        again.ego = None;
        assign(&mut again);
        assert_eq!((again.ego, again.cbv), (s.ego, s.cbv));
    }

    #[test]
    fn source_ego_is_kept_and_cbv_mined_for_it() {
        let mut s = scenario(vec![
            track("0", 0.0, 0.0, 10.0, 0.0),
            track("1", 0.0, 30.0, 10.0, 0.0),
            track("2", 0.0, 6.0, 10.0, 0.0),
        ]);
        s.ego = Some(TrackIndex(1));
        s.ego_origin = RoleOrigin::Source;
        assign(&mut s);
        assert_eq!(s.ego, Some(TrackIndex(1)));
        // Track 2 (y = 6) is 24 m from the ego (y = 30); track 0 is 30 m away.
        assert_eq!(s.cbv, Some(TrackIndex(2)));
        assert_eq!(s.cbv_origin, RoleOrigin::ConflictMining);
    }

    #[test]
    fn a_labelled_pair_without_the_sdc_becomes_ego_and_cbv() {
        // The SDC (0) is far from the labelled pair (1, 2); 2 has the longer future.
        let mut short = track("1", 100.0, 0.0, 10.0, 0.0);
        short.states[35..].iter_mut().for_each(|s| *s = None);
        let mut s = scenario(vec![track("0", 0.0, 50.0, 10.0, 0.0), short, track("2", 90.0, 4.0, 12.0, 0.0)]);
        s.ego = Some(TrackIndex(0));
        s.ego_origin = RoleOrigin::Source;
        s.objects_of_interest = vec![TrackIndex(1), TrackIndex(2)];
        assign(&mut s);
        assert_eq!((s.ego, s.cbv), (Some(TrackIndex(2)), Some(TrackIndex(1))));
        assert_eq!((s.ego_origin, s.cbv_origin), (RoleOrigin::LabelledPair, RoleOrigin::LabelledPair));
        assert!(s.source.notes.iter().any(|n| n.contains("SDC (0) is background")), "{:?}", s.source.notes);
    }

    #[test]
    fn a_labelled_pair_with_a_pedestrian_falls_back_to_mining_for_the_sdc() {
        let mut walker = track("1", 0.0, 6.0, 1.5, 0.0);
        walker.kind = AgentKind::Pedestrian;
        let mut s = scenario(vec![track("0", 0.0, 0.0, 10.0, 0.0), walker, track("2", 0.0, 5.0, 10.0, 0.0)]);
        s.ego = Some(TrackIndex(0));
        s.ego_origin = RoleOrigin::Source;
        s.objects_of_interest = vec![TrackIndex(1), TrackIndex(2)];
        assign(&mut s);
        assert_eq!((s.ego, s.cbv), (Some(TrackIndex(0)), Some(TrackIndex(2))));
        assert_eq!(s.cbv_origin, RoleOrigin::ConflictMining);
    }

    #[test]
    fn a_recorded_ego_overlapping_another_agent_is_found_with_the_step() {
        // 1 drives head-on towards the ego (0): boxes meet when the centres are 4.5 m apart.
        let mut s = scenario(vec![track("0", 0.0, 0.0, 5.0, 0.0), track("1", 30.0, 0.5, -5.0, 0.0)]);
        s.ego = Some(TrackIndex(0));
        let (other, step) = recorded_ego_contact(&s).expect("they overlap");
        assert_eq!(other, TrackIndex(1));
        // Centre gap 30 - 10 t ≤ 4.5 first at t = 2.6 s.
        assert_eq!(step, 26);
        let mut apart = scenario(vec![track("0", 0.0, 0.0, 5.0, 0.0), track("1", 30.0, 3.0, -5.0, 0.0)]);
        apart.ego = Some(TrackIndex(0));
        assert_eq!(recorded_ego_contact(&apart), None);
    }

    #[test]
    fn the_leader_is_the_nearest_car_ahead_in_the_egos_path_not_a_nearer_one_beside_or_behind() {
        let mut s = scenario(vec![
            track("ego", 0.0, 0.0, 10.0, 0.0),
            // Beside, 3.5 m over: the closest approach, but not in the path.
            track("beside", 3.0, 3.5, 10.0, 0.0),
            // Behind in the ego's lane.
            track("behind", -9.0, 0.0, 10.0, 0.0),
            // Ahead in the lane, 15.5 m from the ego's front: the leader.
            track("leader", 20.0, 0.3, 10.0, 0.0),
            // Farther ahead in the lane.
            track("second", 45.0, 0.0, 10.0, 0.0),
            // Ahead and coming the other way.
            track("oncoming", 12.0, 0.0, -10.0, 0.0),
        ]);
        s.ego = Some(TrackIndex(0));
        s.ego_origin = RoleOrigin::Source;
        assign(&mut s);
        assert_eq!(s.cbv, Some(TrackIndex(1)), "the closest approach is the car beside");
        assert!(RolePairing::Leader.assign(&mut s));
        assert_eq!((s.ego, s.cbv), (Some(TrackIndex(0)), Some(TrackIndex(3))));
        assert_eq!(s.cbv_origin, RoleOrigin::LeaderMining);
        assert_eq!(s.ego_origin, RoleOrigin::Source);
    }

    /// The ego east along y = 0 at 10 m/s; cars going north across its
    /// way, one in its lane ahead.
    fn crossing_scene() -> Scenario {
        scenario(vec![
            track("ego", 0.0, 0.0, 10.0, 0.0),
            // Passes (20, 0) at 3.0 s, the ego at 2.0 s: 1 s apart.
            track("crossing", 20.0, -30.0, 0.0, 10.0),
            // Passes (30, 0) at 1.0 s, the ego at 3.0 s: 2 s apart.
            track("early", 30.0, -10.0, 0.0, 10.0),
            // Passes (5, 0) at 2.5 s, but the ego passes it within 1 s.
            track("too-soon", 5.0, -25.0, 0.0, 10.0),
            // Ahead in the ego's lane: the same way, no crossing.
            track("leader", 20.0, 0.0, 10.0, 0.0),
        ])
    }

    #[test]
    fn a_crossing_pair_is_the_car_across_the_egos_way_with_the_least_post_encroachment_time() {
        let mut s = crossing_scene();
        let crossing = path_crossing(&s, TrackIndex(0), TrackIndex(1)).expect("the paths cross");
        assert!((crossing.point - Point2::new(20.0, 0.0)).norm() < 1e-9, "{crossing:?}");
        let arrivals = crossing.arrivals;
        assert!((arrivals.first_s - 2.0).abs() < 1e-9 && (arrivals.second_s - 3.0).abs() < 1e-9, "{crossing:?}");
        assert!((arrivals.gap_s() - 1.0).abs() < 1e-9);
        let early = path_crossing(&s, TrackIndex(0), TrackIndex(2)).expect("the paths cross");
        assert!((early.arrivals.gap_s() - 2.0).abs() < 1e-9, "{early:?}");
        assert_eq!(path_crossing(&s, TrackIndex(0), TrackIndex(3)), None, "the ego is there within 1 s");
        assert_eq!(path_crossing(&s, TrackIndex(0), TrackIndex(4)), None, "one lane: no angle");
        s.ego = Some(TrackIndex(0));
        s.ego_origin = RoleOrigin::Source;
        assert!(RolePairing::Crossing.assign(&mut s));
        assert_eq!((s.ego, s.cbv), (Some(TrackIndex(0)), Some(TrackIndex(1))));
        assert_eq!((s.ego_origin, s.cbv_origin), (RoleOrigin::Source, RoleOrigin::CrossingMining));
        // With no ego named the pair is mined: the same two.
        let mut mined = crossing_scene();
        assert!(RolePairing::Crossing.assign(&mut mined));
        assert_eq!((mined.ego, mined.cbv), (Some(TrackIndex(0)), Some(TrackIndex(1))));
        assert_eq!((mined.ego_origin, mined.cbv_origin), (RoleOrigin::CrossingMining, RoleOrigin::CrossingMining));
    }

    #[test]
    fn paths_that_touch_in_the_recording_or_never_cross_make_no_crossing_pair() {
        // The two pass (20, 0) together: a recorded overlap, not a pair.
        let mut s = scenario(vec![track("ego", 0.0, 0.0, 10.0, 0.0), track("hit", 20.0, -20.0, 0.0, 10.0)]);
        assert!(path_crossing(&s, TrackIndex(0), TrackIndex(1)).is_some());
        s.ego = Some(TrackIndex(0));
        s.ego_origin = RoleOrigin::Source;
        s.cbv = Some(TrackIndex(1));
        assert!(!RolePairing::Crossing.assign(&mut s));
        assert_eq!((s.cbv, s.cbv_origin), (Some(TrackIndex(1)), RoleOrigin::Unassigned), "left as it was");
        // Two lanes the same way and one the other way: nothing crosses.
        let mut apart = scenario(vec![
            track("ego", 0.0, 0.0, 10.0, 0.0),
            track("beside", 0.0, 3.5, 10.0, 0.0),
            track("oncoming", 40.0, -3.5, -10.0, 0.0),
        ]);
        assert!(!RolePairing::Crossing.assign(&mut apart));
        assert_eq!((apart.ego, apart.cbv), (None, None));
    }

    #[test]
    fn the_leader_is_found_along_the_recorded_path_and_none_is_left_as_it_was() {
        // The ego turns onto y (a quarter circle of 20 m radius over 3.1 s,
        // then straight): the car in its path after the turn is its leader,
        // the one straight on from where it starts is not.
        let steps = 60;
        let radius_m = 20.0;
        let speed_mps = 10.0;
        let states = (0..steps)
            .map(|k| {
                let t = k as f64 * 0.1;
                let turn_s = std::f64::consts::FRAC_PI_2 * radius_m / speed_mps;
                let (position, heading_rad) = if t <= turn_s {
                    let a = t * speed_mps / radius_m;
                    (Point2::new(radius_m * a.sin(), radius_m * (1.0 - a.cos())), a)
                } else {
                    (Point2::new(radius_m, radius_m + (t - turn_s) * speed_mps), std::f64::consts::FRAC_PI_2)
                };
                Some(AgentState {
                    position,
                    heading_rad,
                    velocity_mps: Vector2::new(heading_rad.cos(), heading_rad.sin()) * speed_mps,
                })
            })
            .collect();
        let ego = Track { id: AgentId("ego".into()), kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0, states };
        let mut s = scenario(vec![
            ego,
            track("straight-on", 25.0, 0.0, 10.0, 0.0),
            track("after-the-turn", radius_m, radius_m + 10.0, 0.0, 10.0),
        ]);
        s.ego = Some(TrackIndex(0));
        assert_eq!(mine_leader_cbv(&s, TrackIndex(0)), Some(TrackIndex(2)));
        // Without it, nothing is ahead in the path: the scene is left out
        // and left as it was.
        s.tracks.truncate(2);
        s.cbv = Some(TrackIndex(1));
        s.cbv_origin = RoleOrigin::ConflictMining;
        assert!(!assign_leader(&mut s));
        assert_eq!((s.cbv, s.cbv_origin), (Some(TrackIndex(1)), RoleOrigin::ConflictMining));
        // Nor is a leader beyond the gap bound one.
        let far = track("far", 0.0, 0.0, 10.0, 0.0);
        let mut s = scenario(vec![far, track("ahead", LEADER_MAX_GAP_M + 10.0, 0.0, 10.0, 0.0)]);
        s.ego = Some(TrackIndex(0));
        assert_eq!(mine_leader_cbv(&s, TrackIndex(0)), None);
    }
}
