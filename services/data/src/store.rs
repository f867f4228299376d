//! The data server's state: variables with history, semaphores, wait
//! tickets and the record of finished requests. Pure and synchronous (no
//! Zenoh, no clock of its own) so every rule about losing or duplicating a
//! unit is tested here directly.
//!
//! How a wait keeps its unit safe:
//! - every wait carries a *ticket* the client keeps across retries; a
//!   re-sent wait with a known ticket keeps its place (or learns its grant)
//!   instead of queueing twice;
//! - a grant to a ticket with an *owner* (a client with a liveliness token)
//!   is provisional until the client confirms it with `ack`; if the owner is
//!   seen gone first, the unit goes back to the semaphore, so a client
//!   killed between grant and use loses nothing;
//! - `cancel` after a grant answers `granted`, so a client that gives up
//!   just as the unit arrives takes it rather than dropping it;
//! - writes, signals and try-waits carry an `op` id: a retry whose first
//!   reply was lost gets the first reply again, and is not done twice;
//! - a wait with `undo` keeps its confirmed unit on the owner's account
//!   (as System V's SEM_UNDO does) until the owner gives it back with a
//!   `signal` that says `undo`; if the owner dies first, the unit goes back
//!   by itself. A robot's Planner holds a narrow passage this way, so a
//!   robot whose clients die inside it does not close it for ever.

use rome_clock::Instant;
use rome_schema::data::{
    Committed, HistoryInfo, SetReply, SignalReply, TryWaitReply, WaitReply, MAX_HISTORY,
};
use rome_schema::{ErrorCode, ErrorReply, Name};
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet, HashMap, VecDeque};
use std::time::Duration;

mod durable;
pub use durable::{Disk, DiskError, Flush, FILE_NAME, LOG_NAME};

/// How long a finished request's reply is kept for retries.
pub const DEFAULT_RETENTION: Duration = Duration::from_secs(600);

/// How long an owned grant may wait for its `ack` before its unit goes
/// back, even if the owner looks alive (its client gave up on the wait).
pub const DEFAULT_CONFIRM_WITHIN: Duration = Duration::from_secs(60);

/// How many finished requests are remembered at most.
pub const MAX_REMEMBERED: usize = 200_000;

/// What one data server may hold at most; past a limit a write or a
/// create is refused with `quota`, naming the limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Variables (written or with a history length set).
    pub max_variables: usize,
    /// Semaphores.
    pub max_semaphores: usize,
    /// Bytes of stored values, every history counted (JSON text).
    pub max_bytes: u64,
}

impl Default for Limits {
    /// 100 000 variables, 100 000 semaphores, 1 GiB of values.
    fn default() -> Self {
        Limits {
            max_variables: 100_000,
            max_semaphores: 100_000,
            max_bytes: 1 << 30,
        }
    }
}

/// One variable: the last `len` values, newest at the back, each with its
/// size in bytes. The values carry consecutive commit numbers ending at
/// `seq` (a delete empties the history, a trim drops the oldest).
#[derive(Debug)]
struct Var {
    len: u32,
    values: VecDeque<Value>,
    sizes: VecDeque<u64>,
    seq: u64,
    /// The newest commit number already on disk (durable stores only).
    stored_seq: u64,
}

impl Var {
    fn new(len: u32) -> Var {
        Var {
            len,
            values: VecDeque::new(),
            sizes: VecDeque::new(),
            seq: 0,
            stored_seq: 0,
        }
    }

    /// The commit number of the oldest value held (`seq + 1` when empty).
    fn first_seq(&self) -> u64 {
        self.seq + 1 - self.values.len() as u64
    }

    /// Drops the oldest values beyond `len`; the bytes freed.
    fn trim(&mut self) -> u64 {
        let mut freed = 0;
        while self.values.len() > self.len as usize {
            self.values.pop_front();
            freed += self.sizes.pop_front().unwrap_or(0);
        }
        freed
    }
}

/// One counting semaphore with its FIFO queue of tickets.
#[derive(Debug, Default)]
struct Sem {
    value: u64,
    queue: VecDeque<String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum TicketState {
    /// In the queue. `lapse_at`: when it is dropped if nobody asks again
    /// (set while no query is attached).
    Queued { lapse_at: Option<Instant> },
    /// Holds a unit, waiting for the owner's `ack`.
    Granted { at: Instant },
}

#[derive(Debug)]
struct Ticket {
    sem: Name,
    owner: Option<String>,
    state: TicketState,
    /// The units stay on the owner's account once confirmed.
    undo: bool,
    /// How many units it takes at once (1 but for a `units=N` wait).
    units: u64,
}

/// Units an owner holds on a semaphore with `undo`, and since when.
#[derive(Debug, Clone, Copy)]
struct Held {
    units: u64,
    since: Instant,
}

/// A reply kept for requests that may be retried.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
enum Remembered {
    Set(SetReply),
    Signal(SignalReply),
    TryWait(TryWaitReply),
    Confirmed(WaitReply),
}

/// A unit handed to a queued ticket: the server answers its attached query.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Grant {
    /// The semaphore.
    pub sem: Name,
    /// The ticket that now holds the unit.
    pub ticket: String,
}

/// The outcome of a `signal`: its reply and the waits it woke.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Signalled {
    /// The reply to the signalling client.
    pub reply: SignalReply,
    /// Waits to answer `granted` (empty for a retried signal).
    pub grants: Vec<Grant>,
}

/// The outcome of a write: the reply, and the commit to publish (none when
/// a retried write was answered from memory).
#[derive(Debug, Clone, PartialEq)]
pub struct Written {
    /// The reply to the writer.
    pub reply: SetReply,
    /// The commit to publish on `watch`, if this request made one.
    pub commit: Option<Committed>,
}

/// All of the data server's state.
#[derive(Debug)]
pub struct Store {
    default_history: u32,
    retention: Duration,
    confirm_within: Duration,
    vars: BTreeMap<Name, Var>,
    sems: BTreeMap<Name, Sem>,
    tickets: HashMap<String, Ticket>,
    remembered: HashMap<String, Remembered>,
    remembered_order: VecDeque<(Instant, String)>,
    next_anonymous: u64,
    held: BTreeMap<(Name, String), Held>,
    limits: Limits,
    bytes: u64,
    /// What changed since the last [`Store::take_changes`] (durable
    /// stores only).
    changes: Option<Changes>,
}

/// The keys of everything a request changed, so a durable store writes
/// exactly those (each written as it is now, or removed if gone).
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Changes {
    vars: BTreeSet<Name>,
    sems: BTreeSet<Name>,
    tickets: BTreeSet<String>,
    held: BTreeSet<(Name, String)>,
    ops: BTreeSet<String>,
    counter: bool,
}

impl Changes {
    /// Nothing changed.
    pub fn is_empty(&self) -> bool {
        self.vars.is_empty()
            && self.sems.is_empty()
            && self.tickets.is_empty()
            && self.held.is_empty()
            && self.ops.is_empty()
            && !self.counter
    }

    /// Adds `other`'s keys (changes not yet written stay to be written).
    fn merge(&mut self, other: Changes) {
        self.vars.extend(other.vars);
        self.sems.extend(other.sems);
        self.tickets.extend(other.tickets);
        self.held.extend(other.held);
        self.ops.extend(other.ops);
        self.counter |= other.counter;
    }
}

fn err(code: ErrorCode, message: impl Into<String>) -> ErrorReply {
    ErrorReply::new(code, message)
}

fn unknown_sem(name: &Name) -> ErrorReply {
    err(
        ErrorCode::UnknownSemaphore,
        format!("no semaphore named '{name}'; create it first (rome sem create {name} 0)"),
    )
}

impl Store {
    /// An empty store; new variables keep `default_history` values.
    pub fn new(default_history: u32) -> Self {
        Store {
            default_history: default_history.clamp(1, MAX_HISTORY),
            retention: DEFAULT_RETENTION,
            confirm_within: DEFAULT_CONFIRM_WITHIN,
            vars: BTreeMap::new(),
            sems: BTreeMap::new(),
            tickets: HashMap::new(),
            remembered: HashMap::new(),
            remembered_order: VecDeque::new(),
            next_anonymous: 0,
            held: BTreeMap::new(),
            limits: Limits::default(),
            bytes: 0,
            changes: None,
        }
    }

    /// Keeps track of what changes, for a durable store to write.
    pub fn track_changes(mut self) -> Self {
        self.changes = Some(Changes::default());
        self
    }

    /// What changed since the last call (empty when not tracking).
    pub fn take_changes(&mut self) -> Changes {
        self.changes
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// Puts back changes that could not be written, to try again.
    pub fn restore_changes(&mut self, changes: Changes) {
        if let Some(c) = self.changes.as_mut() {
            c.merge(changes);
        }
    }

    fn touch_var(&mut self, name: &Name) {
        if let Some(c) = self.changes.as_mut() {
            c.vars.insert(name.clone());
        }
    }

    fn touch_sem(&mut self, name: &Name) {
        if let Some(c) = self.changes.as_mut() {
            c.sems.insert(name.clone());
        }
    }

    fn touch_ticket(&mut self, ticket: &str) {
        if let Some(c) = self.changes.as_mut() {
            c.tickets.insert(ticket.to_string());
        }
    }

    fn touch_held(&mut self, key: &(Name, String)) {
        if let Some(c) = self.changes.as_mut() {
            c.held.insert(key.clone());
        }
    }

    fn touch_op(&mut self, op: &str) {
        if let Some(c) = self.changes.as_mut() {
            c.ops.insert(op.to_string());
        }
    }

    /// Sets the limits on what the store holds.
    pub fn with_limits(mut self, limits: Limits) -> Self {
        self.limits = limits;
        self
    }

    /// Bytes of values held now, every history counted.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    fn room_for_variable(&self, name: &Name) -> Result<(), ErrorReply> {
        if !self.vars.contains_key(name) && self.vars.len() >= self.limits.max_variables {
            return Err(err(
                ErrorCode::Quota,
                format!(
                    "variable '{name}' would be one too many: the data server holds at most {} variables (--max-variables)",
                    self.limits.max_variables
                ),
            ));
        }
        Ok(())
    }

    /// Sets how long an owned grant may wait for its `ack`.
    pub fn with_confirm_within(mut self, confirm_within: Duration) -> Self {
        self.confirm_within = confirm_within;
        self
    }

    /// Sets how long finished requests are remembered for retries.
    pub fn with_retention(mut self, retention: Duration) -> Self {
        self.retention = retention;
        self
    }

    // ----- idempotency ---------------------------------------------------

    fn recall(&self, op: Option<&str>) -> Option<&Remembered> {
        op.and_then(|op| self.remembered.get(op))
    }

    fn remember(&mut self, op: Option<&str>, now: Instant, what: Remembered) {
        let Some(op) = op else { return };
        self.touch_op(op);
        if self.remembered.insert(op.to_string(), what).is_none() {
            self.remembered_order.push_back((now, op.to_string()));
        }
        while self.remembered_order.len() > MAX_REMEMBERED {
            if let Some((_, old)) = self.remembered_order.pop_front() {
                self.remembered.remove(&old);
                self.touch_op(&old);
            }
        }
    }

    fn reused(op: &str, kind: &str) -> ErrorReply {
        err(
            ErrorCode::Conflict,
            format!("op id '{op}' was already used for a different request than this {kind}; every request needs its own op id"),
        )
    }

    // ----- variables -----------------------------------------------------

    fn commit(&mut self, name: &Name, value: Value) -> Result<Committed, ErrorReply> {
        self.room_for_variable(name)?;
        let size = serde_json::to_vec(&value).map_or(0, |v| v.len() as u64);
        // A full history gives its oldest value's bytes back.
        let freed = match self.vars.get(name) {
            Some(v) if v.values.len() >= v.len as usize => v.sizes.front().copied().unwrap_or(0),
            _ => 0,
        };
        let after = (self.bytes + size).saturating_sub(freed);
        if after > self.limits.max_bytes {
            return Err(err(
                ErrorCode::Quota,
                format!(
                    "writing {size} bytes to '{name}' would take the data server to {after} bytes of values, above its limit of {} (--max-mb); shorten histories or delete variables",
                    self.limits.max_bytes
                ),
            ));
        }
        let default = self.default_history;
        self.touch_var(name);
        let var = self
            .vars
            .entry(name.clone())
            .or_insert_with(|| Var::new(default));
        var.values.push_back(value.clone());
        var.sizes.push_back(size);
        let freed = var.trim();
        var.seq += 1;
        let seq = var.seq;
        self.bytes = (self.bytes + size).saturating_sub(freed);
        Ok(Committed {
            name: name.to_string(),
            seq,
            value: Some(value),
            deleted: false,
        })
    }

    /// A plain write (Zenoh `put` on `var/<name>`): commits unless a limit
    /// would be passed.
    pub fn put(&mut self, name: &Name, value: Value) -> Result<Committed, ErrorReply> {
        self.commit(name, value)
    }

    /// An acknowledged write; a retried `op` is answered from memory.
    pub fn set(
        &mut self,
        name: &Name,
        value: Value,
        op: Option<&str>,
        now: Instant,
    ) -> Result<Written, ErrorReply> {
        match self.recall(op) {
            Some(Remembered::Set(reply)) if reply.name == name.as_str() => {
                return Ok(Written {
                    reply: reply.clone(),
                    commit: None,
                })
            }
            Some(_) => return Err(Self::reused(op.unwrap_or_default(), "set")),
            None => {}
        }
        let commit = self.commit(name, value)?;
        let reply = SetReply {
            name: name.to_string(),
            seq: commit.seq,
        };
        self.remember(op, now, Remembered::Set(reply.clone()));
        Ok(Written {
            reply,
            commit: Some(commit),
        })
    }

    /// Deletes a variable's values (Zenoh `delete`); its history length and
    /// commit numbering carry on, so watchers still see consecutive numbers.
    pub fn delete(&mut self, name: &Name) -> Option<Committed> {
        if self.vars.get(name).is_none_or(|v| v.values.is_empty()) {
            return None;
        }
        self.touch_var(name);
        let var = self.vars.get_mut(name)?;
        var.values.clear();
        let freed: u64 = var.sizes.drain(..).sum();
        self.bytes = self.bytes.saturating_sub(freed);
        var.seq += 1;
        Some(Committed {
            name: name.to_string(),
            seq: var.seq,
            value: None,
            deleted: true,
        })
    }

    /// The value `back` steps before the newest (0 = current; the thesis' -N).
    pub fn get(&self, name: &Name, back: u32) -> Result<&Value, ErrorReply> {
        let var = self
            .vars
            .get(name)
            .filter(|v| !v.values.is_empty())
            .ok_or_else(|| {
                err(
                    ErrorCode::UnknownVariable,
                    format!("no variable named '{name}' has a value; `rome data ls` lists the variables"),
                )
            })?;
        let stored = var.values.len();
        if back as usize >= stored {
            return Err(err(
                ErrorCode::OutOfRange,
                format!(
                    "'{name}' holds {stored} value(s) (history length {}), so back={back} is out of range; use 0..={}",
                    var.len,
                    stored - 1
                ),
            ));
        }
        Ok(&var.values[stored - 1 - back as usize])
    }

    /// Every variable that has a value, with its current value.
    pub fn values(&self) -> impl Iterator<Item = (&Name, &Value)> {
        self.vars
            .iter()
            .filter_map(|(n, v)| v.values.back().map(|value| (n, value)))
    }

    fn info(name: &Name, var: &Var) -> HistoryInfo {
        HistoryInfo {
            name: name.to_string(),
            len: var.len,
            stored: var.values.len() as u32,
            seq: var.seq,
        }
    }

    /// Reads the history length, or sets it (dropping the oldest values).
    ///
    /// Setting the length of a variable never written declares it, as the
    /// thesis' `DataSetHistory` does; reading one is an error.
    pub fn history(&mut self, name: &Name, len: Option<u32>) -> Result<HistoryInfo, ErrorReply> {
        match len {
            Some(len) => {
                if !(1..=MAX_HISTORY).contains(&len) {
                    return Err(err(
                        ErrorCode::OutOfRange,
                        format!("history length must be between 1 and {MAX_HISTORY}, got {len}"),
                    ));
                }
                self.room_for_variable(name)?;
                self.touch_var(name);
                let var = self
                    .vars
                    .entry(name.clone())
                    .or_insert_with(|| Var::new(len));
                var.len = len;
                let freed = var.trim();
                let info = Self::info(name, var);
                self.bytes = self.bytes.saturating_sub(freed);
                Ok(info)
            }
            None => self
                .vars
                .get(name)
                .map(|v| Self::info(name, v))
                .ok_or_else(|| {
                    err(
                        ErrorCode::UnknownVariable,
                        format!("no variable named '{name}'; `rome data ls` lists the variables"),
                    )
                }),
        }
    }

    /// History information of every known variable.
    pub fn histories(&self) -> impl Iterator<Item = (&Name, HistoryInfo)> {
        self.vars.iter().map(|(n, v)| (n, Self::info(n, v)))
    }
}

mod sems;
#[cfg(test)]
mod tests;
