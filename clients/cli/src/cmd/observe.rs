//! Watching the fleet: `rome ls`, `echo`, `record`, `replay`, `view` and
//! `foxglove`, each a module of [`rome_observe`].

pub use rome_observe::{echo, foxglove, ls, record, replay, view};
