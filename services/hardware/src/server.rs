//! The Zenoh side every hardware server shares: one queryable on
//! `<root>/robot/<robot>/<device>/*`, the [`Gate`] (priorities and lock),
//! the lock's storage record, its liveliness watch, and the publication
//! stream.
//!
//! As in the data server, every input becomes an event on one channel and
//! one task owns the device, so requests reach the device one at a time.
//! Before serving, the task takes in every request that has arrived, so
//! when the device is slower than its clients the queue, not arrival
//! order, decides who goes next.

use crate::gate::{Admit, Gate, Holder};
use rome_clock::Instant;
use rome_schema::robot::command::{Command, ReleaseLock, TakeLock};
use rome_schema::robot::Stop;
use rome_schema::robot::{param, LockGrant, LockInfo, Meta, Unlocked, DEFAULT_LOCK_TTL_MS};
use rome_schema::{encode, ErrorCode, ErrorReply, Params};
use rome_serve::{reply_err, Handler, Inbox, Periods};
use std::collections::{HashMap, VecDeque};
use std::future::Future;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;
use zenoh::bytes::{Encoding, ZBytes};
use zenoh::query::Query;
use zenoh::Session;
mod config;
mod watch;
pub use config::{declare_err, Place, ServerConfig, ServerError};

/// How many requests may wait for a server (in its channel, and again in
/// its priority queue) before it answers `busy`.
pub const EVENT_QUEUE: usize = 1024;
/// How many request ids (`op`) a server remembers with their answers.
pub const REMEMBERED_OPS: usize = 4096;

/// How many request ids carried out are kept to count any carried out
/// twice: far more than [`REMEMBERED_OPS`], so a repeat that came after its
/// answer was forgotten would still be seen.
const COUNTED_OPS: usize = 65_536;
/// How often lapsed grants and overdue requests are swept.
pub const SWEEP: Duration = Duration::from_millis(100);

/// How long a server waits for the storage's answer about its lock
/// record, and how many times it asks before starting with the lock free.
const STORE_WAIT: Duration = Duration::from_secs(2);
const STORE_ATTEMPTS: u32 = 3;

/// A reply or publication body.
#[derive(Debug, Clone, PartialEq)]
pub enum Body {
    /// A JSON message.
    Json(Vec<u8>),
    /// Binary data with its encoding (images, rows).
    Binary(Vec<u8>, Encoding),
}

impl Body {
    /// A JSON body from a message.
    pub fn json(message: &impl serde::Serialize) -> Self {
        Body::Json(encode(message))
    }

    /// The payload and its encoding on the wire.
    pub fn into_parts(self) -> (ZBytes, Encoding) {
        match self {
            Body::Json(b) => (ZBytes::from(b), Encoding::APPLICATION_JSON),
            Body::Binary(b, e) => (ZBytes::from(b), e),
        }
    }
}

/// Answers a command that changes nothing, named by its key chunk and
/// given its parameters (those every request may carry taken out), at
/// once from the device's present state, from any thread and without
/// waiting; `None` leaves it to the event loop (a command it does not
/// answer so, parameters it would refuse, a device busy right now).
pub type QuickRead = Arc<dyn Fn(&str, Params) -> Option<Body> + Send + Sync>;

/// Refuses a payload on `command`, which takes none (white space aside).
pub fn no_payload(command: &str, body: Option<&[u8]>) -> Result<(), ErrorReply> {
    match body {
        Some(b) if b.iter().any(|c| !c.is_ascii_whitespace()) => Err(ErrorReply::new(
            ErrorCode::BadJson,
            format!("'{command}' takes no payload"),
        )),
        _ => Ok(()),
    }
}

/// A device's commands: what a hardware server needs to know of them.
pub trait Service: Send + Sync + 'static {
    /// A parsed command.
    type Cmd: Send + Sync + 'static;

    /// The commands, for error messages and docs (lock/unlock excepted).
    const COMMANDS: &'static [&'static str];

    /// Whether the device has a lock token (base, cameras).
    const LOCKABLE: bool;

    /// The commands that only read the device (a base's pose, a sonar
    /// scan): they also answer a wildcard key, one reply per device, so
    /// `z_get 'rome/robot/*/base/pose'` finds every robot.
    const READS: &'static [&'static str] = &[];

    /// Parses a command from its key chunk, parameters and payload; takes
    /// the parameters it knows and refuses the rest.
    fn parse(
        &self,
        command: &str,
        params: Params,
        payload: Option<&[u8]>,
    ) -> Result<Self::Cmd, ErrorReply>;

    /// A way to answer commands that only read (a pose, a scan, camera
    /// rows) from the queryable's callback, if the device can be read
    /// without waiting (a simulated one). The server uses it only when
    /// nothing is queued, being handled or holding the lock, so a quick
    /// read never overtakes a request sent before it.
    fn quick(&self) -> Option<QuickRead> {
        None
    }

    /// Carries a command out on the device.
    fn apply(
        &mut self,
        cmd: Self::Cmd,
        lock: Option<LockInfo>,
    ) -> impl Future<Output = Result<Body, ErrorReply>> + Send;

    /// Whether `cmd` leaves the device moving on its own (a base's move,
    /// turn, go or jog): the server then remembers who sent it, and stops
    /// the device with [`Service::halt`] if that client goes away.
    fn sets_moving(&self, _cmd: &Self::Cmd) -> bool {
        false
    }

    /// Stops the device because the client that set it moving is gone;
    /// says whether it was still in motion (a move may have ended on its
    /// own long before).
    fn halt(&mut self) -> impl Future<Output = Result<bool, ErrorReply>> + Send {
        async { Ok(false) }
    }

    /// How often [`Service::tick`] runs; `None` for never.
    fn period(&self) -> Option<Duration>;

    /// Periodic work (the state stream, a scan, a grab): what to publish,
    /// on which command chunk.
    fn tick(
        &mut self,
        lock: Option<LockInfo>,
        queued: usize,
    ) -> impl Future<Output = Option<(&'static str, Body)>> + Send;
}

enum Op<C> {
    Lock { owner: String, ttl: Duration },
    Unlock { fence: u64 },
    Do(C),
}

struct Pending<C> {
    query: Query,
    command: String,
    client: Option<String>,
    op_id: Option<String>,
    arrived: Instant,
    priority: u8,
    /// Whether it carried the lock holder's fence (never suppressed).
    fenced: bool,
    suppress: Option<Duration>,
    op: Op<C>,
}

/// A hardware server has no events of its own.
type Event = rome_serve::Event<std::convert::Infallible>;

struct Server<S: Service> {
    session: Session,
    /// The streams' keys, declared once (see `rome_serve::keys`).
    keys: rome_serve::keys::Declared,
    config: ServerConfig,
    service: S,
    gate: Gate<Pending<S::Cmd>>,
    /// The client whose command left the device moving, if it named itself.
    mover: Option<String>,
    /// Answers to requests that carried an id, so a repeat (a client whose
    /// reply was lost) is answered without acting twice; oldest dropped
    /// first past [`REMEMBERED_OPS`].
    done: HashMap<String, Result<Body, ErrorReply>>,
    done_order: VecDeque<String>,
    /// What was carried out, for `stats`.
    stats: rome_schema::robot::CommandStats,
    executed_ids: std::collections::HashSet<String>,
    executed_order: VecDeque<String>,
    /// The last publication of each stream (`state`, `scan`, `frame`),
    /// answered to a query on its key.
    last: HashMap<&'static str, (ZBytes, Encoding)>,
    /// Whether a read may be answered from the queryable's callback: no
    /// request queued and no lock held (kept up to date at the end of every
    /// event, while the event itself still counts as being handled).
    quiet: Arc<AtomicBool>,
    /// Reads answered from the callback, counted into `stats`.
    quick_reads: Arc<AtomicU64>,
}

/// Runs a hardware server for `service` until `shutdown` completes.
///
/// Refuses to start if another server already owns the device. Reads the
/// lock's last state from the storage (`<root>/store/...`), so a restarted
/// server knows the holder and never reuses a fence.
pub async fn run<S: Service>(
    session: Session,
    config: ServerConfig,
    service: S,
    shutdown: impl Future<Output = ()>,
) -> Result<(), ServerError> {
    let alive_key = config.alive_key();
    let existing = session
        .liveliness()
        .get(&alive_key)
        .timeout(Duration::from_millis(500))
        .await
        .map_err(|e| declare_err("the liveliness query", e))?;
    if let Ok(reply) = existing.recv_async().await {
        if let Ok(sample) = reply.result() {
            return Err(ServerError::AlreadyServed {
                label: config.label(),
                key: sample.key_expr().to_string(),
            });
        }
    }

    // A callback never waits on the queue (it runs on the link's receive
    // path, or on the task of a client in the same session): a full queue
    // answers `busy` at once. Liveliness changes have a queue of their
    // own that never drops: lock releases and the deadman depend on them.
    let inbox = Inbox::new(&config.label(), EVENT_QUEUE)
        .reads(|q| rome_schema::robot::only_reads(q.key_expr().as_str()));
    let quiet = Arc::new(AtomicBool::new(false));
    let quick_reads = Arc::new(AtomicU64::new(0));
    let answer_now = quick_answer(service.quick(), quiet.clone(), quick_reads.clone());
    let _queryable = session
        .declare_queryable(config.key("*"))
        .callback(inbox.on_query_or(answer_now))
        .await
        .map_err(|e| declare_err("the device queryable", e))?;
    let _alive = session
        .liveliness()
        .declare_subscriber(config.root.alive_clients())
        .callback(inbox.on_alive())
        .await
        .map_err(|e| declare_err("the liveliness subscriber", e))?;
    // A storage that comes (back) up may have missed the last lock record,
    // which is a plain put: it gets it again.
    let _stores = session
        .liveliness()
        .declare_subscriber(config.root.alive_server(crate::storage::STORE_KIND, "*"))
        .callback(inbox.on_alive())
        .await
        .map_err(|e| declare_err("the storage liveliness subscriber", e))?;

    let mut server = Server {
        gate: Gate::new(0),
        mover: None,
        done: HashMap::new(),
        done_order: VecDeque::new(),
        stats: Default::default(),
        executed_ids: Default::default(),
        executed_order: VecDeque::new(),
        last: HashMap::new(),
        quiet,
        quick_reads,
        keys: rome_serve::keys::Declared::new(&session),
        session,
        config,
        service,
    };
    if S::LOCKABLE {
        server.restore_lock().await;
    }
    server.settle();
    let _token = rome_serve::presence::declare(&server.session, &alive_key)
        .await
        .map_err(|e| declare_err("the liveliness token", e))?;
    tracing::info!(server = %server.config.label(), "ready");

    let periods = Periods {
        sweep: SWEEP,
        tick: server.service.period(),
    };
    inbox.run(&mut server, periods, shutdown).await;
    for pending in server.gate.drain_all() {
        let e = ErrorReply::new(
            ErrorCode::ShuttingDown,
            format!("{} is shutting down", server.config.label()),
        );
        reply_err(&pending.query, &e).await;
    }
    tracing::info!(server = %server.config.label(), "stopped");
    Ok(())
}

impl<S: Service> Handler<std::convert::Infallible> for Server<S> {
    async fn event(&mut self, event: Event) {
        match event {
            Event::Query(q) => self.query(q).await,
            Event::Alive(s) => self.alive(s).await,
            // Nobody subscribes to puts here, and there are no own events.
            Event::Put(_) | Event::Own(_) => {}
        }
        self.settle();
    }

    async fn drained(&mut self) {
        self.drain().await;
        self.settle();
    }

    async fn sweep(&mut self) {
        self.sweep_now().await;
        self.settle();
    }

    async fn tick(&mut self) {
        self.tick_now().await;
        self.settle();
    }
}

/// The queryable's quick path: a plain read (no fence, request id,
/// suppression or payload) answered from the device's present state while
/// the server is `quiet`.
fn quick_answer(
    quick: Option<QuickRead>,
    quiet: Arc<AtomicBool>,
    count: Arc<AtomicU64>,
) -> impl Fn(&Query) -> bool + Send + Sync + 'static {
    move |q| {
        let Some(quick) = &quick else {
            return false;
        };
        if !quiet.load(Ordering::SeqCst) || q.payload().is_some() {
            return false;
        }
        let key = q.key_expr().as_str();
        if key.contains(['*', '$']) {
            return false;
        }
        let command = key.rsplit('/').next().unwrap_or_default();
        let mut params = Params::new(q.parameters().iter());
        let plain = Meta::take(&mut params)
            .is_ok_and(|m| m.fence.is_none() && m.op.is_none() && m.suppress_ms.is_none());
        if !plain {
            return false;
        }
        let Some(body) = quick(command, params) else {
            return false;
        };
        count.fetch_add(1, Ordering::Relaxed);
        let (bytes, encoding) = body.into_parts();
        rome_serve::reply_now(q, key, bytes, encoding);
        true
    }
}

impl<S: Service> Server<S> {
    /// Says whether reads may be answered from the callback now.
    fn settle(&self) {
        let quiet = self.gate.queued() == 0 && self.gate.holder().is_none();
        self.quiet.store(quiet, Ordering::SeqCst);
    }

    fn lock(&self) -> Option<LockInfo> {
        self.gate.holder().map(Holder::info)
    }

    fn parse(
        &self,
        command: &str,
        mut params: Params,
        fence: Option<u64>,
        payload: Option<&[u8]>,
    ) -> Result<Op<S::Cmd>, ErrorReply> {
        let lockable = S::LOCKABLE;
        match command {
            TakeLock::NAME if lockable => {
                let lock = TakeLock::parse(&mut params, fence)?;
                params.finish(TakeLock::NAME, &[param::OWNER, param::TTL_MS])?;
                Ok(Op::Lock {
                    owner: lock.owner.unwrap_or_else(|| "anonymous".into()),
                    ttl: Duration::from_millis(lock.ttl_ms.unwrap_or(DEFAULT_LOCK_TTL_MS)),
                })
            }
            ReleaseLock::NAME if lockable => {
                params.finish(ReleaseLock::NAME, &[param::FENCE])?;
                let fence = fence.ok_or_else(|| {
                    ErrorReply::new(
                        ErrorCode::BadParameter,
                        "'unlock' needs the grant's 'fence' parameter (the number 'lock' answered)",
                    )
                })?;
                Ok(Op::Unlock { fence })
            }
            _ => {
                let known = S::COMMANDS;
                if !known.contains(&command) {
                    let mut all: Vec<&str> = known.to_vec();
                    if lockable {
                        all.extend([TakeLock::NAME, ReleaseLock::NAME]);
                    }
                    return Err(ErrorReply::new(
                        ErrorCode::UnknownKey,
                        format!(
                            "{} has no command '{command}'; it has {}",
                            self.config.label(),
                            all.join(", ")
                        ),
                    ));
                }
                self.service.parse(command, params, payload).map(Op::Do)
            }
        }
    }

    async fn query(&mut self, query: Query) {
        let key = query.key_expr().as_str().to_string();
        if key.contains(['*', '$']) {
            return self.sweep_query(query).await;
        }
        let mut params = Params::new(query.parameters().iter());
        let meta = match Meta::take(&mut params) {
            Ok(m) => m,
            Err(e) => return reply_err(&query, &e).await,
        };
        let command = key.rsplit('/').next().unwrap_or_default().to_string();
        if command == "stats" {
            // Not a device command: answered at once, lock or no lock.
            if let Err(e) = params.finish("stats", &[]) {
                return reply_err(&query, &e).await;
            }
            let mut stats = self.stats;
            stats.executed += self.quick_reads.load(Ordering::Relaxed);
            return reply(&query, &key, Body::json(&stats)).await;
        }
        if let Some((bytes, encoding)) = self.last.get(command.as_str()) {
            // A stream's key answers with its last publication.
            if let Err(e) = params.finish(&command, &[]) {
                return reply_err(&query, &e).await;
            }
            let (bytes, encoding) = (bytes.clone(), encoding.clone());
            return rome_serve::reply(&query, &key, bytes, encoding).await;
        }
        let payload = query.payload().map(|p| p.to_bytes().into_owned());
        let op = match self.parse(&command, params, meta.fence, payload.as_deref()) {
            Ok(op) => op,
            Err(e) => {
                tracing::debug!(%key, error = %e, "request refused");
                return reply_err(&query, &e).await;
            }
        };
        let now = Instant::now();
        let pending = Pending {
            query,
            command,
            client: meta.client,
            op_id: meta.op,
            arrived: now,
            priority: meta.priority,
            fenced: meta.fence.is_some(),
            suppress: meta.suppress_ms.map(Duration::from_millis),
            op,
        };
        let wait = Duration::from_millis(meta.wait_ms);
        let holds = meta.fence.is_some() && meta.fence == self.gate.holder().map(|h| h.fence);
        if self.gate.queued() >= EVENT_QUEUE && !holds {
            // Requests wait up to MAX_WAIT_MS behind a lock: without a cap a
            // flood would hold memory for that long.
            return reply_err(&pending.query, &busy(&self.config.label(), "queued")).await;
        }
        match self
            .gate
            .admit(meta.priority, meta.fence, wait, pending, now)
        {
            Admit::Now(p) => self.serve(p).await,
            Admit::Queued => {}
            Admit::Stale { fence, item } => {
                let current = match self.gate.holder() {
                    Some(h) => format!("the lock is held by '{}' with fence {}", h.owner, h.fence),
                    None => "the lock is free".to_string(),
                };
                let e = ErrorReply::new(
                    ErrorCode::StaleFence,
                    format!(
                        "fence {fence} on {} is stale: {current}; lock again to get a new fence",
                        self.config.label()
                    ),
                );
                reply_err(&item.query, &e).await;
            }
        }
    }

    /// Answers a query whose key has wildcards: every read and every
    /// JSON stream of this device that the key matches, one reply each,
    /// at once, since a read changes nothing a lock holder relies on. A
    /// key that matches only commands that act (or return images) gets an
    /// error reply: those need one robot and device named.
    async fn sweep_query(&mut self, query: Query) {
        let wanted = query.key_expr().clone();
        let key_of = |chunk: &str| self.config.key(chunk);
        let matches = |chunk: &str| {
            zenoh::key_expr::KeyExpr::new(key_of(chunk)).is_ok_and(|k| wanted.intersects(&k))
        };
        let reads = S::READS;
        let reads_said = if reads.is_empty() {
            "none".to_string()
        } else {
            reads.join(", ")
        };
        let mut answered = 0usize;
        for &chunk in reads {
            if !matches(chunk) {
                continue;
            }
            let key = key_of(chunk);
            let result = match self
                .service
                .parse(chunk, Params::new(std::iter::empty()), None)
            {
                Ok(cmd) => self.service.apply(cmd, self.lock()).await,
                Err(e) => Err(e),
            };
            match result {
                Ok(body) => reply(&query, &key, body).await,
                // One device failing is said, and the others still answer.
                Err(e) => reply_err(&query, &e).await,
            }
            answered += 1;
        }
        let streams: Vec<(&'static str, ZBytes)> = self
            .last
            .iter()
            .filter(|(chunk, (_, enc))| *enc == Encoding::APPLICATION_JSON && matches(chunk))
            .map(|(chunk, (bytes, _))| (*chunk, bytes.clone()))
            .collect();
        for (chunk, bytes) in streams {
            rome_serve::reply(&query, &key_of(chunk), bytes, Encoding::APPLICATION_JSON).await;
            answered += 1;
        }
        if answered > 0 {
            return;
        }
        let mut others: Vec<&str> = S::COMMANDS.to_vec();
        if S::LOCKABLE {
            others.extend([TakeLock::NAME, ReleaseLock::NAME]);
        }
        others.extend(self.last.keys().copied());
        let hit: Vec<&str> = others.into_iter().filter(|c| matches(c)).collect();
        if hit.is_empty() {
            let last = wanted.as_str().rsplit('/').next().unwrap_or_default();
            if wanted.as_str().contains("**") || last.contains(['*', '$']) {
                // A sweep over more than this device (`rome/**/pose` on
                // a camera): nothing here it meant.
                return;
            }
            let e = ErrorReply::new(
                ErrorCode::UnknownKey,
                format!(
                    "{} has no command '{last}' (asked through '{wanted}'); its reads are {reads_said}",
                    self.config.label(),
                ),
            );
            return reply_err(&query, &e).await;
        }
        let e = ErrorReply::new(
            ErrorCode::Wildcard,
            format!(
                "'{wanted}' names {} on {} through a wildcard; only reads answer a wildcard key ({reads_said}); name the robot and device, as in {}",
                hit.iter().map(|c| format!("'{c}'")).collect::<Vec<_>>().join(", "),
                self.config.label(),
                key_of(hit[0]),
            ),
        );
        reply_err(&query, &e).await;
    }

    /// Serves queued requests while the lock is free.
    async fn drain(&mut self) {
        while let Some(p) = self.gate.next_due() {
            self.serve(p).await;
        }
    }

    async fn serve(&mut self, p: Pending<S::Cmd>) {
        let now = Instant::now();
        let key = p.query.key_expr().as_str().to_string();
        if let Some(done) = p.op_id.as_ref().and_then(|id| self.done.get(id)) {
            // A repeat waits its turn like the first, so the first has
            // been carried out by now: answer as it was answered.
            tracing::debug!(%key, op = ?p.op_id, "repeated request answered from memory");
            self.stats.answered_from_memory += 1;
            return match done.clone() {
                Ok(body) => reply(&p.query, &key, body).await,
                Err(e) => reply_err(&p.query, &e).await,
            };
        }
        if matches!(p.op, Op::Do(_)) {
            if let Some(e) = self.suppressed(&p, now) {
                tracing::debug!(%key, priority = p.priority, error = %e, "suppressed");
                self.stats.suppressed += 1;
                return reply_err(&p.query, &e).await;
            }
        }
        let result = match p.op {
            Op::Lock { owner, ttl } => {
                // The holder's own lock request renews; anyone else's is
                // served only while the lock is free.
                let holder = match self.gate.holder() {
                    Some(h) => h.clone(),
                    None => {
                        let h = self.gate.grant(&owner, ttl, now);
                        tracing::debug!(server = %self.config.label(), holder = %h.owner, fence = h.fence, "lock granted");
                        self.persist().await;
                        h
                    }
                };
                Ok(Body::json(&LockGrant {
                    holder: holder.owner,
                    fence: holder.fence,
                    ttl_ms: holder.ttl.as_millis() as u64,
                }))
            }
            Op::Unlock { fence } => match self.gate.release(fence) {
                Ok(h) => {
                    tracing::debug!(server = %self.config.label(), holder = %h.owner, fence = h.fence, "lock released");
                    self.persist().await;
                    Ok(Body::json(&Unlocked {
                        released: true,
                        fence: h.fence,
                    }))
                }
                Err(_) => Err(ErrorReply::new(ErrorCode::Conflict, "the lock is not held")),
            },
            Op::Do(cmd) => {
                tracing::trace!(server = %self.config.label(), sim_ms = ?rome_clock::now_ms(), client = ?p.client, %key, params = %p.query.parameters(), "carrying out");
                self.count(p.op_id.as_deref());
                let lock = self.lock();
                let moving = self.service.sets_moving(&cmd);
                let result = self.service.apply(cmd, lock).await;
                if let (Ok(_), Some(suppress)) = (&result, p.suppress) {
                    self.gate
                        .suppress(p.priority, p.client.clone(), suppress, now);
                }
                if result.is_ok() && (moving || p.command == Stop::NAME) {
                    // A command without a client id leaves nobody to watch:
                    // the device is no longer tied to the last one's life.
                    self.mover = if moving { p.client.clone() } else { None };
                }
                if let Some(id) = &p.op_id {
                    self.remember(id, &result);
                }
                result
            }
        };
        match result {
            Ok(body) => reply(&p.query, &key, body).await,
            Err(e) => {
                tracing::debug!(%key, command = %p.command, error = %e, "command failed");
                reply_err(&p.query, &e).await
            }
        }
    }

    /// The refusal of a command that acts from below a suppression in
    /// force, if `p` is one.
    fn suppressed(&self, p: &Pending<S::Cmd>, now: Instant) -> Option<ErrorReply> {
        if p.fenced || S::READS.contains(&p.command.as_str()) {
            return None;
        }
        let s = self.gate.suppressed(p.priority, now)?;
        let by = s
            .client
            .as_deref()
            .map_or_else(String::new, |c| format!(" (client '{c}')"));
        Some(ErrorReply::new(
            ErrorCode::Suppressed,
            format!(
                "'{}' at priority {} not carried out on {}: priority {}{by} suppresses lower priorities for {} ms more (its command {} ms ago asked suppress_ms)",
                p.command,
                p.priority,
                self.config.label(),
                s.priority,
                s.until.saturating_duration_since(now).as_millis(),
                now.saturating_duration_since(s.since).as_millis(),
            ),
        ))
    }

    /// Counts a command carried out, and its id if it was carried out before.
    fn count(&mut self, id: Option<&str>) {
        self.stats.executed += 1;
        let Some(id) = id else { return };
        self.stats.with_id += 1;
        if !self.executed_ids.insert(id.to_string()) {
            tracing::error!(server = %self.config.label(), op = %id, "a request id was carried out twice");
            self.stats.ids_executed_twice += 1;
            return;
        }
        self.executed_order.push_back(id.to_string());
        while self.executed_order.len() > COUNTED_OPS {
            if let Some(old) = self.executed_order.pop_front() {
                self.executed_ids.remove(&old);
            }
        }
    }

    fn remember(&mut self, id: &str, result: &Result<Body, ErrorReply>) {
        if self.done.insert(id.to_string(), result.clone()).is_none() {
            self.done_order.push_back(id.to_string());
        }
        while self.done_order.len() > REMEMBERED_OPS {
            if let Some(old) = self.done_order.pop_front() {
                self.done.remove(&old);
            }
        }
    }
}

async fn reply(query: &Query, key: &str, body: Body) {
    let (bytes, encoding) = body.into_parts();
    rome_serve::reply(query, key, bytes, encoding).await
}

/// The answer to a request that found [`EVENT_QUEUE`] others `waiting` (in
/// the queue) or `queued` (behind a lock) on server `label`.
fn busy(label: &str, waiting: &str) -> ErrorReply {
    rome_serve::busy(label, EVENT_QUEUE, waiting)
}
