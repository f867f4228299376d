//! [`RobotClient`]: the hardware servers' function libraries (Fig. 4.8):
//! the base (`RobotMove`, `RobotTurn`, `RobotGetPos`, `RobotLock` …), the
//! proximity subsystem (`ProxReadSonar`, `ProxReadInfraRed`,
//! `ProxSetTimeout`) and the cameras (`CameraGetSize`, `CameraGrab`,
//! `CameraGrabRow`, `CameraLock`).
//!
//! Every call is one Zenoh query to `<root>/robot/<robot>/<device>/<command>`
//! (see `docs/keys.md`) carrying the client's priority, both as the
//! `priority` parameter the server queues by and as the query's Zenoh QoS
//! priority. A command that acts (move, turn, go, jog, stop, set-pose,
//! adjust-pose, set-bumper, timeout) carries a request id (`op`) and is sent
//! again, up to [`ACTING_ATTEMPTS`] times, when its reply does not come: the
//! server answers a repeat as it answered the first and does not act twice.
//!
//! While this client holds a device's lock, its commands to that device
//! carry the grant's fence and a task renews the grant; dropping the
//! [`Lock`] releases it.

use crate::call::{self, selector, Answer, Waiting};
use crate::ClientError;
use rome_schema::robot::command::{
    Command, Grab, ReadBumper, ReadIr, ReadMode, ReadPose, ReadSize, ReadSonar, ReadSpeed,
    ReadWheelSpeed, ReleaseLock, Rows, TakeLock,
};
use rome_schema::robot::{
    format_rows, param, robot_name, AdjustPose, Band, BaseState, BumperReply, Device, Done,
    FrameInfo, Go, IrReply, Jog, LockGrant, MaxRange, ModeReply, Move, PoseReply, Scan, SetBumper,
    SetPose, SetTimeout, SizeReply, SonarReply, SpeedReply, Stop, TimeoutReply, Turn,
    WheelSpeedReply, DEFAULT_LOCK_TTL_MS, DEFAULT_PRIORITY, SONARS,
};
use rome_schema::{decode, ErrorCode, Name, Root};
use rome_serve::presence::{self, Presence};
use serde::de::DeserializeOwned;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::handlers::RingChannel;
use zenoh::qos::Priority;
use zenoh::Session;

mod received;
use received::{image, Skipped};
pub use received::{Image, Stream, STREAM_BACKLOG};

static NEXT_CLIENT: AtomicU64 = AtomicU64::new(1);

/// How often a command that acts is sent at most when no reply comes.
pub const ACTING_ATTEMPTS: u32 = 3;

static NEXT_OP: AtomicU64 = AtomicU64::new(1);

/// The Zenoh QoS priority a RoME priority (0 … 255) travels in; see
/// [`Band::of`].
pub fn zenoh_priority(priority: u8) -> Priority {
    match Band::of(priority) {
        Band::InteractiveHigh => Priority::InteractiveHigh,
        Band::InteractiveLow => Priority::InteractiveLow,
        Band::DataHigh => Priority::DataHigh,
        Band::Data => Priority::Data,
        Band::DataLow => Priority::DataLow,
        Band::Background => Priority::Background,
    }
}

/// The band a request travels in: its priority's ([`zenoh_priority`]),
/// except in a lock-step run, where every message goes in the default
/// band. Zenoh keeps one sender's messages in order only within a band,
/// and the clock's rounds rely on that order; the priority still rides as
/// a parameter, which is what the servers go by, and the clock waits for
/// every message whatever its band.
pub fn band(priority: u8) -> Priority {
    call::lockstep_band(zenoh_priority(priority))
}

/// How a [`RobotClient`] behaves.
#[derive(Debug, Clone)]
pub struct RobotOptions {
    /// The deployment's root prefix.
    pub root: Root,
    /// What this client is (`navigator`, `cli` …): shown by `rome ls`.
    pub role: String,
    /// This client's priority at every hardware server, 0 … 255 (§4.3).
    pub priority: u8,
    /// How long a request may wait in a server's queue (behind a lock).
    pub queue_wait: Duration,
    /// How long a reply may take once the request is served.
    pub reply_timeout: Duration,
    /// A lock grant's life between renewals.
    pub lock_ttl: Duration,
    /// Whether the base stops when this client goes away after setting it
    /// moving (each command names its sender, `client=ID`). On by
    /// default; a one-shot command line tool turns it off so the robot
    /// goes on after the tool exits.
    pub deadman: bool,
    /// How long a request keeps being sent again while nobody serves its
    /// key (a server or the router restarting) before it fails.
    pub unreachable_for: Duration,
    /// Sent with every command that acts as `suppress_ms`: once carried
    /// out, it keeps lower priorities' commands that act off the device
    /// for this long (a colony-style module's suppressor, §4.8.2).
    pub suppress: Option<Duration>,
}

impl RobotOptions {
    /// Defaults for a client with this role.
    pub fn new(role: &str) -> Self {
        RobotOptions {
            root: Root::default(),
            role: role.to_string(),
            priority: DEFAULT_PRIORITY,
            queue_wait: Duration::from_secs(10),
            reply_timeout: Duration::from_secs(5),
            lock_ttl: Duration::from_millis(DEFAULT_LOCK_TTL_MS),
            deadman: true,
            unreachable_for: Duration::from_secs(10),
            suppress: None,
        }
    }
}

struct Inner {
    session: Session,
    options: RobotOptions,
    robot: Name,
    /// Whether `robot` names an elevator (`<root>/building/elevator/…`,
    /// one device) rather than a robot.
    elevator: bool,
    owner: String,
    fences: Mutex<HashMap<String, u64>>,
    _token: Presence,
}

/// A client of one robot's hardware servers. Cheap to clone; clones share
/// one owner id, one liveliness token and the locks they hold.
#[derive(Clone)]
pub struct RobotClient {
    inner: Arc<Inner>,
}

/// A held lock on a device (`RobotLock`, `CameraLock`). Renewed in the
/// background while it lives; released when dropped or [`Lock::unlock`]ed.
pub struct Lock {
    client: RobotClient,
    device: Device,
    grant: LockGrant,
    renew: tokio::task::JoinHandle<()>,
    released: bool,
}

impl Lock {
    /// The grant's fencing number.
    pub fn fence(&self) -> u64 {
        self.grant.fence
    }

    /// The grant.
    pub fn grant(&self) -> &LockGrant {
        &self.grant
    }

    /// Whether the grant is still this client's (false once the server
    /// refused a renewal: the lock lapsed or another client has it).
    pub fn held(&self) -> bool {
        self.client.fence(&self.device) == Some(self.grant.fence)
    }

    /// Releases the lock (`RobotUnlock`, `CameraUnLock`).
    pub async fn unlock(mut self) -> Result<(), ClientError> {
        self.release().await
    }

    /// Stops renewing, forgets the fence and returns the `unlock` request;
    /// from then on this lock is released (dropping it does nothing more).
    fn release(&mut self) -> impl std::future::Future<Output = Result<(), ClientError>> + 'static {
        self.released = true;
        self.renew.abort();
        let fence = self.grant.fence;
        self.client.forget(&self.device, fence);
        let (client, device) = (self.client.clone(), self.device.clone());
        async move {
            match client.json(&device, &ReleaseLock { fence }, false).await {
                Ok(_) => Ok(()),
                // The lock is no longer this client's (a server restarted,
                // or the grant lapsed): there is nothing left to release.
                Err(e) if e.code() == Some(ErrorCode::StaleFence) => {
                    tracing::debug!(device = %device.path(), error = %e, "lock already gone");
                    Ok(())
                }
                Err(e) => Err(e),
            }
        }
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        self.renew.abort();
        if self.released {
            return;
        }
        let unlock = self.release();
        if tokio::runtime::Handle::try_current().is_ok() {
            // In a lock-step run the release is part of the dropping
            // client's instant: the device is free before the clock moves.
            rome_clock::spawn("lock release", unlock);
        }
    }
}

impl RobotClient {
    /// A client of robot `robot`'s servers; declares this client alive
    /// (`<root>/alive/client/<role>/<owner>`), which is what ties its locks
    /// to its life.
    pub async fn connect(
        session: &Session,
        robot: &str,
        options: RobotOptions,
    ) -> Result<Self, ClientError> {
        Self::connect_to(session, robot_name(robot)?, false, options).await
    }

    /// A client of robot or elevator `name`'s servers (see
    /// [`crate::elevator`]).
    pub(crate) async fn connect_to(
        session: &Session,
        robot: Name,
        elevator: bool,
        options: RobotOptions,
    ) -> Result<Self, ClientError> {
        let role = Name::new(options.role.as_str())?;
        let n = NEXT_CLIENT.fetch_add(1, Ordering::Relaxed);
        let owner = format!("{}-r{n}", session.zid());
        let token = presence::declare(session, &options.root.alive_client(role.as_str(), &owner))
            .await
            .map_err(ClientError::zenoh)?;
        Ok(RobotClient {
            inner: Arc::new(Inner {
                session: session.clone(),
                options,
                robot,
                elevator,
                owner,
                fences: Mutex::new(HashMap::new()),
                _token: token,
            }),
        })
    }

    /// The session and options this client was made with, for a client
    /// of another server beside it (an elevator the robot rides).
    pub(crate) fn parts(&self) -> (&Session, &RobotOptions) {
        (&self.inner.session, &self.inner.options)
    }

    /// The robot's name.
    pub fn robot(&self) -> &str {
        self.inner.robot.as_str()
    }

    /// This client's owner id (the last chunk of its liveliness token).
    pub fn owner(&self) -> &str {
        &self.inner.owner
    }

    fn fences(&self) -> std::sync::MutexGuard<'_, HashMap<String, u64>> {
        self.inner
            .fences
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    fn fence(&self, device: &Device) -> Option<u64> {
        self.fences().get(&device.path()).copied()
    }

    fn forget(&self, device: &Device, fence: u64) {
        let mut fences = self.fences();
        if fences.get(&device.path()) == Some(&fence) {
            fences.remove(&device.path());
        }
    }

    /// The key of `chunk` on `device` (an elevator has one device).
    fn key(&self, device: &Device, chunk: &str) -> String {
        let o = &self.inner.options;
        if self.inner.elevator {
            o.root.elevator(&self.inner.robot, chunk)
        } else {
            o.root.robot(&self.inner.robot, device, chunk)
        }
    }

    /// The server's liveliness kind and name, and what to call it.
    fn server(&self, device: &Device) -> (&'static str, String) {
        if self.inner.elevator {
            ("building", format!("elevator/{}", self.inner.robot))
        } else {
            ("robot", format!("{}/{}", self.inner.robot, device.path()))
        }
    }

    /// One command, sent as its schema type encodes it, with the
    /// parameters every command carries; the reply's bytes and encoding.
    async fn raw<C: Command>(
        &self,
        device: &Device,
        command: &C,
        queued: bool,
    ) -> Result<(Vec<u8>, Encoding), ClientError> {
        let o = &self.inner.options;
        let key = self.key(device, C::NAME);
        let payload = command.payload();
        let mut params = command.params();
        let explicit_fence = params.iter().any(|(k, _)| *k == param::FENCE);
        if o.priority != DEFAULT_PRIORITY {
            params.push((param::PRIORITY, o.priority.to_string()));
        }
        if o.deadman {
            params.push((param::CLIENT, self.inner.owner.clone()));
        }
        let acting = C::ACTS;
        if acting {
            let n = NEXT_OP.fetch_add(1, Ordering::Relaxed);
            params.push((param::OP, format!("{}-{n}", self.inner.owner)));
            if let Some(s) = o.suppress {
                params.push((param::SUPPRESS_MS, s.as_millis().to_string()));
            }
        }
        let holds = self.fence(device);
        if let (Some(f), false) = (holds, explicit_fence) {
            params.push((param::FENCE, f.to_string()));
        }
        let wait = if queued && holds.is_none() {
            params.push((param::WAIT_MS, o.queue_wait.as_millis().to_string()));
            o.queue_wait
        } else {
            Duration::ZERO
        };
        let timeout = wait + o.reply_timeout;
        let selector = selector(&key, &params);
        let started = std::time::Instant::now();
        let attempts = if acting { ACTING_ATTEMPTS } else { 1 };
        let mut attempt = 0;
        let mut pause = Duration::from_millis(100);
        // In a lock-step run, a command queued behind another client's
        // lock waits for that client (idle), and so does one that waits
        // for its round to end in a run split into processes; any other
        // is answered at once (busy: the clock waits for the answer).
        let held = rome_clock::in_rounds() && !rome_schema::robot::only_reads(&key);
        let waiting = if wait.is_zero() && !held {
            Waiting::Busy
        } else {
            Waiting::Idle
        };
        loop {
            let tried = std::time::Instant::now();
            let answer = call::attempt(
                &self.inner.session,
                &selector,
                payload.as_deref(),
                timeout,
                band(o.priority),
                waiting,
            )
            .await?;
            match answer {
                Some(Answer::Reply { body, encoding }) => return Ok((body, encoding)),
                Some(Answer::Refused(e)) => {
                    let (kind, name) = self.server(device);
                    let presence = o.root.alive_server(kind, &name);
                    return Err(call::refused(&self.inner.session, e, &presence, &name).await);
                }
                None => {}
            }
            // A silence that came at once: nobody serves the key right now
            // (a server or the router restarting, a link being rebuilt).
            // Nothing was delivered, so asking again is safe for any
            // command; it is, for a while, after a growing pause.
            if tried.elapsed() < Duration::from_millis(50)
                && started.elapsed() + pause < o.unreachable_for
            {
                tokio::time::sleep(pause).await;
                pause = (pause * 2).min(Duration::from_secs(1));
                continue;
            }
            // A silence after waiting: the request or its answer was lost.
            // The same id makes sending an acting command again safe.
            attempt += 1;
            if attempt >= attempts {
                break;
            }
        }
        let device = (!self.inner.elevator).then_some(device);
        Err(no_reply(device, key, started.elapsed()))
    }

    /// One command whose reply is JSON, decoded as the command's reply.
    pub(crate) async fn json<C: Command>(
        &self,
        device: &Device,
        command: &C,
        queued: bool,
    ) -> Result<C::Reply, ClientError> {
        let (bytes, _) = self.raw(device, command, queued).await?;
        Ok(decode(&bytes, &format!("'{}' reply", C::NAME))?)
    }

    async fn base<C: Command>(&self, command: &C) -> Result<C::Reply, ClientError> {
        self.json(&Device::Base, command, true).await
    }

    // ----- base (RServer, Table 4.1) ---------------------------------------

    /// `RobotMove`: go `distance_mm` (negative backwards) at a velocity and
    /// acceleration (negative: keep the current settings).
    pub async fn move_by(
        &self,
        distance_mm: f64,
        velocity_mm_s: f64,
        accel_mm_s2: f64,
    ) -> Result<Done, ClientError> {
        let m = Move {
            distance_mm,
            velocity_mm_s,
            accel_mm_s2,
        };
        self.base(&m).await
    }

    /// `RobotTurn`: turn by `degrees`, positive clockwise.
    pub async fn turn(
        &self,
        degrees: f64,
        velocity_deg_s: f64,
        accel_deg_s2: f64,
    ) -> Result<Done, ClientError> {
        let t = Turn {
            degrees,
            velocity_deg_s,
            accel_deg_s2,
        };
        self.base(&t).await
    }

    /// `RobotGo`: Go mode at a velocity.
    pub async fn go(&self, velocity_mm_s: f64) -> Result<Done, ClientError> {
        self.base(&Go { velocity_mm_s }).await
    }

    /// `RobotJog`: Jog mode at a turn rate, positive clockwise.
    pub async fn jog(&self, rate_deg_s: f64) -> Result<Done, ClientError> {
        self.base(&Jog { rate_deg_s }).await
    }

    /// `RobotStop`: at once (`emergency`) or gradually.
    pub async fn stop(&self, emergency: bool) -> Result<Done, ClientError> {
        self.base(&Stop { emergency }).await
    }

    /// `RobotGetPos`: the pose in virtual 32-bit coordinates.
    pub async fn pose(&self) -> Result<PoseReply, ClientError> {
        self.base(&ReadPose).await
    }

    /// `RobotSetPos`: sets the position registers.
    pub async fn set_pose(
        &self,
        x_mm: i64,
        y_mm: i64,
        heading_deg: f64,
    ) -> Result<Done, ClientError> {
        let p = SetPose {
            x_mm,
            y_mm,
            heading_deg,
        };
        self.base(&p).await
    }

    /// `RobotAdjPos`: adds to the position and heading.
    pub async fn adjust_pose(
        &self,
        dx_mm: i64,
        dy_mm: i64,
        dheading_deg: f64,
    ) -> Result<Done, ClientError> {
        let a = AdjustPose {
            dx_mm,
            dy_mm,
            dheading_deg,
        };
        self.base(&a).await
    }

    /// `RobotGetBumper`: the bumper status.
    pub async fn bumper(&self) -> Result<BumperReply, ClientError> {
        self.base(&ReadBumper).await
    }

    /// `RobotSetBumper`: watch (stop on contact) or ignore the bumpers.
    pub async fn set_bumper(&self, watch: bool) -> Result<Done, ClientError> {
        self.base(&SetBumper { watch }).await
    }

    /// `RobotGetSpeed`: the velocity setting.
    pub async fn speed(&self) -> Result<SpeedReply, ClientError> {
        self.base(&ReadSpeed).await
    }

    /// `RobotGetWSpeed`: the mean wheel speed.
    pub async fn wheel_speed(&self) -> Result<WheelSpeedReply, ClientError> {
        self.base(&ReadWheelSpeed).await
    }

    /// `RobotGetMode`: the operating mode.
    pub async fn mode(&self) -> Result<ModeReply, ClientError> {
        self.base(&ReadMode).await
    }

    /// `RobotLock`: waits for the base's lock token (in the queue like any
    /// request) and holds it until the [`Lock`] is dropped.
    pub async fn lock(&self) -> Result<Lock, ClientError> {
        self.lock_device(Device::Base).await
    }

    /// Subscribes to the base's state stream.
    pub async fn state(&self) -> Result<Stream<BaseState>, ClientError> {
        self.stream(&Device::Base, "state").await
    }

    // ----- proximity (PServer, §4.6.2) -------------------------------------

    /// `ProxReadSonar`: the 24 sonar ranges, mm.
    pub async fn sonar(&self) -> Result<SonarReply, ClientError> {
        self.json(&Device::Proximity, &ReadSonar, true).await
    }

    /// `ProxReadInfraRed`: 24 infrared slots, 1 = something near.
    pub async fn infrared(&self) -> Result<IrReply, ClientError> {
        self.json(&Device::Proximity, &ReadIr, true).await
    }

    /// `ProxSetTimeout`: each sonar's maximum range, mm.
    pub async fn set_timeout(&self, max_mm: [u32; SONARS]) -> Result<TimeoutReply, ClientError> {
        let body = SetTimeout {
            max_mm: MaxRange::Each(max_mm.to_vec()),
        };
        self.json(&Device::Proximity, &body, true).await
    }

    /// Subscribes to the scan stream.
    pub async fn scans(&self) -> Result<Stream<Scan>, ClientError> {
        self.stream(&Device::Proximity, "scan").await
    }

    // ----- cameras (CServer, §4.6.4) ---------------------------------------

    fn camera(name: &str) -> Result<Device, ClientError> {
        Ok(Device::Camera(robot_name(name)?))
    }

    /// `CameraGetSize`.
    pub async fn camera_size(&self, camera: &str) -> Result<SizeReply, ClientError> {
        self.json(&Self::camera(camera)?, &ReadSize, true).await
    }

    /// `CameraGrab`: the last image the server grabbed.
    pub async fn camera_grab(&self, camera: &str) -> Result<Image, ClientError> {
        let (bytes, encoding) = self
            .raw(&Self::camera(camera)?, &Grab { png: false }, true)
            .await?;
        image(bytes, &encoding)
    }

    /// `CameraGrabRow`: some rows of the last image, in one round trip.
    /// A reply that does not carry exactly the rows asked for, in order,
    /// is an error, so `row(k)` is the `k`-th row asked for.
    pub async fn camera_rows(&self, camera: &str, rows: &[u32]) -> Result<Image, ClientError> {
        let ask = Rows {
            rows: rows.to_vec(),
        };
        let (bytes, encoding) = self.raw(&Self::camera(camera)?, &ask, true).await?;
        let img = image(bytes, &encoding)?;
        if img.rows != rows {
            return Err(ClientError::Server(rome_schema::ErrorReply::new(
                ErrorCode::Device,
                format!(
                    "the camera server sent rows {}, not the rows asked for ({})",
                    format_rows(&img.rows),
                    format_rows(rows)
                ),
            )));
        }
        Ok(img)
    }

    /// Subscribes to a camera's frame stream: one message after each grab.
    pub async fn frames(&self, camera: &str) -> Result<Stream<FrameInfo>, ClientError> {
        self.stream(&Self::camera(camera)?, "frame").await
    }

    /// `CameraLock`: freezes the camera's grabbing for this client.
    pub async fn camera_lock(&self, camera: &str) -> Result<Lock, ClientError> {
        self.lock_device(Self::camera(camera)?).await
    }

    // ----- locks and streams ----------------------------------------------

    pub(crate) async fn lock_device(&self, device: Device) -> Result<Lock, ClientError> {
        let o = &self.inner.options;
        let take = TakeLock {
            owner: Some(self.inner.owner.clone()),
            ttl_ms: Some(o.lock_ttl.as_millis() as u64),
            renew: None,
        };
        let grant = self.json(&device, &take, true).await?;
        self.fences().insert(device.path(), grant.fence);
        // A participant of a lock-step clock: the grant is renewed in the
        // simulated time its server counts it in.
        let renew = rome_clock::spawn(
            "lock renewal",
            renew(self.clone(), device.clone(), grant.fence, o.lock_ttl),
        );
        Ok(Lock {
            client: self.clone(),
            device,
            grant,
            renew,
            released: false,
        })
    }

    pub(crate) async fn stream<T: DeserializeOwned>(
        &self,
        device: &Device,
        chunk: &str,
    ) -> Result<Stream<T>, ClientError> {
        let key = self.key(device, chunk);
        // A ring: a reader that falls behind loses the oldest messages
        // rather than holding up every other subscriber of the session.
        let subscriber = self
            .inner
            .session
            .declare_subscriber(&key)
            .with(crate::inflight::counted(
                &key,
                RingChannel::new(STREAM_BACKLOG),
            ))
            .await
            .map_err(ClientError::zenoh)?;
        Ok(Stream {
            subscriber,
            what: chunk.to_string(),
            skipped: std::sync::Mutex::new(Skipped::default()),
            _t: std::marker::PhantomData,
        })
    }
}

/// Keeps a grant alive: a renewal every third of its life.
async fn renew(client: RobotClient, device: Device, fence: u64, ttl: Duration) {
    let every = ttl / 3;
    loop {
        rome_clock::sleep(every).await;
        let take = TakeLock {
            owner: Some(client.inner.owner.clone()),
            ttl_ms: None,
            renew: Some(fence),
        };
        let renewed = client.json(&device, &take, false).await;
        match renewed {
            Ok(_) => {}
            Err(e) if e.code() == Some(ErrorCode::StaleFence) => {
                tracing::warn!(device = %device.path(), fence, "lock lost: {e}");
                client.forget(&device, fence);
                return;
            }
            // A lost renewal is retried next time; the grant outlives two.
            Err(e) => {
                tracing::debug!(device = %device.path(), error = %e, "lock renewal unanswered")
            }
        }
    }
}

fn no_reply(device: Option<&Device>, key: String, waited: Duration) -> ClientError {
    ClientError::NoReply {
        what: match device {
            Some(Device::Base) => "the base server",
            Some(Device::Proximity) => "the proximity server",
            Some(Device::Camera(_)) => "the camera server",
            None => "the elevator server",
        },
        key,
        waited,
    }
}
