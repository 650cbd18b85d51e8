//! Per-variant acceptance: what the planner under test's rollout must
//! satisfy, each failure a sentence saying what happened, when and with whom.

use crate::eval::escape::CollisionEscape;
use crate::eval::progress;
use crate::eval::traffic_rules;
use crate::map::RoadMap;
use crate::scenario::Scenario;
use crate::sim::{Rollout, RolloutSummary, Termination};
use crate::spec::suite::VariantAcceptance;

/// One failed criterion.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AcceptanceFailure {
    /// The criterion (as written in the spec).
    pub criterion: String,
    /// What happened.
    pub what: String,
}

/// Checks a stage-2 rollout; empty when it passes. `escape` is the
/// closed-loop witness's verdict on the ego's collision: a collision with
/// no escape within its budget is the generator's fault, not the
/// planner's, and fails neither collision criterion (it still does not
/// count as solved); a collision no witness was searched for fails.
/// `base` is the scene the variant was made from: its map, and its logged
/// ego for `min_progress`.
pub fn check(
    criteria: &VariantAcceptance,
    rollout: &Rollout,
    base: &Scenario,
    min_ttc_s: Option<f64>,
    escape: Option<CollisionEscape>,
) -> Vec<AcceptanceFailure> {
    let map = &base.map;
    let mut out = Vec::new();
    let summary = rollout.summary();
    // A rollout that could not run to its end never passes, whatever the
    // criteria say: a planner that stops answering has not solved anything.
    out.extend(termination_failure(rollout));
    let against_the_planner = escape.is_none_or(CollisionEscape::avoidable);
    if against_the_planner {
        collision_failures(criteria, &summary, &mut out);
    }
    traffic_rule_failures(criteria, rollout, &summary, map, &mut out);
    if let Some(share) = criteria.min_progress {
        out.extend(progress_failure(share, rollout, base));
    }
    margin_failures(criteria, &summary, min_ttc_s, &mut out);
    out
}

/// Whether the closed-loop witness is asked about `stage2`'s ego collision
/// under `criteria` ([`VariantAcceptance::witnesses_collision`]; a rollout
/// without one has nothing to ask about).
pub fn asks_witness(criteria: &VariantAcceptance, stage2: &Rollout) -> bool {
    stage2.summary().ego_collision.is_none_or(|c| criteria.witnesses_collision(c.at_fault))
}

/// A criterion's failure.
fn fail(criterion: &str, what: String) -> AcceptanceFailure {
    AcceptanceFailure { criterion: criterion.to_string(), what }
}

/// Why a rollout that did not run to its end fails, if it did not.
fn termination_failure(rollout: &Rollout) -> Option<AcceptanceFailure> {
    match &rollout.termination {
        Termination::Completed | Termination::EgoCollision { .. } | Termination::LeftMappedArea { .. } => {}
        Termination::PlannerFailed { step, reason } => {
            let t = step.saturating_sub(rollout.start_step) as f64 * rollout.dt_s;
            return Some(fail(
                "planner_must_answer",
                format!("planner `{}` failed at t = {t:.1} s: {reason}", rollout.planner),
            ));
        }
        Termination::VehicleLimitExceeded { step, reason } => {
            let t = step.saturating_sub(rollout.start_step) as f64 * rollout.dt_s;
            return Some(fail(
                "vehicle_limits",
                format!(
                    "planner `{}` drove the ego beyond its vehicle limits at t = {t:.1} s: {reason}",
                    rollout.planner
                ),
            ));
        }
        Termination::InvalidAgentState { step, agent, reason } => {
            let t = step.saturating_sub(rollout.start_step) as f64 * rollout.dt_s;
            return Some(fail(
                "rollout_completed",
                format!("the rollout was aborted at t = {t:.1} s: agent {agent} has an invalid state: {reason}"),
            ));
        }
    }
    None
}

/// The collision criteria, for a collision that counts against the planner.
fn collision_failures(criteria: &VariantAcceptance, summary: &RolloutSummary, out: &mut Vec<AcceptanceFailure>) {
    if criteria.no_collision
        && let Some(c) = &summary.ego_collision
    {
        let role = if c.with_cbv { " (the CBV)" } else { "" };
        let fault = if c.at_fault { "" } else { ", not at fault" };
        out.push(fail(
            "no_collision",
            format!(
                "ego collided with agent {}{role} at t = {:.1} s ({}{fault})",
                c.other,
                c.time_s,
                c.kind.describe()
            ),
        ));
    }
    if criteria.no_at_fault_collision
        && !criteria.no_collision
        && let Some(c) = summary.ego_collision.as_ref().filter(|c| c.at_fault)
    {
        let role = if c.with_cbv { " (the CBV)" } else { "" };
        out.push(fail(
            "no_at_fault_collision",
            format!(
                "ego caused a collision ({}) with agent {}{role} at t = {:.1} s",
                c.kind.describe(),
                c.other,
                c.time_s
            ),
        ));
    }
}

/// The driving rules: off road, wrong way, red lights, speeding; each
/// unmeasurable on a map without what it needs, which fails.
fn traffic_rule_failures(
    criteria: &VariantAcceptance,
    rollout: &Rollout,
    summary: &RolloutSummary,
    map: &RoadMap,
    out: &mut Vec<AcceptanceFailure>,
) {
    if criteria.no_off_road {
        if map.road_edges.is_empty() {
            // Without road edges nothing is off the road: not a pass.
            out.push(fail(
                "no_off_road",
                "cannot be measured: the scene's map has no road edges (no roads or lanelets)".to_string(),
            ));
        } else if let Some(t) = summary.ego_off_road_s {
            out.push(fail("no_off_road", format!("ego left the road at t = {t:.1} s")));
        }
    }
    if criteria.no_wrong_way {
        if !traffic_rules::has_directed_lanes(map) {
            out.push(fail(
                "no_wrong_way",
                format!(
                    "cannot be measured: the scene's map has no lane (of at least {} m) to tell the traffic's direction",
                    traffic_rules::MIN_DIRECTED_LANE_M
                ),
            ));
        } else if let Some(w) = traffic_rules::wrong_way(rollout, map) {
            out.push(fail(
                "no_wrong_way",
                format!(
                    "ego drove against the traffic of lane {} for {:.1} s from t = {:.1} s",
                    w.lane.0, w.duration_s, w.start_s
                ),
            ));
        }
    }
    if criteria.no_red_light
        && let Some(r) = traffic_rules::red_light_run(rollout, map)
    {
        out.push(fail(
            "no_red_light",
            format!("ego passed the stop line of lane {} on {} at t = {:.1} s", r.lane.0, r.state.describe(), r.time_s),
        ));
    }
    if criteria.no_speeding {
        if !traffic_rules::has_speed_limits(map) {
            out.push(fail(
                "no_speeding",
                "cannot be measured: the scene's map gives no lane a speed limit".to_string(),
            ));
        } else if let Some(v) = traffic_rules::speeding(rollout, map) {
            out.push(fail(
                "no_speeding",
                format!(
                    "ego drove above the limit of lane {} ({:.1} m/s) for {:.1} s from t = {:.1} s, at up to {:.1} m/s",
                    v.lane.0, v.limit_mps, v.duration_s, v.start_s, v.max_speed_mps
                ),
            ));
        }
    }
}

/// `min_progress: share`: the ego covers that share of the logged ego's
/// distance unless something in its path stopped it.
fn progress_failure(share: f64, rollout: &Rollout, base: &Scenario) -> Option<AcceptanceFailure> {
    let logged = base.ego.map_or(&[][..], |ego| &base.track(ego).states[..]);
    match progress::progress(rollout, logged) {
        None => Some(fail(
            "min_progress",
            format!(
                "cannot be measured: the logged ego drives under {} m over these steps, so there is no route \
                     to measure progress along",
                progress::MIN_LOGGED_ROUTE_M
            ),
        )),
        // A NaN share (no distance logged) cannot pass.
        Some(p) if p.blocked_by.is_none() && (p.share().is_nan() || p.share() < share) => Some(fail(
            "min_progress",
            format!(
                "ego drove {:.1} m, {:.0} % of the logged ego's {:.1} m (at least {:.0} % asked), and nothing \
                     in its path stopped it",
                p.driven_m,
                100.0 * p.share(),
                p.logged_m,
                100.0 * share
            ),
        )),
        Some(_) => None,
    }
}

/// The margins: the smallest gap to any agent and the time to collision.
fn margin_failures(
    criteria: &VariantAcceptance,
    summary: &RolloutSummary,
    min_ttc_s: Option<f64>,
    out: &mut Vec<AcceptanceFailure>,
) {
    // A NaN gap (an agent at a non-finite position) fails.
    if let (Some(min), Some(gap)) = (criteria.min_gap_m, summary.min_distance_to_ego_m)
        && (gap.is_nan() || gap < min)
    {
        let who = summary.closest_agent.as_ref().map_or(String::new(), |a| format!(" to agent {a}"));
        out.push(fail("min_gap_m", format!("closest gap{who} was {gap:.2} m < {min} m")));
    }
    if let (Some(min), Some(ttc)) = (criteria.min_ttc_s, min_ttc_s)
        && (ttc.is_nan() || ttc < min)
    {
        out.push(fail("min_ttc_s", format!("time to collision fell to {ttc:.1} s < {min} s")));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::RoadMap;
    use crate::record::test_support::{crossing_rollout, crossing_scenario};

    fn criteria(no_collision: bool, no_at_fault_collision: bool) -> VariantAcceptance {
        VariantAcceptance { no_collision, no_at_fault_collision, ..VariantAcceptance::default() }
    }

    fn failed(escape: Option<CollisionEscape>, criteria: &VariantAcceptance) -> Vec<String> {
        let scenario = crossing_scenario();
        let rollout = crossing_rollout(&scenario);
        assert!(rollout.ego_collision().is_some(), "the fixture's ego must collide");
        check(criteria, &rollout, &scenario, None, escape).into_iter().map(|f| f.criterion).collect()
    }

    #[test]
    fn an_avoidable_collision_fails_and_one_without_an_escape_is_the_generators_fault() {
        let strict = criteria(true, false);
        assert_eq!(failed(Some(CollisionEscape::Avoidable), &strict), ["no_collision"]);
        assert!(failed(Some(CollisionEscape::NoEscapeFound), &strict).is_empty());
        assert!(failed(Some(CollisionEscape::NoEscapeVerified), &strict).is_empty());
        // No witness searched: the collision counts against the planner.
        assert_eq!(failed(None, &strict), ["no_collision"]);
    }

    #[test]
    fn an_ego_beyond_its_vehicle_limits_fails_whatever_the_criteria_and_is_never_solved() {
        let mut rollout = crossing_rollout(&crossing_scenario());
        rollout.termination = crate::sim::Termination::VehicleLimitExceeded {
            step: rollout.start_step + 12,
            reason: "deceleration 98.000 m/s² exceeds the vehicle limit max_decel_mps2 = 12 m/s²".into(),
        };
        let lax = criteria(false, false);
        let failures = check(&lax, &rollout, &crossing_scenario(), None, None);
        assert_eq!(failures.len(), 1, "{failures:?}");
        assert_eq!(failures[0].criterion, "vehicle_limits");
        assert!(failures[0].what.contains("at t = 1.2 s: deceleration 98.000"), "{}", failures[0].what);
        assert!(!crate::harness::Stage2Verdict::of(&rollout).solved());
    }

    #[test]
    fn no_off_road_on_a_map_without_road_edges_fails_as_unmeasurable() {
        let scenario = crossing_scenario();
        let rollout = crossing_rollout(&scenario);
        let off_road = VariantAcceptance { no_collision: false, no_off_road: true, ..VariantAcceptance::default() };
        let empty = Scenario { map: RoadMap::from_lanes(vec![]), ..scenario.clone() };
        let failures = check(&off_road, &rollout, &empty, None, None);
        assert_eq!(failures.len(), 1, "{failures:?}");
        assert!(failures[0].what.starts_with("cannot be measured"), "{failures:?}");
        assert!(!scenario.map.road_edges.is_empty());
        assert!(check(&off_road, &rollout, &scenario, None, None).iter().all(|f| f.criterion != "no_off_road"));
    }

    #[test]
    fn no_speeding_on_a_map_without_speed_limits_fails_as_unmeasurable() {
        let scenario = crossing_scenario();
        let rollout = crossing_rollout(&scenario);
        let speeding = VariantAcceptance { no_collision: false, no_speeding: true, ..VariantAcceptance::default() };
        let mut unlimited = scenario.clone();
        unlimited.map.lanes.iter_mut().for_each(|l| l.speed_limit_mps = None);
        let failures = check(&speeding, &rollout, &unlimited, None, None);
        assert_eq!(failures.len(), 1, "{failures:?}");
        assert_eq!(failures[0].criterion, "no_speeding");
        assert!(failures[0].what.starts_with("cannot be measured"), "{failures:?}");
    }

    #[test]
    fn the_at_fault_rule_follows_the_same_verdict() {
        let at_fault = criteria(false, true);
        let rollout = crossing_rollout(&crossing_scenario());
        let is_at_fault = rollout.summary().ego_collision.is_some_and(|c| c.at_fault);
        let expected: &[&str] = if is_at_fault { &["no_at_fault_collision"] } else { &[] };
        assert_eq!(failed(Some(CollisionEscape::Avoidable), &at_fault), expected);
        assert!(failed(Some(CollisionEscape::NoEscapeFound), &at_fault).is_empty());
    }
}
