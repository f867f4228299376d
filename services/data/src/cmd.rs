//! What each request does to the [`Store`]. The requests themselves
//! (fields, wire form, strict parsing) are defined once, for the server
//! and every client, in [`rome_schema::data::request`].

pub use rome_schema::data::request::{value_from_payload as set_value_from_payload, Request};
pub use rome_schema::Params;

use crate::store::{Grant, Store};
use rome_clock::Instant;
use rome_schema::data::{Committed, WaitStatus};
use rome_schema::{encode, ErrorReply};
use serde::Serialize;
use std::time::Duration;

/// What applying a request asks the server to do.
#[derive(Debug, Default)]
pub struct Applied {
    /// The JSON reply to send now (none: the query is held, see `hold`).
    pub reply: Option<Vec<u8>>,
    /// A commit to publish on `watch/<name>`.
    pub commit: Option<Committed>,
    /// Queued waits that now hold a unit.
    pub grants: Vec<Grant>,
    /// Hold the query for this ticket at most this long.
    pub hold: Option<(String, Duration)>,
}

impl Applied {
    fn reply(message: &impl Serialize) -> Self {
        Applied {
            reply: Some(encode(message)),
            ..Applied::default()
        }
    }
}

/// A request carried out on the store at `now`.
pub trait Apply {
    /// Carries it out.
    fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply>;
}

impl Apply for Request {
    fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply> {
        match self {
            Request::Get(get) => Ok(Applied {
                // The value exactly as written.
                reply: Some(encode(store.get(&get.name, get.back)?)),
                ..Applied::default()
            }),
            Request::Set(set) => {
                let written = store.set(&set.name, set.value, set.op.as_deref(), now)?;
                // Published on `watch/<name>` by the server.
                let mut applied = Applied::reply(&written.reply);
                applied.commit = written.commit;
                Ok(applied)
            }
            Request::History(h) => Ok(Applied::reply(&store.history(&h.name, h.len)?)),
            Request::Read(read) => Ok(Applied::reply(&store.semaphore(&read.name)?)),
            Request::Create(c) => Ok(Applied::reply(&store.create(&c.name, c.value)?)),
            Request::Signal(s) => {
                let signalled = store.signal_units(
                    &s.name,
                    s.op.as_deref(),
                    s.undo_owner.as_deref(),
                    s.units,
                    now,
                )?;
                // The waits it granted are answered by the server.
                let mut applied = Applied::reply(&signalled.reply);
                applied.grants = signalled.grants;
                Ok(applied)
            }
            Request::Wait(w) => {
                let reply = store.wait_units(
                    &w.name,
                    w.ticket.as_deref(),
                    w.owner.as_deref(),
                    w.undo,
                    w.units,
                    now,
                )?;
                if reply.status == WaitStatus::Pending {
                    // The server holds the query until a unit comes or
                    // the hold runs out.
                    return Ok(Applied {
                        hold: Some((reply.ticket, w.hold)),
                        ..Applied::default()
                    });
                }
                Ok(Applied::reply(&reply))
            }
            Request::TryWait(t) => Ok(Applied::reply(&store.try_wait_undo(
                &t.name,
                t.op.as_deref(),
                t.undo_owner.as_deref(),
                now,
            )?)),
            Request::Cancel(c) => Ok(Applied::reply(&store.cancel(&c.name, &c.ticket)?)),
            Request::Ack(a) => Ok(Applied::reply(&store.ack(&a.name, &a.ticket, now)?)),
        }
    }
}

#[cfg(test)]
mod tests;
