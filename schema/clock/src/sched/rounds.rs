//! A run split into processes, made the same in every run: what servers
//! are asked within one round is handed to them in a fixed order.
//!
//! A process that follows the simulator's clock answers each round of an
//! instant (see `rome_client::simtime`), and Zenoh keeps one sender's
//! messages in order, so whatever a party sent before its answer to round
//! `r` has arrived everywhere once that answer has. Requests from two
//! processes within one round still arrive in either order, and a server
//! that took them as they came (two modules commanding one base, two
//! clients signalling one semaphore) would part two runs.
//!
//! So each request carries a [`Stamp`]: the round whose answer it precedes,
//! a stable name for its sender and a count. A server keeps the requests
//! that change something in a [`Hold`]. They are handed over only once a
//! round has passed in which nobody anywhere had anything to do (the
//! simulator then sends a round with `release`): what every process does
//! up to that point does not depend on them, and every request sent
//! before that round has arrived. They go sorted by stamp
//! ([`LockStep::hand_over`]), so their order is the same in every run,
//! and what they cause happens in the rounds after. A read is answered
//! from the state the last hand-over left: it waits only until the rounds
//! before its own have been seen, and is answered in its round.

use crate::sched::{current, locked, Sched, STEPPER};
use crate::LockStep;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex, Weak};

/// Where a message stands in a run split into processes: sent before its
/// sender answered round `round` of instant `time_ms`, the `seq`-th
/// stamped by the sender named `from` (a hash of a name that is the same
/// in every run).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Stamp {
    /// The instant, simulated ms.
    pub time_ms: u64,
    /// The round of the instant.
    pub round: u32,
    /// The sender's stable name, hashed ([`name_hash`]).
    pub from: u64,
    /// How many messages the sender had stamped before this one.
    pub seq: u64,
}

/// The first bytes of an encoded [`Stamp`], so that another attachment is
/// not taken for one.
const MAGIC: [u8; 4] = *b"RMS1";

impl Stamp {
    /// Bytes in an encoded stamp.
    pub const LEN: usize = 4 + 8 + 4 + 8 + 8;

    /// The instant and round, in the order rounds follow each other.
    pub fn round_of(&self) -> (u64, u32) {
        (self.time_ms, self.round)
    }

    /// The stamp as sent (a Zenoh attachment): magic, then each field
    /// little-endian.
    ///
    /// ```text
    /// "RMS1" time_ms:u64 round:u32 from:u64 seq:u64   (32 bytes)
    /// ```
    pub fn to_bytes(&self) -> [u8; Stamp::LEN] {
        let mut b = [0u8; Stamp::LEN];
        b[..4].copy_from_slice(&MAGIC);
        b[4..12].copy_from_slice(&self.time_ms.to_le_bytes());
        b[12..16].copy_from_slice(&self.round.to_le_bytes());
        b[16..24].copy_from_slice(&self.from.to_le_bytes());
        b[24..32].copy_from_slice(&self.seq.to_le_bytes());
        b
    }

    /// A stamp from its bytes; `None` unless they are exactly one.
    pub fn from_bytes(b: &[u8]) -> Option<Stamp> {
        if b.len() != Stamp::LEN || b[..4] != MAGIC {
            return None;
        }
        let u64_at = |i: usize| {
            let mut a = [0u8; 8];
            a.copy_from_slice(&b[i..i + 8]);
            u64::from_le_bytes(a)
        };
        let mut r = [0u8; 4];
        r.copy_from_slice(&b[12..16]);
        Some(Stamp {
            time_ms: u64_at(4),
            round: u32::from_le_bytes(r),
            from: u64_at(16),
            seq: u64_at(24),
        })
    }
}

/// A name's hash that is the same in every run and on every machine
/// (FNV-1a): a process's stable name in its stamps.
pub fn name_hash(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// A clock's rounds, once it is split into them.
#[derive(Default)]
pub(crate) struct Rounds {
    on: bool,
    from: u64,
    /// The round whose answer what is sent now precedes.
    next: (u64, u32),
    seq: u64,
    holds: Vec<Weak<dyn Release>>,
}

/// A [`Hold`] as its clock sees it.
trait Release: Send + Sync {
    /// Hands over what may go at `before` (see [`LockStep::hand_over`]);
    /// how much.
    fn release(&self, before: (u64, u32), changes: bool) -> usize;
    /// Whether it keeps a request that changes something.
    fn holds_changes(&self) -> bool;
}

impl LockStep {
    /// Splits this clock's instants into rounds, as a party of a run split
    /// into processes (or as the simulator that sends them): messages sent
    /// from here on are stamped, and [`Hold`]s keep what they are given.
    /// `name` is this process's name in its stamps: the same in every run
    /// (the program and its arguments, say), and best unlike any other
    /// party's, whose requests in the same round would otherwise be taken
    /// in the order they arrive.
    pub fn split_into_rounds(&self, name: &str) {
        let mut r = locked(&self.sched.rounds);
        r.on = true;
        r.from = name_hash(name);
    }

    /// Whether [`LockStep::split_into_rounds`] was called.
    pub fn in_rounds(&self) -> bool {
        locked(&self.sched.rounds).on
    }

    /// Messages sent from now on precede this process's answer to `round`
    /// of instant `time_ms`.
    pub fn set_round(&self, time_ms: u64, round: u32) {
        locked(&self.sched.rounds).next = (time_ms, round);
    }

    /// The round set last ([`LockStep::set_round`]).
    pub fn round(&self) -> (u64, u32) {
        locked(&self.sched.rounds).next
    }

    /// Round `before` has begun here (the round's message was heard, or,
    /// in the simulator, sent): every [`Hold`] of this clock hands over,
    /// in stamp order, the reads stamped up to it and, if `changes` (the
    /// round before was one in which nobody had anything to do), first
    /// the requests that change something stamped before it. Call once
    /// every message stamped before `before` has arrived (every party has
    /// answered the round before). Nobody runs meanwhile, so the servers
    /// woken find everything handed over in their queues. Returns how many
    /// went.
    pub async fn hand_over(&self, before: (u64, u32), changes: bool) -> usize {
        let holds = self.holds();
        if holds.is_empty() {
            return 0;
        }
        self.take_turn().await;
        let n = holds.iter().map(|h| h.release(before, changes)).sum();
        self.sched.pass(STEPPER);
        n
    }

    /// Whether a [`Hold`] of this clock keeps a request that changes
    /// something (a process says so in its answer to a round).
    pub fn holding(&self) -> bool {
        self.holds().iter().any(|h| h.holds_changes())
    }

    fn holds(&self) -> Vec<Arc<dyn Release>> {
        let mut r = locked(&self.sched.rounds);
        r.holds.retain(|h| h.strong_count() > 0);
        r.holds.iter().filter_map(Weak::upgrade).collect()
    }

    /// A hold for messages to a server of this clock's process: `deliver`
    /// gets each once it may be taken, from [`Hold::put`] or from
    /// [`LockStep::hand_over`]. Keeps at most `capacity` messages.
    pub fn hold<T: Send + 'static>(
        &self,
        capacity: usize,
        deliver: impl Fn(T) + Send + Sync + 'static,
    ) -> Hold<T> {
        let inner = Arc::new(HoldInner {
            sched: Arc::downgrade(&self.sched),
            capacity,
            deliver: Box::new(deliver),
            state: Mutex::new(HoldState {
                items: Vec::new(),
                arrived: 0,
                passed: None,
            }),
        });
        let weak: Weak<dyn Release> = Arc::downgrade(&(inner.clone() as Arc<dyn Release>));
        let mut r = locked(&self.sched.rounds);
        r.holds.retain(|h| h.strong_count() > 0);
        r.holds.push(weak);
        Hold { inner }
    }

    /// The clock of the participant running on this thread.
    pub fn current() -> Option<LockStep> {
        current().map(|p| LockStep {
            sched: p.sched.clone(),
        })
    }
}

/// A stamp for a message sent now from a participant of a clock split
/// into rounds; `None` elsewhere (nothing to stamp).
pub fn stamp() -> Option<Stamp> {
    let part = current()?;
    let mut r = locked(&part.sched.rounds);
    if !r.on {
        return None;
    }
    r.seq += 1;
    Some(Stamp {
        time_ms: r.next.0,
        round: r.next.1,
        from: r.from,
        seq: r.seq,
    })
}

/// Whether this runs in a participant of a clock split into rounds: a
/// request that changes something is then answered only once its round
/// is over, which the participant must not wait for busy.
pub fn in_rounds() -> bool {
    current().is_some_and(|p| locked(&p.sched.rounds).on)
}

/// Messages to one server, kept until their round allows them in; see the
/// module.
pub struct Hold<T> {
    inner: Arc<HoldInner<T>>,
}

/// What [`Hold::put`] did with a message.
#[derive(Debug)]
pub enum Held<T> {
    /// It may be taken now: here it is back.
    Pass(T),
    /// Kept until its round is handed over.
    Kept,
    /// Not kept: the hold is full (here it is back, to be refused).
    Full(T),
}

struct HoldInner<T> {
    sched: Weak<Sched>,
    capacity: usize,
    deliver: Box<dyn Fn(T) + Send + Sync>,
    state: Mutex<HoldState<T>>,
}

struct HoldState<T> {
    /// Kept: stamp, whether a read, the order of arrival, the message.
    items: Vec<(Stamp, bool, u64, T)>,
    arrived: u64,
    /// The last `before` handed over: reads stamped up to it pass.
    passed: Option<(u64, u32)>,
}

/// How far ahead of this process's clock a stamp may be: further is a
/// sender's error (or garbage), and the message is taken as unstamped.
const AHEAD_MS: u64 = 60_000;

impl<T: Send + 'static> Hold<T> {
    /// Whether the clock is split into rounds: otherwise messages are
    /// taken as they come.
    pub fn active(&self) -> bool {
        self.inner
            .sched
            .upgrade()
            .is_some_and(|s| locked(&s.rounds).on)
    }

    /// Offers a message `stamped` by its sender; `read` if it changes
    /// nothing. A read passes once its own round has begun here; a change
    /// is kept until a release after its round. An unstamped message (from
    /// a process outside the rounds: a tool, or a client not yet a party)
    /// passes at once: nothing orders it anyway, and a client that is not
    /// yet a party must not wait on the rounds it keeps from starting.
    pub fn put(&self, stamped: Option<Stamp>, read: bool, item: T) -> Held<T> {
        let now = self
            .inner
            .sched
            .upgrade()
            .map_or(0, |s| s.now_ms.load(Ordering::Acquire));
        let Some(stamp) = stamped.filter(|s| s.time_ms <= now.saturating_add(AHEAD_MS)) else {
            return Held::Pass(item);
        };
        let mut st = locked(&self.inner.state);
        if read && st.passed.is_some_and(|p| stamp.round_of() <= p) {
            return Held::Pass(item);
        }
        if st.items.len() >= self.inner.capacity {
            return Held::Full(item);
        }
        st.arrived += 1;
        let n = st.arrived;
        st.items.push((stamp, read, n, item));
        Held::Kept
    }
}

impl<T: Send + 'static> Release for HoldInner<T> {
    fn release(&self, before: (u64, u32), changes: bool) -> usize {
        let mut going = {
            let mut st = locked(&self.state);
            st.passed = Some(st.passed.map_or(before, |p| p.max(before)));
            let (go, keep): (Vec<_>, Vec<_>) =
                std::mem::take(&mut st.items)
                    .into_iter()
                    .partition(|(stamp, read, _, _)| {
                        if *read {
                            stamp.round_of() <= before
                        } else {
                            changes && stamp.round_of() < before
                        }
                    });
            st.items = keep;
            go
        };
        // Changes first, by stamp (two alike, from two processes of the
        // same name, as they came); then the reads, which see every change
        // handed over before theirs.
        going.sort_by_key(|(stamp, read, n, _)| (*read, *stamp, *n));
        let n = going.len();
        for (_, _, _, item) in going {
            (self.deliver)(item);
        }
        n
    }

    fn holds_changes(&self) -> bool {
        locked(&self.state)
            .items
            .iter()
            .any(|(_, read, _, _)| !read)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stamp_at(round: u32, from: &str, seq: u64) -> Stamp {
        Stamp {
            time_ms: 100,
            round,
            from: name_hash(from),
            seq,
        }
    }

    #[test]
    fn a_stamp_survives_its_bytes_and_nothing_else_is_taken_for_one() {
        let s = stamp_at(3, "navigator", 42);
        assert_eq!(Stamp::from_bytes(&s.to_bytes()), Some(s));
        assert_eq!(Stamp::from_bytes(&s.to_bytes()[..31]), None);
        let mut other = s.to_bytes();
        other[0] = b'X';
        assert_eq!(Stamp::from_bytes(&other), None);
        assert_eq!(Stamp::from_bytes(b""), None);
        assert_ne!(name_hash("wander"), name_hash("avoid"));
        // Fixed, not seeded per process: the same in every run.
        assert_eq!(name_hash(""), 0xcbf2_9ce4_8422_2325);
    }

    /// What a hold delivers at each hand-over, given messages in the order
    /// they arrived: (stamp, read, label).
    async fn delivered(
        arrivals: &[(Option<Stamp>, bool, &'static str)],
        hand_overs: &[(u64, u32)],
    ) -> Vec<Vec<&'static str>> {
        let clock = LockStep::new(100);
        clock.split_into_rounds("test");
        let (tx, rx) = std::sync::mpsc::channel();
        let hold = clock.hold(16, move |label: &'static str| tx.send(label).unwrap());
        let mut passed_at_once = Vec::new();
        for &(stamp, read, label) in arrivals {
            match hold.put(stamp, read, label) {
                Held::Pass(l) => passed_at_once.push(l),
                Held::Kept => {}
                Held::Full(l) => panic!("{l} refused"),
            }
        }
        let mut out = vec![passed_at_once];
        for &before in hand_overs {
            clock.hand_over(before, true).await;
            out.push(rx.try_iter().collect());
        }
        out
    }

    #[tokio::test]
    async fn the_changes_of_a_round_are_handed_over_in_stamp_order_whatever_order_they_came_in() {
        let a = (Some(stamp_at(0, "avoid", 7)), false, "avoid go");
        let w1 = (Some(stamp_at(0, "wander", 3)), false, "wander go");
        let w2 = (Some(stamp_at(0, "wander", 4)), false, "wander jog");
        let late = (Some(stamp_at(1, "escape", 1)), false, "escape go");
        let outside = (None, false, "from outside the rounds");
        let one = delivered(&[a, w1, late, w2, outside], &[(100, 1), (100, 2)]).await;
        let other = delivered(&[outside, late, w2, w1, a], &[(100, 1), (100, 2)]).await;
        assert_eq!(one, other);
        let by_name = |n: &str| name_hash(n);
        let mut first = [("avoid", by_name("avoid")), ("wander", by_name("wander"))];
        first.sort_by_key(|(_, h)| *h);
        let expected_round_0: Vec<&str> = first
            .iter()
            .flat_map(|(n, _)| match *n {
                "avoid" => vec!["avoid go"],
                _ => vec!["wander go", "wander jog"],
            })
            .collect();
        assert_eq!(one[0], vec!["from outside the rounds"], "nothing orders it");
        assert_eq!(one[1], expected_round_0);
        assert_eq!(
            one[2],
            vec!["escape go"],
            "kept until its own round was over"
        );
    }

    #[tokio::test]
    async fn a_read_waits_for_the_rounds_before_its_own_and_no_longer() {
        let set = (Some(stamp_at(0, "ctracker", 1)), false, "set");
        let read_0 = (Some(stamp_at(1, "navigator", 1)), true, "read in round 1");
        let unstamped = (None, true, "read from outside");
        let out = delivered(&[read_0, set, unstamped], &[(100, 1)]).await;
        assert_eq!(out[0], vec!["read from outside"]);
        // The set of round 0 first, then the read of round 1 that must see it.
        assert_eq!(out[1], vec!["set", "read in round 1"]);

        let clock = LockStep::new(100);
        clock.split_into_rounds("test");
        let hold = clock.hold(2, |_: u32| {});
        clock.hand_over((100, 1), false).await;
        assert!(matches!(
            hold.put(Some(stamp_at(1, "n", 1)), true, 1),
            Held::Pass(1)
        ));
        assert!(matches!(
            hold.put(Some(stamp_at(2, "n", 2)), true, 2),
            Held::Kept
        ));
        assert!(!clock.holding());
        assert!(matches!(
            hold.put(Some(stamp_at(1, "n", 3)), false, 3),
            Held::Kept
        ));
        assert!(clock.holding(), "a change waits for a release");
        assert!(matches!(
            hold.put(Some(stamp_at(1, "n", 4)), false, 4),
            Held::Full(4)
        ));
        // Not a release: the change stays; the read of round 2 goes.
        assert_eq!(clock.hand_over((100, 2), false).await, 1);
        assert!(clock.holding());
        assert_eq!(clock.hand_over((100, 3), true).await, 1);
        assert!(!clock.holding());
        // A stamp far ahead of the clock is garbage, taken as unstamped.
        let far = Stamp {
            time_ms: u64::MAX,
            ..stamp_at(0, "x", 1)
        };
        assert!(matches!(hold.put(Some(far), true, 5), Held::Pass(5)));
    }

    #[test]
    fn a_participant_stamps_its_messages_only_once_its_clock_is_in_rounds() {
        let clock = LockStep::new(50);
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        let c = clock.clone();
        let stamps = rt.block_on(clock.participate("sender", async move {
            let before = stamp();
            c.split_into_rounds("sender");
            c.set_round(50, 2);
            let (a, b) = (stamp(), stamp());
            (before, in_rounds(), a, b)
        }));
        assert_eq!(stamps.0, None);
        assert!(stamps.1);
        let (a, b) = (stamps.2.unwrap(), stamps.3.unwrap());
        assert_eq!((a.time_ms, a.round, a.from), (50, 2, name_hash("sender")));
        assert_eq!(b.seq, a.seq + 1);
        assert_eq!(stamp(), None, "outside a participant");
    }
}
