//! What runs beside a task's drive and ends it early: the task cancelled
//! or taken back, the robot blocked, the run overdue.

use super::duty::{DutyConfig, OnDuty, BLOCKED, OVERDUE};
use super::schema::{task_var, Assignment};
use crate::board::{Status, Var};
use std::sync::atomic::{AtomicBool, Ordering::Relaxed};
use std::time::Duration;

/// The time every task is allowed beyond its route at
/// [`DutyConfig::slowest_mm_s`]: setting off, turning onto the route,
/// stopping at the end.
const OVERDUE_GRACE: Duration = Duration::from_secs(120);

/// How far a robot must get from where it was, mm, within
/// [`DutyConfig::stuck`], not to be blocked.
const BLOCKED_RADIUS_MM: f64 = 2_000.0;

impl OnDuty<'_> {
    /// Resolves once the robot's `Task` no longer names `a` (the task was
    /// cancelled or taken back), with the reason.
    pub(super) async fn cancelled(&self, a: &Assignment, every: Duration) -> String {
        loop {
            rome_clock::sleep(every).await;
            let value = self.board.client().get(&task_var(self.name)).await;
            match value.map(serde_json::from_value::<Option<Assignment>>) {
                Ok(Ok(Some(now))) if now == *a => {}
                Ok(Ok(_)) => return format!("task {} was cancelled", a.task),
                // The server away or a bad value: no word of a cancel.
                _ => {}
            }
        }
    }

    /// Resolves once the robot has stayed within two metres of one place
    /// (a robot bumping to and fro against an obstacle moves about, but
    /// gets nowhere)
    /// for `cfg.stuck` without waiting its turn, saying where (by its
    /// odometry): something it cannot pass stands in its way.
    pub(super) async fn blocked(&self, cfg: &DutyConfig, waiting: &AtomicBool) -> String {
        let mut anchor: Option<(f64, f64, rome_clock::Instant)> = None;
        loop {
            rome_clock::sleep(cfg.check_every).await;
            let Ok(p) = self.robot.pose().await else {
                continue;
            };
            let (x, y) = (f64::from(p.x_mm), f64::from(p.y_mm));
            match anchor {
                Some((ax, ay, since))
                    if !waiting.load(Relaxed) && (x - ax).hypot(y - ay) < BLOCKED_RADIUS_MM =>
                {
                    if since.elapsed() >= cfg.stuck {
                        let mut why = format!(
                            "{BLOCKED} at ({:.1}, {:.1}) m: got no further than 2 m in {:.0} s",
                            x / 1000.0,
                            y / 1000.0,
                            cfg.stuck.as_secs_f64()
                        );
                        // What the Navigator sees in the way, if it says;
                        // a Status that does not decode only loses that.
                        let seen = self.board.get::<Status>(Var::Status).await;
                        if let Some(nav) = seen.ok().and_then(|s| s.blocked) {
                            why.push_str(&format!(" (the Navigator: {nav})"));
                        }
                        return why;
                    }
                }
                _ => anchor = Some((x, y, rome_clock::Instant::now())),
            }
        }
    }

    /// Resolves once the robot has driven longer than a route of
    /// `length_mm` takes at [`DutyConfig::slowest_mm_s`], plus
    /// [`OVERDUE_GRACE`], not counting the time it waited its turn; the
    /// reason says where its odometry puts it.
    pub(super) async fn overdue(
        &self,
        cfg: &DutyConfig,
        waiting: &AtomicBool,
        length_mm: f64,
    ) -> String {
        let allowed = OVERDUE_GRACE.as_secs_f64() + length_mm / cfg.slowest_mm_s.max(1.0);
        let mut driven = Duration::ZERO;
        loop {
            rome_clock::sleep(cfg.check_every).await;
            if !waiting.load(Relaxed) {
                driven += cfg.check_every;
            }
            if driven.as_secs_f64() >= allowed {
                let at = match self.robot.pose().await {
                    Ok(p) => format!(
                        " at ({:.1}, {:.1}) m",
                        f64::from(p.x_mm) / 1000.0,
                        f64::from(p.y_mm) / 1000.0
                    ),
                    Err(_) => String::new(),
                };
                return format!(
                    "{OVERDUE}{at}: still driving after {:.0} s for a {:.0} m route (it is allowed {:.0} s)",
                    driven.as_secs_f64(),
                    length_mm / 1000.0,
                    allowed
                );
            }
        }
    }
}
