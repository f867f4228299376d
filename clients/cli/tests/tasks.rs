//! A fleet given errands from the command line, every program a process
//! of its own on loopback: `rome data-server`, `rome sim --robots 2`, each
//! robot's helpers and `rome planner --tasks`, and `rome dispatcher`.
//! `rome task add --wait` ends 0 only once ground truth puts the robot
//! within a metre; the dispatcher is killed with SIGKILL between two
//! tasks, and the one started after it carries on.

#![allow(clippy::unwrap_used)]

mod common;

use common::*;
use rome_client::net::NetOptions;
use rome_tests::ChildGuard;
use std::process::Stdio;

/// Runs a `rome` client command to its end: its standard output, or a
/// failure message with every process's log.
async fn run(port: u16, name: &str, args: &[&str]) -> String {
    let mut p: ChildGuard = client(port, name, args, Stdio::piped());
    let out = tokio::task::spawn_blocking(move || p.try_output())
        .await
        .unwrap();
    out.unwrap_or_else(|e| panic!("rome {args:?} failed: {e}\n{}", logs(port)))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tasks_added_from_the_cli_are_done_and_survive_a_killed_dispatcher() {
    let (_data, port) = data_server();
    let _logs = rome_tests::TestDir::adopt(log_dir(port));
    let _sim = sim(port, "eb3", &["350R", "376L"]);
    let mut crew = Vec::new();
    for robot in ["r1", "r2"] {
        crew.extend(helpers(port, robot, "eb3"));
    }
    let session = NetOptions::loopback_client(port).open().await.unwrap();
    await_up(&session, port, 2).await;
    for (robot, at) in [("r1", "350R"), ("r2", "376L")] {
        let args = ["planner", "--robot", robot, "--from", at, "--tasks"];
        crew.push(client(
            port,
            &format!("planner-{robot}"),
            &args,
            Stdio::null(),
        ));
    }
    // Both robots take tasks before the first is added: otherwise the
    // only robot ready would take it, however far it stands.
    let ds = rome_client::DataClient::connect(&session, rome_client::DataOptions::new("check"))
        .await
        .unwrap();
    rome_tests::eventually(
        std::time::Duration::from_secs(60),
        "both robots take tasks",
        || async {
            let robots = rome_nav::fleet::tasks::robots(&ds)
                .await
                .unwrap_or_default();
            robots.len() == 2 && robots.iter().all(|(_, d)| d.is_ok())
        },
    )
    .await;
    let mut dispatcher = client(port, "dispatcher", &["dispatcher"], Stdio::null());

    let out = run(port, "task-1", &["task", "add", "--to", "356R", "--wait"]).await;
    assert_eq!(out.trim(), "T1", "{out}");
    dispatcher.kill(); // SIGKILL: its semaphore unit comes back by itself.
    let _dispatcher = client(port, "dispatcher-2", &["dispatcher"], Stdio::null());
    let out = run(port, "task-2", &["task", "add", "--to", "372L", "--wait"]).await;
    assert_eq!(out.trim(), "T2", "{out}");

    let ls = run(port, "task-ls", &["task", "ls"]).await;
    let row = |id: &str| {
        ls.lines()
            .find(|l| l.starts_with(&format!("{id} ")))
            .unwrap_or_else(|| panic!("no {id} in:\n{ls}"))
            .split_whitespace()
            .map(String::from)
            .collect::<Vec<_>>()
    };
    // The nearest robot took each: r1 stood at 350R, r2 at 376L.
    assert_eq!(row("T1")[1..4], ["done", "r1", "356R"], "{ls}");
    assert_eq!(row("T2")[1..4], ["done", "r2", "372L"], "{ls}");
    // Each stands where its task ended, ready for the next.
    let robots = run(port, "task-robots", &["task", "robots"]).await;
    for (robot, at) in [("r1", "356R"), ("r2", "372L")] {
        let line = robots
            .lines()
            .find(|l| l.starts_with(&format!("{robot} ")))
            .unwrap_or_else(|| panic!("no {robot} in:\n{robots}"));
        let words: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(words[1..3], ["idle", at], "{robots}");
    }
    for mut c in crew {
        c.kill();
    }
    let _ = session.close().await;
}
