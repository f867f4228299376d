//! Tests of `navigator`.

use super::*;

fn hallway_scan(left: u32, right: u32) -> Vec<u32> {
    // A robot on a hallway's axis: side sonars see the walls, the
    // rest look down the hallway.
    let mut s = vec![10_000u32; 24];
    for i in [5, 6, 7] {
        s[i] = right;
    }
    for i in [17, 18, 19] {
        s[i] = left;
    }
    s
}

#[test]
fn sonar_numbering_wraps_modulo_24() {
    assert_eq!(sonar_add(23, 2), 1);
    assert_eq!(sonar_add(1, -3), 22);
    assert_eq!(sonar_towards(0.0), 12);
    assert_eq!(sonar_towards(90.0), 18);
    assert_eq!(sonar_towards(-90.0), 6);
    assert_eq!(sonar_towards(180.0), 0);
    assert_eq!(sonar_towards(-176.0), 0);
    assert_eq!(sonar_towards(-172.0), 1);
    assert_eq!(bearing(0), 180.0);
}

#[test]
fn the_open_direction_is_searched_in_m_minus_2_to_m_plus_2() {
    let mut s = vec![1_000u32; 24];
    s[14] = 9_000; // 30° left: inside the window around 12
    s[20] = 10_000; // outside it
    assert_eq!(open_sonar(&s, 0.0, 0.0, 2), 14);
    // Heading 45° right of the axis: M is sonar 15; 14 is still inside.
    assert_eq!(open_sonar(&s, -45.0, 0.0, 2), 14);
    // The window wraps: the axis behind the robot.
    let mut s = vec![1_000u32; 24];
    s[23] = 9_000;
    assert_eq!(open_sonar(&s, 180.0, 0.0, 2), 23);
    // Corner state: a narrower window misses sonar 14.
    let mut s = vec![1_000u32; 24];
    s[14] = 9_000;
    assert_eq!(open_sonar(&s, 0.0, 0.0, 1), 12);
}

#[test]
fn center_hallway_jogs_at_four_degrees_per_second_toward_the_open_direction() {
    let cfg = NavConfig::default();
    let mut h = Hallway::new(0);
    // Centred, heading 10° right of the axis: jog left (CCW) at 4°/s.
    let s = hallway_scan(1_400, 1_400);
    assert_eq!(h.step(&cfg, &s, -10.0, 0.0, 0.0, 100), Drive::Jog(4.0));
    assert_eq!(h.step(&cfg, &s, 10.0, 0.0, 0.0, 200), Drive::Jog(-4.0));
    assert_eq!(
        h.step(&cfg, &s, 0.0, 0.0, 0.0, 300),
        Drive::Go(cfg.cruise_mm_s)
    );
}

#[test]
fn below_the_safe_threshold_it_turns_in_place_and_slows_by_a_quarter() {
    let cfg = NavConfig::default();
    let mut h = Hallway::new(0);
    let mut s = hallway_scan(1_400, 1_400);
    // A wall closing in at sonar 16 (60° left): turn right so the
    // closed direction lies on sonar 18.
    s[16] = 600;
    match h.step(&cfg, &s, 0.0, 0.0, 0.0, 1_000) {
        Drive::Turn(d) => assert!((d + 30.0).abs() < 1e-9, "{d}"),
        other => panic!("expected an in-place turn, got {other:?}"),
    }
    let s = hallway_scan(1_400, 1_400);
    assert_eq!(
        h.step(&cfg, &s, 0.0, 0.0, 0.0, 2_000),
        Drive::Go(cfg.cruise_mm_s * 0.75)
    );
}

#[test]
fn the_safe_threshold_halves_after_many_turns_and_grows_when_calm() {
    let cfg = NavConfig::default();
    let mut h = Hallway::new(0);
    let mut s = hallway_scan(1_400, 1_400);
    s[16] = 900;
    for t in 0..3 {
        let _ = h.step(&cfg, &s, 0.0, 0.0, 0.0, 1_000 * t);
    }
    let calm = hallway_scan(1_400, 1_400);
    let _ = h.step(&cfg, &calm, 0.0, 0.0, 0.0, 3_000);
    assert_eq!(h.safe_mm, 500.0);
    let _ = h.step(&cfg, &calm, 0.0, 0.0, 0.0, 3_000 + cfg.calm_ms);
    assert_eq!(h.safe_mm, 625.0);
    // Never above the starting 1 m.
    for k in 2..10 {
        let _ = h.step(&cfg, &calm, 0.0, 0.0, 0.0, 3_000 + k * cfg.calm_ms);
    }
    assert_eq!(h.safe_mm, SAFE_START_MM);
}

#[test]
fn off_centre_it_steers_back_toward_the_middle() {
    let cfg = NavConfig::default();
    // Driving parallel to the walls, 600 mm right of the middle: steer
    // left (counter-clockwise).
    let mut h = Hallway::new(0);
    let s = hallway_scan(2_060, 860);
    let mut last = Drive::Halt;
    for k in 0..20 {
        last = h.step(
            &cfg,
            &s,
            0.0,
            0.0,
            100.0 * f64::from(k),
            100 * u64::from(k as u32),
        );
    }
    assert_eq!(last, Drive::Jog(4.0));
    // In the middle but drifting left at 5°: steer right, whatever
    // odometry says about the heading.
    let mut h = Hallway::new(0);
    for k in 0..20 {
        let drift = 100.0 * f64::from(k) * 5f64.to_radians().tan();
        let s = hallway_scan((1_460.0 - drift) as u32, (1_460.0 + drift) as u32);
        last = h.step(
            &cfg,
            &s,
            0.0,
            0.0,
            100.0 * f64::from(k),
            100 * u64::from(k as u32),
        );
    }
    assert_eq!(last, Drive::Jog(-4.0));
}
