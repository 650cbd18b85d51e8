//! How a number read from a user's file or a planner's reply is shown in a
//! message: as written when it is of an everyday size, in scientific
//! notation when it is huge or tiny, so that 1e300 reads `1e300` and not
//! as a 301-digit line.

/// `value` for a message: the shortest text that reads back as `value`
/// (`4.7244`, `0.1`) when its magnitude is between 1e-4 and 1e7 (or it is
/// zero), else scientific notation (`1e300`, `7.35e299`, `3e-9`); `NaN`
/// and `inf` as Rust writes them.
pub fn shown(value: f64) -> String {
    let magnitude = value.abs();
    if !value.is_finite() || value == 0.0 || (1e-4..1e7).contains(&magnitude) {
        format!("{value}")
    } else {
        format!("{value:e}")
    }
}

/// [`shown`], rounded to `decimals` places when of an everyday size (a
/// measured quantity: `12.346`).
pub fn rounded(value: f64, decimals: usize) -> String {
    let magnitude = value.abs();
    if value.is_finite() && (magnitude == 0.0 || (1e-4..1e7).contains(&magnitude)) {
        format!("{value:.decimals$}")
    } else {
        shown(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn everyday_numbers_read_as_written_and_extreme_ones_in_scientific_notation() {
        assert_eq!(shown(4.7244), "4.7244");
        assert_eq!(shown(0.1), "0.1");
        assert_eq!(shown(-3.0), "-3");
        assert_eq!(shown(0.0), "0");
        assert_eq!(shown(1e300), "1e300");
        assert_eq!(shown(7.354674513135727e299), "7.354674513135727e299");
        assert_eq!(shown(3e-9), "3e-9");
        assert_eq!(shown(f64::NAN), "NaN");
        assert_eq!(rounded(12.34567, 3), "12.346");
        assert_eq!(rounded(1e308, 3), "1e308");
        assert!(shown(-1e300).len() < 10);
    }
}
