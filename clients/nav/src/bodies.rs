//! Robot-sized bodies seen by the sonar ring: which echoes are one body,
//! and where its middle lies.
//!
//! A sonar hears a disc at the range of the nearest point of its beam on
//! it (`rome-sim`'s sonar model, and the ring's as built): the disc's
//! nearest point when its middle lies inside the beam, else the point
//! where the beam's nearer edge first meets it. So one robot standing
//! between two beams is heard by both, at the same range. Taken each for
//! its own robot on its beam's axis, those two echoes make two robots
//! some 0.3 m apart, one either side of the one that is there, and no
//! lane clears both (docs/traffic.md, "Waiting for one that stands in the
//! way").
//!
//! Here neighbouring echoes that one robot-sized disc explains, within
//! the sonars' noise, are taken for that one disc, placed where it
//! explains them. An echo no neighbour shares stays a disc on its beam's
//! axis, one radius behind the echo, as before.

use crate::drive::ROBOT_RADIUS_MM;
use rome_schema::robot::body::{sonar_bearing_deg as bearing, SONAR_HALF_BEAM_DEG};

/// A robot-sized disc heard ahead: its middle, from the robot's middle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// How far its middle is from the robot's, mm.
    pub distance_mm: f64,
    /// Its middle's bearing from the heading, degrees counter-clockwise.
    pub bearing_deg: f64,
    /// The nearest echo that made it: (sonar, range from the skin, mm).
    pub nearest: (usize, f64),
}

/// How far apart the bearings tried for one disc's middle are, degrees.
const FIT_STEP_DEG: f64 = 0.25;

/// Largest difference between an echo and what the fitted disc would
/// return, mm, at `range_mm`: three standard deviations of the difference
/// of two readings, each off by 1 % plus 10 mm (`rome-sim`'s noise, near
/// a real ring's).
fn tolerance_mm(range_mm: f64) -> f64 {
    3.0 * std::f64::consts::SQRT_2 * (10.0 + 0.01 * range_mm)
}

/// A unit vector at `deg` counter-clockwise from the heading.
fn unit(deg: f64) -> (f64, f64) {
    let r = deg.to_radians();
    (r.cos(), r.sin())
}

/// What sonar `i` reads, mm from the skin, off a robot-sized disc whose
/// middle is at `(x, y)` mm (x ahead, y left of the robot's middle), if
/// its beam meets the disc.
pub fn echo(i: usize, (x, y): (f64, f64)) -> Option<f64> {
    let (ax, ay) = unit(bearing(i));
    let (ex, ey) = (x - ROBOT_RADIUS_MM * ax, y - ROBOT_RADIUS_MM * ay);
    let d = ex.hypot(ey);
    if d <= ROBOT_RADIUS_MM {
        return Some(0.0);
    }
    let off = (ex * ay - ey * ax).atan2(ex * ax + ey * ay).to_degrees();
    if off.abs() <= SONAR_HALF_BEAM_DEG {
        return Some(d - ROBOT_RADIUS_MM);
    }
    // Its middle lies outside the beam: the beam's nearer edge meets it.
    let (gx, gy) = unit(bearing(i) - SONAR_HALF_BEAM_DEG * off.signum());
    let along = ex * gx + ey * gy;
    let miss2 = d * d - along * along;
    let r2 = ROBOT_RADIUS_MM * ROBOT_RADIUS_MM;
    (along > 0.0 && miss2 <= r2).then(|| along - (r2 - miss2).sqrt())
}

/// Where along the ray from the robot's middle at `psi` degrees a disc's
/// middle lies for sonar `n` to read `rn` mm off it: its middle inside
/// the beam, or the beam's either edge meeting it at that range.
fn along_ray(n: usize, rn: f64, psi: f64) -> impl Iterator<Item = (f64, f64)> {
    let (ux, uy) = unit(psi);
    let (ax, ay) = unit(bearing(n));
    let s = (ROBOT_RADIUS_MM * ax, ROBOT_RADIUS_MM * ay);
    // Where the middle is `radius` from the point `p`, beyond it.
    let beyond = move |(px, py): (f64, f64), radius: f64| {
        let up = ux * px + uy * py;
        let disc = up * up - (px * px + py * py) + radius * radius;
        (disc >= 0.0).then(|| up + disc.sqrt())
    };
    let inside = beyond(s, rn + ROBOT_RADIUS_MM);
    let edges = [-1.0, 1.0].map(|side| {
        let (gx, gy) = unit(bearing(n) + side * SONAR_HALF_BEAM_DEG);
        beyond((s.0 + rn * gx, s.1 + rn * gy), ROBOT_RADIUS_MM)
    });
    [inside, edges[0], edges[1]]
        .into_iter()
        .flatten()
        .map(move |d| (d * ux, d * uy))
        .filter(move |&c| echo(n, c).is_some_and(|e| (e - rn).abs() < 1.0))
}

/// The one disc that explains every echo in `run` (sonar, range mm), if
/// there is one, and contradicts no other sonar from `first` to `last`
/// (it would not be heard nearer than they read): of the middles that
/// do, the one that explains the echoes best.
fn fit(sonar: &[u32], first: usize, last: usize, run: &[(usize, f64)]) -> Option<Body> {
    let &(n, rn) = run.iter().min_by(|a, b| a.1.total_cmp(&b.1))?;
    let (lo, hi) = (bearing(run[0].0), bearing(run[run.len() - 1].0));
    let steps = ((hi - lo + 4.0 * SONAR_HALF_BEAM_DEG) / FIT_STEP_DEG).round() as i32;
    let mut best: Option<(f64, (f64, f64))> = None;
    for k in 0..=steps {
        let psi = lo - 2.0 * SONAR_HALF_BEAM_DEG + f64::from(k) * FIT_STEP_DEG;
        for c in along_ray(n, rn, psi) {
            let worst = (first..=last).try_fold(0.0_f64, |w, i| {
                let r = f64::from(sonar[i]);
                let heard = echo(i, c);
                if run.iter().any(|&(j, _)| j == i) {
                    let miss = (heard? - r).abs();
                    (miss <= tolerance_mm(r)).then_some(w.max(miss))
                } else {
                    // Another sonar: something else may be nearer, but
                    // the disc is not nearer than it reads.
                    heard.is_none_or(|h| h >= r - tolerance_mm(r)).then_some(w)
                }
            });
            if let Some(w) = worst {
                if best.is_none_or(|(b, _)| w < b) {
                    best = Some((w, c));
                }
            }
        }
    }
    best.map(|(_, (x, y))| Body {
        distance_mm: x.hypot(y),
        bearing_deg: y.atan2(x).to_degrees(),
        nearest: (n, rn),
    })
}

/// The bodies sonars `first..=last` hear nearer than `within_mm` (from
/// the skin), in the order of their sonars. Neighbouring echoes go into one
/// body while one disc explains them all; an echo alone is a disc on its
/// beam's axis, one radius behind the echo.
pub fn bodies(sonar: &[u32], first: usize, last: usize, within_mm: f64) -> Vec<Body> {
    let alone = |i: usize, r: f64| Body {
        distance_mm: ROBOT_RADIUS_MM + r + ROBOT_RADIUS_MM,
        bearing_deg: bearing(i),
        nearest: (i, r),
    };
    let mut out = Vec::new();
    // The echoes of the body being gathered, and the disc fitted to them
    // when there are two or more (kept, so each run is fitted once).
    let mut run: Vec<(usize, f64)> = Vec::new();
    let mut fitted: Option<Body> = None;
    let close = |run: &mut Vec<(usize, f64)>, fitted: &mut Option<Body>, out: &mut Vec<Body>| {
        match run.as_slice() {
            [] => {}
            [(i, r)] => out.push(alone(*i, *r)),
            _ => out.extend(fitted.take()),
        }
        run.clear();
    };
    for i in first..=last {
        let r = f64::from(sonar[i]);
        if r >= within_mm {
            close(&mut run, &mut fitted, &mut out);
            continue;
        }
        run.push((i, r));
        if run.len() > 1 {
            match fit(sonar, first, last, &run) {
                Some(body) => fitted = Some(body),
                None => {
                    run.pop();
                    close(&mut run, &mut fitted, &mut out);
                    run.push((i, r));
                }
            }
        }
    }
    close(&mut run, &mut fitted, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ring's readings off discs at `(x, y)`, nothing else in range.
    fn ring(discs: &[(f64, f64)]) -> Vec<u32> {
        (0..24)
            .map(|i| {
                discs
                    .iter()
                    .filter_map(|&c| echo(i, c))
                    .fold(10_000.0_f64, f64::min)
                    .round() as u32
            })
            .collect()
    }

    #[test]
    fn one_robot_between_two_beams_is_one_body_where_it_stands() {
        // 1.2 m ahead, 22.5° left: on the line between sonars 13 and 14,
        // both of which hear it at the same range.
        let (x, y) = (
            1_200.0 * 22.5_f64.to_radians().cos(),
            1_200.0 * 22.5_f64.to_radians().sin(),
        );
        let s = ring(&[(x, y)]);
        assert_eq!(s[13], s[14], "{s:?}");
        let b = bodies(&s, 9, 15, 3_000.0);
        assert_eq!(b.len(), 1, "{b:?}");
        let (bx, by) = (
            b[0].distance_mm * b[0].bearing_deg.to_radians().cos(),
            b[0].distance_mm * b[0].bearing_deg.to_radians().sin(),
        );
        assert!(
            (bx - x).hypot(by - y) < 30.0,
            "({bx:.0}, {by:.0}) for ({x:.0}, {y:.0})"
        );
    }

    #[test]
    fn two_robots_side_by_side_stay_two_bodies() {
        // Two robots abreast 1.6 m ahead, their middles 0.9 m apart: no one
        // disc explains the five beams that hear them.
        let s = ring(&[(1_600.0, 450.0), (1_600.0, -450.0)]);
        let b = bodies(&s, 9, 15, 3_000.0);
        assert!(b.len() >= 2, "{b:?} from {s:?}");
        let sides: Vec<f64> = b.iter().map(|b| b.bearing_deg.signum()).collect();
        assert!(sides.contains(&1.0) && sides.contains(&-1.0), "{b:?}");
    }

    #[test]
    fn an_echo_alone_is_a_disc_on_its_beam() {
        let mut s = vec![10_000u32; 24];
        s[12] = 900;
        let b = bodies(&s, 9, 15, 3_000.0);
        assert_eq!(
            b,
            vec![Body {
                distance_mm: 2.0 * ROBOT_RADIUS_MM + 900.0,
                bearing_deg: 0.0,
                nearest: (12, 900.0)
            }]
        );
    }
}
