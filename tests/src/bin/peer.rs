//! `rome-test-peer`: one client role in its own process, for tests that
//! need real separate processes (and a process to SIGKILL).

use clap::{Parser, Subcommand};
use rome_client::net::NetOptions;
use rome_client::{DataClient, DataOptions, RobotClient, RobotOptions};
use rome_nav::board::{Board, Goal, GoalType, Sem};

#[derive(Parser)]
struct Args {
    /// The data server's port on 127.0.0.1.
    #[arg(long)]
    port: u16,
    #[command(subcommand)]
    role: Role,
}

#[derive(Subcommand)]
enum Role {
    /// Hand N goals over to one robot's Navigator through its blackboard
    /// (Table 5.4), goal i having GoalDistance i.
    Planner {
        #[arg(long)]
        goals: u32,
        #[arg(long, default_value = "r1")]
        robot: String,
    },
    /// Take N goals from one robot's blackboard, printing each as a JSON
    /// line.
    Navigator {
        #[arg(long)]
        goals: u32,
        #[arg(long, default_value = "r1")]
        robot: String,
    },
    /// Block on a semaphore; prints "acquired" if it ever gets a unit.
    Waiter {
        #[arg(long)]
        sem: String,
    },
    /// Take a unit with an undo wait, print "held" and keep it until killed
    /// (a robot's Planner inside a narrow passage).
    Holder {
        #[arg(long)]
        sem: String,
    },
    /// Take a robot's base lock, print the grant as a JSON line and hold
    /// it (renewing) until killed.
    Locker {
        #[arg(long)]
        robot: String,
    },
}

fn goal(i: u32) -> Goal {
    let kinds = [GoalType::L, GoalType::D, GoalType::C, GoalType::E];
    Goal {
        goal_type: kinds[i as usize % kinds.len()],
        distance: i64::from(i),
        direction_deg: f64::from(i % 360),
    }
}

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let session = NetOptions::loopback(None, &[args.port]).open().await?;
    let role = match &args.role {
        Role::Planner { .. } => "planner",
        Role::Navigator { .. } => "navigator",
        Role::Waiter { .. } => "waiter",
        Role::Holder { .. } => "holder",
        Role::Locker { robot } => {
            let r = RobotClient::connect(&session, robot, RobotOptions::new("locker")).await?;
            let lock = r.lock().await?;
            println!("{}", serde_json::to_string(lock.grant())?);
            std::future::pending::<()>().await;
            return Ok(());
        }
    };
    let ds = DataClient::connect(&session, DataOptions::new(role)).await?;
    match args.role {
        Role::Planner { goals: n, robot } => {
            let board = Board::new(ds, &robot);
            board.declare().await?;
            for i in 0..n {
                board.give_goal(&goal(i)).await?;
                board.down(Sem::RobotStatus).await?;
            }
        }
        Role::Navigator { goals: n, robot } => {
            let board = Board::new(ds, &robot);
            board.declare().await?;
            for _ in 0..n {
                let g = board.take_goal().await?;
                println!("{}", serde_json::to_string(&g)?);
                board.up(Sem::RobotStatus).await?;
            }
        }
        Role::Waiter { sem } => {
            ds.wait(&sem).await?;
            println!("acquired");
        }
        Role::Holder { sem } => {
            ds.wait_undo(&sem).await?;
            println!("held");
            std::future::pending::<()>().await;
        }
        Role::Locker { .. } => {}
    }
    session.close().await.map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(())
}
