//! `rome echo`: any key's traffic, pretty-printed, as `ros2 topic echo`
//! shows a topic; `--hz` gives each key's rate as `ros2 topic hz` does.
//!
//! ```text
//! $ rome echo 'rome/robot/r1/base/state' --count 1
//! 10:41:07.412  PUT  rome/robot/r1/base/state  application/json  291 B
//!   robot: r1
//!   x_mm: 1200
//!   …
//! $ rome echo 'rome/robot/*/**' --hz
//! KEY                                   RATE Hz   MIN s    MAX s    STD s     N
//! rome/robot/r1/base/state                 10.00   0.099    0.101   0.0006    20
//! ```
//!
//! Liveliness tokens under the key come and go as `JOINED`/`LEFT` lines;
//! `--get` sends one query and prints every reply, errors included.
//! Nothing a peer sends can end the command: a payload that does not
//! decode is shown as bytes.

use rome_common::args::{CommonArgs, Side};
use rome_common::exit;
use std::collections::BTreeMap;
use std::time::{Duration, Instant, SystemTime};
use zenoh::bytes::Encoding;
use zenoh::query::ConsolidationMode;
use zenoh::sample::{Sample, SampleKind};

/// Flags of `rome echo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The key expression to watch, e.g. 'rome/robot/r1/base/state' or
    /// 'rome/**'; with --get a selector, parameters and all
    /// ('rome/data/wait/Lane?units=2;hold_ms=500').
    pub key: String,
    /// Send one query (a get) on the key instead of subscribing, and print the replies.
    #[arg(long)]
    pub get: bool,
    /// The query's JSON payload (with --get).
    #[arg(long, requires = "get", value_name = "JSON")]
    pub payload: Option<String>,
    /// Print each key's publication rate every --window seconds instead of the messages.
    #[arg(long, conflicts_with = "get")]
    pub hz: bool,
    /// How many seconds of arrivals each --hz line covers, and how often it is printed.
    #[arg(long, default_value_t = 1.0, value_name = "SECS")]
    pub window: f64,
    /// Stop after this many messages (replies with --get).
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long, value_name = "SECS")]
    pub duration: Option<f64>,
    /// One JSON object per line (time, kind, key, encoding, payload) instead of pretty text.
    #[arg(long)]
    pub json: bool,
    /// How long --get waits for replies, in seconds.
    #[arg(long, default_value_t = 5.0, value_name = "SECS")]
    pub timeout: f64,
    /// Leave liveliness tokens (JOINED/LEFT) out.
    #[arg(long)]
    pub no_alive: bool,
}

/// What was heard.
enum Heard {
    Sample(Sample),
    Alive(Sample),
}

/// Watches, queries or measures the key.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    // A query may carry selector parameters, as `z_get -s 'KEY?A=1;B=2'`.
    let (key, parameters) = match args.key.split_once('?') {
        Some((key, parameters)) if args.get => (key, parameters),
        _ => (args.key.as_str(), ""),
    };
    let key = zenoh::key_expr::KeyExpr::try_from(key.to_string()).map_err(|e| {
        let hint = if args.key.contains('?') && !args.get {
            " (parameters after '?' go with --get only)"
        } else {
            ""
        };
        anyhow::anyhow!("'{}' is not a key expression{hint}: {e}", args.key)
    })?;
    for (name, v) in [
        ("--window", Some(args.window)),
        ("--duration", args.duration),
    ] {
        if let Some(v) = v {
            // Checked here, so that the durations made of them below
            // cannot panic.
            rome_common::seconds(name, v)?;
        }
    }
    let session = common.open(Side::Client).await?;
    let until = args
        .duration
        .map(|d| tokio::time::Instant::now() + Duration::from_secs_f64(d));
    let deadline = async move {
        match until {
            Some(t) => tokio::time::sleep_until(t).await,
            None => std::future::pending().await,
        }
    };
    if args.get {
        return get(&session, &key, parameters, &args).await;
    }
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let samples = {
        let tx = tx.clone();
        session
            .declare_subscriber(&key)
            .callback(move |s| {
                let _ = tx.send(Heard::Sample(s));
            })
            .await
            .map_err(|e| anyhow::anyhow!("cannot subscribe to '{key}': {e}"))?
    };
    let alive = if args.no_alive || args.hz {
        None
    } else {
        Some(
            session
                .liveliness()
                .declare_subscriber(&key)
                .history(true)
                .callback(move |s| {
                    let _ = tx.send(Heard::Alive(s));
                })
                .await
                .map_err(|e| anyhow::anyhow!("cannot watch liveliness on '{key}': {e}"))?,
        )
    };
    tokio::pin!(deadline);
    let mut seen = 0u64;
    let mut rates = Rates::default();
    let mut tick = tokio::time::interval(Duration::from_secs_f64(args.window));
    tick.tick().await;
    loop {
        tokio::select! {
            heard = rx.recv() => {
                let Some(heard) = heard else { break };
                match heard {
                    Heard::Sample(s) if args.hz => {
                        if s.kind() == SampleKind::Put {
                            rates.add(s.key_expr().as_str(), s.payload().len(), Instant::now());
                        }
                        continue;
                    }
                    Heard::Sample(s) => print_sample(&s, kind_of(&s), args.json),
                    Heard::Alive(s) => {
                        let kind = if s.kind() == SampleKind::Put { "JOINED" } else { "LEFT" };
                        print_sample(&s, kind, args.json)
                    }
                }
                seen += 1;
                if args.count.is_some_and(|n| seen >= n) {
                    break;
                }
            }
            _ = tick.tick(), if args.hz => {
                let now = Instant::now();
                let table = rates.table(now, Duration::from_secs_f64(args.window), args.json);
                rome_common::out!("{}", table.strip_suffix('\n').unwrap_or(&table));
                rates.forget_before(now - Duration::from_secs_f64(args.window));
            }
            _ = &mut deadline => break,
        }
    }
    drop(samples);
    drop(alive);
    Ok(exit::OK)
}

async fn get(
    session: &zenoh::Session,
    key: &zenoh::key_expr::KeyExpr<'static>,
    parameters: &str,
    args: &Args,
) -> anyhow::Result<u8> {
    let timeout = rome_common::seconds("--timeout", args.timeout)?;
    let selector = zenoh::query::Selector::from((key.clone(), parameters.to_string()));
    let mut get = session
        .get(selector)
        .consolidation(ConsolidationMode::None)
        .timeout(timeout);
    if let Some(p) = &args.payload {
        get = get.payload(p.clone()).encoding(Encoding::APPLICATION_JSON);
    }
    let replies = get
        .await
        .map_err(|e| anyhow::anyhow!("cannot query '{key}': {e}"))?;
    let (mut n, mut errors) = (0u64, 0u64);
    while let Ok(reply) = replies.recv_async().await {
        match reply.result() {
            Ok(s) => print_sample(s, "REPLY", args.json),
            Err(e) => {
                errors += 1;
                let body = e.payload().to_bytes();
                if args.json {
                    rome_common::out!(
                        "{}",
                        serde_json::json!({"time": now_ms(), "kind": "error", "key": key.as_str(),
                            "encoding": e.encoding().to_string(), "payload": value_of(&body)})
                    );
                } else {
                    rome_common::out!("{}  ERROR  {key}", clock(SystemTime::now()));
                    let text = indent(&pretty(&body, e.encoding()));
                    rome_common::out!("{}", text.strip_suffix('\n').unwrap_or(&text));
                }
            }
        }
        n += 1;
        if args.count.is_some_and(|c| n >= c) {
            break;
        }
    }
    if n == 0 && !args.json {
        eprintln!(
            "no reply on '{key}' within {} s (is anything serving it? `rome ls`)",
            args.timeout
        );
        return Ok(exit::ERROR);
    }
    Ok(if errors > 0 && errors == n {
        exit::ERROR
    } else {
        exit::OK
    })
}

fn kind_of(s: &Sample) -> &'static str {
    match s.kind() {
        SampleKind::Put => "PUT",
        SampleKind::Delete => "DELETE",
    }
}

fn print_sample(s: &Sample, kind: &str, json: bool) {
    let bytes = s.payload().to_bytes();
    if json {
        rome_common::out!(
            "{}",
            serde_json::json!({
                "time": now_ms(),
                "kind": kind.to_ascii_lowercase(),
                "key": s.key_expr().as_str(),
                "encoding": s.encoding().to_string(),
                "bytes": bytes.len(),
                "payload": value_of(&bytes),
            })
        );
        return;
    }
    let head = format!(
        "{}  {kind:6} {}",
        clock(SystemTime::now()),
        s.key_expr().as_str()
    );
    if bytes.is_empty() {
        rome_common::out!("{head}");
        return;
    }
    rome_common::out!(
        "{head}  {}  {}",
        s.encoding(),
        rome_common::progress::size(bytes.len() as u64)
    );
    let text = indent(&pretty(&bytes, s.encoding()));
    rome_common::out!("{}", text.strip_suffix('\n').unwrap_or(&text));
}

/// The payload as JSON if it is JSON, as text if UTF-8, else a summary.
fn value_of(bytes: &[u8]) -> serde_json::Value {
    if let Ok(v) = serde_json::from_slice::<serde_json::Value>(bytes) {
        return v;
    }
    match std::str::from_utf8(bytes) {
        Ok(t) => serde_json::Value::String(t.to_string()),
        Err(_) => serde_json::json!({"binary_bytes": bytes.len()}),
    }
}

/// A payload for people: JSON as indented `field: value` lines in name
/// order (arrays of numbers on one line), a PNG as its size, other bytes as text or a hex
/// preview.
pub fn pretty(bytes: &[u8], encoding: &Encoding) -> String {
    if let Some((w, h)) = png_size(bytes) {
        return format!("<PNG image {w}×{h}>\n");
    }
    if let Ok(v) = serde_json::from_slice::<serde_json::Value>(bytes) {
        let mut out = String::new();
        yaml(&v, 0, &mut out);
        return out;
    }
    if let Ok(t) = std::str::from_utf8(bytes) {
        let shown: String = t.chars().take(2000).collect();
        let more = if shown.len() < t.len() { " …" } else { "" };
        return format!("{shown}{more}\n");
    }
    let preview: Vec<String> = bytes.iter().take(32).map(|b| format!("{b:02x}")).collect();
    let more = if bytes.len() > 32 { " …" } else { "" };
    format!(
        "<{} bytes of {encoding}: {}{more}>\n",
        bytes.len(),
        preview.join(" ")
    )
}

fn yaml(v: &serde_json::Value, depth: usize, out: &mut String) {
    use serde_json::Value;
    let pad = "  ".repeat(depth);
    match v {
        Value::Object(m) if !m.is_empty() => {
            for (k, v) in m {
                match v {
                    Value::Object(inner) if !inner.is_empty() => {
                        out.push_str(&format!("{pad}{k}:\n"));
                        yaml(v, depth + 1, out);
                    }
                    Value::Array(a) if !flat(a) => {
                        out.push_str(&format!("{pad}{k}:\n"));
                        yaml(v, depth + 1, out);
                    }
                    _ => out.push_str(&format!("{pad}{k}: {}\n", scalar(v))),
                }
            }
        }
        Value::Array(a) if !flat(a) => {
            for item in a {
                out.push_str(&format!("{pad}-\n"));
                yaml(item, depth + 1, out);
            }
        }
        _ => out.push_str(&format!("{pad}{}\n", scalar(v))),
    }
}

/// An array shown on one line: scalars only, and not too many.
fn flat(a: &[serde_json::Value]) -> bool {
    a.len() <= 64 && a.iter().all(|v| !v.is_object() && !v.is_array())
}

fn scalar(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Array(a) => {
            let items: Vec<String> = a.iter().map(scalar).collect();
            format!("[{}]", items.join(", "))
        }
        other => other.to_string(),
    }
}

fn indent(text: &str) -> String {
    text.lines().map(|l| format!("  {l}\n")).collect()
}

/// Width and height from a PNG's IHDR chunk, if `bytes` is a PNG.
fn png_size(bytes: &[u8]) -> Option<(u32, u32)> {
    const SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
    if bytes.len() < 24 || !bytes.starts_with(SIGNATURE) || &bytes[12..16] != b"IHDR" {
        return None;
    }
    let w = u32::from_be_bytes(bytes[16..20].try_into().ok()?);
    let h = u32::from_be_bytes(bytes[20..24].try_into().ok()?);
    Some((w, h))
}

fn now_ms() -> u64 {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

/// `HH:MM:SS.mmm`, UTC.
fn clock(t: SystemTime) -> String {
    let ms = t
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64);
    let s = ms / 1000;
    format!(
        "{:02}:{:02}:{:02}.{:03}",
        (s / 3600) % 24,
        (s / 60) % 60,
        s % 60,
        ms % 1000
    )
}

/// Arrivals per key over a sliding window, for `--hz` and `rome ls`.
#[derive(Debug, Default)]
pub struct Rates {
    keys: BTreeMap<String, Arrivals>,
}

#[derive(Debug, Default)]
struct Arrivals {
    times: std::collections::VecDeque<(Instant, usize)>,
}

/// One key's rate over a window.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Rate {
    /// The key.
    pub key: String,
    /// Messages in the window.
    pub count: usize,
    /// Messages per second (from the intervals between them).
    pub hz: f64,
    /// Shortest interval, seconds.
    pub min_s: f64,
    /// Longest interval, seconds.
    pub max_s: f64,
    /// Standard deviation of the intervals, seconds.
    pub std_s: f64,
    /// Mean payload size, bytes.
    pub mean_bytes: f64,
}

impl Rates {
    /// Counts one message of `bytes` on `key` at `at`.
    pub fn add(&mut self, key: &str, bytes: usize, at: Instant) {
        // Keys a peer makes up cannot grow this without bound.
        const MAX_KEYS: usize = 10_000;
        if !self.keys.contains_key(key) && self.keys.len() >= MAX_KEYS {
            return;
        }
        self.keys
            .entry(key.to_string())
            .or_default()
            .times
            .push_back((at, bytes));
    }

    /// Drops arrivals before `t`.
    pub fn forget_before(&mut self, t: Instant) {
        for a in self.keys.values_mut() {
            while a.times.front().is_some_and(|(at, _)| *at < t) {
                a.times.pop_front();
            }
        }
        self.keys.retain(|_, a| !a.times.is_empty());
    }

    /// Each key's rate over the last `window` before `now`.
    pub fn rates(&self, now: Instant, window: Duration) -> Vec<Rate> {
        let from = now.checked_sub(window).unwrap_or(now);
        self.keys
            .iter()
            .filter_map(|(key, a)| {
                let v: Vec<&(Instant, usize)> =
                    a.times.iter().filter(|(t, _)| *t >= from).collect();
                if v.is_empty() {
                    return None;
                }
                let gaps: Vec<f64> = v
                    .windows(2)
                    .map(|w| w[1].0.duration_since(w[0].0).as_secs_f64())
                    .collect();
                let mean_bytes = v.iter().map(|(_, b)| *b as f64).sum::<f64>() / v.len() as f64;
                let (hz, min_s, max_s, std_s) = if gaps.is_empty() {
                    (1.0 / window.as_secs_f64(), 0.0, 0.0, 0.0)
                } else {
                    let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
                    let var =
                        gaps.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / gaps.len() as f64;
                    (
                        if mean > 0.0 {
                            1.0 / mean
                        } else {
                            f64::INFINITY
                        },
                        gaps.iter().copied().fold(f64::INFINITY, f64::min),
                        gaps.iter().copied().fold(0.0, f64::max),
                        var.sqrt(),
                    )
                };
                Some(Rate {
                    key: key.clone(),
                    count: v.len(),
                    hz,
                    min_s,
                    max_s,
                    std_s,
                    mean_bytes,
                })
            })
            .collect()
    }

    fn table(&self, now: Instant, window: Duration, json: bool) -> String {
        let rates = self.rates(now, window);
        if json {
            return rates
                .iter()
                .map(|r| format!("{}\n", serde_json::to_string(r).unwrap_or_default()))
                .collect();
        }
        if rates.is_empty() {
            return format!(
                "{}  nothing published in the last {:.1} s\n",
                clock(SystemTime::now()),
                window.as_secs_f64()
            );
        }
        let width = rates.iter().map(|r| r.key.len()).max().unwrap_or(3).max(3);
        let mut out = format!(
            "{:width$}  {:>9}  {:>7}  {:>7}  {:>7}  {:>5}  {:>8}\n",
            "KEY", "RATE Hz", "MIN s", "MAX s", "STD s", "N", "BYTES"
        );
        for r in rates {
            out.push_str(&format!(
                "{:width$}  {:>9.2}  {:>7.3}  {:>7.3}  {:>7.4}  {:>5}  {:>8.0}\n",
                r.key, r.hz, r.min_s, r.max_s, r.std_s, r.count, r.mean_bytes
            ));
        }
        out.push('\n');
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_come_from_the_intervals_within_the_window() {
        let mut r = Rates::default();
        let t0 = Instant::now();
        for i in 0..11 {
            r.add("a", 100, t0 + Duration::from_millis(100 * i));
        }
        r.add("b", 10, t0 + Duration::from_millis(500));
        let rates = r.rates(t0 + Duration::from_millis(1000), Duration::from_secs(2));
        assert_eq!(rates.len(), 2);
        assert!((rates[0].hz - 10.0).abs() < 1e-6, "{:?}", rates[0]);
        assert_eq!(rates[0].count, 11);
        assert!(rates[0].std_s < 1e-9);
        assert_eq!(rates[1].count, 1);
        r.forget_before(t0 + Duration::from_millis(600));
        let rates = r.rates(t0 + Duration::from_millis(1000), Duration::from_secs(2));
        assert_eq!(rates.len(), 1, "b forgotten: {rates:?}");
        assert_eq!(rates[0].count, 5);
    }

    #[test]
    fn payloads_are_shown_as_fields_pngs_as_sizes_and_garbage_as_bytes() {
        let j = br#"{"robot":"r1","x_mm":12,"sonar":[1,2,3],"lock":{"fence":4}}"#;
        let p = pretty(j, &Encoding::APPLICATION_JSON);
        // Fields in name order.
        assert_eq!(
            p,
            "lock:\n  fence: 4\nrobot: r1\nsonar: [1, 2, 3]\nx_mm: 12\n"
        );
        let mut png = b"\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR".to_vec();
        png.extend(640u32.to_be_bytes());
        png.extend(480u32.to_be_bytes());
        assert_eq!(pretty(&png, &Encoding::IMAGE_PNG), "<PNG image 640×480>\n");
        let g = pretty(&[0xff, 0x00, 0x10], &Encoding::ZENOH_BYTES);
        assert!(g.starts_with("<3 bytes of zenoh/bytes: ff 00 10"), "{g}");
        // A short "PNG" is not read past its end.
        assert!(pretty(b"\x89PNG\r\n\x1a\n", &Encoding::IMAGE_PNG).starts_with("<8 bytes"));
    }
}
