//! `rome bench mem`: resident memory of the servers as separate processes,
//! started from this same binary on loopback and read from
//! `/proc/PID/status` (Linux):
//!
//! - a data server (`rome data-server --in-memory`) empty, then holding
//!   `--variables` variables (100 000) with every history full
//!   (`--history`, 10 values each);
//! - `rome sim --robots N` (100) once every robot's servers are up.
//!
//! ```text
//! $ rome bench mem
//! process                                   RSS MiB   bytes/value
//! data server, empty                           14.2
//! data server, 100000 vars × 10 values        201.5         196
//! rome sim --robots 100                        88.0
//! ```

use rome_client::net::NetOptions;
use rome_client::{DataClient, DataOptions};
use rome_schema::Root;
use serde::Serialize;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Flags of `rome bench mem`.
#[derive(Debug, Clone, clap::Args)]
pub struct MemBench {
    /// Variables the data server is filled with.
    #[arg(long, default_value_t = 100_000, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub variables: u32,
    /// History length of each variable; each is written this many times.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub history: u32,
    /// Robots of the `rome sim` measured.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub robots: u32,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// What `rome bench mem` measured.
#[derive(Debug, Clone, Serialize)]
pub struct MemFigures {
    /// Variables held.
    pub variables: u32,
    /// Values kept per variable.
    pub history: u32,
    /// The data server's resident memory before any write, MiB.
    pub data_empty_mib: f64,
    /// Its resident memory once full, MiB.
    pub data_full_mib: f64,
    /// (full − empty) / (variables × history), bytes.
    pub bytes_per_value: f64,
    /// Robots simulated.
    pub robots: u32,
    /// `rome sim --robots N`'s resident memory, MiB.
    pub sim_mib: f64,
}

/// A child process killed when dropped.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Proc {
    fn start(what: &str, args: &[String]) -> anyhow::Result<Proc> {
        let exe = std::env::current_exe()?;
        let child = Command::new(exe)
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| anyhow::anyhow!("cannot start {what}: {e}"))?;
        Ok(Proc(child))
    }

    /// Resident memory, MiB; an error once the process has ended.
    fn rss_mib(&mut self, what: &str) -> anyhow::Result<f64> {
        if let Some(status) = self.0.try_wait()? {
            anyhow::bail!("{what} ended ({status}) before it was measured");
        }
        rss_mib(self.0.id())
    }
}

/// Resident memory of process `pid`, MiB (`VmRSS` in `/proc/PID/status`).
pub fn rss_mib(pid: u32) -> anyhow::Result<f64> {
    let path = format!("/proc/{pid}/status");
    let status = std::fs::read_to_string(&path)
        .map_err(|e| anyhow::anyhow!("cannot read {path} (Linux only): {e}"))?;
    let kib: f64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .ok_or_else(|| anyhow::anyhow!("no VmRSS line in {path}"))?;
    Ok(kib / 1024.0)
}

/// Net flags that keep a child on one loopback port and off multicast.
fn loopback_args(port: u16) -> Vec<String> {
    vec![
        "--listen".into(),
        format!("tcp/127.0.0.1:{port}"),
        "--no-multicast".into(),
    ]
}

/// A client session to `port`, once the child `what` listens there.
async fn open_when_up(child: &mut Proc, what: &str, port: u16) -> anyhow::Result<zenoh::Session> {
    let started = Instant::now();
    loop {
        match NetOptions::loopback_client(port).open().await {
            Ok(s) => return Ok(s),
            Err(e) => {
                if let Some(status) = child.0.try_wait()? {
                    anyhow::bail!("{what} ended ({status}) before it listened on port {port}");
                }
                anyhow::ensure!(
                    started.elapsed() < Duration::from_secs(30),
                    "{what} did not listen on port {port} within 30 s: {e}"
                );
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
        }
    }
}

/// Measures; `progress` shows a bar on the terminal.
pub async fn figures(args: &MemBench, progress: bool) -> anyhow::Result<MemFigures> {
    let mut bar = progress.then(|| rome_common::progress::Progress::bar("bench mem", "steps", 4));
    let mut step = |n: u64, what: &str| {
        if let Some(b) = &mut bar {
            b.step(n, what);
        }
    };
    step(0, "starting a data server");
    let port = rome_client::net::free_loopback_port()?;
    let mut server_args = vec![
        "data-server".to_string(),
        "--in-memory".into(),
        "--history".into(),
        args.history.to_string(),
        "--max-variables".into(),
        // and the one that says the server is up
        (args.variables + 1).to_string(),
        "--max-mb".into(),
        "65536".into(),
    ];
    server_args.extend(loopback_args(port));
    let mut server = Proc::start("rome data-server", &server_args)?;
    let session = open_when_up(&mut server, "rome data-server", port).await?;
    let data = DataClient::connect(&session, DataOptions::new("bench-mem")).await?;
    // One acknowledged write: the server is up and has made its first
    // variable, so the empty figure includes what any use costs.
    data.set("bench/ready", &0).await?;
    let data_empty_mib = server.rss_mib("the data server")?;

    step(
        1,
        &format!(
            "writing {} values",
            args.variables as u64 * args.history as u64
        ),
    );
    let root = Root::default();
    // Acknowledged writes, many at once: a flood of fire-and-forget puts
    // would overflow the server's bounded inbox by design. Each value is a
    // number, as most of the thesis' variables are (positions, counts).
    const WRITERS: u32 = 64;
    let mut writers = tokio::task::JoinSet::new();
    for w in 0..WRITERS {
        let data = data.clone();
        let (variables, history) = (args.variables, args.history);
        writers.spawn(async move {
            for round in 0..history {
                for v in (w..variables).step_by(WRITERS as usize) {
                    let value = (v as u64 * 1000 + round as u64) as f64 + 0.5;
                    data.set(&format!("bench/v{v}"), &value).await?;
                }
            }
            Ok::<_, rome_client::ClientError>(())
        });
    }
    while let Some(done) = writers.join_next().await {
        done??;
    }
    let last = format!("bench/v{}", args.variables - 1);
    let kept = data.history(&last).await?;
    anyhow::ensure!(
        kept.len as u64 >= args.history as u64,
        "the data server keeps {} values of {last}, not {}",
        kept.len,
        args.history
    );
    let data_full_mib = server.rss_mib("the data server")?;
    let _ = session.close().await;
    drop(server);

    step(2, &format!("starting rome sim --robots {}", args.robots));
    let port = rome_client::net::free_loopback_port()?;
    let mut sim_args = vec![
        "sim".to_string(),
        "--robots".into(),
        args.robots.to_string(),
        "--no-storage".into(),
    ];
    sim_args.extend(loopback_args(port));
    let mut sim = Proc::start("rome sim", &sim_args)?;
    let session = open_when_up(&mut sim, "rome sim", port).await?;
    // Robots start in order: the last one's base up means all are.
    let last_base = format!("r{}/base", args.robots);
    rome_client::alive::await_server(
        &session,
        &root,
        "robot",
        &last_base,
        Duration::from_secs(120),
    )
    .await
    .map_err(|e| anyhow::anyhow!("rome sim --robots {}: {last_base} not up: {e}", args.robots))?;
    step(3, "letting the world run for 3 s");
    tokio::time::sleep(Duration::from_secs(3)).await;
    let sim_mib = sim.rss_mib("rome sim")?;
    let _ = session.close().await;
    drop(sim);
    step(4, "done");
    Ok(MemFigures {
        variables: args.variables,
        history: args.history,
        data_empty_mib,
        data_full_mib,
        bytes_per_value: (data_full_mib - data_empty_mib) * 1_048_576.0
            / (args.variables as f64 * args.history as f64),
        robots: args.robots,
        sim_mib,
    })
}

/// The figures as a table.
pub fn table(f: &MemFigures) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:42} {:>9} {:>13}",
        "process", "RSS MiB", "bytes/value"
    );
    let _ = writeln!(out, "{:42} {:>9.1}", "data server, empty", f.data_empty_mib);
    let _ = writeln!(
        out,
        "{:42} {:>9.1} {:>13.0}",
        format!("data server, {} vars × {} values", f.variables, f.history),
        f.data_full_mib,
        f.bytes_per_value
    );
    let _ = writeln!(
        out,
        "{:42} {:>9.1}",
        format!("rome sim --robots {}", f.robots),
        f.sim_mib
    );
    out
}
