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

/// An error and its causes (its `source()` chain) on one line, `: ` between them, with line
/// breaks made spaces: the text of `error: …` in both front doors, of a warning, and of an
/// error kept in a report (a run's failed episodes). minos's errors print themselves only
/// and keep their cause as their `source()` (`tests/layering.rs` checks every `#[error]`),
/// so this is the one way to show one whole; a cause that the error before it in the chain
/// printed already (a dependency's error that prints the cause it also returns) is not
/// repeated.
pub fn error_line(e: &(dyn std::error::Error + 'static)) -> String {
    let mut line = e.to_string();
    let mut previous = line.clone();
    let mut cause = e.source();
    while let Some(c) = cause {
        let text = c.to_string();
        // minos's own errors print only themselves; a dependency's error may also print the
        // cause it returns as its source, whole or after `: ` (image's and arrow's wrappers
        // do): that cause is not shown twice.
        let printed = previous == text || previous.ends_with(&format!(": {text}"));
        if !text.is_empty() && !printed {
            line.push_str(": ");
            line.push_str(&text);
        }
        previous = text;
        cause = c.source();
    }
    line.replace('\n', " ")
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

thread_local! {
    /// How many [`catch_quietly`] calls the current thread is inside.
    static QUIET: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// Runs `f`, a call into a dependency's reader that may panic on bad data, and returns its
/// panic's message (see [`panic_message`]) as the error. The panic is not printed: the
/// process-wide panic hook is wrapped once so that panics inside `catch_quietly` stay silent
/// (a user sees only the one-line error made of the message) while every other panic is
/// reported by the hook that was installed before.
pub fn catch_quietly<T>(f: impl FnOnce() -> T) -> Result<T, Panicked> {
    static WRAP_HOOK: std::sync::Once = std::sync::Once::new();
    WRAP_HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET.with(std::cell::Cell::get) == 0 {
                previous(info);
            }
        }));
    });
    QUIET.with(|q| q.set(q.get() + 1));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    QUIET.with(|q| q.set(q.get().saturating_sub(1)));
    result.map_err(|p| Panicked(panic_message(p.as_ref())))
}

/// A dependency's panic caught by [`catch_quietly`]: its message, escaped (one line).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct Panicked(pub String);

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("reading {0}")]
    struct Outer(&'static str, #[source] Inner);

    #[derive(Debug, thiserror::Error)]
    #[error("bad\nvalue")]
    struct Inner;

    /// A dependency's kind of error: prints its cause and returns it as its source.
    #[derive(Debug)]
    struct Says(Inner);

    impl std::fmt::Display for Says {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "file.toml: {}", self.0)
        }
    }

    impl std::error::Error for Says {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.0)
        }
    }

    #[test]
    fn an_error_line_holds_each_cause_once() {
        assert_eq!(
            error_line(&Outer("file.toml", Inner)),
            "reading file.toml: bad value"
        );
        // A cause the error before it printed is not repeated; text that only looks like
        // the cause is kept.
        assert_eq!(error_line(&Says(Inner)), "file.toml: bad value");
        assert_eq!(
            error_line(&Outer("bad\nvalue", Inner)),
            "reading bad value: bad value"
        );
        assert_eq!(error_line(&Inner), "bad value");
    }

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

    #[test]
    fn catch_quietly_turns_a_panic_into_its_message_and_passes_values_through() {
        assert_eq!(catch_quietly(|| 4), Ok(4));
        let e = catch_quietly(|| -> u8 { panic!("Type <UNKNOWN 252>\nnot supported") });
        assert_eq!(
            e,
            Err(Panicked("Type <UNKNOWN 252>\\nnot supported".to_string()))
        );
        // Nested guards unwind their own counts: the thread is quiet again only inside one.
        let nested = catch_quietly(|| catch_quietly(|| -> () { panic!("inner") }));
        assert_eq!(nested, Ok(Err(Panicked("inner".to_string()))));
        assert_eq!(QUIET.with(std::cell::Cell::get), 0);
    }
}
