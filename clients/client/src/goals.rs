//! The Planner → Navigator goal hand-over of Table 5.4 (§5.3, §5.8).
//!
//! The Planner writes `GoalType`, `GoalDistance` and `GoalDirection`, does
//! up(`$GoalData`) and then down(`$RobotStatus`) before it may write the
//! next goal; the Navigator does down(`$GoalData`), reads the three
//! variables, carries the goal out and does up(`$RobotStatus`). Both
//! semaphores start at 0, so the two form a one-slot producer/consumer.

use crate::{ClientError, DataClient};
use serde::{Deserialize, Serialize};

/// Semaphore the Planner signals when a goal is ready.
pub const GOAL_DATA: &str = "$GoalData";
/// Semaphore the Navigator signals when it is ready for the next goal.
pub const ROBOT_STATUS: &str = "$RobotStatus";
/// Variable: the segment's mode (`L`, `D`, `E` or `C`).
pub const GOAL_TYPE: &str = "GoalType";
/// Variable: lights to track (mode L) or millimetres to travel.
pub const GOAL_DISTANCE: &str = "GoalDistance";
/// Variable: the heading to keep, in degrees (North 0, West 90).
pub const GOAL_DIRECTION: &str = "GoalDirection";

/// The mode of one path segment (§5.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum GoalType {
    /// S^l: track ceiling lights.
    L,
    /// S^d: dead reckoning to the turning space.
    D,
    /// S^d ending at an elevator.
    E,
    /// S^c: leave the corner.
    C,
}

/// One goal as the Planner hands it to the Navigator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Goal {
    /// The segment's mode.
    pub goal_type: GoalType,
    /// Number of lights (L) or distance in mm (D, E, C).
    pub distance: i64,
    /// Heading in degrees.
    pub direction_deg: i64,
}

/// Creates the two semaphores (at 0) if they do not exist yet.
pub async fn declare(ds: &DataClient) -> Result<(), ClientError> {
    ds.create_semaphore(GOAL_DATA, 0).await?;
    ds.create_semaphore(ROBOT_STATUS, 0).await?;
    Ok(())
}

/// Planner side: hands over one goal and waits until the Navigator is
/// done with it.
pub async fn hand_over(ds: &DataClient, goal: &Goal) -> Result<(), ClientError> {
    ds.set(GOAL_TYPE, &goal.goal_type).await?;
    ds.set(GOAL_DISTANCE, &goal.distance).await?;
    ds.set(GOAL_DIRECTION, &goal.direction_deg).await?;
    ds.signal(GOAL_DATA).await?;
    ds.wait(ROBOT_STATUS).await
}

/// Navigator side: waits for the next goal and reads it.
pub async fn take(ds: &DataClient) -> Result<Goal, ClientError> {
    ds.wait(GOAL_DATA).await?;
    Ok(Goal {
        goal_type: ds.get_as(GOAL_TYPE).await?,
        distance: ds.get_as(GOAL_DISTANCE).await?,
        direction_deg: ds.get_as(GOAL_DIRECTION).await?,
    })
}

/// Navigator side: reports the goal done, so the Planner may go on.
pub async fn done(ds: &DataClient) -> Result<(), ClientError> {
    ds.signal(ROBOT_STATUS).await.map(|_| ())
}
