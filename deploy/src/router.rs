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

use anyhow::Context;
use rome_client::net::DEFAULT_PORT;
use rome_common::args::CommonArgs;
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
    /// REST reads only: GET (and event streams) are served, PUT, PATCH,
    /// POST and DELETE answer 403. For a gateway logged in as an observer
    /// (docs/observing.md), whose queries the router's access control
    /// checks as well.
    #[arg(long)]
    pub rest_read_only: bool,
    /// Bridge ROS 2 nodes on DDS (the domain `ROS_DOMAIN_ID` names, 0
    /// without it, or what the `--config` file sets under
    /// `plugins/ros2dds`) with Zenoh: a topic `/r1/odom` is the key
    /// `r1/odom` (Zenoh's ROS 2 DDS plugin, linked in; docs/ros2.md).
    #[cfg(feature = "ros2dds")]
    #[arg(long)]
    pub ros2: bool,
}

/// The lock-record file inside a data directory.
pub const STORE_FILE: &str = "router-store.redb";

/// Builds the router's configuration: the common flags (mode router, and
/// tcp/0.0.0.0:7447 when no endpoint is given) plus the plugins'.
pub fn config(common: &CommonArgs, args: &Args) -> anyhow::Result<zenoh::Config> {
    let mut net = common.net(rome_common::args::Side::Server);
    if common.mode.is_none() {
        net.mode = Some("router".into());
    }
    // A router listens where peers meet; a gateway in client mode (REST
    // for a role, as docs/observing.md shows) listens nowhere.
    if common.config.is_none() && net.listen.is_empty() && net.mode.as_deref() == Some("router") {
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
            let plugin_at = if args.rest_read_only {
                // The plugin answers on loopback only, behind the
                // read-only front on the public port.
                let port = std::net::TcpListener::bind(("127.0.0.1", 0))
                    .and_then(|l| l.local_addr())
                    .context("no free loopback port for the REST plugin")?
                    .port();
                format!("127.0.0.1:{port}")
            } else {
                port.to_string()
            };
            set(
                &mut config,
                "plugins/rest/http_port",
                format!("\"{plugin_at}\""),
            )?;
            set(&mut config, "plugins/rest/__required__", "true".into())?;
        }
    }
    #[cfg(feature = "ros2dds")]
    if args.ros2 && config.get_json("plugins/ros2dds").is_err() {
        set(&mut config, "plugins/ros2dds", "{}".into())?;
    }
    Ok(config)
}

/// CycloneDDS (the DDS of the ROS 2 plugin) on the loopback interface.
#[cfg(feature = "ros2dds")]
pub const CYCLONE_ON_LOOPBACK: &str = r#"<CycloneDDS><Domain><General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces></General></Domain></CycloneDDS>"#;

/// Whether the ROS 2 plugin's CycloneDDS is to be put on the loopback
/// interface: DDS discovery is kept to this host
/// (`ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, or the plugin's
/// `ros_automatic_discovery_range`) and `CYCLONEDDS_URI` does not say
/// otherwise. Left to itself, CycloneDDS announces its data on the host's
/// first network interface, which a ROS 2 node kept to localhost (Fast
/// DDS with the same range) never answers: neither side sees the other.
#[cfg(feature = "ros2dds")]
pub fn cyclone_on_loopback(config: &zenoh::Config) -> bool {
    let range = config
        .get_json("plugins/ros2dds/ros_automatic_discovery_range")
        .ok()
        .map(|r| r.trim_matches('"').to_string())
        .or_else(|| std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE").ok());
    range.as_deref() == Some("LOCALHOST") && std::env::var_os("CYCLONEDDS_URI").is_none()
}

/// Runs the router until Ctrl-C or SIGTERM.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let config = config(common, &args)?;
    let root = common.root()?;
    // The file first: a router that cannot keep its records says so at once.
    let file = match (args.no_storage, args.in_memory, &args.data_dir) {
        (true, _, _) | (_, true, _) => None,
        (_, _, Some(dir)) => Some(dir.join(STORE_FILE)),
        (_, _, None) => Some(rome_common::args::default_data_dir(root.as_str())?.join(STORE_FILE)),
    };
    let file = file
        .map(|path| rome_hardware::storage::StorageFile::open(&path))
        .transpose()?;
    anyhow::ensure!(
        !args.rest_read_only || args.rest_port.as_deref().is_some_and(|p| p != "none"),
        "--rest-read-only needs --rest-port PORT: the port its read-only front serves"
    );
    let plugin_at = config
        .get_json("plugins/rest/http_port")
        .ok()
        .map(|p| p.trim_matches('"').to_string());
    let rest = match (&plugin_at, &args.rest_port) {
        (Some(_), Some(p)) if args.rest_read_only => format!("on port {p}, read only"),
        (Some(p), _) => format!("on port {p}"),
        (None, _) => "off".to_string(),
    };
    let mut runtime = RuntimeBuilder::new(config.clone())
        .plugins_manager(PluginsManager::static_plugins_only())
        .build()
        .await
        .map_err(|e| anyhow::anyhow!("cannot build the router: {e}"))?;
    runtime
        .start()
        .await
        .map_err(|e| anyhow::anyhow!("cannot start the router: {e}"))?;
    // The plugins start once the router listens, not while it is built as
    // under zenohd: a REST port that answers then means port 7447 is the
    // router's, so a server started after `curl` got its answer joins the
    // router instead of taking the port first (docs/observing.md).
    let (ros2, storage) = start_plugins(&runtime, &config)?;
    let session = zenoh::session::init(runtime.into())
        .await
        .map_err(|e| anyhow::anyhow!("cannot open the router's session: {e}"))?;
    let _front = match (&plugin_at, &args.rest_port) {
        (Some(inner), Some(port)) if args.rest_read_only => {
            let listener = tokio::net::TcpListener::bind(("0.0.0.0", port.parse::<u16>()?))
                .await
                .with_context(|| format!("the REST port {port} is not free"))?;
            Some(tokio::spawn(read_only::serve(listener, inner.clone())))
        }
        _ => None,
    };
    let listen = rome_client::net::locators(&session).await;
    if !listen.is_empty() {
        eprintln!("{}{}", rome_client::net::LISTENING, listen.join(" "));
    }
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
        "rome router: zid {}, {}; REST {}; lock records {}; storage manager {}{ros2}; Ctrl-C to stop",
        session.zid(),
        if listen.is_empty() {
            "listening nowhere (a gateway)".to_string()
        } else {
            format!("listening on {}", listen.join(", "))
        },
        rest,
        records,
        if storage { "on" } else { "off" },
    );
    rome_common::exit::interrupted().await;
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

/// Declares and starts the plugins the configuration has (a plugin
/// declared without configuration fails to start); returns what the
/// banner says of ROS 2, and whether the storage manager started.
fn start_plugins(
    runtime: &zenoh::internal::runtime::Runtime,
    config: &zenoh::Config,
) -> anyhow::Result<(String, bool)> {
    let mut plugins = runtime.plugins_manager();
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
    #[allow(unused_mut)]
    let mut ros2 = String::new();
    #[cfg(feature = "ros2dds")]
    if config.get_json("plugins/ros2dds").is_ok() {
        ros2 = "; ROS 2 DDS plugin on".into();
        if cyclone_on_loopback(config) {
            // Before the plugin makes its DDS participant, which reads it;
            // nothing else in this process reads the environment meanwhile.
            std::env::set_var("CYCLONEDDS_URI", CYCLONE_ON_LOOPBACK);
            ros2 += " (discovery on this host: CycloneDDS on loopback)";
        }
        plugins.declare_static_plugin::<zenoh_plugin_ros2dds::ROS2Plugin, &str>("ros2dds", true);
    }
    let args: zenoh::internal::runtime::DynamicRuntime = runtime.clone().into();
    for plugin in plugins.loaded_plugins_iter_mut() {
        let id = plugin.id().to_string();
        plugin
            .start(&args)
            .map_err(|e| anyhow::anyhow!("the {id} plugin did not start: {e}"))?;
    }
    Ok((ros2, storage))
}

/// The read-only front of the REST plugin: reads pass through, writes
/// are refused with a reason.
mod read_only {
    use axum::body::Body;
    use axum::http::{header, Method, Request, Response, StatusCode};
    use hyper_util::client::legacy::Client;
    use hyper_util::rt::TokioExecutor;

    /// Serves `listener`, passing reads on to the plugin at `inner`.
    pub async fn serve(listener: tokio::net::TcpListener, inner: String) {
        let client: Client<_, Body> = Client::builder(TokioExecutor::new()).build_http();
        let app = axum::Router::new().fallback(move |req: Request<Body>| {
            let (client, inner) = (client.clone(), inner.clone());
            async move { pass(client, &inner, req).await }
        });
        if let Err(e) = axum::serve(listener, app).await {
            tracing::error!(error = %e, "the read-only REST front failed");
        }
    }

    async fn pass(
        client: Client<hyper_util::client::legacy::connect::HttpConnector, Body>,
        inner: &str,
        req: Request<Body>,
    ) -> Response<Body> {
        let method = req.method().clone();
        if method != Method::GET && method != Method::HEAD {
            let body = serde_json::json!({
                "code": "read_only",
                "message": format!(
                    "this REST endpoint only reads (rome router --rest-read-only): {method} {} was not passed on; write through a session with a role that may (operator)",
                    req.uri().path()
                ),
            });
            return Response::builder()
                .status(StatusCode::FORBIDDEN)
                .header(header::CONTENT_TYPE, "application/json")
                .body(Body::from(body.to_string()))
                .unwrap_or_default();
        }
        let path = req.uri().path_and_query().map_or("/", |p| p.as_str());
        let uri = format!("http://{inner}{path}");
        let mut out = Request::builder().method(method).uri(&uri);
        for name in [header::ACCEPT, header::ACCEPT_ENCODING] {
            if let Some(v) = req.headers().get(&name) {
                out = out.header(name, v);
            }
        }
        // A GET's body would be a query payload: a read has none.
        let Ok(out) = out.body(Body::empty()) else {
            return status(StatusCode::BAD_REQUEST, format!("cannot pass on {uri}"));
        };
        match client.request(out).await {
            Ok(res) => res.map(Body::new),
            Err(e) => status(
                StatusCode::BAD_GATEWAY,
                format!("the REST plugin did not answer: {e}"),
            ),
        }
    }

    fn status(code: StatusCode, text: String) -> Response<Body> {
        Response::builder()
            .status(code)
            .body(Body::from(text))
            .unwrap_or_default()
    }
}
