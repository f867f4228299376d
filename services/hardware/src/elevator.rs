//! The elevator server: one elevator's car as a device with a server of
//! its own, under `<root>/building/elevator/<name>/…` (§5.4.6; messages
//! in [`rome_schema::elevator`]).
//!
//! It is a hardware server like the base's: the same queue, priorities,
//! fenced lock (here called the session: one client rides at a time, and
//! a client that dies frees it through liveliness), the same state stream.
//! Its buttons are not commands: presses are puts on `…/press`, taken by
//! the car whoever holds the session, as a button wired to the car is.

use crate::device::{device_error, DeviceError};
use crate::robot::{spawn, Running};
use crate::server::{declare_err, no_payload, Body, Place, ServerConfig, ServerError, Service};
use rome_schema::elevator::{
    Call, Close, ElevatorDone, ElevatorState, GoTo, Open, Press, ReadState, COMMANDS, PRESS,
};
use rome_schema::robot::command::{parse_payload, Command};
use rome_schema::robot::LockInfo;
use rome_schema::{ErrorCode, ErrorReply, Params};
use std::future::Future;
use std::time::Duration;
use zenoh::Session;

/// What the server asks of the car.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CarOp {
    /// Nothing: the state.
    Status,
    /// Stop at this floor (a call, a car's or a hall's button).
    StopAt(String),
    /// Open the doors and hold them.
    Open,
    /// Close the doors.
    Close,
    /// Let held doors go: their holder is gone.
    Release,
}

/// An elevator's car and its controller, as the server drives it.
pub trait ElevatorDevice: Clone + Send + Sync + 'static {
    /// Carries out `op` and returns the car's state afterwards (its
    /// `lock` left empty: the server knows the session).
    fn command(&self, op: CarOp)
        -> impl Future<Output = Result<ElevatorState, DeviceError>> + Send;
}

/// A parsed elevator command.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ElevatorCmd {
    /// `call` or `go`.
    Stop(&'static str, String),
    /// `open`.
    Open,
    /// `close`.
    Close,
    /// `state`.
    State,
}

/// The elevator server's state: its car, and whether a session held the
/// doors when it was last seen.
pub struct Elevator<D: ElevatorDevice> {
    name: String,
    device: D,
    state_period: Option<Duration>,
    session: Option<LockInfo>,
}

impl<D: ElevatorDevice> Elevator<D> {
    /// A server for `device`, publishing its state every `state_period`.
    pub fn new(name: &str, device: D, state_period: Option<Duration>) -> Self {
        Elevator {
            name: name.to_string(),
            device,
            state_period,
            session: None,
        }
    }

    async fn state(&self, op: CarOp, lock: Option<LockInfo>) -> Result<ElevatorState, ErrorReply> {
        let mut s = self.device.command(op).await.map_err(device_error)?;
        s.elevator.clone_from(&self.name);
        s.lock = lock;
        Ok(s)
    }
}

impl<D: ElevatorDevice> Service for Elevator<D> {
    type Cmd = ElevatorCmd;

    const COMMANDS: &'static [&'static str] = COMMANDS;
    const LOCKABLE: bool = true;
    const READS: &'static [&'static str] = &[ReadState::NAME];

    fn parse(
        &self,
        command: &str,
        params: Params,
        body: Option<&[u8]>,
    ) -> Result<ElevatorCmd, ErrorReply> {
        params.finish(command, &["priority", "fence", "wait_ms", "client", "op"])?;
        let none = |cmd: ElevatorCmd| no_payload(command, body).map(|()| cmd);
        match command {
            Call::NAME => Ok(ElevatorCmd::Stop(
                Call::NAME,
                parse_payload::<Call>(body)?.floor,
            )),
            GoTo::NAME => Ok(ElevatorCmd::Stop(
                GoTo::NAME,
                parse_payload::<GoTo>(body)?.floor,
            )),
            Open::NAME => none(ElevatorCmd::Open),
            Close::NAME => none(ElevatorCmd::Close),
            ReadState::NAME => none(ElevatorCmd::State),
            other => Err(ErrorReply::new(
                ErrorCode::UnknownKey,
                format!(
                    "the elevator has no command '{other}' (it has {}, lock, unlock; a button is a put on '{PRESS}')",
                    COMMANDS.join(", ")
                ),
            )),
        }
    }

    async fn apply(
        &mut self,
        cmd: ElevatorCmd,
        lock: Option<LockInfo>,
    ) -> Result<Body, ErrorReply> {
        let (name, op) = match cmd {
            ElevatorCmd::State => return Ok(Body::json(&self.state(CarOp::Status, lock).await?)),
            ElevatorCmd::Stop(name, floor) => (name, CarOp::StopAt(floor)),
            ElevatorCmd::Open => (Open::NAME, CarOp::Open),
            ElevatorCmd::Close => (Close::NAME, CarOp::Close),
        };
        let state = self.state(op, lock).await?;
        Ok(Body::json(&ElevatorDone {
            command: name.into(),
            state,
        }))
    }

    fn period(&self) -> Option<Duration> {
        self.state_period
    }

    async fn tick(
        &mut self,
        lock: Option<LockInfo>,
        _queued: usize,
    ) -> Option<(&'static str, Body)> {
        // A session that ended (given back, or its holder gone) lets go
        // of the doors it held, so the car serves the next rider.
        let ended = self.session.is_some() && self.session != lock;
        self.session.clone_from(&lock);
        let op = if ended { CarOp::Release } else { CarOp::Status };
        match self.state(op, lock).await {
            Ok(s) => Some((ReadState::NAME, Body::json(&s))),
            Err(e) => {
                tracing::warn!(elevator = %self.name, error = %e.message, "elevator state not read");
                None
            }
        }
    }
}

/// Starts the server of elevator `config` names on `device`, with its
/// buttons: a subscriber on `…/press` that hands each press to the car.
/// Dropping the subscriber stops the buttons.
pub async fn spawn_elevator<D: ElevatorDevice>(
    session: &Session,
    config: ServerConfig,
    device: D,
    state_period: Option<Duration>,
) -> Result<(Running, zenoh::pubsub::Subscriber<()>), ServerError> {
    let Place::Elevator(name) = &config.place else {
        return Err(ServerError::Config(format!(
            "{} is not an elevator",
            config.label()
        )));
    };
    let name = name.to_string();
    // The callback runs on Zenoh's threads: it only queues the press.
    let (tx, mut presses) = tokio::sync::mpsc::channel::<Press>(64);
    let buttons = session
        .declare_subscriber(config.key(PRESS))
        .callback(move |sample| {
            let press = rome_schema::decode::<Press>(&sample.payload().to_bytes(), PRESS)
                .map_err(|e| e.to_string())
                .and_then(|p| p.check().map(|()| p).map_err(|e| e.message));
            match press {
                Ok(p) => {
                    if tx.try_send(p).is_err() {
                        tracing::warn!("a button press was dropped: 64 are waiting");
                    }
                }
                Err(e) => tracing::warn!(error = %e, "a button press that is not one was ignored"),
            }
        })
        .await
        .map_err(|e| declare_err("the button subscriber", e))?;
    let car = device.clone();
    tokio::spawn(async move {
        while let Some(p) = presses.recv().await {
            if let Err(e) = car.command(CarOp::StopAt(p.floor.clone())).await {
                tracing::warn!(floor = %p.floor, error = %e, "a button press was not taken");
            }
        }
    });
    let running = spawn(session, config, Elevator::new(&name, device, state_period));
    Ok((running, buttons))
}
