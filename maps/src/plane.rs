//! A building laid out on one plane, as the simulator holds it: every
//! floor's map moved east of the floor before, so that one scene holds all
//! floors and no sensor on one floor can reach another.
//!
//! Names on the plane carry their floor: door `350` of floor `3` is
//! `3:350`, its jambs `3:350L` and `3:350R`, as a building names positions
//! ([`crate::building`]); rings become `3:ring`. Door plates keep their
//! labels: they are what a camera reads. The first floor stays where its
//! map puts it, so a one-floor building is its map to the millimetre.

use crate::building::Building;
use crate::geometry::{Point, Vector};
use crate::model::Map;

/// Space between two floors on the plane, mm: far beyond any sensor's
/// reach (sonar 10 m, cameras 15 m).
pub const FLOOR_GAP_MM: f64 = 50_000.0;

/// A building on one plane.
#[derive(Debug, Clone)]
pub struct Plane {
    /// Every floor's rings and links, renamed and moved.
    pub map: Map,
    /// Each floor's name, how far it is moved, and its extent on the
    /// plane (lowest and highest corner), in the building's order.
    pub floors: Vec<PlaneFloor>,
}

/// Where one floor lies on the plane.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneFloor {
    /// Its name (`3`).
    pub name: String,
    /// Added to the floor map's coordinates to place it on the plane.
    pub offset: Vector,
    /// Its lowest corner on the plane.
    pub lo: Point,
    /// Its highest corner on the plane.
    pub hi: Point,
}

impl Plane {
    /// Lays `building` out.
    pub fn new(building: &Building) -> Plane {
        let mut map = Map {
            name: building.name.clone(),
            tolerance_mm: building.floors.first().map_or(50.0, |f| f.map.tolerance_mm),
            lateral_mm: building
                .floors
                .first()
                .map_or(1_830.0, |f| f.map.lateral_mm),
            rings: Vec::new(),
            links: Vec::new(),
        };
        let mut floors = Vec::new();
        let mut east = f64::NEG_INFINITY;
        for f in &building.floors {
            let (lo, hi) = f.world.bounds();
            let offset = if floors.is_empty() {
                Vector::zeros()
            } else {
                Vector::new(east + FLOOR_GAP_MM - lo.x, 0.0)
            };
            east = hi.x + offset.x;
            let tag = |s: &str| format!("{}:{s}", f.name);
            for ring in &f.map.rings {
                let mut r = ring.clone();
                r.name = tag(&ring.name);
                r.at_mm = ring.at_mm + offset;
                for e in &mut r.edges {
                    // Each edge keeps its floor's default light distance.
                    e.lateral_mm = Some(e.lateral_mm.unwrap_or(f.map.lateral_mm));
                    e.number = e.number.as_deref().map(tag);
                    if let Some(p) = e.tags.get_mut("passage") {
                        *p = tag(p);
                    }
                }
                map.rings.push(r);
            }
            for link in &f.map.links {
                let mut l = link.clone();
                l.a.0 = tag(&link.a.0);
                l.b.0 = tag(&link.b.0);
                map.links.push(l);
            }
            floors.push(PlaneFloor {
                name: f.name.clone(),
                offset,
                lo: lo + offset,
                hi: hi + offset,
            });
        }
        Plane { map, floors }
    }

    /// The floor a point of the plane is on: the one whose extent, widened
    /// by half the gap, holds it.
    pub fn floor_of(&self, p: Point) -> Option<usize> {
        let margin = FLOOR_GAP_MM / 2.0;
        self.floors.iter().position(|f| {
            (f.lo.x - margin..=f.hi.x + margin).contains(&p.x)
                && (f.lo.y - margin..=f.hi.y + margin).contains(&p.y)
        })
    }

    /// A point of the plane as its floor's name and the floor map's
    /// coordinates.
    pub fn local(&self, p: Point) -> Option<(&str, Point)> {
        let f = &self.floors[self.floor_of(p)?];
        Some((&f.name, p - f.offset))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::distance;
    use crate::{load_building_named, World};

    #[test]
    fn the_tower_lies_floor_beside_floor_with_floor_named_positions() {
        let tower = load_building_named("tower").expect("the tower loads");
        let plane = Plane::new(&tower);
        let world = World::from_map(&plane.map);
        assert_eq!(plane.floors.len(), 3);
        // The first floor is EB3 where EB3 is.
        let eb3 = &tower.floors[0].world;
        let p = |w: &World, name: &str| w.position(name).map(|p| p.in_corridor());
        assert_eq!(p(&world, "3:350R"), p(eb3, "350R"));
        // Floor 5's 576L is floor 5's own, moved by its offset, and on
        // floor 5 again when taken back.
        let five = &tower.floors[2].world;
        let on_plane = p(&world, "5:576L").expect("5:576L on the plane");
        let local = p(five, "576L").expect("576L on floor 5");
        assert!(distance(on_plane, local + plane.floors[2].offset) < 1e-6);
        assert_eq!(plane.local(on_plane), Some(("5", local)));
        // Each elevator has a door on every floor, and the floors are far
        // apart.
        let doors = world.positions.keys().filter(|k| k.ends_with("acs.elevL"));
        assert_eq!(doors.count(), 3);
        for pair in plane.floors.windows(2) {
            assert!(pair[1].lo.x - pair[0].hi.x >= FLOOR_GAP_MM - 1e-6);
        }
        assert_eq!(plane.floor_of(pt_far()), None);
    }

    fn pt_far() -> Point {
        Point::new(-1.0e9, 0.0)
    }
}
