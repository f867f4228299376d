//! A Pioneer robot emulator speaking P2OS on any byte stream (a pseudo
//! terminal in the tests): it answers the connection handshake, records
//! every byte it receives, moves a point robot by VEL, RVEL, MOVE and
//! DHEAD, and sends a standard SIP every 100 ms with its 16-bit odometry
//! and eight sonar readings. It can be made to fall silent and come back.

use super::proto::{self, Deframer, Sip};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};

/// What the emulator shares with its test.
#[derive(Clone, Default)]
pub struct Emulator {
    /// Every byte received, in order.
    pub received: Arc<Mutex<Vec<u8>>>,
    /// While true the emulator reads nothing and sends nothing.
    pub silent: Arc<AtomicBool>,
    /// The robot's true x, mm (wide, before the 16-bit register).
    pub x_mm: Arc<Mutex<f64>>,
    /// Bumper bits as the SIP carries them.
    pub bumpers: Arc<Mutex<u16>>,
}

struct Body {
    phase: u8,
    open: bool,
    x: f64,
    y: f64,
    th_deg: f64,
    vel: f64,
    rvel: f64,
    setv: f64,
    to_go: Option<f64>,
    to_turn: Option<f64>,
}

impl Emulator {
    /// The bytes received so far.
    pub fn bytes(&self) -> Vec<u8> {
        crate::locked(&self.received).clone()
    }

    /// Runs on `stream` until it fails.
    pub async fn run<S: AsyncRead + AsyncWrite + Unpin>(self, mut stream: S) {
        let mut body = Body {
            phase: 0,
            open: false,
            x: 0.0,
            y: 0.0,
            th_deg: 0.0,
            vel: 0.0,
            rvel: 0.0,
            setv: 400.0,
            to_go: None,
            to_turn: None,
        };
        let mut deframer = Deframer::default();
        let mut tick = tokio::time::interval(Duration::from_millis(100));
        let mut buf = [0u8; 512];
        let mut bank = 0u8;
        loop {
            tokio::select! {
                read = stream.read(&mut buf) => match read {
                    Ok(0) => tokio::time::sleep(Duration::from_millis(10)).await,
                    Ok(n) => {
                        if self.silent.load(Ordering::Relaxed) {
                            continue;
                        }
                        crate::locked(&self.received).extend_from_slice(&buf[..n]);
                        deframer.push(&buf[..n]);
                        while let Some(Ok(p)) = deframer.next_packet() {
                            if let Some(reply) = self.handle(&mut body, &p) {
                                if stream.write_all(&proto::frame(&reply)).await.is_err() {
                                    return;
                                }
                            }
                        }
                    }
                    // A pty reads EIO while no one has the other end open.
                    Err(_) => tokio::time::sleep(Duration::from_millis(10)).await,
                },
                _ = tick.tick() => {
                    if !body.open || self.silent.load(Ordering::Relaxed) {
                        continue;
                    }
                    body.advance(0.1);
                    *crate::locked(&self.x_mm) = body.x;
                    bank = (bank + 1) % 2;
                    let sonar = (0..8u8).map(|k| {
                        let n = bank * 8 + k;
                        (n, 1_000 + 100 * u16::from(n))
                    }).collect();
                    let sip = Sip {
                        moving: body.vel != 0.0 || body.rvel != 0.0,
                        xpos: wrap(body.x),
                        ypos: wrap(body.y),
                        thpos: (body.th_deg.rem_euclid(360.0) / 360.0 * proto::ANGLE_UNITS).round() as i16,
                        lvel: body.vel as i16,
                        rvel: body.vel as i16,
                        battery: 125,
                        stall_bumpers: *crate::locked(&self.bumpers),
                        flags: 1,
                        sonar,
                        ..Sip::default()
                    };
                    if stream.write_all(&proto::frame(&sip.encode())).await.is_err() {
                        return;
                    }
                }
            }
        }
    }

    fn handle(&self, b: &mut Body, p: &[u8]) -> Option<Vec<u8>> {
        use proto::*;
        let cmd = *p.first()?;
        let arg = match p.get(1..4) {
            Some([kind, lo, hi]) => {
                let m = f64::from(u16::from_le_bytes([*lo, *hi]));
                if *kind == ARG_NINT {
                    -m
                } else {
                    m
                }
            }
            _ => 0.0,
        };
        if !b.open {
            // SYNC1 and OPEN share a number, as do SYNC2 and CLOSE: the
            // phase of the handshake tells them apart \[P2 6.5\].
            return match (b.phase, cmd) {
                (_, SYNC0) => {
                    b.phase = 1;
                    Some(vec![SYNC0])
                }
                (1, SYNC1) => {
                    b.phase = 2;
                    Some(vec![SYNC1])
                }
                (2, SYNC2) => {
                    b.phase = 3;
                    Some([&[SYNC2][..], b"Emu\0Pioneer\0p3dx\0"].concat())
                }
                (3, OPEN) => {
                    b.open = true;
                    None
                }
                _ => {
                    b.phase = 0;
                    None
                }
            };
        }
        match cmd {
            CLOSE => {
                b.open = false;
                b.phase = 0;
                b.vel = 0.0;
                b.rvel = 0.0;
            }
            SETV => b.setv = arg,
            VEL => {
                b.vel = arg;
                b.to_go = None;
            }
            RVEL => {
                b.rvel = arg;
                b.to_turn = None;
            }
            MOVE => {
                b.to_go = Some(arg);
                b.vel = b.setv.copysign(arg);
            }
            DHEAD => {
                b.to_turn = Some(arg);
                b.rvel = 90.0_f64.copysign(arg);
            }
            STOP | E_STOP => {
                b.vel = 0.0;
                b.rvel = 0.0;
                b.to_go = None;
                b.to_turn = None;
            }
            _ => {}
        }
        None
    }
}

impl Body {
    fn advance(&mut self, dt: f64) {
        let mut d = self.vel * dt;
        if let Some(left) = self.to_go {
            if d.abs() >= left.abs() {
                d = left;
                self.vel = 0.0;
                self.to_go = None;
            } else {
                self.to_go = Some(left - d);
            }
        }
        let mut t = self.rvel * dt;
        if let Some(left) = self.to_turn {
            if t.abs() >= left.abs() {
                t = left;
                self.rvel = 0.0;
                self.to_turn = None;
            } else {
                self.to_turn = Some(left - t);
            }
        }
        let (s, c) = self.th_deg.to_radians().sin_cos();
        self.x += d * c;
        self.y += d * s;
        self.th_deg += t;
    }
}

fn wrap(mm: f64) -> i16 {
    (mm.round() as i64).rem_euclid(65_536) as u16 as i16
}
