//! The rules a StickRep map must keep, each broken rule reported with the
//! line it is on.

use crate::geometry::distance;
use crate::model::{EdgeKind, Map};
use crate::world::{trace, Trace};
use std::collections::HashMap;
use std::fmt;

/// The longest a link may span: it joins nodes facing each other across a
/// corridor.
pub const MAX_LINK_MM: f64 = 10_000.0;

/// One broken rule.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// 1-based line number.
    pub line: usize,
    /// What is wrong and how to fix it.
    pub message: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.line, self.message)
    }
}

/// Every problem of a map, in line order; empty if the map is valid.
pub fn validate(map: &Map) -> Vec<Problem> {
    let mut out = Vec::new();
    let mut say = |line: usize, message: String| out.push(Problem { line, message });
    let mut rings: HashMap<&str, usize> = HashMap::new();
    let mut numbers: HashMap<&str, usize> = HashMap::new();
    let mut plates: HashMap<&str, usize> = HashMap::new();
    let mut markers: HashMap<crate::marker::Code, usize> = HashMap::new();
    // One trace per ring, by position: names may repeat in a broken map.
    let traces: Vec<Trace> = map.rings.iter().map(trace).collect();
    for (ri, ring) in map.rings.iter().enumerate() {
        if let Some(first) = rings.insert(&ring.name, ring.line) {
            say(
                ring.line,
                format!("ring '{}' is already defined on line {first}", ring.name),
            );
        }
        if ring.nodes.len() < 3 {
            say(
                ring.line,
                format!(
                    "ring '{}' has {} node(s); a closed contour needs at least 3",
                    ring.name,
                    ring.nodes.len()
                ),
            );
            continue;
        }
        let mut names: HashMap<&str, usize> = HashMap::new();
        for node in &ring.nodes {
            if let Some(first) = names.insert(&node.name, node.line) {
                say(
                    node.line,
                    format!(
                        "node '{}' is already in ring '{}' (line {first})",
                        node.name, ring.name
                    ),
                );
            }
            let a = node.angle_deg.abs();
            if !(a > 0.0 && a < 360.0) {
                say(node.line, format!("adjacency angle of '{}' must be between 0 and 360 degrees (negative for a building corner), got {}", node.name, node.angle_deg));
            }
        }
        let n = ring.edges.len();
        for (i, edge) in ring.edges.iter().enumerate() {
            let kind = edge.kind.keyword();
            if edge.length_mm <= 0.0 {
                say(
                    edge.line,
                    format!("{kind} length must be positive, got {}", edge.length_mm),
                );
            }
            for &d in &edge.lights_mm {
                if d == 0.0 || d.abs() > edge.length_mm {
                    say(edge.line, format!("light offset {d} is outside its {kind} of length {} (offsets are 0 < |d| ≤ length)", edge.length_mm));
                }
            }
            let negatives = edge.lights_mm.iter().filter(|d| **d < 0.0).count();
            if negatives > 0 {
                let prev = &ring.edges[(i + n - 1) % n];
                let next = &ring.edges[(i + 1) % n];
                let paired = prev
                    .lights_mm
                    .iter()
                    .chain(&next.lights_mm)
                    .any(|d| *d < 0.0);
                if !paired {
                    say(edge.line, "a negative light offset marks a turning-space light projected onto two adjacent edges, but neither neighbouring edge has one".to_string());
                }
            }
            for plate in &edge.plates {
                if plate.offset_mm < 0.0 || plate.offset_mm > edge.length_mm {
                    say(
                        edge.line,
                        format!(
                            "plate '{}' at {} mm is outside its {kind} of length {}",
                            plate.label, plate.offset_mm, edge.length_mm
                        ),
                    );
                }
                if let Some(first) = plates.insert(&plate.label, edge.line) {
                    say(
                        edge.line,
                        format!("plate '{}' is already on line {first}", plate.label),
                    );
                }
            }
            match crate::marker::of_edge(edge) {
                Some(_) if edge.kind != EdgeKind::Elevator => say(
                    edge.line,
                    format!("a {kind} has no marker; markers are pasted on elevator doors"),
                ),
                Some(Err(e)) => say(edge.line, e),
                Some(Ok(code)) => {
                    if let Some(first) = markers.insert(code, edge.line) {
                        say(edge.line, format!("marker {code} is already on line {first}: each elevator has its own code"));
                    }
                }
                None => {}
            }
            if let Some(number) = &edge.number {
                if matches!(edge.kind, EdgeKind::Wall | EdgeKind::Window) {
                    say(edge.line, format!("a {kind} has no number; only doors, elevators, glass doors and openings do"));
                }
                if let Some(first) = numbers.insert(number, edge.line) {
                    say(
                        edge.line,
                        format!("door number '{number}' is already on line {first}"),
                    );
                }
            }
        }
        let tr = &traces[ri];
        let turn = tr.total_turn_deg;
        if (turn.abs() - 360.0).abs() > 0.01 {
            say(ring.line, format!("the turns of ring '{}' add up to {turn:.2}°, not ±360°: an adjacency angle is wrong (180 is straight on; 270 a right turn, 90 a left turn)", ring.name));
        }
        let miss = distance(tr.end, ring.at_mm);
        if miss > map.tolerance_mm {
            say(ring.line, format!("ring '{}' misses closing by {miss:.0} mm (tolerance {} mm): its last edge ends at ({:.0}, {:.0}), not at its first node ({:.0}, {:.0}); check lengths and angles", ring.name, map.tolerance_mm, tr.end.x, tr.end.y, ring.at_mm.x, ring.at_mm.y));
        }
    }
    for link in &map.links {
        let mut ends = Vec::new();
        for (ring, node) in [&link.a, &link.b] {
            match map.rings.iter().position(|r| &r.name == ring) {
                None => say(
                    link.line,
                    format!("link names ring '{ring}', which does not exist"),
                ),
                Some(ri) => match map.rings[ri].nodes.iter().position(|n| &n.name == node) {
                    None => say(
                        link.line,
                        format!("link names node '{node}', which ring '{ring}' does not have"),
                    ),
                    Some(i) => ends.push(traces[ri].nodes.get(i).copied()),
                },
            }
        }
        if link.a.0 == link.b.0 {
            say(
                link.line,
                format!("a link joins two rings; both ends are on '{}'", link.a.0),
            );
        }
        if let [Some(p), Some(q)] = ends[..] {
            let span = distance(p, q);
            if span > MAX_LINK_MM {
                say(link.line, format!("link spans {:.1} m; it should join nodes facing each other across a corridor (at most {} m)", span / 1000.0, MAX_LINK_MM / 1000.0));
            }
        }
    }
    out.sort_by_key(|p| p.line);
    out
}
