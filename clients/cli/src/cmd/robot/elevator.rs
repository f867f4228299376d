//! `rome elevator NAME <command>`: an elevator server's commands from the
//! shell, the human operator's buttons among them (§5.4.6: "a human
//! operator will help the robot to operate the elevator by pushing the
//! buttons"). Replies print as one JSON line, streams a line a message.

use super::commands::{follow, hold, one_command, print};
use crate::args::CommonArgs;
use crate::exit;
use anyhow::Context;
use rome_client::elevator::ElevatorClient;
use std::time::Duration;

/// Flags of `rome elevator`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The elevator, by its doors' number in the map (acs.elev, old.elevator).
    pub elevator: String,
    /// This client's priority at the server, 0 (lowest) … 255.
    #[arg(long, short = 'p', default_value_t = rome_schema::robot::DEFAULT_PRIORITY)]
    pub priority: u8,
    /// How long a command may wait behind another client's session, seconds.
    #[arg(long, default_value_t = 10.0, value_name = "SECS")]
    pub wait: f64,
    /// The command.
    #[command(subcommand)]
    pub command: ElevatorCmd,
}

/// An elevator command.
#[derive(Debug, clap::Subcommand)]
pub enum ElevatorCmd {
    /// Press a floor's button, as a person in the hall or the car would:
    /// taken whoever holds the session.
    Press {
        /// The floor.
        #[arg(long)]
        floor: String,
    },
    /// Call the car to a floor (it comes and opens there).
    Call {
        /// The floor.
        #[arg(long)]
        floor: String,
    },
    /// Send the car to a floor (it closes, travels and opens there).
    Go {
        /// The floor.
        #[arg(long)]
        floor: String,
    },
    /// Open the doors and hold them open.
    Open,
    /// Close the doors.
    Close,
    /// The car's state: floor, doors, moving, stops, session.
    State,
    /// Follow the state stream (COUNT messages, or until Ctrl-C).
    Watch {
        /// How many messages.
        #[arg(long, short = 'n')]
        count: Option<u64>,
    },
    /// Take the session and hold it (SECS seconds, or until Ctrl-C).
    Session {
        /// How long, seconds.
        #[arg(long, value_name = "SECS")]
        hold: Option<f64>,
    },
}

/// Runs one elevator command.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let (session, options) = one_command(common, args.priority, args.wait).await?;
    let e = ElevatorClient::connect(&session, &args.elevator, options).await?;
    let what = || format!("elevator '{}'", args.elevator);
    match args.command {
        ElevatorCmd::Press { floor } => {
            // A button has no answer: the car's next state shows the stop.
            let states = e.states().await?;
            e.press(&floor).await.with_context(what)?;
            let seen = tokio::time::timeout(Duration::from_secs(5), async {
                while let Some(s) = states.next().await {
                    let s = s?;
                    if s.stops.contains(&floor) || s.floor == floor && !s.moving {
                        return anyhow::Ok(s);
                    }
                }
                anyhow::bail!("the state stream ended")
            })
            .await;
            match seen {
                Ok(Ok(s)) => print(&s)?,
                Ok(Err(err)) => return Err(err.context(what())),
                Err(_) => anyhow::bail!(
                    "{}: pressed {floor}, but no state within 5 s shows it (is `rome elevator-server` running, and is {floor} a floor it serves?)",
                    what()
                ),
            }
        }
        ElevatorCmd::Call { floor } => print(&e.call(&floor).await.with_context(what)?)?,
        ElevatorCmd::Go { floor } => print(&e.go(&floor).await.with_context(what)?)?,
        ElevatorCmd::Open => print(&e.open().await.with_context(what)?)?,
        ElevatorCmd::Close => print(&e.close().await.with_context(what)?)?,
        ElevatorCmd::State => print(&e.state().await.with_context(what)?)?,
        ElevatorCmd::Watch { count } => follow(e.states().await?, count).await?,
        ElevatorCmd::Session { hold: secs } => {
            return hold(e.session().await.with_context(what)?, secs).await
        }
    }
    Ok(exit::OK)
}
