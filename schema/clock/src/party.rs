//! Participants: futures that run under the clock (busy while they run,
//! idle while they only wait), parties in other processes, counted
//! subscriptions and publications, and the marks a participant puts on
//! what it waits for.

use crate::sched::*;
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

/// A future run as a participant of a [`LockStep`](crate::LockStep) clock
/// (or as itself, when made outside any).
pub struct Participant<F: Future> {
    pub(crate) part: Option<Arc<Part>>,
    pub(crate) inner: Pin<Box<F>>,
}

pub(crate) struct ParkWaker {
    pub(crate) part: Arc<Part>,
    pub(crate) inner: Waker,
}

impl Wake for ParkWaker {
    fn wake(self: Arc<Self>) {
        self.wake_by_ref();
    }

    fn wake_by_ref(self: &Arc<Self>) {
        let next = {
            // Under the participant's own lock, which its end takes too: a
            // waker left behind (in a channel, a timer) and called as the
            // participant ends either comes first, and the end takes the
            // turn back, or finds it ended. Given to an ended participant,
            // the turn would never be passed on.
            let mut s = locked(&self.part.state);
            if s.done {
                return;
            }
            self.part.wake_locked(&mut s);
            // Polled when its turn comes.
            self.part.sched.ready(self.part.id, Some(&self.inner))
        };
        if let Some(w) = next {
            w.wake();
        }
    }
}

impl<F: Future> Future for Participant<F> {
    type Output = F::Output;

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<F::Output> {
        let Some(part) = self.part.clone() else {
            return self.inner.as_mut().poll(cx);
        };
        if !part.sched.take(part.id, cx.waker()) {
            // Not its turn: it stays busy and is woken when it is.
            return Poll::Pending;
        }
        part.wake();
        let seen = part.wakes();
        let waker = Waker::from(Arc::new(ParkWaker {
            part: part.clone(),
            inner: cx.waker().clone(),
        }));
        let mut inner_cx = Context::from_waker(&waker);
        let mut outer = Restore(Some(CURRENT.with(|c| {
            c.borrow_mut().replace(Frame {
                part: part.clone(),
                idle: false,
                busy: false,
                hold: false,
            })
        })));
        let polled = self.inner.as_mut().poll(&mut inner_cx);
        let frame = outer.now();
        match polled {
            Poll::Ready(v) => {
                part.finish();
                self.part = None;
                Poll::Ready(v)
            }
            Poll::Pending => {
                if frame.as_ref().is_some_and(|f| f.idle && !f.busy) {
                    part.park(seen);
                }
                if !frame.is_some_and(|f| f.hold) {
                    part.sched.pass(part.id);
                }
                Poll::Pending
            }
        }
    }
}

/// The frame a participant's poll replaced on its thread, put back when
/// the poll ends, by panicking too: left behind, the frame of a panicked
/// participant would make the next task polled on the thread take itself
/// for that participant.
pub(crate) struct Restore(Option<Option<Frame>>);

impl Restore {
    /// Puts the replaced frame back; the poll's own.
    pub(crate) fn now(&mut self) -> Option<Frame> {
        let outer = self.0.take().flatten();
        CURRENT.with(|c| std::mem::replace(&mut *c.borrow_mut(), outer))
    }
}

impl Drop for Restore {
    fn drop(&mut self) {
        if self.0.is_some() {
            self.now();
        }
    }
}

impl<F: Future> Drop for Participant<F> {
    fn drop(&mut self) {
        if let Some(p) = self.part.take() {
            p.finish();
        }
    }
}

/// `fut` as a participant named `name` of the clock of the participant
/// this is called in; as itself outside any.
pub fn wrap<F: Future>(name: &str, fut: F) -> Participant<F> {
    Participant {
        part: current().map(|p| Part::new(&p.sched, name)),
        inner: Box::pin(fut),
    }
}

/// Spawns `fut` on tokio, as a participant named `name` when called in
/// one.
pub fn spawn<F>(name: &str, fut: F) -> tokio::task::JoinHandle<F::Output>
where
    F: Future + Send + 'static,
    F::Output: Send + 'static,
{
    tokio::spawn(wrap(name, fut))
}

/// Whether this runs in a participant of a lock-step clock.
pub fn is_lockstep() -> bool {
    current().is_some()
}

/// Simulated time in a participant; `None` elsewhere.
pub fn now_ms() -> Option<u64> {
    current().map(|p| p.sched.now_ms.load(Ordering::Acquire))
}

/// A party of a [`LockStep`](crate::LockStep) clock in another process; see
/// [`LockStep::external`](crate::LockStep::external).
pub struct External {
    pub(crate) sched: Arc<Sched>,
    pub(crate) state: Arc<ExternalState>,
}

impl External {
    /// The party has something to do at the present instant (it was sent
    /// the new time): the clock waits for it.
    pub fn expect(&self) {
        let mut busy = locked(&self.state.busy);
        if !*busy {
            *busy = true;
            self.sched.busy.fetch_add(1, Ordering::AcqRel);
        }
    }

    /// The party is done with the present instant.
    pub fn done(&self) {
        let mut busy = locked(&self.state.busy);
        if *busy {
            *busy = false;
            self.sched.release();
        }
    }
}

impl Drop for External {
    fn drop(&mut self) {
        self.done();
    }
}

/// A participant's subscription, registered with its clock so that a
/// message another participant sends to it keeps the clock from moving
/// until it has arrived: without that, a message still crossing the
/// network when everyone else is idle would be seen a step early or late,
/// depending on the machine's load. Call [`Inbound::received`] from the
/// subscription's callback, after the message is handed on.
pub struct Inbound {
    pub(crate) sched: Arc<Sched>,
    pub(crate) id: u64,
    pub(crate) entry: Arc<SubEntry>,
}

/// Registers a subscription whose key expression `matches` a key, when
/// called in a participant of a lock-step clock; `None` elsewhere.
pub fn subscribed(matches: impl Fn(&str) -> bool + Send + Sync + 'static) -> Option<Inbound> {
    let sched = current()?.sched.clone();
    let id = sched.next_sub.fetch_add(1, Ordering::Relaxed);
    let entry = Arc::new(SubEntry {
        matches: Box::new(matches),
        pending: AtomicUsize::new(0),
    });
    locked(&sched.subs).insert(id, entry.clone());
    Some(Inbound { sched, id, entry })
}

/// Announces a message about to be published on `key` by a participant:
/// the clock stays busy until every participant's subscription that
/// matches it has [received](Inbound::received) it. Call before the
/// publication (it could arrive before a call made after). Nothing outside
/// a participant.
pub fn sending(key: &str) {
    let Some(part) = current() else { return };
    let sched = &part.sched;
    let mut subs = locked(&sched.subs);
    for e in subs.matching(key) {
        sched.busy.fetch_add(1, Ordering::AcqRel);
        e.pending.fetch_add(1, Ordering::AcqRel);
    }
}

impl Inbound {
    /// A message arrived (and was handed to whoever reads it).
    pub fn received(&self) {
        if self.entry.take_one() {
            self.sched.release();
        }
    }
}

impl Drop for Inbound {
    fn drop(&mut self) {
        locked(&self.sched.subs).remove(self.id);
        while self.entry.take_one() {
            self.sched.release();
        }
    }
}

/// A wait marked as one the participant is [idle](crate) in or busy in.
pub struct Marked<F: Future> {
    pub(crate) kind: Kind,
    pub(crate) inner: Pin<Box<F>>,
}

impl<F: Future> Future for Marked<F> {
    type Output = F::Output;

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<F::Output> {
        let polled = self.inner.as_mut().poll(cx);
        if polled.is_pending() {
            mark(self.kind);
        } else {
            unmark();
        }
        polled
    }
}

/// Awaits `fut` idle: what it waits for comes from another participant or
/// from the clock (a stream's next message, a semaphore, a sleep).
pub fn idle<F: Future>(fut: F) -> Marked<F> {
    Marked {
        kind: Kind::Idle,
        inner: Box::pin(fut),
    }
}

/// Awaits `fut` busy, even beside idle waits (in a `select!`): it is
/// answered without the clock moving (a query to a server).
pub fn busy<F: Future>(fut: F) -> Marked<F> {
    Marked {
        kind: Kind::Busy,
        inner: Box::pin(fut),
    }
}

/// Awaits `fut`, the participant's own work done elsewhere (on a blocking
/// thread, say), keeping its turn: nobody else runs meanwhile, so what
/// that work reads and changes is the same in every run. Never for a wait
/// on another participant.
pub fn compute<F: Future>(fut: F) -> Marked<F> {
    Marked {
        kind: Kind::Compute,
        inner: Box::pin(fut),
    }
}
