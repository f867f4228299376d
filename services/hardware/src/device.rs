//! One trait per device kind; a hardware server owns one device through it.
//!
//! The serial Pioneer backend ([`crate::serial`]) and the simulated one
//! (`rome-sim-hardware`) implement these, and tests can script their own.

use rome_schema::robot::{BaseState, Move, Turn, SONARS};
use std::future::Future;
use std::sync::Arc;

/// Reads a device's present state at once, from any thread, without
/// waiting: `None` when that is not possible right now (the device is busy,
/// say), and the caller goes the usual way.
pub type Peek<T> = Arc<dyn Fn() -> Option<T> + Send + Sync>;

/// A device's failure as the server answers it: a value outside what the
/// device takes is `out_of_range`, anything else `device`.
pub fn device_error(e: DeviceError) -> rome_schema::ErrorReply {
    use rome_schema::{ErrorCode, ErrorReply};
    match e {
        DeviceError::OutOfRange(m) => ErrorReply::new(ErrorCode::OutOfRange, m),
        other => ErrorReply::new(ErrorCode::Device, other.to_string()),
    }
}

/// A device could not carry out a command.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DeviceError {
    /// The device did not answer within its timeout.
    #[error("the {device} did not answer within {waited_ms} ms; it is being reconnected")]
    NoAnswer {
        /// Which device.
        device: String,
        /// How long the server waited.
        waited_ms: u64,
    },
    /// The device is not connected (yet, or any more).
    #[error("the {device} is not connected: {why}")]
    Disconnected {
        /// Which device.
        device: String,
        /// What the last attempt said.
        why: String,
    },
    /// A value is outside what the device accepts.
    #[error("{0}")]
    OutOfRange(String),
    /// The device cannot do this.
    #[error("{0}")]
    Unsupported(String),
}

/// What the base can be told to do (Table 4.1's motion and setting commands).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BaseOp {
    /// Read the status only.
    Status,
    /// Point-to-point go.
    Move(Move),
    /// Point-to-point turn.
    Turn(Turn),
    /// Go mode at a velocity, mm/s.
    Go(f64),
    /// Jog mode at a turn rate, °/s, positive clockwise.
    Jog(f64),
    /// Stop: emergency (true) or gradual.
    Stop(bool),
    /// Watch (true) or ignore the bumpers.
    SetBumper(bool),
}

/// The base's registers and settings after a command.
///
/// Only the position registers are the device's own form; the rest is the
/// published [`BaseState`], which the base server completes.
#[derive(Debug, Clone, PartialEq)]
pub struct BaseStatus {
    /// x register, mm (16-bit, wraps).
    pub raw_x: i16,
    /// y register, mm (16-bit, wraps).
    pub raw_y: i16,
    /// The device's clock, heading register (North 0, West 90), velocity
    /// setting, mean wheel speed, mode and bumpers. A device leaves `robot`,
    /// `x_mm`, `y_mm`, `lock` and `queued` at their defaults: the server fills
    /// them in, and puts the virtual frame's heading in place of the register's.
    pub state: BaseState,
}

/// A robot base (the LABMATE of §4.6.3, a Pioneer, a simulated one).
pub trait BaseDevice: Send + Sync + 'static {
    /// Carries out `op` and returns the status afterwards.
    fn command(
        &mut self,
        op: BaseOp,
    ) -> impl Future<Output = Result<BaseStatus, DeviceError>> + Send;

    /// The status without a command, at once, if the device can give it so
    /// (a simulated base can; a serial one must be asked over its line).
    fn peek(&self) -> Option<Peek<BaseStatus>> {
        None
    }
}

/// One reading of the sonar ring and infrared detectors.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawScan {
    /// When the ring fired, device ms.
    pub time_ms: u64,
    /// 24 ranges, mm.
    pub sonar_mm: [u32; SONARS],
    /// Infrared bits, bit i = detector i (8 fitted).
    pub ir: u32,
}

/// The proximity subsystem (§4.6.2).
pub trait ProximityDevice: Send + Sync + 'static {
    /// The latest scan.
    fn scan(&mut self) -> impl Future<Output = Result<RawScan, DeviceError>> + Send;
    /// Sets each sonar's maximum range, mm; returns what is in force.
    fn set_timeout(
        &mut self,
        max_mm: [u32; SONARS],
    ) -> impl Future<Output = Result<[u32; SONARS], DeviceError>> + Send;

    /// The latest scan at once, if the device can give it so.
    fn peek(&self) -> Option<Peek<RawScan>> {
        None
    }
}

/// One grabbed image, 8-bit gray, row-major.
#[derive(Debug)]
pub struct Frame {
    /// When it was grabbed, device ms.
    pub time_ms: u64,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// The rows.
    pub pixels: Pixels,
}

impl Frame {
    /// Row `r`, if the frame has it.
    pub fn row(&self, r: u32) -> Option<&[u8]> {
        let w = self.width as usize;
        match &self.pixels {
            Pixels::Bytes(b) => b.get(r as usize * w..(r as usize + 1) * w),
            Pixels::Drawn { rows, draw } => {
                let row = rows.get(r as usize)?;
                Some(row.get_or_init(|| {
                    let mut line = vec![0u8; w];
                    draw(r, &mut line);
                    line.into_boxed_slice()
                }))
            }
        }
    }

    /// Every row, in order (as many as the frame has).
    pub fn bytes(&self) -> Vec<u8> {
        match &self.pixels {
            Pixels::Bytes(b) => b.clone(),
            Pixels::Drawn { .. } => (0..self.height)
                .filter_map(|r| self.row(r))
                .flatten()
                .copied()
                .collect(),
        }
    }
}

/// A frame's pixels.
pub enum Pixels {
    /// width × height bytes, as a grabber hands them over.
    Bytes(Vec<u8>),
    /// Drawn a row at a time when first read (a simulated camera): its
    /// clients read a few rows of most frames and never the rest.
    Drawn {
        /// Each row, once drawn.
        rows: Vec<std::sync::OnceLock<Box<[u8]>>>,
        /// Draws a row into a buffer one row long.
        draw: DrawRow,
    },
}

/// Draws row `r` of a frame into a buffer one row long.
pub type DrawRow = Box<dyn Fn(u32, &mut [u8]) + Send + Sync>;

impl Pixels {
    /// Rows drawn by `draw` when read, of a frame `height` rows high.
    pub fn drawn(height: u32, draw: impl Fn(u32, &mut [u8]) + Send + Sync + 'static) -> Pixels {
        Pixels::Drawn {
            rows: (0..height).map(|_| std::sync::OnceLock::new()).collect(),
            draw: Box::new(draw),
        }
    }
}

impl std::fmt::Debug for Pixels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Pixels::Bytes(b) => write!(f, "Bytes({} bytes)", b.len()),
            Pixels::Drawn { rows, .. } => {
                let drawn = rows.iter().filter(|r| r.get().is_some()).count();
                write!(f, "Drawn({drawn} of {} rows)", rows.len())
            }
        }
    }
}

/// A camera and its frame grabber (§4.6.4).
pub trait CameraDevice: Send + Sync + 'static {
    /// The image size, (width, height).
    fn size(&self) -> (u32, u32);
    /// Grabs a new image.
    fn grab(&mut self) -> impl Future<Output = Result<Frame, DeviceError>> + Send;
}
