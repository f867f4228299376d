//! Where a robot out of service drives to get clear of the knot it was
//! blocked in ([`clear_to`]): a position a few metres along its route,
//! behind it first.

use rome_maps::geometry::Point;
use rome_maps::{Network, World};

/// How far along its route a position must be for a robot to drive to it
/// to get clear, mm: a nearer one lies in the knot the robot stood in.
pub const CLEAR_MIN_MM: f64 = 3_000.0;

/// How far from the robot, in a straight line, positions are looked at to
/// get clear, mm.
pub const CLEAR_NEAR_MM: f64 = 30_000.0;

/// The position a robot out of service at `at`, facing `heading_deg`,
/// drives to, to get clear of where it was blocked: one at least
/// [`CLEAR_MIN_MM`] along its route, behind the robot if any is (the way
/// it came, which it drove through; ahead is what blocked it), the
/// nearest by route of those (ties by name, so every run picks the
/// same), leaving out those it `tried` already. `None`: none within 30 m.
pub fn clear_to(
    world: &World,
    network: &Network,
    at: Point,
    heading_deg: f64,
    tried: &[String],
) -> Option<(String, f64)> {
    let ahead = rome_maps::geometry::direction(heading_deg);
    world
        .positions
        .iter()
        .filter(|(name, _)| !tried.contains(name))
        .filter_map(|(name, p)| {
            let off = p.in_corridor() - at;
            if off.norm() > CLEAR_NEAR_MM {
                return None;
            }
            let route = world.route_from(network, ("here", at), &[], name).ok()?;
            let in_front = off.dot(&ahead) > 0.0;
            (route.length_mm >= CLEAR_MIN_MM).then(|| (in_front, name.clone(), route.length_mm))
        })
        .min_by(|a, b| {
            (a.0.cmp(&b.0))
                .then_with(|| a.2.total_cmp(&b.2))
                .then_with(|| a.1.cmp(&b.1))
        })
        .map(|(_, name, length)| (name, length))
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::plan::tests::eb3;

    #[test]
    fn a_robot_gets_clear_behind_it_first_then_ahead_never_twice_to_one_place() {
        let (world, network) = eb3();
        // On A336L in corridor N, facing south (180°): that position, and
        // any under 3 m of route, is in the knot it stands in.
        let at = world.position("A336L").expect("A336L").in_corridor();
        let behind = |to: &str| {
            let p = world.position(to).expect("named").in_corridor();
            (p - at).dot(&rome_maps::geometry::direction(180.0)) <= 0.0
        };
        let mut tried = Vec::new();
        let mut seen_ahead = false;
        for _ in 0..12 {
            let (to, length) = clear_to(&world, &network, at, 180.0, &tried).expect("a position");
            assert!(length >= CLEAR_MIN_MM, "{to} is {length:.0} mm away");
            let far = (world.position(&to).expect("named").in_corridor() - at).norm();
            assert!(far <= CLEAR_NEAR_MM, "{to} is {far:.0} mm away");
            assert!(!tried.contains(&to), "{to} was tried already");
            // Every position behind before any ahead.
            assert!(
                !(seen_ahead && behind(&to)),
                "{to} behind after one ahead: {tried:?}"
            );
            seen_ahead |= !behind(&to);
            tried.push(to);
        }
        assert!(behind(&tried[0]), "{tried:?}");
        assert!(!tried.iter().any(|t| t == "A336L"), "{tried:?}");
    }

    #[test]
    fn a_robot_with_every_position_near_tried_has_nowhere_to_get_clear_to() {
        let (world, network) = eb3();
        let at = world.position("A336L").expect("A336L").in_corridor();
        let all: Vec<String> = world.positions.keys().cloned().collect();
        assert_eq!(clear_to(&world, &network, at, 0.0, &all), None);
        // Far from everything: nothing within reach either.
        let nowhere = Point::new(-1.0e6, -1.0e6);
        assert_eq!(clear_to(&world, &network, nowhere, 0.0, &[]), None);
    }
}
