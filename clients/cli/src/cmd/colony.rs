//! `rome colony`: colony-style networks (§4.8.2) as prioritised clients.
//!
//! ```text
//! rome colony priorities fig4_14a          # a built-in network: fig4_14a, fig4_14b, fig3_9
//! rome colony priorities my.colony         # a network file (format in docs/colony.md)
//! rome colony behave wander_avoid_escape avoid --robot r1
//! ```
//!
//! `priorities` prints each module's priority (1 the lowest, as a forward
//! traversal of Table 4.2's binary tree visits them), the client priority
//! to give each module's process (`rome --priority` or
//! `RobotOptions::priority`), and the equivalent if/else program. Exits
//! with 1 on a malformed network.
//!
//! `behave` runs one module of a network as a client process of a robot's
//! base, at the priority the network gives it: every period it reads the
//! latest sonar scan and bumpers, and while its predicate holds sends its
//! command with `suppress_ms`, so the base refuses lower modules' commands
//! meanwhile (docs/colony.md). One JSON line per command sent on stdout.

use crate::args::{CommonArgs, Side};
use anyhow::Context;
use rome_client::robot::{RobotClient, RobotOptions};
use rome_colony::behaviours::{Kind, Module, Senses, SONARS};
use rome_colony::{Network, Priorities};
use rome_schema::ErrorCode;
use std::time::Duration;

/// `rome colony` subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum ColonyCmd {
    /// Print each module's priority and the equivalent if/else program.
    Priorities {
        /// A network file, or a built-in network: fig4_14a, fig4_14b, fig3_9,
        /// wander_avoid_escape.
        network: String,
    },
    /// Run one module of a network as a client of a robot's base, at the
    /// priority the network gives it.
    Behave(BehaveArgs),
}

/// Flags of `rome colony behave`.
#[derive(Debug, clap::Args)]
pub struct BehaveArgs {
    /// A network file or built-in network whose modules include this one.
    pub network: String,
    /// The module to run: wander, avoid or escape.
    pub module: String,
    /// The robot whose base it drives.
    #[arg(long, default_value = "r1")]
    pub robot: String,
    /// Control period, ms.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(10..=10_000))]
    pub period_ms: u64,
    /// How long each command suppresses lower modules, ms (more than the
    /// period, so that a module that keeps sending keeps its claim).
    #[arg(long, default_value_t = 400, value_parser = clap::value_parser!(u64).range(0..=60_000))]
    pub suppress_ms: u64,
    /// Seed of the module's random draws (wander's turns).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long, value_name = "S")]
    pub for_s: Option<f64>,
}

/// Runs a `rome colony` subcommand.
pub async fn run(common: &CommonArgs, cmd: ColonyCmd) -> anyhow::Result<u8> {
    match cmd {
        ColonyCmd::Priorities { network } => priorities(&network),
        ColonyCmd::Behave(args) => behave(common, args).await,
    }
}

/// A built-in network or a file, parsed; and what to call it.
fn load(network: &str) -> anyhow::Result<(String, Network)> {
    let (file, text) = match rome_colony::builtin::text(network) {
        Some(t) => (format!("{network} (built in)"), t.to_string()),
        None => (
            network.to_string(),
            std::fs::read_to_string(network)
                .with_context(|| format!("cannot read the network file {network}"))?,
        ),
    };
    let net = rome_colony::parse(&file, &text)?;
    Ok((file, net))
}

fn priorities(network: &str) -> anyhow::Result<u8> {
    let (file, net) = load(network)?;
    let p = net.priorities();
    let n = p.modules.len();
    println!(
        "{file}: {} module(s), output '{}'; priority 1 is the lowest",
        net.modules().len(),
        net.output_node()
    );
    println!("{:>8}  {:>15}  module", "priority", "client priority");
    for g in &p.modules {
        println!(
            "{:>8}  {:>15}  {}",
            g.priority,
            Priorities::client_priority(g.priority, n),
            g.module
        );
    }
    let silent: Vec<&String> = net.modules().iter().filter(|m| p.of(m).is_none()).collect();
    if !silent.is_empty() {
        println!(
            "only inhibit, never drive the output (Lemma 4.1: their predicates gate the modules they inhibit): {}",
            silent.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
        );
    }
    println!(
        "\nequivalent program, highest priority first:\n\n{}",
        p.program()
    );
    Ok(0)
}

/// One command sent, as `behave` prints it.
#[derive(serde::Serialize)]
struct Sent<'a> {
    /// When the reply came, ms: simulated time when following a
    /// simulator's clock (`--sim-time`), else wall-clock time since the
    /// Unix epoch.
    t_ms: u128,
    /// Whether `t_ms` is simulated time.
    sim: bool,
    module: &'a str,
    priority: u8,
    command: &'a str,
    value: f64,
    /// `done`, `suppressed`, or the error.
    outcome: String,
}

async fn behave(common: &CommonArgs, args: BehaveArgs) -> anyhow::Result<u8> {
    let (file, net) = load(&args.network)?;
    let kind = Kind::from_name(&args.module).with_context(|| {
        format!(
            "no behaviour '{}'; `rome colony behave` runs {}",
            args.module,
            Kind::ALL.map(|(n, _)| n).join(", ")
        )
    })?;
    let p = net.priorities();
    let rank = p.of(&args.module).with_context(|| {
        if net.modules().contains(&args.module) {
            format!("module '{}' of {file} never drives the output (it only inhibits), so it has no priority", args.module)
        } else {
            format!("{file} has no module '{}'; its modules are {}", args.module, net.modules().join(", "))
        }
    })?;
    let priority = Priorities::client_priority(rank, p.modules.len());
    if let Some(s) = args.for_s {
        anyhow::ensure!(
            s.is_finite() && s > 0.0,
            "--for-s must be a positive number of seconds, got {s}"
        );
    }
    let session = common.open(Side::Client).await?;
    let mut options = RobotOptions::new(&format!("colony-{}", args.module));
    options.root = common.root()?;
    options.priority = priority;
    options.suppress = Some(Duration::from_millis(args.suppress_ms));
    // A refused command is the point here, not worth a wait in the queue.
    options.queue_wait = Duration::from_millis(args.period_ms);
    let root = options.root.clone();
    rome_client::alive::await_server(
        &session,
        &root,
        "robot",
        &format!("{}/base", args.robot),
        Duration::from_secs(30),
    )
    .await
    .with_context(|| {
        format!(
            "robot {}'s base server is not running (is `rome sim` up?)",
            args.robot
        )
    })?;
    let rc = RobotClient::connect(&session, &args.robot, options).await?;
    let scans = rc.scans().await?;
    let states = rc.state().await?;
    eprintln!(
        "rome colony behave: module '{}' of {file} on robot {}, priority {rank} of {} (client priority {priority}), every {} ms, suppressing lower modules for {} ms",
        args.module, args.robot, p.modules.len(), args.period_ms, args.suppress_ms
    );
    let mut module = Module::new(kind, args.seed);
    let started = rome_clock::Instant::now();
    let limit = args.for_s.map(Duration::from_secs_f64);
    let mut tick = rome_clock::interval(Duration::from_millis(args.period_ms));
    let (mut periods, mut applied, mut done, mut suppressed, mut failed) =
        (0u64, 0u64, 0u64, 0u64, 0u64);
    let stop = tokio::signal::ctrl_c();
    tokio::pin!(stop);
    loop {
        tokio::select! {
            biased;
            _ = &mut stop => break,
            _ = tick.tick() => {}
        }
        if limit.is_some_and(|l| started.elapsed() >= l) {
            break;
        }
        periods += 1;
        let (Some(Ok(scan)), Some(Ok(state))) = (scans.latest().await, states.latest().await)
        else {
            anyhow::bail!(
                "robot {}'s sensor streams ended (the session closed)",
                args.robot
            );
        };
        let mut sonar = [u16::MAX; SONARS];
        for (s, &r) in sonar.iter_mut().zip(&scan.sonar_mm) {
            *s = u16::try_from(r).unwrap_or(u16::MAX);
        }
        let senses = Senses {
            sonar,
            bumped: state.bumpers != 0,
        };
        let now_ms = started.elapsed().as_millis() as u64;
        let Some(cmd) = module.decide(&senses, now_ms) else {
            continue;
        };
        applied += 1;
        let mut sends: Vec<(&str, f64)> = vec![("go", cmd.velocity_mm_s)];
        if let Some(j) = cmd.jog_deg_s {
            sends.push(("jog", j));
        }
        for (command, value) in sends {
            let result = if command == "go" {
                rc.go(value).await
            } else {
                rc.jog(value).await
            };
            let outcome = match result {
                Ok(_) => {
                    done += 1;
                    "done".to_string()
                }
                Err(e) if e.code() == Some(ErrorCode::Suppressed) => {
                    suppressed += 1;
                    "suppressed".to_string()
                }
                Err(e) => {
                    failed += 1;
                    format!("error: {e}")
                }
            };
            let sim_ms = rome_clock::now_ms();
            let line = Sent {
                t_ms: sim_ms.map_or_else(
                    || {
                        std::time::SystemTime::now()
                            .duration_since(std::time::UNIX_EPOCH)
                            .map_or(0, |d| d.as_millis())
                    },
                    u128::from,
                ),
                sim: sim_ms.is_some(),
                module: &args.module,
                priority,
                command,
                value,
                outcome,
            };
            println!("{}", serde_json::to_string(&line)?);
            if line.outcome == "suppressed" {
                // The rest of this period's command would be refused too.
                break;
            }
        }
    }
    eprintln!(
        "rome colony behave: module '{}' applicable in {applied} of {periods} periods; commands carried out {done}, suppressed {suppressed}, failed {failed}",
        args.module
    );
    let _ = session.close().await;
    Ok(0)
}
