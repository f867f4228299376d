//! What a map file says: rings of nodes and edges, and links between rings.

use std::collections::BTreeMap;

/// The kind of an edge (§5.1: wall segment or door; §7.2 adds more).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EdgeKind {
    /// A wall segment.
    Wall,
    /// A door (sonar sees it closed).
    Door,
    /// An elevator door.
    Elevator,
    /// A window or glass-brick wall (seen by sonar).
    Window,
    /// Glass that sonar does not see (specular): the ACS laboratory door.
    Glass,
    /// An opening: no wall at all (a corridor mouth across a turning space).
    Opening,
}

impl EdgeKind {
    /// Every kind, with its keyword.
    pub const ALL: [(EdgeKind, &'static str); 6] = [
        (EdgeKind::Wall, "wall"),
        (EdgeKind::Door, "door"),
        (EdgeKind::Elevator, "elevator"),
        (EdgeKind::Window, "window"),
        (EdgeKind::Glass, "glass"),
        (EdgeKind::Opening, "opening"),
    ];

    /// The keyword in map files.
    pub fn keyword(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(k, _)| *k == self)
            .map_or("wall", |(_, w)| w)
    }

    /// The kind for a keyword.
    pub fn from_keyword(word: &str) -> Option<Self> {
        Self::ALL.iter().find(|(_, w)| *w == word).map(|(k, _)| *k)
    }
}

/// A vertical edge of the building: a junction of walls or a door jamb.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Its name, unique in its ring.
    pub name: String,
    /// Adjacency angle in degrees: the counter-clockwise angle from the
    /// next edge to the previous one (180 = straight on); negative at a
    /// corner of the building.
    pub angle_deg: f64,
    /// Line in the file.
    pub line: usize,
}

impl Node {
    /// Whether the node is a building corner (negative angle).
    pub fn is_corner(&self) -> bool {
        self.angle_deg < 0.0
    }

    /// How much the tracing turns here, counter-clockwise, in degrees.
    pub fn turn_deg(&self) -> f64 {
        180.0 - self.angle_deg.abs()
    }
}

/// A door-number plate on the wall.
#[derive(Debug, Clone, PartialEq)]
pub struct Plate {
    /// What it reads (`350`, `A342`, `364.double`).
    pub label: String,
    /// Where along its edge, mm from the edge's start node.
    pub offset_mm: f64,
}

/// An edge between two consecutive nodes of a ring.
#[derive(Debug, Clone, PartialEq)]
pub struct Edge {
    /// Wall, door, …
    pub kind: EdgeKind,
    /// Length in mm.
    pub length_mm: f64,
    /// Ceiling lights projected onto the edge, mm from its start node
    /// (Table 5.1); negative for a light in a turning space, projected onto
    /// this edge and an adjacent one.
    pub lights_mm: Vec<f64>,
    /// How far the lights are from this wall, mm (the map's default if unset).
    pub lateral_mm: Option<f64>,
    /// A door's number: its jambs are the positions `<number>L` and `<number>R`.
    pub number: Option<String>,
    /// Door-number plates on this edge.
    pub plates: Vec<Plate>,
    /// Free attributes (`corridor=G`, `floor=metal` …).
    pub tags: BTreeMap<String, String>,
    /// Line in the file.
    pub line: usize,
}

/// A closed contour traced with the wall on the left.
#[derive(Debug, Clone, PartialEq)]
pub struct Ring {
    /// Its name, unique in the map.
    pub name: String,
    /// Where its first node is: x (East) and y (North), mm.
    pub at_mm: crate::geometry::Point,
    /// The heading of its first edge, degrees (North 0, West 90).
    pub heading_deg: f64,
    /// Its nodes in tracing order; edge i runs from node i to node i+1
    /// (the last back to the first).
    pub nodes: Vec<Node>,
    /// Its edges, as many as nodes.
    pub edges: Vec<Edge>,
    /// Line of its `ring` statement.
    pub line: usize,
}

/// A place where a path may cross from one ring to another (§7.2): two
/// nodes facing each other across a corridor.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// `(ring, node)` on one side.
    pub a: (String, String),
    /// `(ring, node)` on the other.
    pub b: (String, String),
    /// Line in the file.
    pub line: usize,
}

/// A whole map.
#[derive(Debug, Clone, PartialEq)]
pub struct Map {
    /// Its title.
    pub name: String,
    /// How far a ring may miss closing, mm.
    pub tolerance_mm: f64,
    /// Default distance of ceiling lights from their wall, mm.
    pub lateral_mm: f64,
    /// Its rings.
    pub rings: Vec<Ring>,
    /// Links between rings.
    pub links: Vec<Link>,
}

impl Map {
    /// The ring of that name.
    pub fn ring(&self, name: &str) -> Option<&Ring> {
        self.rings.iter().find(|r| r.name == name)
    }
}
