//! The simulated side of the hardware servers: an adapter between the
//! simulator ([`rome_sim`]) and the hardware servers ([`rome_hardware`]),
//! which know nothing of each other.
//!
//! How this crate is laid out:
//! - [`world`]: one [`rome_sim::Sim`] shared by its stepping thread (or
//!   lock-step task) and each robot's simulated base, proximity subsystem
//!   and cameras, as the hardware servers' device traits.
//! - [`robot`]: starts a simulated robot's servers, the ground-truth server
//!   and the world's clock, each as its own task.
//! - [`lockstep`]: a world stepped in lock-step with the processes that
//!   follow its clock over the network.
//! - [`truth`]: the simulator's ground truth (`<root>/sim/<robot>/truth`),
//!   which navigation never reads.
//! - [`elevator`]: simulated elevator cars as the elevator server's
//!   devices.
//! - [`trace`]: the world's ground truth at every instant, as text that
//!   keeps every bit, to compare two runs.
//! - [`keep`]: the world's state in a file, so a world killed and started
//!   again takes up its robots where they stood.

pub mod elevator;
pub mod keep;
pub mod lockstep;
pub mod robot;
pub mod trace;
pub mod truth;
pub mod world;

pub use world::{SimWorld, Stepper};
