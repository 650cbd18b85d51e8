//! Long text from a user's file or a planner (a parsed value, an `error`
//! message, a panic) cut before it reaches a message or a report, saying
//! how long it was.

/// `text` cut to its first `max_chars` characters, with `…` and its full
/// length appended; unchanged when it is no longer than that.
pub fn cut_with_length(text: &str, max_chars: usize) -> String {
    match text.char_indices().nth(max_chars) {
        Some((at, _)) => format!("{}… ({} characters in all)", &text[..at], text.chars().count()),
        None => text.to_string(),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn long_text_is_cut_with_its_length_and_short_text_kept() {
        assert_eq!(super::cut_with_length("abcdef", 3), "abc… (6 characters in all)");
        assert_eq!(super::cut_with_length("abc", 3), "abc");
        assert_eq!(super::cut_with_length("ééé", 1), "é… (3 characters in all)");
    }
}
