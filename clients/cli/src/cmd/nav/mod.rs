//! Navigation: Chapter 5's clients, Chapter 6's runs and the maps.
//!
//! - [`clients`]: `rome planner|navigator|ctracker|mapper|plfinder`, each
//!   client a process of its own; [`between`] is `rome planner
//!   --building`, a run between floors.
//! - [`demo`] and [`experiment`]: everything in one process, one run or
//!   Chapter 6's tables (cargo feature `sim`); [`floors`] is the demo on
//!   a building of several floors.
//! - [`crew`]: `rome crew`, a robot's clients kept running as processes.
//! - [`fleet`]: `rome dispatcher`, `rome task` and `rome planner --tasks`.
//! - [`scale`]: `rome fleet`, fleets of several sizes measured (cargo
//!   feature `sim`).
//! - [`colony`]: §4.8.2's colony-style networks as prioritised clients.
//! - [`map`]: `rome map check|render|route`.
//! - [`traffic`]: the traffic flags those that drive robots share.

pub mod between;
pub mod clients;
pub mod colony;
pub mod crew;
#[cfg(feature = "sim")]
pub mod demo;
#[cfg(feature = "sim")]
pub mod experiment;
pub mod fleet;
#[cfg(feature = "sim")]
pub mod floors;
pub mod map;
#[cfg(feature = "sim")]
pub mod scale;
pub mod traffic;
