//! The simulator against geometry computed by hand.

#![allow(clippy::unwrap_used)]

use rome_sim::camera::{DIGIT_GREY, LIGHT_GREY, PLATE_GREY};
use rome_sim::spec::{ROBOT_RADIUS_MM, SONAR_HALF_BEAM_DEG};
use rome_sim::{Mode, Noise, Pose, Sim, SimConfig};

/// A 10 × 6 m room: x 0..10000, y 0..6000. The middle 4 m of the south wall
/// are glass; the west wall has door 101 (y 2000..3000) with its plate 300 mm
/// before it; the east wall has an elevator (y 2500..3500); one ceiling light
/// in the middle of the room.
const BOX: &str = "
map test room
tolerance 10
lateral 1500
ring room at 0 6000 heading -90
  node NW -270
  wall 10000 lights 5000 lateral 3000
  node NE -270
  wall 2500
  node E1 180
  elevator 1000 number lift
  node E2 180
  wall 2500
  node SE -270
  wall 3000
  node G1 180
  glass 4000
  node G2 180
  wall 3000
  node SW -270
  wall 2000 plate 101 1700
  node D1 180
  door 1000 number 101
  node D2 180
  wall 3000
end
";

fn quiet() -> SimConfig {
    SimConfig {
        noise: Noise::none(),
        sonar_period_ms: 100,
        ..SimConfig::default()
    }
}

fn room(config: SimConfig) -> Sim {
    let map = rome_maps::parse("box.stk", BOX).unwrap();
    assert!(
        rome_maps::validate(&map).is_empty(),
        "{:?}",
        rome_maps::validate(&map)
    );
    Sim::new(&map, config)
}

fn at(x: f64, y: f64, heading: f64) -> Pose {
    Pose::new(x, y, heading)
}

#[test]
fn sonar_sees_a_perpendicular_wall_at_its_distance() {
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(5_000.0, 3_000.0, 0.0)).unwrap();
    let s = sim.robot(r).sonar;
    // Sonar 12 looks North: 6000 - 3000 - 380.
    assert_eq!(s[12], 2_620);
    // Sonar 18 looks West, sonar 6 East (door and elevator are flush).
    assert_eq!(s[18], 4_620);
    assert_eq!(s[6], 4_620);
}

#[test]
fn sonar_hears_a_corner_from_any_direction_inside_its_beam() {
    let mut sim = room(quiet());
    // From (7000, 3000) the NE corner (10000, 6000) is at bearing -45:
    // sonar 9. Both walls meet its beam at 45°: no specular echo.
    let r = sim.add_robot("r", at(7_000.0, 3_000.0, 0.0)).unwrap();
    let expected =
        std::f64::consts::SQRT_2 * (3_000.0 - ROBOT_RADIUS_MM / std::f64::consts::SQRT_2);
    let got = f64::from(sim.robot(r).sonar[9]);
    assert!((got - expected).abs() <= 1.0, "{got} vs {expected}");
}

#[test]
fn glass_returns_no_echo_but_stops_the_robot() {
    let mut sim = room(quiet());
    // Sonar 0 looks South, straight at the glass.
    let r = sim.add_robot("r", at(5_000.0, 1_500.0, 0.0)).unwrap();
    assert_eq!(sim.robot(r).sonar[0], 10_000, "glass is invisible to sonar");
    // Moved over the wall part of the south wall, it hears the wall.
    let q = sim.add_robot("q", at(1_500.0, 1_500.0, 0.0)).unwrap();
    assert_eq!(sim.robot(q).sonar[0], 1_120);
    // Backing into the glass: the body stops at it.
    sim.robot_mut(r).bumpers.watch = true;
    sim.robot_mut(r).drive.go(-300.0).unwrap();
    sim.run_for(6_000);
    let pose = sim.robot(r).pose;
    assert!((pose.at.y - ROBOT_RADIUS_MM).abs() < 10.0, "{pose:?}");
    assert!(sim.robot(r).bumpers.rear && !sim.robot(r).bumpers.front);
}

#[test]
fn grazing_incidence_returns_nothing() {
    // Turning the robot away from the North wall: within the beam the echo
    // comes back (at the range of the beam's edge), beyond ~20° it does not.
    let d = 6_000.0 - 3_000.0;
    for (heading, expect) in [
        (0.0, Some(d - ROBOT_RADIUS_MM)),
        (15.0, Some(0.0)),
        (30.0, None),
    ] {
        let mut sim = room(quiet());
        let r = sim.add_robot("r", at(5_000.0, 3_000.0, heading)).unwrap();
        let got = sim.robot(r).sonar[12];
        match expect {
            Some(v) if v > 0.0 => assert_eq!(f64::from(got), v),
            Some(_) => {
                // The sensor sits on the ring, turned with the robot.
                let sensor_y = 3_000.0 + ROBOT_RADIUS_MM * heading.to_radians().cos();
                let off = (15.0 - SONAR_HALF_BEAM_DEG).to_radians();
                let want = (6_000.0 - sensor_y) / off.cos();
                assert!((f64::from(got) - want).abs() <= 1.0, "{got} vs {want}");
            }
            None => assert_eq!(got, 10_000, "heading {heading}: grazing, no echo"),
        }
    }
}

#[test]
fn another_robot_echoes_from_its_near_side() {
    let mut sim = room(quiet());
    let a = sim.add_robot("a", at(5_000.0, 3_000.0, 0.0)).unwrap();
    sim.add_robot("b", at(5_000.0, 5_000.0, 180.0)).unwrap();
    sim.sense(a);
    // 2000 between centres, less both radii.
    assert_eq!(sim.robot(a).sonar[12], 2_000 - 2 * 380);
}

#[test]
fn timeouts_cap_the_range() {
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(5_000.0, 3_000.0, 0.0)).unwrap();
    sim.set_timeout(r, 12, 2_000).unwrap();
    sim.sense(r);
    assert_eq!(
        sim.robot(r).sonar[12],
        2_000,
        "the wall at 2620 is past the timeout"
    );
    assert!(sim
        .set_timeout(r, 24, 2_000)
        .unwrap_err()
        .to_string()
        .contains("no sonar 24"));
    assert!(sim
        .set_timeout(r, 1, 0)
        .unwrap_err()
        .to_string()
        .contains("out of range"));
}

#[test]
fn infrared_sees_walls_within_76_cm_but_not_glass() {
    let mut sim = room(quiet());
    let near = sim
        .add_robot("near", at(5_000.0 - 2_500.0, 6_000.0 - 900.0, 0.0))
        .unwrap();
    let far = sim.add_robot("far", at(5_000.0, 3_000.0, 0.0)).unwrap();
    let glass = sim.add_robot("glass", at(5_000.0, 900.0, 180.0)).unwrap();
    // 900 - 380 = 520 mm to the north wall: the forward sensors see it.
    assert_eq!(sim.robot(near).infrared & 0b0110, 0b0110);
    assert_eq!(sim.robot(far).infrared, 0);
    assert_eq!(
        sim.robot(glass).infrared & 0b0110,
        0,
        "glass ahead is not seen"
    );
}

#[test]
fn a_watched_bumper_stops_the_robot_at_the_wall() {
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(5_000.0, 4_500.0, 0.0)).unwrap();
    sim.robot_mut(r).bumpers.watch = true;
    sim.robot_mut(r).drive.go(400.0).unwrap();
    sim.run_for(8_000);
    let robot = sim.robot(r);
    assert_eq!(robot.drive.mode, Mode::Joystick, "emergency stop");
    assert_eq!(robot.drive.v, 0.0);
    assert_eq!(robot.bumpers.status(), 1, "front bumper");
    assert!(
        (robot.pose.at.y - (6_000.0 - ROBOT_RADIUS_MM)).abs() < 10.0,
        "{:?}",
        robot.pose
    );
    // Odometry agrees with the truth: the wheels stopped when the body did.
    assert!((robot.odometry.y - robot.pose.at.y).abs() < 20.0);
}

#[test]
fn an_ignored_bumper_lets_the_wheels_slip_against_the_wall() {
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(5_000.0, 4_500.0, 0.0)).unwrap();
    sim.robot_mut(r).drive.go(400.0).unwrap();
    sim.run_for(8_000);
    let robot = sim.robot(r);
    assert!(matches!(robot.drive.mode, Mode::Go { .. }));
    assert!(robot.bumpers.front);
    assert!((robot.pose.at.y - (6_000.0 - ROBOT_RADIUS_MM)).abs() < 10.0);
    assert!(
        robot.odometry.y - robot.pose.at.y > 1_000.0,
        "the encoders kept counting"
    );
}

#[test]
fn contacts_with_walls_and_robots_are_counted_once_per_touch() {
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(5_000.0, 4_500.0, 0.0)).unwrap();
    // Pressed against the wall for seconds: one touch, one bumper press.
    sim.robot_mut(r).drive.go(400.0).unwrap();
    sim.run_for(8_000);
    let c = sim.robot(r).contacts;
    assert_eq!((c.wall, c.robot, c.bumper), (1, 0, 1), "{c:?}");
    // Backing off and driving in again is a second touch.
    sim.robot_mut(r).drive.go(-400.0).unwrap();
    sim.run_for(2_000);
    sim.robot_mut(r).drive.go(400.0).unwrap();
    sim.run_for(4_000);
    assert_eq!(sim.robot(r).contacts.wall, 2);
    // Two robots driving into each other: one touch each, no wall.
    let mut sim = room(quiet());
    let a = sim.add_robot("a", at(3_000.0, 3_000.0, -90.0)).unwrap(); // East
    let b = sim.add_robot("b", at(6_000.0, 3_000.0, 90.0)).unwrap(); // West
    sim.robot_mut(a).drive.go(300.0).unwrap();
    sim.robot_mut(b).drive.go(300.0).unwrap();
    sim.run_for(10_000);
    for i in [a, b] {
        let c = sim.robot(i).contacts;
        assert_eq!((c.wall, c.robot), (0, 1), "{c:?}");
        assert!(sim.robot(i).bumpers.front);
    }
    // A robot standing in the open touches nothing.
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(5_000.0, 3_000.0, 0.0)).unwrap();
    sim.run_for(2_000);
    assert_eq!(sim.robot(r).contacts.total(), 0);
}

#[test]
fn point_to_point_go_and_turn_reach_their_targets() {
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(2_000.0, 3_000.0, -90.0)).unwrap(); // East
    sim.robot_mut(r)
        .drive
        .move_by(4_000.0, 500.0, 300.0)
        .unwrap();
    sim.run_for(15_000);
    let robot = sim.robot(r);
    assert_eq!(robot.drive.mode, Mode::Go { velocity: 0.0 });
    assert!((robot.pose.at.x - 6_000.0).abs() < 2.0, "{:?}", robot.pose);
    assert!((robot.pose.at.y - 3_000.0).abs() < 2.0);
    // Turn 90° clockwise: from East (-90) to South (180).
    sim.robot_mut(r).drive.turn(90.0, 45.0, 90.0).unwrap();
    sim.run_for(5_000);
    let robot = sim.robot(r);
    let err = rome_maps::geometry::normalize_deg(robot.pose.heading.deg() - 180.0);
    assert!(err.abs() < 0.2, "{}", robot.pose.heading);
    assert!((robot.pose.at.x - 6_000.0).abs() < 2.0, "turning in place");
    // Backwards with negative distance, current settings kept (-1).
    sim.robot_mut(r)
        .drive
        .move_by(-1_000.0, -1.0, -1.0)
        .unwrap();
    sim.run_for(6_000);
    let robot = sim.robot(r);
    assert!((robot.pose.at.y - 4_000.0).abs() < 2.0, "{:?}", robot.pose);
    assert_eq!(robot.drive.speed_setting, 500.0);
}

#[test]
fn jog_superimposes_a_turn_on_forward_motion() {
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(5_000.0, 1_500.0, 0.0)).unwrap();
    sim.robot_mut(r).drive.go(300.0).unwrap();
    sim.robot_mut(r).drive.jog(10.0).unwrap(); // clockwise
    sim.run_for(3_000);
    let robot = sim.robot(r);
    assert!(
        robot.pose.heading.deg() < -20.0,
        "turned clockwise: {}",
        robot.pose.heading
    );
    assert!(robot.pose.at.y > 2_000.0, "and moved on");
}

#[test]
fn jog_keeps_the_gos_direction_and_with_no_speed_turns_in_place() {
    // Backwards: the Go before the Jog went backwards (a Pioneer jogs at
    // the last Go's signed velocity).
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(5_000.0, 3_000.0, 0.0)).unwrap();
    sim.robot_mut(r).drive.go(-300.0).unwrap();
    sim.robot_mut(r).drive.jog(10.0).unwrap();
    sim.run_for(3_000);
    let robot = sim.robot(r);
    assert!(robot.pose.heading.deg() < -20.0, "{}", robot.pose.heading);
    assert!(robot.pose.at.y < 2_500.0, "backed: {:?}", robot.pose);
    // A turn in the middle of it goes on backwards afterwards.
    sim.robot_mut(r).drive.turn(10.0, -1.0, -1.0).unwrap();
    sim.run_for(3_000);
    assert!(
        matches!(sim.robot(r).drive.mode, Mode::Go { velocity } if velocity < 0.0),
        "{:?}",
        sim.robot(r).drive.mode
    );
    // A Go of no speed, then a Jog: a turn in place, though the robot
    // was driving before.
    let q = sim.add_robot("q", at(2_000.0, 2_000.0, 0.0)).unwrap();
    sim.robot_mut(q).drive.go(300.0).unwrap();
    sim.run_for(1_000);
    sim.robot_mut(q).drive.go(0.0).unwrap();
    sim.robot_mut(q).drive.jog(-20.0).unwrap();
    sim.run_for(2_000);
    let from = sim.robot(q).pose;
    sim.run_for(2_000);
    let to = sim.robot(q).pose;
    assert!(
        to.heading.deg() - from.heading.deg() > 30.0,
        "{from:?} {to:?}"
    );
    assert!(from.dist(&to) < 1.0, "turned in place: {from:?} {to:?}");
}

#[test]
fn odometry_registers_wrap_at_both_ends() {
    let mut sim = room(quiet());
    let east = sim.add_robot("east", at(2_000.0, 2_000.0, -90.0)).unwrap();
    let west = sim.add_robot("west", at(8_000.0, 4_000.0, 90.0)).unwrap();
    sim.robot_mut(east).odometry.set(32_700.0, 0.0, -90.0);
    sim.robot_mut(west).odometry.set(-32_700.0, 0.0, 90.0);
    for i in [east, west] {
        sim.robot_mut(i).drive.move_by(200.0, 200.0, 400.0).unwrap();
    }
    sim.run_for(4_000);
    // 32900 does not fit 16 bits: it reads 32900 - 65536.
    assert_eq!(sim.robot(east).registers().x, (32_900 - 65_536) as i16);
    assert_eq!(sim.robot(west).registers().x, (65_536 - 32_900) as i16);
    // Heading in hundredths of a degree: East is 270°.
    assert_eq!(sim.robot(east).registers().heading_centideg, 27_000);
}

#[test]
fn the_upward_camera_sees_a_light_exactly_when_it_is_overhead() {
    // The light is at (5000, 3000), 600 mm along x by 1200 across (y); the
    // camera sees 1500 across the robot by 1200 along it. Heading North,
    // lit pixels appear while |dx| < 300 + 750 and |dy| < 600 + 600.
    let mut sim = room(SimConfig {
        image_size: (150, 120), // 10 mm pixels
        ..quiet()
    });
    let bright = |sim: &mut Sim, i: usize| {
        sim.grab(i);
        sim.robot(i)
            .up
            .as_ref()
            .unwrap()
            .pixels()
            .filter(|p| p.0[0] == LIGHT_GREY)
            .count()
    };
    let mut k = 0;
    for dx in (-1_400..=1_400).step_by(100) {
        let i = sim
            .add_robot(&format!("x{k}"), at(5_000.0 + f64::from(dx), 3_000.0, 0.0))
            .unwrap();
        k += 1;
        let n = bright(&mut sim, i);
        assert_eq!(
            n > 0,
            f64::from(dx).abs() < 1_050.0,
            "dx {dx}: {n} lit pixels"
        );
        if dx == 0 {
            // Fully under the light: 600 of 1500 across, 1200 of 1200 along.
            assert_eq!(n, 60 * 120);
        }
        let i = sim.index(&format!("x{}", k - 1)).unwrap();
        sim.robot_mut(i).pose.at.x = -50_000.0; // out of the way
    }
    for dy in (-1_600..=1_600).step_by(100) {
        let i = sim
            .add_robot(&format!("y{k}"), at(5_000.0, 3_000.0 + f64::from(dy), 0.0))
            .unwrap();
        k += 1;
        let n = bright(&mut sim, i);
        assert_eq!(
            n > 0,
            f64::from(dy).abs() < 1_200.0,
            "dy {dy}: {n} lit pixels"
        );
        sim.robot_mut(i).pose.at.x = -50_000.0;
    }
}

#[test]
fn a_plate_appears_in_the_side_image_in_front_of_its_door() {
    let mut sim = room(quiet());
    // Plate 101 is on the west wall at y = 2000 - 1700 ... the wall runs
    // from SW (0, 0) North, so the plate is at y = 1700, next to door 101
    // (y 2000..3000). Heading North, sonar 18 (the camera) looks West.
    let abeam = sim.add_robot("abeam", at(1_800.0, 1_700.0, 0.0)).unwrap();
    let away = sim.add_robot("away", at(1_800.0, 2_700.0, 0.0)).unwrap();
    sim.grab(abeam);
    sim.grab(away);
    let img = sim.robot(abeam).side.clone().unwrap();
    let (w, h) = img.dimensions();
    let count =
        |img: &image::GrayImage, v: u8, rows: std::ops::Range<u32>, cols: std::ops::Range<u32>| {
            rows.flat_map(|y| cols.clone().map(move |x| (x, y)))
                .filter(|&(x, y)| img.get_pixel(x, y).0[0] == v)
                .count()
        };
    let mid = (h / 2 - 40)..(h / 2 + 40);
    let centre = (w / 2 - 60)..(w / 2 + 60);
    let plate = count(&img, PLATE_GREY, mid.clone(), centre.clone());
    let digits = count(&img, DIGIT_GREY, mid.clone(), centre.clone());
    // 200 x 150 mm at 1420 mm: about 77 x 58 pixels in all.
    assert!(
        plate + digits > 3_500 && plate + digits < 5_000,
        "{plate} + {digits}"
    );
    assert!(digits > 200, "white digits on the plate: {digits}");
    // Nothing plate-black anywhere else in that image.
    let all = count(&img, PLATE_GREY, 0..h, 0..w);
    assert_eq!(all, plate);
    // A metre on, the door is in view but its plate is not.
    let img = sim.robot(away).side.clone().unwrap();
    assert_eq!(count(&img, PLATE_GREY, 0..h, 0..w), 0);
    assert!(count(&img, 105, 0..h, 0..w) > 1_000, "the door itself");
}

#[test]
fn an_elevator_door_opens_after_a_call() {
    let mut sim = room(SimConfig {
        elevator_delay_s: 2.0,
        elevator_open_s: 3.0,
        ..quiet()
    });
    // Facing the lift (East wall, y 2500..3500).
    let r = sim.add_robot("r", at(7_000.0, 3_000.0, -90.0)).unwrap();
    assert_eq!(sim.robot(r).sonar[12], 10_000 - 7_000 - 380);
    sim.call_elevator("lift").unwrap();
    sim.run_for(1_900);
    assert_eq!(sim.elevator_open("lift"), Some(false));
    sim.run_for(200);
    assert_eq!(sim.elevator_open("lift"), Some(true));
    sim.sense(r);
    assert_eq!(
        sim.robot(r).sonar[12],
        10_000 + 2_000 - 7_000 - 380,
        "the cabin's back wall"
    );
    sim.run_for(3_000);
    assert_eq!(sim.elevator_open("lift"), Some(false));
    assert!(sim
        .call_elevator("nope")
        .unwrap_err()
        .to_string()
        .contains("no elevator 'nope'"));
}

#[test]
fn robots_cannot_be_placed_in_walls_or_on_each_other() {
    let mut sim = room(quiet());
    let e = sim
        .add_robot("a", at(100.0, 3_000.0, 0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("a wall is 100 mm"), "{e}");
    sim.add_robot("a", at(5_000.0, 3_000.0, 0.0)).unwrap();
    let e = sim
        .add_robot("b", at(5_300.0, 3_000.0, 0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("robot 'a' is there"), "{e}");
    let e = sim
        .add_robot("a", at(2_000.0, 3_000.0, 0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("already"), "{e}");
    let e = sim
        .add_robot("d", at(f64::NAN, 3_000.0, 0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("must be finite"), "{e}");
    let e = sim.add_robot_at("c", "999L", 0.0).unwrap_err().to_string();
    assert!(e.contains("'999L'"), "{e}");
}

fn eb3() -> rome_maps::Map {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../maps/data/eb3.stk");
    rome_maps::load(std::path::Path::new(path)).unwrap()
}

fn drive_three(seed: u64) -> Vec<Vec<Pose>> {
    let mut sim = Sim::new(
        &eb3(),
        SimConfig {
            seed,
            ..SimConfig::default()
        },
    );
    for (name, at, heading) in [
        ("a", "350R", 90.0),
        ("b", "381L", -90.0),
        ("c", "A342L", 0.0),
    ] {
        let i = sim.add_robot_at(name, at, heading).unwrap();
        sim.robot_mut(i).drive.go(400.0).unwrap();
    }
    sim.run_for(20_000);
    sim.robots().iter().map(|r| r.trail.clone()).collect()
}

#[test]
fn the_same_seed_gives_the_same_trajectory() {
    let a = drive_three(7);
    let b = drive_three(7);
    assert_eq!(a, b);
    let c = drive_three(8);
    assert_ne!(a, c, "another seed, another run");
    // They did move: 20 s at 400 mm/s.
    let last = a[0].last().unwrap();
    assert!((last.at.x - a[0][0].at.x).abs() > 7_000.0, "{last:?}");
}

#[test]
fn wheels_slip_more_on_the_metal_junction() {
    // Drive 4 m along corridor M over the metal patch where J meets M, and
    // 4 m along corridor A's tiles; compare odometry against the truth.
    let err = |from: (f64, f64)| {
        let mut total = 0.0;
        for seed in 0..12 {
            let mut sim = Sim::new(
                &eb3(),
                SimConfig {
                    seed,
                    noise: Noise {
                        wheel_mismatch: 0.0,
                        ..Noise::default()
                    },
                    ..SimConfig::default()
                },
            );
            let i = sim.add_robot("r", at(from.0, from.1, -90.0)).unwrap();
            sim.robot_mut(i)
                .drive
                .move_by(4_000.0, 400.0, 400.0)
                .unwrap();
            sim.run_for(12_000);
            let r = sim.robot(i);
            total += (r.odometry.x - r.pose.at.x).hypot(r.odometry.y - r.pose.at.y);
        }
        total / 12.0
    };
    assert!(sim_on_metal((112_000.0, 55_500.0)));
    let metal = err((110_000.0, 55_500.0));
    let tile = err((60_000.0, 104_000.0));
    assert!(
        metal > 3.0 * tile,
        "metal {metal:.1} mm vs tile {tile:.1} mm"
    );
}

fn sim_on_metal(p: (f64, f64)) -> bool {
    Sim::new(&eb3(), SimConfig::default())
        .scene()
        .on_metal(rome_maps::geometry::pt(p.0, p.1))
}

#[test]
fn a_turn_while_going_resumes_going_and_a_turn_from_standstill_stands() {
    let mut sim = room(quiet());
    let going = sim.add_robot("going", at(2_000.0, 1_500.0, 0.0)).unwrap();
    let still = sim.add_robot("still", at(8_000.0, 1_500.0, 0.0)).unwrap();
    sim.robot_mut(going).drive.go(250.0).unwrap();
    sim.run_for(1_000);
    for i in [going, still] {
        sim.robot_mut(i).drive.turn(-30.0, 30.0, 60.0).unwrap(); // anticlockwise
    }
    sim.run_for(3_000);
    assert_eq!(sim.robot(going).drive.mode, Mode::Go { velocity: 250.0 });
    assert_eq!(sim.robot(still).drive.mode, Mode::Go { velocity: 0.0 });
    assert!((sim.robot(still).pose.heading.deg() - 30.0).abs() < 0.2);
}

#[test]
fn a_turn_begun_while_the_base_still_turns_the_other_way_turns_all_the_way() {
    // Jogging anticlockwise, then told to turn 30° clockwise: the base
    // turns the other way for a few steps while its rate reverses, and the
    // turn still ends 30° clockwise of where it began, not at once.
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(5_000.0, 1_500.0, 0.0)).unwrap();
    sim.robot_mut(r).drive.go(250.0).unwrap();
    sim.robot_mut(r).drive.jog(-8.0).unwrap(); // anticlockwise
    sim.run_for(1_000);
    let from = sim.robot(r).pose.heading.deg();
    sim.robot_mut(r).drive.turn(30.0, 30.0, 60.0).unwrap();
    sim.run_for(100);
    assert!(
        matches!(sim.robot(r).drive.mode, Mode::PointTurn { .. }),
        "the turn ended at once: {:?}",
        sim.robot(r).drive.mode
    );
    sim.run_for(4_000);
    let turned = rome_maps::geometry::normalize_deg(from - sim.robot(r).pose.heading.deg());
    assert!((turned - 30.0).abs() < 0.5, "turned {turned}°");
    // Going forwards, then told to move a metre back: it ends a metre
    // behind where the base stood still, not where the command came.
    let q = sim.add_robot("q", at(2_000.0, 1_500.0, 0.0)).unwrap();
    sim.robot_mut(q).drive.go(300.0).unwrap();
    sim.run_for(2_000);
    sim.robot_mut(q)
        .drive
        .move_by(-1_000.0, 300.0, 300.0)
        .unwrap();
    sim.run_for(100);
    assert!(
        matches!(sim.robot(q).drive.mode, Mode::PointGo { .. }),
        "the move ended at once: {:?}",
        sim.robot(q).drive.mode
    );
    sim.run_for(8_000);
    assert_eq!(sim.robot(q).drive.mode, Mode::Go { velocity: 0.0 });
}

#[test]
fn a_continuous_turn_follows_its_arc_then_goes_on() {
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(3_000.0, 1_500.0, 0.0)).unwrap(); // North
    sim.robot_mut(r).drive.speed_setting = 200.0;
    // A quarter circle of 1 m radius to the right (clockwise).
    sim.robot_mut(r)
        .drive
        .continuous_turn(90.0, 1_000.0)
        .unwrap();
    sim.run_for(12_000);
    let robot = sim.robot(r);
    assert!(
        matches!(robot.drive.mode, Mode::Go { .. }),
        "{:?}",
        robot.drive.mode
    );
    // After the arc the robot goes on East; its track crossed the arc's end
    // (4000, 2500) within a few centimetres.
    let closest = robot
        .trail
        .iter()
        .map(|p| (p.at.x - 4_000.0).hypot(p.at.y - 2_500.0))
        .fold(f64::INFINITY, f64::min);
    assert!(closest < 60.0, "{closest}");
    assert!(
        (robot.pose.at.y - 2_500.0).abs() < 60.0 && robot.pose.at.x > 4_000.0,
        "{:?}",
        robot.pose
    );
}

#[test]
fn the_pacer_holds_simulated_time_to_a_multiple_of_real_time() {
    let free = rome_sim::Pacer::new(None, 0);
    assert_eq!(free.wait(3_600_000), std::time::Duration::ZERO);
    let paced = rome_sim::Pacer::new(Some(2.0), 1_000);
    // 10 simulated seconds after the start are due 5 wall seconds after it.
    let wait = paced.wait(11_000);
    assert!(
        wait > std::time::Duration::from_millis(4_900) && wait <= std::time::Duration::from_secs(5)
    );
    assert_eq!(paced.wait(1_000), std::time::Duration::ZERO);
    assert_eq!(
        rome_sim::Pacer::new(Some(-1.0), 0).speed(),
        None,
        "nonsense pace runs free"
    );
}

#[test]
fn a_trail_stays_bounded_and_still_covers_the_whole_run() {
    let mut sim = Sim::new(
        &eb3(),
        SimConfig {
            trail_max: 16,
            sonar_period_ms: 0,
            ..SimConfig::default()
        },
    );
    let i = sim.add_robot_at("a", "350R", 90.0).unwrap();
    let start = sim.robot(i).pose;
    sim.robot_mut(i).drive.jog(20.0).unwrap();
    // 10 minutes at 2 poses a second would be 1 200 poses.
    let mut longest = 0;
    for _ in 0..60 {
        sim.run_for(10_000);
        longest = longest.max(sim.robot(i).trail.len());
    }
    let r = sim.robot(i);
    assert!(longest <= 16, "the trail grew to {longest} poses");
    assert!(r.trail.len() >= 8, "{}", r.trail.len());
    assert_eq!(r.trail[0], start, "the first pose stays");
    assert!(r.trail_every_ms >= 600_000 / 16, "{}", r.trail_every_ms);
}

#[test]
fn the_ring_fires_one_sonar_after_another_each_from_where_the_robot_is() {
    // Driving North towards the North wall at 400 mm/s: in each 100 ms
    // cycle sonar 12 fires once, 50 ms in (its turn in the firing order),
    // and reads the range from where the robot is at that moment.
    let mut sim = room(quiet());
    let r = sim.add_robot("r", at(5_000.0, 1_500.0, 0.0)).unwrap();
    sim.robot_mut(r).drive.go(400.0).unwrap();
    let turn = rome_sim::sonar::FIRING_ORDER
        .iter()
        .position(|&s| s == 12)
        .unwrap() as u64;
    let fires_at = turn * 100 / 24;
    let mut last = sim.robot(r).sonar[12];
    let mut last_cycle = sim.robot(r).sonar_at_ms;
    let mut fired = 0;
    for _ in 0..300 {
        sim.step();
        let now = sim.time_ms();
        let robot = sim.robot(r);
        let reading = robot.sonar[12];
        let due = (now % 100 + 100 - fires_at) % 100 < 10;
        let changed = reading != last;
        if due {
            let want = 6_000.0 - robot.pose.at.y - ROBOT_RADIUS_MM;
            assert_eq!(f64::from(reading), want.round(), "at {now} ms");
            fired += 1;
        } else {
            assert_eq!(reading, last, "sonar 12 changed at {now} ms, not its turn");
        }
        last = reading;
        // The cycle's time moves on once per cycle, when the last sonar of
        // the order has fired.
        if robot.sonar_at_ms != last_cycle {
            assert_eq!(robot.sonar_at_ms, now);
            assert_eq!(now % 100, 0, "a cycle ended at {now} ms");
            last_cycle = robot.sonar_at_ms;
            // The cycle's scan is the readings as they stood then...
            assert_eq!(robot.scan, robot.sonar);
        } else if changed {
            // ...and stays so while the next cycle fires.
            assert_ne!(robot.scan[12], reading, "at {now} ms");
        }
    }
    assert_eq!(fired, 30);
    assert_eq!(last_cycle, 3_000);
    // It moved: the readings were not all the same.
    assert!(sim.robot(r).pose.at.y > 2_000.0, "{:?}", sim.robot(r).pose);
}

#[test]
fn grabbing_cameras_changes_nothing_but_the_images() {
    // Two worlds of one seed, the same commands; one grabs its cameras at
    // odd moments, once twice in a row, the other never. The motion, the
    // sonar and the trail are the same to the last bit; a frame depends on
    // the instant, not on how many were grabbed before it.
    let map = rome_maps::load_named("fig5_3").unwrap();
    let run = |grab: bool| {
        let mut sim = Sim::new(&map, SimConfig::default());
        let r = sim.add_robot_at("r", "301L", -90.0).unwrap();
        sim.robot_mut(r)
            .drive
            .move_by(3_000.0, 400.0, 400.0)
            .unwrap();
        let mut frames = Vec::new();
        for step in 0..600 {
            sim.step();
            if grab && step % 37 == 0 {
                frames.push(sim.grab_camera(r, rome_sim::Camera::Side));
                if step % 74 == 0 {
                    sim.grab_camera(r, rome_sim::Camera::Up);
                    let again = sim.grab_camera(r, rome_sim::Camera::Side);
                    assert!(frames.last() == Some(&again), "one instant, one frame");
                }
            }
        }
        let robot = sim.robot(r);
        (robot.pose, robot.sonar, robot.trail.clone(), frames)
    };
    let (pose_a, sonar_a, trail_a, frames) = run(true);
    let (pose_b, sonar_b, trail_b, _) = run(false);
    assert_eq!(pose_a.at.x.to_bits(), pose_b.at.x.to_bits());
    assert_eq!(pose_a.at.y.to_bits(), pose_b.at.y.to_bits());
    assert_eq!(sonar_a, sonar_b);
    assert!(trail_a == trail_b, "the trails part");
    // Noise: frames of different instants differ.
    assert!(frames.windows(2).any(|w| w[0] != w[1]));
}

#[test]
fn a_person_walks_to_and_fro_and_is_met_like_a_robot() {
    let mut sim = room(quiet());
    let a = sim.add_robot("a", at(5_000.0, 3_000.0, 0.0)).unwrap();
    let w = sim.add_walker(
        rome_maps::geometry::pt(3_000.0, 5_000.0),
        rome_maps::geometry::pt(7_000.0, 5_000.0),
        1_000.0,
    );
    // Two seconds on, straight ahead of the robot: seen as another robot.
    sim.run_for(2_000);
    assert!((sim.walkers()[w].at.x - 5_000.0).abs() < 1.0);
    sim.sense(a);
    assert_eq!(sim.robot(a).sonar[12], 2_000 - 2 * 380);
    // At the far end it turns back: six seconds later, at 3 m again.
    sim.run_for(6_000);
    assert!(
        (sim.walkers()[w].at.x - 3_000.0).abs() < 1.0,
        "{:?}",
        sim.walkers()[w]
    );
    sim.sense(a);
    assert_ne!(
        sim.robot(a).sonar[12],
        2_000 - 2 * 380,
        "gone from in front"
    );

    // A robot standing in the way: the person waits in front of it.
    let mut sim = room(quiet());
    sim.add_robot("b", at(6_000.0, 5_000.0, 0.0)).unwrap();
    let w = sim.add_walker(
        rome_maps::geometry::pt(3_000.0, 5_000.0),
        rome_maps::geometry::pt(9_000.0, 5_000.0),
        1_000.0,
    );
    sim.run_for(2_300);
    let x = sim.walkers()[w].at.x;
    assert!((5_200.0..5_240.0).contains(&x), "{x}");
    assert_eq!(
        sim.robot(0).contacts.robot,
        0,
        "{:?}",
        sim.robot(0).contacts
    );
    // Two seconds later still there, it turns back the way it came.
    sim.run_for(1_000);
    assert!((5_200.0..5_240.0).contains(&sim.walkers()[w].at.x));
    sim.run_for(1_500);
    let back = sim.walkers()[w];
    assert!(back.at.x < 5_000.0, "{back:?}");
    assert_eq!(back.to.x, 3_000.0);
}

#[test]
fn a_robot_touching_another_still_turns_in_place_with_its_bumper_watched() {
    // Wheels that slip move a turning body a hair along its heading; that
    // hair, towards the robot it touches, must not stop the turn (turning
    // in place never makes a disc touch anything new). Stopped, two
    // robots side by side in a corridor mouth stood touching for ever.
    for seed in 1..=5 {
        let mut sim = room(SimConfig {
            seed,
            ..SimConfig::default()
        });
        let a = sim.add_robot("a", at(4_000.0, 3_000.0, -90.0)).unwrap(); // East
        let gap = 2.0 * ROBOT_RADIUS_MM + 0.001;
        sim.add_robot("b", at(4_000.0 + gap, 3_000.0, 90.0))
            .unwrap();
        sim.robot_mut(a).bumpers.watch = true;
        sim.robot_mut(a).drive.turn(90.0, 45.0, 90.0).unwrap();
        sim.run_for(5_000);
        let robot = sim.robot(a);
        let turned = rome_maps::geometry::normalize_deg(-90.0 - robot.pose.heading.deg());
        assert!((turned - 90.0).abs() < 5.0, "seed {seed}: turned {turned}°");
    }
}

#[test]
fn two_robots_that_met_in_one_step_can_still_back_away_from_each_other() {
    // Both move within one step, each clear of where the other was: they
    // may end a hair inside each other. Every move that left them inside,
    // backing away included, was taken for a new touch and stopped, so
    // the two stood locked together for good.
    let mut sim = room(quiet());
    let a = sim.add_robot("a", at(3_000.0, 3_000.0, -90.0)).unwrap(); // East
    let b = sim.add_robot("b", at(6_000.0, 3_000.0, 90.0)).unwrap(); // West
    for r in [a, b] {
        sim.robot_mut(r).bumpers.watch = true;
        sim.robot_mut(r).drive.go(300.0).unwrap();
    }
    sim.run_for(10_000);
    let gap = |sim: &Sim| nalgebra::distance(&sim.robot(a).pose.at, &sim.robot(b).pose.at);
    let met = gap(&sim);
    assert!(met < 2.0 * ROBOT_RADIUS_MM + 5.0, "they met: {met}");
    for r in [a, b] {
        sim.robot_mut(r).drive.go(-300.0).unwrap();
    }
    sim.run_for(3_000);
    assert!(gap(&sim) > met + 1_000.0, "{met} → {}", gap(&sim));
}
