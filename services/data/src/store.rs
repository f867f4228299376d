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
    Committed, CreateReply, HistoryInfo, SemState, SetReply, SignalReply, TryWaitReply, WaitReply,
    WaitStatus, MAX_HISTORY, MAX_SEMAPHORE_VALUE,
};
use rome_schema::{ErrorCode, ErrorReply, Name};
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet, HashMap, VecDeque};
use std::time::Duration;

mod durable;
pub use durable::{Disk, DiskError, Flush, FILE_NAME};

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
    /// The unit stays on the owner's account once confirmed.
    undo: bool,
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

    // ----- semaphores ----------------------------------------------------

    /// Creates a semaphore; an existing one is left as it is.
    pub fn create(&mut self, name: &Name, value: u64) -> Result<CreateReply, ErrorReply> {
        if value > MAX_SEMAPHORE_VALUE {
            return Err(err(
                ErrorCode::OutOfRange,
                format!("initial value {value} is above the maximum {MAX_SEMAPHORE_VALUE}"),
            ));
        }
        if !self.sems.contains_key(name) && self.sems.len() >= self.limits.max_semaphores {
            return Err(err(
                ErrorCode::Quota,
                format!(
                    "semaphore '{name}' would be one too many: the data server holds at most {} semaphores (--max-semaphores)",
                    self.limits.max_semaphores
                ),
            ));
        }
        if !self.sems.contains_key(name) {
            self.touch_sem(name);
        }
        let mut created = false;
        let sem = self.sems.entry(name.clone()).or_insert_with(|| {
            created = true;
            Sem {
                value,
                queue: VecDeque::new(),
            }
        });
        Ok(CreateReply {
            name: name.to_string(),
            created,
            value: sem.value,
        })
    }

    fn sem_state(&self, name: &Name, sem: &Sem) -> SemState {
        SemState {
            name: name.to_string(),
            value: sem.value,
            waiters: sem.queue.len() as u32,
            held: self
                .held
                .range((name.clone(), String::new())..)
                .take_while(|((n, _), _)| n == name)
                .map(|(_, h)| h.units)
                .sum(),
        }
    }

    /// A semaphore's value, queue length and units held with `undo`.
    pub fn semaphore(&self, name: &Name) -> Result<SemState, ErrorReply> {
        let sem = self.sems.get(name).ok_or_else(|| unknown_sem(name))?;
        Ok(self.sem_state(name, sem))
    }

    /// Every semaphore's state.
    pub fn semaphores(&self) -> impl Iterator<Item = (&Name, SemState)> {
        self.sems.iter().map(|(n, s)| (n, self.sem_state(n, s)))
    }

    /// Hands available units to queued tickets, first come first served.
    fn dispatch(&mut self, name: &Name, now: Instant) -> Vec<Grant> {
        let mut grants = Vec::new();
        let Some(sem) = self.sems.get_mut(name) else {
            return grants;
        };
        while sem.value > 0 {
            let Some(ticket) = sem.queue.pop_front() else {
                break;
            };
            sem.value -= 1;
            if let Some(c) = self.changes.as_mut() {
                c.sems.insert(name.clone());
                c.tickets.insert(ticket.clone());
            }
            if let Some(t) = self.tickets.get_mut(&ticket) {
                if t.owner.is_some() {
                    t.state = TicketState::Granted { at: now };
                } else {
                    // Nobody will confirm an anonymous grant: it is final.
                    self.tickets.remove(&ticket);
                }
            }
            grants.push(Grant {
                sem: name.clone(),
                ticket,
            });
        }
        grants
    }

    /// up(): one more unit, handed to the first queued wait if any.
    pub fn signal(
        &mut self,
        name: &Name,
        op: Option<&str>,
        now: Instant,
    ) -> Result<Signalled, ErrorReply> {
        self.signal_as(name, op, None, now)
    }

    /// up() by `undo_owner`, when given: gives back a unit that owner holds
    /// with `undo` (refused if it holds none).
    pub fn signal_as(
        &mut self,
        name: &Name,
        op: Option<&str>,
        undo_owner: Option<&str>,
        now: Instant,
    ) -> Result<Signalled, ErrorReply> {
        match self.recall(op) {
            Some(Remembered::Signal(reply)) if reply.name == name.as_str() => {
                return Ok(Signalled {
                    reply: reply.clone(),
                    grants: Vec::new(),
                })
            }
            Some(_) => return Err(Self::reused(op.unwrap_or_default(), "signal")),
            None => {}
        }
        let sem = self.sems.get_mut(name).ok_or_else(|| unknown_sem(name))?;
        if sem.value >= MAX_SEMAPHORE_VALUE {
            return Err(err(
                ErrorCode::OutOfRange,
                format!("semaphore '{name}' is at its maximum value {MAX_SEMAPHORE_VALUE}"),
            ));
        }
        if let Some(owner) = undo_owner {
            let key = (name.clone(), owner.to_string());
            self.touch_held(&key);
            match self.held.get_mut(&key) {
                Some(h) if h.units > 1 => h.units -= 1,
                Some(_) => {
                    self.held.remove(&key);
                }
                None => {
                    return Err(err(
                        ErrorCode::Conflict,
                        format!("client '{owner}' holds no unit of semaphore '{name}' to give back (undo signals only return units taken by an undo wait)"),
                    ))
                }
            }
        }
        self.touch_sem(name);
        let Some(sem) = self.sems.get_mut(name) else {
            return Err(unknown_sem(name));
        };
        sem.value += 1;
        let grants = self.dispatch(name, now);
        let value = self.sems.get(name).map_or(0, |s| s.value);
        let reply = SignalReply {
            name: name.to_string(),
            value,
            woke: !grants.is_empty(),
        };
        self.remember(op, now, Remembered::Signal(reply.clone()));
        Ok(Signalled { reply, grants })
    }

    /// down_nowait(): takes a unit if one is free and nobody is queued.
    pub fn try_wait(
        &mut self,
        name: &Name,
        op: Option<&str>,
        now: Instant,
    ) -> Result<TryWaitReply, ErrorReply> {
        match self.recall(op) {
            Some(Remembered::TryWait(reply)) if reply.name == name.as_str() => {
                return Ok(reply.clone())
            }
            Some(_) => return Err(Self::reused(op.unwrap_or_default(), "try-wait")),
            None => {}
        }
        let sem = self.sems.get_mut(name).ok_or_else(|| unknown_sem(name))?;
        // Queued waiters came first: taking a unit past them would break FIFO.
        let acquired = sem.value > 0 && sem.queue.is_empty();
        if acquired {
            sem.value -= 1;
        }
        let value = sem.value;
        if acquired {
            self.touch_sem(name);
        }
        let reply = TryWaitReply {
            name: name.to_string(),
            acquired,
            value,
        };
        self.remember(op, now, Remembered::TryWait(reply.clone()));
        Ok(reply)
    }

    fn position(&self, sem: &Name, ticket: &str) -> Option<u32> {
        let sem = self.sems.get(sem)?;
        sem.queue
            .iter()
            .position(|t| t == ticket)
            .map(|p| p as u32 + 1)
    }

    fn wait_reply(&self, name: &Name, ticket: &str, status: WaitStatus) -> WaitReply {
        let position = match status {
            WaitStatus::Pending => self.position(name, ticket),
            _ => None,
        };
        WaitReply {
            name: name.to_string(),
            ticket: ticket.to_string(),
            status,
            position,
        }
    }

    fn check_ticket_sem(&self, name: &Name, ticket: &str) -> Result<(), ErrorReply> {
        match self.tickets.get(ticket) {
            Some(t) if &t.sem != name => Err(err(
                ErrorCode::Conflict,
                format!(
                    "ticket '{ticket}' belongs to semaphore '{}', not '{name}'",
                    t.sem
                ),
            )),
            _ => Ok(()),
        }
    }

    /// down(): takes a unit now, or queues the ticket (reply `pending`).
    ///
    /// A wait without a ticket gets one made up (and is anonymous: nobody
    /// can retry it). A known ticket keeps its place or learns its grant.
    pub fn wait(
        &mut self,
        name: &Name,
        ticket: Option<&str>,
        owner: Option<&str>,
        now: Instant,
    ) -> Result<WaitReply, ErrorReply> {
        self.wait_undo(name, ticket, owner, false, now)
    }

    /// down() whose unit, once confirmed, stays on the owner's account
    /// (`undo`): it goes back by itself if the owner dies before giving
    /// it back with an undo signal. An undo wait needs an owner.
    pub fn wait_undo(
        &mut self,
        name: &Name,
        ticket: Option<&str>,
        owner: Option<&str>,
        undo: bool,
        now: Instant,
    ) -> Result<WaitReply, ErrorReply> {
        if undo && owner.is_none() {
            return Err(err(
                ErrorCode::BadParameter,
                "an undo wait needs an owner (the client's liveliness id): the unit goes back when that client is gone",
            ));
        }
        if !self.sems.contains_key(name) {
            return Err(unknown_sem(name));
        }
        let ticket = match ticket {
            Some(t) => t.to_string(),
            None => {
                self.next_anonymous += 1;
                if let Some(c) = self.changes.as_mut() {
                    c.counter = true;
                }
                format!("anon-{}", self.next_anonymous)
            }
        };
        self.check_ticket_sem(name, &ticket)?;
        if let Some(t) = self.tickets.get_mut(&ticket) {
            return Ok(match t.state {
                TicketState::Granted { .. } => self.wait_reply(name, &ticket, WaitStatus::Granted),
                TicketState::Queued { .. } => {
                    t.state = TicketState::Queued { lapse_at: None };
                    self.wait_reply(name, &ticket, WaitStatus::Pending)
                }
            });
        }
        if let Some(Remembered::Confirmed(reply)) = self.remembered.get(&ticket) {
            // Already granted and confirmed: a late duplicate of the wait.
            return Ok(reply.clone());
        }
        self.touch_ticket(&ticket);
        self.touch_sem(name);
        self.tickets.insert(
            ticket.clone(),
            Ticket {
                sem: name.clone(),
                owner: owner.map(str::to_string),
                state: TicketState::Queued { lapse_at: None },
                undo,
            },
        );
        if let Some(sem) = self.sems.get_mut(name) {
            sem.queue.push_back(ticket.clone());
        }
        let granted = self.dispatch(name, now).iter().any(|g| g.ticket == ticket);
        let status = if granted {
            WaitStatus::Granted
        } else {
            WaitStatus::Pending
        };
        Ok(self.wait_reply(name, &ticket, status))
    }

    /// Whether [`Store::wait_undo`] on `name` with `ticket` would answer at
    /// once (granted, or the reply of a wait already confirmed) rather than
    /// queue the ticket and ask for its query to be held.
    pub fn wait_answers_at_once(&self, name: &Name, ticket: Option<&str>) -> bool {
        let Some(sem) = self.sems.get(name) else {
            return false;
        };
        if let Some(t) = ticket.and_then(|t| self.tickets.get(t)) {
            return t.sem == *name && matches!(t.state, TicketState::Granted { .. });
        }
        match ticket.and_then(|t| self.remembered.get(t)) {
            Some(Remembered::Confirmed(_)) => true,
            Some(_) => false,
            None => sem.value > 0 && sem.queue.is_empty(),
        }
    }

    /// The server stopped holding a wait's query without a grant. An owned
    /// ticket keeps its place until `lapse_at` (the client asks again
    /// before then); an anonymous one leaves the queue (`timed_out`).
    pub fn release_hold(&mut self, ticket: &str, lapse_at: Instant) -> Option<WaitReply> {
        let t = self.tickets.get_mut(ticket)?;
        let name = t.sem.clone();
        match t.state {
            TicketState::Granted { .. } => {
                Some(self.wait_reply(&name, ticket, WaitStatus::Granted))
            }
            TicketState::Queued { .. } if t.owner.is_some() => {
                t.state = TicketState::Queued {
                    lapse_at: Some(lapse_at),
                };
                Some(self.wait_reply(&name, ticket, WaitStatus::Pending))
            }
            TicketState::Queued { .. } => {
                self.drop_queued(ticket);
                Some(self.wait_reply(&name, ticket, WaitStatus::TimedOut))
            }
        }
    }

    fn drop_queued(&mut self, ticket: &str) {
        if let Some(t) = self.tickets.remove(ticket) {
            self.touch_ticket(ticket);
            self.touch_sem(&t.sem);
            if let Some(sem) = self.sems.get_mut(&t.sem) {
                sem.queue.retain(|q| q != ticket);
            }
        }
    }

    /// Gives up a wait. If the unit was granted meanwhile the answer is
    /// `granted`: the client takes it (and acks) rather than losing it.
    pub fn cancel(&mut self, name: &Name, ticket: &str) -> Result<WaitReply, ErrorReply> {
        self.check_ticket_sem(name, ticket)?;
        let status = match self.tickets.get(ticket).map(|t| t.state) {
            Some(TicketState::Granted { .. }) => WaitStatus::Granted,
            Some(TicketState::Queued { .. }) => {
                self.drop_queued(ticket);
                WaitStatus::Cancelled
            }
            None => match self.remembered.get(ticket) {
                Some(Remembered::Confirmed(_)) => WaitStatus::Confirmed,
                _ => WaitStatus::Unknown,
            },
        };
        Ok(self.wait_reply(name, ticket, status))
    }

    /// Confirms a grant: the unit is the client's for good.
    pub fn ack(
        &mut self,
        name: &Name,
        ticket: &str,
        now: Instant,
    ) -> Result<WaitReply, ErrorReply> {
        self.check_ticket_sem(name, ticket)?;
        match self.tickets.get(ticket).map(|t| t.state) {
            Some(TicketState::Granted { .. }) => {
                self.touch_ticket(ticket);
                if let Some(Ticket {
                    owner: Some(owner),
                    undo: true,
                    ..
                }) = self.tickets.remove(ticket)
                {
                    self.touch_held(&(name.clone(), owner.clone()));
                    let h = self.held.entry((name.clone(), owner)).or_insert(Held {
                        units: 0,
                        since: now,
                    });
                    h.units += 1;
                    h.since = now;
                }
                let reply = self.wait_reply(name, ticket, WaitStatus::Confirmed);
                self.remember(Some(ticket), now, Remembered::Confirmed(reply.clone()));
                Ok(reply)
            }
            Some(TicketState::Queued { .. }) => {
                Ok(self.wait_reply(name, ticket, WaitStatus::Pending))
            }
            None => Ok(match self.remembered.get(ticket) {
                Some(Remembered::Confirmed(reply)) => reply.clone(),
                _ => self.wait_reply(name, ticket, WaitStatus::Unknown),
            }),
        }
    }

    fn give_back(&mut self, ticket: &str, now: Instant) -> Vec<Grant> {
        let Some(t) = self.tickets.remove(ticket) else {
            return Vec::new();
        };
        self.touch_ticket(ticket);
        self.touch_sem(&t.sem);
        let Some(sem) = self.sems.get_mut(&t.sem) else {
            return Vec::new();
        };
        sem.value = sem.value.saturating_add(1);
        self.dispatch(&t.sem, now)
    }

    /// A client is gone (its liveliness token was withdrawn): its queued
    /// waits leave the queues and its unconfirmed units go back.
    pub fn owner_gone(&mut self, owner: &str, now: Instant) -> Vec<Grant> {
        let mine: Vec<(String, TicketState)> = self
            .tickets
            .iter()
            .filter(|(_, t)| t.owner.as_deref() == Some(owner))
            .map(|(id, t)| (id.clone(), t.state))
            .collect();
        // Places first: a unit given back must not go to another of the
        // same dead owner's tickets.
        let (queued, granted): (Vec<_>, Vec<_>) = mine
            .into_iter()
            .partition(|(_, state)| matches!(state, TicketState::Queued { .. }));
        for (id, _) in queued {
            self.drop_queued(&id);
        }
        let mut grants = Vec::new();
        for (id, _) in granted {
            grants.extend(self.give_back(&id, now));
        }
        grants.extend(self.return_held(|o, _| o == owner, now));
        grants
    }

    /// Gives back every unit held with `undo` by an owner `gone` says is
    /// gone (given the owner and since when it holds).
    fn return_held(&mut self, gone: impl Fn(&str, Instant) -> bool, now: Instant) -> Vec<Grant> {
        let dead: Vec<(Name, String)> = self
            .held
            .iter()
            .filter(|((_, owner), h)| gone(owner, h.since))
            .map(|(k, _)| k.clone())
            .collect();
        let mut grants = Vec::new();
        for key in dead {
            let Some(h) = self.held.remove(&key) else {
                continue;
            };
            self.touch_held(&key);
            self.touch_sem(&key.0);
            if let Some(sem) = self.sems.get_mut(&key.0) {
                sem.value = sem.value.saturating_add(h.units);
                grants.extend(self.dispatch(&key.0, now));
            }
        }
        grants
    }

    /// Periodic housekeeping: drops queued tickets nobody asked about in
    /// time, takes back unconfirmed units of owners that are not alive
    /// `grace` after the grant (or of any owner after `confirm_within`),
    /// and forgets finished requests past retention.
    pub fn sweep(
        &mut self,
        now: Instant,
        grace: Duration,
        alive: impl Fn(&str) -> bool,
    ) -> Vec<Grant> {
        let lapsed: Vec<String> = self
            .tickets
            .iter()
            .filter(
                |(_, t)| matches!(t.state, TicketState::Queued { lapse_at: Some(at) } if at <= now),
            )
            .map(|(id, _)| id.clone())
            .collect();
        for id in lapsed {
            self.drop_queued(&id);
        }
        let orphaned: Vec<String> = self
            .tickets
            .iter()
            .filter(|(_, t)| match (&t.owner, t.state) {
                (Some(owner), TicketState::Granted { at }) => {
                    (!alive(owner) && at + grace <= now) || at + self.confirm_within <= now
                }
                _ => false,
            })
            .map(|(id, _)| id.clone())
            .collect();
        let mut grants = Vec::new();
        for id in orphaned {
            grants.extend(self.give_back(&id, now));
        }
        // Units held by an owner that has not been seen alive for the grace
        // period go back, in case its departure was never heard.
        grants.extend(self.return_held(|owner, since| !alive(owner) && since + grace <= now, now));
        while let Some((at, _)) = self.remembered_order.front() {
            if *at + self.retention > now {
                break;
            }
            if let Some((_, op)) = self.remembered_order.pop_front() {
                self.remembered.remove(&op);
                self.touch_op(&op);
            }
        }
        grants
    }

    /// How many tickets are queued or granted-unconfirmed (for tests and stats).
    pub fn open_tickets(&self) -> usize {
        self.tickets.len()
    }
}

#[cfg(test)]
mod tests;
