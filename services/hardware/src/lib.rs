//! The RoME hardware servers: one server per device, each the only owner of
//! its device (§4.6.2–4.6.4).
//!
//! How this crate is laid out:
//! - [`server`]: what every hardware server shares on Zenoh: the queryable,
//!   the [`gate`] (client priorities, the lock token with fencing numbers),
//!   the lock's storage record and liveliness watch, the publication stream.
//! - [`base`] (RServer, Table 4.1), [`proximity`] (PServer) and [`camera`]
//!   (CServer): each device's commands, one `parse` and one `apply`.
//! - [`elevator`]: a building's elevator as a device of its own (§5.4.6),
//!   with the same session (lock) and state stream, and its buttons.
//! - [`vxy`]: virtual 32-bit coordinates over 16-bit registers (§4.6.3).
//! - [`device`]: one trait per device kind; [`serial`] implements them for
//!   a Pioneer base over a serial line (P2OS/ARCOS), and `rome-sim-hardware`
//!   on the simulated world.
//! - [`storage`]: a Zenoh storage in memory, for runs without a router.
//! - [`robot`]: starts a server as a task of its own.
//!
//! Nothing here knows the simulator: a robot computer that drives a real
//! base links this crate alone.

pub mod base;
pub mod camera;
pub mod device;
pub mod elevator;
pub mod gate;
pub mod proximity;
pub mod robot;
pub mod serial;
pub mod server;
pub mod storage;
pub mod vxy;

/// A mutex's contents, also after a panic elsewhere while it was held:
/// what a server keeps behind one is changed whole or not at all, so it
/// stays usable.
pub fn locked<T>(m: &std::sync::Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

pub use server::{Body, ServerConfig, ServerError, Service};
