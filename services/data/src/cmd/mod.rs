//! What each request does to the [`Store`]: one file per request kind,
//! each applying the request of the same name in
//! [`rome_schema::data::request`], where its fields, wire form and strict
//! parsing are defined once for the server and every client.

mod ack;
mod cancel;
mod create;
mod get;
mod history;
mod sem;
mod set;
mod signal;
mod try_wait;
mod wait;

pub use rome_schema::data::request::{value_from_payload as set_value_from_payload, Request};
pub use rome_schema::Params;

use crate::store::{Grant, Store};
use rome_clock::Instant;
use rome_schema::data::Committed;
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
            Request::Get(c) => c.apply(store, now),
            Request::Set(c) => c.apply(store, now),
            Request::History(c) => c.apply(store, now),
            Request::Read(c) => c.apply(store, now),
            Request::Create(c) => c.apply(store, now),
            Request::Signal(c) => c.apply(store, now),
            Request::Wait(c) => c.apply(store, now),
            Request::TryWait(c) => c.apply(store, now),
            Request::Cancel(c) => c.apply(store, now),
            Request::Ack(c) => c.apply(store, now),
        }
    }
}

#[cfg(test)]
mod tests;
