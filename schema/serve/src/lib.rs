//! What every RoME server (the data server, each hardware server) does
//! alike on the Zenoh side, so it is written once.
//!
//! How this crate is laid out:
//! - [`Inbox`]: a server's event queues. Zenoh callbacks run on a link's
//!   receive path (or on the task of a client in the same session), so
//!   they never wait: requests and puts go to a bounded queue, and a query
//!   that finds it full is answered [`busy`] at once; liveliness changes
//!   go to an unbounded queue of their own, because releases and undo
//!   depend on every one of them.
//!   In a run split into processes (a lock-step clock split into rounds)
//!   a request that changes something waits in a `rome_clock::Hold` until
//!   its round is over and is then queued in the same order in every run;
//!   a read ([`Inbox::reads`]) is queued once its round has begun.
//! - [`Handler`] and [`Inbox::run`]: the event loop, one task per server:
//!   liveliness first, then requests (a burst taken in whole before the
//!   handler chooses what to do next), a sweep and an optional tick, until
//!   the shutdown future completes.
//! - [`reply`], [`reply_err`], [`busy`]: answers, with failures to send
//!   logged rather than returned (the asker may be gone).
//! - [`Undeclared`]: a server that could not declare itself on Zenoh.
//! - [`keys`]: keys published on again and again, declared once so
//!   that Zenoh keeps their subscribers instead of matching every one.
//! - [`parties`]: the processes that follow a lock-step clock, as the
//!   clock's driver and every party hear them.
//! - [`presence`]: a program's liveliness token with its version beside
//!   it, and the attachment (stamp, version tag) of requests and replies.
//!   A request from another protocol is refused here, before any server
//!   parses it ([`ErrorCode::Version`]).

pub mod keys;
pub mod parties;
pub mod presence;

use rome_clock::Held;
use rome_schema::{encode, ErrorCode, ErrorReply};
use std::future::Future;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::query::Query;
use zenoh::sample::Sample;

/// Something a server has to deal with; `T` is the server's own kind of
/// event (a timer it set, …).
pub enum Event<T> {
    /// A query on one of its keys.
    Query(Query),
    /// A put or delete on a key it subscribes to.
    Put(Sample),
    /// A liveliness token that appeared or went.
    Alive(Sample),
    /// The server's own event.
    Own(T),
}

/// A server's event queues. See the crate docs.
pub struct Inbox<T> {
    queue: Arc<Queue<T>>,
    rx: flume::Receiver<Event<T>>,
    alive_tx: flume::Sender<Event<T>>,
    alive_rx: flume::Receiver<Event<T>>,
    /// In a run split into processes, where requests wait for their round
    /// (made when the inbox is made within a lock-step participant).
    hold: Option<Arc<rome_clock::Hold<Event<T>>>>,
    /// Which queries only read (see [`Inbox::reads`]).
    reads: Arc<dyn Fn(&Query) -> bool + Send + Sync>,
}

/// When the event loop calls [`Handler::sweep`] and [`Handler::tick`].
#[derive(Debug, Clone, Copy)]
pub struct Periods {
    /// Between two sweeps (expiries, leases).
    pub sweep: Duration,
    /// Between two ticks (a device's periodic work), if it has any.
    pub tick: Option<Duration>,
}

/// A server's reactions; the event loop calls them one at a time.
pub trait Handler<T> {
    /// One event.
    fn event(&mut self, event: Event<T>) -> impl Future<Output = ()> + Send;
    /// After a burst of requests was taken in: a server that queues
    /// requests chooses what to serve next here.
    fn drained(&mut self) -> impl Future<Output = ()> + Send {
        async {}
    }
    /// Every [`Periods::sweep`].
    fn sweep(&mut self) -> impl Future<Output = ()> + Send;
    /// Every [`Periods::tick`].
    fn tick(&mut self) -> impl Future<Output = ()> + Send {
        async {}
    }
}

impl<T: Send + 'static> Inbox<T> {
    /// Queues for server `label` ("the data server", "robot r1 base"),
    /// taking at most `capacity` requests and puts at once.
    pub fn new(label: &str, capacity: usize) -> Self {
        let (tx, rx) = flume::bounded(capacity);
        let (alive_tx, alive_rx) = flume::unbounded();
        let queue = Arc::new(Queue {
            tx,
            pending: AtomicUsize::new(0),
            dropped: AtomicU64::new(0),
            label: label.to_string(),
            capacity,
            refusal: busy(label, capacity, "waiting"),
            runtime: tokio::runtime::Handle::current(),
        });
        let hold = rome_clock::LockStep::current().map(|clock| {
            let queue = queue.clone();
            Arc::new(clock.hold(capacity, move |event| queue.push(event)))
        });
        Inbox {
            queue,
            rx,
            alive_tx,
            alive_rx,
            hold,
            reads: Arc::new(|_| false),
        }
    }

    /// Says which queries only read (their answer changes nothing): in a
    /// run split into processes they are answered within their round,
    /// while anything else waits for the end of its round and is taken in
    /// the same order in every run (see `rome_clock::Hold`). Call before
    /// making the callbacks.
    pub fn reads(mut self, read: impl Fn(&Query) -> bool + Send + Sync + 'static) -> Self {
        self.reads = Arc::new(read);
        self
    }

    /// A queryable callback: queues the query, or answers [`busy`] at once
    /// when the queue is full. Call within the server's tokio runtime.
    pub fn on_query(&self) -> impl Fn(Query) + Send + Sync + 'static {
        self.on_query_or(|_| false)
    }

    /// As [`Inbox::on_query`], but a query that finds nothing queued or
    /// being handled is first offered to `answer_now`, which answers it
    /// from the callback and returns true, or leaves it to the event loop.
    /// It must not wait, and must only touch what the loop keeps under a
    /// lock.
    pub fn on_query_or(
        &self,
        answer_now: impl Fn(&Query) -> bool + Send + Sync + 'static,
    ) -> impl Fn(Query) + Send + Sync + 'static {
        let queue = self.queue.clone();
        let (hold, reads) = (self.hold.clone(), self.reads.clone());
        let held_refusal = busy(&queue.label, queue.capacity, "waiting for their round");
        move |q| {
            if let (_, Some(client)) = presence::split(q.attachment()) {
                if client.protocol != rome_schema::version::PROTOCOL {
                    let e = other_protocol(&queue.label, &client);
                    tracing::warn!(server = %queue.label, %client, "request from another protocol refused");
                    queue.runtime.spawn(async move { reply_err(&q, &e).await });
                    return;
                }
            }
            let q = match hold.as_ref().filter(|h| h.active()) {
                None => q,
                Some(h) => {
                    let stamp = stamp_of(q.attachment());
                    let read = reads(&q);
                    tracing::trace!(key = %q.key_expr(), ?stamp, read, "offered to the hold");
                    match h.put(stamp, read, Event::Query(q)) {
                        Held::Pass(Event::Query(q)) => q,
                        Held::Full(Event::Query(q)) => {
                            let e = held_refusal.clone();
                            queue.runtime.spawn(async move { reply_err(&q, &e).await });
                            return;
                        }
                        _ => return,
                    }
                }
            };
            if queue.pending.load(Ordering::SeqCst) == 0 && answer_now(&q) {
                return;
            }
            queue.push(Event::Query(q));
        }
    }

    /// A subscriber callback for plain puts: queued, or dropped and
    /// counted when the queue is full (a put has no one to answer; a flood
    /// is reported at 1, 2, 4, 8 … drops, not echoed).
    pub fn on_put(&self) -> impl Fn(Sample) + Send + Sync + 'static {
        let (queue, hold) = (self.queue.clone(), self.hold.clone());
        move |s| {
            let s = match hold.as_ref().filter(|h| h.active()) {
                None => s,
                Some(h) => match h.put(stamp_of(s.attachment()), false, Event::Put(s)) {
                    Held::Pass(Event::Put(s)) | Held::Full(Event::Put(s)) => s,
                    _ => return,
                },
            };
            queue.push(Event::Put(s));
        }
    }

    /// A liveliness subscriber callback: every change is kept.
    pub fn on_alive(&self) -> impl Fn(Sample) + Send + Sync + 'static {
        let tx = self.alive_tx.clone();
        move |s| {
            let _ = tx.send(Event::Alive(s));
        }
    }

    /// A sender into the unbounded queue the event loop takes first, with
    /// the liveliness changes: for an event that must neither be dropped
    /// nor wait behind queued requests (the publication of a change a
    /// callback answered at once), sent from anywhere without waiting.
    pub fn first_sender(&self) -> flume::Sender<Event<T>> {
        self.alive_tx.clone()
    }

    /// A sender of the server's own events into the bounded queue (send
    /// with `send_async` from a task: they must not be dropped).
    pub fn sender(&self) -> flume::Sender<Event<T>> {
        self.queue.tx.clone()
    }

    /// One event from the bounded queue, counted off the queue's
    /// `pending` once handled.
    async fn handle<H: Handler<T>>(&self, handler: &mut H, event: Event<T>) {
        let counted = matches!(event, Event::Query(_) | Event::Put(_));
        handler.event(event).await;
        if counted {
            self.queue.pending.fetch_sub(1, Ordering::SeqCst);
        }
    }

    /// Plain puts dropped so far because the queue was full.
    pub fn dropped(&self) -> u64 {
        self.queue.dropped.load(Ordering::Relaxed)
    }

    /// The event loop: runs until `shutdown` completes.
    pub async fn run<H: Handler<T>>(
        &self,
        handler: &mut H,
        periods: Periods,
        shutdown: impl Future<Output = ()>,
    ) {
        // In a lock-step run the loop is idle while it waits: the clock
        // moves on once everyone has been served.
        let mut sweep = rome_clock::interval(periods.sweep);
        let mut tick = rome_clock::interval(periods.tick.unwrap_or(Duration::from_secs(3_600)));
        let shutdown = rome_clock::idle(shutdown);
        tokio::pin!(shutdown);
        loop {
            tokio::select! {
                biased;
                _ = &mut shutdown => break,
                Ok(event) = rome_clock::idle(self.alive_rx.recv_async()) => handler.event(event).await,
                Ok(event) = rome_clock::idle(self.rx.recv_async()) => {
                    self.handle(handler, event).await;
                    // Everything that arrived meanwhile is taken in before
                    // the handler chooses what comes next.
                    while let Ok(event) = self.rx.try_recv() {
                        self.handle(handler, event).await;
                    }
                    handler.drained().await;
                }
                _ = sweep.tick() => handler.sweep().await,
                _ = tick.tick(), if periods.tick.is_some() => handler.tick().await,
            }
        }
    }
}

/// The bounded queue, as the callbacks and a hold's hand-over push into it.
struct Queue<T> {
    tx: flume::Sender<Event<T>>,
    /// Queries and puts queued or being handled: a callback may answer a
    /// request itself only when this is 0, so nothing a client sent before
    /// it is still on its way.
    pending: AtomicUsize,
    dropped: AtomicU64,
    label: String,
    capacity: usize,
    /// The answer to a query that finds the queue full.
    refusal: ErrorReply,
    runtime: tokio::runtime::Handle,
}

impl<T: Send + 'static> Queue<T> {
    /// Queues a request or a put without waiting: a query that finds the
    /// queue full is answered [`busy`], a put dropped and counted (a flood
    /// is reported at 1, 2, 4, 8 … drops, not echoed).
    fn push(&self, event: Event<T>) {
        self.pending.fetch_add(1, Ordering::SeqCst);
        let Err(flume::TrySendError::Full(event)) = self.tx.try_send(event) else {
            return;
        };
        self.pending.fetch_sub(1, Ordering::SeqCst);
        match event {
            Event::Query(q) => {
                let e = self.refusal.clone();
                self.runtime.spawn(async move { reply_err(&q, &e).await });
            }
            _ => {
                let n = self.dropped.fetch_add(1, Ordering::Relaxed) + 1;
                if n.is_power_of_two() {
                    tracing::warn!(server = %self.label, dropped = n, queue = self.capacity, "too busy: plain puts dropped");
                }
            }
        }
    }
}

/// A message's round stamp, if its attachment starts with one.
fn stamp_of(attachment: Option<&zenoh::bytes::ZBytes>) -> Option<rome_clock::Stamp> {
    presence::split(attachment).0
}

/// The refusal of a request from a client of another protocol, from
/// server `label`.
fn other_protocol(label: &str, client: &rome_schema::Speaks) -> ErrorReply {
    let me = rome_schema::Speaks::this();
    ErrorReply::new(
        ErrorCode::Version,
        format!(
            "versions differ: {label} is {me}, the client is {client}; {}; nothing was done",
            me.upgrade_advice(label, client, "the client")
        ),
    )
}

/// The answer to a request that found `capacity` others `waiting` (in the
/// queue) or `queued` (behind a lock) on server `label`: nothing was done.
pub fn busy(label: &str, capacity: usize, waiting: &str) -> ErrorReply {
    ErrorReply::new(
        ErrorCode::Busy,
        format!("{label} has {capacity} requests {waiting} and did not take this one; nothing was done, send it again after a pause"),
    )
}

/// Answers `query` with `bytes` on `key`. Zenoh sends a reply in its
/// query's priority band, so a client's priority rides both ways.
pub async fn reply(
    query: &Query,
    key: &str,
    bytes: impl Into<zenoh::bytes::ZBytes>,
    encoding: Encoding,
) {
    let reply = query.reply(key, bytes).encoding(encoding);
    if let Err(e) = reply.attachment(presence::attachment(None)).await {
        tracing::warn!(%key, error = %e, "reply failed");
    }
}

/// [`reply`] from a Zenoh callback, which cannot await.
pub fn reply_now(
    query: &Query,
    key: &str,
    bytes: impl Into<zenoh::bytes::ZBytes>,
    encoding: Encoding,
) {
    let reply = query.reply(key, bytes).encoding(encoding);
    if let Err(e) = zenoh::Wait::wait(reply.attachment(presence::attachment(None))) {
        tracing::warn!(%key, error = %e, "reply failed");
    }
}

/// Answers `query` with an error reply carrying `e` as JSON. A request
/// the server did not understand, from a client that did not say its
/// version, is told which build the server is: a RoME client that says
/// nothing is older than protocol versions.
pub async fn reply_err(query: &Query, e: &ErrorReply) {
    let told;
    let e = if e.code.misunderstood() && presence::split(query.attachment()).1.is_none() {
        told = ErrorReply::new(
            e.code,
            format!(
                "{} (this server is {}; the client did not say its version: if it is a rome program, it is older, so upgrade it)",
                e.message,
                rome_schema::Speaks::this()
            ),
        );
        &told
    } else {
        e
    };
    if let Err(err) = query
        .reply_err(encode(e))
        .encoding(Encoding::APPLICATION_JSON)
        .await
    {
        tracing::warn!(error = %err, "error reply failed");
    }
}

/// A server could not declare something on Zenoh (a queryable, a
/// subscriber, a liveliness token): every server's first way to fail.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("could not declare {what}: {detail}")]
pub struct Undeclared {
    /// What was being declared.
    pub what: String,
    /// Zenoh's error.
    pub detail: String,
}

impl Undeclared {
    /// `what` could not be declared, for the reason in `e`.
    pub fn new(what: &str, e: zenoh::Error) -> Undeclared {
        Undeclared {
            what: what.to_string(),
            detail: e.to_string(),
        }
    }
}
