//! `rome bench sim`: how fast the simulator runs a building full of robots,
//! in simulated seconds per wall-clock second, on one thread and, from
//! [`rome_sim::world::PARALLEL_FROM`] robots on, on every core (the robots'
//! senses are computed in parallel; their motion stays on one thread).
//!
//! Every robot wanders the corridors (keeps to the middle with jog, turns
//! away when something is close, bumpers watched) while its ring fires the 24
//! sonars one after another, each ten times a second; with cameras on, both
//! cameras also grab every 0.5 s, as the camera server does (§4.6.4).

use rome_maps::geometry::direction;
use rome_sim::rng::Rng;
use rome_sim::{Mode, Pose, Sim, SimConfig};
use serde::Serialize;
use std::time::{Duration, Instant};

/// Flags of `rome bench sim`.
#[derive(Debug, clap::Args)]
pub struct SimBench {
    /// The map: a file, or a built-in map (eb3, annex, campus, fig5_3).
    #[arg(long, default_value = "eb3")]
    pub map: String,
    /// Robot counts to measure.
    #[arg(long, value_delimiter = ',', default_values_t = [1usize, 10, 100, 1000])]
    pub robots: Vec<usize>,
    /// Wall-clock seconds to run each row (at least one simulated second).
    #[arg(long, default_value_t = 3.0)]
    pub seconds: f64,
    /// Seed of the world and of where the robots start.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Measure with cameras off only.
    #[arg(long)]
    pub no_cameras: bool,
    /// Print JSON rows instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// One measurement.
#[derive(Debug, Clone, Serialize)]
pub struct SimRow {
    /// Robots in the world.
    pub robots: usize,
    /// Whether both cameras grabbed every 0.5 s.
    pub cameras: bool,
    /// Threads the robots were sensed on.
    pub threads: usize,
    /// Simulated seconds run.
    pub sim_s: f64,
    /// Wall-clock seconds taken.
    pub wall_s: f64,
    /// Simulated seconds per wall-clock second.
    pub speed: f64,
    /// Sonar scans (24 ranges each) per wall-clock second.
    pub scans_per_s: f64,
}

/// Places `n` robots in corridors: abeam door jambs, spread along and across.
fn populate(sim: &mut Sim, n: usize, rng: &mut Rng) -> anyhow::Result<()> {
    let spots: Vec<(f64, f64, f64, f64)> = sim
        .scene()
        .world
        .positions
        .values()
        .map(|p| {
            let c = p.in_corridor();
            (c.x, c.y, p.wall_heading_deg, p.lateral_mm)
        })
        .collect();
    let mut placed = 0;
    let mut tries = 0;
    while placed < n {
        tries += 1;
        anyhow::ensure!(
            tries < 2_000 * n + 1_000,
            "the map has no room for {n} robots ({placed} placed)"
        );
        let (x, y, h, lateral) = spots[(rng.next_u64() % spots.len() as u64) as usize];
        let along = direction(h);
        let across = direction(h - 90.0);
        let u = (rng.uniform() - 0.5) * 12_000.0;
        let v = (rng.uniform() - 0.5) * (lateral - 500.0).max(0.0);
        let heading = if rng.chance(0.5) { h } else { h + 180.0 };
        let at = rome_maps::geometry::pt(x, y) + along * u + across * v;
        let pose = Pose::new(at.x, at.y, heading);
        if sim.add_robot(&format!("r{placed}"), pose).is_ok() {
            let r = sim.robot_mut(placed);
            r.bumpers.watch = true;
            r.drive.go(400.0)?;
            placed += 1;
        }
    }
    Ok(())
}

/// The wander behaviour, run every half second of simulated time.
fn wander(sim: &mut Sim, rng: &mut Rng) -> anyhow::Result<()> {
    for i in 0..sim.robots().len() {
        let (sonar, mode, bumped) = {
            let r = sim.robot(i);
            (r.sonar, r.drive.mode, r.bumpers.status() != 0)
        };
        if matches!(mode, Mode::PointTurn { .. }) {
            continue;
        }
        let ahead = sonar[10..=14].iter().copied().min().unwrap_or(10_000);
        let drive = &mut sim.robot_mut(i).drive;
        if bumped || ahead < 900 || mode == Mode::Joystick {
            // Turned from Go, the base goes on at 400 mm/s after the turn.
            drive.go(400.0)?;
            drive.turn(120.0 + 60.0 * rng.uniform(), 60.0, 120.0)?;
        } else {
            // Towards the side with more room: left is sonar 18.
            let lean = (f64::from(sonar[18]) - f64::from(sonar[6])) / 200.0;
            if !matches!(mode, Mode::Go { .. } | Mode::Jog { .. }) {
                drive.go(400.0)?;
            }
            drive.jog((-lean).clamp(-8.0, 8.0))?;
        }
    }
    Ok(())
}

/// A pool of `threads` for one measurement, so a row's thread count is
/// the one it reports whatever the host has.
fn pool_of(threads: usize) -> anyhow::Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| anyhow::anyhow!("no pool of {threads} threads: {e}"))
}

/// One row, measured on the pool it is called from.
fn measure(
    args: &SimBench,
    map: &rome_maps::Map,
    n: usize,
    cameras: bool,
    threads: usize,
) -> anyhow::Result<SimRow> {
    let config = SimConfig {
        seed: args.seed,
        sonar_period_ms: 100,
        camera_period_ms: if cameras { 500 } else { 0 },
        ..SimConfig::default()
    };
    let mut sim = Sim::new(map, config);
    let mut rng = Rng::new(args.seed.wrapping_add(n as u64));
    populate(&mut sim, n, &mut rng)?;
    let budget = Duration::from_secs_f64(args.seconds.max(0.1));
    let start_ms = sim.time_ms();
    let started = Instant::now();
    while started.elapsed() < budget || sim.time_ms() - start_ms < 1_000 {
        sim.step();
        if sim.time_ms().is_multiple_of(500) {
            wander(&mut sim, &mut rng)?;
        }
        if sim.time_ms() - start_ms >= 600_000 {
            break;
        }
    }
    let wall_s = started.elapsed().as_secs_f64();
    let sim_s = (sim.time_ms() - start_ms) as f64 / 1000.0;
    Ok(SimRow {
        robots: n,
        cameras,
        threads,
        sim_s,
        wall_s,
        speed: sim_s / wall_s,
        scans_per_s: n as f64 * sim_s * 1000.0 / f64::from(sim.config().sonar_period_ms) / wall_s,
    })
}

/// Runs the benchmark, printing progress on stderr.
pub fn rows(args: &SimBench) -> anyhow::Result<Vec<SimRow>> {
    let map = rome_maps::load_named(&args.map).map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut out = Vec::new();
    let passes = if args.no_cameras { 1 } else { 2 };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // One thread, and every core where the senses are spread over them.
    let threads = |n: usize| {
        if n >= rome_sim::world::PARALLEL_FROM && cores > 1 {
            vec![1, cores]
        } else {
            vec![1]
        }
    };
    let count: usize = args.robots.iter().map(|&n| threads(n).len()).sum();
    let mut bar =
        rome_common::progress::Progress::bar("bench sim", "measurements", (passes * count) as u64);
    for cameras in [false, true] {
        if cameras && args.no_cameras {
            continue;
        }
        for &n in &args.robots {
            for t in threads(n) {
                bar.step(
                    out.len() as u64,
                    &format!(
                        "{n} robot(s), cameras {}, {t} thread(s)",
                        if cameras { "on" } else { "off" }
                    ),
                );
                out.push(pool_of(t)?.install(|| measure(args, &map, n, cameras, t))?);
            }
        }
    }
    bar.finish();
    Ok(out)
}

/// The rows as a table.
pub fn table(rows: &[SimRow]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:>7} {:>8} {:>8} {:>9} {:>9} {:>14} {:>14}",
        "robots", "cameras", "threads", "sim s", "wall s", "sim s/wall s", "sonar scans/s"
    );
    for r in rows {
        let _ = writeln!(
            out,
            "{:>7} {:>8} {:>8} {:>9.1} {:>9.2} {:>14.1} {:>14.0}",
            r.robots,
            if r.cameras { "on" } else { "off" },
            r.threads,
            r.sim_s,
            r.wall_s,
            r.speed,
            r.scans_per_s
        );
    }
    let _ = writeln!(
        out,
        "(threads: the robots' senses; motion on one; each sonar 10 Hz, fired in turn; cameras 512x482, both every 0.5 s when on)"
    );
    out
}
