//! The local map and what is read from it: the histogram grid, the Hough
//! transform that finds a hallway's walls in it, and the checks a wall
//! pair must pass. Pure functions of the grid, so the mapper's rules for
//! when to correct stay apart from how a correction is found.

use rome_maps::geometry::{direction, distance, heading_to, normalize_deg, pt, Point, Vector};

/// Cell size, mm.
pub const CELL_MM: f64 = 100.0;
/// Radius of the sonar ring: readings start at the robot's skin, mm.
pub const SONAR_RING_MM: f64 = 380.0;
/// Readings beyond this are not mapped (glancing and missing echoes), mm.
pub const MAX_RANGE_MM: u32 = 5_000;

/// A histogram grid (HIMM) around an origin, in the odometry frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    origin: Point,
    n: usize,
    cells: Vec<u8>,
}

impl Grid {
    /// Where the map was begun, in the odometry frame.
    pub fn origin(&self) -> Point {
        self.origin
    }

    /// An empty grid of `half_side_mm` around `origin`.
    pub fn new(origin: Point, half_side_mm: f64) -> Grid {
        let n = (2.0 * half_side_mm / CELL_MM).ceil() as usize;
        Grid {
            origin,
            n,
            cells: vec![0; n * n],
        }
    }

    fn cell(&self, p: Point) -> Option<usize> {
        let half = self.n as f64 / 2.0;
        let cx = ((p.x - self.origin.x) / CELL_MM + half).floor();
        let cy = ((p.y - self.origin.y) / CELL_MM + half).floor();
        (cx >= 0.0 && cy >= 0.0 && cx < self.n as f64 && cy < self.n as f64)
            .then(|| cy as usize * self.n + cx as usize)
    }

    fn centre(&self, i: usize) -> Point {
        let half = self.n as f64 / 2.0;
        let (cx, cy) = ((i % self.n) as f64, (i / self.n) as f64);
        self.origin + Vector::new(cx + 0.5 - half, cy + 0.5 - half) * CELL_MM
    }

    /// Adds one sonar reading taken at `at` along heading `axis_deg`.
    pub fn add(&mut self, at: Point, axis_deg: f64, range_mm: u32) {
        if range_mm >= MAX_RANGE_MM {
            return;
        }
        let d = direction(axis_deg);
        let total = SONAR_RING_MM + f64::from(range_mm);
        let mut s = SONAR_RING_MM;
        while s < total - CELL_MM {
            if let Some(i) = self.cell(pt(at.x + d.x * s, at.y + d.y * s)) {
                self.cells[i] = self.cells[i].saturating_sub(1);
            }
            s += CELL_MM;
        }
        if let Some(i) = self.cell(pt(at.x + d.x * total, at.y + d.y * total)) {
            self.cells[i] = (self.cells[i] + 3).min(15);
        }
    }

    /// Cells at least this certain, as points.
    pub fn occupied(&self, min: u8) -> Vec<(Point, u8)> {
        self.cells
            .iter()
            .enumerate()
            .filter(|(_, c)| **c >= min)
            .map(|(i, c)| (self.centre(i), *c))
            .collect()
    }
}

/// The two walls of a hallway found in a local map, in the odometry frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HallwayWalls {
    /// The walls' direction, degrees in [0, 180) (North 0, West 90):
    /// directionless.
    pub orientation_deg: f64,
    /// The walls' common unit normal (x, y).
    pub normal: Vector,
    /// Each wall's distance from the frame's origin along the normal, mm:
    /// wall `i` is the set of points `p` with `p · normal = rho[i]`.
    pub rho: [f64; 2],
}

impl HallwayWalls {
    /// Signed distances of each wall from `p` along the normal turned to
    /// point left of `heading_deg`, mm: the left wall's is positive.
    pub fn beside(&self, p: Point, heading_deg: f64) -> [f64; 2] {
        let left = direction(heading_deg + 90.0);
        let sign = if left.dot(&self.normal) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        let at = p.coords.dot(&self.normal);
        self.rho.map(|r| sign * (r - at))
    }
}

/// The hallway's orientation from the grid: the strongest Hough line and
/// a parallel one at least `min_gap_mm` away. `None` when no such pair.
/// The result is the lines' direction, degrees in [0, 180) (North 0, West
/// 90): directionless.
pub fn hallway_orientation(points: &[(Point, u8)], min_gap_mm: f64) -> Option<f64> {
    hallway_walls(points, min_gap_mm, None).map(|w| w.orientation_deg)
}

/// Both walls from the grid (see [`hallway_orientation`]). Each wall's
/// position is refined from the cells near its Hough line: those within
/// `near` = (point, mm) when there are enough of them there (the walls
/// beside the robot now, not where odometry had drifted less), else all.
pub fn hallway_walls(
    points: &[(Point, u8)],
    min_gap_mm: f64,
    near: Option<(Point, f64)>,
) -> Option<HallwayWalls> {
    if points.len() < 10 {
        return None;
    }
    const STEPS: usize = 360; // half-degree steps over 180°
    let rho_cell = CELL_MM;
    // The centroid, so the accumulator's distances stay small.
    let c0 = Point::from(
        points
            .iter()
            .fold(Vector::zeros(), |a, (p, _)| a + p.coords)
            / points.len() as f64,
    );
    let rmax = points
        .iter()
        .map(|(p, _)| distance(*p, c0))
        .fold(0.0, f64::max);
    let nr = (2.0 * rmax / rho_cell).ceil() as usize + 2;
    let mut acc = vec![0u32; STEPS * nr];
    // Unit normals at 0°, 0.5°, … from +x.
    let trig: Vec<Vector> = (0..STEPS)
        .map(|k| {
            let t = (k as f64 * 0.5).to_radians();
            Vector::new(t.cos(), t.sin())
        })
        .collect();
    for (p, w) in points {
        for (k, n) in trig.iter().enumerate() {
            // The line's normal makes angle t with +x.
            let rho = (p - c0).dot(n);
            let r = ((rho + rmax) / rho_cell).round() as usize;
            acc[k * nr + r] += u32::from(*w);
        }
    }
    let (best, _) = acc.iter().enumerate().max_by_key(|(_, v)| **v)?;
    let (k, r) = (best / nr, best % nr);
    // Guided search: the other wall shares the normal (±1°), a gap away.
    let gap = (min_gap_mm / rho_cell).ceil() as usize;
    let mut second = (0u32, r);
    for dk in -2i64..=2 {
        let kk = (k as i64 + dk).rem_euclid(STEPS as i64) as usize;
        for rr in 0..nr {
            if rr.abs_diff(r) >= gap && acc[kk * nr + rr] > second.0 {
                second = (acc[kk * nr + rr], rr);
            }
        }
    }
    if second.0 < acc[best] / 4 {
        return None;
    }
    // Normal angle t from +x; the line runs at t + 90° from +x. A
    // direction at angle φ from +x has heading φ − 90° (North 0, West 90).
    let normal_from_x = k as f64 * 0.5;
    let normal = trig[k];
    let centre = c0.coords.dot(&normal);
    let coarse = |rr: usize| centre + rr as f64 * rho_cell - rmax;
    let refine = |guess: f64| {
        let on_line = |p: &Point| (p.coords.dot(&normal) - guess).abs() < 250.0;
        let mean = |pts: &mut dyn Iterator<Item = &(Point, u8)>| {
            let (mut sum, mut weight, mut n) = (0.0, 0.0, 0usize);
            for (p, w) in pts {
                sum += f64::from(*w) * p.coords.dot(&normal);
                weight += f64::from(*w);
                n += 1;
            }
            (n >= 8).then(|| sum / weight)
        };
        near.and_then(|(at, within)| {
            mean(
                &mut points
                    .iter()
                    .filter(|(p, _)| on_line(p) && distance(*p, at) <= within),
            )
        })
        .or_else(|| mean(&mut points.iter().filter(|(p, _)| on_line(p))))
        .unwrap_or(guess)
    };
    let rough = HallwayWalls {
        orientation_deg: normal_from_x.rem_euclid(180.0),
        normal,
        rho: [refine(coarse(r)), refine(coarse(second.1))],
    };
    Some(
        near.and_then(|(at, within)| local_fit(points, &rough, at, within))
            .unwrap_or(rough),
    )
}

/// Both walls fitted again from the cells within `within` of `at` only,
/// with one common slope: where odometry has drifted, the walls bend in
/// its frame, and the stretch beside the robot tells its heading error now
/// rather than the average over the map. `None` when that stretch is too
/// short or too sparse to tell.
fn local_fit(
    points: &[(Point, u8)],
    rough: &HallwayWalls,
    at: Point,
    within: f64,
) -> Option<HallwayWalls> {
    let n = rough.normal;
    let u = Vector::new(-n.y, n.x);
    let mut lines: [Vec<(f64, f64, f64)>; 2] = [Vec::new(), Vec::new()];
    for (p, w) in points {
        if distance(*p, at) > within {
            continue;
        }
        let t = p.coords.dot(&n);
        for (i, rho) in rough.rho.iter().enumerate() {
            if (t - rho).abs() < 400.0 {
                lines[i].push((p.coords.dot(&u), t, f64::from(*w)));
            }
        }
    }
    let mut means = [(0.0, 0.0); 2];
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, line) in lines.iter().enumerate() {
        let weight: f64 = line.iter().map(|l| l.2).sum();
        let (lo, hi) = line.iter().fold((f64::MAX, f64::MIN), |(lo, hi), l| {
            (lo.min(l.0), hi.max(l.0))
        });
        if line.len() < 8 || hi - lo < 2_000.0 || weight <= 0.0 {
            return None;
        }
        let ms = line.iter().map(|l| l.0 * l.2).sum::<f64>() / weight;
        let mt = line.iter().map(|l| l.1 * l.2).sum::<f64>() / weight;
        for l in line {
            sxy += l.2 * (l.0 - ms) * (l.1 - mt);
            sxx += l.2 * (l.0 - ms) * (l.0 - ms);
        }
        means[i] = (ms, mt);
    }
    let b = sxy / sxx;
    if !b.is_finite() || b.abs() > 0.2 {
        return None;
    }
    let len = (1.0 + b * b).sqrt();
    let normal = (n - u * b) / len;
    let s_at = at.coords.dot(&u);
    let rho = means.map(|(ms, mt)| {
        let t = mt + b * (s_at - ms);
        (u * s_at + n * t).dot(&normal)
    });
    Some(HallwayWalls {
        orientation_deg: (rough.orientation_deg - b.atan().to_degrees()).rem_euclid(180.0),
        normal,
        rho,
    })
}

/// The sideways correction of odometry position `p`, mm along the left of
/// the corridor's heading: where the walls found say the robot is across
/// the corridor, against where odometry and the map put it. `None` when
/// the walls found are not the corridor's (one on each side, as far apart
/// as the map's, within `tolerance_mm`).
pub fn sideways_fix(
    walls: &HallwayWalls,
    p: Point,
    corridor: &crate::board::Corridor,
    tolerance_mm: f64,
) -> Option<f64> {
    let (left, right) = (corridor.left_mm?, corridor.right_mm?);
    let [a, b] = walls.beside(p, corridor.heading_deg);
    let (seen_left, seen_right) = if a > b { (a, -b) } else { (b, -a) };
    if seen_left <= 0.0 || seen_right <= 0.0 {
        return None;
    }
    if (seen_left + seen_right - (left + right)).abs() > tolerance_mm {
        return None;
    }
    // Offsets left of the line of lights: as the walls say, and as
    // odometry says.
    let seen = ((left - seen_left) + (seen_right - right)) / 2.0;
    let n = direction(corridor.heading_deg + 90.0);
    let odometry = (p - corridor.at()).dot(&n);
    Some(seen - odometry)
}

/// The angle between a directionless orientation `alpha_deg` and the
/// straight track from `from` to `to` (both in the odometry frame),
/// degrees in [0, 90]; `None` when the track is shorter than `min_mm`.
pub fn track_disagreement(alpha_deg: f64, from: Point, to: Point, min_mm: f64) -> Option<f64> {
    if distance(from, to) < min_mm {
        return None;
    }
    let d = (alpha_deg - heading_to(from, to)).rem_euclid(180.0);
    Some(d.min(180.0 - d))
}

/// The directionless rule (§5.5): of α and α + 180°, the one nearer the
/// goal direction Γ.
pub fn orient(alpha_deg: f64, goal_deg: f64) -> f64 {
    let a = normalize_deg(alpha_deg);
    let b = normalize_deg(alpha_deg + 180.0);
    if normalize_deg(goal_deg - a).abs() <= normalize_deg(goal_deg - b).abs() {
        a
    } else {
        b
    }
}
