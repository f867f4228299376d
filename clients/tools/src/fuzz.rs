//! `rome fuzz`: sends generated garbage to every key a running deployment
//! serves or listens on, as anyone on the network could, and checks that
//! nothing broke.
//!
//! What it sends (each case picks one of each at random, from a seed):
//! - keys: every data-server operation and every hardware command of every
//!   robot found alive, unknown operations and commands, names that are
//!   not names (empty chunks, `$`, `@`, 300 characters, non-ASCII), and
//!   wildcards;
//! - parameters: the ones the servers know and unknown ones, with values
//!   that are empty, negative, past 2^32 and 2^64, `NaN`, words, row lists
//!   of thousands of rows, ten thousand digits;
//! - payloads: none, random bytes, invalid UTF-8, JSON of the wrong shape,
//!   the right messages with out-of-range numbers, deep nesting, a
//!   megabyte string;
//! - as queries, and as puts and deletes on the same keys and on the keys
//!   servers and navigation clients subscribe to (state, scan, frame,
//!   truth, the lock records in storage);
//! - on every robot's blackboard (`nav/<robot>/…`, through the data
//!   server), values of the wrong type or out of range on each variable a
//!   navigation client reads, mostly followed by the up() that has the
//!   client read it at once (`fuzz/board.rs`).
//!
//! What it checks at the end:
//! - every server alive at the start is still alive (liveliness), and every
//!   `--pid` still runs;
//! - every query addressed to one server got a reply, and every error reply
//!   is a decodable error naming the problem;
//! - the servers still serve good requests (a variable written and read
//!   back, every robot's pose and sonar);
//! - the memory of every `--pid` grew by at most `--max-growth-mb` over
//!   the second half of the run (after the first half has filled caches,
//!   histories and queues to their bounds).
//!
//! Exit code 0 when every check holds, 1 otherwise.

use anyhow::Context;
use rome_client::{alive, DataClient};
use rome_common::args::{CommonArgs, Side};
use rome_common::exit;
use rome_schema::{ErrorReply, Root};
use rome_sim::rng::Rng;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::Semaphore;
use zenoh::Session;

mod board;
mod garbage;

use garbage::{params, payload, pick};

/// Flags of `rome fuzz`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// How many cases to send.
    #[arg(long, default_value_t = 2_000)]
    pub cases: u64,
    /// Send for this many minutes instead of a number of cases.
    #[arg(long)]
    pub minutes: Option<f64>,
    /// Seed of the generator: the same seed sends the same cases.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Cases in flight at once.
    #[arg(long, default_value_t = 16)]
    pub parallel: usize,
    /// How long a query may wait for its reply, seconds.
    #[arg(long, default_value_t = 20.0)]
    pub reply_timeout: f64,
    /// A process that must survive, and whose memory is watched (repeat).
    #[arg(long = "pid")]
    pub pids: Vec<u32>,
    /// Most a watched process's memory may grow over the second half, MB.
    #[arg(long, default_value_t = 64)]
    pub max_growth_mb: u64,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Where a case goes.
#[derive(Debug, Clone)]
enum Target {
    /// A queryable: data-server operation or hardware command.
    Query { key: String, served: bool },
    /// A key someone subscribes to.
    Publish { key: String },
    /// A robot's blackboard, written through the data server.
    Board { robot: String },
}

/// What the run saw, by kind of case.
#[derive(Debug, Default, serde::Serialize)]
struct Tally {
    sent: u64,
    ok: u64,
    error: u64,
    silent: u64,
    undecodable_error: u64,
    published: u64,
    /// Queries no one server is bound to answer (wildcards, names that
    /// are not names): counted, not judged.
    unaddressed: u64,
}

#[derive(Debug, serde::Serialize)]
struct Summary {
    cases: u64,
    seconds: f64,
    by_kind: BTreeMap<String, Tally>,
    /// Query keys served by one server that got no reply.
    silent_examples: Vec<String>,
    undecodable_examples: Vec<String>,
    servers_lost: Vec<String>,
    pids_gone: Vec<u32>,
    memory_mb: BTreeMap<u32, [f64; 3]>,
    good_requests_failed: Vec<String>,
    passed: bool,
}

/// Runs `rome fuzz`.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    anyhow::ensure!(args.parallel > 0, "--parallel must be at least 1");
    anyhow::ensure!(
        args.reply_timeout.is_finite() && args.reply_timeout > 0.0,
        "--reply-timeout must be a positive number of seconds"
    );
    let root = common.root()?;
    let session = common.open(Side::Client).await?;
    let before = alive::list(&session, &root, Duration::from_secs(2))
        .await
        .context("listing what is alive")?;
    let servers: Vec<String> = before
        .iter()
        .filter(|p| p.class == "server")
        .map(|p| p.key.clone())
        .collect();
    anyhow::ensure!(
        !servers.is_empty(),
        "no RoME server is alive under '{}' (start `rome sim` and `rome data-server`, or pass --connect)",
        root.as_str()
    );
    // A hardware server's token is `robot/<robot>[/camera]` and its device
    // (`base`, `proximity`, a camera's name).
    let robots: Vec<(String, String)> = before
        .iter()
        .filter(|p| p.class == "server")
        .filter_map(|p| {
            let rest = p.role.strip_prefix("robot/")?;
            Some(match rest.split_once('/') {
                Some((robot, kind)) => (robot.to_string(), format!("{kind}/{}", p.id)),
                None => (rest.to_string(), p.id.clone()),
            })
        })
        .collect();
    let data = before
        .iter()
        .any(|p| p.class == "server" && p.role == "data");
    let targets = targets(&root, data, &robots);
    // Blackboard values go through the data server, as a client's would.
    let ds = match data {
        true => Some(
            rome_client::DataClient::connect(&session, rome_client::DataOptions::new("fuzz"))
                .await
                .context("connecting to the data server")?,
        ),
        false => None,
    };
    anyhow::ensure!(
        !targets.is_empty(),
        "no data server and no hardware server is alive under '{}': nothing to send to",
        root.as_str()
    );
    eprintln!(
        "fuzz: {} servers alive, {} targets ({} robots' devices{}), seed {}",
        servers.len(),
        targets.len(),
        robots.len(),
        if data { ", the data server" } else { "" },
        args.seed
    );

    let started = Instant::now();
    let deadline = args
        .minutes
        .map(|m| started + Duration::from_secs_f64(m * 60.0));
    let total = if deadline.is_some() {
        u64::MAX
    } else {
        args.cases
    };
    let mut rng = Rng::new(args.seed);
    let gate = Arc::new(Semaphore::new(args.parallel));
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<(String, Outcome, String)>();
    let mut summary = Summary {
        cases: 0,
        seconds: 0.0,
        by_kind: BTreeMap::new(),
        silent_examples: Vec::new(),
        undecodable_examples: Vec::new(),
        servers_lost: Vec::new(),
        pids_gone: Vec::new(),
        memory_mb: BTreeMap::new(),
        good_requests_failed: Vec::new(),
        passed: false,
    };
    let mem0 = rss_all(&args.pids);
    let mut mem_half = None;
    let timeout = Duration::from_secs_f64(args.reply_timeout);
    let mut last_line = Instant::now();
    let mut n = 0u64;
    while n < total && deadline.is_none_or(|d| Instant::now() < d) {
        let half = match deadline {
            Some(d) => Instant::now() >= started + (d - started) / 2,
            None => n >= total / 2,
        };
        if half && mem_half.is_none() {
            // Let the first half's cases finish before measuring.
            let _ = gate.acquire_many(args.parallel as u32).await;
            mem_half = Some(rss_all(&args.pids));
        }
        let case = Case::generate(&mut rng, &targets);
        let permit = gate.clone().acquire_owned().await?;
        let (s, tx, ds) = (session.clone(), tx.clone(), ds.clone());
        tokio::spawn(async move {
            let kind = case.kind.clone();
            let what = case.describe();
            let outcome = case.send(&s, ds.as_ref(), timeout).await;
            let _ = tx.send((kind, outcome, what));
            drop(permit);
        });
        n += 1;
        while let Ok((kind, outcome, what)) = rx.try_recv() {
            summary.count(&kind, outcome, what);
        }
        if last_line.elapsed() > Duration::from_secs(10) {
            last_line = Instant::now();
            eprintln!(
                "fuzz: {n} cases in {:.0} s, {} silent, {} undecodable",
                started.elapsed().as_secs_f64(),
                summary.silent_examples.len(),
                summary.undecodable_examples.len()
            );
        }
    }
    let _ = gate.acquire_many(args.parallel as u32).await?;
    drop(tx);
    while let Some((kind, outcome, what)) = rx.recv().await {
        summary.count(&kind, outcome, what);
    }
    summary.cases = n;
    summary.seconds = started.elapsed().as_secs_f64();

    // What survived.
    let after = alive::list(&session, &root, Duration::from_secs(2))
        .await
        .context("listing what is alive after the run")?;
    summary.servers_lost = servers
        .iter()
        .filter(|k| !after.iter().any(|p| &p.key == *k))
        .cloned()
        .collect();
    summary.pids_gone = args.pids.iter().copied().filter(|p| !running(*p)).collect();
    let mem_end = rss_all(&args.pids);
    let mem_half = mem_half.unwrap_or_else(|| mem0.clone());
    for (k, pid) in args.pids.iter().enumerate() {
        summary
            .memory_mb
            .insert(*pid, [mem0[k], mem_half[k], mem_end[k]]);
    }
    summary.good_requests_failed = good_requests(&session, &root, data, &robots).await;
    let grew = summary
        .memory_mb
        .values()
        .any(|[_, half, end]| end - half > args.max_growth_mb as f64);
    summary.passed = summary.silent_examples.is_empty()
        && summary.undecodable_examples.is_empty()
        && summary.servers_lost.is_empty()
        && summary.pids_gone.is_empty()
        && summary.good_requests_failed.is_empty()
        && !grew;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_summary(&summary, args.max_growth_mb);
    }
    let _ = session.close().await;
    Ok(if summary.passed {
        exit::OK
    } else {
        exit::ERROR
    })
}

impl Summary {
    fn count(&mut self, kind: &str, outcome: Outcome, what: String) {
        let t = self.by_kind.entry(kind.to_string()).or_default();
        t.sent += 1;
        match outcome {
            Outcome::Replied {
                ok,
                error,
                undecodable,
            } => {
                t.ok += ok;
                t.error += error;
                t.undecodable_error += undecodable;
                if ok + error + undecodable == 0 {
                    t.silent += 1;
                }
                if undecodable > 0 && self.undecodable_examples.len() < 20 {
                    self.undecodable_examples.push(what.clone());
                }
            }
            Outcome::Silent => {
                t.silent += 1;
                if self.silent_examples.len() < 20 {
                    self.silent_examples.push(what);
                }
            }
            Outcome::Published => t.published += 1,
            Outcome::Unaddressed => t.unaddressed += 1,
        }
    }
}

fn print_summary(s: &Summary, max_growth_mb: u64) {
    println!(
        "{} cases in {:.1} s\n\n{:<22} {:>7} {:>7} {:>7} {:>7} {:>11} {:>9} {:>11}",
        s.cases,
        s.seconds,
        "kind",
        "sent",
        "ok",
        "error",
        "silent",
        "undecodable",
        "published",
        "unaddressed"
    );
    for (kind, t) in &s.by_kind {
        println!(
            "{kind:<22} {:>7} {:>7} {:>7} {:>7} {:>11} {:>9} {:>11}",
            t.sent, t.ok, t.error, t.silent, t.undecodable_error, t.published, t.unaddressed
        );
    }
    println!();
    for (pid, [a, b, c]) in &s.memory_mb {
        println!("pid {pid}: {a:.1} MB at the start, {b:.1} MB half way, {c:.1} MB at the end (at most +{max_growth_mb} MB allowed over the second half)");
    }
    let list = |what: &str, items: &[String]| {
        if !items.is_empty() {
            println!("{what}:");
            for i in items {
                println!("  {i}");
            }
        }
    };
    list("queries to one server left unanswered", &s.silent_examples);
    list(
        "error replies that are not a RoME error",
        &s.undecodable_examples,
    );
    list("servers no longer alive", &s.servers_lost);
    list(
        "good requests that failed afterwards",
        &s.good_requests_failed,
    );
    for pid in &s.pids_gone {
        println!("process {pid} is gone");
    }
    println!("{}", if s.passed { "PASSED" } else { "FAILED" });
}

/// Every key a case may go to.
fn targets(root: &Root, data: bool, robots: &[(String, String)]) -> Vec<Target> {
    let r = root.as_str();
    let mut out = Vec::new();
    let q = |key: String, served: bool| Target::Query { key, served };
    if data {
        for op in [
            "var",
            "set",
            "history",
            "create",
            "sem",
            "signal",
            "try-wait",
            "wait",
            "cancel",
            "ack",
            "no-such-op",
        ] {
            for name in ["fz/a", "fz/b/c", "GoalData"] {
                out.push(q(format!("{r}/data/{op}/{name}"), true));
                out.push(Target::Publish {
                    key: format!("{r}/data/{op}/{name}"),
                });
            }
            out.push(q(format!("{r}/data/{op}/*"), false));
            out.push(q(format!("{r}/data/{op}/**"), false));
        }
        out.push(q(format!("{r}/data/**"), false));
        out.push(Target::Publish {
            key: format!("{r}/data/watch/fz/a"),
        });
        // About one case in seven on each robot's blackboard.
        let mut names: Vec<&String> = robots.iter().map(|(robot, _)| robot).collect();
        names.sort();
        names.dedup();
        for robot in names {
            for _ in 0..8 {
                out.push(Target::Board {
                    robot: robot.clone(),
                });
            }
        }
    }
    for (robot, device) in robots {
        let commands: &[&str] = match device.as_str() {
            "base" => rome_hardware::base::COMMANDS,
            "proximity" => rome_hardware::proximity::COMMANDS,
            _ => rome_hardware::camera::COMMANDS,
        };
        let base = format!("{r}/robot/{robot}/{device}");
        for c in commands
            .iter()
            .chain(&["lock", "unlock", "stats", "no-such-command"])
        {
            out.push(q(format!("{base}/{c}"), true));
        }
        // Wildcards over a device's commands are answered: its reads, or
        // an error reply when only commands that act match.
        out.push(q(format!("{base}/*"), true));
        for stream in ["state", "scan", "frame"] {
            out.push(Target::Publish {
                key: format!("{base}/{stream}"),
            });
        }
        out.push(Target::Publish {
            key: format!("{r}/store/robot/{robot}/{device}/lock"),
        });
        out.push(q(format!("{r}/robot/*/{device}/pose"), device == "base"));
        out.push(q(format!("{r}/robot/*/{device}/{}", commands[0]), true));
        out.push(Target::Publish {
            key: format!("{r}/sim/{robot}/truth"),
        });
        out.push(q(format!("{r}/sim/{robot}/truth"), false));
    }
    out
}

/// One generated request.
struct Case {
    kind: String,
    target: Target,
    key: String,
    params: String,
    payload: Option<Vec<u8>>,
    delete: bool,
    board: Option<board::BoardCase>,
}

enum Outcome {
    Replied {
        ok: u64,
        error: u64,
        undecodable: u64,
    },
    Silent,
    Published,
    /// A query not addressed to one server (a wildcard): any answer goes.
    Unaddressed,
}

impl Case {
    fn generate(rng: &mut Rng, targets: &[Target]) -> Case {
        let target = targets[pick(rng, targets.len())].clone();
        let (mut key, is_query) = match &target {
            Target::Query { key, .. } => (key.clone(), true),
            Target::Publish { key } => (key.clone(), false),
            Target::Board { robot } => {
                return Case {
                    kind: "blackboard".into(),
                    key: String::new(),
                    params: String::new(),
                    payload: None,
                    delete: false,
                    board: Some(board::BoardCase::generate(rng, robot)),
                    target,
                };
            }
        };
        // Sometimes the name itself is the garbage.
        if pick(rng, 8) == 0 {
            if let Some((head, _)) = key.rsplit_once('/') {
                let bad = [
                    "x".repeat(300),
                    "é-ü".to_string(),
                    "$x".to_string(),
                    "a%2Fb".to_string(),
                    "_".to_string(),
                ];
                key = format!("{head}/{}", bad[pick(rng, bad.len())]);
            }
        }
        let params = params(rng);
        let (payload_kind, payload) = payload(rng);
        let delete = !is_query && pick(rng, 6) == 0;
        let kind = match (&target, delete) {
            (Target::Query { .. }, _) => format!("query/{payload_kind}"),
            (Target::Publish { .. }, true) => "delete".to_string(),
            (Target::Publish { .. }, false) => format!("put/{payload_kind}"),
            (Target::Board { .. }, _) => "blackboard".to_string(),
        };
        Case {
            kind,
            target,
            key,
            params,
            payload,
            delete,
            board: None,
        }
    }

    fn describe(&self) -> String {
        if let Some(b) = &self.board {
            return b.describe();
        }
        let payload = match &self.payload {
            None => "no payload".to_string(),
            Some(p) if p.len() > 60 => format!("{} bytes", p.len()),
            Some(p) => format!("{:?}", String::from_utf8_lossy(p)),
        };
        let params = if self.params.len() > 80 {
            format!("{}…", self.params.chars().take(80).collect::<String>())
        } else {
            self.params.clone()
        };
        format!("{}?{params} with {payload}", self.key)
    }

    async fn send(self, s: &Session, ds: Option<&DataClient>, timeout: Duration) -> Outcome {
        match &self.target {
            Target::Board { .. } => {
                let (Some(b), Some(ds)) = (&self.board, ds) else {
                    return Outcome::Unaddressed;
                };
                let done = b.send(ds).await;
                Outcome::Replied {
                    ok: u64::from(done.is_ok()),
                    error: u64::from(done.is_err()),
                    undecodable: 0,
                }
            }
            Target::Publish { .. } => {
                let Ok(key) = zenoh::key_expr::KeyExpr::try_from(self.key.clone()) else {
                    return Outcome::Published;
                };
                let _ = if self.delete {
                    s.delete(key).await
                } else {
                    s.put(key, self.payload.unwrap_or_default()).await
                };
                Outcome::Published
            }
            Target::Query { served, .. } => {
                let selector = if self.params.is_empty() {
                    self.key.clone()
                } else {
                    format!("{}?{}", self.key, self.params)
                };
                // A name that is not a key expression never leaves this
                // process; Zenoh itself refuses it.
                let Ok(sel) = zenoh::query::Selector::try_from(selector.as_str()) else {
                    return Outcome::Unaddressed;
                };
                // Not one server's key: a bad name no server matches, or
                // a wildcard.
                let addressed = *served
                    && self.key.split('/').all(|c| {
                        c.is_ascii() && !c.is_empty() && !c.starts_with('$') && c.len() < 200
                    });
                let mut get = s.get(sel).timeout(timeout);
                if let Some(p) = self.payload {
                    get = get.payload(p);
                }
                let Ok(replies) = get.await else {
                    return Outcome::Unaddressed;
                };
                let (mut ok, mut error, mut undecodable) = (0, 0, 0);
                while let Ok(reply) = replies.recv_async().await {
                    match reply.result() {
                        Ok(_) => ok += 1,
                        Err(e) => {
                            let bytes = e.payload().to_bytes();
                            if serde_json::from_slice::<ErrorReply>(&bytes).is_ok() {
                                error += 1
                            } else if is_zenoh_timeout(&bytes) {
                                // Zenoh's own "Timeout" reply stands for silence.
                            } else {
                                undecodable += 1
                            }
                        }
                    }
                }
                if !addressed {
                    Outcome::Unaddressed
                } else if ok + error + undecodable == 0 {
                    Outcome::Silent
                } else {
                    Outcome::Replied {
                        ok,
                        error,
                        undecodable,
                    }
                }
            }
        }
    }
}

fn is_zenoh_timeout(bytes: &[u8]) -> bool {
    bytes == b"Timeout" || bytes.is_empty()
}

/// Requests every server must still answer after the run.
async fn good_requests(
    s: &Session,
    root: &Root,
    data: bool,
    robots: &[(String, String)],
) -> Vec<String> {
    let mut failed = Vec::new();
    let r = root.as_str();
    let ask = |sel: String, payload: Option<Vec<u8>>| {
        let s = s.clone();
        async move {
            let mut get = s.get(sel.as_str()).timeout(Duration::from_secs(10));
            if let Some(p) = payload {
                get = get.payload(p);
            }
            let replies = get.await.map_err(|e| format!("{sel}: {e}"))?;
            match replies.recv_async().await {
                Ok(reply) => match reply.result() {
                    Ok(sample) => Ok(sample.payload().to_bytes().to_vec()),
                    Err(e) => Err(format!(
                        "{sel}: {}",
                        String::from_utf8_lossy(&e.payload().to_bytes())
                    )),
                },
                Err(_) => Err(format!("{sel}: no reply")),
            }
        }
    };
    if data {
        let value = format!("{}", Instant::now().elapsed().as_nanos() % 1_000_000 + 17);
        let set = ask(
            format!("{r}/data/set/fz/check"),
            Some(value.clone().into_bytes()),
        )
        .await;
        let got = ask(format!("{r}/data/var/fz/check"), None).await;
        match (set, got) {
            (Ok(_), Ok(v)) if v == value.as_bytes() => {}
            (Err(e), _) | (_, Err(e)) => failed.push(e),
            (_, Ok(v)) => failed.push(format!(
                "fz/check reads {} after writing {value}",
                String::from_utf8_lossy(&v)
            )),
        }
    }
    for (robot, device) in robots {
        let command = match device.as_str() {
            "base" => "pose",
            "proximity" => "sonar",
            _ => "size",
        };
        if let Err(e) = ask(format!("{r}/robot/{robot}/{device}/{command}"), None).await {
            failed.push(e);
        }
    }
    failed
}

fn running(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        // The state follows the command in parentheses; Z is a zombie.
        Ok(stat) => stat
            .rsplit_once(") ")
            .is_some_and(|(_, rest)| !rest.starts_with('Z')),
        Err(_) => false,
    }
}

fn rss_mb(pid: u32) -> f64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}

fn rss_all(pids: &[u32]) -> Vec<f64> {
    pids.iter().map(|p| rss_mb(*p)).collect()
}
