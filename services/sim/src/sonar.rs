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
use rome_maps::geometry::{direction, normalize_deg, Point};

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

fn bearing(from: Point, to: Point) -> f64 {
    normalize_deg((-(to.0 - from.0)).atan2(to.1 - from.1).to_degrees())
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
    let sensor = |i: usize| {
        let b = heading + sonar_bearing_deg(i);
        let d = direction(b);
        (
            (at.0 + d.0 * ROBOT_RADIUS_MM, at.1 + d.1 * ROBOT_RADIUS_MM),
            b,
        )
    };
    let index_near = |bearing_deg: f64| {
        let rel = normalize_deg(bearing_deg - heading);
        (rel / 15.0).round() as i64 + 12
    };
    // Flat surfaces.
    for &wi in &scratch.walls {
        let wi = wi as usize;
        if !scene.blocks(wi, Sense::Sound, open) {
            continue;
        }
        let w = &scene.walls[wi];
        // The robot must be on the side the wall faces.
        let side = (at.0 - w.a.0) * w.normal.0 + (at.1 - w.a.1) * w.normal.1;
        let n = if side >= 0.0 {
            w.normal
        } else {
            (-w.normal.0, -w.normal.1)
        };
        // Heading that looks straight at the wall.
        let facing = bearing((0.0, 0.0), (-n.0, -n.1));
        let centre = index_near(facing);
        for k in centre - 2..=centre + 2 {
            let i = k.rem_euclid(SONARS as i64) as usize;
            let (s, axis) = sensor(i);
            let incidence = normalize_deg(axis - facing);
            if incidence.abs() > SONAR_MAX_INCIDENCE_DEG {
                continue;
            }
            let dist = (s.0 - w.a.0) * n.0 + (s.1 - w.a.1) * n.1;
            if dist <= 0.0 {
                continue;
            }
            // The beam ray closest to the normal.
            let off = if incidence.abs() <= SONAR_HALF_BEAM_DEG {
                0.0
            } else {
                incidence.abs() - SONAR_HALF_BEAM_DEG
            };
            let range = dist / off.to_radians().cos();
            let ray = normalize_deg(facing + off * incidence.signum());
            let d = direction(ray);
            let p = (s.0 + d.0 * range, s.1 + d.1 * range);
            let u = (p.0 - w.a.0) * w.dir.0 + (p.1 - w.a.1) * w.dir.1;
            if (0.0..=w.len).contains(&u) && range <= SONAR_MAX_MM {
                scratch.echoes.push((i, range, wi, p));
            }
        }
    }
    // Corners.
    for &ci in &scratch.corners {
        let c = scene.reflectors[ci as usize];
        let centre = index_near(bearing(at, c));
        for k in centre - 1..=centre + 1 {
            let i = k.rem_euclid(SONARS as i64) as usize;
            let (s, axis) = sensor(i);
            let range = (c.0 - s.0).hypot(c.1 - s.1);
            if range <= SONAR_MAX_MM
                && range > 1.0
                && normalize_deg(bearing(s, c) - axis).abs() <= SONAR_HALF_BEAM_DEG
            {
                scratch.echoes.push((i, range, usize::MAX, c));
            }
        }
    }
    // Other robots.
    for other in others {
        let dc = (other.at.0 - at.0).hypot(other.at.1 - at.1);
        if dc < 1.0 || dc > reach + ROBOT_RADIUS_MM {
            continue;
        }
        let centre = index_near(bearing(at, other.at));
        for k in centre - 2..=centre + 2 {
            let i = k.rem_euclid(SONARS as i64) as usize;
            let (s, axis) = sensor(i);
            let d = (other.at.0 - s.0).hypot(other.at.1 - s.1);
            if d <= ROBOT_RADIUS_MM {
                continue;
            }
            let spread = (ROBOT_RADIUS_MM / d).asin().to_degrees();
            if normalize_deg(bearing(s, other.at) - axis).abs() <= SONAR_HALF_BEAM_DEG + spread {
                let range = d - ROBOT_RADIUS_MM;
                if range <= SONAR_MAX_MM {
                    let dir = direction(bearing(s, other.at));
                    let p = (s.0 + dir.0 * range, s.1 + dir.1 * range);
                    scratch.echoes.push((i, range, usize::MAX - 1, p));
                }
            }
        }
    }
    scratch
        .echoes
        .sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut out = [0u16; SONARS];
    let mut found = [false; SONARS];
    for &(i, range, wi, p) in &scratch.echoes {
        if found[i] {
            continue;
        }
        let (s, _) = sensor(i);
        let len = (p.0 - s.0).hypot(p.1 - s.1);
        let dir = ((p.0 - s.0) / len, (p.1 - s.1) / len);
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
/// [`IR_RANGE_MM`] of sensor `i` (glass is not seen).
pub fn infrared(scene: &Scene, open: &[bool], at: Point, heading: f64, others: &[Body]) -> u32 {
    let mut bits = 0u32;
    for i in 0..IR_SENSORS {
        let b = heading + ir_bearing_deg(i);
        let d = direction(b);
        let s = (at.0 + d.0 * ROBOT_RADIUS_MM, at.1 + d.1 * ROBOT_RADIUS_MM);
        let mut seen = [-10.0, 0.0, 10.0].iter().any(|spread| {
            scene
                .ray(s, b + spread, IR_RANGE_MM, Sense::Sound, open, None)
                .is_some()
        });
        if !seen {
            seen = others.iter().any(|o| {
                let dist = (o.at.0 - s.0).hypot(o.at.1 - s.1) - ROBOT_RADIUS_MM;
                dist <= IR_RANGE_MM
                    && dist > -ROBOT_RADIUS_MM
                    && normalize_deg(bearing(s, o.at) - b).abs() <= 30.0
            });
        }
        if seen {
            bits |= 1 << i;
        }
    }
    bits
}
