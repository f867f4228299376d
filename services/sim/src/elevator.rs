//! An elevator car: it travels between the floors it serves in a set time
//! per floor, stops where it is called, and opens its doors there.
//!
//! The car serves its stops in the order they were asked for; a stop asked
//! for twice is one stop. It moves only with its doors closed. At a stop
//! the doors open for [`CarSpec::dwell_ms`] and close by themselves,
//! unless they are held open (`open`) until `close` or a new stop.

use std::collections::VecDeque;

/// How a car moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CarSpec {
    /// Travel time from one floor to the next, ms.
    pub per_floor_ms: u64,
    /// Time the doors take to open or to close, ms.
    pub doors_ms: u64,
    /// Time the doors stay open at a stop before closing by themselves.
    pub dwell_ms: u64,
}

impl Default for CarSpec {
    fn default() -> Self {
        CarSpec {
            per_floor_ms: 4_000,
            doors_ms: 2_000,
            dwell_ms: 10_000,
        }
    }
}

/// The doors, with the time left in what they do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DoorState {
    /// Shut.
    Closed,
    /// Opening, `left_ms` to go.
    Opening {
        /// ms until open.
        left_ms: u64,
    },
    /// Open; they close by themselves after `left_ms` unless held.
    Open {
        /// ms until they start to close.
        left_ms: u64,
    },
    /// Closing, `left_ms` to go.
    Closing {
        /// ms until shut.
        left_ms: u64,
    },
}

/// A floor the car does not serve.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("no floor '{floor}' here: it serves {served}")]
pub struct NoFloor {
    /// The floor asked for.
    pub floor: String,
    /// The floors served, comma-separated.
    pub served: String,
}

/// One car.
#[derive(Debug, Clone, PartialEq)]
pub struct Car {
    spec: CarSpec,
    floors: Vec<String>,
    /// Where it is, as an index of `floors` (fractional while moving).
    position: f64,
    doors: DoorState,
    /// Held open by `open`.
    held: bool,
    stops: VecDeque<usize>,
    /// Out of order (a fault to inject): it takes calls and does nothing.
    broken: bool,
}

impl Car {
    /// A car serving `floors` (lowest first), standing at `at` with its
    /// doors closed.
    pub fn new(floors: Vec<String>, at: &str, spec: CarSpec) -> Result<Car, NoFloor> {
        let mut car = Car {
            spec,
            floors,
            position: 0.0,
            doors: DoorState::Closed,
            held: false,
            stops: VecDeque::new(),
            broken: false,
        };
        car.position = car.index(at)? as f64;
        Ok(car)
    }

    fn index(&self, floor: &str) -> Result<usize, NoFloor> {
        self.floors
            .iter()
            .position(|f| f == floor)
            .ok_or_else(|| NoFloor {
                floor: floor.to_string(),
                served: self.floors.join(", "),
            })
    }

    /// Asks the car to stop at `floor` (a call, a car's button); the held
    /// doors are let go.
    pub fn stop_at(&mut self, floor: &str) -> Result<(), NoFloor> {
        let i = self.index(floor)?;
        self.held = false;
        if !self.stops.contains(&i) {
            self.stops.push_back(i);
        }
        Ok(())
    }

    /// Opens the doors where the car stands and holds them open; a car
    /// between floors goes on to its stop first.
    pub fn open(&mut self) {
        if self.at_floor().is_some() && !self.moving() {
            self.held = true;
            match self.doors {
                DoorState::Closed => {
                    self.doors = DoorState::Opening {
                        left_ms: self.spec.doors_ms,
                    }
                }
                DoorState::Closing { left_ms } => {
                    self.doors = DoorState::Opening {
                        left_ms: self.spec.doors_ms.saturating_sub(left_ms),
                    }
                }
                DoorState::Opening { .. } | DoorState::Open { .. } => {}
            }
        }
    }

    /// Closes the doors (and lets a hold go).
    pub fn close(&mut self) {
        self.held = false;
        match self.doors {
            DoorState::Open { .. } => {
                self.doors = DoorState::Closing {
                    left_ms: self.spec.doors_ms,
                }
            }
            DoorState::Opening { left_ms } => {
                self.doors = DoorState::Closing {
                    left_ms: self.spec.doors_ms.saturating_sub(left_ms),
                }
            }
            DoorState::Closed | DoorState::Closing { .. } => {}
        }
    }

    /// Lets held doors go: they close after the usual dwell (the client
    /// that held them went away).
    pub fn release(&mut self) {
        if self.held {
            self.held = false;
            if let DoorState::Open { .. } = self.doors {
                self.doors = DoorState::Open {
                    left_ms: self.spec.dwell_ms,
                };
            }
        }
    }

    /// Something stands in the doorway: open doors wait a whole dwell
    /// again, closing doors open again (an elevator's door edge never
    /// shuts on a body).
    pub fn obstructed(&mut self) {
        match self.doors {
            DoorState::Open { .. } if !self.held => {
                self.doors = DoorState::Open {
                    left_ms: self.spec.dwell_ms,
                }
            }
            DoorState::Closing { left_ms } => {
                self.doors = DoorState::Opening {
                    left_ms: self.spec.doors_ms.saturating_sub(left_ms),
                }
            }
            _ => {}
        }
    }

    /// Puts the car out of order (`true`): it still takes calls, but
    /// neither moves nor opens its doors, as a car stuck on a floor whose
    /// buttons still light up.
    pub fn out_of_order(&mut self, broken: bool) {
        self.broken = broken;
    }

    /// Advances the car by `dt_ms`.
    pub fn step(&mut self, dt_ms: u64) {
        if self.broken {
            return;
        }
        let mut left = dt_ms;
        // Each pass spends time on one thing (doors or travel); a few
        // passes cover any step.
        for _ in 0..8 {
            if left == 0 {
                return;
            }
            left = self.spend(left);
        }
    }

    /// Spends up to `dt` ms on what the car does now; returns what is left.
    fn spend(&mut self, dt: u64) -> u64 {
        match self.doors {
            DoorState::Opening { left_ms } => {
                let used = dt.min(left_ms);
                self.doors = if used == left_ms {
                    DoorState::Open {
                        left_ms: self.spec.dwell_ms,
                    }
                } else {
                    DoorState::Opening {
                        left_ms: left_ms - used,
                    }
                };
                return dt - used;
            }
            DoorState::Open { left_ms } => {
                if self.held {
                    return 0;
                }
                let used = dt.min(left_ms);
                self.doors = if used == left_ms {
                    DoorState::Closing {
                        left_ms: self.spec.doors_ms,
                    }
                } else {
                    DoorState::Open {
                        left_ms: left_ms - used,
                    }
                };
                return dt - used;
            }
            DoorState::Closing { left_ms } => {
                let used = dt.min(left_ms);
                self.doors = if used == left_ms {
                    DoorState::Closed
                } else {
                    DoorState::Closing {
                        left_ms: left_ms - used,
                    }
                };
                return dt - used;
            }
            DoorState::Closed => {}
        }
        let Some(&target) = self.stops.front() else {
            return 0;
        };
        let goal = target as f64;
        let gap = goal - self.position;
        let per_ms = 1.0 / self.spec.per_floor_ms.max(1) as f64;
        let need_ms = (gap.abs() / per_ms).round() as u64;
        if dt < need_ms {
            self.position += gap.signum() * dt as f64 * per_ms;
            return 0;
        }
        // Arrived: the doors open for the dwell.
        self.position = goal;
        self.stops.pop_front();
        self.doors = DoorState::Opening {
            left_ms: self.spec.doors_ms,
        };
        dt - need_ms
    }

    /// The floors served, lowest first.
    pub fn floors(&self) -> &[String] {
        &self.floors
    }

    /// Where the car is, as an index of [`Car::floors`].
    pub fn position(&self) -> f64 {
        self.position
    }

    /// The floor it stands at, if it stands at one.
    pub fn at_floor(&self) -> Option<&str> {
        let i = self.position.round();
        ((self.position - i).abs() < 1e-9).then(|| self.floors[i as usize].as_str())
    }

    /// The floor it is at or last passed, going its way.
    pub fn floor(&self) -> &str {
        let going_up = self
            .stops
            .front()
            .is_some_and(|&s| s as f64 > self.position);
        let i = if going_up {
            self.position.floor()
        } else {
            self.position.ceil()
        };
        &self.floors[(i as usize).min(self.floors.len() - 1)]
    }

    /// Whether it travels.
    pub fn moving(&self) -> bool {
        self.doors == DoorState::Closed
            && self
                .stops
                .front()
                .is_some_and(|&s| (s as f64 - self.position).abs() > 1e-9)
    }

    /// The doors.
    pub fn doors(&self) -> DoorState {
        self.doors
    }

    /// Whether the doors are held open.
    pub fn held(&self) -> bool {
        self.held
    }

    /// The stops still to serve, in order.
    pub fn stops(&self) -> Vec<&str> {
        self.stops
            .iter()
            .map(|&i| self.floors[i].as_str())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn car() -> Car {
        let floors = ["3", "4", "5"].map(String::from).to_vec();
        Car::new(floors, "3", CarSpec::default()).unwrap()
    }

    #[test]
    fn a_call_two_floors_up_takes_two_floors_of_travel_then_opens() {
        let mut c = car();
        c.stop_at("5").unwrap();
        c.step(4_000);
        assert!(c.moving());
        assert_eq!(c.floor(), "4");
        c.step(3_999);
        assert!(c.moving(), "not there before 8 s");
        c.step(1);
        assert_eq!(c.at_floor(), Some("5"));
        assert!(matches!(c.doors(), DoorState::Opening { .. }));
        c.step(2_000);
        assert!(matches!(c.doors(), DoorState::Open { .. }));
        // The dwell, then closing, then shut.
        c.step(10_000 + 2_000);
        assert_eq!(c.doors(), DoorState::Closed);
        assert!(c.stops().is_empty());
    }

    #[test]
    fn held_doors_stay_open_until_closed_and_the_car_waits() {
        let mut c = car();
        c.open();
        c.step(60_000);
        assert!(matches!(c.doors(), DoorState::Open { .. }) && c.held());
        c.close();
        c.step(2_000);
        assert_eq!(c.doors(), DoorState::Closed);
        c.stop_at("4").unwrap();
        c.step(4_000);
        assert_eq!(c.at_floor(), Some("4"));
    }

    #[test]
    fn the_car_never_moves_with_its_doors_open_and_a_stop_is_asked_once() {
        let mut c = car();
        c.open();
        c.step(2_000);
        c.stop_at("5").unwrap();
        c.stop_at("5").unwrap();
        assert_eq!(c.stops(), ["5"]);
        // The hold went with the new stop: dwell, close, then travel.
        c.step(10_000);
        assert_eq!(c.at_floor(), Some("3"), "still open or closing");
        c.step(2_000);
        assert_eq!(c.doors(), DoorState::Closed);
        c.step(8_000);
        assert_eq!(c.at_floor(), Some("5"));
    }

    #[test]
    fn an_unknown_floor_is_named_with_those_served() {
        let mut c = car();
        let e = c.stop_at("7").unwrap_err();
        assert_eq!(e.to_string(), "no floor '7' here: it serves 3, 4, 5");
        assert!(Car::new(vec!["1".into()], "2", CarSpec::default()).is_err());
    }

    #[test]
    fn a_car_out_of_order_takes_calls_and_stays_shut_until_mended() {
        let mut c = car();
        c.out_of_order(true);
        c.stop_at("5").unwrap();
        c.step(60_000);
        assert_eq!((c.at_floor(), c.doors()), (Some("3"), DoorState::Closed));
        assert_eq!(c.stops(), ["5"]);
        c.out_of_order(false);
        c.step(8_000);
        assert_eq!(c.at_floor(), Some("5"));
    }

    #[test]
    fn a_body_in_the_doorway_keeps_the_doors_open_and_reopens_closing_ones() {
        let mut c = car();
        c.stop_at("3").unwrap();
        c.step(2_000);
        assert!(matches!(c.doors(), DoorState::Open { .. }));
        for _ in 0..5 {
            c.step(9_000);
            c.obstructed();
        }
        assert!(matches!(c.doors(), DoorState::Open { .. }), "45 s later");
        c.step(10_500);
        assert!(matches!(c.doors(), DoorState::Closing { .. }));
        c.obstructed();
        assert!(matches!(c.doors(), DoorState::Opening { .. }));
    }
}
