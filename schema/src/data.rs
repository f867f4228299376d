//! Messages of the data server (the thesis' DServer, §4.6.1).
//!
//! Requests carry their arguments as selector parameters (so `z_get`,
//! the REST plugin and any Zenoh binding can send them by hand); only an
//! acknowledged write carries a payload, the JSON value itself. Replies are
//! JSON objects, grouped below by the request that causes them. A failed
//! request is answered with an [`ErrorReply`](crate::ErrorReply) instead.
//!
//! The requests themselves, each defined once with its encoding and its
//! parsing, are in [`request`].

use serde::{Deserialize, Serialize};
use serde_json::Value;

pub mod request;

/// Selector parameter names, shared by the server and every client.
pub mod param {
    /// `back=N`: read the value N steps back in the history (`var` get).
    pub const BACK: &str = "back";
    /// `len=N`: set the history length (`history`).
    pub const LEN: &str = "len";
    /// `value=N`: a semaphore's initial value (`create`).
    pub const VALUE: &str = "value";
    /// `op=ID`: idempotency id; a retried request with the same id is
    /// answered from the first one's result instead of being done twice.
    pub const OP: &str = "op";
    /// `ticket=ID`: a wait's identity across retries (`wait`, `cancel`, `ack`).
    pub const TICKET: &str = "ticket";
    /// `owner=ID`: the waiting client's liveliness id (`wait`).
    pub const OWNER: &str = "owner";
    /// `hold_ms=N`: how long the server may hold a wait before answering
    /// `pending` (`wait`).
    pub const HOLD_MS: &str = "hold_ms";
    /// `undo=true`: a `wait`'s unit stays on the owner's account and goes
    /// back by itself if the owner dies; a `signal` with `undo` and `owner`
    /// gives such a unit back.
    pub const UNDO: &str = "undo";
    /// `units=N`: how many units a `wait` takes or a `signal` adds at
    /// once (1 when absent).
    pub const UNITS: &str = "units";
}

/// The default history length of a new variable.
pub const DEFAULT_HISTORY: u32 = 16;

/// The largest history length a variable may be given.
pub const MAX_HISTORY: u32 = 1_000_000;

/// The longest a server holds one wait query before answering `pending`.
pub const MAX_HOLD_MS: u64 = 60_000;

/// The hold used by a wait that names none.
pub const DEFAULT_HOLD_MS: u64 = 5_000;

/// Largest value a variable may hold, in bytes of JSON. The data server is
/// for shared state, not bulk data: images go through the camera servers.
pub const MAX_VALUE_BYTES: usize = 1 << 20;

/// Largest initial or current semaphore value.
pub const MAX_SEMAPHORE_VALUE: u64 = i64::MAX as u64;

// ----- data server -> client: replies about variables ------------------------

/// Reply to `set/<name>`: the write was committed with this sequence number.
///
/// ```text
/// {"name":"PosX","seq":12}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetReply {
    /// The variable.
    pub name: String,
    /// The variable's commit number: 1 for its first write, +1 for each.
    pub seq: u64,
}

/// Reply to `history/<name>` (and one per variable to `history/**`).
///
/// ```text
/// {"name":"PosX","len":16,"stored":3,"seq":3}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HistoryInfo {
    /// The variable.
    pub name: String,
    /// How many values the variable keeps (the thesis' N).
    pub len: u32,
    /// How many values it holds now (≤ len).
    pub stored: u32,
    /// The commit number of its newest value (0: never written).
    pub seq: u64,
}

/// One committed write, published on `watch/<name>` in commit order.
///
/// ```text
/// {"name":"PosX","seq":13,"value":4}
/// {"name":"PosX","seq":14,"deleted":true}
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Committed {
    /// The variable.
    pub name: String,
    /// Its commit number; consecutive for one variable, so a gap or a
    /// repeat is visible to a watcher.
    pub seq: u64,
    /// The new value (absent when `deleted`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<Value>,
    /// Whether this write deleted the variable.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub deleted: bool,
}

/// Published on `rejected` when the server refuses a plain put (a put has
/// no reply to carry the error).
///
/// ```text
/// {"key":"rome/data/var/PosX","code":"bad_json","message":"..."}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rejected {
    /// The key that was put.
    pub key: String,
    /// Why it was refused.
    pub code: crate::ErrorCode,
    /// A sentence naming the problem.
    pub message: String,
}

// ----- data server -> client: replies about semaphores -----------------------

/// Reply to `sem/<name>` (and one per semaphore to `sem/**`).
///
/// ```text
/// {"name":"GoalData","value":0,"waiters":1}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SemState {
    /// The semaphore.
    pub name: String,
    /// Its value: units available to `wait` without blocking.
    pub value: u64,
    /// How many waits are queued.
    pub waiters: u32,
    /// Units taken with `undo` and not yet given back: they return by
    /// themselves if their holder dies.
    #[serde(default)]
    pub held: u64,
}

/// Reply to `create/<name>?value=N`.
///
/// Creating a semaphore that exists is not an error (both ends of a
/// handshake may create it): `created` is false and `value` is its current
/// value, untouched.
///
/// ```text
/// {"name":"GoalData","created":true,"value":0}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CreateReply {
    /// The semaphore.
    pub name: String,
    /// Whether this request created it.
    pub created: bool,
    /// Its value after the request.
    pub value: u64,
}

/// Reply to `signal/<name>`.
///
/// ```text
/// {"name":"GoalData","value":0,"woke":true}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SignalReply {
    /// The semaphore.
    pub name: String,
    /// Its value after the signal (0 if the unit went to a waiter).
    pub value: u64,
    /// Whether the unit was handed to a queued wait.
    pub woke: bool,
}

/// Reply to `try-wait/<name>`.
///
/// ```text
/// {"name":"GoalData","acquired":false,"value":0}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TryWaitReply {
    /// The semaphore.
    pub name: String,
    /// Whether a unit was taken.
    pub acquired: bool,
    /// Its value after the request.
    pub value: u64,
}

/// Where a wait stands, in replies to `wait`, `cancel` and `ack`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WaitStatus {
    /// A unit is the ticket's. An owned ticket must be confirmed with `ack`.
    Granted,
    /// Still queued; ask again with the same ticket to keep the place.
    Pending,
    /// Removed from the queue without a unit (an anonymous wait's hold
    /// ran out, or its place lapsed).
    TimedOut,
    /// Removed from the queue by `cancel`, without a unit.
    Cancelled,
    /// `ack` confirmed the grant: the unit is the client's for good.
    Confirmed,
    /// The ticket is unknown: never queued, or its grant was taken back
    /// because its owner was seen gone. The client holds no unit.
    Unknown,
}

/// Reply to `wait`, `cancel` and `ack`.
///
/// ```text
/// {"name":"GoalData","ticket":"5f3a-17","status":"pending","position":2}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaitReply {
    /// The semaphore.
    pub name: String,
    /// The wait's ticket (the server makes one up for a wait without).
    pub ticket: String,
    /// Where the wait stands.
    pub status: WaitStatus,
    /// Place in the queue, 1 = next, when `pending`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<u32>,
}
