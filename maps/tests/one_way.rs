//! A one-way stretch: which straight moves run against it.

use rome_maps::geometry::pt;
use rome_maps::OneWay;

/// Corridor stretch 40 m long, driven north, from (0, 0) to (0, 40) m.
fn north() -> OneWay {
    OneWay {
        a: pt(0.0, 0.0),
        b: pt(0.0, 40_000.0),
        reach_mm: 1_500.0,
    }
}

#[test]
fn a_move_inside_is_against_only_when_it_heads_back() {
    let w = north();
    assert!(w.against(pt(0.0, 30_000.0), pt(0.0, 10_000.0)));
    assert!(!w.against(pt(0.0, 10_000.0), pt(0.0, 30_000.0)));
    // Within the turning spaces at its ends, too.
    assert!(w.against(pt(0.0, 41_000.0), pt(0.0, -1_000.0)));
}

#[test]
fn a_line_of_sight_from_a_corridor_in_line_is_against_it() {
    let w = north();
    // From 20 m north of its end to a door inside, or straight through.
    assert!(w.against(pt(0.0, 60_000.0), pt(0.0, 20_000.0)));
    assert!(w.against(pt(0.0, 60_000.0), pt(0.0, -20_000.0)));
    assert!(w.against(pt(500.0, 60_000.0), pt(-500.0, 35_000.0)));
    // The same the right way is not.
    assert!(!w.against(pt(0.0, -20_000.0), pt(0.0, 60_000.0)));
}

#[test]
fn moves_that_only_reach_its_end_or_pass_beside_it_are_not() {
    let w = north();
    // Down the corridor in line, to the junction at its end.
    assert!(!w.against(pt(0.0, 60_000.0), pt(0.0, 40_000.0)));
    // Into its mouth no further than a turning space's reach.
    assert!(!w.against(pt(0.0, 60_000.0), pt(0.0, 39_000.0)));
    // Across its end, along the corridor it meets.
    assert!(!w.against(pt(-20_000.0, 40_000.0), pt(20_000.0, 40_000.0)));
    // South along a parallel corridor 5 m away.
    assert!(!w.against(pt(5_000.0, 60_000.0), pt(5_000.0, -20_000.0)));
}
