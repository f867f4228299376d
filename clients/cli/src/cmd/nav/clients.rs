//! `rome planner | navigator | ctracker | mapper | plfinder`: each
//! navigation client of Chapter 5 as a process of its own, meeting the
//! others only through the data server (Table 5.4) and the robot's hardware
//! servers.
//!
//! ```text
//! rome data-server &  rome sim --at 350R &   (they share port 7447)
//! rome navigator --robot r1 &  rome ctracker --robot r1 &
//! rome mapper --robot r1 &     rome plfinder --robot r1 &
//! rome planner --robot r1 --from 350R --to 376L
//! ```

use crate::args::{CommonArgs, Side};
use crate::exit;
use anyhow::Context;
use rome_client::sim::TruthClient;
use rome_client::{RobotClient, RobotOptions};
use rome_nav::board::{Board, GoalType};
use rome_nav::crew::{Member, Reports};
use rome_nav::ctracker::TrackConfig;
use rome_nav::himm::HimmConfig;
use rome_nav::navigator::NavConfig;
use rome_nav::plan::Plan;
use rome_nav::planner::{self, Progress};
use rome_nav::plfinder::PlConfig;
use rome_nav::report::{Ended, Report, ARRIVED_CM};
use rome_nav::traffic;

/// The robot a client works for.
#[derive(Debug, clap::Args)]
pub struct RobotArg {
    /// The robot's name.
    #[arg(long, default_value = "r1")]
    pub robot: String,
}

/// Flags of `rome planner`.
#[derive(Debug, clap::Args)]
pub struct PlannerArgs {
    #[command(flatten)]
    robot: RobotArg,
    /// Map: a built-in name (eb3, annex, campus, fig5_3) or a .stk file.
    #[arg(long, default_value = "eb3")]
    map: String,
    /// A building instead of one map (the built-in `tower` or `twin`, or a
    /// .bldg file): --from and --to are `FLOOR:POSITION`, and a route
    /// between floors rides an elevator (§5.4.6), which the robot's
    /// Navigator operates through the elevator's server (`rome sim
    /// --building`).
    #[arg(long, value_name = "BUILDING", conflicts_with_all = ["map", "tasks", "via", "traffic", "lanes", "one_way", "leave_junctions", "make_way"])]
    building: Option<String>,
    /// Start: a door jamb like 350R; the robot is registered there.
    #[arg(long)]
    from: String,
    /// Goal.
    #[arg(long, required_unless_present = "tasks")]
    to: Option<String>,
    /// Take goals from the fleet's dispatcher instead of --to: one task
    /// after another, each from where the last one ended
    /// (`rome dispatcher`, `rome task add`).
    #[arg(long, conflicts_with_all = ["to", "via", "dry_run", "timeout"])]
    tasks: bool,
    /// Positions to go through in order on the way (the long way round),
    /// comma-separated.
    #[arg(long, value_delimiter = ',', value_name = "POS")]
    via: Vec<String>,
    /// Which way the robot faces at the start, degrees (North 0, West 90),
    /// if not already along the route: it is registered so and turned onto
    /// the route before the first goal.
    #[arg(long, allow_hyphen_values = true)]
    heading: Option<f64>,
    /// Print the plan and exit without driving.
    #[arg(long)]
    dry_run: bool,
    #[command(flatten)]
    rules: super::traffic::TrafficArgs,
    /// Give up after this many seconds of wall time (exit status 3), with
    /// the goals judged so far; without it the Planner waits as long as the
    /// robot takes.
    #[arg(long, value_name = "SECS")]
    timeout: Option<f64>,
}

/// Flags of `rome navigator`.
#[derive(Debug, clap::Args)]
pub struct NavigatorArgs {
    #[command(flatten)]
    robot: RobotArg,
    /// Cruising speed, mm/s.
    #[arg(long, default_value_t = 400.0)]
    speed: f64,
}

/// Flags of `rome ctracker`.
#[derive(Debug, clap::Args)]
pub struct CTrackerArgs {
    #[command(flatten)]
    robot: RobotArg,
    /// Upward cameras, one child tracker each (repeat a camera to run two
    /// children on it; the token keeps them from counting a light twice).
    #[arg(long = "camera", default_values_t = vec!["up".to_string()])]
    cameras: Vec<String>,
}

/// Flags of `rome plfinder`.
#[derive(Debug, clap::Args)]
pub struct PlFinderArgs {
    #[command(flatten)]
    robot: RobotArg,
    /// Map whose plates name what is found.
    #[arg(long, default_value = "eb3")]
    map: String,
    /// The sideways camera.
    #[arg(long, default_value = "side")]
    camera: String,
}

/// How long a navigation client waits for its robot's servers at start.
const SERVERS_WAIT: std::time::Duration = std::time::Duration::from_secs(120);

async fn connect(
    common: &CommonArgs,
    robot: &str,
    role: &str,
) -> anyhow::Result<(Board, RobotClient)> {
    let ds = rome_common::connect_data(common, role).await?;
    let session = common.open(Side::Client).await?;
    let root = common.root()?;
    // Clients may start before the robot's servers (any order works, as
    // with the data server): wait for them rather than fail.
    for device in ["base", "proximity", "camera/up", "camera/side"] {
        let id = format!("{robot}/{device}");
        let quick = rome_client::alive::await_server(
            &session,
            &root,
            "robot",
            &id,
            std::time::Duration::from_millis(500),
        )
        .await;
        if quick.is_err() {
            eprintln!("rome {role}: waiting for robot {robot}'s {device} server…");
            rome_client::alive::await_server(&session, &root, "robot", &id, SERVERS_WAIT)
                .await
                .with_context(|| {
                    format!("robot {robot}'s {device} server is not running (is `rome sim` or the robot's servers up?)")
                })?;
        }
    }
    let mut options = RobotOptions::new(role);
    options.root = root;
    let rc = RobotClient::connect(&session, robot, options).await?;
    Ok((Board::new(ds, robot), rc))
}

/// A ground-truth client of `robot`, and the truth now if a simulator
/// answers: ground truth judges a run where a simulator gives it, and a
/// real robot is judged by its odometry only (`without` says what that
/// costs, on stderr).
async fn ground_truth(
    common: &CommonArgs,
    robot: &str,
    without: &str,
) -> anyhow::Result<(TruthClient, Option<rome_schema::sim::Truth>)> {
    let session = common.open(Side::Client).await?;
    let truth = TruthClient::new(&session, &common.root()?, robot)?;
    let now = match truth.get().await {
        Ok(t) => Some(t),
        Err(e) => {
            eprintln!("rome planner: no ground truth ({e}); {without}");
            None
        }
    };
    Ok((truth, now))
}

/// `run`, given up after `timeout` seconds of wall time if there is one
/// (`None`): the robot is then stopped rather than left driving
/// unattended, and the Planner says so.
async fn within<R>(
    timeout: Option<f64>,
    robot: &rome_client::RobotClient,
    name: &str,
    run: impl std::future::Future<Output = R>,
) -> Option<R> {
    let Some(t) = timeout else {
        return Some(run.await);
    };
    match tokio::time::timeout(std::time::Duration::from_secs_f64(t), run).await {
        Ok(r) => Some(r),
        Err(_) => {
            let _ = robot.stop(false).await;
            eprintln!("rome planner: gave up after {t} s; robot {name} stopped");
            None
        }
    }
}

/// `rome planner`: plans, registers the robot at the start, hands the
/// goals over one by one and judges each; ends with the run's row of Table
/// 6.1 and where ground truth puts the robot. Exits 1 when the robot ended
/// more than a metre from the goal.
pub async fn planner(common: &CommonArgs, args: PlannerArgs) -> anyhow::Result<u8> {
    if let Some(t) = args.timeout {
        anyhow::ensure!(
            t.is_finite() && t > 0.0,
            "--timeout must be a positive number of seconds, got {t}"
        );
    }
    if let Some(b) = &args.building {
        let building = rome_maps::load_building_named(b)
            .with_context(|| format!("cannot load the building '{b}'"))?;
        let to = args.to.clone().context("--to is needed with --building")?;
        let fp = rome_nav::floors::FloorPlan::new(&building, &args.from, &to)?;
        super::between::describe(&format!("plan {} -> {}", fp.from, fp.to), &fp);
        if args.dry_run {
            return Ok(exit::OK);
        }
        let robot_name = &args.robot.robot;
        let (board, robot) = connect(common, robot_name, "planner").await?;
        let (truth, start) = ground_truth(common, robot_name, "arrival is by odometry").await?;
        let truth = start.map(|_| truth);
        let run = super::between::drive(&board, &robot, truth.as_ref(), &fp, args.heading);
        return match within(args.timeout, &robot, robot_name, run).await {
            Some(done) => done,
            None => Ok(exit::NOT_ACQUIRED),
        };
    }
    let wall = std::time::Instant::now();
    let map = rome_maps::load_named(&args.map)?;
    let world = rome_maps::World::from_map(&map);
    let network = traffic::oneway::network(&map, &world, args.rules.one_way);
    let Some(to) = args.to.clone() else {
        let (board, robot) = connect(common, &args.robot.robot, "planner").await?;
        let duty = super::fleet::Duty {
            board,
            robot,
            world,
            network,
            name: args.robot.robot.clone(),
            at: args.from.clone(),
            heading: args.heading,
            rules: args.rules.to_rules(),
        };
        return super::fleet::take_tasks(common, duty).await;
    };
    args.rules.without_tasks()?;
    let plan = Plan::through(&world, &network, &args.from, &args.via, &to)?
        .keeping(&args.rules.to_rules());
    let via = if args.via.is_empty() {
        String::new()
    } else {
        format!(" via {}", args.via.join(", "))
    };
    println!(
        "plan {} -> {to}{via}: {:.3} m, {} corner(s)",
        args.from,
        plan.route.length_mm / 1_000.0,
        plan.route.turns
    );
    for line in plan.describe() {
        println!("  {line}");
    }
    for chain in traffic::chains(&plan.holds) {
        let parts: Vec<String> = chain
            .holds
            .iter()
            .map(|h| {
                format!(
                    "{} (to goal {})",
                    traffic::describe(&h.semaphore),
                    h.last + 1
                )
            })
            .collect();
        println!(
            "  before goal {}: takes {}",
            chain.first + 1,
            parts.join(", ")
        );
    }
    if args.dry_run {
        return Ok(exit::OK);
    }
    let robot_name = &args.robot.robot;
    let (board, robot) = connect(common, robot_name, "planner").await?;
    let (truth, start) = ground_truth(
        common,
        robot_name,
        "C and D goals are not judged, and arrival is by odometry",
    )
    .await?;
    planner::put_down(&robot, &plan, args.heading)
        .await
        .context("cannot register the robot at the start")?;
    let total = plan.steps.len();
    let run = planner::run(&board, &plan, start.as_ref().map(|_| &truth), |p| match p {
        Progress::Handed(h) => {
            let g = &h.step.goal;
            let unit = if g.goal_type == GoalType::L {
                "light(s)"
            } else {
                "mm"
            };
            println!(
                "[goal {}/{total}] {:?} {} {unit} heading {:.0}°",
                h.index + 1,
                g.goal_type,
                g.distance,
                g.direction_deg
            );
        }
        Progress::Done(h) => match &h.failure {
            Some(why) => println!("[goal {}/{total}] failed: {why}", h.index + 1),
            None => println!("[goal {}/{total}] done", h.index + 1),
        },
        Progress::Waiting(part) => println!("waiting for {}", traffic::describe(part)),
        Progress::Holding(part, true) => println!("in {}", traffic::describe(part)),
        Progress::Holding(part, false) => println!("out of {}", traffic::describe(part)),
    });
    let handed = match within(args.timeout, &robot, robot_name, run).await {
        Some(handed) => handed?,
        None => return Ok(exit::NOT_ACQUIRED),
    };
    let p = robot.pose().await?;
    let odometry = rome_maps::geometry::Pose::from(&p).at;
    let (_, goal) = plan.ends();
    let by_odometry = rome_maps::geometry::distance(odometry, goal);
    let end = match start {
        Some(_) => truth.get().await.ok(),
        None => None,
    };
    let (Some(start), Some(end)) = (start, end) else {
        println!(
            "done: {} goal(s); no ground truth: odometry puts the robot {:.2} m from {}",
            handed.len(),
            by_odometry / 1_000.0,
            to
        );
        return Ok(if by_odometry <= ARRIVED_CM * 10.0 {
            exit::OK
        } else {
            exit::ERROR
        });
    };
    let report = Report::new(Ended {
        robot: robot_name.clone(),
        from: args.from.clone(),
        to: to.clone(),
        plan,
        steps: handed,
        truth: (start, end),
        odometry: Some(odometry),
        odometry_max_error_mm: None,
        wall_time: wall.elapsed(),
        failure: None,
    });
    println!();
    println!("{}", report.table());
    for why in report.reasons() {
        println!("{why}");
    }
    println!(
        "done: {} goal(s); ground truth puts {robot_name} {:.2} m from {} ({:+.0} cm along, {:.0} cm across); odometry is {:.2} m off",
        report.steps.len(),
        report.miss_cm / 100.0,
        to,
        report.to_goal_cm,
        report.off_line_cm,
        report.odometry_error_cm.unwrap_or(0.0) / 100.0
    );
    Ok(if report.arrived() {
        exit::OK
    } else {
        exit::ERROR
    })
}

/// `rome navigator`.
pub async fn navigator(common: &CommonArgs, args: NavigatorArgs) -> anyhow::Result<u8> {
    anyhow::ensure!(
        args.speed.is_finite() && args.speed > 0.0 && args.speed <= 1_000.0,
        "--speed must be in 0..=1000 mm/s, got {}",
        args.speed
    );
    let (board, robot) = connect(common, &args.robot.robot, "navigator").await?;
    let cfg = NavConfig {
        cruise_mm_s: args.speed,
        ..NavConfig::default()
    };
    println!(
        "navigator for robot '{}': waiting for goals",
        args.robot.robot
    );
    Member::Navigator(cfg)
        .run(robot, board, Reports::default())
        .await?;
    Ok(exit::OK)
}

/// `rome ctracker`.
pub async fn ctracker(common: &CommonArgs, args: CTrackerArgs) -> anyhow::Result<u8> {
    let (board, robot) = connect(common, &args.robot.robot, "ctracker").await?;
    let cfg = TrackConfig {
        cameras: args.cameras,
        ..TrackConfig::default()
    };
    println!(
        "ctracker for robot '{}': {} child tracker(s) on {:?}",
        args.robot.robot,
        cfg.cameras.len(),
        cfg.cameras
    );
    Member::CTracker(cfg)
        .run(robot, board, Reports::default())
        .await?;
    Ok(exit::OK)
}

/// `rome mapper`.
pub async fn mapper(common: &CommonArgs, args: RobotArg) -> anyhow::Result<u8> {
    let (board, robot) = connect(common, &args.robot, "mapper").await?;
    println!("local mapper (HIMM) for robot '{}'", args.robot);
    Member::Mapper(HimmConfig::default())
        .run(robot, board, Reports::default())
        .await?;
    Ok(exit::OK)
}

/// `rome plfinder`.
pub async fn plfinder(common: &CommonArgs, args: PlFinderArgs) -> anyhow::Result<u8> {
    let map = rome_maps::load_named(&args.map)?;
    let world = rome_maps::World::from_map(&map);
    let (board, robot) = connect(common, &args.robot.robot, "plfinder").await?;
    let cfg = PlConfig {
        camera: args.camera,
        ..PlConfig::with_map(&world)
    };
    println!(
        "plate finder for robot '{}' on camera '{}'",
        args.robot.robot, cfg.camera
    );
    Member::PlFinder(cfg)
        .run(robot, board, Reports::default())
        .await?;
    Ok(exit::OK)
}
