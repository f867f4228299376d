//! Tests of the crate root.

use super::*;

use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::task::{Poll, Waker};
use std::time::Duration;

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
            let inbound = subscribed(|key| key.starts_with("topic/")).expect("in a participant");
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

#[test]
fn a_keys_matches_follow_the_subscriptions_that_come_and_go() {
    let entry = |prefix: &'static str| {
        Arc::new(SubEntry {
            matches: Box::new(move |k: &str| k.starts_with(prefix)),
            pending: std::sync::atomic::AtomicUsize::new(0),
        })
    };
    let names = |subs: &mut Subs, key: &str| subs.matching(key).len();
    let mut subs = Subs::default();
    subs.insert(0, entry("a/"));
    assert_eq!(names(&mut subs, "a/1"), 1);
    assert_eq!(names(&mut subs, "b/1"), 0);
    // Made after both keys' matches were worked out.
    subs.insert(1, entry("b/"));
    subs.insert(2, entry(""));
    assert_eq!(names(&mut subs, "a/1"), 2);
    assert_eq!(names(&mut subs, "b/1"), 2);
    subs.remove(0);
    assert_eq!(names(&mut subs, "a/1"), 1);
    subs.remove(2);
    assert_eq!(names(&mut subs, "a/1"), 0);
    assert_eq!(names(&mut subs, "b/1"), 1);
    assert_eq!(subs.all().count(), 1);
}
