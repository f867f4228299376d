use super::*;
use crate::plan::Plan;
use rome_maps::World;
use std::collections::HashMap;

/// A small generator of numbers from a seed (no dependency needed).
struct Rng(u64);

impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 33) % n.max(1) as u64) as usize
    }
}

fn hold(semaphore: &str, first: usize, last: usize) -> Hold {
    Hold {
        semaphore: semaphore.into(),
        first,
        last,
    }
}

#[test]
fn waypoints_of_one_crossing_are_one_junction_numbered_west_to_east() {
    let j = Junctions::from_points(&[
        Point::new(10_000.0, 0.0),
        Point::new(0.0, 0.0),
        Point::new(1_200.0, 0.0),
        Point::new(0.0, 1_200.0),
        Point::new(1_200.0, 1_200.0),
    ]);
    assert_eq!(j.len(), 2);
    assert_eq!(j.centre(0), Point::new(600.0, 600.0));
    assert_eq!(j.centre(1), Point::new(10_000.0, 0.0));
    // A line through the crossing uses it; one 2 m beside it does not.
    assert_eq!(
        j.on_line(Point::new(600.0, -5_000.0), Point::new(600.0, 5_000.0)),
        [0]
    );
    assert!(j
        .on_line(Point::new(2_700.0, -5_000.0), Point::new(2_700.0, 5_000.0))
        .is_empty());
}

#[test]
fn overlapping_holds_are_one_chain_taken_in_name_order() {
    let c = chains(&[
        hold("$traffic/junction/007", 0, 1),
        hold("$passage/N", 1, 4),
        hold("$traffic/junction/002", 4, 5),
        hold("$traffic/junction/009", 6, 7),
        hold("$traffic/junction/007", 9, 9),
    ]);
    assert_eq!(c.len(), 3);
    assert_eq!((c[0].first, c[0].last), (0, 5));
    let names: Vec<&str> = c[0].holds.iter().map(|h| h.semaphore.as_str()).collect();
    assert_eq!(
        names,
        [
            "$passage/N",
            "$traffic/junction/002",
            "$traffic/junction/007"
        ]
    );
    // After step 5 the robot holds nothing: step 6 starts a chain of its own.
    assert_eq!((c[1].first, c[1].last), (6, 7));
    assert_eq!((c[2].first, c[2].holds.len()), (9, 1));
}

/// How a robot takes what it holds, for the model below.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Discipline {
    /// Whole chains, each part in name order, before the chain's first step.
    Chains,
    /// Each part just before the first step that uses it, as it comes
    /// along the route: what robots would do without the chains.
    AsItComes,
}

/// One robot in the model: its steps, and what it takes before each.
struct Robot {
    /// Before step i: the parts to take, in order.
    take: Vec<Vec<String>>,
    /// After step i: the parts to give back.
    give: Vec<Vec<String>>,
    /// The next step to drive.
    step: usize,
    /// How many of `take[step]` it has.
    taken: usize,
}

impl Robot {
    fn new(holds: &[Hold], steps: usize, discipline: Discipline) -> Robot {
        let mut take = vec![Vec::new(); steps];
        let mut give = vec![Vec::new(); steps];
        match discipline {
            Discipline::Chains => {
                for c in chains(holds) {
                    for h in &c.holds {
                        take[c.first].push(h.semaphore.clone());
                        give[h.last].push(h.semaphore.clone());
                    }
                }
            }
            Discipline::AsItComes => {
                // What it leaves soonest first: the junction it drives into
                // before the passage beyond.
                let mut holds: Vec<&Hold> = holds.iter().collect();
                holds.sort_by_key(|h| (h.first, h.last));
                for h in holds {
                    take[h.first].push(h.semaphore.clone());
                    give[h.last].push(h.semaphore.clone());
                }
            }
        }
        Robot {
            take,
            give,
            step: 0,
            taken: 0,
        }
    }

    fn done(&self) -> bool {
        self.step == self.take.len()
    }
}

/// Whether robot `r` may take `part` now, given who holds what: a
/// junction or passage when nobody else holds it, a lane's way when
/// nobody holds the other way (a lane's gate only makes the ways take
/// turns; who may be in the lane together is this).
fn free(held: &HashMap<String, Vec<usize>>, part: &str, r: usize) -> bool {
    let others = |p: &str| held.get(p).is_some_and(|h| h.iter().any(|&x| x != r));
    match lanes::Lane::of(part) {
        Some(lane) => !others(&lane.other),
        None => !others(part),
    }
}

/// Runs robots with a random interleaving: at each turn one robot that
/// can act takes its next part or drives its next step. Junctions and
/// passages have one unit; a lane is shared by robots going one way.
/// Returns the robots that wait for each other when nobody can act before
/// all are done: a deadlock.
fn run(mut robots: Vec<Robot>, rng: &mut Rng) -> Option<Vec<usize>> {
    let mut held: HashMap<String, Vec<usize>> = HashMap::new();
    loop {
        let can: Vec<usize> = (0..robots.len())
            .filter(|&r| {
                let robot = &robots[r];
                if robot.done() {
                    return false;
                }
                match robot.take[robot.step].get(robot.taken) {
                    Some(part) => free(&held, part, r),
                    None => true,
                }
            })
            .collect();
        if can.is_empty() {
            let stuck: Vec<usize> = (0..robots.len()).filter(|&r| !robots[r].done()).collect();
            return (!stuck.is_empty()).then_some(stuck);
        }
        let r = can[rng.below(can.len())];
        let robot = &mut robots[r];
        match robot.take[robot.step].get(robot.taken) {
            Some(part) => {
                held.entry(part.clone()).or_default().push(r);
                robot.taken += 1;
            }
            None => {
                for part in &robot.give[robot.step] {
                    if let Some(h) = held.get_mut(part) {
                        h.retain(|&x| x != r);
                    }
                }
                robot.step += 1;
                robot.taken = 0;
            }
        }
    }
}

/// Routes between random doors of a built-in map, as plans' holds.
fn routes_on(map: &str, n: usize, rng: &mut Rng) -> Vec<(Vec<Hold>, usize)> {
    let map = rome_maps::load_named(map).unwrap();
    let world = World::from_map(&map);
    let network = Network::new(&map, &world);
    let doors: Vec<&String> = world
        .positions
        .keys()
        .filter(|n| !n.contains('.'))
        .collect();
    let mut out = Vec::new();
    while out.len() < n {
        let (a, b) = (doors[rng.below(doors.len())], doors[rng.below(doors.len())]);
        if let Ok(plan) = Plan::new(&world, &network, a, b) {
            out.push((plan.holds.clone(), plan.steps.len()));
        }
    }
    out
}

/// Routes on a made-up network: random walks over `junctions` junctions,
/// each visit a turn (enter and leave) with straight stretches between.
fn made_up_routes(junctions: usize, n: usize, rng: &mut Rng) -> Vec<(Vec<Hold>, usize)> {
    (0..n)
        .map(|_| {
            let mut holds = Vec::new();
            let mut step = 0;
            for _ in 0..1 + rng.below(6) {
                step += 1 + rng.below(2);
                let k = rng.below(junctions);
                // Enter and leave; sometimes a passage runs on to the next.
                holds.push(hold(&Junctions::semaphore(k), step, step + 1));
                if rng.below(4) == 0 {
                    holds.push(hold(&format!("$passage/p{}", rng.below(3)), step, step + 3));
                }
                // Sometimes a lane, either way, runs on from the turn.
                if rng.below(3) == 0 {
                    let way = ["up", "down"][rng.below(2)];
                    let lane = format!("$traffic/lane/00{}-00{}/{way}", k, rng.below(junctions));
                    holds.push(hold(&lane, step + 1, step + 2 + rng.below(2)));
                }
                step += 1;
            }
            (holds, step + 4)
        })
        .collect()
}

fn deadlocks(
    routes: &[(Vec<Hold>, usize)],
    discipline: Discipline,
    schedules: usize,
    rng: &mut Rng,
) -> usize {
    (0..schedules)
        .filter(|_| {
            let robots = routes
                .iter()
                .map(|(h, steps)| Robot::new(h, *steps, discipline))
                .collect();
            run(robots, rng).is_some()
        })
        .count()
}

/// No circular wait, whatever the routes and the order robots act in: on
/// the built-in maps with up to 40 robots, and on made-up networks.
#[test]
fn robots_taking_whole_chains_in_name_order_never_wait_in_a_circle() {
    let mut rng = Rng(35);
    for map in ["eb3", "annex", "campus", "fig5_3"] {
        for n in [2, 10, 40] {
            let routes = routes_on(map, n, &mut rng);
            assert_eq!(
                deadlocks(&routes, Discipline::Chains, 20, &mut rng),
                0,
                "{map}, {n} robots"
            );
        }
    }
    for case in 0..200 {
        let routes = made_up_routes(2 + case % 6, 2 + case % 9, &mut rng);
        assert_eq!(
            deadlocks(&routes, Discipline::Chains, 10, &mut rng),
            0,
            "made-up case {case}"
        );
    }
}

/// EB3 with corridor N (the new wing's middle corridor, x = 60 m) marked
/// as the narrow passage `N`, and plans through it head-on.
fn head_on_through_corridor_n() -> Vec<(Vec<Hold>, usize)> {
    let mut map = rome_maps::load_named("eb3").unwrap();
    let world = World::from_map(&map);
    for s in &world.segments {
        let along_n = (s.a.x - 60_000.0).abs() < 1_500.0
            && (s.b.x - 60_000.0).abs() < 1_500.0
            && s.a.y.min(s.b.y) > 8_000.0
            && s.a.y.max(s.b.y) < 54_000.0;
        if along_n {
            let edge = &mut map.rings[s.ring].edges[s.edge];
            edge.tags.insert("passage".into(), "N".into());
        }
    }
    let world = World::from_map(&map);
    let network = Network::new(&map, &world);
    [("303R", "A352L"), ("A353R", "301L")]
        .iter()
        .map(|(a, b)| {
            let plan = Plan::new(&world, &network, a, b).unwrap();
            assert!(plan.holds.iter().any(|h| h.semaphore == "$passage/N"));
            (plan.holds, plan.steps.len())
        })
        .collect()
}

/// The model finds circles where they are: robots that take each part as
/// it comes along the route do deadlock, head-on through EB3's corridor N
/// made a narrow passage (each holds the junction at its end of N and the
/// passage, and waits for the other's junction) and on made-up networks.
#[test]
fn robots_taking_parts_as_they_come_do_wait_in_a_circle() {
    let mut rng = Rng(36);
    let routes = head_on_through_corridor_n();
    assert!(deadlocks(&routes, Discipline::AsItComes, 200, &mut rng) > 0);
    assert_eq!(deadlocks(&routes, Discipline::Chains, 200, &mut rng), 0);
    let mut found = 0;
    for case in 0..200 {
        let routes = made_up_routes(2 + case % 6, 2 + case % 9, &mut rng);
        found += deadlocks(&routes, Discipline::AsItComes, 10, &mut rng);
    }
    assert!(found > 0);
}

/// Two robots head-on through one junction each way: the smallest circle.
#[test]
fn head_on_through_two_junctions_is_the_circle_chains_prevent() {
    let one = vec![
        hold("$traffic/junction/001", 0, 1),
        hold("$traffic/junction/002", 1, 2),
    ];
    let other = vec![
        hold("$traffic/junction/002", 0, 1),
        hold("$traffic/junction/001", 1, 2),
    ];
    let routes = vec![(one, 3), (other, 3)];
    let mut rng = Rng(1);
    assert!(deadlocks(&routes, Discipline::AsItComes, 200, &mut rng) > 0);
    assert_eq!(deadlocks(&routes, Discipline::Chains, 200, &mut rng), 0);
}

#[test]
fn a_plan_holds_the_junctions_it_turns_in() {
    let map = rome_maps::load_named("eb3").unwrap();
    let world = World::from_map(&map);
    let network = Network::new(&map, &world);
    let plan = Plan::new(&world, &network, "350R", "376L").unwrap();
    let junctions = Junctions::of(&network);
    // Every corner's Enter and Leave steps share a junction hold.
    for (i, step) in plan.steps.iter().enumerate() {
        if step.goal.goal_type == crate::board::GoalType::E {
            assert!(
                plan.holds.iter().any(|h| h.first <= i && h.last > i),
                "step {i} turns in a junction it does not hold: {:?}",
                plan.holds
            );
        }
    }
    assert!(!junctions.is_empty());
    assert!(plan
        .holds
        .iter()
        .all(|h| h.first <= h.last && h.last < plan.steps.len()));
}

#[test]
fn a_plan_holds_each_narrow_corridor_it_drives_one_way_and_no_wide_one() {
    let map = rome_maps::load_named("eb3").unwrap();
    let world = World::from_map(&map);
    let network = Network::new(&map, &world);
    let lanes_of = |a: &str, b: &str| -> Vec<String> {
        let plan = Plan::new(&world, &network, a, b).unwrap();
        let mut out: Vec<String> = plan
            .holds
            .iter()
            .filter(|h| lanes::Lane::of(&h.semaphore).is_some())
            .map(|h| h.semaphore.clone())
            .collect();
        out.sort();
        out
    };
    // Corridor A is 3.66 m wide: two robots pass there.
    assert!(lanes_of("350R", "376L").is_empty());
    // Down corridor N (2.44 m) and west along P; and back, the other way
    // of the same two lanes.
    let there = lanes_of("303R", "A352L");
    let back = lanes_of("A352L", "303R");
    assert_eq!(there.len(), 2, "{there:?}");
    assert!(there.iter().all(|s| s.ends_with("/down")), "{there:?}");
    let twins: Vec<String> = there
        .iter()
        .map(|s| lanes::Lane::of(s).unwrap().other)
        .collect();
    assert_eq!(back, twins);
    // Along P in one stretch: one lane, the same whichever door it starts at.
    assert_eq!(lanes_of("A360L", "A352L"), lanes_of("A358L", "A356L"));
}

/// Lanes taken as they come deadlock head on; taken whole before the
/// chain, they do not.
#[test]
fn two_lanes_head_on_are_a_circle_only_when_taken_as_they_come() {
    let one = vec![
        hold("$traffic/lane/001-002/up", 0, 2),
        hold("$traffic/lane/002-003/up", 1, 3),
    ];
    let other = vec![
        hold("$traffic/lane/002-003/down", 0, 2),
        hold("$traffic/lane/001-002/down", 1, 3),
    ];
    let routes = vec![(one.clone(), 4), (other, 4), (one, 4)];
    let mut rng = Rng(2);
    assert!(deadlocks(&routes, Discipline::AsItComes, 200, &mut rng) > 0);
    assert_eq!(deadlocks(&routes, Discipline::Chains, 200, &mut rng), 0);
}

#[test]
fn a_chain_driving_a_lane_both_ways_holds_it_one_way() {
    let c = chains(&[
        hold("$traffic/lane/001-002/up", 0, 2),
        hold("$traffic/lane/001-002/down", 2, 4),
    ]);
    assert_eq!(c.len(), 1);
    assert_eq!(c[0].holds, vec![hold("$traffic/lane/001-002/up", 0, 4)]);
}
