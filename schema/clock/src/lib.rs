//! Simulated time that advances only when everyone has finished with the
//! present instant: ROS's `use_sim_time` with a lock-step simulator.
//!
//! How this crate is laid out (the clock in this file; [`Stamp`] and
//! [`Hold`], for a run split into processes, in `rounds.rs`):
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

mod rounds;
pub use rounds::{in_rounds, name_hash, stamp, Held, Hold, Stamp};

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, Weak};
use std::task::{Context, Poll, Wake, Waker};
use std::time::Duration;

/// A lock-step clock: simulated time in milliseconds, advanced by whoever
/// steps the world, only when every participant has settled.
#[derive(Clone)]
pub struct LockStep {
    sched: Arc<Sched>,
}

struct Sched {
    now_ms: AtomicU64,
    busy: AtomicUsize,
    settled: tokio::sync::Notify,
    timers: Mutex<BTreeMap<(u64, u64), Waker>>,
    next_id: AtomicU64,
    parts: Mutex<Vec<Weak<Part>>>,
    next_part: AtomicU64,
    turn: Mutex<Turn>,
    /// Participants' subscriptions, for counting messages in flight.
    subs: Mutex<BTreeMap<u64, Arc<SubEntry>>>,
    next_sub: AtomicU64,
    /// Parties in other processes, busy until they say they are done.
    externals: Mutex<Vec<Weak<ExternalState>>>,
    /// How often a participant has become busy (made, or woken from
    /// parked): whether anything happened between two looks.
    activity: AtomicU64,
    /// Rounds of a run split into processes, and the holds that wait on
    /// them.
    rounds: Mutex<rounds::Rounds>,
}

/// A subscription the clock counts messages for.
struct SubEntry {
    matches: Box<dyn Fn(&str) -> bool + Send + Sync>,
    /// Messages sent to it and not yet received: each keeps the clock busy.
    pending: AtomicUsize,
}

impl SubEntry {
    /// One message fewer in flight, if any was; whether one was.
    fn take_one(&self) -> bool {
        self.pending
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| n.checked_sub(1))
            .is_ok()
    }
}

/// Whose turn it is, and who is waiting for one.
#[derive(Default)]
struct Turn {
    /// The participant running (or [`STEPPER`] while the clock advances).
    holder: Option<u64>,
    /// Woken participants by creation order, with the waker that gets
    /// each polled (none until its task is first polled).
    ready: BTreeMap<u64, Option<Waker>>,
    /// A new time has been heard and not yet moved to: no participant
    /// takes the turn until the clock has (see [`LockStep::announce`]).
    announced: bool,
}

/// The turn's holder while the clock wakes its sleepers.
const STEPPER: u64 = u64::MAX;

impl Sched {
    /// `id` was woken: it waits for its turn (`waker` gets it polled).
    /// Returns the waker to call once the caller's locks are let go.
    #[must_use]
    fn ready(&self, id: u64, waker: Option<&Waker>) -> Option<Waker> {
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
    fn take(&self, id: u64, waker: &Waker) -> bool {
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
    fn pass(&self, id: u64) {
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
fn grant(t: &mut Turn) -> Option<Waker> {
    let (&id, _) = t.ready.iter().next()?;
    t.holder = Some(id);
    t.ready.get(&id).cloned().flatten()
}

fn locked<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// One participant: busy or parked.
struct Part {
    sched: Arc<Sched>,
    id: u64,
    name: String,
    state: Mutex<PartState>,
}

#[derive(Default)]
struct PartState {
    parked: bool,
    done: bool,
    /// Wakes so far: a wake during a poll keeps the participant busy.
    wakes: u64,
}

impl Part {
    fn new(sched: &Arc<Sched>, name: &str) -> Arc<Part> {
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
    fn wake(&self) {
        self.wake_locked(&mut locked(&self.state));
    }

    fn wake_locked(&self, s: &mut PartState) {
        s.wakes += 1;
        if s.parked && !s.done {
            s.parked = false;
            self.sched.busy.fetch_add(1, Ordering::AcqRel);
            self.sched.activity.fetch_add(1, Ordering::AcqRel);
        }
    }

    fn wakes(&self) -> u64 {
        locked(&self.state).wakes
    }

    /// Parked, unless woken since `seen` wakes.
    fn park(&self, seen: u64) {
        let mut s = locked(&self.state);
        if !s.parked && !s.done && s.wakes == seen {
            s.parked = true;
            self.sched.release();
        }
    }

    /// Gone for good.
    fn finish(&self) {
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
    fn release(&self) {
        if self.busy.fetch_sub(1, Ordering::AcqRel) == 1 {
            self.settled.notify_one();
        }
    }
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
                subs: Mutex::new(BTreeMap::new()),
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
            .values()
            .map(|e| e.pending.load(Ordering::Acquire))
            .sum()
    }

    /// Gives up on every message in flight (a publication dropped on the
    /// way): the clock no longer waits for them. Returns how many.
    pub fn forget_in_flight(&self) -> usize {
        let entries: Vec<Arc<SubEntry>> = locked(&self.sched.subs).values().cloned().collect();
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

thread_local! {
    /// The participant being polled on this thread, and what its waits
    /// said during this poll.
    static CURRENT: RefCell<Option<Frame>> = const { RefCell::new(None) };
}

struct Frame {
    part: Arc<Part>,
    idle: bool,
    busy: bool,
    /// Waiting for its own work (see [`compute`]): keeps the turn.
    hold: bool,
}

fn current() -> Option<Arc<Part>> {
    CURRENT.with(|c| c.borrow().as_ref().map(|f| f.part.clone()))
}

/// A marked wait finished: what the participant waits on next (in this
/// same poll, a `select!` branch's body, say) decides, not the waits
/// polled before it.
fn unmark() {
    CURRENT.with(|c| {
        if let Some(f) = c.borrow_mut().as_mut() {
            f.idle = false;
            f.busy = false;
            f.hold = false;
        }
    });
}

fn mark(kind: Kind) {
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
enum Kind {
    Idle,
    Busy,
    Compute,
}

/// A future run as a participant of a [`LockStep`] clock (or as itself,
/// when made outside any).
pub struct Participant<F: Future> {
    part: Option<Arc<Part>>,
    inner: Pin<Box<F>>,
}

struct ParkWaker {
    part: Arc<Part>,
    inner: Waker,
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
struct Restore(Option<Option<Frame>>);

impl Restore {
    /// Puts the replaced frame back; the poll's own.
    fn now(&mut self) -> Option<Frame> {
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

/// A party of a [`LockStep`] clock in another process; see
/// [`LockStep::external`].
pub struct External {
    sched: Arc<Sched>,
    state: Arc<ExternalState>,
}

struct ExternalState {
    name: String,
    busy: Mutex<bool>,
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
    sched: Arc<Sched>,
    id: u64,
    entry: Arc<SubEntry>,
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
    let subs = locked(&sched.subs);
    for e in subs.values().filter(|e| (e.matches)(key)) {
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
        locked(&self.sched.subs).remove(&self.id);
        while self.entry.take_one() {
            self.sched.release();
        }
    }
}

/// A wait marked as one the participant is [idle](crate) in or busy in.
pub struct Marked<F: Future> {
    kind: Kind,
    inner: Pin<Box<F>>,
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

/// A sleep in simulated time within a participant, in tokio's time
/// elsewhere.
pub struct Sleep {
    kind: SleepKind,
}

enum SleepKind {
    Wall(Pin<Box<tokio::time::Sleep>>),
    Sim {
        sched: Arc<Sched>,
        due: u64,
        key: Option<(u64, u64)>,
    },
}

/// Sleeps for `d`: simulated time in a participant of a lock-step clock,
/// tokio's time elsewhere.
pub fn sleep(d: Duration) -> Sleep {
    match current() {
        Some(p) => {
            let now = p.sched.now_ms.load(Ordering::Acquire);
            sleep_until_sim(&p.sched, now.saturating_add(ms(d)))
        }
        None => Sleep {
            kind: SleepKind::Wall(Box::pin(tokio::time::sleep(d))),
        },
    }
}

fn ms(d: Duration) -> u64 {
    u64::try_from(d.as_millis()).unwrap_or(u64::MAX)
}

fn sleep_until_sim(sched: &Arc<Sched>, due: u64) -> Sleep {
    Sleep {
        kind: SleepKind::Sim {
            sched: sched.clone(),
            due,
            key: None,
        },
    }
}

impl Future for Sleep {
    type Output = ();

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<()> {
        match &mut self.kind {
            SleepKind::Wall(s) => s.as_mut().poll(cx),
            SleepKind::Sim { sched, due, key } => {
                let mut timers = locked(&sched.timers);
                if sched.now_ms.load(Ordering::Acquire) >= *due {
                    if let Some(k) = key.take() {
                        timers.remove(&k);
                    }
                    drop(timers);
                    unmark();
                    return Poll::Ready(());
                }
                let k = *key
                    .get_or_insert_with(|| (*due, sched.next_id.fetch_add(1, Ordering::Relaxed)));
                timers.insert(k, cx.waker().clone());
                drop(timers);
                mark(Kind::Idle);
                Poll::Pending
            }
        }
    }
}

impl Drop for Sleep {
    fn drop(&mut self) {
        if let SleepKind::Sim {
            sched,
            key: Some(k),
            ..
        } = &self.kind
        {
            locked(&sched.timers).remove(k);
        }
    }
}

/// Ticks every `period`, the first at once: simulated time in a
/// participant, tokio's elsewhere (a late tick is delayed, not bunched).
pub struct Interval {
    kind: IntervalKind,
}

enum IntervalKind {
    Wall(tokio::time::Interval),
    Sim {
        sched: Arc<Sched>,
        period: u64,
        next: u64,
    },
}

/// An [`Interval`] of `period` (at least a millisecond in simulated time).
pub fn interval(period: Duration) -> Interval {
    match current() {
        Some(p) => Interval {
            kind: IntervalKind::Sim {
                next: p.sched.now_ms.load(Ordering::Acquire),
                sched: p.sched.clone(),
                period: ms(period).max(1),
            },
        },
        None => {
            let mut i = tokio::time::interval(period);
            i.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            Interval {
                kind: IntervalKind::Wall(i),
            }
        }
    }
}

impl Interval {
    /// The next tick.
    pub async fn tick(&mut self) {
        match &mut self.kind {
            IntervalKind::Wall(i) => {
                i.tick().await;
            }
            IntervalKind::Sim {
                sched,
                period,
                next,
            } => {
                let due = *next;
                sleep_until_sim(sched, due).await;
                let now = sched.now_ms.load(Ordering::Acquire);
                // Ticks stay on the grid start + k·period, skipping any
                // already past (a clock that jumped).
                let mut n = due.saturating_add(*period);
                while n <= now && *period > 0 {
                    n = n.saturating_add(*period);
                }
                *next = n;
            }
        }
    }
}

/// A point in time: simulated in a participant of a lock-step clock, the
/// wall clock's elsewhere (for deadlines and round trips that must not
/// depend on how fast the machine computes).
///
/// Instants of one kind compare by time. The two kinds do not meet in one
/// process's server (everything it runs is a participant or nothing is);
/// should they, a simulated instant counts as the earlier.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Instant {
    /// Simulated milliseconds.
    Sim(u64),
    /// The wall clock.
    Wall(std::time::Instant),
}

impl Instant {
    /// Now.
    pub fn now() -> Instant {
        match now_ms() {
            Some(ms) => Instant::Sim(ms),
            None => Instant::Wall(std::time::Instant::now()),
        }
    }

    /// Time since `self` (zero if `self` is later, or of the other kind).
    pub fn elapsed(&self) -> Duration {
        match (self, Instant::now()) {
            (Instant::Sim(t), Instant::Sim(now)) => Duration::from_millis(now.saturating_sub(*t)),
            (Instant::Wall(t), Instant::Wall(now)) => now.saturating_duration_since(*t),
            _ => Duration::ZERO,
        }
    }

    /// Time from `earlier` to `self` (zero if `earlier` is later, or of
    /// the other kind).
    pub fn saturating_duration_since(&self, earlier: Instant) -> Duration {
        match (self, earlier) {
            (Instant::Sim(t), Instant::Sim(e)) => Duration::from_millis(t.saturating_sub(e)),
            (Instant::Wall(t), Instant::Wall(e)) => t.saturating_duration_since(e),
            _ => Duration::ZERO,
        }
    }

    /// `d` before `self`, if that can be represented.
    pub fn checked_sub(&self, d: Duration) -> Option<Instant> {
        match self {
            Instant::Sim(t) => t.checked_sub(ms(d)).map(Instant::Sim),
            Instant::Wall(t) => t.checked_sub(d).map(Instant::Wall),
        }
    }

    /// Time left until `self` (zero once it has passed).
    pub fn remaining(&self) -> Duration {
        match (self, Instant::now()) {
            (Instant::Sim(t), Instant::Sim(now)) => Duration::from_millis(t.saturating_sub(now)),
            (Instant::Wall(t), Instant::Wall(now)) => t.saturating_duration_since(now),
            _ => Duration::ZERO,
        }
    }
}

impl std::ops::Add<Duration> for Instant {
    type Output = Instant;

    fn add(self, d: Duration) -> Instant {
        match self {
            Instant::Sim(t) => Instant::Sim(t.saturating_add(ms(d))),
            Instant::Wall(t) => Instant::Wall(t + d),
        }
    }
}

/// `fut` had not finished after the time given to [`timeout`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Elapsed;

impl std::fmt::Display for Elapsed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("timed out")
    }
}

impl std::error::Error for Elapsed {}

/// `fut`, or [`Elapsed`] after `d` ([`sleep`]'s time). `fut`'s own marks
/// say whether the participant is idle meanwhile.
pub async fn timeout<F: Future>(d: Duration, fut: F) -> Result<F::Output, Elapsed> {
    let sleep = sleep(d);
    tokio::pin!(fut, sleep);
    std::future::poll_fn(|cx| {
        if let Poll::Ready(v) = fut.as_mut().poll(cx) {
            return Poll::Ready(Ok(v));
        }
        if sleep.as_mut().poll(cx).is_ready() {
            return Poll::Ready(Err(Elapsed));
        }
        Poll::Pending
    })
    .await
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps the clock by 10 ms whenever everyone has settled, until
    /// `until_ms`.
    async fn stepper(clock: LockStep, until_ms: u64) {
        // Time starts with the test's first participant.
        while locked(&clock.sched.parts).is_empty() {
            tokio::task::yield_now().await;
        }
        while clock.now_ms() < until_ms {
            clock.settled().await;
            let next = clock.now_ms() + 10;
            clock.try_advance(|| next).await;
            tokio::task::yield_now().await;
        }
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_sleep_takes_simulated_time_however_long_the_work_between() {
        let clock = LockStep::new(0);
        let stepping = tokio::spawn(stepper(clock.clone(), 2_000));
        let seen = clock
            .participate("sleeper", async {
                let mut seen = Vec::new();
                for _ in 0..5 {
                    // Work that takes real time holds the clock.
                    tokio::time::sleep(Duration::from_millis(20)).await;
                    seen.push(now_ms().expect("in a participant"));
                    sleep(Duration::from_millis(100)).await;
                }
                seen
            })
            .await;
        stepping.abort();
        assert_eq!(seen, vec![0, 100, 200, 300, 400]);
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_message_between_participants_is_handled_before_the_next_step() {
        let clock = LockStep::new(0);
        let stepping = tokio::spawn(stepper(clock.clone(), 5_000));
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel::<u64>();
        let got = clock
            .participate("main", async move {
                let consumer = spawn("consumer", async move {
                    let mut rx = rx;
                    let mut lags = Vec::new();
                    while let Some(sent) = idle(rx.recv()).await {
                        // Slow handling still happens at the instant sent.
                        tokio::time::sleep(Duration::from_millis(5)).await;
                        lags.push(now_ms().expect("in a participant") - sent);
                    }
                    lags
                });
                let mut tick = interval(Duration::from_millis(50));
                for _ in 0..20 {
                    tick.tick().await;
                    tx.send(now_ms().expect("in a participant"))
                        .expect("consumer alive");
                }
                drop(tx);
                idle(consumer).await.expect("consumer ends")
            })
            .await;
        stepping.abort();
        assert_eq!(got, vec![0; 20]);
    }

    /// A message heard after a new time was announced, and before the
    /// clock moved to it, is read at the new time; without the announcement
    /// its reader may run first, at the old one.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_message_after_an_announced_time_is_read_at_that_time() {
        for announced in [true, false] {
            let clock = LockStep::new(0);
            let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<()>();
            let reader = tokio::spawn(clock.participate("reader", async move {
                idle(rx.recv()).await;
                now_ms().expect("in a participant")
            }));
            clock.settled().await;
            if announced {
                clock.announce();
            }
            tx.send(()).expect("reader alive");
            if !announced {
                // Nothing holds the reader back: it reads before the step.
                clock.settled().await;
            }
            clock.advance(10).await;
            let read_at = reader.await.expect("reader ends");
            assert_eq!(
                read_at,
                if announced { 10 } else { 0 },
                "announced: {announced}"
            );
        }
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_busy_wait_beside_a_timeout_holds_the_clock() {
        let clock = LockStep::new(0);
        let stepping = tokio::spawn(stepper(clock.clone(), 60_000));
        let r = clock
            .participate("asker", async {
                // An answer 50 ms of real time away, with a 10 ms simulated
                // timeout: the clock waits for the answer.
                let r = timeout(
                    Duration::from_millis(10),
                    busy(tokio::time::sleep(Duration::from_millis(50))),
                )
                .await;
                (r, now_ms())
            })
            .await;
        stepping.abort();
        assert_eq!(r, (Ok(()), Some(0)));
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn an_idle_wait_lets_time_run_out() {
        let clock = LockStep::new(0);
        let stepping = tokio::spawn(stepper(clock.clone(), 60_000));
        let (_tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<()>();
        let r = clock
            .participate("waiter", async {
                let r = timeout(Duration::from_millis(3_000), idle(rx.recv())).await;
                (r, now_ms())
            })
            .await;
        stepping.abort();
        assert_eq!(r, (Err(Elapsed), Some(3_000)));
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn participants_woken_at_one_instant_run_in_the_order_they_were_made() {
        let clock = LockStep::new(0);
        let stepping = tokio::spawn(stepper(clock.clone(), 10_000));
        let log = Arc::new(Mutex::new(Vec::new()));
        let l = log.clone();
        clock
            .participate("main", async move {
                let mut handles = Vec::new();
                for k in 0..6u64 {
                    let l = l.clone();
                    handles.push(spawn(&format!("p{k}"), async move {
                        for round in 0..10u64 {
                            sleep(Duration::from_millis(20)).await;
                            // Uneven real work: without turns, the order
                            // of a round is whoever finishes first.
                            let spin = std::time::Instant::now();
                            while spin.elapsed()
                                < Duration::from_micros(100 * ((k * 7 + round * 3) % 5))
                            {
                                std::hint::spin_loop();
                            }
                            locked(&l).push((now_ms().unwrap_or(0), k));
                            tokio::task::yield_now().await;
                        }
                    }));
                }
                for h in handles {
                    idle(h).await.expect("participant ends");
                }
            })
            .await;
        stepping.abort();
        let log = locked(&log).clone();
        assert_eq!(log.len(), 60);
        for round in log.chunks(6) {
            let order: Vec<u64> = round.iter().map(|(_, k)| *k).collect();
            assert_eq!(order, vec![0, 1, 2, 3, 4, 5], "{log:?}");
            assert!(round.iter().all(|(t, _)| *t == round[0].0), "{log:?}");
        }
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_deadline_in_a_participant_is_simulated_time() {
        let clock = LockStep::new(0);
        let stepping = tokio::spawn(stepper(clock.clone(), 10_000));
        let (left, gone) = clock
            .participate("main", async {
                let deadline = Instant::now() + Duration::from_millis(500);
                tokio::time::sleep(Duration::from_millis(30)).await;
                let left = deadline.remaining();
                sleep(Duration::from_millis(200)).await;
                (left, deadline.remaining())
            })
            .await;
        stepping.abort();
        assert_eq!(left, Duration::from_millis(500));
        assert_eq!(gone, Duration::from_millis(300));
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn work_after_an_idle_wait_in_the_same_poll_holds_the_clock() {
        // A select! whose idle branch has been polled pending, and whose
        // other branch is ready and then waits for real work: the work
        // holds the clock (the idle branch no longer counts).
        let clock = LockStep::new(0);
        let stepping = tokio::spawn(stepper(clock.clone(), 60_000));
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<()>();
        tx.send(()).expect("open");
        let t = clock
            .participate("server", async move {
                let never = std::future::pending::<()>();
                tokio::select! {
                    biased;
                    _ = idle(never) => unreachable!(),
                    _ = idle(rx.recv()) => {
                        tokio::task::spawn_blocking(|| std::thread::sleep(Duration::from_millis(30)))
                            .await
                            .expect("blocking work");
                    }
                }
                now_ms()
            })
            .await;
        stepping.abort();
        assert_eq!(t, Some(0));
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_message_still_on_the_wire_holds_the_clock_until_it_arrives() {
        // A network in miniature: a thread that takes 20 ms of real time
        // to deliver each message, outside every participant.
        let clock = LockStep::new(0);
        let stepping = tokio::spawn(stepper(clock.clone(), 60_000));
        let (wire, far_end) = std::sync::mpsc::channel::<u64>();
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel::<u64>();
        let got = clock
            .participate("main", async move {
                let inbound =
                    subscribed(|key| key.starts_with("topic/")).expect("in a participant");
                std::thread::spawn(move || {
                    for sent in far_end {
                        std::thread::sleep(Duration::from_millis(20));
                        let _ = tx.send(sent);
                        inbound.received();
                    }
                });
                let consumer = spawn("consumer", async move {
                    let mut rx = rx;
                    let mut lags = Vec::new();
                    while let Some(sent) = idle(rx.recv()).await {
                        lags.push(now_ms().expect("in a participant") - sent);
                    }
                    lags
                });
                let mut tick = interval(Duration::from_millis(50));
                for _ in 0..10 {
                    tick.tick().await;
                    sending("topic/a");
                    sending("elsewhere/b"); // nobody's: nothing to wait for
                    wire.send(now_ms().expect("in a participant"))
                        .expect("wire open");
                }
                drop(wire);
                idle(consumer).await.expect("consumer ends")
            })
            .await;
        stepping.abort();
        assert_eq!(got, vec![0; 10]);
        assert_eq!(clock.in_flight(), 0);
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_message_lost_on_the_way_can_be_given_up() {
        let clock = LockStep::new(0);
        let c = clock.clone();
        let inbound = clock
            .participate("main", async {
                subscribed(|_| true).expect("in a participant")
            })
            .await;
        clock
            .participate("sender", async {
                sending("anything");
                sending("anything");
            })
            .await;
        assert_eq!(c.in_flight(), 2);
        assert_eq!(c.busy(), 2, "two messages keep the clock busy");
        inbound.received();
        assert_eq!(c.forget_in_flight(), 1);
        assert_eq!(c.busy(), 0);
        tokio::time::timeout(Duration::from_secs(5), c.settled())
            .await
            .expect("settled once the lost message is given up");
        drop(inbound);
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_party_elsewhere_holds_the_clock_until_done_or_gone() {
        let clock = LockStep::new(0);
        let far = clock.external("far");
        assert_eq!(clock.busy(), 0, "idle until it is sent a time");
        far.expect();
        far.expect();
        assert_eq!(clock.busy(), 1);
        assert_eq!(clock.busy_names(), vec!["far".to_string()]);
        let waiting = tokio::spawn({
            let c = clock.clone();
            async move { c.settled().await }
        });
        tokio::task::yield_now().await;
        assert!(!waiting.is_finished());
        far.done();
        tokio::time::timeout(Duration::from_secs(5), waiting)
            .await
            .expect("settled once the party is done")
            .expect("no panic");
        far.expect();
        drop(far);
        assert_eq!(clock.busy(), 0, "a party that leaves is not waited for");
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_stuck_clock_says_who_is_busy_and_who_sleeps() {
        let clock = LockStep::new(0);
        let sleeper = tokio::spawn(
            clock.participate("sleeper", async { sleep(Duration::from_millis(250)).await }),
        );
        clock.settled().await;
        // A participant going idle is counted out just before it passes
        // the turn, on its own thread: the clock's own stepping waits for
        // the turn, and so does this.
        let deadline = std::time::Instant::now() + Duration::from_secs(5);
        while locked(&clock.sched.turn).holder.is_some() {
            assert!(
                std::time::Instant::now() < deadline,
                "the sleeper kept the turn"
            );
            tokio::task::yield_now().await;
        }
        let far = clock.external("far");
        far.expect();
        let said = clock.describe();
        assert!(said.starts_with("time 0 ms; busy 1 [\"far\"]"), "{said}");
        assert!(said.contains("1 sleeper(s), next due Some(250)"), "{said}");
        assert!(said.contains("turn held by nobody"), "{said}");
        far.done();
        assert_eq!(clock.try_advance(|| 250).await, Some(250));
        sleeper.await.unwrap();
        assert!(clock.describe().contains("0 sleeper(s)"));
    }

    /// A waker a participant left behind (in a channel, say) can be called
    /// after the participant has ended, by a thread that took it just
    /// before: the ended participant must not be given the turn, or nobody
    /// would run again.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_wake_after_a_participant_ended_gives_it_no_turn() {
        let clock = LockStep::new(0);
        let left = Arc::new(Mutex::new(None::<Waker>));
        let keep = left.clone();
        clock
            .participate(
                "gone",
                std::future::poll_fn(move |cx| {
                    *locked(&keep) = Some(cx.waker().clone());
                    Poll::Ready(())
                }),
            )
            .await;
        let stale = locked(&left).take().expect("polled once");
        stale.wake();
        let after = tokio::spawn(clock.participate("after", async { 7 }));
        // A failure detector, not synchronisation: the participant needs
        // microseconds.
        let got = tokio::time::timeout(Duration::from_secs(5), after).await;
        assert_eq!(
            got.ok().and_then(Result::ok),
            Some(7),
            "{}",
            clock.describe()
        );
    }

    /// Participants that wake one another through channels, are woken
    /// from threads outside the clock and by their sleeps, and are
    /// stopped from outside at any moment (a run's clients aborted at its
    /// end): however a wake falls against an end, the clock goes on for
    /// those still there. (The failure detector's limit is a minute; a
    /// round takes milliseconds.)
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn wakes_from_everywhere_as_participants_are_stopped_never_stop_the_clock() {
        const PARTS: usize = 16;
        const SENDS: usize = 2_000;
        for round in 0..20u64 {
            let clock = LockStep::new(0);
            let stepping = tokio::spawn(stepper(clock.clone(), u64::MAX));
            let (senders, receivers): (Vec<_>, Vec<_>) = (0..PARTS)
                .map(|_| tokio::sync::mpsc::unbounded_channel::<u64>())
                .unzip();
            let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
            let outside = {
                let (senders, stop) = (senders.clone(), stop.clone());
                std::thread::spawn(move || {
                    let mut x = round + 1;
                    for _ in 0..SENDS {
                        if stop.load(Ordering::Relaxed) {
                            break;
                        }
                        x ^= x << 13;
                        x ^= x >> 7;
                        x ^= x << 17;
                        // Passed on three times among the participants.
                        let _ = senders[(x % PARTS as u64) as usize].send(3);
                        std::thread::yield_now();
                    }
                })
            };
            let parts: Vec<_> = receivers
                .into_iter()
                .enumerate()
                .map(|(i, mut rx)| {
                    let all = senders.clone();
                    tokio::spawn(clock.participate(&format!("p{i}"), async move {
                        let mut x = i as u64 + 1;
                        loop {
                            tokio::select! {
                                biased;
                                got = idle(rx.recv()) => {
                                    if let Some(hops @ 1..) = got {
                                        x = x.wrapping_mul(6364136223846793005)
                                            .wrapping_add(1442695040888963407);
                                        let _ = all[(x >> 33) as usize % PARTS].send(hops - 1);
                                    }
                                }
                                _ = sleep(Duration::from_millis(10)) => {}
                            }
                        }
                    }))
                })
                .collect();
            // Stopped one by one at moments of the wall clock's choosing.
            let mut x = round * 31 + 7;
            for p in &parts {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
                tokio::time::sleep(Duration::from_micros((x >> 33) % 500)).await;
                p.abort();
            }
            for p in parts {
                assert!(p.await.is_err_and(|e| e.is_cancelled()));
            }
            let after = tokio::spawn(clock.participate("after", async {
                let from = now_ms().expect("in a participant");
                sleep(Duration::from_millis(30)).await;
                now_ms().expect("in a participant") - from
            }));
            let slept = tokio::time::timeout(Duration::from_secs(60), after).await;
            stop.store(true, Ordering::Relaxed);
            outside.join().unwrap();
            stepping.abort();
            assert_eq!(
                slept.ok().and_then(Result::ok),
                Some(30),
                "round {round}: {}",
                clock.describe()
            );
        }
    }

    /// A participant that panics leaves its thread as it found it: the
    /// next task polled there is no participant.
    #[tokio::test(flavor = "current_thread")]
    async fn a_panicking_participant_leaves_no_trace_on_its_thread() {
        let clock = LockStep::new(0);
        let panicked = tokio::spawn(clock.participate("doomed", async {
            assert!(is_lockstep());
            panic!("a participant's bug");
        }))
        .await;
        assert!(panicked.is_err_and(|e| e.is_panic()));
        // The same thread (one-threaded runtime), outside any participant.
        let after = tokio::spawn(async { is_lockstep() }).await.unwrap();
        assert!(!after, "the panicked participant's frame was left behind");
        assert_eq!(clock.busy(), 0);
    }

    #[tokio::test]
    async fn outside_a_participant_time_is_tokios() {
        assert!(!is_lockstep());
        assert_eq!(now_ms(), None);
        let t = tokio::time::Instant::now();
        sleep(Duration::from_millis(20)).await;
        assert!(t.elapsed() >= Duration::from_millis(20));
    }
}
