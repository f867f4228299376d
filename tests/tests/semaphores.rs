//! No unit lost or duplicated: crashed waiters, timed-out waiters,
//! lost replies, and many clients using a semaphore as a mutex.

#![allow(clippy::unwrap_used)]

use rome_client::net::{open_loopback_peer, NetOptions};
use rome_client::{DataClient, DataOptions};
use rome_tests::{eventually, peer, TestServer};
use serde_json::json;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::Wait;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_waiter_killed_with_sigkill_loses_its_place_and_no_unit() {
    let server = TestServer::start().await;
    let ds = server.client("test").await;
    ds.create_semaphore("S", 0).await.unwrap();
    let mut waiter = peer!(server.port, ["waiter", "--sem", "S"]);
    eventually(Duration::from_secs(15), "the waiter is queued", || async {
        ds.semaphore("S").await.unwrap().waiters == 1
    })
    .await;
    waiter.kill(); // SIGKILL: no goodbye, only the broken link.
    eventually(
        Duration::from_secs(15),
        "the dead waiter's place is dropped",
        || async { ds.semaphore("S").await.unwrap().waiters == 0 },
    )
    .await;
    let signal = ds.signal("S").await.unwrap();
    assert!(!signal.woke, "the unit went to a dead waiter");
    assert_eq!(signal.value, 1);
    assert!(
        ds.try_wait("S").await.unwrap(),
        "the unit is there for the living"
    );
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_wait_dropped_by_a_living_client_gives_its_place_up_and_its_unit_back() {
    // A living client keeps a queued place it stops asking about for the
    // server's grace: a minute here, so only the client can give it up.
    let server = TestServer::start_with(rome_data::ServerConfig {
        grace: Duration::from_secs(60),
        ..rome_data::ServerConfig::default()
    })
    .await;
    let ds = server.client("test").await;
    ds.create_semaphore("S", 0).await.unwrap();
    for undo in [false, true] {
        // A wait dropped while queued (a select! that went the other way).
        // The client stays alive: only its wait goes.
        let a = server.client("a").await;
        let alive = a.clone();
        let queued = tokio::spawn(async move {
            if undo {
                a.wait_undo("S").await
            } else {
                a.wait("S").await
            }
        });
        eventually(Duration::from_secs(15), "the wait is queued", || async {
            ds.semaphore("S").await.unwrap().waiters == 1
        })
        .await;
        queued.abort();
        eventually(
            Duration::from_secs(15),
            "the dropped wait leaves the queue",
            || async { ds.semaphore("S").await.unwrap().waiters == 0 },
        )
        .await;
        let signal = ds.signal("S").await.unwrap();
        assert!(
            !signal.woke,
            "the unit went to a dropped wait (undo {undo})"
        );
        assert!(ds.try_wait("S").await.unwrap(), "the unit is there");
        drop(alive);
    }
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_passage_held_by_a_client_killed_with_sigkill_opens_for_the_next() {
    // $passage/N guards a corridor one robot wide: a Planner holds it with
    // an undo wait. Killed inside, its unit must come back by itself.
    let server = TestServer::start().await;
    let ds = server.client("test").await;
    ds.create_semaphore("$passage/N", 1).await.unwrap();
    let mut holder = peer!(server.port, ["holder", "--sem", "$passage/N"]);
    eventually(Duration::from_secs(15), "the holder holds it", || async {
        let s = ds.semaphore("$passage/N").await.unwrap();
        (s.value, s.held) == (0, 1)
    })
    .await;
    // The next robot queues behind it.
    let next = server.client("next").await;
    let waiting = tokio::spawn(async move {
        next.wait_undo("$passage/N").await.unwrap();
        next
    });
    eventually(Duration::from_secs(15), "the next one waits", || async {
        ds.semaphore("$passage/N").await.unwrap().waiters == 1
    })
    .await;
    holder.kill(); // SIGKILL inside the passage.
    let next = tokio::time::timeout(Duration::from_secs(30), waiting)
        .await
        .expect("the passage opened for the next one")
        .unwrap();
    let s = ds.semaphore("$passage/N").await.unwrap();
    assert_eq!(
        (s.value, s.waiters, s.held),
        (0, 0, 1),
        "exactly one holder"
    );
    // It leaves and gives the unit back: the passage is free, one unit.
    next.give_back("$passage/N").await.unwrap();
    let s = ds.semaphore("$passage/N").await.unwrap();
    assert_eq!((s.value, s.held), (1, 0));
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_wait_for_every_unit_ends_when_the_last_holder_leaves_or_dies() {
    // A one-way lane: robots going one way each hold a unit of its
    // semaphore; one about to go the other way waits for all of them.
    let server = TestServer::start().await;
    let ds = server.client("test").await;
    ds.create_semaphore("Lane", 3).await.unwrap();
    let mut dies = peer!(server.port, ["holder", "--sem", "Lane"]);
    let leaves = server.client("leaves").await;
    leaves.wait_undo("Lane").await.unwrap();
    eventually(Duration::from_secs(15), "two hold a unit", || async {
        let s = ds.semaphore("Lane").await.unwrap();
        (s.value, s.held) == (1, 2)
    })
    .await;
    let other_way = server.client("other-way").await;
    let waiting = tokio::spawn(async move {
        other_way.wait_undo_units("Lane", 3).await.unwrap();
        other_way
    });
    eventually(Duration::from_secs(15), "the other way waits", || async {
        ds.semaphore("Lane").await.unwrap().waiters == 1
    })
    .await;
    // One unit alone is not taken past the queued wait for three.
    assert!(
        !ds.try_wait("Lane").await.unwrap(),
        "a unit went past the wait for all"
    );
    leaves.give_back("Lane").await.unwrap();
    assert_eq!(
        ds.semaphore("Lane").await.unwrap().waiters,
        1,
        "granted with one still held"
    );
    dies.kill(); // SIGKILL in the lane: its unit comes back by itself.
    let other_way = tokio::time::timeout(Duration::from_secs(30), waiting)
        .await
        .expect("the wait for every unit ended")
        .unwrap();
    let s = ds.semaphore("Lane").await.unwrap();
    assert_eq!((s.value, s.waiters, s.held), (0, 0, 3));
    other_way.give_back_units("Lane", 3).await.unwrap();
    let s = ds.semaphore("Lane").await.unwrap();
    assert_eq!((s.value, s.held), (3, 0));
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn waiters_that_time_out_and_retry_lose_and_duplicate_nothing() {
    const UNITS: u64 = 150;
    let server = TestServer::start().await;
    let producer = server.client("producer").await;
    producer.create_semaphore("S", 0).await.unwrap();
    let taken = Arc::new(AtomicU64::new(0));
    let mut consumers = Vec::new();
    for c in 0..3u64 {
        let ds = server.client("consumer").await;
        let taken = taken.clone();
        consumers.push(tokio::spawn(async move {
            let mut mine = 0u64;
            let mut timeouts = 0u64;
            // Very short timeouts, so waits give up while units arrive.
            let mut ms = 1 + c;
            while taken.load(Ordering::SeqCst) < UNITS {
                if ds
                    .wait_timeout("S", Duration::from_millis(ms))
                    .await
                    .unwrap()
                {
                    mine += 1;
                    taken.fetch_add(1, Ordering::SeqCst);
                } else {
                    timeouts += 1;
                }
                ms = ms % 7 + 1;
            }
            (mine, timeouts)
        }));
    }
    for i in 0..UNITS {
        producer.signal("S").await.unwrap();
        if i % 10 == 0 {
            tokio::task::yield_now().await;
        }
    }
    let mut total = 0;
    let mut timeouts = 0;
    for c in consumers {
        let (mine, t) = tokio::time::timeout(Duration::from_secs(60), c)
            .await
            .expect("consumers take every unit (none lost)")
            .unwrap();
        total += mine;
        timeouts += t;
    }
    let state = producer.semaphore("S").await.unwrap();
    assert_eq!(total + state.value, UNITS, "units lost or duplicated");
    assert_eq!(total, UNITS);
    assert_eq!(state.waiters, 0, "cancelled waits left in the queue");
    assert!(
        timeouts > 0,
        "no wait timed out, so the test proved nothing"
    );
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_request_sent_again_after_a_lost_reply_is_done_once() {
    // What a retry is on the wire: the same request with the same op id
    // or ticket, sent again because the first reply never arrived.
    let server = TestServer::start().await;
    let check = server.client("check").await;
    check.create_semaphore("S", 0).await.unwrap();
    let z = server.session().await;
    let ask = |selector: &'static str, payload: Option<&'static str>| {
        let z = z.clone();
        async move {
            let mut get = z.get(selector);
            if let Some(p) = payload {
                get = get.payload(p);
            }
            let reply = get.await.unwrap().recv_async().await.unwrap();
            let body = reply
                .result()
                .expect("success")
                .payload()
                .to_bytes()
                .into_owned();
            serde_json::from_slice::<serde_json::Value>(&body).unwrap()
        }
    };
    for selector in ["rome/data/signal/S?op=x.1", "rome/data/signal/S?op=x.1"] {
        assert_eq!(ask(selector, None).await["value"], 1);
    }
    let first = ask("rome/data/set/v?op=x.2", Some("7")).await;
    assert_eq!(ask("rome/data/set/v?op=x.2", Some("7")).await, first);
    assert_eq!(
        check.history("v").await.unwrap().seq,
        1,
        "a repeated set committed twice"
    );
    // An owned wait granted at once, its grant reply lost: the repeat
    // learns the same grant, and the ack (sent twice) confirms one unit.
    let owner = check.owner().to_string();
    let wait = format!("rome/data/wait/S?ticket=x.3;owner={owner}");
    let wait: &'static str = Box::leak(wait.into_boxed_str());
    assert_eq!(ask(wait, None).await["status"], "granted");
    assert_eq!(ask(wait, None).await["status"], "granted");
    for _ in 0..2 {
        assert_eq!(
            ask("rome/data/ack/S?ticket=x.3", None).await["status"],
            "confirmed"
        );
    }
    assert_eq!(
        check.semaphore("S").await.unwrap().value,
        0,
        "the unit was taken twice"
    );
    for selector in ["rome/data/try-wait/S?op=x.4", "rome/data/try-wait/S?op=x.4"] {
        assert_eq!(ask(selector, None).await["acquired"], false);
    }
    check.signal("S").await.unwrap();
    assert_eq!(check.semaphore("S").await.unwrap().value, 1);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_client_retries_a_lost_reply_with_the_same_id() {
    // A stand-in data server that loses the reply to the first attempt of
    // every request and answers the second, recording the ids it saw. With
    // the test above (the real server does a repeated id once) this covers
    // the whole path of a lost reply.
    let (fake, port) = open_loopback_peer(&[]).await.unwrap();
    let seen: Arc<Mutex<HashMap<String, u32>>> = Arc::default();
    let record = seen.clone();
    let _q = fake
        .declare_queryable("rome/data/**")
        .callback(move |q| {
            let id = q
                .parameters()
                .get("op")
                .or_else(|| q.parameters().get("ticket"))
                .unwrap_or("-")
                .to_string();
            let n = {
                let mut seen = record.lock().unwrap();
                let n = seen.entry(id.clone()).or_insert(0);
                *n += 1;
                *n
            };
            if n == 1 {
                return; // dropped unanswered: the reply is "lost"
            }
            let key = q.key_expr().as_str().to_string();
            let body = if key.contains("/set/") {
                json!({"name": "v", "seq": 1})
            } else {
                json!({"name": "S", "value": 1, "woke": false})
            };
            let _ = q.reply(key, body.to_string()).wait();
        })
        .await
        .unwrap();
    let _token = fake
        .liveliness()
        .declare_token("rome/alive/server/data/fake")
        .await
        .unwrap();

    let session = NetOptions::loopback(None, &[port]).open().await.unwrap();
    let ds = DataClient::connect(&session, DataOptions::new("lossy"))
        .await
        .unwrap();
    for i in 0..10u64 {
        assert_eq!(ds.set("v", &i).await.unwrap(), 1);
        assert_eq!(ds.signal("S").await.unwrap().value, 1);
    }
    let seen = seen.lock().unwrap();
    assert_eq!(
        seen.len(),
        20,
        "each call keeps one id across its retries: {seen:?}"
    );
    assert!(
        seen.values().all(|&n| n == 2),
        "each id sent exactly twice: {seen:?}"
    );
    assert_eq!(ds.retries(), 20);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fifty_clients_count_exactly_under_a_semaphore_mutex() {
    const CLIENTS: usize = 50;
    const ROUNDS: u64 = 4;
    let server = TestServer::start().await;
    let setup = server.client("setup").await;
    setup.create_semaphore("mutex", 1).await.unwrap();
    setup.set("count", &0).await.unwrap();
    let mut tasks = Vec::new();
    for _ in 0..CLIENTS {
        let ds = server.client("counter").await;
        tasks.push(tokio::spawn(async move {
            for _ in 0..ROUNDS {
                ds.wait("mutex").await.unwrap();
                let n: u64 = ds.get_as("count").await.unwrap();
                ds.set("count", &(n + 1)).await.unwrap();
                ds.signal("mutex").await.unwrap();
            }
        }));
    }
    for t in tasks {
        tokio::time::timeout(Duration::from_secs(120), t)
            .await
            .expect("clients finish")
            .unwrap();
    }
    let count: u64 = setup.get_as("count").await.unwrap();
    assert_eq!(count, CLIENTS as u64 * ROUNDS);
    let m = setup.semaphore("mutex").await.unwrap();
    assert_eq!((m.value, m.waiters), (1, 0));
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn long_waits_keep_their_place_across_polls_fifo() {
    let server = TestServer::start().await;
    let ds = server.client("signaller").await;
    ds.create_semaphore("S", 0).await.unwrap();
    // A 40 ms hold turns every wait into a series of polls: the order can
    // only hold if each poll keeps the ticket's place.
    let mut order = Vec::new();
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    for who in 0..3u32 {
        let mut options = DataOptions::new("waiter");
        options.hold = Duration::from_millis(40);
        let waiter = server.client_with(options).await;
        let tx = tx.clone();
        tokio::spawn(async move {
            waiter.wait("S").await.unwrap();
            tx.send(who).unwrap();
        });
        // Queue them one after the other, so FIFO has a known answer.
        eventually(Duration::from_secs(10), "waiter queued", || async {
            ds.semaphore("S").await.unwrap().waiters == who + 1
        })
        .await;
    }
    // Time passing is what is under test here, not a stand-in for an
    // event: every wait goes through about ten polls before a unit comes.
    tokio::time::sleep(Duration::from_millis(400)).await;
    assert_eq!(
        ds.semaphore("S").await.unwrap().waiters,
        3,
        "a place was lost between polls"
    );
    for _ in 0..3 {
        ds.signal("S").await.unwrap();
        order.push(
            tokio::time::timeout(Duration::from_secs(10), rx.recv())
                .await
                .unwrap()
                .unwrap(),
        );
    }
    assert_eq!(order, [0, 1, 2]);
    server.stop().await;
}
