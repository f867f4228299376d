//! Helpers for the integration tests: data servers on loopback ports,
//! client sessions that only ever talk to 127.0.0.1, and child processes
//! that are killed when the test ends.
//!
//! How this crate is laid out:
//! - this file: the helpers;
//! - [`house`]: the source tree's shape checked: file lengths, imports
//!   between files, the crates' arrows;
//! - [`decoders`]: every decoder of network input behind one signature,
//!   for `fuzz/` and `tests/decoders.rs`;
//! - [`relay`]: re-exported from `rome_client`: a TCP relay standing for a
//!   wireless link (delay, pause, cut);
//! - `src/bin/peer.rs`: `rome-test-peer`, a client playing one role
//!   (planner, navigator, waiter) in its own process;
//! - `tests/`: the tests, one file per subject.

pub mod decoders;
pub mod house;
/// The TCP relay, now part of the client library.
pub use rome_client::relay;

use rome_client::net::{open_loopback_peer, NetOptions};
use rome_client::{DataClient, DataOptions};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use zenoh::Session;

/// Sends the warnings of the code under test to the test's own output,
/// which the harness shows when the test fails: a lock-step watchdog's
/// report of a clock that stopped, say. `RUST_LOG` overrides the level.
/// Once per test binary; later calls do nothing.
pub fn show_warnings_on_failure() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_test_writer()
        .with_ansi(false)
        .try_init();
}

/// A data server running in this test process on its own loopback port.
pub struct TestServer {
    /// The port it listens on (127.0.0.1).
    pub port: u16,
    /// Its Zenoh session.
    pub session: Session,
    running: Option<rome_data::Running>,
}

impl TestServer {
    /// Starts a data server with default settings.
    pub async fn start() -> TestServer {
        Self::start_with(rome_data::ServerConfig::default()).await
    }

    /// Starts a data server with this configuration.
    pub async fn start_with(config: rome_data::ServerConfig) -> TestServer {
        let (session, port) = open_loopback_peer(&[])
            .await
            .expect("server session on loopback");
        let running = rome_data::spawn(session.clone(), config);
        TestServer {
            port,
            session,
            running: Some(running),
        }
    }

    /// A new Zenoh client session connected to this server only.
    pub async fn session(&self) -> Session {
        NetOptions::loopback_client(self.port)
            .open()
            .await
            .expect("client session on loopback")
    }

    /// A data client with its own session.
    pub async fn client(&self, role: &str) -> DataClient {
        let session = self.session().await;
        DataClient::connect(&session, DataOptions::new(role))
            .await
            .expect("data client connects")
    }

    /// A data client with its own session and these options.
    pub async fn client_with(&self, options: DataOptions) -> DataClient {
        let session = self.session().await;
        DataClient::connect(&session, options)
            .await
            .expect("data client connects")
    }

    /// Stops the server.
    pub async fn stop(mut self) {
        if let Some(running) = self.running.take() {
            running.stop().await.expect("server stops cleanly");
        }
    }
}

/// Polls `check` until it returns true or `within` has passed; for
/// conditions that only show in another process's state.
pub async fn eventually<F, Fut>(within: Duration, what: &str, mut check: F)
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = bool>,
{
    let deadline = Instant::now() + within;
    while !check().await {
        assert!(Instant::now() < deadline, "not within {within:?}: {what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// Waits until something listens on loopback `port` (a server process
/// just started); panics after `within`.
pub fn await_port(port: u16, within: Duration) {
    let deadline = Instant::now() + within;
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            Instant::now() < deadline,
            "nothing listened on 127.0.0.1:{port} within {within:?}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The last `lines` lines of every file in `dir` (the logs of a test's
/// processes), for a failure message.
pub fn tail_logs(dir: &std::path::Path, lines: usize) -> String {
    let mut out = String::new();
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    files.sort();
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap_or_default();
        let tail: Vec<&str> = text.lines().rev().take(lines).collect();
        out.push_str(&format!("--- {} ---\n", path.display()));
        for l in tail.into_iter().rev() {
            out.push_str(l);
            out.push('\n');
        }
    }
    out
}

/// Waits until a `rome` server started with `--listen tcp/127.0.0.1:0`
/// has said in its log (`log`, its standard error) which port the system
/// gave it, and returns that port: the port is bound for real, never
/// picked free and released for someone else to take first.
pub fn listening_port(log: &std::path::Path, within: Duration) -> u16 {
    let deadline = Instant::now() + within;
    loop {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        if let Some(port) = rome_client::net::said_port(&text) {
            return port;
        }
        assert!(
            Instant::now() < deadline,
            "{} did not say where it listens within {within:?}:\n{text}",
            log.display()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Starts `exe ARGS` (a `rome` server told `--listen tcp/127.0.0.1:0`) and
/// returns it with the port it says it was given; its standard error is
/// read on a thread of its own from then on, kept for `logs`.
pub fn spawn_listening(
    exe: &str,
    args: &[&str],
) -> (ChildGuard, u16, std::sync::Arc<std::sync::Mutex<String>>) {
    use std::io::BufRead;
    let mut child = Command::new(exe)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the program starts");
    let stderr = child.stderr.take().expect("stderr is piped");
    let logs = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
    let (tx, rx) = std::sync::mpsc::channel();
    let kept = logs.clone();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stderr)
            .lines()
            .map_while(Result::ok)
        {
            if let Some(port) = rome_client::net::said_port(&line) {
                let _ = tx.send(port);
            }
            if let Ok(mut k) = kept.lock() {
                k.push_str(&line);
                k.push('\n');
            }
        }
    });
    let guard = ChildGuard(Some(child));
    let port = rx
        .recv_timeout(Duration::from_secs(60))
        .unwrap_or_else(|_| {
            panic!(
                "{exe} {args:?} did not say where it listens:\n{}",
                logs.lock().map(|l| l.clone()).unwrap_or_default()
            )
        });
    (guard, port, logs)
}

/// A client session on the far side of a link to `port` on loopback that
/// delays every message by `delay` each way: the relay standing for the
/// link (pause or cut it to test drop-outs) and the session.
pub async fn far_session(port: u16, delay: Duration) -> (relay::Relay, Session) {
    let relay = relay::Relay::start(
        ([127, 0, 0, 1], 0).into(),
        ([127, 0, 0, 1], port).into(),
        delay,
    )
    .await
    .expect("the relay starts on loopback");
    let session = NetOptions::loopback_client(relay.addr.port())
        .open()
        .await
        .expect("a session opens through the relay");
    (relay, session)
}

/// The walls of EB3's corridor N (the new wing's middle corridor, x = 60 m
/// between rings B and C), as (ring, edge) of `map`: where the tests mark
/// a narrow passage.
pub fn corridor_n_walls(map: &rome_maps::Map) -> Vec<(usize, usize)> {
    rome_maps::World::from_map(map)
        .segments
        .iter()
        .filter(|s| {
            (s.a.x - 60_000.0).abs() < 1_500.0
                && (s.b.x - 60_000.0).abs() < 1_500.0
                && s.a.y.min(s.b.y) > 8_000.0
                && s.a.y.max(s.b.y) < 54_000.0
        })
        .map(|s| (s.ring, s.edge))
        .collect()
}

/// `map` with corridor N's walls ([`corridor_n_walls`]) tagged as the
/// narrow passage `N`.
pub fn with_corridor_n_passage(mut map: rome_maps::Map) -> rome_maps::Map {
    let walls = corridor_n_walls(&map);
    assert!(
        walls.len() >= 4,
        "corridor N's walls: {} edges",
        walls.len()
    );
    for (ring, edge) in walls {
        map.rings[ring].edges[edge]
            .tags
            .insert("passage".into(), "N".into());
    }
    map
}

/// Waits until `count` different liveliness tokens matching `key` are
/// alive (those already there count), at most 10 s for each.
pub async fn await_alive(session: &Session, key: &str, count: usize) {
    let sub = session
        .liveliness()
        .declare_subscriber(key)
        .history(true)
        .await
        .expect("a liveliness subscriber on loopback");
    let mut seen = std::collections::HashSet::new();
    while seen.len() < count {
        let token = tokio::time::timeout(Duration::from_secs(10), sub.recv_async())
            .await
            .unwrap_or_else(|_| panic!("{count} tokens on {key} within 10 s each; saw {seen:?}"))
            .expect("the subscriber is open");
        if token.kind() == zenoh::sample::SampleKind::Put {
            seen.insert(token.key_expr().to_string());
        }
    }
}

/// The flags of a `rome` program on loopback, listening on a port the
/// system picks (it says which in its log), without multicast scouting.
pub const LOOPBACK: [&str; 3] = ["--no-multicast", "--listen", "tcp/127.0.0.1:0"];

/// `rome data-server --in-memory` on loopback ([`LOOPBACK`]).
pub const DATA_SERVER: [&str; 5] = [
    LOOPBACK[0],
    LOOPBACK[1],
    LOOPBACK[2],
    "data-server",
    "--in-memory",
];

/// `rome router` on loopback ([`LOOPBACK`]) with no REST port and no
/// storage.
pub const ROUTER: [&str; 7] = [
    LOOPBACK[0],
    LOOPBACK[1],
    LOOPBACK[2],
    "router",
    "--rest-port",
    "none",
    "--no-storage",
];

/// The flags of a `rome` program on loopback ([`LOOPBACK`]) joined to the
/// one listening on `port`, then `rest` (the command and its flags).
pub fn joined_to(port: u16, rest: &[&str]) -> Vec<String> {
    let endpoint = format!("tcp/127.0.0.1:{port}");
    LOOPBACK
        .iter()
        .chain(&["--connect", &endpoint])
        .chain(rest)
        .map(|s| s.to_string())
        .collect()
}

/// Starts `exe ARGS` with no input or output, its stderr appended to
/// `log` (to read when a test fails); killed when the guard is dropped.
pub fn spawn_logged<S: AsRef<std::ffi::OsStr>>(
    exe: &str,
    args: &[S],
    log: &std::path::Path,
) -> ChildGuard {
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(log)
        .expect("the log file opens");
    ChildGuard(Some(
        Command::new(exe)
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(log)
            .spawn()
            .expect("the program starts"),
    ))
}

/// The `rome` program a test runs: `built` (the test's own
/// `CARGO_BIN_EXE_rome`), or `ROME_EXE` when set, so a slow test can be
/// run many times against one build while the tree is rebuilt.
pub fn rome_exe(built: &str) -> String {
    std::env::var("ROME_EXE").unwrap_or_else(|_| built.to_string())
}

/// A child process killed (SIGKILL) when dropped.
pub struct ChildGuard(pub Option<Child>);

impl ChildGuard {
    /// Kills the child now and reaps it.
    pub fn kill(&mut self) {
        if let Some(mut child) = self.0.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }

    /// Waits for the child and returns its stdout, or, if it failed, its
    /// status, stderr and stdout as the error.
    pub fn try_output(&mut self) -> Result<String, String> {
        let child = self.0.take().ok_or("child already taken")?;
        let out = child.wait_with_output().map_err(|e| e.to_string())?;
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        if out.status.success() {
            Ok(stdout)
        } else {
            Err(format!(
                "child failed ({}): {}\n--- its output ---\n{stdout}",
                out.status,
                String::from_utf8_lossy(&out.stderr)
            ))
        }
    }

    /// Waits for the child and returns its stdout; panics on failure.
    pub fn output(&mut self) -> String {
        let child = self.0.take().expect("child already taken");
        let out = child.wait_with_output().expect("child runs");
        assert!(
            out.status.success(),
            "child failed ({}): {}\n--- its output ---\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr),
            String::from_utf8_lossy(&out.stdout)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    }
}

impl Drop for ChildGuard {
    fn drop(&mut self) {
        self.kill();
    }
}

/// A test's own directory for logs and files under the system's
/// temporary directory: removed when dropped once the test has passed,
/// kept (and its path printed) when the test is failing, to be read.
#[derive(Debug)]
pub struct TestDir(std::path::PathBuf);

impl TestDir {
    /// A new, empty directory named after `label`, this process and the
    /// moment, so tests running side by side never share one.
    pub fn new(label: &str) -> TestDir {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default()
            .as_nanos();
        let path = std::env::temp_dir().join(format!("{label}-{}-{nanos}", std::process::id()));
        std::fs::create_dir_all(&path)
            .unwrap_or_else(|e| panic!("cannot make {}: {e}", path.display()));
        TestDir(path)
    }

    /// A directory made elsewhere (named, say, after a port learnt only
    /// once a server runs), kept or removed in the same way.
    pub fn adopt(path: std::path::PathBuf) -> TestDir {
        TestDir(path)
    }

    /// The directory.
    pub fn path(&self) -> &std::path::Path {
        &self.0
    }
}

impl std::ops::Deref for TestDir {
    type Target = std::path::Path;

    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for TestDir {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("the failed test's files are kept in {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// Starts `rome-test-peer` against the server on `port`
/// (`peer!(port, ["planner", "--goals", "10"])`).
#[macro_export]
macro_rules! peer {
    ($port:expr, $args:expr) => {
        $crate::spawn_peer(env!("CARGO_BIN_EXE_rome-test-peer"), $port, &$args)
    };
}

/// Starts the `rome-test-peer` binary at `exe`; use [`peer!`].
pub fn spawn_peer(exe: &str, port: u16, args: &[&str]) -> ChildGuard {
    let child = Command::new(exe)
        .arg("--port")
        .arg(port.to_string())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("rome-test-peer starts");
    ChildGuard(Some(child))
}

/// A Python virtual environment at `dir` with `packages` installed from
/// PyPI, made the first time (kept for later runs): returns its
/// directory once `import_check` (a Python statement) runs in it.
pub fn python_venv(
    dir: &std::path::Path,
    packages: &[&str],
    import_check: &str,
) -> std::path::PathBuf {
    let python = dir.join("bin/python");
    let ready = |p: &std::path::Path| {
        Command::new(p)
            .args(["-c", import_check])
            .status()
            .is_ok_and(|s| s.success())
    };
    if ready(&python) {
        return dir.to_path_buf();
    }
    let made = Command::new("python3")
        .args(["-m", "venv"])
        .arg(dir)
        .status()
        .expect("python3 is needed for the tests that use Python");
    assert!(made.success(), "python3 -m venv {} failed", dir.display());
    let pip = Command::new(&python)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
        ])
        .args(packages)
        .status()
        .expect("pip runs");
    assert!(pip.success(), "pip install {packages:?} failed");
    assert!(
        ready(&python),
        "{packages:?} installed but `{import_check}` fails"
    );
    dir.to_path_buf()
}

/// A simulated world on built-in map `map` with `robots` (name, position),
/// each put down at its position facing along its wall: the start of
/// every test that drives robots through their servers.
pub fn world(
    map: &str,
    config: rome_sim::SimConfig,
    robots: &[(&str, &str)],
) -> rome_sim_hardware::SimWorld {
    let map = rome_maps::load_named(map).expect("a built-in map");
    let mut sim = rome_sim::Sim::new(&map, config);
    for (robot, at) in robots {
        let heading = sim
            .scene()
            .world
            .position(at)
            .expect("the position is on the map")
            .wall_heading_deg;
        sim.add_robot_at(robot, at, heading)
            .expect("the robot put down");
    }
    rome_sim_hardware::SimWorld::new(sim)
}

/// The simulator's settings for a test that checks servers, not sensing:
/// no noise, and cameras that grab only when asked.
pub fn quiet() -> rome_sim::SimConfig {
    rome_sim::SimConfig {
        noise: rome_sim::Noise::none(),
        camera_period_ms: 0,
        ..rome_sim::SimConfig::default()
    }
}

/// A fleet dispatcher on EB3 with its own session to `server`, looking at
/// the fleet every 200 ms, not yet running.
pub async fn eb3_dispatcher(
    server: &TestServer,
) -> (rome_nav::fleet::dispatcher::Dispatcher, Session) {
    let session = server.session().await;
    let ds =
        rome_client::DataClient::connect(&session, rome_client::DataOptions::new("dispatcher"))
            .await
            .expect("the dispatcher's data client");
    let map = rome_maps::load_named("eb3").expect("eb3 loads");
    let world = rome_maps::World::from_map(&map);
    let network = rome_maps::Network::new(&map, &world);
    let cfg = rome_nav::fleet::dispatcher::DispatchConfig {
        every: Duration::from_millis(200),
    };
    let d = rome_nav::fleet::dispatcher::Dispatcher::new(ds, session.clone(), world, network, cfg);
    (d, session)
}

#[cfg(test)]
mod tests {
    use super::TestDir;

    #[test]
    fn a_test_dir_goes_when_the_test_passes_and_stays_when_it_fails() {
        let passed = TestDir::new("rome-testdir-passed");
        let path = passed.to_path_buf();
        std::fs::write(passed.join("log"), "x").unwrap();
        drop(passed);
        assert!(!path.exists(), "{} left behind", path.display());

        let (tx, rx) = std::sync::mpsc::channel();
        let failed = std::thread::spawn(move || {
            let dir = TestDir::new("rome-testdir-failed");
            tx.send(dir.to_path_buf()).unwrap();
            panic!("a failing test");
        });
        assert!(failed.join().is_err());
        let kept = rx.recv().unwrap();
        assert!(kept.exists(), "{} was removed", kept.display());
        std::fs::remove_dir_all(kept).unwrap();
    }
}
