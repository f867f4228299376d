//! The error reply: a machine-readable code and a sentence a person can act on.
//!
//! Every request a server cannot carry out is answered with an
//! [`ErrorReply`] (as a Zenoh error reply, JSON-encoded), never dropped.

use serde::{Deserialize, Serialize};
use std::fmt;

/// What went wrong with a request, in a form programs can match on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorCode {
    /// The payload is not valid JSON, or not valid UTF-8.
    BadJson,
    /// A name (variable, semaphore, robot …) is not a valid key chunk.
    BadName,
    /// The key does not name any operation of this server.
    UnknownKey,
    /// A selector parameter is missing, unknown or unparsable.
    BadParameter,
    /// A value has the wrong JSON type for this operation.
    WrongType,
    /// A number is outside the range the operation accepts.
    OutOfRange,
    /// The variable has never been written.
    UnknownVariable,
    /// No semaphore of that name has been created.
    UnknownSemaphore,
    /// The request is valid but conflicts with the server's current state.
    Conflict,
    /// The server is shutting down and will not carry out the request.
    ShuttingDown,
    /// The request carried a lock fence that is not the current grant's.
    StaleFence,
    /// The request waited in a queue longer than it allowed (`wait_ms`).
    TimedOut,
    /// The device did not answer or refused the command.
    Device,
    /// A configured limit of the server (variables, semaphores, bytes)
    /// would be passed; the message names the limit and its value.
    Quota,
    /// The server has too many requests waiting and did not take this one
    /// in: nothing was done, so it is safe to send again after a pause.
    Busy,
    /// The server could not keep the change on disk; the change was not
    /// acknowledged and may or may not survive a restart.
    Storage,
    /// The key has a wildcard where the operation needs one robot and
    /// device named: only reads answer a wildcard key.
    Wildcard,
    /// A command that acts came from a lower priority than one carried out
    /// less than that one's `suppress_ms` ago: it was not carried out.
    Suppressed,
    /// The client speaks another protocol than the server (see
    /// [`crate::version`]); the message names both builds and which to
    /// upgrade. Nothing was done.
    Version,
}

impl ErrorCode {
    /// Whether a server answers this when it did not understand the
    /// request: from a peer of another build as likely as from a mistake,
    /// so the versions are worth naming with it.
    pub fn misunderstood(self) -> bool {
        matches!(
            self,
            ErrorCode::UnknownKey
                | ErrorCode::BadParameter
                | ErrorCode::BadJson
                | ErrorCode::WrongType
        )
    }

    /// The code as it appears on the wire (`"unknown_semaphore"` …).
    pub fn as_str(self) -> &'static str {
        match self {
            ErrorCode::BadJson => "bad_json",
            ErrorCode::BadName => "bad_name",
            ErrorCode::UnknownKey => "unknown_key",
            ErrorCode::BadParameter => "bad_parameter",
            ErrorCode::WrongType => "wrong_type",
            ErrorCode::OutOfRange => "out_of_range",
            ErrorCode::UnknownVariable => "unknown_variable",
            ErrorCode::UnknownSemaphore => "unknown_semaphore",
            ErrorCode::Conflict => "conflict",
            ErrorCode::ShuttingDown => "shutting_down",
            ErrorCode::StaleFence => "stale_fence",
            ErrorCode::TimedOut => "timed_out",
            ErrorCode::Device => "device",
            ErrorCode::Busy => "busy",
            ErrorCode::Storage => "storage",
            ErrorCode::Quota => "quota",
            ErrorCode::Wildcard => "wildcard",
            ErrorCode::Suppressed => "suppressed",
            ErrorCode::Version => "version",
        }
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The body of every error reply.
///
/// ```text
/// {"code":"unknown_semaphore","message":"no semaphore named 'GoalData'; create it first (rome sem create GoalData 0)"}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[serde(deny_unknown_fields)]
#[error("{code}: {message}")]
pub struct ErrorReply {
    /// What kind of error this is.
    pub code: ErrorCode,
    /// A sentence that names what was wrong and, where possible, how to fix it.
    pub message: String,
}

impl ErrorReply {
    /// An error reply with this code and message.
    pub fn new(code: ErrorCode, message: impl Into<String>) -> Self {
        ErrorReply {
            code,
            message: message.into(),
        }
    }
}
