//! Record and replay: a demo run recorded in MCAP, played back into a
//! fresh network while another process records it again; both files hold
//! the same messages in the same order, at the same pace.

#![allow(clippy::unwrap_used)]

use rome_cli::cmd::observe::replay::{load, Message};
use std::process::{Command, Stdio};

const ROME: &str = env!("CARGO_BIN_EXE_rome");

fn dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("rome-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Offsets from the first message, seconds.
fn offsets(m: &[Message]) -> Vec<f64> {
    m.iter()
        .map(|x| (x.log_ns - m[0].log_ns) as f64 / 1e9)
        .collect()
}

#[test]
fn a_replayed_recording_is_the_same_messages_in_order_at_the_same_pace() {
    let d = dir("record");
    let original = d.join("run.mcap");
    let out = Command::new(ROME)
        .args(["demo", "--from", "A392L", "--to", "A340R", "--record"])
        .arg(&original)
        .arg("-o")
        .arg(d.join("run.png"))
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("recording: "), "{text}");
    let first = load(&original).unwrap();
    // The run as it was: the base's state stream, the Navigator's status
    // on the blackboard and the ground truth.
    for key in [
        "rome/robot/r1/base/state",
        "rome/data/watch/nav/r1/Status",
        "rome/sim/r1/truth",
    ] {
        assert!(first.iter().any(|m| m.key == key), "{key} not recorded");
    }
    assert!(first.len() > 500, "{} messages", first.len());

    // Played back into a network of two fresh processes.
    let copy = d.join("copy.mcap");
    let (mut recorder, port, _) = rome_tests::spawn_listening(
        ROME,
        &[
            "--mode",
            "peer",
            "--no-multicast",
            "-l",
            "tcp/127.0.0.1:0",
            "record",
            "-o",
            copy.to_str().unwrap(),
        ],
    );
    let played = Command::new(ROME)
        .args(["--no-multicast", "-e", &format!("tcp/127.0.0.1:{port}")])
        .arg("replay")
        .arg(&original)
        .args(["--wait-subscriber", "20"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(
        played.status.success(),
        "{}",
        String::from_utf8_lossy(&played.stderr)
    );
    // Stopped as a person would, with Ctrl-C: the file is finished.
    let pid = recorder.0.as_ref().unwrap().id();
    assert!(Command::new("kill")
        .args(["-INT", &pid.to_string()])
        .status()
        .unwrap()
        .success());
    let said = recorder.output();
    let second = load(&copy).unwrap_or_else(|e| panic!("{e:#}: {said}"));

    let keys = |m: &[Message]| -> Vec<(String, Vec<u8>, bool)> {
        m.iter()
            .map(|x| (x.key.clone(), x.data.clone(), x.delete))
            .collect()
    };
    assert_eq!(second.len(), first.len(), "{said}");
    assert!(
        keys(&second) == keys(&first),
        "other messages or another order"
    );
    assert!(second
        .iter()
        .zip(&first)
        .all(|(a, b)| a.encoding == b.encoding));
    // The pace: every message within 5 % of the run's length of its
    // original offset, and the whole as long within 5 %.
    let (a, b) = (offsets(&first), offsets(&second));
    let span = *a.last().unwrap();
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(
        worst <= 0.05 * span,
        "a message {worst:.3} s off its time in a {span:.1} s run"
    );
    assert!((b.last().unwrap() / span - 1.0).abs() <= 0.05);

    // Foxglove's own reader (TypeScript, as the Foxglove app uses) opens
    // the file: every channel, and every message.
    let foxglove = foxglove_read(&original);
    assert!(
        foxglove.contains(&format!("{} messages, every json one parsed", first.len())),
        "{foxglove}"
    );
    assert!(
        foxglove.contains("rome/robot/r1/base/state json rome.BaseState/jsonschema"),
        "{foxglove}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// What `tests/node/read_mcap.mjs` prints of `file`, with `@mcap/core`
/// and `@mcap/nodejs` installed from npm under the target directory the
/// first time.
fn foxglove_read(file: &std::path::Path) -> String {
    let here = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/node");
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("node-mcap");
    std::fs::create_dir_all(&dir).unwrap();
    for f in ["package.json", "read_mcap.mjs"] {
        std::fs::copy(here.join(f), dir.join(f)).unwrap();
    }
    if !dir.join("node_modules/@mcap/core").exists() {
        let npm = Command::new("npm")
            .args(["install", "--no-audit", "--no-fund", "--silent"])
            .current_dir(&dir)
            .status()
            .expect("npm (Node.js) is needed to check files with Foxglove's MCAP reader");
        assert!(npm.success(), "npm install of @mcap/core failed");
    }
    let out = Command::new("node")
        .arg("read_mcap.mjs")
        .arg(file)
        .current_dir(&dir)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

#[test]
fn replay_names_a_file_that_is_no_recording() {
    let d = dir("replay-bad");
    let bad = d.join("bad.mcap");
    std::fs::write(&bad, b"not an mcap file at all").unwrap();
    let out = Command::new(ROME)
        .args(["--no-multicast", "-e", "tcp/127.0.0.1:9", "replay"])
        .arg(&bad)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.mcap") && err.contains("not an MCAP file"),
        "{err}"
    );
    let out = Command::new(ROME)
        .args(["replay", "/nonexistent/run.mcap"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cannot read /nonexistent/run.mcap"), "{err}");
    let _ = std::fs::remove_dir_all(&d);
}
