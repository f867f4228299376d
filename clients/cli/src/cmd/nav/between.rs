//! `rome planner --building`: the Planner of a run between floors as a
//! process of its own (§5.4.6): the first floor's goals, the elevator ride
//! (the Navigator's V goal), the second floor's goals; ends with where
//! ground truth puts the robot, floor included.

use crate::exit;
use anyhow::Context;
use rome_client::sim::TruthClient;
use rome_client::RobotClient;
use rome_nav::board::{Board, GoalType};
use rome_nav::floors::{self, FloorPlan};
use rome_nav::planner::{self, Progress};

/// How near its goal, on the goal's floor, a run between floors ends to
/// have arrived, mm.
const ARRIVED_MM: f64 = 500.0;

/// A goal handed over, as a line says it: `V ride old.elevator from
/// floor 3 to 5`, `L 9 light(s) heading 90°`, `D 2153 mm heading 90°`.
pub fn goal(h: &rome_nav::planner::Handed) -> String {
    let g = &h.step.goal;
    match (&h.step.ride, g.goal_type) {
        (Some(x), GoalType::V) => {
            format!("V ride {} from floor {} to {}", x.elevator, x.from, x.to)
        }
        (_, GoalType::L) => format!("L {} light(s) heading {:.0}°", g.distance, g.direction_deg),
        _ => format!(
            "{:?} {} mm heading {:.0}°",
            g.goal_type, g.distance, g.direction_deg
        ),
    }
}

/// How many goals a run between floors has and which elevator it rides:
/// `5 goal(s), riding old.elevator from floor 3 to 5`.
pub fn headline(fp: &FloorPlan) -> String {
    let ride = fp.ride.as_ref().and_then(|s| s.ride.as_ref());
    format!(
        "{} goal(s){}",
        fp.steps().len(),
        ride.map_or(String::new(), |x| format!(
            ", riding {} from floor {} to {}",
            x.elevator, x.from, x.to
        ))
    )
}

/// Prints the plan of a run between floors: `title` then its goals.
pub fn describe(title: &str, fp: &FloorPlan) {
    println!("{title}: {}", headline(fp));
    for line in fp.describe() {
        println!("  {line}");
    }
}

/// Drives the robot along `fp`: registers it at the start, hands the goals
/// over and judges each. Exit 1 when it did not end on the goal's floor
/// within half a metre of the goal (by ground truth, or odometry without).
pub async fn drive(
    board: &Board,
    robot: &RobotClient,
    truth: Option<&TruthClient>,
    fp: &FloorPlan,
    heading: Option<f64>,
) -> anyhow::Result<u8> {
    let first = &fp.walks[0].1;
    planner::put_down(robot, first, heading)
        .await
        .context("cannot register the robot at the start")?;
    let total = fp.steps().len();
    let handed = floors::run(board, robot, fp, truth, |p| match p {
        Progress::Handed(h) => println!("[goal {}/{total}] {}", h.index + 1, goal(h)),
        Progress::Done(h) => match &h.failure {
            Some(why) => println!("[goal {}/{total}] failed: {why}", h.index + 1),
            None => println!("[goal {}/{total}] done", h.index + 1),
        },
        _ => {}
    })
    .await?;
    let (floor, plan) = fp.walks.last().context("a plan walks somewhere")?;
    let goal = plan.ends().1;
    let ended = handed.len() < total || handed.iter().any(|h| h.failure.is_some());
    let (where_, miss) = match truth {
        Some(t) => {
            let end = t.get().await.context("no ground truth at the end")?;
            let at = rome_maps::geometry::pt(end.x_mm, end.y_mm);
            let on = end.floor.clone().unwrap_or_else(|| "?".into());
            let miss = (end.floor.as_deref() == Some(floor.as_str()))
                .then(|| rome_maps::geometry::distance(at, goal));
            (format!("ground truth puts it on floor {on}"), miss)
        }
        None => {
            let p = rome_maps::geometry::Pose::from(&robot.pose().await?).at;
            (
                "no ground truth; by odometry".to_string(),
                Some(rome_maps::geometry::distance(p, goal)),
            )
        }
    };
    match miss {
        Some(m) => println!(
            "done: {} of {total} goal(s); {where_}, {:.2} m from {}",
            handed.len(),
            m / 1_000.0,
            fp.to
        ),
        None => println!(
            "done: {} of {total} goal(s); {where_}, not {}'s",
            handed.len(),
            fp.to
        ),
    }
    Ok(if !ended && miss.is_some_and(|m| m <= ARRIVED_MM) {
        exit::OK
    } else {
        exit::ERROR
    })
}
