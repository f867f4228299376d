//! Navigation split into processes, as on robots and their wireless hosts:
//! `rome data-server`, `rome sim --robots 2`, and for each robot
//! `rome navigator`, `rome ctracker`, `rome mapper`, `rome plfinder` and
//! `rome planner --robot rK`, every one a process of its own, meeting only
//! through Zenoh on loopback. Both robots drive at once and must end within
//! a metre of their goals by ground truth, as the same run does in one
//! process.

#![allow(clippy::unwrap_used)]

use rome_client::net::{free_loopback_port, NetOptions};
use rome_tests::ChildGuard;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const ROME: &str = env!("CARGO_BIN_EXE_rome");

/// Where each process's standard error goes, to read when a run fails.
fn log_dir(port: u16) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("rome-navigation-test-{port}"));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn rome(port: u16, name: &str, args: &[&str], stdout: Stdio) -> ChildGuard {
    let log = std::fs::File::create(log_dir(port).join(format!("{name}.log"))).unwrap();
    let child = Command::new(ROME)
        .args(args)
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(log)
        .spawn()
        .unwrap();
    ChildGuard(Some(child))
}

/// Every process's standard error, for a failure message.
fn logs(port: u16) -> String {
    let mut out = String::new();
    if let Ok(dir) = std::fs::read_dir(log_dir(port)) {
        for e in dir.flatten() {
            let text = std::fs::read_to_string(e.path()).unwrap_or_default();
            let tail: Vec<&str> = text.lines().rev().take(8).collect();
            out.push_str(&format!("--- {} ---\n", e.path().display()));
            for l in tail.into_iter().rev() {
                out.push_str(l);
                out.push('\n');
            }
        }
    }
    out
}

/// A client process connected to the data server on `port`.
fn client(port: u16, name: &str, args: &[&str], stdout: Stdio) -> ChildGuard {
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut all = vec!["--no-multicast", "--mode", "client", "--connect", &endpoint];
    all.extend_from_slice(args);
    rome(port, name, &all, stdout)
}

/// The number on a planner's last line: "ground truth puts r1 0.23 m from".
fn metres_from_goal(out: &str) -> f64 {
    let last = out.lines().rfind(|l| l.starts_with("done:")).unwrap_or("");
    let after = last.split(" puts ").nth(1).unwrap_or("");
    after
        .split_whitespace()
        .nth(1)
        .and_then(|m| m.parse().ok())
        .unwrap_or_else(|| panic!("no distance in the planner's last line:\n{out}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_robots_with_every_client_in_its_own_process_both_arrive() {
    let routes = [("r1", "302L", "A340R"), ("r2", "A302R", "A357L")];
    let port = free_loopback_port().unwrap();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let _data = rome(
        port,
        "data-server",
        &["--no-multicast", "--listen", &endpoint, "data-server"],
        Stdio::null(),
    );
    let at = format!("{},{}", routes[0].1, routes[1].1);
    let _sim = rome(
        port,
        "sim",
        &[
            "--no-multicast",
            "--listen",
            "tcp/127.0.0.1:0",
            "--connect",
            &endpoint,
            "sim",
            "--robots",
            "2",
            "--at",
            &at,
            "--seed",
            "4",
            "--speed",
            "4",
        ],
        Stdio::null(),
    );
    let mut helpers = Vec::new();
    for (robot, _, _) in routes {
        for role in ["navigator", "ctracker", "mapper", "plfinder"] {
            let name = format!("{role}-{robot}");
            helpers.push(client(
                port,
                &name,
                &[role, "--robot", robot],
                Stdio::null(),
            ));
        }
    }
    // Every client is up (its liveliness token is there), and both robots'
    // servers, before the Planners hand out their first goals.
    let session = NetOptions::loopback_client(port).open().await.unwrap();
    let root = rome_schema::Root::default();
    let deadline = Instant::now() + Duration::from_secs(90);
    loop {
        let alive = rome_client::alive::list(&session, &root, Duration::from_secs(2))
            .await
            .unwrap();
        let count = |class: &str, role: &str| {
            alive
                .iter()
                .filter(|p| p.class == class && p.role.starts_with(role))
                .count()
        };
        // Each client process holds two tokens (its data-server and its
        // robot client): two robots, four tokens a role.
        let up = ["navigator", "ctracker", "himm", "plfinder"]
            .iter()
            .all(|role| count("client", role) == 4)
            && count("server", "robot") == 8
            && count("server", "sim") == 1;
        if up {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "not up: {alive:?}\n{}",
            logs(port)
        );
    }
    let mut planners = Vec::new();
    for (robot, from, to) in routes {
        let p = client(
            port,
            &format!("planner-{robot}"),
            &[
                "planner",
                "--robot",
                robot,
                "--from",
                from,
                "--to",
                to,
                "--timeout",
                "400",
            ],
            Stdio::piped(),
        );
        planners.push((robot, to, p));
    }
    let mut outs = Vec::new();
    for (robot, to, mut p) in planners {
        let out = tokio::task::spawn_blocking(move || p.try_output())
            .await
            .unwrap();
        match out {
            Ok(out) => outs.push((robot, to, out)),
            Err(e) => panic!("{robot}'s planner failed: {e}\n{}", logs(port)),
        }
    }
    for (robot, to, out) in &outs {
        // Exit status 0 (checked by output()) means within a metre by
        // ground truth; the figure is read back as well.
        let miss = metres_from_goal(out);
        assert!(miss < 1.0, "{robot} ended {miss} m from {to}\n{out}");
        assert!(out.contains("Run time"), "no Table 6.1 row:\n{out}");
        assert!(
            !out.contains("given up"),
            "{robot}'s run was given up:\n{out}"
        );
    }
    // Each robot used its own blackboard: the goals of one never reached
    // the other (each Navigator took exactly its own plan's goals).
    let ds = rome_client::DataClient::connect(&session, rome_client::DataOptions::new("check"))
        .await
        .unwrap();
    for (robot, _, _) in routes {
        let status: serde_json::Value = ds.get(&format!("nav/{robot}/Status")).await.unwrap();
        assert_eq!(status["goal_type"], "D", "{robot}: {status}");
    }
    for mut h in helpers {
        h.kill();
    }
    let _ = session.close().await;
}
