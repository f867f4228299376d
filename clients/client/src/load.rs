//! What this process asked of the data server: how many requests, and how
//! long each took to be answered (wall time), for a fleet run to say the
//! load it put on the server. Waits that are meant to wait (`wait` on a
//! semaphore, a change held for its round) are counted but not timed:
//! their time is the other clients', not the server's.
//!
//! A histogram of fixed buckets, eight to each doubling of microseconds,
//! kept in atomics so that every client of the process records without a
//! lock.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// Buckets per doubling.
const STEPS: u32 = 8;
/// Buckets in all: up to 2^26 µs (67 s).
const BUCKETS: usize = 26 * STEPS as usize;

/// A count of requests and a histogram of reply times.
pub struct Load {
    requests: AtomicU64,
    timed: [AtomicU64; BUCKETS],
}

/// The data server's load from this process.
pub static DATA: Load = Load::new();

/// A snapshot of a [`Load`]: subtract two to get what happened between.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Snapshot {
    /// Requests sent (each attempt counts).
    pub requests: u64,
    /// Timed replies per bucket.
    pub timed: Vec<u64>,
}

impl Load {
    const fn new() -> Load {
        Load {
            requests: AtomicU64::new(0),
            timed: [const { AtomicU64::new(0) }; BUCKETS],
        }
    }

    /// One request, answered after `took` if it was timed.
    pub fn record(&self, took: Option<Duration>) {
        self.requests.fetch_add(1, Ordering::Relaxed);
        if let Some(t) = took {
            self.timed[bucket(t)].fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Everything so far.
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            requests: self.requests.load(Ordering::Relaxed),
            timed: self
                .timed
                .iter()
                .map(|b| b.load(Ordering::Relaxed))
                .collect(),
        }
    }
}

fn bucket(t: Duration) -> usize {
    let us = t.as_secs_f64() * 1e6;
    if us <= 1.0 {
        return 0;
    }
    ((us.log2() * f64::from(STEPS)) as usize).min(BUCKETS - 1)
}

/// The upper edge of bucket `i`.
fn edge(i: usize) -> Duration {
    Duration::from_secs_f64(2f64.powf((i + 1) as f64 / f64::from(STEPS)) / 1e6)
}

impl Snapshot {
    /// What happened after `before`.
    pub fn since(&self, before: &Snapshot) -> Snapshot {
        Snapshot {
            requests: self.requests.saturating_sub(before.requests),
            timed: self
                .timed
                .iter()
                .zip(before.timed.iter().chain(std::iter::repeat(&0)))
                .map(|(a, b)| a.saturating_sub(*b))
                .collect(),
        }
    }

    /// The reply time that `q` (0 … 1) of the timed replies took at most,
    /// to within a bucket (9 %); `None` with nothing timed.
    pub fn quantile(&self, q: f64) -> Option<Duration> {
        let n: u64 = self.timed.iter().sum();
        if n == 0 {
            return None;
        }
        let want = ((q.clamp(0.0, 1.0) * n as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (i, c) in self.timed.iter().enumerate() {
            seen += c;
            if seen >= want {
                return Some(edge(i));
            }
        }
        Some(edge(BUCKETS - 1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_fall_within_a_bucket_of_the_truth() {
        let l = Load::new();
        // 990 replies of 100 µs, 10 of 20 ms: the p99 is 100 µs, the p99.5 20 ms.
        for _ in 0..990 {
            l.record(Some(Duration::from_micros(100)));
        }
        for _ in 0..10 {
            l.record(Some(Duration::from_millis(20)));
        }
        l.record(None);
        let s = l.snapshot();
        assert_eq!(s.requests, 1_001);
        let p99 = s.quantile(0.99).unwrap().as_secs_f64();
        assert!((100e-6..=110e-6).contains(&p99), "{p99}");
        let p995 = s.quantile(0.995).unwrap().as_secs_f64();
        assert!((20e-3..=22e-3).contains(&p995), "{p995}");
        let later = l.snapshot().since(&s);
        assert_eq!((later.requests, later.quantile(0.5)), (0, None));
    }
}
