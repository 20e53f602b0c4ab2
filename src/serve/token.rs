//! Secrets of `minos serve`: session tokens drawn from the operating system's random source,
//! and comparisons that take the same time whatever the strings hold and wherever they differ.

/// Bytes of randomness in a session token (shown as twice as many hex digits).
pub const TOKEN_BYTES: usize = 32;

/// A fresh session token: [`TOKEN_BYTES`] bytes from the OS's random source, in hex.
pub fn session_token() -> Result<String, getrandom::Error> {
    random_hex(TOKEN_BYTES)
}

/// `n` random bytes from the OS, in lowercase hex.
pub fn random_hex(n: usize) -> Result<String, getrandom::Error> {
    let mut bytes = vec![0u8; n];
    getrandom::fill(&mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Whether `s` has the shape of a session token (so no other string reaches a lookup).
pub fn looks_like_token(s: &str) -> bool {
    s.len() == TOKEN_BYTES * 2 && s.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

/// `a == b` in time that depends on neither string's contents nor on where they differ:
/// their sha256 digests (32 bytes, whatever the lengths) compared in constant time
/// ([`subtle`], which keeps the optimiser from shortcutting the comparison).
pub fn same(a: &str, b: &str) -> bool {
    use sha2::{Digest, Sha256};
    use subtle::ConstantTimeEq;
    let (a, b) = (Sha256::digest(a.as_bytes()), Sha256::digest(b.as_bytes()));
    a.as_slice().ct_eq(b.as_slice()).into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_are_long_hex_and_differ() {
        let a = session_token().expect("OS randomness");
        let b = session_token().expect("OS randomness");
        assert!(looks_like_token(&a) && looks_like_token(&b), "{a} {b}");
        assert_ne!(a, b);
        assert!(!looks_like_token("../../etc/passwd"));
        assert!(!looks_like_token(&a.to_uppercase()));
        assert!(!looks_like_token(&a[1..]));
    }

    #[test]
    fn comparison_is_equality() {
        assert!(same("abc", "abc"));
        assert!(!same("abc", "abd"));
        assert!(!same("abc", "abcd"));
        assert!(!same("abc", ""));
        assert!(same("", ""));
        // A difference in the first or the last byte, or only in length, is a difference.
        let t = "f".repeat(64);
        for other in [
            format!("0{}", &t[1..]),
            format!("{}0", &t[..63]),
            t[..63].to_string(),
        ] {
            assert!(!same(&t, &other), "{other}");
        }
    }
}
