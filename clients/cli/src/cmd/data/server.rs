//! `rome data-server`: runs the data server until Ctrl-C or SIGTERM.

use crate::args::CommonArgs;
use crate::exit;
use rome_data::{ServerConfig, Storage};
use std::path::PathBuf;
use std::time::Duration;

/// Flags of `rome data-server`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// History length of a new variable (the thesis' N).
    #[arg(long, default_value_t = rome_schema::data::DEFAULT_HISTORY, value_parser = clap::value_parser!(u32).range(1..=i64::from(rome_schema::data::MAX_HISTORY)))]
    pub history: u32,
    /// How long a queued wait keeps its place between polls, and how long
    /// an unconfirmed grant to a vanished client is kept (milliseconds).
    #[arg(long, default_value_t = 5000, value_name = "MS")]
    pub grace_ms: u64,
    /// At most this many variables; past it writes are refused `quota`.
    #[arg(long, default_value_t = 100_000, value_name = "N")]
    pub max_variables: usize,
    /// At most this many semaphores.
    #[arg(long, default_value_t = 100_000, value_name = "N")]
    pub max_semaphores: usize,
    /// At most this many mebibytes of stored values, every history counted.
    #[arg(long, default_value_t = 1024, value_name = "MIB")]
    pub max_mb: u64,
    /// Keep the state (values, histories, semaphores, waiters) in
    /// DIR/data.redb and its log DIR/data.log; every answered change is
    /// on disk before its answer.
    /// Default: $XDG_DATA_HOME/rome/ROOT (~/.local/share/rome/ROOT).
    #[arg(
        long,
        value_name = "DIR",
        env = "ROME_DATA_DIR",
        conflicts_with = "in_memory"
    )]
    pub data_dir: Option<PathBuf>,
    /// Keep the state only in memory: it is gone when the server stops.
    #[arg(long)]
    pub in_memory: bool,
}

/// Runs the server.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let root = common.root()?;
    let storage = if args.in_memory {
        Storage::InMemory
    } else {
        Storage::Dir(match args.data_dir {
            Some(dir) => dir,
            None => crate::args::default_data_dir(root.as_str())?,
        })
    };
    let (session, net) = common.open_server().await?;
    let config = ServerConfig {
        root,
        storage,
        default_history: args.history,
        grace: Duration::from_millis(args.grace_ms),
        limits: rome_data::Limits {
            max_variables: args.max_variables,
            max_semaphores: args.max_semaphores,
            max_bytes: args.max_mb.saturating_mul(1 << 20),
        },
        ..ServerConfig::default()
    };
    let kept = match &config.storage {
        Storage::InMemory => "in memory only".to_string(),
        Storage::Dir(dir) => format!(
            "state in {} and its log {}",
            dir.join(rome_data::store::FILE_NAME).display(),
            dir.join(rome_data::store::LOG_NAME).display()
        ),
    };
    eprintln!(
        "rome data-server: serving '{}/data/**' (listen {:?}, connect {:?}; {kept}); Ctrl-C to stop",
        config.root.as_str(),
        net.listen,
        net.connect
    );
    let serving = rome_data::run(session.clone(), config, exit::interrupted());
    if common.sim_time {
        let name = "rome data-server";
        rome_client::simtime::follow(&session, &common.root()?, name, serving).await??;
    } else {
        serving.await?;
    }
    let _ = session.close().await;
    Ok(exit::OK)
}
