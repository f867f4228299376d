//! Where the robot was when a sensor reading was taken.
//!
//! A scan or a camera frame carries the device time it was taken at
//! (`time_ms`); the base's state stream carries the pose with the same
//! clock. Asking the base for its pose when a reading arrives would place
//! the reading where the robot is a round trip later: nothing on loopback,
//! but 20 cm at walking speed over a wireless link with 100 ms each way and
//! a retransmission or two. So each client keeps the last few seconds of
//! the state stream and reads the pose at the reading's time from it,
//! interpolated between the two states around it.

use crate::NavError;
use rome_client::RobotClient;
use rome_maps::geometry::Heading;
use rome_maps::geometry::Pose;
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::Notify;

/// How many states are kept (20 s at the default 10 a second).
const KEPT: usize = 200;

/// How long [`PoseTrack::at`] waits for a state at or after a reading's
/// time before asking the base instead.
const WAIT: Duration = Duration::from_millis(1500);

#[derive(Default)]
struct Shared {
    states: VecDeque<(u64, Pose)>,
    closed: bool,
}

/// The recent poses of one robot, from its base's state stream.
pub struct PoseTrack {
    shared: Arc<Mutex<Shared>>,
    arrived: Arc<Notify>,
    task: tokio::task::JoinHandle<()>,
}

impl Drop for PoseTrack {
    fn drop(&mut self) {
        self.task.abort();
    }
}

fn lerp_deg(a: f64, b: f64, t: f64) -> f64 {
    let d = (b - a + 540.0).rem_euclid(360.0) - 180.0;
    (a + d * t).rem_euclid(360.0)
}

/// The pose at `time_ms` from states sorted by time, if they reach it.
fn pose_at(states: &VecDeque<(u64, Pose)>, time_ms: u64) -> Option<Pose> {
    let after = states.iter().position(|(t, _)| *t >= time_ms)?;
    let (t1, p1) = states[after];
    if after == 0 || t1 == time_ms {
        return Some(p1);
    }
    let (t0, p0) = states[after - 1];
    let f = (time_ms - t0) as f64 / (t1 - t0).max(1) as f64;
    Some(Pose {
        at: p0.at + (p1.at - p0.at) * f,
        heading: Heading::from_deg(lerp_deg(p0.heading.deg(), p1.heading.deg(), f)),
    })
}

/// How many pose reads in a row may go unanswered before a client gives up.
const UNANSWERED: u32 = 3;

/// The base's pose. A read kept waiting behind someone else's lock past
/// its wait is asked again: a client that only reads must not end because
/// another holds the robot. So is one the server never answered, a few
/// times.
pub async fn pose_waiting(robot: &RobotClient) -> Result<rome_schema::robot::PoseReply, NavError> {
    let mut unanswered = 0;
    loop {
        match robot.pose().await {
            Err(e) if e.code() == Some(rome_schema::ErrorCode::TimedOut) => {
                tracing::warn!(error = %e, "pose read kept waiting behind a lock; asking again");
            }
            // A base server that died with the request in hand (restarting
            // with its world): asked again, the client library waits for
            // it to serve again.
            Err(e @ rome_client::ClientError::NoReply { .. }) if unanswered < UNANSWERED => {
                unanswered += 1;
                tracing::warn!(error = %e, "pose read unanswered; asking again");
            }
            other => return Ok(other?),
        }
    }
}

impl PoseTrack {
    /// Follows `robot`'s base state stream from now on.
    pub async fn start(robot: &RobotClient) -> Result<PoseTrack, NavError> {
        let stream = robot.state().await?;
        let shared = Arc::new(Mutex::new(Shared::default()));
        let arrived = Arc::new(Notify::new());
        let task = {
            let (shared, arrived) = (shared.clone(), arrived.clone());
            rome_clock::spawn("pose track", async move {
                while let Some(state) = stream.next().await {
                    let Ok(s) = state else { continue };
                    if let Ok(mut sh) = shared.lock() {
                        // A restarted server's clock may start again: keep
                        // the times increasing by starting afresh.
                        if sh.states.back().is_some_and(|(t, _)| *t > s.time_ms) {
                            sh.states.clear();
                        }
                        sh.states.push_back((s.time_ms, Pose::from(&s)));
                        while sh.states.len() > KEPT {
                            sh.states.pop_front();
                        }
                    }
                    arrived.notify_waiters();
                }
                if let Ok(mut sh) = shared.lock() {
                    sh.closed = true;
                }
                arrived.notify_waiters();
            })
        };
        Ok(PoseTrack {
            shared,
            arrived,
            task,
        })
    }

    /// The pose at device time `time_ms`: from the state stream once it
    /// reaches that time, or, if it does not within a moment (no stream,
    /// or a reading from before the oldest state kept), the base's pose now.
    pub async fn at(&self, robot: &RobotClient, time_ms: u64) -> Result<Pose, NavError> {
        let wait = rome_clock::sleep(WAIT);
        tokio::pin!(wait);
        loop {
            // Registered before looking, so a state arriving in between
            // is not missed.
            let notified = self.arrived.notified();
            tokio::pin!(notified);
            notified.as_mut().enable();
            {
                let sh = self
                    .shared
                    .lock()
                    .map_err(|_| NavError::Gone("the pose track"))?;
                let oldest = sh.states.front().map(|(t, _)| *t);
                if oldest.is_some_and(|t| t <= time_ms) {
                    if let Some(p) = pose_at(&sh.states, time_ms) {
                        return Ok(p);
                    }
                }
                if sh.closed || oldest.is_some_and(|t| t > time_ms) {
                    break;
                }
            }
            tokio::select! {
                biased;
                _ = rome_clock::idle(notified) => {}
                _ = &mut wait => break,
            }
        }
        Ok(Pose::from(&robot.pose().await?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, heading: f64) -> Pose {
        Pose::new(x, 0.0, heading)
    }

    #[test]
    fn the_pose_between_two_states_is_interpolated_and_headings_wrap() {
        let states: VecDeque<(u64, Pose)> = [(100, p(0.0, 350.0)), (200, p(100.0, 10.0))].into();
        let mid = pose_at(&states, 150).unwrap();
        assert!((mid.at.x - 50.0).abs() < 1e-9);
        assert!(mid.heading.deg().abs() < 1e-9 || (mid.heading.deg() - 360.0).abs() < 1e-9);
        assert_eq!(pose_at(&states, 200).unwrap().at.x, 100.0);
        assert_eq!(pose_at(&states, 100).unwrap().at.x, 0.0);
        // Not yet reached: the caller waits for the stream.
        assert!(pose_at(&states, 201).is_none());
    }
}
