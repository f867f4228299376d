//! A robot's Planner taking its goals from the dispatcher
//! (`rome planner --tasks`): it says where it stands on `nav/<robot>/Duty`,
//! waits on `$nav/<robot>/Task`, plans from where it stands to the task's
//! goal, drives there as [`crate::planner::run`] does, and reports how it
//! went.
//!
//! A robot without a task (at its start, where its last task ended, or
//! where a task stopped short) that is given none within
//! [`DutyConfig::aside_after`] steps over to the corridor's right wall, out
//! of the others' way ([`planner::step_aside`]; which wall: [`super::aside`]).
//! Where the map gives no wall beside it (a task's goal in a junction), it
//! can first drive on into a corridor ([`planner::step_out`]; `leave_open`
//! of [`crate::traffic::Rules`]), as it would otherwise stand where every
//! robot turning there drives.
//!
//! A task that cannot be planned fails and the robot stays where it is.
//! A run that fails or is cancelled midway stops the robot away from any
//! position the map names: it reports where its odometry puts it
//! (`@x,y` in metres, and `at_mm`), and its next task is planned from
//! there. A robot whose odometry cannot be read, or that is overdue twice
//! running, is `lost`, taking no more tasks until it is started again with
//! `--from`. A robot blocked twice in one place is `lost` too, but only for
//! a rest: then it drives itself clear to a position of the map
//! ([`super::clear::clear_to`]) and takes tasks again, or rests twice as long and tries
//! another position. Left standing for good, such robots become the very
//! knots that block the next ones. A robot held up with a task asks the
//! nearest idle robot standing in its way to drive on, and an idle robot
//! asked does ([`super::way`]). A value on the blackboard that does not
//! decode is reported and skipped; it never ends the Planner.

use super::aside::{
    corridor_axis, leg_at, reversed, start_leg, step_aside, stood_aside, way_out, LastLeg,
    OUT_STEP_MM,
};
use super::clear::{clear_to, CLEAR_NEAR_MM};
use super::schema::{
    decode, duty_var, task_sem, task_var, Assignment, Duty, DutyState, Outcome, WAKE,
};
use crate::board::Board;
use crate::plan::Plan;
use crate::planner::{self, Progress};
use crate::traffic::Rules;
use crate::NavError;
use rome_client::sim::TruthClient;
use rome_client::RobotClient;
use rome_maps::geometry::Point;
use rome_maps::{Network, World};
use std::time::Duration;

/// How a task given up because the robot stood still begins its reason.
pub const BLOCKED: &str = "blocked";

/// How a task given up because it took far too long begins its reason.
pub const OVERDUE: &str = "overdue";

/// How long a robot blocked twice in one place first stands out of
/// service before it tries to drive itself clear. Whatever held it may
/// have moved on by then; each try that fails doubles the rest, up to
/// [`REST_MAX`].
pub const REST_FIRST: Duration = Duration::from_secs(120);

/// The longest rest between two tries at getting clear.
pub const REST_MAX: Duration = Duration::from_secs(960);
/// The longest a robot left on a corridor's middle by a step aside that
/// did not happen waits before it tries again, robot time.
const ASIDE_AGAIN_MAX: Duration = Duration::from_secs(60);

/// What went wrong lately, which decides whether the robot goes out of
/// service; forgotten once it arrives somewhere.
#[derive(Debug, Default)]
struct Trouble {
    /// Where the last task was given up as blocked, if it was.
    blocked_at: Option<(f64, f64)>,
    /// Whether the last task was given up as overdue.
    overdue_before: bool,
    /// Out of service until it gets clear: how long it rests before the
    /// next try, and the positions it tried to get to.
    out: Option<(Duration, Vec<String>)>,
}

/// Where a robot stands after stepping aside, and the axis of the
/// corridor it stepped aside in, degrees.
pub(super) type Aside = (Point, f64);

/// Where a duty says its robot stands: where it stopped (`at_mm`), or the
/// point its position names. `None`: neither (a name the map lacks).
pub(super) fn stands_at(world: &World, duty: &Duty) -> Option<Point> {
    match duty.at_mm {
        Some([x, y]) => Some(Point::new(x, y)),
        None => Some(world.position(&duty.at)?.in_corridor()),
    }
}

/// The robot stands at the position `at`, ready for a task.
fn idle_at(duty: &mut Duty, at: String) {
    duty.at = at;
    duty.at_mm = None;
    duty.state = DutyState::Idle;
}

/// How a point where no position is named is written in `Duty.at`:
/// `@x,y` in metres.
fn off_label(x_mm: f64, y_mm: f64) -> String {
    format!("@{:.1},{:.1}", x_mm / 1000.0, y_mm / 1000.0)
}

/// The robot stands where no position is named, at (`x`, `y`) mm by its
/// odometry.
fn stands_off(duty: &mut Duty, x: f64, y: f64) {
    duty.at = off_label(x, y);
    duty.at_mm = Some([x, y]);
}

/// Where a drive starts from: the position the robot stands at, and
/// where its odometry put it when that is not a named position.
fn start_of(duty: &Duty) -> (String, Option<Point>) {
    (duty.at.clone(), duty.at_mm.map(|[x, y]| Point::new(x, y)))
}

/// How the robot takes tasks.
#[derive(Debug, Clone)]
pub struct DutyConfig {
    /// The position it stands at when it starts (it is registered there).
    pub at: String,
    /// Which way it faces there, degrees; without it the base's odometry
    /// heading is taken.
    pub facing: Option<f64>,
    /// The rules it drives by (junctions, lanes, between tasks).
    pub rules: Rules,
    /// How often a run looks whether its task was cancelled.
    pub check_every: Duration,
    /// A run that has not taken the robot two metres from where it was
    /// this long ago, while it was not waiting its turn for a junction or
    /// passage, is given up as blocked.
    pub stuck: Duration,
    /// A task still driving after its route's length at this speed (plus
    /// two minutes), not counting waits for junctions and passages, is
    /// given up as overdue: a robot that drives on without getting there
    /// has lost its way, and is never blocked.
    pub slowest_mm_s: f64,
    /// A robot without a task (at its start, or where its last task
    /// ended) that is given none within this long steps over to the
    /// corridor's right wall ([`planner::step_aside`]); `None`: it stays on
    /// the middle, and is registered only at its first task.
    pub aside_after: Option<Duration>,
}

impl DutyConfig {
    /// A robot standing at `at`.
    pub fn at(at: &str) -> DutyConfig {
        DutyConfig {
            at: at.to_string(),
            facing: None,
            rules: Rules::default(),
            check_every: Duration::from_secs(1),
            stuck: Duration::from_secs(180),
            slowest_mm_s: 100.0,
            aside_after: Some(Duration::from_secs(5)),
        }
    }
}

/// What the robot tells whoever watches.
#[derive(Debug)]
pub enum DutyNote<'a> {
    /// It took a task and drives this plan.
    Took(&'a Assignment, &'a Plan),
    /// Something the Planner says as it drives.
    Planner(Progress<'a>),
    /// It finished a task, well or not, and stands at a position of the
    /// map (`Some`) or is lost (`None`).
    Ended(&'a Outcome, Option<&'a str>),
    /// A value it read was not what it should be; it was skipped.
    Skipped(String),
    /// Between tasks, it did not get over to the corridor's wall: why (the
    /// Navigator's reason, or the data server's), and the how-manieth try
    /// failed (said on tries 1, 2, 4, 8…: one kept off the wall for long
    /// says so without filling the log). It stands where the step left it
    /// and takes tasks as before.
    NotAside(String, u32),
    /// Out of service where it was blocked twice, it stands this long
    /// before it tries to drive itself clear to a position of the map.
    Resting(Duration),
    /// It drove itself clear to this position and takes tasks again.
    Back(&'a str),
    /// It did not get clear: why. It rests again, twice as long.
    NotBack(String),
    /// Asked by this robot to make way, it drove on to a position (`Ok`),
    /// or did not: why.
    MadeWay(&'a str, Result<&'a str, &'a str>),
    /// Between tasks beside a robot waiting there, it drove on to this
    /// position to stand apart (`Ok`), or stopped short: why.
    Apart(Result<&'a str, &'a str>),
}

/// A robot that takes tasks: its blackboard, base, the map, and where it
/// stands.
pub struct OnDuty<'a> {
    /// Its blackboard (its Planner's data-server client).
    pub board: &'a Board,
    /// Its base.
    pub robot: &'a RobotClient,
    /// Ground truth, where a simulator answers: arrival is judged by it.
    pub truth: Option<&'a TruthClient>,
    /// The map's world.
    pub world: &'a World,
    /// The map's route network.
    pub network: &'a Network,
    /// Its name.
    pub name: &'a str,
}

impl OnDuty<'_> {
    /// Takes tasks until the data server or the robot's servers cannot be
    /// reached.
    pub async fn serve(
        &self,
        cfg: &DutyConfig,
        mut note: impl FnMut(DutyNote<'_>),
    ) -> Result<(), NavError> {
        let ds = self.board.client();
        self.board.declare().await?;
        ds.create_semaphore(&task_sem(self.name), 0).await?;
        ds.create_semaphore(WAKE, 0).await?;
        if self.world.position(&cfg.at).is_none() {
            return Err(NavError::Config(format!(
                "{} is not a position of the map; the robot must stand at one",
                cfg.at
            )));
        }
        let mut duty = Duty {
            at: cfg.at.clone(),
            at_mm: None,
            state: DutyState::Idle,
            task: None,
            owner: ds.owner().to_string(),
            last: None,
        };
        // A task told to an earlier Planner of this robot is not taken up:
        // the dispatcher sees the new owner and hands it out again.
        ds.set(&task_var(self.name), &None::<Assignment>).await?;
        self.report(&duty).await?;
        let mut facing = cfg.facing;
        let mut registered = false;
        let mut trouble = Trouble::default();
        // The leg it steps aside from while it has no task: its start's,
        // its last goal's, or the one it stopped short on.
        let mut last_leg: Option<LastLeg> = None;
        // It stands where the map gives no walls beside it (a junction, a
        // corridor's mouth), ready for a task: where, and the corridor's
        // axis there (NaN: that of its heading).
        let mut in_open: Option<(Point, f64)> = None;
        // Waiting for its first task, it would stand on the middle of the
        // corridor, where in a narrow one nobody passes it untouched: it
        // is registered where it stands and steps aside as it would
        // between tasks.
        if cfg.aside_after.is_some() {
            let heading = match facing {
                Some(f) => f,
                None => self.robot.pose().await?.heading_deg,
            };
            let leg = heading
                .is_finite()
                .then(|| start_leg(self.world, self.network, &cfg.at, heading))
                .flatten();
            if let (Some(leg), Some(p)) = (leg, self.world.position(&cfg.at)) {
                let p = p.in_corridor();
                (self.robot)
                    .set_pose(p.x.round() as i64, p.y.round() as i64, heading)
                    .await?;
                registered = true;
                facing = None;
                last_leg = Some(leg);
            }
        }
        // Where the robot stands after stepping aside, as the step was
        // meant to end (the map's walls, not its odometry); `None` once it
        // drives on.
        let mut aside_at: Option<Aside> = None;
        // How long it waits before it tries a step aside again, after one
        // that left it off the wall, and how many tries have failed.
        let mut aside_again: Option<(Duration, u32)> = None;
        // The last ask to make way answered, by asker.
        let mut answered = std::collections::BTreeMap::new();
        // Whether it drove on to stand apart since its last task: once is
        // enough, wherever that left it.
        let mut apart_tried = false;
        loop {
            if let Some((rest, tried)) = trouble.out.as_mut() {
                aside_at = None;
                rome_clock::sleep(*rest).await;
                let cleared = self
                    .get_clear(
                        cfg,
                        tried,
                        (&mut registered, &mut facing, &mut last_leg),
                        &mut note,
                    )
                    .await;
                match cleared {
                    Ok(at) => {
                        idle_at(&mut duty, at);
                        trouble = Trouble::default();
                        note(DutyNote::Back(&duty.at));
                    }
                    Err(why) => {
                        *rest = (*rest * 2).min(REST_MAX);
                        if let Ok(p) = self.robot.pose().await {
                            stands_off(&mut duty, f64::from(p.x_mm), f64::from(p.y_mm));
                        }
                        note(DutyNote::NotBack(why));
                        note(DutyNote::Resting(*rest));
                    }
                }
                self.report(&duty).await?;
                continue;
            }
            let given = match (last_leg.take(), cfg.aside_after) {
                // Nothing beside it to step to: it drives on out of the
                // open first, then steps aside there.
                (None, Some(after)) if in_open.is_some() => {
                    let open = in_open.take().expect("checked");
                    let given = ds.wait_timeout(&task_sem(self.name), after).await?;
                    if !given {
                        aside_at = None;
                        let out = self.step_out(&mut duty, open).await;
                        self.report(&duty).await?;
                        match out {
                            Ok(leg) => {
                                last_leg = leg;
                                continue;
                            }
                            Err(why) => note(DutyNote::NotAside(why, 1)),
                        }
                    }
                    given
                }
                (Some((direction, walls)), Some(after)) => {
                    let (wait, failed) = aside_again.unwrap_or((after, 0));
                    let given = ds.wait_timeout(&task_sem(self.name), wait).await?;
                    if !given {
                        // Within reach of a robot waiting there, both
                        // waiting would close the corridor between them,
                        // whichever wall each stood by: it drives on to
                        // stand apart first, and steps aside there.
                        if cfg.rules.stand_apart && !apart_tried && failed == 0 {
                            let from = start_of(&duty);
                            let here = stands_at(self.world, &duty);
                            let to = match here {
                                Some(here) => self.apart_to(here, direction).await?,
                                None => None,
                            };
                            if let Some(to) = to {
                                let state = (&mut registered, &mut facing, &mut last_leg);
                                self.go_apart(cfg, &mut duty, (&from, to), state, &mut note)
                                    .await?;
                                apart_tried = true;
                                continue;
                            }
                        }
                        let leg = (direction, walls);
                        // Left on the corridor's middle, where someone
                        // stood beside it or in the step's way (most often
                        // one about to pass it there), it tries again
                        // towards the other wall, soon once, then less
                        // often each time.
                        if let Some(why) = step_aside(self.board, self.robot, leg).await {
                            let failed = failed + 1;
                            if failed.is_power_of_two() {
                                note(DutyNote::NotAside(why, failed));
                            }
                            let next = if failed == 1 {
                                after
                            } else {
                                (wait * 2).min(ASIDE_AGAIN_MAX)
                            };
                            aside_again = Some((next, failed));
                            last_leg = Some(reversed(leg));
                            continue;
                        }
                        aside_at = stands_at(self.world, &duty)
                            .map(|p| (stood_aside(p, direction, walls), direction));
                        aside_again = None;
                    }
                    given
                }
                _ => false,
            };
            if !given {
                ds.wait(&task_sem(self.name)).await?;
            }
            let value = ds.get(&task_var(self.name)).await?;
            let a = match decode::<Option<Assignment>>(&task_var(self.name), &value) {
                Ok(a) => a,
                Err(why) => {
                    note(DutyNote::Skipped(why));
                    continue;
                }
            };
            let last = duty.last.as_ref().map(|o| o.task.as_str());
            let new = a.filter(|a| duty.state != DutyState::Lost && last != Some(a.task.as_str()));
            let Some(a) = new else {
                // Woken with no new task: a robot held up may have asked
                // it to make way.
                if cfg.rules.make_way && duty.state == DutyState::Idle {
                    if let Some((by, ask)) = self.asked(&mut answered).await {
                        let aside = aside_at.take();
                        let was = aside
                            .map(|(q, _)| q)
                            .or_else(|| stands_at(self.world, &duty));
                        let from = start_of(&duty);
                        let state = (&mut registered, &mut facing, &mut last_leg);
                        let ask = (by.as_str(), &ask);
                        // Busy while it drives: no task is handed to it,
                        // nobody asks it again, and nobody takes its old
                        // place for where it stands.
                        duty.state = DutyState::Busy;
                        duty.task = Some(super::schema::making_way_for(&by));
                        self.report(&duty).await?;
                        let made = self
                            .make_way(cfg, ask, (&from, aside, was), state, &mut note)
                            .await;
                        duty.state = DutyState::Idle;
                        duty.task = None;
                        let now = self.robot.pose().await.ok();
                        match (&made, now) {
                            (Ok(at), _) => idle_at(&mut duty, at.clone()),
                            // It drove, and stopped short: it stands where
                            // its odometry puts it.
                            (Err(_), Some(p))
                                if was.is_none_or(|w| {
                                    let now = Point::new(f64::from(p.x_mm), f64::from(p.y_mm));
                                    rome_maps::geometry::distance(w, now) > 500.0
                                }) =>
                            {
                                stands_off(&mut duty, f64::from(p.x_mm), f64::from(p.y_mm))
                            }
                            // It did not drive: it stands as it stood.
                            (Err(_), _) => aside_at = aside,
                        }
                        in_open = None;
                        note(DutyNote::MadeWay(
                            &by,
                            made.as_deref().map_err(String::as_str),
                        ));
                        self.report(&duty).await?;
                    }
                }
                continue;
            };
            duty.state = DutyState::Busy;
            duty.task = Some(a.task.clone());
            aside_again = None;
            apart_tried = false;
            self.report(&duty).await?;
            let from = start_of(&duty);
            let (outcome, at) = self
                .carry_out(
                    cfg,
                    (&from, aside_at.take()),
                    &a,
                    true,
                    (&mut registered, &mut facing, &mut last_leg),
                    &mut note,
                )
                .await;
            if at.is_none() {
                last_leg = None;
            }
            match at {
                Some(at) => {
                    idle_at(&mut duty, at);
                    trouble = Trouble::default();
                }
                // Stopped between named positions: it goes on from where
                // its odometry puts it (registered at its first task's
                // start, corrected by walls and lights on the way).
                None => match self.robot.pose().await {
                    Ok(p) if registered => {
                        let (x, y) = (f64::from(p.x_mm), f64::from(p.y_mm));
                        stands_off(&mut duty, x, y);
                        duty.state = DutyState::Idle;
                        // Stopped short, it would wait on the corridor's
                        // middle too: it steps aside across the corridor
                        // it stands in.
                        let (here, h) = (Point::new(x, y), p.heading_deg);
                        let axis = (cfg.rules.leave_open)
                            .then(|| corridor_axis(self.world, here))
                            .flatten()
                            .unwrap_or(h);
                        last_leg = leg_at(self.world, self.network, here, axis, h);
                        let blocked = outcome
                            .why
                            .as_deref()
                            .is_some_and(|w| w.starts_with(BLOCKED));
                        // Blocked twice in one place: whatever holds it
                        // there would hold it for the next task too, and a
                        // robot that keeps failing tasks keeps them from
                        // robots that could do them. It rests, then tries
                        // to get clear.
                        if blocked
                            && trouble
                                .blocked_at
                                .is_some_and(|(bx, by)| (x - bx).hypot(y - by) < 1_000.0)
                        {
                            duty.state = DutyState::Lost;
                            trouble.out = Some((REST_FIRST, Vec::new()));
                        }
                        trouble.blocked_at = blocked.then_some((x, y));
                        // Overdue twice running: it keeps losing its way.
                        let overdue_now = outcome
                            .why
                            .as_deref()
                            .is_some_and(|w| w.starts_with(OVERDUE));
                        if overdue_now && trouble.overdue_before {
                            duty.state = DutyState::Lost;
                        }
                        trouble.overdue_before = overdue_now;
                    }
                    _ => duty.state = DutyState::Lost,
                },
            }
            if duty.state == DutyState::Lost {
                last_leg = None;
            }
            in_open = None;
            if cfg.rules.leave_open && registered && duty.state == DutyState::Idle {
                // Where no walls are beside the goal (a junction), the last
                // leg's walls are those of the corridor it came from.
                let named =
                    (self.world.position(&duty.at)).map(|p| (p.in_corridor(), p.wall_heading_deg));
                in_open = match (named, &last_leg) {
                    (Some((p, axis)), _) => leg_at(self.world, self.network, p, axis, axis)
                        .is_none()
                        .then_some((p, axis)),
                    (None, None) => duty.at_mm.map(|[x, y]| {
                        let here = Point::new(x, y);
                        (here, corridor_axis(self.world, here).unwrap_or(f64::NAN))
                    }),
                    (None, Some(_)) => None,
                };
                if in_open.is_some() {
                    last_leg = None;
                }
            }
            // Said first, so that whoever watches never takes it for lost
            // for good.
            if let Some((rest, _)) = &trouble.out {
                note(DutyNote::Resting(*rest));
            }
            note(DutyNote::Ended(
                &outcome,
                (duty.state != DutyState::Lost).then_some(duty.at.as_str()),
            ));
            duty.task = None;
            duty.last = Some(outcome);
            self.report(&duty).await?;
        }
    }

    /// Drives on to `to`, to stand apart from robots waiting near, as a
    /// task of its own that the blackboard shows; then stands idle where
    /// it got to. Stopped short, it is left to step aside where it stands
    /// (from the leg it was on there, put in `state`).
    async fn go_apart(
        &self,
        cfg: &DutyConfig,
        duty: &mut Duty,
        (from, to): (&(String, Option<Point>), String),
        state: (&mut bool, &mut Option<f64>, &mut Option<LastLeg>),
        note: &mut impl FnMut(DutyNote<'_>),
    ) -> Result<(), NavError> {
        duty.state = DutyState::Busy;
        duty.task = Some(super::schema::STAND_APART_TASK.to_string());
        self.report(duty).await?;
        let (registered, facing, last_leg) = state;
        let moved = self
            .stand_apart(cfg, (from, to), (registered, facing, &mut *last_leg), note)
            .await;
        match (&moved, self.robot.pose().await) {
            (Ok(at), _) => idle_at(duty, at.clone()),
            (Err(_), Ok(p)) => {
                let (x, y) = (f64::from(p.x_mm), f64::from(p.y_mm));
                stands_off(duty, x, y);
                let (here, h) = (Point::new(x, y), p.heading_deg);
                *last_leg = leg_at(self.world, self.network, here, h, h);
            }
            (Err(_), Err(_)) => {}
        }
        duty.state = DutyState::Idle;
        duty.task = None;
        note(DutyNote::Apart(moved.as_deref().map_err(String::as_str)));
        self.report(duty).await
    }

    /// Drives from where the robot stands to the nearest position it has
    /// not tried yet ([`clear_to`]), as a task of its own that nobody
    /// cancels: the position it arrived at, or why not.
    async fn get_clear(
        &self,
        cfg: &DutyConfig,
        tried: &mut Vec<String>,
        state: (&mut bool, &mut Option<f64>, &mut Option<LastLeg>),
        note: &mut impl FnMut(DutyNote<'_>),
    ) -> Result<String, String> {
        let p = self.robot.pose().await.map_err(|e| e.to_string())?;
        let here = Point::new(f64::from(p.x_mm), f64::from(p.y_mm));
        let Some((to, _)) = clear_to(self.world, self.network, here, p.heading_deg, tried) else {
            return Err(format!(
                "no position of the map it has not tried within {:.0} m",
                CLEAR_NEAR_MM / 1000.0
            ));
        };
        tried.push(to.clone());
        let a = Assignment {
            task: format!("clear to {to}"),
            to,
            via: Vec::new(),
        };
        let from = (off_label(here.x, here.y), Some(here));
        // Its own drive is no task: only what the Planner says is passed on.
        let mut planner_only = |n: DutyNote<'_>| {
            if let DutyNote::Planner(_) = n {
                note(n)
            }
        };
        let (outcome, at) = self
            .carry_out(cfg, (&from, None), &a, false, state, &mut planner_only)
            .await;
        at.ok_or_else(|| outcome.why.unwrap_or_else(|| "no reason given".to_string()))
    }

    /// Drives a robot that stands in the open on out of it
    /// ([`way_out`]): the leg it then steps aside from, `None` when there
    /// is no way out, or why it did not get there. Where it stands after
    /// is written into `duty`.
    async fn step_out(
        &self,
        duty: &mut Duty,
        (at, axis): (Point, f64),
    ) -> Result<Option<LastLeg>, String> {
        let p = self.robot.pose().await.map_err(|e| e.to_string())?;
        let axis = if axis.is_nan() { p.heading_deg } else { axis };
        let waiting = self.waiting().await.map_err(|e| e.to_string())?;
        let Some(out) = way_out(
            self.world,
            self.network,
            (at, axis, p.heading_deg),
            &waiting,
        ) else {
            return Ok(None);
        };
        // Turned in place first: a way out behind the robot, driven as a
        // goal, turns on an arc into whatever corridor opens beside it.
        planner::turn_to(self.robot, out.direction_deg, p.heading_deg)
            .await
            .map_err(|e| e.to_string())?;
        // The way out ends `distance_mm` on from `at`; the robot may have
        // ended its task short of `at` or past it, and is driven to that end.
        let here = Point::new(f64::from(p.x_mm), f64::from(p.y_mm));
        let behind = (at - here).dot(&rome_maps::geometry::direction(out.direction_deg));
        let distance_mm = (out.distance_mm + behind).max(OUT_STEP_MM);
        let said = planner::step_out(self.board, out.direction_deg, distance_mm, out.walls)
            .await
            .map_err(|e| e.to_string())?;
        let p = self.robot.pose().await.map_err(|e| e.to_string())?;
        let (x, y) = (f64::from(p.x_mm), f64::from(p.y_mm));
        stands_off(duty, x, y);
        match said {
            Some(why) => Err(format!("the Navigator: {why}")),
            None => Ok(leg_at(
                self.world,
                self.network,
                Point::new(x, y),
                out.direction_deg,
                out.direction_deg,
            )),
        }
    }

    /// Where the fleet's other robots stand while they wait (idle, or out
    /// of service), as their duties say: where each stopped, or the
    /// position it stands aside from. A duty that does not decode says
    /// nothing of where its robot is and is passed over; one on its way
    /// to a task is not standing anywhere.
    pub(super) async fn waiting(&self) -> Result<Vec<Point>, NavError> {
        Ok((self.others().await?.into_iter())
            .filter(|(_, d, _)| d.state != DutyState::Busy)
            .map(|(_, _, p)| p)
            .collect())
    }

    /// The fleet's other robots whose duties decode and say where they
    /// stand ([`stands_at`]): name, duty, and that point.
    pub(super) async fn others(&self) -> Result<Vec<(String, Duty, Point)>, NavError> {
        let duties = super::tasks::robots(self.board.client()).await?;
        Ok((duties.into_iter())
            .filter(|(name, _)| name != self.name)
            .filter_map(|(name, duty)| {
                let d = duty.ok()?;
                let p = stands_at(self.world, &d)?;
                Some((name, d, p))
            })
            .collect())
    }

    async fn report(&self, duty: &Duty) -> Result<(), NavError> {
        let ds = self.board.client();
        ds.set(&duty_var(self.name), duty).await?;
        ds.signal(WAKE).await?;
        Ok(())
    }
}
