//! Tests of `store`.

use super::*;
use rome_schema::data::WaitStatus;
use serde_json::json;

fn n(s: &str) -> Name {
    Name::new(s).unwrap()
}

#[test]
fn history_is_fifo_and_back_reads_older_values() {
    let mut s = Store::new(3);
    let t = Instant::now();
    for v in 1..=5 {
        s.set(&n("PosX"), json!(v), None, t).unwrap();
    }
    assert_eq!(s.get(&n("PosX"), 0).unwrap(), &json!(5));
    assert_eq!(s.get(&n("PosX"), 2).unwrap(), &json!(3));
    let e = s.get(&n("PosX"), 3).unwrap_err();
    assert_eq!(e.code, ErrorCode::OutOfRange);
    assert!(e.message.contains("holds 3 value"), "{}", e.message);
    let info = s.history(&n("PosX"), Some(2)).unwrap();
    assert_eq!((info.len, info.stored, info.seq), (2, 2, 5));
    assert_eq!(s.get(&n("PosX"), 1).unwrap(), &json!(4));
}

#[test]
fn history_length_is_checked_and_declares_a_variable() {
    let mut s = Store::new(16);
    assert_eq!(
        s.history(&n("x"), Some(0)).unwrap_err().code,
        ErrorCode::OutOfRange
    );
    assert_eq!(
        s.history(&n("x"), Some(MAX_HISTORY + 1)).unwrap_err().code,
        ErrorCode::OutOfRange
    );
    assert_eq!(
        s.history(&n("x"), None).unwrap_err().code,
        ErrorCode::UnknownVariable
    );
    s.history(&n("x"), Some(2)).unwrap();
    assert_eq!(
        s.get(&n("x"), 0).unwrap_err().code,
        ErrorCode::UnknownVariable
    );
    for v in 0..5 {
        s.put(&n("x"), json!(v)).unwrap();
    }
    assert_eq!(s.history(&n("x"), None).unwrap().stored, 2);
}

#[test]
fn retried_set_is_not_committed_twice() {
    let mut s = Store::new(16);
    let t = Instant::now();
    let a = s.set(&n("v"), json!("a"), Some("c1-1"), t).unwrap();
    assert_eq!(a.commit.as_ref().map(|c| c.seq), Some(1));
    let again = s.set(&n("v"), json!("a"), Some("c1-1"), t).unwrap();
    assert_eq!(again.reply, a.reply);
    assert!(again.commit.is_none());
    assert_eq!(s.history(&n("v"), None).unwrap().seq, 1);
    // The same op id on another request is a client bug, named as such.
    let e = s.signal(&n("v"), Some("c1-1"), t).unwrap_err();
    assert_eq!(e.code, ErrorCode::Conflict);
}

#[test]
fn delete_keeps_the_commit_numbering() {
    let mut s = Store::new(4);
    s.put(&n("v"), json!(1)).unwrap();
    let d = s.delete(&n("v")).unwrap();
    assert_eq!((d.seq, d.deleted), (2, true));
    assert!(s.delete(&n("v")).is_none());
    assert_eq!(s.put(&n("v"), json!(2)).unwrap().seq, 3);
}

#[test]
fn semaphore_basics_and_unknown_names() {
    let mut s = Store::new(4);
    let t = Instant::now();
    assert_eq!(
        s.signal(&n("S"), None, t).unwrap_err().code,
        ErrorCode::UnknownSemaphore
    );
    assert_eq!(
        s.wait(&n("S"), None, None, t).unwrap_err().code,
        ErrorCode::UnknownSemaphore
    );
    assert_eq!(
        s.try_wait(&n("S"), None, t).unwrap_err().code,
        ErrorCode::UnknownSemaphore
    );
    assert!(s.create(&n("S"), 1).unwrap().created);
    let again = s.create(&n("S"), 5).unwrap();
    assert!(!again.created);
    assert_eq!(again.value, 1);
    assert!(s.try_wait(&n("S"), None, t).unwrap().acquired);
    assert!(!s.try_wait(&n("S"), None, t).unwrap().acquired);
    assert_eq!(s.signal(&n("S"), None, t).unwrap().reply.value, 1);
}

#[test]
fn waiters_are_served_in_order() {
    let mut s = Store::new(4);
    let t = Instant::now();
    s.create(&n("S"), 0).unwrap();
    for id in ["a", "b", "c"] {
        let r = s.wait(&n("S"), Some(id), Some("o"), t).unwrap();
        assert_eq!(r.status, WaitStatus::Pending);
    }
    assert_eq!(s.semaphore(&n("S")).unwrap().waiters, 3);
    // try-wait may not jump the queue even when a unit is free.
    let mut order = Vec::new();
    for _ in 0..3 {
        let sig = s.signal(&n("S"), None, t).unwrap();
        assert!(sig.reply.woke);
        order.extend(sig.grants.into_iter().map(|g| g.ticket));
    }
    assert_eq!(order, ["a", "b", "c"]);
    assert_eq!(s.semaphore(&n("S")).unwrap().value, 0);
}

#[test]
fn retried_wait_keeps_its_place_and_its_grant() {
    let mut s = Store::new(4);
    let t = Instant::now();
    s.create(&n("S"), 0).unwrap();
    s.wait(&n("S"), Some("a"), Some("o1"), t).unwrap();
    s.wait(&n("S"), Some("b"), Some("o2"), t).unwrap();
    // "a" retries (its reply was lost): still first, not queued twice.
    let r = s.wait(&n("S"), Some("a"), Some("o1"), t).unwrap();
    assert_eq!((r.status, r.position), (WaitStatus::Pending, Some(1)));
    assert_eq!(s.semaphore(&n("S")).unwrap().waiters, 2);
    let sig = s.signal(&n("S"), None, t).unwrap();
    assert_eq!(sig.grants[0].ticket, "a");
    // The grant reply is lost; the retry learns it without a second unit.
    for _ in 0..3 {
        assert_eq!(
            s.wait(&n("S"), Some("a"), Some("o1"), t).unwrap().status,
            WaitStatus::Granted
        );
    }
    assert_eq!(
        s.ack(&n("S"), "a", t).unwrap().status,
        WaitStatus::Confirmed
    );
    // A retried ack, and a very late duplicate wait, are answered from memory.
    assert_eq!(
        s.ack(&n("S"), "a", t).unwrap().status,
        WaitStatus::Confirmed
    );
    assert_eq!(
        s.wait(&n("S"), Some("a"), Some("o1"), t).unwrap().status,
        WaitStatus::Confirmed
    );
    let st = s.semaphore(&n("S")).unwrap();
    assert_eq!((st.value, st.waiters), (0, 1));
}

#[test]
fn cancel_racing_a_grant_hands_over_the_unit() {
    let mut s = Store::new(4);
    let t = Instant::now();
    s.create(&n("S"), 0).unwrap();
    s.wait(&n("S"), Some("a"), Some("o"), t).unwrap();
    s.signal(&n("S"), None, t).unwrap();
    assert_eq!(s.cancel(&n("S"), "a").unwrap().status, WaitStatus::Granted);
    s.ack(&n("S"), "a", t).unwrap();
    // Cancelling a queued ticket removes it and takes nothing.
    s.wait(&n("S"), Some("b"), Some("o"), t).unwrap();
    assert_eq!(
        s.cancel(&n("S"), "b").unwrap().status,
        WaitStatus::Cancelled
    );
    assert_eq!(s.cancel(&n("S"), "b").unwrap().status, WaitStatus::Unknown);
    s.signal(&n("S"), None, t).unwrap();
    assert_eq!(s.semaphore(&n("S")).unwrap().value, 1);
}

#[test]
fn a_dead_owners_place_is_dropped_and_its_unconfirmed_unit_returned() {
    let mut s = Store::new(4);
    let t = Instant::now();
    s.create(&n("S"), 0).unwrap();
    s.wait(&n("S"), Some("dead-1"), Some("dead"), t).unwrap();
    s.wait(&n("S"), Some("dead-2"), Some("dead"), t).unwrap();
    s.wait(&n("S"), Some("live-1"), Some("live"), t).unwrap();
    // The first signal goes to the dead owner before its death is known.
    assert_eq!(
        s.signal(&n("S"), None, t).unwrap().grants[0].ticket,
        "dead-1"
    );
    let grants = s.owner_gone("dead", t);
    assert_eq!(
        grants,
        vec![Grant {
            sem: n("S"),
            ticket: "live-1".into()
        }]
    );
    assert_eq!(
        s.ack(&n("S"), "dead-1", t).unwrap().status,
        WaitStatus::Unknown
    );
    let st = s.semaphore(&n("S")).unwrap();
    assert_eq!((st.value, st.waiters), (0, 0));
}

#[test]
fn an_undo_unit_goes_back_when_its_holder_dies_or_gives_it_back() {
    let mut s = Store::new(4);
    let t = Instant::now();
    s.create(&n("P"), 1).unwrap();
    let w = s
        .wait_undo(&n("P"), Some("a-1"), Some("a"), true, t)
        .unwrap();
    assert_eq!(w.status, WaitStatus::Granted);
    assert_eq!(
        s.ack(&n("P"), "a-1", t).unwrap().status,
        WaitStatus::Confirmed
    );
    let st = s.semaphore(&n("P")).unwrap();
    assert_eq!((st.value, st.held), (0, 1));
    // b queues behind a's unit; a dies holding it: b gets it.
    s.wait_undo(&n("P"), Some("b-1"), Some("b"), true, t)
        .unwrap();
    let grants = s.owner_gone("a", t);
    assert_eq!(grants.len(), 1);
    assert_eq!(grants[0].ticket, "b-1");
    s.ack(&n("P"), "b-1", t).unwrap();
    // b gives it back itself; a second undo signal has nothing to return.
    s.signal_as(&n("P"), None, Some("b"), t).unwrap();
    let err = s.signal_as(&n("P"), None, Some("b"), t).unwrap_err();
    assert_eq!(err.code, ErrorCode::Conflict);
    assert!(err.message.contains("holds no unit"), "{}", err.message);
    let st = s.semaphore(&n("P")).unwrap();
    assert_eq!((st.value, st.waiters, st.held), (1, 0, 0));
    // b's later death returns nothing more: no unit is made up.
    assert!(s.owner_gone("b", t).is_empty());
    assert_eq!(s.semaphore(&n("P")).unwrap().value, 1);
    // A plain wait's unit is final, whoever dies.
    s.wait(&n("P"), Some("c-1"), Some("c"), t).unwrap();
    s.ack(&n("P"), "c-1", t).unwrap();
    s.owner_gone("c", t);
    assert_eq!(s.semaphore(&n("P")).unwrap().value, 0);
    // An undo wait needs an owner to tie the unit to.
    let err = s.wait_undo(&n("P"), None, None, true, t).unwrap_err();
    assert_eq!(err.code, ErrorCode::BadParameter);
}

#[test]
fn a_wait_for_several_units_takes_them_together_and_in_its_turn() {
    let mut s = Store::new(4);
    let t = Instant::now();
    let p = n("Lane");
    s.create(&p, 3).unwrap();
    let take = |s: &mut Store, ticket: &str, owner: &str, units: u64| {
        s.wait_units(&p, Some(ticket), Some(owner), true, units, t)
            .unwrap()
            .status
    };
    assert_eq!(take(&mut s, "a-1", "a", 1), WaitStatus::Granted);
    s.ack(&p, "a-1", t).unwrap();
    // b wants all three: two are free, so it queues; c, behind it, wants
    // one of the two free ones and still waits its turn.
    assert_eq!(take(&mut s, "b-1", "b", 3), WaitStatus::Pending);
    assert_eq!(take(&mut s, "c-1", "c", 1), WaitStatus::Pending);
    assert_eq!(s.semaphore(&p).unwrap().value, 2);
    // The same ticket asking for another count is refused.
    let err = s
        .wait_units(&p, Some("b-1"), Some("b"), true, 2, t)
        .unwrap_err();
    assert_eq!(err.code, ErrorCode::Conflict);
    let err = s.wait_units(&p, None, None, false, 0, t).unwrap_err();
    assert_eq!(err.code, ErrorCode::BadParameter);
    // a gives its unit back: b gets all three, c still waits.
    let grants = s.signal_as(&p, None, Some("a"), t).unwrap().grants;
    let granted: Vec<&str> = grants.iter().map(|g| g.ticket.as_str()).collect();
    assert_eq!(granted, ["b-1"]);
    s.ack(&p, "b-1", t).unwrap();
    let st = s.semaphore(&p).unwrap();
    assert_eq!((st.value, st.waiters, st.held), (0, 1, 3));
    // b cannot give back more than it holds; two of three it can.
    let err = s.signal_units(&p, None, Some("b"), 4, t).unwrap_err();
    assert_eq!(err.code, ErrorCode::Conflict);
    assert!(err.message.contains("holds 3 unit"), "{}", err.message);
    let grants = s.signal_units(&p, None, Some("b"), 2, t).unwrap().grants;
    assert_eq!(grants.len(), 1);
    assert_eq!(grants[0].ticket, "c-1");
    s.ack(&p, "c-1", t).unwrap();
    // b dies with its last unit: it comes back; c's stays with c.
    s.owner_gone("b", t);
    let st = s.semaphore(&p).unwrap();
    assert_eq!((st.value, st.waiters, st.held), (2, 0, 1));
    // A granted wait for several that its owner leaves before the ack
    // gives all of them back.
    assert_eq!(take(&mut s, "d-1", "d", 2), WaitStatus::Granted);
    assert_eq!(s.semaphore(&p).unwrap().value, 0);
    s.owner_gone("d", t);
    assert_eq!(s.semaphore(&p).unwrap().value, 2);
}

#[test]
fn a_holder_never_seen_alive_loses_its_undo_unit_after_the_grace() {
    let mut s = Store::new(4);
    let t = Instant::now();
    let grace = Duration::from_secs(5);
    s.create(&n("P"), 1).unwrap();
    s.wait_undo(&n("P"), Some("a-1"), Some("a"), true, t)
        .unwrap();
    s.ack(&n("P"), "a-1", t).unwrap();
    assert!(s.sweep(t + grace / 2, grace, |_| false).is_empty());
    assert_eq!(s.semaphore(&n("P")).unwrap().held, 1);
    // Alive: kept however long.
    s.sweep(t + grace * 10, grace, |_| true);
    assert_eq!(s.semaphore(&n("P")).unwrap().held, 1);
    s.sweep(t + grace * 2, grace, |_| false);
    let st = s.semaphore(&n("P")).unwrap();
    assert_eq!((st.value, st.held), (1, 0));
}

#[test]
fn sweep_lapses_abandoned_places_and_orphaned_grants() {
    let mut s = Store::new(4);
    let t0 = Instant::now();
    let grace = Duration::from_secs(5);
    s.create(&n("S"), 0).unwrap();
    s.wait(&n("S"), Some("a"), Some("ghost"), t0).unwrap();
    s.wait(&n("S"), Some("b"), Some("live"), t0).unwrap();
    assert_eq!(
        s.release_hold("b", t0 + grace).unwrap().status,
        WaitStatus::Pending
    );
    // "a" is granted to an owner that was never seen alive.
    s.signal(&n("S"), None, t0).unwrap();
    let alive = |o: &str| o == "live";
    assert!(s
        .sweep(t0 + Duration::from_secs(1), grace, alive)
        .is_empty());
    assert_eq!(s.open_tickets(), 2);
    // After the grace "b" has lapsed (nobody asked again), and the
    // ghost's unit returns to the semaphore.
    assert!(s.sweep(t0 + grace, grace, alive).is_empty());
    assert_eq!(s.open_tickets(), 0);
    assert_eq!(s.semaphore(&n("S")).unwrap().value, 1);
}

#[test]
fn a_grant_never_confirmed_goes_back_even_if_the_owner_lives() {
    let mut s = Store::new(4).with_confirm_within(Duration::from_secs(60));
    let t0 = Instant::now();
    s.create(&n("S"), 0).unwrap();
    s.wait(&n("S"), Some("a"), Some("live"), t0).unwrap();
    s.signal(&n("S"), None, t0).unwrap();
    let grace = Duration::from_secs(5);
    s.sweep(t0 + Duration::from_secs(59), grace, |_| true);
    assert_eq!(s.open_tickets(), 1);
    s.sweep(t0 + Duration::from_secs(60), grace, |_| true);
    assert_eq!(s.open_tickets(), 0);
    assert_eq!(s.semaphore(&n("S")).unwrap().value, 1);
    // The late ack learns the unit is not its own.
    assert_eq!(s.ack(&n("S"), "a", t0).unwrap().status, WaitStatus::Unknown);
}

#[test]
fn anonymous_waits_time_out_and_their_grants_are_final() {
    let mut s = Store::new(4);
    let t = Instant::now();
    s.create(&n("S"), 0).unwrap();
    let r = s.wait(&n("S"), None, None, t).unwrap();
    assert_eq!(r.status, WaitStatus::Pending);
    assert_eq!(
        s.release_hold(&r.ticket, t).unwrap().status,
        WaitStatus::TimedOut
    );
    assert_eq!(s.semaphore(&n("S")).unwrap().waiters, 0);
    let r = s.wait(&n("S"), None, None, t).unwrap();
    let g = s.signal(&n("S"), None, t).unwrap().grants;
    assert_eq!(g[0].ticket, r.ticket);
    assert_eq!(s.open_tickets(), 0);
}

#[test]
fn retried_signal_and_try_wait_are_not_done_twice() {
    let mut s = Store::new(4);
    let t = Instant::now();
    s.create(&n("S"), 0).unwrap();
    s.signal(&n("S"), Some("s1"), t).unwrap();
    s.signal(&n("S"), Some("s1"), t).unwrap();
    assert_eq!(s.semaphore(&n("S")).unwrap().value, 1);
    s.signal(&n("S"), Some("s2"), t).unwrap();
    assert!(s.try_wait(&n("S"), Some("t1"), t).unwrap().acquired);
    assert!(s.try_wait(&n("S"), Some("t1"), t).unwrap().acquired);
    assert_eq!(s.semaphore(&n("S")).unwrap().value, 1);
    // Memory of finished requests expires after the retention.
    s.sweep(t + DEFAULT_RETENTION, Duration::ZERO, |_| true);
    s.signal(&n("S"), Some("s1"), t).unwrap();
    assert_eq!(s.semaphore(&n("S")).unwrap().value, 2);
}

/// The data server answers a wait from the queryable's callback only
/// when [`Store::wait_answers_at_once`] says it will not be held: the
/// two must agree in every state a mix of requests can reach.
#[test]
fn a_wait_answers_at_once_exactly_when_the_predicate_says_so() {
    let mut s = Store::new(4);
    let t = Instant::now();
    let sems = [n("A"), n("B")];
    for sem in &sems {
        s.create(sem, 1).unwrap();
    }
    // A fixed linear congruential sequence: the same mix every run.
    let mut x: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = |m: u64| {
        x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
        (x >> 33) % m
    };
    let (mut at_once, mut held, mut serial) = (0, 0, 0u64);
    for _ in 0..5_000 {
        // Mostly the last few tickets, sometimes a new one; a
        // ticket's number says its semaphore.
        serial += u64::from(next(3) == 0);
        let number = serial.saturating_sub(next(4));
        let (sem, ticket) = (&sems[(number % 2) as usize], format!("t{number}"));
        // Every third ticket waits for two units at once.
        let units = 1 + u64::from(number % 3 == 0);
        let owner = ["o1", "o2"][next(2) as usize];
        match next(12) {
            0..=5 => {
                let anonymous = next(4) == 0;
                let ticket = (!anonymous).then_some(ticket.as_str());
                let said = s.wait_answers_at_once(sem, ticket, units);
                let r = s.wait_units(sem, ticket, Some(owner), false, units, t);
                let answered = matches!(&r, Ok(r) if r.status != WaitStatus::Pending);
                assert_eq!(said, answered, "wait {sem} {ticket:?}: {r:?}");
                if said {
                    at_once += 1;
                } else if r.is_ok() {
                    held += 1;
                }
            }
            6 => drop(s.signal(sem, None, t)),
            7..=9 => drop(s.ack(sem, &ticket, t)),
            10 => drop(s.cancel(sem, &ticket)),
            _ => {
                if let Some(owner_gone) = [None, Some("o1"), Some("o2")][next(3) as usize] {
                    s.owner_gone(owner_gone, t);
                }
            }
        }
    }
    // Both answers were given many times.
    assert!(
        at_once > 100 && held > 100,
        "{at_once} at once, {held} held"
    );
}

#[test]
fn tickets_cannot_cross_semaphores() {
    let mut s = Store::new(4);
    let t = Instant::now();
    s.create(&n("A"), 0).unwrap();
    s.create(&n("B"), 0).unwrap();
    s.wait(&n("A"), Some("x"), Some("o"), t).unwrap();
    assert_eq!(
        s.wait(&n("B"), Some("x"), Some("o"), t).unwrap_err().code,
        ErrorCode::Conflict
    );
    assert_eq!(
        s.cancel(&n("B"), "x").unwrap_err().code,
        ErrorCode::Conflict
    );
}

#[test]
fn limits_refuse_with_quota_naming_the_limit_and_deletes_give_room_back() {
    let mut s = Store::new(2).with_limits(Limits {
        max_variables: 2,
        max_semaphores: 1,
        max_bytes: 10,
    });
    let now = Instant::now();
    let a = n("a");
    // "12345" is 7 bytes of JSON; a history of two holds 14: too many.
    s.set(&a, json!("12345"), None, now).unwrap();
    assert_eq!(s.bytes(), 7);
    let e = s.set(&a, json!("12345"), None, now).unwrap_err();
    assert_eq!(e.code, ErrorCode::Quota);
    assert!(e.message.contains("--max-mb"), "{e}");
    assert_eq!(s.get(&a, 0).unwrap(), &json!("12345"));
    // A history of one gives the old value's bytes back as it goes.
    s.history(&a, Some(1)).unwrap();
    s.set(&a, json!("67890"), None, now).unwrap();
    assert_eq!(s.bytes(), 7);
    // Variables and semaphores are counted.
    s.put(&n("b"), json!(1)).unwrap();
    let e = s.put(&n("c"), json!(1)).unwrap_err();
    assert_eq!(e.code, ErrorCode::Quota);
    assert!(e.message.contains("at most 2 variables"), "{e}");
    let e = s.history(&n("c"), Some(3)).unwrap_err();
    assert_eq!(e.code, ErrorCode::Quota);
    s.create(&n("S"), 0).unwrap();
    s.create(&n("S"), 0).unwrap();
    let e = s.create(&n("T"), 0).unwrap_err();
    assert!(e.message.contains("at most 1 semaphores"), "{e}");
    // A delete gives its bytes back.
    s.delete(&a);
    assert_eq!(s.bytes(), 1);
    s.set(&a, json!("12345"), None, now).unwrap();
}

#[test]
fn a_unit_taken_by_an_undo_try_wait_comes_back_when_its_owner_dies() {
    let mut s = Store::new(4);
    let t = Instant::now();
    s.create(&n("J"), 1).unwrap();
    let taken = s.try_wait_undo(&n("J"), Some("a-1"), Some("a"), t).unwrap();
    assert!(taken.acquired);
    // Taken by nobody else meanwhile: not free, and not free for a second try.
    assert!(
        !s.try_wait_undo(&n("J"), Some("b-1"), Some("b"), t)
            .unwrap()
            .acquired
    );
    let st = s.semaphore(&n("J")).unwrap();
    assert_eq!((st.value, st.held), (0, 1));
    // b queues; a dies holding the unit: b gets it.
    s.wait_undo(&n("J"), Some("b-2"), Some("b"), true, t)
        .unwrap();
    let grants = s.owner_gone("a", t);
    assert_eq!(grants.len(), 1);
    assert_eq!(grants[0].ticket, "b-2");
    // A plain try-wait's unit is final, whoever dies.
    s.ack(&n("J"), "b-2", t).unwrap();
    s.signal_as(&n("J"), None, Some("b"), t).unwrap();
    assert!(s.try_wait(&n("J"), Some("c-1"), t).unwrap().acquired);
    assert!(s.owner_gone("c", t).is_empty());
    assert_eq!(s.semaphore(&n("J")).unwrap().value, 0);
}
