//! Where a robot without a task waits: by the right-hand wall of the
//! corridor it stands in, not on its middle, where in a 2.44 m corridor no
//! other robot passes it untouched. The robot steps there with
//! [`crate::planner::step_aside`]; this module says from which leg: the
//! direction it steps along and the walls beside it.

use crate::drive::ROBOT_RADIUS_MM;
use crate::planner::ASIDE_FROM_WALL_MM;
use rome_maps::geometry::{direction, Point};
use rome_maps::{Network, World};
use rome_schema::robot::body::sonar_bearing_deg;

/// How near the path of the step aside an echo may lie, mm, beyond the
/// robot's radius: the wall it steps to stays 50 mm further out.
pub const STEP_CLEARANCE_MM: f64 = 100.0;

/// The leg a robot steps aside from: a direction, and the walls (left,
/// right) beside its line, mm, as a task's last D goal gives them.
pub type LastLeg = (f64, (f64, f64));

/// The leg a robot standing at the position `at` before its first task
/// steps aside from, as one that arrived there would: [`leg_at`] the
/// position, along the wall there. `None`: the map does not name `at`, or
/// no walls are found beside it.
pub fn start_leg(world: &World, network: &Network, at: &str, facing_deg: f64) -> Option<LastLeg> {
    let position = world.position(at)?;
    leg_at(
        world,
        network,
        position.in_corridor(),
        position.wall_heading_deg,
        facing_deg,
    )
}

/// The leg a robot standing at `p` in a corridor along `axis_deg` (either
/// way) steps aside from: the way one-way traffic goes where the stretch
/// is one way, else the way nearer to `facing_deg`, with the walls beside
/// it as the map has them. Robots waiting in a one-way corridor then all
/// stand by the same wall, and the others pass them on the other side.
/// `None`: no walls are found beside it.
pub fn leg_at(
    world: &World,
    network: &Network,
    p: Point,
    axis_deg: f64,
    facing_deg: f64,
) -> Option<LastLeg> {
    let along = |d: f64| rome_maps::geometry::direction(d) * 1_000.0;
    let ahead = rome_maps::geometry::normalize_deg(axis_deg - facing_deg).abs() <= 90.0;
    let (first, second) = if ahead {
        (axis_deg, axis_deg + 180.0)
    } else {
        (axis_deg + 180.0, axis_deg)
    };
    let direction = if network.against(p, p + along(first)) {
        second
    } else {
        first
    };
    let direction = rome_maps::geometry::normalize_deg(direction);
    let walls =
        crate::plan::walls_beside(world, p - along(direction), p + along(direction), direction)?;
    Some((direction, walls))
}

/// Whether the step aside from `leg` is free of what the sonars hear: no
/// echo within [`STEP_CLEARANCE_MM`] of the robot's path as it slides over
/// to the right wall. The Navigator watches ahead as it steps, but a
/// robot standing beside that path, ahead or behind, is not ahead once
/// the robot has turned to step, and the step sweeps into it.
/// `heading_deg` is where the robot faces now, `sonar_mm` its ranges
/// (from its body), in sonar order.
pub fn step_is_clear(sonar_mm: &[u32], heading_deg: f64, leg: LastLeg) -> bool {
    let (along, (_, right)) = leg;
    let end = direction(along - 90.0) * (right - ASIDE_FROM_WALL_MM).max(0.0);
    let len2 = end.norm_squared();
    sonar_mm.iter().enumerate().all(|(i, &r)| {
        let echo = direction(heading_deg + sonar_bearing_deg(i)) * (ROBOT_RADIUS_MM + f64::from(r));
        // The echo's distance from the segment the robot's middle slides along.
        let t = if len2 > 0.0 {
            (echo.dot(&end) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (echo - end * t).norm() >= ROBOT_RADIUS_MM + STEP_CLEARANCE_MM
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::plan::tests::eb3;

    #[test]
    fn a_robot_waiting_for_its_first_task_steps_aside_the_way_one_way_traffic_goes() {
        let (world, network) = eb3();
        let network = crate::traffic::oneway::with_one_way(&world, network);
        let step = |d: f64| rome_maps::geometry::direction(d) * 1_000.0;
        let (mut turned, mut none) = (0, Vec::new());
        for (name, position) in &world.positions {
            let way = position.wall_heading_deg;
            let p = position.in_corridor();
            let one_way = [way, way + 180.0].map(|d| network.against(p, p + step(d)));
            for facing in [way, way + 180.0] {
                // Beside an open side (a hall, a corridor's end) there is
                // no wall to step to: it stays on the middle.
                let Some((d, (left, right))) = start_leg(&world, &network, name, facing) else {
                    none.push(name.as_str());
                    break;
                };
                assert!(
                    left + right > 2_000.0,
                    "{name}: walls {left:.0} + {right:.0}"
                );
                let off = rome_maps::geometry::normalize_deg(d - facing).abs();
                if one_way.iter().any(|&a| a) {
                    assert!(!network.against(p, p + step(d)), "{name}: {d}° against");
                    turned += usize::from(off > 90.0);
                } else {
                    assert!(off < 1.0, "{name}: facing {facing}°, leg {d}°");
                }
            }
        }
        // Each position in a one-way stretch is faced against its way once.
        assert!(turned > 20, "{turned} legs turned to the way");
        assert!(
            none.len() * 10 < world.positions.len(),
            "no leg at {none:?}"
        );
    }

    #[test]
    fn a_robot_stopped_short_in_corridor_n_steps_aside_by_the_west_wall() {
        let (world, network) = eb3();
        let network = crate::traffic::oneway::with_one_way(&world, network);
        // Facing north or south, between doors, in N (one way south).
        for facing in [0.0, 180.0] {
            let at = Point::new(60_100.0, 30_000.0);
            let (d, (left, right)) = leg_at(&world, &network, at, facing, facing).expect("walls");
            assert!((d.abs() - 180.0).abs() < 1e-6, "facing {facing}°: leg {d}°");
            // Heading south, the right wall is the west one, at 58.78 m.
            assert!((right - 1_320.0).abs() < 50.0, "right wall {right:.0} mm");
            assert!(
                (left + right - 2_440.0).abs() < 50.0,
                "{left:.0} + {right:.0}"
            );
        }
    }

    /// The ranges a robot at `at` facing `heading_deg` hears from discs of
    /// the robot's size at `others` and from walls at x = `west` and
    /// `east` (a north-south corridor), mm, by casting each beam's middle.
    fn hear(at: Point, heading_deg: f64, others: &[Point], (west, east): (f64, f64)) -> Vec<u32> {
        (0..rome_schema::robot::SONARS)
            .map(|i| {
                let u = direction(heading_deg + sonar_bearing_deg(i));
                let mut best = 10_000.0_f64;
                for o in others {
                    let d = *o - at;
                    let b = d.dot(&u);
                    let c2 = d.norm_squared() - b * b;
                    let r2 = ROBOT_RADIUS_MM * ROBOT_RADIUS_MM;
                    if b > 0.0 && c2 < r2 {
                        best = best.min(b - (r2 - c2).sqrt());
                    }
                }
                for wall in [west, east] {
                    if u.x.abs() > 1e-9 {
                        let t = (wall - at.x) / u.x;
                        if t > 0.0 {
                            best = best.min(t);
                        }
                    }
                }
                (best - ROBOT_RADIUS_MM).clamp(150.0, 10_000.0) as u32
            })
            .collect()
    }

    #[test]
    fn a_robot_stands_fast_when_another_stands_beside_the_path_of_its_step() {
        // Corridor N, walls at x = 58.78 and 61.22 m. A robot arrived at
        // (60.0, 39.0) m heading south; its right is west. Another robot
        // stands aside by the west wall 0.73 m south of it: the step west
        // sweeps into it, though it is 45° off the way the step faces.
        let walls = (58_780.0, 61_220.0);
        let at = Point::new(60_000.0, 39_000.0);
        let leg = (180.0, (1_220.0, 1_220.0));
        let alone = hear(at, 180.0, &[], walls);
        assert!(step_is_clear(&alone, 180.0, leg), "{alone:?}");
        let other = Point::new(59_330.0, 38_280.0);
        let beside = hear(at, 180.0, &[other], walls);
        assert!(!step_is_clear(&beside, 180.0, leg), "{beside:?}");
        // Facing the other way it hears the same robot behind and to its
        // left, and the step is the same.
        let turned = hear(at, 0.0, &[other], walls);
        assert!(!step_is_clear(&turned, 0.0, leg), "{turned:?}");
        // A robot passing 0.9 m to the east is no hindrance.
        let passing = hear(at, 180.0, &[Point::new(60_900.0, 39_000.0)], walls);
        assert!(step_is_clear(&passing, 180.0, leg), "{passing:?}");
    }
}
