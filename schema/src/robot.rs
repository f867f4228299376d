//! The hardware servers' keys and messages: the base (RServer, §4.6.3), the
//! proximity subsystem (PServer, §4.6.2) and each camera (CServer, §4.6.4).
//!
//! ```text
//! rome/robot/<robot>/base/<command>            RServer: Table 4.1 (queries)
//! rome/robot/<robot>/base/state                RServer publishes its state
//! rome/robot/<robot>/proximity/<command>       PServer: sonar, ir, timeout
//! rome/robot/<robot>/proximity/scan            PServer publishes each scan
//! rome/robot/<robot>/camera/<camera>/<command> CServer: size, grab, rows, lock …
//! rome/robot/<robot>/camera/<camera>/frame     CServer publishes each grab's number
//! rome/store/robot/<robot>/<device>/lock       lock state, kept by a Zenoh storage
//! ```
//!
//! Every command is a query. Its payload, when it has one, is a JSON object
//! (the types below, grouped by who sends them); its selector parameters
//! are the ones every hardware server shares ([`param`]).

use crate::{keys::Name, ErrorCode, ErrorReply, KeyError, Params, Root};
use serde::{Deserialize, Serialize};

/// Number of sonars on the ring, and of infrared slots in a reply (§4.6.2).
pub const SONARS: usize = 24;

/// Decodes a per-sensor list that must have exactly [`SONARS`] entries: a
/// short or long one from anyone on the network is refused at decoding, so
/// no reader can index past its end.
fn exactly_sonars<'de, D, T>(d: D) -> Result<Vec<T>, D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    let v = Vec::<T>::deserialize(d)?;
    if v.len() != SONARS {
        return Err(serde::de::Error::custom(format!(
            "expected {SONARS} readings, one per sensor, got {}",
            v.len()
        )));
    }
    Ok(v)
}

/// The selector parameters every hardware server takes.
pub mod param {
    /// The client's priority, 0 (lowest) … 255 (highest); default
    /// [`super::DEFAULT_PRIORITY`].
    pub const PRIORITY: &str = "priority";
    /// The lock holder's fencing number; commands with another are refused.
    pub const FENCE: &str = "fence";
    /// How long the request may wait in the queue, ms.
    pub const WAIT_MS: &str = "wait_ms";
    /// `lock`: the holder's owner id (last chunk of its liveliness token).
    pub const OWNER: &str = "owner";
    /// `lock`: how long the grant lasts without a renewal, ms.
    pub const TTL_MS: &str = "ttl_ms";
    /// A command that acts: its request id. A repeat with the same id is
    /// answered as the first was, without acting again.
    pub const OP: &str = "op";
    /// Any command: the sender's id (last chunk of its liveliness token).
    /// A base set moving by a client that then goes away is stopped.
    pub const CLIENT: &str = "client";
    /// `rows`: the rows to read, comma-separated (`rows=120,241,360`).
    pub const ROWS: &str = "rows";
    /// `grab`: `raw` (default) or `png`.
    pub const FORMAT: &str = "format";
}

/// A request's priority when it names none (Zenoh's default `Data` band).
pub const DEFAULT_PRIORITY: u8 = 128;
/// How long a request may wait in a queue when it says nothing, ms.
pub const DEFAULT_WAIT_MS: u64 = 10_000;
/// The longest a request may ask to wait in a queue, ms.
pub const MAX_WAIT_MS: u64 = 600_000;
/// A lock grant's default life without a renewal, ms: with the servers'
/// 100 ms sweep, a holder that is cut off loses the lock within 2.6 s.
pub const DEFAULT_LOCK_TTL_MS: u64 = 2_500;
/// The shortest and longest lock life a client may ask for, ms.
pub const LOCK_TTL_RANGE_MS: (u64, u64) = (200, 60_000);

/// Which hardware server a key belongs to.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Device {
    /// The base (RServer).
    Base,
    /// The sonar ring and infrared detectors (PServer).
    Proximity,
    /// One camera (a CServer), by name (`up`, `side`).
    Camera(Name),
}

impl Device {
    /// The key path below the robot: `base`, `proximity`, `camera/<name>`.
    pub fn path(&self) -> String {
        match self {
            Device::Base => "base".into(),
            Device::Proximity => "proximity".into(),
            Device::Camera(name) => format!("camera/{name}"),
        }
    }

    /// The liveliness role of its server: `base`, `proximity`, `camera`.
    pub fn kind(&self) -> &'static str {
        match self {
            Device::Base => "base",
            Device::Proximity => "proximity",
            Device::Camera(_) => "camera",
        }
    }
}

/// A parsed hardware-server key: a command to one device of one robot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RobotKey {
    /// The robot's name.
    pub robot: Name,
    /// The device.
    pub device: Device,
    /// The command (last chunk).
    pub command: String,
}

impl Root {
    /// `<root>/robot/<robot>/<device>/<command>`.
    pub fn robot(&self, robot: &Name, device: &Device, command: &str) -> String {
        format!(
            "{}/robot/{robot}/{}/{command}",
            self.as_str(),
            device.path()
        )
    }

    /// `<root>/robot/<robot>/<device>/*`: the key a device server answers.
    pub fn robot_device_all(&self, robot: &Name, device: &Device) -> String {
        self.robot(robot, device, "*")
    }

    /// `<root>/store/robot/<robot>/<device>/lock`: where a device's lock
    /// state is kept (a Zenoh storage on `<root>/store/**` holds it).
    pub fn lock_store(&self, robot: &Name, device: &Device) -> String {
        format!(
            "{}/store/robot/{robot}/{}/lock",
            self.as_str(),
            device.path()
        )
    }

    /// `<root>/store/**`: what a storage for RoME's servers must cover.
    pub fn store_all(&self) -> String {
        format!("{}/store/**", self.as_str())
    }

    /// Parses `<root>/robot/<robot>/<device>/<command>`; robot names are
    /// one chunk.
    pub fn parse_robot(&self, key: &str) -> Result<RobotKey, KeyError> {
        let unknown = || KeyError::UnknownOp {
            key: key.to_string(),
            ops: "<root>/robot/<robot>/{base,proximity,camera/<camera>}/<command>".into(),
        };
        let rest = key
            .strip_prefix(self.as_str())
            .and_then(|r| r.strip_prefix("/robot/"))
            .ok_or_else(|| KeyError::OutsideRoot {
                key: key.to_string(),
                root: self.as_str().to_string(),
            })?;
        let chunks: Vec<&str> = rest.split('/').collect();
        let (robot, device, command) = match chunks.as_slice() {
            [robot, "base", command] => (*robot, Device::Base, *command),
            [robot, "proximity", command] => (*robot, Device::Proximity, *command),
            [robot, "camera", camera, command] => {
                (*robot, Device::Camera(Name::new(*camera)?), *command)
            }
            _ => return Err(unknown()),
        };
        Ok(RobotKey {
            robot: Name::new(robot)?,
            device,
            command: command.to_string(),
        })
    }
}

/// Checks a robot or camera name: one key chunk.
pub fn robot_name(name: &str) -> Result<Name, KeyError> {
    if name.contains('/') {
        return Err(KeyError::BadName {
            name: name.to_string(),
            why: "robot and camera names are one key chunk, without '/'".into(),
        });
    }
    Name::new(name)
}

/// The parameters every hardware-server request may carry.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Meta {
    /// 0 … 255, higher first.
    pub priority: u8,
    /// The lock holder's fencing number, if the sender holds a lock.
    pub fence: Option<u64>,
    /// How long the request may wait in the queue, ms.
    pub wait_ms: u64,
    /// The sender's id, if it gave one (`client`).
    pub client: Option<String>,
    /// The request id, if it gave one (`op`).
    pub op: Option<String>,
}

impl Meta {
    /// Takes `priority`, `fence`, `wait_ms`, `client` and `op` from the
    /// parameters.
    pub fn take(params: &mut Params) -> Result<Meta, ErrorReply> {
        let priority = params
            .take_int(param::PRIORITY, 0, 255)?
            .map_or(DEFAULT_PRIORITY, |p| p as u8);
        let fence = params
            .take_int(param::FENCE, 0, i128::from(u64::MAX))?
            .map(|f| f as u64);
        let wait_ms = params
            .take_int(param::WAIT_MS, 0, i128::from(MAX_WAIT_MS))?
            .map_or(DEFAULT_WAIT_MS, |w| w as u64);
        let client = params.take_id(param::CLIENT)?;
        let op = params.take_id(param::OP)?;
        Ok(Meta {
            priority,
            fence,
            wait_ms,
            client,
            op,
        })
    }
}

impl Default for Meta {
    fn default() -> Self {
        Meta {
            priority: DEFAULT_PRIORITY,
            fence: None,
            wait_ms: DEFAULT_WAIT_MS,
            client: None,
            op: None,
        }
    }
}

/// A Zenoh QoS priority band, lowest first (the schema names Zenoh's bands
/// without depending on Zenoh).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Band {
    /// Zenoh `Background`.
    Background,
    /// Zenoh `DataLow`.
    DataLow,
    /// Zenoh `Data`, its default.
    Data,
    /// Zenoh `DataHigh`.
    DataHigh,
    /// Zenoh `InteractiveLow`.
    InteractiveLow,
    /// Zenoh `InteractiveHigh`.
    InteractiveHigh,
}

impl Band {
    /// The band a RoME priority travels in (§4.3 on the wire): 224–255
    /// interactive-high, 192–223 interactive-low, 160–191 data-high, 96–159
    /// data (the default 128), 64–95 data-low, 0–63 background. Zenoh's
    /// `RealTime` band is left to Zenoh's own traffic.
    pub fn of(priority: u8) -> Band {
        match priority {
            224..=255 => Band::InteractiveHigh,
            192..=223 => Band::InteractiveLow,
            160..=191 => Band::DataHigh,
            96..=159 => Band::Data,
            64..=95 => Band::DataLow,
            _ => Band::Background,
        }
    }
}

// ---------------------------------------------------------------------------
// Client → base server (RServer, Table 4.1)
// ---------------------------------------------------------------------------

/// `move`: go a distance in a straight line, then stop (point-to-point go).
///
/// ```text
/// {"distance_mm":2000,"velocity_mm_s":300,"accel_mm_s2":-1}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Move {
    /// Distance, mm; negative backwards.
    pub distance_mm: f64,
    /// Velocity, mm/s; negative (the default) keeps the current setting.
    #[serde(default = "keep")]
    pub velocity_mm_s: f64,
    /// Acceleration, mm/s²; negative (the default) keeps the current setting.
    #[serde(default = "keep")]
    pub accel_mm_s2: f64,
}

/// `turn`: turn in place by an angle (point-to-point turn).
///
/// ```text
/// {"degrees":90,"velocity_deg_s":-1,"accel_deg_s2":-1}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Turn {
    /// Angle, degrees; positive clockwise.
    pub degrees: f64,
    /// Turn rate, °/s; negative (the default) keeps the current setting.
    #[serde(default = "keep")]
    pub velocity_deg_s: f64,
    /// Turn acceleration, °/s²; negative (the default) keeps the setting.
    #[serde(default = "keep")]
    pub accel_deg_s2: f64,
}

fn keep() -> f64 {
    -1.0
}

/// `go`: straight on at a velocity (Set GO Mode).
///
/// ```text
/// {"velocity_mm_s":400}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Go {
    /// Velocity, mm/s; negative backwards.
    pub velocity_mm_s: f64,
}

/// `jog`: a turn rate superimposed on forward motion (Set JOG Mode).
///
/// ```text
/// {"rate_deg_s":-4}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Jog {
    /// Turn rate, °/s; positive clockwise.
    pub rate_deg_s: f64,
}

/// `stop`: non-zero (true) is an emergency stop, zero a gradual pause.
///
/// ```text
/// {"emergency":true}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stop {
    /// Stop at once (`emergency_stop()`), not gradually (`pause()`).
    #[serde(default)]
    pub emergency: bool,
}

/// `set-pose`: set the position registers (in virtual 32-bit coordinates).
///
/// ```text
/// {"x_mm":0,"y_mm":0,"heading_deg":90}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetPose {
    /// x, mm.
    pub x_mm: i64,
    /// y, mm.
    pub y_mm: i64,
    /// Heading, degrees (North 0, West 90).
    pub heading_deg: f64,
}

/// `adjust-pose`: add to the position and heading.
///
/// ```text
/// {"dx_mm":-120,"dy_mm":0,"dheading_deg":1.5}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdjustPose {
    /// Change of x, mm.
    #[serde(default)]
    pub dx_mm: i64,
    /// Change of y, mm.
    #[serde(default)]
    pub dy_mm: i64,
    /// Change of heading, degrees.
    #[serde(default)]
    pub dheading_deg: f64,
}

/// `set-bumper`: watch (stop on contact) or ignore the bumpers.
///
/// ```text
/// {"watch":true}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetBumper {
    /// Stop the robot when a bumper touches something.
    pub watch: bool,
}

// ---------------------------------------------------------------------------
// Base server → client
// ---------------------------------------------------------------------------

/// Reply to a motion or setting command: the mode the base is now in.
///
/// ```text
/// {"command":"move","mode":"point_go"}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Done {
    /// The command carried out.
    pub command: String,
    /// The operating mode afterwards.
    pub mode: String,
}

/// `pose`: position in virtual 32-bit coordinates, and the raw registers.
///
/// ```text
/// {"x_mm":40210,"y_mm":-3,"heading_deg":270.0,"raw_x":-25326,"raw_y":-3,"wraps_x":1,"wraps_y":0}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseReply {
    /// x, mm (32-bit virtual).
    pub x_mm: i32,
    /// y, mm (32-bit virtual).
    pub y_mm: i32,
    /// Heading, degrees 0 … 360 (North 0, West 90).
    pub heading_deg: f64,
    /// The device's 16-bit x register.
    pub raw_x: i16,
    /// The device's 16-bit y register.
    pub raw_y: i16,
    /// Net overflows (+) and underflows (−) of x seen so far.
    pub wraps_x: i32,
    /// Net overflows and underflows of y.
    pub wraps_y: i32,
}

/// `bumper`: 0 when free; bit 0 front, bit 1 rear.
///
/// ```text
/// {"status":1,"front":true,"rear":false,"watch":true}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BumperReply {
    /// The thesis' integer: 0 free, non-zero in contact.
    pub status: u8,
    /// The front bumper touches something.
    pub front: bool,
    /// The rear bumper touches something.
    pub rear: bool,
    /// Whether contact stops the robot.
    pub watch: bool,
}

/// `speed`: the last straight-line velocity setting.
///
/// ```text
/// {"speed_mm_s":300}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedReply {
    /// Velocity setting, mm/s.
    pub speed_mm_s: f64,
}

/// `wheel-speed`: the mean magnitude of the two wheels' velocities.
///
/// ```text
/// {"wheel_speed_mm_s":287.5}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelSpeedReply {
    /// mm/s.
    pub wheel_speed_mm_s: f64,
}

/// `mode`: the operating mode (§4.6.3's seven, plus `stopping`).
///
/// ```text
/// {"mode":"jog"}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModeReply {
    /// `joystick`, `go`, `proportional_go`, `continuous_turn`, `point_go`,
    /// `point_turn`, `jog`, `stopping`.
    pub mode: String,
}

/// `lock`: the grant; every later command of the holder carries `fence`.
///
/// ```text
/// {"holder":"6f1c2d-3","fence":1732280000001,"ttl_ms":2500}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LockGrant {
    /// The owner id the lock was granted to (`anonymous` without one).
    pub holder: String,
    /// The fencing number of this grant.
    pub fence: u64,
    /// The grant lapses this long after the holder's last command or renewal.
    pub ttl_ms: u64,
}

/// `unlock`: the lock is free again.
///
/// ```text
/// {"released":true,"fence":1732280000001}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Unlocked {
    /// Always true: a failed unlock is an error reply.
    pub released: bool,
    /// The fence of the grant that ended.
    pub fence: u64,
}

/// `stats` (every hardware server): what the server has carried out, so
/// a repeat carried out twice shows. Answered at once, never queued.
///
/// ```text
/// {"executed":1200,"with_id":310,"answered_from_memory":4,"ids_executed_twice":0}
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommandStats {
    /// Device commands carried out (locks not counted).
    pub executed: u64,
    /// Of those, the ones that carried a request id (`op=`).
    pub with_id: u64,
    /// Repeats of a request id answered from memory without acting.
    pub answered_from_memory: u64,
    /// Request ids carried out more than once (kept for the last
    /// 65 536 ids): 0 unless a repeat was acted on.
    pub ids_executed_twice: u64,
}

/// Who holds a device's lock (in the state stream and the storage).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LockInfo {
    /// The owner id.
    pub holder: String,
    /// The grant's fencing number.
    pub fence: u64,
}

/// A device's lock state as kept in the storage
/// (`<root>/store/robot/<robot>/<device>/lock`).
///
/// ```text
/// {"holder":{"holder":"6f1c2d-3","fence":17},"last_fence":17,"ttl_ms":2500}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LockRecord {
    /// The current holder, if any.
    pub holder: Option<LockInfo>,
    /// The last fence granted: a restarted server grants above it.
    pub last_fence: u64,
    /// The holder's grant life, ms.
    pub ttl_ms: u64,
}

/// `state`: published by the base server at a fixed rate.
///
/// ```text
/// {"robot":"r1","time_ms":120400,"x_mm":1200,"y_mm":-40,"heading_deg":90.0,
///  "speed_mm_s":300,"wheel_speed_mm_s":298.2,"mode":"go","bumpers":0,
///  "watch_bumpers":true,"lock":null,"queued":0}
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseState {
    /// The robot.
    pub robot: String,
    /// The device's clock, ms (simulated time for a simulated robot).
    pub time_ms: u64,
    /// x, mm (32-bit virtual).
    pub x_mm: i32,
    /// y, mm (32-bit virtual).
    pub y_mm: i32,
    /// Heading, degrees.
    pub heading_deg: f64,
    /// Velocity setting, mm/s.
    pub speed_mm_s: f64,
    /// Mean wheel speed, mm/s.
    pub wheel_speed_mm_s: f64,
    /// Operating mode.
    pub mode: String,
    /// Bumper status (0 free; bit 0 front, bit 1 rear).
    pub bumpers: u8,
    /// Whether the bumpers are watched.
    pub watch_bumpers: bool,
    /// The lock holder, if any.
    pub lock: Option<LockInfo>,
    /// Requests waiting in the server's queue (behind the lock).
    pub queued: usize,
}

// ---------------------------------------------------------------------------
// Proximity server (PServer, §4.6.2)
// ---------------------------------------------------------------------------

/// `sonar`: the 24 ranges, mm (sonar 12 looks forward, 6 right, 18 left).
///
/// ```text
/// {"sonar_mm":[10000,2620,…],"time_ms":120400}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SonarReply {
    /// 24 ranges, mm; the sensor's maximum when nothing echoed.
    #[serde(deserialize_with = "exactly_sonars")]
    pub sonar_mm: Vec<u32>,
    /// When the ring fired, device ms.
    pub time_ms: u64,
}

/// `ir`: 24 detector slots (8 fitted), 1 = something within range.
///
/// ```text
/// {"ir":[0,0,1,0,…],"time_ms":120400}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IrReply {
    /// 24 values, 0 or 1.
    #[serde(deserialize_with = "exactly_sonars")]
    pub ir: Vec<u8>,
    /// When the detectors were read, device ms.
    pub time_ms: u64,
}

/// `timeout`: per-sensor maximum range, mm (one number sets all 24).
///
/// ```text
/// {"max_mm":5000}        or        {"max_mm":[5000,5000,…]}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetTimeout {
    /// One range for all sensors, or 24.
    pub max_mm: MaxRange,
}

/// One maximum range for every sonar, or one each.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum MaxRange {
    /// The same for all 24.
    All(u32),
    /// One per sonar.
    Each(Vec<u32>),
}

/// Reply to `timeout`: the ranges now in force.
///
/// ```text
/// {"max_mm":[5000,5000,…]}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeoutReply {
    /// 24 maximum ranges, mm.
    #[serde(deserialize_with = "exactly_sonars")]
    pub max_mm: Vec<u32>,
}

/// `scan`: published by the proximity server for each new scan.
///
/// ```text
/// {"robot":"r1","seq":312,"time_ms":31200,"sonar_mm":[…24],"ir":[…24]}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scan {
    /// The robot.
    pub robot: String,
    /// Scans published so far by this server (a gap means a lost scan).
    pub seq: u64,
    /// When the ring fired, device ms.
    pub time_ms: u64,
    /// 24 ranges, mm.
    #[serde(deserialize_with = "exactly_sonars")]
    pub sonar_mm: Vec<u32>,
    /// 24 infrared values, 0 or 1.
    #[serde(deserialize_with = "exactly_sonars")]
    pub ir: Vec<u8>,
}

// ---------------------------------------------------------------------------
// Camera server (CServer, §4.6.4)
// ---------------------------------------------------------------------------

/// `size`: the image size.
///
/// ```text
/// {"width":512,"height":482}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SizeReply {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

/// `frame`: published after each periodic grab.
///
/// ```text
/// {"robot":"r1","camera":"up","frame":31,"time_ms":15500,"width":512,"height":482}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameInfo {
    /// The robot.
    pub robot: String,
    /// The camera.
    pub camera: String,
    /// Grabs so far.
    pub frame: u64,
    /// When it was grabbed, device ms.
    pub time_ms: u64,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

/// The encoding schema of a binary image reply (`grab`, `rows`):
/// 8-bit gray, row-major, one byte per pixel.
///
/// ```text
/// application/octet-stream;gray8 width=512 height=482 frame=31 time_ms=15500 rows=120,241,360
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Gray8 {
    /// Columns.
    pub width: u32,
    /// Rows in the image (not in the payload).
    pub height: u32,
    /// The grab this came from.
    pub frame: u64,
    /// When it was grabbed, device ms.
    pub time_ms: u64,
    /// The rows sent, in order (all rows for `grab`).
    pub rows: Option<Vec<u32>>,
}

impl Gray8 {
    /// The schema text carried after `application/octet-stream;`.
    pub fn schema(&self) -> String {
        let mut s = format!(
            "gray8 width={} height={} frame={} time_ms={}",
            self.width, self.height, self.frame, self.time_ms
        );
        if let Some(rows) = &self.rows {
            s.push_str(&format!(" rows={}", format_rows(rows)));
        }
        s
    }

    /// Parses [`Gray8::schema`]'s text.
    pub fn parse(schema: &str) -> Result<Gray8, ErrorReply> {
        let bad = |why: &str| {
            ErrorReply::new(
                ErrorCode::BadParameter,
                format!("image schema '{schema}': {why}"),
            )
        };
        let mut words = schema.split_whitespace();
        if words.next() != Some("gray8") {
            return Err(bad("not gray8"));
        }
        let mut g = Gray8 {
            width: 0,
            height: 0,
            frame: 0,
            time_ms: 0,
            rows: None,
        };
        for word in words {
            let (k, v) = word
                .split_once('=')
                .ok_or_else(|| bad("a word without '='"))?;
            let num = |v: &str| v.parse::<u64>().map_err(|_| bad("a field is not a number"));
            let side = |v: &str| {
                num(v)?
                    .try_into()
                    .ok()
                    .filter(|n| (1..=MAX_IMAGE_SIDE).contains(n))
                    .ok_or_else(|| bad(&format!("width and height must be 1 … {MAX_IMAGE_SIDE}")))
            };
            match k {
                "width" => g.width = side(v)?,
                "height" => g.height = side(v)?,
                "frame" => g.frame = num(v)?,
                "time_ms" => g.time_ms = num(v)?,
                "rows" => g.rows = Some(parse_rows(v, MAX_ROWS).map_err(|e| bad(&e.message))?),
                _ => {}
            }
        }
        if g.width == 0 || g.height == 0 {
            return Err(bad("it needs a width and a height"));
        }
        if let Some(r) = g.rows.iter().flatten().find(|r| **r >= g.height) {
            return Err(bad(&format!(
                "row {r} is outside the image's {} rows",
                g.height
            )));
        }
        Ok(g)
    }
}

/// The most rows one `rows` request may ask for, and one reply may carry.
pub const MAX_ROWS: usize = 64;

/// The widest and tallest image a camera reply may describe, pixels: far
/// above any camera's, low enough that a reply's size cannot be absurd.
pub const MAX_IMAGE_SIDE: u32 = 8_192;

/// The longest schema Zenoh carries in an encoding, bytes.
pub const MAX_SCHEMA_LEN: usize = 255;

/// A row list as text, runs of consecutive rows as ranges
/// (`120,200-263,360`), so the list fits in an encoding's schema.
pub fn format_rows(rows: &[u32]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < rows.len() {
        let mut j = i;
        while j + 1 < rows.len() && rows[j + 1] == rows[j].wrapping_add(1) {
            j += 1;
        }
        if j > i + 1 {
            parts.push(format!("{}-{}", rows[i], rows[j]));
        } else {
            parts.extend(rows[i..=j].iter().map(u32::to_string));
        }
        i = j + 1;
    }
    parts.join(",")
}

/// Parses a row list: row numbers and ranges separated by ','
/// (`120,241,360`, `200-263`), refusing a list of more than `max` rows
/// before expanding it, whoever wrote it.
pub fn parse_rows(text: &str, max: usize) -> Result<Vec<u32>, ErrorReply> {
    let bad = || {
        ErrorReply::new(
            ErrorCode::WrongType,
            format!(
                "parameter 'rows' must be row numbers or ranges (200-263) separated by ',', got '{text}'"
            ),
        )
    };
    let too_many = || {
        ErrorReply::new(
            ErrorCode::OutOfRange,
            format!("parameter 'rows' asks for more than {max} rows"),
        )
    };
    let mut out = Vec::new();
    for part in text.split(',') {
        let part = part.trim();
        match part.split_once('-') {
            Some((a, b)) => {
                let a: u32 = a.trim().parse().map_err(|_| bad())?;
                let b: u32 = b.trim().parse().map_err(|_| bad())?;
                if b < a {
                    return Err(bad());
                }
                if (b - a) as usize >= max.saturating_sub(out.len()) {
                    return Err(too_many());
                }
                out.extend(a..=b);
            }
            None => {
                if out.len() >= max {
                    return Err(too_many());
                }
                out.push(part.parse().map_err(|_| bad())?)
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robot_keys_round_trip() {
        let root = Root::default();
        let r1 = robot_name("r1").unwrap();
        for device in [
            Device::Base,
            Device::Proximity,
            Device::Camera(Name::new("up").unwrap()),
        ] {
            let key = root.robot(&r1, &device, "lock");
            let parsed = root.parse_robot(&key).unwrap();
            assert_eq!(parsed.robot, r1);
            assert_eq!(parsed.device, device);
            assert_eq!(parsed.command, "lock");
        }
        assert!(root.parse_robot("rome/robot/r1/arm/x").is_err());
        assert!(root.parse_robot("other/robot/r1/base/pose").is_err());
        assert!(robot_name("a/b").is_err());
    }

    #[test]
    fn meta_takes_defaults_and_refuses_out_of_range() {
        let mut p = Params::parse("");
        assert_eq!(Meta::take(&mut p).unwrap(), Meta::default());
        let mut p = Params::parse("priority=200;fence=7;wait_ms=50");
        let m = Meta::take(&mut p).unwrap();
        assert_eq!((m.priority, m.fence, m.wait_ms), (200, Some(7), 50));
        let err = Meta::take(&mut Params::parse("priority=300")).unwrap_err();
        assert_eq!(err.code, ErrorCode::OutOfRange);
        assert!(err.message.contains("priority"), "{}", err.message);
    }

    #[test]
    fn gray8_schema_round_trips() {
        let g = Gray8 {
            width: 512,
            height: 482,
            frame: 3,
            time_ms: 1500,
            rows: Some(vec![120, 241, 360]),
        };
        assert_eq!(Gray8::parse(&g.schema()).unwrap(), g);
        assert!(Gray8::parse("rgb8 width=1").is_err());
    }

    #[test]
    fn bands_cover_every_priority_in_order() {
        assert_eq!(Band::of(0), Band::Background);
        assert_eq!(Band::of(DEFAULT_PRIORITY), Band::Data);
        assert_eq!(Band::of(255), Band::InteractiveHigh);
        for p in 0..255u8 {
            assert!(Band::of(p) <= Band::of(p + 1), "band order breaks at {p}");
        }
        let mut all: Vec<Band> = (0..=255u8).map(Band::of).collect();
        all.dedup();
        assert_eq!(all.len(), 6, "every band is used");
    }

    #[test]
    fn row_lists_use_ranges_and_fit_a_schema() {
        let rows: Vec<u32> = (181..301).collect();
        assert_eq!(format_rows(&rows), "181-300");
        assert_eq!(parse_rows("181-300", 200).unwrap(), rows);
        assert_eq!(format_rows(&[120, 241, 242, 360]), "120,241,242,360");
        assert_eq!(
            parse_rows("120, 200-202,5", 10).unwrap(),
            vec![120, 200, 201, 202, 5]
        );
        assert!(parse_rows("9-3", 10).is_err());
        assert!(parse_rows("a-3", 10).is_err());
        let g = Gray8 {
            width: 512,
            height: 482,
            frame: 123_456,
            time_ms: 99_999_999,
            rows: Some((200..264).collect()),
        };
        assert!(g.schema().len() <= MAX_SCHEMA_LEN);
        assert_eq!(Gray8::parse(&g.schema()).unwrap(), g);
    }

    #[test]
    fn hostile_image_schemas_are_refused_before_anything_is_allocated() {
        // 2^32 + 1 once read as a width of 1.
        let e = Gray8::parse("gray8 width=4294967297 height=2").unwrap_err();
        assert!(e.message.contains("width and height"), "{}", e.message);
        assert!(Gray8::parse("gray8 width=9000 height=2").is_err());
        assert!(Gray8::parse("gray8 width=0 height=4000000000").is_err());
        assert!(Gray8::parse("gray8 frame=1").is_err(), "no size");
        let e = Gray8::parse("gray8 width=8 height=10 rows=3,10").unwrap_err();
        assert!(e.message.contains("row 10"), "{}", e.message);
        // Many ranges, each short enough alone, once expanded to 150 000
        // rows inside the device task.
        let many = vec!["0-4095"; 40].join(",");
        let e = parse_rows(&many, MAX_ROWS).unwrap_err();
        assert_eq!(e.code, ErrorCode::OutOfRange);
        assert!(parse_rows("0-4294967295", MAX_ROWS).is_err());
        let singles = vec!["1"; MAX_ROWS + 1].join(",");
        assert!(parse_rows(&singles, MAX_ROWS).is_err());
        assert_eq!(parse_rows("0-63", MAX_ROWS).unwrap().len(), MAX_ROWS);
        assert!(parse_rows("0-64", MAX_ROWS).is_err());
    }
}
