//! The barcode reader that finds an elevator's marker (§5.4.6, Fig. 5.11)
//! in a camera image, row by row, as the thesis read it with
//! `CameraGetRow()`.
//!
//! Each row is cut into black and white runs at the middle of its grey
//! range. A pattern starts at a white-to-black transition and is 3, 5 or
//! 7 runs whose widths, against the smallest stripe, are 1 or 3 (black)
//! and 1 (white), 2N + 1 stripes in all, with white on both sides. The
//! stripes give the code ([`Code::from_stripes`]). Patterns of the same
//! code in neighbouring rows and the same columns are merged, and a
//! marker is accepted when it spans enough rows for its width: a marker
//! is q/p ≈ 1.7 stripes tall, so a stripe pattern that is much shorter
//! (a line of text) or much taller (a grille) is not one. Last, the paper
//! must frame it: a stripe above and below it, the row across the marker
//! is white. White digits on a black door plate can make a row that
//! reads as a code for a few rows; the plate above and below them is
//! black. Bars that go on up and down (a grille, blinds) are not framed
//! either.

use image::GrayImage;
use rome_maps::marker::{Code, P_MM, Q_MM, STRIPES};
use std::ops::Range;

/// How the reader works.
#[derive(Debug, Clone, PartialEq)]
pub struct ReaderConfig {
    /// Least difference between a row's darkest and brightest pixels for
    /// it to be read at all, grey levels.
    pub contrast: u8,
    /// Narrowest stripe read, pixels: below this a stripe is noise.
    pub min_stripe_px: f64,
    /// Fewest rows a marker spans.
    pub min_rows: u32,
    /// How far a run may be from its whole number of stripes, as a
    /// fraction of a stripe (plus one pixel for the edges).
    pub tolerance: f64,
}

impl Default for ReaderConfig {
    fn default() -> Self {
        ReaderConfig {
            contrast: 80,
            min_stripe_px: 2.0,
            min_rows: 3,
            tolerance: 0.35,
        }
    }
}

/// A marker found in an image.
#[derive(Debug, Clone, PartialEq)]
pub struct Found {
    /// Its code.
    pub code: Code,
    /// The column of its middle (left edge 0).
    pub column: f64,
    /// The rows it spans.
    pub rows: Range<u32>,
    /// A stripe's width, pixels: p at the marker's distance.
    pub stripe_px: f64,
}

impl Found {
    /// How far the marker is, mm, for a camera whose focal length is
    /// `focal_px` pixels.
    pub fn distance_mm(&self, focal_px: f64) -> f64 {
        P_MM * focal_px / self.stripe_px
    }

    /// Its bearing off the camera's axis, degrees, positive to the left
    /// (counter-clockwise), for an image `width` pixels wide.
    pub fn bearing_deg(&self, width: u32, focal_px: f64) -> f64 {
        -((self.column - f64::from(width) / 2.0) / focal_px)
            .atan()
            .to_degrees()
    }
}

/// One row's pattern: its code, first and last column (exclusive) and
/// stripe width.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowHit {
    /// The code its stripes give.
    pub code: Code,
    /// Its first column.
    pub start: u32,
    /// One past its last column.
    pub end: u32,
    /// A stripe's width, pixels.
    pub stripe_px: f64,
    /// The grey level between its black and white.
    pub threshold: u8,
}

/// Every marker pattern along one row of grey levels.
pub fn read_row(row: &[u8], cfg: &ReaderConfig) -> Vec<RowHit> {
    let (Some(&lo), Some(&hi)) = (row.iter().min(), row.iter().max()) else {
        return Vec::new();
    };
    if hi - lo < cfg.contrast {
        return Vec::new();
    }
    let threshold = (u16::from(lo) + u16::from(hi)) / 2;
    // Runs of (black, first column, width).
    let mut runs: Vec<(bool, usize, usize)> = Vec::new();
    for (i, &px) in row.iter().enumerate() {
        let black = u16::from(px) < threshold;
        match runs.last_mut() {
            Some((b, _, w)) if *b == black => *w += 1,
            _ => runs.push((black, i, 1)),
        }
    }
    let mut hits = Vec::new();
    // A pattern starts on a black run after a white one and ends on a
    // black run before a white one.
    for first in 1..runs.len() {
        if !runs[first].0 {
            continue;
        }
        for count in [3, 5, 7] {
            let Some(after) = runs.get(first + count) else {
                break;
            };
            let found = pattern(&runs[first..first + count], runs[first - 1], *after, cfg);
            if let Some(hit) = found {
                hits.push(RowHit {
                    threshold: threshold as u8,
                    ..hit
                });
                break;
            }
        }
    }
    hits
}

/// The code of `runs` (black first, alternating), if their widths are a
/// marker's and the white on both sides is at least half a stripe.
fn pattern(
    runs: &[(bool, usize, usize)],
    before: (bool, usize, usize),
    after: (bool, usize, usize),
    cfg: &ReaderConfig,
) -> Option<RowHit> {
    let start = runs[0].1;
    let end = runs[runs.len() - 1].1 + runs[runs.len() - 1].2;
    let stripe = (end - start) as f64 / STRIPES as f64;
    if stripe < cfg.min_stripe_px
        || (before.2 as f64) < 0.5 * stripe
        || (after.2 as f64) < 0.5 * stripe
    {
        return None;
    }
    let mut stripes = [false; STRIPES];
    let mut at = 0usize;
    for &(black, _, width) in runs {
        let n = (width as f64 / stripe).round();
        let fits = (width as f64 - n * stripe).abs() <= cfg.tolerance * stripe + 1.0;
        let allowed = if black {
            n == 1.0 || n == 3.0
        } else {
            n == 1.0
        };
        if !fits || !allowed || at + n as usize > STRIPES {
            return None;
        }
        for s in &mut stripes[at..at + n as usize] {
            *s = black;
        }
        at += n as usize;
    }
    if at != STRIPES {
        return None;
    }
    Some(RowHit {
        code: Code::from_stripes(&stripes)?,
        start: start as u32,
        end: end as u32,
        stripe_px: stripe,
        threshold: 0,
    })
}

/// A marker being gathered row by row.
struct Gather {
    code: Code,
    rows: Range<u32>,
    columns: Range<u32>,
    threshold: u8,
    middle: f64,
    stripe_sum: f64,
    hits: u32,
}

/// Every marker in `rows` of `image` (the thesis scans the middle half
/// while it looks for one, then only the rows of the marker found).
pub fn find(image: &GrayImage, rows: Range<u32>, cfg: &ReaderConfig) -> Vec<Found> {
    let width = image.width() as usize;
    let raw = image.as_raw();
    let mut open: Vec<Gather> = Vec::new();
    let mut done: Vec<Gather> = Vec::new();
    for y in rows.start..rows.end.min(image.height()) {
        let from = y as usize * width;
        let Some(line) = raw.get(from..from + width) else {
            break;
        };
        for hit in read_row(line, cfg) {
            let middle = f64::from(hit.start + hit.end) / 2.0;
            // The same marker one or two rows on: same code, same place.
            let same = open.iter_mut().find(|g| {
                g.code == hit.code
                    && g.rows.end + 2 >= y
                    && (g.middle - middle).abs() <= hit.stripe_px
            });
            match same {
                Some(g) => {
                    g.rows.end = y + 1;
                    g.columns = g.columns.start.min(hit.start)..g.columns.end.max(hit.end);
                    g.middle = middle;
                    g.stripe_sum += hit.stripe_px;
                    g.hits += 1;
                }
                None => open.push(Gather {
                    code: hit.code,
                    rows: y..y + 1,
                    columns: hit.start..hit.end,
                    threshold: hit.threshold,
                    middle,
                    stripe_sum: hit.stripe_px,
                    hits: 1,
                }),
            }
        }
        let (ended, going): (Vec<Gather>, Vec<Gather>) =
            open.into_iter().partition(|g| g.rows.end + 2 < y);
        done.extend(ended);
        open = going;
    }
    done.extend(open);
    done.into_iter()
        .filter_map(|g| {
            let stripe_px = g.stripe_sum / f64::from(g.hits);
            // A marker is q/p stripes tall: allow from 0.6 to 1.6 times
            // that (the rows at its top and bottom edge may be lost).
            let tall = f64::from(g.rows.len() as u32) / stripe_px / (Q_MM / P_MM);
            let framed = [
                f64::from(g.rows.start) - stripe_px,
                f64::from(g.rows.end - 1) + stripe_px,
            ]
            .iter()
            .all(|&y| white_row(image, y, &g.columns, g.threshold));
            let ok = g.hits >= cfg.min_rows && (0.6..=1.6).contains(&tall) && framed;
            ok.then_some(Found {
                code: g.code,
                column: g.middle,
                rows: g.rows,
                stripe_px,
            })
        })
        .collect()
}

/// Whether row `y` of `image` is white (nine pixels in ten at least)
/// across `columns`; a row off the image is not.
fn white_row(image: &GrayImage, y: f64, columns: &Range<u32>, threshold: u8) -> bool {
    let y = y.round();
    if y < 0.0 || y >= f64::from(image.height()) || columns.is_empty() {
        return false;
    }
    let white = columns
        .clone()
        .filter(|&x| image.get_pixel(x, y as u32).0[0] >= threshold)
        .count();
    white * 10 >= columns.len() * 9
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row with a marker of `code` drawn `stripe` pixels a stripe from
    /// column `at`, black 20 on white 230, on a grey 140 door.
    fn row_with(code: Code, at: usize, stripe: usize, len: usize) -> Vec<u8> {
        let mut row = vec![140u8; len];
        let paper = at.saturating_sub(2 * stripe)..(at + (STRIPES + 2) * stripe).min(len);
        for px in &mut row[paper] {
            *px = 230;
        }
        for (s, black) in code.stripes().iter().enumerate() {
            if *black {
                for px in &mut row[at + s * stripe..at + (s + 1) * stripe] {
                    *px = 20;
                }
            }
        }
        row
    }

    #[test]
    fn every_code_is_read_from_a_row_at_every_size() {
        let cfg = ReaderConfig::default();
        for code in Code::all() {
            for stripe in [2, 3, 5, 8, 13, 30] {
                let at = 3 * stripe;
                let row = row_with(code, at, stripe, at + 10 * stripe);
                let hits = read_row(&row, &cfg);
                assert_eq!(hits.len(), 1, "{code} at {stripe} px: {hits:?}");
                assert_eq!(hits[0].code, code);
                assert_eq!(hits[0].start as usize, at);
                assert_eq!(hits[0].end as usize, at + STRIPES * stripe);
            }
        }
    }

    #[test]
    fn widths_that_are_not_one_or_three_stripes_are_no_marker() {
        let cfg = ReaderConfig::default();
        // Seven stripes' width, but in bars of two: 2 1 1 1 2.
        let bars: Vec<u8> = [
            (230, 30),
            (20, 16),
            (230, 8),
            (20, 8),
            (230, 8),
            (20, 16),
            (230, 30),
        ]
        .iter()
        .flat_map(|&(grey, n)| std::iter::repeat_n(grey, n))
        .collect();
        assert!(
            read_row(&bars, &cfg).is_empty(),
            "{:?}",
            read_row(&bars, &cfg)
        );
        // A black bar of five stripes.
        let mut row = row_with(Code::all()[0], 40, 8, 160);
        for px in &mut row[48..72] {
            *px = 20;
        }
        assert!(
            read_row(&row, &cfg).is_empty(),
            "{:?}",
            read_row(&row, &cfg)
        );
        // Too little contrast: a faint marker is not read.
        let faint: Vec<u8> = row_with(Code::all()[1], 40, 8, 140)
            .iter()
            .map(|&p| 120 + p / 8)
            .collect();
        assert!(read_row(&faint, &cfg).is_empty());
    }

    /// An image `h` rows tall with the marker in rows `rows`.
    fn image_with(code: Code, stripe: usize, rows: Range<u32>, h: u32) -> GrayImage {
        let w = 200u32;
        let mut img = GrayImage::from_pixel(w, h, image::Luma([140]));
        let row = row_with(code, 50, stripe, w as usize);
        for y in rows {
            for (x, &p) in row.iter().enumerate() {
                img.put_pixel(x as u32, y, image::Luma([p]));
            }
        }
        img
    }

    #[test]
    fn a_marker_is_found_where_it_is_and_only_at_its_height() {
        let cfg = ReaderConfig::default();
        let code = Code::all()[4];
        // 10 px stripes: a marker is about 17 rows tall.
        let found = find(&image_with(code, 10, 40..57, 100), 0..100, &cfg);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].code, code);
        assert_eq!(found[0].rows, 40..57);
        assert!((found[0].column - 85.0).abs() < 1e-9);
        assert!((found[0].stripe_px - 10.0).abs() < 1e-9);
        // Three rows of it: a line of something, not a marker; sixty: a
        // grille.
        assert!(find(&image_with(code, 10, 40..43, 100), 0..100, &cfg).is_empty());
        assert!(find(&image_with(code, 10, 20..80, 100), 0..100, &cfg).is_empty());
        // The same stripes with black above them, as white digits on a
        // black plate: no paper frames them.
        let mut plate = image_with(code, 10, 40..57, 100);
        for y in 25..40 {
            for x in 0..200 {
                plate.put_pixel(x, y, image::Luma([20]));
            }
        }
        assert!(find(&plate, 0..100, &cfg).is_empty());
        // A grille: bars of one width from top to bottom and side to side.
        // Each row reads as codes, but no paper frames them.
        let grille = GrayImage::from_fn(200, 100, |x, _| {
            image::Luma([if (x / 6) % 2 == 0 { 20 } else { 230 }])
        });
        assert!(!read_row(grille.as_raw().get(..200).unwrap_or_default(), &cfg).is_empty());
        assert!(find(&grille, 0..100, &cfg).is_empty());
        // Outside the rows scanned: not seen.
        assert!(find(&image_with(code, 10, 40..57, 100), 60..100, &cfg).is_empty());
    }

    #[test]
    fn distance_and_bearing_follow_the_stripe_width_and_column() {
        let f = Found {
            code: Code::all()[0],
            column: 100.0,
            rows: 0..10,
            stripe_px: 10.0,
        };
        assert!((f.distance_mm(500.0) - P_MM * 50.0).abs() < 1e-9);
        assert!(f.bearing_deg(200, 500.0).abs() < 1e-9);
        let left = Found { column: 50.0, ..f };
        assert!(left.bearing_deg(200, 500.0) > 5.0);
    }
}
