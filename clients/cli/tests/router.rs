//! `rome router` with its built-in plugins: servers and clients that name
//! only the router find each other through it, the REST plugin answers
//! `curl`-style HTTP for a variable and a robot's pose, and the storage
//! manager keeps `rome/store/**`.

#![allow(clippy::unwrap_used)]

use rome_client::net::{free_loopback_port, NetOptions};
use rome_tests::ChildGuard;
use std::io::{Read, Write};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const ROME: &str = env!("CARGO_BIN_EXE_rome");

fn rome(args: &[&str]) -> ChildGuard {
    ChildGuard(Some(
        Command::new(ROME)
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    ))
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
    let port = free_loopback_port().unwrap();
    let rest = free_loopback_port().unwrap();
    let router_ep = format!("tcp/127.0.0.1:{port}");
    let rest_s = rest.to_string();
    let _router = rome(&[
        "--no-multicast",
        "-l",
        &router_ep,
        "router",
        "--rest-port",
        &rest_s,
    ]);
    // The router is up once its port takes connections.
    rome_tests::await_port(port, Duration::from_secs(60));
    // Each names only the router, as on other hosts.
    let via = ["--no-multicast", "-m", "client", "-e", router_ep.as_str()];
    let _data = rome(&[&via[..], &["data-server", "--in-memory"]].concat());
    let _sim = rome(&[&via[..], &["sim", "--robots", "1", "--at", "350R"]].concat());

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
    let _ = session.close().await;
}
