//! The blackboard of Table 5.4: every variable and semaphore the navigation
//! clients share, and nothing else passes between them (§5.8).
//!
//! Each robot has its own copy under `nav/<robot>/`, so several robots share
//! one data server without mixing their goals: the thesis' `GoalType` of
//! robot `r1` is the variable `nav/r1/GoalType`, its `$GoalData` the
//! semaphore `nav/r1/GoalData`.
//!
//! ```text
//!                Planner  Navigator  CTracker  HIMM  PlFinder
//! $StartMap         U                           D
//! $LightDet                             U       D
//! $GoalData         U        D
//! $RobotStatus      D        U
//! $TrackData        U                   D
//! $EndLMode         D                   U
//! GoalDirection     W        R                  R       R
//! GoalDistance      W        R          R       R
//! GoalType          W        R
//! LightOffset       W                   R
//! CeilingLight               R          W       R
//! Overshoot         R                   W
//! ```
//!
//! Beyond the table, the clients publish what a person watching wants to
//! see: `Status` (the Navigator's mode and state), `Plate` (each door plate
//! the PlFinder reports) and `HeadingFix` (each HIMM correction), and the
//! ceiling-light children's `$LightToken` (§5.6). The CTracker writes
//! `CountedAt` (where the robot was when it took `Overshoot`) before the
//! count that ends a segment, so the Navigator measures the next D goal
//! from there, and
//! `TrackLog` (lights seen and missed in the segment) before up($EndLMode),
//! so the Planner judges each L segment by what happened; the Planner
//! writes `Corridor` (where the segment's line of lights lies in the map,
//! and its walls) for the local mapper's sideways correction.
//! A CTracker that cannot read a segment's values writes `CeilingLight` as
//! `{"failed":"why"}` ([`GaveUp`]) instead of a count: the Navigator stops
//! the robot and ends the goal with that reason.
//! The Navigator keeps `GoalActive` (the goal it is carrying out and where
//! it measures it from, `null` between goals), so a Navigator started again
//! after one died takes the goal up while the Planner still waits for it.

use rome_client::{ClientError, DataClient};
use rome_maps::geometry::{Point, Pose};
use serde::{Deserialize, Serialize};

/// `CeilingLight` when the CTracker gave the light segment up:
///
/// ```text
/// {"failed":"the segment's light offsets (LightOffset) could not be read: …"}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaveUp {
    /// Why.
    pub failed: String,
}

/// The semaphores of Table 5.4 (and the trackers' token).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sem {
    /// Planner → HIMM: light tracking has begun.
    StartMap,
    /// CTracker → HIMM: a light was counted.
    LightDet,
    /// Planner → Navigator: a goal is ready.
    GoalData,
    /// Navigator → Planner: the goal is done.
    RobotStatus,
    /// Planner → CTracker: track the lights of a segment.
    TrackData,
    /// CTracker → Planner: the segment's last light is behind.
    EndLMode,
    /// Among the CTracker's children: who may count the light in view.
    LightToken,
}

impl Sem {
    /// The thesis' name, without the `$`.
    pub fn name(self) -> &'static str {
        match self {
            Sem::StartMap => "StartMap",
            Sem::LightDet => "LightDet",
            Sem::GoalData => "GoalData",
            Sem::RobotStatus => "RobotStatus",
            Sem::TrackData => "TrackData",
            Sem::EndLMode => "EndLMode",
            Sem::LightToken => "LightToken",
        }
    }

    /// Its value when first created: the token is free, the rest empty.
    fn initial(self) -> u64 {
        u64::from(self == Sem::LightToken)
    }

    /// Every semaphore.
    pub const ALL: [Sem; 7] = [
        Sem::StartMap,
        Sem::LightDet,
        Sem::GoalData,
        Sem::RobotStatus,
        Sem::TrackData,
        Sem::EndLMode,
        Sem::LightToken,
    ];
}

/// The variables of Table 5.4 and the ones a person watches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Var {
    /// Heading of the segment, degrees (North 0, West 90).
    GoalDirection,
    /// Lights to count (mode L) or millimetres to travel.
    GoalDistance,
    /// The segment's mode: L, D, E or C.
    GoalType,
    /// Distances between the lights of an L segment, mm: from the start to
    /// the first light, then between neighbours.
    LightOffset,
    /// Lights counted so far in the current L segment.
    CeilingLight,
    /// How far past the last light the robot was when it was counted, mm.
    Overshoot,
    /// Where the robot was (odometry) when the CTracker took `Overshoot`,
    /// `null` while a segment is counted ([`CountedAt`]).
    CountedAt,
    /// The Navigator's mode, state and pose, for people watching.
    Status,
    /// The last door plate found.
    Plate,
    /// The last heading correction.
    HeadingFix,
    /// What the CTracker saw in the last L segment.
    TrackLog,
    /// The L segment's corridor in the map: its line of lights and walls.
    Corridor,
    /// The goal the Navigator is carrying out, and where it started it,
    /// so a Navigator started again takes it up; `null` between goals.
    GoalActive,
    /// The L segment the CTracker is counting: lights so far and where
    /// the last was, so a CTracker started again takes it up
    /// ([`crate::ctracker::Tracking`]).
    Tracking,
    /// The route the Planner follows, for people watching (`rome view`).
    Route,
    /// For an E goal: how far the wall ahead stands from the middle of the
    /// turning space, mm, as the map has it (`null` when none is in reach),
    /// written by the Planner before it hands the goal over.
    EndWall,
    /// For a D goal: how far left of the corridor's middle the goal lies,
    /// mm, when well off it (`null` otherwise), written by the Planner
    /// before it hands the goal over.
    GoalLane,
    /// For a D goal: how far the corridor's left and right walls stand
    /// from the goal, mm, as the map has them (`null` when either is not
    /// in reach), written by the Planner before it hands the goal over.
    GoalWalls,
    /// For an E, C or D goal: the glass the map has within reach of it,
    /// which neither sonar nor infrared hears, as panes `[along₁, left₁,
    /// along₂, left₂]` in mm from the goal's end, along its direction and
    /// to its left (`[]` when there is none), written by the Planner
    /// before it hands the goal over.
    Glass,
    /// The junctions and narrow passages the robot holds and the one it
    /// waits for ([`crate::traffic::TrafficState`]), written by the
    /// Planner as they change, for people watching.
    Traffic,
    /// For a V goal: the elevator ride ([`RideInfo`]).
    Ride,
}

impl Var {
    /// The thesis' name.
    pub fn name(self) -> &'static str {
        match self {
            Var::GoalDirection => "GoalDirection",
            Var::GoalDistance => "GoalDistance",
            Var::GoalType => "GoalType",
            Var::LightOffset => "LightOffset",
            Var::CeilingLight => "CeilingLight",
            Var::Overshoot => "Overshoot",
            Var::CountedAt => "CountedAt",
            Var::Status => "Status",
            Var::Plate => "Plate",
            Var::HeadingFix => "HeadingFix",
            Var::TrackLog => "TrackLog",
            Var::Corridor => "Corridor",
            Var::GoalActive => "GoalActive",
            Var::Tracking => "Tracking",
            Var::Route => "Route",
            Var::EndWall => "EndWall",
            Var::GoalLane => "GoalLane",
            Var::GoalWalls => "GoalWalls",
            Var::Glass => "Glass",
            Var::Traffic => "Traffic",
            Var::Ride => "Ride",
        }
    }
}

/// A segment's mode (§5.3, Table 5.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum GoalType {
    /// S^l: Center-Hallway + L-Goal, counting ceiling lights.
    L,
    /// S^d: Center-Hallway + D-Goal, dead reckoning to the goal.
    D,
    /// S^d ending in a turning space: Corner + E-Goal.
    E,
    /// S^c: leaving the corner, Corner + D-Goal.
    C,
    /// An elevator ride (§5.4.6): locate the door by its marker, wait for
    /// the car, enter, turn round, ride and leave; what the ride needs is
    /// in `Ride` ([`RideInfo`]).
    V,
}

/// `Ride`: what the Navigator needs for an elevator ride, written by the
/// Planner before it hands the V goal over. Directions are the goal's: the
/// goal's `direction_deg` is the heading from the corridor into the door.
///
/// ```text
/// {"elevator":"acs.elev","marker":"010","from":"3","to":"5","door_mm":1830,"exit_mm":1830,"wait_s":120.0}
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RideInfo {
    /// The elevator (its server's name).
    pub elevator: String,
    /// The code of the marker on its door (`010`).
    pub marker: String,
    /// The floor the robot gets in at.
    pub from: String,
    /// The floor it gets out at.
    pub to: String,
    /// How far the door is from where the ride starts, mm.
    pub door_mm: i64,
    /// How far from the door the robot stops on the way out, mm: the
    /// corridor's line of lights on the floor it gets out at.
    pub exit_mm: i64,
    /// How long to wait for the car (to come, or to arrive), seconds.
    pub wait_s: f64,
}

/// `CountedAt`: where the robot was, in odometry, when the CTracker
/// counted an L segment's last light and took its `Overshoot`. The
/// Navigator measures the next D goal from here, not from where it
/// learned of the count: over a slow link that can be a metre further on,
/// and the Planner's overshoot compensation would miss by as much.
///
/// ```text
/// {"x_mm":12040.5,"y_mm":3310.0}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CountedAt {
    /// x, mm.
    pub x_mm: f64,
    /// y, mm.
    pub y_mm: f64,
}

/// One goal as the Planner hands it to the Navigator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Goal {
    /// The segment's mode.
    pub goal_type: GoalType,
    /// Lights (L) or millimetres (D, E, C).
    pub distance: i64,
    /// Heading, degrees.
    pub direction_deg: f64,
}

/// What the Navigator is doing, for `rome data get nav/r1/Status`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Status {
    /// Goals taken so far.
    pub goal: u32,
    /// The goal being worked on.
    pub goal_type: GoalType,
    /// `center-hallway` or `corner`.
    pub state: String,
    /// Odometry x, mm.
    pub x_mm: i64,
    /// Odometry y, mm.
    pub y_mm: i64,
    /// Odometry heading, degrees.
    pub heading_deg: f64,
    /// The safe threshold in use, mm.
    pub safe_mm: i64,
    /// Why the robot gets nowhere, while it does: "blocked: something 0.4 m
    /// ahead (sonar 12); no headway for 25 s".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blocked: Option<String>,
    /// Why the last goal was ended before it was reached, when a value it
    /// depends on was bad: "goal 4 ended: the ceiling-light count
    /// (CeilingLight) could not be read, so the robot was stopped: …".
    /// Cleared when the next goal is taken.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
    /// Why the last goal, a D goal with the walls beside its end given
    /// (`GoalWalls`), ended off its line: "something beside it: the side
    /// sonars read 1.4 m across where the map has 2.2 m". A robot
    /// stepping aside for others has then not done so.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub off_line: Option<String>,
}

/// A door plate the PlFinder reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlateReport {
    /// Frame it was found in.
    pub frame: u64,
    /// Where the plate is (odometry frame), mm.
    pub x_mm: i64,
    /// Where the plate is (odometry frame), mm.
    pub y_mm: i64,
    /// Its bounding box in the image: left, top, right, bottom.
    pub bbox: [u32; 4],
    /// The map's plate nearest to it and how far that is, if within 1.5 m.
    pub label: Option<String>,
    /// Distance to that plate, mm.
    pub error_mm: Option<i64>,
}

/// A heading (and sideways) correction from the local mapper.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeadingFix {
    /// After which counted light.
    pub light: i64,
    /// The hallway's orientation the Hough transform found, degrees.
    pub hallway_deg: f64,
    /// The correction applied to the odometry heading, degrees.
    pub correction_deg: f64,
    /// The correction applied across the corridor, mm (positive: to the
    /// left of the goal direction); 0 when the walls did not match the map.
    #[serde(default)]
    pub shift_mm: f64,
}

/// Where an L segment's corridor (or a long stretch without lights) lies
/// in the map, written by the Planner for the local mapper: the line of
/// lights (the route runs along it) and how far each wall is from it. The mapper compares the walls it finds
/// with these to correct the odometry's sideways drift.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Corridor {
    /// A point on the line of lights (the segment's start), mm.
    pub x_mm: f64,
    /// A point on the line of lights, mm.
    pub y_mm: f64,
    /// The line's heading, degrees (North 0, West 90).
    pub heading_deg: f64,
    /// Distance from the line to the wall on the left, mm, if the map has
    /// one there.
    pub left_mm: Option<f64>,
    /// Distance from the line to the wall on the right, mm.
    pub right_mm: Option<f64>,
    /// A long stretch without lights (an E or D goal) rather than an L
    /// segment: the mapper maps it by the distance in `GoalDistance`, mm,
    /// instead of counting lights.
    #[serde(default)]
    pub no_lights: bool,
}

/// The route of a run, as the Planner posts it for people watching.
///
/// ```text
/// {"from":"350R","to":"376L","points":[[50050.0,55500.0],[20300.0,55500.0]],"length_mm":29750.0}
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RouteInfo {
    /// Where the run starts.
    pub from: String,
    /// Where it ends.
    pub to: String,
    /// The corner points of the path, map frame, mm.
    pub points: Vec<[f64; 2]>,
    /// Its length, mm.
    pub length_mm: f64,
}

/// The goal a Navigator is carrying out (`GoalActive`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ActiveGoal {
    /// The goal as the Planner handed it.
    pub goal: Goal,
    /// Where the Navigator measures it from (odometry), x, mm.
    pub start_x_mm: f64,
    /// y, mm.
    pub start_y_mm: f64,
    /// Heading, degrees.
    pub start_heading_deg: f64,
}

// The blackboard's own messages meet points and poses here only, as the
// robots' and the simulator's do in `rome_maps::wire`.

impl Status {
    /// What the Navigator is doing at `pose` (odometry frame).
    pub fn at(goal: u32, goal_type: GoalType, state: &str, pose: &Pose, safe_mm: f64) -> Status {
        Status {
            goal,
            goal_type,
            state: state.to_string(),
            x_mm: pose.at.x.round() as i64,
            y_mm: pose.at.y.round() as i64,
            heading_deg: (pose.heading.deg() * 10.0).round() / 10.0,
            safe_mm: safe_mm.round() as i64,
            blocked: None,
            failed: None,
            off_line: None,
        }
    }
}

impl ActiveGoal {
    /// `goal`, measured from `start`.
    pub fn new(goal: Goal, start: &Pose) -> ActiveGoal {
        ActiveGoal {
            goal,
            start_x_mm: start.at.x,
            start_y_mm: start.at.y,
            start_heading_deg: start.heading.deg(),
        }
    }

    /// Where the goal is measured from.
    pub fn start(&self) -> Pose {
        Pose::new(self.start_x_mm, self.start_y_mm, self.start_heading_deg)
    }
}

impl PlateReport {
    /// Where the plate is (odometry frame).
    pub fn at(&self) -> Point {
        Point::new(self.x_mm as f64, self.y_mm as f64)
    }

    /// Sets where the plate is (rounded to the millimetre).
    pub fn place(&mut self, at: Point) {
        (self.x_mm, self.y_mm) = (at.x.round() as i64, at.y.round() as i64);
    }
}

impl Corridor {
    /// A point on the line of lights.
    pub fn at(&self) -> Point {
        Point::new(self.x_mm, self.y_mm)
    }
}

/// One robot's blackboard on the data server.
#[derive(Clone)]
pub struct Board {
    ds: DataClient,
    scope: String,
}

/// How long a client started again looks for a Planner waiting on it
/// before it takes what was left unfinished as over. A Planner's call that
/// went unanswered in an outage reaches the server that has come back at
/// its next attempt (attempts grow to 3 s, with up to 0.5 s between), and
/// the wait after it follows within the Planner's 2-s slice: 8 s covers
/// both with room for a loaded host.
pub const PLANNER_PATIENCE: std::time::Duration = std::time::Duration::from_secs(8);

impl Board {
    /// Robot `robot`'s board, through a data-server client.
    pub fn new(ds: DataClient, robot: &str) -> Board {
        Board {
            ds,
            scope: format!("nav/{robot}"),
        }
    }

    /// The data-server client underneath.
    pub fn client(&self) -> &DataClient {
        &self.ds
    }

    /// The full data-server name of a variable (`nav/r1/GoalType`).
    pub fn var_name(&self, var: Var) -> String {
        format!("{}/{}", self.scope, var.name())
    }

    /// The full data-server name of a semaphore (`$nav/r1/GoalData`).
    pub fn sem_name(&self, sem: Sem) -> String {
        format!("${}/{}", self.scope, sem.name())
    }

    /// Creates every semaphore that does not exist yet (each client does
    /// this at start, so they may start in any order).
    pub async fn declare(&self) -> Result<(), ClientError> {
        for sem in Sem::ALL {
            self.ds
                .create_semaphore(&self.sem_name(sem), sem.initial())
                .await?;
        }
        Ok(())
    }

    /// Writes a variable.
    pub async fn set<T: Serialize + ?Sized>(&self, var: Var, value: &T) -> Result<(), ClientError> {
        self.ds.set(&self.var_name(var), value).await.map(|_| ())
    }

    /// Reads a variable as `T`.
    pub async fn get<T: serde::de::DeserializeOwned>(&self, var: Var) -> Result<T, ClientError> {
        self.ds.get_as(&self.var_name(var)).await
    }

    /// up().
    pub async fn up(&self, sem: Sem) -> Result<(), ClientError> {
        self.ds.signal(&self.sem_name(sem)).await.map(|_| ())
    }

    /// down(), waiting as long as it takes.
    pub async fn down(&self, sem: Sem) -> Result<(), ClientError> {
        self.ds.wait(&self.sem_name(sem)).await
    }

    /// down() without waiting: whether a unit was taken.
    pub async fn try_down(&self, sem: Sem) -> Result<bool, ClientError> {
        self.ds.try_wait(&self.sem_name(sem)).await
    }

    /// down() without waiting, with an undo unit (§4.6.1): if this client
    /// dies holding it, the data server gives it back. For a token that
    /// one of several processes holds for a moment, which a process killed
    /// while holding it would otherwise keep from the others for good.
    pub async fn try_down_undo(&self, sem: Sem) -> Result<bool, ClientError> {
        self.ds.try_wait_undo(&self.sem_name(sem)).await
    }

    /// Gives back a unit taken with [`Board::try_down_undo`].
    pub async fn give_back(&self, sem: Sem) -> Result<(), ClientError> {
        self.ds.give_back(&self.sem_name(sem)).await.map(|_| ())
    }

    /// Planner: writes a goal's three variables and does up($GoalData).
    pub async fn give_goal(&self, goal: &Goal) -> Result<(), ClientError> {
        self.set(Var::GoalType, &goal.goal_type).await?;
        self.set(Var::GoalDistance, &goal.distance).await?;
        self.set(Var::GoalDirection, &goal.direction_deg).await?;
        self.up(Sem::GoalData).await
    }

    /// Navigator: down($GoalData) and reads the goal.
    pub async fn take_goal(&self) -> Result<Goal, ClientError> {
        self.down(Sem::GoalData).await?;
        self.read_goal().await
    }

    /// Navigator, in the middle of a goal: a goal handed meanwhile, if
    /// there is one (a try-wait on `$GoalData`). The Planner hands the next
    /// goal only after `$RobotStatus`, so one here replaces the goal at
    /// hand: the Planner's run was ended and the robot is to stop.
    pub async fn goal_handed_meanwhile(&self) -> Result<Option<Goal>, ClientError> {
        let sem = self.sem_name(Sem::GoalData);
        if !self.client().try_wait(&sem).await? {
            return Ok(None);
        }
        self.read_goal().await.map(Some)
    }

    /// Whether a client waits on any of `sems`, looked at every 100 ms for
    /// up to `patience`. A client started again after a data-server
    /// outage asks this of the Planner: the Planner's wait reaches a
    /// server that has just come back only when its own call is next
    /// retried, so one look can come too soon.
    pub async fn someone_waits(
        &self,
        sems: &[Sem],
        patience: std::time::Duration,
    ) -> Result<bool, ClientError> {
        let start = rome_clock::Instant::now();
        loop {
            for sem in sems {
                if self.client().semaphore(&self.sem_name(*sem)).await?.waiters > 0 {
                    return Ok(true);
                }
            }
            if start.elapsed() >= patience {
                return Ok(false);
            }
            rome_clock::sleep(std::time::Duration::from_millis(100)).await;
        }
    }

    async fn read_goal(&self) -> Result<Goal, ClientError> {
        Ok(Goal {
            goal_type: self.get(Var::GoalType).await?,
            distance: self.get(Var::GoalDistance).await?,
            direction_deg: self.get(Var::GoalDirection).await?,
        })
    }
}
