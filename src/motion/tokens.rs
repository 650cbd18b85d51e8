//! The motion-token vocabulary (**contract**): acceleration in [-5, 5] m/s²
//! and yaw rate in [-1.5, 1.5] rad/s, each cut into 63 uniform bins whose
//! centres include 0; token id = `i_a · 63 + i_ψ` (3969 tokens). A token is
//! held for one token period of 0.5 s (5 simulator steps of 0.1 s).

use super::kinematics::{
    HeldHeadingStepper, KinematicState, max_deviation_from_holding_m, step_to_heading, turned_headings,
};

/// Bins per axis.
pub const BINS_PER_AXIS: usize = 63;
/// Number of tokens, `63 · 63`.
pub const VOCABULARY_SIZE: usize = BINS_PER_AXIS * BINS_PER_AXIS;
/// Acceleration range, m/s² (symmetric).
pub const MAX_ACCEL_MPS2: f64 = 5.0;
/// Yaw-rate range, rad/s (symmetric).
pub const MAX_YAW_RATE_RADPS: f64 = 1.5;
/// Simulator step, seconds.
pub const SIM_DT_S: f64 = 0.1;
/// Simulator steps per token period.
pub const TOKEN_PERIOD_STEPS: usize = 5;
/// Token period, seconds.
pub const TOKEN_PERIOD_S: f64 = SIM_DT_S * TOKEN_PERIOD_STEPS as f64;

/// A control: longitudinal acceleration and yaw rate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Action {
    /// Acceleration along the heading, m/s².
    pub accel_mps2: f64,
    /// Yaw rate, rad/s (positive turns left).
    pub yaw_rate_radps: f64,
}

/// A token id in `0..3969`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
pub struct Token(pub u16);

impl Token {
    /// Acceleration bin index `i_a`.
    pub fn accel_bin(self) -> usize {
        self.0 as usize / BINS_PER_AXIS
    }
    /// Yaw-rate bin index `i_ψ`.
    pub fn yaw_rate_bin(self) -> usize {
        self.0 as usize % BINS_PER_AXIS
    }
    /// The token of bins `(i_a, i_ψ)`; `None` outside the grid.
    pub fn from_bins(accel_bin: usize, yaw_rate_bin: usize) -> Option<Token> {
        (accel_bin < BINS_PER_AXIS && yaw_rate_bin < BINS_PER_AXIS)
            .then(|| Token((accel_bin * BINS_PER_AXIS + yaw_rate_bin) as u16))
    }
}

/// The token grid: bin centres and the mapping between tokens and actions.
#[derive(Debug, Clone, Copy, Default)]
pub struct TokenGrid;

fn bin_width(max: f64) -> f64 {
    2.0 * max / BINS_PER_AXIS as f64
}

fn centre(bin: usize, max: f64) -> f64 {
    -max + (bin as f64 + 0.5) * bin_width(max)
}

fn nearest_bin(value: f64, max: f64) -> usize {
    (((value + max) / bin_width(max)).floor().max(0.0) as usize).min(BINS_PER_AXIS - 1)
}

/// The headings (each with its `sin_cos()`) of the simulator steps of one
/// token period.
type PeriodHeadings = [(f64, (f64, f64)); TOKEN_PERIOD_STEPS];

/// Heading sequences over a token period, by starting heading and
/// yaw-rate bin, kept for [`TokenGrid::rollout_ends_turning`]: the
/// sequence depends on nothing else, and sines and cosines are most of a
/// rollout's cost. Hashed with foldhash's fixed state: lookups are the
/// hot path, and nothing outside the program picks the keys.
#[derive(Debug, Default)]
pub struct TurnedHeadings(std::collections::HashMap<(u64, usize), PeriodHeadings, foldhash::fast::FixedState>);

impl TurnedHeadings {
    /// The headings from `heading_rad` under `yaw_rate_radps` (the centre
    /// of yaw-rate bin `bin`), worked out at the first asking.
    fn from(&mut self, heading_rad: f64, bin: usize, yaw_rate_radps: f64) -> PeriodHeadings {
        *self
            .0
            .entry((heading_rad.to_bits(), bin))
            .or_insert_with(|| turned_headings(heading_rad, yaw_rate_radps, SIM_DT_S))
    }
}

impl TokenGrid {
    /// Acceleration at the centre of bin `i`, m/s².
    pub fn accel_centre(i: usize) -> f64 {
        centre(i, MAX_ACCEL_MPS2)
    }

    /// Yaw rate at the centre of bin `i`, rad/s.
    pub fn yaw_rate_centre(i: usize) -> f64 {
        centre(i, MAX_YAW_RATE_RADPS)
    }

    /// The action a token stands for (its bin centres).
    pub fn action(token: Token) -> Action {
        Action {
            accel_mps2: Self::accel_centre(token.accel_bin()),
            yaw_rate_radps: Self::yaw_rate_centre(token.yaw_rate_bin()),
        }
    }

    /// The token whose bins contain `action` (values outside the ranges
    /// clamp to the edge bins).
    pub fn quantize(action: Action) -> Token {
        Token::from_bins(
            nearest_bin(action.accel_mps2, MAX_ACCEL_MPS2),
            nearest_bin(action.yaw_rate_radps, MAX_YAW_RATE_RADPS),
        )
        .expect("nearest_bin stays inside the grid")
    }

    /// The last states of [`Self::rollout_with_sin_cos`] from `state` under
    /// each of `tokens`, in order: the same states to the bit, with the
    /// headings (and their sines and cosines) of each yaw-rate bin worked
    /// out once. A heading sequence depends on the yaw rate alone, and a
    /// trust region's many accelerations share few yaw rates.
    pub fn rollout_ends(state: &KinematicState, tokens: &[Token]) -> Vec<(KinematicState, (f64, f64))> {
        Self::rollout_ends_turning(state, tokens, &mut TurnedHeadings::default())
    }

    /// [`Self::rollout_ends`], the heading sequences taken from `turned`
    /// where an earlier call worked them out from the same heading: the
    /// states of a search's beam often share one (the ends of tokens with
    /// the same yaw rate from one state).
    pub fn rollout_ends_turning(
        state: &KinematicState,
        tokens: &[Token],
        turned: &mut TurnedHeadings,
    ) -> Vec<(KinematicState, (f64, f64))> {
        let mut headings: [Option<PeriodHeadings>; BINS_PER_AXIS] = [None; BINS_PER_AXIS];
        tokens
            .iter()
            .map(|&token| {
                let action = Self::action(token);
                let period = headings[token.yaw_rate_bin()]
                    .get_or_insert_with(|| turned.from(state.heading_rad, token.yaw_rate_bin(), action.yaw_rate_radps));
                let mut s = *state;
                for &(heading_rad, sin_cos) in period.iter() {
                    s = step_to_heading(&s, action.accel_mps2, heading_rad, sin_cos, SIM_DT_S);
                }
                (s, period[TOKEN_PERIOD_STEPS - 1].1)
            })
            .collect()
    }

    /// [`Self::rollout_with_sin_cos`], the heading sequence taken from
    /// `turned` where an earlier call worked it out from the same heading
    /// and yaw rate (a scan of many tokens from one state): the same states
    /// to the bit.
    pub fn rollout_turning(
        state: &KinematicState,
        token: Token,
        turned: &mut TurnedHeadings,
    ) -> [(KinematicState, (f64, f64)); TOKEN_PERIOD_STEPS] {
        let action = Self::action(token);
        let period = turned.from(state.heading_rad, token.yaw_rate_bin(), action.yaw_rate_radps);
        let mut s = *state;
        period.map(|(heading_rad, sin_cos)| {
            s = step_to_heading(&s, action.accel_mps2, heading_rad, sin_cos, SIM_DT_S);
            (s, sin_cos)
        })
    }

    /// The largest acceleration and yaw rate, m/s² and rad/s, either way,
    /// among `tokens` (0 for none): what [`Self::rollout_end_reach`] needs
    /// of them.
    pub fn largest_action(tokens: &[Token]) -> (f64, f64) {
        tokens.iter().fold((0.0_f64, 0.0_f64), |(a, w), &t| {
            let action = Self::action(t);
            (a.max(action.accel_mps2.abs()), w.max(action.yaw_rate_radps.abs()))
        })
    }

    /// A disc holding where every rollout from `state` of the tokens whose
    /// [`Self::largest_action`] is `largest` ends: its centre where
    /// holding on at `state`'s speed and heading for the token period ends,
    /// its radius [`max_deviation_from_holding_m`] under that acceleration
    /// and yaw rate (and a micrometre for rounding), m. A search bounds all
    /// of a state's continuations by it before rolling any out.
    pub fn rollout_end_reach(state: &KinematicState, largest: (f64, f64)) -> (crate::geometry::Point2, f64) {
        const ROUNDING_M: f64 = 1e-6;
        let (sin, cos) = state.heading_rad.sin_cos();
        let held_m = state.speed_mps * SIM_DT_S * TOKEN_PERIOD_STEPS as f64;
        let centre = state.position + crate::geometry::Vector2::new(cos, sin) * held_m;
        let radius_m =
            max_deviation_from_holding_m(state.speed_mps, largest, SIM_DT_S, TOKEN_PERIOD_STEPS) + ROUNDING_M;
        (centre, radius_m)
    }

    /// Every token, in id order.
    pub fn all() -> impl Iterator<Item = Token> {
        (0..VOCABULARY_SIZE as u16).map(Token)
    }

    /// The range (largest less smallest bin centre) of acceleration, m/s²,
    /// and of yaw rate, rad/s, that `tokens` span: how much longitudinal
    /// and lateral choice a set of tokens offers (0 for none).
    pub fn ranges(tokens: &[Token]) -> (f64, f64) {
        if tokens.is_empty() {
            return (0.0, 0.0);
        }
        let range = |value: &dyn Fn(Action) -> f64| {
            let (lo, hi) = tokens
                .iter()
                .map(|&t| value(Self::action(t)))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
            hi - lo
        };
        (range(&|a| a.accel_mps2), range(&|a| a.yaw_rate_radps))
    }

    /// Whether holding `token` from `from` passes through `states`, the
    /// states after the period's first `states.len()` steps: positions
    /// within 1e-6 m, headings within 1e-9 rad, speeds within 1e-6 m/s.
    /// Heading and speed count because a standing car's position is the
    /// same under every yaw rate. How a rollout's token is read back.
    pub fn reproduces(from: &KinematicState, token: Token, states: &[crate::scenario::AgentState]) -> bool {
        Self::rollout(from, token).iter().zip(states).all(|(s, target)| {
            (s.position - target.position).norm() < 1e-6
                && crate::geometry::wrap_angle(s.heading_rad - target.heading_rad).abs() < 1e-9
                && (s.speed_mps - KinematicState::from_agent_state(target).speed_mps).abs() < 1e-6
        })
    }

    /// Holds `token` for one token period from `state`; returns the state
    /// after each of the 5 simulator steps.
    pub fn rollout(state: &KinematicState, token: Token) -> [KinematicState; TOKEN_PERIOD_STEPS] {
        Self::rollout_with_sin_cos(state, token).map(|(s, _)| s)
    }

    /// [`Self::rollout`], each state with its heading's `sin_cos()` (as
    /// [`step_with_sin_cos`](super::kinematics::step_with_sin_cos) works it out): for callers that need them
    /// again, to turn the states into agent states or boxes.
    pub fn rollout_with_sin_cos(
        state: &KinematicState,
        token: Token,
    ) -> [(KinematicState, (f64, f64)); TOKEN_PERIOD_STEPS] {
        let action = Self::action(token);
        let mut s = *state;
        // A token without yaw rate holds its heading: its sine and cosine
        // are worked out once.
        let mut stepper = HeldHeadingStepper::default();
        std::array::from_fn(|_| {
            let (next, sin_cos) = stepper.step(&s, action, SIM_DT_S);
            s = next;
            (s, sin_cos)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_centres_include_zero_and_span_the_ranges() {
        assert_eq!(VOCABULARY_SIZE, 3969);
        assert!(TokenGrid::accel_centre(31).abs() < 1e-12);
        assert!(TokenGrid::yaw_rate_centre(31).abs() < 1e-12);
        let w = 10.0 / 63.0;
        assert!((TokenGrid::accel_centre(0) - (-5.0 + w / 2.0)).abs() < 1e-12);
        assert!((TokenGrid::accel_centre(62) - (5.0 - w / 2.0)).abs() < 1e-12);
    }

    #[test]
    fn token_id_is_accel_major() {
        let t = Token::from_bins(2, 5).unwrap();
        assert_eq!(t.0, 2 * 63 + 5);
        assert_eq!((t.accel_bin(), t.yaw_rate_bin()), (2, 5));
        assert!(Token::from_bins(63, 0).is_none());
    }

    #[test]
    fn quantize_inverts_action_for_every_token() {
        for t in TokenGrid::all() {
            assert_eq!(TokenGrid::quantize(TokenGrid::action(t)), t);
        }
        // Out of range clamps to the edge bins.
        let t = TokenGrid::quantize(Action { accel_mps2: 9.0, yaw_rate_radps: -4.0 });
        assert_eq!((t.accel_bin(), t.yaw_rate_bin()), (62, 0));
        // The zero action is the centre token.
        assert_eq!(TokenGrid::quantize(Action::default()), Token(31 * 63 + 31));
    }

    #[test]
    fn every_rollout_ends_within_its_reach() {
        // Every token from standing, crawling, town and freeway speeds, and
        // the few tokens of a narrow region: each end inside the disc, and
        // the disc not much wider than the ends need (the widest token set
        // from 30 m/s reaches about 7 m off holding on).
        let narrow: Vec<Token> = [(-2.0, -0.1), (0.0, 0.0), (1.0, 0.05)]
            .map(|(accel_mps2, yaw_rate_radps)| TokenGrid::quantize(Action { accel_mps2, yaw_rate_radps }))
            .to_vec();
        let all: Vec<Token> = TokenGrid::all().collect();
        for tokens in [&all, &narrow] {
            for (heading_rad, speed_mps) in [(0.0, 0.0), (3.1, 0.4), (-1.2, 12.0), (2.0, 30.0)] {
                let state =
                    KinematicState { position: crate::geometry::Point2::new(310.0, -42.0), heading_rad, speed_mps };
                let (centre, radius_m) = TokenGrid::rollout_end_reach(&state, TokenGrid::largest_action(tokens));
                let farthest_m = tokens
                    .iter()
                    .map(|&t| (TokenGrid::rollout(&state, t)[TOKEN_PERIOD_STEPS - 1].position - centre).norm())
                    .fold(0.0, f64::max);
                assert!(farthest_m <= radius_m, "{state:?}: {farthest_m} beyond {radius_m}");
                assert!(radius_m < 2.0 * farthest_m + 0.1, "{state:?}: {radius_m} for {farthest_m}");
            }
        }
    }

    #[test]
    fn rollout_ends_are_the_rollouts_last_states_to_the_bit() {
        let tokens: Vec<Token> = TokenGrid::all().step_by(7).collect();
        // Fresh, and with the heading sequences of the states before (the
        // last state shares the first one's heading).
        let mut turned = TurnedHeadings::default();
        for (x, heading_rad, speed_mps) in [(0.0, 0.0, 12.0), (-40.0, 3.1, 0.4), (7.0, -1.2, 30.0), (5.0, 0.0, 3.0)] {
            let state = KinematicState { position: crate::geometry::Point2::new(x, 2.0), heading_rad, speed_mps };
            let ends = TokenGrid::rollout_ends(&state, &tokens);
            assert_eq!(ends, TokenGrid::rollout_ends_turning(&state, &tokens, &mut turned));
            for &t in &tokens {
                assert_eq!(
                    TokenGrid::rollout_turning(&state, t, &mut turned),
                    TokenGrid::rollout_with_sin_cos(&state, t)
                );
            }
            for (&t, (end, sin_cos)) in tokens.iter().zip(&ends) {
                let (last, last_sin_cos) = TokenGrid::rollout_with_sin_cos(&state, t)[TOKEN_PERIOD_STEPS - 1];
                assert_eq!(end.position.x.to_bits(), last.position.x.to_bits(), "{t:?}");
                assert_eq!(end.position.y.to_bits(), last.position.y.to_bits(), "{t:?}");
                assert_eq!(end.heading_rad.to_bits(), last.heading_rad.to_bits(), "{t:?}");
                assert_eq!(end.speed_mps.to_bits(), last.speed_mps.to_bits(), "{t:?}");
                assert_eq!(*sin_cos, last_sin_cos, "{t:?}");
            }
        }
    }
}
