//! `rome experiment`: Chapter 6's runs rerun in simulation, several at a
//! time, and tabulated in the layout of Tables 6.1 and 6.2 beside the
//! thesis' rows.
//!
//! ```text
//! rome experiment                          # the 40 runs of Tables 6.1 and 6.2 on EB3
//! rome experiment --plates                 # Table 6.3's routes: door plates
//! rome experiment --people 10              # ten people walking the corridors
//! rome experiment --cruise 400             # at the Navigator's default speed (700 here)
//! rome experiment --routes my.routes       # one FROM TO a line
//! rome experiment --repeats 3 --seed 100   # each route three times, seeds 100, 101, …
//! rome experiment --out results/           # where runs.md and runs.csv go
//! rome experiment --building tower         # runs between floors, riding elevators
//! ```
//!
//! Every run is lock-step with its own seed, so the tables are the same
//! however many run at once and however loaded the machine is.

use crate::progress::Progress;
use anyhow::Context;
use rome_harness::experiment::{self, Outcome, Setup};
use rome_sim::Noise;
use std::path::PathBuf;

/// The experiment's cruising speed, mm/s: at the Navigator's default of 400
/// the 40 runs average 22.5 m/min, at 700 they average 36 and all still
/// end within 0.5 m (docs/experiments.md).
const EXPERIMENT_CRUISE_MM_S: f64 = 700.0;

/// Flags of `rome experiment`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Routes to run, one `FROM TO [SPEED]` a line (default: on eb3 the 40
    /// runs of Tables 6.1 and 6.2, each beside the thesis' row; on annex and
    /// campus their built-in routes).
    #[arg(long, value_name = "FILE")]
    routes: Option<PathBuf>,
    /// Map: a built-in name (eb3, annex, campus, fig5_3) or a .stk file.
    #[arg(long, default_value = "eb3")]
    map: String,
    /// Runs between the floors of a building instead (§5.4.6): the
    /// built-in `tower` (its routes: maps/data/tower.routes) or a .bldg
    /// file with --routes of `FLOOR:POSITION` pairs; each run is judged by
    /// ground truth, floor included.
    #[arg(long, value_name = "BUILDING", conflicts_with_all = ["map", "plates", "people"])]
    building: Option<String>,
    /// Seed of the first run; run k has seed SEED + k.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// How many times each route is run.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeats: u32,
    /// Runs at a time (default: the machine's cores).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=64))]
    jobs: Option<u32>,
    /// Run the routes of Table 6.3 (door plates) on EB3 instead of Tables
    /// 6.1 and 6.2.
    #[arg(long, conflicts_with = "routes")]
    plates: bool,
    /// Cruising speed, mm/s, for routes that give none. 700 makes the 30
    /// m/min aimed at on Tables 6.1 and 6.2; the Navigator's own default,
    /// as in rome demo, is 400.
    #[arg(long, value_name = "MM_S", default_value_t = EXPERIMENT_CRUISE_MM_S)]
    cruise: f64,
    /// People walking to and fro in the corridors of every run (placed
    /// with the run's seed), as the thesis' robot met them.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=200))]
    people: u32,
    /// No sensor noise or wheel slip.
    #[arg(long)]
    no_noise: bool,
    /// Give a run up after this many simulated minutes.
    #[arg(long, default_value_t = 60.0)]
    limit_min: f64,
    /// Give a run up as hung after this many minutes of wall time.
    #[arg(long, default_value_t = 10.0)]
    wall_limit_min: f64,
    /// Directory for runs.md and runs.csv.
    #[arg(long, short = 'o', default_value = "experiment")]
    out: PathBuf,
}

/// `rome experiment --building`: the routes between floors.
async fn building(name: &str, args: &Args) -> anyhow::Result<u8> {
    let building = rome_maps::load_building_named(name)
        .with_context(|| format!("cannot load the building '{name}'"))?;
    let routes = match &args.routes {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read the routes file {}", path.display()))?;
            rome_harness::parse_routes(&path.display().to_string(), &text)?
        }
        None => match rome_maps::builtin::routes(name) {
            Some(text) => rome_harness::parse_routes(&format!("{name} routes (built in)"), text)?,
            None => anyhow::bail!("the building '{name}' has no routes built in; give --routes"),
        },
    };
    let mut cfg = rome_harness::RunConfig::fleet(building.floors[0].map.clone(), Vec::new());
    if args.no_noise {
        cfg.noise = Noise::none();
    }
    cfg.limit = rome_common::minutes("--limit-min", args.limit_min)?;
    cfg.nav.cruise_mm_s = args.cruise;
    super::floors::experiment(super::floors::FloorsExperiment {
        building,
        routes,
        repeats: args.repeats as usize,
        seed: args.seed,
        jobs: args.jobs.map_or_else(
            || std::thread::available_parallelism().map_or(1, |n| n.get()),
            |j| j as usize,
        ),
        cfg,
        out: args.out.clone(),
    })
    .await
}

/// Runs the experiment; exit status 1 when a run did not arrive.
pub async fn run(args: Args) -> anyhow::Result<u8> {
    let limit = rome_common::minutes("--limit-min", args.limit_min)?;
    let wall_limit = rome_common::minutes("--wall-limit-min", args.wall_limit_min)?;
    rome_common::check_cruise(args.cruise)?;
    if let Some(b) = &args.building {
        return building(b, &args).await;
    }
    let map = rome_maps::load_named(&args.map)?;
    let routes = match &args.routes {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read the routes file {}", path.display()))?;
            Some(rome_harness::parse_routes(&path.display().to_string(), &text)?)
        }
        None if args.map == "eb3" && args.plates => Some(
            rome_harness::plates::TABLE_6_3
                .iter()
                .map(|(from, to)| rome_harness::RouteSpec::new("r1", from, to))
                .collect(),
        ),
        None if args.plates => anyhow::bail!("--plates runs Table 6.3's routes, which are on eb3"),
        None if args.map == "eb3" => None,
        None => match rome_maps::builtin::routes(&args.map) {
            Some(text) => Some(rome_harness::parse_routes(
                &format!("{} routes (built in)", args.map),
                text,
            )?),
            None => anyhow::bail!(
                "the default runs are Tables 6.1 and 6.2 on EB3 and the routes built in for annex and campus; give --routes for the map '{}'",
                args.map
            ),
        },
    };
    let trials = experiment::trials(routes, args.repeats as usize, args.seed);
    let jobs = args.jobs.map_or_else(
        || std::thread::available_parallelism().map_or(1, |n| n.get()),
        |j| j as usize,
    );
    let setup = Setup {
        map,
        noise: if args.no_noise {
            Noise::none()
        } else {
            Noise::default()
        },
        jobs,
        limit,
        cruise_mm_s: Some(args.cruise),
        people: args.people as usize,
        wall_limit,
        nav: rome_nav::navigator::NavConfig::default(),
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot make the directory {}", args.out.display()))?;
    let total = trials.len();
    eprintln!(
        "{total} run(s) on '{}', {jobs} at a time, seeds {}…{}, cruising at {} mm/s where a route gives no speed",
        setup.map.name,
        args.seed,
        args.seed.wrapping_add(total as u64 - 1),
        args.cruise
    );
    let mut progress = Progress::bar("experiment", "runs", total as u64);
    let mut done = 0u64;
    let mut failed = 0usize;
    let outcomes = experiment::run_all(&setup, trials, |o: &Outcome| {
        done += 1;
        let line = match &o.report {
            Ok(r) if r.arrived() => format!(
                "{:>3} {}: {:.3} m, {:+.0} cm, {}",
                o.trial.no,
                o.trial.path(),
                r.driven_m,
                r.to_goal_cm,
                experiment::mode_cell(r, rome_nav::board::GoalType::L)
            ),
            _ => {
                failed += 1;
                format!(
                    "{:>3} {}: FAILED: {}",
                    o.trial.no,
                    o.trial.path(),
                    experiment::reason(o)
                )
            }
        };
        progress.println(&line);
        progress.step(done, &format!("({failed} failed)"));
    })
    .await;
    progress.finish();
    let md = experiment::markdown(&outcomes);
    let csv = experiment::csv(&outcomes);
    let reports: Vec<&rome_nav::report::Report> = outcomes
        .iter()
        .filter_map(|o| o.report.as_ref().ok())
        .collect();
    let world = rome_maps::World::from_map(&setup.map);
    let plate_rows: Vec<(String, rome_harness::plates::PlateRun)> = outcomes
        .iter()
        .filter_map(|o| {
            let r = o.report.as_ref().ok()?;
            let name = format!("{}: {}", o.trial.no, o.trial.path());
            Some((name, rome_harness::plates::judge(r, &world)))
        })
        .collect();
    let summary = format!(
        "{}\n\n## Confidence (§6.3)\n\n{}\n## Door plates (§6.2, Tables 6.3 and 6.6)\n\n{}",
        experiment::summary(&outcomes),
        rome_harness::confidence::markdown(&reports),
        rome_harness::plates::markdown(&plate_rows)
    );
    println!("{md}\n{summary}");
    let md_path = args.out.join("runs.md");
    let csv_path = args.out.join("runs.csv");
    std::fs::write(&md_path, format!("{md}\n{summary}\n"))
        .with_context(|| format!("cannot write {}", md_path.display()))?;
    std::fs::write(&csv_path, csv)
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    let pictures = experiment::pictures(&outcomes, &setup.map, &world, &args.out)
        .with_context(|| format!("cannot write the pictures into {}", args.out.display()))?;
    eprintln!(
        "tables: {} and {}; {} picture(s) in {} (all.png: every run; to-goal.svg, speed.svg)",
        md_path.display(),
        csv_path.display(),
        pictures.len(),
        args.out.display()
    );
    let all_arrived = outcomes
        .iter()
        .all(|o| o.report.as_ref().is_ok_and(|r| r.arrived()));
    Ok(if all_arrived { 0 } else { 1 })
}
