//! Escaping text for the XML-family files safer writes (SVG pictures, the
//! JUnit report, the review page, which is also well-formed XML): one rule
//! set, so a name or message with `<`, quotes or control characters (ANSI
//! colours in a planner's stderr) cannot break any of them.

use std::fmt::Write;

/// Escapes element text.
pub fn escape_text(s: &str) -> String {
    escape(s, false)
}

/// Escapes a value written between quotes (single or double); also safe as
/// element text.
pub fn escape_attribute(s: &str) -> String {
    escape(s, true)
}

fn escape(s: &str, attribute: bool) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // Attribute-value normalisation would turn these into spaces.
            '\n' if attribute => out.push_str("&#10;"),
            '\r' if attribute => out.push_str("&#13;"),
            '\t' if attribute => out.push_str("&#9;"),
            '\n' | '\r' | '\t' => out.push(c),
            // Not allowed in XML 1.0, not even as a character reference.
            c if (c as u32) < 0x20 || c == '\u{fffe}' || c == '\u{ffff}' => {
                let _ = write!(out, "\\u{{{:x}}}", c as u32);
            }
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markup_quotes_and_control_characters_cannot_escape_their_context() {
        assert_eq!(escape_text("a<b & 'c' \"d\"\n"), "a&lt;b &amp; &apos;c&apos; &quot;d&quot;\n");
        assert_eq!(escape_attribute("x\ny\u{1b}[31m"), "x&#10;y\\u{1b}[31m");
        // The result parses back to the input (where XML can hold it).
        let doc = format!("<r a=\"{}\">{}</r>", escape_attribute("1 < 2\n\"q\""), escape_text("<&>"));
        let parsed = roxmltree::Document::parse(&doc).unwrap();
        assert_eq!(parsed.root_element().attribute("a"), Some("1 < 2\n\"q\""));
        assert_eq!(parsed.root_element().text(), Some("<&>"));
    }
}
