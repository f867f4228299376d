//! Wildcard reads in a lock-step run, where the data server and its
//! clients are participants of one process: one participant runs at a
//! time, so a server handing over its replies must never wait for the
//! reader to make room (`rome fleet --tasks 300` stood still at time 0 when
//! the dispatcher listed more tasks than a reply channel held).

#![allow(clippy::unwrap_used)]

use rome_client::net::open_loopback_peer;
use rome_client::{DataClient, DataOptions};
use rome_clock::LockStep;
use std::time::Duration;

/// More values than Zenoh's default reply channel (256) holds.
const MANY: usize = 300;

/// Steps the clock by 10 ms whenever everyone has settled.
async fn stepper(clock: LockStep) {
    loop {
        clock.settled().await;
        let next = clock.now_ms() + 10;
        clock.try_advance(|| next).await;
        tokio::task::yield_now().await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_wildcard_read_of_hundreds_of_values_completes_in_lock_step() {
    let (session, _port) = open_loopback_peer(&[]).await.unwrap();
    let clock = LockStep::new(0);
    let read = clock.participate("reader", async move {
        let _server = rome_data::spawn(session.clone(), rome_data::ServerConfig::default());
        let ds = DataClient::connect(&session, DataOptions::new("reader"))
            .await
            .unwrap();
        for i in 0..MANY {
            ds.set(&format!("many/v{i:03}"), &i).await.unwrap();
        }
        let values = ds.values_matching("many/*").await.unwrap();
        let histories = ds.list().await.unwrap();
        (values, histories)
    });
    let stepping = tokio::spawn(stepper(clock.clone()));
    // A guard against a hang, not a measure of speed: the read takes well
    // under a second.
    let (values, histories) = tokio::time::timeout(Duration::from_secs(120), read)
        .await
        .unwrap_or_else(|_| panic!("the read never completed: {}", clock.describe()));
    stepping.abort();
    assert_eq!(values.len(), MANY);
    assert_eq!(values["many/v299"], serde_json::json!(299));
    assert_eq!(
        histories
            .iter()
            .filter(|h| h.name.starts_with("many/"))
            .count(),
        MANY
    );
}
