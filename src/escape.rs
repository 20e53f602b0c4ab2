//! Text quoted from a file into an error message, made safe for a one-line error.

/// `text` with every control character escaped (`\n`, `\u{1}`), so that text quoted from a
/// file cannot break an error across lines.
pub fn escape_controls(text: &str) -> String {
    if !text.chars().any(char::is_control) {
        return text.to_string();
    }
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_escaped_and_other_text_kept() {
        assert_eq!(escape_controls("a\nb\u{1}c é\t"), "a\\nb\\u{1}c é\\t");
        assert_eq!(escape_controls("plain `text`"), "plain `text`");
    }
}
