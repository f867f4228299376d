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
//! Every command is a query. Its payload, when it has one, is a JSON object;
//! its selector parameters are the ones every hardware server shares
//! ([`param`]).
//!
//! How this module is laid out: this file holds the keys, the shared
//! parameters and priorities; the messages are grouped by device, each in
//! its own file and re-exported here: [`base`], [`proximity`], [`camera`],
//! and [`lock`] for the lock token the base and cameras share; [`body`]
//! has the robot's physical figures. [`command`] defines every command
//! once, with its key chunk, payload and reply, for both ends.

use crate::{keys::Name, ErrorReply, KeyError, Params, Root};
use serde::Deserialize;

pub mod base;
pub mod body;
pub mod camera;
pub mod command;
pub mod lock;
pub mod proximity;

pub use base::*;
pub use camera::*;
pub use lock::*;
pub use proximity::*;

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
    /// A command that acts: once it is carried out, the device refuses
    /// commands that act from lower priorities for this many ms (a
    /// suppressor's time constant, §3.2.1; colony-style modules, §4.8.2).
    pub const SUPPRESS_MS: &str = "suppress_ms";
}

/// The requests that only read, on any hardware server: the commands
/// whose answer changes nothing, `stats`, and a stream's key (its last
/// publication). In a run split into processes a server answers these
/// within their round and holds anything else until its round is over,
/// so a client waits for the one busy and for the other idle.
pub const READS: &[&str] = &[
    "pose",
    "speed",
    "wheel-speed",
    "mode",
    "bumper",
    "sonar",
    "ir",
    "size",
    "rows",
    "stats",
    "state",
    "scan",
    "frame",
];

/// Whether a request on `key` only reads ([`READS`]): its last chunk is
/// one of them, or the key has wildcards (a sweep of every read).
pub fn only_reads(key: &str) -> bool {
    key.contains(['*', '$']) || READS.contains(&key.rsplit('/').next().unwrap_or_default())
}

/// A request's priority when it names none (Zenoh's default `Data` band).
pub const DEFAULT_PRIORITY: u8 = 128;
/// How long a request may wait in a queue when it says nothing, ms.
pub const DEFAULT_WAIT_MS: u64 = 10_000;
/// The longest a request may ask to wait in a queue, ms.
pub const MAX_WAIT_MS: u64 = 600_000;
/// The longest suppression a command may ask for, ms.
pub const MAX_SUPPRESS_MS: u64 = 60_000;
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
    /// How long lower priorities are suppressed once it is carried out, ms
    /// (`suppress_ms`).
    pub suppress_ms: Option<u64>,
}

impl Meta {
    /// Takes `priority`, `fence`, `wait_ms`, `client`, `op` and
    /// `suppress_ms` from the parameters.
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
        let suppress_ms = params
            .take_int(param::SUPPRESS_MS, 0, i128::from(MAX_SUPPRESS_MS))?
            .map(|s| s as u64);
        Ok(Meta {
            priority,
            fence,
            wait_ms,
            client,
            op,
            suppress_ms,
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
            suppress_ms: None,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ErrorCode;

    #[test]
    fn only_what_changes_nothing_is_a_read() {
        for key in [
            "rome/robot/r1/base/pose",
            "rome/robot/r1/proximity/sonar",
            "rome/robot/r1/camera/up/rows",
            "rome/robot/r1/base/stats",
            "rome/robot/r1/base/state",
            "rome/robot/*/base/pose",
        ] {
            assert!(only_reads(key), "{key} only reads");
        }
        for key in [
            "rome/robot/r1/base/go",
            "rome/robot/r1/base/set-pose",
            "rome/robot/r1/base/lock",
            "rome/robot/r1/base/unlock",
            "rome/robot/r1/proximity/timeout",
            "rome/robot/r1/camera/up/grab",
            "rome/robot/r1/base/no-such-command",
        ] {
            assert!(!only_reads(key), "{key} may change something");
        }
    }

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
