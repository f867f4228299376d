//! The simulator's ground truth (`<root>/sim/<robot>/truth`): where a
//! simulated robot really is. For judging runs and for people watching;
//! the navigation clients never read it.

use crate::ClientError;
use rome_schema::robot::robot_name;
use rome_schema::sim::Truth;
use rome_schema::{decode, Root};
use std::time::Duration;
use zenoh::Session;

/// Reads one simulated robot's ground truth.
#[derive(Clone)]
pub struct TruthClient {
    session: Session,
    key: String,
    timeout: Duration,
}

impl TruthClient {
    /// A reader of robot `robot`'s truth under `root`.
    pub fn new(session: &Session, root: &Root, robot: &str) -> Result<TruthClient, ClientError> {
        Ok(TruthClient {
            session: session.clone(),
            key: root.sim_truth(&robot_name(robot)?),
            timeout: Duration::from_secs(3),
        })
    }

    /// The key it reads.
    pub fn key(&self) -> &str {
        &self.key
    }

    /// Where the robot is now; `NoReply` when no simulator answers (a real
    /// robot has no ground truth).
    pub async fn get(&self) -> Result<Truth, ClientError> {
        let started = std::time::Instant::now();
        let replies = self
            .session
            .get(self.key.as_str())
            .timeout(self.timeout)
            .with(crate::call::replies())
            .await
            .map_err(ClientError::zenoh)?;
        let no_reply = || ClientError::NoReply {
            what: "the simulator's ground truth",
            key: self.key.clone(),
            waited: started.elapsed(),
        };
        let reply = replies.recv_async().await.map_err(|_| no_reply())?;
        let sample = reply.result().map_err(|_| no_reply())?;
        Ok(decode(&sample.payload().to_bytes(), "ground truth")?)
    }
}
