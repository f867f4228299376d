//! `rome dispatcher`, `rome task add | ls | cancel` and `rome planner
//! --tasks`: a fleet given errands (docs/tasks.md).
//!
//! ```text
//! rome dispatcher --map eb3 &
//! rome planner --robot r1 --from 350R --tasks &      (and each robot's crew)
//! rome task add --to 376L
//! rome task ls
//! rome task cancel T4 --why "not needed"
//! rome task robots
//! ```

use crate::args::{CommonArgs, Side};
use crate::exit;
use anyhow::Context;
use rome_client::RobotClient;
use rome_maps::{Network, World};
use rome_nav::board::Board;
use rome_nav::fleet::dispatcher::{now_ms, DispatchConfig, Dispatcher, Note};
use rome_nav::fleet::duty::{DutyConfig, DutyNote, OnDuty};
use rome_nav::fleet::schema::{DutyState, TaskSpec, TaskState, STATUS_PREFIX};
use rome_nav::fleet::tasks;
use rome_nav::planner::Progress;
use rome_nav::traffic;

/// Flags of `rome dispatcher`.
#[derive(Debug, clap::Args)]
pub struct DispatcherArgs {
    /// Map routes are measured on: a built-in name (eb3, annex, campus, fig5_3)
    /// or a .stk file; the robots' Planners must use the same.
    #[arg(long, default_value = "eb3")]
    map: String,
    /// Longest time between two looks at the fleet, seconds (a crew that
    /// died is noticed within it).
    #[arg(long, default_value_t = 1.0, value_name = "SECS")]
    every: f64,
    /// Measure routes with the narrow corridors of loops one way, as the
    /// robots' Planners do with `--one-way` (docs/traffic.md).
    #[arg(long)]
    one_way: bool,
}

/// `rome task …`.
#[derive(Debug, clap::Subcommand)]
pub enum TaskCmd {
    /// Add a task: a robot is to go to a position.
    Add(AddArgs),
    /// List the tasks and where each stands.
    Ls(LsArgs),
    /// Cancel a task; a robot driving it stops where it is.
    Cancel(CancelArgs),
    /// List the robots taking tasks: where each stands, what it does, how its last task went.
    Robots,
}

/// Flags of `rome task add`.
#[derive(Debug, clap::Args)]
pub struct AddArgs {
    /// Where to go: a position of the map, such as 376L.
    #[arg(long)]
    to: String,
    /// Only this robot may do it.
    #[arg(long)]
    robot: Option<String>,
    /// Higher goes first.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    priority: i64,
    /// Positions to go through on the way, comma-separated.
    #[arg(long, value_delimiter = ',', value_name = "POS")]
    via: Vec<String>,
    /// The task's id (one word); without it the next free number, T1, T2 …
    #[arg(long)]
    id: Option<String>,
    /// Wait until the task ends; exit 0 if done, 1 if it failed or was
    /// cancelled.
    #[arg(long)]
    wait: bool,
}

/// Flags of `rome task ls`.
#[derive(Debug, clap::Args)]
pub struct LsArgs {
    /// One JSON object a line (id, spec, status) instead of a table.
    #[arg(long)]
    json: bool,
}

/// Flags of `rome task cancel`.
#[derive(Debug, clap::Args)]
pub struct CancelArgs {
    /// The task.
    id: String,
    /// Why, for its status.
    #[arg(long)]
    why: Option<String>,
}

/// `rome dispatcher`: hands tasks to robots until interrupted.
pub async fn dispatcher(common: &CommonArgs, args: DispatcherArgs) -> anyhow::Result<u8> {
    let every = rome_common::seconds("--every", args.every)?;
    let map = rome_maps::load_named(&args.map)?;
    let world = World::from_map(&map);
    let network = rome_nav::traffic::oneway::network(&map, &world, args.one_way);
    let ds = rome_common::connect_data(common, "dispatcher").await?;
    let session = common.open(Side::Client).await?;
    let cfg = DispatchConfig { every };
    let d = Dispatcher::new(ds, session, world, network, cfg);
    d.run(|n| match n {
        Note::Waiting => println!("another dispatcher runs; waiting to take over"),
        Note::Running { tasks } => println!(
            "dispatching on {} ({tasks} open task(s) taken up)",
            args.map
        ),
        Note::Task(s, what) => println!("{} ({}): {what}", s.id, s.to),
        Note::Round(why) => eprintln!("rome dispatcher: {why}"),
    })
    .await?;
    Ok(exit::OK)
}

/// `rome task …`.
pub async fn task(common: &CommonArgs, cmd: TaskCmd) -> anyhow::Result<u8> {
    let ds = rome_common::connect_data(common, "cli").await?;
    match cmd {
        TaskCmd::Add(a) => {
            let spec = TaskSpec {
                to: a.to,
                robot: a.robot,
                priority: a.priority,
                via: a.via,
            };
            let id = match &a.id {
                Some(id) => {
                    tasks::add_as(&ds, id, &spec).await?;
                    id.clone()
                }
                None => tasks::add(&ds, &spec).await?,
            };
            println!("{id}");
            if !a.wait {
                return Ok(exit::OK);
            }
            wait_for(&ds, &id).await
        }
        TaskCmd::Ls(a) => {
            let all = tasks::list(&ds).await?;
            if a.json {
                for t in &all {
                    let line = serde_json::json!({
                        "id": t.id,
                        "spec": t.spec.as_ref().ok(),
                        "status": t.status,
                    });
                    println!("{line}");
                }
                return Ok(exit::OK);
            }
            println!(
                "{:<8} {:<9} {:<6} {:<8} {:>4} {:>8}  WHY",
                "ID", "STATE", "ROBOT", "TO", "PRIO", "WAITED"
            );
            let now = now_ms();
            for t in &all {
                let (to, prio) = match &t.spec {
                    Ok(s) => (s.to.as_str(), s.priority.to_string()),
                    Err(_) => ("?", "?".into()),
                };
                let s = t.status.as_ref();
                let waited = s.map_or(String::new(), |s| {
                    format!("{:.1} s", s.waited_ms(now) as f64 / 1000.0)
                });
                let why = s.map_or(String::new(), |s| s.why.join("; "));
                println!(
                    "{:<8} {:<9} {:<6} {:<8} {:>4} {:>8}  {why}",
                    t.id,
                    t.state(),
                    s.and_then(|s| s.robot.as_deref()).unwrap_or("-"),
                    to,
                    prio,
                    waited
                );
            }
            if all.iter().any(|t| t.status.is_none()) {
                println!("(tasks marked new have not been seen by a dispatcher: is `rome dispatcher` running?)");
            }
            Ok(exit::OK)
        }
        TaskCmd::Robots => {
            println!(
                "{:<6} {:<5} {:<12} {:<8}  LAST",
                "ROBOT", "STATE", "AT", "TASK"
            );
            for (robot, duty) in tasks::robots(&ds).await? {
                let d = match duty {
                    Ok(d) => d,
                    Err(why) => {
                        println!("{robot:<6} ?      {why}");
                        continue;
                    }
                };
                let state = match d.state {
                    DutyState::Idle => "idle",
                    DutyState::Busy => "busy",
                    DutyState::Lost => "lost",
                };
                let last = match &d.last {
                    None => String::new(),
                    Some(o) if o.ok => format!("{} arrived", o.task),
                    Some(o) => {
                        format!("{} not arrived: {}", o.task, o.why.as_deref().unwrap_or(""))
                    }
                };
                println!(
                    "{robot:<6} {state:<5} {:<12} {:<8}  {last}",
                    d.at,
                    d.task.as_deref().unwrap_or("-")
                );
            }
            Ok(exit::OK)
        }
        TaskCmd::Cancel(a) => {
            tasks::cancel(&ds, &a.id, a.why.as_deref()).await?;
            println!("asked the dispatcher to cancel {}", a.id);
            Ok(exit::OK)
        }
    }
}

/// Follows a task's status until it ends.
async fn wait_for(ds: &rome_client::DataClient, id: &str) -> anyhow::Result<u8> {
    let name = format!("{STATUS_PREFIX}{id}");
    let mut watch = ds.watch(&name).await?;
    let mut last = None;
    loop {
        // The status as it is now, then each change.
        let status = match ds
            .get_as::<rome_nav::fleet::schema::TaskStatus>(&name)
            .await
        {
            Ok(s) => Some(s),
            Err(e) if e.code() == Some(rome_schema::ErrorCode::UnknownVariable) => None,
            Err(e) => return Err(e).context(format!("task {id}'s status is not one")),
        };
        if let Some(s) = status {
            let line = format!("{:?} {}", s.state, s.robot.as_deref().unwrap_or(""));
            if last.as_ref() != Some(&line) {
                eprintln!(
                    "{id}: {}{}",
                    state_word(s.state),
                    s.robot
                        .as_deref()
                        .map(|r| format!(" ({r})"))
                        .unwrap_or_default()
                );
                last = Some(line);
            }
            if s.state.ended() {
                for why in &s.why {
                    eprintln!("{id}: {why}");
                }
                return Ok(if s.state == TaskState::Done {
                    exit::OK
                } else {
                    exit::ERROR
                });
            }
        }
        match watch.next().await {
            Some(_) => {}
            None => anyhow::bail!("lost the data server while waiting for task {id}"),
        }
    }
}

fn state_word(s: TaskState) -> &'static str {
    match s {
        TaskState::Queued => "queued",
        TaskState::Assigned => "assigned",
        TaskState::Done => "done",
        TaskState::Failed => "failed",
        TaskState::Cancelled => "cancelled",
    }
}

/// A robot's Planner taking tasks, connected.
pub struct Duty {
    /// Its blackboard.
    pub board: Board,
    /// Its base.
    pub robot: RobotClient,
    /// The map's world.
    pub world: World,
    /// The map's routes.
    pub network: Network,
    /// Its name.
    pub name: String,
    /// Where it stands.
    pub at: String,
    /// Which way it faces.
    pub heading: Option<f64>,
    /// The rules it drives by.
    pub rules: rome_nav::traffic::Rules,
}

/// `rome planner --tasks`: takes tasks until interrupted.
pub async fn take_tasks(common: &CommonArgs, d: Duty) -> anyhow::Result<u8> {
    let session = common.open(Side::Client).await?;
    let truth = rome_client::sim::TruthClient::new(&session, &common.root()?, &d.name)?;
    let truth = match truth.get().await {
        Ok(_) => Some(truth),
        Err(e) => {
            eprintln!("rome planner: no ground truth ({e}); arrival is the Navigator's word");
            None
        }
    };
    let on = OnDuty {
        board: &d.board,
        robot: &d.robot,
        truth: truth.as_ref(),
        world: &d.world,
        network: &d.network,
        name: &d.name,
    };
    let mut cfg = DutyConfig::at(&d.at);
    cfg.facing = d.heading;
    cfg.rules = d.rules;
    println!("{} takes tasks at {}", d.name, d.at);
    on.serve(&cfg, |n| match n {
        DutyNote::Took(a, plan) => println!(
            "{}: to {} ({:.1} m, {} goal(s))",
            a.task,
            a.to,
            plan.route.length_mm / 1000.0,
            plan.steps.len()
        ),
        DutyNote::Planner(Progress::Waiting(part)) => {
            println!("waiting for {}", traffic::describe(part))
        }
        DutyNote::Planner(_) => {}
        DutyNote::Ended(o, _) if o.ok => println!("{}: arrived", o.task),
        DutyNote::Ended(o, at) => println!(
            "{}: not arrived: {}{}",
            o.task,
            o.why.as_deref().unwrap_or("no reason"),
            match at {
                Some(at) => format!("; goes on from {at}"),
                None => "; out of service".to_string(),
            }
        ),
        DutyNote::Skipped(why) => eprintln!("rome planner: skipped {why}"),
        DutyNote::NotAside(why, n) => {
            eprintln!(
                "rome planner: {}",
                rome_nav::fleet::aside::not_aside(&why, n)
            )
        }
        DutyNote::Resting(rest) => println!(
            "blocked twice in one place: out of service for {:.0} s, then drives itself clear",
            rest.as_secs_f64()
        ),
        DutyNote::Back(at) => println!("got clear to {at}; takes tasks again"),
        DutyNote::NotBack(why) => eprintln!("rome planner: did not get clear: {why}"),
        DutyNote::MadeWay(by, Ok(at)) => println!("made way for {by}: drove on to {at}"),
        DutyNote::MadeWay(by, Err(why)) => {
            eprintln!("rome planner: did not make way for {by}: {why}")
        }
        DutyNote::Apart(Ok(at)) => println!("waited beside another: drove on to {at}"),
        DutyNote::Apart(Err(why)) => {
            eprintln!("rome planner: did not drive on from beside another: {why}")
        }
    })
    .await?;
    Ok(exit::OK)
}
