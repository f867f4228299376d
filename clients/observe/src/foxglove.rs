//! `rome foxglove`: the fleet's traffic, live, in Foxglove, over Foxglove's
//! WebSocket protocol (`foxglove.websocket.v1`), as `foxglove_bridge` does
//! for ROS 2.
//!
//! ```text
//! rome foxglove                               # ws://127.0.0.1:8765, every key under the root
//! rome foxglove --port 0 'rome/robot/r1/**'   # a free port, said on stderr
//! ```
//!
//! In Foxglove: *Open connection* → *Foxglove WebSocket* →
//! `ws://127.0.0.1:8765`. Every key that carries JSON becomes a channel
//! (topic: the key; encoding `json`; a JSON Schema taken from its first
//! message, as `rome record` writes), advertised as soon as it is first
//! heard, so Plot, Raw Messages and State Transitions panels work on any
//! field. Beside a camera's `…/camera/<camera>/frame` comes
//! `…/camera/<camera>/image`, Foxglove's `CompressedImage` (PNG): while a
//! client subscribes to it, the camera's last picture is fetched (`grab`)
//! each time the camera says it grabbed one. Other bytes are not bridged
//! (`rome record` keeps everything).
//!
//! What goes over the socket, after the protocol's specification:
//!
//! ```text
//! server → client  text    {"op":"serverInfo",…}  {"op":"advertise","channels":[…]}
//!                          {"op":"status","level":0|1|2,"message":…}
//! client → server  text    {"op":"subscribe","subscriptions":[{"id":S,"channelId":C}]}
//!                          {"op":"unsubscribe","subscriptionIds":[S]}
//! server → client  binary  0x01, S (u32 LE), receive time in ns (u64 LE), the message
//! ```
//!
//! A client's malformed or unknown request is answered with an error
//! status naming what was wrong, and the connection goes on. A client too
//! slow for the traffic misses messages, and is told how many.

use anyhow::Context;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::State;
use axum::response::Response;
use axum::routing::get;
use rome_common::args::{CommonArgs, Side};
use rome_common::exit;
use serde_json::{json, Value};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::SystemTime;
use tokio::sync::broadcast;
use zenoh::bytes::Encoding;
use zenoh::pubsub::Subscriber;
use zenoh::sample::{Sample, SampleKind};
use zenoh::Session;

/// The WebSocket subprotocol Foxglove asks for.
pub const SUBPROTOCOL: &str = "foxglove.websocket.v1";
/// The first byte of a binary frame carrying a message.
pub const OP_MESSAGE_DATA: u8 = 0x01;
/// Status levels of the protocol.
const INFO: u8 = 0;
const WARNING: u8 = 1;
const ERROR: u8 = 2;
/// Messages held for each connection before a slow one starts missing
/// some.
const BACKLOG: usize = 4096;
/// Most subscriptions one connection may hold: a client's request never
/// makes the bridge hold more than this.
const MAX_SUBSCRIPTIONS: usize = 4096;
/// Largest request a client may send, bytes (Foxglove's are a few
/// hundred): a bigger one ends the connection.
const MAX_REQUEST: usize = 1 << 20;
/// Most channels: keys beyond this are not bridged (and said so once).
const MAX_CHANNELS: usize = 10_000;

/// Flags of `rome foxglove`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Key expressions to bridge [default: everything under the root, ROOT/**].
    pub keys: Vec<String>,
    /// The WebSocket port (0: any free one); Foxglove's default is 8765.
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// The address to serve on (0.0.0.0 to let other hosts connect).
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: std::net::IpAddr,
}

/// Serves the bridge until Ctrl-C.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let keys = common.keys_or_all(&args.keys)?;
    let session = common.open(Side::Client).await?;
    let listener = tokio::net::TcpListener::bind((args.bind, args.port))
        .await
        .with_context(|| {
            format!(
                "cannot serve on {}:{} (is another rome foxglove there? try --port 0)",
                args.bind, args.port
            )
        })?;
    let at = listener.local_addr()?;
    let bridge = Bridge::start(&session, &keys).await?;
    eprintln!("{}tcp/{at}", rome_client::net::LISTENING);
    eprintln!(
        "rome foxglove: ws://{at} bridges {} (in Foxglove: Open connection, Foxglove WebSocket; Ctrl-C to stop)",
        keys.join(", ")
    );
    serve(listener, bridge, exit::interrupted()).await?;
    Ok(exit::OK)
}

/// Serves `bridge` on `listener` until `shutdown` completes.
pub async fn serve(
    listener: tokio::net::TcpListener,
    bridge: Bridge,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> anyhow::Result<()> {
    let app = axum::Router::new()
        .route("/", get(upgrade))
        .with_state(Arc::new(bridge));
    axum::serve(listener, app)
        .with_graceful_shutdown(shutdown)
        .await
        .context("the WebSocket server failed")
}

/// One channel: a key whose messages are JSON, or a camera's pictures.
#[derive(Debug)]
struct Channel {
    id: u32,
    topic: String,
    schema_name: String,
    schema: String,
    /// For a camera's picture channel, where the pictures are fetched.
    image: Option<Image>,
}

/// A camera's picture channel: a picture is asked for (`grab`, PNG) each
/// time the camera says it grabbed one, while any client subscribes.
#[derive(Debug)]
struct Image {
    /// The camera's key (`…/camera/<camera>`), the pictures' frame.
    camera: String,
    /// Subscriptions to the channel, over every connection.
    watchers: AtomicUsize,
    /// A picture is being fetched: the next waits until it is in.
    fetching: AtomicBool,
}

/// Foxglove's `CompressedImage`, as a JSON Schema.
const COMPRESSED_IMAGE_SCHEMA: &str = r#"{"title":"foxglove.CompressedImage","type":"object","properties":{"timestamp":{"type":"object","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0}}},"frame_id":{"type":"string"},"data":{"type":"string","contentEncoding":"base64"},"format":{"type":"string"}}}"#;
/// Largest picture passed on, bytes: a bigger reply is not a camera's.
const MAX_PICTURE: usize = 16 << 20;

impl Channel {
    fn advertised(&self) -> Value {
        json!({
            "id": self.id,
            "topic": self.topic,
            "encoding": "json",
            "schemaName": self.schema_name,
            "schema": self.schema,
            "schemaEncoding": "jsonschema",
        })
    }
}

/// What every connection hears from the subscribers.
#[derive(Debug, Clone)]
enum Heard {
    /// A key heard for the first time.
    Channel(Arc<Channel>),
    /// A message on a channel, with when it was heard (ns since the epoch).
    Message {
        channel: u32,
        at_ns: u64,
        data: Arc<[u8]>,
    },
}

#[derive(Default)]
struct Channels {
    by_key: HashMap<String, Arc<Channel>>,
    /// A camera's frame channel → its picture channel.
    pictures: HashMap<u32, Arc<Channel>>,
    /// In the order they were made, for a client that connects later.
    all: Vec<Arc<Channel>>,
    /// Whether the limit on channels has been said.
    full_said: bool,
}

impl Channels {
    /// The watchers of channel `id`, if it is a camera's pictures.
    fn watchers(&self, id: u32) -> Option<&AtomicUsize> {
        let ch = self.all.get(usize::try_from(id.checked_sub(1)?).ok()?)?;
        ch.image.as_ref().map(|i| &i.watchers)
    }
}

/// The Zenoh side: subscribers that turn what they hear into channels and
/// messages for every connection.
pub struct Bridge {
    channels: Arc<Mutex<Channels>>,
    heard: broadcast::Sender<Heard>,
    started_ns: u64,
    _subscribers: Vec<Subscriber<()>>,
}

impl Bridge {
    /// Subscribes to `keys` on `session`.
    pub async fn start(session: &Session, keys: &[String]) -> anyhow::Result<Bridge> {
        let channels = Arc::new(Mutex::new(Channels::default()));
        let (heard, _) = broadcast::channel(BACKLOG);
        let fetch = Arc::new(Fetch {
            session: session.clone(),
            runtime: tokio::runtime::Handle::current(),
            heard: heard.clone(),
        });
        let mut subscribers = Vec::new();
        for key in keys {
            let (channels, fetch) = (channels.clone(), fetch.clone());
            let sub = session
                .declare_subscriber(key.clone())
                .callback(move |s| on_sample(&channels, &fetch, &s))
                .await
                .map_err(|e| anyhow::anyhow!("cannot subscribe to '{key}': {e}"))?;
            subscribers.push(sub);
        }
        Ok(Bridge {
            channels,
            heard,
            started_ns: now_ns(),
            _subscribers: subscribers,
        })
    }
}

/// What fetches a camera's pictures.
struct Fetch {
    session: Session,
    runtime: tokio::runtime::Handle,
    heard: broadcast::Sender<Heard>,
}

impl Fetch {
    /// Asks for the picture the camera has just grabbed, if anyone
    /// watches `channel` and none is on its way already.
    fn picture(&self, channel: &Arc<Channel>) {
        let Some(image) = &channel.image else { return };
        if image.watchers.load(Ordering::Acquire) == 0
            || image.fetching.swap(true, Ordering::AcqRel)
        {
            return;
        }
        let (session, heard, channel) = (self.session.clone(), self.heard.clone(), channel.clone());
        self.runtime.spawn(async move {
            let Some(image) = &channel.image else { return };
            match crate::view::grab_png(&session, &image.camera).await {
                Ok(png) if png.len() > MAX_PICTURE => tracing::debug!(
                    camera = %image.camera,
                    bytes = png.len(),
                    "rome foxglove: a picture larger than {MAX_PICTURE} bytes, not passed on"
                ),
                Ok(png) => {
                    let at_ns = now_ns();
                    let _ = heard.send(Heard::Message {
                        channel: channel.id,
                        at_ns,
                        data: compressed_image(&image.camera, at_ns, &png).into(),
                    });
                }
                Err(e) => {
                    tracing::debug!(camera = %image.camera, error = %e, "rome foxglove: no picture")
                }
            }
            image.fetching.store(false, Ordering::Release);
        });
    }
}

/// Foxglove's `CompressedImage` of `png`, as JSON.
fn compressed_image(frame_id: &str, at_ns: u64, png: &[u8]) -> Vec<u8> {
    use base64::Engine;
    json!({
        "timestamp": {"sec": at_ns / 1_000_000_000, "nsec": at_ns % 1_000_000_000},
        "frame_id": frame_id,
        "format": "png",
        "data": base64::engine::general_purpose::STANDARD.encode(png),
    })
    .to_string()
    .into_bytes()
}

/// For a camera's frame key (`…/camera/<camera>/frame`), the camera's
/// key.
fn camera_of(key: &str) -> Option<&str> {
    let (camera, last) = key.rsplit_once('/')?;
    (last == "frame" && camera.rsplit('/').nth(1) == Some("camera")).then_some(camera)
}

/// On a subscriber's thread: a JSON message becomes a channel's message
/// (and the channel, the first time, with a picture channel beside a
/// camera's frames); anything else is left out.
fn on_sample(channels: &Mutex<Channels>, fetch: &Fetch, s: &Sample) {
    let heard = &fetch.heard;
    if s.kind() == SampleKind::Delete {
        return;
    }
    let e = s.encoding();
    if *e != Encoding::APPLICATION_JSON && *e != Encoding::TEXT_JSON {
        return;
    }
    let data = s.payload().to_bytes();
    let key = s.key_expr().as_str();
    let at_ns = now_ns();
    // Under the lock, so that a channel is sent before its first message
    // to every connection.
    let mut c = channels.lock().unwrap_or_else(PoisonError::into_inner);
    let channel = match c.by_key.get(key) {
        Some(ch) => ch.id,
        None => {
            let Ok(first) = serde_json::from_slice::<Value>(&data) else {
                // Not JSON after all: nothing to build a schema from yet.
                return;
            };
            if c.all.len() + 2 > MAX_CHANNELS {
                if !c.full_said {
                    c.full_said = true;
                    tracing::warn!(
                        key,
                        "rome foxglove: {MAX_CHANNELS} channels already; keys heard from now on are not bridged"
                    );
                }
                return;
            }
            let ch = Arc::new(Channel {
                id: c.all.len() as u32 + 1,
                topic: key.to_string(),
                schema_name: crate::record::schema_name(key),
                schema: crate::record::json_schema(&first).to_string(),
                image: None,
            });
            c.by_key.insert(key.to_string(), ch.clone());
            c.all.push(ch.clone());
            // Nobody connected is no error.
            let _ = heard.send(Heard::Channel(ch.clone()));
            if let Some(camera) = camera_of(key) {
                let picture = Arc::new(Channel {
                    id: c.all.len() as u32 + 1,
                    topic: format!("{camera}/image"),
                    schema_name: "foxglove.CompressedImage".to_string(),
                    schema: COMPRESSED_IMAGE_SCHEMA.to_string(),
                    image: Some(Image {
                        camera: camera.to_string(),
                        watchers: AtomicUsize::new(0),
                        fetching: AtomicBool::new(false),
                    }),
                });
                c.pictures.insert(ch.id, picture.clone());
                c.all.push(picture.clone());
                let _ = heard.send(Heard::Channel(picture));
            }
            ch.id
        }
    };
    let _ = heard.send(Heard::Message {
        channel,
        at_ns,
        data: Arc::from(&data[..]),
    });
    let picture = c.pictures.get(&channel).cloned();
    drop(c);
    if let Some(p) = picture {
        fetch.picture(&p);
    }
}

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

async fn upgrade(State(bridge): State<Arc<Bridge>>, ws: WebSocketUpgrade) -> Response {
    ws.protocols([SUBPROTOCOL])
        .max_message_size(MAX_REQUEST)
        .on_upgrade(move |socket| connection(bridge, socket))
}

/// What a client asks for.
#[derive(Debug, serde::Deserialize)]
#[serde(tag = "op", rename_all = "camelCase")]
enum Request {
    Subscribe {
        subscriptions: Vec<Subscription>,
    },
    Unsubscribe {
        #[serde(rename = "subscriptionIds")]
        subscription_ids: Vec<u32>,
    },
}

#[derive(Debug, serde::Deserialize)]
struct Subscription {
    id: u32,
    #[serde(rename = "channelId")]
    channel_id: u32,
}

/// One client's subscriptions: channel → its subscription ids.
#[derive(Default)]
struct Subscribed {
    by_channel: BTreeMap<u32, Vec<u32>>,
    count: usize,
}

impl Subscribed {
    /// Applies `text`, a client's request; a status to send back when
    /// something in it was refused.
    fn apply(&mut self, text: &str, known: impl Fn(u32) -> bool) -> Option<(u8, String)> {
        let request: Request = match serde_json::from_str(text) {
            Ok(r) => r,
            Err(e) => {
                return Some((
                    ERROR,
                    format!(
                    "cannot take this request ({e}); this server takes subscribe and unsubscribe"
                ),
                ))
            }
        };
        let mut refused = Vec::new();
        match request {
            Request::Subscribe { subscriptions } => {
                for s in subscriptions {
                    if !known(s.channel_id) {
                        refused.push(format!("no channel {}", s.channel_id));
                    } else if self.by_channel.values().any(|ids| ids.contains(&s.id)) {
                        refused.push(format!("subscription {} is already in use", s.id));
                    } else if self.count >= MAX_SUBSCRIPTIONS {
                        refused.push(format!(
                            "subscription {} is one more than the {MAX_SUBSCRIPTIONS} a client may hold",
                            s.id
                        ));
                    } else {
                        self.by_channel.entry(s.channel_id).or_default().push(s.id);
                        self.count += 1;
                    }
                }
            }
            Request::Unsubscribe { subscription_ids } => {
                for id in subscription_ids {
                    let mut found = false;
                    for ids in self.by_channel.values_mut() {
                        if let Some(i) = ids.iter().position(|x| *x == id) {
                            ids.swap_remove(i);
                            found = true;
                        }
                    }
                    self.by_channel.retain(|_, ids| !ids.is_empty());
                    if found {
                        self.count -= 1;
                    } else {
                        refused.push(format!("no subscription {id}"));
                    }
                }
            }
        }
        (!refused.is_empty()).then(|| (ERROR, refused.join("; ")))
    }
}

/// The channels one connection subscribes to, counted among their
/// watchers while it does (a camera's pictures are fetched only while
/// someone watches).
struct Watching {
    bridge: Arc<Bridge>,
    channels: BTreeSet<u32>,
}

impl Watching {
    fn update(&mut self, subscribed: &Subscribed) {
        let now: BTreeSet<u32> = subscribed.by_channel.keys().copied().collect();
        let added: Vec<u32> = now.difference(&self.channels).copied().collect();
        let gone: Vec<u32> = self.channels.difference(&now).copied().collect();
        self.count(&added, true);
        self.count(&gone, false);
        self.channels = now;
    }

    /// Counts this connection in (or out of) the watchers of `ids`.
    fn count(&self, ids: &[u32], watching: bool) {
        let c = self
            .bridge
            .channels
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        for &id in ids {
            if let Some(w) = c.watchers(id) {
                if watching {
                    w.fetch_add(1, Ordering::AcqRel);
                } else {
                    w.fetch_sub(1, Ordering::AcqRel);
                }
            }
        }
    }
}

impl Drop for Watching {
    fn drop(&mut self) {
        let all: Vec<u32> = self.channels.iter().copied().collect();
        self.count(&all, false);
    }
}

fn status(level: u8, message: &str) -> Message {
    Message::Text(
        json!({"op": "status", "level": level, "message": message})
            .to_string()
            .into(),
    )
}

fn advertise(channels: &[Arc<Channel>]) -> Message {
    let list: Vec<Value> = channels.iter().map(|c| c.advertised()).collect();
    Message::Text(
        json!({"op": "advertise", "channels": list})
            .to_string()
            .into(),
    )
}

/// The binary frame of one message for subscription `sub`.
fn message_frame(sub: u32, at_ns: u64, data: &[u8]) -> Message {
    let mut frame = Vec::with_capacity(13 + data.len());
    frame.push(OP_MESSAGE_DATA);
    frame.extend_from_slice(&sub.to_le_bytes());
    frame.extend_from_slice(&at_ns.to_le_bytes());
    frame.extend_from_slice(data);
    Message::Binary(frame.into())
}

/// One client, from its handshake until it goes.
async fn connection(bridge: Arc<Bridge>, mut socket: WebSocket) {
    // Listening before the snapshot: a channel made in between comes
    // twice at most (once in each), never not at all.
    let mut heard = bridge.heard.subscribe();
    let (snapshot, known) = {
        let c = bridge
            .channels
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        (c.all.clone(), c.all.len() as u32)
    };
    let info = json!({
        "op": "serverInfo",
        "name": concat!("rome foxglove ", env!("CARGO_PKG_VERSION")),
        "capabilities": [],
        "supportedEncodings": [],
        "metadata": {},
        "sessionId": bridge.started_ns.to_string(),
    });
    if socket
        .send(Message::Text(info.to_string().into()))
        .await
        .is_err()
    {
        return;
    }
    if !snapshot.is_empty() && socket.send(advertise(&snapshot)).await.is_err() {
        return;
    }
    let mut advertised = known;
    let mut subscribed = Subscribed::default();
    let mut watching = Watching {
        bridge: bridge.clone(),
        channels: BTreeSet::new(),
    };
    loop {
        tokio::select! {
            biased;
            from_client = socket.recv() => {
                let reply = match from_client {
                    None | Some(Err(_)) | Some(Ok(Message::Close(_))) => return,
                    Some(Ok(Message::Text(text))) => {
                        let refused =
                            subscribed.apply(text.as_str(), |id| id >= 1 && id <= advertised);
                        watching.update(&subscribed);
                        refused
                    }
                    Some(Ok(Message::Binary(_))) => Some((
                        ERROR,
                        "this server takes no binary requests (no client publishing)".to_string(),
                    )),
                    // Pings are answered by the socket itself.
                    Some(Ok(_)) => None,
                };
                if let Some((level, message)) = reply {
                    if socket.send(status(level, &message)).await.is_err() {
                        return;
                    }
                }
            }
            next = heard.recv() => {
                let out = match next {
                    Ok(Heard::Channel(ch)) => {
                        if ch.id <= advertised {
                            continue;
                        }
                        advertised = ch.id;
                        vec![advertise(&[ch])]
                    }
                    Ok(Heard::Message { channel, at_ns, data }) => subscribed
                        .by_channel
                        .get(&channel)
                        .map(|subs| {
                            subs.iter()
                                .map(|&sub| message_frame(sub, at_ns, &data))
                                .collect()
                        })
                        .unwrap_or_default(),
                    Err(broadcast::error::RecvError::Lagged(n)) => {
                        // Channels made meanwhile are advertised again from
                        // the list, so none is missing.
                        let missed: Vec<Arc<Channel>> = {
                            let c = bridge.channels.lock().unwrap_or_else(PoisonError::into_inner);
                            c.all.iter().skip(advertised as usize).cloned().collect()
                        };
                        let mut out = Vec::new();
                        if let Some(last) = missed.last() {
                            advertised = last.id;
                            out.push(advertise(&missed));
                        }
                        out.push(status(
                            WARNING,
                            &format!("this connection was too slow and missed {n} message(s)"),
                        ));
                        out
                    }
                    Err(broadcast::error::RecvError::Closed) => {
                        let _ = socket.send(status(INFO, "the bridge is stopping")).await;
                        return;
                    }
                };
                for m in out {
                    if socket.send(m).await.is_err() {
                        return;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
