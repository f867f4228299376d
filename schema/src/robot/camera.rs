//! Messages of a camera server (CServer, §4.6.4): the image size, the frame
//! stream, and the binary image replies' schema and row lists.

use crate::{ErrorCode, ErrorReply};
use serde::{Deserialize, Serialize};

/// `size`: the image size.
///
/// ```text
/// {"width":512,"height":482}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SizeReply {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

/// `frame`: published after each periodic grab.
///
/// ```text
/// {"robot":"r1","camera":"up","frame":31,"time_ms":15500,"width":512,"height":482}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameInfo {
    /// The robot.
    pub robot: String,
    /// The camera.
    pub camera: String,
    /// Grabs so far.
    pub frame: u64,
    /// When it was grabbed, device ms.
    pub time_ms: u64,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

/// The encoding schema of a binary image reply (`grab`, `rows`):
/// 8-bit gray, row-major, one byte per pixel.
///
/// ```text
/// application/octet-stream;gray8 width=512 height=482 frame=31 time_ms=15500 rows=120,241,360
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Gray8 {
    /// Columns.
    pub width: u32,
    /// Rows in the image (not in the payload).
    pub height: u32,
    /// The grab this came from.
    pub frame: u64,
    /// When it was grabbed, device ms.
    pub time_ms: u64,
    /// The rows sent, in order (all rows for `grab`).
    pub rows: Option<Vec<u32>>,
}

impl Gray8 {
    /// The schema text carried after `application/octet-stream;`.
    pub fn schema(&self) -> String {
        let mut s = format!(
            "gray8 width={} height={} frame={} time_ms={}",
            self.width, self.height, self.frame, self.time_ms
        );
        if let Some(rows) = &self.rows {
            s.push_str(&format!(" rows={}", format_rows(rows)));
        }
        s
    }

    /// Parses [`Gray8::schema`]'s text.
    pub fn parse(schema: &str) -> Result<Gray8, ErrorReply> {
        let bad = |why: &str| {
            ErrorReply::new(
                ErrorCode::BadParameter,
                format!("image schema '{schema}': {why}"),
            )
        };
        let mut words = schema.split_whitespace();
        if words.next() != Some("gray8") {
            return Err(bad("not gray8"));
        }
        let mut g = Gray8 {
            width: 0,
            height: 0,
            frame: 0,
            time_ms: 0,
            rows: None,
        };
        for word in words {
            let (k, v) = word
                .split_once('=')
                .ok_or_else(|| bad("a word without '='"))?;
            let num = |v: &str| v.parse::<u64>().map_err(|_| bad("a field is not a number"));
            let side = |v: &str| {
                num(v)?
                    .try_into()
                    .ok()
                    .filter(|n| (1..=MAX_IMAGE_SIDE).contains(n))
                    .ok_or_else(|| bad(&format!("width and height must be 1 … {MAX_IMAGE_SIDE}")))
            };
            match k {
                "width" => g.width = side(v)?,
                "height" => g.height = side(v)?,
                "frame" => g.frame = num(v)?,
                "time_ms" => g.time_ms = num(v)?,
                "rows" => g.rows = Some(parse_rows(v, MAX_ROWS).map_err(|e| bad(&e.message))?),
                _ => {}
            }
        }
        if g.width == 0 || g.height == 0 {
            return Err(bad("it needs a width and a height"));
        }
        if let Some(r) = g.rows.iter().flatten().find(|r| **r >= g.height) {
            return Err(bad(&format!(
                "row {r} is outside the image's {} rows",
                g.height
            )));
        }
        Ok(g)
    }
}

/// The most rows one `rows` request may ask for, and one reply may carry.
pub const MAX_ROWS: usize = 64;

/// The widest and tallest image a camera reply may describe, pixels: far
/// above any camera's, low enough that a reply's size cannot be absurd.
pub const MAX_IMAGE_SIDE: u32 = 8_192;

/// The longest schema Zenoh carries in an encoding, bytes.
pub const MAX_SCHEMA_LEN: usize = 255;

/// A row list as text, runs of consecutive rows as ranges
/// (`120,200-263,360`), so the list fits in an encoding's schema.
pub fn format_rows(rows: &[u32]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < rows.len() {
        let mut j = i;
        while j + 1 < rows.len() && rows[j + 1] == rows[j].wrapping_add(1) {
            j += 1;
        }
        if j > i + 1 {
            parts.push(format!("{}-{}", rows[i], rows[j]));
        } else {
            parts.extend(rows[i..=j].iter().map(u32::to_string));
        }
        i = j + 1;
    }
    parts.join(",")
}

/// Parses a row list: row numbers and ranges separated by ','
/// (`120,241,360`, `200-263`), refusing a list of more than `max` rows
/// before expanding it, whoever wrote it.
pub fn parse_rows(text: &str, max: usize) -> Result<Vec<u32>, ErrorReply> {
    let bad = || {
        ErrorReply::new(
            ErrorCode::WrongType,
            format!(
                "parameter 'rows' must be row numbers or ranges (200-263) separated by ',', got '{text}'"
            ),
        )
    };
    let too_many = || {
        ErrorReply::new(
            ErrorCode::OutOfRange,
            format!("parameter 'rows' asks for more than {max} rows"),
        )
    };
    let mut out = Vec::new();
    for part in text.split(',') {
        let part = part.trim();
        match part.split_once('-') {
            Some((a, b)) => {
                let a: u32 = a.trim().parse().map_err(|_| bad())?;
                let b: u32 = b.trim().parse().map_err(|_| bad())?;
                if b < a {
                    return Err(bad());
                }
                if (b - a) as usize >= max.saturating_sub(out.len()) {
                    return Err(too_many());
                }
                out.extend(a..=b);
            }
            None => {
                if out.len() >= max {
                    return Err(too_many());
                }
                out.push(part.parse().map_err(|_| bad())?)
            }
        }
    }
    Ok(out)
}
