//! Elevator cars in the world (§5.4.6): each serves the floors of a
//! building laid out on one plane ([`rome_maps::plane`]), opens its door on
//! the floor it stands at, and carries the robots in its cabin from floor
//! to floor.
//!
//! A car's door on floor F is the scene's elevator `F:NUMBER`. It lets
//! bodies, sonar and cameras through only while fully open; a robot in the
//! doorway keeps it open. When the car comes to another floor, every robot
//! in the cabin is moved to the same place in that floor's cabin: the
//! doors are shut while it travels, so no sensor can tell.

use super::{Sim, SimError};
use crate::elevator::{Car, CarSpec, DoorState};
use crate::spec::{SimConfig, ROBOT_RADIUS_MM};
use rome_maps::building::Building;
use rome_maps::geometry::Heading;
use rome_maps::plane::Plane;

/// A car and its doors.
#[derive(Debug, Clone)]
pub(super) struct WorldCar {
    /// The shaft's number (`acs.elev`).
    number: String,
    car: Car,
    /// The scene's elevator for each floor the car serves, in its order.
    doors: Vec<usize>,
    /// The floor (index of `doors`) whose cabin holds the riders.
    cabin: usize,
}

/// How close to a door's line a robot's edge keeps the doors open, mm.
const DOOR_EDGE_MM: f64 = 50.0;

impl Sim {
    /// A world of a whole building: its floors side by side on one plane
    /// (the first where its map puts it), a car in every elevator shaft,
    /// standing at the shaft's first floor.
    pub fn for_building(
        building: &Building,
        config: SimConfig,
        spec: CarSpec,
    ) -> Result<(Sim, Plane), SimError> {
        let plane = Plane::new(building);
        let mut sim = Sim::new(&plane.map, config);
        for e in &building.elevators {
            let floors: Vec<String> = e
                .floors
                .iter()
                .map(|&f| building.floors[f].name.clone())
                .collect();
            sim.add_car(&e.number, &floors, spec)?;
        }
        Ok((sim, plane))
    }

    /// Puts a car in shaft `number`, serving `floors` (lowest first) and
    /// standing at the first with its doors shut. Each floor must have a
    /// door `FLOOR:NUMBER` in the scene.
    pub fn add_car(
        &mut self,
        number: &str,
        floors: &[String],
        spec: CarSpec,
    ) -> Result<(), SimError> {
        let doors = floors
            .iter()
            .map(|f| {
                let name = format!("{f}:{number}");
                self.scene
                    .elevators
                    .iter()
                    .position(|e| e.number == name)
                    .ok_or(SimError::NoElevator(name))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let first = floors.first().cloned().unwrap_or_default();
        let car = Car::new(floors.to_vec(), &first, spec)
            .map_err(|e| SimError::BadSetting(e.to_string()))?;
        self.cars.retain(|c| c.number != number);
        self.cars.push(WorldCar {
            number: number.to_string(),
            car,
            doors,
            cabin: 0,
        });
        Ok(())
    }

    /// The cars, by shaft number.
    pub fn cars(&self) -> impl Iterator<Item = (&str, &Car)> {
        self.cars.iter().map(|c| (c.number.as_str(), &c.car))
    }

    /// The car of shaft `number`.
    pub fn car(&self, number: &str) -> Option<&Car> {
        self.cars
            .iter()
            .find(|c| c.number == number)
            .map(|c| &c.car)
    }

    /// The car of shaft `number`, to command it.
    pub fn car_mut(&mut self, number: &str) -> Option<&mut Car> {
        self.cars
            .iter_mut()
            .find(|c| c.number == number)
            .map(|c| &mut c.car)
    }

    /// The car whose door is the scene's elevator `e`, and that floor.
    pub(super) fn car_of_door(&mut self, e: usize) -> Option<(&mut Car, String)> {
        self.cars.iter_mut().find_map(|c| {
            let k = c.doors.iter().position(|&d| d == e)?;
            let floor = c.car.floors()[k].clone();
            Some((&mut c.car, floor))
        })
    }

    /// Steps every car by `dt_ms`: doors kept open by a robot in the
    /// doorway, travel, doors that open and shut, riders carried.
    pub(super) fn step_cars(&mut self, dt_ms: u64) {
        for k in 0..self.cars.len() {
            let c = &self.cars[k];
            let here = c.car.position().round() as usize;
            if let Some(&door) = c.doors.get(here) {
                let w = &self.scene.walls[self.scene.elevators[door].door];
                let in_doorway = self.robots.iter().any(|r| {
                    let d = r.pose.at - w.a;
                    let u = d.dot(&w.dir);
                    (-ROBOT_RADIUS_MM..=w.len + ROBOT_RADIUS_MM).contains(&u)
                        && d.dot(&w.normal).abs() < ROBOT_RADIUS_MM + DOOR_EDGE_MM
                });
                if in_doorway {
                    self.cars[k].car.obstructed();
                }
            }
            let c = &mut self.cars[k];
            c.car.step(dt_ms);
            let open_at = (c.car.doors() != DoorState::Closed)
                .then(|| c.car.at_floor().map(str::to_string))
                .flatten()
                .filter(|_| matches!(c.car.doors(), DoorState::Open { .. }));
            for (i, &door) in c.doors.iter().enumerate() {
                self.open[door] = open_at.as_deref() == Some(c.car.floors()[i].as_str());
            }
            let now = (c.car.position().round() as usize).min(c.doors.len() - 1);
            if now != c.cabin {
                let (from, to) = (c.doors[c.cabin], c.doors[now]);
                c.cabin = now;
                for r in &mut self.robots {
                    if self.scene.in_cabin(from, r.pose.at) {
                        let (at, heading) =
                            self.scene.carry(from, to, r.pose.at, r.pose.heading.deg());
                        r.pose.at = at;
                        r.pose.heading = Heading::from_deg(heading).normalized();
                    }
                }
                self.cells_fresh = false;
            }
        }
    }
}
