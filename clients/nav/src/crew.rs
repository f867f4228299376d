//! A robot's crew: the clients that carry out the Planner's goals
//! (Fig. 5.1), started one way whether they share a process (`rome demo`,
//! `rome experiment`) or each has its own (`rome navigator`, `rome
//! ctracker`, `rome mapper`, `rome plfinder`). Each member talks to the
//! others only through the robot's blackboard.

use crate::board::Board;
use crate::ctracker::{CTracker, SegmentLog, TrackConfig};
use crate::drive::NavConfig;
use crate::himm::{Himm, HimmConfig};
use crate::navigator::{NavLog, Navigator};
use crate::plfinder::{PlConfig, PlFinder};
use crate::NavError;
use rome_client::RobotClient;
use tokio::sync::mpsc::UnboundedSender;

/// One member of a robot's crew, with its settings.
#[derive(Debug, Clone)]
pub enum Member {
    /// The Navigator (§5.4).
    Navigator(NavConfig),
    /// The ceiling-light tracker (§5.6).
    CTracker(TrackConfig),
    /// The local mapper, HIMM (§5.5).
    Mapper(HimmConfig),
    /// The door-plate finder (§5.7).
    PlFinder(PlConfig),
}

/// Where members report as they go, for whoever started them; a member
/// with nowhere to report keeps its log to itself.
#[derive(Debug, Default)]
pub struct Reports {
    /// The Navigator's log after each goal.
    pub nav: Option<UnboundedSender<NavLog>>,
    /// The CTracker's log of each light-tracking segment.
    pub track: Option<UnboundedSender<SegmentLog>>,
}

impl Member {
    /// The member's role: what its clients call themselves (`rome ls`)
    /// and the command that runs it alone.
    pub fn role(&self) -> &'static str {
        match self {
            Member::Navigator(_) => "navigator",
            Member::CTracker(_) => "ctracker",
            Member::Mapper(_) => "mapper",
            Member::PlFinder(_) => "plfinder",
        }
    }

    /// Runs the member on its own clients until it fails or its servers
    /// go away.
    pub async fn run(
        self,
        robot: RobotClient,
        board: Board,
        reports: Reports,
    ) -> Result<(), NavError> {
        match self {
            Member::Navigator(cfg) => {
                let mut navigator = Navigator::new(robot, board, cfg);
                match reports.nav {
                    Some(log) => navigator.run_reporting(&log).await,
                    None => navigator.run().await,
                }
            }
            Member::CTracker(cfg) => CTracker::new(robot, board, cfg).run(reports.track).await,
            Member::Mapper(cfg) => Himm::new(robot, board, cfg).run().await,
            Member::PlFinder(cfg) => PlFinder::new(robot, board, cfg).run().await,
        }
    }
}
