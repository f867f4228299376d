//! One-way corridors: the narrow stretches of a loop, each given a fixed
//! way, so robots in them never meet head on.
//!
//! The route network's junctions and the stretches between them form a
//! graph. A depth-first search from junction 0 (neighbours in number
//! order, so every robot finds the same) gives each stretch a way: down
//! the search tree, and back up to an ancestor. Robbins (1939): in a graph
//! without bridges that makes every junction reachable from every other.
//! Only stretches narrower than [`super::lanes::PASSING_MM`] take their
//! way; wide ones stay two-way, which keeps everything reachable. A narrow
//! stretch that is a bridge (a dead-end corridor, or the only way into a
//! part of the building) stays two-way too: one way, it would cut a part
//! off.

use super::lanes::PASSING_MM;
use super::{Junctions, JUNCTION_REACH_MM};
use crate::plan::walls_beside;
use rome_maps::geometry::{distance, heading_to, Point};
use rome_maps::{Map, Network, OneWay, World};

/// How far past a junction's middle a stretch's width is measured, mm
/// (as for lanes): out of the turning space.
const MEASURE_FROM_JUNCTION_MM: f64 = 2_500.0;

/// The network with its narrow stretches one way ([`one_way`]).
pub fn with_one_way(world: &World, network: Network) -> Network {
    let ways = one_way(world, &network);
    network.with_one_way(ways)
}

/// The map's route network, one way where [`one_way`] says if `one_way`:
/// the one place a Planner, a dispatcher or a whole run builds it, so
/// that all of a fleet's robots plan on the same.
pub fn network(map: &Map, world: &World, one_way: bool) -> Network {
    let network = Network::new(map, world);
    if one_way {
        with_one_way(world, network)
    } else {
        network
    }
}

/// The narrow stretches of `network` that lie on a loop, each with its
/// way, from junction middle to junction middle.
pub fn one_way(world: &World, network: &Network) -> Vec<OneWay> {
    let junctions = Junctions::of(network);
    let (stretches, narrow) = stretches(world, network, &junctions);
    let ways = orient(junctions.len(), &stretches);
    (ways.into_iter())
        .filter(|&(a, b)| narrow.contains(&(a.min(b), a.max(b))))
        .map(|(a, b)| OneWay {
            a: junctions.centre(a),
            b: junctions.centre(b),
            reach_mm: JUNCTION_REACH_MM,
        })
        .collect()
}

/// Two junctions joined by a corridor, the smaller number first.
type Stretch = (usize, usize);

/// The stretches between junctions (each once, in order), and which of
/// them are narrow.
fn stretches(
    world: &World,
    network: &Network,
    junctions: &Junctions,
) -> (Vec<Stretch>, Vec<Stretch>) {
    let nearest = |p: Point| {
        (0..junctions.len())
            .min_by(|&a, &b| {
                (distance(p, junctions.centre(a))).total_cmp(&distance(p, junctions.centre(b)))
            })
            .unwrap_or(0)
    };
    let waypoints = network.waypoints();
    let mut out: Vec<Stretch> = Vec::new();
    for (i, j) in network.links() {
        let (a, b) = (nearest(waypoints[i]), nearest(waypoints[j]));
        let (ca, cb) = (junctions.centre(a), junctions.centre(b));
        // A line of sight past a junction is two stretches, not one.
        if a == b || junctions.on_line(ca, cb).len() > 2 {
            continue;
        }
        out.push((a.min(b), a.max(b)));
    }
    out.sort_unstable();
    out.dedup();
    let narrow = (out.iter().copied())
        .filter(|&(a, b)| {
            let (ca, cb) = (junctions.centre(a), junctions.centre(b));
            let len = distance(ca, cb);
            if len <= 2.0 * MEASURE_FROM_JUNCTION_MM + 500.0 {
                return false;
            }
            let u = (cb - ca) / len;
            let (p, q) = (
                ca + u * MEASURE_FROM_JUNCTION_MM,
                cb - u * MEASURE_FROM_JUNCTION_MM,
            );
            walls_beside(world, p, q, heading_to(p, q)).is_some_and(|(l, r)| l + r < PASSING_MM)
        })
        .collect();
    (out, narrow)
}

/// Gives every stretch that is not a bridge a way (from, to), by a
/// depth-first search from junction 0: tree stretches away from the root,
/// the others back toward it.
fn orient(n: usize, stretches: &[Stretch]) -> Vec<(usize, usize)> {
    let mut next: Vec<Vec<usize>> = vec![Vec::new(); n];
    for &(a, b) in stretches {
        next[a].push(b);
        next[b].push(a);
    }
    for v in &mut next {
        v.sort_unstable();
    }
    let mut search = Search {
        next,
        order: vec![usize::MAX; n],
        low: vec![0; n],
        count: 0,
        ways: Vec::new(),
    };
    for root in 0..n {
        if search.order[root] == usize::MAX {
            search.visit(root, usize::MAX);
        }
    }
    search.ways
}

struct Search {
    next: Vec<Vec<usize>>,
    /// When each junction was first reached (`usize::MAX`: not yet).
    order: Vec<usize>,
    /// The earliest junction reachable from its subtree by one stretch
    /// back.
    low: Vec<usize>,
    count: usize,
    ways: Vec<(usize, usize)>,
}

impl Search {
    fn visit(&mut self, u: usize, parent: usize) {
        self.order[u] = self.count;
        self.low[u] = self.count;
        self.count += 1;
        for k in 0..self.next[u].len() {
            let v = self.next[u][k];
            if v == parent {
                continue;
            }
            if self.order[v] == usize::MAX {
                self.visit(v, u);
                self.low[u] = self.low[u].min(self.low[v]);
                // Not a bridge: the subtree below reaches back above it.
                if self.low[v] <= self.order[u] {
                    self.ways.push((u, v));
                }
            } else if self.order[v] < self.order[u] {
                self.low[u] = self.low[u].min(self.order[v]);
                self.ways.push((u, v));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(name: &str) -> (World, Network) {
        let map = rome_maps::load_named(name).expect("a built-in map");
        let world = World::from_map(&map);
        let network = Network::new(&map, &world);
        (world, network)
    }

    #[test]
    fn a_ring_is_driven_round_one_way_and_a_spur_both_ways() {
        // 0-1-2-0 is a ring; 2-3 a spur.
        let mut ways = orient(4, &[(0, 1), (0, 2), (1, 2), (2, 3)]);
        ways.sort_unstable();
        assert_eq!(ways, vec![(0, 1), (1, 2), (2, 0)]);
    }

    #[test]
    fn eb3s_new_wing_becomes_one_way_loops_and_every_door_stays_reachable() {
        let (world, network) = load("eb3");
        let ways = one_way(&world, &network);
        // G, N, J and P's two halves: the new wing's five narrow stretches.
        assert_eq!(ways.len(), 5, "{ways:?}");
        let directed = network.clone().with_one_way(ways.clone());
        let mut names: Vec<&String> = world.positions.keys().collect();
        names.sort();
        let mut longer = 0;
        for (k, from) in names.iter().enumerate() {
            // A spread of starts and goals.
            if k % 20 != 0 {
                continue;
            }
            for to in names.iter().step_by(5) {
                // Some positions no corridor reaches even both ways.
                let Ok(plain) = world.route(&network, from, &[], to) else {
                    continue;
                };
                let one = world
                    .route(&directed, from, &[], to)
                    .unwrap_or_else(|e| panic!("{from} → {to}: {e}"));
                assert!(one.length_mm >= plain.length_mm - 1.0);
                longer += usize::from(one.length_mm > plain.length_mm + 1.0);
                // No leg drives back along a one-way stretch.
                for w in one.points.windows(2) {
                    assert!(
                        !ways.iter().any(|x| drives_back(x, w[0], w[1])),
                        "{from} → {to} runs against {ways:?}: {:?}",
                        one.points
                    );
                }
            }
        }
        assert!(longer > 0, "some routes go round");
    }

    #[test]
    fn a_robot_a_step_past_its_goal_on_a_one_way_stretch_backs_up_to_it() {
        // A392R lies at N's foot, where P is driven west. A robot that
        // drove on 1.3 m west of it out of the junction, given a task
        // there, backs up to it rather than going round the building;
        // one 4 m past it goes round.
        let (world, network) = load("eb3");
        let directed = network.clone().with_one_way(one_way(&world, &network));
        let goal = world.position("A392R").expect("named").in_corridor();
        let from = |back_mm: f64| {
            let p = rome_maps::geometry::pt(goal.x - back_mm, goal.y);
            world.route_from(&directed, ("@past", p), &[], "A392R")
        };
        let near = from(1_300.0).expect("a route");
        assert!((near.length_mm - 1_300.0).abs() < 1.0, "{near:?}");
        let far = from(4_000.0).expect("a route");
        assert!(far.length_mm > 100_000.0, "{far:?}");
    }

    /// Whether the leg from `p` to `q`, walked in steps of 100 mm, moves
    /// back toward `w.a` for more than a metre while within 1 m of the
    /// stretch's line and more than its reach from either end: checked
    /// point by point, not by [`OneWay::against`].
    fn drives_back(w: &OneWay, p: Point, q: Point) -> bool {
        let len = distance(w.a, w.b);
        let u = (w.b - w.a) / len;
        let steps = (distance(p, q) / 100.0).ceil().max(1.0) as usize;
        let mut back = 0.0;
        for k in 0..steps {
            let at = |k: usize| p + (q - p) * (k as f64 / steps as f64);
            let (x, y) = (at(k), at(k + 1));
            let d = x - w.a;
            let (along, across) = (d.dot(&u), (d.x * u.y - d.y * u.x).abs());
            let within = across <= 1_000.0 && along > w.reach_mm && along < len - w.reach_mm;
            if within {
                back += (-(y - x).dot(&u)).max(0.0);
            }
        }
        back > 1_000.0
    }

    #[test]
    fn a_corridor_in_line_with_a_one_way_stretch_does_not_see_down_it() {
        // EB3's corridor B (x = 8 m, north of corridor M) lies in line with
        // corridor G (south of M), which is driven north. A route from B
        // to a door in G goes round by N and P, not straight down G.
        let (world, network) = load("eb3");
        let ways = one_way(&world, &network);
        let directed = network.clone().with_one_way(ways.clone());
        let plain = world.route(&network, "392L", &[], "A397L").unwrap();
        let one = world.route(&directed, "392L", &[], "A397L").unwrap();
        assert!(
            (plain.points.windows(2)).any(|w| ways.iter().any(|x| drives_back(x, w[0], w[1]))),
            "both ways, the route drives down G: {:?}",
            plain.points
        );
        for w in one.points.windows(2) {
            assert!(
                !ways.iter().any(|x| drives_back(x, w[0], w[1])),
                "{:?}",
                one.points
            );
        }
        assert!(one.length_mm > plain.length_mm + 50_000.0, "{one:?}");
    }

    #[test]
    fn a_narrow_spur_stays_two_way() {
        // The Annex: stretch 2-3 is narrow and ends at junction 3, which
        // no other stretch reaches, a dead end; 0-1-2-5-4-0 is a loop.
        let (world, network) = load("annex");
        let j = Junctions::of(&network);
        let (stretches, narrow) = stretches(&world, &network, &j);
        let ways = orient(j.len(), &stretches);
        let spur = (2, 3);
        assert!(narrow.contains(&spur), "{narrow:?}");
        assert!(
            !ways.iter().any(|&(a, b)| (a.min(b), a.max(b)) == spur),
            "{ways:?}"
        );
        // The rest of the loop is one way.
        assert!(ways.contains(&(1, 2)) || ways.contains(&(2, 1)), "{ways:?}");
    }
}
