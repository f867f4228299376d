//! One file per request kind. Each parses its selector parameters and
//! payload strictly (an unknown parameter is an error, so `?bak=2` is not
//! silently read as `back=0`) and applies itself to the [`Store`].
//!
//! Parameters whose name starts with `_` are Zenoh's own (`_anyke` …) and
//! are passed over.

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

pub use ack::Ack;
pub use cancel::Cancel;
pub use create::Create;
pub use get::Get;
pub use history::History;
pub use rome_schema::Params;
pub use sem::Read;
pub use set::{value_from_payload as set_value_from_payload, Set};
pub use signal::Signal;
pub use try_wait::TryWait;
pub use wait::Wait;

use crate::store::{Grant, Store};
use rome_clock::Instant;
use rome_schema::data::Committed;
use rome_schema::keys::DataOp;
use rome_schema::{encode, ErrorCode, ErrorReply, KeyError, Root};
use serde::Serialize;
use std::time::Duration;

/// A request to the data server, parsed from a query on a literal key.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    /// `var/<name>`: read a value.
    Get(Get),
    /// `set/<name>`: acknowledged write.
    Set(Set),
    /// `history/<name>`: read or set the history length.
    History(History),
    /// `sem/<name>`: read a semaphore.
    Read(Read),
    /// `create/<name>`: create a semaphore.
    Create(Create),
    /// `signal/<name>`: up().
    Signal(Signal),
    /// `wait/<name>`: blocking down().
    Wait(Wait),
    /// `try-wait/<name>`: non-blocking down().
    TryWait(TryWait),
    /// `cancel/<name>`: give up a queued wait.
    Cancel(Cancel),
    /// `ack/<name>`: confirm a grant.
    Ack(Ack),
}

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

impl Request {
    /// Parses a query on a literal key into a request.
    pub fn parse(
        root: &Root,
        key: &str,
        params: Params,
        payload: Option<&[u8]>,
    ) -> Result<Request, ErrorReply> {
        let key = root.parse_data(key).map_err(|e| {
            let code = match e {
                KeyError::BadName { .. } => ErrorCode::BadName,
                KeyError::OutsideRoot { .. } | KeyError::UnknownOp { .. } => ErrorCode::UnknownKey,
            };
            ErrorReply::new(code, e.to_string())
        })?;
        let name = key.name;
        let op = key.op;
        // Only a write carries a payload; anywhere else it is a mistake
        // (an argument sent as payload instead of a selector parameter).
        if op != DataOp::Set && payload.is_some_and(|p| !p.is_empty()) {
            return Err(ErrorReply::new(
                ErrorCode::BadParameter,
                format!("'{}' takes no payload; its arguments are selector parameters (see docs/keys.md)", op.chunk()),
            ));
        }
        let request = match op {
            DataOp::Set => Request::Set(Set::parse(name, params, payload)?),
            DataOp::Var => Request::Get(Get::parse(name, params)?),
            DataOp::History => Request::History(History::parse(name, params)?),
            DataOp::Sem => Request::Read(Read::parse(name, params)?),
            DataOp::Create => Request::Create(Create::parse(name, params)?),
            DataOp::Signal => Request::Signal(Signal::parse(name, params)?),
            DataOp::Wait => Request::Wait(Wait::parse(name, params)?),
            DataOp::TryWait => Request::TryWait(TryWait::parse(name, params)?),
            DataOp::Cancel => Request::Cancel(Cancel::parse(name, params)?),
            DataOp::Ack => Request::Ack(Ack::parse(name, params)?),
            DataOp::Watch => {
                return Err(ErrorReply::new(
                    ErrorCode::UnknownKey,
                    format!(
                        "'{}' is published by the server, not queried: subscribe to it (rome data watch {name})",
                        root.data(DataOp::Watch, &name)
                    ),
                ))
            }
        };
        Ok(request)
    }

    /// Applies the request to the store.
    pub fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply> {
        match self {
            Request::Get(c) => c.apply(store),
            Request::Set(c) => c.apply(store, now),
            Request::History(c) => c.apply(store),
            Request::Read(c) => c.apply(store),
            Request::Create(c) => c.apply(store),
            Request::Signal(c) => c.apply(store, now),
            Request::Wait(c) => c.apply(store, now),
            Request::TryWait(c) => c.apply(store, now),
            Request::Cancel(c) => c.apply(store),
            Request::Ack(c) => c.apply(store, now),
        }
    }
}

#[cfg(test)]
mod tests;
