//! `rome bench`: how fast the servers and the simulator are, each figure
//! beside a bare-Zenoh (or echo, or Redis, or etcd) reference measured in
//! the same run.
//!
//! How this module is laid out:
//! - [`data`]: the data server against a bare queryable (`rome bench
//!   data`), the rows every benchmark prints, and the turns they are
//!   measured in;
//! - [`robot`]: hardware-server round trips; [`sim`]: the simulator's
//!   pace; [`mem`]: resident memory;
//! - [`all`]: every benchmark in one run, with targets and the Markdown
//!   section of docs/benchmarks.md.

pub mod all;
pub mod data;
pub mod mem;
mod peers;
pub mod robot;
pub mod sim;

use clap::Subcommand;
use rome_common::exit;

/// The `rome bench` commands.
#[derive(Debug, Subcommand)]
pub enum BenchCmd {
    /// Data server get/set/signal vs a bare Zenoh queryable, on loopback.
    Data(data::DataBench),
    /// Simulated seconds per wall-clock second for 1..1000 robots on a map.
    Sim(sim::SimBench),
    /// Hardware-server round trips (pose, sonar, camera rows) and scan-stream rate.
    Robot(robot::RobotBench),
    /// Resident memory: a data server holding 100 000 variables, `rome sim --robots 100`.
    Mem(mem::MemBench),
    /// Every benchmark in one run: figures, ratios, targets, JSON, and the Markdown section.
    All(all::AllBench),
    /// The far end of `rome bench data`: a data server and a bare queryable
    /// on one loopback port, printed on stdout; ends when stdin closes.
    #[command(hide = true)]
    Serve(data::ServeArgs),
}

/// Runs a `rome bench` command.
pub async fn run(cmd: BenchCmd) -> anyhow::Result<u8> {
    match cmd {
        BenchCmd::Data(args) => {
            let rows = data::data_rows(&args, !args.json).await?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&rows)?);
            } else {
                print!("{}", data::table(&rows));
            }
        }
        BenchCmd::Robot(args) => {
            let figures = robot::figures(&args, !args.json).await?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&figures)?);
            } else {
                print!("{}", data::table(&figures.rows));
                println!(
                    "scan stream (world free-running): {:.0} scans/s, {} lost",
                    figures.scans_per_s, figures.scans_lost
                );
            }
        }
        BenchCmd::Mem(args) => {
            let f = mem::figures(&args, !args.json).await?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&f)?);
            } else {
                print!("{}", mem::table(&f));
            }
        }
        BenchCmd::All(args) => all::run(&args).await?,
        BenchCmd::Serve(args) => data::serve(args).await?,
        BenchCmd::Sim(args) => {
            let rows = tokio::task::spawn_blocking(move || {
                let rows = sim::rows(&args);
                (args, rows)
            })
            .await?;
            let (args, rows) = (rows.0, rows.1?);
            if args.json {
                println!("{}", serde_json::to_string_pretty(&rows)?);
            } else {
                print!("{}", sim::table(&rows));
            }
        }
    }
    Ok(exit::OK)
}
