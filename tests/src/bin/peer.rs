//! `rome-test-peer`: one client role in its own process, for tests that
//! need real separate processes (and a process to SIGKILL).

use clap::{Parser, Subcommand};
use rome_client::goals::{self, Goal, GoalType};
use rome_client::net::NetOptions;
use rome_client::{DataClient, DataOptions, RobotClient, RobotOptions};

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
    /// Hand N goals over (Table 5.4), goal i having GoalDistance i.
    Planner {
        #[arg(long)]
        goals: u32,
    },
    /// Take N goals, printing each as a JSON line.
    Navigator {
        #[arg(long)]
        goals: u32,
    },
    /// Block on a semaphore; prints "acquired" if it ever gets a unit.
    Waiter {
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
        direction_deg: i64::from(i % 360),
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
        Role::Planner { goals: n } => {
            goals::declare(&ds).await?;
            for i in 0..n {
                goals::hand_over(&ds, &goal(i)).await?;
            }
        }
        Role::Navigator { goals: n } => {
            goals::declare(&ds).await?;
            for _ in 0..n {
                let g = goals::take(&ds).await?;
                println!("{}", serde_json::to_string(&g)?);
                goals::done(&ds).await?;
            }
        }
        Role::Waiter { sem } => {
            ds.wait(&sem).await?;
            println!("acquired");
        }
        Role::Locker { .. } => {}
    }
    session.close().await.map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok(())
}
