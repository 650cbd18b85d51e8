//! The search's budget ([`WitnessBudget`]): how wide its beam is, how
//! many expansions it may spend, the margin it keeps from every box, and
//! the ladder of wider beams it searches again with while it finds
//! nothing.

/// Search settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WitnessBudget {
    /// Candidates kept per token period.
    pub beam_width: usize,
    /// Most candidate expansions (one expansion = one token period of one candidate).
    pub max_expansions: usize,
    /// Clearance the witness keeps from every box, m.
    pub margin_m: f64,
    /// When the search finds nothing, it searches again with the beam and
    /// the expansion budget the first of these times as large, and when
    /// that finds nothing either, the next (1: that search is skipped).
    /// Most witnesses are found by the narrow beam and a few need a wide
    /// one; the narrow one keeps the usual case cheap, and only a search
    /// that finds nothing pays for the widest.
    pub widenings: [usize; 3],
    /// Candidates the beam keeps in every speed band ([`SPEED_BAND_MPS`](super::SPEED_BAND_MPS))
    /// whatever their clearance, on top of the best overall up to
    /// `beam_width` (the beam may grow past it by these). Ranked by
    /// clearance alone, the beam fills with braking (slower means farther
    /// from a car closing head-on for the first seconds) and loses the
    /// swerves at speed that escape; widened with the beam.
    pub per_speed_band: usize,
}

impl Default for WitnessBudget {
    fn default() -> Self {
        Self {
            beam_width: 48,
            max_expansions: 60_000,
            margin_m: 0.05,
            widenings: [FIRST_WIDENING, DEFAULT_WIDEST, 1],
            per_speed_band: 3,
        }
    }
}

/// The first widening of the default search: most witnesses the narrow
/// beam misses, the ×8 one finds.
pub const FIRST_WIDENING: usize = 8;

/// The widest beam the default search tries, as a multiple of the narrow
/// one: on recorded scenes the ×64 beam finds escapes from stage-1
/// collisions that the ×8 one misses; only a search that finds nothing
/// pays for it (seconds on a busy scene).
pub const DEFAULT_WIDEST: usize = 64;

/// The widest beam `safer evaluate --witness-widest` accepts, as a multiple
/// of the narrow one (×512 already takes about a minute a search that finds
/// nothing on a busy scene).
pub const MOST_WIDEST: usize = 4096;

impl WitnessBudget {
    /// The default budget, widening at most to `widest` times the narrow
    /// beam: through the default's rungs (×[`FIRST_WIDENING`],
    /// ×[`DEFAULT_WIDEST`]) below `widest`, then ×`widest` (1: no
    /// widening), so that every witness the default finds is found as it
    /// finds it. A wider search finds escapes a narrower one misses, at
    /// more time where none exists.
    pub fn widening_up_to(widest: usize) -> Self {
        let widenings = if widest > DEFAULT_WIDEST {
            [FIRST_WIDENING, DEFAULT_WIDEST, widest]
        } else if widest > FIRST_WIDENING {
            [FIRST_WIDENING, widest, 1]
        } else {
            [widest, 1, 1]
        };
        Self { widenings, ..Self::default() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_budget_widening_up_to_n_ends_its_ladder_at_n() {
        assert_eq!(WitnessBudget::widening_up_to(DEFAULT_WIDEST), WitnessBudget::default());
        // Wider than the default: through its rungs first.
        assert_eq!(WitnessBudget::widening_up_to(512).widenings, [FIRST_WIDENING, DEFAULT_WIDEST, 512]);
        assert_eq!(WitnessBudget::widening_up_to(16).widenings, [FIRST_WIDENING, 16, 1]);
        // Up to the first rung: that rung alone, or none.
        assert_eq!(WitnessBudget::widening_up_to(FIRST_WIDENING).widenings, [FIRST_WIDENING, 1, 1]);
        assert_eq!(WitnessBudget::widening_up_to(4).widenings, [4, 1, 1]);
        assert_eq!(WitnessBudget::widening_up_to(1).widenings, [1, 1, 1]);
    }
}
