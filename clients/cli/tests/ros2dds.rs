//! Real ROS 2 on DDS sees the fleet: an rclpy node (ROS 2 Jazzy, Fast DDS)
//! reaches two simulated robots through `rome router --ros2` (Zenoh's ROS
//! 2 DDS plugin, CycloneDDS) and `rome ros2`, with no ROS install beside
//! the fleet. It lists the bridged topics with their types, reads both
//! odometries, a 24-beam sonar scan and a camera image, and drives r1 on
//! `cmd_vel`: r1 moves by ground truth, r2 stays, and r1 stands still from
//! a second after the last command.
//!
//! Needs the `ros2dds` feature and rclpy from PyPI (made into a venv the
//! first time), so it is ignored by default; `.ci/run` runs it:
//! `cargo test -p rome-cli --features ros2dds --test ros2dds -- --ignored`.
//! DDS discovery stays on this host: both sides are told
//! `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (no multicast; localhost as
//! the only peer), in a ROS domain of the test's own.

#![cfg(feature = "ros2dds")]
#![allow(clippy::unwrap_used)]

mod common;

use common::*;
use std::path::Path;
use std::process::{Command, Stdio};

/// What the probe needs from PyPI.
const ROS_PACKAGES: &[&str] = &[
    "ros-jazzy-rclpy",
    "ros-jazzy-rmw-fastrtps-cpp",
    "ros-jazzy-nav-msgs",
    "ros-jazzy-sensor-msgs",
    "ros-jazzy-geometry-msgs",
];

/// The (x, y) a probe line holds at `path` (`truth_before.r1`, `odom.r1.0`).
fn xy(v: &serde_json::Value, path: &str) -> (f64, f64) {
    let mut at = v;
    for k in path.split('.') {
        at = match k.parse::<usize>() {
            Ok(i) => &at[i],
            Err(_) => &at[k],
        };
    }
    match (at[0].as_f64(), at[1].as_f64()) {
        (Some(x), Some(y)) => (x, y),
        _ => panic!("no position at {path}: {v}"),
    }
}

fn dist(a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - b.0).hypot(a.1 - b.1)
}

#[test]
#[ignore = "needs the ros2dds feature and rclpy from PyPI; .ci/run runs it"]
fn an_rclpy_node_on_dds_sees_the_fleet_and_drives_one_robot() {
    let venv = rome_tests::python_venv(
        &Path::new(env!("CARGO_TARGET_TMPDIR")).join("py-ros2"),
        ROS_PACKAGES,
        "import rclpy, nav_msgs.msg, sensor_msgs.msg, geometry_msgs.msg",
    );
    // The router holds the DDS plugin, in a ROS domain of this test's own.
    // The plugin reads the domain and the discovery range from the
    // environment, as ROS 2 nodes do.
    let domain = (20 + std::process::id() % 200).to_string();
    let first =
        std::env::temp_dir().join(format!("rome-ros2dds-router-{}.log", std::process::id()));
    let _router = rome_tests::ChildGuard(Some(
        Command::new(ROME)
            .args(rome_tests::ROUTER)
            .arg("--ros2")
            .env("ROS_DOMAIN_ID", &domain)
            .env("ROS_DISTRO", "jazzy")
            // The router then keeps CycloneDDS to loopback by itself.
            .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
            .env_remove("CYCLONEDDS_URI")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&first).unwrap())
            .spawn()
            .unwrap(),
    ));
    let port = rome_tests::listening_port(&first, std::time::Duration::from_secs(60));
    std::fs::rename(&first, log_dir(port).join("router.log")).unwrap();
    let _logs = rome_tests::TestDir::adopt(log_dir(port));
    let _sim = sim_with(port, "eb3", &["350R", "376L"], &["--speed", "1"]);
    let _bridge = client(port, "ros2", &["ros2", "--robots", "r1,r2"], Stdio::null());

    let probe = Command::new(venv.join("bin/python"))
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/ros2/probe.py"))
        .args(["--seconds", "90"])
        .env("ROS_DOMAIN_ID", &domain)
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&probe.stdout);
    let report = format!(
        "probe exit {:?}\n{stdout}\n{}\n{}",
        probe.status.code(),
        String::from_utf8_lossy(&probe.stderr),
        logs(port)
    );
    let line = stdout.lines().last().unwrap_or("");
    let v: serde_json::Value =
        serde_json::from_str(line).unwrap_or_else(|e| panic!("no JSON line ({e}):\n{report}"));
    assert_eq!(v["errors"], serde_json::json!([]), "{report}");

    // The graph lists the bridged topics with their ROS 2 types.
    for (topic, ty) in [
        ("/r1/odom", "nav_msgs/msg/Odometry"),
        ("/r2/odom", "nav_msgs/msg/Odometry"),
        ("/r1/sonar", "sensor_msgs/msg/LaserScan"),
        ("/r1/camera/up/image", "sensor_msgs/msg/Image"),
        ("/r1/cmd_vel", "geometry_msgs/msg/Twist"),
    ] {
        assert_eq!(
            v["graph"][topic],
            serde_json::json!([ty]),
            "{topic}\n{report}"
        );
    }
    // Both robots' odometry, a scan of the whole ring, an image of the
    // camera's size.
    for r in ["r1", "r2"] {
        assert_eq!(
            v["odom"][r].as_array().map(Vec::len),
            Some(2),
            "{r}\n{report}"
        );
    }
    assert_eq!(v["sonar_ranges"], 24, "{report}");
    let (w, h) = rome_schema::robot::body::IMAGE_SIZE;
    assert_eq!(v["image"]["width"], w, "{report}");
    assert_eq!(v["image"]["height"], h, "{report}");
    assert_eq!(v["image"]["bytes"], w * h, "{report}");

    // cmd_vel moved r1 (0.3 m/s asked for 2 s, from a standstill), not r2,
    // by ground truth; from a second after the last command r1 stood
    // still. (Ground truth comes twice a second, so the position "at" the
    // last command can be half a second old: the move is measured to a
    // second after it.)
    let moved = dist(xy(&v, "truth_before.r1"), xy(&v, "truth_1s_after.r1"));
    assert!(moved > 0.25, "r1 moved {moved:.2} m on cmd_vel\n{report}");
    let odom = dist(xy(&v, "odom.r1.0"), xy(&v, "odom_after.r1"));
    assert!(odom > 0.25, "r1's odometry moved {odom:.2} m\n{report}");
    let other = dist(xy(&v, "truth_before.r2"), xy(&v, "truth_2_5s_after.r2"));
    assert!(
        other < 0.01,
        "r2 moved {other:.3} m on r1's cmd_vel\n{report}"
    );
    let after = dist(xy(&v, "truth_1s_after.r1"), xy(&v, "truth_2_5s_after.r1"));
    assert!(
        after < 0.005,
        "r1 still moved {after:.3} m from 1 s to 2.5 s after its last cmd_vel\n{report}"
    );
}
