//! `rome demo --building`: robots driven between floors of a building in
//! one process (§5.4.6), each riding an elevator; prints each plan with its
//! floors, each goal as it is handed over and judged, and where each robot
//! ended by ground truth, floor included; draws one picture a floor.

use anyhow::Context;
use rome_harness::floors::{run_floors, FloorFaults, FloorsReport};
use rome_harness::{RouteSpec, RunConfig};
use rome_maps::building::Building;
use rome_maps::render::{self, Shape};
use rome_nav::board::GoalType;
use rome_nav::planner::Progress;
use rome_nav::report::robot_color;
use std::path::{Path, PathBuf};

/// How far from its goal a robot between floors has arrived, mm.
pub const ARRIVED_MM: f64 = 500.0;

/// What `rome demo --building` runs.
pub struct FloorsDemo {
    /// The building.
    pub building: Building,
    /// The routes, `FLOOR:POSITION` at both ends.
    pub routes: Vec<RouteSpec>,
    /// Seed, noise, pace and the rest of a run's settings.
    pub cfg: RunConfig,
    /// Faults to inject.
    pub faults: FloorFaults,
    /// The picture's path: one picture a floor, the floor's name added.
    pub output: PathBuf,
}

/// `out.png` for floor `3` is `out-3.png`.
fn floor_path(output: &Path, floor: &str) -> PathBuf {
    let stem = output
        .file_stem()
        .map_or("rome-demo".into(), |s| s.to_string_lossy().to_string());
    let ext = output
        .extension()
        .map_or("png".into(), |s| s.to_string_lossy().to_string());
    output.with_file_name(format!("{stem}-{floor}.{ext}"))
}

/// Runs the demo; the exit code says whether every robot arrived.
pub async fn run(demo: FloorsDemo) -> anyhow::Result<u8> {
    let mut cfg = demo.cfg;
    cfg.building = Some(demo.building.clone());
    cfg.routes = demo.routes.clone();
    for r in &demo.routes {
        let fp = rome_nav::floors::FloorPlan::new(&demo.building, &r.from, &r.to)
            .with_context(|| format!("{}: cannot plan {} -> {}", r.robot, r.from, r.to))?;
        let title = format!(
            "{} plan {} -> {} in '{}'",
            r.robot, r.from, r.to, demo.building.name
        );
        super::between::describe(&title, &fp);
    }
    let names: Vec<String> = demo.routes.iter().map(|r| r.robot.clone()).collect();
    let run = run_floors(cfg, demo.faults, |k, p| {
        let name = &names[k];
        match p {
            Progress::Handed(h) => {
                println!("[{name} goal {}] {}", h.index + 1, super::between::goal(h));
            }
            Progress::Done(h) => {
                if let Some(why) = &h.failure {
                    println!("[{name} goal {}] failed: {why}", h.index + 1);
                } else if let (GoalType::V, Some(t)) = (h.step.goal.goal_type, &h.truth) {
                    println!(
                        "[{name} goal {}] out on floor {} at ({:.0}, {:.0}) mm",
                        h.index + 1,
                        t.floor.as_deref().unwrap_or("?"),
                        t.x_mm,
                        t.y_mm
                    );
                }
            }
            _ => {}
        }
    })
    .await?;
    let mut all = true;
    for r in &run.robots {
        all &= r.arrived_within(ARRIVED_MM);
        println!("{}", summary(r));
    }
    for (car, holder) in &run.sessions {
        if let Some(h) = holder {
            println!("elevator {car}: its session is still held by {h}");
        }
    }
    for (floor, path) in pictures(&demo.building, &run.robots, &demo.output)? {
        println!("floor {floor}: {}", path.display());
    }
    // A run in which a robot did not reach its goal is a failed run, for
    // scripts too.
    Ok(if all {
        crate::exit::OK
    } else {
        crate::exit::ERROR
    })
}

/// One line on how a robot's run ended.
fn summary(r: &FloorsReport) -> String {
    let to = r.plan.to.as_str();
    let place = match (r.end.floor.as_deref(), r.miss_mm) {
        (Some(f), Some(m)) => format!("on floor {f}, {:.0} cm from {to}", m / 10.0),
        (f, _) => format!("on floor {}, not {to}'s", f.unwrap_or("?")),
    };
    let verdict = if r.arrived_within(ARRIVED_MM) {
        "arrived"
    } else {
        "stopped"
    };
    let why = r
        .failure
        .as_ref()
        .map_or(String::new(), |w| format!("\n  why: {w}"));
    format!(
        "{}: {verdict} {place}; {} contact(s); {:.1} s simulated, {:.1} s wall{why}",
        r.robot,
        r.contacts,
        r.run_time.as_secs_f64(),
        r.wall_time.as_secs_f64()
    )
}

/// One picture a floor any robot walked: the floor's map, each robot's
/// route on it and where it truly went there.
fn pictures(
    building: &Building,
    robots: &[FloorsReport],
    output: &Path,
) -> anyhow::Result<Vec<(String, PathBuf)>> {
    let mut out = Vec::new();
    for floor in &building.floors {
        // The floors walked: a car passing a floor carries its riders
        // through it, which is no walk there.
        if !robots
            .iter()
            .any(|r| r.plan.walks.iter().any(|(f, _)| f == &floor.name))
        {
            continue;
        }
        let mut overlay: Vec<Shape> = Vec::new();
        for (k, r) in robots.iter().enumerate() {
            for (f, plan) in &r.plan.walks {
                if f == &floor.name {
                    overlay.extend(render::route_shapes(&plan.route));
                }
            }
            let here: Vec<_> = r
                .trail
                .iter()
                .filter(|(f, _)| f == &floor.name)
                .map(|(_, p)| *p)
                .collect();
            for w in here.windows(2) {
                overlay.push(Shape::Line {
                    a: w[0],
                    b: w[1],
                    color: robot_color(k),
                    width: 2.0,
                    dashed: false,
                });
            }
            if let Some(end) = here.last() {
                overlay.push(Shape::Dot {
                    at: *end,
                    radius: 4.0,
                    color: robot_color(k),
                });
            }
        }
        if overlay.is_empty() {
            continue;
        }
        let img = render::raster(&floor.map, &floor.world, 1600, &overlay);
        let path = floor_path(output, &floor.name);
        img.save(&path)
            .with_context(|| format!("cannot write {}", path.display()))?;
        out.push((floor.name.clone(), path));
    }
    Ok(out)
}

/// What `rome experiment --building` runs.
pub struct FloorsExperiment {
    /// The building.
    pub building: Building,
    /// The routes, each run `repeats` times.
    pub routes: Vec<RouteSpec>,
    /// How many times each route is run.
    pub repeats: usize,
    /// Seed of the first run; run k has seed SEED + k.
    pub seed: u64,
    /// Runs at a time.
    pub jobs: usize,
    /// Noise, limits and the rest of every run's settings.
    pub cfg: RunConfig,
    /// Where runs.md and runs.csv go.
    pub out: PathBuf,
}

/// One run of the experiment and how it went.
struct Trial {
    no: usize,
    route: RouteSpec,
    seed: u64,
    report: Result<FloorsReport, String>,
}

impl Trial {
    /// The elevator the plan rides, `-` for none.
    fn elevator(&self) -> String {
        self.report
            .as_ref()
            .ok()
            .and_then(|r| r.plan.ride.as_ref())
            .and_then(|s| s.ride.as_ref())
            .map_or("-".into(), |x| x.elevator.clone())
    }

    /// The row's cells, as the CSV header names them.
    fn cells(&self) -> Vec<String> {
        let (arrived, floor, miss, ride, contacts, sim, wall, why) = match &self.report {
            Ok(r) => (
                r.arrived_within(ARRIVED_MM),
                r.end.floor.clone().unwrap_or_default(),
                r.miss_mm
                    .map_or(String::new(), |m| format!("{:.1}", m / 10.0)),
                match r.ride() {
                    Some(h) if h.failure.is_none() => "ok".to_string(),
                    Some(_) => "failed".into(),
                    None => "-".into(),
                },
                r.contacts.to_string(),
                format!("{:.1}", r.run_time.as_secs_f64()),
                format!("{:.1}", r.wall_time.as_secs_f64()),
                r.failure.clone().unwrap_or_default(),
            ),
            Err(e) => (
                false,
                String::new(),
                String::new(),
                "-".into(),
                String::new(),
                String::new(),
                String::new(),
                e.clone(),
            ),
        };
        vec![
            self.no.to_string(),
            self.route.from.clone(),
            self.route.to.clone(),
            self.seed.to_string(),
            self.elevator(),
            if arrived { "yes" } else { "no" }.to_string(),
            floor,
            miss,
            ride,
            contacts,
            sim,
            wall,
            why,
        ]
    }

    /// The CSV row: the reason quoted, since it may hold commas.
    fn csv(&self) -> String {
        let mut cells = self.cells();
        if let Some(why) = cells.last_mut() {
            *why = format!("\"{}\"", why.replace('"', "'"));
        }
        cells.join(",")
    }

    /// The line said when it ends, and the Markdown row.
    fn line(&self) -> String {
        let path = format!("{} -> {}", self.route.from, self.route.to);
        match &self.report {
            Ok(r) if r.arrived_within(ARRIVED_MM) => format!(
                "{:>3} {path}: arrived, {:.0} cm from the goal on floor {}, by {}",
                self.no,
                r.miss_mm.unwrap_or(0.0) / 10.0,
                r.end.floor.as_deref().unwrap_or("?"),
                self.elevator()
            ),
            Ok(r) => format!(
                "{:>3} {path}: FAILED: {}",
                self.no,
                r.failure.clone().unwrap_or_else(|| summary(r))
            ),
            Err(e) => format!("{:>3} {path}: FAILED: {e}", self.no),
        }
    }
}

/// Runs the experiment; the exit code says whether every run arrived.
pub async fn experiment(x: FloorsExperiment) -> anyhow::Result<u8> {
    std::fs::create_dir_all(&x.out)
        .with_context(|| format!("cannot make the directory {}", x.out.display()))?;
    let mut todo = Vec::new();
    for _ in 0..x.repeats {
        for r in &x.routes {
            let no = todo.len() + 1;
            let seed = x.seed.wrapping_add((no - 1) as u64);
            todo.push((no, RouteSpec::new("r1", &r.from, &r.to), seed));
        }
    }
    let total = todo.len();
    eprintln!(
        "{total} run(s) between the floors of '{}', {} at a time, seeds {}…{}",
        x.building.name,
        x.jobs,
        x.seed,
        x.seed.wrapping_add(total as u64 - 1)
    );
    let mut progress = crate::progress::Progress::bar("experiment", "runs", total as u64);
    let mut running = tokio::task::JoinSet::new();
    let mut trials: Vec<Trial> = Vec::new();
    let mut queue = todo.into_iter();
    let mut failed = 0usize;
    loop {
        while running.len() < x.jobs.max(1) {
            let Some((no, route, seed)) = queue.next() else {
                break;
            };
            let mut cfg = x.cfg.clone();
            cfg.building = Some(x.building.clone());
            cfg.routes = vec![route.clone()];
            cfg.seed = seed;
            running.spawn(async move {
                let run = run_floors(cfg, FloorFaults::default(), |_, _| {}).await;
                let report = run
                    .map_err(|e| e.to_string())
                    .and_then(|mut r| r.robots.pop().ok_or_else(|| "no report".to_string()));
                Trial {
                    no,
                    route,
                    seed,
                    report,
                }
            });
        }
        let Some(done) = running.join_next().await else {
            break;
        };
        let trial = done.context("a run's task failed")?;
        if !trial
            .report
            .as_ref()
            .is_ok_and(|r| r.arrived_within(ARRIVED_MM))
        {
            failed += 1;
        }
        progress.println(&trial.line());
        trials.push(trial);
        progress.step(trials.len() as u64, &format!("({failed} failed)"));
    }
    progress.finish();
    trials.sort_by_key(|t| t.no);
    let arrived = trials.len() - failed;
    let rides_ok = trials
        .iter()
        .filter(|t| {
            t.report
                .as_ref()
                .ok()
                .and_then(|r| r.ride())
                .is_some_and(|h| h.failure.is_none())
        })
        .count();
    let contacts: u32 = trials
        .iter()
        .filter_map(|t| t.report.as_ref().ok())
        .map(|r| r.contacts)
        .sum();
    let header =
        "run,from,to,seed,elevator,arrived,floor,miss_cm,ride,contacts,sim_s,wall_s,failure";
    let csv: Vec<String> = std::iter::once(header.to_string())
        .chain(trials.iter().map(Trial::csv))
        .collect();
    let mut md = vec![
        format!("# Runs between the floors of '{}'", x.building.name),
        String::new(),
        format!(
            "{arrived} of {} arrived within {:.1} m of the goal on its floor (ground truth); {rides_ok} ride(s) judged good; {contacts} contact(s).",
            trials.len(),
            ARRIVED_MM / 1_000.0
        ),
        String::new(),
        "| run | route | elevator | arrived | floor | to goal | ride | contacts | simulated |".into(),
        "|---|---|---|---|---|---|---|---|---|".into(),
    ];
    for t in &trials {
        let cells = t.cells();
        md.push(format!(
            "| {} | {} → {} | {} | {} | {} | {} cm | {} | {} | {} s |",
            t.no,
            t.route.from,
            t.route.to,
            cells[4],
            cells[5],
            cells[6],
            cells[7],
            cells[8],
            cells[9],
            cells[10]
        ));
    }
    let md = md.join("\n");
    println!("{md}");
    let md_path = x.out.join("runs.md");
    let csv_path = x.out.join("runs.csv");
    std::fs::write(&md_path, format!("{md}\n"))
        .with_context(|| format!("cannot write {}", md_path.display()))?;
    std::fs::write(&csv_path, csv.join("\n") + "\n")
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    eprintln!("tables: {} and {}", md_path.display(), csv_path.display());
    Ok(if failed == 0 {
        crate::exit::OK
    } else {
        crate::exit::ERROR
    })
}
