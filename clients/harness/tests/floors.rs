//! Runs between floors of the EB3 tower (§5.4.6): the robot walks to an
//! elevator, finds its door by the marker, rides, and walks on; judged by
//! ground truth, floor included.

use rome_harness::floors::run_floors;
use rome_harness::RunConfig;
use rome_nav::board::GoalType;
use rome_nav::planner::Progress;

fn tower_run(from: &str, to: &str) -> RunConfig {
    let mut cfg = RunConfig::new(rome_maps::load_named("eb3").expect("eb3 loads"), from, to);
    cfg.building = Some(rome_maps::load_building_named("tower").expect("the tower loads"));
    cfg
}

fn say(p: Progress<'_>) {
    match p {
        Progress::Handed(h) => eprintln!(
            "handed {} {:?} {}",
            h.index, h.step.goal.goal_type, h.step.goal.distance
        ),
        Progress::Done(h) => eprintln!(
            "done {} {:?}: {:?} at {:?}",
            h.index,
            h.step.goal.goal_type,
            h.failure,
            h.truth
                .as_ref()
                .map(|t| (t.floor.clone(), t.x_mm.round(), t.y_mm.round()))
        ),
        _ => {}
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_robot_goes_from_a_room_on_floor_3_to_one_on_floor_5() {
    let report = run_floors(tower_run("3:350R", "5:576L"), say)
        .await
        .expect("the run runs");
    eprintln!(
        "{:?} {:?} {:?} {:?}",
        report.failure, report.miss_mm, report.end, report.run_time
    );
    let ride = report
        .steps
        .iter()
        .find(|h| h.step.goal.goal_type == GoalType::V)
        .expect("a ride was handed over and judged");
    assert_eq!(ride.failure, None, "the ride is judged good");
    assert_eq!(report.end.floor.as_deref(), Some("5"));
    assert!(report.arrived_within(500.0), "{report:?}");
    assert_eq!(report.contacts, 0);
}
