//! Typed async client library for RoME servers: the thesis' per-server
//! function libraries (Fig. 4.8) on top of Zenoh.
//!
//! How this crate is laid out:
//! - `call`: one query to a server (selector, band, lock-step stamp,
//!   answer, refusal or silence), under both libraries' retry rules.
//! - [`net`]: the one place network options become a `zenoh::Config`
//!   (mode, connect, listen, multicast scouting, config file).
//! - [`data`]: [`DataClient`], the data-server library of §4.6.1
//!   (`DataSetValue`, `DataGetValue`, `DataSetHistory`, `DataCreateSemaphore`,
//!   `DataSignal`, `DataWait` …) as typed async methods.
//! - [`robot`]: [`RobotClient`], the hardware servers' libraries (base,
//!   proximity, cameras: `RobotMove`, `ProxReadSonar`, `CameraGrabRow` …).
//! - [`elevator`]: [`elevator::ElevatorClient`], an elevator server's
//!   library (call, go, open, close, the session, the buttons).
//! - [`sim`]: [`sim::TruthClient`], a simulated robot's ground truth (for
//!   judging runs, never for navigation).
//! - [`simtime`]: following the simulator's clock from another process
//!   (`use_sim_time`), in lock-step with it or not.
//! - [`load`]: how many requests this process sent the data server, and
//!   how long their replies took.
//! - [`alive`]: who is alive (servers and clients), from liveliness tokens.
//! - [`relay`]: a TCP relay standing for a wireless link (delay, pause,
//!   cut), for tests and `rome soak`.
//! - [`error`]: [`ClientError`], what every call can fail with.
//!
//! ```no_run
//! # async fn demo() -> Result<(), rome_client::ClientError> {
//! use rome_client::{net::NetOptions, DataClient, DataOptions};
//! let session = NetOptions::default().open().await?;
//! let ds = DataClient::connect(&session, DataOptions::new("planner")).await?;
//! ds.create_semaphore("$GoalData", 0).await?;
//! ds.set("GoalType", &"L").await?;
//! ds.set("GoalDistance", &3).await?;
//! ds.signal("$GoalData").await?;
//! let previous = ds.get_back("GoalDistance", 1).await; // the thesis' -1
//! # Ok(()) }
//! ```

pub mod alive;
mod call;
pub mod data;
pub mod elevator;
pub mod error;
mod inflight;
pub mod load;
pub mod net;
pub mod relay;
pub mod robot;
pub mod sim;
pub mod simtime;

pub use data::{DataClient, DataOptions, Watch};
pub use error::ClientError;
pub use robot::{RobotClient, RobotOptions};
