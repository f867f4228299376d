//! A light count that reaches the Navigator late, as over a slow or lossy
//! link, does not carry the robot past the D goal after it: that goal is
//! measured from where the CTracker counted the light (`CountedAt`), not
//! from where the Navigator learned of the count.

mod common;

use common::until;
use rome_client::DataOptions;
use rome_maps::geometry::{direction, Pose};
use rome_nav::board::{CountedAt, Sem, Var};
use std::time::Duration;

/// How far past the count the robot drives before the count is said.
const LATE_MM: f64 = 1_000.0;
/// The D goal after the light.
const D_MM: i64 = 2_000;

/// How far `to` lies from `from` along `heading`, mm.
fn along(from: &Pose, to: &Pose, heading: f64) -> f64 {
    let axis = direction(heading);
    (to.at.x - from.at.x) * axis.x + (to.at.y - from.at.y) * axis.y
}

/// As the CTracker says a count: where it was taken, then the count.
async fn say_count(planner: &rome_nav::board::Board, at: Option<CountedAt>, count: i64) {
    planner.set(Var::CountedAt, &at).await.expect("CountedAt");
    planner
        .set(Var::CeilingLight, &count)
        .await
        .expect("CeilingLight");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_d_goal_after_a_late_count_is_measured_from_where_the_light_was_counted() {
    let (rig, _stepper, heading, planner) = common::one_robot(1.0).await;
    let navigating = common::navigator(&rig, DataOptions::new("navigator")).await;
    let tracker = common::robot_client(&rig, "ctracker").await;

    // As a CTracker starting a segment of one light.
    say_count(&planner, None, 0).await;
    common::set_off_on_l(&rig, &planner, heading, 1).await;

    // The light is counted here (the tracker's odometry, and the truth
    // beside it) ...
    let odometry = Pose::from(&tracker.pose().await.expect("the tracker reads the pose"));
    let counted = rig.truth(0);
    // ... but the count reaches the blackboard only a metre later.
    let late = until(Duration::from_secs(20), || {
        along(&counted, &rig.truth(0), heading) > LATE_MM
    })
    .await;
    assert!(late, "the robot stopped before the count was said");
    let at = CountedAt {
        x_mm: odometry.at.x,
        y_mm: odometry.at.y,
    };
    say_count(&planner, Some(at), 1).await;
    tokio::time::timeout(Duration::from_secs(20), planner.down(Sem::RobotStatus))
        .await
        .expect("the Navigator ends the L goal on the count")
        .expect("the Planner hears it");

    common::drive_d(&planner, heading, D_MM, Duration::from_secs(60)).await;
    let end = rig.truth(0);
    let driven = along(&counted, &end, heading);
    eprintln!("driven past the count: {driven:.0} mm for a {D_MM} mm goal");
    // Measured from where the Navigator heard the count, the robot stops
    // a metre past its goal; from the count, within its stopping error.
    assert!(
        (driven - D_MM as f64).abs() < 300.0,
        "the robot stopped {driven:.0} mm past the light, for a goal {D_MM} mm past it"
    );
    navigating.abort();
    rig.stop().await;
}
