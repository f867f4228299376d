//! No unit lost or duplicated: crashed waiters, timed-out waiters,
//! lost replies, and many clients using a semaphore as a mutex.

use rome_client::DataOptions;
use rome_tests::{eventually, peer, TestServer};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

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
    eventually(Duration::from_secs(15), "the dead waiter's place is dropped", || async {
        ds.semaphore("S").await.unwrap().waiters == 0
    })
    .await;
    let signal = ds.signal("S").await.unwrap();
    assert!(!signal.woke, "the unit went to a dead waiter");
    assert_eq!(signal.value, 1);
    assert!(ds.try_wait("S").await.unwrap(), "the unit is there for the living");
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
                if ds.wait_timeout("S", Duration::from_millis(ms)).await.unwrap() {
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
    assert!(timeouts > 0, "no wait timed out, so the test proved nothing");
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn replies_lost_to_the_client_are_retried_without_repeats() {
    let server = TestServer::start().await;
    // An attempt timeout far below the round trip: nearly every first
    // attempt is abandoned by the client while the server carries it out,
    // exactly as if the reply had been lost, and is retried.
    let mut options = DataOptions::new("lossy");
    options.attempt_timeout = Duration::from_micros(200);
    options.request_timeout = Duration::from_secs(30);
    let lossy = server.client_with(options).await;
    lossy.create_semaphore("S", 0).await.unwrap();
    for i in 1..=100u64 {
        let seq = lossy.set("v", &i).await.unwrap();
        assert_eq!(seq, i, "a retried write was committed twice");
        lossy.signal("S").await.unwrap();
    }
    let check = server.client("check").await;
    assert_eq!(check.semaphore("S").await.unwrap().value, 100, "a retried signal counted twice");
    let mut took = 0;
    while check.try_wait("S").await.unwrap() {
        took += 1;
    }
    assert_eq!(took, 100);
    assert_eq!(check.history("v").await.unwrap().seq, 100);
    assert!(lossy.retries() > 0, "no attempt was abandoned, so nothing was retried");
    server.stop().await;
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
