//! The soak's robots: each a world, its servers and its crew as processes,
//! the faults thrown at them, and what a fault must leave behind (a lock
//! released, a robot stopped).

use super::*;
use rome_client::relay::Relay;
use rome_schema::robot::BaseState;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

pub(super) const FAULTS: &[&str] = &[
    "kill-navigator",
    "kill-lock-holder",
    "kill-nav-client",
    "kill-planner",
    "kill-sim",
    "kill-data-server",
    "pause-link",
    "cut-link",
    "crash-waiter",
    "crash-writer",
];

pub(super) enum Restart {
    DataServer,
    Sim(usize),
    Waiter(usize),
    Writer(usize),
}

pub(super) struct RobotRig {
    pub(super) robot: String,
    pub(super) from: String,
    pub(super) to: String,
    /// Whether the robot is at `from` (else at `to`).
    pub(super) at_start: bool,
    pub(super) relay: Relay,
    pub(super) link: String,
    pub(super) sim: Proc,
    /// The world's state file (`rome sim --state`): a killed world is
    /// taken up where it stood.
    pub(super) state: PathBuf,
    /// `rome crew`: navigator, ctracker, mapper, plfinder, each started
    /// again by the crew when it is killed.
    pub(super) crew: Proc,
    pub(super) planner: Option<Proc>,
    pub(super) runs: u32,
}

impl RobotRig {
    /// Judges a planner that ended, by its exit and by where the robot
    /// truly stands, and starts the next run when the robot's world and
    /// crew are up.
    pub(super) async fn judge_planner(
        &mut self,
        runs: &mut Runs,
        exe: &Path,
        judge: &Judge,
    ) -> anyhow::Result<()> {
        if let Some(p) = self.planner.as_mut() {
            let Some(status) = p.ended() else {
                return Ok(());
            };
            let out = std::fs::read_to_string(p.log.with_extension("out")).unwrap_or_default();
            let err = std::fs::read_to_string(&p.log).unwrap_or_default();
            self.planner = None;
            let goal = if self.at_start { &self.to } else { &self.from };
            let verdict = if status.success() {
                match judge.miss_m(&self.robot, goal).await {
                    Some(m) if m <= ARRIVED_WITHIN_M => Ok(Some(m)),
                    Some(m) => Err(Some(format!(
                        "done by the Planner's account, but {m:.2} m from its goal by ground truth"
                    ))),
                    None => Ok(None),
                }
            } else {
                Err(reason(&out, &err))
            };
            match verdict {
                Ok(miss) => {
                    runs.arrived += 1;
                    match miss {
                        Some(m) => runs.worst_miss_m = runs.worst_miss_m.max(m),
                        None => runs.arrived_unjudged += 1,
                    }
                    self.at_start = !self.at_start;
                }
                Err(why) => {
                    match why {
                        Some(why) => {
                            runs.failed_with_reason += 1;
                            *runs.reasons.entry(shorten(&why)).or_default() += 1;
                        }
                        None => runs.failed_without_reason += 1,
                    }
                    // Back to the start, in a fresh world.
                    self.reset(exe);
                }
            }
        }
        if self.planner.is_none() && self.sim.running() && self.crew.running() {
            self.runs += 1;
            let (from, to) = if self.at_start {
                (&self.from, &self.to)
            } else {
                (&self.to, &self.from)
            };
            let dir = self.sim.log.parent().unwrap_or(Path::new("."));
            let mut p = Proc::new(
                dir,
                &format!("planner-{}-{}", self.robot, self.runs),
                strings(&[
                    "--no-multicast",
                    "--mode",
                    "client",
                    "--connect",
                    &self.link,
                    "planner",
                    "--robot",
                    &self.robot,
                    "--from",
                    from,
                    "--to",
                    to,
                    "--timeout",
                    "600",
                ]),
            );
            p.start(exe)?;
            self.planner = Some(p);
        }
        Ok(())
    }

    /// Kills the crew's member `role` with SIGKILL (the crew starts it
    /// again); false if it was not found (between a death and its restart).
    pub(super) fn kill_member(&self, role: &str) -> bool {
        let Some(crew) = self.crew.child.as_ref().map(Child::id) else {
            return false;
        };
        match member_pid(crew, role) {
            Some(pid) => Command::new("kill")
                .args(["-KILL", &pid.to_string()])
                .status()
                .is_ok_and(|s| s.success()),
            None => false,
        }
    }

    /// Puts the robot back at its start, as an operator would after a
    /// failed or killed run: a fresh world, and its crew started afresh.
    /// A crew left running would carry on with the goal it had, measured
    /// in the old world's odometry, and drive the teleported robot into
    /// walls while the next run's Planner waits for it.
    pub(super) fn reset(&mut self, exe: &Path) {
        self.sim.kill();
        // A world started without its state file puts the robot at its
        // start.
        let _ = std::fs::remove_file(&self.state);
        self.crew.stop();
        start_again(&mut self.sim, exe);
        start_again(&mut self.crew, exe);
        self.at_start = true;
    }
}

/// How far from its goal, by ground truth, a run may end and count as
/// arrived.
pub(super) const ARRIVED_WITHIN_M: f64 = 1.0;

/// Ground truth, to judge where a run really ended.
pub(super) struct Judge {
    pub(super) session: zenoh::Session,
    pub(super) world: rome_maps::world::World,
}

impl Judge {
    /// How far robot `robot` truly stands from position `goal`'s point on
    /// the line of lights, m; `None` when its world does not answer.
    pub(super) async fn miss_m(&self, robot: &str, goal: &str) -> Option<f64> {
        let at = self.world.position(goal)?.in_corridor();
        let root = rome_schema::Root::default();
        let truth = rome_client::sim::TruthClient::new(&self.session, &root, robot)
            .ok()?
            .get()
            .await
            .ok()?;
        Some(((truth.x_mm - at.x).powi(2) + (truth.y_mm - at.y).powi(2)).sqrt() / 1000.0)
    }
}

/// Why a planner failed, in its own words: the reasons it printed under
/// its table, or its error.
pub(super) fn reason(out: &str, err: &str) -> Option<String> {
    if let Some(e) = err.lines().rev().find(|l| l.starts_with("error:")) {
        return Some(shorten(e));
    }
    if let Some(g) = err.lines().rev().find(|l| l.contains("gave up after")) {
        return Some(shorten(g));
    }
    let done = out.lines().rev().find(|l| l.starts_with("done:"))?;
    // The starred reasons under the table: the first says what went wrong
    // first.
    let first = out.lines().find(|l| l.starts_with("* "));
    Some(shorten(first.unwrap_or(done)))
}

/// A reason with its numbers taken out, to count alike reasons together.
pub(super) fn shorten(line: &str) -> String {
    let words: String = line
        .chars()
        .map(|c| if c.is_ascii_digit() { '#' } else { c })
        .collect();
    words.chars().take(140).collect()
}

/// The process id of `parent`'s child running `rome <role> …` (Linux:
/// each of the parent's threads lists the children it started).
fn member_pid(parent: u32, role: &str) -> Option<u32> {
    let tasks = std::fs::read_dir(format!("/proc/{parent}/task")).ok()?;
    tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("children")).ok())
        .flat_map(|c| {
            c.split_whitespace()
                .filter_map(|p| p.parse::<u32>().ok())
                .collect::<Vec<_>>()
        })
        .find(|pid| {
            std::fs::read(format!("/proc/{pid}/cmdline"))
                .is_ok_and(|cmd| cmd.split(|b| *b == 0).nth(1) == Some(role.as_bytes()))
        })
}

pub(super) fn start_again(p: &mut Proc, exe: &Path) {
    p.kill();
    if let Err(e) = p.start(exe) {
        eprintln!("soak: {e:#}");
    }
}

pub(super) fn link_of<'a>(robots: &'a [RobotRig], data: &'a Relay, k: usize) -> &'a Relay {
    robots.get(k).map_or(data, |r| &r.relay)
}

/// What a watch waits for after a kill.
#[derive(Debug, Clone)]
pub(super) enum Released {
    /// The lock of this holder is gone.
    Lock(String),
    /// The wheels stand still.
    Stopped,
}

/// The next message of a robot's base state stream.
pub(super) async fn base_state(s: &zenoh::Session, robot: &str) -> Option<BaseState> {
    let sub = s
        .declare_subscriber(format!("rome/robot/{robot}/base/state"))
        .await
        .ok()?;
    let deadline = Instant::now() + Duration::from_secs(2);
    while let Ok(Ok(sample)) = tokio::time::timeout_at(deadline.into(), sub.recv_async()).await {
        if let Ok(state) = rome_schema::decode(&sample.payload().to_bytes(), "state") {
            return Some(state);
        }
    }
    None
}

/// The holder of a robot's base lock once someone holds it.
pub(super) async fn lock_taken(
    s: &zenoh::Session,
    robot: &str,
    within: Duration,
) -> Option<String> {
    let deadline = Instant::now() + within;
    while Instant::now() < deadline {
        if let Some(lock) = base_state(s, robot).await.and_then(|st| st.lock) {
            return Some(lock.holder);
        }
    }
    None
}

/// How long after `killed` the robot's state first shows `what`.
pub(super) async fn released(
    s: zenoh::Session,
    robot: String,
    what: Released,
    killed: Instant,
) -> (Released, Option<Duration>) {
    let Ok(sub) = s
        .declare_subscriber(format!("rome/robot/{robot}/base/state"))
        .await
    else {
        return (what, None);
    };
    let deadline = killed + Duration::from_secs(15);
    while let Ok(Ok(sample)) = tokio::time::timeout_at(deadline.into(), sub.recv_async()).await {
        let Ok(state) = rome_schema::decode::<BaseState>(&sample.payload().to_bytes(), "state")
        else {
            continue;
        };
        let done = match &what {
            Released::Lock(holder) => state.lock.is_none_or(|l| &l.holder != holder),
            Released::Stopped => state.wheel_speed_mm_s.abs() < 1.0,
        };
        if done {
            return (what, Some(killed.elapsed()));
        }
    }
    (what, None)
}
