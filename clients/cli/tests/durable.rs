//! A durable data server (`rome data-server --data-dir`) killed with
//! SIGKILL in the middle of a stream of acknowledged writes and signals,
//! and a router killed the same way between the clients and the data
//! server: the clients ride through, and after the restarts every
//! acknowledged value is there once, in order, every acknowledged signal
//! counted once, and a waiter queued before the kills gets its unit.

#![allow(clippy::unwrap_used)]

use rome_client::data::{DataClient, DataOptions};
use rome_client::net::NetOptions;
use rome_tests::ChildGuard;
use std::path::{Path, PathBuf};

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

const ROME: &str = env!("CARGO_BIN_EXE_rome");

fn scratch(what: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rome-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `rome ARGS`, its stderr appended to `log`.
fn rome(args: &[&str], log: &Path) -> ChildGuard {
    rome_tests::spawn_logged(ROME, args, log)
}

/// Acknowledged sets of 0, 1, 2 … to `seq{k}` (history long enough for
/// all), each followed by an acknowledged signal of `count{k}`, until
/// `stop`. Returns how many of each were acknowledged; `acked` follows
/// along.
async fn stream(data: DataClient, k: usize, acked: Arc<AtomicU64>, stop: Arc<AtomicBool>) -> u64 {
    let (seq, count) = (format!("seq{k}"), format!("count{k}"));
    let mut i = 0;
    while !stop.load(Ordering::Relaxed) {
        data.set(&seq, &i).await.unwrap();
        data.signal(&count).await.unwrap();
        i += 1;
        acked.store(i, Ordering::Relaxed);
    }
    i
}

/// Waits until `acked` has grown by `more` since now.
async fn await_more(acked: &AtomicU64, more: u64) {
    let from = acked.load(Ordering::Relaxed);
    let deadline = Instant::now() + Duration::from_secs(60);
    while acked.load(Ordering::Relaxed) < from + more {
        assert!(
            Instant::now() < deadline,
            "the writer stalled at {}",
            acked.load(Ordering::Relaxed)
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

/// Every acknowledged value of stream `k` is in the history once, in
/// order, and every acknowledged signal counted once.
async fn check(data: &DataClient, k: usize, written: u64) {
    let (seq, count) = (format!("seq{k}"), format!("count{k}"));
    let info = data.history(&seq).await.unwrap();
    assert_eq!(
        info.stored as u64, written,
        "the history holds {} values but {written} were acknowledged ({info:?})",
        info.stored
    );
    for back in 0..written {
        let v = data.get_back(&seq, back as u32).await.unwrap();
        assert_eq!(
            v,
            serde_json::json!(written - 1 - back),
            "{seq}: value {back} back"
        );
    }
    let count = data.semaphore(&count).await.unwrap();
    assert_eq!(count.value, written, "acknowledged signals counted wrong");
}

fn client_options() -> DataOptions {
    DataOptions {
        // A restart takes a second or two on a loaded machine.
        request_timeout: Duration::from_secs(60),
        connect_timeout: Duration::from_secs(60),
        ..DataOptions::new("durability-test")
    }
}

/// A client of the data server on `port`, ready for [`stream`] `0..n`:
/// each `seq{k}` keeps every write, each `count{k}` exists.
async fn writer(port: u16, n: usize) -> (zenoh::Session, DataClient) {
    let session = NetOptions::loopback_client(port).open().await.unwrap();
    let data = DataClient::connect(&session, client_options())
        .await
        .unwrap();
    for k in 0..n {
        data.set_history(&format!("seq{k}"), 100_000).await.unwrap();
        data.create_semaphore(&format!("count{k}"), 0)
            .await
            .unwrap();
    }
    (session, data)
}

/// `rome data-server --data-dir` on a port of the system's choosing, with
/// its arguments to start it again on the same port.
fn durable_server(dir: &Path) -> (ChildGuard, u16, Vec<String>) {
    let log = dir.join("data-server.log");
    let data_dir = dir.join("state");
    let mut args: Vec<String> = [
        "--no-multicast",
        "-l",
        "tcp/127.0.0.1:0",
        "data-server",
        "--data-dir",
        data_dir.to_str().unwrap(),
    ]
    .map(String::from)
    .to_vec();
    let server = rome(&args.iter().map(String::as_str).collect::<Vec<_>>(), &log);
    let port = rome_tests::listening_port(&log, Duration::from_secs(60));
    args[2] = format!("tcp/127.0.0.1:{port}");
    (server, port, args)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn acknowledged_state_survives_sigkill_of_the_data_server() {
    let dir = scratch("durable-data");
    let log = dir.join("data-server.log");
    // First on a port the system gives it, then always on that one.
    let (mut server, port, server_args) = durable_server(&dir);
    let server_args: Vec<&str> = server_args.iter().map(String::as_str).collect();

    let (session, data) = writer(port, 1).await;
    data.create_semaphore("gate", 0).await.unwrap();
    // A waiter queued before the kills keeps its place through them.
    let waiter = {
        let data = data.clone();
        tokio::spawn(async move { data.wait("gate").await })
    };
    rome_tests::eventually(Duration::from_secs(30), "the waiter is queued", || {
        let data = data.clone();
        async move { data.semaphore("gate").await.is_ok_and(|s| s.waiters == 1) }
    })
    .await;

    let acked = Arc::new(AtomicU64::new(0));
    let stop = Arc::new(AtomicBool::new(false));
    let writer = tokio::spawn(stream(data.clone(), 0, acked.clone(), stop.clone()));
    // Kills land at different points of the request stream.
    for (round, more) in [37u64, 101, 13].into_iter().enumerate() {
        await_more(&acked, more).await;
        server.kill();
        let before = acked.load(Ordering::Relaxed);
        server = rome(&server_args, &log);
        // The writer carries on by itself once the server is back.
        await_more(&acked, 5).await;
        eprintln!("round {round}: killed after {before} acknowledged pairs");
    }
    stop.store(true, Ordering::Relaxed);
    let written = writer.await.unwrap();
    assert!(written > 150, "only {written} pairs written");

    check(&data, 0, written).await;
    assert_eq!(data.semaphore("gate").await.unwrap().waiters, 1);
    data.signal("gate").await.unwrap();
    tokio::time::timeout(Duration::from_secs(30), waiter)
        .await
        .expect("the waiter queued before the kills never got its unit")
        .unwrap()
        .unwrap();
    let gate = data.semaphore("gate").await.unwrap();
    assert_eq!((gate.value, gate.waiters), (0, 0), "{gate:?}");

    // And once more from a cold start, with nobody connected in between.
    server.kill();
    drop(data);
    session.close().await.unwrap();
    let _server = rome(&server_args, &log);
    rome_tests::await_port(port, Duration::from_secs(60));
    let session = NetOptions::loopback_client(port).open().await.unwrap();
    let data = DataClient::connect(&session, client_options())
        .await
        .unwrap();
    check(&data, 0, written).await;
    let _ = std::fs::remove_dir_all(dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn clients_ride_through_a_router_killed_and_restarted() {
    let dir = scratch("durable-router");
    let log = dir.join("rome.log");
    let mut router_args = rome_tests::ROUTER;
    let mut router = rome(&router_args, &log);
    let port = rome_tests::listening_port(&log, Duration::from_secs(60));
    let router_ep = format!("tcp/127.0.0.1:{port}");
    router_args[2] = &router_ep;
    let data_dir = dir.join("state");
    let _server = rome(
        &[
            "--no-multicast",
            "-m",
            "client",
            "-e",
            &router_ep,
            "data-server",
            "--data-dir",
            data_dir.to_str().unwrap(),
        ],
        &log,
    );
    let (_session, data) = writer(port, 1).await;

    let acked = Arc::new(AtomicU64::new(0));
    let stop = Arc::new(AtomicBool::new(false));
    let writer = tokio::spawn(stream(data.clone(), 0, acked.clone(), stop.clone()));
    for more in [41u64, 7] {
        await_more(&acked, more).await;
        router.kill();
        router = rome(&router_args, &log);
        await_more(&acked, 5).await;
    }
    stop.store(true, Ordering::Relaxed);
    let written = writer.await.unwrap();
    check(&data, 0, written).await;
    let _ = std::fs::remove_dir_all(dir);
}

/// Requests that arrive together share one sync (group commit); each is
/// still answered only once it is on disk. Eight writers at once, the
/// server killed three times among them.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn acknowledged_writes_of_many_clients_at_once_survive_sigkill() {
    const WRITERS: usize = 8;
    let dir = scratch("durable-many");
    let log = dir.join("data-server.log");
    let (mut server, port, server_args) = durable_server(&dir);
    let server_args: Vec<&str> = server_args.iter().map(String::as_str).collect();
    let (_session, data) = writer(port, WRITERS).await;
    let stop = Arc::new(AtomicBool::new(false));
    let acked: Vec<Arc<AtomicU64>> = (0..WRITERS).map(|_| Arc::default()).collect();
    let writers: Vec<_> = (0..WRITERS)
        .map(|k| tokio::spawn(stream(data.clone(), k, acked[k].clone(), stop.clone())))
        .collect();
    for more in [29u64, 7, 53] {
        await_more(&acked[more as usize % WRITERS], more).await;
        server.kill();
        server = rome(&server_args, &log);
        for a in &acked {
            await_more(a, 3).await;
        }
    }
    stop.store(true, Ordering::Relaxed);
    for (k, w) in writers.into_iter().enumerate() {
        let written = w.await.unwrap();
        check(&data, k, written).await;
    }
    let _ = std::fs::remove_dir_all(dir);
}
