//! What the trust region offers the CBV at one token boundary, to diagnose
//! a realism prior: how much of the prior's probability its top n tokens
//! hold, which accelerations and yaw rates they cover (the longitudinal and
//! the lateral choice, apart), how many distinct behaviours they make
//! (each token held for [`BEHAVIOUR_HOLD_S`], end positions more than
//! [`BEHAVIOUR_SEPARATION_M`] apart), and how many the plausibility rule
//! lets the CBV take. SaFeR can only be as adversarial as these tokens are
//! different: a region of 20 speed choices with no steering offers no lane
//! change, cut-in or turn towards the ego.

use super::background_forecast::BackgroundForecast;
use super::behaviours::distinct_behaviours;
#[cfg(doc)]
use super::behaviours::{BEHAVIOUR_HOLD_S, BEHAVIOUR_SEPARATION_M};
#[cfg(doc)]
use super::choice::TrustRegion;
use super::plausibility::{ContactRule, PlausibilityCheck};
use super::rollout::token_rollouts;
use crate::motion::KinematicState;
use crate::motion::tokens::{Token, TokenGrid};
use crate::policies::WorldView;
use crate::scenario::{AgentState, TrackIndex};

/// The trust region at one token boundary.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrustRegionProfile {
    /// Tokens in the region (n, or fewer for a smaller vocabulary).
    pub tokens: usize,
    /// The prior's probability of the region's tokens together.
    pub probability_mass: f64,
    /// Highest minus lowest acceleration among the tokens (bin centres),
    /// m/s²: the longitudinal choice.
    pub accel_range_mps2: f64,
    /// Distinct acceleration bins among the tokens.
    pub accel_bins: usize,
    /// Highest minus lowest yaw rate among the tokens (bin centres),
    /// rad/s: the lateral choice.
    pub yaw_rate_range_radps: f64,
    /// Distinct yaw-rate bins among the tokens.
    pub yaw_rate_bins: usize,
    /// Distinct behaviours: the tokens' end positions after holding each
    /// for [`BEHAVIOUR_HOLD_S`], grouped in likelihood order, a token
    /// starting a new group when it ends more than
    /// [`BEHAVIOUR_SEPARATION_M`] from every earlier group's first.
    pub behaviours: usize,
    /// Tokens that pass the plausibility rule (the strict one: any
    /// contact counts).
    pub plausible: usize,
}

/// The profile of a region's `tokens` ([`TrustRegion::tokens`] of
/// `logits`) for the CBV of the pair (CBV, ego) in `world` (the background
/// predicted by `forecast`); `None` when the CBV is absent or `tokens` is
/// empty.
pub fn profile_trust_region(
    world: &WorldView<'_>,
    (cbv, ego): (TrackIndex, TrackIndex),
    logits: &[f32],
    tokens: &[Token],
    forecast: &BackgroundForecast<'_>,
) -> Option<TrustRegionProfile> {
    let now = world.state(cbv)?;
    if tokens.is_empty() {
        return None;
    }
    // Softmax mass, stable against large logits.
    let top_logit = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64;
    let weight = |l: f32| (l as f64 - top_logit).exp();
    let total: f64 = logits.iter().map(|&l| weight(l)).sum();
    let mass = tokens.iter().map(|t| weight(logits[t.0 as usize])).sum::<f64>() / total;
    let (accel_range_mps2, yaw_rate_range_radps) = TokenGrid::ranges(tokens);
    let distinct = |bins: &mut dyn Iterator<Item = usize>| bins.collect::<std::collections::BTreeSet<_>>().len();
    let from = KinematicState::from_agent_state(now);
    let check = PlausibilityCheck::new(world, cbv, ego, forecast);
    let plausible = token_rollouts(now, tokens).iter().filter(|r| !check.implausible(r, ContactRule::Any)).count();
    Some(TrustRegionProfile {
        tokens: tokens.len(),
        probability_mass: mass,
        accel_range_mps2,
        accel_bins: distinct(&mut tokens.iter().map(|t| t.accel_bin())),
        yaw_rate_range_radps,
        yaw_rate_bins: distinct(&mut tokens.iter().map(|t| t.yaw_rate_bin())),
        behaviours: distinct_behaviours(&from, tokens.iter().copied(), usize::MAX).len(),
        plausible,
    })
}

/// Where in a region's `tokens` (most likely first) the token lies that
/// took the CBV from `now` through `period` (its states after each step of
/// the token period; rank 0: the likeliest), or `None` when no token of the
/// region did (the plausibility fallback chose from outside it, or
/// something else drove the CBV).
pub fn rank_of_driven_token(now: &AgentState, period: &[AgentState], tokens: &[Token]) -> Option<usize> {
    let from = KinematicState::from_agent_state(now);
    tokens.iter().position(|t| TokenGrid::reproduces(&from, *t, period))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::RoadMap;
    use crate::motion::tokens::VOCABULARY_SIZE;
    use crate::policies::adversary::choice::TrustRegion;
    use crate::policies::adversary::test_support::car;
    use crate::scenario::{AgentBody, AgentKind};

    /// Logits that like `liked` tokens (bins) at the given logit, the rest
    /// at −30.
    fn logits(liked: &[((usize, usize), f32)]) -> Vec<f32> {
        let mut l = vec![-30.0f32; VOCABULARY_SIZE];
        for ((a, y), logit) in liked {
            l[Token::from_bins(*a, *y).unwrap().0 as usize] = *logit;
        }
        l
    }

    fn profile(liked: &[((usize, usize), f32)], n: usize) -> TrustRegionProfile {
        let map = RoadMap::default();
        let bodies = [AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; 2];
        let states = [car(0.0, 0.0, 10.0), car(-30.0, 0.0, 10.0)];
        let world = WorldView { map: &map, step: 0, bodies: &bodies, states: &states };
        let logits = logits(liked);
        let tokens = TrustRegion::TopN(n).tokens(&logits, states[1].as_ref().unwrap());
        profile_trust_region(&world, (TrackIndex(1), TrackIndex(0)), &logits, &tokens, &BackgroundForecast::default())
            .unwrap()
    }

    #[test]
    fn speed_choices_alone_are_no_lateral_choice() {
        // Four accelerations at zero yaw rate (bin 31 is the centre).
        let liked: Vec<_> = [20, 28, 34, 42].iter().map(|&a| ((a, 31), 5.0)).collect();
        let p = profile(&liked, 4);
        assert_eq!((p.tokens, p.accel_bins, p.yaw_rate_bins), (4, 4, 1));
        assert_eq!(p.yaw_rate_range_radps, 0.0);
        let expected = TokenGrid::accel_centre(42) - TokenGrid::accel_centre(20);
        assert!((p.accel_range_mps2 - expected).abs() < 1e-12, "{p:?}");
        // Each held for 2 s ends metres apart along the lane: four behaviours.
        assert_eq!(p.behaviours, 4);
        // Four liked tokens hold nearly all the mass; the rest share e^-35 each.
        assert!(p.probability_mass > 0.999 && p.probability_mass <= 1.0, "{p:?}");
        // An open plane, nobody near: all plausible.
        assert_eq!(p.plausible, 4);
    }

    #[test]
    fn the_driven_token_is_found_by_its_rank_in_the_region() {
        let liked: Vec<_> = [20, 28, 34, 42].iter().map(|&a| ((a, 31), 5.0 - a as f32 / 100.0)).collect();
        let logits = logits(&liked);
        let now = car(0.0, 0.0, 10.0).unwrap();
        let third = crate::policies::prior_sampling::top_tokens(&logits, 4)[2];
        let period = token_rollouts(&now, &[third]).remove(0);
        let region = |n| TrustRegion::TopN(n).tokens(&logits, &now);
        assert_eq!(rank_of_driven_token(&now, &period, &region(4)), Some(2));
        // Outside a region of two.
        assert_eq!(rank_of_driven_token(&now, &period, &region(2)), None);
    }

    #[test]
    fn neighbouring_bins_that_end_within_a_metre_are_one_behaviour() {
        // Two yaw-rate bins side by side at the same acceleration: 2 s at
        // 10 m/s with yaw rates one bin (0.05 rad/s) apart end ~0.5 m apart.
        let p = profile(&[((31, 31), 5.0), ((31, 32), 4.0)], 2);
        assert_eq!((p.yaw_rate_bins, p.behaviours), (2, 1));
        // A hard left beside them is another behaviour.
        let p = profile(&[((31, 31), 5.0), ((31, 32), 4.0), ((31, 62), 3.0)], 3);
        assert_eq!(p.behaviours, 2);
        // Two of three equal-ish logits: the mass of the top 2 is 2/3-ish.
        let p = profile(&[((31, 31), 0.0), ((31, 40), 0.0), ((31, 50), 0.0)], 2);
        assert!((p.probability_mass - 2.0 / 3.0).abs() < 1e-6, "{p:?}");
    }
}
