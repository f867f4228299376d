//! Traffic: the parts of the building robots cannot share, reserved on the
//! data server before a robot drives into them, in an order that cannot
//! deadlock (docs/traffic.md has the argument and a picture).
//!
//! The parts are the junctions (turning spaces: the route network's
//! waypoints, those nearer than [`JUNCTION_MERGE_MM`] to each other taken
//! as one crossing), the narrow passages (edges tagged `passage=NAME`) and
//! the lanes (corridors too narrow to pass in, driven one way at a time:
//! [`lanes`]).
//! Each is a semaphore of value 1 (§4.6.1): `$traffic/junction/NNN` and
//! `$passage/NAME`. A robot holds a junction it turns in, from its
//! Enter-Corner step (whose line ends within [`JUNCTION_REACH_MM`] of the
//! junction's middle) to the Leave-Corner step after it. It does not hold
//! junctions it crosses straight.
//!
//! The discipline:
//! - A robot holds a part ([`Hold`]) from before the first step that uses
//!   it until the last one is done, then gives it back at once.
//! - Holds whose steps overlap form a [`Chain`]: between two chains the
//!   robot stands in a corridor, outside every junction and passage,
//!   holding nothing.
//! - Before a chain's first step the robot takes every part of the chain,
//!   one after another in the order of their names, and waits there (in
//!   the corridor) until it has them all; only then does it drive on.
//!
//! A robot that waits therefore holds only parts that come before, in
//! name order, the part it waits for; a robot that holds a part another
//! waits for is either driving (and gives it back) or waiting for a part
//! later still. A circle of robots each waiting for the next would need
//! names that rise all the way round it: there is none. Every unit is
//! taken with an undo wait, so a robot whose Planner dies frees what it
//! held (the data server sees its liveliness go).
//!
//! [`oneway`] is the other way to keep robots from meeting head on in
//! narrow corridors: give those on loops a fixed way, and plan routes that
//! keep to it. Nothing is reserved for them then.

pub mod lanes;
pub mod oneway;

use rome_maps::geometry::{distance, distance_to_segment, Point};
use rome_maps::Network;
use serde::{Deserialize, Serialize};

/// What a narrow passage's semaphore is called before its name.
pub const PASSAGE_PREFIX: &str = "$passage/";

/// Waypoints nearer than this to each other are one junction (the four
/// building corners of a crossing, the two of a T), mm.
pub const JUNCTION_MERGE_MM: f64 = 2_500.0;
/// A step uses a junction when its line passes this near the junction's
/// middle, mm: inside a 2.4 m turning space, not after the Leave-Corner
/// segment's 1.8 m out of it.
pub const JUNCTION_REACH_MM: f64 = 1_500.0;

/// The rules a fleet's robots drive by, beyond the narrow passages they
/// always reserve. Every command and harness that drives robots carries
/// them as one value, so a flag added here reaches all of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rules {
    /// Reserve the junctions a robot turns in, not only narrow passages.
    /// Off by default: robots that wait for a junction stand on the
    /// corridor's centre line at its mouth, where those leaving it cannot
    /// get past (docs/traffic.md).
    pub traffic: bool,
    /// Drive corridors too narrow to pass in one way at a time
    /// ([`lanes`]). Off by default: ten robots on EB3 did fewer tasks and
    /// touched more with it (docs/traffic.md).
    pub lanes: bool,
    /// The narrow corridors that lie on loops are driven one way only, and
    /// routes keep to their way ([`oneway`]). It shapes the route network
    /// a robot is given, so every robot of a fleet and its dispatcher must
    /// agree on it.
    pub one_way: bool,
    /// A robot without a task that stands where the map gives no walls
    /// beside it (a junction) drives on into a corridor before it steps
    /// aside, and one stopped short steps aside across the corridor the
    /// nearest door lies in rather than across its heading. Off by
    /// default: forty robots on EB3 did better with it in one task set of
    /// four and worse in two (docs/tasks.md).
    pub leave_open: bool,
    /// Held up with a task, a robot asks the nearest idle robot in its way
    /// to make way, and idle, it makes way when asked
    /// ([`crate::fleet::way`]). Off by default: of six task sets of forty
    /// robots on EB3 (with `one_way` and `leave_open`) it did better in two
    /// and no worse in four, but a hundred robots on the Campus touched
    /// more with it (docs/tasks.md).
    pub make_way: bool,
    /// A robot between tasks, before it steps aside, with another waiting
    /// within [`crate::fleet::way::WAY_APART_MM`], drives on along the
    /// corridor to a door clear of robots waiting and steps aside there:
    /// two waiting side by side across a corridor close it. On by default.
    pub stand_apart: bool,
}

impl Default for Rules {
    fn default() -> Rules {
        Rules {
            traffic: false,
            lanes: false,
            one_way: false,
            leave_open: false,
            make_way: false,
            stand_apart: true,
        }
    }
}

/// The junctions of a route network, numbered the same way by every robot
/// that loads the same map.
#[derive(Debug, Clone, PartialEq)]
pub struct Junctions {
    centres: Vec<Point>,
}

impl Junctions {
    /// The network's waypoints, those within [`JUNCTION_MERGE_MM`] of each
    /// other (directly or through others) merged, numbered west to east
    /// then south to north.
    pub fn of(network: &Network) -> Junctions {
        Junctions::from_points(network.waypoints())
    }

    /// [`Junctions::of`] from bare waypoints.
    pub fn from_points(points: &[Point]) -> Junctions {
        let mut group: Vec<usize> = (0..points.len()).collect();
        fn root(group: &mut [usize], mut i: usize) -> usize {
            while group[i] != i {
                group[i] = group[group[i]];
                i = group[i];
            }
            i
        }
        for i in 0..points.len() {
            for j in i + 1..points.len() {
                if distance(points[i], points[j]) < JUNCTION_MERGE_MM {
                    let (a, b) = (root(&mut group, i), root(&mut group, j));
                    group[a.max(b)] = a.min(b);
                }
            }
        }
        let mut sums: std::collections::BTreeMap<usize, (f64, f64, f64)> = Default::default();
        for (i, p) in points.iter().enumerate() {
            let r = root(&mut group, i);
            let s = sums.entry(r).or_insert((0.0, 0.0, 0.0));
            *s = (s.0 + p.x, s.1 + p.y, s.2 + 1.0);
        }
        let mut centres: Vec<Point> = sums
            .values()
            .map(|&(x, y, n)| Point::new(x / n, y / n))
            .collect();
        centres.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
        Junctions { centres }
    }

    /// How many there are.
    pub fn len(&self) -> usize {
        self.centres.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.centres.is_empty()
    }

    /// Junction `k`'s middle.
    pub fn centre(&self, k: usize) -> Point {
        self.centres[k]
    }

    /// Junction `k`'s semaphore.
    pub fn semaphore(k: usize) -> String {
        format!("$traffic/junction/{k:03}")
    }

    /// The junctions the straight line from `a` to `b` passes within
    /// [`JUNCTION_REACH_MM`] of.
    pub fn on_line(&self, a: Point, b: Point) -> Vec<usize> {
        (0..self.centres.len())
            .filter(|&k| distance_to_segment(self.centres[k], a, b) <= JUNCTION_REACH_MM)
            .collect()
    }
}

/// A part of the building a robot holds from before step `first` until
/// step `last` is done.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Hold {
    /// The part's semaphore on the data server.
    pub semaphore: String,
    /// The first step that uses it.
    pub first: usize,
    /// The last step that uses it.
    pub last: usize,
}

/// Steps `first ..= last`, driven only once every part in `holds` is taken.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Chain {
    /// Its first step: everything is taken before it.
    pub first: usize,
    /// Its last step: everything is given back by its end.
    pub last: usize,
    /// What it holds, in the order it is taken (by name), each part once.
    pub holds: Vec<Hold>,
}

/// Groups holds into chains: holds whose steps overlap go together. Where
/// one hold ends and the next begins with the step after, the robot stands
/// between them outside every junction's reach (the step that follows
/// starts where the last one ended, and no longer uses the junction), so
/// it may give back the one before it takes the next.
pub fn chains(holds: &[Hold]) -> Vec<Chain> {
    let mut sorted: Vec<&Hold> = holds.iter().collect();
    sorted.sort_by_key(|h| (h.first, h.last));
    let mut out: Vec<Chain> = Vec::new();
    for h in sorted {
        // A chain that drives a lane both ways holds it the first way
        // throughout: waiting for the other way to empty, it would wait
        // for itself.
        let other = lanes::Lane::of(&h.semaphore).map(|l| l.other);
        match out.last_mut() {
            Some(c) if h.first <= c.last => {
                c.last = c.last.max(h.last);
                let same =
                    |x: &Hold| x.semaphore == h.semaphore || Some(&x.semaphore) == other.as_ref();
                match c.holds.iter_mut().find(|x| same(x)) {
                    Some(x) => {
                        x.first = x.first.min(h.first);
                        x.last = x.last.max(h.last);
                    }
                    None => c.holds.push(h.clone()),
                }
            }
            _ => out.push(Chain {
                first: h.first,
                last: h.last,
                holds: vec![h.clone()],
            }),
        }
    }
    for c in &mut out {
        c.holds.sort_by(|a, b| a.semaphore.cmp(&b.semaphore));
    }
    out
}

/// A part as people call it: `the narrow passage N`, `junction 012`.
pub fn describe(semaphore: &str) -> String {
    if let Some(name) = semaphore.strip_prefix(PASSAGE_PREFIX) {
        format!("the narrow passage {name}")
    } else if let Some(k) = semaphore.strip_prefix("$traffic/junction/") {
        format!("junction {k}")
    } else if let Some(lane) = lanes::Lane::of(semaphore) {
        lane.describe()
    } else {
        semaphore.to_string()
    }
}

/// What a robot holds and waits for, on its blackboard (`nav/<robot>/Traffic`)
/// for people watching: `rome data get nav/r1/Traffic`, `rome view`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TrafficState {
    /// The parts it holds, by semaphore.
    pub holds: Vec<String>,
    /// The part it waits for, if any.
    pub waits_for: Option<String>,
    /// A lane's way whose every unit it may hold for a moment, making
    /// sure nobody drives the lane the other way ([`lanes`]): given back
    /// with the rest if the run ends there.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub draining: Option<String>,
}

#[cfg(test)]
mod tests;
