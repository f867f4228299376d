//! A simulated building for RoME: any number of differential-drive robots in
//! a world built from a StickRep map, with the sensors of §2.4–2.5 and §5.
//!
//! How this crate is laid out:
//! - [`spec`]: the robot as built (sensor layout, sizes, limits) and the
//!   simulation's settings, with where each figure comes from.
//! - [`drive`]: the LABMATE's seven operating modes (§4.6.3) with velocity
//!   and acceleration limits, and odometry in 16-bit registers that wrap.
//! - [`scene`]: the map turned into walls, corners, lights, plates, posters,
//!   metal floors and elevators, with a grid for fast queries.
//! - [`sonar`]: 24 sonars (specular echoes, glass invisible, nothing at
//!   grazing incidence, per-sensor timeouts, noise) and 8 infrared bits.
//! - [`camera`]: the upward camera (ceiling lights, Table 5.3) and the
//!   sideways one (walls, doors, plates with digits, posters, glass bricks).
//! - [`world`]: [`Sim`], the running world: robots, bumpers, wheel slip
//!   (worse on metal), elevators, simulated time in fixed steps.
//! - [`elevator`]: an elevator car travelling between floors, with doors
//!   that open and close.
//! - [`people`]: people walking the corridors to and fro.
//! - [`pace`]: simulated time as fast as possible or at a multiple of real
//!   time.
//! - [`rng`]: the seeded generator that makes a run repeatable.
//!
//! ```
//! # let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../maps/data/fig5_3.stk")).unwrap();
//! let map = rome_maps::parse("fig5_3.stk", &text).unwrap();
//! let mut sim = rome_sim::Sim::new(&map, rome_sim::SimConfig::default());
//! let r = sim.add_robot_at("rome1", "301L", -90.0).unwrap(); // heading East
//! sim.robot_mut(r).drive.move_by(2_000.0, 400.0, 400.0).unwrap();
//! sim.run_for(8_000);
//! let moved = sim.robot(r).travelled_mm;
//! assert!((moved - 2_000.0).abs() < 100.0, "{moved}");
//! ```

pub mod camera;
pub mod drive;
pub mod elevator;
pub mod pace;
pub mod people;
pub mod rng;
pub mod scene;
pub mod sonar;
pub mod spec;
pub mod world;

pub use drive::{Drive, Mode, Odometry, Registers};
pub use pace::Pacer;
pub use spec::{Noise, SimConfig};
pub use world::{Bumpers, Camera, Contacts, Pose, Robot, Sim, SimError, Walker};
