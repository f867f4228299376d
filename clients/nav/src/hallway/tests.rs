//! Center-Hallway across a crossroads, by its own scans: where the
//! walls on both sides fall away, nothing keeps the robot off the line
//! of the corridor's walls beyond but what it remembers of them.

use super::Hallway;
use crate::drive::{Drive, NavConfig, FORWARD, ROBOT_RADIUS_MM, SONARS, SPACING};

/// Half the corridor's width, wall to wall, mm (the Campus's 2.4 m).
const HALF_MM: f64 = 1_200.0;

/// The ranges from the skin of a robot `left_mm` left of the middle,
/// heading `rel_deg` counter-clockwise of the axis: each side wall echoes
/// only to a sonar within 20° of square to it; `open` leaves both out.
fn scan(left_mm: f64, rel_deg: f64, open: bool) -> Vec<u32> {
    sides(HALF_MM, left_mm, rel_deg, !open, !open)
}

/// The ranges from the skin of a robot `left_mm` left of the middle of a
/// corridor `half_mm` wide each side, heading `rel_deg` counter-clockwise
/// of the axis, with the left and the right wall there or not.
fn sides(half_mm: f64, left_mm: f64, rel_deg: f64, left: bool, right: bool) -> Vec<u32> {
    (0..SONARS)
        .map(|i| {
            let at = rel_deg + (i as f64 - FORWARD as f64) * SPACING;
            let (to_left, to_right) = (half_mm - left_mm, half_mm + left_mm);
            let off_left = (at - 90.0).to_radians();
            let off_right = (at + 90.0).to_radians();
            let square = 20_f64.to_radians().cos();
            if left && off_left.cos() > square {
                (to_left / off_left.cos() - ROBOT_RADIUS_MM) as u32
            } else if right && off_right.cos() > square {
                (to_right / off_right.cos() - ROBOT_RADIUS_MM) as u32
            } else {
                10_000
            }
        })
        .collect()
}

/// The `k`-th scan, 100 ms and 40 mm after the last: steps the hallway
/// and moves the robot by what it asked for.
fn drive(
    h: &mut Hallway,
    cfg: &NavConfig,
    s: &[u32],
    k: u32,
    rel_deg: &mut f64,
    left_mm: &mut f64,
) {
    let along = 40.0 * f64::from(k);
    match h.step(cfg, s, *rel_deg, 0.0, along, 100 * u64::from(k)) {
        Drive::Jog(rate) => *rel_deg += rate / 10.0,
        Drive::Turn(by) => *rel_deg += by,
        _ => {}
    }
    *left_mm += 40.0 * rel_deg.to_radians().sin();
}

/// Drives down the middle of a 2.4 m corridor for 1.2 m, swerves 30°
/// left where a crossroads 2.8 m across opens on both sides (as round one
/// standing in it), and drives on: how far left of the middle the robot
/// is where the corridor goes on beyond, mm.
fn across(keep_within_walls: bool) -> f64 {
    let cfg = NavConfig {
        keep_within_walls,
        ..NavConfig::default()
    };
    let mut h = Hallway::new(0);
    let (mut left_mm, mut rel_deg) = (0.0_f64, 0.0_f64);
    for k in 0..100_u32 {
        let along = 40.0 * f64::from(k);
        if along >= 4_000.0 {
            return left_mm;
        }
        if k == 30 {
            rel_deg += 30.0;
        }
        let s = scan(left_mm, rel_deg, (1_200.0..4_000.0).contains(&along));
        drive(&mut h, &cfg, &s, k, &mut rel_deg, &mut left_mm);
    }
    left_mm
}

#[test]
fn out_of_a_crossroads_the_robot_keeps_within_the_walls_it_left() {
    // Its side touches the corner of the corridor beyond when its middle
    // is more than the half-width less its radius off the middle.
    let corner_mm = HALF_MM - ROBOT_RADIUS_MM;
    let thesis = across(false);
    let within = across(true);
    assert!(thesis > corner_mm, "by the heading alone: {thesis:.0} mm");
    assert!(
        within.abs() < corner_mm - 80.0,
        "within the walls: {within:.0} mm"
    );
}

/// Keeping right (0.6 m right of the middle) down a 3 m corridor, a
/// robot swings 60° right where a 2.4 m mouth opens on its right, 0.6 m
/// on (as from one met on its left), past where the walls are carried
/// on, and turns back at 12° a second, driving on: how far left of the
/// middle it is where the mouth's far corner stands, mm. Only the left
/// wall is in view from the mouth on.
fn past_a_mouth(keep_within_walls: bool, walls_from_one_side: bool) -> f64 {
    const HALF: f64 = 1_500.0;
    let cfg = NavConfig {
        keep_within_walls,
        walls_from_one_side,
        ..NavConfig::default()
    };
    let mut h = Hallway::new(0);
    let (mut left_mm, mut rel_deg) = (-600.0_f64, 0.0_f64);
    for k in 0..200_u32 {
        let along = 40.0 * f64::from(k);
        if along >= 3_000.0 {
            break;
        }
        if k == 15 {
            rel_deg -= 60.0;
        } else if rel_deg < 0.0 {
            rel_deg = (rel_deg + 1.2).min(0.0);
        }
        let mouth = (600.0..3_000.0).contains(&along);
        let s = sides(HALF, left_mm, rel_deg, true, !mouth);
        drive(&mut h, &cfg, &s, k, &mut rel_deg, &mut left_mm);
    }
    left_mm
}

#[test]
fn past_a_mouth_the_robot_keeps_within_the_walls_by_the_one_wall_in_view() {
    let corner_mm = 1_500.0 - ROBOT_RADIUS_MM;
    let thesis = past_a_mouth(false, false);
    let carried = past_a_mouth(true, false);
    let within = past_a_mouth(true, true);
    assert!(thesis < -corner_mm, "by the heading alone: {thesis:.0} mm");
    assert!(
        carried < -corner_mm,
        "by the walls carried on alone: {carried:.0} mm"
    );
    assert!(
        within > -corner_mm + 80.0,
        "within the walls: {within:.0} mm"
    );
}

/// Turned to the goal direction in the mouth of the corridor it turns
/// into, its left wall 0.25 m off the robot's skin, only the 45° left
/// detector lit: as the thesis' Corner state, the robot spins on, and
/// past the goal direction; with `corner_creeps` it goes on, bearing
/// away from the wall. A robot standing at a slant ahead, its echo in the
/// strip the robot would sweep, keeps it spinning either way.
#[test]
fn a_corner_goes_on_past_a_wall_beside_it_but_not_past_a_robot_ahead() {
    use crate::hallway::{corner_step, sonar_towards, Walls};
    use rome_schema::robot::Scan;
    let corner = |creeps: bool, sonar: Vec<u32>| {
        let cfg = NavConfig {
            corner_creeps: creeps,
            ..NavConfig::default()
        };
        let mut ir = vec![0u8; 24];
        ir[3] = 1;
        let scan = Scan {
            robot: "r1".into(),
            seq: 0,
            time_ms: 0,
            sonar_mm: sonar,
            ir,
        };
        corner_step(&cfg, &scan, -90.0, -90.0, &mut Walls::default(), 0.0)
    };
    // The middle 630 mm from the left wall, none on the right.
    let wall = sides(HALF_MM, HALF_MM - 630.0, 0.0, true, false);
    assert!(matches!(corner(false, wall.clone()), Drive::Spin(r) if r < 0.0));
    assert!(matches!(corner(true, wall.clone()), Drive::Jog(r) if r < 0.0));
    // Another robot's skin 250 mm off, 30° right of ahead.
    let mut robot = wall;
    robot[sonar_towards(-30.0)] = 250;
    assert!(matches!(corner(true, robot), Drive::Spin(r) if r < 0.0));
}
