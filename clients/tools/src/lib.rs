//! The tools that test and measure a RoME deployment from outside, as a
//! user's own tools would: benchmarks against bare Zenoh and other stores,
//! a chaos soak, and a fuzzer of every key a peer can reach.
//!
//! How this crate is laid out, a module per `rome` command:
//! - [`mod@bench`]: `rome bench data|robot|sim|mem|all`, each figure beside a
//!   reference measured in the same run.
//! - [`soak`]: `rome soak`, robots and data-server load while processes and
//!   links are killed at random; then what a user relies on is checked.
//! - [`fuzz`]: `rome fuzz`, generated garbage to every key of a running
//!   deployment, then a check that nothing broke.

pub mod bench;
pub mod fuzz;
pub mod soak;
