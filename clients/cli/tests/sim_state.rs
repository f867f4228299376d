//! `rome sim --state FILE`: a world killed with SIGKILL in the middle of a
//! move and started again on its state file takes up its robot where it
//! stood, by ground truth; the base controller finishes the move, and the
//! base server's virtual coordinates go on in the client's frame, so a
//! navigation run in progress is not thrown off.

#![allow(clippy::unwrap_used)]

use rome_client::net::NetOptions;
use rome_client::{RobotClient, RobotOptions};
use std::path::Path;
use std::time::Duration;

const ROME: &str = env!("CARGO_BIN_EXE_rome");

/// A world of one robot at 350R, four times real time, kept in `state`.
fn world(state: &Path) -> (rome_tests::ChildGuard, u16) {
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

/// The state file's robot r1 as its documented form has it
/// (`{"time_ms":…,"robots":[{"travelled_mm":…,…}]}`): distance travelled
/// and the file's time.
fn in_file(state: &Path) -> (f64, u64) {
    let kept: serde_json::Value = std::fs::read(state)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or_default();
    (
        kept["robots"][0]["travelled_mm"].as_f64().unwrap_or(0.0),
        kept["time_ms"].as_u64().unwrap_or(0),
    )
}

/// A session, r1's base client and its ground truth, once the base answers.
async fn r1(port: u16) -> (zenoh::Session, RobotClient, rome_client::sim::TruthClient) {
    let session = NetOptions::loopback_client(port).open().await.unwrap();
    rome_tests::await_alive(&session, "rome/alive/server/robot/r1/base", 1).await;
    let robot = RobotClient::connect(&session, "r1", RobotOptions::new("state-test"))
        .await
        .unwrap();
    let truth = rome_client::sim::TruthClient::new(&session, &Default::default(), "r1").unwrap();
    (session, robot, truth)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_world_killed_mid_move_takes_its_robot_up_where_it_stood_and_finishes_the_move() {
    let dir = rome_tests::TestDir::new("rome-sim-state-test");
    let state = dir.join("world.json");
    let (mut first, port) = world(&state);
    let (session, robot, truth) = r1(port).await;
    // A frame of the client's own, as a Planner sets one, then 2 m along
    // at 0.3 m/s: the world is killed on the way.
    robot.set_pose(1_000, 2_000, 90.0).await.unwrap();
    robot.move_by(2_000.0, 300.0, 300.0).await.unwrap();
    rome_tests::eventually(
        Duration::from_secs(60),
        "r1 is under way in the file",
        || {
            let (travelled, _) = in_file(&state);
            async move { travelled > 600.0 }
        },
    )
    .await;
    let before = truth.get().await.unwrap();
    // The world dies under a client still alive, as under a navigation
    // client on another host. Gone first, the client would set off the
    // base server's deadman: the move stopped, and that stop kept in the
    // file before the kill, so the second world would not finish it.
    first.kill();
    drop(robot);
    let _ = session.close().await;
    let (kept, kept_ms) = in_file(&state);
    assert!(
        kept < 1_900.0 && before.travelled_mm < 1_990.0,
        "killed mid-move ({kept:.0} mm in the file, {:.0} mm by truth)",
        before.travelled_mm
    );

    let (_second, port) = world(&state);
    let (_session, robot, truth) = r1(port).await;
    let resumed = truth.get().await.unwrap();
    assert!(
        resumed.travelled_mm >= kept - 1.0 && resumed.time_ms >= kept_ms,
        "taken up where the file left it: {:.0} mm travelled at {} ms; the file said {kept:.0} mm at {kept_ms} ms",
        resumed.travelled_mm,
        resumed.time_ms
    );
    // The sonar ring's scans go on from where they were, not from 0.
    let scans = robot.scans().await.unwrap();
    let scan = scans.next().await.unwrap().unwrap();
    assert!(
        scan.time_ms + 2_000 >= kept_ms,
        "the first scan is of {} ms; the file was written at {kept_ms} ms",
        scan.time_ms
    );
    // The base controller goes on with its move, to its end.
    rome_tests::eventually(Duration::from_secs(20), "r1 finishes its 2 m", || async {
        truth.get().await.is_ok_and(|t| t.travelled_mm > 1_940.0)
            && robot
                .wheel_speed()
                .await
                .is_ok_and(|s| s.wheel_speed_mm_s.abs() < 1.0)
    })
    .await;
    let end = truth.get().await.unwrap();
    assert!(
        (end.travelled_mm - 2_000.0).abs() < 60.0,
        "one move of 2 m in all: {:.0} mm",
        end.travelled_mm
    );
    // In the client's frame, set before the kill: 2 m from where it put r1.
    let p = robot.pose().await.unwrap();
    let along = f64::from(p.x_mm - 1_000).hypot(f64::from(p.y_mm - 2_000));
    assert!(
        (along - 2_000.0).abs() < 100.0,
        "the pose is 2 m from where the frame put r1 before the kill: ({}, {})",
        p.x_mm,
        p.y_mm
    );
}
