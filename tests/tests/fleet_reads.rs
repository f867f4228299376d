//! Fleet-wide reads: a wildcard key asks every robot's read-only commands
//! at once, from a plain Zenoh session (as `z_get`, Python or curl would);
//! a wildcard key on a command that acts gets an error reply, never
//! silence, and acts on nothing.

#![allow(clippy::unwrap_used)]

use rome_client::net::{open_loopback_peer, NetOptions};
use rome_client::{RobotClient, RobotOptions};
use rome_hardware::robot::{Rates, Running};
use rome_schema::robot::{BaseState, PoseReply, SonarReply, WheelSpeedReply};
use rome_schema::{decode, ErrorCode, ErrorReply, Root};
use rome_sim_hardware::robot::spawn_sim_robot;
use rome_sim_hardware::world::Stepper;
use std::collections::BTreeMap;
use std::time::Duration;
use zenoh::query::ConsolidationMode;
use zenoh::Session;

const ROBOTS: [(&str, &str); 3] = [("r1", "350R"), ("r2", "376L"), ("r3", "341L")];

struct Fleet {
    port: u16,
    _session: Session,
    _servers: Vec<Running>,
    _stepper: Stepper,
}

async fn fleet() -> Fleet {
    let (session, port) = open_loopback_peer(&[]).await.unwrap();
    let world = rome_tests::world("eb3", rome_tests::quiet(), &ROBOTS);
    let stepper = world.start(Some(1.0));
    let rates = Rates {
        state: Some(Duration::from_millis(50)),
        scan: Some(Duration::from_millis(50)),
        camera: Duration::from_millis(500),
    };
    let mut servers = Vec::new();
    for (robot, _) in ROBOTS {
        servers.extend(spawn_sim_robot(&session, &Root::default(), &world, robot, rates).unwrap());
    }
    rome_tests::await_alive(&session, "rome/alive/server/robot/**", servers.len()).await;
    Fleet {
        port,
        _session: session,
        _servers: servers,
        _stepper: stepper,
    }
}

/// What a plain session's get on `selector` brings back: replies by key,
/// and error replies.
async fn sweep(
    s: &Session,
    selector: &str,
    payload: Option<&str>,
) -> (BTreeMap<String, Vec<u8>>, Vec<ErrorReply>) {
    let mut get = s
        .get(selector)
        .consolidation(ConsolidationMode::None)
        .timeout(Duration::from_secs(5));
    if let Some(p) = payload {
        get = get.payload(p);
    }
    let replies = get.await.unwrap();
    let (mut ok, mut err) = (BTreeMap::new(), Vec::new());
    while let Ok(reply) = replies.recv_async().await {
        match reply.result() {
            Ok(sample) => {
                let old = ok.insert(
                    sample.key_expr().to_string(),
                    sample.payload().to_bytes().into_owned(),
                );
                assert!(old.is_none(), "two replies on {}", sample.key_expr());
            }
            Err(e) => err.push(decode(&e.payload().to_bytes(), "error reply").unwrap()),
        }
    }
    (ok, err)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_wildcard_read_answers_once_per_robot_and_device() {
    let f = fleet().await;
    let s = NetOptions::loopback_client(f.port).open().await.unwrap();

    let (poses, errs) = sweep(&s, "rome/robot/*/base/pose", None).await;
    assert!(errs.is_empty(), "{errs:?}");
    let keys: Vec<&str> = poses.keys().map(String::as_str).collect();
    assert_eq!(
        keys,
        [
            "rome/robot/r1/base/pose",
            "rome/robot/r2/base/pose",
            "rome/robot/r3/base/pose"
        ]
    );
    // Each reply is that robot's own pose, not one robot's three times.
    let xs: std::collections::HashSet<i32> = poses
        .values()
        .map(|b| decode::<PoseReply>(b, "pose").unwrap().x_mm)
        .collect();
    assert_eq!(xs.len(), 3, "three robots at three places: {xs:?}");

    let (scans, errs) = sweep(&s, "rome/robot/*/proximity/sonar", None).await;
    assert!(errs.is_empty(), "{errs:?}");
    assert_eq!(scans.len(), 3);
    for b in scans.values() {
        assert_eq!(decode::<SonarReply>(b, "sonar").unwrap().sonar_mm.len(), 24);
    }
    let (sizes, errs) = sweep(&s, "rome/robot/*/camera/*/size", None).await;
    assert!(errs.is_empty(), "{errs:?}");
    assert_eq!(sizes.len(), 6, "{:?}", sizes.keys());

    // Everything of one robot: every read and every JSON stream, no
    // command that acts, no image, no error. A stream is answered from
    // its last publication: wait until each has published once.
    for stream in ["base/state", "proximity/scan", "camera/up/frame"] {
        let sub = s
            .declare_subscriber(format!("rome/robot/r2/{stream}"))
            .await
            .unwrap();
        tokio::time::timeout(Duration::from_secs(10), sub.recv_async())
            .await
            .unwrap_or_else(|_| panic!("r2 never published {stream}"))
            .unwrap();
    }
    let (all, errs) = sweep(&s, "rome/robot/r2/**", None).await;
    assert!(errs.is_empty(), "{errs:?}");
    let chunks: Vec<String> = all
        .keys()
        .map(|k| k.trim_start_matches("rome/robot/r2/").to_string())
        .collect();
    for want in [
        "base/pose",
        "base/speed",
        "base/wheel-speed",
        "base/mode",
        "base/bumper",
        "base/state",
        "proximity/sonar",
        "proximity/ir",
        "proximity/scan",
        "camera/up/size",
        "camera/side/size",
        "camera/up/frame",
    ] {
        assert!(
            chunks.iter().any(|c| c == want),
            "{want} missing: {chunks:?}"
        );
    }
    for never in ["stop", "move", "go", "lock", "timeout", "grab", "rows"] {
        assert!(
            !chunks.iter().any(|c| c.ends_with(never)),
            "{never} answered to a sweep: {chunks:?}"
        );
    }
    let state: BaseState = decode(&all["rome/robot/r2/base/state"], "state").unwrap();
    assert_eq!(state.robot, "r2");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_wildcard_read_is_not_kept_waiting_by_a_lock() {
    let f = fleet().await;
    let holder_session = NetOptions::loopback_client(f.port).open().await.unwrap();
    let holder = RobotClient::connect(&holder_session, "r2", RobotOptions::new("holder"))
        .await
        .unwrap();
    let grant = holder.lock().await.unwrap();
    let s = NetOptions::loopback_client(f.port).open().await.unwrap();
    let (poses, errs) = sweep(&s, "rome/robot/*/base/pose", None).await;
    assert!(errs.is_empty(), "{errs:?}");
    assert!(
        poses.contains_key("rome/robot/r2/base/pose"),
        "the locked robot's pose: {:?}",
        poses.keys()
    );
    assert_eq!(poses.len(), 3);
    // The lock is untouched by the sweep: the holder still holds it.
    assert_eq!(holder.lock().await.unwrap().fence(), grant.fence());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_wildcard_command_that_acts_is_refused_with_a_reason_and_moves_nothing() {
    let f = fleet().await;
    let s = NetOptions::loopback_client(f.port).open().await.unwrap();
    let (modes, _) = sweep(&s, "rome/robot/*/base/mode", None).await;
    assert_eq!(modes.len(), 3);
    let (ok, errs) = sweep(&s, "rome/robot/*/base/go", Some(r#"{"velocity_mm_s":400}"#)).await;
    assert!(ok.is_empty(), "{:?}", ok.keys());
    assert_eq!(errs.len(), 3, "one refusal per robot: {errs:?}");
    for e in &errs {
        assert_eq!(e.code, ErrorCode::Wildcard);
        assert!(e.message.contains("'go'"), "{}", e.message);
        assert!(e.message.contains("rome/robot/r"), "{}", e.message);
    }
    let (_, errs) = sweep(&s, "rome/robot/r1/camera/*/grab", None).await;
    assert_eq!(errs.len(), 2, "{errs:?}");
    assert!(errs.iter().all(|e| e.code == ErrorCode::Wildcard));
    let (_, errs) = sweep(&s, "rome/robot/**/lock", None).await;
    assert_eq!(errs.len(), 9, "base and cameras of three robots: {errs:?}");
    // A command no device has is named as such, by every device asked.
    let (_, errs) = sweep(&s, "rome/robot/*/base/fly", None).await;
    assert_eq!(errs.len(), 3, "{errs:?}");
    assert!(errs
        .iter()
        .all(|e| e.code == ErrorCode::UnknownKey && e.message.contains("'fly'")));
    // A sweep over every device for a read only some have is answered by
    // those, and the others keep quiet.
    let (poses, errs) = sweep(&s, "rome/**/pose", None).await;
    assert!(errs.is_empty(), "{errs:?}");
    assert_eq!(poses.len(), 3);

    // Nothing moved: a `go` carried out would have the wheels turning
    // within a few steps; give it that long, then every robot still stands
    // in the mode it was in.
    tokio::time::sleep(Duration::from_millis(300)).await;
    let (speeds, _) = sweep(&s, "rome/robot/*/base/wheel-speed", None).await;
    assert_eq!(speeds.len(), 3);
    for (k, b) in &speeds {
        let v = decode::<WheelSpeedReply>(b, "wheel speed")
            .unwrap()
            .wheel_speed_mm_s;
        assert_eq!(v, 0.0, "{k} moves at {v} mm/s");
    }
    assert_eq!(sweep(&s, "rome/robot/*/base/mode", None).await.0, modes);
}
