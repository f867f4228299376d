//! A flood of requests never stalls a server: its Zenoh callbacks do not
//! wait on a full queue, so clients in the server's own session (as in
//! `rome demo`, where every robot's clients and servers share one) cannot
//! deadlock it, and what does not fit is answered `busy` and sent again.
//!
//! A deadlocked runtime cannot time itself out, so each test runs on a
//! runtime of its own in another thread, watched from the test's thread.

#![allow(clippy::unwrap_used)]

use rome_client::net::open_loopback_peer;
use rome_client::{ClientError, DataClient, DataOptions, RobotClient, RobotOptions};
use rome_hardware::robot::Rates;
use rome_schema::{ErrorCode, Root};
use rome_sim::{Sim, SimConfig};
use rome_sim_hardware::robot::spawn_sim_robot;
use rome_sim_hardware::world::SimWorld;
use std::future::Future;
use std::time::Duration;

/// Runs `body` on a two-worker runtime in its own thread; fails if it has
/// not finished within `within` (a stalled server).
fn watched<F: Future<Output = ()> + Send + 'static>(within: Duration, body: F) {
    let (done, finished) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(body);
        let _ = done.send(());
    });
    match finished.recv_timeout(within) {
        Ok(()) => {}
        Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
            panic!("stalled: not done within {within:?}")
        }
        // The body panicked; its message is on stderr.
        Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => panic!("the test body failed"),
    }
}

#[test]
fn clients_joining_the_data_servers_own_session_and_flooding_it_all_get_through() {
    watched(Duration::from_secs(120), async {
        let (session, _port) = open_loopback_peer(&[]).await.unwrap();
        let server = rome_data::spawn(session.clone(), rome_data::ServerConfig::default());
        let zid = session.zid().to_string();
        rome_client::alive::await_server(
            &session,
            &Root::default(),
            "data",
            &zid,
            Duration::from_secs(10),
        )
        .await
        .unwrap();
        // Hundreds of clients joining at once (each with its liveliness
        // token) and each sending a burst, as a fleet's navigation clients
        // do when a run starts: far more than the server's queue holds.
        let n = 3 * rome_data::server::EVENT_QUEUE;
        let tasks: Vec<_> = (0..n / 4)
            .map(|c| {
                let session = session.clone();
                tokio::spawn(async move {
                    let ds = DataClient::connect(&session, DataOptions::new("flood")).await?;
                    for i in 0..4 {
                        let k = c * 4 + i;
                        ds.create_semaphore(&format!("s{k}"), 0).await?;
                        ds.set(&format!("v{}", k % 40), &k).await?;
                    }
                    Ok::<_, ClientError>(())
                })
            })
            .collect();
        for t in tasks {
            t.await.unwrap().unwrap();
        }
        let ds = DataClient::connect(&session, DataOptions::new("check"))
            .await
            .unwrap();
        for k in 0..40 {
            let v = ds.get(&format!("v{k}")).await.unwrap().as_u64().unwrap() as usize;
            assert_eq!(v % 40, k, "v{k} holds {v}");
        }
        for k in [0, n - 1] {
            assert_eq!(ds.semaphore(&format!("s{k}")).await.unwrap().value, 0);
        }
        server.stop().await.unwrap();
    });
}

#[test]
fn a_flood_on_a_robots_servers_from_their_own_session_is_answered() {
    watched(Duration::from_secs(120), async {
        let (session, _port) = open_loopback_peer(&[]).await.unwrap();
        let map = rome_maps::load_named("fig5_3").unwrap();
        let mut sim = Sim::new(&map, SimConfig::default());
        sim.add_robot_at("r1", "301L", 0.0).unwrap();
        let world = SimWorld::new(sim);
        let _stepper = world.start(Some(1.0));
        let rates = Rates {
            state: Some(Duration::from_millis(100)),
            scan: Some(Duration::from_millis(50)),
            camera: Duration::from_millis(500),
        };
        let servers = spawn_sim_robot(&session, &Root::default(), &world, "r1", rates).unwrap();
        rome_client::alive::await_server(
            &session,
            &Root::default(),
            "robot",
            "r1/base",
            Duration::from_secs(10),
        )
        .await
        .unwrap();
        let n = 3 * rome_hardware::server::EVENT_QUEUE;
        let tasks: Vec<_> = (0..n / 4)
            .map(|_| {
                let session = session.clone();
                tokio::spawn(async move {
                    let r = RobotClient::connect(&session, "r1", RobotOptions::new("flood"))
                        .await
                        .unwrap();
                    let mut out = Vec::new();
                    for _ in 0..4 {
                        out.push(r.pose().await.map(|_| ()));
                    }
                    out
                })
            })
            .collect();
        let (mut ok, mut busy) = (0, 0);
        for t in tasks {
            for r in t.await.unwrap() {
                match r {
                    Ok(()) => ok += 1,
                    Err(ClientError::Server(e)) if e.code == ErrorCode::Busy => busy += 1,
                    Err(e) => panic!("neither a pose nor busy: {e}"),
                }
            }
        }
        assert_eq!(ok + busy, n);
        assert!(
            ok >= rome_hardware::server::EVENT_QUEUE,
            "{ok} answered, {busy} busy"
        );
        // And it still serves.
        let r = RobotClient::connect(&session, "r1", RobotOptions::new("after"))
            .await
            .unwrap();
        r.pose().await.unwrap();
        for s in servers {
            s.stop().await.unwrap();
        }
    });
}
