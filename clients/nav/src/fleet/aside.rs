//! Where a robot without a task waits: by the right-hand wall of the
//! corridor it stands in, not on its middle, where in a 2.44 m corridor no
//! other robot passes it untouched. The robot steps there with
//! [`crate::planner::step_aside`]; this module says from which leg: the
//! direction it steps along and the walls beside it. A robot that stands
//! where no walls are beside it (a junction) first drives on into a
//! corridor ([`way_out`], [`crate::planner::step_out`]).

use crate::board::Board;
use rome_client::RobotClient;
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

/// Steps a robot that stands on `leg`'s line over to the leg's right-hand
/// wall ([`crate::planner::step_aside`]), measured from the way its
/// odometry says it faces. `Some` says why it stands off that wall: the
/// Navigator ended the step, or ended it short (someone stood beside it,
/// or in the step's way).
pub async fn step_aside(board: &Board, robot: &RobotClient, leg: LastLeg) -> Option<String> {
    let (direction, walls) = leg;
    let facing = robot.pose().await.map_or(direction, |p| p.heading_deg);
    match crate::planner::step_aside(board, direction, walls, facing).await {
        Ok(None) => None,
        Ok(Some(why)) => Some(format!("the Navigator: {why}")),
        Err(e) => Some(e.to_string()),
    }
}

/// `leg` the other way along the corridor: its right-hand wall is the
/// other wall.
pub fn reversed((direction, (left, right)): LastLeg) -> LastLeg {
    let back = rome_maps::geometry::normalize_deg(direction + 180.0);
    (back, (right, left))
}

/// Where a robot that stood at `p` stands once it stepped aside from a leg
/// along `direction_deg` with the walls `(left, right)` beside its line
/// ([`crate::planner::step_aside`]): over to the right wall, as far as the
/// map's walls say, not as its odometry does, which may be turned by many
/// degrees where no light or wall has corrected it.
pub fn stood_aside(p: Point, direction_deg: f64, (_, right): (f64, f64)) -> Point {
    let over = (right - crate::planner::ASIDE_FROM_WALL_MM).max(0.0);
    p + rome_maps::geometry::direction(direction_deg - 90.0) * over
}

/// The axis of the corridor at `p`, degrees (either way): the wall of the
/// nearest position of the map within 3 m. A robot's odometry heading is no
/// measure of it where it stopped in a turn or swerved round someone.
/// `None`: no position that near.
pub fn corridor_axis(world: &World, p: Point) -> Option<f64> {
    world
        .positions
        .values()
        .map(|q| (rome_maps::geometry::distance(q.in_corridor(), p), q))
        .filter(|(d, _)| *d <= 3_000.0)
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, q)| q.wall_heading_deg)
}

/// Where a robot that stands with no walls beside it (in a junction, at a
/// corridor's mouth) drives before it steps aside: along or across the
/// corridor it stands in, to the first point, in steps of [`OUT_STEP_MM`],
/// that lies between a corridor's walls and is not reached against one-way
/// traffic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WayOut {
    /// Which way it drives, degrees.
    pub direction_deg: f64,
    /// How far, mm.
    pub distance_mm: f64,
    /// The walls (left, right) beside its line there, mm.
    pub walls: (f64, f64),
}

/// The steps in which a way out is looked for, mm.
pub const OUT_STEP_MM: f64 = 500.0;

/// How far along its way the walls must stand beside a robot's middle, mm,
/// either way, once it is out: its radius and 0.3 m, as its odometry may
/// be off by that.
pub const OUT_BODY_MM: f64 = crate::drive::ROBOT_RADIUS_MM + 300.0;

/// How far a way out may lead, mm: further, it is no step but a drive
/// across the building, and the robot stays where it is.
pub const OUT_MAX_MM: f64 = 6_000.0;

/// How near a way out may pass a robot that stands waiting, centre to
/// centre, mm: two bodies and 0.3 m. The drive out runs on the
/// corridor's middle, and a robot aside stands some 0.6 m off it.
pub const OUT_PASS_MM: f64 = 2.0 * crate::drive::ROBOT_RADIUS_MM + 300.0;

/// How near the end of a way out may lie to a robot that stands waiting,
/// mm: the robot steps aside there, up to 0.6 m across, and two robots
/// aside by one wall leave the corridor to those that pass.
pub const OUT_APART_MM: f64 = 2.0 * crate::drive::ROBOT_RADIUS_MM + 600.0;

/// The way out of the open for a robot at `p`, in a corridor along
/// `axis_deg` (either way), facing `facing_deg` ([`WayOut`]). A robot that
/// ended its task in a junction stands where every robot turning there
/// drives, with no wall to step aside to: it drives on into a corridor
/// first. The ways tried are along the axis and across it, the least
/// turning first. A way that passes within [`OUT_PASS_MM`] of a robot
/// standing at one of `waiting`, or ends within [`OUT_APART_MM`] of one,
/// is not taken: the first robot out of a junction would otherwise stand
/// where the next one's way out ends, and be driven into. `None`: walls
/// stand beside it already, or none within [`OUT_MAX_MM`] along a way
/// free of walls and robots.
pub fn way_out(
    world: &World,
    network: &Network,
    (p, axis_deg, facing_deg): (Point, f64, f64),
    waiting: &[Point],
) -> Option<WayOut> {
    use rome_maps::geometry::normalize_deg;
    if leg_at(world, network, p, axis_deg, facing_deg).is_some() {
        return None;
    }
    // Ahead first, then right (a turn to the right is negative), left, back.
    let mut ways = [0.0, 90.0, 180.0, 270.0].map(|a| normalize_deg(axis_deg + a));
    ways.sort_by(|a, b| {
        let (ta, tb) = (normalize_deg(a - facing_deg), normalize_deg(b - facing_deg));
        (ta.abs().round().total_cmp(&tb.abs().round())).then(ta.total_cmp(&tb))
    });
    let steps = (OUT_MAX_MM / OUT_STEP_MM) as usize;
    ways.into_iter().find_map(|direction_deg| {
        let along = rome_maps::geometry::direction(direction_deg);
        // The body's front edge must not reach a wall on the way.
        let free = crate::plan::ray(world, p, direction_deg, OUT_MAX_MM + 1_000.0)
            .map_or(f64::INFINITY, |d| d - crate::drive::ROBOT_RADIUS_MM - 100.0);
        (2..=steps)
            .map(|k| k as f64 * OUT_STEP_MM)
            .take_while(|&d| d <= free)
            .find_map(|distance_mm| {
                let q = p + along * distance_mm;
                if network.against(p, q) {
                    return None;
                }
                let in_the_way = |o: &Point| {
                    rome_maps::geometry::distance_to_segment(*o, p, q) < OUT_PASS_MM
                        || rome_maps::geometry::distance(*o, q) < OUT_APART_MM
                };
                if waiting.iter().any(in_the_way) {
                    return None;
                }
                // Walls beside the whole body, with room to spare: a robot
                // half in a corridor's mouth still stands in the way of
                // those that turn there.
                let beside = |k: f64| {
                    let at = q + along * k;
                    [90.0, -90.0].iter().all(|side| {
                        crate::plan::ray(world, at, direction_deg + side, 5_000.0).is_some()
                    })
                };
                if ![-OUT_BODY_MM, 0.0, OUT_BODY_MM].into_iter().all(beside) {
                    return None;
                }
                let (_, walls) = leg_at(world, network, q, direction_deg, direction_deg)?;
                // Room to pass it once it stands aside.
                (walls.0 + walls.1 > 2_000.0).then_some(())?;
                let walls = crate::plan::walls_beside(
                    world,
                    q - along * 1_000.0,
                    q + along * 1_000.0,
                    direction_deg,
                )?;
                Some(WayOut {
                    direction_deg,
                    distance_mm,
                    walls,
                })
            })
    })
}

/// How a step aside that did not happen is said, on its `tries`-th try
/// ([`super::duty::DutyNote::NotAside`]): "did not step aside: WHY", with
/// ", try N" from the second try on.
pub fn not_aside(why: &str, tries: u32) -> String {
    match tries {
        1 => format!("did not step aside: {why}"),
        n => format!("did not step aside, try {n}: {why}"),
    }
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

    #[test]
    fn a_robot_that_ended_in_a_junction_drives_on_into_the_corridor_before_it_steps_aside() {
        let (world, network) = eb3();
        let network = crate::traffic::oneway::with_one_way(&world, network);
        let mut out = Vec::new();
        for (name, position) in &world.positions {
            let way = position.wall_heading_deg;
            let p = position.in_corridor();
            for facing in [way, way + 180.0] {
                if start_leg(&world, &network, name, facing).is_some() {
                    assert_eq!(
                        way_out(&world, &network, (p, way, facing), &[]),
                        None,
                        "{name}"
                    );
                    continue;
                }
                let Some(w) = way_out(&world, &network, (p, way, facing), &[]) else {
                    continue;
                };
                let d = w.direction_deg;
                assert!(w.distance_mm <= OUT_MAX_MM, "{name}: {w:?}");
                let q = p + rome_maps::geometry::direction(d) * w.distance_mm;
                assert!(!network.against(p, q), "{name}: {w:?} against");
                assert!(leg_at(&world, &network, q, d, d).is_some(), "{name}: {w:?}");
                out.push(name.as_str());
            }
        }
        // A392's jambs lie in the T-junction at corridor N's foot, where
        // every robot coming down N turns: a way out from either facing.
        for name in ["A392R", "A392L"] {
            assert_eq!(out.iter().filter(|&&n| n == name).count(), 2, "{out:?}");
        }
        // Come straight down N (one way south), it faces P's south wall,
        // and N is behind it: it turns into P.
        let a392r = world.position("A392R").expect("A392R");
        let (p, way) = (a392r.in_corridor(), a392r.wall_heading_deg);
        let w = way_out(&world, &network, (p, way, 180.0), &[]).expect("a way out");
        assert_eq!(w.direction_deg.abs().round(), 90.0, "{w:?}");
        assert!(w.distance_mm <= 2_000.0, "{w:?}");
        assert!((w.walls.0 + w.walls.1 - 2_440.0).abs() < 50.0, "{w:?}");
        // Stopped short of A392L in a turn, its heading 143°, a robot is in
        // P (east-west), not across it; in N (north-south) likewise.
        let axis = |x: f64, y: f64| {
            let a = corridor_axis(&world, Point::new(x, y)).expect("a position near");
            rome_maps::geometry::normalize_deg(a).abs().round()
        };
        assert_eq!(axis(58_360.0, 6_560.0), 90.0);
        assert_eq!(axis(60_100.0, 30_000.0) % 180.0, 0.0);
    }

    #[test]
    fn a_robot_aside_stands_by_the_right_wall_as_the_map_has_it() {
        // Heading south down N, right is west: 1.22 m to the wall, less
        // its radius and 0.15 m.
        let q = stood_aside(Point::new(60_000.0, 30_000.0), 180.0, (1_220.0, 1_220.0));
        assert!(
            (q.x - 59_310.0).abs() < 1e-6 && (q.y - 30_000.0).abs() < 1e-6,
            "{q:?}"
        );
        // Heading east (-90°) in a 3.66 m hall, right is south.
        let q = stood_aside(Point::new(58_500.0, 55_500.0), -90.0, (1_830.0, 1_830.0));
        assert!(
            (q.x - 58_500.0).abs() < 1e-6 && (q.y - 54_200.0).abs() < 1e-6,
            "{q:?}"
        );
        // Already by the wall: it stays.
        let p = Point::new(1.0, 2.0);
        assert_eq!(stood_aside(p, 0.0, (2_000.0, 400.0)), p);
    }

    #[test]
    fn a_way_out_of_a_junction_neither_passes_nor_ends_at_a_robot_waiting_there() {
        let (world, network) = eb3();
        let network = crate::traffic::oneway::with_one_way(&world, network);
        let a392r = world.position("A392R").expect("A392R");
        let (p, way) = (a392r.in_corridor(), a392r.wall_heading_deg);
        let first = way_out(&world, &network, (p, way, 180.0), &[]).expect("a way out");
        let along = |w: &WayOut| rome_maps::geometry::direction(w.direction_deg);
        let end = p + along(&first) * first.distance_mm;
        // The first robot out stepped aside there, 0.6 m towards a wall.
        let side = rome_maps::geometry::direction(first.direction_deg - 90.0);
        let aside = end + side * 600.0;
        let next = way_out(&world, &network, (p, way, 180.0), &[aside]).expect("another way");
        let next_end = p + along(&next) * next.distance_mm;
        assert!(
            rome_maps::geometry::distance_to_segment(aside, p, next_end) >= OUT_PASS_MM,
            "{first:?} then {next:?}"
        );
        assert!(rome_maps::geometry::distance(aside, next_end) >= OUT_APART_MM);
        assert_ne!(first, next);
        assert!(leg_at(
            &world,
            &network,
            next_end,
            next.direction_deg,
            next.direction_deg
        )
        .is_some());
        // A robot far away changes nothing.
        let far = Point::new(10_000.0, 60_000.0);
        assert_eq!(
            way_out(&world, &network, (p, way, 180.0), &[far]),
            Some(first)
        );
    }
}
