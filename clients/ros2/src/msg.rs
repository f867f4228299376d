//! The ROS 2 messages the bridge speaks, laid out field for field as their
//! interface definitions (`builtin_interfaces`, `std_msgs`,
//! `geometry_msgs`, `nav_msgs`, `sensor_msgs` of ROS 2 Jazzy), and their
//! wire form: CDR, little-endian, after the 4-byte encapsulation header
//! that every ROS 2 payload starts with (`00 01 00 00`).
//!
//! CDR aligns each primitive to its own size, counted from the first byte
//! after the header; a string is its length (with the closing NUL) as a
//! `uint32`, its bytes and the NUL; a sequence is its length and its
//! elements; a fixed array is its elements alone. `cdr-encoding` does the
//! aligning; [`encode`] and [`decode`] add and check the header.

use serde::de::{DeserializeOwned, SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// The encapsulation header of little-endian plain CDR (CDR_LE).
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];
/// The encapsulation header of big-endian plain CDR (CDR_BE).
pub const CDR_BE: [u8; 4] = [0x00, 0x00, 0x00, 0x00];

/// A message that could not be read.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    /// Shorter than the encapsulation header.
    #[error("a CDR payload of {0} bytes is shorter than its 4-byte header")]
    Short(usize),
    /// An encapsulation the bridge does not read (only plain CDR is).
    #[error("the payload's encapsulation {0:02x?} is not plain CDR (00 00 or 00 01)")]
    Encapsulation([u8; 2]),
    /// The body does not hold the message.
    #[error("the payload is not a {what}: {why}")]
    Body {
        /// The message type expected.
        what: &'static str,
        /// What the decoder said.
        why: String,
    },
}

/// A ROS 2 message type: its name as ROS 2 spells it.
pub trait Message: Serialize + DeserializeOwned {
    /// `package/msg/Name`.
    const TYPE: &'static str;
}

/// The payload of `message`: the CDR_LE header and the body.
pub fn encode<M: Message>(message: &M) -> Vec<u8> {
    let mut out = CDR_LE.to_vec();
    // Writing into memory fails only for a type serde cannot express in
    // CDR, which none of these is.
    match cdr_encoding::to_vec::<M, byteorder::LittleEndian>(message) {
        Ok(body) => out.extend_from_slice(&body),
        Err(e) => tracing::error!(r#type = M::TYPE, error = %e, "cannot encode"),
    }
    out
}

/// A message from a payload in either byte order.
pub fn decode<M: Message>(payload: &[u8]) -> Result<M, DecodeError> {
    let (head, body) = payload
        .split_at_checked(4)
        .ok_or(DecodeError::Short(payload.len()))?;
    let read = match [head[0], head[1]] {
        [0, 1] => cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(body),
        [0, 0] => cdr_encoding::from_bytes::<M, byteorder::BigEndian>(body),
        other => return Err(DecodeError::Encapsulation(other)),
    };
    read.map(|(m, _)| m).map_err(|e| DecodeError::Body {
        what: M::TYPE,
        why: e.to_string(),
    })
}

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// A time of `ms` milliseconds.
    pub fn from_ms(ms: u64) -> Time {
        Time {
            sec: i32::try_from(ms / 1_000).unwrap_or(i32::MAX),
            nanosec: (ms % 1_000) as u32 * 1_000_000,
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Header {
    /// When.
    pub stamp: Time,
    /// The frame the data is in.
    pub frame_id: String,
}

/// `geometry_msgs/msg/Point`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// x, m.
    pub x: f64,
    /// y, m.
    pub y: f64,
    /// z, m.
    pub z: f64,
}

/// `geometry_msgs/msg/Vector3`.
pub type Vector3 = Point;

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Quaternion {
    /// A turn of `yaw` radians about z (counter-clockwise seen from above).
    pub fn yaw(yaw: f64) -> Quaternion {
        let half = yaw / 2.0;
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: half.sin(),
            w: half.cos(),
        }
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Where.
    pub position: Point,
    /// Which way.
    pub orientation: Quaternion,
}

/// A row-major 6 × 6 covariance (`float64[36]`): a fixed array, so its
/// elements alone, with no length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Covariance(pub [f64; 36]);

impl Default for Covariance {
    fn default() -> Self {
        Covariance([0.0; 36])
    }
}

impl Serialize for Covariance {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(36)?;
        for v in &self.0 {
            t.serialize_element(v)?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for Covariance {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Each;
        impl<'de> Visitor<'de> for Each {
            type Value = Covariance;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("36 float64")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Covariance, A::Error> {
                let mut c = [0.0; 36];
                for (i, v) in c.iter_mut().enumerate() {
                    *v = seq
                        .next_element()?
                        .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                Ok(Covariance(c))
            }
        }
        d.deserialize_tuple(36, Each)
    }
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Its uncertainty.
    pub covariance: Covariance,
}

/// `geometry_msgs/msg/Twist`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    /// m/s.
    pub linear: Vector3,
    /// rad/s.
    pub angular: Vector3,
}

impl Message for Twist {
    const TYPE: &'static str = "geometry_msgs/msg/Twist";
}

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// The twist.
    pub twist: Twist,
    /// Its uncertainty.
    pub covariance: Covariance,
}

/// `nav_msgs/msg/Odometry`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    /// Stamp and the pose's frame.
    pub header: Header,
    /// The twist's frame (the robot's body).
    pub child_frame_id: String,
    /// Where the robot is.
    pub pose: PoseWithCovariance,
    /// How it moves.
    pub twist: TwistWithCovariance,
}

impl Message for Odometry {
    const TYPE: &'static str = "nav_msgs/msg/Odometry";
}

/// `sensor_msgs/msg/LaserScan`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LaserScan {
    /// Stamp and the sensor's frame.
    pub header: Header,
    /// First beam's angle, rad.
    pub angle_min: f32,
    /// Last beam's angle, rad.
    pub angle_max: f32,
    /// Between beams, rad.
    pub angle_increment: f32,
    /// Between beams' measurements, s.
    pub time_increment: f32,
    /// Between scans, s.
    pub scan_time: f32,
    /// Shortest range, m.
    pub range_min: f32,
    /// Longest range, m.
    pub range_max: f32,
    /// Each beam's range, m (+inf: no echo).
    pub ranges: Vec<f32>,
    /// Each beam's intensity (empty: none).
    pub intensities: Vec<f32>,
}

impl Message for LaserScan {
    const TYPE: &'static str = "sensor_msgs/msg/LaserScan";
}

/// `sensor_msgs/msg/Image`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Image {
    /// Stamp and the camera's frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding (`mono8`).
    pub encoding: String,
    /// Whether multi-byte pixels are big-endian.
    pub is_bigendian: u8,
    /// Bytes a row.
    pub step: u32,
    /// The pixels, row by row.
    pub data: Vec<u8>,
}

impl Message for Image {
    const TYPE: &'static str = "sensor_msgs/msg/Image";
}

/// `nav_msgs/msg/MapMetaData`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapMetaData {
    /// When the map was loaded.
    pub map_load_time: Time,
    /// Metres a cell.
    pub resolution: f32,
    /// Cells a row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Where cell (0, 0)'s corner lies in the map's frame.
    pub origin: Pose,
}

/// `nav_msgs/msg/OccupancyGrid`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    /// Stamp and the map's frame.
    pub header: Header,
    /// Its size and place.
    pub info: MapMetaData,
    /// Row by row from the origin: 0 free, 100 occupied, −1 unknown.
    pub data: Vec<i8>,
}

impl Message for OccupancyGrid {
    const TYPE: &'static str = "nav_msgs/msg/OccupancyGrid";
}

#[cfg(test)]
mod tests;
