//! Navigation split into processes, as on robots and their wireless hosts:
//! `rome data-server`, `rome sim --robots 2`, and for each robot
//! `rome navigator`, `rome ctracker`, `rome mapper`, `rome plfinder` and
//! `rome planner --robot rK`, every one a process of its own, meeting only
//! through Zenoh on loopback. Both robots drive at once and must end within
//! a metre of their goals by ground truth, as the same run does in one
//! process; a robot whose clients are all killed inside a narrow
//! passage stops there and does not close the passage for the other; a
//! run whose durable data server is killed mid-route still arrives; and a
//! run in lock-step across processes (`rome sim --lockstep`, every other
//! process on `--sim-time`) is the same run as in one process, to the last
//! bit of every instant's ground truth, twice at once, even when one of
//! its processes starts later than a call may take.

#![allow(clippy::unwrap_used)]

mod common;

use common::*;
use rome_client::net::NetOptions;
use rome_tests::ChildGuard;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// `rome planner --robot ROBOT --from FROM --to TO` on `map`.
fn planner(port: u16, map: &str, route: (&str, &str, &str)) -> ChildGuard {
    planner_with(port, map, route, &[])
}

/// [`planner`], given the global flags `flags` (`--sim-time`).
fn planner_with(
    port: u16,
    map: &str,
    (robot, from, to): (&str, &str, &str),
    flags: &[&str],
) -> ChildGuard {
    client(
        port,
        &format!("planner-{robot}"),
        &flags
            .iter()
            .copied()
            .chain([
                "planner",
                "--robot",
                robot,
                "--map",
                map,
                "--from",
                from,
                "--to",
                to,
                "--timeout",
                "400",
            ])
            .collect::<Vec<_>>(),
        Stdio::piped(),
    )
}

/// Waits for a planner and checks its last line: within a metre of the
/// goal by ground truth, every goal done.
async fn arrived(port: u16, robot: &str, to: &str, mut p: ChildGuard) -> String {
    let out = tokio::task::spawn_blocking(move || p.try_output())
        .await
        .unwrap();
    let out = match out {
        Ok(out) => out,
        Err(e) => panic!("{robot}'s planner failed: {e}\n{}", logs(port)),
    };
    // Exit status 0 (checked by try_output()) means within a metre by
    // ground truth; the figure is read back as well.
    let miss = metres_from_goal(&out);
    assert!(miss < 1.0, "{robot} ended {miss} m from {to}\n{out}");
    assert!(out.contains("Run time"), "no Table 6.1 row:\n{out}");
    assert!(
        !out.contains("given up"),
        "{robot}'s run was given up:\n{out}"
    );
    out
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_robots_with_every_client_in_its_own_process_both_arrive() {
    let routes = [("r1", "302L", "A340R"), ("r2", "A302R", "A357L")];
    let (_data, port) = data_server();
    let _logs = rome_tests::TestDir::adopt(log_dir(port));
    let _sim = sim(port, "eb3", &[routes[0].1, routes[1].1]);
    let mut crew = Vec::new();
    for (robot, _, _) in routes {
        crew.extend(helpers(port, robot, "eb3"));
    }
    let session = NetOptions::loopback_client(port).open().await.unwrap();
    await_up(&session, port, 2).await;
    let planners: Vec<_> = routes.iter().map(|r| planner(port, "eb3", *r)).collect();
    for ((robot, _, to), p) in routes.into_iter().zip(planners) {
        arrived(port, robot, to, p).await;
    }
    // Each robot used its own blackboard: the goals of one never reached
    // the other (each Navigator took exactly its own plan's goals).
    let ds = rome_client::DataClient::connect(&session, rome_client::DataOptions::new("check"))
        .await
        .unwrap();
    for (robot, _, _) in routes {
        let status: serde_json::Value = ds.get(&format!("nav/{robot}/Status")).await.unwrap();
        assert_eq!(status["goal_type"], "D", "{robot}: {status}");
    }
    for mut h in crew {
        h.kill();
    }
    let _ = session.close().await;
}

/// EB3 with corridor N (x = 60 m, between rings B and C) tagged as the
/// narrow passage `N`, written to a file as a user would.
fn eb3_with_passage(port: u16) -> String {
    let map = rome_maps::load_named("eb3").unwrap();
    let mut lines: Vec<String> = rome_maps::builtin::EB3.lines().map(String::from).collect();
    let mut tagged = 0;
    for (ring, edge) in rome_tests::corridor_n_walls(&map) {
        let line = map.rings[ring].edges[edge].line;
        if !lines[line - 1].contains("passage=") {
            lines[line - 1].push_str(" passage=N");
            tagged += 1;
        }
    }
    assert!(tagged >= 2, "corridor N's walls: {tagged} edges");
    let path = log_dir(port).join("eb3-passage.stk");
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    path.display().to_string()
}

/// Inside corridor N, at least 4 m from either end.
fn deep_in_n(t: &rome_schema::sim::Truth) -> bool {
    (t.x_mm - 60_000.0).abs() < 1_300.0 && t.y_mm > 13_000.0 && t.y_mm < 49_000.0
}

/// Each line a planner prints, as it prints it, tagged with its index.
fn follow(k: usize, p: &mut ChildGuard, to: std::sync::mpsc::Sender<(usize, String)>) {
    use std::io::BufRead;
    let stdout = p.0.as_mut().unwrap().stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if to.send((k, line)).is_err() {
                break;
            }
        }
    });
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_whose_clients_are_killed_inside_a_narrow_passage_stops_and_frees_it() {
    // r1 southwards through corridor N, r2 northwards: N is too narrow to
    // pass, so they take turns. Whoever is deep inside N first has every
    // one of its client processes killed with SIGKILL there. The other must
    // then be let in: the data server gives the dead Planner's unit back.
    // (It then finds the dead robot in its way: a passage too narrow to
    // pass is blocked for real, which is for a person to clear.)
    let routes = [("r1", "303R", "A352L"), ("r2", "A353R", "301L")];
    let (_data, port) = data_server();
    let _logs = rome_tests::TestDir::adopt(log_dir(port));
    let map = eb3_with_passage(port);
    let _sim = sim(port, &map, &[routes[0].1, routes[1].1]);
    let mut crews: Vec<Vec<ChildGuard>> = routes
        .iter()
        .map(|(r, _, _)| helpers(port, r, &map))
        .collect();
    let session = NetOptions::loopback_client(port).open().await.unwrap();
    await_up(&session, port, 2).await;
    let root = rome_schema::Root::default();
    let truth: Vec<_> = routes
        .iter()
        .map(|(r, _, _)| rome_client::sim::TruthClient::new(&session, &root, r).unwrap())
        .collect();
    let ds = rome_client::DataClient::connect(&session, rome_client::DataOptions::new("check"))
        .await
        .unwrap();
    let (tx, lines) = std::sync::mpsc::channel();
    let mut planners: Vec<ChildGuard> = Vec::new();
    for (k, r) in routes.iter().enumerate() {
        let mut p = planner(port, &map, *r);
        follow(k, &mut p, tx.clone());
        planners.push(p);
    }
    let mut printed: Vec<Vec<String>> = vec![Vec::new(); routes.len()];
    let take_lines = |printed: &mut Vec<Vec<String>>| {
        while let Ok((k, line)) = lines.try_recv() {
            printed[k].push(line);
        }
    };

    let deadline = Instant::now() + Duration::from_secs(300);
    let (victim, at_kill) = loop {
        assert!(
            Instant::now() < deadline,
            "no robot got deep into corridor N: {printed:?}\n{}",
            logs(port)
        );
        let mut found = None;
        for (k, t) in truth.iter().enumerate() {
            if let Ok(t) = t.get().await {
                if deep_in_n(&t) {
                    found = Some((k, t));
                }
            }
        }
        if let Some(found) = found {
            break found;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    let held = ds.semaphore("$passage/N").await.unwrap();
    assert_eq!(
        (held.value, held.held),
        (0, 1),
        "{} is in N holding the passage",
        routes[victim].0
    );
    take_lines(&mut printed);
    let survivor = 1 - victim;
    let inside = |lines: &[String]| lines.iter().any(|l| l == "in the narrow passage N");
    assert!(
        inside(&printed[victim]) && !inside(&printed[survivor]),
        "{} should hold N alone: {printed:?}",
        routes[victim].0
    );
    // The whole crew at once, as a host losing power would.
    planners[victim].kill();
    for mut c in crews[victim].drain(..) {
        c.kill();
    }

    // The survivor is let in, and the dead robot stays where it died (the
    // base's deadman stopped it).
    let deadline = Instant::now() + Duration::from_secs(120);
    while !inside(&printed[survivor]) {
        assert!(
            Instant::now() < deadline,
            "{} was never let into N after {} died there: {:?}\n{}",
            routes[survivor].0,
            routes[victim].0,
            printed[survivor],
            logs(port)
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
        take_lines(&mut printed);
    }
    let after = truth[victim].get().await.unwrap();
    let drifted = after.travelled_mm - at_kill.travelled_mm;
    assert!(
        drifted < 1_000.0,
        "{} drove on {drifted:.0} mm after its clients died",
        routes[victim].0
    );
    assert!(deep_in_n(&after), "{after:?}");
    planners[survivor].kill();
    for mut c in crews[survivor].drain(..) {
        c.kill();
    }
    let _ = session.close().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_run_whose_data_server_is_killed_and_restarted_mid_route_still_arrives() {
    // Back at once, as a supervisor would start it.
    run_with_data_server_down_for(Duration::ZERO).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_run_whose_data_server_is_down_longer_than_a_call_may_take_still_arrives() {
    // Down for longer than a client's call is retried (10 s), so that calls
    // fail with "no reply" meanwhile: the Planner's wait for the Navigator
    // ends a two-second slice in the outage, and its cancel is unanswered.
    // The helpers run under `rome crew`, as deployed, which starts again
    // those that end on the outage; the Planner has to wait it out.
    run_with_data_server_down_for(Duration::from_secs(14)).await;
}

/// A run whose data server is killed well on the way and started again
/// after `down` of wall time (the outage is the fault, not a wait for an
/// event): the robot still arrives. For an outage, the helpers run under
/// `rome crew`.
async fn run_with_data_server_down_for(down: Duration) {
    // As deployed: a router in the middle, a durable data server beside it.
    let route = ("r1", "350R", "376L");
    let (_router, port) = server("router", &rome_tests::ROUTER);
    let _logs = rome_tests::TestDir::adopt(log_dir(port));
    let state = log_dir(port).join("state");
    let _ = std::fs::remove_dir_all(&state);
    let state = state.display().to_string();
    let data_args = ["data-server", "--data-dir", state.as_str()];
    let mut data = client(port, "data-server", &data_args, Stdio::null());
    let _sim = sim(port, "eb3", &[route.1]);
    let _crew = if down.is_zero() {
        helpers(port, route.0, "eb3")
    } else {
        let args = ["crew", "--robot", route.0, "--map", "eb3"];
        vec![client(port, "crew", &args, Stdio::null())]
    };
    let session = NetOptions::loopback_client(port).open().await.unwrap();
    await_up(&session, port, 1).await;
    let root = rome_schema::Root::default();
    let truth = rome_client::sim::TruthClient::new(&session, &root, route.0).unwrap();
    let planner = planner(port, "eb3", route);

    // Well on its way: killed, and back at once, as a supervisor would.
    let deadline = Instant::now() + Duration::from_secs(300);
    let at_kill = loop {
        assert!(
            Instant::now() < deadline,
            "r1 never got going\n{}",
            logs(port)
        );
        if let Ok(t) = truth.get().await {
            if t.travelled_mm > 6_000.0 {
                break t;
            }
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    data.kill();
    tokio::time::sleep(down).await;
    let _data = client(port, "data-server-again", &data_args, Stdio::null());

    arrived(port, route.0, route.2, planner).await;
    let end = truth.get().await.unwrap();
    assert!(
        at_kill.travelled_mm < 0.5 * end.travelled_mm,
        "the kill came late: {:.0} of {:.0} mm",
        at_kill.travelled_mm,
        end.travelled_mm
    );
    let _ = session.close().await;
}

/// A lock-step run of 302L → A340R split into seven processes: the data
/// server, the simulator (tracing every instant to `trace`), four helpers
/// and the planner, each on `--sim-time`, held at the start until all six
/// followers are in. Returns the planner's output once it has arrived.
/// With `late`, the ctracker starts only once the planner has said that a
/// request of its waits for its round: a party later than a call's
/// timeout, which the world and every request held for it wait for, so
/// the run is still the same.
async fn split_run(trace: &std::path::Path, late: bool) -> String {
    let (robot, from, to) = ("r1", "302L", "A340R");
    let (_data, port) = server(
        "data-server",
        &[
            "--no-multicast",
            "--listen",
            "tcp/127.0.0.1:0",
            "--sim-time",
            "data-server",
            "--in-memory",
        ],
    );
    let _logs = rome_tests::TestDir::adopt(log_dir(port));
    let trace = trace.to_str().expect("a UTF-8 path");
    let _sim = sim_with(
        port,
        "eb3",
        &[from],
        &["--lockstep", "--parties", "6", "--trace", trace],
    );
    let flags = ["--sim-time"];
    let first: Vec<&str> = HELPERS
        .into_iter()
        .filter(|&r| !late || r != "ctracker")
        .collect();
    let mut crew = helpers_of(port, (robot, "eb3"), &flags, &first);
    let planner = planner_with(port, "eb3", (robot, from, to), &flags);
    if late {
        let log = log_dir(port).join(format!("planner-{robot}.log"));
        // Held past a call's timeout: waiting on, or (were it not to wait
        // while the data server is there) given up.
        let said = [
            "a request waits for its round",
            "no reply from the data server",
        ];
        rome_tests::eventually(Duration::from_secs(120), said[0], || {
            let log = log.clone();
            async move {
                let log = std::fs::read_to_string(&log).unwrap_or_default();
                said.iter().any(|s| log.contains(s))
            }
        })
        .await;
        crew.extend(helpers_of(port, (robot, "eb3"), &flags, &["ctracker"]));
    }
    let out = arrived(port, robot, to, planner).await;
    for mut c in crew {
        c.kill();
    }
    out
}

/// Where two traces first part, as a message naming the instant's line
/// in each; `None` when one is the beginning of the other.
fn parting(a: &[u8], b: &[u8]) -> Option<String> {
    let (a, b) = (String::from_utf8_lossy(a), String::from_utf8_lossy(b));
    a.lines()
        .zip(b.lines())
        .enumerate()
        .find(|(_, (x, y))| x != y)
        .map(|(k, (x, y))| format!("line {}:\n  {x}\n  {y}", k + 1))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lockstep_run_split_into_processes_is_the_same_run_as_in_one_process() {
    // Two such runs at once, on one machine: their traces (every
    // instant's true pose and sonar ranges, each float to its last bit)
    // and the same route in one process must be the same bytes.
    let dir = rome_tests::TestDir::new("lockstep-split");
    let (a, b) = (dir.path().join("a.trace"), dir.path().join("b.trace"));
    // The second has a party that starts late (see `split_run`).
    let (out, _) = tokio::join!(split_run(&a, false), split_run(&b, true));
    let row = out
        .lines()
        .find(|l| l.contains("302L to A340R"))
        .unwrap_or_else(|| panic!("no table row:\n{out}"));
    assert_eq!(
        row.matches("1/1").count(),
        3,
        "every light, corner and door found:\n{out}"
    );
    // The same route in one process (`rome demo`, lock-step, no network).
    let one = dir.path().join("one.trace");
    let (one_path, png) = (one.clone(), dir.path().join("one-process.png"));
    let demo = tokio::task::spawn_blocking(move || {
        Command::new(ROME)
            .args(["demo", "--no-multicast", "--seed", SEED])
            .args(["--from", "302L", "--to", "A340R", "-o"])
            .arg(png)
            .arg("--trace")
            .arg(one_path)
            .output()
            .expect("rome demo runs")
    })
    .await
    .expect("rome demo ends");
    let one_out = String::from_utf8_lossy(&demo.stdout);
    assert!(demo.status.success(), "rome demo failed:\n{one_out}");
    let one_row = one_out
        .lines()
        .find(|l| l.contains("302L to A340R"))
        .unwrap_or_else(|| panic!("no table row from rome demo:\n{one_out}"));
    assert_eq!(
        row.split_whitespace().collect::<Vec<_>>(),
        one_row.split_whitespace().collect::<Vec<_>>(),
        "split into seven processes and in one, the run differs:\n{out}\n---\n{one_out}"
    );
    let [a, b, one] = [a, b, one].map(|p| std::fs::read(&p).unwrap());
    // The one-process run ends when its robot has arrived; the split runs'
    // simulators go on until they are stopped, a few instants later or
    // more. So the one-process trace is the beginning of each.
    let instants = one.iter().filter(|&&c| c == b'\n').count();
    assert!(instants > 9_000, "the run was {instants} instants long");
    for (name, split) in [("first", &a), ("second", &b)] {
        assert!(
            split.starts_with(&one),
            "the {name} split run parts from the one-process run at {}",
            parting(split, &one).unwrap_or_else(|| "its end: it is shorter".into())
        );
    }
    if let Some(at) = parting(&a, &b) {
        panic!("the two split runs part at {at}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_planner_between_floors_gives_up_at_its_timeout_and_stops_the_robot() {
    // No Navigator runs: the first goal is never done, and the Planner
    // gives the run up after --timeout seconds, with exit status 3.
    let (_data, port) = server(
        "data-server",
        &[
            "--no-multicast",
            "--listen",
            "tcp/127.0.0.1:0",
            "data-server",
            "--in-memory",
        ],
    );
    let _logs = rome_tests::TestDir::adopt(log_dir(port));
    let sim = rome_tests::joined_to(
        port,
        &[
            "sim",
            "--building",
            "tower",
            "--at",
            "3:350R",
            "--seed",
            SEED,
            "--speed",
            "4",
        ],
    );
    let sim: Vec<&str> = sim.iter().map(String::as_str).collect();
    let _sim = rome(port, "sim", &sim, Stdio::null());
    let args = [
        "planner",
        "--robot",
        "r1",
        "--building",
        "tower",
        "--from",
        "3:350R",
        "--to",
        "5:576L",
        "--timeout",
        "3",
    ];
    let mut planner = client(port, "planner", &args, Stdio::piped());
    let child = planner.0.take().unwrap();
    let out = tokio::task::spawn_blocking(move || child.wait_with_output().unwrap())
        .await
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let said = std::fs::read_to_string(log_dir(port).join("planner.log")).unwrap();
    assert_eq!(
        out.status.code(),
        Some(3),
        "{stdout}\n{said}\n{}",
        logs(port)
    );
    assert!(
        said.contains("gave up after 3 s; robot r1 stopped"),
        "{said}"
    );
    assert!(
        stdout.contains("[goal 1/"),
        "the first goal was handed:\n{stdout}"
    );
}
