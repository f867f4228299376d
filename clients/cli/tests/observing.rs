//! docs/observing.md, run as written: every `sh` block of a section, and
//! its `python` blocks, in one shell script inside a network namespace of
//! the test's own (so the default ports 7447 and 8000 are free and nothing
//! leaves the machine), with `rome`, `curl`, Python's `eclipse-zenoh`,
//! `zenoh-cli` and `mcap` on the PATH. Then what each block printed is
//! checked: none of it is the project's code but `rome` itself.
//!
//! Needs root (`ip netns`) and network access to PyPI the first time (the
//! virtual environment is kept under the target directory); `cargo test
//! --workspace` lists it as ignored and CI runs it with `--ignored`.

#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

const ROME: &str = env!("CARGO_BIN_EXE_rome");
const PY_PACKAGES: &[&str] = &["eclipse-zenoh==1.10.2", "zenoh-cli==0.7.0", "mcap==1.6.0"];

#[derive(Debug)]
enum Block {
    Sh(String),
    Python(String),
}

/// The runnable blocks of each `## ` section.
fn sections(doc: &str) -> Vec<(String, Vec<Block>)> {
    let mut out: Vec<(String, Vec<Block>)> = Vec::new();
    let mut fence: Option<(String, String)> = None;
    for line in doc.lines() {
        if let Some((info, body)) = &mut fence {
            if line.trim_end() == "```" {
                let block = match info.as_str() {
                    "sh" => Some(Block::Sh(body.clone())),
                    "python" => Some(Block::Python(body.clone())),
                    _ => None,
                };
                if let (Some(b), Some(last)) = (block, out.last_mut()) {
                    last.1.push(b);
                }
                fence = None;
            } else {
                body.push_str(line);
                body.push('\n');
            }
        } else if let Some(info) = line.strip_prefix("```") {
            fence = Some((info.trim().to_string(), String::new()));
        } else if let Some(title) = line.strip_prefix("## ") {
            out.push((title.to_string(), Vec::new()));
        }
    }
    out.retain(|(_, b)| !b.is_empty());
    out
}

fn venv() -> PathBuf {
    rome_tests::python_venv(
        &Path::new(env!("CARGO_TARGET_TMPDIR")).join("py-observing"),
        PY_PACKAGES,
        "import zenoh, mcap, zenoh_cli",
    )
}

/// Runs one section's blocks in a fresh namespace; returns each block's
/// output (stdout and stderr together).
fn run_section(n: usize, blocks: &[Block], venv: &Path) -> Vec<String> {
    let dir = std::env::temp_dir().join(format!("rome-observing-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("deploy/secure")).unwrap();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../deploy/secure/router.json5"),
        dir.join("deploy/secure/router.json5"),
    )
    .unwrap();
    let mut script = String::from(
        "set -e\nstop() { kill $(jobs -p) 2>/dev/null || true; wait 2>/dev/null || true; }\ntrap stop EXIT\n",
    );
    for (i, b) in blocks.iter().enumerate() {
        script.push_str(&format!("echo '@@block {i}'\n"));
        match b {
            Block::Sh(text) => script.push_str(text),
            Block::Python(text) => {
                let file = dir.join(format!("block{i}.py"));
                std::fs::write(&file, text).unwrap();
                script.push_str(&format!("python3 {}\n", file.display()));
            }
        }
    }
    script.push_str("echo '@@end'\n");
    std::fs::write(dir.join("run.sh"), &script).unwrap();
    let ns = format!("rome-doc-{}-{n}", std::process::id());
    let ip = |args: &[&str]| {
        let s = Command::new("ip").args(args).status();
        assert!(
            s.is_ok_and(|s| s.success()),
            "ip {args:?} failed (this test needs root and iproute2)"
        );
    };
    ip(&["netns", "add", &ns]);
    ip(&["netns", "exec", &ns, "ip", "link", "set", "lo", "up"]);
    let bin = Path::new(ROME).parent().unwrap();
    let path = format!(
        "{}:{}:{}",
        venv.join("bin").display(),
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = Command::new("ip")
        .args(["netns", "exec", &ns, "timeout", "180", "bash", "run.sh"])
        .current_dir(&dir)
        .env("PATH", path)
        .env("HOME", &dir)
        .env_remove("ROME_CONNECT")
        .output()
        .unwrap();
    let _ = Command::new("ip").args(["netns", "del", &ns]).status();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.status.success() && text.contains("@@end"),
        "section {n} failed ({:?}):\n{script}\n---\n{text}",
        out.status
    );
    let _ = std::fs::remove_dir_all(&dir);
    // stdout only, split by the markers; stderr (progress, logs) was shown
    // above on failure.
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    stdout
        .split("@@block ")
        .skip(1)
        .map(|s| {
            s.split_once('\n')
                .map_or("", |(_, rest)| rest)
                .replace("@@end\n", "")
        })
        .collect()
}

/// The output of the block whose text contains `marker`.
fn output<'a>(blocks: &[Block], outputs: &'a [String], marker: &str) -> &'a str {
    let i = blocks
        .iter()
        .position(|b| match b {
            Block::Sh(t) | Block::Python(t) => t.contains(marker),
        })
        .unwrap_or_else(|| panic!("no block of docs/observing.md has '{marker}'"));
    &outputs[i]
}

#[test]
#[ignore = "needs root for network namespaces and PyPI for the Python packages; CI runs it with --ignored"]
fn every_command_of_docs_observing_md_works_as_written() {
    let doc = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/observing.md"),
    )
    .unwrap();
    let sections = sections(&doc);
    let titles: Vec<&str> = sections.iter().map(|(t, _)| t.as_str()).collect();
    assert_eq!(
        titles,
        [
            "A fleet, a router and its REST plugin",
            "An observer's REST, behind access control",
            "Recording and replaying: MCAP"
        ]
    );
    let venv = venv();
    let all: Vec<Vec<String>> = sections
        .iter()
        .enumerate()
        .map(|(n, (_, blocks))| run_section(n, blocks, &venv))
        .collect();

    // The fleet.
    let (b, o) = (&sections[0].1, &all[0]);
    let poses = output(b, o, "echo --get 'rome/robot/*/base/pose'");
    let mut keys: Vec<String> = poses
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["key"].to_string())
        .collect();
    keys.sort();
    assert_eq!(
        keys,
        [
            "\"rome/robot/r1/base/pose\"",
            "\"rome/robot/r2/base/pose\"",
            "\"rome/robot/r3/base/pose\""
        ]
    );
    let stop = output(b, o, "base/stop'");
    assert_eq!(stop.matches("code: wildcard").count(), 3, "{stop}");
    assert!(stop.contains("refused, as it should be"), "{stop}");
    let echo = output(b, o, "--hz");
    for want in [
        "PUT    rome/robot/r1/base/state",
        "RATE Hz",
        "rome/robot/r1/proximity/scan",
        "ROBOT",
        "camera/up",
    ] {
        assert!(echo.contains(want), "'{want}' missing:\n{echo}");
    }
    let curl = output(b, o, "text/event-stream");
    assert!(
        curl.contains(r#"{"key":"rome/data/var/Speed","value":300"#),
        "{curl}"
    );
    for r in ["r1", "r2", "r3"] {
        assert!(
            curl.contains(&format!(r#""key":"rome/robot/{r}/base/pose""#)),
            "{curl}"
        );
    }
    assert!(
        curl.contains("event: PUT\ndata: {\"key\":\"rome/robot/r1/base/state\""),
        "{curl}"
    );
    let py = output(b, o, "import zenoh");
    for r in ["r1", "r2", "r3"] {
        assert!(py.contains(&format!("rome/robot/{r}/base/pose ")), "{py}");
    }
    assert!(py.contains("Speed 300"), "{py}");
    let cli = output(b, o, "zenoh --mode client");
    assert_eq!(cli.matches("/base/pose {").count(), 3, "{cli}");
    assert!(cli.contains("rome/data/var/Speed 300"), "{cli}");

    // The observer's gateway.
    let (b, o) = (&sections[1].1, &all[1]);
    let gw = output(b, o, "--rest-read-only");
    let lines: Vec<&str> = gw.lines().collect();
    assert_eq!(lines.len(), 6, "{gw}");
    assert_eq!(
        lines[0], "Speed = 300 (seq 1)",
        "the operator's write: {gw}"
    );
    assert!(
        lines[1].contains(r#""key":"rome/robot/r1/base/pose""#),
        "{gw}"
    );
    assert!(lines[2].contains(r#""value":300"#), "{gw}");
    assert!(
        lines[3].contains(r#""code":"read_only""#) && lines[3].ends_with("HTTP 403"),
        "{gw}"
    );
    assert!(
        lines[4].contains(r#""value":300"#),
        "the PUT changed the value: {gw}"
    );
    assert_eq!(lines[5], "[]", "an observer's stop was answered: {gw}");

    // The recording, read by another implementation of MCAP.
    let (b, o) = (&sections[2].1, &all[2]);
    let rec = output(b, o, "rome record");
    for want in [
        "rome/robot/r1/base/state json rome.BaseState",
        "rome/robot/r1/proximity/scan json rome.Scan",
        "rome/sim/r1/truth json rome.Truth",
    ] {
        assert!(rec.contains(want), "'{want}' missing:\n{rec}");
    }
}
