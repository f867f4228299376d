//! The semaphores of the store: creating, signalling, waiting with tickets,
//! holds and confirmations, undo units, and what an owner's departure gives
//! back.

use super::*;
use rome_clock::Instant;
use rome_schema::data::{
    CreateReply, SemState, SignalReply, TryWaitReply, WaitReply, WaitStatus, MAX_SEMAPHORE_VALUE,
};
use rome_schema::{ErrorCode, ErrorReply, Name};
use std::collections::VecDeque;
use std::time::Duration;

impl Store {
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
        // First come first served: a wait for several units at the head
        // of the queue keeps those behind it waiting until they are all
        // free, so it is not starved by single units going past it.
        while let Some(front) = sem.queue.front() {
            let units = self.tickets.get(front).map_or(1, |t| t.units);
            if sem.value < units {
                break;
            }
            let Some(ticket) = sem.queue.pop_front() else {
                break;
            };
            sem.value -= units;
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
        self.signal_units(name, op, undo_owner, 1, now)
    }

    /// up() by `units` at once (System V's `semop` with a positive count);
    /// with `undo_owner`, gives back that many of the units the owner
    /// holds with `undo` (refused if it holds fewer).
    pub fn signal_units(
        &mut self,
        name: &Name,
        op: Option<&str>,
        undo_owner: Option<&str>,
        units: u64,
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
        if units == 0 || sem.value > MAX_SEMAPHORE_VALUE - units.min(MAX_SEMAPHORE_VALUE) {
            return Err(err(
                ErrorCode::OutOfRange,
                format!(
                    "semaphore '{name}' at {} cannot go up by {units}: its maximum is {MAX_SEMAPHORE_VALUE} and a signal adds at least 1",
                    sem.value
                ),
            ));
        }
        if let Some(owner) = undo_owner {
            let key = (name.clone(), owner.to_string());
            let holds = self.held.get(&key).map_or(0, |h| h.units);
            if holds == 0 {
                return Err(err(
                    ErrorCode::Conflict,
                    format!("client '{owner}' holds no unit of semaphore '{name}' to give back (undo signals only return units taken by an undo wait)"),
                ));
            }
            if holds < units {
                return Err(err(
                    ErrorCode::Conflict,
                    format!("client '{owner}' holds {holds} unit(s) of semaphore '{name}', fewer than the {units} it gives back"),
                ));
            }
            self.touch_held(&key);
            if holds == units {
                self.held.remove(&key);
            } else if let Some(h) = self.held.get_mut(&key) {
                h.units -= units;
            }
        }
        self.touch_sem(name);
        let Some(sem) = self.sems.get_mut(name) else {
            return Err(unknown_sem(name));
        };
        sem.value += units;
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
        self.try_wait_undo(name, op, None, now)
    }

    /// down_nowait() whose unit, if taken, stays on `undo_owner`'s account
    /// as a confirmed undo wait's does: it goes back by itself if that
    /// owner dies before giving it back with an undo signal.
    pub fn try_wait_undo(
        &mut self,
        name: &Name,
        op: Option<&str>,
        undo_owner: Option<&str>,
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
            if let Some(owner) = undo_owner {
                self.hold_undo(name, owner.to_string(), 1, now);
            }
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
        self.wait_units(name, ticket, owner, undo, 1, now)
    }

    /// down() by `units` at once: the ticket is granted when that many are
    /// free and it is first in the queue (System V's `semop` with a
    /// negative count). Waiting for every unit of a semaphore and giving
    /// them straight back is how a client waits until nobody holds one.
    pub fn wait_units(
        &mut self,
        name: &Name,
        ticket: Option<&str>,
        owner: Option<&str>,
        undo: bool,
        units: u64,
        now: Instant,
    ) -> Result<WaitReply, ErrorReply> {
        if units == 0 {
            return Err(err(
                ErrorCode::BadParameter,
                "a wait takes at least 1 unit (units=0 would wait for nothing)",
            ));
        }
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
        if let Some(t) = self.tickets.get(&ticket) {
            if t.units != units {
                return Err(err(
                    ErrorCode::Conflict,
                    format!(
                        "ticket '{ticket}' waits for {} unit(s), not {units}",
                        t.units
                    ),
                ));
            }
        }
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
                units,
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
    pub fn wait_answers_at_once(&self, name: &Name, ticket: Option<&str>, units: u64) -> bool {
        let Some(sem) = self.sems.get(name) else {
            return false;
        };
        if let Some(t) = ticket.and_then(|t| self.tickets.get(t)) {
            return t.sem == *name && matches!(t.state, TicketState::Granted { .. });
        }
        match ticket.and_then(|t| self.remembered.get(t)) {
            Some(Remembered::Confirmed(_)) => true,
            Some(_) => false,
            None => sem.value >= units.max(1) && sem.queue.is_empty(),
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

    /// Puts one unit of `name` on `owner`'s undo account: it goes back by
    /// itself if the owner dies before giving it back.
    fn hold_undo(&mut self, name: &Name, owner: String, units: u64, now: Instant) {
        let key = (name.clone(), owner);
        self.touch_held(&key);
        let h = self.held.entry(key).or_insert(Held {
            units: 0,
            since: now,
        });
        h.units += units;
        h.since = now;
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
                    units,
                    ..
                }) = self.tickets.remove(ticket)
                {
                    self.hold_undo(name, owner, units, now);
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
        sem.value = sem.value.saturating_add(t.units);
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
