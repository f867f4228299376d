//! The stores the data server is measured beside, each started on loopback
//! ports of its own for as long as the bench runs, or left out with a
//! message when it is not installed:
//!
//! - Debian's `redis-server`, in memory: the plain get and set;
//! - Debian's `etcd` (`etcd-server`), one member that syncs its log before
//!   it answers a write: the durable set, and its lock recipe beside the
//!   durable semaphore.
//!
//! etcd is spoken to through its HTTP/JSON gateway (`POST /v3/kv/put`,
//! `/v3/lease/grant`, `/v3/lock/lock`, `/v3/lock/unlock`; the JSON forms of
//! its gRPC API, keys and values in base64), on one kept-alive connection
//! per client. The gateway is part of the etcd server and adds its own hop
//! to each request, which is said beside the figures.

use base64::Engine;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use tokio::io::{AsyncBufReadExt, AsyncReadExt, AsyncWriteExt, BufReader};
use tokio::net::TcpStream;

/// Debian's redis-server on a loopback port of its own, without
/// persistence, for as long as this lives.
pub(super) struct Redis {
    child: Child,
    pub(super) port: u16,
}

impl Redis {
    /// Starts one, or `None` when redis-server is not installed.
    pub(super) fn start() -> anyhow::Result<Option<Redis>> {
        let port = rome_client::net::free_loopback_port()?;
        let Some(child) = spawn_if_installed(
            Command::new("redis-server")
                .args(["--bind", "127.0.0.1", "--port", &port.to_string()])
                .args(["--save", "", "--appendonly", "no", "--protected-mode", "no"]),
        )?
        else {
            return Ok(None);
        };
        let redis = Redis { child, port };
        until_up("redis-server", port, || {
            use std::io::{Read, Write};
            let mut c = std::net::TcpStream::connect(("127.0.0.1", port)).ok()?;
            let mut b = [0u8; 7];
            c.write_all(b"PING\r\n").ok()?;
            c.read_exact(&mut b).ok()?;
            (&b == b"+PONG\r\n").then_some(())
        })?;
        Ok(Some(redis))
    }
}

impl Drop for Redis {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `command` with its output discarded, or `None` when its program
/// is not installed.
fn spawn_if_installed(command: &mut Command) -> anyhow::Result<Option<Child>> {
    match command.stdout(Stdio::null()).stderr(Stdio::null()).spawn() {
        Ok(c) => Ok(Some(c)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => anyhow::bail!(
            "cannot start {}: {e}",
            command.get_program().to_string_lossy()
        ),
    }
}

/// Polls `ready` every 20 ms until it answers, for at most 10 s.
fn until_up(what: &str, port: u16, ready: impl Fn() -> Option<()>) -> anyhow::Result<()> {
    let up = Instant::now();
    while ready().is_none() {
        anyhow::ensure!(
            up.elapsed() < Duration::from_secs(10),
            "{what} did not answer on port {port} within 10 s"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    Ok(())
}

/// Debian's etcd, one member on loopback with its data in a fresh
/// directory, for as long as this lives.
pub(super) struct Etcd {
    child: Child,
    dir: PathBuf,
    pub(super) port: u16,
}

impl Etcd {
    /// Starts one, or `None` when etcd is not installed.
    pub(super) fn start() -> anyhow::Result<Option<Etcd>> {
        let port = rome_client::net::free_loopback_port()?;
        let peer = rome_client::net::free_loopback_port()?;
        let dir = std::env::temp_dir().join(format!("rome-bench-etcd-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let client_url = format!("http://127.0.0.1:{port}");
        let peer_url = format!("http://127.0.0.1:{peer}");
        let Some(child) = spawn_if_installed(
            Command::new("etcd")
                .arg("--data-dir")
                .arg(&dir)
                .args(["--name", "bench"])
                .args(["--listen-client-urls", &client_url])
                .args(["--advertise-client-urls", &client_url])
                .args(["--listen-peer-urls", &peer_url])
                .args(["--initial-advertise-peer-urls", &peer_url])
                .args(["--initial-cluster", &format!("bench={peer_url}")]),
        )?
        else {
            return Ok(None);
        };
        let etcd = Etcd { child, dir, port };
        until_up("etcd", port, || {
            use std::io::{Read, Write};
            let mut c = std::net::TcpStream::connect(("127.0.0.1", port)).ok()?;
            c.write_all(b"GET /health HTTP/1.0\r\n\r\n").ok()?;
            let mut reply = String::new();
            c.read_to_string(&mut reply).ok()?;
            reply.contains("\"health\":\"true\"").then_some(())
        })?;
        Ok(Some(etcd))
    }
}

impl Drop for Etcd {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// One client's kept-alive connection to etcd, with a lease of its own
/// that its locks are bound to (the lock recipe's contract: a client that
/// dies loses its locks when the lease runs out).
pub(super) struct EtcdConn {
    stream: BufReader<TcpStream>,
    lease: String,
    /// The name of this client's lock, base64.
    lock: String,
}

/// Seconds of the lease: longer than any measurement.
const LEASE_TTL_S: u32 = 600;

impl EtcdConn {
    /// Connects to etcd on `port` and takes a lease; `name` names the
    /// client's lock.
    pub(super) async fn connect(port: u16, name: &str) -> anyhow::Result<EtcdConn> {
        let stream = TcpStream::connect(("127.0.0.1", port)).await?;
        stream.set_nodelay(true)?;
        let mut conn = EtcdConn {
            stream: BufReader::new(stream),
            lease: String::new(),
            lock: b64(name),
        };
        let granted = conn
            .post("/v3/lease/grant", &format!("{{\"TTL\":{LEASE_TTL_S}}}"))
            .await?;
        conn.lease = granted["ID"]
            .as_str()
            .ok_or_else(|| anyhow::anyhow!("etcd granted a lease without an ID: {granted}"))?
            .to_string();
        Ok(conn)
    }

    /// Puts `value` on `key`, answered once etcd has synced it.
    pub(super) async fn put(&mut self, key: &str, value: &str) -> anyhow::Result<()> {
        let body = format!("{{\"key\":\"{}\",\"value\":\"{}\"}}", b64(key), b64(value));
        self.post("/v3/kv/put", &body).await.map(drop)
    }

    /// Takes the client's lock under its lease and gives it back.
    pub(super) async fn lock_unlock(&mut self) -> anyhow::Result<()> {
        let body = format!(
            "{{\"name\":\"{}\",\"lease\":\"{}\"}}",
            self.lock, self.lease
        );
        let locked = self.post("/v3/lock/lock", &body).await?;
        let key = locked["key"]
            .as_str()
            .ok_or_else(|| anyhow::anyhow!("etcd locked without a key: {locked}"))?
            .to_string();
        self.post("/v3/lock/unlock", &format!("{{\"key\":\"{key}\"}}"))
            .await
            .map(drop)
    }

    /// One request on the kept-alive connection: its JSON answer, or an
    /// error naming the status and what etcd said.
    async fn post(&mut self, path: &str, body: &str) -> anyhow::Result<serde_json::Value> {
        let request = format!(
            "POST {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
            body.len()
        );
        self.stream.write_all(request.as_bytes()).await?;
        let mut head = String::new();
        while !head.ends_with("\r\n\r\n") {
            anyhow::ensure!(
                head.len() < 16_384,
                "etcd's answer to {path} has no end of head"
            );
            let n = self.stream.read_line(&mut head).await?;
            anyhow::ensure!(n > 0, "etcd closed the connection before answering {path}");
        }
        let length = head
            .lines()
            .find_map(|l| {
                let (name, value) = l.split_once(':')?;
                name.eq_ignore_ascii_case("content-length")
                    .then(|| value.trim().parse::<usize>().ok())?
            })
            .ok_or_else(|| anyhow::anyhow!("etcd's answer to {path} has no Content-Length"))?;
        let mut answer = vec![0u8; length];
        self.stream.read_exact(&mut answer).await?;
        anyhow::ensure!(
            head.starts_with("HTTP/1.1 200"),
            "etcd answered {path} with {}: {}",
            head.lines().next().unwrap_or(""),
            String::from_utf8_lossy(&answer)
        );
        serde_json::from_slice(&answer)
            .map_err(|e| anyhow::anyhow!("etcd's answer to {path} is not JSON: {e}"))
    }
}

fn b64(s: &str) -> String {
    base64::engine::general_purpose::STANDARD.encode(s)
}
