//! What every `rome` command shares, whichever crate holds it.
//!
//! How this crate is laid out:
//! - [`args`]: [`CommonArgs`], the Zenoh and deployment
//!   flags of every command (`--connect`, `--listen`, `--mode`, `--config`,
//!   `--no-multicast`, `--root`, `--identity` …), turned into network
//!   options in one place.
//! - [`exit`]: the exit codes, documented in `rome --help`, the interrupt
//!   signal, and [`out!`] for output that may go to a closed pipe.
//! - [`progress`]: progress bars on a terminal, plain lines elsewhere.
//! - [`supervise`]: keeps a set of `rome` processes running, restarting
//!   each that ends with a back-off (`rome crew`).
//! - [`time`]: flags of seconds and minutes turned into durations, with
//!   a clear error where converting would panic.
//! - Here: reaching the data server from the flags, and the checks of
//!   flags several commands take.

pub mod args;
pub mod exit;
pub mod progress;
pub mod supervise;
pub mod time;

pub use time::{check_positive, minutes, seconds};

use anyhow::Context;
use args::{CommonArgs, Side};
use rome_client::{DataClient, DataOptions};

/// Checks a `--cruise` speed: mm/s, above 0 and at most 1000.
pub fn check_cruise(mm_s: f64) -> anyhow::Result<()> {
    anyhow::ensure!(
        mm_s.is_finite() && mm_s > 0.0 && mm_s <= 1_000.0,
        "--cruise must be a speed in mm/s in 0..=1000, got {mm_s}"
    );
    Ok(())
}

/// Opens a client session and connects to the data server.
pub async fn connect_data(common: &CommonArgs, role: &str) -> anyhow::Result<DataClient> {
    let connect_timeout = seconds("--connect-timeout", common.connect_timeout)?;
    let session = common.open(Side::Client).await?;
    let mut options = DataOptions::new(role);
    options.root = common.root()?;
    options.connect_timeout = connect_timeout;
    DataClient::connect(&session, options).await.context(
        "cannot reach the data server (start one with `rome data-server`, or pass --connect)",
    )
}

/// A Zenoh session that talks to nobody (no listening, no scouting), for
/// a command's tests in this process.
///
/// # Panics
///
/// When Zenoh cannot open a session at all: a test cannot go on then.
pub async fn isolated_session() -> zenoh::Session {
    let config = rome_client::net::NetOptions::isolated()
        .to_config()
        .expect("an isolated session's configuration");
    zenoh::open(config).await.expect("an isolated session")
}
