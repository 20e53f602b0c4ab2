//! What every response of `minos serve` is checked against and carries: the `Host` a request
//! names must be this server's (a page of another site whose name was made to resolve to this
//! machine — DNS rebinding — names its own host and is refused), and every response carries
//! headers that keep the page from being framed, sniffed or made to load anything from
//! elsewhere (a content-security policy whose scripts and styles are the page's own, by hash).

use std::net::{IpAddr, SocketAddr};

use axum::http::{header, HeaderMap, HeaderName, HeaderValue};
use sha2::{Digest, Sha256};

/// Whether `host` (a request's `Host` header) names this server, listening on `bound`: a
/// loopback address or `localhost` (any port), the address it listens on, any address when
/// it listens on all of them, or one of the names in `allowed` (lowercase, as the operator
/// gave them with `--allowed-host`). A missing or malformed `Host` is refused.
pub fn host_allowed(host: Option<&str>, bound: SocketAddr, allowed: &[String]) -> bool {
    let Some(name) = host.and_then(host_name) else {
        return false;
    };
    if let Ok(ip) = name.parse::<IpAddr>() {
        // An address is not a name: no rebinding can make a page of another site send it.
        return ip.is_loopback() || ip == bound.ip() || bound.ip().is_unspecified();
    }
    name == "localhost" || allowed.contains(&name)
}

/// The host name of a `Host` header without its port, lowercase, without a final dot (IPv6
/// addresses without their brackets); `None` when it is not a host.
fn host_name(host: &str) -> Option<String> {
    let host = host.trim();
    let name = if let Some(rest) = host.strip_prefix('[') {
        let (inside, after) = rest.split_once(']')?;
        if !(after.is_empty() || port(after.strip_prefix(':')?)) {
            return None;
        }
        inside
    } else {
        match host.rsplit_once(':') {
            Some((name, p)) if port(p) => name,
            Some(_) => return None,
            None => host,
        }
    };
    let name = name.strip_suffix('.').unwrap_or(name).to_ascii_lowercase();
    let ok = !name.is_empty()
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'-' | b'.' | b':' | b'_'));
    ok.then_some(name)
}

fn port(p: &str) -> bool {
    !p.is_empty() && p.len() <= 5 && p.bytes().all(|b| b.is_ascii_digit())
}

/// `'sha256-…'`: a content-security-policy source allowing exactly the inline text `text`.
fn csp_hash(text: &str) -> String {
    use base64::Engine as _;
    let digest = Sha256::digest(text.as_bytes());
    format!(
        "'sha256-{}'",
        base64::engine::general_purpose::STANDARD.encode(digest)
    )
}

/// The content-security policy of the page whose inline script is `script` and inline style
/// `style`: nothing but them runs, images only from the page itself (and the blobs it makes
/// of frames), connections only to this server, no framing, no forms elsewhere.
pub fn page_policy(script: &str, style: &str) -> String {
    format!(
        "default-src 'none'; script-src {}; style-src {}; img-src 'self' blob: data:; \
         connect-src 'self'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'",
        csp_hash(script),
        csp_hash(style)
    )
}

/// The policy of every other response (JSON, errors): nothing at all.
pub const API_POLICY: &str = "default-src 'none'; frame-ancestors 'none'";

/// Adds the headers every response carries to `headers`; `policy` is its content-security
/// policy (kept when the response set one).
pub fn add_headers(headers: &mut HeaderMap, policy: &str) {
    let fixed: [(HeaderName, &'static str); 6] = [
        (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
        (header::REFERRER_POLICY, "no-referrer"),
        (header::X_FRAME_OPTIONS, "DENY"),
        (header::CACHE_CONTROL, "no-store"),
        (
            HeaderName::from_static("cross-origin-opener-policy"),
            "same-origin",
        ),
        (
            HeaderName::from_static("cross-origin-resource-policy"),
            "same-origin",
        ),
    ];
    for (name, value) in fixed {
        headers.insert(name, HeaderValue::from_static(value));
    }
    if !headers.contains_key(header::CONTENT_SECURITY_POLICY) {
        if let Ok(v) = HeaderValue::from_str(policy) {
            headers.insert(header::CONTENT_SECURITY_POLICY, v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_this_servers_names_are_hosts() {
        let local: SocketAddr = "127.0.0.1:8080".parse().unwrap();
        let ok = |h: &str| host_allowed(Some(h), local, &[]);
        for h in [
            "127.0.0.1:8080",
            "localhost:8080",
            "LOCALHOST",
            "[::1]:8080",
            "127.0.0.1",
            "localhost.",
        ] {
            assert!(ok(h), "{h}");
        }
        // DNS rebinding: a name of the attacker's that resolves to 127.0.0.1.
        for h in [
            "evil.example:8080",
            "evil.example",
            "localhost.evil.example",
            "10.0.0.7:8080",
            "",
            "a b",
            "x:y:z",
            "[::1]x",
        ] {
            assert!(!ok(h), "{h}");
        }
        assert!(!host_allowed(None, local, &[]));
        // Names the operator gives; the bound address; any address when bound to all.
        let named = ["lab.example.org".to_string()];
        assert!(host_allowed(Some("Lab.Example.org:443"), local, &named));
        let lan: SocketAddr = "192.168.1.5:80".parse().unwrap();
        assert!(host_allowed(Some("192.168.1.5"), lan, &[]));
        assert!(!host_allowed(Some("192.168.1.6"), lan, &[]));
        let all: SocketAddr = "0.0.0.0:80".parse().unwrap();
        assert!(host_allowed(Some("192.168.1.6"), all, &[]));
        assert!(!host_allowed(Some("evil.example"), all, &[]));
    }

    #[test]
    fn the_page_policy_allows_exactly_its_own_script() {
        let p = page_policy("alert(1)", "b{}");
        // sha256("alert(1)") in base64, computed independently (openssl dgst -sha256 -binary | base64).
        assert!(
            p.contains("'sha256-bhHHL3z2vDgxUt0W3dWQOrprscmda2Y5pLsLg4GF+pI='"),
            "{p}"
        );
        assert!(!p.contains("unsafe-inline") && p.contains("frame-ancestors 'none'"));
    }
}
