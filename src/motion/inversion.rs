//! Log-to-token inversion: turns a recorded track into motion tokens by
//! choosing, per token period, the token whose 0.5 s rollout best matches
//! the log, starting from the *reconstructed* state so that drift is
//! corrected period by period instead of accumulating.
//!
//! The search is coordinate descent on the grid rather than all 3969
//! tokens: the best acceleration bin with the log's yaw rate, then the best
//! yaw-rate bin with that acceleration, then joint ±2-bin refinement until no
//! neighbour improves (≈ 200 rollouts a period instead of 3969). The cost it
//! minimises and its weights are below; the resulting round-trip error is
//! measured over all shared scenes (`safer token-roundtrip`).

use crate::geometry::wrap_angle;
use crate::scenario::{AgentState, Track};

use super::kinematics::KinematicState;
use super::tokens::{Action, BINS_PER_AXIS, TOKEN_PERIOD_S, TOKEN_PERIOD_STEPS, Token, TokenGrid};

/// A run of tokens over consecutive token periods, starting from a logged state.
#[derive(Debug, Clone, PartialEq)]
pub struct TokenSegment {
    /// Step of the initial state (a token-period boundary).
    pub start_step: usize,
    /// The logged state the rollout starts from.
    pub initial: KinematicState,
    /// One token per period, in order.
    pub tokens: Vec<Token>,
}

impl TokenSegment {
    /// The reconstructed states at steps `start_step + 1 ..= start_step + 5·len`.
    pub fn rollout(&self) -> Vec<KinematicState> {
        let mut out = Vec::with_capacity(self.tokens.len() * TOKEN_PERIOD_STEPS);
        let mut s = self.initial;
        for &t in &self.tokens {
            let period = TokenGrid::rollout(&s, t);
            out.extend_from_slice(&period);
            s = period[TOKEN_PERIOD_STEPS - 1];
        }
        out
    }
}

/// A track as token segments; gaps in the log split segments.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TokenizedTrack {
    /// Segments in time order.
    pub segments: Vec<TokenSegment>,
}

/// Per-step position error of a reconstruction against the log.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RoundTripError {
    /// Sum of displacement over compared steps, metres.
    pub displacement_sum_m: f64,
    /// Number of compared steps.
    pub steps: usize,
    /// Sum of final-step displacement over segments, metres.
    pub final_displacement_sum_m: f64,
    /// Number of segments.
    pub segments: usize,
    /// Largest displacement seen, metres.
    pub max_displacement_m: f64,
}

impl RoundTripError {
    /// Average displacement error, metres.
    pub fn ade_m(&self) -> f64 {
        self.displacement_sum_m / self.steps.max(1) as f64
    }
    /// Final displacement error, averaged over segments, metres.
    pub fn fde_m(&self) -> f64 {
        self.final_displacement_sum_m / self.segments.max(1) as f64
    }
    /// Adds another tally.
    pub fn merge(&mut self, o: &RoundTripError) {
        self.displacement_sum_m += o.displacement_sum_m;
        self.steps += o.steps;
        self.final_displacement_sum_m += o.final_displacement_sum_m;
        self.segments += o.segments;
        self.max_displacement_m = self.max_displacement_m.max(o.max_displacement_m);
    }
}

/// Heading error is weighed as the displacement of a point 2 m from the box
/// centre (about half a car length), so a heading error costs what the
/// corner of the car would be off by.
const HEADING_LEVER_M: f64 = 2.0;

/// Cost of one period's rollout against the log: squared position error at
/// every logged step, the last step counted twice (it seeds the next
/// period), plus heading and speed errors at the end converted to metres.
fn period_cost(rollout: &[KinematicState; TOKEN_PERIOD_STEPS], log: &[Option<&AgentState>]) -> f64 {
    let mut cost = 0.0;
    for (s, l) in rollout.iter().zip(log) {
        if let Some(l) = l {
            cost += (s.position - l.position).norm_squared();
        }
    }
    if let Some(Some(end)) = log.last() {
        let s = &rollout[TOKEN_PERIOD_STEPS - 1];
        let target = KinematicState::from_agent_state(end);
        cost += (s.position - end.position).norm_squared();
        cost += (HEADING_LEVER_M * wrap_angle(s.heading_rad - end.heading_rad)).powi(2);
        cost += (TOKEN_PERIOD_S * (s.speed_mps - target.speed_mps)).powi(2);
    }
    cost
}

/// The token that best reproduces `log` (the 5 logged states after `from`).
pub fn best_token(from: &KinematicState, log: &[Option<&AgentState>]) -> Token {
    let Some(Some(end)) = log.last() else { return TokenGrid::quantize(Action::default()) };
    let target = KinematicState::from_agent_state(end);
    let guess = TokenGrid::quantize(Action {
        accel_mps2: (target.speed_mps - from.speed_mps) / TOKEN_PERIOD_S,
        yaw_rate_radps: wrap_angle(target.heading_rad - from.heading_rad) / TOKEN_PERIOD_S,
    });
    let cost = |ia: usize, ip: usize| {
        let t = Token::from_bins(ia, ip).expect("bins in range");
        period_cost(&TokenGrid::rollout(from, t), log)
    };
    let (mut ia, mut ip) = (guess.accel_bin(), guess.yaw_rate_bin());
    let mut best = cost(ia, ip);
    // Ties keep the lower bin index, so the result is deterministic.
    let line_search = |fixed_is_accel: bool, ia: &mut usize, ip: &mut usize, best: &mut f64| {
        for k in 0..BINS_PER_AXIS {
            let (a, p) = if fixed_is_accel { (*ia, k) } else { (k, *ip) };
            let c = cost(a, p);
            if c < *best {
                *best = c;
                (*ia, *ip) = (a, p);
            }
        }
    };
    line_search(false, &mut ia, &mut ip, &mut best);
    line_search(true, &mut ia, &mut ip, &mut best);
    for _ in 0..4 {
        let (mut na, mut np) = (ia, ip);
        for da in -2i32..=2 {
            for dp in -2i32..=2 {
                let (a, p) = (ia as i32 + da, ip as i32 + dp);
                if a < 0 || p < 0 || a >= BINS_PER_AXIS as i32 || p >= BINS_PER_AXIS as i32 {
                    continue;
                }
                let c = cost(a as usize, p as usize);
                if c < best {
                    best = c;
                    (na, np) = (a as usize, p as usize);
                }
            }
        }
        if (na, np) == (ia, ip) {
            break;
        }
        (ia, ip) = (na, np);
    }
    Token::from_bins(ia, ip).expect("bins in range")
}

/// Tokenizes `track` on token periods aligned to `anchor_step` (periods
/// start at `anchor_step + 5k`, k may be negative). A period is tokenized
/// when the log is valid at its start and end; a gap ends the segment, and
/// the next one restarts from the logged state.
pub fn tokenize_track(track: &Track, anchor_step: usize) -> TokenizedTrack {
    tokenize_track_drifting(track, anchor_step, &mut |t| t).0
}

/// [`tokenize_track`] whose rollout applies `drift(best)` in place of each
/// period's best token, so the reconstructed states wander off the log the
/// way a closed-loop rollout does and the following periods' best tokens
/// steer back. Returns the track of applied tokens and, per segment, the
/// best (intended) token of each period.
pub fn tokenize_track_drifting(
    track: &Track,
    anchor_step: usize,
    drift: &mut dyn FnMut(Token) -> Token,
) -> (TokenizedTrack, Vec<Vec<Token>>) {
    let n = track.states.len();
    let mut segments = Vec::new();
    let mut intended = Vec::new();
    let mut current: Option<(TokenSegment, KinematicState, Vec<Token>)> = None;
    let mut b = anchor_step % TOKEN_PERIOD_STEPS;
    while b + TOKEN_PERIOD_STEPS < n {
        let end = b + TOKEN_PERIOD_STEPS;
        let usable = track.state(b).is_some() && track.state(end).is_some();
        if !usable {
            if let Some((seg, _, best)) = current.take() {
                segments.push(seg);
                intended.push(best);
            }
        } else {
            let (seg, from, best) = current.get_or_insert_with(|| {
                let initial = KinematicState::from_agent_state(track.state(b).expect("checked valid"));
                (TokenSegment { start_step: b, initial, tokens: Vec::new() }, initial, Vec::new())
            });
            let log: Vec<Option<&AgentState>> = (b + 1..=end).map(|k| track.state(k)).collect();
            let token = best_token(from, &log);
            let applied = drift(token);
            *from = TokenGrid::rollout(from, applied)[TOKEN_PERIOD_STEPS - 1];
            seg.tokens.push(applied);
            best.push(token);
        }
        b = end;
    }
    if let Some((seg, _, best)) = current {
        segments.push(seg);
        intended.push(best);
    }
    (TokenizedTrack { segments }, intended)
}

/// Round-trip error of `tokenized` against the log of `track`.
pub fn round_trip_error(track: &Track, tokenized: &TokenizedTrack) -> RoundTripError {
    let mut e = RoundTripError::default();
    for seg in &tokenized.segments {
        let states = seg.rollout();
        let mut last = None;
        for (i, s) in states.iter().enumerate() {
            if let Some(l) = track.state(seg.start_step + 1 + i) {
                let d = (s.position - l.position).norm();
                e.displacement_sum_m += d;
                e.steps += 1;
                e.max_displacement_m = e.max_displacement_m.max(d);
                last = Some(d);
            }
        }
        if let Some(d) = last {
            e.final_displacement_sum_m += d;
            e.segments += 1;
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point2;
    use crate::scenario::{AgentId, AgentKind};

    /// A track generated by the kinematic model itself from known tokens.
    fn synthetic_track(tokens: &[Token]) -> Track {
        let mut s = KinematicState { position: Point2::new(5.0, -3.0), heading_rad: 0.3, speed_mps: 8.0 };
        let mut states = vec![Some(s.to_agent_state())];
        for &t in tokens {
            for k in TokenGrid::rollout(&s, t) {
                states.push(Some(k.to_agent_state()));
            }
            s = TokenGrid::rollout(&s, t)[TOKEN_PERIOD_STEPS - 1];
        }
        Track { id: AgentId("1".into()), kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0, states }
    }

    #[test]
    fn tokens_of_a_model_generated_track_are_recovered_exactly() {
        let tokens: Vec<Token> = [(31, 31), (40, 31), (40, 35), (20, 25), (31, 50), (10, 31)]
            .map(|(a, p)| Token::from_bins(a, p).unwrap())
            .into();
        let track = synthetic_track(&tokens);
        let tokenized = tokenize_track(&track, 0);
        assert_eq!(tokenized.segments.len(), 1);
        assert_eq!(tokenized.segments[0].tokens, tokens);
        let err = round_trip_error(&track, &tokenized);
        assert!(err.max_displacement_m < 1e-9, "{err:?}");
        assert_eq!(err.steps, tokens.len() * TOKEN_PERIOD_STEPS);
    }

    #[test]
    fn gaps_split_segments_and_anchor_aligns_periods() {
        let tokens = vec![Token::from_bins(31, 31).unwrap(); 6];
        let mut track = synthetic_track(&tokens);
        track.states[12] = None; // inside period [10, 15] (anchor 0) only
        let tk = tokenize_track(&track, 0);
        // Period [10,15] has valid ends, so it stays; the gap step is just not compared.
        assert_eq!(tk.segments.len(), 1);
        track.states[15] = None; // now periods [10,15] and [15,20] are unusable
        let tk = tokenize_track(&track, 0);
        assert_eq!(tk.segments.len(), 2);
        assert_eq!(tk.segments[1].start_step, 20);
        // Anchor 2: periods start at 2, 7, 12, ...
        let tk = tokenize_track(&synthetic_track(&tokens), 12);
        assert_eq!(tk.segments[0].start_step, 2);
    }
}
