use super::*;

/// EB3's world and route network.
pub(crate) fn eb3() -> (World, Network) {
    let map = rome_maps::load_named("eb3").expect("eb3 loads");
    let world = World::from_map(&map);
    let net = Network::new(&map, &world);
    (world, net)
}

#[test]
fn a_straight_route_is_lights_then_dead_reckoning() {
    let (world, net) = eb3();
    let plan = Plan::new(&world, &net, "350R", "376L").expect("plan");
    let kinds: Vec<GoalType> = plan.steps.iter().map(|s| s.goal.goal_type).collect();
    assert_eq!(kinds, vec![GoalType::L, GoalType::D]);
    assert_eq!(
        plan.modes(),
        ModeCount {
            l: 1,
            c: 0,
            d: 1,
            v: 0
        }
    );
    let l = &plan.steps[0];
    assert_eq!(l.goal.distance as usize, l.light_offsets_mm.len());
    assert!(l.goal.distance >= 5, "78 m of corridor has many lights");
    // Corridor A is 3.66 m wide with its lights down the middle.
    let (left, right) = l.walls_mm.expect("both walls of corridor A");
    assert!((left - 1_830.0).abs() < 30.0, "{left}");
    assert!((right - 1_830.0).abs() < 30.0, "{right}");
    // Light offsets and the last leg add up to the route's length.
    let total: f64 = l.light_offsets_mm.iter().sum::<f64>() + plan.steps[1].goal.distance as f64;
    assert!(
        (total - plan.route.length_mm).abs() < 2.0,
        "{total} vs {}",
        plan.route.length_mm
    );
}

#[test]
fn a_plan_from_a_point_between_positions_starts_there() {
    // Two metres along corridor A from 350R towards 376L, where a
    // robot whose run failed might stand.
    let (world, net) = eb3();
    let whole = Plan::new(&world, &net, "350R", "376L").expect("plan");
    let (a, b) = whole.ends();
    let d = rome_maps::geometry::distance(a, b);
    let p = Point::new(
        a.x + (b.x - a.x) * 2_000.0 / d,
        a.y + (b.y - a.y) * 2_000.0 / d,
    );
    let plan = Plan::from_point(&world, &net, ("@here", p), &[], "376L").expect("plan");
    assert!(
        (plan.route.length_mm - (whole.route.length_mm - 2_000.0)).abs() < 1.0,
        "{} vs {}",
        plan.route.length_mm,
        whole.route.length_mm
    );
    assert_eq!(plan.route.stops[0], "@here");
    assert!(Plan::from_point(&world, &net, ("@here", p), &[], "nowhere").is_err());
}

#[test]
fn a_route_with_corners_has_enter_and_leave_corner_segments() {
    let (world, net) = eb3();
    let plan = Plan::new(&world, &net, "341L", "311R").expect("plan");
    assert_eq!(plan.route.turns, 2);
    let m = plan.modes();
    assert_eq!((m.c, m.d), (2, 1), "{:?}", plan.describe());
    assert!(m.l >= 2, "{:?}", plan.describe());
    // Every E is followed by a C that turns onto the next leg's heading.
    for w in plan.steps.windows(2) {
        if w[0].goal.goal_type == GoalType::E {
            assert_eq!(w[1].goal.goal_type, GoalType::C);
            assert_ne!(w[0].goal.direction_deg, w[1].goal.direction_deg);
        }
    }
    assert_eq!(
        plan.steps.last().map(|s| s.goal.goal_type),
        Some(GoalType::D)
    );
}

#[test]
fn the_long_way_round_goes_through_its_via_positions() {
    let (world, net) = eb3();
    let v = |names: &[&str]| names.iter().map(|n| (*n).to_string()).collect::<Vec<_>>();
    // Table 6.2 #6: "a complete cycle of the building", 337.007 m.
    let cycle =
        Plan::through(&world, &net, "345R", &v(&["359L", "301.secondL"]), "345L").expect("plan");
    assert!(
        (cycle.route.length_mm - 337_900.0).abs() < 500.0,
        "{}",
        cycle.route.length_mm
    );
    assert_eq!(cycle.route.turns, 4);
    assert_eq!(cycle.label(), "345R to 345L via 359L, 301.secondL");
    let m = cycle.modes();
    assert_eq!((m.c, m.d), (4, 1), "{:?}", cycle.describe());
    // The shortest way is the next door.
    let short = Plan::new(&world, &net, "345R", "345L").expect("plan");
    assert_eq!(short.label(), "345R to 345L");
    assert!(short.route.length_mm < 1_000.0);
    // A via position on the way adds no corner and no length.
    let direct = Plan::new(&world, &net, "350R", "376L").expect("plan");
    let through = Plan::through(&world, &net, "350R", &v(&["360L"]), "376L").expect("plan");
    assert_eq!(
        through.steps.len(),
        direct.steps.len(),
        "{:?}",
        through.describe()
    );
    assert!((through.route.length_mm - direct.route.length_mm).abs() < 1.0);
    // One behind the start makes the route turn back: refused, named.
    let err = Plan::through(&world, &net, "350R", &v(&["346L"]), "376L").expect_err("U-turn");
    assert!(
        matches!(&err, RouteError::TurnsBack { via, .. } if via == "346L"),
        "{err}"
    );
}

#[test]
fn unknown_rooms_are_named_with_suggestions() {
    let (world, net) = eb3();
    let err = Plan::new(&world, &net, "350R", "999X").expect_err("unknown");
    assert!(err.to_string().contains("999X"), "{err}");
    let err = Plan::new(&world, &net, "35OR", "376L").expect_err("typo");
    assert!(err.to_string().contains("did you mean"), "{err}");
}

#[test]
fn rooms_with_no_corridor_between_them_are_unreachable() {
    // Two separate square buildings, each a corridor ring, far apart.
    let ring = |name: &str, x: i64| {
        format!(
            "ring {name} at {x} 0 heading -90\n  node A -270\n  wall 4000 plate {name}1 2000\n  node B -270\n  wall 4000\n  node C -270\n  wall 4000\n  node D -270\n  wall 4000\nend\n"
        )
    };
    let text = format!(
        "map two buildings\ntolerance 50\nlateral 1000\n\n{}\n{}",
        ring("west", 0),
        ring("east", 100_000)
    );
    let map = rome_maps::from_text("two.stk".into(), &text).expect("the map loads");
    let world = World::from_map(&map);
    let net = Network::new(&map, &world);
    let err = Plan::new(&world, &net, "west.A", "east.A").expect_err("no corridor");
    assert!(
        err.to_string().contains("no way from 'west.A' to 'east.A'"),
        "{err}"
    );
}

#[test]
fn the_glass_door_goes_with_the_goals_near_it_across_the_way_ahead() {
    // Table 6.1's route into the glass door by the ACS laboratory: east
    // along corridor A to its end, then south.
    let (world, net) = eb3();
    let plan = Plan::new(&world, &net, "345R", "311.doubleL").expect("plan");
    assert_eq!(plan.glass.len(), 1, "EB3 has one glass door");
    let handed: Vec<Vec<[i64; 4]>> = plan.steps.iter().map(|s| s.glass_mm(&plan.glass)).collect();
    assert!(
        handed[0].is_empty(),
        "the first goal is far from it: {handed:?}"
    );
    let e = plan
        .steps
        .iter()
        .position(|s| s.goal.goal_type == GoalType::E)
        .expect("a corner");
    let [a_along, a_left, b_along, b_left] = *handed[e].first().expect("the corner's glass");
    // Straight ahead of the turning space's middle, where the map has the
    // end wall, and across the whole 3.66 m corridor.
    let end = plan.steps[e].end_wall_mm.expect("an end wall") as i64;
    assert!(
        (a_along - end).abs() <= 1 && (b_along - end).abs() <= 1,
        "{handed:?}"
    );
    assert_eq!(
        (a_left.min(b_left), a_left.max(b_left)),
        (-1_830, 1_830),
        "{handed:?}"
    );
    // The corner's C goal sets off beside it, so has it too.
    assert_eq!(plan.steps[e + 1].goal.goal_type, GoalType::C);
    assert_eq!(handed[e + 1].len(), 1);
}
