//! `rome fleet`: fleets of several sizes given the same tasks through the
//! dispatcher, in lock-step, measured by ground truth.
//!
//! ```text
//! rome fleet                                   # 1, 5 and 10 robots, 50 tasks on EB3
//! rome fleet --robots 1,5,10,20,40 --tasks 200 # the sweep of docs/tasks.md
//! rome fleet --map annex --seed 7 --out runs/  # where fleet.csv and fleet.svg go
//! rome fleet --robots 10 --trace               # and fleet/10.trace: every instant's ground truth
//! rome fleet --robots 40 --tasks 200 --every 15 # a task every 15 s instead of all at once
//! ```

use crate::progress::Progress;
use anyhow::Context;
use rome_harness::scale::{self, ScaleConfig, ScaleEvent};
use rome_harness::tasks::{Said, TaskEvent};
use std::path::PathBuf;
use std::time::Duration;

/// Flags of `rome fleet`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Fleet sizes, comma-separated; a one-robot run is added first when
    /// missing, as efficiency is measured against it (see --no-baseline).
    #[arg(long, value_delimiter = ',', default_values_t = vec![1usize, 5, 10])]
    robots: Vec<usize>,
    /// Tasks given to every fleet (door jambs picked with the seed).
    #[arg(long, default_value_t = 50)]
    tasks: usize,
    /// Map: a built-in name (eb3, annex, campus, fig5_3) or a .stk file.
    #[arg(long, default_value = "eb3")]
    map: String,
    /// Seed of the robots' starts, the tasks and the world.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    rules: super::traffic::TrafficArgs,
    /// Add the tasks as a stream, one every SECS of simulated time,
    /// instead of all at the start: the wait for a robot is then the
    /// dispatcher's and the fleet's, not a backlog's, and throughput is
    /// at most the rate they come at.
    #[arg(long, value_name = "SECS")]
    every: Option<f64>,
    /// Give a run up after this many simulated minutes.
    #[arg(long, default_value_t = 1440.0)]
    limit_min: f64,
    /// Directory for fleet.csv, fleet.svg, tasks.csv (each task's times,
    /// robots and reasons), contacts.csv (where and when each contact
    /// began) and stuck.csv (where each robot counted as stuck stood
    /// longest).
    #[arg(long, short = 'o', default_value = "fleet")]
    out: PathBuf,
    /// Also write each run's ground truth at every instant to OUT/N.trace
    /// for a fleet of N: a line per robot per instant with its true pose,
    /// distance driven and sonar ranges (what led up to a contact).
    #[arg(long)]
    trace: bool,
    /// Run only the sizes given, without the one-robot run that
    /// efficiency is measured against (its column is then empty).
    #[arg(long)]
    no_baseline: bool,
    /// Drive no faster than lets a robot stop, halfway, for the nearest
    /// thing within 15° of ahead, as if it came as fast: fewer robots
    /// touching in a backlog, but it changes every run's course
    /// (docs/traffic.md, "Driving no faster than it can stop").
    #[arg(long)]
    brake_ahead: bool,
    /// Go by the sensors alone, as the thesis' Navigator: the glass the
    /// map has (EB3's door across corridor A's east end) is then not
    /// heard, and robots driven to its side of a turning space touch it
    /// (docs/traffic.md, "The glass the sonars do not hear").
    #[arg(long)]
    deaf_to_glass: bool,
    /// Remember, for a metre driven, a near echo ahead that a sonar
    /// loses: the corner of a corridor's mouth slides between two beams as
    /// a robot closes on it at a slant. Among forty robots on the Campus
    /// it took two corner touches of three away, but in EB3's backlogs
    /// robots block each other more, so it is off by default
    /// (docs/traffic.md, "The corner between two beams").
    #[arg(long)]
    remember_echoes: bool,
    /// Outside the Corner state, turn away from what a forward infrared
    /// detector (15° either side of ahead) sees and the three sonars ahead
    /// do not hear: the corner of a corridor's mouth between two beams. In
    /// EB3's backlogs it took every contact away; on the Campus walls were
    /// touched half as often and robots more often, so it is off by default
    /// (docs/traffic.md, "The forward infrared outside the Corner state").
    #[arg(long)]
    infrared_ahead: bool,
    /// Where a side of the corridor has opened (a junction, a door's
    /// recess), carry where its walls were on by odometry and turn back
    /// towards the middle before the robot's side would cross the line of
    /// a wall: robots that swerved round one standing in a crossroads
    /// touched the corner of the corridor beyond. Alone, robots touched
    /// each other more often; with --infrared-ahead, twenty Campus and EB3
    /// runs had fewer contacts than with either (24 against 34 on main),
    /// but not none, so it is off by default (docs/traffic.md, "Back
    /// within the walls after a crossroads")
    #[arg(long)]
    keep_within_walls: bool,
    /// With --keep-within-walls: once a turn of more than 45° (or 3 m
    /// driven) has let the walls carried on go, take up where the robot
    /// is from the one wall in view, by the last fit's axis and width, for
    /// up to 6 m. A robot that swung round one met in a corridor's mouth
    /// came back along the line of the mouth's wall and touched its far
    /// corner. On the Campus, eight runs with all three of --brake-ahead,
    /// --infrared-ahead and --keep-within-walls had fewer contacts with it;
    /// EB3's backlogs had more, so it is off by default (docs/traffic.md,
    /// "Where the walls were, from one wall").
    #[arg(long, requires = "keep_within_walls")]
    walls_from_one_side: bool,
    /// In the Corner state, turned to within 20° of the goal direction
    /// with only a 45° infrared detector lit and the strip ahead clear,
    /// go on bearing away from what it sees instead of spinning on past
    /// the goal direction. A robot turned into a corridor with its wall
    /// 0.25 m off its side spun in place for minutes and held three
    /// robots up. Over runs on a grid floor, in EB3 and on the Campus,
    /// more tasks were done and fewer robots stood a minute, but there
    /// were as many contacts, so it is off by default (docs/traffic.md,
    /// "Spinning in a corridor's mouth")
    #[arg(long)]
    corner_creeps: bool,
}

/// Runs the sweep; exit status 1 when a task was not done.
pub async fn run(args: Args) -> anyhow::Result<u8> {
    let limit = rome_common::minutes("--limit-min", args.limit_min)?;
    let every = (args.every)
        .map(|s| rome_common::seconds("--every", s))
        .transpose()?;
    anyhow::ensure!(args.tasks > 0, "--tasks must be at least 1");
    let mut sizes = args.robots.clone();
    anyhow::ensure!(
        sizes.iter().all(|n| (1..=200).contains(n)),
        "--robots takes fleet sizes from 1 to 200, got {sizes:?}"
    );
    sizes.sort_unstable();
    sizes.dedup();
    if sizes.first() != Some(&1) && !args.no_baseline {
        sizes.insert(0, 1);
    }
    let cfg = ScaleConfig {
        map: rome_maps::load_named(&args.map)?,
        sizes,
        tasks: args.tasks,
        seed: args.seed,
        rules: args.rules.to_rules(),
        brake_ahead: args.brake_ahead,
        hear_glass: !args.deaf_to_glass,
        remember_echoes: args.remember_echoes,
        infrared_ahead: args.infrared_ahead,
        keep_within_walls: args.keep_within_walls,
        walls_from_one_side: args.walls_from_one_side,
        corner_creeps: args.corner_creeps,
        every,
        limit,
        stuck: Duration::from_secs(60),
        traces: args.trace.then(|| args.out.clone()),
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot make {}", args.out.display()))?;
    let stream = match args.every {
        Some(s) => format!(", one every {s} s"),
        None => String::new(),
    };
    println!(
        "{} task(s){stream} on {} for fleets of {:?} robots, seed {}",
        cfg.tasks, args.map, cfg.sizes, cfg.seed
    );
    println!("{}", scale::HEADER);
    let mut bar: Option<Progress> = None;
    let mut done = 0u64;
    let rows = scale::sweep(&cfg, |e| match e {
        ScaleEvent::Begin { robots } => {
            done = 0;
            bar = Some(Progress::bar(
                &format!("{robots} robot(s)"),
                "tasks",
                cfg.tasks as u64,
            ));
        }
        ScaleEvent::Run(TaskEvent::Task(s, what)) if s.state.ended() => {
            done += 1;
            if let Some(b) = bar.as_mut() {
                b.set(done, &format!("{} {what}", s.id));
            }
        }
        ScaleEvent::Run(TaskEvent::Robot(
            robot,
            said @ (Said::NotArrived(..)
            | Said::Trouble(_)
            | Said::Rests(_)
            | Said::Back(_)
            | Said::Apart(_)),
        )) => {
            eprintln!("{robot}: {said}");
        }
        ScaleEvent::Run(_) => {}
        ScaleEvent::End(row) => {
            if let Some(mut b) = bar.take() {
                b.finish();
            }
            println!("{}", scale::csv_line(row));
        }
    })
    .await?;
    // Each file: its header, then every run's lines.
    let table = |header: &str, lines: &dyn Fn(&scale::ScaleRow) -> String| {
        let mut out = format!("{header}\n");
        for r in &rows {
            out.push_str(&lines(r));
        }
        out
    };
    let write = |name: &str, text: String| {
        let path = args.out.join(name);
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))?;
        anyhow::Ok(path)
    };
    write(
        "contacts.csv",
        table(scale::CONTACTS_HEADER, &scale::contact_lines),
    )?;
    write("stuck.csv", table(scale::STUCK_HEADER, &scale::stuck_lines))?;
    write("tasks.csv", table(scale::TASKS_HEADER, &scale::task_lines))?;
    let csv_path = write(
        "fleet.csv",
        table(scale::HEADER, &|r| format!("{}\n", scale::csv_line(r))),
    )?;
    let title = format!("{} tasks on {}, seed {}", cfg.tasks, args.map, cfg.seed);
    let svg_path = write("fleet.svg", scale::svg(&rows, &title))?;
    println!("wrote {} and {}", csv_path.display(), svg_path.display());
    Ok(if rows.iter().all(|r| r.done == r.tasks) {
        crate::exit::OK
    } else {
        crate::exit::ERROR
    })
}
