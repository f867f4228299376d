//! A Navigator that cannot read what its goal depends on stops the robot
//! instead of driving on blind; one that reads a bad value ends that goal
//! with the reason and carries out the next.

mod common;

use common::until;
use rome_client::DataOptions;
use rome_nav::board::{Goal, GoalType, Sem, Status, Var};
use rome_nav::NavError;
use std::time::{Duration, Instant};

/// Waits for the Navigator to end the goal at hand, and returns why it
/// says it ended it.
async fn goal_failure(planner: &rome_nav::board::Board) -> String {
    tokio::time::timeout(Duration::from_secs(20), planner.down(Sem::RobotStatus))
        .await
        .expect("the Navigator ends the goal")
        .expect("the goal's end is signalled");
    let status: Status = planner.get(Var::Status).await.expect("a Status");
    status.failed.expect("the Status says why the goal ended")
}

/// Waits (at most a minute) until the CTracker has counted the segment's
/// first light.
async fn first_light_counted(planner: &rome_nav::board::Board) {
    let counted = tokio::time::timeout(Duration::from_secs(60), async {
        while !planner
            .get::<i64>(Var::CeilingLight)
            .await
            .is_ok_and(|n| n == 1)
        {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    });
    counted.await.expect("the first light is counted");
}

/// As the Planner hands the CTracker and the Navigator an L segment of
/// three lights along `heading`, with `offsets` as its `LightOffset`.
async fn hand_l_segment(
    planner: &rome_nav::board::Board,
    offsets: serde_json::Value,
    heading: f64,
) {
    planner
        .set(Var::LightOffset, &offsets)
        .await
        .expect("LightOffset");
    planner
        .set(Var::GoalDistance, &3i64)
        .await
        .expect("GoalDistance");
    planner
        .set(Var::GoalDirection, &heading)
        .await
        .expect("GoalDirection");
    planner.up(Sem::TrackData).await.expect("up($TrackData)");
    planner
        .give_goal(&Goal {
            goal_type: GoalType::L,
            distance: 3,
            direction_deg: heading,
        })
        .await
        .expect("the L goal is handed over");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_l_goal_stops_the_robot_when_the_light_count_goes_unanswered() {
    let (mut rig, _stepper, heading, planner) = common::one_robot(1.0).await;

    let request_timeout = Duration::from_secs(6);
    let opts = DataOptions {
        request_timeout,
        ..DataOptions::new("navigator")
    };
    let navigating = common::navigator(&rig, opts).await;

    // Many more lights than the corridor has: the goal can only end by
    // the count, which is about to become unreadable.
    common::set_off_on_l(&rig, &planner, heading, 50).await;
    let world = rig.world.clone();
    let i = rig.index[0];
    let speed = move || world.lock().robot(i).drive.wheel_speed().abs();
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

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_light_count_that_is_not_a_number_ends_the_goal_and_the_navigator_takes_the_next() {
    // Anyone may write the blackboard. A JSON object where the light count
    // should be ends the L goal, with the reason, and stops the robot;
    // the Navigator then carries out the next goal. It used to exit.
    let (rig, _stepper, heading, planner) = common::one_robot(1.0).await;
    let navigating = common::navigator(&rig, DataOptions::new("navigator")).await;

    // Many more lights than the corridor has: it can only end by the count.
    common::set_off_on_l(&rig, &planner, heading, 50).await;
    planner
        .set(Var::CeilingLight, &serde_json::json!({"lights": "many"}))
        .await
        .expect("the bad value is written");
    let why = goal_failure(&planner).await;
    assert!(
        why.contains("CeilingLight") && why.contains("invalid type: map"),
        "{why}"
    );
    let world = rig.world.clone();
    let i = rig.index[0];
    let speed = move || world.lock().robot(i).drive.wheel_speed().abs();
    assert!(
        until(Duration::from_secs(5), || speed() < 1.0).await,
        "the robot still drives at {:.0} mm/s",
        speed()
    );
    assert!(
        !navigating.is_finished(),
        "the Navigator exited: {navigating:?}"
    );

    // The next goal is carried out by the same Navigator.
    let before = rig.truth(0);
    common::drive_d(&planner, heading, 1_000, Duration::from_secs(30)).await;
    let after = rig.truth(0);
    let driven = (after.at.x - before.at.x).hypot(after.at.y - before.at.y);
    assert!(driven > 700.0, "drove {driven:.0} mm of 1000");
    let status: Status = planner.get(Var::Status).await.expect("a Status");
    assert_eq!(status.failed, None, "{status:?}");
    navigating.abort();
    rig.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn light_offsets_that_are_not_numbers_give_the_segment_up_and_the_ctracker_takes_the_next() {
    // The CTracker used to exit on a segment value it could not read,
    // leaving the robot's light segments uncounted for good.
    let (rig, _stepper, heading, planner) = common::one_robot(1.0).await;
    let navigating = common::navigator(&rig, DataOptions::new("navigator")).await;
    let tracking = common::ctracker(&rig).await;

    hand_l_segment(&planner, serde_json::json!("many"), heading).await;
    let why = goal_failure(&planner).await;
    assert!(
        why.contains("CTracker gave the light segment up") && why.contains("LightOffset"),
        "{why}"
    );
    assert!(!tracking.is_finished(), "the CTracker exited: {tracking:?}");
    assert!(!navigating.is_finished(), "the Navigator exited");

    // The next segment, with good values, is taken up: the count starts
    // again from 0.
    planner
        .set(Var::LightOffset, &vec![2_000.0, 4_000.0])
        .await
        .unwrap();
    planner.up(Sem::TrackData).await.unwrap();
    let counting = async {
        while planner.get::<i64>(Var::CeilingLight).await.is_err() {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    };
    tokio::time::timeout(Duration::from_secs(10), counting)
        .await
        .expect("the CTracker took up the next segment");
    assert!(!tracking.is_finished(), "the CTracker exited: {tracking:?}");
    tracking.abort();
    navigating.abort();
    rig.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_ctracker_killed_while_a_light_is_in_view_gives_its_token_back() {
    // A child took $LightToken without undo: a CTracker killed while a
    // light was in view kept the token from every later CTracker of the
    // robot, which then counted no light again (every one "missed").
    let (rig, _stepper, heading, planner) = common::one_robot(2.0).await;
    let navigating = common::navigator(&rig, DataOptions::new("navigator")).await;
    let tracking = common::ctracker(&rig).await;
    hand_l_segment(
        &planner,
        serde_json::json!([1_024.0, 6_000.0, 6_000.0]),
        heading,
    )
    .await;
    let token = planner.sem_name(Sem::LightToken);
    let value = || async { planner.client().semaphore(&token).await.unwrap().value };
    let held = async {
        while value().await != 0 {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    };
    tokio::time::timeout(Duration::from_secs(60), held)
        .await
        .expect("a child took the token under the first light");
    // Killed while it holds it: its process (here its task and its data
    // client) is gone.
    tracking.abort();
    let _ = tracking.await;
    let back = async {
        while value().await != 1 {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    };
    tokio::time::timeout(Duration::from_secs(10), back)
        .await
        .expect("the data server gave the dead CTracker's token back");
    navigating.abort();
    rig.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_ctracker_killed_mid_segment_and_started_again_takes_the_segment_up() {
    // A CTracker started again used to wait for the next segment: the
    // Navigator never heard the rest of the count, and the robot drove
    // past its lights until it was stopped.
    let (rig, _stepper, heading, planner) = common::one_robot(2.0).await;
    let navigating = common::navigator(&rig, DataOptions::new("navigator")).await;
    let first = common::ctracker(&rig).await;
    let start = rig.truth(0);
    hand_l_segment(
        &planner,
        serde_json::json!([1_024.0, 6_000.0, 6_000.0]),
        heading,
    )
    .await;
    // The Planner waits for the goal's end, as it does.
    let goal_done = {
        let planner = planner.clone();
        tokio::spawn(async move { planner.down(Sem::RobotStatus).await })
    };
    first_light_counted(&planner).await;
    first.abort();
    let _ = first.await;
    let second = common::ctracker(&rig).await;
    tokio::time::timeout(Duration::from_secs(60), goal_done)
        .await
        .expect("the L goal ends by its count, told by the CTracker started again")
        .expect("the wait task")
        .expect("down($RobotStatus)");
    tokio::time::timeout(Duration::from_secs(10), planner.down(Sem::EndLMode))
        .await
        .expect("the segment is closed")
        .expect("down($EndLMode)");
    let log: rome_nav::ctracker::SegmentLog = planner.get(Var::TrackLog).await.expect("TrackLog");
    assert_eq!(log.seen + log.missed, 3, "each light counted once: {log:?}");
    // By ground truth the robot stopped at the third light, not before
    // and not a light later.
    let end = rig.truth(0);
    let along = (end.at.x - start.at.x).hypot(end.at.y - start.at.y);
    assert!(
        (12_000.0..14_500.0).contains(&along),
        "stopped {along:.0} mm along; the third light is 13 024 mm"
    );
    second.abort();
    navigating.abort();
    rig.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_ctracker_started_again_before_the_planner_waits_again_still_takes_the_segment_up() {
    // After a data-server outage the CTracker is started again while the
    // Planner's wait has not yet reached the server that came back. A
    // tracker that took one look then judged the segment over, and the
    // Navigator, which took its goal up, drove past lights nobody
    // counted into the corridor's end wall.
    let (rig, _stepper, heading, planner) = common::one_robot(2.0).await;
    let navigating = common::navigator(&rig, DataOptions::new("navigator")).await;
    let first = common::ctracker(&rig).await;
    hand_l_segment(
        &planner,
        serde_json::json!([1_024.0, 6_000.0, 6_000.0]),
        heading,
    )
    .await;
    let waiting = {
        let planner = planner.clone();
        tokio::spawn(async move { planner.down(Sem::RobotStatus).await })
    };
    first_light_counted(&planner).await;
    // The outage: the Planner's wait is gone from the server, and the
    // CTracker is started again before it comes back.
    waiting.abort();
    let _ = waiting.await;
    let status = planner.sem_name(Sem::RobotStatus);
    let no_waiter = async {
        while planner.client().semaphore(&status).await.unwrap().waiters > 0 {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    };
    tokio::time::timeout(Duration::from_secs(10), no_waiter)
        .await
        .expect("the Planner's wait leaves the queue");
    first.abort();
    let _ = first.await;
    let second = common::ctracker(&rig).await;
    // The Planner's next wait reaches the server two seconds later.
    tokio::time::sleep(Duration::from_secs(2)).await;
    tokio::time::timeout(Duration::from_secs(60), planner.down(Sem::RobotStatus))
        .await
        .expect("the L goal ends by its count, told by the CTracker started again")
        .expect("down($RobotStatus)");
    let log: rome_nav::ctracker::SegmentLog = planner.get(Var::TrackLog).await.expect("TrackLog");
    assert_eq!(log.seen + log.missed, 3, "each light counted once: {log:?}");
    second.abort();
    navigating.abort();
    rig.stop().await;
}
