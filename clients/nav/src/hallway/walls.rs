//! The walls a hallway robot steers by: the side sonars' ranges, read
//! square on, fitted over the last metre driven to tell how far off the
//! middle the robot is and at what angle it moves (§5.4.1).

use super::{bearing, sonar_add, sonar_towards};
use crate::drive::{FORWARD, ROBOT_CLEARANCE_MM, ROBOT_RADIUS_MM, SPACING};
use rome_maps::geometry::normalize_deg;

/// Where the robot is between two hallway walls, from the side sonars 6
/// and 18: how far off the middle, and (over the last metre) at what angle
/// it is moving relative to the walls.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Walls {
    /// (distance driven, offset left of the middle, hallway width, mm;
    /// the odometry's heading, degrees).
    pub(super) samples: std::collections::VecDeque<(f64, f64, f64, f64)>,
    /// Where to keep across the hallway: offset left of the middle, mm
    /// (negative: right of it).
    pub(super) lane_mm: f64,
    /// The Corner state's stop-and-go turn in progress, degrees per second.
    pub(super) spin: Option<f64>,
    /// Steer to the lane briskly: making way for an oncoming robot, the
    /// robot must be across before the two meet (a gentle 10° per metre
    /// off the lane takes some 14 s to move half a metre).
    pub(super) brisk: bool,
    /// Between wall sightings, while steering briskly, carry where the
    /// walls were on by odometry ([`NavConfig::coast_on_odometry`]).
    pub(super) coasting: bool,
    /// Carry where the walls were on at every scan, and turn back before
    /// the robot leaves the lane between them ([`Walls::back_within`];
    /// [`NavConfig::keep_within_walls`](crate::drive::NavConfig)).
    pub(super) guarding: bool,
    /// Where the walls were at the last fit of fresh samples, carried on
    /// by odometry while no new sample comes.
    coast: Option<Coast>,
    /// The walls' axis and the hallway's half-width at the last fit, while
    /// guarding: what one wall in view needs to tell where the robot is
    /// once [`Walls::carry`] has let the walls go ([`Walls::reanchor`]).
    kept: Option<Kept>,
}

/// The last fit's axis and half-width, kept on after the walls carried on
/// by odometry are let go.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Kept {
    /// The walls' axis by the odometry's heading, degrees
    /// counter-clockwise.
    axis_deg: f64,
    /// Half the hallway's width, wall to wall, mm.
    half_mm: f64,
    /// The distance driven at the fit, mm.
    fit_mm: f64,
}

/// The robot's place between the walls at the last fit, and how it has
/// moved since by odometry.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Coast {
    /// The walls' axis by the odometry's heading, degrees
    /// counter-clockwise.
    axis_deg: f64,
    /// The distance driven at the fit, mm.
    fit_mm: f64,
    /// The distance driven when the offset was last carried on, mm.
    along_mm: f64,
    /// The offset left of the middle, carried on, mm.
    offset_mm: f64,
    /// Half the hallway's width, wall to wall, at the fit, mm.
    half_mm: f64,
    /// The angle to the axis when the offset was last carried on,
    /// degrees counter-clockwise.
    angle_deg: f64,
}

/// Driving this far is enough to tell the angle to the walls, mm.
const WALL_WINDOW_MM: f64 = 1_000.0;

/// How far past the last sample the walls are carried on by odometry
/// when coasting, mm: across a junction's turning space (2.4 m) and a
/// door's recess.
const COAST_MM: f64 = 3_000.0;

/// How far the robot may turn from the walls' axis before the walls are
/// no longer carried on, degrees: further than the brisk swerve (30°), not
/// as far as a corner.
const COAST_TURNED_DEG: f64 = 45.0;

/// How far ahead [`Walls::back_within`] looks along the heading, mm.
const WITHIN_AHEAD_MM: f64 = 500.0;

/// What [`Walls::back_within`] leaves between the robot's side and where
/// a wall was, mm.
const WITHIN_MARGIN_MM: f64 = 100.0;

/// The angle to the axis [`Walls::back_within`] turns to, degrees: under
/// Check-Goal's 20°, so it is not turned straight back.
const WITHIN_BACK_DEG: f64 = 15.0;

/// How far the sonars from ahead round to the side [`Walls::back_within`]
/// turns to must read, mm from the skin.
const WITHIN_CLEAR_MM: f64 = 1_000.0;

/// How far past the last fit [`Walls::reanchor`] still goes by its axis
/// and width, mm: past a junction's mouth, with a robot met in it.
const KEPT_MM: f64 = 6_000.0;

/// A side reading shorter than this is a wall in view, mm.
const WALL_IN_VIEW_MM: f64 = 3_500.0;

/// How far the sonar read for a side wall may turn from the side sonar
/// (6 or 18), in sonar steps of 15°: enough for the steepest swerve the
/// hallway steers (30°).
const SQUARE_ON_STEPS: i64 = 2;

/// How far the wall at `side_deg` of the axis (90: left, -90: right)
/// stands from the robot's skin, mm, read by the sonar most nearly square
/// to it. A wall returns an echo only within 20° of square (the specular
/// model, as Polaroid sonar), so at a slant of 30° the side sonar hears
/// nothing and the walls are lost just when the robot steers over to keep
/// right; the sonar 30° round still hears the wall, from the foot of the
/// perpendicular, so its range is its own distance from the wall. Sonars
/// are 15° apart: the one chosen sits on the ring within 7.5° of square,
/// `R·(1 − cos)` (at most 3 mm) farther from the wall than the skin at
/// square. Driving along the axis (within 7.5°), or turned further than
/// the swerve, it is sonar 6 or 18 itself, read as it is.
fn square_on(sonar: &[u32], side_deg: f64, rel_deg: f64) -> f64 {
    let normal = normalize_deg(side_deg - rel_deg);
    let side = sonar_towards(side_deg);
    let i = sonar_towards(normal);
    let steps = (normalize_deg(bearing(i) - bearing(side)) / SPACING).round() as i64;
    // A side sonar that hears its wall is read as before; the one square
    // to the wall only stands in for it when it hears nothing.
    let heard = f64::from(sonar[side]) < WALL_IN_VIEW_MM;
    if heard || i == side || steps.abs() > SQUARE_ON_STEPS {
        return f64::from(sonar[side]);
    }
    let off = normalize_deg(normal - bearing(i)).to_radians();
    f64::from(sonar[i]) - ROBOT_RADIUS_MM * (1.0 - off.cos())
}

/// The left and the right wall's distances from the skin, each read
/// square on (see `square_on`), mm.
fn side_walls(sonar: &[u32], rel_deg: f64) -> (f64, f64) {
    (
        square_on(sonar, 90.0, rel_deg),
        square_on(sonar, -90.0, rel_deg),
    )
}

impl Walls {
    /// Adds a scan; returns the steering correction (degrees
    /// counter-clockwise) that brings the robot back to the middle, when
    /// both walls have been in view long enough to tell. `rel_deg` is the
    /// heading relative to the hallway's axis (counter-clockwise) when the
    /// walls are to be read square on (see `square_on`); 0 reads sonars 6
    /// and 18 as they are. `heading_deg` is the odometry's heading
    /// (counter-clockwise), by which the walls are carried on between
    /// sightings when coasting and steering briskly.
    pub fn steer(
        &mut self,
        sonar: &[u32],
        rel_deg: f64,
        along_mm: f64,
        heading_deg: f64,
    ) -> Option<f64> {
        let (left, right) = side_walls(sonar, rel_deg);
        let width = left + right;
        while self
            .samples
            .front()
            .is_some_and(|s| along_mm - s.0 > WALL_WINDOW_MM || s.0 > along_mm)
        {
            self.samples.pop_front();
        }
        // A door recess or a side corridor changes the width: not a wall.
        let steady =
            self.samples.is_empty() || self.samples.iter().all(|s| (s.2 - width).abs() < 250.0);
        if left < WALL_IN_VIEW_MM && right < WALL_IN_VIEW_MM && steady {
            self.samples
                .push_back((along_mm, (right - left) / 2.0, width, heading_deg));
            let fit = self.angle_and_offset();
            let half_mm = width / 2.0 + ROBOT_RADIUS_MM;
            // The walls' axis, only when something carries them on.
            let axis_deg = fit
                .filter(|_| self.coasting || self.guarding)
                .map(|(angle_deg, _)| self.mean_heading(heading_deg) - angle_deg);
            if let Some(axis_deg) = axis_deg.filter(|_| self.guarding) {
                self.kept = Some(Kept {
                    axis_deg,
                    half_mm,
                    fit_mm: along_mm,
                });
            }
            self.coast = fit
                .zip(axis_deg)
                .map(|((angle_deg, offset_mm), axis_deg)| Coast {
                    axis_deg,
                    fit_mm: along_mm,
                    along_mm,
                    offset_mm,
                    half_mm,
                    angle_deg,
                });
            return fit.map(|(angle, offset)| self.wanted(offset) - angle);
        }
        if !(self.coasting && self.brisk) {
            return self.fit();
        }
        // Beyond the thesis: no new sample (a side opened, or a recess),
        // and the last ones describe where the robot was, not where it is.
        // Steered by them, it turns on at the same rate for as long as
        // they last: keeping right into a junction, a robot swung 45° off
        // the axis and into the step at a narrower corridor's mouth. The
        // walls are carried on by the odometry's turn and travel instead,
        // across a junction and no further. Only while swerving briskly:
        // carried on at every opening, on the way to a corner too, robots
        // stood still more often, and one lost its way and its task
        // (docs/traffic.md, "Walls carried on by odometry").
        let (offset, angle) = self.carry(along_mm, heading_deg)?;
        Some(self.wanted(offset) - angle)
    }

    /// Carries where the walls were on by the odometry's travel and turn
    /// since the last call: the offset left of the middle (mm) and the
    /// angle to the axis (degrees counter-clockwise), while the last fit
    /// is near enough behind and the robot has not turned into another
    /// corridor.
    pub(super) fn carry(&mut self, along_mm: f64, heading_deg: f64) -> Option<(f64, f64)> {
        let c = self.coast.as_mut()?;
        if along_mm - c.fit_mm > COAST_MM || along_mm < c.fit_mm {
            self.coast = None;
            return None;
        }
        let angle = normalize_deg(heading_deg - c.axis_deg);
        if angle.abs() > COAST_TURNED_DEG {
            // Turned into another corridor: these walls say nothing of it.
            self.coast = None;
            return None;
        }
        c.offset_mm += (along_mm - c.along_mm) * angle.to_radians().sin();
        c.along_mm = along_mm;
        c.angle_deg = angle;
        Some((c.offset_mm, angle))
    }

    /// Beyond the thesis: where the walls carried on were let go (the
    /// robot turned further than [`COAST_TURNED_DEG`] off their axis, or
    /// drove past [`COAST_MM`]) and only one wall is in view, takes up
    /// where the robot is from that wall, by the axis and half-width of
    /// the last fit, for [`Walls::back_within`]. A robot that met another
    /// in a junction's mouth swung 63° off the axis, came back along the
    /// line of the mouth's wall with the mouth on one side and the other
    /// robot on the other, never again had both walls in view, and
    /// touched the mouth's far corner (docs/traffic.md, "The three
    /// options together"). A robot beside it, read as that side's wall,
    /// makes it seem nearer that side than it is; a turn is then away
    /// from that robot, and only onto sonars that read a metre clear.
    pub(super) fn reanchor(&mut self, sonar: &[u32], along_mm: f64, heading_deg: f64) {
        let Some(k) = self.kept else { return };
        if self.coast.is_some() {
            return;
        }
        if along_mm - k.fit_mm > KEPT_MM || along_mm < k.fit_mm {
            self.kept = None;
            return;
        }
        let angle = normalize_deg(heading_deg - k.axis_deg);
        if angle.abs() > COAST_TURNED_DEG {
            return;
        }
        let (left, right) = side_walls(sonar, angle);
        let offset_mm = match (left < WALL_IN_VIEW_MM, right < WALL_IN_VIEW_MM) {
            (true, false) => k.half_mm - (left + ROBOT_RADIUS_MM),
            (false, true) => right + ROBOT_RADIUS_MM - k.half_mm,
            _ => return,
        };
        self.coast = Some(Coast {
            axis_deg: k.axis_deg,
            fit_mm: along_mm,
            along_mm,
            offset_mm,
            half_mm: k.half_mm,
            angle_deg: angle,
        });
    }

    /// Beyond the thesis: the turn (degrees counter-clockwise) that keeps
    /// the robot within where the walls were, when a side has opened (a
    /// junction, a door's recess) and half a metre on along its heading
    /// the robot would stand nearer than [`WITHIN_MARGIN_MM`] to the line
    /// of a wall. A robot that swerved round one standing in a crossroads
    /// came out of it with its side past the line of the corridor's wall,
    /// heading on at the corner (docs/traffic.md, "Back within the walls
    /// after a crossroads").
    pub(super) fn back_within(&self, sonar: &[u32]) -> Option<f64> {
        let c = self.coast.as_ref()?;
        let both = [90.0, -90.0]
            .into_iter()
            .all(|side| f64::from(sonar[sonar_towards(side)]) < WALL_IN_VIEW_MM);
        if both {
            return None;
        }
        let angle = c.angle_deg;
        let ahead = c.offset_mm + WITHIN_AHEAD_MM * angle.to_radians().sin();
        let limit = c.half_mm - ROBOT_RADIUS_MM - WITHIN_MARGIN_MM;
        if ahead.abs() <= limit {
            return None;
        }
        let turn = (-ahead.signum() * WITHIN_BACK_DEG - angle).clamp(-30.0, 30.0);
        // Towards the middle stands what the robot swerved round, or a
        // robot passing: turned onto it, a robot stood blocked beside it
        // and was touched. Then the robot goes on as before.
        let towards = |k: i64| sonar_add(FORWARD, k * turn.signum() as i64);
        let clear = (0..=6).all(|k| f64::from(sonar[towards(k)]) >= WITHIN_CLEAR_MM);
        (turn.abs() >= 5.0 && clear).then_some(turn)
    }

    /// How far right of the middle a robot keeps to let another pass: up
    /// to 0.6 m, leaving at least 0.3 m between its side and the wall.
    pub fn keep_right_mm(&self) -> f64 {
        // Side sonars read from the robot's skin: the half-width from the
        // middle is half their sum plus the radius.
        let half = self.width().map_or(1_500.0, |w| w / 2.0 + 380.0);
        (half - ROBOT_CLEARANCE_MM).clamp(0.0, 600.0)
    }

    /// The hallway's width between the side sonars (the robot's own width
    /// left out), mm, if the walls are in view.
    pub fn width(&self) -> Option<f64> {
        let n = self.samples.len();
        (n >= 4).then(|| self.samples.iter().map(|s| s.2).sum::<f64>() / n as f64)
    }

    /// The steering correction from the samples so far, if there are
    /// enough.
    pub fn fit(&self) -> Option<f64> {
        let (angle, offset) = self.angle_and_offset()?;
        Some(self.wanted(offset) - angle)
    }

    /// The angle the robot moves at relative to the walls (degrees
    /// counter-clockwise) and its offset left of the middle at the last
    /// sample (mm), if there are enough samples.
    fn angle_and_offset(&self) -> Option<(f64, f64)> {
        let n = self.samples.len() as f64;
        let (s0, s1) = (self.samples.front()?.0, self.samples.back()?.0);
        if self.samples.len() < 4 || s1 - s0 < WALL_WINDOW_MM / 2.0 {
            return None;
        }
        let ms = self.samples.iter().map(|s| s.0).sum::<f64>() / n;
        let me = self.samples.iter().map(|s| s.1).sum::<f64>() / n;
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for s in &self.samples {
            sxy += (s.0 - ms) * (s.1 - me);
            sxx += (s.0 - ms) * (s.0 - ms);
        }
        // Moving left (counter-clockwise of the walls) raises the offset.
        let angle = (sxy / sxx).atan().to_degrees();
        Some((angle, self.samples.back()?.1))
    }

    /// The samples' mean heading, degrees counter-clockwise, unwrapped
    /// around `heading_deg`. The fit's angle is the robot's over the
    /// samples, so the walls' axis lies that far from it.
    fn mean_heading(&self, heading_deg: f64) -> f64 {
        let n = self.samples.len() as f64;
        (self.samples.iter())
            .map(|s| heading_deg + normalize_deg(s.3 - heading_deg))
            .sum::<f64>()
            / n
    }

    /// The angle to the walls to steer to from `offset_mm` left of the
    /// middle, degrees counter-clockwise.
    fn wanted(&self, offset_mm: f64) -> f64 {
        let off = offset_mm - self.lane_mm;
        if self.brisk {
            (-off / 1_000.0 * 50.0).clamp(-30.0, 30.0)
        } else {
            (-off / 1_000.0 * 10.0).clamp(-12.0, 12.0)
        }
    }
}
