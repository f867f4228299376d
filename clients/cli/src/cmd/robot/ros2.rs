//! `rome ros2`: the fleet's robots as ROS 2 topics ([`rome_ros2::bridge`]).
//!
//! ```text
//! rome ros2 --robots r1,r2                 # r1/odom, r1/sonar, r1/ground_truth, r1/camera/up/image, r1/cmd_vel …
//! rome ros2 --robots r1 --namespace fleet  # fleet/r1/odom …
//! rome ros2 --robots r1 --map eb3          # and the floor's map on `map`
//! rome ros2 --robots r1 --rmw-zenoh        # as rmw_zenoh: 0/r1/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_…
//! ```
//!
//! Each key carries a ROS 2 message in CDR, as Zenoh's ROS 2 DDS bridge
//! maps `/r1/odom` on DDS to `r1/odom` on Zenoh (docs/ros2.md).

use rome_common::args::{CommonArgs, Side};
use rome_common::exit;
use std::time::Duration;

/// Flags of `rome ros2`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The robots to bridge (comma-separated or repeated).
    #[arg(long, required = true, value_delimiter = ',', value_name = "ROBOT")]
    robots: Vec<String>,
    /// A ROS namespace before each robot's topics.
    #[arg(long, default_value = "", value_name = "NS")]
    namespace: String,
    /// The bridge's priority at each base, 0 … 255 (§4.3).
    #[arg(long)]
    priority: Option<u8>,
    /// Publish this map as an occupancy grid on `map`: a built-in name
    /// (eb3, annex, campus, fig5_3) or a .stk file.
    #[arg(long, value_name = "MAP")]
    map: Option<String>,
    /// A moving base is stopped when no cmd_vel has come for this long, ms.
    #[arg(long, default_value_t = 500, value_parser = clap::value_parser!(u64).range(50..=10_000))]
    deadman_ms: u64,
    /// Speak rmw_zenoh's keys and liveliness tokens, so ROS 2 nodes on
    /// `rmw_zenoh_cpp` see the topics with no DDS (instead of the keys
    /// Zenoh's ROS 2 DDS bridge maps).
    #[arg(long)]
    rmw_zenoh: bool,
    /// The ROS domain, with --rmw-zenoh.
    #[arg(long, env = "ROS_DOMAIN_ID", default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=232))]
    domain: u32,
}

/// Runs the bridge until Ctrl-C or SIGTERM.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let mut bridge = rome_ros2::bridge::Bridge::new(args.robots);
    bridge.root = common.root()?;
    bridge.namespace = args.namespace;
    bridge.deadman = Duration::from_millis(args.deadman_ms);
    if args.rmw_zenoh {
        bridge.form = rome_ros2::bridge::Form::RmwZenoh {
            domain: args.domain,
        };
    }
    if let Some(p) = args.priority {
        bridge.priority = p;
    }
    if let Some(name) = &args.map {
        let map = rome_maps::load_named(name)?;
        bridge.map = Some(rome_maps::World::from_map(&map));
    }
    let session = common.open(Side::Client).await?;
    let form = match bridge.form {
        rome_ros2::bridge::Form::Dds => "keys for the ROS 2 DDS bridge".to_string(),
        rome_ros2::bridge::Form::RmwZenoh { domain } => format!("as rmw_zenoh, domain {domain}"),
    };
    eprintln!(
        "rome ros2: {} as ROS 2 topics, {form} ({}, {}, {} published; {} read); Ctrl-C to stop",
        bridge.robots.join(", "),
        bridge.key("<robot>", rome_ros2::bridge::ODOM),
        bridge.key("<robot>", rome_ros2::bridge::SONAR),
        bridge.key("<robot>", rome_ros2::bridge::GROUND_TRUTH),
        bridge.key("<robot>", rome_ros2::bridge::CMD_VEL),
    );
    rome_ros2::bridge::run(&session, &bridge, exit::interrupted()).await?;
    let _ = session.close().await;
    Ok(exit::OK)
}
