//! The ROS 2 bridge over real Zenoh sessions on loopback: two simulated
//! robots' odometry, sonar and ground truth arrive in CDR on the keys a
//! ROS 2 DDS bridge maps to topics, and a camera's images and the map as
//! an occupancy grid once someone subscribes; a `cmd_vel` to r1 moves r1 by ground
//! truth and leaves r2 where it stands; with no `cmd_vel` for the
//! deadman's time, r1 stops; and the bridge, ending, leaves alone a robot
//! another client drives.

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
    let ahead = msg::encode(&Twist {
        linear: Vector3 {
            x: 0.3,
            y: 0.0,
            z: 0.0,
        },
        angular: Vector3::default(),
    });
    let publisher = ros.declare_publisher("r1/cmd_vel").await.unwrap();
    // A message that is not a Twist is skipped; the bridge goes on.
    publisher.put(vec![1u8, 2, 3]).await.unwrap();
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    for _ in 0..20 {
        tick.tick().await;
        publisher.put(ahead.clone()).await.unwrap();
    }
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
