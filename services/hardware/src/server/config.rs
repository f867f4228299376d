//! Where and how a hardware server runs, and why one could not.

use rome_schema::robot::{robot_name, Device};
use rome_schema::{Name, Root};

/// Where and how a hardware server runs.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// The deployment's root prefix.
    pub root: Root,
    /// The robot's name (one key chunk).
    pub robot: Name,
    /// Which of its devices this server owns.
    pub device: Device,
}

impl ServerConfig {
    /// A server of `device` on robot `robot` under `root`.
    pub fn new(root: &Root, robot: &str, device: Device) -> Result<Self, ServerError> {
        let robot = robot_name(robot).map_err(|e| ServerError::Config(e.to_string()))?;
        Ok(ServerConfig {
            root: root.clone(),
            robot,
            device,
        })
    }

    /// `robot r1 base`, `robot r1 camera up`: for logs and errors.
    pub fn label(&self) -> String {
        format!(
            "robot {} {}",
            self.robot,
            self.device.path().replace('/', " ")
        )
    }

    /// The server's liveliness token: `<root>/alive/server/robot/<robot>/<device>`.
    pub fn alive_key(&self) -> String {
        format!(
            "{}/alive/server/robot/{}/{}",
            self.root.as_str(),
            self.robot,
            self.device.path()
        )
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
