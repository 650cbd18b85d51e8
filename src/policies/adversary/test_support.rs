//! What the adversary's unit tests share: cars, tokens, a dead-end road,
//! a stub feasibility oracle and the choice on an open plane.

use super::{BackgroundForecast, EgoCbvState, Feasibility, FeasibilityOracle, Search, safer_choice};
use crate::geometry::{Point2, Vector2};
use crate::map::RoadMap;
use crate::models::ModelError;
use crate::motion::Action;
use crate::motion::tokens::{Token, TokenGrid};
use crate::policies::WorldView;
use crate::scenario::{AgentBody, AgentKind, AgentState, TrackIndex};

/// A car at (`x`, `y`) heading along +x at `speed_mps`.
pub(super) fn car(x: f64, y: f64, speed_mps: f64) -> Option<AgentState> {
    Some(AgentState { position: Point2::new(x, y), heading_rad: 0.0, velocity_mps: Vector2::new(speed_mps, 0.0) })
}

/// A car at the origin heading along +x at a steady `speed_mps`, and its
/// states under the token of `yaw_rate_radps` (no acceleration).
pub(super) fn turning(speed_mps: f64, yaw_rate_radps: f64) -> (AgentState, Vec<AgentState>) {
    let now = car(0.0, 0.0, speed_mps).expect("a car");
    let token = TokenGrid::quantize(Action { accel_mps2: 0.0, yaw_rate_radps });
    let from = crate::motion::KinematicState::from_agent_state(&now);
    (now, TokenGrid::rollout(&from, token).iter().map(crate::motion::KinematicState::to_agent_state).collect())
}

/// The token of `accel_mps2` driving straight on.
pub(super) fn token(accel_mps2: f64) -> Token {
    TokenGrid::quantize(Action { accel_mps2, yaw_rate_radps: 0.0 })
}

/// A road 8 m wide along +x (y from -2 to 6) that ends at x = 40: one
/// road edge with the road on its left.
pub(super) fn dead_end_road() -> RoadMap {
    use crate::geometry::Polyline;
    use crate::map::{MapElementId, RoadEdge, RoadEdgeKind};
    let points = [(-50.0, -2.0), (40.0, -2.0), (40.0, 6.0), (-50.0, 6.0)];
    let polyline = Polyline::new(points.iter().map(|&(x, y)| Point2::new(x, y)).collect());
    let edge = RoadEdge { id: MapElementId(1), polyline, kind: RoadEdgeKind::Boundary };
    RoadMap::new(vec![], vec![edge], vec![], vec![], vec![], vec![], vec![])
}

/// The choice with the ego (index 0), the CBV (index 1) and any other
/// cars (background at constant velocity) in `states` on an open plane,
/// the prior liking the straight-on accelerations `liked` (m/s², logit)
/// and nothing else.
pub(super) fn choice_in(
    states: &[Option<AgentState>],
    liked: &[(f64, f32)],
    search: Search,
    oracle: Option<&dyn FeasibilityOracle>,
) -> Token {
    let liked: Vec<(Token, f32)> = liked.iter().map(|&(accel_mps2, logit)| (token(accel_mps2), logit)).collect();
    choice_among(states, &liked, search, oracle)
}

/// [`choice_in`] with the prior liking the tokens `liked` (token, logit).
pub(super) fn choice_among(
    states: &[Option<AgentState>],
    liked: &[(Token, f32)],
    search: Search,
    oracle: Option<&dyn FeasibilityOracle>,
) -> Token {
    choice_under(states, liked, search, Feasibility { oracle, ..Feasibility::default() })
}

/// [`choice_among`] under the whole feasibility constraint `constraint`.
pub(super) fn choice_under(
    states: &[Option<AgentState>],
    liked: &[(Token, f32)],
    search: Search,
    constraint: Feasibility<'_>,
) -> Token {
    let map = RoadMap::default();
    let bodies = vec![AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; states.len()];
    let world = WorldView { map: &map, step: 0, bodies: &bodies, states };
    let logits = logits_liking(liked);
    let mut feasibility_s = 0.0;
    safer_choice(
        &world,
        (TrackIndex(1), TrackIndex(0)),
        &logits,
        search,
        &BackgroundForecast::default(),
        constraint,
        &mut feasibility_s,
    )
    .unwrap()
    .unwrap()
}

/// The prior's logits when it likes the tokens `liked` (token, logit) and
/// nothing else.
pub(super) fn logits_liking(liked: &[(Token, f32)]) -> Vec<f32> {
    let mut logits = vec![-30.0f32; crate::motion::tokens::VOCABULARY_SIZE];
    for &(t, logit) in liked {
        logits[t.0 as usize] = logit;
    }
    logits
}

/// A feasibility value from a rule on the candidate state.
pub(super) struct StubOracle(pub(super) fn(&EgoCbvState) -> f32);
impl FeasibilityOracle for StubOracle {
    fn values(&self, pairs: &[EgoCbvState]) -> Result<Vec<f32>, ModelError> {
        Ok(pairs.iter().map(self.0).collect())
    }
}

/// The accelerations (m/s², logit) the prior likes in the choice tests.
pub(super) const LIKED: [(f64, f32); 5] = [(-5.0, 5.0), (-2.0, 4.0), (0.0, 3.0), (2.0, 2.0), (5.0, 1.0)];
