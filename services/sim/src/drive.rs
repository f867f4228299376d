//! The base's motion controller: the seven LABMATE operating modes of §4.6.3
//! with velocity and acceleration limits, and the odometry its wheel
//! encoders keep in 16-bit registers.
//!
//! Conventions are the thesis': headings in degrees with North 0 and West 90
//! (counter-clockwise); a positive *turn* is clockwise (Table 4.1, Turn).

use crate::spec::{MAX_SPEED_MM_S, MAX_TURN_DEG_S, WHEEL_BASE_MM};

/// An operating mode (§4.6.3).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Mode {
    /// Joystick mode: the power-up default; the robot holds still.
    Joystick,
    /// Go: straight on at a velocity (mm/s, negative backwards), holding the
    /// heading it had when the mode began.
    Go {
        /// Velocity, mm/s.
        velocity: f64,
    },
    /// Proportional go: as Go, without correcting the heading.
    ProportionalGo {
        /// Velocity, mm/s.
        velocity: f64,
    },
    /// Continuous turn: turn by an angle on an arc of a radius at the
    /// current speed setting, then Go.
    ContinuousTurn {
        /// Degrees still to turn, positive clockwise.
        remaining_deg: f64,
        /// Arc radius, mm (0 turns in place).
        radius_mm: f64,
    },
    /// Point-to-point go (Move): a distance with a trapezoidal profile, then
    /// Go at zero velocity.
    PointGo {
        /// Distance still to go, mm (negative backwards).
        remaining_mm: f64,
    },
    /// Point-to-point turn (Turn): an angle in place with a trapezoidal
    /// profile, then Go at the velocity the robot had before (§5.4.1's
    /// in-place turn while centring in a hallway), standing if it stood.
    PointTurn {
        /// Degrees still to turn, positive clockwise.
        remaining_deg: f64,
        /// Velocity of the Go mode that follows, mm/s.
        resume_mm_s: f64,
    },
    /// Jog: a turn rate (degrees per second, positive clockwise) superimposed
    /// on motion at the speed setting, until Go or another Jog.
    Jog {
        /// Turn rate, degrees per second, positive clockwise.
        rate_deg_s: f64,
        /// The motion is backwards: the Go before it was. A Pioneer keeps
        /// the last Go's signed velocity under its turn (VEL, then RVEL).
        #[serde(default)]
        backwards: bool,
    },
    /// A gradual stop (pause) in progress; Joystick when stopped.
    Stopping,
}

impl Mode {
    /// The mode's name, as the base server reports it.
    pub fn name(&self) -> &'static str {
        match self {
            Mode::Joystick => "joystick",
            Mode::Go { .. } => "go",
            Mode::ProportionalGo { .. } => "proportional_go",
            Mode::ContinuousTurn { .. } => "continuous_turn",
            Mode::PointGo { .. } => "point_go",
            Mode::PointTurn { .. } => "point_turn",
            Mode::Jog { .. } => "jog",
            Mode::Stopping => "stopping",
        }
    }
}

/// Why a command was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DriveError {
    /// A value outside what the base can do.
    #[error("{what} {value} is out of range ({range})")]
    OutOfRange {
        /// Which parameter.
        what: &'static str,
        /// The value given.
        value: f64,
        /// What is accepted.
        range: &'static str,
    },
}

fn check(what: &'static str, value: f64, max: f64, range: &'static str) -> Result<f64, DriveError> {
    if value.is_finite() && value.abs() <= max {
        Ok(value)
    } else {
        Err(DriveError::OutOfRange { what, value, range })
    }
}

/// The controller: mode, settings and the speeds it commands. It can be
/// saved whole: a base controller keeps its command going while the
/// computer that serves it restarts.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Drive {
    /// Current mode.
    pub mode: Mode,
    /// Straight-line speed setting, mm/s (Get Speed Setting).
    pub speed_setting: f64,
    /// Straight-line acceleration setting, mm/s².
    pub accel_setting: f64,
    /// Turning speed setting, degrees per second.
    pub turn_speed_setting: f64,
    /// Turning acceleration setting, degrees per second².
    pub turn_accel_setting: f64,
    /// Commanded speed now, mm/s.
    pub v: f64,
    /// Commanded turn rate now, degrees per second (counter-clockwise).
    pub w: f64,
    /// Heading Go mode holds (odometric), degrees.
    hold_heading: Option<f64>,
}

impl Default for Drive {
    fn default() -> Self {
        Drive {
            mode: Mode::Joystick,
            speed_setting: 300.0,
            accel_setting: 300.0,
            turn_speed_setting: 30.0,
            turn_accel_setting: 60.0,
            v: 0.0,
            w: 0.0,
            hold_heading: None,
        }
    }
}

const SPEED_RANGE: &str = "-1000..=1000 mm/s";

impl Drive {
    /// Go: straight on at `velocity` mm/s (Set GO Mode).
    pub fn go(&mut self, velocity: f64) -> Result<(), DriveError> {
        let velocity = check("velocity", velocity, MAX_SPEED_MM_S, SPEED_RANGE)?;
        self.speed_setting = velocity.abs();
        self.mode = Mode::Go { velocity };
        self.hold_heading = None;
        Ok(())
    }

    /// Proportional go at `velocity` mm/s.
    pub fn proportional_go(&mut self, velocity: f64) -> Result<(), DriveError> {
        let velocity = check("velocity", velocity, MAX_SPEED_MM_S, SPEED_RANGE)?;
        self.speed_setting = velocity.abs();
        self.mode = Mode::ProportionalGo { velocity };
        Ok(())
    }

    /// Jog: turn at `rate` degrees per second (positive clockwise) while
    /// moving at the speed setting (Set JOG Mode), backwards if the Go
    /// before it was.
    pub fn jog(&mut self, rate: f64) -> Result<(), DriveError> {
        let rate = check(
            "jog rate",
            rate,
            MAX_TURN_DEG_S,
            "-90..=90 degrees per second",
        )?;
        let backwards = match self.mode {
            Mode::Go { velocity } | Mode::ProportionalGo { velocity } => velocity < 0.0,
            Mode::Jog { backwards, .. } => backwards,
            _ => false,
        };
        self.mode = Mode::Jog {
            rate_deg_s: rate,
            backwards,
        };
        Ok(())
    }

    /// A Jog's velocity: the speed setting, backwards if its Go was; a
    /// turn that interrupts the Jog goes on at it too.
    fn jog_mm_s(&self, backwards: bool) -> f64 {
        if backwards {
            -self.speed_setting
        } else {
            self.speed_setting
        }
    }

    /// Move: `distance` mm (negative backwards) at `velocity` mm/s and
    /// `accel` mm/s²; a negative velocity or acceleration keeps the current
    /// setting (Table 4.1).
    pub fn move_by(&mut self, distance: f64, velocity: f64, accel: f64) -> Result<(), DriveError> {
        let distance = check("distance", distance, 1.0e9, "±1e9 mm")?;
        if velocity >= 0.0 {
            self.speed_setting = check("velocity", velocity, MAX_SPEED_MM_S, "0..=1000 mm/s")?;
        }
        if accel >= 0.0 {
            self.accel_setting = check("acceleration", accel, 5_000.0, "0..=5000 mm/s²")?;
        }
        self.mode = Mode::PointGo {
            remaining_mm: distance,
        };
        Ok(())
    }

    /// Turn: `degrees` (positive clockwise) at `velocity` °/s and `accel`
    /// °/s²; negative velocity or acceleration keeps the current setting.
    pub fn turn(&mut self, degrees: f64, velocity: f64, accel: f64) -> Result<(), DriveError> {
        let degrees = check("turn", degrees, 36_000.0, "±36000 degrees")?;
        if velocity >= 0.0 {
            self.turn_speed_setting = check(
                "turn velocity",
                velocity,
                MAX_TURN_DEG_S,
                "0..=90 degrees per second",
            )?;
        }
        if accel >= 0.0 {
            self.turn_accel_setting = check(
                "turn acceleration",
                accel,
                720.0,
                "0..=720 degrees per second²",
            )?;
        }
        let resume_mm_s = match self.mode {
            Mode::Go { velocity } | Mode::ProportionalGo { velocity } => velocity,
            Mode::Jog { backwards, .. } => self.jog_mm_s(backwards),
            Mode::ContinuousTurn { .. } => self.speed_setting,
            Mode::PointTurn { resume_mm_s, .. } => resume_mm_s,
            Mode::Joystick | Mode::PointGo { .. } | Mode::Stopping => 0.0,
        };
        self.mode = Mode::PointTurn {
            remaining_deg: degrees,
            resume_mm_s,
        };
        Ok(())
    }

    /// Continuous turn: `degrees` (positive clockwise) on an arc of
    /// `radius_mm` at the speed setting.
    pub fn continuous_turn(&mut self, degrees: f64, radius_mm: f64) -> Result<(), DriveError> {
        let degrees = check("turn", degrees, 36_000.0, "±36000 degrees")?;
        let radius_mm = check("radius", radius_mm, 1.0e6, "0..=1e6 mm")?.abs();
        self.mode = Mode::ContinuousTurn {
            remaining_deg: degrees,
            radius_mm,
        };
        Ok(())
    }

    /// Stop: at once (`emergency`), or gradually at the acceleration setting.
    pub fn stop(&mut self, emergency: bool) {
        if emergency {
            self.v = 0.0;
            self.w = 0.0;
            self.mode = Mode::Joystick;
        } else {
            self.mode = Mode::Stopping;
        }
    }

    /// Average magnitude of the two wheels' speeds, mm/s (Get Wheel Speed).
    pub fn wheel_speed(&self) -> f64 {
        let (l, r) = self.wheels();
        (l.abs() + r.abs()) / 2.0
    }

    /// Left and right wheel speeds, mm/s.
    pub fn wheels(&self) -> (f64, f64) {
        let half = self.w.to_radians() * WHEEL_BASE_MM / 2.0;
        (self.v - half, self.v + half)
    }

    /// Advances the controller by `dt` seconds given the odometric heading;
    /// returns the wheel speeds (left, right) in mm/s for this step.
    pub fn step(&mut self, dt: f64, heading_deg: f64) -> (f64, f64) {
        let (target_v, target_w) = self.targets(heading_deg, dt);
        let turning = matches!(self.mode, Mode::PointTurn { .. });
        let dv = if matches!(self.mode, Mode::Joystick) {
            f64::INFINITY
        } else {
            self.accel_setting * dt
        };
        self.v += (target_v - self.v).clamp(-dv, dv);
        let dw = if turning || matches!(self.mode, Mode::ContinuousTurn { .. }) {
            self.turn_accel_setting * dt
        } else {
            // Heading corrections and jog rates are applied briskly.
            4.0 * MAX_TURN_DEG_S * dt
        };
        self.w += (target_w - self.w).clamp(-dw, dw);
        self.w = self.w.clamp(-MAX_TURN_DEG_S, MAX_TURN_DEG_S);
        // This step runs at these speeds, whatever the mode becomes.
        let used = self.wheels();
        // Progress of point-to-point modes, measured by the encoders.
        let travelled = self.v * dt;
        let turned_cw = -self.w * dt;
        match &mut self.mode {
            Mode::PointGo { remaining_mm } => {
                let before = *remaining_mm;
                *remaining_mm -= travelled;
                if remaining_mm.abs() < 0.01 || passed(before, *remaining_mm) {
                    self.v = 0.0;
                    self.mode = Mode::Go { velocity: 0.0 };
                    self.hold_heading = None;
                }
            }
            Mode::PointTurn { remaining_deg, .. } | Mode::ContinuousTurn { remaining_deg, .. } => {
                let before = *remaining_deg;
                *remaining_deg -= turned_cw;
                if remaining_deg.abs() < 0.001 || passed(before, *remaining_deg) {
                    let resume = if let Mode::PointTurn { resume_mm_s, .. } = self.mode {
                        self.w = 0.0;
                        resume_mm_s
                    } else {
                        self.speed_setting
                    };
                    self.mode = Mode::Go { velocity: resume };
                    self.hold_heading = None;
                }
            }
            Mode::Stopping if self.v == 0.0 && self.w == 0.0 => self.mode = Mode::Joystick,
            _ => {}
        }
        used
    }

    /// What speed and turn rate the mode asks for now.
    fn targets(&mut self, heading_deg: f64, dt: f64) -> (f64, f64) {
        match self.mode {
            Mode::Joystick | Mode::Stopping => (0.0, 0.0),
            Mode::Go { velocity } => {
                let hold = *self.hold_heading.get_or_insert(heading_deg);
                // Error integration: steer back to the held heading.
                let err = rome_maps::geometry::normalize_deg(hold - heading_deg);
                (velocity, (2.0 * err).clamp(-10.0, 10.0))
            }
            Mode::ProportionalGo { velocity } => (velocity, 0.0),
            Mode::Jog {
                rate_deg_s,
                backwards,
            } => (self.jog_mm_s(backwards), -rate_deg_s),
            Mode::PointGo { remaining_mm } => {
                // The last step lands exactly on the target.
                let reach = (2.0 * self.accel_setting * remaining_mm.abs())
                    .sqrt()
                    .max(20.0);
                let v = self.speed_setting.min(reach).min(remaining_mm.abs() / dt);
                (remaining_mm.signum() * v, 0.0)
            }
            Mode::PointTurn { remaining_deg, .. } => {
                let reach = (2.0 * self.turn_accel_setting * remaining_deg.abs()).sqrt();
                let w = self
                    .turn_speed_setting
                    .min(reach)
                    .max(0.5)
                    .min(remaining_deg.abs() / dt);
                (0.0, -remaining_deg.signum() * w)
            }
            Mode::ContinuousTurn {
                remaining_deg,
                radius_mm,
            } => {
                let reach = (2.0 * self.turn_accel_setting * remaining_deg.abs()).sqrt();
                let w = self.turn_speed_setting.min(reach).max(0.5);
                let v = if radius_mm > 0.0 {
                    (w.to_radians() * radius_mm).min(self.speed_setting)
                } else {
                    0.0
                };
                let w = if radius_mm > 0.0 {
                    (v / radius_mm).to_degrees()
                } else {
                    w
                };
                (v, -remaining_deg.signum() * w)
            }
        }
    }
}

/// Whether a step carried a point-to-point command past its target: what
/// remained changed sign. A step that goes the wrong way (the base still
/// moving the other way when the command came) only adds to what remains.
fn passed(before: f64, after: f64) -> bool {
    before != 0.0 && before.signum() != after.signum()
}

/// Odometry as the base keeps it: a pose integrated from the wheel
/// encoders, read out through 16-bit registers that wrap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Odometry {
    /// x, mm (unbounded inside; the registers wrap).
    pub x: f64,
    /// y, mm.
    pub y: f64,
    /// Heading, degrees.
    pub heading: f64,
}

impl Odometry {
    /// Integrates the wheels' travel (mm) over one step.
    pub fn advance(&mut self, left_mm: f64, right_mm: f64) {
        let d = (left_mm + right_mm) / 2.0;
        let dh = ((right_mm - left_mm) / WHEEL_BASE_MM).to_degrees();
        let mid = self.heading + dh / 2.0;
        let dir = rome_maps::geometry::direction(mid);
        self.x += d * dir.x;
        self.y += d * dir.y;
        self.heading = rome_maps::geometry::normalize_deg(self.heading + dh);
    }

    /// The registers: x and y in mm as signed 16-bit values that wrap at
    /// ±32768, and the heading in hundredths of a degree, 0..36000.
    pub fn registers(&self) -> Registers {
        Registers {
            x: wrap16(self.x),
            y: wrap16(self.y),
            heading_centideg: (self.heading.rem_euclid(360.0) * 100.0).round() as u32 as u16
                % 36_000,
        }
    }

    /// Sets the registers (Set Position): x and y in mm, heading in degrees.
    pub fn set(&mut self, x: f64, y: f64, heading: f64) {
        self.x = x;
        self.y = y;
        self.heading = rome_maps::geometry::normalize_deg(heading);
    }
}

/// The base's position registers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Registers {
    /// x, mm, wrapping.
    pub x: i16,
    /// y, mm, wrapping.
    pub y: i16,
    /// Heading, hundredths of a degree (North 0, West 9000).
    pub heading_centideg: u16,
}

/// A length in mm as a 16-bit register holds it.
pub fn wrap16(mm: f64) -> i16 {
    (mm.round() as i64).rem_euclid(65_536) as u16 as i16
}
