//! A world that outlives its process (`rome sim --state FILE`).
//!
//! When the computer serving a real robot restarts, the robot stays where
//! it stood, and its base controller keeps its position registers and
//! goes on with the command it was given (a move of 2 m goes on to its
//! end). A
//! simulated world killed and started again would put its robots back at
//! their start with fresh odometry, so a navigation run in progress could
//! only fail. With a state file the world writes, every
//! [`KEEP_EVERY_MS`] of simulated time, each robot's true pose, its
//! odometry registers, its motion controller, its last sonar scan and its
//! base server's virtual frame; started again
//! on the same file, it takes them up. What happened between the last
//! write and the kill is lost for truth and odometry alike, so the robot
//! seems to have been set back a few centimetres, and both still agree.
//!
//! The file is JSON (`{"time_ms":…,"robots":[{"name":"r1",…}]}`), written
//! to a temporary file beside it and renamed, so a kill mid-write leaves
//! the previous state whole.

use crate::world::SimWorld;
use rome_hardware::vxy::{SavedFrame, VirtualPose};
use rome_maps::geometry::Pose;
use std::path::{Path, PathBuf};

/// How often the state is written, ms of simulated time.
pub const KEEP_EVERY_MS: u64 = 100;

/// The state file.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Kept {
    /// Simulated time of the state, ms.
    pub time_ms: u64,
    /// Every robot of the world.
    pub robots: Vec<KeptRobot>,
}

/// One robot's state.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KeptRobot {
    /// Its name.
    pub name: String,
    /// Where it truly stood: x, y (mm) and heading (degrees).
    pub truth: (f64, f64, f64),
    /// Its odometry: x, y (mm) and heading (degrees).
    pub odometry: (f64, f64, f64),
    /// Its base server's virtual frame.
    pub frame: SavedFrame,
    /// Distance it had truly travelled, mm.
    pub travelled_mm: f64,
    /// Its motion controller: the command it was carrying out goes on.
    pub drive: rome_sim::Drive,
    /// Its sonar ring's last complete cycle (mm) and when it ended, ms:
    /// a scan's time must not go back to 0 when the world is taken up.
    pub scan: (Vec<u16>, u64),
}

/// A state file that cannot be read or written.
#[derive(Debug, thiserror::Error)]
#[error("the world's state file {path}: {detail}")]
pub struct KeepError {
    /// The file.
    pub path: PathBuf,
    /// What went wrong.
    pub detail: String,
}

fn error(path: &Path, detail: impl ToString) -> KeepError {
    KeepError {
        path: path.to_path_buf(),
        detail: detail.to_string(),
    }
}

/// The world's state now.
pub fn snapshot(world: &SimWorld) -> Kept {
    // The world and the frames are locked one after the other, never
    // together: a base server locks them in its own order.
    let (time_ms, mut robots) = {
        let sim = world.lock();
        let robots: Vec<KeptRobot> = sim
            .robots()
            .iter()
            .map(|r| KeptRobot {
                name: r.name.clone(),
                truth: (r.pose.at.x, r.pose.at.y, r.pose.heading.deg()),
                odometry: (r.odometry.x, r.odometry.y, r.odometry.heading),
                frame: VirtualPose::default().save(),
                travelled_mm: r.travelled_mm,
                drive: r.drive.clone(),
                scan: (r.scan.to_vec(), r.sonar_at_ms),
            })
            .collect();
        (sim.time_ms(), robots)
    };
    for r in &mut robots {
        r.frame = rome_hardware::locked(&world.frame(&r.name)).save();
    }
    Kept { time_ms, robots }
}

/// Writes `kept` to `path` whole: a temporary file, synced, then renamed.
pub fn write(path: &Path, kept: &Kept) -> Result<(), KeepError> {
    let json = serde_json::to_vec(kept).map_err(|e| error(path, e))?;
    let tmp = path.with_extension("tmp");
    let f = std::fs::File::create(&tmp).map_err(|e| error(&tmp, e))?;
    std::io::Write::write_all(&mut &f, &json).map_err(|e| error(&tmp, e))?;
    f.sync_data().map_err(|e| error(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| error(path, e))
}

/// Reads a state file: `None` when there is none.
pub fn read(path: &Path) -> Result<Option<Kept>, KeepError> {
    match std::fs::read(path) {
        Ok(bytes) => serde_json::from_slice(&bytes)
            .map(Some)
            .map_err(|e| error(path, format!("not a world's state: {e}"))),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(error(path, e)),
    }
}

/// Puts the world back as `kept` says: its time, and every robot it names
/// where it stood, with its odometry and its base frame. Robots are
/// matched by name; the names of robots not in the world come back, so
/// the caller can say so.
pub fn restore(world: &SimWorld, kept: &Kept) -> Vec<String> {
    let mut unknown = Vec::new();
    {
        let mut sim = world.lock();
        sim.resume_at(kept.time_ms);
        for k in &kept.robots {
            let Ok(i) = sim.index(&k.name) else {
                unknown.push(k.name.clone());
                continue;
            };
            let r = sim.robot_mut(i);
            r.pose = Pose::new(k.truth.0, k.truth.1, k.truth.2);
            r.odometry.x = k.odometry.0;
            r.odometry.y = k.odometry.1;
            r.odometry.heading = k.odometry.2;
            r.travelled_mm = k.travelled_mm;
            r.drive = k.drive.clone();
            if let Ok(ranges) = <[u16; rome_sim::spec::SONARS]>::try_from(k.scan.0.as_slice()) {
                r.scan = ranges;
                r.sonar = ranges;
            }
            r.sonar_at_ms = k.scan.1;
        }
    }
    for k in kept.robots.iter().filter(|k| !unknown.contains(&k.name)) {
        *rome_hardware::locked(&world.frame(&k.name)) = VirtualPose::restore(&k.frame);
    }
    unknown
}

/// Writes the world's state to `path` every [`KEEP_EVERY_MS`] of simulated
/// time (`pace`: simulated time per real time) until the task is aborted.
/// A write that fails is said once, and tried again.
pub fn spawn_keeper(world: SimWorld, path: PathBuf, pace: f64) -> tokio::task::JoinHandle<()> {
    let every = std::time::Duration::from_secs_f64(KEEP_EVERY_MS as f64 / 1000.0 / pace.max(1e-3));
    tokio::spawn(async move {
        let mut tick = tokio::time::interval(every);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        let mut failing = false;
        let mut last = None;
        loop {
            tick.tick().await;
            let kept = snapshot(&world);
            if last.as_ref() == Some(&kept) {
                continue;
            }
            let (w, p) = (kept.clone(), path.clone());
            match tokio::task::spawn_blocking(move || write(&p, &w)).await {
                Ok(Ok(())) => {
                    failing = false;
                    last = Some(kept);
                }
                Ok(Err(e)) if !failing => {
                    failing = true;
                    tracing::warn!("{e}; the world goes on without it");
                }
                _ => {}
            }
        }
    })
}
