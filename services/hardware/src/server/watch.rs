//! A hardware server's side of its lock that outlives it: the holders seen
//! alive or gone (liveliness), the record written to and read back from the
//! storage, and the periodic sweep and tick.

use super::*;
use crate::gate::Gate;
use rome_clock::Instant;
use rome_schema::robot::{LockRecord, DEFAULT_LOCK_TTL_MS};
use rome_schema::{decode, encode, ErrorCode, ErrorReply};
use rome_serve::reply_err;
use std::time::{Duration, SystemTime};
use zenoh::bytes::Encoding;
use zenoh::qos::CongestionControl;
use zenoh::query::ConsolidationMode;
use zenoh::sample::{Sample, SampleKind};

impl<S: Service> Server<S> {
    pub(super) async fn alive(&mut self, sample: Sample) {
        let Some(alive) = self.config.root.parse_alive(sample.key_expr().as_str()) else {
            return;
        };
        if alive.class == rome_schema::keys::AliveClass::Server
            && alive.role == crate::storage::STORE_KIND
        {
            if sample.kind() == SampleKind::Put && S::LOCKABLE {
                self.storage_up(alive.id).await;
            }
            return;
        }
        if sample.kind() != SampleKind::Delete {
            return;
        }
        if self.mover.as_deref() == Some(alive.id) {
            // A deadman: nobody is left to stop what that client started
            // (its process died, or its host dropped off the network).
            self.mover = None;
            match self.service.halt().await {
                Ok(true) => {
                    tracing::warn!(server = %self.config.label(), client = %alive.id, "the client that set the device moving is gone; stopped it")
                }
                Ok(false) => {
                    tracing::debug!(server = %self.config.label(), client = %alive.id, "the client that last moved the device is gone; it stood still")
                }
                Err(e) => {
                    tracing::error!(server = %self.config.label(), client = %alive.id, error = %e, "the client that set the device moving is gone and stopping it failed")
                }
            }
        }
        if let Some(h) = self.gate.owner_gone(alive.id) {
            tracing::warn!(server = %self.config.label(), holder = %h.owner, fence = h.fence, "lock holder gone; lock released");
            self.persist().await;
            self.drain().await;
        }
    }

    pub(super) async fn sweep_now(&mut self) {
        let now = Instant::now();
        if let Some(h) = self.gate.expire(now) {
            tracing::warn!(server = %self.config.label(), holder = %h.owner, fence = h.fence, "lock not renewed in time; released");
            self.persist().await;
            self.drain().await;
        }
        for p in self.gate.overdue(now) {
            let why = match self.gate.holder() {
                Some(h) => format!("behind the lock held by '{}' (fence {})", h.owner, h.fence),
                None => "in the queue".into(),
            };
            let e = ErrorReply::new(
                ErrorCode::TimedOut,
                format!(
                    "'{}' waited {} ms {why} on {} and was not carried out (raise 'wait_ms' to wait longer)",
                    p.command,
                    p.arrived.elapsed().as_millis(),
                    self.config.label()
                ),
            );
            reply_err(&p.query, &e).await;
        }
    }

    pub(super) async fn tick_now(&mut self) {
        let lock = self.lock();
        let queued = self.gate.queued();
        // Stamped with when the device was read, not when it was sent: a
        // subscriber sees the reading's age (`rome bench robot`, recordings).
        let read_at = self.session.new_timestamp();
        if let Some((chunk, body)) = self.service.tick(lock, queued).await {
            let key = self.config.key(chunk);
            let (bytes, encoding) = body.into_parts();
            self.last.insert(chunk, (bytes.clone(), encoding.clone()));
            let Some(declared) = self.keys.get(&key) else {
                tracing::warn!(%key, "no key to publish on");
                return;
            };
            rome_clock::sending(&key);
            let sent = self
                .session
                .put(declared, bytes)
                .encoding(encoding)
                .timestamp(read_at)
                .congestion_control(CongestionControl::Drop)
                .await;
            if let Err(e) = sent {
                tracing::warn!(%key, error = %e, "publication failed");
            }
        }
    }

    /// Writes the lock state to the storage.
    pub(super) async fn persist(&self) {
        let key = self.config.lock_store();
        let record = LockRecord {
            holder: self.lock(),
            last_fence: self.gate.last_fence(),
            ttl_ms: self
                .gate
                .holder()
                .map_or(DEFAULT_LOCK_TTL_MS, |h| h.ttl.as_millis() as u64),
        };
        let sent = self
            .session
            .put(&key, encode(&record))
            .encoding(Encoding::APPLICATION_JSON)
            .congestion_control(CongestionControl::Block)
            .await;
        if let Err(e) = sent {
            tracing::error!(%key, error = %e, "lock state not stored");
        }
    }

    /// Reads the lock state a previous run stored; without one, fences
    /// start from the clock so they never repeat a lost run's. A storage
    /// that is there but slow to answer (a loaded machine, a router far
    /// away) is asked again: starting with the lock free would make the
    /// holder's fence stale and let another client take the device.
    pub(super) async fn restore_lock(&mut self) {
        let mut record = None;
        for attempt in 1..=STORE_ATTEMPTS {
            match self.stored().await {
                Lookup::Found(r) => {
                    record = Some(r);
                    break;
                }
                Lookup::Nothing => break,
                Lookup::Silent(why) if attempt < STORE_ATTEMPTS => {
                    tracing::warn!(server = %self.config.label(), attempt, %why, "the storage did not answer for the lock record; asking again");
                }
                Lookup::Silent(why) => {
                    tracing::error!(server = %self.config.label(), attempts = STORE_ATTEMPTS, %why, "the storage never answered for the lock record: the lock starts free, with fences above any a lost run could have granted");
                }
            }
        }
        let clock = SystemTime::now()
            .duration_since(SystemTime::UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as u64);
        match record {
            Some(r) => {
                self.gate = Gate::new(r.last_fence);
                if let Some(holder) = &r.holder {
                    // The holder gets one grant life to show it is still there.
                    self.gate
                        .restore(holder, Duration::from_millis(r.ttl_ms), Instant::now());
                    tracing::info!(server = %self.config.label(), holder = %holder.holder, fence = holder.fence, "lock restored from the storage");
                }
            }
            None => self.gate = Gate::new(clock * 1000),
        }
    }

    /// A storage came (back) up: what it knows is merged (fences only ever
    /// go up; its holder comes back only if nothing was granted since),
    /// and it gets the lock record it may have missed.
    async fn storage_up(&mut self, storage: &str) {
        let lookup = self.stored().await;
        if let Lookup::Silent(why) = &lookup {
            tracing::warn!(server = %self.config.label(), %storage, %why, "a storage came up but did not answer for the lock record");
        }
        if let Lookup::Found(r) = lookup {
            let newer = r.last_fence >= self.gate.last_fence();
            self.gate.raise(r.last_fence);
            if let (Some(holder), None, true) = (&r.holder, self.gate.holder(), newer) {
                self.gate
                    .restore(holder, Duration::from_millis(r.ttl_ms), Instant::now());
                tracing::info!(server = %self.config.label(), holder = %holder.holder, fence = holder.fence, "lock restored from a storage that came up");
            }
        }
        tracing::info!(server = %self.config.label(), %storage, "a storage came up; lock record stored again");
        self.persist().await;
    }

    /// The lock record in the storage, if one answers with a readable one.
    async fn stored(&self) -> Lookup {
        let key = self.config.lock_store();
        let replies = match self
            .session
            .get(&key)
            .consolidation(ConsolidationMode::Latest)
            .timeout(STORE_WAIT)
            .await
        {
            Ok(replies) => replies,
            Err(e) => return Lookup::Silent(format!("the query could not be sent: {e}")),
        };
        let (mut record, mut silent) = (None, None);
        while let Ok(reply) = replies.recv_async().await {
            match reply.result() {
                Ok(sample) => {
                    match decode::<LockRecord>(&sample.payload().to_bytes(), "lock record") {
                        Ok(r) => record = Some(r),
                        Err(e) => tracing::warn!(%key, error = %e, "stored lock state unreadable"),
                    }
                }
                // Zenoh ends a query that ran out of time with an error
                // reply; a storage may answer with one too.
                Err(e) => {
                    silent = Some(format!(
                        "{} (asked {key}, waited up to {:?})",
                        String::from_utf8_lossy(&e.payload().to_bytes()),
                        STORE_WAIT
                    ))
                }
            }
        }
        match (record, silent) {
            (Some(r), _) => Lookup::Found(r),
            (None, Some(why)) => Lookup::Silent(why),
            (None, None) => Lookup::Nothing,
        }
    }
}

/// What asking the storage for a lock record found.
enum Lookup {
    /// A readable record.
    Found(LockRecord),
    /// Every storage answered, and none holds one (or none is running).
    Nothing,
    /// No complete answer: the query timed out or was refused (why).
    Silent(String),
}
