//! The fleet's dispatcher (`rome dispatcher`): hands each waiting task to
//! a free robot, and a task whose robot failed or whose crew died to
//! another, saying why.
//!
//! One runs per fleet: it holds `$fleet/dispatcher` (value 1) with an undo
//! wait, so a second one waits in the queue and takes over, with every
//! task where the first left it, when the first one's liveliness goes.
//! It keeps nothing of its own: each round reads the tasks, cancellations
//! and robots' duties from the data server and writes the statuses back,
//! so a dispatcher started again carries on.
//!
//! A round runs when `$fleet/wake` is signalled (a task added, cancelled
//! or ended) and at least every [`DispatchConfig::every`], to notice crews
//! that died.

use super::assign::{assign, Free, Waiting};
use super::schema::{
    decode, task_sem, task_var, Assignment, Duty, DutyState, TaskSpec, TaskState, TaskStatus,
    CANCEL_PREFIX, DISPATCHER, MAX_ATTEMPTS, STATUS_PREFIX, TASK_PREFIX, WAKE,
};
use crate::NavError;
use rome_client::{ClientError, DataClient};
use rome_maps::geometry::Point;
use rome_maps::{Network, World};
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

/// How the dispatcher runs.
#[derive(Debug, Clone)]
pub struct DispatchConfig {
    /// The longest time between two rounds.
    pub every: Duration,
}

impl Default for DispatchConfig {
    fn default() -> Self {
        DispatchConfig {
            every: Duration::from_secs(1),
        }
    }
}

/// What the dispatcher tells whoever watches.
#[derive(Debug, Clone, PartialEq)]
pub enum Note {
    /// Another dispatcher runs: this one waits to take over.
    Waiting,
    /// This one runs; `tasks` are still open from before.
    Running {
        /// Open tasks taken up.
        tasks: usize,
    },
    /// A task changed: its status afterwards, and what happened.
    Task(TaskStatus, String),
    /// A round could not be done (the data server is away, say); the
    /// next one tries again.
    Round(String),
}

/// The dispatcher: its data-server client, the map routes are measured on,
/// and the tasks' statuses as it last wrote them.
pub struct Dispatcher {
    ds: DataClient,
    session: zenoh::Session,
    world: World,
    network: Network,
    cfg: DispatchConfig,
    statuses: BTreeMap<String, TaskStatus>,
    /// Duties that did not decode, and why: each is said once.
    bad_duties: BTreeMap<String, String>,
    /// Route lengths between positions, mm, as measured once.
    lengths: BTreeMap<(String, String), Option<f64>>,
    /// Who is alive, from the first round on.
    alive: Option<rome_client::alive::Watch>,
}

impl Dispatcher {
    /// A dispatcher for the fleet its data-server client serves (under that
    /// client's root), measuring routes on the map of `world`.
    pub fn new(
        ds: DataClient,
        session: zenoh::Session,
        world: World,
        network: Network,
        cfg: DispatchConfig,
    ) -> Dispatcher {
        Dispatcher {
            ds,
            session,
            world,
            network,
            cfg,
            statuses: BTreeMap::new(),
            bad_duties: BTreeMap::new(),
            lengths: BTreeMap::new(),
            alive: None,
        }
    }

    /// Waits until it is the one dispatcher, then runs until the data
    /// server cannot be reached at all. A round that fails is reported
    /// and tried again; no value read ends it.
    pub async fn run(mut self, mut note: impl FnMut(Note)) -> Result<(), NavError> {
        self.ds.create_semaphore(DISPATCHER, 1).await?;
        self.ds.create_semaphore(WAKE, 0).await?;
        if !self.ds.try_wait_undo(DISPATCHER).await? {
            note(Note::Waiting);
            self.ds.wait_undo(DISPATCHER).await?;
        }
        for (name, value) in self
            .ds
            .values_matching(&format!("{STATUS_PREFIX}*"))
            .await?
        {
            if let Ok(s) = serde_json::from_value::<TaskStatus>(value) {
                if name.strip_prefix(STATUS_PREFIX) == Some(s.id.as_str()) {
                    self.statuses.insert(s.id.clone(), s);
                }
            }
        }
        let open = self.statuses.values().filter(|s| !s.state.ended()).count();
        note(Note::Running { tasks: open });
        loop {
            if let Err(e) = self.round(&mut note).await {
                note(Note::Round(e.to_string()));
            }
            if let Err(e) = self.ds.wait_timeout(WAKE, self.cfg.every).await {
                note(Note::Round(e.to_string()));
                rome_clock::sleep(self.cfg.every).await;
            }
        }
    }

    /// The tasks' statuses as last written.
    pub fn statuses(&self) -> &BTreeMap<String, TaskStatus> {
        &self.statuses
    }

    /// One look at everything, and what follows from it.
    pub async fn round(&mut self, note: &mut impl FnMut(Note)) -> Result<(), ClientError> {
        let now = now_ms();
        let specs = self.ds.values_matching(&format!("{TASK_PREFIX}*")).await?;
        let cancels = self
            .ds
            .values_matching(&format!("{CANCEL_PREFIX}*"))
            .await?;
        let duties = self.duties(note).await?;
        let alive = self.alive().await?;

        let mut changed: Vec<(String, String)> = Vec::new();
        let mut specs_ok: BTreeMap<String, TaskSpec> = BTreeMap::new();
        for (name, value) in &specs {
            let Some(id) = name.strip_prefix(TASK_PREFIX) else {
                continue;
            };
            match decode::<TaskSpec>(name, value) {
                Ok(spec) => {
                    if !self.statuses.contains_key(id) {
                        let mut s = self.fresh(id, &spec.to, spec.priority, now);
                        if let Some(why) = self.unplaceable(&spec) {
                            end(&mut s, TaskState::Failed, why.clone(), now);
                            changed.push((id.into(), why));
                        } else {
                            changed.push((id.into(), "added".into()));
                        }
                        self.statuses.insert(id.into(), s);
                    }
                    specs_ok.insert(id.into(), spec);
                }
                Err(why) => {
                    if !self.statuses.contains_key(id) {
                        let mut s = self.fresh(id, "", 0, now);
                        end(&mut s, TaskState::Failed, why.clone(), now);
                        self.statuses.insert(id.into(), s);
                        changed.push((id.into(), why));
                    }
                }
            }
        }

        // Cancellations, then what the robots report.
        for (name, value) in &cancels {
            let Some(id) = name.strip_prefix(CANCEL_PREFIX) else {
                continue;
            };
            let Some(s) = self.statuses.get_mut(id) else {
                continue;
            };
            if s.state.ended() {
                continue;
            }
            let why = match value.get("why").and_then(Value::as_str) {
                Some(w) => format!("cancelled: {w}"),
                None => "cancelled".to_string(),
            };
            if s.state == TaskState::Assigned {
                if let Some(robot) = s.robot.clone() {
                    self.ds.set(&task_var(&robot), &None::<Assignment>).await?;
                    self.ds.signal(&task_sem(&robot)).await?;
                }
            }
            end(s, TaskState::Cancelled, why.clone(), now);
            changed.push((id.into(), why));
        }
        for s in self.statuses.values_mut() {
            if s.state != TaskState::Assigned {
                continue;
            }
            let Some(robot) = s.robot.clone() else {
                continue;
            };
            let duty = duties.get(&robot);
            let outcome = duty
                .and_then(|d| d.last.as_ref())
                .filter(|o| o.task == s.id);
            let taken_back = match (duty, outcome) {
                (_, Some(o)) if o.ok => {
                    end(s, TaskState::Done, format!("{robot} arrived"), now);
                    changed.push((s.id.clone(), format!("done by {robot}")));
                    continue;
                }
                (_, Some(o)) => format!(
                    "{robot} did not arrive: {}",
                    o.why.as_deref().unwrap_or("no reason given")
                ),
                (None, None) => format!("{robot} reports no duty"),
                (Some(d), None) if !alive.contains(&d.owner) => {
                    format!("{robot}'s Planner is gone (its crew stopped or was cut off)")
                }
                (Some(d), None) if d.state == DutyState::Lost => {
                    format!("{robot} is lost and takes no task")
                }
                (Some(_), None) => continue,
            };
            s.why.push(taken_back.clone());
            s.robot = None;
            let pinned = specs_ok.get(&s.id).and_then(|t| t.robot.as_ref());
            if s.tried.len() as u32 >= MAX_ATTEMPTS || pinned.is_some() {
                s.state = TaskState::Failed;
                s.ended_ms = Some(now);
                changed.push((s.id.clone(), format!("failed: {taken_back}")));
            } else {
                s.state = TaskState::Queued;
                changed.push((s.id.clone(), format!("back in the queue: {taken_back}")));
            }
        }

        for (id, what) in changed {
            if let Some(s) = self.statuses.get(&id) {
                self.ds.set(&format!("{STATUS_PREFIX}{id}"), s).await?;
                note(Note::Task(s.clone(), what));
            }
        }

        // Free robots: idle, alive, and not handed a task they have not
        // reported on.
        let handed: BTreeSet<&str> = self
            .statuses
            .values()
            .filter(|s| s.state == TaskState::Assigned)
            .filter_map(|s| s.robot.as_deref())
            .collect();
        let free: Vec<Free> = duties
            .iter()
            .filter(|(r, d)| {
                d.state == DutyState::Idle
                    && alive.contains(&d.owner)
                    && !handed.contains(r.as_str())
            })
            .map(|(r, d)| Free {
                name: r.clone(),
                at: d.at.clone(),
                at_mm: d.at_mm,
            })
            .collect();
        let waiting: Vec<Waiting<'_>> = self
            .statuses
            .values()
            .filter(|s| s.state == TaskState::Queued)
            .map(|s| Waiting {
                status: s,
                robot: specs_ok.get(&s.id).and_then(|t| t.robot.as_deref()),
            })
            .collect();
        let (world, network, lengths) = (&self.world, &self.network, &mut self.lengths);
        let chosen = assign(&waiting, &free, |robot, to| {
            if robot.at_mm.is_none() && robot.at == to {
                return Some(0.0);
            }
            *lengths
                .entry((robot.at.clone(), to.to_string()))
                .or_insert_with(|| {
                    let route = match robot.at_mm {
                        Some([x, y]) => {
                            world.route_from(network, (&robot.at, Point::new(x, y)), &[], to)
                        }
                        None => world.route(network, &robot.at, &[], to),
                    };
                    route.ok().map(|r| r.length_mm)
                })
        });
        for (id, robot) in chosen {
            let Some(s) = self.statuses.get_mut(&id) else {
                continue;
            };
            let via = specs_ok.get(&id).map(|t| t.via.clone()).unwrap_or_default();
            s.state = TaskState::Assigned;
            s.robot = Some(robot.clone());
            s.tried.push(robot.clone());
            s.assigned_ms = Some(now);
            // The status first: a dispatcher that dies here and starts
            // again finds the task handed over, and the robot's report.
            self.ds.set(&format!("{STATUS_PREFIX}{id}"), &*s).await?;
            let a = Assignment {
                task: id.clone(),
                to: s.to.clone(),
                via,
            };
            self.ds.set(&task_var(&robot), &Some(a)).await?;
            self.ds.create_semaphore(&task_sem(&robot), 0).await?;
            self.ds.signal(&task_sem(&robot)).await?;
            let at = free
                .iter()
                .find(|f| f.name == robot)
                .map_or("?", |f| f.at.as_str());
            note(Note::Task(s.clone(), format!("to {robot}, from {at}")));
        }
        Ok(())
    }

    /// Every robot's duty that decodes; the others are said once each.
    async fn duties(
        &mut self,
        note: &mut impl FnMut(Note),
    ) -> Result<BTreeMap<String, Duty>, ClientError> {
        let mut out = BTreeMap::new();
        for (robot, duty) in super::tasks::robots(&self.ds).await? {
            match duty {
                Ok(d) => {
                    self.bad_duties.remove(&robot);
                    out.insert(robot, d);
                }
                Err(why) => {
                    if self.bad_duties.get(&robot) != Some(&why) {
                        note(Note::Round(format!("robot {robot} left out: {why}")));
                        self.bad_duties.insert(robot, why);
                    }
                }
            }
        }
        Ok(out)
    }

    /// The ids of every live client (a duty's owner among them while its
    /// Planner runs).
    async fn alive(&mut self) -> Result<BTreeSet<String>, ClientError> {
        if self.alive.is_none() {
            let root = &self.ds.options().root;
            let watch =
                rome_client::alive::Watch::start(&self.session, root, Duration::from_secs(2))
                    .await?;
            self.alive = Some(watch);
        }
        Ok(self.alive.as_ref().map(|w| w.ids()).unwrap_or_default())
    }

    fn fresh(&self, id: &str, to: &str, priority: i64, now: u64) -> TaskStatus {
        let seq = self.statuses.values().map(|s| s.seq + 1).max().unwrap_or(1);
        TaskStatus::queued(id, to, priority, now, seq)
    }

    /// Why the map cannot place the task's goal or a position on its way.
    fn unplaceable(&self, spec: &TaskSpec) -> Option<String> {
        std::iter::once(&spec.to)
            .chain(&spec.via)
            .find(|p| self.world.position(p).is_none())
            .map(|p| {
                rome_maps::RouteError::Unknown {
                    name: p.clone(),
                    similar: self.world.similar(p),
                }
                .to_string()
            })
    }
}

fn end(s: &mut TaskStatus, state: TaskState, why: String, now: u64) {
    s.state = state;
    s.ended_ms = Some(now);
    if state != TaskState::Done {
        s.why.push(why);
    }
}

/// The dispatcher's clock, ms: simulated time in a lock-step run, the wall
/// clock's (Unix time) otherwise, so statuses from two dispatchers compare.
pub fn now_ms() -> u64 {
    rome_clock::now_ms().unwrap_or_else(|| {
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as u64)
    })
}
