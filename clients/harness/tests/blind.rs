//! A Navigator that cannot read what its goal depends on stops the robot
//! instead of driving on blind.

mod common;

use rome_client::{DataClient, DataOptions, RobotClient, RobotOptions};
use rome_nav::board::{Board, Goal, GoalType};
use rome_nav::navigator::{NavConfig, Navigator};
use rome_nav::NavError;
use std::time::{Duration, Instant};

/// Waits, checking every 20 ms, until `ok` holds or `within` passes.
async fn until(within: Duration, mut ok: impl FnMut() -> bool) -> bool {
    let deadline = Instant::now() + within;
    while Instant::now() < deadline {
        if ok() {
            return true;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    ok()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_l_goal_stops_the_robot_when_the_light_count_goes_unanswered() {
    let (mut rig, _stepper, heading, planner) = common::one_robot(1.0).await;

    let request_timeout = Duration::from_secs(6);
    let ds = DataClient::connect(
        &rig.session,
        DataOptions {
            request_timeout,
            ..DataOptions::new("navigator")
        },
    )
    .await
    .expect("navigator data client");
    let robot = RobotClient::connect(&rig.session, "r1", RobotOptions::new("navigator"))
        .await
        .expect("navigator robot client");
    let board = Board::new(ds, "r1");
    let mut nav = Navigator::new(robot, board, NavConfig::default());
    let navigating = tokio::spawn(async move { nav.run().await });

    // Many more lights than the corridor has: the goal can only end by
    // the count, which is about to become unreadable.
    planner
        .give_goal(&Goal {
            goal_type: GoalType::L,
            distance: 50,
            direction_deg: heading,
        })
        .await
        .expect("the goal is handed over");
    let start = rig.truth(0);
    let world = rig.world.clone();
    let i = rig.index[0];
    let speed = move || world.lock().robot(i).drive.wheel_speed().abs();
    let moved = until(Duration::from_secs(20), || {
        let p = rig.truth(0);
        (p.at.x - start.at.x).hypot(p.at.y - start.at.y) > 500.0
    })
    .await;
    assert!(moved, "the robot never set off on its L goal");
    assert!(speed() > 100.0, "driving at {} mm/s", speed());

    rig.stop_data_server().await;
    let stopped_at = Instant::now();
    // Ground truth: the wheels stop well before the read gives up.
    let stopped = until(request_timeout, || speed() < 1.0).await;
    assert!(
        stopped,
        "the robot still drives at {:.0} mm/s {:.1?} after the data server went",
        speed(),
        stopped_at.elapsed()
    );
    assert!(
        !navigating.is_finished(),
        "the robot was stopped while the read was still waiting"
    );
    let ended = tokio::time::timeout(request_timeout * 2, navigating)
        .await
        .expect("the Navigator ends once the read fails")
        .expect("the Navigator task does not panic");
    match ended {
        Err(NavError::Unreadable { what, .. }) => assert!(what.contains("CeilingLight"), "{what}"),
        other => panic!("expected the light count to be reported unreadable, got {other:?}"),
    }
    let stop_pose = rig.truth(0);
    assert!(speed() < 1.0, "the robot set off again: {stop_pose:?}");
    rig.stop().await;
}
