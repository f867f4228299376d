//! A running world: the building, the robots in it, simulated time.

use crate::camera;
use crate::drive::{Drive, Odometry, Registers};
use crate::rng::Rng;
use crate::scene::{self, Scene};
use crate::sonar::{self, Body};
use crate::spec::{SimConfig, ROBOT_RADIUS_MM, SONARS, SONAR_MAX_MM};
use image::GrayImage;
use rome_maps::geometry::{pt, Heading, Point, Vector};
use rome_maps::Map;
use std::sync::Arc;

/// Why a world request was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// No robot of that name.
    #[error("no robot '{0}' in the world")]
    NoRobot(String),
    /// A robot of that name exists already.
    #[error("a robot named '{0}' is already in the world")]
    Duplicate(String),
    /// A robot may not be placed there.
    #[error("cannot place robot '{name}' at ({x:.0}, {y:.0}): {why}")]
    Blocked {
        /// The robot.
        name: String,
        /// x, mm.
        x: f64,
        /// y, mm.
        y: f64,
        /// What is in the way.
        why: String,
    },
    /// No such position in the map.
    #[error(transparent)]
    Position(#[from] rome_maps::RouteError),
    /// No elevator of that number.
    #[error("no elevator '{0}' in the map")]
    NoElevator(String),
    /// A sensor timeout outside 1..=10000 mm or a sonar that does not exist.
    #[error("{0}")]
    BadSetting(String),
}

/// The true pose of a robot: the one pose type of the project.
pub use rome_maps::geometry::Pose;
mod cars;
mod sense;

pub use sense::CameraView;

/// The bumpers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Bumpers {
    /// The front bumper touches something.
    pub front: bool,
    /// The rear bumper touches something.
    pub rear: bool,
    /// Whether a touch stops the robot (Set Bumper).
    pub watch: bool,
}

impl Bumpers {
    /// The status word of Get Bumper Status: 0 none, bit 0 front, bit 1 rear.
    pub fn status(&self) -> u8 {
        u8::from(self.front) | (u8::from(self.rear) << 1)
    }
}

/// Contacts a robot has had: each time it came to touch a wall or another
/// robot counts once, however long the touch lasts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Contacts {
    /// Touches of a wall, door or other solid part of the building.
    pub wall: u32,
    /// Touches of another robot.
    pub robot: u32,
    /// Times a bumper was pressed (by either).
    pub bumper: u32,
    touching_wall: bool,
    touching_robot: bool,
    pressed: bool,
}

impl Contacts {
    /// All touches, walls and robots.
    pub fn total(&self) -> u32 {
        self.wall + self.robot
    }

    fn update(&mut self, wall: bool, robot: bool, pressed: bool) {
        self.wall += u32::from(wall && !self.touching_wall);
        self.robot += u32::from(robot && !self.touching_robot);
        self.bumper += u32::from(pressed && !self.pressed);
        (self.touching_wall, self.touching_robot, self.pressed) = (wall, robot, pressed);
    }
}

/// One robot.
#[derive(Debug, Clone)]
pub struct Robot {
    /// Its name (`rome1`).
    pub name: String,
    /// Where it truly is.
    pub pose: Pose,
    /// Its motion controller.
    pub drive: Drive,
    /// What its encoders say.
    pub odometry: Odometry,
    /// Its bumpers.
    pub bumpers: Bumpers,
    /// Last sonar ranges, mm: each sonar's latest reading.
    pub sonar: [u16; SONARS],
    /// The ranges of the ring's last complete cycle, mm: what the
    /// proximity subsystem reports, the same whenever it is read until the
    /// next cycle ends.
    pub scan: [u16; SONARS],
    /// When the ring last finished a cycle (or all sonars last fired at
    /// once), ms of simulated time.
    pub sonar_at_ms: u64,
    /// Per-sonar timeout (maximum range), mm.
    pub timeouts: [u16; SONARS],
    /// Last infrared bits.
    pub infrared: u32,
    /// Last upward image.
    pub up: Option<GrayImage>,
    /// Last sideways image.
    pub side: Option<GrayImage>,
    /// Distance truly travelled, mm.
    pub travelled_mm: f64,
    /// True poses every half second of simulated time, thinned out to at
    /// most [`SimConfig::trail_max`] over a long run.
    pub trail: Vec<Pose>,
    /// Simulated ms between trail poses: doubles each time it is thinned.
    pub trail_every_ms: u64,
    /// Touches of walls and other robots so far.
    pub contacts: Contacts,
    /// Cameras with their lens covered (a fault to inject): bit 0 up,
    /// bit 1 side.
    covered: u8,
    /// The wheels' systematic difference (heading drift).
    wheel_bias: f64,
    /// Where its cameras' pixel noise comes from (see
    /// [`Sim::grab_camera`]).
    camera_seed: u64,
    rng: Rng,
}

impl Robot {
    /// The base's position registers.
    pub fn registers(&self) -> Registers {
        self.odometry.registers()
    }

    /// Adds the pose to the trail when its period comes round, halving the
    /// trail and doubling the period when it holds `max` poses.
    fn keep_trail(&mut self, time_ms: u64, dt_ms: u64, max: usize) {
        if time_ms % self.trail_every_ms < dt_ms {
            if self.trail.len() >= max {
                let mut k = 0;
                self.trail.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.trail_every_ms *= 2;
            }
            if time_ms % self.trail_every_ms < dt_ms {
                self.trail.push(self.pose);
            }
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Door {
    Closed,
    Opening { at_ms: u64 },
    Open { until_ms: u64 },
}

/// One of a robot's two cameras (Table 5.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Camera {
    /// Looks up at the ceiling lights (§5.6).
    Up,
    /// Looks sideways at the door plates (§5.7).
    Side,
}

impl Camera {
    /// Both cameras.
    pub const ALL: [Camera; 2] = [Camera::Up, Camera::Side];

    /// The camera's name, as its server's key uses it.
    pub fn name(self) -> &'static str {
        match self {
            Camera::Up => "up",
            Camera::Side => "side",
        }
    }
}

/// A world: building, robots, time.
#[derive(Debug)]
pub struct Sim {
    /// Shared with the camera views handed out ([`Sim::camera_view`]).
    scene: Arc<Scene>,
    config: SimConfig,
    robots: Vec<Robot>,
    time_ms: u64,
    rng: Rng,
    doors: Vec<Door>,
    open: Vec<bool>,
    scratch: sonar::Scratch,
    walls: Vec<u32>,
    /// Robots by grid cell (counting sort): robots of cell c are
    /// `cell_robots[cell_start[c]..cell_start[c + 1]]`.
    cell_start: Vec<u32>,
    cell_robots: Vec<u32>,
    /// Where the robots of `cell_robots` are, in the same order.
    cell_bodies: Vec<Body>,
    /// People walking the corridors.
    walkers: Vec<Walker>,
    /// Every body's centre: the robots', then the walkers'
    /// (`cell_robots` indexes it).
    centres: Vec<Point>,
    /// Whether the cells match the robots' poses (a caller may have moved
    /// one through [`Sim::robot_mut`]).
    cells_fresh: bool,
    near: Vec<Body>,
    pixel_noise: Arc<camera::PixelNoise>,
    /// Elevator cars of a building ([`Sim::add_car`]).
    cars: Vec<cars::WorldCar>,
    /// From how many robots on, a step senses them on several threads.
    parallel_from: usize,
}

/// From how many robots on a step senses them on several threads: below,
/// handing the work out costs more than it saves.
pub const PARALLEL_FROM: usize = 16;

/// A person walking to and fro between two points of the corridors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Walker {
    /// Where the person is, mm.
    pub at: Point,
    /// Where the present leg began.
    pub from: Point,
    /// Where it ends; then the person turns back.
    pub to: Point,
    /// Walking speed, mm/s.
    pub speed_mm_s: f64,
    /// How long the person has stood waiting for a robot, ms.
    waited_ms: u64,
}

/// How long a person waits for a robot in the way before turning back, ms.
const WALKER_PATIENCE_MS: u64 = 2_000;

/// How close a wall or robot must be to press a bumper, mm.
const CONTACT_MM: f64 = 10.0;
/// How often a robot's trail is recorded, ms.
const TRAIL_MS: u64 = 500;

impl Sim {
    /// A world on a (valid) map, with no robots yet.
    pub fn new(map: &Map, config: SimConfig) -> Sim {
        let scene = Scene::new(map);
        let n = scene.elevators.len();
        let mut rng = Rng::new(config.seed);
        let pixel_noise = Arc::new(camera::PixelNoise::new(config.noise.pixel, &mut rng));
        Sim {
            rng,
            pixel_noise,
            scene: Arc::new(scene),
            config,
            robots: Vec::new(),
            time_ms: 0,
            doors: vec![Door::Closed; n],
            open: vec![false; n],
            scratch: sonar::Scratch::default(),
            walls: Vec::new(),
            cell_start: Vec::new(),
            cell_robots: Vec::new(),
            cell_bodies: Vec::new(),
            walkers: Vec::new(),
            centres: Vec::new(),
            cells_fresh: false,
            near: Vec::new(),
            parallel_from: PARALLEL_FROM,
            cars: Vec::new(),
        }
    }

    /// The building.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The settings.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// Simulated time, ms.
    pub fn time_ms(&self) -> u64 {
        self.time_ms
    }

    /// Takes up a world saved at `time_ms`: its clock goes on from there.
    /// The robots are put back through [`Sim::robot_mut`].
    pub fn resume_at(&mut self, time_ms: u64) {
        self.time_ms = time_ms;
    }

    /// The robots, in the order they were added.
    pub fn robots(&self) -> &[Robot] {
        &self.robots
    }

    /// The index of a robot by name.
    pub fn index(&self, name: &str) -> Result<usize, SimError> {
        self.robots
            .iter()
            .position(|r| r.name == name)
            .ok_or_else(|| SimError::NoRobot(name.to_string()))
    }

    /// A robot by index.
    pub fn robot(&self, i: usize) -> &Robot {
        &self.robots[i]
    }

    /// A robot's controller and odometry, to command it.
    pub fn robot_mut(&mut self, i: usize) -> &mut Robot {
        self.cells_fresh = false;
        &mut self.robots[i]
    }

    /// Adds a robot at a true pose; its odometry starts at that pose (the
    /// robot is told its true heading and position, §5).
    pub fn add_robot(&mut self, name: &str, pose: Pose) -> Result<usize, SimError> {
        if self.robots.iter().any(|r| r.name == name) {
            return Err(SimError::Duplicate(name.to_string()));
        }
        let at = pose.at;
        let blocked = |why: String| SimError::Blocked {
            name: name.to_string(),
            x: pose.at.x,
            y: pose.at.y,
            why,
        };
        if ![pose.at.x, pose.at.y, pose.heading.deg()]
            .iter()
            .all(|v| v.is_finite())
        {
            return Err(blocked(format!(
                "the pose must be finite numbers, got {pose:?}"
            )));
        }
        if let Some((d, _)) =
            self.scene
                .nearest_solid(at, ROBOT_RADIUS_MM, &self.open, &mut self.walls)
        {
            return Err(blocked(format!("a wall is {d:.0} mm from its centre")));
        }
        if let Some(other) = self
            .robots
            .iter()
            .find(|r| r.pose.dist(&pose) < 2.0 * ROBOT_RADIUS_MM)
        {
            return Err(blocked(format!("robot '{}' is there", other.name)));
        }
        let mut rng = self.rng.fork();
        let wheel_bias = rng.normal(self.config.noise.wheel_mismatch);
        let camera_seed = rng.next_u64();
        let mut odometry = Odometry {
            x: 0.0,
            y: 0.0,
            heading: 0.0,
        };
        odometry.set(pose.at.x, pose.at.y, pose.heading.deg());
        self.robots.push(Robot {
            name: name.to_string(),
            pose: Pose {
                heading: pose.heading.normalized(),
                ..pose
            },
            drive: Drive::default(),
            odometry,
            bumpers: Bumpers::default(),
            sonar: [SONAR_MAX_MM as u16; SONARS],
            scan: [SONAR_MAX_MM as u16; SONARS],
            sonar_at_ms: 0,
            timeouts: [SONAR_MAX_MM as u16; SONARS],
            infrared: 0,
            up: None,
            side: None,
            travelled_mm: 0.0,
            trail: vec![pose],
            trail_every_ms: TRAIL_MS,
            contacts: Contacts::default(),
            covered: 0,
            wheel_bias,
            camera_seed,
            rng,
        });
        let i = self.robots.len() - 1;
        self.rebuild_cells();
        self.sense(i);
        Ok(i)
    }

    /// Adds a robot in the corridor abeam a named position (`350R`),
    /// heading `heading` degrees.
    pub fn add_robot_at(
        &mut self,
        name: &str,
        position: &str,
        heading: f64,
    ) -> Result<usize, SimError> {
        let p =
            self.scene
                .world
                .position(position)
                .ok_or_else(|| rome_maps::RouteError::Unknown {
                    name: position.to_string(),
                    similar: self.scene.world.similar(position),
                })?;
        let at = p.in_corridor();
        self.add_robot(name, Pose::new(at.x, at.y, heading))
    }

    /// Sets one sonar's timeout (maximum range, mm).
    pub fn set_timeout(&mut self, i: usize, sonar: usize, mm: u16) -> Result<(), SimError> {
        if sonar >= SONARS {
            return Err(SimError::BadSetting(format!(
                "no sonar {sonar}: sonars are 0..=23"
            )));
        }
        if mm == 0 || f64::from(mm) > SONAR_MAX_MM {
            return Err(SimError::BadSetting(format!(
                "sonar timeout {mm} mm is out of range (1..=10000 mm)"
            )));
        }
        self.robots[i].timeouts[sonar] = mm;
        Ok(())
    }

    /// Calls an elevator: its door opens after the configured delay.
    pub fn call_elevator(&mut self, number: &str) -> Result<(), SimError> {
        let e = self
            .scene
            .elevators
            .iter()
            .position(|e| e.number == number)
            .ok_or_else(|| SimError::NoElevator(number.to_string()))?;
        // A car's door: the call brings the car to that floor.
        if let Some((car, floor)) = self.car_of_door(e) {
            return car
                .stop_at(&floor)
                .map_err(|e| SimError::BadSetting(e.to_string()));
        }
        if self.doors[e] == Door::Closed {
            self.doors[e] = Door::Opening {
                at_ms: self.time_ms + (self.config.elevator_delay_s * 1000.0) as u64,
            };
        }
        Ok(())
    }

    /// Whether an elevator's door is open.
    pub fn elevator_open(&self, number: &str) -> Option<bool> {
        let e = self
            .scene
            .elevators
            .iter()
            .position(|e| e.number == number)?;
        Some(self.open[e])
    }

    /// Advances the world by one physics step.
    pub fn step(&mut self) {
        let dt_ms = u64::from(self.config.step_ms.max(1));
        let dt = dt_ms as f64 / 1000.0;
        self.time_ms += dt_ms;
        for (e, door) in self.doors.iter_mut().enumerate() {
            match *door {
                Door::Opening { at_ms } if self.time_ms >= at_ms => {
                    *door = Door::Open {
                        until_ms: self.time_ms + (self.config.elevator_open_s * 1000.0) as u64,
                    };
                    self.open[e] = true;
                }
                Door::Open { until_ms } if self.time_ms >= until_ms => {
                    *door = Door::Closed;
                    self.open[e] = false;
                }
                _ => {}
            }
        }
        if !self.cars.is_empty() {
            self.step_cars(dt_ms);
        }
        if !self.cells_fresh {
            self.rebuild_cells();
        }
        for i in 0..self.robots.len() {
            self.move_robot(i, dt);
        }
        if !self.walkers.is_empty() {
            self.move_walkers(dt);
        }
        // Once per step, for the sensors now and the motion next step.
        self.rebuild_cells();
        let sonar_period = u64::from(self.config.sonar_period_ms);
        let camera_due = self.config.camera_period_ms > 0
            && self.time_ms % u64::from(self.config.camera_period_ms) < dt_ms;
        let trail_max = self.config.trail_max.max(2);
        let time_ms = self.time_ms;
        let parallel = self.robots.len() >= self.parallel_from;
        let (senses, robots, scratch, near) = self.senses_of_robots();
        let each = |r: &mut Robot, scratch: &mut sonar::Scratch, near: &mut Vec<Body>| {
            if sonar_period > 0 {
                senses.fire_due(r, sonar_period, dt_ms, scratch, near);
            }
            if camera_due {
                senses.grab_camera(r, Camera::Up);
                senses.grab_camera(r, Camera::Side);
            }
            r.keep_trail(time_ms, dt_ms, trail_max);
        };
        if parallel {
            // On the threads of the rayon pool this runs in (every core by
            // default), each with buffers of its own.
            use rayon::prelude::*;
            robots.par_iter_mut().for_each_init(
                || (sonar::Scratch::default(), Vec::new()),
                |(scratch, near), r| each(r, scratch, near),
            );
        } else {
            for r in robots {
                each(r, scratch, near);
            }
        }
    }

    /// Senses the robots on several threads when there are at least
    /// `robots` of them ([`PARALLEL_FROM`] by default; `usize::MAX` never).
    /// The readings are the same either way, bit for bit.
    pub fn sense_in_parallel_from(&mut self, robots: usize) {
        self.parallel_from = robots;
    }

    /// Runs for `ms` of simulated time.
    pub fn run_for(&mut self, ms: u64) {
        let end = self.time_ms + ms;
        while self.time_ms < end {
            self.step();
        }
    }

    fn rebuild_cells(&mut self) {
        self.centres.clear();
        self.centres.extend(self.robots.iter().map(|r| r.pose.at));
        self.centres.extend(self.walkers.iter().map(|w| w.at));
        let (cols, rows) = self.scene.grid();
        self.cell_start.clear();
        self.cell_start.resize(cols * rows + 1, 0);
        let scene = &self.scene;
        let cell = |p: Point| {
            let (cx, cy) = scene.cell_xy(p);
            cy * cols + cx
        };
        for &p in &self.centres {
            self.cell_start[cell(p) + 1] += 1;
        }
        for c in 1..self.cell_start.len() {
            self.cell_start[c] += self.cell_start[c - 1];
        }
        let n_bodies = self.centres.len();
        self.cell_robots.clear();
        self.cell_robots.resize(n_bodies, 0);
        // cell_start[c + 1] is where cell c ends; fill each cell from its
        // end backwards, which leaves cell_start[c] where it starts.
        for (i, &p) in self.centres.iter().enumerate().rev() {
            let c = cell(p);
            self.cell_start[c + 1] -= 1;
            self.cell_robots[self.cell_start[c + 1] as usize] = i as u32;
        }
        self.cell_start.rotate_left(1);
        let n = self.cell_start.len();
        self.cell_start[n - 1] = n_bodies as u32;
        self.cell_bodies.clear();
        let centres = &self.centres;
        self.cell_bodies
            .extend(self.cell_robots.iter().map(|&i| Body {
                at: centres[i as usize],
            }));
        self.cells_fresh = true;
    }

    /// Other robots within `r` of robot `i` (by cells; a superset), into
    /// `out`.
    fn bodies_near(&self, i: usize, r: f64, out: &mut Vec<Body>) {
        out.clear();
        let me = &self.robots[i];
        let (cols, _) = self.scene.grid();
        let (x0, y0) = self.scene.cell_xy(me.pose.at - Vector::repeat(r));
        let (x1, y1) = self.scene.cell_xy(me.pose.at + Vector::repeat(r));
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                let c = cy * cols + cx;
                let (a, b) = (self.cell_start[c] as usize, self.cell_start[c + 1] as usize);
                for &j in &self.cell_robots[a..b] {
                    if j as usize != i {
                        out.push(Body {
                            at: self.centres[j as usize],
                        });
                    }
                }
            }
        }
    }

    /// Adds a person who walks from `from` to `to` and back at `speed_mm_s`,
    /// for ever, starting at `from`. Robots' sonars, infrared and bumpers
    /// meet a person as they meet another robot; a person waits while a
    /// robot stands in the way, and turns back after two seconds of it.
    pub fn add_walker(&mut self, from: Point, to: Point, speed_mm_s: f64) -> usize {
        self.walkers.push(Walker {
            at: from,
            from,
            to,
            speed_mm_s: speed_mm_s.max(0.0),
            waited_ms: 0,
        });
        self.cells_fresh = false;
        self.walkers.len() - 1
    }

    /// The people walking the corridors.
    pub fn walkers(&self) -> &[Walker] {
        &self.walkers
    }

    /// The people, to move one by hand (a test, a placement).
    pub fn walkers_mut(&mut self) -> &mut [Walker] {
        self.cells_fresh = false;
        &mut self.walkers
    }

    fn move_walkers(&mut self, dt: f64) {
        let n = self.robots.len();
        let dt_ms = (dt * 1_000.0).round() as u64;
        for w in &mut self.walkers {
            let leg = w.to - w.from;
            let len = leg.norm();
            if len < 1.0 {
                continue;
            }
            let next = w.at + leg / len * (w.speed_mm_s * dt);
            let clear = (2.0 * ROBOT_RADIUS_MM + CONTACT_MM).powi(2);
            // Robots are the first n centres, where they were at the
            // start of the step.
            if self.centres[..n.min(self.centres.len())]
                .iter()
                .any(|r| nalgebra::distance_squared(r, &next) < clear)
            {
                // Nobody stands for ever in front of a robot: after a
                // while the person turns back the way they came.
                w.waited_ms += dt_ms;
                if w.waited_ms >= WALKER_PATIENCE_MS {
                    w.waited_ms = 0;
                    std::mem::swap(&mut w.from, &mut w.to);
                }
                continue;
            }
            w.waited_ms = 0;
            if (next - w.from).norm() >= len {
                w.at = w.to;
                std::mem::swap(&mut w.from, &mut w.to);
            } else {
                w.at = next;
            }
        }
    }

    fn move_robot(&mut self, i: usize, dt: f64) {
        let mut others = std::mem::take(&mut self.near);
        self.bodies_near(i, 3.0 * ROBOT_RADIUS_MM, &mut others);
        let on_metal = {
            let r = &self.robots[i];
            !self.scene.metal.is_empty() && self.scene.on_metal(r.pose.at)
        };
        let noise = &self.config.noise;
        let r = &mut self.robots[i];
        let (vl, vr) = r.drive.step(dt, r.odometry.heading);
        let (dl, dr) = (vl * dt, vr * dt);
        r.odometry.advance(dl, dr);
        let mut blocked = false;
        let mut walls_fresh = false;
        if dl != 0.0 || dr != 0.0 {
            let slip = noise.slip * if on_metal { noise.metal_factor } else { 1.0 };
            let tl = dl * (1.0 + r.wheel_bias + r.rng.normal(slip));
            let tr = dr * (1.0 - r.wheel_bias + r.rng.normal(slip));
            let mut truth = Odometry {
                x: r.pose.at.x,
                y: r.pose.at.y,
                heading: r.pose.heading.deg(),
            };
            truth.advance(tl, tr);
            let to = pt(truth.x, truth.y);
            // Walls near enough for this move and for the bumpers after it.
            let moved = nalgebra::distance(&to, &r.pose.at);
            self.scene.walls_near_unsorted(
                to,
                ROBOT_RADIUS_MM + CONTACT_MM + moved,
                &mut self.walls,
            );
            walls_fresh = true;
            // A body stops where it would touch a wall or another robot;
            // the wheels may go on turning (and the encoders counting).
            let touches =
                scene::nearest_of(&self.scene, &self.walls, to, ROBOT_RADIUS_MM, &self.open)
                    .is_some()
                    || others.iter().any(|o| {
                        // Two robots that move in one step may end a hair
                        // inside each other: only a move deeper in is
                        // stopped, or they could never part.
                        let after = nalgebra::distance_squared(&o.at, &to);
                        after < (2.0 * ROBOT_RADIUS_MM).powi(2)
                            && after < nalgebra::distance_squared(&o.at, &r.pose.at)
                    });
            // A turn in place is never blocked: the hair that slipping
            // wheels move the body would otherwise stop every turn of a
            // robot that touches something, and two robots touching side
            // by side could never turn away from each other.
            let in_place = (vl + vr).abs() < 1e-9;
            blocked = touches && !in_place;
            let heading = Heading::from_deg(truth.heading);
            if touches {
                // Turning in place never makes a disc touch anything new.
                r.pose.heading = heading;
            } else {
                r.travelled_mm += nalgebra::distance(&to, &r.pose.at);
                r.pose = Pose { at: to, heading };
            }
        }
        let at = r.pose.at;
        if !walls_fresh {
            self.scene
                .walls_near_unsorted(at, ROBOT_RADIUS_MM + CONTACT_MM, &mut self.walls);
        }
        let wall = scene::nearest_of(
            &self.scene,
            &self.walls,
            at,
            ROBOT_RADIUS_MM + CONTACT_MM,
            &self.open,
        )
        .map(|(_, q)| q);
        let robot = others
            .iter()
            .find(|o| {
                nalgebra::distance_squared(&o.at, &at)
                    < (2.0 * ROBOT_RADIUS_MM + CONTACT_MM).powi(2)
            })
            .map(|o| nalgebra::center(&o.at, &at));
        r.bumpers.front = false;
        r.bumpers.rear = false;
        if let Some(c) = wall.or(robot) {
            let towards = (c - at).dot(&r.pose.heading.unit());
            r.bumpers.front = towards >= 0.0;
            r.bumpers.rear = towards < 0.0;
        }
        r.contacts
            .update(wall.is_some(), robot.is_some(), r.bumpers.status() != 0);
        if blocked && r.bumpers.watch {
            r.drive.stop(true);
        }
        self.near = others;
    }
}
