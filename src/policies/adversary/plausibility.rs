//! The plausibility check ([`PlausibilityCheck`]): whether a candidate
//! token keeps the CBV a plausible road user (the rule in the module's
//! documentation): it turns no harder than a car's tyres hold, it stays
//! on the road with room to stop on it, it
//! touches no background agent while it holds the token, it does not slow
//! in front of replayed traffic closing on it, and it runs into no one
//! while it brakes after the token (and, under [`WrongWayRule::Forbidden`],
//! it does not turn against a lane's traffic, then or while it brakes, or,
//! against it already, heads back to a lane of its way; under
//! [`WrongWayRule::HumanLaneChanges`], it moves sideways across its lanes
//! no faster than recorded drivers change lanes);
//! with the fallback rule counting only the CBV's own faults
//! ([`ContactRule`]).

use super::background_forecast::BackgroundForecast;
use super::broad_phase::Bounds;
use super::lane_change_pace::LaneChangePaceHold;
use super::rollout::{BRAKING_CHECK_STEPS, braking_after, continued_after, token_rollout_turning};
use super::turning_limit::{CbvTurningLimit, first_beyond};
use super::wrong_way::{AcrossLanesHold, TrafficDirectionHold, WrongWayRule};
use crate::geometry::OrientedBox;
use crate::motion::KinematicState;
use crate::motion::tokens::{MAX_ACCEL_MPS2, SIM_DT_S, TOKEN_PERIOD_STEPS, Token, TurnedHeadings, VOCABULARY_SIZE};
use crate::policies::WorldView;
use crate::policies::prior_sampling::ranked_tokens;
use crate::scenario::contact::{EgoCollisionKind, EgoContact};
use crate::scenario::{AgentState, TrackIndex};

/// Background agents farther than this from the CBV cannot be reached
/// within the plausibility check's horizon (3.5 s at a closing speed of
/// up to about 34 m/s) and are not checked, m.
const BACKGROUND_CHECK_RANGE_M: f64 = 120.0;

/// The road check of the braking path goes on past
/// [`BRAKING_CHECK_STEPS`] until the CBV stands, for at most this many
/// steps more (8 s in all: enough to stop from 40 m/s at the hardest
/// braking). Only the road is checked that far: the background forecast
/// is not.
const STANDSTILL_CHECK_MAX_STEPS: usize = 60;

/// A token held this many steps (1 s) more must not bring the CBV and a
/// background agent (predicted at constant velocity) into contact: no
/// brake checks on followers, no stopping in the way of crossing traffic.
const HOLDING_CHECK_STEPS: usize = 10;

/// After the held token the CBV keeps its speed (and curvature) this many
/// steps (2 s) more, and a replayed agent that would run into it within
/// them makes the token implausible: a replayed car cannot yield (agents
/// the prior or a rule drives can, and are not checked here), and a
/// driver does not slow down or stop in front of traffic closing on it
/// faster than it could get out of the way (seen on WOMD interactive: a
/// CBV slowing in a lane where a car came up at 25 m/s, a CBV stopped in
/// the path of crossing traffic 2 s away; 1 s of holding saw both only
/// when no token could avoid them any more). Contacts the CBV would be at
/// fault for are not counted here: running into someone at constant speed
/// seconds ahead is what the braking check is for.
const CLOSING_CHECK_STEPS: usize = 20;

/// The CBV's path while it holds the token: `rollout` (the token's states),
/// then [`HOLDING_CHECK_STEPS`] steps holding the token's acceleration and
/// curvature, then [`CLOSING_CHECK_STEPS`] more at the speed reached,
/// still holding the curvature.
fn held_path(rollout: &[AgentState]) -> Vec<AgentState> {
    let mut held: Vec<AgentState> = holding(rollout).collect();
    held.extend(continued_after(&held, 0.0, CLOSING_CHECK_STEPS));
    held
}

/// The first step at which one of `own` (the CBV's boxes, one a step,
/// made as they are asked for) touches the agent predicted at `predicted`
/// at the same step. Every box of one agent (and of the CBV) has the same
/// size, so one reach serves all of an agent's pairs.
fn first_contact(
    predicted: &[Option<(AgentState, OrientedBox)>],
    own: impl IntoIterator<Item = OrientedBox>,
) -> Option<usize> {
    let mut own = own.into_iter().peekable();
    let reach_m = predicted.iter().flatten().next()?.1.reach_to(own.peek()?);
    predicted.iter().zip(own).position(|(theirs, own)| theirs.is_some_and(|(_, b)| b.intersects_within(&own, reach_m)))
}

/// The states of [`held_path`] while the token is held: `rollout`, then
/// [`HOLDING_CHECK_STEPS`] steps holding its acceleration and curvature.
fn holding(rollout: &[AgentState]) -> impl Iterator<Item = AgentState> + '_ {
    let accel_mps2 = match rollout {
        [.., before, end] => (end.speed_mps() - before.speed_mps()) / SIM_DT_S,
        _ => 0.0,
    };
    let held = continued_after(rollout, accel_mps2.clamp(-MAX_ACCEL_MPS2, MAX_ACCEL_MPS2), HOLDING_CHECK_STEPS);
    rollout.iter().copied().chain(held)
}

/// Which contacts with background traffic break the plausibility rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum ContactRule {
    /// Any contact while the CBV holds its token (being run into included:
    /// no brake checks, no stopping in the way), and running into someone
    /// while it brakes after the token: the rule.
    Any,
    /// Only contacts the CBV is at fault for, as the metrics judge them,
    /// and cut-ins ([`PlausibilityCheck::cut_in`]): the fallback when a
    /// replayed agent will run into the CBV whatever it does.
    AtFaultOnly,
}

/// Which violation of the plausibility rule a check looks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Violation {
    /// The first step at which the rule is broken.
    First,
    /// Any step at which it is: whether it is broken at all.
    Any,
}

/// The check of whether a candidate rollout of the CBV (one state per
/// simulator step of the token) is implausible for a road user (the
/// module's rule: leaving the road, touching background traffic during the
/// token, or no room to brake short of it). The background's predicted
/// states and boxes are built once per decision.
pub(super) struct PlausibilityCheck<'w> {
    world: &'w WorldView<'w>,
    cbv_body: crate::scenario::AgentBody,
    /// The CBV now (`None`: absent, nothing is implausible).
    cbv_now: Option<AgentState>,
    /// Each nearby background agent's predicted state and box, one per
    /// step of the check (`None`: absent at that step).
    background: Vec<Vec<Option<(AgentState, OrientedBox)>>>,
    /// Whether each of those agents is replayed from its recording.
    replayed: Vec<bool>,
    /// The bounds of each of those agents' predicted boxes over all the
    /// steps: a CBV path whose boxes lie outside them touches none of
    /// that agent's, and its box tests are skipped.
    background_bounds: Vec<Bounds>,
    /// The background agent that last made a token break the rule (an
    /// index into `background`): checked first for the next token.
    last_blocker: std::cell::Cell<Option<usize>>,
    /// The CBV's signed distance to the road edge now, m (positive: off
    /// the road; `None` where the map has no road edges near it).
    edge_distance_now: Option<f64>,
    on_road_now: bool,
    /// The lanes holding the CBV's centre now, driven its way (empty off
    /// the lanes or on a map without them): what it cuts in from.
    lanes_now: Vec<crate::map::MapElementId>,
    /// What the wrong-way rule holds the CBV to: kept out of lanes
    /// against their traffic, or heading back out of one
    /// ([`WrongWayRule::Forbidden`]).
    traffic_direction: TrafficDirectionHold,
    /// What the rule against driving across the lanes holds the CBV to:
    /// kept along them, or turning back towards them
    /// ([`WrongWayRule::AlongTheLanes`]).
    across_lanes: AcrossLanesHold,
    /// What the lane-change pace rule holds the CBV to: kept to a human
    /// sideways pace, or slowing to it
    /// ([`WrongWayRule::HumanLaneChanges`]).
    lane_change_pace: LaneChangePaceHold,
    /// How hard the CBV may turn (the tyres' grip unless a lower limit is set).
    turning: CbvTurningLimit,
    /// What [`Self::implausible`] said of each token the fallbacks scanned
    /// (held from the CBV's state now), by rule. Where nothing is
    /// plausible the ego-contact rule's fallback and the plain one after it
    /// both judge the whole vocabulary under one rule; the second asks
    /// here. Emptied whenever the check's rules change.
    scanned: std::cell::RefCell<ScannedVerdicts>,
}

/// [`PlausibilityCheck::implausible`] of the tokens a check's fallbacks
/// scanned, by token id: one table a [`ContactRule`], made at its first use.
#[derive(Debug, Default)]
struct ScannedVerdicts {
    any: Vec<Option<bool>>,
    at_fault_only: Vec<Option<bool>>,
}

impl ScannedVerdicts {
    fn slot(&mut self, token: Token, rule: ContactRule) -> &mut Option<bool> {
        let table = match rule {
            ContactRule::Any => &mut self.any,
            ContactRule::AtFaultOnly => &mut self.at_fault_only,
        };
        let id = token.0 as usize;
        if table.len() <= id {
            table.resize(VOCABULARY_SIZE.max(id + 1), None);
        }
        &mut table[id]
    }
}

impl<'w> PlausibilityCheck<'w> {
    pub(super) fn new(
        world: &'w WorldView<'w>,
        cbv: TrackIndex,
        ego: TrackIndex,
        forecast: &BackgroundForecast<'_>,
    ) -> Self {
        let cbv_body = world.body(cbv);
        let cbv_now = world.state(cbv).copied();
        let Some(now) = cbv_now else {
            return Self {
                world,
                cbv_body,
                cbv_now,
                background: Vec::new(),
                replayed: Vec::new(),
                background_bounds: Vec::new(),
                last_blocker: Default::default(),
                edge_distance_now: None,
                on_road_now: false,
                lanes_now: Vec::new(),
                traffic_direction: TrafficDirectionHold::NotHeld,
                across_lanes: AcrossLanesHold::NotHeld,
                lane_change_pace: LaneChangePaceHold::NotHeld,
                turning: CbvTurningLimit::GRIP.for_kind(cbv_body.kind),
                scanned: Default::default(),
            };
        };
        let horizon = TOKEN_PERIOD_STEPS + BRAKING_CHECK_STEPS.max(HOLDING_CHECK_STEPS + CLOSING_CHECK_STEPS);
        let in_range = |s: &AgentState| (s.position - now.position).norm() < BACKGROUND_CHECK_RANGE_M;
        let (background, replayed): (Vec<Vec<_>>, Vec<bool>) = (0..world.states.len())
            .filter(|&i| i != cbv.0 && i != ego.0)
            .filter_map(|i| {
                let (states, replayed) = forecast.states(world, TrackIndex(i), horizon);
                states.iter().flatten().next().is_some_and(in_range).then_some((i, states, replayed))
            })
            .map(|(i, states, replayed)| {
                let b = world.bodies[i];
                (states.into_iter().map(|s| s.map(|at| (at, b.footprint(&at)))).collect(), replayed)
            })
            .unzip();
        let background_bounds =
            background.iter().map(|predicted| Bounds::of(predicted.iter().flatten().map(|(_, b)| b))).collect();
        Self {
            world,
            cbv_body,
            cbv_now,
            background,
            replayed,
            background_bounds,
            last_blocker: Default::default(),
            edge_distance_now: world.map.signed_distance_to_road_edge(&now.position),
            on_road_now: !world.map.is_off_road_within_map(&now.position),
            lanes_now: world.map.lanes_containing(&now.position, now.heading_rad),
            traffic_direction: TrafficDirectionHold::NotHeld,
            across_lanes: AcrossLanesHold::NotHeld,
            lane_change_pace: LaneChangePaceHold::NotHeld,
            turning: CbvTurningLimit::GRIP.for_kind(cbv_body.kind),
            scanned: Default::default(),
        }
    }

    /// The check with the CBV held to turning within `limit` (the default:
    /// the tyres' grip).
    pub(super) fn with_turning_limit(self, limit: CbvTurningLimit) -> Self {
        Self { turning: limit.for_kind(self.cbv_body.kind), scanned: Default::default(), ..self }
    }

    /// The check with `rule` on driving against a lane's traffic (the
    /// default allows it).
    pub(super) fn with_wrong_way(self, rule: WrongWayRule) -> Self {
        let map = self.world.map;
        let Some(now) = self.cbv_now else { return self };
        let traffic_direction = TrafficDirectionHold::of(rule, map, &now);
        let across_lanes = AcrossLanesHold::of(rule, map, &now);
        let lane_change_pace = LaneChangePaceHold::of(rule, map, &now);
        Self { traffic_direction, across_lanes, lane_change_pace, scanned: Default::default(), ..self }
    }

    /// Whether the lane-change pace rule holds the CBV for this token.
    pub(super) fn paces_lane_changes(&self) -> bool {
        self.lane_change_pace != LaneChangePaceHold::NotHeld
    }

    /// This check without the lane-change pace rule: what the choice
    /// judges by once that rule leaves no token plausible.
    pub(super) fn without_lane_change_pace(self) -> Self {
        Self { lane_change_pace: LaneChangePaceHold::NotHeld, scanned: Default::default(), ..self }
    }

    /// Whether the CBV, hit by `theirs` at `at`, cut in: it was hit from
    /// behind (or standing) in a lane that neither holds nor continues
    /// any of its lanes now. nuPlan does not blame a car hit from behind,
    /// but a driver moving into a lane must leave the traffic in it room:
    /// in the fallbacks, where only the CBV's own faults count, a cut-in
    /// in front of a replayed car (which cannot yield) counts as one.
    /// Undecided (false) where the CBV is in no lane now or then.
    fn cut_in(&self, at: &AgentState, theirs: &AgentState) -> bool {
        let hit_from_behind = matches!(
            EgoCollisionKind::classify(at, theirs),
            EgoCollisionKind::ActiveRear | EgoCollisionKind::StoppedEgo
        );
        if !hit_from_behind || self.lanes_now.is_empty() {
            return false;
        }
        let map = self.world.map;
        let lanes_then = map.lanes_containing(&at.position, at.heading_rad);
        !lanes_then.is_empty()
            && !lanes_then.iter().any(|&then| self.lanes_now.iter().any(|&now| map.lanes_connected(now, then)))
    }

    /// Whether `rollout` breaks the rule: the checks stop at the first
    /// violation found (the plausibility fallback ranks the whole
    /// vocabulary, where most tokens break it).
    pub(super) fn implausible(&self, rollout: &[AgentState], rule: ContactRule) -> bool {
        self.violation(rollout, Violation::Any, rule).is_some()
    }

    /// The first step (counted from the token's first state) at which
    /// `rollout` breaks the rule, or `None` for a plausible token.
    pub(super) fn first_violation(&self, rollout: &[AgentState], rule: ContactRule) -> Option<usize> {
        self.violation(rollout, Violation::First, rule)
    }

    /// A step at which `rollout` breaks the rule: the first one, or (for
    /// [`Violation::Any`]) the first one the checks come to.
    fn violation(&self, rollout: &[AgentState], wanted: Violation, rule: ContactRule) -> Option<usize> {
        // The token's own states first: beyond the tyres' grip or tighter
        // than a car steers (see the `grip` module), which no car drives
        // whatever the rules, and
        // sideways faster than a recorded lane change or not slowing to it
        // (see the `lane_change_pace` module). A product a step and a few
        // lane queries, which in a turn or a lane change reject most of the
        // tokens the plausibility fallback ranks before their contacts and
        // their paths to a standstill are worked out.
        let beyond_grip = || self.first_beyond_turning_limit(rollout);
        let brisk = || self.lane_change_pace.first_breach(self.world.map, rollout);
        let rules = || self.rule_violation(rollout, wanted, rule);
        match wanted {
            Violation::Any => beyond_grip().or_else(brisk).or_else(rules),
            Violation::First => beyond_grip().into_iter().chain(brisk()).chain(rules()).min(),
        }
    }

    /// [`Self::violation`] of the rules of the road and of the traffic
    /// (all but those on the token's own grip and sideways pace).
    fn rule_violation(&self, rollout: &[AgentState], wanted: Violation, rule: ContactRule) -> Option<usize> {
        let end = rollout.last()?;
        // Whether at all, under the strict rule: a contact while holding
        // the token breaks it whatever else the token does, and the agent
        // that blocked the last token is asked first (see
        // `touches_last_blocker_while_holding`).
        if wanted == Violation::Any
            && rule == ContactRule::Any
            && let Some(k) = self.touches_last_blocker_while_holding(rollout)
        {
            return Some(k);
        }
        let map = self.world.map;
        // Across the lanes on the token's own states, or not turning back
        // towards them (see the `wrong_way` module). Whether at all, it is
        // asked first: a few lane queries on the token's own states, which
        // under the rule reject many of the tokens a scan ranks before
        // their braking paths and contacts are worked out.
        let across = || self.across_lanes.first_breach(map, rollout);
        if wanted == Violation::Any
            && let Some(k) = across()
        {
            return Some(k);
        }
        let braking: Vec<AgentState> = rollout.iter().copied().chain(braking_after(rollout)).collect();
        let contact = |wanted| self.contact_violation(rollout, &braking, wanted, rule);
        // The path to a standstill, rolled out once for the road and
        // wrong-way checks, and only if one of them is come to.
        let moving = std::cell::OnceCell::new();
        let moving_path = || moving.get_or_init(|| Self::moving_path(&braking)).as_slice();
        // Into a lane against its traffic (under the wrong-way rule),
        // judged along the road check's path: a token that leaves the CBV
        // heading into the oncoming lanes faster than braking can stop it
        // is as good as in them (see the `wrong_way` module).
        let wrong_way = || {
            let against = self.traffic_direction.first_breach(map, rollout, moving_path);
            match wanted {
                Violation::First => against.into_iter().chain(across()).min(),
                // Across the lanes was asked first.
                Violation::Any => against,
            }
        };
        if !self.on_road_now {
            // Off the road already: head back to it, not farther away.
            let farther_off = || match (self.edge_distance_now, map.signed_distance_to_road_edge(&end.position)) {
                (Some(now), Some(then)) if then > now => Some(rollout.len() - 1),
                _ => None,
            };
            return match wanted {
                Violation::First => farther_off().into_iter().chain(wrong_way()).chain(contact(wanted)).min(),
                // Whether at all (the answer is the same in any order):
                // the contacts first, as below.
                Violation::Any => contact(wanted).or_else(farther_off).or_else(wrong_way),
            };
        }
        let off_road = |s: &AgentState| map.is_off_road_within_map(&s.position);
        match wanted {
            Violation::First => {
                moving_path().iter().position(off_road).into_iter().chain(wrong_way()).chain(contact(wanted)).min()
            }
            // Whether at all, in the order that finds a violation soonest
            // (the answer is the same in any order). The contacts first:
            // box tests behind a bounds test, which reject most of the
            // tokens the plausibility fallback ranks, each before its
            // path to a standstill is rolled out and a nearest-edge query
            // is made. Then the road: the farthest state first (a path
            // that leaves the road ends off it), then the rest of the path
            // from the far end.
            Violation::Any => contact(wanted)
                .or_else(|| {
                    let path = moving_path();
                    let (last, rest) = path.split_last()?;
                    if off_road(last) { Some(path.len() - 1) } else { rest.iter().rposition(off_road) }
                })
                .or_else(wrong_way),
        }
    }

    /// The first step at which the CBV, holding `rollout`'s token (over
    /// [`holding`]), touches the background agent that blocked the last
    /// token, if it does. Under [`ContactRule::Any`] such a contact breaks
    /// the rule whatever else the token does. Where nothing is plausible a
    /// fallback scan judges the whole vocabulary, and most of its tokens
    /// run into the same agent within a few steps: they are answered here
    /// from the states and boxes up to the contact, before the braking and
    /// held paths are rolled out in full.
    fn touches_last_blocker_while_holding(&self, rollout: &[AgentState]) -> Option<usize> {
        let predicted = self.background.get(self.last_blocker.get()?)?;
        first_contact(predicted, holding(rollout).map(|at| self.cbv_body.footprint(&at)))
    }

    /// The road check's path: `braking` (the token's states and the
    /// braking after them) on to a standstill, moving states only (a
    /// stopped CBV stays where it stopped). On to a standstill: 2 s of
    /// braking from motorway speed still leaves a bend to run out of (seen
    /// on WOMD interactive: a CBV at 21 m/s judged able to stop on the road
    /// that, a token later, had no token left that stayed on it).
    fn moving_path(braking: &[AgentState]) -> Vec<AgentState> {
        let to_standstill = continued_after(braking, -MAX_ACCEL_MPS2, STANDSTILL_CHECK_MAX_STEPS);
        braking.iter().copied().chain(to_standstill).take_while(|s| s.speed_mps() > 0.0).collect()
    }

    /// A step at which the CBV following `rollout` (and holding it, or
    /// braking after it along `braking`) meets background traffic in a way
    /// `rule` forbids.
    fn contact_violation(
        &self,
        rollout: &[AgentState],
        braking: &[AgentState],
        wanted: Violation,
        rule: ContactRule,
    ) -> Option<usize> {
        let map = self.world.map;
        let mut first: Option<usize> = None;
        let note = |first: &mut Option<usize>, k: usize| *first = Some(first.map_or(k, |f| f.min(k)));
        // Each background agent's first contact is judged, as the metrics
        // judge a collision by its onset (a follower at constant velocity
        // would otherwise drive through the stopped CBV and seem to be hit
        // from the front). Holding the token, any contact counts: stopping
        // in the way of traffic is the CBV's doing too.
        // Both paths start with the token's own states: their boxes are built once.
        let body = |s: &AgentState| self.cbv_body.footprint(s);
        let token_boxes: Vec<OrientedBox> = rollout.iter().map(body).collect();
        let held = held_path(rollout);
        let held_boxes: Vec<OrientedBox> =
            token_boxes.iter().copied().chain(held[rollout.len()..].iter().map(body)).collect();
        let braking_boxes: Vec<OrientedBox> =
            token_boxes.into_iter().chain(braking[rollout.len()..].iter().map(body)).collect();
        let own_bounds = Bounds::of(held_boxes.iter().chain(&braking_boxes));
        // Whether a token breaks the rule at all does not depend on the
        // order the agents are checked in: the agent that broke it for the
        // last token checked is asked first (the tokens of one decision
        // are most often blocked by the same car).
        let blocker = self.last_blocker.get().filter(|&i| i < self.background.len());
        let order = blocker.into_iter().chain((0..self.background.len()).filter(|&i| Some(i) != blocker));
        // A check for any violation is answered by the first one found.
        let answered = |first: Option<usize>| wanted == Violation::Any && first.is_some();
        for i in order {
            if answered(first) {
                break;
            }
            let (predicted, replayed) = (&self.background[i], self.replayed[i]);
            if !self.background_bounds[i].overlaps(&own_bounds) {
                continue;
            }
            let before = first;
            if let Some(k) = first_contact(predicted, held_boxes.iter().copied())
                && let Some((theirs, _)) = predicted[k]
            {
                let at_fault = || EgoContact::ego_at_fault(map, &held[k], &held_boxes[k], &theirs);
                let breaks_rule = match rule {
                    ContactRule::Any if k < rollout.len() + HOLDING_CHECK_STEPS => true,
                    // Keeping its speed: only replayed traffic closing on
                    // the CBV (the others react).
                    ContactRule::Any => replayed && !at_fault(),
                    ContactRule::AtFaultOnly if k < rollout.len() + HOLDING_CHECK_STEPS => {
                        at_fault() || self.cut_in(&held[k], &theirs)
                    }
                    ContactRule::AtFaultOnly => replayed && self.cut_in(&held[k], &theirs),
                };
                if breaks_rule {
                    note(&mut first, k);
                }
            }
            // Braking after the token: only what the CBV runs into (not
            // asked once the held path has answered).
            if !answered(first)
                && let Some(k) = first_contact(predicted, braking_boxes.iter().copied())
                && let Some((theirs, _)) = predicted[k]
                && EgoContact::ego_at_fault(map, &braking[k], &braking_boxes[k], &theirs)
            {
                note(&mut first, k);
            }
            if first != before {
                self.last_blocker.set(Some(i));
            }
        }
        first
    }

    /// The likeliest plausible token of the prior's ranking of `logits`
    /// (most likely first) that `region` does not hold, if any: the
    /// plausibility fallback, once every token of the trust region has
    /// failed. For a top-n region these are the ranks from n on; for a
    /// distinct-behaviour region, also the near-duplicates it skipped.
    pub(super) fn likeliest_plausible_outside(
        &self,
        logits: &[f32],
        region: &[Token],
        rule: ContactRule,
    ) -> Option<Token> {
        self.likeliest_plausible_outside_where(logits, region, rule, |_| true)
    }

    /// [`likeliest_plausible_outside`](Self::likeliest_plausible_outside)
    /// among the tokens whose rollout (the CBV's states over the token)
    /// `keep` accepts.
    pub(super) fn likeliest_plausible_outside_where(
        &self,
        logits: &[f32],
        region: &[Token],
        rule: ContactRule,
        keep: impl Fn(&[AgentState]) -> bool,
    ) -> Option<Token> {
        // Judged before `keep`, which cannot change which token is found:
        // a scan that finds none leaves every token's verdict for the next.
        self.likeliest_outside_where(logits, region, |token, rollout| {
            !self.implausible_scanned(token, rollout, rule) && keep(rollout)
        })
    }

    /// [`Self::implausible`] of `rollout`, `token` held from the CBV's state
    /// now, answered from [`Self::scanned`] where an earlier scan judged it.
    fn implausible_scanned(&self, token: Token, rollout: &[AgentState], rule: ContactRule) -> bool {
        if let Some(verdict) = *self.scanned.borrow_mut().slot(token, rule) {
            return verdict;
        }
        let verdict = self.implausible(rollout, rule);
        *self.scanned.borrow_mut().slot(token, rule) = Some(verdict);
        verdict
    }

    /// Whether `rollout` (a token's states from the CBV's state now) keeps
    /// the CBV within the tyres' grip, or the lower turning limit set, and
    /// within a car's turning circle (see the `grip` module); `true`
    /// without a CBV.
    pub(super) fn within_turning_limit(&self, rollout: &[AgentState]) -> bool {
        self.first_beyond_turning_limit(rollout).is_none()
    }

    /// The first state of `rollout` a step turning harder than the limit
    /// reaches (`None` within it, or without a CBV).
    fn first_beyond_turning_limit(&self, rollout: &[AgentState]) -> Option<usize> {
        self.cbv_now.as_ref().and_then(|now| first_beyond(now, rollout, self.turning))
    }

    /// The likeliest token of the prior's ranking of `logits` that
    /// `region` does not hold and that keeps the CBV within grip and its
    /// turning circle: the last resort's, where nothing is plausible, for a
    /// car can break a rule but not its tyres' or its steering's limit.
    /// Straight on is always within both, so there is one whenever the CBV
    /// is present.
    pub(super) fn likeliest_within_turning_limit_outside(&self, logits: &[f32], region: &[Token]) -> Option<Token> {
        self.likeliest_outside_where(logits, region, |_, rollout| self.within_turning_limit(rollout))
    }

    /// The likeliest token of the prior's ranking of `logits` that
    /// `region` does not hold and that `keep` accepts with its rollout
    /// (from the CBV's state now); `None` without a CBV.
    fn likeliest_outside_where(
        &self,
        logits: &[f32],
        region: &[Token],
        keep: impl Fn(Token, &[AgentState]) -> bool,
    ) -> Option<Token> {
        let now = self.cbv_now.as_ref()?;
        let from = KinematicState::from_agent_state(now);
        let mut turned = TurnedHeadings::default();
        let mut in_region = vec![false; logits.len()];
        for t in region {
            if let Some(slot) = in_region.get_mut(t.0 as usize) {
                *slot = true;
            }
        }
        ranked_tokens(logits)
            .into_iter()
            .filter(|t| !in_region[t.0 as usize])
            .find(|&t| keep(t, &token_rollout_turning(&from, t, &mut turned)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::map::RoadMap;
    use crate::motion::Action;
    use crate::motion::tokens::TokenGrid;
    use crate::policies::adversary::rollout::token_rollouts;
    use crate::policies::adversary::test_support::{car, dead_end_road, token};
    use crate::policies::adversary::wrong_way::drives_wrong_way;
    use crate::scenario::{AgentBody, AgentKind};

    /// A recording in which every agent of `states` keeps its velocity for 4 s.
    fn recorded_at_constant_velocity(states: &[Option<AgentState>]) -> crate::scenario::Scenario {
        use crate::scenario::{AgentId, ScenarioSource, Track};
        let tracks = states
            .iter()
            .enumerate()
            .map(|(i, s)| Track {
                id: AgentId(format!("agent-{i}")),
                kind: AgentKind::Vehicle,
                length_m: 4.5,
                width_m: 2.0,
                states: (0..40)
                    .map(|k| {
                        s.map(|s| AgentState { position: s.position + s.velocity_mps * (k as f64 * SIM_DT_S), ..s })
                    })
                    .collect(),
            })
            .collect();
        crate::scenario::Scenario::new(
            "constant-velocity",
            ScenarioSource::authored("test"),
            SIM_DT_S,
            RoadMap::default(),
            tracks,
        )
        .with_roles(TrackIndex(0), Some(TrackIndex(1)))
    }

    /// A straight road of 3.5 m lanes, `lanes` one way (ids 0..) and
    /// `oncoming_lanes` the other (ids 100..).
    fn two_way_road(lanes: usize, oncoming_lanes: usize) -> crate::map::RoadMap {
        crate::map::templates::StraightRoad {
            lanes,
            oncoming_lanes,
            lane_width_m: 3.5,
            length_m: 300.0,
            speed_limit_mps: None,
        }
        .build()
    }

    /// The y of lane `id`'s centreline on a straight road.
    fn lane_y(map: &crate::map::RoadMap, id: i64) -> f64 {
        map.lane(crate::map::MapElementId(id)).unwrap().centreline.points()[0].y
    }

    /// Whether each of two tokens that only yaw, at `yaw_rates_radps`, is
    /// implausible under `rule` for a CBV at x = 100 m on lane centre
    /// `y_m`, heading `heading_rad` at `speed_mps`, the ego standing at
    /// x = 20 m in the same lane.
    fn turning_tokens_judged(
        map: &RoadMap,
        y_m: f64,
        heading_rad: f64,
        speed_mps: f64,
        yaw_rates_radps: [f64; 2],
        rule: WrongWayRule,
    ) -> Vec<bool> {
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let v = Vector2::new(heading_rad.cos(), heading_rad.sin()) * speed_mps;
        let cbv = AgentState { position: Point2::new(100.0, y_m), heading_rad, velocity_mps: v };
        let states = [car(20.0, y_m, 0.0), Some(cbv)];
        let world = WorldView { map, step: 0, bodies: &bodies, states: &states };
        let check = PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &BackgroundForecast::default())
            .with_wrong_way(rule);
        let tokens =
            yaw_rates_radps.map(|yaw_rate_radps| TokenGrid::quantize(Action { accel_mps2: 0.0, yaw_rate_radps }));
        token_rollouts(&cbv, &tokens).iter().map(|r| check.implausible(r, ContactRule::Any)).collect()
    }

    fn implausible_tokens(world: &WorldView<'_>, cbv: TrackIndex, tokens: &[Token]) -> Vec<bool> {
        let check = PlausibilityCheck::new(world, cbv, TrackIndex(0), &BackgroundForecast::default());
        token_rollouts(world.states[cbv.0].as_ref().unwrap(), tokens)
            .iter()
            .map(|r| check.implausible(r, ContactRule::Any))
            .collect()
    }

    /// The bodies and states of a crowd: the ego (0) far off, the CBV (1)
    /// at 12 m/s among cars ahead, beside and behind it.
    fn crowd() -> ([AgentBody; 6], [Option<AgentState>; 6]) {
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 6];
        let states = [
            car(0.0, 100.0, 10.0),
            car(0.0, 0.0, 12.0),
            car(16.0, 0.0, 4.0),
            car(6.0, 3.6, 12.0),
            car(-10.0, -3.6, 18.0),
            car(22.0, -3.6, 0.0),
        ];
        (bodies, states)
    }

    #[test]
    fn one_check_judges_every_token_as_a_fresh_check_does_whoever_blocked_the_last() {
        // The CBV in the crowd: one check asked about the whole vocabulary
        // in turn (it asks the agent that blocked the last token first)
        // answers what a new check answers for each token alone, with the
        // blocker changing.
        let map = RoadMap::default();
        let (bodies, states) = crowd();
        let world = WorldView { map: &map, step: 10, bodies: &bodies, states: &states };
        let (ego, cbv) = (TrackIndex(0), TrackIndex(1));
        let tokens: Vec<Token> = (0..crate::motion::tokens::VOCABULARY_SIZE as u16).step_by(7).map(Token).collect();
        let rollouts = token_rollouts(states[1].as_ref().unwrap(), &tokens);
        let shared = PlausibilityCheck::new(&world, cbv, ego, &BackgroundForecast::default());
        let mut blockers = std::collections::BTreeSet::new();
        let (mut implausible, mut answered_by_the_blocker) = (0, 0);
        for r in &rollouts {
            let fresh = PlausibilityCheck::new(&world, cbv, ego, &BackgroundForecast::default());
            // A fresh check has no blocker to ask first; the shared one
            // answers some tokens from the blocker's contact alone.
            assert_eq!(fresh.touches_last_blocker_while_holding(r), None);
            answered_by_the_blocker += usize::from(shared.touches_last_blocker_while_holding(r).is_some());
            for rule in [ContactRule::Any, ContactRule::AtFaultOnly] {
                assert_eq!(shared.implausible(r, rule), fresh.implausible(r, rule));
                assert_eq!(shared.first_violation(r, rule), fresh.first_violation(r, rule));
            }
            implausible += usize::from(fresh.implausible(r, ContactRule::Any));
            blockers.insert(shared.last_blocker.get());
        }
        assert!(blockers.len() >= 3, "{blockers:?}");
        assert!(implausible > 50 && implausible < rollouts.len() - 50, "{implausible} of {}", rollouts.len());
        assert!(answered_by_the_blocker > 20, "{answered_by_the_blocker} of {implausible}");
    }

    #[test]
    fn a_scan_that_finds_nothing_leaves_its_verdicts_to_the_next_scan_of_the_same_rules() {
        // The CBV in the crowd, a prior ranking the vocabulary in a
        // scrambled order. A first scan whose extra condition keeps
        // nothing judges every token; the plain scan after it finds what a
        // fresh check finds, and a check with other rules starts afresh.
        let map = RoadMap::default();
        let (bodies, states) = crowd();
        let world = WorldView { map: &map, step: 10, bodies: &bodies, states: &states };
        let (ego, cbv) = (TrackIndex(0), TrackIndex(1));
        let size = crate::motion::tokens::VOCABULARY_SIZE;
        let logits: Vec<f32> = (0..size).map(|i| ((i * 7919) % size) as f32).collect();
        let region = [Token(5), Token(2000)];
        for rule in [ContactRule::Any, ContactRule::AtFaultOnly] {
            let shared = PlausibilityCheck::new(&world, cbv, ego, &BackgroundForecast::default());
            assert_eq!(shared.likeliest_plausible_outside_where(&logits, &region, rule, |_| false), None);
            let judged = |check: &PlausibilityCheck<'_>| {
                let mut scanned = check.scanned.borrow_mut();
                TokenGrid::all().filter(|&t| scanned.slot(t, rule).is_some()).count()
            };
            assert_eq!(judged(&shared), size - region.len(), "{rule:?}");
            let fresh = PlausibilityCheck::new(&world, cbv, ego, &BackgroundForecast::default());
            let found = fresh.likeliest_plausible_outside(&logits, &region, rule);
            assert!(found.is_some(), "{rule:?}");
            assert_eq!(shared.likeliest_plausible_outside(&logits, &region, rule), found, "{rule:?}");
            assert_eq!(judged(&shared.with_turning_limit(CbvTurningLimit::GRIP)), 0, "{rule:?}");
        }
    }

    #[test]
    fn whether_a_token_breaks_the_rule_at_all_is_whether_it_has_a_first_violation() {
        // On the dead-end road with traffic, on it and (2 m past its left
        // edge) off it: the early-stopping check (contacts first) says
        // "implausible" exactly for the tokens that have a first violation,
        // of either kind, under both rules.
        let map = dead_end_road();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 5];
        let tokens: Vec<Token> = (0..crate::motion::tokens::VOCABULARY_SIZE as u16).step_by(5).map(Token).collect();
        for (cbv_at, label) in [(car(0.0, 2.0, 12.0), "on the road"), (car(0.0, 8.0, 6.0), "off the road")] {
            let states =
                [car(-40.0, 0.0, 0.0), cbv_at, car(14.0, 2.0, 4.0), car(6.0, -0.5, 12.0), car(-9.0, 4.5, 16.0)];
            let world = WorldView { map: &map, step: 10, bodies: &bodies, states: &states };
            let check = PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &BackgroundForecast::default());
            let (mut road_first, mut contact_only, mut plausible) = (0, 0, 0);
            for r in token_rollouts(states[1].as_ref().unwrap(), &tokens) {
                for rule in [ContactRule::Any, ContactRule::AtFaultOnly] {
                    let first = check.first_violation(&r, rule);
                    assert_eq!(check.implausible(&r, rule), first.is_some(), "{label}, {rule:?}");
                }
                let contact = check.contact_violation(
                    &r,
                    &r.iter().copied().chain(braking_after(&r)).collect::<Vec<_>>(),
                    Violation::First,
                    ContactRule::Any,
                );
                match (check.first_violation(&r, ContactRule::Any), contact) {
                    (None, _) => plausible += 1,
                    (Some(k), Some(c)) if c == k => contact_only += 1,
                    (Some(_), _) => road_first += 1,
                }
            }
            // Both kinds of violation, and plausible tokens, are among them.
            assert!(
                road_first > 10 && contact_only > 10 && plausible > 10,
                "{label}: {road_first} {contact_only} {plausible}"
            );
        }
    }

    #[test]
    fn a_token_the_cbv_cannot_brake_out_of_is_implausible() {
        // Ego far away; the CBV at 15 m/s, 25 m behind a stopped car. Full
        // acceleration for 0.5 s leaves it no room to stop (about 8 m at
        // 19 m/s / 5 m/s² needs 36 m); full braking does.
        let map = RoadMap::default();
        let body = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };
        let bodies = [body; 3];
        let states = [car(0.0, 100.0, 10.0), car(0.0, 0.0, 15.0), car(30.0, 0.0, 0.0)];
        let world = WorldView { map: &map, step: 10, bodies: &bodies, states: &states };
        let (ego, cbv) = (TrackIndex(0), TrackIndex(1));
        let tokens = [token(MAX_ACCEL_MPS2), token(0.0), token(-MAX_ACCEL_MPS2)];
        let rollouts = token_rollouts(states[1].as_ref().unwrap(), &tokens);
        let implausible = |world: &WorldView<'_>| {
            let check = PlausibilityCheck::new(world, cbv, ego, &BackgroundForecast::default());
            rollouts.iter().map(|r| check.implausible(r, ContactRule::Any)).collect::<Vec<bool>>()
        };
        assert_eq!(implausible(&world), vec![true, true, false]);
        // The same tokens with the stopped car in the next lane are all plausible.
        let beside = [states[0], states[1], car(30.0, 4.0, 0.0)];
        let world = WorldView { states: &beside, ..world };
        assert_eq!(implausible(&world), vec![false; 3]);
    }

    #[test]
    fn slowing_in_front_of_replayed_traffic_closing_fast_is_implausible_seconds_before_contact() {
        // Ego far away; the CBV at 10 m/s and a replayed car 40 m behind it
        // at 25 m/s (35.5 m between the boxes, 15 m/s faster: contact in
        // 2.4 s at constant speeds, after the token and its 1 s hold).
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let tokens = [token(MAX_ACCEL_MPS2), token(0.0), token(-2.0)];
        let implausible = |states: &[Option<AgentState>; 3], not_replayed: &[usize]| {
            let scenario = recorded_at_constant_velocity(states);
            let world = WorldView { map: &scenario.map, step: 0, bodies: &bodies, states };
            let forecast = BackgroundForecast { recording: Some(&scenario), not_replayed };
            let check = PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &forecast);
            token_rollouts(states[1].as_ref().unwrap(), &tokens)
                .iter()
                .map(|r| check.implausible(r, ContactRule::Any))
                .collect::<Vec<bool>>()
        };
        let closing = [car(0.0, 100.0, 10.0), car(0.0, 0.0, 10.0), car(-40.0, 0.0, 25.0)];
        // Speeding up keeps ahead of it; keeping the speed or slowing down
        // is to be run into.
        assert_eq!(implausible(&closing, &[]), vec![false, true, true]);
        // A car the prior drives can brake: only the 1 s hold is checked.
        assert_eq!(implausible(&closing, &[2]), vec![false; 3]);
        // 80 m behind, it reaches the CBV in none of the three within 3.5 s.
        let far = [closing[0], closing[1], car(-80.0, 0.0, 25.0)];
        assert_eq!(implausible(&far, &[]), vec![false; 3]);
        // What the CBV would run into seconds ahead at its speed is left to
        // the braking check: a stopped car 25.5 m ahead is reached in
        // 2.55 s, and the CBV can still stop short of it.
        let ahead = [closing[0], closing[1], car(30.0, 0.0, 0.0)];
        assert_eq!(implausible(&ahead, &[]), vec![false; 3]);
    }

    #[test]
    fn the_ego_is_never_an_obstacle_of_the_plausibility_check() {
        // The adversary exists to reach the ego: closing on it is not implausible.
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(20.0, 0.0, 0.0), car(0.0, 0.0, 15.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let rollouts = token_rollouts(states[1].as_ref().unwrap(), &[token(MAX_ACCEL_MPS2)]);
        assert!(
            !PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &BackgroundForecast::default())
                .implausible(&rollouts[0], ContactRule::Any)
        );
    }

    #[test]
    fn a_token_after_which_the_cbv_cannot_stop_on_the_road_is_implausible() {
        // 30 m before the dead end at 15 m/s: full braking stops it on the
        // road (about 23 m); full acceleration for 0.5 s leaves it no room,
        // though the token itself stays on the road.
        let map = dead_end_road();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(-40.0, 0.0, 0.0), car(10.0, 2.0, 15.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        assert_eq!(
            implausible_tokens(&world, TrackIndex(1), &[token(MAX_ACCEL_MPS2), token(-MAX_ACCEL_MPS2)]),
            vec![true, false]
        );
    }

    #[test]
    fn under_the_wrong_way_rule_a_token_that_turns_the_cbv_against_the_traffic_is_implausible() {
        let map = two_way_road(1, 1);
        let own = lane_y(&map, 0);
        // Turning round in its own lane, 110° from the lane's direction at
        // 3 m/s (a lane 120° from its heading is driven against), further
        // on or back.
        let judged = |heading_deg: f64, rule| {
            turning_tokens_judged(&map, own, f64::to_radians(heading_deg), 3.0, [0.6, -0.6], rule)
        };
        // Turning on past 120° breaks the rule; turning back does not.
        assert_eq!(judged(110.0, WrongWayRule::Forbidden), [true, false]);
        // Without the rule (the default) neither does.
        assert_eq!(judged(110.0, WrongWayRule::Allowed), [false, false]);
        // A CBV against the traffic already must head back. At 170° the
        // lane of its way is the oncoming one, on its left: turning on (to
        // 187°) steers it away from that lane, turning back (to 153°)
        // towards it.
        assert_eq!(judged(170.0, WrongWayRule::Forbidden), [true, false]);
        assert_eq!(judged(170.0, WrongWayRule::Allowed), [false, false]);
    }

    #[test]
    fn under_the_wrong_way_rule_a_cbv_against_the_traffic_must_head_back_to_a_lane_of_its_way() {
        let map = two_way_road(1, 1);
        let (own, oncoming) = (lane_y(&map, 0), lane_y(&map, 100));
        // Overtaking in the oncoming lane at 10 m/s, heading its own way.
        let towards_own = (own - oncoming).signum();
        let judged = |yaw_rates_radps, rule| turning_tokens_judged(&map, oncoming, 0.0, 10.0, yaw_rates_radps, rule);
        // Steering back towards its own lane is plausible; steering on
        // away from it is not ...
        assert_eq!(judged([0.3 * towards_own, -0.3 * towards_own], WrongWayRule::Forbidden), [false, true]);
        // ... and neither is holding on in the oncoming lane.
        assert_eq!(judged([0.0, 0.0], WrongWayRule::Forbidden), [true, true]);
        // Without the rule any of them is.
        assert_eq!(judged([0.3 * towards_own, 0.0], WrongWayRule::Allowed), [false, false]);
        assert!(drives_wrong_way(&map, &car(100.0, oncoming, 10.0).unwrap()), "the CBV starts against the traffic");
    }

    #[test]
    fn along_the_lanes_a_token_that_turns_the_cbv_across_them_is_implausible_and_a_lane_change_is_not() {
        // Five lanes: room to turn across two of them to the right, away
        // from the oncoming lane, without leaving the road.
        let map = two_way_road(5, 1);
        let middle = lane_y(&map, 2);
        // At 8 m/s in the middle of five lanes, heading `heading_deg` to
        // the right of the lanes' direction, turning further on or back.
        let judged = |heading_deg: f64, rule| {
            turning_tokens_judged(&map, middle, -f64::to_radians(heading_deg), 8.0, [-0.5, 0.5], rule)
        };
        // 20° off the lanes: turning on at 0.5 rad/s passes 30° within the
        // token's half second (14°) ...
        assert_eq!(judged(20.0, WrongWayRule::AlongTheLanes), [true, false]);
        // ... which the wrong-way rule alone, and the default, allow.
        assert_eq!(judged(20.0, WrongWayRule::Forbidden), [false, false]);
        assert_eq!(judged(20.0, WrongWayRule::Allowed), [false, false]);
        // A lane change's few degrees, turning on, stay under 30°.
        assert_eq!(judged(5.0, WrongWayRule::AlongTheLanes), [false, false]);
        // A CBV across the lanes already (40°) must turn back towards
        // them: turning on (to 54°) breaks the rule, turning back (to 26°)
        // does not.
        assert_eq!(judged(40.0, WrongWayRule::AlongTheLanes), [true, false]);
        assert_eq!(judged(40.0, WrongWayRule::Forbidden), [false, false]);
    }

    #[test]
    fn at_a_human_lane_change_pace_a_token_that_moves_the_cbv_sideways_faster_is_implausible() {
        let map = two_way_road(5, 1);
        let middle = lane_y(&map, 2);
        let judged = |heading_deg: f64, rule| {
            turning_tokens_judged(&map, middle, -f64::to_radians(heading_deg), 8.0, [-0.5, 0.5], rule)
        };
        // 10° off the lanes at 8 m/s (1.39 m/s sideways): turning on at
        // 0.5 rad/s reaches 24° within the token (3.2 m/s sideways), which
        // along the lanes alone is allowed; turning back is plausible.
        assert_eq!(judged(10.0, WrongWayRule::HumanLaneChanges), [true, false]);
        assert_eq!(judged(10.0, WrongWayRule::AlongTheLanes), [false, false]);
        // Brisker already (20°, 2.7 m/s sideways): turning back slows the
        // pace and is plausible, turning on is not.
        assert_eq!(judged(20.0, WrongWayRule::HumanLaneChanges), [true, false]);
        // Across the lanes (40°) the along-the-lanes hold still applies.
        assert_eq!(judged(40.0, WrongWayRule::HumanLaneChanges), [true, false]);
    }

    #[test]
    fn under_the_wrong_way_rule_a_token_that_leaves_the_cbv_no_room_to_stay_out_of_the_oncoming_lane_is_implausible() {
        let map = two_way_road(2, 2);
        let (own, oncoming) = (lane_y(&map, 1), lane_y(&map, 100));
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        // At 20 m/s in the left of its two lanes, heading 8° towards the
        // two oncoming ones.
        let towards = 8f64.to_radians() * (oncoming - own).signum();
        let v = Vector2::new(towards.cos(), towards.sin()) * 20.0;
        let states = [
            car(20.0, own, 0.0),
            Some(AgentState { position: Point2::new(100.0, own), heading_rad: towards, velocity_mps: v }),
        ];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let yawing = |yaw_rate_radps| TokenGrid::quantize(Action { accel_mps2: 0.0, yaw_rate_radps });
        // Holding on, and steering half way back to the lane's direction
        // (and on, braking in that curve, into the lane on its right).
        let (on, back) = (yawing(0.0), yawing(-towards / (2.0 * crate::motion::TOKEN_PERIOD_S)));
        let rollouts = token_rollouts(states[1].as_ref().unwrap(), &[on, back]);
        // Holding on keeps the CBV with the traffic for the token's own
        // half second: it is the braking after it that crosses over.
        assert!(rollouts[0].iter().all(|s| !drives_wrong_way(&map, s)));
        let judged = |rule| {
            let check = PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &BackgroundForecast::default())
                .with_wrong_way(rule);
            rollouts.iter().map(|r| check.implausible(r, ContactRule::Any)).collect::<Vec<_>>()
        };
        assert_eq!(judged(WrongWayRule::Forbidden), [true, false]);
        assert_eq!(judged(WrongWayRule::Allowed), [false, false]);
    }

    #[test]
    fn room_to_stop_is_judged_to_a_standstill_not_over_the_first_two_seconds() {
        // 67 m before the dead end at 25 m/s. Holding speed for the token,
        // 2 s of full braking end 14.5 m short of the end, still at
        // 15 m/s: the standstill lies 8 m past it. Braking as the token
        // stops it 4.5 m short.
        let map = dead_end_road();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(-45.0, 0.0, 0.0), car(-27.0, 2.0, 25.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        assert_eq!(implausible_tokens(&world, TrackIndex(1), &[token(0.0), token(-MAX_ACCEL_MPS2)]), vec![true, false]);
    }

    #[test]
    fn off_the_road_the_cbv_must_head_back_to_it() {
        // 2 m beside the road's left edge (y = 6), heading along it.
        let map = dead_end_road();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(-40.0, 0.0, 0.0), car(0.0, 8.0, 5.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let turn = |yaw_rate_radps| TokenGrid::quantize(Action { accel_mps2: 0.0, yaw_rate_radps });
        assert_eq!(implausible_tokens(&world, TrackIndex(1), &[turn(0.5), turn(-0.5)]), vec![true, false]);
    }

    #[test]
    fn no_brake_checks_on_a_follower_but_stopping_room_is_judged_on_what_the_cbv_hits() {
        // A follower 3.5 m behind at the same 10 m/s (constant velocity).
        // Keeping speed is plausible, though braking hard after the token
        // would get the CBV hit from behind (the follower's doing, not the
        // CBV's); braking hard as the token, held for a second, is a brake
        // check and implausible.
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let states = [car(0.0, 100.0, 0.0), car(0.0, 0.0, 10.0), car(-8.0, 0.0, 10.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        assert_eq!(implausible_tokens(&world, TrackIndex(1), &[token(0.0), token(-MAX_ACCEL_MPS2)]), vec![false, true]);
        // The follower 20 m behind: braking hard is no brake check.
        let far = [states[0], states[1], car(-20.0, 0.0, 10.0)];
        let world = WorldView { states: &far, ..world };
        assert_eq!(
            implausible_tokens(&world, TrackIndex(1), &[token(0.0), token(-MAX_ACCEL_MPS2)]),
            vec![false, false]
        );
    }

    #[test]
    fn stopping_in_the_way_of_crossing_traffic_is_implausible() {
        // The CBV at 2 m/s stands in the path of a car crossing at 10 m/s,
        // 1 s away. Stopping there gets it hit (a stopped CBV is not at
        // fault by the metrics' rule, but it chose to stop there);
        // accelerating clears the path in time.
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let crossing = AgentState {
            position: Point2::new(8.0, -12.0),
            heading_rad: std::f64::consts::FRAC_PI_2,
            velocity_mps: Vector2::new(0.0, 10.0),
        };
        let states = [car(0.0, 100.0, 0.0), car(8.0, 0.0, 2.0), Some(crossing)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        assert_eq!(
            implausible_tokens(&world, TrackIndex(1), &[token(-MAX_ACCEL_MPS2), token(MAX_ACCEL_MPS2)]),
            vec![true, false]
        );
    }

    #[test]
    fn with_no_plausible_token_in_the_trust_region_the_likeliest_plausible_one_is_taken() {
        // Before the dead end: the prior likes accelerating (implausible);
        // among the rest it prefers -4 m/s² to -5 m/s².
        let map = dead_end_road();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(-40.0, 0.0, 0.0), car(10.0, 2.0, 15.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let mut logits = vec![-10.0f32; crate::motion::tokens::VOCABULARY_SIZE];
        logits[token(MAX_ACCEL_MPS2).0 as usize] = 5.0;
        logits[token(3.0).0 as usize] = 4.0;
        logits[token(-4.0).0 as usize] = 2.0;
        logits[token(-MAX_ACCEL_MPS2).0 as usize] = 1.0;
        let check = PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &BackgroundForecast::default());
        assert_eq!(
            check.likeliest_plausible_outside(&logits, &[], ContactRule::Any),
            Some(token(-4.0)),
            "the likeliest plausible of all"
        );
        let region = [token(MAX_ACCEL_MPS2), token(3.0)];
        assert_eq!(check.likeliest_plausible_outside(&logits, &region, ContactRule::Any), Some(token(-4.0)));
        // A region that holds the likeliest plausible token leaves the next one.
        let region = [token(MAX_ACCEL_MPS2), token(-4.0)];
        assert_eq!(
            check.likeliest_plausible_outside(&logits, &region, ContactRule::Any),
            Some(token(-MAX_ACCEL_MPS2)),
            "skipped over the region, not over the ranks it would fill"
        );
    }

    #[test]
    fn in_the_fallback_a_cut_in_hit_from_behind_is_the_cbvs_fault_and_keeping_its_lane_is_not() {
        // Two eastbound lanes (y 0–3.5 and 3.5–7). The CBV at 10 m/s with
        // its centre just inside the left lane (y = 3.6); a follower in the
        // right lane 8 m behind at 20 m/s. Keeping its lane, the follower
        // clips the CBV's rear corner: hit from behind in its own lane, not
        // its fault (nuPlan). Moving over into the right lane in front of
        // the follower (a crabbing path, to keep the geometry plain), the
        // same hit from behind is a cut-in: its fault in the fallback.
        let map = crate::map::templates::StraightRoad {
            lanes: 2,
            oncoming_lanes: 0,
            lane_width_m: 3.5,
            length_m: 200.0,
            speed_limit_mps: None,
        }
        .build();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 3];
        let states = [car(150.0, 5.25, 10.0), car(100.0, 3.6, 10.0), car(92.0, 1.75, 20.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let check = PlausibilityCheck::new(&world, TrackIndex(1), TrackIndex(0), &BackgroundForecast::default());
        let path = |lateral_m: fn(usize) -> f64| -> Vec<AgentState> {
            (1..=TOKEN_PERIOD_STEPS)
                .map(|k| car(100.0 + k as f64 * 10.0 * SIM_DT_S, lateral_m(k), 10.0).unwrap())
                .collect()
        };
        let keeping_its_lane = path(|_| 3.6);
        let cutting_in = path(|k| 3.6 - 0.2 * k as f64);
        assert!(check.implausible(&keeping_its_lane, ContactRule::Any), "the follower hits it");
        assert!(!check.implausible(&keeping_its_lane, ContactRule::AtFaultOnly));
        assert!(check.implausible(&cutting_in, ContactRule::AtFaultOnly));
    }
}
