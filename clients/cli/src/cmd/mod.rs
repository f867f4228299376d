//! The commands, grouped as a user meets them. Each command's module has
//! its flags and a `run`; commands whose work is a library of their own
//! (observing, deploying, testing) only hand their flags over.
//!
//! - [`data`]: `data-server`, `data`, `sem`: the data server and its
//!   variables and semaphores (§4.6.1).
//! - [`robot`]: `sim`, `pioneer`, `robot`, `storage`: the hardware servers
//!   on simulated or serial devices, and commands to them (§4.6.2–4.6.4).
//! - [`nav`]: `planner`, `navigator`, `ctracker`, `mapper`, `plfinder`,
//!   `demo`, `experiment`, `colony`, `map`: Chapter 5's clients, Chapter 6's
//!   runs, §4.8's colony networks and the maps they go by.
//! - `observe`: `ls`, `echo`, `record`, `replay`, `view`, `foxglove`
//!   ([`rome_observe`], cargo feature `observe`).
//! - `deploy`: `router`, `certs` ([`rome_deploy`], feature `router`).
//! - `tools`: `bench`, `soak`, `fuzz` ([`rome_tools`], feature `tools`).

pub mod data;
#[cfg(feature = "router")]
pub mod deploy;
pub mod nav;
#[cfg(feature = "observe")]
pub mod observe;
pub mod robot;
#[cfg(feature = "tools")]
pub mod tools;
