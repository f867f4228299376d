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
//! lock records) in a memory storage, so a restarted hardware server finds
//! its lock's holder and last fence there even when no `rome storage` runs.

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
    /// Do not keep the lock records (`<root>/store/**`) in a memory storage.
    #[arg(long)]
    pub no_storage: bool,
}

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
    if !args.no_storage {
        let root = common.root()?;
        set(
            &mut config,
            "plugins/storage_manager/storages/rome_locks",
            format!(
                r#"{{ key_expr: "{}", volume: {{ id: "memory" }} }}"#,
                root.store_all()
            ),
        )?;
        set(
            &mut config,
            "plugins/storage_manager/__required__",
            "true".into(),
        )?;
    }
    Ok(config)
}

/// Runs the router until Ctrl-C or SIGTERM.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let config = config(common, &args)?;
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
    let listen: Vec<String> = session
        .info()
        .locators()
        .await
        .iter()
        .map(|l| l.to_string())
        .collect();
    eprintln!(
        "rome router: zid {}, listening on {}; REST {}; storage manager {}; Ctrl-C to stop",
        session.zid(),
        listen.join(", "),
        rest,
        if storage { "on" } else { "off" },
    );
    crate::exit::interrupted().await;
    let _ = session.close().await;
    Ok(0)
}
