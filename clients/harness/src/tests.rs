//! Tests of the crate root.

use super::*;

#[test]
fn a_routes_file_takes_speeds_and_the_long_way_round() {
    let routes = parse_routes(
        "t.routes",
        "# comment\n350R 376L\n345R 345L 600 via 359L 301.secondL\n341R 381R via 301.secondL\n",
    )
    .unwrap();
    assert_eq!(routes.len(), 3);
    assert_eq!((routes[0].robot.as_str(), routes[0].via.len()), ("r1", 0));
    assert_eq!(routes[1].cruise_mm_s, Some(600.0));
    assert_eq!(routes[1].via, ["359L", "301.secondL"]);
    assert_eq!(
        (routes[2].cruise_mm_s, routes[2].via.as_slice()),
        (None, &["301.secondL".to_string()][..])
    );
    for bad in [
        "350R 376L via",
        "350R",
        "350R 376L fast",
        "350R 376L 300 400 via A",
    ] {
        let e = parse_routes("t.routes", bad).unwrap_err().to_string();
        assert!(e.contains("t.routes:1"), "{bad}: {e}");
    }
}
