//! The Navigator's Status on the blackboard. It is written every second of
//! robot time while a goal is at hand: in the control loop, and again
//! while the Navigator waits outside it (a turn or a stop settling, a
//! sideways step held up by someone crossing). A Planner that hears
//! nothing for [`crate::planner::NAVIGATOR_SILENCE`] takes the Navigator
//! for dead and gives the goal up, so a wait longer than that must not be
//! silent.

use super::*;

/// How often the Status is written while the Navigator waits outside its
/// loop, robot time, ms (the loop writes it as often).
const BEAT_MS: u64 = 1_000;

/// The goal at hand, for its Status, and when that is due again.
pub(super) struct AtHand {
    goal_type: GoalType,
    corner: bool,
    /// Scan time of the next write; `None` until a wait has begun.
    next_ms: Option<u64>,
}

impl AtHand {
    /// For `goal`, which a ride does not take: its stages say where it is.
    pub(super) fn for_goal(goal: &Goal) -> Option<AtHand> {
        (goal.goal_type != GoalType::V).then_some(AtHand {
            goal_type: goal.goal_type,
            corner: matches!(goal.goal_type, GoalType::C | GoalType::E),
            next_ms: None,
        })
    }
}

fn state(corner: bool) -> &'static str {
    if corner {
        "corner"
    } else {
        "center-hallway"
    }
}

impl Navigator {
    /// The Status of a goal of `goal_type` at `pose`, with why the robot
    /// gets nowhere if it does.
    fn status_at(&self, goal_type: GoalType, corner: bool, pose: &Pose) -> Status {
        let mut status = Status::at(
            self.goals,
            goal_type,
            state(corner),
            pose,
            self.hallway.as_ref().map_or(0.0, |h| h.safe_mm),
        );
        status.blocked = self.blocked.clone();
        status.off_line = self.off_line.clone();
        status
    }

    /// Writes the Status of `goal` at `pose`.
    pub(super) async fn publish(
        &mut self,
        goal: &Goal,
        pose: &Pose,
        corner: bool,
    ) -> Result<(), NavError> {
        let status = self.status_at(goal.goal_type, corner, pose);
        self.board.set(Var::Status, &status).await?;
        if let Some(at_hand) = self.at_hand.as_mut() {
            at_hand.next_ms = None;
        }
        Ok(())
    }

    /// While the Navigator waits outside its loop, at the scan of time
    /// `t_ms`: the goal's Status, once a second, with the robot's pose
    /// and what it waits for (`waiting`, asked only when a write is due)
    /// if that is known.
    pub(super) async fn beat(
        &mut self,
        t_ms: u64,
        waiting: impl FnOnce() -> Option<String>,
    ) -> Result<(), NavError> {
        let Some(at_hand) = self.at_hand.as_mut() else {
            return Ok(());
        };
        match at_hand.next_ms {
            Some(next) if t_ms >= next => {}
            Some(_) => return Ok(()),
            None => {
                at_hand.next_ms = Some(t_ms + BEAT_MS);
                return Ok(());
            }
        }
        at_hand.next_ms = Some(t_ms + BEAT_MS);
        let (goal_type, corner) = (at_hand.goal_type, at_hand.corner);
        let pose = Pose::from(&self.robot.pose().await?);
        let mut status = self.status_at(goal_type, corner, &pose);
        if let Some(why) = waiting() {
            status.blocked = Some(why);
        }
        self.board.set(Var::Status, &status).await?;
        Ok(())
    }
}
