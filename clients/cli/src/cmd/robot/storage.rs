//! `rome storage`: a Zenoh storage in memory for the servers' lock state,
//! for deployments without a router's storage manager.

use crate::args::CommonArgs;
use crate::exit;

/// Flags of `rome storage`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The key expression to store [default: ROOT/store/**].
    #[arg(long, value_name = "KEYEXPR")]
    pub key: Option<String>,
}

/// Runs the storage until Ctrl-C or SIGTERM.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let root = common.root()?;
    let key = args.key.unwrap_or_else(|| root.store_all());
    let (session, net) = common.open_server().await?;
    eprintln!(
        "rome storage: keeping '{key}' (listen {:?}, connect {:?}); Ctrl-C to stop",
        net.listen, net.connect
    );
    rome_hardware::storage::run(session.clone(), &root, key, exit::interrupted())
        .await
        .map_err(|e| anyhow::anyhow!("the storage failed: {e}"))?;
    let _ = session.close().await;
    Ok(exit::OK)
}
