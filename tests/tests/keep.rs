//! A world's state written by `rome sim --state` and taken up by a fresh
//! world: every part a robot's servers report from goes on where it was
//! (true pose, odometry, motion controller, the sonar ring's last scan and
//! its time, the base's virtual frame, the world's time).

#![allow(clippy::unwrap_used)]

use rome_hardware::vxy::Pose32Target;
use rome_sim_hardware::keep;

#[test]
fn a_fresh_world_takes_up_everything_its_robots_report_from() {
    let old = rome_tests::world("eb3", rome_tests::quiet(), &[("r1", "350R")]);
    {
        let mut sim = old.lock();
        sim.robot_mut(0)
            .drive
            .move_by(3_000.0, 400.0, 300.0)
            .unwrap();
        sim.run_for(4_000);
    }
    rome_hardware::locked(&old.frame("r1")).set(
        90.0,
        Pose32Target {
            x_mm: 1_000.0,
            y_mm: -2_000.0,
            heading_deg: 45.0,
        },
    );
    let kept = keep::snapshot(&old);
    let dir = rome_tests::TestDir::new("rome-keep-test");
    let path = dir.join("world.json");
    keep::write(&path, &kept).unwrap();
    let read = keep::read(&path).unwrap().expect("the file is there");
    // JSON keeps every number to within a unit of its last place.
    let (x0, x1) = (kept.robots[0].truth.0, read.robots[0].truth.0);
    assert!((x0 - x1).abs() <= x0.abs() * 1e-15, "{x0} read as {x1}");
    assert_eq!(
        read.robots[0].drive.mode.name(),
        "point_go",
        "a move under way"
    );
    assert!(read.robots[0].scan.1 > 3_000, "the ring has fired");

    let new = rome_tests::world(
        "eb3",
        rome_tests::quiet(),
        &[("r1", "350R"), ("r9", "376L")],
    );
    assert_eq!(keep::restore(&new, &read), Vec::<String>::new());
    // The new world says what the file said, to the bit.
    let now = keep::snapshot(&new);
    assert_eq!(now.time_ms, read.time_ms);
    assert_eq!(now.robots[0], read.robots[0]);
    {
        let sim = new.lock();
        assert_eq!(sim.robot(0).sonar, sim.robot(0).scan);
    }
    // r9, not in the file, is left as placed.
    assert!(now.robots[1].travelled_mm == 0.0);
    // A robot the file does not name is left as placed; one the world
    // does not have is named.
    let mut other = read;
    other.robots[0].name = "r7".into();
    assert_eq!(keep::restore(&new, &other), vec!["r7".to_string()]);
}
