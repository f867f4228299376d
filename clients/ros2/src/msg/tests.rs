//! The wire form against layouts worked out by hand from the CDR rules.

use super::*;

fn le(v: f64) -> [u8; 8] {
    v.to_le_bytes()
}

#[test]
fn a_twist_is_the_header_and_six_doubles() {
    let t = Twist {
        linear: Vector3 {
            x: 1.0,
            y: 0.0,
            z: 0.0,
        },
        angular: Vector3 {
            x: 0.0,
            y: 0.0,
            z: 0.5,
        },
    };
    let bytes = encode(&t);
    let mut want = vec![0x00, 0x01, 0x00, 0x00];
    for v in [1.0, 0.0, 0.0, 0.0, 0.0, 0.5] {
        want.extend_from_slice(&le(v));
    }
    assert_eq!(bytes, want);
    assert_eq!(decode::<Twist>(&bytes).unwrap(), t);
}

#[test]
fn an_odometry_aligns_its_strings_and_doubles_from_after_the_header() {
    let o = Odometry {
        header: Header {
            stamp: Time::from_ms(1_500),
            frame_id: "odom".into(),
        },
        child_frame_id: "base_link".into(),
        pose: PoseWithCovariance {
            pose: Pose {
                position: Point {
                    x: 2.5,
                    y: -1.0,
                    z: 0.0,
                },
                orientation: Quaternion::yaw(0.0),
            },
            covariance: Covariance::default(),
        },
        twist: TwistWithCovariance::default(),
    };
    let bytes = encode(&o);
    let body = &bytes[4..];
    assert_eq!(&bytes[..4], &CDR_LE);
    assert_eq!(&body[0..4], &1i32.to_le_bytes(), "sec");
    assert_eq!(&body[4..8], &500_000_000u32.to_le_bytes(), "nanosec");
    assert_eq!(&body[8..12], &5u32.to_le_bytes(), "'odom' and its NUL");
    assert_eq!(&body[12..17], b"odom\0");
    assert_eq!(&body[17..20], &[0, 0, 0], "padding to the next uint32");
    assert_eq!(&body[20..24], &10u32.to_le_bytes());
    assert_eq!(&body[24..34], b"base_link\0");
    assert_eq!(&body[34..40], &[0; 6], "padding to the first double");
    assert_eq!(&body[40..48], &le(2.5), "position.x");
    assert_eq!(&body[48..56], &le(-1.0), "position.y");
    // pose 7 doubles, its covariance 36, the twist 6 and its covariance 36.
    assert_eq!(body.len(), 40 + 8 * (7 + 36 + 6 + 36));
    assert_eq!(decode::<Odometry>(&bytes).unwrap(), o);
}

#[test]
fn a_laser_scan_has_its_ranges_as_a_sequence() {
    let s = LaserScan {
        header: Header {
            stamp: Time::from_ms(0),
            frame_id: "sonar".into(),
        },
        angle_min: -1.0,
        angle_max: 1.0,
        angle_increment: 0.25,
        time_increment: 0.0,
        scan_time: 0.1,
        range_min: 0.15,
        range_max: 10.0,
        ranges: (0..24).map(|i| i as f32).collect(),
        intensities: Vec::new(),
    };
    let bytes = encode(&s);
    let body = &bytes[4..];
    // stamp 8, "sonar" 4 + 6, padding 2, seven floats, then the ranges.
    assert_eq!(&body[18..20], &[0, 0]);
    assert_eq!(&body[20..24], &(-1.0f32).to_le_bytes(), "angle_min");
    assert_eq!(&body[48..52], &24u32.to_le_bytes(), "the ranges' length");
    assert_eq!(&body[52 + 4 * 23..52 + 4 * 24], &23.0f32.to_le_bytes());
    assert_eq!(&body[148..152], &0u32.to_le_bytes(), "no intensities");
    assert_eq!(body.len(), 152);
    assert_eq!(decode::<LaserScan>(&bytes).unwrap(), s);
}

#[test]
fn big_endian_payloads_are_read_too() {
    let mut bytes = CDR_BE.to_vec();
    for v in [0.2f64, 0.0, 0.0, 0.0, 0.0, -0.1] {
        bytes.extend_from_slice(&v.to_be_bytes());
    }
    let t: Twist = decode(&bytes).unwrap();
    assert_eq!((t.linear.x, t.angular.z), (0.2, -0.1));
}

#[test]
fn what_is_not_a_message_says_why() {
    let e = decode::<Twist>(&[0, 1]).unwrap_err().to_string();
    assert!(e.contains("shorter than its 4-byte header"), "{e}");
    let e = decode::<Twist>(&[0, 3, 0, 0, 1, 2])
        .unwrap_err()
        .to_string();
    assert!(e.contains("not plain CDR"), "{e}");
    let e = decode::<Twist>(&[0, 1, 0, 0, 1, 2, 3])
        .unwrap_err()
        .to_string();
    assert!(e.contains("geometry_msgs/msg/Twist"), "{e}");
}

#[test]
fn a_time_splits_milliseconds_into_seconds_and_nanoseconds() {
    assert_eq!(
        Time::from_ms(61_234),
        Time {
            sec: 61,
            nanosec: 234_000_000
        }
    );
}
