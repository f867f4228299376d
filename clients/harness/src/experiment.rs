//! Chapter 6's experiments rerun in simulation (`rome experiment`): many
//! one-robot runs, several at a time, each in lock-step with its own seed,
//! tabulated in the layout of Tables 6.1 and 6.2 beside the thesis' own
//! rows.
//!
//! Every figure in the tables is judged from what happened: the distance
//! driven and the distance to the goal come from ground truth, and a mode
//! counts as done only when its segment was judged successful (a light
//! segment that saw its lights, a corner entered and left, a dead-reckoning
//! leg that ended where the plan said). A starred entry carries its reason.

use crate::{run, RouteSpec, RunConfig};
use rome_maps::Map;
use rome_nav::board::GoalType;
use rome_nav::navigator::NavConfig;
use rome_nav::report::{mmss, Report};
use rome_nav::NavError;
use rome_sim::Noise;
use std::sync::Arc;
use std::time::Duration;

/// One row of Table 6.1 or 6.2 as the thesis prints it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThesisRun {
    /// `"6.1"` or `"6.2"`.
    pub table: &'static str,
    /// The row's number in its table.
    pub no: u32,
    /// Start, as our EB3 map names it.
    pub from: &'static str,
    /// Goal, as our EB3 map names it.
    pub to: &'static str,
    /// "Actual Dist." in metres.
    pub dist_m: f64,
    /// "Dist. to Goal" in cm; `None` for a failed run.
    pub to_goal_cm: Option<f64>,
    /// "Run Time" as printed (`None` for a failed run).
    pub time: Option<&'static str>,
    /// The L, C and D columns as printed (`"0*/1"`).
    pub modes: [&'static str; 3],
}

#[allow(clippy::too_many_arguments)] // one row of a printed table, field by field
const fn t(
    table: &'static str,
    no: u32,
    from: &'static str,
    to: &'static str,
    dist_m: f64,
    to_goal_cm: Option<f64>,
    time: Option<&'static str>,
    modes: [&'static str; 3],
) -> ThesisRun {
    ThesisRun {
        table,
        no,
        from,
        to,
        dist_m,
        to_goal_cm,
        time,
        modes,
    }
}

/// The 40 runs of Tables 6.1 (old wing, 27 runs) and 6.2 (new wing, 13),
/// with the places named as the EB3 map names them (`303.second.R` for the
/// thesis' "303.second.R", `NW.men's.L` for "NW.men'sL").
#[rustfmt::skip]
pub const CHAPTER6: [ThesisRun; 40] = [
    t("6.1", 1, "350R", "376L", 78.181, Some(-13.0), Some("5:26"), ["1/1", "0/0", "1/1"]),
    t("6.1", 2, "350R", "376L", 78.181, Some(46.0), Some("5:57"), ["1/1", "0/0", "1/1"]),
    t("6.1", 3, "350R", "376L", 78.181, Some(-15.0), Some("6:19"), ["1/1", "0/0", "1/1"]),
    t("6.1", 4, "350R", "376L", 78.181, Some(20.0), Some("6:09"), ["1/1", "0/0", "1/1"]),
    t("6.1", 5, "350R", "376L", 78.181, Some(43.0), Some("5:43"), ["1/1", "0/0", "1/1"]),
    t("6.1", 6, "350R", "376L", 78.181, Some(61.0), Some("5:14"), ["1/1", "0/0", "1/1"]),
    t("6.1", 7, "350R", "376L", 78.181, Some(53.0), Some("5:45"), ["1/1", "0/0", "1/1"]),
    t("6.1", 8, "381L", "343R", 73.863, Some(81.0), Some("5:02"), ["1/1", "0/0", "1/1"]),
    t("6.1", 9, "381L", "343R", 73.863, Some(30.0), Some("5:01"), ["1/1", "0/0", "1/1"]),
    t("6.1", 10, "381L", "343R", 73.863, Some(66.0), Some("5:11"), ["1/1", "0/0", "1/1"]),
    t("6.1", 11, "381L", "343R", 73.863, Some(41.0), Some("5:34"), ["1/1", "0/0", "1/1"]),
    t("6.1", 12, "381L", "343R", 73.863, Some(25.0), Some("4:59"), ["1/1", "0/0", "1/1"]),
    t("6.1", 13, "381L", "343R", 73.863, None, None, ["0*/1", "0/0", "0/1"]),
    t("6.1", 14, "346L", "388R", 107.95, Some(-45.0), Some("6:46"), ["1/1", "0/0", "1/1"]),
    t("6.1", 15, "341L", "311R", 91.795, Some(60.0), Some("9:40"), ["3/3", "2/2", "1/1"]),
    t("6.1", 16, "303.second.R", "350R", 106.984, Some(100.0), Some("8:40"), ["3/3", "2/2", "1/1"]),
    t("6.1", 17, "345R", "311.double.R", 105.714, Some(36.0), Some("12:36"), ["3/3", "2/2", "1/1"]),
    t("6.1", 18, "341L", "311L", 89.966, Some(50.0), Some("12:51"), ["3/3", "2/2", "1/1"]),
    t("6.1", 19, "303.second.L", "350R", 107.899, Some(62.5), Some("11:53"), ["3/3", "2/2", "1/1"]),
    t("6.1", 20, "345R", "311R", 96.774, Some(48.0), Some("13:31"), ["3/3", "2/2", "1/1"]),
    t("6.1", 21, "303.second.L", "350L", 106.070, Some(75.0), Some("10:40"), ["3/3", "2/2", "1/1"]),
    t("6.1", 22, "345R", "311.double.L", 103.886, None, None, ["1/3", "1*/2", "0/1"]),
    t("6.1", 23, "NE.men.R", "302R", 120.650, Some(50.0), Some("11:43"), ["3/3", "6/6", "1/1"]),
    t("6.1", 24, "301R", "350R", 154.686, Some(60.0), Some("15:52"), ["3/4", "6/6", "1/1"]),
    t("6.1", 25, "350R", "372L", 59.740, Some(80.0), Some("3:26"), ["1/1", "0/0", "1/1"]),
    t("6.1", 26, "381R", "NE.men.R", 92.354, Some(50.0), Some("5:10"), ["1/1", "0/0", "1/1"]),
    t("6.1", 27, "acs.elev.R", "376R", 89.052, Some(20.0), Some("6:11"), ["1/1", "0/0", "1/1"]),
    t("6.2", 1, "302L", "A340R", 35.585, Some(-7.0), Some("7:33"), ["1/1", "1/1", "1/1"]),
    t("6.2", 2, "A392L", "A340R", 15.113, Some(7.0), Some("3:09"), ["1/1", "1/1", "1/1"]),
    t("6.2", 3, "311L", "381R", 171.754, Some(-36.0), Some("23:56"), ["6/6", "8/8", "1/1"]),
    t("6.2", 4, "323L", "381R", 197.358, None, None, ["4*/7", "5/9", "0/1"]),
    t("6.2", 5, "341R", "381R", 260.807, Some(75.0), Some("32:31"), ["8/8", "10/10", "1/1"]),
    t("6.2", 6, "345R", "345L", 337.007, None, None, ["7/9", "8*/10", "0/1"]),
    t("6.2", 7, "A313L", "345L", 98.958, Some(95.0), Some("9:39"), ["2/2", "2/2", "1/1"]),
    t("6.2", 8, "NE.women.L", "A314R", 203.911, Some(59.0), Some("22:08"), ["6/6", "7/7", "1/1"]),
    t("6.2", 9, "A314R", "345R", 101.904, Some(24.0), Some("9:52"), ["2/2", "2/2", "1/1"]),
    t("6.2", 10, "NW.men's.L", "A314R", 142.748, Some(35.0), Some("18:56"), ["5/5", "6/6", "1/1"]),
    t("6.2", 11, "A342L", "A323R", 38.633, Some(40.0), Some("5:36"), ["1/1", "0/0", "1/1"]),
    t("6.2", 12, "A347L", "A385R", 103.530, None, None, ["2/3", "1*/2", "0/1"]),
    t("6.2", 13, "A365L", "301R", 69.900, Some(48.0), Some("9:41"), ["2/2", "1/1", "1/1"]),
];

/// The way round the thesis' robot took where it was not the shortest: our
/// EB3's corridors through these positions give the lengths Table 6.2
/// prints, on the corridors' centre lines (#4 198.1 m for 197.358, #5
/// 261.7 for 260.807, #6 "a complete cycle of the building" 337.9 for
/// 337.007). #8 (203.911 m) is left the shortest way: the nearest way in
/// our map (209.8 m, through A305R and A355L) turns back on itself at
/// A355L, which the Planner cannot drive; without turning back none comes
/// nearer than 247 m.
pub const WAY_ROUND: [(&str, u32, &[&str]); 3] = [
    ("6.2", 4, &["301.secondL"]),
    ("6.2", 5, &["301.secondL"]),
    ("6.2", 6, &["359L", "301.secondL"]),
];

impl ThesisRun {
    /// The positions this run goes through ([`WAY_ROUND`]), if any.
    pub fn via(&self) -> &'static [&'static str] {
        WAY_ROUND
            .iter()
            .find(|(t, n, _)| *t == self.table && *n == self.no)
            .map_or(&[], |(_, _, v)| v)
    }
}

/// One run to make.
#[derive(Debug, Clone)]
pub struct Trial {
    /// Its number in the output, from 1.
    pub no: usize,
    /// The route (robot `r1`).
    pub route: RouteSpec,
    /// The world's seed.
    pub seed: u64,
    /// The thesis' row it reruns, if any.
    pub thesis: Option<ThesisRun>,
}

impl Trial {
    /// Its route as the tables name it ([`rome_nav::plan::label`]).
    pub fn path(&self) -> String {
        let r = &self.route;
        rome_nav::plan::label(&r.from, &r.via, &r.to)
    }
}

/// The trials of `routes` (or of [`CHAPTER6`] when `None`), each `repeats`
/// times; trial k (from 0) has seed `seed + k`.
pub fn trials(routes: Option<Vec<RouteSpec>>, repeats: usize, seed: u64) -> Vec<Trial> {
    let base: Vec<(RouteSpec, Option<ThesisRun>)> = match routes {
        Some(r) => r.into_iter().map(|r| (r, None)).collect(),
        None => CHAPTER6
            .iter()
            .map(|t| {
                let mut r = RouteSpec::new("r1", t.from, t.to);
                r.via = t.via().iter().map(|v| (*v).to_string()).collect();
                (r, Some(*t))
            })
            .collect(),
    };
    let mut out = Vec::new();
    for _ in 0..repeats.max(1) {
        for (route, thesis) in &base {
            let k = out.len();
            let mut route = route.clone();
            route.robot = "r1".into();
            out.push(Trial {
                no: k + 1,
                route,
                seed: seed.wrapping_add(k as u64),
                thesis: *thesis,
            });
        }
    }
    out
}

/// How the trials are run.
#[derive(Debug, Clone)]
pub struct Setup {
    /// The building.
    pub map: Map,
    /// Sensor noise and wheel slip.
    pub noise: Noise,
    /// Runs at a time.
    pub jobs: usize,
    /// A run is given up after this much simulated time.
    pub limit: Duration,
    /// The Navigator's cruising speed, mm/s, for routes that do not give
    /// their own (`None`: the Navigator's default).
    pub cruise_mm_s: Option<f64>,
    /// People walking the corridors in every run.
    pub people: usize,
    /// A run still going after this much wall-clock time is given up as
    /// hung, so that one run cannot hold the whole experiment.
    pub wall_limit: Duration,
    /// The Navigator's configuration (its cruise replaced by the route's
    /// or [`Setup::cruise_mm_s`]).
    pub nav: NavConfig,
}

/// A trial and how it ended: its report, or why there is none (a route
/// the map cannot plan, say).
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The trial.
    pub trial: Trial,
    /// The run's report.
    pub report: Result<Report, String>,
}

/// Runs every trial, `setup.jobs` at a time (each its own lock-step world,
/// so the result does not depend on how many run at once); `done` hears
/// each outcome as it ends. The outcomes come back in trial order.
pub async fn run_all(
    setup: &Setup,
    trials: Vec<Trial>,
    mut done: impl FnMut(&Outcome),
) -> Vec<Outcome> {
    let gate = Arc::new(tokio::sync::Semaphore::new(setup.jobs.max(1)));
    let mut set = tokio::task::JoinSet::new();
    for trial in trials {
        let gate = gate.clone();
        let mut cfg = RunConfig::new(setup.map.clone(), &trial.route.from, &trial.route.to);
        // The trial's route whole (way points and all), the setup's cruise
        // where the route names none.
        cfg.routes[0] = RouteSpec {
            robot: cfg.routes[0].robot.clone(),
            cruise_mm_s: trial.route.cruise_mm_s.or(setup.cruise_mm_s),
            ..trial.route.clone()
        };
        cfg.seed = trial.seed;
        cfg.noise = setup.noise.clone();
        cfg.limit = setup.limit;
        cfg.people = setup.people;
        cfg.nav = setup.nav.clone();
        let wall_limit = setup.wall_limit;
        set.spawn(async move {
            let _permit = gate.acquire_owned().await;
            let report = match tokio::time::timeout(wall_limit, run(cfg, |_| {})).await {
                Ok(r) => r.map_err(|e: NavError| e.to_string()),
                Err(_) => Err(format!(
                    "hung: still running after {} s of wall time, given up (a run takes seconds; docs/experiments.md)",
                    wall_limit.as_secs()
                )),
            };
            Outcome { trial, report }
        });
    }
    let mut out = Vec::new();
    while let Some(joined) = set.join_next().await {
        match joined {
            Ok(o) => {
                done(&o);
                out.push(o);
            }
            Err(e) => tracing::error!(error = %e, "an experiment run's task failed"),
        }
    }
    out.sort_by_key(|o| o.trial.no);
    out
}

/// A mode column (L, C or D) as the thesis prints it: `m/n`, with a star
/// after `m` when [`Report::mode`] stars it.
pub fn mode_cell(r: &Report, column: GoalType) -> String {
    let (done, need, starred) = r.mode(column);
    format!("{done}{}/{need}", if starred { "*" } else { "" })
}

/// Average speed over the run, m/min (the thesis' measure).
pub fn speed_m_min(r: &Report) -> f64 {
    let min = r.run_time.as_secs_f64() / 60.0;
    if min > 0.0 {
        r.driven_m / min
    } else {
        0.0
    }
}

/// A signed whole number of cm, with no "-0".
fn signed_cm(cm: f64) -> String {
    let r = cm.round();
    if r == 0.0 {
        "0".into()
    } else {
        format!("{r:+.0}")
    }
}

fn to_goal(r: &Report) -> String {
    if r.arrived() {
        signed_cm(r.to_goal_cm)
    } else {
        format!("Fail ({})*", signed_cm(r.to_goal_cm))
    }
}

/// Why a run is starred, one line (empty when nothing is).
pub fn reason(o: &Outcome) -> String {
    match &o.report {
        Err(e) => e.clone(),
        Ok(r) => {
            let mut why: Vec<String> = Vec::new();
            if let Some(f) = &r.failure {
                why.push(f.clone());
            } else if !r.arrived() {
                why.push(format!(
                    "ended {:.0} cm from the goal by ground truth",
                    r.miss_cm
                ));
            }
            why.extend(r.reasons().into_iter().map(|l| {
                l.trim_start_matches("* ")
                    .trim_start_matches(&format!("{}: ", r.robot))
                    .to_string()
            }));
            why.join("; ")
        }
    }
}

/// The results in the layout of Tables 6.1 and 6.2, each row beside the
/// thesis' row it reruns, then the starred rows' reasons.
pub fn markdown(outcomes: &[Outcome]) -> String {
    let mut s = String::from(
        "| No. | Path | Seed | Actual Dist. (m) | Dist. to Goal (cm) | Run Time | Speed (m/min) | L | C | D | Thesis | Thesis Dist. (m) | Thesis to Goal (cm) | Thesis Time | Thesis L | Thesis C | Thesis D |\n\
         |----:|------|-----:|-----------------:|-------------------:|---------:|--------------:|---|---|---|--------|-----------------:|--------------------:|------------:|---|---|---|\n",
    );
    for o in outcomes {
        let tr = &o.trial;
        let path = tr.path();
        let ours = match &o.report {
            Ok(r) => format!(
                "{:.3} | {} | {} | {:.1} | {} | {} | {}",
                r.driven_m,
                to_goal(r),
                mmss(r.run_time),
                speed_m_min(r),
                mode_cell(r, GoalType::L),
                mode_cell(r, GoalType::C),
                mode_cell(r, GoalType::D)
            ),
            Err(_) => "— | Fail* | — | — | — | — | —".to_string(),
        };
        let thesis = match &tr.thesis {
            Some(t) => format!(
                "{} #{} | {:.3} | {} | {} | {} | {} | {}",
                t.table,
                t.no,
                t.dist_m,
                t.to_goal_cm
                    .map_or("Fail".to_string(), |c| format!("{c:+}")),
                t.time.unwrap_or("—"),
                t.modes[0],
                t.modes[1],
                t.modes[2]
            ),
            None => "— | — | — | — | — | — | —".to_string(),
        };
        s.push_str(&format!(
            "| {} | {path} | {} | {ours} | {thesis} |\n",
            tr.no, tr.seed
        ));
    }
    let starred: Vec<String> = outcomes
        .iter()
        .filter(|o| !reason(o).is_empty())
        .map(|o| format!("- No. {}: {}", o.trial.no, reason(o)))
        .collect();
    if !starred.is_empty() {
        s.push_str("\nStarred:\n\n");
        s.push_str(&starred.join("\n"));
        s.push('\n');
    }
    s
}

/// A CSV cell: quoted when it holds a comma, a quote or a line break.
pub(crate) fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The results as CSV, one run a line, with the thesis' row beside it.
pub fn csv(outcomes: &[Outcome]) -> String {
    let mut s = String::from(
        "no,from,to,via,seed,arrived,actual_m,to_goal_cm,miss_cm,run_time_s,speed_m_min,l,c,d,contacts,thesis,thesis_dist_m,thesis_to_goal_cm,thesis_time,thesis_l,thesis_c,thesis_d,reason\n",
    );
    for o in outcomes {
        let tr = &o.trial;
        let mut f: Vec<String> = vec![
            tr.no.to_string(),
            tr.route.from.clone(),
            tr.route.to.clone(),
            // Space-separated, as a routes file writes them.
            tr.route.via.join(" "),
            tr.seed.to_string(),
        ];
        match &o.report {
            Ok(r) => f.extend([
                r.arrived().to_string(),
                format!("{:.3}", r.driven_m),
                format!("{:.0}", r.to_goal_cm),
                format!("{:.0}", r.miss_cm),
                format!("{:.1}", r.run_time.as_secs_f64()),
                format!("{:.2}", speed_m_min(r)),
                mode_cell(r, GoalType::L),
                mode_cell(r, GoalType::C),
                mode_cell(r, GoalType::D),
                r.contacts.total().to_string(),
            ]),
            Err(_) => {
                f.push("false".into());
                f.extend(std::iter::repeat_n(String::new(), 9));
            }
        }
        match &tr.thesis {
            Some(t) => f.extend([
                format!("{} #{}", t.table, t.no),
                format!("{:.3}", t.dist_m),
                t.to_goal_cm.map_or(String::new(), |c| c.to_string()),
                t.time.unwrap_or("").to_string(),
                t.modes[0].to_string(),
                t.modes[1].to_string(),
                t.modes[2].to_string(),
            ]),
            None => f.extend(std::iter::repeat_n(String::new(), 7)),
        }
        f.push(reason(o));
        let line: Vec<String> = f.iter().map(|x| csv_field(x)).collect();
        s.push_str(&line.join(","));
        s.push('\n');
    }
    s
}

/// A few lines that sum the runs up: how many arrived, within 0.5 m and
/// 1 m, speeds, and each mode's m/n over all runs.
pub fn summary(outcomes: &[Outcome]) -> String {
    let reports: Vec<&Report> = outcomes
        .iter()
        .filter_map(|o| o.report.as_ref().ok())
        .collect();
    let n = outcomes.len();
    let arrived_n = reports.iter().filter(|r| r.arrived()).count();
    let within = |cm: f64| {
        reports
            .iter()
            .filter(|r| r.failure.is_none() && r.miss_cm < cm)
            .count()
    };
    let speeds: Vec<f64> = reports.iter().map(|r| speed_m_min(r)).collect();
    let (lo, hi) = speeds.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| {
        (lo.min(v), hi.max(v))
    });
    let mean = if speeds.is_empty() {
        0.0
    } else {
        speeds.iter().sum::<f64>() / speeds.len() as f64
    };
    let sum = |f: &dyn Fn(&Report) -> (usize, usize)| {
        reports
            .iter()
            .map(|r| f(r))
            .fold((0, 0), |(a, b), (c, d)| (a + c, b + d))
    };
    let l = sum(&|r| (r.modes_done.l, r.modes_needed.l));
    let c = sum(&|r| (r.modes_done.c, r.modes_needed.c));
    let d = sum(&|r| (r.modes_done.d, r.modes_needed.d));
    let speed = if speeds.is_empty() {
        "no run".to_string()
    } else {
        format!("{lo:.1}–{hi:.1} m/min, mean {mean:.1}")
    };
    format!(
        "{arrived_n} of {n} runs arrived (within 1 m, no failure); {} within 0.5 m\n\
         speed: {speed} (thesis: 7.0–17.875 m/min old wing, 4.7–10.25 new wing)\n\
         modes over all runs: L {}/{}, C {}/{}, D {}/{} (thesis: L 99/101, C 76/79)",
        within(50.0),
        l.0,
        l.1,
        c.0,
        c.1,
        d.0,
        d.1
    )
}

/// Writes the pictures of the runs on `map` (whose world is `world`) into
/// `dir`: each run's true trajectory over the map (`run-07.png`), all of
/// them on one map (`all.png`, labelled by run number), and the
/// distributions of the distance to the goal and of the speed
/// (`to-goal.svg`, `speed.svg`). Returns the paths.
pub fn pictures(
    outcomes: &[Outcome],
    map: &Map,
    world: &rome_maps::World,
    dir: &std::path::Path,
) -> std::io::Result<Vec<std::path::PathBuf>> {
    let mut written = Vec::new();
    let mut all = Vec::new();
    for o in outcomes {
        let Ok(r) = &o.report else { continue };
        let path = dir.join(format!("run-{:02}.png", o.trial.no));
        let png = rome_nav::report::fleet_picture(std::slice::from_ref(r), map, world, 1200);
        std::fs::write(&path, png)?;
        written.push(path);
        let mut labelled = r.clone();
        labelled.robot = o.trial.no.to_string();
        // Every run had people of its own: on one map they would be a
        // tangle, so the overview leaves them out.
        labelled.people.clear();
        all.push(labelled);
    }
    if !all.is_empty() {
        let path = dir.join("all.png");
        std::fs::write(
            &path,
            rome_nav::report::fleet_picture(&all, map, world, 2000),
        )?;
        written.push(path);
    }
    let reports: Vec<&Report> = all.iter().collect();
    let to_goal: Vec<f64> = reports.iter().map(|r| r.to_goal_cm).collect();
    let speed: Vec<f64> = reports.iter().map(|r| speed_m_min(r)).collect();
    for (name, svg) in [
        (
            "to-goal.svg",
            histogram_svg(
                "Distance to goal along the last corridor",
                "cm",
                &to_goal,
                5.0,
            ),
        ),
        (
            "speed.svg",
            histogram_svg("Average speed", "m/min", &speed, 1.0),
        ),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, svg)?;
        written.push(path);
    }
    Ok(written)
}

/// A bar chart of how many `values` fall in each bin of `bin` units, as
/// SVG (a bin's bar is labelled with its lower edge and its count).
pub fn histogram_svg(title: &str, unit: &str, values: &[f64], bin: f64) -> String {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let (w, h, left, bottom, top) = (640.0, 320.0, 40.0, 40.0, 40.0);
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"{}\" y=\"20\" text-anchor=\"middle\" font-size=\"14\">{title} ({} runs)</text>\n",
        w / 2.0,
        finite.len()
    );
    if finite.is_empty() || bin.is_nan() || bin <= 0.0 {
        svg.push_str("</svg>\n");
        return svg;
    }
    let lo = (finite.iter().copied().fold(f64::INFINITY, f64::min) / bin).floor() as i64;
    let hi = (finite.iter().copied().fold(f64::NEG_INFINITY, f64::max) / bin).floor() as i64;
    // Never more bars than there is room for.
    let n = ((hi - lo + 1).clamp(1, 200)) as usize;
    let mut counts = vec![0usize; n];
    for v in &finite {
        let k = ((v / bin).floor() as i64 - lo).clamp(0, n as i64 - 1) as usize;
        counts[k] += 1;
    }
    let most = counts.iter().copied().max().unwrap_or(1).max(1) as f64;
    let bar_w = (w - 2.0 * left) / n as f64;
    let plot_h = h - bottom - top;
    for (k, c) in counts.iter().enumerate() {
        let x = left + k as f64 * bar_w;
        let bh = plot_h * *c as f64 / most;
        let y = h - bottom - bh;
        svg.push_str(&format!(
            "<rect x=\"{x:.1}\" y=\"{y:.1}\" width=\"{:.1}\" height=\"{bh:.1}\" fill=\"#4a7ab5\"/>\n",
            (bar_w - 1.0).max(0.5)
        ));
        if *c > 0 {
            svg.push_str(&format!(
                "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{c}</text>\n",
                x + bar_w / 2.0,
                y - 3.0
            ));
        }
        if n <= 30 || k % (n / 15 + 1) == 0 {
            svg.push_str(&format!(
                "<text x=\"{x:.1}\" y=\"{:.1}\">{}</text>\n",
                h - bottom + 14.0,
                (lo + k as i64) as f64 * bin
            ));
        }
    }
    svg.push_str(&format!(
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{unit}</text>\n</svg>\n",
        w / 2.0,
        h - 8.0
    ));
    svg
}
