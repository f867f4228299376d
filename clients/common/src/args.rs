//! Flags shared by every command, turned into network options in one place.

use clap::Args;
use rome_client::net::{NetOptions, Secrets, DEFAULT_PORT};
use rome_schema::Root;
use std::path::PathBuf;

/// Zenoh and deployment flags, accepted by every command.
#[derive(Debug, Clone, Args)]
pub struct CommonArgs {
    /// A Zenoh configuration file (JSON5) to start from.
    #[arg(short, long, global = true, env = "ROME_CONFIG", value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Zenoh mode: peer, client or router [default: peer for servers,
    /// client for everything else].
    #[arg(short, long, global = true, env = "ROME_MODE", value_parser = ["peer", "client", "router"])]
    pub mode: Option<String>,
    /// Endpoint to connect to, e.g. tcp/192.168.1.10:7447 (repeatable).
    #[arg(
        short = 'e',
        long,
        global = true,
        env = "ROME_CONNECT",
        value_delimiter = ',',
        value_name = "ENDPOINT"
    )]
    pub connect: Vec<String>,
    /// Endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable).
    #[arg(
        short,
        long,
        global = true,
        env = "ROME_LISTEN",
        value_delimiter = ',',
        value_name = "ENDPOINT"
    )]
    pub listen: Vec<String>,
    /// Turn off multicast scouting (only the given endpoints are used).
    #[arg(
        long,
        global = true,
        env = "ROME_NO_MULTICAST",
        alias = "no-multicast-scouting"
    )]
    pub no_multicast: bool,
    /// Root prefix of every key, so deployments can share a router.
    #[arg(long, global = true, env = "ROME_ROOT", default_value = rome_schema::keys::DEFAULT_ROOT)]
    pub root: String,
    /// How long to keep trying to reach the network and the data server, in seconds.
    #[arg(
        long,
        global = true,
        env = "ROME_CONNECT_TIMEOUT",
        default_value_t = 10.0,
        value_name = "SECS",
        value_parser = crate::time::parse_seconds
    )]
    pub connect_timeout: f64,
    /// Who this program is in a deployment with access control (a role:
    /// observer, operator, data; a robot: r1 …; or router); its TLS
    /// certificate, key and password are read from --secrets.
    #[arg(
        long,
        global = true,
        env = "ROME_IDENTITY",
        value_name = "NAME",
        requires = "secrets"
    )]
    pub identity: Option<String>,
    /// The directory `rome certs` filled with the deployment's credentials.
    #[arg(long, global = true, env = "ROME_SECRETS", value_name = "DIR")]
    pub secrets: Option<PathBuf>,
    /// Take time from the simulator's clock (rome/sim/clock), as ROS's
    /// use_sim_time: sleeps, periods and timeouts are simulated time, and
    /// with `rome sim --lockstep` the world waits for this process at
    /// every instant.
    #[arg(long, global = true, env = "ROME_SIM_TIME")]
    pub sim_time: bool,
    /// More log output (-v info, -vv debug); RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
}

/// Whether a TCP port on every interface is already in use.
fn port_taken(port: u16) -> bool {
    matches!(
        std::net::TcpListener::bind(("0.0.0.0", port)),
        Err(e) if e.kind() == std::io::ErrorKind::AddrInUse
    )
}

/// Whether the program serves (listens by default) or is a client
/// (connects by default).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// A server: listens on 0.0.0.0:7447 when nothing is given.
    Server,
    /// A client: connects to 127.0.0.1:7447 when nothing is given.
    Client,
}

impl CommonArgs {
    /// The root prefix, validated.
    pub fn root(&self) -> anyhow::Result<Root> {
        Ok(Root::new(self.root.as_str())?)
    }

    /// `keys` as given, or everything under the root (`ROOT/**`) when
    /// none is.
    pub fn keys_or_all(&self, keys: &[String]) -> anyhow::Result<Vec<String>> {
        Ok(if keys.is_empty() {
            vec![format!("{}/**", self.root()?.as_str())]
        } else {
            keys.to_vec()
        })
    }

    /// Network options for this side, with the out-of-the-box defaults.
    pub fn net(&self, side: Side) -> NetOptions {
        let mut net = NetOptions {
            config: self.config.clone(),
            mode: self.mode.clone(),
            connect: self.connect.clone(),
            listen: self.listen.clone(),
            no_multicast: self.no_multicast,
            connect_timeout: None,
            secrets: self.identity.as_ref().map(|identity| Secrets {
                dir: self.secrets.clone().unwrap_or_else(|| PathBuf::from(".")),
                identity: identity.clone(),
            }),
        };
        if net.is_unconfigured() {
            match side {
                Side::Server => net.listen.push(format!("tcp/0.0.0.0:{DEFAULT_PORT}")),
                Side::Client => net.connect.push(format!("tcp/127.0.0.1:{DEFAULT_PORT}")),
            }
        }
        // Clients only talk to servers: Zenoh's client mode, unless told
        // otherwise, so one-shot commands do not mesh with every peer.
        if side == Side::Client && net.mode.is_none() && net.config.is_none() {
            net.mode = Some("client".into());
        }
        // A server in client mode (behind a router) waits for it as a
        // client does, so servers and router may start in any order.
        let client_mode = side == Side::Client || net.mode.as_deref() == Some("client");
        if client_mode {
            // Set in code rather than parsed, a bad value leaves Zenoh's own.
            net.connect_timeout =
                crate::time::seconds("--connect-timeout", self.connect_timeout).ok();
        }
        net
    }

    /// Opens a session for this side (a client's is the process's shared
    /// one, if [`share_session`] gave one).
    pub async fn open(&self, side: Side) -> anyhow::Result<zenoh::Session> {
        match side {
            Side::Server => Ok(self.open_server().await?.0),
            Side::Client => match SHARED.get() {
                Some(session) => Ok(session.clone()),
                None => Ok(self.net(side).open().await?),
            },
        }
    }

    /// Opens a server's session; returns it with the options it used.
    ///
    /// With no endpoint and no config given, the first server on a host
    /// listens on port 7447 and is the meeting point: a later one finds
    /// the port taken and joins it instead (connecting to 127.0.0.1:7447
    /// and listening on a loopback port of its own for the other peers),
    /// so `rome data-server`, `rome sim` and `rome storage` run side by
    /// side with no flags, and clients reach them all through 7447.
    ///
    /// Says on standard error where it listens, with the port the system
    /// gave for a `:0` endpoint: `rome: listening on tcp/127.0.0.1:40211`.
    pub async fn open_server(&self) -> anyhow::Result<(zenoh::Session, NetOptions)> {
        let (session, net) = self.open_server_session().await?;
        eprintln!(
            "{}{}",
            rome_client::net::LISTENING,
            rome_client::net::locators(&session).await.join(" ")
        );
        Ok((session, net))
    }

    async fn open_server_session(&self) -> anyhow::Result<(zenoh::Session, NetOptions)> {
        let net = self.net(Side::Server);
        let defaulted = self.config.is_none() && self.connect.is_empty() && self.listen.is_empty();
        let join = || NetOptions {
            connect: vec![format!("tcp/127.0.0.1:{DEFAULT_PORT}")],
            listen: vec!["tcp/127.0.0.1:0".into()],
            ..net.clone()
        };
        // Looked at first, so the usual case needs no failed listen (and
        // no warning from Zenoh); a server that takes the port between the
        // look and the listen is caught by the second try.
        if defaulted && port_taken(DEFAULT_PORT) {
            tracing::info!("port {DEFAULT_PORT} is taken; joining the server there");
            let joined = join();
            return Ok((joined.open().await?, joined));
        }
        match net.open().await {
            Ok(session) => Ok((session, net)),
            Err(e) if defaulted && port_taken(DEFAULT_PORT) => {
                tracing::info!("port {DEFAULT_PORT} is taken ({e}); joining the server there");
                let joined = join();
                Ok((joined.open().await?, joined))
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Installs the log subscriber: warnings by default, info for servers.
    pub fn init_logging(&self, server: bool) {
        use tracing_subscriber::EnvFilter;
        let level = match (self.verbose, server) {
            (0, false) => "warn",
            (0, true) | (1, _) => "info",
            _ => "debug",
        };
        // A client's errors already say what Zenoh could not do; Zenoh's own
        // warnings stay on for servers, which run for long.
        let zenoh = if server || self.verbose > 0 {
            "warn"
        } else {
            "error"
        };
        let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| {
            EnvFilter::new(format!("{level},zenoh={zenoh},zenoh_transport={zenoh}"))
        });
        use std::io::IsTerminal;
        let _ = tracing_subscriber::fmt()
            .with_env_filter(filter)
            .with_ansi(std::io::stderr().is_terminal())
            .with_writer(std::io::stderr)
            .try_init();
    }
}

/// The per-user default data directory of a deployment root.
pub fn default_data_dir(root: &str) -> anyhow::Result<PathBuf> {
    let base = match std::env::var_os("XDG_DATA_HOME").filter(|d| !d.is_empty()) {
        Some(d) => PathBuf::from(d),
        None => std::env::var_os("HOME")
            .filter(|d| !d.is_empty())
            .map(|h| PathBuf::from(h).join(".local/share"))
            .ok_or_else(|| anyhow::anyhow!("neither XDG_DATA_HOME nor HOME is set, so there is no default data directory; give --data-dir DIR or --in-memory"))?,
    };
    Ok(base.join("rome").join(root.replace('/', "_")))
}

/// The session every client of this process uses, once shared.
static SHARED: std::sync::OnceLock<zenoh::Session> = std::sync::OnceLock::new();

/// Makes `session` the one [`CommonArgs::open`] gives every client of this
/// process. A process that follows a lock-step clock sends its answers to
/// the clock on it: Zenoh keeps one sender's messages in order only on one
/// session's link, and the rounds rely on a process's requests reaching
/// the others before its answer does.
pub fn share_session(session: &zenoh::Session) {
    let _ = SHARED.set(session.clone());
}
