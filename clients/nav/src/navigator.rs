//! The Navigator (§5.4): a deterministic state machine run in one control
//! loop (Fig. 5.8). Each pass takes the newest sonar and infrared scan and
//! the odometry pose, asks the goal function whether the segment is done,
//! and lets the current state steer.
//!
//! | mode (Table 5.2)        | state          | goal   |
//! |-------------------------|----------------|--------|
//! | ceiling-light tracking  | Center-Hallway | L-Goal |
//! | dead reckoning          | Center-Hallway | D-Goal |
//! | leave corner            | Corner         | D-Goal |
//! | enter corner            | Corner         | E-Goal |
//!
//! Check-Bumper and Check-Goal run every few seconds of robot time beside
//! the loop. Goals come from the Planner through `$GoalData`; the Navigator
//! answers each with `$RobotStatus` (Table 5.4).

use crate::board::{ActiveGoal, Board, Goal, GoalType, Sem, Status, Var};
use crate::drive::{ahead_speed_cap, reaction_s, stops_short, Speedometer, Throttle};
pub use crate::drive::{
    Drive, NavConfig, FORWARD, JOG_RATE_DEG_S, KEEP_RIGHT_AHEAD_MM, KEEP_RIGHT_BEAR_DEG,
    KEEP_RIGHT_FOR_MM, ONCOMING_CLOSING, OPEN_ENOUGH_MM, ROBOT_CLEARANCE_MM, ROBOT_RADIUS_MM,
    SAFE_START_MM, SONARS, SPACING,
};
pub use crate::hallway::{
    bearing, corner_step, open_sonar, side_touch, sonar_add, sonar_towards, Hallway, Oncoming,
    Walls,
};
use crate::NavError;
use blocked::Headway;
use rome_client::RobotClient;
use rome_maps::geometry::normalize_deg;
use rome_schema::robot::Scan;
use std::time::Duration;

/// Over this last stretch of a D goal that lies off the corridor's middle,
/// the robot moves onto the goal's line, mm.
pub const LANE_APPROACH_MM: f64 = 5_000.0;

/// Driving to a corner, a robot keeps right for an oncoming one only while
/// the turning space is farther than this, mm: over the last metres it
/// lines up on the corridor's middle to turn.
pub const ENTER_PASSING_MM: f64 = 2_500.0;
/// A Leave-Corner goal driven keeping right ends only with the robot
/// heading within this of the corridor's axis, degrees: half of what the
/// report judges a corner by ([`crate::report::CORNER_HEADING_DEG`]).
pub const LEFT_CORNER_SWERVE_DEG: f64 = 10.0;
/// Scans in a row (a tenth of a second each) a robot told to drive may
/// stand still before Check-Bumper looks why.
const STILL_SCANS: u32 = 3;
/// A pose, here in the odometry frame: the project's one pose type.
pub use rome_maps::geometry::Pose;

/// What the Navigator did: goals carried out per mode, and each failure.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NavLog {
    /// Goals done: L, E, C, D, V.
    pub done: [usize; 5],
    /// In-place turns made by Center-Hallway.
    pub turns: usize,
    /// Bumper contacts handled.
    pub bumps: usize,
}

fn slot(t: GoalType) -> usize {
    match t {
        GoalType::L => 0,
        GoalType::E => 1,
        GoalType::C => 2,
        GoalType::D => 3,
        GoalType::V => 4,
    }
}

/// A command's round trip longer than this (and than three times the
/// estimate) is taken as an outage, not as the link's speed, s.
const OUTAGE_S: f64 = 0.25;

/// The Navigator of one robot.
pub struct Navigator {
    robot: RobotClient,
    board: Board,
    cfg: NavConfig,
    last: Option<Drive>,
    hallway: Option<Hallway>,
    /// Where the last straight segment ended, so the next one on the same
    /// line measures from there rather than from where it was picked up.
    carry: Option<Pose>,
    goals: u32,
    log: NavLog,
    /// Distance driven so far by odometry, mm.
    odometer: f64,
    /// The speed set with Go, and what caps it.
    speed: Throttle,
    speedo: Speedometer,
    odometer_at: Option<Pose>,
    /// Poses by device time, from the base's state stream.
    track: Option<crate::track::PoseTrack>,
    /// A smoothed round trip of a drive command, seconds: how late a
    /// decision reaches the base, and so how far ahead to stop.
    rtt_s: f64,
    /// Why the robot gets nowhere on its goal, while it does.
    blocked: Option<String>,
    /// Why the last D goal ended off its line, when it did.
    off_line: Option<String>,
    /// A goal the Planner handed before the one at hand ended, which
    /// replaces it.
    handed: Option<Goal>,
    /// The goal at hand, for the Status written while the Navigator waits
    /// outside its loop ([`Navigator::beat`]).
    at_hand: Option<status::AtHand>,
    /// Near echoes of the last metre driven ([`NavConfig::remember_echoes`]).
    echoes: echoes::Echoes,
}

impl Navigator {
    /// A Navigator for a robot, talking to the Planner through `board`.
    pub fn new(robot: RobotClient, board: Board, cfg: NavConfig) -> Navigator {
        let speed = Throttle::new(cfg.cruise_mm_s);
        Navigator {
            robot,
            board,
            cfg,
            last: None,
            hallway: None,
            carry: None,
            goals: 0,
            log: NavLog::default(),
            odometer: 0.0,
            track: None,
            rtt_s: 0.0,
            blocked: None,
            off_line: None,
            odometer_at: None,
            speed,
            speedo: Speedometer::default(),
            handed: None,
            at_hand: None,
            echoes: echoes::Echoes::default(),
        }
    }

    /// What it has done so far.
    pub fn log(&self) -> &NavLog {
        &self.log
    }

    /// Takes goals from the Planner and carries them out, for ever (until
    /// a client call fails or the future is dropped).
    pub async fn run(&mut self) -> Result<(), NavError> {
        let (tx, _rx) = tokio::sync::mpsc::unbounded_channel();
        self.run_reporting(&tx).await
    }

    /// As [`Navigator::run`], sending the log after each goal.
    pub async fn run_reporting(
        &mut self,
        log: &tokio::sync::mpsc::UnboundedSender<NavLog>,
    ) -> Result<(), NavError> {
        self.board.declare().await?;
        let scans = self.robot.scans().await?;
        self.robot.set_bumper(self.cfg.stop_on_contact).await?;
        self.track = Some(crate::track::PoseTrack::start(&self.robot).await?);
        // A Navigator that died in the middle of a goal left it here: take
        // it up, measured from where it was started (the Planner is still
        // waiting for its $RobotStatus).
        let mut resume = match self.board.get::<Option<ActiveGoal>>(Var::GoalActive).await {
            Ok(active) => active,
            Err(e) if e.code() == Some(rome_schema::ErrorCode::UnknownVariable) => None,
            // Anyone may write the blackboard: what does not decode is no goal.
            Err(rome_client::ClientError::Decode(e)) => {
                tracing::warn!(error = %e, "navigator: GoalActive does not decode; ignored");
                None
            }
            Err(e) => return Err(e.into()),
        };
        if resume.is_some() && !self.planner_waits().await? {
            // Left from a run whose Planner has gone: not to be driven.
            tracing::info!("navigator: an unfinished goal was left, but no Planner waits for it");
            self.board.set(Var::GoalActive, &None::<ActiveGoal>).await?;
            resume = None;
        }
        loop {
            let (goal, start) = match (self.handed.take(), resume.take()) {
                (Some(goal), _) => (goal, None),
                (None, Some(active)) => {
                    tracing::info!(goal = ?active.goal, "navigator: taking up the goal left unfinished");
                    (active.goal, Some(active.start()))
                }
                (None, None) => match self.next_goal(&scans).await {
                    Ok(goal) => (goal, None),
                    Err(e) => {
                        self.goals += 1;
                        self.fail_goal(e).await?;
                        continue;
                    }
                },
            };
            self.goals += 1;
            self.off_line = None;
            self.at_hand = status::AtHand::for_goal(&goal);
            tracing::info!(?goal, n = self.goals, "navigator: goal");
            let done = if goal.goal_type == GoalType::V {
                self.ride(&goal, &scans).await
            } else {
                self.carry_out(&goal, start, &scans).await
            };
            if let Err(NavError::Superseded) = done {
                // No $RobotStatus for the goal left: the Planner that
                // handed the next one does not wait for it.
                tracing::info!("navigator: a new goal came before this one ended; it is left");
                continue;
            }
            if let Err(e) = done {
                self.fail_goal(e).await?;
                continue;
            }
            self.log.done[slot(goal.goal_type)] += 1;
            let _ = log.send(self.log.clone());
            // Cleared before the Planner hears the goal is done, so a
            // Navigator started after this never does it twice.
            self.board.set(Var::GoalActive, &None::<ActiveGoal>).await?;
            self.board.up(Sem::RobotStatus).await?;
        }
    }

    /// Whether a Planner waits on `$RobotStatus` (looked at for up to
    /// [`crate::board::PLANNER_PATIENCE`]).
    async fn planner_waits(&self) -> Result<bool, NavError> {
        let patience = crate::board::PLANNER_PATIENCE;
        Ok(self
            .board
            .someone_waits(&[Sem::RobotStatus], patience)
            .await?)
    }

    /// Waits for the Planner's next goal. A robot left moving (after an L
    /// or C goal) that gets none within [`NavConfig::idle_scans`] scans is
    /// stopped where it is: a Planner that died or waits for a passage
    /// must not leave it driving on.
    async fn next_goal(
        &mut self,
        scans: &rome_client::robot::Stream<Scan>,
    ) -> Result<Goal, NavError> {
        let board = self.board.clone();
        // A goal that does not decode still took $GoalData: the Planner
        // waits for its end, which `fail_goal` gives.
        let take = async {
            board.take_goal().await.map_err(|e| {
                NavError::reading("the goal (GoalType, GoalDistance, GoalDirection)", e)
            })
        };
        tokio::pin!(take);
        let mut idle = 0usize;
        loop {
            tokio::select! {
                biased;
                goal = &mut take => return goal,
                _ = self.next_scan(scans), if self.is_moving() => {
                    idle += 1;
                    if idle >= self.cfg.idle_scans {
                        tracing::info!("navigator: no goal; stopping the robot while it waits");
                        self.send(Drive::Halt).await?;
                        self.hallway = None;
                        // `carry` stays: the Planner's next D or E goal is
                        // measured from where the last segment ended, not
                        // from where the robot came to rest waiting for it
                        // (over a slow link that can be a metre on).
                    }
                }
            }
        }
    }

    /// The lights counted in this L segment. A read unanswered for
    /// [`NavConfig::blind_after`] stops the robot while it goes on; a read
    /// that fails stops the robot and ends the goal with the reason. Only
    /// a count not yet written reads as 0.
    async fn light_count(&mut self) -> Result<i64, NavError> {
        let board = self.board.clone();
        let read = board.get::<i64>(Var::CeilingLight);
        tokio::pin!(read);
        let got = tokio::select! {
            biased;
            got = &mut read => got,
            _ = rome_clock::sleep(self.cfg.blind_after) => {
                tracing::warn!("navigator: the light count goes unanswered; stopping the robot until it is read");
                self.send(Drive::Halt).await?;
                read.await
            }
        };
        match got {
            Ok(n) => Ok(n),
            Err(e) if e.code() == Some(rome_schema::ErrorCode::UnknownVariable) => Ok(0),
            Err(e) => {
                if let Err(stop) = self.send(Drive::Halt).await {
                    tracing::warn!(error = %stop, "navigator: could not stop the robot");
                }
                // Not a count: the CTracker may have written why it gave
                // the segment up instead.
                if let Ok(g) = board.get::<crate::board::GaveUp>(Var::CeilingLight).await {
                    return Err(NavError::SegmentGivenUp(g.failed));
                }
                Err(NavError::Unreadable {
                    what: "the ceiling-light count (CeilingLight)",
                    source: e,
                })
            }
        }
    }

    fn is_moving(&self) -> bool {
        !matches!(self.last, None | Some(Drive::Halt))
    }

    async fn send(&mut self, d: Drive) -> Result<(), NavError> {
        let stale = self.speed.stale() && matches!(d, Drive::Go(_) | Drive::Jog(_));
        if self.last == Some(d) && !matches!(d, Drive::Turn(_)) && !stale {
            return Ok(());
        }
        // Simulated time in a lock-step run, where the link costs nothing.
        let sent = rome_clock::Instant::now();
        // Commands sent, one round trip each.
        let trips = match d {
            Drive::Go(v) => {
                self.speed.wanted = v;
                self.speed.set = self.speed.target();
                self.robot.go(self.speed.set).await?;
                1
            }
            Drive::Jog(r) => {
                // A jog moves at the speed setting, which a spin or a halt
                // left at zero.
                let again = stale || matches!(self.last, None | Some(Drive::Spin(_) | Drive::Halt));
                if again {
                    self.speed.set = self.speed.target();
                    self.robot.go(self.speed.set).await?;
                }
                self.robot.jog(-r).await?;
                1 + u32::from(again)
            }
            Drive::Turn(deg) => {
                self.robot.turn(-deg, 45.0, -1.0).await?;
                1
            }
            Drive::Spin(r) => {
                self.robot.go(0.0).await?;
                self.robot.jog(-r).await?;
                2
            }
            Drive::Halt => {
                self.robot.stop(false).await?;
                1
            }
        };
        let rtt = (sent.elapsed().as_secs_f64() / f64::from(trips)).min(2.0);
        // A command that waited out a server restarting or a link cut says
        // nothing of the link: taken whole, a few of them would make the
        // stopping distance of a D goal longer than the goal, and the
        // goal would end where it began. A link truly slower is still
        // learnt, by at most 40 % a command.
        let rtt = rtt.min((3.0 * self.rtt_s).max(OUTAGE_S));
        self.rtt_s = if self.rtt_s == 0.0 {
            rtt
        } else {
            0.8 * self.rtt_s + 0.2 * rtt
        };
        self.last = Some(d);
        Ok(())
    }

    async fn next_scan(&self, scans: &rome_client::robot::Stream<Scan>) -> Result<Scan, NavError> {
        // The newest scan: steering by a backlog would steer by the past.
        match rome_clock::timeout(self.cfg.scan_timeout, scans.latest()).await {
            Ok(Some(scan)) => Ok(scan?),
            Ok(None) => Err(NavError::Gone("the proximity server's scan stream closed")),
            Err(_) => Err(NavError::Silent {
                what: "proximity server (no scan)",
                waited: self.cfg.scan_timeout,
            }),
        }
    }

    /// Waits until the base has finished an in-place turn, a move by a
    /// distance or a stop; the scan that showed it.
    async fn settle(&mut self, scans: &rome_client::robot::Stream<Scan>) -> Result<Scan, NavError> {
        for _ in 0..600 {
            let scan = self.next_scan(scans).await?;
            self.beat(scan.time_ms, || None).await?;
            if self.base_settled().await? {
                return Ok(scan);
            }
        }
        Err(NavError::Gone("the base never finished its turn"))
    }

    /// Whether the base has finished an in-place turn, a move by a
    /// distance or a stop (or is in Go mode at speed).
    async fn base_settled(&self) -> Result<bool, NavError> {
        let mode = self.robot.mode().await?;
        let speed = self.robot.wheel_speed().await?;
        let moving = ["point_turn", "point_go", "stopping"].contains(&mode.mode.as_str());
        Ok((!moving && speed.wheel_speed_mm_s < 5.0)
            || (mode.mode == "go" && speed.wheel_speed_mm_s > 5.0))
    }

    async fn carry_out(
        &mut self,
        goal: &Goal,
        resumed: Option<Pose>,
        scans: &rome_client::robot::Stream<Scan>,
    ) -> Result<(), NavError> {
        let mut scan = self.next_scan(scans).await?;
        let mut pose = self.pose_of(&scan).await?;
        self.hear_again(&pose, &mut scan);
        let start = match (resumed, goal.goal_type, self.carry) {
            (Some(p), _, _) => p,
            (None, GoalType::D | GoalType::E, Some(p)) => p,
            _ => pose,
        };
        self.board
            .set(Var::GoalActive, &Some(ActiveGoal::new(*goal, &start)))
            .await?;
        let corner = matches!(goal.goal_type, GoalType::C | GoalType::E);
        // Where the turning space's end wall stands, if the map has one: a
        // Planner that does not write it (or a value that does not decode)
        // leaves the estimate from the corridor's own width.
        let end_wall_mm = self
            .map_mm(goal, GoalType::E, Var::EndWall, |d: &i64| {
                (1..=100_000).contains(d)
            })
            .await;
        // Where the walls stand beside a D goal, in the map: only
        // distances a corridor can have.
        let goal_walls: Option<(i64, i64)> = self
            .map_mm(goal, GoalType::D, Var::GoalWalls, |(l, r)| {
                [l, r].iter().all(|d| (1..=10_000).contains(*d))
            })
            .await;
        // Where across the corridor a D goal lies, if well off the middle.
        let lane_mm = self
            .map_mm(goal, GoalType::D, Var::GoalLane, |d: &i64| {
                d.abs() <= 10_000
            })
            .await;
        let glass = self.glass(goal, &start).await;
        self.speed.cap = f64::INFINITY;
        if goal.goal_type == GoalType::C {
            // Leave the corner: stop, face the outgoing corridor, go.
            self.send(Drive::Halt).await?;
            self.settle(scans).await?;
            pose = self.pose().await?;
            let turn = normalize_deg(goal.direction_deg - pose.heading.deg());
            if turn.abs() > 2.0 {
                self.send(Drive::Turn(turn)).await?;
                self.settle(scans).await?;
            }
            self.last = None;
            self.send(Drive::Go(self.cfg.corner_mm_s)).await?;
            scan = self.next_scan(scans).await?;
            pose = self.pose().await?;
            glass::hear(&glass, &pose, &mut scan);
            self.hear_again(&pose, &mut scan);
        } else if self.hallway.is_none() || self.last.is_none() {
            self.last = None;
            self.send(Drive::Go(self.cfg.cruise_mm_s)).await?;
        }
        let hallway_start = scan.time_ms;
        let mut next_check = scan.time_ms + self.cfg.check_period_ms;
        let mut checked_at: Option<Pose> = None;
        let mut next_status = scan.time_ms;
        // A goal taken up again may already have its count: the count seen
        // belongs to this segment.
        let mut counted_low = resumed.is_some();
        let mut walls = Walls::default();
        // The last pose and its time, to tell how fast the robot goes.
        let mut moved: Option<(u64, Pose)> = None;
        // Scans in a row on which a robot told to drive stood still.
        let mut still_scans = 0u32;
        let mut headway: Option<Headway> = None;
        let mut oncoming = Oncoming::default();
        // Whether the last scan was driven keeping right for someone met.
        let mut passing = false;
        loop {
            // The goal function: progress along the goal direction, so a
            // robot that swerves round another does not count the swerve.
            let axis = rome_maps::geometry::direction(goal.direction_deg);
            let travelled = (pose.at.x - start.at.x) * axis.x + (pose.at.y - start.at.y) * axis.y;
            // The speed asked for, or less while the robot is still
            // speeding up to it (a short leg from a standstill would
            // otherwise stop at once, braking from a speed never reached):
            // what it drove since the last scan, and what it can gain
            // before the next.
            let asked = self.robot_speed();
            let speed = match moved {
                Some((t0, p0)) if scan.time_ms > t0 => {
                    let dt = (scan.time_ms - t0) as f64 / 1_000.0;
                    let measured = pose.dist(&p0) / dt;
                    asked.min(measured + self.cfg.stop_accel_mm_s2 * dt)
                }
                _ => asked,
            };
            let step_mm = moved.map_or(f64::INFINITY, |(_, p0)| pose.dist(&p0));
            moved = Some((scan.time_ms, pose));
            // Braking distance, and what is driven while the pose and the
            // stop travel the link (a real robot runs at real time, so the
            // round trip in seconds is the robot's seconds).
            let stopping = speed * speed / (2.0 * self.cfg.stop_accel_mm_s2) + speed * self.rtt_s;
            let done = match goal.goal_type {
                GoalType::L => {
                    let n = self.light_count().await?;
                    // Armed once the count of this segment has been seen
                    // below the goal, so a count left from the segment
                    // before cannot end this one.
                    counted_low |= n < goal.distance;
                    counted_low && n >= goal.distance
                }
                GoalType::D => {
                    let stand = self.cfg.stand_when_blocked && self.blocked.is_some();
                    let short = goal.distance as f64 - travelled;
                    travelled + stopping >= goal.distance as f64
                        || (stand && blocked::ends_here(short))
                }
                // A robot that keeps right while it leaves a corner has
                // left it once it heads down the corridor again, not while
                // it swerves.
                GoalType::C => {
                    let off = normalize_deg(goal.direction_deg - pose.heading.deg());
                    travelled >= goal.distance as f64
                        && !(passing && off.abs() > LEFT_CORNER_SWERVE_DEG)
                }
                // A ride is not driven here ([`Navigator::ride`]).
                GoalType::V => travelled >= goal.distance as f64,
                GoalType::E => {
                    let ahead = f64::from(
                        scan.sonar_mm[sonar_towards(goal.direction_deg - pose.heading.deg())],
                    );
                    let remaining = goal.distance as f64 - travelled;
                    let near = match end_wall_mm {
                        // The middle is where the map puts it from the end
                        // wall: stop so as to come to rest there (sonar
                        // ranges start at the ring, a radius out).
                        Some(d) => ahead + ROBOT_RADIUS_MM - stopping <= d as f64,
                        // Else the end wall stands about half a hallway
                        // beyond the middle.
                        None => ahead < walls.width().map_or(1_200.0, |w| w / 2.0 + 300.0),
                    };
                    travelled + stopping >= goal.distance as f64 || (near && remaining < 1_200.0)
                }
            };
            if done {
                break;
            }
            // Turning in a corner makes no headway by design.
            let blocked = if corner {
                None
            } else {
                headway
                    .get_or_insert_with(|| Headway::new(scan.time_ms, travelled))
                    .update(
                        scan.time_ms,
                        travelled,
                        &scan.sonar_mm,
                        normalize_deg(goal.direction_deg - pose.heading.deg()),
                    )
            };
            if let (Some(why), None) = (&blocked, &self.blocked) {
                tracing::warn!("navigator: {why}");
            }
            self.blocked = blocked;
            // Beyond the thesis: driving up a corridor to a corner, or out
            // of a turning space into the next corridor, a robot met
            // head-on keeps right as in a hallway, by the Center-Hallway
            // state, until it has passed. The Corner state has no
            // keep-right, and its infrared stop-and-go would see the near
            // wall of a narrow corridor once the robot is over; leaving a
            // corner, it would spin away from the oncoming robot until
            // clear, round to the way it came.
            let remaining = goal.distance as f64 - travelled;
            // A Leave-Corner goal ends a few metres into a corridor that
            // goes on: what stands beyond its end is not an end wall.
            let room = if goal.goal_type == GoalType::C {
                f64::INFINITY
            } else {
                remaining
            };
            passing = match goal.goal_type {
                GoalType::E => self.cfg.corner_keep_right && remaining > ENTER_PASSING_MM,
                GoalType::C => self.cfg.leave_corner_keep_right,
                _ => false,
            } && oncoming.watch(&scan.sonar_mm, self.odometer, room);
            // The state.
            let drive = if passing {
                let hallway = self
                    .hallway
                    .get_or_insert_with(|| Hallway::new(hallway_start));
                hallway.room_mm = room;
                hallway.lane_mm = 0.0;
                hallway.oncoming = oncoming.clone();
                // At the Corner state's speed: the E goal's end is judged
                // for it, and a swerve at cruising speed carries the robot
                // past the turning space.
                let cfg = NavConfig {
                    cruise_mm_s: self.cfg.corner_mm_s.min(self.cfg.cruise_mm_s),
                    ..self.cfg.clone()
                };
                hallway.step(
                    &cfg,
                    &scan.sonar_mm,
                    pose.heading.deg(),
                    goal.direction_deg,
                    self.odometer,
                    scan.time_ms,
                )
            } else if corner {
                corner_step(
                    &self.cfg,
                    &scan,
                    pose.heading.deg(),
                    goal.direction_deg,
                    &mut walls,
                    self.odometer,
                )
            } else {
                let hallway = self
                    .hallway
                    .get_or_insert_with(|| Hallway::new(hallway_start));
                hallway.room_mm = match goal.goal_type {
                    GoalType::L => f64::INFINITY,
                    _ => goal.distance as f64 - travelled,
                };
                // The goal's own line, over the last metres to it.
                hallway.lane_mm = match lane_mm {
                    Some(l) if hallway.room_mm < LANE_APPROACH_MM => l as f64,
                    _ => 0.0,
                };
                hallway.step(
                    &self.cfg,
                    &scan.sonar_mm,
                    pose.heading.deg(),
                    goal.direction_deg,
                    self.odometer,
                    scan.time_ms,
                )
            };
            let drive = self.felt(drive, &scan, corner && !passing);
            let drive = if self.cfg.stand_when_blocked && self.blocked.is_some() {
                let rel = normalize_deg(goal.direction_deg - pose.heading.deg());
                blocked::instead(drive, &scan.sonar_mm, rel)
            } else {
                drive
            };
            tracing::debug!(
                t = scan.time_ms,
                x = pose.at.x,
                y = pose.at.y,
                heading = pose.heading.deg(),
                left = scan.sonar_mm[18],
                right = scan.sonar_mm[6],
                ?drive,
                "navigator: step"
            );
            self.speed.cap = if self.cfg.brake_for_ahead && (passing || !corner) {
                let late = reaction_s(self.rtt_s);
                ahead_speed_cap(&scan.sonar_mm, self.cfg.stop_accel_mm_s2, late)
            } else {
                f64::INFINITY
            };
            if let Drive::Turn(_) = drive {
                self.log.turns += 1;
                let (v, a) = (self.speedo.mm_s(), self.cfg.stop_accel_mm_s2);
                if self.cfg.stop_short_to_turn && stops_short(&scan.sonar_mm, v, a, self.rtt_s) {
                    // Stopped, then told to go again: the turn brakes from
                    // nothing and takes the Go up after, as every safety
                    // turn does, so a robot wedged by a corner still edges on.
                    self.robot.stop(true).await?;
                    self.robot.go(self.speed.set).await?;
                }
                self.send(drive).await?;
                self.settle(scans).await?;
                self.last = None;
            } else {
                self.send(drive).await?;
            }
            // Told to drive and standing still: the base may have stopped
            // itself on a touch. Check-Bumper runs now rather than at the
            // next check, and the drive is sent again if nothing touches.
            let driving = self.cfg.stop_on_contact
                && match self.last {
                    Some(Drive::Go(v)) => v > 50.0,
                    Some(Drive::Jog(_)) => true,
                    _ => false,
                };
            still_scans = if driving && step_mm < 1.0 {
                still_scans + 1
            } else {
                0
            };
            if still_scans >= STILL_SCANS {
                still_scans = 0;
                if !self.check_bumper(&pose, goal, &scan, scans).await? {
                    self.last = None;
                }
            }
            // The timers: Check-Bumper and Check-Goal.
            if scan.time_ms >= next_check {
                next_check = scan.time_ms + self.cfg.check_period_ms;
                // Told to drive but standing still since the last check: the
                // base may have been stopped by its deadman (this client's
                // link dropped for longer than its lease, a router
                // restarted). The next step sends its drive again.
                let still = checked_at.is_some_and(|p: Pose| pose.dist(&p) < 50.0);
                if still && matches!(self.last, Some(Drive::Go(_) | Drive::Jog(_))) {
                    tracing::info!(
                        "navigator: standing still while driving; sending the drive again"
                    );
                    self.last = None;
                }
                checked_at = Some(pose);
                self.goal_handed_meanwhile().await?;
                let _ = self.check_bumper(&pose, goal, &scan, scans).await?;
                // Between two walls the walls are the better compass:
                // Check-Goal only steps in when they are out of sight.
                let walls_seen = if corner {
                    walls.fit().is_some()
                } else {
                    self.hallway
                        .as_ref()
                        .is_some_and(|h| h.walls.fit().is_some())
                };
                if !walls_seen {
                    self.check_goal(&pose, goal, corner).await?;
                }
            }
            if scan.time_ms >= next_status {
                next_status = scan.time_ms + 1_000;
                self.publish(goal, &pose, corner).await?;
            }
            scan = self.next_scan(scans).await?;
            pose = self.pose_of(&scan).await?;
            glass::hear(&glass, &pose, &mut scan);
            self.hear_again(&pose, &mut scan);
        }
        self.speed.cap = f64::INFINITY;
        self.carry = None;
        self.blocked = None;
        match goal.goal_type {
            GoalType::L => self.carry = Some(self.after_count(goal, pose).await),
            GoalType::E => {
                self.send(Drive::Halt).await?;
                self.settle(scans).await?;
                self.hallway = None;
            }
            GoalType::D => {
                self.send(Drive::Halt).await?;
                let at_rest = self.settle(scans).await?;
                let step = self.cfg.onto_line && goal.distance > 0;
                if let Some((left, right)) = goal_walls.filter(|_| step) {
                    self.off_line =
                        (self.onto_line(scans, at_rest, goal, left as f64, right as f64)).await?;
                }
                self.hallway = None;
            }
            GoalType::C | GoalType::V => {}
        }
        self.publish(goal, &pose, corner).await?;
        Ok(())
    }

    /// Distances the Planner took from the map for goals of type `kind`
    /// (`EndWall`, `GoalLane`, `GoalWalls`): `None` for other goals, when
    /// it wrote none, or when what is there does not decode or is not
    /// `sane` (anyone may write the blackboard).
    async fn map_mm<T: serde::de::DeserializeOwned>(
        &self,
        goal: &Goal,
        kind: GoalType,
        var: Var,
        sane: impl Fn(&T) -> bool,
    ) -> Option<T> {
        if goal.goal_type != kind {
            return None;
        }
        let value: Option<T> = self.board.get(var).await.ok().flatten();
        value.filter(|d| sane(d))
    }
}

pub mod blocked;
mod echoes;
mod glass;
mod infrared;
mod odometer;
mod recover;
mod ride;
mod status;
#[cfg(test)]
mod tests;
