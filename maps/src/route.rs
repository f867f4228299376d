//! Shortest paths between named positions (`350R` → `376L`) along the
//! corridors of a map.
//!
//! A robot travels on the corridor's centre line, the line of its ceiling
//! lights (§5.3, §5.6). Every building corner (a node with a negative
//! adjacency angle) and every linked node gives a waypoint where the centre
//! lines of its two edges cross: the middle of a turning space. A start or
//! goal is the point abeam its door on that line. Two waypoints are joined
//! when the straight line between them meets no wall, door or glass; the
//! route is the shortest chain of such lines (Dijkstra). Links between rings
//! (§7.2) thus add their waypoints, and a corridor shared by two rings (one
//! ring on each side) is one corridor.
//!
//! A leg that starts or ends at a door keeps to the line of the door's
//! corridor ([`ALONG_MM`]) or runs square across it ([`SLANT_DEG`]): a door
//! just round a corner is reached through the turning space's middle, with
//! a corner, not on a slant across it.
//! The Navigator follows hallways (§5.4); on a slant its walls pull it
//! off the line, and the distance runs out short of the door.

use crate::geometry::{
    direction, distance, distance_to_segment, heading_to as heading, normalize_deg, Point,
};
use crate::model::{EdgeKind, Map};
use crate::world::{intersect, Position, World};

/// A route between two positions.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    /// The positions asked for: start, any via points, goal.
    pub stops: Vec<String>,
    /// The corner points of the path, start first, goal last.
    pub points: Vec<Point>,
    /// Its length, mm.
    pub length_mm: f64,
    /// How many times the path turns by more than 30°: the corners the
    /// robot has to take.
    pub turns: usize,
}

impl Route {
    /// The straight legs: start, end, length (mm) and heading (degrees).
    pub fn legs(&self) -> Vec<(Point, Point, f64, f64)> {
        self.points
            .windows(2)
            .map(|w| (w[0], w[1], distance(w[0], w[1]), heading(w[0], w[1])))
            .collect()
    }
}

/// Why there is no route.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RouteError {
    /// The map has no such position.
    #[error("no position '{name}' in the map{}", hint(.similar))]
    Unknown {
        /// What was asked for.
        name: String,
        /// Positions with a similar name.
        similar: Vec<String>,
    },
    /// No corridor connects the two.
    #[error("no way from '{from}' to '{to}': no corridor connects them")]
    Unreachable {
        /// Start.
        from: String,
        /// Goal.
        to: String,
    },
    /// A via position makes the route turn back on itself, which the
    /// Planner cannot drive (its corners are turns of less than 150°).
    #[error("the route turns back on itself at '{via}' (by {turn_deg:.0}°); choose via positions along the way round")]
    TurnsBack {
        /// The via position.
        via: String,
        /// The turn there, degrees.
        turn_deg: f64,
    },
}

fn hint(similar: &[String]) -> String {
    if similar.is_empty() {
        " (door jambs are named like 350L and 350R, nodes like outer.NE)".to_string()
    } else {
        format!("; did you mean {}?", similar.join(", "))
    }
}

/// A stretch of corridor driven one way only: from `a` toward `b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OneWay {
    /// Where it starts (the middle of the turning space at that end).
    pub a: Point,
    /// Where it ends.
    pub b: Point,
    /// How far either side of the line from `a` to `b` a point lies in it,
    /// and how far past either end, mm.
    pub reach_mm: f64,
}

impl OneWay {
    /// Whether the straight move from `p` to `q` runs against it: it heads
    /// back toward `a` (more than 60° off the way), and either both ends
    /// lie in it, or it drives more than `reach_mm` of it. The second case
    /// is a line of sight that enters from outside: a corridor in line
    /// with the stretch sees straight down it, and a move from there to a
    /// door inside, or through to the far end, is as much against the way
    /// as one that starts inside.
    pub fn against(&self, p: Point, q: Point) -> bool {
        let len = distance(self.a, self.b);
        let (step, moved) = (q - p, distance(p, q));
        if len < 1.0 || moved < 1.0 || step.dot(&(self.b - self.a)) >= -0.5 * moved * len {
            return false;
        }
        let u = (self.b - self.a) / len;
        // Where a point lies: along the way from `a`, and to its left.
        let at = |x: Point| {
            let d = x - self.a;
            (d.dot(&u), d.y * u.x - d.x * u.y)
        };
        let ((ap, cp), (aq, cq)) = (at(p), at(q));
        let inside = |along: f64, across: f64| {
            across.abs() <= self.reach_mm && along >= -self.reach_mm && along <= len + self.reach_mm
        };
        if inside(ap, cp) && inside(aq, cq) {
            return true;
        }
        // The share of the move, 0 to 1, that lies between the ends and
        // within reach across.
        let mut span = (0.0_f64, 1.0_f64);
        for (from, to, lo, hi) in [(ap, aq, 0.0, len), (cp, cq, -self.reach_mm, self.reach_mm)] {
            let d = to - from;
            if d.abs() < 1e-9 {
                if from < lo || from > hi {
                    return false;
                }
                continue;
            }
            let (s0, s1) = ((lo - from) / d, (hi - from) / d);
            span = (span.0.max(s0.min(s1)), span.1.min(s0.max(s1)));
        }
        (span.1 - span.0) * moved > self.reach_mm
    }
}

/// The corridor network of a map: waypoints and the walls that block lines.
#[derive(Debug, Clone)]
pub struct Network {
    waypoints: Vec<Point>,
    walls: Vec<(Point, Point)>,
    /// Which waypoints see each other, and how far apart they are.
    edges: Vec<Vec<(usize, f64)>>,
    /// Stretches driven one way only; paths never run against them.
    one_way: Vec<OneWay>,
}

impl Network {
    /// Builds the network of a map and its world.
    pub fn new(map: &Map, world: &World) -> Network {
        let walls: Vec<(Point, Point)> = world
            .segments
            .iter()
            .filter(|s| s.kind != EdgeKind::Opening)
            .map(|s| (s.a, s.b))
            .collect();
        let mut linked = std::collections::BTreeSet::new();
        for link in &map.links {
            linked.insert((link.a.0.as_str(), link.a.1.as_str()));
            linked.insert((link.b.0.as_str(), link.b.1.as_str()));
        }
        let mut waypoints: Vec<Point> = Vec::new();
        for (ri, ring) in map.rings.iter().enumerate() {
            let n = ring.nodes.len();
            for (i, node) in ring.nodes.iter().enumerate() {
                if !node.is_corner() && !linked.contains(&(ring.name.as_str(), node.name.as_str()))
                {
                    continue;
                }
                let at = world.nodes[ri][i].1;
                let (Some(prev), Some(next)) =
                    (world.segment(ri, (i + n - 1) % n), world.segment(ri, i))
                else {
                    continue;
                };
                let (prev, next) = (&world.segments[prev], &world.segments[next]);
                let lat = |e: usize| ring.edges[e].lateral_mm.unwrap_or(map.lateral_mm);
                let h1 = heading(prev.a, prev.b);
                let h2 = heading(next.a, next.b);
                let p1 = offset(at, h1, lat(prev.edge));
                let p2 = offset(at, h2, lat(next.edge));
                let p = intersect(p1, direction(h1), p2, direction(h2)).unwrap_or(p2);
                if !waypoints.iter().any(|w| distance(*w, p) < 1.0) {
                    waypoints.push(p);
                }
            }
        }
        let mut net = Network {
            edges: vec![Vec::new(); waypoints.len()],
            waypoints,
            walls,
            one_way: Vec::new(),
        };
        for i in 0..net.waypoints.len() {
            for j in i + 1..net.waypoints.len() {
                let (p, q) = (net.waypoints[i], net.waypoints[j]);
                if net.clear(p, q) {
                    let d = distance(p, q);
                    net.edges[i].push((j, d));
                    net.edges[j].push((i, d));
                }
            }
        }
        net
    }

    /// The waypoints (turning-space centres).
    pub fn waypoints(&self) -> &[Point] {
        &self.waypoints
    }

    /// The pairs of waypoints joined by a straight line, each once.
    pub fn links(&self) -> Vec<(usize, usize)> {
        // One way, a link is kept in one direction only.
        let mut links: Vec<(usize, usize)> = (self.edges.iter().enumerate())
            .flat_map(|(i, e)| e.iter().map(move |&(j, _)| (i.min(j), i.max(j))))
            .collect();
        links.sort_unstable();
        links.dedup();
        links
    }

    /// The same network with these stretches driven one way only: every
    /// path it finds afterwards keeps to their way.
    pub fn with_one_way(mut self, one_way: Vec<OneWay>) -> Network {
        self.one_way = one_way;
        // The links against a way are dropped once here, not filtered out
        // on every path search.
        for i in 0..self.edges.len() {
            let p = self.waypoints[i];
            let mut e = std::mem::take(&mut self.edges[i]);
            e.retain(|&(j, _)| !self.against(p, self.waypoints[j]));
            self.edges[i] = e;
        }
        self
    }

    /// Whether the move from `p` to `q` runs against a one-way stretch.
    pub fn against(&self, p: Point, q: Point) -> bool {
        self.one_way.iter().any(|w| w.against(p, q))
    }

    /// Whether a path may go straight from `p` to `q`: no wall between,
    /// and not against a one-way stretch.
    fn open(&self, p: Point, q: Point) -> bool {
        self.clear(p, q) && !self.against(p, q)
    }

    /// Whether the straight line from p to q meets no wall.
    pub fn clear(&self, p: Point, q: Point) -> bool {
        !self.walls.iter().any(|&(a, b)| crosses(p, q, a, b))
    }

    /// How far a leg from `p` is to keep from every wall: `want_mm`, or as
    /// far as `p` itself stands from the nearest (a robot by a wall may
    /// leave along it, not cut a corner closer). 0: no margin wanted.
    fn margin_at(&self, p: Point, want_mm: f64) -> f64 {
        if want_mm <= 0.0 {
            return 0.0;
        }
        let here = (self.walls.iter())
            .map(|&(a, b)| distance_to_segment(p, a, b))
            .fold(f64::INFINITY, f64::min);
        want_mm.min(here - 1.0)
    }

    /// Whether the straight line from `p` to `q` keeps `margin_mm` from
    /// every wall ([`Network::margin_at`]).
    fn keeps_off(&self, p: Point, q: Point, margin_mm: f64) -> bool {
        margin_mm <= 0.0
            || self.walls.iter().all(|&(a, b)| {
                let apart = [
                    distance_to_segment(p, a, b),
                    distance_to_segment(q, a, b),
                    distance_to_segment(a, p, q),
                    distance_to_segment(b, p, q),
                ];
                !crosses(p, q, a, b) && apart.into_iter().all(|d| d >= margin_mm)
            })
    }

    /// The shortest path between two ends in corridors: keeping to the
    /// doors' corridor lines, or where that finds none, any way.
    fn path(&self, from: End, to: End) -> Option<(Vec<Point>, f64)> {
        let kept = from.axis.is_some() || to.axis.is_some() || from.clear_mm > 0.0;
        self.path_keeping(from, to)
            .or_else(|| kept.then(|| self.path_keeping(from.anyway(), to.anyway()))?)
    }

    /// The shortest path whose first and last legs the ends admit.
    fn path_keeping(&self, from_end: End, to_end: End) -> Option<(Vec<Point>, f64)> {
        let (from, to) = (from_end.at, to_end.at);
        // Once a search: the start's room to its nearest wall.
        let margin = self.margin_at(from, from_end.clear_mm);
        let leaves = |q: Point| self.open(from, q) && self.keeps_off(from, q, margin);
        // A robot standing a step past its goal on a one-way stretch backs
        // up to it: the way round may be the building's whole loop.
        let backs_up = from_end.clear_mm > 0.0 && distance(from, to) <= BACK_UP_MM;
        let straight = (backs_up || !self.against(from, to))
            && self.clear(from, to)
            && self.keeps_off(from, to, margin);
        if straight && from_end.admits(to) && to_end.admits(from) {
            return Some((vec![from, to], distance(from, to)));
        }
        let n = self.waypoints.len();
        let (start, goal) = (n, n + 1);
        let point = |i: usize| match i {
            i if i == start => from,
            i if i == goal => to,
            i => self.waypoints[i],
        };
        let neighbours = |i: usize| -> Vec<(usize, f64)> {
            let mut out = Vec::new();
            if i < n {
                let p = self.waypoints[i];
                out.extend(self.edges[i].iter().copied());
                if self.open(p, to) && to_end.admits(p) {
                    out.push((goal, distance(p, to)));
                }
            } else if i == start {
                for (k, w) in self.waypoints.iter().enumerate() {
                    if leaves(*w) && from_end.admits(*w) {
                        out.push((k, distance(from, *w)));
                    }
                }
            }
            out
        };
        let mut dist = vec![f64::INFINITY; n + 2];
        let mut prev = vec![usize::MAX; n + 2];
        let mut done = vec![false; n + 2];
        dist[start] = 0.0;
        loop {
            let u = (0..n + 2)
                .filter(|&i| !done[i] && dist[i].is_finite())
                .min_by(|&a, &b| dist[a].total_cmp(&dist[b]))?;
            if u == goal {
                break;
            }
            done[u] = true;
            for (v, w) in neighbours(u) {
                if dist[u] + w < dist[v] {
                    dist[v] = dist[u] + w;
                    prev[v] = u;
                }
            }
        }
        let mut chain = vec![goal];
        while let Some(&last) = chain.last() {
            if last == start {
                break;
            }
            chain.push(prev[last]);
        }
        chain.reverse();
        Some((chain.into_iter().map(point).collect(), dist[goal]))
    }
}

impl World {
    /// The shortest route from one named position to another through the
    /// `via` positions in order.
    pub fn route(
        &self,
        network: &Network,
        from: &str,
        via: &[&str],
        to: &str,
    ) -> Result<Route, RouteError> {
        let start = self.position(from).ok_or_else(|| RouteError::Unknown {
            name: from.to_string(),
            similar: self.similar(from),
        })?;
        self.route_from(network, (from, start.in_corridor()), via, to)
    }

    /// The shortest route from a point (a robot standing where no position
    /// is named, as its odometry puts it; `start.0` names it in the route)
    /// to a named position through the `via` positions in order.
    pub fn route_from(
        &self,
        network: &Network,
        start: (&str, Point),
        via: &[&str],
        to: &str,
    ) -> Result<Route, RouteError> {
        let mut stops: Vec<&str> = vec![start.0];
        stops.extend_from_slice(via);
        stops.push(to);
        // A start that stands where its name puts it is that door's end.
        let mut at = vec![match self.position(start.0) {
            Some(p) if distance(p.in_corridor(), start.1) < 1.0 => End::of(p),
            _ => End::standing(start.1),
        }];
        for name in &stops[1..] {
            let p = self.position(name).ok_or_else(|| RouteError::Unknown {
                name: (*name).to_string(),
                similar: self.similar(name),
            })?;
            at.push(End::of(p));
        }
        let mut points = vec![at[0].at];
        let mut length_mm = 0.0;
        for (k, w) in at.windows(2).enumerate() {
            let (leg, len) = network
                .path(w[0], w[1])
                .ok_or_else(|| RouteError::Unreachable {
                    from: stops[k].to_string(),
                    to: stops[k + 1].to_string(),
                })?;
            points.extend(leg.into_iter().skip(1));
            length_mm += len;
        }
        points.dedup_by(|a, b| distance(*a, *b) < 1.0);
        let turns = points
            .windows(3)
            .filter(|w| normalize_deg(heading(w[1], w[2]) - heading(w[0], w[1])).abs() > 30.0)
            .count();
        Ok(Route {
            stops: stops.iter().map(|s| (*s).to_string()).collect(),
            points,
            length_mm,
            turns,
        })
    }

    /// Position names close to `name` (same stem, or one character off).
    pub fn similar(&self, name: &str) -> Vec<String> {
        let stem = name.trim_end_matches(['L', 'R', '.']);
        let mut out: Vec<String> = self
            .positions
            .keys()
            .filter(|k| {
                (!stem.is_empty() && k.trim_end_matches(['L', 'R']) == stem)
                    || edit_distance(k, name) <= 1
            })
            .cloned()
            .collect();
        out.truncate(6);
        out
    }
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = if ca == *cb {
                prev
            } else {
                1 + prev.min(row[j]).min(row[j + 1])
            };
            prev = cur;
        }
    }
    row[b.len()]
}

/// How far from a door's corridor line (the line of its lights) the first
/// or last leg of a path may end, mm. Well over the few hundred mm that
/// corridors' centre lines differ by where their lateral distances
/// differ; well under a corridor's width.
pub const ALONG_MM: f64 = 600.0;

/// How far from a door's corridor line or its square a leg from the door
/// may slant, degrees: the few degrees a door set in a turning space is off
/// the crossing corridor's line, not a cut across the turning space.
pub const SLANT_DEG: f64 = 15.0;

/// How far the first leg from where a robot stands (a point no position
/// names) keeps its middle from every wall, mm: its radius and 0.12 m.
/// Such a point may lie anywhere across a corridor, off its centre line;
/// a straight line from there that grazes a wall's end is clear for a
/// point, not for the robot, which the Navigator then turns off the line.
pub const BODY_CLEAR_MM: f64 = rome_schema::robot::body::ROBOT_RADIUS_MM + 120.0;

/// How far a robot standing where no position is named may drive straight
/// back to its goal against a one-way stretch, mm: as far as a step out
/// of a junction or aside takes it past a position.
pub const BACK_UP_MM: f64 = 3_000.0;

/// One end of a path: a point, at a door the heading of its corridor, and
/// how far from the walls a leg from it keeps ([`BODY_CLEAR_MM`]).
#[derive(Debug, Clone, Copy)]
struct End {
    at: Point,
    axis: Option<f64>,
    clear_mm: f64,
}

impl End {
    /// A named position: the point abeam it, and at a door its wall's
    /// heading.
    fn of(p: &Position) -> End {
        End {
            at: p.in_corridor(),
            axis: p.door.then_some(p.wall_heading_deg),
            clear_mm: 0.0,
        }
    }

    /// A point a leg may leave or reach any way.
    fn point(at: Point) -> End {
        End {
            at,
            axis: None,
            clear_mm: 0.0,
        }
    }

    /// Where a robot stands that no position names: a leg leaves it with
    /// room for its body.
    fn standing(at: Point) -> End {
        End {
            at,
            axis: None,
            clear_mm: BODY_CLEAR_MM,
        }
    }

    /// The same point, admitting any leg.
    fn anyway(self) -> End {
        End::point(self.at)
    }

    /// Whether a leg between this end and `q` keeps to its corridor line,
    /// or runs square across it: a door in a junction lies on the line of
    /// the corridor crossing its own.
    fn admits(&self, q: Point) -> bool {
        self.axis.is_none_or(|h| {
            let off = (q - self.at).perp(&direction(h)).abs();
            let slant = normalize_deg(heading(self.at, q) - h).abs();
            let slant = slant.min(180.0 - slant);
            off <= ALONG_MM || slant <= SLANT_DEG || slant >= 90.0 - SLANT_DEG
        })
    }
}

fn offset(p: Point, heading_deg: f64, lateral: f64) -> Point {
    p + direction(heading_deg - 90.0) * lateral
}

/// Whether segments pq and ab cross (touching counts).
fn crosses(p: Point, q: Point, a: Point, b: Point) -> bool {
    let orient = |o: Point, s: Point, t: Point| (s - o).perp(&(t - o));
    let d1 = orient(a, b, p);
    let d2 = orient(a, b, q);
    let d3 = orient(p, q, a);
    let d4 = orient(p, q, b);
    d1 * d2 <= 0.0 && d3 * d4 <= 0.0 && !(d1 == 0.0 && d2 == 0.0 && d3 == 0.0 && d4 == 0.0)
}
