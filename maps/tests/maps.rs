//! The shipped maps load, and their geometry is what the file says.

#![allow(clippy::unwrap_used)]

use rome_maps::geometry::{distance, pt, Point};
use rome_maps::{load, World};
use std::path::Path;

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
}

fn near(p: Point, q: (f64, f64)) -> bool {
    distance(p, pt(q.0, q.1)) < 1.0
}

#[test]
fn figure_5_3_loads_with_the_thesis_structure() {
    let map = load(&data("fig5_3.stk")).unwrap();
    let outer = map.ring("outer").unwrap();
    let names: Vec<&str> = outer.nodes.iter().map(|n| n.name.as_str()).collect();
    // §5.1: "A, L1, L2, B, X1, X2, Y2, Y1, C, D, E, and F".
    assert_eq!(
        names,
        ["A", "L1", "L2", "B", "X1", "X2", "Y2", "Y1", "C", "D", "E", "F"]
    );
    assert_eq!(map.ring("inner").unwrap().nodes.len(), 8);
    // E is a building corner with a 90° magnitude; X1..Y2 are not corners.
    let e = outer.nodes.iter().find(|n| n.name == "E").unwrap();
    assert!(e.is_corner() && e.angle_deg.abs() == 90.0);
    assert!(outer
        .nodes
        .iter()
        .filter(|n| n.name.starts_with(['X', 'Y']))
        .all(|n| !n.is_corner()));

    let world = World::from_map(&map);
    let at = |name: &str| world.position(name).unwrap().at;
    assert!(near(at("outer.B"), (40000.0, 30000.0)));
    assert!(near(at("outer.E"), (6000.0, 12000.0)));
    // The door L1L2: jambs 1.5 m apart on the north wall, L west of R.
    assert!(near(at("L1L2L"), (18000.0, 30000.0)));
    assert!(near(at("L1L2R"), (19500.0, 30000.0)));
    // The thesis' spellings of a jamb resolve alike.
    assert_eq!(world.position("301.R"), world.position("301R"));
    // The turning-space light (-19000 on L2B, -1500 on BX1) is one light,
    // where the two projections' perpendiculars cross.
    let turning: Vec<_> = world
        .lights
        .iter()
        .filter(|l| near(l.at, (38500.0, 28500.0)))
        .collect();
    assert_eq!(turning.len(), 1);
    // Every other light is 1.5 m into the corridor from its wall.
    assert!(world.lights.iter().any(|l| near(l.at, (10000.0, 28500.0))));
    assert!(world.lights.iter().any(|l| near(l.at, (7500.0, 15000.0))));
    assert_eq!(world.lights.len(), 2 + 5 + 6 + 2 + 3);
    assert_eq!(world.plates.len(), 3);
}

/// The heading of each leg, folded onto 0–90° from the nearest of a
/// corridor's two axes on these square maps (0 along, 90 across).
fn slants(route: &rome_maps::Route) -> Vec<f64> {
    route
        .legs()
        .iter()
        .map(|l| {
            let h = l.3.rem_euclid(90.0);
            h.min(90.0 - h)
        })
        .collect()
}

/// How near the straight line `p`–`q` comes to a wall of `world`, mm.
fn nearest_wall(world: &World, p: Point, q: Point) -> f64 {
    use rome_maps::geometry::distance_to_segment as to;
    (world.segments.iter())
        .filter(|s| s.kind != rome_maps::model::EdgeKind::Opening)
        .map(|s| {
            to(p, s.a, s.b)
                .min(to(q, s.a, s.b))
                .min(to(s.a, p, q))
                .min(to(s.b, p, q))
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_robot_standing_off_the_middle_leaves_with_room_for_its_body() {
    let map = load(&data("eb3.stk")).unwrap();
    let world = World::from_map(&map);
    let net = rome_maps::Network::new(&map, &world);
    // Stood aside in M, 0.53 m from its south wall and 0.03 m west of the
    // line of N's west wall, which ends there. Down N, the straight line
    // to a door clears that wall's end by a few centimetres: clear for a
    // point, not for a robot 0.76 m wide.
    let at = pt(58_750.0, 54_200.0);
    let here = nearest_wall(&world, at, at);
    let mut down_n = 0;
    for (name, position) in &world.positions {
        let q = position.in_corridor();
        if !(58_780.0..61_220.0).contains(&q.x) || q.y > 50_000.0 {
            continue;
        }
        down_n += 1;
        let r = world
            .route_from(&net, ("@58.75,54.20", at), &[], name)
            .unwrap();
        let first = nearest_wall(&world, r.points[0], r.points[1]);
        assert!(
            first >= rome_maps::route::BODY_CLEAR_MM.min(here) - 1.0,
            "{name}: the first leg {:?} comes {first:.0} mm from a wall",
            &r.points[..2]
        );
    }
    assert!(down_n > 10, "{down_n} positions down N");
}

#[test]
fn a_door_round_a_corner_is_reached_through_the_turning_space_not_across_it() {
    let map = load(&data("campus.stk")).unwrap();
    let world = World::from_map(&map);
    let net = rome_maps::Network::new(&map, &world);
    // 3019L is in the east corridor, 2.6 m south of its T with the
    // corridor of 2410R, 3 m to the west. The two see each other across
    // the turning space: the straight line is 3.97 m at 49°.
    for (from, to) in [("3019L", "2410R"), ("2410R", "3019L")] {
        let r = world.route(&net, from, &[], to).unwrap();
        assert_eq!(r.points.len(), 3, "{from} -> {to}: {:?}", r.points);
        assert!(near(r.points[1], (100_500.0, 37_000.0)), "{:?}", r.points);
        assert!((r.length_mm - 5600.0).abs() < 1.0, "{}", r.length_mm);
        assert_eq!(r.turns, 1);
        assert!(slants(&r).iter().all(|s| *s < 1.0), "{:?}", slants(&r));
    }
    // A door set in a turning space, a few degrees off the line of the
    // corridor crossing its own, still leaves straight down that corridor.
    let map = load(&data("annex.stk")).unwrap();
    let world = World::from_map(&map);
    let net = rome_maps::Network::new(&map, &world);
    let r = world.route(&net, "299L", &[], "203L").unwrap();
    assert_eq!(r.turns, 1, "{:?}", r.points);
    assert!((r.length_mm - 25_208.0).abs() < 1.0, "{}", r.length_mm);
}
