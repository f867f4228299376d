//! One module per command group.

pub mod bench;
pub mod bench_all;
pub mod bench_mem;
pub mod bench_robot;
pub mod bench_sim;
pub mod certs;
pub mod colony;
pub mod data;
pub mod data_server;
pub mod demo;
pub mod echo;
pub mod experiment;
pub mod foxglove;
pub mod fuzz;
pub mod ls;
pub mod map;
pub mod nav;
pub mod pioneer;
pub mod record;
pub mod replay;
pub mod robot;
pub mod router;
pub mod sem;
pub mod sim;
pub mod soak;
pub mod storage;
pub mod view;

use crate::args::{CommonArgs, Side};
use anyhow::Context;
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
    let session = common.open(Side::Client).await?;
    anyhow::ensure!(
        common.connect_timeout.is_finite() && common.connect_timeout > 0.0,
        "--connect-timeout must be a positive number of seconds, got {}",
        common.connect_timeout
    );
    let mut options = DataOptions::new(role);
    options.root = common.root()?;
    options.connect_timeout = std::time::Duration::from_secs_f64(common.connect_timeout);
    DataClient::connect(&session, options).await.context(
        "cannot reach the data server (start one with `rome data-server`, or pass --connect)",
    )
}

/// A Zenoh session that talks to nobody (no listening, no scouting), for
/// a command's tests in this process.
#[cfg(test)]
pub(crate) async fn isolated_session() -> zenoh::Session {
    let config = rome_client::net::NetOptions::isolated()
        .to_config()
        .expect("an isolated session's configuration");
    zenoh::open(config).await.expect("an isolated session")
}
