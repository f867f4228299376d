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

#[test]
fn a_crew_s_lines_name_its_robot_under_a_filter_for_the_navigation_clients_alone() {
    // The filter a user sets to follow the Navigator's steps: warnings,
    // and the navigation clients' debug lines.
    let filter = tracing_subscriber::EnvFilter::new("warn,rome_nav::navigator=debug");
    let subscriber = tracing_subscriber::fmt().with_env_filter(filter).finish();
    tracing::subscriber::with_default(subscriber, || {
        let span = crew_span("r2");
        assert!(
            !span.is_disabled(),
            "the crew span is filtered out: the Navigator's lines would not say whose they are"
        );
    });
}
