//! Where the robot is by odometry, and how far and how fast it has
//! driven: the bookkeeping behind every pose the Navigator steers by.

use super::{Drive, NavError, Navigator, Pose};
use rome_schema::robot::Scan;

impl Navigator {
    pub(super) async fn pose(&mut self) -> Result<Pose, NavError> {
        let pose = Pose::from(&self.robot.pose().await?);
        Ok(self.odometer_to(pose))
    }

    /// The pose when `scan` was taken (from the state stream), so a step
    /// steers by the scan and the pose of one moment.
    pub(super) async fn pose_of(&mut self, scan: &Scan) -> Result<Pose, NavError> {
        let pose = match &self.track {
            Some(track) => self.odometer_to(track.at(&self.robot, scan.time_ms).await?),
            None => self.pose().await?,
        };
        // Timed by the scan either way, so a Navigator without the state
        // stream still knows how fast it drives.
        self.speedo.update(scan.time_ms, self.odometer);
        Ok(pose)
    }

    fn odometer_to(&mut self, pose: Pose) -> Pose {
        if let Some(before) = self.odometer_at {
            self.odometer += pose.dist(&before);
        }
        self.odometer_at = Some(pose);
        pose
    }

    /// The speed the last drive asked for, mm/s.
    pub(super) fn robot_speed(&self) -> f64 {
        match self.last {
            Some(Drive::Go(v)) => v,
            Some(Drive::Jog(_)) => self.cfg.cruise_mm_s,
            _ => 0.0,
        }
    }
}
