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
