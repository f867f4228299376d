//! What the fleet's tasks are on the data server: their names and values.
//!
//! ```text
//! fleet/task/<id>      {"to":"376L","robot":null,"priority":0,"via":[]}   whoever adds it
//! fleet/cancel/<id>    {"why":"not needed"}                               whoever cancels it
//! fleet/status/<id>    {"id":"T7","state":"assigned","robot":"r3",…}      the dispatcher
//! nav/<robot>/Duty     {"at":"350R","state":"idle","task":null,…}         the robot's Planner
//! nav/<robot>/Task     {"task":"T7","to":"376L","via":[]} or null         the dispatcher
//! $nav/<robot>/Task    up() by the dispatcher after it writes Task,
//!                      or by a robot that asks it to make way
//! nav/<robot>/Way      {"at_mm":[x,y],"heading_deg":90,"to_mm":[x,y],"of":["r15"],"n":2}
//!                      or null                                            the robot's Planner
//! $fleet/wake          up() by anyone who adds, cancels or ends a task
//! $fleet/dispatcher    value 1: held (undo) by the one dispatcher running
//! $fleet/task-ids      up() hands out task numbers
//! ```
//!
//! Every variable has one writer, so no lock is needed to change one: a
//! task is written once by whoever adds it and never again; its status
//! only by the dispatcher; a robot's duty only by its Planner. Everything
//! read here comes from the network and is decoded strictly, one value at
//! a time: a bad one fails that task with the reason, not the reader.

use serde::{Deserialize, Serialize};

/// Where tasks are added: `fleet/task/<id>`.
pub const TASK_PREFIX: &str = "fleet/task/";
/// Where cancellations are written: `fleet/cancel/<id>`.
pub const CANCEL_PREFIX: &str = "fleet/cancel/";
/// Where the dispatcher keeps each task's status: `fleet/status/<id>`.
pub const STATUS_PREFIX: &str = "fleet/status/";
/// Woken whenever there is something for the dispatcher to look at.
pub const WAKE: &str = "$fleet/wake";
/// Held by the dispatcher that runs; a second one waits for it.
pub const DISPATCHER: &str = "$fleet/dispatcher";
/// Hands out task numbers (`T1`, `T2` …) to `rome task add`.
pub const TASK_IDS: &str = "$fleet/task-ids";
/// How many robots a task is tried on before it fails for good.
pub const MAX_ATTEMPTS: u32 = 3;

/// `nav/<robot>/Duty`.
pub fn duty_var(robot: &str) -> String {
    format!("nav/{robot}/Duty")
}

/// `nav/<robot>/Task`.
pub fn task_var(robot: &str) -> String {
    format!("nav/{robot}/Task")
}

/// `$nav/<robot>/Task`.
pub fn task_sem(robot: &str) -> String {
    format!("$nav/{robot}/Task")
}

/// `nav/<robot>/Way`.
pub fn way_var(robot: &str) -> String {
    format!("nav/{robot}/Way")
}

/// A robot held up with a task asks robots standing idle just ahead of it
/// to make way, on its own `nav/<robot>/Way` (`null` when it asks
/// nothing). Each robot it names is woken through its `$nav/<robot>/Task`,
/// and answers each `n` once.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WayAsk {
    /// Where the asker is held up, by its odometry, mm.
    pub at_mm: [f64; 2],
    /// The way it goes there: its route's heading, degrees.
    pub heading_deg: f64,
    /// Where its route ends, mm: nobody makes way to there.
    pub to_mm: [f64; 2],
    /// The robots asked.
    pub of: Vec<String>,
    /// Counts the asker's asks: a larger one is a new ask.
    pub n: u64,
}

/// A task as whoever adds it writes it to `fleet/task/<id>`: go to a
/// position, on a given robot or on whichever is best placed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskSpec {
    /// Where to go: a position of the map (a door jamb such as 376L).
    pub to: String,
    /// Only this robot may do it.
    #[serde(default)]
    pub robot: Option<String>,
    /// Higher goes first; equal priorities go in the order added.
    #[serde(default)]
    pub priority: i64,
    /// Positions to go through on the way, in order.
    #[serde(default)]
    pub via: Vec<String>,
}

/// Where a task stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TaskState {
    /// Waiting for a robot.
    Queued,
    /// Handed to a robot, which is on its way.
    Assigned,
    /// The robot arrived.
    Done,
    /// It cannot be done: the reasons are in `why`.
    Failed,
    /// Cancelled before it was done.
    Cancelled,
}

impl TaskState {
    /// Whether nothing more will happen to the task.
    pub fn ended(self) -> bool {
        matches!(
            self,
            TaskState::Done | TaskState::Failed | TaskState::Cancelled
        )
    }
}

/// A task's status, written by the dispatcher to `fleet/status/<id>`.
/// Times are the dispatcher's clock (simulated time in a lock-step run),
/// milliseconds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskStatus {
    /// The task's id.
    pub id: String,
    /// Where it goes.
    pub to: String,
    /// Its priority.
    pub priority: i64,
    /// Where it stands.
    pub state: TaskState,
    /// The robot it is or was last handed to.
    pub robot: Option<String>,
    /// The robots it was handed to, in order.
    pub tried: Vec<String>,
    /// Why it was taken from a robot, failed or cancelled, in order.
    pub why: Vec<String>,
    /// When the dispatcher first saw it.
    pub added_ms: u64,
    /// When it was last handed to a robot.
    pub assigned_ms: Option<u64>,
    /// When it ended.
    pub ended_ms: Option<u64>,
    /// The order the dispatcher saw tasks in (ties of priority).
    pub seq: u64,
}

impl TaskStatus {
    /// A task just seen: queued, tried by no robot yet.
    pub fn queued(id: &str, to: &str, priority: i64, added_ms: u64, seq: u64) -> TaskStatus {
        TaskStatus {
            id: id.into(),
            to: to.into(),
            priority,
            state: TaskState::Queued,
            robot: None,
            tried: vec![],
            why: vec![],
            added_ms,
            assigned_ms: None,
            ended_ms: None,
            seq,
        }
    }

    /// How long it waited for the robot that last took it, ms: from added
    /// to handed over (to its end if it ended waiting, to now if it still
    /// waits).
    pub fn waited_ms(&self, now_ms: u64) -> u64 {
        let until = match self.state {
            TaskState::Queued => now_ms,
            _ => self.assigned_ms.or(self.ended_ms).unwrap_or(now_ms),
        };
        until.saturating_sub(self.added_ms)
    }
}

/// What a robot is told to do: `nav/<robot>/Task` (`null`: nothing, or
/// stop what you were told).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Assignment {
    /// The task.
    pub task: String,
    /// Where to go.
    pub to: String,
    /// Positions on the way.
    pub via: Vec<String>,
}

/// What a robot making way for `by` says its task is, on its
/// `nav/<robot>/Duty` and as its drive's name.
pub fn making_way_for(by: &str) -> String {
    format!("make way for {by}")
}

/// What a robot driving on to stand apart from robots waiting
/// ([`super::way`]) says its task is, on its `nav/<robot>/Duty` and as its
/// drive's name.
pub const STAND_APART_TASK: &str = "stand apart";

/// A robot's state as its Planner reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DutyState {
    /// Standing at `at`, ready for a task.
    Idle,
    /// On its way to a task's goal.
    Busy,
    /// Out of service: it does not know where it is (its odometry cannot
    /// be read), or it was blocked twice in one place. It takes no task
    /// until it is put down again.
    Lost,
}

/// How a robot's last task went.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Outcome {
    /// The task.
    pub task: String,
    /// Whether the robot arrived.
    pub ok: bool,
    /// Why not.
    pub why: Option<String>,
}

/// `nav/<robot>/Duty`: written by the robot's Planner when it takes tasks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Duty {
    /// Where it stands (when idle) or last stood: a position of the map,
    /// or `@x,y` (metres) where its odometry puts it between positions.
    pub at: String,
    /// Where its odometry puts it, mm, when that is not a named position.
    #[serde(default)]
    pub at_mm: Option<[f64; 2]>,
    /// Its state.
    pub state: DutyState,
    /// The task it carries out.
    pub task: Option<String>,
    /// Its Planner's data-server owner id: when that client's liveliness
    /// goes, the robot's crew is gone.
    pub owner: String,
    /// How its last task went.
    pub last: Option<Outcome>,
}

/// Decodes a value read from the blackboard as `T`, naming it on failure.
pub fn decode<T: serde::de::DeserializeOwned>(
    name: &str,
    value: &serde_json::Value,
) -> Result<T, String> {
    serde_json::from_value(value.clone())
        .map_err(|e| format!("{name} is not what it should be: {e}"))
}
