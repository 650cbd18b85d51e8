//! The lookahead's continuations one token on ([`Continuations`]): where
//! each leaves the CBV, and its box distance to the ego and its objective
//! there, worked out exactly only when the search needs them.
//!
//! A beam as wide as the trust region makes its width squared children a
//! depth (3 600 over 60 behaviours), and the search keeps the beam's
//! width of them and the few that lower a first token's loss. Every child
//! gets cheap lower bounds from the separating axes; the exact box
//! distances (the costly part) are asked only where a bound could still
//! put a child among those, and [`Continuations::next_in_order`] hands
//! out the children in exactly the order a full sort by exact score would:
//! the same search, bit for bit, at a fraction of the cost.

use std::cell::Cell;
use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

use super::in_path::path_sweep;
use super::objective::Objective;
use super::turning_limit::{CbvTurningLimit, first_beyond};
use crate::geometry::OrientedBox;
use crate::motion::KinematicState;
use crate::motion::tokens::{Token, TokenGrid, TurnedHeadings};
use crate::scenario::{AgentBody, AgentState};

/// One continuation one token on: which first token it extends, from
/// which member of the beam, with which token, where the CBV is at its
/// end; lower bounds of its box distance to the ego's prediction there
/// and of its objective, and the exact ones once asked for.
pub(super) struct Child {
    /// The first token it extends (its index in the trust region).
    pub(super) root: usize,
    /// Its parent's place in the beam.
    pub(super) parent: usize,
    /// The token it adds.
    pub(super) token: Token,
    /// Where the CBV is at its start (its parent's end).
    pub(super) from: KinematicState,
    /// Where the CBV is at its end.
    pub(super) state: KinematicState,
    /// `state` as an agent state.
    pub(super) at: AgentState,
    distance_lower_bound_m: f64,
    score_lower_bound_m: f64,
    distance_m: Cell<Option<f64>>,
    score_m: Cell<Option<f64>>,
}

impl Child {
    /// Whether its token turns the CBV harder than `limit` on the way (see
    /// the `grip` module): the step states are rolled out again, as only
    /// the few children the search judges are asked.
    pub(super) fn beyond(&self, limit: CbvTurningLimit) -> bool {
        let states: Vec<AgentState> =
            TokenGrid::rollout(&self.from, self.token).iter().map(KinematicState::to_agent_state).collect();
        first_beyond(&self.from.to_agent_state(), &states, limit).is_some()
    }
}

/// The children of a beam at one depth, against the ego's
/// constant-velocity prediction at that depth.
pub(super) struct Continuations {
    children: Vec<Child>,
    ego: AgentState,
    ego_box: OrientedBox,
    ego_sin_cos: (f64, f64),
    ego_body: AgentBody,
    cbv_body: AgentBody,
    objective: Objective,
    /// The children not yet handed out by [`Self::next_in_order`], keyed
    /// by exact score or by lower bound (built on first use).
    ranking: Option<BinaryHeap<Reverse<Ranked>>>,
}

/// A child's place in the ranking: by score (exact, or a lower bound still
/// to be made exact), then the likelier first token, then the order the
/// children were made in.
#[derive(Debug, Clone, Copy)]
struct Ranked {
    score_m: f64,
    root: usize,
    index: usize,
    exact: bool,
}

impl Ord for Ranked {
    fn cmp(&self, other: &Self) -> Ordering {
        self.score_m.total_cmp(&other.score_m).then(self.root.cmp(&other.root)).then(self.index.cmp(&other.index))
    }
}

impl PartialOrd for Ranked {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl PartialEq for Ranked {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Ranked {}

impl Continuations {
    /// Every continuation of each `(parent, (root, state))` of the beam
    /// (`parent` its place in the beam) by each of `tokens`, beam member
    /// first, against the ego at `ego` (its constant-velocity prediction at
    /// the children's end). A caller may leave out members whose
    /// continuations cannot count: the rest keep their order.
    pub(super) fn new(
        beam: impl Iterator<Item = (usize, (usize, KinematicState))>,
        tokens: &[Token],
        ego: AgentState,
        (ego_body, cbv_body): (AgentBody, AgentBody),
        objective: Objective,
    ) -> Self {
        let ego_box = ego_body.footprint(&ego);
        let ego_sin_cos = ego.heading_rad.sin_cos();
        let mut children = Vec::with_capacity(beam.size_hint().0 * tokens.len());
        let mut turned = TurnedHeadings::default();
        for (parent, (root, from)) in beam {
            for (&token, (state, sin_cos)) in
                tokens.iter().zip(TokenGrid::rollout_ends_turning(&from, tokens, &mut turned))
            {
                let at = state.to_agent_state_with_sin_cos(sin_cos);
                // One sweep bounds both: at lead 0 it is the distance's.
                let sweep = path_sweep((&ego, ego_sin_cos), ego_body, (&at, sin_cos), cbv_body);
                let distance_lower_bound_m = sweep.lower_bound_m(0.0);
                let score_lower_bound_m = objective.loss_lower_bound((&ego, ego_sin_cos), ego_body, &at, &sweep);
                children.push(Child {
                    root,
                    parent,
                    token,
                    from,
                    state,
                    at,
                    distance_lower_bound_m,
                    score_lower_bound_m,
                    distance_m: Cell::new(None),
                    score_m: Cell::new(None),
                });
            }
        }
        Self { children, ego, ego_box, ego_sin_cos, ego_body, cbv_body, objective, ranking: None }
    }

    /// How many children there are.
    pub(super) fn len(&self) -> usize {
        self.children.len()
    }

    /// Child `i`.
    pub(super) fn child(&self, i: usize) -> &Child {
        &self.children[i]
    }

    /// Child `i`'s box distance to the ego's prediction, m.
    pub(super) fn distance_m(&self, i: usize) -> f64 {
        let c = &self.children[i];
        if let Some(distance_m) = c.distance_m.get() {
            return distance_m;
        }
        let distance_m = self.ego_box.distance_with_sin_cos(&self.cbv_body.footprint(&c.at), self.ego_sin_cos);
        c.distance_m.set(Some(distance_m));
        distance_m
    }

    /// Whether child `i` is clear of the ego (box distance above 0; a
    /// contact ends a continuation).
    fn clear(&self, i: usize) -> bool {
        self.children[i].distance_lower_bound_m > 0.0 || self.distance_m(i) > 0.0
    }

    /// Child `i`'s objective, m (worked out once: [`Self::score_unless`]
    /// keeps every exact score).
    pub(super) fn score_m(&self, i: usize) -> f64 {
        self.score_unless(i, |_| false)
    }

    /// Child `i`'s objective, `settled` and the answer as in
    /// [`Objective::loss_unless`] (here a settled answer may be the lower
    /// bound, below the exact objective).
    pub(super) fn score_unless(&self, i: usize, settled: impl Fn(f64) -> bool) -> f64 {
        let c = &self.children[i];
        if let Some(score) = c.score_m.get() {
            return score;
        }
        if !c.score_lower_bound_m.is_nan() && settled(c.score_lower_bound_m) {
            return c.score_lower_bound_m;
        }
        let distance_m = match self.objective {
            Objective::Contact => self.distance_m(i),
            // The in-path objectives do not read it.
            Objective::InPath | Objective::CutIn => f64::NAN,
        };
        let score = self.objective.loss_unless(&self.ego, self.ego_body, &c.at, self.cbv_body, distance_m, &settled);
        if !settled(score) {
            c.score_m.set(Some(score));
        }
        score
    }

    /// The next clear child in the order of a sort of all the clear ones by
    /// score (ties to the likelier first token, then the order they were
    /// made in), or `None` when all have been handed out.
    pub(super) fn next_in_order(&mut self) -> Option<usize> {
        let mut ranking = self.ranking.take().unwrap_or_else(|| self.ranked());
        let next = loop {
            let Some(Reverse(top)) = ranking.pop() else { break None };
            if !top.exact {
                // A bound at the top: make it exact, and it takes its place.
                ranking.push(Reverse(Ranked { score_m: self.score_m(top.index), exact: true, ..top }));
            } else if self.clear(top.index) {
                break Some(top.index);
            }
        };
        self.ranking = Some(ranking);
        next
    }

    /// Hands out children by [`Self::next_in_order`] onto `order` until it
    /// holds `n` or all have been.
    pub(super) fn extend_order(&mut self, order: &mut Vec<usize>, n: usize) {
        while order.len() < n {
            let Some(i) = self.next_in_order() else { break };
            order.push(i);
        }
    }

    /// The ranking before any child is handed out: exact scores where
    /// known, else the lower bounds (a NaN bound, or a zero that the exact
    /// score could undercut as -0, as minus infinity: made exact first).
    fn ranked(&self) -> BinaryHeap<Reverse<Ranked>> {
        let entry = |(index, c): (usize, &Child)| {
            let ranked = match c.score_m.get() {
                Some(score_m) => Ranked { score_m, root: c.root, index, exact: true },
                None => {
                    let bound = c.score_lower_bound_m;
                    let score_m = if bound.is_nan() || bound == 0.0 { f64::NEG_INFINITY } else { bound };
                    Ranked { score_m, root: c.root, index, exact: false }
                }
            };
            Reverse(ranked)
        };
        self.children.iter().enumerate().map(entry).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Action;
    use crate::policies::adversary::test_support::car;
    use crate::scenario::AgentKind;

    const CAR: AgentBody = AgentBody { kind: AgentKind::Vehicle, length_m: 4.5, width_m: 2.0 };

    /// A beam around an ego at 12 m/s: behind it, beside it, ahead in its
    /// lane and in the next, crossing; each continued by 25 tokens of
    /// accelerations and yaw rates.
    fn continuations(objective: Objective) -> Continuations {
        let ego = car(0.0, 0.0, 12.0).unwrap();
        let beam: Vec<(usize, KinematicState)> =
            [(-9.0, 0.0, 0.0), (-2.0, 3.4, 0.1), (14.0, 0.2, 0.0), (9.0, -3.6, 0.2), (20.0, 8.0, -1.4)]
                .iter()
                .enumerate()
                .map(|(root, &(x, y, h))| {
                    let at = AgentState { heading_rad: h, ..car(x, y, 10.0).unwrap() };
                    (root, KinematicState { heading_rad: h, ..KinematicState::from_agent_state(&at) })
                })
                .collect();
        let tokens: Vec<Token> = [-5.0, -2.0, 0.0, 2.0, 5.0]
            .iter()
            .flat_map(|&a| {
                [-0.4, -0.1, 0.0, 0.1, 0.4].map(|w| TokenGrid::quantize(Action { accel_mps2: a, yaw_rate_radps: w }))
            })
            .collect();
        Continuations::new(beam.into_iter().enumerate(), &tokens, ego, (CAR, CAR), objective)
    }

    fn exact_distances(c: &Continuations) -> usize {
        c.children.iter().filter(|c| c.distance_m.get().is_some()).count()
    }

    #[test]
    fn children_come_in_the_order_of_a_full_sort_by_exact_score_with_fewer_exact_distances() {
        for objective in [Objective::Contact, Objective::InPath, Objective::CutIn] {
            let mut lazy = continuations(objective);
            let full = continuations(objective);
            // The full sort: every clear child by exact score, ties to the
            // likelier first token, then the order they were made in.
            let exact = |i: usize| {
                let c = full.child(i);
                let d = full.distance_m(i);
                (objective.loss(&full.ego, CAR, &c.at, CAR, d), d)
            };
            let mut sorted: Vec<usize> = (0..full.len()).filter(|&i| exact(i).1 > 0.0).collect();
            sorted.sort_by(|&x, &y| {
                exact(x).0.total_cmp(&exact(y).0).then(full.child(x).root.cmp(&full.child(y).root)).then(x.cmp(&y))
            });
            assert!(sorted.len() > 100 && sorted.len() < full.len(), "{objective:?}: some contacts, most clear");
            // The first ten cost far fewer exact distances than there are children.
            let mut order = Vec::new();
            lazy.extend_order(&mut order, 10);
            assert_eq!(order, sorted[..10], "{objective:?}");
            assert!(
                exact_distances(&lazy) * 4 < lazy.len(),
                "{objective:?}: {} of {}",
                exact_distances(&lazy),
                lazy.len()
            );
            // And all of them, the whole sort.
            lazy.extend_order(&mut order, usize::MAX);
            assert_eq!(order, sorted, "{objective:?}");
            for &i in &order {
                assert_eq!(lazy.score_m(i).to_bits(), exact(i).0.to_bits(), "{objective:?}");
            }
        }
    }

    #[test]
    fn a_score_asked_unless_settled_is_exact_below_the_line_and_settled_above_it() {
        for objective in [Objective::Contact, Objective::InPath, Objective::CutIn] {
            let lazy = continuations(objective);
            let full = continuations(objective);
            let line_m = 3.0;
            for i in 0..lazy.len() {
                let exact = full.score_m(i);
                let score = lazy.score_unless(i, |s| s >= line_m);
                if exact < line_m {
                    assert_eq!(score.to_bits(), exact.to_bits(), "{objective:?} {i}");
                } else {
                    assert!(score >= line_m, "{objective:?} {i}: {score} for {exact}");
                }
            }
        }
    }

    #[test]
    fn a_child_whose_token_turns_beyond_grip_or_tighter_than_a_car_says_so() {
        // From 10 m/s: 1.5 rad/s pulls 15 m/s² sideways, 0.8 rad/s 8 m/s²;
        // from 5 m/s, 1.5 rad/s pulls 7.5 m/s² on a 3.3 m radius, tighter
        // than a car steers, and 0.8 rad/s turns on 6.3 m.
        let ego = car(0.0, 0.0, 12.0).unwrap();
        let beam = [10.0, 5.0].map(|v| KinematicState::from_agent_state(&car(-9.0, 0.0, v).unwrap()));
        let turns = [1.5, 0.8].map(|w| TokenGrid::quantize(Action { accel_mps2: 0.0, yaw_rate_radps: w }));
        let c =
            Continuations::new(beam.into_iter().enumerate().enumerate(), &turns, ego, (CAR, CAR), Objective::Contact);
        let beyond: Vec<bool> = (0..c.len()).map(|i| c.child(i).beyond(CbvTurningLimit::GRIP)).collect();
        assert_eq!(beyond, [true, false, true, false]);
    }
}
