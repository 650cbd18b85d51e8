//! How well the realism prior predicts recorded driving ([`PriorFit`]): at
//! every token boundary of every moving agent of a recorded scene, the
//! prior's distribution over the next token against the token the agent
//! applied (the log-to-token inversion's), as held-out negative
//! log-likelihood, top-1 accuracy and how often the recorded token is in
//! the top n (the trust region), with the top n's acceleration and
//! yaw-rate range; the same again over the samples whose recorded token
//! turns (yaw rate of at least [`TURNING_YAW_RATE_RADPS`] either way), the
//! tight urban turns a prior that only keeps its lane misses, and over the
//! turn onsets ([`begins_turn`]), with how many yaw-rate bins the top n
//! miss them by ([`TokenKindFit`]).
//!
//! The history the prior reads can be aligned two ways
//! ([`HistoryAlignment`]): ending at the boundary, as in closed loop, or one
//! step late, ending 0.1 s into the token to be predicted. A prior that
//! fits much better one step late has learned to read the start of the
//! answer from its input, which it never has in closed loop.

use crate::models::ModelError;
use crate::models::prior::RealismPrior;
use crate::models::prior_dataset::TokenizedScene;
use crate::models::prior_features::{MapTokens, QueryFeatures, StateHistory, build_query};
use crate::motion::Token;
use crate::motion::tokens::{TOKEN_PERIOD_STEPS, TokenGrid};
use crate::policies::prior_sampling::top_tokens;
use crate::scenario::{AgentKind, AgentState, Scenario};

/// Which states the prior's history holds at a token boundary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum HistoryAlignment {
    /// The history ends at the boundary: what the prior sees in closed loop.
    AtBoundary,
    /// The history ends one simulator step (0.1 s) into the token to be
    /// predicted: a probe of whether the prior reads the answer's start.
    OneStepLate,
}

/// The tokenized scene as a history seen one step late.
struct OneStepLate<'a>(&'a TokenizedScene);

impl StateHistory for OneStepLate<'_> {
    fn state(&self, step: usize, agent: usize) -> Option<AgentState> {
        self.0.state(step + 1, agent)
    }
    fn agents(&self) -> usize {
        self.0.agents()
    }
}

/// The yaw rate from which a recorded token counts as turning, rad/s
/// (a 20 m radius at 6 m/s).
pub const TURNING_YAW_RATE_RADPS: f64 = 0.3;

/// Sums over the samples of one or more scenes (add them with
/// `+`; the means are the sums over `samples`).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct PriorFit {
    /// Samples: (moving vehicle, token boundary) pairs with a recorded token.
    pub samples: usize,
    /// Sum of the negative log-likelihoods of the recorded tokens, nats.
    pub nll_sum: f64,
    /// Samples whose recorded token is the prior's most likely one.
    pub top1: usize,
    /// Samples whose recorded token is among the prior's top n.
    pub in_top_n: usize,
    /// Sum of the top n's acceleration ranges, m/s².
    pub accel_range_sum_mps2: f64,
    /// Sum of the top n's yaw-rate ranges, rad/s.
    pub yaw_rate_range_sum_radps: f64,
    /// The samples whose recorded token turns (see [`TURNING_YAW_RATE_RADPS`]).
    pub turning: TokenKindFit,
    /// The samples whose recorded token begins a turn (see [`begins_turn`]).
    pub turn_onset: TokenKindFit,
}

impl std::ops::Add for PriorFit {
    type Output = PriorFit;

    /// Both sums together.
    fn add(self, other: PriorFit) -> PriorFit {
        PriorFit {
            samples: self.samples + other.samples,
            nll_sum: self.nll_sum + other.nll_sum,
            top1: self.top1 + other.top1,
            in_top_n: self.in_top_n + other.in_top_n,
            accel_range_sum_mps2: self.accel_range_sum_mps2 + other.accel_range_sum_mps2,
            yaw_rate_range_sum_radps: self.yaw_rate_range_sum_radps + other.yaw_rate_range_sum_radps,
            turning: self.turning + other.turning,
            turn_onset: self.turn_onset + other.turn_onset,
        }
    }
}

impl PriorFit {
    /// Mean of a sum over the samples (`None` without samples).
    fn mean(&self, sum: f64) -> Option<f64> {
        per_sample(sum, self.samples)
    }

    /// Mean negative log-likelihood of the recorded token, nats.
    pub fn nll(&self) -> Option<f64> {
        self.mean(self.nll_sum)
    }

    /// Share of samples whose recorded token is the most likely one.
    pub fn top1_share(&self) -> Option<f64> {
        self.mean(self.top1 as f64)
    }

    /// Share of samples whose recorded token is among the top n.
    pub fn in_top_n_share(&self) -> Option<f64> {
        self.mean(self.in_top_n as f64)
    }

    /// Mean acceleration range of the top n, m/s².
    pub fn accel_range_mps2(&self) -> Option<f64> {
        self.mean(self.accel_range_sum_mps2)
    }

    /// Mean yaw-rate range of the top n, rad/s.
    pub fn yaw_rate_range_radps(&self) -> Option<f64> {
        self.mean(self.yaw_rate_range_sum_radps)
    }
}

/// Sums over the samples of one kind of recorded token (the turning ones,
/// the turn onsets): how likely the prior finds them and how far its
/// top n miss them laterally.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct TokenKindFit {
    /// Samples of this kind.
    pub samples: usize,
    /// Sum of their negative log-likelihoods, nats.
    pub nll_sum: f64,
    /// Those whose recorded token is among the prior's top n.
    pub in_top_n: usize,
    /// Sum of how far the top n's yaw rates fall short of the recorded
    /// one, in yaw-rate bins (see [`yaw_rate_miss_bins`]).
    pub yaw_rate_miss_bins_sum: f64,
    /// The samples counted by how far the top n miss them, in the buckets
    /// of [`YAW_RATE_MISS_BUCKETS`].
    pub yaw_rate_misses: [usize; YAW_RATE_MISS_BUCKETS.len()],
}

impl std::ops::Add for TokenKindFit {
    type Output = TokenKindFit;

    /// Both sums together.
    fn add(self, other: TokenKindFit) -> TokenKindFit {
        TokenKindFit {
            samples: self.samples + other.samples,
            nll_sum: self.nll_sum + other.nll_sum,
            in_top_n: self.in_top_n + other.in_top_n,
            yaw_rate_miss_bins_sum: self.yaw_rate_miss_bins_sum + other.yaw_rate_miss_bins_sum,
            yaw_rate_misses: std::array::from_fn(|i| self.yaw_rate_misses[i] + other.yaw_rate_misses[i]),
        }
    }
}

impl TokenKindFit {
    /// One sample: its negative log-likelihood, whether its token is in the
    /// top n, and by how many yaw-rate bins the top n miss it.
    pub fn one(nll: f64, in_top_n: bool, yaw_rate_miss_bins: usize) -> Self {
        let mut yaw_rate_misses = [0; YAW_RATE_MISS_BUCKETS.len()];
        yaw_rate_misses[yaw_rate_miss_bucket(yaw_rate_miss_bins)] = 1;
        Self {
            samples: 1,
            nll_sum: nll,
            in_top_n: usize::from(in_top_n),
            yaw_rate_miss_bins_sum: yaw_rate_miss_bins as f64,
            yaw_rate_misses,
        }
    }

    /// Mean negative log-likelihood, nats.
    pub fn nll(&self) -> Option<f64> {
        per_sample(self.nll_sum, self.samples)
    }

    /// Share among the top n.
    pub fn in_top_n_share(&self) -> Option<f64> {
        per_sample(self.in_top_n as f64, self.samples)
    }

    /// Mean of [`yaw_rate_miss_bins`]: whether the top n miss these tokens
    /// by a bin or two (the grid's resolution) or by many (the prior does
    /// not predict them).
    pub fn yaw_rate_miss_bins(&self) -> Option<f64> {
        per_sample(self.yaw_rate_miss_bins_sum, self.samples)
    }

    /// Shares in each bucket of [`YAW_RATE_MISS_BUCKETS`]: many small
    /// misses (a prior that turns too gently) or few large ones (turns it
    /// does not predict) give the same mean.
    pub fn yaw_rate_miss_shares(&self) -> Option<[f64; YAW_RATE_MISS_BUCKETS.len()]> {
        (self.samples > 0).then(|| self.yaw_rate_misses.map(|n| n as f64 / self.samples as f64))
    }
}

/// Buckets of [`yaw_rate_miss_bins`], as (label, fewest bins): none (a
/// token of the top n steers as the recorded one), one or two (the grid's
/// resolution: a turn slightly too gentle or too sharp), three to five,
/// and six or more (0.29 rad/s: the turn is not on offer at all).
pub const YAW_RATE_MISS_BUCKETS: [(&str, usize); 4] = [("0", 0), ("1-2", 1), ("3-5", 3), ("6+", 6)];

/// The bucket of [`YAW_RATE_MISS_BUCKETS`] that a miss of `bins` falls in.
pub fn yaw_rate_miss_bucket(bins: usize) -> usize {
    YAW_RATE_MISS_BUCKETS.iter().rposition(|&(_, fewest)| bins >= fewest).unwrap_or(0)
}

/// How many yaw-rate bins separate `recorded` from the nearest yaw-rate bin
/// among `top`: 0 when a token of `top` steers as it does, whatever its
/// acceleration.
pub fn yaw_rate_miss_bins(top: &[Token], recorded: Token) -> usize {
    let bin = recorded.yaw_rate_bin();
    top.iter().map(|t| t.yaw_rate_bin().abs_diff(bin)).min().unwrap_or(0)
}

/// `sum` over `samples` samples, per sample (`None` without samples).
fn per_sample(sum: f64, samples: usize) -> Option<f64> {
    (samples > 0).then(|| sum / samples as f64)
}

/// Whether `token` turns: its yaw rate is at least
/// [`TURNING_YAW_RATE_RADPS`] either way.
pub fn is_turning(token: Token) -> bool {
    TokenGrid::yaw_rate_centre(token.yaw_rate_bin()).abs() >= TURNING_YAW_RATE_RADPS
}

/// Whether `token` begins a turn: it turns (see [`is_turning`]) and
/// `before`, the token applied in the period before it, does not. The
/// history the prior reads then shows no turn yet: what it predicts there
/// is whether a turn starts, not how one goes on.
pub fn begins_turn(before: Token, token: Token) -> bool {
    is_turning(token) && !is_turning(before)
}

/// The negative log-likelihood (nats) of `token` under the softmax of
/// `logits`.
pub fn token_nll(logits: &[f32], token: Token) -> f64 {
    let max = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64;
    let log_sum = max + logits.iter().map(|&x| (x as f64 - max).exp()).sum::<f64>().ln();
    log_sum - logits[token.0 as usize] as f64
}

/// The prior's fit on `scenario`, once for each of `alignments` (in
/// their order): every vehicle moving faster than `min_speed_mps` at a
/// token boundary where the inversion gives its next token (and, so that
/// every alignment scores the same samples, whose state one step later is
/// known); `top_n` is the trust region's size. The scene is tokenized and
/// its map encoded once for all the alignments.
pub fn prior_fit(
    prior: &RealismPrior,
    scenario: &Scenario,
    alignments: &[HistoryAlignment],
    top_n: usize,
    min_speed_mps: f64,
) -> Result<Vec<PriorFit>, ModelError> {
    let scene = TokenizedScene::new(scenario);
    let boundaries: Vec<(usize, usize)> = scene
        .labelled_boundaries()
        .into_iter()
        .filter(|&(step, agent)| {
            scene.bodies[agent].kind == AgentKind::Vehicle
                && scene.state(step, agent).is_some_and(|s| s.speed_mps() > min_speed_mps)
                && scene.state(step + 1, agent).is_some()
        })
        .collect();
    if boundaries.is_empty() {
        return Ok(vec![PriorFit::default(); alignments.len()]);
    }
    let map = MapTokens::build(&scenario.map);
    let embedding = prior.encode_map(&map)?;
    let late = OneStepLate(&scene);
    alignments
        .iter()
        .map(|alignment| {
            let history: &dyn StateHistory = match alignment {
                HistoryAlignment::AtBoundary => &scene,
                HistoryAlignment::OneStepLate => &late,
            };
            let samples: Vec<(QueryFeatures, Token, Option<Token>)> = boundaries
                .iter()
                .filter_map(|&(step, agent)| {
                    let query = build_query(history, &scene.bodies, &map, &scenario.map, agent, step)?;
                    let before = step.checked_sub(TOKEN_PERIOD_STEPS).and_then(|s| scene.labels.get(&(agent, s)));
                    Some((query, scene.labels[&(agent, step)], before.copied()))
                })
                .collect();
            let queries: Vec<&QueryFeatures> = samples.iter().map(|(q, _, _)| q).collect();
            let logits = prior.logits(&queries, &embedding)?;
            Ok(samples.iter().zip(&logits).fold(PriorFit::default(), |fit, ((_, recorded, before), logits)| {
                let top = top_tokens(logits, top_n);
                let (accel_range_mps2, yaw_rate_range_radps) = TokenGrid::ranges(&top);
                let nll = token_nll(logits, *recorded);
                let in_top_n = top.contains(recorded);
                let this_sample = TokenKindFit::one(nll, in_top_n, yaw_rate_miss_bins(&top, *recorded));
                let kind_fit = |is_kind: bool| if is_kind { this_sample } else { TokenKindFit::default() };
                fit + PriorFit {
                    samples: 1,
                    nll_sum: nll,
                    top1: usize::from(top.first() == Some(recorded)),
                    in_top_n: usize::from(in_top_n),
                    accel_range_sum_mps2: accel_range_mps2,
                    yaw_rate_range_sum_radps: yaw_rate_range_radps,
                    turning: kind_fit(is_turning(*recorded)),
                    turn_onset: kind_fit(before.is_some_and(|b| begins_turn(b, *recorded))),
                }
            }))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_nll_of_a_token_is_minus_its_log_softmax() {
        // Uniform over four: ln 4 each.
        assert!((token_nll(&[0.0; 4], Token(2)) - 4f64.ln()).abs() < 1e-12);
        // Shifting every logit changes nothing; a likelier token costs less.
        let logits = [1.0f32, 3.0, 0.5, -2.0];
        let shifted: Vec<f32> = logits.iter().map(|x| x + 100.0).collect();
        assert!((token_nll(&logits, Token(1)) - token_nll(&shifted, Token(1))).abs() < 1e-4);
        assert!(token_nll(&logits, Token(1)) < token_nll(&logits, Token(0)));
        let p1 = (3.0f64).exp() / logits.iter().map(|&x| (x as f64).exp()).sum::<f64>();
        assert!((token_nll(&logits, Token(1)) + p1.ln()).abs() < 1e-9);
    }

    #[test]
    fn sums_add_and_means_divide_by_the_samples() {
        let a = PriorFit {
            samples: 2,
            nll_sum: 3.0,
            top1: 1,
            in_top_n: 2,
            accel_range_sum_mps2: 4.0,
            yaw_rate_range_sum_radps: 0.2,
            turning: TokenKindFit::one(2.5, false, 6),
            turn_onset: TokenKindFit::default(),
        };
        let both = a + PriorFit {
            samples: 2,
            nll_sum: 1.0,
            top1: 0,
            in_top_n: 1,
            turning: TokenKindFit::one(1.5, true, 0),
            turn_onset: TokenKindFit::one(4.0, false, 2),
            ..PriorFit::default()
        };
        assert_eq!(both.samples, 4);
        assert_eq!(both.nll(), Some(1.0));
        assert_eq!(both.top1_share(), Some(0.25));
        assert_eq!(both.in_top_n_share(), Some(0.75));
        assert_eq!(both.accel_range_mps2(), Some(1.0));
        assert_eq!(PriorFit::default().nll(), None);
        assert_eq!(both.turning.nll(), Some(2.0));
        assert_eq!(both.turning.in_top_n_share(), Some(0.5));
        assert_eq!(both.turning.yaw_rate_miss_bins(), Some(3.0));
        assert_eq!(both.turning.yaw_rate_miss_shares(), Some([0.5, 0.0, 0.0, 0.5]));
        assert_eq!(both.turn_onset.samples, 1);
        assert_eq!(both.turn_onset.yaw_rate_miss_shares(), Some([0.0, 1.0, 0.0, 0.0]));
        let none = TokenKindFit::default();
        assert_eq!((none.nll(), none.in_top_n_share(), none.yaw_rate_miss_bins()), (None, None, None));
        assert_eq!(none.yaw_rate_miss_shares(), None);
    }

    #[test]
    fn a_turn_begins_where_a_turning_token_follows_one_that_does_not_turn() {
        use crate::motion::tokens::BINS_PER_AXIS;
        let t = |yaw| Token::from_bins(31, yaw).unwrap();
        let centre = BINS_PER_AXIS / 2;
        let first_turning = (centre..BINS_PER_AXIS).find(|&y| is_turning(t(y))).unwrap();
        assert!(begins_turn(t(centre), t(first_turning)), "straight on, then a left turn");
        assert!(begins_turn(t(first_turning - 1), t(BINS_PER_AXIS - 1)), "from just under the threshold");
        assert!(begins_turn(t(centre), t(2 * centre - first_turning)), "a right turn");
        assert!(!begins_turn(t(first_turning), t(first_turning + 2)), "a turn going on");
        assert!(!begins_turn(t(centre), t(first_turning - 1)), "a bend under the threshold");
        assert!(!begins_turn(t(first_turning), t(centre)), "a turn ending");
    }

    #[test]
    fn a_miss_falls_in_the_bucket_of_the_most_bins_it_reaches() {
        let buckets: Vec<usize> = (0..9).map(yaw_rate_miss_bucket).collect();
        assert_eq!(buckets, [0, 1, 1, 2, 2, 2, 3, 3, 3]);
        assert_eq!(yaw_rate_miss_bucket(62), YAW_RATE_MISS_BUCKETS.len() - 1);
    }

    #[test]
    fn a_turn_is_missed_by_the_yaw_rate_bins_to_the_nearest_token_whatever_its_acceleration() {
        let t = |accel, yaw| Token::from_bins(accel, yaw).unwrap();
        let top = [t(30, 31), t(20, 33), t(40, 29)];
        // A token of the top n steering as the recorded one does, at another acceleration: no miss.
        assert_eq!(yaw_rate_miss_bins(&top, t(10, 33)), 0);
        // Seven bins right of the nearest (29), four left of it (33).
        assert_eq!(yaw_rate_miss_bins(&top, t(31, 22)), 7);
        assert_eq!(yaw_rate_miss_bins(&top, t(31, 37)), 4);
        assert_eq!(yaw_rate_miss_bins(&[], t(31, 37)), 0);
    }

    #[test]
    fn a_token_turns_from_the_threshold_yaw_rate_either_way() {
        use crate::motion::tokens::BINS_PER_AXIS;
        let centre = BINS_PER_AXIS / 2;
        assert!(!is_turning(Token::from_bins(centre, centre).unwrap()), "zero yaw rate");
        let turning: Vec<usize> =
            (0..BINS_PER_AXIS).filter(|&y| is_turning(Token::from_bins(centre, y).unwrap())).collect();
        // Both ends of the grid turn, symmetrically, and every bin that
        // turns is at or past the threshold.
        assert!(turning.contains(&0) && turning.contains(&(BINS_PER_AXIS - 1)), "{turning:?}");
        assert_eq!(turning.iter().filter(|&&y| y < centre).count(), turning.iter().filter(|&&y| y > centre).count());
        for y in turning {
            assert!(TokenGrid::yaw_rate_centre(y).abs() >= TURNING_YAW_RATE_RADPS);
        }
    }

    #[test]
    fn a_prior_fit_scores_the_moving_vehicles_of_a_recorded_scene() {
        use crate::models::ModelSource;
        use crate::models::prior::PriorVariant;
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/ngsim/USA_US101-15_1_T-1.xml");
        let scenario = crate::scenario::import::load(&path).unwrap().remove(0);
        let prior = RealismPrior::load(&ModelSource::Embedded, PriorVariant::Differential).unwrap();
        let both = [HistoryAlignment::AtBoundary, HistoryAlignment::OneStepLate];
        let [at, late] = prior_fit(&prior, &scenario, &both, 20, 1.0).unwrap()[..] else { panic!("two fits") };
        // The same samples either way, and a real distribution: better
        // than uniform (ln 3969 = 8.29 nats), ranges inside the grid.
        assert!(at.samples > 20, "{at:?}");
        assert_eq!(at.samples, late.samples);
        for fit in [at, late] {
            assert!(fit.nll().unwrap() < 8.29, "{fit:?}");
            assert!(fit.in_top_n >= fit.top1);
            assert!((0.0..=10.0).contains(&fit.accel_range_mps2().unwrap()), "{fit:?}");
            assert!((0.0..=3.0).contains(&fit.yaw_rate_range_radps().unwrap()), "{fit:?}");
        }
        // Nothing moving, nothing scored.
        let none = prior_fit(&prior, &scenario, &both, 20, 1e9).unwrap();
        assert_eq!(none, vec![PriorFit::default(); 2]);
        // One alignment alone is that alignment's fit.
        assert_eq!(prior_fit(&prior, &scenario, &both[1..], 20, 1.0).unwrap(), vec![late]);
    }
}
