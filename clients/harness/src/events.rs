//! What a run tells whoever watches as it goes (events, each robot's state
//! at each tick), and what it ends with (one report per robot).

use rome_maps::{Map, World};
use rome_nav::plan::Plan;
use rome_nav::planner::Handed;
use rome_nav::report::Report;
use rome_sim::Pose;
use std::time::Duration;

/// Something to show while the robots drive; `robot` is the index in the
/// configuration's routes.
#[derive(Debug, Clone)]
pub enum Event {
    /// A robot's plan, before anything moves.
    Planned {
        /// Which robot.
        robot: usize,
        /// Its plan.
        plan: Plan,
    },
    /// A goal handed to a Navigator.
    Goal {
        /// Which robot.
        robot: usize,
        /// The goal.
        handed: Handed,
    },
    /// A goal done and judged.
    Judged {
        /// Which robot.
        robot: usize,
        /// The goal, with its verdict.
        handed: Handed,
    },
    /// A robot waits for, holds or has given back a part of the building
    /// it reserves: a narrow passage or a junction ([`rome_nav::traffic`]).
    Traffic {
        /// Which robot.
        robot: usize,
        /// The part's semaphore (`$passage/N`, `$traffic/junction/012`).
        part: String,
        /// What it is doing with it.
        state: PartState,
    },
    /// A robot's run ended (arrived, failed or given up).
    Finished {
        /// Which robot.
        robot: usize,
        /// Its report.
        report: Box<Report>,
    },
    /// The servers are up and the world is about to step: the run's
    /// session, for whoever wants to listen in (a recorder, a viewer).
    Started {
        /// The session every server and client of the run shares.
        session: zenoh::Session,
    },
    /// Once a simulated second or so: where every robot truly is.
    Tick {
        /// Simulated time since the start, s.
        time_s: f64,
        /// Each robot, in order.
        robots: Vec<RobotTick>,
    },
}

/// Where a robot is with a part of the building it reserves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PartState {
    /// Stopped, waiting for it to be free.
    Waiting,
    /// Holding it (going through).
    Holding,
    /// Gave it back.
    Left,
}

/// One robot's state in a [`Event::Tick`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotTick {
    /// True pose.
    pub pose: Pose,
    /// Distance truly driven, mm.
    pub travelled_mm: f64,
    /// How far odometry is from the truth, mm.
    pub odometry_error_mm: f64,
    /// Whether its run has ended.
    pub finished: bool,
}

/// The outcome of a whole run: one report per robot, in order.
#[derive(Debug, Clone)]
pub struct FleetReport {
    /// Each robot's run.
    pub robots: Vec<Report>,
    /// Wall-clock time of the whole run.
    pub wall_time: Duration,
}

impl FleetReport {
    /// The table: a header and one row per robot.
    pub fn table(&self) -> String {
        let mut out = Report::header();
        for (i, r) in self.robots.iter().enumerate() {
            out.push('\n');
            out.push_str(&r.row(i + 1));
        }
        out
    }

    /// Every starred entry's reason.
    pub fn reasons(&self) -> Vec<String> {
        self.robots.iter().flat_map(Report::reasons).collect()
    }

    /// Every trajectory on the map, as PNG bytes.
    pub fn picture(&self, map: &Map, world: &World, width_px: u32) -> Vec<u8> {
        rome_nav::report::fleet_picture(&self.robots, map, world, width_px)
    }
}
