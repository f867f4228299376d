//! A fleet given errands in one process: the simulated world, each
//! robot's crew and a Planner taking tasks ([`rome_nav::fleet::duty`]),
//! and the dispatcher ([`rome_nav::fleet::dispatcher`]), all as separate
//! clients of one data server, as they are across hosts. Tasks are added
//! at the start; the run ends when every task has ended or at the limit.
//!
//! Judged by what happened: a task is done only when its robot's ground
//! truth is within a metre of the goal; contacts and standing still are
//! counted from the simulated world.

use crate::{connect, crew_span, members, monitored, Harness, RunConfig};
use rome_client::sim::TruthClient;
use rome_client::{DataClient, DataOptions, RobotClient, RobotOptions};
use rome_maps::geometry::Point;
use rome_maps::World;
use rome_nav::crew::Reports;
use rome_nav::fleet::dispatcher::{DispatchConfig, Dispatcher, Note};
use rome_nav::fleet::duty::{DutyConfig, DutyNote, OnDuty};
use rome_nav::fleet::schema::{TaskSpec, TaskStatus};
use rome_nav::fleet::tasks;
use rome_nav::planner::Progress;
use rome_nav::NavError;
use rome_schema::sim::ContactCount;
use rome_schema::Root;
use rome_sim::Pose;
use std::collections::BTreeMap;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;
use tracing::Instrument;

/// What to run.
#[derive(Debug, Clone)]
pub struct TaskRun {
    /// The world and crews; each route gives a robot's name and where it
    /// starts (`from`; its `to` is not used).
    pub run: RunConfig,
    /// The tasks, with their ids, added as the world starts.
    pub tasks: Vec<(String, TaskSpec)>,
    /// Add the tasks one at a time, the next this much simulated time
    /// after the last (errands that come in a stream), instead of all as
    /// the world starts.
    pub every: Option<Duration>,
    /// A robot whose whole crew is killed as it takes its first task (a
    /// fault to inject).
    pub kill: Option<String>,
    /// People who stand still at these points from the start, and leave
    /// the building after this much simulated time: a corridor closed for
    /// a while (a fault to inject).
    pub closed: Option<(Vec<Point>, Duration)>,
    /// Robots that never step aside between tasks but stand where they
    /// stop, on the corridor's middle: a step aside cut short, as a fault
    /// to inject.
    pub stay: Vec<String>,
}

/// What happened.
#[derive(Debug, Clone)]
pub struct TaskReport {
    /// Every task's status at the end.
    pub statuses: Vec<TaskStatus>,
    /// Each robot's contacts, by ground truth.
    pub contacts: BTreeMap<String, ContactCount>,
    /// Where each robot stands at the end, by ground truth: (x, y) mm.
    pub at_end: BTreeMap<String, (f64, f64)>,
    /// How far each robot's odometry heading is off at the end, by ground
    /// truth: true heading less odometry's, degrees in (−180, 180].
    pub heading_off_end: BTreeMap<String, f64>,
    /// Each robot's longest time standing still (moved under half a metre)
    /// while it had a task, simulated s.
    pub longest_still_s: BTreeMap<String, f64>,
    /// Where and when each robot's longest time standing still with a
    /// task began (robots that never stood still with one are left out).
    pub longest_still_at: BTreeMap<String, StillAt>,
    /// Each task's time spent waiting its turn for junctions and passages
    /// on the way, simulated s, by task id.
    pub traffic_wait_s: BTreeMap<String, f64>,
    /// Where and when each contact began, in the order they happened.
    pub contact_places: Vec<ContactAt>,
    /// Simulated time of the run, s.
    pub sim_s: f64,
    /// Wall time of the run.
    pub wall: Duration,
}

/// A contact, where it began: the robot's ground truth at the end of the
/// second in which the count rose (so within a second's drive of the
/// touch). Two touches begun in one second are two, at one place.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactAt {
    /// Simulated time since the start, s.
    pub t_s: f64,
    /// The robot that touched.
    pub robot: String,
    /// Where it stood, mm.
    pub x_mm: f64,
    /// Where it stood, mm.
    pub y_mm: f64,
    /// Another robot (`true`) or a wall.
    pub with_robot: bool,
    /// The task it was doing, if any.
    pub task: Option<String>,
}

/// A robot's longest time standing still with a task: the robot's ground
/// truth once it had stood there longest.
#[derive(Debug, Clone, PartialEq)]
pub struct StillAt {
    /// Simulated time since the start when it began to stand, s.
    pub since_s: f64,
    /// How long it stood, s.
    pub still_s: f64,
    /// Where it stood, mm.
    pub x_mm: f64,
    /// Where it stood, mm.
    pub y_mm: f64,
    /// The task it had.
    pub task: Option<String>,
}

/// Something that happened.
#[derive(Debug, Clone)]
pub enum TaskEvent {
    /// The dispatcher changed a task: its status, and what happened.
    Task(TaskStatus, String),
    /// A robot said something.
    Robot(String, Said),
}

/// What a robot says.
#[derive(Debug, Clone, PartialEq)]
pub enum Said {
    /// It took a task.
    Took(String),
    /// It arrived at a task's goal.
    Arrived(String),
    /// It did not: the task, why, and whether it is lost now (stopped
    /// away from any position the map names, taking no more tasks).
    NotArrived(String, String, bool),
    /// It waits its turn for a junction or passage (`Some`), or no longer.
    Waits(Option<String>),
    /// Out of service where it was blocked twice, it rests this many
    /// seconds before it tries to get clear: it is not lost for good.
    Rests(f64),
    /// It got clear to this position and takes tasks again.
    Back(String),
    /// A value it read was skipped, or one of its clients failed.
    Trouble(String),
    /// Asked by this robot to make way, it drove on to a position (`Ok`),
    /// or did not: why.
    MadeWay(String, Result<String, String>),
    /// Between tasks beside a robot waiting there, it drove on to this
    /// position to stand apart, or did not: why.
    Apart(Result<String, String>),
}

impl std::fmt::Display for Said {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Said::Took(t) => write!(f, "took {t}"),
            Said::Arrived(t) => write!(f, "{t} arrived"),
            Said::NotArrived(t, why, lost) => {
                write!(f, "{t} not arrived: {why}")?;
                if *lost {
                    write!(f, "; lost")?;
                }
                Ok(())
            }
            Said::Waits(Some(part)) => write!(f, "waits for {part}"),
            Said::Waits(None) => write!(f, "goes on"),
            Said::Rests(s) => write!(f, "rests {s:.0} s, then drives itself clear"),
            Said::Back(at) => write!(f, "got clear to {at}; takes tasks again"),
            Said::Trouble(why) => write!(f, "{why}"),
            Said::MadeWay(by, Ok(at)) => write!(f, "made way for {by}: drove on to {at}"),
            Said::MadeWay(by, Err(why)) => write!(f, "did not make way for {by}: {why}"),
            Said::Apart(Ok(at)) => write!(f, "waited beside another: drove on to {at}"),
            Said::Apart(Err(why)) => write!(f, "did not drive on from beside another: {why}"),
        }
    }
}

/// Runs the fleet until every task has ended or `run.limit` of simulated
/// time has passed.
pub async fn run_tasks(
    cfg: TaskRun,
    progress: &mut impl FnMut(TaskEvent),
) -> Result<TaskReport, NavError> {
    let lockstep = cfg.run.lockstep;
    monitored(lockstep, |clock| run_all(cfg, progress, clock)).await
}

/// Adds the tasks from `next` on that are due `elapsed` into the run:
/// task k at k × `every`, or all at once without it. Returns the first not
/// yet added.
async fn add_due(
    adder: &DataClient,
    all: &[(String, TaskSpec)],
    every: Option<Duration>,
    mut next: usize,
    elapsed: Duration,
) -> Result<usize, NavError> {
    let due = |k: usize| match every {
        None => true,
        // Past what a Duration holds is never.
        Some(every) => (u32::try_from(k).ok())
            .and_then(|k| every.checked_mul(k))
            .is_some_and(|at| elapsed >= at),
    };
    while next < all.len() && due(next) {
        let (id, spec) = &all[next];
        tasks::add_as(adder, id, spec).await?;
        next += 1;
    }
    Ok(next)
}

async fn run_all(
    cfg: TaskRun,
    progress: &mut impl FnMut(TaskEvent),
    clock: Option<rome_clock::LockStep>,
) -> Result<TaskReport, NavError> {
    let wall = Instant::now();
    let run = &cfg.run;
    let world = World::from_map(&run.map);
    let network = run.network(&world);
    let mut starts = Vec::new();
    for r in &run.routes {
        let p = world
            .position(&r.from)
            .ok_or_else(|| NavError::Config(format!("{}: no position '{}'", r.robot, r.from)))?
            .in_corridor();
        // Facing North: the first task turns it onto its route.
        starts.push((r.robot.clone(), Pose::new(p.x, p.y, 0.0)));
    }
    let rig = Harness::start(run, &starts, run.net.clone()).await?;
    let session = rig.session.clone();
    let root = Root::default();

    let (etx, mut erx) = mpsc::unbounded_channel::<TaskEvent>();
    let mut crews: Vec<tokio::task::JoinSet<()>> = Vec::new();
    for r in &run.routes {
        let mut set = tokio::task::JoinSet::new();
        for member in members(run, &world, r.cruise_mm_s) {
            let role = member.role();
            let (board, robot) = connect(&session, &r.robot, role).await?;
            let (name, etx) = (r.robot.clone(), etx.clone());
            let span = crew_span(&name);
            set.spawn(rome_clock::wrap(
                &format!("{} {role}", r.robot),
                async move {
                    if let Err(e) = member.run(robot, board, Reports::default()).await {
                        let why = Said::Trouble(format!("the {role} failed: {e}"));
                        let _ = etx.send(TaskEvent::Robot(name, why));
                    }
                }
                .instrument(span),
            ));
        }
        let (board, robot) = connect(&session, &r.robot, "planner").await?;
        let truth = TruthClient::new(&session, &root, &r.robot)?;
        let (world, network) = (world.clone(), network.clone());
        let mut duty = DutyConfig::at(&r.from);
        duty.facing = Some(0.0);
        duty.rules = run.rules;
        duty.stuck = run.stuck;
        duty.slowest_mm_s = run.slowest_mm_s;
        if cfg.stay.contains(&r.robot) {
            duty.aside_after = None;
        }
        let (name, etx) = (r.robot.clone(), etx.clone());
        set.spawn(rome_clock::wrap(
            &format!("{} planner", r.robot),
            async move {
                let on = OnDuty {
                    board: &board,
                    robot: &robot,
                    truth: Some(&truth),
                    world: &world,
                    network: &network,
                    name: &name,
                };
                let say = |what: Said| {
                    let _ = etx.send(TaskEvent::Robot(name.clone(), what));
                };
                let r = on
                    .serve(&duty, |n| match n {
                        DutyNote::Took(a, _) => say(Said::Took(a.task.clone())),
                        DutyNote::Ended(o, _) if o.ok => say(Said::Arrived(o.task.clone())),
                        DutyNote::Ended(o, at) => say(Said::NotArrived(
                            o.task.clone(),
                            o.why.clone().unwrap_or_default(),
                            at.is_none(),
                        )),
                        DutyNote::Skipped(why) => say(Said::Trouble(format!("skipped {why}"))),
                        DutyNote::NotAside(why, n) => {
                            say(Said::Trouble(rome_nav::fleet::aside::not_aside(&why, n)))
                        }
                        DutyNote::Planner(Progress::Waiting(part)) => {
                            say(Said::Waits(Some(part.to_string())))
                        }
                        DutyNote::Planner(Progress::Holding(_, true)) => say(Said::Waits(None)),
                        DutyNote::Planner(_) => {}
                        DutyNote::Resting(rest) => say(Said::Rests(rest.as_secs_f64())),
                        DutyNote::Back(at) => say(Said::Back(at.to_string())),
                        DutyNote::NotBack(why) => {
                            say(Said::Trouble(format!("did not get clear: {why}")))
                        }
                        DutyNote::MadeWay(by, made) => say(Said::MadeWay(
                            by.to_string(),
                            made.map(str::to_string).map_err(str::to_string),
                        )),
                        DutyNote::Apart(moved) => say(Said::Apart(
                            moved.map(str::to_string).map_err(str::to_string),
                        )),
                    })
                    .await;
                if let Err(e) = r {
                    say(Said::Trouble(format!("the planner failed: {e}")));
                }
            }
            .instrument(crew_span(&r.robot)),
        ));
        crews.push(set);
    }
    let ds = DataClient::connect(&session, DataOptions::new("dispatcher")).await?;
    let d = Dispatcher::new(
        ds,
        session.clone(),
        world.clone(),
        network.clone(),
        DispatchConfig::default(),
    );
    let detx = etx.clone();
    let dispatcher = rome_clock::spawn("the dispatcher", async move {
        let _ = d
            .run(|n| {
                if let Note::Task(s, what) = n {
                    let _ = detx.send(TaskEvent::Task(s, what));
                }
            })
            .await;
    });
    drop(etx);
    let adder = DataClient::connect(&session, DataOptions::new("cli")).await?;
    let mut added = add_due(&adder, &cfg.tasks, cfg.every, 0, Duration::ZERO).await?;
    // The people who close a corridor, and when they leave.
    let mut closed: Option<(Vec<usize>, Duration)> = cfg.closed.as_ref().map(|(at, until)| {
        let mut w = rig.world.lock();
        (
            at.iter().map(|p| w.add_walker(*p, *p, 0.0)).collect(),
            *until,
        )
    });
    rig.trace(run.trace.as_deref())?;
    let stepper = match clock {
        Some(clock) => rig.world.start_lockstep(clock, run.speed, |_| {}),
        None => rig.world.start(Some(run.wall_speed())),
    };

    let names: Vec<String> = run.routes.iter().map(|r| r.robot.clone()).collect();
    let mut statuses: BTreeMap<String, TaskStatus> = BTreeMap::new();
    let mut busy = vec![false; names.len()];
    let t0 = rig.world.lock().time_ms();
    let mut still: Vec<(u64, f64)> = vec![(t0, 0.0); names.len()];
    let mut longest_at: Vec<Option<StillAt>> = vec![None; names.len()];
    // Each robot's task and since when it waits its turn, if it does.
    let mut doing: Vec<Option<String>> = vec![None; names.len()];
    let mut waits_since: Vec<Option<u64>> = vec![None; names.len()];
    let mut traffic_wait_s: BTreeMap<String, f64> = BTreeMap::new();
    let mut tick = rome_clock::interval(run.period(1_000.0));
    let mut killed = false;
    let mut touched: Vec<(u32, u32)> = vec![(0, 0); names.len()];
    let mut contact_places: Vec<ContactAt> = Vec::new();
    // Robots that take no more tasks: lost, or their crew killed.
    let mut lost = vec![false; names.len()];
    let mut resting = vec![false; names.len()];
    loop {
        let ended = statuses.len() == cfg.tasks.len() && statuses.values().all(|s| s.state.ended());
        // Nobody left to do what remains.
        let ended = ended || lost.iter().all(|l| *l);
        let now = rig.world.lock().time_ms();
        if ended || Duration::from_millis(now - t0) > run.limit {
            break;
        }
        if let Some((people, _)) =
            closed.take_if(|(_, until)| Duration::from_millis(now - t0) >= *until)
        {
            // Gone from the building: far off, where no sonar reaches.
            let gone = Point::new(-1.0e7, -1.0e7);
            let mut w = rig.world.lock();
            for k in people {
                let p = &mut w.walkers_mut()[k];
                (p.at, p.from, p.to) = (gone, gone, gone);
            }
        }
        tokio::select! {
            biased;
            Some(event) = rome_clock::idle(erx.recv()) => {
                match &event {
                    TaskEvent::Task(s, _) => {
                        statuses.insert(s.id.clone(), s.clone());
                    }
                    TaskEvent::Robot(name, said) => {
                        if let Some(k) = names.iter().position(|n| n == name) {
                            match said {
                                Said::Waits(Some(_)) => {
                                    waits_since[k].get_or_insert(now);
                                    progress(event);
                                    continue;
                                }
                                Said::Waits(None) => {
                                    if let (Some(t0), Some(task)) = (waits_since[k].take(), &doing[k]) {
                                        *traffic_wait_s.entry(task.clone()).or_default() += (now - t0) as f64 / 1000.0;
                                    }
                                    progress(event);
                                    continue;
                                }
                                Said::Took(task) => doing[k] = Some(task.clone()),
                                _ => doing[k] = None,
                            }
                            busy[k] = matches!(said, Said::Took(_));
                            // Resting is not lost for good: it comes back.
                            match said {
                                Said::Rests(_) => resting[k] = true,
                                Said::Back(_) => resting[k] = false,
                                _ => {}
                            }
                            lost[k] |= matches!(said, Said::NotArrived(_, _, true)) && !resting[k];
                            still[k] = (now, rig.world.lock().robot(rig.index[k]).travelled_mm);
                            if !killed && busy[k] && cfg.kill.as_deref() == Some(name.as_str()) {
                                // The whole crew dies at once, Planner too.
                                crews[k].abort_all();
                                killed = true;
                                busy[k] = false;
                                lost[k] = true;
                            }
                        }
                    }
                }
                progress(event);
            }
            _ = tick.tick() => {
                let elapsed = Duration::from_millis(now - t0);
                added = add_due(&adder, &cfg.tasks, cfg.every, added, elapsed).await?;
                for k in 0..names.len() {
                    let (moved, c, at) = {
                        let w = rig.world.lock();
                        let r = w.robot(rig.index[k]);
                        (r.travelled_mm, r.contacts, r.pose.at)
                    };
                    let here = ContactAt {
                        t_s: (now - t0) as f64 / 1000.0,
                        robot: names[k].clone(),
                        x_mm: at.x,
                        y_mm: at.y,
                        with_robot: false,
                        task: doing[k].clone(),
                    };
                    contact_places.extend(begun(touched[k], (c.wall, c.robot), &here));
                    touched[k] = (c.wall, c.robot);
                    // Waiting one's turn is not being stuck.
                    if !busy[k] || waits_since[k].is_some() || moved - still[k].1 >= 500.0 {
                        still[k] = (now, moved);
                    }
                    let held = (now - still[k].0) as f64 / 1000.0;
                    if held > longest_at[k].as_ref().map_or(0.0, |a| a.still_s) {
                        longest_at[k] = Some(StillAt {
                            since_s: (still[k].0 - t0) as f64 / 1000.0,
                            still_s: held,
                            x_mm: at.x,
                            y_mm: at.y,
                            task: doing[k].clone(),
                        });
                    }
                }
            }
        }
    }
    let sim_s = (rig.world.lock().time_ms() - t0) as f64 / 1000.0;
    drop(stepper);
    dispatcher.abort();
    for mut set in crews {
        set.abort_all();
        while set.join_next().await.is_some() {}
    }
    let (mut contacts, mut at_end) = (BTreeMap::new(), BTreeMap::new());
    let mut heading_off_end = BTreeMap::new();
    for (k, name) in names.iter().enumerate() {
        let t = rome_sim_hardware::truth::truth_of(&rig.world, rig.index[k]);
        contacts.insert(name.clone(), t.contacts);
        at_end.insert(name.clone(), (t.x_mm, t.y_mm));
        // The odometry as the robot's clients see it: the base server's
        // frame, which the mapper's corrections move.
        let monitor =
            RobotClient::connect(&rig.session, name, RobotOptions::new("monitor")).await?;
        let odometry = monitor.pose().await?.heading_deg;
        let off = rome_maps::geometry::normalize_deg(t.heading_deg - odometry);
        heading_off_end.insert(name.clone(), off);
    }
    let longest_still_s = (names.iter().cloned().zip(&longest_at))
        .map(|(name, at)| (name, at.as_ref().map_or(0.0, |a| a.still_s)))
        .collect();
    let longest_still_at = (names.iter().cloned().zip(longest_at))
        .filter_map(|(name, at)| Some((name, at?)))
        .collect();
    rig.stop().await;
    Ok(TaskReport {
        statuses: statuses.into_values().collect(),
        contacts,
        at_end,
        heading_off_end,
        longest_still_s,
        longest_still_at,
        traffic_wait_s,
        contact_places,
        sim_s,
        wall: wall.elapsed(),
    })
}

/// The contacts begun since the counts (wall, robot) were `before`: one
/// for each the count rose by, at `here`, so the lines written match the
/// counts however many touches one second held.
fn begun(before: (u32, u32), now: (u32, u32), here: &ContactAt) -> Vec<ContactAt> {
    let walls = (before.0..now.0).map(|_| false);
    let robots = (before.1..now.1).map(|_| true);
    walls
        .chain(robots)
        .map(|with_robot| ContactAt {
            with_robot,
            ..here.clone()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_touches_begun_in_one_second_are_two_contacts() {
        let here = ContactAt {
            t_s: 12.0,
            robot: "r3".into(),
            x_mm: 1_000.0,
            y_mm: 2_000.0,
            with_robot: false,
            task: Some("T4".into()),
        };
        let lines = begun((1, 0), (3, 1), &here);
        let with: Vec<bool> = lines.iter().map(|c| c.with_robot).collect();
        assert_eq!(with, [false, false, true]);
        assert!(lines.iter().all(|c| c.t_s == 12.0 && c.robot == "r3"));
        assert!(begun((3, 1), (3, 1), &here).is_empty());
    }
}
