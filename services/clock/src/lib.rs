//! Simulated time that advances only when everyone has finished with the
//! present instant: ROS's `use_sim_time` with a lock-step simulator.
//!
//! How this crate is laid out (one file):
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
//! A run is then the same whatever the machine's load: every reaction to
//! what happened at simulated time `t` is complete before the world takes
//! its next step.

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
}

fn locked<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// One participant: busy or parked.
struct Part {
    sched: Arc<Sched>,
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
        let part = Arc::new(Part {
            sched: sched.clone(),
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
        let mut s = locked(&self.state);
        s.wakes += 1;
        if s.parked && !s.done {
            s.parked = false;
            self.sched.busy.fetch_add(1, Ordering::AcqRel);
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
        let mut s = locked(&self.state);
        if !s.done {
            s.done = true;
            if !s.parked {
                self.sched.release();
            }
        }
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

    /// How many participants are busy.
    pub fn busy(&self) -> usize {
        self.sched.busy.load(Ordering::Acquire)
    }

    /// The names of the participants that are busy.
    pub fn busy_names(&self) -> Vec<String> {
        locked(&self.sched.parts)
            .iter()
            .filter_map(Weak::upgrade)
            .filter(|p| {
                let s = locked(&p.state);
                !s.parked && !s.done
            })
            .map(|p| p.name.clone())
            .collect()
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

    /// The earliest time a sleeper waits for, if any.
    pub fn next_due(&self) -> Option<u64> {
        locked(&self.sched.timers).keys().next().map(|(t, _)| *t)
    }

    /// Moves time on to `now_ms` (never back) and wakes every sleeper due
    /// by then; each is busy before this returns.
    pub fn advance(&self, now_ms: u64) {
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
}

fn current() -> Option<Arc<Part>> {
    CURRENT.with(|c| c.borrow().as_ref().map(|f| f.part.clone()))
}

fn mark(idle: bool) {
    CURRENT.with(|c| {
        if let Some(f) = c.borrow_mut().as_mut() {
            if idle {
                f.idle = true;
            } else {
                f.busy = true;
            }
        }
    });
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
        self.part.wake();
        self.inner.wake_by_ref();
    }
}

impl<F: Future> Future for Participant<F> {
    type Output = F::Output;

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<F::Output> {
        let Some(part) = self.part.clone() else {
            return self.inner.as_mut().poll(cx);
        };
        part.wake();
        let seen = part.wakes();
        let waker = Waker::from(Arc::new(ParkWaker {
            part: part.clone(),
            inner: cx.waker().clone(),
        }));
        let mut inner_cx = Context::from_waker(&waker);
        let outer = CURRENT.with(|c| {
            c.borrow_mut().replace(Frame {
                part: part.clone(),
                idle: false,
                busy: false,
            })
        });
        let polled = self.inner.as_mut().poll(&mut inner_cx);
        let frame = CURRENT.with(|c| std::mem::replace(&mut *c.borrow_mut(), outer));
        match polled {
            Poll::Ready(v) => {
                part.finish();
                self.part = None;
                Poll::Ready(v)
            }
            Poll::Pending => {
                if frame.is_some_and(|f| f.idle && !f.busy) {
                    part.park(seen);
                }
                Poll::Pending
            }
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

/// A wait marked as one the participant is [idle](crate) in or busy in.
pub struct Marked<F: Future> {
    idle: bool,
    inner: Pin<Box<F>>,
}

impl<F: Future> Future for Marked<F> {
    type Output = F::Output;

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<F::Output> {
        let polled = self.inner.as_mut().poll(cx);
        if polled.is_pending() {
            mark(self.idle);
        }
        polled
    }
}

/// Awaits `fut` idle: what it waits for comes from another participant or
/// from the clock (a stream's next message, a semaphore, a sleep).
pub fn idle<F: Future>(fut: F) -> Marked<F> {
    Marked {
        idle: true,
        inner: Box::pin(fut),
    }
}

/// Awaits `fut` busy, even beside idle waits (in a `select!`): it is
/// answered without the clock moving (a query to a server).
pub fn busy<F: Future>(fut: F) -> Marked<F> {
    Marked {
        idle: false,
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
                    return Poll::Ready(());
                }
                let k = *key
                    .get_or_insert_with(|| (*due, sched.next_id.fetch_add(1, Ordering::Relaxed)));
                timers.insert(k, cx.waker().clone());
                drop(timers);
                mark(true);
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
        while clock.now_ms() < until_ms {
            clock.settled().await;
            clock.advance(clock.now_ms() + 10);
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

    #[tokio::test]
    async fn outside_a_participant_time_is_tokios() {
        assert!(!is_lockstep());
        assert_eq!(now_ms(), None);
        let t = tokio::time::Instant::now();
        sleep(Duration::from_millis(20)).await;
        assert!(t.elapsed() >= Duration::from_millis(20));
    }
}
