//! `rome sem …`: semaphores. Thesis names with `$` work as they are
//! (`$GoalData` is the semaphore `GoalData`).

use crate::args::CommonArgs;
use crate::exit;
use clap::Subcommand;
use rome_common::connect_data;
use std::time::Duration;

/// The `rome sem` commands.
#[derive(Debug, Subcommand)]
pub enum SemCmd {
    /// Create a semaphore with an initial value (an existing one is left as it is).
    Create {
        /// The semaphore ($GoalData or GoalData).
        name: String,
        /// Its initial value.
        value: u64,
    },
    /// up(): add a unit, waking the first waiter.
    Signal {
        /// The semaphore.
        name: String,
    },
    /// down(): take a unit, blocking until one is there.
    Wait {
        /// The semaphore.
        name: String,
        /// Give up after this many seconds (exit code 3).
        #[arg(short, long, value_name = "SECS")]
        timeout: Option<f64>,
    },
    /// Take a unit only if one is free now (exit code 3 if not).
    TryWait {
        /// The semaphore.
        name: String,
    },
    /// Show a semaphore's value, waiters and units held with undo.
    Get {
        /// The semaphore.
        name: String,
    },
    /// List the semaphores.
    Ls {
        /// JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
}

/// Runs a `rome sem` command.
pub async fn run(common: &CommonArgs, cmd: SemCmd) -> anyhow::Result<u8> {
    let ds = connect_data(common, "cli").await?;
    match cmd {
        SemCmd::Create { name, value } => {
            let r = ds.create_semaphore(&name, value).await?;
            if r.created {
                println!("created {} = {}", r.name, r.value);
            } else {
                println!("{} exists, value {} (left as it is)", r.name, r.value);
            }
        }
        SemCmd::Signal { name } => {
            let r = ds.signal(&name).await?;
            let woke = if r.woke { ", woke a waiter" } else { "" };
            println!("{} = {}{woke}", r.name, r.value);
        }
        SemCmd::Wait { name, timeout } => {
            let acquired = match timeout {
                None => {
                    ds.wait(&name).await?;
                    true
                }
                Some(secs) => {
                    anyhow::ensure!(
                        secs.is_finite() && secs >= 0.0,
                        "--timeout must be a non-negative number of seconds, got {secs}"
                    );
                    ds.wait_timeout(&name, Duration::from_secs_f64(secs))
                        .await?
                }
            };
            if !acquired {
                eprintln!("timed out waiting for {name}");
                return Ok(exit::NOT_ACQUIRED);
            }
            println!("acquired {name}");
        }
        SemCmd::TryWait { name } => {
            if !ds.try_wait(&name).await? {
                eprintln!("{name}: no unit free");
                return Ok(exit::NOT_ACQUIRED);
            }
            println!("acquired {name}");
        }
        SemCmd::Get { name } => {
            let s = ds.semaphore(&name).await?;
            // Units held with undo come back by themselves if their holder
            // dies: a lane's robots, a narrow passage's one.
            let held = if s.held > 0 {
                format!(", {} held with undo", s.held)
            } else {
                String::new()
            };
            println!("{} = {} ({} waiting{held})", s.name, s.value, s.waiters);
        }
        SemCmd::Ls { json } => {
            let sems = ds.semaphores().await?;
            if json {
                println!("{}", serde_json::to_string_pretty(&sems)?);
            } else if sems.is_empty() {
                eprintln!("no semaphores yet");
            } else {
                let width = sems.iter().map(|s| s.name.len()).max().unwrap_or(4).max(4);
                println!(
                    "{:width$}  {:>6}  {:>7}  {:>4}",
                    "NAME", "VALUE", "WAITING", "HELD"
                );
                for s in &sems {
                    println!(
                        "{:width$}  {:>6}  {:>7}  {:>4}",
                        s.name, s.value, s.waiters, s.held
                    );
                }
            }
        }
    }
    Ok(exit::OK)
}
