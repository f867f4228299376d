//! A fleet given errands in one process: the simulated world, each
//! robot's crew and a Planner taking tasks ([`rome_nav::fleet::duty`]),
//! and the dispatcher ([`rome_nav::fleet::dispatcher`]), all as separate
//! clients of one data server, as they are across hosts. Tasks are added
//! at the start; the run ends when every task has ended or at the limit.
//!
//! Judged by what happened: a task is done only when its robot's ground
//! truth is within a metre of the goal; contacts and standing still are
//! counted from the simulated world.

use crate::{connect, members, Harness, RunConfig};
use rome_client::sim::TruthClient;
use rome_client::{DataClient, DataOptions};
use rome_maps::{Network, World};
use rome_nav::crew::Reports;
use rome_nav::fleet::dispatcher::{DispatchConfig, Dispatcher, Note};
use rome_nav::fleet::duty::{DutyConfig, DutyNote, OnDuty};
use rome_nav::fleet::schema::{TaskSpec, TaskStatus};
use rome_nav::fleet::tasks;
use rome_nav::NavError;
use rome_schema::sim::ContactCount;
use rome_schema::Root;
use rome_sim::Pose;
use std::collections::BTreeMap;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

/// What to run.
#[derive(Debug, Clone)]
pub struct TaskRun {
    /// The world and crews; each route gives a robot's name and where it
    /// starts (`from`; its `to` is not used).
    pub run: RunConfig,
    /// The tasks, with their ids, added as the world starts.
    pub tasks: Vec<(String, TaskSpec)>,
    /// A robot whose whole crew is killed as it takes its first task (a
    /// fault to inject).
    pub kill: Option<String>,
}

/// What happened.
#[derive(Debug, Clone)]
pub struct TaskReport {
    /// Every task's status at the end.
    pub statuses: Vec<TaskStatus>,
    /// Each robot's contacts, by ground truth.
    pub contacts: BTreeMap<String, ContactCount>,
    /// Each robot's longest time standing still (moved under half a metre)
    /// while it had a task, simulated s.
    pub longest_still_s: BTreeMap<String, f64>,
    /// Simulated time of the run, s.
    pub sim_s: f64,
    /// Wall time of the run.
    pub wall: Duration,
}

/// Something that happened, as a line to show.
#[derive(Debug, Clone)]
pub enum TaskEvent {
    /// The dispatcher changed a task.
    Task(TaskStatus, String),
    /// A robot said something.
    Robot(String, String),
}

/// Runs the fleet until every task has ended or `run.limit` of simulated
/// time has passed.
pub async fn run_tasks(
    cfg: TaskRun,
    progress: &mut impl FnMut(TaskEvent),
) -> Result<TaskReport, NavError> {
    if cfg.run.lockstep {
        let clock = rome_clock::LockStep::new(0);
        clock
            .clone()
            .participate("the run's monitor", run_all(cfg, progress, Some(clock)))
            .await
    } else {
        run_all(cfg, progress, None).await
    }
}

async fn run_all(
    cfg: TaskRun,
    progress: &mut impl FnMut(TaskEvent),
    clock: Option<rome_clock::LockStep>,
) -> Result<TaskReport, NavError> {
    let wall = Instant::now();
    let run = &cfg.run;
    let world = World::from_map(&run.map);
    let network = Network::new(&run.map, &world);
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
            set.spawn(rome_clock::wrap(
                &format!("{} {role}", r.robot),
                async move {
                    if let Err(e) = member.run(robot, board, Reports::default()).await {
                        let _ = etx.send(TaskEvent::Robot(name, format!("the {role} failed: {e}")));
                    }
                },
            ));
        }
        let (board, robot) = connect(&session, &r.robot, "planner").await?;
        let truth = TruthClient::new(&session, &root, &r.robot)?;
        let (world, network) = (world.clone(), network.clone());
        let mut duty = DutyConfig::at(&r.from);
        duty.facing = Some(0.0);
        duty.traffic = run.traffic;
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
                let say = |what: String| {
                    let _ = etx.send(TaskEvent::Robot(name.clone(), what));
                };
                let r = on
                    .serve(&duty, |n| match n {
                        DutyNote::Took(a, _) => say(format!("took {} to {}", a.task, a.to)),
                        DutyNote::Ended(o) if o.ok => say(format!("{} arrived", o.task)),
                        DutyNote::Ended(o) => say(format!(
                            "{} not arrived: {}",
                            o.task,
                            o.why.as_deref().unwrap_or("")
                        )),
                        DutyNote::Skipped(why) => say(format!("skipped {why}")),
                        DutyNote::Planner(_) => {}
                    })
                    .await;
                if let Err(e) = r {
                    say(format!("the planner failed: {e}"));
                }
            },
        ));
        crews.push(set);
    }
    let ds = DataClient::connect(&session, DataOptions::new("dispatcher")).await?;
    let d = Dispatcher::new(
        ds,
        session.clone(),
        root.clone(),
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
    for (id, spec) in &cfg.tasks {
        tasks::add_as(&adder, id, spec).await?;
    }
    let stepper = match clock {
        Some(clock) => rig.world.start_lockstep(clock, run.speed, |_| {}),
        None => rig.world.start(Some(run.wall_speed())),
    };

    let names: Vec<String> = run.routes.iter().map(|r| r.robot.clone()).collect();
    let mut statuses: BTreeMap<String, TaskStatus> = BTreeMap::new();
    let mut busy = vec![false; names.len()];
    let t0 = rig.world.lock().time_ms();
    let mut still: Vec<(u64, f64)> = vec![(t0, 0.0); names.len()];
    let mut longest = vec![0.0f64; names.len()];
    let mut tick = rome_clock::interval(run.period(1_000.0));
    let mut killed = false;
    loop {
        let ended = statuses.len() == cfg.tasks.len() && statuses.values().all(|s| s.state.ended());
        let now = rig.world.lock().time_ms();
        if ended || Duration::from_millis(now - t0) > run.limit {
            break;
        }
        tokio::select! {
            biased;
            Some(event) = rome_clock::idle(erx.recv()) => {
                match &event {
                    TaskEvent::Task(s, _) => {
                        statuses.insert(s.id.clone(), s.clone());
                    }
                    TaskEvent::Robot(name, what) => {
                        let k = names.iter().position(|n| n == name);
                        if let Some(k) = k {
                            busy[k] = what.starts_with("took ");
                            still[k] = (now, rig.world.lock().robot(rig.index[k]).travelled_mm);
                            if !killed && busy[k] && cfg.kill.as_deref() == Some(name.as_str()) {
                                // The whole crew dies at once, Planner too.
                                crews[k].abort_all();
                                killed = true;
                                busy[k] = false;
                            }
                        }
                    }
                }
                progress(event);
            }
            _ = tick.tick() => {
                for k in 0..names.len() {
                    let moved = rig.world.lock().robot(rig.index[k]).travelled_mm;
                    if !busy[k] || moved - still[k].1 >= 500.0 {
                        still[k] = (now, moved);
                    }
                    longest[k] = longest[k].max((now - still[k].0) as f64 / 1000.0);
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
    let mut contacts = BTreeMap::new();
    for (k, name) in names.iter().enumerate() {
        let t = rome_sim_hardware::truth::truth_of(&rig.world, rig.index[k]);
        contacts.insert(name.clone(), t.contacts);
    }
    let longest_still_s = names.iter().cloned().zip(longest).collect();
    rig.stop().await;
    Ok(TaskReport {
        statuses: statuses.into_values().collect(),
        contacts,
        longest_still_s,
        sim_s,
        wall: wall.elapsed(),
    })
}
