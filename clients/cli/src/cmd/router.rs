//! `rome router`: a Zenoh router with the storage manager and the REST
//! plugin linked into the binary.
//!
//! `cargo install zenohd` brings a router with no plugins, and plugins
//! built as shared libraries load only into a router of the very same
//! build. So the project's binary carries its own: the plugins are
//! declared static (`PluginsManager::static_plugins_only`) and configured
//! as under zenohd (`plugins/rest`, `plugins/storage_manager`).
//!
//! ```text
//! rome router                         # tcp/0.0.0.0:7447, REST on 8000
//! rome router --rest-port 8080 -l tcp/0.0.0.0:7448
//! rome router -c deploy/router.json5  # everything from a Zenoh config file
//! ```
//!
//! By default the router keeps `<root>/store/**` (the hardware servers'
//! lock records) in a storage of its own, written through to a redb file,
//! so a restarted hardware server finds its lock's holder and last fence
//! there, and so does one restarted after the router itself.
//!
//! Why not the storage manager for that: its durable backends load only as
//! shared libraries built by the very same toolchain and zenoh version as
//! the router, which a one-binary `cargo install` cannot ship, and its
//! replication keeps records only while one of two routers stays up (a lab
//! whose power goes loses both). One file, one binary, no ABI to match.
//! The storage manager stays linked for storages a `--config` file asks for.

use crate::args::CommonArgs;
use anyhow::Context;
use rome_client::net::DEFAULT_PORT;
use zenoh::internal::plugins::PluginsManager;
use zenoh::internal::runtime::RuntimeBuilder;

/// Flags of `rome router`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The REST plugin's HTTP port (`curl http://HOST:PORT/rome/**`);
    /// `none` turns the REST plugin off [default: 8000, or what the
    /// `--config` file says].
    #[arg(long, value_name = "PORT|none")]
    pub rest_port: Option<String>,
    /// Do not keep the lock records (`<root>/store/**`) at all.
    #[arg(long)]
    pub no_storage: bool,
    /// Keep the lock records in DIR/router-store.redb [default:
    /// $XDG_DATA_HOME/rome/ROOT, beside the data server's state].
    #[arg(long, value_name = "DIR", env = "ROME_ROUTER_DIR", conflicts_with_all = ["in_memory", "no_storage"])]
    pub data_dir: Option<std::path::PathBuf>,
    /// Keep the lock records in memory only: gone when the router stops.
    #[arg(long, conflicts_with = "no_storage")]
    pub in_memory: bool,
}

/// The lock-record file inside a data directory.
pub const STORE_FILE: &str = "router-store.redb";

/// Builds the router's configuration: the common flags (mode router, and
/// tcp/0.0.0.0:7447 when no endpoint is given) plus the plugins'.
pub fn config(common: &CommonArgs, args: &Args) -> anyhow::Result<zenoh::Config> {
    let mut net = common.net(crate::args::Side::Server);
    if common.mode.is_none() {
        net.mode = Some("router".into());
    }
    if common.config.is_none() && net.listen.is_empty() {
        net.listen = vec![format!("tcp/0.0.0.0:{DEFAULT_PORT}")];
    }
    let mut config = net.to_config()?;
    let set = |config: &mut zenoh::Config, key: &str, json: String| {
        config
            .insert_json5(key, &json)
            .map_err(|e| anyhow::anyhow!("cannot set '{key}' to {json}: {e}"))
    };
    let rest = match (&args.rest_port, &common.config) {
        (Some(p), _) => Some(p.as_str()),
        (None, Some(_)) => None,
        (None, None) => Some("8000"),
    };
    match rest {
        None => {}
        Some("none") => {
            config
                .remove("plugins/rest")
                .map_err(|e| anyhow::anyhow!("cannot turn REST off: {e}"))?;
        }
        Some(port) => {
            let port: u16 = port.parse().with_context(|| {
                format!("--rest-port must be a port number or 'none', got '{port}'")
            })?;
            // Zenoh's loader panics on a plugin that fails to start: say
            // why first.
            std::net::TcpListener::bind(("0.0.0.0", port)).with_context(|| {
                format!("the REST port {port} is not free (--rest-port another, or none)")
            })?;
            set(&mut config, "plugins/rest/http_port", format!("\"{port}\""))?;
            set(&mut config, "plugins/rest/__required__", "true".into())?;
        }
    }
    Ok(config)
}

/// Runs the router until Ctrl-C or SIGTERM.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let config = config(common, &args)?;
    let root = common.root()?;
    // The file first: a router that cannot keep its records says so at once.
    let file = match (args.no_storage, args.in_memory, &args.data_dir) {
        (true, _, _) | (_, true, _) => None,
        (_, _, Some(dir)) => Some(dir.join(STORE_FILE)),
        (_, _, None) => Some(crate::args::default_data_dir(root.as_str())?.join(STORE_FILE)),
    };
    let file = file
        .map(|path| rome_hardware::storage::StorageFile::open(&path))
        .transpose()?;
    let rest = match config.get_json("plugins/rest/http_port") {
        Ok(p) => format!("on port {}", p.trim_matches('"')),
        Err(_) => "off".to_string(),
    };
    // A plugin declared without configuration fails to start: declare only
    // those the configuration has.
    let mut plugins = PluginsManager::static_plugins_only();
    if config.get_json("plugins/rest").is_ok() {
        plugins.declare_static_plugin::<zenoh_plugin_rest::RestPlugin, &str>("rest", true);
    }
    let storage = config.get_json("plugins/storage_manager").is_ok();
    if storage {
        plugins.declare_static_plugin::<zenoh_plugin_storage_manager::StoragesPlugin, &str>(
            "storage_manager",
            true,
        );
    }
    let mut runtime = RuntimeBuilder::new(config)
        .plugins_manager(plugins)
        .build()
        .await
        .map_err(|e| anyhow::anyhow!("cannot build the router: {e}"))?;
    runtime
        .start()
        .await
        .map_err(|e| anyhow::anyhow!("cannot start the router: {e}"))?;
    let session = zenoh::session::init(runtime.into())
        .await
        .map_err(|e| anyhow::anyhow!("cannot open the router's session: {e}"))?;
    let listen = rome_client::net::locators(&session).await;
    eprintln!("{}{}", rome_client::net::LISTENING, listen.join(" "));
    let records = match (&file, args.no_storage) {
        (_, true) => "not kept".to_string(),
        (None, false) => "in memory".to_string(),
        (Some(f), false) => format!("in {}", f.path().display()),
    };
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let store = (!args.no_storage).then(|| {
        let (session, root) = (session.clone(), root.clone());
        tokio::spawn(async move {
            rome_hardware::storage::run_on(session, &root, root.store_all(), file, async move {
                let _ = stopped.await;
            })
            .await
        })
    });
    eprintln!(
        "rome router: zid {}, listening on {}; REST {}; lock records {}; storage manager {}; Ctrl-C to stop",
        session.zid(),
        listen.join(", "),
        rest,
        records,
        if storage { "on" } else { "off" },
    );
    crate::exit::interrupted().await;
    let _ = stop.send(());
    if let Some(store) = store {
        match store.await {
            Ok(Ok(())) => {}
            Ok(Err(e)) => tracing::error!(error = %e, "the lock-record storage failed"),
            Err(e) => tracing::error!(error = %e, "the lock-record storage task failed"),
        }
    }
    let _ = session.close().await;
    Ok(0)
}
