//! The building as the simulator sees it: wall segments with what each
//! sensor makes of them, corner reflectors, ceiling lights, plates, posters,
//! metal floors and elevators, with a grid for fast nearby-wall queries.

use rome_maps::geometry::{direction, Point, Vector};
use rome_maps::model::EdgeKind;
use rome_maps::{Map, World};

/// Side of a grid cell, mm.
pub(crate) const CELL_MM: f64 = 2_000.0;
/// How deep an elevator cabin is behind its door, mm.
const CABIN_MM: f64 = 2_000.0;

/// One wall segment.
#[derive(Debug, Clone, PartialEq)]
pub struct Wall {
    /// Start (in the map's tracing order).
    pub a: Point,
    /// End.
    pub b: Point,
    /// Unit vector from a to b.
    pub dir: Vector,
    /// Length, mm.
    pub len: f64,
    /// Unit normal pointing into the corridor (right of the tracing).
    pub normal: Vector,
    /// What it is.
    pub kind: EdgeKind,
    /// The elevator this door belongs to, if it is one.
    pub elevator: Option<usize>,
    /// Glass bricks (a checker pattern to a camera).
    pub bricks: bool,
    /// Posters on it: offsets from `a`, mm.
    pub posters: Vec<f64>,
    /// Door plates on it: label and offset from `a`, mm.
    pub plates: Vec<(String, f64)>,
    /// Door number, if any.
    pub number: Option<String>,
    /// The barcode-like marker on an elevator door (Fig. 5.11).
    pub marker: Option<rome_maps::marker::Code>,
    /// A bare metal wall of an elevator's cabin (`cabin=metal`): sonar
    /// and infrared get spurious readings off it (§5.4.6).
    pub metal: bool,
}

impl Wall {
    /// A plain wall of a kind from a to b: no elevator, plates or posters.
    pub fn plain(a: Point, b: Point, kind: EdgeKind) -> Wall {
        let len = rome_maps::geometry::distance(a, b).max(1e-9);
        let dir = (b - a) / len;
        Wall {
            a,
            b,
            dir,
            len,
            normal: Vector::new(dir.y, -dir.x),
            kind,
            elevator: None,
            bricks: false,
            posters: Vec::new(),
            plates: Vec::new(),
            number: None,
            marker: None,
            metal: false,
        }
    }
}

/// What the sensors and bodies test of a wall, packed into one cache line
/// and kept beside [`Scene::walls`] (same index): a beam that tries a wall
/// reads 64 bytes, not the whole wall with its plates and posters.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(align(64))]
pub struct Line {
    /// Start.
    pub a: Point,
    /// Unit vector from a to b.
    pub dir: Vector,
    /// Unit normal (see [`Wall::normal`]).
    pub normal: Vector,
    /// Length, mm.
    pub len: f64,
    /// The elevator whose door this is, or `u32::MAX`.
    elevator: u32,
    /// Whether bodies and cameras are stopped (not an opening).
    solid: bool,
    /// Whether sound and infrared are stopped (not an opening, not glass).
    sounding: bool,
}

impl Line {
    fn of(w: &Wall) -> Line {
        Line {
            a: w.a,
            dir: w.dir,
            normal: w.normal,
            len: w.len,
            elevator: w.elevator.map_or(u32::MAX, |e| e as u32),
            solid: w.kind != EdgeKind::Opening,
            sounding: w.kind != EdgeKind::Opening && w.kind != EdgeKind::Glass,
        }
    }
}

/// A ceiling light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lamp {
    /// Centre, mm.
    pub at: Point,
    /// Unit vector along its wall (its short side runs this way).
    pub along: Vector,
}

/// An elevator: its door and whether it is open.
#[derive(Debug, Clone, PartialEq)]
pub struct Elevator {
    /// Its door number (`acs.elev`).
    pub number: String,
    /// Index of its door in [`Scene::walls`].
    pub door: usize,
}

/// The static building.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Every wall, door, window, glass and elevator cabin wall.
    pub walls: Vec<Wall>,
    /// The same walls as the sensors test them (same index).
    pub lines: Vec<Line>,
    /// Corners that echo sound from any direction.
    pub reflectors: Vec<Point>,
    /// Ceiling lights.
    pub lamps: Vec<Lamp>,
    /// Metal floor patches (quadrilaterals).
    pub metal: Vec<[Point; 4]>,
    /// The bare metal walls of elevator cabins, by index into `walls`.
    pub metal_walls: Vec<usize>,
    /// Elevators.
    pub elevators: Vec<Elevator>,
    /// The map's positions.
    pub world: World,
    lo: Point,
    cols: usize,
    rows: usize,
    cells: Filed,
    reflector_cells: Filed,
}

/// Indices filed by grid cell, all in one array: cell `c`'s are
/// `items[start[c]..start[c + 1]]`. One allocation, read in order, where a
/// vector per cell would cost a pointer chase per cell a beam visits.
#[derive(Debug, Clone, Default)]
struct Filed {
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Filed {
    fn new(lists: &[Vec<u32>]) -> Filed {
        let mut start = Vec::with_capacity(lists.len() + 1);
        let mut items = Vec::with_capacity(lists.iter().map(Vec::len).sum());
        start.push(0);
        for list in lists {
            items.extend_from_slice(list);
            start.push(items.len() as u32);
        }
        Filed { start, items }
    }

    /// Cell `c`'s indices; none for a cell outside the grid.
    fn get(&self, c: usize) -> &[u32] {
        match (self.start.get(c), self.start.get(c + 1)) {
            (Some(&a), Some(&b)) => &self.items[a as usize..b as usize],
            _ => &[],
        }
    }
}

/// Which sensor is asking: each sees different things.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sense {
    /// Bodies: everything but openings and open elevator doors.
    Touch,
    /// Sonar and infrared: not glass (specular), not openings, not open doors.
    Sound,
    /// Cameras: everything but openings and open elevator doors.
    Sight,
}

impl Scene {
    /// Builds the scene of a valid map.
    pub fn new(map: &Map) -> Scene {
        let world = World::from_map(map);
        let mut walls = Vec::new();
        let mut elevators = Vec::new();
        let mut metal = Vec::new();
        let mut cabins = Vec::new();
        for s in &world.segments {
            let edge = &map.rings[s.ring].edges[s.edge];
            let mut wall = Wall::plain(s.a, s.b, s.kind);
            let normal = wall.normal;
            wall.elevator = if edge.kind == EdgeKind::Elevator {
                elevators.push(Elevator {
                    number: edge
                        .number
                        .clone()
                        .unwrap_or_else(|| format!("elevator{}", elevators.len())),
                    door: walls.len(),
                });
                let back = |p: Point| p - normal * CABIN_MM;
                let bare = edge.tags.get("cabin").map(String::as_str) == Some("metal");
                cabins.push((s.a, back(s.a), bare));
                cabins.push((back(s.a), back(s.b), bare));
                cabins.push((back(s.b), s.b, bare));
                Some(elevators.len() - 1)
            } else {
                None
            };
            if edge.tags.get("floor").map(String::as_str) == Some("metal") {
                let depth = 2.0 * edge.lateral_mm.unwrap_or(map.lateral_mm);
                let out = |p: Point| p + normal * depth;
                metal.push([s.a, s.b, out(s.b), out(s.a)]);
            }
            wall.posters = edge
                .tags
                .get("poster")
                .map(|v| {
                    v.split(',')
                        .filter_map(|x| x.trim().parse::<f64>().ok())
                        .collect()
                })
                .unwrap_or_default();
            wall.plates = edge
                .plates
                .iter()
                .map(|p| (p.label.clone(), p.offset_mm))
                .collect();
            wall.bricks = edge.tags.get("bricks").map(String::as_str) == Some("yes");
            wall.number = edge.number.clone();
            wall.marker = rome_maps::marker::of_edge(edge).and_then(Result::ok);
            walls.push(wall);
        }
        // Walls of the map come first, in the order of `world.segments`.
        walls.extend(cabins.into_iter().map(|(a, b, metal)| Wall {
            metal,
            ..Wall::plain(a, b, EdgeKind::Wall)
        }));
        let metal_walls = (0..walls.len()).filter(|&i| walls[i].metal).collect();
        // Corners: nodes where the wall changes direction.
        let mut reflectors = Vec::new();
        for (ri, ring) in map.rings.iter().enumerate() {
            for (i, node) in ring.nodes.iter().enumerate() {
                if node.turn_deg().abs() > 1.0 {
                    reflectors.push(world.nodes[ri][i].1);
                }
            }
        }
        let lamps = world
            .lights
            .iter()
            .map(|l| Lamp {
                at: l.at,
                along: world
                    .segment(l.ring, l.edge)
                    .map_or(Vector::x(), |i| walls[i].dir),
            })
            .collect();
        let (lo, hi) = world.bounds();
        let lo = lo - Vector::repeat(3.0 * CELL_MM);
        let cols = (((hi.x - lo.x) / CELL_MM).ceil() as usize + 4).max(1);
        let rows = (((hi.y - lo.y) / CELL_MM).ceil() as usize + 4).max(1);
        let lines = walls.iter().map(Line::of).collect();
        let mut scene = Scene {
            walls,
            lines,
            reflectors,
            lamps,
            metal,
            metal_walls,
            elevators,
            world,
            lo,
            cols,
            rows,
            cells: Filed::default(),
            reflector_cells: Filed::default(),
        };
        let mut cells = vec![Vec::new(); cols * rows];
        let mut reflector_cells = vec![Vec::new(); cols * rows];
        // Every cell a wall passes through, so that a ray walking the
        // cells it crosses meets every wall it hits; each cell's walls in
        // the walls' order.
        for (i, w) in scene.walls.iter().enumerate() {
            let (x0, y0) = scene.cell_xy(w.a.inf(&w.b) - Vector::repeat(1.0));
            let (x1, y1) = scene.cell_xy(w.a.sup(&w.b) + Vector::repeat(1.0));
            for cy in y0..=y1 {
                for cx in x0..=x1 {
                    if scene.clips_cell(w.a, w.b, cx, cy) {
                        cells[cy * cols + cx].push(i as u32);
                    }
                }
            }
        }
        for (i, p) in scene.reflectors.iter().enumerate() {
            let c = scene.cell_of(*p);
            reflector_cells[c].push(i as u32);
        }
        scene.cells = Filed::new(&cells);
        scene.reflector_cells = Filed::new(&reflector_cells);
        scene
    }

    /// The grid's size in cells: (columns, rows); cells are 2 m square.
    pub fn grid(&self) -> (usize, usize) {
        (self.cols, self.rows)
    }

    /// The grid cell (column, row) holding `p`, clamped to the grid.
    pub fn cell_xy(&self, p: Point) -> (usize, usize) {
        // Truncation floors what is not negative (and sends NaN to 0); it
        // is far cheaper than `floor` on a baseline x86-64, and this is
        // called for every beam section and robot.
        let index = |v: f64, n: usize| {
            if v > 0.0 {
                (v as usize).min(n - 1)
            } else {
                0
            }
        };
        (
            index((p.x - self.lo.x) / CELL_MM, self.cols),
            index((p.y - self.lo.y) / CELL_MM, self.rows),
        )
    }

    /// Whether the segment from `a` to `b` passes through cell (`cx`,
    /// `cy`) or within a millimetre of it (Liang–Barsky clipping).
    fn clips_cell(&self, a: Point, b: Point, cx: usize, cy: usize) -> bool {
        let lo = self.lo + Vector::new(cx as f64, cy as f64) * CELL_MM - Vector::repeat(1.0);
        let hi = lo + Vector::repeat(CELL_MM + 2.0);
        let d = b - a;
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (p, q) in [
            (-d.x, a.x - lo.x),
            (d.x, hi.x - a.x),
            (-d.y, a.y - lo.y),
            (d.y, hi.y - a.y),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return false;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
        t0 <= t1
    }

    fn cell_of(&self, p: Point) -> usize {
        let (cx, cy) = self.cell_xy(p);
        cy * self.cols + cx
    }

    /// Whether a wall stops this sense, given which elevator doors are open.
    pub fn blocks(&self, wall: usize, sense: Sense, open: &[bool]) -> bool {
        let w = &self.lines[wall];
        let stops = if sense == Sense::Sound {
            w.sounding
        } else {
            w.solid
        };
        // An elevator's door lets everything through while it is open.
        stops
            && (w.elevator == u32::MAX || !open.get(w.elevator as usize).copied().unwrap_or(false))
    }

    /// Indices of walls that may lie within `r` of `p` (a superset), sorted.
    pub fn walls_near(&self, p: Point, r: f64, out: &mut Vec<u32>) {
        self.walls_near_unsorted(p, r, out);
        out.sort_unstable();
        out.dedup();
    }

    /// As [`Scene::walls_near`], possibly with repeats, in no order.
    pub fn walls_near_unsorted(&self, p: Point, r: f64, out: &mut Vec<u32>) {
        out.clear();
        let (x0, y0) = self.cell_xy(p - Vector::repeat(r));
        let (x1, y1) = self.cell_xy(p + Vector::repeat(r));
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                out.extend_from_slice(self.cells.get(cy * self.cols + cx));
            }
        }
    }

    /// Indices of the walls filed under grid cell `c` (row-major; see
    /// [`Scene::grid`]): every wall that passes through the cell or within
    /// a millimetre of it; none for a cell outside the grid.
    pub fn walls_in_cell(&self, c: usize) -> &[u32] {
        self.cells.get(c)
    }

    /// Indices of the corner reflectors in grid cell `c`.
    pub fn reflectors_in_cell(&self, c: usize) -> &[u32] {
        self.reflector_cells.get(c)
    }

    /// Indices of corner reflectors within the cells around `p` ± `r`.
    pub fn reflectors_near(&self, p: Point, r: f64, out: &mut Vec<u32>) {
        out.clear();
        let (x0, y0) = self.cell_xy(p - Vector::repeat(r));
        let (x1, y1) = self.cell_xy(p + Vector::repeat(r));
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                out.extend_from_slice(self.reflector_cells.get(cy * self.cols + cx));
            }
        }
    }

    /// The first wall a ray meets within `max` mm: (distance, wall index,
    /// offset along the wall from its start). `skip` is never hit.
    pub fn ray(
        &self,
        from: Point,
        heading_deg: f64,
        max: f64,
        sense: Sense,
        open: &[bool],
        skip: Option<usize>,
    ) -> Option<(f64, usize, f64)> {
        let d = direction(heading_deg);
        self.ray_dir(from, d, max, sense, open, skip)
    }

    /// As [`Scene::ray`] with a unit direction vector.
    pub fn ray_dir(
        &self,
        from: Point,
        d: Vector,
        max: f64,
        sense: Sense,
        open: &[bool],
        skip: Option<usize>,
    ) -> Option<(f64, usize, f64)> {
        // Walk the grid cells the ray crosses (Amanatides & Woo, 1987).
        let (mut cx, mut cy) = self.cell_xy(from);
        let step_x: isize = if d.x > 0.0 { 1 } else { -1 };
        let step_y: isize = if d.y > 0.0 { 1 } else { -1 };
        let next_x = self.lo.x + (cx as f64 + if d.x > 0.0 { 1.0 } else { 0.0 }) * CELL_MM;
        let next_y = self.lo.y + (cy as f64 + if d.y > 0.0 { 1.0 } else { 0.0 }) * CELL_MM;
        let mut t_max_x = if d.x.abs() < 1e-12 {
            f64::INFINITY
        } else {
            (next_x - from.x) / d.x
        };
        let mut t_max_y = if d.y.abs() < 1e-12 {
            f64::INFINITY
        } else {
            (next_y - from.y) / d.y
        };
        let t_dx = if d.x.abs() < 1e-12 {
            f64::INFINITY
        } else {
            CELL_MM / d.x.abs()
        };
        let t_dy = if d.y.abs() < 1e-12 {
            f64::INFINITY
        } else {
            CELL_MM / d.y.abs()
        };
        let mut best: Option<(f64, usize, f64)> = None;
        loop {
            for &wi in self.cells.get(cy * self.cols + cx) {
                let wi = wi as usize;
                if Some(wi) == skip || !self.blocks(wi, sense, open) {
                    continue;
                }
                let w = &self.lines[wi];
                if let Some((t, u)) = hit(from, d, w.a, w.dir, w.len) {
                    if t <= max && best.is_none_or(|(bt, _, _)| t < bt) {
                        best = Some((t, wi, u));
                    }
                }
            }
            let t_next = t_max_x.min(t_max_y);
            if best.is_some_and(|(bt, _, _)| bt <= t_next) || t_next > max {
                return best;
            }
            if t_max_x < t_max_y {
                t_max_x += t_dx;
                let nx = cx as isize + step_x;
                if nx < 0 || nx >= self.cols as isize {
                    return best;
                }
                cx = nx as usize;
            } else {
                t_max_y += t_dy;
                let ny = cy as isize + step_y;
                if ny < 0 || ny >= self.rows as isize {
                    return best;
                }
                cy = ny as usize;
            }
        }
    }

    /// Whether `p` (a robot's centre) is inside elevator `e`'s cabin: behind
    /// its door, within the door's width and the cabin's depth.
    pub fn in_cabin(&self, e: usize, p: Point) -> bool {
        let w = &self.walls[self.elevators[e].door];
        let d = p - w.a;
        let (u, back) = (d.dot(&w.dir), -d.dot(&w.normal));
        (0.0..=w.len).contains(&u) && (0.0..=CABIN_MM).contains(&back)
    }

    /// Moves a pose from elevator `from`'s cabin to the same place in
    /// elevator `to`'s: the same offset from the door and the same heading
    /// against it (a car carries its riders).
    pub fn carry(&self, from: usize, to: usize, at: Point, heading_deg: f64) -> (Point, f64) {
        let (a, b) = (
            &self.walls[self.elevators[from].door],
            &self.walls[self.elevators[to].door],
        );
        let d = at - a.a;
        let (u, n) = (d.dot(&a.dir), d.dot(&a.normal));
        let turn =
            rome_maps::geometry::heading_to(b.a, b.b) - rome_maps::geometry::heading_to(a.a, a.b);
        (b.a + b.dir * u + b.normal * n, heading_deg + turn)
    }

    /// Whether `p` is on a metal floor.
    pub fn on_metal(&self, p: Point) -> bool {
        self.metal.iter().any(|q| inside(q, p))
    }

    /// Distance from `p` to the nearest wall that bodies bump into, with the
    /// nearest point on it, looking within `r`.
    pub fn nearest_solid(
        &self,
        p: Point,
        r: f64,
        open: &[bool],
        scratch: &mut Vec<u32>,
    ) -> Option<(f64, Point)> {
        self.walls_near_unsorted(p, r, scratch);
        nearest_of(self, scratch, p, r, open)
    }
}

/// The nearest of `walls` (indices, repeats allowed) that bodies bump into,
/// within `r` of `p`: (distance, nearest point on it).
pub fn nearest_of(
    scene: &Scene,
    walls: &[u32],
    p: Point,
    r: f64,
    open: &[bool],
) -> Option<(f64, Point)> {
    let mut best: Option<(f64, Point)> = None;
    for &wi in walls {
        let wi = wi as usize;
        let w = &scene.lines[wi];
        // Cheap rejection before the door and glass checks.
        let side = (p - w.a).dot(&w.normal).abs();
        if side > r || best.is_some_and(|(bd, _)| side >= bd) {
            continue;
        }
        if !scene.blocks(wi, Sense::Touch, open) {
            continue;
        }
        let t = (p - w.a).dot(&w.dir).clamp(0.0, w.len);
        let q = w.a + w.dir * t;
        let d = nalgebra::distance(&p, &q);
        if d <= r && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, q));
        }
    }
    best
}

/// Where a ray meets a segment (shared with the Navigator, which hears
/// the map's glass with it).
pub use rome_maps::geometry::hit;

fn inside(q: &[Point; 4], p: Point) -> bool {
    let mut sign = 0.0;
    for i in 0..4 {
        let (a, b) = (q[i], q[(i + 1) % 4]);
        let c = (b - a).perp(&(p - a));
        if c != 0.0 {
            if sign != 0.0 && c.signum() != sign {
                return false;
            }
            sign = c.signum();
        }
    }
    true
}

/// Where tests put robots: a spot in the corridor beside each named
/// position of the map.
#[cfg(test)]
pub(crate) fn corridor_spots(scene: &Scene) -> Vec<Point> {
    scene
        .world
        .positions
        .values()
        .map(|p| p.in_corridor())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// A ray walks only the cells it crosses: every wall it hits must be
    /// filed under one of them, however the wall clips a cell.
    #[test]
    fn a_ray_finds_the_nearest_wall_of_the_whole_building() {
        for name in ["eb3", "annex", "campus", "fig5_3"] {
            rays_find_the_nearest_wall(name);
        }
    }

    /// An octagonal room: walls at 45° to the grid, which cross cells
    /// anywhere, clipping some by a corner.
    const OCTAGON: &str = "map octagon
ring room at 0 0 heading 0
  node A -225
  wall 7300
  node B -225
  wall 7300
  node C -225
  wall 7300
  node D -225
  wall 7300
  node E -225
  wall 7300
  node F -225
  wall 7300
  node G -225
  wall 7300
  node H -225
  wall 7300
end
";

    #[test]
    fn a_ray_across_any_piece_of_a_wall_meets_it() {
        let map = rome_maps::parse::parse("octagon", OCTAGON).unwrap();
        let scene = Scene::new(&map);
        let open = vec![false; scene.elevators.len()];
        let mut pieces = 0;
        for (i, w) in scene.walls.iter().enumerate() {
            // Every tenth of a millimetre of the wall but its ends, where
            // the ray meets the next wall first.
            let inner = w.len - 200.0;
            let steps = (inner * 10.0) as usize;
            for k in 0..=steps {
                let at = w.a + w.dir * (100.0 + inner * k as f64 / steps as f64);
                let from = at + w.normal * 50.0;
                let got = scene.ray_dir(from, -w.normal, 100.0, Sense::Touch, &open, None);
                assert!(
                    got.is_some_and(|(t, _, _)| (t - 50.0).abs() < 1e-6),
                    "wall {i} at {at:?}: {got:?}"
                );
                pieces += 1;
            }
        }
        assert!(pieces > 500_000, "{pieces}");
    }

    fn rays_find_the_nearest_wall(name: &str) {
        let map = rome_maps::load_named(name).unwrap();
        let scene = Scene::new(&map);
        let open = vec![false; scene.elevators.len()];
        let spots = corridor_spots(&scene);
        let mut rng = Rng::new(11);
        let mut hits = 0;
        for _ in 0..20_000 {
            let base = spots[(rng.next_u64() % spots.len() as u64) as usize];
            let from = base + Vector::new(rng.uniform() - 0.5, rng.uniform() - 0.5) * 6_000.0;
            let d = direction(rng.uniform() * 360.0);
            let max = rng.uniform() * 10_000.0;
            for sense in [Sense::Sound, Sense::Touch] {
                let want = (0..scene.walls.len())
                    .filter(|&i| scene.blocks(i, sense, &open))
                    .filter_map(|i| {
                        let w = &scene.lines[i];
                        hit(from, d, w.a, w.dir, w.len).map(|(t, _)| t)
                    })
                    .filter(|&t| t <= max)
                    .min_by(f64::total_cmp);
                let got = scene.ray_dir(from, d, max, sense, &open, None).map(|h| h.0);
                assert_eq!(
                    got, want,
                    "{name}: ray from {from:?} along {d:?}, {max} mm, {sense:?}"
                );
                hits += usize::from(want.is_some());
            }
        }
        assert!(hits > 10_000, "{name}: {hits} rays of 40 000 met a wall");
    }
}
