//! Testing and measuring: `rome bench`, `soak` and `fuzz`, modules of
//! [`rome_tools`].

pub use rome_tools::{bench, fuzz, soak};
