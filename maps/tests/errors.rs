//! Every broken map gets an error naming its file and line and what is
//! wrong. Each case is the good Figure 5.3 map with one thing broken.

#![allow(clippy::unwrap_used)]

use rome_maps::{parse, validate};

const GOOD: &str = include_str!("../data/fig5_3.stk");

/// The map with line `line` (1-based) replaced by `with`.
fn broken(line: usize, with: &str) -> String {
    GOOD.lines()
        .enumerate()
        .map(|(i, l)| if i + 1 == line { with } else { l })
        .collect::<Vec<_>>()
        .join("\n")
}

fn line_of(needle: &str) -> usize {
    GOOD.lines().position(|l| l.contains(needle)).unwrap() + 1
}

/// Parses (which must succeed) and validates; returns every problem as
/// "line: message".
fn problems(text: &str) -> Vec<String> {
    let map = parse("fig.stk", text).unwrap();
    validate(&map).iter().map(ToString::to_string).collect()
}

fn parse_error(text: &str) -> String {
    parse("fig.stk", text).unwrap_err().to_string()
}

fn assert_problem(text: &str, line: usize, words: &[&str]) {
    let found = problems(text);
    let hit = found
        .iter()
        .find(|p| p.starts_with(&format!("{line}: ")) && words.iter().all(|w| p.contains(w)));
    assert!(
        hit.is_some(),
        "no problem at line {line} with {words:?}: {found:#?}"
    );
}

#[test]
fn the_good_map_has_no_problems() {
    assert!(problems(GOOD).is_empty());
}

#[test]
fn a_ring_that_does_not_close() {
    let l = line_of("wall 34000");
    let ring = line_of("ring outer");
    assert_problem(
        &broken(l, "  wall 33000 lights 5000"),
        ring,
        &["misses closing by 1000 mm", "tolerance 50"],
    );
}

#[test]
fn angles_that_do_not_add_up() {
    let l = line_of("node X2 270");
    let ring = line_of("ring outer");
    let text = broken(l, "  node X2 250");
    assert_problem(&text, ring, &["turns", "add up to", "not ±360"]);
}

#[test]
fn an_angle_out_of_range() {
    let l = line_of("node X2 270");
    assert_problem(&broken(l, "  node X2 360"), l, &["between 0 and 360"]);
}

#[test]
fn duplicate_names() {
    let l = line_of("node X2 270");
    assert_problem(
        &broken(l, "  node X1 270"),
        l,
        &["node 'X1' is already in ring 'outer'"],
    );
    let l = line_of("ring inner");
    let text = broken(l, "ring outer at 37000 27000 heading 90");
    assert_problem(&text, l, &["ring 'outer' is already defined"]);
    let l = line_of("door 1000 number 302");
    assert_problem(
        &broken(l, "  door 1000 number 301"),
        l,
        &["door number '301' is already"],
    );
    let l = line_of("plate 302");
    assert_problem(
        &broken(l, "  wall 14000 plate 301 13700"),
        l,
        &["plate '301' is already"],
    );
}

#[test]
fn lights_outside_their_edge_or_unpaired() {
    let l = line_of("wall 24000 lights 12000 18000");
    assert_problem(
        &broken(l, "  wall 24000 lights 12000 25000"),
        l,
        &["light offset 25000 is outside"],
    );
    assert_problem(
        &broken(l, "  wall 24000 lights 12000 -18000"),
        l,
        &["negative light offset", "neither neighbouring"],
    );
}

#[test]
fn a_plate_off_its_wall() {
    let l = line_of("plate 301");
    assert_problem(
        &broken(l, "  wall 10000 plate 301 -5"),
        l,
        &["plate '301' at -5 mm is outside"],
    );
}

#[test]
fn a_numbered_wall() {
    let l = line_of("wall 13000");
    assert_problem(
        &broken(l, "  wall 13000 number 999"),
        l,
        &["a wall has no number"],
    );
}

#[test]
fn a_zero_length_edge() {
    let l = line_of("wall 2000");
    assert_problem(&broken(l, "  wall 0"), l, &["length must be positive"]);
}

#[test]
fn bad_links() {
    let l = line_of("link outer.A inner.Q");
    assert_problem(
        &broken(l, "link outer.A inner.Z"),
        l,
        &["node 'Z'", "ring 'inner'"],
    );
    assert_problem(&broken(l, "link outer.A nowhere.Q"), l, &["ring 'nowhere'"]);
    assert_problem(
        &broken(l, "link outer.A outer.B"),
        l,
        &["both ends are on 'outer'"],
    );
    assert_problem(
        &broken(l, "link outer.A inner.S"),
        l,
        &["spans", "at most 10 m"],
    );
}

#[test]
fn a_ring_with_too_few_nodes() {
    let text = "ring tiny at 0 0 heading 0\nnode A -90\nwall 10\nnode B -90\nwall 10\nend\n";
    assert_problem(text, 1, &["2 node(s)", "at least 3"]);
}

#[test]
fn syntax_errors_name_file_and_line() {
    let cases: Vec<(String, usize, &str)> = vec![
        (
            broken(line_of("node X2 270"), "  nod X2 270"),
            line_of("node X2 270"),
            "unknown statement 'nod'",
        ),
        (
            broken(line_of("node X2 270"), "  node X2 right"),
            line_of("node X2 270"),
            "adjacency angle (degrees) must be a number, got 'right'",
        ),
        (
            broken(line_of("node X2 270"), "  node X2"),
            line_of("node X2 270"),
            "missing adjacency angle",
        ),
        (
            broken(line_of("wall 2000"), "  wall 2000 colour=red lamp 5"),
            line_of("wall 2000"),
            "unknown edge option 'lamp'",
        ),
        (
            broken(line_of("wall 2000"), "  wall 2000 lights"),
            line_of("wall 2000"),
            "'lights' needs at least one offset",
        ),
        (
            broken(line_of("wall 2000"), "  wall 2000 lights 500 nan"),
            line_of("wall 2000"),
            "light offset (mm) must be finite, got 'nan'",
        ),
        (
            broken(line_of("wall 4000"), "  node Z 180"),
            line_of("wall 4000"),
            "two nodes in a row",
        ),
        (
            broken(line_of("node Y2 270"), "  wall 10"),
            line_of("node Y2 270"),
            "two edges in a row",
        ),
        (
            broken(line_of("ring outer"), "ring outer at 0 north heading -90"),
            line_of("ring outer"),
            "y (mm) must be a number",
        ),
        (
            broken(line_of("ring outer"), "ring out.er at 0 0 heading -90"),
            line_of("ring outer"),
            "may not contain '.'",
        ),
        (
            broken(line_of("tolerance 50"), "tolerance -5"),
            line_of("tolerance 50"),
            "tolerance must be positive",
        ),
        (
            broken(line_of("link outer.A inner.Q"), "link outerA inner.Q"),
            line_of("link outer.A inner.Q"),
            "must be ring.node",
        ),
    ];
    for (text, line, words) in cases {
        let e = parse_error(&text);
        assert!(e.starts_with(&format!("fig.stk:{line}: ")), "{e}");
        assert!(e.contains(words), "{e}");
    }
    // A ring whose closing edge is missing, and one never closed.
    let end = GOOD.lines().position(|l| l.trim() == "end").unwrap() + 1;
    let e = parse_error(&broken(end - 1, ""));
    assert!(
        e.starts_with(&format!("fig.stk:{end}: "))
            && e.contains("needs the edge from 'F' back to 'A'"),
        "{e}"
    );
    let e = parse_error(&broken(end, ""));
    assert!(
        e.contains("is not closed with 'end' before a new ring"),
        "{e}"
    );
    let e = parse_error("map empty\n");
    assert!(e.contains("the map has no rings"), "{e}");
}

#[test]
fn a_marker_that_is_bad_misplaced_or_shared() {
    let l = line_of("door 1000 number 302");
    let elevator = |marker: &str| format!("  elevator 1000 number 302 marker={marker}");
    assert!(problems(&broken(l, &elevator("101"))).is_empty());
    assert_problem(
        &broken(l, &elevator("110")),
        l,
        &["marker '110'", "side by side"],
    );
    assert_problem(&broken(l, &elevator("1012")), l, &["3 binary digits"]);
    assert_problem(
        &broken(l, "  door 1000 number 302 marker=101"),
        l,
        &["a door has no marker", "elevator doors"],
    );
    // Two elevators with one code: the second is named.
    let m = line_of("door 1000 number 301");
    let text = broken(l, &elevator("010"));
    let text = text
        .lines()
        .enumerate()
        .map(|(i, s)| {
            if i + 1 == m {
                "  elevator 1000 number 301 marker=010"
            } else {
                s
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let (first, second) = (l.min(m), l.max(m));
    assert_problem(
        &text,
        second,
        &[
            "marker 010 is already on line",
            &first.to_string(),
            "its own code",
        ],
    );
}
