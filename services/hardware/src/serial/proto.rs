//! The Pioneer P2OS/ARCOS client-server packet protocol: framing, checksum,
//! command numbers, argument types and the standard server information
//! packet (SIP).
//!
//! Sources of each fact (public manuals of the protocol):
//! - \[P2\] *Pioneer 2 / PeopleBot Operations Manual*, ActivMedia Robotics,
//!   v9, 2001, ch. 6 "P2OS": packet protocol (6.2), checksum (6.2.3),
//!   client commands (6.3, table 13), server information packets (6.4,
//!   table 14), SYNC/OPEN/CLOSE connection (6.5).
//! - \[P3\] *Pioneer 3 Operations Manual*, MobileRobots, v5, 2007, ch. 6
//!   "ARCOS": the same framing and commands, E_STOP (55) and BUMPSTALL (44),
//!   conversion factors of 1.0 mm for Pioneer 3 distances and velocities.

/// Packet header, two bytes \[P2 6.2\].
pub const HEADER: [u8; 2] = [0xFA, 0xFB];
/// The byte count covers command/type byte, arguments and the two
/// checksum bytes, at most 200 \[P2 6.2.1\].
pub const MAX_COUNT: u8 = 200;

/// Connection: synchronisation packets, echoed by the robot \[P2 6.5\].
pub const SYNC0: u8 = 0;
/// Second sync packet.
pub const SYNC1: u8 = 1;
/// Third sync packet; the robot answers with its name, class and subclass.
pub const SYNC2: u8 = 2;
/// After connection, command 0 is the watchdog pulse \[P2 table 13\].
pub const PULSE: u8 = 0;
/// Starts the servers: SIPs begin \[P2 table 13\].
pub const OPEN: u8 = 1;
/// Closes the servers and the connection.
pub const CLOSE: u8 = 2;
/// Enables (1) or disables (0) the motors.
pub const ENABLE: u8 = 4;
/// Translation acceleration, mm/s² (negative: deceleration).
pub const SETA: u8 = 5;
/// Maximum translation velocity, mm/s.
pub const SETV: u8 = 6;
/// Resets the odometry origin to 0, 0, 0.
pub const SETO: u8 = 7;
/// Translate a distance, mm (negative: backwards).
pub const MOVE: u8 = 8;
/// Maximum rotation velocity, °/s.
pub const SETRV: u8 = 10;
/// Translate at a velocity, mm/s.
pub const VEL: u8 = 11;
/// Turn relative to the current heading, degrees, positive counter-clockwise.
pub const DHEAD: u8 = 13;
/// Rotate at a velocity, °/s, positive counter-clockwise.
pub const RVEL: u8 = 21;
/// Rotation acceleration, °/s².
pub const SETRA: u8 = 23;
/// Stop without disabling the motors.
pub const STOP: u8 = 29;
/// Stall on bumper contact: 0 never, 1 front, 2 rear, 3 either \[P3\].
pub const BUMPSTALL: u8 = 44;
/// Emergency stop, overriding deceleration \[P3\].
pub const E_STOP: u8 = 55;

/// Argument type: positive (or zero) integer, two bytes low first \[P2 6.3\].
pub const ARG_INT: u8 = 0x3B;
/// Argument type: negative integer, its magnitude two bytes low first.
pub const ARG_NINT: u8 = 0x1B;
/// Argument type: string, length-prefixed.
pub const ARG_STR: u8 = 0x2B;

/// SIP type: the robot stands \[P2 table 14\].
pub const SIP_STOPPED: u8 = 0x32;
/// SIP type: the robot moves.
pub const SIP_MOVING: u8 = 0x33;
/// Angle units of THPOS: 4096 per turn \[P2 table 14, AngleConvFactor 0.001534 rad\].
pub const ANGLE_UNITS: f64 = 4096.0;

/// The checksum of a packet's payload (command or type byte onwards):
/// the sum of big-endian byte pairs in 16 bits, an odd last byte XORed in
/// \[P2 6.2.3\]. Sent high byte first.
pub fn checksum(payload: &[u8]) -> u16 {
    let mut c: u16 = 0;
    let mut pairs = payload.chunks_exact(2);
    for p in &mut pairs {
        c = c.wrapping_add(u16::from_be_bytes([p[0], p[1]]));
    }
    if let [last] = pairs.remainder() {
        c ^= u16::from(*last);
    }
    c
}

/// Frames a payload: header, count, payload, checksum.
pub fn frame(payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(payload.len() + 5);
    out.extend_from_slice(&HEADER);
    out.push((payload.len() + 2) as u8);
    out.extend_from_slice(payload);
    out.extend_from_slice(&checksum(payload).to_be_bytes());
    out
}

/// A command without argument.
pub fn command(number: u8) -> Vec<u8> {
    frame(&[number])
}

/// A command with an integer argument (clamped to ±32767).
pub fn command_int(number: u8, value: i32) -> Vec<u8> {
    let magnitude = value.unsigned_abs().min(32_767) as u16;
    let kind = if value < 0 { ARG_NINT } else { ARG_INT };
    let [lo, hi] = magnitude.to_le_bytes();
    frame(&[number, kind, lo, hi])
}

/// A framing or checksum error in received bytes.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// The count byte is impossible.
    #[error("bad byte count {0}")]
    Count(u8),
    /// The checksum does not match.
    #[error("checksum {got:04x}, expected {want:04x}")]
    Checksum {
        /// Received.
        got: u16,
        /// Computed.
        want: u16,
    },
}

/// Reassembles packets from a byte stream, resynchronising on the header.
#[derive(Debug, Default)]
pub struct Deframer {
    buf: Vec<u8>,
}

impl Deframer {
    /// Adds received bytes.
    pub fn push(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// The next complete packet's payload; `None` until one is complete.
    pub fn next_packet(&mut self) -> Option<Result<Vec<u8>, FrameError>> {
        match self.buf.windows(2).position(|w| w == HEADER) {
            None => {
                // Keep a trailing 0xFA: it may start the next header.
                let keep = usize::from(self.buf.last() == Some(&HEADER[0]));
                self.buf.drain(..self.buf.len() - keep);
                return None;
            }
            Some(s) => {
                self.buf.drain(..s);
            }
        }
        if self.buf.len() < 3 {
            return None;
        }
        let count = self.buf[2];
        if !(3..=MAX_COUNT).contains(&count) {
            self.buf.drain(..2);
            return Some(Err(FrameError::Count(count)));
        }
        let total = 3 + usize::from(count);
        if self.buf.len() < total {
            return None;
        }
        let packet: Vec<u8> = self.buf.drain(..total).collect();
        let payload = &packet[3..total - 2];
        let got = u16::from_be_bytes([packet[total - 2], packet[total - 1]]);
        let want = checksum(payload);
        if got != want {
            return Some(Err(FrameError::Checksum { got, want }));
        }
        Some(Ok(payload.to_vec()))
    }
}

/// A standard server information packet \[P2 table 14\].
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Sip {
    /// Moving (0x33) or stopped (0x32).
    pub moving: bool,
    /// x, mm, 16 bits.
    pub xpos: i16,
    /// y, mm, 16 bits.
    pub ypos: i16,
    /// Heading, 4096ths of a turn, counter-clockwise.
    pub thpos: i16,
    /// Left wheel velocity, mm/s.
    pub lvel: i16,
    /// Right wheel velocity, mm/s.
    pub rvel: i16,
    /// Battery, tenths of a volt.
    pub battery: u8,
    /// Bit 0 left stall, bits 1–7 front bumpers, bit 8 right stall,
    /// bits 9–15 rear bumpers.
    pub stall_bumpers: u16,
    /// Servo set point, 4096ths of a turn.
    pub control: i16,
    /// Bit 0: motors enabled.
    pub flags: u16,
    /// Compass, 2° units.
    pub compass: u8,
    /// Sonar readings in this packet: (number, range mm).
    pub sonar: Vec<(u8, u16)>,
}

impl Sip {
    /// Front bumpers pressed (bits 1–7).
    pub fn front(&self) -> bool {
        self.stall_bumpers & 0x00FE != 0
    }

    /// Rear bumpers pressed (bits 9–15).
    pub fn rear(&self) -> bool {
        self.stall_bumpers & 0xFE00 != 0
    }

    /// The payload (type byte onwards), as a robot sends it.
    pub fn encode(&self) -> Vec<u8> {
        let mut p = vec![if self.moving { SIP_MOVING } else { SIP_STOPPED }];
        for v in [self.xpos, self.ypos, self.thpos, self.lvel, self.rvel] {
            p.extend_from_slice(&v.to_le_bytes());
        }
        p.push(self.battery);
        p.extend_from_slice(&self.stall_bumpers.to_le_bytes());
        p.extend_from_slice(&self.control.to_le_bytes());
        p.extend_from_slice(&self.flags.to_le_bytes());
        p.push(self.compass);
        p.push(self.sonar.len() as u8);
        for (n, r) in &self.sonar {
            p.push(*n);
            p.extend_from_slice(&r.to_le_bytes());
        }
        p
    }

    /// Parses a payload; `None` if it is not a standard SIP or is short.
    pub fn parse(p: &[u8]) -> Option<Sip> {
        let moving = match *p.first()? {
            SIP_STOPPED => false,
            SIP_MOVING => true,
            _ => return None,
        };
        let i16_at = |i: usize| Some(i16::from_le_bytes([*p.get(i)?, *p.get(i + 1)?]));
        let u16_at = |i: usize| Some(u16::from_le_bytes([*p.get(i)?, *p.get(i + 1)?]));
        let count = usize::from(*p.get(19)?);
        let mut sonar = Vec::with_capacity(count);
        for k in 0..count {
            let at = 20 + 3 * k;
            sonar.push((*p.get(at)?, u16_at(at + 1)?));
        }
        Some(Sip {
            moving,
            xpos: i16_at(1)?,
            ypos: i16_at(3)?,
            thpos: i16_at(5)?,
            lvel: i16_at(7)?,
            rvel: i16_at(9)?,
            battery: *p.get(11)?,
            stall_bumpers: u16_at(12)?,
            control: i16_at(14)?,
            flags: u16_at(16)?,
            compass: *p.get(18)?,
            sonar,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_frame_byte_for_byte() {
        assert_eq!(command(SYNC0), [0xFA, 0xFB, 0x03, 0x00, 0x00, 0x00]);
        assert_eq!(command(SYNC2), [0xFA, 0xFB, 0x03, 0x02, 0x00, 0x02]);
        // 0x043B + 0x0100 = 0x053B.
        assert_eq!(
            command_int(ENABLE, 1),
            [0xFA, 0xFB, 0x06, 0x04, 0x3B, 0x01, 0x00, 0x05, 0x3B]
        );
        // MOVE −1000: magnitude 0x03E8 low first; 0x081B + 0xE803 = 0xF01E.
        assert_eq!(
            command_int(MOVE, -1000),
            [0xFA, 0xFB, 0x06, 0x08, 0x1B, 0xE8, 0x03, 0xF0, 0x1E]
        );
    }

    #[test]
    fn an_odd_payload_xors_its_last_byte() {
        assert_eq!(checksum(&[0x01, 0x02, 0x03]), 0x0102 ^ 0x03);
        assert_eq!(
            checksum(&[0xFF, 0xFF, 0x00, 0x02]),
            0x0001,
            "sum wraps at 16 bits"
        );
    }

    #[test]
    fn deframer_resyncs_and_rejects_bad_checksums() {
        let mut d = Deframer::default();
        let mut bytes = vec![0x00, 0x13, 0xFA];
        bytes.extend(command_int(VEL, 250));
        let mut bad = command(STOP);
        let n = bad.len();
        bad[n - 1] ^= 0xFF;
        bytes.extend(bad);
        bytes.extend(command(OPEN));
        // Fed in two pieces that split a packet.
        d.push(&bytes[..7]);
        assert_eq!(d.next_packet(), None);
        d.push(&bytes[7..]);
        assert_eq!(d.next_packet(), Some(Ok(vec![VEL, ARG_INT, 250, 0])));
        assert!(matches!(
            d.next_packet(),
            Some(Err(FrameError::Checksum { .. }))
        ));
        assert_eq!(d.next_packet(), Some(Ok(vec![OPEN])));
        assert_eq!(d.next_packet(), None);
    }

    #[test]
    fn a_sip_parses_from_its_documented_layout() {
        // Moving; x = -2 (0xFFFE), y = 1000, th = 1024 (90°), wheels 100/120,
        // battery 12.5 V, front bumper 1 (bit 1), two sonar readings.
        let bytes = [
            0x33, 0xFE, 0xFF, 0xE8, 0x03, 0x00, 0x04, 0x64, 0x00, 0x78, 0x00, 125, 0x02, 0x00,
            0x00, 0x00, 0x01, 0x00, 0x00, 2, 0, 0x10, 0x27, 5, 0xDC, 0x05,
        ];
        let sip = Sip::parse(&bytes).unwrap();
        assert!(sip.moving && sip.front() && !sip.rear());
        assert_eq!((sip.xpos, sip.ypos, sip.thpos), (-2, 1000, 1024));
        assert_eq!((sip.lvel, sip.rvel, sip.battery), (100, 120, 125));
        assert_eq!(sip.sonar, [(0, 10_000), (5, 1_500)]);
        assert_eq!(sip.encode(), bytes);
        assert_eq!(Sip::parse(&bytes[..20]), None, "short packet");
    }
}
