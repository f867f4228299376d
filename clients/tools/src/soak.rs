//! `rome soak`: a chaos soak. Robots drive routes back and forth while
//! writers and waiters load the data server, and faults are thrown at
//! random: processes killed with SIGKILL (navigation clients, planners, a
//! robot's simulator and hardware servers, the data server) and started
//! again, links paused and cut, data clients crashed. At the end it checks
//! what a user relies on:
//!
//! - no acknowledged write is lost: every writer's variable holds at least
//!   the last value whose write was acknowledged (and nothing it never
//!   tried to write);
//! - no semaphore unit is lost or duplicated: never more holders than
//!   units, and once everyone has let go the count is back where it began;
//! - no robot is held by a dead client for longer than the promised bound
//!   ([`LOCK_BOUND`], docs/hardware.md): a client that took a robot's base
//!   lock and is killed loses it within the bound, and a robot whose
//!   navigator is killed while driving stops within it;
//! - every navigation run either arrived or was reported failed with a
//!   reason (runs the soak itself killed, or that were still driving at
//!   the end, are counted apart).
//!
//! Layout of the deployment, every part a `rome` process of its own:
//!
//! ```text
//! rome data-server (durable, in DIR/data) ── listens on P
//!   ├─ rome sim --first k --robots 1   one world per robot, connected to P
//!   ├─ relay k ── rK's crew (`rome crew`: navigator, ctracker, mapper,
//!   │             plfinder, each restarted by the crew) and planner
//!   └─ relay D ── the writers and waiters (tasks of `rome soak`)
//! ```
//!
//! Each robot has a world of its own so a robot that failed can be put
//! back at its start by restarting its simulator afresh. A world killed
//! as a fault is started again on its state file (`rome sim --state`),
//! with the robot where it stood.

use anyhow::Context;
use rome_client::net::NetOptions;
use rome_client::relay::Relay;
use rome_common::args::CommonArgs;
use rome_common::exit;
use rome_sim::rng::Rng;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

mod load;
mod report;
mod robots;
use load::*;
use report::print_summary;
use robots::*;

/// The longest a dead client may hold a robot's base lock (docs/hardware.md:
/// a crashed holder is released at once, one cut off within 2.6 s, and the
/// state stream shows it), and the longest a robot may drive on after the
/// client driving it died.
pub const LOCK_BOUND: Duration = Duration::from_millis(3_000);

/// Flags of `rome soak`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// How long to run, minutes.
    #[arg(long, default_value_t = 2.0)]
    pub minutes: f64,
    /// Robots, each in its own simulated world (EB3), driving the first
    /// routes of maps/data/eb3.routes back and forth.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=10))]
    pub robots: u32,
    /// Writers, each writing 1, 2, 3 … to a variable of its own.
    #[arg(long, default_value_t = 4)]
    pub writers: usize,
    /// Waiters, each taking a unit of one semaphore, holding it a moment
    /// and giving it back.
    #[arg(long, default_value_t = 6)]
    pub waiters: usize,
    /// Units of the waiters' semaphore.
    #[arg(long, default_value_t = 2)]
    pub units: u64,
    /// Simulated time per real time.
    #[arg(long, default_value_t = 4.0)]
    pub speed: f64,
    /// Mean seconds between two faults.
    #[arg(long, default_value_t = 6.0)]
    pub fault_every: f64,
    /// The faults to throw, comma-separated (default: every kind).
    #[arg(long, value_delimiter = ',', value_parser = clap::builder::PossibleValuesParser::new(FAULTS.iter().copied()))]
    pub faults: Vec<String>,
    /// Seed of the faults and of the worlds.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Where the logs and the data server's files go (default: a new
    /// directory under the system's temporary directory).
    #[arg(long)]
    pub dir: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

/// One `rome` child process, started again after it is killed.
struct Proc {
    name: String,
    args: Vec<String>,
    log: PathBuf,
    child: Option<Child>,
    starts: u32,
}

impl Proc {
    fn new(dir: &Path, name: &str, args: Vec<String>) -> Proc {
        Proc {
            name: name.to_string(),
            args,
            log: dir.join(format!("{name}.log")),
            child: None,
            starts: 0,
        }
    }

    fn start(&mut self, exe: &Path) -> anyhow::Result<()> {
        let log = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&self.log)
            .with_context(|| format!("cannot open {}", self.log.display()))?;
        let out = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(self.log.with_extension("out"))?;
        self.starts += 1;
        self.child = Some(
            Command::new(exe)
                .args(&self.args)
                .stdin(Stdio::null())
                .stdout(out)
                .stderr(log)
                .spawn()
                .with_context(|| format!("cannot start {}", self.name))?,
        );
        Ok(())
    }

    fn kill(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }

    /// Asks it to stop (SIGTERM: a crew stops its members first) and
    /// waits up to 5 s, then kills it.
    fn stop(&mut self) {
        if let Some(c) = self.child.as_mut() {
            let _ = Command::new("kill")
                .args(["-TERM", &c.id().to_string()])
                .status();
            let deadline = Instant::now() + Duration::from_secs(5);
            while Instant::now() < deadline && matches!(c.try_wait(), Ok(None)) {
                std::thread::sleep(Duration::from_millis(50));
            }
        }
        self.kill();
    }

    /// The exit status if it ended by itself.
    fn ended(&mut self) -> Option<std::process::ExitStatus> {
        let status = self.child.as_mut()?.try_wait().ok()??;
        self.child = None;
        Some(status)
    }

    fn running(&self) -> bool {
        self.child.is_some()
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        self.kill();
    }
}

/// How navigation runs ended.
#[derive(Debug, Default, serde::Serialize)]
struct Runs {
    /// Ended with the Planner's success and, by ground truth, within
    /// [`ARRIVED_WITHIN_M`] of the goal (or with no truth to ask).
    arrived: u64,
    /// Of those, ones whose world did not answer for ground truth.
    arrived_unjudged: u64,
    /// The farthest an arrived run ended from its goal, m.
    worst_miss_m: f64,
    failed_with_reason: u64,
    failed_without_reason: u64,
    killed_by_soak: u64,
    cut_short_by_end: u64,
    reasons: BTreeMap<String, u64>,
}

#[derive(Debug, Default, serde::Serialize)]
struct Summary {
    minutes: f64,
    faults: BTreeMap<String, u64>,
    writes_acked: u64,
    writes_failed: u64,
    writes_lost: Vec<String>,
    units: u64,
    waits_granted: u64,
    /// Holds whose unit the server had taken back (its owner seemed gone).
    holds_revoked: u64,
    /// The most holds the server stood behind at one moment.
    most_holders: i64,
    semaphore_at_end: String,
    units_lost_or_duplicated: Option<String>,
    /// How long a base lock stayed with a killed holder, ms.
    lock_releases_ms: Vec<u64>,
    /// How long a robot drove on after its navigator was killed, ms.
    stops_ms: Vec<u64>,
    /// Releases and stops not seen (the robot's world was down meanwhile).
    releases_unseen: u64,
    /// Lock holders started that did not get the lock in time.
    locks_not_taken: u64,
    runs: Runs,
    failures: Vec<String>,
    passed: bool,
    logs: String,
}

struct Shared {
    stop: AtomicBool,
    granted: AtomicU64,
    holds: Mutex<Vec<Hold>>,
    acked: Mutex<Vec<u64>>,
    attempted: Mutex<Vec<u64>>,
    write_errors: AtomicU64,
}

/// Runs `rome soak`.
pub async fn run(_common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    anyhow::ensure!(
        args.minutes.is_finite() && args.minutes > 0.0,
        "--minutes must be a positive number"
    );
    anyhow::ensure!(
        args.speed.is_finite() && args.speed > 0.0 && args.speed <= 20.0,
        "--speed must be in (0, 20]"
    );
    anyhow::ensure!(
        args.fault_every.is_finite() && args.fault_every > 0.0,
        "--fault-every must be a positive number of seconds"
    );
    anyhow::ensure!(args.units > 0, "--units must be at least 1");
    let exe = std::env::current_exe().context("cannot find the rome program")?;
    let dir = match &args.dir {
        Some(d) => d.clone(),
        None => std::env::temp_dir().join(format!("rome-soak-{}", std::process::id())),
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    eprintln!("soak: logs in {}", dir.display());
    let routes = eb3_routes(args.robots as usize)?;
    let mut rng = Rng::new(args.seed);

    // The data server, first on a port of the system's choosing, then
    // always on that one.
    let data_dir = dir.join("data");
    let mut ds = Proc::new(
        &dir,
        "data-server",
        strings(&[
            "--no-multicast",
            "--listen",
            "tcp/127.0.0.1:0",
            "data-server",
            "--data-dir",
            &data_dir.to_string_lossy(),
        ]),
    );
    ds.start(&exe)?;
    let port = listening_port(&ds.log, Duration::from_secs(60)).await?;
    ds.args[2] = format!("tcp/127.0.0.1:{port}");
    let upstream: std::net::SocketAddr = ([127, 0, 0, 1], port).into();
    let endpoint = format!("tcp/127.0.0.1:{port}");

    // Each robot's world, link and clients.
    let mut robots = Vec::new();
    for (k, (from, to)) in routes.iter().enumerate() {
        let n = k + 1;
        let robot = format!("r{n}");
        let relay = Relay::start(([127, 0, 0, 1], 0).into(), upstream, Duration::ZERO).await?;
        let link = format!("tcp/127.0.0.1:{}", relay.addr.port());
        let mut sim_args = strings(&[
            "--no-multicast",
            "--listen",
            "tcp/127.0.0.1:0",
            "--connect",
            &endpoint,
            "sim",
            "--robots",
            "1",
            "--first",
            &n.to_string(),
            "--at",
            from,
            "--speed",
            &args.speed.to_string(),
            "--seed",
            &(args.seed + n as u64).to_string(),
        ]);
        // A killed world is taken up where it stood, as a real robot
        // stands where it was when its computer restarts.
        let state = dir.join(format!("world-{robot}.json"));
        sim_args.extend(["--state".to_string(), state.to_string_lossy().into_owned()]);
        if n > 1 {
            // One storage of lock records is enough (the first world's).
            sim_args.push("--no-storage".into());
        }
        let mut sim = Proc::new(&dir, &format!("sim-{robot}"), sim_args);
        sim.start(&exe)?;
        // Its crew restarts a killed member itself, as on a robot's host.
        let mut crew = Proc::new(
            &dir,
            &format!("crew-{robot}"),
            strings(&[
                "--no-multicast",
                "--mode",
                "client",
                "--connect",
                &link,
                "crew",
                "--robot",
                &robot,
            ]),
        );
        crew.start(&exe)?;
        robots.push(RobotRig {
            robot,
            from: from.clone(),
            to: to.clone(),
            at_start: true,
            relay,
            link,
            sim,
            state,
            crew,
            planner: None,
            runs: 0,
        });
    }

    // The data-load clients, through a link of their own.
    let data_relay = Relay::start(([127, 0, 0, 1], 0).into(), upstream, Duration::ZERO).await?;
    let data_port = data_relay.addr.port();
    let shared = Arc::new(Shared {
        stop: AtomicBool::new(false),
        granted: AtomicU64::new(0),
        holds: Mutex::new(Vec::new()),
        acked: Mutex::new(vec![0; args.writers]),
        attempted: Mutex::new(vec![0; args.writers]),
        write_errors: AtomicU64::new(0),
    });
    let setup = data_client(data_port, "soak-setup").await?;
    let pool = "soak/pool";
    let created = setup.create_semaphore(pool, args.units).await?;
    anyhow::ensure!(
        created.value == args.units && created.created,
        "the semaphore {pool} already exists in {} (value {}); soak in a fresh --dir",
        data_dir.display(),
        created.value
    );
    let mut writers: Vec<tokio::task::JoinHandle<()>> = (0..args.writers)
        .map(|i| tokio::spawn(writer(i, data_port, shared.clone())))
        .collect();
    let mut waiters: Vec<Waiter> = (0..args.waiters)
        .map(|i| Waiter::start(i, data_port, pool, shared.clone(), &mut rng))
        .collect();

    // Watches every robot's base state for lock releases, and asks the
    // worlds where a run truly ended.
    let watcher = NetOptions::loopback_client(port).open().await?;
    let judge = Judge {
        session: watcher.clone(),
        world: rome_maps::world::World::from_map(&rome_maps::load_named("eb3")?),
    };

    let mut summary = Summary {
        units: args.units,
        logs: dir.display().to_string(),
        ..Summary::default()
    };
    let started = Instant::now();
    let end = started + Duration::from_secs_f64(args.minutes * 60.0);
    let mut next_fault = started + exp_secs(&mut rng, args.fault_every);
    let kinds: Vec<&str> = if args.faults.is_empty() {
        FAULTS.to_vec()
    } else {
        args.faults.iter().map(String::as_str).collect()
    };
    let mut pending: Vec<(Instant, Restart)> = Vec::new();
    let mut watches: Vec<tokio::task::JoinHandle<(Released, Option<Duration>)>> = Vec::new();
    let mut paused: Vec<(Instant, usize)> = Vec::new();
    let mut last_line = Instant::now();
    while Instant::now() < end {
        tokio::time::sleep(Duration::from_millis(200)).await;
        let now = Instant::now();
        // Restarts that are due.
        let (due, later): (Vec<_>, Vec<_>) = pending.into_iter().partition(|(t, _)| *t <= now);
        pending = later;
        for (_, r) in due {
            match r {
                Restart::DataServer => start_again(&mut ds, &exe),
                Restart::Sim(k) => start_again(&mut robots[k].sim, &exe),
                Restart::Waiter(i) => {
                    waiters[i] = Waiter::start(i, data_port, pool, shared.clone(), &mut rng)
                }
                Restart::Writer(i) => {
                    writers[i] = tokio::spawn(writer(i, data_port, shared.clone()))
                }
            }
        }
        for (t, relay) in std::mem::take(&mut paused) {
            if t <= now {
                link_of(&robots, &data_relay, relay).resume();
            } else {
                paused.push((t, relay));
            }
        }
        // Processes that ended by themselves are started again (a client
        // that gave up is as good as crashed); planners are judged.
        if ds.ended().is_some() {
            start_again(&mut ds, &exe);
        }
        for (k, r) in robots.iter_mut().enumerate() {
            let restarting = |p: &Restart| matches!(p, Restart::Sim(j) if *j == k);
            if r.sim.ended().is_some() && !pending.iter().any(|(_, p)| restarting(p)) {
                start_again(&mut r.sim, &exe);
            }
            if r.crew.ended().is_some() {
                start_again(&mut r.crew, &exe);
            }
            r.judge_planner(&mut summary.runs, &exe, &judge).await?;
        }
        // A fault.
        if now >= next_fault {
            next_fault = now + exp_secs(&mut rng, args.fault_every);
            let name = kinds[pick(&mut rng, kinds.len())];
            let back = now + Duration::from_millis(1_000 + rng.next_u64() % 2_000);
            let k = pick(&mut rng, robots.len());
            match name {
                "kill-navigator" => {
                    // A robot driving when its controller dies must stop.
                    let moving = base_state(&watcher, &robots[k].robot)
                        .await
                        .is_some_and(|s| s.wheel_speed_mm_s.abs() > 1.0);
                    robots[k].kill_member("navigator");
                    if moving {
                        watches.push(tokio::spawn(released(
                            watcher.clone(),
                            robots[k].robot.clone(),
                            Released::Stopped,
                            Instant::now(),
                        )));
                    }
                }
                "kill-lock-holder" => {
                    // Someone takes the robot's base lock and dies holding it.
                    let mut p = Proc::new(
                        &dir,
                        &format!("lock-{}", robots[k].robot),
                        strings(&[
                            "--no-multicast",
                            "--mode",
                            "client",
                            "--connect",
                            &robots[k].link,
                            "robot",
                            &robots[k].robot,
                            "lock",
                            "--hold",
                            "600",
                        ]),
                    );
                    p.start(&exe)?;
                    let holder =
                        lock_taken(&watcher, &robots[k].robot, Duration::from_secs(5)).await;
                    p.kill();
                    match holder {
                        Some(holder) => watches.push(tokio::spawn(released(
                            watcher.clone(),
                            robots[k].robot.clone(),
                            Released::Lock(holder),
                            Instant::now(),
                        ))),
                        None => summary.locks_not_taken += 1,
                    }
                }
                "kill-nav-client" => {
                    let role = ["ctracker", "mapper", "plfinder"][pick(&mut rng, 3)];
                    robots[k].kill_member(role);
                }
                "kill-planner" => {
                    if let Some(p) = robots[k].planner.as_mut() {
                        p.kill();
                        robots[k].planner = None;
                        summary.runs.killed_by_soak += 1;
                        // Where the robot stopped is unknown: back to the start.
                        robots[k].reset(&exe);
                    }
                }
                "kill-sim" => {
                    robots[k].sim.kill();
                    pending.push((back, Restart::Sim(k)));
                }
                "kill-data-server" => {
                    ds.kill();
                    pending.push((back, Restart::DataServer));
                }
                "pause-link" => {
                    let l = pick(&mut rng, robots.len() + 1);
                    link_of(&robots, &data_relay, l).pause();
                    paused.push((
                        now + Duration::from_millis(1_000 + rng.next_u64() % 4_000),
                        l,
                    ));
                }
                "cut-link" => {
                    let l = pick(&mut rng, robots.len() + 1);
                    link_of(&robots, &data_relay, l).cut();
                }
                "crash-waiter" if !waiters.is_empty() => {
                    let i = pick(&mut rng, waiters.len());
                    waiters[i].crash().await;
                    pending.push((back, Restart::Waiter(i)));
                }
                "crash-writer" if !writers.is_empty() => {
                    let i = pick(&mut rng, writers.len());
                    writers[i].abort();
                    pending.push((back, Restart::Writer(i)));
                }
                _ => {}
            }
            *summary.faults.entry(name.to_string()).or_default() += 1;
            // When, and at which robot (its link, world or crew, where the
            // fault has one), to read beside the robots' logs.
            let _ = std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(dir.join("faults.log"))
                .and_then(|mut f| {
                    use std::io::Write;
                    writeln!(
                        f,
                        "{:7.1} s  {name:<18} {}",
                        started.elapsed().as_secs_f64(),
                        robots[k].robot
                    )
                });
        }
        if last_line.elapsed() >= Duration::from_secs(10) {
            last_line = Instant::now();
            let acked: u64 = shared.acked.lock().map_or(0, |a| a.iter().sum());
            eprintln!(
                "soak: {:.0} s, {} faults, runs {} arrived / {} failed, {} writes acked, {} units granted",
                started.elapsed().as_secs_f64(),
                summary.faults.values().sum::<u64>(),
                summary.runs.arrived,
                summary.runs.failed_with_reason + summary.runs.failed_without_reason,
                acked,
                shared.granted.load(Ordering::Relaxed)
            );
        }
    }

    // The end: no more faults; everything that is down comes back.
    eprintln!("soak: time is up; checking");
    for r in &robots {
        r.relay.resume();
    }
    data_relay.resume();
    if !ds.running() {
        start_again(&mut ds, &exe);
    }
    for r in robots.iter_mut() {
        if let Some(mut p) = r.planner.take() {
            if p.ended().is_some() {
                r.planner = Some(p);
                r.judge_planner(&mut summary.runs, &exe, &judge).await?;
            } else {
                p.kill();
                summary.runs.cut_short_by_end += 1;
            }
        }
    }
    shared.stop.store(true, Ordering::SeqCst);
    for w in writers {
        w.abort();
    }
    for w in &mut waiters {
        w.finish().await;
    }
    for h in watches {
        match h.await {
            Ok((Released::Lock(_), Some(d))) => summary.lock_releases_ms.push(d.as_millis() as u64),
            Ok((Released::Stopped, Some(d))) => summary.stops_ms.push(d.as_millis() as u64),
            _ => summary.releases_unseen += 1,
        }
    }

    // What the data server says now, from a fresh client.
    let check = data_client(port, "soak-check").await?;
    let acked = shared.acked.lock().map(|a| a.clone()).unwrap_or_default();
    let attempted = shared
        .attempted
        .lock()
        .map(|a| a.clone())
        .unwrap_or_default();
    summary.writes_acked = acked.iter().sum();
    summary.writes_failed = shared.write_errors.load(Ordering::Relaxed);
    for i in 0..args.writers {
        let name = format!("soak/w{i}");
        let value: u64 = if acked[i] == 0 {
            continue;
        } else {
            match check.get_as(&name).await {
                Ok(v) => v,
                Err(e) => {
                    summary
                        .writes_lost
                        .push(format!("{name}: cannot be read: {e}"));
                    continue;
                }
            }
        };
        if value < acked[i] || value > attempted[i] {
            summary.writes_lost.push(format!(
                "{name} holds {value}; {} was acknowledged and {} the last tried",
                acked[i], attempted[i]
            ));
        }
    }
    // Every waiter has let go (and crashed ones' units came back when
    // their owners went): the count must settle back at `units`.
    let settle = Instant::now() + Duration::from_secs(30);
    let last = loop {
        let s = check.semaphore(pool).await;
        if let Ok(s) = &s {
            if s.value == args.units && s.held == 0 && s.waiters == 0 {
                break s.clone();
            }
        }
        if Instant::now() > settle {
            break s?;
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    };
    summary.semaphore_at_end = format!(
        "value {}, held {}, waiters {}",
        last.value, last.held, last.waiters
    );
    summary.waits_granted = shared.granted.load(Ordering::Relaxed);
    let holds = shared.holds.lock().map(|h| h.clone()).unwrap_or_default();
    summary.holds_revoked = holds.iter().filter(|h| h.revoked).count() as u64;
    summary.most_holders = deepest_overlap(&holds);
    if last.value != args.units || last.held != 0 || summary.most_holders > args.units as i64 {
        summary.units_lost_or_duplicated = Some(format!(
            "{} units at the start; at the end {}; at most {} holders at once",
            args.units, summary.semaphore_at_end, summary.most_holders
        ));
    }
    summary.minutes = started.elapsed().as_secs_f64() / 60.0;

    let mut failures = Vec::new();
    failures.extend(summary.writes_lost.iter().cloned());
    failures.extend(summary.units_lost_or_duplicated.iter().cloned());
    if let Some(worst) = summary.lock_releases_ms.iter().max() {
        if *worst > LOCK_BOUND.as_millis() as u64 {
            failures.push(format!(
                "a robot stayed locked by a killed client for {worst} ms (bound {} ms)",
                LOCK_BOUND.as_millis()
            ));
        }
    }
    if let Some(worst) = summary.stops_ms.iter().max() {
        if *worst > LOCK_BOUND.as_millis() as u64 {
            failures.push(format!(
                "a robot drove on for {worst} ms after its navigator was killed (bound {} ms)",
                LOCK_BOUND.as_millis()
            ));
        }
    }
    if summary.runs.failed_without_reason > 0 {
        failures.push(format!(
            "{} navigation run(s) ended without saying why",
            summary.runs.failed_without_reason
        ));
    }
    if summary.writes_acked == 0 || summary.waits_granted == 0 {
        failures.push("the data-load clients got nothing done".into());
    }
    summary.passed = failures.is_empty();
    summary.failures = failures;
    let _ = check;
    let _ = watcher.close().await;
    drop(robots);
    drop(ds);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_summary(&summary);
    }
    Ok(if summary.passed {
        exit::OK
    } else {
        exit::ERROR
    })
}

async fn listening_port(log: &Path, within: Duration) -> anyhow::Result<u16> {
    let deadline = Instant::now() + within;
    loop {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        if let Some(port) = rome_client::net::said_port(&text) {
            return Ok(port);
        }
        anyhow::ensure!(
            Instant::now() < deadline,
            "the data server did not start within {within:?}; see {}",
            log.display()
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

fn eb3_routes(n: usize) -> anyhow::Result<Vec<(String, String)>> {
    let text = include_str!("../../../maps/data/eb3.routes");
    let routes: Vec<(String, String)> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .filter_map(|l| {
            let mut w = l.split_whitespace();
            Some((w.next()?.to_string(), w.next()?.to_string()))
        })
        .take(n)
        .collect();
    anyhow::ensure!(
        routes.len() == n,
        "eb3.routes has only {} routes",
        routes.len()
    );
    Ok(routes)
}

fn strings(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

fn pick(rng: &mut Rng, n: usize) -> usize {
    (rng.next_u64() % n.max(1) as u64) as usize
}

/// Exponentially distributed seconds with this mean.
fn exp_secs(rng: &mut Rng, mean: f64) -> Duration {
    let u = rng.uniform().max(1e-9);
    Duration::from_secs_f64((-u.ln() * mean).min(mean * 5.0))
}

#[cfg(test)]
mod tests;
