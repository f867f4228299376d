//! The hardware servers (§4.6.2–4.6.4) and the commands to them.
//!
//! - [`sim`]: `rome sim`, a simulated world and every robot's servers
//!   (cargo feature `sim`).
//! - [`pioneer`]: `rome pioneer`, a Pioneer base on a serial line.
//! - [`commands`]: `rome robot`, one command to a robot's servers.
//! - [`elevator_server`]: `rome elevator-server`, a building's elevators
//!   as simulated cars with their servers (cargo feature `sim`).
//! - [`elevator`]: `rome elevator`, one command to an elevator's server,
//!   or a button pressed.
//! - [`storage`]: `rome storage`, the servers' lock records in memory.
//! - [`ros2`]: `rome ros2`, the robots as ROS 2 topics (cargo feature
//!   `ros2`).

pub mod commands;
pub mod elevator;
#[cfg(feature = "sim")]
pub mod elevator_server;
pub mod pioneer;
#[cfg(feature = "ros2")]
pub mod ros2;
#[cfg(feature = "sim")]
pub mod sim;
pub mod storage;
