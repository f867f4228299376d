//! `rome router` with its built-in plugins: servers and clients that name
//! only the router find each other through it, the REST plugin answers
//! `curl`-style HTTP for a variable and a robot's pose, and the storage
//! manager keeps `rome/store/**`; and a lock record kept by the router
//! outlives a SIGKILL of the router and of the robot's servers at once;
//! and the REST port answers only once the router listens.

#![allow(clippy::unwrap_used)]

use rome_client::net::{free_loopback_port, NetOptions};
use rome_tests::ChildGuard;
use std::io::{Read, Write};

use std::time::{Duration, Instant};

const ROME: &str = env!("CARGO_BIN_EXE_rome");

fn rome(args: &[&str]) -> ChildGuard {
    let log = std::env::temp_dir().join("rome-router-test.log");
    rome_tests::spawn_logged(ROME, args, &log)
}

/// One HTTP GET on loopback; the status line and the body.
fn http_get(port: u16, path: &str) -> Option<(String, String)> {
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).ok()?;
    s.set_read_timeout(Some(Duration::from_secs(10))).ok()?;
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n"
    )
    .ok()?;
    let mut text = String::new();
    s.read_to_string(&mut text).ok()?;
    let (head, body) = text.split_once("\r\n\r\n")?;
    Some((head.lines().next()?.to_string(), body.to_string()))
}

/// One HTTP PUT of a JSON body on loopback; the status line.
fn http_put(port: u16, path: &str, body: &str) -> Option<String> {
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).ok()?;
    s.set_read_timeout(Some(Duration::from_secs(10))).ok()?;
    write!(
        s,
        "PUT {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n\
         Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )
    .ok()?;
    let mut text = String::new();
    s.read_to_string(&mut text).ok()?;
    Some(text.lines().next()?.to_string())
}

/// Polls until `path` answers 200 with a body containing `want`.
fn await_http(port: u16, path: &str, want: &str) -> String {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let got = http_get(port, path);
        if let Some((status, body)) = &got {
            if status.contains(" 200") && body.contains(want) {
                return body.clone();
            }
        }
        assert!(
            Instant::now() < deadline,
            "GET {path} never gave '{want}': {got:?}"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn servers_and_clients_meet_through_the_router_and_rest_answers() {
    // The REST plugin must be told its port; Zenoh's is the system's choice.
    let rest = free_loopback_port().unwrap();
    let rest_s = rest.to_string();
    let (_router, port, _) = rome_tests::spawn_listening(
        ROME,
        &[
            "--no-multicast",
            "-l",
            "tcp/127.0.0.1:0",
            "router",
            "--rest-port",
            &rest_s,
            "--in-memory",
        ],
    );
    let router_ep = format!("tcp/127.0.0.1:{port}");
    // Each names only the router, as on other hosts.
    let via = ["--no-multicast", "-m", "client", "-e", router_ep.as_str()];
    let _data = rome(&[&via[..], &["data-server", "--in-memory"]].concat());
    let _sim = rome(&[&via[..], &["sim", "--robots", "1", "--at", "350R"]].concat());
    let _dispatcher = rome(&[&via[..], &["dispatcher"]].concat());

    let session = NetOptions::loopback_client(port).open().await.unwrap();
    let ds = rome_client::DataClient::connect(&session, rome_client::DataOptions::new("test"))
        .await
        .unwrap();
    ds.set("PosX", &serde_json::json!(1234)).await.unwrap();
    rome_client::alive::await_server(
        &session,
        &rome_schema::Root::default(),
        "robot",
        "r1/base",
        Duration::from_secs(60),
    )
    .await
    .unwrap();

    let (var, pose) = tokio::task::spawn_blocking(move || {
        (
            await_http(rest, "/rome/data/var/PosX", "1234"),
            await_http(rest, "/rome/robot/r1/base/pose", "x_mm"),
        )
    })
    .await
    .unwrap();
    assert!(var.contains("\"rome/data/var/PosX\""), "{var}");
    let replies: serde_json::Value = serde_json::from_str(&pose).unwrap();
    let value = &replies[0]["value"];
    assert!(value["x_mm"].is_number(), "{pose}");

    // The router's storage keeps what is put under rome/store/**.
    session
        .put("rome/store/test/record", "{\"kept\":true}")
        .encoding(zenoh::bytes::Encoding::APPLICATION_JSON)
        .await
        .unwrap();
    let stored =
        tokio::task::spawn_blocking(move || await_http(rest, "/rome/store/test/record", "kept"))
            .await
            .unwrap();
    assert!(stored.contains("rome/store/test/record"), "{stored}");

    // A fleet task added with a REST PUT reaches the dispatcher, which
    // queues it (no robot takes tasks here).
    let put = tokio::task::spawn_blocking(move || {
        http_put(rest, "/rome/data/var/fleet/task/rest-1", r#"{"to":"356R"}"#)
    })
    .await
    .unwrap();
    assert!(
        put.as_deref().is_some_and(|s| s.contains(" 200")),
        "{put:?}"
    );
    let status = tokio::task::spawn_blocking(move || {
        await_http(rest, "/rome/data/var/fleet/status/rest-1", "queued")
    })
    .await
    .unwrap();
    assert!(status.contains("356R"), "{status}");
    let _ = session.close().await;
}

/// Scripts wait for the REST port and then start servers that take the
/// Zenoh port if it is free (docs/observing.md). So the first moment REST
/// answers, the router must already hold its port: were the plugins started
/// before the listeners, a server started then could take the port and the
/// router would exit.
#[test]
fn the_rest_port_answers_only_once_the_router_holds_its_own() {
    let rest = free_loopback_port().unwrap();
    let zenoh = free_loopback_port().unwrap();
    let listen = format!("tcp/127.0.0.1:{zenoh}");
    let rest_s = rest.to_string();
    let _router = rome(&[
        "--no-multicast",
        "-l",
        &listen,
        "router",
        "--rest-port",
        &rest_s,
        "--in-memory",
    ]);
    // Polled as fast as the port can be tried: the slower the polling, the
    // more likely the listener is up by the time REST is first seen.
    let deadline = Instant::now() + Duration::from_secs(60);
    while std::net::TcpStream::connect(("127.0.0.1", rest)).is_err() {
        assert!(Instant::now() < deadline, "REST never answered on {rest}");
        std::thread::sleep(Duration::from_micros(200));
    }
    let taken = std::net::TcpListener::bind(("127.0.0.1", zenoh));
    assert!(
        taken.is_err(),
        "port {zenoh} was still free when REST on {rest} first answered"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lock_record_outlives_the_router_and_the_robot_killed_together() {
    let dir = std::env::temp_dir().join(format!(
        "rome-router-store-{}-{:?}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default()
            .as_nanos()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    let dir_s = dir.display().to_string();
    let mut router_args = [
        "--no-multicast",
        "-l",
        "tcp/127.0.0.1:0",
        "router",
        "--rest-port",
        "none",
        "--data-dir",
        &dir_s,
    ];
    // First on a port the system gives it, then always on that one.
    let (mut router, port, _) = rome_tests::spawn_listening(ROME, &router_args);
    let router_ep = format!("tcp/127.0.0.1:{port}");
    router_args[2] = &router_ep;
    let via = ["--no-multicast", "-m", "client", "-e", router_ep.as_str()];
    // The router keeps the records: the robot runs no storage of its own.
    let sim_args = [
        &via[..],
        &["sim", "--robots", "1", "--at", "350R", "--no-storage"],
    ]
    .concat();
    let mut sim = rome(&sim_args);

    let session = NetOptions::loopback_client(port).open().await.unwrap();
    let root = rome_schema::Root::default();
    rome_client::alive::await_server(&session, &root, "robot", "r1/base", Duration::from_secs(60))
        .await
        .unwrap();
    let client =
        rome_client::RobotClient::connect(&session, "r1", rome_client::RobotOptions::new("holder"))
            .await
            .unwrap();
    let lock = client.lock().await.unwrap();
    let fence = lock.fence();
    // The record is in the router's storage once a query finds it there.
    let robot = rome_schema::Name::new("r1").unwrap();
    let key = root.lock_store(&robot, &rome_schema::robot::Device::Base);
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let replies = session.get(&key).await.unwrap();
        let mut seen = None;
        while let Ok(reply) = replies.recv_async().await {
            match reply.result() {
                Ok(sample) => {
                    seen = Some(String::from_utf8_lossy(&sample.payload().to_bytes()).into_owned())
                }
                Err(e) => {
                    seen = Some(format!(
                        "error reply: {}",
                        String::from_utf8_lossy(&e.payload().to_bytes())
                    ))
                }
            }
        }
        if seen
            .as_deref()
            .is_some_and(|r| r.contains(&format!("\"fence\":{fence}")))
        {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "lock record never stored: {seen:?}"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }

    // Power lost at both: everything killed at once, then started again.
    router.kill();
    sim.kill();
    let _router = rome(&router_args);
    rome_tests::await_port(port, Duration::from_secs(60));
    // As a robot booting after its router would (one that boots first stores
    // its record again when the storage comes up, but cannot know the old
    // holder).
    rome_client::alive::await_server(&session, &root, "store", "*", Duration::from_secs(60))
        .await
        .unwrap();
    let _sim = rome(&sim_args);
    rome_client::alive::await_server(&session, &root, "robot", "r1/base", Duration::from_secs(60))
        .await
        .unwrap();

    // The new base server knows the holder and its fence …
    let state = client.state().await.unwrap();
    let s = state.next().await.unwrap().unwrap();
    assert_eq!(
        s.lock.map(|l| l.fence),
        Some(fence),
        "the lock was forgotten"
    );
    // … and the next grant goes above it.
    lock.unlock().await.unwrap();
    let again = client.lock().await.unwrap();
    assert_eq!(again.fence(), fence + 1);
    let _ = session.close().await;
    let _ = std::fs::remove_dir_all(dir);
}
