//! How a run is judged and reported, as in Chapter 6: a row of Tables
//! 6.1–6.2 per robot, with each mode judged by what happened rather than by
//! the Planner having moved on.
//!
//! - an L segment fails when the robot lost the lights: more than a third
//!   of them missed, or the segment ended on distance alone (the CTracker's
//!   `TrackLog`);
//! - a C segment fails when the robot did not end up heading into the
//!   intended corridor (ground truth at its end);
//! - a D segment fails when the robot stopped more than a metre from its
//!   goal (ground truth);
//! - a contact with a wall or another robot, or a bumper press, marks the
//!   run.
//!
//! Failures are starred in the row and each gets a reason underneath, as in
//! the thesis' tables. Ground truth comes from the simulator's truth key;
//! on a real robot, without it, C and D segments cannot be judged and say
//! so.

use crate::board::{GoalType, HeadingFix, PlateReport};
use crate::ctracker::SegmentLog;
use crate::navigator::NavLog;
use crate::plan::{ModeCount, Plan, Step};
use rome_maps::geometry::{direction, distance, Heading, Point, Pose};
use rome_maps::render::{self, Rgb, Shape};
use rome_maps::{Map, World};
use rome_schema::sim::{ContactCount, Truth};
use std::time::Duration;

/// One goal as handed over, with what it turned into.
#[derive(Debug, Clone, PartialEq)]
pub struct Handed {
    /// Index in the plan.
    pub index: usize,
    /// The step, with the distance actually sent.
    pub step: Step,
    /// The Overshoot read after an L segment, mm.
    pub overshoot_mm: Option<i64>,
    /// What the CTracker saw, for an L segment.
    pub track: Option<SegmentLog>,
    /// Where the robot truly was when the goal was done, if a simulator
    /// says.
    pub truth: Option<Truth>,
    /// Why the goal failed, judged from what happened.
    pub failure: Option<String>,
}

impl Handed {
    /// Goal `index`, `step`, just handed over: nothing seen or judged yet.
    pub fn new(index: usize, step: &Step) -> Handed {
        Handed {
            index,
            step: step.clone(),
            overshoot_mm: None,
            track: None,
            truth: None,
            failure: None,
        }
    }
}

/// How near the goal a run must end to have arrived, and how near its goal
/// a D segment must stop, cm.
pub const ARRIVED_CM: f64 = 100.0;
/// How far the true heading may be off the outgoing corridor's after a
/// Leave-Corner segment, degrees.
pub const CORNER_HEADING_DEG: f64 = 20.0;
/// How far the robot may be from the outgoing corridor's centre line after
/// a Leave-Corner segment, mm.
pub const CORNER_LATERAL_MM: f64 = 1_000.0;
/// How far from the corridor point outside the destination floor's door a
/// ride may end, by ground truth, mm.
pub const RIDE_ARRIVED_MM: f64 = 500.0;

/// A duration as the tables print run times, `m:ss`.
pub fn mmss(d: Duration) -> String {
    let s = d.as_secs();
    format!("{}:{:02}", s / 60, s % 60)
}

/// Why a step failed, judged from what happened; `None` when it did not
/// (or cannot be judged: no ground truth for a C or D step).
pub fn judge_step(
    step: &Step,
    truth: Option<&Truth>,
    track: Option<&SegmentLog>,
) -> Option<String> {
    match step.goal.goal_type {
        GoalType::L => match track {
            Some(log) => log.failure(),
            None => Some("the light tracker reported nothing for the segment".into()),
        },
        GoalType::D => {
            let t = truth?;
            let miss = distance(Pose::from(t).at, step.to);
            (miss > ARRIVED_CM * 10.0)
                .then(|| format!("stopped {:.2} m from its goal", miss / 1_000.0))
        }
        GoalType::C => {
            let t = truth?;
            let heading = step.goal.direction_deg;
            let off = Pose::from(t).heading.minus(Heading::from_deg(heading));
            let d = direction(heading);
            let off_start = Pose::from(t).at - step.from;
            let along = off_start.dot(&d);
            let lateral = off_start.perp(&d).abs();
            if off.abs() > CORNER_HEADING_DEG {
                Some(format!(
                    "heading {off:+.0}° off the corridor it should enter"
                ))
            } else if lateral > CORNER_LATERAL_MM || along < 0.0 {
                Some(format!(
                    "not in the corridor it should enter: {:.2} m off its centre line, {:.2} m along it",
                    lateral / 1_000.0,
                    along / 1_000.0
                ))
            } else {
                None
            }
        }
        GoalType::E => None,
        GoalType::V => {
            // Judged on the floor it should end on: the floor first.
            let t = truth?;
            let to = step.ride.as_ref().map(|r| r.to.as_str());
            if t.floor.is_some() && t.floor.as_deref() != to {
                return Some(format!(
                    "ended on floor {}, not {}",
                    t.floor.as_deref().unwrap_or("?"),
                    to.unwrap_or("?")
                ));
            }
            let miss = distance(Pose::from(t).at, step.to);
            (miss > RIDE_ARRIVED_MM).then(|| {
                format!(
                    "left the elevator {:.2} m from the corridor point outside its door",
                    miss / 1_000.0
                )
            })
        }
    }
}

/// The outcome of one robot's run: a row of Table 6.1 and more.
#[derive(Debug, Clone)]
pub struct Report {
    /// The robot.
    pub robot: String,
    /// Start.
    pub from: String,
    /// Goal.
    pub to: String,
    /// The plan.
    pub plan: Plan,
    /// Every goal handed over, with its verdict.
    pub steps: Vec<Handed>,
    /// Distance truly driven, m (the thesis' "Actual Dist.").
    pub driven_m: f64,
    /// Signed distance to the goal along the last leg, cm: positive past
    /// it, negative short of it (ground truth).
    pub to_goal_cm: f64,
    /// Distance from the goal across the last leg, cm.
    pub off_line_cm: f64,
    /// Straight-line distance from the goal, cm.
    pub miss_cm: f64,
    /// How far odometry was from the truth at the end, cm.
    pub odometry_error_cm: Option<f64>,
    /// The largest odometry error seen during the run, cm.
    pub odometry_max_error_cm: Option<f64>,
    /// Simulated run time.
    pub run_time: Duration,
    /// Wall-clock time it took.
    pub wall_time: Duration,
    /// Modes the plan needs.
    pub modes_needed: ModeCount,
    /// Modes carried out and judged successful.
    pub modes_done: ModeCount,
    /// Touches of walls and other robots during the run.
    pub contacts: ContactCount,
    /// The true trajectory (when the run was watched throughout).
    pub trail: Vec<Point>,
    /// What the Navigator did (in-process runs).
    pub nav: NavLog,
    /// Door plates reported.
    pub plates: Vec<PlateReport>,
    /// Where people walked to and fro in the run's world, one leg each
    /// (drawn dashed on the pictures).
    pub people: Vec<(Point, Point)>,
    /// Heading and sideways corrections made.
    pub fixes: Vec<HeadingFix>,
    /// Why the run was given up, when it was (the robot did not arrive).
    pub failure: Option<String>,
}

/// What a finished run is made of, to build its [`Report`].
#[derive(Debug, Clone)]
pub struct Ended {
    /// The robot.
    pub robot: String,
    /// Start.
    pub from: String,
    /// Goal.
    pub to: String,
    /// The plan.
    pub plan: Plan,
    /// The goals handed over and judged, in order.
    pub steps: Vec<Handed>,
    /// Ground truth when the run started and when it ended.
    pub truth: (Truth, Truth),
    /// Odometry at the end: x, y mm.
    pub odometry: Option<Point>,
    /// Largest odometry error seen during the run, mm.
    pub odometry_max_error_mm: Option<f64>,
    /// Wall-clock time.
    pub wall_time: Duration,
    /// Why the run was given up.
    pub failure: Option<String>,
}

impl Report {
    /// Judges a finished run.
    pub fn new(e: Ended) -> Report {
        let (start, end) = &e.truth;
        let (_, goal) = e.plan.ends();
        let last_heading = e
            .plan
            .route
            .legs()
            .last()
            .map_or(e.plan.start_heading_deg, |l| l.3);
        let d = direction(last_heading);
        let end_at = Pose::from(end).at;
        let off = end_at - goal;
        let mut done = ModeCount::default();
        for h in &e.steps {
            if h.failure.is_some() {
                continue;
            }
            match h.step.goal.goal_type {
                GoalType::L => done.l += 1,
                GoalType::C => done.c += 1,
                GoalType::D => done.d += 1,
                GoalType::V => done.v += 1,
                GoalType::E => {}
            }
        }
        Report {
            robot: e.robot,
            from: e.from,
            to: e.to,
            modes_needed: e.plan.modes(),
            modes_done: done,
            driven_m: (end.travelled_mm - start.travelled_mm) / 1_000.0,
            to_goal_cm: off.dot(&d) / 10.0,
            off_line_cm: off.perp(&d).abs() / 10.0,
            miss_cm: distance(end_at, goal) / 10.0,
            odometry_error_cm: e.odometry.map(|o| distance(o, end_at) / 10.0),
            odometry_max_error_cm: e.odometry_max_error_mm.map(|m| m / 10.0),
            run_time: Duration::from_millis(end.time_ms.saturating_sub(start.time_ms)),
            wall_time: e.wall_time,
            contacts: start.contacts.since(&end.contacts),
            plan: e.plan,
            steps: e.steps,
            trail: Vec::new(),
            nav: NavLog::default(),
            plates: Vec::new(),
            people: Vec::new(),
            fixes: Vec::new(),
            failure: e.failure,
        }
    }

    /// Whether the run reached the goal: not given up, and within a metre
    /// by ground truth.
    pub fn arrived(&self) -> bool {
        self.failure.is_none() && self.miss_cm < ARRIVED_CM
    }

    /// Whether every mode the plan needs was carried out successfully,
    /// without a contact, and the robot arrived.
    pub fn clean(&self) -> bool {
        self.arrived() && self.modes_done == self.modes_needed && self.contacts.total() == 0
    }

    /// What the CTracker did, per L segment.
    pub fn lights(&self) -> impl Iterator<Item = &SegmentLog> {
        self.steps.iter().filter_map(|h| h.track.as_ref())
    }

    /// The header of the table.
    pub fn header() -> String {
        format!(
            "{:<4}{:<6}{:<22}{:>11}{:>14}{:>10}{:>8}{:>8}{:>8}  {}",
            "No.",
            "Robot",
            "Path",
            "Actual (m)",
            "To goal (cm)",
            "Run time",
            "L",
            "C",
            "D",
            "Contacts"
        )
    }

    /// A mode column of Table 6.1 for `column` (L, C or D; an Enter-Corner
    /// segment counts with C, whose corners it begins): how many were
    /// carried out successfully, how many the plan needs, and whether it is
    /// starred (a segment of it failed, or not all were carried out).
    pub fn mode(&self, column: GoalType) -> (usize, usize, bool) {
        let of = |t: GoalType| match t {
            GoalType::E => GoalType::C,
            t => t,
        };
        let (done, need) = match of(column) {
            GoalType::L => (self.modes_done.l, self.modes_needed.l),
            GoalType::D => (self.modes_done.d, self.modes_needed.d),
            _ => (self.modes_done.c, self.modes_needed.c),
        };
        let failed = self
            .steps
            .iter()
            .any(|h| of(h.step.goal.goal_type) == of(column) && h.failure.is_some());
        (done, need, failed || done < need)
    }

    /// The run as row `no` of the table, in the layout of Table 6.1: a mode
    /// column with a failed segment is starred.
    pub fn row(&self, no: usize) -> String {
        let frac = |t: GoalType| {
            let (done, need, starred) = self.mode(t);
            format!("{done}/{need}{}", if starred { "*" } else { "" })
        };
        let c = self.contacts;
        let contacts = if c.total() == 0 && c.bumper == 0 {
            "0".to_string()
        } else {
            format!(
                "{}* ({} wall, {} robot)",
                c.total().max(c.bumper),
                c.wall,
                c.robot
            )
        };
        format!(
            "{:<4}{:<6}{:<22}{:>11.3}{:>+14.0}{:>10}{:>8}{:>8}{:>8}  {}",
            no,
            self.robot,
            format!("{} to {}", self.from, self.to),
            self.driven_m,
            self.to_goal_cm,
            mmss(self.run_time),
            frac(GoalType::L),
            frac(GoalType::C),
            frac(GoalType::D),
            contacts
        )
    }

    /// The header and this run as row 1.
    pub fn table(&self) -> String {
        format!("{}\n{}", Report::header(), self.row(1))
    }

    /// Why each starred entry is starred, one line each (empty when
    /// nothing failed).
    pub fn reasons(&self) -> Vec<String> {
        let mut out: Vec<String> = self
            .steps
            .iter()
            .filter_map(|h| {
                let why = h.failure.as_ref()?;
                let column = match h.step.goal.goal_type {
                    GoalType::E | GoalType::C => "C",
                    GoalType::L => "L",
                    GoalType::D => "D",
                    GoalType::V => "V",
                };
                Some(format!(
                    "* {}: {column} (goal {}, subpath {}): {why}",
                    self.robot,
                    h.index + 1,
                    h.step.subpath
                ))
            })
            .collect();
        let handed = self.steps.len();
        if handed < self.plan.steps.len() {
            out.push(format!(
                "* {}: goals {}–{} never carried out",
                self.robot,
                handed + 1,
                self.plan.steps.len()
            ));
        }
        let c = self.contacts;
        if c.total() > 0 || c.bumper > 0 {
            out.push(format!(
                "* {}: contacts: {} with walls, {} with robots, {} bumper press(es)",
                self.robot, c.wall, c.robot, c.bumper
            ));
        }
        if let Some(why) = &self.failure {
            out.push(format!("* {}: given up: {why}", self.robot));
        }
        out
    }

    /// The trajectory on the map, as PNG bytes.
    pub fn picture(&self, map: &Map, world: &World, width_px: u32) -> Vec<u8> {
        fleet_picture(std::slice::from_ref(self), map, world, width_px)
    }
}

/// One colour per robot, the first the single-robot trajectory's.
pub fn robot_color(i: usize) -> Rgb {
    const PALETTE: [Rgb; 8] = [
        render::TRACK,
        [230, 120, 0],
        [150, 40, 190],
        [0, 150, 140],
        [200, 20, 110],
        [110, 110, 0],
        [90, 60, 30],
        [60, 60, 60],
    ];
    PALETTE[i % PALETTE.len()]
}

/// Every run's route and true trajectory on one map, each robot in its own
/// colour and named at its end, as PNG bytes.
pub fn fleet_picture(reports: &[Report], map: &Map, world: &World, width_px: u32) -> Vec<u8> {
    let mut overlay = Vec::new();
    // Robots of one world share its people: each leg drawn once, under
    // everything else.
    let mut legs: Vec<(Point, Point)> = Vec::new();
    for leg in reports.iter().flat_map(|r| &r.people) {
        if !legs.contains(leg) {
            legs.push(*leg);
            overlay.push(Shape::Line {
                a: leg.0,
                b: leg.1,
                color: render::PEOPLE,
                width: 2.0,
                dashed: true,
            });
        }
    }
    for r in reports {
        overlay.extend(render::route_shapes(&r.plan.route));
    }
    for (i, r) in reports.iter().enumerate() {
        let color = robot_color(i);
        for w in r.trail.windows(2) {
            overlay.push(Shape::Line {
                a: w[0],
                b: w[1],
                color,
                width: 2.0,
                dashed: false,
            });
        }
        if let Some(end) = r.trail.last() {
            overlay.push(Shape::Dot {
                at: *end,
                radius: 4.0,
                color,
            });
            if reports.len() > 1 {
                overlay.push(Shape::Text {
                    at: *end,
                    text: r.robot.to_uppercase(),
                    color,
                    size: 2,
                });
            }
        }
        for p in &r.plates {
            overlay.push(Shape::Dot {
                at: p.at(),
                radius: 3.0,
                color: render::FOUND,
            });
        }
    }
    let img = render::raster(map, world, width_px, &overlay);
    let mut out = std::io::Cursor::new(Vec::new());
    // Encoding an in-memory RGB image cannot fail.
    let _ = img.write_to(&mut out, image::ImageFormat::Png);
    out.into_inner()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::board::Goal;
    use rome_maps::geometry::pt;

    fn step(goal_type: GoalType, from: Point, to: Point, heading: f64) -> Step {
        Step {
            goal: Goal {
                goal_type,
                distance: distance(from, to).round() as i64,
                direction_deg: heading,
            },
            subpath: 1,
            light_offsets_mm: Vec::new(),
            from,
            to,
            walls_mm: None,
            end_wall_mm: None,
            goal_walls_mm: None,
            ride: None,
        }
    }

    fn truth(x: f64, y: f64, heading: f64) -> Truth {
        Truth {
            robot: "r1".into(),
            time_ms: 0,
            x_mm: x,
            y_mm: y,
            heading_deg: heading,
            travelled_mm: 0.0,
            contacts: ContactCount::default(),
            floor: None,
        }
    }

    #[test]
    fn a_ride_is_judged_by_the_floor_and_then_by_where_it_left_the_car() {
        let mut s = step(GoalType::V, pt(0.0, 0.0), pt(5_000.0, 0.0), 90.0);
        s.ride = Some(crate::board::RideInfo {
            elevator: "acs.elev".into(),
            marker: "010".into(),
            from: "3".into(),
            to: "5".into(),
            door_mm: 1_830,
            exit_mm: 1_830,
            wait_s: 60.0,
        });
        let on = |floor: &str, x: f64| Truth {
            floor: Some(floor.into()),
            ..truth(x, 0.0, 0.0)
        };
        assert_eq!(
            judge_step(&s, Some(&on("4", 5_000.0)), None),
            Some("ended on floor 4, not 5".into())
        );
        assert_eq!(judge_step(&s, Some(&on("5", 5_100.0)), None), None);
        let far = judge_step(&s, Some(&on("5", 5_600.0)), None).unwrap_or_default();
        assert!(far.contains("0.60 m from the corridor point"), "{far}");
    }

    #[test]
    fn a_d_segment_fails_beyond_a_metre_from_its_goal() {
        let s = step(GoalType::D, pt(0.0, 0.0), pt(0.0, 10_000.0), 0.0);
        assert_eq!(
            judge_step(&s, Some(&truth(300.0, 9_400.0, 0.0)), None),
            None
        );
        let why = judge_step(&s, Some(&truth(0.0, 8_700.0, 0.0)), None).expect("fails");
        assert!(why.contains("1.30 m from its goal"), "{why}");
        // Without ground truth a D segment cannot be judged.
        assert_eq!(judge_step(&s, None, None), None);
    }

    #[test]
    fn a_c_segment_fails_unless_the_robot_heads_into_the_corridor() {
        // Leaving a corner westwards (heading 90) from (0, 0).
        let s = step(GoalType::C, pt(0.0, 0.0), pt(-1_800.0, 0.0), 90.0);
        assert_eq!(
            judge_step(&s, Some(&truth(-1_700.0, 200.0, 95.0)), None),
            None
        );
        let why = judge_step(&s, Some(&truth(-1_700.0, 0.0, 140.0)), None).expect("heading");
        assert!(why.contains("+50°"), "{why}");
        // Into the corridor to the north instead.
        let why = judge_step(&s, Some(&truth(-200.0, 1_800.0, 80.0)), None).expect("place");
        assert!(why.contains("1.80 m off its centre line"), "{why}");
    }

    #[test]
    fn an_l_segment_fails_when_the_lights_were_lost() {
        let s = step(GoalType::L, pt(0.0, 0.0), pt(0.0, 10_000.0), 0.0);
        let log = |seen, missed, last_missed| SegmentLog {
            lights: 6,
            seen,
            missed,
            refused: 0,
            overshoot_mm: 0.0,
            last_missed,
            first_missed: false,
            found_late: 0,
        };
        assert_eq!(judge_step(&s, None, Some(&log(6, 0, false))), None);
        assert_eq!(judge_step(&s, None, Some(&log(4, 2, false))), None);
        let why = judge_step(&s, None, Some(&log(3, 3, false))).expect("lost");
        assert!(why.contains("3 of 6 missed"), "{why}");
        let why = judge_step(&s, None, Some(&log(5, 1, true))).expect("distance");
        assert!(why.contains("distance alone"), "{why}");
        assert!(judge_step(&s, None, None).is_some());
    }
}
