//! The base server (the thesis' RServer, §4.6.3): Table 4.1 over Zenoh.
//!
//! ```text
//! rome/robot/<robot>/base/move          {"distance_mm":2000,"velocity_mm_s":300,"accel_mm_s2":-1}
//! rome/robot/<robot>/base/turn          {"degrees":90,"velocity_deg_s":-1,"accel_deg_s2":-1}
//! rome/robot/<robot>/base/go            {"velocity_mm_s":400}
//! rome/robot/<robot>/base/jog           {"rate_deg_s":-4}
//! rome/robot/<robot>/base/stop          {"emergency":true}
//! rome/robot/<robot>/base/pose          (Get Position, 32-bit virtual coordinates)
//! rome/robot/<robot>/base/set-pose      {"x_mm":0,"y_mm":0,"heading_deg":90}
//! rome/robot/<robot>/base/adjust-pose   {"dx_mm":-120,"dy_mm":0,"dheading_deg":1.5}
//! rome/robot/<robot>/base/bumper        (Get Bumper Status)
//! rome/robot/<robot>/base/set-bumper    {"watch":true}
//! rome/robot/<robot>/base/speed         (Get Speed Setting)
//! rome/robot/<robot>/base/wheel-speed   (Get Wheel Speed)
//! rome/robot/<robot>/base/mode          (Get Mode)
//! rome/robot/<robot>/base/lock          ?owner=ID;ttl_ms=2500
//! rome/robot/<robot>/base/unlock        ?fence=N
//! rome/robot/<robot>/base/state         published at --state-hz
//! ```
//!
//! A motion command (move, turn, go, jog) that names its sender
//! (`?client=ID`, the last chunk of the sender's liveliness token) makes
//! the server watch that client: when its token goes, the base is stopped,
//! so a robot does not drive on after its controller died.

use crate::device::{device_error, BaseDevice, BaseOp, BaseStatus};
use crate::locked;
use crate::server::{no_payload, Body, QuickRead, Service};
use crate::vxy::{Pose32, Pose32Target, VirtualPose};
use rome_schema::robot::command::{
    parse_payload, Command, ReadBumper, ReadMode, ReadPose, ReadSpeed, ReadWheelSpeed,
};
use rome_schema::robot::{
    AdjustPose, BaseState, BumperReply, Done, Go, Jog, LockInfo, ModeReply, Move, PoseReply,
    SetBumper, SetPose, SpeedReply, Stop, Turn, WheelSpeedReply,
};
use rome_schema::{ErrorCode, ErrorReply, Params};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The base server's commands (lock and unlock come with every lockable server).
pub const COMMANDS: &[&str] = &[
    Move::NAME,
    Turn::NAME,
    Go::NAME,
    Jog::NAME,
    Stop::NAME,
    ReadPose::NAME,
    SetPose::NAME,
    AdjustPose::NAME,
    ReadBumper::NAME,
    SetBumper::NAME,
    ReadSpeed::NAME,
    ReadWheelSpeed::NAME,
    ReadMode::NAME,
];

/// A parsed base command.
#[derive(Debug, Clone, PartialEq)]
pub enum BaseCmd {
    /// A motion or setting carried to the device.
    Op(BaseOp),
    /// `pose`.
    Pose,
    /// `set-pose`.
    SetPose(SetPose),
    /// `adjust-pose`.
    AdjustPose(AdjustPose),
    /// `bumper`.
    Bumper,
    /// `speed`.
    Speed,
    /// `wheel-speed`.
    WheelSpeed,
    /// `mode`.
    Mode,
}

/// The base server's state: its device and the virtual coordinate frame.
pub struct Base<D: BaseDevice> {
    robot: String,
    device: D,
    /// Shared with the quick reads answered from the queryable's callback.
    frame: Arc<Mutex<VirtualPose>>,
    state_period: Option<Duration>,
}

/// The base's read commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Read {
    Pose,
    Bumper,
    Speed,
    WheelSpeed,
    Mode,
}

impl Read {
    fn of(command: &str) -> Option<Read> {
        Some(match command {
            ReadPose::NAME => Read::Pose,
            ReadBumper::NAME => Read::Bumper,
            ReadSpeed::NAME => Read::Speed,
            ReadWheelSpeed::NAME => Read::WheelSpeed,
            ReadMode::NAME => Read::Mode,
            _ => return None,
        })
    }
}

/// A read's answer from the device's status, read through the frame.
fn read_body(read: Read, s: BaseStatus, frame: &mut VirtualPose) -> Body {
    // Every read of the registers follows their wraps, whatever was asked.
    let p = frame.read(s.raw_x, s.raw_y, s.state.heading_deg);
    match read {
        Read::Pose => Body::json(&PoseReply {
            x_mm: p.x_mm,
            y_mm: p.y_mm,
            heading_deg: p.heading_deg,
            raw_x: s.raw_x,
            raw_y: s.raw_y,
            wraps_x: frame.x.wraps(),
            wraps_y: frame.y.wraps(),
        }),
        Read::Bumper => Body::json(&BumperReply {
            status: s.state.bumpers,
            front: s.state.bumpers & 1 != 0,
            rear: s.state.bumpers & 2 != 0,
            watch: s.state.watch_bumpers,
        }),
        Read::Speed => Body::json(&SpeedReply {
            speed_mm_s: s.state.speed_mm_s,
        }),
        Read::WheelSpeed => Body::json(&WheelSpeedReply {
            wheel_speed_mm_s: s.state.wheel_speed_mm_s,
        }),
        Read::Mode => Body::json(&ModeReply { mode: s.state.mode }),
    }
}

impl<D: BaseDevice> Base<D> {
    /// A base server for `device`, publishing its state every `state_period`.
    pub fn new(robot: &str, device: D, state_period: Option<Duration>) -> Self {
        Self::with_frame(robot, device, state_period, Arc::default())
    }

    /// A base server whose virtual coordinate frame is `frame`, shared with
    /// whoever keeps it across a restart of the server.
    pub fn with_frame(
        robot: &str,
        device: D,
        state_period: Option<Duration>,
        frame: Arc<Mutex<VirtualPose>>,
    ) -> Self {
        Base {
            robot: robot.to_string(),
            device,
            frame,
            state_period,
        }
    }

    async fn status(&mut self, op: BaseOp) -> Result<(BaseStatus, Pose32), ErrorReply> {
        let status = self.device.command(op).await.map_err(device_error)?;
        let pose = locked(&self.frame).read(status.raw_x, status.raw_y, status.state.heading_deg);
        Ok((status, pose))
    }

    async fn read(&mut self, read: Read) -> Result<Body, ErrorReply> {
        let status = self
            .device
            .command(BaseOp::Status)
            .await
            .map_err(device_error)?;
        Ok(read_body(read, status, &mut locked(&self.frame)))
    }

    fn set_frame(&mut self, raw_heading: f64, to: Pose32Target) -> Result<(), ErrorReply> {
        if !(to.x_mm.abs() <= f64::from(i32::MAX)
            && to.y_mm.abs() <= f64::from(i32::MAX)
            && to.heading_deg.is_finite())
        {
            return Err(ErrorReply::new(
                ErrorCode::OutOfRange,
                "the position must fit 32-bit millimetres and the heading be finite",
            ));
        }
        locked(&self.frame).set(raw_heading, to);
        Ok(())
    }
}

impl<D: BaseDevice> Service for Base<D> {
    type Cmd = BaseCmd;

    const COMMANDS: &'static [&'static str] = COMMANDS;
    const LOCKABLE: bool = true;
    const READS: &'static [&'static str] = &[
        ReadPose::NAME,
        ReadSpeed::NAME,
        ReadWheelSpeed::NAME,
        ReadMode::NAME,
        ReadBumper::NAME,
    ];

    fn parse(
        &self,
        command: &str,
        params: Params,
        body: Option<&[u8]>,
    ) -> Result<BaseCmd, ErrorReply> {
        params.finish(command, &["priority", "fence", "wait_ms", "client", "op"])?;
        let bare = |cmd: BaseCmd| no_payload(command, body).map(|()| cmd);
        Ok(match command {
            Move::NAME => BaseCmd::Op(BaseOp::Move(parse_payload(body)?)),
            Turn::NAME => BaseCmd::Op(BaseOp::Turn(parse_payload(body)?)),
            Go::NAME => BaseCmd::Op(BaseOp::Go(parse_payload::<Go>(body)?.velocity_mm_s)),
            Jog::NAME => BaseCmd::Op(BaseOp::Jog(parse_payload::<Jog>(body)?.rate_deg_s)),
            Stop::NAME => {
                // A stop without a payload is a gradual one.
                let s: Stop = match body {
                    Some(b) if !b.is_empty() => parse_payload(body)?,
                    _ => Stop::default(),
                };
                BaseCmd::Op(BaseOp::Stop(s.emergency))
            }
            SetPose::NAME => BaseCmd::SetPose(parse_payload(body)?),
            AdjustPose::NAME => BaseCmd::AdjustPose(parse_payload(body)?),
            SetBumper::NAME => {
                BaseCmd::Op(BaseOp::SetBumper(parse_payload::<SetBumper>(body)?.watch))
            }
            ReadPose::NAME => bare(BaseCmd::Pose)?,
            ReadBumper::NAME => bare(BaseCmd::Bumper)?,
            ReadSpeed::NAME => bare(BaseCmd::Speed)?,
            ReadWheelSpeed::NAME => bare(BaseCmd::WheelSpeed)?,
            ReadMode::NAME => bare(BaseCmd::Mode)?,
            other => {
                return Err(ErrorReply::new(
                    ErrorCode::UnknownKey,
                    format!("the base has no command '{other}'"),
                ))
            }
        })
    }

    fn sets_moving(&self, cmd: &BaseCmd) -> bool {
        matches!(
            cmd,
            BaseCmd::Op(BaseOp::Move(_) | BaseOp::Turn(_) | BaseOp::Go(_) | BaseOp::Jog(_))
        )
    }

    async fn halt(&mut self) -> Result<bool, ErrorReply> {
        // Stopped whatever the status says: a Go just set may not have
        // turned the wheels yet.
        let (before, _) = self.status(BaseOp::Status).await?;
        self.status(BaseOp::Stop(false)).await?;
        let s = &before.state;
        Ok(s.wheel_speed_mm_s > 0.0 || !matches!(s.mode.as_str(), "joystick" | "go"))
    }

    async fn apply(&mut self, cmd: BaseCmd, _lock: Option<LockInfo>) -> Result<Body, ErrorReply> {
        match cmd {
            BaseCmd::Op(op) => {
                let name = match op {
                    BaseOp::Move(_) => "move",
                    BaseOp::Turn(_) => "turn",
                    BaseOp::Go(_) => "go",
                    BaseOp::Jog(_) => "jog",
                    BaseOp::Stop(_) => "stop",
                    BaseOp::SetBumper(_) => "set-bumper",
                    BaseOp::Status => "status",
                };
                let (status, _) = self.status(op).await?;
                Ok(Body::json(&Done {
                    command: name.into(),
                    mode: status.state.mode,
                }))
            }
            BaseCmd::Pose => self.read(Read::Pose).await,
            BaseCmd::SetPose(to) => {
                let (s, _) = self.status(BaseOp::Status).await?;
                self.set_frame(
                    s.state.heading_deg,
                    Pose32Target {
                        x_mm: to.x_mm as f64,
                        y_mm: to.y_mm as f64,
                        heading_deg: to.heading_deg,
                    },
                )?;
                Ok(Body::json(&Done {
                    command: "set-pose".into(),
                    mode: s.state.mode,
                }))
            }
            BaseCmd::AdjustPose(d) => {
                let (s, p) = self.status(BaseOp::Status).await?;
                self.set_frame(
                    s.state.heading_deg,
                    Pose32Target {
                        x_mm: f64::from(p.x_mm) + d.dx_mm as f64,
                        y_mm: f64::from(p.y_mm) + d.dy_mm as f64,
                        heading_deg: p.heading_deg + d.dheading_deg,
                    },
                )?;
                Ok(Body::json(&Done {
                    command: "adjust-pose".into(),
                    mode: s.state.mode,
                }))
            }
            BaseCmd::Bumper => self.read(Read::Bumper).await,
            BaseCmd::Speed => self.read(Read::Speed).await,
            BaseCmd::WheelSpeed => self.read(Read::WheelSpeed).await,
            BaseCmd::Mode => self.read(Read::Mode).await,
        }
    }

    fn quick(&self) -> Option<QuickRead> {
        let peek = self.device.peek()?;
        let frame = self.frame.clone();
        Some(Arc::new(move |command: &str, params: Params| {
            params.finish(command, &[]).ok()?;
            let read = Read::of(command)?;
            let status = peek()?;
            Some(read_body(read, status, &mut locked(&frame)))
        }))
    }

    fn period(&self) -> Option<Duration> {
        self.state_period
    }

    async fn tick(
        &mut self,
        lock: Option<LockInfo>,
        queued: usize,
    ) -> Option<(&'static str, Body)> {
        match self.status(BaseOp::Status).await {
            Ok((s, p)) => Some((
                "state",
                Body::json(&BaseState {
                    robot: self.robot.clone(),
                    x_mm: p.x_mm,
                    y_mm: p.y_mm,
                    heading_deg: p.heading_deg,
                    lock,
                    queued,
                    ..s.state
                }),
            )),
            Err(e) => {
                tracing::warn!(robot = %self.robot, error = %e, "base state not read");
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::DeviceError;

    /// A base that reports a fixed mode and wheel speed and counts stops.
    struct Still(&'static str, f64, Arc<Mutex<u32>>);

    impl BaseDevice for Still {
        async fn command(&mut self, op: BaseOp) -> Result<BaseStatus, DeviceError> {
            if matches!(op, BaseOp::Stop(_)) {
                *self.2.lock().unwrap() += 1;
            }
            Ok(BaseStatus {
                raw_x: 0,
                raw_y: 0,
                state: BaseState {
                    mode: self.0.into(),
                    wheel_speed_mm_s: self.1,
                    ..BaseState::default()
                },
            })
        }
    }

    #[tokio::test]
    async fn a_halt_stops_the_base_and_says_whether_it_was_in_motion() {
        for (mode, wheels, moving) in [
            ("go", 120.0, true),
            ("point_turn", 0.0, true),
            ("jog", 0.0, true),
            // A move that ended: Go at zero velocity.
            ("go", 0.0, false),
            ("joystick", 0.0, false),
        ] {
            let stops = Arc::default();
            let mut base = Base::new("r1", Still(mode, wheels, Arc::clone(&stops)), None);
            assert_eq!(
                base.halt().await.unwrap(),
                moving,
                "{mode} at {wheels} mm/s"
            );
            assert_eq!(*stops.lock().unwrap(), 1, "{mode}: stopped all the same");
        }
    }
}
