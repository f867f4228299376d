//! `rome view` against `rome demo --robots 2` in another process: the page
//! and its assets come from the binary, the event stream carries both
//! robots, a camera picture comes on demand, bad requests are named; and,
//! in headless Chromium, two screenshots a few seconds apart show the
//! robots in different places.

#![allow(clippy::unwrap_used)]

use rome_tests::ChildGuard;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

const ROME: &str = env!("CARGO_BIN_EXE_rome");

/// A two-robot demo that others can watch, and a view of it.
struct Watched {
    _demo: ChildGuard,
    _view: ChildGuard,
    web: u16,
    dir: std::path::PathBuf,
}

fn start(name: &str) -> Watched {
    let dir = std::env::temp_dir().join(format!("rome-view-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("demo.png");
    let (demo, port, _) = rome_tests::spawn_listening(
        ROME,
        &[
            "--no-multicast",
            "-l",
            "tcp/127.0.0.1:0",
            "demo",
            "--robots",
            "2",
            "--speed",
            "2",
            "-o",
            png.to_str().unwrap(),
        ],
    );
    let (view, web, _) = rome_tests::spawn_listening(
        ROME,
        &[
            "--no-multicast",
            "-e",
            &format!("tcp/127.0.0.1:{port}"),
            "view",
            "--port",
            "0",
        ],
    );
    Watched {
        _demo: demo,
        _view: view,
        web,
        dir,
    }
}

/// A plain HTTP/1.1 GET: status, head and body (chunks left in).
fn http(port: u16, path: &str) -> (u16, String, Vec<u8>) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).unwrap();
    let split = raw.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&raw[..split]).into_owned();
    let status = head.split_whitespace().nth(1).unwrap().parse().unwrap();
    (status, head, raw[split + 4..].to_vec())
}

/// Reads `/events` until `done` holds for the events seen, or panics.
fn events_until(
    port: u16,
    what: &str,
    done: impl Fn(&[serde_json::Value]) -> bool,
) -> Vec<serde_json::Value> {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    write!(s, "GET /events HTTP/1.1\r\nHost: localhost\r\n\r\n").unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    let (mut text, mut seen) = (String::new(), Vec::new());
    let mut buf = [0u8; 65536];
    while Instant::now() < deadline {
        let n = s.read(&mut buf).unwrap_or(0);
        text.push_str(&String::from_utf8_lossy(&buf[..n]));
        while let Some(end) = text.find('\n') {
            let line: String = text.drain(..=end).collect();
            if let Some(data) = line.trim_end().strip_prefix("data: ") {
                seen.push(serde_json::from_str(data).unwrap_or_else(|e| panic!("{e}: {data}")));
            }
        }
        if done(&seen) {
            return seen;
        }
    }
    panic!(
        "the event stream never showed {what}; {} events",
        seen.len()
    );
}

fn has(seen: &[serde_json::Value], kind: &str, robot: &str) -> bool {
    seen.iter().any(|e| e["k"] == kind && e["robot"] == robot)
}

#[test]
fn the_view_serves_its_page_the_fleet_live_and_cameras_on_demand() {
    let w = start("http");
    // The page and everything it loads come from the binary.
    let (code, head, page) = http(w.web, "/");
    assert_eq!(code, 200);
    assert!(head
        .to_ascii_lowercase()
        .contains("content-type: text/html"));
    let page = String::from_utf8(page).unwrap();
    assert!(
        page.contains("<canvas") && page.contains("/view.js"),
        "{page}"
    );
    for asset in ["/view.js", "/view.css"] {
        let (code, _, body) = http(w.web, asset);
        assert_eq!(code, 200, "{asset}");
        let body = String::from_utf8(body).unwrap();
        assert!(
            !body.contains("http://") && !body.contains("https://"),
            "{asset} loads from elsewhere"
        );
    }
    assert!(!page.contains("http://") && !page.contains("https://"));
    let (code, _, map) = http(w.web, "/map.json");
    assert_eq!(code, 200);
    let map: serde_json::Value = serde_json::from_slice(&map).unwrap();
    assert!(map["lines"].as_array().unwrap().len() > 100, "EB3's walls");

    // Both robots' poses, routes and blackboards arrive, and scans as
    // rays from where the robot is.
    let seen = events_until(
        w.web,
        "both robots' truth, state, route and navigator status",
        |seen| {
            ["r1", "r2"].iter().all(|r| {
                has(seen, "truth", r)
                    && has(seen, "state", r)
                    && has(seen, "route", r)
                    && has(seen, "scan", r)
                    && seen
                        .iter()
                        .any(|e| e["k"] == "board" && e["robot"] == *r && e["var"] == "Status")
            })
        },
    );
    let route = seen
        .iter()
        .find(|e| e["k"] == "route" && e["robot"] == "r1")
        .unwrap();
    assert_eq!(route["v"]["from"], "350R");
    assert_eq!(route["v"]["to"], "376L");
    let scan = seen.iter().find(|e| e["k"] == "scan").unwrap();
    assert_eq!(scan["rays"].as_array().unwrap().len(), 24);

    // A camera picture on demand, as PNG.
    let (code, head, png) = http(w.web, "/camera/r1/up");
    assert_eq!(code, 200, "{head}");
    assert!(
        png.starts_with(b"\x89PNG\r\n\x1a\n"),
        "not a PNG: {head} {:?}",
        String::from_utf8_lossy(&png[..png.len().min(200)])
    );
    // Names that are not names, and a robot nobody serves.
    let (code, _, body) = http(w.web, "/camera/r*/up");
    assert_eq!(code, 400);
    assert!(String::from_utf8_lossy(&body).contains("not a robot name"));
    let (code, _, body) = http(w.web, "/camera/r9/up");
    assert_eq!(code, 504);
    assert!(String::from_utf8_lossy(&body).contains("robot r9 camera up did not answer"));
    let _ = std::fs::remove_dir_all(&w.dir);
}

/// Chromium's screenshot of the page after `wait` seconds of live data.
fn screenshot(port: u16, out: &std::path::Path, wait: u32) -> image::RgbImage {
    let profile = out.with_extension("profile");
    let status = std::process::Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--window-size=1400,800",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--screenshot={}", out.display()))
        .arg(format!("http://127.0.0.1:{port}/?wait={wait}"))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .expect("chromium (Debian's package) is needed: apt-get install chromium");
    assert!(status.success());
    image::open(out).unwrap().to_rgb8()
}

/// Pixels of robot r1's colour (#1f6fd1) and r2's (#d1461f), near enough.
fn robot_pixels(img: &image::RgbImage, c: [u8; 3]) -> Vec<(u32, u32)> {
    img.enumerate_pixels()
        .filter(|(x, _, p)| {
            *x < 1060
                && p.0
                    .iter()
                    .zip(c)
                    .all(|(a, b)| (i32::from(*a) - i32::from(b)).abs() < 12)
        })
        .map(|(x, y, _)| (x, y))
        .collect()
}

#[test]
#[ignore = "needs Debian's chromium; CI installs it and runs this with --ignored"]
fn in_chromium_the_robots_move_between_two_screenshots() {
    let w = start("chromium");
    // Both robots are under way before the first picture.
    events_until(w.web, "both robots' truth", |seen| {
        has(seen, "truth", "r1") && has(seen, "truth", "r2")
    });
    let shots = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let a = screenshot(w.web, &shots.join("view-1.png"), 2);
    std::thread::sleep(Duration::from_secs(4));
    let b = screenshot(w.web, &shots.join("view-2.png"), 2);
    let centre = |px: &[(u32, u32)]| {
        let n = px.len().max(1) as f64;
        (
            px.iter().map(|p| f64::from(p.0)).sum::<f64>() / n,
            px.iter().map(|p| f64::from(p.1)).sum::<f64>() / n,
        )
    };
    for (robot, colour) in [("r1", [0x1f, 0x6f, 0xd1]), ("r2", [0xd1, 0x46, 0x1f])] {
        let (pa, pb) = (robot_pixels(&a, colour), robot_pixels(&b, colour));
        assert!(
            pa.len() > 50 && pb.len() > 50,
            "{robot} is not drawn: {} and {} pixels",
            pa.len(),
            pb.len()
        );
        // The trail grows and the robot moves: the drawing of this robot
        // is not where it was.
        let moved: usize = pb.iter().filter(|p| !pa.contains(p)).count();
        let (ca, cb) = (centre(&pa), centre(&pb));
        assert!(
            moved > 30,
            "{robot} drawn in the same place twice ({moved} new pixels; centres {ca:?} and {cb:?}); see {}",
            shots.display()
        );
    }
    let _ = std::fs::remove_dir_all(&w.dir);
}
