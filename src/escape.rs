//! Text quoted from a file (or from a dependency's panic) into an error message, made safe
//! for a one-line error.

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

/// The message of a panic caught with `catch_unwind` (its `&str` or `String` payload, else
/// "unknown cause"), escaped like [`escape_controls`].
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    let text = payload
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("unknown cause");
    escape_controls(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_escaped_and_other_text_kept() {
        assert_eq!(escape_controls("a\nb\u{1}c é\t"), "a\\nb\\u{1}c é\\t");
        assert_eq!(escape_controls("plain `text`"), "plain `text`");
    }

    #[test]
    fn panic_messages_of_either_payload_type_become_one_line() {
        let caught = |f: fn()| std::panic::catch_unwind(f).expect_err("panics");
        let hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {}));
        let literal = caught(|| panic!("index out of bounds"));
        let formatted = caught(|| panic!("bad {}\nline", 2));
        let other = caught(|| std::panic::panic_any(7u8));
        std::panic::set_hook(hook);
        assert_eq!(panic_message(literal.as_ref()), "index out of bounds");
        assert_eq!(panic_message(formatted.as_ref()), "bad 2\\nline");
        assert_eq!(panic_message(other.as_ref()), "unknown cause");
    }
}
