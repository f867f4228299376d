//! The forward infrared detectors, heard outside the Corner state.
//!
//! The thesis' Center-Hallway state steers by the sonars alone; only the
//! Corner state stops and turns on its infrared (§5.4.2). But a sonar hears
//! a corner only while it lies within its beam, and near the ring the beams
//! leave gaps: a block's convex corner at a corridor's mouth, met at a
//! slant, slides between two beams and every sonar reads past it until the
//! bumper touches (docs/traffic.md, "The corner between two beams"). The
//! two detectors looking 15° either side of ahead cover that gap within
//! their 0.76 m.
//!
//! With [`NavConfig::infrared_ahead`](crate::drive::NavConfig), when one of
//! the two sees something and none of the three sonars ahead (11, 12 and
//! 13) hears anything within the detectors' reach, the robot turns away
//! from that side. What those sonars hear is theirs to steer round, and the
//! detectors looking 45° out see a corridor's wall whenever the robot
//! keeps right, so they are left out. A robot seen 30–45° off ahead, which
//! sonars 9, 10, 14 or 15 hear, still turns it: asking those sonars too
//! was tried and did worse (docs/traffic.md, "The forward infrared
//! outside the Corner state").

use super::{Drive, Navigator};
use rome_schema::robot::body::IR_RANGE_MM;
use rome_schema::robot::Scan;

/// The infrared slots looking 15° right and 15° left of ahead.
const RIGHT: usize = 1;
const LEFT: usize = 2;

/// The sonars 15° either side of ahead and ahead.
const AHEAD: std::ops::RangeInclusive<usize> = 11..=13;

/// How far the robot turns away at a time, degrees: less than a safety
/// turn's 30°, as the detector tells only that something is near, and a
/// scan later it is asked again.
pub const TURN_DEG: f64 = 10.0;

/// Which way to turn, degrees counter-clockwise, if one forward detector
/// sees what the three sonars ahead do not hear within its reach.
pub fn unheard(scan: &Scan) -> Option<f64> {
    let heard = scan
        .sonar_mm
        .get(AHEAD)
        .is_none_or(|ahead| ahead.iter().any(|&r| f64::from(r) <= IR_RANGE_MM));
    if heard {
        return None;
    }
    match (scan.ir_lit(RIGHT), scan.ir_lit(LEFT)) {
        (true, false) => Some(TURN_DEG),
        (false, true) => Some(-TURN_DEG),
        _ => None,
    }
}

impl Navigator {
    /// The state's `drive`, or a turn away from what a forward detector
    /// sees and the sonars ahead do not hear, when
    /// [`NavConfig::infrared_ahead`](crate::drive::NavConfig) is on and the
    /// Corner state (which has its own infrared stop-and-go) is not
    /// steering. A turn or a stop the state asked for is kept.
    pub(super) fn felt(&self, drive: Drive, scan: &Scan, corner_state: bool) -> Drive {
        if !self.cfg.infrared_ahead || corner_state {
            return drive;
        }
        match (drive, unheard(scan)) {
            (Drive::Go(_) | Drive::Jog(_), Some(turn)) => {
                tracing::debug!(
                    t = scan.time_ms,
                    turn,
                    ir = ?&scan.ir[..scan.ir.len().min(4)],
                    "navigator: infrared sees what the sonars ahead do not; turning away"
                );
                Drive::Turn(turn)
            }
            (drive, _) => drive,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(ir: [u8; 8], ahead: u32) -> Scan {
        let mut sonar_mm = vec![5_000; 24];
        sonar_mm[11..=13].fill(ahead);
        Scan {
            robot: "r1".into(),
            seq: 1,
            time_ms: 0,
            sonar_mm,
            ir: ir.to_vec(),
        }
    }

    #[test]
    fn a_detector_lit_with_nothing_heard_ahead_turns_the_robot_away_from_its_side() {
        assert_eq!(
            unheard(&scan([0, 1, 0, 0, 0, 0, 0, 0], 5_000)),
            Some(TURN_DEG)
        );
        assert_eq!(
            unheard(&scan([0, 0, 1, 0, 0, 0, 0, 0], 5_000)),
            Some(-TURN_DEG)
        );
    }

    #[test]
    fn what_the_sonars_ahead_hear_or_both_sides_or_the_outer_detectors_do_not_turn_it() {
        assert_eq!(unheard(&scan([0, 1, 0, 0, 0, 0, 0, 0], 700)), None);
        assert_eq!(unheard(&scan([0, 1, 1, 0, 0, 0, 0, 0], 5_000)), None);
        assert_eq!(unheard(&scan([1, 0, 0, 1, 1, 1, 1, 1], 5_000)), None);
        assert_eq!(unheard(&scan([0; 8], 5_000)), None);
        let short = Scan {
            sonar_mm: vec![5_000; 3],
            ..scan([0, 1, 0, 0, 0, 0, 0, 0], 5_000)
        };
        assert_eq!(unheard(&short), None, "a short scan hears nothing to go by");
    }

    #[test]
    fn in_the_simulator_a_corridors_corner_between_two_beams_is_seen_and_turned_from() {
        // r25 of the Campus's first minutes (40 robots, seed 1), driving
        // west into the corridor between blocks b5 and b11, 127.5 s into
        // the run, its true pose: b11's south-east corner, at (82 600,
        // 14 800), stands 429 mm from the ring, 6° right of ahead, and no
        // sonar within 45° of ahead hears it.
        let pose = rome_maps::geometry::Pose::new(83_381.1, 14_586.6, 81.39);
        let now = crate::navigator::tests::campus_scan("r25", 127_500, pose);
        let nearest = (9..=15).map(|i| now.sonar_mm[i]).min().unwrap_or(0);
        assert!(nearest > 1_000, "the sonars hear it: {:?}", now.sonar_mm);
        assert_eq!(
            &now.ir[..4],
            &[0, 1, 0, 0],
            "the detector 15° right sees it"
        );
        assert_eq!(unheard(&now), Some(TURN_DEG), "turned left, away from it");
    }
}
