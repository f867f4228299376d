//! Tests of `navigator`.

use super::*;

/// What robot `robot` of the Campus senses at `pose`, `time_ms` into a
/// run, the simulator's sonar and infrared with no noise: the corners of
/// the Campus's fleet runs, put back for a test.
pub(super) fn campus_scan(robot: &str, time_ms: u64, pose: Pose) -> Scan {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../maps/data/campus.stk");
    let map = rome_maps::load(std::path::Path::new(path)).expect("the Campus");
    let config = rome_sim::SimConfig {
        noise: rome_sim::Noise::none(),
        ..rome_sim::SimConfig::default()
    };
    let mut sim = rome_sim::Sim::new(&map, config);
    let r = sim.add_robot(robot, pose).expect("placed");
    let seen = sim.robot(r);
    Scan {
        robot: robot.into(),
        seq: 0,
        time_ms,
        sonar_mm: seen.sonar.iter().map(|&v| u32::from(v)).collect(),
        ir: Scan::ir_slots(seen.infrared),
    }
}

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

/// A robot on a hallway's axis with a wall closing in at sonar 16 (60°
/// left), `mm` away.
fn closing_in_on_the_left(mm: u32) -> (NavConfig, Hallway, Vec<u32>) {
    let mut s = hallway_scan(1_400, 1_400);
    s[16] = mm;
    (NavConfig::default(), Hallway::new(0), s)
}

#[test]
fn below_the_safe_threshold_it_turns_in_place_and_slows_by_a_quarter() {
    // Turn right so the closed direction lies on sonar 18.
    let (cfg, mut h, s) = closing_in_on_the_left(600);
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
    let (cfg, mut h, s) = closing_in_on_the_left(900);
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
fn keeping_off_the_middle_a_robot_50_degrees_off_ahead_still_turns_it_away() {
    let cfg = NavConfig::default();
    let mut h = Hallway::new(0);
    // Off the middle, only 15° either side of ahead counts at the safe
    // threshold: a robot passed 0.8 m away at 45° is passed by.
    h.lane_mm = -600.0;
    let mut s = hallway_scan(1_400, 1_400);
    s[15] = 800;
    let passing = h.step(&cfg, &s, 0.0, 0.0, 0.0, 1_000);
    assert!(!matches!(passing, Drive::Turn(_)), "{passing:?}");
    // The same robot 0.25 m away would be grazed by the front quarter:
    // turn right, away from it.
    s[15] = 250;
    match h.step(&cfg, &s, 0.0, 0.0, 100.0, 1_100) {
        Drive::Turn(d) => assert!(d <= -5.0, "{d}"),
        other => panic!("expected a turn away to the right, got {other:?}"),
    }
}

/// Scan `k` of a robot driving straight at 1 m/s, scanning every 0.1 s.
fn driven_at(h: &mut Hallway, cfg: &NavConfig, s: &[u32], k: i32) -> Drive {
    let k = f64::from(k);
    h.step(cfg, s, 0.0, 0.0, 100.0 * k, (100.0 * k) as u64)
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
        last = driven_at(&mut h, &cfg, &s, k);
    }
    assert_eq!(last, Drive::Jog(4.0));
    // In the middle but drifting left at 5°: steer right, whatever
    // odometry says about the heading.
    let mut h = Hallway::new(0);
    for k in 0..20 {
        let drift = 100.0 * f64::from(k) * 5f64.to_radians().tan();
        let s = hallway_scan((1_460.0 - drift) as u32, (1_460.0 + drift) as u32);
        last = driven_at(&mut h, &cfg, &s, k);
    }
    assert_eq!(last, Drive::Jog(-4.0));
}

/// What the ring reads between the walls of a corridor `width_mm` wide,
/// the robot's middle `left_mm` left of the corridor's middle and heading
/// `rel_deg` from its axis: the specular model's readings (a wall echoes
/// only within 20° of square, from the beam's nearest point on it, the
/// beam 7.5° either side), nothing else in view.
fn slanted_scan(width_mm: f64, left_mm: f64, rel_deg: f64) -> Vec<u32> {
    (0..24)
        .map(|i| {
            let dir = rel_deg + bearing(i);
            // Each wall: its normal's direction from the axis, and how far
            // it stands from the robot's middle.
            [
                (90.0, width_mm / 2.0 - left_mm),
                (-90.0, width_mm / 2.0 + left_mm),
            ]
            .iter()
            .filter_map(|(normal, far)| {
                let incidence = normalize_deg(dir - normal).abs();
                (incidence <= 20.0).then(|| {
                    let skin = far - 380.0 * incidence.to_radians().cos();
                    skin / (incidence - 7.5).max(0.0).to_radians().cos()
                })
            })
            .fold(10_000.0f64, f64::min)
            .round() as u32
        })
        .collect()
}

#[test]
fn swerving_30_degrees_the_walls_stay_in_view() {
    // Keeping right for an oncoming robot in a 2.44 m corridor, the
    // robot turns 30° right: sonars 6 and 18 are 30° off square and hear
    // nothing; sonars 8 and 20 are square to the walls.
    let s = slanted_scan(2_440.0, 0.0, -30.0);
    assert_eq!((s[6], s[18]), (10_000, 10_000), "{s:?}");
    let mut walls = Walls::default();
    let mut left_mm = 0.0;
    for k in 0..12 {
        let along = 100.0 * f64::from(k);
        let s = slanted_scan(2_440.0, left_mm, -30.0);
        walls.steer(&s, -30.0, along, -30.0);
        left_mm -= 100.0 * 30f64.to_radians().tan();
    }
    // The walls are read as far apart as they are (the robot's width
    // left out) ...
    let width = walls.width().expect("both walls in view");
    assert!((width - (2_440.0 - 760.0)).abs() < 5.0, "{width}");
    // ... and the robot, now 0.6 m right of the middle and moving right
    // at 30°, is steered back left.
    let steer = walls.fit().expect("a fit of the walls");
    assert!(steer > 20.0, "{steer}");
    // Along the axis the side sonars read the walls as they are.
    let s = slanted_scan(2_440.0, 300.0, 0.0);
    let mut walls = Walls::default();
    for k in 0..6 {
        walls.steer(&s, 0.0, 100.0 * f64::from(k), 0.0);
    }
    assert_eq!(walls.width(), Some(f64::from(s[6] + s[18])));
}

#[test]
fn between_two_sonars_the_wall_is_read_by_the_nearer_one() {
    // 25° right of the axis, 0.3 m left of the middle: sonars 6 and 18
    // hear nothing, and the walls are 5° off square for sonars 8 and 20.
    let (width, left) = (2_440.0, 300.0);
    let s = slanted_scan(width, left, -25.0);
    assert_eq!((s[6], s[18]), (10_000, 10_000), "{s:?}");
    let mut walls = Walls::default();
    for k in 0..6 {
        walls.steer(&s, -25.0, 100.0 * f64::from(k), -25.0);
    }
    let read = walls.width().expect("both walls in view");
    assert!((read - (width - 760.0)).abs() < 1.0, "{read}");
}

/// A hallway scan with something `ahead_mm` away on the axis ahead.
fn with_ahead(ahead_mm: u32) -> Vec<u32> {
    let mut s = hallway_scan(800, 800);
    s[12] = ahead_mm;
    s
}

#[test]
fn something_closing_faster_than_the_robot_drives_is_oncoming_and_a_still_one_is_not() {
    // Another robot met head-on: over 0.5 m driven the range shrinks by
    // 1 m (both drive at the same speed).
    let mut o = Oncoming::default();
    let met: Vec<bool> = (0..6)
        .map(|k| o.watch(&with_ahead(4_000 - 200 * k), 100.0 * f64::from(k), 20_000.0))
        .collect();
    assert_eq!(met, [false, false, false, true, true, true]);
    // Kept right for 3 m past the last sighting, then no more.
    assert!(o.watch(&with_ahead(10_000), 3_400.0, 20_000.0));
    assert!(!o.watch(&with_ahead(10_000), 3_600.0, 20_000.0));
    // Something standing in the hallway: the range shrinks as fast as the
    // robot drives.
    let mut o = Oncoming::default();
    assert!((0..10).all(|k| !o.watch(
        &with_ahead(4_000 - 100 * k),
        100.0 * f64::from(k),
        20_000.0
    )));
    // The goal's own end wall (no nearer than the goal) is never oncoming,
    // however fast it seems to come.
    let mut o = Oncoming::default();
    assert!((0..6).all(|k| !o.watch(
        &with_ahead(4_000 - 200 * k),
        100.0 * f64::from(k),
        f64::from(4_000 - 200 * k)
    )));
}

#[test]
fn a_scan_watched_twice_at_one_distance_counts_once() {
    // The Enter-Corner goal watches a scan, then hands it to Center-Hallway,
    // which watches it again: the answer is the same as watching it once.
    let (mut once, mut twice) = (Oncoming::default(), Oncoming::default());
    for k in 0..6 {
        let (s, along) = (with_ahead(4_000 - 200 * k), 100.0 * f64::from(k));
        let a = once.watch(&s, along, 20_000.0);
        let b = twice.watch(&s, along, 20_000.0);
        assert_eq!(twice.watch(&s, along, 20_000.0), b);
        assert_eq!(a, b);
    }
    assert_eq!(once, twice);
}

/// A scan in the Corner state: `ir` lit on the detectors given (0–3).
fn corner_scan(sonar: Vec<u32>, lit: &[usize]) -> Scan {
    let mut ir = vec![0u8; 24];
    for &i in lit {
        ir[i] = 1;
    }
    Scan {
        robot: "r1".into(),
        seq: 0,
        time_ms: 0,
        sonar_mm: sonar,
        ir,
    }
}

#[test]
fn a_corner_spin_away_from_a_detection_turns_back_at_a_right_angle_to_the_goal() {
    // Something on the left front stays lit (a robot passing close, then
    // the wall the spin swings towards): the robot turns away, right, but
    // never more than 90° off the goal direction.
    let cfg = NavConfig::default();
    let mut walls = Walls::default();
    let (goal, mut heading) = (-90.0, -90.0);
    let mut worst: f64 = 0.0;
    let mut turned_back = false;
    for _ in 0..100 {
        let scan = corner_scan(hallway_scan(800, 800), &[2]);
        let Drive::Spin(rate) = corner_step(&cfg, &scan, heading, goal, &mut walls, 0.0) else {
            panic!("a detection spins in place");
        };
        turned_back |= rate > 0.0;
        heading += rate;
        worst = worst.max(normalize_deg(goal - heading).abs());
    }
    assert!(turned_back, "the spin never turned back");
    assert!(worst <= 90.0 + 8.0, "turned {worst}° off the goal");
}

/// The ring beside one wall on the right, `skin_mm` from the robot's skin
/// and `rel_deg` (counter-clockwise) off parallel to it, nothing else in
/// sonar range: the specular model, clamped at the shortest range.
fn beside_a_wall_on_the_right(skin_mm: f64, rel_deg: f64) -> Vec<u32> {
    use rome_schema::robot::body::{SONAR_MAX_INCIDENCE_DEG, SONAR_MIN_MM};
    (0..24)
        .map(|i| {
            let off_square = normalize_deg(bearing(i) + rel_deg + 90.0);
            if off_square.abs() > SONAR_MAX_INCIDENCE_DEG {
                return 10_000;
            }
            let centre = skin_mm + ROBOT_RADIUS_MM;
            let range = centre / off_square.to_radians().cos() - ROBOT_RADIUS_MM;
            range.max(SONAR_MIN_MM).round() as u32
        })
        .collect()
}

#[test]
fn a_robot_setting_out_beside_a_wall_with_its_heading_off_bears_away_before_the_touch() {
    // A robot stood 150 mm from the wall on its right (as one stands aside
    // between tasks) and sets out along it; odometry's heading is 4° off,
    // into the wall. Nothing on the left is near enough for the walls to
    // be fitted, so only the side sonars can tell: they read their
    // shortest range all the way in.
    let cfg = NavConfig::default();
    let mut h = Hallway::new(0);
    let (mut skin, mut rel, odometry_error) = (150.0_f64, -4.0_f64, 4.0);
    let mut closest = skin;
    let mut along = 0.0;
    for k in 0..150u64 {
        let s = beside_a_wall_on_the_right(skin, rel);
        let drive = h.step(&cfg, &s, rel + odometry_error, 0.0, along, 100 * k);
        let (turn, speed) = match drive {
            Drive::Go(v) => (0.0, v),
            Drive::Jog(r) => (r * 0.1, cfg.cruise_mm_s),
            Drive::Turn(d) => (d, 0.0),
            other => panic!("unexpected {other:?}"),
        };
        rel += turn;
        let d = speed * 0.1;
        along += d;
        skin += d * rel.to_radians().sin();
        closest = closest.min(skin);
    }
    assert!(along > 5_000.0, "drove only {along:.0} mm");
    assert!(closest > 50.0, "came within {closest:.0} mm of the wall");
    // Near on both sides, as in a doorway, or with a robot passing on the
    // other side, it bears neither way.
    for other in [150, 600] {
        let mut s = beside_a_wall_on_the_right(150.0, 0.0);
        s[18] = other;
        assert_eq!(side_touch(&s), None, "other side at {other} mm");
    }
    assert_eq!(
        side_touch(&beside_a_wall_on_the_right(150.0, 0.0)),
        Some(1.0)
    );
    assert_eq!(side_touch(&beside_a_wall_on_the_right(400.0, 0.0)), None);
}

/// A scan from the middle of a 2.2 m corridor with a robot-sized disc
/// standing `ahead_mm` ahead and `across_mm` left of the middle, each
/// beam read along its axis.
fn with_disc(ahead_mm: f64, across_mm: f64) -> Vec<u32> {
    let mut s = slanted_scan(2_200.0, 0.0, 0.0);
    for (i, r) in s.iter_mut().enumerate() {
        if let Some(range) = disc_echo(i, ahead_mm, across_mm) {
            *r = (*r).min(range.max(150.0).round() as u32);
        }
    }
    s
}

/// Sonar `i`'s range, read along its axis, to a robot-sized disc
/// `ahead_mm` ahead and `across_mm` left of the robot's middle, if the
/// axis meets it.
fn disc_echo(i: usize, ahead_mm: f64, across_mm: f64) -> Option<f64> {
    let far = ahead_mm * ahead_mm + across_mm * across_mm - ROBOT_RADIUS_MM * ROBOT_RADIUS_MM;
    let b = bearing(i).to_radians();
    let towards = b.cos() * ahead_mm + b.sin() * across_mm;
    let hit = towards * towards - far;
    (towards > 0.0 && hit >= 0.0).then(|| towards - hit.sqrt() - ROBOT_RADIUS_MM)
}

#[test]
fn a_robot_standing_aside_ahead_is_passed_on_its_far_side() {
    // One stood aside 150 mm from the right wall of a 2.2 m corridor:
    // 0.57 m right of the middle, where a robot driving on the middle
    // would pass 0.19 m short of the 0.76 m two need.
    let across = -(1_100.0 - 150.0 - ROBOT_RADIUS_MM);
    let aside = with_disc(2_400.0, across);
    assert!(aside[11] < 2_000 && aside[12] == 10_000, "{aside:?}");
    // Seen from 2.8 m off, drawing `nearer_mm` nearer each 0.1 m the
    // robot drives (as near as it drives: it stands still); what the
    // robot does when it is 2.4 m off, and on the next scan, where it has
    // left the front sonars' view.
    let run = |pass_wide: bool, nearer_mm: f64| {
        let cfg = NavConfig {
            pass_wide,
            ..NavConfig::default()
        };
        let mut h = Hallway::new(0);
        let clear = slanted_scan(2_200.0, 0.0, 0.0);
        for k in 0..8 {
            driven_at(&mut h, &cfg, &clear, k);
        }
        for k in 8..12 {
            let ahead = 2_800.0 - nearer_mm * f64::from(k - 8);
            driven_at(&mut h, &cfg, &with_disc(ahead, across), k);
        }
        let seen = driven_at(
            &mut h,
            &cfg,
            &with_disc(2_800.0 - 4.0 * nearer_mm, across),
            12,
        );
        let abeam = driven_at(&mut h, &cfg, &clear, 13);
        (seen, abeam)
    };
    // Over to the left, briskly, and kept there.
    let left = Drive::Jog(crate::drive::KEEP_RIGHT_JOG_DEG_S);
    assert_eq!(run(true, 100.0), (left, left));
    // The thesis' Navigator drives on along the middle.
    let thesis = run(false, 100.0);
    assert!(matches!(thesis, (Drive::Go(_), Drive::Go(_))), "{thesis:?}");
    // One that comes towards the robot is not passed so.
    let (met, _) = run(true, 200.0);
    assert_ne!(met, left);
}

#[test]
fn a_safety_turn_stops_at_once_only_when_braking_would_carry_the_robot_into_what_is_ahead() {
    // Cruising at 400 mm/s and braking at 300 mm/s², a point turn carries
    // the robot 267 mm on: a robot 300 mm off, 30° right of ahead (what
    // was touched in a junction), is too near; the same 300 mm at a
    // corner's 250 mm/s, or 600 mm off at cruising speed, is not.
    let mut s = hallway_scan(1_200, 1_200);
    s[10] = 300;
    assert!(crate::drive::stops_short(&s, 400.0, 300.0, 0.0));
    assert!(!crate::drive::stops_short(&s, 250.0, 300.0, 0.0));
    // A slow link: what is sent arrives later, and the robot drives on.
    assert!(crate::drive::stops_short(&s, 250.0, 300.0, 0.5));
    s[10] = 600;
    assert!(!crate::drive::stops_short(&s, 400.0, 300.0, 0.0));
    // Only what the safety rule watches (60° either side) counts: a wall
    // beside or a robot behind does not.
    let mut s = hallway_scan(150, 150);
    s[0] = 150;
    assert!(!crate::drive::stops_short(&s, 400.0, 300.0, 0.0));
}

#[test]
fn the_speedometer_reads_the_speed_driven_not_the_speed_set() {
    let mut s = crate::drive::Speedometer::default();
    assert_eq!(s.update(0, 0.0), 0.0);
    // 40 mm every 100 ms is 400 mm/s; smoothed, it gets there in a few scans.
    let mut v = 0.0;
    for k in 1..=10u64 {
        v = s.update(100 * k, 40.0 * k as f64);
    }
    assert!((v - 400.0).abs() < 1.0, "{v}");
    // Standing (a turn in place): the speed falls away, however fast the
    // robot was told to go.
    for k in 11..=20u64 {
        v = s.update(100 * k, 400.0);
    }
    assert!(v < 1.0, "{v}");
    // The same instant twice, or time going back, reads nothing new.
    assert_eq!(s.update(2_000, 400.0), v);
    assert_eq!(s.update(1_000, 900.0), v);
}

/// Two robots driving head on from 5 m apart, each setting its speed from
/// the gap it read at the last scan (`speed_for`), the setting reaching
/// the base a scan later and the base changing speed at 300 mm/s²; the
/// smallest gap between their skins, mm.
fn closest_head_on(speed_for: impl Fn(f64) -> f64) -> f64 {
    let (dt, scan_every, accel) = (0.01, 10, 300.0);
    let (mut gap, mut v, mut set, mut read) = (5_000.0_f64, 400.0_f64, 400.0, 5_000.0);
    let mut closest = gap;
    for k in 0..3_000 {
        if k % scan_every == 0 {
            // What was read a scan ago is acted on now.
            set = speed_for(read);
            read = gap;
        }
        v += (set - v).clamp(-accel * dt, accel * dt);
        gap -= 2.0 * v * dt;
        closest = closest.min(gap);
    }
    closest
}

#[test]
fn two_robots_closing_head_on_at_the_ahead_cap_stop_apart_and_at_cruise_they_meet() {
    let mut s = hallway_scan(1_200, 1_200);
    assert_eq!(crate::drive::ahead_speed_cap(&s, 300.0, 0.1), f64::INFINITY);
    // 1 m ahead, acting 0.1 s late: v² / 300 + 0.2 v = 800.
    s[12] = 1_000;
    let cap = crate::drive::ahead_speed_cap(&s, 300.0, 0.1);
    assert!((cap - 460.8).abs() < 0.1, "{cap}");
    // Only 15° either side of ahead counts: a robot passed abeam does not
    // slow the robot.
    s[12] = 10_000;
    s[9] = 300;
    assert_eq!(crate::drive::ahead_speed_cap(&s, 300.0, 0.1), f64::INFINITY);
    // The model acts on what it read up to two scans before.
    let capped = |gap: f64| {
        let mut ring = hallway_scan(1_200, 1_200);
        ring[12] = gap.clamp(150.0, 10_000.0) as u32;
        400.0_f64.min(crate::drive::ahead_speed_cap(&ring, 300.0, 0.2))
    };
    let closest = closest_head_on(capped);
    assert!(closest > 100.0, "capped, they came within {closest:.0} mm");
    // Cruising until the shortest safe threshold (0.35 m) and braking
    // then, as both did before, they meet.
    let cruise = |gap: f64| if gap < 350.0 { 0.0 } else { 400.0 };
    let closest = closest_head_on(cruise);
    assert!(closest <= 0.0, "at cruise they kept {closest:.0} mm");
}

/// The Corner state's ring with a robot-sized disc `ahead_mm` ahead and
/// `across_mm` left of the robot's middle, and a wall parallel to the
/// heading `left_skin_mm` off its left side.
fn corner_beside_a_disc(ahead_mm: f64, across_mm: f64, left_skin_mm: f64) -> Vec<u32> {
    use rome_schema::robot::body::{SONAR_MAX_INCIDENCE_DEG, SONAR_MIN_MM};
    (0..24)
        .map(|i| {
            let mut range = f64::from(10_000u32);
            let off_square = normalize_deg(bearing(i) - 90.0);
            if off_square.abs() <= SONAR_MAX_INCIDENCE_DEG {
                let centre = left_skin_mm + ROBOT_RADIUS_MM;
                range = centre / off_square.to_radians().cos() - ROBOT_RADIUS_MM;
            }
            if let Some(disc) = disc_echo(i, ahead_mm, across_mm) {
                range = range.min(disc);
            }
            range.max(SONAR_MIN_MM).round() as u32
        })
        .collect()
}

#[test]
fn a_robot_setting_off_from_a_corner_beside_one_standing_bears_away_from_it() {
    // Its detectors clear, facing its goal, a robot sets off in a corner
    // with one standing idle ahead on its right, 30 mm nearer its line
    // than two bodies pass, and a wall 550 mm off its left. Driven
    // straight on, the two touch; bearing away, they pass.
    let closest = |bears_off: bool| {
        let cfg = NavConfig {
            corner_bears_off: bears_off,
            ..NavConfig::default()
        };
        let mut walls = Walls::default();
        let (mut x, mut y, mut heading) = (0.0_f64, 0.0_f64, 0.0_f64);
        let (disc_x, disc_y, wall_skin) = (400.0, -(2.0 * ROBOT_RADIUS_MM - 30.0), 550.0);
        let mut closest = f64::INFINITY;
        for _ in 0..40 {
            let h = heading.to_radians();
            let (dx, dy) = (disc_x - x, disc_y - y);
            let (ahead, across) = (dx * h.cos() + dy * h.sin(), -dx * h.sin() + dy * h.cos());
            let scan = corner_scan(corner_beside_a_disc(ahead, across, wall_skin - y), &[]);
            let (turn, speed) = match corner_step(&cfg, &scan, heading, 0.0, &mut walls, x) {
                Drive::Go(v) => (0.0, v),
                Drive::Jog(r) => (r * 0.1, cfg.corner_mm_s),
                Drive::Spin(r) => (r * 0.1, 0.0),
                other => panic!("unexpected {other:?}"),
            };
            heading += turn;
            x += speed * 0.1 * heading.to_radians().cos();
            y += speed * 0.1 * heading.to_radians().sin();
            closest = closest.min((disc_x - x).hypot(disc_y - y));
        }
        closest
    };
    let touch = 2.0 * ROBOT_RADIUS_MM;
    assert!(closest(false) < touch, "straight on, it cleared the disc");
    assert!(
        closest(true) > touch,
        "bearing away, it came within {:.0} mm",
        closest(true)
    );
    // With less than its room on the other side, it bears neither way.
    let mut s = corner_beside_a_disc(0.0, -780.0, 550.0);
    assert_eq!(crate::hallway::corner_side_touch(&s), Some(1.0));
    s[18] = 300;
    assert_eq!(crate::hallway::corner_side_touch(&s), None);
}

/// A robot `left_mm` left of the middle of a 3 m corridor drives at
/// 300 mm/s towards another, `its_left_mm` left of the middle, which
/// stands `from_mm` ahead and walks away at `its_mm_s`, each beam hearing
/// the nearest point of its beam on it (`bodies::echo`). If the robot
/// halts: how far ahead the other's middle was then, mm, and for how long
/// it halted, ms of robot time.
fn towards_one_ahead(
    cfg: &NavConfig,
    left_mm: f64,
    its_left_mm: f64,
    from_mm: f64,
    its_mm_s: f64,
) -> Option<(f64, u64)> {
    let mut h = Hallway::new(0);
    let mut along = 0.0;
    let mut halted = None::<(f64, u64)>;
    for k in 0..600u64 {
        let t = 100 * k;
        let ahead = from_mm + its_mm_s * k as f64 / 10.0 - along;
        if ahead < 1_000.0 {
            break;
        }
        let mut s = slanted_scan(3_000.0, left_mm, 0.0);
        for (i, r) in s.iter_mut().enumerate() {
            if let Some(e) = crate::bodies::echo(i, (ahead, its_left_mm - left_mm)) {
                *r = (*r).min(e.max(150.0).round() as u32);
            }
        }
        match (h.step(cfg, &s, 0.0, 0.0, along, t), halted) {
            (Drive::Halt, None) => halted = Some((ahead, t)),
            (Drive::Halt, Some(_)) => {}
            (_, Some((ahead, since))) => return Some((ahead, t - since)),
            (_, None) => along += 30.0,
        }
    }
    halted.map(|(ahead, since)| (ahead, 60_000 - since))
}

#[test]
fn one_standing_on_the_middle_that_no_lane_passes_is_waited_for_a_while() {
    // Keeping 0.6 m right of the middle of a 3 m corridor, towards one
    // standing on the middle: passing on either side would leave less
    // than the 0.3 m a robot keeps from the wall.
    let cfg = NavConfig::default();
    let standing = |cfg: &NavConfig, left_mm, its_left_mm| {
        towards_one_ahead(cfg, left_mm, its_left_mm, 3_500.0, 0.0)
    };
    let (ahead, waited) = standing(&cfg, -600.0, 0.0).expect("it halts");
    // Short of it: some 0.9 m or more between the skins, braking left
    // aside (it was heard within 1 m, off the edge of a beam).
    let gap = ahead.hypot(600.0) - 2.0 * ROBOT_RADIUS_MM;
    assert!(gap >= 900.0, "halted {gap:.0} mm off");
    // For a while, then as before.
    assert_eq!(waited, 10_000);
    // One stood aside by the wall leaves a lane: passed, not waited for.
    assert_eq!(standing(&cfg, 0.0, -950.0), None);
    // One walking off ahead, within the metre, is not waited for; the same
    // one standing is.
    assert_eq!(towards_one_ahead(&cfg, -600.0, 0.0, 1_800.0, 150.0), None);
    assert!(towards_one_ahead(&cfg, -600.0, 0.0, 1_800.0, 0.0).is_some());
    // The thesis' Navigator does not wait.
    let thesis = NavConfig {
        pass_wide: false,
        ..NavConfig::default()
    };
    assert_eq!(standing(&thesis, -600.0, 0.0), None);
}

/// Drives a robot by Center-Hallway down the middle of EB3's corridor B
/// (3.66 m) into a junction whose left side opens 1.2 m on, with
/// something coming on the axis until then: how far right of the middle
/// it goes over the next 3.6 m (mm), and how far right of the axis it
/// turns (degrees).
fn swing_into_a_junction(coast_on_odometry: bool) -> (f64, f64) {
    let cfg = NavConfig {
        coast_on_odometry,
        ..NavConfig::default()
    };
    let mut h = Hallway::new(0);
    // Left of the middle, mm; heading from the axis, degrees
    // counter-clockwise; 100 ms and 40 mm a scan.
    let (mut left_mm, mut rel_deg) = (0.0_f64, 0.0_f64);
    let (mut most_right, mut most_turned) = (0.0_f64, 0.0_f64);
    for k in 0..120_u32 {
        let along = 40.0 * f64::from(k);
        let mut s = slanted_scan(3_660.0, left_mm, rel_deg);
        if along < 1_200.0 {
            // Coming at the robot as fast as it drives.
            s[12] = (4_400.0 - 2.0 * along) as u32;
        } else {
            // The junction: nothing on the left.
            for r in &mut s[13..=23] {
                *r = 10_000;
            }
        }
        match h.step(&cfg, &s, rel_deg, 0.0, along, 100 * u64::from(k)) {
            Drive::Jog(rate) => rel_deg += rate / 10.0,
            Drive::Turn(by) => rel_deg += by,
            _ => {}
        }
        left_mm += 40.0 * rel_deg.to_radians().sin();
        most_right = most_right.min(left_mm);
        most_turned = most_turned.min(rel_deg);
    }
    (-most_right, -most_turned)
}

#[test]
fn keeping_right_into_a_junction_the_walls_left_behind_are_carried_on_by_odometry() {
    // Beyond the junction the corridor goes on as G, 2.44 m: the outer
    // wall steps 0.61 m in, and a robot whose middle is more than
    // 1.22 - 0.38 m right of B's middle runs into the step. By the walls
    // last heard, as they were, the robot is still where it was when the
    // left side opened, short of its lane: it turns on right, past 40°,
    // and ends past the step's edge. Carried on by odometry, the walls
    // say how far it has come across and how far it has turned: it
    // turns back from the brisk swerve's 30° (33° with the fit's lag,
    // before the junction) and holds its lane, 0.6 m right.
    let edge_mm = 1_220.0 - ROBOT_RADIUS_MM;
    let (stale_mm, stale_deg) = swing_into_a_junction(false);
    let (carried_mm, carried_deg) = swing_into_a_junction(true);
    assert!(
        stale_mm > edge_mm && stale_deg > 40.0,
        "by the walls as last heard: {stale_mm:.0} mm, {stale_deg:.1}°"
    );
    assert!(
        carried_mm < 700.0 && carried_deg < 35.0,
        "carried on: {carried_mm:.0} mm, {carried_deg:.1}°"
    );
}
