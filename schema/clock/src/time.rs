//! Sleeps, intervals, instants and timeouts: simulated time inside a
//! participant, tokio's time anywhere else.

use crate::party::now_ms;
use crate::sched::*;
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;

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
