//! `rome sim --state FILE`: a world killed with SIGKILL and started again
//! on its state file takes up its robot where it stood, by ground truth,
//! and the base server's virtual coordinates go on where they were, so a
//! navigation run in progress is not thrown off.

#![allow(clippy::unwrap_used)]

use rome_client::net::NetOptions;
use rome_client::{RobotClient, RobotOptions};
use rome_schema::sim::Truth;
use std::time::Duration;

const ROME: &str = env!("CARGO_BIN_EXE_rome");

/// A world of one robot at 350R, four times real time, kept in `state`.
fn world(state: &std::path::Path) -> (rome_tests::ChildGuard, u16) {
    let state = state.to_string_lossy();
    let args = [
        "--no-multicast",
        "--listen",
        "tcp/127.0.0.1:0",
        "sim",
        "--robots",
        "1",
        "--at",
        "350R",
        "--speed",
        "4",
        "--state",
        &state,
    ];
    let (child, port, _logs) = rome_tests::spawn_listening(ROME, &args);
    (child, port)
}

/// r1's base pose and its ground truth, once its base answers.
async fn where_r1(port: u16) -> ((i32, i32, f64), Truth) {
    let session = NetOptions::loopback_client(port).open().await.unwrap();
    rome_tests::await_alive(&session, "rome/alive/server/robot/r1/base", 1).await;
    let robot = RobotClient::connect(&session, "r1", RobotOptions::new("state-test"))
        .await
        .unwrap();
    let p = robot.pose().await.unwrap();
    let truth = rome_client::sim::TruthClient::new(&session, &Default::default(), "r1")
        .unwrap()
        .get()
        .await
        .unwrap();
    ((p.x_mm, p.y_mm, p.heading_deg), truth)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_world_killed_and_started_again_takes_its_robot_up_where_it_stood() {
    let dir = rome_tests::TestDir::new("rome-sim-state-test");
    let state = dir.join("world.json");
    let (mut first, port) = world(&state);
    let session = NetOptions::loopback_client(port).open().await.unwrap();
    rome_tests::await_alive(&session, "rome/alive/server/robot/r1/base", 1).await;
    let robot = RobotClient::connect(&session, "r1", RobotOptions::new("state-test"))
        .await
        .unwrap();
    // A frame of the client's own, as a Planner sets one, then 2 m along.
    robot.set_pose(1_000, 2_000, 90.0).await.unwrap();
    robot.move_by(2_000.0, 400.0, 400.0).await.unwrap();
    let truth = rome_client::sim::TruthClient::new(&session, &Default::default(), "r1").unwrap();
    rome_tests::eventually(Duration::from_secs(60), "r1 drives its 2 m", || async {
        truth.get().await.is_ok_and(|t| t.travelled_mm > 1_990.0)
            && robot
                .wheel_speed()
                .await
                .is_ok_and(|s| s.wheel_speed_mm_s.abs() < 1.0)
    })
    .await;
    let before = (robot.pose().await.unwrap(), truth.get().await.unwrap());
    // The state file has caught up with the robot at rest.
    rome_tests::eventually(Duration::from_secs(30), "the state file is written", || {
        let (state, t) = (state.clone(), before.1.clone());
        async move {
            // The file's documented form: {"time_ms":…,"robots":[{"truth":[x,y,h],…}]}.
            let kept: serde_json::Value = std::fs::read(&state)
                .ok()
                .and_then(|b| serde_json::from_slice(&b).ok())
                .unwrap_or_default();
            kept["time_ms"].as_u64().is_some_and(|ms| ms > t.time_ms)
                && kept["robots"][0]["truth"][0].as_f64() == Some(t.x_mm)
        }
    })
    .await;
    drop(robot);
    let _ = session.close().await;
    first.kill();

    let (_second, port) = world(&state);
    let ((x, y, heading), t) = where_r1(port).await;
    let (p0, t0) = before;
    assert!(
        (t.x_mm - t0.x_mm).abs() < 1.0 && (t.y_mm - t0.y_mm).abs() < 1.0,
        "r1 stands where it stood: ({:.0}, {:.0}) mm, was ({:.0}, {:.0})",
        t.x_mm,
        t.y_mm,
        t0.x_mm,
        t0.y_mm
    );
    assert!(t.time_ms >= t0.time_ms, "the world's time goes on");
    assert_eq!(
        (x, y),
        (p0.x_mm, p0.y_mm),
        "the base's virtual coordinates go on in the client's frame"
    );
    assert!(
        (heading - p0.heading_deg).abs() < 0.01,
        "{heading} vs {}",
        p0.heading_deg
    );
    let along = f64::from(x - 1_000).hypot(f64::from(y - 2_000));
    assert!(
        (along - 2_000.0).abs() < 100.0,
        "the pose is 2 m from where the frame put r1 before the kill: ({x}, {y})"
    );
}
