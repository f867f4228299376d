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
use rome_maps::geometry::{direction, Point};
use rome_maps::model::EdgeKind;

/// Grey of the ceiling between lights.
pub const CEILING_GREY: u8 = 60;
/// Grey of a lit ceiling light.
pub const LIGHT_GREY: u8 = 235;
/// Grey of a door plate's background.
pub const PLATE_GREY: u8 = 15;
/// Grey of a plate's digits.
pub const DIGIT_GREY: u8 = 245;

const FLOOR_GREY: u8 = 70;
const UPPER_CEILING_GREY: u8 = 205;
const FAR_GREY: u8 = 30;
const WALL_HEIGHT_MM: f64 = 2_700.0;
const SIDE_RANGE_MM: f64 = 15_000.0;

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

    /// A reader over the table from a random start.
    fn reader(&self, rng: &mut Rng) -> impl FnMut(u8) -> u8 + '_ {
        let mut k = rng.next_u64() as usize;
        let stride = 1 + 2 * (rng.next_u64() as usize % 1000);
        move |v| {
            if self.table.is_empty() {
                return v;
            }
            k = k.wrapping_add(stride);
            (i16::from(v) + self.table[k & 0xFFFF]).clamp(0, 255) as u8
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
    let mut noisy = pixel_noise.reader(rng);
    let (w, h) = size;
    let f = direction(heading);
    let r = direction(heading - 90.0);
    let reach = (UP_VIEW_MM.0.hypot(UP_VIEW_MM.1) + LIGHT_SIZE_MM.1) / 2.0 + 100.0;
    let near: Vec<usize> = scene
        .lamps
        .iter()
        .enumerate()
        .filter(|(_, l)| nalgebra::distance(&l.at, &at) <= reach)
        .map(|(i, _)| i)
        .collect();
    let mut img = GrayImage::new(w, h);
    for row in 0..h {
        let fwd = (0.5 - (f64::from(row) + 0.5) / f64::from(h)) * UP_VIEW_MM.1;
        for col in 0..w {
            let lat = ((f64::from(col) + 0.5) / f64::from(w) - 0.5) * UP_VIEW_MM.0;
            let p = at + f * fwd + r * lat;
            let v = if !near.is_empty() && lit(scene, &near, p) {
                LIGHT_GREY
            } else {
                CEILING_GREY
            };
            img.put_pixel(col, row, image::Luma([noisy(v)]));
        }
    }
    img
}

/// The sideways camera's image, looking along sonar 18 from the robot's
/// side at the height of the door plates.
#[allow(clippy::too_many_arguments)]
pub fn side_image(
    scene: &Scene,
    open: &[bool],
    at: Point,
    heading: f64,
    size: (u32, u32),
    pixel_noise: &PixelNoise,
    rng: &mut Rng,
) -> GrayImage {
    let mut noisy = pixel_noise.reader(rng);
    let (w, h) = size;
    let axis = heading + sonar_bearing_deg(18);
    let ad = direction(axis);
    let eye = at + ad * ROBOT_RADIUS_MM;
    let focal = f64::from(w) / 2.0 / (SIDE_FOV_DEG / 2.0).to_radians().tan();
    let mut img = GrayImage::new(w, h);
    for col in 0..w {
        let x = f64::from(col) + 0.5 - f64::from(w) / 2.0;
        let off = (x / focal).atan();
        let ray = axis - off.to_degrees();
        let hit = scene.ray(eye, ray, SIDE_RANGE_MM, Sense::Sight, open, None);
        for row in 0..h {
            let v = match hit {
                None => FAR_GREY,
                Some((t, wi, u)) => {
                    let depth = t * off.cos();
                    let y = f64::from(h) / 2.0 - (f64::from(row) + 0.5);
                    let z = PLATE_HEIGHT_MM + y * depth / focal;
                    if z < 0.0 {
                        FLOOR_GREY
                    } else if z > WALL_HEIGHT_MM {
                        UPPER_CEILING_GREY
                    } else {
                        surface(scene, wi, u, z)
                    }
                }
            };
            img.put_pixel(col, row, image::Luma([noisy(v)]));
        }
    }
    img
}

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
            if u < 60.0 || u > wall.len - 60.0 || (2_050.0..2_110.0).contains(&z) {
                60
            } else if z > 2_110.0 {
                170
            } else {
                105
            }
        }
        EdgeKind::Elevator => 140,
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
