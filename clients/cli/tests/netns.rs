//! Three hosts on one machine, made by the test with network namespaces:
//!
//! ```text
//!   robot ns ── veth ── router host (this namespace) ── veth ── station ns
//!   rome sim             rome router, rome data-server           the five navigation
//!                        a delaying relay (100 ms each way)      clients, rome data set
//! ```
//!
//! The station's link loses 5 % of its packets each way (iptables
//! `statistic`), is rate-limited (tc `tbf`), and reaches the router only
//! through the relay, since this kernel has no netem. On it a navigation
//! run arrives (ground truth), the base server carried out no request id
//! twice (its own count), and every acknowledged write from the station is
//! in the data server.
//!
//! It needs root, iproute2 and iptables, so it is `#[ignore]`d in the
//! README's test run (which lists it as ignored) and run on its own:
//! `cargo test -p rome-cli --test netns -- --ignored` (CI does). Where
//! namespaces cannot be made it fails, saying why; it never passes without
//! having run.

#![allow(clippy::unwrap_used)]

use rome_client::net::{free_loopback_port, NetOptions};
use rome_client::{DataClient, DataOptions};
use rome_tests::relay::Relay;
use rome_tests::ChildGuard;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

fn rome() -> String {
    rome_tests::rome_exe(env!("CARGO_BIN_EXE_rome"))
}

/// Runs a setup command; panics with its output if it fails.
fn sh(args: &[&str]) {
    let out = Command::new(args[0])
        .args(&args[1..])
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "cannot run {args:?} ({e}): this test needs root, iproute2 and iptables to make network namespaces"
            )
        });
    assert!(
        out.status.success(),
        "{args:?} failed: {}{}\nthis test needs root, iproute2 and iptables to make network namespaces",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The namespaces and links of one run, removed when dropped.
struct Hosts {
    robot: String,
    station: String,
    /// This side's address on the robot's link and on the station's.
    robot_side: String,
    station_side: String,
}

impl Hosts {
    fn make() -> Hosts {
        // Short, per-run names: interface names have 15 characters at most.
        let tag = std::process::id() % 100_000;
        let net = 200 + (tag % 50);
        let hosts = Hosts {
            robot: format!("rome{tag}r"),
            station: format!("rome{tag}s"),
            robot_side: format!("10.{net}.1.1"),
            station_side: format!("10.{net}.2.1"),
        };
        for (ns, side, peer, subnet) in [
            (&hosts.robot, format!("rr{tag}a"), format!("rr{tag}b"), 1),
            (&hosts.station, format!("rs{tag}a"), format!("rs{tag}b"), 2),
        ] {
            sh(&["ip", "netns", "add", ns]);
            sh(&[
                "ip", "link", "add", &side, "type", "veth", "peer", "name", &peer,
            ]);
            sh(&["ip", "link", "set", &peer, "netns", ns]);
            sh(&[
                "ip",
                "addr",
                "add",
                &format!("10.{net}.{subnet}.1/24"),
                "dev",
                &side,
            ]);
            sh(&["ip", "link", "set", &side, "up"]);
            let inside = |cmd: &[&str]| {
                let mut all = vec!["ip", "netns", "exec", ns.as_str()];
                all.extend_from_slice(cmd);
                sh(&all);
            };
            inside(&[
                "ip",
                "addr",
                "add",
                &format!("10.{net}.{subnet}.2/24"),
                "dev",
                &peer,
            ]);
            inside(&["ip", "link", "set", &peer, "up"]);
            inside(&["ip", "link", "set", "lo", "up"]);
            if subnet == 2 {
                // The wireless link: 5 % loss each way, 8 Mbit/s each way.
                for chain in ["INPUT", "OUTPUT"] {
                    inside(&[
                        "iptables",
                        "-A",
                        chain,
                        "-m",
                        "statistic",
                        "--mode",
                        "random",
                        "--probability",
                        "0.05",
                        "-j",
                        "DROP",
                    ]);
                }
                let tbf = [
                    "root", "tbf", "rate", "8mbit", "burst", "32kbit", "latency", "400ms",
                ];
                inside(&[&["tc", "qdisc", "add", "dev", &peer][..], &tbf[..]].concat());
                sh(&[&["tc", "qdisc", "add", "dev", &side][..], &tbf[..]].concat());
            }
        }
        hosts
    }
}

impl Drop for Hosts {
    fn drop(&mut self) {
        // Deleting a namespace deletes its veth ends and with them the pairs.
        for ns in [&self.robot, &self.station] {
            let _ = Command::new("ip").args(["netns", "del", ns]).status();
        }
    }
}

/// `rome ARGS` inside namespace `ns` (or here), its stderr in `log`.
fn rome_in(ns: Option<&str>, args: &[&str], log: &Path, stdout: Stdio) -> ChildGuard {
    let log = std::fs::File::create(log).unwrap();
    let mut cmd = match ns {
        Some(ns) => {
            let mut c = Command::new("ip");
            c.args(["netns", "exec", ns, &rome()]);
            c
        }
        None => Command::new(rome()),
    };
    ChildGuard(Some(
        cmd.args(args)
            .stdin(Stdio::null())
            .stdout(stdout)
            .stderr(log)
            .spawn()
            .unwrap(),
    ))
}

fn logs(dir: &Path) -> String {
    let mut out = String::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let text = std::fs::read_to_string(e.path()).unwrap_or_default();
        let tail: Vec<&str> = text.lines().rev().take(6).collect();
        out.push_str(&format!("--- {}\n", e.path().display()));
        for l in tail.into_iter().rev() {
            out.push_str(l);
            out.push('\n');
        }
    }
    out
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[ignore = "needs root and network namespaces: cargo test -p rome-cli --test netns -- --ignored"]
async fn navigation_over_a_lossy_slow_delayed_link_arrives_exactly_once() {
    let hosts = Hosts::make();
    let dir: PathBuf = std::env::temp_dir().join(format!("rome-netns-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("logs")).unwrap();
    let log = |name: &str| dir.join("logs").join(format!("{name}.log"));

    // The router host: the router on both links and on loopback (for the
    // data server and this test), the data server, the relay.
    let port = free_loopback_port().unwrap();
    let listen = format!("tcp/{}:{port},tcp/127.0.0.1:{port}", hosts.robot_side);
    let _router = rome_in(
        None,
        &[
            "--no-multicast",
            "-l",
            &listen,
            "router",
            "--rest-port",
            "none",
            "--in-memory",
        ],
        &log("router"),
        Stdio::null(),
    );
    rome_tests::await_port(port, Duration::from_secs(60));
    let local = format!("tcp/127.0.0.1:{port}");
    let state = dir.join("state").display().to_string();
    let _data = rome_in(
        None,
        &[
            "--no-multicast",
            "-m",
            "client",
            "-e",
            &local,
            "data-server",
            "--data-dir",
            &state,
        ],
        &log("data-server"),
        Stdio::null(),
    );
    let relay = Relay::start(
        format!("{}:0", hosts.station_side).parse().unwrap(),
        ([127, 0, 0, 1], port).into(),
        Duration::from_millis(100),
    )
    .await
    .unwrap();
    let via_relay = format!("tcp/{}", relay.addr);

    // The robot.
    let robot_ep = format!("tcp/{}:{port}", hosts.robot_side);
    let _sim = rome_in(
        Some(&hosts.robot),
        &[
            "--no-multicast",
            "-m",
            "client",
            "-e",
            &robot_ep,
            "sim",
            "--robots",
            "1",
            "--at",
            "350R",
            "--no-storage",
            "--seed",
            "4",
            "--speed",
            "1",
        ],
        &log("sim"),
        Stdio::null(),
    );

    // The station, every client over the bad link.
    let station = |name: &str, args: &[&str], stdout: Stdio| {
        let mut all = vec!["--no-multicast", "-m", "client", "-e", via_relay.as_str()];
        all.extend_from_slice(args);
        rome_in(Some(&hosts.station), &all, &log(name), stdout)
    };
    let mut crew = Vec::new();
    for role in ["navigator", "ctracker", "mapper", "plfinder"] {
        crew.push(station(role, &[role, "--robot", "r1"], Stdio::null()));
    }
    let here = NetOptions::loopback_client(port).open().await.unwrap();
    let root = rome_schema::Root::default();
    rome_client::alive::await_server(&here, &root, "robot", "r1/base", Duration::from_secs(120))
        .await
        .unwrap();
    let planner = station(
        "planner",
        &[
            "planner",
            "--robot",
            "r1",
            "--from",
            "350R",
            "--to",
            "356R",
            "--timeout",
            "900",
        ],
        Stdio::piped(),
    );
    let out = tokio::task::spawn_blocking(move || {
        let mut p = planner;
        p.try_output()
    })
    .await
    .unwrap();
    let out = out.unwrap_or_else(|e| {
        panic!(
            "the planner failed over the link: {e}\n{}",
            logs(&dir.join("logs"))
        )
    });
    eprintln!("{out}");

    // Exactly once, by the base server's own count.
    let got = here
        .get("rome/robot/r1/base/stats")
        .timeout(Duration::from_secs(10))
        .await
        .unwrap();
    let reply = got.recv_async().await.unwrap();
    let stats: rome_schema::robot::CommandStats =
        serde_json::from_slice(&reply.result().unwrap().payload().to_bytes()).unwrap();
    eprintln!("base server: {stats:?}");
    assert!(stats.with_id > 0, "no command with a request id: {stats:?}");
    assert_eq!(stats.ids_executed_twice, 0, "{stats:?}");

    // Acknowledged writes from the station, each a program of its own.
    let ds = DataClient::connect(&here, DataOptions::new("check"))
        .await
        .unwrap();
    ds.set_history("Probe", 100).await.unwrap();
    let writes = 20;
    for i in 0..writes {
        let v = i.to_string();
        let mut w = station(
            &format!("set-{i}"),
            &["data", "set", "Probe", &v],
            Stdio::piped(),
        );
        let done = tokio::task::spawn_blocking(move || w.try_output())
            .await
            .unwrap();
        // Its stderr went to its log: a failure shows that log.
        if let Err(e) = done {
            let said = std::fs::read_to_string(log(&format!("set-{i}"))).unwrap_or_default();
            panic!(
                "write {i} from the station failed: {e}\n--- its log ---\n{said}\n{}",
                logs(&dir.join("logs"))
            );
        }
    }
    let history = ds.history("Probe").await.unwrap();
    assert_eq!(history.stored, writes, "{history:?}");
    for back in 0..writes {
        let v = ds.get_back("Probe", back).await.unwrap();
        assert_eq!(v, serde_json::json!(writes - 1 - back));
    }
    for mut c in crew {
        c.kill();
    }
    drop(relay);
    drop(hosts);
    let _ = std::fs::remove_dir_all(&dir);
}
