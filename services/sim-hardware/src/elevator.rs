//! Simulated elevator cars as the elevator server's devices: each a
//! [`rome_sim::elevator::Car`] stepped in real time (or a multiple of it).

use rome_hardware::device::DeviceError;
use rome_hardware::elevator::{CarOp, ElevatorDevice};
use rome_schema::elevator::{Doors, ElevatorState};
use rome_sim::elevator::{Car, DoorState};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// A car shared by its stepping task and its server.
#[derive(Clone)]
pub struct SimCar {
    car: Arc<Mutex<Car>>,
}

/// How often a car is stepped, real time.
const STEP: Duration = Duration::from_millis(20);

impl SimCar {
    /// Shares `car`; step it with [`SimCar::run`].
    pub fn new(car: Car) -> Self {
        SimCar {
            car: Arc::new(Mutex::new(car)),
        }
    }

    /// Steps the car at `speed` × real time until the task is aborted.
    pub fn run(&self, speed: f64) -> tokio::task::JoinHandle<()> {
        let car = self.car.clone();
        tokio::spawn(async move {
            let mut tick = tokio::time::interval(STEP);
            tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            let mut last = tokio::time::Instant::now();
            let mut owed = 0.0_f64;
            loop {
                tick.tick().await;
                let now = tokio::time::Instant::now();
                owed += (now - last).as_secs_f64() * 1_000.0 * speed;
                last = now;
                let ms = owed.floor();
                owed -= ms;
                rome_hardware::locked(&car).step(ms as u64);
            }
        })
    }

    /// The car's state as the server reports it.
    pub fn state(&self) -> ElevatorState {
        state_of(&rome_hardware::locked(&self.car))
    }
}

/// The message form of a car's state (name and session left empty).
pub fn state_of(car: &Car) -> ElevatorState {
    ElevatorState {
        elevator: String::new(),
        floors: car.floors().to_vec(),
        floor: car.floor().to_string(),
        position: car.position(),
        moving: car.moving(),
        doors: match car.doors() {
            DoorState::Closed => Doors::Closed,
            DoorState::Opening { .. } => Doors::Opening,
            DoorState::Open { .. } => Doors::Open,
            DoorState::Closing { .. } => Doors::Closing,
        },
        held: car.held(),
        stops: car.stops().into_iter().map(String::from).collect(),
        lock: None,
    }
}

/// Does `op` to `car`; the state it leaves.
fn apply(car: &mut Car, op: CarOp) -> Result<ElevatorState, DeviceError> {
    match op {
        CarOp::Status => {}
        CarOp::StopAt(floor) => car
            .stop_at(&floor)
            .map_err(|e| DeviceError::OutOfRange(e.to_string()))?,
        CarOp::Open => car.open(),
        CarOp::Close => car.close(),
        CarOp::Release => car.release(),
    }
    Ok(state_of(car))
}

impl ElevatorDevice for SimCar {
    async fn command(&self, op: CarOp) -> Result<ElevatorState, DeviceError> {
        apply(&mut rome_hardware::locked(&self.car), op)
    }
}

/// A car of a building's world ([`rome_sim::Sim::for_building`]) as the
/// elevator server's device: commands go to the world's car, which the
/// world steps with its robots (in lock-step too) and whose door on each
/// floor robots meet.
#[derive(Clone)]
pub struct WorldCar {
    world: crate::world::SimWorld,
    number: String,
}

impl WorldCar {
    /// The world's car of shaft `number`.
    pub fn new(world: crate::world::SimWorld, number: &str) -> Result<Self, rome_sim::SimError> {
        if world.lock().car(number).is_none() {
            return Err(rome_sim::SimError::NoElevator(number.to_string()));
        }
        Ok(WorldCar {
            world,
            number: number.to_string(),
        })
    }
}

impl ElevatorDevice for WorldCar {
    async fn command(&self, op: CarOp) -> Result<ElevatorState, DeviceError> {
        let mut sim = self.world.lock();
        let car = sim
            .car_mut(&self.number)
            .ok_or_else(|| DeviceError::Disconnected {
                device: format!("car '{}'", self.number),
                why: "the world has no such car".into(),
            })?;
        apply(car, op)
    }
}
