//! RoME's readings as ROS 2 messages, and a ROS 2 velocity as a base
//! command.
//!
//! Frames follow REP 103 and REP 105: metres, radians, x East and y North
//! in `odom` and `map` (RoME's own axes), yaw counter-clockwise from East.
//! RoME measures headings from North (West 90°), so yaw = heading + 90°.
//! The body frame `base_link` has x forward and y to the left.

use crate::msg::{
    Covariance, Header, LaserScan, Odometry, Point, Pose, PoseWithCovariance, Quaternion, Time,
    Twist, TwistWithCovariance, Vector3,
};
use rome_schema::robot::body::{
    MAX_SPEED_MM_S, MAX_TURN_DEG_S, SONAR_FORWARD, SONAR_MAX_MM, SONAR_MIN_MM, SONAR_SPACING_DEG,
};
use rome_schema::robot::{BaseState, Scan};
use rome_schema::sim::Truth;

/// Yaw, radians counter-clockwise from East, of a RoME heading.
pub fn yaw_of(heading_deg: f64) -> f64 {
    (heading_deg + 90.0).to_radians()
}

/// `robot`'s frames: `<robot>/odom`, `<robot>/base_link`, `<robot>/sonar`.
pub fn frame(robot: &str, name: &str) -> String {
    format!("{robot}/{name}")
}

/// The base's odometry: where its registers put it, and how fast it
/// drives and turns (the turn from the heading since `before`, the base's
/// previous state).
pub fn odometry(state: &BaseState, before: Option<&BaseState>) -> Odometry {
    let turn = before
        .filter(|b| state.time_ms > b.time_ms)
        .map_or(0.0, |b| {
            // The shorter way round: 359° to 1° is a turn of 2°.
            let d = (state.heading_deg - b.heading_deg + 180.0).rem_euclid(360.0) - 180.0;
            d.to_radians() / ((state.time_ms - b.time_ms) as f64 / 1_000.0)
        });
    Odometry {
        header: Header {
            stamp: Time::from_ms(state.time_ms),
            frame_id: frame(&state.robot, "odom"),
        },
        child_frame_id: frame(&state.robot, "base_link"),
        pose: PoseWithCovariance {
            pose: Pose {
                position: Point {
                    x: f64::from(state.x_mm) / 1_000.0,
                    y: f64::from(state.y_mm) / 1_000.0,
                    z: 0.0,
                },
                orientation: Quaternion::yaw(yaw_of(state.heading_deg)),
            },
            covariance: Covariance::default(),
        },
        twist: TwistWithCovariance {
            twist: Twist {
                linear: Vector3 {
                    x: state.wheel_speed_mm_s / 1_000.0,
                    y: 0.0,
                    z: 0.0,
                },
                angular: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: turn,
                },
            },
            covariance: Covariance::default(),
        },
    }
}

/// Where the simulator truly has the robot, in the `map` frame (the
/// floor's map in a building).
pub fn ground_truth(t: &Truth) -> Odometry {
    Odometry {
        header: Header {
            stamp: Time::from_ms(t.time_ms),
            frame_id: "map".into(),
        },
        child_frame_id: frame(&t.robot, "base_link"),
        pose: PoseWithCovariance {
            pose: Pose {
                position: Point {
                    x: t.x_mm / 1_000.0,
                    y: t.y_mm / 1_000.0,
                    z: 0.0,
                },
                orientation: Quaternion::yaw(yaw_of(t.heading_deg)),
            },
            covariance: Covariance::default(),
        },
        twist: TwistWithCovariance::default(),
    }
}

/// The sonar ring as one scan of 24 beams, 15° apart, counter-clockwise
/// from straight behind: sonar k points (k − 12) × 15° off forward
/// (sonar 12 forward, 18 to the left). A sonar that heard no echo reads
/// +inf (REP 117).
pub fn sonar(scan: &Scan) -> LaserScan {
    let step = SONAR_SPACING_DEG.to_radians() as f32;
    let first = -(SONAR_FORWARD as f64 * SONAR_SPACING_DEG).to_radians() as f32;
    LaserScan {
        header: Header {
            stamp: Time::from_ms(scan.time_ms),
            frame_id: frame(&scan.robot, "sonar"),
        },
        angle_min: first,
        angle_max: first + step * (scan.sonar_mm.len().saturating_sub(1)) as f32,
        angle_increment: step,
        time_increment: 0.0,
        scan_time: 0.0,
        range_min: (SONAR_MIN_MM / 1_000.0) as f32,
        range_max: (SONAR_MAX_MM / 1_000.0) as f32,
        ranges: scan
            .sonar_mm
            .iter()
            .map(|&mm| {
                if f64::from(mm) >= SONAR_MAX_MM {
                    f32::INFINITY
                } else {
                    mm as f32 / 1_000.0
                }
            })
            .collect(),
        intensities: Vec::new(),
    }
}

/// A camera's grab as a `mono8` image (8-bit grey, row by row), in frame
/// `frame`.
pub fn image(grab: &rome_client::robot::Image, frame: String) -> crate::msg::Image {
    crate::msg::Image {
        header: Header {
            stamp: Time::from_ms(grab.time_ms),
            frame_id: frame,
        },
        height: grab.rows.len() as u32,
        width: grab.width,
        encoding: "mono8".into(),
        is_bigendian: 0,
        step: grab.width,
        data: grab.pixels.clone(),
    }
}

/// A floor's map as an occupancy grid of `resolution_m` cells in frame
/// `map`, a metre of margin round the building: a cell a wall, door,
/// window, glass or elevator door crosses is occupied (100), every other
/// cell free (0); an opening is no wall.
pub fn occupancy(world: &rome_maps::World, resolution_m: f64) -> crate::msg::OccupancyGrid {
    let cell = resolution_m * 1_000.0;
    let (lo, hi) = world.bounds();
    let origin = (lo.x - 1_000.0, lo.y - 1_000.0);
    let width = ((hi.x - lo.x + 2_000.0) / cell).ceil() as u32;
    let height = ((hi.y - lo.y + 2_000.0) / cell).ceil() as u32;
    let mut data = vec![0i8; width as usize * height as usize];
    for s in world
        .segments
        .iter()
        .filter(|s| s.kind != rome_maps::model::EdgeKind::Opening)
    {
        // Half a cell a step: no cell the segment crosses is skipped.
        let steps = ((s.b - s.a).norm() / (cell / 2.0)).ceil().max(1.0) as usize;
        for k in 0..=steps {
            let p = s.a + (s.b - s.a) * (k as f64 / steps as f64);
            let (i, j) = ((p.x - origin.0) / cell, (p.y - origin.1) / cell);
            if i >= 0.0 && j >= 0.0 && (i as u32) < width && (j as u32) < height {
                data[j as usize * width as usize + i as usize] = 100;
            }
        }
    }
    crate::msg::OccupancyGrid {
        header: Header {
            stamp: Time::default(),
            frame_id: "map".into(),
        },
        info: crate::msg::MapMetaData {
            map_load_time: Time::default(),
            resolution: resolution_m as f32,
            width,
            height,
            origin: Pose {
                position: Point {
                    x: origin.0 / 1_000.0,
                    y: origin.1 / 1_000.0,
                    z: 0.0,
                },
                orientation: Quaternion::yaw(0.0),
            },
        },
        data,
    }
}

/// What a `cmd_vel` asks of the base.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Drive {
    /// Go straight on at mm/s (negative backwards).
    Go(f64),
    /// Drive at mm/s (negative backwards, zero in place) while turning at
    /// °/s, positive clockwise (the base's sense): Go at the speed, then
    /// Jog at the rate. The base's Jog turns while it keeps the velocity
    /// the last Go set (§4.6.2; on a Pioneer, VEL and RVEL), so the Go
    /// comes first even to turn in place: without it, a turn asked of a
    /// robot that was driving would be an arc at the old speed.
    Arc {
        /// Speed along the heading, mm/s.
        mm_s: f64,
        /// Turn rate, °/s, positive clockwise.
        turn_deg_s: f64,
    },
}

/// Below this, rad/s, a twist's turn is taken as none.
const NO_TURN: f64 = 0.01;

/// A `cmd_vel` as a base command: its forward speed and its turn together.
/// `None` for a twist with a value that is not a finite number. Speeds are
/// held to the base's limits.
pub fn drive(t: &Twist) -> Option<Drive> {
    let (v, w) = (t.linear.x, t.angular.z);
    if !v.is_finite() || !w.is_finite() {
        return None;
    }
    let mm_s = (v * 1_000.0).clamp(-MAX_SPEED_MM_S, MAX_SPEED_MM_S);
    Some(if w.abs() >= NO_TURN {
        Drive::Arc {
            mm_s,
            turn_deg_s: (-w.to_degrees()).clamp(-MAX_TURN_DEG_S, MAX_TURN_DEG_S),
        }
    } else {
        Drive::Go(mm_s)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn north_is_a_quarter_turn_from_east() {
        let q = Quaternion::yaw(yaw_of(0.0));
        assert!((q.z - std::f64::consts::FRAC_PI_4.sin()).abs() < 1e-12);
        assert!(yaw_of(-90.0).abs() < 1e-12, "East");
    }

    #[test]
    fn the_forward_sonar_is_at_angle_zero_and_silence_is_infinity() {
        let mut mm = vec![SONAR_MAX_MM as u32; 24];
        mm[12] = 1_500;
        let s = sonar(&Scan {
            robot: "r1".into(),
            seq: 1,
            time_ms: 2_000,
            sonar_mm: mm,
            ir: vec![0; 24],
        });
        let at = |k: usize| s.angle_min + s.angle_increment * k as f32;
        assert!(at(12).abs() < 1e-6);
        assert!((at(18) - std::f32::consts::FRAC_PI_2).abs() < 1e-6, "left");
        assert_eq!(s.ranges[12], 1.5);
        assert_eq!(s.ranges[0], f32::INFINITY);
        assert_eq!(s.ranges.len(), 24);
        assert_eq!(s.header.frame_id, "r1/sonar");
    }

    #[test]
    fn a_twist_drives_and_turns_together_clockwise_positive() {
        let t = |v: f64, w: f64| Twist {
            linear: Vector3 {
                x: v,
                y: 0.0,
                z: 0.0,
            },
            angular: Vector3 {
                x: 0.0,
                y: 0.0,
                z: w,
            },
        };
        assert_eq!(drive(&t(0.3, 0.0)), Some(Drive::Go(300.0)));
        assert_eq!(drive(&t(5.0, 0.0)), Some(Drive::Go(MAX_SPEED_MM_S)));
        // Counter-clockwise in ROS is negative for the base.
        match drive(&t(0.3, 0.5)) {
            Some(Drive::Arc { mm_s, turn_deg_s }) => {
                assert_eq!(mm_s, 300.0);
                assert!(
                    (turn_deg_s + 0.5f64.to_degrees()).abs() < 1e-9,
                    "{turn_deg_s}"
                );
            }
            other => panic!("{other:?}"),
        }
        // In place, and backwards, keep their speed too.
        assert!(matches!(drive(&t(0.0, -0.5)), Some(Drive::Arc { mm_s, .. }) if mm_s == 0.0));
        assert!(matches!(drive(&t(-0.2, 0.5)), Some(Drive::Arc { mm_s, .. }) if mm_s == -200.0));
        assert_eq!(drive(&t(f64::NAN, 0.0)), None);
        assert_eq!(drive(&t(0.1, f64::INFINITY)), None);
    }

    #[test]
    fn odometry_turns_from_the_heading_since_the_last_state() {
        let s = |t: u64, h: f64| BaseState {
            robot: "r1".into(),
            time_ms: t,
            heading_deg: h,
            ..BaseState::default()
        };
        let o = odometry(&s(1_500, 10.0), Some(&s(1_000, 5.0)));
        let w = o.twist.twist.angular.z;
        assert!((w - 10f64.to_radians()).abs() < 1e-9, "{w}");
        assert_eq!(o.header.frame_id, "r1/odom");
        assert_eq!(o.child_frame_id, "r1/base_link");
    }
}
