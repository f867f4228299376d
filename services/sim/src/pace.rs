//! Simulated time against wall-clock time: as fast as possible, or paced at
//! a chosen multiple of real time.

use std::time::{Duration, Instant};

/// Keeps simulated time at `speed` × wall-clock time (or lets it run free).
#[derive(Debug, Clone)]
pub struct Pacer {
    speed: Option<f64>,
    wall_start: Instant,
    sim_start_ms: u64,
}

impl Pacer {
    /// Paced at `speed` × real time; `None` runs as fast as possible.
    pub fn new(speed: Option<f64>, sim_now_ms: u64) -> Pacer {
        Pacer {
            speed: speed.filter(|s| s.is_finite() && *s > 0.0),
            wall_start: Instant::now(),
            sim_start_ms: sim_now_ms,
        }
    }

    /// How long to wait before simulated time `sim_ms` is due; zero when it
    /// is late already or the pace is free.
    pub fn wait(&self, sim_ms: u64) -> Duration {
        let Some(speed) = self.speed else {
            return Duration::ZERO;
        };
        let due = Duration::from_secs_f64(
            sim_ms.saturating_sub(self.sim_start_ms) as f64 / 1000.0 / speed,
        );
        due.saturating_sub(self.wall_start.elapsed())
    }

    /// The pace: `None` for as fast as possible.
    pub fn speed(&self) -> Option<f64> {
        self.speed
    }
}
