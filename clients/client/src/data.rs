//! [`DataClient`]: the data server's function library (§4.6.1).
//!
//! Every call is a Zenoh query to `<root>/data/<op>/<name>` (see
//! `docs/keys.md`). Calls that change state carry an id, so a call whose
//! reply is lost is retried without being done twice; a blocking wait
//! keeps one ticket for all its polls and confirms its grant before
//! returning, so no unit is lost or duplicated when replies go missing,
//! the call times out, or the client dies.

mod watch;

use crate::call::{self, refusal, selector, Answer, Waiting};
use crate::ClientError;
use rome_schema::data::request::{
    Ack, Cancel, Command, Create, Get, History, Read, Set, Signal, TryWait, Wait,
};
use rome_schema::data::{CreateReply, HistoryInfo, SemState, SignalReply, WaitStatus, MAX_HOLD_MS};
use rome_schema::keys::DataOp;
use rome_schema::{decode, ErrorCode, ErrorReply, Name, Root};
use rome_serve::presence::{self, Presence};
use serde::de::DeserializeOwned;
use serde::Serialize;
use serde_json::Value;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use watch::Backlog;
pub use watch::Watch;
use zenoh::qos::Priority;
use zenoh::sample::Sample;
use zenoh::Session;

/// The first pause after a query that no server matched.
const FIRST_BACKOFF: Duration = Duration::from_millis(20);
/// The longest pause between such queries.
const MAX_BACKOFF: Duration = Duration::from_millis(500);

/// How many bytes of commits a [`Watch`] keeps for its reader by default
/// ([`DataOptions::watch_backlog`]).
pub const WATCH_BACKLOG_BYTES: usize = 64 << 20;
/// The variable [`DataClient::watch`] reads to learn that its subscription
/// has reached the server (a plain read: nothing changes).
const WATCH_PROBE: &str = "watch-probe";

/// Numbers the clients of this process, so owners are unique per session.
static NEXT_CLIENT: AtomicU64 = AtomicU64::new(1);

/// How a [`DataClient`] behaves.
#[derive(Debug, Clone)]
pub struct DataOptions {
    /// The deployment's root prefix.
    pub root: Root,
    /// What this client is (`planner`, `cli` …): shown by `rome ls`.
    pub role: String,
    /// How long one call may take, retries included (waits excepted, and
    /// requests held for their round in a run split into processes, which
    /// wait while the data server is there; this is then when the wait is
    /// said).
    pub request_timeout: Duration,
    /// How long the first attempt of a call may take before it is
    /// retried; each silent attempt doubles it, up to `max_attempt_timeout`.
    pub attempt_timeout: Duration,
    /// The longest a single attempt may take.
    pub max_attempt_timeout: Duration,
    /// How long the server holds one poll of a blocking wait.
    pub hold: Duration,
    /// How long [`DataClient::connect`] waits for the data server to appear.
    pub connect_timeout: Duration,
    /// The Zenoh priority of this client's requests (§4.3).
    pub priority: Priority,
    /// How many bytes of commits a [`Watch`] keeps while its reader is
    /// busy; commits beyond are dropped and counted ([`Watch::missed`]).
    pub watch_backlog: usize,
}

impl DataOptions {
    /// Defaults for a client with this role.
    pub fn new(role: &str) -> Self {
        DataOptions {
            root: Root::default(),
            role: role.to_string(),
            request_timeout: Duration::from_secs(10),
            attempt_timeout: Duration::from_millis(500),
            max_attempt_timeout: Duration::from_secs(3),
            hold: Duration::from_secs(10),
            connect_timeout: Duration::from_secs(10),
            priority: Priority::Data,
            watch_backlog: WATCH_BACKLOG_BYTES,
        }
    }
}

struct Inner {
    session: Session,
    options: DataOptions,
    owner: String,
    next_id: AtomicU64,
    retries: AtomicU64,
    _token: Presence,
}

/// A connection to the data server. Cheap to clone; clones share one
/// owner id and one liveliness token.
#[derive(Clone)]
pub struct DataClient {
    inner: Arc<Inner>,
}

impl DataClient {
    /// Declares this client alive and waits until the data server is seen.
    pub async fn connect(session: &Session, options: DataOptions) -> Result<Self, ClientError> {
        let n = NEXT_CLIENT.fetch_add(1, Ordering::Relaxed);
        let owner = format!("{}-{n}", session.zid());
        let role = Name::new(options.role.as_str())?;
        let token = presence::declare(session, &options.root.alive_client(role.as_str(), &owner))
            .await
            .map_err(ClientError::zenoh)?;
        let client = DataClient {
            inner: Arc::new(Inner {
                session: session.clone(),
                owner,
                next_id: AtomicU64::new(1),
                retries: AtomicU64::new(0),
                _token: token,
                options,
            }),
        };
        client.await_server().await?;
        Ok(client)
    }

    async fn await_server(&self) -> Result<(), ClientError> {
        let o = &self.inner.options;
        let key = o.root.alive_server("data", "*");
        let seen = self
            .inner
            .session
            .liveliness()
            .declare_subscriber(&key)
            .history(true)
            .await
            .map_err(ClientError::zenoh)?;
        match tokio::time::timeout(o.connect_timeout, seen.recv_async()).await {
            Ok(Ok(_)) => Ok(()),
            _ => Err(ClientError::NoReply {
                what: "the data server",
                key,
                waited: o.connect_timeout,
            }),
        }
    }

    /// This client's owner id (the last chunk of its liveliness token).
    pub fn owner(&self) -> &str {
        &self.inner.owner
    }

    /// The options in use.
    pub fn options(&self) -> &DataOptions {
        &self.inner.options
    }

    /// How many request attempts went unanswered and were retried so far
    /// (a sign of a lossy or overloaded link).
    pub fn retries(&self) -> u64 {
        self.inner.retries.load(Ordering::Relaxed)
    }

    fn next_id(&self) -> String {
        let n = self.inner.next_id.fetch_add(1, Ordering::Relaxed);
        format!("{}.{n}", self.inner.owner)
    }

    /// The band requests travel in: the options', except in a lock-step
    /// run (see [`crate::robot::band`]).
    fn band(&self) -> Priority {
        call::lockstep_band(self.inner.options.priority)
    }

    fn key(&self, op: DataOp, name: &Name) -> String {
        self.inner.options.root.data(op, name)
    }

    /// One query attempt; `Ok(None)` when nothing answered in `timeout`.
    async fn attempt(
        &self,
        op: DataOp,
        key: &str,
        params: &[(&str, String)],
        payload: Option<&[u8]>,
        timeout: Duration,
    ) -> Result<Option<Answer>, ClientError> {
        // In a lock-step run a held wait waits for another client (idle),
        // and so does a change that waits for its round to end in a run
        // split into processes; anything else is answered at once (busy:
        // the clock waits).
        let held = rome_clock::in_rounds() && !op.only_reads();
        let waiting = if held || op == DataOp::Wait {
            Waiting::Idle
        } else {
            Waiting::Busy
        };
        let selector = selector(key, params);
        let started = std::time::Instant::now();
        let answer = call::attempt(
            &self.inner.session,
            &selector,
            payload,
            timeout,
            self.band(),
            waiting,
        )
        .await;
        // Timed only when the server answers at once and did answer.
        let answered = waiting == Waiting::Busy && matches!(answer, Ok(Some(_)));
        crate::load::DATA.record(answered.then(|| started.elapsed()));
        answer
    }

    /// A request, sent as its schema type encodes it; what it answers is
    /// decoded as that type's reply.
    async fn request<C: Command>(&self, command: &C) -> Result<C::Reply, ClientError> {
        let what = match C::OP {
            DataOp::Var => format!("value of '{}'", command.name()),
            op => format!("{} reply", op.chunk()),
        };
        let key = command.key(&self.inner.options.root);
        let payload = command.payload();
        self.call(C::OP, &key, &command.params(), payload.as_deref(), &what)
            .await
    }

    /// A call, retried on silence until `request_timeout`; safe because
    /// every state-changing call carries an id. In a run split into
    /// processes an answer is awaited as long as the data server is there.
    async fn call<T: DeserializeOwned>(
        &self,
        op: DataOp,
        key: &str,
        params: &[(&str, String)],
        payload: Option<&[u8]>,
        what: &str,
    ) -> Result<T, ClientError> {
        let o = &self.inner.options;
        let started = Instant::now();
        let deadline = started + o.request_timeout;
        let mut backoff = FIRST_BACKOFF;
        let mut attempt_timeout = o.attempt_timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(ClientError::NoReply {
                    what: "the data server",
                    key: key.to_string(),
                    waited: started.elapsed(),
                });
            }
            let tried = Instant::now();
            let answer = if rome_clock::in_rounds() {
                // In a run split into processes the server holds a request
                // until its round, which may be long in coming: one
                // attempt (a second would be stamped for a later round),
                // as long as the server is there.
                let answer = self.attempt(op, key, params, payload, call::HELD_PATIENCE);
                call::held(answer, o.request_timeout, key).await?
            } else {
                let this_attempt = left.min(attempt_timeout);
                // A loaded server or link answers late: give the next
                // attempt longer instead of abandoning every one at the
                // same point.
                attempt_timeout =
                    (attempt_timeout * 2).min(o.max_attempt_timeout.max(o.attempt_timeout));
                self.attempt(op, key, params, payload, this_attempt).await?
            };
            if !matches!(answer, Some(Answer::Reply { .. })) {
                let refused = answer.is_some();
                tracing::debug!(%key, refused, after = ?tried.elapsed(), "data call unanswered");
            }
            match answer {
                Some(Answer::Reply { body, .. }) => return Ok(decode(&body, what)?),
                // Busy: the server took nothing in, so sending again is
                // safe whatever the call; pause as for silence.
                Some(Answer::Refused(e)) if e.code == ErrorCode::Busy => {
                    self.busy(&mut backoff, left).await
                }
                Some(Answer::Refused(e)) => return Err(self.refused(e).await),
                None => self.silence(&mut backoff, tried, left).await,
            }
        }
    }

    /// A refusal, with the versions named if they may be why.
    async fn refused(&self, e: ErrorReply) -> ClientError {
        let o = &self.inner.options;
        let presence = o.root.alive_server("data", "*");
        call::refused(&self.inner.session, e, &presence, "the data server").await
    }

    /// An attempt tried at `tried` got no reply: counts the retry and, if
    /// the silence came at once (no queryable matched: the server is not
    /// there yet, or restarting), waits `backoff` (at most `left`) and
    /// doubles it up to [`MAX_BACKOFF`].
    async fn silence(&self, backoff: &mut Duration, tried: Instant, left: Duration) {
        self.inner.retries.fetch_add(1, Ordering::Relaxed);
        if tried.elapsed() < *backoff {
            tokio::time::sleep((*backoff).min(left)).await;
            *backoff = (*backoff * 2).min(MAX_BACKOFF);
        }
    }

    /// An attempt was answered `busy` (the server took nothing in): counts
    /// the retry, waits `backoff` (at most `left`) and doubles it up to
    /// [`MAX_BACKOFF`].
    async fn busy(&self, backoff: &mut Duration, left: Duration) {
        self.inner.retries.fetch_add(1, Ordering::Relaxed);
        tokio::time::sleep((*backoff).min(left)).await;
        *backoff = (*backoff * 2).min(MAX_BACKOFF);
    }

    /// A wildcard query: every reply's key and body.
    async fn collect(&self, key: &str) -> Result<Vec<(String, Vec<u8>)>, ClientError> {
        let replies = self
            .inner
            .session
            .get(key)
            .timeout(self.inner.options.max_attempt_timeout)
            .priority(self.band())
            // Unbounded: Zenoh's default channel (256) would hold a server
            // in this process up for this reader ([`call::replies`]).
            .with(call::replies())
            .await
            .map_err(ClientError::zenoh)?;
        let mut out = Vec::new();
        while let Ok(reply) = replies.recv_async().await {
            match reply.result() {
                Ok(sample) => out.push((
                    sample.key_expr().as_str().to_string(),
                    sample.payload().to_bytes().into_owned(),
                )),
                Err(err) => {
                    if let Some(e) = refusal(&err.payload().to_bytes())? {
                        return Err(ClientError::Server(e));
                    }
                }
            }
        }
        Ok(out)
    }

    // ----- variables -------------------------------------------------------

    /// Writes a variable and waits until it is committed
    /// (`DataSetValue(DS, "PosX", 4)`); returns its commit number.
    pub async fn set(
        &self,
        name: &str,
        value: &(impl Serialize + ?Sized),
    ) -> Result<u64, ClientError> {
        let set = Set {
            name: Name::new(name)?,
            value: serde_json::to_value(value)
                .map_err(|e| ClientError::Value(format!("'{name}': {e}")))?,
            op: Some(self.next_id()),
        };
        Ok(self.request(&set).await?.seq)
    }

    /// Reads a variable's current value (`DataGetValue(DS, "PosX", 0)`).
    pub async fn get(&self, name: &str) -> Result<Value, ClientError> {
        self.get_back(name, 0).await
    }

    /// Reads the value `back` writes ago (`DataGetValue(DS, "PosX", -back)`).
    pub async fn get_back(&self, name: &str, back: u32) -> Result<Value, ClientError> {
        let name = Name::new(name)?;
        self.request(&Get { name, back }).await
    }

    /// Reads a variable's current value as `T`.
    pub async fn get_as<T: DeserializeOwned>(&self, name: &str) -> Result<T, ClientError> {
        let value = self.get(name).await?;
        serde_json::from_value(value).map_err(|e| {
            ClientError::Decode(rome_schema::DecodeError::Json {
                what: format!("value of '{name}'"),
                detail: e.to_string(),
                excerpt: String::new(),
            })
        })
    }

    /// Sets how many values a variable keeps (`DataSetHistory(DS, "PosX", N)`).
    pub async fn set_history(&self, name: &str, len: u32) -> Result<HistoryInfo, ClientError> {
        let name = Name::new(name)?;
        self.request(&History {
            name,
            len: Some(len),
        })
        .await
    }

    /// A variable's history length, stored count and commit number.
    pub async fn history(&self, name: &str) -> Result<HistoryInfo, ClientError> {
        let name = Name::new(name)?;
        self.request(&History { name, len: None }).await
    }

    /// Every variable the server knows, sorted by name.
    pub async fn list(&self) -> Result<Vec<HistoryInfo>, ClientError> {
        let mut out: Vec<HistoryInfo> = self.collect_all(DataOp::History, "history reply").await?;
        out.sort_by(|a, b| a.name.cmp(&b.name));
        Ok(out)
    }

    /// Every reply to `<root>/data/<op>/**`, decoded.
    async fn collect_all<T: DeserializeOwned>(
        &self,
        op: DataOp,
        what: &str,
    ) -> Result<Vec<T>, ClientError> {
        let key = self.inner.options.root.data_all_of(op);
        let mut out = Vec::new();
        for (_, body) in self.collect(&key).await? {
            out.push(decode(&body, what)?);
        }
        Ok(out)
    }

    /// Every variable's current value, by name.
    pub async fn values(&self) -> Result<std::collections::BTreeMap<String, Value>, ClientError> {
        self.values_matching("**").await
    }

    /// The current value of every variable whose name `pattern` matches
    /// (a Zenoh key expression over names: `fleet/task/*`, `nav/*/Duty`),
    /// by name. Each value is as stored: whoever reads it decodes it.
    pub async fn values_matching(
        &self,
        pattern: &str,
    ) -> Result<std::collections::BTreeMap<String, Value>, ClientError> {
        let root = &self.inner.options.root;
        let key = root.data_matching(DataOp::Var, pattern);
        if zenoh::key_expr::KeyExpr::try_from(key.as_str()).is_err() {
            return Err(ClientError::Value(format!(
                "'{pattern}' is not a pattern of variable names (a key expression such as fleet/task/*)"
            )));
        }
        let mut out = std::collections::BTreeMap::new();
        for (key, body) in self.collect(&key).await? {
            let parsed = root.parse_data(&key)?;
            out.insert(parsed.name.to_string(), decode(&body, "variable value")?);
        }
        Ok(out)
    }

    /// Follows committed writes to variables matching `pattern` (`PosX`,
    /// `r1/**`, `**`): each exactly once, in commit order per variable.
    ///
    /// Returns once the data server has answered a read sent after the
    /// subscription on this client's link, so the server knows of the
    /// subscription: every commit made after `watch` returns, by anyone,
    /// is seen. (If no server answers within the request timeout, it
    /// returns all the same: the subscription stands.)
    ///
    /// Commits wait for the reader in a queue of up to
    /// [`DataOptions::watch_backlog`] bytes. It never holds up the session:
    /// a full queue that stopped the link's receive path would also stop
    /// the answers to this client's own requests, so a reader that asks
    /// the server something between two commits would wait for ever.
    pub async fn watch(&self, pattern: &str) -> Result<Watch, ClientError> {
        let key = self
            .inner
            .options
            .root
            .data_pattern(DataOp::Watch, pattern)?;
        let backlog = Arc::new(Backlog::new(self.inner.options.watch_backlog));
        let (tx, rx) = flume::unbounded::<Sample>();
        let queue = backlog.clone();
        let push = move |sample: Sample| {
            if queue.admit(sample.payload().len()) {
                let _ = tx.send(sample);
            }
        };
        let subscriber = self
            .inner
            .session
            .declare_subscriber(&key)
            .with(crate::inflight::counted(&key, (push, rx)))
            .await
            .map_err(ClientError::zenoh)?;
        // Zenoh keeps a link's messages in order: once this read is
        // answered, the subscription declared before it has reached the
        // server. What the read finds does not matter.
        let probe = Get {
            name: Name::new(WATCH_PROBE)?,
            back: 0,
        };
        let key = probe.key(&self.inner.options.root);
        let _ = self
            .attempt(Get::OP, &key, &[], None, self.inner.options.request_timeout)
            .await;
        Ok(Watch::new(subscriber, backlog))
    }

    // ----- semaphores ------------------------------------------------------

    /// Creates a semaphore (`DataCreateSemaphore(DS, "$XYZ", 1)`); one
    /// that exists is left as it is (`created: false`).
    pub async fn create_semaphore(
        &self,
        name: &str,
        value: u64,
    ) -> Result<CreateReply, ClientError> {
        let name = Name::semaphore(name)?;
        self.request(&Create { name, value }).await
    }

    /// up() (`DataSignal(DS, "$XYZ")`).
    pub async fn signal(&self, name: &str) -> Result<SignalReply, ClientError> {
        self.up(name, false, 1).await
    }

    /// Gives back a unit taken with [`DataClient::wait_undo`].
    pub async fn give_back(&self, name: &str) -> Result<SignalReply, ClientError> {
        self.up(name, true, 1).await
    }

    /// Gives back `units` units taken with [`DataClient::wait_undo_units`].
    pub async fn give_back_units(
        &self,
        name: &str,
        units: u64,
    ) -> Result<SignalReply, ClientError> {
        self.up(name, true, units).await
    }

    /// up() by `units`, giving back this client's undo units when `undo`.
    async fn up(&self, name: &str, undo: bool, units: u64) -> Result<SignalReply, ClientError> {
        let signal = Signal {
            name: Name::semaphore(name)?,
            op: Some(self.next_id()),
            undo_owner: undo.then(|| self.inner.owner.clone()),
            units,
        };
        self.request(&signal).await
    }

    /// Non-blocking down(): whether a unit was taken.
    pub async fn try_wait(&self, name: &str) -> Result<bool, ClientError> {
        self.try_down(name, false).await
    }

    /// Non-blocking down() whose unit, if taken, stays on this client's
    /// account as [`DataClient::wait_undo`]'s does: it comes back by itself
    /// if the client dies before [`DataClient::give_back`]. Answered at
    /// once, so a lock-step clock waits for it (a wait that may be held
    /// does not hold the clock).
    pub async fn try_wait_undo(&self, name: &str) -> Result<bool, ClientError> {
        self.try_down(name, true).await
    }

    async fn try_down(&self, name: &str, undo: bool) -> Result<bool, ClientError> {
        let try_wait = TryWait {
            name: Name::semaphore(name)?,
            op: Some(self.next_id()),
            undo_owner: undo.then(|| self.inner.owner.clone()),
        };
        Ok(self.request(&try_wait).await?.acquired)
    }

    /// A semaphore's value and queue length.
    pub async fn semaphore(&self, name: &str) -> Result<SemState, ClientError> {
        let name = Name::semaphore(name)?;
        self.request(&Read { name }).await
    }

    /// Every semaphore, sorted by name.
    pub async fn semaphores(&self) -> Result<Vec<SemState>, ClientError> {
        let mut out: Vec<SemState> = self.collect_all(DataOp::Sem, "semaphore state").await?;
        out.sort_by(|a, b| a.name.cmp(&b.name));
        Ok(out)
    }

    /// Blocking down() (`DataWait(DS, "$XYZ")`), for as long as it takes.
    pub async fn wait(&self, name: &str) -> Result<(), ClientError> {
        self.wait_until(name, None, false, 1).await.map(|_| ())
    }

    /// Blocking down() whose unit stays on this client's account: if the
    /// client dies before [`DataClient::give_back`], the data server takes
    /// the unit back by itself (System V's SEM_UNDO). For a resource held
    /// for a while, such as a narrow passage.
    pub async fn wait_undo(&self, name: &str) -> Result<(), ClientError> {
        self.wait_until(name, None, true, 1).await.map(|_| ())
    }

    /// [`DataClient::wait_undo`] for `units` units at once, taken when this
    /// wait is first in the queue and that many are free. Waiting for
    /// every unit of a semaphore, then giving them straight back, waits
    /// until nobody holds one.
    pub async fn wait_undo_units(&self, name: &str, units: u64) -> Result<(), ClientError> {
        self.wait_until(name, None, true, units).await.map(|_| ())
    }

    /// Blocking down() for at most `timeout`: whether a unit was taken.
    /// On `false` nothing was taken and the place in the queue is given up.
    pub async fn wait_timeout(&self, name: &str, timeout: Duration) -> Result<bool, ClientError> {
        self.wait_until(name, Some(rome_clock::Instant::now() + timeout), false, 1)
            .await
    }

    async fn wait_until(
        &self,
        name: &str,
        deadline: Option<rome_clock::Instant>,
        undo: bool,
        units: u64,
    ) -> Result<bool, ClientError> {
        let name = Name::semaphore(name)?;
        let ticket = self.next_id();
        // Dropped before it ends (a select! that went another way), the
        // wait gives its place in the queue up at once, and a unit that
        // reached it meanwhile goes back: else the ticket would keep its
        // place until the server's grace ran out, and the next up() would
        // go to nobody.
        let mut place = Place {
            client: Some(self.clone()),
            name: name.clone(),
            ticket: ticket.clone(),
            undo,
            units,
        };
        let taken = self
            .wait_ticket(&name, &ticket, deadline, undo, units)
            .await;
        // A wait that failed gives its place up too: its ack may have been
        // confirmed by a server whose answer never came back, and a unit
        // kept by a living owner that no longer waits would be lost to
        // everyone.
        if taken.is_ok() {
            place.client = None;
        }
        taken
    }

    async fn wait_ticket(
        &self,
        name: &Name,
        ticket: &str,
        deadline: Option<rome_clock::Instant>,
        undo: bool,
        units: u64,
    ) -> Result<bool, ClientError> {
        let key = self.key(DataOp::Wait, name);
        let o = &self.inner.options;
        let mut backoff = FIRST_BACKOFF;
        loop {
            let left = deadline.map(|d| d.remaining());
            if left == Some(Duration::ZERO) {
                return self.give_up(name, ticket).await;
            }
            let hold = left
                .unwrap_or(o.hold)
                .min(o.hold)
                .min(Duration::from_millis(MAX_HOLD_MS));
            let wait = Wait {
                name: name.clone(),
                ticket: Some(ticket.to_string()),
                owner: Some(self.inner.owner.clone()),
                hold,
                undo,
                units,
            };
            let tried = Instant::now();
            // A hold is simulated time in a lock-step run, which may go
            // slower than the wall clock: the server answers when it ends.
            let patience = if rome_clock::is_lockstep() {
                LOCKSTEP_PATIENCE
            } else {
                hold + o.max_attempt_timeout
            };
            match self
                .attempt(Wait::OP, &key, &wait.params(), None, patience)
                .await?
            {
                Some(Answer::Refused(e)) if e.code == ErrorCode::Busy => {
                    self.busy(&mut backoff, Duration::MAX).await
                }
                Some(Answer::Refused(e)) => return Err(self.refused(e).await),
                Some(Answer::Reply { body, .. }) => {
                    let reply: <Wait as Command>::Reply = decode(&body, "wait reply")?;
                    match reply.status {
                        WaitStatus::Granted => {
                            if self.confirm(name, ticket).await? {
                                return Ok(true);
                            }
                            // Taken back before our ack landed: wait again.
                        }
                        WaitStatus::Confirmed => return Ok(true),
                        WaitStatus::Pending
                        | WaitStatus::TimedOut
                        | WaitStatus::Cancelled
                        | WaitStatus::Unknown => {}
                    }
                }
                None => {
                    let left = left.unwrap_or(Duration::MAX);
                    self.silence(&mut backoff, tried, left).await;
                }
            }
        }
    }

    /// A wait dropped before it ended: its ticket leaves the queue, and a
    /// unit it was granted or took meanwhile goes back (an undo unit to
    /// the owner's account first, so it can be given back).
    async fn abandon(
        &self,
        name: &Name,
        ticket: &str,
        undo: bool,
        units: u64,
    ) -> Result<(), ClientError> {
        if self.give_up(name, ticket).await? {
            self.up(name.as_str(), undo, units).await?;
        }
        Ok(())
    }

    /// Confirms a grant; `false` if the server had taken it back.
    async fn confirm(&self, name: &Name, ticket: &str) -> Result<bool, ClientError> {
        let ack = Ack {
            name: name.clone(),
            ticket: ticket.to_string(),
        };
        Ok(self.request(&ack).await?.status == WaitStatus::Confirmed)
    }

    /// Cancels a wait at its deadline; takes the unit if it came meanwhile.
    async fn give_up(&self, name: &Name, ticket: &str) -> Result<bool, ClientError> {
        let cancel = Cancel {
            name: name.clone(),
            ticket: ticket.to_string(),
        };
        match self.request(&cancel).await?.status {
            WaitStatus::Granted => self.confirm(name, ticket).await,
            WaitStatus::Confirmed => Ok(true),
            _ => Ok(false),
        }
    }
}

/// The place of a wait in a semaphore's queue while the wait runs; see
/// [`DataClient::abandon`]. `client` is taken out when the wait ends
/// without an error.
struct Place {
    client: Option<DataClient>,
    name: Name,
    ticket: String,
    undo: bool,
    units: u64,
}

impl Drop for Place {
    fn drop(&mut self) {
        let Some(client) = self.client.take() else {
            return;
        };
        if tokio::runtime::Handle::try_current().is_err() {
            return;
        }
        let (name, ticket, undo, units) = (
            self.name.clone(),
            self.ticket.clone(),
            self.undo,
            self.units,
        );
        rome_clock::spawn("abandoned wait", async move {
            if let Err(e) = client.abandon(&name, &ticket, undo, units).await {
                tracing::debug!(error = %e, sem = %name.as_str(), "an abandoned wait could not give its place up");
            }
        });
    }
}

/// How long a held wait in a lock-step run waits for its answer on the
/// wall clock: the data server answers when the (simulated) hold ends,
/// however long that takes in wall time (in another process following the
/// same clock, a vanished data server is then noticed only after this).
const LOCKSTEP_PATIENCE: Duration = Duration::from_secs(3_600);
