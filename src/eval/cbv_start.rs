//! Where the CBV starts relative to the ego: behind it, beside it or ahead
//! of it going its way, across its way, or towards it. The start bounds the
//! conflicts a scene's adversary can make: a CBV behind the ego and going
//! its way reaches the ego's front only by overtaking it, and otherwise runs
//! into its tail, the contact `--ego-contact not-from-behind` rules out; so
//! `safer evaluate` reports the collision rate by the CBV's start.
//!
//! The rules, with Δ the angle between the two headings: `oncoming` when
//! Δ ≥ 135°, `crossing` when Δ ≥ 45° (the bounds of the conflict kinds,
//! [`crate::eval::conflict_kind`]); going the same way, `behind` when the
//! CBV's front is behind the ego's tail along the ego's heading, `ahead`
//! when its tail is ahead of the ego's front, `beside` when the two
//! overlap along the ego's heading (in any lane).

use crate::geometry::wrap_angle;
use crate::scenario::{AgentBody, AgentState, Scenario};

/// The heading difference from which a CBV crosses the ego's way, rad (45°).
pub const CROSSING_MIN_ANGLE_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// The heading difference from which a CBV comes towards the ego, rad (135°).
pub const ONCOMING_MIN_ANGLE_RAD: f64 = 3.0 * std::f64::consts::FRAC_PI_4;

/// Where the CBV starts relative to the ego.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CbvStart {
    /// Going the ego's way, wholly behind its tail.
    Behind,
    /// Going the ego's way, beside it (the two overlap along its heading).
    Beside,
    /// Going the ego's way, wholly ahead of its front.
    Ahead,
    /// Across the ego's way (45° to 135° from its heading).
    Crossing,
    /// Towards the ego (135° or more from its heading).
    Oncoming,
}

impl CbvStart {
    /// Every start, in report order.
    pub const ALL: [Self; 5] = [Self::Behind, Self::Beside, Self::Ahead, Self::Crossing, Self::Oncoming];

    /// The name reports use.
    pub fn name(self) -> &'static str {
        match self {
            Self::Behind => "behind",
            Self::Beside => "beside",
            Self::Ahead => "ahead",
            Self::Crossing => "crossing",
            Self::Oncoming => "oncoming",
        }
    }

    /// Where a CBV at `cbv` starts relative to an ego at `ego`.
    pub fn of((ego, ego_body): (&AgentState, &AgentBody), (cbv, cbv_body): (&AgentState, &AgentBody)) -> Self {
        let delta_rad = wrap_angle(cbv.heading_rad - ego.heading_rad).abs();
        if delta_rad >= ONCOMING_MIN_ANGLE_RAD {
            return Self::Oncoming;
        }
        if delta_rad >= CROSSING_MIN_ANGLE_RAD {
            return Self::Crossing;
        }
        let forward = crate::geometry::Vector2::new(ego.heading_rad.cos(), ego.heading_rad.sin());
        let along_m = (cbv.position - ego.position).dot(&forward);
        let clear_m = (ego_body.length_m + cbv_body.length_m) / 2.0;
        if along_m < -clear_m {
            Self::Behind
        } else if along_m > clear_m {
            Self::Ahead
        } else {
            Self::Beside
        }
    }

    /// Where the scenario's CBV starts relative to its ego at the current
    /// step, where the variants start; `None` without both there.
    pub fn of_scenario(scenario: &Scenario) -> Option<Self> {
        let track = |i: Option<crate::scenario::TrackIndex>| {
            let track = &scenario.tracks[i?.0];
            Some((track.state(scenario.current_step)?, track.body()))
        };
        let ((ego, ego_body), (cbv, cbv_body)) = (track(scenario.ego)?, track(scenario.cbv)?);
        Some(Self::of((ego, &ego_body), (cbv, &cbv_body)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Point2, Vector2};
    use crate::scenario::AgentKind;

    const CAR: AgentBody = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };

    fn at(x: f64, y: f64, heading_deg: f64) -> AgentState {
        let heading_rad = heading_deg.to_radians();
        AgentState {
            position: Point2::new(x, y),
            heading_rad,
            velocity_mps: Vector2::new(heading_rad.cos(), heading_rad.sin()) * 10.0,
        }
    }

    fn start(cbv: AgentState) -> CbvStart {
        // The ego at the origin, heading 30° (so the frame matters).
        let ego = at(0.0, 0.0, 30.0);
        CbvStart::of((&ego, &CAR), (&cbv, &CAR))
    }

    #[test]
    fn a_cbv_going_the_egos_way_is_behind_beside_or_ahead_by_its_offset_along_the_egos_heading() {
        // `m` along the ego's heading and `left_m` to its left.
        let along = |m: f64, left_m: f64, heading_deg: f64| {
            let forward = Vector2::new(30f64.to_radians().cos(), 30f64.to_radians().sin());
            let p = forward * m + Vector2::new(-forward.y, forward.x) * left_m;
            at(p.x, p.y, heading_deg)
        };
        // Two car lengths back in the next lane, and just clear of the tail.
        assert_eq!(start(along(-9.0, 3.5, 30.0)), CbvStart::Behind);
        assert_eq!(start(along(-4.6, 0.0, 40.0)), CbvStart::Behind);
        // Overlapping the ego's length, in the next lane either side.
        assert_eq!(start(along(-4.4, 3.5, 30.0)), CbvStart::Beside);
        assert_eq!(start(along(3.0, -3.5, 20.0)), CbvStart::Beside);
        // Clear of its front, in its lane or the next.
        assert_eq!(start(along(4.6, 0.0, 30.0)), CbvStart::Ahead);
        assert_eq!(start(along(30.0, 3.5, 70.0)), CbvStart::Ahead);
    }

    #[test]
    fn a_cbv_heading_45_degrees_or_more_off_the_egos_way_crosses_it_and_135_or_more_comes_towards_it() {
        assert_eq!(start(at(20.0, 0.0, 30.0 + 44.0)), CbvStart::Ahead);
        assert_eq!(start(at(20.0, 0.0, 30.0 + 46.0)), CbvStart::Crossing);
        assert_eq!(start(at(20.0, 0.0, 30.0 - 134.0)), CbvStart::Crossing);
        assert_eq!(start(at(20.0, 0.0, 30.0 + 136.0)), CbvStart::Oncoming);
        // Across the ±180° seam.
        assert_eq!(start(at(-20.0, 5.0, 30.0 - 180.0)), CbvStart::Oncoming);
    }
}
