//! The one held-out rule of the training data: which scenes the shipped
//! models never train on. Every [`HELD_OUT_EVERY`]-th scene of a sequence
//! (positions 9, 19, 29, … counted from 0) is held out, the rest is for
//! training. The split is by scene, never by sample, so no state of a
//! held-out scene leaks into training through a neighbouring sample.
//!
//! A *sequence* is what the rule counts in:
//!
//! - prior shards ([`prior_shards`](super::prior_shards)): each source on
//!   its own — the recorded (NGSIM) scenes sorted by id, then the synthetic
//!   scenes in generation order — so both sources hold out 10 %;
//! - the feasibility collection
//!   ([`feasibility_transitions`](super::feasibility_transitions)): its
//!   scenes in collection order (recorded sorted by id, then synthetic) as
//!   one sequence. `safer feasibility-dataset` writes the split into the
//!   transitions' metadata and `safer feasibility-eval` evaluates on the
//!   same scenes through [`Split::of`], so evaluation never sees a scene
//!   V_h was trained on.
//!
//! These are the splits the shipped models were trained with (model cards
//! in `models/`, `training/*/train.py` read the `split` that the Rust side
//! wrote); changing the rule or what it counts in changes which scenes a
//! shipped model has seen, so it needs the models retrained.

/// Every `HELD_OUT_EVERY`-th scene of a sequence is held out.
pub const HELD_OUT_EVERY: usize = 10;

/// Whether the scene at `position` (0-based) in its sequence is held out.
pub fn is_held_out(position: usize) -> bool {
    position % HELD_OUT_EVERY == HELD_OUT_EVERY - 1
}

/// Which part of the data a scene belongs to (written into shard metadata
/// as `train` / `held-out`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Split {
    /// Used for training.
    Train,
    /// Held out for evaluation.
    HeldOut,
}

impl Split {
    /// Every variant, in declaration order (for choosers such as the command line).
    pub const ALL: &'static [Self] = &[Self::Train, Self::HeldOut];
}

impl Split {
    /// The split of the scene at `position` in its sequence ([`is_held_out`]).
    pub fn of(position: usize) -> Self {
        if is_held_out(position) { Self::HeldOut } else { Self::Train }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rule_is_deterministic_and_holds_out_every_tenth_scene() {
        let held: Vec<usize> = (0..40).filter(|&i| is_held_out(i)).collect();
        assert_eq!(held, vec![9, 19, 29, 39]);
        let again: Vec<usize> = (0..40).filter(|&i| is_held_out(i)).collect();
        assert_eq!(held, again);
    }

    #[test]
    fn about_ten_percent_is_held_out_and_the_splits_are_disjoint() {
        for n in [84usize, 300, 384, 1000] {
            let splits: Vec<Split> = (0..n).map(Split::of).collect();
            let held = splits.iter().filter(|s| **s == Split::HeldOut).count();
            let train = splits.iter().filter(|s| **s == Split::Train).count();
            assert_eq!(held, n / HELD_OUT_EVERY, "{n} scenes");
            assert_eq!(held + train, n, "every scene is in exactly one split");
            let share = held as f64 / n as f64;
            assert!((0.09..=0.11).contains(&share), "{n} scenes: {share}");
        }
    }

    #[test]
    fn split_names_match_what_the_training_scripts_read() {
        assert_eq!(serde_json::to_string(&Split::HeldOut).unwrap(), "\"held-out\"");
        assert_eq!(serde_json::to_string(&Split::Train).unwrap(), "\"train\"");
    }

    /// The shipped V_h was split over its collection of 84 NGSIM + 300
    /// synthetic scenes as one sequence: this pins which synthetic scenes
    /// that made held out (the 6th of every ten, not the 10th).
    #[test]
    fn the_feasibility_collection_counts_recorded_and_synthetic_as_one_sequence() {
        let recorded = 84;
        let held_synthetic: Vec<usize> = (0..30).filter(|&j| is_held_out(recorded + j)).collect();
        assert_eq!(held_synthetic, vec![5, 15, 25]);
    }
}
