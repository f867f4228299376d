//! `rome crew` keeps a robot's navigation clients running: a member killed
//! with SIGKILL is started again, a Navigator killed in the middle of a
//! goal is started again and takes the goal up, and the run arrives;
//! SIGTERM stops every member; `-v` reaches the members.

#![allow(clippy::unwrap_used)]

use rome_tests::{listening_port, spawn_logged};
use std::path::Path;
use std::time::{Duration, Instant};

const ROME: &str = env!("CARGO_BIN_EXE_rome");

/// Waits until a line of `log` after the first `skip` lines contains
/// `what`; returns it and its index.
fn line_with(log: &Path, what: &str, skip: usize, within: Duration) -> (String, usize) {
    let deadline = Instant::now() + within;
    loop {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        if let Some((i, l)) = text
            .lines()
            .enumerate()
            .skip(skip)
            .find(|(_, l)| l.contains(what))
        {
            return (l.to_string(), i);
        }
        assert!(
            Instant::now() < deadline,
            "no line with {what:?} in {}:\n{text}",
            log.display()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The pid in a line like `crew r1: navigator started (pid 4121)`.
fn pid_of(line: &str) -> u32 {
    let tail = line.rsplit("(pid ").next().unwrap();
    tail.trim_end_matches(')').parse().unwrap()
}

fn signal(pid: u32, name: &str) {
    let ok = std::process::Command::new("kill")
        .args([format!("-{name}"), pid.to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill -{name} {pid}");
}

fn running(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .map(|s| !s.contains(") Z "))
        .unwrap_or(false)
}

/// Starts `rome ARGS` with its standard output and error, its members'
/// lines included, in `log`.
fn spawn_crew(args: &[String], log: &Path) -> rome_tests::ChildGuard {
    let file = || {
        std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(log)
            .unwrap()
    };
    rome_tests::ChildGuard(Some(
        std::process::Command::new(ROME)
            .args(args)
            .stdin(std::process::Stdio::null())
            .stdout(file())
            .stderr(file())
            .spawn()
            .unwrap(),
    ))
}

/// A data server and one simulated robot at 350R; the port joined to.
fn world(dir: &Path) -> (u16, [rome_tests::ChildGuard; 2]) {
    let ds_log = dir.join("data-server.log");
    let ds = spawn_logged(ROME, &rome_tests::DATA_SERVER, &ds_log);
    let port = listening_port(&ds_log, Duration::from_secs(60));
    let sim = rome_tests::joined_to(port, &["sim", "--robots", "1", "--at", "350R"]);
    let sim = spawn_logged(ROME, &sim, &dir.join("sim.log"));
    (port, [ds, sim])
}

#[test]
fn a_crew_killed_with_sigkill_takes_its_members_with_it() {
    let dir = rome_tests::TestDir::new("rome-crew-kill-test");
    let (port, _world) = world(&dir);
    let log = dir.join("crew.log");
    let args = rome_tests::joined_to(
        port,
        &["crew", "--robot", "r1", "--no-plfinder", "--no-mapper"],
    );
    let mut crew = spawn_crew(&args, &log);
    let minute = Duration::from_secs(60);
    let (line, _) = line_with(&log, "navigator started (pid ", 0, minute);
    let navigator = pid_of(&line);
    let (line, _) = line_with(&log, "ctracker started (pid ", 0, minute);
    let ctracker = pid_of(&line);
    line_with(&log, "waiting for goals", 0, minute);
    crew.kill();
    let deadline = Instant::now() + Duration::from_secs(10);
    while running(navigator) || running(ctracker) {
        assert!(
            Instant::now() < deadline,
            "members outlived their crew by 10 s\n{}",
            std::fs::read_to_string(&log).unwrap_or_default()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn a_killed_member_is_started_again_and_the_crew_still_drives() {
    let dir = rome_tests::TestDir::new("rome-crew-test");
    let (port, _world) = world(&dir);
    let crew_log = dir.join("crew.log");
    let args = rome_tests::joined_to(
        port,
        &["crew", "--robot", "r1", "--no-plfinder", "--no-mapper"],
    );
    let mut crew = spawn_crew(&args, &crew_log);
    let minute = Duration::from_secs(60);

    let (line, at) = line_with(&crew_log, "navigator started (pid ", 0, minute);
    let first = pid_of(&line);
    line_with(&crew_log, "waiting for goals", at, minute);
    signal(first, "KILL");
    let (ended, at) = line_with(&crew_log, "navigator ended", at, minute);
    assert!(
        ended.contains("killed by signal 9") && ended.contains("again in 0.5 s (restart 1)"),
        "{ended}"
    );
    let (line, at) = line_with(&crew_log, "navigator started (pid ", at, minute);
    let second = pid_of(&line);
    assert_ne!(first, second);
    line_with(&crew_log, "waiting for goals", at, minute);

    // The crew, with its Navigator started again, carries a run out; its
    // Navigator killed again in the middle of a goal, the one started
    // after it takes the goal up and the run arrives.
    let planner = rome_tests::joined_to(
        port,
        &["planner", "--robot", "r1", "--from", "350R", "--to", "356R"],
    );
    let run = std::process::Command::new(ROME)
        .args(&planner)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let get = rome_tests::joined_to(port, &["data", "get", "nav/r1/GoalActive"]);
    let deadline = Instant::now() + minute;
    loop {
        let out = std::process::Command::new(ROME)
            .args(&get)
            .output()
            .unwrap();
        let value = String::from_utf8_lossy(&out.stdout);
        if out.status.success() && value.contains("goal") {
            break;
        }
        assert!(Instant::now() < deadline, "the Navigator never took a goal");
    }
    signal(second, "KILL");
    let (line, at) = line_with(&crew_log, "navigator started (pid ", at, minute);
    let third = pid_of(&line);
    // Arriving is the proof: a Navigator that did not take the goal up
    // would leave the Planner waiting until it gave the run up.
    let out = run.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
        rome_tests::tail_logs(&dir, 20)
    );
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(said.contains("from 356R"), "{said}");

    // SIGTERM: the crew stops every member and ends.
    let crew_pid = crew.0.as_ref().unwrap().id();
    signal(crew_pid, "TERM");
    let deadline = Instant::now() + minute;
    let status = loop {
        if let Some(s) = crew.0.as_mut().unwrap().try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < deadline, "the crew did not end");
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(status.success(), "{status:?}");
    line_with(&crew_log, "crew r1: stopped", at, minute);
    assert!(!running(third), "the Navigator outlived its crew");
}

#[test]
fn a_verbose_crew_makes_its_members_verbose() {
    // The Navigator says at info level that it took a goal: seen in the
    // crew's output with `-v`, not without (the default is warnings).
    let dir = rome_tests::TestDir::new("crew-verbose");
    let (port, _world) = world(dir.path());
    for verbose in [false, true] {
        let log = dir.path().join(format!("crew-{verbose}.log"));
        let mut args = rome_tests::joined_to(
            port,
            &[
                "crew",
                "--robot",
                "r1",
                "--no-plfinder",
                "--no-mapper",
                "--from",
                "350R",
                "--to",
                "376L",
            ],
        );
        if verbose {
            args.push("-v".into());
        }
        let mut crew = spawn_crew(&args, &log);
        let minute = Duration::from_secs(60);
        // The Planner prints its plan once the goal is on its way; the
        // Navigator's log line about it comes at once after.
        line_with(&log, "[planner] [goal 1/", 0, minute);
        if verbose {
            line_with(&log, "navigator: goal", 0, minute);
        }
        crew.kill();
        let text = std::fs::read_to_string(&log).unwrap();
        assert_eq!(
            text.contains("navigator: goal"),
            verbose,
            "with -v {verbose}:\n{text}"
        );
    }
}
