//! The RoME data server (the thesis' DServer, §4.6.1) on Zenoh.
//!
//! How this crate is laid out:
//! - [`store`]: the state (variables with history, semaphores, wait
//!   tickets), pure and synchronous; every rule about not losing or
//!   duplicating a unit lives and is tested there. Its `durable` part
//!   writes what each request changed to a redb file ([`store::Disk`])
//!   before the request is answered.
//! - [`cmd`]: one file per request kind, each parsing its key, selector
//!   parameters and payload strictly, and applying itself to the store.
//! - [`server`]: the Zenoh side: one queryable, two subscribers and a
//!   liveliness subscriber feed one event loop that owns the store;
//!   [`server::run`] takes its shutdown signal so tests can drive it.

pub mod cmd;
pub mod server;
pub mod store;

pub use server::{run, spawn, Running, ServerConfig, ServerError, Storage};
pub use store::{Limits, Store};
