//! The ROS 2 bridge over real Zenoh sessions on loopback: two simulated
//! robots' odometry, sonar and ground truth arrive in CDR on the keys a
//! ROS 2 DDS bridge maps to topics, and a camera's images and the map as
//! an occupancy grid once someone subscribes; a `cmd_vel` to r1 moves r1 by ground
//! truth and leaves r2 where it stands; with no `cmd_vel` for the
//! deadman's time, r1 stops; and the bridge, ending, leaves alone a robot
//! another client drives.
//!
//! In rmw_zenoh's form, the graph an rmw_zenoh node reads lists the
//! bridge's node and topics with ROS 2 Jazzy's type hashes, the data comes
//! on the keys those tokens name with rmw_zenoh's attachment, and a Twist
//! on `cmd_vel`'s key drives the robot.

#![allow(clippy::unwrap_used)]

use rome_client::net::{open_loopback_peer, NetOptions};
use rome_client::sim::TruthClient;
use rome_hardware::robot::Rates;
use rome_ros2::bridge::{self, Bridge};
use rome_ros2::msg::{self, Image, LaserScan, OccupancyGrid, Odometry, Twist, Vector3};
use rome_schema::sim::Truth;
use rome_schema::Root;
use std::time::Duration;
use zenoh::Session;

/// The next message on `sub` that decodes as `M`.
async fn next<M: msg::Message>(
    sub: &zenoh::pubsub::Subscriber<zenoh::handlers::FifoChannelHandler<zenoh::sample::Sample>>,
) -> M {
    let sample = tokio::time::timeout(Duration::from_secs(30), sub.recv_async())
        .await
        .expect("a message within 30 s")
        .unwrap();
    msg::decode(&sample.payload().to_bytes()).unwrap()
}

/// A `cmd_vel` to drive at `m_s` while turning at `rad_s`
/// (counter-clockwise), encoded.
fn twist(m_s: f64, rad_s: f64) -> Vec<u8> {
    msg::encode(&Twist {
        linear: Vector3 {
            x: m_s,
            y: 0.0,
            z: 0.0,
        },
        angular: Vector3 {
            x: 0.0,
            y: 0.0,
            z: rad_s,
        },
    })
}

/// Puts `message` on `publisher` `commands` times, ten a second.
async fn send(publisher: &zenoh::pubsub::Publisher<'_>, message: &[u8], commands: usize) {
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    for _ in 0..commands {
        tick.tick().await;
        publisher.put(message.to_vec()).await.unwrap();
    }
}

/// Ground truth once the simulated clock has reached `ms`.
async fn truth_at(truth: &TruthClient, ms: u64) -> Truth {
    loop {
        let t = truth.get().await.unwrap();
        if t.time_ms >= ms {
            return t;
        }
        // The world steps at real time: the clock is polled, not awaited.
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ros2_messages_come_out_and_cmd_vel_drives_one_robot_with_a_deadman() {
    let (server, port): (Session, u16) = open_loopback_peer(&[]).await.unwrap();
    let root = Root::default();
    let world = rome_tests::world(
        "eb3",
        rome_tests::quiet(),
        &[("r1", "350R"), ("r2", "376L")],
    );
    let _stepper = world.start(Some(1.0));
    let rates = Rates {
        state: Some(Duration::from_millis(50)),
        scan: Some(Duration::from_millis(100)),
        camera: Duration::from_millis(500),
    };
    let mut running = Vec::new();
    for r in ["r1", "r2"] {
        running.extend(
            rome_sim_hardware::robot::spawn_sim_robot(&server, &root, &world, r, rates).unwrap(),
        );
    }
    running.push(rome_sim_hardware::robot::spawn_truth(
        &server,
        &root,
        &world,
        Some(Duration::from_millis(100)),
    ));
    for r in ["r1", "r2"] {
        rome_tests::await_alive(&server, &format!("rome/alive/server/robot/{r}/base"), 1).await;
    }

    let bridge_session = NetOptions::loopback(None, &[port]).open().await.unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let mut bridged = Bridge::new(vec!["r1".into(), "r2".into()]);
    let eb3 = rome_maps::World::from_map(&rome_maps::load_named("eb3").unwrap());
    bridged.map = Some(eb3.clone());
    let b = bridged.clone();
    let bridge_task = tokio::spawn(async move {
        bridge::run(&bridge_session, &b, async {
            let _ = stopped.await;
        })
        .await
    });

    let ros = NetOptions::loopback(None, &[port]).open().await.unwrap();
    let sub = |key: &str| ros.declare_subscriber(key.to_string());
    let odom1 = sub("r1/odom").await.unwrap();
    let odom2 = sub("r2/odom").await.unwrap();
    let sonar1 = sub("r1/sonar").await.unwrap();
    let truth1 = sub("r1/ground_truth").await.unwrap();

    let o: Odometry = next(&odom1).await;
    assert_eq!(o.header.frame_id, "r1/odom");
    assert_eq!(o.child_frame_id, "r1/base_link");
    let o2: Odometry = next(&odom2).await;
    assert_eq!(o2.header.frame_id, "r2/odom");
    let s: LaserScan = next(&sonar1).await;
    assert_eq!(s.ranges.len(), 24);
    assert!(s.ranges.iter().any(|r| r.is_finite()), "{:?}", s.ranges);
    let g: Odometry = next(&truth1).await;
    assert_eq!(g.header.frame_id, "map");
    // A camera's images flow once someone subscribes.
    let up = sub("r1/camera/up/image").await.unwrap();
    let i: Image = next(&up).await;
    let (w, h) = rome_schema::robot::body::IMAGE_SIZE;
    assert_eq!((i.width, i.height, i.step), (w, h, w));
    assert_eq!(i.encoding, "mono8");
    assert_eq!(i.data.len(), (w * h) as usize);
    assert_eq!(i.header.frame_id, "r1/camera/up");
    drop(up);
    // The map: a wall's cell occupied, the cell r1 stands on free.
    let map = sub("map").await.unwrap();
    let grid: OccupancyGrid = next(&map).await;
    let info = &grid.info;
    assert_eq!(grid.data.len(), (info.width * info.height) as usize);
    let cell = |x_mm: f64, y_mm: f64| {
        let res = f64::from(info.resolution);
        let i = ((x_mm / 1_000.0 - info.origin.position.x) / res) as usize;
        let j = ((y_mm / 1_000.0 - info.origin.position.y) / res) as usize;
        grid.data[j * info.width as usize + i]
    };
    let wall = eb3
        .segments
        .iter()
        .find(|s| s.kind == rome_maps::model::EdgeKind::Wall)
        .unwrap();
    let mid = wall.a + (wall.b - wall.a) * 0.5;
    assert_eq!(cell(mid.x, mid.y), 100, "a wall at {mid:?}");
    let at = TruthClient::new(&ros, &root, "r1")
        .unwrap()
        .get()
        .await
        .unwrap();
    assert_eq!(
        cell(at.x_mm, at.y_mm),
        0,
        "r1 at ({}, {})",
        at.x_mm,
        at.y_mm
    );
    drop(map);

    // Drive r1 at 0.3 m/s for two seconds, ten commands a second.
    let t1 = TruthClient::new(&ros, &root, "r1").unwrap();
    let t2 = TruthClient::new(&ros, &root, "r2").unwrap();
    let (start1, start2) = (t1.get().await.unwrap(), t2.get().await.unwrap());
    let ahead = twist(0.3, 0.0);
    let publisher = ros.declare_publisher("r1/cmd_vel").await.unwrap();
    // A message that is not a Twist is skipped; the bridge goes on.
    publisher.put(vec![1u8, 2, 3]).await.unwrap();
    send(&publisher, &ahead, 20).await;
    let last = t1.get().await.unwrap().time_ms;
    let moved = t1.get().await.unwrap().travelled_mm - start1.travelled_mm;
    assert!(moved > 300.0, "r1 drove {moved:.0} mm on cmd_vel");
    // The odometry says so too.
    let mut o = next::<Odometry>(&odom1).await;
    while o.twist.twist.linear.x < 0.1 {
        o = next(&odom1).await;
    }

    // No more commands: stopped within a second of the last, by ground
    // truth (nothing more driven between 1 s and 2.5 s after it).
    let a = truth_at(&t1, last + 1_000).await.travelled_mm;
    let b = truth_at(&t1, last + 2_500).await.travelled_mm;
    assert!(
        b - a < 5.0,
        "r1 still drove {:.0} mm after its deadman",
        b - a
    );
    let still = t2.get().await.unwrap().travelled_mm - start2.travelled_mm;
    assert!(still < 1.0, "r2 drove {still:.1} mm on r1's cmd_vel");

    // A twist that drives and turns drives an arc; one with no speed turns
    // in place, though the robot was driving the moment before. A heading
    // grows counter-clockwise, as a ROS yaw does.
    let turned =
        |a: &Truth, b: &Truth| rome_maps::geometry::normalize_deg(b.heading_deg - a.heading_deg);
    let a = t1.get().await.unwrap();
    send(&publisher, &twist(0.3, 0.3), 15).await;
    let b = t1.get().await.unwrap();
    assert!(
        b.travelled_mm - a.travelled_mm > 150.0,
        "the arc drove {:.0} mm",
        b.travelled_mm - a.travelled_mm
    );
    assert!(
        turned(&a, &b) > 8.0,
        "the arc turned {:.1}°",
        turned(&a, &b)
    );
    // A second to come to rest from the arc's speed, then one in place.
    send(&publisher, &twist(0.0, 0.5), 10).await;
    let c = t1.get().await.unwrap();
    send(&publisher, &twist(0.0, 0.5), 10).await;
    let d = t1.get().await.unwrap();
    assert!(
        d.travelled_mm - c.travelled_mm < 20.0,
        "a turn in place drove {:.0} mm",
        d.travelled_mm - c.travelled_mm
    );
    assert!(
        turned(&c, &d) > 15.0,
        "the turn in place turned {:.1}°",
        turned(&c, &d)
    );

    // Another client drives r2; the bridge ends and leaves r2 going, as
    // it never drove r2 itself.
    let mut options = rome_client::RobotOptions::new("other");
    options.deadman = false;
    let other = rome_client::RobotClient::connect(&ros, "r2", options)
        .await
        .unwrap();
    other.go(200.0).await.unwrap();
    let _ = stop.send(());
    bridge_task.await.unwrap().unwrap();
    let ended = t2.get().await.unwrap();
    let later = truth_at(&t2, ended.time_ms + 1_000).await;
    assert!(
        later.travelled_mm - ended.travelled_mm > 100.0,
        "r2, driven by another client, was stopped when the bridge ended"
    );
    other.stop(true).await.unwrap();
    drop(running);
}

/// A token's chunks as rmw_zenoh's graph reads them: kind, topic (`%` back
/// to `/`), type and hash, for a publisher or subscription.
fn entity(token: &str) -> Option<(String, String, String, String)> {
    let parts: Vec<&str> = token.split('/').collect();
    if parts.len() != 13 || parts[0] != "@ros2_lv" {
        return None;
    }
    Some((
        parts[5].to_string(),
        parts[9].replace('%', "/"),
        parts[10].to_string(),
        parts[11].to_string(),
    ))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn as_rmw_zenoh_the_graph_lists_the_topics_and_cmd_vel_drives() {
    let (server, port): (Session, u16) = open_loopback_peer(&[]).await.unwrap();
    let root = Root::default();
    let world = rome_tests::world("eb3", rome_tests::quiet(), &[("r1", "350R")]);
    let _stepper = world.start(Some(1.0));
    let rates = Rates {
        state: Some(Duration::from_millis(50)),
        scan: Some(Duration::from_millis(100)),
        camera: Duration::from_millis(500),
    };
    let mut running =
        rome_sim_hardware::robot::spawn_sim_robot(&server, &root, &world, "r1", rates).unwrap();
    running.push(rome_sim_hardware::robot::spawn_truth(
        &server,
        &root,
        &world,
        Some(Duration::from_millis(100)),
    ));
    rome_tests::await_alive(&server, "rome/alive/server/robot/r1/base", 1).await;

    let bridge_session = NetOptions::loopback(None, &[port]).open().await.unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let mut bridged = Bridge::new(vec!["r1".into()]);
    bridged.form = bridge::Form::RmwZenoh { domain: 17 };
    let bridge_task = tokio::spawn(async move {
        bridge::run(&bridge_session, &bridged, async {
            let _ = stopped.await;
        })
        .await
    });

    // What an rmw_zenoh node's graph cache hears: the domain's tokens.
    let ros = NetOptions::loopback(None, &[port]).open().await.unwrap();
    let graph = ros
        .liveliness()
        .declare_subscriber("@ros2_lv/17/**")
        .history(true)
        .await
        .unwrap();
    let (mut node, mut odom, mut cmd_vel) = (None, None, None);
    while node.is_none() || odom.is_none() || cmd_vel.is_none() {
        let sample = tokio::time::timeout(Duration::from_secs(30), graph.recv_async())
            .await
            .expect("the bridge's tokens within 30 s")
            .unwrap();
        let token = sample.key_expr().to_string();
        if token.ends_with("/NN/%/%/rome_ros2") {
            node = Some(token);
        } else if let Some((kind, topic, ty, hash)) = entity(&token) {
            match (kind.as_str(), topic.as_str()) {
                ("MP", "/r1/odom") => odom = Some((ty, hash)),
                ("MS", "/r1/cmd_vel") => cmd_vel = Some((ty, hash)),
                _ => {}
            }
        }
    }
    // The types and hashes are ROS 2 Jazzy's own.
    let (odom_type, odom_hash) = odom.unwrap();
    assert_eq!(odom_type, "nav_msgs::msg::dds_::Odometry_");
    assert_eq!(
        odom_hash,
        "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0"
    );
    let (twist_type, twist_hash) = cmd_vel.unwrap();
    assert_eq!(twist_type, "geometry_msgs::msg::dds_::Twist_");
    assert_eq!(
        twist_hash,
        "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a"
    );

    // The data, on the key built from the token, with rmw_zenoh's
    // attachment: sequence numbers that rise, one publisher's GID.
    let odom1 = ros
        .declare_subscriber(format!("17/r1/odom/{odom_type}/{odom_hash}"))
        .await
        .unwrap();
    let mut seen = Vec::new();
    for _ in 0..2 {
        let sample = tokio::time::timeout(Duration::from_secs(30), odom1.recv_async())
            .await
            .expect("odometry within 30 s")
            .unwrap();
        let o: Odometry = msg::decode(&sample.payload().to_bytes()).unwrap();
        assert_eq!(o.header.frame_id, "r1/odom");
        let a = sample
            .attachment()
            .expect("an attachment")
            .to_bytes()
            .to_vec();
        assert_eq!(a.len(), 33, "{a:?}");
        assert_eq!(a[16], 16, "the GID's length");
        seen.push((
            i64::from_le_bytes(a[..8].try_into().unwrap()),
            a[17..].to_vec(),
        ));
    }
    assert!(seen[1].0 > seen[0].0, "sequence numbers {seen:?}");
    assert_eq!(seen[0].1, seen[1].1);

    // A Twist on cmd_vel's key drives r1.
    let t1 = TruthClient::new(&ros, &root, "r1").unwrap();
    let start = t1.get().await.unwrap();
    let ahead = twist(0.3, 0.0);
    let publisher = ros
        .declare_publisher(format!("17/r1/cmd_vel/{twist_type}/{twist_hash}"))
        .await
        .unwrap();
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    for _ in 0..15 {
        tick.tick().await;
        publisher.put(ahead.clone()).await.unwrap();
    }
    let moved = t1.get().await.unwrap().travelled_mm - start.travelled_mm;
    assert!(moved > 200.0, "r1 drove {moved:.0} mm on cmd_vel");

    // Ending, the bridge's tokens go: the graph hears the node leave.
    let _ = stop.send(());
    bridge_task.await.unwrap().unwrap();
    loop {
        let sample = tokio::time::timeout(Duration::from_secs(30), graph.recv_async())
            .await
            .expect("the node's token withdrawn within 30 s")
            .unwrap();
        if sample.kind() == zenoh::sample::SampleKind::Delete
            && sample.key_expr().as_str().ends_with("/NN/%/%/rome_ros2")
        {
            break;
        }
    }
    drop(running);
}
