//! The simulated devices: one [`rome_sim::Sim`] world, stepped on its own
//! thread at a chosen pace, and each robot's base, proximity subsystem and
//! cameras as [`BaseDevice`], [`ProximityDevice`] and [`CameraDevice`].

use crate::trace::Trace;
use rome_hardware::device::{
    BaseDevice, BaseOp, BaseStatus, CameraDevice, DeviceError, Frame, Peek, Pixels,
    ProximityDevice, RawScan,
};
use rome_hardware::vxy::VirtualPose;
use rome_schema::robot::{BaseState, SONARS};
use rome_sim::{Camera, Pacer, Sim, SimError};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

/// A world shared by its stepping thread and the devices of its robots.
#[derive(Clone)]
pub struct SimWorld {
    sim: Arc<Mutex<Sim>>,
    /// Each robot's base server's virtual coordinate frame, by robot: kept
    /// here so the world's state can be saved and taken up whole
    /// ([`crate::keep`]).
    frames: Arc<Mutex<BTreeMap<String, Arc<Mutex<VirtualPose>>>>>,
    /// The floors of a building's world ([`Sim::for_building`]): where
    /// each lies on the world's plane.
    plane: Option<Arc<rome_maps::plane::Plane>>,
    /// Where every instant's ground truth is written, if anywhere
    /// ([`SimWorld::trace_to`]).
    trace: Arc<Mutex<Option<Trace>>>,
}

/// The stepping thread (or lock-step task); stops when dropped.
pub struct Stepper {
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
    task: Option<tokio::task::JoinHandle<()>>,
}

impl Drop for Stepper {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        if let Some(t) = self.task.take() {
            t.abort();
        }
    }
}

/// How long a lock-step clock waits for its participants before it says
/// which are still busy (and goes on waiting).
const STALL: std::time::Duration = std::time::Duration::from_secs(10);

/// How long a lock-step clock waits for a publication still on its way
/// when nobody else is busy, before taking it as dropped.
const LOST_AFTER: std::time::Duration = std::time::Duration::from_secs(1);

/// How long a lock-step world may go without a step, in wall time, before
/// the watchdog reports the clock's state.
const WATCHDOG: std::time::Duration = std::time::Duration::from_secs(60);

/// A round has begun (another of the instant, or a new instant's first):
/// in a run split into processes, the reads stamped for it are answered
/// in it, from the state the rounds before left.
async fn pass_reads(clock: &rome_clock::LockStep) {
    if clock.in_rounds() {
        clock.hand_over(clock.round(), false).await;
    }
}

/// A thread that reports the clock's state, and whether the world is
/// locked, when the world has not stepped for [`WATCHDOG`] of wall time: a
/// thread of its own, so that it speaks even when every task is stuck.
/// It ends when `stop` is set.
fn watchdog(
    clock: &rome_clock::LockStep,
    world: &SimWorld,
    stop: &Arc<AtomicBool>,
    stepped: &Arc<std::sync::atomic::AtomicU64>,
) -> Option<std::thread::JoinHandle<()>> {
    let (clock, world, stop, stepped) =
        (clock.clone(), world.clone(), stop.clone(), stepped.clone());
    std::thread::Builder::new()
        .name("lock-step watchdog".into())
        .spawn(move || {
            let tick = std::time::Duration::from_millis(200);
            let mut seen = stepped.load(Ordering::Relaxed);
            let mut since = std::time::Instant::now();
            while !stop.load(Ordering::Relaxed) {
                std::thread::sleep(tick);
                let now = stepped.load(Ordering::Relaxed);
                if now != seen {
                    (seen, since) = (now, std::time::Instant::now());
                } else if since.elapsed() >= WATCHDOG {
                    since = std::time::Instant::now();
                    tracing::warn!(
                        steps = now,
                        world_locked = world.try_lock().is_none(),
                        clock = %clock.describe(),
                        "lock-step world: no step for a minute of wall time"
                    );
                }
            }
        })
        .ok()
}

impl SimWorld {
    /// Shares a world.
    pub fn new(sim: Sim) -> Self {
        SimWorld {
            sim: Arc::new(Mutex::new(sim)),
            frames: Arc::default(),
            plane: None,
            trace: Arc::default(),
        }
    }

    /// Shares a world of a building's floors laid out on `plane`.
    pub fn on_plane(sim: Sim, plane: rome_maps::plane::Plane) -> Self {
        SimWorld {
            plane: Some(Arc::new(plane)),
            ..SimWorld::new(sim)
        }
    }

    /// The floors' layout, in a world of a building.
    pub fn plane(&self) -> Option<&rome_maps::plane::Plane> {
        self.plane.as_deref()
    }

    /// Robot `robot`'s base frame, shared with its base server.
    pub fn frame(&self, robot: &str) -> Arc<Mutex<VirtualPose>> {
        rome_hardware::locked(&self.frames)
            .entry(robot.to_string())
            .or_default()
            .clone()
    }

    /// Writes the world's ground truth at the present instant and after
    /// every step from now on to the file `path` ([`crate::trace`]).
    pub fn trace_to(&self, path: &std::path::Path) -> std::io::Result<()> {
        let file = std::fs::File::create(path)?;
        let mut trace = Trace::new(std::io::BufWriter::new(file));
        trace.instant(&self.lock());
        *rome_hardware::locked(&self.trace) = Some(trace);
        Ok(())
    }

    /// One step of the world, traced if a trace is on; the time after it.
    fn step(&self) -> u64 {
        let mut sim = self.lock();
        sim.step();
        if let Some(t) = rome_hardware::locked(&self.trace).as_mut() {
            t.instant(&sim);
        }
        sim.time_ms()
    }

    /// The world, locked (a device that panicked mid-step leaves it usable).
    pub fn lock(&self) -> MutexGuard<'_, Sim> {
        rome_hardware::locked(&self.sim)
    }

    /// The world, if nobody else has it right now (a step in progress).
    pub fn try_lock(&self) -> Option<MutexGuard<'_, Sim>> {
        match self.sim.try_lock() {
            Ok(g) => Some(g),
            Err(std::sync::TryLockError::Poisoned(p)) => Some(p.into_inner()),
            Err(std::sync::TryLockError::WouldBlock) => None,
        }
    }

    /// Steps the world on its own thread at `speed` × real time (`None`:
    /// as fast as it goes).
    pub fn start(&self, speed: Option<f64>) -> Stepper {
        let stop = Arc::new(AtomicBool::new(false));
        let world = self.clone();
        let stopping = stop.clone();
        let thread = std::thread::Builder::new()
            .name("rome-sim".into())
            .spawn(move || {
                let pacer = Pacer::new(speed, world.lock().time_ms());
                while !stopping.load(Ordering::Relaxed) {
                    let now = world.step();
                    let wait = pacer.wait(now);
                    if !wait.is_zero() {
                        std::thread::sleep(wait);
                    } else if pacer.speed().is_none() {
                        // Free-running: let the servers at the world now and then.
                        std::thread::yield_now();
                    }
                }
            })
            .ok();
        Stepper {
            stop,
            thread,
            task: None,
        }
    }

    /// Steps the world in lock-step with `clock`: a step is taken only
    /// when every participant of the clock has finished with the present
    /// instant, and never faster than `speed` × real time (`None`: as fast
    /// as they go). `on_step` hears each new time, before any participant
    /// is woken to it. Call within a tokio runtime.
    pub fn start_lockstep(
        &self,
        clock: rome_clock::LockStep,
        speed: Option<f64>,
        on_step: impl FnMut(u64) + Send + 'static,
    ) -> Stepper {
        self.start_lockstep_rounds(clock, speed, on_step, || async { false })
    }

    /// As [`SimWorld::start_lockstep`], and each time every participant
    /// has settled, before the world steps, `another_round` is asked
    /// whether the present instant goes on (it resolves to true once it
    /// has made someone busy again, as [`crate::lockstep::start_lockstep_with`]
    /// does with the next round): the clock then waits for them first.
    pub fn start_lockstep_rounds<R>(
        &self,
        clock: rome_clock::LockStep,
        speed: Option<f64>,
        mut on_step: impl FnMut(u64) + Send + 'static,
        mut another_round: impl FnMut() -> R + Send + 'static,
    ) -> Stepper
    where
        R: std::future::Future<Output = bool> + Send,
    {
        let stop = Arc::new(AtomicBool::new(false));
        let world = self.clone();
        let stopping = stop.clone();
        let stepped = Arc::new(std::sync::atomic::AtomicU64::new(0));
        // Not joined when the stepper goes: it sees `stop` within a tick.
        let _ = watchdog(&clock, self, &stop, &stepped);
        let progress = stepped;
        let task = tokio::spawn(async move {
            let start = world.lock().time_ms();
            let pacer = Pacer::new(speed, start);
            clock.advance(start).await;
            // The start is an instant like any other: whoever follows the
            // clock from elsewhere has finished with it, and waits for the
            // next, before the world first steps.
            on_step(start);
            let mut steps = 0u64;
            let mut waited = std::time::Duration::ZERO;
            while !stopping.load(Ordering::Relaxed) {
                if tokio::time::timeout(LOST_AFTER, clock.settled())
                    .await
                    .is_err()
                {
                    waited += LOST_AFTER;
                    if clock.busy_names().is_empty() {
                        // Only messages are awaited, and for longer than
                        // any crossing takes: a publication was dropped.
                        let lost = clock.forget_in_flight();
                        tracing::warn!(
                            time_ms = clock.now_ms(),
                            lost,
                            "lock-step clock: gave up on publications that never arrived"
                        );
                    } else if waited >= STALL {
                        waited = std::time::Duration::ZERO;
                        tracing::warn!(
                            time_ms = clock.now_ms(),
                            busy = ?clock.busy_names(),
                            in_flight = clock.in_flight(),
                            "lock-step clock: still waiting for these participants to finish with the present instant"
                        );
                    }
                    continue;
                }
                waited = std::time::Duration::ZERO;
                if another_round().await {
                    pass_reads(&clock).await;
                    continue;
                }
                // `on_step` hears the new time before any participant wakes
                // to it: what it sends goes ahead of whatever they send.
                let stepped = clock
                    .try_advance(|| {
                        let now = world.step();
                        on_step(now);
                        now
                    })
                    .await;
                // Someone became busy after all: it finishes first.
                let Some(now) = stepped else { continue };
                pass_reads(&clock).await;
                let wait = pacer.wait(now);
                steps += 1;
                progress.store(steps, Ordering::Relaxed);
                if !wait.is_zero() {
                    tokio::time::sleep(wait).await;
                } else if steps.is_multiple_of(8) {
                    // Let tasks outside the clock (a recorder, a viewer) run.
                    tokio::task::yield_now().await;
                }
            }
        });
        Stepper {
            stop,
            thread: None,
            task: Some(task),
        }
    }

    fn index(&self, robot: &str) -> Result<usize, SimError> {
        self.lock().index(robot)
    }

    /// Robot `robot`'s base.
    pub fn base(&self, robot: &str) -> Result<SimBase, SimError> {
        Ok(SimBase {
            world: self.clone(),
            i: self.index(robot)?,
        })
    }

    /// Robot `robot`'s sonars and infrared detectors.
    pub fn proximity(&self, robot: &str) -> Result<SimProximity, SimError> {
        Ok(SimProximity {
            world: self.clone(),
            i: self.index(robot)?,
        })
    }

    /// One of robot `robot`'s cameras.
    pub fn camera(&self, robot: &str, which: Camera) -> Result<SimCamera, SimError> {
        let size = self.lock().config().image_size;
        Ok(SimCamera {
            world: self.clone(),
            i: self.index(robot)?,
            which,
            size,
        })
    }
}

/// A simulated robot's base.
pub struct SimBase {
    world: SimWorld,
    i: usize,
}

impl BaseDevice for SimBase {
    async fn command(&mut self, op: BaseOp) -> Result<BaseStatus, DeviceError> {
        let mut sim = self.world.lock();
        let time_ms = sim.time_ms();
        if op != BaseOp::Status {
            let r = sim.robot_mut(self.i);
            let d = &mut r.drive;
            let done = match op {
                BaseOp::Status => Ok(()),
                BaseOp::Move(m) => d.move_by(m.distance_mm, m.velocity_mm_s, m.accel_mm_s2),
                BaseOp::Turn(t) => d.turn(t.degrees, t.velocity_deg_s, t.accel_deg_s2),
                BaseOp::Go(v) => d.go(v),
                BaseOp::Jog(rate) => d.jog(rate),
                BaseOp::Stop(emergency) => {
                    d.stop(emergency);
                    Ok(())
                }
                BaseOp::SetBumper(watch) => {
                    r.bumpers.watch = watch;
                    Ok(())
                }
            };
            done.map_err(|e| DeviceError::OutOfRange(e.to_string()))?;
        }
        Ok(base_status(&sim, self.i, time_ms))
    }

    fn peek(&self) -> Option<Peek<BaseStatus>> {
        let (world, i) = (self.world.clone(), self.i);
        Some(Arc::new(move || {
            let sim = world.try_lock()?;
            Some(base_status(&sim, i, sim.time_ms()))
        }))
    }
}

/// Robot `i`'s base status at `time_ms`.
fn base_status(sim: &Sim, i: usize, time_ms: u64) -> BaseStatus {
    let r = sim.robot(i);
    let regs = r.odometry.registers();
    BaseStatus {
        raw_x: regs.x,
        raw_y: regs.y,
        state: BaseState {
            time_ms,
            heading_deg: f64::from(regs.heading_centideg) / 100.0,
            speed_mm_s: r.drive.speed_setting,
            wheel_speed_mm_s: r.drive.wheel_speed(),
            mode: r.drive.mode.name().to_string(),
            bumpers: r.bumpers.status(),
            watch_bumpers: r.bumpers.watch,
            ..BaseState::default()
        },
    }
}

/// A simulated robot's proximity subsystem.
pub struct SimProximity {
    world: SimWorld,
    i: usize,
}

impl ProximityDevice for SimProximity {
    async fn scan(&mut self) -> Result<RawScan, DeviceError> {
        Ok(raw_scan(&self.world.lock(), self.i))
    }

    fn peek(&self) -> Option<Peek<RawScan>> {
        let (world, i) = (self.world.clone(), self.i);
        Some(Arc::new(move || {
            let sim = world.try_lock()?;
            Some(raw_scan(&sim, i))
        }))
    }

    async fn set_timeout(&mut self, max_mm: [u32; SONARS]) -> Result<[u32; SONARS], DeviceError> {
        let mut sim = self.world.lock();
        for (s, mm) in max_mm.iter().enumerate() {
            let mm = u16::try_from(*mm)
                .map_err(|_| DeviceError::OutOfRange(format!("sonar {s}: {mm} mm is too far")))?;
            sim.set_timeout(self.i, s, mm)
                .map_err(|e| DeviceError::OutOfRange(e.to_string()))?;
        }
        Ok(sim.robot(self.i).timeouts.map(u32::from))
    }
}

/// Robot `i`'s latest scan.
fn raw_scan(sim: &Sim, i: usize) -> RawScan {
    let r = sim.robot(i);
    RawScan {
        time_ms: r.sonar_at_ms,
        sonar_mm: r.scan.map(u32::from),
        ir: r.infrared,
    }
}

/// A simulated robot's camera.
pub struct SimCamera {
    world: SimWorld,
    i: usize,
    which: Camera,
    size: (u32, u32),
}

impl CameraDevice for SimCamera {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    async fn grab(&mut self) -> Result<Frame, DeviceError> {
        let world = self.world.clone();
        let (i, which) = (self.i, self.which);
        // The world's lock may be held for a whole step: off the async
        // workers (and, in a lock-step run, holding the clock until the
        // frame is taken). Only what the camera sees is taken now; its
        // rows are drawn when they are read.
        rome_clock::compute(tokio::task::spawn_blocking(move || {
            let mut sim = world.lock();
            let time_ms = sim.time_ms();
            let view = sim.camera_view(i, which);
            let (width, height) = view.size();
            Frame {
                time_ms,
                width,
                height,
                pixels: Pixels::drawn(height, move |r, line| view.row(r, line)),
            }
        }))
        .await
        .map_err(|e| DeviceError::Disconnected {
            device: format!("{} camera", which.name()),
            why: e.to_string(),
        })
    }
}
