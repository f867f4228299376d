//! The queue in front of a device: client priorities (§4.3) and the lock
//! token (§4.6.3 "Locking Mechanism", shared by the camera server).
//!
//! Requests without a fence wait here while another client holds the lock
//! (postponed, not refused) and are served highest priority first, first
//! come first served within a priority. The holder's requests carry the
//! grant's fencing number and go straight to the device; a request with any
//! other fence is refused, so a holder whose grant lapsed cannot act on the
//! robot after someone else got it.
//!
//! A command carried out with `suppress_ms` also suppresses lower
//! priorities for that long: their commands that act are refused
//! (`suppressed`), not queued, since a colony-style module's output is a
//! stream and a stale command carried out later would be wrong (§3.2.2,
//! §4.8.2). The dominant module keeps its claim by sending within the time
//! constant; when it falls silent, the others' streams get through again.

use rome_clock::Instant;
use rome_schema::robot::LockInfo;
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::time::Duration;

/// The current grant.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Holder {
    /// The owner id the lock was granted to.
    pub owner: String,
    /// Its fencing number.
    pub fence: u64,
    /// How long the grant lives without a renewal.
    pub ttl: Duration,
    /// When it lapses unless renewed.
    pub expires: Instant,
}

impl Holder {
    /// The holder as the state stream and the storage show it.
    pub fn info(&self) -> LockInfo {
        LockInfo {
            holder: self.owner.clone(),
            fence: self.fence,
        }
    }
}

/// A suppression in force: commands that act from below `priority` are
/// refused until `until`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Suppressor {
    /// The priority of the command that suppresses.
    pub priority: u8,
    /// Its sender, if it named itself.
    pub client: Option<String>,
    /// When it was carried out.
    pub since: Instant,
    /// When the suppression ends unless renewed.
    pub until: Instant,
}

/// What to do with a request that just arrived.
#[derive(Debug, PartialEq, Eq)]
pub enum Admit<T> {
    /// The holder's own request: serve it now.
    Now(T),
    /// Queued until the lock is free and its turn comes.
    Queued,
    /// Its fence is not the current grant's.
    Stale {
        /// The fence it carried.
        fence: u64,
        /// The request, to answer with the error.
        item: T,
    },
}

struct Queued<T> {
    priority: u8,
    seq: u64,
    deadline: Instant,
    item: T,
}

impl<T> PartialEq for Queued<T> {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl<T> Eq for Queued<T> {}
impl<T> PartialOrd for Queued<T> {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl<T> Ord for Queued<T> {
    fn cmp(&self, other: &Self) -> Ordering {
        // The heap pops the greatest: higher priority, then the earlier arrival.
        self.priority
            .cmp(&other.priority)
            .then_with(|| other.seq.cmp(&self.seq))
    }
}

/// A device's queue and lock.
pub struct Gate<T> {
    heap: BinaryHeap<Queued<T>>,
    seq: u64,
    holder: Option<Holder>,
    last_fence: u64,
    suppressor: Option<Suppressor>,
}

impl<T> Gate<T> {
    /// An empty gate whose next grant gets a fence above `last_fence`.
    pub fn new(last_fence: u64) -> Self {
        Gate {
            heap: BinaryHeap::new(),
            seq: 0,
            holder: None,
            last_fence,
            suppressor: None,
        }
    }

    /// The current grant, if any.
    pub fn holder(&self) -> Option<&Holder> {
        self.holder.as_ref()
    }

    /// The last fence granted.
    pub fn last_fence(&self) -> u64 {
        self.last_fence
    }

    /// How many requests wait.
    pub fn queued(&self) -> usize {
        self.heap.len()
    }

    /// Admits a request: the holder's (right fence) now, a wrong fence
    /// refused, anything else queued.
    pub fn admit(
        &mut self,
        priority: u8,
        fence: Option<u64>,
        wait: Duration,
        item: T,
        now: Instant,
    ) -> Admit<T> {
        match (fence, &mut self.holder) {
            (Some(f), Some(h)) if h.fence == f => {
                h.expires = now + h.ttl;
                Admit::Now(item)
            }
            (Some(fence), _) => Admit::Stale { fence, item },
            (None, _) => {
                self.seq += 1;
                self.heap.push(Queued {
                    priority,
                    seq: self.seq,
                    deadline: now + wait,
                    item,
                });
                Admit::Queued
            }
        }
    }

    /// The next request to serve: none while the lock is held.
    pub fn next_due(&mut self) -> Option<T> {
        if self.holder.is_some() {
            return None;
        }
        self.heap.pop().map(|q| q.item)
    }

    /// Grants the (free) lock to `owner`.
    pub fn grant(&mut self, owner: &str, ttl: Duration, now: Instant) -> Holder {
        self.last_fence += 1;
        let holder = Holder {
            owner: owner.to_string(),
            fence: self.last_fence,
            ttl,
            expires: now + ttl,
        };
        self.holder = Some(holder.clone());
        holder
    }

    /// Makes the next grant's fence go above `fence` as well.
    pub fn raise(&mut self, fence: u64) {
        self.last_fence = self.last_fence.max(fence);
    }

    /// Puts back a grant a restarted server read from the storage.
    pub fn restore(&mut self, info: &LockInfo, ttl: Duration, now: Instant) {
        self.last_fence = self.last_fence.max(info.fence);
        self.holder = Some(Holder {
            owner: info.holder.clone(),
            fence: info.fence,
            ttl,
            expires: now + ttl,
        });
    }

    /// Ends the grant with this fence; `Err` with the current fence if it
    /// is not the holder's.
    pub fn release(&mut self, fence: u64) -> Result<Holder, Option<u64>> {
        match &self.holder {
            Some(h) if h.fence == fence => Ok(self.holder.take().expect("checked Some")),
            other => Err(other.as_ref().map(|h| h.fence)),
        }
    }

    /// Ends a grant that was not renewed in time.
    pub fn expire(&mut self, now: Instant) -> Option<Holder> {
        match &self.holder {
            Some(h) if h.expires <= now => self.holder.take(),
            _ => None,
        }
    }

    /// Ends the grant of an owner whose liveliness token went away.
    pub fn owner_gone(&mut self, owner: &str) -> Option<Holder> {
        match &self.holder {
            Some(h) if h.owner == owner => self.holder.take(),
            _ => None,
        }
    }

    /// The suppression a command that acts at `priority` meets now, if any:
    /// one from a strictly higher priority still in force.
    pub fn suppressed(&self, priority: u8, now: Instant) -> Option<&Suppressor> {
        self.suppressor
            .as_ref()
            .filter(|s| s.priority > priority && now < s.until)
    }

    /// Records that a command at `priority` asking `suppress` was carried
    /// out: it suppresses lower priorities from now for that long. A claim
    /// of a higher priority still in force is kept; one of the same or a
    /// lower priority is replaced (each command of the stream renews it).
    pub fn suppress(
        &mut self,
        priority: u8,
        client: Option<String>,
        suppress: Duration,
        now: Instant,
    ) {
        if self.suppressed(priority, now).is_some() || suppress.is_zero() {
            return;
        }
        self.suppressor = Some(Suppressor {
            priority,
            client,
            since: now,
            until: now + suppress,
        });
    }

    /// Takes out every queued request whose wait ran out.
    pub fn overdue(&mut self, now: Instant) -> Vec<T> {
        if self.heap.iter().all(|q| q.deadline > now) {
            return Vec::new();
        }
        let (late, keep): (Vec<_>, Vec<_>) = std::mem::take(&mut self.heap)
            .into_vec()
            .into_iter()
            .partition(|q| q.deadline <= now);
        self.heap = keep.into();
        let mut late = late;
        late.sort_by_key(|q| q.seq);
        late.into_iter().map(|q| q.item).collect()
    }

    /// Takes out every queued request (shutdown).
    pub fn drain_all(&mut self) -> Vec<T> {
        std::mem::take(&mut self.heap)
            .into_sorted_vec()
            .into_iter()
            .rev()
            .map(|q| q.item)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WAIT: Duration = Duration::from_secs(10);

    #[test]
    fn highest_priority_first_then_arrival_order() {
        let now = Instant::now();
        let mut g = Gate::new(0);
        for (p, name) in [(10, "a"), (200, "b"), (10, "c"), (200, "d"), (128, "e")] {
            assert_eq!(g.admit(p, None, WAIT, name, now), Admit::Queued);
        }
        let order: Vec<_> = std::iter::from_fn(|| g.next_due()).collect();
        assert_eq!(order, ["b", "d", "e", "a", "c"]);
    }

    #[test]
    fn a_held_lock_postpones_others_and_lets_the_holder_through() {
        let now = Instant::now();
        let mut g = Gate::new(41);
        let h = g.grant("alice", Duration::from_secs(3), now);
        assert_eq!(h.fence, 42);
        assert_eq!(g.admit(128, None, WAIT, "bob", now), Admit::Queued);
        assert_eq!(g.next_due(), None, "nothing passes a held lock");
        assert_eq!(
            g.admit(128, Some(42), WAIT, "alice", now),
            Admit::Now("alice")
        );
        assert_eq!(
            g.admit(128, Some(41), WAIT, "old", now),
            Admit::Stale {
                fence: 41,
                item: "old"
            }
        );
        assert_eq!(g.release(41), Err(Some(42)));
        assert!(g.release(42).is_ok());
        assert_eq!(g.next_due(), Some("bob"));
        // After the release, the old fence is stale too.
        assert!(matches!(
            g.admit(1, Some(42), WAIT, "x", now),
            Admit::Stale { .. }
        ));
    }

    #[test]
    fn grants_lapse_unless_renewed_and_end_with_their_owner() {
        let t0 = Instant::now();
        let ttl = Duration::from_millis(2500);
        let mut g: Gate<&str> = Gate::new(0);
        g.grant("alice", ttl, t0);
        // A command at 2 s renews the grant to 4.5 s.
        assert!(matches!(
            g.admit(1, Some(1), WAIT, "cmd", t0 + Duration::from_secs(2)),
            Admit::Now(_)
        ));
        assert_eq!(g.expire(t0 + Duration::from_secs(4)), None);
        assert_eq!(
            g.expire(t0 + Duration::from_millis(4500)).map(|h| h.fence),
            Some(1)
        );
        g.grant("bob", ttl, t0);
        assert_eq!(g.owner_gone("alice"), None);
        assert_eq!(g.owner_gone("bob").map(|h| h.fence), Some(2));
    }

    #[test]
    fn overdue_requests_leave_the_queue_in_arrival_order() {
        let t0 = Instant::now();
        let mut g = Gate::new(0);
        g.grant("alice", Duration::from_secs(60), t0);
        g.admit(1, None, Duration::from_millis(100), "short", t0);
        g.admit(9, None, Duration::from_secs(5), "long", t0);
        g.admit(5, None, Duration::from_millis(50), "shorter", t0);
        assert!(g.overdue(t0 + Duration::from_millis(10)).is_empty());
        assert_eq!(
            g.overdue(t0 + Duration::from_millis(200)),
            ["short", "shorter"]
        );
        assert_eq!(g.queued(), 1);
    }

    #[test]
    fn a_suppressor_refuses_lower_priorities_until_its_stream_stops() {
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let mut g: Gate<()> = Gate::new(0);
        assert!(g.suppressed(0, t0).is_none(), "nothing suppresses at first");
        g.suppress(200, Some("escape".into()), ms(300), t0);
        assert_eq!(
            g.suppressed(100, t0 + ms(299)).map(|s| s.priority),
            Some(200)
        );
        assert!(
            g.suppressed(200, t0 + ms(10)).is_none(),
            "its own priority passes"
        );
        assert!(
            g.suppressed(250, t0 + ms(10)).is_none(),
            "a higher one passes"
        );
        // A lower priority's claim does not shorten or replace it.
        g.suppress(100, None, ms(1000), t0 + ms(100));
        assert_eq!(
            g.suppressed(50, t0 + ms(200)).map(|s| s.priority),
            Some(200)
        );
        assert!(g.suppressed(150, t0 + ms(200)).is_some());
        // The stream goes on: each command renews the claim.
        g.suppress(200, Some("escape".into()), ms(300), t0 + ms(250));
        assert!(g.suppressed(100, t0 + ms(500)).is_some());
        // It falls silent: the lower ones get through again.
        assert!(g.suppressed(100, t0 + ms(550)).is_none());
        // Once it lapsed, a lower priority may claim in its turn.
        g.suppress(100, None, ms(300), t0 + ms(600));
        assert_eq!(
            g.suppressed(50, t0 + ms(700)).map(|s| s.priority),
            Some(100)
        );
        // A zero time constant suppresses nothing.
        let mut g: Gate<()> = Gate::new(0);
        g.suppress(200, None, Duration::ZERO, t0);
        assert!(g.suppressed(0, t0).is_none());
    }

    #[test]
    fn a_restored_grant_keeps_its_fence_and_later_grants_go_above() {
        let now = Instant::now();
        let mut g: Gate<()> = Gate::new(0);
        g.restore(
            &LockInfo {
                holder: "alice".into(),
                fence: 77,
            },
            Duration::from_secs(3),
            now,
        );
        assert!(matches!(
            g.admit(1, Some(77), WAIT, (), now),
            Admit::Now(())
        ));
        g.release(77).unwrap();
        assert_eq!(g.grant("bob", Duration::from_secs(3), now).fence, 78);
    }
}
