//! Lanes: stretches of corridor too narrow for two robots to pass, driven
//! one way at a time.
//!
//! A lane is the stretch of a corridor between two junctions (or between
//! a junction and the corridor's dead end) narrower than [`PASSING_MM`].
//! Robots going the same way may be in it together; one about to go the
//! other way waits, outside, until the last of them has left. Its name is
//! its two ends, `$traffic/lane/012-015` (junction numbers; a dead end is
//! `012-end-h090`, its junction and the heading out of it into the dead
//! end), and it has three semaphores:
//!
//! - `…/up` and `…/down`, of value [`LANE_CAPACITY`]: each robot in the
//!   lane holds one unit of its way's, with an undo wait. `up` is the way
//!   east (or north, for a corridor running north–south).
//! - `…/gate`, of value 1: held while a robot makes sure the other way is
//!   empty. It waits for every unit of the other way's semaphore (one
//!   `units=N` wait) and gives them straight back, takes a unit of its
//!   own way's, and gives the gate back. Robots that come while the gate
//!   is held queue behind it, so the ways take turns and neither starves.
//!
//! Every unit is taken with an undo wait: a robot whose Planner dies in a
//! lane, or at its gate, frees it. The Planner takes a lane as it takes a
//! junction, in the chain discipline of [`super`]: everything a chain
//! needs is taken, in name order, before the robot drives into it. A robot
//! waiting at a gate waits for robots that hold their whole chain and are
//! driving out, so a lane adds no circle of waits.

use super::{Hold, Junctions, JUNCTION_REACH_MM};
use rome_maps::geometry::Point;

/// What a lane's semaphores are called before its name.
pub const LANE_PREFIX: &str = "$traffic/lane/";

/// Corridors narrower than this are lanes, mm: two robots of 0.76 m
/// (`rome_schema::robot::body::ROBOT_RADIUS_MM` × 2) passing each other
/// with less than about 0.5 m beside and between them touch, or stand.
pub const PASSING_MM: f64 = 3_000.0;

/// How many robots may be in a lane one way at once: more than any fleet,
/// so only the other way's robots ever wait.
pub const LANE_CAPACITY: u64 = 1_000;

/// How far from a junction's middle a lane's width is measured, mm: out
/// of the turning space and of the corridors that cross there.
const MEASURE_FROM_JUNCTION_MM: f64 = 2_500.0;

/// A stretch of a route: the straight line from `a` to `b`, driven by the
/// plan's steps `first ..= last` (from the one that turns into it to the
/// one that turns out of it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leg {
    /// Where it starts.
    pub a: Point,
    /// Where it ends.
    pub b: Point,
    /// The step before which a lane on it must be held.
    pub first: usize,
    /// The step after which the robot is out of it.
    pub last: usize,
}

/// The lanes the legs drive, one hold per lane and leg, held the leg's
/// steps. `width(p, q)` is the corridor's width along the line from `p` to
/// `q` (its walls left and right), `None` where they are not both known.
pub fn holds(
    junctions: &Junctions,
    width: impl Fn(Point, Point) -> Option<f64>,
    legs: &[Leg],
) -> Vec<Hold> {
    let mut out = Vec::new();
    for leg in legs {
        let (dx, dy) = (leg.b.x - leg.a.x, leg.b.y - leg.a.y);
        let len = dx.hypot(dy);
        if len < 1.0 {
            continue;
        }
        // The corridor's own direction: east, or north if it runs more
        // north–south than east–west. Every robot names the lane the same.
        let (mut ux, mut uy) = (dx / len, dy / len);
        let flip = if ux.abs() >= uy.abs() {
            ux < 0.0
        } else {
            uy < 0.0
        };
        if flip {
            (ux, uy) = (-ux, -uy);
        }
        let up = dx * ux + dy * uy > 0.0;
        let along = |p: Point| (p.x - leg.a.x) * ux + (p.y - leg.a.y) * uy;
        let across = |p: Point| ((p.x - leg.a.x) * uy - (p.y - leg.a.y) * ux).abs();
        let at = |t: f64| Point::new(leg.a.x + ux * t, leg.a.y + uy * t);
        let end = along(leg.b);
        let (ta, tb) = (end.min(0.0), end.max(0.0));
        // The junctions on the corridor's line, in its direction.
        let mut ends: Vec<(f64, usize)> = (0..junctions.len())
            .map(|k| (junctions.centre(k), k))
            .filter(|(c, _)| across(*c) <= JUNCTION_REACH_MM)
            .map(|(c, k)| (along(c), k))
            .collect();
        ends.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut bounds: Vec<(f64, Option<usize>)> = vec![(f64::NEG_INFINITY, None)];
        bounds.extend(ends.iter().map(|&(t, k)| (t, Some(k))));
        bounds.push((f64::INFINITY, None));
        for pair in bounds.windows(2) {
            let ((t0, j0), (t1, j1)) = (pair[0], pair[1]);
            // The stretch's part outside both turning spaces, and how much
            // of it the leg drives.
            let (s0, s1) = (t0 + JUNCTION_REACH_MM, t1 - JUNCTION_REACH_MM);
            if s1 - s0 < 500.0 || ta.max(s0) + 500.0 > tb.min(s1) {
                continue;
            }
            // Measured over the whole stretch between two junctions, so
            // every robot finds the same; a dead end over what is driven.
            let m0 = if j0.is_some() {
                t0 + MEASURE_FROM_JUNCTION_MM
            } else {
                ta
            };
            let m1 = if j1.is_some() {
                t1 - MEASURE_FROM_JUNCTION_MM
            } else {
                tb
            };
            let Some(w) = width(at(m0.min(m1)), at(m0.max(m1))) else {
                continue;
            };
            if w >= PASSING_MM {
                continue;
            }
            let lane = match (j0, j1) {
                (Some(a), Some(b)) => format!("{LANE_PREFIX}{:03}-{:03}", a.min(b), a.max(b)),
                // A dead end: its junction, and which of the junction's
                // four ways it leaves by.
                (Some(k), None) | (None, Some(k)) => {
                    let heading = uy.atan2(ux).to_degrees().round() as i64;
                    let heading = if j1.is_none() { heading } else { heading + 180 };
                    format!("{LANE_PREFIX}{k:03}-end-h{:03}", heading.rem_euclid(360))
                }
                (None, None) => continue,
            };
            out.push(Hold {
                semaphore: format!("{lane}/{}", if up { "up" } else { "down" }),
                first: leg.first,
                last: leg.last,
            });
        }
    }
    out
}

/// A lane's semaphores, from the semaphore of one of its ways.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Lane {
    /// The lane's name, `$traffic/lane/012-015`.
    pub name: String,
    /// The way held: `…/up` or `…/down`.
    pub way: String,
    /// The other way.
    pub other: String,
    /// Its gate, `…/gate`.
    pub gate: String,
}

impl Lane {
    /// The lane whose way `semaphore` is; `None` for anything else.
    pub fn of(semaphore: &str) -> Option<Lane> {
        let rest = semaphore.strip_prefix(LANE_PREFIX)?;
        let (name, way) = rest.rsplit_once('/')?;
        let other = match way {
            "up" => "down",
            "down" => "up",
            _ => return None,
        };
        let name = format!("{LANE_PREFIX}{name}");
        Some(Lane {
            way: semaphore.to_string(),
            other: format!("{name}/{other}"),
            gate: format!("{name}/gate"),
            name,
        })
    }

    /// The lane as people call it: `the narrow corridor 012-015 (up)`.
    pub fn describe(&self) -> String {
        let name = self.name.strip_prefix(LANE_PREFIX).unwrap_or(&self.name);
        let way = self.way.rsplit('/').next().unwrap_or_default();
        let toward = if way == "up" {
            "east or north"
        } else {
            "west or south"
        };
        format!("the narrow corridor {name} (driven one way at a time; this way {toward})")
    }
}
