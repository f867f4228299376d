//! The robot as built (RoME, §2.4–2.5, §5.4.1, §5.6, Table 5.3): its
//! sensors, size and limits, which the hardware servers, the simulator and
//! the navigation clients all go by.
//!
//! Sources for the figures: 24 sonars with a 10 m range and 8 infrared
//! proximity sensors of about 76 cm (§2.4); sonars 15° apart with sonar 12
//! forward and 6, 18 sideways (Figure 5.9, §5.4.1); the upward camera of
//! Table 5.3, seeing about 1.2 × 1.5 m of a ceiling 1.35 m above it, lights
//! 0.6 × 1.2 m (§5.6); door plates at about 53 inches (§5.7). The base's size
//! and limits are those of a TRC LABMATE of the time: about 0.76 m square, up
//! to about 1 m/s.

pub use super::SONARS;

/// Angle between neighbouring sonars, degrees.
pub const SONAR_SPACING_DEG: f64 = 15.0;
/// The sonar pointing forward.
pub const SONAR_FORWARD: usize = 12;
/// Sonar range, mm.
pub const SONAR_MAX_MM: f64 = 10_000.0;
/// Closest range a sonar reports, mm (its ring-down time).
pub const SONAR_MIN_MM: f64 = 150.0;
/// Half the sonar's beam width, degrees (a beam of about 15°).
pub const SONAR_HALF_BEAM_DEG: f64 = 7.5;
/// Largest angle between the beam and a flat surface's normal that still
/// returns an echo; beyond it the sound glances off (grazing incidence).
pub const SONAR_MAX_INCIDENCE_DEG: f64 = 20.0;
/// Number of infrared proximity sensors (their bits in a 24-bit word).
pub const IR_SENSORS: usize = 8;
/// Infrared detection distance, mm.
pub const IR_RANGE_MM: f64 = 760.0;
/// Robot radius, mm: the body is treated as a disc.
pub const ROBOT_RADIUS_MM: f64 = 380.0;
/// Distance between the drive wheels, mm.
pub const WHEEL_BASE_MM: f64 = 560.0;
/// Fastest straight-line speed, mm/s.
pub const MAX_SPEED_MM_S: f64 = 1_000.0;
/// Fastest turn, degrees per second.
pub const MAX_TURN_DEG_S: f64 = 90.0;
/// Height of the ceiling above the upward camera, mm (Table 5.3).
pub const CEILING_ABOVE_CAMERA_MM: f64 = 1_350.0;
/// Ceiling area one upward image covers: across × along the robot, mm (§5.6).
pub const UP_VIEW_MM: (f64, f64) = (1_500.0, 1_200.0);
/// A ceiling light: along its wall × out from it, mm (§5.6).
pub const LIGHT_SIZE_MM: (f64, f64) = (600.0, 1_200.0);
/// Height of the sideways camera and of the door plates' centres, mm
/// (53 inches; the camera is set so the plates are in the middle rows, §5.7).
pub const PLATE_HEIGHT_MM: f64 = 1_346.0;
/// A door plate's size: width × height, mm.
pub const PLATE_SIZE_MM: (f64, f64) = (200.0, 150.0);
/// Horizontal field of view of the sideways camera, degrees.
pub const SIDE_FOV_DEG: f64 = 50.0;
/// Image size of both cameras (Table 5.3: 512 × 482).
pub const IMAGE_SIZE: (u32, u32) = (512, 482);

/// Bearing of sonar `i` from the robot's forward direction, degrees
/// counter-clockwise: sonar 12 ahead, 18 to the left, 6 to the right, 0 behind.
pub fn sonar_bearing_deg(i: usize) -> f64 {
    (i as f64 - SONAR_FORWARD as f64) * SONAR_SPACING_DEG
}

/// Bearing of infrared sensor `i`, degrees counter-clockwise from forward:
/// four looking ahead and to the front corners, two sideways, two to the
/// rear corners.
pub fn ir_bearing_deg(i: usize) -> f64 {
    [-45.0, -15.0, 15.0, 45.0, 90.0, 150.0, -150.0, -90.0][i % IR_SENSORS]
}
