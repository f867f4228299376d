//! Telling a robot that is blocked from one that is slow: driving a
//! hallway goal, it has gained less than [`HEADWAY_MM`] along the goal
//! direction in [`BLOCKED_AFTER_MS`] of robot time. Swerving, turning in
//! place and bumping to and fro all count as no headway. The reason names
//! what the sonars see nearest towards the goal (else nearest in front),
//! so a person reading `nav/<robot>/Status` knows what stands in the way.
//! And what a blocked robot does: it stands while its way stays closed
//! ([`instead`]), and ends a D goal it is blocked just short of
//! ([`ends_here`]).

use crate::drive::{Drive, PASS_ROOM_MM, ROBOT_RADIUS_MM};
use crate::hallway::bearing;
use rome_maps::geometry::normalize_deg;

/// Headway along the goal that counts as getting somewhere, mm.
pub const HEADWAY_MM: f64 = 300.0;
/// How long without headway before the robot is blocked, ms of robot time.
pub const BLOCKED_AFTER_MS: u64 = 20_000;
/// A robot blocked this near the end of a D goal ends the goal there, mm
/// (with [`crate::drive::NavConfig::stand_when_blocked`]): half of how
/// near its goal a D segment must stop ([`crate::report::ARRIVED_CM`]),
/// so one standing on the goal's last metre, or beside it, is no reason
/// to push on into it.
pub const ENDS_BLOCKED_MM: f64 = 500.0;
/// What stands within this angle of the goal direction, degrees, and
/// nearer than [`IN_THE_WAY_MM`], is what the reason names.
const TOWARDS_GOAL_DEG: f64 = 45.0;
/// See [`TOWARDS_GOAL_DEG`], mm.
const IN_THE_WAY_MM: u32 = 2_000;

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

    /// Takes the robot's progress at `now_ms` and its scan, with the goal
    /// direction `goal_rel_deg` counter-clockwise of its heading; the reason
    /// it is blocked, while it is.
    pub fn update(
        &mut self,
        now_ms: u64,
        travelled_mm: f64,
        sonar: &[u32],
        goal_rel_deg: f64,
    ) -> Option<String> {
        if travelled_mm >= self.mark.1 + HEADWAY_MM || now_ms < self.mark.0 {
            self.mark = (now_ms, travelled_mm);
            return None;
        }
        let stuck_ms = now_ms - self.mark.0;
        (stuck_ms >= BLOCKED_AFTER_MS).then(|| reason(sonar, goal_rel_deg, stuck_ms))
    }
}

/// "blocked: something 0.4 m ahead (sonar 12); no headway for 25 s".
fn reason(sonar: &[u32], goal_rel_deg: f64, stuck_ms: u64) -> String {
    // What stands towards the goal, if anything is near there; else the
    // nearest thing in the front half of the ring (sonars 6, right, to 18,
    // left). In a narrow corridor that is a side wall, which a robot
    // standing beside it is always near, and says little.
    let towards = nearest(sonar, |i| {
        normalize_deg(bearing(i) - goal_rel_deg).abs() <= TOWARDS_GOAL_DEG
    })
    .filter(|(_, r)| *r < IN_THE_WAY_MM);
    let what = match towards.or_else(|| nearest(sonar, |i| (6..=18).contains(&i))) {
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

/// What a blocked robot does instead of `drive`, the goal direction
/// `goal_rel_deg` counter-clockwise of its heading: while its way towards
/// the goal stays closed ([`way_closed`]) it stands rather than make a
/// safety turn. Such turns only swing it to and fro before what stands
/// there, and the base takes up the Go it turned out of after each one, so
/// the robot creeps a few millimetres a turn nearer until the bodies
/// touch. Standing, it drives on as soon as the way opens, or its Planner
/// gives the goal up.
pub fn instead(drive: Drive, sonar: &[u32], goal_rel_deg: f64) -> Drive {
    match drive {
        Drive::Turn(_) if way_closed(sonar, goal_rel_deg) => Drive::Halt,
        d => d,
    }
}

/// Whether a blocked robot `short_mm` before a D goal's end ends the goal
/// there ([`ENDS_BLOCKED_MM`]).
pub fn ends_here(short_mm: f64) -> bool {
    let ends = short_mm <= ENDS_BLOCKED_MM;
    if ends {
        tracing::info!(
            short_mm,
            "navigator: blocked short of the goal; it ends here"
        );
    }
    ends
}

/// Whether something stands in the way towards the goal, `goal_rel_deg`
/// counter-clockwise of the heading: a reading that puts something in the
/// strip the body would sweep driving straight at the goal (its radius and
/// [`PASS_ROOM_MM`] either side) within [`WAY_CLOSED_MM`] of its front. A
/// blocked robot stands only then; one whose goal direction is open (it
/// swung off it, and what its safety turns shy from stands to one side)
/// turns on as before. The walls of a corridor it drives along lie
/// outside the strip.
pub fn way_closed(sonar: &[u32], goal_rel_deg: f64) -> bool {
    (0..sonar.len()).any(|i| {
        let off = normalize_deg(bearing(i) - goal_rel_deg).to_radians();
        let d = f64::from(sonar[i]) + ROBOT_RADIUS_MM;
        let (along, across) = (d * off.cos(), (d * off.sin()).abs());
        along > 0.0
            && along < ROBOT_RADIUS_MM + WAY_CLOSED_MM
            && across < ROBOT_RADIUS_MM + PASS_ROOM_MM
    })
}

/// See [`way_closed`], mm.
pub const WAY_CLOSED_MM: f64 = 1_000.0;

/// The sonar with the shortest reading among those `keep` keeps, and the
/// reading.
fn nearest(sonar: &[u32], keep: impl Fn(usize) -> bool) -> Option<(usize, u32)> {
    (0..sonar.len())
        .filter(|i| keep(*i))
        .map(|i| (i, sonar[i]))
        .min_by_key(|(_, r)| *r)
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
    fn the_way_is_closed_by_what_stands_towards_the_goal_not_beside_it() {
        // A robot 0.3 m ahead, the goal straight on: closed.
        assert!(way_closed(&ring(12, 300), 0.0));
        // The same robot while the goal lies 60° to the left: open.
        assert!(!way_closed(&ring(12, 300), 60.0));
        // A robot 0.1 m away 30° off the goal direction stands in the
        // body's way; a wall 0.8 m away there leaves room.
        assert!(way_closed(&ring(14, 100), 0.0));
        assert!(!way_closed(&ring(10, 800), 0.0));
        // A side wall beside the robot (sonar 6, right) never closes it.
        assert!(!way_closed(&ring(6, 150), 0.0));
        // Far enough ahead, the way is open.
        assert!(!way_closed(&ring(12, 1_000), 0.0));
    }

    #[test]
    fn no_headway_for_twenty_seconds_is_blocked_and_names_what_is_ahead() {
        let mut h = Headway::new(0, 0.0);
        let ahead = ring(12, 420);
        assert_eq!(h.update(10_000, 200.0, &ahead, 0.0), None);
        // Bumping to and fro: back and forth, no headway.
        assert_eq!(h.update(15_000, -100.0, &ahead, 0.0), None);
        assert_eq!(
            h.update(20_000, 250.0, &ahead, 0.0).as_deref(),
            Some("blocked: something 0.4 m ahead (sonar 12); no headway for 20 s")
        );
        // Once it gets on, it is not blocked, and the watch starts again.
        assert_eq!(h.update(21_000, 320.0, &ahead, 0.0), None);
        assert_eq!(h.update(40_000, 400.0, &ahead, 0.0), None);
        let left = ring(15, 900);
        assert_eq!(
            h.update(41_000, 400.0, &left, 0.0).as_deref(),
            Some("blocked: something 0.9 m 45° left (sonar 15); no headway for 20 s")
        );
    }

    #[test]
    fn the_reason_names_what_stands_towards_the_goal_not_the_wall_beside() {
        // Wedged in a narrow corridor: the right wall 0.1 m off, another
        // robot 0.5 m ahead and to the left, the goal straight on.
        let mut s = ring(6, 100);
        s[13] = 500;
        let mut h = Headway::new(0, 0.0);
        assert_eq!(
            h.update(20_000, 0.0, &s, 0.0).as_deref(),
            Some("blocked: something 0.5 m ahead (sonar 13); no headway for 20 s")
        );
        // Turned 90° left of the goal: the goal lies on sonar 6's side.
        assert_eq!(
            h.update(20_000, 0.0, &s, -90.0).as_deref(),
            Some("blocked: something 0.1 m 90° right (sonar 6); no headway for 20 s")
        );
        // Nothing near towards the goal: the nearest thing in front.
        let mut s = ring(6, 100);
        s[12] = 4_000;
        assert_eq!(
            h.update(20_000, 0.0, &s, 0.0).as_deref(),
            Some("blocked: something 0.1 m 90° right (sonar 6); no headway for 20 s")
        );
    }

    #[test]
    fn steady_headway_is_never_blocked() {
        let mut h = Headway::new(0, 0.0);
        for k in 1..200u64 {
            assert_eq!(
                h.update(k * 1_000, k as f64 * 400.0, &ring(12, 300), 0.0),
                None
            );
        }
    }
}
