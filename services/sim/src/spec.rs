//! The simulation's settings, and the robot as built
//! ([`rome_schema::robot::body`], re-exported here).

pub use rome_schema::robot::body::*;

/// How noisy and slippery the world is.
#[derive(Debug, Clone, PartialEq)]
pub struct Noise {
    /// Sonar range noise: standard deviation as a fraction of the range.
    pub sonar_relative: f64,
    /// Sonar range noise floor, mm.
    pub sonar_floor_mm: f64,
    /// Chance that a sonar misses an echo it should hear.
    pub sonar_dropout: f64,
    /// Wheel slip: standard deviation of each wheel's travel, as a fraction.
    pub slip: f64,
    /// How much worse slip is on a metal floor.
    pub metal_factor: f64,
    /// Heading drift: standard deviation of the wheels' systematic
    /// difference per robot (unequal wheel diameters), as a fraction.
    pub wheel_mismatch: f64,
    /// Camera pixel noise, grey levels.
    pub pixel: f64,
}

impl Noise {
    /// The default: a plausible 1990s robot on a tiled floor.
    pub fn default_noise() -> Noise {
        Noise {
            sonar_relative: 0.01,
            sonar_floor_mm: 10.0,
            sonar_dropout: 0.002,
            slip: 0.01,
            metal_factor: 8.0,
            wheel_mismatch: 0.002,
            pixel: 4.0,
        }
    }

    /// No noise at all: for tests against hand-computed geometry.
    pub fn none() -> Noise {
        Noise {
            sonar_relative: 0.0,
            sonar_floor_mm: 0.0,
            sonar_dropout: 0.0,
            slip: 0.0,
            metal_factor: 1.0,
            wheel_mismatch: 0.0,
            pixel: 0.0,
        }
    }
}

impl Default for Noise {
    fn default() -> Self {
        Noise::default_noise()
    }
}

/// How a world runs.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Seed of every random choice: the same seed gives the same run.
    pub seed: u64,
    /// Physics step, ms.
    pub step_ms: u32,
    /// How often every robot's sonars fire, ms (0: only on request).
    pub sonar_period_ms: u32,
    /// How often every robot's cameras grab, ms (0: only on request).
    pub camera_period_ms: u32,
    /// Camera image size, pixels.
    pub image_size: (u32, u32),
    /// Noise and slip.
    pub noise: Noise,
    /// Seconds from an elevator call to its door opening.
    pub elevator_delay_s: f64,
    /// Seconds an elevator door stays open.
    pub elevator_open_s: f64,
    /// Most poses a robot's trail keeps: when full, every other pose is
    /// dropped and the trail is recorded half as often, so it covers the
    /// whole run at coarser spacing however long the simulator runs.
    pub trail_max: usize,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            seed: 1,
            step_ms: 10,
            sonar_period_ms: 100,
            camera_period_ms: 0,
            image_size: IMAGE_SIZE,
            noise: Noise::default(),
            elevator_delay_s: 5.0,
            elevator_open_s: 10.0,
            trail_max: 4_096,
        }
    }
}
