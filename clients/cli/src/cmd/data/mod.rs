//! The data server (DServer, §4.6.1) and the commands to it.
//!
//! - [`server`]: `rome data-server`.
//! - [`vars`]: `rome data set|get|history|watch|ls`, the shared variables.
//! - [`sem`]: `rome sem`, the semaphores.

pub mod sem;
pub mod server;
pub mod vars;
