//! The reading end of a watch: committed writes, each once, with a byte
//! limit on what waits for a slow reader.

use crate::ClientError;
use rome_schema::data::Committed;
use rome_schema::decode;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;

/// A stream of committed writes (see [`crate::DataClient::watch`]).
pub struct Watch {
    subscriber: Subscriber<flume::Receiver<Sample>>,
    backlog: Arc<Backlog>,
    last: HashMap<String, u64>,
}

/// What a [`Watch`] holds for its reader.
pub(super) struct Backlog {
    limit: usize,
    /// Payload bytes queued.
    bytes: AtomicUsize,
    /// Commits dropped because `limit` was reached.
    missed: AtomicU64,
}

impl Backlog {
    pub(super) fn new(limit: usize) -> Backlog {
        Backlog {
            limit,
            bytes: AtomicUsize::new(0),
            missed: AtomicU64::new(0),
        }
    }

    /// Whether a sample of `len` bytes fits; one that does not is
    /// dropped and counted.
    pub(super) fn admit(&self, len: usize) -> bool {
        if self.bytes.fetch_add(len, Ordering::SeqCst) + len <= self.limit {
            return true;
        }
        self.bytes.fetch_sub(len, Ordering::SeqCst);
        let n = self.missed.fetch_add(1, Ordering::SeqCst) + 1;
        if n.is_power_of_two() {
            tracing::warn!(
                missed = n,
                backlog = self.limit,
                "watch reader too slow: commits dropped"
            );
        }
        false
    }
}

impl Watch {
    pub(super) fn new(
        subscriber: Subscriber<flume::Receiver<Sample>>,
        backlog: Arc<Backlog>,
    ) -> Watch {
        Watch {
            subscriber,
            backlog,
            last: HashMap::new(),
        }
    }

    /// How many commits were dropped so far because the reader fell more
    /// than [`crate::DataOptions::watch_backlog`] bytes behind (a skipped commit
    /// number also shows each gap).
    pub fn missed(&self) -> u64 {
        self.backlog.missed.load(Ordering::SeqCst)
    }

    /// The next committed write; `None` once the session is closed.
    ///
    /// A repeat of a commit already seen is skipped, so each write is
    /// returned once even if the network delivers it twice.
    pub async fn next(&mut self) -> Option<Result<Committed, ClientError>> {
        loop {
            let sample = rome_clock::idle(self.subscriber.recv_async()).await.ok()?;
            self.backlog
                .bytes
                .fetch_sub(sample.payload().len(), Ordering::SeqCst);
            let commit: Committed = match decode(&sample.payload().to_bytes(), "watch event") {
                Ok(c) => c,
                Err(e) => return Some(Err(e.into())),
            };
            let last = self.last.entry(commit.name.clone()).or_insert(0);
            if commit.seq <= *last {
                continue;
            }
            if *last != 0 && commit.seq != *last + 1 {
                tracing::warn!(name = %commit.name, from = *last, to = commit.seq, "watch skipped commits");
            }
            *last = commit.seq;
            return Some(Ok(commit));
        }
    }
}
