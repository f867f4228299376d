//! Shared vocabulary of every RoME program: key expressions, messages and
//! error replies.
//!
//! How this crate is laid out:
//! - [`keys`]: the key-expression scheme (`rome/data/var/<name>` …), with a
//!   builder and a parser for every key, so servers and clients never format
//!   keys by hand.
//! - [`data`]: the messages of the data server (the thesis' DServer, §4.6.1),
//!   grouped by who sends them to whom.
//! - [`robot`]: the hardware servers' commands, replies and streams (base,
//!   proximity, cameras; §4.6.2–4.6.4), with their priority and lock
//!   parameters.
//! - [`elevator`]: the elevator server's commands, state and button
//!   presses (§5.4.6), under `<root>/building/elevator/<name>/…`.
//! - [`sim`]: the simulator's ground truth, which navigation never reads.
//! - [`params`]: strict selector-parameter parsing shared by every server.
//! - [`error`]: the error reply every server sends instead of a silent drop.
//! - [`codec`]: the one encode and the one strict decode entry point.
//! - [`version`]: this build and its protocol number, as every program
//!   says them on its liveliness token and in its requests and replies.
//!
//! The crate deliberately does not depend on Zenoh: it is plain data, so any
//! program (and any other language) can follow `docs/keys.md` without it.

pub mod codec;
pub mod data;
pub mod elevator;
pub mod error;
pub mod keys;
pub mod params;
pub mod robot;
pub mod sim;
pub mod version;

pub use codec::{decode, encode, DecodeError};
pub use error::{ErrorCode, ErrorReply};
pub use keys::{DataKey, KeyError, Name, Root};
pub use params::Params;
pub use version::Speaks;
