//! The navigation clients of Chapter 5, each a client of the data server
//! and the hardware servers and of nothing else.
//!
//! How this crate is laid out:
//! - [`board`]: the variables and semaphores of Table 5.4, the only way the
//!   clients talk to each other.
//! - [`plan`]: the Path Planner's route and its segments S^l, S^d, S^c
//!   (§5.3); [`planner`] runs it against a Navigator.
//! - [`navigator`]: the deterministic state machine of §5.4 (Center-Hallway,
//!   Corner; L-, D-, E-Goal; Check-Bumper, Check-Goal; a goal ended on a
//!   bad value without ending the Navigator; [`navigator::blocked`] tells
//!   a blocked robot from a slow one); [`hallway`] is
//!   what its states steer by (sonar geometry, hallway model, wall fits),
//!   [`drive`] its settings and motion commands; [`bodies`] tells which
//!   echoes ahead are one robot, and where it stands.
//! - [`crew`]: a robot's crew (Navigator, CTracker, mapper, plate finder),
//!   started one way in one process or in many.
//! - [`ctracker`]: ceiling-light tracking from three scan lines (§5.6).
//! - [`himm`]: the local mapper's histogram grid and Hough transform for
//!   heading correction (§5.5).
//! - [`plfinder`]: door-plate detection from the side camera (§5.7).
//! - [`barcode`]: the reader of the elevator markers (§5.4.6, Fig. 5.11).
//! - [`report`]: how a run is judged by what happened (lights seen, ground
//!   truth, contacts) and reported as rows of Tables 6.1–6.2 and a picture.
//! - [`track`]: where the robot was when a scan or frame was taken, from
//!   the base's state stream, so readings are placed right over a slow link.
//! - [`floors`]: runs between floors, riding an elevator (§5.4.6).
//! - [`fleet`]: tasks for a fleet, the dispatcher that hands them out and
//!   a robot's Planner taking them.
//! - [`traffic`]: the junctions and narrow passages a robot reserves
//!   before it drives into them, in an order that cannot deadlock.

pub mod barcode;
pub mod board;
pub mod bodies;
pub mod crew;
pub mod ctracker;
pub mod drive;
pub mod fleet;
pub mod floors;
pub mod hallway;
pub mod himm;
pub mod navigator;
pub mod plan;
pub mod planner;
pub mod plfinder;
pub mod report;
pub mod track;
pub mod traffic;

use std::time::Duration;

/// Whether `e` says a blackboard value is bad rather than unreachable: it
/// does not decode, or it was never written although its semaphore was
/// signalled. Anyone may write the blackboard, so such a value ends the
/// work at hand, with the reason, and the client goes on.
pub fn bad_value(e: &rome_client::ClientError) -> bool {
    matches!(e, rome_client::ClientError::Decode(_))
        || e.code() == Some(rome_schema::ErrorCode::UnknownVariable)
}

impl NavError {
    /// A failed read of `what` off the blackboard: a bad value
    /// ([`bad_value`]) is [`NavError::Unreadable`], which ends the goal at
    /// hand; anything else (a server gone) passes as it is.
    pub fn reading(what: &'static str, e: rome_client::ClientError) -> NavError {
        if bad_value(&e) {
            NavError::Unreadable { what, source: e }
        } else {
            e.into()
        }
    }
}

/// Why a navigation client stopped.
#[derive(Debug, thiserror::Error)]
pub enum NavError {
    /// A server refused a request or could not be reached.
    #[error(transparent)]
    Client(#[from] rome_client::ClientError),
    /// A server stopped sending what the client waits for.
    #[error("the {what} has been silent for {waited:.1?}")]
    Silent {
        /// Which server, and what was awaited.
        what: &'static str,
        /// How long the client waited.
        waited: Duration,
    },
    /// A value a goal depends on could not be read; the robot was stopped.
    #[error("{what} could not be read, so the robot was stopped: {source}")]
    Unreadable {
        /// Which value.
        what: &'static str,
        /// Why.
        source: rome_client::ClientError,
    },
    /// The CTracker gave the light segment up (it could not read the
    /// segment's values); the robot was stopped.
    #[error("the CTracker gave the light segment up, so the robot was stopped: {0}")]
    SegmentGivenUp(String),
    /// An elevator ride could not be done (no marker seen, no car came);
    /// the robot was stopped.
    #[error("the elevator ride failed, so the robot was stopped: {0}")]
    Ride(String),
    /// The Planner handed a new goal before the one at hand ended: the
    /// robot was stopped and the new goal replaces it.
    #[error("a new goal came before this one ended")]
    Superseded,
    /// A server went away or misbehaved.
    #[error("{0}")]
    Gone(&'static str),
    /// A run cannot be set up as asked.
    #[error("{0}")]
    Config(String),
    /// The Planner cannot plan the run.
    #[error(transparent)]
    Route(#[from] rome_maps::RouteError),
}
