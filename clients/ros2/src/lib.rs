//! RoME's robots as ROS 2 topics.
//!
//! How this crate is laid out:
//! - [`msg`]: the ROS 2 messages the bridge speaks (`nav_msgs/Odometry`,
//!   `sensor_msgs/LaserScan`, `sensor_msgs/Image`, `geometry_msgs/Twist`
//!   …) and their CDR wire form.
//! - [`convert`]: RoME's base state, sonar scans and ground truth as those
//!   messages, and a `cmd_vel` as a base command.
//! - [`bridge`]: per robot, those messages published on the Zenoh keys a
//!   ROS 2 DDS bridge maps to topics (`r1/odom` is `/r1/odom`), and the
//!   base driven from `r1/cmd_vel`, with a deadman.

pub mod bridge;
pub mod convert;
pub mod msg;
