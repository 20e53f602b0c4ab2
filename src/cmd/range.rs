//! `MIN..MAX` (or a single `N`) ranges on the command line.

/// Parses `3..8`, `3..=8` or `5` into an inclusive range.
pub fn parse_range(s: &str) -> Result<(usize, usize), String> {
    let parse = |t: &str| {
        t.trim()
            .parse::<usize>()
            .map_err(|_| format!("`{t}` is not a whole number (expected MIN..MAX, e.g. 3..8)"))
    };
    let (lo, hi) = match s.split_once("..") {
        Some((a, b)) => (parse(a)?, parse(b.trim_start_matches('='))?),
        None => {
            let n = parse(s)?;
            (n, n)
        }
    };
    if lo > hi {
        return Err(format!("`{s}`: MIN is larger than MAX"));
    }
    Ok((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_parse() {
        assert_eq!(parse_range("3..8"), Ok((3, 8)));
        assert_eq!(parse_range("3..=8"), Ok((3, 8)));
        assert_eq!(parse_range("5"), Ok((5, 5)));
        assert!(parse_range("8..3").is_err());
        assert!(parse_range("a..3").unwrap_err().contains("`a`"));
    }
}
