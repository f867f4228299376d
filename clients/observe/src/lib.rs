//! Watching a RoME fleet with nothing but Zenoh: who is alive, every key's
//! traffic, recordings, a live web page and a Foxglove bridge. Every tool
//! here only listens (or asks, as any client would) and never changes what
//! it watches.
//!
//! How this crate is laid out, a module per `rome` command:
//! - [`ls`]: the live servers and clients, each robot's devices with their
//!   stream rates (`rome ls`).
//! - [`echo`]: any key's puts, deletes, liveliness and replies, or their
//!   rates (`rome echo`).
//! - [`record`] and [`replay`]: MCAP recordings of everything heard, and
//!   putting one back on Zenoh with its original timing.
//! - [`view`]: a live web page of the fleet (map, poses, trails, sonar,
//!   routes, blackboards, cameras), served with axum.
//! - [`foxglove`]: the fleet's traffic live over Foxglove's WebSocket
//!   protocol, cameras as images.
//!
//! Each module has its command's flags (`Args`) and a `run` taking them.

pub mod echo;
pub mod foxglove;
pub mod ls;
pub mod record;
pub mod replay;
pub mod view;
