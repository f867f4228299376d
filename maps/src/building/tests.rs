use super::*;
use crate::{load_building_named, load_named};

fn tower() -> Building {
    load_building_named("tower").expect("the tower loads")
}

#[test]
fn the_tower_has_three_floors_joined_by_both_elevators() {
    let t = tower();
    let names: Vec<&str> = t.floors.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["3", "4", "5"]);
    let shafts: Vec<(&str, &[usize])> = t
        .elevators
        .iter()
        .map(|e| (e.number.as_str(), e.floors.as_slice()))
        .collect();
    assert_eq!(
        shafts,
        [
            ("acs.elev", &[0, 1, 2][..]),
            ("old.elevator", &[0, 1, 2][..])
        ]
    );
    // Each floor has its own room numbers.
    assert!(t.floors[1].world.position("450R").is_some());
    assert!(t.floors[1].world.position("350R").is_none());
}

#[test]
fn a_route_between_floors_rides_the_elevator_that_makes_the_walk_shortest() {
    let t = tower();
    let r = t.route("3:350R", "5:576L").unwrap();
    let ride = r.ride.clone().expect("rides an elevator");
    assert_eq!(r.walks.len(), 2);
    assert_eq!((r.walks[0].0, r.walks[1].0), (0, 2));
    assert_eq!(r.walks[0].1.stops, ["350R", ride.as_str()]);
    assert_eq!(r.walks[1].1.stops, [ride.as_str(), "576L"]);
    // The walk on each floor starts or ends at the door the floor's map has.
    let door_3 = door(&t.floors[0].world, &ride).unwrap();
    let end = *r.walks[0].1.points.last().unwrap();
    assert!((end - door_3).norm() < 1.0, "ends at the elevator door");
    // No other elevator gives a shorter walk.
    for other in t.elevators.iter().filter(|e| e.number != ride) {
        let w3 = t.floors[0].world.route(
            &Network::new(&t.floors[0].map, &t.floors[0].world),
            "350R",
            &[],
            &format!("{}L", other.number),
        );
        let w5 = t.floors[2].world.route(
            &Network::new(&t.floors[2].map, &t.floors[2].world),
            &format!("{}L", other.number),
            &[],
            "576L",
        );
        let via_other = w3.unwrap().length_mm + w5.unwrap().length_mm;
        // Within the door's width of the jamb used here.
        assert!(
            r.walked_mm() <= via_other + 2_100.0,
            "{} vs {via_other} via {}",
            r.walked_mm(),
            other.number
        );
    }
    // On one floor, the route is the floor's own.
    let same = t.route("4:450R", "4:476L").unwrap();
    assert!(same.ride.is_none());
    let eb3 = load_named("eb3").unwrap();
    let world = World::from_map(&eb3);
    let plain = world
        .route(&Network::new(&eb3, &world), "350R", &[], "376L")
        .unwrap();
    assert!((same.walked_mm() - plain.length_mm).abs() < 1e-6);
}

#[test]
fn positions_name_their_floor_and_a_wrong_one_is_named() {
    let t = tower();
    let e = t.route("9:350R", "3:376L").unwrap_err().to_string();
    assert!(e.contains("'9:350R'") && e.contains("3:350R"), "{e}");
    // Only floors that have a 350R are suggested.
    assert!(!e.contains("4:350R"), "{e}");
    let e = t.route("4:350R", "3:376L").unwrap_err().to_string();
    assert!(e.contains("'4:350R'") && e.contains("4:350"), "{e}");
}

#[test]
fn an_elevator_on_one_floor_only_is_an_error_at_its_line() {
    let text = "building two floors\nfloor 3 eb3\nfloor 1 annex\n";
    let e = building_from_text("test.bldg", text, load_named)
        .unwrap_err()
        .to_string();
    let eb3_line = load_named("eb3")
        .unwrap()
        .rings
        .iter()
        .flat_map(|r| &r.edges)
        .find(|e| e.number.as_deref() == Some("acs.elev"))
        .unwrap()
        .line;
    assert!(
        e.contains(&format!(
            "eb3:{eb3_line}: elevator 'acs.elev' is on floor '3' only (test.bldg:2)"
        )),
        "{e}"
    );
    assert!(e.contains("old.elevator"), "{e}");
}

#[test]
fn bad_statements_and_floors_are_errors_with_their_line() {
    let text = "building b\nfloor 3 eb3\nfloor 3 eb3\nfloor 4\nlift 3 4\nfloor 5 nowhere.stk\n";
    let e = building_from_text("b.bldg", text, load_named)
        .unwrap_err()
        .to_string();
    assert!(e.contains("b.bldg:3: floor '3' is named twice"), "{e}");
    assert!(e.contains("b.bldg:4: a floor is `floor NAME MAP`"), "{e}");
    assert!(
        e.contains("b.bldg:5: not a building statement: 'lift 3 4'"),
        "{e}"
    );
    assert!(
        e.contains("b.bldg:6: floor '5': its map 'nowhere.stk' does not load"),
        "{e}"
    );
    assert!(e.contains("cannot read nowhere.stk"), "{e}");
}

#[test]
fn an_elevator_carries_one_code_on_every_floor_and_no_other_has_it() {
    let tower = tower();
    let codes: Vec<String> = tower
        .elevators
        .iter()
        .map(|e| {
            let (code, _) = marker_of(&tower.floors[0].map, &e.number).expect("a marker");
            format!("{} {code}", e.number)
        })
        .collect();
    assert_eq!(codes, ["acs.elev 010", "old.elevator 101"]);
    // Floor 4 repaints acs.elev; floor 5 gives old.elevator acs.elev's code.
    let repaint = |name: &str| {
        let mut map = load_named(name)?;
        let (number, code) = match name {
            "tower-4" => ("acs.elev", "100"),
            "tower-5" => ("old.elevator", "010"),
            _ => return Ok(map),
        };
        for e in map.rings.iter_mut().flat_map(|r| r.edges.iter_mut()) {
            if e.number.as_deref() == Some(number) {
                e.tags.insert("marker".into(), code.into());
            }
        }
        Ok(map)
    };
    let text = "building b\nfloor 3 eb3\nfloor 4 tower-4\nfloor 5 tower-5\n";
    let e = building_from_text("b.bldg", text, repaint)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("elevator 'acs.elev' has marker 100 on floor '4' but 010 on floor '3'"),
        "{e}"
    );
    assert!(
        e.contains("elevator 'old.elevator' has marker 010, as elevator 'acs.elev' has"),
        "{e}"
    );
    assert!(e.starts_with("tower-4:"), "{e}");
}

#[test]
fn elevators_drawn_without_markers_get_the_codes_no_other_has() {
    // The tower with old.elevator's marker left off every floor: it gets
    // the first code acs.elev (010) does not have.
    let bare = |name: &str| {
        let mut map = load_named(name)?;
        for e in map.rings.iter_mut().flat_map(|r| r.edges.iter_mut()) {
            if e.number.as_deref() == Some("old.elevator") {
                e.tags.remove("marker");
            }
        }
        Ok(map)
    };
    let text = "building b\nfloor 3 eb3\nfloor 4 tower-4\n";
    let b = building_from_text("b.bldg", text, bare).expect("loads");
    for f in 0..2 {
        let code = |n: &str| marker_of(&b.floors[f].map, n).map(|(c, _)| c.to_string());
        assert_eq!(code("acs.elev").as_deref(), Some("010"));
        assert_eq!(code("old.elevator").as_deref(), Some("000"), "floor {f}");
    }
}
