//! A fleet measured at scale (`rome fleet`): the same tasks given to
//! fleets of several sizes through the dispatcher, in lock-step, each
//! judged by ground truth; a table, a CSV and a picture of throughput and
//! fleet efficiency against the fleet's size.
//!
//! Throughput is tasks done per simulated hour, from the start to the
//! end of the last task. Fleet efficiency at N robots is throughput(N) /
//! (N × throughput(1)): 1 when N robots do N times the work of one, less
//! as they get in each other's way or wait for work.

use crate::experiment::csv_field;
use crate::routes::{pick_doors, pick_routes};
use crate::tasks::{run_tasks, ContactAt, StillAt, TaskEvent, TaskRun};
use crate::RunConfig;
use rome_maps::Map;
use rome_nav::fleet::schema::{TaskSpec, TaskState, TaskStatus};
use rome_nav::traffic::Rules;
use rome_nav::NavError;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::time::Duration;

/// What to measure.
#[derive(Debug, Clone)]
pub struct ScaleConfig {
    /// The map.
    pub map: Map,
    /// Fleet sizes, each run with the same tasks.
    pub sizes: Vec<usize>,
    /// How many tasks each run is given.
    pub tasks: usize,
    /// Seed of the robots' starts, the tasks and the world.
    pub seed: u64,
    /// The rules the robots drive by.
    pub rules: Rules,
    /// Drive no faster than lets a robot stop for what is ahead
    /// (`NavConfig::brake_for_ahead`).
    pub brake_ahead: bool,
    /// Hear the glass the map has, which the sensors do not
    /// (`NavConfig::hear_glass`).
    pub hear_glass: bool,
    /// Remember the near echoes ahead that a sonar loses
    /// (`NavConfig::remember_echoes`).
    pub remember_echoes: bool,
    /// Turn away from what a forward infrared detector sees and the three
    /// sonars ahead do not hear (`NavConfig::infrared_ahead`).
    pub infrared_ahead: bool,
    /// Turn back towards the middle before leaving where the walls were
    /// (`NavConfig::keep_within_walls`).
    pub keep_within_walls: bool,
    /// With `keep_within_walls`, take up where the robot is from one wall
    /// in view once the walls carried on are let go
    /// (`NavConfig::walls_from_one_side`).
    pub walls_from_one_side: bool,
    /// In the Corner state, go on past what only a 45° detector sees
    /// when the way ahead is clear (`NavConfig::corner_creeps`).
    pub corner_creeps: bool,
    /// Add the tasks one this much simulated time after another, as a
    /// stream of errands, instead of all at the start.
    pub every: Option<Duration>,
    /// Give a run up after this much simulated time.
    pub limit: Duration,
    /// A robot standing still this long with a task counts as stuck.
    pub stuck: Duration,
    /// A directory for each run's ground truth at every instant,
    /// `<robots>.trace` (`rome_sim_hardware::trace`): where each robot was
    /// in the seconds before a contact.
    pub traces: Option<std::path::PathBuf>,
}

/// One fleet size's run.
#[derive(Debug, Clone, PartialEq)]
pub struct ScaleRow {
    /// Robots.
    pub robots: usize,
    /// Tasks given.
    pub tasks: usize,
    /// Tasks done (arrived, by ground truth).
    pub done: usize,
    /// Tasks failed.
    pub failed: usize,
    /// Mean wait for a robot, s.
    pub wait_mean_s: f64,
    /// Longest wait for a robot, s.
    pub wait_max_s: f64,
    /// Mean time a task's robot waited its turn for junctions and passages
    /// on the way, s.
    pub traffic_wait_mean_s: f64,
    /// The longest such wait of one task, s.
    pub traffic_wait_max_s: f64,
    /// Simulated time to the end of the last task, h.
    pub sim_h: f64,
    /// Tasks done per simulated hour.
    pub throughput_h: f64,
    /// throughput(N) / (N × throughput(1)), once the one-robot run is in.
    pub efficiency: Option<f64>,
    /// Touches of walls, by ground truth.
    pub wall_contacts: u32,
    /// Touches of robots, by ground truth.
    pub robot_contacts: u32,
    /// Robots that stood still longer than the stuck limit with a task.
    pub stuck: usize,
    /// Wall time of the run, s.
    pub wall_s: f64,
    /// Requests to the data server in the run.
    pub data_requests: u64,
    /// Of them, per second of wall time.
    pub data_per_s: f64,
    /// Median and 99th-percentile reply time of the requests the server
    /// answers at once (not waits), ms of wall time.
    pub data_p50_ms: f64,
    /// See [`ScaleRow::data_p50_ms`].
    pub data_p99_ms: f64,
    /// Where each contact began.
    pub contact_places: Vec<ContactAt>,
    /// The robots counted in [`ScaleRow::stuck`], each where it stood
    /// longest, by name.
    pub stuck_places: Vec<(String, StillAt)>,
    /// Every task's status at the end.
    pub statuses: Vec<TaskStatus>,
    /// Each task's time spent waiting its turn on the way, s, by task id.
    pub traffic_wait_s: BTreeMap<String, f64>,
}

/// What a sweep tells whoever watches.
#[derive(Debug)]
pub enum ScaleEvent<'a> {
    /// A run of `robots` begins.
    Begin {
        /// Its fleet size.
        robots: usize,
    },
    /// Something happened in the run.
    Run(&'a TaskEvent),
    /// A run ended.
    End(&'a ScaleRow),
}

/// The tasks a sweep gives every fleet: `n` door jambs picked with `seed`.
pub fn pick_tasks(map: &Map, n: usize, seed: u64) -> Vec<(String, TaskSpec)> {
    pick_doors(map, n, seed ^ 0x7a5c)
        .into_iter()
        .enumerate()
        .map(|(k, to)| {
            let spec = TaskSpec {
                to,
                robot: None,
                priority: 0,
                via: vec![],
            };
            (format!("T{}", k + 1), spec)
        })
        .collect()
}

/// Runs every fleet size in turn and returns a row for each.
pub async fn sweep(
    cfg: &ScaleConfig,
    mut progress: impl FnMut(ScaleEvent<'_>),
) -> Result<Vec<ScaleRow>, NavError> {
    let tasks = pick_tasks(&cfg.map, cfg.tasks, cfg.seed);
    let mut rows: Vec<ScaleRow> = Vec::new();
    for &n in &cfg.sizes {
        progress(ScaleEvent::Begin { robots: n });
        let routes = pick_routes(&cfg.map, Vec::new(), n, cfg.seed)?;
        let mut run = RunConfig::fleet(cfg.map.clone(), routes);
        // Robots among robots keep right and step aside: their tracks
        // stray across the corridors they map.
        run.himm_cfg.track_side_mm = rome_nav::himm::FLEET_TRACK_SIDE_MM;
        // What a safety turn shies from may be a robot standing in a
        // junction: stop at once rather than brake on into it.
        run.nav.stop_short_to_turn = true;
        // And one may stand idle beside a robot turning in a corner.
        run.nav.corner_bears_off = true;
        // And keeping right into a junction, where the walls fall away.
        run.nav.coast_on_odometry = true;
        run.nav.brake_for_ahead = cfg.brake_ahead;
        // Glass across a corridor's end is heard by none of its sensors.
        run.nav.hear_glass = cfg.hear_glass;
        run.nav.remember_echoes = cfg.remember_echoes;
        run.nav.infrared_ahead = cfg.infrared_ahead;
        run.nav.keep_within_walls = cfg.keep_within_walls;
        run.nav.walls_from_one_side = cfg.walls_from_one_side;
        run.nav.corner_creeps = cfg.corner_creeps;
        run.seed = cfg.seed;
        run.limit = cfg.limit;
        run.rules = cfg.rules;
        run.trace = cfg.traces.as_ref().map(|d| d.join(format!("{n}.trace")));
        // The plate finder reads camera images that no task needs.
        run.plfinder = false;
        let load = rome_client::load::DATA.snapshot();
        let r = run_tasks(
            TaskRun {
                run,
                tasks: tasks.clone(),
                every: cfg.every,
                kill: None,
                closed: None,
                stay: Vec::new(),
            },
            &mut |e| progress(ScaleEvent::Run(&e)),
        )
        .await?;
        let done: Vec<_> = r
            .statuses
            .iter()
            .filter(|s| s.state == TaskState::Done)
            .collect();
        let waits: Vec<f64> = r.statuses.iter().filter_map(wait_s).collect();
        let t0 = r.statuses.iter().map(|s| s.added_ms).min().unwrap_or(0);
        let last = done.iter().filter_map(|s| s.ended_ms).max().unwrap_or(t0);
        let sim_h = (last.saturating_sub(t0)) as f64 / 3.6e6;
        let throughput_h = if sim_h > 0.0 {
            done.len() as f64 / sim_h
        } else {
            0.0
        };
        let traffic: Vec<f64> = (r.statuses.iter())
            .map(|s| traffic_s(&r.traffic_wait_s, s))
            .collect();
        let one = rows.iter().find(|r| r.robots == 1).map(|r| r.throughput_h);
        let load = rome_client::load::DATA.snapshot().since(&load);
        let ms = |q: f64| load.quantile(q).map_or(0.0, |d| d.as_secs_f64() * 1e3);
        let stuck_places: Vec<(String, StillAt)> = (r.longest_still_at.into_iter())
            .filter(|(_, at)| at.still_s > cfg.stuck.as_secs_f64())
            .collect();
        let row = ScaleRow {
            robots: n,
            tasks: cfg.tasks,
            done: done.len(),
            failed: r
                .statuses
                .iter()
                .filter(|s| s.state == TaskState::Failed)
                .count(),
            wait_mean_s: waits.iter().sum::<f64>() / waits.len().max(1) as f64,
            wait_max_s: waits.iter().copied().fold(0.0, f64::max),
            traffic_wait_mean_s: traffic.iter().sum::<f64>() / traffic.len().max(1) as f64,
            traffic_wait_max_s: traffic.iter().copied().fold(0.0, f64::max),
            sim_h,
            throughput_h,
            efficiency: one
                .filter(|t| *t > 0.0)
                .map(|t| throughput_h / (n as f64 * t)),
            wall_contacts: r.contacts.values().map(|c| c.wall).sum(),
            robot_contacts: r.contacts.values().map(|c| c.robot).sum(),
            stuck: stuck_places.len(),
            wall_s: r.wall.as_secs_f64(),
            data_requests: load.requests,
            data_per_s: load.requests as f64 / r.wall.as_secs_f64().max(1e-3),
            data_p50_ms: ms(0.5),
            data_p99_ms: ms(0.99),
            contact_places: r.contact_places,
            stuck_places,
            statuses: r.statuses,
            traffic_wait_s: r.traffic_wait_s,
        };
        progress(ScaleEvent::End(&row));
        rows.push(row);
    }
    Ok(rows)
}

/// The table's header.
pub const HEADER: &str =
    "robots,tasks,done,failed,wait_mean_s,wait_max_s,traffic_wait_mean_s,traffic_wait_max_s,sim_h,throughput_per_h,efficiency,wall_contacts,robot_contacts,stuck,wall_s,data_requests,data_per_s,data_p50_ms,data_p99_ms";

/// A row as a line of the CSV.
pub fn csv_line(r: &ScaleRow) -> String {
    format!(
        "{},{},{},{},{:.1},{:.1},{:.1},{:.1},{:.3},{:.1},{},{},{},{},{:.1},{},{:.0},{:.2},{:.2}",
        r.robots,
        r.tasks,
        r.done,
        r.failed,
        r.wait_mean_s,
        r.wait_max_s,
        r.traffic_wait_mean_s,
        r.traffic_wait_max_s,
        r.sim_h,
        r.throughput_h,
        r.efficiency.map_or(String::new(), |e| format!("{e:.2}")),
        r.wall_contacts,
        r.robot_contacts,
        r.stuck,
        r.wall_s,
        r.data_requests,
        r.data_per_s,
        r.data_p50_ms,
        r.data_p99_ms
    )
}

/// Throughput (left axis) and efficiency (right axis) against the
/// fleet's size, as an SVG picture.
pub fn svg(rows: &[ScaleRow], title: &str) -> String {
    let points: Vec<_> = rows
        .iter()
        .map(|r| (r.robots, r.throughput_h, r.efficiency))
        .collect();
    plot(&points, title)
}

/// [`svg`] of (robots, tasks per hour, efficiency) points. The efficiency
/// axis runs from 0 to 1, or higher when a fleet did more than its size
/// times one robot's tasks (robots that share a route's slow parts can),
/// so that every point stays inside the plot.
fn plot(rows: &[(usize, f64, Option<f64>)], title: &str) -> String {
    let (w, h, pad) = (640.0, 400.0, 60.0);
    let max_n = rows.iter().map(|r| r.0).max().unwrap_or(1).max(1) as f64;
    let max_t = rows.iter().map(|r| r.1).fold(1.0, f64::max) * 1.1;
    let max_e = rows.iter().filter_map(|r| r.2).fold(1.0, f64::max);
    let max_e = if max_e > 1.0 {
        (max_e * 11.0).ceil() / 10.0
    } else {
        1.0
    };
    let x = |n: f64| pad + (w - 2.0 * pad) * n / max_n;
    let y = |f: f64| h - pad - (h - 2.0 * pad) * f;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="24" text-anchor="middle" font-size="15">{title}</text>"#,
        w / 2.0
    );
    let _ = writeln!(
        s,
        r#"<path d="M{pad},{pad} V{} H{}" stroke="black" fill="none"/>"#,
        h - pad,
        w - pad
    );
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">robots</text>"#,
        w / 2.0,
        h - 20.0
    );
    let _ = writeln!(
        s,
        r##"<text x="14" y="{}" fill="#1f77b4" transform="rotate(-90 14 {})" text-anchor="middle">tasks per simulated hour (max {max_t:.0})</text>"##,
        h / 2.0,
        h / 2.0
    );
    let _ = writeln!(
        s,
        r##"<text x="{}" y="{}" fill="#d62728" transform="rotate(90 {} {})" text-anchor="middle">efficiency (0 to {max_e})</text>"##,
        w - 14.0,
        h / 2.0,
        w - 14.0,
        h / 2.0
    );
    let series = [
        (
            "#1f77b4",
            rows.iter()
                .map(|r| (r.0, Some(r.1 / max_t)))
                .collect::<Vec<_>>(),
        ),
        (
            "#d62728",
            rows.iter().map(|r| (r.0, r.2.map(|e| e / max_e))).collect(),
        ),
    ];
    for (color, points) in series {
        let pts: Vec<String> = points
            .iter()
            .filter_map(|(n, f)| f.map(|f| format!("{:.1},{:.1}", x(*n as f64), y(f))))
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" stroke="{color}" stroke-width="2" fill="none"/>"#,
            pts.join(" ")
        );
        for p in &pts {
            let (px, py) = p.split_once(',').unwrap_or(("0", "0"));
            let _ = writeln!(s, r#"<circle cx="{px}" cy="{py}" r="4" fill="{color}"/>"#);
        }
    }
    for r in rows {
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{}" text-anchor="middle">{}</text>"#,
            x(r.0 as f64),
            h - pad + 16.0,
            r.0
        );
    }
    s.push_str("</svg>\n");
    s
}

/// The header of stuck.csv.
pub const STUCK_HEADER: &str = "robots,robot,since_s,still_s,x_m,y_m,task";

/// Each robot counted as stuck in a run, where it stood longest, as lines
/// of stuck.csv.
pub fn stuck_lines(row: &ScaleRow) -> String {
    let mut out = String::new();
    for (robot, at) in &row.stuck_places {
        let _ = writeln!(
            out,
            "{},{},{:.0},{:.0},{:.2},{:.2},{}",
            row.robots,
            robot,
            at.since_s,
            at.still_s,
            at.x_mm / 1000.0,
            at.y_mm / 1000.0,
            at.task.as_deref().unwrap_or("")
        );
    }
    out
}

/// The header of contacts.csv.
pub const CONTACTS_HEADER: &str = "robots,t_s,robot,x_m,y_m,with,task";

/// Each contact of a run as lines of contacts.csv.
pub fn contact_lines(row: &ScaleRow) -> String {
    let mut out = String::new();
    for c in &row.contact_places {
        let _ = writeln!(
            out,
            "{},{:.0},{},{:.2},{:.2},{},{}",
            row.robots,
            c.t_s,
            c.robot,
            c.x_mm / 1000.0,
            c.y_mm / 1000.0,
            if c.with_robot { "robot" } else { "wall" },
            c.task.as_deref().unwrap_or("")
        );
    }
    out
}

/// A task's wait for a robot, s: from its adding to its last handing out
/// (so a task handed out again counts its first robot's drive); `None`
/// while it was never handed out.
fn wait_s(s: &TaskStatus) -> Option<f64> {
    (s.assigned_ms).map(|a| a.saturating_sub(s.added_ms) as f64 / 1000.0)
}

/// A task's time waiting its turn on the way, s.
fn traffic_s(traffic_wait_s: &BTreeMap<String, f64>, s: &TaskStatus) -> f64 {
    traffic_wait_s.get(&s.id).copied().unwrap_or(0.0)
}

/// The header of tasks.csv.
pub const TASKS_HEADER: &str =
    "robots,task,to,state,added_s,handed_s,ended_s,wait_s,traffic_wait_s,robot,tried,why";

/// Every task of a run as lines of tasks.csv: when it was added, last
/// handed to a robot and ended (simulated s from the first task's
/// adding), its wait for a robot as the table counts it (`wait_s`),
/// the robots it was handed to and why it was taken from them.
pub fn task_lines(row: &ScaleRow) -> String {
    let t0 = row.statuses.iter().map(|s| s.added_ms).min().unwrap_or(0);
    let s_of = |ms: Option<u64>| {
        ms.map_or(String::new(), |ms| {
            format!("{:.1}", ms.saturating_sub(t0) as f64 / 1000.0)
        })
    };
    let mut statuses: Vec<&TaskStatus> = row.statuses.iter().collect();
    statuses.sort_by_key(|s| (s.added_ms, s.seq));
    let mut out = String::new();
    for s in statuses {
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{:.1},{},{},{}",
            row.robots,
            csv_field(&s.id),
            csv_field(&s.to),
            csv_field(&format!("{:?}", s.state).to_lowercase()),
            s_of(Some(s.added_ms)),
            s_of(s.assigned_ms),
            s_of(s.ended_ms),
            wait_s(s).map_or(String::new(), |w| format!("{w:.1}")),
            traffic_s(&row.traffic_wait_s, s),
            csv_field(s.robot.as_deref().unwrap_or("")),
            csv_field(&s.tried.join(" ")),
            csv_field(&s.why.join("; ")),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::plot;

    /// The plotted points' y, in the order drawn.
    fn ys(svg: &str) -> Vec<f64> {
        svg.lines()
            .filter_map(|l| l.split_once(r#"cy=""#))
            .filter_map(|(_, rest)| rest.split('"').next()?.parse().ok())
            .collect()
    }

    #[test]
    fn an_efficiency_above_one_stays_inside_the_plot() {
        // Inside: from y = 60 (top) to 340 (the robots' axis).
        let svg = plot(
            &[
                (1, 10.0, None),
                (20, 230.0, Some(1.15)),
                (40, 238.0, Some(0.59)),
            ],
            "fleet",
        );
        assert!(svg.contains("efficiency (0 to 1.3)"), "{svg}");
        let y = ys(&svg);
        assert_eq!(y.len(), 5, "{svg}");
        assert!(y.iter().all(|y| (60.0..=340.0).contains(y)), "{y:?}");
        // 1.15 of 1.3 is above 0.59 of 1.3, both where their share puts them.
        assert!((y[3] - (340.0 - 280.0 * 1.15 / 1.3)).abs() < 0.1, "{y:?}");
        assert!((y[4] - (340.0 - 280.0 * 0.59 / 1.3)).abs() < 0.1, "{y:?}");
        let within = plot(&[(1, 10.0, None), (5, 40.0, Some(0.8))], "fleet");
        assert!(within.contains("efficiency (0 to 1)"), "{within}");
        assert!((ys(&within)[2] - (340.0 - 280.0 * 0.8)).abs() < 0.1);
    }
}
