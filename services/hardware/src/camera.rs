//! The camera server (the thesis' CServer, §4.6.4): one per camera, each
//! under its own key. It grabs periodically (every 0.5 s by default) and
//! serves the last frame; while a client holds its lock it stops grabbing,
//! so the holder reads one frozen image row by row.
//!
//! ```text
//! rome/robot/<robot>/camera/<camera>/size    → {"width":512,"height":482}
//! rome/robot/<robot>/camera/<camera>/grab    → gray8 bytes (?format=png for PNG)
//! rome/robot/<robot>/camera/<camera>/rows    ?rows=120,241,360 → those rows' bytes, in order
//! rome/robot/<robot>/camera/<camera>/lock    ?owner=ID;ttl_ms=2500
//! rome/robot/<robot>/camera/<camera>/unlock  ?fence=N
//! rome/robot/<robot>/camera/<camera>/frame   published after each grab
//! ```

use crate::device::{CameraDevice, Frame};
use crate::locked;
use crate::server::{Body, QuickRead, Service};
use rome_schema::robot::command::{Command, Grab, ReadSize, Rows};
pub use rome_schema::robot::MAX_ROWS;
use rome_schema::robot::{format_rows, param, parse_rows, FrameInfo, Gray8, LockInfo, SizeReply};
use rome_schema::{ErrorCode, ErrorReply, Params};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::bytes::Encoding;

/// The camera server's commands.
pub const COMMANDS: &[&str] = &[ReadSize::NAME, Grab::NAME, Rows::NAME];
/// The thesis' grab period.
pub const DEFAULT_PERIOD: Duration = Duration::from_millis(500);
/// Longest row list a reply can describe (as ranges), characters: the rest
/// of the 255-byte schema holds the image's size, frame and time.
pub const MAX_ROW_LIST_LEN: usize = 160;

/// A parsed camera command.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CameraCmd {
    /// `size`.
    Size,
    /// `grab`, as PNG when true.
    Grab {
        /// PNG instead of raw gray8.
        png: bool,
    },
    /// `rows`.
    Rows(Vec<u32>),
}

/// The last frame and its grab number.
#[derive(Debug, Clone)]
struct Shot {
    frame: Arc<Frame>,
    n: u64,
}

/// The camera server's state: the device and the last frame.
pub struct Camera<D: CameraDevice> {
    robot: String,
    name: String,
    device: D,
    period: Duration,
    /// Shared with the quick reads answered from the queryable's callback.
    last: Arc<Mutex<Option<Shot>>>,
}

impl<D: CameraDevice> Camera<D> {
    /// A camera server for `device`, grabbing every `period`.
    pub fn new(robot: &str, name: &str, device: D, period: Duration) -> Self {
        Camera {
            robot: robot.to_string(),
            name: name.to_string(),
            device,
            period,
            last: Arc::new(Mutex::new(None)),
        }
    }

    fn shot(&self) -> Option<Shot> {
        locked(&self.last).clone()
    }

    async fn grab(&mut self) -> Result<(), ErrorReply> {
        let frame = self
            .device
            .grab()
            .await
            .map_err(|e| ErrorReply::new(ErrorCode::Device, e.to_string()))?;
        let mut last = locked(&self.last);
        let n = last.as_ref().map_or(0, |s| s.n) + 1;
        *last = Some(Shot {
            frame: Arc::new(frame),
            n,
        });
        Ok(())
    }

    /// The last frame and its grab number, grabbing one first if there is
    /// none yet.
    async fn current(&mut self) -> Result<Shot, ErrorReply> {
        if self.shot().is_none() {
            self.grab().await?;
        }
        self.shot()
            .ok_or_else(|| ErrorReply::new(ErrorCode::Device, "no frame grabbed"))
    }
}

/// The rows asked for (`rows=120,241,360`), checked against the image's
/// `height` and what a reply can describe.
fn rows_param(mut params: Params, height: u32) -> Result<Vec<u32>, ErrorReply> {
    let list = params.take_text(param::ROWS).ok_or_else(|| {
        ErrorReply::new(
            ErrorCode::BadParameter,
            "'rows' needs the parameter 'rows' (e.g. rows=120,241,360)",
        )
    })?;
    params.finish(
        "rows",
        &["rows", "priority", "fence", "wait_ms", "client", "op"],
    )?;
    let rows = parse_rows(&list, MAX_ROWS)?;
    if rows.is_empty() || rows.len() > MAX_ROWS {
        return Err(ErrorReply::new(
            ErrorCode::OutOfRange,
            format!("'rows': ask for 1 … {MAX_ROWS} rows, got {}", rows.len()),
        ));
    }
    // The list travels back in the reply's encoding, which Zenoh limits to
    // 255 bytes.
    if format_rows(&rows).len() > MAX_ROW_LIST_LEN {
        return Err(ErrorReply::new(
            ErrorCode::OutOfRange,
            format!(
                "'rows': the list is too long to describe in a reply ({} characters as ranges, at most {MAX_ROW_LIST_LEN}); ask for runs of rows (200-263) or fewer rows",
                format_rows(&rows).len()
            ),
        ));
    }
    if let Some(r) = rows.iter().find(|r| **r >= height) {
        return Err(ErrorReply::new(
            ErrorCode::OutOfRange,
            format!(
                "'rows': row {r} is outside the image (rows 0 … {})",
                height - 1
            ),
        ));
    }
    Ok(rows)
}

/// The bytes of `rows` of a shot, in order.
fn rows_body(shot: &Shot, rows: Vec<u32>) -> Result<Body, ErrorReply> {
    let frame = &shot.frame;
    let w = frame.width as usize;
    let mut out = Vec::with_capacity(w * rows.len());
    for r in &rows {
        // The device's frame may be smaller than the size it declared.
        let row = frame.row(*r).ok_or_else(|| {
            ErrorReply::new(
                ErrorCode::Device,
                format!(
                    "row {r} is not in the grabbed frame ({} × {})",
                    frame.width, frame.height
                ),
            )
        })?;
        out.extend_from_slice(row);
    }
    Ok(Body::Binary(out, encoding(frame, shot.n, Some(rows))))
}

/// The encoding of a raw reply: gray8 and where it came from.
fn encoding(frame: &Frame, frames: u64, rows: Option<Vec<u32>>) -> Encoding {
    let g = Gray8 {
        width: frame.width,
        height: frame.height,
        frame: frames,
        time_ms: frame.time_ms,
        rows,
    };
    Encoding::APPLICATION_OCTET_STREAM.with_schema(g.schema())
}

fn png(frame: &Frame) -> Result<Vec<u8>, ErrorReply> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(
            &frame.bytes(),
            frame.width,
            frame.height,
            image::ExtendedColorType::L8,
        )
        .map_err(|e| ErrorReply::new(ErrorCode::Device, format!("PNG encoding failed: {e}")))?;
    Ok(out)
}

impl<D: CameraDevice> Service for Camera<D> {
    type Cmd = CameraCmd;

    const COMMANDS: &'static [&'static str] = COMMANDS;
    const LOCKABLE: bool = true;
    const READS: &'static [&'static str] = &[ReadSize::NAME];

    fn parse(
        &self,
        command: &str,
        mut params: Params,
        _body: Option<&[u8]>,
    ) -> Result<CameraCmd, ErrorReply> {
        match command {
            ReadSize::NAME => {
                params.finish(command, &["priority", "fence", "wait_ms", "client", "op"])?;
                Ok(CameraCmd::Size)
            }
            Grab::NAME => {
                let grab = Grab::parse(&mut params)?;
                params.finish(
                    command,
                    &["format", "priority", "fence", "wait_ms", "client", "op"],
                )?;
                Ok(CameraCmd::Grab { png: grab.png })
            }
            Rows::NAME => {
                let (_, height) = self.device.size();
                let rows = rows_param(params, height)?;
                Ok(CameraCmd::Rows(rows))
            }
            other => Err(ErrorReply::new(
                ErrorCode::UnknownKey,
                format!("the camera server has no command '{other}'"),
            )),
        }
    }

    async fn apply(&mut self, cmd: CameraCmd, _lock: Option<LockInfo>) -> Result<Body, ErrorReply> {
        match cmd {
            CameraCmd::Size => {
                let (width, height) = self.device.size();
                Ok(Body::json(&SizeReply { width, height }))
            }
            CameraCmd::Grab { png: as_png } => {
                let shot = self.current().await?;
                if as_png {
                    Ok(Body::Binary(png(&shot.frame)?, Encoding::IMAGE_PNG))
                } else {
                    Ok(Body::Binary(
                        shot.frame.bytes(),
                        encoding(&shot.frame, shot.n, None),
                    ))
                }
            }
            CameraCmd::Rows(rows) => rows_body(&self.current().await?, rows),
        }
    }

    fn quick(&self) -> Option<QuickRead> {
        let (last, (_, height)) = (self.last.clone(), self.device.size());
        Some(Arc::new(move |command: &str, params: Params| {
            if command != Rows::NAME {
                return None;
            }
            let rows = rows_param(params, height).ok()?;
            // Before the first grab the event loop grabs one.
            let shot = locked(&last).clone()?;
            rows_body(&shot, rows).ok()
        }))
    }

    fn period(&self) -> Option<Duration> {
        Some(self.period)
    }

    async fn tick(
        &mut self,
        lock: Option<LockInfo>,
        _queued: usize,
    ) -> Option<(&'static str, Body)> {
        if lock.is_some() {
            // Frozen while locked (§4.6.4).
            return None;
        }
        if let Err(e) = self.grab().await {
            tracing::warn!(robot = %self.robot, camera = %self.name, error = %e, "grab failed");
            return None;
        }
        let shot = self.shot()?;
        let frame = &shot.frame;
        Some((
            "frame",
            Body::json(&FrameInfo {
                robot: self.robot.clone(),
                camera: self.name.clone(),
                frame: shot.n,
                time_ms: frame.time_ms,
                width: frame.width,
                height: frame.height,
            }),
        ))
    }
}
