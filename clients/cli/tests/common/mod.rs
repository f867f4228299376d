//! What the process-level navigation tests share: a data server on a port
//! of the system's choosing, `rome sim`, a robot's helper clients, each a
//! process of its own with its log kept for a failure message, and a wait
//! until all of them are up.

#![allow(dead_code)]

use rome_tests::ChildGuard;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

pub const ROME: &str = env!("CARGO_BIN_EXE_rome");

/// Where each process's standard error goes, to read when a run fails.
pub fn log_dir(port: u16) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("rome-navigation-test-{port}"));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub fn rome(port: u16, name: &str, args: &[&str], stdout: Stdio) -> ChildGuard {
    let log = std::fs::File::create(log_dir(port).join(format!("{name}.log"))).unwrap();
    let child = Command::new(ROME)
        .args(args)
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(log)
        .spawn()
        .unwrap();
    ChildGuard(Some(child))
}

/// Every process's standard error, for a failure message.
pub fn logs(port: u16) -> String {
    rome_tests::tail_logs(&log_dir(port), 8)
}

/// A client process connected to the data server on `port`.
pub fn client(port: u16, name: &str, args: &[&str], stdout: Stdio) -> ChildGuard {
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut all = vec!["--no-multicast", "--mode", "client", "--connect", &endpoint];
    all.extend_from_slice(args);
    rome(port, name, &all, stdout)
}

/// The number on a planner's last line: "ground truth puts r1 0.23 m from".
pub fn metres_from_goal(out: &str) -> f64 {
    let last = out.lines().rfind(|l| l.starts_with("done:")).unwrap_or("");
    let after = last.split(" puts ").nth(1).unwrap_or("");
    after
        .split_whitespace()
        .nth(1)
        .and_then(|m| m.parse().ok())
        .unwrap_or_else(|| panic!("no distance in the planner's last line:\n{out}"))
}

/// A `rome` server told `--listen tcp/127.0.0.1:0`, and the port it was
/// given; its log then joins the run's others, in `log_dir(port)`.
pub fn server(name: &str, args: &[&str]) -> (ChildGuard, u16) {
    let first = std::env::temp_dir().join(format!(
        "rome-navigation-{name}-{}-{:?}.log",
        std::process::id(),
        std::thread::current().id()
    ));
    let child = rome_tests::spawn_logged(ROME, args, &first);
    let port = rome_tests::listening_port(&first, Duration::from_secs(60));
    // The process keeps writing to the moved file.
    std::fs::rename(&first, log_dir(port).join(format!("{name}.log"))).unwrap();
    (child, port)
}

/// `rome data-server` on a port of the system's choosing, and that port.
pub fn data_server() -> (ChildGuard, u16) {
    server("data-server", &rome_tests::DATA_SERVER)
}

/// `rome sim` with a robot at each of `at`, joined to the data server,
/// at 4 × real time.
pub fn sim(port: u16, map: &str, at: &[&str]) -> ChildGuard {
    sim_with(port, map, at, &["--speed", "4"])
}

/// The seed of every simulated world here.
pub const SEED: &str = "4";

/// `rome sim` with a robot at each of `at`, joined to the data server,
/// seed [`SEED`], with `pace` (`--speed 4`, `--lockstep` …).
pub fn sim_with(port: u16, map: &str, at: &[&str], pace: &[&str]) -> ChildGuard {
    let robots = at.len().to_string();
    let at = at.join(",");
    let mut args = rome_tests::joined_to(
        port,
        &[
            "sim", "--map", map, "--robots", &robots, "--at", &at, "--seed", SEED,
        ],
    );
    args.extend(pace.iter().map(|s| s.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    rome(port, "sim", &args, Stdio::null())
}

/// A robot's four helper clients, each a process: navigator, ctracker,
/// mapper and plfinder.
pub fn helpers(port: u16, robot: &str, map: &str) -> Vec<ChildGuard> {
    helpers_with(port, robot, map, &[])
}

/// A robot's helper clients, by subcommand.
pub const HELPERS: [&str; 4] = ["navigator", "ctracker", "mapper", "plfinder"];

/// [`helpers`], each given the global flags `flags` (`--sim-time`).
pub fn helpers_with(port: u16, robot: &str, map: &str, flags: &[&str]) -> Vec<ChildGuard> {
    helpers_of(port, (robot, map), flags, &HELPERS)
}

/// Those of a robot's helper clients named in `roles`, each given the
/// global flags `flags`.
pub fn helpers_of(
    port: u16,
    (robot, map): (&str, &str),
    flags: &[&str],
    roles: &[&str],
) -> Vec<ChildGuard> {
    let mut out = Vec::new();
    for &role in roles {
        let name = format!("{role}-{robot}");
        let mut args = flags.to_vec();
        args.extend([role, "--robot", robot]);
        if role == "plfinder" {
            args.extend(["--map", map]);
        }
        out.push(client(port, &name, &args, Stdio::null()));
    }
    out
}

/// Waits until every client is up (its liveliness token is there), and
/// every robot's servers, so the Planners hand out their first goals to
/// clients that hear them.
pub async fn await_up(session: &zenoh::Session, port: u16, robots: usize) {
    let root = rome_schema::Root::default();
    let deadline = Instant::now() + Duration::from_secs(90);
    loop {
        let alive = rome_client::alive::list(session, &root, Duration::from_secs(2))
            .await
            .unwrap();
        let count = |class: &str, role: &str| {
            alive
                .iter()
                .filter(|p| p.class == class && p.role.starts_with(role))
                .count()
        };
        // Each client process holds two tokens (its data-server and its
        // robot client).
        let up = HELPERS
            .iter()
            .all(|role| count("client", role) == 2 * robots)
            && count("server", "robot") == 4 * robots
            && count("server", "sim") == 1;
        if up {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "not up: {alive:?}\n{}",
            logs(port)
        );
    }
}
