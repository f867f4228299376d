//! The bridge: each robot's readings published as ROS 2 messages, and its
//! base driven by `cmd_vel`.
//!
//! ```text
//! <ns>/<robot>/odom           nav_msgs/msg/Odometry      from the base's state stream
//! <ns>/<robot>/sonar          sensor_msgs/msg/LaserScan  from each scan of the sonar ring
//! <ns>/<robot>/ground_truth   nav_msgs/msg/Odometry      from the simulator's truth (simulation only)
//! <ns>/<robot>/camera/<name>/image  sensor_msgs/msg/Image  each camera, only while someone subscribes
//! <ns>/<robot>/cmd_vel        geometry_msgs/msg/Twist    read: drives the base
//! <ns>/map                    nav_msgs/msg/OccupancyGrid the map, given one, while someone subscribes
//! ```
//!
//! Each payload is the message's CDR serialization. The key is, in the
//! default form ([`Form::Dds`]), the ROS 2 topic's name without its
//! leading slash, as Zenoh's ROS 2 DDS bridge (`zenoh-plugin-ros2dds`)
//! carries a topic: through it `/r1/odom` on DDS is `r1/odom` here. In the
//! rmw_zenoh form ([`Form::RmwZenoh`]) it is the key ROS 2's own Zenoh
//! middleware uses, with its liveliness tokens ([`crate::topics`]). A
//! `cmd_vel` is a base command at the bridge's priority, under the base's
//! lock rules (§4.3); when none has come for the deadman's time, the base
//! is stopped at once.

use crate::convert::{self, Drive};
use crate::msg::{self, Image, LaserScan, OccupancyGrid, Odometry, Twist};
use crate::rmw_zenoh::Qos;
use crate::throttle::Throttle;
pub use crate::topics::Form;
use crate::topics::{Out, Topics};
use rome_client::{ClientError, RobotClient, RobotOptions};
use rome_schema::robot::BaseState;
use rome_schema::Root;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;
use tokio::task::JoinSet;
use zenoh::Session;

/// The odometry topic's last name.
pub const ODOM: &str = "odom";
/// The sonar scan topic's last name.
pub const SONAR: &str = "sonar";
/// The ground truth topic's last name.
pub const GROUND_TRUTH: &str = "ground_truth";
/// The velocity command topic's last name.
pub const CMD_VEL: &str = "cmd_vel";
/// The map topic's name.
pub const MAP: &str = "map";
/// The map's cells, metres.
pub const MAP_RESOLUTION_M: f64 = 0.1;
/// How often the map is sent again while someone subscribes (a subscriber
/// that comes late gets it within this).
pub const MAP_EVERY: Duration = Duration::from_secs(2);

/// The robot's cameras (§2.5): upward at the ceiling, sideways at the wall.
pub const CAMERAS: [&str; 2] = ["up", "side"];

/// A camera's image topic below the robot.
pub fn camera_topic(camera: &str) -> String {
    format!("camera/{camera}/image")
}

/// What to bridge.
#[derive(Debug, Clone)]
pub struct Bridge {
    /// The robots.
    pub robots: Vec<String>,
    /// The deployment's root prefix (RoME's keys).
    pub root: Root,
    /// A ROS namespace before each robot's topics (empty: none).
    pub namespace: String,
    /// The bridge's priority at the base (§4.3).
    pub priority: u8,
    /// With no `cmd_vel` for this long, a moving base is stopped.
    pub deadman: Duration,
    /// How often a camera with a subscriber is grabbed.
    pub camera_every: Duration,
    /// The floor's map, published as an occupancy grid (`None`: none).
    pub map: Option<rome_maps::World>,
    /// The keys' form: for the DDS bridge, or as rmw_zenoh.
    pub form: Form,
}

impl Bridge {
    /// Bridges `robots` with no namespace, a deadman of 0.5 s and the
    /// client library's default priority.
    pub fn new(robots: Vec<String>) -> Bridge {
        Bridge {
            robots,
            root: Root::default(),
            namespace: String::new(),
            priority: RobotOptions::new("ros2").priority,
            deadman: Duration::from_millis(500),
            camera_every: Duration::from_millis(500),
            map: None,
            form: Form::Dds,
        }
    }

    /// The ROS 2 name of the map's topic, with no leading slash.
    pub fn map_key(&self) -> String {
        crate::topics::in_namespace(&self.namespace, MAP)
    }

    /// The ROS 2 name of `robot`'s `topic`, with no leading slash (in the
    /// DDS form, also its Zenoh key).
    pub fn key(&self, robot: &str, topic: &str) -> String {
        crate::topics::in_namespace(&self.namespace, &format!("{robot}/{topic}"))
    }
}

/// Runs the bridge until `stop` completes; robots it is driving then are
/// stopped (a robot it never drove, or left stopped, is not touched: it
/// may be driven by its own Navigator). Fails only if a robot's client
/// cannot be made; a message that does not decode, or a command the base
/// refuses, is logged and the bridge goes on.
pub async fn run(
    session: &Session,
    bridge: &Bridge,
    stop: impl std::future::Future<Output = ()>,
) -> Result<(), ClientError> {
    let mut tasks = JoinSet::new();
    let mut bases = Vec::new();
    let topics = Topics::new(session, bridge.form, &bridge.namespace).await?;
    if let Some(world) = &bridge.map {
        let grid = msg::encode(&convert::occupancy(world, MAP_RESOLUTION_M));
        let publisher: Out<OccupancyGrid> = topics.publisher(MAP, Qos::MAP).await?;
        tasks.spawn(async move {
            let mut tick = tokio::time::interval(MAP_EVERY);
            loop {
                next_wanted(&mut tick, &publisher).await;
                publisher.send_bytes(grid.clone()).await;
            }
        });
    }
    for robot in &bridge.robots {
        let mut options = RobotOptions::new("ros2");
        options.root = bridge.root.clone();
        options.priority = bridge.priority;
        let base = RobotClient::connect(session, robot, options).await?;
        let states = base.state().await?;
        let scans = base.scans().await?;
        let truth = session
            .declare_subscriber(bridge.root.sim_truth(&rome_schema::Name::new(robot)?))
            .await
            .map_err(ClientError::zenoh)?;
        let commands = topics
            .subscriber::<Twist>(&format!("{robot}/{CMD_VEL}"), Qos::COMMAND)
            .await?;
        let odom: Out<Odometry> = topics
            .publisher(&format!("{robot}/{ODOM}"), Qos::STREAM)
            .await?;
        tasks.spawn(async move {
            let mut before: Option<BaseState> = None;
            while let Some(read) = states.next().await {
                match read {
                    Ok(s) => {
                        odom.send(&convert::odometry(&s, before.as_ref())).await;
                        before = Some(s);
                    }
                    Err(e) => tracing::warn!(error = %e, "base state skipped"),
                }
            }
        });
        let sonar: Out<LaserScan> = topics
            .publisher(&format!("{robot}/{SONAR}"), Qos::STREAM)
            .await?;
        tasks.spawn(async move {
            while let Some(read) = scans.next().await {
                match read {
                    Ok(s) => sonar.send(&convert::sonar(&s)).await,
                    Err(e) => tracing::warn!(error = %e, "sonar scan skipped"),
                }
            }
        });
        let truth_out: Out<Odometry> = topics
            .publisher(&format!("{robot}/{GROUND_TRUTH}"), Qos::STREAM)
            .await?;
        tasks.spawn(async move {
            let mut skipped = Throttle::default();
            while let Ok(sample) = truth.recv_async().await {
                let bytes = sample.payload().to_bytes();
                match serde_json::from_slice::<rome_schema::sim::Truth>(&bytes) {
                    Ok(t) => truth_out.send(&convert::ground_truth(&t)).await,
                    Err(e) => {
                        if let Some(n) = skipped.hit(std::time::Instant::now()) {
                            tracing::warn!(error = %e, times = n, "ground truth skipped");
                        }
                    }
                }
            }
        });
        for camera in CAMERAS {
            let publisher: Out<Image> = topics
                .publisher(&format!("{robot}/{}", camera_topic(camera)), Qos::STREAM)
                .await?;
            let (base, every) = (base.clone(), bridge.camera_every);
            tasks.spawn(async move { images(&base, camera, &publisher, every).await });
        }
        let driving = Arc::new(AtomicBool::new(false));
        let (driver, deadman, d) = (base.clone(), bridge.deadman, driving.clone());
        tasks.spawn(async move {
            // The whole of `commands` moves in: its token announces the
            // subscription for as long as it reads.
            let commands = commands;
            drive(&driver, &commands.subscriber, deadman, &d).await
        });
        bases.push((base, driving));
    }
    stop.await;
    tasks.abort_all();
    for (base, driving) in bases {
        // A robot the bridge left moving would get its deadman from the
        // base server once this client's token goes; stopping it here is
        // sooner.
        if driving.load(Ordering::SeqCst) {
            let _ = base.stop(false).await;
        }
    }
    Ok(())
}

/// Waits for the next tick of `tick` at which `publisher` has a
/// subscriber: what is heavy to make is not made for nobody.
async fn next_wanted<M: msg::Message>(tick: &mut tokio::time::Interval, publisher: &Out<M>) {
    loop {
        tick.tick().await;
        if publisher.wanted().await {
            return;
        }
    }
}

/// Publishes `camera`'s newest image every `every`, while `publisher` has
/// a subscriber: an image is 250 kB, not to be sent to nobody.
async fn images(base: &RobotClient, camera: &str, publisher: &Out<Image>, every: Duration) {
    let mut tick = tokio::time::interval(every);
    let mut last_frame = None;
    loop {
        next_wanted(&mut tick, publisher).await;
        let image = match base.camera_grab(camera).await {
            Ok(i) => i,
            Err(e) => {
                tracing::warn!(camera, error = %e, "camera image not read");
                continue;
            }
        };
        if last_frame == Some(image.frame) {
            continue;
        }
        last_frame = Some(image.frame);
        let frame = format!("{}/camera/{camera}", base.robot());
        publisher.send(&convert::image(&image, frame)).await;
    }
}

/// Drives `base` from the `cmd_vel` samples `commands` brings, stopping it
/// when none has come for `deadman` while it moves; `driving` says
/// whether the base is moving on the bridge's command.
async fn drive(
    base: &RobotClient,
    commands: &zenoh::pubsub::Subscriber<
        zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>,
    >,
    deadman: Duration,
    driving: &AtomicBool,
) {
    let mut last: Option<Drive> = None;
    // A node sending what is no Twist is warned of once every few seconds.
    let mut skipped = Throttle::default();
    loop {
        let sample = match last {
            // Standing still: wait as long as it takes.
            None => commands.recv_async().await.ok(),
            Some(_) => match tokio::time::timeout(deadman, commands.recv_async()).await {
                Ok(s) => s.ok(),
                Err(_) => {
                    // At once: a deadman is for a link or a node that is
                    // gone, and the robot must not coast on for a metre.
                    if let Err(e) = base.stop(true).await {
                        tracing::warn!(error = %e, "deadman: the base could not be stopped");
                        continue;
                    }
                    tracing::info!("deadman: no cmd_vel for {deadman:?}; base stopped");
                    last = None;
                    driving.store(false, Ordering::SeqCst);
                    continue;
                }
            },
        };
        let Some(sample) = sample else { return };
        let twist: Twist = match msg::decode(&sample.payload().to_bytes()) {
            Ok(t) => t,
            Err(e) => {
                if let Some(n) = skipped.hit(std::time::Instant::now()) {
                    tracing::warn!(key = %sample.key_expr(), error = %e, times = n, "cmd_vel skipped");
                }
                continue;
            }
        };
        let Some(want) = convert::drive(&twist) else {
            if let Some(n) = skipped.hit(std::time::Instant::now()) {
                tracing::warn!(
                    ?twist,
                    times = n,
                    "cmd_vel with a value that is not a number skipped"
                );
            }
            continue;
        };
        // The same command again only keeps the deadman away.
        if last == Some(want) {
            continue;
        }
        let done = match want {
            Drive::Go(v) => base.go(v).await,
            Drive::Arc { mm_s, turn_deg_s } => match base.go(mm_s).await {
                Ok(_) => base.jog(turn_deg_s).await,
                Err(e) => Err(e),
            },
        };
        match done {
            Ok(_) => {
                last = Some(want);
                driving.store(true, Ordering::SeqCst);
            }
            Err(e) => tracing::warn!(error = %e, ?want, "cmd_vel not carried out"),
        }
    }
}
