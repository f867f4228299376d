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

use crate::board::{Board, Corridor, HeadingFix, Sem, Var};
use crate::NavError;
use rome_client::RobotClient;
use rome_maps::geometry::{
    direction, distance, heading_to, normalize_deg, pt, Point, Pose, Vector,
};
use tokio::sync::mpsc;

/// Cell size, mm.
pub const CELL_MM: f64 = 100.0;
/// Radius of the sonar ring: readings start at the robot's skin, mm.
pub const SONAR_RING_MM: f64 = 380.0;
/// A track this long is straight enough to check the walls against, mm.
const MIN_TRACK_MM: f64 = 6_000.0;
/// A stretch without lights is mapped until this far short of its end, mm:
/// past it the robot is in the turning space, where the walls end.
const STRETCH_END_MM: f64 = 2_000.0;
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
            light_map_mm: 5_500.0,
            sideways: true,
            max_shift_mm: 3_000.0,
            min_shift_mm: 20.0,
            width_tolerance_mm: 400.0,
            near_mm: 5_000.0,
            learn_drift: true,
            drift_gain: 0.8,
            max_drift_deg_m: 2.0,
        }
    }
}

/// A histogram grid (HIMM) around an origin, in the odometry frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    origin: Point,
    n: usize,
    cells: Vec<u8>,
}

impl Grid {
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
                            let mapped = distance(grid.origin, now);
                            // Every three lights as in the thesis, and also at
                            // the segment's last light once the map is long
                            // enough: a hallway with one or two lights (the
                            // thesis' trouble spots G, N and J) still gets
                            // its heading corrected.
                            let last = seen >= total && mapped >= self.cfg.min_map_mm;
                            let long = self.cfg.light_map_mm > 0.0 && mapped >= self.cfg.light_map_mm;
                            if in_map >= self.cfg.lights_per_map || last || long {
                                self.correct_anew(&mut grid, now, goal, corridor, seen)
                                    .await?;
                                in_map = 0;
                            }
                        }
                        scan = scans.next() => {
                            // A map that has grown this long without three
                            // lights (lights far apart) is used as it is.
                            let p0 = crate::track::pose_waiting(&self.robot).await?;
                            let now = Pose::from(&p0).at;
                            if distance(grid.origin, now) > self.cfg.max_map_mm {
                                self.correct(&grid, now, goal, corridor, seen).await?;
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
    /// otherwise leave the heading to drift all the way.
    async fn map_stretch(
        &self,
        mut grid: Grid,
        goal: f64,
        total_mm: f64,
        corridor: &Corridor,
        scans: &rome_client::robot::Stream<rome_schema::robot::Scan>,
        track: &crate::track::PoseTrack,
    ) -> Result<(), NavError> {
        let start = grid.origin;
        let axis = direction(goal);
        let mut fixes = 0i64;
        while let Some(scan) = scans.next().await {
            let p = crate::track::pose_waiting(&self.robot).await?;
            let now = Pose::from(&p).at;
            let along = (now - start).dot(&axis);
            let end = along >= total_mm - STRETCH_END_MM;
            if distance(grid.origin, now) >= self.cfg.light_map_mm {
                fixes += 1;
                self.correct_anew(&mut grid, now, goal, Some(corridor), fixes)
                    .await?;
            }
            if end {
                return Ok(());
            }
            self.add_scan(&mut grid, &scan?, track).await?;
        }
        Err(NavError::Gone("the proximity server's scan stream closed"))
    }

    /// [`Himm::correct`], then a new map from where the corrected odometry
    /// puts the robot.
    async fn correct_anew(
        &self,
        grid: &mut Grid,
        now: Point,
        goal: f64,
        corridor: Option<&Corridor>,
        light: i64,
    ) -> Result<(), NavError> {
        self.correct(grid, now, goal, corridor, light).await?;
        let p = crate::track::pose_waiting(&self.robot).await?;
        *grid = Grid::new(Pose::from(&p).at, self.cfg.half_side_mm);
        Ok(())
    }

    /// Corrects the heading, and the sideways offset when the corridor is
    /// known, from `grid`, mapped from its origin to `now`.
    async fn correct(
        &self,
        grid: &Grid,
        now: Point,
        goal: f64,
        corridor: Option<&Corridor>,
        light: i64,
    ) -> Result<(), NavError> {
        let Some(walls) = hallway_walls(&grid.occupied(6), 1_000.0, Some((now, self.cfg.near_mm)))
        else {
            tracing::info!(light, "himm: no pair of walls in the local map");
            return Ok(());
        };
        let alpha = walls.orientation_deg;
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
        let found = normalize_deg(goal - gamma);
        let mut fix = found;
        if fix.abs() > self.cfg.max_fix_deg || fix.abs() < self.cfg.min_fix_deg {
            tracing::info!(light, fix, "himm: heading correction not applied");
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
            return Ok(());
        }
        let left = direction(goal + 90.0);
        self.robot
            .adjust_pose(
                (left.x * shift).round() as i64,
                (left.y * shift).round() as i64,
                fix,
            )
            .await?;
        tracing::info!(light, alpha, fix, shift, "himm: odometry corrected");
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
        Ok(())
    }
}

#[cfg(test)]
mod tests;
