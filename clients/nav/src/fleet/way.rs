//! Making way (§4.7: several robots, one data server). A robot held up
//! with a task asks the nearest robot standing idle just ahead of it to
//! drive on ([`WayAsk`] on its own `nav/<robot>/Way`, and an up() on that
//! one's `$nav/<robot>/Task`); the one asked, busy meanwhile, drives ahead
//! the way the asker goes to a position a few metres on ([`way_to`]), and
//! steps aside there as after any task. A robot making way asks nobody:
//! asks passed on from robot to robot making way drove them into each
//! other.
//!
//! Why: a robot between tasks whose step aside was cut short, or that
//! stands where no walls are beside it, can leave a passing robot too
//! little room, and the one held up behind it gives its task up. Only the
//! robot in the way can change that, and the data server is all that
//! connects the two.

use super::aside::LastLeg;
use super::duty::{Aside, DutyConfig, DutyNote, OnDuty};
use super::schema::{
    decode, making_way_for, task_sem, way_var, Assignment, Duty, DutyState, WayAsk,
    STAND_APART_TASK,
};
use crate::NavError;
use rome_maps::geometry::{direction, distance, distance_to_segment, Point};
use rome_maps::route::Route;
use rome_maps::{Network, World};
use std::collections::BTreeMap;
use std::convert::Infallible;
use std::sync::atomic::{AtomicBool, Ordering::Relaxed};
use std::time::Duration;

/// How long a robot with a task, not waiting its turn, gets no further
/// than [`ASK_RADIUS_MM`] before it asks, and between two asks. Well
/// within the time after which it would give its task up as blocked.
pub const ASK_AFTER: Duration = Duration::from_secs(15);

/// How far a robot must get within [`ASK_AFTER`] not to ask, mm.
pub const ASK_RADIUS_MM: f64 = 1_000.0;

/// How near the asker an idle robot must stand to be asked, mm: one body
/// beside or ahead of it, with room to pass between.
pub const ASK_NEAR_MM: f64 = 2_500.0;

/// How far behind the asker, against the way it goes, a robot may stand
/// and still be asked, mm: one beside it holds it up too.
pub const ASK_BEHIND_MM: f64 = 500.0;

/// How far ahead along the asker's way a robot making way drives at the
/// least, mm.
pub const WAY_ON_MM: f64 = 3_000.0;

/// How near the asker the way there may come, mm (where the robot does
/// not start nearer): two bodies' half widths and a gap.
pub const WAY_CLEAR_MM: f64 = 1_200.0;

/// How near another idle robot a robot making way may stop, mm.
pub const WAY_APART_MM: f64 = 1_500.0;

/// How far from where it stands a position is looked at, mm.
const WAY_NEAR_MM: f64 = 30_000.0;

/// The heading of `route`'s leg nearest `at`, degrees: the way a robot
/// driving it goes there, whichever way its odometry says it faces.
pub fn way_heading(route: &Route, at: Point) -> Option<f64> {
    (route.legs().into_iter())
        .filter(|l| l.2 > 1.0)
        .min_by(|a, b| {
            distance_to_segment(at, a.0, a.1).total_cmp(&distance_to_segment(at, b.0, b.1))
        })
        .map(|l| l.3)
}

/// What a position a robot drives on to ([`way_to`]) keeps clear of, and
/// how far it may lie.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    /// How near a robot waiting, or the asker's goal, it may be, mm.
    pub apart_mm: f64,
    /// Door jambs only: a ring's node may stand in a turning space, where
    /// no wall is beside it to wait by.
    pub doors_only: bool,
    /// The longest route to it, mm.
    pub route_mm: f64,
}

/// Making way: clear of the asker's goal and of robots waiting by a
/// body and more, anywhere within 30 m.
pub const MAKING_WAY: Reach = Reach {
    apart_mm: WAY_APART_MM,
    doors_only: false,
    route_mm: f64::INFINITY,
};

/// Standing apart: [`APART_MM`] from every robot waiting, at a door, no
/// more than [`APART_ROUTE_MM`] away. A longer drive, through a fleet
/// this dense, meets more robots than the wait would have held up.
pub const APART: Reach = Reach {
    apart_mm: APART_MM,
    doors_only: true,
    route_mm: APART_ROUTE_MM,
};

/// The position a robot standing at `here` drives to, to make way for a
/// robot held up at `asker` going `heading_deg` to `goal`: one at least
/// [`WAY_ON_MM`] further on that way than `here`, whose route from `here`
/// comes no nearer the asker than [`WAY_CLEAR_MM`] (or than `here` is),
/// as far as `reach` says from the asker's goal and every robot
/// `waiting`; the nearest by route, ties by name.
/// `None`: no such position within 30 m, or within `reach`'s route.
pub fn way_to(
    world: &World,
    network: &Network,
    here: Point,
    (asker, heading_deg, goal): (Point, f64, Point),
    (waiting, reach): (&[Point], &Reach),
) -> Option<String> {
    let on = direction(heading_deg);
    let keep = distance(here, asker).min(WAY_CLEAR_MM) - 50.0;
    world
        .positions
        .iter()
        .filter(|(_, p)| p.door || !reach.doors_only)
        .filter_map(|(name, p)| {
            let q = p.in_corridor();
            let off = q - here;
            if off.norm() > WAY_NEAR_MM || off.dot(&on) < WAY_ON_MM {
                return None;
            }
            if (waiting.iter().chain([&goal])).any(|w| distance(*w, q) < reach.apart_mm) {
                return None;
            }
            let route = world.route_from(network, ("here", here), &[], name).ok()?;
            let near = (route.legs().into_iter())
                .map(|(a, b, _, _)| distance_to_segment(asker, a, b))
                .fold(f64::INFINITY, f64::min);
            let within = route.length_mm <= reach.route_mm;
            (near >= keep && within).then(|| (route.length_mm, name.clone()))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)))
        .map(|(_, name)| name)
}

/// The robot a robot held up at `here`, going `heading_deg`, asks to make
/// way, of `others` (name, duty, where it stands): the nearest idle one
/// without a task within [`ASK_NEAR_MM`], not more than [`ASK_BEHIND_MM`]
/// behind; ties by name. The nearest only: two asked at once drive off side
/// by side into each other, and one still in the way is asked at the next
/// ask. Nobody while one is still making way for it (named `me`): a
/// second one set off beside the first drives into it or the asker.
pub fn in_the_way<'a>(
    (me, here, heading_deg): (&str, Point, f64),
    others: &'a [(String, Duty, Point)],
) -> Option<&'a str> {
    let on = direction(heading_deg);
    let mine = making_way_for(me);
    if (others.iter()).any(|(_, d, _)| d.task.as_deref() == Some(mine.as_str())) {
        return None;
    }
    (others.iter())
        .filter(|(_, d, _)| d.state == DutyState::Idle && d.task.is_none())
        .map(|(name, _, p)| (name.as_str(), *p - here))
        .filter(|(_, off)| off.norm() <= ASK_NEAR_MM && off.dot(&on) >= -ASK_BEHIND_MM)
        .min_by(|a, b| a.1.norm().total_cmp(&b.1.norm()).then_with(|| a.0.cmp(b.0)))
        .map(|(name, _)| name)
}

impl OnDuty<'_> {
    /// Runs beside a task's drive and never ends: each time the robot has
    /// got no further than [`ASK_RADIUS_MM`] in [`ASK_AFTER`] without
    /// waiting its turn, it asks the nearest idle robot standing ahead of
    /// it on `route` to make way, and sets `asked`.
    pub(super) async fn ask_way(
        &self,
        cfg: &DutyConfig,
        (waiting, asked): (&AtomicBool, &AtomicBool),
        route: &Route,
    ) -> Infallible {
        let mut anchor: Option<(Point, rome_clock::Instant)> = None;
        loop {
            rome_clock::sleep(cfg.check_every).await;
            let Ok(p) = self.robot.pose().await else {
                continue;
            };
            let here = Point::new(f64::from(p.x_mm), f64::from(p.y_mm));
            match anchor {
                Some((a, since)) if !waiting.load(Relaxed) && distance(a, here) < ASK_RADIUS_MM => {
                    if since.elapsed() >= ASK_AFTER {
                        anchor = None;
                        match self.ask(here, route).await {
                            Ok(true) => asked.store(true, Relaxed),
                            Ok(false) => {}
                            Err(e) => {
                                tracing::warn!(robot = self.name, "could not ask to make way: {e}")
                            }
                        }
                    }
                }
                _ => anchor = Some((here, rome_clock::Instant::now())),
            }
        }
    }

    /// Asks the nearest idle robot standing within [`ASK_NEAR_MM`] of
    /// `here`, and not behind it on `route`, to make way: whether it asked
    /// one.
    async fn ask(&self, here: Point, route: &Route) -> Result<bool, NavError> {
        let Some(heading_deg) = way_heading(route, here) else {
            return Ok(false);
        };
        let others = self.others().await?;
        let Some(name) = in_the_way((self.name, here, heading_deg), &others) else {
            return Ok(false);
        };
        let of = vec![name.to_string()];
        // Each ask's count is the time it is made: later is larger, in
        // this task or the next, and the same in every lock-step run.
        let n = rome_clock::now_ms().unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_millis() as u64)
        });
        let goal = route.points.last().copied().unwrap_or(here);
        let ask = WayAsk {
            at_mm: [here.x, here.y],
            heading_deg,
            to_mm: [goal.x, goal.y],
            of,
            n,
        };
        let ds = self.board.client();
        ds.set(&way_var(self.name), &Some(&ask)).await?;
        for robot in &ask.of {
            ds.signal(&task_sem(robot)).await?;
        }
        tracing::info!(robot = self.name, asked = ?ask.of, "held up: asks to make way");
        Ok(true)
    }

    /// The first ask naming this robot that it has not `answered` yet, and
    /// who made it. A value that does not decode is passed over: it asks
    /// nothing.
    pub(super) async fn asked(
        &self,
        answered: &mut BTreeMap<String, u64>,
    ) -> Option<(String, WayAsk)> {
        let values = self
            .board
            .client()
            .values_matching("nav/*/Way")
            .await
            .ok()?;
        let mut first = None;
        for (name, value) in values {
            let Some(by) = name
                .strip_prefix("nav/")
                .and_then(|r| r.strip_suffix("/Way"))
            else {
                continue;
            };
            if by == self.name || value.is_null() {
                continue;
            }
            let Ok(ask) = decode::<WayAsk>(&name, &value) else {
                continue;
            };
            let fresh = answered.get(by).is_none_or(|&n| n < ask.n);
            let sound = (ask.at_mm.iter().chain(&ask.to_mm)).all(|v| v.is_finite())
                && ask.heading_deg.is_finite();
            if !fresh || !sound || !ask.of.iter().any(|r| r == self.name) {
                continue;
            }
            answered.insert(by.to_string(), ask.n);
            first.get_or_insert((by.to_string(), ask));
        }
        first
    }

    /// Drives from where the robot stands (`from`, stood aside at `aside`;
    /// `here`, the point of either, `None` where the map names neither)
    /// to the position [`way_to`] gives for `ask`, as a drive of its own
    /// that nobody cancels: the position it arrived at, or why not.
    pub(super) async fn make_way(
        &self,
        cfg: &DutyConfig,
        (by, ask): (&str, &WayAsk),
        (from, aside, here): (&(String, Option<Point>), Option<Aside>, Option<Point>),
        state: (&mut bool, &mut Option<f64>, &mut Option<LastLeg>),
        note: &mut impl FnMut(DutyNote<'_>),
    ) -> Result<String, String> {
        let here = here.ok_or_else(|| format!("it stands nowhere the map names ({})", from.0))?;
        let waiting = self.waiting().await.map_err(|e| e.to_string())?;
        let asker = Point::new(ask.at_mm[0], ask.at_mm[1]);
        let goal = Point::new(ask.to_mm[0], ask.to_mm[1]);
        let toward = (asker, ask.heading_deg, goal);
        let Some(to) = way_to(
            self.world,
            self.network,
            here,
            toward,
            (&waiting, &MAKING_WAY),
        ) else {
            return Err(format!(
                "no position {:.0} m or more on the way {by} goes",
                WAY_ON_MM / 1000.0
            ));
        };
        (self.drive_on(cfg, (making_way_for(by), to), (from, aside), state, note)).await
    }

    /// Drives from `from` (stood aside at `aside`) to the position `to`
    /// under the name `task`, as a drive of its own that nobody cancels
    /// and that asks nobody to make way: the position it arrived at, or
    /// why not. Only the Planner's notes are passed on.
    async fn drive_on(
        &self,
        cfg: &DutyConfig,
        (task, to): (String, String),
        (from, aside): (&(String, Option<Point>), Option<Aside>),
        state: (&mut bool, &mut Option<f64>, &mut Option<LastLeg>),
        note: &mut impl FnMut(DutyNote<'_>),
    ) -> Result<String, String> {
        let a = Assignment {
            task,
            to,
            via: Vec::new(),
        };
        let mut planner_only = |n: DutyNote<'_>| {
            if let DutyNote::Planner(_) = n {
                note(n)
            }
        };
        let (outcome, at) = self
            .carry_out(cfg, (from, aside), &a, false, state, &mut planner_only)
            .await;
        at.ok_or_else(|| outcome.why.unwrap_or_else(|| "no reason given".to_string()))
    }
}

/// How far from every robot waiting a robot that drives on to stand apart
/// stops, mm: one passing between two waiting by opposite walls needs
/// room to cross the corridor between them.
pub const APART_MM: f64 = 5_000.0;

/// The longest drive to stand apart, mm.
pub const APART_ROUTE_MM: f64 = 10_000.0;

impl OnDuty<'_> {
    /// Where a robot between tasks that stands at `here`, within
    /// [`WAY_APART_MM`] of another robot waiting, and about to step aside
    /// along `direction_deg`, drives on to: the nearest position
    /// at least [`WAY_ON_MM`] on that way, and as far as [`APART`] says
    /// from every robot waiting ([`way_to`]). `None`: no robot waits near it, or no such
    /// position is within reach; it stays and tries its step again.
    pub(super) async fn apart_to(
        &self,
        here: Point,
        direction_deg: f64,
    ) -> Result<Option<String>, NavError> {
        let waiting = self.waiting().await?;
        if !waiting.iter().any(|w| distance(*w, here) < WAY_APART_MM) {
            return Ok(None);
        }
        let ahead = (here, direction_deg, here);
        Ok(way_to(
            self.world,
            self.network,
            here,
            ahead,
            (&waiting, &APART),
        ))
    }

    /// Drives from `from` to `to` ([`Self::apart_to`]) to stand apart:
    /// the position it arrived at, or why not.
    pub(super) async fn stand_apart(
        &self,
        cfg: &DutyConfig,
        (from, to): (&(String, Option<Point>), String),
        state: (&mut bool, &mut Option<f64>, &mut Option<LastLeg>),
        note: &mut impl FnMut(DutyNote<'_>),
    ) -> Result<String, String> {
        let task = (STAND_APART_TASK.to_string(), to);
        self.drive_on(cfg, task, (from, None), state, note).await
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::plan::tests::eb3;

    #[test]
    fn a_robot_makes_way_ahead_on_the_askers_way_never_to_its_goal_or_back_past_it() {
        let (world, network) = eb3();
        let at = |name: &str| world.position(name).expect("named").in_corridor();
        // r1 stands at A336L in corridor N; the asker is held up 1.5 m
        // north of it, going south (180°) to A342R.
        let here = at("A336L");
        let asker = here + direction(0.0) * 1_500.0;
        let goal = at("A342R");
        let way = |asker: Point, heading: f64, waiting: &[Point]| {
            let waiting = (waiting, &MAKING_WAY);
            way_to(&world, &network, here, (asker, heading, goal), waiting)
        };
        let to = way(asker, 180.0, &[]).expect("a position");
        let q = at(&to);
        assert!(
            (q - here).dot(&direction(180.0)) >= WAY_ON_MM,
            "{to} is not 3 m on south"
        );
        assert!(
            distance(q, goal) >= WAY_APART_MM,
            "{to} is the asker's goal"
        );
        // Going north instead, it makes way north, never back past the
        // asker south of it.
        let asker = here + direction(180.0) * 1_500.0;
        let to = way(asker, 0.0, &[]).expect("a position");
        assert!((at(&to) - here).dot(&direction(0.0)) >= WAY_ON_MM, "{to}");
        // With a robot standing at that place, it goes elsewhere.
        let other = way(asker, 0.0, &[at(&to)]);
        assert_ne!(other.as_deref(), Some(to.as_str()));
    }

    #[test]
    fn a_robot_standing_apart_drives_to_a_door_well_clear_of_every_robot_waiting() {
        let (world, network) = eb3();
        let at = |name: &str| world.position(name).expect("named").in_corridor();
        // r1 ended at A336R going south, beside r2 waiting at A336L; r3
        // waits 4 m further south.
        let here = at("A336R");
        let waiting = [at("A336L"), here + direction(180.0) * 4_000.0];
        let ahead = (here, 180.0, here);
        let to = way_to(&world, &network, here, ahead, (&waiting, &APART)).expect("a position");
        let p = world.position(&to).expect("named");
        assert!(p.door, "{to} is a ring's node, not a door");
        let q = p.in_corridor();
        assert!((q - here).dot(&direction(180.0)) >= WAY_ON_MM, "{to}");
        for w in waiting {
            assert!(distance(q, w) >= APART_MM, "{to} is near one waiting");
        }
        let route = world.route_from(&network, ("here", here), &[], &to);
        let length = route.expect("a route").length_mm;
        assert!(length <= APART_ROUTE_MM, "{to} is {length:.0} mm away");
        // Kept only a body and more from robots waiting, the place beside
        // the robot further south would do.
        let body = Reach {
            apart_mm: WAY_APART_MM,
            ..APART
        };
        let near = way_to(&world, &network, here, ahead, (&waiting, &body));
        let near = near.expect("a position");
        assert!(distance(at(&near), waiting[1]) < APART_MM, "{near}");
        // With robots waiting every 2 m for 14 m on, no door within its
        // reach will do: it stays.
        let row: Vec<_> = (0..8)
            .map(|k| here + direction(180.0) * (2_000.0 * f64::from(k)))
            .collect();
        assert_eq!(way_to(&world, &network, here, ahead, (&row, &APART)), None);
    }

    #[test]
    fn only_the_nearest_idle_robot_ahead_or_beside_is_asked() {
        let duty = |state, task: Option<&str>| Duty {
            at: "@0,0".into(),
            at_mm: None,
            state,
            task: task.map(str::to_string),
            owner: "o".into(),
            last: None,
        };
        let idle = || duty(DutyState::Idle, None);
        let here = Point::new(0.0, 0.0);
        // Going east (270°; north is 0°, west 90°): r3 1 m behind, r4 busy making way 0.5 m ahead,
        // r5 idle 1.5 m ahead, r6 idle 2 m ahead, r7 3 m ahead (too far).
        let mut others = vec![
            ("r3".to_string(), idle(), Point::new(-1_000.0, 0.0)),
            (
                "r4".to_string(),
                duty(DutyState::Busy, Some("make way for r9")),
                Point::new(500.0, 0.0),
            ),
            ("r6".to_string(), idle(), Point::new(2_000.0, 0.0)),
            ("r5".to_string(), idle(), Point::new(1_500.0, 0.0)),
            ("r7".to_string(), idle(), Point::new(3_000.0, 0.0)),
        ];
        assert_eq!(in_the_way(("r1", here, 270.0), &others), Some("r5"));
        // One beside it, 0.4 m behind, is nearer still.
        others.push(("r8".to_string(), idle(), Point::new(-400.0, 800.0)));
        assert_eq!(in_the_way(("r1", here, 270.0), &others), Some("r8"));
        // Going west, r3 is ahead and nearest after r8.
        assert_eq!(in_the_way(("r1", here, 90.0), &others), Some("r8"));
        others.pop();
        assert_eq!(in_the_way(("r1", here, 90.0), &others), Some("r3"));
        // While one makes way for r1, r1 asks nobody else; r10 may ask
        // (r4 makes way for r9).
        others.push((
            "r2".to_string(),
            duty(DutyState::Busy, Some(&making_way_for("r1"))),
            Point::new(20_000.0, 0.0),
        ));
        assert_eq!(in_the_way(("r1", here, 90.0), &others), None);
        assert_eq!(in_the_way(("r10", here, 90.0), &others), Some("r3"));
        assert_eq!(in_the_way(("r9", here, 90.0), &others), None);
        // Only the busy one near ahead: nobody is asked.
        others.retain(|(name, _, _)| name == "r4" || name == "r7");
        assert_eq!(in_the_way(("r1", here, 270.0), &others), None);
    }

    #[test]
    fn the_way_an_asker_goes_is_its_nearest_legs_whatever_it_faces() {
        let (world, network) = eb3();
        let from = world.position("A326L").expect("named").in_corridor();
        let route = world
            .route_from(&network, ("here", from), &[], "A342R")
            .expect("a route");
        let h = way_heading(&route, from + direction(180.0) * 2_000.0).expect("a heading");
        assert!(
            rome_maps::geometry::normalize_deg(h - 180.0).abs() < 5.0,
            "{h}"
        );
    }
}
