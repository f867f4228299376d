//! A wireless dropout between a client and its servers, played by a relay
//! the test pauses: a 1 s silence keeps the client's base lock (same
//! fence, its commands still obeyed) and its place in a semaphore queue; a
//! 10 s silence gives both back, the lock within the promised 3 s and the
//! place once the link's lease (5 s) ends.

#![allow(clippy::unwrap_used)]

use rome_client::net::open_loopback_peer;
use rome_client::{DataClient, DataOptions, RobotClient, RobotOptions};
use rome_hardware::robot::{Rates, Running};
use rome_schema::Root;
use rome_sim_hardware::robot::spawn_sim_robot;
use rome_sim_hardware::world::Stepper;
use rome_tests::relay::Relay;
use std::time::{Duration, Instant};
use zenoh::Session;

/// Robot r1 and a data server in one session on a loopback port, and a
/// client session reaching them only through a relay.
struct Link {
    near: Session,
    far: Session,
    relay: Relay,
    _servers: Vec<Running>,
    _data: rome_data::Running,
    _stepper: Stepper,
}

async fn link() -> Link {
    let (near, port) = open_loopback_peer(&[]).await.unwrap();
    let world = rome_tests::world("fig5_3", rome_tests::quiet(), &[("r1", "301L")]);
    let stepper = world.start(Some(1.0));
    let rates = Rates {
        state: Some(Duration::from_millis(50)),
        ..Rates::default()
    };
    let servers = spawn_sim_robot(&near, &Root::default(), &world, "r1", rates).unwrap();
    let data = rome_data::spawn(near.clone(), rome_data::ServerConfig::default());
    let (relay, far) = rome_tests::far_session(port, Duration::from_millis(20)).await;
    Link {
        near,
        far,
        relay,
        _servers: servers,
        _data: data,
        _stepper: stepper,
    }
}

/// The far client holding r1's base lock and queued on semaphore `gate`,
/// with a data client on the near side to watch and signal it.
struct Holder {
    robot: RobotClient,
    lock: rome_client::robot::Lock,
    waiter: tokio::task::JoinHandle<Result<(), rome_client::ClientError>>,
}

async fn hold(l: &Link) -> (DataClient, Holder) {
    let near_data = DataClient::connect(&l.near, DataOptions::new("near"))
        .await
        .unwrap();
    rome_client::alive::await_server(
        &l.far,
        &Root::default(),
        "robot",
        "r1/base",
        Duration::from_secs(30),
    )
    .await
    .unwrap();
    let robot = RobotClient::connect(&l.far, "r1", RobotOptions::new("far"))
        .await
        .unwrap();
    let lock = robot.lock().await.unwrap();
    near_data.create_semaphore("gate", 0).await.unwrap();
    let far_data = DataClient::connect(&l.far, DataOptions::new("far"))
        .await
        .unwrap();
    let waiter = tokio::spawn(async move { far_data.wait("gate").await });
    rome_tests::eventually(Duration::from_secs(10), "the far waiter queued", || {
        let d = near_data.clone();
        async move { d.semaphore("gate").await.is_ok_and(|s| s.waiters == 1) }
    })
    .await;
    (
        near_data,
        Holder {
            robot,
            lock,
            waiter,
        },
    )
}

/// The lock holder's fence as the base's state stream shows it now.
async fn lock_shown(near: &Session) -> Option<u64> {
    let watcher = RobotClient::connect(near, "r1", RobotOptions::new("near"))
        .await
        .unwrap();
    let states = watcher.state().await.unwrap();
    let s = states.next().await.unwrap().unwrap();
    s.lock.map(|l| l.fence)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_one_second_dropout_keeps_the_lock_and_the_place_in_the_queue() {
    let l = link().await;
    let (near_data, h) = hold(&l).await;
    let fence = h.lock.fence();

    l.relay.pause();
    // The silence itself (its length is the point of the test).
    tokio::time::sleep(Duration::from_secs(1)).await;
    l.relay.resume();

    // The holder's commands are still obeyed, under the same fence …
    h.robot.go(0.0).await.unwrap();
    assert_eq!(lock_shown(&l.near).await, Some(fence));
    assert!(h.lock.held());
    // … and the waiter kept its place: a signal now is its unit.
    assert_eq!(near_data.semaphore("gate").await.unwrap().waiters, 1);
    near_data.signal("gate").await.unwrap();
    tokio::time::timeout(Duration::from_secs(10), h.waiter)
        .await
        .expect("the waiter lost its place in the dropout")
        .unwrap()
        .unwrap();
    assert_eq!(near_data.semaphore("gate").await.unwrap().value, 0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_ten_second_dropout_gives_the_lock_and_the_place_back() {
    let l = link().await;
    let (near_data, h) = hold(&l).await;
    let fence = h.lock.fence();
    assert_eq!(lock_shown(&l.near).await, Some(fence));

    let cut = Instant::now();
    l.relay.pause();
    rome_tests::eventually(Duration::from_secs(4), "the lock given back", || {
        let near = l.near.clone();
        async move { lock_shown(&near).await.is_none() }
    })
    .await;
    let lock_back = cut.elapsed();
    assert!(lock_back < Duration::from_secs(3), "{lock_back:?}");
    rome_tests::eventually(Duration::from_secs(9), "the place given back", || {
        let d = near_data.clone();
        async move { d.semaphore("gate").await.is_ok_and(|s| s.waiters == 0) }
    })
    .await;
    let place_back = cut.elapsed();
    assert!(place_back < Duration::from_secs(9), "{place_back:?}");
    eprintln!("lock back after {lock_back:?}, place after {place_back:?}");
    // Someone else is served meanwhile.
    let other = RobotClient::connect(&l.near, "r1", RobotOptions::new("other"))
        .await
        .unwrap();
    let theirs = other.lock().await.unwrap();
    assert!(theirs.fence() > fence);
    tokio::time::sleep_until((cut + Duration::from_secs(10)).into()).await;
    l.relay.resume();
    theirs.unlock().await.unwrap();
    h.waiter.abort();
}
