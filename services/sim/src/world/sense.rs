//! What a robot of the world senses: sonar firings in the ring's order,
//! infrared, bumpers, and camera images.

use super::*;
use crate::camera;
use crate::rng::Rng;
use crate::sonar::{self};
use crate::spec::{IR_RANGE_MM, ROBOT_RADIUS_MM, SONARS, SONAR_MAX_MM};
use image::GrayImage;
use rome_maps::geometry::{Point, Vector};
use std::sync::{Arc, OnceLock};

/// What the senses of every robot read and none writes, for one step.
/// Each robot is sensed from its own generator and the world as it stands,
/// so robots are sensed alike in any order and on any number of threads.
pub(super) struct Senses<'a> {
    scene: &'a Arc<Scene>,
    open: &'a [bool],
    cell_start: &'a [u32],
    cell_bodies: &'a [Body],
    walkers: &'a [Walker],
    config: &'a SimConfig,
    pixel_noise: &'a Arc<camera::PixelNoise>,
    time_ms: u64,
}

impl Senses<'_> {
    /// Fires those of robot `r`'s sonars whose turn in the ring's cycle of
    /// `period` ms came during the last `dt_ms`: one after another in
    /// [`sonar::FIRING_ORDER`], evenly spread over the cycle, each from where
    /// the robot is when it fires. The infrared is read as a cycle begins;
    /// [`Robot::sonar_at_ms`] moves on when a cycle ends. `scratch` and
    /// `near` are buffers only.
    pub(super) fn fire_due(
        &self,
        r: &mut Robot,
        period: u64,
        dt_ms: u64,
        scratch: &mut sonar::Scratch,
        near: &mut Vec<Body>,
    ) {
        let into = self.time_ms % period;
        let (at, heading) = (r.pose.at, r.pose.heading.deg());
        let forward = r.pose.heading.unit();
        for (k, &sonar) in sonar::FIRING_ORDER.iter().enumerate() {
            let fires_at = k as u64 * period / SONARS as u64;
            if (into + period - fires_at) % period >= dt_ms {
                continue;
            }
            r.sonar[sonar] = sonar::fire(
                self.scene,
                self.open,
                at,
                forward,
                sonar,
                sonar::Others::Cells {
                    start: self.cell_start,
                    bodies: self.cell_bodies,
                },
                r.timeouts[sonar],
                &self.config.noise,
                &mut r.rng,
                scratch,
            );
            if k == 0 {
                near.clear();
                let (start, bodies) = (self.cell_start, self.cell_bodies);
                let (cols, _) = self.scene.grid();
                let reach = ROBOT_RADIUS_MM * 2.0 + IR_RANGE_MM;
                let (x0, y0) = self.scene.cell_xy(at - Vector::repeat(reach));
                let (x1, y1) = self.scene.cell_xy(at + Vector::repeat(reach));
                for cy in y0..=y1 {
                    for cx in x0..=x1 {
                        let c = cy * cols + cx;
                        near.extend(
                            bodies[start[c] as usize..start[c + 1] as usize]
                                .iter()
                                .filter(|b| b.at != at),
                        );
                    }
                }
                r.infrared = sonar::infrared(
                    self.scene, self.open, at, heading, near, scratch, &mut r.rng,
                );
            }
            if k == SONARS - 1 {
                r.scan = r.sonar;
                r.sonar_at_ms = self.time_ms;
            }
        }
    }

    /// Grabs one of robot `r`'s cameras now, as [`Sim::grab_camera`]
    /// says, and keeps the image in the robot's `up` or `side`.
    pub(super) fn grab_camera<'r>(&self, r: &'r mut Robot, which: Camera) -> &'r GrayImage {
        let (at, heading) = (r.pose.at, r.pose.heading.deg());
        let size = self.config.image_size;
        let (px, mut frame) = (&**self.pixel_noise, self.frame_rng(r, which));
        let image = if r.covered & Sim::camera_bit(which) != 0 {
            GrayImage::new(size.0, size.1)
        } else {
            match which {
                Camera::Up => camera::up_image(self.scene, at, heading, size, px, &mut frame),
                Camera::Side => {
                    let people = self.people_seen(at);
                    let open = self.open;
                    camera::side_image(self.scene, open, at, heading, &people, size, px, &mut frame)
                }
            }
        };
        let kept = match which {
            Camera::Up => &mut r.up,
            Camera::Side => &mut r.side,
        };
        kept.insert(image)
    }

    /// Where a frame's pixel noise comes from: the robot, the camera and
    /// the instant alone (see [`Sim::grab_camera`]).
    fn frame_rng(&self, r: &Robot, which: Camera) -> Rng {
        Rng::new(
            r.camera_seed
                ^ self.time_ms.wrapping_mul(0x9E37_79B9_7F4A_7C15)
                ^ (u64::from(Sim::camera_bit(which)) << 56),
        )
    }

    /// The people the sideways camera at `at` could see.
    fn people_seen(&self, at: Point) -> Vec<Point> {
        self.walkers
            .iter()
            .map(|w| w.at)
            .filter(|p| nalgebra::distance(p, &at) < camera::SIDE_RANGE_MM)
            .collect()
    }

    /// What robot `r`'s camera sees now, to be drawn when asked for: the
    /// same pixels as [`Senses::grab_camera`].
    fn camera_view(&self, r: &Robot, which: Camera) -> CameraView {
        let (at, heading) = (r.pose.at, r.pose.heading.deg());
        let size = self.config.image_size;
        let kind = if r.covered & Sim::camera_bit(which) != 0 {
            View::Covered
        } else {
            match which {
                Camera::Up => View::Up(camera::Up::new(self.scene, at, heading, size)),
                Camera::Side => View::Side {
                    side: camera::Side::new(at, heading, self.people_seen(at), size),
                    open: self.open.to_vec(),
                    columns: OnceLock::new(),
                },
            }
        };
        CameraView {
            scene: self.scene.clone(),
            noise: self.pixel_noise.clone(),
            start: self.frame_rng(r, which).next_u64(),
            size,
            kind,
        }
    }
}

/// One grab of a camera, drawn a row at a time when the rows are asked
/// for: a navigation client reads three rows of the upward camera's frame
/// and a band of the sideways one's, so most of a frame is never looked
/// at. A row comes out exactly as the whole image drawn at the grab would
/// have it, noise included.
#[derive(Debug)]
pub struct CameraView {
    scene: Arc<Scene>,
    noise: Arc<camera::PixelNoise>,
    /// Where in the noise table the frame's noise starts.
    start: u64,
    size: (u32, u32),
    kind: View,
}

#[derive(Debug)]
enum View {
    /// The lens is covered: black, without noise.
    Covered,
    Up(camera::Up),
    Side {
        side: camera::Side,
        /// The doors as they stood at the grab.
        open: Vec<bool>,
        columns: OnceLock<camera::Columns>,
    },
}

impl CameraView {
    /// The image's (width, height).
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// Row `row`'s pixels into `line`, which holds one row (a row outside
    /// the image leaves it alone).
    pub fn row(&self, row: u32, line: &mut [u8]) {
        let (w, h) = (self.size.0 as usize, self.size.1);
        if row >= h || line.len() != w {
            return;
        }
        let row = row as usize;
        match &self.kind {
            View::Covered => {
                line.fill(0);
                return;
            }
            View::Up(up) => up.row(&self.scene, row, line),
            View::Side {
                side,
                open,
                columns,
            } => {
                let columns = columns.get_or_init(|| side.columns(&self.scene, open));
                side.row(&self.scene, columns, row, line);
            }
        }
        self.noise.apply_at(self.start, row * w, line);
    }

    /// The whole image.
    pub fn image(&self) -> GrayImage {
        let (w, h) = self.size;
        let mut pixels = vec![0u8; w as usize * h as usize];
        if w > 0 {
            for (row, line) in pixels.chunks_exact_mut(w as usize).enumerate() {
                self.row(row as u32, line);
            }
        }
        GrayImage::from_raw(w, h, pixels).unwrap_or_else(|| GrayImage::new(w, h))
    }
}

impl Sim {
    /// What the robots' senses read now, beside the robots and the
    /// buffers to sense them with, borrowed apart.
    pub(super) fn senses_of_robots(
        &mut self,
    ) -> (
        Senses<'_>,
        &mut [Robot],
        &mut sonar::Scratch,
        &mut Vec<Body>,
    ) {
        let senses = Senses {
            scene: &self.scene,
            open: &self.open,
            cell_start: &self.cell_start,
            cell_bodies: &self.cell_bodies,
            walkers: &self.walkers,
            config: &self.config,
            pixel_noise: &self.pixel_noise,
            time_ms: self.time_ms,
        };
        (senses, &mut self.robots, &mut self.scratch, &mut self.near)
    }

    /// Fires all of robot `i`'s sonars at once and reads its infrared now.
    pub fn sense(&mut self, i: usize) {
        if !self.cells_fresh {
            self.rebuild_cells();
        }
        let mut others = std::mem::take(&mut self.near);
        self.bodies_near(i, SONAR_MAX_MM + 2.0 * ROBOT_RADIUS_MM, &mut others);
        let r = &mut self.robots[i];
        let at = r.pose.at;
        r.sonar = sonar::scan(
            &self.scene,
            &self.open,
            at,
            r.pose.heading.deg(),
            &others,
            &r.timeouts,
            &self.config.noise,
            &mut r.rng,
            &mut self.scratch,
        );
        r.infrared = sonar::infrared(
            &self.scene,
            &self.open,
            at,
            r.pose.heading.deg(),
            &others,
            &mut self.scratch,
            &mut r.rng,
        );
        r.scan = r.sonar;
        r.sonar_at_ms = self.time_ms;
        self.near = others;
    }

    /// Covers one of robot `i`'s cameras: from now on it sees only black
    /// (a fault to inject, to see a run fail the way a blind robot would).
    pub fn cover_camera(&mut self, i: usize, which: Camera) {
        self.robots[i].covered |= Self::camera_bit(which);
    }

    fn camera_bit(which: Camera) -> u8 {
        match which {
            Camera::Up => 1,
            Camera::Side => 2,
        }
    }

    /// Grabs both of robot `i`'s cameras now.
    pub fn grab(&mut self, i: usize) {
        self.grab_camera(i, Camera::Up);
        self.grab_camera(i, Camera::Side);
    }

    /// What robot `i`'s camera sees now, drawn only as far as it is
    /// asked for ([`CameraView::row`]); the same pixels as
    /// [`Sim::grab_camera`] now, without keeping the image in the robot.
    pub fn camera_view(&mut self, i: usize, which: Camera) -> CameraView {
        let (senses, robots, _, _) = self.senses_of_robots();
        senses.camera_view(&robots[i], which)
    }

    /// Grabs one of robot `i`'s cameras now and returns the image (also
    /// kept in the robot's `up` or `side`).
    ///
    /// A frame's pixel noise follows from the robot, the camera and the
    /// instant alone, not from a generator the motion also draws on: grabs
    /// asked for in any order, or twice, or not at all, change nothing else
    /// in the world (a run repeats whatever order two servers' requests
    /// arrive in).
    pub fn grab_camera(&mut self, i: usize, which: Camera) -> GrayImage {
        let (senses, robots, _, _) = self.senses_of_robots();
        senses.grab_camera(&mut robots[i], which).clone()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use crate::spec::Noise;

    #[test]
    fn a_views_rows_drawn_in_any_order_are_the_grabbed_image() {
        let map = rome_maps::load_named("eb3").unwrap();
        let mut sim = Sim::new(
            &map,
            SimConfig {
                noise: Noise {
                    pixel: 8.0,
                    ..Noise::default()
                },
                ..SimConfig::default()
            },
        );
        let spots = crate::scene::corridor_spots(sim.scene());
        let mut robots = Vec::new();
        for k in 0..12 {
            let at = spots[(k * 97 + 5) % spots.len()];
            let name = format!("r{k}");
            robots.push(
                sim.add_robot(&name, Pose::new(at.x, at.y, k as f64 * 31.0))
                    .unwrap(),
            );
        }
        for (i, which) in robots
            .iter()
            .flat_map(|&i| [(i, Camera::Up), (i, Camera::Side)])
        {
            let view = sim.camera_view(i, which);
            let grabbed = sim.grab_camera(i, which);
            let (w, h) = view.size();
            let mut drawn = vec![0u8; (w * h) as usize];
            for row in (0..h)
                .rev()
                .step_by(3)
                .chain((0..h).filter(|r| r % 3 != (h - 1) % 3))
            {
                let s = (row * w) as usize;
                view.row(row, &mut drawn[s..s + w as usize]);
            }
            assert_eq!(&drawn, grabbed.as_raw(), "robot {i}, {which:?}");
        }
    }
}
