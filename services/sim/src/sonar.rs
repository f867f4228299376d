//! Sonar and infrared.
//!
//! Sonar follows the usual specular model of Polaroid ranging (Kuc and
//! Siegel 1987; Leonard and Durrant-Whyte 1992): a flat wall returns an echo
//! only when its normal lies within the beam (here: within
//! [`SONAR_MAX_INCIDENCE_DEG`](crate::spec::SONAR_MAX_INCIDENCE_DEG) of the axis, the beam being
//! [`SONAR_HALF_BEAM_DEG`] either side), at the range of the nearest point of
//! the beam on it; corners return from any direction inside the beam; glass
//! returns nothing; another robot returns from its nearest side. Whatever
//! echoes, the nearest echo not hidden behind another wall is the reading;
//! with no echo within the sensor's timeout the reading is the timeout.

use crate::rng::Rng;
use crate::scene::{Scene, Sense};
use crate::spec::{
    ir_bearing_deg, sonar_bearing_deg, Noise, IR_RANGE_MM, IR_SENSORS, ROBOT_RADIUS_MM, SONARS,
    SONAR_HALF_BEAM_DEG, SONAR_MAX_MM, SONAR_MIN_MM,
};
use rome_maps::geometry::{direction, heading_to, normalize_deg, Point, UnitComplex, Vector};
use std::sync::LazyLock;

/// Where a robot is, for the sensors of others.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// Centre, mm.
    pub at: Point,
}

/// The other robots a beam may meet.
#[derive(Debug, Clone, Copy)]
pub enum Others<'a> {
    /// All of these are tried.
    List(&'a [Body]),
    /// Filed by the scene's grid cells: the robots of cell `c` are
    /// `bodies[start[c]..start[c + 1]]`; only the cells the beam crosses are
    /// looked at.
    Cells {
        /// Where each cell's robots start in `bodies` (one more than cells).
        start: &'a [u32],
        /// The robots, cell by cell.
        bodies: &'a [Body],
    },
}

/// Reusable buffers, so a scan allocates nothing.
#[derive(Debug, Default, Clone)]
pub struct Scratch {
    walls: Vec<u32>,
    /// Per wall, the number of the firing that last looked at it (so a wall
    /// filed under several cells is tried once per firing).
    seen: Vec<u32>,
    /// The same for grid cells.
    cell_seen: Vec<u32>,
    firing: u32,
    /// Candidate echoes: (range, wall or usize::MAX, point).
    echoes: Vec<(f64, usize, Point)>,
    /// Where the robots near enough for the infrared sensors are.
    close: Vec<Point>,
}

/// The order in which the ring fires its sonars, one after another through
/// each cycle: consecutive firings point 105° apart, so one sonar's echo is
/// not heard by the next one to fire (crosstalk).
pub const FIRING_ORDER: [usize; SONARS] = {
    let mut order = [0; SONARS];
    let mut k = 0;
    while k < SONARS {
        order[k] = (k * 7) % SONARS;
        k += 1;
    }
    order
};

/// How far apart the beam is walked, mm: nearer echoes are found before
/// farther cells are looked at.
const SECTION_MM: f64 = 2_000.0;
/// How far the cells looked at reach beyond the beam, mm: robots are filed
/// by their centre, which may lie this far out of a beam their disc enters.
/// Walls need no margin: each is filed under every cell it passes through
/// (see [`Scene::walls_in_cell`]).
const MARGIN_MM: f64 = ROBOT_RADIUS_MM + 10.0;

/// cos and sin of [`SONAR_HALF_BEAM_DEG`] (7.5°), and cos of
/// [`SONAR_MAX_INCIDENCE_DEG`](crate::spec::SONAR_MAX_INCIDENCE_DEG) (20°):
/// computed once, not per beam.
const COS_HALF_BEAM: f64 = 0.991_444_861_373_810_4;
const SIN_HALF_BEAM: f64 = 0.130_526_192_220_051_6;
const COS_MAX_INCIDENCE: f64 = 0.939_692_620_785_908_4;

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
    let forward = direction(heading);
    let mut out = [0u16; SONARS];
    for (i, o) in out.iter_mut().enumerate() {
        *o = fire(
            scene,
            open,
            at,
            forward,
            i,
            Others::List(others),
            timeouts[i],
            noise,
            rng,
            scratch,
        );
    }
    out
}

/// Fires sonar `i` of a robot at `at` facing `forward` (a unit vector, see
/// [`direction`]): its range in mm, or `timeout` when nothing echoes within
/// it.
///
/// Only the walls and corners filed under the grid cells the beam crosses
/// are tried, nearest section of the beam first; the walk stops at the first
/// section that holds an echo nothing hides (culling).
#[allow(clippy::too_many_arguments)]
pub fn fire(
    scene: &Scene,
    open: &[bool],
    at: Point,
    forward: Vector,
    i: usize,
    others: Others<'_>,
    timeout: u16,
    noise: &Noise,
    rng: &mut Rng,
    scratch: &mut Scratch,
) -> u16 {
    let axis = turned(forward, SONAR_TURNS[i % SONARS]);
    let s = at + axis * ROBOT_RADIUS_MM;
    let reach = f64::from(timeout).min(SONAR_MAX_MM);
    let (sin_beam, cos_beam, cos_max) = (SIN_HALF_BEAM, COS_HALF_BEAM, COS_MAX_INCIDENCE);
    let edges = edges(axis);
    let (cols, rows) = scene.grid();
    if scratch.seen.len() != scene.walls.len() || scratch.cell_seen.len() != cols * rows {
        scratch.seen = vec![0; scene.walls.len()];
        scratch.cell_seen = vec![0; cols * rows];
        scratch.firing = 0;
    }
    scratch.firing = scratch.firing.wrapping_add(1);
    if scratch.firing == 0 {
        scratch.seen.fill(0);
        scratch.cell_seen.fill(0);
        scratch.firing = 1;
    }
    let firing = scratch.firing;
    scratch.echoes.clear();
    if let Others::List(list) = others {
        for other in list {
            if let Some(echo) = body_echo(at, s, axis, &edges, other.at, reach) {
                scratch.echoes.push(echo);
            }
        }
    }
    let across = Vector::new(-axis.y, axis.x);
    let mut checked = 0.0;
    let mut near = 0.0;
    while near < reach {
        let far = (near + SECTION_MM).min(reach);
        // Points of the beam between `near` and `far` from the sensor lie
        // within this box: along the axis from near·cos to far, across it
        // within far·sin either side.
        let half = far * sin_beam + MARGIN_MM;
        let (a0, a1) = (near * cos_beam - MARGIN_MM, far + MARGIN_MM);
        let corners = [
            s + axis * a0 + across * half,
            s + axis * a0 - across * half,
            s + axis * a1 + across * half,
            s + axis * a1 - across * half,
        ];
        let lo = corners.iter().fold(corners[0], |m, p| m.inf(p));
        let hi = corners.iter().fold(corners[0], |m, p| m.sup(p));
        let (x0, y0) = scene.cell_xy(lo);
        let (x1, y1) = scene.cell_xy(hi);
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                let c = cy * cols + cx;
                if scratch.cell_seen[c] == firing {
                    continue;
                }
                scratch.cell_seen[c] = firing;
                for &wi in scene.walls_in_cell(c) {
                    let wi = wi as usize;
                    if scratch.seen[wi] == firing {
                        continue;
                    }
                    scratch.seen[wi] = firing;
                    if let Some((range, p)) = wall_echo(scene, open, wi, s, axis, cos_beam, cos_max)
                    {
                        if range <= reach {
                            scratch.echoes.push((range, wi, p));
                        }
                    }
                }
                if let Others::Cells { start, bodies } = others {
                    let (a, b) = (start.get(c), start.get(c + 1));
                    if let (Some(&a), Some(&b)) = (a, b) {
                        for other in bodies.get(a as usize..b as usize).unwrap_or(&[]) {
                            if let Some(echo) = body_echo(at, s, axis, &edges, other.at, reach) {
                                scratch.echoes.push(echo);
                            }
                        }
                    }
                }
                for &ci in scene.reflectors_in_cell(c) {
                    let c = scene.reflectors[ci as usize];
                    let e = c - s;
                    let range = e.norm();
                    if range <= reach && range > 1.0 && e.dot(&axis) >= cos_beam * range {
                        scratch.echoes.push((range, usize::MAX, c));
                    }
                }
            }
        }
        // Every echo up to `far` is now known: the nearest one that nothing
        // hides is the reading.
        scratch.echoes.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        for &(range, wi, p) in &scratch.echoes {
            if range < checked {
                continue;
            }
            if range > far {
                break;
            }
            let len = nalgebra::distance(&p, &s).max(1e-9);
            let dir = (p - s) / len;
            let skip = (wi < scene.walls.len()).then_some(wi);
            // Hidden if another wall is met clearly before the echo point.
            let hidden = scene
                .ray_dir(s, dir, (len - 20.0).max(0.0), Sense::Sound, open, skip)
                .is_some();
            if !hidden {
                let metal = scene.walls.get(wi).is_some_and(|w| w.metal);
                if metal && rng.chance(METAL_SONAR_SPURIOUS) {
                    // Off a mirror to sound the echo comes back the long way.
                    let late = range * (1.5 + 1.5 * rng.uniform());
                    return reading(late.min(f64::from(timeout) + 1.0), timeout, noise, rng);
                }
                return reading(range, timeout, noise, rng);
            }
        }
        checked = far;
        near = far;
    }
    timeout
}

/// The echo sonar at `s` (on the ring of the robot at `me`) with axis
/// `axis` hears from the robot whose centre is `other`, if its disc enters
/// the beam within `reach`: from the disc's nearest point inside the beam.
fn body_echo(
    me: Point,
    s: Point,
    axis: Vector,
    edges: &[Vector; 2],
    other: Point,
    reach: f64,
) -> Option<(f64, usize, Point)> {
    if other == me {
        return None;
    }
    let e = other - s;
    // Cheap rejections first: a disc wholly behind the sensor, or wholly
    // outside the cone (its centre farther from the cone's edge than the
    // radius).
    let ahead = e.dot(&axis);
    let aside = axis.perp(&e).abs();
    if ahead < -ROBOT_RADIUS_MM
        || aside * COS_HALF_BEAM - ahead.max(0.0) * SIN_HALF_BEAM > ROBOT_RADIUS_MM
    {
        return None;
    }
    let d2 = e.norm_squared();
    let r2 = ROBOT_RADIUS_MM * ROBOT_RADIUS_MM;
    if d2 <= r2 || d2 > (reach + ROBOT_RADIUS_MM) * (reach + ROBOT_RADIUS_MM) {
        return None;
    }
    let d = d2.sqrt();
    let (range, p) = if e.dot(&axis) >= COS_HALF_BEAM * d {
        let range = d - ROBOT_RADIUS_MM;
        (range, s + e / d * range)
    } else {
        // The disc's centre is outside the beam: the disc enters it, if at
        // all, across the beam's edge nearer to it.
        let edge = edges[usize::from(axis.perp(&e) < 0.0)];
        let along = e.dot(&edge);
        let miss2 = d2 - along * along;
        if along <= 0.0 || miss2 > r2 {
            return None;
        }
        let range = along - (r2 - miss2).sqrt();
        (range, s + edge * range)
    };
    (range > 0.0 && range <= reach).then_some((range, usize::MAX - 1, p))
}

/// `v` turned counter-clockwise by the angle of cosine and sine `turn`.
fn turned(v: Vector, (cos, sin): (f64, f64)) -> Vector {
    Vector::new(v.x * cos - v.y * sin, v.x * sin + v.y * cos)
}

/// cos and sin of each sonar's bearing.
static SONAR_TURNS: LazyLock<[(f64, f64); SONARS]> = LazyLock::new(|| {
    std::array::from_fn(|i| {
        let b = sonar_bearing_deg(i).to_radians();
        (b.cos(), b.sin())
    })
});

/// cos and sin of each infrared sensor's bearing, and of the three rays it
/// looks along (its axis and 10° either side).
static IR_TURNS: LazyLock<[[(f64, f64); 4]; IR_SENSORS]> = LazyLock::new(|| {
    std::array::from_fn(|i| {
        std::array::from_fn(|k| {
            let spread = [0.0, -10.0, 0.0, 10.0][k];
            let b = (ir_bearing_deg(i) + spread).to_radians();
            (b.cos(), b.sin())
        })
    })
});

/// The beam's two edges: `axis` turned by half the beam counter-clockwise,
/// then clockwise.
fn edges(axis: Vector) -> [Vector; 2] {
    let turn = |sin: f64| {
        Vector::new(
            axis.x * COS_HALF_BEAM - axis.y * sin,
            axis.x * sin + axis.y * COS_HALF_BEAM,
        )
    };
    [turn(SIN_HALF_BEAM), turn(-SIN_HALF_BEAM)]
}

/// The echo sonar at `s` with axis `axis` hears from wall `wi`, if any:
/// (range, point of reflection).
fn wall_echo(
    scene: &Scene,
    open: &[bool],
    wi: usize,
    s: Point,
    axis: Vector,
    cos_beam: f64,
    cos_max: f64,
) -> Option<(f64, Point)> {
    if !scene.blocks(wi, Sense::Sound, open) {
        return None;
    }
    let w = &scene.lines[wi];
    // The sensor must be on the side the wall faces it with.
    let side = (s - w.a).dot(&w.normal);
    let n = if side >= 0.0 { w.normal } else { -w.normal };
    let dist = side.abs();
    if dist <= 0.0 {
        return None;
    }
    let look = -n;
    let cos_inc = axis.dot(&look);
    if cos_inc < cos_max {
        return None;
    }
    let (range, p) = if cos_inc >= cos_beam {
        (dist, s - n * dist)
    } else {
        // The beam's edge ray, the one closest to the normal: `look` turned
        // by `off` towards the axis.
        let off = cos_inc.min(1.0).acos() - SONAR_HALF_BEAM_DEG.to_radians();
        let range = dist / off.cos();
        let turn = UnitComplex::new(off * look.perp(&axis).signum());
        (range, s + (turn * look) * range)
    };
    let u = (p - w.a).dot(&w.dir);
    (0.0..=w.len).contains(&u).then_some((range, p))
}

fn reading(range: f64, timeout: u16, noise: &Noise, rng: &mut Rng) -> u16 {
    let timeout = f64::from(timeout);
    if range > timeout || rng.chance(noise.sonar_dropout) {
        return timeout as u16;
    }
    let noisy = range + rng.normal(noise.sonar_relative * range + noise.sonar_floor_mm);
    noisy.clamp(SONAR_MIN_MM, timeout).round() as u16
}

/// A bare metal wall (an elevator's cabin, `cabin=metal`) is a mirror to
/// sound (§5.4.6): this share of the echoes off it come back the long way,
/// late, and read 1.5 to 3 times as far.
pub const METAL_SONAR_SPURIOUS: f64 = 0.4;
/// ... and it throws infrared back hard: a detector looking at one within
/// this reach, mm, twice its range, fires half the time whatever is near.
pub const METAL_IR_REACH_MM: f64 = 2.0 * IR_RANGE_MM;
/// How often such a detector fires.
pub const METAL_IR_SPURIOUS: f64 = 0.5;

/// Reads the infrared sensors: bit `i` set when something is within
/// [`IR_RANGE_MM`] of sensor `i`, along its axis or 10° either side (glass
/// is not seen); a bare metal wall within [`METAL_IR_REACH_MM`] sets it at
/// random (drawn from `rng` only then).
pub fn infrared(
    scene: &Scene,
    open: &[bool],
    at: Point,
    heading: f64,
    others: &[Body],
    scratch: &mut Scratch,
    rng: &mut Rng,
) -> u32 {
    // A ray's hit lies within this of the centre: a wall whose line is
    // farther cannot be seen (the cells give a superset, in no order, which
    // a yes-or-no test per ray does not mind).
    let reach = ROBOT_RADIUS_MM + IR_RANGE_MM;
    scene.walls_near_unsorted(at, reach, &mut scratch.walls);
    scratch.walls.retain(|&w| {
        let wall = &scene.lines[w as usize];
        (at - wall.a).dot(&wall.normal).abs() <= reach
            && scene.blocks(w as usize, Sense::Sound, open)
    });
    let walls = &scratch.walls;
    let reach2 = (2.0 * ROBOT_RADIUS_MM + IR_RANGE_MM).powi(2);
    // Found once for all the sensors.
    scratch.close.clear();
    scratch.close.extend(
        others
            .iter()
            .filter(|o| nalgebra::distance_squared(&o.at, &at) <= reach2)
            .map(|o| o.at),
    );
    let close = &scratch.close;
    let metal: Vec<usize> = scene
        .metal_walls
        .iter()
        .copied()
        .filter(|&w| {
            let l = &scene.lines[w];
            (at - l.a).dot(&l.normal).abs() <= ROBOT_RADIUS_MM + METAL_IR_REACH_MM
                && scene.blocks(w, Sense::Sound, open)
        })
        .collect();
    if walls.is_empty() && close.is_empty() && metal.is_empty() {
        return 0;
    }
    let forward = direction(heading);
    let mut bits = 0u32;
    for (i, turns) in IR_TURNS.iter().enumerate() {
        let b = heading + ir_bearing_deg(i);
        let s = at + turned(forward, turns[0]) * ROBOT_RADIUS_MM;
        let mut seen = turns[1..].iter().any(|&turn| {
            let r = turned(forward, turn);
            walls.iter().any(|&w| {
                let w = &scene.lines[w as usize];
                crate::scene::hit(s, r, w.a, w.dir, w.len).is_some_and(|(t, _)| t <= IR_RANGE_MM)
            })
        });
        if !seen {
            seen = close.iter().any(|&o| {
                let dist = nalgebra::distance(&o, &s) - ROBOT_RADIUS_MM;
                dist <= IR_RANGE_MM
                    && dist > -ROBOT_RADIUS_MM
                    && normalize_deg(heading_to(s, o) - b).abs() <= 30.0
            });
        }
        if !seen && !metal.is_empty() {
            let glare = turns[1..].iter().any(|&turn| {
                let r = turned(forward, turn);
                metal.iter().any(|&w| {
                    let w = &scene.lines[w];
                    crate::scene::hit(s, r, w.a, w.dir, w.len)
                        .is_some_and(|(t, _)| t <= METAL_IR_REACH_MM)
                })
            });
            seen = glare && rng.chance(METAL_IR_SPURIOUS);
        }
        if seen {
            bits |= 1 << i;
        }
    }
    bits
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use crate::scene::hit;
    use crate::spec::SONAR_MAX_INCIDENCE_DEG;

    /// Every echo in the building tried, nothing culled: what [`fire`] must
    /// agree with.
    fn everything(
        scene: &Scene,
        at: Point,
        heading: f64,
        i: usize,
        others: &[Body],
        timeout: u16,
    ) -> u16 {
        let open = vec![false; scene.elevators.len()];
        let axis = turned(direction(heading), SONAR_TURNS[i]);
        let s = at + axis * ROBOT_RADIUS_MM;
        let reach = f64::from(timeout).min(SONAR_MAX_MM);
        let beam = SONAR_HALF_BEAM_DEG.to_radians();
        let cos_max = SONAR_MAX_INCIDENCE_DEG.to_radians().cos();
        let edges = [
            direction(heading + sonar_bearing_deg(i) + SONAR_HALF_BEAM_DEG),
            direction(heading + sonar_bearing_deg(i) - SONAR_HALF_BEAM_DEG),
        ];
        let mut echoes = Vec::new();
        for wi in 0..scene.walls.len() {
            if let Some((range, p)) = wall_echo(scene, &open, wi, s, axis, beam.cos(), cos_max) {
                if range <= reach {
                    echoes.push((range, wi, p));
                }
            }
        }
        for &c in &scene.reflectors {
            let e = c - s;
            let range = e.norm();
            if range <= reach && range > 1.0 && e.dot(&axis) >= beam.cos() * range {
                echoes.push((range, usize::MAX, c));
            }
        }
        for o in others {
            echoes.extend(body_echo(at, s, axis, &edges, o.at, reach));
        }
        echoes.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (range, wi, p) in echoes {
            let len = nalgebra::distance(&p, &s);
            // Every wall of the building that stops sound, no grid.
            let dir = (p - s) / len;
            let hidden = (0..scene.walls.len()).any(|h| {
                let w = &scene.lines[h];
                h != wi
                    && scene.blocks(h, Sense::Sound, &open)
                    && hit(s, dir, w.a, w.dir, w.len).is_some_and(|(t, _)| t <= len - 20.0)
            });
            if !hidden {
                return range.clamp(SONAR_MIN_MM, f64::from(timeout)).round() as u16;
            }
        }
        timeout
    }

    #[test]
    fn a_robot_echoes_from_its_nearest_point_inside_the_beam() {
        // Against rays spread densely across the beam, edges included.
        let mut rng = Rng::new(11);
        let me = Point::new(0.0, 0.0);
        let axis = direction(0.0);
        let s = me + axis * ROBOT_RADIUS_MM;
        let edges = edges(axis);
        let (mut heard, mut missed) = (0, 0);
        for _ in 0..4_000 {
            let other = s + Vector::new(
                (rng.uniform() - 0.5) * 2_500.0,
                (rng.uniform() - 0.3) * 10_000.0,
            );
            let got = body_echo(me, s, axis, &edges, other, SONAR_MAX_MM).map(|(r, _, _)| r);
            let e = other - s;
            let r2 = ROBOT_RADIUS_MM * ROBOT_RADIUS_MM;
            let mut nearest: Option<f64> = None;
            let mut least_miss = f64::INFINITY;
            for k in 0..=2_000 {
                let a = (k as f64 / 1_000.0 - 1.0) * SONAR_HALF_BEAM_DEG;
                let ray = direction(a);
                let along = e.dot(&ray);
                let miss2 = e.norm_squared() - along * along;
                if along > 0.0 {
                    least_miss = least_miss.min(miss2.sqrt());
                }
                if along > 0.0 && miss2 <= r2 {
                    let t = along - (r2 - miss2).sqrt();
                    if t > 0.0 && t <= SONAR_MAX_MM && nearest.is_none_or(|n| t < n) {
                        nearest = Some(t);
                    }
                }
            }
            // Discs that barely touch the beam are left to rounding.
            if (least_miss - ROBOT_RADIUS_MM).abs() < 1.0 || e.norm() <= ROBOT_RADIUS_MM {
                continue;
            }
            match (got, nearest) {
                (Some(g), Some(n)) => {
                    assert!((g - n).abs() < 2.0, "{other:?}: {g} vs {n}");
                    heard += 1;
                }
                (None, None) => missed += 1,
                _ => panic!("{other:?}: {got:?} vs {nearest:?}"),
            }
        }
        assert!(
            heard > 100 && missed > 100,
            "{heard} heard, {missed} missed"
        );
    }

    #[test]
    fn the_beam_constants_are_its_angles() {
        let beam = SONAR_HALF_BEAM_DEG.to_radians();
        assert!((COS_HALF_BEAM - beam.cos()).abs() < 1e-15);
        assert!((SIN_HALF_BEAM - beam.sin()).abs() < 1e-15);
        let max = SONAR_MAX_INCIDENCE_DEG.to_radians();
        assert!((COS_MAX_INCIDENCE - max.cos()).abs() < 1e-15);
    }

    #[test]
    fn culling_never_changes_a_reading() {
        let map = rome_maps::load_named("eb3").unwrap();
        let scene = Scene::new(&map);
        let open = vec![false; scene.elevators.len()];
        let spots = crate::scene::corridor_spots(&scene);
        let mut rng = Rng::new(7);
        let noise = Noise::none();
        let mut scratch = Scratch::default();
        let (cols, rows) = scene.grid();
        let mut tried = 0;
        let mut echoes = 0;
        for _ in 0..600 {
            let base = spots[(rng.next_u64() % spots.len() as u64) as usize];
            let jitter = |rng: &mut Rng| (rng.uniform() - 0.5) * 3_000.0;
            let at = base + Vector::new(jitter(&mut rng), jitter(&mut rng));
            let heading = rng.uniform() * 360.0;
            // A few robots around, some within reach of the beams.
            let mut bodies: Vec<Body> = (0..6)
                .map(|_| Body {
                    at: at + Vector::new(jitter(&mut rng), jitter(&mut rng)) * 2.0,
                })
                .filter(|b| nalgebra::distance(&b.at, &at) > 2.0 * ROBOT_RADIUS_MM)
                .collect();
            // Filed by cell, as the world files them.
            bodies.sort_by_key(|b| {
                let (cx, cy) = scene.cell_xy(b.at);
                cy * cols + cx
            });
            let mut start = vec![0u32; cols * rows + 1];
            for b in &bodies {
                let (cx, cy) = scene.cell_xy(b.at);
                start[cy * cols + cx + 1] += 1;
            }
            for c in 1..start.len() {
                start[c] += start[c - 1];
            }
            for i in 0..SONARS {
                let timeout = if i % 5 == 0 { 3_000 } else { 10_000 };
                let want = everything(&scene, at, heading, i, &bodies, timeout);
                for (how, others) in [
                    ("listed", Others::List(&bodies)),
                    (
                        "by cell",
                        Others::Cells {
                            start: &start,
                            bodies: &bodies,
                        },
                    ),
                ] {
                    let got = fire(
                        &scene,
                        &open,
                        at,
                        direction(heading),
                        i,
                        others,
                        timeout,
                        &noise,
                        &mut rng,
                        &mut scratch,
                    );
                    assert_eq!(
                        got, want,
                        "sonar {i} at {at:?} heading {heading}, robots {how}"
                    );
                }
                tried += 1;
                echoes += usize::from(want < timeout);
            }
        }
        // The sample must be worth something: most beams hear an echo.
        assert!(echoes * 3 > tried, "{echoes} echoes of {tried}");
    }
}
