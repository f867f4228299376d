//! `rome ls`: the live servers and clients, from liveliness tokens, and
//! each robot's devices with the rates of their streams.
//!
//! ```text
//! $ rome ls
//! CLASS   ROLE              ID                                VERSION   PROTO
//! server  robot/r1          base                              0.1.0         1
//! server  robot/r1/camera   up                                0.1.0         1
//! …
//! ROBOT  DEVICE      STREAM  RATE Hz  BYTES
//! r1     base        state     10.00    291
//! r1     proximity   scan       9.98    402
//! r1     camera/up   frame      2.00    104
//! ```

use crate::echo::Rates;
use rome_common::args::{CommonArgs, Side};
use rome_common::exit;
use std::time::Instant;

/// Flags of `rome ls`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// How long to collect answers and count stream messages, in seconds.
    #[arg(long, default_value_t = 2.0)]
    pub timeout: f64,
}

/// One robot device's stream, as heard during the listing.
#[derive(Debug, serde::Serialize)]
struct Stream {
    robot: String,
    device: String,
    stream: String,
    hz: f64,
    mean_bytes: f64,
}

/// Lists who is alive, and how often each robot device publishes.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let window = rome_common::seconds("--timeout", args.timeout)?;
    let session = common.open(Side::Client).await?;
    let root = common.root()?;
    let rates = std::sync::Arc::new(std::sync::Mutex::new(Rates::default()));
    let started = Instant::now();
    let _streams = {
        let rates = rates.clone();
        session
            .declare_subscriber(format!("{}/robot/**", root.as_str()))
            .callback(move |s| {
                if let Ok(mut r) = rates.lock() {
                    r.add(s.key_expr().as_str(), s.payload().len(), Instant::now());
                }
            })
            .await
            .map_err(|e| anyhow::anyhow!("cannot subscribe to the robots' streams: {e}"))?
    };
    // Peers learn each other's tokens just after connecting; a liveliness
    // subscriber with history waits for that instead of guessing.
    let (people, versions) = tokio::join!(
        rome_client::alive::list(&session, &root, window),
        rome_client::alive::versions(&session, &root, window)
    );
    let (people, versions) = (people?, versions?);
    let speaks = |key: &str| versions.iter().find(|(k, _)| k == key).map(|(_, s)| s);
    // The streams are counted over the whole window, however soon the
    // tokens came.
    tokio::time::sleep_until((started + window).into()).await;
    let heard = started.elapsed();
    let prefix = format!("{}/robot/", root.as_str());
    let streams: Vec<Stream> = rates
        .lock()
        .map(|r| r.rates(Instant::now(), heard))
        .unwrap_or_default()
        .into_iter()
        .filter_map(|r| {
            let rest = r.key.strip_prefix(&prefix)?;
            let (robot, rest) = rest.split_once('/')?;
            let (device, stream) = rest.rsplit_once('/')?;
            Some(Stream {
                robot: robot.to_string(),
                device: device.to_string(),
                stream: stream.to_string(),
                // From the intervals when there are some, since the
                // subscription starts a moment after the window does.
                hz: if r.count >= 2 {
                    r.hz
                } else {
                    r.count as f64 / heard.as_secs_f64()
                },
                mean_bytes: r.mean_bytes,
            })
        })
        .collect();
    if args.json {
        let rows: Vec<_> = people
            .iter()
            .map(
                |p| serde_json::json!({"class": p.class, "role": p.role, "id": p.id, "key": p.key, "speaks": speaks(&p.key)}),
            )
            .collect();
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({"alive": rows, "streams": streams}))?
        );
        return Ok(exit::OK);
    }
    if people.is_empty() {
        eprintln!(
            "nothing alive under '{}' (is a server running, and --connect right?)",
            root.as_str()
        );
        return Ok(exit::OK);
    }
    let me = rome_schema::Speaks::this();
    println!(
        "{:6}  {:16}  {:32}  {:8}  {:>5}",
        "CLASS", "ROLE", "ID", "VERSION", "PROTO"
    );
    let mut differ = 0;
    for p in &people {
        let (version, protocol) = match speaks(&p.key) {
            Some(s) => (s.version.clone(), s.protocol.to_string()),
            None => ("-".to_string(), "-".to_string()),
        };
        if speaks(&p.key).is_none_or(|s| s.protocol != me.protocol) {
            differ += 1;
        }
        println!(
            "{:6}  {:16}  {:32}  {:8}  {:>5}",
            p.class, p.role, p.id, version, protocol
        );
    }
    if differ > 0 {
        use std::io::Write;
        let _ = std::io::stdout().flush();
        eprintln!(
            "mixed builds: this is {me}, and {differ} of {} speak another protocol or did not say (`-`: older than protocol versions); they may misread each other's requests",
            people.len()
        );
    }
    // Every device with a server, with its streams or none heard.
    let mut devices: Vec<(String, String)> = people
        .iter()
        .filter_map(|p| {
            // `robot/r1` + `base`, `robot/r1/camera` + `up`.
            let rest = p.role.strip_prefix("robot/")?;
            let (robot, kind) = rest.split_once('/').unwrap_or((rest, ""));
            let device = if kind.is_empty() {
                p.id.clone()
            } else {
                format!("{kind}/{}", p.id)
            };
            Some((robot.to_string(), device))
        })
        .collect();
    devices.sort();
    if devices.is_empty() {
        return Ok(exit::OK);
    }
    println!();
    println!(
        "{:8}  {:12}  {:8}  {:>8}  {:>7}",
        "ROBOT", "DEVICE", "STREAM", "RATE Hz", "BYTES"
    );
    for (robot, device) in &devices {
        let mine: Vec<&Stream> = streams
            .iter()
            .filter(|s| &s.robot == robot && &s.device == device)
            .collect();
        if mine.is_empty() {
            println!("{robot:8}  {device:12}  {:8}  {:>8}  {:>7}", "-", "0", "-");
        }
        for s in mine {
            println!(
                "{robot:8}  {device:12}  {:8}  {:>8.2}  {:>7.0}",
                s.stream, s.hz, s.mean_bytes
            );
        }
    }
    Ok(exit::OK)
}
