//! The wire form of `rmw_zenoh`, ROS 2's own Zenoh middleware (Jazzy and
//! later): what a ROS 2 node running `RMW_IMPLEMENTATION=rmw_zenoh_cpp`
//! puts on Zenoh, so the bridge can speak it with no DDS at all.
//!
//! From ros2/rmw_zenoh's `docs/design.md` and its liveliness code:
//!
//! ```text
//! data      <domain>/<topic>/<type>/<hash>
//!           0/r1/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_3cc97dc7…
//! node      @ros2_lv/<domain>/<zid>/<nid>/<nid>/NN/<enclave>/<namespace>/<node>
//! publisher @ros2_lv/<domain>/<zid>/<nid>/<eid>/MP/<enclave>/<namespace>/<node>/<topic>/<type>/<hash>/<qos>
//! reader    … the same with MS
//! ```
//!
//! - `<topic>` in a data key is the topic's name without its leading and
//!   trailing slashes; in a liveliness token every `/` of a name becomes
//!   `%` (the root namespace `/` is `%`, `/r1/odom` is `%r1%odom`).
//! - `<type>` is the DDS name of the type: `nav_msgs/msg/Odometry` is
//!   `nav_msgs::msg::dds_::Odometry_`.
//! - `<hash>` is the type's REP-2011 hash, `RIHS01_` and the SHA-256 of
//!   the type description's canonical JSON ([`type_hash`]).
//! - `<zid>` is the session's Zenoh id as Zenoh writes it (hex, no leading
//!   zeros); `<nid>` and `<eid>` number the node and the entity within the
//!   session.
//! - `<qos>` is `reliability:durability:history,depth:deadline:lifespan:liveliness`,
//!   each value `rmw_qos_profile_t`'s number; an empty place is
//!   rmw_zenoh's default ([`Qos::to_key`]).
//! - Each sample carries an attachment: the sequence number and the source
//!   time in ns (`i64` little-endian each), then the publisher's 16-byte
//!   GID as a sequence (its length, 16, as LEB128, then the bytes), as
//!   `zenoh-ext` serializes them ([`attachment`]). This is the form since
//!   rmw_zenoh 0.2.4 (Jazzy, April 2025); before, each field's name came
//!   before it.
//!
//! The message's payload is the same CDR as on DDS ([`crate::msg`]).

use crate::msg::Message;

/// The liveliness tokens' first chunk.
pub const ADMIN_SPACE: &str = "@ros2_lv";

/// What stands for `/` in a liveliness token's names.
pub const SLASH: char = '%';

/// The DDS name of a ROS 2 type: `pkg/msg/Name` is `pkg::msg::dds_::Name_`.
/// `None` for a name not of that form.
pub fn dds_type_name(ros_type: &str) -> Option<String> {
    let mut parts = ros_type.split('/');
    match (parts.next(), parts.next(), parts.next(), parts.next()) {
        (Some(pkg), Some(kind), Some(name), None)
            if [pkg, kind, name].iter().all(|p| !p.is_empty()) =>
        {
            Some(format!("{pkg}::{kind}::dds_::{name}_"))
        }
        _ => None,
    }
}

/// A name in a liveliness token: each `/` as `%`.
pub fn mangle(name: &str) -> String {
    name.replace('/', &SLASH.to_string())
}

/// The data key of `topic` carrying `M` in `domain`.
pub fn topic_key<M: Message>(domain: u32, topic: &str) -> String {
    format!(
        "{domain}/{}/{}/{}",
        topic.trim_matches('/'),
        dds_type_name(M::TYPE).unwrap_or_default(),
        type_hash(M::TYPE).unwrap_or_default()
    )
}

/// A Zenoh id as rmw_zenoh writes it (zenoh-cpp's `Id::to_string`, the
/// same as Zenoh's own text of an id): the little-endian id as one number,
/// in lower-case hex with no leading zeros.
pub fn zid_text(zid_le: &[u8; 16]) -> String {
    format!("{:x}", u128::from_le_bytes(*zid_le))
}

/// The QoS of a publisher or reader, as much of it as the token says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Reliable (1) or best effort (2).
    pub reliable: bool,
    /// Transient local (1) or volatile (2).
    pub transient_local: bool,
    /// Keep last (1) this many.
    pub depth: u32,
}

impl Qos {
    /// What the bridge publishes with: reliable, volatile, the last 5. A
    /// reliable writer serves reliable and best-effort readers alike (a
    /// best-effort one would serve only the latter: a node subscribing
    /// with ROS 2's default QoS would get nothing).
    pub const STREAM: Qos = Qos {
        reliable: true,
        transient_local: false,
        depth: 5,
    };
    /// What the bridge reads `cmd_vel` with: best effort, volatile, the
    /// last 10. A best-effort reader takes from reliable and best-effort
    /// writers alike (teleop nodes use both).
    pub const COMMAND: Qos = Qos {
        reliable: false,
        transient_local: false,
        depth: 10,
    };
    /// ROS 2's default: reliable, volatile, the last 10.
    pub const DEFAULT: Qos = Qos {
        reliable: true,
        transient_local: false,
        depth: 10,
    };
    /// A map's: reliable, transient local, the last 1 (what Nav2's map
    /// server offers).
    pub const MAP: Qos = Qos {
        reliable: true,
        transient_local: true,
        depth: 1,
    };

    /// The token's QoS chunk. Reliability, durability, history and depth
    /// are written out; deadline, lifespan and liveliness are left empty,
    /// which reads as rmw_zenoh's defaults (infinite, automatic).
    pub fn to_key(&self) -> String {
        let reliability = if self.reliable { 1 } else { 2 };
        let durability = if self.transient_local { 1 } else { 2 };
        format!("{reliability}:{durability}:1,{}:,:,:,,", self.depth)
    }
}

/// What a liveliness token announces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A node (`NN`).
    Node,
    /// A publisher (`MP`).
    Publisher,
    /// A subscription (`MS`).
    Subscription,
}

impl Kind {
    fn chunk(self) -> &'static str {
        match self {
            Kind::Node => "NN",
            Kind::Publisher => "MP",
            Kind::Subscription => "MS",
        }
    }
}

/// A node as the graph sees it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Node {
    /// The ROS domain (`ROS_DOMAIN_ID`).
    pub domain: u32,
    /// The session's Zenoh id, little-endian.
    pub zid_le: [u8; 16],
    /// The node's number within the session.
    pub nid: u32,
    /// Its namespace, `/` for none.
    pub namespace: String,
    /// Its name.
    pub name: String,
}

impl Node {
    /// The node's own token.
    pub fn token(&self) -> String {
        self.prefix(self.nid, Kind::Node)
    }

    /// The token of a publisher or subscription `eid` of this node on
    /// `topic` carrying `M`.
    pub fn entity_token<M: Message>(&self, eid: u32, kind: Kind, topic: &str, qos: Qos) -> String {
        format!(
            "{}/{}/{}/{}/{}",
            self.prefix(eid, kind),
            mangle(&absolute(topic)),
            mangle(&dds_type_name(M::TYPE).unwrap_or_default()),
            type_hash(M::TYPE).unwrap_or_default(),
            qos.to_key()
        )
    }

    fn prefix(&self, id: u32, kind: Kind) -> String {
        format!(
            "{ADMIN_SPACE}/{}/{}/{}/{id}/{}/{}/{}/{}",
            self.domain,
            zid_text(&self.zid_le),
            self.nid,
            kind.chunk(),
            // The enclave: the root one.
            mangle("/"),
            mangle(&absolute(&self.namespace)),
            mangle(&self.name)
        )
    }
}

/// `name` with one leading slash.
fn absolute(name: &str) -> String {
    format!("/{}", name.trim_matches('/'))
}

/// A sample's attachment: `seq` and `time_ns` as `i64` little-endian, then
/// `gid` as a sequence of 16 bytes (its length as LEB128, then the bytes).
pub fn attachment(seq: i64, time_ns: i64, gid: &[u8; 16]) -> Vec<u8> {
    let mut out = Vec::with_capacity(33);
    out.extend_from_slice(&seq.to_le_bytes());
    out.extend_from_slice(&time_ns.to_le_bytes());
    // 16 < 128: one LEB128 byte.
    out.push(16);
    out.extend_from_slice(gid);
    out
}

/// How a field's type is given in a type description
/// (`type_description_interfaces/msg/FieldType`).
pub mod field_type {
    /// Another message.
    pub const NESTED: u8 = 1;
    /// `uint8`.
    pub const UINT8: u8 = 3;
    /// `int32`.
    pub const INT32: u8 = 6;
    /// `uint32`.
    pub const UINT32: u8 = 7;
    /// `float32`.
    pub const FLOAT: u8 = 10;
    /// `float64`.
    pub const DOUBLE: u8 = 11;
    /// `string`.
    pub const STRING: u8 = 17;
    /// Added to a type for a fixed array of it (its capacity the length).
    pub const ARRAY: u8 = 48;
    /// Added to a type for an unbounded sequence of it.
    pub const SEQUENCE: u8 = 144;
}

/// One field: its name, type id, capacity (a fixed array's length) and,
/// for a nested message, that message's type.
type Field = (&'static str, u8, u32, &'static str);

/// The type descriptions of the messages the bridge speaks and those they
/// hold, from the ROS 2 Jazzy interface definitions.
const TYPES: &[(&str, &[Field])] = {
    use field_type::*;
    &[
        (
            "builtin_interfaces/msg/Time",
            &[("sec", INT32, 0, ""), ("nanosec", UINT32, 0, "")],
        ),
        (
            "std_msgs/msg/Header",
            &[
                ("stamp", NESTED, 0, "builtin_interfaces/msg/Time"),
                ("frame_id", STRING, 0, ""),
            ],
        ),
        (
            "geometry_msgs/msg/Vector3",
            &[
                ("x", DOUBLE, 0, ""),
                ("y", DOUBLE, 0, ""),
                ("z", DOUBLE, 0, ""),
            ],
        ),
        (
            "geometry_msgs/msg/Point",
            &[
                ("x", DOUBLE, 0, ""),
                ("y", DOUBLE, 0, ""),
                ("z", DOUBLE, 0, ""),
            ],
        ),
        (
            "geometry_msgs/msg/Quaternion",
            &[
                ("x", DOUBLE, 0, ""),
                ("y", DOUBLE, 0, ""),
                ("z", DOUBLE, 0, ""),
                ("w", DOUBLE, 0, ""),
            ],
        ),
        (
            "geometry_msgs/msg/Pose",
            &[
                ("position", NESTED, 0, "geometry_msgs/msg/Point"),
                ("orientation", NESTED, 0, "geometry_msgs/msg/Quaternion"),
            ],
        ),
        (
            "geometry_msgs/msg/Twist",
            &[
                ("linear", NESTED, 0, "geometry_msgs/msg/Vector3"),
                ("angular", NESTED, 0, "geometry_msgs/msg/Vector3"),
            ],
        ),
        (
            "geometry_msgs/msg/PoseWithCovariance",
            &[
                ("pose", NESTED, 0, "geometry_msgs/msg/Pose"),
                ("covariance", DOUBLE + ARRAY, 36, ""),
            ],
        ),
        (
            "geometry_msgs/msg/TwistWithCovariance",
            &[
                ("twist", NESTED, 0, "geometry_msgs/msg/Twist"),
                ("covariance", DOUBLE + ARRAY, 36, ""),
            ],
        ),
        (
            "nav_msgs/msg/Odometry",
            &[
                ("header", NESTED, 0, "std_msgs/msg/Header"),
                ("child_frame_id", STRING, 0, ""),
                ("pose", NESTED, 0, "geometry_msgs/msg/PoseWithCovariance"),
                ("twist", NESTED, 0, "geometry_msgs/msg/TwistWithCovariance"),
            ],
        ),
        (
            "sensor_msgs/msg/LaserScan",
            &[
                ("header", NESTED, 0, "std_msgs/msg/Header"),
                ("angle_min", FLOAT, 0, ""),
                ("angle_max", FLOAT, 0, ""),
                ("angle_increment", FLOAT, 0, ""),
                ("time_increment", FLOAT, 0, ""),
                ("scan_time", FLOAT, 0, ""),
                ("range_min", FLOAT, 0, ""),
                ("range_max", FLOAT, 0, ""),
                ("ranges", FLOAT + SEQUENCE, 0, ""),
                ("intensities", FLOAT + SEQUENCE, 0, ""),
            ],
        ),
        (
            "sensor_msgs/msg/Image",
            &[
                ("header", NESTED, 0, "std_msgs/msg/Header"),
                ("height", UINT32, 0, ""),
                ("width", UINT32, 0, ""),
                ("encoding", STRING, 0, ""),
                ("is_bigendian", UINT8, 0, ""),
                ("step", UINT32, 0, ""),
                ("data", UINT8 + SEQUENCE, 0, ""),
            ],
        ),
        (
            "nav_msgs/msg/MapMetaData",
            &[
                ("map_load_time", NESTED, 0, "builtin_interfaces/msg/Time"),
                ("resolution", FLOAT, 0, ""),
                ("width", UINT32, 0, ""),
                ("height", UINT32, 0, ""),
                ("origin", NESTED, 0, "geometry_msgs/msg/Pose"),
            ],
        ),
        (
            "nav_msgs/msg/OccupancyGrid",
            &[
                ("header", NESTED, 0, "std_msgs/msg/Header"),
                ("info", NESTED, 0, "nav_msgs/msg/MapMetaData"),
                // int8[]: INT8 is 2.
                ("data", 2 + SEQUENCE, 0, ""),
            ],
        ),
    ]
};

fn fields_of(name: &str) -> Option<&'static [Field]> {
    TYPES.iter().find(|(n, _)| *n == name).map(|(_, f)| *f)
}

/// One type's description in the canonical JSON of REP-2011: keys in this
/// order, `", "` and `": "` between items, no default values.
fn description_json(name: &str, fields: &[Field]) -> String {
    let fields: Vec<String> = fields
        .iter()
        .map(|(field, id, capacity, nested)| {
            format!(
                "{{\"name\": \"{field}\", \"type\": {{\"type_id\": {id}, \"capacity\": {capacity}, \"string_capacity\": 0, \"nested_type_name\": \"{nested}\"}}}}"
            )
        })
        .collect();
    format!(
        "{{\"type_name\": \"{name}\", \"fields\": [{}]}}",
        fields.join(", ")
    )
}

/// The REP-2011 hash of `ros_type` (`RIHS01_` and 64 hex digits): SHA-256
/// of the canonical JSON of its description and of every type it holds,
/// directly or not, those in the order of their names. `None` for a type
/// not described here.
pub fn type_hash(ros_type: &str) -> Option<String> {
    let top = fields_of(ros_type)?;
    let mut held = std::collections::BTreeSet::new();
    let mut todo: Vec<&str> = top.iter().map(|f| f.3).filter(|n| !n.is_empty()).collect();
    while let Some(n) = todo.pop() {
        if held.insert(n) {
            todo.extend(fields_of(n)?.iter().map(|f| f.3).filter(|n| !n.is_empty()));
        }
    }
    let referenced: Option<Vec<String>> = held
        .iter()
        .map(|n| fields_of(n).map(|f| description_json(n, f)))
        .collect();
    let json = format!(
        "{{\"type_description\": {}, \"referenced_type_descriptions\": [{}]}}",
        description_json(ros_type, top),
        referenced?.join(", ")
    );
    let digest = ring::digest::digest(&ring::digest::SHA256, json.as_bytes());
    let hex: String = digest.as_ref().iter().map(|b| format!("{b:02x}")).collect();
    Some(format!("RIHS01_{hex}"))
}

#[cfg(test)]
mod tests;
