//! `rome ls`: the live servers and clients, from liveliness tokens.

use crate::args::{CommonArgs, Side};
use crate::exit;
use std::time::Duration;

/// Flags of `rome ls`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// How long to collect answers, in seconds.
    #[arg(long, default_value_t = 2.0)]
    pub timeout: f64,
}

/// Lists who is alive.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    anyhow::ensure!(
        args.timeout.is_finite() && args.timeout > 0.0,
        "--timeout must be a positive number of seconds"
    );
    let session = common.open(Side::Client).await?;
    let root = common.root()?;
    // Peers learn each other's tokens just after connecting; a liveliness
    // subscriber with history waits for that instead of guessing.
    let people =
        rome_client::alive::list(&session, &root, Duration::from_secs_f64(args.timeout)).await?;
    if args.json {
        let rows: Vec<_> = people
            .iter()
            .map(
                |p| serde_json::json!({"class": p.class, "role": p.role, "id": p.id, "key": p.key}),
            )
            .collect();
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else if people.is_empty() {
        eprintln!(
            "nothing alive under '{}' (is a server running, and --connect right?)",
            root.as_str()
        );
    } else {
        println!("{:6}  {:16}  ID", "CLASS", "ROLE");
        for p in &people {
            println!("{:6}  {:16}  {}", p.class, p.role, p.id);
        }
    }
    Ok(exit::OK)
}
