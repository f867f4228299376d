//! `rome bench all`: every benchmark in one run, so that every ratio is
//! between figures taken minutes apart on the same machine, then the
//! project's performance targets read off those ratios.
//!
//! ```text
//! $ rome bench all --out bench.json --doc docs/benchmarks.md
//! == data server (far end in its own process) …
//! == targets
//! target                                                       measured       aim  met
//! get p50 / bare queryable, 1 client(s)                           1.08x   ≤ 1.10x  yes
//! durable set ops/s / etcd put ops/s, 50 clients                 1.62x   ≥ 1.00x  yes
//! …
//! 10 of 17 targets met
//! wrote bench.json; regenerated the marked section of docs/benchmarks.md
//! ```
//!
//! The Markdown file keeps everything outside the lines
//! `<!-- rome bench all: begin -->` and `<!-- rome bench all: end -->`.

use super::data::{self as bench, DataBench, Row};
use super::mem::{self as bench_mem, MemBench, MemFigures};
use super::robot::{self as bench_robot, RobotBench, RobotFigures};
use super::sim::{self as bench_sim, SimBench, SimRow};
use serde::Serialize;
use std::path::PathBuf;

/// Where the generated section of a Markdown file begins.
pub const DOC_BEGIN: &str = "<!-- rome bench all: begin -->";
/// Where it ends.
pub const DOC_END: &str = "<!-- rome bench all: end -->";

/// Flags of `rome bench all`.
#[derive(Debug, clap::Args)]
pub struct AllBench {
    /// Seconds to measure each round-trip operation at each client count.
    #[arg(long, default_value_t = 2.0)]
    pub seconds: f64,
    /// Client counts of the data-server measurements.
    #[arg(long, value_delimiter = ',', default_values_t = [1usize, 50])]
    pub clients: Vec<usize>,
    /// Robot counts of the simulator measurements.
    #[arg(long, value_delimiter = ',', default_values_t = [1usize, 10, 100, 1000])]
    pub sim_robots: Vec<usize>,
    /// Wall-clock seconds of each simulator measurement.
    #[arg(long, default_value_t = 3.0)]
    pub sim_seconds: f64,
    /// Variables of the data server whose memory is measured.
    #[arg(long, default_value_t = 100_000)]
    pub variables: u32,
    /// Robots of the `rome sim` whose memory is measured.
    #[arg(long, default_value_t = 100)]
    pub mem_robots: u32,
    /// Where to write every figure as JSON.
    #[arg(long, value_name = "FILE", default_value = "rome-bench.json")]
    pub out: PathBuf,
    /// A Markdown file whose marked section is replaced by this run's
    /// tables (docs/benchmarks.md).
    #[arg(long, value_name = "FILE")]
    pub doc: Option<PathBuf>,
}

/// One target read off the run.
#[derive(Debug, Clone, Serialize)]
pub struct Target {
    /// What is compared.
    pub what: String,
    /// The measured figure.
    pub measured: f64,
    /// The aim.
    pub aim: f64,
    /// Whether the aim is an upper bound (ratios) or a lower one (speeds).
    pub at_most: bool,
    /// Whether it was met.
    pub met: bool,
}

impl Target {
    /// A target, met or not by `measured`.
    fn new(what: String, measured: f64, aim: f64, at_most: bool) -> Self {
        let met = if at_most {
            measured <= aim
        } else {
            measured >= aim
        };
        Target {
            what,
            measured,
            aim,
            at_most,
            met,
        }
    }
}

/// Everything one run measured.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// When the run ended (UTC, RFC 3339).
    pub when: String,
    /// Processors the machine offers.
    pub cores: usize,
    /// The build profile that measured (`release` or `debug`).
    pub build: &'static str,
    /// `rome bench data`'s rows.
    pub data: Vec<Row>,
    /// `rome bench robot`'s figures.
    pub robot: RobotFigures,
    /// `rome bench sim`'s rows.
    pub sim: Vec<SimRow>,
    /// `rome bench mem`'s figures.
    pub mem: MemFigures,
    /// The targets read off the figures.
    pub targets: Vec<Target>,
}

/// Runs everything, prints it, writes the JSON and the Markdown section.
pub async fn run(args: &AllBench) -> anyhow::Result<()> {
    // The durable server's state, measured beside etcd's.
    let disk = std::env::temp_dir().join(format!("rome-bench-all-{}", std::process::id()));
    let data_args = DataBench {
        clients: args.clients.clone(),
        seconds: args.seconds,
        json: false,
        data_dir: Some(disk.clone()),
        in_process: false,
        unix: false,
    };
    eprintln!("== data server (its far end in a process of its own)");
    let data = bench::data_rows(&data_args, true).await;
    let _ = std::fs::remove_dir_all(&disk);
    let data = data?;
    eprintln!("== hardware servers");
    let robot = bench_robot::figures(
        &RobotBench {
            seconds: args.seconds,
            json: false,
        },
        true,
    )
    .await?;
    eprintln!("== simulator");
    let sim_args = SimBench {
        map: "eb3".into(),
        robots: args.sim_robots.clone(),
        seconds: args.sim_seconds,
        seed: 1,
        no_cameras: false,
        json: false,
    };
    let sim = tokio::task::spawn_blocking(move || bench_sim::rows(&sim_args)).await??;
    eprintln!("== memory");
    let mem = bench_mem::figures(
        &MemBench {
            variables: args.variables,
            history: 10,
            robots: args.mem_robots,
            json: false,
        },
        true,
    )
    .await?;
    let targets = targets(&data, &robot, &sim);
    let report = Report {
        when: {
            let t = time::OffsetDateTime::now_utc();
            format!(
                "{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z",
                t.year(),
                u8::from(t.month()),
                t.day(),
                t.hour(),
                t.minute(),
                t.second()
            )
        },
        cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
        build: if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
        data,
        robot,
        sim,
        mem,
        targets,
    };
    let text = report_text(&report);
    print!("{text}");
    eprintln!("{}", met_summary(&report.targets));
    std::fs::write(&args.out, serde_json::to_string_pretty(&report)? + "\n")
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", args.out.display()))?;
    eprintln!("wrote {}", args.out.display());
    if let Some(doc) = &args.doc {
        let old = std::fs::read_to_string(doc)
            .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", doc.display()))?;
        let new = replace_section(&old, &markdown(&report, &text))
            .map_err(|e| anyhow::anyhow!("{}: {e}", doc.display()))?;
        std::fs::write(doc, new)
            .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", doc.display()))?;
        eprintln!("regenerated the marked section of {}", doc.display());
    }
    Ok(())
}

/// The project's performance targets, read off one run's figures: the
/// data server's requests within 1.10× of the bare queryable (a wait, two
/// round trips by design, of two), the hardware servers' reads likewise,
/// the durable server against etcd, and the simulator's speed. Redis is
/// in the tables as context, not a target: a bare Zenoh query is itself
/// about twice a Redis GET here.
pub fn targets(data: &[Row], robot: &RobotFigures, sim: &[SimRow]) -> Vec<Target> {
    let find = |rows: &[Row], op: &str, clients: usize| {
        rows.iter()
            .find(|r| r.op == op && r.clients == clients)
            .cloned()
    };
    let p50_ratio = |a: &Row, b: &Row| a.p50_us as f64 / b.p50_us.max(1) as f64;
    let mut out = Vec::new();
    let clients: std::collections::BTreeSet<usize> = data.iter().map(|r| r.clients).collect();
    for &n in &clients {
        if let Some(raw) = find(data, "zenoh-queryable", n) {
            for op in ["get", "set", "signal"] {
                if let Some(r) = find(data, op, n) {
                    out.push(Target::new(
                        format!("{op} p50 / bare queryable, {n} client(s)"),
                        p50_ratio(&r, &raw),
                        1.10,
                        true,
                    ));
                }
            }
            if let Some(r) = find(data, "wait", n) {
                out.push(Target::new(
                    format!("wait p50 / two bare round trips, {n} client(s)"),
                    p50_ratio(&r, &raw) / 2.0,
                    1.10,
                    true,
                ));
            }
        }
        if let (Some(a), Some(b)) = (
            find(data, "wait+signal, on disk", n),
            find(data, "etcd lock+unlock", n),
        ) {
            out.push(Target::new(
                format!("durable wait+signal p50 / etcd lock+unlock p50, {n} client(s)"),
                p50_ratio(&a, &b),
                1.0,
                true,
            ));
        }
    }
    if let (Some(a), Some(b)) = (find(data, "set, on disk", 50), find(data, "etcd put", 50)) {
        out.push(Target::new(
            "durable set ops/s / etcd put ops/s, 50 clients".into(),
            a.ops_per_s / b.ops_per_s.max(1e-9),
            1.0,
            false,
        ));
        out.push(Target::new(
            "durable set p50 / etcd put p50, 50 clients".into(),
            p50_ratio(&a, &b),
            1.0,
            true,
        ));
    }
    if let Some(raw) = find(&robot.rows, "zenoh-queryable", 1) {
        for op in ["pose", "sonar", "camera-3-rows"] {
            if let Some(r) = find(&robot.rows, op, 1) {
                out.push(Target::new(
                    format!("{op} p50 / bare queryable"),
                    p50_ratio(&r, &raw),
                    1.10,
                    true,
                ));
            }
        }
    }
    for (robots, cameras) in [(1000, false), (100, true)] {
        // On every core the machine has.
        if let Some(r) = sim
            .iter()
            .filter(|r| r.robots == robots && r.cameras == cameras)
            .max_by_key(|r| r.threads)
        {
            out.push(Target::new(
                format!(
                    "simulator, {robots} robots, cameras {}: × real time",
                    if cameras { "on" } else { "off" }
                ),
                r.speed,
                10.0,
                false,
            ));
        }
    }
    out
}

/// The targets as a table.
pub fn targets_table(targets: &[Target]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:62} {:>9} {:>9} {:>4}",
        "target", "measured", "aim", "met"
    );
    for t in targets {
        let _ = writeln!(
            out,
            "{:62} {:>9} {:>9} {:>4}",
            t.what,
            format!("{:.2}x", t.measured),
            format!("{}{:.2}x", if t.at_most { "≤ " } else { "≥ " }, t.aim),
            if t.met { "yes" } else { "no" },
        );
    }
    out
}

/// Every table of the report, as the terminal shows it.
pub fn report_text(r: &Report) -> String {
    let mut out = String::new();
    out += "== data server: round trips, µs (far end in its own process)\n";
    out += &bench::table(&r.data);
    out += "\n== hardware servers: one client, round trips µs; a scan's age on arrival\n";
    out += &bench::table(&r.robot.rows);
    out += &format!(
        "scan stream (world free-running): {:.0} scans/s, {} lost\n",
        r.robot.scans_per_s, r.robot.scans_lost
    );
    out += "\n== simulator (EB3)\n";
    out += &bench_sim::table(&r.sim);
    out += "\n== resident memory\n";
    out += &bench_mem::table(&r.mem);
    out += "\n== targets\n";
    out += &targets_table(&r.targets);
    out
}

/// The Markdown section for `r`, whose tables are `text`.
pub fn markdown(r: &Report, text: &str) -> String {
    format!(
        "{DOC_BEGIN}\n\
         <!-- Generated by `rome bench all --doc docs/benchmarks.md`; edits here are overwritten. -->\n\n\
         Run of {when}, {build} build, {cores} cores: {met}.\n\n\
         ```text\n{text}```\n\
         {DOC_END}",
        when = r.when,
        build = r.build,
        cores = r.cores,
        met = met_summary(&r.targets),
    )
}

/// "N of M targets met".
pub fn met_summary(targets: &[Target]) -> String {
    let met = targets.iter().filter(|t| t.met).count();
    format!("{met} of {} targets met", targets.len())
}

/// `doc` with the text between the markers (markers included) replaced by
/// `section`; an error naming what is missing when they are not there once
/// each, in order.
pub fn replace_section(doc: &str, section: &str) -> Result<String, String> {
    let begin = doc.find(DOC_BEGIN);
    let end = doc.find(DOC_END);
    match (begin, end) {
        (Some(b), Some(e)) if b < e => {
            if doc[b + DOC_BEGIN.len()..].contains(DOC_BEGIN)
                || doc[e + DOC_END.len()..].contains(DOC_END)
            {
                return Err("the markers appear more than once".into());
            }
            Ok(format!(
                "{}{section}{}",
                &doc[..b],
                &doc[e + DOC_END.len()..]
            ))
        }
        (Some(_), Some(_)) => Err(format!("'{DOC_END}' comes before '{DOC_BEGIN}'")),
        _ => Err(format!(
            "no section marked by the lines '{DOC_BEGIN}' and '{DOC_END}' to regenerate"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(op: &'static str, clients: usize, p50_us: u64, ops_per_s: f64) -> Row {
        Row {
            op,
            clients,
            ops_per_s,
            p50_us,
            p99_us: p50_us * 2,
            samples: 100,
        }
    }

    #[test]
    fn targets_are_read_off_the_ratios_and_can_fail() {
        let data = vec![
            row("redis GET", 1, 60, 16_000.0),
            row("zenoh-queryable", 1, 100, 9_000.0),
            row("get", 1, 105, 8_000.0),
            row("set", 1, 130, 7_000.0),
            row("wait", 1, 215, 4_000.0),
            row("wait+signal, on disk", 1, 900, 1_000.0),
            row("etcd lock+unlock", 1, 800, 1_200.0),
            row("zenoh-queryable", 50, 1000, 45_000.0),
            row("wait", 50, 2300, 20_000.0),
            row("set, on disk", 50, 2000, 22_000.0),
            row("etcd put", 50, 3000, 14_000.0),
            row("wait+signal, on disk", 50, 5000, 9_000.0),
            row("etcd lock+unlock", 50, 10_000, 5_000.0),
        ];
        let robot = RobotFigures {
            rows: vec![
                row("zenoh-queryable", 1, 100, 1.0),
                row("pose", 1, 150, 1.0),
            ],
            scans_per_s: 100.0,
            scans_lost: 0,
        };
        let sim = vec![SimRow {
            robots: 1000,
            cameras: false,
            threads: 2,
            sim_s: 12.0,
            wall_s: 1.0,
            speed: 12.0,
            scans_per_s: 0.0,
        }];
        let t = targets(&data, &robot, &sim);
        let get = |what: &str| {
            t.iter()
                .find(|t| t.what == what)
                .unwrap_or_else(|| panic!("no target '{what}' in {t:?}"))
        };
        assert!(get("get p50 / bare queryable, 1 client(s)").met);
        assert!(!get("set p50 / bare queryable, 1 client(s)").met);
        // A wait is two round trips: 215 µs against 2 × 100 is 1.075.
        let wait = get("wait p50 / two bare round trips, 1 client(s)");
        assert!((wait.measured - 1.075).abs() < 1e-9 && wait.met);
        assert!(!get("wait p50 / two bare round trips, 50 client(s)").met);
        assert!(!get("pose p50 / bare queryable").met);
        assert!(!get("durable wait+signal p50 / etcd lock+unlock p50, 1 client(s)").met);
        assert!(get("durable wait+signal p50 / etcd lock+unlock p50, 50 client(s)").met);
        let put = get("durable set ops/s / etcd put ops/s, 50 clients");
        assert!((put.measured - 22.0 / 14.0).abs() < 1e-9 && put.met && !put.at_most);
        assert!(get("durable set p50 / etcd put p50, 50 clients").met);
        assert!(get("simulator, 1000 robots, cameras off: × real time").met);
        assert!(
            !t.iter()
                .any(|t| t.what.contains("Redis") || t.what.contains("redis")),
            "Redis is context, not a target"
        );
        assert_eq!(met_summary(&t), "6 of 10 targets met");
        assert!(
            !t.iter().any(|t| t.what.contains("cameras on")),
            "no figure, no target"
        );
    }

    #[test]
    fn the_marked_section_is_replaced_and_the_rest_kept() {
        let doc = format!("# T\n\nbefore\n{DOC_BEGIN}\nold\n{DOC_END}\nafter\n");
        let new = replace_section(&doc, &format!("{DOC_BEGIN}\nnew\n{DOC_END}"))
            .expect("markers present");
        assert_eq!(
            new,
            format!("# T\n\nbefore\n{DOC_BEGIN}\nnew\n{DOC_END}\nafter\n")
        );
        let e = replace_section("# T\nno markers\n", "x").expect_err("no markers");
        assert!(e.contains("no section marked"), "{e}");
        let e = replace_section(&format!("{DOC_END}\n{DOC_BEGIN}\n"), "x").expect_err("reversed");
        assert!(e.contains("comes before"), "{e}");
    }
}
