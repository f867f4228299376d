//! Pictures of a map: rings by edge kind, doors with their numbers,
//! ceiling lights, door plates, links and a scale bar, as SVG or PNG.
//!
//! Both formats draw the same list of primitives ([`scene`]), so they
//! cannot drift apart.

use crate::geometry::Point;
use crate::model::{EdgeKind, Map};
use crate::world::World;
use std::fmt::Write as _;

/// An RGB colour.
pub type Rgb = [u8; 3];

/// One thing to draw, in world coordinates (mm).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// A line.
    Line {
        /// Start.
        a: Point,
        /// End.
        b: Point,
        /// Colour.
        color: Rgb,
        /// Width in pixels.
        width: f64,
        /// Dashed.
        dashed: bool,
    },
    /// A filled disc of a radius in pixels.
    Dot {
        /// Centre.
        at: Point,
        /// Radius in pixels.
        radius: f64,
        /// Colour.
        color: Rgb,
    },
    /// A label whose top-left corner is at `at`.
    Text {
        /// Where.
        at: Point,
        /// What.
        text: String,
        /// Colour.
        color: Rgb,
        /// Font scale (1 = text 11 pixels high).
        size: i64,
    },
}

fn edge_style(kind: EdgeKind) -> (Rgb, f64, bool) {
    match kind {
        EdgeKind::Wall => ([34, 34, 34], 2.0, false),
        EdgeKind::Door => ([181, 101, 29], 3.0, false),
        EdgeKind::Elevator => ([31, 95, 191], 4.0, false),
        EdgeKind::Window => ([63, 167, 214], 3.0, false),
        EdgeKind::Glass => ([120, 200, 255], 3.0, true),
        EdgeKind::Opening => ([190, 190, 190], 1.0, true),
    }
}

const LIGHT: Rgb = [235, 180, 0];
/// Colour of a planned route.
pub const ROUTE: Rgb = [220, 30, 30];
/// Colour of a driven trajectory.
pub const TRACK: Rgb = [20, 90, 220];
/// Colour of door plates a robot found, where its odometry put them.
pub const FOUND: Rgb = [20, 160, 60];
/// Where people walked to and fro (the simulator's walkers).
pub const PEOPLE: Rgb = [150, 60, 170];
const PLATE: Rgb = [0, 0, 0];
const LINK: Rgb = [40, 160, 60];
const LABEL: Rgb = [120, 60, 0];
const NODE: Rgb = [120, 120, 120];

/// Everything to draw for a map.
pub fn scene(map: &Map, world: &World) -> Vec<Shape> {
    let mut out = Vec::new();
    for s in &world.segments {
        let (color, width, dashed) = edge_style(s.kind);
        out.push(Shape::Line {
            a: s.a,
            b: s.b,
            color,
            width,
            dashed,
        });
    }
    for link in &map.links {
        let a = world.positions.get(&format!("{}.{}", link.a.0, link.a.1));
        let b = world.positions.get(&format!("{}.{}", link.b.0, link.b.1));
        if let (Some(a), Some(b)) = (a, b) {
            out.push(Shape::Line {
                a: a.at,
                b: b.at,
                color: LINK,
                width: 1.5,
                dashed: true,
            });
        }
    }
    for light in &world.lights {
        out.push(Shape::Dot {
            at: light.at,
            radius: 4.0,
            color: LIGHT,
        });
    }
    for plate in &world.plates {
        out.push(Shape::Dot {
            at: plate.at,
            radius: 2.5,
            color: PLATE,
        });
    }
    for s in &world.segments {
        let number = map.rings[s.ring].edges[s.edge].number.as_ref();
        if let Some(number) = number {
            let mid = nalgebra::center(&s.a, &s.b);
            out.push(Shape::Text {
                at: mid,
                text: number.clone(),
                color: LABEL,
                size: 1,
            });
        }
    }
    for (ri, ring) in map.rings.iter().enumerate() {
        if let Some((name, p)) = world.nodes.get(ri).and_then(|n| n.first()) {
            out.push(Shape::Text {
                at: *p,
                text: format!("{} ({name})", ring.name),
                color: NODE,
                size: 1,
            });
        }
    }
    out
}

/// What the colours mean: (colour, dashed, text), drawn in a corner.
fn legend(map: &Map, overlay: &[Shape]) -> Vec<(Rgb, bool, &'static str)> {
    let mut out = Vec::new();
    let kinds: std::collections::BTreeSet<&'static str> = map
        .rings
        .iter()
        .flat_map(|r| &r.edges)
        .map(|e| e.kind.keyword())
        .collect();
    for (kind, word) in EdgeKind::ALL {
        if kinds.contains(word) {
            let (c, _, dashed) = edge_style(kind);
            out.push((c, dashed, word));
        }
    }
    out.push((LIGHT, false, "ceiling light"));
    out.push((PLATE, false, "door plate"));
    if !map.links.is_empty() {
        out.push((LINK, true, "link"));
    }
    let has = |c: Rgb| {
        overlay
            .iter()
            .any(|s| matches!(s, Shape::Line { color, .. } if *color == c))
    };
    if has(ROUTE) {
        out.push((ROUTE, false, "route"));
    }
    if has(TRACK) {
        out.push((TRACK, false, "trajectory"));
    }
    if has(PEOPLE) {
        out.push((PEOPLE, true, "people walking"));
    }
    if overlay
        .iter()
        .any(|s| matches!(s, Shape::Dot { color, .. } if *color == FOUND))
    {
        out.push((FOUND, false, "plate found (odom.)"));
    }
    out
}

/// A route drawn as a thick line with its stops labelled.
pub fn route_shapes(route: &crate::Route) -> Vec<Shape> {
    let mut out: Vec<Shape> = route
        .points
        .windows(2)
        .map(|w| Shape::Line {
            a: w[0],
            b: w[1],
            color: ROUTE,
            width: 3.0,
            dashed: false,
        })
        .collect();
    if let (Some(first), Some(last)) = (route.points.first(), route.points.last()) {
        for (at, text) in [(first, route.stops.first()), (last, route.stops.last())] {
            out.push(Shape::Dot {
                at: *at,
                radius: 5.0,
                color: ROUTE,
            });
            if let Some(text) = text {
                out.push(Shape::Text {
                    at: *at,
                    text: text.clone(),
                    color: ROUTE,
                    size: 2,
                });
            }
        }
    }
    out
}

/// How world millimetres map to picture pixels.
struct View {
    lo: Point,
    hi: Point,
    scale: f64,
    margin: f64,
    top: f64,
    width: u32,
    height: u32,
    /// Top of the legend band, below the scale bar.
    legend_y: f64,
}

/// Horizontal room for one legend entry, pixels.
const LEGEND_SLOT: f64 = 130.0;

impl View {
    fn new(world: &World, width_px: u32, legend_entries: usize) -> View {
        let (lo, hi) = world.bounds();
        let margin = 40.0;
        let top = 40.0;
        let span_x = (hi.x - lo.x).max(1.0);
        let span_y = (hi.y - lo.y).max(1.0);
        let scale = (f64::from(width_px) - 2.0 * margin) / span_x;
        let per_row = ((f64::from(width_px) - 2.0 * margin) / LEGEND_SLOT).max(1.0) as usize;
        let rows = legend_entries.div_ceil(per_row);
        let legend_y = span_y * scale + 2.0 * margin + top;
        let height = (legend_y + 16.0 * rows as f64 + 8.0).ceil() as u32;
        View {
            lo,
            hi,
            scale,
            margin,
            top,
            width: width_px,
            height,
            legend_y,
        }
    }

    /// Where legend entry `i` goes: the left end of its sample line.
    fn legend_at(&self, i: usize) -> (f64, f64) {
        let per_row = ((f64::from(self.width) - 2.0 * self.margin) / LEGEND_SLOT).max(1.0) as usize;
        (
            self.margin + LEGEND_SLOT * (i % per_row) as f64,
            self.legend_y + 6.0 + 16.0 * (i / per_row) as f64,
        )
    }

    fn px(&self, p: Point) -> (f64, f64) {
        (
            self.margin + (p.x - self.lo.x) * self.scale,
            self.top + self.margin + (self.hi.y - p.y) * self.scale,
        )
    }

    /// A 10 m (or 1 m) scale bar and the title, in pixel coordinates.
    fn furniture(&self, title: &str) -> (f64, String, String) {
        let metres = if (self.hi.x - self.lo.x) > 20_000.0 {
            10.0
        } else {
            1.0
        };
        (
            metres * 1000.0 * self.scale,
            format!("{metres} M"),
            title.to_string(),
        )
    }
}

/// How a line is drawn.
#[derive(Clone, Copy)]
struct Stroke {
    color: Rgb,
    width: f64,
    dashed: bool,
}

/// A surface the map is drawn on, in pixels. The SVG document and the
/// image draw the same shapes at the same places, each in its own way.
trait Canvas {
    fn line(&mut self, from: (f64, f64), to: (f64, f64), stroke: Stroke);
    fn dot(&mut self, at: (f64, f64), radius: f64, color: Rgb);
    fn text(&mut self, at: (f64, f64), text: &str, color: Rgb, size: i64);
}

impl View {
    /// Draws the map's shapes, then `overlay` over them, on `canvas`.
    fn draw(&self, scene: Vec<Shape>, overlay: &[Shape], canvas: &mut impl Canvas) {
        for shape in scene.into_iter().chain(overlay.iter().cloned()) {
            match shape {
                Shape::Line {
                    a,
                    b,
                    color,
                    width,
                    dashed,
                } => canvas.line(
                    self.px(a),
                    self.px(b),
                    Stroke {
                        color,
                        width,
                        dashed,
                    },
                ),
                Shape::Dot { at, radius, color } => canvas.dot(self.px(at), radius, color),
                Shape::Text {
                    at,
                    text,
                    color,
                    size,
                } => canvas.text(self.px(at), &text, color, size),
            }
        }
    }
}

struct SvgCanvas(String);

impl Canvas for SvgCanvas {
    fn line(&mut self, (x1, y1): (f64, f64), (x2, y2): (f64, f64), stroke: Stroke) {
        let dash = if stroke.dashed {
            r#" stroke-dasharray="6 4""#
        } else {
            ""
        };
        let _ = writeln!(
            self.0,
            r#"<line x1="{x1:.1}" y1="{y1:.1}" x2="{x2:.1}" y2="{y2:.1}" stroke="{}" stroke-width="{}" stroke-linecap="round"{dash}/>"#,
            hex(stroke.color),
            stroke.width
        );
    }

    fn dot(&mut self, (x, y): (f64, f64), radius: f64, color: Rgb) {
        let _ = writeln!(
            self.0,
            r#"<circle cx="{x:.1}" cy="{y:.1}" r="{radius}" fill="{}" stroke="black" stroke-width="0.5"/>"#,
            hex(color)
        );
    }

    fn text(&mut self, (x, y): (f64, f64), text: &str, color: Rgb, size: i64) {
        let _ = writeln!(
            self.0,
            r#"<text x="{:.1}" y="{:.1}" font-size="{}" fill="{}">{}</text>"#,
            x + 3.0,
            y + 10.0,
            9 * size + 1,
            hex(color),
            escape(text)
        );
    }
}

struct RasterCanvas(image::RgbImage);

impl RasterCanvas {
    /// Sets one pixel, if it is inside the picture.
    fn put(&mut self, x: i64, y: i64, c: Rgb) {
        let (w, h) = (i64::from(self.0.width()), i64::from(self.0.height()));
        if (0..w).contains(&x) && (0..h).contains(&y) {
            self.0.put_pixel(x as u32, y as u32, image::Rgb(c));
        }
    }
}

impl Canvas for RasterCanvas {
    fn line(&mut self, (x1, y1): (f64, f64), (x2, y2): (f64, f64), stroke: Stroke) {
        let len = (x2 - x1).hypot(y2 - y1);
        let steps = len.ceil().max(1.0) as i64;
        let r = (stroke.width / 2.0).round() as i64;
        for i in 0..=steps {
            let t = i as f64 / steps as f64;
            if stroke.dashed && (t * len / 5.0) as i64 % 2 == 1 {
                continue;
            }
            let (x, y) = (x1 + (x2 - x1) * t, y1 + (y2 - y1) * t);
            for dy in -r..=r {
                for dx in -r..=r {
                    self.put(x.round() as i64 + dx, y.round() as i64 + dy, stroke.color);
                }
            }
        }
    }

    fn dot(&mut self, (cx, cy): (f64, f64), radius: f64, color: Rgb) {
        let r = radius.ceil() as i64;
        for dy in -r - 1..=r + 1 {
            for dx in -r - 1..=r + 1 {
                let d = (dx as f64).hypot(dy as f64);
                let (x, y) = (cx.round() as i64 + dx, cy.round() as i64 + dy);
                if d <= radius {
                    self.put(x, y, color);
                } else if d <= radius + 1.0 {
                    self.put(x, y, [0, 0, 0]);
                }
            }
        }
    }

    fn text(&mut self, (x, y): (f64, f64), text: &str, color: Rgb, size: i64) {
        label(&mut self.0, text, x + 3.0, y + 3.0, size, color);
    }
}

fn hex(c: Rgb) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// The map as an SVG document.
/// `overlay` is drawn over the map (a route, a trajectory).
pub fn svg(map: &Map, world: &World, width_px: u32, overlay: &[Shape]) -> String {
    let legend = legend(map, overlay);
    let v = View::new(world, width_px, legend.len());
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" viewBox="0 0 {} {}" font-family="sans-serif">"#,
        v.width, v.height, v.width, v.height
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let mut canvas = SvgCanvas(s);
    v.draw(scene(map, world), overlay, &mut canvas);
    let mut s = canvas.0;
    let (bar, bar_label, title) = v.furniture(&map.name);
    let by = v.legend_y - 15.0;
    let _ = writeln!(
        s,
        r#"<text x="{}" y="24" font-size="16">{}</text>"#,
        v.margin,
        escape(&title)
    );
    let _ = writeln!(
        s,
        r#"<line x1="{}" y1="{by}" x2="{:.1}" y2="{by}" stroke="black" stroke-width="3"/>"#,
        v.margin,
        v.margin + bar
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" font-size="11">{}</text>"#,
        v.margin + bar + 6.0,
        by + 4.0,
        bar_label.to_lowercase()
    );
    for (i, (color, dashed, text)) in legend.into_iter().enumerate() {
        let (x, y) = v.legend_at(i);
        let dash = if dashed {
            r#" stroke-dasharray="4 3""#
        } else {
            ""
        };
        let _ = writeln!(
            s,
            r#"<line x1="{x}" y1="{y}" x2="{}" y2="{y}" stroke="{}" stroke-width="4"{dash}/><text x="{}" y="{}" font-size="11">{text}</text>"#,
            x + 22.0,
            hex(color),
            x + 28.0,
            y + 4.0
        );
    }
    s.push_str("</svg>\n");
    s
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The map as an RGB image.
/// `overlay` is drawn over the map (a route, a trajectory).
pub fn raster(map: &Map, world: &World, width_px: u32, overlay: &[Shape]) -> image::RgbImage {
    let legend = legend(map, overlay);
    let v = View::new(world, width_px, legend.len());
    let mut c = RasterCanvas(image::RgbImage::from_pixel(
        v.width,
        v.height,
        image::Rgb([255, 255, 255]),
    ));
    v.draw(scene(map, world), overlay, &mut c);
    let (bar, bar_label, title) = v.furniture(&map.name);
    label(&mut c.0, &title, v.margin, 8.0, 2, [0, 0, 0]);
    let by = v.legend_y as i64 - 15;
    for x in v.margin as i64..(v.margin + bar) as i64 {
        for dy in -1..=1 {
            c.put(x, by + dy, [0, 0, 0]);
        }
    }
    label(
        &mut c.0,
        &bar_label,
        v.margin + bar + 6.0,
        by as f64 - 6.0,
        1,
        [0, 0, 0],
    );
    for (i, (color, dashed, text)) in legend.into_iter().enumerate() {
        let (x, y) = v.legend_at(i);
        let (x, y) = (x as i64, y as i64);
        for dx in 0..22 {
            if dashed && (dx / 4) % 2 == 1 {
                continue;
            }
            for dy in -1..=1 {
                c.put(x + dx, y + dy, color);
            }
        }
        label(
            &mut c.0,
            text,
            (x + 28) as f64,
            (y - 6) as f64,
            1,
            [0, 0, 0],
        );
    }
    c.0
}

/// Pixel height of text at font scale 1.
pub const TEXT_PX: f32 = 11.0;

/// The labels' typeface: DejaVu Sans, built into the binary.
fn typeface() -> Option<&'static ab_glyph::FontRef<'static>> {
    static FACE: std::sync::OnceLock<Option<ab_glyph::FontRef<'static>>> =
        std::sync::OnceLock::new();
    FACE.get_or_init(|| ab_glyph::FontRef::try_from_slice(dejavu::sans::regular()).ok())
        .as_ref()
}

/// Draws `text` with its top left corner at (`x`, `y`), `scale` ×
/// [`TEXT_PX`] high, blended into the picture by each pixel's coverage so
/// it stays smooth at any size.
pub fn label(img: &mut image::RgbImage, text: &str, x: f64, y: f64, scale: i64, color: Rgb) {
    use ab_glyph::{Font, ScaleFont};
    let Some(face) = typeface() else { return };
    let font = face.as_scaled(TEXT_PX * scale.clamp(1, 16) as f32);
    let baseline = y as f32 + font.ascent();
    let (w, h) = (img.width() as i64, img.height() as i64);
    let mut pen = x as f32;
    let mut last = None;
    for c in text.chars() {
        let id = font.glyph_id(c);
        if let Some(prev) = last {
            pen += font.kern(prev, id);
        }
        let glyph = id.with_scale_and_position(font.scale(), ab_glyph::point(pen, baseline));
        pen += font.h_advance(id);
        last = Some(id);
        let Some(outline) = face.outline_glyph(glyph) else {
            continue;
        };
        let bounds = outline.px_bounds();
        outline.draw(|gx, gy, coverage| {
            let px = bounds.min.x as i64 + i64::from(gx);
            let py = bounds.min.y as i64 + i64::from(gy);
            if !(0..w).contains(&px) || !(0..h).contains(&py) {
                return;
            }
            let p = img.get_pixel_mut(px as u32, py as u32);
            let a = coverage.clamp(0.0, 1.0);
            for (o, c) in p.0.iter_mut().zip(color) {
                *o = (f32::from(*o) * (1.0 - a) + f32::from(c) * a).round() as u8;
            }
        });
    }
}

/// Width in pixels of `text` at font `scale`.
pub fn label_width(text: &str, scale: i64) -> f64 {
    use ab_glyph::{Font, ScaleFont};
    let Some(face) = typeface() else { return 0.0 };
    let font = face.as_scaled(TEXT_PX * scale.clamp(1, 16) as f32);
    f64::from(
        text.chars()
            .map(|c| font.h_advance(font.glyph_id(c)))
            .sum::<f32>(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rows and columns `text` covers, and whether any pixel is only
    /// partly covered (smoothed edges, not a bitmap).
    fn ink(text: &str, scale: i64) -> (u32, u32, bool) {
        let mut img = image::RgbImage::from_pixel(400, 200, image::Rgb([255, 255, 255]));
        label(&mut img, text, 10.0, 10.0, scale, [0, 0, 0]);
        let inked: Vec<(u32, u32, u8)> = img
            .enumerate_pixels()
            .filter(|(_, _, p)| p.0[0] < 255)
            .map(|(x, y, p)| (x, y, p.0[0]))
            .collect();
        let rows = inked.iter().map(|p| p.1).max().unwrap_or(0)
            - inked.iter().map(|p| p.1).min().unwrap_or(0);
        let cols = inked.iter().map(|p| p.0).max().unwrap_or(0)
            - inked.iter().map(|p| p.0).min().unwrap_or(0);
        (rows, cols, inked.iter().any(|p| p.2 > 0 && p.2 < 200))
    }

    #[test]
    fn labels_are_drawn_in_a_real_typeface_at_any_scale() {
        let (r1, c1, smooth) = ink("A392 Hall", 1);
        assert!(smooth, "edges are blended");
        assert!((7..=13).contains(&r1), "about 11 px high at scale 1: {r1}");
        let (r4, c4, _) = ink("A392 Hall", 4);
        assert!(
            r4 >= 3 * r1 && c4 >= 3 * c1,
            "scale 4: {r4}×{c4} against {r1}×{c1}"
        );
        // Proportional, unlike the 5×7 bitmap: an i is narrower than an m.
        assert!(label_width("iiii", 1) < label_width("mmmm", 1) * 0.6);
        // Lower case is lower case.
        assert_ne!(ink("abc", 2), ink("ABC", 2));
    }
}
