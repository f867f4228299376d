//! `rome demo`: simulated robots driving from room to room, with the data
//! server, each robot's hardware servers and its navigation clients in one
//! process on an in-process Zenoh session: no router, no configuration.
//!
//! It shows each robot's plan, then live progress while they drive, then
//! one row of Table 6.1 per robot (judged by ground truth, failures starred
//! with their reasons), and writes every trajectory on the map to a PNG.
//!
//! ```text
//! rome demo                               # r1: 350R to 376L
//! rome demo --robots 3                    # the map's first three fleet routes
//! rome demo --routes routes.txt           # one FROM TO a line, robot k on line k
//! rome demo --cover-camera r1             # r1 sees no light: its L segment fails
//! rome demo --people 10                   # ten people walking the corridors
//! rome demo --record run.mcap             # and keep everything it published
//! rome demo --trace run.trace             # every instant's ground truth, to the last bit
//! rome -l tcp/127.0.0.1:7447 demo         # others may watch: rome view, rome echo
//! ```
//!
//! With no network flag the run's session talks to nobody else; with
//! `--listen`, `--connect` or `--config` it joins that network as a peer.

use crate::args::{CommonArgs, Side};
use crate::exit;
use anyhow::Context;
use rome_harness::{self as run, Event, PartState, RobotTick, RouteSpec, RunConfig};
use rome_nav::board::GoalType;
use rome_nav::report::Report;
use rome_observe::record::Recorder;
use rome_sim::Noise;
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::Duration;

/// Flags of `rome demo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Start of robot r1: a door jamb like 350R, or RING.NODE.
    #[arg(long, default_value = "350R")]
    pub from: String,
    /// Goal of robot r1.
    #[arg(long, default_value = "376L")]
    pub to: String,
    /// How many robots drive at once: r1 takes --from/--to, the others the
    /// map's fleet routes (EB3 has ten), or routes picked with the seed.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub robots: u32,
    /// A routes file, one `FROM TO` a line: robot k drives line k
    /// (overrides --from, --to and --robots).
    #[arg(long, value_name = "FILE")]
    pub routes: Option<PathBuf>,
    /// Map: a built-in name (eb3, annex, campus, fig5_3) or a .stk file.
    #[arg(long, default_value = "eb3")]
    pub map: String,
    /// A building of several floors instead of one map (the built-in
    /// `tower`, or a .bldg file): --from and --to are `FLOOR:POSITION`
    /// (`3:350R`), robots ride elevators between floors (§5.4.6), and one
    /// picture a floor is drawn (`rome-demo-3.png` …).
    #[arg(long, value_name = "BUILDING", conflicts_with_all = ["map", "robots", "record", "traffic", "lanes", "one_way"])]
    pub building: Option<String>,
    /// With --building: cover this robot's sideways camera (a fault to
    /// inject: it cannot see an elevator's marker). Repeatable.
    #[arg(long, value_name = "ROBOT", requires = "building")]
    pub cover_side: Vec<String>,
    /// With --building: put this elevator's car out of order (a fault to
    /// inject: it takes calls and never comes). Repeatable.
    #[arg(long, value_name = "ELEVATOR", requires = "building")]
    pub out_of_order: Vec<String>,
    /// With --building: stop this elevator's server as soon as its car
    /// first moves with a robot in it, and start it again SECS simulated
    /// seconds later (a fault to inject).
    #[arg(long, value_name = "ELEVATOR:SECS", requires = "building")]
    pub elevator_outage: Option<String>,
    /// Seed of the simulated world (the same seed, the same sensor noise).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// At most this many times real time (default: as fast as the clients
    /// compute; the world steps only when every server and client has
    /// finished with the present instant, so a seed gives the same run).
    #[arg(long)]
    pub speed: Option<f64>,
    /// Pace the world against the wall clock at --speed (default 4) and let
    /// the clients keep up as they can, instead of in lock-step.
    #[arg(long)]
    pub wall_clock: bool,
    /// People walking to and fro in the corridors (placed with the seed),
    /// as the thesis' robot met them in the hallways.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=200))]
    people: u32,
    /// Cruising speed, mm/s, for robots whose route gives none (default:
    /// the Navigator's, 400; rome experiment runs at 700).
    #[arg(long, value_name = "MM_S")]
    pub cruise: Option<f64>,
    /// No sensor noise or wheel slip.
    #[arg(long)]
    pub no_noise: bool,
    /// Where to write the trajectory picture.
    #[arg(long, short = 'o', default_value = "rome-demo.png")]
    pub output: PathBuf,
    /// Give up after this many simulated minutes.
    #[arg(long, default_value_t = 60.0)]
    pub limit_min: f64,
    /// Leave out the local mapper (no heading or sideways correction).
    #[arg(long)]
    pub no_himm: bool,
    /// The traffic flags.
    #[command(flatten)]
    pub rules: super::traffic::TrafficArgs,
    /// Leave out the door-plate finder.
    #[arg(long)]
    pub no_plfinder: bool,
    /// Record everything the run publishes to this MCAP file (as `rome record` does).
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// Write every robot's true pose and sonar ranges at every instant to
    /// this file, each float to its last bit: two runs are the same run
    /// when their traces are the same file (`cmp`).
    #[arg(long, value_name = "FILE", conflicts_with = "building")]
    pub trace: Option<PathBuf>,
    /// Cover this robot's upward camera (a fault to inject: it sees no
    /// ceiling light, and its L segments are reported failed). Repeatable.
    #[arg(long, value_name = "ROBOT")]
    pub cover_camera: Vec<String>,
}

/// `rome demo --building`: the same settings, on a building's floors.
async fn building(
    name: &str,
    args: &Args,
    mut cfg: RunConfig,
    routes: Vec<RouteSpec>,
) -> anyhow::Result<u8> {
    let building = rome_maps::load_building_named(name)
        .with_context(|| format!("cannot load the building '{name}'"))?;
    cfg.seed = args.seed;
    cfg.speed = args.speed;
    cfg.lockstep = !args.wall_clock;
    cfg.himm = !args.no_himm;
    cfg.covered = args.cover_camera.clone();
    cfg.people = args.people as usize;
    cfg.limit = rome_common::minutes("--limit-min", args.limit_min)?;
    if args.no_noise {
        cfg.noise = Noise::none();
    }
    let outage = match &args.elevator_outage {
        Some(spec) => {
            let (car, secs) = spec.rsplit_once(':').with_context(|| {
                format!("--elevator-outage '{spec}': give ELEVATOR:SECS, such as old.elevator:30")
            })?;
            let secs: f64 = secs
                .parse()
                .ok()
                .filter(|s: &f64| s.is_finite() && (0.0..=3_600.0).contains(s))
                .with_context(|| format!("--elevator-outage '{spec}': SECS must be 0 … 3600"))?;
            Some((car.to_string(), Duration::from_secs_f64(secs)))
        }
        None => None,
    };
    let known: Vec<&str> = building
        .elevators
        .iter()
        .map(|e| e.number.as_str())
        .collect();
    for car in args
        .out_of_order
        .iter()
        .chain(outage.iter().map(|(c, _)| c))
    {
        anyhow::ensure!(
            known.contains(&car.as_str()),
            "the building '{}' has no elevator '{car}'; it has {}",
            building.name,
            known.join(", ")
        );
    }
    for name in &args.cover_side {
        anyhow::ensure!(
            routes.iter().any(|r| &r.robot == name),
            "--cover-side {name}: no such robot in this run"
        );
    }
    let faults = rome_harness::floors::FloorFaults {
        side_covered: args.cover_side.clone(),
        out_of_order: args.out_of_order.clone(),
        outage,
    };
    super::floors::run(super::floors::FloorsDemo {
        building,
        routes,
        cfg,
        faults,
        output: args.output.clone(),
    })
    .await
}

/// The routes the flags ask for.
fn routes(args: &Args, map: &rome_maps::Map) -> anyhow::Result<Vec<RouteSpec>> {
    if let Some(path) = &args.routes {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read the routes file {}", path.display()))?;
        return Ok(run::parse_routes(&path.display().to_string(), &text)?);
    }
    let first = RouteSpec::new("r1", &args.from, &args.to);
    let n = args.robots as usize;
    if n == 1 {
        return Ok(vec![first]);
    }
    let mut out = vec![first];
    let extra = match rome_maps::builtin::routes(&args.map) {
        Some(text) => run::parse_routes(&format!("{} routes (built in)", args.map), text)?,
        None => Vec::new(),
    };
    for r in extra {
        if out.len() == n {
            break;
        }
        // r1's own start is taken: skip a built-in route that starts there.
        if out.iter().any(|o| o.from == r.from) {
            continue;
        }
        out.push(RouteSpec {
            robot: format!("r{}", out.len() + 1),
            ..r
        });
    }
    if out.len() < n {
        out = run::pick_routes(map, out, n, args.seed)?;
    }
    Ok(out)
}

/// Runs the demo.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    args.rules.without_tasks()?;
    let map = rome_maps::load_named(&args.map)?;
    let limit = rome_common::minutes("--limit-min", args.limit_min)?;
    let mut routes = routes(&args, &map)?;
    if let Some(v) = args.cruise {
        rome_common::check_cruise(v)?;
        for r in routes.iter_mut().filter(|r| r.cruise_mm_s.is_none()) {
            r.cruise_mm_s = Some(v);
        }
    }
    for name in &args.cover_camera {
        anyhow::ensure!(
            routes.iter().any(|r| &r.robot == name),
            "--cover-camera {name}: no such robot in this run (robots are r1 … r{})",
            routes.len()
        );
    }
    let n = routes.len();
    let mut cfg = RunConfig::fleet(map.clone(), routes.clone());
    if let Some(b) = &args.building {
        return building(b, &args, cfg, routes).await;
    }
    cfg.seed = args.seed;
    cfg.speed = args.speed;
    cfg.lockstep = !args.wall_clock;
    cfg.himm = !args.no_himm;
    cfg.plfinder = !args.no_plfinder;
    cfg.covered = args.cover_camera.clone();
    cfg.people = args.people as usize;
    cfg.rules = args.rules.to_rules();
    cfg.trace = args.trace.clone();
    cfg.limit = limit;
    if args.no_noise {
        cfg.noise = Noise::none();
    }
    let networked =
        common.config.is_some() || !common.connect.is_empty() || !common.listen.is_empty();
    if networked {
        let mut net = common.net(Side::Server);
        if net.mode.is_none() {
            net.mode = Some("peer".into());
        }
        cfg.net = net;
    }
    let root = common.root()?;
    anyhow::ensure!(
        root.as_str() == rome_schema::keys::DEFAULT_ROOT,
        "rome demo runs under the root '{}'; --root {} is not supported here",
        rome_schema::keys::DEFAULT_ROOT,
        root.as_str()
    );
    let mut recorder: Option<anyhow::Result<Recorder>> = None;
    let mut lengths = vec![0.0; n];
    let mut screen = Live::new(std::io::stdout().is_terminal());
    let mut next_line_s = 0.0;
    let mut modes: Vec<String> = vec!["-".into(); n];
    let fleet = run::run_fleet(cfg, &mut |event| match event {
        Event::Started { session } => {
            // Before the world steps, so the recording has the start.
            let handle = tokio::runtime::Handle::current();
            tokio::task::block_in_place(|| {
                if networked {
                    let at = handle.block_on(rome_client::net::locators(&session));
                    eprintln!("{}{}", rome_client::net::LISTENING, at.join(" "));
                }
                if let Some(path) = &args.record {
                    let keys = [format!("{}/**", root.as_str())];
                    recorder = Some(handle.block_on(Recorder::start(&session, &keys, path, false)));
                }
            });
        }
        Event::Planned { robot, plan } => {
            lengths[robot] = plan.route.length_mm / 1_000.0;
            let r = &routes[robot];
            println!(
                "{} plan {} -> {} on '{}': {:.3} m, {} corner(s), {} goal(s){}",
                r.robot,
                r.from,
                r.to,
                map.name,
                lengths[robot],
                plan.route.turns,
                plan.steps.len(),
                if plan.passages.is_empty() {
                    String::new()
                } else {
                    format!(
                        "; narrow passage(s) {}",
                        plan.passages
                            .iter()
                            .map(|p| p.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                }
            );
            for line in plan.describe() {
                println!("  {line}");
            }
        }
        Event::Goal { robot, handed } => {
            let g = &handed.step.goal;
            let unit = if g.goal_type == GoalType::L {
                "light(s)"
            } else {
                "mm"
            };
            modes[robot] = format!("{:?} {}", g.goal_type, handed.index + 1);
            screen.line(&format!(
                "[{} goal {}] {:?} {} {unit} heading {:.0}°",
                routes[robot].robot,
                handed.index + 1,
                g.goal_type,
                g.distance,
                g.direction_deg
            ));
        }
        Event::Judged { robot, handed } => {
            if let Some(why) = &handed.failure {
                screen.line(&format!(
                    "[{} goal {}] failed: {why}",
                    routes[robot].robot,
                    handed.index + 1
                ));
            }
        }
        Event::Traffic { robot, part, state } => {
            // Junctions are taken and given back at every corner: only a
            // wait is worth a line; a narrow passage's every change is.
            let what = match state {
                PartState::Waiting => "waits for",
                PartState::Holding => "enters",
                PartState::Left => "has left",
            };
            if state == PartState::Waiting || part.starts_with("$passage/") {
                screen.line(&format!(
                    "[{}] {what} {}",
                    routes[robot].robot,
                    rome_nav::traffic::describe(&part)
                ));
            }
        }
        Event::Finished { robot, report } => {
            modes[robot] = if report.arrived() {
                "arrived".into()
            } else {
                "stopped".into()
            };
            screen.line(&format!(
                "[{}] {} {:.0} cm from {}",
                routes[robot].robot, modes[robot], report.miss_cm, report.to
            ));
        }
        Event::Tick { time_s, robots } => {
            let lines: Vec<(u64, String)> = robots
                .iter()
                .enumerate()
                .map(|(k, t)| {
                    let share = t.travelled_mm / 1_000.0 / lengths[k].max(0.001);
                    (
                        (share * 1000.0).clamp(0.0, 1000.0) as u64,
                        status(&routes[k].robot, time_s, t, lengths[k], &modes[k]),
                    )
                })
                .collect();
            if screen.tty {
                screen.draw(&lines);
            } else if time_s >= next_line_s {
                // Into a file or a pipe: lines every ten simulated seconds.
                for (_, l) in &lines {
                    println!("{l}");
                }
                next_line_s = time_s + 10.0;
            }
        }
    })
    .await;
    let recorded = match recorder {
        Some(Ok(r)) => Some(r.stop().await),
        Some(Err(e)) => Some(Err(e)),
        None => None,
    };
    let fleet = fleet.context("the run failed")?;
    screen.clear();
    println!();
    println!("{}", fleet.table());
    for why in fleet.reasons() {
        println!("{why}");
    }
    println!();
    for r in &fleet.robots {
        summary(r);
    }
    let world = rome_maps::World::from_map(&map);
    let png = fleet.picture(&map, &world, 1600);
    std::fs::write(&args.output, png)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    println!(
        "trajectories: {} ({} robot(s), {:.1?} of wall time)",
        args.output.display(),
        fleet.robots.len(),
        fleet.wall_time
    );
    if let (Some(path), Some(summary)) = (&args.record, recorded) {
        let s = summary.with_context(|| format!("the recording to {} failed", path.display()))?;
        println!(
            "recording: {} ({} message(s) on {} channel(s) over {:.1} s; `rome replay {}` plays it)",
            path.display(),
            s.messages,
            s.channels,
            s.span_s,
            path.display()
        );
    }
    // A run in which a robot did not reach its goal is a failed run, for
    // scripts too.
    if fleet.robots.len() < n || fleet.robots.iter().any(|r| !r.arrived()) {
        return Ok(exit::ERROR);
    }
    Ok(exit::OK)
}

/// One robot's progress line.
fn status(robot: &str, time_s: f64, t: &RobotTick, total_m: f64, mode: &str) -> String {
    format!(
        "  {robot:<4}{:>3}:{:02}  {:<8} driven {:>7.2} m of {:.1}  at ({:.1}, {:.1}) m heading {:>4.0}°  odometry off {:>4.2} m",
        (time_s as u64) / 60,
        (time_s as u64) % 60,
        mode,
        t.travelled_mm / 1_000.0,
        total_m,
        t.pose.at.x / 1_000.0,
        t.pose.at.y / 1_000.0,
        t.pose.heading,
        t.odometry_error_mm / 1_000.0
    )
}

/// What one robot's run came to, in words.
fn summary(r: &Report) {
    let verdict = match &r.failure {
        None if r.arrived() => "arrived",
        None => "stopped, off the goal:",
        Some(why) => {
            eprintln!("error: {} did not arrive: {why}", r.robot);
            "gave up"
        }
    };
    println!(
        "{}: {verdict} {:.0} cm from {} ({:+.0} cm along the corridor, {:.0} cm across) by ground truth; {} simulated",
        r.robot,
        r.miss_cm,
        r.to,
        r.to_goal_cm,
        r.off_line_cm,
        fmt_time(r.run_time),
    );
    let seen: usize = r.lights().map(|s| s.seen).sum();
    let missed: usize = r.lights().map(|s| s.missed).sum();
    println!(
        "    ceiling lights: {seen} seen, {missed} missed; corrections: {} (sideways {} of them); in-place turns: {}; door plates: {}; odometry off by {:.2} m at the end, {:.2} m at most",
        r.fixes.len(),
        r.fixes.iter().filter(|f| f.shift_mm != 0.0).count(),
        r.nav.turns,
        r.plates.len(),
        r.odometry_error_cm.unwrap_or(0.0) / 100.0,
        r.odometry_max_error_cm.unwrap_or(0.0) / 100.0,
    );
    let named: Vec<String> = r.plates.iter().filter_map(|p| p.label.clone()).collect();
    if !named.is_empty() {
        println!("    plates read as: {}", named.join(" "));
    }
}

fn fmt_time(d: Duration) -> String {
    format!("{}:{:02}", d.as_secs() / 60, d.as_secs() % 60)
}

/// Progress on a terminal: one indicatif bar per robot (the share of its
/// route driven, with its status), event lines scrolling above them.
/// Elsewhere, plain lines.
struct Live {
    tty: bool,
    multi: indicatif::MultiProgress,
    bars: Vec<indicatif::ProgressBar>,
}

impl Live {
    fn new(tty: bool) -> Live {
        Live {
            tty,
            multi: indicatif::MultiProgress::new(),
            bars: Vec::new(),
        }
    }

    /// Takes the bars off the screen.
    fn clear(&mut self) {
        for b in self.bars.drain(..) {
            b.finish_and_clear();
        }
        let _ = self.multi.clear();
    }

    /// An event line, above the bars.
    fn line(&mut self, text: &str) {
        if self.tty && !self.bars.is_empty() {
            let _ = self.multi.println(text);
        } else {
            println!("{text}");
        }
    }

    /// Moves each robot's bar: `done` per mille of its route, and its line.
    fn draw(&mut self, rows: &[(u64, String)]) {
        while self.bars.len() < rows.len() {
            let bar = self.multi.add(indicatif::ProgressBar::new(1000));
            if let Ok(style) = indicatif::ProgressStyle::with_template("[{bar:24}] {msg}") {
                bar.set_style(style.progress_chars("=> "));
            }
            self.bars.push(bar);
        }
        for (bar, (done, line)) in self.bars.iter().zip(rows) {
            bar.set_position(*done);
            bar.set_message(line.clone());
        }
        let _ = std::io::stdout().flush();
    }
}
