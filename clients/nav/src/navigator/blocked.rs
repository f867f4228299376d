//! Telling a robot that is blocked from one that is slow: driving a
//! hallway goal, it has gained less than [`HEADWAY_MM`] along the goal
//! direction in [`BLOCKED_AFTER_MS`] of robot time. Swerving, turning in
//! place and bumping to and fro all count as no headway. The reason names
//! what the sonars see nearest in front, so a person reading
//! `nav/<robot>/Status` knows what stands in the way.

use crate::hallway::bearing;

/// Headway along the goal that counts as getting somewhere, mm.
pub const HEADWAY_MM: f64 = 300.0;
/// How long without headway before the robot is blocked, ms of robot time.
pub const BLOCKED_AFTER_MS: u64 = 20_000;

/// The watch over one goal's headway.
#[derive(Debug, Clone, PartialEq)]
pub struct Headway {
    /// Since when, and from how far along the goal, no headway was made.
    mark: (u64, f64),
}

impl Headway {
    /// A watch starting at `now_ms`, `travelled_mm` along the goal.
    pub fn new(now_ms: u64, travelled_mm: f64) -> Headway {
        Headway {
            mark: (now_ms, travelled_mm),
        }
    }

    /// Takes the robot's progress at `now_ms`; the reason it is blocked,
    /// while it is.
    pub fn update(&mut self, now_ms: u64, travelled_mm: f64, sonar: &[u32]) -> Option<String> {
        if travelled_mm >= self.mark.1 + HEADWAY_MM || now_ms < self.mark.0 {
            self.mark = (now_ms, travelled_mm);
            return None;
        }
        let stuck_ms = now_ms - self.mark.0;
        (stuck_ms >= BLOCKED_AFTER_MS).then(|| reason(sonar, stuck_ms))
    }
}

/// "blocked: something 0.4 m ahead (sonar 12); no headway for 25 s".
fn reason(sonar: &[u32], stuck_ms: u64) -> String {
    // The front half of the ring: sonars 6 (right) to 18 (left).
    let nearest = (6..=18.min(sonar.len().saturating_sub(1)))
        .map(|i| (i, sonar[i]))
        .min_by_key(|(_, r)| *r);
    let what = match nearest {
        Some((i, r)) => {
            let b = bearing(i);
            let side = if b.abs() < 20.0 {
                "ahead".to_string()
            } else if b > 0.0 {
                format!("{:.0}° left", b)
            } else {
                format!("{:.0}° right", -b)
            };
            format!(
                "something {:.1} m {side} (sonar {i})",
                f64::from(r) / 1000.0
            )
        }
        None => "no sonar reading".to_string(),
    };
    format!(
        "blocked: {what}; no headway for {:.0} s",
        stuck_ms as f64 / 1000.0
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring(nearest: usize, range: u32) -> Vec<u32> {
        let mut s = vec![5_000; 24];
        s[nearest] = range;
        s
    }

    #[test]
    fn no_headway_for_twenty_seconds_is_blocked_and_names_what_is_ahead() {
        let mut h = Headway::new(0, 0.0);
        let ahead = ring(12, 420);
        assert_eq!(h.update(10_000, 200.0, &ahead), None);
        // Bumping to and fro: back and forth, no headway.
        assert_eq!(h.update(15_000, -100.0, &ahead), None);
        assert_eq!(
            h.update(20_000, 250.0, &ahead).as_deref(),
            Some("blocked: something 0.4 m ahead (sonar 12); no headway for 20 s")
        );
        // Once it gets on, it is not blocked, and the watch starts again.
        assert_eq!(h.update(21_000, 320.0, &ahead), None);
        assert_eq!(h.update(40_000, 400.0, &ahead), None);
        let left = ring(15, 900);
        assert_eq!(
            h.update(41_000, 400.0, &left).as_deref(),
            Some("blocked: something 0.9 m 45° left (sonar 15); no headway for 20 s")
        );
    }

    #[test]
    fn steady_headway_is_never_blocked() {
        let mut h = Headway::new(0, 0.0);
        for k in 1..200u64 {
            assert_eq!(h.update(k * 1_000, k as f64 * 400.0, &ring(12, 300)), None);
        }
    }
}
