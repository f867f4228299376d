//! Where and how a hardware server runs, and why one could not.

use rome_schema::robot::{robot_name, Device};
use rome_schema::{Name, Root};

/// Which device a server owns: one of a robot's, or a building's
/// elevator. It decides every key the server uses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Place {
    /// A robot's base, proximity subsystem or camera:
    /// `<root>/robot/<robot>/<device>/…`.
    Robot {
        /// The robot's name (one key chunk).
        robot: Name,
        /// Which of its devices.
        device: Device,
    },
    /// A building's elevator: `<root>/building/elevator/<name>/…`.
    Elevator(Name),
}

impl Place {
    /// The key path below the root: `robot/r1/base`,
    /// `building/elevator/acs.elev`.
    pub fn path(&self) -> String {
        match self {
            Place::Robot { robot, device } => format!("robot/{robot}/{}", device.path()),
            Place::Elevator(name) => format!("building/elevator/{name}"),
        }
    }
}

/// Where and how a hardware server runs.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// The deployment's root prefix.
    pub root: Root,
    /// The device it owns.
    pub place: Place,
}

impl ServerConfig {
    /// A server of `device` on robot `robot` under `root`.
    pub fn new(root: &Root, robot: &str, device: Device) -> Result<Self, ServerError> {
        let robot = robot_name(robot).map_err(|e| ServerError::Config(e.to_string()))?;
        Ok(ServerConfig {
            root: root.clone(),
            place: Place::Robot { robot, device },
        })
    }

    /// The server of elevator `name` under `root`.
    pub fn elevator(root: &Root, name: &str) -> Result<Self, ServerError> {
        let name = Name::new(name)
            .map_err(|e| ServerError::Config(format!("elevator name '{name}': {e}")))?;
        Ok(ServerConfig {
            root: root.clone(),
            place: Place::Elevator(name),
        })
    }

    /// `robot r1 base`, `robot r1 camera up`, `elevator acs.elev`: for
    /// logs and errors.
    pub fn label(&self) -> String {
        match &self.place {
            Place::Robot { robot, device } => {
                format!("robot {robot} {}", device.path().replace('/', " "))
            }
            Place::Elevator(name) => format!("elevator {name}"),
        }
    }

    /// `<root>/<place>/<chunk>`: a command's or a stream's key.
    pub fn key(&self, chunk: &str) -> String {
        format!("{}/{}/{chunk}", self.root.as_str(), self.place.path())
    }

    /// `<root>/store/<place>/lock`: where the lock state is kept (a Zenoh
    /// storage on `<root>/store/**` holds it).
    pub fn lock_store(&self) -> String {
        format!("{}/store/{}/lock", self.root.as_str(), self.place.path())
    }

    /// The server's liveliness token: `<root>/alive/server/<place>`.
    pub fn alive_key(&self) -> String {
        format!("{}/alive/server/{}", self.root.as_str(), self.place.path())
    }
}

/// A hardware server could not start or failed.
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    /// A Zenoh declaration failed.
    #[error(transparent)]
    Declare(#[from] rome_serve::Undeclared),
    /// Another server already owns this device.
    #[error("{label} is already served (liveliness token '{key}'): each device has one server")]
    AlreadyServed {
        /// Which device.
        label: String,
        /// The token seen.
        key: String,
    },
    /// The configuration is not valid.
    #[error("{0}")]
    Config(String),
}

/// A declaration on Zenoh (`what`) failed.
pub fn declare_err(what: &str, e: zenoh::Error) -> ServerError {
    ServerError::Declare(rome_serve::Undeclared::new(what, e))
}
