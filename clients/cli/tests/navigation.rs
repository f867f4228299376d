//! The navigation clients as separate `rome` processes, as on a robot and
//! its wireless hosts: the simulated robot, its hardware servers and the
//! data server run in this test on a loopback port; `rome navigator`,
//! `rome ctracker`, `rome mapper`, `rome plfinder` and finally
//! `rome planner` each run in a process of their own and meet only through
//! Zenoh. The run must end within a metre of the goal.

#![allow(clippy::unwrap_used)]

use rome_client::net::{free_loopback_port, NetOptions};
use rome_nav::plan::Plan;
use rome_nav::run::{Rig, RunConfig};
use rome_tests::ChildGuard;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const ROME: &str = env!("CARGO_BIN_EXE_rome");

fn client(port: u16, args: &[&str], stdout: Stdio) -> ChildGuard {
    let child = Command::new(ROME)
        .args(["--no-multicast", "--mode", "client", "--connect"])
        .arg(format!("tcp/127.0.0.1:{port}"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    ChildGuard(Some(child))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_client_in_its_own_process_still_arrives() {
    let (from, to) = ("302L", "A340R");
    let map = rome_maps::load_named("eb3").unwrap();
    let world = rome_maps::World::from_map(&map);
    let network = rome_maps::Network::new(&map, &world);
    let plan = Plan::new(&world, &network, from, to).unwrap();
    let mut cfg = RunConfig::new(map, from, to);
    cfg.seed = 4;
    let port = free_loopback_port().unwrap();
    let rig = Rig::start(&cfg, &plan, NetOptions::loopback(Some(port), &[]))
        .await
        .unwrap();

    let mut helpers = Vec::new();
    for args in [
        &["navigator", "--robot", "r1"][..],
        &["ctracker", "--robot", "r1"],
        &["mapper", "--robot", "r1"],
        &["plfinder", "--robot", "r1"],
    ] {
        helpers.push(client(port, args, Stdio::null()));
    }
    // Every client is up (its liveliness token is there) before the
    // Planner hands out the first goal.
    let session = NetOptions::loopback_client(port).open().await.unwrap();
    let root = rome_schema::Root::default();
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let alive = rome_client::alive::list(&session, &root, Duration::from_secs(2))
            .await
            .unwrap();
        let up = ["navigator", "ctracker", "himm", "plfinder"]
            .iter()
            .all(|role| alive.iter().any(|p| p.class == "client" && p.role == *role));
        if up {
            break;
        }
        assert!(Instant::now() < deadline, "clients not up: {alive:?}");
    }
    let _stepper = rig.world.start(Some(cfg.speed));
    let mut planner = client(
        port,
        &["planner", "--robot", "r1", "--from", from, "--to", to],
        Stdio::piped(),
    );
    let out = tokio::task::spawn_blocking(move || planner.output())
        .await
        .unwrap();
    assert!(out.contains("done:"), "{out}");
    let end = rig.truth();
    let (_, goal) = plan.ends();
    let miss = (end.x - goal.0).hypot(end.y - goal.1);
    assert!(miss < 1_000.0, "ended {miss:.0} mm from {to}\n{out}");
    for mut h in helpers {
        h.kill();
    }
    let _ = session.close().await;
    rig.stop().await;
}
