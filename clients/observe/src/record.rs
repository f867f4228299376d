//! `rome record`: everything heard on some keys, written to an MCAP file,
//! as `ros2 bag record` does; `rome replay` puts it back.
//!
//! ```text
//! rome record -o run.mcap                       # every key under the root
//! rome record -o r1.mcap 'rome/robot/r1/**' 'rome/sim/r1/truth'
//! ```
//!
//! The file has one channel per key (and encoding): JSON messages on a
//! `json` channel with a JSON Schema (`jsonschema`) taken from the key's
//! first message, other payloads (images, bytes) as they came, with the
//! Zenoh encoding as the channel's message encoding. Every channel's
//! metadata carries `zenoh.encoding`, and `zenoh.kind` (`put` or `delete`).
//! Log times are when the message was heard, in nanoseconds since the Unix
//! epoch; publish times are the sender's Zenoh timestamp where it set one.
//! The `mcap` CLI (`mcap info run.mcap`) and Foxglove open the file.

use anyhow::Context;
use rome_common::args::{CommonArgs, Side};
use rome_common::exit;
use rome_common::progress::Progress;
use std::collections::{BTreeMap, HashMap};
use std::io::{BufWriter, Seek, Write};
use std::path::{Path, PathBuf};
use std::time::SystemTime;
use tokio::sync::{mpsc, oneshot};
use zenoh::bytes::Encoding;
use zenoh::sample::{Sample, SampleKind};
use zenoh::Session;

/// Flags of `rome record`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The MCAP file to write.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// Key expressions to record [default: everything under the root, ROOT/**].
    pub keys: Vec<String>,
    /// Stop after this many seconds (otherwise at Ctrl-C).
    #[arg(long, value_name = "SECS")]
    pub duration: Option<f64>,
}

/// What a recording holds.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Summary {
    /// Messages written.
    pub messages: u64,
    /// Channels (keys and encodings).
    pub channels: usize,
    /// Payload bytes written.
    pub bytes: u64,
    /// From the first message to the last, seconds.
    pub span_s: f64,
}

/// Records until Ctrl-C or `--duration`.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let duration = (args.duration)
        .map(|d| rome_common::seconds("--duration", d))
        .transpose()?;
    let keys = common.keys_or_all(&args.keys)?;
    let session = common.open(Side::Client).await?;
    if !common.listen.is_empty() {
        // Where others reach it, with the port a `:0` endpoint was given.
        let at = rome_client::net::locators(&session).await;
        eprintln!("{}{}", rome_client::net::LISTENING, at.join(" "));
    }
    let recorder = Recorder::start(&session, &keys, &args.output, true).await?;
    eprintln!(
        "rome record: recording {} to {} (Ctrl-C to stop)",
        keys.join(", "),
        args.output.display()
    );
    let until = async {
        match duration {
            Some(d) => tokio::time::sleep(d).await,
            None => std::future::pending().await,
        }
    };
    tokio::select! {
        _ = until => {}
        _ = exit::interrupted() => {}
    }
    let summary = recorder.stop().await?;
    eprintln!(
        "rome record: {} message(s) on {} channel(s), {} bytes over {:.1} s in {}",
        summary.messages,
        summary.channels,
        summary.bytes,
        summary.span_s,
        args.output.display()
    );
    Ok(exit::OK)
}

/// A recording in progress: subscribers feeding an MCAP writer.
pub struct Recorder {
    stop: oneshot::Sender<()>,
    task: tokio::task::JoinHandle<anyhow::Result<Summary>>,
}

impl Recorder {
    /// Subscribes to `keys` on `session` and writes what comes to `path`;
    /// with `progress`, shows how much on stderr.
    pub async fn start(
        session: &Session,
        keys: &[String],
        path: &Path,
        progress: bool,
    ) -> anyhow::Result<Self> {
        let file = std::fs::File::create(path)
            .with_context(|| format!("cannot create {}", path.display()))?;
        let mut writer = Mcap::new(BufWriter::new(file))
            .with_context(|| format!("cannot start an MCAP file in {}", path.display()))?;
        let (tx, mut rx) = mpsc::unbounded_channel::<(Sample, u64)>();
        let mut subscribers = Vec::new();
        for key in keys {
            let tx = tx.clone();
            let sub = session
                .declare_subscriber(key.clone())
                .callback(move |s| {
                    let _ = tx.send((s, now_ns()));
                })
                .await
                .map_err(|e| anyhow::anyhow!("cannot subscribe to '{key}': {e}"))?;
            subscribers.push(sub);
        }
        drop(tx);
        let (stop, mut stopped) = oneshot::channel();
        let task = tokio::spawn(async move {
            let mut progress = progress.then(|| Progress::counter("recording", "messages"));
            loop {
                tokio::select! {
                    biased;
                    heard = rx.recv() => {
                        let Some((sample, at)) = heard else { break };
                        writer.write(&sample, at)?;
                        if let Some(p) = &mut progress {
                            let note = format!("{} channels, {}", writer.summary.channels, rome_common::progress::size(writer.summary.bytes));
                            p.set(writer.summary.messages, &note);
                        }
                    }
                    _ = &mut stopped => break,
                }
            }
            drop(subscribers);
            // What was already heard goes in too.
            while let Ok((sample, at)) = rx.try_recv() {
                writer.write(&sample, at)?;
            }
            drop(progress);
            writer.finish()
        });
        Ok(Recorder { stop, task })
    }

    /// Stops listening, writes out what was heard and closes the file.
    pub async fn stop(self) -> anyhow::Result<Summary> {
        let _ = self.stop.send(());
        self.task.await.context("the recorder task failed")?
    }
}

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

/// The MCAP side: channels and schemas made as keys first appear.
struct Mcap<W: Write + Seek> {
    out: mcap::Writer<W>,
    channels: HashMap<(String, String, bool), u16>,
    sequence: u32,
    first_ns: Option<u64>,
    last_ns: u64,
    summary: Summary,
}

/// A channel's metadata key for the Zenoh encoding.
pub const META_ENCODING: &str = "zenoh.encoding";
/// A channel's metadata key for `put` or `delete`.
pub const META_KIND: &str = "zenoh.kind";

impl<W: Write + Seek> Mcap<W> {
    fn new(w: W) -> mcap::McapResult<Self> {
        let out = mcap::WriteOptions::new()
            .compression(None)
            .profile("")
            .library(concat!("rome ", env!("CARGO_PKG_VERSION")))
            .create(w)?;
        Ok(Mcap {
            out,
            channels: HashMap::new(),
            sequence: 0,
            first_ns: None,
            last_ns: 0,
            summary: Summary::default(),
        })
    }

    fn write(&mut self, sample: &Sample, at_ns: u64) -> anyhow::Result<()> {
        let key = sample.key_expr().as_str().to_string();
        let encoding = sample.encoding().to_string();
        let delete = sample.kind() == SampleKind::Delete;
        let data = sample.payload().to_bytes();
        let channel = match self.channels.get(&(key.clone(), encoding.clone(), delete)) {
            Some(id) => *id,
            None => {
                let id = self.add_channel(&key, sample.encoding(), delete, &data)?;
                self.channels.insert((key, encoding, delete), id);
                self.summary.channels = self.channels.len();
                id
            }
        };
        let publish = sample.timestamp().map_or(at_ns, |t| {
            t.get_time()
                .to_system_time()
                .duration_since(SystemTime::UNIX_EPOCH)
                .map_or(at_ns, |d| d.as_nanos() as u64)
        });
        self.sequence = self.sequence.wrapping_add(1);
        self.out.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: channel,
                sequence: self.sequence,
                log_time: at_ns,
                publish_time: publish,
            },
            &data,
        )?;
        self.first_ns.get_or_insert(at_ns);
        self.last_ns = self.last_ns.max(at_ns);
        self.summary.messages += 1;
        self.summary.bytes += data.len() as u64;
        Ok(())
    }

    fn add_channel(
        &mut self,
        key: &str,
        encoding: &Encoding,
        delete: bool,
        first: &[u8],
    ) -> anyhow::Result<u16> {
        let mut meta = BTreeMap::new();
        meta.insert(META_ENCODING.to_string(), encoding.to_string());
        meta.insert(
            META_KIND.to_string(),
            if delete { "delete" } else { "put" }.to_string(),
        );
        let json = (*encoding == Encoding::APPLICATION_JSON || *encoding == Encoding::TEXT_JSON)
            .then(|| serde_json::from_slice::<serde_json::Value>(first).ok())
            .flatten();
        let (schema, message_encoding) = match json {
            Some(v) if !delete => {
                let schema = serde_json::to_vec(&json_schema(&v))?;
                let name = schema_name(key);
                (
                    self.out.add_schema(&name, "jsonschema", &schema)?,
                    "json".to_string(),
                )
            }
            _ => (0, encoding.to_string()),
        };
        Ok(self
            .out
            .add_channel(schema, key, &message_encoding, &meta)?)
    }

    fn finish(mut self) -> anyhow::Result<Summary> {
        self.out.finish()?;
        let mut w = self.out.into_inner();
        w.flush()?;
        self.summary.span_s = self
            .first_ns
            .map_or(0.0, |f| (self.last_ns.saturating_sub(f)) as f64 / 1e9);
        Ok(self.summary)
    }
}

/// The schema's name: the message type the key carries, where known.
pub(crate) fn schema_name(key: &str) -> String {
    let last = key.rsplit('/').next().unwrap_or(key);
    let known = match last {
        "state" => "BaseState",
        "scan" => "Scan",
        "frame" => "FrameInfo",
        "truth" => "Truth",
        other => other,
    };
    format!("rome.{known}")
}

/// A JSON Schema that `v` satisfies: types of fields, items of arrays
/// from the first one; `null` allows anything, since a field that is
/// null now (a free lock) holds an object later.
pub fn json_schema(v: &serde_json::Value) -> serde_json::Value {
    use serde_json::{json, Value};
    match v {
        Value::Null => json!({}),
        Value::Bool(_) => json!({"type": "boolean"}),
        Value::Number(_) => json!({"type": "number"}),
        Value::String(_) => json!({"type": "string"}),
        Value::Array(a) => match a.first() {
            Some(first) => json!({"type": "array", "items": json_schema(first)}),
            None => json!({"type": "array"}),
        },
        Value::Object(m) => {
            let props: serde_json::Map<String, Value> =
                m.iter().map(|(k, v)| (k.clone(), json_schema(v))).collect();
            json!({"type": "object", "properties": props})
        }
    }
}

#[cfg(test)]
mod tests;
