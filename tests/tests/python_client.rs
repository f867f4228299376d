//! A client in another language (Python's `eclipse-zenoh`), written from
//! docs/keys.md alone, against the data server.
//!
//! The package is installed from PyPI into a virtual environment under the
//! target directory the first time, so a fresh machine needs only Python 3.

#![allow(clippy::unwrap_used)]

use rome_tests::TestServer;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The version matching the Zenoh crates (1.10).
const PY_ZENOH: &str = "eclipse-zenoh==1.10.2";

/// The interpreter with `eclipse-zenoh`, set up once per test binary: the
/// tests run in parallel and two `python3 -m venv` on one directory collide.
fn python_with_zenoh() -> PathBuf {
    static PYTHON: OnceLock<PathBuf> = OnceLock::new();
    PYTHON.get_or_init(install_python_zenoh).clone()
}

fn install_python_zenoh() -> PathBuf {
    let venv = Path::new(env!("CARGO_TARGET_TMPDIR")).join("py-zenoh");
    rome_tests::python_venv(&venv, &[PY_ZENOH], "import zenoh").join("bin/python")
}

/// Runs `tests/python/<script> PORT`; it must pass every check.
async fn run_script(python: PathBuf, script: &str, port: u16) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("python")
        .join(script);
    let out = tokio::task::spawn_blocking(move || {
        Command::new(python)
            .arg(script)
            .arg(port.to_string())
            .output()
            .unwrap()
    })
    .await
    .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains(" 0 failed"), "{stdout}");
    assert!(!stdout.contains("FAIL"), "{stdout}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn python_client_from_docs_alone() {
    let python = tokio::task::spawn_blocking(python_with_zenoh)
        .await
        .unwrap();
    let server = TestServer::start().await;
    run_script(python, "keys_check.py", server.port).await;
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn python_client_drives_a_robot_from_docs_alone() {
    use rome_client::net::open_loopback_peer;
    let python = tokio::task::spawn_blocking(python_with_zenoh)
        .await
        .unwrap();
    let (session, port) = open_loopback_peer(&[]).await.unwrap();
    let world = rome_tests::world("fig5_3", rome_sim::SimConfig::default(), &[("r1", "301L")]);
    let _stepper = world.start(Some(1.0));
    let servers = rome_sim_hardware::robot::spawn_sim_robot(
        &session,
        &rome_schema::Root::default(),
        &world,
        "r1",
        rome_hardware::robot::Rates::default(),
    )
    .unwrap();
    // All four servers are up before the script asks anything.
    rome_tests::await_alive(&session, "rome/alive/server/robot/r1/**", 4).await;
    run_script(python, "robot_check.py", port).await;
    for s in servers {
        s.stop().await.unwrap();
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn python_adds_cancels_and_does_fleet_tasks_from_docs_alone() {
    let python = tokio::task::spawn_blocking(python_with_zenoh)
        .await
        .unwrap();
    let server = TestServer::start().await;
    let (dispatcher, _session) = rome_tests::eb3_dispatcher(&server).await;
    let running = tokio::spawn(async move { dispatcher.run(|_| {}).await });
    run_script(python, "tasks_check.py", server.port).await;
    assert!(
        !running.is_finished(),
        "the dispatcher stopped: {running:?}"
    );
    running.abort();
    server.stop().await;
}
