//! Keeps a set of `rome` processes running, as `ros2 launch` with respawn
//! or systemd's `Restart=` would: each member that ends is started again
//! after a back-off that doubles with each quick end, and every line a
//! member writes is passed on with its name in front (standard error to
//! standard error, where the set's own lines go too).
//!
//! ```text
//! crew r1: navigator started (pid 4121)
//! [navigator] rome navigator: robot r1's base reached; waiting for goals
//! crew r1: navigator ended (killed by signal 9) after 12.4 s; again in 0.5 s (restart 1)
//! crew r1: navigator started (pid 4188)
//! ```

use std::path::PathBuf;
use std::process::Stdio;
use std::time::Duration;
use tokio::io::{AsyncBufReadExt, AsyncRead, BufReader};
use tokio::process::{Child, Command};
use tokio::sync::mpsc;

/// One process of the set.
#[derive(Debug, Clone)]
pub struct Member {
    /// How it is named in the output.
    pub name: String,
    /// Its arguments, after the program's name.
    pub args: Vec<String>,
}

/// The program every member runs, and what its environment changes.
#[derive(Debug, Clone)]
pub struct Launch {
    /// The program (this one, for `rome crew`).
    pub program: PathBuf,
    /// Variables set for every member.
    pub env: Vec<(String, String)>,
    /// Variables taken away from every member's environment.
    pub unset: Vec<String>,
}

/// The variable that gives a member its supervisor's process id: a member
/// whose parent is no longer that process ends ([`end_when_orphaned`]).
pub const PARENT_VAR: &str = "ROME_SUPERVISOR_PID";

/// For a program started by [`supervise`]: resolves once the supervisor
/// that started it has gone (it was killed with SIGKILL, say, and could not
/// stop its members), so that the member ends with it. Never resolves in a
/// program started otherwise.
pub async fn end_when_orphaned() {
    let Some(parent) = std::env::var(PARENT_VAR)
        .ok()
        .and_then(|p| p.parse::<u32>().ok())
    else {
        return std::future::pending().await;
    };
    loop {
        #[cfg(unix)]
        if std::os::unix::process::parent_id() != parent {
            return;
        }
        tokio::time::sleep(Duration::from_secs(1)).await;
    }
}

/// When a member that ended is started again.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Restart {
    /// Whatever the exit status.
    Always,
    /// Unless it exited with status 0 (a Planner whose run arrived).
    OnFailure,
    /// Never: the set ends when every member has.
    Never,
}

/// How the set is kept.
#[derive(Debug, Clone)]
pub struct Policy {
    /// When to start a member again.
    pub restart: Restart,
    /// The first back-off; it doubles with each end that came sooner than
    /// [`Policy::settled`] after its start.
    pub backoff: Duration,
    /// The longest back-off.
    pub max_backoff: Duration,
    /// A member that ran this long starts the doubling again from
    /// [`Policy::backoff`].
    pub settled: Duration,
}

impl Default for Policy {
    fn default() -> Self {
        Policy {
            restart: Restart::OnFailure,
            backoff: Duration::from_millis(500),
            max_backoff: Duration::from_secs(30),
            // A member that ran this long is not failing at once: killed
            // or crashed in the middle of its work, it is wanted back
            // soon (a Navigator's Planner gives up on a long silence).
            settled: Duration::from_secs(10),
        }
    }
}

impl Policy {
    /// The wait before the next start of a member that ran for `ran`,
    /// after a wait of `last` before this start (`None`: its first).
    pub fn next_backoff(&self, last: Option<Duration>, ran: Duration) -> Duration {
        match last {
            Some(last) if ran < self.settled => (last * 2).min(self.max_backoff),
            _ => self.backoff,
        }
    }
}

/// Member `i` ended: how (for people), whether with status 0, after how long.
enum Event {
    Ended(usize, String, bool, Duration),
}

/// One member's place in the set.
struct Slot {
    /// Its process, while it runs.
    pid: Option<u32>,
    /// When it is to be started (again).
    due: Option<tokio::time::Instant>,
    /// The last back-off it waited.
    backoff: Option<Duration>,
    /// How many times it was started again.
    restarts: u64,
}

impl Slot {
    /// The member `name` ended (`how`, with status 0 or not, after `ran`):
    /// it is due again after its back-off, or not at all.
    fn ended(
        &mut self,
        policy: &Policy,
        say: &str,
        name: &str,
        how: &str,
        success: bool,
        ran: Duration,
    ) {
        let again = match policy.restart {
            Restart::Always => true,
            Restart::OnFailure => !success,
            Restart::Never => false,
        };
        if !again {
            eprintln!(
                "{say}: {name} ended ({how}) after {:.1} s",
                ran.as_secs_f64()
            );
            return;
        }
        let wait = policy.next_backoff(self.backoff, ran);
        self.backoff = Some(wait);
        self.restarts += 1;
        eprintln!(
            "{say}: {name} ended ({how}) after {:.1} s; again in {:.1} s (restart {})",
            ran.as_secs_f64(),
            wait.as_secs_f64(),
            self.restarts
        );
        self.due = Some(tokio::time::Instant::now() + wait);
    }
}

/// Runs `members` of `launch` under `policy` until `stop` completes (every
/// member is then sent SIGTERM, and SIGKILL 3 s later) or, with
/// [`Restart::Never`] or members that exit 0 under
/// [`Restart::OnFailure`], until none is left. `say` prefixes the set's
/// own lines (`crew r1`).
pub async fn supervise(
    launch: Launch,
    members: Vec<Member>,
    policy: Policy,
    say: &str,
    stop: impl std::future::Future<Output = ()>,
) -> anyhow::Result<()> {
    let (tx, mut rx) = mpsc::unbounded_channel::<Event>();
    let now = tokio::time::Instant::now();
    // Each member waits out its own back-off while the others are watched
    // and started again.
    let mut slots: Vec<Slot> = members
        .iter()
        .map(|_| Slot {
            pid: None,
            due: Some(now),
            backoff: None,
            restarts: 0,
        })
        .collect();
    tokio::pin!(stop);
    loop {
        if slots.iter().all(|s| s.pid.is_none() && s.due.is_none()) {
            eprintln!("{say}: every member has ended");
            return Ok(());
        }
        let next = slots.iter().filter_map(|s| s.due).min();
        let wake = async {
            match next {
                Some(t) => tokio::time::sleep_until(t).await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            _ = &mut stop => break,
            _ = wake => {
                let now = tokio::time::Instant::now();
                for (i, slot) in slots.iter_mut().enumerate() {
                    if slot.due.is_some_and(|t| t <= now) {
                        slot.due = None;
                        match start(&launch, &members[i], i, say, tx.clone()) {
                            Ok(pid) => slot.pid = Some(pid),
                            Err(how) => slot.ended(&policy, say, &members[i].name, &how, false, Duration::ZERO),
                        }
                    }
                }
            }
            Some(Event::Ended(i, how, success, ran)) = rx.recv() => {
                slots[i].pid = None;
                slots[i].ended(&policy, say, &members[i].name, &how, success, ran);
            }
        }
    }
    let mut pids: Vec<Option<u32>> = slots.iter().map(|s| s.pid).collect();
    // Stopped: every member is asked to end, then made to.
    for pid in pids.iter().flatten() {
        signal(*pid, "TERM");
    }
    let deadline = tokio::time::Instant::now() + Duration::from_secs(3);
    while pids.iter().any(Option::is_some) {
        match tokio::time::timeout_at(deadline, rx.recv()).await {
            Ok(Some(Event::Ended(i, ..))) => pids[i] = None,
            _ => {
                for pid in pids.iter().flatten() {
                    signal(*pid, "KILL");
                }
                break;
            }
        }
    }
    eprintln!("{say}: stopped");
    Ok(())
}

/// Starts member `i`, passing its output on and reporting its end; `Err`
/// says why it could not be started (its program replaced as it was
/// upgraded, say), and it is tried again as a member that ended.
fn start(
    launch: &Launch,
    m: &Member,
    i: usize,
    say: &str,
    tx: mpsc::UnboundedSender<Event>,
) -> Result<u32, String> {
    let mut cmd = Command::new(&launch.program);
    cmd.args(&m.args)
        .envs(launch.env.iter().map(|(k, v)| (k, v)))
        .env(PARENT_VAR, std::process::id().to_string());
    for k in &launch.unset {
        cmd.env_remove(k);
    }
    let spawned = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        // A member must not outlive the set when the set's task is dropped.
        .kill_on_drop(true)
        .spawn();
    let mut child: Child = match spawned {
        Ok(c) => c,
        Err(e) => {
            return Err(format!(
                "could not be started from {}: {e}",
                launch.program.display()
            ))
        }
    };
    // Known until the child is reaped, which only its waiter below does.
    let Some(pid) = child.id() else {
        return Err("ended before its process id could be read".into());
    };
    eprintln!("{say}: {} started (pid {pid})", m.name);
    let tag = format!("[{}]", m.name);
    if let Some(out) = child.stdout.take() {
        tokio::spawn(pass_on(out, tag.clone(), false));
    }
    if let Some(err) = child.stderr.take() {
        tokio::spawn(pass_on(err, tag, true));
    }
    let started = std::time::Instant::now();
    tokio::spawn(async move {
        let (how, success) = match child.wait().await {
            Ok(status) => (describe(status), status.success()),
            Err(e) => (format!("could not be waited for: {e}"), false),
        };
        let _ = tx.send(Event::Ended(i, how, success, started.elapsed()));
    });
    Ok(pid)
}

/// Passes each line of `from` on, with `tag` in front: to standard error
/// if it came from there, else to standard output.
async fn pass_on(from: impl AsyncRead + Unpin, tag: String, to_stderr: bool) {
    let mut lines = BufReader::new(from).lines();
    while let Ok(Some(line)) = lines.next_line().await {
        if to_stderr {
            eprintln!("{tag} {line}");
        } else {
            crate::out!("{tag} {line}");
        }
    }
}

fn describe(status: std::process::ExitStatus) -> String {
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(sig) = status.signal() {
            return format!("killed by signal {sig}");
        }
    }
    match status.code() {
        Some(c) => format!("exit status {c}"),
        None => "ended".to_string(),
    }
}

/// Sends a signal by name to `pid` with the system's `kill`, which needs
/// no binding to the C library.
fn signal(pid: u32, name: &str) {
    let _ = std::process::Command::new("kill")
        .args([format!("-{name}"), pid.to_string()])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
}

#[cfg(test)]
mod tests {
    use super::*;

    fn launch(program: &str) -> Launch {
        Launch {
            program: program.into(),
            env: Vec::new(),
            unset: Vec::new(),
        }
    }

    fn member(name: &str, args: &[&str]) -> Member {
        Member {
            name: name.into(),
            args: args.iter().map(|a| a.to_string()).collect(),
        }
    }

    #[tokio::test]
    async fn without_restarts_the_set_ends_when_every_member_has() {
        let policy = Policy {
            restart: Restart::Never,
            ..Policy::default()
        };
        let members = vec![
            member("a", &["-c", "exit 0"]),
            member("b", &["-c", "exit 3"]),
        ];
        let ended = tokio::time::timeout(
            Duration::from_secs(20),
            supervise(
                launch("/bin/sh"),
                members,
                policy,
                "test",
                std::future::pending(),
            ),
        )
        .await;
        assert!(matches!(ended, Ok(Ok(()))), "{ended:?}");
    }

    #[tokio::test]
    async fn a_member_that_cannot_be_started_is_tried_again_and_the_set_goes_on() {
        // It used to end the whole set with the error.
        let policy = Policy {
            restart: Restart::Always,
            backoff: Duration::from_millis(10),
            ..Policy::default()
        };
        let members = vec![member("gone", &[])];
        let (stopped_tx, stopped) = tokio::sync::oneshot::channel::<()>();
        let stop = async move {
            tokio::time::sleep(Duration::from_millis(300)).await;
            let _ = stopped_tx.send(());
        };
        let r = supervise(launch("/nonexistent/rome"), members, policy, "test", stop).await;
        assert!(r.is_ok(), "{r:?}");
        // It kept trying until it was stopped, rather than ending with no
        // member left.
        assert!(stopped.await.is_ok(), "the set ended before it was stopped");
    }

    #[test]
    fn the_backoff_doubles_for_quick_ends_and_starts_again_after_a_settled_run() {
        let p = Policy::default();
        let quick = Duration::from_secs(1);
        let first = p.next_backoff(None, quick);
        assert_eq!(first, Duration::from_millis(500));
        let second = p.next_backoff(Some(first), quick);
        assert_eq!(second, Duration::from_secs(1));
        let mut w = second;
        for _ in 0..10 {
            w = p.next_backoff(Some(w), quick);
        }
        assert_eq!(w, Duration::from_secs(30), "capped");
        assert_eq!(
            p.next_backoff(Some(w), Duration::from_secs(11)),
            Duration::from_millis(500),
            "a settled run starts the doubling again"
        );
    }
}
