//! `rome sim`: one simulated world and the base, proximity and camera
//! servers of every robot in it, until Ctrl-C or SIGTERM.

use crate::args::CommonArgs;
use crate::exit;
use anyhow::Context;
use rome_hardware::robot::Rates;
use rome_sim::{Noise, Sim, SimConfig};
use rome_sim_hardware::robot::spawn_sim_robot;
use rome_sim_hardware::world::SimWorld;
use std::path::PathBuf;
use std::time::Duration;

/// Flags of `rome sim`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The map: a built-in name (eb3, annex, campus, fig5_3) or a StickRep file.
    #[arg(long, default_value = "eb3", value_name = "MAP")]
    pub map: String,
    /// A building of several floors instead of one map: the built-in
    /// `tower` or a .bldg file. Its floors lie side by side in one world,
    /// a car runs in every elevator shaft, each with its elevator server
    /// (`<root>/building/elevator/<name>/…`), positions are `FLOOR:POS`
    /// (`3:350R`) and ground truth names each robot's floor.
    #[arg(long, value_name = "BUILDING", conflicts_with = "map")]
    pub building: Option<String>,
    /// How many robots (named r1, r2, …).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub robots: u32,
    /// Number of the first robot: `--first 3 --robots 2` runs r3 and r4,
    /// so several worlds (one `rome sim` each) can share one deployment.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub first: u32,
    /// Where they start: named positions (350R, 376L …), one per robot;
    /// without it robots are spread over the map's doors.
    #[arg(long, value_delimiter = ',', value_name = "POS")]
    pub at: Vec<String>,
    /// Seed of the world's randomness: the same seed gives the same run.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Simulated time per real time (1 = real time).
    #[arg(long, default_value_t = 1.0, conflicts_with = "free")]
    pub speed: f64,
    /// Run as fast as the machine allows.
    #[arg(long)]
    pub free: bool,
    /// Step in lock-step with the servers and with every process started
    /// with --sim-time: each instant waits until all have finished with
    /// it, so a run goes as fast as they compute and the same seed gives
    /// the same run whatever the machine's load. The clock is published
    /// at every step.
    #[arg(long, conflicts_with_all = ["free", "speed"])]
    pub lockstep: bool,
    /// With --lockstep: hold the clock at its start until N processes
    /// follow it (clients started with --sim-time), so that a run split
    /// into processes starts at the same instant for all of them.
    #[arg(long, value_name = "N", requires = "lockstep", default_value_t = 0)]
    pub parties: usize,
    /// No sensor noise, slip or drift.
    #[arg(long)]
    pub no_noise: bool,
    /// Base state stream rate, Hz of simulated time (0: off).
    #[arg(long, default_value_t = 10.0, value_name = "HZ")]
    pub state_hz: f64,
    /// How often the proximity server looks for a new scan, Hz of
    /// simulated time (0: off).
    #[arg(long, default_value_t = 40.0, value_name = "HZ")]
    pub scan_hz: f64,
    /// Ground-truth stream rate (`<root>/sim/<robot>/truth`), Hz of
    /// simulated time (0: answer queries only).
    #[arg(long, default_value_t = 2.0, value_name = "HZ")]
    pub truth_hz: f64,
    /// Camera grab period, ms of simulated time (the thesis: 500).
    #[arg(long, default_value_t = 500, value_name = "MS", value_parser = clap::value_parser!(u64).range(10..=60_000))]
    pub camera_period_ms: u64,
    /// Do not run a storage for lock state (use a router's storage instead).
    #[arg(long)]
    pub no_storage: bool,
    /// People walking to and fro in the corridors (met by sonar, infrared
    /// and bumpers like robots; placed with --seed, 3 m or more from every
    /// robot).
    #[arg(long, default_value_t = 0, value_name = "N", value_parser = clap::value_parser!(u32).range(0..=1000))]
    pub people: u32,
    /// Keep the robots' state in FILE: where each truly stands, its
    /// odometry and its base's virtual frame, written every 100 ms of
    /// simulated time. Started again on the same file, the world takes
    /// them up, as a real robot stands where it was when the computer
    /// serving it restarts. Without the file, robots start as placed.
    #[arg(long, value_name = "FILE")]
    pub state: Option<PathBuf>,
    /// Write every robot's true pose and sonar ranges at every instant to
    /// this file, each float to its last bit (as `rome demo --trace`): two
    /// lock-step runs are the same run when their traces are the same.
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
}

fn period(hz: f64, flag: &str) -> anyhow::Result<Option<Duration>> {
    anyhow::ensure!(
        hz.is_finite() && (0.0..=1000.0).contains(&hz),
        "{flag} must be 0 … 1000 Hz, got {hz}"
    );
    Ok((hz > 0.0).then(|| Duration::from_secs_f64(1.0 / hz)))
}

/// A world as the flags ask: robots placed, and for a building the
/// floors' layout.
pub struct Built {
    /// The world.
    pub sim: Sim,
    /// Its robots' names.
    pub names: Vec<String>,
    /// Where a building's floors lie (`None`: one map).
    pub plane: Option<rome_maps::plane::Plane>,
}

/// Builds the world with its robots placed.
pub fn world(args: &Args) -> anyhow::Result<Built> {
    let config = SimConfig {
        seed: args.seed,
        noise: if args.no_noise {
            Noise::none()
        } else {
            Noise::default()
        },
        camera_period_ms: 0,
        ..SimConfig::default()
    };
    let (mut sim, map, plane) = match &args.building {
        Some(b) => {
            let building = rome_maps::load_building_named(b)
                .with_context(|| format!("cannot load the building '{b}'"))?;
            let (sim, plane) =
                Sim::for_building(&building, config, rome_sim::elevator::CarSpec::default())?;
            (sim, plane.map.clone(), Some(plane))
        }
        None => {
            let map = rome_maps::load_named(&args.map)
                .with_context(|| format!("cannot load the map '{}'", args.map))?;
            (Sim::new(&map, config), map, None)
        }
    };
    let n = args.robots as usize;
    anyhow::ensure!(
        args.at.is_empty() || args.at.len() == n,
        "--at names {} position(s) for {n} robot(s); give one per robot",
        args.at.len()
    );
    let mut names = Vec::new();
    if !args.at.is_empty() {
        for (k, pos) in args.at.iter().enumerate() {
            let name = format!("r{}", args.first as usize + k);
            let heading = sim
                .scene()
                .world
                .position(pos)
                .map_or(0.0, |p| p.wall_heading_deg);
            sim.add_robot_at(&name, pos, heading)
                .with_context(|| format!("cannot place {name} at {pos}"))?;
            names.push(name);
        }
        sim.add_people(&map, args.people as usize, args.seed)?;
        return Ok(Built { sim, names, plane });
    }
    let mut spots: Vec<(String, f64)> = sim
        .scene()
        .world
        .positions
        .iter()
        .map(|(name, p)| (name.clone(), p.wall_heading_deg))
        .collect();
    spots.sort_by(|a, b| a.0.cmp(&b.0));
    anyhow::ensure!(
        !spots.is_empty(),
        "the map '{}' has no named positions",
        args.map
    );
    let mut tried = 0;
    while names.len() < n && tried < spots.len() * 2 {
        let (pos, heading) = &spots[(tried * 7919 + names.len() * spots.len() / n) % spots.len()];
        tried += 1;
        let name = format!("r{}", args.first as usize + names.len());
        if sim.add_robot_at(&name, pos, *heading).is_ok() {
            names.push(name);
        }
    }
    anyhow::ensure!(
        names.len() == n,
        "the map '{}' has room for only {} robot(s) at its doors",
        args.map,
        names.len()
    );
    sim.add_people(&map, args.people as usize, args.seed)?;
    Ok(Built { sim, names, plane })
}

/// Takes up the world's state from `path` if it is there, and keeps it
/// there from now on.
fn take_up(
    world: &SimWorld,
    path: &std::path::Path,
    pace: f64,
) -> anyhow::Result<tokio::task::JoinHandle<()>> {
    use rome_sim_hardware::keep;
    if let Some(kept) = keep::read(path)? {
        let unknown = keep::restore(world, &kept);
        eprintln!(
            "rome sim: took up the state in {} ({:.1} s of simulated time)",
            path.display(),
            kept.time_ms as f64 / 1000.0
        );
        if !unknown.is_empty() {
            eprintln!(
                "rome sim: {} names robot(s) not in this world, left out: {}",
                path.display(),
                unknown.join(", ")
            );
        }
    }
    let task = keep::spawn_keeper(world.clone(), path.to_path_buf(), pace);
    Ok(task)
}

/// Runs the world and its servers.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    anyhow::ensure!(
        args.free || (args.speed.is_finite() && args.speed > 0.0 && args.speed <= 1_000.0),
        "--speed must be a positive number up to 1000, got {}",
        args.speed
    );
    // Rates are in simulated time: at 4 × real time the servers run four
    // times as often (free-running: as given, in real time).
    let pace = if args.free || args.lockstep {
        1.0
    } else {
        args.speed
    };
    let sim_time = |d: Duration| Duration::from_secs_f64((d.as_secs_f64() / pace).max(0.001));
    let rates = Rates {
        state: period(args.state_hz, "--state-hz")?.map(sim_time),
        scan: period(args.scan_hz, "--scan-hz")?.map(sim_time),
        camera: sim_time(Duration::from_millis(args.camera_period_ms)),
    };
    let truth_every = period(args.truth_hz, "--truth-hz")?.map(sim_time);
    let Built { sim, names, plane } = world(&args)?;
    let cars: Vec<String> = sim.cars().map(|(n, _)| n.to_string()).collect();
    let root = common.root()?;
    let (session, net) = common.open_server().await?;
    let world = match plane {
        Some(plane) => SimWorld::on_plane(sim, plane),
        None => SimWorld::new(sim),
    };
    let _keeper = match &args.state {
        Some(path) => Some(take_up(&world, path, pace)?),
        None => None,
    };
    if let Some(path) = &args.trace {
        world
            .trace_to(path)
            .with_context(|| format!("cannot write the trace {}", path.display()))?;
    }
    let clock = args
        .lockstep
        .then(|| rome_clock::LockStep::new(world.lock().time_ms()));
    let (storage_stop, storage_stopped) = tokio::sync::oneshot::channel::<()>();
    let storage = (!args.no_storage).then(|| {
        let (session, root) = (session.clone(), root.clone());
        tokio::spawn(async move {
            rome_hardware::storage::run(session, &root, root.store_all(), async move {
                let _ = storage_stopped.await;
            })
            .await
        })
    });
    let spawn_servers = async {
        let mut servers = vec![rome_sim_hardware::robot::spawn_truth(
            &session,
            &root,
            &world,
            truth_every,
        )];
        for name in &names {
            servers.extend(spawn_sim_robot(&session, &root, &world, name, rates)?);
        }
        let mut buttons = Vec::new();
        for car in &cars {
            let config = rome_hardware::ServerConfig::elevator(&root, car)?;
            let device = rome_sim_hardware::elevator::WorldCar::new(world.clone(), car)?;
            let (server, pressed) =
                rome_hardware::elevator::spawn_elevator(&session, config, device, rates.state)
                    .await?;
            servers.push(server);
            buttons.push(pressed);
        }
        anyhow::Ok((servers, buttons))
    };
    // In lock-step the servers are the clock's participants: spawned in one.
    let (mut servers, _buttons, _stepper) = match &clock {
        Some(clock) => {
            let (servers, buttons) = clock.participate("rome sim", spawn_servers).await?;
            let parties =
                rome_sim_hardware::lockstep::Parties::follow(&session, &root, clock).await?;
            if args.parties > 0 {
                eprintln!(
                    "rome sim: holding the clock until {} process(es) follow it (--sim-time)…",
                    args.parties
                );
                let mut said = parties.len();
                // The start instant, over and over: a follower declares
                // itself once it has heard the clock.
                let start = rome_schema::sim::Clock::instant(clock.now_ms(), true);
                let interrupted = exit::interrupted();
                tokio::pin!(interrupted);
                while parties.len() < args.parties {
                    rome_sim_hardware::lockstep::publish_clock(&session, &root.sim_clock(), &start)
                        .await
                        .map_err(|e| anyhow::anyhow!("cannot publish the clock: {e}"))?;
                    if parties.len() != said {
                        said = parties.len();
                        eprintln!("rome sim: {said} of {} follow the clock", args.parties);
                    }
                    tokio::select! {
                        _ = &mut interrupted => return Ok(exit::INTERRUPTED),
                        _ = tokio::time::sleep(Duration::from_millis(100)) => {}
                    }
                }
            }
            let stepper = rome_sim_hardware::lockstep::start_lockstep_with(
                &session, &root, &world, clock, parties,
            );
            (servers, buttons, stepper)
        }
        None => {
            let (mut servers, buttons) = spawn_servers.await?;
            servers.push(rome_sim_hardware::robot::spawn_clock(
                &session,
                &root,
                &world,
                sim_time(Duration::from_millis(rome_schema::sim::CLOCK_EVERY_MS)),
                false,
            ));
            let stepper = world.start((!args.free).then_some(args.speed));
            (servers, buttons, stepper)
        }
    };
    {
        let sim = world.lock();
        for r in sim.robots() {
            let (floor, at) = match world.plane().and_then(|p| p.local(r.pose.at)) {
                Some((f, at)) => (format!(" on floor {f}"), at),
                None => (String::new(), r.pose.at),
            };
            eprintln!(
                "{}: at ({:.0}, {:.0}) mm{floor} heading {:.0}°",
                r.name, at.x, at.y, r.pose.heading
            );
        }
        for (number, car) in sim.cars() {
            eprintln!(
                "elevator {number}: floors {}, at {}; serving '{}/building/elevator/{number}/…'",
                car.floors().join(", "),
                car.floor(),
                root.as_str()
            );
        }
    }
    let place = match &args.building {
        Some(b) => format!("building '{b}'"),
        None => format!("map '{}'", args.map),
    };
    eprintln!(
        "rome sim: {place}, {} robot(s), {} (listen {:?}, connect {:?}); serving '{}/robot/<robot>/{{base,proximity,camera/up,camera/side}}/*' and ground truth on '{}'; Ctrl-C to stop",
        names.len(),
        if args.lockstep {
            "in lock-step with its clients".to_string()
        } else if args.free {
            "free-running".to_string()
        } else {
            format!("{}× real time", args.speed)
        },
        net.listen,
        net.connect,
        root.as_str(),
        root.sim_truth_all()
    );
    let mut watch = tokio::time::interval(Duration::from_millis(500));
    let interrupted = exit::interrupted();
    tokio::pin!(interrupted);
    loop {
        tokio::select! {
            _ = &mut interrupted => break,
            _ = watch.tick() => {
                // A server that ended is reported once, with why; the
                // others go on.
                let (ended, running): (Vec<_>, Vec<_>) =
                    servers.into_iter().partition(|s| s.is_finished());
                servers = running;
                for s in ended {
                    let label = s.label().to_string();
                    match s.stop().await {
                        Ok(()) => eprintln!("rome sim: the server of {label} has stopped; the others go on"),
                        Err(e) => eprintln!("rome sim: the server of {label} has stopped: {e}; the others go on"),
                    }
                }
            }
        }
    }
    for s in servers {
        if let Err(e) = s.stop().await {
            eprintln!("rome sim: {e}");
        }
    }
    let _ = storage_stop.send(());
    if let Some(task) = storage {
        let _ = task.await;
    }
    let _ = session.close().await;
    Ok(exit::OK)
}
