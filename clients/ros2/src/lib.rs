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
//! - [`throttle`]: warnings about bad input said once a while, counted.
//! - [`topics`]: where each topic goes on Zenoh, in the DDS bridge's form
//!   or in rmw_zenoh's.
//! - [`dds_plugin`]: the liveliness tokens by which Zenoh's ROS 2 DDS
//!   plugin learns of the bridge's topics.
//! - [`rmw_zenoh`]: the keys, liveliness tokens, type hashes and
//!   attachments of ROS 2's own Zenoh middleware, so the bridge can speak
//!   to rmw_zenoh nodes with no DDS between.

pub mod bridge;
pub mod convert;
pub mod dds_plugin;
pub mod msg;
pub mod rmw_zenoh;
pub mod throttle;
pub mod topics;
