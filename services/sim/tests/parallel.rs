//! Robots sensed on several threads read what they read on one, bit for
//! bit: every field of every robot (pose, odometry, sonar, infrared,
//! images, trail, its generator) after each second of a crowded run.

#![allow(clippy::unwrap_used)]

use rome_sim::{Mode, Sim, SimConfig};

/// 40 robots at EB3's first positions, driving on and turning away from
/// what is near: they meet walls and each other.
fn crowd(parallel_from: usize) -> Sim {
    let map = rome_maps::load_named("eb3").unwrap();
    let config = SimConfig {
        seed: 7,
        sonar_period_ms: 100,
        camera_period_ms: 1_000,
        ..SimConfig::default()
    };
    let mut sim = Sim::new(&map, config);
    sim.sense_in_parallel_from(parallel_from);
    let mut names: Vec<String> = sim.scene().world.positions.keys().cloned().collect();
    names.sort();
    // Two positions across a corridor share its spot: the second is
    // skipped.
    for name in &names {
        let k = sim.robots().len();
        if k == 40 {
            break;
        }
        let heading = if k.is_multiple_of(2) { 0.0 } else { 180.0 };
        if let Ok(i) = sim.add_robot_at(&format!("r{k}"), name, heading) {
            sim.robot_mut(i).drive.go(400.0).unwrap();
        }
    }
    assert_eq!(sim.robots().len(), 40);
    sim
}

/// Turns away from anything within a metre ahead.
fn steer(sim: &mut Sim) {
    for i in 0..sim.robots().len() {
        let r = sim.robot(i);
        let ahead = r.sonar[10..=14].iter().copied().min().unwrap_or(10_000);
        if ahead < 1_000 && !matches!(r.drive.mode, Mode::PointTurn { .. }) {
            sim.robot_mut(i).drive.turn(90.0, 60.0, 120.0).unwrap();
        }
    }
}

#[test]
fn robots_sensed_on_four_threads_read_what_they_read_on_one() {
    let mut one = crowd(usize::MAX);
    let mut many = crowd(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap();
    for second in 1..=10 {
        for _ in 0..2 {
            steer(&mut one);
            steer(&mut many);
            one.run_for(500);
            pool.install(|| many.run_for(500));
        }
        assert_eq!(
            format!("{:?}", one.robots()),
            format!("{:?}", many.robots()),
            "the robots differ after {second} s"
        );
    }
    let moved = one
        .robots()
        .iter()
        .filter(|r| r.travelled_mm > 1_000.0)
        .count();
    assert!(moved >= 30, "only {moved} of 40 robots drove a metre");
    assert!(one
        .robots()
        .iter()
        .all(|r| r.up.is_some() && r.side.is_some()));
}
