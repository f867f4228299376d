//! Virtual X-Y coordinates (§4.6.3): 16-bit position registers unwrapped
//! into 32-bit positions, and the frame that Set/Adjust Position move.
//!
//! The thesis' rule, applied on every read: an overflow from `old` to
//! `new` is `old > 0 ∧ new < 0 ∧ |new − old| > 2^15`; an underflow is
//! `old < 0 ∧ new > 0 ∧ |new − old| > 2^15`. It holds as long as the robot
//! travels less than 32.768 m between two reads, which the servers' state
//! stream (10 Hz by default) guarantees for any LABMATE or Pioneer speed.

use nalgebra::{Isometry2, Point2, UnitComplex};

/// A point, mm.
type Point = Point2<f64>;

/// One 16-bit register unwrapped into a wider count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Unwrap {
    last: Option<i16>,
    wraps: i32,
}

impl Unwrap {
    /// Reads a new register value; returns the unwrapped position.
    pub fn update(&mut self, new: i16) -> i64 {
        if let Some(old) = self.last {
            let (o, n) = (i32::from(old), i32::from(new));
            let jump = (n - o).abs() > 1 << 15;
            if o > 0 && n < 0 && jump {
                self.wraps += 1;
            } else if o < 0 && n > 0 && jump {
                self.wraps -= 1;
            }
        }
        self.last = Some(new);
        self.value()
    }

    /// The unwrapped position of the last read.
    pub fn value(&self) -> i64 {
        i64::from(self.wraps) * 65_536 + i64::from(self.last.unwrap_or(0))
    }

    /// Net overflows (+) and underflows (−) so far.
    pub fn wraps(&self) -> i32 {
        self.wraps
    }
}

/// The device's odometry as the server presents it: both registers
/// unwrapped, then moved by the frame that Set and Adjust Position define.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VirtualPose {
    /// x register.
    pub x: Unwrap,
    /// y register.
    pub y: Unwrap,
    /// Rotation of the frame, degrees (counter-clockwise, as headings).
    turn_deg: f64,
    /// Device position to virtual position: the rotation by `turn_deg`,
    /// then a translation, mm.
    frame: Isometry2<f64>,
}

/// A pose in virtual coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose32 {
    /// x, mm.
    pub x_mm: i32,
    /// y, mm.
    pub y_mm: i32,
    /// Heading, degrees 0 … 360.
    pub heading_deg: f64,
}

impl VirtualPose {
    /// Reads the registers (x, y in mm; heading in degrees) and returns the
    /// virtual pose.
    pub fn read(&mut self, raw_x: i16, raw_y: i16, raw_heading_deg: f64) -> Pose32 {
        let x = self.x.update(raw_x) as f64;
        let y = self.y.update(raw_y) as f64;
        self.apply(x, y, raw_heading_deg)
    }

    fn apply(&self, x: f64, y: f64, heading: f64) -> Pose32 {
        let v = self.frame * Point::new(x, y);
        Pose32 {
            x_mm: clamp32(v.x),
            y_mm: clamp32(v.y),
            heading_deg: (heading + self.turn_deg).rem_euclid(360.0),
        }
    }

    /// Set Position: from now on the last read pose reads as `to`.
    pub fn set(&mut self, raw_heading_deg: f64, to: Pose32Target) {
        self.turn_deg = to.heading_deg - raw_heading_deg;
        let turn = UnitComplex::new(self.turn_deg.to_radians());
        let here = Point::new(self.x.value() as f64, self.y.value() as f64);
        let shift = Point::new(to.x_mm, to.y_mm) - turn * here;
        self.frame = Isometry2::from_parts(shift.into(), turn);
    }
}

/// What a [`VirtualPose`] holds, to keep it across a restart of its
/// server: a base controller keeps its registers when the computer that
/// serves it restarts, so the server must take up the same unwrapping
/// and frame, or every pose it reports jumps.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SavedFrame {
    /// The x register's last read, and its net wraps.
    pub x: (Option<i16>, i32),
    /// The y register's last read, and its net wraps.
    pub y: (Option<i16>, i32),
    /// Rotation of the frame, degrees.
    pub turn_deg: f64,
    /// Translation of the frame, mm.
    pub shift_mm: (f64, f64),
}

impl VirtualPose {
    /// The state to keep.
    pub fn save(&self) -> SavedFrame {
        let t = self.frame.translation.vector;
        SavedFrame {
            x: (self.x.last, self.x.wraps),
            y: (self.y.last, self.y.wraps),
            turn_deg: self.turn_deg,
            shift_mm: (t.x, t.y),
        }
    }

    /// The virtual pose as it was saved: the same reads give the same
    /// poses, to the bit.
    pub fn restore(s: &SavedFrame) -> VirtualPose {
        let turn = UnitComplex::new(s.turn_deg.to_radians());
        let shift = nalgebra::Translation2::new(s.shift_mm.0, s.shift_mm.1);
        VirtualPose {
            x: Unwrap {
                last: s.x.0,
                wraps: s.x.1,
            },
            y: Unwrap {
                last: s.y.0,
                wraps: s.y.1,
            },
            turn_deg: s.turn_deg,
            frame: Isometry2::from_parts(shift, turn),
        }
    }
}

/// Where Set Position puts the robot (f64 so Adjust can add without
/// rounding twice).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose32Target {
    /// x, mm.
    pub x_mm: f64,
    /// y, mm.
    pub y_mm: f64,
    /// Heading, degrees.
    pub heading_deg: f64,
}

fn clamp32(v: f64) -> i32 {
    v.round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Drives a register through `mm` positions as a device would hold them.
    fn run(path: impl IntoIterator<Item = i64>) -> (Unwrap, Vec<i64>) {
        let mut u = Unwrap::default();
        let seen = path
            .into_iter()
            .map(|mm| u.update(mm.rem_euclid(65_536) as u16 as i16))
            .collect();
        (u, seen)
    }

    #[test]
    fn overflow_past_plus_32767_reads_on_upwards() {
        let path: Vec<i64> = (0..200).map(|i| 30_000 + i * 500).collect();
        let (u, seen) = run(path.clone());
        assert_eq!(seen, path);
        assert_eq!(
            u.wraps(),
            2,
            "129.5 m is two wraps above the register's range"
        );
    }

    #[test]
    fn underflow_past_minus_32768_reads_on_downwards() {
        let path: Vec<i64> = (0..300).map(|i| -30_000 - i * 700).collect();
        let (u, seen) = run(path.clone());
        assert_eq!(seen, path);
        assert_eq!(u.wraps(), -4);
    }

    #[test]
    fn crossing_zero_is_not_a_wrap_and_back_and_forth_unwinds() {
        let mut path: Vec<i64> = (0..100).map(|i| 1_000 - i * 20).collect();
        path.extend((0..400).map(|i| -1_000 + i * 300));
        path.extend((0..400).map(|i| 118_700 - i * 300));
        let (u, seen) = run(path.clone());
        assert_eq!(seen, path);
        assert_eq!(u.wraps(), 0, "back at -1000 mm: every overflow undone");
    }

    #[test]
    fn a_restored_frame_reads_as_the_saved_one() {
        let mut v = VirtualPose::default();
        // Past a wrap, and turned by Set Position.
        for i in 0..100_i64 {
            let mm = 30_000 + i * 700;
            v.read(mm.rem_euclid(65_536) as u16 as i16, 1_000, 10.0);
        }
        v.set(
            10.0,
            Pose32Target {
                x_mm: 12_345.5,
                y_mm: -7_000.0,
                heading_deg: 97.25,
            },
        );
        let mut w = VirtualPose::restore(&v.save());
        assert_eq!(w, v);
        assert_eq!(w.read(-20_000, 1_500, 12.0), v.read(-20_000, 1_500, 12.0));
        // The JSON form keeps every bit too.
        let json = serde_json::to_string(&v.save()).expect("encodes");
        let back: SavedFrame = serde_json::from_str(&json).expect("decodes");
        assert_eq!(VirtualPose::restore(&back), v);
    }

    #[test]
    fn set_and_adjust_move_the_frame_exactly() {
        let mut v = VirtualPose::default();
        let p = v.read(1_000, 2_000, 90.0);
        assert_eq!((p.x_mm, p.y_mm), (1_000, 2_000));
        v.set(
            90.0,
            Pose32Target {
                x_mm: 0.0,
                y_mm: 0.0,
                heading_deg: 0.0,
            },
        );
        let p = v.read(1_000, 2_000, 90.0);
        assert_eq!((p.x_mm, p.y_mm, p.heading_deg), (0, 0, 0.0));
        // The robot, heading West (90°) in raw terms, goes 500 mm: in the
        // new frame it heads North (0°), so y grows.
        let p = v.read(500, 2_000, 90.0);
        assert_eq!((p.x_mm, p.y_mm), (0, 500));
    }
}
