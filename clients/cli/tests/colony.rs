//! The colony-style running example (§4.8.2, docs/colony.md): wander,
//! avoid and escape, each `rome colony behave` in a process of its own,
//! drive one simulated base at the priorities the network
//! `wander_avoid_escape` gives them, meeting only through the base server.
//!
//! Robot r1's modules send `suppress_ms`; robot r2's, in the same world,
//! send `--suppress-ms 0`, the control: there the same check must find
//! lower modules' commands carried out in the middle of a higher module's
//! stream, or the check could not fail.

#![allow(clippy::unwrap_used)]

use rome_tests::ChildGuard;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

const ROME: &str = env!("CARGO_BIN_EXE_rome");
/// The suppression r1's modules ask for, ms.
const SUPPRESS_MS: u128 = 400;
/// How far apart two processes' readings of the simulated clock may be,
/// ms (a few 10 ms steps): a lower module's command answered `done`
/// between SLACK and SUPPRESS_MS − SLACK after a higher module's was
/// carried out inside its claim.
const SLACK: u128 = 50;
/// How long the modules run, simulated s.
const RUN_S: &str = "120";

#[derive(Debug, Clone, serde::Deserialize)]
struct Sent {
    t_ms: u128,
    module: String,
    priority: u8,
    command: String,
    outcome: String,
}

/// `rome ARGS…` as a client of the server on `port`, its standard output
/// into `out` and its standard error into `err`.
fn client(port: u16, out: &Path, err: &Path, args: &[&str]) -> ChildGuard {
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut all = vec!["--no-multicast", "--mode", "client", "--connect", &endpoint];
    all.extend_from_slice(args);
    let child = Command::new(ROME)
        .args(all)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(out).unwrap())
        .stderr(std::fs::File::create(err).unwrap())
        .spawn()
        .unwrap();
    ChildGuard(Some(child))
}

fn behave(port: u16, dir: &Path, robot: &str, module: &str, suppress: u128) -> ChildGuard {
    let suppress = suppress.to_string();
    client(
        port,
        &dir.join(format!("{robot}-{module}.jsonl")),
        &dir.join(format!("{robot}-{module}.log")),
        &[
            "--sim-time",
            "colony",
            "behave",
            "wander_avoid_escape",
            module,
            "--robot",
            robot,
            "--suppress-ms",
            &suppress,
            "--for-s",
            RUN_S,
        ],
    )
}

fn read(dir: &Path, robot: &str) -> Vec<Sent> {
    let mut all = Vec::new();
    for m in ["wander", "avoid", "escape"] {
        let text = std::fs::read_to_string(dir.join(format!("{robot}-{m}.jsonl"))).unwrap();
        all.extend(
            text.lines()
                .map(|l| serde_json::from_str::<Sent>(l).unwrap_or_else(|e| panic!("{e}: {l}"))),
        );
    }
    all.sort_by_key(|s| s.t_ms);
    all
}

/// Lower modules' commands carried out inside a higher module's claim:
/// (higher, lower, the lower's command, ms after).
fn breaches(sent: &[Sent]) -> Vec<(String, String, String, u128)> {
    let mut out = Vec::new();
    for h in sent.iter().filter(|s| s.outcome == "done") {
        for l in sent.iter().filter(|l| {
            l.outcome == "done"
                && l.priority < h.priority
                && l.t_ms > h.t_ms + SLACK
                && l.t_ms < h.t_ms + SUPPRESS_MS - SLACK
        }) {
            out.push((
                h.module.clone(),
                l.module.clone(),
                l.command.clone(),
                l.t_ms - h.t_ms,
            ));
        }
    }
    out
}

fn count(sent: &[Sent], module: &str, outcome: &str) -> usize {
    sent.iter()
        .filter(|s| s.module == module && s.outcome == outcome)
        .count()
}

#[test]
fn the_higher_behaviour_is_carried_out_while_it_applies_and_the_lower_resume() {
    let d = rome_tests::TestDir::new("rome-colony-test");
    let sim_log = d.join("sim.log");
    let _sim = rome_tests::spawn_logged(
        ROME,
        &[
            "--no-multicast",
            "--listen",
            "tcp/127.0.0.1:0",
            "sim",
            "--map",
            "fig5_3",
            "--robots",
            "2",
            "--lockstep",
            "--parties",
            "6",
        ],
        &sim_log,
    );
    let port = rome_tests::listening_port(&sim_log, Duration::from_secs(60));
    let mut procs = Vec::new();
    for m in ["wander", "avoid", "escape"] {
        procs.push(behave(port, &d, "r1", m, SUPPRESS_MS));
        procs.push(behave(port, &d, "r2", m, 0));
    }
    for p in &mut procs {
        let status = p.0.as_mut().unwrap().wait().unwrap();
        assert!(status.success(), "{}", rome_tests::tail_logs(&d, 8));
    }
    let r1 = read(&d, "r1");
    let logs = || rome_tests::tail_logs(&d, 8);
    for m in ["wander", "avoid", "escape"] {
        assert!(
            count(&r1, m, "done") > 0,
            "{m} never had a command carried out on r1\n{}",
            logs()
        );
    }
    let refused = count(&r1, "wander", "suppressed") + count(&r1, "avoid", "suppressed");
    assert!(refused > 0, "nothing was suppressed on r1\n{}", logs());
    assert_eq!(
        count(&r1, "escape", "suppressed"),
        0,
        "the highest module is never suppressed"
    );
    let errors: Vec<_> = r1
        .iter()
        .filter(|s| s.outcome.starts_with("error"))
        .collect();
    assert!(errors.is_empty(), "{errors:?}");
    let b = breaches(&r1);
    assert!(
        b.is_empty(),
        "{} lower commands carried out inside a claim, first: {:?}",
        b.len(),
        &b[..b.len().min(8)]
    );
    // The lower ones resume: wherever every higher claim ran out with no
    // new one for a while, wander drives again within a period or two.
    let higher: Vec<u128> = r1
        .iter()
        .filter(|s| s.module != "wander" && s.outcome == "done")
        .map(|s| s.t_ms)
        .collect();
    let wander: Vec<u128> = r1
        .iter()
        .filter(|s| s.module == "wander" && s.outcome == "done")
        .map(|s| s.t_ms)
        .collect();
    let end = r1.last().unwrap().t_ms;
    const WITHIN: u128 = 300;
    let lapses: Vec<u128> = higher
        .iter()
        .map(|&h| h + SUPPRESS_MS)
        .filter(|&e| {
            e + WITHIN < end
                && !higher
                    .iter()
                    .any(|&h| h > e - SUPPRESS_MS && h <= e + WITHIN)
        })
        .collect();
    assert!(
        lapses.len() >= 3,
        "too few higher episodes ended: {lapses:?}"
    );
    for e in &lapses {
        assert!(
            wander.iter().any(|&w| w + SLACK >= *e && w <= e + WITHIN),
            "wander did not resume within {WITHIN} ms of the claim running out at {e} ms"
        );
    }
    // The control: without suppression the wires are not honoured.
    let r2 = read(&d, "r2");
    assert_eq!(r2.iter().filter(|s| s.outcome == "suppressed").count(), 0);
    assert!(
        !breaches(&r2).is_empty(),
        "without suppress_ms the check found nothing: it could not fail"
    );
}

/// A `rome` server listening on a port of the system's choosing, and
/// that port.
fn server(dir: &Path, name: &str, args: &[&str]) -> (ChildGuard, u16) {
    let log = dir.join(format!("{name}.log"));
    let child = rome_tests::spawn_logged(ROME, args, &log);
    (
        child,
        rome_tests::listening_port(&log, Duration::from_secs(60)),
    )
}

/// §4.8.1: the upper layer hands legs down and the lower layer drives them,
/// two processes that share only the data server's variables and
/// semaphores; the robot goes out and back, judged by ground truth.
#[test]
fn two_layers_talking_only_through_the_data_server_drive_out_and_back() {
    let d = rome_tests::TestDir::new("rome-colony-layers");
    let (_ds, port) = server(&d, "data-server", &rome_tests::DATA_SERVER);
    let _sim = rome_tests::spawn_logged(
        ROME,
        &rome_tests::joined_to(port, &["sim", "--map", "fig5_3", "--speed", "4"]),
        &d.join("sim.log"),
    );
    let layer = |which: &str| {
        client(
            port,
            &d.join(format!("{which}.out")),
            &d.join(format!("{which}.log")),
            &[
                "colony",
                "layer",
                which,
                "--sides",
                "2",
                "--side-mm",
                "2000",
            ],
        )
    };
    // The lower layer starts first; the upper one once the robot is up,
    // so that ground truth has the start.
    let mut lower = layer("lower");
    let deadline = std::time::Instant::now() + Duration::from_secs(60);
    while !std::fs::read_to_string(d.join("lower.log"))
        .unwrap_or_default()
        .contains("waiting for legs")
    {
        assert!(
            std::time::Instant::now() < deadline,
            "the lower layer never reached the base\n{}",
            rome_tests::tail_logs(&d, 8)
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let mut upper = layer("upper");
    for (name, p) in [("upper", &mut upper), ("lower", &mut lower)] {
        let status = p.0.as_mut().unwrap().wait().unwrap();
        assert!(
            status.success(),
            "{name} failed\n{}",
            rome_tests::tail_logs(&d, 8)
        );
    }
    let out = std::fs::read_to_string(d.join("upper.out")).unwrap();
    assert_eq!(
        out.matches(" done: the lower layer reports").count(),
        2,
        "{out}"
    );
    let last = out.lines().rfind(|l| l.starts_with("done:")).unwrap();
    // "done: 2 legs; ground truth puts r1 29 mm from where it started, after 4005 mm driven"
    let numbers: Vec<f64> = last
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    let [_, off, driven] = numbers[..] else {
        panic!("no figures in {last}")
    };
    assert!(off < 300.0, "ended {off} mm from the start: {last}");
    assert!(
        (driven - 4_000.0).abs() < 400.0,
        "drove {driven} mm: {last}"
    );
}
