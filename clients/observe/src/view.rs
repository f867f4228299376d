//! `rome view`: one live web page of the fleet, served by the binary with
//! everything it needs built in (no CDN, no files beside it).
//!
//! ```text
//! rome view                          # http://127.0.0.1:8090, EB3
//! rome view --map fig5_3 --port 0    # a free port, said on stderr
//! ```
//!
//! The page shows the map, every robot's true pose (from the simulator's
//! ground truth, where there is one) and odometry pose with their trails,
//! the sonar ranges as rays, the planned route, the ceiling lights counted
//! and door plates found, each robot's blackboard, and a camera picture on
//! demand. It follows Zenoh through one server-sent-event stream:
//!
//! ```text
//! GET /              the page          GET /map.json     the map's shapes (mm)
//! GET /events        the live stream   GET /camera/R/C   a PNG grab of robot R's camera C
//! GET /view.js, /view.css              the page's script and style
//! GET /hold?ms=N     answers after N ms (at most 30 s): what `/?wait=S`
//!                    loads, so the page's load event comes S seconds late
//!                    and `chromium --headless --screenshot` shows live data
//! ```
//!
//! Events are JSON objects with a kind `k`: `state`, `truth`, `scan`,
//! `board`, `route`, `light`, `plate`, and `trail` (the trails so far, sent
//! to a page when it connects, after the last of each kind). Streams faster
//! than a page can use are thinned to 20 messages a second per robot.

use anyhow::Context;
use axum::extract::{Path as UrlPath, State};
use axum::http::{header, StatusCode};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use rome_common::args::{CommonArgs, Side};
use rome_common::exit;
use rome_maps::geometry::Pose;
use rome_maps::render::Shape;
use rome_schema::robot::body::{sonar_bearing_deg, SONAR_MAX_MM};
use rome_schema::robot::{BaseState, Scan};
use rome_schema::sim::Truth;
use rome_schema::Root;
use serde_json::{json, Value};
use std::collections::{BTreeMap, VecDeque};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::sync::broadcast;
use zenoh::sample::Sample;
use zenoh::Session;

const INDEX_HTML: &str = include_str!("view/index.html");
const VIEW_JS: &str = include_str!("view/view.js");
const VIEW_CSS: &str = include_str!("view/view.css");

/// Longest trail kept per robot and kind, points.
const TRAIL_POINTS: usize = 4000;
/// A trail point is kept when this far from the last, mm.
const TRAIL_STEP_MM: f64 = 100.0;
/// Fastest a robot's state, truth or scan goes to the page.
const MIN_GAP: Duration = Duration::from_millis(50);
/// Plates and lights kept per robot.
const MARKS: usize = 500;
/// Flags of `rome view`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Map: a built-in name (eb3, annex, campus, fig5_3) or a .stk file.
    #[arg(long, default_value = "eb3")]
    pub map: String,
    /// The HTTP port (0: any free one).
    #[arg(long, default_value_t = 8090)]
    pub port: u16,
    /// The address to serve on (0.0.0.0 to let other hosts look).
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: std::net::IpAddr,
}

/// Serves the page until Ctrl-C.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let map = rome_maps::load_named(&args.map)?;
    let session = common.open(Side::Client).await?;
    let root = common.root()?;
    let listener = tokio::net::TcpListener::bind((args.bind, args.port))
        .await
        .with_context(|| {
            format!(
                "cannot serve on {}:{} (is another rome view there? try --port 0)",
                args.bind, args.port
            )
        })?;
    let at = listener.local_addr()?;
    let view = View::start(&session, &root, &map).await?;
    eprintln!("{}tcp/{at}", rome_client::net::LISTENING);
    eprintln!(
        "rome view: http://{at}/ (map '{}'; Ctrl-C to stop)",
        map.name
    );
    serve(listener, view, exit::interrupted()).await?;
    Ok(exit::OK)
}

/// Serves `view` on `listener` until `shutdown` completes.
pub async fn serve(
    listener: tokio::net::TcpListener,
    view: View,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> anyhow::Result<()> {
    let app = axum::Router::new()
        .route(
            "/",
            get(|| async { page(INDEX_HTML, "text/html; charset=utf-8") }),
        )
        .route(
            "/view.js",
            get(|| async { page(VIEW_JS, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/view.css",
            get(|| async { page(VIEW_CSS, "text/css; charset=utf-8") }),
        )
        .route("/map.json", get(map_json))
        .route("/events", get(events))
        .route("/camera/{robot}/{camera}", get(camera))
        .route("/hold", get(hold))
        .with_state(Arc::new(view));
    axum::serve(listener, app)
        .with_graceful_shutdown(shutdown)
        .await
        .context("the web server failed")
}

fn page(body: &'static str, kind: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, kind),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        body,
    )
        .into_response()
}

/// The live side: what Zenoh brings, kept for pages that connect later
/// and passed on to those connected.
pub struct View {
    session: Session,
    root: Root,
    map_json: String,
    hub: Arc<Hub>,
    _subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
}

#[derive(Default)]
struct Robot {
    truth: Option<Pose>,
    odometry: Option<Pose>,
    sent: BTreeMap<&'static str, Instant>,
    trail_truth: VecDeque<[f64; 2]>,
    trail_odo: VecDeque<[f64; 2]>,
    lights: Option<u64>,
    board_seen: std::collections::HashSet<String>,
    marks: VecDeque<Value>,
}

struct Hub {
    tx: broadcast::Sender<Arc<str>>,
    state: Mutex<HubState>,
}

#[derive(Default)]
struct HubState {
    robots: BTreeMap<String, Robot>,
    /// The last event of each kind per robot (and variable).
    last: BTreeMap<String, Arc<str>>,
}

impl View {
    /// Subscribes to the fleet's streams and blackboards under `root`.
    pub async fn start(
        session: &Session,
        root: &Root,
        map: &rome_maps::Map,
    ) -> anyhow::Result<View> {
        let world = rome_maps::World::from_map(map);
        let map_json = map_shapes(map, &world).to_string();
        let (tx, _) = broadcast::channel(1024);
        let hub = Arc::new(Hub {
            tx,
            state: Mutex::new(HubState::default()),
        });
        let r = root.as_str();
        let mut subscribers = Vec::new();
        for key in [
            format!("{r}/robot/*/base/state"),
            format!("{r}/robot/*/proximity/scan"),
            format!("{r}/sim/*/truth"),
            format!("{r}/data/watch/nav/*/*"),
        ] {
            let hub = hub.clone();
            let prefix = format!("{r}/");
            let sub = session
                .declare_subscriber(key.clone())
                .callback(move |s| hub.heard(&prefix, &s))
                .await
                .map_err(|e| anyhow::anyhow!("cannot subscribe to '{key}': {e}"))?;
            subscribers.push(sub);
        }
        // What the blackboards hold already: the watch stream brings only
        // changes.
        if let Ok(replies) = session
            .get(format!("{r}/data/var/nav/*/*"))
            .timeout(Duration::from_secs(2))
            .await
        {
            let var_prefix = format!("{r}/data/var/nav/");
            while let Ok(reply) = replies.recv_async().await {
                let Ok(sample) = reply.result() else { continue };
                let Some((robot, var)) = sample
                    .key_expr()
                    .as_str()
                    .strip_prefix(&var_prefix)
                    .and_then(|rest| rest.split_once('/'))
                else {
                    continue;
                };
                if let Ok(v) = serde_json::from_slice::<Value>(&sample.payload().to_bytes()) {
                    for e in hub.board(robot, var, v, true) {
                        let _ = hub.tx.send(e);
                    }
                }
            }
        }
        Ok(View {
            session: session.clone(),
            root: root.clone(),
            map_json,
            hub,
            _subscribers: subscribers,
        })
    }
}

impl Hub {
    /// One sample from Zenoh; anything that does not decode is skipped.
    fn heard(&self, prefix: &str, s: &Sample) {
        let Some(rest) = s.key_expr().as_str().strip_prefix(prefix) else {
            return;
        };
        let bytes = s.payload().to_bytes();
        let parts: Vec<&str> = rest.split('/').collect();
        let events = match parts.as_slice() {
            ["robot", robot, "base", "state"] => rome_schema::decode::<BaseState>(&bytes, "state")
                .ok()
                .map(|m| self.state(robot, &m)),
            ["robot", robot, "proximity", "scan"] => rome_schema::decode::<Scan>(&bytes, "scan")
                .ok()
                .map(|m| self.scan(robot, &m)),
            ["sim", robot, "truth"] => rome_schema::decode::<Truth>(&bytes, "truth")
                .ok()
                .map(|m| self.truth(robot, &m)),
            ["data", "watch", "nav", robot, var] => {
                rome_schema::decode::<rome_schema::data::Committed>(&bytes, "watch")
                    .ok()
                    .map(|c| self.board(robot, var, c.value.unwrap_or(Value::Null), false))
            }
            _ => None,
        };
        for e in events.into_iter().flatten() {
            let _ = self.tx.send(e);
        }
    }

    fn with_robot<T>(
        &self,
        robot: &str,
        f: impl FnOnce(&mut Robot, &mut BTreeMap<String, Arc<str>>) -> T,
    ) -> Option<T> {
        let mut st = self.state.lock().ok()?;
        let HubState { robots, last } = &mut *st;
        if !robots.contains_key(robot) && robots.len() >= 1000 {
            // Names a peer makes up cannot grow this without bound.
            return None;
        }
        let r = robots.entry(robot.to_string()).or_default();
        Some(f(r, last))
    }

    fn state(&self, robot: &str, m: &BaseState) -> Vec<Arc<str>> {
        let pose = Pose::from(m);
        self.with_robot(robot, |r, last| {
            r.odometry = Some(pose);
            push_trail(&mut r.trail_odo, &pose);
            if !due(r, "state") {
                return vec![];
            }
            let e = pose_event("state", robot, &pose, json!({
                "mode": m.mode, "speed_mm_s": m.speed_mm_s, "lock": m.lock.as_ref().map(|l| l.holder.clone()), "queued": m.queued,
            }));
            vec![keep(last, format!("state/{robot}"), e)]
        })
        .unwrap_or_default()
    }

    fn truth(&self, robot: &str, m: &Truth) -> Vec<Arc<str>> {
        let pose = Pose::from(m);
        if !(pose.at.x.is_finite() && pose.at.y.is_finite() && pose.heading.deg().is_finite()) {
            return vec![];
        }
        self.with_robot(robot, |r, last| {
            r.truth = Some(pose);
            push_trail(&mut r.trail_truth, &pose);
            if !due(r, "truth") {
                return vec![];
            }
            let e = pose_event(
                "truth",
                robot,
                &pose,
                json!({
                    "travelled_mm": m.travelled_mm, "contacts": m.contacts.wall + m.contacts.robot,
                }),
            );
            vec![keep(last, format!("truth/{robot}"), e)]
        })
        .unwrap_or_default()
    }

    fn scan(&self, robot: &str, m: &Scan) -> Vec<Arc<str>> {
        self.with_robot(robot, |r, last| {
            // Drawn from where the robot truly is, so the rays meet the
            // walls they echo from; odometry where there is no truth.
            let Some(pose) = r.truth.or(r.odometry) else {
                return vec![];
            };
            if !due(r, "scan") {
                return vec![];
            }
            let rays: Vec<Value> = m
                .sonar_mm
                .iter()
                .take(24)
                .enumerate()
                .map(|(i, &mm)| {
                    let d = pose.heading.turned(sonar_bearing_deg(i)).unit();
                    // A range at the ring's maximum is no echo.
                    let reach = f64::from(mm).min(SONAR_MAX_MM);
                    let end = pose.at + d * reach;
                    json!([end.x.round(), end.y.round(), reach < SONAR_MAX_MM])
                })
                .collect();
            let e = json!({"k": "scan", "robot": robot, "from": [pose.at.x.round(), pose.at.y.round()], "rays": rays});
            vec![keep(last, format!("scan/{robot}"), e)]
        })
        .unwrap_or_default()
    }

    /// A blackboard value: from the watch stream, or (`initial`) read at
    /// start, which yields to anything the stream already brought.
    fn board(&self, robot: &str, var: &str, v: Value, initial: bool) -> Vec<Arc<str>> {
        self.with_robot(robot, |r, last| {
            if initial && !r.board_seen.insert(var.to_string()) {
                return vec![];
            }
            r.board_seen.insert(var.to_string());
            let mut out = Vec::new();
            match var {
                "Route" => {
                    out.push(keep(last, format!("route/{robot}"), json!({"k": "route", "robot": robot, "v": v})));
                }
                "CeilingLight" => {
                    // A light counted: marked where the robot thinks it is.
                    let n = v.as_u64().unwrap_or(0);
                    if let (Some(before), Some(p)) = (r.lights, r.odometry) {
                        if n > before {
                            out.push(mark(r, json!({"k": "light", "robot": robot, "x": p.at.x.round(), "y": p.at.y.round(), "n": n})));
                        }
                    }
                    r.lights = Some(n);
                }
                "Plate" => {
                    if let (Some(x), Some(y)) = (v["x_mm"].as_f64(), v["y_mm"].as_f64()) {
                        out.push(mark(r, json!({"k": "plate", "robot": robot, "x": x, "y": y, "label": v["label"]})));
                    }
                }
                _ => {}
            }
            out.push(keep(last, format!("board/{robot}/{var}"), json!({"k": "board", "robot": robot, "var": var, "v": v})));
            out
        })
        .unwrap_or_default()
    }

    /// What a page that just connected needs: the trails and marks so
    /// far, then the last event of each kind.
    fn snapshot(&self) -> Vec<Arc<str>> {
        let Ok(st) = self.state.lock() else {
            return vec![];
        };
        let mut out = Vec::new();
        for (name, r) in &st.robots {
            let e = json!({"k": "trail", "robot": name, "truth": r.trail_truth, "odometry": r.trail_odo});
            out.push(Arc::from(e.to_string()));
            out.extend(r.marks.iter().map(|m| Arc::from(m.to_string())));
        }
        out.extend(st.last.values().cloned());
        out
    }
}

fn due(r: &mut Robot, kind: &'static str) -> bool {
    let now = Instant::now();
    match r.sent.get(kind) {
        Some(t) if now.duration_since(*t) < MIN_GAP => false,
        _ => {
            r.sent.insert(kind, now);
            true
        }
    }
}

fn push_trail(trail: &mut VecDeque<[f64; 2]>, p: &Pose) {
    let far = trail
        .back()
        .is_none_or(|b| (b[0] - p.at.x).hypot(b[1] - p.at.y) >= TRAIL_STEP_MM);
    if far {
        trail.push_back([p.at.x.round(), p.at.y.round()]);
        if trail.len() > TRAIL_POINTS {
            trail.pop_front();
        }
    }
}

fn mark(r: &mut Robot, e: Value) -> Arc<str> {
    r.marks.push_back(e.clone());
    if r.marks.len() > MARKS {
        r.marks.pop_front();
    }
    Arc::from(e.to_string())
}

fn keep(last: &mut BTreeMap<String, Arc<str>>, slot: String, e: Value) -> Arc<str> {
    let e: Arc<str> = Arc::from(e.to_string());
    last.insert(slot, e.clone());
    e
}

fn pose_event(kind: &str, robot: &str, p: &Pose, extra: Value) -> Value {
    let d = p.heading.unit();
    let mut e = json!({
        "k": kind, "robot": robot,
        "x": p.at.x.round(), "y": p.at.y.round(),
        "heading": (p.heading.deg() * 10.0).round() / 10.0,
        "dir": [d.x, d.y],
    });
    if let (Some(o), Value::Object(x)) = (e.as_object_mut(), extra) {
        o.extend(x);
    }
    e
}

/// The map as the renderer draws it: lines, dots and labels in mm.
fn map_shapes(map: &rome_maps::Map, world: &rome_maps::World) -> Value {
    let hex = |c: [u8; 3]| format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]);
    let (mut lines, mut dots, mut texts) = (Vec::new(), Vec::new(), Vec::new());
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let mut grow = |x: f64, y: f64| {
        lo = [lo[0].min(x), lo[1].min(y)];
        hi = [hi[0].max(x), hi[1].max(y)];
    };
    for s in rome_maps::render::scene(map, world) {
        match s {
            Shape::Line {
                a,
                b,
                color,
                width,
                dashed,
            } => {
                grow(a.x, a.y);
                grow(b.x, b.y);
                lines.push(json!([a.x, a.y, b.x, b.y, hex(color), width, dashed]));
            }
            Shape::Dot { at, radius, color } => dots.push(json!([at.x, at.y, radius, hex(color)])),
            Shape::Text {
                at,
                text,
                color,
                size,
            } => texts.push(json!([at.x, at.y, text, hex(color), size])),
        }
    }
    json!({"name": map.name, "min": lo, "max": hi, "lines": lines, "dots": dots, "texts": texts})
}

async fn map_json(State(view): State<Arc<View>>) -> Response {
    (
        [(header::CONTENT_TYPE, "application/json")],
        view.map_json.clone(),
    )
        .into_response()
}

async fn events(State(view): State<Arc<View>>) -> impl IntoResponse {
    // Subscribed before the snapshot is taken, so nothing falls between.
    let rx = view.hub.tx.subscribe();
    let first: VecDeque<Arc<str>> = view.hub.snapshot().into();
    let stream = futures_util::stream::unfold((first, rx), |(mut first, mut rx)| async move {
        if let Some(e) = first.pop_front() {
            return Some((
                Ok::<_, std::convert::Infallible>(SseEvent::default().data(&*e)),
                (first, rx),
            ));
        }
        loop {
            match rx.recv().await {
                Ok(e) => return Some((Ok(SseEvent::default().data(&*e)), (first, rx))),
                // A page too slow for the stream misses some; the next
                // state and truth put it right.
                Err(broadcast::error::RecvError::Lagged(_)) => continue,
                Err(broadcast::error::RecvError::Closed) => return None,
            }
        }
    });
    Sse::new(stream).keep_alive(KeepAlive::default())
}

async fn hold(axum::extract::Query(q): axum::extract::Query<BTreeMap<String, String>>) -> Response {
    let ms = q
        .get("ms")
        .and_then(|v| v.parse::<u64>().ok())
        .unwrap_or(0)
        .min(30_000);
    tokio::time::sleep(Duration::from_millis(ms)).await;
    // A transparent 1×1 GIF.
    const GIF: &[u8] = b"GIF89a\x01\x00\x01\x00\x80\x00\x00\x00\x00\x00\xff\xff\xff!\xf9\x04\x01\x00\x00\x00\x00,\x00\x00\x00\x00\x01\x00\x01\x00\x00\x02\x02D\x01\x00;";
    (
        [
            (header::CONTENT_TYPE, "image/gif"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        GIF,
    )
        .into_response()
}

async fn camera(
    State(view): State<Arc<View>>,
    UrlPath((robot, cam)): UrlPath<(String, String)>,
) -> Response {
    let bad = |what: &str, v: &str| {
        (
            StatusCode::BAD_REQUEST,
            format!("'{v}' is not a {what} name"),
        )
            .into_response()
    };
    let Ok(robot) = rome_schema::Name::new(&robot) else {
        return bad("robot", &robot);
    };
    let Ok(cam) = rome_schema::Name::new(&cam) else {
        return bad("camera", &cam);
    };
    let camera = format!("{}/robot/{robot}/camera/{cam}", view.root.as_str());
    match grab_png(&view.session, &camera).await {
        Ok(png) => (
            [
                (header::CONTENT_TYPE, "image/png"),
                (header::CACHE_CONTROL, "no-store"),
            ],
            png,
        )
            .into_response(),
        Err(e @ NoPicture::Ask(_)) => (StatusCode::BAD_GATEWAY, e.to_string()).into_response(),
        Err(NoPicture::Refused(why)) => (
            StatusCode::BAD_GATEWAY,
            format!("robot {robot} camera {cam}: {why}"),
        )
            .into_response(),
        Err(NoPicture::Silent) => (
            StatusCode::GATEWAY_TIMEOUT,
            format!(
                "robot {robot} camera {cam} did not answer within 3 s (is it running? `rome ls`)"
            ),
        )
            .into_response(),
    }
}

/// Why a camera gave no picture.
#[derive(Debug)]
pub(crate) enum NoPicture {
    /// The query could not be sent (what went wrong, with the key).
    Ask(String),
    /// The camera server answered with an error.
    Refused(String),
    /// Nobody answered in time.
    Silent,
}

impl std::fmt::Display for NoPicture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NoPicture::Ask(e) => write!(f, "{e}"),
            NoPicture::Refused(why) => write!(f, "refused: {why}"),
            NoPicture::Silent => write!(f, "no answer within 3 s"),
        }
    }
}

/// The last picture the camera at key `camera` (`ROOT/robot/R/camera/C`)
/// grabbed, as PNG: asked at a low priority, waiting at most 2 s in the
/// camera's queue and 3 s in all, so that the camera gives up on the
/// request before the asker does.
pub(crate) async fn grab_png(session: &Session, camera: &str) -> Result<Vec<u8>, NoPicture> {
    use rome_schema::robot::{command::Command, command::Grab, param};
    let mut params = Grab { png: true }.params();
    params.push((param::WAIT_MS, "2000".into()));
    params.push((param::PRIORITY, "64".into()));
    let params: Vec<String> = params.iter().map(|(k, v)| format!("{k}={v}")).collect();
    let key = format!("{camera}/{}?{}", Grab::NAME, params.join(";"));
    let replies = session
        .get(&key)
        .timeout(Duration::from_secs(3))
        .await
        .map_err(|e| NoPicture::Ask(format!("cannot ask {key}: {e}")))?;
    let reply = replies.recv_async().await.map_err(|_| NoPicture::Silent)?;
    match reply.result() {
        Ok(s) => Ok(s.payload().to_bytes().into_owned()),
        Err(e) => Err(NoPicture::Refused(
            String::from_utf8_lossy(&e.payload().to_bytes()).into_owned(),
        )),
    }
}
