//! A client of an elevator server (`<root>/building/elevator/<name>/…`):
//! the same call layer, retries, session (lock) and streams as a robot's
//! servers, since an elevator is served as a device is.

use crate::robot::{Lock, RobotClient, RobotOptions, Stream};
use crate::ClientError;
use rome_schema::elevator::{
    Call, Close, ElevatorDone, ElevatorState, GoTo, Open, Press, ReadState, PRESS,
};
use rome_schema::robot::command::Command;
use rome_schema::robot::Device;
use rome_schema::Name;
use zenoh::Session;

/// A client of one elevator. Cheap to clone.
#[derive(Clone)]
pub struct ElevatorClient {
    inner: RobotClient,
    session: Session,
    press_key: String,
}

/// The slot the elevator's one device takes in the robot client's books.
const CAR: Device = Device::Base;

impl ElevatorClient {
    /// A client of elevator `name`; declares this client alive, which
    /// ties its session to its life.
    pub async fn connect(
        session: &Session,
        name: &str,
        options: RobotOptions,
    ) -> Result<Self, ClientError> {
        let name = Name::new(name)?;
        let press_key = options.root.elevator(&name, PRESS);
        let inner = RobotClient::connect_to(session, name, true, options).await?;
        Ok(ElevatorClient {
            inner,
            session: session.clone(),
            press_key,
        })
    }

    /// A client of elevator `name` on the session and with the options of
    /// `robot`'s client: the client of the robot that rides it.
    pub async fn beside(robot: &RobotClient, name: &str) -> Result<Self, ClientError> {
        let (session, options) = robot.parts();
        Self::connect(session, name, options.clone()).await
    }

    /// `call`: the car is wanted at `floor`; it comes and opens there.
    pub async fn call(&self, floor: &str) -> Result<ElevatorDone, ClientError> {
        let c = Call {
            floor: floor.into(),
        };
        self.inner.json(&CAR, &c, true).await
    }

    /// `go`: the car closes, travels to `floor` and opens there.
    pub async fn go(&self, floor: &str) -> Result<ElevatorDone, ClientError> {
        let g = GoTo {
            floor: floor.into(),
        };
        self.inner.json(&CAR, &g, true).await
    }

    /// `open`: opens the doors and holds them open.
    pub async fn open(&self) -> Result<ElevatorDone, ClientError> {
        self.inner.json(&CAR, &Open, true).await
    }

    /// `close`: closes the doors.
    pub async fn close(&self) -> Result<ElevatorDone, ClientError> {
        self.inner.json(&CAR, &Close, true).await
    }

    /// `state`: the car now.
    pub async fn state(&self) -> Result<ElevatorState, ClientError> {
        self.inner.json(&CAR, &ReadState, true).await
    }

    /// Takes the session: until it is given back (or this client dies),
    /// the others' commands wait.
    pub async fn session(&self) -> Result<Lock, ClientError> {
        self.inner.lock_device(CAR).await
    }

    /// Subscribes to the state stream.
    pub async fn states(&self) -> Result<Stream<ElevatorState>, ClientError> {
        self.inner.stream(&CAR, ReadState::NAME).await
    }

    /// Presses the button of `floor`, as a person would: a put, taken by
    /// the car whoever holds the session.
    pub async fn press(&self, floor: &str) -> Result<(), ClientError> {
        let p = Press {
            floor: floor.into(),
        };
        p.check()?;
        self.session
            .put(&self.press_key, rome_schema::encode(&p))
            .encoding(zenoh::bytes::Encoding::APPLICATION_JSON)
            .await
            .map_err(ClientError::zenoh)
    }
}
