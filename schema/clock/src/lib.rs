//! Simulated time that advances only when everyone has finished with the
//! present instant: ROS's `use_sim_time` with a lock-step simulator.
//!
//! How this crate is laid out (the clock's handle in this file, its state in `sched.rs`,
//! participants in `party.rs`, time in `time.rs`; [`Stamp`] and [`Hold`],
//! for a run split into processes, in `sched/rounds.rs`):
//! - [`LockStep`]: the clock a simulator steps. It counts the
//!   *participants* that are busy; [`LockStep::settled`] waits until none
//!   is, and [`LockStep::advance`] moves time on and wakes the sleepers
//!   that are due.
//! - [`wrap`], [`spawn`], [`LockStep::participate`]: a future run as a
//!   participant. It is busy while it runs and while it waits for
//!   something unmarked (a query's answer, say); it is idle while every
//!   wait it is in is an [`idle`] wait or a [`sleep`]. Anything that wakes
//!   it makes it busy again at once, on the waker's own thread, so a
//!   message passed from one participant to another cannot slip between
//!   two steps.
//! - [`sleep`], [`interval`], [`timeout`], [`now_ms`]: simulated time
//!   inside a participant, tokio's time anywhere else, so servers and
//!   clients are written once for both.
//! - [`idle`] and [`busy`]: how a participant marks what it waits for:
//!   something another participant or the clock provides (a stream's next
//!   message, a semaphore) is idle; something a passive server answers at
//!   once is busy.
//!
//! - [`Instant`]: a point in simulated time in a participant, on the wall
//!   clock elsewhere.
//! - [`subscribed`] and [`sending`]: a participant's subscription and
//!   publication, counted so that a message still crossing the network
//!   keeps the clock busy until it arrives.
//! - [`External`] ([`LockStep::external`]): a party in another process,
//!   busy from the moment it is sent an instant until it says it is done.
//! - [`Stamp`], [`Hold`], [`LockStep::hand_over`]: in a run split into
//!   processes, the requests of one round handed to a server in the same
//!   order in every run, whatever order they arrived in.
//!
//! A participant that waits on several things at once writes
//! `tokio::select! { biased; … }`: without `biased` tokio polls the
//! branches in a random order, and two that are ready at one instant
//! (a scan and a light, say) would be taken in a different order from one
//! run to the next.
//!
//! A run is then the same whatever the machine's load: every reaction to
//! what happened at simulated time `t` is complete before the world takes
//! its next step. And one participant runs at a time, taking turns in the
//! order they were created among those woken: what wakes whom is decided
//! by what ran before, not by threads, so the same start gives the same
//! run.

mod party;
mod sched;
mod time;
pub use party::{
    busy, compute, idle, is_lockstep, now_ms, sending, spawn, subscribed, wrap, External, Inbound,
    Marked, Participant,
};
pub use sched::rounds::{in_rounds, name_hash, stamp, Held, Hold, Stamp};
pub use time::{interval, sleep, timeout, Elapsed, Instant, Interval, Sleep};

use sched::*;
use std::collections::BTreeMap;
use std::future::Future;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, Weak};
use std::task::Waker;

/// A lock-step clock: simulated time in milliseconds, advanced by whoever
/// steps the world, only when every participant has settled.
#[derive(Clone)]
pub struct LockStep {
    sched: Arc<Sched>,
}

impl Default for LockStep {
    fn default() -> Self {
        LockStep::new(0)
    }
}

impl LockStep {
    /// A clock at `start_ms`, with no participant yet.
    pub fn new(start_ms: u64) -> LockStep {
        LockStep {
            sched: Arc::new(Sched {
                now_ms: AtomicU64::new(start_ms),
                busy: AtomicUsize::new(0),
                settled: tokio::sync::Notify::new(),
                timers: Mutex::new(BTreeMap::new()),
                next_id: AtomicU64::new(0),
                parts: Mutex::new(Vec::new()),
                next_part: AtomicU64::new(0),
                turn: Mutex::new(Turn::default()),
                subs: Mutex::new(Subs::default()),
                next_sub: AtomicU64::new(0),
                externals: Mutex::new(Vec::new()),
                activity: AtomicU64::new(0),
                rounds: Mutex::new(rounds::Rounds::default()),
            }),
        }
    }

    /// Simulated time, ms.
    pub fn now_ms(&self) -> u64 {
        self.sched.now_ms.load(Ordering::Acquire)
    }

    /// Runs `fut` as a participant named `name` (for the messages of a
    /// clock that waits too long).
    pub fn participate<F: Future>(&self, name: &str, fut: F) -> Participant<F> {
        Participant {
            part: Some(Part::new(&self.sched, name)),
            inner: Box::pin(fut),
        }
    }

    /// How often a participant of this process has become busy so far
    /// (made, or woken by a message, a timer or another participant); the
    /// parties in other processes are not counted. Two equal looks mean
    /// nothing happened in between.
    pub fn activity(&self) -> u64 {
        self.sched.activity.load(Ordering::Acquire)
    }

    /// How many participants are busy.
    pub fn busy(&self) -> usize {
        self.sched.busy.load(Ordering::Acquire)
    }

    /// The names of the participants that are busy, those of other
    /// processes included.
    pub fn busy_names(&self) -> Vec<String> {
        let mut names: Vec<String> = locked(&self.sched.parts)
            .iter()
            .filter_map(Weak::upgrade)
            .filter(|p| {
                let s = locked(&p.state);
                !s.parked && !s.done
            })
            .map(|p| p.name.clone())
            .collect();
        names.extend(
            locked(&self.sched.externals)
                .iter()
                .filter_map(Weak::upgrade)
                .filter(|e| *locked(&e.busy))
                .map(|e| e.name.clone()),
        );
        names
    }

    /// The clock's state in a line, for a report of a clock that does not
    /// move: the time, who is busy, who holds the turn and who waits for
    /// one, the sleepers and the messages in flight.
    pub fn describe(&self) -> String {
        let names: BTreeMap<u64, String> = locked(&self.sched.parts)
            .iter()
            .filter_map(Weak::upgrade)
            .map(|p| (p.id, p.name.clone()))
            .collect();
        let name = |id: u64| match id {
            STEPPER => "the clock".to_string(),
            id => names
                .get(&id)
                .cloned()
                .unwrap_or_else(|| format!("participant {id} (gone)")),
        };
        let (holder, ready, announced) = {
            let t = locked(&self.sched.turn);
            let ready: Vec<String> = t
                .ready
                .iter()
                .map(|(&id, w)| {
                    format!(
                        "{}{}",
                        name(id),
                        if w.is_none() { " (never polled)" } else { "" }
                    )
                })
                .collect();
            (t.holder.map(name), ready, t.announced)
        };
        let (sleepers, next_due) = {
            let timers = locked(&self.sched.timers);
            (timers.len(), timers.keys().next().map(|(t, _)| *t))
        };
        format!(
            "time {} ms{}; busy {} {:?}; turn held by {}; waiting for a turn {:?}; {} sleeper(s), next due {:?}; {} message(s) in flight",
            self.now_ms(),
            if announced { " (a new time announced)" } else { "" },
            self.busy(),
            self.busy_names(),
            holder.as_deref().unwrap_or("nobody"),
            ready,
            sleepers,
            next_due,
            self.in_flight()
        )
    }

    /// A party in another process (a client following this clock over the
    /// network): idle until [`External::expect`] makes it busy, busy until
    /// [`External::done`]; gone when dropped.
    pub fn external(&self, name: &str) -> External {
        let state = Arc::new(ExternalState {
            name: name.to_string(),
            busy: Mutex::new(false),
        });
        let mut all = locked(&self.sched.externals);
        all.retain(|e| e.strong_count() > 0);
        all.push(Arc::downgrade(&state));
        External {
            sched: self.sched.clone(),
            state,
        }
    }

    /// Waits until no participant is busy.
    pub async fn settled(&self) {
        loop {
            let notified = self.sched.settled.notified();
            tokio::pin!(notified);
            notified.as_mut().enable();
            if self.busy() == 0 {
                return;
            }
            notified.await;
        }
    }

    /// Messages sent by participants to participants' subscriptions and
    /// not yet received.
    pub fn in_flight(&self) -> usize {
        locked(&self.sched.subs)
            .all()
            .map(|e| e.pending.load(Ordering::Acquire))
            .sum()
    }

    /// Gives up on every message in flight (a publication dropped on the
    /// way): the clock no longer waits for them. Returns how many.
    pub fn forget_in_flight(&self) -> usize {
        let entries: Vec<Arc<SubEntry>> = locked(&self.sched.subs).all().cloned().collect();
        let mut n = 0;
        for e in entries {
            while e.take_one() {
                n += 1;
                self.sched.release();
            }
        }
        n
    }

    /// The earliest time a sleeper waits for, if any.
    pub fn next_due(&self) -> Option<u64> {
        locked(&self.sched.timers).keys().next().map(|(t, _)| *t)
    }

    /// Moves time on to `now_ms` (never back) and wakes every sleeper due
    /// by then; each is busy before this returns. Unconditional: for a
    /// clock that follows another (the simulator's, over the network).
    pub async fn advance(&self, now_ms: u64) {
        self.take_turn().await;
        self.wake_due(now_ms);
        locked(&self.sched.turn).announced = false;
        self.sched.pass(STEPPER);
    }

    /// Says, from wherever the new time is heard (a subscriber's callback),
    /// that [`LockStep::advance`] is coming: until it has run, no
    /// participant takes a free turn. A message heard after the time and
    /// before the clock moved then wakes its reader at the new time, not
    /// the old, however the threads are scheduled. Call only when an
    /// `advance` will follow.
    pub fn announce(&self) {
        locked(&self.sched.turn).announced = true;
    }

    /// The step of the clock's owner: if no participant is busy once the
    /// turn is taken, runs `next` (which moves the world on and returns its
    /// new time), moves time on to it and wakes the sleepers due; `None`
    /// when a participant became busy since [`LockStep::settled`] (made,
    /// or woken from outside), so that it finishes at the present instant.
    /// Nobody runs meanwhile: a participant made or woken during the step
    /// starts at the new time.
    pub async fn try_advance(&self, next: impl FnOnce() -> u64) -> Option<u64> {
        self.take_turn().await;
        if self.busy() > 0 {
            self.sched.pass(STEPPER);
            return None;
        }
        let now_ms = next();
        self.wake_due(now_ms);
        self.sched.pass(STEPPER);
        Some(now_ms)
    }

    /// Takes the turn for the clock itself.
    async fn take_turn(&self) {
        // Everyone woken here waits until all are: then the first created
        // goes first, whichever timer fired first.
        loop {
            let taken = {
                let mut t = locked(&self.sched.turn);
                t.holder.is_none() && {
                    t.holder = Some(STEPPER);
                    true
                }
            };
            if taken {
                return;
            }
            // The last participant to park is passing it on; a blocking
            // wait here could keep it from this thread.
            tokio::task::yield_now().await;
        }
    }

    fn wake_due(&self, now_ms: u64) {
        self.sched.now_ms.fetch_max(now_ms, Ordering::AcqRel);
        let now = self.now_ms();
        let due: Vec<Waker> = {
            let mut timers = locked(&self.sched.timers);
            let later = timers.split_off(&(now + 1, 0));
            std::mem::replace(&mut *timers, later)
                .into_values()
                .collect()
        };
        for w in due {
            w.wake();
        }
    }
}

#[cfg(test)]
mod tests;
