//! Rate limits of `minos serve`: token buckets, one per key (a session token, an access
//! token), so one page or one holder of a link cannot flood the server for everyone.

use std::collections::HashMap;
use std::sync::{Mutex, PoisonError};
use std::time::Instant;

/// How fast a server lets requests in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RateLimits {
    /// Messages a session's page may send per second (a burst of twice as many is let
    /// through); the excess is refused with an error message and does nothing.
    pub messages_per_second: u32,
    /// Sessions one access token (or, without one, everyone together) may create per
    /// minute; a burst of as many is let through, then `429 Too Many Requests`.
    pub sessions_per_minute: u32,
}

impl Default for RateLimits {
    fn default() -> Self {
        RateLimits {
            messages_per_second: 50,
            sessions_per_minute: 120,
        }
    }
}

/// A token bucket: holds up to `burst` tokens, refilled at `per_second`; each event takes
/// one.
#[derive(Debug, Clone)]
pub struct Bucket {
    per_second: f64,
    burst: f64,
    tokens: f64,
    last: Instant,
}

impl Bucket {
    /// A full bucket.
    pub fn new(per_second: f64, burst: f64, now: Instant) -> Self {
        Bucket {
            per_second,
            burst,
            tokens: burst,
            last: now,
        }
    }

    /// Takes a token at `now`; false when none is left (the event is over the limit).
    pub fn take(&mut self, now: Instant) -> bool {
        let elapsed = now.saturating_duration_since(self.last).as_secs_f64();
        self.last = self.last.max(now);
        self.tokens = (self.tokens + elapsed * self.per_second).min(self.burst);
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }

    /// Whether the bucket is full again at `now` (its key can be forgotten).
    fn full(&self, now: Instant) -> bool {
        let elapsed = now.saturating_duration_since(self.last).as_secs_f64();
        self.tokens + elapsed * self.per_second >= self.burst
    }
}

/// A bucket per key.
#[derive(Debug)]
pub struct Keyed {
    per_second: f64,
    burst: f64,
    buckets: Mutex<HashMap<String, Bucket>>,
}

/// Keys remembered before full buckets are forgotten.
const FORGET_ABOVE: usize = 4096;

impl Keyed {
    /// Buckets of `burst` tokens refilled at `per_second`.
    pub fn new(per_second: f64, burst: f64) -> Self {
        Keyed {
            per_second,
            burst,
            buckets: Mutex::new(HashMap::new()),
        }
    }

    /// Takes a token of `key`'s bucket; false when it is over the limit.
    pub fn take(&self, key: &str) -> bool {
        let now = Instant::now();
        let mut buckets = self.buckets.lock().unwrap_or_else(PoisonError::into_inner);
        if buckets.len() > FORGET_ABOVE {
            buckets.retain(|_, b| !b.full(now));
        }
        buckets
            .entry(key.to_string())
            .or_insert_with(|| Bucket::new(self.per_second, self.burst, now))
            .take(now)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn a_bucket_lets_its_burst_through_then_its_rate() {
        let t0 = Instant::now();
        let mut b = Bucket::new(10.0, 3.0, t0);
        assert!(b.take(t0) && b.take(t0) && b.take(t0));
        assert!(!b.take(t0), "the burst is spent");
        // 10 per second: one more token after 100 ms, not before.
        assert!(!b.take(t0 + Duration::from_millis(50)));
        assert!(b.take(t0 + Duration::from_millis(101)));
        assert!(!b.take(t0 + Duration::from_millis(101)));
        // Never more than the burst, however long it rests.
        let later = t0 + Duration::from_secs(60);
        assert_eq!((0..5).filter(|_| b.take(later)).count(), 3);
    }

    #[test]
    fn keys_have_their_own_buckets() {
        let k = Keyed::new(0.001, 2.0);
        assert!(k.take("a") && k.take("a"));
        assert!(!k.take("a"));
        assert!(k.take("b"), "another key is not limited by the first");
    }
}
