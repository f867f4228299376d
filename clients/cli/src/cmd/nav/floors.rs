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
        let ride = fp.ride.as_ref().and_then(|s| s.ride.as_ref());
        println!(
            "{} plan {} -> {} in '{}': {} goal(s){}",
            r.robot,
            r.from,
            r.to,
            demo.building.name,
            fp.steps().len(),
            ride.map_or(String::new(), |x| format!(
                ", riding {} from floor {} to {}",
                x.elevator, x.from, x.to
            ))
        );
        for line in fp.describe() {
            println!("  {line}");
        }
    }
    let names: Vec<String> = demo.routes.iter().map(|r| r.robot.clone()).collect();
    let run = run_floors(cfg, demo.faults, |k, p| {
        let name = &names[k];
        match p {
            Progress::Handed(h) => {
                let g = &h.step.goal;
                let what = match (&h.step.ride, g.goal_type) {
                    (Some(x), GoalType::V) => {
                        format!("V ride {} from floor {} to {}", x.elevator, x.from, x.to)
                    }
                    (_, GoalType::L) => {
                        format!("L {} light(s) heading {:.0}°", g.distance, g.direction_deg)
                    }
                    _ => format!(
                        "{:?} {} mm heading {:.0}°",
                        g.goal_type, g.distance, g.direction_deg
                    ),
                };
                println!("[{name} goal {}] {what}", h.index + 1);
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
