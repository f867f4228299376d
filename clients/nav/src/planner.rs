//! The Path Planner as a client (§5.3, §5.8): puts the robot down at the
//! start, then hands the plan's goals to the Navigator one at a time.
//!
//! For each goal it writes GoalType, GoalDistance and GoalDirection and
//! signals `$GoalData`, then waits on `$RobotStatus` before the next. An L
//! segment also gets LightOffset and `$TrackData` (for the CTracker) and
//! `$StartMap` (for the local mapper); after it the Planner waits on
//! `$EndLMode` and takes the CTracker's `Overshoot` off the dead-reckoning
//! distance that follows: the overshoot compensation of Chapter 6.
//!
//! Traffic ([`crate::traffic`]): before the junctions, narrow passages
//! and lanes of the route (a chain of them between two stretches of plain
//! corridor) the Planner takes their semaphores with undo waits, in the
//! order of their names (a junction or passage alone, a lane one way
//! among others going that way), and gives each back once the robot has
//! left it:
//! robots take turns and never wait for each other in a circle, and a
//! robot whose Planner dies inside does not close them, because the data
//! server takes the units back when the Planner's liveliness goes. If a
//! part is busy, the robot is first stopped where it is (a D goal of no
//! distance), so it does not drive on while it waits. What it holds and
//! waits for is on its blackboard (`Traffic`).
//!
//! Each goal done is judged by what happened ([`crate::report::judge_step`]):
//! the CTracker's `TrackLog` for an L segment, and, where a simulator
//! answers, the robot's ground truth for C and D segments.

use crate::board::{Board, Corridor, Goal, GoalType, Sem, Var};
use crate::plan::{Plan, Step};
use crate::report::judge_step;
pub use crate::report::Handed;
use crate::traffic::lanes::{Lane, LANE_CAPACITY};
use crate::traffic::{chains, Chain, TrafficState};
use crate::NavError;
use rome_client::sim::TruthClient;
use rome_client::RobotClient;

/// What the Planner tells whoever watches.
#[derive(Debug, Clone, Copy)]
pub enum Progress<'a> {
    /// A goal was handed to the Navigator.
    Handed(&'a Handed),
    /// The Navigator reported it done, and it was judged.
    Done(&'a Handed),
    /// The robot waits for a junction or narrow passage to be free (its
    /// semaphore; [`crate::traffic::describe`] names it).
    Waiting(&'a str),
    /// The robot holds a junction or narrow passage (`true`) or has given
    /// it back.
    Holding(&'a str, bool),
}

/// Registers the robot at the plan's start: odometry reads the map's
/// coordinates and the robot's heading, and the robot is turned onto the
/// route in place if it faces elsewhere. `facing` is that heading if known
/// (the thesis gives the robot its true heading at the start, §5); without
/// it the base's own odometry heading is taken as the way the robot faces.
pub async fn put_down(
    robot: &RobotClient,
    plan: &Plan,
    facing: Option<f64>,
) -> Result<(), NavError> {
    let (start, _) = plan.ends();
    let facing = match facing {
        Some(f) => f,
        None => robot.pose().await?.heading_deg,
    };
    if !facing.is_finite() {
        return Err(NavError::Config(format!(
            "the start heading must be a number of degrees, got {facing}"
        )));
    }
    robot
        .set_pose(start.x.round() as i64, start.y.round() as i64, facing)
        .await?;
    turn_onto(robot, plan, facing).await
}

/// Turns the robot in place onto the plan's first heading, if it faces
/// elsewhere (`facing`, in the map's frame): for a robot registered
/// already, such as one that arrived at the start of its next task.
pub async fn turn_onto(robot: &RobotClient, plan: &Plan, facing: f64) -> Result<(), NavError> {
    turn_to(robot, plan.start_heading_deg, facing).await
}

/// Turns the robot in place to `heading_deg` if it faces elsewhere
/// (`facing`, in the map's frame), and waits until the turn is done.
pub async fn turn_to(robot: &RobotClient, heading_deg: f64, facing: f64) -> Result<(), NavError> {
    let turn = rome_maps::geometry::normalize_deg(heading_deg - facing);
    if turn.abs() > 1.0 {
        // Positive turns are clockwise on the base.
        robot.turn(-turn, 45.0, -1.0).await?;
        while robot.mode().await?.mode == "point_turn" {
            rome_clock::sleep(std::time::Duration::from_millis(50)).await;
        }
    }
    Ok(())
}

/// Hands every goal of the plan to the Navigator and judges each when it is
/// done (with ground truth from `truth`, if given); `progress` hears of
/// each goal as it is handed over and as it is done.
pub async fn run(
    board: &Board,
    plan: &Plan,
    truth: Option<&TruthClient>,
    mut progress: impl FnMut(Progress<'_>),
) -> Result<Vec<Handed>, NavError> {
    board.declare().await?;
    // A new run: no goal of an earlier one is to be taken up.
    board
        .set(Var::GoalActive, &None::<crate::board::ActiveGoal>)
        .await?;
    board
        .set(Var::Route, &crate::board::RouteInfo::of(plan))
        .await?;
    let mut out = Vec::with_capacity(plan.steps.len());
    let mut overshoot = 0i64;
    // Whether `Glass` holds panes from an earlier goal.
    let mut glass_left = true;
    let chains = chains(&plan.holds);
    let mut traffic = TrafficState::default();
    board.set(Var::Traffic, &traffic).await?;
    for (index, step) in plan.steps.iter().enumerate() {
        for chain in chains.iter().filter(|c| c.first == index) {
            take(board, chain, step, index > 0, &mut traffic, &mut progress).await?;
        }
        let mut step = step.clone();
        let mut handed_overshoot = None;
        match step.goal.goal_type {
            GoalType::L => {
                board.set(Var::LightOffset, &step.light_offsets_mm).await?;
                board.set(Var::Corridor, &Corridor::of(&step)).await?;
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
                if step.goal.goal_type == GoalType::E {
                    let end = step.end_wall_mm.map(|d| d.round() as i64);
                    board.set(Var::EndWall, &end).await?;
                } else {
                    let lane = step.lane_mm().map(|d| d.round() as i64);
                    board.set(Var::GoalLane, &lane).await?;
                    let walls = step
                        .goal_walls_mm
                        .map(|(l, r)| (l.round() as i64, r.round() as i64));
                    board.set(Var::GoalWalls, &walls).await?;
                }
            }
            GoalType::C => {}
            GoalType::V => board.set(Var::Ride, &step.ride).await?,
        }
        if matches!(step.goal.goal_type, GoalType::E | GoalType::C | GoalType::D) {
            // Written only near glass, and once after to clear it: a map
            // without glass costs no request.
            let glass = step.glass_mm(&plan.glass);
            if !glass.is_empty() || glass_left {
                board.set(Var::Glass, &glass).await?;
                glass_left = !glass.is_empty();
            }
        }
        let stretch = matches!(step.goal.goal_type, GoalType::D | GoalType::E)
            && step.goal.distance >= crate::plan::MAP_STRETCH_MM;
        if stretch {
            board.set(Var::Corridor, &Corridor::of(&step)).await?;
        }
        board.give_goal(&step.goal).await?;
        if stretch {
            // After the goal, so the mapper reads this stretch's distance
            // and direction.
            board.up(Sem::StartMap).await?;
        }
        let mut handed = Handed::new(index, &step);
        progress(Progress::Handed(&handed));
        await_status(board).await?;
        // The Navigator ended the goal on a bad value: the run ends here,
        // with its reason (a Status that does not decode says nothing).
        let ended = failed(board).await;
        if step.goal.goal_type == GoalType::L && ended.is_none() {
            // The CTracker closes the segment as the count is reached.
            await_while(board, Sem::EndLMode, NAVIGATOR_SILENCE, "CTracker (the light segment was not closed after the Navigator ended it; is `rome ctracker` running?)", || async { 0 })
                .await?;
            overshoot = board.get(Var::Overshoot).await?;
            handed_overshoot = Some(overshoot);
            handed.track = board.get(Var::TrackLog).await.ok();
        }
        handed.overshoot_mm = handed_overshoot;
        if let Some(t) = truth {
            // Ground truth judges the goal; a simulator that does not
            // answer leaves C and D unjudged rather than failing the run.
            handed.truth = t.get().await.ok();
        }
        handed.failure = ended
            .clone()
            .or_else(|| judge_step(&step, handed.truth.as_ref(), handed.track.as_ref()));
        progress(Progress::Done(&handed));
        out.push(handed);
        if ended.is_some() {
            give_back_all(board).await?;
            break;
        }
        for chain in chains
            .iter()
            .filter(|c| (c.first..=c.last).contains(&index))
        {
            for h in chain.holds.iter().filter(|h| h.last == index) {
                board.client().give_back(&h.semaphore).await?;
                traffic.holds.retain(|s| s != &h.semaphore);
                board.set(Var::Traffic, &traffic).await?;
                progress(Progress::Holding(&h.semaphore, false));
            }
        }
    }
    Ok(out)
}

/// Gives back every junction and passage the robot still holds (as its
/// blackboard's `Traffic` says): for a run that ended before its last step,
/// failed or given up, so that others are not kept waiting for a robot
/// that no longer drives. Must be called with the Planner's own client,
/// whose undo units they are.
pub async fn give_back_all(board: &Board) -> Result<(), NavError> {
    let traffic: TrafficState = match board.get(Var::Traffic).await {
        Ok(t) => t,
        // Never written: the run never got to its traffic.
        Err(_) => return Ok(()),
    };
    let ds = board.client();
    let lane_drained = traffic.draining.iter().map(|sem| (sem, LANE_CAPACITY));
    for (sem, units) in traffic.holds.iter().map(|s| (s, 1)).chain(lane_drained) {
        match ds.give_back_units(sem, units).await {
            Ok(_) => {}
            // Given back already, just before the blackboard was written.
            Err(e) if e.code() == Some(rome_schema::ErrorCode::Conflict) => {}
            Err(e) => return Err(e.into()),
        }
    }
    board.set(Var::Traffic, &TrafficState::default()).await?;
    Ok(())
}

/// How long [`stop_navigator`] waits for the Navigator to take its stop:
/// a driving Navigator looks for a new goal at its Check-Goal (every 3–5
/// s of robot time), then brakes.
const STOP_PATIENCE: std::time::Duration = std::time::Duration::from_secs(15);
/// How long after that it waits for a second `$RobotStatus`: the goal
/// left may have ended on its own just before the stop was taken.
const STOP_SETTLE: std::time::Duration = std::time::Duration::from_secs(3);

/// Stops the Navigator on the goal it is on, for a run that ended before
/// its last goal (given up as blocked, cancelled, overdue): a D goal of
/// no distance is handed, which the Navigator takes in place of the goal
/// at hand ([`Board::goal_handed_meanwhile`]), or at once if it is idle.
/// Without it, the Navigator of a run given up drives on to a goal nobody
/// follows, into the robots that go on, and the `$RobotStatus` it ends
/// with would end the next run's first goal. Every `$RobotStatus` the
/// Navigator gives meanwhile is taken, so the next run starts even.
/// Returns whether the Navigator answered.
pub async fn stop_navigator(board: &Board, robot: &RobotClient) -> Result<bool, NavError> {
    let heading = robot.pose().await?.heading_deg;
    board
        .give_goal(&Goal {
            goal_type: GoalType::D,
            distance: 0,
            direction_deg: if heading.is_finite() { heading } else { 0.0 },
        })
        .await?;
    let ds = board.client();
    let sem = board.sem_name(Sem::RobotStatus);
    if !ds.wait_timeout(&sem, STOP_PATIENCE).await? {
        return Ok(false);
    }
    while ds.wait_timeout(&sem, STOP_SETTLE).await? {}
    Ok(true)
}

/// How far from the right wall a robot between tasks stands, mm, from its
/// middle: its radius and 0.15 m.
pub const ASIDE_FROM_WALL_MM: f64 = crate::drive::ROBOT_RADIUS_MM + 150.0;

/// Moves a robot that stands where its last D goal ended (heading
/// `direction_deg`, the walls `walls` = (left, right) mm from its line, as
/// the map has them) over to the corridor's right wall. A robot between
/// tasks otherwise stands on the middle of the corridor, where in a 2.44 m
/// corridor no other robot can pass it without a touch. It is the
/// Navigator's sideways step onto a goal's line (`GoalWalls`), on a goal
/// of 1 mm whose line lies 0.53 m (its radius and 0.15 m) from the right wall;
/// the Navigator checks the walls against the map and watches for anyone
/// in the way as it steps. `Some` says why the Navigator ended the goal
/// instead, or why it ended it off the line (`Status::off_line`: someone
/// stood beside it, or in the way of the step).
///
/// The Navigator measures across the hallway from the way the robot faces
/// (`facing_deg`, odometry): one that faces against the leg steps to the
/// same wall, given as the wall on its left.
pub async fn step_aside(
    board: &Board,
    direction_deg: f64,
    (left, right): (f64, f64),
    facing_deg: f64,
) -> Result<Option<String>, NavError> {
    if right <= ASIDE_FROM_WALL_MM {
        return Ok(None);
    }
    let far = left + right - ASIDE_FROM_WALL_MM;
    let (direction_deg, walls) =
        if rome_maps::geometry::normalize_deg(direction_deg - facing_deg).abs() > 90.0 {
            (
                rome_maps::geometry::normalize_deg(direction_deg + 180.0),
                (ASIDE_FROM_WALL_MM, far),
            )
        } else {
            (direction_deg, (far, ASIDE_FROM_WALL_MM))
        };
    if let Some(why) = d_goal_on_line(board, direction_deg, 1.0, walls).await? {
        return Ok(Some(why));
    }
    Ok(board
        .get::<crate::board::Status>(Var::Status)
        .await
        .ok()
        .and_then(|s| s.off_line))
}

/// Drives a robot that stands with no walls beside it (a junction, a
/// corridor's mouth) `distance_mm` along `direction_deg` into the corridor
/// there, on its middle line (`walls` = (left, right) mm from that line
/// where it ends), so that it can step aside there ([`step_aside`]). `Some`
/// says why the Navigator ended the goal instead.
pub async fn step_out(
    board: &Board,
    direction_deg: f64,
    distance_mm: f64,
    walls: (f64, f64),
) -> Result<Option<String>, NavError> {
    d_goal_on_line(board, direction_deg, distance_mm, walls).await
}

/// Hands the Navigator a D goal of `distance_mm` along `direction_deg`
/// whose line lies `(left, right)` mm from the walls (`GoalWalls`, no
/// lane), and waits for it to end: `Some` says why the Navigator ended it
/// short.
async fn d_goal_on_line(
    board: &Board,
    direction_deg: f64,
    distance_mm: f64,
    (left, right): (f64, f64),
) -> Result<Option<String>, NavError> {
    board.set(Var::GoalLane, &None::<i64>).await?;
    let walls = (left.round() as i64, right.round() as i64);
    board.set(Var::GoalWalls, &Some(walls)).await?;
    board
        .give_goal(&Goal {
            goal_type: GoalType::D,
            distance: distance_mm.round() as i64,
            direction_deg,
        })
        .await?;
    await_status(board).await?;
    Ok(failed(board).await)
}

/// Waits on `$RobotStatus`: the Navigator is done with the goal. The
/// Navigator writes its Status every second of robot time while it works
/// on a goal: silence means it died with the goal.
pub(crate) async fn await_status(board: &Board) -> Result<(), NavError> {
    let status = board.var_name(Var::Status);
    let ds = board.client();
    await_while(
        board,
        Sem::RobotStatus,
        NAVIGATOR_SILENCE,
        "Navigator (no Status written while it has a goal; is `rome navigator` running?)",
        || async { ds.history(&status).await.map_or(0, |h| h.seq) },
    )
    .await
}

/// Why the Navigator ended the goal it was given, if it did, from its
/// Status: the run ends there, with that reason (a Status that does not
/// decode says nothing).
pub(crate) async fn failed(board: &Board) -> Option<String> {
    board
        .get::<crate::board::Status>(Var::Status)
        .await
        .ok()
        .and_then(|s| s.failed)
}

/// How long the Planner waits for a sign of life from the Navigator (a new
/// Status) or the CTracker before it gives the run up as failed, wall time.
pub const NAVIGATOR_SILENCE: std::time::Duration = std::time::Duration::from_secs(30);

/// down(`sem`), failing with [`NavError::Silent`] naming `what` if
/// `progress` (a counter the other side moves) stands still for `silence`.
async fn await_while<F, Fut>(
    board: &Board,
    sem: Sem,
    silence: std::time::Duration,
    what: &'static str,
    progress: F,
) -> Result<(), NavError>
where
    F: Fn() -> Fut,
    Fut: std::future::Future<Output = u64>,
{
    let name = board.sem_name(sem);
    let mut seen = progress().await;
    let mut since = rome_clock::Instant::now();
    loop {
        let slice = silence.min(std::time::Duration::from_secs(2));
        match board.client().wait_timeout(&name, slice).await {
            Ok(true) => return Ok(()),
            Ok(false) => {}
            // The data server did not answer the slice's end (down, or
            // starting again): the wait has given its place up by itself
            // (a unit that reached it goes back), and the next slice waits
            // anew. How long this may go on is the silence's to say:
            // `progress` stands still while the server cannot be read.
            Err(e @ rome_client::ClientError::NoReply { .. }) => {
                tracing::warn!(error = %e, "waiting on {name}: the data server did not answer; waiting again");
            }
            Err(e) => return Err(e.into()),
        }
        let now = progress().await;
        if now != seen {
            (seen, since) = (now, rome_clock::Instant::now());
        } else if since.elapsed() >= silence {
            return Err(NavError::Silent {
                what,
                waited: since.elapsed(),
            });
        }
    }
}

/// Takes every part of `chain` before `step`, in the order of their
/// names; a robot that may be moving (`moving`) is stopped first if it has
/// to wait.
async fn take(
    board: &Board,
    chain: &Chain,
    step: &Step,
    moving: bool,
    traffic: &mut TrafficState,
    progress: &mut impl FnMut(Progress<'_>),
) -> Result<(), NavError> {
    let ds = board.client();
    let mut waiting = Waiting {
        board,
        step,
        stopped: !moving,
    };
    for hold in &chain.holds {
        let sem = &hold.semaphore;
        if let Some(lane) = Lane::of(sem) {
            take_lane(&lane, &mut waiting, traffic, progress).await?;
        } else {
            ds.create_semaphore(sem, 1).await?;
            // Free: taken at once (the common case, and one a lock-step
            // clock waits for). Busy: the robot stops and waits in the queue.
            if !ds.try_wait_undo(sem).await? {
                waiting.begin(sem, traffic, progress).await?;
                ds.wait_undo(sem).await?;
            }
        }
        traffic.waits_for = None;
        traffic.holds.push(sem.clone());
        board.set(Var::Traffic, &*traffic).await?;
        progress(Progress::Holding(sem, true));
    }
    Ok(())
}

/// A robot about to wait for a part of the building.
struct Waiting<'a> {
    board: &'a Board,
    step: &'a Step,
    stopped: bool,
}

impl Waiting<'_> {
    /// Says what the robot waits for, and stops it if it may be moving.
    async fn begin(
        &mut self,
        sem: &str,
        traffic: &mut TrafficState,
        progress: &mut impl FnMut(Progress<'_>),
    ) -> Result<(), NavError> {
        // Said once for a part, though a lane may be waited for twice (its
        // gate, then the other way emptying); the blackboard is written
        // each time, so what a lane drains is on it.
        if traffic.waits_for.as_deref() != Some(sem) {
            progress(Progress::Waiting(sem));
        }
        traffic.waits_for = Some(sem.to_string());
        self.board.set(Var::Traffic, &*traffic).await?;
        if !self.stopped {
            self.board
                .give_goal(&Goal {
                    goal_type: GoalType::D,
                    distance: 0,
                    direction_deg: self.step.goal.direction_deg,
                })
                .await?;
            self.board.down(Sem::RobotStatus).await?;
            self.stopped = true;
        }
        Ok(())
    }
}

/// Takes a unit of `lane`'s way ([`crate::traffic::lanes`]): through its
/// gate, once nobody drives it the other way.
async fn take_lane(
    lane: &Lane,
    waiting: &mut Waiting<'_>,
    traffic: &mut TrafficState,
    progress: &mut impl FnMut(Progress<'_>),
) -> Result<(), NavError> {
    let ds = waiting.board.client();
    ds.create_semaphore(&lane.gate, 1).await?;
    ds.create_semaphore(&lane.way, LANE_CAPACITY).await?;
    ds.create_semaphore(&lane.other, LANE_CAPACITY).await?;
    if !ds.try_wait_undo(&lane.gate).await? {
        waiting.begin(&lane.way, traffic, progress).await?;
        ds.wait_undo(&lane.gate).await?;
    }
    // Held now: a run that ends from here on gives it back.
    traffic.holds.push(lane.gate.clone());
    // Only a robot holding the gate takes a unit of either way, so once the
    // other way is empty nobody enters it until the gate is given back.
    if ds.semaphore(&lane.other).await?.value < LANE_CAPACITY {
        traffic.draining = Some(lane.other.clone());
        waiting.begin(&lane.way, traffic, progress).await?;
        ds.wait_undo_units(&lane.other, LANE_CAPACITY).await?;
        ds.give_back_units(&lane.other, LANE_CAPACITY).await?;
        traffic.draining = None;
    }
    if !ds.try_wait_undo(&lane.way).await? {
        // More robots than the lane's capacity one way: rarer than rare.
        waiting.begin(&lane.way, traffic, progress).await?;
        ds.wait_undo(&lane.way).await?;
    }
    ds.give_back(&lane.gate).await?;
    traffic.holds.retain(|s| s != &lane.gate);
    Ok(())
}
