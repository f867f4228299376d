//! What the hardware servers send besides JSON replies: camera images
//! (raw grey levels or PNG), and the state, scan and frame streams a
//! client follows.

use crate::ClientError;
use rome_schema::robot::Gray8;
use rome_schema::{decode, ErrorCode};
use serde::de::DeserializeOwned;
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::handlers::RingChannelHandler;
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;

/// An image (or some of its rows) from a camera server, 8-bit gray.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Columns.
    pub width: u32,
    /// Rows of the whole image.
    pub height: u32,
    /// The grab it came from.
    pub frame: u64,
    /// When it was grabbed, device ms.
    pub time_ms: u64,
    /// The rows carried, in order (every row for a full grab).
    pub rows: Vec<u32>,
    /// `rows.len() × width` bytes.
    pub pixels: Vec<u8>,
}

impl Image {
    /// The pixels of the `k`-th row carried, or `None` past the last.
    pub fn row(&self, k: usize) -> Option<&[u8]> {
        let w = self.width as usize;
        self.pixels
            .get(k.checked_mul(w)?..k.checked_add(1)?.checked_mul(w)?)
    }

    /// The pixels of image row `row`, if this image carries it.
    pub fn image_row(&self, row: u32) -> Option<&[u8]> {
        self.row(self.rows.iter().position(|r| *r == row)?)
    }
}

pub(super) fn image(bytes: Vec<u8>, encoding: &Encoding) -> Result<Image, ClientError> {
    let text = encoding.to_string();
    let schema = text.split_once(';').map(|(_, s)| s).unwrap_or_default();
    // Gray8::parse bounds the size and the row list; the payload must
    // match them before anything is built on the server's numbers.
    let g = Gray8::parse(schema)?;
    let carried = g.rows.as_ref().map_or(g.height as usize, Vec::len);
    if bytes.len() as u64 != carried as u64 * u64::from(g.width) {
        return Err(ClientError::Server(rome_schema::ErrorReply::new(
            ErrorCode::Device,
            format!(
                "image reply has {} bytes, not {carried} rows × {} columns",
                bytes.len(),
                g.width
            ),
        )));
    }
    let rows = g.rows.unwrap_or_else(|| (0..g.height).collect());
    Ok(Image {
        width: g.width,
        height: g.height,
        frame: g.frame,
        time_ms: g.time_ms,
        rows,
        pixels: bytes,
    })
}

/// Messages a stream keeps for a reader that falls behind; older ones are
/// dropped.
pub const STREAM_BACKLOG: usize = 64;

/// A subscription to a server's stream (`state`, `scan`, `frame`). A
/// reader that falls more than [`STREAM_BACKLOG`] messages behind loses
/// the oldest: sensor streams are about the newest reading.
pub struct Stream<T> {
    pub(super) subscriber: Subscriber<RingChannelHandler<Sample>>,
    pub(super) what: String,
    pub(super) skipped: std::sync::Mutex<Skipped>,
    pub(super) _t: std::marker::PhantomData<T>,
}

/// Messages a stream skipped, for warnings that cannot flood the log.
#[derive(Default)]
pub(super) struct Skipped {
    pub(super) total: u64,
    pub(super) unreported: u64,
    pub(super) reported_at: Option<std::time::Instant>,
}

/// The least time between two warnings about skipped stream messages.
pub(super) const SKIP_WARNING_EVERY: Duration = Duration::from_secs(10);

impl<T: DeserializeOwned> Stream<T> {
    /// Decodes a message; one that does not decode (anyone on the network
    /// may publish on a stream's key) is skipped with a warning, so a
    /// reader never stops on one bad message.
    pub(super) fn decoded(&self, sample: &Sample) -> Option<T> {
        match decode(&sample.payload().to_bytes(), &self.what) {
            Ok(t) => Some(t),
            Err(e) => {
                // Someone flooding a stream with garbage must not fill the
                // reader's disk with warnings: the first, then one every
                // SKIP_WARNING_EVERY with the count in between.
                let mut s = self.skipped.lock().unwrap_or_else(|p| p.into_inner());
                s.total += 1;
                s.unreported += 1;
                if s.reported_at
                    .is_none_or(|t| t.elapsed() >= SKIP_WARNING_EVERY)
                {
                    tracing::warn!(
                        key = %sample.key_expr(),
                        error = %e,
                        skipped = s.unreported,
                        total = s.total,
                        "stream messages skipped"
                    );
                    s.unreported = 0;
                    s.reported_at = Some(std::time::Instant::now());
                }
                None
            }
        }
    }

    /// Messages skipped so far because they did not decode.
    pub fn skipped(&self) -> u64 {
        self.skipped.lock().map_or(0, |s| s.total)
    }

    /// The next message that decodes; `None` when the session closed.
    pub async fn next(&self) -> Option<Result<T, ClientError>> {
        Some(self.next_stamped().await?.map(|(t, _)| t))
    }

    /// The next message that decodes, with when its reading was taken: the
    /// publication's timestamp, which the hardware servers set to the
    /// moment they read the device (`None` from a publisher that sets none).
    pub async fn next_stamped(
        &self,
    ) -> Option<Result<(T, Option<std::time::SystemTime>), ClientError>> {
        loop {
            let sample = rome_clock::idle(self.subscriber.recv_async()).await.ok()?;
            if let Some(t) = self.decoded(&sample) {
                let at = sample.timestamp().map(|ts| ts.get_time().to_system_time());
                return Some(Ok((t, at)));
            }
        }
    }

    /// The newest message that decodes: waits for one, then skips any
    /// queued behind it, so a reader slower than the stream (over a slow
    /// link) steers by the latest reading rather than by one seconds old.
    pub async fn latest(&self) -> Option<Result<T, ClientError>> {
        let mut newest = None;
        loop {
            if newest.is_none() {
                let sample = rome_clock::idle(self.subscriber.recv_async()).await.ok()?;
                newest = self.decoded(&sample);
            }
            while let Ok(Some(sample)) = self.subscriber.try_recv() {
                if let Some(t) = self.decoded(&sample) {
                    newest = Some(t);
                }
            }
            if let Some(t) = newest {
                return Some(Ok(t));
            }
        }
    }
}
