//! A building of several floors (§5.4.6): each floor a StickRep map, the
//! floors joined by their elevators. An elevator is an `elevator` edge with
//! a `number`; the same number on two or more floors is one shaft, whose
//! car goes between them.
//!
//! ```text
//! # maps/data/tower.bldg
//! building EB3 tower
//! floor 3 eb3                # a built-in map …
//! floor 4 tower-4.stk        # … or a file beside this one
//! ```
//!
//! A position in a building is `FLOOR:POSITION` (`4:450R`). A route between
//! floors rides one elevator: the shortest walk to an elevator door that
//! serves both floors, the ride, and the walk from that door on the other
//! floor.

use crate::geometry::{pt, Point};
use crate::model::{EdgeKind, Map};
use crate::route::{Network, Route, RouteError};
use crate::world::World;
use crate::LoadError;
use std::path::Path;

/// One floor of a building.
#[derive(Debug, Clone)]
pub struct Floor {
    /// Its name, as positions use it (`3` in `3:350R`).
    pub name: String,
    /// Its map.
    pub map: Map,
    /// The map in world coordinates.
    pub world: World,
    /// The map as the building names it (a file or a built-in map).
    pub source: String,
    /// Line of its `floor` statement.
    pub line: usize,
}

/// One elevator shaft: a number, and the floors whose maps have an
/// elevator door of that number.
#[derive(Debug, Clone, PartialEq)]
pub struct Elevator {
    /// The doors' number (`acs.elev`).
    pub number: String,
    /// Indices into [`Building::floors`], in the building's order.
    pub floors: Vec<usize>,
}

/// A whole building.
#[derive(Debug, Clone)]
pub struct Building {
    /// Its title.
    pub name: String,
    /// Its floors, in the file's order.
    pub floors: Vec<Floor>,
    /// Its elevators, sorted by number.
    pub elevators: Vec<Elevator>,
}

/// A route through a building: a walk on each floor it crosses, and the
/// elevator ride between two walks.
#[derive(Debug, Clone)]
pub struct BuildingRoute {
    /// `(floor index, walk)` in order: one walk, or two with a ride between.
    pub walks: Vec<(usize, Route)>,
    /// The elevator ridden, if the route changes floor.
    pub ride: Option<String>,
}

impl BuildingRoute {
    /// Length walked, mm (the ride not counted).
    pub fn walked_mm(&self) -> f64 {
        self.walks.iter().map(|(_, r)| r.length_mm).sum()
    }
}

/// Reads a building file: its floors (each loaded and checked as a map)
/// and their elevators. Every problem is reported, each as `FILE:LINE:`.
pub fn load_building(path: &Path) -> Result<Building, LoadError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| LoadError::Io {
        path: file.clone(),
        detail: e.to_string(),
    })?;
    let dir = path.parent().unwrap_or(Path::new("."));
    building_from_text(&file, &text, |name| {
        let beside = dir.join(name);
        if beside.exists() {
            crate::load(&beside)
        } else {
            crate::load_named(name)
        }
    })
}

/// A building from its text; `floor_map` loads a floor's map by the name
/// the text gives.
pub fn building_from_text(
    file: &str,
    text: &str,
    floor_map: impl Fn(&str) -> Result<Map, LoadError>,
) -> Result<Building, LoadError> {
    let mut problems: Vec<String> = Vec::new();
    let mut say = |line: usize, message: String| problems.push(format!("{file}:{line}: {message}"));
    let mut name = String::new();
    let mut floors: Vec<Floor> = Vec::new();
    let mut floor_errors = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let words: Vec<&str> = raw
            .split('#')
            .next()
            .unwrap_or("")
            .split_whitespace()
            .collect();
        match words.as_slice() {
            [] => {}
            ["building", title @ ..] if !title.is_empty() => name = title.join(" "),
            ["floor", floor, map] => {
                if floor.contains(':') {
                    say(line, format!("a floor's name cannot hold ':' (it separates floor and position, as in 3:350R): '{floor}'"));
                } else if floors.iter().any(|f| f.name == *floor) {
                    say(line, format!("floor '{floor}' is named twice"));
                } else {
                    match floor_map(map) {
                        Ok(m) => floors.push(Floor {
                            name: floor.to_string(),
                            world: World::from_map(&m),
                            map: m,
                            source: map.to_string(),
                            line,
                        }),
                        Err(e) => {
                            say(
                                line,
                                format!("floor '{floor}': its map '{map}' does not load:"),
                            );
                            floor_errors.push(e.to_string());
                        }
                    }
                }
            }
            ["floor", ..] => say(
                line,
                "a floor is `floor NAME MAP` (a map file beside this one, or a built-in map)"
                    .into(),
            ),
            _ => say(
                line,
                format!(
                    "not a building statement: '{}' (building TITLE…, floor NAME MAP)",
                    raw.trim()
                ),
            ),
        }
    }
    if floors.is_empty() && floor_errors.is_empty() {
        say(1, "a building needs at least one `floor NAME MAP`".into());
    }
    let elevators = shafts(&floors);
    for e in elevators.iter().filter(|e| e.floors.len() == 1) {
        let f = &floors[e.floors[0]];
        let at = elevator_line(&f.map, &e.number).unwrap_or(0);
        problems.push(format!(
            "{}:{at}: elevator '{}' is on floor '{}' only ({file}:{}): an elevator joins floors, so give its door the same number on another floor",
            f.source, e.number, f.name, f.line
        ));
    }
    // Each elevator has its own code, the same on every floor, so a robot
    // knows the car by its marker wherever it stands.
    let mut codes: Vec<(crate::marker::Code, &str)> = Vec::new();
    for e in &elevators {
        let mut first: Option<(crate::marker::Code, &str)> = None;
        for &fi in &e.floors {
            let f = &floors[fi];
            let Some((code, at)) = marker_of(&f.map, &e.number) else {
                continue;
            };
            match first {
                Some((c, name)) if c != code => problems.push(format!(
                    "{}:{at}: elevator '{}' has marker {code} on floor '{}' but {c} on floor '{name}': an elevator carries one code on every floor",
                    f.source, e.number, f.name
                )),
                Some(_) => {}
                None => first = Some((code, &f.name)),
            }
            if let Some((_, other)) = codes.iter().find(|(c, n)| *c == code && *n != e.number) {
                problems.push(format!(
                    "{}:{at}: elevator '{}' has marker {code}, as elevator '{other}' has: each elevator has its own code",
                    f.source, e.number
                ));
            } else if !codes.iter().any(|(c, _)| *c == code) {
                codes.push((code, &e.number));
            }
        }
    }
    if problems.is_empty() && floor_errors.is_empty() {
        paint(&mut floors, &elevators, &codes);
        return Ok(Building {
            name,
            floors,
            elevators,
        });
    }
    problems.extend(floor_errors);
    Err(LoadError::Building(problems.join("\n")))
}

/// Gives every elevator without a `marker=` on any floor the first code no
/// other elevator of the building has, in the order of their numbers, on
/// all its floors: a building drawn without markers can still be ridden.
/// Past the five codes there are, an elevator stays unmarked.
fn paint(floors: &mut [Floor], elevators: &[Elevator], taken: &[(crate::marker::Code, &str)]) {
    let mut free = crate::marker::Code::all()
        .into_iter()
        .filter(|c| !taken.iter().any(|(t, _)| t == c));
    for e in elevators {
        if taken.iter().any(|(_, n)| *n == e.number) {
            continue;
        }
        let Some(code) = free.next() else {
            return;
        };
        for &fi in &e.floors {
            let f = &mut floors[fi];
            for edge in f.map.rings.iter_mut().flat_map(|r| r.edges.iter_mut()) {
                if edge.kind == EdgeKind::Elevator && edge.number.as_deref() == Some(&e.number) {
                    edge.tags.insert("marker".into(), code.to_string());
                }
            }
        }
    }
}

/// Every elevator number and the floors that have a door with it.
fn shafts(floors: &[Floor]) -> Vec<Elevator> {
    let mut out: Vec<Elevator> = Vec::new();
    for (i, f) in floors.iter().enumerate() {
        for n in elevator_numbers(&f.map) {
            match out.iter_mut().find(|e| e.number == n) {
                Some(e) if !e.floors.contains(&i) => e.floors.push(i),
                Some(_) => {}
                None => out.push(Elevator {
                    number: n,
                    floors: vec![i],
                }),
            }
        }
    }
    out.sort_by(|a, b| a.number.cmp(&b.number));
    out
}

fn elevator_numbers(map: &Map) -> Vec<String> {
    map.rings
        .iter()
        .flat_map(|r| &r.edges)
        .filter(|e| e.kind == EdgeKind::Elevator)
        .filter_map(|e| e.number.clone())
        .collect()
}

/// The marker on an elevator's door on one floor, and its line.
fn marker_of(map: &Map, number: &str) -> Option<(crate::marker::Code, usize)> {
    map.rings
        .iter()
        .flat_map(|r| &r.edges)
        .filter(|e| e.kind == EdgeKind::Elevator && e.number.as_deref() == Some(number))
        .find_map(|e| Some((crate::marker::of_edge(e)?.ok()?, e.line)))
}

fn elevator_line(map: &Map, number: &str) -> Option<usize> {
    map.rings
        .iter()
        .flat_map(|r| &r.edges)
        .find(|e| e.kind == EdgeKind::Elevator && e.number.as_deref() == Some(number))
        .map(|e| e.line)
}

impl Building {
    /// The marker on elevator `number`'s doors, if it has one (the same on
    /// every floor).
    pub fn marker(&self, number: &str) -> Option<crate::marker::Code> {
        self.floors
            .iter()
            .find_map(|f| marker_of(&f.map, number))
            .map(|(c, _)| c)
    }

    /// The floor of that name.
    pub fn floor(&self, name: &str) -> Option<usize> {
        self.floors.iter().position(|f| f.name == name)
    }

    /// Splits `FLOOR:POSITION`; a position without a floor is on the first.
    pub fn locate<'p>(&self, position: &'p str) -> Result<(usize, &'p str), RouteError> {
        let (floor, pos) = match position.split_once(':') {
            Some((f, p)) => (f, p),
            None => (
                self.floors.first().map_or("", |f| f.name.as_str()),
                position,
            ),
        };
        let k = self.floor(floor).ok_or_else(|| RouteError::Unknown {
            name: position.to_string(),
            // The floors that have such a position.
            similar: self
                .floors
                .iter()
                .filter(|f| f.world.position(pos).is_some())
                .map(|f| format!("{}:{pos}", f.name))
                .collect(),
        })?;
        Ok((k, pos))
    }

    /// The shortest route from one `FLOOR:POSITION` to another, riding the
    /// elevator that makes the walk shortest when the floors differ.
    pub fn route(&self, from: &str, to: &str) -> Result<BuildingRoute, RouteError> {
        let (fa, a) = self.locate(from)?;
        let (fb, b) = self.locate(to)?;
        let walk = |k: usize, start: (&str, Point), goal: &str| {
            let f = &self.floors[k];
            f.world
                .route_from(&Network::new(&f.map, &f.world), start, &[], goal)
        };
        let at = |k: usize, pos: &str| {
            self.floors[k]
                .world
                .position(pos)
                .map(|p| p.in_corridor())
                .ok_or_else(|| RouteError::Unknown {
                    name: format!("{}:{pos}", self.floors[k].name),
                    similar: self.floors[k]
                        .world
                        .similar(pos)
                        .into_iter()
                        .map(|s| format!("{}:{s}", self.floors[k].name))
                        .collect(),
                })
        };
        let start = at(fa, a)?;
        at(fb, b)?;
        if fa == fb {
            return Ok(BuildingRoute {
                walks: vec![(fa, walk(fa, (a, start), b)?)],
                ride: None,
            });
        }
        let mut best: Option<BuildingRoute> = None;
        for e in self
            .elevators
            .iter()
            .filter(|e| e.floors.contains(&fa) && e.floors.contains(&fb))
        {
            let (Some(door_a), Some(door_b)) = (
                door(&self.floors[fa].world, &e.number),
                door(&self.floors[fb].world, &e.number),
            ) else {
                continue;
            };
            // Walk to the door: the walk from the door back, reversed.
            let Ok(mut there) = walk(fa, (e.number.as_str(), door_a), a) else {
                continue;
            };
            there.points.reverse();
            there.stops.reverse();
            let Ok(on) = walk(fb, (e.number.as_str(), door_b), b) else {
                continue;
            };
            let candidate = BuildingRoute {
                walks: vec![(fa, there), (fb, on)],
                ride: Some(e.number.clone()),
            };
            if best
                .as_ref()
                .is_none_or(|r| candidate.walked_mm() < r.walked_mm())
            {
                best = Some(candidate);
            }
        }
        best.ok_or_else(|| RouteError::Unreachable {
            from: from.to_string(),
            to: to.to_string(),
        })
    }
}

/// The point in the corridor in front of the middle of elevator door
/// `number` on a floor.
fn door(world: &World, number: &str) -> Option<Point> {
    let l = world.position(&format!("{number}L"))?.in_corridor();
    let r = world.position(&format!("{number}R"))?.in_corridor();
    Some(pt((l.x + r.x) / 2.0, (l.y + r.y) / 2.0))
}

#[cfg(test)]
mod tests;
