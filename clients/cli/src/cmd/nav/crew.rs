//! `rome crew`: one robot's navigation clients as processes of their own,
//! each started again when it ends (`rome_common::supervise`).
//!
//! ```text
//! rome crew --robot r1                          # navigator, ctracker, mapper, plfinder
//! rome crew --robot r1 --from 350R --tasks      # and a Planner taking the fleet's tasks
//! rome crew --robot r1 --from 350R --to 376L    # and a Planner for one run
//! ```
//!
//! The members reach the network with the crew's own flags (`--connect`,
//! `--mode`, `--root`, `--identity` …), passed to them as the `ROME_…`
//! variables those flags read, and never listen themselves; `-v` makes
//! them as verbose as the crew. A Navigator
//! started again takes up the goal in progress (`GoalActive`).

use rome_common::args::CommonArgs;
use rome_common::exit;
use rome_common::supervise::{supervise, Launch, Member, Policy, Restart};
use std::time::Duration;

/// Flags of `rome crew`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The robot.
    #[arg(long, default_value = "r1")]
    robot: String,
    /// Map for the Planner: a built-in name or a .stk file.
    #[arg(long, default_value = "eb3")]
    map: String,
    /// Also run a Planner, with the robot registered here (a door jamb like 350R).
    #[arg(long, value_name = "POS")]
    from: Option<String>,
    /// The Planner drives from --from to here once.
    #[arg(long, value_name = "POS", requires = "from", conflicts_with = "tasks")]
    to: Option<String>,
    /// The Planner takes the fleet's tasks (`rome dispatcher`).
    #[arg(long, requires = "from")]
    tasks: bool,
    /// Leave the local mapper out.
    #[arg(long)]
    no_mapper: bool,
    /// Leave the door-plate finder out.
    #[arg(long)]
    no_plfinder: bool,
    /// When a member that ended is started again.
    #[arg(long, value_enum, default_value = "on-failure")]
    restart: Restart,
    /// The first wait before a restart, seconds; it doubles while a member
    /// keeps ending within 10 s of its start, up to 30 s.
    #[arg(long, default_value_t = 0.5, value_name = "SECS")]
    backoff: f64,
}

/// The members' arguments; each is as verbose as the crew (`-v`
/// `verbose` times), which it logs into the crew's output.
fn members(args: &Args, verbose: u8) -> Vec<Member> {
    let mut out = roles(args);
    for m in &mut out {
        m.args.extend((0..verbose).map(|_| "-v".to_string()));
    }
    out
}

/// Each member's subcommand and its own flags.
fn roles(args: &Args) -> Vec<Member> {
    let robot = ["--robot".to_string(), args.robot.clone()];
    let mut roles = vec!["navigator", "ctracker"];
    if !args.no_mapper {
        roles.push("mapper");
    }
    if !args.no_plfinder {
        roles.push("plfinder");
    }
    let mut out: Vec<Member> = roles
        .into_iter()
        .map(|role| Member {
            name: role.to_string(),
            args: [vec![role.to_string()], robot.to_vec()].concat(),
        })
        .collect();
    if let Some(from) = &args.from {
        let mut a = vec!["planner".to_string()];
        a.extend(robot.iter().cloned());
        a.extend([
            "--map".into(),
            args.map.clone(),
            "--from".into(),
            from.clone(),
        ]);
        match (&args.to, args.tasks) {
            (Some(to), _) => a.extend(["--to".into(), to.clone()]),
            (None, true) => a.push("--tasks".into()),
            (None, false) => return out,
        }
        out.push(Member {
            name: "planner".into(),
            args: a,
        });
    }
    out
}

/// The crew's network flags for its members, as the variables the same
/// flags read from the environment. Listening stays the crew's own.
fn member_env(common: &CommonArgs) -> Vec<(&'static str, String)> {
    let mut env = vec![
        ("ROME_ROOT", common.root.clone()),
        ("ROME_CONNECT_TIMEOUT", common.connect_timeout.to_string()),
    ];
    if !common.connect.is_empty() {
        env.push(("ROME_CONNECT", common.connect.join(",")));
    }
    if let Some(m) = &common.mode {
        env.push(("ROME_MODE", m.clone()));
    }
    if let Some(c) = &common.config {
        env.push(("ROME_CONFIG", c.display().to_string()));
    }
    if let Some(i) = &common.identity {
        env.push(("ROME_IDENTITY", i.clone()));
    }
    if let Some(s) = &common.secrets {
        env.push(("ROME_SECRETS", s.display().to_string()));
    }
    if common.no_multicast {
        env.push(("ROME_NO_MULTICAST", "true".into()));
    }
    if common.sim_time {
        env.push(("ROME_SIM_TIME", "true".into()));
    }
    env
}

/// Runs `rome crew` until Ctrl-C or SIGTERM, or until every member has
/// ended for good.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    anyhow::ensure!(
        args.backoff.is_finite() && args.backoff > 0.0 && args.backoff <= 30.0,
        "--backoff must be a number of seconds in (0, 30], got {}",
        args.backoff
    );
    let program = std::env::current_exe()
        .map_err(|e| anyhow::anyhow!("cannot find this program to start the crew with: {e}"))?;
    let launch = Launch {
        program,
        env: member_env(common)
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect(),
        // Members are clients of the network: the crew's --listen is not
        // theirs.
        unset: vec!["ROME_LISTEN".into()],
    };
    let policy = Policy {
        restart: args.restart,
        backoff: Duration::from_secs_f64(args.backoff),
        ..Policy::default()
    };
    let say = format!("crew {}", args.robot);
    let members = members(&args, common.verbose);
    supervise(launch, members, policy, &say, exit::interrupted()).await?;
    Ok(exit::OK)
}
