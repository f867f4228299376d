//! `rome demo`: a simulated robot driving from one room to another, with
//! the data server, the hardware servers and every navigation client in
//! one process on an in-process Zenoh session: no router, no configuration.
//!
//! It shows the plan, then progress while the robot drives, then the run as
//! a row of Table 6.1, and writes the trajectory on the map to a PNG.

use crate::exit;
use anyhow::Context;
use rome_nav::board::GoalType;
use rome_nav::run::{self, Event, RunConfig};
use rome_sim::Noise;
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::Duration;

/// Flags of `rome demo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Start: a door jamb like 350R, or RING.NODE.
    #[arg(long, default_value = "350R")]
    pub from: String,
    /// Goal.
    #[arg(long, default_value = "376L")]
    pub to: String,
    /// Map: a built-in name (eb3, fig5_3) or a .stk file.
    #[arg(long, default_value = "eb3")]
    pub map: String,
    /// Seed of the simulated world (the same seed, the same sensor noise).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Simulated time per real time.
    #[arg(long, default_value_t = 4.0)]
    pub speed: f64,
    /// No sensor noise or wheel slip.
    #[arg(long)]
    pub no_noise: bool,
    /// Where to write the trajectory picture.
    #[arg(long, short = 'o', default_value = "rome-demo.png")]
    pub output: PathBuf,
    /// Give up after this many simulated minutes.
    #[arg(long, default_value_t = 60.0)]
    pub limit_min: f64,
    /// Leave out the local mapper (no heading correction).
    #[arg(long)]
    pub no_himm: bool,
    /// Leave out the door-plate finder.
    #[arg(long)]
    pub no_plfinder: bool,
}

/// Runs the demo.
pub async fn run(args: Args) -> anyhow::Result<u8> {
    let map = rome_maps::load_named(&args.map)?;
    anyhow::ensure!(
        args.limit_min.is_finite() && args.limit_min > 0.0,
        "--limit-min must be a positive number of minutes, got {}",
        args.limit_min
    );
    let mut cfg = RunConfig::new(map.clone(), &args.from, &args.to);
    cfg.seed = args.seed;
    cfg.speed = args.speed;
    cfg.himm = !args.no_himm;
    cfg.plfinder = !args.no_plfinder;
    cfg.limit = Duration::from_secs_f64(args.limit_min * 60.0);
    if args.no_noise {
        cfg.noise = Noise::none();
    }
    let mut total_m = 0.0;
    let mut last_line = 0usize;
    let tty = std::io::stdout().is_terminal();
    let mut next_line_s = 0.0;
    let report = run::run(cfg, |event| match event {
        Event::Planned(plan) => {
            total_m = plan.route.length_mm / 1_000.0;
            println!(
                "plan {} -> {} on '{}': {:.3} m, {} corner(s), {} goal(s)",
                args.from,
                args.to,
                map.name,
                total_m,
                plan.route.turns,
                plan.steps.len()
            );
            for line in plan.describe() {
                println!("  {line}");
            }
        }
        Event::Goal(h) => {
            let g = &h.step.goal;
            let unit = if g.goal_type == GoalType::L {
                "light(s)"
            } else {
                "mm"
            };
            clear(&mut last_line);
            println!(
                "[goal {}] {:?} {} {unit} heading {:.0}°",
                h.index + 1,
                g.goal_type,
                g.distance,
                g.direction_deg
            );
        }
        Event::Tick {
            time_s,
            pose,
            travelled_mm,
        } => {
            let line = format!(
                "  {:>3}:{:02}  driven {:>7.2} m of {:.1}  at ({:.1}, {:.1}) m heading {:.0}°",
                (time_s as u64) / 60,
                (time_s as u64) % 60,
                travelled_mm / 1_000.0,
                total_m,
                pose.x / 1_000.0,
                pose.y / 1_000.0,
                pose.heading
            );
            if tty {
                clear(&mut last_line);
                print!("{line}");
                last_line = line.len();
                let _ = std::io::stdout().flush();
            } else if time_s >= next_line_s {
                // Into a file or a pipe: a line every ten simulated seconds.
                println!("{line}");
                next_line_s = time_s + 10.0;
            }
        }
    })
    .await
    .context("the run failed")?;
    clear(&mut last_line);
    println!();
    println!("{}", report.table());
    println!();
    let verdict = match &report.failure {
        None if report.arrived() => "arrived",
        None => "stopped, off the goal:",
        Some(why) => {
            eprintln!("error: the robot did not arrive: {why}");
            "gave up"
        }
    };
    println!(
        "{verdict} {:.0} cm from the goal ({:+.0} cm along the corridor, {:.0} cm across); {} simulated in {:.1?}",
        report.miss_cm,
        report.to_goal_cm,
        report.off_line_cm,
        fmt_time(report.run_time),
        report.wall_time
    );
    let seen: usize = report.lights.iter().map(|s| s.seen).sum();
    let missed: usize = report.lights.iter().map(|s| s.missed).sum();
    println!(
        "ceiling lights: {seen} seen, {missed} missed; heading corrections: {}; in-place turns: {}; door plates: {}",
        report.fixes.len(),
        report.nav.turns,
        report.plates.len()
    );
    let named: Vec<String> = report
        .plates
        .iter()
        .filter_map(|p| p.label.clone())
        .collect();
    if !named.is_empty() {
        println!("  plates read as: {}", named.join(" "));
    }
    let world = rome_maps::World::from_map(&map);
    let png = report.picture(&map, &world, 1600);
    std::fs::write(&args.output, png)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    println!("trajectory: {}", args.output.display());
    // A run that did not reach the goal is a failed run, for scripts too.
    if !report.arrived() {
        return Ok(exit::ERROR);
    }
    Ok(exit::OK)
}

fn fmt_time(d: Duration) -> String {
    format!("{}:{:02}", d.as_secs() / 60, d.as_secs() % 60)
}

/// Rubs out the progress line.
fn clear(last: &mut usize) {
    if *last > 0 {
        print!("\r{:width$}\r", "", width = *last);
        *last = 0;
    }
}
