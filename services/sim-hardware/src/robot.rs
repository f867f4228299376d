//! A simulated robot's hardware servers, and the world's own: its ground
//! truth and its clock, each in a task of this process.

use crate::world::SimWorld;
use rome_hardware::base::Base;
use rome_hardware::camera::Camera;
use rome_hardware::proximity::Proximity;
use rome_hardware::robot::{spawn, Rates, Running};
use rome_hardware::{ServerConfig, ServerError};
use rome_schema::robot::Device;
use rome_schema::{Name, Root};
use std::time::Duration;
use zenoh::Session;

/// Serves the ground truth of every robot in `world` on
/// `<root>/sim/<robot>/truth`, published every `period` (see [`crate::truth`]).
pub fn spawn_truth(
    session: &Session,
    root: &Root,
    world: &SimWorld,
    period: Option<Duration>,
) -> Running {
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let task = rome_clock::spawn(
        "sim truth",
        crate::truth::run(
            session.clone(),
            root.clone(),
            world.clone(),
            period,
            async move {
                let _ = stopped.await;
            },
        ),
    );
    Running::new("sim truth", stop, task)
}

/// Publishes `world`'s simulated time on `<root>/sim/clock` every
/// `period` ([`rome_schema::sim::CLOCK_EVERY_MS`] of simulated time: in a
/// lock-step run that is the period; otherwise pass it scaled to the
/// wall-clock pace).
pub fn spawn_clock(
    session: &Session,
    root: &Root,
    world: &SimWorld,
    period: Duration,
    lockstep: bool,
) -> Running {
    let (stop, mut stopped) = tokio::sync::oneshot::channel::<()>();
    let (session, key, world) = (session.clone(), root.sim_clock(), world.clone());
    let task = rome_clock::spawn("sim clock", async move {
        let mut tick = rome_clock::interval(period);
        loop {
            tokio::select! {
                biased;
                _ = rome_clock::idle(&mut stopped) => return Ok(()),
                _ = tick.tick() => {
                    let clock = rome_schema::sim::Clock::instant(world.lock().time_ms(), lockstep);
                    let _ = crate::lockstep::publish_clock(&session, &key, &clock).await;
                }
            }
        }
    });
    Running::new("sim clock", stop, task)
}

/// Starts the base, proximity and both camera servers of simulated robot
/// `robot`, each in its own task.
pub fn spawn_sim_robot(
    session: &Session,
    root: &Root,
    world: &SimWorld,
    robot: &str,
    rates: Rates,
) -> Result<Vec<Running>, ServerError> {
    let sim_err = |e: rome_sim::SimError| ServerError::Config(e.to_string());
    let mut out = Vec::new();
    out.push(spawn(
        session,
        ServerConfig::new(root, robot, Device::Base)?,
        Base::with_frame(
            robot,
            world.base(robot).map_err(sim_err)?,
            rates.state,
            world.frame(robot),
        ),
    ));
    out.push(spawn(
        session,
        ServerConfig::new(root, robot, Device::Proximity)?,
        Proximity::new(robot, world.proximity(robot).map_err(sim_err)?, rates.scan),
    ));
    for which in rome_sim::Camera::ALL {
        let name = Name::new(which.name()).map_err(|e| ServerError::Config(e.to_string()))?;
        out.push(spawn(
            session,
            ServerConfig::new(root, robot, Device::Camera(name))?,
            Camera::new(
                robot,
                which.name(),
                world.camera(robot, which).map_err(sim_err)?,
                rates.camera,
            ),
        ));
    }
    Ok(out)
}
