//! A map laid out in world coordinates: each ring traced from its edges'
//! lengths and turns, its segments, ceiling lights, door plates and named
//! positions, as the simulator and the navigation clients use them.

use crate::geometry::{direction, normalize_deg, pt, Point, Vector};
use crate::model::{EdgeKind, Map, Ring};
use std::collections::BTreeMap;

/// Where a ring's tracing goes: node positions, edge headings, and how it
/// fails to close.
#[derive(Debug, Clone)]
pub struct Trace {
    /// Position of each node.
    pub nodes: Vec<Point>,
    /// Heading of each edge.
    pub headings: Vec<f64>,
    /// Where the tracing ends after the last edge (the first node, ideally).
    pub end: Point,
    /// The sum of the turns at all nodes (±360 for a closed contour).
    pub total_turn_deg: f64,
}

/// Follows a ring's edges from its first node.
pub fn trace(ring: &Ring) -> Trace {
    let mut p = ring.at_mm;
    let mut h = ring.heading_deg;
    let mut nodes = Vec::with_capacity(ring.nodes.len());
    let mut headings = Vec::with_capacity(ring.edges.len());
    for (i, edge) in ring.edges.iter().enumerate() {
        nodes.push(p);
        headings.push(h);
        p += direction(h) * edge.length_mm;
        if let Some(next) = ring.nodes.get(i + 1) {
            h += next.turn_deg();
        }
    }
    let total_turn_deg = ring.nodes.iter().map(|n| n.turn_deg()).sum();
    Trace {
        nodes,
        headings,
        end: p,
        total_turn_deg,
    }
}

/// A straight piece of an edge, for sonar, rendering and collisions.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// Start (the edge's start node).
    pub a: Point,
    /// End.
    pub b: Point,
    /// What it is.
    pub kind: EdgeKind,
    /// Index of its ring in the map.
    pub ring: usize,
    /// Index of its edge in the ring.
    pub edge: usize,
    /// The narrow passage it bounds (the edge's `passage=NAME`), where
    /// robots cannot pass each other and take turns.
    pub passage: Option<String>,
}

/// A ceiling light.
#[derive(Debug, Clone, PartialEq)]
pub struct Light {
    /// Where it is.
    pub at: Point,
    /// Ring and edge it is projected onto (the first, for a paired light).
    pub ring: usize,
    /// Edge index.
    pub edge: usize,
}

/// A door-number plate on a wall.
#[derive(Debug, Clone, PartialEq)]
pub struct PlateAt {
    /// What it reads.
    pub label: String,
    /// Where it is on the wall.
    pub at: Point,
    /// The heading of the wall it is on (the tracing direction).
    pub wall_heading_deg: f64,
}

/// A named position: a door jamb (`350L`, `350R`) or a node (`outer.A`).
#[derive(Debug, Clone, PartialEq)]
pub struct Position {
    /// The point on the wall.
    pub at: Point,
    /// The heading of the wall there (tracing direction); the corridor is
    /// to the right of it.
    pub wall_heading_deg: f64,
    /// Ring index.
    pub ring: usize,
    /// Edge index the position starts or ends.
    pub edge: usize,
    /// How far the corridor's centre line (its lights) is from this wall, mm.
    pub lateral_mm: f64,
    /// A door jamb (`350R`), not a node (`outer.NE`), whose point may
    /// stand in a turning space.
    pub door: bool,
}

impl Position {
    /// The point in the corridor abeam this position, on the line of the
    /// lights: where a robot stands to start from or arrive at it.
    pub fn in_corridor(&self) -> Point {
        self.at + direction(self.wall_heading_deg - 90.0) * self.lateral_mm
    }
}

/// Everything in world coordinates.
#[derive(Debug, Clone, Default)]
pub struct World {
    /// Every edge as a segment.
    pub segments: Vec<Segment>,
    /// Ceiling lights.
    pub lights: Vec<Light>,
    /// Door-number plates.
    pub plates: Vec<PlateAt>,
    /// Named positions: door jambs and `ring.node`.
    pub positions: BTreeMap<String, Position>,
    /// Node positions per ring.
    pub nodes: Vec<Vec<(String, Point)>>,
}

/// Intersection of the lines p + t·u and q + s·v, if not parallel.
pub(crate) fn intersect(p: Point, u: Vector, q: Point, v: Vector) -> Option<Point> {
    let det = u.perp(&v);
    if det.abs() < 1e-9 {
        return None;
    }
    let t = (q - p).perp(&v) / det;
    Some(p + u * t)
}

impl World {
    /// Builds the world of a (valid) map.
    pub fn from_map(map: &Map) -> World {
        let mut world = World::default();
        for (ri, ring) in map.rings.iter().enumerate() {
            let tr = trace(ring);
            let n = ring.edges.len();
            let end_of = |i: usize| {
                if i + 1 < n {
                    tr.nodes[i + 1]
                } else {
                    tr.nodes[0]
                }
            };
            world.nodes.push(
                ring.nodes
                    .iter()
                    .zip(&tr.nodes)
                    .map(|(node, p)| (node.name.clone(), *p))
                    .collect(),
            );
            // Negative (turning-space) lights pair with the next edge's.
            let mut used: Vec<Vec<bool>> = ring
                .edges
                .iter()
                .map(|e| vec![false; e.lights_mm.len()])
                .collect();
            for (ei, edge) in ring.edges.iter().enumerate() {
                let start = tr.nodes[ei];
                let h = tr.headings[ei];
                let dir = direction(h);
                let right = direction(h - 90.0);
                let lateral = edge.lateral_mm.unwrap_or(map.lateral_mm);
                world.segments.push(Segment {
                    a: start,
                    b: end_of(ei),
                    kind: edge.kind,
                    ring: ri,
                    edge: ei,
                    passage: edge.tags.get("passage").cloned(),
                });
                for (li, &d) in edge.lights_mm.iter().enumerate() {
                    if used[ei][li] {
                        continue;
                    }
                    used[ei][li] = true;
                    let foot = start + dir * d.abs();
                    let mut at = foot + right * lateral;
                    if d < 0.0 {
                        let next = (ei + 1) % n;
                        let partner = ring.edges[next]
                            .lights_mm
                            .iter()
                            .enumerate()
                            .find(|(k, v)| **v < 0.0 && !used[next][*k]);
                        if let Some((k, v)) = partner {
                            used[next][k] = true;
                            let h2 = tr.headings[next];
                            let foot2 = tr.nodes[next] + direction(h2) * v.abs();
                            if let Some(p) = intersect(foot, right, foot2, direction(h2 - 90.0)) {
                                at = p;
                            }
                        }
                    }
                    world.lights.push(Light {
                        at,
                        ring: ri,
                        edge: ei,
                    });
                }
                for plate in &edge.plates {
                    world.plates.push(PlateAt {
                        label: plate.label.clone(),
                        at: start + dir * plate.offset_mm,
                        wall_heading_deg: normalize_deg(h),
                    });
                }
                let position = |at: Point, door: bool| Position {
                    at,
                    wall_heading_deg: normalize_deg(h),
                    ring: ri,
                    edge: ei,
                    lateral_mm: lateral,
                    door,
                };
                if let Some(number) = &edge.number {
                    // Facing the door from the corridor, the edge's start
                    // is on the left (the wall is traced on the left).
                    world
                        .positions
                        .insert(format!("{number}L"), position(start, true));
                    world
                        .positions
                        .insert(format!("{number}R"), position(end_of(ei), true));
                }
                world.positions.insert(
                    format!("{}.{}", ring.name, ring.nodes[ei].name),
                    position(start, false),
                );
            }
        }
        world
    }

    /// Index in [`World::segments`] of edge `edge` of ring `ring`.
    pub fn segment(&self, ring: usize, edge: usize) -> Option<usize> {
        self.segments
            .iter()
            .position(|s| s.ring == ring && s.edge == edge)
    }

    /// Finds a position by name, accepting the thesis' spellings
    /// (`350R`, `311.double.R`, `311.doubleL`).
    pub fn position(&self, name: &str) -> Option<&Position> {
        if let Some(p) = self.positions.get(name) {
            return Some(p);
        }
        let (stem, side) = name.split_at(name.len().checked_sub(1)?);
        let stem = stem.strip_suffix('.').unwrap_or(stem);
        self.positions.get(&format!("{stem}{side}"))
    }

    /// The bounding box of all segments: (min, max).
    pub fn bounds(&self) -> (Point, Point) {
        let mut lo = pt(f64::INFINITY, f64::INFINITY);
        let mut hi = pt(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for s in &self.segments {
            for p in [s.a, s.b] {
                lo = lo.inf(&p);
                hi = hi.sup(&p);
            }
        }
        if lo.x > hi.x {
            return (pt(0.0, 0.0), pt(1.0, 1.0));
        }
        (lo, hi)
    }
}
