//! The local mapper for heading correction (§5.5).
//!
//! While the robot tracks ceiling lights the mapper builds a histogram grid
//! from the sonar (HIMM: each echo raises the certainty of the cell it comes
//! from by 3 and lowers the cells on the way by 1, on the sonar's axis only,
//! certainties 0–15). Every three lights the grid's cells are put through a
//! Hough transform: the strongest line is one hallway wall, and a guided
//! search for a parallel line at least a metre away finds the other. Their
//! orientation α is "directionless": the hallway runs along α or α + 180°,
//! whichever is nearer the goal direction Γ. The difference between that
//! and Γ is the odometry's heading error, and the mapper takes it out with
//! the base server's adjust-pose. Then it starts a new local map. Beyond
//! the thesis, it also corrects at a segment's last light when the map
//! covers 8 m or more, and whenever a map reaches 12 m before its third
//! light, so hallways with lights far apart or fewer than three lights are
//! not left uncorrected (Chapter 6's trouble spots G, N and J), and the
//! heading error stays small between corrections. A robot that has
//! driven 10 m without its heading found good (short errands between
//! nearby doors, whose maps never reach those lengths) takes a correction
//! from a map of 2 m, if it is 2° or more. A wall pair is believed
//! only when the robot's own track over the map runs along it (the
//! Navigator keeps the robot parallel to the walls): a Hough line that
//! disagrees with the track by more than a few degrees (in a fleet, and
//! more than half a metre of straying across the hallway over the track's
//! length explains) is a door recess or a side corridor, not the hallway.

use crate::board::{Board, Corridor, HeadingFix, Sem, Var};
use crate::NavError;
use rome_client::RobotClient;
use rome_maps::geometry::{direction, distance, normalize_deg, Point, Pose};
use tokio::sync::mpsc;

mod walls;
pub use walls::*;

/// [`HimmConfig::track_side_mm`] for robots in a fleet, mm: half a metre,
/// what keeping right and stepping aside move a robot across a corridor
/// over a short map.
pub const FLEET_TRACK_SIDE_MM: f64 = 500.0;

/// A track this long is straight enough to check the walls against, mm.
const MIN_TRACK_MM: f64 = 6_000.0;
/// A track this long is checked against a short map's walls, mm.
const SHORT_TRACK_MM: f64 = 1_500.0;
/// A stale heading is tried on a short stretch map this much further on
/// after a try that found it good enough, mm.
const SHORT_RETRY_MM: f64 = 1_000.0;
/// A stretch without lights is mapped until this far short of its end, mm:
/// past it the robot is in the turning space, where the walls end.
const STRETCH_END_MM: f64 = 2_000.0;

/// How the mapper works.
#[derive(Debug, Clone, PartialEq)]
pub struct HimmConfig {
    /// Lights per local map (the thesis: three).
    pub lights_per_map: i64,
    /// Half the side of the local map, mm.
    pub half_side_mm: f64,
    /// Largest correction believed, degrees.
    pub max_fix_deg: f64,
    /// Largest angle between the walls found and the robot's track over
    /// the map, degrees, beside what [`HimmConfig::track_side_mm`] adds.
    pub max_track_deg: f64,
    /// How far the robot's track over a map may stray across the hallway,
    /// mm: in a fleet a robot keeps right for others, steps aside and
    /// passes them, and a drifting odometry bends its own track, so the
    /// straight line from the map's start to the robot runs at a slant to
    /// the walls by up to atan(this / its length) more. A side corridor or
    /// a door recess still lies across the track. 0 by default: a robot
    /// alone drives the corridor's middle, and one among people strays
    /// round them, which bends the walls it maps as well
    /// ([`FLEET_TRACK_SIDE_MM`] in a fleet).
    pub track_side_mm: f64,
    /// Smallest correction worth sending, degrees.
    pub min_fix_deg: f64,
    /// A local map this long is enough for a correction at a segment's
    /// last light, mm.
    pub min_map_mm: f64,
    /// A local map this long is used for a correction even before its
    /// third light, mm.
    pub max_map_mm: f64,
    /// At any light, a local map at least this long is used for a
    /// correction (0: only every `lights_per_map` lights, as the thesis),
    /// mm.
    pub light_map_mm: f64,
    /// Whether the sideways offset is corrected too, from the walls'
    /// distance to the line of lights that the map gives.
    pub sideways: bool,
    /// Largest sideways correction believed, mm.
    pub max_shift_mm: f64,
    /// Smallest sideways correction worth sending, mm.
    pub min_shift_mm: f64,
    /// How far the width between the walls found may differ from the
    /// map's for them to be the corridor's walls, mm.
    pub width_tolerance_mm: f64,
    /// The walls are placed from the cells within this distance of the
    /// robot, mm.
    pub near_mm: f64,
    /// Whether the mapper learns how fast the odometry's heading drifts
    /// (a wheel a little larger than the other turns every straight run)
    /// and takes the drift out as the robot goes, between corrections.
    pub learn_drift: bool,
    /// How much of each correction's drift rate is learnt (0–1).
    pub drift_gain: f64,
    /// Largest drift rate believed, degrees per metre.
    pub max_drift_deg_m: f64,
    /// After this much driving without the heading found good, mm, a
    /// shorter map serves for a correction (0: never). A robot on short
    /// errands between nearby doors drives no 5.5 m map in one go, and
    /// would otherwise drift as its wheels do for as long as it works.
    pub stale_mm: f64,
    /// The shortest map that serves then, mm.
    pub short_map_mm: f64,
    /// A correction from a short map is applied only when at least this
    /// large, degrees: walls placed over 2 m are good to a degree or two,
    /// and a smaller correction is as likely their error as the heading's.
    pub short_min_fix_deg: f64,
}

impl HimmConfig {
    /// The largest angle between the walls found and a track `track_mm`
    /// long for the walls to be the hallway's, degrees.
    pub fn track_tolerance_deg(&self, track_mm: f64) -> f64 {
        let side = if track_mm > 0.0 {
            (self.track_side_mm / track_mm).atan().to_degrees()
        } else {
            90.0
        };
        self.max_track_deg + side
    }

    /// Whether a map `mapped_mm` long serves for a correction because the
    /// heading is stale: not found good over the last `since_mm` driven.
    pub fn short_map_serves(&self, mapped_mm: f64, since_mm: f64) -> bool {
        self.stale_mm > 0.0 && since_mm >= self.stale_mm && mapped_mm >= self.short_map_mm
    }
}

impl Default for HimmConfig {
    fn default() -> Self {
        HimmConfig {
            lights_per_map: 3,
            half_side_mm: 22_000.0,
            max_fix_deg: 45.0,
            max_track_deg: 6.0,
            track_side_mm: 0.0,
            min_fix_deg: 0.3,
            min_map_mm: 8_000.0,
            max_map_mm: 12_000.0,
            light_map_mm: 5_500.0,
            sideways: true,
            max_shift_mm: 3_000.0,
            min_shift_mm: 20.0,
            width_tolerance_mm: 400.0,
            near_mm: 5_000.0,
            learn_drift: true,
            drift_gain: 0.8,
            max_drift_deg_m: 2.0,
            stale_mm: 10_000.0,
            short_map_mm: 2_000.0,
            short_min_fix_deg: 2.0,
        }
    }
}

/// The odometry's heading drift as learnt from the corrections, degrees
/// per millimetre driven (positive: the odometry heading must grow), and
/// how far the robot has driven since its heading was last found.
#[derive(Debug, Clone, Default)]
struct Drift(std::sync::Arc<std::sync::Mutex<DriftState>>);

#[derive(Debug, Clone, Copy, Default)]
struct DriftState {
    rate: f64,
    since_mm: f64,
}

impl Drift {
    fn lock(&self) -> std::sync::MutexGuard<'_, DriftState> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn get(&self) -> f64 {
        self.lock().rate
    }

    /// How far the robot has driven since its heading was last found, mm.
    fn since(&self) -> f64 {
        self.lock().since_mm
    }

    /// Counts `mm` more driven.
    fn drove(&self, mm: f64) {
        self.lock().since_mm += mm;
    }

    /// The heading was just found good, or set right: what drifts from
    /// here on is counted from here.
    fn found(&self) {
        self.lock().since_mm = 0.0;
    }

    /// Learns from a correction of `fix_deg`: the drift that gathered over
    /// everything driven since the heading was last found, not over the
    /// local map alone. A robot corrected over a 6 m map after driving far
    /// on legs too short to map had drifted over all of that; taken over
    /// the 6 m alone, a 12° correction is learnt as 1.6°/m, which then
    /// turns the heading the other way as fast.
    fn learn(&self, fix_deg: f64, cfg: &HimmConfig) {
        let mut d = self.lock();
        let driven_mm = std::mem::take(&mut d.since_mm);
        if driven_mm < 3_000.0 {
            return;
        }
        let max = cfg.max_drift_deg_m / 1_000.0;
        d.rate = (d.rate + cfg.drift_gain * fix_deg / driven_mm).clamp(-max, max);
    }
}

/// The local mapper of one robot.
pub struct Himm {
    robot: RobotClient,
    board: Board,
    cfg: HimmConfig,
    drift: Drift,
}

impl Himm {
    /// A mapper.
    pub fn new(robot: RobotClient, board: Board, cfg: HimmConfig) -> Himm {
        Himm {
            robot,
            board,
            cfg,
            drift: Drift::default(),
        }
    }

    /// Takes the learnt drift out of the odometry heading as the robot
    /// drives, every half metre or so, for as long as scans come.
    async fn compensate(&self) -> Result<(), NavError> {
        let scans = self.robot.scans().await?;
        let mut last: Option<Point> = None;
        let mut driven = 0.0;
        let mut n = 0u32;
        while let Some(scan) = scans.next().await {
            scan?;
            n += 1;
            // The pose every few scans is plenty at walking speed.
            if !n.is_multiple_of(4) {
                continue;
            }
            let p = crate::track::pose_waiting(&self.robot).await?;
            let at = Pose::from(&p).at;
            if let Some(before) = last {
                let step = distance(before, at);
                // A jump is a correction or a set-pose, not driving.
                if step < 500.0 {
                    driven += step;
                    self.drift.drove(step);
                }
            }
            last = Some(at);
            let rate = self.drift.get();
            if driven >= 500.0 {
                if rate != 0.0 {
                    self.robot.adjust_pose(0, 0, rate * driven).await?;
                }
                driven = 0.0;
            }
        }
        Err(NavError::Gone("the proximity server's scan stream closed"))
    }

    /// Maps every L segment, correcting the heading every three lights,
    /// until a client call fails.
    pub async fn run(&self) -> Result<(), NavError> {
        self.board.declare().await?;
        self.board
            .client()
            .set_history(&self.board.var_name(Var::HeadingFix), 256)
            .await?;
        // down($LightDet) in a task of its own: a wait given up half-way
        // could lose a unit.
        let (tx, mut lights) = mpsc::unbounded_channel::<()>();
        let board = self.board.clone();
        let counter = rome_clock::spawn("himm light counter", async move {
            while board.down(Sem::LightDet).await.is_ok() {
                if tx.send(()).is_err() {
                    break;
                }
            }
        });
        let track = crate::track::PoseTrack::start(&self.robot).await?;
        let scans = self.robot.scans().await?;
        let mapping = async {
            loop {
                self.board.down(Sem::StartMap).await?;
                // Anyone may write the blackboard: a segment whose heading
                // or length does not decode is not mapped, and the mapper
                // waits for the next one.
                let read = async {
                    let goal: f64 = self.board.get(Var::GoalDirection).await?;
                    let total: i64 = self.board.get(Var::GoalDistance).await?;
                    Ok::<_, rome_client::ClientError>((goal, total))
                };
                let (goal, total) = match read.await {
                    Ok(v) => v,
                    Err(e) if crate::bad_value(&e) => {
                        tracing::warn!(error = %e, "mapper: a segment's GoalDirection or GoalDistance cannot be read; not mapped");
                        continue;
                    }
                    Err(e) => return Err(e.into()),
                };
                // A Planner that writes no corridor leaves the sideways
                // offset alone.
                let corridor: Option<Corridor> = self.board.get(Var::Corridor).await.ok();
                let corridor = corridor.as_ref();
                let p = crate::track::pose_waiting(&self.robot).await?;
                let mut grid = Grid::new(Pose::from(&p).at, self.cfg.half_side_mm);
                if let Some(c) = corridor.filter(|c| c.no_lights) {
                    self.map_stretch(grid, goal, total as f64, c, &scans, &track)
                        .await?;
                    continue;
                }
                let mut seen = 0i64;
                let mut in_map = 0i64;
                while seen < total {
                    tokio::select! {
                        biased;
                        Some(()) = rome_clock::idle(lights.recv()) => {
                            seen += 1;
                            in_map += 1;
                            let p = crate::track::pose_waiting(&self.robot).await?;
                            let now = Pose::from(&p).at;
                            let mapped = distance(grid.origin(), now);
                            // Every three lights as in the thesis, and also at
                            // the segment's last light once the map is long
                            // enough: a hallway with one or two lights (the
                            // thesis' trouble spots G, N and J) still gets
                            // its heading corrected.
                            let last = seen >= total && mapped >= self.cfg.min_map_mm;
                            let long = self.cfg.light_map_mm > 0.0 && mapped >= self.cfg.light_map_mm;
                            let full = Asked { now, goal, corridor, light: seen, short: false };
                            if in_map >= self.cfg.lights_per_map || last || long {
                                self.correct_anew(&mut grid, full).await?;
                                in_map = 0;
                            } else if self.cfg.short_map_serves(mapped, self.drift.since())
                                && self.correct_anew(&mut grid, Asked { short: true, ..full }).await?
                            {
                                in_map = 0;
                            }
                        }
                        scan = scans.next() => {
                            // A map that has grown this long without three
                            // lights (lights far apart) is used as it is.
                            let p0 = crate::track::pose_waiting(&self.robot).await?;
                            let now = Pose::from(&p0).at;
                            if distance(grid.origin(), now) > self.cfg.max_map_mm {
                                let full = Asked { now, goal, corridor, light: seen, short: false };
                                self.correct(&grid, &full).await?;
                                grid = Grid::new(now, self.cfg.half_side_mm);
                                in_map = 0;
                            }
                            let Some(scan) = scan else {
                                return Err(NavError::Gone("the proximity server's scan stream closed"));
                            };
                            self.add_scan(&mut grid, &scan?, &track).await?;
                        }
                    }
                }
            }
        };
        let result = if self.cfg.learn_drift {
            tokio::select! {
                biased;
                r = mapping => r,
                r = self.compensate() => r,
            }
        } else {
            mapping.await
        };
        counter.abort();
        result
    }

    /// Adds a scan to the map, from where the ring fired rather than where
    /// the robot is by the time the scan got here.
    async fn add_scan(
        &self,
        grid: &mut Grid,
        scan: &rome_schema::robot::Scan,
        track: &crate::track::PoseTrack,
    ) -> Result<(), NavError> {
        let p = track.at(&self.robot, scan.time_ms).await?;
        for (i, r) in scan.sonar_mm.iter().enumerate() {
            grid.add(p.at, p.heading.deg() + crate::navigator::bearing(i), *r);
        }
        Ok(())
    }

    /// Maps a stretch without lights `total_mm` long along `goal`,
    /// correcting whenever the map covers `light_map_mm`, as an L segment
    /// is corrected at a light: a long corridor with no lights would
    /// otherwise leave the heading to drift all the way. A stale heading
    /// is tried on a shorter map, every metre until it is set right.
    async fn map_stretch(
        &self,
        mut grid: Grid,
        goal: f64,
        total_mm: f64,
        corridor: &Corridor,
        scans: &rome_client::robot::Stream<rome_schema::robot::Scan>,
        track: &crate::track::PoseTrack,
    ) -> Result<(), NavError> {
        let start = grid.origin();
        let axis = direction(goal);
        let mut fixes = 0i64;
        let mut tried_mm = 0.0;
        while let Some(scan) = scans.next().await {
            let p = crate::track::pose_waiting(&self.robot).await?;
            let now = Pose::from(&p).at;
            let along = (now - start).dot(&axis);
            let end = along >= total_mm - STRETCH_END_MM;
            let mapped = distance(grid.origin(), now);
            if mapped >= self.cfg.light_map_mm {
                fixes += 1;
                let full = Asked {
                    now,
                    goal,
                    corridor: Some(corridor),
                    light: fixes,
                    short: false,
                };
                self.correct_anew(&mut grid, full).await?;
                tried_mm = 0.0;
            } else if mapped >= tried_mm + SHORT_RETRY_MM
                && self.cfg.short_map_serves(mapped, self.drift.since())
            {
                tried_mm = mapped;
                if self
                    .correct_anew(
                        &mut grid,
                        Asked {
                            now,
                            goal,
                            corridor: Some(corridor),
                            light: fixes + 1,
                            short: true,
                        },
                    )
                    .await?
                {
                    fixes += 1;
                    tried_mm = 0.0;
                }
            }
            if end {
                return Ok(());
            }
            self.add_scan(&mut grid, &scan?, track).await?;
        }
        Err(NavError::Gone("the proximity server's scan stream closed"))
    }

    /// [`Himm::correct`], then a new map from where the corrected odometry
    /// puts the robot (after a [`Asked::short`] map, only if it corrected);
    /// says whether the odometry was adjusted.
    async fn correct_anew(&self, grid: &mut Grid, at: Asked<'_>) -> Result<bool, NavError> {
        let adjusted = self.correct(grid, &at).await?;
        // A short map that found the heading good enough grows on, to be
        // tried again longer.
        if adjusted || !at.short {
            let p = crate::track::pose_waiting(&self.robot).await?;
            *grid = Grid::new(Pose::from(&p).at, self.cfg.half_side_mm);
        }
        Ok(adjusted)
    }

    /// Corrects the heading, and the sideways offset when the corridor is
    /// known, from `grid`, mapped from its origin to [`Asked::now`]; says
    /// whether the odometry was adjusted. A short map (a stale heading's) is
    /// checked against a shorter track, and corrects the heading only by
    /// [`HimmConfig::short_min_fix_deg`] or more, or not at all.
    async fn correct(&self, grid: &Grid, at: &Asked<'_>) -> Result<bool, NavError> {
        let Asked {
            now,
            goal,
            corridor,
            light,
            short,
        } = *at;
        let Some(walls) = hallway_walls(&grid.occupied(6), 1_000.0, Some((now, self.cfg.near_mm)))
        else {
            tracing::info!(light, short, "himm: no pair of walls in the local map");
            return Ok(false);
        };
        let alpha = walls.orientation_deg;
        let min_track = if short { SHORT_TRACK_MM } else { MIN_TRACK_MM };
        if let Some(off) = track_disagreement(alpha, grid.origin(), now, min_track) {
            if off > self.cfg.track_tolerance_deg(distance(grid.origin(), now)) {
                tracing::info!(
                    light,
                    short,
                    alpha,
                    off,
                    "himm: walls found across the track; not a hallway"
                );
                return Ok(false);
            }
        }
        let gamma = orient(alpha, goal);
        let found = normalize_deg(goal - gamma);
        let mut fix = found;
        let min_fix = if short {
            self.cfg.short_min_fix_deg
        } else {
            self.cfg.min_fix_deg
        };
        if fix.abs() > self.cfg.max_fix_deg || fix.abs() < min_fix {
            tracing::info!(light, short, fix, "himm: heading correction not applied");
            if short {
                return Ok(false);
            }
            fix = 0.0;
        }
        if self.cfg.learn_drift && fix != 0.0 {
            self.drift.learn(fix, &self.cfg);
        } else if found.abs() < self.cfg.min_fix_deg {
            self.drift.found();
        }
        let shift = corridor
            .filter(|_| self.cfg.sideways)
            .and_then(|c| sideways_fix(&walls, now, c, self.cfg.width_tolerance_mm))
            .filter(|s| s.abs() <= self.cfg.max_shift_mm && s.abs() >= self.cfg.min_shift_mm)
            .unwrap_or(0.0);
        if fix == 0.0 && shift == 0.0 {
            return Ok(false);
        }
        let left = direction(goal + 90.0);
        self.robot
            .adjust_pose(
                (left.x * shift).round() as i64,
                (left.y * shift).round() as i64,
                fix,
            )
            .await?;
        let drift_deg_m = self.drift.get() * 1_000.0;
        tracing::info!(
            light,
            short,
            alpha,
            fix,
            shift,
            drift_deg_m,
            "himm: odometry corrected"
        );
        self.board
            .set(
                Var::HeadingFix,
                &HeadingFix {
                    light,
                    hallway_deg: (gamma * 100.0).round() / 100.0,
                    correction_deg: (fix * 100.0).round() / 100.0,
                    shift_mm: shift.round(),
                },
            )
            .await?;
        Ok(true)
    }
}

/// Where and for what a correction is asked: the robot at `now` on a
/// segment along `goal` (degrees) in `corridor` when it is known, after
/// `light` lights (or stretches mapped), from a `short` map or a full one.
#[derive(Clone, Copy)]
struct Asked<'a> {
    now: Point,
    goal: f64,
    corridor: Option<&'a Corridor>,
    light: i64,
    short: bool,
}

#[cfg(test)]
mod tests;
