//! The door-plate finder, PlFinder (§5.7).
//!
//! For each grab of the sideways camera it takes the camera's lock (so the
//! image cannot change half-way), reads a band of rows around the middle
//! (the plates hang at the camera's height), and:
//!
//! 1. makes the negative and stretches the grey levels with
//!    x' = (x/M)^e1·M below M and ((x−M)/(255−M))^e2·(255−M)+M above, with
//!    M = 0.8·255, e1 = 5, e2 = 0.5: the black plates become bright, walls
//!    and doors dark;
//! 2. thresholds;
//! 3. looks for a dark-to-bright transition along the middle row, then in
//!    the rows above it, and traces that region's border, keeping its chain
//!    code;
//! 4. finds the corners where the chain code turns sharply (curvature from
//!    the chain code over arms of k links), and takes their bounding box;
//! 5. accepts the box if its size and shape fit a plate at the distance the
//!    sideways sonar (18) measures and it carries a number: dark digits
//!    in its middle (a black bar of an elevator's marker, §5.4.6, has the
//!    size of a plate but is solid).
//!
//! Two grabs overlap when the distance D between them is less than r1 + l2
//! (Fig. 5.17–5.18); plates wholly inside the overlap were seen already and
//! are skipped. When the heading deviates from the hallway by |β| ≥ 50° the
//! geometry breaks down and the finder does nothing.

use crate::board::{Board, PlateReport, Var};
use crate::NavError;
use rome_client::RobotClient;
use rome_maps::geometry::{direction, distance, normalize_deg, Point};
use rome_maps::World;

/// M of the grey-level stretch.
pub const STRETCH_M: f64 = 0.8 * 255.0;
/// Exponent below M.
pub const STRETCH_E1: f64 = 5.0;
/// Exponent above M.
pub const STRETCH_E2: f64 = 0.5;
/// |β| from which the finder does nothing, degrees.
pub const BETA_LIMIT_DEG: f64 = 50.0;

/// How the finder works.
#[derive(Debug, Clone, PartialEq)]
pub struct PlConfig {
    /// The sideways camera.
    pub camera: String,
    /// Half its horizontal field of view, degrees.
    pub half_fov_deg: f64,
    /// Rows read around the middle, at least (more when the wall is close:
    /// [`band_rows`]).
    pub band_rows: u32,
    /// Threshold after stretching.
    pub threshold: u8,
    /// A plate's width and height, mm.
    pub plate_mm: (f64, f64),
    /// Distance from the robot's centre to the camera and the sonar, mm.
    pub ring_mm: f64,
    /// The map's plates, to name what is found (label, where).
    pub known: Vec<(String, Point)>,
}

impl PlConfig {
    /// The defaults, naming plates from a map.
    pub fn with_map(world: &World) -> PlConfig {
        PlConfig {
            known: world
                .plates
                .iter()
                .map(|p| (p.label.clone(), p.at))
                .collect(),
            ..PlConfig::default()
        }
    }
}

impl Default for PlConfig {
    fn default() -> Self {
        PlConfig {
            camera: "side".into(),
            half_fov_deg: 25.0,
            band_rows: 120,
            threshold: 200,
            plate_mm: (200.0, 150.0),
            ring_mm: 380.0,
            known: Vec::new(),
        }
    }
}

/// The non-linear grey-level stretch of §5.7, applied to a value.
pub fn stretch(x: u8) -> u8 {
    let x = f64::from(x);
    let m = STRETCH_M;
    let y = if x <= m {
        (x / m).powf(STRETCH_E1) * m
    } else {
        ((x - m) / (255.0 - m)).powf(STRETCH_E2) * (255.0 - m) + m
    };
    y.round().clamp(0.0, 255.0) as u8
}

/// Negative, stretch and threshold: `true` where a plate may be.
pub fn binarize(pixels: &[u8], threshold: u8) -> Vec<bool> {
    let lut: Vec<bool> = (0..=255u8).map(|v| stretch(255 - v) >= threshold).collect();
    pixels.iter().map(|p| lut[usize::from(*p)]).collect()
}

/// Chain-code directions, clockwise from West in image coordinates (y
/// down): W, NW, N, NE, E, SE, S, SW.
const DIRS: [(i64, i64); 8] = [
    (-1, 0),
    (-1, -1),
    (0, -1),
    (1, -1),
    (1, 0),
    (1, 1),
    (0, 1),
    (-1, 1),
];

/// A traced border: its pixels and the chain code between them.
#[derive(Debug, Clone, PartialEq)]
pub struct Border {
    /// Pixels, in order.
    pub points: Vec<(i64, i64)>,
    /// Chain code (index into the clockwise directions W, NW, N, …).
    pub chain: Vec<u8>,
    /// Whether the border came back to where it started.
    pub closed: bool,
}

/// Traces the border of the bright region containing `start`, whose left
/// neighbour is dark (Moore-neighbour tracing).
pub fn trace(img: &[bool], w: usize, h: usize, start: (i64, i64)) -> Border {
    let on = |p: (i64, i64)| {
        p.0 >= 0
            && p.1 >= 0
            && (p.0 as usize) < w
            && (p.1 as usize) < h
            && img[p.1 as usize * w + p.0 as usize]
    };
    let mut points = vec![start];
    let mut chain = Vec::new();
    let mut c = start;
    let mut back = 0usize; // the backtrack neighbour's direction from c: West
    let limit = 4 * (w + h) * 4;
    for _ in 0..limit {
        let mut moved = false;
        for j in 1..=8 {
            let k = (back + j) % 8;
            let n = (c.0 + DIRS[k].0, c.1 + DIRS[k].1);
            if on(n) {
                // The neighbour checked just before is background: it is
                // the new backtrack, seen from n.
                let prev = (back + j - 1) % 8;
                let b = (c.0 + DIRS[prev].0, c.1 + DIRS[prev].1);
                back = DIRS
                    .iter()
                    .position(|d| (n.0 + d.0, n.1 + d.1) == b)
                    .unwrap_or(0);
                chain.push(k as u8);
                c = n;
                moved = true;
                break;
            }
        }
        if !moved {
            // A single pixel.
            return Border {
                points,
                chain,
                closed: true,
            };
        }
        if c == start {
            return Border {
                points,
                chain,
                closed: true,
            };
        }
        points.push(c);
    }
    Border {
        points,
        chain,
        closed: false,
    }
}

/// Corner points of a closed border: where the direction of the chain over
/// `k` links ahead differs from the one over `k` links behind by more than
/// `min_deg`, at local maxima of that difference (after Beus and Tiu's
/// chain-code curvature).
pub fn corners(border: &Border, k: usize, min_deg: f64) -> Vec<(i64, i64)> {
    let n = border.chain.len();
    if n < 4 * k || !border.closed {
        return Vec::new();
    }
    let vec_of = |from: usize, len: usize| {
        (0..len).fold((0i64, 0i64), |a, i| {
            let d = DIRS[usize::from(border.chain[(from + i) % n])];
            (a.0 + d.0, a.1 + d.1)
        })
    };
    let curv: Vec<f64> = (0..n)
        .map(|i| {
            let ahead = vec_of(i, k);
            let behind = vec_of((i + n - k) % n, k);
            let a1 = (ahead.1 as f64).atan2(ahead.0 as f64);
            let a0 = (behind.1 as f64).atan2(behind.0 as f64);
            normalize_deg((a1 - a0).to_degrees()).abs()
        })
        .collect();
    let mut out = Vec::new();
    for i in 0..n {
        if curv[i] < min_deg {
            continue;
        }
        let peak = (1..=k).all(|j| curv[i] >= curv[(i + j) % n] && curv[i] > curv[(i + n - j) % n]);
        if peak {
            // chain[i] leaves points[i].
            out.push(border.points[i % border.points.len()]);
        }
    }
    out
}

/// A plate candidate in an image.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// left, top, right, bottom (pixels).
    pub bbox: [u32; 4],
    /// Corners found.
    pub corners: usize,
}

/// Finds plate-like regions in a binary band image: each accepted region's
/// corner bounding box. `size_px` is the expected plate size in pixels.
pub fn find_plates(img: &[bool], w: usize, h: usize, size_px: (f64, f64)) -> Vec<Candidate> {
    let mut out: Vec<Candidate> = Vec::new();
    let mut done = vec![false; w * h];
    // The middle row first, then the rows above it.
    let mid = h / 2;
    let rows: Vec<usize> = std::iter::once(mid)
        .chain((0..mid).rev().step_by(4))
        .collect();
    for y in rows {
        let mut x = 1;
        while x < w {
            let i = y * w + x;
            if img[i] && !img[i - 1] && !done[i] {
                let b = trace(img, w, h, (x as i64, y as i64));
                for p in &b.points {
                    done[p.1 as usize * w + p.0 as usize] = true;
                }
                if b.closed && b.points.len() >= 12 {
                    let k = (b.chain.len() / 24).clamp(2, 8);
                    let cs = corners(&b, k, 40.0);
                    if let Some(c) = accept(&cs, size_px) {
                        // A region the band's top or bottom row cuts off is
                        // taller than the band shows (a door, a dark
                        // opening): a plate hangs wholly inside it.
                        let cut = c.bbox[1] == 0 || c.bbox[3] as usize + 1 >= h;
                        if !cut
                            && numbered(img, w, &c.bbox)
                            && !out.iter().any(|o| overlaps(&o.bbox, &c.bbox))
                        {
                            out.push(c);
                        }
                    }
                }
            }
            x += 1;
        }
        if !out.is_empty() && y != mid {
            break;
        }
    }
    out
}

/// Whether a region carries a number: a plate's digits are holes in its
/// middle, where a black bar of the same size (an elevator's marker,
/// §5.4.6) is solid. At least a twentieth of the middle half of the box
/// must be off.
fn numbered(img: &[bool], w: usize, bbox: &[u32; 4]) -> bool {
    let [l, t, r, b] = bbox.map(|v| v as usize);
    let (qw, qh) = ((r - l) / 4, (b - t) / 4);
    let (xs, ys) = (l + qw..=r - qw, t + qh..=b - qh);
    let total = xs.clone().count() * ys.clone().count();
    let off = ys
        .flat_map(|y| xs.clone().map(move |x| y * w + x))
        .filter(|&i| !img.get(i).copied().unwrap_or(true))
        .count();
    total > 0 && off * 20 >= total
}

fn overlaps(a: &[u32; 4], b: &[u32; 4]) -> bool {
    a[0] <= b[2] && b[0] <= a[2] && a[1] <= b[3] && b[1] <= a[3]
}

/// Bounding box of the corners, accepted if it is the size and shape of a
/// plate.
fn accept(corners: &[(i64, i64)], size_px: (f64, f64)) -> Option<Candidate> {
    if !(4..=10).contains(&corners.len()) {
        return None;
    }
    let l = corners.iter().map(|c| c.0).min()?;
    let r = corners.iter().map(|c| c.0).max()?;
    let t = corners.iter().map(|c| c.1).min()?;
    let b = corners.iter().map(|c| c.1).max()?;
    let (bw, bh) = ((r - l + 1) as f64, (b - t + 1) as f64);
    let ok_w = (0.6 * size_px.0..=1.6 * size_px.0).contains(&bw);
    let ok_h = (0.6 * size_px.1..=1.6 * size_px.1).contains(&bh);
    let aspect = bw / bh;
    let want = size_px.0 / size_px.1;
    (ok_w && ok_h && (aspect - want).abs() <= 0.45 * want).then_some(Candidate {
        bbox: [l as u32, t as u32, r as u32, b as u32],
        corners: corners.len(),
    })
}

/// How many middle rows to read so that a plate at the distance the
/// sideways sonar gives fits inside them with room to spare: at least
/// `min_rows`, more for a wall close by (a plate 0.7 m off is taller than
/// EB3's 120 rows), at most the image's `height`.
pub fn band_rows(min_rows: u32, plate_h_mm: f64, focal: f64, reading_mm: f64, height: u32) -> u32 {
    // What the finder accepts is up to 1.6 times the plate's size, and the
    // reading is the slant distance, a little more than the perpendicular
    // one the plate's size follows.
    let plate_px = plate_h_mm * focal / reading_mm.max(1.0);
    let want = (2.0 * plate_px + 8.0).ceil();
    let rows = if want.is_finite() && want < f64::from(height) {
        want as u32
    } else {
        height
    };
    rows.max(min_rows).min(height) & !1
}

/// The view of one grab on the wall (Fig. 5.17): how far behind (l) and
/// ahead (r) of the camera's foot it reaches, mm, given β and the
/// perpendicular distance d.
pub fn view_on_wall(d: f64, beta_deg: f64, half_fov_deg: f64) -> (f64, f64) {
    let l = d * (beta_deg + half_fov_deg).to_radians().tan();
    let r = d * (half_fov_deg - beta_deg).to_radians().tan();
    (l, r)
}

/// The first image column not seen in the grab before (Fig. 5.18): the
/// frames overlap when D < r1 + l2.
pub fn first_new_column(
    r1: f64,
    dist: f64,
    d2: f64,
    beta2_deg: f64,
    half_fov_deg: f64,
    width: u32,
) -> u32 {
    let s = r1 - dist;
    let off = (s / d2).atan() + beta2_deg.to_radians();
    let focal = f64::from(width) / 2.0 / half_fov_deg.to_radians().tan();
    let col = f64::from(width) / 2.0 + focal * off.tan();
    col.clamp(0.0, f64::from(width)) as u32
}

/// The finder of one robot.
pub struct PlFinder {
    robot: RobotClient,
    board: Board,
    cfg: PlConfig,
}

struct Last {
    at: Point,
    r: f64,
}

impl PlFinder {
    /// A finder.
    pub fn new(robot: RobotClient, board: Board, cfg: PlConfig) -> PlFinder {
        PlFinder { robot, board, cfg }
    }

    /// Looks at every grab until a client call fails.
    pub async fn run(&self) -> Result<(), NavError> {
        self.board.declare().await?;
        self.board
            .client()
            .set_history(&self.board.var_name(Var::Plate), 256)
            .await?;
        let track = crate::track::PoseTrack::start(&self.robot).await?;
        let frames = self.robot.frames(&self.cfg.camera).await?;
        let size = self.robot.camera_size(&self.cfg.camera).await?;
        let (w, h) = (size.width, size.height);
        let focal = f64::from(w) / 2.0 / self.cfg.half_fov_deg.to_radians().tan();
        let mut last: Option<Last> = None;
        let mut reported: Vec<Point> = Vec::new();
        while let Some(frame) = frames.next().await {
            let frame = frame?;
            let Ok(goal) = self.board.get::<f64>(Var::GoalDirection).await else {
                continue;
            };
            let lock = self.robot.camera_lock(&self.cfg.camera).await?;
            let sonar = self.robot.sonar().await?;
            let reading = f64::from(sonar.sonar_mm.get(18).copied().unwrap_or(u32::MAX));
            let band = band_rows(self.cfg.band_rows, self.cfg.plate_mm.1, focal, reading, h);
            let top = h / 2 - band / 2;
            let rows: Vec<u32> = (top..top + band).collect();
            // The server hands out at most 64 rows a request.
            let mut pixels = Vec::with_capacity(rows.len() * w as usize);
            let mut grabbed_ms = None;
            let mut lost = false;
            for chunk in rows.chunks(64) {
                match self.robot.camera_rows(&self.cfg.camera, chunk).await {
                    Ok(img) => {
                        grabbed_ms = Some(img.time_ms);
                        pixels.extend(img.pixels);
                    }
                    // The camera server restarted under the lock: this
                    // frame is lost, the next one takes a new lock.
                    Err(e) if e.code() == Some(rome_schema::ErrorCode::StaleFence) => {
                        tracing::warn!(error = %e, "plfinder: the camera lock was lost; skipping the frame");
                        lost = true;
                        break;
                    }
                    Err(e) => return Err(e.into()),
                }
            }
            if lost {
                lock.unlock().await?;
                continue;
            }
            // Where the (locked, so frozen) image was grabbed.
            let pose = match grabbed_ms {
                Some(t) => track.at(&self.robot, t).await?,
                None => {
                    lock.unlock().await?;
                    continue;
                }
            };
            lock.unlock().await?;
            let beta = normalize_deg(pose.heading.deg() - goal);
            if beta.abs() >= BETA_LIMIT_DEG || reading >= 5_000.0 {
                last = None;
                continue;
            }
            let d = reading * beta.to_radians().cos();
            let heading = pose.heading;
            let eye_dir = direction(heading.deg() + 90.0);
            let eye = pose.at + eye_dir * self.cfg.ring_mm;
            let (l, r) = view_on_wall(d, beta, self.cfg.half_fov_deg);
            let start_col = match &last {
                Some(prev) => {
                    let dist = distance(prev.at, eye);
                    if dist < prev.r + l {
                        first_new_column(prev.r, dist, d, beta, self.cfg.half_fov_deg, w)
                    } else {
                        0
                    }
                }
                None => 0,
            };
            last = Some(Last { at: eye, r });
            let bin = binarize(&pixels, self.cfg.threshold);
            let size_px = (
                self.cfg.plate_mm.0 * focal / d,
                self.cfg.plate_mm.1 * focal / d,
            );
            for c in find_plates(&bin, w as usize, band as usize, size_px) {
                if c.bbox[2] < start_col {
                    continue;
                }
                let col = f64::from(c.bbox[0] + c.bbox[2]) / 2.0 + 0.5 - f64::from(w) / 2.0;
                let off = (col / focal).atan().to_degrees();
                let s = d * (off - beta).to_radians().tan();
                let normal = direction(goal + 90.0);
                let along = direction(goal);
                let at = eye + normal * d + along * s;
                if reported.iter().any(|p| distance(*p, at) < 500.0) {
                    continue;
                }
                reported.push(at);
                let near = self
                    .cfg
                    .known
                    .iter()
                    .map(|(label, p)| (label, distance(*p, at)))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .filter(|(_, e)| *e <= 1_500.0);
                let mut report = PlateReport {
                    frame: frame.frame,
                    x_mm: 0,
                    y_mm: 0,
                    bbox: [c.bbox[0], c.bbox[1] + top, c.bbox[2], c.bbox[3] + top],
                    label: near.map(|(l, _)| l.clone()),
                    error_mm: near.map(|(_, e)| e.round() as i64),
                };
                report.place(at);
                tracing::info!(?report, "plfinder: door plate");
                self.board.set(Var::Plate, &report).await?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stretch_follows_the_formula() {
        assert_eq!(stretch(0), 0);
        assert_eq!(stretch(255), 255);
        assert_eq!(stretch(204), 204);
        // (102/204)^5 · 204 = 6.4
        assert_eq!(stretch(102), 6);
        // ((230 − 204)/51)^0.5 · 51 + 204 = 240.4
        assert_eq!(stretch(230), 240);
    }

    fn plate_image(w: usize, h: usize, rect: (usize, usize, usize, usize)) -> Vec<bool> {
        let mut img = vec![false; w * h];
        for y in rect.1..rect.3 {
            for x in rect.0..rect.2 {
                img[y * w + x] = true;
            }
        }
        // Dark digits inside do not matter to the outer border: three
        // strokes two pixels wide across the middle.
        let (rw, rh) = (rect.2 - rect.0, rect.3 - rect.1);
        for k in 1..=3 {
            let x = rect.0 + rw * k / 4;
            for y in rect.1 + rh / 4..rect.3 - rh / 4 {
                img[y * w + x] = false;
                img[y * w + x + 1] = false;
            }
        }
        img
    }

    #[test]
    fn a_solid_bar_of_a_plates_size_carries_no_number_and_is_no_plate() {
        // An elevator marker's black bar (§5.4.6) after the stretch.
        let (w, h) = (200, 100);
        let mut img = vec![false; w * h];
        for y in 30..90 {
            for x in 50..130 {
                img[y * w + x] = true;
            }
        }
        assert!(find_plates(&img, w, h, (80.0, 60.0)).is_empty());
        // With digits in it, the same box is a plate.
        let img = plate_image(w, h, (50, 30, 130, 90));
        assert_eq!(find_plates(&img, w, h, (80.0, 60.0)).len(), 1);
    }

    #[test]
    fn a_rectangle_traces_closed_with_four_corners() {
        let (w, h) = (200, 100);
        let img = plate_image(w, h, (50, 30, 130, 90));
        let b = trace(&img, w, h, (50, 50));
        assert!(b.closed);
        // The outer border of an 80 × 60 rectangle.
        assert_eq!(b.points.len(), 2 * (80 + 60) - 4);
        let cs = corners(&b, 4, 40.0);
        assert_eq!(cs.len(), 4, "{cs:?}");
        for c in [(50, 30), (129, 30), (129, 89), (50, 89)] {
            assert!(
                cs.iter()
                    .any(|p| (p.0 - c.0).abs() <= 1 && (p.1 - c.1).abs() <= 1),
                "{c:?} in {cs:?}"
            );
        }
    }

    #[test]
    fn plates_of_the_expected_size_are_accepted_and_others_not() {
        let (w, h) = (200, 100);
        let img = plate_image(w, h, (50, 30, 130, 90));
        let found = find_plates(&img, w, h, (80.0, 60.0));
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].bbox, [50, 30, 129, 89]);
        // Expecting plates a third the size, the box is refused.
        assert!(find_plates(&img, w, h, (27.0, 20.0)).is_empty());
        // A tall narrow region (a poster's edge, a door frame) is refused.
        let img = plate_image(w, h, (50, 5, 70, 95));
        assert!(find_plates(&img, w, h, (80.0, 60.0)).is_empty());
    }

    #[test]
    fn the_band_grows_to_hold_a_plate_on_a_near_wall() {
        let focal = 256.0 / 25f64.to_radians().tan();
        // EB3's 120 rows hold a plate 1.5 m off; a plate 0.7 m off is 118
        // rows tall and needs more; nothing beyond the image.
        assert_eq!(band_rows(120, 150.0, focal, 1_500.0, 482), 120);
        let near = band_rows(120, 150.0, focal, 700.0, 482);
        assert!(near >= 2 * 118 && near.is_multiple_of(2), "{near}");
        assert_eq!(band_rows(120, 150.0, focal, 50.0, 482), 482);
        // A reading of nothing (or garbage) keeps the least.
        assert_eq!(band_rows(120, 150.0, focal, f64::from(u32::MAX), 482), 120);
        assert_eq!(band_rows(120, 150.0, focal, 0.0, 482), 482);
    }

    #[test]
    fn a_region_the_band_cuts_off_is_not_a_plate() {
        // A plate's size and shape, but running off the band's bottom row
        // (a dark door or opening seen through the band): refused.
        let (w, h) = (200, 60);
        let img = plate_image(w, h, (50, 10, 130, 60));
        assert!(find_plates(&img, w, h, (80.0, 50.0)).is_empty());
        let img = plate_image(w, h, (50, 0, 130, 50));
        assert!(find_plates(&img, w, h, (80.0, 50.0)).is_empty());
        // The same region one row clear of either edge is a plate.
        let img = plate_image(w, h, (50, 5, 130, 55));
        assert_eq!(find_plates(&img, w, h, (80.0, 50.0)).len(), 1);
    }

    #[test]
    fn overlap_geometry_of_figures_5_17_and_5_18() {
        // Facing the wall squarely: the view reaches d·tan(φ) each way.
        let (l, r) = view_on_wall(1_000.0, 0.0, 30.0);
        assert!((l - 577.35).abs() < 0.1 && (r - 577.35).abs() < 0.1);
        // Turned by β = 40°: the view behind grows, ahead becomes negative
        // (r < 0 when β > 30°).
        let (l, r) = view_on_wall(1_000.0, 40.0, 30.0);
        assert!(l > 2_700.0 && r < 0.0, "{l} {r}");
        // Two grabs 400 mm apart overlap by r1 + l2 − D: 754.7 mm; the new
        // part starts right of the middle column.
        let col = first_new_column(577.35, 400.0, 1_000.0, 0.0, 30.0, 512);
        assert!(col > 256 && col < 512, "{col}");
        // Grabs far apart do not overlap: everything is new.
        let col = first_new_column(577.35, 2_000.0, 1_000.0, 0.0, 30.0, 512);
        assert_eq!(col, 0);
    }
}
