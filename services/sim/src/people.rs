//! People walking the corridors, as the thesis' robot met them (§6.2):
//! placed on the map's corridors, each to and fro between two turning
//! spaces.

use crate::scene::Sense;
use crate::spec::ROBOT_RADIUS_MM;
use crate::{Sim, SimError};
use rome_maps::geometry::Point;
use rome_maps::{Map, Network, World};

impl Sim {
    /// Puts `n` people in the corridors of `map`, chosen with `seed`: each
    /// walks to and fro at 1.0–1.4 m/s between two turning spaces in sight of
    /// each other at least 8 m apart, to the right of the corridor's centre
    /// line (where the robots drive) as far as the corridor allows (at most
    /// 1.4 m), starting at least 3 m from every robot.
    pub fn add_people(&mut self, map: &Map, n: usize, seed: u64) -> Result<(), SimError> {
        if n == 0 {
            return Ok(());
        }
        let world = World::from_map(map);
        let network = Network::new(map, &world);
        let points = network.waypoints();
        let mut legs = Vec::new();
        for (i, &a) in points.iter().enumerate() {
            for &b in &points[i + 1..] {
                if rome_maps::geometry::distance(a, b) >= 8_000.0 && network.clear(a, b) {
                    legs.push((a, b));
                }
            }
        }
        if legs.is_empty() {
            return Err(SimError::BadSetting(format!(
                "the map '{}' has no corridor of 8 m or more for people to walk",
                map.name
            )));
        }
        let mut rng = crate::rng::Rng::new(seed ^ 0x7065_6f70_6c65);
        let starts: Vec<Point> = (0..self.robots().len())
            .map(|i| self.robot(i).pose.at)
            .collect();
        let mut placed = 0;
        let mut tries = 0;
        while placed < n && tries < 1_000 * n {
            tries += 1;
            let k = (rng.next_u64() % legs.len() as u64) as usize;
            let (mut a, mut b) = legs[k];
            if rng.chance(0.5) {
                std::mem::swap(&mut a, &mut b);
            }
            let along = (b - a).normalize();
            // Keep right (of the direction walked), as far as the corridor
            // lets a person of a robot's girth walk clear of its wall.
            let side = rome_maps::geometry::Vector::new(along.y, -along.x);
            // The simulator's own ray: what a body would touch (walls, doors,
            // glass; not openings).
            let free = [0.25, 0.5, 0.75]
                .iter()
                .map(|f| {
                    self.scene()
                        .ray_dir(a + (b - a) * *f, side, 5_000.0, Sense::Touch, &[], None)
                        .map_or(f64::INFINITY, |(d, _, _)| d)
                })
                .fold(f64::INFINITY, f64::min);
            let offset = (free - ROBOT_RADIUS_MM - 50.0).clamp(0.0, 1_400.0);
            let right = side * offset;
            let (from, to) = (a + right, b + right);
            let start = from + (to - from) * rng.uniform();
            if starts
                .iter()
                .any(|s| rome_maps::geometry::distance(*s, start) < 3_000.0)
            {
                continue;
            }
            let i = self.add_walker(from, to, 1_000.0 + 400.0 * rng.uniform());
            let w = &mut self.walkers_mut()[i];
            w.at = start;
            placed += 1;
        }
        Ok(())
    }
}
