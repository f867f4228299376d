//! The Zenoh side of the data server.
//!
//! Every input (queries, plain puts, liveliness changes, hold timers, the
//! housekeeping tick) is turned into an event on one channel, in the
//! order Zenoh delivers it, and one task owns the [`Store`] and handles
//! events one at a time. So a put followed by a get from the same session
//! is seen in that order and commits are published in commit order. The
//! one exception is a request that finds nothing queued or being handled:
//! a plain read (`var/<name>`, `sem/<name>`), and with the store in memory
//! a `set`, a `signal`, an `ack` or a `wait` that takes a unit at once (one
//! that would be queued needs its query held, which the task does), is
//! answered by the queryable's callback itself,
//! under the store's lock, saving the trip through the loop (a change
//! leaves its publication and grants to the task, ahead of anything
//! queued); a request behind anything else takes its place in the queue.
//! A change the task commits while such a publication is still queued is
//! queued behind it, so watchers see commits in commit order whichever
//! path made them.
//!
//! The channel is bounded ([`EVENT_QUEUE`]) and a Zenoh callback never
//! waits on it: a callback runs on the link's receive path (or, for a
//! client in the same session, on the client's own task), so blocking there
//! would stall every other peer on the link, or deadlock a process whose
//! clients and server share one session. When the queue is full a query is
//! answered `busy` at once (nothing was done; the client library tries
//! again after a pause) and a plain put is dropped and counted, as Zenoh
//! drops puts on a congested link. Liveliness changes go on a channel of
//! their own that never drops: a waiter's cleanup and an undo depend on
//! them, and they come no faster than peers can come and go. The queues and
//! the loop are `rome_serve`'s, shared with the hardware servers.
//!
//! With a data directory, the loop takes in every request that has arrived
//! (a burst) and applies each, then writes their changes in one
//! transaction, syncs the disk once and only then answers them, in order
//! (group commit): a thousand clients cost a
//! sync per burst, not one each. Reads in the callback wait for the loop
//! while a burst's changes are unsynced. A `wait` is answered before the
//! sync, as its answer acknowledges nothing until `ack` confirms it.

mod quick;

use crate::cmd::{Applied, Apply, Params, Request};
use crate::store::{Disk, DiskError, Flush, Grant, Store};
use quick::Quick;
use rome_clock::Instant;
use rome_schema::data::{Committed, Rejected, WaitReply, WaitStatus, DEFAULT_HISTORY};
use rome_schema::keys::DataOp;
use rome_schema::{encode, ErrorCode, ErrorReply, Root};
use rome_serve::{reply_err, Handler, Inbox, Periods};
use serde::Serialize;
use std::collections::hash_map::Entry;
use std::collections::{HashMap, HashSet};
use std::future::Future;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::key_expr::KeyExpr;
use zenoh::qos::CongestionControl;
use zenoh::query::Query;
use zenoh::sample::{Sample, SampleKind};
use zenoh::Session;

/// How many events may wait for the server before queries are answered
/// `busy` and plain puts dropped.
pub const EVENT_QUEUE: usize = 256;

/// How long after a restart a queued place waits for its client to ask
/// again, beyond the grace: a client may be in the middle of its longest
/// default poll (10 s hold and 3 s of slack) when the old server died.
const PLACES_KEPT_AFTER_LOAD: Duration = Duration::from_secs(15);

/// How the data server runs.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// The deployment's root prefix.
    pub root: Root,
    /// History length of a new variable.
    pub default_history: u32,
    /// How long a queued wait keeps its place between a client's polls,
    /// and how long an unconfirmed grant to an owner not seen alive is kept
    /// before its unit is taken back.
    pub grace: Duration,
    /// How often lapsed places and orphaned grants are swept.
    pub sweep_every: Duration,
    /// What the server may hold at most.
    pub limits: crate::store::Limits,
    /// Where the state is kept.
    pub storage: Storage,
}

/// Where a data server keeps its state.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Storage {
    /// Only in memory: gone when the server stops.
    InMemory,
    /// In `DIR/data.redb` and its log `DIR/data.log`: every answered
    /// change is on disk (the log synced) before its answer is sent, and
    /// loaded again at start.
    Dir(std::path::PathBuf),
}

impl Default for ServerConfig {
    fn default() -> Self {
        ServerConfig {
            root: Root::default(),
            default_history: DEFAULT_HISTORY,
            grace: Duration::from_secs(5),
            sweep_every: Duration::from_millis(500),
            limits: crate::store::Limits::default(),
            storage: Storage::InMemory,
        }
    }
}

/// The data server could not start.
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    /// A Zenoh declaration failed.
    #[error(transparent)]
    Declare(#[from] rome_serve::Undeclared),
    /// The state file could not be opened or read.
    #[error(transparent)]
    Disk(#[from] DiskError),
    /// The server task ended abnormally (it panicked or was aborted).
    #[error("the data server task failed: {0}")]
    Task(String),
}

/// A data server running in a task of this process (embedded runs,
/// tests, benchmarks).
pub struct Running {
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<Result<(), ServerError>>,
}

impl Running {
    /// Stops the server and waits for it to finish.
    pub async fn stop(mut self) -> Result<(), ServerError> {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        match (&mut self.task).await {
            Ok(result) => result,
            Err(e) => Err(ServerError::Task(e.to_string())),
        }
    }
}

/// Starts [`run`] in a task; it stops on [`Running::stop`] or when dropped.
pub fn spawn(session: Session, config: ServerConfig) -> Running {
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    // A participant of the run's clock when started in one (lock-step).
    let task = rome_clock::spawn(
        "the data server",
        run(session, config, async move {
            let _ = stopped.await;
        }),
    );
    Running {
        stop: Some(stop),
        task,
    }
}

/// The data server's own events.
enum Own {
    /// A held wait whose time is up.
    HoldOver { ticket: String, generation: u64 },
    /// Follow-ups are queued ([`Follows`]): publish them in order.
    Drain,
}

/// What a change answered from the queryable's callback leaves to do:
/// publish its commit to watchers and answer the waits it granted.
struct Follow {
    commit: Option<Committed>,
    grants: Vec<Grant>,
}

/// Follow-ups waiting for the task, in the order their changes were made:
/// pushed to only with the store locked, and the task woken with
/// [`Own::Drain`] after the change's answer has gone, so the wake-up
/// costs the answer nothing.
#[derive(Default)]
struct Follows(Mutex<std::collections::VecDeque<Follow>>);

impl Follows {
    /// Queues `follow`; whether the queue was empty, so that the task
    /// needs waking. Whenever the queue holds anything, a [`Own::Drain`]
    /// is on its way or the task is draining (it pops until the queue is
    /// empty, under the same lock), so one wake-up serves every follow-up
    /// queued before the task gets to it.
    fn push(&self, follow: Follow) -> bool {
        let mut queue = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        queue.push_back(follow);
        queue.len() == 1
    }

    fn pop(&self) -> Option<Follow> {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .pop_front()
    }

    /// `commit` back if nothing is queued (it may be published now), or
    /// queued behind what is.
    fn queue_behind(&self, commit: Committed) -> Option<Committed> {
        let mut queue = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        if queue.is_empty() {
            return Some(commit);
        }
        queue.push_back(Follow {
            commit: Some(commit),
            grants: Vec::new(),
        });
        None
    }
}

type Event = rome_serve::Event<Own>;

struct Held {
    query: Query,
    generation: u64,
}

struct Server {
    session: Session,
    /// The watch keys of written variables, declared once (see
    /// `rome_serve::keys`).
    keys: rome_serve::keys::Declared,
    config: ServerConfig,
    /// Shared with the queryable's callback, which answers some requests
    /// itself when nothing is queued ahead of them (see [`Quick`]).
    store: Arc<Mutex<Store>>,
    held: HashMap<String, Held>,
    generation: u64,
    alive: HashSet<String>,
    events: flume::Sender<Event>,
    /// Follow-ups of changes answered in the callback, and the queue
    /// [`Own::Drain`] goes on (taken before any request): a commit made
    /// while one is queued is queued behind it instead of published ahead
    /// of it.
    follows: (flume::Sender<Event>, Arc<Follows>),
    disk: Option<Disk>,
    /// Changes written to disk but not yet synced (plain puts).
    unsynced: bool,
    /// With a disk: the requests of the burst being taken in, applied but
    /// neither written nor answered. One transaction and one sync when the
    /// burst is in cover them all (group commit); each is answered after
    /// it, in order.
    batch: Vec<(Query, String, Result<Applied, ErrorReply>)>,
    /// Set while `batch` holds a change: the callback's reads wait for the
    /// loop, which answers them after the sync.
    batch_unsynced: Arc<AtomicBool>,
}

fn declare_err(what: &str, e: zenoh::Error) -> ServerError {
    ServerError::Declare(rome_serve::Undeclared::new(what, e))
}

/// Runs the data server on `session` until `shutdown` completes.
///
/// Queries still held (blocked waits) are dropped on shutdown; their
/// clients see no reply and retry with the same ticket.
pub async fn run(
    session: Session,
    config: ServerConfig,
    shutdown: impl Future<Output = ()>,
) -> Result<(), ServerError> {
    let root = config.root.clone();
    // The state first: a server that cannot keep it must not answer.
    let mut store = Store::new(config.default_history).with_limits(config.limits);
    let disk = match &config.storage {
        Storage::InMemory => None,
        Storage::Dir(dir) => {
            let disk = Disk::open(dir)?;
            store = store.track_changes();
            disk.load(&mut store, config.grace + PLACES_KEPT_AFTER_LOAD)?;
            tracing::info!(
                file = %disk.path().display(),
                variables = store.histories().count(),
                semaphores = store.semaphores().count(),
                waiters = store.open_tickets(),
                "state loaded"
            );
            Some(disk)
        }
    };
    let inbox = {
        let root = root.clone();
        // A key that does not parse is refused, which changes nothing.
        Inbox::<Own>::new("the data server", EVENT_QUEUE).reads(move |q| {
            root.parse_data(q.key_expr().as_str())
                .map_or(true, |k| k.op.only_reads())
        })
    };
    let store = Arc::new(Mutex::new(store));
    let follows = (inbox.first_sender(), Arc::new(Follows::default()));
    let batch_unsynced = Arc::new(AtomicBool::new(false));
    let quick = Quick {
        unsynced: batch_unsynced.clone(),
        store: store.clone(),
        root: root.clone(),
        follows: follows.1.clone(),
        // A write answered at once must already be on disk, and must be
        // stamped on the clock the event loop uses (in a lock-step run,
        // the simulated one, which a callback on a link's thread does not
        // see): otherwise only reads are answered from the callback.
        writes: (disk.is_none()).then(|| (inbox.first_sender(), rome_clock::now_ms().is_some())),
    };
    let _queryable = session
        .declare_queryable(root.data_all())
        .callback(inbox.on_query_or(move |q: &Query| quick.answer(q)))
        .await
        .map_err(|e| declare_err("the data queryable", e))?;
    let mut subscribers = Vec::new();
    for op in [DataOp::Var, DataOp::Signal] {
        subscribers.push(
            session
                .declare_subscriber(root.data_all_of(op))
                .callback(inbox.on_put())
                .await
                .map_err(|e| declare_err("the put subscriber", e))?,
        );
    }
    let _alive = session
        .liveliness()
        .declare_subscriber(root.alive_clients())
        .history(true)
        .callback(inbox.on_alive())
        .await
        .map_err(|e| declare_err("the liveliness subscriber", e))?;
    // Declared last: a client that sees this token can query at once.
    let alive = root.alive_server("data", &session.zid().to_string());
    let _token = rome_serve::presence::declare(&session, &alive)
        .await
        .map_err(|e| declare_err("the liveliness token", e))?;
    tracing::info!(root = root.as_str(), zid = %session.zid(), "data server ready");

    let mut server = Server {
        store,
        disk,
        unsynced: false,
        batch: Vec::new(),
        batch_unsynced,
        keys: rome_serve::keys::Declared::new(&session),
        session,
        held: HashMap::new(),
        generation: 0,
        alive: HashSet::new(),
        events: inbox.sender(),
        follows,
        config,
    };
    let periods = Periods {
        sweep: server.config.sweep_every,
        tick: None,
    };
    inbox.run(&mut server, periods, shutdown).await;
    tracing::info!(held = server.held.len(), "data server stopping");
    Ok(())
}

impl Handler<Own> for Server {
    async fn event(&mut self, event: Event) {
        match event {
            Event::Query(q) => self.query(q).await,
            Event::Put(s) => self.put(s).await,
            Event::Alive(s) => self.alive(s).await,
            Event::Own(Own::HoldOver { ticket, generation }) => {
                self.hold_over(ticket, generation).await
            }
            Event::Own(Own::Drain) => {
                // Each follow-up is taken off the queue before it is
                // published; nothing of the task's own can come between,
                // and one more Drain than needed finds the queue empty.
                while let Some(Follow { commit, grants }) = self.follows.1.pop() {
                    if let Some(commit) = commit {
                        self.publish(&commit).await;
                    }
                    self.answer_grants(grants).await;
                }
            }
        }
    }

    async fn drained(&mut self) {
        if self.batch.is_empty() && !self.batch_unsynced.load(Ordering::SeqCst) {
            return;
        }
        let batch = std::mem::take(&mut self.batch);
        let synced = self.keep(Flush::Sync);
        if synced.is_ok() {
            self.batch_unsynced.store(false, Ordering::SeqCst);
        }
        for (query, key, applied) in batch {
            // A request that changed something is acknowledged only once
            // the change is on disk; the others wait for the sync too, so
            // none shows a change before its writer is told.
            let applied = match (&synced, applied) {
                (Err(e), Ok(_)) => Err(e.clone()),
                (_, applied) => applied,
            };
            self.answer(query, key, applied).await;
        }
    }

    async fn sweep(&mut self) {
        self.sweep_now().await
    }
}

impl Server {
    async fn query(&mut self, query: Query) {
        let key = query.key_expr().as_str().to_string();
        if key.contains('*') {
            return self.list(query).await;
        }
        let params = Params::new(query.parameters().iter());
        let payload = query.payload().map(|p| p.to_bytes().into_owned());
        let now = Instant::now();
        let request = Request::parse(&self.config.root, &key, params, payload.as_deref());
        // A wait is answered before its sync: its answer acknowledges
        // nothing. A unit it was granted is the client's only once `ack`
        // confirms it, and the ack is answered after the sync; a server
        // that dies before the sync has forgotten the grant and answers
        // the ack `unknown`, and the client waits again.
        let early = matches!(request, Ok(Request::Wait(_)));
        let applied = request.and_then(|request| {
            let store = self.store.clone();
            let mut store = lock(&store);
            let mut applied = request.apply(&mut store, now)?;
            if self.disk.is_some() {
                // Written and synced with the rest of the burst, in one
                // transaction (`drained`); set under the lock, so no read
                // in the callback sees the change before that.
                self.batch_unsynced.store(true, Ordering::SeqCst);
            }
            applied.commit = applied.commit.and_then(|c| self.in_order(c));
            Ok(applied)
        });
        if self.disk.is_some() && !early {
            self.batch.push((query, key, applied));
            return;
        }
        self.answer(query, key, applied).await;
    }

    /// Answers a request, publishes its commit, holds its query if it
    /// waits and answers the waits it granted.
    async fn answer(&mut self, query: Query, key: String, applied: Result<Applied, ErrorReply>) {
        match applied {
            Err(e) => {
                tracing::debug!(%key, error = %e, "request refused");
                reply_err(&query, &e).await;
            }
            Ok(applied) => {
                if let Some(reply) = applied.reply {
                    reply_json(&query, &key, reply).await;
                }
                if let Some(commit) = applied.commit {
                    self.publish(&commit).await;
                }
                if let Some((ticket, hold)) = applied.hold {
                    self.hold(ticket, hold, query);
                }
                self.answer_grants(applied.grants).await;
            }
        }
    }

    /// A query with wildcards: one reply per variable value, history and
    /// semaphore whose key it matches (`rome/data/var/**`, `rome/**` …).
    async fn list(&mut self, query: Query) {
        let params = Params::new(query.parameters().iter());
        if let Err(e) = params.finish("a wildcard query", &[]) {
            return reply_err(&query, &e).await;
        }
        let root = &self.config.root;
        // Keys first: only what the query matches is encoded and sent.
        let matches = |op: DataOp, name: &rome_schema::Name| {
            let key = root.data(op, name);
            let hit =
                KeyExpr::try_from(key.as_str()).is_ok_and(|ke| query.key_expr().intersects(&ke));
            hit.then_some(key)
        };
        let mut replies: Vec<(String, Vec<u8>)> = Vec::new();
        {
            let store = lock(&self.store);
            for (name, value) in store.values() {
                if let Some(key) = matches(DataOp::Var, name) {
                    replies.push((key, encode(value)));
                }
            }
            for (name, info) in store.histories() {
                if let Some(key) = matches(DataOp::History, name) {
                    replies.push((key, encode(&info)));
                }
            }
            for (name, state) in store.semaphores() {
                if let Some(key) = matches(DataOp::Sem, name) {
                    replies.push((key, encode(&state)));
                }
            }
        }
        for (key, payload) in replies {
            reply_json(&query, &key, payload).await;
        }
    }

    async fn put(&mut self, sample: Sample) {
        let key = sample.key_expr().as_str().to_string();
        let data_key = match self.config.root.parse_data(&key) {
            Ok(k) => k,
            Err(e) => {
                return self
                    .reject(&key, ErrorReply::new(ErrorCode::BadName, e.to_string()))
                    .await
            }
        };
        let now = Instant::now();
        let result: Result<Option<Committed>, ErrorReply> = match (data_key.op, sample.kind()) {
            (DataOp::Var, SampleKind::Put) => {
                let bytes = sample.payload().to_bytes();
                crate::cmd::set_value_from_payload(&data_key.name, Some(&bytes)).and_then(|value| {
                    let mut store = lock(&self.store);
                    store.put(&data_key.name, value).map(|c| self.in_order(c))
                })
            }
            (DataOp::Var, SampleKind::Delete) => {
                let mut store = lock(&self.store);
                Ok(store.delete(&data_key.name).and_then(|c| self.in_order(c)))
            }
            (DataOp::Signal, SampleKind::Put) => {
                let signalled = lock(&self.store).signal(&data_key.name, None, now);
                match signalled {
                    // Its grants are answered: on disk first.
                    Ok(signalled) => match self.keep(Flush::Sync) {
                        Ok(()) => {
                            self.answer_grants(signalled.grants).await;
                            Ok(None)
                        }
                        Err(e) => Err(e),
                    },
                    Err(e) => Err(e),
                }
            }
            (DataOp::Signal, SampleKind::Delete) => Err(ErrorReply::new(
                ErrorCode::BadParameter,
                "a delete on a signal key means nothing; put to signal a semaphore",
            )),
            _ => return,
        };
        // A plain put promises nothing: it reaches the disk with the next
        // answered change, or shortly after on the housekeeping tick.
        let result = result.and_then(|commit| self.keep(Flush::Later).map(|()| commit));
        match result {
            Ok(Some(commit)) => self.publish(&commit).await,
            Ok(None) => {}
            Err(e) => self.reject(&key, e).await,
        }
    }

    async fn reject(&self, key: &str, e: ErrorReply) {
        tracing::warn!(%key, error = %e, "put refused");
        let rejected = Rejected {
            key: key.to_string(),
            code: e.code,
            message: e.message,
        };
        self.send(&self.config.root.rejected(), &rejected).await;
    }

    /// `commit`, just made with the store locked, if it may be published
    /// now; `None` when a change answered from the callback is still
    /// waiting to be published: then `commit` is queued behind it.
    fn in_order(&self, commit: Committed) -> Option<Committed> {
        let (wake, follows) = &self.follows;
        let now = follows.queue_behind(commit);
        if now.is_none() {
            // The channel is unbounded and its receiver lives as long as
            // `self`.
            let _ = wake.send(Event::Own(Own::Drain));
        }
        now
    }

    async fn publish(&self, commit: &Committed) {
        match rome_schema::Name::new(commit.name.as_str()) {
            Ok(name) => {
                let key = self.config.root.data(DataOp::Watch, &name);
                self.send(&key, commit).await;
            }
            Err(e) => tracing::error!(error = %e, "commit on an invalid name"),
        }
    }

    async fn send(&self, key: &str, message: &impl Serialize) {
        let Some(declared) = self.keys.get(key) else {
            tracing::error!(%key, "publication on an invalid key");
            return;
        };
        rome_clock::sending(key);
        // Block rather than drop: a watcher must see every commit.
        let sent = self
            .session
            .put(declared, encode(message))
            .encoding(Encoding::APPLICATION_JSON)
            .congestion_control(CongestionControl::Block)
            .await;
        if let Err(e) = sent {
            tracing::error!(%key, error = %e, "publication failed");
        }
    }

    fn hold(&mut self, ticket: String, hold: Duration, query: Query) {
        self.generation += 1;
        let generation = self.generation;
        // A newer poll of the same ticket replaces the old one; the old
        // query is dropped, which ends it with no reply (its client has
        // already moved on to the new one).
        self.held.insert(ticket.clone(), Held { query, generation });
        let events = self.events.clone();
        // Simulated time when the server is a participant of a lock-step
        // clock.
        rome_clock::spawn("the data server's hold timer", async move {
            rome_clock::sleep(hold).await;
            let _ = events
                .send_async(Event::Own(Own::HoldOver { ticket, generation }))
                .await;
        });
    }

    async fn hold_over(&mut self, ticket: String, generation: u64) {
        // A newer poll of the ticket has its own timer: only the latest counts.
        let held = match self.held.entry(ticket.clone()) {
            Entry::Occupied(e) if e.get().generation == generation => e.remove(),
            _ => return,
        };
        let lapse_at = Instant::now() + self.config.grace;
        let released = lock(&self.store).release_hold(&ticket, lapse_at);
        if let Err(e) = self.keep(Flush::Sync) {
            return reply_err(&held.query, &e).await;
        }
        if let Some(reply) = released {
            let key = held.query.key_expr().as_str().to_string();
            reply_json(&held.query, &key, encode(&reply)).await;
        }
    }

    async fn answer_grants(&mut self, grants: Vec<Grant>) {
        for grant in grants {
            let Some(held) = self.held.remove(&grant.ticket) else {
                // Not held right now: the client's next poll learns it.
                continue;
            };
            let reply = WaitReply {
                name: grant.sem.to_string(),
                ticket: grant.ticket,
                status: WaitStatus::Granted,
                position: None,
            };
            let key = held.query.key_expr().as_str().to_string();
            reply_json(&held.query, &key, encode(&reply)).await;
        }
    }

    async fn alive(&mut self, sample: Sample) {
        let key = sample.key_expr().as_str();
        let Some(alive) = self.config.root.parse_alive(key) else {
            return;
        };
        let owner = alive.id.to_string();
        match sample.kind() {
            SampleKind::Put => {
                self.alive.insert(owner);
            }
            SampleKind::Delete => {
                self.alive.remove(&owner);
                let grants = lock(&self.store).owner_gone(&owner, Instant::now());
                tracing::debug!(%owner, passed_on = grants.len(), "client gone; its waits dropped");
                if self.keep(Flush::Sync).is_ok() {
                    self.answer_grants(grants).await;
                }
            }
        }
    }

    async fn sweep_now(&mut self) {
        let alive = &self.alive;
        let grants =
            lock(&self.store).sweep(Instant::now(), self.config.grace, |o| alive.contains(o));
        // Also makes plain puts since the last answered change durable.
        if self.keep(Flush::Sync).is_ok() {
            self.answer_grants(grants).await;
        }
    }

    /// Writes what changed since the last call to disk (a no-op in memory
    /// or when nothing changed). On failure the changes stay to be written
    /// with the next call and the caller answers `storage`.
    fn keep(&mut self, flush: Flush) -> Result<(), ErrorReply> {
        let store = self.store.clone();
        let mut store = lock(&store);
        self.keep_in(&mut store, flush)
    }

    /// [`Server::keep`] with the store already locked.
    fn keep_in(&mut self, store: &mut Store, flush: Flush) -> Result<(), ErrorReply> {
        let Some(disk) = &self.disk else {
            return Ok(());
        };
        let changes = store.take_changes();
        if changes.is_empty() {
            if flush == Flush::Sync && self.unsynced {
                disk.sync().map_err(storage_error)?;
                self.unsynced = false;
            }
            return Ok(());
        }
        match disk.write(store, &changes, flush) {
            Ok(()) => {
                // A synced write also syncs what was written before it.
                self.unsynced = flush == Flush::Later;
                Ok(())
            }
            Err(e) => {
                tracing::error!(error = %e, "state not written");
                store.restore_changes(changes);
                Err(storage_error(e))
            }
        }
    }
}

/// The store, also after a panic elsewhere while it was locked: every
/// change is applied whole or not at all, so what is there stays usable.
fn lock(store: &Mutex<Store>) -> MutexGuard<'_, Store> {
    store.lock().unwrap_or_else(PoisonError::into_inner)
}

async fn reply_json(query: &Query, key: &str, payload: Vec<u8>) {
    rome_serve::reply(query, key, payload, Encoding::APPLICATION_JSON).await
}

fn storage_error(e: DiskError) -> ErrorReply {
    ErrorReply::new(
        ErrorCode::Storage,
        format!("the change could not be kept on disk, so it is not acknowledged: {e}"),
    )
}
