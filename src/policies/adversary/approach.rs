//! The approach phase: for the first 1–4 token periods (drawn from the
//! seed, [`APPROACH_TOKENS`]) the prior drives the CBV, restricted to
//! plausible tokens, before the adversary engages; or none at all
//! ([`ApproachPhase::None`], the paper's protocol).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::background_forecast::BackgroundForecast;
use super::choice::Search;
use super::plausibility::{ContactRule, PlausibilityCheck};
use super::rollout::token_rollouts;
use crate::motion::tokens::Token;
use crate::policies::WorldView;
use crate::policies::prior_sampling::{TokenSampling, draw_seed, sample_token, top_tokens};
use crate::scenario::TrackIndex;

/// The approach phase: the prior drives the CBV for this many token
/// periods (drawn per seed, uniformly) before the adversary engages.
pub const APPROACH_TOKENS: std::ops::RangeInclusive<usize> = 1..=4;

/// Whether the prior drives the CBV for a while before the adversary
/// engages.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "kebab-case")]
pub enum ApproachPhase {
    /// [`APPROACH_TOKENS`] token periods, drawn from the variant's seed:
    /// with the background on log replay a strict arg min from the first
    /// token would give every seed the same variant, so each seed starts
    /// the attack from a different, realistic state.
    #[default]
    Seeded,
    /// None: the adversary chooses from the first token on, as in the
    /// paper. With the background on log replay every seed of a scene then
    /// gives the same variant.
    None,
}

impl ApproachPhase {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Seeded, Self::None];

    /// How many token periods the prior drives the CBV `cbv` of a rollout
    /// seeded `seed` before the adversary engages.
    pub fn tokens(self, seed: u64, cbv: TrackIndex) -> usize {
        match self {
            Self::Seeded => {
                let mut rng = ChaCha8Rng::seed_from_u64(draw_seed(seed, cbv.0, usize::MAX));
                rng.random_range(APPROACH_TOKENS)
            }
            Self::None => 0,
        }
    }
}

/// The approach phase's token for the CBV of the pair (CBV, ego): a draw
/// from the prior (`sampling`, with `rng`) among the plausible tokens of
/// its top k (the plausibility rule with `search`'s rules on driving
/// against the traffic and on turning); when none is, the fallbacks of the module's
/// plausibility rule; when nothing is plausible at all, a draw among the
/// top k's tokens within the tyres' grip, or the lower turning limit set
/// (among all of them where the CBV is absent).
pub(super) fn approach_draw(
    world: &WorldView<'_>,
    (cbv, ego): (TrackIndex, TrackIndex),
    logits: &[f32],
    sampling: TokenSampling,
    forecast: &BackgroundForecast<'_>,
    search: &Search,
    rng: &mut impl Rng,
) -> Token {
    let top = &top_tokens(logits, sampling.top_k.clamp(1, logits.len()))[..];
    let Some(cbv_now) = world.state(cbv) else { return sample_token(logits, sampling, rng) };
    let check = PlausibilityCheck::new(world, cbv, ego, forecast)
        .with_wrong_way(search.wrong_way)
        .with_turning_limit(search.turning);
    let rollouts = token_rollouts(cbv_now, top);
    // As in the adversary's choice: the plausible tokens of the top k,
    // else the likeliest plausible one of the vocabulary; under the strict
    // rule first, then counting only the CBV's own faults.
    for rule in [ContactRule::Any, ContactRule::AtFaultOnly] {
        let plausible: Vec<Token> =
            top.iter().zip(&rollouts).filter(|(_, r)| !check.implausible(r, rule)).map(|(t, _)| *t).collect();
        if !plausible.is_empty() {
            // Only the checked, plausible tokens keep their logits: a draw
            // from the top k of logits merely masked where implausible
            // would reach past the top k to tokens never checked.
            let mut masked = vec![f32::NEG_INFINITY; logits.len()];
            for t in &plausible {
                masked[t.0 as usize] = logits[t.0 as usize];
            }
            return sample_token(&masked, TokenSampling { top_k: plausible.len(), ..sampling }, rng);
        }
        if let Some(t) = check.likeliest_plausible_outside(logits, top, rule) {
            return t;
        }
    }
    // Nothing plausible: a draw from the top k (`sample_token` draws from
    // the same top k), kept within the tyres' grip or the lower turning
    // limit set. A draw beyond it is drawn again among the top k's tokens
    // within it, which makes the draw the prior's conditioned on the limit
    // (and leaves every draw within it as it was).
    let drawn = sample_token(logits, sampling, rng);
    let within: Vec<Token> =
        top.iter().zip(&rollouts).filter(|(_, r)| check.within_turning_limit(r)).map(|(t, _)| *t).collect();
    if within.contains(&drawn) {
        return drawn;
    }
    if within.is_empty() {
        return check.likeliest_within_turning_limit_outside(logits, top).unwrap_or(drawn);
    }
    let mut masked = vec![f32::NEG_INFINITY; logits.len()];
    for t in &within {
        masked[t.0 as usize] = logits[t.0 as usize];
    }
    sample_token(&masked, TokenSampling { top_k: within.len(), ..sampling }, rng)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::RoadMap;
    use crate::motion::tokens::MAX_ACCEL_MPS2;
    use crate::policies::adversary::TrustRegion;
    use crate::policies::adversary::test_support::{car, logits_liking, token};
    use crate::scenario::{AgentBody, AgentKind, AgentState};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// The approach draws of the CBV (index 1) against the ego (index 0),
    /// 4.5 × 2 m cars of `states` on an open plane, over seeds 0 to 31,
    /// the prior liking `liked` (token, logit) and nothing else, drawing
    /// from its top two.
    fn top_two_draws(states: &[Option<AgentState>], liked: &[(Token, f32)]) -> Vec<Token> {
        let map = RoadMap::default();
        let bodies = vec![AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 }; states.len()];
        let world = WorldView { map: &map, step: 10, bodies: &bodies, states };
        let logits = logits_liking(liked);
        let sampling = TokenSampling { top_k: 2, temperature: 1.0 };
        (0..32)
            .map(|seed| {
                approach_draw(
                    &world,
                    (TrackIndex(1), TrackIndex(0)),
                    &logits,
                    sampling,
                    &BackgroundForecast::default(),
                    &Search::one_step(TrustRegion::TopN(1)),
                    &mut ChaCha8Rng::seed_from_u64(seed),
                )
            })
            .collect()
    }

    #[test]
    fn the_approach_draws_only_among_the_checked_plausible_tokens_of_the_top_k() {
        // 25 m behind a stopped car at 15 m/s: of the top two, full
        // acceleration is implausible and full braking plausible; holding
        // speed (implausible too, ranked third and as likely as braking)
        // lies outside the top two and is never checked, so never drawn.
        let states = [car(0.0, 100.0, 10.0), car(0.0, 0.0, 15.0), car(30.0, 0.0, 0.0)];
        let liked = [(token(MAX_ACCEL_MPS2), 5.0), (token(-MAX_ACCEL_MPS2), 4.0), (token(0.0), 4.0 - 1e-6)];
        let draws = top_two_draws(&states, &liked);
        assert!(draws.iter().all(|&t| t == token(-MAX_ACCEL_MPS2)), "{draws:?}");
    }

    #[test]
    fn with_nothing_plausible_the_approach_draws_within_turning_limit() {
        // A stopped car 1 m ahead of the CBV at 15 m/s: every token runs
        // into it. Of the top two, the likelier turns hard (1.5 rad/s, 22
        // m/s² sideways): a draw from the top two as they are would take it
        // in about three draws of four; within grip, braking is left.
        let states = [car(0.0, 100.0, 10.0), car(0.0, 0.0, 15.0), car(5.5, 0.0, 0.0)];
        let turn = crate::motion::tokens::TokenGrid::quantize(crate::motion::Action {
            accel_mps2: -MAX_ACCEL_MPS2,
            yaw_rate_radps: 1.5,
        });
        let draws = top_two_draws(&states, &[(turn, 5.0), (token(-MAX_ACCEL_MPS2), 4.0)]);
        assert!(draws.iter().all(|&t| t == token(-MAX_ACCEL_MPS2)), "{draws:?}");
    }

    #[test]
    fn seeded_approach_phases_cover_the_range_and_depend_on_the_seed() {
        let lengths: Vec<usize> = (0..64).map(|seed| ApproachPhase::Seeded.tokens(seed, TrackIndex(3))).collect();
        assert!(lengths.iter().all(|n| APPROACH_TOKENS.contains(n)), "{lengths:?}");
        for n in APPROACH_TOKENS {
            assert!(lengths.contains(&n), "{n} never drawn in {lengths:?}");
        }
        // A pure function of the seed.
        assert_eq!(ApproachPhase::Seeded.tokens(5, TrackIndex(3)), ApproachPhase::Seeded.tokens(5, TrackIndex(3)));
    }

    #[test]
    fn without_an_approach_phase_the_adversary_engages_at_once() {
        assert!((0..64).all(|seed| ApproachPhase::None.tokens(seed, TrackIndex(3)) == 0));
    }
}
