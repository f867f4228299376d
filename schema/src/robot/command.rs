//! Every hardware-server command, defined once: its key chunk, whether it
//! acts on the device, its payload or its own selector parameters, and
//! what it answers. The client library sends each through [`Command`];
//! the servers parse payloads with [`parse_payload`] and name commands by
//! the same [`Command::NAME`], so the two ends cannot drift apart.
//!
//! ```text
//! get rome/robot/r1/base/move  payload: {"distance_mm":2000}  -> {"command":"move","mode":"point_go"}
//! get rome/robot/r1/base/pose                                 -> {"x_mm":…,"y_mm":…,"heading_deg":…}
//! get rome/robot/r1/camera/up/rows?rows=120,241               -> two rows of pixels
//! get rome/robot/r1/base/lock?owner=c7-r1;ttl_ms=2500         -> {"holder":"c7-r1","fence":…,"ttl_ms":2500}
//! ```
//!
//! The parameters every command may carry (priority, fence, wait, op,
//! client, suppression) are [`super::Meta`]'s.

use super::{
    format_rows, param, AdjustPose, BumperReply, Done, Go, IrReply, Jog, LockGrant, ModeReply,
    Move, PoseReply, SetBumper, SetPose, SetTimeout, SizeReply, SonarReply, SpeedReply, Stop,
    TimeoutReply, Turn, Unlocked, WheelSpeedReply,
};
use crate::{decode, encode, ErrorCode, ErrorReply, Params};
use serde::de::{DeserializeOwned, IgnoredAny};
use serde::Serialize;

/// One command to a hardware server.
pub trait Command {
    /// Its key chunk: `<root>/robot/<robot>/<device>/<NAME>`.
    const NAME: &'static str;
    /// Whether it acts on the device (moves it, changes a setting): such
    /// a command carries a request id, so sending it again is safe.
    const ACTS: bool;
    /// What the server answers (an image's bytes are not JSON:
    /// [`IgnoredAny`]).
    type Reply: DeserializeOwned;

    /// Its JSON payload, if it has one.
    fn payload(&self) -> Option<Vec<u8>> {
        None
    }

    /// Its own selector parameters.
    fn params(&self) -> Vec<(&'static str, String)> {
        Vec::new()
    }
}

/// A command whose payload is itself, as JSON.
pub trait Payload: Command + Serialize + DeserializeOwned {
    /// A payload to show when one is missing or wrong.
    const EXAMPLE: &'static str;

    /// Refuses what JSON lets through but the device cannot take.
    fn check(&self) -> Result<(), ErrorReply> {
        Ok(())
    }
}

/// Decodes and checks a command's payload strictly, naming the command
/// and showing an example on error.
pub fn parse_payload<C: Payload>(payload: Option<&[u8]>) -> Result<C, ErrorReply> {
    let (name, example) = (C::NAME, C::EXAMPLE);
    let bytes = payload.filter(|p| !p.is_empty()).ok_or_else(|| {
        ErrorReply::new(
            ErrorCode::BadJson,
            format!("'{name}' needs a JSON payload such as {example}"),
        )
    })?;
    let command: C = decode(bytes, &format!("'{name}' payload")).map_err(|e| {
        let text = e.to_string();
        let code = if text.contains("invalid type") || text.contains("missing field") {
            ErrorCode::WrongType
        } else {
            ErrorCode::BadJson
        };
        ErrorReply::new(code, format!("{text}; expected {example}"))
    })?;
    command.check()?;
    Ok(command)
}

/// Refuses a number that is not finite (JSON cannot carry one, but a
/// decoder may overflow to one).
fn finite(command: &str, fields: &[(&str, f64)]) -> Result<(), ErrorReply> {
    for (name, v) in fields {
        if !v.is_finite() {
            return Err(ErrorReply::new(
                ErrorCode::OutOfRange,
                format!("'{command}': {name} must be a finite number"),
            ));
        }
    }
    Ok(())
}

/// A command whose payload is itself.
macro_rules! payload_command {
    ($ty:ty, $name:literal, $reply:ty, $example:literal, |$c:ident| $check:expr) => {
        impl Command for $ty {
            const NAME: &'static str = $name;
            const ACTS: bool = true;
            type Reply = $reply;
            fn payload(&self) -> Option<Vec<u8>> {
                Some(encode(self))
            }
        }
        impl Payload for $ty {
            const EXAMPLE: &'static str = $example;
            fn check(&self) -> Result<(), ErrorReply> {
                let $c = self;
                finite($name, &$check)
            }
        }
    };
}

payload_command!(
    Move,
    "move",
    Done,
    r#"{"distance_mm":2000,"velocity_mm_s":300}"#,
    |m| [
        ("distance_mm", m.distance_mm),
        ("velocity_mm_s", m.velocity_mm_s),
        ("accel_mm_s2", m.accel_mm_s2)
    ]
);
payload_command!(Turn, "turn", Done, r#"{"degrees":90}"#, |t| [
    ("degrees", t.degrees),
    ("velocity_deg_s", t.velocity_deg_s),
    ("accel_deg_s2", t.accel_deg_s2)
]);
payload_command!(Go, "go", Done, r#"{"velocity_mm_s":400}"#, |g| [(
    "velocity_mm_s",
    g.velocity_mm_s
)]);
payload_command!(Jog, "jog", Done, r#"{"rate_deg_s":-4}"#, |j| [(
    "rate_deg_s",
    j.rate_deg_s
)]);
payload_command!(Stop, "stop", Done, r#"{"emergency":true}"#, |_s| []);
payload_command!(
    SetPose,
    "set-pose",
    Done,
    r#"{"x_mm":0,"y_mm":0,"heading_deg":90}"#,
    |p| [("heading_deg", p.heading_deg)]
);
payload_command!(
    AdjustPose,
    "adjust-pose",
    Done,
    r#"{"dx_mm":-120,"dy_mm":0,"dheading_deg":1.5}"#,
    |a| [("dheading_deg", a.dheading_deg)]
);
payload_command!(SetBumper, "set-bumper", Done, r#"{"watch":true}"#, |_s| []);
payload_command!(
    SetTimeout,
    "timeout",
    TimeoutReply,
    r#"{"max_mm":5000}"#,
    |_t| []
);

/// A command that only reads, without payload or parameters of its own.
macro_rules! read_command {
    ($(#[$doc:meta])* $ty:ident, $name:literal, $reply:ty) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
        pub struct $ty;
        impl Command for $ty {
            const NAME: &'static str = $name;
            const ACTS: bool = false;
            type Reply = $reply;
        }
    };
}

read_command!(
    /// `pose` (base): the pose in virtual 32-bit coordinates.
    ReadPose, "pose", PoseReply
);
read_command!(
    /// `bumper` (base): the bumper status.
    ReadBumper, "bumper", BumperReply
);
read_command!(
    /// `speed` (base): the velocity setting.
    ReadSpeed, "speed", SpeedReply
);
read_command!(
    /// `wheel-speed` (base): the mean wheel speed.
    ReadWheelSpeed, "wheel-speed", WheelSpeedReply
);
read_command!(
    /// `mode` (base): the operating mode.
    ReadMode, "mode", ModeReply
);
read_command!(
    /// `sonar` (proximity): the 24 ranges.
    ReadSonar, "sonar", SonarReply
);
read_command!(
    /// `ir` (proximity): the 24 infrared slots.
    ReadIr, "ir", IrReply
);
read_command!(
    /// `size` (camera): the image's width and height.
    ReadSize, "size", SizeReply
);

/// `grab` (camera): the last image, raw (`format=raw`, the default) or as
/// a PNG (`format=png`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Grab {
    /// A PNG instead of raw pixels.
    pub png: bool,
}

impl Command for Grab {
    const NAME: &'static str = "grab";
    const ACTS: bool = false;
    type Reply = IgnoredAny;

    fn params(&self) -> Vec<(&'static str, String)> {
        if self.png {
            vec![(param::FORMAT, "png".into())]
        } else {
            Vec::new()
        }
    }
}

impl Grab {
    /// Takes `format` from the parameters.
    pub fn parse(params: &mut Params) -> Result<Grab, ErrorReply> {
        match params.take_id(param::FORMAT)?.as_deref() {
            None | Some("raw") => Ok(Grab { png: false }),
            Some("png") => Ok(Grab { png: true }),
            Some(other) => Err(ErrorReply::new(
                ErrorCode::BadParameter,
                format!("'grab': format must be 'raw' or 'png', got '{other}'"),
            )),
        }
    }
}

/// `rows` (camera): some rows of the last image (`rows=120,200-263`).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Rows {
    /// The rows, in the order the reply carries them.
    pub rows: Vec<u32>,
}

impl Command for Rows {
    const NAME: &'static str = "rows";
    const ACTS: bool = false;
    type Reply = IgnoredAny;

    fn params(&self) -> Vec<(&'static str, String)> {
        vec![(param::ROWS, format_rows(&self.rows))]
    }
}

/// `lock` (base, cameras): takes the lock token, or renews a grant when
/// the request carries its `fence`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TakeLock {
    /// The holder's owner id (`anonymous` when absent).
    pub owner: Option<String>,
    /// How long the grant lasts without a renewal, ms.
    pub ttl_ms: Option<u64>,
    /// The grant to renew; the server reads it with the parameters every
    /// command may carry ([`super::Meta::fence`]).
    pub renew: Option<u64>,
}

impl Command for TakeLock {
    const NAME: &'static str = "lock";
    const ACTS: bool = false;
    type Reply = LockGrant;

    fn params(&self) -> Vec<(&'static str, String)> {
        let mut params = Vec::with_capacity(2);
        if let Some(owner) = &self.owner {
            params.push((param::OWNER, owner.clone()));
        }
        if let Some(ttl) = self.ttl_ms {
            params.push((param::TTL_MS, ttl.to_string()));
        }
        if let Some(fence) = self.renew {
            params.push((param::FENCE, fence.to_string()));
        }
        params
    }
}

impl TakeLock {
    /// Takes `owner` and `ttl_ms` (within [`super::LOCK_TTL_RANGE_MS`]);
    /// `renew` is the fence [`super::Meta::take`] took before.
    pub fn parse(params: &mut Params, fence: Option<u64>) -> Result<TakeLock, ErrorReply> {
        let owner = params.take_id(param::OWNER)?;
        let (lo, hi) = super::LOCK_TTL_RANGE_MS;
        let ttl_ms = params
            .take_int(param::TTL_MS, i128::from(lo), i128::from(hi))?
            .map(|t| t as u64);
        Ok(TakeLock {
            owner,
            ttl_ms,
            renew: fence,
        })
    }
}

/// `unlock` (base, cameras): gives the token back; the request carries
/// the grant's `fence` (a [`super::Meta`] parameter).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReleaseLock {
    /// The grant's fencing number.
    pub fence: u64,
}

impl Command for ReleaseLock {
    const NAME: &'static str = "unlock";
    const ACTS: bool = false;
    type Reply = Unlocked;

    fn params(&self) -> Vec<(&'static str, String)> {
        vec![(param::FENCE, self.fence.to_string())]
    }
}

#[cfg(test)]
mod tests;
