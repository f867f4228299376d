//! Network options, turned into a `zenoh::Config` in this one place.
//!
//! Every `rome` program and every test builds its session through
//! [`NetOptions`], so mode, endpoints and scouting behave the same
//! everywhere.

use crate::ClientError;
use std::path::PathBuf;
use zenoh::{Config, Session};

/// The port zenohd and `rome` servers listen on by default.
pub const DEFAULT_PORT: u16 = 7447;

/// The link lease every `rome` program announces (Zenoh's default is
/// 10 s), with [`KEEP_ALIVES`] keep-alives in it: a link silent for 1 s
/// (a wireless dropout) keeps its session, its liveliness tokens and so a
/// client's waits and locks; one silent for about 5 s is closed, so its
/// tokens go and what it held is given back, 10 s cut or not. The
/// hardware lock's own 2.5 s life is shorter still (docs/hardware.md).
pub const LEASE: std::time::Duration = std::time::Duration::from_secs(5);

/// Keep-alives sent per [`LEASE`] on an otherwise idle link (Zenoh's
/// default): one every 1.25 s, so three can be lost before the lease ends.
pub const KEEP_ALIVES: u32 = 4;

/// How a program joins the Zenoh network.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct NetOptions {
    /// A Zenoh configuration file (JSON5) to start from.
    pub config: Option<PathBuf>,
    /// `peer`, `client` or `router`; Zenoh's default (peer) when unset.
    pub mode: Option<String>,
    /// Endpoints to connect to (`tcp/10.0.0.5:7447` …).
    pub connect: Vec<String>,
    /// Endpoints to listen on.
    pub listen: Vec<String>,
    /// Turn multicast scouting off (tests, and networks without multicast).
    pub no_multicast: bool,
    /// How long opening may keep trying the connect endpoints (Zenoh's
    /// `connect/timeout_ms`); Zenoh's default (a client tries once) if unset.
    pub connect_timeout: Option<std::time::Duration>,
    /// Who this program is in a deployment with access control: its TLS
    /// certificate and its user name and password (see [`Secrets`]).
    pub secrets: Option<Secrets>,
}

/// A program's credentials, as `rome certs DIR` makes them: in `dir`,
/// `ca.pem` (the deployment's authority), `<identity>.pem` and
/// `<identity>-key.pem` (its certificate and key, for mutual TLS),
/// `<identity>.password` (its password, user name `<identity>`), and on the
/// router `users.txt` (every user's password, to check them).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Secrets {
    /// The directory holding the files.
    pub dir: PathBuf,
    /// The name this program goes by: a role (`observer`, `operator`,
    /// `data`), a robot (`r1`), or `router`.
    pub identity: String,
}

impl Secrets {
    /// The path of one of the files, checked to exist.
    pub fn file(&self, name: &str) -> Result<PathBuf, ClientError> {
        let path = self.dir.join(name);
        if path.is_file() {
            Ok(path)
        } else {
            Err(ClientError::Zenoh(format!(
                "{} is missing: identity '{}' needs it (`rome certs {} --names {}` makes it)",
                path.display(),
                self.identity,
                self.dir.display(),
                self.identity
            )))
        }
    }

    /// The configuration entries (key, JSON value) these credentials set.
    pub fn entries(&self) -> Result<Vec<(&'static str, String)>, ClientError> {
        let path = |name: &str| {
            self.file(name)
                .map(|p| json_string(&p.display().to_string()))
        };
        let cert = path(&format!("{}.pem", self.identity))?;
        let key = path(&format!("{}-key.pem", self.identity))?;
        let password_file = self.file(&format!("{}.password", self.identity))?;
        let password = std::fs::read_to_string(&password_file).map_err(|e| {
            ClientError::Zenoh(format!("cannot read {}: {e}", password_file.display()))
        })?;
        let mut out = vec![
            ("transport/link/tls/root_ca_certificate", path("ca.pem")?),
            ("transport/link/tls/connect_certificate", cert.clone()),
            ("transport/link/tls/connect_private_key", key.clone()),
            ("transport/link/tls/listen_certificate", cert),
            ("transport/link/tls/listen_private_key", key),
            ("transport/link/tls/enable_mtls", "true".into()),
            ("transport/auth/usrpwd/user", json_string(&self.identity)),
            (
                "transport/auth/usrpwd/password",
                json_string(password.trim()),
            ),
        ];
        let users = self.dir.join("users.txt");
        if users.is_file() {
            out.push((
                "transport/auth/usrpwd/dictionary_file",
                json_string(&users.display().to_string()),
            ));
        }
        Ok(out)
    }
}

impl NetOptions {
    /// Options for a session on loopback only: listens on 127.0.0.1 at
    /// `listen` (an ephemeral port if `None`: peers gossip their listen
    /// locators, and Zenoh's default `[::]:0` would advertise addresses off
    /// this machine), connects to `connect`, multicast scouting off.
    pub fn loopback(listen: Option<u16>, connect: &[u16]) -> Self {
        NetOptions {
            config: None,
            mode: Some("peer".into()),
            connect: connect
                .iter()
                .map(|p| format!("tcp/127.0.0.1:{p}"))
                .collect(),
            listen: vec![format!("tcp/127.0.0.1:{}", listen.unwrap_or(0))],
            no_multicast: true,
            connect_timeout: None,
            secrets: None,
        }
    }

    /// Options for a Zenoh *client* session on loopback: connects to
    /// 127.0.0.1:`connect` only, listens nowhere, multicast off. Clients of
    /// RoME talk only to servers, so unlike peers they need no mesh with
    /// each other (fifty peers would open over a thousand links).
    pub fn loopback_client(connect: u16) -> Self {
        NetOptions {
            config: None,
            mode: Some("client".into()),
            connect: vec![format!("tcp/127.0.0.1:{connect}")],
            listen: Vec::new(),
            no_multicast: true,
            connect_timeout: None,
            secrets: None,
        }
    }

    /// Options for a session that talks to nobody but itself: every
    /// component of an embedded run shares it.
    pub fn isolated() -> Self {
        NetOptions {
            config: None,
            mode: Some("peer".into()),
            connect: Vec::new(),
            listen: Vec::new(),
            no_multicast: true,
            connect_timeout: None,
            secrets: None,
        }
    }

    /// Whether neither endpoints nor a config file were given.
    pub fn is_unconfigured(&self) -> bool {
        self.config.is_none() && self.connect.is_empty() && self.listen.is_empty()
    }

    /// Builds the Zenoh configuration.
    pub fn to_config(&self) -> Result<Config, ClientError> {
        let mut config = match &self.config {
            Some(path) => Config::from_file(path).map_err(|e| {
                ClientError::Zenoh(format!("cannot load config file {}: {e}", path.display()))
            })?,
            None => Config::default(),
        };
        let mut set = |key: &str, value: String| {
            config
                .insert_json5(key, &value)
                .map_err(|e| ClientError::Zenoh(format!("invalid {key} {value}: {e}")))
        };
        if let Some(mode) = &self.mode {
            if !matches!(mode.as_str(), "peer" | "client" | "router") {
                return Err(ClientError::Zenoh(format!(
                    "unknown mode '{mode}'; use peer, client or router"
                )));
            }
            set("mode", json_string(mode))?;
        }
        if !self.connect.is_empty() {
            set("connect/endpoints", json_list(&self.connect))?;
        }
        if !self.listen.is_empty()
            || (self.no_multicast && self.connect.is_empty() && self.config.is_none())
        {
            // With no listen endpoint, no connect endpoint and no scouting
            // the session is on its own: do not open Zenoh's default
            // listener on every interface either.
            set("listen/endpoints", json_list(&self.listen))?;
        }
        if self.no_multicast {
            set("scouting/multicast/enabled", "false".into())?;
        }
        if let Some(timeout) = self.connect_timeout {
            set("connect/timeout_ms", timeout.as_millis().to_string())?;
        }
        if self.config.is_none() {
            // A configuration file says for itself (deploy/*.json5 do).
            set("transport/link/tx/lease", LEASE.as_millis().to_string())?;
            set("transport/link/tx/keep_alive", KEEP_ALIVES.to_string())?;
        }
        if let Some(secrets) = &self.secrets {
            for (key, value) in secrets.entries()? {
                set(key, value)?;
            }
        }
        Ok(config)
    }

    /// Opens a Zenoh session with these options.
    pub async fn open(&self) -> Result<Session, ClientError> {
        let config = self.to_config()?;
        zenoh::open(config).await.map_err(|e| {
            let text = e.to_string();
            if text.contains("Unable to connect") {
                let hint = match &self.secrets {
                    Some(s) => format!(
                        "is a router running there, and does it take identity '{}' (its certificate from {}'s authority and its password)?",
                        s.identity,
                        s.dir.join("ca.pem").display()
                    ),
                    None if self.connect.iter().any(|e| e.starts_with("tls/")) => {
                        "a tls/ endpoint needs credentials: --identity NAME --secrets DIR (`rome certs DIR` makes them)".to_string()
                    }
                    None => "is a server or router running there? --connect names another".to_string(),
                };
                ClientError::Zenoh(format!("cannot reach {} ({hint})", self.connect.join(", ")))
            } else {
                ClientError::Zenoh(format!(
                    "cannot open a session (connect {:?}, listen {:?}): {text}",
                    self.connect, self.listen
                ))
            }
        })
    }
}

/// Opens a peer session on loopback that listens on a port the system
/// picks and connects to `connect`, and returns it with that port: the
/// port is bound for real, never picked free and let go for another
/// program to take first. For tests and benchmarks.
pub async fn open_loopback_peer(connect: &[u16]) -> Result<(Session, u16), ClientError> {
    let session = NetOptions::loopback(None, connect).open().await?;
    let port = bound_port(&session)
        .await
        .ok_or_else(|| ClientError::Zenoh("the session listens on no tcp/127.0.0.1 port".into()))?;
    Ok((session, port))
}

/// How a `rome` server says on standard error where it listens, with the
/// port the system gave it for a `:0` endpoint:
/// `rome: listening on tcp/127.0.0.1:40211`.
pub const LISTENING: &str = "rome: listening on ";

/// The endpoints `session` listens on, ports as bound.
pub async fn locators(session: &Session) -> Vec<String> {
    session
        .info()
        .locators()
        .await
        .iter()
        .map(|l| l.to_string())
        .collect()
}

/// The port `session` listens on at 127.0.0.1, if any.
pub async fn bound_port(session: &Session) -> Option<u16> {
    loopback_port(&locators(session).await.join(" "))
}

/// The first 127.0.0.1 port among space-separated endpoints.
fn loopback_port(endpoints: &str) -> Option<u16> {
    endpoints.split_whitespace().find_map(|l| {
        l.strip_prefix("tcp/127.0.0.1:")
            .or_else(|| l.strip_prefix("tls/127.0.0.1:"))?
            .split(['?', '#'])
            .next()?
            .parse()
            .ok()
    })
}

/// The 127.0.0.1 port a server said it listens on ([`LISTENING`]), in
/// the text of its standard error.
pub fn said_port(stderr: &str) -> Option<u16> {
    stderr
        .lines()
        .find_map(|l| loopback_port(l.strip_prefix(LISTENING)?))
}

/// A TCP port on 127.0.0.1 that was free a moment ago (the OS picks it),
/// for a program that must be told its port before it starts (a router
/// with a configuration file). Another program may take it meanwhile:
/// prefer [`open_loopback_peer`], or `--listen tcp/127.0.0.1:0` and the
/// `rome: listening on` line a server prints.
pub fn free_loopback_port() -> std::io::Result<u16> {
    let listener = std::net::TcpListener::bind(("127.0.0.1", 0))?;
    Ok(listener.local_addr()?.port())
}

fn json_string(s: &str) -> String {
    serde_json::Value::String(s.to_string()).to_string()
}

fn json_list(items: &[String]) -> String {
    serde_json::Value::from(items.to_vec()).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_servers_port_is_read_from_what_it_said() {
        let err = "2026 INFO starting\nrome: listening on tcp/192.0.2.2:7447 tcp/127.0.0.1:40211\nready\n";
        assert_eq!(said_port(err), Some(40211));
        assert_eq!(said_port("rome: listening on tcp/10.0.0.1:7447\n"), None);
        assert_eq!(said_port("listening on tcp/127.0.0.1:5\n"), None);
        assert_eq!(
            said_port("rome: listening on tls/127.0.0.1:7448\n"),
            Some(7448)
        );
    }

    #[test]
    fn loopback_options_become_config() {
        let config = NetOptions::loopback(Some(17001), &[17002])
            .to_config()
            .unwrap();
        let listen = config.get_json("listen/endpoints").unwrap();
        assert!(listen.contains("tcp/127.0.0.1:17001"), "{listen}");
        let connect = config.get_json("connect/endpoints").unwrap();
        assert!(connect.contains("tcp/127.0.0.1:17002"), "{connect}");
        assert_eq!(
            config.get_json("scouting/multicast/enabled").unwrap(),
            "false"
        );
        assert_eq!(config.get_json("mode").unwrap(), "\"peer\"");
    }

    #[test]
    fn bad_mode_and_missing_file_are_named() {
        let opts = NetOptions {
            mode: Some("server".into()),
            ..NetOptions::default()
        };
        assert!(opts
            .to_config()
            .unwrap_err()
            .to_string()
            .contains("unknown mode 'server'"));
        let opts = NetOptions {
            config: Some("/nonexistent/zenoh.json5".into()),
            ..NetOptions::default()
        };
        assert!(opts
            .to_config()
            .unwrap_err()
            .to_string()
            .contains("/nonexistent/zenoh.json5"));
    }

    #[test]
    fn bad_endpoint_is_named() {
        let opts = NetOptions {
            connect: vec!["not an endpoint".into()],
            ..NetOptions::default()
        };
        let err = opts.to_config().unwrap_err().to_string();
        assert!(err.contains("connect/endpoints"), "{err}");
    }
}
