//! Deploying: `rome router` and `rome certs`, modules of [`rome_deploy`].

pub use rome_deploy::{certs, router};
