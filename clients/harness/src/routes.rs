//! Routes to run: one robot's start, goal, speed and the places it passes,
//! from a routes file (`FROM TO [SPEED] [via …]` a line) or picked at
//! random on a map.

use rome_maps::geometry::Point;
use rome_maps::{Map, Network, World};
use rome_nav::plan::Plan;
use rome_nav::NavError;

/// One robot's route.
#[derive(Debug, Clone, PartialEq)]
pub struct RouteSpec {
    /// The robot's name (`r1`).
    pub robot: String,
    /// Start position (`350R`).
    pub from: String,
    /// Goal position (`376L`).
    pub to: String,
    /// The robot's cruising speed, mm/s, if not the Navigator's default.
    pub cruise_mm_s: Option<f64>,
    /// Positions the route goes through in order (the long way round).
    pub via: Vec<String>,
}

impl RouteSpec {
    /// Robot `robot` from `from` to `to` at the default speed.
    pub fn new(robot: &str, from: &str, to: &str) -> RouteSpec {
        RouteSpec {
            robot: robot.into(),
            from: from.into(),
            to: to.into(),
            cruise_mm_s: None,
            via: Vec::new(),
        }
    }
}

/// Reads a routes file: one `FROM TO [SPEED] [via POS…]` a line (SPEED
/// the cruising speed in mm/s; the route goes through the `via` positions
/// in order; blank lines and `#` comments skipped); robot k is named `rk`.
pub fn parse_routes(file: &str, text: &str) -> Result<Vec<RouteSpec>, NavError> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let all: Vec<&str> = line.split_whitespace().collect();
        let (words, via) = match all.iter().position(|w| *w == "via") {
            Some(k) if k + 1 < all.len() => (&all[..k], &all[k + 1..]),
            Some(_) => {
                return Err(NavError::Config(format!(
                    "{file}:{}: 'via' needs one position or more after it, got '{line}'",
                    i + 1
                )))
            }
            None => (&all[..], &[][..]),
        };
        let (from, to, speed) = match *words {
            [from, to] => (from, to, None),
            [from, to, speed] => (from, to, Some(speed)),
            _ => {
                return Err(NavError::Config(format!(
                    "{file}:{}: expected 'FROM TO', 'FROM TO SPEED' (like '350R 376L 300') and 'via POS…' after either, got '{line}'",
                    i + 1
                )))
            }
        };
        let cruise_mm_s = match speed {
            None => None,
            Some(w) => match w.parse::<f64>() {
                Ok(v) if v > 0.0 && v <= 1_000.0 => Some(v),
                _ => {
                    return Err(NavError::Config(format!(
                        "{file}:{}: speed '{w}' must be a number of mm/s in 0..=1000",
                        i + 1
                    )))
                }
            },
        };
        out.push(RouteSpec {
            robot: format!("r{}", out.len() + 1),
            from: from.into(),
            to: to.into(),
            cruise_mm_s,
            via: via.iter().map(|v| (*v).to_string()).collect(),
        });
    }
    if out.is_empty() {
        return Err(NavError::Config(format!(
            "{file}: no routes (one 'FROM TO' a line)"
        )));
    }
    Ok(out)
}

/// Adds routes picked with `seed` to `routes` until there are `n`: door
/// jambs at least 20 m apart with a plan between them, each robot starting
/// at least 2 m from every other.
pub fn pick_routes(
    map: &Map,
    mut routes: Vec<RouteSpec>,
    n: usize,
    seed: u64,
) -> Result<Vec<RouteSpec>, NavError> {
    let world = World::from_map(map);
    let network = Network::new(map, &world);
    // Door jambs only (`350R`), not ring nodes (`outer.NW`).
    let doors: Vec<(&String, Point)> = world
        .positions
        .iter()
        .filter(|(name, _)| !name.contains('.'))
        .map(|(name, p)| (name, p.in_corridor()))
        .collect();
    let start_of = |name: &str| {
        world
            .position(name)
            .map(|p| p.in_corridor())
            .unwrap_or(Point::new(f64::NAN, f64::NAN))
    };
    let mut next = picker(seed);
    let mut tries = 0;
    while routes.len() < n && tries < 200 * n && doors.len() >= 2 {
        tries += 1;
        let (from, a) = doors[next(doors.len())];
        let (to, b) = doors[next(doors.len())];
        let clear = routes
            .iter()
            .all(|r| rome_maps::geometry::distance(start_of(&r.from), a) >= 2_000.0);
        if !clear || rome_maps::geometry::distance(a, b) < 20_000.0 {
            continue;
        }
        if Plan::new(&world, &network, from, to).is_ok() {
            routes.push(RouteSpec::new(&format!("r{}", routes.len() + 1), from, to));
        }
    }
    if routes.len() < n {
        return Err(NavError::Config(format!(
            "the map '{}' has routes for only {} robot(s) starting apart; give --routes",
            map.name,
            routes.len()
        )));
    }
    Ok(routes)
}

/// A picker of indices below `m`, the same sequence for the same seed on
/// every machine (a linear congruential generator: no crate's algorithm
/// may change under the runs).
fn picker(seed: u64) -> impl FnMut(usize) -> usize {
    let mut state = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
    move |m: usize| {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 33) % m.max(1) as u64) as usize
    }
}

/// `n` door jambs of `map` picked with `seed` (the same one may come
/// twice, as errands do): goals for tasks.
pub fn pick_doors(map: &Map, n: usize, seed: u64) -> Vec<String> {
    let world = World::from_map(map);
    let doors: Vec<&String> = world
        .positions
        .keys()
        .filter(|name| !name.contains('.'))
        .collect();
    if doors.is_empty() {
        return Vec::new();
    }
    let mut next = picker(seed);
    (0..n).map(|_| doors[next(doors.len())].clone()).collect()
}
