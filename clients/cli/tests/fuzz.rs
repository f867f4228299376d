//! `rome fuzz` against a deployment of processes: a data server, a
//! simulated robot's hardware servers, the robot's four navigation
//! clients, and the long-running observers (`rome view`, `rome foxglove`,
//! `rome record`) and dispatcher. Thousands of generated requests and publications later, every
//! process still runs, every query addressed to a server was answered
//! (errors with a RoME error naming the problem), and the servers still
//! serve good requests.

#![allow(clippy::unwrap_used)]

use rome_client::net::NetOptions;
use rome_tests::{listening_port, spawn_logged, ChildGuard};
use std::time::{Duration, Instant};

const ROME: &str = env!("CARGO_BIN_EXE_rome");

fn logs(dir: &std::path::Path) -> String {
    rome_tests::tail_logs(dir, 6)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn generated_garbage_from_the_network_breaks_no_server_and_no_client() {
    let dir = rome_tests::TestDir::new("rome-fuzz-test");
    let mut procs: Vec<(String, ChildGuard)> = Vec::new();
    let ds_log = dir.join("data-server.log");
    procs.push((
        "data-server".into(),
        spawn_logged(ROME, &rome_tests::DATA_SERVER, &ds_log),
    ));
    let port = listening_port(&ds_log, Duration::from_secs(60));
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let sim = rome_tests::joined_to(port, &["sim", "--robots", "1", "--at", "350R"]);
    procs.push(("sim".into(), spawn_logged(ROME, &sim, &dir.join("sim.log"))));
    for role in ["navigator", "ctracker", "mapper", "plfinder"] {
        let args = [
            "--no-multicast",
            "--mode",
            "client",
            "--connect",
            &endpoint,
            role,
            "--robot",
            "r1",
        ];
        procs.push((
            role.into(),
            spawn_logged(ROME, &args, &dir.join(format!("{role}.log"))),
        ));
    }

    // The long-running observers and the dispatcher read what anyone
    // publishes too: they must outlive the garbage as the clients do.
    let mcap = dir.join("fuzz.mcap");
    let mcap = mcap.to_str().unwrap();
    let others: [(&str, Vec<&str>); 4] = [
        ("view", vec!["view", "--port", "0"]),
        ("foxglove", vec!["foxglove", "--port", "0"]),
        ("record", vec!["record", "--output", mcap]),
        ("dispatcher", vec!["dispatcher"]),
    ];
    for (name, rest) in others {
        let mut args = vec!["--no-multicast", "--mode", "client", "--connect", &endpoint];
        args.extend(rest);
        procs.push((
            name.into(),
            spawn_logged(ROME, &args, &dir.join(format!("{name}.log"))),
        ));
    }

    // Everyone up: the data server, four hardware servers, the truth
    // server, the storage, and the four clients (two tokens each).
    let watcher = NetOptions::loopback_client(port).open().await.unwrap();
    let root = rome_schema::Root::default();
    let deadline = Instant::now() + Duration::from_secs(90);
    loop {
        let alive = rome_client::alive::list(&watcher, &root, Duration::from_secs(1))
            .await
            .unwrap();
        let servers = alive.iter().filter(|p| p.class == "server").count();
        let clients = alive.iter().filter(|p| p.class == "client").count();
        if servers >= 7 && clients >= 8 {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "not everyone came up: {alive:?}\n{}",
            logs(&dir)
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }

    let pids: Vec<String> = procs
        .iter()
        .map(|(_, c)| c.0.as_ref().unwrap().id().to_string())
        .collect();
    let mut args = vec![
        "--no-multicast".to_string(),
        "--mode".into(),
        "client".into(),
        "--connect".into(),
        endpoint.clone(),
        "fuzz".into(),
        "--cases".into(),
        "3000".into(),
        "--seed".into(),
        "11".into(),
        "--json".into(),
    ];
    for p in &pids {
        args.extend(["--pid".to_string(), p.clone()]);
    }
    let out = tokio::task::spawn_blocking(move || {
        std::process::Command::new(ROME)
            .args(&args)
            .stdin(std::process::Stdio::null())
            .output()
            .unwrap()
    })
    .await
    .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let summary: serde_json::Value = serde_json::from_str(&stdout).unwrap_or_else(|e| {
        panic!(
            "rome fuzz printed no summary ({e}): {stdout}\n{}\n{}",
            String::from_utf8_lossy(&out.stderr),
            logs(&dir)
        )
    });
    let why = format!("{summary:#}\n{}", logs(&dir));
    assert_eq!(summary["cases"], 3000, "{why}");
    assert_eq!(summary["silent_examples"], serde_json::json!([]), "{why}");
    assert_eq!(
        summary["undecodable_examples"],
        serde_json::json!([]),
        "{why}"
    );
    assert_eq!(summary["servers_lost"], serde_json::json!([]), "{why}");
    assert_eq!(summary["pids_gone"], serde_json::json!([]), "{why}");
    assert_eq!(
        summary["good_requests_failed"],
        serde_json::json!([]),
        "{why}"
    );
    // The run did reach the servers: most queries were refused with a
    // RoME error, and both queries and publications went out.
    let kinds = summary["by_kind"].as_object().unwrap();
    let total = |field: &str| -> u64 { kinds.values().map(|t| t[field].as_u64().unwrap()).sum() };
    assert!(total("error") > 1_000, "{why}");
    assert!(total("published") > 500, "{why}");
    // Bad values on r1's blackboard, most of them read at once by the
    // client they were meant for: every client still runs (checked above
    // through `pids_gone` and below).
    assert!(kinds["blackboard"]["ok"].as_u64().unwrap() > 100, "{why}");
    assert_eq!(summary["passed"], true, "{why}");
    assert!(out.status.success(), "{why}");
    for (name, child) in &mut procs {
        let c = child.0.as_mut().unwrap();
        assert!(
            c.try_wait().unwrap().is_none(),
            "{name} exited\n{}",
            logs(&dir)
        );
    }
    let _ = watcher.close().await;
}
