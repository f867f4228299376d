//! The clock's shared state: who is busy, whose turn it is, the timers
//! due, the subscriptions counted, and the participant being polled on
//! each thread. [`crate::LockStep`] is its handle; the participants
//! ([`crate::party`]) and sleeps ([`crate::time`]) change it.

pub(crate) mod rounds;

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, Weak};
use std::task::Waker;

pub(crate) struct Sched {
    pub(crate) now_ms: AtomicU64,
    pub(crate) busy: AtomicUsize,
    pub(crate) settled: tokio::sync::Notify,
    pub(crate) timers: Mutex<BTreeMap<(u64, u64), Waker>>,
    pub(crate) next_id: AtomicU64,
    pub(crate) parts: Mutex<Vec<Weak<Part>>>,
    pub(crate) next_part: AtomicU64,
    pub(crate) turn: Mutex<Turn>,
    /// Participants' subscriptions, for counting messages in flight.
    pub(crate) subs: Mutex<Subs>,
    pub(crate) next_sub: AtomicU64,
    /// Parties in other processes, busy until they say they are done.
    pub(crate) externals: Mutex<Vec<Weak<ExternalState>>>,
    /// How often a participant has become busy (made, or woken from
    /// parked): whether anything happened between two looks.
    pub(crate) activity: AtomicU64,
    /// Rounds of a run split into processes, and the holds that wait on
    /// them.
    pub(crate) rounds: Mutex<rounds::Rounds>,
}

/// The subscriptions the clock counts messages for, with the ones each
/// key published on matches. A fleet's participants publish on a few
/// hundred keys over and over while thousands of subscriptions stand, so
/// matching every subscription at every publication would cost more than
/// the rest of the clock: a key's matches are worked out once and kept up
/// to date as subscriptions come and go.
#[derive(Default)]
pub(crate) struct Subs {
    all: BTreeMap<u64, Arc<SubEntry>>,
    by_key: HashMap<String, Vec<Arc<SubEntry>>>,
}

/// Keys whose matches are kept at most; past it the memo starts again, so
/// keys made up once each (a reply's, say) cannot grow it without bound.
const KEYS_KEPT: usize = 4096;

impl Subs {
    pub(crate) fn insert(&mut self, id: u64, entry: Arc<SubEntry>) {
        for (key, hits) in &mut self.by_key {
            if (entry.matches)(key) {
                hits.push(entry.clone());
            }
        }
        self.all.insert(id, entry);
    }

    pub(crate) fn remove(&mut self, id: u64) {
        if let Some(gone) = self.all.remove(&id) {
            for hits in self.by_key.values_mut() {
                hits.retain(|e| !Arc::ptr_eq(e, &gone));
            }
        }
    }

    /// Every subscription, in the order they were made.
    pub(crate) fn all(&self) -> impl Iterator<Item = &Arc<SubEntry>> {
        self.all.values()
    }

    /// The subscriptions a message on `key` goes to.
    pub(crate) fn matching(&mut self, key: &str) -> &[Arc<SubEntry>] {
        if !self.by_key.contains_key(key) {
            if self.by_key.len() >= KEYS_KEPT {
                self.by_key.clear();
            }
            let hits = self
                .all
                .values()
                .filter(|e| (e.matches)(key))
                .cloned()
                .collect();
            self.by_key.insert(key.to_owned(), hits);
        }
        &self.by_key[key]
    }
}

/// A subscription the clock counts messages for.
pub(crate) struct SubEntry {
    pub(crate) matches: Box<dyn Fn(&str) -> bool + Send + Sync>,
    /// Messages sent to it and not yet received: each keeps the clock busy.
    pub(crate) pending: AtomicUsize,
}

impl SubEntry {
    /// One message fewer in flight, if any was; whether one was.
    pub(crate) fn take_one(&self) -> bool {
        self.pending
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| n.checked_sub(1))
            .is_ok()
    }
}

/// Whose turn it is, and who is waiting for one.
#[derive(Default)]
pub(crate) struct Turn {
    /// The participant running (or [`STEPPER`] while the clock advances).
    pub(crate) holder: Option<u64>,
    /// Woken participants by creation order, with the waker that gets
    /// each polled (none until its task is first polled).
    pub(crate) ready: BTreeMap<u64, Option<Waker>>,
    /// A new time has been heard and not yet moved to: no participant
    /// takes the turn until the clock has (see [`LockStep::announce`](crate::LockStep::announce)).
    pub(crate) announced: bool,
}

/// The turn's holder while the clock wakes its sleepers.
pub(crate) const STEPPER: u64 = u64::MAX;

impl Sched {
    /// `id` was woken: it waits for its turn (`waker` gets it polled).
    /// Returns the waker to call once the caller's locks are let go.
    #[must_use]
    pub(crate) fn ready(&self, id: u64, waker: Option<&Waker>) -> Option<Waker> {
        let mut t = locked(&self.turn);
        let slot = t.ready.entry(id).or_insert(None);
        if let Some(w) = waker {
            *slot = Some(w.clone());
        }
        if t.holder == Some(id) {
            // Woken in its own turn: polled again at once if it keeps the
            // turn (see [`compute`]), else when it comes round.
            return waker.cloned();
        }
        if t.holder.is_some() || t.announced {
            return None;
        }
        grant(&mut t)
    }

    /// Whether `id` holds the turn, or takes it now (nobody holds it and
    /// `id` is the first woken); else `id` waits, to be woken by `waker`.
    pub(crate) fn take(&self, id: u64, waker: &Waker) -> bool {
        let mut t = locked(&self.turn);
        if t.holder == Some(id) {
            t.ready.remove(&id);
            return true;
        }
        match t.ready.get_mut(&id) {
            Some(slot) => *slot = Some(waker.clone()),
            // Polled without being woken: it waits for its wake.
            None => return false,
        }
        if t.holder.is_none() && !t.announced && t.ready.keys().next() == Some(&id) {
            t.ready.remove(&id);
            t.holder = Some(id);
            return true;
        }
        false
    }

    /// `id` is done with its turn (if it held it); the next woken gets it.
    pub(crate) fn pass(&self, id: u64) {
        let next = {
            let mut t = locked(&self.turn);
            if t.holder != Some(id) {
                return;
            }
            t.holder = None;
            if t.announced {
                // The clock is about to move on: it takes the turn next.
                return;
            }
            grant(&mut t)
        };
        if let Some(w) = next {
            w.wake();
        }
    }
}

/// Gives the free turn to the first woken; the waker to call.
pub(crate) fn grant(t: &mut Turn) -> Option<Waker> {
    let (&id, _) = t.ready.iter().next()?;
    t.holder = Some(id);
    t.ready.get(&id).cloned().flatten()
}

pub(crate) fn locked<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// One participant: busy or parked.
pub(crate) struct Part {
    pub(crate) sched: Arc<Sched>,
    pub(crate) id: u64,
    pub(crate) name: String,
    pub(crate) state: Mutex<PartState>,
}

#[derive(Default)]
pub(crate) struct PartState {
    pub(crate) parked: bool,
    pub(crate) done: bool,
    /// Wakes so far: a wake during a poll keeps the participant busy.
    pub(crate) wakes: u64,
}

impl Part {
    pub(crate) fn new(sched: &Arc<Sched>, name: &str) -> Arc<Part> {
        sched.busy.fetch_add(1, Ordering::AcqRel);
        sched.activity.fetch_add(1, Ordering::AcqRel);
        let id = sched.next_part.fetch_add(1, Ordering::Relaxed);
        // A new participant waits for its first turn like a woken one.
        if let Some(w) = sched.ready(id, None) {
            w.wake();
        }
        let part = Arc::new(Part {
            sched: sched.clone(),
            id,
            name: name.to_string(),
            state: Mutex::new(PartState::default()),
        });
        let mut parts = locked(&sched.parts);
        parts.retain(|p| p.strong_count() > 0);
        parts.push(Arc::downgrade(&part));
        part
    }

    /// Busy again (woken, or polled).
    pub(crate) fn wake(&self) {
        self.wake_locked(&mut locked(&self.state));
    }

    pub(crate) fn wake_locked(&self, s: &mut PartState) {
        s.wakes += 1;
        if s.parked && !s.done {
            s.parked = false;
            self.sched.busy.fetch_add(1, Ordering::AcqRel);
            self.sched.activity.fetch_add(1, Ordering::AcqRel);
        }
    }

    pub(crate) fn wakes(&self) -> u64 {
        locked(&self.state).wakes
    }

    /// Parked, unless woken since `seen` wakes.
    pub(crate) fn park(&self, seen: u64) {
        let mut s = locked(&self.state);
        if !s.parked && !s.done && s.wakes == seen {
            s.parked = true;
            self.sched.release();
        }
    }

    /// Gone for good.
    pub(crate) fn finish(&self) {
        {
            let mut s = locked(&self.state);
            if s.done {
                return;
            }
            s.done = true;
            if !s.parked {
                self.sched.release();
            }
        }
        locked(&self.sched.turn).ready.remove(&self.id);
        self.sched.pass(self.id);
    }
}

impl Sched {
    pub(crate) fn release(&self) {
        if self.busy.fetch_sub(1, Ordering::AcqRel) == 1 {
            self.settled.notify_one();
        }
    }
}

thread_local! {
    /// The participant being polled on this thread, and what its waits
    /// said during this poll.
    pub(crate) static CURRENT: RefCell<Option<Frame>> = const { RefCell::new(None) };
}

pub(crate) struct Frame {
    pub(crate) part: Arc<Part>,
    pub(crate) idle: bool,
    pub(crate) busy: bool,
    /// Waiting for its own work (see [`compute`]): keeps the turn.
    pub(crate) hold: bool,
}

pub(crate) fn current() -> Option<Arc<Part>> {
    CURRENT.with(|c| c.borrow().as_ref().map(|f| f.part.clone()))
}

/// A marked wait finished: what the participant waits on next (in this
/// same poll, a `select!` branch's body, say) decides, not the waits
/// polled before it.
pub(crate) fn unmark() {
    CURRENT.with(|c| {
        if let Some(f) = c.borrow_mut().as_mut() {
            f.idle = false;
            f.busy = false;
            f.hold = false;
        }
    });
}

pub(crate) fn mark(kind: Kind) {
    CURRENT.with(|c| {
        if let Some(f) = c.borrow_mut().as_mut() {
            match kind {
                Kind::Idle => f.idle = true,
                Kind::Busy => f.busy = true,
                Kind::Compute => {
                    f.busy = true;
                    f.hold = true;
                }
            }
        }
    });
}

/// What a marked wait waits for.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Kind {
    Idle,
    Busy,
    Compute,
}

pub(crate) struct ExternalState {
    pub(crate) name: String,
    pub(crate) busy: Mutex<bool>,
}
