//! Warnings about what comes off the network, said at most once a while:
//! a ROS 2 node that publishes the wrong type on `cmd_vel` at 100 Hz must
//! not fill the bridge's log, yet the log must still say it goes on and
//! how often.

use std::time::{Duration, Instant};

/// How often a throttled warning is said at most.
pub const EVERY: Duration = Duration::from_secs(5);

/// One kind of warning, said the first time and then at most once every
/// [`EVERY`], with how many times it happened since it was last said.
#[derive(Debug, Default)]
pub struct Throttle {
    said: Option<Instant>,
    unsaid: u64,
}

impl Throttle {
    /// The thing happened at `now`: `Some(n)` when it is to be said now,
    /// `n` being how many times it happened since it was last said (this
    /// one included), `None` when it is only counted.
    pub fn hit(&mut self, now: Instant) -> Option<u64> {
        self.unsaid += 1;
        match self.said {
            Some(t) if now.saturating_duration_since(t) < EVERY => None,
            _ => {
                self.said = Some(now);
                Some(std::mem::take(&mut self.unsaid))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn said_at_first_then_counted_until_its_time_comes_again() {
        let t0 = Instant::now();
        let mut w = Throttle::default();
        assert_eq!(w.hit(t0), Some(1));
        for k in 1..100 {
            assert_eq!(w.hit(t0 + Duration::from_millis(10 * k)), None);
        }
        // Five seconds on: said again, with the 99 unsaid and this one.
        assert_eq!(w.hit(t0 + EVERY), Some(100));
        assert_eq!(w.hit(t0 + EVERY + Duration::from_millis(1)), None);
    }
}
