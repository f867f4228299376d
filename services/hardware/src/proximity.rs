//! The proximity server (the thesis' PServer, §4.6.2): the 24 sonars and
//! the infrared detectors.
//!
//! ```text
//! rome/robot/<robot>/proximity/sonar     → {"sonar_mm":[…24],"time_ms":…}
//! rome/robot/<robot>/proximity/ir        → {"ir":[…24 of 0/1],"time_ms":…}
//! rome/robot/<robot>/proximity/timeout   {"max_mm":5000} or {"max_mm":[…24]}
//! rome/robot/<robot>/proximity/scan      published for every new scan
//! ```

use crate::device::{device_error, ProximityDevice, RawScan};
use crate::server::{Body, QuickRead, Service};
use rome_schema::robot::command::{parse_payload, Command, ReadIr, ReadSonar};
use rome_schema::robot::{
    IrReply, LockInfo, MaxRange, Scan, SetTimeout, SonarReply, TimeoutReply, SONARS,
};
use rome_schema::{ErrorCode, ErrorReply, Params};
use std::time::Duration;

/// The proximity server's commands.
pub const COMMANDS: &[&str] = &[ReadSonar::NAME, ReadIr::NAME, SetTimeout::NAME];
/// The longest maximum range a sonar can be given, mm (its physical reach).
pub const MAX_RANGE_MM: u32 = 10_000;
/// The shortest, mm (inside the transducer's ring-down nothing is heard).
pub const MIN_RANGE_MM: u32 = 150;

/// A parsed proximity command.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ProxCmd {
    /// `sonar`.
    Sonar,
    /// `ir`.
    Ir,
    /// `timeout`.
    Timeout([u32; SONARS]),
}

/// The proximity server's state.
pub struct Proximity<D: ProximityDevice> {
    robot: String,
    device: D,
    scan_period: Option<Duration>,
    last_published: Option<u64>,
    seq: u64,
}

impl<D: ProximityDevice> Proximity<D> {
    /// A proximity server for `device`, looking for new scans every
    /// `scan_period` and publishing each.
    pub fn new(robot: &str, device: D, scan_period: Option<Duration>) -> Self {
        Proximity {
            robot: robot.to_string(),
            device,
            scan_period,
            last_published: None,
            seq: 0,
        }
    }
}

/// The proximity server's read commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Read {
    Sonar,
    Ir,
}

/// A read's answer from a scan.
fn read_body(read: Read, s: RawScan) -> Body {
    match read {
        Read::Sonar => Body::json(&SonarReply {
            sonar_mm: s.sonar_mm.to_vec(),
            time_ms: s.time_ms,
        }),
        Read::Ir => Body::json(&IrReply {
            ir: Scan::ir_slots(s.ir),
            time_ms: s.time_ms,
        }),
    }
}

fn ranges(max: MaxRange) -> Result<[u32; SONARS], ErrorReply> {
    let each = match max {
        MaxRange::All(v) => vec![v; SONARS],
        MaxRange::Each(v) => v,
    };
    let arr: [u32; SONARS] = each.as_slice().try_into().map_err(|_| {
        ErrorReply::new(
            ErrorCode::WrongType,
            format!(
                "'timeout': max_mm must be one number or {SONARS} numbers, got {}",
                each.len()
            ),
        )
    })?;
    if let Some((i, v)) = arr
        .iter()
        .enumerate()
        .find(|(_, v)| !(MIN_RANGE_MM..=MAX_RANGE_MM).contains(*v))
    {
        return Err(ErrorReply::new(
            ErrorCode::OutOfRange,
            format!("'timeout': sonar {i}'s maximum range must be {MIN_RANGE_MM} … {MAX_RANGE_MM} mm, got {v}"),
        ));
    }
    Ok(arr)
}

impl<D: ProximityDevice> Service for Proximity<D> {
    type Cmd = ProxCmd;

    const COMMANDS: &'static [&'static str] = COMMANDS;
    const LOCKABLE: bool = false;
    const READS: &'static [&'static str] = &[ReadSonar::NAME, ReadIr::NAME];

    fn parse(
        &self,
        command: &str,
        params: Params,
        body: Option<&[u8]>,
    ) -> Result<ProxCmd, ErrorReply> {
        params.finish(command, &["priority", "wait_ms", "client", "op"])?;
        match command {
            ReadSonar::NAME => Ok(ProxCmd::Sonar),
            ReadIr::NAME => Ok(ProxCmd::Ir),
            SetTimeout::NAME => {
                let t: SetTimeout = parse_payload(body)?;
                Ok(ProxCmd::Timeout(ranges(t.max_mm)?))
            }
            other => Err(ErrorReply::new(
                ErrorCode::UnknownKey,
                format!("the proximity server has no command '{other}'"),
            )),
        }
    }

    async fn apply(&mut self, cmd: ProxCmd, _lock: Option<LockInfo>) -> Result<Body, ErrorReply> {
        match cmd {
            ProxCmd::Sonar => {
                let s = self.device.scan().await.map_err(device_error)?;
                Ok(read_body(Read::Sonar, s))
            }
            ProxCmd::Ir => {
                let s = self.device.scan().await.map_err(device_error)?;
                Ok(read_body(Read::Ir, s))
            }
            ProxCmd::Timeout(max) => {
                let now = self.device.set_timeout(max).await.map_err(device_error)?;
                Ok(Body::json(&TimeoutReply {
                    max_mm: now.to_vec(),
                }))
            }
        }
    }

    fn quick(&self) -> Option<QuickRead> {
        let peek = self.device.peek()?;
        Some(std::sync::Arc::new(move |command: &str, params: Params| {
            params.finish(command, &[]).ok()?;
            let read = match command {
                ReadSonar::NAME => Read::Sonar,
                ReadIr::NAME => Read::Ir,
                _ => return None,
            };
            Some(read_body(read, peek()?))
        }))
    }

    fn period(&self) -> Option<Duration> {
        self.scan_period
    }

    async fn tick(
        &mut self,
        _lock: Option<LockInfo>,
        _queued: usize,
    ) -> Option<(&'static str, Body)> {
        let scan: RawScan = match self.device.scan().await {
            Ok(s) => s,
            Err(e) => {
                tracing::warn!(robot = %self.robot, error = %e, "scan not read");
                return None;
            }
        };
        if self.last_published == Some(scan.time_ms) {
            return None;
        }
        self.last_published = Some(scan.time_ms);
        self.seq += 1;
        Some((
            "scan",
            Body::json(&Scan {
                robot: self.robot.clone(),
                seq: self.seq,
                time_ms: scan.time_ms,
                sonar_mm: scan.sonar_mm.to_vec(),
                ir: Scan::ir_slots(scan.ir),
            }),
        ))
    }
}
