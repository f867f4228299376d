//! The `rome` command-line program: it parses flags and hands them to the
//! libraries that do the work.
//!
//! How this crate is laid out:
//! - [`Cli`] and [`Command`]: every command and its flags, with
//!   [`CommonArgs`](args::CommonArgs) (the Zenoh and deployment flags,
//!   from `rome-common`) flattened in.
//! - [`cmd`]: the commands, grouped: `data` (data-server, data, sem),
//!   `robot` (sim, pioneer, robot, storage, elevator-server, elevator,
//!   ros2), `nav` (planner, navigator,
//!   ctracker, mapper, plfinder, crew, dispatcher, task, demo, experiment,
//!   fleet, colony, map), `observe` (ls, echo, record, replay, view,
//!   foxglove), `deploy` (router, certs) and `tools` (bench, soak, fuzz).
//! - [`main`] and [`run`]: the runtime, the interrupt, the lock-step clock
//!   a command may follow, and the exit code.
//!
//! Cargo features, all on by default: `observe` (the observing tools, a
//! web server and MCAP), `sim` (the simulator, `rome demo` and `rome
//! experiment`; it takes `observe` along for `demo --record`), `tools`
//! (benchmarks, soak, fuzz; they start `rome sim`, so `sim` too),
//! `router` (a Zenoh router with its plugins, and `rome certs`) and `ros2`
//! (`rome ros2`, the robots as ROS 2 topics). With none
//! of them `rome` is the robot-side program: the data server, the hardware
//! servers of a real base, the navigation clients and the commands to them.
//!
//! `main` only parses flags and calls [`main`]; everything else is here so
//! tests and benchmarks can call commands without a subprocess.

pub mod cmd;

pub use rome_common::{args, exit, out, progress};

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Command-line client and servers for RoME over Zenoh.
#[derive(Debug, Parser)]
#[command(
    name = "rome",
    version,
    about = "RoME over Zenoh: data server, robot servers and clients for robot navigation",
    long_about = "RoME over Zenoh: the client-server robot control architecture of the thesis \
(data server, hardware servers, navigation clients) on Zenoh.\n\n\
Every program meets the others through Zenoh. With no --connect/--listen/--config, servers \
listen on tcp/0.0.0.0:7447 and clients connect to tcp/127.0.0.1:7447, so one machine works \
out of the box; point --connect at a router or server for anything else. Servers run as \
Zenoh peers and everything else as Zenoh clients unless --mode says otherwise.",
    after_help = "Exit codes: 0 success, 1 error, 2 bad usage, 3 not acquired / timed out (sem try-wait, sem wait --timeout), 130 interrupted, 141 output pipe closed.\n\
Keys, payloads and plain-Zenoh examples: docs/keys.md"
)]
pub struct Cli {
    /// Zenoh and deployment flags.
    #[command(flatten)]
    pub common: args::CommonArgs,
    /// The command.
    #[command(subcommand)]
    pub command: Command,
}

/// The commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the data server (DServer): shared variables and semaphores.
    DataServer(cmd::data::server::Args),
    /// Read, write and watch shared variables.
    #[command(subcommand)]
    Data(cmd::data::vars::DataCmd),
    /// Create, signal and wait on semaphores.
    #[command(subcommand)]
    Sem(cmd::data::sem::SemCmd),
    /// List the live servers and clients, and each robot's devices with their stream rates.
    #[cfg(feature = "observe")]
    Ls(cmd::observe::ls::Args),
    /// Record everything heard on some keys to an MCAP file (Ctrl-C to stop).
    #[cfg(feature = "observe")]
    Record(cmd::observe::record::Args),
    /// Put an MCAP recording back on Zenoh with its original timing.
    #[cfg(feature = "observe")]
    Replay(cmd::observe::replay::Args),
    /// Serve a live web page of the fleet: map, poses, trails, sonar, routes, blackboards, cameras.
    #[cfg(feature = "observe")]
    View(cmd::observe::view::Args),
    /// Serve the fleet's traffic live to Foxglove (its WebSocket protocol): every JSON key a channel, cameras as images.
    #[cfg(feature = "observe")]
    Foxglove(cmd::observe::foxglove::Args),
    /// Print any key's traffic (puts, deletes, liveliness, replies with --get), or its rates with --hz.
    #[cfg(feature = "observe")]
    Echo(cmd::observe::echo::Args),
    /// Check and draw StickRep maps.
    #[command(subcommand)]
    Map(cmd::nav::map::MapCmd),
    /// Run a simulated world and every robot's base, proximity and camera servers.
    #[cfg(feature = "sim")]
    Sim(cmd::robot::sim::Args),
    /// Run the base and proximity servers of a Pioneer robot on a serial line (P2OS).
    Pioneer(cmd::robot::pioneer::Args),
    /// Send commands to a robot's hardware servers (base, proximity, cameras).
    Robot(cmd::robot::commands::Args),
    /// Bridge robots to ROS 2: odom, sonar and ground_truth published, cmd_vel read, in CDR.
    #[cfg(feature = "ros2")]
    Ros2(cmd::robot::ros2::Args),
    /// Run a building's elevators as simulated cars, each with its server (call, go, open, close, session, buttons).
    #[cfg(feature = "sim")]
    ElevatorServer(cmd::robot::elevator_server::Args),
    /// Send commands to an elevator's server, or press its buttons as a person would.
    Elevator(cmd::robot::elevator::Args),
    /// Keep the servers' lock state in memory (a Zenoh storage on ROOT/store/**).
    Storage(cmd::robot::storage::Args),
    /// Run a Zenoh router with the storage manager and REST plugins built in.
    #[cfg(feature = "router")]
    Router(cmd::deploy::router::Args),
    /// Make a deployment's TLS certificates and passwords (for --identity and --secrets).
    #[cfg(feature = "router")]
    Certs(cmd::deploy::certs::Args),
    /// Run everything in one process: a simulated robot drives from room to room (no router, no configuration).
    #[cfg(feature = "sim")]
    Demo(cmd::nav::demo::Args),
    /// Measure fleets of several sizes given the same tasks: tasks done, waits, throughput, efficiency, contacts.
    #[cfg(feature = "sim")]
    Fleet(cmd::nav::scale::Args),
    /// Rerun Chapter 6's runs (Tables 6.1 and 6.2) in simulation, several at a time, and tabulate them beside the thesis'.
    #[cfg(feature = "sim")]
    Experiment(cmd::nav::experiment::Args),
    /// Path Planner (§5.3): plan a route, register the robot at its start, hand goals to the Navigator.
    Planner(cmd::nav::clients::PlannerArgs),
    /// Navigator (§5.4): carry out the Planner's goals with the Center-Hallway and Corner states.
    Navigator(cmd::nav::clients::NavigatorArgs),
    /// Ceiling-light tracker, CTracker (§5.6): count the lights of each light-tracking segment.
    Ctracker(cmd::nav::clients::CTrackerArgs),
    /// Local mapper, HIMM (§5.5): sonar map and Hough transform to correct the heading.
    Mapper(cmd::nav::clients::RobotArg),
    /// Door-plate finder, PlFinder (§5.7): report the door plates the side camera sees.
    Plfinder(cmd::nav::clients::PlFinderArgs),
    /// A robot's navigation clients as processes, each started again when it ends (as `ros2 launch` with respawn).
    Crew(cmd::nav::crew::Args),
    /// The fleet's dispatcher: hand each task to the free robot with the shortest route to it.
    Dispatcher(cmd::nav::fleet::DispatcherArgs),
    /// Add, list and cancel the fleet's tasks.
    #[command(subcommand)]
    Task(cmd::nav::fleet::TaskCmd),
    /// Colony-style networks as prioritised clients (§4.8.2): module priorities and the equivalent program.
    #[command(subcommand)]
    Colony(cmd::nav::colony::ColonyCmd),
    /// Measure round trips and throughput.
    #[cfg(feature = "tools")]
    #[command(subcommand)]
    Bench(cmd::tools::bench::BenchCmd),
    /// Send generated garbage to every key of a running deployment and check that nothing broke.
    #[cfg(feature = "tools")]
    Fuzz(cmd::tools::fuzz::Args),
    /// Chaos soak on loopback: robots, clients and data-server load while processes and links are killed at random; then check that nothing was lost.
    #[cfg(feature = "tools")]
    Soak(cmd::tools::soak::Args),
}

/// The environment variable Zenoh reads its runtimes' layout from.
pub const ZENOH_RUNTIME_ENV: &str = "ZENOH_RUNTIME";

/// How `rome` lays out Zenoh's runtimes unless `ZENOH_RUNTIME` is set:
/// reading links, running callbacks, accepting and managing links share
/// one pool of two threads, and writing to links keeps a thread of its
/// own (a callback waiting for room on a congested link must never hold
/// up the thread that makes the room). Fewer threads than Zenoh's default
/// (two for reading, one each for the rest) and fewer hand-overs between
/// them: a fifth off a round trip on loopback (docs/benchmarks.md).
pub const ZENOH_RUNTIME: &str =
    "(rx: (handover: app), acc: (handover: app), net: (handover: app), app: (worker_threads: 2))";

/// The exit status a shell gives a program ended by a broken pipe
/// (128 + SIGPIPE).
const BROKEN_PIPE_EXIT: i32 = 141;

/// A reader that stops reading (`rome planner … --dry-run | head -1`) ends
/// the program quietly, with the status a shell gives a broken pipe, as
/// it ends other command-line tools. Rust ignores SIGPIPE, so the next
/// line printed would otherwise panic. Putting the signal back would do
/// it too, but would also let it kill a server writing to a socket or a
/// pipe whose reader has gone.
fn quiet_on_broken_pipe() {
    let before = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let text = (payload.downcast_ref::<String>().map(String::as_str))
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or_default();
        if text.starts_with("failed printing to stdout") && text.contains("Broken pipe") {
            std::process::exit(BROKEN_PIPE_EXIT);
        }
        before(info);
    }));
}

/// Whether Zenoh can read the layout in `ZENOH_RUNTIME`; what is wrong
/// with it if not. Zenoh reads the variable when it first starts a
/// runtime and panics on a value it cannot parse; this reads it first,
/// with the panic caught and its message kept, and starts no thread.
pub fn check_zenoh_runtime() -> Result<(), String> {
    let said = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
    let hook = std::panic::take_hook();
    {
        let said = said.clone();
        std::panic::set_hook(Box::new(move |info| {
            let text = info
                .payload()
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| info.payload().downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            if let Ok(mut s) = said.lock() {
                *s = text;
            }
        }));
    }
    let read = std::panic::catch_unwind(|| {
        let _ = &*zenoh_runtime::ZRUNTIME_PARAM;
    });
    std::panic::set_hook(hook);
    match read {
        Ok(()) => Ok(()),
        Err(_) => {
            let value = std::env::var(ZENOH_RUNTIME_ENV).unwrap_or_default();
            let why = said.lock().map(|s| s.clone()).unwrap_or_default();
            Err(format!(
                "{ZENOH_RUNTIME_ENV}='{value}' is not a layout Zenoh can read ({why}); unset it for rome's own, or give Zenoh's RON form, e.g. '()' for Zenoh's defaults"
            ))
        }
    }
}

/// The commands a build may leave out, each with the cargo feature that
/// brings it (all on by default; a robot-side build has none of them).
pub const OPTIONAL_COMMANDS: &[(&str, &str, bool)] = &[
    ("ls", "observe", cfg!(feature = "observe")),
    ("record", "observe", cfg!(feature = "observe")),
    ("replay", "observe", cfg!(feature = "observe")),
    ("view", "observe", cfg!(feature = "observe")),
    ("foxglove", "observe", cfg!(feature = "observe")),
    ("echo", "observe", cfg!(feature = "observe")),
    ("sim", "sim", cfg!(feature = "sim")),
    ("demo", "sim", cfg!(feature = "sim")),
    ("experiment", "sim", cfg!(feature = "sim")),
    ("fleet", "sim", cfg!(feature = "sim")),
    ("router", "router", cfg!(feature = "router")),
    ("ros2", "ros2", cfg!(feature = "ros2")),
    ("certs", "router", cfg!(feature = "router")),
    ("bench", "tools", cfg!(feature = "tools")),
    ("fuzz", "tools", cfg!(feature = "tools")),
    ("soak", "tools", cfg!(feature = "tools")),
];

/// Parses the command line as clap does, except that a command this build
/// left out is named as such, with the feature that brings it back,
/// instead of being called unknown.
pub fn parse() -> Cli {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    use clap::Parser;
    let e = match Cli::try_parse() {
        Ok(cli) => return cli,
        Err(e) => e,
    };
    if e.kind() == ErrorKind::InvalidSubcommand {
        if let Some(ContextValue::String(name)) = e.get(ContextKind::InvalidSubcommand) {
            if let Some((_, feature, _)) =
                OPTIONAL_COMMANDS.iter().find(|(n, _, on)| n == name && !on)
            {
                eprintln!(
                    "error: '{name}' is not in this build of rome: it comes with the cargo feature '{feature}' \
                     (cargo install --path clients/cli --features {feature}, or the default build)"
                );
                std::process::exit(i32::from(exit::USAGE));
            }
        }
    }
    e.exit()
}

/// Runs a parsed command line and returns the process exit code.
pub fn main(cli: Cli) -> ExitCode {
    quiet_on_broken_pipe();
    let server = cli.command.is_server();
    cli.common.init_logging(server);
    // These end on the interrupt themselves, to finish what they write.
    let own_interrupt = server || cli.command.ends_on_interrupt();
    let runtime = match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
    {
        Ok(rt) => rt,
        Err(e) => {
            eprintln!("error: cannot start the async runtime: {e}");
            return ExitCode::from(exit::ERROR);
        }
    };
    let code = runtime.block_on(async {
        // A member of a `rome crew` whose crew was killed ends with it.
        tokio::spawn(async {
            rome_common::supervise::end_when_orphaned().await;
            // Its standard error was a pipe to the crew, which has gone:
            // a failed write must not keep it from ending.
            use std::io::Write;
            let _ = writeln!(
                std::io::stderr(),
                "error: the `rome crew` that started this program has gone; ending"
            );
            std::process::exit(i32::from(exit::ERROR));
        });
        let result = if own_interrupt {
            // A server takes the interrupt as its shutdown signal and exits 0.
            run(cli).await
        } else {
            tokio::select! {
                result = run(cli) => result,
                _ = exit::interrupted() => Ok(exit::INTERRUPTED),
            }
        };
        result.unwrap_or_else(|e| {
            eprintln!("error: {e:#}");
            exit::ERROR
        })
    });
    // Zenoh's background tasks must not hold the process open.
    runtime.shutdown_timeout(std::time::Duration::from_millis(500));
    ExitCode::from(code)
}

/// Runs one command; `Ok` carries the exit code.
pub async fn run(cli: Cli) -> anyhow::Result<u8> {
    // The data server follows the clock on its own session.
    if !cli.common.sim_time || matches!(cli.command, Command::DataServer(_)) {
        return run_command(cli).await;
    }
    anyhow::ensure!(
        !cli.command.keeps_its_own_time(),
        "--sim-time is for the data server and the clients that follow a simulator (`rome sim` keeps the clock itself)"
    );
    let session = cli.common.open(args::Side::Client).await?;
    args::share_session(&session);
    let root = cli.common.root()?;
    // The same in every run of the same command, whatever its ports or
    // process id: it orders this process's requests among the others'.
    let name = format!("rome {:?}", cli.command);
    let out = rome_client::simtime::follow(&session, &root, &name, run_command(cli)).await;
    let _ = session.close().await;
    out?
}

impl Command {
    /// A server: it logs at info and takes the interrupt as its shutdown.
    fn is_server(&self) -> bool {
        match self {
            Command::DataServer(_) | Command::Storage(_) | Command::Pioneer(_) => true,
            #[cfg(feature = "sim")]
            Command::Sim(_) | Command::ElevatorServer(_) => true,
            #[cfg(feature = "router")]
            Command::Router(_) => true,
            _ => false,
        }
    }

    /// A command that ends on the interrupt itself, to finish what it writes.
    fn ends_on_interrupt(&self) -> bool {
        match self {
            Command::Colony(cmd::nav::colony::ColonyCmd::Behave(_)) => true,
            // It stops its members first.
            Command::Crew(_) => true,
            #[cfg(feature = "observe")]
            Command::Record(_) | Command::View(_) | Command::Foxglove(_) => true,
            // It stops the robots it set moving.
            #[cfg(feature = "ros2")]
            Command::Ros2(_) => true,
            _ => false,
        }
    }

    /// A command that keeps its own time (or none): `--sim-time` is not
    /// for it.
    fn keeps_its_own_time(&self) -> bool {
        match self {
            Command::Storage(_) | Command::Pioneer(_) => true,
            #[cfg(feature = "sim")]
            Command::Sim(_)
            | Command::ElevatorServer(_)
            | Command::Demo(_)
            | Command::Experiment(_)
            | Command::Fleet(_) => true,
            #[cfg(feature = "tools")]
            Command::Bench(_) | Command::Soak(_) => true,
            #[cfg(feature = "router")]
            Command::Router(_) => true,
            _ => false,
        }
    }
}

async fn run_command(cli: Cli) -> anyhow::Result<u8> {
    let common = cli.common;
    match cli.command {
        Command::DataServer(args) => cmd::data::server::run(&common, args).await,
        Command::Data(c) => cmd::data::vars::run(&common, c).await,
        Command::Sem(c) => cmd::data::sem::run(&common, c).await,
        #[cfg(feature = "observe")]
        Command::Ls(args) => cmd::observe::ls::run(&common, args).await,
        #[cfg(feature = "observe")]
        Command::Echo(args) => cmd::observe::echo::run(&common, args).await,
        #[cfg(feature = "observe")]
        Command::View(args) => cmd::observe::view::run(&common, args).await,
        #[cfg(feature = "observe")]
        Command::Foxglove(args) => cmd::observe::foxglove::run(&common, args).await,
        #[cfg(feature = "observe")]
        Command::Record(args) => cmd::observe::record::run(&common, args).await,
        #[cfg(feature = "observe")]
        Command::Replay(args) => cmd::observe::replay::run(&common, args).await,
        Command::Map(c) => cmd::nav::map::run(c),
        #[cfg(feature = "ros2")]
        Command::Ros2(args) => cmd::robot::ros2::run(&common, args).await,
        #[cfg(feature = "sim")]
        Command::Sim(args) => cmd::robot::sim::run(&common, args).await,
        Command::Pioneer(args) => cmd::robot::pioneer::run(&common, args).await,
        Command::Robot(args) => cmd::robot::commands::run(&common, args).await,
        #[cfg(feature = "sim")]
        Command::ElevatorServer(args) => cmd::robot::elevator_server::run(&common, args).await,
        Command::Elevator(args) => cmd::robot::elevator::run(&common, args).await,
        Command::Storage(args) => cmd::robot::storage::run(&common, args).await,
        #[cfg(feature = "router")]
        Command::Router(args) => cmd::deploy::router::run(&common, args).await,
        #[cfg(feature = "router")]
        Command::Certs(args) => cmd::deploy::certs::run(args),
        #[cfg(feature = "sim")]
        Command::Demo(args) => cmd::nav::demo::run(&common, args).await,
        #[cfg(feature = "sim")]
        Command::Experiment(args) => cmd::nav::experiment::run(args).await,
        #[cfg(feature = "sim")]
        Command::Fleet(args) => cmd::nav::scale::run(args).await,
        Command::Colony(c) => cmd::nav::colony::run(&common, c).await,
        Command::Planner(args) => cmd::nav::clients::planner(&common, args).await,
        Command::Dispatcher(args) => cmd::nav::fleet::dispatcher(&common, args).await,
        Command::Crew(args) => cmd::nav::crew::run(&common, args).await,
        Command::Task(c) => cmd::nav::fleet::task(&common, c).await,
        Command::Navigator(args) => cmd::nav::clients::navigator(&common, args).await,
        Command::Ctracker(args) => cmd::nav::clients::ctracker(&common, args).await,
        Command::Mapper(args) => cmd::nav::clients::mapper(&common, args).await,
        Command::Plfinder(args) => cmd::nav::clients::plfinder(&common, args).await,
        #[cfg(feature = "tools")]
        Command::Bench(c) => cmd::tools::bench::run(c).await,
        #[cfg(feature = "tools")]
        Command::Fuzz(args) => cmd::tools::fuzz::run(&common, args).await,
        #[cfg(feature = "tools")]
        Command::Soak(args) => cmd::tools::soak::run(&common, args).await,
    }
}
