//! The Path Planner as a client (§5.3, §5.8): puts the robot down at the
//! start, then hands the plan's goals to the Navigator one at a time.
//!
//! For each goal it writes GoalType, GoalDistance and GoalDirection and
//! signals `$GoalData`, then waits on `$RobotStatus` before the next. An L
//! segment also gets LightOffset and `$TrackData` (for the CTracker) and
//! `$StartMap` (for the local mapper); after it the Planner waits on
//! `$EndLMode` and takes the CTracker's `Overshoot` off the dead-reckoning
//! distance that follows: the overshoot compensation of Chapter 6.

use crate::board::{Board, GoalType, Sem, Var};
use crate::plan::{Plan, Step};
use crate::NavError;
use rome_client::RobotClient;

/// One goal as handed over, with what it turned into.
#[derive(Debug, Clone, PartialEq)]
pub struct Handed {
    /// Index in the plan.
    pub index: usize,
    /// The step, with the distance actually sent.
    pub step: Step,
    /// The Overshoot read after an L segment, mm.
    pub overshoot_mm: Option<i64>,
}

/// Registers the robot at the plan's start: odometry reads the map's
/// coordinates and the robot's true heading (the thesis gives the robot its
/// true heading at the start, §5). `facing` is that heading when it is not
/// already the route's: the robot is then turned onto the route in place.
pub async fn put_down(
    robot: &RobotClient,
    plan: &Plan,
    facing: Option<f64>,
) -> Result<(), NavError> {
    let (start, _) = plan.ends();
    let facing = facing.unwrap_or(plan.start_heading_deg);
    if !facing.is_finite() {
        return Err(NavError::Config(format!(
            "the start heading must be a number of degrees, got {facing}"
        )));
    }
    robot
        .set_pose(start.0.round() as i64, start.1.round() as i64, facing)
        .await?;
    let turn = rome_maps::geometry::normalize_deg(plan.start_heading_deg - facing);
    if turn.abs() > 1.0 {
        // Positive turns are clockwise on the base.
        robot.turn(-turn, 45.0, -1.0).await?;
        while robot.mode().await?.mode == "point_turn" {
            tokio::time::sleep(std::time::Duration::from_millis(50)).await;
        }
    }
    Ok(())
}

/// Hands every goal of the plan to the Navigator; `progress` hears of each
/// goal as it is handed over.
pub async fn run(
    board: &Board,
    plan: &Plan,
    mut progress: impl FnMut(&Handed),
) -> Result<Vec<Handed>, NavError> {
    board.declare().await?;
    let mut out = Vec::with_capacity(plan.steps.len());
    let mut overshoot = 0i64;
    for (index, step) in plan.steps.iter().enumerate() {
        let mut step = step.clone();
        let mut handed_overshoot = None;
        match step.goal.goal_type {
            GoalType::L => {
                board.set(Var::LightOffset, &step.light_offsets_mm).await?;
                board.set(Var::GoalDistance, &step.goal.distance).await?;
                board
                    .set(Var::GoalDirection, &step.goal.direction_deg)
                    .await?;
                board.up(Sem::TrackData).await?;
                board.up(Sem::StartMap).await?;
            }
            GoalType::D | GoalType::E => {
                // The Navigator measures from where it stopped counting
                // lights; the CTracker says how far past the light that was.
                step.goal.distance = (step.goal.distance - overshoot).max(0);
                overshoot = 0;
            }
            GoalType::C => {}
        }
        board.give_goal(&step.goal).await?;
        let mut handed = Handed {
            index,
            step: step.clone(),
            overshoot_mm: None,
        };
        progress(&handed);
        board.down(Sem::RobotStatus).await?;
        if step.goal.goal_type == GoalType::L {
            board.down(Sem::EndLMode).await?;
            overshoot = board.get(Var::Overshoot).await?;
            handed_overshoot = Some(overshoot);
        }
        handed.overshoot_mm = handed_overshoot;
        out.push(handed);
    }
    Ok(out)
}
