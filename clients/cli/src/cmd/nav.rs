//! `rome planner | navigator | ctracker | mapper | plfinder`: each
//! navigation client of Chapter 5 as a process of its own, meeting the
//! others only through the data server (Table 5.4) and the robot's hardware
//! servers.
//!
//! ```text
//! rome data-server &  rome sim --at 350R &
//! rome navigator --robot r1 &  rome ctracker --robot r1 &
//! rome mapper --robot r1 &     rome plfinder --robot r1 &
//! rome planner --robot r1 --from 350R --to 376L
//! ```

use crate::args::{CommonArgs, Side};
use crate::exit;
use anyhow::Context;
use rome_client::{RobotClient, RobotOptions};
use rome_nav::board::{Board, GoalType};
use rome_nav::ctracker::{CTracker, TrackConfig};
use rome_nav::himm::{Himm, HimmConfig};
use rome_nav::navigator::{NavConfig, Navigator};
use rome_nav::plan::Plan;
use rome_nav::planner;
use rome_nav::plfinder::{PlConfig, PlFinder};

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
    /// Map: a built-in name (eb3, fig5_3) or a .stk file.
    #[arg(long, default_value = "eb3")]
    map: String,
    /// Start: a door jamb like 350R; the robot is registered there.
    #[arg(long)]
    from: String,
    /// Goal.
    #[arg(long)]
    to: String,
    /// Which way the robot faces at the start, degrees (North 0, West 90),
    /// if not already along the route: it is registered so and turned onto
    /// the route before the first goal.
    #[arg(long, allow_hyphen_values = true)]
    heading: Option<f64>,
    /// Print the plan and exit without driving.
    #[arg(long)]
    dry_run: bool,
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

async fn connect(
    common: &CommonArgs,
    robot: &str,
    role: &str,
) -> anyhow::Result<(Board, RobotClient)> {
    let ds = super::connect_data(common, role).await?;
    let session = common.open(Side::Client).await?;
    let mut options = RobotOptions::new(role);
    options.root = common.root()?;
    let rc = RobotClient::connect(&session, robot, options).await?;
    Ok((Board::new(ds, robot), rc))
}

/// `rome planner`: plans, registers the robot at the start, and hands the
/// goals over one by one.
pub async fn planner(common: &CommonArgs, args: PlannerArgs) -> anyhow::Result<u8> {
    let map = rome_maps::load_named(&args.map)?;
    let world = rome_maps::World::from_map(&map);
    let network = rome_maps::Network::new(&map, &world);
    let plan = Plan::new(&world, &network, &args.from, &args.to)?;
    println!(
        "plan {} -> {}: {:.3} m, {} corner(s)",
        args.from,
        args.to,
        plan.route.length_mm / 1_000.0,
        plan.route.turns
    );
    for line in plan.describe() {
        println!("  {line}");
    }
    if args.dry_run {
        return Ok(exit::OK);
    }
    let (board, robot) = connect(common, &args.robot.robot, "planner").await?;
    planner::put_down(&robot, &plan, args.heading)
        .await
        .context("cannot register the robot at the start")?;
    let total = plan.steps.len();
    let handed = planner::run(&board, &plan, |h| {
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
    })
    .await?;
    let p = robot.pose().await?;
    let (_, goal) = plan.ends();
    println!(
        "done: {} goal(s); odometry puts the robot {:.0} mm from {}",
        handed.len(),
        (f64::from(p.x_mm) - goal.0).hypot(f64::from(p.y_mm) - goal.1),
        args.to
    );
    Ok(exit::OK)
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
    Navigator::new(robot, board, cfg).run().await?;
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
    CTracker::new(robot, board, cfg).run(None).await?;
    Ok(exit::OK)
}

/// `rome mapper`.
pub async fn mapper(common: &CommonArgs, args: RobotArg) -> anyhow::Result<u8> {
    let (board, robot) = connect(common, &args.robot, "himm").await?;
    println!("local mapper (HIMM) for robot '{}'", args.robot);
    Himm::new(robot, board, HimmConfig::default()).run().await?;
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
    PlFinder::new(robot, board, cfg).run().await?;
    Ok(exit::OK)
}
