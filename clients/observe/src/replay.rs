//! `rome replay`: an MCAP recording put back on Zenoh with its original
//! timing, so `rome view` and `rome echo` show a recorded run as if it
//! were live.
//!
//! ```text
//! rome replay run.mcap                 # as recorded
//! rome replay run.mcap --rate 4 --loop # four times as fast, again and again
//! ```
//!
//! It opens its session as the servers it stands in for do: with no
//! network flags it listens on port 7447, or joins whoever has it.
//!
//! Each message goes out on its channel's topic as its key, with the Zenoh
//! encoding of the channel's `zenoh.encoding` metadata (or JSON for a
//! `json` channel of another recorder), as a delete where `zenoh.kind` says
//! so. A message is put when its log time, measured from the first
//! message's and divided by the rate, comes; lateness does not add up.

use crate::record::{META_ENCODING, META_KIND};
use anyhow::Context;
use rome_common::args::{CommonArgs, Side};
use rome_common::exit;
use rome_common::progress::Progress;
use std::path::{Path, PathBuf};
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::Session;

/// Flags of `rome replay`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The MCAP file to play.
    pub file: PathBuf,
    /// Speed: 2 plays twice as fast, 0.5 at half speed.
    #[arg(long, default_value_t = 1.0)]
    pub rate: f64,
    /// Start again from the beginning at the end, until Ctrl-C.
    #[arg(long = "loop")]
    pub repeat: bool,
    /// Before the first message, wait up to this many seconds for a
    /// subscriber to its key (a recorder, a viewer) to be matched.
    #[arg(long, default_value_t = 0.0, value_name = "SECS")]
    pub wait_subscriber: f64,
}

/// One message to put back.
#[derive(Debug, Clone)]
pub struct Message {
    /// The key.
    pub key: String,
    /// Its encoding on Zenoh.
    pub encoding: Encoding,
    /// A delete rather than a put.
    pub delete: bool,
    /// When it was heard, nanoseconds since the Unix epoch.
    pub log_ns: u64,
    /// The payload.
    pub data: Vec<u8>,
}

/// Reads every message of an MCAP file, in log-time order.
pub fn load(path: &Path) -> anyhow::Result<Vec<Message>> {
    let buf = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    anyhow::ensure!(
        buf.starts_with(mcap::MAGIC),
        "{} is not an MCAP file (it does not begin with MCAP's magic bytes)",
        path.display()
    );
    let stream = mcap::MessageStream::new(&buf)
        .with_context(|| format!("{} is not an MCAP file", path.display()))?;
    let mut out = Vec::new();
    for m in stream {
        let m = m.with_context(|| {
            format!(
                "{}: message {} cannot be read",
                path.display(),
                out.len() + 1
            )
        })?;
        let meta = &m.channel.metadata;
        let encoding = match meta.get(META_ENCODING) {
            Some(e) => Encoding::from(e.as_str()),
            None if m.channel.message_encoding == "json" => Encoding::APPLICATION_JSON,
            None => Encoding::ZENOH_BYTES,
        };
        let key = m.channel.topic.clone();
        zenoh::key_expr::KeyExpr::try_from(key.as_str()).map_err(|e| {
            anyhow::anyhow!(
                "{}: channel topic '{key}' is not a Zenoh key: {e}",
                path.display()
            )
        })?;
        out.push(Message {
            key,
            encoding,
            delete: meta.get(META_KIND).is_some_and(|k| k == "delete"),
            log_ns: m.log_time,
            data: m.data.into_owned(),
        });
    }
    // Files from other recorders need not be in log-time order.
    out.sort_by_key(|m| m.log_ns);
    Ok(out)
}

/// Plays the file until its end (or for ever with `--loop`).
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    anyhow::ensure!(
        args.rate.is_finite() && args.rate > 0.0,
        "--rate must be a positive number, got {}",
        args.rate
    );
    let messages = load(&args.file)?;
    anyhow::ensure!(
        !messages.is_empty(),
        "{} has no messages",
        args.file.display()
    );
    let span = messages.last().map_or(0, |m| m.log_ns) - messages[0].log_ns;
    let subscriber_within = checked(&args, span)?;
    eprintln!(
        "rome replay: {} message(s) over {:.1} s from {} at rate {}",
        messages.len(),
        span as f64 / 1e9,
        args.file.display(),
        args.rate
    );
    // It stands in for the servers that published the run: with no flags it
    // listens on port 7447 (or joins whoever has it) for viewers to reach.
    let session = common.open(Side::Server).await?;
    if let Some(within) = subscriber_within {
        wait_subscriber(&session, &messages[0].key, within).await?;
    }
    loop {
        play(&session, &messages, args.rate).await?;
        if !args.repeat {
            break;
        }
    }
    // Puts are sent by now; give the link a moment to carry the last ones
    // before the session closes.
    session.close().await.ok();
    Ok(exit::OK)
}

/// The time flags checked against a file of `span_ns`: how long to wait
/// for a subscriber (`None`: not at all).
fn checked(args: &Args, span_ns: u64) -> anyhow::Result<Option<Duration>> {
    // 0 (the default) does not wait at all; any other value is a time
    // checked as every time flag is.
    let within = if args.wait_subscriber == 0.0 {
        None
    } else {
        Some(rome_common::seconds(
            "--wait-subscriber",
            args.wait_subscriber,
        )?)
    };
    // A slow enough rate stretches the file past what a clock can count.
    let span_s = span_ns as f64 / 1e9;
    let stretched = span_s / args.rate;
    anyhow::ensure!(
        stretched <= rome_common::time::LONGEST_S,
        "--rate {:?} would stretch the file's {span_s:.1} s over {stretched:.3e} s, \
         past the longest time a flag may give ({} s)",
        args.rate,
        rome_common::time::LONGEST_S
    );
    Ok(within)
}

/// Waits until a subscriber matching `key` is known.
async fn wait_subscriber(session: &Session, key: &str, within: Duration) -> anyhow::Result<()> {
    let publisher = session
        .declare_publisher(key.to_string())
        .await
        .map_err(|e| anyhow::anyhow!("cannot declare a publisher on '{key}': {e}"))?;
    let listener = publisher
        .matching_listener()
        .await
        .map_err(|e| anyhow::anyhow!("cannot watch who subscribes to '{key}': {e}"))?;
    let now = publisher
        .matching_status()
        .await
        .map_err(|e| anyhow::anyhow!("cannot ask who subscribes to '{key}': {e}"))?;
    if now.matching() {
        return Ok(());
    }
    let deadline = tokio::time::Instant::now() + within;
    loop {
        match tokio::time::timeout_at(deadline, listener.recv_async()).await {
            Ok(Ok(status)) if status.matching() => return Ok(()),
            Ok(Ok(_)) => continue,
            Ok(Err(e)) => anyhow::bail!("lost the watch on '{key}': {e}"),
            Err(_) => anyhow::bail!(
                "nobody subscribed to '{key}' within {:.1} s",
                within.as_secs_f64()
            ),
        }
    }
}

/// Puts `messages` on `session` once, at their recorded pace / `rate`.
pub async fn play(session: &Session, messages: &[Message], rate: f64) -> anyhow::Result<()> {
    let Some(first) = messages.first() else {
        return Ok(());
    };
    let start = tokio::time::Instant::now();
    let mut progress = Progress::bar("replaying", "messages", messages.len() as u64);
    for (i, m) in messages.iter().enumerate() {
        let offset = (m.log_ns - first.log_ns) as f64 / 1e9 / rate;
        tokio::time::sleep_until(start + Duration::from_secs_f64(offset)).await;
        let sent = if m.delete {
            session.delete(m.key.as_str()).await
        } else {
            session
                .put(m.key.as_str(), m.data.clone())
                .encoding(m.encoding.clone())
                .await
        };
        sent.map_err(|e| anyhow::anyhow!("cannot put on '{}': {e}", m.key))?;
        progress.set(i as u64 + 1, "");
    }
    progress.finish();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{checked, Args};
    use std::time::Duration;

    fn args(rate: f64, wait_subscriber: f64) -> Args {
        Args {
            file: "run.mcap".into(),
            rate,
            repeat: false,
            wait_subscriber,
        }
    }

    #[test]
    fn time_flags_that_no_clock_could_count_are_refused_by_name() {
        let minute = 60_000_000_000;
        assert_eq!(checked(&args(1.0, 0.0), minute).unwrap(), None);
        assert_eq!(
            checked(&args(0.5, 20.0), minute).unwrap(),
            Some(Duration::from_secs(20))
        );
        // Both panicked where they were turned into durations.
        let e = checked(&args(1.0, 1e30), minute).unwrap_err().to_string();
        assert!(e.starts_with("--wait-subscriber must be at most"), "{e}");
        let e = checked(&args(1.0, -1.0), minute).unwrap_err().to_string();
        assert!(e.starts_with("--wait-subscriber must be a positive"), "{e}");
        let e = checked(&args(1e-300, 0.0), minute).unwrap_err().to_string();
        assert!(
            e.starts_with("--rate 1e-300 would stretch the file's 60.0 s"),
            "{e}"
        );
    }
}
