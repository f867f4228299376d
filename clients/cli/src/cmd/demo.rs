//! `rome demo`: everything in one process on one in-process Zenoh
//! session, no router and no configuration.
//!
//! Today it runs the data server with a Planner and a Navigator client
//! handing goals over exactly as Table 5.4 prescribes, and shows a
//! variable's history; the simulated robot joins it as the rest of the
//! system lands.

use crate::args::CommonArgs;
use crate::exit;
use rome_client::goals::{self, Goal, GoalType};
use rome_client::net::NetOptions;
use rome_client::{DataClient, DataOptions};
use std::time::Instant;

/// Flags of `rome demo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// How many goals the Planner hands to the Navigator.
    #[arg(long, default_value_t = 6)]
    pub goals: u32,
}

/// A made-up route from room 350 to room 376: light tracking, dead
/// reckoning to a corner, leaving the corner, and so on.
fn route(n: u32) -> Vec<Goal> {
    let pattern = [
        (GoalType::L, 4, 0),
        (GoalType::D, 3200, 0),
        (GoalType::C, 1800, 90),
        (GoalType::L, 6, 90),
        (GoalType::D, 2500, 90),
        (GoalType::E, 900, 180),
    ];
    (0..n as usize)
        .map(|i| {
            let (goal_type, distance, direction_deg) = pattern[i % pattern.len()];
            Goal {
                goal_type,
                distance,
                direction_deg,
            }
        })
        .collect()
}

/// Runs the demo.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let started = Instant::now();
    let session = NetOptions::isolated().open().await?;
    let root = common.root()?;
    let server = rome_data::spawn(
        session.clone(),
        rome_data::ServerConfig {
            root: root.clone(),
            ..Default::default()
        },
    );
    let options = |role: &str| DataOptions {
        root: root.clone(),
        ..DataOptions::new(role)
    };
    let planner = DataClient::connect(&session, options("planner")).await?;
    let navigator = DataClient::connect(&session, options("navigator")).await?;
    println!(
        "data server up under '{}' ({:.0?})",
        root.as_str(),
        started.elapsed()
    );

    // The one set/get, and the history the thesis' DataGetValue(-N) reads.
    planner.set_history("PosX", 4).await?;
    for x in [1000, 1250, 1500] {
        planner.set("PosX", &x).await?;
    }
    println!(
        "PosX = {} (one write ago {}, two ago {})",
        planner.get("PosX").await?,
        planner.get_back("PosX", 1).await?,
        planner.get_back("PosX", 2).await?
    );

    goals::declare(&planner).await?;
    let plan = route(args.goals);
    let total = plan.len();
    let nav = tokio::spawn(async move {
        let mut seen = Vec::new();
        for _ in 0..total {
            let goal = goals::take(&navigator).await?;
            seen.push(goal);
            goals::done(&navigator).await?;
        }
        Ok::<_, rome_client::ClientError>(seen)
    });
    for (i, goal) in plan.iter().enumerate() {
        goals::hand_over(&planner, goal).await?;
        let unit = if goal.goal_type == GoalType::L {
            "lights"
        } else {
            "mm"
        };
        println!(
            "[{}/{total}] planner -> navigator: GoalType {:?}, GoalDistance {} {unit}, GoalDirection {}°",
            i + 1,
            goal.goal_type,
            goal.distance,
            goal.direction_deg
        );
    }
    let seen = nav.await??;
    anyhow::ensure!(
        seen == plan,
        "the navigator received {seen:?}, expected {plan:?}"
    );
    println!(
        "navigator received all {total} goals in order via $GoalData/$RobotStatus ({:.0?} in all)",
        started.elapsed()
    );
    server.stop().await?;
    let _ = session.close().await;
    Ok(exit::OK)
}
