//! Text → [`Map`]. One statement per line; `#` starts a comment.
//!
//! ```text
//! map Figure 5.3: a hypothetical building
//! tolerance 50                    # rings must close within 50 mm
//! lateral 1500                    # lights 1.5 m from their wall unless told
//! ring outer at 0 30000 heading -90
//!   node A -270
//!   wall 8000 lights 4000
//!   node L1 180
//!   door 1500 number L1L2 plate L1L2 -300
//!   ...
//! end
//! link outer.A inner.P
//! ```
//!
//! See `docs/stickrep.md` for every statement.

use crate::model::{Edge, EdgeKind, Link, Map, Node, Plate, Ring};
use std::collections::BTreeMap;
use std::fmt;

/// A line the parser could not understand.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub struct ParseError {
    /// The file name, as given to [`parse`].
    pub file: String,
    /// 1-based line number.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.file, self.line, self.message)
    }
}

/// Default closing tolerance of a ring, mm.
pub const DEFAULT_TOLERANCE_MM: f64 = 100.0;
/// Default distance of ceiling lights from their wall, mm.
pub const DEFAULT_LATERAL_MM: f64 = 1500.0;

struct Parser<'a> {
    file: &'a str,
    map: Map,
    ring: Option<Ring>,
    expect_node: bool,
}

fn number(word: Option<&str>, what: &str) -> Result<f64, String> {
    let word = word.ok_or_else(|| format!("missing {what}"))?;
    let value: f64 = word
        .parse()
        .map_err(|_| format!("{what} must be a number, got '{word}'"))?;
    if !value.is_finite() {
        return Err(format!("{what} must be finite, got '{word}'"));
    }
    Ok(value)
}

fn name<'w>(word: Option<&'w str>, what: &str) -> Result<&'w str, String> {
    word.ok_or_else(|| format!("missing {what}"))
}

impl Parser<'_> {
    fn statement(&mut self, line: usize, words: &[&str]) -> Result<(), String> {
        let mut it = words.iter().copied();
        let Some(keyword) = it.next() else {
            return Ok(());
        };
        match keyword {
            "map" => {
                self.outside_ring("map")?;
                self.map.name = words[1..].join(" ");
            }
            "tolerance" => {
                self.outside_ring("tolerance")?;
                self.map.tolerance_mm = positive(number(it.next(), "tolerance (mm)")?, "tolerance")?;
                none_left(it)?;
            }
            "lateral" => {
                self.outside_ring("lateral")?;
                self.map.lateral_mm = positive(number(it.next(), "lateral distance (mm)")?, "lateral distance")?;
                none_left(it)?;
            }
            "ring" => {
                if let Some(open) = &self.ring {
                    return Err(format!(
                        "ring '{}' (line {}) is not closed with 'end' before a new ring",
                        open.name, open.line
                    ));
                }
                let ring_name = name(it.next(), "ring name")?;
                if ring_name.contains('.') {
                    return Err(format!("ring name '{ring_name}' may not contain '.' (links name ring.node)"));
                }
                expect(it.next(), "at")?;
                let x = number(it.next(), "x (mm)")?;
                let y = number(it.next(), "y (mm)")?;
                expect(it.next(), "heading")?;
                let heading = number(it.next(), "heading (degrees)")?;
                none_left(it)?;
                self.ring = Some(Ring {
                    name: ring_name.to_string(),
                    at_mm: crate::geometry::Point::new(x, y),
                    heading_deg: heading,
                    nodes: Vec::new(),
                    edges: Vec::new(),
                    line,
                });
                self.expect_node = true;
            }
            "node" => {
                let expect_node = self.expect_node;
                let ring = self.ring.as_mut().ok_or("'node' outside a ring")?;
                if !expect_node {
                    let prev = ring.nodes.last().map_or("", |n| n.name.as_str());
                    return Err(format!("two nodes in a row: an edge must follow node '{prev}'"));
                }
                let node_name = name(it.next(), "node name")?;
                let angle = number(it.next(), "adjacency angle (degrees)")?;
                none_left(it)?;
                ring.nodes.push(Node {
                    name: node_name.to_string(),
                    angle_deg: angle,
                    line,
                });
                self.expect_node = false;
            }
            "end" => {
                let ring = self.ring.take().ok_or("'end' without a ring")?;
                if ring.nodes.is_empty() {
                    return Err(format!("ring '{}' has no nodes", ring.name));
                }
                if !self.expect_node {
                    let last = ring.nodes.last().map_or("", |n| n.name.as_str());
                    return Err(format!(
                        "ring '{}' ends at node '{last}': it needs the edge from '{last}' back to '{}'",
                        ring.name, ring.nodes[0].name
                    ));
                }
                none_left(it)?;
                self.map.rings.push(ring);
                self.expect_node = false;
            }
            "link" => {
                self.outside_ring("link")?;
                let a = ring_node(it.next())?;
                let b = ring_node(it.next())?;
                none_left(it)?;
                self.map.links.push(Link { a, b, line });
            }
            word => match EdgeKind::from_keyword(word) {
                Some(kind) => {
                    let expect_node = self.expect_node;
                    let ring = self
                        .ring
                        .as_mut()
                        .ok_or_else(|| format!("'{word}' outside a ring"))?;
                    if expect_node {
                        return Err(match ring.nodes.last() {
                            None => format!("a ring starts with a node, not '{word}'"),
                            Some(n) => format!("two edges in a row after node '{}': a node must come between", n.name),
                        });
                    }
                    ring.edges.push(edge(kind, &words[1..], line)?);
                    self.expect_node = true;
                }
                None => {
                    return Err(format!(
                        "unknown statement '{word}'; expected map, tolerance, lateral, ring, node, end, link or an edge ({})",
                        EdgeKind::ALL.map(|(_, w)| w).join(", ")
                    ))
                }
            },
        }
        Ok(())
    }

    fn outside_ring(&self, what: &str) -> Result<(), String> {
        match &self.ring {
            Some(r) => Err(format!(
                "'{what}' inside ring '{}'; close it with 'end' first",
                r.name
            )),
            None => Ok(()),
        }
    }
}

fn positive(v: f64, what: &str) -> Result<f64, String> {
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{what} must be positive, got {v}"))
    }
}

fn expect(word: Option<&str>, keyword: &str) -> Result<(), String> {
    match word {
        Some(w) if w == keyword => Ok(()),
        Some(w) => Err(format!("expected '{keyword}', got '{w}'")),
        None => Err(format!("expected '{keyword}'")),
    }
}

fn none_left<'a>(mut it: impl Iterator<Item = &'a str>) -> Result<(), String> {
    match it.next() {
        Some(w) => Err(format!("unexpected '{w}' at the end of the line")),
        None => Ok(()),
    }
}

fn ring_node(word: Option<&str>) -> Result<(String, String), String> {
    let word = word.ok_or("a link needs two ends, ring.node ring.node")?;
    let (ring, node) = word
        .split_once('.')
        .ok_or_else(|| format!("link end '{word}' must be ring.node"))?;
    Ok((ring.to_string(), node.to_string()))
}

fn edge(kind: EdgeKind, words: &[&str], line: usize) -> Result<Edge, String> {
    let mut it = words.iter().copied().peekable();
    let length = number(it.next(), &format!("{} length (mm)", kind.keyword()))?;
    let mut edge = Edge {
        kind,
        length_mm: length,
        lights_mm: Vec::new(),
        lateral_mm: None,
        number: None,
        plates: Vec::new(),
        tags: BTreeMap::new(),
        line,
    };
    while let Some(word) = it.next() {
        match word {
            "lights" => {
                let mut any = false;
                // Offsets run until the next option; a word that reads as a
                // number but is not finite ('nan', 'inf') is an error.
                while let Some(&w) = it.peek().filter(|w| w.parse::<f64>().is_ok()) {
                    edge.lights_mm.push(number(Some(w), "light offset (mm)")?);
                    it.next();
                    any = true;
                }
                if !any {
                    return Err("'lights' needs at least one offset (mm)".into());
                }
            }
            "lateral" => edge.lateral_mm = Some(positive(number(it.next(), "lateral distance (mm)")?, "lateral distance")?),
            "number" => {
                let label = name(it.next(), "door number")?;
                if edge.number.replace(label.to_string()).is_some() {
                    return Err("an edge has one 'number'".into());
                }
            }
            "plate" => {
                let label = name(it.next(), "plate label")?;
                let offset = number(it.next(), "plate offset (mm)")?;
                edge.plates.push(Plate {
                    label: label.to_string(),
                    offset_mm: offset,
                });
            }
            tag if tag.contains('=') => {
                let (k, v) = tag.split_once('=').unwrap_or((tag, ""));
                // A passage's name becomes a semaphore's name: one key chunk.
                if k == "passage"
                    && (v.is_empty()
                        || !v
                            .chars()
                            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-'))
                {
                    return Err(format!(
                        "passage name '{v}' must be letters, digits, '_' or '-' (it names the passage's semaphore)"
                    ));
                }
                edge.tags.insert(k.to_string(), v.to_string());
            }
            other => {
                return Err(format!(
                    "unknown edge option '{other}'; expected lights, lateral, number, plate or key=value"
                ))
            }
        }
    }
    Ok(edge)
}

/// Parses a map; `file` only names the source in errors.
pub fn parse(file: &str, text: &str) -> Result<Map, ParseError> {
    let mut p = Parser {
        file,
        map: Map {
            name: String::new(),
            tolerance_mm: DEFAULT_TOLERANCE_MM,
            lateral_mm: DEFAULT_LATERAL_MM,
            rings: Vec::new(),
            links: Vec::new(),
        },
        ring: None,
        expect_node: false,
    };
    let mut last = 0;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        last = line;
        let content = raw.split('#').next().unwrap_or("");
        let words: Vec<&str> = content.split_whitespace().collect();
        p.statement(line, &words).map_err(|message| ParseError {
            file: p.file.to_string(),
            line,
            message,
        })?;
    }
    if let Some(ring) = &p.ring {
        return Err(ParseError {
            file: file.to_string(),
            line: last.max(1),
            message: format!(
                "ring '{}' (line {}) is never closed with 'end'",
                ring.name, ring.line
            ),
        });
    }
    if p.map.rings.is_empty() {
        return Err(ParseError {
            file: file.to_string(),
            line: last.max(1),
            message: "the map has no rings".into(),
        });
    }
    Ok(p.map)
}
