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
//! heading error stays small between corrections. A wall pair is believed
//! only when the robot's own track over the map runs along it (the
//! Navigator keeps the robot parallel to the walls): a Hough line that
//! disagrees with the track by more than a few degrees is a door recess or
//! a side corridor, not the hallway.

use crate::board::{Board, HeadingFix, Sem, Var};
use crate::NavError;
use rome_client::RobotClient;
use rome_maps::geometry::{direction, distance, heading_to, normalize_deg};
use tokio::sync::mpsc;

/// Cell size, mm.
pub const CELL_MM: f64 = 100.0;
/// Radius of the sonar ring: readings start at the robot's skin, mm.
pub const SONAR_RING_MM: f64 = 380.0;
/// A track this long is straight enough to check the walls against, mm.
const MIN_TRACK_MM: f64 = 6_000.0;
/// Readings beyond this are not mapped (glancing and missing echoes), mm.
pub const MAX_RANGE_MM: u32 = 5_000;

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
    /// the map, degrees.
    pub max_track_deg: f64,
    /// Smallest correction worth sending, degrees.
    pub min_fix_deg: f64,
    /// A local map this long is enough for a correction at a segment's
    /// last light, mm.
    pub min_map_mm: f64,
    /// A local map this long is used for a correction even before its
    /// third light, mm.
    pub max_map_mm: f64,
}

impl Default for HimmConfig {
    fn default() -> Self {
        HimmConfig {
            lights_per_map: 3,
            half_side_mm: 22_000.0,
            max_fix_deg: 45.0,
            max_track_deg: 6.0,
            min_fix_deg: 0.3,
            min_map_mm: 8_000.0,
            max_map_mm: 12_000.0,
        }
    }
}

/// A histogram grid (HIMM) around an origin, in the odometry frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    origin: (f64, f64),
    n: usize,
    cells: Vec<u8>,
}

impl Grid {
    /// An empty grid of `half_side_mm` around `origin`.
    pub fn new(origin: (f64, f64), half_side_mm: f64) -> Grid {
        let n = (2.0 * half_side_mm / CELL_MM).ceil() as usize;
        Grid {
            origin,
            n,
            cells: vec![0; n * n],
        }
    }

    fn cell(&self, p: (f64, f64)) -> Option<usize> {
        let half = self.n as f64 / 2.0;
        let cx = ((p.0 - self.origin.0) / CELL_MM + half).floor();
        let cy = ((p.1 - self.origin.1) / CELL_MM + half).floor();
        (cx >= 0.0 && cy >= 0.0 && cx < self.n as f64 && cy < self.n as f64)
            .then(|| cy as usize * self.n + cx as usize)
    }

    fn centre(&self, i: usize) -> (f64, f64) {
        let half = self.n as f64 / 2.0;
        let (cx, cy) = ((i % self.n) as f64, (i / self.n) as f64);
        (
            self.origin.0 + (cx + 0.5 - half) * CELL_MM,
            self.origin.1 + (cy + 0.5 - half) * CELL_MM,
        )
    }

    /// Adds one sonar reading taken at `at` along heading `axis_deg`.
    pub fn add(&mut self, at: (f64, f64), axis_deg: f64, range_mm: u32) {
        if range_mm >= MAX_RANGE_MM {
            return;
        }
        let d = direction(axis_deg);
        let total = SONAR_RING_MM + f64::from(range_mm);
        let mut s = SONAR_RING_MM;
        while s < total - CELL_MM {
            if let Some(i) = self.cell((at.0 + d.0 * s, at.1 + d.1 * s)) {
                self.cells[i] = self.cells[i].saturating_sub(1);
            }
            s += CELL_MM;
        }
        if let Some(i) = self.cell((at.0 + d.0 * total, at.1 + d.1 * total)) {
            self.cells[i] = (self.cells[i] + 3).min(15);
        }
    }

    /// Cells at least this certain, as points.
    pub fn occupied(&self, min: u8) -> Vec<((f64, f64), u8)> {
        self.cells
            .iter()
            .enumerate()
            .filter(|(_, c)| **c >= min)
            .map(|(i, c)| (self.centre(i), *c))
            .collect()
    }
}

/// The hallway's orientation from the grid: the strongest Hough line and
/// a parallel one at least `min_gap_mm` away. `None` when no such pair.
/// The result is the lines' direction, degrees in [0, 180) (North 0, West
/// 90): directionless.
pub fn hallway_orientation(points: &[((f64, f64), u8)], min_gap_mm: f64) -> Option<f64> {
    if points.len() < 10 {
        return None;
    }
    const STEPS: usize = 360; // half-degree steps over 180°
    let rho_cell = CELL_MM;
    let (cx, cy) = points
        .iter()
        .fold((0.0, 0.0), |a, (p, _)| (a.0 + p.0, a.1 + p.1));
    let (cx, cy) = (cx / points.len() as f64, cy / points.len() as f64);
    let rmax = points
        .iter()
        .map(|(p, _)| (p.0 - cx).hypot(p.1 - cy))
        .fold(0.0, f64::max);
    let nr = (2.0 * rmax / rho_cell).ceil() as usize + 2;
    let mut acc = vec![0u32; STEPS * nr];
    let trig: Vec<(f64, f64)> = (0..STEPS)
        .map(|k| {
            let t = (k as f64 * 0.5).to_radians();
            (t.cos(), t.sin())
        })
        .collect();
    for ((x, y), w) in points {
        for (k, (c, s)) in trig.iter().enumerate() {
            // The line's normal makes angle t with +x.
            let rho = (x - cx) * c + (y - cy) * s;
            let r = ((rho + rmax) / rho_cell).round() as usize;
            acc[k * nr + r] += u32::from(*w);
        }
    }
    let (best, _) = acc.iter().enumerate().max_by_key(|(_, v)| **v)?;
    let (k, r) = (best / nr, best % nr);
    // Guided search: the other wall shares the normal (±1°), a gap away.
    let gap = (min_gap_mm / rho_cell).ceil() as usize;
    let mut second = 0u32;
    for dk in -2i64..=2 {
        let kk = (k as i64 + dk).rem_euclid(STEPS as i64) as usize;
        for rr in 0..nr {
            if rr.abs_diff(r) >= gap {
                second = second.max(acc[kk * nr + rr]);
            }
        }
    }
    if second < acc[best] / 4 {
        return None;
    }
    // Normal angle t from +x; the line runs at t + 90° from +x. A
    // direction at angle φ from +x has heading φ − 90° (North 0, West 90).
    let normal_from_x = k as f64 * 0.5;
    let heading = normal_from_x; // (t + 90) − 90
    Some(heading.rem_euclid(180.0))
}

/// The angle between a directionless orientation `alpha_deg` and the
/// straight track from `from` to `to` (both in the odometry frame),
/// degrees in [0, 90]; `None` when the track is shorter than `min_mm`.
pub fn track_disagreement(
    alpha_deg: f64,
    from: (f64, f64),
    to: (f64, f64),
    min_mm: f64,
) -> Option<f64> {
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

/// The local mapper of one robot.
pub struct Himm {
    robot: RobotClient,
    board: Board,
    cfg: HimmConfig,
}

impl Himm {
    /// A mapper.
    pub fn new(robot: RobotClient, board: Board, cfg: HimmConfig) -> Himm {
        Himm { robot, board, cfg }
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
        let counter = tokio::spawn(async move {
            while board.down(Sem::LightDet).await.is_ok() {
                if tx.send(()).is_err() {
                    break;
                }
            }
        });
        let scans = self.robot.scans().await?;
        let result = async {
            loop {
                self.board.down(Sem::StartMap).await?;
                let goal: f64 = self.board.get(Var::GoalDirection).await?;
                let total: i64 = self.board.get(Var::GoalDistance).await?;
                let p = self.robot.pose().await?;
                let mut grid = Grid::new((f64::from(p.x_mm), f64::from(p.y_mm)), self.cfg.half_side_mm);
                let mut seen = 0i64;
                let mut in_map = 0i64;
                while seen < total {
                    tokio::select! {
                        Some(()) = lights.recv() => {
                            seen += 1;
                            in_map += 1;
                            let p = self.robot.pose().await?;
                            let now = (f64::from(p.x_mm), f64::from(p.y_mm));
                            let mapped = distance(grid.origin, now);
                            // Every three lights as in the thesis, and also at
                            // the segment's last light once the map is long
                            // enough: a hallway with one or two lights (the
                            // thesis' trouble spots G, N and J) still gets
                            // its heading corrected.
                            let last = seen >= total && mapped >= self.cfg.min_map_mm;
                            if in_map >= self.cfg.lights_per_map || last {
                                self.correct(&grid, now, goal, seen).await?;
                                let p = self.robot.pose().await?;
                                grid = Grid::new((f64::from(p.x_mm), f64::from(p.y_mm)), self.cfg.half_side_mm);
                                in_map = 0;
                            }
                        }
                        scan = scans.next() => {
                            // A map that has grown this long without three
                            // lights (lights far apart) is used as it is.
                            let p0 = self.robot.pose().await?;
                            let now = (f64::from(p0.x_mm), f64::from(p0.y_mm));
                            if distance(grid.origin, now) > self.cfg.max_map_mm {
                                self.correct(&grid, now, goal, seen).await?;
                                grid = Grid::new(now, self.cfg.half_side_mm);
                                in_map = 0;
                            }
                            let Some(scan) = scan else {
                                return Err(NavError::Gone("the proximity server's scan stream closed"));
                            };
                            let scan = scan?;
                            let p = self.robot.pose().await?;
                            let at = (f64::from(p.x_mm), f64::from(p.y_mm));
                            for (i, r) in scan.sonar_mm.iter().enumerate() {
                                grid.add(at, p.heading_deg + crate::navigator::bearing(i), *r);
                            }
                        }
                    }
                }
            }
        }
        .await;
        counter.abort();
        result
    }

    /// Corrects the heading from `grid`, mapped from its origin to `now`.
    async fn correct(
        &self,
        grid: &Grid,
        now: (f64, f64),
        goal: f64,
        light: i64,
    ) -> Result<(), NavError> {
        let Some(alpha) = hallway_orientation(&grid.occupied(6), 1_000.0) else {
            tracing::info!(light, "himm: no pair of walls in the local map");
            return Ok(());
        };
        if let Some(off) = track_disagreement(alpha, grid.origin, now, MIN_TRACK_MM) {
            if off > self.cfg.max_track_deg {
                tracing::info!(
                    light,
                    alpha,
                    off,
                    "himm: walls found across the track; not a hallway"
                );
                return Ok(());
            }
        }
        let gamma = orient(alpha, goal);
        let fix = normalize_deg(goal - gamma);
        if fix.abs() > self.cfg.max_fix_deg || fix.abs() < self.cfg.min_fix_deg {
            tracing::info!(light, fix, "himm: correction not applied");
            return Ok(());
        }
        self.robot.adjust_pose(0, 0, fix).await?;
        tracing::info!(light, alpha, fix, "himm: heading corrected");
        self.board
            .set(
                Var::HeadingFix,
                &HeadingFix {
                    light,
                    hallway_deg: (gamma * 100.0).round() / 100.0,
                    correction_deg: (fix * 100.0).round() / 100.0,
                },
            )
            .await?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn corridor(heading_deg: f64, width_mm: f64) -> Grid {
        // A robot driving along a corridor, its side sonars hitting both
        // walls every 40 mm (a scan every 0.1 s at 0.4 m/s).
        let mut g = Grid::new((0.0, 0.0), 12_000.0);
        let d = direction(heading_deg);
        for k in 0..250 {
            let s = -5_000.0 + 40.0 * f64::from(k);
            let at = (d.0 * s, d.1 * s);
            let side = width_mm / 2.0 - SONAR_RING_MM;
            g.add(at, heading_deg + 90.0, side as u32);
            g.add(at, heading_deg - 90.0, side as u32);
        }
        g
    }

    #[test]
    fn himm_raises_the_echo_cell_and_lowers_the_path() {
        let mut g = Grid::new((0.0, 0.0), 2_000.0);
        for _ in 0..6 {
            g.add((0.0, 0.0), 0.0, 1_000);
        }
        let hits = g.occupied(15);
        assert_eq!(hits.len(), 1);
        let ((x, y), _) = hits[0];
        assert!(x.abs() < 100.0 && (y - 1_380.0).abs() < 100.0, "{x} {y}");
        // A later echo farther along the same axis clears the old cell.
        for _ in 0..15 {
            g.add((0.0, 0.0), 0.0, 1_800);
        }
        assert!(g.occupied(1).iter().all(|((_, y), _)| *y > 2_000.0));
    }

    #[test]
    fn the_hough_transform_finds_the_corridor_orientation() {
        for heading in [0.0, 7.0, 90.0, -33.0, 180.0 - 4.0] {
            let g = corridor(heading, 3_660.0);
            let a = hallway_orientation(&g.occupied(6), 1_000.0).expect("two walls");
            let err = normalize_deg(2.0 * (a - heading)) / 2.0;
            assert!(err.abs() <= 1.0, "heading {heading}: found {a}");
        }
    }

    #[test]
    fn one_wall_alone_gives_no_orientation() {
        let mut g = Grid::new((0.0, 0.0), 12_000.0);
        for k in 0..250 {
            g.add((0.0, -5_000.0 + 40.0 * f64::from(k)), 90.0, 1_000);
        }
        assert_eq!(hallway_orientation(&g.occupied(6), 1_000.0), None);
    }

    #[test]
    fn the_directionless_rule_picks_the_side_nearer_the_goal() {
        assert_eq!(orient(3.0, 0.0), 3.0);
        assert_eq!(orient(3.0, 180.0), -177.0);
        assert_eq!(orient(178.0, 0.0), -2.0);
        assert_eq!(orient(92.0, -90.0), -88.0);
    }

    #[test]
    fn walls_are_checked_against_the_robots_track() {
        // 10 m due West (heading 90) with the walls found at 93°: 3° off.
        let off = track_disagreement(93.0, (0.0, 0.0), (-10_000.0, 0.0), 6_000.0).unwrap();
        assert!((off - 3.0).abs() < 1e-9, "{off}");
        // Directionless: walls at -87° are the same line as 93°.
        let off = track_disagreement(-87.0, (0.0, 0.0), (-10_000.0, 0.0), 6_000.0).unwrap();
        assert!((off - 3.0).abs() < 1e-9, "{off}");
        // Heading North while the walls run East-West: a side corridor.
        let off = track_disagreement(90.0, (0.0, 0.0), (0.0, 8_000.0), 6_000.0).unwrap();
        assert!((off - 90.0).abs() < 1e-9, "{off}");
        // Too short a track to tell.
        assert_eq!(
            track_disagreement(0.0, (0.0, 0.0), (0.0, 2_000.0), 6_000.0),
            None
        );
    }
}
