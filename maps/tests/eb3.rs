//! The EB3 reconstruction: the structure the thesis describes, and the routes
//! of Tables 6.1–6.2 near their published lengths (docs/eb3.md).

#![allow(clippy::unwrap_used)]

use rome_maps::model::EdgeKind;
use rome_maps::{load, Map, Network, World};
use std::path::Path;

fn eb3() -> (Map, World, Network) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/eb3.stk");
    let map = load(&path).unwrap();
    let world = World::from_map(&map);
    let net = Network::new(&map, &world);
    (map, world, net)
}

/// (from, via, to, thesis length m, thesis corners) — the via points put the
/// route on the long way round where the thesis' run took it.
const ROUTES: &[(&str, &[&str], &str, f64, usize)] = &[
    ("350R", &[], "376L", 78.181, 0),
    ("381L", &[], "343R", 73.863, 0),
    ("346L", &[], "388R", 107.95, 0),
    ("341L", &[], "311R", 91.795, 2),
    ("303.second.R", &[], "350R", 106.984, 2),
    ("345R", &[], "311.double.R", 105.714, 2),
    ("341L", &[], "311L", 89.966, 2),
    ("303.second.L", &[], "350R", 107.899, 2),
    ("345R", &[], "311R", 96.774, 2),
    ("303.second.L", &[], "350L", 106.070, 2),
    ("345R", &[], "311.doubleL", 103.886, 2),
    ("NE.men.R", &[], "302R", 120.650, 6),
    ("301R", &[], "350R", 154.686, 6),
    ("350R", &[], "372L", 59.740, 0),
    ("381R", &[], "NE.men.R", 92.354, 0),
    ("acs.elev.R", &[], "376R", 89.052, 0),
    ("302L", &[], "A340R", 35.585, 1),
    ("A392L", &[], "A340R", 15.113, 1),
    ("311L", &["301R"], "381R", 171.754, 8),
    ("323L", &["301R"], "381R", 197.358, 9),
    ("341R", &["311L", "388R"], "381R", 260.807, 10),
    ("345R", &["311L", "388R"], "345L", 337.007, 10),
    ("A313L", &[], "345L", 98.958, 2),
    ("NE.women.L", &["A305R", "A355L"], "A314R", 203.911, 7),
    ("A314R", &[], "345R", 101.904, 2),
    ("NW.men'sL", &[], "A314R", 142.748, 6),
    ("A342L", &[], "A323R", 38.633, 0),
    ("A347L", &[], "A385R", 103.530, 2),
    ("A365L", &[], "301R", 69.900, 1),
];

#[test]
fn every_route_of_tables_6_1_and_6_2_is_within_three_percent() {
    let (_, world, net) = eb3();
    let mut worst = Vec::new();
    for &(from, via, to, thesis, _) in ROUTES {
        let r = world.route(&net, from, via, to).unwrap();
        let err = (r.length_mm / 1000.0 - thesis) / thesis;
        if err.abs() > 0.03 {
            worst.push(format!(
                "{from} -> {to}: {:.3} m vs {thesis}",
                r.length_mm / 1000.0
            ));
        }
        // A route is never shorter than the straight line.
        let (a, b) = (world.position(from).unwrap(), world.position(to).unwrap());
        assert!(
            r.length_mm + 1.0 >= rome_maps::geometry::distance(a.in_corridor(), b.in_corridor())
        );
    }
    assert_eq!(worst.len(), 0, "{worst:?}");
}

#[test]
fn straight_routes_have_no_corner_and_old_wing_corner_routes_two() {
    let (_, world, net) = eb3();
    for &(from, via, to, _, corners) in ROUTES {
        let r = world.route(&net, from, via, to).unwrap();
        if corners == 0 || (corners == 2 && via.is_empty() && !from.starts_with('A')) {
            assert_eq!(r.turns, corners, "{from} -> {to}");
        }
    }
}

#[test]
fn the_floor_has_the_structure_the_thesis_describes() {
    let (map, world, _) = eb3();
    // Appendix A: four rings, the first enclosing the other three.
    assert_eq!(map.rings.len(), 4);
    let (lo, hi) = world.bounds();
    let (w, h) = ((hi.x - lo.x) / 1000.0, (hi.y - lo.y) / 1000.0);
    assert!(
        (115.0..136.0).contains(&w) && (95.0..116.0).contains(&h),
        "{w} x {h}"
    );
    // Corridors G, N and J have exactly two ceiling lights each.
    for corridor in ["G", "N", "J"] {
        let x = match corridor {
            "G" => 8_000.0,
            "N" => 60_000.0,
            _ => 112_000.0,
        };
        let n = world
            .lights
            .iter()
            .filter(|l| (l.at.x - x).abs() < 1_500.0 && l.at.y > 8_000.0 && l.at.y < 53_000.0)
            .count();
        assert_eq!(n, 2, "corridor {corridor}");
    }
    // Old wing corridors are wider than the new wing's.
    let lateral = |name: &str| world.position(name).unwrap().lateral_mm;
    assert!(lateral("350R") > lateral("A340R"));
    // A glass door, a metal floor, two elevators, every room of Tables 6.1–6.3.
    let edges: Vec<_> = map.rings.iter().flat_map(|r| &r.edges).collect();
    assert!(edges.iter().any(|e| e.kind == EdgeKind::Glass));
    assert!(edges
        .iter()
        .any(|e| e.tags.get("floor").map(String::as_str) == Some("metal")));
    assert_eq!(
        edges
            .iter()
            .filter(|e| e.kind == EdgeKind::Elevator)
            .count(),
        2
    );
    for room in [
        "350",
        "376",
        "381",
        "343",
        "346",
        "388",
        "341",
        "311",
        "303.second",
        "345",
        "311.double",
        "NE.men",
        "302",
        "301",
        "372",
        "acs.elev",
        "A340",
        "A392",
        "323",
        "A313",
        "NE.women",
        "A314",
        "NW.men's",
        "A342",
        "A323",
        "A347",
        "A385",
        "A365",
        "352",
        "384",
        "364.double",
        "old.elevator",
        "339",
        "350.1",
        "350.2",
        "317.1",
        "317.2",
        "314",
        "340.cmptr.room",
        "A395",
        "A397",
    ] {
        for side in ["L", "R"] {
            assert!(
                world.position(&format!("{room}{side}")).is_some(),
                "{room}{side}"
            );
        }
    }
}

#[test]
fn unknown_rooms_are_named_with_suggestions() {
    let (_, world, net) = eb3();
    let err = world
        .route(&net, "350X", &[], "376L")
        .unwrap_err()
        .to_string();
    assert!(err.contains("'350X'") && err.contains("350L"), "{err}");
}
