//! A Pioneer base (P2OS/ARCOS) over a serial line, as a [`BaseDevice`] and
//! a [`ProximityDevice`].
//!
//! One link task owns the port: it connects (CLOSE, SYNC0–2, OPEN, ENABLE),
//! reads server information packets, sends commands and a watchdog pulse
//! every second. When the robot goes silent for longer than the answer
//! timeout the link drops the port, commands fail at once with an error
//! saying so, and the task reconnects until the robot answers again.
//! Commands given while disconnected are never replayed later.
//!
//! The LABMATE's own protocol is not public; P2OS is the documented
//! protocol of a real base with the same 16-bit odometry, so the base
//! server's virtual coordinates (§4.6.3) apply unchanged.

pub mod emulator;
pub mod proto;

use crate::device::{BaseDevice, BaseOp, BaseStatus, DeviceError, ProximityDevice, RawScan};
use proto::{Deframer, Sip};
use rome_schema::robot::{BaseState, SONARS};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::sync::mpsc;
use tokio_serial::SerialPortBuilderExt;

/// How to reach the robot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct P2osConfig {
    /// The serial device (`/dev/ttyUSB0`).
    pub path: String,
    /// Baud rate (Pioneer 3: 9600 by default, 115200 when configured).
    pub baud: u32,
    /// How long the robot may stay silent before it counts as gone.
    pub answer_timeout: Duration,
}

impl P2osConfig {
    /// A port at 9600 baud with a one-second answer timeout.
    pub fn new(path: &str) -> Self {
        P2osConfig {
            path: path.to_string(),
            baud: 9600,
            answer_timeout: Duration::from_secs(1),
        }
    }
}

struct Link {
    connected: bool,
    why: String,
    last_sip: Sip,
    last_at: Option<Instant>,
    started: Instant,
    sonar: [u32; SONARS],
    sonar_at_ms: u64,
    max: [u32; SONARS],
    speed_setting: f64,
    watch: bool,
    mode: &'static str,
    connects: u64,
}

/// A Pioneer base and its sonar ring on a serial line. Clones share the link.
#[derive(Clone)]
pub struct P2os {
    link: Arc<Mutex<Link>>,
    tx: mpsc::UnboundedSender<Vec<u8>>,
    config: P2osConfig,
    _task: Arc<TaskGuard>,
}

struct TaskGuard(tokio::task::JoinHandle<()>);

impl Drop for TaskGuard {
    fn drop(&mut self) {
        self.0.abort();
    }
}

impl P2os {
    /// Starts the link task; it connects (and reconnects) on its own.
    pub fn start(config: P2osConfig) -> P2os {
        let link = Arc::new(Mutex::new(Link {
            connected: false,
            why: "not connected yet".into(),
            last_sip: Sip::default(),
            last_at: None,
            started: Instant::now(),
            sonar: [rome_schema::robot::body::SONAR_MAX_MM as u32; SONARS],
            sonar_at_ms: 0,
            max: [rome_schema::robot::body::SONAR_MAX_MM as u32; SONARS],
            speed_setting: 0.0,
            watch: false,
            mode: "joystick",
            connects: 0,
        }));
        let (tx, rx) = mpsc::unbounded_channel();
        let task = tokio::spawn(run_link(config.clone(), link.clone(), rx));
        P2os {
            link,
            tx,
            config,
            _task: Arc::new(TaskGuard(task)),
        }
    }

    fn link(&self) -> MutexGuard<'_, Link> {
        crate::locked(&self.link)
    }

    /// Whether the robot is connected and answering.
    pub fn connected(&self) -> bool {
        self.link().connected
    }

    /// Why the link last failed (empty reason text while connected).
    pub fn last_error(&self) -> String {
        self.link().why.clone()
    }

    /// How many times the link has (re)connected.
    pub fn connects(&self) -> u64 {
        self.link().connects
    }

    /// The link, if the robot is answering.
    fn live(&self) -> Result<MutexGuard<'_, Link>, DeviceError> {
        let link = self.link();
        let device = format!("Pioneer on {}", self.config.path);
        if !link.connected {
            return Err(DeviceError::Disconnected {
                device,
                why: link.why.clone(),
            });
        }
        let silent = link.last_at.map_or(Duration::MAX, |t| t.elapsed());
        if silent > self.config.answer_timeout {
            return Err(DeviceError::NoAnswer {
                device,
                waited_ms: silent.as_millis() as u64,
            });
        }
        Ok(link)
    }

    fn send(&self, packets: impl IntoIterator<Item = Vec<u8>>) -> Result<(), DeviceError> {
        for p in packets {
            self.tx.send(p).map_err(|_| DeviceError::Disconnected {
                device: format!("Pioneer on {}", self.config.path),
                why: "the link task has ended".into(),
            })?;
        }
        Ok(())
    }
}

fn int(v: f64) -> i32 {
    v.round().clamp(-32_767.0, 32_767.0) as i32
}

impl BaseDevice for P2os {
    async fn command(&mut self, op: BaseOp) -> Result<BaseStatus, DeviceError> {
        use proto::*;
        let mut packets = Vec::new();
        {
            let mut link = self.live()?;
            match op {
                BaseOp::Status => {}
                BaseOp::Move(m) => {
                    if m.velocity_mm_s >= 0.0 {
                        packets.push(command_int(SETV, int(m.velocity_mm_s)));
                        link.speed_setting = m.velocity_mm_s;
                    }
                    if m.accel_mm_s2 >= 0.0 {
                        packets.push(command_int(SETA, int(m.accel_mm_s2)));
                    }
                    packets.push(command_int(MOVE, int(m.distance_mm)));
                    link.mode = "point_go";
                }
                BaseOp::Turn(t) => {
                    if t.velocity_deg_s >= 0.0 {
                        packets.push(command_int(SETRV, int(t.velocity_deg_s)));
                    }
                    if t.accel_deg_s2 >= 0.0 {
                        packets.push(command_int(SETRA, int(t.accel_deg_s2)));
                    }
                    // Table 4.1 turns clockwise for positive; P2OS counter-clockwise.
                    packets.push(command_int(DHEAD, -int(t.degrees)));
                    link.mode = "point_turn";
                }
                BaseOp::Go(v) => {
                    packets.push(command_int(RVEL, 0));
                    packets.push(command_int(VEL, int(v)));
                    link.speed_setting = v;
                    link.mode = "go";
                }
                BaseOp::Jog(rate) => {
                    packets.push(command_int(VEL, int(link.speed_setting)));
                    packets.push(command_int(RVEL, -int(rate)));
                    link.mode = "jog";
                }
                BaseOp::Stop(emergency) => {
                    packets.push(command(if emergency { E_STOP } else { STOP }));
                    link.mode = "stopping";
                }
                BaseOp::SetBumper(watch) => {
                    packets.push(command_int(BUMPSTALL, if watch { 3 } else { 0 }));
                    link.watch = watch;
                }
            }
        }
        self.send(packets)?;
        let link = self.live()?;
        let s = &link.last_sip;
        let mode = if !s.moving && link.mode == "stopping" {
            "joystick"
        } else {
            link.mode
        };
        Ok(BaseStatus {
            raw_x: s.xpos,
            raw_y: s.ypos,
            state: BaseState {
                time_ms: link.started.elapsed().as_millis() as u64,
                heading_deg: (f64::from(s.thpos) * 360.0 / proto::ANGLE_UNITS).rem_euclid(360.0),
                speed_mm_s: link.speed_setting,
                wheel_speed_mm_s: (f64::from(s.lvel).abs() + f64::from(s.rvel).abs()) / 2.0,
                mode: mode.to_string(),
                bumpers: u8::from(s.front()) | (u8::from(s.rear()) << 1),
                watch_bumpers: link.watch,
                ..BaseState::default()
            },
        })
    }
}

impl ProximityDevice for P2os {
    async fn scan(&mut self) -> Result<RawScan, DeviceError> {
        let link = self.live()?;
        let mut sonar = link.sonar;
        for (r, max) in sonar.iter_mut().zip(link.max) {
            *r = (*r).min(max);
        }
        // Infrared detectors are not part of the standard SIP.
        Ok(RawScan {
            time_ms: link.sonar_at_ms,
            sonar_mm: sonar,
            ir: 0,
        })
    }

    async fn set_timeout(&mut self, max_mm: [u32; SONARS]) -> Result<[u32; SONARS], DeviceError> {
        // P2OS has no per-sonar range limit: the server caps the readings.
        let mut link = self.live()?;
        link.max = max_mm;
        Ok(link.max)
    }
}

type Port = tokio_serial::SerialStream;

async fn run_link(
    config: P2osConfig,
    link: Arc<Mutex<Link>>,
    mut rx: mpsc::UnboundedReceiver<Vec<u8>>,
) {
    let l = Link2(link.clone());
    loop {
        let why = match connect(&config).await {
            Ok((port, deframer)) => {
                // Commands given while disconnected are dropped, never replayed.
                while rx.try_recv().is_ok() {}
                {
                    let mut g = l.get();
                    g.connected = true;
                    g.connects += 1;
                    g.last_at = Some(Instant::now());
                }
                tracing::info!(path = %config.path, "Pioneer connected");
                serve(&config, port, deframer, &link, &mut rx).await
            }
            Err(why) => why,
        };
        {
            let mut g = l.get();
            if g.connected {
                tracing::warn!(path = %config.path, %why, "Pioneer lost; reconnecting");
            }
            g.connected = false;
            g.why = why;
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

struct Link2(Arc<Mutex<Link>>);

impl Link2 {
    fn get(&self) -> MutexGuard<'_, Link> {
        crate::locked(&self.0)
    }
}

/// Opens the port and runs the connection handshake \[P2 6.5\].
async fn connect(config: &P2osConfig) -> Result<(Port, Deframer), String> {
    use proto::*;
    let mut port = tokio_serial::new(&config.path, config.baud)
        .timeout(config.answer_timeout)
        .open_native_async()
        .map_err(|e| format!("cannot open {}: {e}", config.path))?;
    let mut deframer = Deframer::default();
    let io = |e: std::io::Error| format!("{}: {e}", config.path);
    // A robot still in a previous session ignores SYNC0 as a pulse.
    port.write_all(&command(CLOSE)).await.map_err(io)?;
    for sync in [SYNC0, SYNC1, SYNC2] {
        port.write_all(&command(sync)).await.map_err(io)?;
        let deadline = Instant::now() + config.answer_timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(format!(
                    "no answer to SYNC{sync} within {:?}",
                    config.answer_timeout
                ));
            }
            if let Some(packet) = deframer.next_packet() {
                if matches!(packet, Ok(ref p) if p.first() == Some(&sync)) {
                    break;
                }
                continue;
            }
            let mut buf = [0u8; 256];
            match tokio::time::timeout(left, port.read(&mut buf)).await {
                Ok(Ok(n)) if n > 0 => deframer.push(&buf[..n]),
                Ok(Ok(_)) => return Err("the port closed".into()),
                Ok(Err(e)) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Ok(Err(e)) => return Err(io(e)),
                Err(_) => {}
            }
        }
    }
    port.write_all(&command(OPEN)).await.map_err(io)?;
    port.write_all(&command_int(ENABLE, 1)).await.map_err(io)?;
    Ok((port, deframer))
}

/// Runs a connected link until the robot goes silent or the port fails.
async fn serve(
    config: &P2osConfig,
    mut port: Port,
    mut deframer: Deframer,
    link: &Arc<Mutex<Link>>,
    rx: &mut mpsc::UnboundedReceiver<Vec<u8>>,
) -> String {
    let l = Link2(link.clone());
    let mut pulse = tokio::time::interval(Duration::from_secs(1));
    let mut check = tokio::time::interval(config.answer_timeout / 4);
    let mut buf = [0u8; 512];
    loop {
        tokio::select! {
            read = port.read(&mut buf) => match read {
                Ok(0) => return "the port closed".into(),
                Ok(n) => {
                    deframer.push(&buf[..n]);
                    while let Some(packet) = deframer.next_packet() {
                        match packet {
                            Ok(p) => if let Some(sip) = Sip::parse(&p) {
                                let mut g = l.get();
                                let now_ms = g.started.elapsed().as_millis() as u64;
                                for (n, r) in &sip.sonar {
                                    if let Some(slot) = g.sonar.get_mut(usize::from(*n)) {
                                        *slot = u32::from(*r);
                                    }
                                }
                                if !sip.sonar.is_empty() {
                                    g.sonar_at_ms = now_ms;
                                }
                                g.last_sip = sip;
                                g.last_at = Some(Instant::now());
                            },
                            Err(e) => tracing::debug!(path = %config.path, error = %e, "bad packet"),
                        }
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) => return format!("{}: {e}", config.path),
            },
            Some(packet) = rx.recv() => {
                if let Err(e) = port.write_all(&packet).await {
                    return format!("{}: {e}", config.path);
                }
            }
            _ = pulse.tick() => {
                if let Err(e) = port.write_all(&proto::command(proto::PULSE)).await {
                    return format!("{}: {e}", config.path);
                }
            }
            _ = check.tick() => {
                let silent = l.get().last_at.map_or(Duration::MAX, |t| t.elapsed());
                if silent > config.answer_timeout {
                    return format!("no server information packet for {} ms", silent.as_millis());
                }
            }
        }
    }
}
