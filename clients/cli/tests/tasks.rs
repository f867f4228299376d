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
    for mut c in crew {
        c.kill();
    }
    let _ = session.close().await;
}
