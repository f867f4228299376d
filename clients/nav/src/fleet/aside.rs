//! Where a robot without a task waits: by the right-hand wall of the
//! corridor it stands in, not on its middle, where in a 2.44 m corridor no
//! other robot passes it untouched. The robot steps there with
//! [`crate::planner::step_aside`]; this module says from which leg: the
//! direction it steps along and the walls beside it.

use rome_maps::geometry::Point;
use rome_maps::{Network, World};

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
}
