//! A Navigator started again after one died in the middle of a goal takes
//! the goal up where it was measured from, and the Planner hears it done
//! once: the robot ends where the goal says, not a segment further.

mod common;

use rome_client::DataOptions;
use rome_nav::board::{Goal, GoalType, Sem};
use std::time::{Duration, Instant};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_restarted_navigator_finishes_the_goal_its_predecessor_left() {
    let (rig, _stepper, heading, planner) = common::one_robot(2.0).await;

    let first = common::navigator(&rig, DataOptions::new("navigator")).await;
    let start = rig.truth(0);
    planner
        .give_goal(&Goal {
            goal_type: GoalType::D,
            distance: 5_000,
            direction_deg: heading,
        })
        .await
        .expect("the goal is handed over");
    let done = {
        let planner = planner.clone();
        tokio::spawn(async move { planner.down(Sem::RobotStatus).await })
    };
    // Two metres along, the Navigator dies.
    let deadline = Instant::now() + Duration::from_secs(60);
    while rig.truth(0).dist(&start) < 2_000.0 {
        assert!(Instant::now() < deadline, "the robot never got going");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    first.abort();
    let _ = first.await;

    let second = common::navigator(&rig, DataOptions::new("navigator")).await;
    tokio::time::timeout(Duration::from_secs(60), done)
        .await
        .expect("the goal was never finished: the new Navigator did not take it up")
        .expect("the Planner's wait does not panic")
        .expect("the Planner hears the goal done");
    let end = rig.truth(0);
    let driven = end.dist(&start);
    assert!(
        (driven - 5_000.0).abs() < 500.0,
        "the robot ended {driven:.0} mm from where the goal began, not 5000"
    );
    // Done once: the goal is not taken up again.
    let status = planner
        .client()
        .semaphore(&planner.sem_name(Sem::RobotStatus))
        .await
        .expect("semaphore state");
    assert_eq!(status.value, 0, "the goal was reported done twice");
    second.abort();
    rig.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn garbage_in_goal_active_is_no_goal() {
    let (rig, _stepper, heading, planner) = common::one_robot(2.0).await;
    // Anyone may write the blackboard.
    planner
        .client()
        .set(
            &planner.var_name(rome_nav::board::Var::GoalActive),
            &"nonsense",
        )
        .await
        .expect("written");
    let nav = common::navigator(&rig, DataOptions::new("navigator")).await;
    common::drive_d(&planner, heading, 1_000, Duration::from_secs(60)).await;
    assert!(
        !nav.is_finished(),
        "the Navigator stopped on a bad GoalActive"
    );
    nav.abort();
    rig.stop().await;
}
