//! What a client call can fail with.

use rome_schema::{DecodeError, ErrorReply, KeyError};
use std::time::Duration;

/// Why a client call failed.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The server refused the request and said why.
    #[error(transparent)]
    Server(#[from] ErrorReply),
    /// A name or pattern is not valid; nothing was sent.
    #[error(transparent)]
    Key(#[from] KeyError),
    /// No server answered in time.
    #[error("no reply from {what} on '{key}' after {waited:.1?}; is it running and reachable, and does the router's access control let this identity ask? (`rome ls` lists what is alive)")]
    NoReply {
        /// Which server was asked.
        what: &'static str,
        /// The key that was queried.
        key: String,
        /// How long the client tried.
        waited: Duration,
    },
    /// A reply could not be decoded: the server speaks another version.
    #[error("unexpected reply: {0}")]
    Decode(#[from] DecodeError),
    /// A value to write cannot be written as JSON (a map with keys that
    /// are not strings …); nothing was sent.
    #[error("cannot write the value as JSON: {0}")]
    Value(String),
    /// The server refused a request it did not understand, and it speaks
    /// another protocol than this client (or says nothing of its version).
    #[error("{refused}; {versions}")]
    Versions {
        /// The server's refusal.
        refused: ErrorReply,
        /// Both builds, and which to upgrade.
        versions: String,
    },
    /// Zenoh itself failed (bad configuration, session closed …).
    #[error("zenoh: {0}")]
    Zenoh(String),
}

impl ClientError {
    /// Zenoh's own failure `e`.
    pub fn zenoh(e: impl std::fmt::Display) -> Self {
        ClientError::Zenoh(e.to_string())
    }

    /// The server's error code, if the server refused the request.
    pub fn code(&self) -> Option<rome_schema::ErrorCode> {
        match self {
            ClientError::Server(e) | ClientError::Versions { refused: e, .. } => Some(e.code),
            _ => None,
        }
    }
}
