//! Messages of the base server (RServer, Table 4.1): the commands a client
//! sends, and the replies and state the server sends back.

use super::LockInfo;
use serde::{Deserialize, Serialize};

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

/// `state`: published by the base server at a fixed rate.
///
/// ```text
/// {"robot":"r1","time_ms":120400,"x_mm":1200,"y_mm":-40,"heading_deg":90.0,
///  "speed_mm_s":300,"wheel_speed_mm_s":298.2,"mode":"go","bumpers":0,
///  "watch_bumpers":true,"lock":null,"queued":0}
/// ```
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
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
