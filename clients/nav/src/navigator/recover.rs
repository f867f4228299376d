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
/// Something ahead of a sideways step this much nearer than the scene at
/// rest put it has come into the way, mm (walls seen at a slant shrink a
/// little faster than the robot drives; sonar noise is a few centimetres).
const STEP_CAME_MM: f64 = 400.0;
/// Nearer than this ahead stops a sideways step with more still to go, mm.
const STEP_TOUCH_MM: f64 = 250.0;
/// The way ahead of a halted sideways step is clear again with this much
/// room beyond what is left of it, mm ...
const STEP_ROOM_MM: f64 = 400.0;
/// ... or with this much room at all, mm.
const STEP_CLEAR_MM: f64 = 1_500.0;
/// Scans (10 a second) a halted sideways step waits for its way at most.
const STEP_WAIT_SCANS: u32 = 200;
/// How near beyond its radius a sideways step brings the body to an echo
/// heard at rest, beside its way as well as ahead, mm. A wall the step
/// heads for stands farther off than that at the step's end (a robot
/// stepping aside stops [`crate::drive::ROBOT_RADIUS_MM`] + 150 mm from it).
const STEP_SIDE_CLEARANCE_MM: f64 = 100.0;
/// How near what lies behind a robot that backs away from a touch it
/// may come, mm.
const BACK_CLEARANCE_MM: f64 = 100.0;

/// How far Check-Bumper backs away from a touch: 0.3 m, as the thesis'
/// Navigator, but no nearer than [`BACK_CLEARANCE_MM`] to what the three
/// sonars looking the way it backs read, and not at all for less than
/// 100 mm, mm.
fn backing_room(away: [f64; 3]) -> f64 {
    let room = away.iter().fold(f64::INFINITY, |a, r| a.min(*r)) - BACK_CLEARANCE_MM;
    if room < 100.0 {
        0.0
    } else {
        room.min(300.0)
    }
}

/// Whether what the sonars see ahead (`now`, mm from the skin) stops a
/// sideways step with `remaining` mm to go, when the scene at rest put it
/// at `expected`.
fn step_in_the_way(now: f64, expected: f64, remaining: f64) -> bool {
    let came = now < expected - STEP_CAME_MM && now < remaining + STEP_ROOM_MM;
    let touching = now < STEP_TOUCH_MM && remaining > now;
    came || touching
}

/// How much of a sideways step of `mm` the scene at rest leaves room for
/// (`sonar_mm`, ranges from the skin, taken facing the step's way): the
/// body stops [`STEP_SIDE_CLEARANCE_MM`] short of every echo point it
/// would sweep. The sonars ahead watch the step as it goes; this also
/// counts those beside it, such as a robot that already stands aside a
/// little way along the wall the step heads for, which the body would
/// reach sideways, not head on.
fn step_room(sonar_mm: &[u32], mm: f64) -> f64 {
    let reach = ROBOT_RADIUS_MM + STEP_SIDE_CLEARANCE_MM;
    let mut room = mm;
    for (i, range) in sonar_mm.iter().enumerate() {
        let range = f64::from(*range);
        if range >= rome_schema::robot::body::SONAR_MAX_MM {
            continue;
        }
        let bearing = rome_schema::robot::body::sonar_bearing_deg(i).to_radians();
        let d = range + ROBOT_RADIUS_MM;
        let (along, across) = (d * bearing.cos(), d * bearing.sin());
        if along <= 0.0 || across.abs() >= reach {
            continue;
        }
        room = room.min(along - (reach * reach - across * across).sqrt());
    }
    room.max(0.0)
}

/// How far behind the Navigator's own pose, along the goal, the
/// CTracker's `CountedAt` may lie, mm: farther is a value from elsewhere
/// (a count seldom arrives seconds late at cruise).
const COUNTED_BEHIND_MM: f64 = 5_000.0;
/// ... and how far ahead: the CTracker's pose may be a scan newer.
const COUNTED_AHEAD_MM: f64 = 300.0;
/// ... and how far across, mm.
const COUNTED_ACROSS_MM: f64 = 1_000.0;

/// Where the D goal after an L segment along `direction_deg` is measured
/// from: the CTracker's `counted` when it lies plausibly behind `pose`
/// (where the Navigator learned of the count), else `None`.
pub(super) fn counted_start(
    counted: Option<crate::board::CountedAt>,
    pose: &Pose,
    direction_deg: f64,
) -> Option<Pose> {
    let c = counted?;
    if !(c.x_mm.is_finite() && c.y_mm.is_finite()) {
        return None;
    }
    let axis = rome_maps::geometry::direction(direction_deg);
    let (dx, dy) = (c.x_mm - pose.at.x, c.y_mm - pose.at.y);
    let along = dx * axis.x + dy * axis.y;
    let across = dy * axis.x - dx * axis.y;
    let plausible = (-COUNTED_BEHIND_MM..=COUNTED_AHEAD_MM).contains(&along)
        && across.abs() <= COUNTED_ACROSS_MM;
    plausible.then(|| Pose {
        at: rome_maps::geometry::Point::new(c.x_mm, c.y_mm),
        heading: pose.heading,
    })
}

impl Navigator {
    /// Where the D goal after the L goal just ended at `pose` is measured
    /// from: where the CTracker counted the last light and took the
    /// overshoot the Planner takes off that goal. The count reaches the
    /// Navigator later, over a slow or lossy link a metre or more later;
    /// measured from `pose`, the robot would stop that much past its goal.
    pub(super) async fn after_count(&self, goal: &Goal, pose: Pose) -> Pose {
        let counted = self.board.get(Var::CountedAt).await.ok().flatten();
        match counted_start(counted, &pose, goal.direction_deg) {
            Some(at) => {
                tracing::debug!(
                    late_mm = at.dist(&pose),
                    "navigator: the next goal is measured from where the count was taken"
                );
                at
            }
            None => {
                if counted.is_some() {
                    tracing::warn!(?counted, "navigator: CountedAt lies nowhere near the robot; the next goal is measured from here");
                }
                pose
            }
        }
    }

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
    /// not believed. `Some` says why the robot ends off its line: what it
    /// could not measure or where the step stopped.
    pub(super) async fn onto_line(
        &mut self,
        scans: &rome_client::robot::Stream<Scan>,
        at_rest: Scan,
        goal: &Goal,
        left_mm: f64,
        right_mm: f64,
    ) -> Result<Option<String>, NavError> {
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
                return Ok(Some(format!(
                    "something beside it: the side sonars read {:.1} m across where the map has {:.1} m",
                    (left + right) / 1_000.0,
                    (left_mm + right_mm) / 1_000.0
                )));
            }
            squared = true;
            self.send(Drive::Turn(err)).await?;
            scan = self.settle(scans).await?;
        };
        // Left of the goal's line is positive.
        let off = ((right - left) - (right_mm - left_mm)) / 2.0;
        if off.abs() <= OFF_LINE_MM {
            return Ok(None);
        }
        if off.abs() > MAX_STEP_MM {
            return Ok(Some(format!(
                "{:.2} m off its line, more than a sideways step",
                off.abs() / 1_000.0
            )));
        }
        tracing::info!(off, "navigator: stepping sideways onto the goal's line");
        let quarter = if off > 0.0 { -90.0 } else { 90.0 };
        self.send(Drive::Turn(quarter)).await?;
        let at_rest = self.settle(scans).await?;
        let short = self.step_watched(scans, at_rest, off.abs()).await?;
        self.send(Drive::Turn(-quarter)).await?;
        self.settle(scans).await?;
        self.last = None;
        Ok(short)
    }

    /// The sideways step itself, `mm` straight on, watching the sonars
    /// ahead: the step crosses the corridor, where other robots drive.
    /// Something that comes nearer than the scene at rest explains, and is
    /// in the way of what is left of the step, stops the robot; it goes on
    /// once the way is clear, or stays where it is (off its line) after
    /// [`STEP_WAIT_SCANS`]. With nothing coming it is the same move as an
    /// unwatched one. `Some` says why it stopped more than [`OFF_LINE_MM`]
    /// short.
    async fn step_watched(
        &mut self,
        scans: &rome_client::robot::Stream<Scan>,
        at_rest: Scan,
        mm: f64,
    ) -> Result<Option<String>, NavError> {
        let ahead = |s: &Scan| f64::from((10..=14).map(|i| s.sonar_mm[i]).min().unwrap_or(0));
        let mut left = step_room(&at_rest.sonar_mm, mm);
        if left < mm {
            tracing::info!(
                room = left,
                step = mm,
                "navigator: something beside the sideways step's way; stepping only as far as it leaves room"
            );
        }
        let short = |left: f64, why: &str| {
            (left > OFF_LINE_MM)
                .then(|| format!("{why}: stopped {:.2} m short of its line", left / 1_000.0))
        };
        let room_short = short(mm - left, "something beside the step's way");
        let mut expected = ahead(&at_rest);
        let mut waited = 0;
        while left > OFF_LINE_MM / 3.0 {
            let from = self.pose().await?;
            self.robot.move_by(left, 200.0, -1.0).await?;
            let stopped = loop {
                let scan = self.next_scan(scans).await?;
                self.beat(scan.time_ms, || None).await?;
                let moved = self.pose().await?.dist(&from);
                let now = ahead(&scan);
                let remaining = left - moved;
                if step_in_the_way(now, expected - moved, remaining) {
                    tracing::info!(
                        ahead = now,
                        remaining,
                        "navigator: something crosses the sideways step; waiting"
                    );
                    self.send(Drive::Halt).await?;
                    self.settle(scans).await?;
                    break true;
                }
                if self.base_settled().await? {
                    break false;
                }
            };
            if !stopped {
                return Ok(room_short);
            }
            left -= self.pose().await?.dist(&from);
            // Wait for the way to clear.
            loop {
                let scan = self.next_scan(scans).await?;
                let now = ahead(&scan);
                let why = || {
                    Some(format!(
                        "waiting: something {:.1} m ahead is in the way of the sideways step onto the goal's line",
                        now / 1_000.0
                    ))
                };
                self.beat(scan.time_ms, why).await?;
                if now >= (left + STEP_ROOM_MM).min(STEP_CLEAR_MM) {
                    expected = now;
                    break;
                }
                waited += 1;
                if waited >= STEP_WAIT_SCANS {
                    tracing::info!(
                        "navigator: the sideways step stays blocked; staying off the line"
                    );
                    return Ok(short(left, "something in the step's way"));
                }
            }
        }
        Ok(room_short)
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
            // Beyond the thesis: away from the touch only as far as the
            // sonars on that side leave room. Among other robots, backing
            // blind the full 0.3 m touched the one behind.
            let away = if b.front { [23, 0, 1] } else { [11, 12, 13] };
            let room = away.map(|i| f64::from(scan.sonar_mm[i]));
            let back = backing_room(room);
            // Each is carried out before the next is sent: a command sent
            // at once would take the place of the one before.
            if back > 0.0 {
                let back = if b.front { -back } else { back };
                self.robot.move_by(back, 200.0, -1.0).await?;
                self.settle(scans).await?;
            }
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

#[cfg(test)]
mod step_tests {
    use super::{backing_room, step_in_the_way, step_room, ROBOT_RADIUS_MM};
    use rome_schema::robot::body::{sonar_bearing_deg, SONARS, SONAR_HALF_BEAM_DEG, SONAR_MAX_MM};

    /// Ranges from the skin of a robot at the origin facing +x, to a
    /// robot's disc at `other` (if any) and a wall across the way at
    /// `wall_x` mm: the nearest of rays across each beam.
    fn ranges(other: Option<(f64, f64)>, wall_x: f64) -> Vec<u32> {
        (0..SONARS)
            .map(|i| {
                let mut nearest = SONAR_MAX_MM;
                for k in -5..=5 {
                    let b = (sonar_bearing_deg(i) + SONAR_HALF_BEAM_DEG * f64::from(k) / 5.0)
                        .to_radians();
                    let (dx, dy) = (b.cos(), b.sin());
                    if dx > 0.0 {
                        nearest = nearest.min(wall_x / dx);
                    }
                    if let Some((cx, cy)) = other {
                        let t = cx * dx + cy * dy;
                        let miss2 = cx * cx + cy * cy - t * t;
                        let r2 = ROBOT_RADIUS_MM * ROBOT_RADIUS_MM;
                        if t > 0.0 && miss2 < r2 {
                            nearest = nearest.min(t - (r2 - miss2).sqrt());
                        }
                    }
                }
                (nearest - ROBOT_RADIUS_MM).clamp(0.0, SONAR_MAX_MM) as u32
            })
            .collect()
    }

    #[test]
    fn a_sideways_step_stops_short_of_a_robot_standing_aside_beside_its_end() {
        // A robot 690 mm from the aside line steps to it, 530 mm from the
        // wall; alone, it steps the whole way.
        let step = 690.0;
        let wall = step + 530.0;
        assert_eq!(step_room(&ranges(None, wall), step), step);
        // Another stands on that line 730 mm along the wall, to either
        // side: the whole step would bring the two 0.73 m apart, less than
        // two radii (what happened among forty robots in corridor N).
        for side in [730.0, -730.0] {
            let other = (step, side);
            let room = step_room(&ranges(Some(other), wall), step);
            let apart = (other.0 - room).hypot(other.1);
            assert!(
                apart >= 2.0 * ROBOT_RADIUS_MM + 50.0,
                "stepped {room:.0} of {step} mm, ending {apart:.0} mm from the other"
            );
            // It still steps, where there is room.
            assert!(room > 150.0, "stepped only {room:.0} mm");
        }
        // One farther along the wall leaves the step whole.
        assert_eq!(step_room(&ranges(Some((step, 1_500.0)), wall), step), step);
    }

    #[test]
    fn backing_away_from_a_touch_stops_short_of_what_is_behind() {
        // Nothing behind: the thesis' 0.3 m.
        assert_eq!(backing_room([10_000.0, 10_000.0, 10_000.0]), 300.0);
        // A robot 0.25 m behind, 15° off: 0.15 m, 0.1 m short of it.
        assert_eq!(backing_room([250.0, 900.0, 10_000.0]), 150.0);
        // Closer than that: no backing at all.
        assert_eq!(backing_room([10_000.0, 140.0, 10_000.0]), 0.0);
    }

    #[test]
    fn a_wall_that_nears_as_the_robot_drives_does_not_stop_the_step() {
        // 1.6 m to the far wall at rest, 1.0 m driven, 0.2 m to go.
        assert!(!step_in_the_way(620.0, 600.0, 200.0));
        // The last of a step towards a line near the far wall.
        assert!(!step_in_the_way(420.0, 430.0, 20.0));
    }

    #[test]
    fn a_robot_that_comes_into_the_step_stops_it() {
        // The wall was 2 m off; a robot crossing stands 0.5 m ahead with
        // 0.8 m of the step to go.
        assert!(step_in_the_way(500.0, 1_700.0, 800.0));
        // Nearer than the step will go, though the scene at rest saw it.
        assert!(step_in_the_way(200.0, 250.0, 600.0));
    }

    #[test]
    fn something_beyond_the_end_of_the_step_is_no_matter() {
        // Came closer than expected, but beyond what is left of the step.
        assert!(!step_in_the_way(1_200.0, 2_000.0, 300.0));
    }

    #[test]
    fn a_d_goal_is_measured_from_a_count_taken_behind_the_robot() {
        use super::counted_start;
        use crate::board::CountedAt;
        use rome_maps::geometry::Pose;
        // Heading 90 (West): along is -x.
        let here = Pose::new(10_000.0, 5_000.0, 90.0);
        let at = |x_mm, y_mm| Some(CountedAt { x_mm, y_mm });
        // Taken 1.1 m behind: measured from there.
        let from = counted_start(at(11_100.0, 5_020.0), &here, 90.0).expect("a start");
        assert_eq!((from.at.x, from.at.y), (11_100.0, 5_020.0));
        assert_eq!(from.heading, here.heading);
        // A scan newer than the Navigator's pose, a little ahead: taken.
        assert!(counted_start(at(9_800.0, 5_000.0), &here, 90.0).is_some());
        // Nowhere near: far behind, ahead, across, or not a number.
        for bad in [
            at(16_000.0, 5_000.0),
            at(9_000.0, 5_000.0),
            at(10_500.0, 6_500.0),
            at(f64::NAN, 5_000.0),
            at(10_500.0, f64::INFINITY),
            None,
        ] {
            assert_eq!(counted_start(bad, &here, 90.0), None, "{bad:?}");
        }
    }
}
