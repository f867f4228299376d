//! The glass the map has, heard where the sensors hear nothing.
//!
//! Glass returns no echo to a sonar (its reflection is specular and goes
//! elsewhere) and is not seen by the infrared detectors: the thesis'
//! robot ran into EB3's glass door by the ACS laboratory (Table 6.1,
//! note a). Among robots, one that had spun away from another in that
//! turning space drove on into the glass, its sonars reading nothing
//! ahead, and so did one that drifted to the glass side of the turning
//! space.
//!
//! With [`NavConfig::hear_glass`](crate::drive::NavConfig) the Navigator
//! adds to each scan of an Enter-Corner, Leave-Corner or Dead-Reckoning
//! goal the panes the Planner handed over with it (`Glass`), placed by
//! odometry from where the goal began. They sound as a wall would:
//! - a sonar whose axis is within the echo angle of a pane's normal reads
//!   the range to it, where the echo's point lies on the pane;
//! - an infrared detector that meets a pane within its reach fires.
//!
//! A reading nearer than the glass (a robot, a person) is kept.

use super::{Goal, GoalType, Navigator, Pose, Var};
use rome_maps::geometry::{direction, hit, Point, Vector};
use rome_schema::robot::body::{
    ir_bearing_deg, sonar_bearing_deg, IR_RANGE_MM, IR_SENSORS, ROBOT_RADIUS_MM,
    SONAR_HALF_BEAM_DEG, SONAR_MAX_INCIDENCE_DEG, SONAR_MIN_MM,
};
use rome_schema::robot::Scan;

/// The most panes a goal takes: anyone may write the blackboard.
const MOST_PANES: usize = 32;
/// How far from a goal's end a pane may be, mm.
const FARTHEST_MM: i64 = 100_000;

/// A pane of glass in the Navigator's odometry frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pane {
    a: Point,
    /// Unit vector from `a` to the other end.
    dir: Vector,
    len: f64,
}

impl Pane {
    /// The pane `[along₁, left₁, along₂, left₂]` (mm from the end of
    /// `goal`, along its direction and to its left) of a goal begun at
    /// `start`; `None` for one of no length.
    pub fn of(start: &Pose, goal: &Goal, mm: [i64; 4]) -> Option<Pane> {
        let (axis, left) = (
            direction(goal.direction_deg),
            direction(goal.direction_deg + 90.0),
        );
        let end = start.at + axis * goal.distance as f64;
        let at = |along: i64, side: i64| end + axis * along as f64 + left * side as f64;
        let (a, b) = (at(mm[0], mm[1]), at(mm[2], mm[3]));
        let len = (b - a).norm();
        (len >= 1.0).then(|| Pane {
            a,
            dir: (b - a) / len,
            len,
        })
    }

    /// The pane's unit normal on the side of `s`, and how far `s` is from
    /// its line.
    fn facing(&self, s: Point) -> (Vector, f64) {
        let n = Vector::new(-self.dir.y, self.dir.x);
        let side = (s - self.a).dot(&n);
        (if side >= 0.0 { n } else { -n }, side.abs())
    }

    /// The echo a sonar at `s` looking along `axis` hears from the pane:
    /// the range to the beam's ray nearest the normal, if that ray meets
    /// the pane.
    fn echo(&self, s: Point, axis: Vector) -> Option<f64> {
        let (n, dist) = self.facing(s);
        let inc = axis.dot(&-n).clamp(-1.0, 1.0).acos();
        if dist <= 0.0 || inc > SONAR_MAX_INCIDENCE_DEG.to_radians() {
            return None;
        }
        let off = (inc - SONAR_HALF_BEAM_DEG.to_radians()).max(0.0);
        let range = dist / off.cos();
        // The ray `off` from the normal, turned towards the axis.
        let turn = if (-n).perp(&axis) >= 0.0 { off } else { -off };
        let (c, sn) = (turn.cos(), turn.sin());
        let ray = Vector::new(-n.x * c + n.y * sn, -n.x * sn - n.y * c);
        let u = (s + ray * range - self.a).dot(&self.dir);
        (0.0..=self.len).contains(&u).then_some(range)
    }

    /// How far along `r` a ray from `s` meets the pane, if ahead.
    fn hit(&self, s: Point, r: Vector) -> Option<f64> {
        hit(s, r, self.a, self.dir, self.len).map(|(t, _)| t)
    }
}

/// Adds `panes` to `scan`, taken at `pose`: a sonar reading or an infrared
/// detector is changed only where the glass is nearer.
pub fn hear(panes: &[Pane], pose: &Pose, scan: &mut Scan) {
    if panes.is_empty() {
        return;
    }
    let heading = pose.heading.deg();
    for (i, reading) in scan.sonar_mm.iter_mut().enumerate() {
        let axis = direction(heading + sonar_bearing_deg(i));
        let s = pose.at + axis * ROBOT_RADIUS_MM;
        for pane in panes {
            if let Some(range) = pane.echo(s, axis) {
                *reading = (*reading).min(range.max(SONAR_MIN_MM).round() as u32);
            }
        }
    }
    for i in 0..IR_SENSORS.min(scan.ir.len()) {
        let b = heading + ir_bearing_deg(i);
        let s = pose.at + direction(b) * ROBOT_RADIUS_MM;
        // The detector's axis and 10° either side, as it looks.
        let seen = [-10.0, 0.0, 10.0].iter().any(|spread| {
            let r = direction(b + spread);
            panes
                .iter()
                .any(|p| p.hit(s, r).is_some_and(|t| t <= IR_RANGE_MM))
        });
        if seen {
            scan.ir[i] = 1;
        }
    }
}

impl Navigator {
    /// The panes the Planner handed over with `goal`, begun at `start`:
    /// none unless [`NavConfig::hear_glass`](crate::drive::NavConfig), for
    /// other goals than E, C and D, or when what is there does not decode
    /// or is out of bounds.
    pub(super) async fn glass(&self, goal: &Goal, start: &Pose) -> Vec<Pane> {
        let kind = matches!(goal.goal_type, GoalType::E | GoalType::C | GoalType::D);
        if !self.cfg.hear_glass || !kind {
            return Vec::new();
        }
        let panes: Vec<[i64; 4]> = self.board.get(Var::Glass).await.ok().unwrap_or_default();
        let sane =
            panes.len() <= MOST_PANES && panes.iter().flatten().all(|v| v.abs() <= FARTHEST_MM);
        if !sane {
            tracing::warn!("navigator: `Glass` out of bounds; going by the sensors alone");
            return Vec::new();
        }
        panes
            .into_iter()
            .filter_map(|mm| Pane::of(start, goal, mm))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    fn scan() -> Scan {
        Scan {
            robot: "r1".into(),
            seq: 1,
            time_ms: 0,
            sonar_mm: vec![10_000; 24],
            ir: vec![0; 24],
        }
    }

    /// An Enter-Corner goal east (heading 270) from the origin for 6 m,
    /// with a pane 3.66 m wide across the way 1.8 m beyond its end: at
    /// x = 7.8 m, y from −1.83 to 1.83 m.
    fn pane() -> Vec<Pane> {
        let goal = Goal {
            goal_type: GoalType::E,
            distance: 6_000,
            direction_deg: 270.0,
        };
        let start = Pose::new(0.0, 0.0, 270.0);
        vec![Pane::of(&start, &goal, [1_800, -1_830, 1_800, 1_830]).unwrap()]
    }

    #[test]
    fn facing_the_glass_the_front_sonars_hear_it_and_a_nearer_echo_is_kept() {
        let mut s = scan();
        s.sonar_mm[13] = 300;
        hear(&pane(), &Pose::new(6_000.0, 0.0, 270.0), &mut s);
        assert_eq!(s.sonar_mm[13], 300, "the nearer echo is kept");
        // Sonar 12 looks ahead: 1.8 m less the body's radius.
        assert_eq!(s.sonar_mm[12], 1_420);
        // 15° off the normal is within the beam and the echo angle: the
        // beam's edge ray 7.5° off returns.
        let d = 1_800.0 - ROBOT_RADIUS_MM * 15f64.to_radians().cos();
        let want = (d / 7.5f64.to_radians().cos()).round() as u32;
        assert_eq!(s.sonar_mm[11], want);
        // 30° off glances off; behind hears nothing.
        assert_eq!(s.sonar_mm[10], 10_000);
        assert_eq!(s.sonar_mm[0], 10_000);
        // Infrared reaches 760 mm: not yet.
        assert!(s.ir.iter().all(|&b| b == 0), "{:?}", s.ir);
    }

    #[test]
    fn close_to_the_glass_the_detectors_ahead_fire() {
        let mut s = scan();
        // 0.5 m from the glass, facing it 15° to the right of its normal.
        hear(&pane(), &Pose::new(7_300.0, 0.0, 255.0), &mut s);
        assert_eq!(s.sonar_mm[12], 150, "the shortest a sonar reads");
        assert_eq!(&s.ir[..4], &[1, 1, 1, 1]);
        assert_eq!(&s.ir[5..8], &[0, 0, 0]);
    }

    #[test]
    fn past_the_end_of_a_pane_nothing_is_heard_and_from_beyond_only_behind() {
        let mut s = scan();
        // Level with the glass but 2.5 m to its side: the echo's point
        // would lie off the pane.
        hear(&pane(), &Pose::new(6_000.0, 2_500.0, 270.0), &mut s);
        assert_eq!(s, scan());
        // Beyond it by odometry, facing away: sonar 0 looks back at it.
        hear(&pane(), &Pose::new(9_000.0, 0.0, 270.0), &mut s);
        assert_eq!(s.sonar_mm[12], 10_000);
        assert_eq!(s.sonar_mm[0], 820);
    }

    #[test]
    fn beside_the_glass_the_side_sonar_hears_it() {
        // Driving north 1 m west of the pane (x = 6.8 m), level with it:
        // sonar 6 looks right, east.
        let mut s = scan();
        hear(&pane(), &Pose::new(6_800.0, 0.0, 0.0), &mut s);
        assert_eq!(s.sonar_mm[6], 620);
    }
}
