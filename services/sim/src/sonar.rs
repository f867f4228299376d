//! Sonar and infrared.
//!
//! Sonar follows the usual specular model of Polaroid ranging (Kuc and
//! Siegel 1987; Leonard and Durrant-Whyte 1992): a flat wall returns an echo
//! only when its normal lies within the beam (here: within
//! [`SONAR_MAX_INCIDENCE_DEG`] of the axis, the beam being
//! [`SONAR_HALF_BEAM_DEG`] either side), at the range of the nearest point of
//! the beam on it; corners return from any direction inside the beam; glass
//! returns nothing; another robot returns from its nearest side. Whatever
//! echoes, the nearest echo not hidden behind another wall is the reading;
//! with no echo within the sensor's timeout the reading is the timeout.

use crate::rng::Rng;
use crate::scene::{Scene, Sense};
use crate::spec::{
    ir_bearing_deg, sonar_bearing_deg, Noise, IR_RANGE_MM, IR_SENSORS, ROBOT_RADIUS_MM, SONARS,
    SONAR_HALF_BEAM_DEG, SONAR_MAX_INCIDENCE_DEG, SONAR_MAX_MM, SONAR_MIN_MM,
};
use rome_maps::geometry::{direction, heading_to, normalize_deg, Point, UnitComplex, Vector};

/// Where a robot is, for the sensors of others.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// Centre, mm.
    pub at: Point,
}

/// Reusable buffers, so a scan allocates nothing.
#[derive(Debug, Default, Clone)]
pub struct Scratch {
    walls: Vec<u32>,
    corners: Vec<u32>,
    /// Candidate echoes: (sonar, range, wall or usize::MAX, point).
    echoes: Vec<(usize, f64, usize, Point)>,
}

/// Fires all sonars of a robot at `at` heading `heading`: ranges in mm.
#[allow(clippy::too_many_arguments)]
pub fn scan(
    scene: &Scene,
    open: &[bool],
    at: Point,
    heading: f64,
    others: &[Body],
    timeouts: &[u16; SONARS],
    noise: &Noise,
    rng: &mut Rng,
    scratch: &mut Scratch,
) -> [u16; SONARS] {
    let reach = SONAR_MAX_MM + ROBOT_RADIUS_MM;
    scene.walls_near(at, reach, &mut scratch.walls);
    scene.reflectors_near(at, reach, &mut scratch.corners);
    scratch.echoes.clear();
    // Each sensor's position on the ring and its axis.
    let mut sensors = [(at, Vector::zeros()); SONARS];
    for (i, s) in sensors.iter_mut().enumerate() {
        let d = direction(heading + sonar_bearing_deg(i));
        *s = (at + d * ROBOT_RADIUS_MM, d);
    }
    let forward = direction(heading);
    let left = Vector::new(-forward.y, forward.x);
    // The sonar nearest to a direction (a unit vector), by its bearing.
    let index_near = |v: Vector| {
        let rel = v.dot(&left).atan2(v.dot(&forward));
        (rel.to_degrees() / 15.0).round() as i64 + 12
    };
    let cos_beam = SONAR_HALF_BEAM_DEG.to_radians().cos();
    let cos_max = SONAR_MAX_INCIDENCE_DEG.to_radians().cos();
    // Flat surfaces.
    for &wi in &scratch.walls {
        let wi = wi as usize;
        if !scene.blocks(wi, Sense::Sound, open) {
            continue;
        }
        let w = &scene.walls[wi];
        // The robot must be on the side the wall faces.
        let side = (at - w.a).dot(&w.normal);
        let n = if side >= 0.0 { w.normal } else { -w.normal };
        if side.abs() > reach {
            continue;
        }
        // Too far along the wall's line to matter.
        let along = (at - w.a).dot(&w.dir);
        let beyond = if along < 0.0 {
            -along
        } else {
            (along - w.len).max(0.0)
        };
        if beyond * beyond + side * side > reach * reach {
            continue;
        }
        let look = -n;
        let centre = index_near(look);
        for k in centre - 2..=centre + 2 {
            let i = k.rem_euclid(SONARS as i64) as usize;
            let (s, axis) = sensors[i];
            let cos_inc = axis.dot(&look);
            if cos_inc < cos_max {
                continue;
            }
            let dist = (s - w.a).dot(&n);
            if dist <= 0.0 {
                continue;
            }
            let (range, p) = if cos_inc >= cos_beam {
                (dist, s - n * dist)
            } else {
                // The beam's edge ray, the one closest to the normal:
                // `look` turned by `off` towards the axis.
                let off = cos_inc.min(1.0).acos() - SONAR_HALF_BEAM_DEG.to_radians();
                let range = dist / off.cos();
                let turn = UnitComplex::new(off * look.perp(&axis).signum());
                (range, s + (turn * look) * range)
            };
            let u = (p - w.a).dot(&w.dir);
            if (0.0..=w.len).contains(&u) && range <= SONAR_MAX_MM {
                scratch.echoes.push((i, range, wi, p));
            }
        }
    }
    // Corners.
    for &ci in &scratch.corners {
        let c = scene.reflectors[ci as usize];
        let to = c - at;
        let dc = to.norm();
        if dc > reach || dc < 1.0 {
            continue;
        }
        let centre = index_near(to / dc);
        for k in centre - 1..=centre + 1 {
            let i = k.rem_euclid(SONARS as i64) as usize;
            let (s, axis) = sensors[i];
            let e = c - s;
            let range = e.norm();
            if range <= SONAR_MAX_MM && range > 1.0 && e.dot(&axis) >= cos_beam * range {
                scratch.echoes.push((i, range, usize::MAX, c));
            }
        }
    }
    // Other robots: the beam meets a robot's disc when the direction to its
    // centre is within half the beam plus the disc's angular radius.
    for other in others {
        let to = other.at - at;
        let dc2 = to.norm_squared();
        if dc2 < 1.0 || dc2 > (reach + ROBOT_RADIUS_MM).powi(2) {
            continue;
        }
        let dc = dc2.sqrt();
        let rel = to.dot(&left).atan2(to.dot(&forward)).to_degrees();
        let spread = (ROBOT_RADIUS_MM / dc).min(1.0).asin().to_degrees() + SONAR_HALF_BEAM_DEG;
        let lo = ((rel - spread) / 15.0).ceil() as i64;
        let hi = ((rel + spread) / 15.0).floor() as i64;
        for k in lo..=hi {
            let i = (k + 12).rem_euclid(SONARS as i64) as usize;
            let (s, _) = sensors[i];
            let e = other.at - s;
            let d = e.norm();
            let range = d - ROBOT_RADIUS_MM;
            if range > 0.0 && range <= SONAR_MAX_MM {
                scratch
                    .echoes
                    .push((i, range, usize::MAX - 1, s + e / d * range));
            }
        }
    }
    scratch
        .echoes
        .sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut out = [0u16; SONARS];
    let mut found = [false; SONARS];
    for &(i, range, wi, p) in &scratch.echoes {
        if found[i] {
            continue;
        }
        let (s, _) = sensors[i];
        let len = nalgebra::distance(&p, &s).max(1e-9);
        let dir = (p - s) / len;
        let skip = (wi < scene.walls.len()).then_some(wi);
        // Hidden if another wall is met clearly before the echo point.
        let hidden = scene
            .ray_dir(s, dir, (len - 20.0).max(0.0), Sense::Sound, open, skip)
            .is_some();
        if hidden {
            continue;
        }
        found[i] = true;
        out[i] = reading(range, timeouts[i], noise, rng);
    }
    for i in 0..SONARS {
        if !found[i] {
            out[i] = timeouts[i];
        }
    }
    out
}

fn reading(range: f64, timeout: u16, noise: &Noise, rng: &mut Rng) -> u16 {
    let timeout = f64::from(timeout);
    if range > timeout || rng.chance(noise.sonar_dropout) {
        return timeout as u16;
    }
    let noisy = range + rng.normal(noise.sonar_relative * range + noise.sonar_floor_mm);
    noisy.clamp(SONAR_MIN_MM, timeout).round() as u16
}

/// Reads the infrared sensors: bit `i` set when something is within
/// [`IR_RANGE_MM`] of sensor `i`, along its axis or 10° either side (glass
/// is not seen).
pub fn infrared(
    scene: &Scene,
    open: &[bool],
    at: Point,
    heading: f64,
    others: &[Body],
    scratch: &mut Scratch,
) -> u32 {
    scene.walls_near(at, ROBOT_RADIUS_MM + IR_RANGE_MM, &mut scratch.walls);
    let walls: Vec<usize> = scratch
        .walls
        .iter()
        .map(|&w| w as usize)
        .filter(|&w| scene.blocks(w, Sense::Sound, open))
        .collect();
    let reach2 = (2.0 * ROBOT_RADIUS_MM + IR_RANGE_MM).powi(2);
    let close: Vec<&Body> = others
        .iter()
        .filter(|o| nalgebra::distance_squared(&o.at, &at) <= reach2)
        .collect();
    let mut bits = 0u32;
    for i in 0..IR_SENSORS {
        let b = heading + ir_bearing_deg(i);
        let d = direction(b);
        let s = at + d * ROBOT_RADIUS_MM;
        let mut seen = [-10.0, 0.0, 10.0].iter().any(|spread| {
            let r = direction(b + spread);
            walls.iter().any(|&w| {
                let w = &scene.walls[w];
                crate::scene::hit(s, r, w.a, w.dir, w.len).is_some_and(|(t, _)| t <= IR_RANGE_MM)
            })
        });
        if !seen {
            seen = close.iter().any(|o| {
                let dist = nalgebra::distance(&o.at, &s) - ROBOT_RADIUS_MM;
                dist <= IR_RANGE_MM
                    && dist > -ROBOT_RADIUS_MM
                    && normalize_deg(heading_to(s, o.at) - b).abs() <= 30.0
            });
        }
        if seen {
            bits |= 1 << i;
        }
    }
    bits
}
