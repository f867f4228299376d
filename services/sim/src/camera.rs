//! The two cameras (§5.6–5.7, Figure 5.15): one looking up at the ceiling
//! lights, one looking sideways along sonar 18 at the wall and its door
//! plates. Both give 8-bit grey images.

use crate::rng::Rng;
use crate::scene::{Scene, Sense};
use crate::spec::{
    sonar_bearing_deg, LIGHT_SIZE_MM, PLATE_HEIGHT_MM, PLATE_SIZE_MM, ROBOT_RADIUS_MM,
    SIDE_FOV_DEG, UP_VIEW_MM,
};
use image::GrayImage;
use rome_maps::font;
use rome_maps::geometry::{direction, Point, Vector};
use rome_maps::model::EdgeKind;

/// Grey of the ceiling between lights.
pub const CEILING_GREY: u8 = 60;
/// Grey of a lit ceiling light.
pub const LIGHT_GREY: u8 = 235;
/// Grey of a door plate's background.
pub const PLATE_GREY: u8 = 15;
/// Grey of a plate's digits.
pub const DIGIT_GREY: u8 = 245;

/// Grey of a marker's black stripes.
pub const MARKER_BLACK: u8 = 20;
/// Grey of a marker's paper.
pub const MARKER_WHITE: u8 = 230;

const FLOOR_GREY: u8 = 70;
const UPPER_CEILING_GREY: u8 = 205;
const FAR_GREY: u8 = 30;
const WALL_HEIGHT_MM: f64 = 2_700.0;
/// Grey of a person (clothes, hair) on the sideways image.
pub const PERSON_GREY: u8 = 95;
/// A person's height, mm: taller than the door plates, so a person
/// between the camera and a plate hides it.
pub const PERSON_HEIGHT_MM: f64 = 1_750.0;
/// How far the sideways camera sees, mm.
pub const SIDE_RANGE_MM: f64 = 15_000.0;

/// Pixel noise drawn once per world: a table of Gaussian grey-level
/// offsets, read from a random place for each image (drawing a normal per
/// pixel would cost more than the rendering).
#[derive(Debug, Clone)]
pub struct PixelNoise {
    table: Vec<i16>,
}

impl PixelNoise {
    /// A table of offsets with standard deviation `sd` grey levels.
    pub fn new(sd: f64, rng: &mut Rng) -> PixelNoise {
        let table = if sd == 0.0 {
            Vec::new()
        } else {
            (0..1 << 16)
                .map(|_| rng.normal(sd).round() as i16)
                .collect()
        };
        PixelNoise { table }
    }

    /// Adds the table's offsets to `pixels`, read on from a random place
    /// (contiguous runs of the table, so the loop vectorises).
    fn apply(&self, pixels: &mut [u8], rng: &mut Rng) {
        let start = rng.next_u64();
        self.apply_at(start, 0, pixels);
    }

    /// Adds the offsets [`apply`](Self::apply) would add, from the place
    /// `start`, to the image's pixels from index `first` on: a row of an
    /// image gets the same noise drawn alone as drawn with the rest.
    pub(crate) fn apply_at(&self, start: u64, first: usize, pixels: &mut [u8]) {
        if self.table.is_empty() {
            return;
        }
        let n = self.table.len();
        let mut k = ((start as usize) % n + first % n) % n;
        for run in pixels.chunks_mut(n) {
            let mut done = 0;
            while done < run.len() {
                let take = (run.len() - done).min(n - k);
                for (p, &t) in run[done..done + take]
                    .iter_mut()
                    .zip(&self.table[k..k + take])
                {
                    *p = (i16::from(*p) + t).clamp(0, 255) as u8;
                }
                done += take;
                k = (k + take) % n;
            }
        }
    }
}

/// Whether a ceiling point is under a light.
pub fn lit(scene: &Scene, near: &[usize], p: Point) -> bool {
    near.iter().any(|&li| {
        let l = &scene.lamps[li];
        let d = p - l.at;
        let along = d.dot(&l.along);
        let across = l.along.perp(&d);
        along.abs() <= LIGHT_SIZE_MM.0 / 2.0 && across.abs() <= LIGHT_SIZE_MM.1 / 2.0
    })
}

/// The upward camera's image: columns run across the robot (left to right),
/// rows along it (row 0 ahead), covering [`UP_VIEW_MM`] of ceiling.
pub fn up_image(
    scene: &Scene,
    at: Point,
    heading: f64,
    size: (u32, u32),
    pixel_noise: &PixelNoise,
    rng: &mut Rng,
) -> GrayImage {
    let view = Up::new(scene, at, heading, size);
    drawn(size, pixel_noise, rng, |row, line| {
        view.row(scene, row, line)
    })
}

/// An image of `size` drawn row by row by `draw`, then the frame's noise
/// added to the whole of it.
fn drawn(
    size: (u32, u32),
    pixel_noise: &PixelNoise,
    rng: &mut Rng,
    draw: impl Fn(usize, &mut [u8]),
) -> GrayImage {
    let (w, h) = size;
    let mut pixels = vec![0u8; w as usize * h as usize];
    if w > 0 {
        for (row, line) in pixels.chunks_exact_mut(w as usize).enumerate() {
            draw(row, line);
        }
    }
    pixel_noise.apply(&mut pixels, rng);
    GrayImage::from_raw(w, h, pixels).unwrap_or_else(|| GrayImage::new(w, h))
}

/// The upward camera at one pose, drawn a row at a time (without noise).
#[derive(Debug, Clone)]
pub(crate) struct Up {
    at: Point,
    /// Ahead, and to the right.
    f: Vector,
    r: Vector,
    /// The lights that could be in view.
    near: Vec<usize>,
    size: (u32, u32),
}

impl Up {
    pub(crate) fn new(scene: &Scene, at: Point, heading: f64, size: (u32, u32)) -> Up {
        let reach = (UP_VIEW_MM.0.hypot(UP_VIEW_MM.1) + LIGHT_SIZE_MM.1) / 2.0 + 100.0;
        let near = scene
            .lamps
            .iter()
            .enumerate()
            .filter(|(_, l)| nalgebra::distance(&l.at, &at) <= reach)
            .map(|(i, _)| i)
            .collect();
        Up {
            at,
            f: direction(heading),
            r: direction(heading - 90.0),
            near,
            size,
        }
    }

    /// Row `row`'s pixels into `line` (one row's length).
    pub(crate) fn row(&self, scene: &Scene, row: usize, line: &mut [u8]) {
        let (w, h) = self.size;
        let lat_of = |col: f64| ((col + 0.5) / f64::from(w) - 0.5) * UP_VIEW_MM.0;
        let fwd = (0.5 - (row as f64 + 0.5) / f64::from(h)) * UP_VIEW_MM.1;
        let centre = self.at + self.f * fwd;
        // Columns that may be under a light: along this row a light's
        // rectangle is one span of columns; one more either side is tried
        // pixel by pixel, so rounding cannot change a pixel.
        let (mut first, mut last) = (w as usize, 0usize);
        for &li in &self.near {
            if let Some((lo, hi)) = lit_span(&scene.lamps[li], centre, self.r) {
                let to_col = |lat: f64| (lat / UP_VIEW_MM.0 + 0.5) * f64::from(w) - 0.5;
                let c0 = (to_col(lo).floor() - 1.0).max(0.0) as usize;
                let c1 = (to_col(hi).ceil() + 1.0).min(f64::from(w) - 1.0);
                if c1 >= 0.0 {
                    first = first.min(c0);
                    last = last.max(c1 as usize);
                }
            }
        }
        line.fill(CEILING_GREY);
        for col in first..=last.min(line.len().saturating_sub(1)) {
            if lit(scene, &self.near, centre + self.r * lat_of(col as f64)) {
                line[col] = LIGHT_GREY;
            }
        }
    }
}

/// Where along the line `centre + across · lat` a light's rectangle lies:
/// the range of `lat`, if the line meets it.
fn lit_span(l: &crate::scene::Lamp, centre: Point, across: Vector) -> Option<(f64, f64)> {
    let d = centre - l.at;
    // Both of the rectangle's coordinates are linear in lat.
    let along = (d.dot(&l.along), across.dot(&l.along));
    let side = (l.along.perp(&d), l.along.perp(&across));
    let mut lo = f64::NEG_INFINITY;
    let mut hi = f64::INFINITY;
    for ((c0, c1), half) in [
        (along, LIGHT_SIZE_MM.0 / 2.0),
        (side, LIGHT_SIZE_MM.1 / 2.0),
    ] {
        if c1.abs() < 1e-12 {
            if c0.abs() > half {
                return None;
            }
        } else {
            let (a, b) = ((-half - c0) / c1, (half - c0) / c1);
            lo = lo.max(a.min(b));
            hi = hi.min(a.max(b));
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// The sideways camera's image, looking along sonar 18 from the robot's
/// side at the height of the door plates. `people` are the centres of the
/// people about (upright cylinders of a robot's girth,
/// [`PERSON_HEIGHT_MM`] tall), who hide what stands behind them.
#[allow(clippy::too_many_arguments)]
pub fn side_image(
    scene: &Scene,
    open: &[bool],
    at: Point,
    heading: f64,
    people: &[Point],
    size: (u32, u32),
    pixel_noise: &PixelNoise,
    rng: &mut Rng,
) -> GrayImage {
    let view = Side::new(at, heading, people.to_vec(), size);
    let columns = view.columns(scene, open);
    drawn(size, pixel_noise, rng, |row, line| {
        view.row(scene, &columns, row, line)
    })
}

/// The sideways camera at one pose, drawn a row at a time (without noise)
/// once its columns are worked out.
#[derive(Debug, Clone)]
pub(crate) struct Side {
    eye: Point,
    axis: f64,
    focal: f64,
    people: Vec<Point>,
    size: (u32, u32),
}

/// What each column of a sideways image looks at: the wall, and the
/// rows a person nearer than the wall covers.
#[derive(Debug)]
pub(crate) struct Columns {
    walls: Vec<Option<Column>>,
    figures: Vec<Option<(usize, usize)>>,
}

impl Side {
    pub(crate) fn new(at: Point, heading: f64, people: Vec<Point>, size: (u32, u32)) -> Side {
        let axis = heading + sonar_bearing_deg(18);
        Side {
            eye: at + direction(axis) * ROBOT_RADIUS_MM,
            axis,
            focal: f64::from(size.0) / 2.0 / (SIDE_FOV_DEG / 2.0).to_radians().tan(),
            people,
            size,
        }
    }

    /// The height a row shows at `per_row` millimetres a row.
    fn z_at(&self, row: usize, per_row: f64) -> f64 {
        PLATE_HEIGHT_MM + (f64::from(self.size.1) / 2.0 - (row as f64 + 0.5)) * per_row
    }

    /// The first row whose height is not above `limit` (heights fall row
    /// by row).
    fn first_below(&self, limit: f64, per_row: f64, strict: bool) -> usize {
        let (h, hu) = (f64::from(self.size.1), self.size.1 as usize);
        let guess = h / 2.0 - 0.5 - (limit - PLATE_HEIGHT_MM) / per_row;
        let mut row = if guess > 2.0 {
            ((guess as usize) - 2).min(hu)
        } else {
            0
        };
        while row < hu
            && (if strict {
                self.z_at(row, per_row) >= limit
            } else {
                self.z_at(row, per_row) > limit
            })
        {
            row += 1;
        }
        row
    }

    /// The angle of column `col` off the axis, radians.
    fn off(&self, col: usize) -> f64 {
        let x = col as f64 + 0.5 - f64::from(self.size.0) / 2.0;
        (x / self.focal).atan()
    }

    /// One ray per column: what it meets, millimetres of height per row
    /// there, and the rows where the wall starts (above it the ceiling)
    /// and the floor starts; and the people in front.
    pub(crate) fn columns(&self, scene: &Scene, open: &[bool]) -> Columns {
        let (wu, hu) = (self.size.0 as usize, self.size.1 as usize);
        let walls: Vec<Option<Column>> = (0..wu)
            .map(|col| {
                let off = self.off(col);
                let ray = self.axis - off.to_degrees();
                let (t, wi, u) =
                    scene.ray(self.eye, ray, SIDE_RANGE_MM, Sense::Sight, open, None)?;
                let wall = &scene.walls[wi];
                let per_row = t * off.cos() / self.focal;
                let top = self.first_below(WALL_HEIGHT_MM, per_row, false);
                let floor = self.first_below(0.0, per_row, true).max(top);
                // A wall without plates, posters or glass bricks changes its
                // look only at the door frame's heights: three runs of rows.
                let plain = wall.plates.is_empty()
                    && wall.posters.is_empty()
                    && wall.marker.is_none()
                    && !(wall.kind == EdgeKind::Window && wall.bricks);
                let mut runs = None;
                if plain {
                    let frame_top = self
                        .first_below(FRAME_MM.1, per_row, false)
                        .clamp(top, floor);
                    let frame_bottom = self
                        .first_below(FRAME_MM.0, per_row, true)
                        .clamp(frame_top, floor);
                    // Each run's grey, read at one of its rows; a row exactly
                    // at a frame edge is left to the pixel-by-pixel path.
                    let grey = |from: usize, to: usize| {
                        (from < to).then(|| surface(scene, wi, u, self.z_at(from, per_row)))
                    };
                    let exact = [frame_top, frame_bottom]
                        .iter()
                        .any(|&r| r < hu && FRAME_MM_EDGES.contains(&self.z_at(r, per_row)));
                    if !exact {
                        runs = Some((
                            [frame_top, frame_bottom],
                            [
                                grey(top, frame_top).unwrap_or(0),
                                grey(frame_top, frame_bottom).unwrap_or(0),
                                grey(frame_bottom, floor).unwrap_or(0),
                            ],
                        ));
                    }
                }
                Some(Column {
                    t,
                    per_row,
                    wi,
                    u,
                    top,
                    floor,
                    runs,
                })
            })
            .collect();
        let figures = if self.people.is_empty() {
            Vec::new()
        } else {
            (0..wu)
                .map(|col| {
                    let off = self.off(col);
                    let d = direction(self.axis - off.to_degrees());
                    let wall_t = walls[col].as_ref().map_or(SIDE_RANGE_MM, |c| c.t);
                    let t = self
                        .people
                        .iter()
                        .filter_map(|&c| ray_disc(self.eye, d, c, ROBOT_RADIUS_MM))
                        .filter(|&t| t < wall_t)
                        .min_by(f64::total_cmp)?;
                    let per_row = t * off.cos() / self.focal;
                    let top = self.first_below(PERSON_HEIGHT_MM, per_row, false);
                    Some((top, self.first_below(0.0, per_row, true).max(top)))
                })
                .collect()
        };
        Columns { walls, figures }
    }

    /// Row `row`'s pixels into `line` (one row's length).
    pub(crate) fn row(&self, scene: &Scene, columns: &Columns, row: usize, line: &mut [u8]) {
        for (col, (px, column)) in line.iter_mut().zip(&columns.walls).enumerate() {
            let hidden = columns
                .figures
                .get(col)
                .copied()
                .flatten()
                .is_some_and(|(top, floor)| (top..floor).contains(&row));
            *px = if hidden {
                PERSON_GREY
            } else {
                match column {
                    None => FAR_GREY,
                    Some(c) if row < c.top => UPPER_CEILING_GREY,
                    Some(c) if row >= c.floor => FLOOR_GREY,
                    Some(c) => match c.runs {
                        Some(([a, b], greys)) => {
                            greys[usize::from(row >= a) + usize::from(row >= b)]
                        }
                        None => surface(scene, c.wi, c.u, self.z_at(row, c.per_row)),
                    },
                }
            };
        }
    }
}

/// How far along the ray from `eye` in the unit direction `d` it first
/// meets the disc of radius `r` about `c`, if it does ahead of the eye.
fn ray_disc(eye: Point, d: Vector, c: Point, r: f64) -> Option<f64> {
    let f = eye - c;
    let b = f.dot(&d);
    let disc = b * b - (f.dot(&f) - r * r);
    if disc < 0.0 {
        return None;
    }
    let t = -b - disc.sqrt();
    (t > 0.0).then_some(t)
}

/// What one column of the sideways image looks at.
#[derive(Debug)]
struct Column {
    /// How far along the ray the wall is, mm.
    t: f64,
    /// Millimetres of height per row on the wall it meets.
    per_row: f64,
    /// The wall, and where along it.
    wi: usize,
    u: f64,
    /// The first row of wall below the ceiling, and the first of floor.
    top: usize,
    floor: usize,
    /// For a wall whose look changes only at the door frame's heights: the
    /// rows where the frame starts and ends, and the greys above, in and
    /// below it.
    runs: Option<([usize; 2], [u8; 3])>,
}

/// The heights of a door frame's top bar, mm: [bottom, top) (see
/// [`surface`]).
const FRAME_MM: (f64, f64) = (2_050.0, 2_110.0);
const FRAME_MM_EDGES: [f64; 2] = [FRAME_MM.0, FRAME_MM.1];

/// What a wall looks like at offset `u` along it and height `z`.
fn surface(scene: &Scene, wi: usize, u: f64, z: f64) -> u8 {
    let wall = &scene.walls[wi];
    for (label, at) in &wall.plates {
        let (pw, ph) = PLATE_SIZE_MM;
        let (du, dz) = (u - (at - pw / 2.0), (PLATE_HEIGHT_MM + ph / 2.0) - z);
        if (0.0..pw).contains(&du) && (0.0..ph).contains(&dz) {
            // White digits, centred, with a margin of a tenth of the plate.
            let cols = font::width(label, 1).max(1) as f64;
            let cell = ((pw * 0.8) / cols).min(ph * 0.8 / f64::from(font::HEIGHT));
            let x0 = (pw - cols * cell) / 2.0;
            let y0 = (ph - f64::from(font::HEIGHT) * cell) / 2.0;
            let (fc, fr) = (((du - x0) / cell).floor(), ((dz - y0) / cell).floor());
            return if du >= x0 && dz >= y0 && font::lit(label, fc as i64, fr as i64) {
                DIGIT_GREY
            } else {
                PLATE_GREY
            };
        }
    }
    for at in &wall.posters {
        if (u - at).abs() <= 300.0 && (1_000.0..1_900.0).contains(&z) {
            return 25;
        }
    }
    match wall.kind {
        EdgeKind::Door => {
            // A darker frame around a wooden door.
            if u < 60.0 || u > wall.len - 60.0 || (FRAME_MM.0..FRAME_MM.1).contains(&z) {
                60
            } else if z > FRAME_MM.1 {
                170
            } else {
                105
            }
        }
        // Metal doors, with the marker's black stripes on white paper.
        EdgeKind::Elevator => match wall.marker.and_then(|m| m.ink(wall.len, u, z)) {
            Some(true) => MARKER_BLACK,
            Some(false) => MARKER_WHITE,
            None => 140,
        },
        EdgeKind::Glass => 185,
        EdgeKind::Window if wall.bricks => {
            // Glass bricks: a grid of dark mortar and bright blocks.
            let (bu, bz) = ((u / 200.0).rem_euclid(1.0), (z / 200.0).rem_euclid(1.0));
            if bu < 0.1 || bz < 0.1 {
                55
            } else {
                225
            }
        }
        EdgeKind::Window => 120,
        _ => 170,
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn noise_added_a_row_at_a_time_is_the_noise_added_to_the_whole_image() {
        let mut rng = Rng::new(7);
        let noise = PixelNoise::new(6.0, &mut rng);
        // Rows that straddle the table's end, and one longer than it.
        for (w, h) in [(512usize, 482usize), (1000, 3), (70_000, 2)] {
            let image: Vec<u8> = (0..w * h).map(|i| (i * 37 % 251) as u8).collect();
            let mut whole = image.clone();
            noise.apply(&mut whole, &mut Rng::new(99));
            let start = Rng::new(99).next_u64();
            let mut rows = image.clone();
            for (row, line) in rows.chunks_exact_mut(w).enumerate().rev() {
                noise.apply_at(start, row * w, line);
            }
            assert_eq!(rows, whole, "{w} × {h}");
            assert_ne!(rows, image, "noise was added");
        }
    }

    #[test]
    fn the_upward_image_is_every_pixel_tested_against_every_light() {
        let map = rome_maps::load_named("eb3").unwrap();
        let scene = Scene::new(&map);
        let mut rng = Rng::new(3);
        let quiet = PixelNoise::new(0.0, &mut rng);
        let size = (64, 60);
        let mut lit_pixels = 0;
        for k in 0..200 {
            let lamp = &scene.lamps[(k * 7) % scene.lamps.len()];
            let jitter = |rng: &mut Rng| (rng.uniform() - 0.5) * 2_000.0;
            let at = lamp.at + Vector::new(jitter(&mut rng), jitter(&mut rng));
            let heading = rng.uniform() * 360.0;
            let got = up_image(&scene, at, heading, size, &quiet, &mut rng);
            let (f, r) = (direction(heading), direction(heading - 90.0));
            let all: Vec<usize> = (0..scene.lamps.len()).collect();
            for (col, row, px) in got.enumerate_pixels() {
                let fwd = (0.5 - (f64::from(row) + 0.5) / f64::from(size.1)) * UP_VIEW_MM.1;
                let lat = ((f64::from(col) + 0.5) / f64::from(size.0) - 0.5) * UP_VIEW_MM.0;
                let want = if lit(&scene, &all, at + f * fwd + r * lat) {
                    LIGHT_GREY
                } else {
                    CEILING_GREY
                };
                assert_eq!(
                    px.0[0], want,
                    "pixel ({col}, {row}) at {at:?} heading {heading}"
                );
                lit_pixels += usize::from(want == LIGHT_GREY);
            }
        }
        // Lights were in view, and not always.
        assert!(lit_pixels > 0);
        let total = 200 * 64 * 60;
        assert!(
            lit_pixels > total / 20 && lit_pixels < total / 2,
            "{lit_pixels} of {total}"
        );
    }

    /// EB3 with its elevators shut, pixel noise off, and a generator.
    fn eb3_quiet() -> (Scene, Vec<bool>, PixelNoise, Rng) {
        let map = rome_maps::load_named("eb3").unwrap();
        let scene = Scene::new(&map);
        let open = vec![false; scene.elevators.len()];
        let mut rng = Rng::new(5);
        let quiet = PixelNoise::new(0.0, &mut rng);
        (scene, open, quiet, rng)
    }

    #[test]
    fn the_side_image_is_every_pixel_looked_at() {
        let (scene, open, quiet, mut rng) = eb3_quiet();
        let (w, h) = (96u32, 90u32);
        // Beside walls with plates, doors and plain stretches.
        let spots = crate::scene::corridor_spots(&scene);
        let mut kinds = std::collections::BTreeSet::new();
        for k in 0..120 {
            let at = spots[(k * 13) % spots.len()];
            let heading = rng.uniform() * 360.0;
            let got = side_image(&scene, &open, at, heading, &[], (w, h), &quiet, &mut rng);
            let axis = heading + sonar_bearing_deg(18);
            let eye = at + direction(axis) * ROBOT_RADIUS_MM;
            let focal = f64::from(w) / 2.0 / (SIDE_FOV_DEG / 2.0).to_radians().tan();
            for col in 0..w {
                let off = ((f64::from(col) + 0.5 - f64::from(w) / 2.0) / focal).atan();
                let hit = scene.ray(
                    eye,
                    axis - off.to_degrees(),
                    SIDE_RANGE_MM,
                    Sense::Sight,
                    &open,
                    None,
                );
                for row in 0..h {
                    let want = match hit {
                        None => FAR_GREY,
                        Some((t, wi, u)) => {
                            let y = f64::from(h) / 2.0 - (f64::from(row) + 0.5);
                            let z = PLATE_HEIGHT_MM + y * t * off.cos() / focal;
                            if z < 0.0 {
                                FLOOR_GREY
                            } else if z > WALL_HEIGHT_MM {
                                UPPER_CEILING_GREY
                            } else {
                                kinds.insert(format!("{:?}", scene.walls[wi].kind));
                                surface(&scene, wi, u, z)
                            }
                        }
                    };
                    assert_eq!(
                        got.get_pixel(col, row).0[0],
                        want,
                        "({col}, {row}) at {at:?} heading {heading}"
                    );
                }
            }
        }
        assert!(kinds.len() >= 3, "walls seen: {kinds:?}");
    }

    #[test]
    fn a_person_between_the_side_camera_and_the_wall_hides_it() {
        let (scene, open, quiet, _) = eb3_quiet();
        let (w, h) = (96u32, 90u32);
        // A spot and heading from which the camera looks at a wall a few
        // metres off.
        let (at, heading, axis, eye, t) = scene
            .world
            .positions
            .values()
            .map(|p| p.in_corridor())
            .flat_map(|at| (0..8).map(move |k| (at, f64::from(k) * 45.0)))
            .find_map(|(at, heading)| {
                let axis = heading + sonar_bearing_deg(18);
                let eye = at + direction(axis) * ROBOT_RADIUS_MM;
                let (t, _, _) = scene.ray(eye, axis, SIDE_RANGE_MM, Sense::Sight, &open, None)?;
                (2_500.0..8_000.0)
                    .contains(&t)
                    .then_some((at, heading, axis, eye, t))
            })
            .unwrap();
        let person = eye + direction(axis) * (t - 600.0);
        let mut r1 = Rng::new(9);
        let mut r2 = Rng::new(9);
        let bare = side_image(&scene, &open, at, heading, &[], (w, h), &quiet, &mut r1);
        let seen = side_image(
            &scene,
            &open,
            at,
            heading,
            &[person],
            (w, h),
            &quiet,
            &mut r2,
        );
        // The middle column at the plates' height (the middle row) is the
        // person; the top row, above the person's head at that range, is
        // what it was without.
        let (mid, mid_row) = (w / 2, h / 2);
        assert_eq!(seen.get_pixel(mid, mid_row).0[0], PERSON_GREY);
        assert_ne!(bare.get_pixel(mid, mid_row).0[0], PERSON_GREY);
        assert_eq!(seen.get_pixel(mid, 0).0[0], bare.get_pixel(mid, 0).0[0]);
        // A person behind the camera, or beyond the wall, hides nothing.
        let behind = eye - direction(axis) * 2_000.0;
        let beyond = eye + direction(axis) * (t + 2_000.0);
        let mut r3 = Rng::new(9);
        let none = side_image(
            &scene,
            &open,
            at,
            heading,
            &[behind, beyond],
            (w, h),
            &quiet,
            &mut r3,
        );
        assert_eq!(none, bare);
    }
}
