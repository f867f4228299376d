//! A Navigator that waits outside its control loop still writes its
//! Status every second of robot time: a Planner that hears nothing for
//! `NAVIGATOR_SILENCE` (30 s) gives the goal up as the Navigator's death,
//! and a sideways step held up by someone crossing waits 20 s on top of
//! its turns. And a step onto the goal's line that someone standing beside
//! the robot keeps it from says so in the Status (`off_line`): a robot
//! stepping aside for others has then not done so.

mod common;

use rome_client::DataOptions;
use rome_maps::geometry::{direction, normalize_deg, Pose};
use rome_nav::board::{Status, Var};
use rome_nav::navigator::ROBOT_RADIUS_MM;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// How far left of where the robot stands the map puts its next goal's
/// line, mm: it steps sideways that far.
const STEP_MM: f64 = 800.0;
/// Where another robot stops in the way of the step, ahead of the
/// stepping robot's middle, mm.
const IN_THE_WAY_MM: f64 = 1_300.0;

/// Drives r1 out of the doorway into the corridor, where the side sonars
/// see both walls, and gives the walls (left, right) that the map, as the
/// Planner writes it, would put beside a goal whose line lies [`STEP_MM`]
/// to the robot's left: it will step over to it.
async fn into_the_corridor(
    rig: &rome_harness::Harness,
    planner: &rome_nav::board::Board,
    heading: f64,
) -> (i64, i64) {
    let eyes = common::robot_client(rig, "test").await;
    common::drive_d(planner, heading, 1_500, Duration::from_secs(60)).await;
    let sonar = eyes.sonar().await.expect("the sonar ring is read");
    let left = f64::from(sonar.sonar_mm[18]) + ROBOT_RADIUS_MM;
    let right = f64::from(sonar.sonar_mm[6]) + ROBOT_RADIUS_MM;
    (
        (left - STEP_MM).round() as i64,
        (right + STEP_MM).round() as i64,
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_navigator_held_up_on_a_sideways_step_still_says_it_is_alive() {
    let (rig, _stepper, heading, planner) = common::one_robot(4.0).await;
    let navigating = common::navigator(&rig, DataOptions::new("navigator")).await;
    let walls = into_the_corridor(&rig, &planner, heading).await;
    planner
        .set(Var::GoalWalls, &Some(walls))
        .await
        .expect("GoalWalls");
    // Once the robot has turned for the step and set off on it, another
    // robot crosses into its way and stays there. (One already there when
    // it turned is not waited for: the step ends short of it.)
    let someone = {
        let (world, k) = (rig.world.clone(), rig.index[0]);
        tokio::spawn(async move {
            let mut turned_at = None;
            for _ in 0..2_000 {
                let at = world.lock().robot(k).pose;
                if normalize_deg(at.heading.deg() - heading) > 80.0 {
                    turned_at.get_or_insert(at.at);
                }
                if turned_at.is_some_and(|p| (at.at - p).norm() > 100.0) {
                    let way = direction(heading + 90.0);
                    let stop = Pose::new(
                        at.at.x + way.x * IN_THE_WAY_MM,
                        at.at.y + way.y * IN_THE_WAY_MM,
                        heading,
                    );
                    world
                        .lock()
                        .add_robot("someone", stop)
                        .expect("the other robot");
                    return true;
                }
                tokio::time::sleep(Duration::from_millis(10)).await;
            }
            false
        })
    };

    // Every Status written while the goal is at hand, by simulated time.
    let status = planner.var_name(Var::Status);
    let done = Arc::new(AtomicBool::new(false));
    let watcher = {
        let (ds, done, world) = (planner.client().clone(), done.clone(), rig.world.clone());
        tokio::spawn(async move {
            let mut seen = Vec::new();
            let mut last = ds.history(&status).await.expect("Status history").seq;
            while !done.load(Ordering::SeqCst) {
                let seq = ds.history(&status).await.expect("Status history").seq;
                if seq != last {
                    last = seq;
                    let what: Status = ds.get_as(&status).await.expect("Status decodes");
                    seen.push((world.lock().time_ms(), what.blocked));
                }
                tokio::time::sleep(Duration::from_millis(20)).await;
            }
            seen
        })
    };
    let start_ms = rig.world.lock().time_ms();
    common::drive_d(&planner, heading, 1, Duration::from_secs(60)).await;
    let end_ms = rig.world.lock().time_ms();
    done.store(true, Ordering::SeqCst);
    let seen = watcher.await.expect("the watcher");
    assert!(
        someone.await.expect("the other robot"),
        "the robot never turned to step"
    );

    // The watcher may see a last write after the goal ended.
    let times: Vec<u64> = std::iter::once(start_ms)
        .chain(seen.iter().map(|(t, _)| *t).filter(|t| *t <= end_ms))
        .chain(std::iter::once(end_ms))
        .collect();
    let longest = times.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0);
    eprintln!(
        "goal held {} ms, {} Status writes, longest silence {longest} ms",
        end_ms - start_ms,
        seen.len()
    );
    assert!(
        end_ms - start_ms > 20_000,
        "the step was not held up: the goal took {} ms",
        end_ms - start_ms
    );
    assert!(
        seen.iter()
            .any(|(_, b)| b.as_deref().is_some_and(|b| b.contains("sideways step"))),
        "no Status said what the robot waits for: {seen:?}"
    );
    assert!(
        longest < 3_000,
        "the Navigator was silent for {longest} ms of robot time"
    );
    navigating.abort();
    rig.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_step_onto_the_line_kept_from_by_someone_beside_says_so() {
    let (rig, _stepper, heading, planner) = common::one_robot(4.0).await;
    let navigating = common::navigator(&rig, DataOptions::new("navigator")).await;
    let walls = into_the_corridor(&rig, &planner, heading).await;
    let k = rig.index[0];
    let stood = rig.world.lock().robot(k).pose.at;
    // Someone stands beside the robot on the side it would step to, a
    // hand's width from its body.
    let left_of = direction(heading + 90.0);
    let beside = stood + left_of * (2.0 * ROBOT_RADIUS_MM + 100.0);
    let other = (rig.world.lock())
        .add_robot("someone", Pose::new(beside.x, beside.y, heading))
        .expect("the other robot");
    let step = |why: &'static str| {
        let planner = &planner;
        async move {
            planner
                .set(Var::GoalWalls, &Some(walls))
                .await
                .expect("GoalWalls");
            common::drive_d(planner, heading, 1, Duration::from_secs(60)).await;
            let status: Status = planner.get(Var::Status).await.expect("Status");
            eprintln!("{why}: {:?}", status.off_line);
            status.off_line
        }
    };
    let kept = step("someone beside").await;
    let moved = (rig.world.lock().robot(k).pose.at - stood).dot(&left_of);
    assert!(
        kept.as_deref()
            .is_some_and(|w| w.contains("something beside")),
        "the Status did not say the step was kept from: {kept:?} (moved {moved:.0} mm)"
    );
    assert!(
        moved < STEP_MM / 2.0,
        "the robot stepped {moved:.0} mm into someone"
    );

    // Someone leaves: the step is made, and the Status says nothing.
    let away = stood - left_of * 20_000.0;
    rig.world.lock().robot_mut(other).pose = Pose::new(away.x, away.y, heading);
    let made = step("nobody beside").await;
    let moved = (rig.world.lock().robot(k).pose.at - stood).dot(&left_of);
    assert_eq!(made, None, "moved {moved:.0} mm");
    assert!(
        (moved - STEP_MM).abs() < 200.0,
        "the robot stepped {moved:.0} mm, not {STEP_MM} mm"
    );
    navigating.abort();
    rig.stop().await;
}
