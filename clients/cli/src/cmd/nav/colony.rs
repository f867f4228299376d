//! `rome colony`: colony-style networks (§4.8.2) as prioritised clients.
//!
//! ```text
//! rome colony priorities fig4_14a          # a built-in network: fig4_14a, fig4_14b, fig3_9
//! rome colony priorities my.colony         # a network file (format in docs/colony.md)
//! rome colony behave wander_avoid_escape avoid --robot r1
//! rome colony layer upper --robot r1     # §4.8.1: plans legs, hands them down
//! rome colony layer lower --robot r1     # drives them, reports back up
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
//!
//! `layer` is the hierarchical case (§4.8.1, Figure 4.10): two layers, each
//! its own process, that exchange information only through the data
//! server's variables and semaphores. The upper layer plans a polygon's
//! legs and hands them down one at a time; the lower layer drives each on
//! the base and reports the pose it reached.

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
    /// One layer of a two-layer hierarchy that talks only through the data
    /// server (§4.8.1): upper plans a polygon's legs, lower drives them.
    Layer(LayerArgs),
}

/// Which layer `rome colony layer` runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Which {
    /// Plans the legs, hands each down, reads what the lower layer reports.
    Upper,
    /// Drives each leg it is handed on the robot's base, reports the pose.
    Lower,
}

/// Flags of `rome colony layer`.
#[derive(Debug, clap::Args)]
pub struct LayerArgs {
    /// Which layer to run.
    #[arg(value_enum)]
    pub layer: Which,
    /// The robot.
    #[arg(long, default_value = "r1")]
    pub robot: String,
    /// Upper: sides of the polygon (2: out and back).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(2..=12))]
    pub sides: u32,
    /// Upper: length of a side, mm.
    #[arg(long, default_value_t = 2_000.0)]
    pub side_mm: f64,
}

/// What the upper layer hands down: `layers/<robot>/Leg`.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Leg {
    /// Which leg, from 0.
    leg: u32,
    /// Turn in place first, degrees clockwise.
    turn_deg: f64,
    /// Then go this far, mm.
    distance_mm: f64,
    /// No more legs: the lower layer ends.
    last: bool,
}

/// What the lower layer reports: `layers/<robot>/Report`.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Report {
    /// The leg carried out.
    leg: u32,
    /// The base's pose after it, mm and degrees.
    x_mm: f64,
    y_mm: f64,
    heading_deg: f64,
}

/// The variables and semaphores the two layers share, and nothing else.
struct Shared {
    leg: String,
    report: String,
    leg_ready: String,
    leg_done: String,
}

impl Shared {
    fn of(robot: &str) -> Self {
        Shared {
            leg: format!("layers/{robot}/Leg"),
            report: format!("layers/{robot}/Report"),
            leg_ready: format!("$layers/{robot}/LegReady"),
            leg_done: format!("$layers/{robot}/LegDone"),
        }
    }
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
        ColonyCmd::Layer(args) => layer(common, args).await,
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

/// A client of `robot`'s base once its server is up (waiting up to 30 s,
/// so a behaviour may start before the simulator).
async fn base(
    session: &zenoh::Session,
    robot: &str,
    options: RobotOptions,
) -> anyhow::Result<RobotClient> {
    rome_client::alive::await_server(
        session,
        &options.root,
        "robot",
        &format!("{robot}/base"),
        Duration::from_secs(30),
    )
    .await
    .with_context(|| format!("robot {robot}'s base server is not running (is `rome sim` up?)"))?;
    Ok(RobotClient::connect(session, robot, options).await?)
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
    let rc = base(&session, &args.robot, options).await?;
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
    // Ctrl-C or SIGTERM ends the stream; the counts are still printed.
    let stop = crate::exit::interrupted();
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

async fn layer(common: &CommonArgs, args: LayerArgs) -> anyhow::Result<u8> {
    anyhow::ensure!(
        args.side_mm.is_finite() && (100.0..=50_000.0).contains(&args.side_mm),
        "--side-mm must be 100 … 50 000 mm, got {}",
        args.side_mm
    );
    let role = match args.layer {
        Which::Upper => "layer-upper",
        Which::Lower => "layer-lower",
    };
    let ds = rome_common::connect_data(common, role).await?;
    let names = Shared::of(&args.robot);
    // Either layer may start first: both create the semaphores (one that
    // exists is left as it is).
    for sem in [&names.leg_ready, &names.leg_done] {
        ds.create_semaphore(sem, 0)
            .await
            .with_context(|| format!("cannot create the semaphore {sem}"))?;
    }
    let session = common.open(Side::Client).await?;
    let l = Layer {
        common,
        args: &args,
        ds: &ds,
        names: &names,
        session: &session,
    };
    let out = match args.layer {
        Which::Upper => upper(l).await,
        Which::Lower => lower(l).await,
    };
    let _ = session.close().await;
    out
}

/// What either layer works with: one session and one data client, opened
/// by [`layer`] and closed there whatever the layer's outcome.
#[derive(Clone, Copy)]
struct Layer<'a> {
    common: &'a CommonArgs,
    args: &'a LayerArgs,
    ds: &'a rome_client::DataClient,
    names: &'a Shared,
    session: &'a zenoh::Session,
}

async fn upper(l: Layer<'_>) -> anyhow::Result<u8> {
    // Ground truth only judges the run at the end, as the planner's does;
    // the layers never read it.
    let truth = rome_client::sim::TruthClient::new(l.session, &l.common.root()?, &l.args.robot)?;
    let start = truth.get().await.ok();
    let turn = 360.0 / f64::from(l.args.sides);
    for k in 0..=l.args.sides {
        let leg = Leg {
            leg: k,
            turn_deg: if k == 0 { 0.0 } else { turn },
            distance_mm: l.args.side_mm,
            last: k == l.args.sides,
        };
        l.ds.set(&l.names.leg, &leg).await?;
        l.ds.signal(&l.names.leg_ready).await?;
        if leg.last {
            break;
        }
        println!(
            "upper: leg {k}: turn {:.0}°, go {:.0} mm (handed down)",
            leg.turn_deg, leg.distance_mm
        );
        l.ds.wait(&l.names.leg_done).await?;
        let r: Report =
            l.ds.get_as(&l.names.report).await.with_context(|| {
                format!("the lower layer's report {} is not one", l.names.report)
            })?;
        anyhow::ensure!(
            r.leg == k,
            "the lower layer reported leg {} where leg {k} was handed down",
            r.leg
        );
        println!(
            "upper: leg {k} done: the lower layer reports ({:.0}, {:.0}) mm, heading {:.1}°",
            r.x_mm, r.y_mm, r.heading_deg
        );
    }
    match (start, truth.get().await.ok()) {
        (Some(a), Some(b)) => println!(
            "done: {} legs; ground truth puts {} {:.0} mm from where it started, after {:.0} mm driven",
            l.args.sides,
            l.args.robot,
            (b.x_mm - a.x_mm).hypot(b.y_mm - a.y_mm),
            b.travelled_mm - a.travelled_mm
        ),
        _ => println!("done: {} legs (no ground truth to judge by)", l.args.sides),
    }
    Ok(0)
}

async fn lower(l: Layer<'_>) -> anyhow::Result<u8> {
    let mut options = RobotOptions::new("layer-lower");
    options.root = l.common.root()?;
    let rc = base(l.session, &l.args.robot, options).await?;
    let states = rc.state().await?;
    eprintln!(
        "rome colony layer lower: robot {}'s base reached; waiting for legs on {}",
        l.args.robot, l.names.leg_ready
    );
    loop {
        l.ds.wait(&l.names.leg_ready).await?;
        let leg: Leg =
            l.ds.get_as(&l.names.leg)
                .await
                .with_context(|| format!("the upper layer's leg {} is not one", l.names.leg))?;
        if leg.last {
            println!("lower: no more legs");
            break;
        }
        if leg.turn_deg != 0.0 {
            rc.turn(leg.turn_deg, 60.0, -1.0).await?;
            still(&states).await?;
        }
        rc.move_by(leg.distance_mm, 300.0, -1.0).await?;
        still(&states).await?;
        let p = rc.pose().await?;
        let report = Report {
            leg: leg.leg,
            x_mm: f64::from(p.x_mm),
            y_mm: f64::from(p.y_mm),
            heading_deg: p.heading_deg,
        };
        println!("lower: leg {} driven", leg.leg);
        l.ds.set(&l.names.report, &report).await?;
        l.ds.signal(&l.names.leg_done).await?;
    }
    Ok(0)
}

/// Waits until the base has carried out its last motion: a state that is
/// not moving after one that was, or a minute of states that never moved.
async fn still(
    states: &rome_client::robot::Stream<rome_schema::robot::BaseState>,
) -> anyhow::Result<()> {
    let mut moved = false;
    for _ in 0..600 {
        let s = states
            .next()
            .await
            .context("the base's state stream ended")??;
        // A finished move or turn leaves the base at rest in go mode.
        let moving = matches!(s.mode.as_str(), "point_go" | "point_turn" | "stopping")
            || s.wheel_speed_mm_s.abs() > 1.0;
        if moved && !moving {
            return Ok(());
        }
        moved |= moving;
    }
    anyhow::bail!("the base did not finish its motion within 600 states")
}
