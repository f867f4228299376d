//! Every request to the data server, defined once: its fields, its wire
//! form (key, selector parameters, payload) in [`Command::params`] and
//! [`Command::payload`], and its strict parsing in [`Command::parse`]. The
//! client library encodes with the first two and the server parses with
//! the third, so the two ends cannot drift apart; a test encodes each one
//! and parses it back.
//!
//! One file per request, each with its wire form in its doc comment;
//! [`Request`] is the one that a key names, parsed from a query.
//!
//! Parameters whose name starts with `_` are Zenoh's own (`_anyke` …) and
//! are passed over; any other unknown parameter is an error, so `?bak=2` is
//! not silently read as `back=0`.

/// Defines a request: its doc comment and derives, its type name, the
/// operation its key names, its reply, what its name is the name of, its
/// own fields (after `name`), and the rest of its [`Command`]: how it is
/// encoded (`params`, `payload`) and parsed (`parse`).
macro_rules! request {
    (
        $(#[$meta:meta])*
        $ty:ident: $op:ident -> $reply:ty, $what:literal {
            $($(#[$field_meta:meta])* pub $field:ident: $field_ty:ty,)*
        }
        $($command:tt)*
    ) => {
        $(#[$meta])*
        pub struct $ty {
            #[doc = $what]
            pub name: $crate::Name,
            $($(#[$field_meta])* pub $field: $field_ty,)*
        }

        impl $crate::data::request::Command for $ty {
            const OP: $crate::keys::DataOp = $crate::keys::DataOp::$op;
            type Reply = $reply;

            fn name(&self) -> &$crate::Name {
                &self.name
            }

            $($command)*
        }
    };
}

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
pub use sem::Read;
pub use set::{value_from_payload, Set};
pub use signal::Signal;
pub use try_wait::TryWait;
pub use wait::Wait;

use crate::keys::DataOp;
use crate::{ErrorCode, ErrorReply, KeyError, Name, Params, Root};
use serde::de::DeserializeOwned;

/// One kind of request to the data server.
pub trait Command: Sized {
    /// The operation its key names (`<root>/data/<op>/<name>`).
    const OP: DataOp;
    /// What the server answers on success.
    type Reply: DeserializeOwned;

    /// The variable or semaphore it is about.
    fn name(&self) -> &Name;

    /// Its selector parameters, as [`Command::parse`] reads them back.
    fn params(&self) -> Vec<(&'static str, String)>;

    /// Its payload; only an acknowledged write has one.
    fn payload(&self) -> Option<Vec<u8>> {
        None
    }

    /// Parses it from the name in its key, its parameters and its payload
    /// (the payload is refused before this for every request but a write).
    fn parse(name: Name, params: Params, payload: Option<&[u8]>) -> Result<Self, ErrorReply>;

    /// Its key under `root`.
    fn key(&self, root: &Root) -> String {
        root.data(Self::OP, self.name())
    }
}

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
            DataOp::Var => Request::Get(Get::parse(name, params, None)?),
            DataOp::History => Request::History(History::parse(name, params, None)?),
            DataOp::Sem => Request::Read(Read::parse(name, params, None)?),
            DataOp::Create => Request::Create(Create::parse(name, params, None)?),
            DataOp::Signal => Request::Signal(Signal::parse(name, params, None)?),
            DataOp::Wait => Request::Wait(Wait::parse(name, params, None)?),
            DataOp::TryWait => Request::TryWait(TryWait::parse(name, params, None)?),
            DataOp::Cancel => Request::Cancel(Cancel::parse(name, params, None)?),
            DataOp::Ack => Request::Ack(Ack::parse(name, params, None)?),
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
}

/// Takes `owner` and `undo`: the owner whose undo unit the request gives
/// back or takes (`owner=ID;undo=true`); an owner alone changes nothing.
fn undo_owner(params: &mut Params, what: &str) -> Result<Option<String>, ErrorReply> {
    let owner = params.take_id(super::param::OWNER)?;
    let undo = params.take_bool(super::param::UNDO)?;
    match (owner, undo) {
        (Some(owner), true) => Ok(Some(owner)),
        (None, true) => Err(ErrorReply::new(
            ErrorCode::BadParameter,
            format!("an undo {what} names the owner whose unit it is (owner=ID)"),
        )),
        (_, false) => Ok(None),
    }
}

/// `op=ID` and `owner=ID;undo=true`, each when there is one: the
/// parameters signal and try-wait share.
fn op_undo_params(op: &Option<String>, undo_owner: &Option<String>) -> Vec<(&'static str, String)> {
    let mut params: Vec<_> = op.iter().map(|op| (super::param::OP, op.clone())).collect();
    if let Some(owner) = undo_owner {
        params.push((super::param::OWNER, owner.clone()));
        params.push((super::param::UNDO, "true".to_string()));
    }
    params
}

/// Parses `op`, `owner` and `undo` and nothing else (signal, try-wait).
fn parse_op_undo(
    mut params: Params,
    what: &str,
) -> Result<(Option<String>, Option<String>), ErrorReply> {
    let op = params.take_id(super::param::OP)?;
    let undo_owner = undo_owner(&mut params, what)?;
    params.finish(
        what,
        &[super::param::OP, super::param::OWNER, super::param::UNDO],
    )?;
    Ok((op, undo_owner))
}

/// Takes the required `ticket` parameter of `op`.
fn required_ticket(op: &str, params: &mut Params) -> Result<String, ErrorReply> {
    params.take_id(super::param::TICKET)?.ok_or_else(|| {
        ErrorReply::new(
            ErrorCode::BadParameter,
            format!("'{op}' needs the ticket of the wait: ?ticket=ID"),
        )
    })
}

#[cfg(test)]
mod tests;
