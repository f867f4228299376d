//! The world side of a run: the simulated world, its hardware servers,
//! ground truth, clock and data server on one session; for a building,
//! its floors side by side and an elevator server for every car.

use crate::RunConfig;
use rome_client::net::NetOptions;
use rome_hardware::robot::Rates;
use rome_nav::NavError;
use rome_schema::Root;
use rome_sim::elevator::CarSpec;
use rome_sim::{Pose, Sim, SimConfig};
use rome_sim_hardware::robot::{spawn_sim_robot, spawn_truth};
use rome_sim_hardware::world::SimWorld;
use std::time::Duration;

/// The world side of a run: the simulated robots put down at their plans'
/// starts facing their routes, their hardware servers, the ground-truth
/// server and a data server, on one Zenoh session. The world does not step
/// until [`SimWorld::start`] is called on [`Harness::world`].
pub struct Harness {
    /// The session the servers use.
    pub session: zenoh::Session,
    /// The simulated world.
    pub world: SimWorld,
    /// Each robot's index in it, in the order of the plans.
    pub index: Vec<usize>,
    servers: Vec<rome_hardware::robot::Running>,
    /// Each car's elevator server and button subscriber, by shaft
    /// (`None` while stopped, [`Harness::stop_elevator`]).
    elevators: Vec<(String, Option<ElevatorServer>)>,
    elevator_state: Option<Duration>,
    data: Option<rome_data::Running>,
}

impl Harness {
    /// Starts writing the world's ground truth at every instant to `path`
    /// (`rome_sim_hardware::trace`), from the instant it stands at.
    pub fn trace(&self, path: Option<&std::path::Path>) -> Result<(), NavError> {
        let Some(path) = path else { return Ok(()) };
        self.world.trace_to(path).map_err(|e| {
            NavError::Config(format!("cannot write the trace {}: {e}", path.display()))
        })
    }

    /// Builds the world with robots put down at `starts` (robot name, true
    /// pose) and starts the servers on a session opened with `net`;
    /// returns once every server is alive.
    pub async fn start(
        cfg: &RunConfig,
        starts: &[(String, Pose)],
        net: NetOptions,
    ) -> Result<Harness, NavError> {
        if let Some(speed) = cfg.speed.filter(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(NavError::Config(format!(
                "the simulation speed must be a positive number, got {speed}"
            )));
        }
        let config = SimConfig {
            seed: cfg.seed,
            noise: cfg.noise.clone(),
            ..SimConfig::default()
        };
        let (mut sim, plane) = match &cfg.building {
            Some(b) => {
                let (sim, plane) = Sim::for_building(b, config, CarSpec::default())
                    .map_err(|e| NavError::Config(e.to_string()))?;
                (sim, Some(plane))
            }
            None => (Sim::new(&cfg.map, config), None),
        };
        let cars: Vec<String> = sim.cars().map(|(n, _)| n.to_string()).collect();
        let mut index = Vec::new();
        for (robot, start) in starts {
            let i = sim
                .add_robot(robot, *start)
                .map_err(|e| NavError::Config(e.to_string()))?;
            index.push(i);
        }
        let people_map = plane.as_ref().map_or(&cfg.map, |p| &p.map);
        sim.add_people(people_map, cfg.people, cfg.seed)
            .map_err(|e| NavError::Config(e.to_string()))?;
        for name in &cfg.covered {
            let i = sim
                .index(name)
                .map_err(|e| NavError::Config(e.to_string()))?;
            sim.cover_camera(i, rome_sim::Camera::Up);
        }
        let world = match plane {
            Some(plane) => SimWorld::on_plane(sim, plane),
            None => SimWorld::new(sim),
        };
        // The servers' clocks follow the simulated one: in lock-step their
        // periods are simulated time already.
        let scale = |ms: f64| cfg.period(ms);
        let rates = Rates {
            state: Some(scale(100.0)),
            scan: Some(scale(25.0)),
            camera: scale(500.0),
        };
        let session = net
            .open()
            .await
            .map_err(|e| NavError::Config(e.to_string()))?;
        let root = Root::default();
        let data = rome_data::spawn(
            session.clone(),
            rome_data::ServerConfig {
                root: root.clone(),
                ..Default::default()
            },
        );
        let mut servers = vec![
            spawn_truth(&session, &root, &world, Some(scale(500.0))),
            rome_sim_hardware::robot::spawn_clock(
                &session,
                &root,
                &world,
                scale(rome_schema::sim::CLOCK_EVERY_MS as f64),
                cfg.lockstep,
            ),
        ];
        for (robot, _) in starts {
            servers.extend(
                spawn_sim_robot(&session, &root, &world, robot, rates)
                    .map_err(|e| NavError::Config(e.to_string()))?,
            );
        }
        let mut elevators = Vec::new();
        for car in &cars {
            let running = spawn_car(&session, &root, &world, car, rates.state).await?;
            elevators.push((car.clone(), Some(running)));
        }
        for car in &cars {
            rome_client::alive::await_server(
                &session,
                &root,
                "building/elevator",
                car,
                Duration::from_secs(10),
            )
            .await?;
        }
        for (robot, _) in starts {
            for device in ["base", "proximity", "camera/up", "camera/side"] {
                rome_client::alive::await_server(
                    &session,
                    &root,
                    "robot",
                    &format!("{robot}/{device}"),
                    Duration::from_secs(10),
                )
                .await?;
            }
        }
        rome_client::alive::await_server(&session, &root, "sim", "truth", Duration::from_secs(10))
            .await?;
        Ok(Harness {
            session,
            world,
            index,
            servers,
            elevators,
            elevator_state: rates.state,
            data: Some(data),
        })
    }

    /// Where robot `k` (in the order of the plans) truly is.
    pub fn truth(&self, k: usize) -> Pose {
        self.world.lock().robot(self.index[k]).pose
    }

    /// Stops elevator `car`'s server alone (a fault to inject): the car
    /// goes on as it was told, and nobody can tell it more.
    pub async fn stop_elevator(&mut self, car: &str) {
        for (name, running) in &mut self.elevators {
            if name == car {
                if let Some((server, _buttons)) = running.take() {
                    let _ = server.stop().await;
                }
            }
        }
    }

    /// Starts elevator `car`'s server again after [`Harness::stop_elevator`].
    pub async fn start_elevator(&mut self, car: &str) -> Result<(), NavError> {
        for (name, running) in &mut self.elevators {
            if name == car && running.is_none() {
                let root = Root::default();
                *running = Some(
                    spawn_car(&self.session, &root, &self.world, car, self.elevator_state).await?,
                );
            }
        }
        Ok(())
    }

    /// Stops the data server alone (a fault to inject); the hardware
    /// servers and the world go on.
    pub async fn stop_data_server(&mut self) {
        if let Some(data) = self.data.take() {
            let _ = data.stop().await;
        }
    }

    /// Stops the servers and closes the session.
    pub async fn stop(mut self) {
        for s in std::mem::take(&mut self.servers) {
            let _ = s.stop().await;
        }
        for (_, running) in std::mem::take(&mut self.elevators) {
            if let Some((server, _)) = running {
                let _ = server.stop().await;
            }
        }
        self.stop_data_server().await;
        let _ = self.session.close().await;
    }
}

/// An elevator server and the subscriber of its buttons.
type ElevatorServer = (rome_hardware::robot::Running, zenoh::pubsub::Subscriber<()>);

/// Serves the world's car `car`.
async fn spawn_car(
    session: &zenoh::Session,
    root: &Root,
    world: &SimWorld,
    car: &str,
    state: Option<Duration>,
) -> Result<ElevatorServer, NavError> {
    let config = rome_hardware::ServerConfig::elevator(root, car)
        .map_err(|e| NavError::Config(e.to_string()))?;
    let device = rome_sim_hardware::elevator::WorldCar::new(world.clone(), car)
        .map_err(|e| NavError::Config(e.to_string()))?;
    rome_hardware::elevator::spawn_elevator(session, config, device, state)
        .await
        .map_err(|e| NavError::Config(e.to_string()))
}
