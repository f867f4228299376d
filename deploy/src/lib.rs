//! Deploying RoME on hosts: the router and the credentials. The files
//! beside this crate (`router.json5`, `systemd/`, `secure/`,
//! `fleet-on-one-host.sh`) are what a deployment installs; this crate is
//! what `rome` needs to serve them.
//!
//! How this crate is laid out:
//! - [`router`]: `rome router`, a Zenoh router with the storage manager and
//!   REST plugins linked in statically, and the servers' lock records kept
//!   in a file.
//! - [`certs`]: `rome certs`, a deployment's TLS authority, certificates
//!   and passwords for access control.

pub mod certs;
pub mod router;
