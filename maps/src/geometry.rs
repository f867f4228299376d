//! A map in world coordinates: x East, y North, millimetres; headings in
//! degrees with North 0 and West 90 (counter-clockwise), as in the thesis.
//!
//! Points and displacements are nalgebra's ([`Point`], [`Vector`]); a
//! heading is a [`Heading`], which knows the thesis' convention and turns
//! into nalgebra's rotation; a robot's pose is a [`Pose`], the one pose
//! type of the simulator and the navigation clients.

use crate::model::{EdgeKind, Map, Ring};
pub use nalgebra::{Isometry2, Point2, UnitComplex, Vector2};
use std::collections::BTreeMap;

/// A point, mm (x East, y North).
pub type Point = Point2<f64>;

/// A displacement, mm.
pub type Vector = Vector2<f64>;

/// A point from its coordinates, mm.
pub fn pt(x: f64, y: f64) -> Point {
    Point::new(x, y)
}

/// A heading in the thesis' convention: degrees, North 0, West 90
/// (counter-clockwise), East −90. Kept as given; [`Heading::normalized`]
/// brings it into (−180, 180].
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Heading(f64);

impl Heading {
    /// North.
    pub const NORTH: Heading = Heading(0.0);

    /// A heading of `deg` degrees (North 0, West 90).
    pub const fn from_deg(deg: f64) -> Heading {
        Heading(deg)
    }

    /// Degrees (North 0, West 90), as given.
    pub const fn deg(self) -> f64 {
        self.0
    }

    /// The same direction in (−180, 180].
    pub fn normalized(self) -> Heading {
        Heading(normalize_deg(self.0))
    }

    /// Turned `deg` degrees counter-clockwise.
    pub fn turned(self, deg: f64) -> Heading {
        Heading(self.0 + deg)
    }

    /// The signed turn from `other` to `self`, degrees in (−180, 180].
    pub fn minus(self, other: Heading) -> f64 {
        normalize_deg(self.0 - other.0)
    }

    /// The unit vector pointing this way.
    pub fn unit(self) -> Vector {
        self.rotation() * Vector::x()
    }

    /// The rotation that takes the x axis (East) to this heading: the
    /// thesis' North 0 is the mathematician's 90°.
    pub fn rotation(self) -> UnitComplex<f64> {
        UnitComplex::new((self.0 + 90.0).to_radians())
    }

    /// The heading of a direction (North for a zero vector).
    pub fn of(v: Vector) -> Heading {
        if v.x == 0.0 && v.y == 0.0 {
            return Heading::NORTH;
        }
        Heading(normalize_deg((-v.x).atan2(v.y).to_degrees()))
    }
}

/// The degrees, with the formatter's width and precision (`{:.0}°`).
impl std::fmt::Display for Heading {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(&self.0, f)
    }
}

/// Where a robot is and which way it faces: the one pose type of the
/// simulator (truth) and the navigation clients (odometry).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose {
    /// Position, mm.
    pub at: Point,
    /// Heading.
    pub heading: Heading,
}

impl Pose {
    /// A pose at (`x`, `y`) mm heading `heading_deg` (North 0, West 90).
    pub fn new(x: f64, y: f64, heading_deg: f64) -> Pose {
        Pose {
            at: Point::new(x, y),
            heading: Heading::from_deg(heading_deg),
        }
    }

    /// Distance between two poses' positions, mm.
    pub fn dist(&self, other: &Pose) -> f64 {
        nalgebra::distance(&self.at, &other.at)
    }

    /// The point `d` mm ahead.
    pub fn ahead(&self, d: f64) -> Point {
        self.at + self.heading.unit() * d
    }

    /// As an isometry: robot frame (x ahead, y to the left) to world.
    pub fn isometry(&self) -> Isometry2<f64> {
        Isometry2::from_parts(self.at.coords.into(), self.heading.rotation())
    }
}

/// Unit vector of a heading in degrees (North 0, West 90).
pub fn direction(heading_deg: f64) -> Vector {
    Heading::from_deg(heading_deg).unit()
}

/// Heading from p towards q, degrees (North 0, West 90).
pub fn heading_to(p: Point, q: Point) -> f64 {
    Heading::of(q - p).deg()
}

/// Normalises an angle to (-180, 180].
pub fn normalize_deg(a: f64) -> f64 {
    let mut a = a % 360.0;
    if a <= -180.0 {
        a += 360.0;
    } else if a > 180.0 {
        a -= 360.0;
    }
    a
}

/// Distance between two points, mm.
pub fn distance(p: Point, q: Point) -> f64 {
    nalgebra::distance(&p, &q)
}

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
                let position = |at: Point| Position {
                    at,
                    wall_heading_deg: normalize_deg(h),
                    ring: ri,
                    edge: ei,
                    lateral_mm: lateral,
                };
                if let Some(number) = &edge.number {
                    // Facing the door from the corridor, the edge's start
                    // is on the left (the wall is traced on the left).
                    world
                        .positions
                        .insert(format!("{number}L"), position(start));
                    world
                        .positions
                        .insert(format!("{number}R"), position(end_of(ei)));
                }
                world.positions.insert(
                    format!("{}.{}", ring.name, ring.nodes[ei].name),
                    position(start),
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

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vector, b: Vector) -> bool {
        (a - b).norm() < 1e-12
    }

    #[test]
    fn headings_follow_the_thesis_north_0_west_90() {
        assert!(close(Heading::from_deg(0.0).unit(), Vector::new(0.0, 1.0)));
        assert!(close(
            Heading::from_deg(90.0).unit(),
            Vector::new(-1.0, 0.0)
        ));
        assert!(close(
            Heading::from_deg(-90.0).unit(),
            Vector::new(1.0, 0.0)
        ));
        assert!(close(
            Heading::from_deg(180.0).unit(),
            Vector::new(0.0, -1.0)
        ));
        for deg in [-179.0, -90.0, -12.5, 0.0, 45.0, 90.0, 180.0] {
            let h = Heading::from_deg(deg);
            assert!((Heading::of(h.unit()).deg() - deg).abs() < 1e-9, "{deg}");
        }
        assert_eq!(heading_to(pt(0.0, 0.0), pt(-5.0, 0.0)), 90.0);
        assert_eq!(
            Heading::from_deg(350.0).minus(Heading::from_deg(10.0)),
            -20.0
        );
        assert_eq!(Heading::from_deg(540.0).normalized().deg(), 180.0);
        assert_eq!(format!("{:.0}°", Heading::from_deg(89.6)), "90°");
    }

    #[test]
    fn a_pose_is_an_isometry_from_the_robot_frame() {
        // Facing West at (1000, 2000): one metre ahead is x = 0.
        let p = Pose::new(1_000.0, 2_000.0, 90.0);
        let ahead = p.isometry() * Point::new(1_000.0, 0.0);
        assert!((ahead - pt(0.0, 2_000.0)).norm() < 1e-9, "{ahead}");
        assert!((p.ahead(1_000.0) - ahead).norm() < 1e-9);
        // The robot's left (robot-frame +y) is South when facing West.
        let left = p.isometry() * Point::new(0.0, 500.0);
        assert!((left - pt(1_000.0, 1_500.0)).norm() < 1e-9, "{left}");
        assert_eq!(p.dist(&Pose::new(1_000.0, 2_003.0, 0.0)), 3.0);
    }
}
