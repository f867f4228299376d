//! The `rome` program driven as a person would from a shell, against
//! `rome data-server` running in another process, all on loopback.

#![allow(clippy::unwrap_used)]

use rome_client::net::free_loopback_port;
use rome_tests::ChildGuard;
use std::ffi::OsStr;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const ROME: &str = env!("CARGO_BIN_EXE_rome");

struct Shell {
    port: u16,
    server: ChildGuard,
}

impl Shell {
    fn start() -> Shell {
        let (server, port, _) = rome_tests::spawn_listening(
            ROME,
            &[
                "data-server",
                "--in-memory",
                "--no-multicast",
                "--listen",
                "tcp/127.0.0.1:0",
            ],
        );
        Shell { port, server }
    }

    fn cmd(&self, args: &[&str]) -> Command {
        let mut c = Command::new(ROME);
        c.args(["--no-multicast", "--listen", "tcp/127.0.0.1:0", "--connect"])
            .arg(format!("tcp/127.0.0.1:{}", self.port))
            .args(args)
            .stdin(Stdio::null());
        c
    }

    fn run(&self, args: &[&str]) -> (i32, String, String) {
        let Output {
            status,
            stdout,
            stderr,
        } = self.cmd(args).output().unwrap();
        (
            status.code().unwrap_or(-1),
            String::from_utf8_lossy(&stdout).into_owned(),
            String::from_utf8_lossy(&stderr).into_owned(),
        )
    }

    fn ok(&self, args: &[&str]) -> String {
        let (code, out, err) = self.run(args);
        assert_eq!(code, 0, "rome {args:?} failed: {err}");
        out
    }
}

#[test]
fn variables_from_the_shell() {
    let sh = Shell::start();
    assert_eq!(
        sh.ok(&["data", "set", "PosX", "4"]).trim(),
        "PosX = 4 (seq 1)"
    );
    sh.ok(&["data", "set", "PosX", "5"]);
    sh.ok(&["data", "set", "Pose", r#"{"x_mm":1,"heading_deg":90}"#]);
    assert_eq!(sh.ok(&["data", "get", "PosX"]).trim(), "5");
    assert_eq!(sh.ok(&["data", "get", "PosX", "--back", "1"]).trim(), "4");
    assert_eq!(
        sh.ok(&["data", "history", "PosX", "1"]).trim(),
        "PosX: keeps 1, holds 1, last seq 2"
    );
    let ls = sh.ok(&["data", "ls"]);
    assert!(
        ls.contains("PosX") && ls.contains("\"heading_deg\":90"),
        "{ls}"
    );

    let (code, _, err) = sh.run(&["data", "get", "PosX", "--back", "1"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("out_of_range") && err.contains("back=1"),
        "{err}"
    );
    let (code, _, err) = sh.run(&["data", "set", "PosX", "abc"]);
    assert_eq!(code, 1);
    assert!(err.contains("not JSON"), "{err}");
    let (code, _, err) = sh.run(&["data", "set", "bad name", "1"]);
    assert_eq!(code, 1);
    assert!(err.contains("invalid name 'bad name'"), "{err}");
}

#[test]
fn semaphores_from_the_shell() {
    let sh = Shell::start();
    assert_eq!(
        sh.ok(&["sem", "create", "$GoalData", "0"]).trim(),
        "created GoalData = 0"
    );
    let (code, _, err) = sh.run(&["sem", "try-wait", "GoalData"]);
    assert_eq!((code, err.trim()), (3, "GoalData: no unit free"));
    let (code, _, _) = sh.run(&["sem", "wait", "GoalData", "--timeout", "0.2"]);
    assert_eq!(code, 3);

    // A blocking wait in one shell, released by a signal from another.
    let waiter = sh
        .cmd(&["sem", "wait", "$GoalData"])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut waiter = ChildGuard(Some(waiter));
    let deadline = Instant::now() + Duration::from_secs(20);
    while !sh.ok(&["sem", "get", "GoalData"]).contains("(1 waiting)") {
        assert!(Instant::now() < deadline, "the waiter never queued");
    }
    assert!(sh
        .ok(&["sem", "signal", "GoalData"])
        .contains("woke a waiter"));
    assert_eq!(waiter.output().trim(), "acquired $GoalData");
    assert_eq!(
        sh.ok(&["sem", "get", "GoalData"]).trim(),
        "GoalData = 0 (0 waiting)"
    );

    // Selector parameters on a query, as z_get takes them: two units at
    // once, then two given back; none at all is refused by name.
    sh.ok(&["sem", "create", "Lane", "3"]);
    let got = sh.ok(&["echo", "--get", "rome/data/wait/Lane?units=2;hold_ms=500"]);
    assert!(got.contains("status: granted"), "{got}");
    assert_eq!(
        sh.ok(&["sem", "get", "Lane"]).trim(),
        "Lane = 1 (0 waiting)"
    );
    sh.ok(&["echo", "--get", "rome/data/signal/Lane?units=2"]);
    assert_eq!(
        sh.ok(&["sem", "get", "Lane"]).trim(),
        "Lane = 3 (0 waiting)"
    );
    let (code, out, _) = sh.run(&["echo", "--get", "rome/data/wait/Lane?units=0"]);
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("parameter 'units' must be between 1"), "{out}");

    let (code, _, err) = sh.run(&["sem", "signal", "Nope"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("unknown_semaphore") && err.contains("'Nope'"),
        "{err}"
    );
}

#[test]
fn ls_shows_the_live_server_and_clients() {
    let sh = Shell::start();
    sh.ok(&["sem", "create", "S", "0"]);
    let waiter = sh
        .cmd(&["sem", "wait", "S"])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let _waiter = ChildGuard(Some(waiter));
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let out = sh.ok(&["ls"]);
        if out.contains("server  data") && out.contains("client  cli") {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "rome ls never showed both: {out}"
        );
    }
}

#[test]
fn the_server_stops_cleanly_on_sigint() {
    let mut sh = Shell::start();
    sh.ok(&["data", "set", "x", "1"]);
    let mut child = sh.server.0.take().unwrap();
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    assert_eq!(child.wait().unwrap().code(), Some(0));
}

#[test]
fn no_server_is_a_clear_error() {
    let port = free_loopback_port().unwrap();
    let out = Command::new(ROME)
        .args(["--no-multicast", "--listen", "tcp/127.0.0.1:0", "--connect"])
        .arg(format!("tcp/127.0.0.1:{port}"))
        .args(["--connect-timeout", "1", "data", "get", "x"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("cannot reach tcp/127.0.0.1:{port}")),
        "{err}"
    );
}

#[test]
fn demo_runs_with_no_configuration() {
    let dir = std::env::temp_dir().join(format!("rome-demo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("run.png");
    let out = offline_ok([
        "demo",
        "--from",
        "A392L",
        "--to",
        "A340R",
        "-o",
        png.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    // The plan, then the run as a row of Table 6.1 with every mode done.
    assert!(text.contains("plan A392L -> A340R"), "{text}");
    assert!(
        text.contains("Actual (m)") && text.contains("Run time"),
        "{text}"
    );
    let row = text
        .lines()
        .find(|l| l.contains("A392L to A340R"))
        .unwrap_or_else(|| panic!("no Table 6.1 row in {text}"));
    // L, C, D and contacts: every mode done, judged by ground truth, and
    // nothing touched.
    let cols: Vec<&str> = row.split_whitespace().collect();
    assert_eq!(cols[cols.len() - 4..], ["1/1", "0/0", "1/1", "0"], "{row}");
    assert!(text.contains("by ground truth"), "{text}");
    // The trajectory picture is a PNG.
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn demo_refuses_a_broken_routes_file_by_line() {
    let dir = std::env::temp_dir().join(format!("rome-routes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bad.routes");
    std::fs::write(&file, "# two robots\n350R 376L\n381L\n").unwrap();
    let err = offline_err(["demo", "--routes", file.to_str().unwrap()]);
    assert!(err.contains("bad.routes:3"), "{err}");
    assert!(err.contains("expected 'FROM TO'"), "{err}");
    std::fs::write(&file, "350R 376L fast\n").unwrap();
    let err = offline_err(["demo", "--routes", file.to_str().unwrap()]);
    assert!(err.contains("speed 'fast'"), "{err}");
    std::fs::write(&file, "350R 376L\n381L 999Q\n").unwrap();
    let err = offline_err(["demo", "--routes", file.to_str().unwrap()]);
    assert!(err.contains("'999Q'"), "{err}");
    let err = offline_err(["demo", "--cover-camera", "r7"]);
    assert!(err.contains("--cover-camera r7"), "{err}");
    let err = offline_err(["demo", "--cruise", "0"]);
    assert!(err.contains("--cruise must be a speed"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `rome fleet --no-baseline` runs only the sizes asked for, and
/// `--trace` leaves each run's ground truth, a line a robot an instant;
/// tasks.csv says when each task came, went to a robot and ended.
#[test]
fn fleet_without_its_baseline_runs_only_the_sizes_asked_and_traces_them() {
    let dir = std::env::temp_dir().join(format!("rome-fleet-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = offline_ok([
        "fleet",
        "--robots",
        "2",
        "--tasks",
        "2",
        "--no-baseline",
        "--trace",
        "-o",
        dir.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("for fleets of [2] robots"), "{text}");
    let csv = std::fs::read_to_string(dir.join("fleet.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 1, "{csv}");
    let cells: Vec<&str> = rows[0].split(',').collect();
    // Two robots, two tasks, both done; no efficiency without the
    // one-robot run.
    assert_eq!(&cells[..3], ["2", "2", "2"], "{csv}");
    assert_eq!(cells[10], "", "{csv}");
    // Where robots stood still too long, beside where they touched.
    let stuck = std::fs::read_to_string(dir.join("stuck.csv")).unwrap();
    assert_eq!(
        stuck.lines().next(),
        Some("robots,robot,since_s,still_s,x_m,y_m,task"),
        "{stuck}"
    );
    // Each task: when it came, went to a robot and ended, and which.
    let tasks = std::fs::read_to_string(dir.join("tasks.csv")).unwrap();
    let lines: Vec<&str> = tasks.lines().collect();
    assert_eq!(
        lines[0],
        "robots,task,to,state,added_s,handed_s,ended_s,wait_s,traffic_wait_s,robot,tried,why",
        "{tasks}"
    );
    assert_eq!(lines.len(), 3, "{tasks}");
    for line in &lines[1..] {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!((f[0], f[3]), ("2", "done"), "{tasks}");
        let (added, handed, ended): (f64, f64, f64) = (
            f[4].parse().unwrap(),
            f[5].parse().unwrap(),
            f[6].parse().unwrap(),
        );
        assert!(added <= handed && handed < ended, "{tasks}");
        assert!(f[9] == "r1" || f[9] == "r2", "{tasks}");
    }
    assert!(!dir.join("1.trace").exists());
    let trace = std::fs::read_to_string(dir.join("2.trace")).unwrap();
    let mut last = std::collections::BTreeMap::new();
    for line in trace.lines() {
        let f: Vec<&str> = line.split(' ').collect();
        assert_eq!(f.len(), 6 + 24, "{line}");
        let t: u64 = f[0].parse().unwrap();
        let travelled: f64 = f[5].parse().unwrap();
        last.insert(f[1].to_string(), (t, travelled));
    }
    // Both robots were traced to the end of the run, and both drove.
    assert_eq!(last.len(), 2, "{last:?}");
    for (robot, (t, travelled)) in &last {
        assert!(
            *t > 10_000 && *travelled > 1_000.0,
            "{robot}: {t} ms, {travelled} mm"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn experiment_tabulates_its_runs_and_the_confidence_automaton() {
    let dir = std::env::temp_dir().join(format!("rome-experiment-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let routes = dir.join("two.routes");
    std::fs::write(&routes, "A392L A340R\n302L A340R\n").unwrap();
    let out_dir = dir.join("out");
    let out = offline_ok([
        "experiment",
        "--routes",
        routes.to_str().unwrap(),
        "--seed",
        "5",
        "-o",
        out_dir.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("| 1 | A392L to A340R | 5 | "), "{text}");
    assert!(text.contains("| 2 | 302L to A340R | 6 | "), "{text}");
    assert!(text.contains("2 of 2 runs arrived"), "{text}");
    // §6.3: the counts behind p2 (two L segments) and p3 (one corner),
    // and Table 6.5's row for each route with its input string.
    assert!(
        text.contains("| p2 = p6 | L-mode completed | 2/2 = 1.0000 | 99/101 = 0.9802 |"),
        "{text}"
    );
    assert!(
        text.contains("| p3 = p4 = p7 | C-mode completed | 1/1 = 1.0000 |"),
        "{text}"
    );
    assert!(
        text.contains("| 302L to A340R | cld | 1.0000 | 0.8913 |"),
        "{text}"
    );
    let csv = std::fs::read_to_string(out_dir.join("runs.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(
        csv.lines()
            .nth(2)
            .unwrap()
            .starts_with("2,302L,A340R,,6,true,"),
        "{csv}"
    );
    let md = std::fs::read_to_string(out_dir.join("runs.md")).unwrap();
    assert!(md.contains("## Confidence"), "{md}");

    // Clear errors: a map with no default runs, a broken routes file.
    let err = offline_err(["experiment", "--map", "fig5_3"]);
    assert!(err.contains("give --routes"), "{err}");
    std::fs::write(&routes, "A392L\n").unwrap();
    let err = offline_err(["experiment", "--routes", routes.to_str().unwrap()]);
    assert!(err.contains("two.routes:1"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn colony_priorities_of_figure_4_14_and_a_malformed_network() {
    let out = offline_ok(["colony", "priorities", "fig4_14b"]);
    let text = String::from_utf8_lossy(&out.stdout);
    let order: Vec<&str> = text
        .lines()
        .filter_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            (w.len() == 3 && w[0].parse::<u32>().is_ok()).then(|| w[2])
        })
        .collect();
    assert_eq!(order, ["A", "B", "C", "D"], "{text}");
    assert!(text.contains("if P_A(x) then"), "{text}");
    let dir = std::env::temp_dir().join(format!("rome-colony-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("loop.colony");
    std::fs::write(
        &file,
        "module A\nmodule B\nsuppress s1 A over s2\nsuppress s2 B over s1\noutput s1\n",
    )
    .unwrap();
    let err = offline_err(["colony", "priorities", file.to_str().unwrap()]);
    assert!(
        err.contains("loop.colony") && err.contains("cycle"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn demo_names_a_room_it_does_not_know() {
    let err = offline_err(["demo", "--from", "350R", "--to", "37GL"]);
    assert!(err.contains("'37GL'"), "{err}");
    assert!(err.contains("did you mean"), "{err}");
    let err = offline_err(["planner", "--from", "999X", "--to", "376L", "--dry-run"]);
    assert!(err.contains("no position '999X'"), "{err}");
}

/// `--leave-junctions` says where a robot waits between tasks: a command
/// that drives routes, not tasks, refuses it rather than ignore it.
#[test]
fn leave_junctions_without_tasks_is_refused_by_name() {
    for args in [
        &["demo", "--leave-junctions"][..],
        &[
            "planner",
            "--from",
            "350R",
            "--to",
            "376L",
            "--dry-run",
            "--leave-junctions",
        ],
    ] {
        let err = offline_err(args);
        assert!(
            err.contains("--leave-junctions") && err.contains("--tasks"),
            "{args:?}: {err}"
        );
    }
}

/// `--one-way` sends a route that would run north up corridor N (narrow,
/// on the new wing's loop, one way south) round the loop instead, and the
/// dry run says so; a building has no one-way corridors to ask for.
#[test]
fn planner_one_way_plans_round_the_loop() {
    let length = |extra: &[&str]| {
        let mut args = vec!["planner", "--from", "A353R", "--to", "301L", "--dry-run"];
        args.extend_from_slice(extra);
        let out = offline_ok(args);
        let text = String::from_utf8_lossy(&out.stdout).to_string();
        let first = text.lines().next().unwrap_or_default().to_string();
        let metres = first
            .split(": ")
            .nth(1)
            .and_then(|r| r.split(" m").next())
            .and_then(|m| m.parse::<f64>().ok());
        (
            metres.unwrap_or_else(|| panic!("no length in {first:?}")),
            text,
        )
    };
    let (plain, text) = length(&[]);
    let (one_way, text_one_way) = length(&["--one-way"]);
    assert!(
        one_way > plain + 50.0,
        "one way {one_way} m, plain {plain} m\n{text}\n{text_one_way}"
    );
    let out = Command::new(ROME)
        .args(["planner", "--building", "tower", "--from", "1:A"])
        .args(["--to", "2:B", "--one-way"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("'--one-way'"), "{err}");
}

/// Output into a pipe nobody reads any more (`rome … | head -1`) ends
/// `rome` quietly with a shell's broken-pipe status, not a panic.
#[test]
fn a_closed_pipe_ends_rome_quietly() {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = Command::new(ROME)
        .args(["planner", "--from", "A353R", "--to", "301L", "--dry-run"])
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(out.status.code(), Some(141), "{err}");
}

#[test]
fn help_names_the_commands_and_exit_codes() {
    let out = Command::new(ROME).arg("--help").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    for word in [
        "data-server",
        "data",
        "sem",
        "ls",
        "--connect",
        "--no-multicast",
        "Exit codes",
    ] {
        assert!(text.contains(word), "--help lacks {word}: {text}");
    }
    let out = Command::new(ROME)
        .args(["sem", "wait", "--help"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("--timeout"));
    let out = Command::new(ROME).args(["data", "frob"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
}

/// Runs `rome` with `args` and no server, and checks it succeeded.
fn offline_ok<S: AsRef<std::ffi::OsStr>>(
    args: impl IntoIterator<Item = S>,
) -> std::process::Output {
    let out = Command::new(ROME).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// A `ZENOH_RUNTIME` Zenoh cannot parse is refused with a message naming
/// it, before Zenoh starts (which would panic on it).
#[test]
fn an_unreadable_zenoh_runtime_is_an_error_not_a_panic() {
    let out = Command::new(ROME)
        .args(["data", "get", "x"])
        .env("ZENOH_RUNTIME", "(app: (worker_threads: 2)")
        .env("RUST_BACKTRACE", "0")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("ZENOH_RUNTIME='(app: (worker_threads: 2)' is not a layout Zenoh can read"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// Runs `rome` without a server; it must fail with exit 1. Returns stderr.
fn offline_err<S: AsRef<std::ffi::OsStr>>(args: impl IntoIterator<Item = S>) -> String {
    let out = Command::new(ROME).args(args).output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn map_file(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../maps/data")
        .join(name)
}

#[test]
fn map_check_passes_good_maps_and_names_file_and_line_in_broken_ones() {
    let good = map_file("fig5_3.stk");
    let out = offline_ok([
        std::ffi::OsStr::new("map"),
        "check".as_ref(),
        good.as_os_str(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("2 ring(s), 20 nodes"), "{text}");
    assert!(
        text.contains("18 lights, 3 numbered doors, 3 plates, 4 links"),
        "{text}"
    );

    let dir = std::env::temp_dir().join(format!("rome-map-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let broken = dir.join("broken.stk");
    let text = std::fs::read_to_string(&good)
        .unwrap()
        .replace("node X2 270", "node X2 250");
    std::fs::write(&broken, text).unwrap();
    let err = offline_err([OsStr::new("map"), OsStr::new("check"), broken.as_os_str()]);
    assert!(
        err.contains(&format!("{}:", broken.display())) && err.contains("not ±360"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn map_render_writes_png_and_svg() {
    let dir = std::env::temp_dir().join(format!("rome-render-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, width) in [("fig.png", "800"), ("fig.svg", "900")] {
        let out_path = dir.join(name);
        let map = map_file("fig5_3.stk");
        offline_ok([
            std::ffi::OsStr::new("map"),
            "render".as_ref(),
            map.as_os_str(),
            "-o".as_ref(),
            out_path.as_os_str(),
            "--width".as_ref(),
            width.as_ref(),
        ]);
        let bytes = std::fs::read(&out_path).unwrap();
        if name.ends_with(".png") {
            assert_eq!(&bytes[1..4], b"PNG");
            let w = u32::from_be_bytes([bytes[16], bytes[17], bytes[18], bytes[19]]);
            assert_eq!(w, 800);
        } else {
            let svg = String::from_utf8(bytes).unwrap();
            assert!(svg.starts_with("<svg") && svg.contains(r#"width="900""#));
            assert!(
                svg.contains(">L1L2<") && svg.contains(">301<"),
                "door labels drawn"
            );
        }
    }
    let fig = map_file("fig5_3.stk");
    let err = offline_err([
        OsStr::new("map"),
        OsStr::new("render"),
        fig.as_os_str(),
        OsStr::new("-o"),
        OsStr::new("/tmp/x.gif"),
    ]);
    assert!(err.contains("name the output .png or .svg"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn map_check_on_eb3_and_a_broken_copy_of_it() {
    let out = offline_ok(["map", "check", "eb3"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("4 ring(s)") && text.contains("9 links"),
        "{text}"
    );

    let dir = std::env::temp_dir().join(format!("rome-eb3-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let broken = dir.join("eb3.stk");
    let good = std::fs::read_to_string(map_file("eb3.stk")).unwrap();
    // A door one metre too long: the outer ring no longer closes; and a link
    // to a node that does not exist.
    let text = good
        .replacen(
            "door 900  lights 804 number 381",
            "door 1900  lights 804 number 381",
            1,
        )
        .replace("link outer.NE A.NE", "link outer.NE A.NX");
    assert_ne!(text, good);
    std::fs::write(&broken, &text).unwrap();
    let err = offline_err([OsStr::new("map"), OsStr::new("check"), broken.as_os_str()]);
    let line_of = |needle: &str| text.lines().position(|l| l.starts_with(needle)).unwrap() + 1;
    assert!(
        err.contains(&format!("{}:{}:", broken.display(), line_of("ring outer")))
            && err.contains("misses closing"),
        "{err}"
    );
    assert!(
        err.contains(&format!(
            "{}:{}:",
            broken.display(),
            line_of("link outer.NE")
        )) && err.contains("NX"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn map_route_measures_table_6_1_routes_and_names_unknown_rooms() {
    let out = offline_ok(["map", "route", "eb3", "341L", "311R", "--legs"]);
    let text = String::from_utf8_lossy(&out.stdout);
    // Table 6.1, run 15: 91.795 m with two corners.
    assert!(
        text.contains("341L -> 311R: 91.79") && text.contains("2 corner(s), 3 leg(s)"),
        "{text}"
    );
    assert_eq!(
        text.lines().filter(|l| l.contains("heading")).count(),
        3,
        "{text}"
    );

    let err = offline_err(["map", "route", "eb3", "350X", "376L"]);
    assert!(
        err.contains("no position '350X'") && err.contains("350L, 350R"),
        "{err}"
    );
}

#[test]
fn map_commands_take_a_building_of_floors() {
    let out = offline_ok(["map", "check", "tower"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("3 floor(s), 2 elevator(s)"), "{text}");
    assert!(text.contains("elevator acs.elev: floors 3, 4, 5"), "{text}");
    let out = offline_ok(["map", "route", "tower", "3:350R", "5:576L"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("riding elevator"), "{text}");
    assert!(
        text.contains("floor 3: 350R ->") && text.contains("floor 5: "),
        "{text}"
    );
    let err = offline_err(["map", "route", "tower", "4:350R", "3:376L"]);
    assert!(
        err.contains("no position '4:350R'") && err.contains("4:450R"),
        "{err}"
    );

    let dir = rome_tests::TestDir::new("building");
    let file = dir.path().join("two.bldg");
    std::fs::write(&file, "building two\nfloor 3 eb3\nfloor 1 annex\n").unwrap();
    let err = offline_err([OsStr::new("map"), OsStr::new("check"), file.as_os_str()]);
    assert!(
        err.contains("elevator 'acs.elev' is on floor '3' only") && err.contains("two.bldg:2"),
        "{err}"
    );
    let out = offline_ok([
        OsStr::new("map"),
        OsStr::new("render"),
        OsStr::new("tower"),
        OsStr::new("-o"),
        dir.path().join("t.png").as_os_str(),
        OsStr::new("--route"),
        OsStr::new("3:350R"),
        OsStr::new("5:576L"),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    for floor in ["3", "4", "5"] {
        assert!(dir.path().join(format!("t-{floor}.png")).exists(), "{text}");
    }
}

#[test]
fn bench_sim_reports_each_robot_count() {
    let out = offline_ok([
        "bench",
        "sim",
        "--robots",
        "1,3",
        "--seconds",
        "0.1",
        "--no-cameras",
        "--json",
    ]);
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 2);
    for (row, n) in rows.iter().zip([1, 3]) {
        assert_eq!(row["robots"], n);
        assert_eq!(row["cameras"], false);
        let (sim, wall, speed) = (
            row["sim_s"].as_f64().unwrap(),
            row["wall_s"].as_f64().unwrap(),
            row["speed"].as_f64().unwrap(),
        );
        assert!(sim >= 1.0, "at least one simulated second: {sim}");
        assert!((speed - sim / wall).abs() < 1e-6 * speed.max(1.0));
    }
    assert!(String::from_utf8_lossy(&out.stderr).contains("3 robot(s), cameras off"));
}

#[test]
fn bench_robot_reports_round_trips_and_the_scan_stream() {
    let out = offline_ok(["bench", "robot", "--seconds", "0.2", "--json"]);
    let f: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let ops: Vec<&str> = f["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["op"].as_str().unwrap())
        .collect();
    assert_eq!(
        ops,
        [
            "zenoh-queryable",
            "pose-plain-get",
            "pose",
            "sonar",
            "camera-3-rows",
            "scan read→sub"
        ]
    );
    for r in f["rows"].as_array().unwrap() {
        let (p50, p99) = (r["p50_us"].as_u64().unwrap(), r["p99_us"].as_u64().unwrap());
        assert!(p50 > 0 && p50 <= p99, "{r}");
        assert!(r["samples"].as_u64().unwrap() > 0);
    }
    assert!(f["scans_per_s"].as_f64().unwrap() > 0.0);
    assert_eq!(f["scans_lost"], 0);
}

/// `rome sim` with robots r1 and r2 on the Figure 5.3 map, and its port.
fn two_robots() -> (ChildGuard, u16) {
    let (sim, port, _) = rome_tests::spawn_listening(
        ROME,
        &[
            "sim",
            "--map",
            "fig5_3",
            "--robots",
            "2",
            "--no-multicast",
            "-l",
            "tcp/127.0.0.1:0",
        ],
    );
    (sim, port)
}

#[test]
fn robot_commands_from_the_shell_against_rome_sim() {
    let (mut sim, port) = two_robots();
    let connect = format!("tcp/127.0.0.1:{port}");
    let robot = |args: &[&str]| {
        Command::new(ROME)
            .args(["-e", &connect, "--no-multicast", "robot"])
            .args(args)
            .output()
            .unwrap()
    };
    // Up once r2's base answers.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
    while !robot(&["r2", "mode"]).status.success() {
        assert!(
            std::time::Instant::now() < deadline,
            "rome sim did not come up"
        );
    }
    let out = robot(&["r1", "set-pose", "0", "0", "90"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let pose: serde_json::Value = serde_json::from_slice(&robot(&["r1", "pose"]).stdout).unwrap();
    assert_eq!(
        (pose["x_mm"].as_i64(), pose["heading_deg"].as_f64()),
        (Some(0), Some(90.0))
    );
    let sonar: serde_json::Value = serde_json::from_slice(&robot(&["r2", "sonar"]).stdout).unwrap();
    assert_eq!(sonar["sonar_mm"].as_array().unwrap().len(), 24);
    let rows: serde_json::Value =
        serde_json::from_slice(&robot(&["r1", "camera", "up", "rows", "1,2,3"]).stdout).unwrap();
    assert_eq!(rows["rows"].as_array().unwrap().len(), 3);
    let bad = robot(&["r1", "go", "9000"]);
    assert_eq!(bad.status.code(), Some(1));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("out_of_range") && err.contains("robot 'r1'"),
        "{err}"
    );
    sim.kill();
}

#[test]
fn echo_and_ls_show_a_fleets_traffic_and_rates() {
    let (mut sim, port) = two_robots();
    let connect = format!("tcp/127.0.0.1:{port}");
    let rome = |args: &[&str]| {
        let out = Command::new(ROME)
            .args(["-e", &connect, "--no-multicast"])
            .args(args)
            .stdin(Stdio::null())
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let lines = |out: &str| -> Vec<serde_json::Value> {
        out.lines()
            .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
            .collect()
    };
    // The first state message, pretty and as JSON; it waits for the sim.
    let (code, out, err) = rome(&["echo", "rome/robot/r2/base/state", "--count", "1"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        out.contains("PUT    rome/robot/r2/base/state") && out.contains("  robot: r2"),
        "{out}"
    );
    let (_, out, _) = rome(&[
        "echo",
        "rome/robot/*/proximity/scan",
        "--count",
        "4",
        "--json",
    ]);
    let scans = lines(&out);
    assert_eq!(scans.len(), 4);
    assert!(scans.iter().all(
        |s| s["kind"] == "put" && s["payload"]["sonar_mm"].as_array().map(Vec::len) == Some(24)
    ));

    // Liveliness: the servers already up are JOINED.
    let (_, out, _) = rome(&["echo", "rome/alive/server/robot/r1/**", "--count", "4"]);
    assert_eq!(out.matches("JOINED").count(), 4, "{out}");

    // A get over the fleet: one reply per robot; an act: errors, rc 1.
    let (code, out, _) = rome(&["echo", "--get", "rome/robot/*/base/pose", "--json"]);
    assert_eq!(code, Some(0));
    let mut keys: Vec<String> = lines(&out)
        .iter()
        .map(|r| format!("{} {}", r["kind"], r["key"]))
        .collect();
    keys.sort();
    assert_eq!(
        keys,
        [
            r#""reply" "rome/robot/r1/base/pose""#,
            r#""reply" "rome/robot/r2/base/pose""#
        ]
    );
    let (code, out, _) = rome(&[
        "echo",
        "--get",
        "rome/robot/*/base/go",
        "--payload",
        r#"{"velocity_mm_s":300}"#,
    ]);
    assert_eq!(code, Some(1));
    assert_eq!(out.matches("code: wildcard").count(), 2, "{out}");

    // Rates per key.
    let (_, out, _) = rome(&[
        "echo",
        "rome/robot/r1/**",
        "--hz",
        "--window",
        "2",
        "--duration",
        "2.5",
        "--json",
    ]);
    let rates = lines(&out);
    let mut keys: Vec<&str> = rates.iter().filter_map(|r| r["key"].as_str()).collect();
    keys.sort();
    assert_eq!(
        keys,
        [
            "rome/robot/r1/base/state",
            "rome/robot/r1/camera/side/frame",
            "rome/robot/r1/camera/up/frame",
            "rome/robot/r1/proximity/scan"
        ]
    );
    assert!(rates
        .iter()
        .all(|r| r["hz"].as_f64().unwrap() > 0.0 && r["count"].as_u64().unwrap() >= 1));

    // A reader that stops early (`| head -1`) ends it quietly.
    let mut child = Command::new(ROME)
        .args(["-e", &connect, "--no-multicast", "echo", "rome/robot/**"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    std::io::BufRead::read_line(
        &mut std::io::BufReader::new(child.stdout.take().unwrap()),
        &mut first,
    )
    .unwrap();
    assert!(first.contains("rome/robot/"), "{first}");
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(!err.contains("panicked"), "{err}");

    // rome ls: each device with its stream.
    let (code, out, err) = rome(&["ls", "--json"]);
    assert_eq!(code, Some(0), "{err}");
    let ls: serde_json::Value = serde_json::from_str(&out).unwrap();
    let mut streams: Vec<String> = ls["streams"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            format!(
                "{}/{}/{}",
                s["robot"].as_str().unwrap(),
                s["device"].as_str().unwrap(),
                s["stream"].as_str().unwrap()
            )
        })
        .collect();
    streams.sort();
    assert_eq!(
        streams,
        [
            "r1/base/state",
            "r1/camera/side/frame",
            "r1/camera/up/frame",
            "r1/proximity/scan",
            "r2/base/state",
            "r2/camera/side/frame",
            "r2/camera/up/frame",
            "r2/proximity/scan"
        ]
    );
    let (_, out, _) = rome(&["ls"]);
    assert!(out.contains("ROBOT") && out.contains("camera/up"), "{out}");
    sim.kill();
}

/// The Zenoh rows of `rome bench data`, beside the TCP floor and Redis.
const DATA_OPS: [&str; 7] = [
    "zenoh-queryable",
    "zenoh-queryable+body",
    "zenoh pub/sub",
    "get",
    "set",
    "signal",
    "wait",
];

#[test]
fn bench_data_measures_the_tcp_floor_zenoh_and_redis_in_one_run() {
    let out = offline_ok([
        "bench",
        "data",
        "--clients",
        "1,2",
        "--seconds",
        "0.2",
        "--json",
    ]);
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mut ops: Vec<String> = rows
        .as_array()
        .unwrap()
        .iter()
        .map(|r| format!("{} {}", r["op"].as_str().unwrap(), r["clients"]))
        .collect();
    ops.sort();
    let redis = std::process::Command::new("redis-server")
        .arg("--version")
        .output()
        .is_ok();
    let mut want: Vec<String> = Vec::new();
    for n in [1, 2] {
        let mut names = vec!["tcp ping-pong"];
        names.extend(DATA_OPS);
        if redis {
            names.extend(["redis GET", "redis SET"]);
        }
        want.extend(names.iter().map(|o| format!("{o} {n}")));
    }
    want.sort();
    assert_eq!(ops, want);
    if !redis {
        assert!(String::from_utf8_lossy(&out.stderr).contains("redis-server is not installed"));
    }
    for r in rows.as_array().unwrap() {
        assert!(
            r["samples"].as_u64().unwrap() > 0 && r["p50_us"].as_u64().unwrap() > 0,
            "{r}"
        );
    }
}

#[test]
fn bench_mem_reads_the_servers_resident_memory() {
    let out = offline_ok([
        "bench",
        "mem",
        "--variables",
        "2000",
        "--history",
        "3",
        "--robots",
        "2",
        "--json",
    ]);
    let f: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (empty, full) = (
        f["data_empty_mib"].as_f64().unwrap(),
        f["data_full_mib"].as_f64().unwrap(),
    );
    assert!(empty > 1.0 && full > empty, "{f}");
    assert!(f["sim_mib"].as_f64().unwrap() > 1.0, "{f}");
    assert_eq!(f["variables"], 2000);
    assert_eq!(f["robots"], 2);
}

#[test]
fn bench_all_writes_every_figure_and_regenerates_only_the_marked_section() {
    let dir = rome_tests::TestDir::new("rome-bench-all");
    let (json, doc) = (dir.join("bench.json"), dir.join("doc.md"));
    let begin = "<!-- rome bench all: begin -->";
    let end = "<!-- rome bench all: end -->";
    std::fs::write(
        &doc,
        format!("# Mine\n\nkept\n{begin}\nold\n{end}\nalso kept\n"),
    )
    .unwrap();
    let out = offline_ok([
        "bench".as_ref(),
        "all".as_ref(),
        "--seconds".as_ref(),
        "0.1".as_ref(),
        "--clients".as_ref(),
        "1".as_ref(),
        "--sim-robots".as_ref(),
        "1".as_ref(),
        "--sim-seconds".as_ref(),
        "0.2".as_ref(),
        "--variables".as_ref(),
        "500".as_ref(),
        "--mem-robots".as_ref(),
        "1".as_ref(),
        "--out".as_ref(),
        json.as_os_str(),
        "--doc".as_ref(),
        doc.as_os_str(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("== targets"), "{text}");
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    for part in ["data", "sim"] {
        assert!(
            !report[part].as_array().unwrap().is_empty(),
            "{part}: {report}"
        );
    }
    assert!(report["robot"]["rows"].as_array().unwrap().len() >= 4);
    assert!(report["mem"]["data_full_mib"].as_f64().unwrap() > 0.0);
    let targets = report["targets"].as_array().unwrap();
    assert!(
        targets
            .iter()
            .any(|t| t["what"] == "get p50 / bare queryable, 1 client(s)"),
        "{targets:?}"
    );
    let doc = std::fs::read_to_string(&doc).unwrap();
    assert!(doc.starts_with("# Mine\n\nkept\n"), "{doc}");
    assert!(doc.ends_with(&format!("{end}\nalso kept\n")), "{doc}");
    assert!(
        !doc.contains("\nold\n") && doc.contains("== targets"),
        "{doc}"
    );
}

#[test]
fn sim_time_is_refused_where_there_is_no_clock_to_follow() {
    // The simulator keeps the clock; a demo runs its own.
    for cmd in [["sim", "--robots", "1"], ["demo", "--robots", "1"]] {
        let err = offline_err(["--sim-time"].iter().chain(&cmd));
        assert!(
            err.contains("--sim-time is for the data server and the clients"),
            "{err}"
        );
    }
    let out = Command::new(ROME)
        .args(["sim", "--parties", "2"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "a usage error: {err}");
    assert!(
        err.contains("--lockstep"),
        "--parties needs --lockstep: {err}"
    );
}

#[test]
fn bench_data_reaches_its_far_end_over_a_unix_socket() {
    let out = offline_ok([
        "bench",
        "data",
        "--unix",
        "--clients",
        "1",
        "--seconds",
        "0.2",
        "--json",
    ]);
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for op in DATA_OPS {
        let row = rows
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["op"] == op)
            .unwrap_or_else(|| panic!("no {op} row: {rows}"));
        assert!(row["samples"].as_u64().unwrap() > 0, "{row}");
    }
}

/// The commands a build may leave out are rome's commands exactly when
/// their feature is on, so what the program says of a missing one (the
/// feature that brings it) stays true.
#[test]
fn the_commands_a_build_may_leave_out_are_there_with_their_feature() {
    use clap::CommandFactory;
    let cli = rome_cli::Cli::command();
    for (name, feature, on) in rome_cli::OPTIONAL_COMMANDS {
        assert_eq!(
            cli.find_subcommand(name).is_some(),
            *on,
            "'{name}' and the feature '{feature}'"
        );
    }
}
