//! The Path Planner's global plan (§5.3): the shortest route, cut at its
//! corners into straight subpaths S_1 … S_n, and each subpath into at most
//! three segments S^l (count ceiling lights), S^d (dead reckoning to the
//! turning space or the goal) and S^c (leave the corner).
//!
//! ```text
//! A [S_1^l; S_1^d; S_1^c] U_1,  U_1 [S_2^l; S_2^d; S_2^c] U_2,  …  [S_n^l; S_n^d] B
//!     L      E      C              L      E      C                  L      D
//! ```
//!
//! A subpath that ends in a turning space ends in an Enter-Corner segment
//! (goal type `E`), the last one in a Dead-Reckoning segment (`D`); Tables
//! 6.1–6.2 count E and C together as the corner column.

use crate::board::{Corridor, Goal, GoalType, RouteInfo};
use crate::traffic::lanes::{self, Leg, LANE_PREFIX};
use crate::traffic::{Hold, Junctions, Rules, PASSAGE_PREFIX};
use rome_maps::geometry::{direction, distance, heading_to, normalize_deg, Point};
use rome_maps::{Network, Route, RouteError, World};

/// How far the Leave-Corner segment takes the robot from the middle of the
/// turning space into the outgoing corridor, mm.
pub const LEAVE_CORNER_MM: f64 = 1_800.0;
/// Lights nearer than this to where a segment starts are already overhead
/// or behind: not counted, mm.
pub const LIGHT_START_MARGIN_MM: f64 = 700.0;
/// Lights nearer than this to a turning space's middle are left to the
/// Enter-Corner segment, mm.
pub const LIGHT_END_MARGIN_MM: f64 = 600.0;
/// The last dead-reckoning leg is at least this long, mm: a light nearer
/// the goal is left to it, so that a robot counting that light at cruising
/// speed still has room to brake (0.8 m from 0.7 m/s at the base's 300
/// mm/s²) instead of ending past the goal.
pub const LAST_LEG_MIN_MM: f64 = 1_000.0;
/// A goal this far or farther off its corridor's middle is approached
/// along its own line, mm.
pub const LANE_MIN_MM: f64 = 200.0;
/// A stretch without lights at least this long is mapped by the local
/// mapper as an L segment is, mm: 3 m of it before its turning space, a
/// map long enough for a stale heading ([`crate::himm::HimmConfig::stale_mm`]).
pub const MAP_STRETCH_MM: i64 = 5_000;
/// How far ahead of a turning space's middle a wall counts as its end wall,
/// mm: beyond this the robot would see the corridor go on.
pub const END_WALL_REACH_MM: f64 = 4_000.0;
/// A light belongs to a subpath if it is this close to its line, mm.
pub const LIGHT_LATERAL_MM: f64 = 900.0;

/// One step of the plan: a goal and where it lies in the world.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// What the Navigator is told.
    pub goal: Goal,
    /// Subpath number, from 1.
    pub subpath: usize,
    /// For an L step: LightOffset, the distances from the segment's start
    /// to the first light and then between lights, mm.
    pub light_offsets_mm: Vec<f64>,
    /// Where the segment starts and ends on the route, mm (world frame).
    pub from: Point,
    /// End of the segment.
    pub to: Point,
    /// For an L, E or D step: how far the corridor's left and right walls
    /// are from the route, mm, as the map has them (the median over the segment,
    /// so doors and side corridors do not count), if both are there.
    pub walls_mm: Option<(f64, f64)>,
    /// For an E step: how far the wall straight ahead is from the middle of
    /// the turning space, mm, if the map has one within reach (a T or an L
    /// turn; none at a crossing).
    pub end_wall_mm: Option<f64>,
    /// For the last D step: how far the corridor's left and right walls
    /// stand from the goal, mm, if both are in reach.
    pub goal_walls_mm: Option<(f64, f64)>,
    /// For a V step: the ride; `from` is in the floor it starts on, `to`
    /// in the floor it ends on.
    pub ride: Option<crate::board::RideInfo>,
}

impl Step {
    /// The panes of `glass` within [`GLASS_REACH_MM`] of the step's leg, as
    /// the `Glass` variable has them: `[along, left]` of each end, mm, from
    /// the step's end along its direction and to its left.
    pub fn glass_mm(&self, glass: &[(Point, Point)]) -> Vec<[i64; 4]> {
        let (axis, left) = (
            direction(self.goal.direction_deg),
            direction(self.goal.direction_deg + 90.0),
        );
        let frame = |p: Point| {
            let d = p - self.to;
            [d.dot(&axis).round() as i64, d.dot(&left).round() as i64]
        };
        glass
            .iter()
            .filter(|&&(a, b)| {
                // Two segments that do not cross: the nearest of their
                // ends to the other.
                let d = |p, q, r| rome_maps::geometry::distance_to_segment(p, q, r);
                let (f, t) = (self.from, self.to);
                [d(a, f, t), d(b, f, t), d(f, a, b), d(t, a, b)]
                    .into_iter()
                    .fold(f64::INFINITY, f64::min)
                    <= GLASS_REACH_MM
            })
            .map(|&(a, b)| {
                let (a, b) = (frame(a), frame(b));
                [a[0], a[1], b[0], b[1]]
            })
            .collect()
    }

    /// For the last D step: how far left of the corridor's middle the
    /// goal lies, mm, when it lies at least [`LANE_MIN_MM`] off it (a door
    /// on a corridor's end wall); `None` for a goal on or near the middle,
    /// or where the walls beside it are not both known.
    pub fn lane_mm(&self) -> Option<f64> {
        let (left, right) = self.goal_walls_mm?;
        let off = (right - left) / 2.0;
        (off.abs() >= LANE_MIN_MM).then_some(off)
    }
}

/// A narrow passage on the route (edges tagged `passage=NAME`): the
/// Planner holds its semaphore from before step `first` until step `last`
/// is done, so robots take turns through it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PassageUse {
    /// The passage's name.
    pub name: String,
    /// The step before which the robot must hold the passage: the one that
    /// takes it into the turning space before it (or the first step).
    pub first: usize,
    /// The step after which the robot has left it: the one that takes it
    /// out of the turning space after it (or the last step).
    pub last: usize,
}

impl PassageUse {
    /// The passage's semaphore on the data server (`$passage/NAME`).
    pub fn semaphore(&self) -> String {
        format!("{PASSAGE_PREFIX}{}", self.name)
    }
}

/// The plan for one run.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The route it follows.
    pub route: Route,
    /// Its steps, in order.
    pub steps: Vec<Step>,
    /// Heading at the start, degrees: the robot is put down facing it.
    pub start_heading_deg: f64,
    /// The narrow passages it goes through.
    pub passages: Vec<PassageUse>,
    /// What the robot reserves on the way and when ([`crate::traffic`]):
    /// the narrow passages, and the junctions it turns in or crosses when
    /// the plan was made with the route network ([`Plan::through`]).
    pub holds: Vec<Hold>,
    /// The map's glass (each pane's ends, world frame): what the sensors
    /// do not hear, handed to the Navigator with the goals near it.
    pub glass: Vec<(Point, Point)>,
}

/// How far from a goal's leg glass is handed over with the goal, mm: the
/// sonars' useful reach in a turning space and beyond a corridor's walls.
pub const GLASS_REACH_MM: f64 = 4_000.0;

/// How often each mode occurs: the L / C / D columns of Tables 6.1–6.2.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ModeCount {
    /// Ceiling-light tracking segments.
    pub l: usize,
    /// Corners (an Enter-Corner followed by a Leave-Corner segment).
    pub c: usize,
    /// Dead-reckoning segments.
    pub d: usize,
    /// Elevator rides (§5.4.6).
    pub v: usize,
}

/// A route as tables name it: `341R to 381R`, with `via 301.secondL, …`
/// when it goes the long way round.
pub fn label(from: &str, via: &[String], to: &str) -> String {
    if via.is_empty() {
        format!("{from} to {to}")
    } else {
        format!("{from} to {to} via {}", via.join(", "))
    }
}

/// Makes a route through via positions drivable: a via position on a
/// straight stretch is no corner and leaves the corner points; one where
/// the way reverses is refused, by the name of the stop nearest to it.
fn drive_through(world: &World, route: &mut Route) -> Result<(), RouteError> {
    let points = &mut route.points;
    let mut k = 1;
    while k + 1 < points.len() {
        let turn = normalize_deg(
            heading_to(points[k], points[k + 1]) - heading_to(points[k - 1], points[k]),
        );
        if turn.abs() > 150.0 {
            let via = route
                .stops
                .iter()
                .filter_map(|name| world.position(name).map(|p| (name, p.in_corridor())))
                .min_by(|a, b| distance(a.1, points[k]).total_cmp(&distance(b.1, points[k])))
                .map_or_else(String::new, |(name, _)| name.clone());
            return Err(RouteError::TurnsBack {
                via,
                turn_deg: turn.abs(),
            });
        }
        if turn.abs() < 1.0 {
            points.remove(k);
        } else {
            k += 1;
        }
    }
    Ok(())
}

impl Plan {
    /// Plans the route from `from` to `to` and segments it.
    pub fn new(world: &World, network: &Network, from: &str, to: &str) -> Result<Plan, RouteError> {
        Plan::through(world, network, from, &[], to)
    }

    /// Plans the route from `from` to `to` through the `via` positions in
    /// order (the long way round) and segments it.
    pub fn through(
        world: &World,
        network: &Network,
        from: &str,
        via: &[String],
        to: &str,
    ) -> Result<Plan, RouteError> {
        let start = world
            .position(from)
            .ok_or_else(|| RouteError::Unknown {
                name: from.to_string(),
                similar: world.similar(from),
            })?
            .in_corridor();
        Plan::from_point(world, network, (from, start), via, to)
    }

    /// Plans the route from a point (where odometry puts a robot that
    /// stopped away from any named position; `start.0` names it) to `to`
    /// through the `via` positions, and segments it.
    pub fn from_point(
        world: &World,
        network: &Network,
        start: (&str, Point),
        via: &[String],
        to: &str,
    ) -> Result<Plan, RouteError> {
        let via: Vec<&str> = via.iter().map(String::as_str).collect();
        let mut route = world.route_from(network, start, &via, to)?;
        if !via.is_empty() {
            drive_through(world, &mut route)?;
        }
        let mut plan = Plan::segment(world, route);
        let junctions = Junctions::of(network);
        plan.holds.extend(junction_holds(&junctions, &plan.steps));
        let legs: Vec<Leg> = (plan.route.legs().iter().enumerate())
            .map(|(i, &(a, b, _, _))| {
                let (first, last) = leg_steps(&plan.steps, i + 1);
                Leg { a, b, first, last }
            })
            .collect();
        let width = |p: Point, q: Point| {
            let (l, r) = walls_beside(world, p, q, heading_to(p, q))?;
            Some(l + r)
        };
        plan.holds.extend(lanes::holds(&junctions, width, &legs));
        Ok(plan)
    }

    /// Leaves out the junctions: the robot reserves only the narrow
    /// passages and the lanes.
    pub fn without_junctions(mut self) -> Plan {
        self.holds.retain(|h| {
            h.semaphore.starts_with(PASSAGE_PREFIX) || h.semaphore.starts_with(LANE_PREFIX)
        });
        self
    }

    /// Leaves out the lanes: robots meet head on in corridors too narrow
    /// to pass in, as before lanes were driven one way at a time.
    pub fn without_lanes(mut self) -> Plan {
        self.holds.retain(|h| !h.semaphore.starts_with(LANE_PREFIX));
        self
    }

    /// The holds a fleet's rules keep: without [`Rules::traffic`] only the
    /// narrow passages and lanes ([`Plan::without_junctions`]), without
    /// [`Rules::lanes`] no lanes ([`Plan::without_lanes`]).
    pub fn keeping(self, rules: &Rules) -> Plan {
        let plan = if rules.traffic {
            self
        } else {
            self.without_junctions()
        };
        if rules.lanes {
            plan
        } else {
            plan.without_lanes()
        }
    }

    /// The route as tables name it ([`label`]).
    pub fn label(&self) -> String {
        match &self.route.stops[..] {
            [from, via @ .., to] => label(from, via, to),
            other => other.join(""),
        }
    }

    /// Segments a route.
    pub fn segment(world: &World, route: Route) -> Plan {
        let legs = route.legs();
        let mut lights: Vec<Point> = Vec::new();
        for l in &world.lights {
            // A light in a turning space is projected onto two edges (Table
            // 5.1's negative offsets): count it once.
            if !lights.iter().any(|p| distance(*p, l.at) < 150.0) {
                lights.push(l.at);
            }
        }
        let mut steps = Vec::new();
        let n = legs.len();
        for (i, &(a, b, len, heading)) in legs.iter().enumerate() {
            let subpath = i + 1;
            let last = i + 1 == n;
            let start_t = if i == 0 {
                0.0
            } else {
                LEAVE_CORNER_MM.min(len)
            };
            let end_t = if last {
                len - LAST_LEG_MIN_MM
            } else {
                len - LIGHT_END_MARGIN_MM
            };
            let d = direction(heading);
            let at = |t: f64| a + d * t;
            let mut ts: Vec<f64> = lights
                .iter()
                .filter_map(|p| {
                    let (dx, dy) = (p.x - a.x, p.y - a.y);
                    let t = dx * d.x + dy * d.y;
                    let lateral = (dx * d.y - dy * d.x).abs();
                    (lateral <= LIGHT_LATERAL_MM
                        && t >= start_t + LIGHT_START_MARGIN_MM
                        && t <= end_t)
                        .then_some(t)
                })
                .collect();
            ts.sort_by(f64::total_cmp);
            let mut t = start_t;
            if !ts.is_empty() {
                let mut offsets = Vec::with_capacity(ts.len());
                let mut prev = start_t;
                for &lt in &ts {
                    offsets.push(lt - prev);
                    prev = lt;
                }
                steps.push(Step {
                    goal: Goal {
                        goal_type: GoalType::L,
                        distance: ts.len() as i64,
                        direction_deg: heading,
                    },
                    subpath,
                    light_offsets_mm: offsets,
                    from: at(t),
                    to: at(prev),
                    walls_mm: walls_beside(world, at(t), at(prev), heading),
                    end_wall_mm: None,
                    goal_walls_mm: None,
                    ride: None,
                });
                t = prev;
            }
            steps.push(Step {
                goal: Goal {
                    goal_type: if last { GoalType::D } else { GoalType::E },
                    distance: (len - t).max(0.0).round() as i64,
                    direction_deg: heading,
                },
                subpath,
                light_offsets_mm: Vec::new(),
                from: at(t),
                to: b,
                walls_mm: walls_beside(world, at(t), b, heading),
                end_wall_mm: (!last)
                    .then(|| ray(world, b, heading, END_WALL_REACH_MM))
                    .flatten(),
                goal_walls_mm: last.then(|| goal_walls(world, b, heading)).flatten(),
                ride: None,
            });
            if !last {
                let (_, _, next_len, next_heading) = legs[i + 1];
                let nd = direction(next_heading);
                let leave = LEAVE_CORNER_MM.min(next_len);
                steps.push(Step {
                    goal: Goal {
                        goal_type: GoalType::C,
                        distance: leave.round() as i64,
                        direction_deg: next_heading,
                    },
                    subpath,
                    light_offsets_mm: Vec::new(),
                    from: b,
                    to: b + nd * leave,
                    walls_mm: None,
                    end_wall_mm: None,
                    goal_walls_mm: None,
                    ride: None,
                });
            }
        }
        let start_heading_deg = legs.first().map_or(0.0, |l| l.3);
        let passages = passages_on(world, &legs, &steps);
        let holds = passages
            .iter()
            .map(|p| Hold {
                semaphore: p.semaphore(),
                first: p.first,
                last: p.last,
            })
            .collect();
        let glass = world
            .segments
            .iter()
            .filter(|s| s.kind == rome_maps::model::EdgeKind::Glass)
            .map(|s| (s.a, s.b))
            .collect();
        Plan {
            route,
            steps,
            start_heading_deg,
            passages,
            holds,
            glass,
        }
    }

    /// The modes the plan needs, as Tables 6.1–6.2 count them.
    pub fn modes(&self) -> ModeCount {
        let mut m = ModeCount::default();
        for s in &self.steps {
            match s.goal.goal_type {
                GoalType::L => m.l += 1,
                GoalType::C => m.c += 1,
                GoalType::D => m.d += 1,
                GoalType::V => m.v += 1,
                GoalType::E => {}
            }
        }
        m
    }

    /// The start (first route point) and goal (last route point).
    pub fn ends(&self) -> (Point, Point) {
        let p = &self.route.points;
        (p[0], p[p.len() - 1])
    }

    /// The plan in the thesis' notation, one subpath per line.
    pub fn describe(&self) -> Vec<String> {
        self.steps
            .iter()
            .map(|s| {
                let what = match s.goal.goal_type {
                    GoalType::L => format!(
                        "S{}^l  track {} light(s) at {} mm",
                        s.subpath,
                        s.goal.distance,
                        s.light_offsets_mm
                            .iter()
                            .map(|d| format!("{d:.0}"))
                            .collect::<Vec<_>>()
                            .join("+")
                    ),
                    GoalType::D => match s.lane_mm() {
                        Some(lane) => format!(
                            "S{}^d  dead-reckon {} mm to the goal, {:.0} mm {} of the middle",
                            s.subpath,
                            s.goal.distance,
                            lane.abs(),
                            if lane > 0.0 { "left" } else { "right" }
                        ),
                        None => format!(
                            "S{}^d  dead-reckon {} mm to the goal",
                            s.subpath, s.goal.distance
                        ),
                    },
                    GoalType::E => format!(
                        "S{}^d  enter the corner: {} mm to the turning space",
                        s.subpath, s.goal.distance
                    ),
                    GoalType::C => format!(
                        "S{}^c  leave the corner: turn to {:.0}° and go {} mm",
                        s.subpath, s.goal.direction_deg, s.goal.distance
                    ),
                    GoalType::V => match &s.ride {
                        Some(r) => format!(
                            "S{}^v  ride elevator {} (marker {}) from floor {} to floor {}",
                            s.subpath, r.elevator, r.marker, r.from, r.to
                        ),
                        None => format!("S{}^v  ride an elevator", s.subpath),
                    },
                };
                format!("{what}  (heading {:.0}°)", s.goal.direction_deg)
            })
            .collect()
    }
}

/// One hold per junction the plan turns in: from its Enter-Corner step
/// to the Leave-Corner step after it. Steps that pass a junction straight
/// do not hold it: a robot crossing would hold it for a whole segment,
/// tens of metres, and at 40 robots on EB3 that kept the turning ones
/// waiting until fewer arrived than with no reservations at all.
fn junction_holds(junctions: &Junctions, steps: &[Step]) -> Vec<Hold> {
    let mut out: Vec<Hold> = Vec::new();
    for (i, step) in steps.iter().enumerate() {
        if !matches!(step.goal.goal_type, GoalType::E | GoalType::C) {
            continue;
        }
        for k in junctions.on_line(step.from, step.to) {
            let semaphore = Junctions::semaphore(k);
            match out
                .iter_mut()
                .find(|h| h.semaphore == semaphore && h.last + 1 == i)
            {
                Some(h) => h.last = i,
                None => out.push(Hold {
                    semaphore,
                    first: i,
                    last: i,
                }),
            }
        }
    }
    out
}

/// The passages along each leg, and the steps that hold them.
fn passages_on(
    world: &World,
    legs: &[(Point, Point, f64, f64)],
    steps: &[Step],
) -> Vec<PassageUse> {
    let mut out: Vec<PassageUse> = Vec::new();
    for (i, &(a, _, len, heading)) in legs.iter().enumerate() {
        let d = direction(heading);
        let project = |p: Point| {
            let (dx, dy) = (p.x - a.x, p.y - a.y);
            (dx * d.x + dy * d.y, (dx * d.y - dy * d.x).abs())
        };
        let subpath = i + 1;
        for seg in &world.segments {
            let Some(name) = &seg.passage else { continue };
            let ((ta, la), (tb, lb)) = (project(seg.a), project(seg.b));
            // A wall of this leg's corridor: beside the route, along it.
            let beside = la.max(lb) <= 3_000.0 && (la - lb).abs() < 300.0;
            let overlap = ta.max(tb).min(len) - ta.min(tb).max(0.0);
            if !beside || overlap < 500.0 {
                continue;
            }
            let (first, last) = leg_steps(steps, subpath);
            match out.iter_mut().find(|p| &p.name == name) {
                Some(p) => {
                    p.first = p.first.min(first);
                    p.last = p.last.max(last);
                }
                None => out.push(PassageUse {
                    name: name.clone(),
                    first,
                    last,
                }),
            }
        }
    }
    out
}

/// The steps that hold what leg `subpath` drives through: from the one
/// that takes the robot into the turning space before it (or the first)
/// to the one that takes it out of the turning space after it (or the
/// last).
fn leg_steps(steps: &[Step], subpath: usize) -> (usize, usize) {
    let first = if subpath == 1 {
        0
    } else {
        steps
            .iter()
            .position(|s| s.subpath == subpath - 1 && s.goal.goal_type == GoalType::E)
            .unwrap_or(0)
    };
    let last = steps
        .iter()
        .position(|s| s.subpath == subpath && s.goal.goal_type == GoalType::C)
        .unwrap_or(steps.len().saturating_sub(1));
    (first, last)
}

/// How far a ray from `at` along `heading_deg` goes before it meets a
/// solid edge (not an opening), mm; `None` beyond `max_mm`.
pub(crate) fn ray(world: &World, at: Point, heading_deg: f64, max_mm: f64) -> Option<f64> {
    let d = direction(heading_deg);
    world
        .segments
        .iter()
        .filter(|s| s.kind != rome_maps::model::EdgeKind::Opening)
        .filter_map(|s| {
            let e = (s.b.x - s.a.x, s.b.y - s.a.y);
            let det = d.x * e.1 - d.y * e.0;
            if det.abs() < 1e-9 {
                return None;
            }
            let w = (s.a.x - at.x, s.a.y - at.y);
            let t = (w.0 * e.1 - w.1 * e.0) / det;
            let u = (w.0 * d.y - w.1 * d.x) / det;
            (t > 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
        })
        .fold(None, |best: Option<f64>, t| {
            Some(best.map_or(t, |b| b.min(t)))
        })
        .filter(|t| *t <= max_mm)
}

/// How far the walls left and right of a goal at `goal`, reached along
/// `heading_deg`, stand from it, mm: measured just before it (a goal at a
/// door is beside the door's jamb, not in its opening).
fn goal_walls(world: &World, goal: Point, heading_deg: f64) -> Option<(f64, f64)> {
    let p = goal - direction(heading_deg) * 600.0;
    let left = ray(world, p, heading_deg + 90.0, 5_000.0)?;
    let right = ray(world, p, heading_deg - 90.0, 5_000.0)?;
    Some((left, right))
}

/// The walls left and right of the route between `from` and `to`: the
/// median distance over eleven points along it.
pub(crate) fn walls_beside(
    world: &World,
    from: Point,
    to: Point,
    heading_deg: f64,
) -> Option<(f64, f64)> {
    let median = |mut v: Vec<f64>| {
        if v.len() < 6 {
            return None;
        }
        v.sort_by(f64::total_cmp);
        Some(v[v.len() / 2])
    };
    let (mut left, mut right) = (Vec::new(), Vec::new());
    for k in 0..=10 {
        let f = f64::from(k) / 10.0;
        let p = from + (to - from) * f;
        left.extend(ray(world, p, heading_deg + 90.0, 5_000.0));
        right.extend(ray(world, p, heading_deg - 90.0, 5_000.0));
    }
    Some((median(left)?, median(right)?))
}

// The blackboard's forms of a plan: the board knows nothing of plans, a
// plan knows how it is written on the board.
impl RouteInfo {
    /// The route of `plan`.
    pub fn of(plan: &Plan) -> RouteInfo {
        let stops = &plan.route.stops;
        RouteInfo {
            from: stops.first().cloned().unwrap_or_default(),
            to: stops.last().cloned().unwrap_or_default(),
            points: plan.route.points.iter().map(|p| [p.x, p.y]).collect(),
            length_mm: plan.route.length_mm,
        }
    }
}

impl Corridor {
    /// The corridor of a plan step.
    pub fn of(step: &Step) -> Corridor {
        Corridor {
            x_mm: step.from.x,
            y_mm: step.from.y,
            heading_deg: step.goal.direction_deg,
            left_mm: step.walls_mm.map(|w| w.0),
            right_mm: step.walls_mm.map(|w| w.1),
            no_lights: step.goal.goal_type != GoalType::L,
        }
    }
}

#[cfg(test)]
pub(crate) mod tests;
