//! Near echoes ahead, remembered while the robot drives on.
//!
//! A sonar hears a corner only while the corner lies within its beam
//! (7.5° either side of its axis), and the beams fan out from the ring's
//! rim 15° apart: near the robot they leave gaps. The convex corner of a
//! corridor's mouth, heard straight ahead at 0.75 m, slides into the gap
//! between two beams as the robot closes on it at a slant, and from then
//! on every sonar reads nothing: among forty robots on the Campus, two
//! drove on into such corners (docs/traffic.md, "The corner between two
//! beams").
//!
//! With [`NavConfig::remember_echoes`](crate::drive::NavConfig) the
//! Navigator remembers a near echo (within [`NEAR_MM`]) that a sonar
//! within 45° of ahead loses from one scan to the next. As a sonar tells
//! how far but not where within its beam, the echo is kept as the beam's
//! arc at that range, placed by odometry, and fills in the sonars ahead
//! that it lies before. It is forgotten once the robot has driven
//! [`KEEP_DRIVEN_MM`] or [`KEEP_MS`] have passed, when a beam that holds
//! the whole arc hears past it (it moved away), or when odometry is
//! corrected under it. An echo its sonar still hears is not remembered:
//! the reading says where it is.

use super::{Navigator, Pose};
use crate::hallway::sonar_towards;
use rome_maps::geometry::{direction, heading_to, normalize_deg, Point};
use rome_schema::robot::body::{sonar_bearing_deg, ROBOT_RADIUS_MM, SONAR_HALF_BEAM_DEG};
use rome_schema::robot::{Scan, SONARS};

/// Echoes nearer than this to the ring are remembered, mm.
pub const NEAR_MM: f64 = 1_000.0;
/// An echo is forgotten after the robot has driven this far, mm.
pub const KEEP_DRIVEN_MM: f64 = 1_000.0;
/// An echo is forgotten after this long, ms.
pub const KEEP_MS: u64 = 4_000;
/// Remembered echoes fill in the sonars within this of ahead, degrees:
/// the safety checks' cone.
const AHEAD_DEG: f64 = 45.0;
/// A beam pointing at a remembered echo that reads this much farther
/// says it has gone, mm.
const GONE_MM: f64 = 150.0;
/// A pose that moves this much more than the odometer counted was
/// corrected (HIMM), and the echoes placed by the old one are dropped, mm.
const JUMP_MM: f64 = 100.0;
/// The most echoes kept, the newest: 24 a scan over a few scans.
const MOST: usize = 120;

/// One echo: where it may be, and when it was heard. A sonar tells how
/// far, not where within its beam: the echo is the arc of the beam at
/// that range, kept as [`ARC`] points across it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Echo {
    arc: [Point; ARC],
    odometer_mm: f64,
    time_ms: u64,
}

/// Points kept across a beam's arc.
const ARC: usize = 5;

/// The near echoes of the last metre driven.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Echoes {
    kept: Vec<Echo>,
    /// The pose and odometer at the last scan.
    last: Option<(Point, f64)>,
    /// The last scan's near echoes ahead: sonar, range, where the sonar
    /// stood and the way it looked (degrees).
    before: Vec<(usize, f64, Point, f64)>,
}

impl Echoes {
    /// Takes the scan's near echoes in and fills in the sonars ahead that
    /// hear less than what is remembered. `odometer_mm` is the distance
    /// driven so far.
    pub fn hear(&mut self, pose: &Pose, odometer_mm: f64, scan: &mut Scan) {
        if scan.sonar_mm.len() != SONARS {
            return;
        }
        let heading = pose.heading.deg();
        if let Some((at, odo)) = self.last {
            if (at - pose.at).norm() > (odometer_mm - odo).abs() + JUMP_MM {
                self.kept.clear();
                self.before.clear();
            }
        }
        self.last = Some((pose.at, odometer_mm));
        let heard = scan.sonar_mm.clone();
        self.kept.retain(|e| {
            odometer_mm - e.odometer_mm <= KEEP_DRIVEN_MM
                && scan.time_ms.saturating_sub(e.time_ms) <= KEEP_MS
                && !gone(&e.arc, pose, heading, &heard)
        });
        // An echo is remembered when it is lost: while its sonar hears it,
        // the reading says where it is.
        for &(i, r, s, b) in &self.before {
            if f64::from(heard[i]) > r + GONE_MM {
                let arc = std::array::from_fn(|k| {
                    let across = (k as f64 / (ARC - 1) as f64 * 2.0 - 1.0) * SONAR_HALF_BEAM_DEG;
                    s + direction(b + across) * r
                });
                let echo = Echo {
                    arc,
                    odometer_mm,
                    time_ms: scan.time_ms,
                };
                if !gone(&echo.arc, pose, heading, &heard) {
                    self.kept.push(echo);
                }
            }
        }
        self.before.clear();
        for (i, &r) in heard.iter().enumerate() {
            if sonar_bearing_deg(i).abs() <= AHEAD_DEG && f64::from(r) < NEAR_MM {
                let b = heading + sonar_bearing_deg(i);
                let s = pose.at + direction(b) * ROBOT_RADIUS_MM;
                self.before.push((i, f64::from(r), s, b));
            }
        }
        // The newest are kept: what was heard last is what lies nearest.
        let over = self.kept.len().saturating_sub(MOST);
        self.kept.drain(..over);
        for p in self.kept.iter().flat_map(|e| e.arc.iter()) {
            let rel = normalize_deg(heading_to(pose.at, *p) - heading);
            if rel.abs() > AHEAD_DEG {
                continue;
            }
            let i = sonar_towards(rel);
            let range = ((p - pose.at).norm() - ROBOT_RADIUS_MM).max(1.0);
            let slot = &mut scan.sonar_mm[i];
            *slot = (*slot).min(range as u32);
        }
    }
}

impl Navigator {
    /// The scan with the near echoes of the last metre driven filled in,
    /// when [`NavConfig::remember_echoes`](crate::drive::NavConfig) is on.
    pub(super) fn hear_again(&mut self, pose: &Pose, scan: &mut Scan) {
        if self.cfg.remember_echoes {
            self.echoes.hear(pose, self.odometer, scan);
        }
    }
}

/// Whether a beam that has the whole of the echo's arc within it reads
/// farther than all of it: what echoed there has gone. Closer than where
/// it was heard, the arc is wider than any beam, and the echo stays.
fn gone(arc: &[Point; ARC], pose: &Pose, heading: f64, heard: &[u32]) -> bool {
    (0..SONARS).any(|i| {
        let b = heading + sonar_bearing_deg(i);
        let s = pose.at + direction(b) * ROBOT_RADIUS_MM;
        let mut farthest = 0.0_f64;
        let within = arc.iter().all(|p| {
            farthest = farthest.max((p - s).norm());
            (p - s).norm() > 1.0
                && normalize_deg(heading_to(s, *p) - b).abs() <= SONAR_HALF_BEAM_DEG + 0.01
        });
        within && f64::from(heard[i]) > farthest + GONE_MM
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::navigator::tests::campus_scan;

    fn scan(time_ms: u64, sonar: &[(usize, u32)]) -> Scan {
        let mut sonar_mm = vec![5_000; SONARS];
        for &(i, r) in sonar {
            sonar_mm[i] = r;
        }
        Scan {
            robot: "r1".into(),
            seq: 0,
            time_ms,
            sonar_mm,
            ir: vec![0; SONARS],
        }
    }

    fn pose(x: f64, y: f64, heading: f64) -> Pose {
        Pose::new(x, y, heading)
    }

    #[test]
    fn a_corner_heard_ahead_is_still_there_when_it_slides_between_two_beams() {
        // Heading west (90°), a corner on sonar 12's axis 750 mm from the
        // ring, at (-1130, 0).
        let mut echoes = Echoes::default();
        let mut first = scan(0, &[(12, 750)]);
        echoes.hear(&pose(0.0, 0.0, 90.0), 0.0, &mut first);
        // Its arc, placed from the ring's middle, reads a few mm nearer.
        assert!(
            (745..=750).contains(&first.sonar_mm[12]),
            "{:?}",
            first.sonar_mm
        );
        // 530 mm short of it, turned 12° to the right: the corner lies 12°
        // left of ahead, 10.5° off sonar 13's axis as seen from that sonar
        // on the rim, and 38° off sonar 12's: in no beam, and nobody hears
        // it.
        let mut later = scan(2_000, &[]);
        echoes.hear(&pose(-600.0, 0.0, 78.0), 600.0, &mut later);
        // The beam's arc at 750 mm, ±98 mm across, 150–155 mm from the
        // ring now, fills in the sonars it lies before.
        let nearest = (11..=14).map(|i| later.sonar_mm[i]).min().unwrap_or(0);
        assert!((140..=160).contains(&nearest), "{:?}", later.sonar_mm);
        let far = (0..SONARS).filter(|i| !(11..=14).contains(i));
        assert!(far.map(|i| later.sonar_mm[i]).all(|r| r == 5_000));
    }

    #[test]
    fn the_newest_echoes_are_kept_when_there_are_many() {
        // Two seconds of echoes 45° either side, lost, then a corner ahead
        // lost too: the corner is remembered.
        let mut echoes = Echoes::default();
        for k in 0..20 {
            let mut side = scan(k * 100, &[(9, 900), (10, 900), (14, 900), (15, 900)]);
            echoes.hear(&pose(0.0, 0.0, 0.0), 0.0, &mut side);
        }
        echoes.hear(&pose(0.0, 0.0, 0.0), 0.0, &mut scan(2_000, &[(12, 700)]));
        let mut on = scan(2_100, &[]);
        echoes.hear(&pose(0.0, 300.0, 0.0), 300.0, &mut on);
        assert!((380..=420).contains(&on.sonar_mm[12]), "{:?}", on.sonar_mm);
    }

    #[test]
    fn an_echo_a_beam_now_hears_past_is_forgotten() {
        let mut echoes = Echoes::default();
        echoes.hear(&pose(0.0, 0.0, 0.0), 0.0, &mut scan(0, &[(12, 600)]));
        // Standing still, sonar 12 now reads 2 m: what stood there left.
        let mut now = scan(500, &[(12, 2_000)]);
        echoes.hear(&pose(0.0, 0.0, 0.0), 0.0, &mut now);
        assert_eq!(now.sonar_mm[12], 2_000);
        assert!(echoes.kept.is_empty());
    }

    #[test]
    fn echoes_are_forgotten_after_a_metre_driven_a_correction_or_beside() {
        let mut echoes = Echoes::default();
        echoes.hear(&pose(0.0, 0.0, 0.0), 0.0, &mut scan(0, &[(12, 900)]));
        // Corrected by 300 mm with 100 mm driven: dropped.
        let mut next = scan(100, &[]);
        echoes.hear(&pose(300.0, 100.0, 0.0), 100.0, &mut next);
        assert_eq!(next.sonar_mm[12], 5_000);
        // A side echo is not remembered: only what lies ahead is.
        let mut echoes = Echoes::default();
        echoes.hear(&pose(0.0, 0.0, 0.0), 0.0, &mut scan(0, &[(6, 400)]));
        let mut on = scan(100, &[]);
        echoes.hear(&pose(0.0, 100.0, 0.0), 100.0, &mut on);
        assert!(on.sonar_mm.iter().all(|&r| r == 5_000), "{:?}", on.sonar_mm);
        // Lost 100 mm on, remembered; a metre after that, forgotten.
        let mut echoes = Echoes::default();
        echoes.hear(&pose(0.0, 0.0, 0.0), 0.0, &mut scan(0, &[(12, 900)]));
        let mut lost = scan(300, &[]);
        echoes.hear(&pose(0.0, 100.0, 0.0), 100.0, &mut lost);
        assert!(lost.sonar_mm[12] < 900, "{:?}", lost.sonar_mm);
        let mut far = scan(3_000, &[]);
        echoes.hear(&pose(0.0, 600.0, 0.0), 1_150.0, &mut far);
        assert!(far.sonar_mm.iter().all(|&r| r == 5_000));
    }

    #[test]
    fn in_the_simulator_a_corridors_corner_lost_between_two_beams_is_remembered() {
        // r25 of the Campus's first minutes (40 robots, seed 1), driving
        // west at 300 mm/s into the corridor between blocks b5 and b11
        // at 126.5 s and 127.5 s of the run, its true poses; b11's
        // south-east corner stands at (82 600, 14 800), 429 mm from the
        // ring at the second.
        let scan_at =
            |time_ms, x, y, heading| campus_scan("r25", time_ms, Pose::new(x, y, heading));
        let (first, second) = (
            Pose::new(83_677.3, 14_541.6, 79.81),
            Pose::new(83_381.1, 14_586.6, 81.39),
        );
        let mut heard = scan_at(126_500, first.at.x, first.at.y, 79.81);
        assert!(heard.sonar_mm[12] < 800, "{:?}", heard.sonar_mm);
        let mut echoes = Echoes::default();
        echoes.hear(&first, 0.0, &mut heard);
        let mut now = scan_at(127_500, second.at.x, second.at.y, 81.39);
        let ahead = |s: &Scan| (9..=15).map(|i| s.sonar_mm[i]).min().unwrap_or(0);
        assert!(
            ahead(&now) > 1_000,
            "the sonars hear it: {:?}",
            now.sonar_mm
        );
        echoes.hear(&second, (second.at - first.at).norm(), &mut now);
        assert!(
            (330..=440).contains(&ahead(&now)),
            "remembered: {:?}",
            now.sonar_mm
        );
    }
}
