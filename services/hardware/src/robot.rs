//! Starting hardware servers as tasks: one task per device, so one
//! failing does not stop the others (§4.7: servers stay independent).

use crate::base::Base;
use crate::camera::{self, Camera};
use crate::proximity::Proximity;
use crate::server::{self, ServerConfig, ServerError, Service};
use crate::sim::SimWorld;
use rome_schema::robot::Device;
use rome_schema::{Name, Root};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;
use zenoh::Session;

/// Rates of a robot's servers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rates {
    /// How often the base publishes its state (`None`: never).
    pub state: Option<Duration>,
    /// How often the proximity server looks for a new scan to publish.
    pub scan: Option<Duration>,
    /// How often each camera grabs.
    pub camera: Duration,
}

impl Default for Rates {
    fn default() -> Self {
        Rates {
            state: Some(Duration::from_millis(100)),
            scan: Some(Duration::from_millis(50)),
            camera: camera::DEFAULT_PERIOD,
        }
    }
}

/// A hardware server running in a task of this process.
pub struct Running {
    label: String,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<Result<(), ServerError>>,
}

impl Running {
    /// `robot r1 base` …
    pub fn label(&self) -> &str {
        &self.label
    }

    /// Whether the task has ended (stopped, failed or aborted).
    pub fn is_finished(&self) -> bool {
        self.task.is_finished()
    }

    /// Kills the server at once, as a crash would.
    pub fn abort(&self) {
        self.task.abort();
    }

    /// Stops the server and waits for it; `Ok` if it had already ended.
    pub async fn stop(mut self) -> Result<(), ServerError> {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        match self.task.await {
            Ok(result) => result,
            Err(_) => Ok(()),
        }
    }
}

/// Runs `service` as a hardware server in a task.
pub fn spawn<S: Service>(session: &Session, config: ServerConfig, service: S) -> Running {
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let label = config.label();
    // A participant of the run's clock when started in one (lock-step).
    let task = rome_clock::spawn(
        &label,
        server::run(session.clone(), config, service, async move {
            let _ = stopped.await;
        }),
    );
    Running {
        label,
        stop: Some(stop),
        task,
    }
}

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
    Running {
        label: "sim truth".into(),
        stop: Some(stop),
        task,
    }
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
                    let clock = rome_schema::sim::Clock {
                        time_ms: world.lock().time_ms(),
                        lockstep,
                    };
                    let _ = publish_clock(&session, &key, clock).await;
                }
            }
        }
    });
    Running {
        label: "sim clock".into(),
        stop: Some(stop),
        task,
    }
}

/// The processes following a lock-step clock over the network (clients
/// started with `--sim-time`): each is a party of `clock`, sent every
/// instant and waited for until it acknowledges it.
#[derive(Clone)]
pub struct Parties {
    inner: Arc<std::sync::Mutex<PartyMap>>,
    _subscribers: Arc<(zenoh::pubsub::Subscriber<()>, zenoh::pubsub::Subscriber<()>)>,
}

impl Parties {
    /// Follows the parties' liveliness tokens and acknowledgements.
    pub async fn follow(
        session: &Session,
        root: &Root,
        clock: &rome_clock::LockStep,
    ) -> Result<Parties, ServerError> {
        let inner: Arc<std::sync::Mutex<PartyMap>> = Arc::default();
        let members = {
            let (inner, clock) = (inner.clone(), clock.clone());
            session
                .liveliness()
                .declare_subscriber(root.sim_clock_parties())
                .history(true)
                .callback(move |s| {
                    let key = s.key_expr().as_str();
                    let id = key.rsplit('/').next().unwrap_or(key).to_string();
                    let mut all = crate::locked(&inner);
                    match s.kind() {
                        zenoh::sample::SampleKind::Put => {
                            tracing::info!(party = %id, "a process follows the lock-step clock");
                            let party = clock.external(&format!("process {id}"));
                            all.insert(id, (party, u64::MAX));
                        }
                        zenoh::sample::SampleKind::Delete => {
                            tracing::info!(party = %id, "a process no longer follows the lock-step clock");
                            all.remove(&id);
                        }
                    }
                })
                .await
                .map_err(|e| server::declare_err("the clock parties' liveliness subscriber", e))?
        };
        let acks = {
            let inner = inner.clone();
            session
                .declare_subscriber(root.sim_clock_acks())
                .callback(move |s| {
                    let key = s.key_expr().as_str();
                    let id = key.rsplit('/').next().unwrap_or(key);
                    let ack: rome_schema::sim::ClockAck =
                        match rome_schema::decode(&s.payload().to_bytes(), "clock ack") {
                            Ok(a) => a,
                            Err(e) => {
                                tracing::warn!(%key, error = %e, "clock acknowledgement skipped");
                                return;
                            }
                        };
                    if let Some((party, expected)) = crate::locked(&inner).get(id) {
                        if ack.time_ms == *expected {
                            party.done();
                        }
                    }
                })
                .await
                .map_err(|e| server::declare_err("the clock acknowledgement subscriber", e))?
        };
        Ok(Parties {
            inner,
            _subscribers: Arc::new((members, acks)),
        })
    }

    /// Every party is sent instant `time_ms`: the clock waits for each.
    pub fn expect(&self, time_ms: u64) {
        let mut all = crate::locked(&self.inner);
        for (party, expected) in all.values_mut() {
            *expected = time_ms;
            party.expect();
        }
    }

    /// How many processes follow the clock.
    pub fn len(&self) -> usize {
        crate::locked(&self.inner).len()
    }

    /// Whether none does.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

type PartyMap = HashMap<String, (rome_clock::External, u64)>;

/// Publishes `clock` on `key` (`<root>/sim/clock`). A lock-step clock is
/// never dropped on the way (its followers need every instant); a paced
/// one may be, as any stream.
pub async fn publish_clock(
    session: &Session,
    key: &str,
    clock: rome_schema::sim::Clock,
) -> zenoh::Result<()> {
    session
        .put(key, rome_schema::encode(&clock))
        .encoding(zenoh::bytes::Encoding::APPLICATION_JSON)
        .congestion_control(if clock.lockstep {
            zenoh::qos::CongestionControl::Block
        } else {
            zenoh::qos::CongestionControl::Drop
        })
        .await
}

/// Publishes each instant a lock-step world steps to (from `steps`) on
/// `<root>/sim/clock`, none dropped: processes following the clock need
/// every one.
pub fn spawn_lockstep_clock(
    session: &Session,
    root: &Root,
    mut steps: tokio::sync::mpsc::UnboundedReceiver<u64>,
) -> Running {
    let (stop, mut stopped) = tokio::sync::oneshot::channel::<()>();
    let (session, key) = (session.clone(), root.sim_clock());
    let task = tokio::spawn(async move {
        loop {
            tokio::select! {
                biased;
                _ = &mut stopped => return Ok(()),
                step = steps.recv() => {
                    let Some(time_ms) = step else { return Ok(()) };
                    let clock = rome_schema::sim::Clock { time_ms, lockstep: true };
                    let _ = publish_clock(&session, &key, clock).await;
                }
            }
        }
    });
    Running {
        label: "sim clock".into(),
        stop: Some(stop),
        task,
    }
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
        Base::new(robot, world.base(robot).map_err(sim_err)?, rates.state),
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
