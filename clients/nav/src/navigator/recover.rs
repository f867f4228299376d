//! What the Navigator does when things are off: Check-Bumper and
//! Check-Goal (§5.4), stepping onto a D goal's line when people left the
//! robot aside, and ending a goal whose values are bad without ending the
//! Navigator.

use super::*;

/// How far across from its goal's line a robot may end a D goal before it
/// steps sideways onto it, mm.
const OFF_LINE_MM: f64 = 300.0;
/// The longest such sideways step, mm: farther off is a misreading (a
/// robot in a corridor cannot stand farther from its middle).
const MAX_STEP_MM: f64 = 1_500.0;
/// How near the side sonars' two ranges must add up to the map's width
/// beside the goal for them to be believed, mm.
const WIDTH_AGREES_MM: f64 = 250.0;

impl Navigator {
    /// Ends the goal at hand because a value it depends on is bad: the
    /// robot is stopped, the reason goes to `Status.failed`, and the
    /// Planner is told the goal is over, so this Navigator goes on to the
    /// next goal. Anything but a bad value ([`crate::bad_value`]) or a
    /// segment the CTracker gave up (a server gone, a blackboard that
    /// cannot be written) is returned, and ends the Navigator.
    pub(super) async fn fail_goal(&mut self, e: NavError) -> Result<(), NavError> {
        let bad_value = match &e {
            NavError::Unreadable { source, .. } => crate::bad_value(source),
            NavError::SegmentGivenUp(_) | NavError::Ride(_) => true,
            _ => false,
        };
        if !bad_value {
            return Err(e);
        }
        let why = format!("goal {} ended: {e}", self.goals);
        tracing::warn!("navigator: {why}");
        if let Err(stop) = self.send(Drive::Halt).await {
            tracing::warn!(error = %stop, "navigator: could not stop the robot");
        }
        self.hallway = None;
        self.carry = None;
        self.blocked = None;
        let said = async {
            let mut status: Status = self.board.get(Var::Status).await.unwrap_or_else(|_| {
                Status::at(self.goals, GoalType::D, "stopped", &Pose::default(), 0.0)
            });
            status.state = "stopped".into();
            status.failed = Some(why.clone());
            self.board.set(Var::Status, &status).await?;
            self.board.set(Var::GoalActive, &None::<ActiveGoal>).await?;
            self.board.up(Sem::RobotStatus).await
        };
        // A blackboard that cannot be written cannot be told either: the
        // value that could not be read is what went wrong.
        said.await.map_err(|_| e)
    }

    /// Check-Goal's look at `$GoalData`: a goal handed before the one at
    /// hand ended replaces it (a Planner's run was ended, a task given up
    /// or cancelled, and the robot is to stop). The robot is stopped and
    /// the goal at hand ends with [`NavError::Superseded`]; the new goal
    /// is taken next. Without this look, a Navigator would drive on to
    /// the goal of a run nobody follows any more, and its `$RobotStatus`
    /// would end the next run's first goal.
    pub(super) async fn goal_handed_meanwhile(&mut self) -> Result<(), NavError> {
        let handed = self.board.goal_handed_meanwhile().await.map_err(|e| {
            NavError::reading("the goal (GoalType, GoalDistance, GoalDirection)", e)
        })?;
        let Some(goal) = handed else {
            return Ok(());
        };
        self.send(Drive::Halt).await?;
        self.hallway = None;
        self.carry = None;
        self.blocked = None;
        self.handed = Some(goal);
        Err(NavError::Superseded)
    }

    /// At the end of a D goal, a robot standing more than
    /// [`OFF_LINE_MM`] across from its goal, as the side sonars measure it
    /// against where the map puts the walls beside the goal (`left`,
    /// `right` mm from it), steps sideways onto the goal's line: a quarter
    /// turn, a move, a quarter turn back. Among people the robot keeps
    /// right or steers round them, and nothing else brings it back once
    /// the distance is driven. Side readings that do not add up to the
    /// map's width there (a person or an open door beside the robot) are
    /// not believed.
    pub(super) async fn onto_line(
        &mut self,
        scans: &rome_client::robot::Stream<Scan>,
        at_rest: Scan,
        goal: &Goal,
        left_mm: f64,
        right_mm: f64,
    ) -> Result<(), NavError> {
        let mut squared = false;
        let mut scan = at_rest;
        let (left, right) = loop {
            // Side ranges start at the ring, a radius out from the middle.
            let left = f64::from(scan.sonar_mm[18]) + ROBOT_RADIUS_MM;
            let right = f64::from(scan.sonar_mm[6]) + ROBOT_RADIUS_MM;
            tracing::debug!(
                left,
                right,
                left_mm,
                right_mm,
                "navigator: where across the hallway the D goal ended"
            );
            if (left + right - (left_mm + right_mm)).abs() < WIDTH_AGREES_MM {
                break (left, right);
            }
            // A robot left at an angle to the walls (steering round
            // someone) hears no echo from them: it faces along the
            // corridor once and looks again.
            let err = normalize_deg(goal.direction_deg - self.pose().await?.heading.deg());
            if squared || err.abs() < 5.0 {
                return Ok(());
            }
            squared = true;
            self.send(Drive::Turn(err)).await?;
            scan = self.settle(scans).await?;
        };
        // Left of the goal's line is positive.
        let off = ((right - left) - (right_mm - left_mm)) / 2.0;
        if off.abs() <= OFF_LINE_MM || off.abs() > MAX_STEP_MM {
            return Ok(());
        }
        tracing::info!(off, "navigator: stepping sideways onto the goal's line");
        let quarter = if off > 0.0 { -90.0 } else { 90.0 };
        self.send(Drive::Turn(quarter)).await?;
        self.settle(scans).await?;
        self.robot.move_by(off.abs(), 200.0, -1.0).await?;
        self.settle(scans).await?;
        self.send(Drive::Turn(-quarter)).await?;
        self.settle(scans).await?;
        self.last = None;
        Ok(())
    }

    /// Check-Bumper: on contact, back off, turn away from the obstacle
    /// (toward the goal direction, or the more open side) and go on.
    /// Whether there was a contact.
    pub(super) async fn check_bumper(
        &mut self,
        pose: &Pose,
        goal: &Goal,
        scan: &Scan,
        scans: &rome_client::robot::Stream<Scan>,
    ) -> Result<bool, NavError> {
        let b = self.robot.bumper().await?;
        if b.front || b.rear {
            self.log.bumps += 1;
            tracing::warn!(front = b.front, rear = b.rear, "navigator: bumper contact");
            let back = if b.front { -300.0 } else { 300.0 };
            // Each is carried out before the next is sent: a command sent
            // at once would take the place of the one before.
            self.robot.move_by(back, 200.0, -1.0).await?;
            self.settle(scans).await?;
            let err = normalize_deg(goal.direction_deg - pose.heading.deg());
            let turn = if err.abs() >= 5.0 {
                err.clamp(-30.0, 30.0)
            } else if scan.sonar_mm[18] > scan.sonar_mm[6] {
                20.0
            } else {
                -20.0
            };
            self.robot.turn(-turn, 45.0, -1.0).await?;
            self.settle(scans).await?;
            self.last = None;
            return Ok(true);
        }
        Ok(false)
    }

    /// Check-Goal: a heading far off the goal direction is turned back.
    pub(super) async fn check_goal(
        &mut self,
        pose: &Pose,
        goal: &Goal,
        corner: bool,
    ) -> Result<(), NavError> {
        let err = normalize_deg(goal.direction_deg - pose.heading.deg());
        if err.abs() > if corner { 10.0 } else { 20.0 } {
            tracing::info!(
                err,
                "navigator: check-goal turns back to the goal direction"
            );
            self.send(Drive::Turn(err.clamp(-45.0, 45.0))).await?;
            self.last = None;
        }
        Ok(())
    }
}
